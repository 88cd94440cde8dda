"""How graded `map-replan`'s own heading actions are in the paper's action map (a1 -> a heading offset of 90 a1
degrees, clipped by the task to 30): `map-replan` flies N hard validation tunnels of one water and its a1 is
histogrammed. Beside `label_saturation.py` (the same planner's labels read in the rate map, 85 % at -1 or +1), it says
whether labels in the paper's map would carry magnitude.

    python docs/runs/planner-learned/paper_labels.py [EPISODES] [WATER]
"""

from __future__ import annotations

import sys

import numpy as np

from auv_mj.agents.ppo.planner import VALIDATION_FIRST_SEED
from auv_mj.zoo import registry as policies

EDGES = [0, 0.02, 0.05, 0.1, 0.2, 1 / 3, 0.5, 0.95, 1.0001]


def main(episodes: int = 10, water: str = "ideal") -> None:
    headings = []
    for seed in range(VALIDATION_FIRST_SEED, VALIDATION_FIRST_SEED + episodes):
        env = policies.make_env("map-replan", "tunnel", seed, arena="random", tier="hard", conditions=water)
        policy = policies.make_policy("map-replan", env, seed, "tunnel")
        if env.task.action_kind != "paper":
            raise ValueError(f"map-replan's env has action map {env.task.action_kind!r}, expected 'paper'")
        time_step = env.reset()
        while not time_step.last():
            action = np.asarray(policy.act(time_step), float).ravel()
            headings.append(action[1])
            time_step = env.step(action)
    h = np.abs(np.array(headings))
    counts = np.histogram(h, bins=EDGES)[0] / len(h)
    print(f"{len(h)} steps of {episodes} hard {water} tunnels; median |a1| {np.median(h):.3f}; "
          f"|a1| > 0.95: {np.mean(h > 0.95):.3f}; |a1| >= 1/3 (past the 30-degree clip): {np.mean(h >= 1 / 3):.3f}")
    for lo, hi, share in zip(EDGES[:-1], EDGES[1:], counts, strict=True):
        print(f"  |a1| in [{lo:.3f}, {min(hi, 1.0):.3f}): {share:.3f}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]), *sys.argv[2:3])
