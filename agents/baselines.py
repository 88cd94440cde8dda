"""Baselines that act on observations alone: uniform random actions. (The classical controllers, which
read the task, live with the tasks: `auv_mj.planners.guidance`.)"""

from __future__ import annotations

from collections.abc import Callable

import dm_env
import numpy as np

Policy = Callable[[dm_env.TimeStep], np.ndarray]


def uniform_random(env, seed: int = 0) -> Policy:
    """Uniform actions within the action spec's bounds, from its own seeded generator."""
    rng = np.random.default_rng(seed)
    spec = env.action_spec()
    low = np.broadcast_to(spec.minimum, spec.shape)
    high = np.broadcast_to(spec.maximum, spec.shape)

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        return rng.uniform(low, high)

    return policy
