"""The hard tier of the procedural arenas (issue 30): local-minimum traps, dense clutter and fast movers.

Reactive planners (line of sight under a repulsive field) fail where an obstacle is concave towards them:
they are led into it by the goal's pull and held there by the field (Choset et al., *Principles of Robot
Motion*, Ch. 4, local minima of potential fields). The hard tier is made of such water:

- `cup`: three walls open towards the start, the route running into the opening;
- `wedge`: two walls in a V, the apex away from the start;
- `wall`: one long wall across the route, ending a little way past it on one side (the gap at one end),
  sometimes with a hook at that end turned back towards the start;
- `clutter`: a field of small boxes whose gaps are all at least DENSE_GAP (hull width + 2 d_s and more);
- traps in series (`HardSpec.traps`) along the route;
- movers at up to 1 m/s crossing the route or coming head-on along it (`moving_obstacles`);
- in tunnels (`random_hard_tunnel`): a wide tunnel whose straights hold a cup, a wedge or a wall.

Open water (`random_hard_layout`: the `obstacles` and `moving_obstacles` tasks with `tier="hard"`): start and
goal as far apart as HardSpec.goal_distance, traps centred on the straight route between them, all walls
HARD_THICKNESS thick.

Every arena is certified (`certify`): a path keeping CERTIFY_CLEARANCE from every footprint joins its start
and its goal on the oracle's grid (`auv_mj.arenas.grid`), and every gap the generator makes itself is at
least DENSE_GAP; a draw that fails is redrawn from the same random stream (at most `HardSpec.tries` times).
A hard arena is a function of its seed, as every procedural arena is (`auv_mj.seeds`). The shapes are drawn
from wide ranges and never tuned to any planner.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import shapely

from auv_mj.arenas import grid
from auv_mj.arenas.procedural import ProceduralTunnel, TunnelSpec, as_random, passing_gap, random_tunnel
from auv_mj.arenas.tunnels import (
    WALL_THICKNESS,
    MovingObstacle,
    Obstacle,
    TunnelLayout,
    box_polygon,
    check_unknown,
    route_clearance,
    tunnel_element,
    wall_box,
)
from auv_mj.geometry import arc_lengths

TIERS = ("standard", "hard")
"""The `tier` task option's values: today's distributions, or this module's."""
HARD_THICKNESS = 3.0
"""Thickness of a trap's walls [m]."""
DENSE_GAP = 2 * route_clearance() + 1.0
"""Least gap [m] the generator leaves between two obstacles of different traps and inside clutter: d_s to both
sides of a hull turned any way (2 x 5.665 m) and 1 m to spare, more than the hull's width + 2 d_s (10.19 m)."""
CERTIFY_CLEARANCE = route_clearance()
"""Clearance [m] of the certificate's path on the grid (between cell centres): d_s from a hull turned any way."""
END_CLEARANCE = 45.0
"""Least distance [m] from the start and from the goal to any obstacle or mover track."""
EDGE_CLEARANCE = 35.0
"""Least distance [m] from the map's edge to any obstacle (beyond the geofence's reach of a passing vehicle)."""
TRAP_SPACING = 60.0
"""Least distance [m] along the route between the extents of two traps in series."""
MAX_TUNNEL_TRAP_DEPTH = 35.0
"""A tunnel trap's extent along the axis [m]: within the task's passing window of sub-goals (5 x 10 m)."""


