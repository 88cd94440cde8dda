"""Line of sight in 3-D and the protection domain on the 3-D fan: the classical planners of the 6-DOF domain.

- `los_policy`: line-of-sight guidance in 3-D (Fossen 2011, Ch. 10; the geometry is the task's
  `auv_mj.control.depth_heading.los_command`) to the goal, or along the tube, as a planning policy.
- `protect_command`: the protection domain of Sec. 3.2.2 (`auv_mj.planners.avoidance.RepulsiveField`) on the 3-D
  fan: the level row's echoes bend the heading as in the plane, the down and up rows' echoes push the depth command
  up or down.
- `classical_3d`: the baseline of an auv3d environment (`--policy splane`, `--policy los-avoid`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from auv_mj.control.depth_heading import los_command
from auv_mj.episode import FunctionPlanner, Planner
from auv_mj.geometry import wrap_angle
from auv_mj.planners.avoidance import RepulsiveField
from auv_mj.sim.sensors3d import FAN_AZIMUTHS, FAN_ELEVATIONS
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks.auv3d import (
    CRUISE_SPEED,
    DEPTH_RANGE,
    HEADING_RANGE,
    LOOKAHEAD,
    MAX_SPEED,
    TUBE_INFLUENCE,
    DepthHeading,
    Tunnel3D,
    splane_policy,
)

TUBE_FIELD = RepulsiveField(influence=TUBE_INFLUENCE)
"""The protection domain inside a tube: echoes of the near wall repel only within TUBE_INFLUENCE."""


def protect_command(command: Sequence[float], heading: float, ranges: np.ndarray,
                    field: RepulsiveField | None = None, depth_gain: float = 1.0) -> tuple[float, float, float]:
    """`command` (V, psi, depth) bent away from the fan's echoes (27 ranges, `auv_mj.sim.sensors3d` order).

    Heading: the planar repulsion (Eq. 22 gradient) of the level row's nine beams on the offset psi_cmd - psi.
    Depth: each down-row echo nearer than the domain pushes the depth command up by depth_gain (1/d - 1/d0) k
    metres, each up-row echo pushes it down; the lift is scaled to metres by the vehicle's look-ahead, d0.
    """
    field = field or RepulsiveField()
    speed, psi_cmd, depth_cmd = (float(c) for c in command)
    rows = np.asarray(ranges, dtype=float).reshape(len(FAN_ELEVATIONS), len(FAN_AZIMUTHS))
    level = int(np.argmin(np.abs(FAN_ELEVATIONS)))
    offset = field.heading_offset(rows[level], wrap_angle(psi_cmd - heading))
    push = 0.0
    for row, sign in ((0, -1.0), (len(FAN_ELEVATIONS) - 1, 1.0)):  # down row lifts (less depth), up row sinks
        near = rows[row][rows[row] < min(field.influence, SONAR_RANGE)]
        if near.size:
            d = np.maximum(near, 0.5)
            push += sign * depth_gain * field.influence * float(np.max(1.0 / d - 1.0 / field.influence))
    return speed, wrap_angle(heading + offset), depth_cmd + push


def los_policy(env, avoid: bool = False) -> Planner:
    """Line of sight in 3-D (to the goal, or along the tube) as a planning policy; `avoid` adds the protection
    domain on the 3-D fan (`los-avoid`)."""
    task, physics = env.task, env.physics
    field = TUBE_FIELD if isinstance(task, Tunnel3D) else None

    def policy(time_step) -> np.ndarray:
        position = physics.position()
        if len(task.path) >= 2:
            command = los_command(position, task.path, LOOKAHEAD, CRUISE_SPEED)
        else:
            offset = task.goal - position
            command = (CRUISE_SPEED, math.atan2(offset[1], offset[0]), -float(task.goal[2]))
        if avoid:
            command = protect_command(command, physics.heading(), task.sensors.read(physics)["sonar"], field)
        return command_action(command, physics)

    return FunctionPlanner(policy)


def command_action(command: Sequence[float], physics) -> np.ndarray:
    """The planning action (a_speed, a_heading, a_depth) in [-1, 1]^3 that asks the executor for `command`
    (V [m/s], psi [rad], depth [m]) from the vehicle's heading and depth now (clipped where it lies beyond one
    step's range)."""
    heading_offset = wrap_angle(command[1] - physics.heading()) / HEADING_RANGE
    depth_offset = (command[2] - physics.depth()) / DEPTH_RANGE
    return np.clip([2.0 * command[0] / MAX_SPEED - 1.0, heading_offset, depth_offset], -1.0, 1.0)


def classical_3d(env, avoid: bool = False) -> Planner:
    """The classical baseline of an auv3d environment: the S-plane depth-heading executor on depth_heading;
    line of sight in 3-D on the classical executor on goal3d and tunnel3d, inside the protection domain on the
    3-D fan if `avoid` (the app's `--policy splane` and `--policy los-avoid`)."""
    if isinstance(env.task, DepthHeading):
        if avoid:
            raise ValueError("los-avoid is a planner: it runs on goal3d and tunnel3d, not on depth_heading")
        return splane_policy(env)
    return los_policy(env, avoid=avoid)
