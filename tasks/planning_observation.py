"""What a planning task's policy reads: the observation vectors (Table 2's and ours), one function for a batch.

The task option `observation` picks one: "relative" (default, RELATIVE_FIELDS): the current goal in the body frame, the
motion, the command and the sonar; "paper" (OBSERVATION_FIELDS): Table 2's vector beside the absolute `desired_goal`;
"planner" (ours, issue 51, PLANNER_FIELDS): what the classical planners read (docs/planners.md) -- the route target
ROUTE_HORIZON ahead (`route_target_index`, the rule `map-replan` and `bug` aim by), the pose across the map, the
previous action, the motion, the command, the geofence and the sonar; "planner-map" (ours, PLANNER_MAP_FIELDS): that
vector with the map the vehicle's own sonar has built beside it (`auv_mj.arenas.sonar_memory.SonarMemory`, the map
`map-replan` plans on), cast as MEMORY_BEAMS rays all round the vehicle: what `map-replan` remembers and the sonars no
longer show.

Every vector ends in the nine sonar ranges (SONAR_SLICE). `observe` builds them for N vehicles from the step's arrays
(`auv_mj.tasks.planning_step`: `RouteBatch`, `Readout`), with N = 1 for `PlanningTask.get_observation` and N for the
batched env; the privileged input of a critic is the step's info, not an observation
(`auv_mj.tasks.planning_step.privileged`).
"""

from __future__ import annotations

import numpy as np

from auv_mj.arenas.sonar_memory import MEMORY_NAMES
from auv_mj.geometry import wrap_angle
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_NAMES, SONAR_RANGE, fence_ranges
from auv_mj.tasks.planning_step import (
    GOAL_DISTANCE_SCALE,
    MAX_HEADING_DIFFERENCE,
    MAX_SPEED,
    PLANNER_OBSERVATIONS,
    Readout,
    RouteBatch,
)
from auv_mj.tasks.routes import route_target_index

OBSERVATIONS = ("relative", "paper", "planner", "planner-map")
"""The values of the task option `observation` (module docstring)."""

POSITION_SCALE = 600.0
"""Positions in the observation vector are divided by this [m]."""

OBSERVATION_FIELDS = ("x", "y", "cos_psi", "sin_psi", "u", "v", "r", "heading_command", "speed_command",
                      *SONAR_NAMES)
"""The paper's "observation" vector (observation="paper", Table 2): x, y / POSITION_SCALE; cos, sin psi;
u, v / MAX_SPEED; r [rad/s]; wrap_angle(psi_cmd - psi) / MAX_HEADING_DIFFERENCE; V_cmd / MAX_SPEED; the nine
sonar ranges / SONAR_RANGE. A policy reads it with the absolute `desired_goal` beside it."""
RELATIVE_FIELDS = ("goal_distance", "cos_goal_bearing", "sin_goal_bearing", "u", "v", "r", "heading_command",
                   "speed_command", *SONAR_NAMES)
"""The "relative" observation (the default): what the vehicle could know of itself and its goal, nothing tied
to map coordinates -- the distance to the current goal / GOAL_DISTANCE_SCALE (at most GOAL_DISTANCE_CLIP),
the goal's bearing in the body frame (cos, sin), then u, v, r, the command and the sonar as in the paper's
vector. The goal is inside the observation, so a policy reads this vector alone (`goal_in_observation`)."""
FENCE_NAMES = tuple(f"fence_{k + 1}" for k in range(len(BEAM_ANGLES)))
"""The map's edge as each sonar beam would read it were it a wall (the geofence, `map_fence`), S1..S9's directions."""
PLANNER_FIELDS = ("target_distance", "cos_target_bearing", "sin_target_bearing", "map_x", "map_y", "cos_psi",
                  "sin_psi", "previous_speed_action", "previous_heading_action", "u", "v", "r", "heading_command",
                  "speed_command", *FENCE_NAMES, *SONAR_NAMES)
