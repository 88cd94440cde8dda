"""Videos of 6-DOF episodes: the frames of one episode run by a policy, in time, streamed to a file or an array.

`auv-mj render --task tunnel3d --policy los-avoid -o tube.mp4` runs one episode and writes it (the domain record's
`video`, `video_frames_3d`). This module holds what turns an episode into frames: its view of the episode
(`iter_frames_3d` over the planar videos' `stream_frames`), the interpolation between recorded states
(`interpolate`), the progress a frame shows, the Gymnasium face's live frame (`LiveView3D`) and
`render_episode_3d`; the 3-D track gathered beside the frames (`auv_mj.episode.Track3D`, the `track` of
`iter_frames_3d`) is what `auv_mj.figures.trajectory3d` plots. The frame is drawn by
`auv_mj.render.frame3d.FrameRenderer3D`.

Timing as the planar videos (`auv_mj.render.episode_video`): a frame every `speedup / fps` simulation seconds, one
per control step by default (15x real time for the 0.5 s planner at DEFAULT_FPS); a smaller `speedup` interpolates
the states recorded at the control steps (positions linearly, the attitude by normalised linear interpolation of the
quaternion, movers linearly; the sonar held, as the 2 Hz sonar holds it). The environment is stepped exactly as in
evaluation, through the one episode loop (`auv_mj.episode.EpisodeRecorder`).

Python API: `iter_frames_3d(env, policy, ...)` (streaming) and `render_episode_3d(env, policy, path)` (streamed to
the file; `in_memory=True` for the (T, H, W, 3) array).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from auv_mj.episode import EpisodeRecorder, Track3D
from auv_mj.geometry import distance_along, polyline_length
from auv_mj.render.episode_video import (
    DEFAULT_HOLD_END,
    TIME_TOLERANCE,
    VideoOptions,
    episode_output,
    frame_bound,
    stream_frames,
)
from auv_mj.render.frame import DEFAULT_SIZE
from auv_mj.render.frame3d import FrameRenderer3D, State3D
from auv_mj.render.writers import DEFAULT_FPS
from auv_mj.sim.sensors3d import altimeter


def interpolate(a: State3D, b: State3D, time: float) -> State3D:
    """The state at `time` in [a.time, b.time]: positions, velocities and movers linear, the quaternions by
    normalised linear interpolation, the sonar and the event held from `a` (the sonar samples at 2 Hz)."""
    span = b.time - a.time
    if span <= 0.0 or time >= b.time - TIME_TOLERANCE:  # physics time drifts by ulps from the frame clock
        return b
    s = float(np.clip((time - a.time) / span, 0.0, 1.0))

    def mix(x, y):
        return x + s * (y - x)

    return State3D(time, mix(a.qpos, b.qpos), mix(a.mocap_pos, b.mocap_pos), a.sonar, mix(a.velocity, b.velocity),
                   mix(a.altitude, b.altitude), mix(a.goal_distance, b.goal_distance), mix(a.progress, b.progress))


def _progress_of(env, start_distance: float, time_limit: float) -> tuple[float, float]:
    """(distance to the goal [m] or NaN, share of the episode done): distance made good towards the goal on
    planning tasks (along the tube on tunnel3d), the time on tracking ones."""
    physics, task = env.physics, env.task
    goal = getattr(task, "goal", None)
    path = getattr(task, "path", None)
    position = physics.position()
    if path is not None and len(path) >= 2:
        along = distance_along(path, position)
        return float(np.linalg.norm(goal - position)), along / max(polyline_length(path), 1e-9)
    if goal is not None and math.isfinite(start_distance) and start_distance > 0:
        distance = float(np.linalg.norm(goal - position))
        return distance, float(np.clip(1.0 - distance / start_distance, 0.0, 1.0))
    return math.nan, float(np.clip(physics.time() / time_limit, 0.0, 1.0)) if time_limit > 0 else 0.0


def _route_length(env, start_distance: float) -> float | None:
    """The length [m] of the route `_progress_of` measures along: the tube's path, else the start's distance to the
    goal; None on a task without a goal (depth_heading)."""
    path = getattr(env.task, "path", None)
    if path is not None and len(path) >= 2:
        return polyline_length(path)
    return start_distance if math.isfinite(start_distance) and start_distance > 0 else None


def _time_limit(env) -> float:
    """The episode's time limit [s] (0 where it has none): the share of it gone is a tracking task's progress."""
    limit = getattr(env, "_step_limit", None)
    return (limit if limit and math.isfinite(limit) else 0.0) * env.control_timestep()


def _state(env, event: str, start_distance: float, time_limit: float) -> State3D:
    physics = env.physics
    data = physics.data.ptr
    distance, share = _progress_of(env, start_distance, time_limit)
    if event == "goal":
        share = 1.0
    return State3D(float(physics.time()), data.qpos.copy(), data.mocap_pos.copy(), physics.sonar(),
                   physics.body_velocity(), altimeter(physics), distance, share, event)


class LiveView3D:
    """The video's frame of a 6-DOF episode stepped elsewhere: what the Gymnasium face's `render()` returns for the
    auv3d ids (chase, top and side panels, heads-up display, progress bar, event banner). `start` after each reset,
    `add` after each step, `frame()` when a picture is wanted (the renderer is made then, once per episode)."""

    def __init__(self, env, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], title: str = ""):
        self.env, self.size, self.title = env, (width, height), title
        self._recorder = EpisodeRecorder(env)  # the episode loop's read-out of each step, as `iter_frames_3d` has it
        self._renderer: FrameRenderer3D | None = None
        self._event, self._start_distance, self._started = "", math.nan, False
        self._time_limit = _time_limit(env)

    def start(self, time_step) -> None:
        """A new episode from its reset `time_step` (a new arena: a new renderer at the next frame)."""
        self.close()
        self._recorder.start(time_step)
        goal = getattr(self.env.task, "goal", None)
        self._start_distance = (float(np.linalg.norm(goal - self.env.physics.position())) if goal is not None
                                else math.nan)
        self._event, self._started = "", True

    def add(self, time_step, action) -> None:
        """The step that `action` led to: its event, if any, becomes the banner."""
        if not self._started:
            raise RuntimeError("LiveView3D.add before start: call start(time_step) after the reset")
        self._event = self._recorder.add(time_step, action).event
        del self._recorder.snapshots[:-1]  # the frame needs the last instant only

    def frame(self) -> np.ndarray:
        """The (H, W, 3) uint8 frame of the environment's current state."""
        if not self._started:
            raise RuntimeError("no episode to draw yet: call start(time_step) after the reset")
        if self._renderer is None:
            self._renderer = FrameRenderer3D(self.env.physics, *self.size, self.title)
        return self._renderer.render(_state(self.env, self._event, self._start_distance, self._time_limit),
                                     self._event)

    def close(self) -> None:
        """Frees the renderer's OpenGL context (a new one is made by the next frame)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def iter_frames_3d(env, policy: Callable, *, max_steps: int | None = None, width: int = DEFAULT_SIZE[0],
                   height: int = DEFAULT_SIZE[1], fps: float = DEFAULT_FPS, speedup: float | None = None,
                   hold_end: float = DEFAULT_HOLD_END, title: str = "", track: Track3D | None = None,
                   recorder: EpisodeRecorder | None = None, progress: bool = False) -> Iterator[np.ndarray]:
    """Runs one episode of `policy(time_step) -> action` on the auv3d `env`, yielding (H, W, 3) uint8 frames, one
    every `speedup / fps` simulated seconds (default: one per control step); `track` (if given) gathers the 3-D
    track at the control steps, `recorder` keeps the episode's record."""
    time_limit = _time_limit(env)

    def view_of(recorder: EpisodeRecorder, first) -> _View3D:
        return _View3D(env, width, height, title, time_limit)

    yield from stream_frames(env, policy, view_of, max_steps=max_steps, fps=fps, speedup=speedup,
                             hold_end=hold_end, recorder=recorder, progress=progress, track=track)


