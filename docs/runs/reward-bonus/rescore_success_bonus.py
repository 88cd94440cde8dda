"""Rescores published `auv-mj benchmark` results for the success bonus (issue 45): a one-off migration.

Before the bonus, an episode of the default reward ("suite") that reached its goal was paid 1 on its last step; it
is now paid K, the steps left in its time limit, itself included (`tasks/planning_rewards.py`, `success_bonus`). No
other step's reward changed, so a success's return becomes return - 1 + K, with K = step_limit - steps + 1: `step_limit`
read
from the episode's own task (its cell's environment reseeded and reset, as `auv-mj benchmark` builds it: a
procedural tunnel has its own limit) and `steps` from its time to the goal. Failures keep their returns. The cells'
`return` and `return_std` are recomputed as `auv_mj.benchmark.metrics.summarise` computes them. Only the returns change:
success, outcomes, times and clearances are left as they are. Run it once, on results made before the bonus:

    python docs/runs/reward-bonus/rescore_success_bonus.py LEADERBOARD.json docs/runs/benchmark/hard_*/*.json

It was run once, on the shipped leaderboard (now auv_mj/benchmark/data/leaderboard.json) and the hard-tier runs;
running it again on rescored results would add the bonus twice.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from auv_mj.tasks import suite
from auv_mj.tasks.planning_rewards import success_bonus
from auv_mj.tasks.planning_step import PLANNER_DT

OLD_SUCCESS_REWARD = 1.0
"""What the "suite" reward paid on the step that reached the goal before the bonus."""

_ENVIRONMENTS: dict = {}


def step_limit(task: str, task_kwargs: dict, seed: int) -> int:
    """`PlanningTask.step_limit` of episode `seed` of `task` with `task_kwargs` (after its reset)."""
    key = (task, json.dumps(task_kwargs, sort_keys=True))
    env = _ENVIRONMENTS.get(key)
    if env is None:
        env = _ENVIRONMENTS[key] = suite.load(suite.domain_of(task), task, task_kwargs={**task_kwargs, "random": 0})
    env.task.random.seed(seed)
    env.reset()
    return env.task.step_limit


def rescored(result: dict) -> dict:
    """One policy's benchmark result with its successes' returns paid the bonus and its summaries redone."""
    for cell in result["cells"].values():
        if cell["task_kwargs"].get("reward", "suite") != "suite":
            raise ValueError(f"{cell['task']}: reward {cell['task_kwargs']['reward']!r}; only 'suite' is rescored")
        for episode in cell["episodes"]:
            if not episode["success"]:
                continue
            steps = round(episode["time_to_goal"] / PLANNER_DT)
            left = step_limit(cell["task"], cell["task_kwargs"], episode["seed"]) - steps + 1
            episode["return"] = episode["return"] - OLD_SUCCESS_REWARD + float(success_bonus("suite", left))
        returns = [e["return"] for e in cell["episodes"]]
        cell["summary"]["return"] = float(np.mean(returns))
        cell["summary"]["return_std"] = float(np.std(returns))
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path, help="results.json files or the leaderboard, rewritten")
    args = parser.parse_args(argv)
    for path in args.files:
        data = json.loads(path.read_text())
        if "policies" in data:
            for name, result in data["policies"].items():
                data["policies"][name] = rescored(result)
        else:
            data = rescored(data)
        path.write_text(json.dumps(data, indent=1, allow_nan=False))
        print(f"{path}: rescored")


if __name__ == "__main__":
    main()
