"""Videos of planar episodes: the frames of one episode run by a policy, in time, streamed to a file or an array.

`auv-mj render --task goal --policy splane -o goal.mp4` runs one episode and writes an H.264 MP4 (GIF with --gif,
or when no ffmpeg is found). This module holds what turns an episode into a sequence of frames: the clock of the
video (`iter_frames`), the interpolation between recorded states (`interpolate`), the trail and the goals a frame
shows, the render's progress bar (`RenderBar`), the Gymnasium face's live frame (`LiveView`) and `render_episode`.
The frame itself is drawn by `auv_mj.render.frame.FrameRenderer`; the files are written by
`auv_mj.render.writers`. The 6-DOF videos (`auv_mj.render.episode_video3d`) share the episode's loop of frames
(`stream_frames`: the one episode loop, the video's clock `VideoClock`, the progress bar, the closing frames, each
domain drawing through its `EpisodeView`), the bounds and the output step, and the options of `auv-mj render`
(`VideoOptions`): each domain's record names its video (`auv_mj.tasks.domains.Domain.video`: `video_frames` here),
so the command draws either without asking which.

Timing: a video frame every `speedup / fps` simulation seconds. By default one frame per control step
(speedup = fps x control period: 15x real time for the 0.5 s planner at 30 fps); a smaller speedup
interpolates the recorded states between control steps (pose, velocity and moving obstacles linearly;
sonar held, as the 2 Hz sonar holds it), a larger one skips states. The environment is always stepped
exactly as in training and evaluation.

Python API: `render_episode(env, policy, "episode.mp4")` (streams to the file; `in_memory=True` instead returns the
(T, H, W, 3) uint8 array, 2.8 MB a 1280 x 720 frame) and `iter_frames(...)` (streaming).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from auv_mj.console import complete, progress_bar
from auv_mj.episode import EpisodeRecorder, Snapshot, StepObserver, outcome, outcome_label
from auv_mj.geometry import distance_along, polyline_length, wrap_angle
from auv_mj.render import glbackend
from auv_mj.render.frame import CAMERAS, DEFAULT_SIZE, FOLLOW_VIEW, FrameRenderer
from auv_mj.render.writers import DEFAULT_FPS, write_video

TRAIL_SPACING = 1 / 500
"""A trail point is kept every this fraction of the view height."""
EVENT_HOLD = 1.5
"""An event (goal, collision) stays on screen for this many seconds of video."""
DEFAULT_HOLD_END = 1.0
"""The last frame is repeated for this many seconds of video."""
TIME_TOLERANCE = 1e-6
"""Frame times within this of a recorded instant [s] show that instant (physics time drifts by ulps)."""


@dataclass(frozen=True)
class VideoOptions:
    """How an episode's video is drawn, in either domain: what `auv-mj render` passes to the domain's video
    (`video_frames`, `auv_mj.render.episode_video3d.video_frames_3d`), each reading the options of its views."""

    max_steps: int | None = None
    """Cut the episode after this many steps (None: to its end)."""
    width: int = DEFAULT_SIZE[0]
    """Frame width [px]."""
    height: int = DEFAULT_SIZE[1]
    """Frame height [px]."""
    fps: float = DEFAULT_FPS
    """Video frames per second."""
    speedup: float | None = None
    """Simulated seconds per video second (None: a frame per control step)."""
    hold_end: float = DEFAULT_HOLD_END
    """Seconds of video the last frame is held."""
    title: str = ""
    """The text the frames carry."""
    progress: bool = False
    """Whether a progress bar shows on the terminal."""
    camera: str = "both"
    """The planar views (one of CAMERAS); the 6-DOF video always shows its three panels."""
    follow_view: float = FOLLOW_VIEW
    """Height [m] of the planar follow view."""


def interpolate(a: Snapshot, b: Snapshot, t: float) -> Snapshot:
    """The state at time t in [a.time, b.time]: pose, velocity and movers linear, sonar held from `a`."""
    span = b.time - a.time
    if t >= b.time - TIME_TOLERANCE or span <= 0:
        return b
    alpha = float(np.clip((t - a.time) / span, 0.0, 1.0))
    pose = a.pose + alpha * (b.pose - a.pose)
    pose[2] = a.pose[2] + alpha * wrap_angle(b.pose[2] - a.pose[2])
    return replace(a, time=t, pose=pose, velocity=a.velocity + alpha * (b.velocity - a.velocity),
                   movers=a.movers + alpha * (b.movers - a.movers))


class _Trail:
    """Positions so far, one kept every `spacing` metres (amortised O(1) appends, no per-frame copies)."""

    def __init__(self, spacing: float):
        self.spacing = spacing
        self._points = np.empty((1024, 2))
        self.count = 0

    def add(self, point: np.ndarray) -> None:
        if self.count and np.hypot(*(point - self._points[self.count - 1])) < self.spacing:
            return
        if self.count == len(self._points):
            self._points = np.concatenate([self._points, np.empty_like(self._points)])
        self._points[self.count] = point
        self.count += 1

    def view(self) -> np.ndarray:
        return self._points[: self.count]


class _Goals:
    """The goals a frame shows and how many are reached: the arena's, or for a task that sets one at a time, each
    it has set so far."""

    def __init__(self):
        self._seen: list[np.ndarray] = []
        self.goals, self.reached = np.zeros((0, 2)), 0

    def update(self, snap: Snapshot, arena) -> None:
        if np.all(np.isfinite(snap.desired_goal)) and (
                not self._seen or not np.allclose(self._seen[-1], snap.desired_goal)):
            self._seen.append(snap.desired_goal)
        self.goals = arena.goals if len(arena.goals) else np.array(self._seen).reshape(-1, 2)
        self.reached = int(snap.info.get("goals_reached", len(self._seen) - 1))


class LiveView:
    """The video's frame of an episode stepped elsewhere, one control step at a time: what the Gymnasium face's
    `render()` returns for the planar ids. `start` after each reset, `add` after each step, `frame()` when a picture
    is wanted (the renderer is made then, once per episode); the frame is `iter_frames`' (goal, path, sonar, trail,
    text overlay and key), without the interpolation between steps."""

    def __init__(self, env, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], camera: str = "both",
                 follow_view: float = FOLLOW_VIEW, title: str = ""):
        if camera not in CAMERAS:
            raise ValueError(f"camera must be one of {CAMERAS}, got {camera!r}")
        self.env, self.size, self.camera, self.title = env, (width, height), camera, title
        self.follow_view = follow_view
        self._recorder = EpisodeRecorder(env)
        self._renderer: FrameRenderer | None = None
        self._snap: Snapshot | None = None
        self._trail, self._goals = _Trail(TRAIL_SPACING * follow_view), _Goals()

    def start(self, time_step) -> None:
        """A new episode from its reset `time_step`: a new arena, trail and goals."""
        self.close()
        self._trail, self._goals = _Trail(TRAIL_SPACING * self.follow_view), _Goals()
        self._observe(self._recorder.start(time_step))

    def add(self, time_step, action) -> None:
        """The step that `action` led to."""
        if self._snap is None:
            raise RuntimeError("LiveView.add before start: call start(time_step) after the reset")
        self._observe(self._recorder.add(time_step, action))
        del self._recorder.snapshots[:-1]  # the frame needs the last instant only

    def _observe(self, snap: Snapshot) -> None:
        self._snap = snap
        self._trail.add(snap.pose[:2])
        self._goals.update(snap, self._recorder.arena)

    def frame(self) -> np.ndarray:
        """The (H, W, 3) uint8 frame of the latest instant."""
        if self._snap is None:
            raise RuntimeError("no episode to draw yet: call start(time_step) after the reset")
        if self._renderer is None:
            self._renderer = FrameRenderer(self.env.physics, *self.size, self.camera, self.follow_view,
                                           arena=self._recorder.arena, title=self.title)
        return self._renderer.render(self._snap, self._trail.view(), self._goals.goals, self._goals.reached,
                                     self._snap.event)

    def close(self) -> None:
        """Frees the renderer's OpenGL context (a new one is made by the next frame)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def frame_interval(env, fps: float, speedup: float | None) -> float:
    """Simulated seconds [s] between two frames of a video of `env`: `speedup / fps`, or one control step where
    `speedup` is None; ValueError unless positive."""
    frame_dt = (speedup if speedup is not None else fps * env.control_timestep()) / fps
    if not frame_dt > 0:
        raise ValueError(f"speedup and fps must be positive, got speedup={speedup}, fps={fps}")
    return frame_dt


