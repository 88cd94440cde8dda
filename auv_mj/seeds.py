"""The seed ranges of the project, in one place: training, validation and test never cross.

Procgen and the dm_control suite evaluate on seeds never used in training; so do we. A seed here is a
task seed (the `random` of a suite task, `reset(seed=...)` of a Gymnasium id): it draws the episode's
start, goal, obstacles and, with `arena="random"`, the arena itself, in both suite domains (the planar tasks
and the 6-DOF goal3d and tunnel3d draw an episode's arena from its task seed).

- TEST: held-out seeds that figures are reported on (`auv-mj eval --seed 10000`, `auv-mj reproduce`);
- VALIDATION: seeds that models are chosen on (checkpoints, hyper-parameters), never reported as results;
- TRAIN: every seed a training run resets its environment with (`auv_mj.agents.offpolicy.train.episode_seed`).
"""

from __future__ import annotations

TEST = range(10_000, 20_000)
VALIDATION = range(20_000, 30_000)
TRAIN = range(1_000_000, 2**31 - 1)
"""Training seeds are drawn from here (a hash of the run seed and the episode index), far from the others."""


def train_seed(run_seed: int, episode: int) -> int:
    """The task seed of episode `episode` of a training run seeded `run_seed`: a hash into TRAIN."""
    import numpy as np

    value = int(np.random.SeedSequence([run_seed, episode]).generate_state(1, np.uint64)[0])
    return TRAIN.start + value % len(TRAIN)


SEEDS = {"train": TRAIN, "test": TEST, "validation": VALIDATION}
"""The three ranges by name. Seeds outside them (0-9999, say) are free for examples and demos."""


def seed_split(seed: int) -> str:
    """The name of the SEEDS range holding `seed` ("train", "validation", "test"), or "unassigned"."""
    return next((name for name, seeds in SEEDS.items() if seed in seeds), "unassigned")
