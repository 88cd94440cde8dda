"""`bug`: a complete sensor-based planner of the Bug family on the nine sonars (issue 30, part 1's optional one).

The Bug algorithms (Lumelsky & Stepanov 1987; Choset et al., *Principles of Robot Motion*, Ch. 2) alternate two
behaviours: *motion to goal* along the straight line, and *boundary following* round the obstacle that blocks
it, left only at a point nearer the goal than where the obstacle was met. That leave rule is what makes them
complete on static obstacles: each obstacle is left nearer the goal than it was met, so the vehicle cannot
cycle. Here the leave rule is DistBug's (Kamon & Rivlin 1997): leave as soon as the way to the goal is seen free
and the vehicle is LEAVE_MARGIN nearer the goal than at the hit point, not only on Bug2's m-line, which a vehicle
pushed about by the protection domain rarely crosses exactly.

Sensing is what the other classical planners have: the nine sonar ranges (a 180 deg fan ahead), the pose, the
route and the map's edge. A forward fan loses a wall as soon as it is abeam, so the planner keeps the echoes of
the last MEMORY_STEPS scans as points in the world frame (its only memory; no map is built or searched) and
follows the nearest of them.

- *Motion to goal*: line of sight to the current goal, until an echo (now or remembered) lies in the corridor
  CORRIDOR wide along the line to the goal or to the route target (below), nearer than BLOCK_RANGE. The hit
  point's distance to the target is kept. The side is the one whose wall tangent points nearer the target, or
  on a wall met square on, the one TangentBug's heuristic chooses (Kamon, Rivlin & Rimon 1998): towards the end
  of the obstacle, as the fan sees it, that is the shorter way to the goal.
- *Boundary following*: the heading is the tangent of the nearest remembered echo on the wall's side and of the
  same boundary (within CONNECT of the echo followed before), turned towards it or away
  to hold WALL_DISTANCE (proportional, WALL_GAIN, at most WALL_TURN); with its boundary ahead nearer than
  FRONT_CLEAR (a concave corner) it turns away from its side at the full rate. With no echo within FOLLOW_RANGE it arcs
  towards the wall's side (round a corner), and after LOST_STEPS of that it takes the nearest echo on its side
  as its boundary. It leaves as above; after FOLLOW_LIMIT metres without a leave it
  turns and follows the other way, for twice as far, and so on.

It cruises at the top speed inside the speed-aware protection domain with the geofence, as every planner of the
benchmark does (`auv_mj.planners.map_planner`). On a route of many goals (a tunnel) motion to goal heads for the task's
current goal, as line of sight does; a boundary's target (for the hit distance and the leave) is the route point
ROUTE_HORIZON on (`auv_mj.planners.map_planner.route_target`, `map_replan`'s target too), and reaching it also leaves.
"""

from __future__ import annotations

import math
from collections import deque

import dm_env
import numpy as np

from auv_mj.episode import Planner, PlannerBase
from auv_mj.geometry import wrap_angle
from auv_mj.planners.avoidance import SLOW_CONE, map_fence, with_repulsion
from auv_mj.planners.guidance import approach_speed
from auv_mj.planners.map_planner import PROTECTION, route_target, sonar_rays
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_RANGE
from auv_mj.tasks.planning_observation import SONAR_SLICE
from auv_mj.tasks.planning_step import ACTION_HEADING_RANGE

