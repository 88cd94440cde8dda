"""Tunnel arenas from a centreline: two walls of long boxes, end caps and the global path (Sec. 4.3).

`build_tunnel` turns a tunnel axis (the known global route of Sec. 4.3) and a width into an arena
MJCF element that follows the convention of `auv_mj.arenas.arena`. The path logic (reading, smoothing,
offsetting, simplifying, validating: `layout_tunnel`) is kept apart from geom creation
(`tunnel_element`), as in dm_control's corridor arenas. `auv-mj tunnel` is the command line, and the
procedural arenas of `auv_mj.arenas.procedural` are laid out by the same functions.

Shapely 2 (GEOS, vectorised) does the polyline geometry: resampling, Douglas-Peucker simplification
of the walls, crossings (an STRtree query), exact distances, and the free-water test `free_route`.
The wall offset stays our own miter offset: it takes a width per point, and a fold (a bend tighter than
the width) must be reported, not cleaned up as GEOS offset curves do.
"""

from __future__ import annotations

import copy
import json
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from auv_mj import inputs
from auv_mj.arenas.arena import (
    MAX_EXTENT,
    MAX_MOVER_SPEED,
    SAFETY_DISTANCE,
    UNKNOWN_OBSTACLE_PREFIX,
    vehicle_names,
)
from auv_mj.geometry import wrap_angle, xy_text
from auv_mj.inputs import check_numbers, is_number, is_real
from auv_mj.sim.vehicle import vehicle_facts


def min_width() -> float:
    """Narrowest tunnel [m]: d_s to both walls from a vehicle on the axis, turned any way (hull from the MJCF)."""
    return 2 * (SAFETY_DISTANCE + vehicle_facts().hull_half_length)


def route_clearance() -> float:
    """Distance [m] the vehicle's centre keeps from everything so that its hull keeps d_s, turned any way."""
    return SAFETY_DISTANCE + vehicle_facts().hull_half_length


def path_clearance() -> float:
    """Least distance [m] from the global path to a wall or known obstacle: d_s from the hull of a
    vehicle on the path heading along it (what `auv-mj check-arena` measures)."""
    return SAFETY_DISTANCE + vehicle_facts().hull_radius


WALL_THICKNESS = 1.0
"""Thickness of a wall box [m]; the wall's inner face is the tunnel's edge."""
WALL_HALF_HEIGHT = 3.0
"""Half height of every box [m]: boxes span the vehicle's plane z = 0 with room to spare."""
PATH_SPACING = 10.0
"""Default distance between consecutive path sites [m]."""
END_CLEARANCE = 15.0
"""How far an open tunnel runs on past its first and last centreline points before the end caps [m]."""
BOUNDS_MARGIN = 10.0
"""Margin between the outermost geom and `arena_bounds` [m]."""
MERGE_TOLERANCE = 0.25
"""Largest deviation [m] of a merged wall box from the exact offset curve (Douglas-Peucker)."""
SMOOTH_ITERATIONS = 3
"""Chaikin corner-cutting rounds of `--smooth`."""
MAX_TURN_DEG = 120.0
"""Sharpest turn of the centreline at one point [deg]."""
MOVER_PREFIX = "mover_"
OBSTACLE_PREFIX = "obstacle_"
UNKNOWN_PREFIX = UNKNOWN_OBSTACLE_PREFIX + "_"
ROUTE_MARGIN = 1.0
"""Half width [m] of the lane that `free_route` asks for on top of d_s from everything: room to steer."""

# Bounds on what a tunnel spec may ask for, so that every tunnel is built in bounded time and memory.
MAX_SMOOTH_ITERATIONS = 8
"""Most Chaikin rounds (each doubles the points)."""
MIN_PATH_SPACING, MAX_PATH_SPACING = 1.0, 1000.0
"""Path site spacing range [m]; the tasks' sub-goals are SUBGOAL_SPACING = 10 m apart anyway."""
MAX_WIDTH = 1000.0
"""Widest tunnel [m]."""
MAX_WALL_THICKNESS = 100.0
"""Thickest wall [m]."""
MAX_END_CLEARANCE = 1000.0
"""Longest run past the ends [m]."""
MAX_MARGIN = 1000.0
"""Widest margin around the tunnel [m]."""
MAX_MERGE_TOLERANCE = 10.0
"""Largest wall merging tolerance [m]."""
MAX_CENTRELINE_POINTS = 5000
"""Most centreline points read."""
MAX_WORKING_POINTS = 1000
"""Most centreline points after smoothing (points x 2^rounds): the wall checks compare every wall face
with every other, so this bounds their time and memory."""
MAX_TUNNEL_LENGTH = 20_000.0
"""Longest centreline [m]."""
MAX_OBSTACLE_SIZE = 1000.0
"""Largest obstacle length or width [m]."""
MAX_MOVER_RADIUS = 100.0
"""Largest moving obstacle radius [m]."""
MAX_NAME_LENGTH = 64
"""Longest obstacle or mover name."""
JSON_KEYS = ("centreline", "centerline", "width")
"""The keys a JSON centreline object may have."""

WALL_RGBA = "0.45 0.47 0.5 1"
OBSTACLE_RGBA = "0.6 0.4 0.25 1"
MOVER_RGBA = "0.85 0.2 0.2 1"
PATH_RGBA = "0.1 0.6 1 0.5"
HEADER = ("Tunnel arena made by auv-mj tunnel (auv_mj/arenas/tunnels.py), arena convention of auv_mj/arenas/arena.py; "
          "the command that made it is the text tunnel_command")


# --- inputs ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Centreline:
    """A tunnel axis: points (n, 2) [m], optional widths (n,) [m], a label per point for messages."""

    points: np.ndarray
    widths: np.ndarray | None = None
    labels: tuple[str, ...] = ()
    source: str = "<centreline>"
    width: float | None = None
    """A constant width given by the file itself (JSON "width"), used when no width is passed."""

    def label(self, i: int) -> str:
        """Name of point `i` in messages ("row 4" of a CSV file, "point 3" otherwise)."""
        return self.labels[i] if self.labels else f"point {i}"


