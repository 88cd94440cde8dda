"""The classical planners of the benchmark (issue 30): `los_fast`, `map_replan` and `oracle`.

Each is `factory(env) -> policy(time_step) -> action` on a planning task's suite environment, on the sensors
and the speed envelope of the learned planners: the nine sonar ranges of the observation, the vehicle's pose
(what line of sight already reads, `env.physics.pose()`), the task's route (its goals) and the map's edge
(the geofence). Every one cruises at the top speed MAX_SPEED = 2 m/s inside the speed-aware protection domain
(`auv_mj.planners.avoidance.PROTECTIONS["speed-aware"]`) with the geofence, as `planner-general` is deployed.

- `los_fast`: line of sight along the route at 2 m/s under that domain: `planner-general`'s zero action (but
  for the approach to a small final goal, `approach_speed`, which every planner here shares).
- `map_replan`: the mapping local planner of an AUV stack (Choset et al., *Principles of Robot Motion*, Ch. 2
  and 5; LaValle, *Planning Algorithms*, Ch. 5-6). An occupancy grid of CELL metres is filled online from the
  sonar rays (unknown space free: log-odds counts, HIT and MISS); whenever the map changes near the planned
  path, at most every REPLAN_STEPS planner steps, Dijkstra's algorithm searches it again
  (`auv_mj.arenas.grid.shortest_path`: cells nearer than INFLATION to an echo are closed, cells within
  SOFT_CLEARANCE cost more) to the goal, or on a route of many goals (a tunnel's path) to the route point
  `auv_mj.tasks.routes.ROUTE_HORIZON` metres on (`route_target`); line of sight then follows the path, aiming
  LOOKAHEAD metres along it.
- `oracle`: the same search and follower on the true map: every geom's footprint, unknown obstacles included,
  and the movers where they are (swept over MOVER_HORIZON seconds at their measured velocity), replanned every
  ORACLE_REPLAN_STEPS. It is no competitor: it certifies that an arena is feasible and gives the reference time
  of the time-efficiency score (oracle time / own time on a success, 0 on a failure; SPL, Anderson et al. 2018).
"""

from __future__ import annotations

import math

import dm_env
import mujoco
import numpy as np

from auv_mj.arenas import arena, grid, sonar_memory
from auv_mj.arenas.sonar_memory import MEMORY_BEAMS, SonarMemory, memory_bounds
from auv_mj.episode import VEHICLE_BODY, FunctionPlanner, Planner, PlannerBase, arena_geometry, geom_footprint
from auv_mj.planners.avoidance import PROTECTIONS, map_fence, with_repulsion
from auv_mj.planners.guidance import approach_speed, los_heading
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks.planning_observation import SONAR_SLICE
from auv_mj.tasks.planning_rewards import FOLLOW_REACHED, PROGRESS_GAIN
from auv_mj.tasks.planning_step import MAX_SPEED, PLANNER_DT
from auv_mj.tasks.routes import route_target_index

PROTECTION = PROTECTIONS["speed-aware"]
"""The protection domain every planner here runs inside, with the geofence (what `planner-general` runs with)."""
CELL = grid.CELL
"""Cell size of the occupancy grid [m] (2 m: a fifth of the narrowest gap of the hard tier)."""
INFLATION = grid.HARD_CLEARANCE
"""Hard inflation [m]: a planned cell centre keeps this far from an echo's cell (hull half length 0.665 m plus
the 1.4 m of rasterisation, to spare); the protection domain keeps d_s = 5 m beyond it."""
SOFT_CLEARANCE = grid.SOFT_CLEARANCE
"""Cells nearer than this [m] to an echo cost more: paths keep hull + d_s and more where there is room."""
REPLAN_STEPS = 4
"""Least planner steps (2 s) between two searches when the map changed near the path ..."""
REPLAN_PERIOD = 40
"""... and a search every this many steps (20 s) regardless."""
OFF_PATH = 10.0
"""A vehicle this far [m] from its planned path (pushed off by the protection domain) plans again."""
LOOKAHEAD = 14.0
"""Line of sight aims at the path's point this far [m] ahead of the vehicle's nearest one (pure pursuit)."""
ROUTE_TARGET_RADIUS = 4.0
"""Radius [m] of such an intermediate target (the route's last goal keeps the task's radius)."""
WINDOW = 120.0
"""The search stays within the bounding box of vehicle and target grown by this [m]."""
ORACLE_REPLAN_STEPS = 4
"""The oracle searches again every this many steps (2 s) when the arena has movers."""
MOVER_HORIZON = 6.0
"""The oracle closes each mover's footprint swept over this many seconds [s] at its measured velocity."""
SONAR_OFFSET = 0.665
"""The sonars' origin ahead of the vehicle's centre [m] (the `sonar_site_*` of the vehicle MJCF)."""

