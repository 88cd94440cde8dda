"""Open-water arenas from a list of shapes: what `auv-mj tunnel` does for tunnels, `auv-mj arena` does for open water.

A layout (`OpenWater`) is a start pose, a goal, an optional global path, and shapes in the water:
- `Box` (centre, length along its angle, width, angle in degrees), `Cylinder` (centre, radius) and `Polygon`
  (its corners in order; concave ones are cut into triangles by Shapely's constrained Delaunay
  triangulation, because MuJoCo collides a mesh by its convex hull), each a static wall, obstacle or
  unknown obstacle (`role`; the names `wall_*`, `obstacle_*`, `unknown_*` of `auv_mj.arenas.arena`);
- `MoverPath`: a cylinder moving along its waypoints at its speed and back (the convention's
  `mover_*` mocap body and numeric).

`read_layout(path)` reads one from JSON or CSV (the formats are in `docs/arenas.md`), checked field by field
with the file, the shape and the field named; `OpenWater.element()` writes the arena MJCF (geom creation
kept apart from the reading and checking); `build_arena(path)` does both and then runs `check-arena`'s own
code (`auv_mj.arenas.arena_check`, with `--no-path` unless the layout has a path), so that a task takes
every arena it writes.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from shapely import affinity

from auv_mj import inputs
from auv_mj.arenas.arena import MAX_EXTENT, MAX_MOVER_SPEED, MAX_MOVER_WAYPOINTS, MOVER_PREFIX, vehicle_names
from auv_mj.arenas.tunnels import (
    MAX_MOVER_RADIUS,
    MAX_NAME_LENGTH,
    MAX_OBSTACLE_SIZE,
    MOVER_RGBA,
    OBSTACLE_RGBA,
    PATH_RGBA,
    WALL_HALF_HEIGHT,
    WALL_RGBA,
    WALL_THICKNESS,
)
from auv_mj.inputs import is_number

ROLES = {"obstacle": "obstacle_", "wall": "wall_", "unknown": "unknown_"}
"""A static shape's role -> its geom name prefix (the arena convention)."""
DEFAULT_MARGIN = 25.0
"""`arena_bounds`, when the layout gives none, is the bounding box of everything plus this [m]."""
MAX_SHAPES = 1000
"""Most shapes (static and moving) in one layout."""
MAX_POLYGON_POINTS = 200
"""Most corners of one polygon."""
MAX_PATH_POINTS = 1000
"""Most points of a layout's global path."""
JSON_KEYS = ("name", "bounds", "border", "start", "heading", "goal", "path", "shapes")
"""The keys a JSON layout may hold."""
SHAPE_FIELDS = {
    "box": ("type", "name", "role", "x", "y", "length", "width", "angle"),
    "cylinder": ("type", "name", "role", "x", "y", "radius"),
    "polygon": ("type", "name", "role", "points"),
    "mover": ("type", "name", "waypoints", "speed", "radius"),
}
"""The fields each shape type may have."""
HEADER = ("Open-water arena made by auv-mj arena (auv_mj/arenas/layout.py), arena convention of "
          "auv_mj/arenas/arena.py")
"""The first comment of a written arena (no double hyphen: XML comments may not hold one)."""


