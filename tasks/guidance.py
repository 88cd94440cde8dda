"""The classical controllers of the tasks: line-of-sight guidance for the planning tasks and the S-plane
controller (Eq. 32) on speed_heading. Each is a callable `policy(time_step) -> action in [-1, 1]^2` of one
environment; `classical(env)` picks the task's own. `los_avoid(env)` adds the protection domain of
Sec. 3.2.2 (`tasks.avoidance`) to line of sight: the classical local planner a learned one must beat.

A residual planner (ours, after residual RL: Johannink et al. 2019, Silver et al. 2018) builds on line of
sight: `guided_action` reads its action a = (a0, a1) as the speed a0 (as any planner's) and a correction
to line of sight's heading offset, offset = clip(h_LOS + residual * a1, -1, 1). A zero action is line of
sight at the cruise speed, exactly; with the protection domain on top, `los-avoid`. The correction depends
on the goal, so hindsight relabelling cannot reuse such transitions (train them with `ddpg`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import dm_env
import numpy as np

from auv_mj.geometry import wrap_angle
from tasks.avoidance import with_repulsion
from tasks.planning import ACTION_HEADING_RANGE, TARGET_SPEED, speed_action
from tasks.speed_heading import executor_policy
from tasks.splane import SPlaneController

Policy = Callable[[dm_env.TimeStep], np.ndarray]
CRUISE_ACTION = speed_action(TARGET_SPEED)
"""The speed action a0 commanding the target velocity of Tables 6-8 and 12 (Table 3, forward only)."""
MAX_RESIDUAL = 2.0
"""Largest heading correction span of a residual planner (normalised heading offsets: 2 overrides any
line-of-sight offset)."""


def los_heading(goal, pose) -> float:
    """Line of sight's heading action: the bearing of `goal` (x, y) from `pose` (x, y, psi), normalised by
    ACTION_HEADING_RANGE and clipped to [-1, 1]."""
    x, y, psi = (float(p) for p in pose[:3])
    offset = wrap_angle(math.atan2(float(goal[1]) - y, float(goal[0]) - x) - psi)
    return float(np.clip(offset / ACTION_HEADING_RANGE, -1.0, 1.0))


def line_of_sight(env) -> Policy:
    """Heads straight for the current desired goal at the cruise speed; sees no obstacles."""

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        return np.array([CRUISE_ACTION, los_heading(time_step.observation["desired_goal"], env.physics.pose())])

    return policy


def guided_action(action, goal, pose, residual: float) -> np.ndarray:
    """A residual planner's action as the task's: speed a0 kept, heading clip(h_LOS + residual * a1, -1, 1)
    (module docstring); `goal` the desired goal, `pose` the vehicle's (x, y, psi)."""
    action = np.array(action, dtype=float)
    action[1] = np.clip(los_heading(goal, pose) + residual * action[1], -1.0, 1.0)
    return action


def with_guidance(policy: Policy, env, residual: float) -> Policy:
    """`policy`, a residual planner's, acting in `env` through `guided_action`."""

    def act(time_step: dm_env.TimeStep) -> np.ndarray:
        return guided_action(policy(time_step), time_step.observation["desired_goal"], env.physics.pose(),
                             residual)

    return act


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