@dataclass(frozen=True)
class Obstacle:
    """A known static obstacle: a box `length` x `width` [m] centred at (x, y), turned `angle` deg."""

    x: float
    y: float
    length: float
    width: float
    angle: float = 0.0
    name: str = ""

    def __post_init__(self):
        what = f"obstacle {self.name or ''} at ({self.x}, {self.y})".replace("  ", " ")
        _check_name(self.name, what)
        check_numbers(what, (("x", self.x, -MAX_EXTENT, MAX_EXTENT), ("y", self.y, -MAX_EXTENT, MAX_EXTENT),
                              ("angle", self.angle, -360.0, 360.0)))
        if not (is_real(self.length) and is_real(self.width) and 0 < self.length <= MAX_OBSTACLE_SIZE
                and 0 < self.width <= MAX_OBSTACLE_SIZE):
            raise ValueError(f"{what}: length {self.length} and width {self.width} must be positive, at most "
                             f"{MAX_OBSTACLE_SIZE:g} m")

    @classmethod
    def parse(cls, text: str) -> Obstacle:
        """From "x,y,length,width[,angle[,name]]" (the `--obstacle` option)."""
        numbers, name = _split_spec(text, "--obstacle", "x,y,length,width[,angle[,name]]", 4, 5)
        try:
            return cls(*numbers, name=name)
        except ValueError as e:
            raise ValueError(f"--obstacle {text!r}: {e}") from None

    def corners(self) -> np.ndarray:
        """The four corners (4, 2) [m], counter-clockwise."""
        c, s = math.cos(math.radians(self.angle)), math.sin(math.radians(self.angle))
        half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [self.length / 2, self.width / 2]
        return half @ np.array([[c, s], [-s, c]]) + [self.x, self.y]


@dataclass(frozen=True)
class MovingObstacle:
    """An unknown moving obstacle: a cylinder of `radius` [m] going (x0, y0) -> (x1, y1) at `speed` m/s."""

    x0: float
    y0: float
    x1: float
    y1: float
    speed: float
    radius: float
    name: str = ""

    def __post_init__(self):
        what = f"mover {self.name}" if self.name else "mover"
        _check_name(self.name, what)
        check_numbers(what, [(k, getattr(self, k), -MAX_EXTENT, MAX_EXTENT) for k in ("x0", "y0", "x1", "y1")])
        if not (is_real(self.speed) and is_real(self.radius) and 0 <= self.speed <= MAX_MOVER_SPEED
                and 0 < self.radius <= MAX_MOVER_RADIUS):
            raise ValueError(f"{what}: speed {self.speed} must be in [0, {MAX_MOVER_SPEED:g}] m/s and radius "
                             f"{self.radius} in (0, {MAX_MOVER_RADIUS:g}] m")

    @classmethod
    def parse(cls, text: str) -> MovingObstacle:
        """From "x0,y0,x1,y1,speed,radius[,name]" (the `--mover` option)."""
        numbers, name = _split_spec(text, "--mover", "x0,y0,x1,y1,speed,radius[,name]", 6, 6)
        try:
            return cls(*numbers, name=name)
        except ValueError as e:
            raise ValueError(f"--mover {text!r}: {e}") from None


def _split_spec(text: str, option: str, form: str, least: int, most: int) -> tuple[list[float], str]:
    cells = [c.strip() for c in text.split(",")]
    name = ""
    if len(cells) > least and not is_number(cells[-1]):
        name = cells.pop()
    if not least <= len(cells) <= most:
        raise ValueError(f"{option} {text!r}: expected {form}")
    numbers = []
    for cell in cells:
        if not is_number(cell, finite=True):
            raise ValueError(f"{option} {text!r}: {cell!r} is not a finite number (expected {form})")
        numbers.append(float(cell))
    if name and not (name.replace("_", "").isalnum() and name.isascii() and len(name) <= MAX_NAME_LENGTH):
        raise ValueError(f"{option} {text!r}: name {name!r} may hold only letters, digits and _ "
                         f"(at most {MAX_NAME_LENGTH})")
    return numbers, name


def _check_name(name, what: str) -> None:
    """Names become MJCF names: letters, digits and _, at most MAX_NAME_LENGTH characters."""
    if not isinstance(name, str) or len(name) > MAX_NAME_LENGTH or (name and not name.replace("_", "").isalnum()) \
            or not name.isascii():
        raise ValueError(f"{what}: name {name!r:.80} may hold only letters, digits and _ "
                         f"(at most {MAX_NAME_LENGTH})")
    if name in vehicle_names():
        raise ValueError(f"{what}: name {name!r} reuses a name of the vehicle model (auv, hull, x, y, yaw, sonar_*, "
                         "...): name it otherwise")


def read_centreline(path: str | Path) -> Centreline:
    """Reads a centreline from CSV (x,y[,width] rows, header optional) or JSON.

    JSON is a list of [x, y] or [x, y, width], or {"centreline": [...], "width": W}. The file is read within
    the bounds of `auv_mj.inputs` (size, UTF-8 text, JSON nesting); errors name the file.
    """
    path = Path(path)
    text = inputs.read_text(path, "the centreline")
    if path.suffix.lower() == ".json" or text.lstrip().startswith(("[", "{")):
        return _parse_json(text, inputs.source_name(path))
    return _parse_csv(text, inputs.source_name(path))


def _parse_csv(text: str, source: str) -> Centreline:
    rows, labels = [], []
    columns = ("x", "y", "width")
    table = inputs.csv_rows(text, source, "x,y or x,y,width")
    for lineno, cells in enumerate(table, start=1):
        cells = [c.strip() for c in cells]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if not rows and not any(is_number(c) for c in cells):
            if [c.lower() for c in cells[:3]] == ["x", "y", "z"]:
                raise ValueError(f"{source}: row {lineno}: the columns are x,y,z, a tube's centreline (a planar one "
                                 "is x,y[,width]): build it with `auv-mj tunnel --tube`")
            continue  # the header
        if len(cells) not in (2, 3):
            raise ValueError(f"{source}: row {lineno} has {len(cells)} cells; expected x,y or x,y,width")
        if rows and len(cells) != len(rows[0]):
            raise ValueError(f"{source}: row {lineno} has {len(cells)} cells but the rows before it "
                             f"have {len(rows[0])}")
        values = []
        for column, cell in zip(columns, cells, strict=False):
            if not is_number(cell):
                raise ValueError(f"{source}: row {lineno}, column {column}: {cell!r} is not a number")
            values.append(float(cell))
        rows.append(values)
        labels.append(f"row {lineno}")
    return _centreline(rows, labels, source)


def _parse_json(text: str, source: str) -> Centreline:
    inputs.check_json_depth(text, source)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{source}: not valid JSON: {e}") from None
    width = None
    if isinstance(data, dict):
        _check_json_keys(data, source)
        points = data.get("centreline", data.get("centerline"))
        if points is None:
            raise ValueError(f"{source}: a JSON object needs a \"centreline\" list of [x, y] points")
        width = data.get("width")
        if width is not None and (isinstance(width, bool) or not isinstance(width, (int, float))):
            raise ValueError(f"{source}: \"width\" must be a number, got {width!r}")
        data = points
    if not isinstance(data, list):
        raise ValueError(f"{source}: expected a list of [x, y] or [x, y, width] points")
    rows, labels = [], []
    for i, point in enumerate(data):
        if not isinstance(point, list) or len(point) not in (2, 3):
            raise ValueError(f"{source}: point {i} is {point!r}; expected [x, y] or [x, y, width]")
        if rows and len(point) != len(rows[0]):
            raise ValueError(f"{source}: point {i} has {len(point)} values but the points before it "
                             f"have {len(rows[0])}")
        for column, value in zip(("x", "y", "width"), point, strict=False):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{source}: point {i}, {column}: {value!r} is not a number")
        rows.append([float(v) for v in point])
        labels.append(f"point {i}")
    line = _centreline(rows, labels, source)
    return Centreline(line.points, line.widths, line.labels, source, width)


