"""The hard tier of the 3-D arenas: water where a planner must use depth, certified by the 3-D oracle's search.

A reactive planner in 3-D (line of sight under the protection domain on the 27-beam fan) fails where the way on
is above or below it: it turns along a wall that it should climb over, or is led into a cave. The hard tier of
`goal3d` (`hard_goal_arena`) is one of:

- `over`: a wall across the route, from the seabed up to a few metres above the start's and the goal's depths and
  WALL_SPAN wide: the way is over it (round it is a long detour);
- `under`: a curtain hanging from the surface across the route, below the start's and goal's depths: the way is
  under it;
- `cave`: three walls and a roof open towards the start, the goal behind: an overhang to back out of and pass over
  (or round);
- `relief`: ridges on the seabed across the route, start and goal near the bed: the way follows the relief over
  each crest.

The hard tier of `tunnel3d` (`hard_tube`) is a wider tube (HARD_TUBE_RADIUS) with PLUGS obstacles in it, each
blocking the cross-section from the wall to just past the centreline on a random side, so that a vehicle on the
centreline must pass beside, above or below it.

Every arena is certified before it is returned (`certify`): the oracle's voxel map of the arena's true geoms
(`auv_mj.arenas.voxels.geom_occupancy`) holds a pitch-limited path (`auv_mj.arenas.voxels.shortest_path`) from
start to goal keeping the oracle's clearance; a draw that fails is redrawn from the same random stream. The shapes
are drawn from wide ranges and never tuned to any planner.
"""

from __future__ import annotations

import copy
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from auv_mj.arenas import grid, voxels
from auv_mj.arenas.arena3d import arena_root, seabed
from auv_mj.arenas.geodesic import VoxelField
from auv_mj.arenas.tubes import Tube, random_tube, tube_arena
from auv_mj.geometry import arc_lengths

KINDS = ("over", "under", "cave", "relief")
"""The hard goal3d arenas (module docstring)."""
ROUTE_LENGTH = (120.0, 150.0)
"""Horizontal start-goal distance of a hard goal3d arena [m]: room to climb a wall at a flyable slope, within
the task's time limit at cruise speed."""
WALL_SPAN = 300.0
"""Width of a wall or curtain across the route [m]: going round it is twice the route's length."""
WALL_THICKNESS = 2.0
RISE = (5.0, 9.0)
"""How far a wall's top rises above (or a curtain's bottom reaches below) the start's and goal's depths [m]."""
CAVE_WIDTH, CAVE_DEPTH = (60.0, 100.0), (35.0, 60.0)
"""A cave's width across the route and its depth along it [m]."""
RIDGES = (2, 3)
RIDGE_RADIUS = (8.0, 13.0)
"""Radius of a ridge (a capsule lying on the seabed across the route) [m]."""
RIDGE_ALTITUDE = (4.0, 8.0)
"""Start and goal heights above the bed in `relief` [m]."""
HARD_TUBE_RADIUS = 5.0
"""Inner radius of a hard tube [m]: room to pass a plug."""
HARD_STAVE_RADIUS = 1.0
"""Stave radius of a hard tube [m]: thick enough that its N_STAVES staves close the wider ring."""
PLUGS = (1, 3)
PLUG_OVERLAP = 0.3
"""A plug reaches this far [m] past the centreline: a vehicle on the centreline hits it."""
PLUG_LENGTH = 1.5
"""Length of a plug along the tube [m]."""
PLUG_SPAN = (0.25, 0.85)
"""Where plugs stand, as fractions of the tube's length."""
OPEN_CELL = (2.0, 1.0)
"""(horizontal, vertical) voxel size [m] of the open-water map (the oracle's and the certificate's)."""
TUBE_CELL = (1.0, 0.5)
"""(horizontal, vertical) voxel size [m] of a tube's map: a fifth of a hard tube's radius."""
OPEN_CLEARANCE = grid.HARD_CLEARANCE
"""Least clearance [m] of a planned voxel centre from an occupied one in open water: the hull's half length
(0.665 m) plus the voxels' half diagonal (1.5 m) and some to spare, as in the plane."""
TUBE_CLEARANCE = 1.0
"""Least clearance [m] in a tube: the hull's radius (0.1 m) and its depth and heading errors; the vehicle flies
along the path, so its half length does not count across it."""
TRIES = 30


