"""The C hydrodynamic step (`hydro_kernel.c`), built on first use with the machine's C compiler.

Why: the hydrodynamics run between MuJoCo's `mj_step1` and `mj_step2` on every physics step. From Python
that costs three calls into MuJoCo plus the force code per step, about twice a plain `mj_step`; the C loop
makes one call per `AUVPhysics.step(n)` (issue 18 asks for at most 2x). It computes the same floating-point
values as the Python loop of `Hydrodynamics.bind`, which stays the reference and the fallback.

The library is compiled once per source, compiler and machine into a cache folder (`AUV_MJ_CACHE`, else
`$XDG_CACHE_HOME/auv-mj`, else `~/.cache/auv-mj`), written under a temporary name and renamed, so that
processes started together (test workers, Ray workers, collectors) never load a half-written file. It
needs no MuJoCo header: MuJoCo's functions are looked up in the `libmujoco` that the `mujoco` package
loaded. With no C compiler (`CC`, else `cc`), or with `AUV_MJ_NATIVE=0`, `kernel()` returns None and the
Python loop runs: same results, slower (one warning says so, unless `AUV_MJ_NATIVE=0` asked for it).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
import warnings
from functools import cache
from pathlib import Path

import mujoco

SOURCE = Path(__file__).with_name("hydro_kernel.c")
FLAGS = ("-O2", "-shared", "-fPIC", "-ffp-contract=off", "-fno-builtin-sin", "-fno-builtin-cos")
"""No fused multiply-adds and libm's own sin and cos, as CPython's math module calls them: the C loop then
rounds exactly as the Python loop does."""
MUJOCO_FUNCTIONS = ("mj_factorM", "mj_step1", "mj_step2")


class NativeKernel:
    """The loaded C step: `advance` (ctypes function) and MuJoCo's functions it calls, as addresses."""

    def __init__(self, library: ctypes.CDLL, mujoco_library: ctypes.CDLL):
        self.advance = library.auv_hydro_advance
        self.advance.restype = None
        self.sizes = (library.auv_kernel_sizes(0), library.auv_kernel_sizes(1))
        self.functions = tuple(ctypes.cast(getattr(mujoco_library, name), ctypes.c_void_p)
                               for name in MUJOCO_FUNCTIONS)


def enabled() -> bool:
    """False when the environment variable AUV_MJ_NATIVE is "0" (the Python loop is asked for)."""
    return os.environ.get("AUV_MJ_NATIVE", "1").strip() != "0"


def cache_dir() -> Path:
    """Where the compiled library is kept."""
    if os.environ.get("AUV_MJ_CACHE"):
        return Path(os.environ["AUV_MJ_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "auv-mj"


def mujoco_library_path() -> Path:
    """The libmujoco shared library that the `mujoco` package loaded."""
    folder = Path(mujoco.__file__).parent
    found = sorted(folder.glob("libmujoco.so*")) + sorted(folder.glob("libmujoco*.dylib"))
    if not found:
        raise OSError(f"no libmujoco shared library in {folder}")
    return found[0]


def build(compiler: str, target: Path, source: Path = SOURCE, flags: tuple[str, ...] = FLAGS,
          libraries: tuple[str, ...] = ()) -> None:
    """Compiles `source` into the shared library `target`, atomically (a temporary name, then a rename);
    `libraries` are linker arguments put after the source."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, temporary = tempfile.mkstemp(suffix=".so", dir=target.parent)
    os.close(fd)
    try:
        result = subprocess.run([compiler, *flags, "-o", temporary, str(source), "-lm", *libraries],
                                capture_output=True, text=True, timeout=120)
        if result.returncode != 0:
            raise OSError(f"{compiler} failed on {source.name}: {result.stderr.strip()[:500]}")
        os.replace(temporary, target)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def compiled(source: Path = SOURCE, flags: tuple[str, ...] = FLAGS, depends: tuple[Path, ...] = (),
             libraries: tuple[str, ...] = ()) -> Path:
    """The shared library of the C file `source` in the cache, built first if it is not there; it is keyed by the
    source and the files it includes (`depends`), the compiler, the flags, the `libraries` and the platform.
    OSError when there is no compiler or the build fails."""
    compiler = shutil.which(os.environ.get("CC", "cc"))
    if compiler is None:
        raise OSError(f"no C compiler found ({os.environ.get('CC', 'cc')!r}; set CC)")
    texts = b"".join(path.read_bytes() for path in (source, *depends))
    key = hashlib.sha256(texts + "\0".join((compiler, *flags, *libraries, platform.machine(),
                                             platform.system())).encode()).hexdigest()[:16]
    target = cache_dir() / f"{source.stem}-{key}.so"
    if not target.exists():
        build(compiler, target, source, flags, libraries)
    return target


@cache
def kernel() -> NativeKernel | None:
    """The C step, compiled if needed; None (with one warning) when it cannot be built or loaded."""
    if not enabled():
        return None
    try:
        return NativeKernel(ctypes.CDLL(str(compiled())), ctypes.CDLL(str(mujoco_library_path())))
    except (OSError, subprocess.SubprocessError, AttributeError) as e:
        warnings.warn(f"auv-mj: the C hydrodynamic step is unavailable ({e}); the Python step runs instead "
                      "(same results, about 1.5x slower). Set AUV_MJ_NATIVE=0 to choose it quietly.",
                      RuntimeWarning, stacklevel=2)
        return None
