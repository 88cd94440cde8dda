"""A privileged teacher (issue 51): steering down the episode's geodesic field on the true map, in action="rate".

Learning by Cheating (Chen et al. 2019) trains a sensor-only student on the labels of an expert that sees the world
as it is; DAgger (Ross et al. 2011) asks that expert at the states the student visits. The expert must then be
cheap per step and able to act from any state, not only along its own plan. `geodesic-teacher` is such an expert:
it has no plan to follow, only the geodesic field of the episode (`auv_mj.arenas.geodesic`, the route length left on
the arena's true static map, searched once at the reset by the task, `auv_mj.tasks.routes.RoutePotential`) and the
movers' true positions. Each step, for every vehicle of a batch at once (`teacher_actions`):

- it casts CANDIDATES headings round the current one and samples each ray every SAMPLE_STEP metres out to LOOKAHEAD;
- a sample is blocked where the field's grid is closed (within `grid.HARD_CLEARANCE` of a footprint, or off the
  grid), or where a mover will be when the vehicle gets there (the mover's disc grown by MOVER_MARGIN, moved on at
  its true velocity for the time the vehicle needs to reach the sample);
- the cost of a heading is BLOCKED_COST per blocked sample, plus the route length left at the ray's end, plus
  CLEARANCE_COST per metre that a sample lies inside SAFE_DISTANCE of a closed cell (as the oracle's soft clearance
  keeps its path off the walls), plus TURN_COST per radian of turn;
- it turns the heading command towards the cheapest heading as fast as action="rate" allows (a1 = the change over
  `MAX_HEADING_CHANGE`, clipped to [-1, 1]), and sets the speed from the turn still to make (top speed up to
  SLOW_TURN, down to TURN_SPEED at a right angle), from the blocked samples near the bow (SLOW_SPEED) and, near a
  final goal narrower than APPROACH_RADIUS, the target speed, as the classical planners approach it; there it steers
  straight at the goal where nothing blocks the way, holding its heading while the goal lies inside its turning
  circle (a tunnel's 2 m goal is otherwise circled for ever).

It acts in action="rate", the student's action space (or in the paper's map, "paper", where the task uses it:
Table 3's offset from the heading, `heading_actions`), and its input is privileged: it must never be the input of a
deployed learner. `geodesic_teacher(env)` is its per-env face for the zoo (a dm_env planning task; the geodesic field
is the task's own, under reward="geodesic" or observation="planner", else searched here at the first step), and
`BatchTeacher` drives `auv_mj.tasks.vector.AUVVectorEnv` through its `privileged_state()` read-out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import dm_env
import numpy as np
from scipy import ndimage

from auv_mj.arenas.geodesic import GeodesicField, distances
from auv_mj.episode import PlannerBase
from auv_mj.geometry import wrap_angle
from auv_mj.planners.guidance import APPROACH, APPROACH_RADIUS
from auv_mj.tasks.planning import mover_states, route_potential
from auv_mj.tasks.planning_step import (
    ACTION_HEADING_RANGE,
    MAX_HEADING_CHANGE,
    MAX_SPEED,
    executor_command,
    speed_action,
)
from auv_mj.tasks.routes import TARGET_SPEED, RoutePotential

LOOKAHEAD = 16.0
"""How far [m] along each candidate heading the teacher looks (about 8 s at 2 m/s: a turn of 48 deg at 6 deg a step)."""
SAMPLE_STEP = 2.0
"""Spacing [m] of the samples along a ray (the field's 2 m cell)."""
CANDIDATES = np.deg2rad(np.arange(-150.0, 150.1, 7.5))
"""Headings [rad] the teacher weighs, relative to the vehicle's heading."""
BLOCKED_COST = 1.0e4
"""Cost of one blocked sample: a blocked ray loses to every open one."""
SAFE_DISTANCE = 6.0
"""Samples nearer than this [m] to a closed cell of the field cost CLEARANCE_COST a metre short of it."""
CLEARANCE_COST = 3.0
"""Route metres a metre of lost clearance costs (about the oracle's soft clearance)."""
TURN_COST = 1.0
"""Route metres a radian of turn costs: among equal headings, the straighter."""
MOVER_MARGIN = 6.0
"""A mover's disc is grown by this [m] (the hull and d_s)."""
SLOW_TURN = math.radians(35.0)
"""Turns up to this [rad] are flown at the top speed ..."""
TURN_SPEED = 0.6
"""... and a turn of a right angle or more at this speed [m/s] (linear between): a tighter circle."""
SLOW_SPEED = 0.5
"""Speed [m/s] when even the cheapest heading is blocked within NEAR_BLOCK of the bow."""
NEAR_BLOCK = 6.0
"""Range [m] of the blocked samples that slow the vehicle to SLOW_SPEED."""
CAPTURE_RADIUS = 6.0
"""The turning circle [m] at the approach's TARGET_SPEED and 6 deg a step (4.8 m), to spare: a goal inside it cannot
be reached by turning towards it (the vehicle would circle it), so the teacher holds its heading first."""
CAPTURE_CONE = math.radians(10.0)
"""A goal within this bearing [rad] of the bow is steered at regardless."""

_SAMPLES = np.arange(SAMPLE_STEP, LOOKAHEAD + 1e-9, SAMPLE_STEP)


@dataclass(frozen=True)
class TeacherInput:
    """What the teacher reads of N vehicles (privileged: the true map and movers, never a learner's input)."""

    potentials: Sequence[RoutePotential]
    """(N,) each episode's geodesic potential (`RoutePotential`)."""
    goal_index: np.ndarray
    """(N,) the current goal of each route."""
    position: np.ndarray
    """(N, 2) [m]."""
    psi: np.ndarray
    """(N,) heading [rad]."""
    heading_command: np.ndarray
    """(N,) the executor's heading command [rad] (what action="rate" changes)."""
    movers: Sequence[np.ndarray] = ()
    """(N,) each episode's movers now, (M, 5): x, y, radius [m], vx, vy [m/s]; empty for none."""


_FREE_DISTANCE: dict[int, tuple[GeodesicField, np.ndarray]] = {}
"""Per field (by id, the field kept alive beside it): each cell's distance [m] to the nearest closed cell."""


def free_distance(field: GeodesicField) -> np.ndarray:
    """Each cell's distance [m] to the nearest closed cell of `field` (a Euclidean distance transform, cached)."""
    key = id(field)
    cached = _FREE_DISTANCE.get(key)
    if cached is None or cached[0] is not field:
        if len(_FREE_DISTANCE) > 4096:
            _FREE_DISTANCE.clear()
        cached = (field, ndimage.distance_transform_edt(np.isfinite(field.field)) * field.area.cell)
        _FREE_DISTANCE[key] = cached
    return cached[1]


def _ray_costs(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(blocked (C, S) bool, lost clearance (C, S) [m]) of samples `points` (C, S, 2) on one field."""
    if not isinstance(field, GeodesicField):
        return np.zeros(points.shape[:2], bool), np.zeros(points.shape[:2])
    area = field.area
    cells = np.floor((points - area.origin) / area.cell).astype(int)
    inside = ((cells[..., 0] >= 0) & (cells[..., 1] >= 0)
              & (cells[..., 0] < area.shape[0]) & (cells[..., 1] < area.shape[1]))
    i = np.clip(cells[..., 0], 0, area.shape[0] - 1)
    j = np.clip(cells[..., 1], 0, area.shape[1] - 1)
    room = free_distance(field)[i, j]
    blocked = ~inside | ~np.isfinite(field.field[i, j])
    return blocked, np.maximum(SAFE_DISTANCE - room, 0.0)


def heading_actions(desired: np.ndarray, psi: np.ndarray, command: np.ndarray, kind: str = "rate") -> np.ndarray:
    """The heading action a1 (N,) that turns the heading command towards `desired` [rad] as fast as the action map
    `kind` allows: "rate", the change over MAX_HEADING_CHANGE; "paper", Table 3's offset from the heading psi."""
    if kind == "rate":
        return np.clip(wrap_angle(desired - command) / MAX_HEADING_CHANGE, -1.0, 1.0)
    return np.clip(wrap_angle(desired - psi) / ACTION_HEADING_RANGE, -1.0, 1.0)


def rate_from_paper(action: np.ndarray, psi: float, heading_command: float) -> np.ndarray:
    """The action in action="rate" that gives the executor the very command `action` gives in action="paper" (Table
    3's offset from the heading psi [rad], from the previous heading command [rad]): the same speed action, and the
    command's change over MAX_HEADING_CHANGE (paper's turn is clipped to that change, and both maps then clip the
    command's difference from the heading alike, `executor_command`)."""
    action = np.asarray(action, dtype=float)
    command = executor_command(action[None], np.array([psi]), np.array([heading_command]), "paper")[0, 1]
    return np.array([action[0], np.clip(wrap_angle(command - heading_command) / MAX_HEADING_CHANGE, -1.0, 1.0)])


class InTaskActions(PlannerBase):
    """A planner written for action="paper" (every classical planner of the plane) acting on a planning task of
    either action map: on action="rate" its action is read through `rate_from_paper`, so the executor gets the
    command it would have got (what `auv_mj.jobs.student.PlannerTeacher` labels a rate student with)."""

    def __init__(self, planner, env):
        self.planner, self.env = planner, env

    def reset(self) -> None:
        self.planner.reset()

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        action = np.asarray(self.planner.act(time_step), dtype=float)
        task = self.env.task
        if task.action_kind == "paper":
            return action
        return rate_from_paper(action, float(self.env.physics.pose()[2]), float(task.episode.command[1]))


def teacher_actions(state: TeacherInput, kind: str = "rate") -> np.ndarray:
    """The teacher's actions (N, 2) for N vehicles (module docstring), in the action map `kind` ("rate", the
    student's, or "paper")."""
    n = len(state.potentials)
    actions = np.zeros((n, 2))
    angles = np.asarray(state.psi, float)[:, None] + CANDIDATES[None, :]
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (N, C, 2)
    position = np.asarray(state.position, float).reshape(n, 2)
    points = position[:, None, None, :] + _SAMPLES[None, None, :, None] * directions[:, :, None, :]  # (N, C, S, 2)
    fields, ends, blocked, lost = [], [], [], []
    for k in range(n):
        potential = state.potentials[k]
        field = potential.fields[int(potential.leg[int(state.goal_index[k])])]
        b, lc = _ray_costs(field, points[k])
        movers = state.movers[k] if len(state.movers) > k else np.zeros((0, 5))
        if len(movers):
            arrival = _SAMPLES / MAX_SPEED  # (S,) s: when the vehicle would be at each sample
            centres = movers[:, None, :2] + movers[:, None, 3:5] * arrival[None, :, None]  # (M, S, 2)
            gap = np.hypot(*(points[k][None] - centres[:, None]).transpose(3, 0, 1, 2))  # (M, C, S)
            b = b | np.any(gap < (movers[:, 2] + MOVER_MARGIN)[:, None, None], axis=0)
        fields += [field] * len(CANDIDATES)
        ends.append(points[k, :, -1])
        blocked.append(b)
        lost.append(lc)
    route = distances(fields, np.concatenate(ends)).reshape(n, len(CANDIDATES))
    blocked_a, lost_a = np.asarray(blocked), np.asarray(lost)
    cost = (BLOCKED_COST * blocked_a.sum(-1) + route + CLEARANCE_COST * lost_a.sum(-1) * SAMPLE_STEP
            / LOOKAHEAD + TURN_COST * np.abs(CANDIDATES)[None, :])
    best = np.argmin(cost, axis=1)
    line = np.arange(n)
    desired = angles[line, best]
    command = np.asarray(state.heading_command, float)
    psi = np.asarray(state.psi, float)
    turn = np.abs(CANDIDATES[best])
    share = np.clip((turn - SLOW_TURN) / (math.pi / 2 - SLOW_TURN), 0.0, 1.0)
    speed = MAX_SPEED + (TURN_SPEED - MAX_SPEED) * share
    near = int(np.searchsorted(_SAMPLES, NEAR_BLOCK, side="right"))
    speed = np.where(blocked_a[line, best, :near].any(-1), SLOW_SPEED, speed)
    last = [p.fields[-1] for p in state.potentials]
    goal = np.array([f.goal for f in last]).reshape(n, 2)
    narrow = np.array([f.goal_radius < APPROACH_RADIUS for f in last])
    approach = narrow & (np.hypot(*(goal - position).T) < APPROACH)
    speed = np.where(approach, TARGET_SPEED, speed)
    for k in np.flatnonzero(approach):
        desired[k] = _capture(state.potentials[k].fields[-1], position[k], float(psi[k]), float(desired[k]))
    actions[:, 1] = heading_actions(desired, psi, command, kind)
    actions[:, 0] = speed_action(speed)
    return actions


def _capture(field, position: np.ndarray, psi: float, desired: float) -> float:
    """The heading [rad] near a narrow final goal (a tunnel's 2 m one): straight at the goal where the segment is
    open, unless the goal lies inside the turning circle on that side (CAPTURE_RADIUS), where the vehicle holds its
    heading to widen the gap first; the field's choice `desired` where the segment is blocked."""
    offset = field.goal - position
    distance = float(np.hypot(*offset))
    along = np.arange(0.0, distance, SAMPLE_STEP)[:, None] * offset / max(distance, 1e-9)
    blocked, _ = _ray_costs(field, (position + along)[None])
    if blocked.any():
        return desired
    bearing = wrap_angle(math.atan2(offset[1], offset[0]) - psi)
    side = 1.0 if bearing >= 0 else -1.0
    centre = position + CAPTURE_RADIUS * side * np.array([-math.sin(psi), math.cos(psi)])
    if np.hypot(*(field.goal - centre)) < CAPTURE_RADIUS and abs(bearing) > CAPTURE_CONE:
        return psi
    return psi + bearing


class GeodesicTeacher(PlannerBase):
    """The teacher on one dm_env planning task (module docstring): its action in action="rate"."""

    def __init__(self, env):
        self.env = env
        self._potential: RoutePotential | None = None

    def reset(self) -> None:
        self._potential = None

    def potential(self) -> RoutePotential:
        """The episode's geodesic potential: the task's own, or searched here once an episode."""
        task = self.env.task
        own = task.episode.potential
        if own is not None:
            return own
        if self._potential is None:
            self._potential = route_potential(self.env.physics, task, task.geodesic_legs)
        return self._potential

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first():
            self._potential = None
        task, physics = self.env.task, self.env.physics
        pose = np.asarray(physics.pose(), dtype=float)
        state = TeacherInput(potentials=[self.potential()], goal_index=np.array([task.episode.goal_index]),
                             position=pose[None, :2], psi=pose[None, 2],
                             heading_command=np.array([task.episode.command[1]]),
                             movers=[mover_states(physics, task)])
        return teacher_actions(state, self.env.task.action_kind)[0]


def checked_reach(mover_reach: float | None) -> float | None:
    """`BatchTeacher`'s mover_reach, checked: None, or a finite distance > 0 [m] (ValueError naming it else)."""
    if mover_reach is not None and not (isinstance(mover_reach, (int, float)) and math.isfinite(mover_reach)
                                        and mover_reach > 0):
        raise ValueError(f"mover_reach: a distance > 0 [m] or None, got {mover_reach!r}")
    return None if mover_reach is None else float(mover_reach)


def near_movers(position: np.ndarray, movers: Sequence[np.ndarray], reach: float) -> np.ndarray:
    """(N,) bool: whether a mover's disc comes within `reach` [m] of each vehicle `position` (N, 2) now (`movers`:
    each row's (M, 5) of `TeacherInput.movers`)."""
    position = np.asarray(position, float).reshape(-1, 2)
    near = np.zeros(len(position), dtype=bool)
    for k, m in enumerate(movers):
        m = np.asarray(m, float).reshape(-1, 5)
        if len(m):
            near[k] = bool(np.any(np.hypot(*(m[:, :2] - position[k]).T) - m[:, 2] < reach))
    return near


class BatchTeacher:
    """The teacher over a batched env (`auv_mj.tasks.vector.AUVVectorEnv` or a mixture of them): `actions()` reads
    the env's `privileged_state()` and labels every row at once.

    With `mover_reach` [m], it labels only the rows with a mover's disc within that of the vehicle (`near_movers`)
    and leaves the others NaN, which the imitation term skips (`auv_mj.agents.ppo.ppo.ppo_loss`): imitation weighted
    against RL state by state (issue 51, item 5), kept where the learned planners still fail, an oncoming mover
    (docs/runs/planner-learned), and RL left alone elsewhere."""

    def __init__(self, env, mover_reach: float | None = None):
        if not hasattr(env, "privileged_state"):
            raise TypeError("the teacher needs an env with privileged_state() (auv_mj.tasks.vector.AUVVectorEnv)")
        self.env = env
        self.mover_reach = checked_reach(mover_reach)

    def actions(self) -> np.ndarray:
        """The teacher's actions (N, 2) at the env's current states (NaN rows away from movers, with mover_reach)."""
        state = self.env.privileged_state()
        if self.mover_reach is None:
            return teacher_actions(TeacherInput(**state), self.env.action_kind)
        rows = np.flatnonzero(near_movers(state["position"], state["movers"], self.mover_reach))
        actions = np.full((len(state["potentials"]), 2), np.nan)
        if len(rows):  # the teacher asked at those rows alone (its cost is per row)
            actions[rows] = teacher_actions(TeacherInput(**{key: ([value[k] for k in rows] if isinstance(value, list)
                                                                  else np.asarray(value)[rows])
                                                            for key, value in state.items()}),
                                            self.env.action_kind)
        return actions


def geodesic_teacher(env) -> GeodesicTeacher:
    """The privileged teacher on a planning task's suite environment, in the task's action map (the student's is
    action="rate")."""
    return GeodesicTeacher(env)
