"""Tube arenas for the 6-DOF vehicle (issue 32): a pipe along an x, y, z centreline, and open water with a seabed.

A tube's wall is a ring of capsules ("staves") along each centreline segment, sized to the tube: staves of
`stave_radius_for(radius)` (0.6 m, or a tenth of a wide tube's radius), as many round the ring as keep
neighbouring staves' axes within STAVE_OVERLAP of a stave's diameter (`staves_for`, from the diameter and the
sharpest turn of the centreline), so that a tube from 2 to 100 m across has a closed wall of tens of staves round.
Each stave lies on its segment's cylinder and is cut by the planes bisecting the turns at its ends (a mitre
joint), its ring frame carried from segment to segment by parallel transport (no twist): consecutive staves meet
end to end round bends, and the free radius is `radius` everywhere. `check_tube` measures the largest gap
between neighbouring staves (`wall_gap`), refuses a bend so tight for the tube's width that the wall would fold,
and `tube_report` (`auv-mj check-arena`) casts rays across the tube from the centreline to find any way out,
whoever wrote the wall. Rays of the sonar fan and the hull's contacts see the wall as it is. The centreline lies
in the arena's `tube_centreline` numeric (x y z triples), the radius in `tube_radius`, the staves in
`tube_stave_radius` and `tube_staves`.

A tube may hold rocks (`TubeObstacle`, spheres `obstacle_NAME`) and movers (`TubeMover`, mocap spheres
`mover_NAME` going back and forth, their tracks in `mover3d_NAME` numerics); `check_items` refuses one outside
the tube, one that leaves less than MIN_PASSAGE to get past, or one within END_CLEARANCE of the start or goal.
`read_tube` reads a tube from a CSV of x, y, z rows or a JSON object with its obstacles and movers.

Procedural tubes (`random_tube`) climb, dive and bend within the vehicle's envelope: bends no tighter than
MIN_BEND_RADIUS, slopes no steeper than MAX_SLOPE, the whole tube below MIN_COVER of water.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from auv_mj.arenas.arena3d import arena_root, seabed
from auv_mj.inputs import check_numbers, csv_rows, did_you_mean, is_number, is_real, read_text

N_STAVES = 20
"""Staves round the ring of a tube written before the ring was sized to the tube (no `tube_staves` numeric)."""
STAVE_RADIUS = 0.6
"""Thinnest stave capsule [m]: the radius of each stave of a narrow tube."""
STAVE_SHARE = 0.1
"""A wide tube's staves are this share of its inner radius thick (radius [m]), so that a 100 m tube needs tens of
staves round its ring, not hundreds."""
STAVE_OVERLAP = 0.75
"""Neighbouring staves' axes are at most this share of a stave's diameter apart anywhere along the tube: where
two staves meet the wall is still 2 sqrt(1 - 0.75^2) = 1.3 stave radii thick."""
MIN_STAVES = 12
"""Fewest staves round a ring."""
MAX_WALL_GEOMS = 40_000
"""Most staves a tube's wall may have (segments x staves round the ring)."""
TUBE_RADIUS = 3.0
"""Default inner free radius of a tube [m]: about 15 REMUS hull radii, room to correct a depth error."""
MIN_RADIUS = 1.0
"""Narrowest tube `check_tube` accepts [m]: the hull's half length (0.67 m) plus a margin."""
MAX_RADIUS = 50.0
"""Widest tube [m]: 100 m across, as wide as the widest planar tunnels."""
MIN_BEND_RADIUS = 20.0
"""Tightest bend of a tube's centreline [m]: the REMUS turns on about 15 m at full rudder and 1.5 m/s."""
MAX_SLOPE = math.radians(12.0)
"""Steepest climb or dive of a centreline segment [rad]: below the classical executor's 14 deg pitch limit
(`auv_mj.control.depth_heading.DepthHeadingGains.max_pitch`), so that a vehicle can follow it with margin."""
MIN_COVER = 2.0
"""Water above the top of a tube [m]."""
SEGMENT_LENGTH = 4.0
"""Length of a procedural tube's segments [m]."""
SLOPE_CHANGE = 0.08
"""Largest change of a procedural tube's slope from one segment to the next [rad]."""
LEVEL_OUT = 6.0
"""A procedural tube closer than this [m] to its cover stops climbing."""
RANDOM_LENGTH = (80.0, 160.0)
RANDOM_DEPTH = (15.0, 40.0)
MAX_POINTS = 2000
"""Most centreline points a tube file may hold."""
MAX_EXTENT = 10_000.0
"""Largest |coordinate| of a centreline [m]."""


def stave_radius_for(radius: float) -> float:
    """The stave radius [m] of a tube of inner radius `radius`: STAVE_RADIUS, or STAVE_SHARE of a wide tube's."""
    return max(STAVE_RADIUS, STAVE_SHARE * float(radius))


def vertex_turns(centreline: np.ndarray) -> np.ndarray:
    """(K,) the angle [rad] the centreline turns through at each point (0 at both ends)."""
    directions = _directions(centreline)
    turns = np.zeros(len(centreline))
    if len(directions) > 1:
        turns[1:-1] = np.arccos(np.clip(np.einsum("ij,ij->i", directions[:-1], directions[1:]), -1.0, 1.0))
    return turns