@dataclass(frozen=True)
class HardSpec:
    """What hard open-water arenas are drawn from (ranges (low, high); counts inclusive)."""

    goal_distance: tuple[float, float] = (350.0, 500.0)
    """Start to goal [m]: room for traps in series."""
    traps: tuple[int, int] = (2, 3)
    """Traps along the route (fewer when they do not fit)."""
    kinds: tuple[str, ...] = ("cup", "wedge", "wall", "clutter")
    """Trap kinds, drawn uniformly."""
    cup_width: tuple[float, float] = (60.0, 100.0)
    """Inner width of a cup [m]: its mouth is wider than twice the protection domain's reach d0 = 30 m
    (`auv_mj.planners.avoidance.RepulsiveField.influence`), so a reactive planner is not turned away at the mouth but
    meets the back wall inside, where a local minimum of the field lies."""
    cup_depth: tuple[float, float] = (35.0, 70.0)
    """Inner depth of a cup [m]: more than d0, so that the back wall's echoes do not reach the mouth."""
    wedge_arm: tuple[float, float] = (60.0, 110.0)
    """Length of a wedge's arms [m] (more than twice d0, as a cup's mouth)."""
    wedge_opening: tuple[float, float] = (math.radians(40.0), math.radians(100.0))
    """Angle between a wedge's arms [rad]."""
    wall_length: tuple[float, float] = (200.0, 340.0)
    """Length of a long wall [m] ..."""
    wall_open_end: tuple[float, float] = (40.0, 100.0)
    """... which ends this far [m] past the route on its open side (beyond d0 from it)."""
    hook_chance: float = 0.5
    """Chance that a long wall has a hook turned back towards the start at its open end."""
    hook: tuple[float, float] = (20.0, 50.0)
    """Length of the hook [m]."""
    tilt: float = math.radians(25.0)
    """A trap is turned up to this far from square to the route [rad]."""
    clutter_count: tuple[int, int] = (10, 18)
    """Boxes tried in a clutter field."""
    clutter_half: tuple[float, float] = (2.0, 7.0)
    """Half-sizes of clutter boxes [m]."""
    clutter_region: tuple[float, float] = (70.0, 110.0)
    """Along and across extent of a clutter field [m]."""
    movers: tuple[int, int] = (0, 0)
    """Movers crossing the route or coming head-on along it."""
    mover_speed: tuple[float, float] = (0.5, 1.0)
    """Speed of a mover [m/s]."""
    mover_radius: tuple[float, float] = (2.0, 5.0)
    mover_half_path: tuple[float, float] = (25.0, 60.0)
    """Half-length of a mover's ping-pong track [m]."""
    head_on_chance: float = 0.5
    """Chance that a mover runs along the route towards the start rather than across it."""
    tries: int = 60
    """Draws before giving up (each failed draw is redrawn from the same random stream)."""


HARD_OBSTACLES = HardSpec()
"""The `obstacles` task's hard tier: two or three static traps in series."""
HARD_MOVING = HardSpec(traps=(1, 2), movers=(2, 4))
"""The `moving_obstacles` task's hard tier: one or two traps and two to four fast movers."""


@dataclass(frozen=True)
class HardLayout:
    """A hard open-water arena: start pose, goal, map, the traps' boxes and the movers (all unknown)."""

    seed: int | None
    start: np.ndarray
    heading: float
    goal: np.ndarray
    bounds: tuple[float, float, float, float]
    obstacles: tuple[Obstacle, ...]
    movers: tuple[MovingObstacle, ...]
    kinds: tuple[str, ...]
    """The traps' kinds in order along the route."""
    draws: int = 1
    """How many draws it took (the ones before failed a check)."""

    def element(self, name: str | None = None, command: str | None = None, path_spacing: float = 10.0) -> ET.Element:
        """An arena MJCF element: the boxes as unknown obstacles, the movers, and the straight start-goal line
        as its global path (as `procedural.Clutter.element`)."""
        name = name or (f"hard_open_water_{self.seed}" if self.seed is not None else "hard_open_water")
        line = np.array([self.start, self.goal], dtype=float)
        count = max(1, math.ceil(np.hypot(*(line[1] - line[0])) / path_spacing))
        path = line[0] + (line[1] - line[0]) * np.linspace(0.0, 1.0, count + 1)[:, None]
        layout = TunnelLayout((), path, float(self.heading), np.asarray(self.bounds, dtype=float), False, line)
        return tunnel_element(layout, (), self.movers, WALL_THICKNESS, name, command, self.obstacles)


class _Redraw(Exception):
    """This draw failed a check: draw again."""


def _box(frame: tuple[np.ndarray, float], u: float, v: float, along: float, across: float, angle: float,
         name: str) -> Obstacle:
    """A box `along` x `across` [m] centred at (u, v) of a frame (origin, angle [rad]) and turned `angle` in it."""
    origin, theta = frame
    c, s = math.cos(theta), math.sin(theta)
    x, y = origin + np.array([c * u - s * v, s * u + c * v])
    return Obstacle(float(x), float(y), float(along), float(across), math.degrees(_wrap(theta + angle)), name)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def cup(random, frame, spec: HardSpec, name: str) -> list[Obstacle]:
    """Three walls open towards -u: the back across at u = depth / 2, the sides along at v = +-width / 2."""
    width, depth, t = random.uniform(*spec.cup_width), random.uniform(*spec.cup_depth), HARD_THICKNESS
    return [_box(frame, depth / 2 + t / 2, 0.0, t, width + 2 * t, 0.0, f"{name}_back"),
            _box(frame, 0.0, width / 2 + t / 2, depth, t, 0.0, f"{name}_left"),
            _box(frame, 0.0, -width / 2 - t / 2, depth, t, 0.0, f"{name}_right")]


