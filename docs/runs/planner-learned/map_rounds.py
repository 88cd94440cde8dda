"""DAgger round by round, the planner observation against the planner-map one: the mean hard-tier validation
success after each round (10 episodes a hard cell, seeds 27000-27009) and the two tunnel cells, from the runs' logs
(the runs' dagger_cells.csv, copied here as final_fit_dagger_cells.csv and map_dagger_cells.csv; round 12 is the
final fit of 128 epochs). Prints a Markdown table.

    python docs/runs/planner-learned/map_rounds.py [PLANNER_CELLS.csv MAP_CELLS.csv]
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
TUNNELS = ("tunnel/hard/ideal", "tunnel/hard/ocean")


def rounds(path: Path) -> dict[int, dict[str, float]]:
    """{round: {cell: success}} of a dagger_cells.csv."""
    out: dict[int, dict[str, float]] = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            out.setdefault(int(row["round"]), {})[row["cell"]] = float(row["val_success"])
    return out


def main(planner: Path = HERE / "final_fit_dagger_cells.csv", mapped: Path = HERE / "map_dagger_cells.csv") -> None:
    a, b = rounds(planner), rounds(mapped)
    print("| round | planner: mean | tunnels ideal / ocean | planner-map: mean | tunnels ideal / ocean |")
    print("| --- | --- | --- | --- | --- |")
    for k in sorted(set(a) | set(b)):
        cells = []
        for run in (a, b):
            if k in run:
                cells += [f"{np.mean(list(run[k].values())):.3f}", " / ".join(f"{run[k][c]:.1f}" for c in TUNNELS)]
            else:
                cells += ["-", "-"]
        print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(*(Path(p) for p in sys.argv[1:3]))
