"""A planning task's route: its goals, the path they lie on, and the geodesic potential along it.

Goals. Every task is a sequence of goals g_0..g_n (Sec. 3.2.4): `desired_goal` is the current one, and
reaching it (within the task's goal radius) makes the next one current; reaching a later one kills every
goal before it. Reaching the last is success. GOAL_RADIUS = 12.5 m is the 25 m target area of Tables 6-8
(goal, waypoints, obstacles, moving_obstacles); SUBGOAL_RADIUS = 2 m is Table 1's L_target <= 2 m for the
virtual sub-goals of a global path (tunnel, path_line, path_curve), spaced SUBGOAL_SPACING apart. On a
global path (routes with `pass_corridor`) a sub-goal other than the last also dies once the vehicle is
past it (ahead of it along the path, within PASS_CORRIDOR across it), with no +4: a vehicle that went
around an obstacle on the path goes on rather than turning back. The batched step applies these rules
(`auv_mj.tasks.planning_step.goals_hit`, `goals_passed`).

Geometry of routes: `discretise` spaces the virtual sub-goals along a path, `path_length`, `distances_to_polylines`
(the cross-track error), random starts and goals inside a map, the time limit a route's length asks for
(`route_time_limit`), and the route target the planners aim at (`route_target_index`). `RoutePotential` is the
potential of reward="geodesic" (`auv_mj.tasks.planning_rewards`, "The geodesic reward"): the route length left on the
arena's true static map, from one geodesic field per leg (`auv_mj.arenas.geodesic`; searched at the reset by
`auv_mj.tasks.planning.route_potential`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from auv_mj.arenas import arena
from auv_mj.arenas.geodesic import Field

TARGET_SPEED = 1.0
"""Target velocity of every experiment [m/s] (Tables 6-8, 12); sizes the time limits."""

GOAL_RADIUS = 12.5
"""Radius of a target area [m]: Tables 6-8's target area diameter of 25 m."""
SUBGOAL_RADIUS = 2.0
"""Radius of a virtual sub-goal on a global path [m] (Table 1: L_target <= 2 m)."""
MAX_GOAL_RADIUS = 50.0
"""Largest `goal_radius` a task accepts [m]: four target areas; beyond it a start can count as the goal."""
SUBGOAL_SPACING = 10.0
"""Largest distance between consecutive virtual sub-goals of a discretised path [m]."""
PASS_CORRIDOR = 15.0
"""A path sub-goal (not the last) also dies once the vehicle is past it, within this distance of it
across the path [m]: it need not turn back to a sub-goal it went around (an obstacle on the path)."""

MAP_MARGIN = 25.0
"""Random starts and goals keep this far inside the map [m]."""
GOAL_DISTANCE_RANGE = (100.0, 400.0)
"""A random goal is this far from the random start [m]."""

ROUTE_HORIZON = 80.0
"""On a route of many goals a planner aims at the route point this far [m] along it from the current goal
(`route_target_index`: `map-replan`'s and `bug`'s target, and the planner observation's)."""

GEODESIC_LEGS = ("each", "last")
"""What the geodesic potential runs to (`PlanningTask.geodesic_legs`): "each" goal of the route in turn (target areas,
a path to follow), or the "last" alone (a tunnel: its sub-goals lie on the axis, which runs into each trap's mouth)."""