def wedge(random, frame, spec: HardSpec, name: str) -> list[Obstacle]:
    """Two arms in a V whose apex points +u, open towards -u."""
    arm, half = random.uniform(*spec.wedge_arm), random.uniform(*spec.wedge_opening) / 2
    apex = arm * math.cos(half) / 2
    boxes = []
    for side, label in ((1.0, "left"), (-1.0, "right")):
        direction = np.array([-math.cos(half), side * math.sin(half)])
        centre = np.array([apex, 0.0]) + direction * (arm / 2 - HARD_THICKNESS / 2)
        boxes.append(_box(frame, *centre, arm + HARD_THICKNESS, HARD_THICKNESS,
                          math.atan2(direction[1], direction[0]), f"{name}_{label}"))
    return boxes


def wall(random, frame, spec: HardSpec, name: str) -> list[Obstacle]:
    """A long wall across the route at u = 0, ending `wall_open_end` past it on one side, maybe with a hook."""
    length, open_end = random.uniform(*spec.wall_length), random.uniform(*spec.wall_open_end)
    side = 1.0 if random.rand() < 0.5 else -1.0
    far = length - open_end
    boxes = [_box(frame, 0.0, side * (open_end - far) / 2, HARD_THICKNESS, length, 0.0, f"{name}_wall")]
    if random.rand() < spec.hook_chance:
        hook = random.uniform(*spec.hook)
        boxes.append(_box(frame, -hook / 2 + HARD_THICKNESS / 2, side * (open_end - HARD_THICKNESS / 2), hook,
                          HARD_THICKNESS, 0.0, f"{name}_hook"))
    return boxes


def clutter(random, frame, spec: HardSpec, name: str, taken: list) -> list[Obstacle]:
    """Small boxes in a field centred on the route, DENSE_GAP from each other and from `taken` polygons."""
    along, across = random.uniform(*spec.clutter_region, 2)
    boxes, shapes = [], []
    for k in range(random.randint(spec.clutter_count[0], spec.clutter_count[1] + 1)):
        hx, hy = random.uniform(*spec.clutter_half, 2)
        box = _box(frame, random.uniform(-along / 2, along / 2), random.uniform(-across / 2, across / 2),
                   2 * hx, 2 * hy, random.uniform(-math.pi, math.pi), f"{name}_{k}")
        shape = shapely.polygons(box.corners())
        if all(shape.distance(other) >= DENSE_GAP for other in [*shapes, *taken]):
            boxes.append(box)
            shapes.append(shape)
    return boxes


TRAPS = {"cup": cup, "wedge": wedge, "wall": wall}
"""The concave traps by name (clutter, which needs the polygons already placed, is drawn apart)."""


def _extent(kind: str, spec: HardSpec) -> float:
    """The most [m] a trap of `kind` reaches along the route either side of its centre."""
    return {"cup": spec.cup_depth[1] / 2 + HARD_THICKNESS, "wedge": spec.wedge_arm[1] / 2 + HARD_THICKNESS,
            "wall": spec.hook[1] + HARD_THICKNESS, "clutter": spec.clutter_region[1] / 2 + spec.clutter_half[1]}[kind]


def _random_point(random, bounds, margin: float) -> np.ndarray:
    return random.uniform(np.array(bounds[:2]) + margin, np.array(bounds[2:]) - margin)


def random_hard_layout(random: int | np.random.RandomState | None, bounds, spec: HardSpec = HARD_OBSTACLES,
                       goal_radius: float = 12.5) -> HardLayout:
    """A certified hard open-water arena in `bounds` drawn from `random` (a seed or a task's RandomState)."""
    random, seed = as_random(random)
    reason = ""
    for draw in range(1, spec.tries + 1):
        try:
            return _draw_layout(random, bounds, spec, goal_radius, seed, draw)
        except _Redraw as e:
            reason = str(e)
    raise RuntimeError(f"no certified hard arena in {spec.tries} draws (seed {seed}); the last failed: {reason}")