def _number(value, what: str, low: float = -MAX_EXTENT, high: float = MAX_EXTENT, low_open: bool = False) -> float:
    """A finite real number in [low, high] (`low_open`: (low, high]); ValueError naming `what` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not (low < value if low_open else low <= value) or value > high:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}]"
        raise ValueError(f"{what} = {str(value)[:40]!r} must be a finite number in {interval}")
    return float(value)


def _point(value, what: str) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"{what} = {str(value)[:60]!r} must be a point [x, y]")
    return np.array([_number(value[0], f"{what} x"), _number(value[1], f"{what} y")])


def _points(value, what: str, least: int, most: int) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or not least <= len(value) <= most:
        raise ValueError(f"{what} must be a list of {least} to {most} points [x, y], got {str(value)[:60]!r}")
    return np.array([_point(p, f"{what}[{i}]") for i, p in enumerate(value)]).reshape(-1, 2)


def _name(value, what: str) -> str:
    if value is None or value == "":
        return ""
    if not isinstance(value, str) or len(value) > MAX_NAME_LENGTH or not value.isascii() \
            or not value.replace("_", "").isalnum():
        raise ValueError(f"{what}: name {str(value)[:80]!r} may hold only letters, digits and _ "
                         f"(at most {MAX_NAME_LENGTH})")
    if value in vehicle_names():
        raise ValueError(f"{what}: name {value!r} reuses a name of the vehicle model (auv, hull, x, y, yaw, "
                         "sonar_*, ...): name it otherwise")
    return value


def _role(value, what: str) -> str:
    if value is None:
        return "obstacle"
    if value not in ROLES:
        raise ValueError(f"{what}: role {str(value)[:40]!r} must be one of {', '.join(ROLES)}"
                         f"{inputs.did_you_mean(value, ROLES)}")
    return value


@dataclass(frozen=True)
class Box:
    """A static box: centre (x, y) [m], `length` along `angle` [deg] and `width` across it [m]."""

    x: float
    y: float
    length: float
    width: float
    angle: float = 0.0
    name: str = ""
    role: str = "obstacle"

    def outline(self) -> shapely.Polygon:
        """Its footprint seen from above."""
        box = shapely.box(-self.length / 2, -self.width / 2, self.length / 2, self.width / 2)
        return affinity.translate(affinity.rotate(box, self.angle), self.x, self.y)


@dataclass(frozen=True)
class Cylinder:
    """A static upright cylinder: centre (x, y) and `radius` [m]."""

    x: float
    y: float
    radius: float
    name: str = ""
    role: str = "obstacle"

    def outline(self) -> shapely.Polygon:
        """Its footprint seen from above."""
        return shapely.Point(self.x, self.y).buffer(self.radius, quad_segs=16)


@dataclass(frozen=True)
class Polygon:
    """A static prism over a simple polygon: its corners (n, 2) [m] in order, either way round."""

    points: np.ndarray = field(repr=False)
    name: str = ""
    role: str = "obstacle"

    def outline(self) -> shapely.Polygon:
        """Its footprint seen from above."""
        return shapely.Polygon(self.points)

    def pieces(self) -> list[np.ndarray]:
        """Convex pieces (each (k, 2), counter-clockwise) that make up the polygon: itself when convex, else
        the triangles of its constrained Delaunay triangulation (MuJoCo collides a mesh by its convex hull)."""
        outline = shapely.orient_polygons(self.outline())
        if math.isclose(outline.convex_hull.area, outline.area, rel_tol=1e-9):
            return [np.asarray(outline.exterior.coords)[:-1]]
        triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(outline))
        return [np.asarray(shapely.orient_polygons(t).exterior.coords)[:-1] for t in triangles]


@dataclass(frozen=True)
class MoverPath:
    """A moving cylinder of `radius` [m] going through `waypoints` (n, 2) [m] at `speed` [m/s], then back."""

    waypoints: np.ndarray = field(repr=False)
    speed: float
    radius: float
    name: str = ""


Shape = Box | Cylinder | Polygon


@dataclass(frozen=True)
class OpenWater:
    """An open-water layout: start pose, goal, optional global path, static shapes, movers and the map."""

    start: np.ndarray
    goal: np.ndarray
    heading: float
    """Initial heading [rad]."""
    shapes: tuple[Shape, ...] = ()
    movers: tuple[MoverPath, ...] = ()
    path: np.ndarray | None = None
    """The global path (n, 2) [m] (`path_*` sites), or None."""
    bounds: tuple[float, float, float, float] | None = None
    """(xmin, ymin, xmax, ymax) [m]; None: everything's bounding box plus DEFAULT_MARGIN."""
    border: bool = False
    """Walls along the map's edges."""
    name: str = "open_water"
    source: str = "<layout>"

    def map_bounds(self) -> tuple[float, float, float, float]:
        """`arena_bounds`: as given, or the bounding box of everything plus DEFAULT_MARGIN."""
        if self.bounds is not None:
            return self.bounds
        points = [self.start[None], self.goal[None]]
        points += [np.asarray(s.outline().exterior.coords) for s in self.shapes]
        points += [np.vstack([m.waypoints - m.radius, m.waypoints + m.radius]) for m in self.movers]
        if self.path is not None:
            points.append(self.path)
        every = np.vstack(points)
        low, high = every.min(axis=0) - DEFAULT_MARGIN, every.max(axis=0) + DEFAULT_MARGIN
        return float(low[0]), float(low[1]), float(high[0]), float(high[1])

    def geom_names(self) -> list[str]:
        """Names of the static geoms, in order (a polygon cut in pieces is NAME_0, NAME_1, ...)."""
        names = []
        for k, shape in enumerate(self.shapes):
            base = ROLES[shape.role] + (shape.name or str(k))
            names += ([f"{base}_{i}" for i in range(len(shape.pieces()))]
                      if isinstance(shape, Polygon) and len(shape.pieces()) > 1 else [base])
        if self.border:
            names += [f"wall_border_{side}" for side in ("south", "east", "north", "west")]
        return names

    def mover_names(self) -> list[str]:
        """Body (and geom, numeric) names of the movers."""
        return [MOVER_PREFIX + (m.name or str(k)) for k, m in enumerate(self.movers)]

    def element(self, command: str | None = None) -> ET.Element:
        """The arena MJCF element (angles in radians, as the vehicle's compiler reads them)."""
        root = ET.Element("mujoco", model=self.name)
        asset = ET.SubElement(root, "asset")
        default = ET.SubElement(root, "default")
        for cls, tag, attrs in (("arena_wall", "geom", {"rgba": WALL_RGBA}),
                                ("arena_obstacle", "geom", {"rgba": OBSTACLE_RGBA}),
                                ("arena_mover", "geom", {"type": "cylinder", "rgba": MOVER_RGBA}),
                                ("arena_path", "site", {"type": "sphere", "size": "0.5", "rgba": PATH_RGBA,
                                                        "group": "3"})):
            ET.SubElement(ET.SubElement(default, "default", {"class": cls}), tag, attrs)
        world = ET.SubElement(root, "worldbody")
        names = iter(self.geom_names())
        for shape in self.shapes:
            cls = "arena_wall" if shape.role == "wall" else "arena_obstacle"
            if isinstance(shape, Box):
                ET.SubElement(world, "geom", {"name": next(names), "class": cls, "type": "box",
                                              "pos": _fmt(shape.x, shape.y, 0),
                                              "size": _fmt(shape.length / 2, shape.width / 2, WALL_HALF_HEIGHT),
                                              "euler": _fmt(0, 0, math.radians(shape.angle))})
            elif isinstance(shape, Cylinder):
                ET.SubElement(world, "geom", {"name": next(names), "class": cls, "type": "cylinder",
                                              "pos": _fmt(shape.x, shape.y, 0),
                                              "size": _fmt(shape.radius, WALL_HALF_HEIGHT)})
            else:
                for piece in shape.pieces():
                    name = next(names)
                    prism = np.vstack([np.column_stack([piece, np.full(len(piece), z)])
                                       for z in (-WALL_HALF_HEIGHT, WALL_HALF_HEIGHT)])
                    ET.SubElement(asset, "mesh", {"name": name, "vertex": _fmt(*prism.ravel())})
                    ET.SubElement(world, "geom", {"name": name, "class": cls, "type": "mesh", "mesh": name})
        if self.border:
            xmin, ymin, xmax, ymax = self.map_bounds()
            half = WALL_THICKNESS / 2
            for side, centre, size in (("south", ((xmin + xmax) / 2, ymin), ((xmax - xmin) / 2 + half, half)),
                                       ("east", (xmax, (ymin + ymax) / 2), (half, (ymax - ymin) / 2 + half)),
                                       ("north", ((xmin + xmax) / 2, ymax), ((xmax - xmin) / 2 + half, half)),
                                       ("west", (xmin, (ymin + ymax) / 2), (half, (ymax - ymin) / 2 + half))):
                ET.SubElement(world, "geom", {"name": f"wall_border_{side}", "class": "arena_wall", "type": "box",
                                              "pos": _fmt(*centre, 0), "size": _fmt(*size, WALL_HALF_HEIGHT)})
        ET.SubElement(world, "site", {"name": "start", "type": "box", "size": "1.5 0.4 0.4", "rgba": "0.1 0.8 0.2 1",
                                      "pos": _fmt(*self.start, 0), "euler": _fmt(0, 0, self.heading)})
        ET.SubElement(world, "site", {"name": "goal", "type": "sphere", "size": "1", "rgba": "0.9 0.8 0.1 1",
                                      "pos": _fmt(*self.goal, 0)})
        for k, point in enumerate(() if self.path is None else self.path):
            ET.SubElement(world, "site", {"name": f"path_{k}", "class": "arena_path", "pos": _fmt(*point, 0)})
        custom = ET.SubElement(root, "custom")
        ET.SubElement(custom, "numeric", {"name": "arena_bounds", "data": _fmt(*self.map_bounds())})
        if command:
            ET.SubElement(custom, "text", {"name": "arena_command", "data": " ".join(command.split())})
        for name, mover in zip(self.mover_names(), self.movers, strict=True):
            body = ET.SubElement(world, "body", {"name": name, "mocap": "true", "pos": _fmt(*mover.waypoints[0], 0)})
            ET.SubElement(body, "geom", {"name": name, "class": "arena_mover",
                                         "size": _fmt(mover.radius, WALL_HALF_HEIGHT)})
            ET.SubElement(custom, "numeric", {"name": name, "data": _fmt(*mover.waypoints.ravel(), mover.speed)})
        if len(asset) == 0:
            root.remove(asset)
        return root


