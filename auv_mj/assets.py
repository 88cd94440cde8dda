"""Where the shipped MJCF files live, for editable installs and built wheels alike."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def models_dir() -> Path:
    """The `models/` folder (installed as the package `auv_mj.models`)."""
    return Path(str(resources.files("auv_mj.models")))


def model_path(name: str) -> Path:
    """Path of a shipped MJCF file, e.g. `model_path("auv.xml")` or `model_path("arenas/tunnel.xml")`."""
    path = models_dir() / name
    if not path.is_file():
        raise FileNotFoundError(f"no shipped model {name!r} in {models_dir()}")
    return path