def _draw_layout(random, bounds, spec: HardSpec, goal_radius: float, seed, draw: int) -> HardLayout:
    bounds = tuple(float(b) for b in bounds)
    start = _random_point(random, bounds, EDGE_CLEARANCE)
    for _ in range(200):
        goal = _random_point(random, bounds, EDGE_CLEARANCE)
        if spec.goal_distance[0] <= np.hypot(*(goal - start)) <= spec.goal_distance[1]:
            break
    else:
        raise _Redraw("no goal at the drawn distance inside the map")
    heading = float(random.uniform(-math.pi, math.pi))
    length = float(np.hypot(*(goal - start)))
    direction = math.atan2(goal[1] - start[1], goal[0] - start[0])
    count = random.randint(spec.traps[0], spec.traps[1] + 1)
    kinds = [spec.kinds[random.randint(len(spec.kinds))] for _ in range(count)]
    spans = [_extent(kind, spec) for kind in kinds]
    room = length - 2 * END_CLEARANCE - sum(2 * s for s in spans) - TRAP_SPACING * (count - 1)
    while count > 1 and room < 0:  # traps in series: as many as fit on this route
        count -= 1
        kinds, spans = kinds[:count], spans[:count]
        room = length - 2 * END_CLEARANCE - sum(2 * s for s in spans) - TRAP_SPACING * (count - 1)
    slack = np.sort(random.uniform(0.0, max(room, 0.0), count))
    obstacles: list[Obstacle] = []
    shapes: list = []
    u = END_CLEARANCE
    for k, (kind, span) in enumerate(zip(kinds, spans, strict=True)):
        centre_u = u + (slack[k] - (slack[k - 1] if k else 0.0)) + span
        u = centre_u + span + TRAP_SPACING
        lateral = random.uniform(-0.25, 0.25) * (spec.cup_width[0] if kind == "cup" else 30.0)
        angle = direction + random.uniform(-spec.tilt, spec.tilt)
        origin = start + centre_u * np.array([math.cos(direction), math.sin(direction)]) \
            + lateral * np.array([-math.sin(direction), math.cos(direction)])
        frame = (origin, angle)
        boxes = clutter(random, frame, spec, f"t{k}", shapes) if kind == "clutter" \
            else TRAPS[kind](random, frame, spec, f"t{k}")
        new = [shapely.polygons(b.corners()) for b in boxes]
        if kind != "clutter" and any(a.distance(b) < DENSE_GAP for a in new for b in shapes):
            raise _Redraw(f"trap {k} ({kind}) comes nearer than {DENSE_GAP:.1f} m to another")
        obstacles += boxes
        shapes += new
    _check_clear(shapes, start, goal, bounds)
    movers = _movers(random, spec, start, goal, shapes)
    if not certified([b.corners() for b in obstacles], start, goal, bounds, goal_radius):
        raise _Redraw("no path keeps d_s from the obstacles (not certified)")
    return HardLayout(seed, start, heading, goal, bounds, tuple(obstacles), tuple(movers), tuple(kinds), draw)


def _check_clear(shapes, start, goal, bounds) -> None:
    """Every obstacle END_CLEARANCE from start and goal and EDGE_CLEARANCE inside the map."""
    if not shapes:
        return
    union = shapely.union_all(shapes)
    if union.distance(shapely.Point(start)) < END_CLEARANCE or union.distance(shapely.Point(goal)) < END_CLEARANCE:
        raise _Redraw("an obstacle is too near the start or the goal")
    x0, y0, x1, y1 = union.bounds
    if x0 < bounds[0] + EDGE_CLEARANCE or y0 < bounds[1] + EDGE_CLEARANCE or x1 > bounds[2] - EDGE_CLEARANCE \
            or y1 > bounds[3] - EDGE_CLEARANCE:
        raise _Redraw("an obstacle is too near the map's edge")