def staves_for(radius: float, stave_radius: float, turn: float = 0.0) -> int:
    """Staves round the ring that keep neighbouring staves' axes within STAVE_OVERLAP of a stave's diameter.

    A ring is a circle of radius `radius + stave_radius` where the tube runs straight; at a point where the
    centreline turns through `turn` the ring is the mitre ellipse, stretched by 1 / cos(turn / 2) across the bend,
    and so are the gaps between staves there."""
    wall = radius + stave_radius
    reach = STAVE_OVERLAP * stave_radius * math.cos(0.5 * min(turn, 0.5 * math.pi))
    return max(MIN_STAVES, math.ceil(math.pi / math.asin(min(1.0, reach / wall))))


def _directions(points: np.ndarray) -> np.ndarray:
    segments = np.diff(np.asarray(points, dtype=float), axis=0)
    lengths = np.linalg.norm(segments, axis=1, keepdims=True)
    return segments / np.maximum(lengths, 1e-12)


def _rotate(v: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`v` turned by the least rotation taking unit vector `a` to unit vector `b` (Rodrigues)."""
    axis = np.cross(a, b)
    sin, cos = float(np.linalg.norm(axis)), float(a @ b)
    if sin < 1e-12:
        return v.copy()
    axis /= sin
    return v * cos + np.cross(axis, v) * sin + axis * (axis @ v) * (1.0 - cos)


@dataclass(frozen=True)
class Tube:
    """A tube: its centreline (K, 3) [m, world, z up], inner free radius [m], and its wall's staves (their
    radius [m] and number round the ring; by default sized to the tube: `stave_radius_for`, `staves_for`)."""

    centreline: np.ndarray
    radius: float = TUBE_RADIUS
    stave_radius: float | None = None
    staves: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "centreline", np.asarray(self.centreline, dtype=float).reshape(-1, 3))
        if self.stave_radius is None:
            object.__setattr__(self, "stave_radius", stave_radius_for(self.radius))
        if self.staves is None:
            turn = float(np.max(vertex_turns(self.centreline))) if len(self.centreline) > 2 else 0.0
            object.__setattr__(self, "staves", staves_for(self.radius, self.stave_radius, turn))

    @property
    def wall_radius(self) -> float:
        """Distance of the staves' axes from the centreline where it runs straight [m]."""
        return self.radius + self.stave_radius

    def start_heading(self) -> float:
        """Heading of the first segment [rad]."""
        d = self.centreline[1] - self.centreline[0]
        return math.atan2(d[1], d[0])

    def length(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self.centreline, axis=0), axis=1)))

    def frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(directions, normals, binormals), each (K - 1, 3): an orthonormal frame per segment, the normal carried
        from segment to segment by the least rotation (parallel transport: the ring does not twist)."""
        directions = _directions(self.centreline)
        seed = np.array([0.0, 0.0, 1.0]) if abs(directions[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        normal = seed - directions[0] * (seed @ directions[0])
        normals = np.empty_like(directions)
        for i, d in enumerate(directions):
            if i:
                normal = _rotate(normal, directions[i - 1], d)
                normal -= d * (normal @ d)  # keep it exact against rounding
            normal /= np.linalg.norm(normal)
            normals[i] = normal
        return directions, normals, np.cross(directions, normals)

    def stave_ends(self) -> np.ndarray:
        """(K - 1, staves, 2, 3): each segment's staves, from end to end.

        Stave k of a segment is the line `wall_radius` from the segment's axis at angle 2 pi k / staves in the
        segment's frame, cut by the planes that bisect the turns at its two ends (a mitre joint; the end planes
        are square to the first and last segments). Neighbouring segments' staves k meet on the bisecting plane,
        so the wall has no gap round a bend, and every stave lies on its segment's cylinder, so the free radius
        is `radius` everywhere."""
        points = self.centreline
        directions, normals, binormals = self.frames()
        planes = np.vstack([directions[:1], directions[:-1] + directions[1:], directions[-1:]])
        planes /= np.linalg.norm(planes, axis=1, keepdims=True)
        angles = 2.0 * math.pi * np.arange(self.staves) / self.staves
        out = np.empty((len(directions), self.staves, 2, 3))
        for i, d in enumerate(directions):
            offsets = self.wall_radius * (np.cos(angles)[:, None] * normals[i] + np.sin(angles)[:, None] * binormals[i])
            base = points[i] + offsets
            for end, j in enumerate((i, i + 1)):
                s = ((points[j] - base) @ planes[j]) / (d @ planes[j])
                out[i, :, end] = base + s[:, None] * d
        return out

    def rings(self) -> np.ndarray:
        """(K, staves, 3) where the staves meet at each centreline point (the mitre ellipses)."""
        ends = self.stave_ends()
        return np.concatenate([ends[:, :, 0], ends[-1:, :, 1]])


def tube_elements(tube: Tube, name: str = "tube") -> list[ET.Element]:
    """The staves (geoms named wall_<name>_<segment>_<stave>) and start/goal sites of `tube`."""
    ends = tube.stave_ends()
    elements = []
    for i in range(len(ends)):
        for k in range(tube.staves):
            elements.append(ET.Element("geom", name=f"wall_{name}_{i}_{k}", type="capsule",
                                       fromto=" ".join(f"{v:.8g}" for v in ends[i, k].ravel()),
                                       size=f"{tube.stave_radius:g}", rgba="0.5 0.55 0.6 0.35"))
    for site, point in (("start", tube.centreline[0]), ("goal", tube.centreline[-1])):
        elements.append(ET.Element("site", name=site, pos=" ".join(f"{v:.6g}" for v in point), size="0.3",
                                   rgba="0 1 0 0.5" if site == "start" else "1 0 0 0.5"))
    return elements


MIN_PASSAGE = 2.0
"""Narrowest way past an obstacle or mover in a tube [m]: ten hull diameters, room for the vehicle to get by."""
END_CLEARANCE = 10.0
"""Obstacles and movers keep this far [m] from a tube's start and goal."""
MAX_MOVER_SPEED = 2.0
"""Fastest mover in a tube [m/s]: the vehicle's top speed."""
MAX_ITEMS = 100
"""Most obstacles, and most movers, in a tube."""
MOVER_NUMERIC = "mover3d_"
"""A mover's track in a tube arena: `<numeric name="mover3d_NAME" data="x0 y0 z0 x1 y1 z1 speed">`; its body is
the mocap body `mover_NAME`."""


