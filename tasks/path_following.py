"""path_line and path_curve: follow a global path of virtual sub-goals (Sec. 4.2, Fig. 13-14, Tables 10-11).

The path is discretised into sub-goals SUBGOAL_SPACING apart (reached within SUBGOAL_RADIUS, Table 1;
passed ones die too, see `routes`);
the path's first point is the first sub-goal, so an episode begins with the run from the start to the
path. last_info["cross_track_error"] is the distance to the path, and "speed_error" / "heading_error"
are the executor's tracking errors, for the MAE and maximum errors of Tables 10 and 11 (which leave out
the run to the path: the steps before last_info["goals_reached"] first exceeds 0). Both start at rest
facing east, toward the path; the target speed is TARGET_SPEED (1 m/s).
- path_line: the straight path from (200, 40) to (300, 300), starting at (70, 40).
- path_curve: y = 30 sin(0.02 x) + 180 for 65 <= x <= 500 (Eq. 33), starting at (35, 230).
"""

from __future__ import annotations

import numpy as np

from auv_mj.tasks import planning, planning_physics, routes
from auv_mj.tasks.registry import SUITE

LINE = np.array([[200.0, 40.0], [300.0, 300.0]])
"""The straight path of Sec. 4.2 [m]."""
LINE_START = np.array([70.0, 40.0])
CURVE_X_RANGE = (65.0, 500.0)
"""Extent in x of the curve path of Eq. (33) [m]."""
CURVE_START = np.array([35.0, 230.0])
CURVE_RESOLUTION = 1.0
"""Step in x of the polyline that stands for the curve in the cross-track error [m]."""
START_HEADING = 0.0
"""Both experiments start facing east, toward the path [rad]."""


def curve(x: np.ndarray) -> np.ndarray:
    """Eq. (33): y = 30 sin(0.02 x) + 180 [m]."""
    return 30.0 * np.sin(0.02 * x) + 180.0


def curve_polyline(resolution: float = CURVE_RESOLUTION) -> np.ndarray:
    """The curve of Eq. (33) as a polyline with points `resolution` m apart in x."""
    x = np.linspace(*CURVE_X_RANGE, int(round((CURVE_X_RANGE[1] - CURVE_X_RANGE[0]) / resolution)) + 1)
    return np.column_stack([x, curve(x)])


def equal_arc_points(polyline: np.ndarray, spacing: float = routes.SUBGOAL_SPACING) -> np.ndarray:
    """Points along a dense polyline at equal arc length, no more than `spacing` apart, ends included."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(polyline, axis=0).T))])
    s = np.linspace(0.0, arc[-1], int(np.ceil(arc[-1] / spacing)) + 1)
    return np.column_stack([np.interp(s, arc, polyline[:, 0]), np.interp(s, arc, polyline[:, 1])])


class PathFollowing(planning.PlanningTask):
    """Follow a fixed global path, sub-goal by sub-goal, from a fixed start at rest."""

    kind = "path"

    def __init__(self, path: np.ndarray, start: np.ndarray, subgoals: np.ndarray | None = None, **kwargs):
        """`path`: the reference polyline [m]; `subgoals`: its sub-goals (default: `discretise(path)`)."""
        kwargs.setdefault("goal_radius", routes.SUBGOAL_RADIUS)
        super().__init__(**kwargs)
        self.path = np.asarray(path, dtype=float)
        self.start = np.asarray(start, dtype=float)
        self.subgoals = routes.discretise(self.path if subgoals is None else subgoals)

    def route(self, physics, info) -> routes.Route:
        """The fixed start, heading, sub-goals and path."""
        return routes.Route(start=self.start, heading=START_HEADING, goals=self.subgoals, path=self.path,
                              pass_corridor=routes.PASS_CORRIDOR)


def _time_limit(path: np.ndarray, start: np.ndarray) -> float:
    return routes.route_time_limit(routes.path_length(np.vstack([start, path])))


_LINE_TIME_LIMIT = _time_limit(LINE, LINE_START)
_CURVE_TIME_LIMIT = _time_limit(curve_polyline(), CURVE_START)


@SUITE.add("benchmarking", "goal", "planning", "tracking")
def path_line(time_limit=_LINE_TIME_LIMIT, random=None, environment_kwargs=None, **task_kwargs):
    """Follow the straight path (200, 40) -> (300, 300) from (70, 40) (Sec. 4.2, Fig. 13, Table 10)."""
    physics = planning_physics.Physics.load(planning_physics.open_water_arena(), task_kwargs.get("conditions"))
    task = PathFollowing(LINE, LINE_START, random=random, **task_kwargs)
    return planning.environment(physics, task, time_limit, environment_kwargs)


@SUITE.add("benchmarking", "goal", "planning", "tracking")
def path_curve(time_limit=_CURVE_TIME_LIMIT, random=None, environment_kwargs=None, **task_kwargs):
    """Follow y = 30 sin(0.02 x) + 180, 65 <= x <= 500, from (35, 230) (Sec. 4.2, Fig. 14, Table 11)."""
    physics = planning_physics.Physics.load(planning_physics.open_water_arena(), task_kwargs.get("conditions"))
    path = curve_polyline()
    task = PathFollowing(path, CURVE_START, subgoals=equal_arc_points(path), random=random, **task_kwargs)
    return planning.environment(physics, task, time_limit, environment_kwargs)
