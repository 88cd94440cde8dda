"""Voxel occupancy grids of the water column and pitch-limited shortest paths on them (LaValle, *Planning
Algorithms*, Ch. 5-6, in 3-D): the map of the 3-D mapping planners (`auv_mj.planners.map_planner3d`: filled from the
27-beam fan and the altimeter online, or from the true geoms for the oracle) and the certificate of the hard 3-D
arenas (`auv_mj.arenas.traps3d`).

A grid is `VoxelGrid(origin, cell, shape)`: voxel (i, j, k) covers x in origin_x + [i, i + 1) h, y likewise, z in
origin_z + [k, k + 1) v, with cell = (h, h, v). The search is Dijkstra's algorithm (scipy's compiled
`csgraph.dijkstra`) on a lattice that a torpedo-shaped vehicle can fly (`lattice`): the 8 level moves of the
planar grid, and climbs or dives of one layer over a horizontal run long enough that the flight path stays within
the vehicle's pitch limit. A straight climb or dive is no edge: the REMUS cannot hover up or down. Each edge is
weighted by its length times the mean cost of the voxels it crosses (`auv_mj.arenas.grid.cost_field`), so that a
path keeps to the middle of the free water where it can. The grid's indexing, the search's ends and the path back
are the planar grid's too (`auv_mj.arenas.cells`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix

from auv_mj.arenas.cells import CellGrid, goal_reach, path_to_goal
from auv_mj.arenas.grid import SOFT_WEIGHT
from auv_mj.geometry import arc_lengths, polyline_length

CLIMB_MARGIN = 0.8
"""Share of the vehicle's pitch limit a planned climb or dive may use: the flight path of the buoyant REMUS is
steeper or shallower than its pitch by its angle of attack, and its depth loop overshoots a little."""
CLIMB_LAYERS = 2
"""Climbing edges rise one or two layers: with two, the steepest edge comes nearer the slope limit than whole
horizontal steps over one layer allow (a tube climbing at its steepest needs it)."""
_LEVEL = ((1, 0), (0, 1), (1, 1), (1, -1))
"""The four level edge directions (the graph is undirected)."""
_COMPASS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
"""The eight horizontal directions of the climbing edges."""


@dataclass(frozen=True)
class VoxelGrid(CellGrid):
    """A regular grid over a box of water: `origin` (x, y, z) [m] of the corner of voxel (0, 0, 0), `cell` the voxel
    size (h, h, v) [m], `shape` (nx, ny, nz) voxels (`auv_mj.arenas.cells.CellGrid` in three dimensions)."""

    @classmethod
    def covering(cls, low, high, horizontal: float, vertical: float) -> VoxelGrid:
        """The grid covering the box from `low` to `high` (x, y, z) [m] with voxels of `horizontal` x `vertical` m."""
        low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        if not np.all(high > low):
            raise ValueError(f"voxel grid box {tuple(low)} to {tuple(high)}: each high corner must exceed the low one")
        cell = np.array([horizontal, horizontal, vertical], dtype=float)
        shape = tuple(int(v) for v in np.ceil((high - low) / cell))
        return cls(low, cell, shape)

    def index(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Voxel indices (n, 3) of world points (n, 3) and whether each lies on the grid."""
        return self.cell_index(points)

    def centre(self, ijk) -> np.ndarray:
        """World (x, y, z) [m] of the centres of voxels (n, 3)."""
        return self.centre_of(ijk)

    def centres(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The x, y and z [m] of the voxel centres along each axis."""
        return tuple(self.origin[a] + (np.arange(self.shape[a]) + 0.5) * self.cell[a] for a in range(3))


# --- occupancy from geoms ---------------------------------------------------------------------------------------


def _outside_distance(kind: int, size: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Distance [m] of points (..., 3) in a geom's frame from the geom (0 inside; an ellipsoid's is approximate)."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.maximum(np.sqrt(x * x + y * y + z * z) - size[0], 0.0)
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        zc = np.clip(z, -size[1], size[1])
        return np.maximum(np.sqrt(x * x + y * y + (z - zc) ** 2) - size[0], 0.0)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        radial = np.maximum(np.sqrt(x * x + y * y) - size[0], 0.0)
        axial = np.maximum(np.abs(z) - size[1], 0.0)
        return np.sqrt(radial ** 2 + axial ** 2)
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        excess = np.maximum(np.abs(local) - size[:3], 0.0)
        return np.sqrt(np.sum(excess ** 2, axis=-1))
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        scaled = np.sqrt(np.sum((local / size[:3]) ** 2, axis=-1))
        return np.maximum(scaled - 1.0, 0.0) * float(np.min(size[:3]))
    raise ValueError(f"geom type {kind} has no voxel occupancy")


VOXEL_GEOMS = (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
               mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_ELLIPSOID, mujoco.mjtGeom.mjGEOM_PLANE)
"""The geom types an arena of the 6-DOF vehicle may be built of (what `geom_occupancy` marks)."""


def geom_occupancy(grid: VoxelGrid, model: mujoco.MjModel, data: mujoco.MjData, skip_body: int | None = None,
                   occupied: np.ndarray | None = None, skip_bodies: set[int] | None = None) -> np.ndarray:
    """Voxels (nx, ny, nz) bool whose centre lies within half a voxel diagonal of a geom (a wall thinner than a
    voxel still closes), or-ed into `occupied` if given. Geoms of body `skip_body` and its children (the vehicle),
    and of the root bodies `skip_bodies` (moving obstacles) and theirs, are left out; a plane (the seabed) fills
    the water below it. ValueError naming a geom of another type."""
    occupied = np.zeros(grid.shape, bool) if occupied is None else occupied
    slack = 0.5 * float(np.linalg.norm(grid.cell))
    axes = grid.centres()
    for g in range(model.ngeom):
        root = int(model.body_rootid[int(model.geom_bodyid[g])])
        if (skip_body is not None and root == skip_body) or (skip_bodies and root in skip_bodies):
            continue
        kind = mujoco.mjtGeom(int(model.geom_type[g]))
        if kind not in VOXEL_GEOMS:
            raise ValueError(f"geom {model.geom(g).name or g}: a 3-D arena holds spheres, capsules, cylinders, boxes, "
                             f"ellipsoids and planes, not {kind.name}")
        position = data.geom_xpos[g]
        rotation = data.geom_xmat[g].reshape(3, 3)
        if kind == mujoco.mjtGeom.mjGEOM_PLANE:
            x, y, z = np.meshgrid(*axes, indexing="ij")
            height = (np.stack([x, y, z], axis=-1) - position) @ rotation[:, 2]
            occupied |= height <= slack
            continue
        reach = float(model.geom_rbound[g]) + slack
        lo = [int(np.searchsorted(axes[a], position[a] - reach)) for a in range(3)]
        hi = [int(np.searchsorted(axes[a], position[a] + reach, "right")) for a in range(3)]
        if any(h <= lo_ for lo_, h in zip(lo, hi, strict=True)):
            continue
        x, y, z = np.meshgrid(axes[0][lo[0]:hi[0]], axes[1][lo[1]:hi[1]], axes[2][lo[2]:hi[2]], indexing="ij")
        local = (np.stack([x, y, z], axis=-1) - position) @ rotation
        near = _outside_distance(kind, model.geom_size[g], local) <= slack
        occupied[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] |= near
    return occupied


def clearance(grid: VoxelGrid, occupied: np.ndarray) -> np.ndarray:
    """Distance [m] from each voxel centre to the nearest occupied voxel centre (inf on an empty grid)."""
    if not occupied.any():
        return np.full(grid.shape, np.inf)
    return ndimage.distance_transform_edt(~occupied, sampling=grid.cell)


# --- the search -------------------------------------------------------------------------------------------------


def lattice(cell, max_slope: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The undirected edges of the flyable lattice: (end offset (3,), the voxel offsets (m, 3) the edge crosses).

    The 4 level directions of the 8-connected plane, and for each of the 8 compass directions a climb of one or
    CLIMB_LAYERS layers (m v metres) over the fewest horizontal steps n that keep its slope m v / (n |d| h) within
    `max_slope` [rad] (the vehicle's pitch limit times CLIMB_MARGIN); its dive is the same edge walked backwards.
    A climbing edge crosses the voxels of its horizontal steps, each on the layer its height is nearer to."""
    h, v = float(cell[0]), float(cell[2])
    if not 0.0 < max_slope < math.pi / 2:
        raise ValueError(f"max_slope {max_slope!r}: a climb angle in (0, pi/2) rad")
    edges = [(np.array([di, dj, 0]), np.array([[0, 0, 0], [di, dj, 0]])) for di, dj in _LEVEL]
    for layers in range(1, CLIMB_LAYERS + 1):
        for di, dj in _COMPASS:
            run = h * math.hypot(di, dj)
            n = max(1, math.ceil(layers * v / (math.tan(max_slope) * run) - 1e-9))
            steps = np.arange(n + 1)
            crossed = np.column_stack([steps * di, steps * dj, np.rint(layers * steps / n - 1e-9).astype(int)])
            edges.append((np.array([n * di, n * dj, layers]), crossed))
    return edges


def lattice_graph(cell, cost: np.ndarray, max_slope: float):
    """The flyable `lattice` over the voxels of `cost` (nx, ny, nz; per metre, inf: closed) as a sparse graph (scipy
    CSR, node i the voxel of flat index i in C order), each edge weighted by its length times the mean cost of its two
    ends; None where no edge joins two open voxels. The search (`shortest_path`) and the geodesic field of the 3-D
    reward (`auv_mj.arenas.geodesic.VoxelField`) walk it."""
    n = cost.shape
    ids = np.arange(cost.size).reshape(n)
    passable = np.isfinite(cost)
    rows, cols, weights = [], [], []
    for end, crossed in lattice(cell, max_slope):
        low = np.maximum(-crossed.min(axis=0), 0)
        high = np.array(n) - np.maximum(crossed.max(axis=0), 0)
        if np.any(high <= low):
            continue
        region = tuple(slice(a, b) for a, b in zip(low, high, strict=True))

        def shifted(array, offset, region=region):
            return array[tuple(slice(s.start + o, s.stop + o) for s, o in zip(region, offset, strict=True))]

        ok = np.ones(tuple(high - low), bool)
        for offset in crossed:
            ok &= shifted(passable, offset)
        if not ok.any():
            continue
        length = float(np.linalg.norm(end * np.asarray(cell, dtype=float)))
        rows.append(ids[region][ok])
        cols.append(shifted(ids, end)[ok])
        weights.append(0.5 * length * (cost[region][ok] + shifted(cost, end)[ok]))
    if not rows:
        return None
    return coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(cost.size, cost.size)).tocsr()