def _checked_name(name, what: str) -> str:
    if not isinstance(name, str) or len(name) > 64 or not name.isascii() or (
            name and not name.replace("_", "").isalnum()):
        raise ValueError(f"{what}: name {name!r:.80} may hold only letters, digits and _ (at most 64)")
    return name


def _spec(text: str, option: str, form: str, count: int) -> tuple[list[float], str]:
    """The numbers and optional trailing name of a comma-separated `option` value."""
    cells = [c.strip() for c in str(text).split(",")]
    name = cells.pop() if len(cells) == count + 1 and not is_number(cells[-1], finite=True) else ""
    if len(cells) != count or not all(is_number(c, finite=True) for c in cells):
        raise ValueError(f"{option} {text!r:.80}: expected {form}")
    return [float(c) for c in cells], name


@dataclass(frozen=True)
class TubeObstacle:
    """A rock in a tube: a sphere of `radius` [m] centred at (x, y, z) [m, world, z up]."""

    x: float
    y: float
    z: float
    radius: float
    name: str = ""

    def __post_init__(self):
        what = f"obstacle {self.name}".strip()
        _checked_name(self.name, what)
        check_numbers(what, (("x", self.x, -MAX_EXTENT, MAX_EXTENT), ("y", self.y, -MAX_EXTENT, MAX_EXTENT),
                        ("z", self.z, -MAX_EXTENT, MAX_EXTENT), ("radius", self.radius, 0.05, MAX_RADIUS)))

    @property
    def centre(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])

    @classmethod
    def parse(cls, text: str) -> TubeObstacle:
        """From "x,y,z,radius[,name]" (the `--obstacle` option of `auv-mj tunnel --tube`)."""
        numbers, name = _spec(text, "--obstacle", "x,y,z,radius[,name] for a tube", 4)
        try:
            return cls(*numbers, name=name)
        except ValueError as e:
            raise ValueError(f"--obstacle {text!r}: {e}") from None


@dataclass(frozen=True)
class TubeMover:
    """A sphere of `radius` [m] going back and forth from `start` to `end` [m, world] at `speed` [m/s]."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    speed: float
    radius: float
    name: str = ""

    def __post_init__(self):
        what = f"mover {self.name}".strip()
        _checked_name(self.name, what)
        if not (len(self.start) == 3 and len(self.end) == 3):
            raise ValueError(f"{what}: start and end must be x, y, z points")
        check_numbers(what, tuple((f"{end}.{axis}", v, -MAX_EXTENT, MAX_EXTENT)
                             for end, point in (("start", self.start), ("end", self.end))
                             for axis, v in zip("xyz", point, strict=True))
                 + (("speed", self.speed, 0.0, MAX_MOVER_SPEED), ("radius", self.radius, 0.05, MAX_RADIUS)))

    @classmethod
    def parse(cls, text: str) -> TubeMover:
        """From "x0,y0,z0,x1,y1,z1,speed,radius[,name]" (the `--mover` option of `auv-mj tunnel --tube`)."""
        numbers, name = _spec(text, "--mover", "x0,y0,z0,x1,y1,z1,speed,radius[,name] for a tube", 8)
        try:
            return cls(tuple(numbers[:3]), tuple(numbers[3:6]), numbers[6], numbers[7], name=name)
        except ValueError as e:
            raise ValueError(f"--mover {text!r}: {e}") from None

    def position(self, time: float) -> np.ndarray:
        """Where the mover is at `time` [s]: it starts at `start` and ping-pongs along its track."""
        a, b = np.asarray(self.start, dtype=float), np.asarray(self.end, dtype=float)
        span = float(np.linalg.norm(b - a))
        if span < 1e-9 or self.speed <= 0.0:
            return a
        travelled = (self.speed * time) % (2.0 * span)
        s = travelled if travelled <= span else 2.0 * span - travelled
        return a + (s / span) * (b - a)


def distance_to_centreline(tube: Tube, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance [m] of each of `points` (N, 3) from the centreline, its arc length [m] along it)."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    a, b = tube.centreline[:-1], tube.centreline[1:]
    ab = b - a
    lengths2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
    t = np.clip(np.einsum("nij,ij->ni", points[:, None, :] - a[None], ab) / lengths2, 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    distance = np.linalg.norm(points[:, None, :] - nearest, axis=-1)
    best = np.argmin(distance, axis=1)
    arc = np.concatenate([[0.0], np.cumsum(np.sqrt(lengths2))])
    rows = np.arange(len(points))
    return distance[rows, best], arc[best] + t[rows, best] * np.sqrt(lengths2[best])


def _check_fit(tube: Tube, what: str, centre: np.ndarray, radius: float) -> None:
    """ValueError naming `what` unless a sphere of `radius` at `centre` sits inside the tube, leaves a way past
    and keeps clear of the start and the goal."""
    off, along = distance_to_centreline(tube, centre[None])
    off, along = float(off[0]), float(along[0])
    where = f"{what} at ({', '.join(f'{v:g}' for v in centre)})"
    if off > tube.radius:
        raise ValueError(f"{where} is outside the tube: {off:.1f} m from the centreline, whose free radius is "
                         f"{tube.radius:g} m")
    passage = tube.radius + off - radius
    if passage < MIN_PASSAGE:
        raise ValueError(f"{where} blocks the tube: it leaves {max(passage, 0.0):.1f} m to get past, the vehicle "
                         f"needs {MIN_PASSAGE:g} m (make it smaller or move it towards the wall)")
    for end, point in (("start", tube.centreline[0]), ("goal", tube.centreline[-1])):
        gap = float(np.linalg.norm(centre - point)) - radius
        if gap < END_CLEARANCE:
            raise ValueError(f"{where} is {max(gap, 0.0):.1f} m from the tube's {end}: keep {END_CLEARANCE:g} m clear")
    if not 0.0 <= along <= tube.length():
        raise ValueError(f"{where} is beyond the tube's ends")


TRACK_SAMPLES = 25
"""Points along a mover's track that `check_items` checks."""


