"""Procedural arenas: random tunnels and open-water clutter, drawn from a seed or a task's `random`.

Tunnels (`random_tunnel`, Sec. 4.3's task on maps never seen in training). A centreline of straights
and circular bends, `TunnelSpec.width` wide and `TunnelSpec.length` long, is laid out by
`auv_mj.arenas.tunnels.layout_tunnel` (the geometry of `auv-mj tunnel`), placed anywhere in
+-`TunnelSpec.placement` m, turned any way and run in either direction, so that nothing about a map is
in its absolute coordinates. Inside it stand unknown obstacles (`unknown_*`, boxes the global path
runs through or past) and movers crossing the axis or moving along it (`mover_*`).

Open water (`random_boxes`, `random_crossers`: the `obstacles` and `moving_obstacles` tasks' random
layouts, Tables 7-8 at random): boxes from `ClutterSpec.sizes` near the straight route from start to
goal, and movers crossing it; `Clutter.element()` writes one as an arena file.

How a tunnel is kept feasible, by construction:
- every bend has a radius of at least `turn_radius` + width / 2, so that every lane across the tunnel,
  the inner wall included, curves no tighter than the vehicle's least turn radius (`TunnelSpec`);
- parts of the centreline more than half a turn of the sharpest bend apart stay a width, two walls and
  `SEPARATION` apart, so the tunnel never runs into or alongside itself;
- an unknown obstacle stands on a straight (or a gentle bend), juts out from one wall or floats clear
  of both, comes within d_s of the path (where the width leaves room for that), and leaves at least one
  gap of `passing_gap()` (d_s to both sides of a hull turned any way, plus `LANE` each side) while
  reaching at most `obstacle_reach` past the axis;
- a mover moving along the axis keeps `passing_gap()` free beside its whole track; a crossing mover is
  slower than the vehicle; obstacles and movers are `SPACING` apart along the axis and `END_CLEARANCE`
  from the start and the goal;
and by checks, redrawing (at most `TunnelSpec.tries` times, deterministically) when one fails:
- `layout_tunnel` validates the walls (no folds or crossings; the path d_s from every wall);
- `auv_mj.arenas.tunnels.check_unknown` asks Shapely for water joining start and goal that keeps d_s from every
  wall, unknown obstacle and along-axis mover track, with the hull turned any way.
Every arena passes `auv-mj check-arena`, and the classical planner `los-avoid` gets through (measured
with `auv-mj eval --task tunnel --arena random`; see docs/evaluation.md).

Seeds. An arena is a function of its seed: `random_tunnel(seed)` draws from `RandomState(seed)`, as
a task seeded `seed` does for its first episode, so `auv-mj tunnel --random S` writes the arena of
`auv-mj eval --arena random --seed S`'s first episode. `SEEDS` splits seeds into training, validation
and test ranges that are never crossed.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from auv_mj.arenas.arena import MAX_EXTENT, MAX_MOVER_SPEED
from auv_mj.arenas.tunnels import (
    MAX_MOVER_RADIUS,
    MAX_OBSTACLE_SIZE,
    MAX_TUNNEL_LENGTH,
    MAX_WIDTH,
    WALL_THICKNESS,
    MovingObstacle,
    Obstacle,
    TunnelLayout,
    check_unknown,
    layout_tunnel,
    min_width,
    path_clearance,
    route_clearance,
    tunnel_element,
)
from auv_mj.seeds import SEEDS, seed_split  # noqa: F401  (re-exported: the arenas' seed ranges)

LANE = 2.0
"""Room to steer [m] on either side of the lane past an obstacle, beyond d_s from both sides of it."""
SEPARATION = 4.0
"""Least water [m] between the walls of two parts of a tunnel that are not neighbours along it."""
SPACING = 60.0
"""Least distance [m] along the axis between two unknown obstacles or movers: one encounter at a time."""
END_CLEARANCE = 60.0
"""Least distance [m] along the axis from the start and from the goal to an obstacle or a mover."""
LEAD = (40.0, 100.0)
"""Length range [m] of the straight leading out of the start and into the goal."""
STRAIGHT = (20.0, 150.0)
"""Length range [m] of a straight between two bends."""
STRAIGHT_CHANCE = 0.6
"""Chance that a straight comes before a bend (else bends run into each other: waves, S-bends)."""
BEND_ANGLE = (math.radians(20.0), math.pi)
"""Range of the angle a bend turns through [rad]: a slight kink up to a U-turn."""
GENTLE_RADIUS = 400.0
"""Largest bend radius drawn [m]; radii are log-uniform from the least one up to this."""
HEADING_SPREAD = math.radians(100.0)
"""The centreline's heading stays within this of its first heading [rad]: it cannot spiral into itself."""
ARC_STEP = (math.radians(5.0), 4.0)
"""A bend's centreline points are at most this far apart: angle [rad], chord [m]."""
OBSTACLE_SPAN_MARGIN = 15.0
"""An obstacle stands this far [m] along the axis inside a straight or gentle bend: not in a sharp bend."""
OBSTACLE_BEND_RADIUS = 150.0
"""Bends at least this wide [m] count as straight for placing obstacles and crossing movers."""
MOVER_WALL_GAP = 1.0
"""Least water [m] between a mover's track and a wall."""
MOVER_SKEW = math.radians(30.0)
"""A crossing mover's track turns up to this far from square to the axis [rad]."""
ISLAND_CHANCE = 0.4
"""Chance that an obstacle floats clear of both walls, where the width leaves two passing gaps."""