MEMORY_STEPS = 40
"""Scans whose echoes are remembered (20 s at the sonar's 2 Hz): a wall abeam or behind is still followed."""
CORRIDOR = 8.0
"""Half-width [m] of the corridor along the line to the goal that must hold no echo (hull and d_s = 5 m, and
room to spare): an echo in it blocks motion to goal."""
BLOCK_RANGE = 35.0
"""An echo in the corridor nearer than this [m] blocks: at 2 m/s, 17 s to turn (a 90 deg turn takes 7.5 s)."""
LEAVE_RANGE = 60.0
"""The way to the goal counts as free when the corridor is clear this far [m] (or to the goal, if nearer)."""
LEAVE_MARGIN = 2.0
"""The vehicle leaves a boundary only this much [m] nearer the goal than the hit point (the Bug leave rule)."""
WALL_DISTANCE = 14.0
"""Distance [m] boundary following holds to the wall: beyond the protection domain's d_s = 5 m and far enough
that its repulsion (30 m influence) and the follower agree."""
WALL_GAIN = 0.06
"""Heading correction [rad per m] of the distance error to WALL_DISTANCE."""
WALL_TURN = math.pi / 3
"""Largest correction [rad] towards or away from the wall."""
OPEN_JUMP = 2 * CORRIDOR
"""A beam reading this much [m] farther than its neighbour nearer the target's bearing sees past the obstacle."""
SIDE_AHEAD = math.pi / 8
"""Echoes within this [rad] of the bow on the other side still count as the followed wall (a corner ahead)."""
LOST_STEPS = 16
"""Boundary following that has seen no echo of its boundary for this many steps (8 s, a quarter circle of the
arc) forgets it, and follows the nearest echo on its side."""
CONNECT = 20.0
"""Echoes within this [m] of the one followed a step before belong to the same boundary (the fan's beams are
22.5 deg apart: 16 m at 40 m)."""
AHEAD = np.abs(BEAM_ANGLES) <= SLOW_CONE + 1e-9
"""The beams ahead, S4-S6 (the speed-aware domain's slow-down cone)."""
FRONT_CLEAR = 20.0
"""Boundary following with an echo this near [m] in the beams ahead (S4-S6, `auv_mj.planners.avoidance.SLOW_CONE`) turns
away from its wall's side at the full rate: a concave corner (a wedge's apex, a cup's back) is not driven into."""
SIDE_TIE = math.pi / 6
"""The two sides' wall tangents closer than this [rad] in their error to the target's bearing are a tie."""
FOLLOW_RANGE = 40.0
"""Remembered echoes farther than this [m] are no wall to follow: the follower arcs towards its side."""
CORNER_TURN = math.pi / 4
"""Heading offset [rad] of that arc round a corner."""
FOLLOW_LIMIT = 250.0
"""Boundary following turns and goes the other way after this many metres [m] without a leave, then after
twice as many, and so on (a doubling search, which stays complete): a wall followed the long way round (to the
map's edge, or back along a tunnel's wall) is given up."""


def corridor_blocked(points: np.ndarray, position: np.ndarray, goal: np.ndarray, reach: float,
                     half_width: float = CORRIDOR) -> bool:
    """Whether any of `points` (n x 2) lies within `half_width` of the segment from `position` towards `goal`,
    no farther along it than `reach` [m] (nor than the goal)."""
    if len(points) == 0:
        return False
    line = goal - position
    length = float(np.hypot(*line))
    if length < 1e-9:
        return False
    unit = line / length
    rel = points - position
    along = rel @ unit
    across = np.abs(rel @ np.array([-unit[1], unit[0]]))
    return bool(np.any((along > 0.0) & (along < min(reach, length)) & (across < half_width)))