def check_items(tube: Tube, obstacles: list[TubeObstacle], movers: list[TubeMover]) -> None:
    """ValueError naming the first obstacle or mover that does not fit the tube (`_check_fit` at each obstacle,
    along each mover's track), or a name used twice."""
    if len(obstacles) > MAX_ITEMS or len(movers) > MAX_ITEMS:
        raise ValueError(f"a tube holds at most {MAX_ITEMS} obstacles and {MAX_ITEMS} movers")
    names = [f"obstacle_{o.name or k}" for k, o in enumerate(obstacles)] + \
            [f"mover_{m.name or k}" for k, m in enumerate(movers)]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"{repeated[0]} is named twice: give each obstacle and mover its own name")
    for k, obstacle in enumerate(obstacles):
        _check_fit(tube, f"obstacle {obstacle.name or k}", obstacle.centre, obstacle.radius)
    for k, mover in enumerate(movers):
        a, b = np.asarray(mover.start, dtype=float), np.asarray(mover.end, dtype=float)
        for s in np.linspace(0.0, 1.0, TRACK_SAMPLES):
            point = a + s * (b - a)
            try:
                _check_fit(tube, f"mover {mover.name or k}", point, mover.radius)
            except ValueError as e:
                raise ValueError(f"{e} ({s:.0%} along its track)") from None


def item_elements(obstacles: list[TubeObstacle], movers: list[TubeMover]) -> tuple[list[ET.Element], dict]:
    """The geoms of `obstacles` (spheres obstacle_NAME), the mocap bodies of `movers` (mover_NAME, a sphere each)
    and the movers' tracks as numerics."""
    elements, numerics = [], {}
    for k, o in enumerate(obstacles):
        elements.append(ET.Element("geom", name=f"obstacle_{o.name or k}", type="sphere", size=f"{o.radius:g}",
                                   pos=" ".join(f"{v:.6g}" for v in o.centre), rgba="0.6 0.3 0.3 1"))
    for k, m in enumerate(movers):
        name = m.name or str(k)
        body = ET.Element("body", name=f"mover_{name}", mocap="true", pos=" ".join(f"{v:.6g}" for v in m.start))
        ET.SubElement(body, "geom", name=f"mover_{name}_geom", type="sphere", size=f"{m.radius:g}",
                      rgba="0.85 0.35 0.2 1")
        elements.append(body)
        numerics[f"{MOVER_NUMERIC}{name}"] = [*m.start, *m.end, m.speed]
    return elements, numerics


def items_from_arena(root: ET.Element) -> tuple[list[TubeObstacle], list[TubeMover]]:
    """The spherical obstacles (geoms obstacle_*) and the movers (`mover3d_*` numerics, the radius of their
    body's sphere) of a tube arena; ValueError naming a bad one."""
    world = root.find("worldbody")
    obstacles = []
    bodies = {}
    for element in world if world is not None else []:
        name = element.get("name") or ""
        if element.tag == "geom" and name.startswith("obstacle_") and element.get("type") == "sphere":
            try:
                centre = [float(v) for v in (element.get("pos") or "0 0 0").split()]
                obstacles.append(TubeObstacle(*centre, float((element.get("size") or "").split()[0]),
                                              name.removeprefix("obstacle_")))
            except (ValueError, TypeError, IndexError):
                raise ValueError(f"geom {name} needs a pos (x y z) and a size (radius)") from None
        elif element.tag == "body":
            bodies[name] = element
    movers = []
    for numeric in root.iter("numeric"):
        key = numeric.get("name") or ""
        if not key.startswith(MOVER_NUMERIC):
            continue
        name = key.removeprefix(MOVER_NUMERIC)
        body = bodies.get(f"mover_{name}")
        sphere = body.find("geom") if body is not None else None
        if body is None or body.get("mocap") != "true" or sphere is None:
            raise ValueError(f"numeric {key} needs a mocap body mover_{name} holding its geom")
        try:
            values = [float(v) for v in (numeric.get("data") or "").split()]
            radius = float((sphere.get("size") or "").split()[0])
        except (ValueError, IndexError):
            values, radius = [], math.nan
        if len(values) != 7:
            raise ValueError(f"numeric {key} must hold x0 y0 z0 x1 y1 z1 speed")
        movers.append(TubeMover(tuple(values[:3]), tuple(values[3:6]), values[6], radius, name))
    return obstacles, movers


