"""The mapping planner and the oracle in 3-D: `map-replan` and `oracle` on goal3d and tunnel3d.

Both are `factory(env) -> policy(time_step) -> action` on an auv3d planning environment, the 3-D counterparts of
`auv_mj.planners.map_planner`'s (Choset et al., *Principles of Robot Motion*, Ch. 2 and 5; LaValle, *Planning
Algorithms*, Ch. 5-6):

- The map is a voxel grid of the water (`auv_mj.arenas.voxels.VoxelGrid`): OPEN_CELL (2 m across, 1 m high) in open
  water, TUBE_CELL (1 m, 0.5 m) in a tube (`auv_mj.arenas.traps3d.map_cells`). `map_replan` fills it online from the
  27-beam fan and the altimeter (unknown water free; log-odds counts as in the plane: +HIT for an echo's voxel,
  -MISS for each voxel a beam crossed, occupied at >= OCCUPIED), each ping cast from the pose it was taken at
  (`SonarVoxelMap.beams`: ocean water's sonar reaches the planner a ping late); the `oracle` from the true geoms
  (`auv_mj.arenas.traps3d.true_map`). Both know the surface: water shallower than the task's MIN_DEPTH is closed.
- In open water `map-replan`'s search also keeps clear of the unknown water its echoes close round
  (`SonarVoxelMap.search_map`: a morphological closing by CLOSING, where no beam has crossed): the fan's beams are
  22.5 and 30 deg apart, and with unknown water free every hole between a wall's echoes looked like a way through.
- The search (`auv_mj.arenas.voxels.shortest_path`) is Dijkstra's algorithm on the flyable lattice: level moves,
  and climbs or dives no steeper than the executor's pitch limit (read from the task's executor,
  `DepthHeadingGains.max_pitch`) times CLIMB_MARGIN. A voxel nearer than the hard clearance (OPEN_CLEARANCE 2.5 m,
  TUBE_CLEARANCE 1 m) to an occupied one is closed, and one within SOFT_CELLS voxels of it costs more, so a path
  keeps to open water. It runs in a box round the vehicle and its target grown by WINDOW (TUBE_WINDOW in a tube),
  on the whole map where that box holds no way (the oracle's, and `map-replan`'s in open water).
- Replanning, as in the plane: the search runs again when the map changed near the path (new occupied voxels
  within the soft clearance of the path left), at most every REPLAN_STEPS planner steps; when the target moved on;
  when the vehicle is further than OFF_PATH (TUBE_OFF_PATH) from its path; and every REPLAN_PERIOD steps regardless.
  The target is the goal (goal3d) or the centreline's point ROUTE_HORIZON metres on from the vehicle's nearest one,
  moved on in ROUTE_STEP steps, and on past any obstacle the map holds there (tunnel3d).
- The follower is 3-D line of sight on the planned path (`auv_mj.control.depth_heading.los_command`: heading to the
  point LOOKAHEAD metres along it, in a tube TUBE_LOOKAHEAD, `map-replan`'s MAP_TUBE_LOOKAHEAD, its depth as the
  depth command) at the classical planners' CRUISE_SPEED, its heading the course over the ground (less the crab
  angle the DVL measures, `auv_mj.planners.los3d.CrabEstimate`: a cross current would otherwise hold the vehicle
  LOOKAHEAD tan(crab) off its path), inside
  the protection domain on the 3-D fan (`auv_mj.planners.los3d.protect_command`) with PATH_FIELD in open water and
  the tube's domain in a tube, sized to its radius (`auv_mj.planners.los3d.tube_field`) and reading the fan filtered
  over pings (`auv_mj.planners.los3d.domain_ranges`). In a tube without movers `map-replan`'s domain guards only
  against the echoes its path was not planned round (`SonarVoxelMap.unplanned_echoes`).

The oracle follows its path without the protection domain in a tube with no moving obstacles, where its map is
exact (`TrueVoxelMap.guarded`). It is no competitor: it certifies the hard 3-D arenas
(`auv_mj.arenas.traps3d.certify`, the same map and search) and gives the reference time of the 3-D suite's time
efficiency.
"""

from __future__ import annotations

import copy
import itertools
import math
from collections import deque

import dm_env
import mujoco
import numpy as np
from scipy import ndimage

