"""`auv-mj check-arena`'s checks: is an arena MJCF usable?

Loads an arena through `auv_mj.arenas.arena.load` and checks the convention of `auv_mj.arenas.arena` with MuJoCo's
own queries: `mj_geomDistance` between the hull, posed along the global path, and every static geom
(the d_s = 5 m of Table 1), and `mj_ray` along each path segment (does the path leave free space?).
Unknown obstacles (`unknown*`) may stand on the path; for them it checks instead that water joins the
start to the goal keeping d_s from every static geom (`auv_mj.arenas.tunnels.free_route`, on the geoms'
outlines seen from above). The check draws nothing: its report carries what a preview needs, and
`auv_mj.figures.arenas.preview` draws it.
"""

from __future__ import annotations

import collections
import hashlib
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import shapely

from auv_mj import inputs
from auv_mj.arenas.arena import (
    MAX_EXTENT,
    MAX_MOVER_SPEED,
    MAX_MOVER_WAYPOINTS,
    MOVER_PREFIX,
    PATH_SITE_PREFIX,
    UNKNOWN_OBSTACLE_PREFIX,
    ArenaInfo,
    arena_info,
    load,
)
from auv_mj.arenas.tunnels import (
    ROUTE_MARGIN,
    SAFETY_DISTANCE,
    crossings,
    route_blocker,
    route_clearance,
    segment_lines,
)
from auv_mj.console import counted, progress_bar
from auv_mj.geometry import xy_text
from auv_mj.sim.physics import AUVPhysics

if TYPE_CHECKING:
    from tqdm import tqdm

    from auv_mj.arenas.tubes import Tube, TubeMover, TubeObstacle

CHECK_STEP = 1.0
"""Distance between the poses at which the path's clearance is measured [m]."""
WALL_JOIN_MARGIN = 2.0
"""Two wall geoms crossing within this many thicknesses of an end of either are joined, not crossing."""
SEARCH_DISTANCE = 120.0
"""Distances are measured up to the sonar range [m]; farther reads as this."""
HIDDEN_Z = 1e4
"""Where moving obstacles are parked [m] while the static map is checked."""
MAX_LINES = 20
"""At most this many lines per kind of problem."""
MAX_STATIC_GEOMS = 10_000
"""Most static geoms an arena may have: the checks pose the hull against the nearby ones along the path."""
RAY_STEP = 1e-3
"""How far past a geom the path may cross a ray starts again [m]."""
STATIC_PREFIXES = ("wall", "obstacle", UNKNOWN_OBSTACLE_PREFIX)


@dataclass(frozen=True)
class ArenaView:
    """What a top-down preview of a planar arena draws (`auv_mj.figures.arenas.preview`): the arena as loaded and
    checked, its convention's read-outs (None where its numbers are unreadable), the geoms too far out to draw, and
    its kind ("tunnel" or "open-water", `arena_kind`)."""

    physics: AUVPhysics
    info: ArenaInfo | None
    skip: frozenset[int]
    kind: str


@dataclass(frozen=True)
class TubeView:
    """What a preview of a 3-D tube arena draws (`auv_mj.arenas.tubes`): the tube, its rocks and its movers."""

    tube: Tube
    obstacles: list[TubeObstacle]
    movers: list[TubeMover]
    kind: str = "tube"


@dataclass
class ArenaReport:
    """What `check_arena` found: problems make an arena unusable, warnings do not."""

    source: str
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    summary: str = ""
    png: Path | None = None
    """The preview drawn of the arena, once one is (`auv_mj.figures.arenas.preview`); the check draws none."""
    view: ArenaView | TubeView | None = field(default=None, repr=False, compare=False)
    """What a preview draws; None where nothing sound can be (an arena that does not load)."""

    @property
    def ok(self) -> bool:
        """True when the arena is usable."""
        return not self.problems

    def lines(self) -> list[str]:
        """The report as printed: a summary, one line per problem or warning, then OK or a count."""
        out = [f"{self.source}: {self.summary}"] if self.summary else []
        out += [f"problem: {p}" for p in self.problems] + [f"warning: {w}" for w in self.warnings]
        out.append("OK" if self.ok else f"{counted(len(self.problems), 'problem')}: not a usable arena")
        return out


CHECK_STAGES = ("load", "numbers and sites", "extent", "geoms", "walls", "route", "unknown obstacles", "movers")
"""The stages of `check_arena`, in order: what its progress bar counts (a preview drawn after the check,
`auv_mj.figures.arenas.preview`, counts one stage more)."""


