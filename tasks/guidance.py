"""The classical controllers of the tasks: line-of-sight guidance for the planning tasks and the S-plane
controller (Eq. 32) on speed_heading. Each is a callable `policy(time_step) -> action in [-1, 1]^2` of one
environment; `classical(env)` picks the task's own. `los_avoid(env)` adds the protection domain of
Sec. 3.2.2 (`tasks.avoidance`) to line of sight: the classical local planner a learned one must beat.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import dm_env
import numpy as np

from auv_mj.geometry import wrap_angle
from tasks.avoidance import with_repulsion
from tasks.planning import ACTION_HEADING_RANGE, MAX_SPEED, MIN_SPEED, TARGET_SPEED
from tasks.speed_heading import executor_policy
from tasks.splane import SPlaneController

Policy = Callable[[dm_env.TimeStep], np.ndarray]
CRUISE_ACTION = 2.0 * (TARGET_SPEED - MIN_SPEED) / (MAX_SPEED - MIN_SPEED) - 1.0
"""The speed action a0 commanding the target velocity of Tables 6-8 and 12 (Table 3, forward only)."""


def line_of_sight(env) -> Policy:
    """Heads straight for the current desired goal at the cruise speed; sees no obstacles."""

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        goal = np.asarray(time_step.observation["desired_goal"], dtype=float)
        x, y, psi = env.physics.pose()
        offset = wrap_angle(math.atan2(goal[1] - y, goal[0] - x) - psi)
        return np.array([CRUISE_ACTION, np.clip(offset / ACTION_HEADING_RANGE, -1.0, 1.0)])

    return policy


def los_avoid(env) -> Policy:
    """Line of sight along the route (global path, sub-goals or the straight line to the goal) with the
    protection domain of Sec. 3.2.2 active."""
    return with_repulsion(line_of_sight(env))


def splane_tracker(env) -> Policy:
    """The S-plane controller of Eq. (32) driving (tau_u, tau_r) on the speed_heading task."""
    return executor_policy(env, SPlaneController())


def is_goal_task(env) -> bool:
    """Whether the environment exposes the goal-conditioned observations."""
    return "desired_goal" in env.observation_spec()


def classical(env) -> Policy:
    """The classical baseline of a task: S-plane on speed_heading, line of sight elsewhere."""
    return line_of_sight(env) if is_goal_task(env) else splane_tracker(env)
