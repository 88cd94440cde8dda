"""`auv-mj eval`: dm_control suite-style evaluation of a policy over seeded episodes of one or more tasks.

Metrics per task (mean over N episodes seeded `seed`, `seed + 1`, ...): success rate, collision rate, safety
violations (entering d_s = 5 m), minimum clearance, path length, time to goal, return; for tracking tasks the
mean absolute and maximum error of speed and heading (per disturbance phase on speed_heading, Table 9).
Deterministic for a given seed: each episode's randomness comes from its task seed.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from agents import policies
from auv_mj.cli import json_object, progress_bar

TRACKING_KEYS = ("speed_error", "heading_error", "cross_track_error")


def run_episode(env, policy, max_steps: int | None = None) -> dict:
    """One episode; returns its metrics and the per-step tracking errors."""
    time_step = env.reset()
    policy_reset = getattr(policy, "reset", None)
    if policy_reset:
        policy_reset()
    total, steps, length = 0.0, 0, 0.0
    min_clearance = math.inf
    collision = safety = success = False
    time_to_goal = math.nan
    tracking: dict[str, list[float]] = defaultdict(list)
    phases: list[str] = []
    position = env.physics.pose()[:2]
    while not time_step.last() and (max_steps is None or steps < max_steps):
        time_step = env.step(policy(time_step))
        steps += 1
        total += float(time_step.reward or 0.0)
        new_position = env.physics.pose()[:2]
        length += float(np.hypot(*(new_position - position)))
        position = new_position
        info = getattr(env.task, "last_info", {}) or {}
        min_clearance = min(min_clearance, float(info.get("min_clearance", math.inf)))
        collision |= bool(info.get("collision", False))
        safety |= bool(info.get("safety_violation", False))
        if info.get("success", False) and not success:
            success, time_to_goal = True, float(env.physics.time())
        for key in TRACKING_KEYS:
            if key in info:
                tracking[key].append(abs(float(info[key])))
        if "phase" in info:
            phases.append(str(info["phase"]))
    result = {"return": total, "steps": steps, "success": success, "collision": collision,
              "safety_violation": safety, "min_clearance": min_clearance, "path_length": length,
              "time_to_goal": time_to_goal}
    for key, values in tracking.items():
        values = np.asarray(values)
        name = key.replace("_error", "")
        result[f"mae_{name}"] = float(values.mean())
        result[f"max_{name}"] = float(values.max())
        for phase in sorted(set(phases)):
            mask = np.array([p == phase for p in phases])
            if mask.any():
                result[f"mae_{name}_{phase}"] = float(values[mask].mean())
    return result


def summarise(episodes: list[dict]) -> dict:
    """Per-task summary of episode metrics (rates, means; time to goal over successful episodes)."""
    summary = {"episodes": len(episodes),
               "success_rate": float(np.mean([e["success"] for e in episodes])),
               "collision_rate": float(np.mean([e["collision"] for e in episodes])),
               "safety_violation_rate": float(np.mean([e["safety_violation"] for e in episodes])),
               "min_clearance": float(np.min([e["min_clearance"] for e in episodes])),
               "median_min_clearance": float(np.median([e["min_clearance"] for e in episodes])),
               "path_length": float(np.mean([e["path_length"] for e in episodes])),
               "return": float(np.mean([e["return"] for e in episodes])),
               "return_std": float(np.std([e["return"] for e in episodes]))}
    times = [e["time_to_goal"] for e in episodes if e["success"]]
    summary["time_to_goal"] = float(np.mean(times)) if times else math.nan
    extra = sorted({k for e in episodes for k in e if k.startswith(("mae_", "max_"))})
    for key in extra:
        values = [e[key] for e in episodes if key in e]
        summary[key] = float(np.max(values) if key.startswith("max_") else np.mean(values))
    return summary


def evaluate(policy_name: str, task_names: list[str], episodes: int, seed: int = 0,
             max_steps: int | None = None, progress: bool = True, task_kwargs: dict | None = None) -> dict:
    """Evaluates `policy_name` on each task; returns {"policy", "seed", "tasks": {task: summary}}.

    `task_kwargs` go to every task (e.g. random commands on speed_heading); the seed is the episode's.
    """
    task_kwargs = dict(task_kwargs or {})
    if "random" in task_kwargs:
        raise ValueError("task_kwargs: 'random' is set by --seed (episode i gets seed + i), leave it out")
    results = {}
    for task_name in task_names:
        runs = []
        bar = progress_bar(total=episodes, desc=f"eval {task_name}", unit="ep", disable=not progress)
        for i in range(episodes):
            try:
                env = policies.make_env(policy_name, task_name, seed + i, **task_kwargs)
            except TypeError as e:  # an option the task does not take
                raise ValueError(f"task_kwargs {task_kwargs} do not fit task {task_name!r}: {e}") from None
            policy = policies.make_policy(policy_name, env, seed + i, task_name)
            runs.append(run_episode(env, policy, max_steps))
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in runs]):.2f}")
        bar.close()
        results[task_name] = summarise(runs)
    return {"policy": policy_name, "seed": seed, "episodes": episodes, "task_kwargs": task_kwargs,
            "tasks": results}


def format_table(results: dict) -> str:
    """A plain-text table of the headline metrics, one row per task."""
    columns = ("success_rate", "collision_rate", "min_clearance", "path_length", "time_to_goal", "return",
               "mae_speed", "mae_heading")
    header = f"{'task':<18}" + "".join(f"{c:>15}" for c in columns)
    lines = [f"policy: {results['policy']}   episodes: {results['episodes']}   seed: {results['seed']}",
             header, "-" * len(header)]
    for task, summary in results["tasks"].items():
        cells = "".join(f"{summary.get(c, math.nan):>15.3f}" for c in columns)
        lines.append(f"{task:<18}{cells}")
    return "\n".join(lines)


def write_outputs(results: dict, json_path: Path | None, csv_path: Path | None) -> None:
    """Writes the results as JSON ({"tasks": {...}}) and as a CSV of one row per task."""
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(results, indent=2, allow_nan=True))
    if csv_path:
        csv_path.parent.mkdir(parents=True, exist_ok=True)
        keys = sorted({k for s in results["tasks"].values() for k in s})
        with open(csv_path, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["task", *keys])
            for task, summary in results["tasks"].items():
                writer.writerow([task, *(summary.get(k, "") for k in keys)])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj eval`."""
    parser.add_argument("--policy", required=True,
                        help="checkpoint path, shipped policy (planner, executor, two-layer) "
                             "or baseline (splane, random)")
    parser.add_argument("--task", default="all", help="task name, tag (e.g. benchmarking, planning) or 'all'")
    parser.add_argument("--episodes", type=int, default=10, help="episodes per task")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON",
                        help="task options for every task, e.g. '{\"command\": \"random\", "
                             "\"disturbances\": \"random\", \"reward\": \"paper\"}'")
    parser.add_argument("--max-steps", type=int, default=None, help="cut episodes after this many steps")
    parser.add_argument("--json", type=Path, default=None, help="write results as JSON here")
    parser.add_argument("--csv", type=Path, default=None, help="write results as CSV here")


def run(args: argparse.Namespace) -> int:
    """Runs the evaluation, prints the table, writes JSON/CSV."""
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be >= 1, got {args.episodes}")
    try:
        task_names = policies.resolve_tasks(args.task, args.policy)
        results = evaluate(args.policy, task_names, args.episodes, args.seed, args.max_steps,
                           task_kwargs=args.task_kwargs)
    except (ValueError, FileNotFoundError) as e:
        raise SystemExit(f"auv-mj eval: {e}") from None
    print(format_table(results))
    write_outputs(results, args.json, args.csv)
    for path in (args.json, args.csv):
        if path:
            print(f"wrote {path}")
    return 0
