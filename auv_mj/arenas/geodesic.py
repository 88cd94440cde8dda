"""The geodesic distance to the goal on an arena's true static map: the potential of the `geodesic` reward.

Straight-line progress pays the way into a trap: a cup's mouth faces the goal, and every metre into it is a metre
nearer in a straight line. The length of the shortest collision-free route is not fooled: inside the cup it grows
as the vehicle goes in, and going round shortens it. Habitat's PointNav reward is progress on this distance
(`DistanceToGoalReward`); here it is the potential Phi = -d of policy-invariant shaping (Ng et al. 1999).

`GeodesicField.on_grid(area, occupied, goal, goal_radius)` blocks the cells nearer than `clearance` to an occupied
cell and runs one Dijkstra search (scipy's compiled `csgraph.dijkstra`) from every free cell within the goal radius
over the 8-connected free cells, each edge weighted by its length (`auv_mj.arenas.grid.cell_graph` with unit cost):
`field[i, j]` is the route length [m] from that cell's centre into the goal region. `distance(points)` answers for
any points at once (vectorised: the batched env asks for N vehicles in one call): 0 within the goal radius, else the
least |point - centre| + field over the free cells of the REACH x REACH block round the point's cell, and
`unreachable` where none of them leads to the goal (a vehicle walled in, or on a cell the search cannot leave).

`OpenWaterField(goal, goal_radius)` is the same distance where nothing stands between the vehicle and the goal on a
convex map: the straight distance to the goal region, exactly (the grid's 8-connected route would be up to 8 % longer).
`field_of_arena` picks it for an arena without static footprints. `distances(fields, points)` asks N fields (one per
point, of either kind, a batch of episodes) at once: the batched environment's one call per step.

`VoxelField.on_map(space, free, goal, goal_radius, max_slope)` is the field in 3-D, for the 6-DOF tasks: one Dijkstra
search from the free voxels within the goal radius over the pitch-limited lattice a torpedo-shaped vehicle can fly
(`auv_mj.arenas.voxels.lattice_graph`, unit cost: each edge its length), so that a wall in the way is climbed over
at the vehicle's slope, not straight up. `voxel_distances(fields, points)` answers N of them at once, as `distances`:
the least |point - centre| + field over the free voxels of a block round the point's voxel wide enough to reach past
the clearance kept from the walls (`VoxelField.reach`); a point off the grid looks from the nearest voxel inside it,
so the distance grows with the way back onto the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra

from auv_mj.arenas import grid, voxels

REACH = 3
"""Cells on each side of a point's cell that `distance` looks through for a free cell (7 x 7: 6 m on a 2 m grid, so a
vehicle running within the clearance of a wall still finds the free cells beside it)."""


@dataclass(frozen=True)
class GeodesicField:
    """Route lengths [m] to a goal region over a grid's free cells."""

    area: grid.Grid
    """The grid."""
    field: np.ndarray
    """(nx, ny) route length [m] from each cell centre into the goal region; inf where blocked or cut off."""
    goal: np.ndarray
    """Goal (x, y) [m]."""
    goal_radius: float
    """Radius [m] of the goal region."""
    unreachable: float
    """What `distance` gives where no free cell near the point leads to the goal [m]: longer than every route."""

    @classmethod
    def on_grid(cls, area: grid.Grid, occupied: np.ndarray, goal, goal_radius: float,
                clearance: float = grid.HARD_CLEARANCE) -> GeodesicField:
        """The field over `area` of the occupancy `occupied` (nx, ny), cells nearer than `clearance` [m] to an
        occupied one blocked, to within `goal_radius` [m] of `goal` (the goal's own cell where no cell centre lies
        that near)."""
        goal = np.asarray(goal, dtype=float)[:2]
        free = grid.clearance(area, occupied) >= clearance
        nx, ny = area.shape
        graph = grid.cell_graph(area.cell, np.where(free, 1.0, np.inf))
        centres = area.centre(*np.divmod(np.arange(nx * ny), ny))
        near = np.hypot(*(centres - goal).T)
        sources = np.flatnonzero((near <= goal_radius) & free.ravel())
        if sources.size == 0:
            sources = np.array([int(np.ravel_multi_index(area.nearest(goal), area.shape))])
        field = dijkstra(graph, directed=False, indices=sources, min_only=True)
        field[sources] = 0.0
        field = field.reshape(nx, ny)
        field[~free] = np.inf
        finite = field[np.isfinite(field)]
        longest = float(finite.max()) if finite.size else 0.0
        return cls(area, field, goal, float(goal_radius), longest + 2 * (REACH + 1) * area.cell * math.sqrt(2))

    @classmethod
    def of_arena(cls, polygons, bounds, goal, goal_radius: float, clearance: float = grid.HARD_CLEARANCE,
                 cell: float = grid.CELL) -> GeodesicField:
        """The field of an arena: its static footprints `polygons` (each (k, 2) [m]) rasterised on a grid of
        `cell` over `bounds` (x_min, y_min, x_max, y_max), the map's edge occupied (leaving the map ends an episode)."""
        area = grid.Grid.covering(bounds, cell)
        occupied = grid.rasterise(area, polygons)
        occupied[[0, -1], :] = occupied[:, [0, -1]] = True
        return cls.on_grid(area, occupied, goal, goal_radius, clearance)

    def distance(self, points) -> np.ndarray:
        """Route length [m] from each point (n, 2) into the goal region; see the module docstring."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return distances((self,) * len(points), points)


@dataclass(frozen=True)
class OpenWaterField:
    """The geodesic distance on a convex map without obstacles: the straight distance to the goal region [m]."""

    goal: np.ndarray
    """Goal (x, y) [m]."""
    goal_radius: float
    """Radius [m] of the goal region."""

    def distance(self, points) -> np.ndarray:
        """Distance [m] from each point (n, 2) into the goal region (0 inside it)."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return distances((self,) * len(points), points)