def passing_gap() -> float:
    """Least gap [m] beside an unknown obstacle or a mover's track along the axis: d_s to both sides of
    a hull turned any way (`auv_mj.arenas.tunnels.route_clearance`), and LANE to spare on either side."""
    return 2.0 * (route_clearance() + LANE)


MAX_COUNT = 20
"""Most unknown obstacles or movers a spec may ask for."""
MAX_TRIES = 1000
"""Most draws a spec may allow before it gives up."""


def _real(value, whole: bool = False) -> bool:
    """A finite real number (a whole one if `whole`), not a bool."""
    kinds = (int, np.integer) if whole else (int, float, np.integer, np.floating)
    return isinstance(value, kinds) and not isinstance(value, (bool, np.bool_)) and math.isfinite(value)


@dataclass(frozen=True)
class TunnelSpec:
    """What random tunnels are drawn from (ranges are (low, high), counts inclusive)."""

    turn_radius: float
    """The vehicle's least turn radius [m]: the planning tasks' top speed over their heading-command rate
    (`auv_mj.tasks.tunnel.least_turn_radius`). The sharpest bend is turn_radius + width / 2."""
    width: tuple[float, float] = (20.0, 60.0)
    """Tunnel width [m]."""
    length: tuple[float, float] = (300.0, 1000.0)
    """Length of the centreline [m]."""
    obstacles: tuple[int, int] = (1, 3)
    """Number of unknown obstacles."""
    movers: tuple[int, int] = (1, 2)
    """Number of movers."""
    obstacle_length: tuple[float, float] = (4.0, 20.0)
    """An obstacle's length along the axis [m]."""
    obstacle_reach: float = 4.0
    """How far past the axis an obstacle may reach [m]: the vehicle passes it within the planning tasks'
    PASS_CORRIDOR of the path, so the sub-goals it goes around die (tests check the two agree)."""
    mover_radius: tuple[float, float] = (1.0, 3.0)
    """Radius of a mover [m]."""
    crossing_speed: tuple[float, float] = (0.05, 0.25)
    """Speed of a mover crossing the axis [m/s]."""
    along_speed: tuple[float, float] = (0.1, 0.4)
    """Speed of a mover going up and down the axis [m/s]."""
    along_length: tuple[float, float] = (30.0, 100.0)
    """Length of an along-axis mover's track [m]."""
    placement: float = 1000.0
    """The tunnel's centre lies anywhere in [-placement, placement]^2 [m]."""
    tries: int = 50
    """Draws before giving up (each failed draw is redrawn from the same random stream)."""

    def __post_init__(self):
        limits = {"width": MAX_WIDTH, "length": MAX_TUNNEL_LENGTH, "obstacles": MAX_COUNT, "movers": MAX_COUNT,
                  "obstacle_length": MAX_OBSTACLE_SIZE, "mover_radius": MAX_MOVER_RADIUS,
                  "crossing_speed": MAX_MOVER_SPEED, "along_speed": MAX_MOVER_SPEED, "along_length": MAX_TUNNEL_LENGTH}
        for name, high in limits.items():
            value = getattr(self, name)
            whole = name in ("obstacles", "movers")
            if not (isinstance(value, tuple) and len(value) == 2 and all(_real(v, whole) for v in value)
                    and 0 <= value[0] <= value[1] <= high):
                raise ValueError(f"TunnelSpec.{name} = {value!r:.60}: expected 0 <= low <= high <= {high:g}"
                                 f"{', whole numbers' if whole else ', finite'}")
        scalars = (("turn_radius", MAX_EXTENT, False), ("placement", MAX_EXTENT / 2, False),
                   ("obstacle_reach", MAX_WIDTH, False), ("tries", MAX_TRIES, True))
        for name, high, whole in scalars:
            value = getattr(self, name)
            if not (_real(value, whole) and 0 <= value <= high):
                raise ValueError(f"TunnelSpec.{name} = {value!r:.40}: expected a {'whole ' if whole else ''}number "
                                 f"in [0, {high:g}]")
        if self.width[0] < min_width():
            raise ValueError(f"TunnelSpec.width = {self.width}: below the narrowest tunnel, {min_width():.2f} m")
        if self.length[0] < 2 * END_CLEARANCE:
            raise ValueError(f"TunnelSpec.length = {self.length}: shorter than the {2 * END_CLEARANCE:g} m kept "
                             "clear at the start and the goal")
        if not (self.turn_radius > 0 and self.placement >= 0 and self.tries >= 1 and self.obstacle_reach >= 0):
            raise ValueError("TunnelSpec: turn_radius must be positive, placement and obstacle_reach >= 0, "
                             "tries >= 1")


