"""Classical baselines: line-of-sight guidance for the planning tasks, the S-plane controller (Eq. 32) for
speed_heading, and uniform random actions. Each is a callable `policy(time_step) -> action in [-1, 1]^2`."""

from __future__ import annotations

import math
from collections.abc import Callable

import dm_env
import numpy as np

from auv_mj.splane import SPlaneController, wrap_angle

CRUISE_SPEED = 1.0
"""Target velocity of Tables 6-8 and 12 [m/s]."""
MIN_PLANNER_SPEED, MAX_PLANNER_SPEED = 0.0, 2.0
"""The planning tasks' V in [0, 2] m/s: a0 = 2 (V - min) / (max - min) - 1 (Table 3, forward only)."""
MAX_HEADING_OFFSET = math.pi / 2
"""Table 3: psi offset in [-90, 90] deg, the planner action a1 = offset / 90 deg."""

CRUISE_ACTION = 2.0 * (CRUISE_SPEED - MIN_PLANNER_SPEED) / (MAX_PLANNER_SPEED - MIN_PLANNER_SPEED) - 1.0
"""The speed action a0 commanding CRUISE_SPEED."""

Policy = Callable[[dm_env.TimeStep], np.ndarray]


def line_of_sight(env) -> Policy:
    """Heads straight for the current desired goal at the cruise speed; sees no obstacles."""

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        goal = np.asarray(time_step.observation["desired_goal"], dtype=float)
        x, y, psi = env.physics.pose()
        offset = wrap_angle(math.atan2(goal[1] - y, goal[0] - x) - psi)
        return np.array([CRUISE_ACTION, np.clip(offset / MAX_HEADING_OFFSET, -1.0, 1.0)])

    return policy


def splane_tracker(env) -> Policy:
    """The S-plane controller of Eq. (32) driving (tau_u, tau_r) on the speed_heading task."""
    controller = SPlaneController()
    low, high = env.physics.model.actuator_ctrlrange.T

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first():
            controller.reset()
        command = env.task.command(env.physics)
        u, v, r = env.physics.body_velocity()
        tau = controller(command, (u, v, r, env.physics.pose()[2]))
        return np.clip(2 * (tau - low) / (high - low) - 1, -1.0, 1.0)

    return policy


def uniform_random(env, seed: int = 0) -> Policy:
    """Uniform actions in [-1, 1]^2 from its own seeded generator."""
    rng = np.random.default_rng(seed)
    shape = env.action_spec().shape

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        return rng.uniform(-1.0, 1.0, size=shape)

    return policy


def is_goal_task(env) -> bool:
    """Whether the environment exposes the goal-conditioned observations."""
    return "desired_goal" in env.observation_spec()


def classical(env) -> Policy:
    """The classical baseline of a task: S-plane on speed_heading, line of sight elsewhere."""
    return line_of_sight(env) if is_goal_task(env) else splane_tracker(env)
