"""obstacles and moving_obstacles: reach a target area past unknown obstacles (Sec. 4.1, Tables 7 and 8).

The obstacles are geoms the vehicle knows nothing about: it sees them only through its sonar.

obstacles (static, Table 7, Fig. 10): scenario "a" and "b" are the arenas `models/arenas/
obstacles_table7_{a,b}.xml` (Table 7's start, target and obstacle count; our polygons). "random" (default,
training) draws a random start, heading and goal as the `goal` task does, then MIN_OBSTACLES..
MAX_OBSTACLES boxes from OBSTACLE_SIZES, placed near the straight route (within ROUTE_SPREAD of it), never
within OBSTACLE_CLEARANCE of the start or the goal and OBSTACLE_GAP apart. The boxes are mocap bodies, so
they move between episodes without recompiling; unused ones are parked below the sonar plane.

moving_obstacles (Table 8, Fig. 11): scenario "a" (two obstacles at 0.1 m/s crossing the route
horizontally) and "b" (four at 0.2 m/s crossing vertically) are `models/arenas/moving_table8_{a,b}.xml`.
"random" draws MIN_MOVERS..MAX_MOVERS obstacles of radius MOVER_RADIUS on ping-pong paths across the
route at MOVER_SPEED_RANGE. Movers are moved on the executor's 10 Hz tick.

Named scenarios start facing the target (their `start` site); the paper gives no initial heading.
"""

from __future__ import annotations

import math
from xml.etree import ElementTree as ET

import numpy as np

from auv_mj import arena
from auv_mj.assets import model_path
from tasks import options, planning
from tasks.registry import SUITE

_DEFAULT_TIME_LIMIT = 900.0
"""Seconds (1800 planner steps): the farthest random goal at TARGET_SPEED with detours."""
OBSTACLE_HEIGHT = 2.0
"""Half-height of obstacle geoms [m]: they span the sonar plane z = 0."""
PARK_DEPTH = -100.0
"""z [m] of unused obstacles: below every sonar beam and out of reach of the vehicle."""

SCENARIOS = {"a": "arenas/obstacles_table7_a.xml", "b": "arenas/obstacles_table7_b.xml"}
"""Table 7's static scenarios (shipped arenas)."""
OBSTACLE_SIZES = ((20.0, 8.0), (15.0, 6.0), (12.0, 12.0), (25.0, 5.0), (10.0, 18.0), (8.0, 8.0),
                  (18.0, 10.0), (6.0, 14.0))
"""Half-sizes (x, y) [m] of the random boxes: the pool a random episode draws from (Fig. 10's scale)."""
MIN_OBSTACLES, MAX_OBSTACLES = 3, len(OBSTACLE_SIZES)
"""Number of obstacles of a random episode (inclusive; Table 7 has 6 and 7)."""
ROUTE_SPREAD = 80.0
"""Random obstacles lie within this distance [m] of the straight start-goal line ..."""
OBSTACLE_CLEARANCE = 30.0
"""... keep this far [m] from the start and the goal (a 12.5 m target area plus d0) ..."""
OBSTACLE_GAP = 15.0
"""... and this far from each other [m] (bounding circles), leaving passages wider than 2 d_s."""

MOVING_SCENARIOS = {"a": "arenas/moving_table8_a.xml", "b": "arenas/moving_table8_b.xml"}
"""Table 8's dynamic scenarios (shipped arenas)."""
MIN_MOVERS, MAX_MOVERS = 1, 4
"""Number of moving obstacles of a random episode (inclusive; Table 8 has 2 and 4)."""
MOVER_RADIUS = 5.0
"""Radius of the random moving obstacles [m] (as in the Table 8 arenas)."""
MOVER_SPEED_RANGE = (0.1, 0.2)
"""Speeds of random moving obstacles [m/s] (Table 8)."""
MOVER_HALF_PATH = (20.0, 60.0)
"""Half-length of a random mover's ping-pong path [m]."""
MOVER_CROSSING = (0.25, 0.75)
"""A random mover's path crosses the route at this fraction of its length ..."""
MOVER_SKEW = math.radians(30)
"""... at up to this angle from square to it [rad]."""
PLACEMENT_TRIES = 200
"""Rejection-sampling attempts per random obstacle."""