from auv_mj.arenas import cells, grid, sonar_memory, traps3d, voxels
from auv_mj.arenas.sonar_memory import HIT, MISS, OCCUPIED, SATURATION
from auv_mj.control.depth_heading import los_command
from auv_mj.episode import VEHICLE_BODY, Planner, PlannerBase
from auv_mj.geometry import arc_lengths, wrap_angle
from auv_mj.planners.avoidance import RepulsiveField
from auv_mj.planners.los3d import (
    CrabEstimate,
    FanFilter,
    command_action,
    course_command,
    domain_field,
    domain_ranges,
    protect_command,
)
from auv_mj.planners.map_planner import Replanning
from auv_mj.sim.physics3d import set_pose
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, FAN_AZIMUTHS, FAN_ELEVATIONS, fan_directions
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks.auv3d import CRUISE_SPEED, GOAL_RADIUS, HEADING_RANGE, MIN_DEPTH, State3D, Tunnel3D
from auv_mj.tasks.auv3d import LOOKAHEAD as TUBE_LOS_LOOKAHEAD

SOFT_CELLS = 3.0
"""Voxels (horizontal size) beyond the hard clearance within which a voxel costs more."""
REPLAN_STEPS = 4
"""Least planner steps (2 s) between two searches when the map changed near the path ..."""
REPLAN_PERIOD = 40
"""... and a search every this many steps (20 s) regardless."""
OFF_PATH, TUBE_OFF_PATH = 8.0, 2.0
"""A vehicle this far [m] from its planned path plans again (open water, tube)."""
LOOKAHEAD = 10.0
"""Line of sight aims at the path's point this far [m] along it (chosen on validation seeds, docs/benchmark.md) ..."""
TUBE_LOOKAHEAD = TUBE_LOS_LOOKAHEAD
"""... in a tube, as far as `los-avoid` aims along the centreline (the oracle's, which plans ORACLE_ROUTE_HORIZON
ahead and passes a plug in a long, gentle swing) ..."""
MAP_TUBE_LOOKAHEAD = 5.0
"""... and `map-replan`'s in a tube. The fan shows a plug's free side only some 12 m before it, so `map-replan`'s
path passes a plug in a detour a few metres long; aimed 8 m along it, line of sight cut the detour's corner (pure
pursuit's, Coulter 1992) and flew into the plug though its path went round it (validation seed 20002 of the hard
tubes, traced: from 7.7 m before the plug the path went round its edge and the vehicle held its line, 0.7 m inside
it). Chosen on the hard validation tubes, seeds 20000-20099 in ideal / ocean water
(docs/runs/map-replan-3d/README.md): 8 m passed 81 / 66 of 100, 4 m 86 / 83, 5 m 94 / 87, 6 m 91 / 80. The 3-D
teacher's look-ahead came to 5 m the same way (`auv_mj.planners.teacher3d.TEACHER_TUBE_LOOKAHEAD`)."""
SMOOTH_SPACING = 0.5
SMOOTH_WINDOW = 4.0
"""A planned path is resampled every SMOOTH_SPACING metres and averaged over SMOOTH_WINDOW voxels
(`auv_mj.arenas.voxels.smooth`)."""
PATH_FIELD = RepulsiveField(influence=15.0)
"""The protection domain in open water while following a planned path: the paper's gain, echoes repelling within
15 m (chosen on validation seeds over the open-water 30 m of `los-avoid`, which turns the vehicle along a wall it
is planned to climb over)."""
ROUTE_HORIZON = 12.0
"""In a tube the search goes to the centreline's point this far [m] on (the chord of a 20 m bend over it strays
0.9 m from the centreline: unseen wall beyond the fan's reach round a bend does not pull the path into it) ..."""
ORACLE_ROUTE_HORIZON = 30.0
"""... the oracle's, which no unseen wall can mislead, this far ..."""
ROUTE_STEP = 4.0
"""... moved on in steps of this many metres (each a new target, a new search)."""
WINDOW = np.array([20.0, 20.0, 12.0])
"""The open-water search stays within the box round vehicle and target grown by this [m] ..."""
TUBE_WINDOW = np.array([8.0, 8.0, 8.0])
"""... in a tube, by this."""
TURN_TEST_TIME = 60.0
"""Seconds of the hard-over turn that `turning_radius` flies in a copy of the physics (2 to 3 full circles of the
REMUS at cruise speed): the first half settles the turn, the second half is measured."""
TURN_TEST_DEPTH = 30.0
"""Depth [m] of that turn (contacts are off in the copy; only the water's forces act)."""
CAPTURE_MARGIN = 1.2
"""The turning circle the goal capture keeps the goal out of is the measured one times this (the measured turn is
steady and in still water; the vehicle entering it still slews its rudder, and ocean water disturbs it)."""


