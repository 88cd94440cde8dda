"""What a vehicle's own sonar has shown it: an occupancy grid of the planning plane filled from its echoes.

The map `map-replan` plans on (`auv_mj.planners.map_planner.SonarMap`) and the map a learned planner reads under
observation="planner-map" (`auv_mj.tasks.planning_observation`): a grid of CELL metres over the episode's map
(`memory_bounds`), each cell a log-odds count (Thrun et al., *Probabilistic Robotics*, Ch. 9, in whole numbers):
+HIT for an echo in it, -MISS for a beam that crossed it, occupied at >= OCCUPIED, clipped to +-SATURATION (int8:
the sum of one ping, at most SATURATION + HIT, fits before the clip); unknown
space counts as free. `SonarMemory.add_scan` adds one ping of the nine beams; `SonarMemory.scan` casts MEMORY_BEAMS
rays on the map all round the vehicle (`auv_mj.arenas.grid.ray_ranges`), what the map remembers behind and beside
the vehicle where the sonars (-90 to +90 deg from the bow) no longer look.
"""

from __future__ import annotations

import math

import numpy as np

from auv_mj.arenas import cells, grid
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
        echoed = self.grid.flat_cells(echoes[hit])
        # `cells.count_beams`'s sum, -MISS then +HIT, clipped once at the end, on the touched cells alone: a ping
        # touches a few hundred of a map's ~10^5 cells, and this is every vehicle's every step under "planner-map".
        odds, occupied = self.odds.reshape(-1), self.occupied.reshape(-1)
        odds[missed] -= MISS
        odds[echoed] += HIT
        touched = np.concatenate([missed, echoed])
        odds[touched] = np.clip(odds[touched], -SATURATION, SATURATION)
        was, now = occupied[touched], odds[touched] >= OCCUPIED
        occupied[touched] = now
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
