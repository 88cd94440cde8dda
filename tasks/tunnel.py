"""tunnel: inspect a tunnel along its known global path past unknown obstacles (Sec. 4.3, Table 12).

The arena (default `models/arenas/tunnel_inspection.xml`; any arena file or ElementTree root via
`arena=...`, see `auv_mj.arenas.arena` and `auv-mj tunnel`) gives the start site, the global path (sites
path_0..path_N on the tunnel axis), the known and unknown obstacles, the movers and `arena_bounds`, the
map (leaving it ends the episode). The global path, discretised to SUBGOAL_SPACING, is the sequence of
virtual sub-goals (SUBGOAL_RADIUS, Table 1; passed ones die too, see `routes`), beginning after the
path point nearest the start; a `goal` site off the path's end is appended as the last goal. The
vehicle starts at rest on the start site's heading; last_info["cross_track_error"] is the distance to
the global path (Fig. 17).

`arena="random"` draws a fresh procedural tunnel (`auv_mj.arenas.procedural`, RANDOM_TUNNELS) for every
episode from the task's `random` and recompiles the physics in place before the episode starts; the
episode's time limit is then `route_time_limit` of that tunnel (the environment's own limit is the
longest such tunnel's). With `tier="hard"` (issue 30) the tunnels are wide (60-100 m) and hold cups, wedges and walls
across the axis on their straights, and faster movers (`auv_mj.arenas.traps.random_hard_tunnel`), each certified on
the oracle's grid. `random_arena(seed)` is the arena of the first episode of a task seeded `seed`
(what `auv-mj tunnel --random SEED` writes). Train, validate and test on the ranges of `auv_mj.seeds`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from auv_mj.arenas import procedural, traps
from auv_mj.arenas.arena import arena_info, compose_xml
from auv_mj.assets import model_path
from auv_mj.tasks import options as checks
from auv_mj.tasks import planning, planning_physics, planning_step, routes
from auv_mj.tasks.registry import SUITE

DEFAULT_ARENA = "arenas/tunnel_inspection.xml"
"""The Sec. 4.3 tunnel (Table 12), relative to `models/`."""
RANDOM = "random"
"""The `arena` value that draws a procedural tunnel per episode."""


def least_turn_radius() -> float:
    """The vehicle's least turn radius [m] in the planning tasks: the top speed MAX_SPEED over the
    heading command's largest rate, MAX_HEADING_CHANGE per PLANNER_DT (Table 1: 6 deg per 0.5 s)."""
    return planning_step.MAX_SPEED / (planning_step.MAX_HEADING_CHANGE / planning_step.PLANNER_DT)


RANDOM_TUNNELS = procedural.TunnelSpec(turn_radius=least_turn_radius())
"""The distribution of `arena="random"`: widths 20-60 m, lengths 300-1000 m, 1-3 unknown obstacles and
1-2 movers (see `procedural.TunnelSpec`)."""


def random_arena(random, spec: procedural.TunnelSpec = RANDOM_TUNNELS,
                 tier: str = "standard") -> procedural.ProceduralTunnel:
    """The procedural tunnel drawn from `random` (a seed: the arena of that episode seed); with tier="hard" a
    wide one holding traps (`auv_mj.arenas.traps.random_hard_tunnel`, issue 30)."""
    if checks.choice("tier", tier, traps.TIERS) == "hard":
        return traps.random_hard_tunnel(random, spec)
    return procedural.random_tunnel(random, spec)


def tunnel_spec(options: procedural.TunnelSpec | Mapping | None) -> procedural.TunnelSpec:
    """RANDOM_TUNNELS with `options` set: field -> value, a range as [low, high] or one number, e.g.
    {"width": 30, "length": [300, 500], "movers": 0}."""
    if options is None:
        return RANDOM_TUNNELS
    if isinstance(options, procedural.TunnelSpec):
        return options
    if not isinstance(options, Mapping) or not all(isinstance(key, str) for key in options):
        raise ValueError(f"arena_spec must be a dict of TunnelSpec fields, got {options!r:.60}")
    fields = {f.name: getattr(RANDOM_TUNNELS, f.name) for f in dataclasses.fields(procedural.TunnelSpec)}
    unknown = sorted(set(options) - set(fields))
    if unknown:
        raise ValueError(f"arena_spec: unknown field(s) {', '.join(unknown)}; valid: {', '.join(sorted(fields))}")
    changes = {}
    for name, value in options.items():
        if isinstance(fields[name], tuple):
            value = tuple(value) if isinstance(value, list | tuple) else (value, value)
            if len(value) != 2:
                raise ValueError(f"arena_spec: {name} must be [low, high] or one number, got {options[name]!r:.60}")
        changes[name] = value
    try:
        return dataclasses.replace(RANDOM_TUNNELS, **changes)
    except (TypeError, ValueError) as e:
        raise ValueError(f"arena_spec: {' '.join(str(e).split())}") from None


def tunnel_route(info) -> tuple[np.ndarray, np.ndarray]:
    """(sub-goals, reference path) of an arena: its path sites, discretised, and its goal site."""
    if len(info.path) < 1 or info.start is None:
        raise ValueError("a tunnel arena needs a `start` site and path sites path_0, path_1, ...")
    path = info.path
    if info.goal is not None and np.hypot(*(info.goal - path[-1])) > routes.SUBGOAL_RADIUS:
        path = np.vstack([path, info.goal])
    points = routes.discretise(path)
    nearest = int(np.argmin(routes.goal_distance(points, info.start)))
    return points[min(nearest + 1, len(points) - 1):], path


