"""obstacles and moving_obstacles: reach a target area past unknown obstacles (Sec. 4.1, Tables 7 and 8).

The obstacles are geoms the vehicle knows nothing about: it sees them only through its sonar.

obstacles (static, Table 7, Fig. 10): scenario "a" and "b" are the arenas `models/arenas/
obstacles_table7_{a,b}.xml` (Table 7's start, target and obstacle count; our polygons). "random" (default,
training; `arena="random"` says the same) draws a fresh layout every episode (`random_layout`): a random
start, heading and goal as the `goal` task does, then boxes of the open-water generator
`auv_mj.arenas.procedural.random_boxes` (CLUTTER: sizes, counts and spacing) near the straight route. The boxes
are mocap bodies, so they move between episodes without recompiling; unused ones are parked below the
sonar plane.

moving_obstacles (Table 8, Fig. 11): scenario "a" (two obstacles at 0.1 m/s crossing the route
horizontally) and "b" (four at 0.2 m/s crossing vertically) are `models/arenas/moving_table8_{a,b}.xml`.
"random" draws movers on ping-pong paths across the route (`auv_mj.arenas.procedural.random_crossers`, CLUTTER).
Movers are moved on the executor's 10 Hz tick.

`auv-mj tunnel --random SEED --task obstacles` writes the layout of a random episode as an arena file.

`tier="hard"` (with the random scenario; issue 30) draws each episode's arena from `auv_mj.arenas.traps`
instead: concave traps (cups, wedges, long walls with a gap at one end) in series and dense clutter across a
longer route, with movers at up to 1 m/s crossing and head-on on moving_obstacles; each arena is certified
feasible on the oracle's grid and compiled per episode. `tier="standard"` (default) is the layouts above.

`arena=PATH` (`--arena PATH`) runs either task on a user's arena: an MJCF file (or an ElementTree root) with
`start` and `goal` sites, walls, obstacles and movers on their paths (`docs/arenas.md`; `auv-mj arena` builds one
from a list of shapes), refused unless `auv-mj check-arena --no-path` finds it usable. The episode is the named
scenarios' (the arena's start, goal and movers); its time limit is the longer of the default and
`routes.route_time_limit` of the start-to-goal leg.

Named scenarios start facing the target (their `start` site); the paper gives no initial heading.
"""

from __future__ import annotations

import math
from xml.etree import ElementTree as ET

import numpy as np

from auv_mj.arenas import arena, procedural, traps
from auv_mj.arenas.tunnels import mover_name
from auv_mj.assets import model_path
from auv_mj.tasks import options, planning, planning_physics, routes
from auv_mj.tasks.registry import SUITE

_DEFAULT_TIME_LIMIT = 900.0
"""Seconds (1800 planner steps): the farthest random goal at TARGET_SPEED with detours."""
OBSTACLE_HEIGHT = 2.0
"""Half-height of obstacle geoms [m]: they span the sonar plane z = 0."""
PARK_DEPTH = -100.0
"""z [m] of unused obstacles: below every sonar beam and out of reach of the vehicle."""

SCENARIOS = {"a": "arenas/obstacles_table7_a.xml", "b": "arenas/obstacles_table7_b.xml"}
"""Table 7's static scenarios (shipped arenas)."""
MOVING_SCENARIOS = {"a": "arenas/moving_table8_a.xml", "b": "arenas/moving_table8_b.xml"}
"""Table 8's dynamic scenarios (shipped arenas)."""
CLUTTER = procedural.ClutterSpec()
"""The random layouts' obstacles and movers (sizes, counts, spacing: `procedural.ClutterSpec`)."""


def random_layout(random: np.random.RandomState, moving: bool,
                  bounds=planning_physics.MAP_BOUNDS) -> procedural.Clutter:
    """A random episode's layout drawn from `random`: start, heading and goal as the `goal` task draws
    them, then boxes (`obstacles`) or movers (`moving_obstacles`) along the route. With a fresh
    RandomState(seed) it is the first episode of the task seeded `seed` (`auv-mj tunnel --random`)."""
    start, heading, goal = routes.random_start_and_goal(random, bounds)
    if moving:
        return procedural.Clutter(start, heading, goal, tuple(bounds),
                                  movers=procedural.random_crossers(random, start, goal, CLUTTER), spec=CLUTTER)
    return procedural.Clutter(start, heading, goal, tuple(bounds),
                              boxes=procedural.random_boxes(random, start, goal, bounds, CLUTTER), spec=CLUTTER)


