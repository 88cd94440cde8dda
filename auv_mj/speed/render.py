"""How fast the planar episode renderer draws (`auv-mj bench --sections render`), beside a bare `mujoco.Renderer`.

Speed, not looks: what a frame shows is `auv_mj.render.frame`. `time_against_bare_renderer` draws the same recorded
states with `FrameRenderer` and with `_BareRenderer` (the model's geoms only, from the same camera: what no
renderer of this scene can beat) and reports both frame rates and their ratio.
The "render" section of `auv-mj bench` times it on the obstacles task under line of sight; `auv-mj render
--bench` prints it alone.
"""

from __future__ import annotations

import copy
import math
import time

import mujoco
import numpy as np

from auv_mj.episode import EpisodeRecorder, Snapshot
from auv_mj.planners.guidance import line_of_sight
from auv_mj.render import glbackend
from auv_mj.render.frame import FOLLOW_VIEW, SAMPLES, FrameRenderer
from auv_mj.speed.sections import BenchSettings, Measurement, section
from auv_mj.tasks import suite


def time_against_bare_renderer(env, policy, sizes: tuple[tuple[int, int], ...] = ((1280, 720), (640, 360)),
                               frames: int = 60, repeats: int = 5) -> dict[str, dict[str, float]]:
    """Frames/s of FrameRenderer (camera "both") vs a bare `mujoco.Renderer` of the same scene and size.

    Both draw the same recorded states of `env` run by `policy` (`auv-mj bench` uses the obstacles task
    with line of sight) from the same orthographic top-down camera with the same multisampling; the bare renderer
    draws the model's geoms only, one view, no decorations or text (the limit). The two take turns, pass by
    pass, `repeats` passes each, and the best pass of each counts: a shared machine's slow spells then fall on
    both alike. Returns {"WxH": {"ours_fps", "bare_fps", "ratio"}}.
    """
    recorder = EpisodeRecorder(env)
    states = list(recorder.run(policy, frames))
    trail = np.array([s.pose[:2] for s in states])
    results = {}
    for width, height in sizes:
        with FrameRenderer(env.physics, width, height, "both", arena=recorder.arena) as renderer, \
                _BareRenderer(env.physics, width, height) as bare:
            out = np.empty((renderer.height, renderer.width, 3), np.uint8)
            renderer.render(states[0], out=out)  # warm-up
            bare.render(states[:1])

            def ours(renderer=renderer, out=out) -> None:
                for i, state in enumerate(states):
                    renderer.render(state, trail[: i + 1], out=out)

            passes = {"ours": ours, "bare": lambda bare=bare: bare.render(states)}
            best = dict.fromkeys(passes, math.inf)
            for _ in range(repeats):
                for name, work in passes.items():
                    start = time.perf_counter()
                    work()
                    best[name] = min(best[name], time.perf_counter() - start)
        ours_fps, bare_fps = len(states) / best["ours"], len(states) / best["bare"]
        results[f"{width}x{height}"] = {"ours_fps": ours_fps, "bare_fps": bare_fps, "ratio": ours_fps / bare_fps}
    return results


class _BareRenderer:
    """A bare `mujoco.Renderer` of the model's geoms from the follow view's camera: the benchmark's limit."""

    def __init__(self, physics, width: int, height: int):
        model = self.model = copy.copy(physics.model.ptr)
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        model.vis.global_.orthographic = 1
        model.vis.global_.fovy = FOLLOW_VIEW
        model.vis.quality.offsamples = SAMPLES
        self.data = mujoco.MjData(model)
        self.camera = mujoco.MjvCamera()
        self.camera.azimuth, self.camera.elevation, self.camera.distance = 90.0, -90.0, 0.5 * model.stat.extent
        self.qpos = [model.joint(n).qposadr[0] for n in ("x", "y", "yaw")]
        self.renderer = mujoco.Renderer(model, height, width)

    def render(self, states: list[Snapshot]) -> None:
        for state in states:
            self.data.qpos[self.qpos] = state.pose
            mujoco.mj_kinematics(self.model, self.data)
            self.camera.lookat[:] = (state.pose[0], state.pose[1], 0.0)
            self.renderer.update_scene(self.data, self.camera)
            self.renderer.render()

    def __enter__(self) -> _BareRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.renderer.close()


@section("render")
def render_section(settings: BenchSettings) -> list[Measurement]:
    """Frames per second of the episode renderer against a bare mujoco.Renderer of the same scene."""
    try:
        glbackend.require()
    except glbackend.RenderingUnavailable as e:
        return [Measurement("rendering unavailable", float("nan"), "", str(e))]
    env = suite.load("auv", "obstacles", task_kwargs={"random": settings.seed})
    measurements = []
    timings = time_against_bare_renderer(env, line_of_sight(env), frames=max(10, settings.calls(60)))
    for size, r in timings.items():
        measurements.append(Measurement(f"render {size} ours", r["ours_fps"], "frames/s"))
        measurements.append(Measurement(f"render {size} bare mujoco.Renderer (limit)", r["bare_fps"], "frames/s"))
        measurements.append(Measurement(f"render {size} ours / bare", r["ratio"], "x"))
    return measurements