class VideoClock:
    """The clock of an episode's video, planar and 6-DOF alike: a frame every `frame_interval` simulated seconds
    from the episode's first instant, each showing the banner of the last event (goal, collision) for EVENT_HOLD
    seconds of video after it."""

    def __init__(self, env, fps: float, speedup: float | None):
        self.frame_dt, self.fps = frame_interval(env, fps, speedup), fps
        self.next_time: float | None = None
        self.event, self.event_until = "", -math.inf

    def frames_to(self, time: float, event: str = "") -> Iterator[tuple[float, str]]:
        """The frames due up to the recorded instant `time` [s] (whose step ended with `event`, if any): each
        frame's time and the banner it shows ("" for none)."""
        if self.next_time is None:
            self.next_time = time
        if event:
            self.event, self.event_until = event, time + EVENT_HOLD * self.fps * self.frame_dt
        while self.next_time <= time + TIME_TOLERANCE:
            yield self.next_time, self.event if self.next_time <= self.event_until else ""
            self.next_time += self.frame_dt


def closing_frames(bar, snap, recorder, max_steps: int | None, frame, hold_end: float,
                   fps: float) -> Iterator[np.ndarray]:
    """The end of an episode's video, planar and 6-DOF alike: the bar's last word (the outcome, or "cut" where
    --max-steps stopped it) and the last frame held for `hold_end` seconds."""
    if bar is not None:
        bar.finish(snap.success, outcome_label(outcome([snap.event]), recorder.cut, max_steps))
    for _ in range(int(round(hold_end * fps)) if frame is not None else 0):
        yield frame.copy()