def arena_name(source: str | Path | ET.Element) -> str:
    """How a report calls an arena by default: its file, or `<arena element>`."""
    return inputs.source_name(source) if not isinstance(source, ET.Element) else "<arena element>"


def check_arena(source: str | Path | ET.Element, *, need_path: bool = True, name: str | None = None,
                progress: bool = False, bar: tqdm | None = None) -> ArenaReport:
    """Checks an arena (a file or an element) and returns the report, with what a preview of it needs (`view`).

    The check draws nothing: `auv_mj.figures.arenas.preview(source, png)` checks and draws in one call, or draws a
    report already made. `need_path=False` accepts an arena without a global path (the goal-reaching tasks of Tables
    7-8). `name` is how the report (and a preview's title) calls the arena (default `arena_name`): the file an
    element is about to be written to, say. `progress` shows a bar over CHECK_STAGES (a large arena takes a while to
    compile and search); it ends at 100 % also where stages are skipped. `bar` is a caller's own bar (tqdm) to move
    through CHECK_STAGES instead, left open: the preview's, which counts its drawing after them.
    """
    if name is None:
        name = arena_name(source)
    own = bar is None
    if own:
        bar = progress_bar(total=len(CHECK_STAGES), desc=f"check-arena {Path(name).name}"[:40], unit="stage",
                           disable=not progress)

    def stage(label: str) -> None:
        bar.n = CHECK_STAGES.index(label)
        bar.set_postfix_str(label)

    try:
        report = _check(source, name, need_path, stage)
        if own:
            bar.set_postfix_str("done")
            bar.update(bar.total - bar.n)  # every stage done or not needed
        else:
            bar.n = len(CHECK_STAGES)
        return report
    finally:
        if own:
            bar.close()


def _check(source: str | Path | ET.Element, name: str, need_path: bool, stage) -> ArenaReport:
    """`check_arena`'s work, calling `stage(label)` as each of CHECK_STAGES begins."""
    report = ArenaReport(name)
    from auv_mj.arenas import tubes  # a 3-D tube arena (issue 32) is checked for the 6-DOF vehicle

    if tubes.is_tube_arena(source):
        report.summary, report.problems = tubes.tube_report(source)
        try:
            root = source if isinstance(source, ET.Element) else inputs.parse_xml(
                inputs.read_text(Path(source), "arena MJCF", inputs.MAX_XML_BYTES), name, "arena MJCF")
            tube = tubes.tube_from_arena(root)
            if tube is not None:
                report.view = TubeView(tube, *tubes.items_from_arena(root))
        except ValueError:
            pass  # the report names what is wrong; there is nothing sound to draw
        return report
    stage("load")
    try:
        physics = load(source)
    except ValueError as e:
        report.problems.append(str(e))
        return report
    model = physics.model.ptr
    info = None
    placed = False
    stage("numbers and sites")
    if _check_numerics(model, report):
        info = arena_info(physics)
        placed = _check_sites(model, info, report, need_path)
    stage("extent")
    static, absurd = _check_extent(model, physics, report)
    stage("geoms")
    _check_geoms(model, physics, static, report)
    stage("walls")
    _check_walls(model, physics, static, report)
    if info is not None and placed and not absurd:
        stage("route")
        _check_route(physics, info, static, report)
        stage("unknown obstacles")
        _check_unknown(physics, info, static, report)
        stage("movers")
        _check_movers(physics, info, static, report)
    report.view = ArenaView(physics, info, frozenset(absurd), arena_kind(model, info))
    return report


_VERDICTS: collections.OrderedDict[tuple[str, bool], tuple[str, ...]] = collections.OrderedDict()
VERDICT_CACHE_SIZE = 64
"""Arenas whose `require_usable` verdict is remembered (by content), so a task loads a checked arena fast."""
SHOWN_PROBLEMS = 3
"""`require_usable` names this many problems in its one-line error."""


