"""`auv-mj render`: one episode of a policy on a task to an MP4/GIF, off-screen (`auv_mj.render`), and the
domain's episode figures (--plots): the task's domain record (`auv_mj.tasks.domains.Domain`) names its video and
figures, so both domains take one path here."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from auv_mj.cli.options import (
    add_episode_options,
    add_force_option,
    add_output_option,
    bounded_float,
    check_output,
    fps,
    pixels,
    positive_int,
    task_kwargs,
    usage_error,
)
from auv_mj.episode import EpisodeRecorder, outcome, outcome_label
from auv_mj.planners.guidance import line_of_sight
from auv_mj.render import glbackend
from auv_mj.render.episode_video import DEFAULT_HOLD_END, VideoOptions
from auv_mj.render.frame import CAMERAS, DEFAULT_SIZE, FOLLOW_VIEW
from auv_mj.render.writers import DEFAULT_FPS, VIDEO_SUFFIXES, write_video
from auv_mj.speed.render import time_against_bare_renderer
from auv_mj.tasks import domains, suite
from auv_mj.zoo import registry as policies


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj render`."""
    add_episode_options(parser)
    add_output_option(parser, "video file (.mp4 or .gif)", old="--output", type=Path, default=None, metavar="FILE")
    add_force_option(parser)
    parser.add_argument("--fps", type=fps, default=DEFAULT_FPS, help="video frame rate")
    parser.add_argument("--width", type=pixels, default=DEFAULT_SIZE[0], help="frame width [px] (made even)")
    parser.add_argument("--height", type=pixels, default=DEFAULT_SIZE[1], help="frame height [px] (made even)")
    parser.add_argument("--camera", choices=CAMERAS, default="both",
                        help="follow (top-down, vehicle centred), overview (whole arena), "
                             "both (follow + overview inset)")
    parser.add_argument("--follow-view", type=bounded_float(0.0, 10_000.0, "m", low_open=True), default=FOLLOW_VIEW,
                        help="follow view height [m]")
    parser.add_argument("--speedup", type=bounded_float(0.0, 10_000.0, low_open=True), default=None,
                        help="simulation seconds per video second (default: one frame per control step)")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="cut the episode after this many steps")
    parser.add_argument("--hold-end", type=bounded_float(0.0, 60.0, "s"), default=DEFAULT_HOLD_END,
                        help="seconds to hold the last frame")
    parser.add_argument("--gif", action="store_true", help="write an animated GIF instead of an MP4")
    parser.add_argument("--save-episode", type=Path, default=None, help="also save the episode record (.npz)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--plots", default=None, metavar="PREFIX",
                        help="6-DOF (auv3d) tasks: also write PREFIX_depth.png and PREFIX_track.png")
    parser.add_argument("--bench", action="store_true",
                        help="measure frames/s at 1280x720 and 640x360 against a bare mujoco.Renderer; "
                             "no video")


def make_env_and_policy(args: argparse.Namespace):
    """The environment and policy of the command's episode; bad options are a usage error (exit 2)."""
    try:
        return policies.env_and_policy(args.policy, args.task, args.seed, task_kwargs(args))
    except (FileNotFoundError, ValueError, KeyError) as e:
        usage_error(args, str(e))


def run(args: argparse.Namespace) -> int:
    """`auv-mj render`: renders one episode to a video file, or runs the benchmark."""
    if args.output is not None and args.output.suffix.lower() not in VIDEO_SUFFIXES:
        usage_error(args, f"-o {args.output}: a video file ends in .mp4 or .gif, not "
                          f"{repr(args.output.suffix) if args.output.suffix else 'without a suffix'}")
    try:
        glbackend.require()
        if args.bench:
            env, _ = policies.env_and_policy("splane", "obstacles", args.seed)
            for size, r in time_against_bare_renderer(env, line_of_sight(env)).items():
                print(f"{size}: ours {r['ours_fps']:.1f} frames/s, bare mujoco.Renderer {r['bare_fps']:.1f} "
                      f"frames/s, ratio {r['ratio']:.2f}")
            return 0
        try:
            domain = domains.DOMAINS[suite.domain_of(args.task)]
        except ValueError as e:
            usage_error(args, str(e))
        figures_of = domain.episode_figures()  # the domain's --plots figures, if it draws any
        if args.output is None and (args.plots is None or figures_of is None):
            usage_error(args, "give the video file with -o/--out" + (" (and/or --plots PREFIX)" if figures_of else ""))
        title = f"{args.task} / {args.policy}"
        figures = figures_of(args.plots, title) if figures_of is not None and args.plots is not None else None
        check_output(args, args.output, "-o", replace=args.force)
        for name in figures.files() if figures is not None else ():
            check_output(args, name, "--plots", replace=args.force)
        check_output(args, args.save_episode, "--save-episode", replace=args.force)
        env, policy = make_env_and_policy(args)
        recorder = EpisodeRecorder(env, args.task, args.policy, args.seed)
        if args.output is not None:
            options = VideoOptions(max_steps=args.max_steps, width=args.width, height=args.height, fps=args.fps,
                                   speedup=args.speedup, hold_end=args.hold_end, title=title,
                                   progress=not args.no_progress, camera=args.camera, follow_view=args.follow_view)
            frames = domain.video_frames()(env, policy, options, recorder, figures)
            start = time.perf_counter()
            path = write_video(frames, args.output, args.fps, gif=True if args.gif else None)
            elapsed = time.perf_counter() - start
        else:  # figures alone: the same episode loop, nothing drawn
            for _ in recorder.run(policy, args.max_steps):
                figures.add(env)
    except glbackend.RenderingUnavailable as e:
        print(f"{args.prog}: {e}", file=sys.stderr)
        return 2
    record = recorder.record()
    if args.output is not None:
        print(f"wrote {path}: {record.steps} steps, {record.time[-1]:.1f} s simulated, outcome "
              f"{outcome_label(outcome(record.event), record.cut, args.max_steps)}, return "
              f"{record.episode_return:.2f}, {elapsed:.1f} s to render")
    if args.save_episode:
        print(f"wrote {record.save(args.save_episode)}")
    for written in figures.write(env) if figures is not None else ():
        print(f"wrote {written}")
    return 0
