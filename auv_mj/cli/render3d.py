"""Videos and plots of 6-DOF episodes: `python -m auv_mj.cli.render3d --task tunnel3d --policy splane`.

Runs one episode of an auv3d task with a registered policy (`auv_mj.zoo.registry`), writes the video of
`auv_mj.render.episode_video3d` (chase, top-down and side views with a heads-up display) and, with --plots PREFIX, two
figures:
PREFIX_depth.png (depth against time, with the command where the task has one) and PREFIX_track.png (the
3-D track, with the tube's centreline or the goal), drawn by `auv_mj.figures.trajectory3d`.
`auv-mj render --task tunnel3d ...` runs it (`render_3d`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from auv_mj.episode import EpisodeRecorder, outcome, outcome_label
from auv_mj.figures.trajectory3d import plot_depth, plot_track
from auv_mj.render.episode_video import DEFAULT_HOLD_END
from auv_mj.render.episode_video3d import Track3D, iter_frames_3d
from auv_mj.render.frame import DEFAULT_SIZE
from auv_mj.render.writers import DEFAULT_FPS, write_video
from auv_mj.tasks import suite
from auv_mj.zoo.registry import env_and_policy


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m auv_mj.cli.render3d", description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="tunnel3d", choices=[name for _, name in suite.TASKS_3D])
    parser.add_argument("--policy", default="splane")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-steps", type=int, default=None)
    parser.add_argument("-o", "--out", "--output", dest="output", default=None,
                        help="video to write (.mp4 or .gif); none if omitted (--output: its old name)")
    parser.add_argument("--plots", default=None, metavar="PREFIX", help="write PREFIX_depth.png, PREFIX_track.png")
    parser.add_argument("--width", type=int, default=DEFAULT_SIZE[0])
    parser.add_argument("--height", type=int, default=DEFAULT_SIZE[1])
    args = parser.parse_args(argv)
    if args.output is None and args.plots is None:
        parser.error("give -o VIDEO and/or --plots PREFIX")
    env, policy = env_and_policy(args.policy, args.task, args.seed)
    render_3d(env, policy, args.output, args.plots, args.max_steps, f"{args.task}, {args.policy}, seed {args.seed}",
              width=args.width, height=args.height)
    return 0


def render_3d(env, policy, output: str | Path | None, plots: str | None, max_steps: int | None,
              title: str, *, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], fps: float = DEFAULT_FPS,
              speedup: float | None = None, hold_end: float = DEFAULT_HOLD_END, gif: bool | None = None,
              progress: bool = False) -> None:
    """One episode of a 6-DOF task: the video of `auv_mj.render.episode_video3d` (chase, top and side views, heads-up
    display) to `output` and/or the depth and track figures `plots`_depth.png, `plots`_track.png."""
    track = Track3D()
    if output:
        recorder = EpisodeRecorder(env)
        frames = iter_frames_3d(env, policy, max_steps=max_steps, width=width, height=height, fps=fps,
                                speedup=speedup, hold_end=hold_end, title=title, track=track, recorder=recorder,
                                progress=progress)
        written = write_video(frames, output, fps=fps, gif=gif)
        record = recorder.record()
        print(f"wrote {written}: {record.steps} steps, {record.time[-1]:.1f} s simulated, outcome "
              f"{outcome_label(outcome(record.event), record.cut, max_steps)}")
    else:  # the same episode loop, nothing drawn
        recorder = EpisodeRecorder(env)
        for _ in recorder.run(policy, max_steps):
            track.add(env)
    if plots:
        arrays = track.arrays()
        print(f"wrote {plot_depth(arrays, f'{plots}_depth.png', title)}")
        path = getattr(env.task, "path", None)
        goal = getattr(env.task, "goal", None)
        print(f"wrote {plot_track(arrays, f'{plots}_track.png', path, goal, title)}")

if __name__ == "__main__":
    raise SystemExit(main())