@dataclass(frozen=True)
class Arena3D:
    """A drawn arena: its MJCF root, start (3,), heading [rad], goal (3,), global path (K, 3) (empty in open water)
    and its kind; once certified, the certificate."""

    root: ET.Element
    start: np.ndarray
    heading: float
    goal: np.ndarray
    path: np.ndarray
    kind: str
    route: np.ndarray | None = None
    """The oracle's certificate (m, 3) [m]: a pitch-limited voxel path from the start to within the goal radius
    (`certify`), None before certification. A task's time limit covers it (`auv_mj.tasks.auv3d.route_time_limit`)."""

    def as_tuple(self):
        """(root, start, heading, goal, path): what a 3-D task's `draw_arena` returns."""
        return self.root, self.start, self.heading, self.goal, self.path


class _Redraw(Exception):
    pass


def _geom(name: str, kind: str, size, pos, frame: np.ndarray | None = None, rgba: str = "0.55 0.35 0.3 1",
          ) -> ET.Element:
    element = ET.Element("geom", name=name, type=kind, size=" ".join(f"{float(s):.4g}" for s in size),
                         pos=" ".join(f"{float(p):.4f}" for p in pos), rgba=rgba)
    if frame is not None:  # rows: the geom's x and y axes in the world
        element.set("xyaxes", " ".join(f"{float(v):.6f}" for v in np.ravel(frame[:2])))
    return element


def _route_frame(heading: float) -> np.ndarray:
    """Rows: along the route, across it (port), up."""
    return np.array([[math.cos(heading), math.sin(heading), 0.0], [-math.sin(heading), math.cos(heading), 0.0],
                     [0.0, 0.0, 1.0]])


def _draw_goal(random: np.random.RandomState, water_depth: float, kind: str) -> Arena3D:
    heading = random.uniform(-math.pi, math.pi)
    frame = _route_frame(heading)
    distance = random.uniform(*ROUTE_LENGTH)
    elements = [seabed(water_depth)]
    middle = random.uniform(0.45, 0.55) * distance

    def at(along: float, across: float, z: float) -> np.ndarray:
        return along * frame[0] + across * frame[1] + np.array([0.0, 0.0, z])

    if kind == "over":
        depths = random.uniform(25.0, 40.0, 2)
        top = float(np.min(depths)) - random.uniform(*RISE)
        half = 0.5 * (water_depth - top)
        elements.append(_geom("wall_over", "box", (WALL_THICKNESS / 2, WALL_SPAN / 2, half),
                              at(middle, random.uniform(-30, 30), -water_depth + half), frame))
    elif kind == "under":
        depths = random.uniform(6.0, 14.0, 2)
        bottom = float(np.max(depths)) + random.uniform(*RISE)
        half = 0.5 * (bottom + 2.0)
        elements.append(_geom("curtain", "box", (WALL_THICKNESS / 2, WALL_SPAN / 2, half),
                              at(middle, random.uniform(-30, 30), 2.0 - half), frame))
    elif kind == "cave":
        depths = random.uniform(20.0, 35.0, 2)
        roof = float(np.min(depths)) - random.uniform(*RISE)
        width, length = random.uniform(*CAVE_WIDTH), random.uniform(*CAVE_DEPTH)
        back = middle + 0.5 * length
        half = 0.5 * (water_depth - roof)
        t = WALL_THICKNESS / 2
        elements += [
            _geom("cave_back", "box", (t, width / 2, half), at(back, 0.0, -water_depth + half), frame),
            _geom("cave_port", "box", (length / 2, t, half), at(back - length / 2, width / 2, -water_depth + half),
                  frame),
            _geom("cave_starboard", "box", (length / 2, t, half),
                  at(back - length / 2, -width / 2, -water_depth + half), frame),
            _geom("cave_roof", "box", (length / 2, width / 2, t), at(back - length / 2, 0.0, -roof + t), frame),
        ]
        distance = max(distance, back + 30.0)
    else:  # relief
        count = int(random.randint(RIDGES[0], RIDGES[1] + 1))
        for k, along in enumerate(np.linspace(0.3, 0.75, count) * distance + random.uniform(-8, 8, count)):
            radius = random.uniform(*RIDGE_RADIUS)
            centre = at(along, 0.0, -water_depth + 0.3 * radius)
            lying = np.array([frame[2], -frame[0]])  # the capsule's axis (local z) across the route
            elements.append(_geom(f"ridge_{k}", "capsule", (radius, WALL_SPAN / 2), centre, lying,
                                  rgba="0.45 0.4 0.3 1"))
        depths = water_depth - random.uniform(*RIDGE_ALTITUDE, 2)
    start = np.array([0.0, 0.0, -depths[0]])
    goal = at(distance, random.uniform(-10, 10), -depths[1])
    elements.append(ET.Element("site", name="goal", pos=" ".join(f"{v:.3f}" for v in goal), size="0.5",
                               rgba="1 0 0 0.5"))
    return Arena3D(arena_root(f"goal3d_{kind}", elements), start, heading, goal, np.zeros((0, 3)), kind)