def _nearest(path: np.ndarray, position: np.ndarray) -> tuple[float, float]:
    """(distance [m] of `position` from the polyline `path`, arc length [m] of its nearest point)."""
    if len(path) < 2:
        return float(np.linalg.norm(path[0] - position)), 0.0
    a, d = path[:-1], np.diff(path, axis=0)
    lengths2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-12)
    t = np.clip(np.einsum("ij,ij->i", position - a, d) / lengths2, 0.0, 1.0)
    gaps = np.linalg.norm(a + t[:, None] * d - position, axis=1)
    k = int(np.argmin(gaps))
    arc = np.concatenate([[0.0], np.cumsum(np.sqrt(lengths2))])
    return float(gaps[k]), float(arc[k] + t[k] * np.sqrt(lengths2[k]))


def _point_at(path: np.ndarray, s: float) -> np.ndarray:
    arc = arc_lengths(path)
    if s >= arc[-1]:
        return path[-1].copy()
    j = int(np.searchsorted(arc, s, side="right") - 1)
    return path[j] + (s - arc[j]) / max(arc[j + 1] - arc[j], 1e-12) * (path[j + 1] - path[j])


def turning_radius(task, physics, speed: float = CRUISE_SPEED) -> float:
    """The radius [m] of the vehicle's tightest horizontal turn at `speed` as its executor flies it, measured by
    flying it: a copy of `physics` (contacts and current off, no disturbance) and of the task's executor (reset),
    commanded HEADING_RANGE ahead of the heading every tick, as a planner turning hard does, at TURN_TEST_DEPTH.
    R = mean horizontal speed / mean |yaw rate| over the second half of TURN_TEST_TIME.

    A fin-steered hull's turning circle does not shrink with speed (every force of the hull and the fins grows as
    u^2, `auv_mj.sim.hydro3d.force_frd`, so the steady yaw rate grows as u): slowing down does not capture a goal
    inside it, flying out of it does (`VoxelFollower.capture`)."""
    trial = physics.copy(share_model=False)
    trial.disturbance = None
    model = trial.model.ptr
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    model.opt.wind[:] = 0.0
    set_pose(trial, (0.0, 0.0, -TURN_TEST_DEPTH), nu=(speed, 0.0, 0.0, 0.0, 0.0, 0.0))
    trial.reset_fins()
    executor = copy.deepcopy(task.executor)
    executor.reset()

    def tick(p) -> None:
        roll, pitch, heading = (float(a) for a in p.attitude())
        u, v, w, rp, q, r = (float(x) for x in p.body_velocity())
        state = State3D(u, v, w, rp, q, r, roll, pitch, heading, p.depth())
        p.set_control(executor((speed, heading + HEADING_RANGE, TURN_TEST_DEPTH), state))

    trial.set_tick(tick)
    steps = max(int(round(1.0 / model.opt.timestep)), 1)
    dof = trial.hydrodynamics.dof_adr
    rates, speeds = [], []
    for k in range(int(TURN_TEST_TIME)):
        trial.step(steps)
        if k >= TURN_TEST_TIME / 2:
            speeds.append(float(np.hypot(*trial.data.qvel[dof:dof + 2])))
            rates.append(abs(float(trial.body_velocity()[5])))
    return float(np.mean(speeds) / max(float(np.mean(rates)), 1e-6))


