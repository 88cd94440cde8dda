"""Line of sight in 3-D and the protection domain on the 3-D fan: the classical planners of the 6-DOF domain.

- `los_policy`: line-of-sight guidance in 3-D (Fossen 2011, Ch. 10; the geometry is the task's
  `auv_mj.control.depth_heading.los_command`) to the goal, or along the tube, as a planning policy.
- `protect_command`: the protection domain of Sec. 3.2.2 (`auv_mj.planners.avoidance.RepulsiveField`) on the 3-D
  fan: the level row's echoes bend the heading as in the plane, the down and up rows' echoes push the depth command
  up or down.
- `FanFilter` (`auv_mj.sim.sensors3d`): the fan as a tube's domain reads it, each beam the nearer of its newest ping
  and its median over the last FILTER_PINGS, so that one lost echo or one range that jumps away does not turn the
  vehicle towards the wall (ocean water loses 5 % of echoes, `auv_mj.sim.ocean.SonarNoise`), while an echo that
  comes nearer is heard at once. `domain_ranges` applies it in a tube only (its docstring says why).
- `CrabEstimate`: the angle between the vehicle's course over ground and its heading, from the DVL, so that line of
  sight on a planned path can command the course it means (a cross current otherwise holds the vehicle off its
  path; `auv_mj.planners.map_planner3d`).
- `domain_field`: the domain of a task, sized to the tube the vehicle is in (`tube_field`): the paper's domain
  shrunk to TUBE_DOMAIN_SHARE of the tube's radius, its gain k_2 with it, so that it reacts to the wall the way the
  open-water domain reacts to an obstacle at the same share of its reach.
- `classical_3d`: the baseline of an auv3d environment (`--policy splane`, `--policy los-avoid`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from auv_mj.control.depth_heading import los_command
from auv_mj.episode import FunctionPlanner, Planner
from auv_mj.geometry import wrap_angle
from auv_mj.planners.avoidance import RepulsiveField
from auv_mj.planners.guidance import heading_action
from auv_mj.sim.sensors3d import FAN_AZIMUTHS, FAN_ELEVATIONS, FanFilter
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks.auv3d import (
    CRUISE_SPEED,
    DEPTH_RANGE,
    HEADING_RANGE,
    LOOKAHEAD,
    MAX_SPEED,
    DepthHeading,
    Planning3D,
    splane_policy,
)

OPEN_FIELD = RepulsiveField()
"""The protection domain in open water: the paper's (d0 = 30 m, k_2 = 120; `RepulsiveField`)."""
TUBE_DOMAIN_SHARE = 0.6
"""A tube's domain reaches this share of the tube's inner radius R (d0 = 0.6 R: 1.8 m in the standard 3 m tube, 3 m
in a hard 5 m one, 1.2 m in a user's 4 m wide tube): a vehicle on the centreline has no wall inside its domain,
and one that has drifted 0.4 R off it has. The fixed d0 = 2.5 m it replaces reached past a 2 m radius (a 4 m tube),
where both walls repelled at once. On 10 validation tubes in ocean water (seeds 20000-20009, `los-avoid`), 0.5, 0.6
and 0.8 each passed 10 of 10 standard tubes (least clearance 1.09, 1.26 and 1.53 m) and 2, 2 and 1 of 10 hard ones
(docs/benchmark.md); 0.6 was set before the scan and kept."""
CRAB_GAIN = 0.2
"""Weight of each planner step's DVL crab angle in `CrabEstimate`'s average (0.5 s steps: a time constant of 2.2 s)."""
CRAB_MIN_SPEED = 0.5
"""Below this forward speed over the ground [m/s] `CrabEstimate` keeps its angle ..."""
CRAB_MAX_RATE = 0.05
"""... and above this yaw rate [rad/s] (3 deg/s; a 30 m circle at cruise speed)."""