def hard_goal_arena(random: np.random.RandomState, water_depth: float, max_pitch: float, surface: float,
                    goal_radius: float) -> Arena3D:
    """A certified hard goal3d arena drawn from `random`: a kind of KINDS, then its shape (module docstring).
    `max_pitch` [rad] is the vehicle's pitch limit, `surface` [m] the least depth a path may reach, `goal_radius`
    [m] the task's."""
    kind = KINDS[int(random.randint(len(KINDS)))]
    reason = ""
    for _ in range(TRIES):
        arena = _draw_goal(random, water_depth, kind)
        route = certify(arena, max_pitch, surface, goal_radius)
        if route is not None:
            return replace(arena, route=route)
        reason = "no pitch-limited path keeps the oracle's clearance"
    raise RuntimeError(f"no certified hard {kind} arena in {TRIES} draws: {reason}")


def _plug(tube: Tube, point: np.ndarray, tangent: np.ndarray, angle: float, name: str) -> ET.Element:
    """A box across the tube at `point` filling the cross-section on the side `angle` (about the tangent, from
    the horizontal) from PLUG_OVERLAP past the centreline into the wall."""
    tangent = tangent / np.linalg.norm(tangent)
    side = np.cross([0.0, 0.0, 1.0], tangent)
    side /= np.linalg.norm(side)
    up = np.cross(tangent, side)
    towards = math.cos(angle) * side + math.sin(angle) * up
    reach = tube.wall_radius + tube.stave_radius
    half = 0.5 * (reach + PLUG_OVERLAP)
    centre = point + towards * (half - PLUG_OVERLAP)
    return _geom(name, "box", (PLUG_LENGTH / 2, half, reach), centre, np.array([tangent, towards]))


def _draw_tube(random: np.random.RandomState) -> tuple[Tube, list[ET.Element]]:
    line = random_tube(random).centreline
    tube = Tube(line, HARD_TUBE_RADIUS, HARD_STAVE_RADIUS)
    arc = arc_lengths(line)
    count = int(random.randint(PLUGS[0], PLUGS[1] + 1))
    stations = np.sort(random.uniform(*PLUG_SPAN, count)) * arc[-1]
    plugs = []
    for k, s in enumerate(stations):
        j = min(int(np.searchsorted(arc, s)) - 1, len(line) - 2)
        j = max(j, 0)
        point = line[j] + (s - arc[j]) / (arc[j + 1] - arc[j]) * (line[j + 1] - line[j])
        plugs.append(_plug(tube, point, line[j + 1] - line[j], random.uniform(-math.pi, math.pi), f"plug_{k}"))
    return tube, plugs


