"""Two policies' time efficiency paired by seed over `auv-mj benchmark` results (issue 30).

For every cell both results hold (filtered by --tier / --water) and every seed the oracle reached the goal on,
the difference A - B of the per-episode time efficiency (oracle time / own time, capped at 1; 0 on a failure, as
`auv_mj.benchmark.metrics.cell_summary` scores it), its mean, a 95 % bootstrap interval (seeded) and the seeds each
policy was the faster on.

    python experiments/paired_efficiency.py runs/hard100/planner-general/results.json \
        runs/hard100/map-replan/results.json --oracle runs/hard100/oracle/results.json --tier hard --water ideal
    python experiments/paired_efficiency.py planner-general map-replan --tier hard     # the published leaderboard's

A or B (and --oracle) is a results file or the name of a policy published on the leaderboard
(`docs/benchmark/leaderboard.json`); --oracle defaults to the leaderboard's `oracle`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from auv_mj.benchmark.leaderboard import LEADERBOARD
from auv_mj.benchmark.metrics import bootstrap_mean, oracle_times, paired_efficiency
from auv_mj.benchmark.suite import ORACLE


def paired(a: dict, b: dict, oracle: dict, tier: str | None, water: str | None, cell_name: str | None = None
           ) -> np.ndarray:
    """The per-seed differences of time efficiency, A - B, over the cells of --tier / --water (or one cell)."""
    names = [n for n, c in a["cells"].items() if (not tier or c["tier"] == tier) and (not water or c["water"] == water)
             and (cell_name is None or n == cell_name)]
    return paired_efficiency(a, b, oracle_times(oracle), names)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a")
    parser.add_argument("b")
    parser.add_argument("--oracle", default=ORACLE)
    parser.add_argument("--tier")
    parser.add_argument("--water")
    parser.add_argument("--resamples", type=int, default=5000)
    args = parser.parse_args()
    a, b, oracle = (results(name) for name in (args.a, args.b, args.oracle))
    d = paired(a, b, oracle, args.tier, args.water)
    if d.size == 0:
        raise SystemExit("no seeds in common (check --tier / --water and the files)")
    print(f"{a['policy']} - {b['policy']}: {_line(d, args.resamples, a['policy'], b['policy'])}")
    for name in a["cells"]:
        cell = paired(a, b, oracle, args.tier, args.water, name)
        if cell.size:
            print(f"  {name}: {_line(cell, args.resamples, a['policy'], b['policy'])}")


def results(name: str) -> dict:
    """A results dict: the file `name`, else the leaderboard's entry of the policy `name`."""
    if Path(name).is_file():
        return json.loads(Path(name).read_text())
    board = json.loads(LEADERBOARD.read_text())["policies"]
    if name not in board:
        raise SystemExit(f"{name!r} is neither a results file nor a policy on the leaderboard ({sorted(board)})")
    return board[name]


def _line(d: np.ndarray, resamples: int, a: str, b: str) -> str:
    """The mean of the differences `d`, its 95 % bootstrap interval, and who was faster how often."""
    mean, low, high = bootstrap_mean(d, resamples)
    return (f"{d.size} seeds, mean {mean:+.3f} [{low:+.3f}, {high:+.3f}] (95 % bootstrap); {a} faster on "
            f"{(d > 0).sum()}, {b} on {(d < 0).sum()}")


if __name__ == "__main__":
    main()
