"""The suite's domains, one record each: what the zoo, the benchmark and the CLI read instead of checking flags.

A domain is one vehicle and its tasks (dm_control's suite has a domain per body: "cartpole", "walker"): "auv", the
planar REMUS-100 of the paper (surge, sway, yaw), and "auv3d", the 6-DOF REMUS-100. Its `Domain` names its task
registry, its physics class (a `auv_mj.sim.vehicle_physics.VehiclePhysics`), its vehicle MJCF, its classical
executors and the entry-point group of its executor plugins, its frame renderer, its episode video and its episode
figures (what `auv-mj render` draws, reading the record rather than asking which domain). A new vehicle is a new
record.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from dm_control.utils import containers

from auv_mj.control.depth_heading import OCEAN_DEPTH_GAINS, DepthHeadingController
from auv_mj.control.splane import OCEAN_GAINS, SPlaneController
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.physics3d import AUV3DPhysics
from auv_mj.tasks.registry import DOMAIN_3D, SUITE, SUITE3D


@dataclass(frozen=True)
class Domain:
    """One domain of the suite."""

    name: str
    """Its name in `suite.load(name, task)`."""
    title: str
    """In words: "planar", "6-DOF"."""
    registry: containers.TaggedTasks
    """Its tasks: name -> factory, with tags."""
    physics: type
    """The vehicle's physics class (its tasks' physics derive from it): `isinstance(env.physics, physics)` says an
    environment is of this domain."""
    vehicle: str
    """The vehicle's MJCF in models/ (`auv_mj.assets.model_path`). The 6-DOF vehicle's file keeps its published name,
    `auv6.xml` (users' arenas and tools name it), while the code's 3-D modules all say "3d"."""
    executors: Mapping[str, Callable[[], Any]]
    """The classical executors by name, which the tasks build themselves (the S-planes of Eq. 32)."""
    executor_plugins: str
    """The entry-point group of its other executors (pyproject.toml: the learned ones)."""
    renderer: str
    """"module:class" of its frame renderer in `auv_mj.render` (the core), imported on first use: rendering loads
    OpenGL, which loading a task must not."""
    video: str
    """"module:function" of its episode video in `auv_mj.render`, imported on first use (as `renderer`):
    `frames(env, policy, options: VideoOptions, recorder, track) -> Iterator[frame]`, the frames of one episode
    (`auv_mj.render.episode_video.VideoOptions`)."""
    figures: str | None = None
    """"module:class" of its episode figures in `auv_mj.figures` (`auv-mj render --plots PREFIX`): made with
    (prefix, title), it gathers beside the episode (`add(env)`, a video's `track`) and draws (`write(env)`); None for
    a domain that draws none."""

    def frame_renderer(self) -> type:
        """The domain's frame renderer class."""
        return _load(self.renderer)

    def video_frames(self) -> Callable[..., Any]:
        """The domain's episode video: `frames(env, policy, options, recorder, track)` (`video`)."""
        return _load(self.video)

    def episode_figures(self) -> type | None:
        """The domain's episode figures class (`figures`), None where it has none."""
        return _load(self.figures) if self.figures is not None else None


def _load(reference: str) -> Any:
    """The object a "module:name" reference names, its module imported now."""
    module, _, name = reference.partition(":")
    return getattr(importlib.import_module(module), name)


DOMAINS: dict[str, Domain] = {
    "auv": Domain("auv", "planar", SUITE, AUVPhysics, "auv.xml",
                  {"splane": SPlaneController, "splane-ocean": lambda: SPlaneController(OCEAN_GAINS)},
                  "auv_mj.executors", "auv_mj.render.frame:FrameRenderer", "auv_mj.render.episode_video:video_frames"),
    DOMAIN_3D: Domain(DOMAIN_3D, "6-DOF", SUITE3D, AUV3DPhysics, "auv6.xml",
                         {"splane": DepthHeadingController,
                          "splane-ocean": lambda: DepthHeadingController(OCEAN_DEPTH_GAINS)},
                         "auv_mj.executors_3d", "auv_mj.render.frame3d:FrameRenderer3D",
                         "auv_mj.render.episode_video3d:video_frames_3d", "auv_mj.figures.trajectory3d:TrackFigures"),
}
"""Every domain, by name."""


def of_env(env) -> Domain:
    """The domain of an environment, from its physics; ValueError for an environment of none."""
    for domain in DOMAINS.values():
        if isinstance(getattr(env, "physics", None), domain.physics):
            return domain
    raise ValueError(f"{type(env).__name__} is no environment of auv-mj's domains ({', '.join(DOMAINS)})")
