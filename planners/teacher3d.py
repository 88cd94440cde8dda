"""The privileged teacher in 3-D: line of sight down the episode's field on the true voxel map.

The planar teacher (`auv_mj.planners.teacher`) in the water column, for the 6-DOF tasks goal3d and tunnel3d. A
teacher for DAgger (Ross et al. 2011) labels the states the student visits, so it must act from any state, cheaply:
it follows no plan of its own. At the reset the task searches the episode's arena once, from the goal outwards, on
the oracle's voxel map of the true static geoms (`Planning3D.steering_field`: `auv_mj.arenas.traps3d.geodesic_field`
weighed by the oracle's soft clearance, on the lattice the vehicle flies at its pitch limit); the search leaves each
voxel its next hop towards the goal (`VoxelField.next_hop`), so that the cheapest way to the goal from anywhere is
read off in a few array look-ups. Each step, for every vehicle of a batch at once (`teacher_actions_3d`):

- it enters the field at the voxel near the vehicle that leads to the goal most cheaply (the vehicle may sit within
  the clearance the free water keeps from the walls: it looks through `VoxelField.reach` voxels round it);
- it walks the next hops out to LOOKAHEAD metres (`auv_mj.planners.map_planner3d`'s line of sight;
  TEACHER_TUBE_LOOKAHEAD in a tube), and aims at that point: the heading offset is the point's bearing off the
  vehicle's course over the ground (its true travel over the last step: in a current the vehicle crabs, and an aim off
  its heading would set it into a tube's wall), added to its heading; the depth offset is the steepest climb or dive
  the way asks within PREVIEW metres, over the look-ahead (the lattice climbs at the vehicle's steepest, right before
  a wall; the vehicle's climb lags its command, so it must start sooner: `aim_points`);
- the speed is CRUISE_SPEED; MAX_SPEED for a steep climb or dive (CLIMB_SPEED_DEMAND), TURN_SPEED for a turn
  sharper than SLOW_TURN; within the goal's region it aims at the goal itself.

In open water its field climbs at OPEN_WATER_SLOPE, what the vehicle flies, not at the certificate's steeper slope:
where a wall must be climbed sooner than the vehicle can, the way circles to gain height.

With a `horizon` [m] the teacher knows a tube's plug only once it has come within that of the plug's centre
(`Planning3D.unseen_plugs`; its field is searched again without the plugs still unknown): a teacher limited to
about what the fan can show (Weihs et al. 2020's imitation gap). With 8 m it passes 18 of 20 hard validation tubes
in both waters, against 20 and 19 with the whole map, and its student learned no better
(docs/runs/planner-learned-3d/).

The actions are those of the 3-D planning tasks, (a_speed, a_heading, a_depth) in [-1, 1]^3 (speed over MAX_SPEED,
the heading offset over HEADING_RANGE, the depth offset over DEPTH_RANGE; `auv_mj.tasks.auv3d.planning_command`).
Moving obstacles are not in the field (its map is static): the random arenas of the training mixture have none. Its
input is privileged: it must never be the input of a deployed learner. `BatchTeacher3D` drives the batched 6-DOF env
(`auv_mj.tasks.vector3d.AUV3DVectorEnv`, or a mixture of them) through its `privileged_state()`;
`geodesic_teacher_3d(env)` is its face on one dm_env 3-D planning task (the zoo's `geodesic-teacher` on auv3d).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import dm_env
import numpy as np

from auv_mj.arenas.geodesic import VoxelField, entry_voxels, field_groups
from auv_mj.episode import PlannerBase
from auv_mj.geometry import wrap_angle
from auv_mj.planners.map_planner3d import LOOKAHEAD
from auv_mj.tasks.auv3d import CRUISE_SPEED, DEPTH_RANGE, HEADING_RANGE, MAX_SPEED

OPEN_WATER_SLOPE = math.radians(7.0)
"""The steepest climb [rad] of the teacher's way in open water: what the REMUS flies at CRUISE_SPEED under a full
depth command, measured in both waters (8-9 deg, less while the climb starts); the certificate's lattice climbs at
11.5 deg (its pitch limit times CLIMB_MARGIN), which the vehicle reaches only at the top speed."""
CLIMB_SPEED_DEMAND = 0.6
"""A depth offset of at least this share of DEPTH_RANGE is flown at MAX_SPEED: the stern planes climb steeper."""
TURN_SPEED = 1.2
"""Speed [m/s] of a sharp turn (the REMUS's stern planes still bite; slower, a current sets it further off)."""
SLOW_TURN = math.radians(60.0)
"""Turns sharper than this [rad] are flown at TURN_SPEED."""
TEACHER_TUBE_LOOKAHEAD = 5.0
"""Line of sight's look-ahead [m] in a tube: shorter than `los-avoid`'s and the oracle's (TUBE_LOOKAHEAD, 8 m), which
cuts the corner round a plug; on validation seeds 20000-20029 of the hard tubes (ideal / ocean) 4 m reached 23 / 23,
5 m 29 / 26, 6 m 27 / 27 and 8 m 23 / 26 of 30. `map-replan` came to 5 m too
(`auv_mj.planners.map_planner3d.MAP_TUBE_LOOKAHEAD`)."""
PREVIEW = 30.0
"""How far [m] down the way in open water the teacher looks for the steepest climb or dive it must start now."""
MIN_PREVIEW = 4.0
"""Climbs and dives nearer than this [m] are rated over this distance (a voxel's step is no slope)."""
MIN_TRAVEL = 0.2
"""Below this travel [m] over a step the course is the heading (at a reset, or nearly stopped)."""


def course_over_ground(previous: np.ndarray, position: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """The direction [rad] of each vehicle's horizontal travel from `previous` to `position` (N, 3), its `heading`
    (N,) where it moved less than MIN_TRAVEL."""
    step = np.asarray(position, dtype=float)[:, :2] - np.asarray(previous, dtype=float)[:, :2]
    moved = np.hypot(step[:, 0], step[:, 1]) >= MIN_TRAVEL
    return np.where(moved, np.arctan2(step[:, 1], step[:, 0]), np.asarray(heading, dtype=float))


def aim_points(field: VoxelField, points: np.ndarray) -> np.ndarray:
    """The aims (n, 3) from each of `points` (n, 3) down `field`: entered at the voxel of its reach block round the
    point with the least |point - centre| + field, then along the next hops. The aim's x, y are the way's point
    LOOKAHEAD metres on (a tube's field: TEACHER_TUBE_LOOKAHEAD); its z the point's own plus the steepest climb
    or dive the way asks within PREVIEW metres (a tube's: TEACHER_TUBE_LOOKAHEAD) times the look-ahead, so that
    the vehicle, whose climb lags its command, starts a climb over a wall before the way's own, taken at the
    lattice's steepest. The goal where the way ends sooner (the goal region reached) or none leads on."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    space = field.space
    n = len(points)
    node, entered = entry_voxels(field, points)
    reach = TEACHER_TUBE_LOOKAHEAD if field.outside_closed else LOOKAHEAD
    preview = TEACHER_TUBE_LOOKAHEAD if field.outside_closed else PREVIEW
    here = points.copy()
    travelled = np.zeros(n)
    aim = np.tile(field.goal, (n, 1))
    aimed = ~np.isfinite(entered)
    steepest = np.zeros(n)
    done = aimed.copy()
    for _ in range(int(math.ceil(3.0 * max(reach, preview) / float(np.min(space.cell)))) + 1):
        if done.all():
            break
        centre = space.origin + (np.column_stack(np.unravel_index(np.where(done, 0, node), space.shape)) + 0.5) \
            * space.cell
        travelled = np.where(done, travelled, travelled + np.linalg.norm(centre - here, axis=1))
        here = np.where(done[:, None], here, centre)
        far = ~aimed & ~done & (travelled >= reach)
        aim[far] = centre[far]
        aimed |= far
        rate = (centre[:, 2] - points[:, 2]) / np.maximum(travelled, MIN_PREVIEW)
        steeper = ~done & (np.abs(rate) > np.abs(steepest))
        steepest = np.where(steeper, rate, steepest)
        done |= travelled >= preview
        following = np.where(done, -9999, field.next_hop[np.where(done, 0, node)])
        done |= following < 0  # a source: the goal region
        node = np.where(done, node, following)
    goal_row = np.all(aim == field.goal, axis=1)
    aim[:, 2] = np.where(goal_row & (np.linalg.norm(aim - points, axis=1) < reach), aim[:, 2],
                         points[:, 2] + steepest * reach)
    return aim


def teacher_actions_3d(fields: Sequence[VoxelField], position: np.ndarray, course: np.ndarray) -> np.ndarray:
    """The teacher's actions (N, 3) for N vehicles at `position` (N, 3) travelling along `course` (N,) [rad], each
    down its episode's steering field (module docstring). The heading offset is the aim's bearing off the course:
    the task's action map adds it to the heading, which turns the course by as much."""
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    aim = np.empty_like(position)
    for members in field_groups(fields):
        aim[members] = aim_points(fields[members[0]], position[members])
    offset = aim - position
    turn = wrap_angle(np.arctan2(offset[:, 1], offset[:, 0]) - np.asarray(course, dtype=float))
    depth = np.clip(-offset[:, 2] / DEPTH_RANGE, -1.0, 1.0)
    speed = np.where(np.abs(turn) > SLOW_TURN, TURN_SPEED,
                     np.where(np.abs(depth) >= CLIMB_SPEED_DEMAND, MAX_SPEED, CRUISE_SPEED))
    return np.column_stack([2.0 * speed / MAX_SPEED - 1.0, np.clip(turn / HEADING_RANGE, -1.0, 1.0), depth])


class GeodesicTeacher3D(PlannerBase):
    """The teacher on one dm_env 3-D planning task (module docstring); with `horizon` [m], it knows a tube's plug
    only once it has come within that of it (`Planning3D.unseen_plugs`)."""

    def __init__(self, env, horizon: float | None = None):
        self.env = env
        self.horizon = horizon
        self._previous: np.ndarray | None = None

    def reset(self) -> None:
        self._previous = None

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        task, physics = self.env.task, self.env.physics
        position = np.asarray(physics.position(), dtype=float)[None].copy()
        previous = position if time_step.first() or self._previous is None else self._previous
        self._previous = position
        course = course_over_ground(previous, position, np.array([physics.heading()]))
        hidden = frozenset() if self.horizon is None else task.unseen_plugs(position[0], self.horizon)
        return teacher_actions_3d([task.steering_field(OPEN_WATER_SLOPE, hidden)], position, course)[0]


class BatchTeacher3D:
    """The teacher over the batched 6-DOF env (`auv_mj.tasks.vector3d.AUV3DVectorEnv` or a mixture of them):
    `actions()` reads the env's `privileged_state()` and labels every row at once."""

    def __init__(self, env, horizon: float | None = None):
        """`horizon` [m]: as `GeodesicTeacher3D`'s."""
        if not hasattr(env, "privileged_state"):
            raise TypeError("the teacher needs an env with privileged_state() (auv_mj.tasks.vector3d.AUV3DVectorEnv)")
        self.env = env
        self.horizon = horizon

    def actions(self) -> np.ndarray:
        """The teacher's actions (N, 3) at the env's current states."""
        state = self.env.privileged_state(OPEN_WATER_SLOPE, self.horizon)
        course = course_over_ground(state["previous_position"], state["position"], state["heading"])
        return teacher_actions_3d(state["steering"], state["position"], course)


def geodesic_teacher_3d(env) -> GeodesicTeacher3D:
    """The privileged teacher on a 3-D planning task's suite environment."""
    return GeodesicTeacher3D(env)
