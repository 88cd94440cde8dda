"""What a vehicle's own sonar has shown it: an occupancy grid of the planning plane filled from its echoes.

The map `map-replan` plans on (`auv_mj.planners.map_planner.SonarMap`) and the map a learned planner reads under
observation="planner-map" (`auv_mj.tasks.planning_observation`): a grid of CELL metres over the episode's map
(`memory_bounds`), each cell a log-odds count (Thrun et al., *Probabilistic Robotics*, Ch. 9, in whole numbers):
+HIT for an echo in it, -MISS for a beam that crossed it, occupied at >= OCCUPIED, clipped to +-SATURATION (int8:
the sum of one ping, at most SATURATION + HIT, fits before the clip); unknown
space counts as free. `SonarMemory.add_scan` adds one ping of the nine beams; `SonarMemory.scan` casts MEMORY_BEAMS
rays on the map all round the vehicle (`auv_mj.arenas.grid.ray_ranges`), what the map remembers behind and beside
the vehicle where the sonars (-90 to +90 deg from the bow) no longer look.

In 3-D the same counts fill voxels (`VoxelMemory`): the map `map-replan` plans on there
(`auv_mj.planners.map_planner3d.SonarVoxelMap`, on the grid of `memory_grid3d`) and the map a learned 3-D planner
reads under observation="fan-map" (`auv_mj.tasks.auv3d`), filled from the 27-beam fan and the altimeter, each ping
cast from the pose it was taken at (`fan_beams`); `VoxelMemory.scan` reads the nearest occupied voxel in each of
FAN_MEMORY_BEAMS sectors round the vehicle (12 azimuths, three elevation bands). Not rays: the fan's 27 beams leave
a wall as scattered voxels, which rays cast 30 degrees apart pass between (a tube's wall read 5 m on one ray and
nothing on the next, step after step); a sector holds the nearest of them wherever it lies.
"""

from __future__ import annotations

import math

import numpy as np

from auv_mj.arenas import cells, grid, voxels
from auv_mj.arenas.traps3d import map_cells
from auv_mj.geometry import wrap_angle
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, fan_directions
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_RANGE

CELL = grid.CELL
"""Cell size of the map [m] (2 m: a fifth of the narrowest gap of the hard tier)."""
HIT, MISS, OCCUPIED, SATURATION = 2, 1, 2, 6
"""Log-odds counts of a cell: +HIT for an echo in it, -MISS for a beam through it, occupied at >= OCCUPIED,
clipped to [-SATURATION, SATURATION]. One echo marks a cell; two clear passes free it (a mover gone)."""
RAY_STEP = CELL / 2
"""Spacing [m] of the points a beam marks free."""
MEMORY_BEAMS = 16
"""Rays of the map-memory scan, evenly all round the vehicle from its bow (22.5 deg apart): what the map
remembers all round it, behind it too, where the nine sonars (-90 to +90 deg from the bow) do not look."""
MEMORY_RANGE = 60.0
"""Reach [m] of the map-memory scan: twice the protection domain's d0, about a cup's depth."""
MEMORY_NAMES = tuple(f"memory_{k + 1}" for k in range(MEMORY_BEAMS))
"""The scan's entries, beam k at psi + k 2 pi / MEMORY_BEAMS (k = 0 the bow, counter-clockwise)."""


def memory_bounds(bounds, points, margin: float) -> tuple[float, float, float, float]:
    """The rectangle (x_min, y_min, x_max, y_max) [m] an episode's map covers: its `arena_bounds`, or where it has
    none, the box round `points` (k, 2) (the start and the goals) grown by `margin` (a sonar's reach)."""
    if bounds is not None:
        return tuple(float(b) for b in bounds)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    low, high = points.min(axis=0) - margin, points.max(axis=0) + margin
    return (*(float(v) for v in low), *(float(v) for v in high))