def iter_frames(env, policy, *, max_steps: int | None = None, width: int = DEFAULT_SIZE[0],
                height: int = DEFAULT_SIZE[1], camera: str = "both", fps: float = DEFAULT_FPS,
                speedup: float | None = None, follow_view: float = FOLLOW_VIEW,
                hold_end: float = DEFAULT_HOLD_END, title: str = "", recorder: EpisodeRecorder | None = None,
                progress: bool = False, track: StepObserver | None = None) -> Iterator[np.ndarray]:
    """Runs one episode of `policy(time_step) -> action` on `env`, yielding (H, W, 3) uint8 frames.

    A frame every `speedup / fps` simulation seconds (default: one per control step). Pass a `recorder`
    to keep the episode's record as well, and a `track` (anything with `add(env)`, called after the reset and each
    control step, as the 6-DOF video calls it) to gather more beside the frames.
    """
    def view_of(recorder: EpisodeRecorder, first: Snapshot) -> _PlanarView:
        return _PlanarView(env, recorder, first, width, height, camera, follow_view, title)

    yield from stream_frames(env, policy, view_of, max_steps=max_steps, fps=fps, speedup=speedup,
                             hold_end=hold_end, recorder=recorder, progress=progress, track=track)


class _PlanarView:
    """The planar video's view of an episode (an `EpisodeView`): the frame renderer over the recorded arena, the
    trail so far and the goals, the route of the progress bar (`route_of`)."""

    def __init__(self, env, recorder: EpisodeRecorder, first: Snapshot, width: int, height: int, camera: str,
                 follow_view: float, title: str):
        self.trail, self.marks, self.arena = _Trail(TRAIL_SPACING * follow_view), _Goals(), recorder.arena
        self.renderer = FrameRenderer(env.physics, width, height, camera, follow_view, arena=recorder.arena,
                                      title=title)
        self.route, self.goal_radius = route_of(recorder.arena, first), recorder.arena.goal_radius

    def state(self, snap: Snapshot) -> Snapshot:
        self.marks.update(snap, self.arena)
        return snap

    def draw(self, previous: Snapshot, state: Snapshot, time: float, banner: str) -> np.ndarray:
        shown = interpolate(previous, state, time)
        self.trail.add(shown.pose[:2])
        return self.renderer.render(shown, self.trail.view(), self.marks.goals, self.marks.reached, banner)

    def made_good(self, snap: Snapshot, state: Snapshot) -> float | None:
        return distance_along(self.route, snap.pose[:2]) if self.route is not None else None

    def close(self) -> None:
        self.renderer.close()


class EpisodeView(Protocol):
    """What a domain's video draws of an episode (`stream_frames`), made after the episode's reset."""

    route: np.ndarray | float | None
    """The route the progress bar measures along (`RenderBar`): its points, its length, or None."""
    goal_radius: float
    """The task's goal radius [m] (the bar ends this short of the route's end)."""

    def state(self, snap: Snapshot) -> Any:
        """The drawable state of the recorded instant `snap`."""

    def draw(self, previous: Any, state: Any, time: float, banner: str) -> np.ndarray:
        """The (H, W, 3) uint8 frame at `time` [s] between two drawable states, with the event `banner` ("")."""

    def made_good(self, snap: Snapshot, state: Any) -> float | None:
        """The route made good [m] at a recorded instant (None without a route)."""

    def close(self) -> None:
        """Frees the view's renderer."""