class _View3D:
    """The 6-DOF video's view of an episode (an `auv_mj.render.episode_video.EpisodeView`): the three-panel frame
    renderer, and the route the progress bar measures along (`_progress_of`)."""

    def __init__(self, env, width: int, height: int, title: str, time_limit: float):
        self.env, self.time_limit = env, time_limit
        self.renderer = FrameRenderer3D(env.physics, width, height, title)
        goal = getattr(env.task, "goal", None)
        self.start_distance = float(np.linalg.norm(goal - env.physics.position())) if goal is not None else math.nan
        self.route = _route_length(env, self.start_distance)
        self.goal_radius = float(getattr(env.task, "goal_radius", 0.0))

    def state(self, snap) -> State3D:
        return _state(self.env, snap.event, self.start_distance, self.time_limit)

    def draw(self, previous: State3D, state: State3D, time: float, banner: str) -> np.ndarray:
        return self.renderer.render(interpolate(previous, state, time), banner)

    def made_good(self, snap, state: State3D) -> float | None:
        return state.progress * self.route if self.route is not None else None

    def close(self) -> None:
        self.renderer.close()


def video_frames_3d(env, policy: Callable, options: VideoOptions, recorder: EpisodeRecorder | None = None,
                    track: Track3D | None = None) -> Iterator[np.ndarray]:
    """The 6-DOF domain's video (`auv_mj.tasks.domains.Domain.video`): `iter_frames_3d` with `options`; the chase,
    top and side panels always show, so `options.camera` and `options.follow_view` (the planar views') do not
    apply."""
    return iter_frames_3d(env, policy, max_steps=options.max_steps, width=options.width, height=options.height,
                          fps=options.fps, speedup=options.speedup, hold_end=options.hold_end, title=options.title,
                          track=track, recorder=recorder, progress=options.progress)


def render_episode_3d(env, policy: Callable, path: str | Path | None = None, *, in_memory: bool = False,
                      max_steps: int | None = None, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                      fps: float = DEFAULT_FPS, speedup: float | None = None, hold_end: float = DEFAULT_HOLD_END,
                      title: str = "", track: Track3D | None = None, recorder: EpisodeRecorder | None = None,
                      progress: bool = False, gif: bool | None = None) -> Path | np.ndarray:
    """One episode of the auv3d `env` streamed to the video file `path` (returned), or with `in_memory=True` the
    whole video as one (T, H, W, 3) uint8 array, width x height x 3 bytes a frame (as `render_episode`); the other
    options are `iter_frames_3d`'."""
    frames = iter_frames_3d(env, policy, max_steps=max_steps, width=width, height=height, fps=fps, speedup=speedup,
                            hold_end=hold_end, title=title, track=track, recorder=recorder, progress=progress)
    bound = frame_bound(env, max_steps, fps, speedup, hold_end)
    return episode_output(frames, path, in_memory, bound, width, height, fps, gif)