def tube_field(radius: float) -> RepulsiveField:
    """The protection domain in a tube of inner radius `radius` [m]: the open-water domain scaled to it.

    d0 = TUBE_DOMAIN_SHARE * radius, and k_2 scaled by (d0 / 30 m)^2: the Eq. (22) gradient k_2 (1/d - 1/d0) / d is
    then the open-water one at d / d0 the same, so a wall at a third of the tube's domain bends the heading as an
    obstacle at a third of the open-water domain does. The paper's k_2 = 120 on a 2.5 m domain (the domain this
    replaces) bent the heading 45 deg, at right angles to the wall, for a wall 0.2 m inside the domain: in ocean
    water, where the vehicle drifts 1 to 2 m off the centreline, it swung from wall to wall until it hit one."""
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"a tube's radius must be a positive number of metres, got {radius!r}")
    influence = TUBE_DOMAIN_SHARE * float(radius)
    scale = influence / OPEN_FIELD.influence
    return RepulsiveField(influence=influence, gain=OPEN_FIELD.gain * scale * scale)


def domain_field(task: Planning3D, open_water: RepulsiveField = OPEN_FIELD) -> RepulsiveField:
    """The protection domain of a 3-D planning task now: in a tube (tunnel3d), the tube's (`tube_field` of the
    radius of the tube the vehicle is in), elsewhere `open_water`."""
    radius = getattr(task, "tube_radius", None)
    return tube_field(radius) if radius is not None else open_water


class CrabEstimate:
    """The crab angle beta = chi - psi [rad] (course over ground minus heading) a current sets, from the DVL.

    Line of sight aims the heading at a point LOOKAHEAD ahead on the path; in a cross current the vehicle then flies
    a course beta off its heading and settles where the look-ahead point's bearing is off the path by beta, a cross-
    track error of LOOKAHEAD tan(beta): 1.3 m for the ocean's 0.25 m/s across a 1.5 m/s vehicle on a tube's 8 m
    look-ahead, more than a tube's clearance. Commanding the heading psi_d = chi_d - beta instead flies the course
    line of sight means (Fossen 2011, *Handbook of Marine Craft Hydrodynamics and Motion Control*, Sec. 10.3.2, the
    crab angle measured by a velocity-over-ground sensor). beta = atan2(v, u) of the DVL's body-frame velocity over
    the ground, averaged with weight CRAB_GAIN per planner step (a time constant of some 2 s: the DVL's noise is
    smoothed, the current's drift over minutes followed). It is measured in straight flight only (yaw rate below
    CRAB_MAX_RATE) and held through turns: in a turn the hull slips sideways by itself (and the DVL, aft of the
    centre, with it), and turning harder to undo that slip feeds the turn (the oracle hit a plug in ideal water,
    validation seed 20002 of the hard tubes, when it did); below CRAB_MIN_SPEED it is held too (atan2 of a slow
    vehicle's velocity is noise)."""

    def __init__(self, gain: float = CRAB_GAIN):
        if not 0.0 < gain <= 1.0:
            raise ValueError(f"a crab estimate's gain must be in (0, 1], got {gain!r}")
        self.gain = gain
        self.reset()

    def reset(self) -> None:
        """Forgets the angle (a new episode)."""
        self.angle = 0.0

    def __call__(self, sensed: Mapping[str, np.ndarray]) -> float:
        """The crab angle [rad] after the sensors' held samples (`auv_mj.sim.sensors3d.Sensors3D.read`): the DVL's
        (u, v, w) [m/s] over the ground and the gyro's (p, q, r) [rad/s], both in the body frame."""
        u, v = (float(x) for x in sensed["dvl"][:2])
        if u > CRAB_MIN_SPEED and abs(float(sensed["gyro"][2])) < CRAB_MAX_RATE:
            self.angle += self.gain * wrap_angle(math.atan2(v, u) - self.angle)
        return self.angle


def domain_ranges(task: Planning3D, fan: FanFilter, time: float, ranges: np.ndarray) -> np.ndarray:
    """The fan's ranges [m] as the protection domain of `task` reads them now: through `fan` in a tube, as they
    are in open water.

    In a tube the wall is always near and the domain small, so one lost echo of the near wall would turn the
    vehicle towards it for a ping; in open water the domain (15 or 30 m) holds many echoes and the vehicle turns
    fast round obstacles, where a per-beam filter in the body frame smears an echo across the turn: on validation
    (goal3d, standard, ocean, seeds 20000-20009) the filter cost `map-replan` 2 of 10 episodes there."""
    if getattr(task, "tube_radius", None) is None:
        return np.asarray(ranges, dtype=float)
    return fan(time, ranges)


