"""Rendering a physics state headless: the OpenGL backend choice (`glbackend`, imported first so MUJOCO_GL is set
before mujoco reads it), numpy drawing (`raster`), one frame (`frame`, `frame3d`), the episode videos
(`episode_video`, `episode_video3d`) and the video files (`writers`).

The planar renderer's public names are re-exported here (`auv_mj.render.render_episode`,
`auv_mj.render.write_video`, ...), loaded on first use so that `import auv_mj` (which imports `glbackend` first)
stays light. How fast the renderer draws is measured in the library (`auv_mj.speed.render`), not here.
"""

from __future__ import annotations

import importlib
from typing import Any

from auv_mj.render import glbackend  # noqa: F401  (first: sets MUJOCO_GL)

PUBLIC = {
    "auv_mj.render.frame": ("DEFAULT_SIZE", "FrameRenderer", "arena_extent", "render_frame"),
    "auv_mj.render.episode_video": ("LiveView", "episode_output", "frame_bound", "interpolate", "iter_frames",
                                    "render_episode"),
    "auv_mj.render.writers": ("DEFAULT_FPS", "ffmpeg_available", "write_video"),
}
"""The module of each public name."""
_HOME = {name: module for module, names in PUBLIC.items() for name in names}

__all__ = sorted(_HOME)


def __getattr__(name: str) -> Any:
    """The renderer's public names, from the module that holds each (`PUBLIC`) on first use (PEP 562)."""
    if name in _HOME:
        return getattr(importlib.import_module(_HOME[name]), name)
    raise AttributeError(f"module 'auv_mj.render' has no attribute {name!r}")