def tube_arena(tube: Tube, name: str = "tube", water_depth: float | None = None,
               obstacles: list[TubeObstacle] = (), movers: list[TubeMover] = ()) -> ET.Element:
    """An arena MJCF root with the tube, its centreline and radius numerics, a seabed if `water_depth`, and the
    obstacles and movers (checked to fit by `check_items`)."""
    check_items(tube, list(obstacles), list(movers))
    elements = tube_elements(tube, name)
    if water_depth is not None:
        elements.insert(0, seabed(water_depth))
    extra, mover_numerics = item_elements(list(obstacles), list(movers))
    return arena_root(name, elements + extra, {"tube_centreline": tube.centreline.ravel().tolist(),
                                               "tube_radius": [tube.radius], "tube_stave_radius": [tube.stave_radius],
                                               "tube_staves": [tube.staves], **mover_numerics})


def random_tube(random: np.random.RandomState) -> Tube:
    """A procedural tube: a random length, depth, climbs, dives and bends within the module's limits."""
    length = random.uniform(*RANDOM_LENGTH)
    depth = random.uniform(*RANDOM_DEPTH)
    heading = random.uniform(-math.pi, math.pi)
    slope = 0.0
    max_turn = SEGMENT_LENGTH / MIN_BEND_RADIUS
    points = [np.array([0.0, 0.0, -depth])]
    turn_rate = 0.0
    for _ in range(int(length / SEGMENT_LENGTH)):
        turn_rate = float(np.clip(turn_rate + random.uniform(-0.4, 0.4) * max_turn, -0.9 * max_turn, 0.9 * max_turn))
        heading += turn_rate
        top = -(TUBE_RADIUS + STAVE_RADIUS + MIN_COVER)
        change = random.uniform(-SLOPE_CHANGE, SLOPE_CHANGE)
        if points[-1][2] > top - LEVEL_OUT:  # near the cover: only level out and go down
            change = -SLOPE_CHANGE
        slope = float(np.clip(slope + change, -0.8 * MAX_SLOPE, 0.8 * MAX_SLOPE))
        step = SEGMENT_LENGTH * np.array([math.cos(slope) * math.cos(heading), math.cos(slope) * math.sin(heading),
                                          math.sin(slope)])
        nxt = points[-1] + step
        points.append(nxt)
    return Tube(np.array(points))


def goal_arena(random: np.random.RandomState, water_depth: float):
    """goal3d's arena: a seabed, a goal 60-100 m away at another depth, and obstacles (spheres and upright
    cylinders standing on the bed) near the straight line. Returns (root, start, heading, goal, empty path)."""
    start = np.array([0.0, 0.0, -random.uniform(8.0, 20.0)])
    bearing = random.uniform(-math.pi, math.pi)
    distance = random.uniform(60.0, 100.0)
    goal = np.array([distance * math.cos(bearing), distance * math.sin(bearing), -random.uniform(10.0, 40.0)])
    elements = [seabed(water_depth)]
    for k in range(int(random.randint(2, 6))):
        s = random.uniform(0.25, 0.8)
        centre = start + s * (goal - start) + np.append(random.uniform(-10.0, 10.0, 2), 0.0)
        if random.uniform() < 0.5:
            radius = random.uniform(3.0, 6.0)
            elements.append(ET.Element("geom", name=f"obstacle_{k}", type="sphere", size=f"{radius:.3f}",
                                       pos=" ".join(f"{v:.3f}" for v in centre), rgba="0.6 0.3 0.3 1"))
        else:
            radius, top = random.uniform(2.0, 4.0), centre[2] + random.uniform(3.0, 10.0)
            half = 0.5 * (top + water_depth)
            elements.append(ET.Element("geom", name=f"obstacle_{k}", type="cylinder", size=f"{radius:.3f} {half:.3f}",
                                       pos=f"{centre[0]:.3f} {centre[1]:.3f} {top - half:.3f}", rgba="0.6 0.3 0.3 1"))
    elements.append(ET.Element("site", name="goal", pos=" ".join(f"{v:.3f}" for v in goal), size="0.5",
                               rgba="1 0 0 0.5"))
    root = arena_root("goal3d", elements)
    return root, start, bearing, goal, np.zeros((0, 3))