def hard_tube(random: np.random.RandomState, max_pitch: float) -> Arena3D:
    """A certified hard tube drawn from `random`: a procedural centreline (`auv_mj.arenas.tubes.random_tube`) as a
    HARD_TUBE_RADIUS tube with PLUGS plugs (module docstring)."""
    for _ in range(TRIES):
        tube, plugs = _draw_tube(random)
        root = tube_arena(tube, "hard_tube")
        world = root.find("worldbody")
        for plug in plugs:
            world.append(plug)
        line = tube.centreline
        arena = Arena3D(root, line[0], tube.start_heading(), line[-1], line, "plugs")
        route = certify(arena, max_pitch, None, 2.0, corridor=(line, tube.radius))
        if route is not None:
            return replace(arena, route=route)
    raise RuntimeError(f"no certified hard tube in {TRIES} draws")


# --- the certificate ---------------------------------------------------------------------------------------------


def arena_model(root: ET.Element) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The arena's geoms alone compiled (no vehicle), placed (`mj_forward`)."""
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def map_cells(path: np.ndarray) -> tuple[tuple[float, float], float]:
    """The voxel size (OPEN_CELL or TUBE_CELL) and the hard clearance [m] of an arena with this global path."""
    return (TUBE_CELL, TUBE_CLEARANCE) if len(path) >= 2 else (OPEN_CELL, OPEN_CLEARANCE)


def true_map(grid_: voxels.VoxelGrid, model: mujoco.MjModel, data: mujoco.MjData, surface: float | None,
             skip_body: int | None = None, skip_bodies: set[int] | None = None) -> np.ndarray:
    """The oracle's occupancy: every geom (`voxels.geom_occupancy`; but those of `skip_body` or `skip_bodies` and
    their children) and, if `surface` is given, the water shallower than `surface` metres (the surface, which ends an
    episode, is a wall to the planners)."""
    occupied = voxels.geom_occupancy(grid_, model, data, skip_body, skip_bodies=skip_bodies)
    if surface is not None:
        occupied[:, :, grid_.centres()[2] > -surface] = True
    return occupied


def corridor_mask(grid_: voxels.VoxelGrid, line: np.ndarray, radius: float) -> np.ndarray:
    """Voxels whose centre lies within `radius` of the polyline `line` (K, 3): inside a tube. Each segment looks only
    through the voxels of its bounding box grown by `radius` (no voxel outside it lies that near)."""
    axes = grid_.centres()
    mask = np.zeros(grid_.shape, bool)
    line = np.asarray(line, dtype=float)
    for a, b in zip(line[:-1], line[1:], strict=True):
        low, high = np.minimum(a, b) - radius, np.maximum(a, b) + radius
        lo = [int(np.searchsorted(axes[k], low[k])) for k in range(3)]
        hi = [int(np.searchsorted(axes[k], high[k], "right")) for k in range(3)]
        if any(h <= l_ for l_, h in zip(lo, hi, strict=True)):
            continue
        x, y, z = np.meshgrid(axes[0][lo[0]:hi[0]], axes[1][lo[1]:hi[1]], axes[2][lo[2]:hi[2]], indexing="ij")
        points = np.stack([x, y, z], axis=-1)
        d = b - a
        t = np.clip((points - a) @ d / max(float(d @ d), 1e-12), 0.0, 1.0)
        near = np.linalg.norm(points - (a + t[..., None] * d), axis=-1) <= radius
        mask[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] |= near
    return mask


PLUG_PREFIX = "plug_"
"""The names of a hard tube's plugs (`_plug`): the obstacles inside a tube, which its walls do not foretell."""


def plug_centres(root: ET.Element) -> dict[str, np.ndarray]:
    """Each plug's name -> its box centre (3,) [m], of an arena's MJCF root (none: an empty dict)."""
    return {g.get("name"): np.array([float(v) for v in g.get("pos", "0 0 0").split()])
            for g in root.iter("geom") if (g.get("name") or "").startswith(PLUG_PREFIX)}


