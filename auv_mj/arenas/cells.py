"""Regular grids of cells in the plane or in the water column, and what the planar and the 3-D maps do alike on them.

The planar occupancy grid (`auv_mj.arenas.grid.Grid`, cells (i, j)) and the voxel grid of the water column
(`auv_mj.arenas.voxels.VoxelGrid`, voxels (i, j, k)) are one `CellGrid` in d = 2 or 3 dimensions: cell `index`
covers origin + [index, index + 1) * cell along each axis, points and indices are arrays of shape (n, d). This
module holds what the two grids, their searches and the two mapping planners (`auv_mj.planners.map_planner`,
`auv_mj.planners.map_planner3d`) share, written once:

- `CellGrid`: the cells of points, their centres, the nearest cell, the block of cells over a box (a search
  window, a footprint's bounding box);
- `goal_reach` and `path_to_goal`: which cells a search may end in, and its path back through Dijkstra's tree
  (LaValle, *Planning Algorithms*, Ch. 5-6);
- `beam_marks` and `count_beams`: the log-odds occupancy counts of range beams (Thrun et al., *Probabilistic
  Robotics*, Ch. 9, in small): the cells a beam crosses short of its range count a miss, the cell of its echo a
  hit, both clipped to a saturation;
- `ray_ranges`: a rangefinder cast on a map instead of on the world (the scans of a sonar map's memory,
  `auv_mj.arenas.sonar_memory`).

Each grid keeps its own numbers where the two differ on purpose (the planar edge weights and clearances, the
voxels' pitch-limited lattice), so that both give exactly the results they gave before they shared this core.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra


@dataclass(frozen=True)
class CellGrid:
    """A regular grid of cells over a box of d dimensions (the planar `Grid`, d = 2; the `VoxelGrid`, d = 3)."""

    origin: np.ndarray
    """World coordinates (d,) [m] of the corner of cell (0, ..., 0)."""
    cell: float | np.ndarray
    """Cell size [m]: one for every axis, or one per axis (d,)."""
    shape: tuple[int, ...]
    """Cells along each axis."""

    def cell_index(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Cell indices (n, d) of world points (..., d) and whether each lies on the grid."""
        dims = len(self.shape)
        cells = np.floor((np.asarray(points, dtype=float).reshape(-1, dims) - self.origin) / self.cell).astype(int)
        inside = np.all((cells >= 0) & (cells < np.array(self.shape)), axis=1)
        return cells, inside

    def flat_cells(self, points) -> np.ndarray:
        """The flat (C-order) indices of the cells on the grid that hold any of `points` (..., d), sorted, once each."""
        cells, inside = self.cell_index(points)
        return np.unique(np.ravel_multi_index(cells[inside].T, self.shape))

    def centre_of(self, cells) -> np.ndarray:
        """World coordinates (n, d) [m] of the centres of cells (n, d)."""
        return self.origin + (np.asarray(cells).reshape(-1, len(self.shape)) + 0.5) * self.cell

    def nearest(self, point) -> tuple[int, ...]:
        """The cell holding `point`, clipped onto the grid."""
        cells, _ = self.cell_index(point)
        return tuple(int(v) for v in np.clip(cells[0], 0, np.array(self.shape) - 1))

    def block(self, low, high) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (d,) the index range [lo, hi) of the cells over the box from `low` to `high` (d,) [m], clipped
        onto the grid: a search window, or the cells a footprint's bounding box may touch."""
        lo = np.maximum(np.floor((np.asarray(low) - self.origin) / self.cell).astype(int), 0)
        hi = np.minimum(np.ceil((np.asarray(high) - self.origin) / self.cell).astype(int), self.shape)
        return lo, hi


# --- the search's ends ------------------------------------------------------------------------------------------


def goal_reach(cell: float, goal_radius: float) -> tuple[float, float]:
    """(reach, spare) [m] of a search's targets on cells of size `cell` (the largest side): the cells within `reach`
    of the goal, else the nearest reachable cell within `reach + spare` (`path_to_goal`)."""
    return max(goal_radius, cell), 4 * cell