def require_usable(source: str | Path | ET.Element, need_path: bool = True) -> None:
    """Refuses an arena that `check_arena` (the code of `auv-mj check-arena`) finds unusable.

    Raises ValueError naming the arena and its problems, on one line. Tasks call this where an arena enters;
    the verdict is cached by the arena's content, so loading the same arena again costs a hash.
    """
    if isinstance(source, ET.Element):
        name = "<arena element>"
        inputs.check_element(source, name, "arena")
        content = ET.tostring(source, encoding="unicode").encode()
    elif isinstance(source, (str, Path)):
        name = inputs.source_name(source)
        content = inputs.read_bytes(source, "arena", inputs.MAX_XML_BYTES)
    else:
        raise ValueError(f"an arena is a file path or an ElementTree element, got {type(source).__name__}")
    key = (hashlib.sha256(content).hexdigest(), need_path)
    problems = _VERDICTS.get(key)
    if problems is None:
        problems = tuple(" ".join(p.split()) for p in check_arena(source, need_path=need_path).problems)
        _VERDICTS[key] = problems
        while len(_VERDICTS) > VERDICT_CACHE_SIZE:
            _VERDICTS.popitem(last=False)
    if problems:
        shown = "; ".join(p.removeprefix(f"{name}: ") for p in problems[:SHOWN_PROBLEMS])
        more = f"; and {len(problems) - SHOWN_PROBLEMS} more" if len(problems) > SHOWN_PROBLEMS else ""
        raise ValueError(f"{name}: not a usable arena: {shown}{more} (`auv-mj check-arena` lists them all)")


def _name(model: mujoco.MjModel, geom: int) -> str:
    return model.geom(geom).name or f"geom #{geom} (unnamed)"


def _add(lines: list[str], new: list[str]) -> None:
    lines += new[:MAX_LINES]
    if len(new) > MAX_LINES:
        lines.append(f"... and {len(new) - MAX_LINES} more like these")


def _check_numerics(model: mujoco.MjModel, report: ArenaReport) -> bool:
    """The `<numeric>`s the convention reads: arena_bounds and one per mover; False if unreadable."""
    readable = True
    numerics = {model.numeric(i).name: i for i in range(model.nnumeric)}

    def values(name: str) -> np.ndarray:
        i = numerics[name]
        return model.numeric_data[model.numeric_adr[i]:model.numeric_adr[i] + model.numeric_size[i]]

    if "arena_bounds" not in numerics:
        report.problems.append('no <numeric name="arena_bounds" data="xmin ymin xmax ymax">: '
                               "the map has no edge")
    elif len(values("arena_bounds")) != 4:
        report.problems.append(f'<numeric name="arena_bounds"> has {len(values("arena_bounds"))} values; '
                               "expected xmin ymin xmax ymax")
    elif not np.all(np.abs(values("arena_bounds")) <= MAX_EXTENT):  # NaN fails too
        report.problems.append(f"arena_bounds {_xy4(values('arena_bounds'))} must be finite numbers within "
                               f"+-{MAX_EXTENT:g} m")
    bodies = {model.body(i).name: i for i in range(model.nbody)}
    for name in numerics:
        if name.startswith(MOVER_PREFIX) and name not in bodies:
            report.problems.append(f'<numeric name="{name}"> has no <body name="{name}" mocap="true">: '
                                   "a mover's path needs its obstacle")
    for body, i in bodies.items():
        if not body.startswith(MOVER_PREFIX):
            continue
        if model.body_mocapid[i] < 0:
            report.problems.append(f'body {body}: named as a mover but not mocap="true", so it would never move '
                                   f"(name a fixed body otherwise, or make it a mocap body)")
        elif body not in numerics:
            report.problems.append(f'mover body {body} has no <numeric name="{body}" '
                                   'data="x0 y0 x1 y1 speed">: it would never move')
        elif len(values(body)) < 5 or len(values(body)) % 2 == 0 or len(values(body)) > 2 * MAX_MOVER_WAYPOINTS + 1:
            report.problems.append(f'<numeric name="{body}"> has {len(values(body))} values; '
                                   f"expected x0 y0 x1 y1 [... xn yn] speed (2 to {MAX_MOVER_WAYPOINTS} waypoints)")
            readable = False
    return readable


