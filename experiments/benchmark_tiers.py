"""Runs the hard-tier benchmark of issue 30 with the one episode loop (`auv_mj.episode`) and writes its table.

Each cell is a policy on a task's hard tier (`tier="hard"`, `arena="random"`) over the same held-out seeds
(`auv_mj.seeds.TEST`, from --seed): success with its 95 % Wilson interval, collisions, timeouts, mean time to the
goal, time efficiency against `oracle` on the same seed (oracle time / own time on a success, capped at 1 as SPL
caps path ratios; 0 on a failure), and the least and median of the episodes' least clearances.

    python experiments/benchmark_tiers.py --episodes 20 --seed 10000 --json docs/runs/benchmark/hard.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from auv_mj.benchmark.metrics import wilson
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners import map_planner
from auv_mj.tasks import suite
from auv_mj.zoo.registry import env_and_policy

POLICIES = ("oracle", "planner-general", "two-layer-general", "los-avoid", "los-fast", "map-replan")
TASKS = ("obstacles", "moving_obstacles", "tunnel")


CLASSICAL = {"los-fast": map_planner.los_fast, "map-replan": map_planner.map_replan, "oracle": map_planner.oracle}
"""The planners of `auv_mj.planners.map_planner`, built here directly (the same as their registered names)."""


def make(policy: str, task: str, seed: int, task_kwargs: dict):
    """The environment of one episode and the policy acting in it."""
    if policy in CLASSICAL:
        env = suite.load("auv", task, task_kwargs={**task_kwargs, "random": seed})
        return env, CLASSICAL[policy](env)
    return env_and_policy(policy, task, seed, dict(task_kwargs))


def run_cell(policy: str, task: str, seeds, task_kwargs: dict) -> list[dict]:
    """One episode per seed; each its metrics."""
    rows = []
    for seed in seeds:
        env, act = make(policy, task, seed, task_kwargs)
        metrics = episode_metrics(record_episode(env, act, task=task, policy_name=policy, seed=seed))
        rows.append({"seed": seed, **{k: metrics[k] for k in ("success", "outcome", "time_to_goal", "min_clearance")}})
    return rows


def summary(rows: list[dict], reference: dict[int, float | None]) -> dict:
    """The cell's figures (module docstring)."""
    n = len(rows)
    wins = [r for r in rows if r["success"]]
    low, high = wilson(len(wins), n)
    efficiency = []
    for r in rows:
        ref = reference.get(r["seed"])
        efficiency.append(min(1.0, ref / r["time_to_goal"]) if r["success"] and ref else 0.0)
    clearance = [r["min_clearance"] for r in rows if r["min_clearance"] is not None]
    return {"episodes": n, "success": len(wins) / n if n else 0.0, "wilson": [low, high],
            "collisions": sum(r["outcome"] == "collision" for r in rows),
            "left_map": sum(r["outcome"] == "left_map" for r in rows),
            "timeouts": sum(r["outcome"] == "timeout" for r in rows),
            "mean_time": float(np.mean([r["time_to_goal"] for r in wins])) if wins else None,
            "efficiency": float(np.mean(efficiency)) if efficiency else 0.0,
            "least_clearance": float(np.min(clearance)) if clearance else None,
            "median_clearance": float(np.median(clearance)) if clearance else None}


def merged(results: list[dict]) -> dict:
    """Result files pooled: each cell's episodes of every file (a seed once), summaries recomputed."""
    pooled: dict = {}
    for result in results:
        for task, cells in result.items():
            for policy, cell in cells.items():
                rows = pooled.setdefault(task, {}).setdefault(policy, {"rows": []})["rows"]
                seen = {r["seed"] for r in rows}
                rows += [r for r in cell["rows"] if r["seed"] not in seen]
    for cells in pooled.values():
        reference = {r["seed"]: r["time_to_goal"] for r in cells.get("oracle", {}).get("rows", [])}
        for cell in cells.values():
            cell["summary"] = summary(cell["rows"], reference)
    return pooled


def markdown(result: dict) -> str:
    """The cells of a result file as a markdown table, one row per task and policy."""
    lines = ["| set | policy | episodes | success [95 % Wilson] | collisions | left map | timeouts | mean time [s] | "
             "time efficiency | least / median clearance [m] |", "| --- " * 10 + "|"]
    for task, cells in result.items():
        for policy, cell in cells.items():
            s = cell["summary"]
            time_text = f"{s['mean_time']:.0f}" if s["mean_time"] is not None else "-"
            clear = (f"{s['least_clearance']:.1f} / {s['median_clearance']:.1f}" if s["least_clearance"] is not None
                     else "-")
            lines.append(f"| {task} | `{policy}` | {s['episodes']} | {s['success']:.2f} [{s['wilson'][0]:.2f}, "
                         f"{s['wilson'][1]:.2f}] | {s['collisions']} | {s['left_map']} | {s['timeouts']} | "
                         f"{time_text} | {s['efficiency']:.2f} | {clear} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=10_000)
    parser.add_argument("--tasks", default=",".join(TASKS))
    parser.add_argument("--policies", default=",".join(POLICIES))
    parser.add_argument("--tier", default="hard")
    parser.add_argument("--conditions", default="ideal")
    parser.add_argument("--json", required=True)
    parser.add_argument("--markdown", action="store_true",
                        help="print the table of --json (several files, comma-separated: their episodes pooled) "
                             "and run nothing")
    args = parser.parse_args()
    if args.markdown:
        print(markdown(merged([json.loads(Path(name).read_text()) for name in args.json.split(",")])))
        return
    seeds = range(args.seed, args.seed + args.episodes)
    task_kwargs = {"arena": "random", "tier": args.tier, "conditions": args.conditions}
    out = Path(args.json)
    result = json.loads(out.read_text()) if out.is_file() else {}
    for task in args.tasks.split(","):
        cells = result.setdefault(task, {})
        for policy in args.policies.split(","):
            start = time.time()
            rows = run_cell(policy, task, seeds, task_kwargs)
            cells[policy] = {"rows": rows, "wall_s": time.time() - start}
            reference = {r["seed"]: r["time_to_goal"] for r in cells.get("oracle", {}).get("rows", [])}
            for cell in cells.values():
                cell["summary"] = summary(cell["rows"], reference)
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_text(json.dumps(result, indent=1))
            s = cells[policy]["summary"]
            print(f"{task} {policy}: {s['success']:.2f} [{s['wilson'][0]:.2f}, {s['wilson'][1]:.2f}] "
                  f"coll {s['collisions']} to {s['timeouts']} time {s['mean_time']} eff {s['efficiency']:.2f} "
                  f"({time.time() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