def _movers(random, spec: HardSpec, start, goal, shapes) -> list[MovingObstacle]:
    """Movers across the route or head-on along it, their tracks DENSE_GAP from every obstacle and
    END_CLEARANCE from start and goal; one that finds no place in 50 tries is left out."""
    along = (goal - start) / np.hypot(*(goal - start))
    normal = np.array([-along[1], along[0]])
    length = float(np.hypot(*(goal - start)))
    union = shapely.union_all(shapes) if shapes else None
    movers = []
    for k in range(random.randint(spec.movers[0], spec.movers[1] + 1)):
        radius, speed = random.uniform(*spec.mover_radius), round(random.uniform(*spec.mover_speed), 2)
        head_on = random.rand() < spec.head_on_chance
        for _ in range(50):
            half = random.uniform(*spec.mover_half_path)
            centre = start + random.uniform(0.2, 0.8) * length * along
            if head_on:
                centre = centre + random.uniform(-5.0, 5.0) * normal
                ends = (centre + half * along, centre - half * along)  # starts on the goal's side, coming on
            else:
                skew = random.uniform(-math.radians(30), math.radians(30))
                across = normal * math.cos(skew) + along * math.sin(skew)
                centre = centre + random.uniform(-0.5, 0.5) * half * across
                ends = (centre - half * across, centre + half * across)
                if random.rand() < 0.5:
                    ends = ends[::-1]
            track = shapely.LineString(ends).buffer(radius)
            ends_near = min(track.distance(shapely.Point(start)), track.distance(shapely.Point(goal)))
            if ends_near < END_CLEARANCE:
                continue
            if union is not None and track.distance(union) < DENSE_GAP:
                continue
            (x0, y0), (x1, y1) = ends
            movers.append(MovingObstacle(float(x0), float(y0), float(x1), float(y1), float(speed), float(radius),
                                         str(k)))
            break
    return movers


def certify(polygons, start, goal, bounds, goal_radius: float, clearance: float = CERTIFY_CLEARANCE,
            walls=()) -> np.ndarray | None:
    """The oracle's certificate: a grid path (m, 2) from `start` to within `goal_radius` of `goal` keeping
    `clearance` [m] from every polygon (k, 2) and from the map's edge, or None when there is none."""
    area, cost = _certificate_cost(polygons, bounds, clearance, walls)
    return grid.shortest_path(area, cost, start, goal, goal_radius)


def certified(polygons, start, goal, bounds, goal_radius: float, clearance: float = CERTIFY_CLEARANCE,
              walls=()) -> bool:
    """Whether `certify` would return a certificate (the same arguments), decided without searching the path
    (`grid.reaches`): what the hard tier's draws check at every reset."""
    area, cost = _certificate_cost(polygons, bounds, clearance, walls)
    return grid.reaches(area, cost, start, goal, goal_radius)


def _certificate_cost(polygons, bounds, clearance: float, walls) -> tuple[grid.Grid, np.ndarray]:
    """The certificate's grid over `bounds` and its cost field: the polygons and walls rasterised, the map's
    edge occupied, and `clearance` [m] the hard clearance."""
    area = grid.Grid.covering(bounds, grid.CELL)
    occupied = grid.rasterise(area, [*polygons, *walls])
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    return area, grid.cost_field(grid.clearance(area, occupied), clearance)


# --- tunnels ------------------------------------------------------------------------------------------


def hard_tunnel_spec(standard: TunnelSpec) -> TunnelSpec:
    """The tunnel task's hard tier from its standard spec: wide tunnels (60-100 m), at most one box obstacle
    beside the traps, one or two movers up to 1 m/s across and 0.3-1 m/s along the axis."""
    return dataclasses.replace(standard, width=(60.0, 100.0), length=(400.0, 1000.0), obstacles=(0, 1),
                               movers=(1, 2), crossing_speed=(0.3, 1.0), along_speed=(0.3, 1.0))


TUNNEL_TRAPS: tuple[int, int] = (1, 3)
"""Traps placed on a hard tunnel's straights (fewer when they do not fit)."""


def random_hard_tunnel(random: int | np.random.RandomState | None, standard: TunnelSpec,
                       tries: int = 30) -> ProceduralTunnel:
    """A certified hard tunnel: a wide tunnel of `hard_tunnel_spec(standard)` with traps on its straights,
    concave towards the start, each leaving a way past of at least DENSE_GAP + passing_gap() / 2."""
    random, seed = as_random(random)
    spec = hard_tunnel_spec(standard)
    reason = ""
    for draw in range(1, tries + 1):
        tunnel = random_tunnel(random, spec)
        try:
            traps = _tunnel_traps(random, tunnel)
        except _Redraw as e:
            reason = str(e)
            continue
        return dataclasses.replace(tunnel, seed=seed, unknown=tunnel.unknown + tuple(traps), draws=draw)
    raise RuntimeError(f"no certified hard tunnel in {tries} draws (seed {seed}); the last failed: {reason}")


