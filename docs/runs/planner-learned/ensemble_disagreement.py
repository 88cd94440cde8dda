"""How often the members of a planar ensemble pull opposite ways: the hard validation tunnels of one water, stepped
batched with the ensemble's action (the mean of the members' clipped actions), each member's own action logged.
Counts the steps where two members' normalised actions have opposite signs and both exceed 0.5 in size (strong
disagreement), in the episodes the ensemble passes and in those it fails (there over the last 300 steps).

    python docs/runs/planner-learned/ensemble_disagreement.py WATER EPISODES CHECKPOINT CHECKPOINT ...
"""

from __future__ import annotations

import sys

import numpy as np

from auv_mj.agents.ppo.planner import VALIDATION_FIRST_SEED
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.spaces import normalised_action
from auv_mj.tasks.vector import AUVVectorEnv


def main(water: str, episodes: int, paths: list[str]) -> None:
    members = [PPOPolicy.load(p) for p in paths]
    spec = members[0].spec
    options = spec.get("task_options", {})
    seeds = list(range(VALIDATION_FIRST_SEED, VALIDATION_FIRST_SEED + episodes))
    env = AUVVectorEnv("tunnel", num_envs=episodes, threads=1,
                       task_kwargs={**options, "arena": "random", "tier": "hard", "conditions": water})
    try:
        obs, _ = env.reset(seed=seeds)
        done, success = np.zeros(episodes, bool), np.zeros(episodes, bool)
        strong: list[list[np.ndarray]] = [[] for _ in seeds]
        while not done.all():
            acts = np.stack([m(obs) for m in members])                    # (K, N, A), env units
            norm = normalised_action(acts, spec)
            opposite = (norm.max(axis=0) > 0.5) & (norm.min(axis=0) < -0.5)   # (N, A)
            for i in np.flatnonzero(~done):
                strong[i].append(opposite[i])
            obs, _, term, trunc, info = env.step(acts.mean(axis=0))
            ended = (term | trunc) & ~done
            success[ended] = info["success"][ended]
            done |= ended
    finally:
        env.close()
    print(f"tunnel/hard/{water}: the ensemble passes {int(success.sum())} of {episodes}")
    for label, rows in (("passed", [np.array(strong[i]) for i in np.flatnonzero(success)]),
                        ("failed, last 300 steps", [np.array(strong[i])[-300:] for i in np.flatnonzero(~success)])):
        if rows:
            both = np.concatenate(rows)
            print(f"{label}: {len(rows)} episodes, {len(both)} steps; strong disagreement per action dim: "
                  + ", ".join(f"{v:.3f}" for v in both.mean(axis=0)))
    for i in np.flatnonzero(~success):
        s = np.array(strong[i])
        print(f"  seed {seeds[i]}: {len(s)} steps; strong disagreement over the last 300: "
              + ", ".join(f"{v:.3f}" for v in s[-300:].mean(axis=0)))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3:])
