"""Occupancy grids of the planning plane and shortest paths on them (LaValle, *Planning Algorithms*, Ch. 5-6).

The map of the mapping planners (`auv_mj.planners.map_planner`: filled from the sonar online, or from the true geoms for
the oracle) and the certificate of the hard arenas (`auv_mj.arenas.traps`): an arena is feasible when a path
from its start to its goal keeps HARD_CLEARANCE from every footprint on this grid.

A grid is `Grid(origin, cell, shape)`: cell (i, j) covers x in origin_x + [i, i + 1) cell, y likewise. The
search is Dijkstra's algorithm (scipy's compiled `csgraph.dijkstra`) on the 8-connected graph of the cells
whose clearance is at least `hard`, each edge weighted by its length times the mean of its two cells' costs,
so that a path keeps to the middle of a gap when it can (`cost_field`). The grid's indexing, the search's ends and
the path back are the voxel grid's too (`auv_mj.arenas.cells`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix

from auv_mj.arenas import cells
from auv_mj.arenas.cells import CellGrid, goal_reach, path_to_goal
from auv_mj.geometry import polyline_length

CELL = 2.0
"""Cell size [m]: a fifth of the narrowest gap the hard tier leaves (hull width + 2 d_s, about 10.2 m)."""
HARD_CLEARANCE = 2.5
"""Least clearance [m] of a planned cell centre from an occupied cell centre: the hull's half length
(0.665 m) plus the rasterisation error of a footprint (half a cell diagonal, 1.4 m) and some to spare."""
SOFT_CLEARANCE = 12.0
"""Below this clearance [m] a cell costs more (`cost_field`): paths keep d_s = 5 m and more where there is
room, and the middle of a gap where there is not."""
SOFT_WEIGHT = 4.0
"""Extra cost of a cell at HARD_CLEARANCE over a free one (quadratic in between)."""
_STEPS = ((1, 0), (0, 1), (1, 1), (1, -1))
"""The four edge directions of the 8-connected grid (the graph is undirected)."""


@dataclass(frozen=True)
class Grid(CellGrid):
    """A regular grid over a rectangle of the plane: `origin` (x, y) [m] of the corner of cell (0, 0), `cell` its
    size [m] (a float), `shape` (nx, ny) cells (`auv_mj.arenas.cells.CellGrid` in two dimensions)."""

    @classmethod
    def covering(cls, bounds, cell: float = CELL, margin: float = 0.0) -> Grid:
        """The grid covering `bounds` (x_min, y_min, x_max, y_max) [m] grown by `margin`."""
        low = np.array(bounds[:2], dtype=float) - margin
        high = np.array(bounds[2:], dtype=float) + margin
        if not np.all(high > low):
            raise ValueError(f"grid bounds {tuple(bounds)}: x_max and y_max must exceed x_min and y_min")
        shape = tuple(int(v) for v in np.ceil((high - low) / cell))
        return cls(low, float(cell), shape)

    def index(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell indices (i, j) of world points (n, 2) and whether each lies on the grid."""
        cells, inside = self.cell_index(points)
        return cells[:, 0], cells[:, 1], inside

    def centre(self, i, j) -> np.ndarray:
        """World (x, y) [m] of the centres of cells (i, j)."""
        return self.centre_of(np.column_stack([i, j]))


def rasterise(grid: Grid, polygons, occupied: np.ndarray | None = None) -> np.ndarray:
    """Cells (nx, ny) bool whose centre lies within half a cell diagonal of a convex polygon (k, 2) [m] of
    `polygons`, or-ed into `occupied` if given. Half a diagonal: a wall thinner than a cell still closes."""
    occupied = np.zeros(grid.shape, bool) if occupied is None else occupied
    slack = grid.cell * math.sqrt(0.5)
    for polygon in polygons:
        polygon = np.asarray(polygon, dtype=float)
        x, y = polygon[:, 0], polygon[:, 1]
        if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:  # clockwise: make it counter-clockwise
            polygon = polygon[::-1]
        low, high = grid.block(polygon.min(axis=0) - slack, polygon.max(axis=0) + slack)
        if np.any(high <= low):
            continue
        ii, jj = np.meshgrid(np.arange(low[0], high[0]), np.arange(low[1], high[1]), indexing="ij")
        centres = grid.origin + (np.stack([ii, jj], axis=-1) + 0.5) * grid.cell
        inside = np.ones(ii.shape, bool)
        for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
            edge = b - a
            length = math.hypot(*edge)
            if length < 1e-12:
                continue
            outward = ((centres[..., 0] - a[0]) * edge[1] - (centres[..., 1] - a[1]) * edge[0]) / length
            inside &= outward <= slack
        occupied[ii[inside], jj[inside]] = True
    return occupied


def clearance(grid: Grid, occupied: np.ndarray) -> np.ndarray:
    """Distance [m] from each cell centre to the nearest occupied cell centre (inf on an empty grid)."""
    if not occupied.any():
        return np.full(grid.shape, np.inf)
    return ndimage.distance_transform_edt(~occupied) * grid.cell