def _check_json_keys(data: dict, source: str) -> None:
    """A JSON centreline object holds JSON_KEYS only, and one spelling of "centreline"."""
    unknown = [k for k in data if k not in JSON_KEYS]
    if unknown:
        raise ValueError(f"{source}: unknown keys {unknown[:5]!r:.80} in the JSON object"
                         f"{inputs.did_you_mean(unknown[0], JSON_KEYS)}; it may hold {', '.join(JSON_KEYS)}")
    if "centreline" in data and "centerline" in data:
        raise ValueError(f"{source}: give \"centreline\" or \"centerline\", not both")


def _centreline(rows: list[list[float]], labels: list[str], source: str) -> Centreline:
    if len(rows) > MAX_CENTRELINE_POINTS:
        raise ValueError(f"{source}: {len(rows)} centreline points; at most {MAX_CENTRELINE_POINTS}")
    array = np.array(rows, dtype=float).reshape(-1, len(rows[0]) if rows else 2)
    for i, row in enumerate(array):
        for column, value in zip(("x", "y", "width"), row, strict=False):
            if not math.isfinite(value):
                raise ValueError(f"{source}: {labels[i]}, {column} = {value}: not a finite number")
    widths = array[:, 2].copy() if array.shape[1] == 3 else None
    return Centreline(array[:, :2].copy(), widths, tuple(labels), source)