def read_centreline(path: str | Path) -> np.ndarray:
    """(K, 3) x, y, z [m] rows of a CSV (header optional: its names must start x, y, z, in either case; rows
    starting with `#` are comments, as in a planar centreline); ValueError naming the file, the row (its line) and
    the field of a bad entry, with the text as the file has it."""
    path = Path(path)
    text = read_text(path, "tube centreline CSV", 10_000_000)
    rows = [(line, row) for line, row in enumerate(csv_rows(text, str(path), "x,y,z"), start=1)
            if row and any(cell.strip() for cell in row) and not row[0].strip().startswith("#")]
    if rows and not is_number(rows[0][1][0], finite=True):
        header = [cell.strip() for cell in rows[0][1]]
        if [name.lower() for name in header[:3]] != ["x", "y", "z"]:
            raise ValueError(f"{path}: row {rows[0][0]}: the header must start x,y,z, got "
                             f"{','.join(header)[:60]!r}")
        rows = rows[1:]
    points = []
    for line, row in rows:
        if len(row) < 3:
            raise ValueError(f"{path}: row {line} needs x,y,z [m], got {','.join(row)[:60]!r}")
        values = []
        for name, cell in zip("xyz", row[:3], strict=True):
            if not is_number(cell, finite=True) or not abs(float(cell)) <= MAX_EXTENT:
                raise ValueError(f"{path}: row {line}: {name} = {cell.strip()[:30]!r} is not a coordinate within "
                                 f"+-{MAX_EXTENT:g} m")
            values.append(float(cell))
        points.append(values)
    if not 2 <= len(points) <= MAX_POINTS:
        raise ValueError(f"{path}: a tube needs 2 to {MAX_POINTS} centreline points, got {len(points)}")
    return np.array(points)


TUBE_JSON_KEYS = ("centreline", "width", "obstacles", "movers")
"""The keys a tube's JSON file may hold."""


@dataclass(frozen=True)
class TubeSpec:
    """What a tube file holds: the centreline (K, 3) [m], and where given its diameter, obstacles and movers."""

    centreline: np.ndarray
    width: float | None = None
    obstacles: tuple[TubeObstacle, ...] = ()
    movers: tuple[TubeMover, ...] = ()


def read_tube(path: str | Path) -> TubeSpec:
    """A tube from a CSV of x, y, z rows (`read_centreline`) or a JSON object {"centreline": [[x, y, z], ...],
    "width": D, "obstacles": [{"x", "y", "z", "radius", "name"}], "movers": [{"start": [x, y, z], "end": [x, y, z],
    "speed", "radius", "name"}]} (all but the centreline optional); ValueError naming the file and field."""
    import json

    from auv_mj.inputs import check_json_depth

    path = Path(path)
    text = read_text(path, "tube file", 10_000_000)
    if path.suffix.lower() != ".json" and not text.lstrip().startswith("{"):
        return TubeSpec(read_centreline(path))
    check_json_depth(text, str(path))
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON: {e}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a tube's JSON is an object with a \"centreline\" of [x, y, z] points")
    unknown = sorted(set(data) - set(TUBE_JSON_KEYS))
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r:.60}{did_you_mean(unknown[0], TUBE_JSON_KEYS)} (a tube's "
                         f"JSON may hold {', '.join(TUBE_JSON_KEYS)})")
    points = data.get("centreline")
    if not (isinstance(points, list) and 2 <= len(points) <= MAX_POINTS and all(
            isinstance(p, list) and len(p) == 3 and all(is_real(v) and abs(v) <= MAX_EXTENT for v in p)
            for p in points)):
        raise ValueError(f"{path}: \"centreline\" must be a list of 2 to {MAX_POINTS} [x, y, z] points [m] within "
                         f"+-{MAX_EXTENT:g} m")
    width = data.get("width")
    if width is not None and not (is_real(width) and 2 * MIN_RADIUS <= width <= 2 * MAX_RADIUS):
        raise ValueError(f"{path}: \"width\" must be a diameter in [{2 * MIN_RADIUS:g}, {2 * MAX_RADIUS:g}] m, "
                         f"got {width!r:.40}")
    obstacles, movers = [], []
    for key, kind, fields in (("obstacles", TubeObstacle, ("x", "y", "z", "radius")),
                              ("movers", TubeMover, ("start", "end", "speed", "radius"))):
        items = data.get(key, [])
        if not isinstance(items, list) or len(items) > MAX_ITEMS:
            raise ValueError(f"{path}: \"{key}\" must be a list of at most {MAX_ITEMS} objects")
        for k, item in enumerate(items):
            if not isinstance(item, dict) or set(item) - {*fields, "name"} or set(fields) - set(item):
                raise ValueError(f"{path}: {key}[{k}] must be an object with {', '.join(fields)}[, name]")
            values = {f: tuple(item[f]) if isinstance(item[f], list) else item[f] for f in fields}
            try:
                made = kind(**values, name=item.get("name", ""))
            except (ValueError, TypeError) as e:
                raise ValueError(f"{path}: {key}[{k}]: {e}") from None
            (obstacles if key == "obstacles" else movers).append(made)
    return TubeSpec(np.array(points, dtype=float), width, tuple(obstacles), tuple(movers))