def route_limit(info) -> float:
    """The time limit [s] of an arena's route: `route_time_limit` of its start-to-goal path length."""
    _, path = tunnel_route(info)
    return routes.route_time_limit(routes.path_length(np.vstack([info.start, path])))


class Tunnel(planning.PlanningTask):
    """Follow a tunnel's global path of virtual sub-goals, avoiding walls and unknown obstacles."""

    kind = "tunnel"
    geodesic_legs = "last"
    """reward="geodesic" runs to the tunnel's end alone: the field follows the tunnel, while the sub-goals on its axis
    lie in each trap's mouth (`routes.GEODESIC_LEGS`)."""

    def __init__(self, arena_spec: procedural.TunnelSpec | None = None, route_time_limit: bool = True,
                 tier: str = "standard", **kwargs):
        """`arena_spec`: draw a procedural tunnel of it per episode, ending the episode at its
        `route_limit` if `route_time_limit`; `tier` "standard" or "hard" (`random_arena`, with arena="random"
        only); kwargs go to `PlanningTask` (goal_radius defaults to SUBGOAL_RADIUS)."""
        kwargs.setdefault("goal_radius", routes.SUBGOAL_RADIUS)
        super().__init__(**kwargs)
        self.tier = checks.choice("tier", tier, traps.TIERS)
        if self.tier == "hard" and arena_spec is None:
            raise ValueError('tier="hard" applies to arena="random" only')
        self.arena_spec = arena_spec
        self.route_time_limit = route_time_limit
        self.arena: procedural.ProceduralTunnel | None = None
        """The episode's procedural tunnel (None on a fixed arena)."""
        self._time_limit: float | None = None

    def initialize_episode(self, physics: planning_physics.Physics) -> None:
        """With `arena_spec`, draws the episode's tunnel and recompiles the physics around it first."""
        if self.arena_spec is not None:
            self.arena = random_arena(self.random, self.arena_spec, self.tier)
            xml, source = compose_xml(self.arena.element(), thruster_lag=self.ocean.conditions.thruster_lag)
            physics.reload_from_xml_string(xml, source=source)
        super().initialize_episode(physics)
        limited = self.arena_spec is not None and self.route_time_limit
        self._time_limit = route_limit(arena_info(physics)) if limited else None

    def route(self, physics, info) -> routes.Route:
        """The arena's start, path sub-goals and movers."""
        goals, path = tunnel_route(info)
        return routes.Route(start=info.start, heading=info.start_heading, goals=goals, path=path,
                              movers=info.movers, pass_corridor=routes.PASS_CORRIDOR)

    @property
    def episode_time_limit(self) -> float | None:
        """A procedural tunnel's own time limit [s] (`route_limit`), None on a fixed arena."""
        return self._time_limit

    @property
    def step_limit(self) -> int:
        """As `PlanningTask`, or the steps of a procedural tunnel's own time limit where fewer (`get_termination`)."""
        if self._time_limit is None:
            return super().step_limit
        return min(super().step_limit, math.ceil(self._time_limit / planning_step.PLANNER_DT - 0.5))

    def get_termination(self, physics) -> float | None:
        """As `PlanningTask`; on a procedural tunnel also 1.0 (truncation) at its own time limit."""
        done = super().get_termination(physics)
        if done is None and self._time_limit is not None \
                and physics.time() >= self._time_limit - planning_step.PLANNER_DT / 2:
            return 1.0
        return done


@SUITE.add("benchmarking", "goal", "planning", "obstacles", "tracking")
def tunnel(time_limit=None, random=None, environment_kwargs=None, arena=None, arena_spec=None, **task_kwargs):
    """Tunnel inspection (Sec. 4.3); `arena` is an arena path or element (default the Table 12 tunnel),
    or "random": a procedural tunnel per episode, of RANDOM_TUNNELS with `arena_spec` (a dict of
    `procedural.TunnelSpec` fields) set.

    A file or element is refused (ValueError naming it and its problems) unless `auv-mj check-arena` finds it
    usable, and an `arena_spec` that gives no tunnel (`procedural.check_feasible`) is refused naming its
    conflicting fields. time_limit defaults to `route_time_limit` of the start-to-goal path length (per
    episode when random).
    """
    if isinstance(arena, str) and arena == RANDOM:
        spec = tunnel_spec(arena_spec)
        if arena_spec is not None:  # refused here, before any episode, not in the first reset
            procedural.check_feasible(spec)
        task = Tunnel(arena_spec=spec, route_time_limit=time_limit is None, random=random, **task_kwargs)
        physics = planning_physics.Physics.load(planning_physics.open_water_arena(),  # replaced at every reset
                                        task_kwargs.get("conditions"))
        if time_limit is None:  # the longest tunnel's; each episode ends at its own (Tunnel.get_termination)
            time_limit = routes.route_time_limit(spec.length[1] + 2 * routes.SUBGOAL_SPACING)
        return planning.environment(physics, task, time_limit, environment_kwargs)
    if arena_spec is not None:
        raise ValueError("arena_spec applies to arena='random' only")
    physics = planning_physics.load_arena(model_path(DEFAULT_ARENA) if arena is None else arena, need_path=True,
                                  conditions=task_kwargs.get("conditions"))
    task = Tunnel(random=random, **task_kwargs)
    if time_limit is None:
        time_limit = route_limit(arena_info(physics))
    return planning.environment(physics, task, time_limit, environment_kwargs)
