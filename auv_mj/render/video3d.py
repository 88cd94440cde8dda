"""Videos of 6-DOF episodes (issue 32): a chase camera beside a top-down and a side (depth) view.

All three are drawn by MuJoCo's own renderer (`mujoco.Renderer`, off-screen through `auv_mj.render.glbackend`):
the chase view is the vehicle MJCF's tracking camera `chase` (behind and above the hull), the top-down view
looks straight down on the vehicle from TOP_DISTANCE, the side view looks at it level from its port side at
SIDE_DISTANCE, so that climbs and dives read as they are. The frames are written by `video.write_video`.

Python API: `iter_frames_3d(env, policy)` (one frame per control step, through the episode loop of
`auv_mj.episode.EpisodeRecorder`, gathering a `Track3D` if asked), `render_episode_3d(env, policy)`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import mujoco
import numpy as np

from auv_mj.episode import EpisodeRecorder
from auv_mj.render import glbackend  # noqa: F401  (picks the OpenGL backend before a context is made)

CHASE_CAMERA = "chase"
TOP_DISTANCE = 40.0
"""Height of the top-down view's camera above the vehicle [m]."""
SIDE_DISTANCE = 30.0
"""Distance of the side view's camera from the vehicle [m]."""
MESH_SLICES, MESH_STACKS = 10, 4
"""Capsule tessellation of the views (MuJoCo's defaults are 28 and 16)."""
PANEL_SIZE = (320, 240)
"""(width, height) of each of the three panels [pixels]."""


def _free_camera(lookat: np.ndarray, distance: float, azimuth: float, elevation: float) -> mujoco.MjvCamera:
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = lookat
    camera.distance, camera.azimuth, camera.elevation = distance, azimuth, elevation
    return camera


def frame(renderer: mujoco.Renderer, physics) -> np.ndarray:
    """(H, 3 W, 3) uint8: chase | top-down | side of the physics' current state."""
    data = physics.data.ptr
    position = physics.position()
    heading = math.degrees(physics.heading())
    panels = []
    for camera in (CHASE_CAMERA,
                   _free_camera(position, TOP_DISTANCE, heading, -90.0),
                   _free_camera(position, SIDE_DISTANCE, heading - 90.0, 0.0)):
        renderer.update_scene(data, camera=camera)
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
            renderer.scene.flags[flag] = False  # a CPU rasteriser pays for each pass
        panels.append(renderer.render())
    return np.concatenate(panels, axis=1)


def _light_meshes(model: mujoco.MjModel) -> None:
    """Fewer slices and stacks per capsule: a tube holds hundreds of them, and the renderer is often a CPU one."""
    model.vis.quality.numslices = MESH_SLICES
    model.vis.quality.numstacks = MESH_STACKS


@dataclass
class Track3D:
    """The 3-D track of an episode, gathered beside its EpisodeRecord: world positions and attitudes."""

    time: list = field(default_factory=list)
    position: list = field(default_factory=list)
    """[m], world, z up."""
    attitude: list = field(default_factory=list)
    """(roll, pitch, yaw) [rad]."""
    depth_command: list = field(default_factory=list)
    """The task's depth command [m] where it has one (depth_heading), else NaN."""

    def add(self, env) -> None:
        physics = env.physics
        self.time.append(physics.time())
        self.position.append(physics.position())
        self.attitude.append(physics.attitude())
        self.depth_command.append(float((getattr(env.task, "last_info", {}) or {}).get("depth_command", np.nan)))

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, dtype=float) for k, v in vars(self).items()}


def iter_frames_3d(env, policy: Callable, max_steps: int | None = None, size: tuple[int, int] = PANEL_SIZE,
                   track: Track3D | None = None, recorder: EpisodeRecorder | None = None) -> Iterator[np.ndarray]:
    """Runs one episode of `policy(time_step) -> action` on the auv3d `env` (the episode loop of
    `auv_mj.episode.EpisodeRecorder`, `recorder` if given), yielding a frame per control step; `track` (if
    given) gathers the 3-D track."""
    width, height = size
    physics = env.physics
    recorder = recorder or EpisodeRecorder(env)
    renderer = None
    try:
        for _ in recorder.run(policy, max_steps):
            if renderer is None or renderer.model is not physics.model.ptr:  # a task that reloads its arena
                if renderer is not None:
                    renderer.close()
                _light_meshes(physics.model.ptr)
                renderer = mujoco.Renderer(physics.model.ptr, height=height, width=width)
            if track is not None:
                track.add(env)
            yield frame(renderer, physics)
    finally:
        if renderer is not None:
            renderer.close()


def render_episode_3d(env, policy: Callable, **kwargs) -> np.ndarray:
    """(T, H, 3 W, 3) uint8 frames of one episode (`iter_frames_3d`)."""
    return np.stack(list(iter_frames_3d(env, policy, **kwargs)))
