"""The standard tier's kinematic time bound against `los-fast` (docs/benchmark.md, "Where the time goes").

For each published test seed of obstacles and moving_obstacles on the standard tier in ideal water that the oracle,
`los-fast` and `planner-general` all reached, the straight line from the start to the goal area's edge flown at the
top cruise speed (no turn from the initial heading, no obstacle, no acceleration) is a time no planner can beat.
Prints, over those seeds, that bound and the oracle's time as fractions of `los-fast`'s (ratios of sums).

    python docs/runs/benchmark/straight_line_bound.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from auv_mj.benchmark.leaderboard import LEADERBOARD
from auv_mj.tasks import suite
from auv_mj.tasks.planning_step import MAX_SPEED

NAMES = ("oracle", "los-fast", "planner-general")


def main() -> None:
    board = json.loads(Path(LEADERBOARD).read_text())["policies"]
    for task in ("obstacles", "moving_obstacles"):
        cell = f"{task}/standard/ideal"
        episodes = {n: {e["seed"]: e for e in board[n]["cells"][cell]["episodes"]} for n in NAMES}
        bound, fast, oracle = [], [], []
        for seed in sorted(episodes["oracle"]):
            if not all(episodes[n][seed]["success"] for n in NAMES):
                continue
            env = suite.load("auv", task, task_kwargs={"random": seed, "tier": "standard", "conditions": "ideal"})
            env.reset()
            start, goal = np.asarray(env.physics.pose())[:2], env.task.goals[-1]
            straight = np.linalg.norm(goal - start)
            bound.append((straight - env.task.goal_radius) / MAX_SPEED)
            fast.append(episodes["los-fast"][seed]["time_to_goal"])
            oracle.append(episodes["oracle"][seed]["time_to_goal"])
        print(f"{task}: {len(bound)} seeds; straight-line bound {sum(bound) / sum(fast):.3f} x los-fast's time, "
              f"oracle {sum(oracle) / sum(fast):.3f} x")


if __name__ == "__main__":
    main()