@dataclass(frozen=True)
class ProceduralTunnel:
    """A drawn tunnel: its centreline, width, unknown obstacles, movers and laid-out walls."""

    seed: int | None
    """The seed it was drawn from (None when drawn from a running random stream)."""
    centreline: np.ndarray
    """(n, 2) centreline points [m], start first."""
    width: float
    unknown: tuple[Obstacle, ...]
    movers: tuple[MovingObstacle, ...]
    layout: TunnelLayout = field(repr=False)
    draws: int = 1
    """How many draws it took (the ones before failed a check)."""

    @property
    def length(self) -> float:
        """Length of the centreline [m]."""
        return float(np.sum(np.hypot(*np.diff(self.centreline, axis=0).T)))

    def element(self, name: str | None = None, command: str | None = None) -> ET.Element:
        """The arena MJCF element (`auv_mj.arenas.tunnels.tunnel_element`)."""
        name = name or (f"random_tunnel_{self.seed}" if self.seed is not None else "random_tunnel")
        return tunnel_element(self.layout, (), self.movers, WALL_THICKNESS, name, command, self.unknown)


class _Redraw(Exception):
    """This draw failed a check: draw again. `fields` are the TunnelSpec fields that the failure weighs on."""

    def __init__(self, message: str, fields: tuple[str, ...] = ("width", "length")):
        super().__init__(message)
        self.fields = fields


class InfeasibleSpec(RuntimeError):
    """A TunnelSpec gave no feasible tunnel in `tries` draws; `fields` are the ones that conflict."""

    def __init__(self, message: str, fields: tuple[str, ...]):
        super().__init__(message)
        self.fields = fields


PROBE_SEED = 0
"""The seed `check_feasible` draws a spec's trial tunnel from."""


