"""Rendering a physics state headless: the OpenGL backend choice (`glbackend`, imported first so MUJOCO_GL is set
before mujoco reads it), numpy drawing (`raster`) and the episode renderer (`video`).

The renderer's public names are re-exported here (`auv_mj.render.render_episode`, `auv_mj.render.write_video`,
...), loaded on first use so that `import auv_mj` (which imports `glbackend` first) stays light.
"""

from __future__ import annotations

import importlib
from typing import Any

from auv_mj.render import glbackend  # noqa: F401  (first: sets MUJOCO_GL)

__all__ = ["DEFAULT_FPS", "DEFAULT_SIZE", "FrameRenderer", "LiveView", "arena_extent", "episode_output",
           "ffmpeg_available", "frame_bound", "interpolate", "iter_frames", "render_episode", "render_frame",
           "time_against_bare_renderer", "write_video"]


def __getattr__(name: str) -> Any:
    """The renderer's public names, from `auv_mj.render.video` on first use (PEP 562)."""
    if name in __all__:
        return getattr(importlib.import_module("auv_mj.render.video"), name)
    raise AttributeError(f"module 'auv_mj.render' has no attribute {name!r}")