def stream_frames(env, policy, view_of: Callable[[EpisodeRecorder, Snapshot], EpisodeView], *,
                  max_steps: int | None, fps: float, speedup: float | None, hold_end: float,
                  recorder: EpisodeRecorder | None, progress: bool,
                  track: StepObserver | None) -> Iterator[np.ndarray]:
    """The one loop of an episode's video, planar and 6-DOF alike: runs the episode through the one episode loop
    (`recorder`), makes the domain's view after the reset (`view_of(recorder, first snapshot)`), yields its frames on
    the video's clock (`VideoClock`) and the closing ones, and moves the progress bar by the route made good."""
    recorder = recorder if recorder is not None else EpisodeRecorder(env)
    clock = VideoClock(env, fps, speedup)
    glbackend.require()
    view, previous, frame, bar = None, None, None, None
    try:
        for snap in recorder.run(policy, max_steps):
            if view is None:  # after the reset: the task has drawn its arena
                view = view_of(recorder, snap)
                bar = RenderBar(view.route, view.goal_radius, step_bound(env, max_steps), progress)
            if track is not None:
                track.add(env)
            state = view.state(snap)
            previous = state if previous is None else previous
            for time, shown in clock.frames_to(snap.time, snap.event):
                frame = view.draw(previous, state, time, shown)
                yield frame
            previous = state
            bar.advance(view.made_good(snap, state), snap.step)
        yield from closing_frames(bar, snap, recorder, max_steps, frame, hold_end, fps)
    finally:
        if bar is not None:
            bar.close()
        if view is not None:
            view.close()


def video_frames(env, policy, options: VideoOptions, recorder: EpisodeRecorder | None = None,
                 track: StepObserver | None = None) -> Iterator[np.ndarray]:
    """The planar domain's video (`auv_mj.tasks.domains.Domain.video`): `iter_frames` with `options`."""
    return iter_frames(env, policy, max_steps=options.max_steps, width=options.width, height=options.height,
                       camera=options.camera, fps=options.fps, speedup=options.speedup,
                       follow_view=options.follow_view, hold_end=options.hold_end, title=options.title,
                       recorder=recorder, progress=options.progress, track=track)


def step_bound(env, max_steps: int | None) -> int | None:
    """The most steps an episode of `env` can take: its time limit, or `max_steps` if fewer; None without either."""
    limit = getattr(env, "_step_limit", None)
    steps = min(limit if limit and math.isfinite(limit) else math.inf, max_steps or math.inf)
    return math.ceil(steps) if math.isfinite(steps) else None


def route_of(arena, first: Snapshot) -> np.ndarray | None:
    """(P, 2) the route an episode's progress is measured along: the global path, else straight from the start to
    the goal (the arena's, else the vehicle's position and the desired goal at the reset `first`); None on a task
    without a goal."""
    if len(arena.path) > 1:
        return np.asarray(arena.path, float)
    for ends in (np.array([arena.start, arena.goal], float), np.array([first.pose[:2], first.desired_goal], float)):
        if np.all(np.isfinite(ends)):
            return ends
    return None


class RenderBar:
    """The render's progress bar: on a task with a goal, the metres made good along the route (`route_of`) out of
    its length short of the goal radius, so that it fills as the vehicle goes, ends full at the goal and stays where
    the vehicle stopped otherwise, its total fixed from the start; on a task without one (tracking), the steps out of
    the time limit (or `max_steps`), which such an episode runs to. The outcome shows beside it at the end."""

    def __init__(self, route: np.ndarray | float | None, goal_radius: float, steps: int | None, enabled: bool):
        """`route`: its (P, 2) points or its length [m], None on a task without a goal."""
        if route is not None:
            length = float(route) if np.ndim(route) == 0 else polyline_length(route)
            self.total = max(int(math.ceil(length - goal_radius)), 1)
            self.bar = progress_bar(total=self.total, unit="m", desc="render, route", disable=not enabled,
                                    bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} m "
                                               "[{elapsed}<{remaining}{postfix}]")
        else:
            self.total = steps
            self.bar = progress_bar(total=steps, unit="step", desc="render", disable=not enabled)
        self.by_route = route is not None

    def advance(self, metres: float | None, step: int) -> None:
        """After a step: the route made good [m] so far (None on a task without a goal), the step's number."""
        done = min(int(metres), self.total) if self.by_route and metres is not None else step
        if self.total is not None:
            done = min(done, self.total)
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def finish(self, reached: bool, label: str) -> None:
        """The episode's end: full at the goal (the last metres are inside the goal radius) and on a tracking task
        (its schedule is done), else where it stopped; the outcome `label` beside it."""
        if reached and self.total is not None:
            self.bar.update(self.total - self.bar.n)
        elif not self.by_route:
            complete(self.bar)
        self.bar.set_postfix_str(label)

    def close(self) -> None:
        self.bar.close()