class VoxelFollower(Replanning, PlannerBase):
    """A search on a voxel map, replanned when it must (the planar planner's `Replanning`), followed by 3-D line of
    sight (module docstring).

    Subclasses fill `self.occupied` (`start`, `update`) and say when the map changed near the path."""

    replan_steps = REPLAN_STEPS
    replan_period = REPLAN_PERIOD
    route_horizon = ROUTE_HORIZON
    tube_lookahead = TUBE_LOOKAHEAD
    """Line of sight's look-ahead [m] on the path in a tube (LOOKAHEAD in open water)."""
    whole_map_fallback = False
    """Whether a search that finds nothing in its window searches the whole map (`plan`): the oracle's, and
    `map-replan`'s in open water (`SonarVoxelMap.whole_map_fallback`)."""

    def __init__(self, env):
        self.env = env
        self.task, self.physics = env.task, env.physics
        self.grid: voxels.VoxelGrid | None = None
        self.fan = FanFilter()
        self.crab = CrabEstimate()

    def reset(self) -> None:
        """Forgets the map, the path, the domain's pings and the crab angle (the next step starts a new episode)."""
        self.grid = None
        self.fan.reset()
        self.crab.reset()

    @property
    def in_tube(self) -> bool:
        return isinstance(self.task, Tunnel3D) and len(self.task.path) >= 2

    def start(self) -> None:
        """A new episode: an empty map over the episode's water, the surface closed."""
        task = self.task
        self.max_slope = task.max_pitch * voxels.CLIMB_MARGIN
        _, self.hard = traps3d.map_cells(task.path if self.in_tube else np.zeros((0, 3)))
        self.grid = sonar_memory.memory_grid3d(self.physics.position(), task.goal, task.path, self.in_tube)
        self.surface = np.zeros(self.grid.shape, bool)
        self.surface[:, :, self.grid.centres()[2] > -MIN_DEPTH] = True
        self.occupied = self.surface.copy()
        self.path: np.ndarray | None = None
        self.since_plan = 0
        self.target_key = None
        self.turn_radius = None if self.in_tube else CAPTURE_MARGIN * turning_radius(task, self.physics)

    def update(self) -> bool:
        """Brings the map up to date; whether it changed near the path."""
        raise NotImplementedError

    def near_path(self, fresh: np.ndarray) -> bool:
        """Whether any of the voxels `fresh` (n, 3) lies within the soft clearance of the path left."""
        if self.path is None or not len(fresh):
            return self.path is None and bool(len(fresh))
        centres = self.grid.centre(fresh)
        ahead = self.path[self.progress_index():]
        reach = self.hard + SOFT_CELLS * float(self.grid.cell[0])
        return bool(np.min(np.linalg.norm(centres[:, None, :] - ahead[None, ::2, :], axis=2)) < reach)

    def progress_index(self) -> int:
        """Index of the path vertex nearest the vehicle."""
        return int(np.argmin(np.linalg.norm(self.path - self.physics.position(), axis=1)))

    def target(self) -> tuple[np.ndarray, float, object]:
        """The search's target, its radius [m] and a key that changes when the target does."""
        task = self.task
        if not self.in_tube:
            return task.goal, GOAL_RADIUS, 0
        _, s = _nearest(task.path, self.physics.position())
        step = int((s + self.route_horizon) // ROUTE_STEP)
        point = _point_at(task.path, step * ROUTE_STEP)
        while self.blocked(point) and np.linalg.norm(point - task.path[-1]) > 1e-9:  # on to water past an obstacle
            step += 1
            point = _point_at(task.path, step * ROUTE_STEP)
        return point, GOAL_RADIUS, step if np.linalg.norm(point - task.path[-1]) > 1e-9 else "end"

    def blocked(self, point: np.ndarray) -> bool:
        """Whether an occupied voxel lies within the hard clearance of `point`'s voxel (box neighbourhood)."""
        ijk, inside = self.grid.index(point)
        if not inside[0]:
            return False
        reach = np.ceil(self.hard / self.grid.cell).astype(int)
        lo = np.maximum(ijk[0] - reach, 0)
        hi = np.minimum(ijk[0] + reach + 1, self.grid.shape)
        return bool(self.occupied[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]].any())

    def _search(self, position: np.ndarray, goal: np.ndarray, radius: float, soft: float, lo: np.ndarray,
                hi: np.ndarray, box) -> np.ndarray | None:
        """The shortest flyable path on the map's voxels [lo, hi) (its costs from their clearance), within `box`
        (None: anywhere in them); None if there is none."""
        space = self.grid
        crop = tuple(slice(a, b) for a, b in zip(lo, hi, strict=True))
        local = voxels.VoxelGrid(space.origin + lo * space.cell, space.cell, tuple(int(v) for v in hi - lo))
        cost = grid.cost_field(voxels.clearance(local, self.search_map(crop)), self.hard, soft)
        return voxels.shortest_path(local, cost, position, goal, self.max_slope, radius, box)

    def search_map(self, crop: tuple[slice, ...]) -> np.ndarray:
        """The occupied voxels the search keeps clear of in `crop`: the map's."""
        return self.occupied[crop]

    def plan(self, position: np.ndarray, goal: np.ndarray, radius: float) -> None:
        """Searches the map round the vehicle and the target (the box grown by WINDOW, TUBE_WINDOW in a tube); where
        no path lies within that box and `whole_map_fallback`, the whole map; keeps the old path when neither finds one.

        The box is a speed-up, not a rule: a hard goal3d arena's way over a wall or a cave's roof climbs up to
        RISE + the wall's thickness + the clearance, 13.5 m, above the shallower end, past WINDOW's 12 m, and a search
        that fails leaves the vehicle on its old path or, at the start, on the straight line into the cave (seed
        20006 of the hard tier flew into the cave and climbed out over its roof only at 240 s)."""
        self.since_plan = 0
        space = self.grid
        window = TUBE_WINDOW if self.in_tube else WINDOW
        soft = self.hard + SOFT_CELLS * float(space.cell[0])
        ends = np.vstack([position, goal])
        low, high = ends.min(axis=0), ends.max(axis=0)
        lo, hi = space.block(low - window - soft, high + window + soft)
        path = self._search(position, goal, radius, soft, lo, hi, (low - window, high + window))
        if path is None and self.whole_map_fallback and not np.array_equal(hi - lo, space.shape):
            path = self._search(position, goal, radius, soft, np.zeros(3, int), np.array(space.shape), None)
        if path is not None:
            if np.linalg.norm(path[-1] - goal) <= radius:
                path[-1] = goal
            self.path = voxels.smooth(np.vstack([position, path]), SMOOTH_SPACING, SMOOTH_WINDOW * space.cell[0])

    def command(self) -> tuple[float, float, float]:
        """Brings the map and the plan up to date; the (V, psi, depth) command of line of sight on the path."""
        position = self.physics.position()
        if self.grid is None:
            self.start()
        changed = self.update()
        goal, radius, key = self.target()
        self.replan_if_due(changed, position, goal, radius, key)
        if self.path is not None and self.since_plan >= self.replan_steps:
            off = TUBE_OFF_PATH if self.in_tube else OFF_PATH
            if _nearest(self.path, position)[0] > off:
                self.plan(position, goal, radius)
        path = self.path if self.path is not None else np.vstack([position, goal])
        command = los_command(position, path, self.tube_lookahead if self.in_tube else LOOKAHEAD, CRUISE_SPEED)
        command = course_command(command, self.crab(self.task.sensors.read(self.physics)))
        return command if self.in_tube else self.capture(command, position)

    def capture(self, command: tuple[float, float, float], position: np.ndarray) -> tuple[float, float, float]:
        """The goal capture in open water: within LOOKAHEAD of the goal (horizontally), aim at the goal itself
        (heading to it, its depth), unless it lies inside the turning circle on its side (horizontal distance
        d < 2 R |sin beta|, beta its bearing off the heading, R `turning_radius` times CAPTURE_MARGIN): a vehicle
        turning hard towards it then circles it for ever (pure pursuit's orbit; seed 20008 of the hard goal3d tier
        circled 4-8 m off its goal for 160 s). There it holds its heading until the goal is out of that circle,
        then turns: a point outside the circle it turns on stays outside, so the turn closes on the goal."""
        goal = self.task.goal
        offset = goal - position
        distance = float(np.hypot(offset[0], offset[1]))
        if distance > LOOKAHEAD:
            return command
        heading = self.physics.heading()
        bearing = math.atan2(offset[1], offset[0])
        inside = distance < 2.0 * self.turn_radius * abs(math.sin(wrap_angle(bearing - heading)))
        return command[0], heading if inside else bearing, -float(goal[2])

    @property
    def guarded(self) -> bool:
        """Whether the protection domain guards the path's command: it guards against what the map does not know."""
        return True

    def unplanned_echoes(self, ranges: np.ndarray) -> np.ndarray:
        """The fan's ranges [m] (27, the domain's reading of them) that the protection domain guards against: all
        of them here (`SonarVoxelMap.unplanned_echoes` leaves out those its path was planned round)."""
        return ranges

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first():
            self.reset()
        command = self.command()
        if self.guarded:
            ranges = domain_ranges(self.task, self.fan, self.physics.time(),
                                   self.task.sensors.read(self.physics)["sonar"])
            ranges = self.unplanned_echoes(ranges)
            command = protect_command(command, self.physics.heading(), ranges, domain_field(self.task, PATH_FIELD))
        return command_action(command, self.physics)


