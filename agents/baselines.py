"""Baselines that act on observations alone: uniform random actions. (The classical planners, which read the task,
are the peers of the learned agents: `auv_mj.planners`.)"""

from __future__ import annotations

import dm_env
import numpy as np

from auv_mj.episode import FunctionPlanner, Planner


def uniform_random(env, seed: int = 0) -> Planner:
    """Uniform actions within the action spec's bounds, from its own seeded generator."""
    rng = np.random.default_rng(seed)
    spec = env.action_spec()
    low = np.broadcast_to(spec.minimum, spec.shape)
    high = np.broadcast_to(spec.maximum, spec.shape)

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        return rng.uniform(low, high)

    return FunctionPlanner(policy)