def without_geoms(arena: Arena3D, names: frozenset[str]) -> Arena3D:
    """`arena` with the geoms called `names` taken out of a copy of its root (a map of what is known of it)."""
    root = copy.deepcopy(arena.root)
    for parent in list(root.iter()):
        for child in list(parent):
            if child.tag == "geom" and child.get("name") in names:
                parent.remove(child)
    return replace(arena, root=root)


def oracle_map(arena: Arena3D, surface: float | None, corridor: tuple[np.ndarray, float] | None = None,
               static_only: bool = False) -> tuple[voxels.VoxelGrid, np.ndarray, float]:
    """The oracle's voxel map of `arena`: (the grid over its start, goal and corridor with a margin, the cost per metre
    of each voxel (`grid.cost_field` of the clearance; inf nearer than the hard clearance to a geom, the surface or,
    with `corridor` (a centreline and a radius: a tube's inside), outside the corridor), the hard clearance [m]).
    `static_only` leaves the moving obstacles (mocap bodies) out. The certificate and the 3-D geodesic field share
    it."""
    model, data = arena_model(arena.root)
    cell, hard = map_cells(arena.path)
    points = np.vstack([arena.start, arena.goal] + ([corridor[0]] if corridor is not None else []))
    margin = np.array([20.0, 20.0, 15.0]) if corridor is None else np.full(3, corridor[1] + 3.0)
    high = points.max(axis=0) + margin
    if surface is not None:
        high[2] = min(high[2], 0.0)
    space = voxels.VoxelGrid.covering(points.min(axis=0) - margin, high, *cell)
    skip = None
    if static_only:
        skip = {int(b) for b in range(model.nbody) if model.body_mocapid[b] >= 0}
    occupied = true_map(space, model, data, surface, skip_bodies=skip)
    cost = grid.cost_field(voxels.clearance(space, occupied), hard, hard + 2.0 * cell[0])
    if corridor is not None:
        cost[~corridor_mask(space, *corridor)] = np.inf
    return space, cost, hard


def certify(arena: Arena3D, max_pitch: float, surface: float | None, goal_radius: float,
            corridor: tuple[np.ndarray, float] | None = None) -> np.ndarray | None:
    """The oracle's certificate of `arena`: a pitch-limited voxel path (m, 3) from its start to within
    `goal_radius` of its goal that keeps the oracle's clearance from every geom (and from the surface), inside
    `corridor` (a centreline and a radius: a tube's inside) if given; None when there is none."""
    space, cost, _ = oracle_map(arena, surface, corridor)
    for end in (arena.start, arena.goal):  # the ends themselves must be clear
        i, inside = space.index(end)
        if not inside[0] or not np.isfinite(cost[tuple(i[0])]):
            return None
    path = voxels.shortest_path(space, cost, arena.start, arena.goal, max_pitch * voxels.CLIMB_MARGIN, goal_radius)
    if path is None or np.linalg.norm(path[-1] - arena.goal) > goal_radius + float(np.max(space.cell)):
        return None
    return path


def geodesic_field(arena: Arena3D, max_pitch: float, surface: float | None, goal_radius: float,
                   corridor: tuple[np.ndarray, float] | None = None, soft: bool = False,
                   mapped: tuple[voxels.VoxelGrid, np.ndarray, float] | None = None) -> VoxelField:
    """The geodesic distance to `arena`'s goal on its true static map (the potential of the 6-DOF tasks'
    reward="geodesic"): the route length [m] over the certificate's voxels (`oracle_map`, the moving obstacles left
    out), climbing within the certificate's slope, `max_pitch` times CLIMB_MARGIN. `soft`: weighed by the oracle's
    soft clearance instead (its values are then costs, not lengths; its way down, `VoxelField.next_hop`, keeps to
    the middle of the water: a privileged teacher's). `mapped`: `oracle_map(arena, surface, corridor,
    static_only=True)` where the caller has it already."""
    space, cost, hard = mapped or oracle_map(arena, surface, corridor, static_only=True)
    return VoxelField.on_map(space, np.isfinite(cost), arena.goal, goal_radius, max_pitch * voxels.CLIMB_MARGIN,
                             hard, outside_closed=corridor is not None, cost=cost if soft else None)
