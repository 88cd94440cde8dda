"""Failures to look at: an MP4 and a trajectory PNG of each episode that did not reach the goal.

`record_failures` is what `auv-mj eval --record-failures DIR` and `auv-mj benchmark --record-failures DIR` call
after the evaluation:
episodes are functions of their seed (task and policy seeded the same, `auv-mj eval`), so each failed one is run
again, this time through the renderer (`auv_mj.render.episode_video.iter_frames`) and the episode recorder, rather than
rendering every episode while most of them succeed. Files are named `TASK_seedSEED_OUTCOME.mp4` and
`..._trajectory.png` (with a `POLICY_` prefix when asked), so a folder of them sorts by task and seed and says
why each ended. Without OpenGL the PNG is still written; without ffmpeg the video is a GIF.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from auv_mj.episode import EpisodeRecorder, outcome
from auv_mj.figures.trajectory import plot_trajectory
from auv_mj.render import glbackend
from auv_mj.zoo import registry as policies

VIDEO_SIZE = (640, 360)
"""(width, height) of a failure's video [pixels]: small, as a folder may hold many."""
VIDEO_FPS = 30.0
"""Frame rate of a failure's video [frames/s]; a frame per planner step plays the episode 15 times fast."""
SUCCESS = "goal"
"""The outcome that is not a failure."""


@dataclass(frozen=True)
class FailureFiles:
    """What `record_failure` wrote for one episode."""

    task: str
    seed: int
    outcome: str
    """The outcome of the episode as it ran again (the one the evaluation saw, the episode being seeded)."""
    video: Path | None
    """The MP4 (or GIF without ffmpeg); None when no OpenGL backend can render."""
    trajectory: Path


def file_stem(task: str, seed: int, episode_outcome: str, policy: str | None = None) -> str:
    """`[POLICY_]TASK_seedSEED_OUTCOME`, with anything but letters, digits, `-` and `.` in the policy made `_`
    (a checkpoint path names a policy too)."""
    prefix = "" if not policy else re.sub(r"[^A-Za-z0-9.-]+", "_", Path(policy).stem if "/" in policy else policy)
    return f"{prefix + '_' if prefix else ''}{task}_seed{seed}_{episode_outcome}"


def record_failure(policy_name: str, task_name: str, seed: int, directory: str | Path,
                   task_kwargs: dict | None = None, max_steps: int | None = None, *,
                   size: tuple[int, int] = VIDEO_SIZE, fps: float = VIDEO_FPS,
                   prefix_policy: bool = False) -> FailureFiles:
    """Runs episode `seed` of `task_name` under `policy_name` again and writes its video and trajectory PNG
    into `directory` (made if missing)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    env, policy = policies.env_and_policy(policy_name, task_name, seed, task_kwargs)
    recorder = EpisodeRecorder(env, task_name, policy_name, seed)
    frames = None
    try:
        glbackend.require()
        from auv_mj.render.episode_video import iter_frames

        frames = iter_frames(env, policy, max_steps=max_steps, width=size[0], height=size[1], fps=fps,
                             title=f"{task_name} / {policy_name} / seed {seed}", recorder=recorder)
    except glbackend.RenderingUnavailable as e:
        print(f"record-failures: no video of {task_name} seed {seed}: {e}", file=sys.stderr)
    video = None
    staged = directory / f".{task_name}_seed{seed}.rendering.mp4"  # named once the outcome is known
    try:
        if frames is not None:
            from auv_mj.render.writers import write_video

            video = write_video(frames, staged, fps)
        else:
            for _ in recorder.run(policy, max_steps):
                pass
        record = recorder.record()
        ended = outcome(record.event)
        stem = file_stem(task_name, seed, ended, policy_name if prefix_policy else None)
        if video is not None:
            video = video.replace(directory / f"{stem}{video.suffix}")
    finally:
        for leftover in (staged, staged.with_suffix(".gif")):
            leftover.unlink(missing_ok=True)
    trajectory = plot_trajectory([record], directory / f"{stem}_trajectory.png",
                                       title=f"{task_name}: {policy_name}, seed {seed}, {ended} after "
                                             f"{record.time[-1]:.0f} s")
    return FailureFiles(task_name, seed, ended, video, Path(trajectory))


def record_failures(policy_name: str, episodes: Iterable[tuple[str, int, str]], directory: str | Path,
                    task_kwargs: dict | None = None, max_steps: int | None = None, **options) -> list[FailureFiles]:
    """`record_failure` for each (task, seed, outcome) of `episodes` whose outcome is not SUCCESS, each (task, seed)
    once; `options` go to `record_failure` (size, fps, prefix_policy). Returns what was written, in the order given.
    A deterministic evaluation lists one episode for all its seeds (`auv_mj.benchmark.runner.evaluate`), so the
    same episode is never filmed twice."""
    failed = dict.fromkeys((task, seed) for task, seed, episode_outcome in episodes if episode_outcome != SUCCESS)
    return [record_failure(policy_name, task, seed, directory, task_kwargs, max_steps, **options)
            for task, seed in failed]