"""The "planner" observation (issue 51): what the classical planners read (docs/planners.md), for a learner that must
beat them. target_distance, cos and sin of target_bearing: the route target, the goal or on a route of many goals the
route point ROUTE_HORIZON on (`route_target_index`, the one rule `map-replan` and `bug` aim by), as the relative
observation gives its goal (distance / GOAL_DISTANCE_SCALE capped at GOAL_DISTANCE_CLIP, body-frame bearing); map_x,
map_y: the position across the arena's `arena_bounds`, each in [-1, 1] (x / POSITION_SCALE where an arena has none),
and cos, sin psi -- the pose the planners place their map by (`env.physics.pose()`), in the map's own frame, which the
route target and the geofence are measured in too; the previous action (a0, a1) (0 before the first step); u, v, r,
the heading and speed commands as in the paper's vector; fence_1..fence_9: the geofence / SONAR_RANGE (`map_fence`,
what the planners' protection domain adds to the echoes); then the nine sonar ranges / SONAR_RANGE (last, as in
every observation: SONAR_SLICE). No goal coordinates: `desired_goal` is for rewards and relabelling only."""
PLANNER_MAP_FIELDS = (*PLANNER_FIELDS[:-len(SONAR_NAMES)], *MEMORY_NAMES, *SONAR_NAMES)
"""The "planner-map" observation: PLANNER_FIELDS with memory_1..memory_16 before the sonar block -- the sonar map's
scan (`SonarMemory.scan`: the range / MEMORY_RANGE to the nearest occupied cell along each of MEMORY_BEAMS rays from
the vehicle's centre, ray k at psi + k 22.5 deg, 1 where the map holds nothing within MEMORY_RANGE), the map updated
with this step's ping (the sensed ranges, cast from the sonars' origin at the pose of now, as `map-replan` casts
them) before it is read."""

GOAL_DISTANCE_CLIP = 5.0
"""Distances to the goal / GOAL_DISTANCE_SCALE are capped here (500 m): far goals differ only in bearing."""
SONAR_SLICE = slice(-len(SONAR_NAMES), None)
"""The nine sonar ranges / SONAR_RANGE end both observation vectors."""


def relative_goal(achieved_goal, desired_goal) -> np.ndarray:
    """The goal features of the relative observation from the pose (x, y, cos psi, sin psi) and the goal:
    (distance / GOAL_DISTANCE_SCALE capped at GOAL_DISTANCE_CLIP, cos and sin of the body-frame bearing)."""
    achieved, desired = np.asarray(achieved_goal, dtype=float), np.asarray(desired_goal, dtype=float)
    dx, dy = desired[..., 0] - achieved[..., 0], desired[..., 1] - achieved[..., 1]
    c, s = achieved[..., 2], achieved[..., 3]
    forward, left = c * dx + s * dy, -s * dx + c * dy
    distance = np.hypot(forward, left)
    safe = np.where(distance > 1e-9, distance, 1.0)
    return np.stack([np.minimum(distance / GOAL_DISTANCE_SCALE, GOAL_DISTANCE_CLIP),
                     np.where(distance > 1e-9, forward / safe, 1.0), np.where(distance > 1e-9, left / safe, 0.0)],
                    axis=-1)


