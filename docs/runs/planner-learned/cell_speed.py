"""Success, collisions, time-outs (neither) and ground speed of a PPO run's training episodes per hard cell, over its
first and last WINDOW rollouts, from the run's `cells.csv` (this record's `*_cells.csv`): how "PPO straight from the
`map-replan`-taught student" slowed the vehicle, beside the record's second stages that did not.

    python docs/runs/planner-learned/cell_speed.py CELLS.csv [CELLS.csv ...] [--window 40] [--upto 80]

`--upto N` reads a run as if it had stopped after rollout N: runs of different lengths compared at the same steps.
"""

from __future__ import annotations

import argparse
import csv

CELLS = ("obstacles/hard", "moving_obstacles/hard", "tunnel/hard")


def summary(path: str, window: int, upto: int | None = None) -> list[tuple[str, str, int, float, float, float, float]]:
    """(cell, "first"/"last", episodes, success, collisions, time-outs, mean ground speed [m/s]) of each hard task,
    both waters pooled, episode-weighted over the first and the last `window` rollouts (the last up to rollout
    `upto` where given)."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    last = max(int(r["iteration"]) for r in rows)
    last = last if upto is None else min(last, upto)
    out = []
    for cell in CELLS:
        for name, lo, hi in (("first", 0, window), ("last", last - window, last)):
            n = success = collision = speed = 0.0
            for r in rows:
                if r["cell"].startswith(cell) and lo < int(r["iteration"]) <= hi:
                    k = int(r["episodes"])
                    n += k
                    success += float(r["success_rate"]) * k
                    collision += float(r["collision_rate"]) * k
                    speed += float(r["mean_speed"]) * k
            if n:
                out.append((cell, name, int(n), success / n, collision / n, 1 - (success + collision) / n, speed / n))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cells", nargs="+", help="a PPO run's cells.csv")
    parser.add_argument("--window", type=int, default=40, help="rollouts at each end [40]")
    parser.add_argument("--upto", type=int, help="read each run as if it stopped after this rollout [its last]")
    args = parser.parse_args()
    for path in args.cells:
        print(path)
        print("| cell | rollouts | episodes | success | collisions | time-outs | speed [m/s] |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for cell, name, n, s, c, t, v in summary(path, args.window, args.upto):
            print(f"| {cell} | {name} {args.window} | {n} | {s:.2f} | {c:.2f} | {t:.2f} | {v:.2f} |")


if __name__ == "__main__":
    main()