_FAN = fan_directions()
_NEIGHBOURS = np.array([(r * len(FAN_AZIMUTHS) + c, r * len(FAN_AZIMUTHS) + c + 1) for r in range(len(FAN_ELEVATIONS))
                        for c in range(len(FAN_AZIMUTHS) - 1)]
                       + [(r * len(FAN_AZIMUTHS) + c, (r + 1) * len(FAN_AZIMUTHS) + c)
                          for r in range(len(FAN_ELEVATIONS) - 1) for c in range(len(FAN_AZIMUTHS))])
"""Pairs of neighbouring fan beams (in azimuth within a row, in elevation within a column)."""
JOIN_POINTS = 8
"""Points marked along the segment between two joined echoes (`SonarVoxelMap.update`)."""
CLOSING = np.array([6.0, 6.0, 6.0])
"""Half-extent [m] (x, y, z) of the box `SonarVoxelMap.search_map` closes the echoes with in open water: unknown
water between echoes nearer than about twice this is taken for the wall they lie on. The fan's rows are 30 deg apart,
so a wall 20 m off shows echoes some 10-12 m apart; with unknown water free the search took every hole between them for
a way out of a hard goal3d arena's cave (seed 20006 of the hard tier flew inside its cave for 200 s and timed out).
Chosen on validation seeds 20000-20049 (docs/runs/map-replan-3d/README.md): hard goal3d 38 and 39 of 50 (ideal,
ocean) with none, 45 / 41 with 4 m, 47 / 44 with 6 m, 48 / 43 with 8 m; standard goal3d 50 / 50 with 6 m as
without."""
PLANNED_REACH = 1
"""An echo within this many voxels (each way, on each axis) of a voxel the last search kept clear of is one the path
was planned round (`SonarVoxelMap.unplanned_echoes`): the domain reads the fan filtered over pings, cast from the
ping's pose, and its echo may land a voxel off the one the map marked."""
_REACH = np.array(list(itertools.product(range(-PLANNED_REACH, PLANNED_REACH + 1), repeat=3)))
"""Offsets of the voxels within PLANNED_REACH of a voxel."""