Field = GeodesicField | OpenWaterField
"""Either kind of geodesic distance field."""


def field_of_arena(polygons, bounds, goal, goal_radius: float) -> Field:
    """The geodesic field of an arena (`GeodesicField.of_arena`), or `OpenWaterField` where it has no static
    footprints (its map is a rectangle: the straight line stays on it)."""
    if len(polygons) == 0:
        return OpenWaterField(np.asarray(goal, dtype=float)[:2].copy(), float(goal_radius))
    return GeodesicField.of_arena(polygons, bounds, goal, goal_radius)


def distances(fields, points) -> np.ndarray:
    """Route length [m] from point k (N, 2) into the goal region of fields[k], for N fields of either kind at once:
    the arithmetic over all rows together, only the look-up of each grid field's REACH block row by row."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    goal = np.array([f.goal for f in fields], dtype=float).reshape(-1, 2)
    radius = np.array([f.goal_radius for f in fields], dtype=float)
    straight = np.hypot(points[:, 0] - goal[:, 0], points[:, 1] - goal[:, 1])
    result = np.maximum(straight - radius, 0.0)
    gridded = [k for k, f in enumerate(fields) if isinstance(f, GeodesicField)]
    if gridded:
        rows = np.array(gridded)
        grids = [fields[k] for k in gridded]
        origin = np.array([f.area.origin for f in grids], dtype=float)
        cell = np.array([f.area.cell for f in grids], dtype=float)
        shape = np.array([f.area.shape for f in grids], dtype=int)
        at = points[rows]
        cells = np.floor((at - origin) / cell[:, None]).astype(int)
        offsets = np.arange(-REACH, REACH + 1)
        ci = np.clip(cells[:, 0, None, None] + offsets[None, :, None], 0, shape[:, 0, None, None] - 1)
        cj = np.clip(cells[:, 1, None, None] + offsets[None, None, :], 0, shape[:, 1, None, None] - 1)
        ci, cj = np.broadcast_arrays(ci, cj)
        values = np.empty(ci.shape)
        groups: dict[int, list[int]] = {}  # rows that ask the same field: one look-up each
        for row, f in enumerate(grids):
            groups.setdefault(id(f), []).append(row)
        for members in groups.values():
            values[members] = grids[members[0]].field[ci[members], cj[members]]
        cx = origin[:, 0, None, None] + (ci + 0.5) * cell[:, None, None]
        cy = origin[:, 1, None, None] + (cj + 0.5) * cell[:, None, None]
        route = np.hypot(cx - at[:, 0, None, None], cy - at[:, 1, None, None]) + values
        best = np.min(route.reshape(len(rows), -1), axis=1)
        unreachable = np.array([f.unreachable for f in grids], dtype=float)
        best = np.where(np.isfinite(best), best, unreachable)
        result[rows] = np.where(straight[rows] <= radius[rows], 0.0, best)
    return result


@dataclass(frozen=True)
class VoxelField:
    """Route lengths [m] to a goal region over a voxel map's free voxels, on the flyable lattice (module docstring)."""

    space: voxels.VoxelGrid
    """The voxel grid."""
    field: np.ndarray
    """(nx, ny, nz) route length [m] from each voxel centre into the goal region; inf where blocked or cut off."""
    goal: np.ndarray
    """Goal (x, y, z) [m]."""
    goal_radius: float
    """Radius [m] of the goal region."""
    reach: tuple[int, int, int]
    """Voxels on each side of a point's voxel, per axis, that `distance` looks through for a free one."""
    unreachable: float
    """What `distance` gives where no voxel near the point leads to the goal [m]: longer than every route."""
    room: np.ndarray
    """(nx, ny, nz) distance [m] from each voxel centre to the nearest closed voxel's (0 on a closed one): how far
    a point is from leaving the free water (a privileged teacher keeps to the middle of it)."""
    outside_closed: bool = False
    """Whether the water off the grid is closed too (a tube's field: its grid covers the tube), or open (open water:
    the grid is the search's box)."""
    next_hop: np.ndarray | None = None
    """(nx * ny * nz) flat index of the next voxel on the cheapest way from each voxel to the goal region (-9999
    where none: a source, closed or cut off): the search's predecessors, the way down the field."""

    @classmethod
    def on_map(cls, space: voxels.VoxelGrid, free: np.ndarray, goal, goal_radius: float, max_slope: float,
               clearance: float = 0.0, outside_closed: bool = False, cost: np.ndarray | None = None) -> VoxelField:
        """The field over `space` of the free voxels `free` (nx, ny, nz) bool, to within `goal_radius` [m] of `goal`
        (the free voxel nearest the goal where none lies that near), climbing at most `max_slope` [rad]; `clearance`
        [m] is what the free set keeps from the walls, which `distance` looks past; `outside_closed` whether the water
        off the grid is closed. `cost` (nx, ny, nz) weighs each edge by its length times the mean cost per metre of
        its ends (the oracle's soft clearance: the way down keeps to the middle of the water), else by its length
        alone: the field is then the route length."""
        goal = np.asarray(goal, dtype=float)[:3]
        weights = np.ones(space.shape) if cost is None else np.asarray(cost, dtype=float)
        graph = voxels.lattice_graph(space.cell, np.where(free, weights, np.inf), max_slope)
        centres = space.centre(np.column_stack(np.unravel_index(np.arange(free.size), space.shape)))
        near = np.linalg.norm(centres - goal, axis=1)
        open_ = free.ravel()
        sources = np.flatnonzero((near <= goal_radius) & open_)
        if sources.size == 0 and open_.any():
            sources = np.flatnonzero(open_)[[int(np.argmin(near[open_]))]]
        field = np.full(free.size, np.inf)
        next_hop = np.full(free.size, -9999, dtype=np.int64)
        if graph is not None and sources.size:
            field, next_hop, _ = dijkstra(graph, directed=False, indices=sources, min_only=True,
                                          return_predecessors=True)
        field[sources] = 0.0
        field = field.reshape(space.shape)
        field[~free] = np.inf
        finite = field[np.isfinite(field)]
        longest = float(finite.max()) if finite.size else 0.0
        reach = tuple(int(math.ceil(clearance / c)) + 1 for c in space.cell)
        room = voxels.clearance(space, ~free) if not free.all() else np.full(space.shape, np.inf)
        return cls(space, field, goal, float(goal_radius), reach,
                   longest + 2.0 * float(np.linalg.norm(np.asarray(reach) * space.cell)), room, outside_closed,
                   np.asarray(next_hop, dtype=np.int64))

    def distance(self, points) -> np.ndarray:
        """Route length [m] from each point (n, 3) into the goal region; see the module docstring."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        return voxel_distances((self,) * len(points), points)


def field_groups(fields) -> list[list[int]]:
    """The rows of `fields` that hold the same field object, group by group: a batch looks each field up once."""
    groups: dict[int, list[int]] = {}
    for row, f in enumerate(fields):
        groups.setdefault(id(f), []).append(row)
    return list(groups.values())


def point_voxels(field: VoxelField, points: np.ndarray) -> np.ndarray:
    """The (i, j, k) voxel (n, 3) of each of `points` (n, 3) on the field's grid, the nearest on the grid for a point
    off it."""
    shape = np.array(field.space.shape)
    return np.clip(np.floor((points - field.space.origin) / field.space.cell).astype(int), 0, shape - 1)


def entry_voxels(field: VoxelField, points) -> tuple[np.ndarray, np.ndarray]:
    """For each of `points` (n, 3), the voxel of its reach block round the point's voxel (the nearest on the grid
    for a point off it) with the least |point - centre| + field: its flat index (n,) and that sum (n,; inf where no
    voxel of the block leads to the goal). What `voxel_distances` answers, and where a teacher enters the field."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    shape = np.array(field.space.shape)
    cells = point_voxels(field, points)
    offsets = np.stack(np.meshgrid(*[np.arange(-r, r + 1) for r in field.reach], indexing="ij"), -1).reshape(-1, 3)
    block = np.clip(cells[:, None, :] + offsets[None], 0, shape - 1)
    centres = field.space.origin + (block + 0.5) * field.space.cell
    score = np.linalg.norm(centres - points[:, None, :], axis=-1) + field.field[block[..., 0], block[..., 1],
                                                                                  block[..., 2]]
    best = np.argmin(score, axis=1)
    rows = np.arange(len(points))
    return np.ravel_multi_index(tuple(block[rows, best].T), field.space.shape), score[rows, best]