def random_obstacle_arena(bounds=planning.MAP_BOUNDS) -> ET.Element:
    """Open water with one parked mocap box per OBSTACLE_SIZES entry (`obstacle_0`, ...)."""
    root = planning.open_water_arena(bounds)
    worldbody = root.find("worldbody")
    for i, (hx, hy) in enumerate(OBSTACLE_SIZES):
        body = ET.SubElement(worldbody, "body", name=f"obstacle_{i}", mocap="true", pos=f"0 0 {PARK_DEPTH:g}")
        ET.SubElement(body, "geom", name=f"obstacle_{i}", type="box",
                      size=f"{hx:g} {hy:g} {OBSTACLE_HEIGHT:g}", rgba="0.1 0.1 0.1 1")
    return root


def random_mover_arena(bounds=planning.MAP_BOUNDS) -> ET.Element:
    """Open water with MAX_MOVERS parked mocap cylinders (`mover_0`, ...), given paths per episode."""
    root = planning.open_water_arena(bounds)
    worldbody = root.find("worldbody")
    for i in range(MAX_MOVERS):
        body = ET.SubElement(worldbody, "body", name=f"mover_{i}", mocap="true", pos=f"0 0 {PARK_DEPTH:g}")
        ET.SubElement(body, "geom", name=f"obstacle_mover_{i}", type="cylinder",
                      size=f"{MOVER_RADIUS:g} {OBSTACLE_HEIGHT:g}", rgba="0.7 0.1 0.1 1")
    return root


def _segment_distance(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from `point` to the segment a-b [m]."""
    return planning.distance_to_polyline(point, np.array([a, b]))


def _mocap_id(physics, body: str) -> int:
    model = physics.model.ptr
    return int(model.body_mocapid[model.body(body).id])


class Obstacles(planning.PlanningTask):
    """Reach a target area past static obstacles seen only by the sonar."""

    def __init__(self, scenario: str = "random", **kwargs):
        """`scenario` is "random" or a key of SCENARIOS; other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *SCENARIOS))
        super().__init__(**kwargs)
        self.scenario = scenario

    def route(self, physics, info) -> planning.Route:
        """The arena's start and goal, or a random route with random obstacles placed along it."""
        if self.scenario != "random":
            return planning.Route(start=info.start, heading=info.start_heading, goals=info.goal[None])
        start, heading, goal = planning.random_start_and_goal(self.random, info.bounds)
        self._place_obstacles(physics, info.bounds, start, goal)
        return planning.Route(start=start, heading=heading, goals=goal[None])

    def _place_obstacles(self, physics, bounds, start: np.ndarray, goal: np.ndarray) -> None:
        random = self.random
        data = physics.data.ptr
        along = goal - start
        normal = np.array([-along[1], along[0]]) / np.hypot(*along)
        count = random.randint(MIN_OBSTACLES, MAX_OBSTACLES + 1)
        placed: list[tuple[np.ndarray, float]] = []
        for i in random.permutation(len(OBSTACLE_SIZES))[:count]:
            radius = float(np.hypot(*OBSTACLE_SIZES[i]))
            for _ in range(PLACEMENT_TRIES):
                centre = (start + random.uniform(0.15, 0.85) * along
                          + random.uniform(-ROUTE_SPREAD, ROUTE_SPREAD) * normal)
                inside = (bounds[0] + radius <= centre[0] <= bounds[2] - radius
                          and bounds[1] + radius <= centre[1] <= bounds[3] - radius)
                nearest_end = min(np.hypot(*(centre - start)), np.hypot(*(centre - goal)))
                clear = nearest_end >= radius + OBSTACLE_CLEARANCE
                apart = all(np.hypot(*(centre - c)) >= radius + r + OBSTACLE_GAP for c, r in placed)
                if inside and clear and apart:
                    break
            else:
                continue
            placed.append((centre, radius))
            yaw = random.uniform(-math.pi, math.pi)
            mocap = _mocap_id(physics, f"obstacle_{i}")
            data.mocap_pos[mocap] = (centre[0], centre[1], 0.0)
            data.mocap_quat[mocap] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