def as_random(random: int | np.random.RandomState | None) -> tuple[np.random.RandomState, int | None]:
    """A RandomState from a seed (kept), a RandomState (used as is) or None (fresh entropy)."""
    if isinstance(random, np.random.RandomState):
        return random, None
    if random is None:
        return np.random.RandomState(), None
    seed = int(random)
    return np.random.RandomState(seed), seed


def random_tunnel(random: int | np.random.RandomState | None, spec: TunnelSpec) -> ProceduralTunnel:
    """A random tunnel of `spec`, drawn from `random` (a seed or a task's RandomState; see module doc)."""
    random, seed = as_random(random)
    failure = _Redraw("")
    for draw in range(1, spec.tries + 1):
        try:
            return _draw_tunnel(random, spec, seed, draw)
        except _Redraw as e:
            failure = e
    origin = f"seed {seed}" if seed is not None else "from a running random stream"
    raise InfeasibleSpec(f"no feasible tunnel in {spec.tries} draws ({origin}); the last failed: {failure} "
                         f"(weighs on {', '.join(failure.fields)})", failure.fields)


@functools.lru_cache(maxsize=64)
def check_feasible(spec: TunnelSpec) -> None:
    """Refuses (ValueError naming the conflicting fields and their values) a spec that gives no tunnel from
    PROBE_SEED in `spec.tries` draws, so that a task can refuse it before its first episode rather than
    fail in a reset. Cached: a spec is drawn once per process."""
    try:
        random_tunnel(PROBE_SEED, spec)
    except InfeasibleSpec as e:
        values = ", ".join(f"{name}={_shown_field(getattr(spec, name))}" for name in e.fields)
        raise ValueError(f"arena_spec: {values} conflict: {' '.join(str(e).split())}") from None


def _shown_field(value) -> str:
    return f"[{value[0]:g}, {value[1]:g}]" if isinstance(value, tuple) else f"{value:g}"


def _draw_tunnel(random: np.random.RandomState, spec: TunnelSpec, seed: int | None, draw: int) -> ProceduralTunnel:
    width = float(random.uniform(*spec.width))
    length = float(random.uniform(*spec.length))
    least_radius = spec.turn_radius + width / 2
    local, straights = _centreline(random, length, least_radius)
    _check_separation(local, width, least_radius)
    angle, reverse = random.uniform(-math.pi, math.pi), random.rand() < 0.5
    centre = random.uniform(-spec.placement, spec.placement, 2)
    if reverse:
        total = _Axis(local).length
        local = local[::-1]
        straights = [(total - b, total - a, r) for a, b, r in straights[::-1]]
    c, s = math.cos(angle), math.sin(angle)
    world = local @ np.array([[c, s], [-s, c]])
    world += centre - (world.min(axis=0) + world.max(axis=0)) / 2
    source = f"random tunnel (seed {seed}, draw {draw})"
    try:
        layout = layout_tunnel(world, width)
    except ValueError as e:
        raise _Redraw(str(e), ("width", "length")) from None
    axis = _Axis(world)
    unknown, movers, tracks = _place(random, spec, axis, straights, width)
    try:  # the along-axis movers' tracks, as boxes, must leave a way past as the obstacles do
        check_unknown(layout, [*unknown, *tracks], source=source)
    except ValueError as e:
        raise _Redraw(str(e), ("width", "obstacles", "obstacle_length", "movers", "along_length")) from None
    return ProceduralTunnel(seed, world, width, tuple(unknown), tuple(movers), layout, draw)


