"""Tube arenas for the 6-DOF vehicle (issue 32): a pipe along an x, y, z centreline, and open water with a seabed.

A tube's wall is a ring of N_STAVES capsules ("staves") along each centreline segment, each from one ring
point to the same ring point of the next vertex. The rings are carried along the centreline by parallel
transport (no twist), so consecutive staves meet end to end round bends and the wall is closed: neighbouring
staves overlap (`Tube.stave_radius` is more than half their spacing). Rays of the sonar fan and the hull's
contacts see the wall as it is. The inner free radius is `radius`; the centreline lies in the arena's
`tube_centreline` numeric (x y z triples) and the radius in `tube_radius`, which `check_tube` (and
`auv-mj check-arena`) read back.

Procedural tubes (`random_tube`) climb, dive and bend within the vehicle's envelope: bends no tighter than
MIN_BEND_RADIUS, slopes no steeper than MAX_SLOPE, the whole tube below MIN_COVER of water.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from auv_mj.arenas.arena3d import arena_root, seabed
from auv_mj.inputs import csv_rows, read_text

N_STAVES = 20
"""Staves round a tube's ring."""
STAVE_RADIUS = 0.6
"""Radius of each stave capsule [m]."""
TUBE_RADIUS = 3.0
"""Default inner free radius of a tube [m]: about 15 REMUS hull radii, room to correct a depth error."""
MIN_RADIUS = 1.0
"""Narrowest tube `check_tube` accepts [m]: the hull's half length (0.67 m) plus a margin."""
MIN_BEND_RADIUS = 20.0
"""Tightest bend of a tube's centreline [m]: the REMUS turns on about 15 m at full rudder and 1.5 m/s."""
MAX_SLOPE = math.radians(12.0)
"""Steepest climb or dive of a centreline segment [rad]: below the classical executor's 14 deg pitch limit
(`auv_mj.tasks.auv3d_control.DepthHeadingGains.max_pitch`), so that a vehicle can follow it with margin."""
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