def check_tube(tube: Tube, water_depth: float | None = None) -> list[str]:
    """What keeps `tube` from being a usable arena for the 6-DOF REMUS (empty when nothing): too narrow or wide,
    a gap in the wall, a bend or slope beyond the vehicle's envelope, a bend too tight for the tube's width,
    too shallow, below the seabed, or crossing itself."""
    problems = []
    points = tube.centreline
    if len(points) < 2:
        return [f"a tube needs at least 2 centreline points, got {len(points)}"]
    segments = np.diff(points, axis=0)
    lengths = np.linalg.norm(segments, axis=1)
    if np.any(lengths < 1e-6):
        problems.append(f"centreline points {int(np.argmin(lengths))} and {int(np.argmin(lengths)) + 1} coincide")
        return problems
    if tube.radius < MIN_RADIUS:
        problems.append(f"inner radius {tube.radius:g} m is below {MIN_RADIUS:g} m: the hull would not fit")
    if tube.radius > MAX_RADIUS:
        problems.append(f"inner radius {tube.radius:g} m is above {MAX_RADIUS:g} m")
    if not (tube.stave_radius > 0 and tube.staves >= 3):
        problems.append(f"a wall needs 3 or more staves of a positive radius, got {tube.staves} of "
                        f"{tube.stave_radius:g} m")
        return problems
    if len(segments) * tube.staves > MAX_WALL_GEOMS:
        problems.append(f"the wall would need {len(segments) * tube.staves} staves ({len(segments)} segments x "
                        f"{tube.staves}), more than {MAX_WALL_GEOMS}: give fewer centreline points")
        return problems
    directions = segments / lengths[:, None]
    slopes = np.arcsin(np.clip(directions[:, 2], -1.0, 1.0))
    steep = np.flatnonzero(np.abs(slopes) > MAX_SLOPE + 1e-9)
    if steep.size:
        problems.append(f"segment {int(steep[0])} climbs or dives at {math.degrees(slopes[steep[0]]):.1f} deg, beyond "
                        f"{math.degrees(MAX_SLOPE):.0f} deg")
    turns = vertex_turns(points)[1:-1]
    if len(turns):
        bend = 0.5 * (lengths[:-1] + lengths[1:]) / np.maximum(turns, 1e-12)
        tight = np.flatnonzero(bend < MIN_BEND_RADIUS - 1e-9)
        if tight.size:
            problems.append(f"the bend at point {int(tight[0]) + 1} has a radius of {bend[tight[0]]:.1f} m, tighter "
                            f"than {MIN_BEND_RADIUS:g} m")
    ends = tube.stave_ends()
    reach = np.einsum("skj,sj->sk", ends[:, :, 1] - ends[:, :, 0], directions)
    folded = np.argwhere(reach <= 0.0)
    if folded.size:
        i = int(folded[0, 0])
        problems.append(f"the wall folds on the inside of the bend at segment {i}: a tube {2 * tube.radius:g} m "
                        f"across needs bends wider than its wall's {tube.wall_radius:.1f} m radius (space the "
                        "points out, or --smooth)")
    gap = wall_gap(tube, ends)
    if gap[0] > 0.0:
        problems.append(f"the wall has gaps: staves {gap[0] + 2 * tube.stave_radius:.2f} m apart, "
                        f"{2 * tube.stave_radius:.2f} m thick, at centreline point {gap[1]}")
    top = float(np.max(ends[..., 2])) + tube.stave_radius
    if top > -MIN_COVER + 1e-9:
        where = (f"{top:.1f} m above the surface" if top > 0.0 else "the surface" if top == 0.0
                 else f"{-top:.1f} m below the surface")
        problems.append(f"the tube's top reaches {where}: it needs {MIN_COVER:g} m of water above it (lower the "
                        f"centreline by {top + MIN_COVER:.1f} m, z is up and 0 at the surface)")
    if water_depth is not None and float(np.min(ends[..., 2])) - tube.stave_radius < -water_depth:
        problems.append(f"the tube goes below the seabed at {water_depth:g} m")
    crossing = _crossing(points, lengths, 2.0 * (tube.wall_radius + tube.stave_radius))
    if crossing is not None:
        problems.append(f"segments {crossing[0]} and {crossing[1]} come within "
                        f"{2.0 * (tube.wall_radius + tube.stave_radius):g} m of each other: the tube crosses itself")
    return problems


def wall_gap(tube: Tube, ends: np.ndarray | None = None) -> tuple[float, int]:
    """(largest gap [m] between neighbouring staves' surfaces, the centreline point where it is); negative when
    they overlap everywhere. Neighbouring staves run between points `a` apart at one end and `b` at the other, so
    their axes are at most max(a, b) apart along them (the distance of matching points is convex)."""
    ends = tube.stave_ends() if ends is None else ends
    apart = np.linalg.norm(ends - np.roll(ends, -1, axis=1), axis=-1)  # (segments, staves, 2)
    worst = np.unravel_index(int(np.argmax(apart)), apart.shape)
    return float(apart[worst]) - 2.0 * tube.stave_radius, int(worst[0] + worst[2])


LEAK_RAYS = 36
"""Rays across the tube from each point where `wall_leaks` looks for a way out."""


def wall_leaks(physics, tube: Tube) -> list[str]:
    """Where rays from the centreline, across it, leave the tube without meeting a wall stave (the model's own
    geoms, as the sonar and the hull see them, whoever wrote them): from each segment's middle, square to it, the
    wall is `wall_radius` away."""
    model, data = physics.model.ptr, physics.data.ptr
    vehicle = model.body("auv").id
    directions, normals, binormals = tube.frames()
    angles = 2.0 * math.pi * (np.arange(LEAK_RAYS) + 0.5) / LEAK_RAYS
    reach = tube.wall_radius + 1e-6
    for i in range(len(directions)):
        middle = 0.5 * (tube.centreline[i] + tube.centreline[i + 1])
        rays = np.cos(angles)[:, None] * normals[i] + np.sin(angles)[:, None] * binormals[i]
        geoms = np.zeros(LEAK_RAYS, dtype=np.int32)
        distance = np.zeros(LEAK_RAYS)
        mujoco.mj_multiRay(model, data, middle, np.ascontiguousarray(rays).ravel(), None, 1, vehicle, geoms,
                           distance, None, LEAK_RAYS, reach)
        open_ = np.flatnonzero((distance < 0) | (distance > reach))
        if open_.size:
            where = middle + tube.radius * rays[open_[0]]
            return [f"the wall has a gap: a ray from the middle of segment {i} leaves the tube near "
                    f"({', '.join(f'{v:.1f}' for v in where)})"]
    return []


