"""goal: reach one target area in open water (Sec. 4.1, goal-directed behaviour, Table 6 (a), Fig. 9a).

Training episodes ("random", default) start at rest at a random point and heading of the 600 m x 600 m
map, with the goal 100..400 m away (planning.GOAL_DISTANCE_RANGE); the target area has a 25 m diameter
(GOAL_RADIUS). The single-target experiments of Table 6 are `scenario="a1"`, "a2", "a3"; they start facing
the target (the paper gives no initial heading). The multi-target rows (b)1, (b)2 are layouts of the
`waypoints` task.
"""

from __future__ import annotations

import numpy as np

from tasks import options, planning
from tasks.registry import SUITE

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
        """`scenario` is "random" or a key of SCENARIOS; other kwargs go to `PlanningTask`."""
        options.choice("scenario", scenario, ("random", *SCENARIOS))
        super().__init__(**kwargs)
        self.scenario = scenario

    def route(self, physics, info) -> planning.Route:
        """A random start, heading and goal, or the Table 6 scenario."""
        if self.scenario == "random":
            start, heading, goal = planning.random_start_and_goal(self.random, info.bounds)
        else:
            start, goal = (np.array(p) for p in SCENARIOS[self.scenario])
            heading = planning.heading_to(start, goal)
        return planning.Route(start=start, heading=heading, goals=goal[None])


@SUITE.add("benchmarking", "goal", "planning")
def goal(time_limit=_DEFAULT_TIME_LIMIT, random=None, environment_kwargs=None, **task_kwargs):
    """Reach a target area in open water (Table 6 (a); task_kwargs scenario="random"|"a1"|"a2"|"a3")."""
    physics = planning.Physics.load(planning.open_water_arena(), task_kwargs.get("conditions"))
    task = Goal(random=random, **task_kwargs)
    return planning.environment(physics, task, time_limit, environment_kwargs)