def _centreline(random: np.random.RandomState, length: float,
                least_radius: float) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
    """Points of a centreline from (0, 0) heading +x, and its straight-enough stretches (s0, s1, radius)."""
    lead_in, lead_out = random.uniform(*LEAD, 2)
    pieces = [(lead_in, 0.0)]  # (length, signed curvature)
    heading, used = 0.0, lead_in
    while used < length - lead_out - 1.0:
        room = length - lead_out - used
        if random.rand() < STRAIGHT_CHANCE:
            straight = min(random.uniform(*STRAIGHT), room)
            pieces.append((straight, 0.0))
            used += straight
            room -= straight
            if room <= 1.0:
                break
        radius = least_radius * (GENTLE_RADIUS / least_radius) ** random.rand() if least_radius < GENTLE_RADIUS \
            else least_radius
        turn = random.uniform(*BEND_ANGLE)
        sign = 1.0 if random.rand() < 0.5 else -1.0
        if abs(heading + sign * turn) > HEADING_SPREAD:
            sign = -sign
            turn = min(turn, HEADING_SPREAD - sign * heading)
        turn = min(turn, room / radius)
        pieces.append((radius * turn, sign / radius))
        heading += sign * turn
        used += radius * turn
    pieces.append((length - used, 0.0))
    points, bounds, heading = [np.zeros(2)], [], 0.0
    for piece, curvature in pieces:
        if piece <= 1e-9:
            continue
        first = len(points) - 1
        if curvature == 0.0:
            steps = np.array([piece])
        else:
            count = max(1, math.ceil(max(abs(piece * curvature) / ARC_STEP[0], piece / ARC_STEP[1])))
            steps = np.full(count, piece / count)
        for step in steps:  # exact points on the circle: chords at the mean heading of their arc
            turn = step * curvature
            chord = step if turn == 0.0 else 2.0 * math.sin(turn / 2) / curvature
            middle = heading + turn / 2
            points.append(points[-1] + chord * np.array([math.cos(middle), math.sin(middle)]))
            heading += turn
        bounds.append((first, len(points) - 1, math.inf if curvature == 0.0 else 1.0 / abs(curvature)))
    points = np.array(points)
    s = _Axis(points).s
    return points, [(s[i], s[j], radius) for i, j, radius in bounds if radius >= OBSTACLE_BEND_RADIUS]


def _check_separation(points: np.ndarray, width: float, least_radius: float) -> None:
    """Parts of the centreline more than half a turn of the sharpest bend apart keep a width, two walls
    and SEPARATION apart (nearer parts are neighbours: a bend keeps them apart by its radius)."""
    axis = _Axis(points)
    dense = axis.resample(2.0)
    s = np.linspace(0.0, axis.length, len(dense))
    far = np.abs(s[:, None] - s[None]) >= math.pi * least_radius
    gap = np.hypot(*(dense[:, None] - dense[None]).transpose(2, 0, 1))
    if np.any(far & (gap < width + 2 * WALL_THICKNESS + SEPARATION)):
        raise _Redraw("the centreline comes back alongside itself", ("width", "length"))


