"""waypoints: reach target areas in turn (Sec. 3.2.4 virtual sub-goals; Table 6 (b)-(d), Fig. 9b-d).

`desired_goal` is the current target; reaching it (GOAL_RADIUS, the 25 m target area of Table 6) makes
the next one current (event "subgoal", r_following +4); reaching the last is success. Layouts:
- "random" (default, training): a random start and heading, then MIN_WAYPOINTS..MAX_WAYPOINTS targets,
  each LEG_RANGE m from the previous one;
- "b1", "b2": the multi-target experiments of Table 6 (b): its start and end target, with intermediate
  targets of our design (the paper only draws them, Fig. 9b);
- "c": the wide-field water search of Fig. 9c, a lawnmower of four north-south lanes from (75, 25) to
  (425, 350);
- "d": the river waterway search traversal of Fig. 9d, a meandering waterway from (25, 375) to (425, 25).
Named layouts start facing their first target.

`arena=PATH` (`--arena PATH`) runs the task on a user's arena: an MJCF file (or an ElementTree root) whose
`path_0`, `path_1`, ... sites are the targets in order, then its `goal` site (`docs/arenas.md`); path sites within
the goal radius of the `start` site are not targets. It is refused unless `auv-mj check-arena --no-path` finds it
usable; its time limit is the longer of the default and `routes.route_time_limit` of the route.
"""

from __future__ import annotations

import math

import numpy as np

from auv_mj.tasks import options, planning, planning_physics, routes
from auv_mj.tasks.registry import SUITE

_DEFAULT_TIME_LIMIT = 4000.0
"""Seconds (8000 planner steps): the longest layout ("c", 1650 m) at TARGET_SPEED, twice over."""
MIN_WAYPOINTS, MAX_WAYPOINTS = 2, 5
"""Number of targets of a random layout (inclusive)."""
LEG_RANGE = (60.0, 200.0)
"""Distance between consecutive random targets [m]."""
LAYOUTS = {
    "b1": ((70.0, 380.0), ((180.0, 300.0), (250.0, 160.0), (400.0, 50.0))),
    "b2": ((100.0, 100.0), ((175.0, 225.0), (300.0, 225.0), (425.0, 75.0))),
    "c": ((75.0, 25.0), ((75.0, 350.0), (191.7, 350.0), (191.7, 25.0), (308.3, 25.0), (308.3, 350.0),
                         (425.0, 350.0))),
    "d": ((25.0, 375.0), ((90.0, 330.0), (130.0, 250.0), (210.0, 215.0), (260.0, 140.0), (340.0, 105.0),
                          (425.0, 25.0))),
}
"""Start and targets [m] of the named layouts (Table 6 rows (b)1, (b)2, (c), (d))."""


class Waypoints(planning.PlanningTask):
    """Reach a sequence of target areas in order; the map is open water."""

    kind = "waypoints"

    def __init__(self, layout: str = "random", **kwargs):
        """`layout` is "random", a key of LAYOUTS or planning_physics.ARENA_SCENARIO (the arena's own sites; the factory
        sets it for `arena=PATH`); other kwargs go to `PlanningTask`."""
        options.choice("layout", layout, ("random", *LAYOUTS, planning_physics.ARENA_SCENARIO))
        super().__init__(**kwargs)
        self.layout = layout

    def route(self, physics, info) -> routes.Route:
        """A random chain of targets, a named layout, or the user's arena's path sites and goal."""
        if self.layout == planning_physics.ARENA_SCENARIO:
            return planning_physics.arena_route(info, self.goal_radius, waypoints=True)
        if self.layout == "random":
            start = routes.random_point(self.random, info.bounds)
            targets = [start]
            for _ in range(self.random.randint(MIN_WAYPOINTS, MAX_WAYPOINTS + 1)):
                targets.append(routes.random_point(self.random, info.bounds, avoid=targets[-1],
                                                     min_distance=LEG_RANGE[0], max_distance=LEG_RANGE[1]))
            goals = np.array(targets[1:])
            heading = self.random.uniform(-math.pi, math.pi)
        else:
            start, goals = (np.array(p) for p in LAYOUTS[self.layout])
            heading = routes.heading_to(start, goals[0])
        return routes.Route(start=start, heading=heading, goals=goals)


@SUITE.add("benchmarking", "goal", "planning", "waypoints")
def waypoints(time_limit=None, random=None, environment_kwargs=None, layout="random", arena=None, **task_kwargs):
    """Reach target areas in turn (Table 6 (b)-(d); layout="random"|"b1"|"b2"|"c"|"d"), or a user's arena's path
    sites (`arena=PATH`, see the module docstring); time_limit defaults to _DEFAULT_TIME_LIMIT."""
    layout = planning_physics.arena_scenario(arena, "layout", layout)
    task = Waypoints(layout=layout, random=random, **task_kwargs)
    physics, user = planning_physics.open_water_physics(arena, task_kwargs.get("conditions"),
                                                        planning_physics.open_water_arena())
    time_limit = planning_physics.arena_time_limit(time_limit, _DEFAULT_TIME_LIMIT, physics, user)
    return planning.environment(physics, task, time_limit, environment_kwargs)
