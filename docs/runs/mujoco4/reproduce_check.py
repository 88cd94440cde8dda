"""MuJoCo 4.0.1 / dm-control 1.0.52 against the published suite v1 (measured under MuJoCo 3.17 / dm-control 1.0.50):
re-runs the first SEEDS episodes of every cell for a few published policies and compares each episode's record with
the leaderboard's (outcome, time to the goal, path length, least clearance).

    python docs/runs/mujoco4/reproduce_check.py [--seeds 2] [--policies oracle,map-replan,bug,planner-general]
"""

from __future__ import annotations

import argparse
import json
import math

import mujoco

from auv_mj.benchmark.leaderboard import read_board
from auv_mj.benchmark.runner import run_cell_episode
from auv_mj.benchmark.suite import SUITE_V1
from auv_mj.console import progress_bar

FIELDS = ("time_to_goal", "path_length", "min_clearance", "return")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="episodes per cell (the cell's first seeds)")
    parser.add_argument("--policies", default="oracle,map-replan,bug,planner-general")
    args = parser.parse_args()
    board = read_board()["policies"]
    jobs = [(p, c, e) for p in args.policies.split(",") for c in SUITE_V1
            for e in board[p]["cells"][c.name]["episodes"][:args.seeds]]
    rows, worst = [], dict.fromkeys(FIELDS, 0.0)
    bar = progress_bar(total=len(jobs), desc="re-run", unit="ep")
    for policy, cell, published in jobs:
        now = run_cell_episode(policy, cell.task, published["seed"], cell.task_kwargs, None)
        same = now["outcome"] == published["outcome"]
        diffs = {}
        for f in FIELDS:
            a, b = now.get(f), published.get(f)
            diffs[f] = None if a is None or b is None else abs(float(a) - float(b))
            if diffs[f] is not None and not math.isnan(diffs[f]):
                worst[f] = max(worst[f], diffs[f])
        rows.append({"policy": policy, "cell": cell.name, "seed": published["seed"], "same_outcome": same,
                     "outcome": now["outcome"], "published_outcome": published["outcome"], **diffs})
        bar.update(1)
    bar.close()
    print(json.dumps({"mujoco": mujoco.__version__, "episodes": len(rows),
                      "same_outcome": sum(r["same_outcome"] for r in rows), "largest_difference": worst,
                      "differing": [r for r in rows if not r["same_outcome"] or any(
                          (r[f] or 0) > 1e-6 for f in FIELDS)]}, indent=1))


if __name__ == "__main__":
    main()