def _fmt(*values: float) -> str:
    return " ".join(f"{v:.6g}" for v in values)


# --- reading and checking ---------------------------------------------------------------------------------


def make_shape(fields: dict, what: str) -> Shape | MoverPath:
    """A shape from its fields (the JSON object form), each checked; ValueError naming `what` and the field."""
    if not isinstance(fields, dict):
        raise ValueError(f"{what} must be an object with a \"type\", got {str(fields)[:60]!r}")
    kind = fields.get("type")
    if kind not in SHAPE_FIELDS:
        raise ValueError(f"{what}: type {str(kind)[:40]!r} must be one of {', '.join(SHAPE_FIELDS)}"
                         f"{inputs.did_you_mean(kind, SHAPE_FIELDS)}")
    unknown = sorted(set(fields) - set(SHAPE_FIELDS[kind]))
    if unknown:
        raise ValueError(f"{what}: a {kind} has no field(s) {', '.join(map(str, unknown))[:80]}; it takes "
                         f"{', '.join(SHAPE_FIELDS[kind][1:])}")
    missing = [f for f in SHAPE_FIELDS[kind][1:] if f not in fields and f not in ("name", "role", "angle")]
    if missing:
        raise ValueError(f"{what}: a {kind} needs {', '.join(missing)}")
    name = _name(fields.get("name"), what)
    what = f"{what} ({kind} {name})" if name else f"{what} ({kind})"
    if kind == "mover":
        return MoverPath(_points(fields["waypoints"], f"{what}: waypoints", 2, MAX_MOVER_WAYPOINTS),
                         _number(fields["speed"], f"{what}: speed", 0.0, MAX_MOVER_SPEED),
                         _number(fields["radius"], f"{what}: radius", 0.0, MAX_MOVER_RADIUS, low_open=True), name)
    role = _role(fields.get("role"), what)
    if kind == "box":
        return Box(_number(fields["x"], f"{what}: x"), _number(fields["y"], f"{what}: y"),
                   _number(fields["length"], f"{what}: length", 0.0, MAX_OBSTACLE_SIZE, low_open=True),
                   _number(fields["width"], f"{what}: width", 0.0, MAX_OBSTACLE_SIZE, low_open=True),
                   _number(fields.get("angle", 0.0), f"{what}: angle", -360.0, 360.0), name, role)
    if kind == "cylinder":
        return Cylinder(_number(fields["x"], f"{what}: x"), _number(fields["y"], f"{what}: y"),
                        _number(fields["radius"], f"{what}: radius", 0.0, MAX_OBSTACLE_SIZE, low_open=True),
                        name, role)
    points = _points(fields["points"], f"{what}: points", 3, MAX_POLYGON_POINTS)
    outline = shapely.Polygon(points)
    if not outline.is_valid or outline.area <= 0:
        raise ValueError(f"{what}: points must outline a simple polygon (no crossing edges, an area above 0): "
                         f"{shapely.is_valid_reason(outline)}")
    size = np.ptp(points, axis=0)
    if np.any(size > MAX_OBSTACLE_SIZE):
        raise ValueError(f"{what}: spans {size[0]:.0f} m x {size[1]:.0f} m; at most {MAX_OBSTACLE_SIZE:g} m")
    return Polygon(points, name, role)


