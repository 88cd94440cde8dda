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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra

from auv_mj.arenas import grid

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
        i, j, _ = self.area.index(points)
        offsets = np.arange(-REACH, REACH + 1)
        ci = np.clip(i[:, None, None] + offsets[None, :, None], 0, self.area.shape[0] - 1)
        cj = np.clip(j[:, None, None] + offsets[None, None, :], 0, self.area.shape[1] - 1)
        centres = self.area.origin + (np.stack(np.broadcast_arrays(ci, cj), axis=-1) + 0.5) * self.area.cell
        straight = np.hypot(*np.moveaxis(centres - points[:, None, None, :], -1, 0))
        best = np.min((straight + self.field[ci, cj]).reshape(len(points), -1), axis=1)
        best = np.where(np.isfinite(best), best, self.unreachable)
        return np.where(np.hypot(*(points - self.goal).T) <= self.goal_radius, 0.0, best)