def sonar_rays(pose) -> tuple[np.ndarray, np.ndarray]:
    """The sonars' origin (x, y) [m] and the nine beams' unit directions (9 x 2) in the world frame at `pose`
    (x, y, psi) (`auv_mj.arenas.sonar_memory.sonar_rays`): a beam's echo at range r lies at origin + r * direction."""
    return sonar_memory.sonar_rays(pose[:2], pose[2], SONAR_OFFSET)


def fast_line_of_sight(env) -> Planner:
    """Line of sight along the route at 2 m/s (no protection domain: `los_fast` adds it), slowing to 1 m/s
    near a small final goal as every planner here does (`approach_speed`): without it, it circles a tunnel's
    2 m final goal in wide water for ever. On open water (12.5 m goals) it is `planner-general`'s zero action."""

    def policy(time_step: dm_env.TimeStep) -> np.ndarray:
        pose = env.physics.pose()
        return np.array([approach_speed(env.task, pose), los_heading(time_step.observation["desired_goal"], pose)])

    return FunctionPlanner(policy)


def los_fast(env) -> Planner:
    """Line of sight along the route at 2 m/s inside the speed-aware domain with the geofence."""
    return with_repulsion(fast_line_of_sight(env), PROTECTION, map_fence(env))


def _bounds(env) -> tuple[float, float, float, float]:
    """The episode's map (`arena_bounds`), or the box round its start and goals grown by SONAR_RANGE."""
    info = arena.arena_info(env.physics)
    return memory_bounds(info.bounds, np.vstack([env.physics.pose()[:2], env.task.goals]), SONAR_RANGE)


def route_target(task) -> tuple[np.ndarray, float, int]:
    """A planning task's target for a planner that looks ahead along its route: the goal itself, or on a route
    of many goals (a tunnel's path) the route point ROUTE_HORIZON metres on from the current goal (the task layer's
    rule, `auv_mj.tasks.routes.route_target_index`, which the planner observation shows a learner too); its radius
    [m] (ROUTE_TARGET_RADIUS short of the route's end) and its index on the route."""
    goals, index = task.goals, task.goal_index
    if len(goals) == 1:
        return goals[0], task.goal_radius, index
    k = int(route_target_index(goals[None], np.array([len(goals)]), np.array([index]))[0])
    radius = task.goal_radius if k == len(goals) - 1 else ROUTE_TARGET_RADIUS
    return goals[k], radius, k


class Replanning:
    """When a mapping planner searches its map again, in the plane (`GridFollower`) and in 3-D
    (`auv_mj.planners.map_planner3d.VoxelFollower`): the follower keeps `path`, `since_plan` (planner steps since the
    last search), `target_key` and a `plan(here, goal, radius)` that searches."""

    replan_steps = REPLAN_STEPS
    """Least planner steps between two searches when the map changed near the path."""
    replan_period = REPLAN_PERIOD
    """A search every this many planner steps regardless."""

    def replan_if_due(self, changed: bool, here: np.ndarray, goal: np.ndarray, radius: float, key) -> None:
        """Counts a planner step and searches again when there is no path, the target moved on (`key` changed),
        `replan_period` steps have passed, or the map `changed` near the path and `replan_steps` have passed."""
        self.since_plan += 1
        if (self.path is None or key != self.target_key or self.since_plan >= self.replan_period
                or (changed and self.since_plan >= self.replan_steps)):
            self.target_key = key
            self.plan(here, goal, radius)


