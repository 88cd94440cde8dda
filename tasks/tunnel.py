"""tunnel: inspect a tunnel along its known global path past unknown obstacles (Sec. 4.3, Table 12).

The arena (default `models/arenas/tunnel_inspection.xml`; any arena file or ElementTree root via
`arena=...`, see `auv_mj.arena` and `auv-mj tunnel`) gives the start site, the global path (sites
path_0..path_N on the tunnel axis), the known and unknown obstacles, the movers and `arena_bounds`, the
map (leaving it ends the episode). The global path, discretised to SUBGOAL_SPACING, is the sequence of
virtual sub-goals (SUBGOAL_RADIUS, Table 1; passed ones die too, see `planning`), beginning after the
path point nearest the start; a `goal` site off the path's end is appended as the last goal. The
vehicle starts at rest on the start site's heading; last_info["cross_track_error"] is the distance to
the global path (Fig. 17).
"""

from __future__ import annotations

import numpy as np

from auv_mj.arena import arena_info
from auv_mj.assets import model_path
from tasks import planning
from tasks.registry import SUITE

DEFAULT_ARENA = "arenas/tunnel_inspection.xml"
"""The Sec. 4.3 tunnel (Table 12), relative to `models/`."""


def tunnel_route(info) -> tuple[np.ndarray, np.ndarray]:
    """(sub-goals, reference path) of an arena: its path sites, discretised, and its goal site."""
    if len(info.path) < 1 or info.start is None:
        raise ValueError("a tunnel arena needs a `start` site and path sites path_0, path_1, ...")
    path = info.path
    if info.goal is not None and np.hypot(*(info.goal - path[-1])) > planning.SUBGOAL_RADIUS:
        path = np.vstack([path, info.goal])
    points = planning.discretise(path)
    nearest = int(np.argmin(planning.goal_distance(points, info.start)))
    return points[min(nearest + 1, len(points) - 1):], path


class Tunnel(planning.PlanningTask):
    """Follow a tunnel's global path of virtual sub-goals, avoiding walls and unknown obstacles."""

    def __init__(self, **kwargs):
        """kwargs go to `PlanningTask` (goal_radius defaults to SUBGOAL_RADIUS)."""
        kwargs.setdefault("goal_radius", planning.SUBGOAL_RADIUS)
        super().__init__(**kwargs)

    def route(self, physics, info) -> planning.Route:
        """The arena's start, path sub-goals and movers."""
        goals, path = tunnel_route(info)
        return planning.Route(start=info.start, heading=info.start_heading, goals=goals, path=path,
                              movers=info.movers, pass_corridor=planning.PASS_CORRIDOR)


@SUITE.add("benchmarking", "goal", "planning", "obstacles", "tracking")
def tunnel(time_limit=None, random=None, environment_kwargs=None, arena=None, **task_kwargs):
    """Tunnel inspection (Sec. 4.3); `arena` is an arena path or element (default the Table 12 tunnel).

    The arena is refused (ValueError naming it and its problems) unless `auv-mj check-arena` finds it
    usable. time_limit defaults to `route_time_limit` of the start-to-goal path length.
    """
    physics = planning.load_arena(model_path(DEFAULT_ARENA) if arena is None else arena, need_path=True)
    task = Tunnel(random=random, **task_kwargs)
    if time_limit is None:
        info = arena_info(physics)
        _, path = tunnel_route(info)
        time_limit = planning.route_time_limit(planning.path_length(np.vstack([info.start, path])))
    return planning.environment(physics, task, time_limit, environment_kwargs)
