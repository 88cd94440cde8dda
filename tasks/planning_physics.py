"""The physics of a planning task: the vehicle in an arena, with the executor's clock, and the arena options.

`Physics` is `AUVPhysics` with the executor layer's clock (`auv_mj.control.clock.ExecutorClock`), compiled for the
task's conditions (lagged actuators where the ocean asks for them). An arena enters a task once, checked by
`load_arena` (`auv-mj check-arena`); the open-water tasks (goal, waypoints, obstacles) take their `arena` option
through `arena_scenario`, `open_water_physics`, `arena_route` and `arena_time_limit`, and draw their own layouts on
`open_water_arena`, the empty 600 m map of Sec. 4.1 (MAP_BOUNDS).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from auv_mj.arenas import arena, arena_check, tubes
from auv_mj.control.clock import ExecutorClock
from auv_mj.control.splane import EXECUTOR_DT
from auv_mj.sim import ocean
from auv_mj.sim.physics import AUVPhysics
from auv_mj.tasks import options
from auv_mj.tasks.routes import GOAL_RADIUS, Route, goal_distance, path_length, route_time_limit

MAP_BOUNDS = (0.0, 0.0, 600.0, 600.0)
"""The 600 m x 600 m map of Sec. 4.1 (xmin, ymin, xmax, ymax) [m]."""

ARENA_SCENARIO = "arena"
"""The scenario (or layout) of an open-water task run on a user's arena (`arena=PATH`): its sites, walls,
obstacles and movers instead of a random or a named layout."""
RANDOM_ARENA = "random"
"""`arena="random"`, the `--arena random` of every command: the task's own random layouts."""


def open_water_arena(bounds: Sequence[float] = MAP_BOUNDS) -> ET.Element:
    """An empty map: `arena_bounds` and a `goal` site (the target area, moved to each episode's goal)."""
    root = ET.Element("mujoco")
    ET.SubElement(ET.SubElement(root, "custom"), "numeric", name="arena_bounds",
                  data=" ".join(f"{b:g}" for b in bounds))
    worldbody = ET.SubElement(root, "worldbody")
    ET.SubElement(worldbody, "site", name="goal", type="cylinder", size=f"{GOAL_RADIUS:g} 0.05",
                  rgba="1 0.9 0 0.3")
    return root


class Physics(ExecutorClock, AUVPhysics):
    """AUVPhysics with the executor layer's clock (`auv_mj.control.clock.ExecutorClock`): `set_tick(callback)` calls the
    low-level controller every EXECUTOR_DT while it steps; the callback sets the controls and moves the obstacles.
    """

    TICK_PERIOD = EXECUTOR_DT

    @classmethod
    def load(cls, arena_source: str | Path | ET.Element | None, conditions=None) -> Physics:
        """The vehicle in `arena_source` (an arena MJCF path or ElementTree root; see `auv_mj.arenas.arena`), compiled
        for the task option `conditions` (`auv_mj.sim.ocean.conditions`: lagged actuators where they ask for it)."""
        xml, source = arena.compose_xml(arena_source, thruster_lag=ocean.conditions(conditions).thruster_lag)
        return cls.from_xml_string(xml, source=source)


def load_arena(source: str | Path | ET.Element, need_path: bool, conditions=None) -> Physics:
    """Physics of the vehicle in an arena file or element, refused unless `auv-mj check-arena` finds it usable.

    The arena is checked once where it enters a task, by `arena_check.require_usable` (cached by content). A tube
    arena (`auv-mj tunnel --tube`) is the 6-DOF vehicle's and is refused naming the file and the task that flies it.
    """
    source = options.arena_source(source)
    if tubes.is_tube_arena(source):
        name = "the arena element" if isinstance(source, ET.Element) else str(source)
        raise ValueError(f"{name}: a tube arena (`auv-mj tunnel --tube`) is for the 6-DOF vehicle: fly it with "
                         "--task tunnel3d; the planar tasks take arenas from `auv-mj tunnel` (without --tube) or "
                         "`auv-mj arena`")
    arena_check.require_usable(source, need_path)
    return Physics.load(source, conditions)


def arena_scenario(arena_option, choice: str, value: str, default: str = "random") -> str:
    """The scenario an open-water task runs with its `arena` option and its `choice` option (scenario or layout)
    set to `value`: ARENA_SCENARIO for an arena file or element, which may not come with another `choice`; `value`
    for None or "random" (read as `choice`="random")."""
    if arena_option is None:
        if value == ARENA_SCENARIO:
            raise ValueError(f"{choice}={ARENA_SCENARIO!r} is set by arena=PATH (an arena MJCF file); give the arena")
        return value
    if isinstance(arena_option, str) and arena_option == RANDOM_ARENA:
        if value != default:
            raise ValueError(f"arena='random' draws a {default} {choice}; it cannot go with {choice}={value!r}")
        return default
    options.arena_source(arena_option)
    if value not in (default, ARENA_SCENARIO):
        raise ValueError(f"arena={arena_option!r:.80} and {choice}={value!r} conflict: a user's arena gives the "
                         f"start, the goal and the obstacles itself; leave {choice} out")
    return ARENA_SCENARIO


def arena_route(info: arena.ArenaInfo, radius: float, waypoints: bool = False) -> Route:
    """A user's open-water arena as a route (`docs/arenas.md`): from its `start` site on that site's heading to
    its `goal` site, past its movers on their paths. With `waypoints` its `path_*` sites, in order, are targets
    before the goal (those within `radius` of the start are not: `path_0` is usually the start itself)."""
    goals = info.goal[None]
    if waypoints and len(info.path):
        targets = info.path[goal_distance(info.path, info.start) > radius]
        if len(targets) and goal_distance(targets[-1], info.goal) <= 1e-6:
            targets = targets[:-1]
        goals = np.vstack([targets, goals])
    return Route(start=info.start, heading=info.start_heading, goals=goals, movers=info.movers)


def open_water_physics(arena_option, conditions, default: ET.Element) -> tuple[Physics, bool]:
    """The physics of an open-water task and whether it is a user's arena: `arena_option` (a file or element,
    refused unless `auv-mj check-arena --no-path` finds it usable) or the task's own `default` arena."""
    if arena_option is None or (isinstance(arena_option, str) and arena_option == RANDOM_ARENA):
        return Physics.load(default, conditions), False
    return load_arena(arena_option, need_path=False, conditions=conditions), True


def arena_time_limit(time_limit: float | None, default: float, physics: Physics, user_arena: bool) -> float:
    """An open-water task's time limit [s]: `time_limit` if given; on a user's arena the longer of `default`
    and `route_time_limit` of the straight legs from its start through its path sites to its goal."""
    if time_limit is not None:
        return time_limit
    if not user_arena:
        return default
    info = arena.arena_info(physics)
    return max(default, route_time_limit(path_length(np.vstack([info.start, info.path.reshape(-1, 2),
                                                                    info.goal]))))