def _tunnel_traps(random, tunnel: ProceduralTunnel) -> list[Obstacle]:
    layout, width = tunnel.layout, tunnel.width
    path = layout.path
    s = arc_lengths(path)
    heading = np.arctan2(*np.diff(path, axis=0).T[::-1])
    taken = [shapely.polygons(o.corners()) for o in tunnel.unknown]
    taken += [shapely.LineString([(m.x0, m.y0), (m.x1, m.y1)]).buffer(m.radius) for m in tunnel.movers]
    gap = DENSE_GAP + passing_gap() / 2
    traps: list[Obstacle] = []
    wanted = random.randint(TUNNEL_TRAPS[0], TUNNEL_TRAPS[1] + 1)
    for k in range(wanted):
        for _ in range(40):
            i = random.randint(len(path) - 1)
            if not (120.0 <= s[i] <= s[-1] - 120.0):
                continue
            window = (s >= s[i] - 50.0) & (s <= s[i] + 50.0)
            turn = np.abs(np.angle(np.exp(1j * (heading[window[:-1]] - heading[i]))))
            if turn.size == 0 or turn.max() > math.radians(8.0):
                continue  # a straight only
            kind = ("cup", "wedge", "wall")[random.randint(3)]
            try:
                boxes = _tunnel_trap(random, kind, path[i], heading[i], width, gap, f"trap{k}")
            except _Redraw:
                continue
            shapes = [shapely.polygons(b.corners()) for b in boxes]
            if any(a.distance(b) < gap for a in shapes for b in taken):
                continue
            traps += boxes
            taken += shapes
            break
    if not traps:
        raise _Redraw("no straight holds a trap")
    try:
        check_unknown(layout, [*tunnel.unknown, *traps], source="hard tunnel")
    except ValueError as e:
        raise _Redraw(str(e)) from None
    walls = [box_polygon(*centre, *half, yaw) for centre, half, yaw in
             (wall_box(w, WALL_THICKNESS) for w in layout.walls)]
    wall_outlines = [np.asarray(w.exterior.coords)[:-1] for w in walls]
    if not certified([b.corners() for b in [*tunnel.unknown, *traps]], path[0], path[-1], layout.bounds, 2.0,
                     walls=wall_outlines):
        raise _Redraw("no path keeps d_s from the walls and traps (not certified)")
    return traps


def _tunnel_trap(random, kind: str, point, heading: float, width: float, gap: float, name: str) -> list[Obstacle]:
    """A trap across a tunnel `width` wide at `point` facing the start, leaving at least `gap` on one side."""
    room = width - gap  # the most a trap may span across the tunnel
    side = 1.0 if random.rand() < 0.5 else -1.0
    depth = random.uniform(15.0, MAX_TUNNEL_TRAP_DEPTH - HARD_THICKNESS)
    if kind == "wall":  # from one wall across the axis, the gap at the other end
        length = random.uniform(width / 2 + 5.0, room)
        frame = (np.asarray(point, dtype=float), heading)
        return [_box(frame, 0.0, side * (width / 2 - length / 2), HARD_THICKNESS, length, 0.0, f"{name}_wall")]
    span = random.uniform(0.4, 0.8) * room
    low, high = gap - width / 2 + span / 2, width / 2 - span / 2  # `gap` free on one side, inside the tunnel
    mouth = span / 2 - HARD_THICKNESS - 2.0  # the axis runs into the opening
    low, high = max(low, -mouth), min(high, mouth)
    if high < low:
        raise _Redraw(f"a {kind} {span:.0f} m wide leaves no way past in a {width:.0f} m tunnel")
    lateral = side * random.uniform(low, high)
    frame = (np.asarray(point, dtype=float) + lateral * np.array([-math.sin(heading), math.cos(heading)]), heading)
    if kind == "cup":
        spec = HardSpec(cup_width=(span - 2 * HARD_THICKNESS,) * 2, cup_depth=(depth,) * 2)
        return cup(random, frame, spec, name)
    half = math.radians(random.uniform(30.0, 55.0))
    arm = min(span / 2 / math.sin(half), depth / math.cos(half))
    spec = HardSpec(wedge_arm=(arm, arm), wedge_opening=(2 * half, 2 * half))
    return wedge(random, frame, spec, name)
