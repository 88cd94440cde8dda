"""The C 6-DOF hydrodynamic step (`hydro3d_kernel.c`), built on first use as the planar kernel is (`native`).

The library is compiled once per source, compiler and machine into the planar kernel's cache folder, under a
temporary name and renamed. With no C compiler, or with `AUV_MJ_NATIVE=0`, `kernel()` returns None and the
Python loop of `Hydro3D.bind` runs (same physics, slower).
"""

from __future__ import annotations

import ctypes
import subprocess
import warnings
from functools import cache
from pathlib import Path

from auv_mj.sim import native

SOURCE = Path(__file__).with_name("hydro3d_kernel.c")
FLAGS = ("-O2", "-shared", "-fPIC")
COEFFICIENTS = ("X_uu", "Y_vv", "Y_rr", "Z_ww", "Z_qq", "K_pp", "M_ww", "M_qq", "N_vv", "N_rr", "Y_uv", "Y_ur",
                "Z_uw", "Z_uq", "M_uw", "M_uq", "N_uv", "N_ur", "Y_uudr", "N_uudr", "Z_uuds", "M_uuds", "B")
"""The coefficients the C step reads after the two added-mass matrices, in the order of its enum."""


class Kernel3D:
    """The loaded C step `advance` and MuJoCo's functions it calls."""

    def __init__(self, library: ctypes.CDLL, mujoco_library: ctypes.CDLL):
        self.advance = library.auv3d_hydro_advance
        self.advance.restype = None
        self.sizes = (library.auv3d_kernel_sizes(0), library.auv3d_kernel_sizes(1))
        self.functions = tuple(ctypes.cast(getattr(mujoco_library, name), ctypes.c_void_p)
                               for name in native.MUJOCO_FUNCTIONS)


@cache
def kernel() -> Kernel3D | None:
    """The C step, compiled if needed; None (with one warning) when it cannot be built or loaded."""
    if not native.enabled():
        return None
    try:
        library = native.compiled(SOURCE, FLAGS)
        return Kernel3D(ctypes.CDLL(str(library)), ctypes.CDLL(str(native.mujoco_library_path())))
    except (OSError, subprocess.SubprocessError, AttributeError) as e:
        warnings.warn(f"auv-mj: the C 6-DOF step is unavailable ({e}); the Python step runs instead. Set "
                      "AUV_MJ_NATIVE=0 to choose it quietly.", RuntimeWarning, stacklevel=2)
        return None
