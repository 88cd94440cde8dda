"""The classical controllers of the tasks: line-of-sight guidance for the planning tasks and the S-plane
controller (Eq. 32) on speed_heading. Each is a callable `policy(time_step) -> action in [-1, 1]^2` of one
environment; `classical(env)` picks the task's own. `los_avoid(env)` adds the protection domain of
Sec. 3.2.2 (`auv_mj.planners.avoidance`) to line of sight: the classical local planner a learned one must beat.

A residual planner (ours, after residual RL: Johannink et al. 2019, Silver et al. 2018) builds on line of
sight: `guided_action` reads its action a = (a0, a1) as the speed a0 (as any planner's) and a correction
to line of sight's heading offset, offset = clip(h_LOS + residual * a1, -1, 1). A zero action is line of
sight at the cruise speed, exactly; with the protection domain on top, `los-avoid`. The correction depends
on the goal, so hindsight relabelling cannot reuse such transitions (train them with `ddpg`).

With `speed="top"` (issue 30) the speed is a correction too: V action = clip(base + a0, -1, 1), the base the
classical planners' speed (`approach_speed`: the top cruise speed, 2 m/s, slowing to the target speed near a
small final goal); with `speed="fixed"` the speed is that base and a0 is unused (the planner steers only). A
zero action is then exactly the classical planner it corrects: on the map's virtual goal
(`auv_mj.planners.map_planner.MapGuide`) inside the speed-aware domain, `map-replan`.
"""

from __future__ import annotations

import math

import dm_env
import numpy as np

from auv_mj.control.splane import SPlaneController
from auv_mj.episode import FunctionPlanner, Planner
from auv_mj.geometry import wrap_angle
from auv_mj.planners.avoidance import with_repulsion
from auv_mj.tasks.planning_step import ACTION_HEADING_RANGE, MAX_SPEED, speed_action
from auv_mj.tasks.routes import TARGET_SPEED
from auv_mj.tasks.speed_heading import executor_policy

CRUISE_ACTION = speed_action(TARGET_SPEED)
"""The speed action a0 commanding the target velocity of Tables 6-8 and 12 (Table 3, forward only)."""
MAX_RESIDUAL = 2.0
"""Largest heading correction span of a residual planner (normalised heading offsets: 2 overrides any
line-of-sight offset)."""
TOP_SPEED_ACTION = speed_action(MAX_SPEED)
"""The speed action a0 of the top cruise speed, 2 m/s (Table 3, forward only)."""
APPROACH = 30.0
"""Within this distance [m] of a small final goal (radius under APPROACH_RADIUS) the classical planners slow to
the target speed, 1 m/s, halving the turn radius (19 m at 2 m/s): a point inside the turning circle is reached,
not orbited."""
APPROACH_RADIUS = 5.0
"""Goals at least this wide [m] (the 12.5 m target areas) are reached at full speed."""
SPEED_GAINS = {"top": 1.0, "fixed": 0.0}
"""The gain of a residual planner's speed action a0 on `approach_speed` (module docstring): "top", a correction;
"fixed", unused (the speed is `approach_speed`)."""
SPEEDS = ("absolute", *SPEED_GAINS)
"""What a residual planner's speed action a0 is: "absolute", the speed itself (as any planner's), or one of
SPEED_GAINS."""


def heading_action(bearing: float, heading: float, span: float = ACTION_HEADING_RANGE) -> float:
    """A planning action's heading part: the turn from `heading` to `bearing` [rad], wrapped, over the `span` [rad]
    one step may command, clipped to [-1, 1]. Line of sight steers by it in the plane (`los_heading`) and in 3-D
    (`auv_mj.planners.los3d.command_action`)."""
    return float(np.clip(wrap_angle(bearing - heading) / span, -1.0, 1.0))


def los_heading(goal, pose) -> float:
    """Line of sight's heading action: the bearing of `goal` (x, y) from `pose` (x, y, psi), normalised by
    ACTION_HEADING_RANGE and clipped to [-1, 1]."""
    x, y, psi = (float(p) for p in pose[:3])
    return heading_action(math.atan2(float(goal[1]) - y, float(goal[0]) - x), psi)


def line_of_sight(env) -> Planner:
    """Heads straight for the current desired goal at the cruise speed; sees no obstacles."""

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        return np.array([CRUISE_ACTION, los_heading(time_step.observation["desired_goal"], env.physics.pose())])

    return FunctionPlanner(policy)


def approach_speed(task, pose) -> float:
    """TOP_SPEED_ACTION, or the target speed's action within APPROACH of a final goal narrower than
    APPROACH_RADIUS: the classical planners' speed (`auv_mj.planners.map_planner`)."""
    goals = task.goals
    if task.goal_radius < APPROACH_RADIUS and np.hypot(*(goals[-1] - np.asarray(pose)[:2])) < APPROACH:
        return speed_action(TARGET_SPEED)
    return TOP_SPEED_ACTION


def guided_action(action, goal, pose, residual: float, speed: str = "absolute", task=None) -> np.ndarray:
    """A residual planner's action as the task's: heading clip(h_LOS + residual * a1, -1, 1), and speed a0 kept
    ("absolute") or clip(approach_speed + SPEED_GAINS[speed] * a0, -1, 1) in `task` (module docstring); `goal`
    the desired goal, `pose` the vehicle's (x, y, psi)."""
    action = np.array(action, dtype=float)
    action[1] = np.clip(los_heading(goal, pose) + residual * action[1], -1.0, 1.0)
    if speed != "absolute":
        action[0] = np.clip(approach_speed(task, pose) + SPEED_GAINS[speed] * action[0], -1.0, 1.0)
    return action


def checked_speed(speed) -> str:
    """`speed` if it is one of SPEEDS; ValueError naming it otherwise."""
    if not isinstance(speed, str) or speed not in SPEEDS:
        raise ValueError(f"speed must be one of {list(SPEEDS)}, got {speed!r}")
    return speed


def los_avoid(env) -> Planner:
    """Line of sight along the route (global path, sub-goals or the straight line to the goal) with the
    protection domain of Sec. 3.2.2 active."""
    return with_repulsion(line_of_sight(env))


def splane_tracker(env) -> Planner:
    """The S-plane controller of Eq. (32) driving (tau_u, tau_r) on the speed_heading task."""
    return executor_policy(env, SPlaneController())


def is_goal_task(env) -> bool:
    """Whether the environment exposes the goal-conditioned observations."""
    return "desired_goal" in env.observation_spec()


def classical(env) -> Planner:
    """The classical baseline of a task: S-plane on speed_heading, line of sight elsewhere."""
    return line_of_sight(env) if is_goal_task(env) else splane_tracker(env)
