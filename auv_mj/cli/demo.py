"""`auv-mj demo`: the end-to-end system of Sec. 4.3 in a few minutes on a CPU.

Loads the shipped HER-DDPG planner and DDPG executor, drives the full MuJoCo dynamics through the
`tunnel` task (Table 12), prints an evaluation table beside the planner on the S-plane executor and the
classical baseline (line-of-sight guidance + S-plane), and writes `demo/tunnel.mp4` and `demo/tunnel_trajectory.png`.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from auv_mj import glbackend
from auv_mj.cli import policies
from auv_mj.cli.options import check_output, fps, pixels, seed_int, usage_error
from auv_mj.episode import EpisodeRecord, EpisodeRecorder, record_episode

TASK = "tunnel"
SEED = 0
SYSTEM = "two-layer"
COMPARED = ("planner", "splane")
"""Rows beside the demonstrated policy: HER-DDPG on the S-plane executor, and line of sight on S-plane."""


def episode_metrics(record: EpisodeRecord) -> dict[str, float]:
    """Success, clearance, global-path tracking (Fig. 17) and path length against the global path's."""
    steps = np.diff(record.pose[:, :2], axis=0)
    travelled = float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))
    path = record.arena.path
    path_length = float(np.sum(np.hypot(*np.diff(path, axis=0).T))) if len(path) > 1 else math.nan
    cross = np.abs(record.info.get("cross_track_error", np.full(record.steps, np.nan)))
    clearance = record.info.get("min_clearance", np.full(record.steps, np.nan))
    return {"success": float(record.succeeded),
            "collision": float(np.any(record.event == "collision")),
            "min_clear_m": float(np.nanmin(clearance)),
            "track_mae_m": float(np.nanmean(cross)),
            "track_max_m": float(np.nanmax(cross)),
            "length_m": travelled,
            "global_m": path_length,
            "length_ratio": travelled / path_length if path_length else math.nan,
            "time_s": float(record.time[-1]),
            "return": record.episode_return}


def format_rows(rows: dict[str, dict[str, float]]) -> str:
    """The demo's table: one row per policy."""
    columns = list(next(iter(rows.values())))
    header = f"{'policy':<12}" + "".join(f"{c:>13}" for c in columns)
    lines = [header, "-" * len(header)]
    for name, metrics in rows.items():
        # round(x, 2) + 0.0 turns a rounded -0.0 (a clearance of -0.001 m at contact) into 0.00
        lines.append(f"{name:<12}" + "".join(f"{round(metrics[c], 2) + 0.0:>13.2f}" for c in columns))
    return "\n".join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj demo`."""
    parser.add_argument("--out", type=Path, default=Path("demo"), help="output folder (default: demo/)")
    parser.add_argument("--seed", type=seed_int, default=SEED, help="task seed")
    parser.add_argument("--width", type=pixels, default=1280)
    parser.add_argument("--height", type=pixels, default=720)
    parser.add_argument("--fps", type=fps, default=30.0)
    parser.add_argument("--policy", default=SYSTEM,
                        help="policy to demonstrate (default: two-layer = shipped planner + executor)")
    parser.add_argument("--no-video", action="store_true", help="skip the video (table and plot only)")


def run(args: argparse.Namespace) -> int:
    """Runs the demo; returns 0 once the table and files are written, whatever the episode's outcome."""
    from auv_mj import render
    from auv_mj.cli import plots

    if args.out.exists() and not args.out.is_dir():
        usage_error(args, f"--out {args.out} is a file, not a folder")
    check_output(args, args.out / "tunnel_episode.npz", "--out")
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    try:
        env = policies.make_env(args.policy, TASK, args.seed)
        policy = policies.make_policy(args.policy, env, args.seed, TASK)
    except (FileNotFoundError, ValueError) as e:
        usage_error(args, " ".join(str(e).split()))
    recorder = EpisodeRecorder(env, TASK, args.policy, args.seed)
    video = args.out / "tunnel.mp4"
    if args.no_video:
        for _ in recorder.run(policy):
            pass
    else:
        try:
            glbackend.require()
            frames = render.iter_frames(env, policy, width=args.width, height=args.height, fps=args.fps,
                                        title=f"{TASK} / {args.policy}", recorder=recorder, progress=True)
            render.write_video(frames, video, args.fps)
        except glbackend.RenderingUnavailable as e:
            print(f"auv-mj demo: no video: {e}", file=sys.stderr)
            video = None
    record = recorder.record()
    record.save(args.out / "tunnel_episode.npz")
    records = {args.policy: record}
    for name in COMPARED:
        if name not in records:
            try:
                env = policies.make_env(name, TASK, args.seed)
                records[name] = record_episode(env, policies.make_policy(name, env, args.seed, TASK), task=TASK,
                                               policy_name=name, seed=args.seed)
            except FileNotFoundError as e:
                print(f"auv-mj demo: skipping {name}: {e}", file=sys.stderr)
    figure = plots.plot_trajectory(list(records.values()), args.out / "tunnel_trajectory.png",
                                   labels=list(records), title=f"Tunnel inspection (Table 12), seed {args.seed}")
    rows = {name: episode_metrics(r) for name, r in records.items()}
    print(f"\nTunnel inspection (Sec. 4.3, Table 12), seed {args.seed}; safety distance d_s = 5 m; track = "
          "distance to the global path (Fig. 17); length_ratio = path length / global path length")
    print(format_rows(rows))
    if video is not None and not args.no_video:
        print(f"\nvideo:      {video.resolve()}")
    print(f"trajectory: {Path(figure).resolve()}")
    print(f"episode:    {(args.out / 'tunnel_episode.npz').resolve()}")
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0
