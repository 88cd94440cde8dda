"""`auv-mj plot trajectory|tracking|learning`: paper-style PNG figures (`auv_mj.figures`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from auv_mj.cli.options import (
    add_episode_options,
    add_force_option,
    add_output_option,
    check_output,
    pixels,
    positive_int,
    task_kwargs,
    usage_error,
)
from auv_mj.episode import record_episode
from auv_mj.figures.canvas import DEFAULT_SIZE, as_records
from auv_mj.figures.curves import BANDS, LEARNING_WINDOW, plot_learning
from auv_mj.figures.tracking import plot_tracking, tracking_csv
from auv_mj.figures.trajectory import plot_trajectory
from auv_mj.zoo import registry as policies


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj plot`."""
    sub = parser.add_subparsers(dest="kind", required=True, metavar="KIND")
    for kind, help_text in (("trajectory", "map, obstacles, path, goal and trajectories (Figs. 9-11, 16)"),
                            ("tracking", "speed/heading vs commanded and errors (Figs. 12-14, 17)")):
        p = sub.add_parser(kind, help=help_text)
        p.add_argument("inputs", nargs="*", type=Path,
                       help="episode .npz files (auv-mj render --save-episode)" +
                            (" or a tracking CSV" if kind == "tracking" else ""))
        add_episode_options(p, task=None, task_required=False,
                            task_help="run an episode of this suite task instead of reading inputs")
        p.add_argument("--max-steps", type=positive_int, default=None)
        if kind == "trajectory":
            p.add_argument("--labels", nargs="*", default=None, help="one legend label per input")
        else:
            p.add_argument("--x", choices=("step", "time"), default="step", help="horizontal axis")
            p.add_argument("--csv", type=Path, default=None, help="also write the per-step tracking CSV")
        _common(p)
    p = sub.add_parser("learning", help="return and success rate vs episodes from training CSVs (Fig. 8)")
    p.add_argument("--runs", action="append", required=True, metavar="CSV_OR_GLOB", nargs="+",
                   help="training logs (progress.csv, run directories or globs) of one group; "
                        "repeat per group")
    p.add_argument("--label", action="append", default=None, help="label of each --runs group, in order")
    p.add_argument("--window", type=positive_int, default=LEARNING_WINDOW, help="episodes per moving average")
    p.add_argument("--band", choices=BANDS, default="minmax",
                   help="shaded band across runs (ci: 95 %% confidence interval of the mean)")
    p.add_argument("--x", choices=("episode", "steps"), default="episode", help="horizontal axis")
    _common(p)


def _common(p: argparse.ArgumentParser) -> None:
    add_output_option(p, "PNG file", old="--output", type=Path, required=True, metavar="FILE")
    add_force_option(p)
    p.add_argument("--title", default=None)
    p.add_argument("--width", type=pixels, default=DEFAULT_SIZE[0], help="image width [px]")
    p.add_argument("--height", type=pixels, default=None,
                   help=f"image height [px] (default {DEFAULT_SIZE[1]}; trajectories: fit the map)")


def _episode_inputs(args: argparse.Namespace) -> list:
    if args.task:
        try:
            env, policy = policies.env_and_policy(args.policy, args.task, args.seed, task_kwargs(args))
        except (FileNotFoundError, ValueError, KeyError) as e:
            usage_error(args, str(e))
        return [record_episode(env, policy, args.max_steps, args.task, args.policy, args.seed)]
    if not args.inputs:
        usage_error(args, "give episode files or --task")
    return list(args.inputs)


def run(args: argparse.Namespace) -> int:
    """`auv-mj plot KIND ...`: writes one PNG."""
    args.prog = f"{args.prog} {args.kind}"
    check_output(args, args.output, "-o", replace=args.force)
    check_output(args, getattr(args, "csv", None), "--csv", replace=args.force)
    size = {"width": args.width, "title": args.title}
    if args.height is not None or args.kind != "trajectory":
        size["height"] = args.height or DEFAULT_SIZE[1]
    try:
        if args.kind == "trajectory":
            if args.labels and len(args.labels) != max(len(args.inputs), 1):
                usage_error(args, f"{len(args.labels)} labels for {max(len(args.inputs), 1)} episodes")
            path = plot_trajectory(as_records(_episode_inputs(args)), args.output, args.labels, **size)
        elif args.kind == "tracking":
            source = _episode_inputs(args)[0]
            is_csv = isinstance(source, Path) and source.suffix.lower() == ".csv"
            if args.csv and not is_csv:
                print(f"wrote {tracking_csv(as_records(source)[0], args.csv)}")
            path = plot_tracking(source, args.output, x=args.x, **size)
        else:
            labels = args.label or [f"group {i + 1}" for i in range(len(args.runs))]
            if len(labels) != len(args.runs):
                usage_error(args, f"{len(args.runs)} --runs groups but {len(labels)} --label")
            path = plot_learning(list(zip(labels, args.runs, strict=True)), args.output, args.window,
                                 args.band, args.x, **size)
    except ValueError as e:
        usage_error(args, " ".join(str(e).split()))
    except OSError as e:
        raise SystemExit(f"{args.prog}: error: {' '.join(str(e).split())}") from None
    print(f"wrote {path}")
    return 0
