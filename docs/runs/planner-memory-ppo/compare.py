"""The hard-tier table of planner-memory beside the published map-replan, bug and los-fast rows (test seeds).

Usage (from the repository root): python docs/runs/planner-memory-ppo/compare.py RESULTS.json [RESULTS.json ...]
Each RESULTS.json is `auv-mj benchmark --out DIR`'s DIR/results.json. Success per cell, and time efficiency
paired by seed against map-replan (`auv_mj.benchmark.metrics.paired_efficiency`, 95 % bootstrap interval) over
the seeds both ran, with the shipped leaderboard's oracle as the reference.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from auv_mj.benchmark.leaderboard import LEADERBOARD
from auv_mj.benchmark.metrics import bootstrap_mean, oracle_times, paired_efficiency

PUBLISHED = ("map-replan", "bug", "los-fast")
CELLS = [f"{task}/hard/{water}" for task in ("obstacles", "moving_obstacles", "tunnel") for water in ("ideal", "ocean")]


def _cut(result: dict, seeds: dict[str, set[int]]) -> dict:
    """`result` restricted to the seeds of each cell in `seeds` (a published row cut to a shorter run's seeds)."""
    cells = {}
    for name, cell in result["cells"].items():
        if name in seeds:
            cells[name] = {**cell, "episodes": [e for e in cell["episodes"] if e["seed"] in seeds[name]]}
    return {**result, "cells": cells}


def _success(cell: dict) -> str:
    episodes = cell["episodes"]
    return f"{sum(e['success'] for e in episodes) / len(episodes):.2f}" if episodes else "-"


def main(paths: list[Path]) -> None:
    board = json.loads(Path(LEADERBOARD).read_text())["policies"]
    mine = {json.loads(p.read_text())["policy"]: json.loads(p.read_text()) for p in paths}
    seeds = {name: {e["seed"] for e in cell["episodes"]} for name, cell in next(iter(mine.values()))["cells"].items()
             if name in CELLS}
    rows = {**{name: _cut(board[name], seeds) for name in PUBLISHED}, **{n: _cut(r, seeds) for n, r in mine.items()}}
    reference = oracle_times(board["oracle"])
    episodes = len(next(iter(seeds.values())))
    print(f"Hard tier, test seeds, {episodes} episodes a cell (the published rows cut to the same seeds).\n")
    print("| policy | " + " | ".join(CELLS) + " | time efficiency - map-replan (paired) |")
    print("| --- | " + " | ".join("---" for _ in CELLS) + " | --- |")
    for name, result in rows.items():
        cells = [_success(result["cells"][c]) if c in result["cells"] else "-" for c in CELLS]
        if name == "map-replan":
            paired = "0 (the reference row)"
        else:
            diffs = paired_efficiency(result, rows["map-replan"], reference, CELLS)
            mean, low, high = bootstrap_mean(diffs)
            paired = f"{mean:+.3f} [{low:+.3f}, {high:+.3f}] ({diffs.size} seeds)"
        print(f"| `{name}` | " + " | ".join(cells) + f" | {paired} |")


if __name__ == "__main__":
    main([Path(p) for p in sys.argv[1:]])