def _check_sites(model: mujoco.MjModel, info: ArenaInfo, report: ArenaReport, need_path: bool) -> bool:
    """start, goal, path_0..path_N present, finite, in order and inside arena_bounds; movers' paths valid.

    False when a position or heading is not a finite number (the checks that pose the vehicle are skipped).
    """
    for name, xy in (("start", info.start), ("goal", info.goal)):
        if xy is None:
            report.problems.append(f'no <site name="{name}">')
    numbers = sorted(int(m.group(1)) for i in range(model.nsite)
                     if (m := re.fullmatch(PATH_SITE_PREFIX + r"(\d+)", model.site(i).name)))
    if not numbers:
        if need_path:
            report.problems.append(f"no global path: no sites {PATH_SITE_PREFIX}0, {PATH_SITE_PREFIX}1, ...")
    elif len(numbers) < 2:
        report.problems.append(f"the global path has one site ({PATH_SITE_PREFIX}{numbers[0]}); "
                               "it needs two or more")
    missing = sorted(set(range(numbers[-1] + 1)) - set(numbers)) if numbers else []
    if missing:
        shown = ", ".join(f"{PATH_SITE_PREFIX}{k}" for k in missing[:10])
        report.problems.append(f"the global path skips {shown}{' ...' if len(missing) > 10 else ''}: "
                               f"its sites must be numbered {PATH_SITE_PREFIX}0, {PATH_SITE_PREFIX}1, ... "
                               "in order")
    points = [("start", info.start), ("goal", info.goal)]
    points += [(f"{PATH_SITE_PREFIX}{k}", p) for k, p in zip(numbers, info.path, strict=False)]
    placed = _check_movers_numbers(info, report)
    far = [f"{name} ({xy_text(p)}) is not at finite coordinates within +-{MAX_EXTENT:g} m" for name, p in points
           if p is not None and not np.all(np.abs(p) <= MAX_EXTENT)]
    _add(report.problems, far)
    if not math.isfinite(info.start_heading):
        report.problems.append("the start site's orientation is not a finite angle: no initial heading")
    placed = placed and not far and math.isfinite(info.start_heading)
    length = float(np.sum(np.hypot(*np.diff(info.path, axis=0).T))) if len(info.path) > 1 else 0.0
    if length > MAX_EXTENT:
        report.problems.append(f"the global path is {length:.0f} m long; at most {MAX_EXTENT:g} m")
        placed = False
    if info.bounds is None or len(info.bounds) != 4 or not np.all(np.abs(info.bounds) <= MAX_EXTENT):
        return placed
    xmin, ymin, xmax, ymax = info.bounds
    if not (xmin < xmax and ymin < ymax):
        report.problems.append(f"arena_bounds {_xy4(info.bounds)} is empty (needs xmin < xmax, ymin < ymax)")
        return placed
    points += [(f"{m.body} {_waypoint_label(k, len(m.waypoints))}", p) for m in info.movers
               for k, p in enumerate(m.waypoints)]
    outside = [f"{name} ({xy_text(p)}) is outside arena_bounds {_xy4(info.bounds)}" for name, p in points
               if p is not None and np.all(np.isfinite(p)) and not (xmin <= p[0] <= xmax and ymin <= p[1] <= ymax)]
    _add(report.problems, outside)
    return placed


def _check_movers_numbers(info: ArenaInfo, report: ArenaReport) -> bool:
    """Each mover's path ends are finite and its speed is in [0, MAX_MOVER_SPEED]; False if any is not."""
    bad = []
    for mover in info.movers:
        if not np.all(np.abs(mover.waypoints) <= MAX_EXTENT):
            bad.append(f"{mover.body}: its path ends ({xy_text(mover.start)}) and ({xy_text(mover.end)}) and "
                       f"waypoints must be finite within +-{MAX_EXTENT:g} m")
        if not 0.0 <= mover.speed <= MAX_MOVER_SPEED:
            bad.append(f"{mover.body}: speed {mover.speed:g} m/s is not in [0, {MAX_MOVER_SPEED:g}] m/s")
    _add(report.problems, bad)
    return not bad


def _check_extent(model: mujoco.MjModel, physics: AUVPhysics, report: ArenaReport) -> tuple[list[int], set[int]]:
    """Geoms of the arena (static and movers') with sizes and positions within MAX_EXTENT.

    Returns the static geoms fit for the geometric checks, and the geoms too large or too far to check or draw.
    """
    data = physics.data.ptr
    vehicle = model.body("auv").id
    absurd, lines = set(), []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == vehicle:
            continue
        size, centre, reach = model.geom_size[g], data.geom_xpos[g], model.geom_rbound[g]
        if not (np.all(np.abs(size) <= MAX_EXTENT) and np.all(np.abs(centre) <= MAX_EXTENT)
                and abs(reach) <= MAX_EXTENT):
            absurd.add(g)
            lines.append(f"{_name(model, g)} (size {' '.join(f'{v:g}' for v in size)}, at "
                         f"{xy_text(centre)}) is beyond the largest arena extent, {MAX_EXTENT:g} m")
    _add(report.problems, lines)
    static = [g for g in range(model.ngeom) if model.geom_bodyid[g] == 0 and g not in absurd]
    if len(static) > MAX_STATIC_GEOMS:
        report.problems.append(f"{len(static)} static geoms; at most {MAX_STATIC_GEOMS}")
        return [], absurd
    return static, absurd