def observe(routes: RouteBatch, rows: np.ndarray | slice, reached: np.ndarray, readout: Readout, command: np.ndarray,
            kind: str | bool, action: np.ndarray | None = None,
            memory: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """`PlanningTask.get_observation` of N vehicles, rows `rows` of `routes`: "observation" (of `kind`: "relative"
    RELATIVE_FIELDS, "paper" OBSERVATION_FIELDS, "planner" PLANNER_FIELDS, which reads `action` (N, 2), the last
    step's, "planner-map" PLANNER_MAP_FIELDS, which reads `memory` (N, MEMORY_BEAMS) too, the sonar maps' scans;
    True and False stand for "relative" and "paper"), "achieved_goal" and "desired_goal", each (N, k)."""
    if isinstance(kind, bool | np.bool_):
        kind = "relative" if kind else "paper"
    relative = kind in ("relative", *PLANNER_OBSERVATIONS)
    psi, (u, v, r) = readout.psi, readout.velocity.T
    motion = np.stack([u / MAX_SPEED, v / MAX_SPEED, r, wrap_angle(command[:, 1] - psi) / MAX_HEADING_DIFFERENCE,
                       command[:, 0] / MAX_SPEED], axis=1)
    at = np.minimum(reached, routes.n_goals[rows] - 1)
    line = np.arange(len(reached))
    goal = routes.goals[rows][line, at]
    x, y = readout.position[:, 0], readout.position[:, 1]
    c, s = readout.cos_psi, readout.sin_psi
    sonar = readout.sonar / SONAR_RANGE
    if relative:
        achieved = np.stack([x, y, c, s], axis=1)
        desired = np.concatenate([goal, routes.goal_cos_sin[rows][line, at]], axis=1)
        if kind in PLANNER_OBSERVATIONS:
            head, fence = planner_inputs(routes, rows, at, readout, action)
            scan = [] if kind == "planner" else [np.asarray(memory, dtype=float).reshape(len(at), len(MEMORY_NAMES))]
            vector = np.concatenate([head, motion, fence, *scan, sonar], axis=1)
        else:
            vector = np.concatenate([relative_goal(achieved, desired), motion, sonar], axis=1)
    else:
        achieved, desired = np.stack([x, y], axis=1), goal
        vector = np.concatenate([np.stack([x / POSITION_SCALE, y / POSITION_SCALE, c, s], axis=1), motion, sonar],
                                axis=1)
    return {"observation": vector, "achieved_goal": achieved, "desired_goal": desired}


def remember(memories, readout: Readout, sonar_offset: np.ndarray) -> np.ndarray:
    """Adds the step's ping (`readout.sonar`, the sensed ranges) to each vehicle's sonar map (`memories`, N
    `SonarMemory`) at its pose, its sonars `sonar_offset` (N,) [m] ahead of its centre; the maps' scans (N,
    MEMORY_BEAMS), the "planner-map" observation's memory block."""
    scans = np.empty((len(memories), len(MEMORY_NAMES)))
    for k, memory in enumerate(memories):
        psi = float(readout.psi[k])
        memory.add_ping(readout.position[k], psi, float(sonar_offset[k]), readout.sonar[k])
        scans[k] = memory.scan(readout.position[k], psi)
    return scans


def planner_inputs(routes: RouteBatch, rows: np.ndarray | slice, at: np.ndarray, readout: Readout,
                   action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The planner observation's entries but the motion and sonar blocks (PLANNER_FIELDS): the route target, the pose
    and the previous action (N, 9); and the geofence / SONAR_RANGE (N, 9). Rows `rows` of `routes`, goal `at` (N,)
    current."""
    goals, n = routes.goals[rows], routes.n_goals[rows]
    line = np.arange(len(at))
    target = goals[line, route_target_index(goals, n, at)]
    x, y = readout.position[:, 0], readout.position[:, 1]
    c, s = readout.cos_psi, readout.sin_psi
    pose = np.stack([x, y, c, s], axis=1)
    bounds, has_bounds = routes.bounds[rows], routes.has_bounds[rows]
    span = np.where(has_bounds[:, None], bounds[:, 2:] - bounds[:, :2], 1.0)
    across = 2.0 * (readout.position - bounds[:, :2]) / span - 1.0
    across = np.where(has_bounds[:, None], across, readout.position / POSITION_SCALE)
    offset = routes.sonar_offset[rows]
    origins = readout.position + offset[:, None] * np.stack([c, s], axis=1)
    fence = np.where(has_bounds[:, None], fence_ranges(origins, readout.psi, bounds), SONAR_RANGE)
    head = np.concatenate([relative_goal(pose, target), across, np.stack([c, s], axis=1),
                           np.asarray(action, dtype=float).reshape(len(at), 2)], axis=1)
    return head, fence / SONAR_RANGE