def random_obstacle_arena(bounds=planning_physics.MAP_BOUNDS) -> ET.Element:
    """Open water with one parked mocap box per CLUTTER.sizes entry (`obstacle_0`, ...)."""
    root = planning_physics.open_water_arena(bounds)
    worldbody = root.find("worldbody")
    for i, (hx, hy) in enumerate(CLUTTER.sizes):
        body = ET.SubElement(worldbody, "body", name=f"obstacle_{i}", mocap="true", pos=f"0 0 {PARK_DEPTH:g}")
        ET.SubElement(body, "geom", name=f"obstacle_{i}", type="box",
                      size=f"{hx:g} {hy:g} {OBSTACLE_HEIGHT:g}", rgba="0.1 0.1 0.1 1")
    return root


def random_mover_arena(bounds=planning_physics.MAP_BOUNDS) -> ET.Element:
    """Open water with CLUTTER.movers[1] parked mocap cylinders (`mover_0`, ...), given paths per episode."""
    root = planning_physics.open_water_arena(bounds)
    worldbody = root.find("worldbody")
    for i in range(CLUTTER.movers[1]):
        body = ET.SubElement(worldbody, "body", name=f"mover_{i}", mocap="true", pos=f"0 0 {PARK_DEPTH:g}")
        ET.SubElement(body, "geom", name=f"obstacle_mover_{i}", type="cylinder",
                      size=f"{CLUTTER.mover_radius:g} {OBSTACLE_HEIGHT:g}", rgba="0.7 0.1 0.1 1")
    return root


def _mocap_id(physics, body: str) -> int:
    model = physics.model.ptr
    return int(model.body_mocapid[model.body(body).id])


def _tier(tier: str, scenario: str) -> str:
    """The `tier` option: "standard" (today's layouts) or "hard" (`auv_mj.arenas.traps`, random scenario only)."""
    options.choice("tier", tier, traps.TIERS)
    if tier == "hard" and scenario != "random":
        raise ValueError(f"tier=\"hard\" applies to arena=\"random\" (scenario=\"random\"), not scenario={scenario!r}")
    return tier


def _draw_hard(task: planning.PlanningTask, physics, spec: traps.HardSpec) -> None:
    """Draws the episode's hard arena from the task's `random` and recompiles the physics around it."""
    task.layout = traps.random_hard_layout(task.random, planning_physics.MAP_BOUNDS, spec, task.goal_radius)
    xml, source = arena.compose_xml(task.layout.element(), thruster_lag=task.ocean.conditions.thruster_lag)
    physics.reload_from_xml_string(xml, source=source)


def _hard_route(task: planning.PlanningTask, info) -> routes.Route:
    """The hard arena's start, goal and movers."""
    layout = task.layout
    return routes.Route(start=layout.start, heading=layout.heading, goals=layout.goal[None], movers=info.movers)


class Obstacles(planning.PlanningTask):
    """Reach a target area past static obstacles seen only by the sonar."""

    kind = "obstacles"

    def __init__(self, scenario: str = "random", tier: str = "standard", **kwargs):
        """`scenario` is "random", a key of SCENARIOS or planning_physics.ARENA_SCENARIO (a user's arena, set by the
        factory for `arena=PATH`); other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *SCENARIOS, planning_physics.ARENA_SCENARIO))
        super().__init__(**kwargs)
        self.scenario = scenario
        self.tier = _tier(tier, scenario)
        """"standard" or "hard" (`tier`: a hard arena of `auv_mj.arenas.traps` per episode)."""

    def initialize_episode(self, physics) -> None:
        """With tier="hard", draws the episode's hard arena (HARD_OBSTACLES) and recompiles the physics first."""
        if self.tier == "hard":
            _draw_hard(self, physics, traps.HARD_OBSTACLES)
        super().initialize_episode(physics)

    def route(self, physics, info) -> routes.Route:
        """The arena's start and goal (and movers, on a user's arena), or a random route with random obstacles
        placed along it."""
        if self.tier == "hard":
            return _hard_route(self, info)
        if self.scenario == planning_physics.ARENA_SCENARIO:
            return planning_physics.arena_route(info, self.goal_radius)
        if self.scenario != "random":
            return routes.Route(start=info.start, heading=info.start_heading, goals=info.goal[None])
        layout = random_layout(self.random, moving=False, bounds=info.bounds)
        data = physics.data.ptr
        for box in layout.boxes:
            mocap = _mocap_id(physics, f"obstacle_{box.size}")
            data.mocap_pos[mocap] = (box.centre[0], box.centre[1], 0.0)
            data.mocap_quat[mocap] = (math.cos(box.yaw / 2), 0.0, 0.0, math.sin(box.yaw / 2))
        return routes.Route(start=layout.start, heading=layout.heading, goals=layout.goal[None])