def make_layout(data: dict, source: str = "<layout>", name: str | None = None) -> OpenWater:
    """A checked layout from the JSON object form (`docs/arenas.md`); ValueError naming `source` and the field."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a layout is a JSON object with \"start\", \"goal\" and \"shapes\"")
    unknown = sorted(set(data) - set(JSON_KEYS))
    if unknown:
        raise ValueError(f"{source}: unknown key(s) {', '.join(map(str, unknown))[:80]}; a layout holds "
                         f"{', '.join(JSON_KEYS)}")
    for key in ("start", "goal"):
        if key not in data:
            raise ValueError(f"{source}: no \"{key}\": [x, y]")
    start, goal = _point(data["start"], f"{source}: start"), _point(data["goal"], f"{source}: goal")
    path = None if data.get("path") is None else _points(data["path"], f"{source}: path", 2, MAX_PATH_POINTS)
    aim = path[1] if path is not None and np.hypot(*(path[1] - path[0])) > 0 else goal
    heading = (math.radians(_number(data["heading"], f"{source}: heading", -360.0, 360.0)) if "heading" in data
               else math.atan2(aim[1] - start[1], aim[0] - start[0]))
    shapes = data.get("shapes", [])
    if not isinstance(shapes, list) or len(shapes) > MAX_SHAPES:
        raise ValueError(f"{source}: \"shapes\" must be a list of at most {MAX_SHAPES} shapes")
    made = [make_shape(s, f"{source}: shape {k}") for k, s in enumerate(shapes)]
    bounds = None
    if data.get("bounds") is not None:
        b = data["bounds"]
        if not isinstance(b, (list, tuple)) or len(b) != 4:
            raise ValueError(f"{source}: bounds must be [xmin, ymin, xmax, ymax], got {str(b)[:60]!r}")
        bounds = tuple(_number(v, f"{source}: bounds[{i}]") for i, v in enumerate(b))
        if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
            raise ValueError(f"{source}: bounds {list(bounds)} is empty (needs xmin < xmax, ymin < ymax)")
    border = data.get("border", False)
    if not isinstance(border, bool):
        raise ValueError(f"{source}: border must be true or false, got {str(border)[:40]!r}")
    layout = OpenWater(start, goal, heading, tuple(s for s in made if not isinstance(s, MoverPath)),
                       tuple(s for s in made if isinstance(s, MoverPath)), path, bounds, border,
                       _name(name or data.get("name") or "open_water", f"{source}: name"), source)
    check_layout(layout)
    return layout


def check_layout(layout: OpenWater) -> None:
    """What the arena check cannot name by the shape: unique names, start and goal in open water, and
    everything inside the map. ValueError naming the layout's source and the shape."""
    source = layout.source
    names = layout.geom_names() + layout.mover_names()
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"{source}: shapes need unique names; {', '.join(repeated[:5])} is given twice")
    for label, point in (("start", layout.start), ("goal", layout.goal)):
        for k, shape in enumerate(layout.shapes):
            if shape.outline().intersects(shapely.Point(*point)):
                raise ValueError(f"{source}: the {label} ({point[0]:g}, {point[1]:g}) lies inside shape {k} "
                                 f"({ROLES[shape.role]}{shape.name or k}): it must be in open water")
    xmin, ymin, xmax, ymax = layout.map_bounds()
    points = [("start", layout.start), ("goal", layout.goal)]
    points += [(f"path[{i}]", p) for i, p in enumerate(() if layout.path is None else layout.path)]
    points += [(f"{n} waypoint {i}", p) for n, m in zip(layout.mover_names(), layout.movers, strict=True)
               for i, p in enumerate(m.waypoints)]
    for label, p in points:
        if not (xmin <= p[0] <= xmax and ymin <= p[1] <= ymax):
            raise ValueError(f"{source}: {label} ({p[0]:g}, {p[1]:g}) is outside the bounds "
                             f"[{xmin:g}, {ymin:g}, {xmax:g}, {ymax:g}]")