class SonarVoxelMap(VoxelFollower):
    """`map-replan`'s map: log-odds counts of the fan's and the altimeter's echoes and clear beams.

    Two neighbouring beams' echoes nearer each other than twice the hard clearance plus a voxel are joined (the
    voxels along the segment between them are hit too): the search could not pass between them anyway, and a wall
    seen by a sparse fan has no holes between its beams."""

    tube_lookahead = MAP_TUBE_LOOKAHEAD

    def plan(self, position: np.ndarray, goal: np.ndarray, radius: float) -> None:
        """The search (`VoxelFollower.plan`); in a tube without movers it also keeps the map it searched on, the
        echoes its path was planned round (`unplanned_echoes`)."""
        super().plan(position, goal, radius)
        if self.in_tube and not self.task.movers:
            self.planned_map = self.occupied & ~self.surface

    def unplanned_echoes(self, ranges: np.ndarray) -> np.ndarray:
        """In a tube without movers, the domain guards only against the echoes the path was not planned round: a
        beam whose echo lies within a voxel (PLANNED_REACH) of a voxel the last search kept clear of reads its range
        limit. Elsewhere every echo (`VoxelFollower.unplanned_echoes`).

        The path already keeps TUBE_CLEARANCE and the soft clearance from every voxel it was searched round, so the
        domain, guarding against those echoes too, only fought it (`VoxelFollower.guarded`: it guards against what
        the map does not know): round a plug the path passes 1-1.5 m from the plug's edge, well inside the tube's
        domain (3 m in a hard tube), and the domain bent the heading away from the plug by up to 90 deg; past the
        plug the vehicle, turned out towards the far wall, could not turn back in its 6 m turning circle and struck
        the wall (validation seed 20076 of the hard tubes, ocean water, traced). An echo the map has not yet been
        searched round (a plug seen since the last search, a wall round a bend) is still guarded against until the
        next search. Chosen on the hard validation tubes (docs/runs/map-replan-3d/README.md): seeds 20000-20099,
        94 / 87 of 100 (ideal, ocean) with every echo guarded, 95 / 93 with the planned ones left out, 93 / 92
        with no domain in a tube."""
        planned = self.planned_map  # None until a search in a tube without movers (`plan`)
        if planned is None:
            return ranges
        ranges = np.array(ranges, dtype=float)
        origin, fan = self.poses[0]
        ijk, inside = self.grid.index(origin[None] + fan * ranges[:, None])
        near = np.clip(ijk[:, None, :] + _REACH[None], 0, np.array(self.grid.shape) - 1)
        planned_round = inside & planned[near[..., 0], near[..., 1], near[..., 2]].any(axis=1)
        ranges[(ranges < SONAR_RANGE) & planned_round] = SONAR_RANGE
        return ranges

    @property
    def whole_map_fallback(self) -> bool:
        """In open water, where the search keeps clear of the closed holes between echoes (`search_map`): there a
        search that finds nothing in its window is no longer one that missed a hole, but one whose way round (over a
        cave's roof, 13.5 m above the shallower end) lies outside the window. Without the closing a whole-map search
        on each failure made `map-replan` 1.5 times slower and changed none of 80 validation outcomes; with it, hard
        goal3d went from 47 and 44 to 50 and 49 of 50 validation arenas (ideal, ocean water;
        docs/runs/map-replan-3d/README.md). Not in a tube, which keeps its map and search as they were."""
        return not self.in_tube

    def search_map(self, crop: tuple[slice, ...]) -> np.ndarray:
        """In open water, the map's occupied voxels and the unknown ones its echoes close round: the morphological
        closing (dilation, then erosion) of the echoed voxels by a box of half-extent CLOSING, kept where no beam has
        crossed (log-odds count 0). A voxel a beam crossed stays open, so a gap the fan has seen through is kept.
        The closing is taken on the crop grown by CLOSING (within the map), so that it is the same at the crop's
        edge as inside. Not in a tube, whose 1 m voxels and 3-5 m radius such a closing would seal."""
        occupied = self.occupied[crop]
        if self.in_tube:
            return occupied
        reach = np.round(CLOSING / self.grid.cell).astype(int)
        lo = np.maximum([c.start - r for c, r in zip(crop, reach, strict=True)], 0)
        hi = np.minimum([c.stop + r for c, r in zip(crop, reach, strict=True)], self.grid.shape)
        grown = tuple(slice(a, b) for a, b in zip(lo, hi, strict=True))
        size = tuple(int(v) for v in 2 * reach + 1)
        echoes = self.occupied[grown] & ~self.surface[grown]
        closed = ndimage.minimum_filter(ndimage.maximum_filter(echoes, size=size, mode="constant", cval=False),
                                        size=size, mode="nearest")
        inner = tuple(slice(c.start - a, c.stop - a) for c, a in zip(crop, lo, strict=True))
        return occupied | (closed[inner] & (self.odds[crop] == 0))

    def start(self) -> None:
        super().start()
        self.odds = np.zeros(self.grid.shape, np.int8)
        self.planned_map: np.ndarray | None = None
        self.poses: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=1 + self.task.ocean.sonar_latency)

    def beams(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(origins (28, 3), unit directions (28, 3), ranges (28,)) [m] of the fan's 27 beams and the altimeter's
        in the world, from the held samples and the vehicle's pose; a beam without an echo reads its range limit.

        The fan's ranges are cast from the pose the vehicle had when they were taken: a planner step is one ping
        (PLANNER_DT = 1 / SONAR_RATE_HZ), and the task sees a ping `Ocean3D.sonar_latency` pings late (ocean water:
        one, 0.5 s, 0.75 m at cruise speed), so the pose of that many steps ago. Cast from the pose of now, every
        echo lands 0.75 m beyond the obstacle: a plug's face stood that far behind where it was, and `map-replan`
        passed 31 of 50 hard validation tubes in ideal water with the latency alone, 40 with the ping's pose, 42
        without latency (docs/runs/map-replan-3d/README.md)."""
        model, data = self.physics.model.ptr, self.physics.data.ptr
        sensed = self.task.sensors.read(self.physics)
        sonar, altimeter = model.site("sonar").id, model.site("altimeter").id
        self.poses.append((data.site_xpos[sonar].copy(), _FAN @ data.site_xmat[sonar].reshape(3, 3).T))
        origin, fan = self.poses[0]
        down = -data.site_xmat[altimeter].reshape(3, 3)[:, 2]
        origins = np.vstack([np.repeat(origin[None], len(fan), axis=0), data.site_xpos[altimeter]])
        return origins, np.vstack([fan, down]), np.append(np.asarray(sensed["sonar"], dtype=float),
                                                          float(sensed["altimeter"]))

    def update(self) -> bool:
        """Marks the beams: voxels along each beam short of its range clear, its echo's voxel hit (the log-odds counts
        of the planar map, `auv_mj.arenas.cells.count_beams`)."""
        origins, directions, ranges = self.beams()
        limits = np.append(np.full(len(ranges) - 1, SONAR_RANGE), ALTIMETER_RANGE)
        missed, echoes, hit = cells.beam_marks(self.grid, origins, directions, ranges, limits, SONAR_RANGE,
                                               0.5 * float(np.min(self.grid.cell)), float(self.grid.cell[0]))
        a, b = _NEIGHBOURS[:, 0], _NEIGHBOURS[:, 1]
        join = hit[a] & hit[b] & (np.linalg.norm(echoes[a] - echoes[b], axis=1)
                                  < 2.0 * self.hard + float(self.grid.cell[0]))
        t = np.linspace(0.0, 1.0, JOIN_POINTS)[None, :, None]
        joined = (echoes[a[join]][:, None, :] * (1.0 - t) + echoes[b[join]][:, None, :] * t).reshape(-1, 3)
        echoed = self.grid.flat_cells(np.vstack([echoes[hit], joined]))
        touched, odds = cells.count_beams(self.odds, missed, echoed, HIT, MISS, SATURATION)
        occupied = (odds >= OCCUPIED) | self.surface.flat[touched]
        new = touched[occupied & ~self.occupied.flat[touched]]
        self.occupied.flat[touched] = occupied
        return self.near_path(np.column_stack(np.unravel_index(new, self.grid.shape)))



class TrueVoxelMap(VoxelFollower):
    """The oracle's map: every geom of the arena (the 3-D arenas are static) and the surface. Knowing the walls, it
    looks ORACLE_ROUTE_HORIZON along a tube: time to climb, dive or sidestep to pass a plug at a flyable slope."""

    route_horizon = ORACLE_ROUTE_HORIZON
    whole_map_fallback = True

    def start(self) -> None:
        super().start()
        physics = self.physics
        vehicle = physics.model.ptr.body(VEHICLE_BODY).id
        self.occupied = traps3d.true_map(self.grid, physics.model.ptr, physics.data.ptr, MIN_DEPTH, vehicle)

    def update(self) -> bool:
        return False

    @property
    def guarded(self) -> bool:
        """In a tube without moving obstacles the oracle's map holds every wall and plug exactly, so it follows its
        path without the protection domain; a domain there only pushes: at a plug's edge, 1 m off the path it
        certified, the tube's domain turned the vehicle harder than its fins could take back (validation seed 20003
        of the hard tubes). Without it the oracle passed 50 and 48 of 50 hard validation tubes (seeds 20000-20049,
        ideal and ocean water, `splane-ocean`) against 48 and 47 with it, and 20 and 20 of 20 standard ones.
        In open water (goal3d) and among movers it keeps the domain."""
        return not (self.in_tube and not self.task.movers)


def sonar_voxel_planner(env) -> Planner:
    """`map-replan` on an auv3d planning environment (module docstring)."""
    return SonarVoxelMap(env)


def true_voxel_planner(env) -> Planner:
    """The `oracle` on an auv3d planning environment (module docstring)."""
    return TrueVoxelMap(env)