def as_centreline(centreline: Centreline | Sequence | np.ndarray, source: str = "<centreline>") -> Centreline:
    """A Centreline from an (n, 2) or (n, 3) array-like of x, y[, width] (or a Centreline itself)."""
    if isinstance(centreline, Centreline):
        return centreline
    try:
        array = np.array(centreline, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{source}: the centreline must be numbers x, y[, width]: {e}") from None
    if array.ndim != 2 or array.shape[1] not in (2, 3):
        raise ValueError(f"{source}: the centreline must have shape (n, 2) or (n, 3), got {array.shape}")
    return _centreline(array.tolist(), [f"point {i}" for i in range(len(array))], source)


# --- path logic -----------------------------------------------------------------------------------


def chaikin(points: np.ndarray, iterations: int, closed: bool = False) -> np.ndarray:
    """Chaikin corner cutting of an (n, k) polyline; an open one keeps its two end points."""
    points = np.asarray(points, dtype=float)
    for _ in range(iterations):
        a = points if closed else points[:-1]
        b = np.roll(points, -1, axis=0) if closed else points[1:]
        cut = np.empty((2 * len(a), points.shape[1]))
        cut[0::2] = 0.75 * a + 0.25 * b
        cut[1::2] = 0.25 * a + 0.75 * b
        points = cut if closed else np.vstack([points[:1], cut, points[-1:]])
    return points


def resample(points: np.ndarray, spacing: float, closed: bool = False) -> np.ndarray:
    """Points every ~`spacing` m of arc length along a polyline, the end points included.

    A closed polyline starts at its first point and stops one spacing short of coming back to it.
    """
    return _resample(points, spacing, closed)[0]


def _resample(points: np.ndarray, spacing: float, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """`resample`, and the arc length of each point."""
    line = polyline(points, closed)
    count = max(3 if closed else 1, math.ceil(line.length / spacing - 1e-9))
    at = np.linspace(0.0, line.length, count + 1)
    if closed:
        at = at[:-1]
    return shapely.get_coordinates(shapely.line_interpolate_point(line, at)), at


def polyline(points: np.ndarray, closed: bool = False) -> shapely.LineString:
    """A polyline (n, 2) as a Shapely LineString, or a LinearRing when `closed`."""
    return shapely.linearrings(points) if closed else shapely.linestrings(points)


def segment_lines(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The segments a[i] -> b[i] ((n, 2) each) as an array of n Shapely LineStrings."""
    return shapely.linestrings(np.stack([a, b], axis=1))


def crossings(lines: np.ndarray, others: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where segments `lines` properly cross segments `others` (default: each other, i < j).

    Returns the index pairs (i, j) in lexicographic order and the crossing points (k, 2). Touching at an
    end or running along each other is not crossing. An STRtree query, so about n log n.
    """
    i, j = shapely.STRtree(lines if others is None else others).query(lines, predicate="crosses")
    if others is None:
        i, j = i[i < j], j[i < j]
    order = np.lexsort((j, i))
    i, j = i[order], j[order]
    points = shapely.intersection(lines[i], (lines if others is None else others)[j])
    return i, j, shapely.get_coordinates(points).reshape(len(i), 2)


@dataclass(frozen=True)
class WallSegment:
    """The inner face a -> b of one wall box; the tunnel lies to its right, the box to its left.

    `extend_a` / `extend_b` lengthen the box past a / b to close the outside of a corner.
    """

    name: str
    a: np.ndarray
    b: np.ndarray
    extend_a: float = 0.0
    extend_b: float = 0.0


@dataclass(frozen=True)
class TunnelLayout:
    """Everything `tunnel_element` needs: wall faces, the global path, the start heading, bounds."""

    walls: tuple[WallSegment, ...]
    path: np.ndarray
    start_heading: float
    bounds: np.ndarray
    closed: bool
    axis: np.ndarray = field(repr=False)
    """The (smoothed) centreline the path samples, (n, 2)."""


class _Working:
    """The centreline being laid out: points, half widths, and where each point came from."""

    def __init__(self, line: Centreline, half: np.ndarray, closed: bool):
        self.line, self.closed = line, closed
        self.points = line.points
        self.half = half
        self.src = np.arange(len(line.points), dtype=float)

    def near(self, *src: float) -> str:
        """Names the input points around working positions `src` (fractions of input indices)."""
        n = len(self.line.points)
        if self.closed and max(src) - min(src) > n / 2:
            src = tuple(v + n if v < n / 2 else v for v in src)
        lo, hi = math.floor(min(src) + 1e-6), math.ceil(max(src) - 1e-6)
        names = dict.fromkeys(self.line.label(i % n if self.closed else min(max(i, 0), n - 1))
                              for i in range(lo, hi + 1))
        return " and ".join(names) if len(names) <= 2 else f"{next(iter(names))} to {list(names)[-1]}"


def layout_tunnel(centreline: Centreline | Sequence | np.ndarray, width: float | None = None, *,
                  closed: bool = False, smooth: int = 0, path_spacing: float = PATH_SPACING,
                  obstacles: Sequence[Obstacle] = (), movers: Sequence[MovingObstacle] = (),
                  wall_thickness: float = WALL_THICKNESS, end_clearance: float = END_CLEARANCE,
                  margin: float = BOUNDS_MARGIN, merge_tolerance: float = MERGE_TOLERANCE) -> TunnelLayout:
    """The walls, path and bounds of a tunnel, validated; see `build_tunnel` for the arguments."""
    line = as_centreline(centreline)
    source = line.source
    check_parameters(source, width=width, smooth=smooth, path_spacing=path_spacing, wall_thickness=wall_thickness,
                     end_clearance=end_clearance, margin=margin, merge_tolerance=merge_tolerance)
    widths = _widths(line, width)
    check_extent(line, widths, smooth, closed, obstacles, movers)
    points = line.points
    if closed and len(points) > 2 and np.allclose(points[0], points[-1]):
        line = Centreline(points[:-1], None if line.widths is None else line.widths[:-1],
                          line.labels[:-1], source, line.width)
        widths, points = widths[:-1], points[:-1]
    least = 3 if closed else 2
    if len(points) < least:
        raise ValueError(f"{source}: a{' closed' if closed else 'n open'} tunnel needs at least {least} "
                         f"centreline points, got {len(points)}")
    work = _Working(line, widths / 2, closed)
    _check_polyline(work)
    if smooth:
        # a loop's point index goes round like an angle, which survives averaging as (cos, sin)
        n = len(points)
        angle = 2 * np.pi * work.src / n
        src = np.column_stack([np.cos(angle), np.sin(angle)]) if closed else work.src[:, None]
        smoothed = chaikin(np.column_stack([work.points, work.half, src]), smooth, closed)
        if closed:
            smoothed = _start_near(smoothed, points[0])
        work.points, work.half = smoothed[:, :2], smoothed[:, 2]
        work.src = ((np.arctan2(smoothed[:, 4], smoothed[:, 3]) * n / (2 * np.pi)) % n if closed
                    else smoothed[:, 3])
    _check_turns(work)
    rings = _wall_rings(work, end_clearance)
    _check_walls(work, rings)
    walls = _merge_walls(rings, merge_tolerance, wall_thickness)
    check_inside(source, walls, obstacles, movers)
    path = resample(work.points, path_spacing, closed)
    _check_clearance(work, walls, obstacles)
    heading = math.atan2(*(work.points[1] - work.points[0])[::-1])
    bounds = _bounds(walls, wall_thickness, obstacles, movers, margin)
    return TunnelLayout(tuple(walls), path, heading, bounds, closed, work.points)


def check_parameters(source: str, *, width, smooth, path_spacing, wall_thickness, end_clearance, margin,
                     merge_tolerance) -> None:
    """The layout options, by type and range (the MAX_* / MIN_* bounds); ValueError naming the option."""
    if not (isinstance(smooth, (int, np.integer)) and not isinstance(smooth, bool)
            and 0 <= smooth <= MAX_SMOOTH_ITERATIONS):
        raise ValueError(f"{source}: smoothing rounds must be a whole number in [0, {MAX_SMOOTH_ITERATIONS}], "
                         f"got {smooth!r:.40}")
    checks = [("path spacing", path_spacing, MIN_PATH_SPACING, MAX_PATH_SPACING),
              ("wall thickness", wall_thickness, 0.0, MAX_WALL_THICKNESS),
              ("end clearance", end_clearance, 0.0, MAX_END_CLEARANCE), ("margin", margin, 0.0, MAX_MARGIN),
              ("merge tolerance", merge_tolerance, 0.0, MAX_MERGE_TOLERANCE)]
    if width is not None:
        checks.append(("width", width, 0.0, MAX_WIDTH))
    check_numbers(source, checks)
    if not wall_thickness > 0:
        raise ValueError(f"{source}: wall thickness must be above 0 m, got {wall_thickness:g}")
    if not merge_tolerance > 0:  # 0 keeps every vertex of the offset curves: a box per polyline point
        raise ValueError(f"{source}: merge tolerance must be above 0 m, got {merge_tolerance:g}")


def check_extent(line: Centreline, widths: np.ndarray, smooth: int, closed: bool,
                 obstacles: Sequence[Obstacle], movers: Sequence[MovingObstacle]) -> None:
    """Bounded work: coordinates within MAX_EXTENT, widths up to MAX_WIDTH, at most MAX_WORKING_POINTS points
    after smoothing, a centreline up to MAX_TUNNEL_LENGTH; and obstacles and movers of unique names."""
    source = line.source
    far = np.flatnonzero(np.any(np.abs(line.points) > MAX_EXTENT, axis=1))
    if len(far):
        raise ValueError(f"{source}: {line.label(int(far[0]))} ({xy_text(line.points[far[0]])}) is beyond "
                         f"+-{MAX_EXTENT:g} m")
    wide = np.flatnonzero(widths > MAX_WIDTH)
    if len(wide):
        where = f"{line.label(int(wide[0]))}: " if line.widths is not None else ""
        raise ValueError(f"{source}: {where}width {widths[wide[0]]:g} m is wider than {MAX_WIDTH:g} m")
    working = len(line.points) * 2 ** int(smooth)
    if working > MAX_WORKING_POINTS:
        raise ValueError(f"{source}: {len(line.points)} centreline points smoothed {smooth} times make {working} "
                         f"points; at most {MAX_WORKING_POINTS}: use fewer points or rounds")
    loop = np.vstack([line.points, line.points[:1]]) if closed else line.points
    length = float(np.sum(np.hypot(*np.diff(loop, axis=0).T)))
    if length > MAX_TUNNEL_LENGTH:
        raise ValueError(f"{source}: the centreline is {length:.0f} m long; at most {MAX_TUNNEL_LENGTH:g} m")
    check_names(source, obstacles, movers)


def check_names(source: str, obstacles: Sequence[Obstacle], movers: Sequence[MovingObstacle],
                unknown: Sequence[Obstacle] = ()) -> None:
    """Obstacles, movers and unknown obstacles are objects of their classes with unique MJCF names."""
    for kind, items, cls in (("obstacle", obstacles, Obstacle), ("mover", movers, MovingObstacle),
                             ("unknown obstacle", unknown, Obstacle)):
        if not all(isinstance(item, cls) for item in items):
            raise ValueError(f"{source}: {kind}s must be {cls.__name__} objects")
    names = ([obstacle_name(o, k) for k, o in enumerate(obstacles)] + [mover_name(m, k) for k, m in enumerate(movers)]
             + [unknown_name(o, k) for k, o in enumerate(unknown)])
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"{source}: obstacles and movers need unique names; {', '.join(repeated)} is given twice")


def check_inside(source: str, walls: Sequence[WallSegment], obstacles: Sequence[Obstacle],
                 movers: Sequence[MovingObstacle], unknown: Sequence[Obstacle] = ()) -> None:
    """Every obstacle's centre (known or unknown) and both ends of every mover's track lie inside the tunnel:
    within the closed chains of wall faces (even-odd rule, so a closed tunnel's inner wall is a hole)."""
    a = np.array([w.a for w in walls])
    b = np.array([w.b for w in walls])
    points = [(f"{obstacle_name(o, k)} at ({xy_text([o.x, o.y])})", (o.x, o.y)) for k, o in enumerate(obstacles)]
    points += [(f"{unknown_name(o, k)} at ({xy_text([o.x, o.y])})", (o.x, o.y)) for k, o in enumerate(unknown)]
    points += [(f"{mover_name(m, k)}'s track {end} ({xy_text(p)})", p) for k, m in enumerate(movers)
               for end, p in (("start", (m.x0, m.y0)), ("end", (m.x1, m.y1)))]
    if not points:
        return
    xy = np.array([p for _, p in points], dtype=float)
    x, y = xy[:, :1], xy[:, 1:]
    ya, yb = a[None, :, 1], b[None, :, 1]
    straddles = (ya > y) != (yb > y)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        cross_x = a[None, :, 0] + (y - ya) * (b[None, :, 0] - a[None, :, 0]) / (yb - ya)
    inside = np.count_nonzero(straddles & (cross_x > x), axis=1) % 2 == 1
    outside = [name for (name, _), ok in zip(points, inside, strict=True) if not ok]
    if outside:
        raise ValueError(f"{source}: {outside[0]} is outside the tunnel: obstacles and movers must lie between "
                         "its walls")


def _start_near(loop: np.ndarray, first: np.ndarray) -> np.ndarray:
    """A closed polyline (n, k) (x, y first) turned to start where it passes nearest to `first`."""
    a, b = loop, np.roll(loop, -1, axis=0)
    d = b[:, :2] - a[:, :2]
    t = np.clip(np.sum((first - a[:, :2]) * d, axis=1) / np.sum(d * d, axis=1), 0.0, 1.0)
    foot = a + t[:, None] * (b - a)
    k = int(np.argmin(np.hypot(*(foot[:, :2] - first).T)))
    rest = np.roll(loop, -(k + 1), axis=0)
    if np.isclose(t[k], 1.0):
        return rest
    if np.isclose(t[k], 0.0):
        return np.roll(rest, 1, axis=0)
    return np.vstack([foot[k:k + 1], rest])


def _widths(line: Centreline, width: float | None) -> np.ndarray:
    source = line.source
    if width is not None and line.widths is not None:
        raise ValueError(f"{source}: the centreline gives a width per point and a constant width "
                         f"{width} m was passed too; use one or the other")
    if width is None and line.widths is None:
        width = line.width
    if line.widths is None and width is None:
        raise ValueError(f"{source}: no tunnel width: pass --width W or give a third column")
    widths = line.widths if line.widths is not None else np.full(len(line.points), float(width))
    for i, w in enumerate(widths):
        where = f"{line.label(i)}: " if line.widths is not None else ""
        if not math.isfinite(w):
            raise ValueError(f"{source}: {where}width {w} is not a finite number")
        if w < min_width():
            raise ValueError(
                f"{source}: {where}width {w:g} m is too narrow: a vehicle on the axis keeps d_s = "
                f"{SAFETY_DISTANCE:g} m from both walls with its {vehicle_facts().hull_half_length:.3f} m half "
                f"length, so a "
                f"tunnel must be at least {min_width():.2f} m wide")
    return np.asarray(widths, dtype=float)


def _segments(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends of the segments of a polyline (a closed one has one more, back to its start)."""
    return (points, np.roll(points, -1, axis=0)) if closed else (points[:-1], points[1:])


def _arc_length(points: np.ndarray, closed: bool) -> np.ndarray:
    a, b = _segments(points, closed)
    return np.concatenate([[0.0], np.cumsum(np.hypot(*(b - a).T))])


def _check_polyline(work: _Working) -> None:
    """Repeated points and a centreline crossing itself, named by the input rows."""
    source, line = work.line.source, work.line
    a, b = _segments(work.points, work.closed)
    for i in np.flatnonzero(np.hypot(*(b - a).T) < 1e-9):
        j = (i + 1) % len(work.points)
        raise ValueError(f"{source}: {line.label(i)} and {line.label(j)} are the same point "
                         f"({xy_text(a[i])}); remove one")
    i, j, points = crossings(segment_lines(a, b))
    if len(i):
        i, j, n = i[0], j[0], len(work.points)
        raise ValueError(f"{source}: the centreline crosses itself: the segment {line.label(i)} - "
                         f"{line.label((i + 1) % n)} crosses {line.label(j)} - {line.label((j + 1) % n)} "
                         f"at ({xy_text(points[0])})")


def _check_turns(work: _Working) -> None:
    a, b = _segments(work.points, work.closed)
    d = b - a
    heading = np.arctan2(d[:, 1], d[:, 0])
    nxt = np.roll(heading, -1) if work.closed else heading[1:]
    turn = np.abs(wrap_angle(nxt - heading[: len(nxt)]))
    bad = np.flatnonzero(turn > math.radians(MAX_TURN_DEG))
    if len(bad):
        k = (bad[0] + 1) % len(work.points)
        raise ValueError(f"{work.line.source}: the centreline turns {math.degrees(turn[bad[0]]):.0f} deg at "
                         f"{work.near(work.src[k])} ({xy_text(work.points[k])}); at most {MAX_TURN_DEG:g} deg "
                         "at one point: add points or smooth it")


def _offset(points: np.ndarray, half: np.ndarray, closed: bool) -> np.ndarray:
    """Miter offset of a polyline, `half` [m] to its left (negative: right), per vertex."""
    a, b = _segments(points, closed)
    d = b - a
    normal = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(*d.T)[:, None]
    if closed:
        before, after = np.roll(normal, 1, axis=0), normal
    else:
        before, after = np.vstack([normal[:1], normal]), np.vstack([normal, normal[-1:]])
    miter = before + after
    miter /= np.hypot(*miter.T)[:, None]
    scale = 1.0 / np.maximum(np.sum(miter * after, axis=1), 1e-6)
    return points + miter * (half * scale)[:, None]


@dataclass
class _Ring:
    """A closed chain of wall faces (tunnel on its right), split into named parts."""

    parts: list[tuple[str, np.ndarray, np.ndarray]]  # (name, points (k, 2), src (k,)), end = next's start
    closed_part: bool = False  # one part that closes on itself (a closed tunnel's wall)


def _wall_rings(work: _Working, end_clearance: float) -> list[_Ring]:
    points, half, src = work.points, work.half, work.src
    if not work.closed:
        t0 = (points[0] - points[1]) / np.hypot(*(points[0] - points[1]))
        t1 = (points[-1] - points[-2]) / np.hypot(*(points[-1] - points[-2]))
        if end_clearance > 0:
            points = np.vstack([points[0] + t0 * end_clearance, points, points[-1] + t1 * end_clearance])
            half = np.concatenate([half[:1], half, half[-1:]])
            src = np.concatenate([src[:1], src, src[-1:]])
    left = _offset(points, half, work.closed)
    right = _offset(points, -half, work.closed)
    _check_folds(work, points, left, right, src)
    if work.closed:
        return [_Ring([("left", left, src)], True), _Ring([("right", right[::-1], src[::-1])], True)]
    return [_Ring([("left", left, src),
                   ("cap_goal", np.array([left[-1], right[-1]]), src[[-1, -1]]),
                   ("right", right[::-1], src[::-1]),
                   ("cap_start", np.array([right[0], left[0]]), src[[0, 0]])])]


def _check_folds(work: _Working, points: np.ndarray, left: np.ndarray, right: np.ndarray,
                 src: np.ndarray) -> None:
    """An offset segment pointing against its centreline segment: the bend is tighter than the width."""
    a, b = _segments(points, work.closed)
    for side, wall in (("left", left), ("right", right)):
        wa, wb = _segments(wall, work.closed)
        bad = np.flatnonzero(np.sum((wb - wa) * (b - a), axis=1) <= 0)
        if len(bad):
            i = bad[0]
            j = (i + 1) % len(points)
            w = 2 * max(work.half.max(), 0)
            raise ValueError(
                f"{work.line.source}: the {side} wall folds over itself near {work.near(src[i], src[j])} "
                f"({xy_text(points[i])}): the bend there is too tight for a {w:g} m wide tunnel (its radius "
                f"must exceed half the width, {w / 2:g} m): widen the bend, add points, smooth it, or "
                "narrow the tunnel")


def _ring_segments(ring: _Ring) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
    """All faces of a ring: starts, ends, part names, and (k, 2) src of their end points."""
    a, b, names, src = [], [], [], []
    for name, pts, s in ring.parts:
        if ring.closed_part:
            pts, s = np.vstack([pts, pts[:1]]), np.concatenate([s, s[:1]])
        a.append(pts[:-1])
        b.append(pts[1:])
        names += [name] * (len(pts) - 1)
        src.append(np.column_stack([s[:-1], s[1:]]))
    return np.vstack(a), np.vstack(b), names, np.vstack(src)


def _check_walls(work: _Working, rings: list[_Ring]) -> None:
    """Wall faces crossing each other (the tunnel overlaps itself); faces only touch at their joins."""
    chains = [_ring_segments(r) for r in rings]
    names = sum((c[2] for c in chains), [])
    src = np.vstack([c[3] for c in chains])
    i, j, points = crossings(segment_lines(np.vstack([c[0] for c in chains]), np.vstack([c[1] for c in chains])))
    if len(i):
        i, j = i[0], j[0]
        what = {"left": "left wall", "right": "right wall", "cap_goal": "end cap at the goal",
                "cap_start": "end cap at the start"}
        raise ValueError(
            f"{work.line.source}: the tunnel walls cross at ({xy_text(points[0])}): the {what[names[i]]} near "
            f"{work.near(*src[i])} crosses the {what[names[j]]} near {work.near(*src[j])} (the bend is "
            "too tight for the width, or the tunnel runs into itself)")


def _merge_walls(rings: list[_Ring], tolerance: float, thickness: float) -> list[WallSegment]:
    """Merges near-collinear faces into long boxes and lengthens boxes to close outside corners."""
    walls = []
    for ring in rings:
        faces: list[tuple[str, np.ndarray, np.ndarray]] = []
        for name, pts, _ in ring.parts:
            # Douglas-Peucker (GEOS): the fewest vertices within `tolerance` of the exact offset curve
            kept = shapely.get_coordinates(shapely.simplify(polyline(pts, ring.closed_part), tolerance,
                                                            preserve_topology=False))
            count = len(kept) - 1
            for k in range(count):
                # the right wall is walked backwards; number every wall from the start
                number = count - 1 - k if name == "right" else k
                faces.append((name if name.startswith("cap") else f"{name}_{number}", kept[k], kept[k + 1]))
        n = len(faces)
        extend = np.zeros((n, 2))
        for k in range(n):
            d1 = faces[k][2] - faces[k][1]
            d2 = faces[(k + 1) % n][2] - faces[(k + 1) % n][1]
            turn = math.atan2(d1[0] * d2[1] - d1[1] * d2[0], float(d1 @ d2))
            if turn < 0:  # turning into the tunnel: the boxes' outer corners leave a wedge to fill
                e = thickness * math.tan(min(-turn, math.radians(150)) / 2)
                extend[k, 1] = extend[(k + 1) % n, 0] = e
        walls += [WallSegment(f"wall_{name}", a, b, float(ea), float(eb))
                  for (name, a, b), (ea, eb) in zip(faces, extend, strict=False)]
    return walls


def _check_clearance(work: _Working, walls: list[WallSegment], obstacles: Sequence[Obstacle]) -> None:
    """The global path keeps path_clearance() from every wall and known obstacle (exact distances)."""
    source = work.line.source
    path = polyline(work.points, work.closed)
    src = np.concatenate([work.src, work.src[:1] + len(work.line.points)]) if work.closed else work.src
    arc = _arc_length(work.points, work.closed)

    def nearest(shape) -> tuple[np.ndarray, str]:
        """The point of the path nearest `shape`, and the input points around it."""
        p = shapely.get_coordinates(shapely.shortest_line(path, shape))[0]
        return p, work.near(float(np.interp(shapely.line_locate_point(path, shapely.points(p)), arc, src)))

    faces = segment_lines(np.array([w.a for w in walls]), np.array([w.b for w in walls]))
    distance = shapely.distance(path, faces)
    j = int(np.argmin(distance))
    if distance[j] < path_clearance():
        p, near = nearest(faces[j])
        raise ValueError(
            f"{source}: the global path near {near} ({xy_text(p)}) passes {distance[j]:.2f} m from the wall "
            f"{walls[j].name}, closer than d_s + hull radius = {path_clearance():.2f} m (another part of the "
            "tunnel is too close)")
    boxes = shapely.polygons([o.corners() for o in obstacles]) if obstacles else np.array([])
    for k, gap in enumerate(shapely.distance(path, boxes)):
        if gap < path_clearance():
            obstacle = obstacles[k]
            p, near = nearest(boxes[k])
            raise ValueError(
                f"{source}: {obstacle_name(obstacle, k)} at ({xy_text([obstacle.x, obstacle.y])}) is {gap:.2f} m "
                f"from the global path near {near} ({xy_text(p)}), closer than d_s + hull radius = "
                f"{path_clearance():.2f} m: move it or route the centreline around it")


def _bounds(walls: list[WallSegment], thickness: float, obstacles: Sequence[Obstacle],
            movers: Sequence[MovingObstacle], margin: float) -> np.ndarray:
    pts = [w.a for w in walls] + [w.b for w in walls]
    pad = thickness + max((max(w.extend_a, w.extend_b) for w in walls), default=0.0)
    lo, hi = np.min(pts, axis=0) - pad, np.max(pts, axis=0) + pad
    for o in obstacles:
        lo, hi = np.minimum(lo, o.corners().min(axis=0)), np.maximum(hi, o.corners().max(axis=0))
    for m in movers:
        ends = np.array([[m.x0, m.y0], [m.x1, m.y1]])
        lo, hi = np.minimum(lo, ends.min(axis=0) - m.radius), np.maximum(hi, ends.max(axis=0) + m.radius)
    return np.concatenate([lo - margin, hi + margin])


# --- free water -----------------------------------------------------------------------------------


def box_polygon(x: float, y: float, half_x: float, half_y: float, yaw: float) -> shapely.Polygon:
    """The footprint of a box centred at (x, y) with half sizes (half_x, half_y), turned `yaw` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    corners = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [half_x, half_y]
    return shapely.polygons(corners @ np.array([[c, s], [-s, c]]) + [x, y])


def free_route(footprints: Sequence[shapely.Geometry], start, goal, bounds,
               margin: float = ROUTE_MARGIN) -> bool:
    """Whether water inside `bounds` (xmin, ymin, xmax, ymax) joins `start` to `goal` in which the hull,
    turned any way, keeps d_s from every footprint with `margin` m to spare on either side.

    The footprints are grown by `route_clearance()` + `margin` (the vehicle's configuration space, taken
    conservatively as a disc) and the free part of the map that holds the start must hold the goal.
    """
    reach = route_clearance() + margin
    blocked = shapely.union_all(shapely.buffer(np.asarray(footprints, dtype=object), reach, quad_segs=4))
    parts = shapely.get_parts(shapely.difference(shapely.box(*bounds), blocked))
    home = parts[shapely.intersects_xy(parts, *start)]
    return bool(len(home)) and bool(shapely.intersects_xy(home, *goal).any())


def route_blocker(fixed: Sequence[shapely.Geometry], added: Sequence[shapely.Geometry], start, goal, bounds,
                  margin: float = ROUTE_MARGIN) -> int | None:
    """Which of the footprints `added`, placed in order among `fixed`, first closes the way from start to
    goal (`free_route`): its index, -1 if `fixed` alone leaves no way, None if there is a way."""
    everything = [*fixed, *added]
    if free_route(everything, start, goal, bounds, margin):
        return None
    for k in range(-1, len(added) - 1):
        if not free_route(everything[:len(fixed) + k + 1], start, goal, bounds, margin):
            return k
    return len(added) - 1  # every shorter prefix leaves a way: the last one closes it


def check_unknown(layout: TunnelLayout, unknown: Sequence[Obstacle], obstacles: Sequence[Obstacle] = (),
                  wall_thickness: float = WALL_THICKNESS, margin: float = ROUTE_MARGIN,
                  source: str = "<tunnel>") -> None:
    """Raises ValueError naming the first unknown obstacle that leaves no way past it (`free_route` from
    the path's first point to its last; on a closed tunnel, whose goal is next to its start, that says
    little)."""
    if not unknown:
        return
    fixed = [box_polygon(*centre, *half, yaw) for centre, half, yaw in
             (wall_box(w, wall_thickness) for w in layout.walls)]
    fixed += [shapely.polygons(o.corners()) for o in obstacles]
    added = [shapely.polygons(o.corners()) for o in unknown]
    k = route_blocker(fixed, added, layout.path[0], layout.path[-1], layout.bounds, margin)
    gap = 2 * (route_clearance() + margin)
    if k == -1:
        raise ValueError(f"{source}: no way from start to goal keeps d_s = {SAFETY_DISTANCE:g} m from the walls "
                         f"and known obstacles with the hull turned any way and {margin:g} m to spare (a lane "
                         f"{gap:.2f} m wide): the tunnel is too narrow for unknown obstacles")
    if k is not None:
        o = unknown[k]
        raise ValueError(f"{source}: {unknown_name(o, k)} at ({xy_text([o.x, o.y])}) closes the tunnel: no way past "
                         f"it keeps d_s = {SAFETY_DISTANCE:g} m from everything with the hull turned any way "
                         f"and {margin:g} m to spare; leave a gap of at least {gap:.2f} m beside it")


def obstacle_name(obstacle: Obstacle, index: int) -> str:
    """Geom name of a known obstacle: `obstacle_<name>` or `obstacle_<index>`."""
    name = obstacle.name or str(index)
    return name if name.startswith(OBSTACLE_PREFIX) else OBSTACLE_PREFIX + name


def unknown_name(obstacle: Obstacle, index: int) -> str:
    """Geom name of an unknown obstacle: `unknown_<name>` or `unknown_<index>`."""
    name = obstacle.name or str(index)
    return name if name.startswith(UNKNOWN_PREFIX) else UNKNOWN_PREFIX + name


def mover_name(mover: MovingObstacle, index: int) -> str:
    """Body (and geom) name of a moving obstacle: `mover_<name>` or `mover_<index>`."""
    name = mover.name or str(index)
    return name if name.startswith(MOVER_PREFIX) else MOVER_PREFIX + name


# --- geom creation --------------------------------------------------------------------------------


def _fmt(*values: float) -> str:
    # 1e-7 rad of yaw error moves the far end of a 200 m wall by only 0.02 mm
    text = (f"{round(float(v), 7):.12g}" for v in values)
    return " ".join("0" if t == "-0" else t for t in text)


def wall_box(wall: WallSegment, thickness: float = WALL_THICKNESS) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre (x, y), half sizes (length, thickness) and yaw [rad] of the box behind a wall face."""
    d = wall.b - wall.a
    length = float(np.hypot(*d))
    u = d / length
    outward = np.array([-u[1], u[0]])
    centre = (wall.a + wall.b) / 2 + outward * thickness / 2 + u * (wall.extend_b - wall.extend_a) / 2
    half = np.array([(length + wall.extend_a + wall.extend_b) / 2, thickness / 2])
    return centre, half, math.atan2(u[1], u[0])


def tunnel_element(layout: TunnelLayout, obstacles: Sequence[Obstacle] = (),
                   movers: Sequence[MovingObstacle] = (), wall_thickness: float = WALL_THICKNESS,
                   name: str = "tunnel", command: str | None = None,
                   unknown: Sequence[Obstacle] = ()) -> ET.Element:
    """The arena MJCF element of a laid-out tunnel (angles in radians, as the vehicle's compiler).

    `unknown` obstacles are boxes `unknown_*` that the global path does not avoid (see `auv_mj.arenas.arena`).
    `command`, the command line that made it, is kept as `<text name="tunnel_command">`.
    """
    root = ET.Element("mujoco", model=_xml_text(name))
    default = ET.SubElement(root, "default")
    for cls, tag, attrs in (
        ("tunnel_wall", "geom", {"type": "box", "rgba": WALL_RGBA}),
        ("tunnel_obstacle", "geom", {"type": "box", "rgba": OBSTACLE_RGBA}),
        ("tunnel_mover", "geom", {"type": "cylinder", "rgba": MOVER_RGBA}),
        ("tunnel_path", "site", {"type": "sphere", "size": "0.5", "rgba": PATH_RGBA, "group": "3"}),
    ):
        ET.SubElement(ET.SubElement(default, "default", {"class": cls}), tag, attrs)
    world = ET.SubElement(root, "worldbody")
    for wall in layout.walls:
        centre, half, yaw = wall_box(wall, wall_thickness)
        ET.SubElement(world, "geom", {"name": wall.name, "class": "tunnel_wall", "pos": _fmt(*centre, 0),
                                      "size": _fmt(*half, WALL_HALF_HEIGHT), "euler": _fmt(0, 0, yaw)})
    boxes = [(obstacle_name(o, k), o) for k, o in enumerate(obstacles)]
    boxes += [(unknown_name(o, k), o) for k, o in enumerate(unknown)]
    for geom_name, obstacle in boxes:
        ET.SubElement(world, "geom", {
            "name": geom_name, "class": "tunnel_obstacle", "pos": _fmt(obstacle.x, obstacle.y, 0),
            "size": _fmt(obstacle.length / 2, obstacle.width / 2, WALL_HALF_HEIGHT),
            "euler": _fmt(0, 0, math.radians(obstacle.angle))})
    path = layout.path
    ET.SubElement(world, "site", {"name": "start", "type": "box", "size": "1.5 0.4 0.4",
                                  "rgba": "0.1 0.8 0.2 1", "pos": _fmt(*path[0], 0),
                                  "euler": _fmt(0, 0, layout.start_heading)})
    ET.SubElement(world, "site", {"name": "goal", "type": "sphere", "size": "1", "rgba": "0.9 0.8 0.1 1",
                                  "pos": _fmt(*path[-1], 0)})
    for k, p in enumerate(path):
        ET.SubElement(world, "site", {"name": f"path_{k}", "class": "tunnel_path", "pos": _fmt(*p, 0)})
    custom = ET.SubElement(root, "custom")
    ET.SubElement(custom, "numeric", {"name": "arena_bounds", "data": _fmt(*layout.bounds)})
    if command:
        ET.SubElement(custom, "text", {"name": "tunnel_command", "data": _xml_text(command)})
    for k, mover in enumerate(movers):
        body_name = mover_name(mover, k)
        body = ET.SubElement(world, "body", {"name": body_name, "mocap": "true",
                                             "pos": _fmt(mover.x0, mover.y0, 0)})
        ET.SubElement(body, "geom", {"name": body_name, "class": "tunnel_mover",
                                     "size": _fmt(mover.radius, WALL_HALF_HEIGHT)})
        ET.SubElement(custom, "numeric", {"name": body_name,
                                          "data": _fmt(mover.x0, mover.y0, mover.x1, mover.y1, mover.speed)})
    return root


def build_tunnel(centreline: Centreline | Sequence | np.ndarray, width: float | None = None, *,
                 closed: bool = False, smooth: int = 0, path_spacing: float = PATH_SPACING,
                 obstacles: Sequence[Obstacle] = (), movers: Sequence[MovingObstacle] = (),
                 wall_thickness: float = WALL_THICKNESS, end_clearance: float = END_CLEARANCE,
                 margin: float = BOUNDS_MARGIN, merge_tolerance: float = MERGE_TOLERANCE,
                 name: str = "tunnel", command: str | None = None,
                 unknown: Sequence[Obstacle] = ()) -> ET.Element:
    """Arena MJCF element of a tunnel along `centreline` (points [m], or a `Centreline`).

    `width` [m] is constant unless the centreline gives one per point. `closed` makes a loop (no end
    caps; the goal is one path spacing short of the start); `smooth` is the number of Chaikin rounds.
    An open tunnel runs `end_clearance` m past its ends. `obstacles` are known (the path keeps d_s from
    them), `unknown` ones are not (the path may run through them, but they must leave a way past:
    `check_unknown`). Raises ValueError naming the input on malformed or unsafe geometry (too narrow,
    too tight a bend, walls or centreline crossing, an obstacle on the path or closing the tunnel).
    """
    line = as_centreline(centreline)
    layout = layout_tunnel(line, width, closed=closed, smooth=smooth, path_spacing=path_spacing,
                           obstacles=obstacles, movers=movers, wall_thickness=wall_thickness,
                           end_clearance=end_clearance, margin=margin, merge_tolerance=merge_tolerance)
    check_unknown_spec(line.source, layout, obstacles, movers, unknown)
    check_unknown(layout, unknown, obstacles, wall_thickness, source=line.source)
    return tunnel_element(layout, obstacles, movers, wall_thickness, name, command, unknown)


def check_unknown_spec(source: str, layout: TunnelLayout, obstacles: Sequence[Obstacle],
                       movers: Sequence[MovingObstacle], unknown: Sequence[Obstacle]) -> None:
    """Unknown obstacles have names unique among all obstacles and movers, and lie inside the tunnel."""
    if unknown:
        check_names(source, obstacles, movers, unknown)
        check_inside(source, layout.walls, (), (), unknown)


def _xml_text(text: str) -> str:
    """`text` with the characters XML 1.0 cannot hold (control characters, lone surrogates) replaced by '?'."""
    return "".join(c if c in "\t\n\r" or (" " <= c <= "\ud7ff") or ("\ue000" <= c <= "\ufffd")
                   or ("\U00010000" <= c <= "\U0010ffff") else "?" for c in str(text))


def save(element: ET.Element, path: str | Path, header: str = HEADER) -> Path:
    """Writes an arena element as indented MJCF, atomically: a file there is either the old one or the new one;
    `header` is its first comment (what made it)."""
    path = Path(path)
    element = copy.deepcopy(element)
    ET.indent(element)
    text = ET.tostring(element, encoding="unicode")
    temporary = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        temporary.write_text(f"<!-- {header} -->\n{text}\n")
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path