def voxel_room(fields, points) -> np.ndarray:
    """The field's `room` [m] at point k (N, 3) of the VoxelField fields[k], for N fields at once: the distance from
    the point's voxel (the nearest on the grid for a point off it) to the nearest closed voxel, 0 in a closed one. A
    critic's privileged clearance (`auv_mj.tasks.auv3d.PRIVILEGED_FIELDS`)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    result = np.empty(len(points))
    for members in field_groups(fields):
        cells = point_voxels(fields[members[0]], points[members])
        result[members] = fields[members[0]].room[cells[:, 0], cells[:, 1], cells[:, 2]]
    return result


def voxel_distances(fields, points) -> np.ndarray:
    """Route length [m] from point k (N, 3) into the goal region of the VoxelField fields[k], for N fields at once:
    0 within the goal radius, else the least |point - centre| + field over the voxels within the field's `reach` of
    the point's voxel (the nearest voxel on the grid for a point off it, `entry_voxels`), `unreachable` where none
    leads to the goal."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    result = np.empty(len(points))
    for members in field_groups(fields):
        f = fields[members[0]]
        at = points[members]
        route = entry_voxels(f, at)[1]
        route = np.where(np.isfinite(route), route, f.unreachable)
        straight = np.linalg.norm(at - f.goal, axis=1)
        result[members] = np.where(straight <= f.goal_radius, 0.0, route)
    return result