@dataclass(frozen=True)
class Tube:
    """A tube: its centreline (K, 3) [m, world, z up] and inner free radius [m]."""

    centreline: np.ndarray
    radius: float = TUBE_RADIUS
    stave_radius: float = STAVE_RADIUS

    @property
    def wall_radius(self) -> float:
        """Distance of the staves' axes from the centreline [m]."""
        return self.radius + self.stave_radius

    def start_heading(self) -> float:
        """Heading of the first segment [rad]."""
        d = self.centreline[1] - self.centreline[0]
        return math.atan2(d[1], d[0])

    def length(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self.centreline, axis=0), axis=1)))

    def rings(self) -> np.ndarray:
        """(K, N_STAVES, 3) the staves' end points at each vertex (parallel-transported frames)."""
        points = self.centreline
        segments = np.diff(points, axis=0)
        segments /= np.linalg.norm(segments, axis=1, keepdims=True)
        tangents = np.vstack([segments[:1], segments[:-1] + segments[1:], segments[-1:]])
        tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
        seed = np.array([0.0, 0.0, 1.0]) if abs(tangents[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        normal = seed - tangents[0] * (seed @ tangents[0])
        normal /= np.linalg.norm(normal)
        angles = np.linspace(0.0, 2.0 * math.pi, N_STAVES, endpoint=False)
        out = np.empty((len(points), N_STAVES, 3))
        for i, t in enumerate(tangents):
            normal = normal - t * (normal @ t)  # transport: remove the new tangent's part
            normal /= np.linalg.norm(normal)
            binormal = np.cross(t, normal)
            ring = np.cos(angles)[:, None] * normal + np.sin(angles)[:, None] * binormal
            out[i] = points[i] + self.wall_radius * ring
        return out


def tube_elements(tube: Tube, name: str = "tube") -> list[ET.Element]:
    """The staves (geoms named wall_<name>_<segment>_<stave>) and start/goal sites of `tube`."""
    rings = tube.rings()
    elements = []
    for i in range(len(rings) - 1):
        for k in range(N_STAVES):
            a, b = rings[i, k], rings[i + 1, k]
            elements.append(ET.Element("geom", name=f"wall_{name}_{i}_{k}", type="capsule",
                                       fromto=" ".join(f"{v:.6g}" for v in (*a, *b)), size=f"{tube.stave_radius:g}",
                                       rgba="0.5 0.55 0.6 0.35"))
    for site, point in (("start", tube.centreline[0]), ("goal", tube.centreline[-1])):
        elements.append(ET.Element("site", name=site, pos=" ".join(f"{v:.6g}" for v in point), size="0.3",
                                   rgba="0 1 0 0.5" if site == "start" else "1 0 0 0.5"))
    return elements


def tube_arena(tube: Tube, name: str = "tube", water_depth: float | None = None) -> ET.Element:
    """An arena MJCF root with the tube, its centreline and radius numerics, and a seabed if `water_depth`."""
    elements = tube_elements(tube, name)
    if water_depth is not None:
        elements.insert(0, seabed(water_depth))
    return arena_root(name, elements, {"tube_centreline": tube.centreline.ravel().tolist(),
                                       "tube_radius": [tube.radius], "tube_stave_radius": [tube.stave_radius]})


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
    """(K, 3) x, y, z [m] rows of a CSV (header optional: its names must start x, y, z); ValueError naming the
    file, row and field of a bad entry."""
    path = Path(path)
    text = read_text(path, "tube centreline CSV", 10_000_000)
    rows = [row for row in csv_rows(text, str(path), "x,y,z") if row and any(cell.strip() for cell in row)]
    if rows and not _is_number(rows[0][0]):
        header = [cell.strip().lower() for cell in rows[0]]
        if header[:3] != ["x", "y", "z"]:
            raise ValueError(f"{path}: the header must start x,y,z, got {','.join(header)[:60]!r}")
        rows = rows[1:]
    points = []
    for number, row in enumerate(rows, start=1):
        if len(row) < 3:
            raise ValueError(f"{path}: row {number} needs x,y,z [m], got {','.join(row)[:60]!r}")
        values = []
        for name, cell in zip("xyz", row[:3], strict=True):
            if not _is_number(cell) or not abs(float(cell)) <= MAX_EXTENT:
                raise ValueError(f"{path}: row {number}: {name} = {cell.strip()[:30]!r} is not a coordinate within "
                                 f"+-{MAX_EXTENT:g} m")
            values.append(float(cell))
        points.append(values)
    if not 2 <= len(points) <= MAX_POINTS:
        raise ValueError(f"{path}: a tube needs 2 to {MAX_POINTS} centreline points, got {len(points)}")
    return np.array(points)


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def check_tube(tube: Tube, water_depth: float | None = None) -> list[str]:
    """What keeps `tube` from being a usable arena for the 6-DOF REMUS (empty when nothing): too narrow, a gap
    in the wall, a bend or slope beyond the vehicle's envelope, too shallow, below the seabed, or crossing itself."""
    problems = []
    points = tube.centreline
    segments = np.diff(points, axis=0)
    lengths = np.linalg.norm(segments, axis=1)
    if np.any(lengths < 1e-6):
        problems.append(f"centreline points {int(np.argmin(lengths))} and {int(np.argmin(lengths)) + 1} coincide")
        return problems
    if tube.radius < MIN_RADIUS:
        problems.append(f"inner radius {tube.radius:g} m is below {MIN_RADIUS:g} m: the hull would not fit")
    spacing = 2.0 * math.pi * tube.wall_radius / N_STAVES
    if spacing > 2.0 * tube.stave_radius:
        problems.append(f"the wall has gaps: staves {spacing:.2f} m apart, {2 * tube.stave_radius:.2f} m thick")
    directions = segments / lengths[:, None]
    slopes = np.arcsin(np.clip(directions[:, 2], -1.0, 1.0))
    steep = np.flatnonzero(np.abs(slopes) > MAX_SLOPE + 1e-9)
    if steep.size:
        problems.append(f"segment {int(steep[0])} climbs or dives at {math.degrees(slopes[steep[0]]):.1f} deg, beyond "
                        f"{math.degrees(MAX_SLOPE):.0f} deg")
    if len(directions) > 1:
        turns = np.arccos(np.clip(np.einsum("ij,ij->i", directions[:-1], directions[1:]), -1.0, 1.0))
        bend = 0.5 * (lengths[:-1] + lengths[1:]) / np.maximum(turns, 1e-12)
        tight = np.flatnonzero(bend < MIN_BEND_RADIUS - 1e-9)
        if tight.size:
            problems.append(f"the bend at point {int(tight[0]) + 1} has a radius of {bend[tight[0]]:.1f} m, tighter "
                            f"than {MIN_BEND_RADIUS:g} m")
    top = float(np.max(points[:, 2])) + tube.wall_radius + tube.stave_radius
    if top > -MIN_COVER + 1e-9:
        problems.append(f"the tube's top reaches {-top:.1f} m depth: it needs {MIN_COVER:g} m of water above it")
    if water_depth is not None and float(np.min(points[:, 2])) - tube.wall_radius - tube.stave_radius < -water_depth:
        problems.append(f"the tube goes below the seabed at {water_depth:g} m")
    clearance = 2.0 * (tube.wall_radius + tube.stave_radius)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    for i in range(len(segments)):
        for j in range(i + 2, len(segments)):
            if arc[j] - arc[i + 1] < 0.5 * math.pi * clearance:  # near along the line: the bend limit covers it
                continue
            if _segment_distance(points[i], points[i + 1], points[j], points[j + 1]) < clearance:
                problems.append(f"segments {i} and {j} come within {clearance:g} m of each other: the tube crosses "
                                "itself")
                return problems
    return problems


def _segment_distance(a0, a1, b0, b1) -> float:
    """Shortest distance between segments a0-a1 and b0-b1 (sampled finely enough for the check)."""
    s = np.linspace(0.0, 1.0, 9)
    pa = a0 + s[:, None] * (a1 - a0)
    pb = b0 + s[:, None] * (b1 - b0)
    return float(np.min(np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)))


def tube_from_arena(root: ET.Element) -> Tube | None:
    """The tube an arena MJCF describes (its tube_* numerics), or None when it holds no tube."""
    values = {n.get("name"): n.get("data", "") for n in root.iter("numeric")}
    if "tube_centreline" not in values:
        return None
    try:
        line = np.array([float(v) for v in values["tube_centreline"].split()]).reshape(-1, 3)
        radius = float(values.get("tube_radius", TUBE_RADIUS))
        stave = float(values.get("tube_stave_radius", STAVE_RADIUS))
    except ValueError:
        raise ValueError("tube_centreline must hold x y z triples and tube_radius one number") from None
    return Tube(line, radius, stave)


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
    from auv_mj.sim.physics6 import AUV6Physics, set_pose

    if isinstance(source, ET.Element):
        root = source
    else:
        root = parse_xml(read_text(Path(source), "arena MJCF", 50_000_000), str(source), "arena MJCF")
    try:
        tube = tube_from_arena(root)
    except ValueError as e:
        return "a tube arena", [str(e)]
    problems = check_tube(tube)
    staves = sum(1 for g in root.iter("geom") if (g.get("name") or "").startswith("wall_"))
    expected = N_STAVES * (len(tube.centreline) - 1)
    if staves != expected:
        problems.append(f"{staves} wall staves where the centreline needs {expected}")
    try:
        xml, name = compose_xml(root)
        physics = AUV6Physics.from_xml_string(xml, source=name)
        set_pose(physics, tube.centreline[0], yaw=tube.start_heading())
        physics.forward()
        if physics.data.ncon:
            problems.append("the vehicle touches the wall at the start")
    except ValueError as e:
        problems.append(str(e))
    summary = (f"a tube of {tube.length():.0f} m, inner radius {tube.radius:g} m, depth "
               f"{-tube.centreline[:, 2].max():.1f} to {-tube.centreline[:, 2].min():.1f} m, {staves} staves")
    return summary, problems
