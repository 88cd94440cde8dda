"""What a learned planner struck in the tunnels: each collision of a benchmark run, run again.

    python docs/runs/planner-learned/tunnel_failures.py POLICY EPISODES_CSV

POLICY is a `--policy` value (`planner-learned`, `planner-learned=PATH`); EPISODES_CSV a benchmark's `episodes.csv`
for it. For every collision in a `tunnel/*` cell the episode is run again (episodes are functions of their seed) and
the script prints what the vehicle struck: "mover" when the nearest mover's centre is within MOVER_STRIKE of the
vehicle at the end, else "wall" (a wall of the tunnel or an obstacle); then that mover's distance [m] and bearing from
the bow [deg] 20, 10 and 5 s before the end, and the vehicle's speed over the last 1.5 s [m/s]. An episode that ends
otherwise when run again (on another CPU, `docs/benchmark.md`) is printed as such.
"""

from __future__ import annotations

import csv
import math
import sys

import numpy as np

from auv_mj.episode import outcome, record_episode
from auv_mj.zoo.registry import env_and_policy

MOVER_STRIKE = 8.0
"""A mover's centre this near [m] at a collision: the mover was struck (movers' radii are 2-5 m, the hull's 0.67)."""
LOOK_BACK = (20.0, 10.0, 5.0)
"""Seconds before the end at which the struck mover's place is printed."""
SPEED_SPAN = 1.5
"""The speed at the end is the distance flown over this many last seconds [s], over that time."""


def rerun(policy: str, cell: str, seed: int) -> str:
    """One line on collision `seed` of `cell` run again (the project's episode loop, `record_episode`)."""
    _, tier, conditions = cell.split("/")
    env, planner = env_and_policy(policy, "tunnel", seed, {"arena": "random", "tier": tier,
                                                            "conditions": conditions})
    record = record_episode(env, planner, task="tunnel", policy_name=policy, seed=seed)
    ending = outcome(record.event)
    if ending != "collision":
        return f"{cell} {seed}: ran again to {ending!r}, not a collision"
    pose, movers = record.pose, record.movers

    def before(seconds: float) -> int:  # the recorded instant `seconds` before the end, counted in control steps
        return max(0, len(pose) - 1 - int(round(seconds / record.control_dt)))

    gaps = np.hypot(*(movers[-1] - pose[-1, :2]).T) if movers.shape[1] else np.zeros(0)
    struck, where = "wall", ""
    if len(gaps) and gaps.min() <= MOVER_STRIKE:
        k = int(np.argmin(gaps))
        struck = "mover"
        for seconds in LOOK_BACK:
            i = before(seconds)
            offset = movers[i, k] - pose[i, :2]
            bearing = math.degrees(math.remainder(math.atan2(offset[1], offset[0]) - pose[i, 2], 2 * math.pi))
            where += f" {seconds:g} s before: {np.hypot(*offset):.0f} m at {bearing:+.0f} deg;"
    back = before(SPEED_SPAN)
    speed = np.hypot(*(pose[-1, :2] - pose[back, :2])) / (record.time[-1] - record.time[back])
    return f"{cell} {seed}: {struck};{where} speed at the end {speed:.2f} m/s"


def main(policy: str, episodes: str) -> None:
    rows = [r for r in csv.DictReader(open(episodes)) if r["cell"].startswith("tunnel/")
            and r["outcome"] == "collision"]
    counts: dict[str, int] = {}
    for row in rows:
        line = rerun(policy, row["cell"], int(row["seed"]))
        print(line, flush=True)
        kind = line.split(": ")[1].split(";")[0].split(" ")[0]
        counts[kind] = counts.get(kind, 0) + 1
    print(counts)


if __name__ == "__main__":
    main(*sys.argv[1:3])