def course_command(command: Sequence[float], crab: float) -> tuple[float, float, float]:
    """(V, psi, depth) `command` whose heading is a course over the ground, as the heading that flies it with the
    vehicle crabbing `crab` [rad] (`CrabEstimate`)."""
    return float(command[0]), wrap_angle(float(command[1]) - crab), float(command[2])


def protect_command(command: Sequence[float], heading: float, ranges: np.ndarray,
                    field: RepulsiveField | None = None, depth_gain: float = 1.0) -> tuple[float, float, float]:
    """`command` (V, psi, depth) bent away from the fan's echoes (27 ranges, `auv_mj.sim.sensors3d` order).

    Heading: the planar repulsion (Eq. 22 gradient) of the level row's nine beams on the offset psi_cmd - psi.
    Depth: each down-row echo nearer than the domain pushes the depth command up by depth_gain (1/d - 1/d0) k
    metres, each up-row echo pushes it down; the lift is scaled to metres by the vehicle's look-ahead, d0, and the
    push is at most d0, so that in a tube it keeps the depth command inside the tube.
    """
    field = field or OPEN_FIELD
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
    push = float(np.clip(push, -field.influence, field.influence))
    return speed, wrap_angle(heading + offset), depth_cmd + push


def los_policy(env, avoid: bool = False) -> Planner:
    """Line of sight in 3-D (to the goal, or along the tube) as a planning policy; `avoid` adds the protection
    domain on the 3-D fan (`los-avoid`).

    It commands the heading at its target, not the course (`CrabEstimate`, which `map-replan` and the oracle use):
    on validation the course cost `los-avoid` hard ocean tubes it had passed by drifting off the centreline, where
    every plug stands (docs/runs/map-replan-3d/README.md), so the reactive baselines fly as they were published."""
    task, physics = env.task, env.physics
    fan = FanFilter()

    def policy(time_step) -> np.ndarray:
        if time_step.first():
            fan.reset()
        position = physics.position()
        if len(task.path) >= 2:
            command = los_command(position, task.path, LOOKAHEAD, CRUISE_SPEED)
        else:
            offset = task.goal - position
            command = (CRUISE_SPEED, math.atan2(offset[1], offset[0]), -float(task.goal[2]))
        if avoid:
            ranges = domain_ranges(task, fan, physics.time(), task.sensors.read(physics)["sonar"])
            command = protect_command(command, physics.heading(), ranges, domain_field(task))
        return command_action(command, physics)

    return FunctionPlanner(policy, fan.reset)


def command_action(command: Sequence[float], physics) -> np.ndarray:
    """The planning action (a_speed, a_heading, a_depth) in [-1, 1]^3 that asks the executor for `command`
    (V [m/s], psi [rad], depth [m]) from the vehicle's heading and depth now (clipped where it lies beyond one
    step's range)."""
    depth_offset = (command[2] - physics.depth()) / DEPTH_RANGE
    return np.clip([2.0 * command[0] / MAX_SPEED - 1.0, heading_action(command[1], physics.heading(), HEADING_RANGE),
                    depth_offset], -1.0, 1.0)


def classical_3d(env, avoid: bool = False) -> Planner:
    """The classical baseline of an auv3d environment: the S-plane depth-heading executor on depth_heading;
    line of sight in 3-D on the classical executor on goal3d and tunnel3d, inside the protection domain on the
    3-D fan if `avoid` (the app's `--policy splane` and `--policy los-avoid`)."""
    if isinstance(env.task, DepthHeading):
        if avoid:
            raise ValueError("los-avoid is a planner: it runs on goal3d and tunnel3d, not on depth_heading")
        return splane_policy(env)
    return los_policy(env, avoid=avoid)