class MovingObstacles(planning.PlanningTask):
    """Reach a target area past obstacles moving on ping-pong paths, seen only by the sonar."""

    kind = "moving_obstacles"

    def __init__(self, scenario: str = "random", tier: str = "standard", **kwargs):
        """`scenario` is "random", a key of MOVING_SCENARIOS or planning_physics.ARENA_SCENARIO (a user's arena, set by
        the factory for `arena=PATH`); other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *MOVING_SCENARIOS, planning_physics.ARENA_SCENARIO))
        super().__init__(**kwargs)
        self.scenario = scenario
        self.tier = _tier(tier, scenario)
        """"standard" or "hard" (`tier`: a hard arena of `auv_mj.arenas.traps` per episode)."""

    def initialize_episode(self, physics) -> None:
        """With tier="hard", draws the episode's hard arena (HARD_MOVING) and recompiles the physics first."""
        if self.tier == "hard":
            _draw_hard(self, physics, traps.HARD_MOVING)
        super().initialize_episode(physics)

    def route(self, physics, info) -> routes.Route:
        """The arena's start, goal and movers, or a random route with random movers crossing it."""
        if self.tier == "hard":
            return _hard_route(self, info)
        if self.scenario != "random":
            return planning_physics.arena_route(info, self.goal_radius)
        layout = random_layout(self.random, moving=True, bounds=info.bounds)
        movers = tuple(arena.Mover(mover_name(m, k), np.array([m.x0, m.y0]), np.array([m.x1, m.y1]), m.speed)
                       for k, m in enumerate(layout.movers))
        for mover in movers:
            physics.data.ptr.mocap_pos[_mocap_id(physics, mover.body)][2] = 0.0
        return routes.Route(start=layout.start, heading=layout.heading, goals=layout.goal[None], movers=movers)


def _physics(scenario: str, arena_option, conditions, random_arena,
             shipped: dict) -> tuple[planning_physics.Physics, bool]:
    """The physics of a scenario: the parked random arena, a user's arena or a shipped one; and whether user's."""
    if scenario == planning_physics.ARENA_SCENARIO:
        return planning_physics.open_water_physics(arena_option, conditions, random_arena)
    if scenario == "random":
        return planning_physics.Physics.load(random_arena, conditions), False
    return planning_physics.load_arena(model_path(shipped[scenario]), need_path=False, conditions=conditions), False


@SUITE.add("benchmarking", "goal", "planning", "obstacles")
def obstacles(time_limit=None, random=None, environment_kwargs=None, scenario="random", arena=None, **task_kwargs):
    """Reach a target past static unknown obstacles (Table 7; scenario="random"|"a"|"b"; arena="random"
    is scenario="random", a fresh layout per episode; arena=PATH a user's arena); time_limit defaults to
    _DEFAULT_TIME_LIMIT."""
    scenario = planning_physics.arena_scenario(arena, "scenario", scenario)
    task = Obstacles(scenario=scenario, random=random, **task_kwargs)
    physics, user = _physics(scenario, arena, task_kwargs.get("conditions"), random_obstacle_arena(), SCENARIOS)
    time_limit = planning_physics.arena_time_limit(time_limit, _DEFAULT_TIME_LIMIT, physics, user)
    return planning.environment(physics, task, time_limit, environment_kwargs)


@SUITE.add("benchmarking", "goal", "planning", "obstacles", "moving")
def moving_obstacles(time_limit=None, random=None, environment_kwargs=None, scenario="random", arena=None,
                     **task_kwargs):
    """Reach a target past moving unknown obstacles (Table 8; scenario="random"|"a"|"b"; arena="random"
    is scenario="random", a fresh layout per episode; arena=PATH a user's arena); time_limit defaults to
    _DEFAULT_TIME_LIMIT."""
    scenario = planning_physics.arena_scenario(arena, "scenario", scenario)
    task = MovingObstacles(scenario=scenario, random=random, **task_kwargs)
    physics, user = _physics(scenario, arena, task_kwargs.get("conditions"), random_mover_arena(),
                             MOVING_SCENARIOS)
    time_limit = planning_physics.arena_time_limit(time_limit, _DEFAULT_TIME_LIMIT, physics, user)
    return planning.environment(physics, task, time_limit, environment_kwargs)