def _crossing(points: np.ndarray, lengths: np.ndarray, clearance: float) -> tuple[int, int] | None:
    """Two segments, far apart along the line, that come within `clearance` of each other (None if none)."""
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    s = np.linspace(0.0, 1.0, 9)
    samples = points[:-1, None, :] + s[None, :, None] * np.diff(points, axis=0)[:, None, :]  # (S, 9, 3)
    middles, halves = samples[:, 4], 0.5 * lengths
    for i in range(len(lengths)):
        far = np.flatnonzero(arc[:-1] - arc[i + 1] >= 0.5 * math.pi * clearance)  # near along the line: the bend
        far = far[far > i + 1]                                                     # limit covers it
        near = far[np.linalg.norm(middles[far] - middles[i], axis=1) < clearance + halves[far] + halves[i]]
        if not near.size:
            continue
        gaps = np.linalg.norm(samples[i][None, :, None, :] - samples[near][:, None, :, :], axis=-1).min(axis=(1, 2))
        hit = np.flatnonzero(gaps < clearance)
        if hit.size:
            return i, int(near[hit[0]])
    return None


def tube_from_arena(root: ET.Element) -> Tube | None:
    """The tube an arena MJCF describes (its tube_* numerics), or None when it holds no tube."""
    values = {n.get("name"): n.get("data", "") for n in root.iter("numeric")}
    if "tube_centreline" not in values:
        return None
    try:
        line = np.array([float(v) for v in values["tube_centreline"].split()]).reshape(-1, 3)
        radius = float(values.get("tube_radius", TUBE_RADIUS))
        stave = float(values.get("tube_stave_radius", STAVE_RADIUS))
        staves = float(values.get("tube_staves", N_STAVES))  # a tube written before rings were sized: 20
    except ValueError:
        raise ValueError("tube_centreline must hold x y z triples, and tube_radius, tube_stave_radius and "
                         "tube_staves one number each") from None
    if not (all(math.isfinite(v) for v in (radius, stave, staves)) and staves == int(staves)
            and 3 <= staves <= MAX_WALL_GEOMS and line.size and np.all(np.isfinite(line))):
        raise ValueError(f"tube numerics out of range: radius {radius:g}, stave radius {stave:g}, staves {staves:g} "
                         "(a whole number of 3 or more)")
    return Tube(line, radius, stave, int(staves))


def is_tube_arena(source: str | Path | ET.Element) -> bool:
    """Whether an arena (file or element) describes a tube (holds a `tube_centreline` numeric)."""
    if isinstance(source, ET.Element):
        root = source
    else:
        try:
            root = ET.fromstring(read_text(Path(source), "arena MJCF", 50_000_000))
        except (OSError, ValueError, ET.ParseError):
            return False
    return any(n.get("name") == "tube_centreline" for n in root.iter("numeric"))


def tube_report(source: str | Path | ET.Element) -> tuple[str, list[str]]:
    """(summary, problems) of a tube arena: `check_tube` on its numerics, the staves it should hold, and the
    6-DOF vehicle compiled inside it, placed at the start, free of contacts."""
    from auv_mj.arenas.arena3d import compose_xml
    from auv_mj.inputs import parse_xml
    from auv_mj.sim.physics3d import AUV3DPhysics, set_pose

    if isinstance(source, ET.Element):
        root = source
    else:
        root = parse_xml(read_text(Path(source), "arena MJCF", 50_000_000), str(source), "arena MJCF")
    try:
        tube = tube_from_arena(root)
    except ValueError as e:
        return "a tube arena", [str(e)]
    problems = check_tube(tube)
    if problems and len(tube.centreline) < 2:
        return "a tube arena", problems
    staves = sum(1 for g in root.iter("geom") if (g.get("name") or "").startswith("wall_"))
    expected = tube.staves * (len(tube.centreline) - 1)
    if staves != expected:
        problems.append(f"{staves} wall staves where the centreline needs {expected}")
    try:
        xml, name = compose_xml(root)
        physics = AUV3DPhysics.from_xml_string(xml, source=name)
        set_pose(physics, tube.centreline[0], yaw=tube.start_heading())
        physics.forward()
        if physics.data.ncon:
            problems.append("the vehicle touches the wall at the start")
        if not problems:
            problems += wall_leaks(physics, tube)
        check_items(tube, *items_from_arena(root))
    except ValueError as e:
        problems.append(str(e))
    summary = (f"a tube of {tube.length():.0f} m, inner radius {tube.radius:g} m, depth "
               f"{-tube.centreline[:, 2].max():.1f} to {-tube.centreline[:, 2].min():.1f} m, {staves} staves")
    return summary, problems
