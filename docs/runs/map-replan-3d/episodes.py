"""Episodes of a 3-D planner on one hard cell of the 3-D suite, on VALIDATION seeds, with why each one ended.

`auv-mj benchmark` runs the suite's TEST seeds only; this runs the same cells (arena "random", the cell's tier and
water) on validation seeds and prints one JSON line per episode: its outcome, what the hull touched on a
collision and the speeds of its last steps.

    python docs/runs/map-replan-3d/episodes.py map-replan tunnel3d hard ideal 20000 20 [out.json]

The environment variable EXECUTOR names the executor (suite 3d v3's is `splane-ocean`; unset, the task's own).
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np

from auv_mj.zoo import registry as policies


def _geom_name(model, geom: int) -> str:
    return model.geom(geom).name or "body:" + model.body(model.geom_bodyid[geom]).name


def run(policy_name: str, task: str, tier: str, water: str, seed: int) -> dict:
    """One episode's outcome, steps, time [s], mean and top speed [m/s]; on a collision, what the hull touched."""
    executor = {"executor": os.environ["EXECUTOR"]} if os.environ.get("EXECUTOR") else {}
    env = policies.make_env(policy_name, task, seed, arena="random", tier=tier, conditions=water, **executor)
    planner = policies.make_policy(policy_name, env, seed, task)
    time_step = env.reset()
    planner.reset()
    physics, model = env.physics, env.physics.model.ptr
    speeds = []
    while not time_step.last():
        time_step = env.step(planner.act(time_step))
        speeds.append(float(np.linalg.norm(physics.data.ptr.qvel[:3])))
    event = env.task.last_info.get("event", "") or "timeout"
    row = {"seed": seed, "event": event, "steps": len(speeds), "t": physics.time(), "vmax": max(speeds),
           "vmean": float(np.mean(speeds))}
    if event == "collision":
        data, hull = physics.data.ptr, model.geom("hull").id
        row["hit"] = [_geom_name(model, c.geom2 if c.geom1 == hull else c.geom1) for c in data.contact[:data.ncon]
                      if hull in (c.geom1, c.geom2)]
        row["v_before"] = speeds[-5:]
    return row


def main() -> None:
    policy, task, tier, water = sys.argv[1:5]
    first, count = int(sys.argv[5]), int(sys.argv[6])
    rows, start = [], time.time()
    for seed in range(first, first + count):
        rows.append(run(policy, task, tier, water, seed))
        print(json.dumps(rows[-1]), flush=True)
    wins = sum(r["event"] == "goal" for r in rows)
    print(f"SUMMARY {policy} {task}/{tier}/{water} seeds {first}-{first + count - 1}: {wins}/{count} "
          f"({time.time() - start:.0f}s)", flush=True)
    if len(sys.argv) > 7:
        with open(sys.argv[7], "w") as out:
            json.dump(rows, out)


if __name__ == "__main__":
    main()
