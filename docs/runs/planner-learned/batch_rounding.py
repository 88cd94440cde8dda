"""One hard validation cell of a planar learned planner, run twice: all episodes in one batched env (as
`auv_mj.agents.ppo.planner.validate` runs them) and each seed alone (a batch of one). The env repeats each seed's
episode either way (tested); only the network's rounding differs, since a matrix product's last bits depend on its
number of rows. Prints the episodes whose outcome differs and the first step where their actions part.

    python docs/runs/planner-learned/batch_rounding.py CHECKPOINT [EPISODES] [WATER] [TASK]
"""

from __future__ import annotations

import sys

import numpy as np

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.ppo.planner import VALIDATION_FIRST_SEED
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.tasks.vector import AUVVectorEnv


def run(path: str, seeds: list[int], task: str, water: str) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """(success, steps, actions per env) of `seeds` stepped together in one batched env."""
    options = read_checkpoint(path, "ppo").metadata["spec"].get("task_options", {})
    env = AUVVectorEnv(task, num_envs=len(seeds), threads=1,
                       task_kwargs={**options, "arena": "random", "tier": "hard", "conditions": water})
    policy = PPOPolicy.load(path)
    try:
        obs, _ = env.reset(seed=seeds)
        n = len(seeds)
        done, success, steps = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, int)
        actions: list[list[np.ndarray]] = [[] for _ in seeds]
        while not done.all():
            act = policy(obs)
            for i in np.flatnonzero(~done):
                actions[i].append(act[i].copy())
            obs, _, term, trunc, info = env.step(act)
            steps[~done] += 1
            ended = (term | trunc) & ~done
            success[ended] = info["success"][ended]
            done |= ended
    finally:
        env.close()
    return success, steps, [np.array(a) for a in actions]


def main(path: str, episodes: int = 50, water: str = "ocean", task: str = "tunnel") -> None:
    seeds = list(range(VALIDATION_FIRST_SEED, VALIDATION_FIRST_SEED + episodes))
    batched = run(path, seeds, task, water)
    alone = [run(path, [s], task, water) for s in seeds]
    print(f"{task}/hard/{water}: batched {int(batched[0].sum())}/{episodes}, "
          f"alone {sum(int(a[0][0]) for a in alone)}/{episodes}")
    parted_episodes = 0
    for i, seed in enumerate(seeds):
        a, b = batched[2][i], alone[i][2][0]
        n = min(len(a), len(b))
        parted = np.flatnonzero(np.any(a[:n] != b[:n], axis=1))
        first = int(parted[0]) if parted.size else None
        parted_episodes += first is not None
        if batched[0][i] != alone[i][0][0]:
            gap = float(np.abs(a[first] - b[first]).max()) if first is not None else 0.0
            print(f"seed {seed}: batched {'success' if batched[0][i] else 'failure'} in {batched[1][i]} steps, "
                  f"alone {'success' if alone[i][0][0] else 'failure'} in {alone[i][1][0]} steps; "
                  f"actions first part at step {first} by {gap:.1e}")
    print(f"{parted_episodes} of {episodes} episodes' actions differ somewhere between the two runs")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], *(int(a) for a in args[1:2]), *args[2:4])