def _check_geoms(model: mujoco.MjModel, physics: AUVPhysics, static: list[int], report: ArenaReport) -> None:
    """Static geoms named by the convention (a warning), reaching the plane z = 0 and visible to the sonar
    (problems: a geom the sonar and the hull cannot meet is a wall that is not there)."""
    data = physics.data.ptr
    notes, problems = [], []
    for g in static:
        name = model.geom(g).name
        if not name.startswith(STATIC_PREFIXES):
            notes.append(f"static {_name(model, g)}: the convention names walls wall*, obstacles obstacle* "
                         f"and unknown obstacles {UNKNOWN_OBSTACLE_PREFIX}*")
        if model.geom_rgba[g, 3] == 0:
            problems.append(f"{_name(model, g)}: rgba alpha is 0 (fully transparent), and the sonar (mj_ray) "
                            "does not see such a geom: give it an alpha above 0")
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        rot = data.geom_xmat[g].reshape(3, 3)
        z = data.geom_xpos[g, 2] + rot[2] @ centre
        reach = np.abs(rot[2]) @ half
        if not z - reach <= 0 <= z + reach:
            problems.append(f"{_name(model, g)}: pos z spans {z - reach:.2f}..{z + reach:.2f} m, not the vehicle's "
                            "plane z = 0: neither the hull nor the sonar meets it")
    _add(report.warnings, notes)
    _add(report.problems, problems)