class GridFollower(Replanning, PlannerBase):
    """A search on an occupancy grid, replanned when it must (`Replanning`), followed by line of sight (module
    docstring).

    Subclasses fill `self.occupied` (`start`, `update`) and say when the map changed near the path.
    """

    def __init__(self, env):
        self.env = env
        self.grid: grid.Grid | None = None

    def reset(self) -> None:
        """Forgets the map and the path (the next step starts a new episode)."""
        self.grid = None

    def start(self) -> None:
        """A new episode: an empty map over the episode's bounds."""
        self.grid = grid.Grid.covering(_bounds(self.env), CELL, margin=CELL)
        self.occupied = np.zeros(self.grid.shape, bool)
        self.path: np.ndarray | None = None
        self.progress = 0
        self.since_plan = 0
        self.target_key = None

    def update(self, time_step: dm_env.TimeStep, pose: np.ndarray) -> bool:
        """Brings the map up to date; whether it changed near the path."""
        raise NotImplementedError

    def target(self) -> tuple[np.ndarray, float, int]:
        """The search's target, its radius [m] and a key that changes when the target does (`route_target`)."""
        return route_target(self.env.task)

    def plan(self, pose: np.ndarray, goal: np.ndarray, radius: float) -> None:
        """Searches the map from the vehicle to the target; keeps the old path when none is found."""
        cost = grid.cost_field(grid.clearance(self.grid, self.occupied), INFLATION, SOFT_CLEARANCE)
        path = grid.shortest_path(self.grid, cost, pose[:2], goal, radius, WINDOW)
        if path is None:
            path = grid.shortest_path(self.grid, cost, pose[:2], goal, radius)
        self.since_plan = 0
        if path is not None:
            path[-1] = goal if np.hypot(*(path[-1] - goal)) <= radius else path[-1]
            self.path, self.progress = np.vstack([pose[:2], path]), 0

    def carrot(self, pose: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """The point LOOKAHEAD along the path past the vehicle's nearest one, and the vehicle's distance to
        the path [m]."""
        if self.path is None:
            return goal, 0.0
        ahead = self.path[self.progress:]
        gaps = np.hypot(*(ahead - pose[:2]).T)
        nearest = int(np.argmin(gaps[: max(1, int(4 * LOOKAHEAD / CELL))]))
        self.progress += nearest
        steps = np.hypot(*np.diff(self.path[self.progress:], axis=0).T)
        along = np.concatenate([[0.0], np.cumsum(steps)])
        k = int(np.searchsorted(along, LOOKAHEAD))
        point = self.path[self.progress + k] if k < len(along) else self.path[-1]
        return point, float(gaps[nearest])

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        pose = np.array(self.env.physics.pose(), dtype=float)
        point, _ = self.waypoint(time_step)
        return np.array([approach_speed(self.env.task, pose), los_heading(point, pose)])

    def waypoint(self, time_step: dm_env.TimeStep) -> tuple[np.ndarray, float]:
        """Brings the map and the plan up to date; the point line of sight aims at, and the length [m] of the
        planned path left from the vehicle to its end."""
        pose = np.array(self.env.physics.pose(), dtype=float)
        if self.grid is None or time_step.first():
            self.start()
        changed = self.update(time_step, pose)
        goal, radius, key = self.target()
        self.replan_if_due(changed, pose, goal, radius, key)
        point, off = self.carrot(pose, goal)
        if off > OFF_PATH and self.since_plan >= self.replan_steps:
            self.plan(pose, goal, radius)
            point, _ = self.carrot(pose, goal)
        left = float(np.hypot(*(point - pose[:2])))
        if self.path is not None:
            left = max(left, grid.path_length(self.path[self.progress:]))
        return point, left


class SonarMap(GridFollower):
    """`map_replan`'s map: log-odds counts of the sonar's echoes and clear beams, unknown space free
    (`auv_mj.arenas.sonar_memory.SonarMemory`, the map a learned planner reads under observation="planner-map")."""

    def start(self) -> None:
        super().start()
        self.memory = SonarMemory(_bounds(self.env))

    def update(self, time_step: dm_env.TimeStep, pose: np.ndarray) -> bool:
        """Marks the nine beams: cells along each beam short of its range clear, its echo's cell hit
        (`SonarMemory.add_scan`)."""
        ranges = np.asarray(time_step.observation["observation"])[SONAR_SLICE] * SONAR_RANGE
        origin, directions = sonar_rays(pose)
        new = self.memory.add_scan(origin, directions, ranges, SONAR_RANGE)
        self.occupied = self.memory.occupied
        if not new.any() or self.path is None:
            return bool(new.any())
        fresh = self.grid.centre(*np.nonzero(new))
        near = np.min(np.hypot(*(fresh[:, None, :] - self.path[None, self.progress::2, :]).transpose(2, 0, 1)))
        return bool(near < SOFT_CLEARANCE + CELL)


class TrueMap(GridFollower):
    """The oracle's map: every geom's footprint at t = 0, and the movers' where they are now."""

    replan_steps = ORACLE_REPLAN_STEPS

    def start(self) -> None:
        super().start()
        physics = self.env.physics
        model, data = physics.model.ptr, physics.data.ptr
        movers = set(arena_geometry(physics, self.env.task).mover_names)
        vehicle = model.body(VEHICLE_BODY).id
        self.static = np.zeros(self.grid.shape, bool)
        self.moving: list[int] = []
        for g in range(model.ngeom):
            body = int(model.geom_bodyid[g])
            root = body
            while int(model.body_parentid[root]) != 0:
                root = int(model.body_parentid[root])
            if root == vehicle or model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
                continue
            if abs(data.geom_xpos[g][2]) > model.geom_rbound[g] > 0:
                continue  # parked below the plane (an unused obstacle of a random arena)
            if model.body(root).name in movers:
                self.moving.append(g)
                continue
            outline = geom_footprint(model, data, g)
            if outline is not None:
                grid.rasterise(self.grid, [outline], self.static)
        self.occupied = self.static.copy()
        self.last_seen: tuple[float, np.ndarray] | None = None

    def update(self, time_step: dm_env.TimeStep, pose: np.ndarray) -> bool:
        """The movers' footprints now, swept MOVER_HORIZON ahead at their velocity since the last look."""
        if not self.moving:
            return False
        if self.since_plan + 1 < self.replan_steps and self.path is not None:
            return False
        physics = self.env.physics
        model, data = physics.model.ptr, physics.data.ptr
        now, centres = float(physics.time()), data.geom_xpos[self.moving][:, :2].copy()
        velocity = np.zeros_like(centres)
        if self.last_seen is not None and now > self.last_seen[0]:
            velocity = (centres - self.last_seen[1]) / (now - self.last_seen[0])
        self.last_seen = (now, centres)
        occupied = self.static.copy()
        for k, g in enumerate(self.moving):
            outline = geom_footprint(model, data, g)
            if outline is None:
                continue
            for dt in np.linspace(0.0, MOVER_HORIZON, 4):
                grid.rasterise(self.grid, [outline + velocity[k] * dt], occupied)
        self.occupied = occupied
        return True


def sonar_map_planner(env) -> Planner:
    """The mapping local planner's search and follower (no protection domain: `map_replan` adds it)."""
    return SonarMap(env)


def true_map_planner(env) -> Planner:
    """The oracle's search and follower on the true map (no protection domain: `oracle` adds it)."""
    return TrueMap(env)


def map_replan(env) -> Planner:
    """The mapping local planner (module docstring) inside the speed-aware domain with the geofence."""
    return with_repulsion(sonar_map_planner(env), PROTECTION, map_fence(env))


def oracle(env) -> Planner:
    """The planner on the true map (module docstring) inside the speed-aware domain with the geofence."""
    return with_repulsion(true_map_planner(env), PROTECTION, map_fence(env))





GUIDES = ("route", "map", "map-memory")
"""What a residual planner's goal input is: "route", the task's own goal (the straight route), "map", the
virtual goal along `map_replan`'s planned path (`MapGuide`), or "map-memory", that goal and the map itself as
an input too: MEMORY_BEAMS ranges cast on the sonar map all round the vehicle (`MapGuide`, `memory=True`)."""


class MapGuide:
    """The sonar map's planned path as a planner's goal: the memory of a map-guided residual planner (issue 30).

    Each step it brings `SonarMap` up to date (the map, and the search when it must run again, as `map_replan`)
    and puts a virtual goal in the observation in place of the task's: on the bearing of the path's look-ahead
    point, as far away as the planned path is long, so that the body-frame goal the planner reads (distance and
    bearing, `auv_mj.tasks.planning_observation.RELATIVE_FIELDS`) keeps the range it has on the straight route.
    Line of sight, which a residual planner corrects (`auv_mj.planners.guidance`), then aims along the path: with the
    learned output zeroed the planner is `map_replan`'s follower at the zero action's speed.
    """

    def __init__(self, env, memory: bool = False):
        self.env = env
        self.follower = SonarMap(env)
        self.memory = bool(memory)
        """Whether the observation also carries the map (`memory_scan`, guide="map-memory")."""
        self.inserted_inputs: tuple[int, int] | None = None
        """(index, count) of the inputs this guide puts into the observation vector (the memory scan, just before
        the sonar block, so that SONAR_SLICE still reads the sonar); None when it adds none."""
        if self.memory:
            size = int(np.prod(env.observation_spec()["observation"].shape))
            self.inserted_inputs = SONAR_SLICE.indices(size)[0], MEMORY_BEAMS
        self.left = self.left_before = 0.0
        """The planned path's length left [m] at the last call, and at the call before."""

    def memory_scan(self, pose: np.ndarray) -> np.ndarray:
        """The map's memory in the body frame: MEMORY_BEAMS ranges / MEMORY_RANGE cast on the sonar map's
        occupied cells from the vehicle's centre (`SonarMemory.scan`), beam k at psi + k 2 pi / 16."""
        return self.follower.memory.scan(pose[:2], pose[2])

    def reset(self) -> None:
        """Forgets the map (the next step starts a new episode)."""
        self.follower.reset()

    def reward(self, info: dict) -> float:
        """`path_reward` of the step between the last two calls (`info`: the task's `last_info` of that step)."""
        return path_reward(self.left_before, self.left, info)

    def __call__(self, time_step: dm_env.TimeStep) -> tuple[dict, float]:
        """The observation with the virtual goal in it, and the planned path's length left [m]."""
        point, left = self.follower.waypoint(time_step)
        self.left_before, self.left = (left if time_step.first() else self.left), left
        pose = np.array(self.env.physics.pose(), dtype=float)
        bearing = math.atan2(point[1] - pose[1], point[0] - pose[0])
        observation = dict(time_step.observation)
        desired = np.asarray(observation["desired_goal"], dtype=float).copy()
        desired[:2] = pose[:2] + left * np.array([math.cos(bearing), math.sin(bearing)])
        if desired.size == 4:
            desired[2:] = (math.cos(bearing), math.sin(bearing))
        vector = self.env.task.relabel_observation(observation["observation"], observation["achieved_goal"], desired)
        if self.memory:
            at, _ = self.inserted_inputs
            vector = np.concatenate([vector[:at], self.memory_scan(pose), vector[at:]])
        observation["observation"] = vector
        observation["desired_goal"] = desired
        return observation, left


PATH_STEP = 1.5 * MAX_SPEED * PLANNER_DT
"""Largest path progress [m] one planner step is paid for under guide="map" (`path_reward`): 1.5 times what
the top speed covers in a planner step (1.5 m). The path's length also jumps when the map changes (a wall
found ahead, the target moving on along a route); the cap keeps such a jump from paying or costing more than
one step can."""


def path_reward(left_before: float, left: float, info: dict) -> float:
    """The reward of a map-guided planner's step (guide="map"): reward="progress" on the planned path's length
    left instead of the straight distance (PROGRESS_GAIN per metre, capped at PATH_STEP), +4 (Eq. 23) on reaching
    a goal, and the task's goal-independent part (Eqs. 24-25: avoidance, the per-step cost, any collision
    penalty). In a trap the straight distance rewards the way into the cup; the path's length, the way round."""
    gained = min(max(left_before - left, -PATH_STEP), PATH_STEP)
    reached = FOLLOW_REACHED if info.get("event") in ("goal", "subgoal") else 0.0
    return float(PROGRESS_GAIN * gained + reached + info["goal_independent_reward"])
