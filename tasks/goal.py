"""goal: reach one target area in open water (Sec. 4.1, goal-directed behaviour, Table 6 (a), Fig. 9a).

Training episodes ("random", default) start at rest at a random point and heading of the 600 m x 600 m
map, with the goal 100..400 m away (routes.GOAL_DISTANCE_RANGE); the target area has a 25 m diameter
(GOAL_RADIUS). The single-target experiments of Table 6 are `scenario="a1"`, "a2", "a3"; they start facing
the target (the paper gives no initial heading). The multi-target rows (b)1, (b)2 are layouts of the
`waypoints` task.

`arena=PATH` (`--arena PATH`) runs the task on a user's arena instead of open water: an MJCF file (or an
ElementTree root) with `start` and `goal` sites, walls, obstacles and movers (`docs/arenas.md`, `auv-mj arena`),
refused unless `auv-mj check-arena --no-path` finds it usable. Its time limit is then the longer of the default
and `routes.route_time_limit` of the start-to-goal leg.
"""

from __future__ import annotations

import numpy as np

from auv_mj.tasks import options, planning, planning_physics, routes
from auv_mj.tasks.registry import SUITE

_DEFAULT_TIME_LIMIT = 600.0
"""Seconds (1200 planner steps): the farthest random goal at TARGET_SPEED, with room to turn."""
SCENARIOS = {
    "a1": ((300.0, 100.0), (50.0, 325.0)),
    "a2": ((75.0, 125.0), (200.0, 200.0)),
    "a3": ((50.0, 275.0), (300.0, 100.0)),
}
"""Table 6 (a): start and target [m] of the single-target experiments."""


class Goal(planning.PlanningTask):
    """Reach one target area from rest; the map is open water."""

    def __init__(self, scenario: str = "random", **kwargs):
        """`scenario` is "random", a key of SCENARIOS or planning_physics.ARENA_SCENARIO (the arena's own start and
        goal; the factory sets it for `arena=PATH`); other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *SCENARIOS, planning_physics.ARENA_SCENARIO))
        super().__init__(**kwargs)
        self.scenario = scenario

    def route(self, physics, info) -> routes.Route:
        """A random start, heading and goal, the Table 6 scenario, or the user's arena's start and goal."""
        if self.scenario == planning_physics.ARENA_SCENARIO:
            return planning_physics.arena_route(info, self.goal_radius)
        if self.scenario == "random":
            start, heading, goal = routes.random_start_and_goal(self.random, info.bounds)
        else:
            start, goal = (np.array(p) for p in SCENARIOS[self.scenario])
            heading = routes.heading_to(start, goal)
        return routes.Route(start=start, heading=heading, goals=goal[None])


@SUITE.add("benchmarking", "goal", "planning")
def goal(time_limit=None, random=None, environment_kwargs=None, scenario="random", arena=None, **task_kwargs):
    """Reach a target area in open water (Table 6 (a); scenario="random"|"a1"|"a2"|"a3"), or on a user's
    arena (`arena=PATH`, see the module docstring); time_limit defaults to _DEFAULT_TIME_LIMIT."""
    scenario = planning_physics.arena_scenario(arena, "scenario", scenario)
    task = Goal(scenario=scenario, random=random, **task_kwargs)
    physics, user = planning_physics.open_water_physics(arena, task_kwargs.get("conditions"),
                                                        planning_physics.open_water_arena())
    time_limit = planning_physics.arena_time_limit(time_limit, _DEFAULT_TIME_LIMIT, physics, user)
    return planning.environment(physics, task, time_limit, environment_kwargs)