def goal_distance(a, b) -> np.ndarray:
    """Distance [m] between (x, y) points along the last axis, elementwise over leading axes."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def discretise(polyline: np.ndarray, spacing: float = SUBGOAL_SPACING) -> np.ndarray:
    """Points along `polyline` (its vertices kept) no more than `spacing` apart: the virtual sub-goals."""
    polyline = np.asarray(polyline, dtype=float).reshape(-1, 2)
    points = [polyline[:1]]
    for a, b in zip(polyline[:-1], polyline[1:], strict=True):
        pieces = max(1, math.ceil(np.hypot(*(b - a)) / spacing - 1e-9))
        points.append(a + (b - a) * (np.arange(1, pieces + 1)[:, None] / pieces))
    return np.concatenate(points)


def path_length(polyline: np.ndarray) -> float:
    """Length of a polyline [m]."""
    return float(np.sum(np.hypot(*np.diff(np.asarray(polyline, dtype=float), axis=0).T)))


def distance_to_polyline(point: np.ndarray, polyline: np.ndarray) -> float:
    """Shortest distance from `point` to the polyline [m] (the cross-track error)."""
    point, polyline = np.asarray(point, dtype=float), np.asarray(polyline, dtype=float)
    return float(distances_to_polylines(point[None], polyline[None])[0])


def distances_to_polylines(points: np.ndarray, polylines: np.ndarray) -> np.ndarray:
    """`distance_to_polyline` of N points (N, 2) to N polylines (N, P, 2) of as many vertices (a shorter one
    padded with its last vertex: a zero-length segment changes no distance)."""
    a, b = polylines[:, :-1], polylines[:, 1:]
    d = b - a
    point = points[:, None, :]
    pa = point - a
    dot = pa[..., 0] * d[..., 0] + pa[..., 1] * d[..., 1]
    length = np.maximum(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1], 1e-12)
    closest = a + np.clip(dot / length, 0, 1)[..., None] * d
    return np.min(np.hypot(closest[..., 0] - point[..., 0], closest[..., 1] - point[..., 1]), axis=1)


def random_point(random: np.random.RandomState, bounds: Sequence[float], margin: float = MAP_MARGIN,
                 avoid: np.ndarray | None = None, min_distance: float = 0.0,
                 max_distance: float = math.inf, tries: int = 1000) -> np.ndarray:
    """A uniform point `margin` inside `bounds`, `min_distance`..`max_distance` from `avoid` if given."""
    low = np.array(bounds[:2], dtype=float) + margin
    high = np.array(bounds[2:], dtype=float) - margin
    for _ in range(tries):
        point = random.uniform(low, high)
        if avoid is None or min_distance <= np.hypot(*(point - avoid)) <= max_distance:
            return point
    raise ValueError(f"no point {min_distance}..{max_distance} m from {avoid} inside {bounds} "
                     f"(margin {margin})")


def random_start_and_goal(random: np.random.RandomState,
                          bounds: Sequence[float]) -> tuple[np.ndarray, float, np.ndarray]:
    """A random start, heading and goal (GOAL_DISTANCE_RANGE apart) inside `bounds`."""
    start = random_point(random, bounds)
    goal = random_point(random, bounds, avoid=start, min_distance=GOAL_DISTANCE_RANGE[0],
                        max_distance=GOAL_DISTANCE_RANGE[1])
    return start, random.uniform(-math.pi, math.pi), goal


def heading_to(start: np.ndarray, target: np.ndarray) -> float:
    """The heading [rad] from `start` towards `target`."""
    return math.atan2(target[1] - start[1], target[0] - start[0])


def route_time_limit(length: float) -> float:
    """A time limit [s] for a route of `length` m: twice its time at TARGET_SPEED plus a minute, in 10 s."""
    return 10.0 * math.ceil((2.0 * length / TARGET_SPEED + 60.0) / 10.0)


@dataclass(frozen=True)
class Route:
    """One episode's layout: start pose, goal sequence, reference path and moving obstacles."""

    start: np.ndarray
    """(x, y) [m]; the vehicle starts at rest."""
    heading: float
    """Initial heading psi [rad]."""
    goals: np.ndarray
    """(n, 2) goals in the order they must be reached [m]; the last is the episode's goal."""
    path: np.ndarray | None = None
    """Reference polyline for the cross-track error [m]; None: from the start through the goals."""
    movers: tuple[arena.Mover, ...] = ()
    """Moving obstacles (mocap bodies of the arena) and their paths."""
    pass_corridor: float | None = None
    """If set, goals but the last also die when passed within this distance across the route [m]."""


@dataclass(frozen=True)
class RoutePotential:
    """The potential of reward="geodesic" on one episode's route: while goal k is current, the route length left is
    fields[leg[k]].distance(position) + rest[k] [m] (`auv_mj.tasks.planning_rewards`, "The geodesic reward")."""

    fields: tuple[Field, ...]
    """The geodesic field of each leg's goal on the arena's true static map (`auv_mj.arenas.geodesic`)."""
    leg: np.ndarray
    """(n,) the field in use while goal k is current."""
    rest: np.ndarray
    """(n,) the route's length [m] beyond that field's goal: the legs after it, each from one goal to the next."""


def route_target_index(goals: np.ndarray, n: np.ndarray, index: np.ndarray) -> np.ndarray:
    """The route target of N routes (goals (N, G, 2), n (N,) goals each, `index` (N,) the current goal's): the first
    goal after the current one that lies ROUTE_HORIZON or more along the route from it, else the last; the goal itself
    on a route of one. What `map-replan` and `bug` aim at (`auv_mj.planners.map_planner.route_target`) and the planner
    observation shows. The route's length is summed leg by leg from the current goal, in order."""
    goals = np.asarray(goals, dtype=float)
    n, index = np.asarray(n, dtype=int), np.asarray(index, dtype=int)
    if goals.shape[1] < 2:
        return n - 1
    legs = np.hypot(goals[:, 1:, 0] - goals[:, :-1, 0], goals[:, 1:, 1] - goals[:, :-1, 1])
    slot = np.arange(legs.shape[1])
    use = (slot >= index[:, None]) & (slot < n[:, None] - 1)
    walked = np.cumsum(np.where(use, legs, 0.0), axis=1)
    far = use & (walked >= ROUTE_HORIZON)
    return np.where(far.any(axis=1), np.argmax(far, axis=1) + 1, n - 1)