def path_to_goal(graph, source: int, centres: np.ndarray, near_goal: np.ndarray, reach: float,
                 spare: float) -> np.ndarray | None:
    """The node centres of the shortest path in `graph` (Dijkstra) from node `source` to the nearest node (by path
    length) within `reach` of the goal (`near_goal`: each node's distance to it), else to the reachable node nearest
    the goal within `reach + spare`; None if there is none. The planar grid's and the voxel map's search share it."""
    distance, previous = dijkstra(graph, directed=False, indices=source, return_predecessors=True)
    reached = np.isfinite(distance)
    targets = np.flatnonzero((near_goal <= reach) & reached)
    if targets.size == 0:
        nearby = np.flatnonzero(reached & (near_goal <= reach + spare))
        if nearby.size == 0:
            return None
        targets = nearby[[int(np.argmin(near_goal[nearby]))]]
    node = int(targets[np.argmin(distance[targets])])
    path = [node]
    while node != source:
        node = int(previous[node])
        if node < 0:
            return None
        path.append(node)
    return centres[np.array(path[::-1])]


# --- occupancy counted from range beams -------------------------------------------------------------------------


def beam_marks(grid: CellGrid, origins: np.ndarray, directions: np.ndarray, ranges: np.ndarray,
               limits: float | np.ndarray, reach: float, step: float,
               short: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What range beams tell a map: (the flat indices of the cells they cross, sorted, once each; each beam's end
    (n, d) [m]; whether it ended on an echo (n,)).

    Beam k leaves `origins` (d,) or its own (n, d) [m] along the unit `directions[k]` and reads `ranges[k]` [m], an
    echo where that is under its `limits` (one for all, or (n,)); it is sampled every `step` metres out to `reach`,
    and its samples more than `short` [m] (a cell) before its range are the cells it crossed. A beam's end is its
    range, or its limit where it read more."""
    origins = np.asarray(origins, dtype=float)
    samples = np.arange(0.0, reach, step)
    clear = samples[None, :] < (ranges[:, None] - short)
    points = np.expand_dims(origins, -2) + samples[None, :, None] * directions[:, None, :]
    crossed = grid.flat_cells(points[clear])
    hit = ranges < limits - 1e-6
    ends = origins + np.minimum(ranges, limits)[:, None] * directions
    return crossed, ends, hit


def count_beams(odds: np.ndarray, missed: np.ndarray, echoed: np.ndarray, hit: int, miss: int,
                saturation: int) -> tuple[np.ndarray, np.ndarray]:
    """Adds a scan to the log-odds counts `odds` (in place): -`miss` for each cell of `missed`, +`hit` for each of
    `echoed` (flat indices, once each), clipped to [-saturation, saturation]; (the cells touched, their counts)."""
    touched = np.union1d(missed, echoed)
    counts = odds.flat[touched].astype(np.int16)
    counts -= miss * np.isin(touched, missed)
    counts += hit * np.isin(touched, echoed)
    counts = np.clip(counts, -saturation, saturation)
    odds.flat[touched] = counts
    return touched, counts


def ray_ranges(grid: CellGrid, occupied: np.ndarray, origin, directions, max_range: float,
               step: float) -> np.ndarray:
    """Range [m] along each ray from `origin` (d,) along the unit `directions` (n, d) to the first occupied cell of
    `occupied` (the grid's shape), or `max_range` where none lies within it. Rays are sampled every `step` metres
    from `step` on; off the grid counts as free. Vectorised over rays and samples."""
    directions = np.asarray(directions, dtype=float).reshape(-1, len(grid.shape))
    samples = np.arange(step, max_range, step)
    points = np.asarray(origin, dtype=float)[:len(grid.shape)] + samples[None, :, None] * directions[:, None, :]
    index, inside = grid.cell_index(points)
    hit = np.zeros(len(index), bool)
    hit[inside] = occupied[tuple(index[inside].T)]
    hit = hit.reshape(len(directions), len(samples))
    first = np.argmax(hit, axis=1)
    return np.where(hit.any(axis=1), samples[first], float(max_range))
