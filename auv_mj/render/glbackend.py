"""Chooses MuJoCo's OpenGL backend before `mujoco` and `dm_control` are imported (they read it once).

Importing this module (`auv_mj/__init__` does so first) runs `configure()`, which never fails: with
MUJOCO_GL unset it picks EGL, else OSMesa, whichever system library loads; a MUJOCO_GL value that cannot
work (unknown, or its library missing) is replaced by "disable" so that simulation still imports, and
`require()` raises a `RenderingUnavailable` naming the variable, the valid values and the Debian/Ubuntu
packages to install as soon as anything tries to render. This module imports nothing from MuJoCo.
"""

from __future__ import annotations

import ctypes
import os

VARIABLE = "MUJOCO_GL"
HEADLESS = ("egl", "osmesa")
"""Backends that need no display, in order of preference."""
DISABLED = ("disable", "disabled", "off", "false", "0")
DISPLAY_BACKENDS = ("glfw", "on", "enable", "enabled", "true", "1", "")
"""Values that both mujoco and dm_control accept and that open a window system context (need DISPLAY)."""
VALID_VALUES = "egl (headless, GPU or Mesa), osmesa (headless software), glfw (needs a display), disable"
LIBRARIES = {"egl": ("libEGL.so.1", "libEGL.so"),
             "osmesa": ("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so")}
PACKAGES = {"egl": "libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri (or a GPU driver's EGL)",
            "osmesa": "libosmesa6"}
"""Debian/Ubuntu packages providing each headless backend."""

backend: str | None = None
"""The backend chosen by `configure()` (the value MUJOCO_GL now holds)."""
automatic = False
"""True when MUJOCO_GL was unset and `configure()` chose the backend."""
problem: str | None = None
"""Why rendering cannot work in this process, or None."""


class RenderingUnavailable(RuntimeError):
    """No usable OpenGL backend for off-screen rendering; the message says what to set or install."""


def loadable(name: str) -> bool:
    """Whether the system library of headless backend `name` ("egl" or "osmesa") can be loaded."""
    for library in LIBRARIES[name]:
        try:
            ctypes.CDLL(library)
            return True
        except OSError:
            continue
    return False


def install_hint() -> str:
    """One line naming the packages of both headless backends."""
    return (f"install {PACKAGES['egl']} for EGL, or {PACKAGES['osmesa']} for OSMesa "
            "(Debian/Ubuntu package names)")


def configure() -> str:
    """Sets MUJOCO_GL (and records any `problem`) before mujoco is imported; returns the backend."""
    global backend, automatic, problem
    value = os.environ.get(VARIABLE)
    problem = None
    automatic = value is None
    if value is None:
        chosen = next((name for name in HEADLESS if loadable(name)), None)
        if chosen is None:
            problem = f"no headless OpenGL library (libEGL, libOSMesa) could be loaded: {install_hint()}"
        backend = chosen or "disable"
    else:
        value = value.strip().lower()
        if value in HEADLESS and not loadable(value):
            problem = (f"{VARIABLE}={value} but {' / '.join(LIBRARIES[value])} cannot be loaded: install "
                       f"{PACKAGES[value]}, or set {VARIABLE} to another of: {VALID_VALUES}")
            backend = "disable"
        elif value not in HEADLESS + DISABLED + DISPLAY_BACKENDS:
            problem = (f"environment variable {VARIABLE}={os.environ[VARIABLE]!r} is not a valid OpenGL "
                       f"backend; set it to one of: {VALID_VALUES}")
            backend = "disable"
        else:
            backend = value
            if value in DISABLED:
                problem = f"rendering is switched off by {VARIABLE}={os.environ[VARIABLE]!r}"
    os.environ[VARIABLE] = backend
    return backend


def require() -> str:
    """The configured backend; raises RenderingUnavailable when rendering cannot work."""
    if backend is None:
        configure()
    if problem:
        raise RenderingUnavailable(problem)
    return backend


configure()