CSV_ROWS = {
    "start": "start,x,y[,heading]", "goal": "goal,x,y", "bounds": "bounds,xmin,ymin,xmax,ymax", "path": "path,x,y",
    "border": "border", "box": "box,NAME,x,y,length,width[,angle[,role]]",
    "cylinder": "cylinder,NAME,x,y,radius[,role]", "polygon": "polygon,NAME,x1,y1,x2,y2,x3,y3[,...]",
    "mover": "mover,NAME,speed,radius,x1,y1,x2,y2[,...]",
}
"""The rows of a CSV layout, by their first cell (NAME may be empty; `#` starts a comment)."""


def _csv_layout(text: str, source: str) -> dict:
    """The JSON object form of a CSV layout (rows of CSV_ROWS); ValueError naming the row and cell."""
    data: dict = {"shapes": []}
    table = inputs.csv_rows(text, source, "e.g. start,x,y or box,NAME,x,y,length,width")
    for lineno, cells in enumerate(table, start=1):
        cells = _before_comment([c.strip() for c in cells])
        if not any(cells):
            continue
        kind, rest = cells[0].lower(), cells[1:]
        where = f"{source}: row {lineno}"
        if kind not in CSV_ROWS:
            raise ValueError(f"{where}: {cells[0][:40]!r} is not a row type; rows are {', '.join(CSV_ROWS)}")
        named = kind in ("box", "cylinder", "polygon", "mover")
        name, numbers = (rest[0] if rest else "", rest[1:]) if named else ("", rest)
        role = None
        if kind in ("box", "cylinder") and numbers and not is_number(numbers[-1]):
            role, numbers = numbers[-1], numbers[:-1]
        values = []
        for column, cell in enumerate(numbers, start=3 if named else 2):
            if not is_number(cell):
                raise ValueError(f"{where}, column {column}: {cell[:40]!r} is not a number (a row is "
                                 f"{CSV_ROWS[kind]})")
            values.append(float(cell))
        counts = {"start": (2, 3), "goal": (2, 2), "bounds": (4, 4), "path": (2, 2), "border": (0, 0),
                  "box": (4, 5), "cylinder": (3, 3), "polygon": (6, 2 * MAX_POLYGON_POINTS),
                  "mover": (6, 2 + 2 * MAX_MOVER_WAYPOINTS)}[kind]
        if not counts[0] <= len(values) <= counts[1] or (kind in ("polygon", "mover") and len(values) % 2):
            raise ValueError(f"{where}: {len(values)} numbers; a row is {CSV_ROWS[kind]}")
        if kind in ("start", "goal", "bounds", "border") and kind in data:
            raise ValueError(f"{where}: a second {kind} row")
        if kind == "start":
            data["start"] = values[:2]
            if len(values) == 3:
                data["heading"] = values[2]
        elif kind in ("goal", "bounds"):
            data[kind] = values
        elif kind == "border":
            data["border"] = True
        elif kind == "path":
            data.setdefault("path", []).append(values)
        elif kind == "box":
            shape = dict(zip(("x", "y", "length", "width", "angle"), values, strict=False))
            data["shapes"].append({"type": "box", "name": name, **shape, **({"role": role} if role else {})})
        elif kind == "cylinder":
            shape = dict(zip(("x", "y", "radius"), values, strict=True))
            data["shapes"].append({"type": "cylinder", "name": name, **shape, **({"role": role} if role else {})})
        elif kind == "polygon":
            data["shapes"].append({"type": "polygon", "name": name, "points": _pairs(values)})
        else:
            data["shapes"].append({"type": "mover", "name": name, "speed": values[0], "radius": values[1],
                                   "waypoints": _pairs(values[2:])})
    return data


def _before_comment(cells: list[str]) -> list[str]:
    """The cells of a CSV row before a `#` comment (a whole-line one, or one after the values)."""
    for i, cell in enumerate(cells):
        if "#" in cell:
            head = cell[:cell.index("#")].strip()
            return cells[:i] + ([head] if head else [])
    return cells


def _pairs(values: Sequence[float]) -> list[list[float]]:
    return [list(values[i:i + 2]) for i in range(0, len(values), 2)]


def read_layout(path: str | Path, name: str | None = None) -> OpenWater:
    """A checked layout from a JSON (`.json`, or text starting with `{`) or CSV file, read within the bounds of
    `auv_mj.inputs`; ValueError naming the file, the shape or row, and the field."""
    path = Path(path)
    text = inputs.read_text(path, "the arena layout")
    source = inputs.source_name(path)
    if path.suffix.lower() == ".json" or text.lstrip().startswith("{"):
        inputs.check_json_depth(text, source)
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise ValueError(f"{source}: not valid JSON: {e}") from None
    else:
        data = _csv_layout(text, source)
    return make_layout(data, source, name)