class MovingObstacles(planning.PlanningTask):
    """Reach a target area past obstacles moving on ping-pong paths, seen only by the sonar."""

    def __init__(self, scenario: str = "random", **kwargs):
        """`scenario` is "random" or a key of MOVING_SCENARIOS; other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *MOVING_SCENARIOS))
        super().__init__(**kwargs)
        self.scenario = scenario

    def route(self, physics, info) -> planning.Route:
        """The arena's start, goal and movers, or a random route with random movers crossing it."""
        if self.scenario != "random":
            return planning.Route(start=info.start, heading=info.start_heading, goals=info.goal[None],
                                  movers=info.movers)
        start, heading, goal = planning.random_start_and_goal(self.random, info.bounds)
        return planning.Route(start=start, heading=heading, goals=goal[None],
                              movers=self._draw_movers(physics, start, goal))

    def _draw_movers(self, physics, start: np.ndarray, goal: np.ndarray) -> tuple[arena.Mover, ...]:
        random = self.random
        along = goal - start
        square = math.atan2(along[1], along[0]) + math.pi / 2
        movers = []
        for i in range(random.randint(MIN_MOVERS, MAX_MOVERS + 1)):
            for _ in range(PLACEMENT_TRIES):
                centre = start + random.uniform(*MOVER_CROSSING) * along
                angle = square + random.uniform(-MOVER_SKEW, MOVER_SKEW)
                half = random.uniform(*MOVER_HALF_PATH) * np.array([math.cos(angle), math.sin(angle)])
                ends = (centre - half, centre + half)
                if random.rand() < 0.5:
                    ends = ends[::-1]
                reach = MOVER_RADIUS + OBSTACLE_CLEARANCE
                if min(_segment_distance(start, *ends), _segment_distance(goal, *ends)) >= reach:
                    break
            else:
                continue
            name = f"mover_{i}"
            movers.append(arena.Mover(name, ends[0], ends[1], float(random.uniform(*MOVER_SPEED_RANGE))))
            physics.data.ptr.mocap_pos[_mocap_id(physics, name)][2] = 0.0
        return tuple(movers)


@SUITE.add("benchmarking", "goal", "planning", "obstacles")
def obstacles(time_limit=_DEFAULT_TIME_LIMIT, random=None, environment_kwargs=None, scenario="random",
              **task_kwargs):
    """Reach a target past static unknown obstacles (Table 7; scenario="random"|"a"|"b")."""
    task = Obstacles(scenario=scenario, random=random, **task_kwargs)
    physics = (planning.Physics.load(random_obstacle_arena()) if scenario == "random"
               else planning.load_arena(model_path(SCENARIOS[scenario]), need_path=False))
    return planning.environment(physics, task, time_limit, environment_kwargs)


@SUITE.add("benchmarking", "goal", "planning", "obstacles", "moving")
def moving_obstacles(time_limit=_DEFAULT_TIME_LIMIT, random=None, environment_kwargs=None, scenario="random",
                     **task_kwargs):
    """Reach a target past moving unknown obstacles (Table 8; scenario="random"|"a"|"b")."""
    task = MovingObstacles(scenario=scenario, random=random, **task_kwargs)
    physics = (planning.Physics.load(random_mover_arena()) if scenario == "random"
               else planning.load_arena(model_path(MOVING_SCENARIOS[scenario]), need_path=False))
    return planning.environment(physics, task, time_limit, environment_kwargs)