def follow_heading(points: np.ndarray, position: np.ndarray, psi: float, side: int,
                   anchor: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """Boundary following's heading [rad, world] and the echo it follows: the tangent of the nearest of `points`
    on the wall's side `side` (+1 port, -1 starboard; ahead within SIDE_AHEAD counts on either), bent to hold
    WALL_DISTANCE; an arc towards `side` (and no echo) with no such wall in FOLLOW_RANGE. With an `anchor` (the
    echo followed a step before) only echoes within CONNECT of it count: the boundary is followed, not whatever
    is nearest (a tunnel's far wall, another obstacle)."""
    if len(points):
        rel = points - position
        bearings = np.arctan2(rel[:, 1], rel[:, 0]) - psi
        bearings = (bearings + np.pi) % (2 * np.pi) - np.pi
        usable = side * bearings > -SIDE_AHEAD
        if anchor is not None:
            usable &= np.hypot(*(points - anchor).T) < CONNECT
        distances = np.where(usable, np.hypot(*rel.T), np.inf)
        k = int(np.argmin(distances))
        if distances[k] <= FOLLOW_RANGE:
            towards = math.atan2(rel[k, 1], rel[k, 0])
            correction = float(np.clip(WALL_GAIN * (distances[k] - WALL_DISTANCE), -WALL_TURN, WALL_TURN))
            return towards - side * (math.pi / 2) + side * correction, points[k].copy()
    return psi + side * CORNER_TURN, anchor


class BugPlanner(PlannerBase):
    """Motion to goal and boundary following on the sonar's remembered echoes (module docstring)."""

    def __init__(self, env):
        self.env = env
        self.reset()

    def reset(self) -> None:
        """Forgets the echoes and the mode (the next step starts a new episode)."""
        self.echoes: deque[np.ndarray] = deque(maxlen=MEMORY_STEPS)
        self.following = False
        self.side = 1
        self.leg: tuple[np.ndarray, int] | None = None
        """The boundary's target and its index on the route, fixed from the hit until the leave."""
        self.hit_distance = math.inf
        self.followed = 0.0
        self.flips = 0
        self.anchor: np.ndarray | None = None
        """The echo boundary following followed last (`follow_heading`)."""
        self.lost = 0
        """Steps since boundary following last saw an echo of its boundary."""
        self.last: np.ndarray | None = None

    def sense(self, time_step: dm_env.TimeStep, pose: np.ndarray) -> np.ndarray:
        """Adds this scan's echoes to the memory; the nine ranges [m]."""
        ranges = np.asarray(time_step.observation["observation"])[SONAR_SLICE] * SONAR_RANGE
        origin, directions = sonar_rays(pose)
        hit = ranges < SONAR_RANGE - 1e-6
        self.echoes.append(origin + ranges[hit, None] * directions[hit])
        return ranges

    def choose_side(self, ranges: np.ndarray, position: np.ndarray, psi: float, target: np.ndarray) -> int:
        """+1 (wall on port: turn to starboard) or -1, by TangentBug's heuristic: on each side of the target's
        bearing the blocking obstacle ends at the last echo before a beam that sees OPEN_JUMP farther (a
        discontinuity of the range); the side whose end point O minimises |x - O| + |O - target| is taken. A
        side whose beams never open scores infinity; with neither open, the side of the farther free water."""
        x, y = position
        origin, directions = sonar_rays((x, y, psi))
        bearing = wrap_angle(math.atan2(target[1] - y, target[0] - x) - psi)
        centre = int(np.argmin(np.abs(BEAM_ANGLES - np.clip(bearing, BEAM_ANGLES[0], BEAM_ANGLES[-1]))))
        blocking = float(ranges[centre])
        scores = {}
        for side, step in ((1, -1), (-1, 1)):  # starboard beams are the lower indices: turning starboard
            score, k = math.inf, centre
            while 0 <= k + step < len(ranges):
                if ranges[k + step] > min(ranges[k], blocking) + OPEN_JUMP:
                    end = origin + ranges[k] * directions[k]
                    score = float(np.hypot(*(end - position)) + np.hypot(*(target - end)))
                    break
                k += step
            scores[side] = score
        if math.isinf(scores[1]) and math.isinf(scores[-1]):
            return 1 if ranges[:centre].max(initial=0.0) >= ranges[centre + 1:].max(initial=0.0) else -1
        return 1 if scores[1] <= scores[-1] else -1

    def hit_boundary(self, ranges: np.ndarray, points: np.ndarray, position: np.ndarray, psi: float) -> None:
        """Motion to goal is blocked: boundary following towards the route target, from here. The side is the
        one whose wall tangent points nearer the target by more than SIDE_TIE (a wall met obliquely, a tunnel's
        wall at a bend: not back the way the vehicle came); on a wall met square on, `choose_side`'s."""
        target, _, index = route_target(self.env.task)
        target = np.asarray(target, float)
        bearing = math.atan2(target[1] - position[1], target[0] - position[0])
        errors = {s: abs(wrap_angle(follow_heading(points, position, psi, s)[0] - bearing)) for s in (1, -1)}
        if abs(errors[1] - errors[-1]) > SIDE_TIE:
            side = 1 if errors[1] < errors[-1] else -1
        else:
            side = self.choose_side(ranges, position, psi, target)
        self.following, self.side, self.anchor, self.lost = True, side, None, 0
        self.leg, self.hit_distance = (np.array(target, float), index), float(np.hypot(*(target - position)))
        self.followed, self.flips = 0.0, 0

    def may_leave(self, points: np.ndarray, position: np.ndarray) -> bool:
        """The leave rule: the task's goal has reached the leg's target, or the vehicle is LEAVE_MARGIN nearer
        the target than at the hit and sees the way to it free."""
        target, index = self.leg
        if self.env.task.goal_index >= index and len(self.env.task.goals) > 1:
            return True
        distance = float(np.hypot(*(target - position)))
        return distance <= self.hit_distance - LEAVE_MARGIN and not corridor_blocked(points, position, target,
                                                                                     LEAVE_RANGE)

    def corner_ahead(self, ranges: np.ndarray, pose: np.ndarray) -> bool:
        """Whether a beam ahead sees the followed boundary (within CONNECT of its echo) nearer than FRONT_CLEAR:
        a concave corner of it (a wedge's apex, a cup's back), where following turns away at the full rate. A
        wall ahead of another body (a tunnel's far wall at a bend) is left to the tangent and the domain."""
        if self.anchor is None:
            return False
        near = AHEAD & (ranges < FRONT_CLEAR)
        if not near.any():
            return False
        origin, directions = sonar_rays(pose)
        echoes = origin + ranges[near, None] * directions[near]
        return bool(np.any(np.hypot(*(echoes - self.anchor).T) < CONNECT))

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first():
            self.reset()
        pose = np.array(self.env.physics.pose(), dtype=float)
        position, psi = pose[:2], float(pose[2])
        goal = np.asarray(time_step.observation["desired_goal"], dtype=float)[:2]
        ranges = self.sense(time_step, pose)
        points = np.vstack(self.echoes)
        if self.following:
            self.followed += float(np.hypot(*(position - self.last)))
            if self.may_leave(points, position):
                self.following = False
            elif self.followed > FOLLOW_LIMIT * 2 ** self.flips:  # the doubling search: turn and go the other way
                self.side, self.followed, self.flips = -self.side, 0.0, self.flips + 1
        elif (corridor_blocked(points, position, goal, BLOCK_RANGE)
              or corridor_blocked(points, position, np.asarray(route_target(self.env.task)[0], float),
                                  BLOCK_RANGE)):
            self.hit_boundary(ranges, points, position, psi)
        self.last = position.copy()
        if self.following:
            heading, anchor = follow_heading(points, position, psi, self.side, self.anchor)
            if self.corner_ahead(ranges, pose):
                heading = psi - self.side * math.pi / 2
            self.lost = 0 if anchor is not self.anchor else self.lost + 1
            self.anchor = anchor if self.lost < LOST_STEPS else None
        else:
            heading = math.atan2(goal[1] - position[1], goal[0] - position[0])
        offset = wrap_angle(heading - psi)
        return np.array([approach_speed(self.env.task, pose),
                         float(np.clip(offset / ACTION_HEADING_RANGE, -1.0, 1.0))])


def bug_planner(env) -> Planner:
    """The Bug planner (module docstring) without the protection domain: `bug` adds it."""
    planner = BugPlanner(env)

    return planner


def bug(env) -> Planner:
    """The Bug planner inside the speed-aware domain with the geofence."""
    return with_repulsion(bug_planner(env), PROTECTION, map_fence(env))