def shortest_path(grid: VoxelGrid, cost: np.ndarray, start, goal, max_slope: float, goal_radius: float = 0.0,
                  box: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray | None:
    """The cheapest path (m, 3) [m] of voxel centres on the flyable `lattice` from `start`'s voxel to a voxel
    within `goal_radius` of `goal` (its nearest reachable voxel if none), or None when there is none.

    `cost` is per metre (inf: closed). A start voxel below the hard clearance (the vehicle near an echo) is
    passable; `box` (low, high) [m] keeps the search inside that box of water (the whole grid when None)."""
    start_cell = np.array(grid.nearest(start))
    lo, hi = np.zeros(3, int), np.array(grid.shape)
    if box is not None:
        lo, hi = grid.block(*box)
        lo = np.minimum(lo, start_cell)
        hi = np.maximum(hi, start_cell + 1)
    local = cost[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]].copy()
    si = tuple(start_cell - lo)
    local[si] = min(local[si], 1.0 + SOFT_WEIGHT)
    graph = lattice_graph(grid.cell, local, max_slope)
    if graph is None:
        return None
    n = local.shape
    ids = np.arange(local.size).reshape(n)
    centres = grid.centre(np.column_stack(np.unravel_index(np.arange(local.size), n)) + lo)
    near_goal = np.linalg.norm(centres - np.asarray(goal, dtype=float)[:3], axis=1)
    return path_to_goal(graph, int(ids[si]), centres, near_goal, *goal_reach(float(np.max(grid.cell)), goal_radius))


def smooth(path: np.ndarray, spacing: float, window: float) -> np.ndarray:
    """`path` (m, 3) resampled every `spacing` metres and averaged over `window` metres (its ends kept): the
    lattice's steps ironed out for line of sight. The average cuts a corner by less than window^2 / (8 R) on a bend
    of radius R."""
    path = np.asarray(path, dtype=float)
    length = polyline_length(path)
    if len(path) < 3 or length < 2 * spacing:
        return path
    arc = arc_lengths(path)
    s = np.linspace(0.0, length, int(math.ceil(length / spacing)) + 1)
    points = np.column_stack([np.interp(s, arc, path[:, a]) for a in range(3)])
    half = max(1, int(round(window / spacing / 2)))
    padded = np.vstack([np.repeat(points[:1], half, axis=0), points, np.repeat(points[-1:], half, axis=0)])
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    out = np.column_stack([np.convolve(padded[:, a], kernel, mode="valid") for a in range(3)])
    out[0], out[-1] = points[0], points[-1]
    return out

