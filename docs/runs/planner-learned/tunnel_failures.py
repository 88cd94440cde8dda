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

from auv_mj.episode import arena_geometry
from auv_mj.tasks.planning_step import PLANNER_DT
from auv_mj.zoo.registry import env_and_policy

MOVER_STRIKE = 8.0
"""A mover's centre this near [m] at a collision: the mover was struck (movers' radii are 2-5 m, the hull's 0.67)."""
LOOK_BACK = (20.0, 10.0, 5.0)
"""Seconds before the end at which the struck mover's place is printed."""


def rerun(policy: str, cell: str, seed: int) -> str:
    """One line on collision `seed` of `cell` run again."""
    _, tier, conditions = cell.split("/")
    env, planner = env_and_policy(policy, "tunnel", seed, {"arena": "random", "tier": tier,
                                                            "conditions": conditions})
    planner.reset()
    step = env.reset()  # the arena's model is built here: read it after
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    movers = [model.body(name).id for name in arena_geometry(physics, env.task).mover_names]
    poses, places = [], []
    while not step.last():
        step = env.step(planner.act(step))
        poses.append(np.array(physics.pose(), dtype=float))
        places.append(np.array([data.xpos[b][:2] for b in movers]).reshape(len(movers), 2))
    event = env.task.last_info.get("event")
    if event != "collision":
        return f"{cell} {seed}: ran again to {event!r}, not a collision"
    end = poses[-1]
    gaps = [float(np.hypot(*(p - end[:2]))) for p in places[-1]]
    if not gaps or min(gaps) > MOVER_STRIKE:
        struck, where = "wall", ""
    else:
        k = int(np.argmin(gaps))
        struck, where = "mover", ""
        for seconds in LOOK_BACK:
            i = max(0, len(poses) - 1 - int(round(seconds / PLANNER_DT)))
            offset = places[i][k] - poses[i][:2]
            bearing = math.degrees(math.remainder(math.atan2(offset[1], offset[0]) - poses[i][2], 2 * math.pi))
            where += f" {seconds:g} s before: {np.hypot(*offset):.0f} m at {bearing:+.0f} deg;"
    back = max(1, int(round(1.5 / PLANNER_DT)))
    speed = np.hypot(*(poses[-1][:2] - poses[-1 - back][:2])) / (back * PLANNER_DT)
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