def cost_field(free_distance: np.ndarray, hard: float = HARD_CLEARANCE, soft: float = SOFT_CLEARANCE,
               weight: float = SOFT_WEIGHT) -> np.ndarray:
    """Cost per metre of each cell: inf nearer than `hard` [m] to an obstacle, 1 beyond `soft`, and
    1 + weight ((soft - d) / (soft - hard))^2 in between."""
    near = np.clip((soft - free_distance) / (soft - hard), 0.0, 1.0)
    return np.where(free_distance < hard, np.inf, 1.0 + weight * near ** 2)


def shortest_path(grid: Grid, cost: np.ndarray, start, goal, goal_radius: float = 0.0,
                  window: float | None = None) -> np.ndarray | None:
    """The cheapest 8-connected path (m, 2) [m] of cell centres from `start`'s cell to a cell within
    `goal_radius` of `goal` (its nearest passable cell if none), or None when there is none.

    A start cell below the hard clearance (the vehicle near an echo) is passable; `window` [m] keeps the
    search inside the bounding box of start and goal grown by that much (the whole grid when None).
    """
    start_cell = grid.nearest(start)
    lo, hi = np.zeros(2, int), np.array(grid.shape)
    if window is not None:
        ends = np.array([start, goal], dtype=float)[:, :2]
        lo, hi = grid.block(ends.min(axis=0) - window, ends.max(axis=0) + window)
    local = cost[lo[0]:hi[0], lo[1]:hi[1]].copy()
    si, sj = start_cell[0] - lo[0], start_cell[1] - lo[1]
    local[si, sj] = min(local[si, sj], 1.0 + SOFT_WEIGHT)
    nx, ny = local.shape
    ids = np.arange(nx * ny).reshape(nx, ny)
    graph = cell_graph(grid.cell, local)
    centres = grid.centre(*np.divmod(np.arange(nx * ny), ny)) + lo * grid.cell
    near_goal = np.hypot(*(centres - np.asarray(goal, dtype=float)[:2]).T)
    return path_to_goal(graph, int(ids[si, sj]), centres, near_goal, *goal_reach(grid.cell, goal_radius))


def cell_graph(cell: float, cost: np.ndarray):
    """The 8-connected graph (a scipy CSR matrix over the cells in C order) of the cells of finite `cost` (nx, ny),
    each edge weighted by its length times the mean of its two cells' costs [m]."""
    nx, ny = cost.shape
    ids = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for di, dj in _STEPS:
        a = (slice(0, nx - di), slice(max(0, -dj), ny - max(0, dj)))
        b = (slice(di, nx), slice(max(0, dj), ny - max(0, -dj)) if dj >= 0 else slice(0, ny + dj))
        ok = np.isfinite(cost[a]) & np.isfinite(cost[b])
        rows.append(ids[a][ok])
        cols.append(ids[b][ok])
        weights.append(math.hypot(di, dj) * cell * 0.5 * (cost[a][ok] + cost[b][ok]))
    return coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(nx * ny, nx * ny)).tocsr()


_EIGHT = np.ones((3, 3), dtype=bool)
"""The 8-neighbourhood of `ndimage.label`: the edges of `shortest_path`'s graph (`_STEPS`, both ways)."""


def reaches(grid: Grid, cost: np.ndarray, start, goal, goal_radius: float = 0.0) -> bool:
    """Whether `shortest_path(grid, cost, start, goal, goal_radius)` (whole grid) finds a path, without searching
    for it.

    Dijkstra finds a path exactly when a target cell is connected to the start: its edges join 8-neighbours
    that are both passable (finite cost, the start cell always), with positive weights, and it returns a path
    when a reached cell lies within reach + spare of the goal (`auv_mj.arenas.cells.goal_reach`; the nearer targets
    lie within that too). So one connected-component labelling decides it, about 50 times faster on the arena grids: the
    hard tier's certificate at every reset (`auv_mj.arenas.traps.certified`). Tested equal to
    `shortest_path(...) is not None` (`tests/arenas/test_hard_tier_arenas.py`).
    """
    si, sj = grid.nearest(start)
    passable = np.isfinite(cost)
    passable[si, sj] = True
    labels, _ = ndimage.label(passable, structure=_EIGHT)
    reach, spare = goal_reach(grid.cell, goal_radius)
    ci, cj = np.divmod(np.flatnonzero(labels == labels[si, sj]), grid.shape[1])
    near_goal = np.hypot(*(grid.centre(ci, cj) - np.asarray(goal, dtype=float)[:2]).T)
    return bool(np.any(near_goal <= reach + spare))


path_length = polyline_length
"""Length [m] of a polyline (m, 2) (`auv_mj.geometry.polyline_length`)."""


def ray_ranges(grid: Grid, occupied: np.ndarray, origin, angles, max_range: float) -> np.ndarray:
    """Range [m] along each ray from `origin` (x, y) at world `angles` [rad] to the first occupied cell, or
    `max_range` where none lies within it: a rangefinder cast on the map instead of on the world (the
    ego-centric scan of a map-memory planner, `auv_mj.planners.map_planner.MapGuide`). Rays are sampled every half cell;
    off the grid counts as free. Vectorised over rays and samples."""
    angles = np.asarray(angles, dtype=float).ravel()
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    return cells.ray_ranges(grid, occupied, origin, directions, max_range, grid.cell / 2)