IN_MEMORY_WARNING = 512 * 2 ** 20
"""Bytes of frames above which `render_episode(..., in_memory=True)` warns before it renders (a 1280 x 720 frame is
2.8 MB: a 700 m tunnel at one frame per control step (826 frames) is about 2.1 GB)."""


def frame_bound(env, max_steps: int | None, fps: float, speedup: float | None, hold_end: float) -> int | None:
    """The most frames an episode of `env` can give (its time limit or `max_steps`, then the held end), or None
    when it has no limit."""
    steps = step_bound(env, max_steps)
    if steps is None:
        return None
    frame_dt = frame_interval(env, fps, speedup)
    return int(math.floor(steps * env.control_timestep() / frame_dt + TIME_TOLERANCE)) + 1 + int(round(hold_end * fps))


def size_text(frames: int | None, width: int, height: int) -> str:
    """What `frames` frames of width x height take in memory, in words ("up to 826 frames of 1280 x 720: 2.1 GB")."""
    width, height = int(width) // 2 * 2, int(height) // 2 * 2
    if frames is None:
        return f"{width * height * 3 / 2 ** 20:.1f} MB a frame of {width} x {height}, for as long as the episode runs"
    size = frames * width * height * 3
    amount = f"{size / 2 ** 30:.1f} GB" if size >= 2 ** 30 else f"{size / 2 ** 20:.0f} MB"
    return f"up to {frames} frames of {width} x {height}: {amount}"


def episode_output(frames: Iterable[np.ndarray], path: str | Path | None, in_memory: bool, bound: int | None,
                   width: int, height: int, fps: float, gif: bool | None) -> Path | np.ndarray:
    """Where `render_episode` and `render_episode_3d` put their frames: streamed to `path` (memory flat in the
    episode's length), or, asked for with `in_memory=True`, stacked into one (T, H, W, 3) array, with a warning
    first when that may pass IN_MEMORY_WARNING bytes."""
    if (path is None) == (not in_memory):
        raise ValueError(f"give path= to stream the video to a file, or in_memory=True for the whole video as one "
                         f"(T, H, W, 3) array ({size_text(bound, width, height)}); not "
                         f"{'both' if in_memory else 'neither'}")
    if path is not None:
        return write_video(frames, path, fps, gif)
    if bound is None or bound * (width // 2 * 2) * (height // 2 * 2) * 3 > IN_MEMORY_WARNING:
        warnings.warn(f"render_episode(in_memory=True) keeps every frame in memory, {size_text(bound, width, height)}"
                      f"; give path= to stream the video to a file instead", stacklevel=3)
    frames = list(frames)
    return np.stack(frames) if frames else np.zeros((0, 0, 0, 3), dtype=np.uint8)


def render_episode(env, policy, path: str | Path | None = None, *, in_memory: bool = False,
                   max_steps: int | None = None, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                   camera: str = "both", fps: float = DEFAULT_FPS, speedup: float | None = None,
                   follow_view: float = FOLLOW_VIEW, hold_end: float = DEFAULT_HOLD_END, title: str = "",
                   recorder: EpisodeRecorder | None = None, progress: bool = False,
                   gif: bool | None = None) -> Path | np.ndarray:
    """Renders one episode of `policy(time_step) -> action` on `env` to the video file `path` (MP4, or GIF: see
    `write_video`) and returns the path written; the frames stream to the file, so memory stays flat however long
    the episode.

    `in_memory=True` (and no path) returns the whole video as one (T, H, W, 3) uint8 array instead: width x height
    x 3 bytes a frame, 2.8 MB at the default 1280 x 720, about 2.1 GB for a 700 m tunnel; it warns first when the
    episode's time limit allows more than IN_MEMORY_WARNING bytes. `iter_frames` yields the frames one at a time.
    The other options are `iter_frames`'.
    """
    frames = iter_frames(env, policy, max_steps=max_steps, width=width, height=height, camera=camera, fps=fps,
                         speedup=speedup, follow_view=follow_view, hold_end=hold_end, title=title,
                         recorder=recorder, progress=progress)
    bound = frame_bound(env, max_steps, fps, speedup, hold_end)
    return episode_output(frames, path, in_memory, bound, width, height, fps, gif)
