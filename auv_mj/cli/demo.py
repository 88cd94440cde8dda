"""`auv-mj demo`: the end-to-end system of Sec. 4.3 in a few minutes on a CPU.

Loads the shipped HER-DDPG planner and DDPG executor, drives the full MuJoCo dynamics through the
`tunnel` task (Table 12), prints an evaluation table beside the paper's planner on the S-plane executor, the
general planner and the strongest classical planner (`map-replan`, COMPARED), and writes `demo/tunnel.mp4`,
`demo/tunnel_trajectory.png` and `demo/tunnel_episode.npz`. `--task`, `--task-kwargs`, `--arena` run the same
demo elsewhere (files named after the task), e.g. on a tunnel you authored: `auv-mj demo --arena my_tunnel.xml`.
On an arena of the user's (or a random one) the demo flies ARENA_SYSTEM unless `--policy` names another: the paper's
system was trained on the paper's one tunnel and fails on others.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from auv_mj import render
from auv_mj.cli.evaluate import shown_clearance, table_cell
from auv_mj.cli.options import (
    add_episode_options,
    add_force_option,
    add_output_option,
    check_output,
    fps,
    pixels,
    task_kwargs,
    usage_error,
)
from auv_mj.console import progress_bar
from auv_mj.episode import EpisodeRecord, EpisodeRecorder, episode_metrics, record_episode
from auv_mj.figures.trajectory import plot_trajectory
from auv_mj.render import glbackend
from auv_mj.zoo import registry as policies

TASK = "tunnel"
SYSTEM = "two-layer"
"""The policy the demo flies on the paper's arenas: the paper's planner on its learned executor (Sec. 4.3)."""
ARENA_SYSTEM = "planner-general"
"""The policy the demo flies on an arena given with --arena (or task_kwargs' "arena"): the general planner, which
passes tunnels it was not trained on (an authored S-bend that narrows, with an unknown rock and a mover: goal, as
map-replan and two-layer-general; two-layer timed out there)."""
COMPARED = ("planner", "two-layer-general", "map-replan")
"""Rows beside the demonstrated policy: the paper's HER-DDPG planner on the S-plane executor, the general planner
(trained on the distribution of arenas) on its learned executor, and the strongest classical planner at equal
tools, `map-replan` (a sonar occupancy grid searched again as it changes), a fair fight rather than line of sight
with no avoidance."""


def demo_row(record: EpisodeRecord) -> dict:
    """The demo's row of one episode: the eval metrics (`auv_mj.episode.episode_metrics`, the one definition)
    that Sec. 4.3 reports -- outcome, clearance, tracking of the global path (Fig. 17) -- and the path length
    against the global path's."""
    metrics = episode_metrics(record)
    path = record.arena.path
    global_length = float(np.sum(np.hypot(*np.diff(path, axis=0).T))) if len(path) > 1 else None
    return {"outcome": metrics["outcome"],
            "min_clear_m": shown_clearance(metrics["min_clearance"]),
            "track_mae_m": metrics.get("mae_cross_track"),
            "track_max_m": metrics.get("max_cross_track"),
            "length_m": metrics["path_length"],
            "global_m": global_length,
            "length_ratio": metrics["path_length"] / global_length if global_length else None,
            "time_s": float(record.time[-1]),
            "return": metrics["return"]}


def format_rows(rows: dict[str, dict]) -> str:
    """The demo's table: one row per policy."""
    columns = list(next(iter(rows.values())))
    width = max(12, *(len(name) + 1 for name in rows))
    header = f"{'policy':<{width}}" + "".join(f"{c:>13}" for c in columns)
    lines = [header, "-" * len(header)]
    for name, metrics in rows.items():
        lines.append(f"{name:<{width}}" + "".join(table_cell(metrics[c], 13, 2) for c in columns))
    return "\n".join(lines)


def demo_policy(policy: str | None, kwargs: dict) -> tuple[str, str]:
    """The policy the demo flies and why, in a line: `policy` when given, else SYSTEM on the paper's arenas and
    ARENA_SYSTEM on an arena of the user's."""
    if policy is not None:
        return policy, ""
    if kwargs.get("arena") is None:
        return SYSTEM, ""
    return ARENA_SYSTEM, (f"flying {ARENA_SYSTEM}, the general planner, on the arena {kwargs['arena']}: the paper's "
                          f"{SYSTEM} was trained on the paper's one tunnel and fails on others (--policy {SYSTEM} "
                          f"flies it anyway)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj demo`."""
    add_episode_options(parser, task=TASK, policy=None)
    policy = next(action for action in parser._actions if action.dest == "policy")
    policy.help += f" (default: {SYSTEM}; on an arena given with --arena, {ARENA_SYSTEM})"
    add_output_option(parser, "output folder (default: demo/)", type=Path, default=Path("demo"), metavar="DIR")
    add_force_option(parser)
    parser.add_argument("--width", type=pixels, default=1280)
    parser.add_argument("--height", type=pixels, default=720)
    parser.add_argument("--fps", type=fps, default=30.0)
    parser.add_argument("--no-video", action="store_true", help="skip the video (table and plot only)")


MANIFEST = ".auv-mj-demo"
"""The file in the demo's folder naming the files the demo wrote there: a second `auv-mj demo` replaces those (its
own), never a file of the same name that someone else put there."""


def demo_wrote(path: Path) -> bool:
    """Whether `path` is a file an earlier demo wrote (listed in its folder's MANIFEST) and may be replaced."""
    manifest = path.parent / MANIFEST
    return manifest.is_file() and path.name in manifest.read_text().split("\n")


def _note_written(folder: Path, files: list[Path]) -> None:
    """Adds `files` to `folder`'s MANIFEST."""
    manifest = folder / MANIFEST
    names = set(manifest.read_text().split("\n")) if manifest.is_file() else set()
    manifest.write_text("\n".join(sorted((names | {f.name for f in files}) - {""})) + "\n")


def run(args: argparse.Namespace) -> int:
    """Runs the demo; returns 0 once the table and files are written, whatever the episode's outcome."""
    task, kwargs = args.task, task_kwargs(args)
    args.policy, why = demo_policy(args.policy, kwargs)
    if why:
        print(f"{args.prog}: {why}", flush=True)
    if args.out.exists() and not args.out.is_dir():
        usage_error(args, f"--out {args.out} is a file, not a folder")
    for name in (".mp4", "_episode.npz", "_trajectory.png"):
        check_output(args, args.out / f"{task}{name}", "-o/--out", replace=args.force, may_replace=demo_wrote)
    start = time.perf_counter()
    try:
        env, policy = policies.env_and_policy(args.policy, task, args.seed, kwargs)
    except (FileNotFoundError, ValueError) as e:
        usage_error(args, " ".join(str(e).split()))
    args.out.mkdir(parents=True, exist_ok=True)
    recorder = EpisodeRecorder(env, task, args.policy, args.seed)
    video = args.out / f"{task}.mp4"
    compared = [name for name in COMPARED  # (planar policies: none on a 6-DOF task)
                if name != args.policy and policies.runs_on(policies.POLICIES[name], task)]
    bar = None
    if args.no_video:  # the table's episodes, a minute or so each: one bar over them names the one running
        bar = progress_bar(total=1 + len(compared), desc="demo: table episodes", unit="ep")
        bar.set_postfix(policy=args.policy)
        for _ in recorder.run(policy):
            pass
        bar.update(1)
    else:
        try:
            glbackend.require()
            frames = render.iter_frames(env, policy, width=args.width, height=args.height, fps=args.fps,
                                        title=f"{task} / {args.policy}", recorder=recorder, progress=True)
            render.write_video(frames, video, args.fps)
        except glbackend.RenderingUnavailable as e:
            print(f"{args.prog}: no video: {e}", file=sys.stderr)
            video = None
    record = recorder.record()
    episode_file = args.out / f"{task}_episode.npz"
    record.save(episode_file)
    records = {args.policy: record}
    if bar is None:  # after the video, whose episode had the renderer's bar
        bar = progress_bar(total=len(compared), desc="demo: table episodes", unit="ep")
    for name in compared:
        bar.set_postfix(policy=name)
        try:
            env, policy = policies.env_and_policy(name, task, args.seed, kwargs)
            records[name] = record_episode(env, policy, task=task, policy_name=name, seed=args.seed)
        except (FileNotFoundError, ValueError) as e:
            bar.write(f"{args.prog}: skipping {name}: {e}", file=sys.stderr)
        bar.update(1)
    bar.close()
    title = "Tunnel inspection (Table 12)" if task == TASK and not kwargs else task
    rows = {name: demo_row(r) for name, r in records.items()}
    labels = [f"{name} ({row['outcome']}, {row['length_m']:.0f} m)" for name, row in rows.items()]  # a short track too
    figure = plot_trajectory(list(records.values()), args.out / f"{task}_trajectory.png",
                             labels=labels, title=f"{title}, seed {args.seed}")
    _note_written(args.out, [p for p in (video, episode_file, args.out / f"{task}_trajectory.png") if p is not None])
    print(f"\n{title}, seed {args.seed}; safety distance d_s = 5 m; outcome = goal, collision, left_map or "
          "timeout; track = distance to the global path (Fig. 17) once on it; length_ratio = path length / "
          "global path length")
    print(format_rows(rows))
    if video is not None and not args.no_video:
        print(f"\nvideo:      {video.resolve()}")
    print(f"trajectory: {Path(figure).resolve()}")
    print(f"episode:    {episode_file.resolve()}")
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0
