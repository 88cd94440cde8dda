"""The paired comparisons of this record: runs of the same seeds before and after a change, seed by seed.

    python docs/runs/map-replan-3d/compare.py pairs BEFORE.json:AFTER.json [BEFORE.json:AFTER.json ...]
    python docs/runs/map-replan-3d/compare.py boards OLD_BOARD.json NEW_BOARD.json POLICY
    python docs/runs/map-replan-3d/compare.py executor DIR [BOARD.json|-] [POLICY]

- `pairs`: `episodes.py` outputs (its JSON file), one pair a cell: successes before and after, the seeds gained and
  lost, and over all pairs given the exact McNemar test of gained against lost (`auv_mj.benchmark.metrics`).
- `boards`: one policy's entries on two leaderboard files of the same suite (the old one from git, e.g.
  `git show c7cba50:auv_mj/benchmark/data/leaderboard3d_v3.json > old.json`), cell by cell.
- `executor`: `auv-mj eval ... --json DIR/depth-executor-TASK-TIER-WATER.json` runs of POLICY (`map-replan` by
  default) on another executor (their `_episodes.csv`), against that policy's row on a suite 3d v3 board (the shipped
  board, also given as -, or BOARD.json from git: the board the runs were measured beside): successes and time
  efficiency a cell, and the paired time efficiency with its 95 % bootstrap interval.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.benchmark import leaderboard, metrics, suite


def _outcomes(path: str) -> dict[int, bool]:
    return {int(r["seed"]): r["event"] == "goal" for r in json.loads(Path(path).read_text())}


def _gained_lost(before: dict[int, bool], after: dict[int, bool]) -> tuple[int, int]:
    seeds = set(before) & set(after)
    return sum(after[s] and not before[s] for s in seeds), sum(before[s] and not after[s] for s in seeds)


def pairs(args: list[str]) -> None:
    total = [0, 0]
    for pair in args:
        first, second = pair.split(":")
        before, after = _outcomes(first), _outcomes(second)
        gained, lost = _gained_lost(before, after)
        total[0] += gained
        total[1] += lost
        print(f"{Path(second).stem}: {sum(before.values())} -> {sum(after.values())} of {len(after)}, "
              f"gained {gained}, lost {lost}")
    print(f"all: gained {total[0]}, lost {total[1]}, exact McNemar p = {metrics.exact_mcnemar(*total):.3f}")


def boards(old_path: str, new_path: str, policy: str) -> None:
    old, new = (json.loads(Path(p).read_text())["policies"][policy] for p in (old_path, new_path))
    total = [0, 0]
    for name, cell in new["cells"].items():
        before = {e["seed"]: e["success"] for e in old["cells"][name]["episodes"]}
        after = {e["seed"]: e["success"] for e in cell["episodes"]}
        gained, lost = _gained_lost(before, after)
        total[0] += gained
        total[1] += lost
        print(f"{name}: {sum(before.values())} -> {sum(after.values())}, gained {gained}, lost {lost}")
    print(f"all: gained {total[0]}, lost {total[1]}, exact McNemar p = {metrics.exact_mcnemar(*total):.3f}")


def executor(folder: str, board_file: str | None = None, policy: str = "map-replan") -> None:
    path = Path(board_file) if board_file not in (None, "-") else leaderboard.board_path(suite.suite_for("auv3d", 3))
    board = leaderboard.read_board(path)["policies"]
    references = metrics.oracle_times(board["oracle"])
    shipped = board[policy]
    ours: dict = {"cells": {}}
    for name, cell in shipped["cells"].items():
        task, tier, water = name.split("/")
        with open(Path(folder) / f"depth-executor-{task}-{tier}-{water}_episodes.csv") as f:
            rows = [{"seed": int(r["seed"]), "success": r["success"] == "True",
                     "time_to_goal": float(r["time_to_goal"]) if r["time_to_goal"] not in ("", "None") else None}
                    for r in csv.DictReader(f)]
        ours["cells"][name] = {"episodes": rows}
        reference = references[name]
        mine = np.mean([metrics.episode_efficiency(r, reference) for r in rows if r["seed"] in reference])
        print(f"{name}: {sum(r['success'] for r in rows)}/{len(rows)} ({mine:.2f}) against "
              f"{sum(e['success'] for e in cell['episodes'])}/{len(cell['episodes'])} "
              f"({cell['summary']['time_efficiency']:.2f})")
    differences = metrics.paired_efficiency(ours, shipped, references)
    mean, low, high = metrics.bootstrap_mean(differences)
    wins = [sum(e["success"] for c in r["cells"].values() for e in c["episodes"]) for r in (ours, shipped)]
    print(f"paired time efficiency, this executor - the board's: {mean:+.3f} [{low:+.3f}, {high:+.3f}] "
          f"({differences.size} seeds); successes {wins[0]} against {wins[1]}")


def main() -> None:
    command, args = sys.argv[1], sys.argv[2:]
    {"pairs": pairs, "boards": lambda a: boards(*a), "executor": lambda a: executor(*a)}[command](args)


if __name__ == "__main__":
    main()