def _footprint_axis(model: mujoco.MjModel, data: mujoco.MjData,
                    g: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The long axis (two xy ends) and half thickness of a box or capsule wall, seen from above."""
    rot = data.geom_xmat[g].reshape(3, 3)
    centre, size = data.geom_xpos[g, :2], model.geom_size[g]
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
        axis = rot[:2, 2] * size[1]
        return centre - axis, centre + axis, float(size[0])
    a, b = rot[:2, 0] * size[0], rot[:2, 1] * size[1]
    (long, short) = (a, b) if np.hypot(*a) >= np.hypot(*b) else (b, a)
    return centre - long, centre + long, float(np.hypot(*short))


def _check_walls(model: mujoco.MjModel, physics: AUVPhysics, static: list[int], report: ArenaReport) -> None:
    """Wall geoms crossing each other anywhere but at their ends (a self-intersecting wall)."""
    data = physics.data.ptr
    kinds = (int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CAPSULE))
    walls = [g for g in static if model.geom(g).name.startswith("wall") and int(model.geom_type[g]) in kinds]
    if len(walls) < 2:
        return
    axes = [_footprint_axis(model, data, g) for g in walls]
    a0, a1 = np.array([a[0] for a in axes]), np.array([a[1] for a in axes])
    half = np.array([a[2] for a in axes])
    length = np.hypot(*(a1 - a0).T)
    found = []
    for i, j, p in zip(*crossings(segment_lines(a0, a1)), strict=True):
        margin = WALL_JOIN_MARGIN * (half[i] + half[j])
        along_i, along_j = np.hypot(*(p - a0[i])), np.hypot(*(p - a0[j]))
        if min(along_i, length[i] - along_i) > margin and min(along_j, length[j] - along_j) > margin:
            found.append(f"walls {_name(model, walls[i])} and {_name(model, walls[j])} cross at ({xy_text(p)}), "
                         "not end to end: the wall intersects itself")
    _add(report.problems, found)


def _hide_movers(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    data.mocap_pos[:, 2] = HIDDEN_Z
    mujoco.mj_kinematics(model, data)


def _pose(physics: AUVPhysics, data: mujoco.MjData, x: float, y: float, yaw: float) -> None:
    model = physics.model.ptr
    for joint, value in (("x", x), ("y", y), ("yaw", yaw)):
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = value
    mujoco.mj_kinematics(model, data)


def _route(info: ArenaInfo) -> list[tuple[str, np.ndarray]]:
    """start, path_0 .. path_N, goal: the line the vehicle is meant to follow, named (no repeats)."""
    route = [(f"{PATH_SITE_PREFIX}{k}", p) for k, p in enumerate(info.path)]
    if info.start is not None and not (route and np.allclose(info.start, route[0][1])):
        route.insert(0, ("start", info.start))
    if info.goal is not None and not (route and np.allclose(info.goal, route[-1][1])):
        route.append(("goal", info.goal))
    keep = route[:1]
    for name, p in route[1:]:
        if np.hypot(*(p - keep[-1][1])) > 1e-6:
            keep.append((name, p))
    return keep


def _check_route(physics: AUVPhysics, info: ArenaInfo, static: list[int], report: ArenaReport) -> None:
    """Start, goal and the global path lie in free space and keep d_s from every static geom (Table 1)."""
    model, data = physics.model.ptr, mujoco.MjData(physics.model.ptr)
    _hide_movers(model, data)
    route = _route(info) if len(info.path) else []
    least = (math.inf, None, None)
    known = [g for g in static if not _is_unknown(model, g)]
    if static:
        _add(report.problems, _check_poses(physics, data, info, route, static))
        if len(route) > 1 and known:
            through, close, least = _check_segments(physics, data, route, known)
            _add(report.problems, through)
            _add(report.problems, _close_runs(model, route, close))
    report.summary = _summary(model, info, static, least)


def _near(model: mujoco.MjModel, data: mujoco.MjData, hull: int, static: list[int], reach: float) -> list[int]:
    """The geoms of `static` whose bounding spheres come within `reach` of the hull's (planes always):
    only they can be closer than `reach`, so a large arena costs mj_geomDistance calls only nearby."""
    geoms = np.asarray(static, dtype=int)
    if not len(geoms):
        return []
    gap = (np.hypot(*(data.geom_xpos[geoms, :2] - data.geom_xpos[hull, :2]).T)
           - model.geom_rbound[geoms] - model.geom_rbound[hull])
    return geoms[(gap < reach) | (model.geom_rbound[geoms] == 0)].tolist()


def _is_unknown(model: mujoco.MjModel, geom: int) -> bool:
    return model.geom(geom).name.startswith(UNKNOWN_OBSTACLE_PREFIX)


def _check_poses(physics: AUVPhysics, data: mujoco.MjData, info: ArenaInfo, route: list,
                 static: list[int]) -> list[str]:
    """The vehicle at start (d_s clear), at each path site and at the goal (not inside a geom; path sites
    may lie inside unknown obstacles)."""
    model = physics.model.ptr
    hull = model.geom("hull").id
    poses = [(name, p, route[min(k + 1, len(route) - 1)][1] - route[max(k - 1, 0)][1])
             for k, (name, p) in enumerate(route)]
    heading = np.array([math.cos(info.start_heading), math.sin(info.start_heading)])
    if info.start is not None:
        poses.insert(0, ("start", info.start, heading))
    if info.goal is not None and not route:
        poses.append(("goal", info.goal, heading))
    problems = []
    for name, p, d in poses:
        _pose(physics, data, p[0], p[1], math.atan2(d[1], d[0]))
        on_path = name.startswith(PATH_SITE_PREFIX)  # the path may run through unknown obstacles
        for g in _near(model, data, hull, static, SAFETY_DISTANCE):
            if on_path and _is_unknown(model, g):
                continue
            gap = mujoco.mj_geomDistance(model, data, hull, g, SAFETY_DISTANCE, None)
            if gap < 0:
                problems.append(f"{name} ({xy_text(p)}) lies inside {_name(model, g)}: "
                                "the vehicle there would overlap it")
            elif name == "start" and gap < SAFETY_DISTANCE:
                heading_deg = math.degrees(info.start_heading)
                problems.append(f"the vehicle at start ({xy_text(p)}, heading {heading_deg:.0f} deg) is "
                                f"{gap:.2f} m from {_name(model, g)}, closer than "
                                f"d_s = {SAFETY_DISTANCE:g} m")
    return list(dict.fromkeys(problems))


def _check_segments(physics: AUVPhysics, data: mujoco.MjData, route: list, static: list[int]):
    """Rays along each route segment (crossings) and the hull's clearance every CHECK_STEP metres.

    Returns the crossings, {(geom, segment): (least gap, where)} for gaps under d_s, and the least
    clearance overall as (gap, geom, segment name).
    """
    model = physics.model.ptr
    hull, auv = model.geom("hull").id, model.body("auv").id
    through, close, least = [], {}, (math.inf, None, None)
    for k in range(len(route) - 1):
        (name_a, a), (name_b, b) = route[k], route[k + 1]
        segment = f"{name_a}-{name_b}"
        d = b - a
        length = float(np.hypot(*d))
        crossed, hit = _first_hit(model, data, a, d / length, length, auv, set(static))
        if crossed >= 0:
            through.append(f"segment {segment} runs through {_name(model, crossed)} at "
                           f"({xy_text(a + d * hit / length)}): the path leaves free space")
        for s in np.linspace(0.0, 1.0, max(2, math.ceil(length / CHECK_STEP) + 1)):
            p = a + s * d
            _pose(physics, data, p[0], p[1], math.atan2(d[1], d[0]))
            for g in _near(model, data, hull, static, SEARCH_DISTANCE):
                gap = mujoco.mj_geomDistance(model, data, hull, g, SEARCH_DISTANCE, None)
                if gap < least[0]:
                    least = (gap, g, segment)
                if gap < SAFETY_DISTANCE and g != crossed and gap < close.get((g, k), (math.inf,))[0]:
                    close[(g, k)] = (gap, p)
    return through, close, least


def _first_hit(model: mujoco.MjModel, data: mujoco.MjData, origin: np.ndarray, direction: np.ndarray,
               length: float, auv: int, geoms: set[int]) -> tuple[int, float]:
    """The first of `geoms` that a ray from `origin` meets within `length`, and where (-1 if none); the
    ray goes on through any other geom it meets (unknown obstacles, which the path may cross)."""
    geomid = np.zeros(1, np.int32)
    direction = np.array([direction[0], direction[1], 0.0])
    travelled = 0.0
    while True:
        start = np.array([origin[0], origin[1], 0.0]) + travelled * direction
        hit = mujoco.mj_ray(model, data, start, direction, None, 1, auv, geomid)
        if hit < 0 or travelled + hit >= length:
            return -1, math.inf
        if int(geomid[0]) in geoms:
            return int(geomid[0]), travelled + hit
        travelled += hit + RAY_STEP


def _close_runs(model: mujoco.MjModel, route: list, close: dict) -> list[str]:
    """One line per geom and run of consecutive route segments that come closer than d_s to it."""
    lines = []
    for g in sorted({g for g, _ in close}):
        ks = sorted(k for h, k in close if h == g)
        runs, start = [], ks[0]
        for prev, k in zip(ks, ks[1:] + [None], strict=True):
            if k != prev + 1:
                runs.append((start, prev))
                start = k
        for first, last in runs:
            gap, p = min((close[(g, k)] for k in range(first, last + 1)), key=lambda c: c[0])
            where = (f"segment {route[first][0]}-{route[first + 1][0]}" if first == last
                     else f"segments {route[first][0]} to {route[last + 1][0]}")
            what = ("runs into" if gap < 0 else f"passes {gap:.2f} m from")
            lines.append(f"{where} {what} {_name(model, g)} at ({xy_text(p)}), closer than "
                         f"d_s = {SAFETY_DISTANCE:g} m")
    return lines


def _check_unknown(physics: AUVPhysics, info: ArenaInfo, static: list[int], report: ArenaReport) -> None:
    """Unknown obstacles leave water from start to goal that keeps d_s from every static geom."""
    model, data = physics.model.ptr, mujoco.MjData(physics.model.ptr)
    unknown = [g for g in static if _is_unknown(model, g)]
    if not unknown or info.start is None or info.goal is None or info.bounds is None or len(info.bounds) != 4:
        return
    mujoco.mj_kinematics(model, data)
    outlines = {g: geom_outline(model, data, g) for g in static}
    fixed = [shapely.polygons(outlines[g]) for g in static if g not in unknown and outlines[g] is not None]
    unknown = [g for g in unknown if outlines[g] is not None]
    k = route_blocker(fixed, [shapely.polygons(outlines[g]) for g in unknown], info.start, info.goal,
                      info.bounds)
    lane = f"keeps d_s = {SAFETY_DISTANCE:g} m from every static geom with the hull turned any way and " \
           f"{ROUTE_MARGIN:g} m to spare (a lane {2 * (route_clearance() + ROUTE_MARGIN):.2f} m wide)"
    if k == -1:
        report.problems.append(f"no way from start to goal {lane}, even without the unknown obstacles")
    elif k is not None:
        where = xy_text(model.geom_pos[unknown[k]])
        report.problems.append(f"{_name(model, unknown[k])} at ({where}) closes the way: no way from start to "
                               f"goal {lane}")


def _check_movers(physics: AUVPhysics, info: ArenaInfo, static: list[int], report: ArenaReport) -> None:
    """Moving obstacles start and end in free water, and not on top of the vehicle's start."""
    model, data = physics.model.ptr, mujoco.MjData(physics.model.ptr)
    hull, auv = model.geom("hull").id, model.body("auv").id
    geomid = np.zeros(1, np.int32)
    for mover in info.movers:
        body = model.body(mover.body).id
        mocap = model.body_mocapid[body]
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
        waypoints = mover.waypoints
        for k, xy in enumerate(waypoints):
            label = _waypoint_label(k, len(waypoints))
            _hide_movers(model, data)
            data.mocap_pos[mocap] = [xy[0], xy[1], 0.0]
            if info.start is not None:
                _pose(physics, data, *info.start, info.start_heading)
            mujoco.mj_kinematics(model, data)
            for g in geoms:
                for s in static:
                    if mujoco.mj_geomDistance(model, data, g, s, 1.0, None) < 0:
                        report.problems.append(f"{mover.body} at its {label} ({xy_text(xy)}) "
                                               f"overlaps {_name(model, s)}")
                gap = mujoco.mj_geomDistance(model, data, g, hull, SAFETY_DISTANCE + 1.0, None)
                if label == "start" and info.start is not None and gap < SAFETY_DISTANCE:
                    report.problems.append(f"{mover.body} starts {gap:.2f} m from the vehicle's start, "
                                           f"closer than d_s = {SAFETY_DISTANCE:g} m")
        for a, b in zip(waypoints[:-1], waypoints[1:], strict=True):
            delta = b - a
            length = float(np.hypot(*delta))
            if length > 0:
                _hide_movers(model, data)
                hit = mujoco.mj_ray(model, data, np.array([*a, 0.0]), np.array([*delta / length, 0.0]),
                                    None, 1, auv, geomid)
                if 0 <= hit < length:
                    report.warnings.append(f"{mover.body} moves through {_name(model, int(geomid[0]))}")
                    break


def _waypoint_label(k: int, count: int) -> str:
    """start, waypoint 1, ..., end: the points of a mover's path as messages name them."""
    return "start" if k == 0 else "end" if k == count - 1 else f"waypoint {k}"


def _summary(model: mujoco.MjModel, info: ArenaInfo, static: list[int], least) -> str:
    names = [model.geom(g).name for g in static]
    walls = sum(n.startswith("wall") for n in names)
    unknown = sum(n.startswith(UNKNOWN_OBSTACLE_PREFIX) for n in names)
    length = float(np.sum(np.hypot(*np.diff(info.path, axis=0).T))) if len(info.path) > 1 else 0.0
    text = (f"{counted(walls, 'wall geom')}, {counted(len(static) - walls - unknown, 'other static geom')}, "
            f"{counted(unknown, 'unknown obstacle') + ', ' if unknown else ''}{counted(len(info.movers), 'mover')}, "
            f"{counted(len(info.path), 'path site')} over {length:.0f} m")
    if least is not None and least[1] is not None:
        text += f"; least clearance {least[0]:.2f} m (to {_name(model, least[1])}, segment {least[2]})"
    return text


def _xy4(b) -> str:
    return " ".join(f"{v:g}" for v in b)


# --- what an arena is, seen from above --------------------------------------------------------------


def arena_kind(model: mujoco.MjModel, info: ArenaInfo | None) -> str:
    """What an arena is, for a reader: "tunnel" (made by `auv-mj tunnel`, or walls along a global path) or
    "open-water" (made by `auv-mj arena`, or anything else)."""
    texts = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i) for i in range(model.ntext)}
    if "tunnel_command" in texts:
        return "tunnel"
    if "arena_command" in texts:
        return "open-water"
    walls = any(model.geom(g).name.startswith("wall") for g in range(model.ngeom))
    return "tunnel" if walls and info is not None and len(info.path) > 1 else "open-water"