def _count(odds: np.ndarray, occupied: np.ndarray, missed: np.ndarray,
           echoed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Adds a ping's counts to a map in place: `cells.count_beams`'s sum, -MISS for each cell of `missed` then +HIT
    for each of `echoed` (flat indices, once each), clipped once at the end, on the touched cells alone (a ping
    touches a few hundred of a map's 10^5-10^6 cells, and this is every vehicle's every step under a map
    observation); `occupied` follows. Returns (the cells touched, whether each was occupied before, is now)."""
    odds, occupied = odds.reshape(-1), occupied.reshape(-1)
    odds[missed] -= MISS
    odds[echoed] += HIT
    touched = np.concatenate([missed, echoed])
    odds[touched] = np.clip(odds[touched], -SATURATION, SATURATION)
    was, now = occupied[touched], odds[touched] >= OCCUPIED
    occupied[touched] = now
    return touched, was, now


def sonar_rays(position, psi: float, sonar_offset: float) -> tuple[np.ndarray, np.ndarray]:
    """The sonars' origin (x, y) [m], `sonar_offset` ahead of `position` at heading `psi`, and the nine beams' unit
    directions (9 x 2) in the world frame: a beam's echo at range r lies at origin + r * direction."""
    psi = float(psi)
    origin = np.asarray(position, dtype=float)[:2] + sonar_offset * np.array([math.cos(psi), math.sin(psi)])
    return origin, np.column_stack([np.cos(psi + BEAM_ANGLES), np.sin(psi + BEAM_ANGLES)])


class SonarMemory:
    """One episode's sonar map: log-odds counts (`odds`) and the occupied cells (`occupied`) on `grid`, a grid of
    CELL metres over `bounds` grown by a cell."""

    def __init__(self, bounds):
        self.grid = grid.Grid.covering(bounds, CELL, margin=CELL)
        self.odds = np.zeros(self.grid.shape, np.int8)
        self.occupied = np.zeros(self.grid.shape, bool)

    def add_scan(self, origin, directions: np.ndarray, ranges: np.ndarray, reach: float) -> np.ndarray:
        """Adds one ping: beam k leaves `origin` (x, y) [m] along the unit `directions[k]` and read `ranges[k]` [m],
        an echo where that is under `reach` (the sonar's range). Cells along a beam short of its range count -MISS,
        its echo's cell +HIT (`auv_mj.arenas.cells.count_beams`). Returns the cells that became occupied (bool,
        the grid's shape)."""
        missed, echoes, hit = cells.beam_marks(self.grid, origin, directions, np.asarray(ranges, dtype=float),
                                               reach, reach, RAY_STEP, CELL)
        touched, was, now = _count(self.odds, self.occupied, missed, self.grid.flat_cells(echoes[hit]))
        new = np.zeros(self.grid.shape, bool)
        new.reshape(-1)[touched] = now & ~was
        return new

    def add_ping(self, position, psi: float, sonar_offset: float, ranges: np.ndarray) -> np.ndarray:
        """`add_scan` of the nine sonars' ping at the pose (`position` (x, y) [m], `psi` [rad]): the beams leave the
        sonars' origin `sonar_offset` [m] ahead of the centre at BEAM_ANGLES from the bow, reach SONAR_RANGE."""
        origin, directions = sonar_rays(position, psi, sonar_offset)
        return self.add_scan(origin, directions, ranges, SONAR_RANGE)

    def scan(self, position, psi: float) -> np.ndarray:
        """The map's memory in the body frame: MEMORY_BEAMS ranges / MEMORY_RANGE in [0, 1] cast on the occupied
        cells from `position` (x, y) [m], beam k at `psi` + k 2 pi / MEMORY_BEAMS."""
        angles = float(psi) + np.arange(MEMORY_BEAMS) * (2 * math.pi / MEMORY_BEAMS)
        return grid.ray_ranges(self.grid, self.occupied, position, angles, MEMORY_RANGE) / MEMORY_RANGE


# --- in 3-D: the fan's voxel map -----------------------------------------------------------------------------

MAP_MARGIN_3D = np.array([60.0, 60.0, 25.0])
"""An open-water voxel map covers the vehicle, the goal and the route grown by this [m] (below the surface) ..."""
TUBE_MAP_MARGIN_3D = np.array([12.0, 12.0, 10.0])
"""... a tube's map its centreline grown by this."""
FAN_MEMORY_AZIMUTHS = 12
"""Azimuth sectors of the 3-D memory scan, 30 deg wide, all round the vehicle: sector a is centred on
heading + a 2 pi / FAN_MEMORY_AZIMUTHS (a = 0 the bow, counter-clockwise)."""
FAN_MEMORY_BAND = math.radians(15.0)
"""The 3-D memory scan's elevation bands: below -FAN_MEMORY_BAND, within it (level), above it (half the angle
between the fan's rows, which are 30 deg down, level and 30 deg up: `FAN_ELEVATIONS`)."""
FAN_MEMORY_BEAMS = FAN_MEMORY_AZIMUTHS * 3
FAN_MEMORY_RANGE = 40.0
"""Reach [m] of the 3-D memory scan: ten tube radii, the hard goal3d arena's obstacles a few lengths off."""
FAN_MEMORY_NAMES = tuple(f"fan_memory_{k + 1}" for k in range(FAN_MEMORY_BEAMS))
"""The 3-D scan's entries, band-major (below, level, above), then the azimuth sectors from the bow: the distance to
the nearest occupied voxel's centre in each, over FAN_MEMORY_RANGE (1: none within it). In the world's vertical and
the vehicle's heading: no roll or pitch."""
_FAN = fan_directions()


def memory_grid3d(position, goal, path, tube: bool) -> voxels.VoxelGrid:
    """The voxel grid of an episode's sonar map: voxels of `traps3d.map_cells` (a tube's finer), over the vehicle's
    `position`, the `goal` and the `path` (k, 3) [m] grown by MAP_MARGIN_3D, or TUBE_MAP_MARGIN_3D along a `tube`;
    not above the surface."""
    (horizontal, vertical), _ = map_cells(np.asarray(path, dtype=float).reshape(-1, 3) if tube else np.zeros((0, 3)))
    points = np.vstack([np.asarray(position, dtype=float), np.asarray(goal, dtype=float),
                        np.asarray(path, dtype=float).reshape(-1, 3)])
    margin = TUBE_MAP_MARGIN_3D if tube else MAP_MARGIN_3D
    high = points.max(axis=0) + margin
    high[2] = min(high[2], 0.0)
    return voxels.VoxelGrid.covering(points.min(axis=0) - margin, high, horizontal, vertical)


def quaternion_matrix(quaternion) -> np.ndarray:
    """The rotation matrix (3, 3) of a unit (w, x, y, z) quaternion (MuJoCo's order): body to world."""
    w, x, y, z = (float(v) for v in np.asarray(quaternion, dtype=float).ravel()[:4])
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def fan_beams(position, attitude, sonar_site, altimeter_site,
              ping_pose: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origins (28, 3), unit directions (28, 3), range limits (28,)) in the world of the fan's 27 beams and the
    altimeter's, the vehicle at `position` (3,) [m] with `attitude` (w, x, y, z): its sonar and altimeter sites at
    `sonar_site` and `altimeter_site` (3,) [m] in the body frame, the fan along the body's axes, the altimeter down
    its -z. `ping_pose` (position, attitude): where the fan's ping was taken, if not here (a ping seen late)."""
    rotation = quaternion_matrix(attitude)
    origin, fan_rotation = position, rotation
    if ping_pose is not None:
        origin, fan_rotation = ping_pose[0], quaternion_matrix(ping_pose[1])
    sonar = np.asarray(origin, dtype=float) + fan_rotation @ np.asarray(sonar_site, dtype=float)
    altimeter = np.asarray(position, dtype=float) + rotation @ np.asarray(altimeter_site, dtype=float)
    origins = np.vstack([np.repeat(sonar[None], len(_FAN), axis=0), altimeter])
    directions = np.vstack([_FAN @ fan_rotation.T, -rotation[:, 2]])
    return origins, directions, np.append(np.full(len(_FAN), SONAR_RANGE), ALTIMETER_RANGE)


class VoxelMemory:
    """One episode's 3-D sonar map: log-odds counts (`odds`) and the occupied voxels (`occupied`, and their flat
    indices `cells`, sorted) on `grid` (`memory_grid3d`), counted as the planar map's (HIT, MISS, OCCUPIED,
    SATURATION)."""

    def __init__(self, grid_: voxels.VoxelGrid):
        self.grid = grid_
        self.odds = np.zeros(grid_.shape, np.int8)
        self.occupied = np.zeros(grid_.shape, bool)
        self.cells = np.zeros(0, dtype=np.intp)

    def add_beams(self, origins, directions, ranges, limits) -> None:
        """Adds one ping: beam k leaves `origins[k]` (3,) [m] along the unit `directions[k]` and read `ranges[k]` [m],
        an echo where that is under its `limits[k]`. Voxels a beam crossed a voxel short of its range count -MISS,
        its echo's +HIT (`auv_mj.arenas.cells.count_beams`)."""
        limits = np.asarray(limits, dtype=float)
        missed, echoes, hit = cells.beam_marks(self.grid, origins, np.asarray(directions, dtype=float),
                                               np.asarray(ranges, dtype=float), limits, float(np.max(limits)),
                                               0.5 * float(np.min(self.grid.cell)), float(self.grid.cell[0]))
        touched, was, now = _count(self.odds, self.occupied, missed, self.grid.flat_cells(echoes[hit]))
        if np.any(was != now):
            self.cells = np.union1d(np.setdiff1d(self.cells, touched[was & ~now]), touched[now & ~was])

    def scan(self, position, heading: float) -> np.ndarray:
        """The map's memory round the vehicle at `position` (3,) [m] and `heading` [rad]: in each of FAN_MEMORY_BEAMS
        sectors (FAN_MEMORY_NAMES), the distance to the nearest occupied voxel's centre / FAN_MEMORY_RANGE, 1 where
        none lies within it."""
        scan = np.full(FAN_MEMORY_BEAMS, FAN_MEMORY_RANGE)
        if len(self.cells):
            offset = self.grid.centre_of(np.column_stack(np.unravel_index(self.cells, self.grid.shape))) \
                - np.asarray(position, dtype=float)
            across = np.hypot(offset[:, 0], offset[:, 1])
            distance = np.hypot(across, offset[:, 2])
            near = distance < FAN_MEMORY_RANGE
            offset, across, distance = offset[near], across[near], distance[near]
            width = 2 * math.pi / FAN_MEMORY_AZIMUTHS
            bearing = wrap_angle(np.arctan2(offset[:, 1], offset[:, 0]) - float(heading))
            sector = np.floor((bearing + 0.5 * width) / width).astype(int) % FAN_MEMORY_AZIMUTHS
            elevation = np.arctan2(offset[:, 2], across)
            band = np.where(elevation < -FAN_MEMORY_BAND, 0, np.where(elevation > FAN_MEMORY_BAND, 2, 1))
            np.minimum.at(scan, band * FAN_MEMORY_AZIMUTHS + sector, distance)
        return scan / FAN_MEMORY_RANGE