class _Axis:
    """Arc-length parametrisation of a polyline: point, tangent angle and left normal at s [m]."""

    def __init__(self, points: np.ndarray):
        self.points = points
        self.s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        self.length = float(self.s[-1])

    def point(self, s: float) -> np.ndarray:
        return np.array([np.interp(s, self.s, self.points[:, 0]), np.interp(s, self.s, self.points[:, 1])])

    def angle(self, s: float) -> float:
        k = int(np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.points) - 2))
        d = self.points[k + 1] - self.points[k]
        return math.atan2(d[1], d[0])

    def frame(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Point, unit tangent, unit left normal and tangent angle [rad] at s."""
        angle = self.angle(s)
        tangent = np.array([math.cos(angle), math.sin(angle)])
        return self.point(s), tangent, np.array([-tangent[1], tangent[0]]), angle

    def resample(self, spacing: float) -> np.ndarray:
        at = np.linspace(0.0, self.length, max(2, math.ceil(self.length / spacing) + 1))
        return np.column_stack([np.interp(at, self.s, self.points[:, 0]), np.interp(at, self.s, self.points[:, 1])])


def _bend(length: float, radius: float) -> float:
    """How far [m] the axis, a bend of `radius` drawn in chords of ARC_STEP, strays from the ends of a box
    `length` long set along the chord at its middle: the bend's sagitta and the chord's tilt."""
    return (length / 2) ** 2 / (2 * radius) + (length / 2) * ARC_STEP[1] / (2 * radius)


def _place(random: np.random.RandomState, spec: TunnelSpec, axis: _Axis, stretches: list, width: float):
    """Unknown obstacles and movers on straight-enough stretches, SPACING apart; raises _Redraw when one
    does not fit. Returns the obstacles, the movers and the boxes swept by the along-axis movers."""
    taken: list[tuple[float, float]] = []
    gap = passing_gap()

    def spot(span: float, straight_only: bool = False) -> tuple[float, float]:
        """A free place s [m] along the axis for something `span` long, and the radius of the axis there."""
        usable = [(max(a + OBSTACLE_SPAN_MARGIN, END_CLEARANCE) + span / 2,
                   min(b - OBSTACLE_SPAN_MARGIN, axis.length - END_CLEARANCE) - span / 2, radius)
                  for a, b, radius in stretches if not straight_only or math.isinf(radius)]
        usable = [(a, b, radius) for a, b, radius in usable if b > a]
        if not usable:
            raise _Redraw("no straight long enough for an obstacle or a mover",
                          ("length", "obstacle_length", "along_length"))
        sizes = np.array([b - a for a, b, _ in usable])
        for _ in range(20):
            a, b, radius = usable[random.choice(len(usable), p=sizes / sizes.sum())]
            s = random.uniform(a, b)
            if all(s + span / 2 + SPACING <= lo or s - span / 2 - SPACING >= hi for lo, hi in taken):
                taken.append((s - span / 2, s + span / 2))
                return s, radius
        raise _Redraw("no room for every obstacle and mover", ("length", "obstacles", "movers"))

    unknown = []
    for k in range(random.randint(spec.obstacles[0], spec.obstacles[1] + 1)):
        along = random.uniform(*spec.obstacle_length)
        s, radius = spot(along)
        point, _, normal, angle = axis.frame(s)
        bend = _bend(along, radius)
        reach = min(spec.obstacle_reach, width / 2 - gap) - bend  # how far past the axis it may go
        island_room = reach  # how far either side of the axis a free-standing one may go
        if island_room >= 1.0 and random.rand() < ISLAND_CHANCE:
            half = random.uniform(1.0, island_room)
            centre = random.uniform(-min(half, island_room - half), min(half, island_room - half))
            lateral = 2 * half
        else:
            side = 1.0 if random.rand() < 0.5 else -1.0
            tip = random.uniform(min(reach, -path_clearance()), reach)  # within d_s of the path if it can
            lateral = width / 2 + WALL_THICKNESS / 2 + tip  # from inside the wall to the tip
            centre = side * (width / 2 + WALL_THICKNESS / 2 - lateral / 2)
        if lateral <= 0:
            raise _Redraw(f"a {width:.1f} m wide tunnel leaves no {gap:.2f} m passing gap beside an obstacle",
                          ("width", "obstacles"))
        x, y = point + centre * normal
        unknown.append(Obstacle(float(x), float(y), float(along), float(lateral), math.degrees(angle), f"{k}"))

    movers, tracks = [], []
    for k in range(random.randint(spec.movers[0], spec.movers[1] + 1)):
        radius = random.uniform(*spec.mover_radius)
        along_room = (width - gap - MOVER_WALL_GAP) / 2 - radius  # spare lateral room of an along mover
        if random.rand() < 0.5 and along_room > 0:
            track = random.uniform(*spec.along_length)
            s, _ = spot(track + 2 * radius, straight_only=True)
            point, tangent, normal, angle = axis.frame(s)
            side = 1.0 if random.rand() < 0.5 else -1.0
            offset = side * (width / 2 - MOVER_WALL_GAP - radius - random.uniform(0.0, along_room))
            ends = [point + offset * normal - tangent * track / 2, point + offset * normal + tangent * track / 2]
            speed = round(random.uniform(*spec.along_speed), 2)
            middle = point + offset * normal
            tracks.append(Obstacle(float(middle[0]), float(middle[1]), track + 2 * radius, 2 * radius,
                                   math.degrees(angle)))
        else:
            skew = random.uniform(-MOVER_SKEW, MOVER_SKEW)
            half = (width / 2 - MOVER_WALL_GAP - radius) / math.cos(skew)
            s, _ = spot(2 * (half * abs(math.sin(skew)) + radius))
            point, tangent, normal, _ = axis.frame(s)
            direction = normal * math.cos(skew) + tangent * math.sin(skew)
            ends = [point - half * direction, point + half * direction]
            speed = round(random.uniform(*spec.crossing_speed), 2)
        if random.rand() < 0.5:
            ends = ends[::-1]
        (x0, y0), (x1, y1) = ends
        movers.append(MovingObstacle(float(x0), float(y0), float(x1), float(y1), float(speed), float(radius),
                                     f"{k}"))
    return unknown, movers, tracks


# --- open water ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ClutterSpec:
    """What random open-water clutter is drawn from: the `obstacles` and `moving_obstacles` tasks'
    random layouts (Tables 7-8's scale), placed along the straight route from start to goal."""

    sizes: tuple[tuple[float, float], ...] = ((20.0, 8.0), (15.0, 6.0), (12.0, 12.0), (25.0, 5.0), (10.0, 18.0),
                                              (8.0, 8.0), (18.0, 10.0), (6.0, 14.0))
    """Half-sizes (x, y) [m] of the boxes: the pool a layout draws from (Fig. 10's scale)."""
    obstacles: tuple[int, int] = (3, 8)
    """Number of boxes (inclusive; Table 7 has 6 and 7; at most one of each size)."""
    route_spread: float = 80.0
    """Boxes lie within this distance [m] of the straight start-goal line ..."""
    clearance: float = 30.0
    """... keep this far [m] from the start and the goal (a 12.5 m target area plus d0) ..."""
    gap: float = 15.0
    """... and this far from each other [m] (bounding circles), leaving passages wider than 2 d_s."""
    movers: tuple[int, int] = (1, 4)
    """Number of moving obstacles (inclusive; Table 8 has 2 and 4)."""
    mover_radius: float = 5.0
    """Radius of the moving obstacles [m] (as in the Table 8 arenas)."""
    mover_speed: tuple[float, float] = (0.1, 0.2)
    """Speeds of the moving obstacles [m/s] (Table 8)."""
    mover_half_path: tuple[float, float] = (20.0, 60.0)
    """Half-length of a mover's ping-pong path [m]."""
    mover_crossing: tuple[float, float] = (0.25, 0.75)
    """A mover's path crosses the route at this fraction of its length ..."""
    mover_skew: float = math.radians(30)
    """... at up to this angle from square to it [rad]."""
    tries: int = 200
    """Rejection-sampling attempts per obstacle; one that finds no place is left out."""


@dataclass(frozen=True)
class Box:
    """A box of open-water clutter: `ClutterSpec.sizes[size]` centred at `centre`, turned `yaw` [rad]."""

    size: int
    centre: np.ndarray
    yaw: float

    def obstacle(self, spec: ClutterSpec, name: str = "") -> Obstacle:
        """As an `auv_mj.arenas.tunnels.Obstacle` (angle in degrees)."""
        hx, hy = spec.sizes[self.size]
        return Obstacle(float(self.centre[0]), float(self.centre[1]), 2 * hx, 2 * hy, math.degrees(self.yaw),
                        name)


@dataclass(frozen=True)
class Clutter:
    """An open-water layout: start pose, goal, map bounds, boxes and movers (all unknown to the vehicle)."""

    start: np.ndarray
    heading: float
    goal: np.ndarray
    bounds: tuple[float, float, float, float]
    boxes: tuple[Box, ...] = ()
    movers: tuple[MovingObstacle, ...] = ()
    spec: ClutterSpec = field(default_factory=ClutterSpec, repr=False)

    def element(self, name: str = "random_open_water", command: str | None = None,
                path_spacing: float = 10.0) -> ET.Element:
        """An arena MJCF element of the layout: the boxes as unknown obstacles, the movers, and the
        straight line from start to goal as its global path (what `los-avoid` follows in open water)."""
        line = np.array([self.start, self.goal], dtype=float)
        count = max(1, math.ceil(np.hypot(*(line[1] - line[0])) / path_spacing))
        path = line[0] + (line[1] - line[0]) * np.linspace(0.0, 1.0, count + 1)[:, None]
        layout = TunnelLayout((), path, float(self.heading), np.asarray(self.bounds, dtype=float), False, line)
        unknown = [box.obstacle(self.spec, str(k)) for k, box in enumerate(self.boxes)]
        return tunnel_element(layout, (), self.movers, WALL_THICKNESS, name, command, unknown)


def _segment_distance(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from `point` to the segment a-b [m]."""
    d = b - a
    t = min(max(float(np.dot(point - a, d) / max(float(np.dot(d, d)), 1e-12)), 0.0), 1.0)
    return float(np.hypot(*(a + t * d - point)))


def random_boxes(random: np.random.RandomState, start: np.ndarray, goal: np.ndarray, bounds,
                 spec: ClutterSpec = ClutterSpec()) -> tuple[Box, ...]:
    """Boxes of `spec.sizes` near the straight route, clear of start, goal and each other (rejection
    sampling; a box that finds no place in `spec.tries` draws is left out)."""
    along = goal - start
    normal = np.array([-along[1], along[0]]) / np.hypot(*along)
    count = random.randint(spec.obstacles[0], spec.obstacles[1] + 1)
    placed: list[tuple[np.ndarray, float]] = []
    boxes = []
    for i in random.permutation(len(spec.sizes))[:count]:
        radius = float(np.hypot(*spec.sizes[i]))
        for _ in range(spec.tries):
            centre = (start + random.uniform(0.15, 0.85) * along
                      + random.uniform(-spec.route_spread, spec.route_spread) * normal)
            inside = (bounds[0] + radius <= centre[0] <= bounds[2] - radius
                      and bounds[1] + radius <= centre[1] <= bounds[3] - radius)
            nearest_end = min(np.hypot(*(centre - start)), np.hypot(*(centre - goal)))
            clear = nearest_end >= radius + spec.clearance
            apart = all(np.hypot(*(centre - c)) >= radius + r + spec.gap for c, r in placed)
            if inside and clear and apart:
                break
        else:
            continue
        placed.append((centre, radius))
        boxes.append(Box(int(i), centre, float(random.uniform(-math.pi, math.pi))))
    return tuple(boxes)


def random_crossers(random: np.random.RandomState, start: np.ndarray, goal: np.ndarray,
                    spec: ClutterSpec = ClutterSpec()) -> tuple[MovingObstacle, ...]:
    """Movers on ping-pong paths across the straight route, clear of start and goal; mover k is named
    "k" (body `mover_k`) even when an earlier one found no place."""
    along = goal - start
    square = math.atan2(along[1], along[0]) + math.pi / 2
    movers = []
    for i in range(random.randint(spec.movers[0], spec.movers[1] + 1)):
        for _ in range(spec.tries):
            centre = start + random.uniform(*spec.mover_crossing) * along
            angle = square + random.uniform(-spec.mover_skew, spec.mover_skew)
            half = random.uniform(*spec.mover_half_path) * np.array([math.cos(angle), math.sin(angle)])
            ends = (centre - half, centre + half)
            if random.rand() < 0.5:
                ends = ends[::-1]
            reach = spec.mover_radius + spec.clearance
            if min(_segment_distance(start, *ends), _segment_distance(goal, *ends)) >= reach:
                break
        else:
            continue
        (x0, y0), (x1, y1) = ends
        movers.append(MovingObstacle(float(x0), float(y0), float(x1), float(y1),
                                     float(random.uniform(*spec.mover_speed)), spec.mover_radius, str(i)))
    return tuple(movers)