def geom_outline(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray | None:
    """The xy outline of a geom seen from above (None for planes): what the unknown obstacles' route check and the
    preview (`auv_mj.figures.arenas`) both use."""
    kind, size = mujoco.mjtGeom(int(model.geom_type[g])), model.geom_size[g]
    rot, centre = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
    circle = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 33)), np.sin(np.linspace(0, 2 * np.pi, 33))])
    if kind == mujoco.mjtGeom.mjGEOM_PLANE:
        return None
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        corners = np.array([[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]]) * size
        return (corners @ rot.T + centre)[:, :2]
    if kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_SPHERE):
        return centre[:2] + size[0] * circle
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        axis = rot[:2, 2] * size[1]
        half = len(circle) // 2
        angle = math.atan2(axis[1], axis[0])
        turn = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        arc = size[0] * circle[: half + 1] @ np.array([[0, 1], [-1, 0]]).T @ turn.T
        return np.vstack([centre[:2] + axis + arc, centre[:2] - axis - arc])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        from scipy.spatial import ConvexHull

        mesh = model.geom_dataid[g]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        xy = (model.mesh_vert[start:start + count] @ rot.T + centre)[:, :2]
        return xy[ConvexHull(xy).vertices]
    return centre[:2] + model.geom_rbound[g] * circle
