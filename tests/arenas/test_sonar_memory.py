"""The sonar map a vehicle builds from its own echoes (`auv_mj.arenas.sonar_memory`), checked against the geometry of
the beams: where an echo lands, which cells a beam clears, what a scan cast on the map reads, in the body frame."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from auv_mj.arenas import cells
from auv_mj.arenas.sonar_memory import (
    CELL,
    FAN_MEMORY_AZIMUTHS,
    FAN_MEMORY_BAND,
    FAN_MEMORY_BEAMS,
    FAN_MEMORY_NAMES,
    FAN_MEMORY_RANGE,
    HIT,
    MEMORY_BEAMS,
    MEMORY_RANGE,
    MISS,
    OCCUPIED,
    TUBE_MAP_MARGIN_3D,
    SonarMemory,
    VoxelMemory,
    fan_beams,
    memory_bounds,
    memory_grid3d,
    quaternion_matrix,
)
from auv_mj.sim.sensors3d import ALTIMETER_RANGE
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_RANGE

OFFSET = 0.665
"""Sonar origin ahead of the centre [m] in these tests."""


def _ping(ahead: float | None = None) -> np.ndarray:
    """Nine ranges [m]: nothing within reach but, where given, an echo `ahead` [m] on the bow beam (S5)."""
    ranges = np.full(len(BEAM_ANGLES), SONAR_RANGE)
    if ahead is not None:
        ranges[len(BEAM_ANGLES) // 2] = ahead
    return ranges


def test_an_echo_marks_its_cell_and_the_beam_clears_the_way_to_it():
    memory = SonarMemory((0.0, 0.0, 200.0, 200.0))
    position, psi = np.array([50.0, 80.0]), math.radians(30.0)
    new = memory.add_ping(position, psi, OFFSET, _ping(ahead=17.0))
    echo = position + (OFFSET + 17.0) * np.array([math.cos(psi), math.sin(psi)])
    i, j, inside = memory.grid.index(echo[None])
    assert inside[0] and memory.occupied[i[0], j[0]] and memory.odds[i[0], j[0]] == HIT
    assert np.count_nonzero(new) == 1 and new[i[0], j[0]]
    # A point half-way along the bow beam, and one along the port beam (S9, +90 deg), which read no echo: crossed.
    for direction, reach in ((psi, 8.0), (psi + math.pi / 2, 20.0)):
        point = position + OFFSET * np.array([math.cos(psi), math.sin(psi)]) \
            + reach * np.array([math.cos(direction), math.sin(direction)])
        i, j, _ = memory.grid.index(point[None])
        assert memory.odds[i[0], j[0]] == -MISS and not memory.occupied[i[0], j[0]]
    # Behind the vehicle no beam looked: unknown, counted free.
    behind = position - 20.0 * np.array([math.cos(psi), math.sin(psi)])
    i, j, _ = memory.grid.index(behind[None])
    assert memory.odds[i[0], j[0]] == 0


def test_the_scan_reads_the_map_in_the_body_frame_all_round():
    memory = SonarMemory((0.0, 0.0, 200.0, 200.0))
    position = np.array([100.0, 100.0])
    memory.add_ping(position, 0.0, OFFSET, _ping(ahead=24.0))  # an echo due east, 24.665 m from the centre
    expected = (OFFSET + 24.0) / MEMORY_RANGE
    tolerance = 1.5 * CELL / MEMORY_RANGE
    for psi, beam in ((0.0, 0), (math.pi / 2, 12), (math.pi, 8), (-math.pi / 2, 4), (math.radians(22.5), 15)):
        scan = memory.scan(position, psi)
        assert scan.shape == (MEMORY_BEAMS,)
        assert scan[beam] == pytest.approx(expected, abs=tolerance), (psi, beam)
        assert np.all(np.delete(scan, beam) == 1.0), (psi, scan)
    # From 20 m further west the same echo is 20 m further: within reach still, and beyond it from 40 m west.
    assert memory.scan(position - [20.0, 0.0], 0.0)[0] == pytest.approx(expected + 20.0 / MEMORY_RANGE, abs=tolerance)
    assert memory.scan(position - [40.0, 0.0], 0.0)[0] == 1.0


def test_counts_add_up_and_clear_passes_free_a_cell_again():
    """Log-odds in whole numbers: +HIT an echo, -MISS a clear pass, occupied at >= OCCUPIED, saturating."""
    memory = SonarMemory((0.0, 0.0, 200.0, 200.0))
    position = np.array([100.0, 100.0])
    echo = position + [OFFSET + 10.0, 0.0]
    i, j, _ = memory.grid.index(echo[None])
    counts = []
    for _ in range(5):
        memory.add_ping(position, 0.0, OFFSET, _ping(ahead=10.0))
        counts.append(int(memory.odds[i[0], j[0]]))
    assert counts == [min(HIT * (k + 1), 6) for k in range(5)]
    freed_after = None
    for k in range(10):  # the echo gone (a mover moved on): the beam now passes through the cell
        memory.add_ping(position, 0.0, OFFSET, _ping())
        if not memory.occupied[i[0], j[0]]:
            freed_after = k + 1
            break
    assert freed_after == (6 - OCCUPIED) // MISS + 1
    assert memory.scan(position, 0.0)[0] == 1.0


def test_the_map_covers_the_arena_or_the_route_grown_by_the_sonars_reach():
    assert memory_bounds(np.array([-5.0, 0.0, 300.0, 200.0]), [[0.0, 0.0]], 30.0) == (-5.0, 0.0, 300.0, 200.0)
    assert memory_bounds(None, [[10.0, 20.0], [110.0, -40.0], [60.0, 70.0]], 30.0) == (-20.0, -70.0, 140.0, 100.0)
    memory = SonarMemory((0.0, 0.0, 100.0, 60.0))
    low, high = memory.grid.origin, memory.grid.origin + np.array(memory.grid.shape) * CELL
    assert np.all(low <= [-CELL, -CELL]) and np.all(high >= [100.0 + CELL, 60.0 + CELL])


def test_a_ping_counts_as_the_voxel_maps_count_beams_does():
    """`add_scan` updates only the cells a ping touched; the map is what `cells.count_beams` (the 3-D map's routine)
    and a full `odds >= OCCUPIED` give, ping after ping, and `new` is the cells that turned occupied."""
    rng = np.random.default_rng(3)
    memory = SonarMemory((0.0, 0.0, 120.0, 120.0))
    odds, occupied = np.zeros(memory.grid.shape, np.int8), np.zeros(memory.grid.shape, bool)
    turned, most = 0, 0
    for _ in range(300):
        position, psi = rng.uniform(20.0, 100.0, 2), rng.uniform(-math.pi, math.pi)
        ranges = np.where(rng.random(len(BEAM_ANGLES)) < 0.6, rng.uniform(1.0, 40.0, len(BEAM_ANGLES)), SONAR_RANGE)
        new = memory.add_ping(position, psi, OFFSET, ranges)
        origin = position + OFFSET * np.array([math.cos(psi), math.sin(psi)])
        directions = np.column_stack([np.cos(psi + BEAM_ANGLES), np.sin(psi + BEAM_ANGLES)])
        missed, echoes, hit = cells.beam_marks(memory.grid, origin, directions, ranges, SONAR_RANGE, SONAR_RANGE,
                                               CELL / 2, CELL)
        cells.count_beams(odds, missed, memory.grid.flat_cells(echoes[hit]), HIT, MISS, 6)
        np.testing.assert_array_equal(memory.odds, odds)
        np.testing.assert_array_equal(new, (odds >= OCCUPIED) & ~occupied)
        occupied = odds >= OCCUPIED
        np.testing.assert_array_equal(memory.occupied, occupied)
        turned, most = turned + int(new.sum()), max(most, int(occupied.sum()))
    assert turned > 100 and most > 20 and (odds < 0).sum() > 500


# --- in 3-D: the fan's voxel map -----------------------------------------------------------------------------


def _voxel_memory() -> VoxelMemory:
    """An open-water map round a vehicle at 20 m depth and a goal 100 m east and 10 m deeper."""
    return VoxelMemory(memory_grid3d([0.0, 0.0, -20.0], [100.0, 0.0, -30.0], np.zeros((0, 3)), tube=False))


def test_the_quaternion_matrix_is_mujocos():
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        expected = np.zeros(9)
        mujoco.mju_quat2Mat(expected, q)
        np.testing.assert_allclose(quaternion_matrix(q), expected.reshape(3, 3), atol=1e-12)


def test_the_fan_is_cast_from_its_site_and_the_ping_from_the_pose_it_was_taken_at():
    """A vehicle yawed 90 deg (bow north): the fan leaves the sonar site ahead of it, its level bow beam points north,
    its upper row 30 deg up; the altimeter looks straight down from its own site; a ping taken at another pose is
    cast from there, the altimeter from now."""
    yaw = np.array([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)])
    position, sonar, altimeter = np.array([5.0, 6.0, -20.0]), np.array([0.665, 0.0, 0.0]), np.array([0.3, 0.0, -0.1])
    origins, directions, limits = fan_beams(position, yaw, sonar, altimeter)
    assert origins.shape == directions.shape == (28, 3) and limits.shape == (28,)
    np.testing.assert_allclose(origins[0], [5.0, 6.665, -20.0], atol=1e-12)
    np.testing.assert_allclose(origins[-1], [5.0, 6.3, -20.1], atol=1e-12)
    bow = len(BEAM_ANGLES) + len(BEAM_ANGLES) // 2  # the level row's middle beam
    np.testing.assert_allclose(directions[bow], [0.0, 1.0, 0.0], atol=1e-12)
    up = 2 * len(BEAM_ANGLES) + len(BEAM_ANGLES) // 2
    np.testing.assert_allclose(directions[up], [0.0, math.cos(math.pi / 6), math.sin(math.pi / 6)], atol=1e-12)
    np.testing.assert_allclose(directions[-1], [0.0, 0.0, -1.0], atol=1e-12)
    assert np.all(limits[:-1] == SONAR_RANGE) and limits[-1] == ALTIMETER_RANGE
    earlier = (np.array([5.0, 5.0, -19.0]), np.array([1.0, 0.0, 0.0, 0.0]))  # bow east
    late, late_directions, _ = fan_beams(position, yaw, sonar, altimeter, ping_pose=earlier)
    np.testing.assert_allclose(late[0], [5.665, 5.0, -19.0], atol=1e-12)
    np.testing.assert_allclose(late_directions[bow], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(late[-1], origins[-1], atol=1e-12)
    np.testing.assert_allclose(late_directions[-1], directions[-1], atol=1e-12)


def test_a_voxel_echo_marks_its_voxel_and_its_beam_clears_the_way():
    memory = _voxel_memory()
    level = np.array([1.0, 0.0, 0.0, 0.0])
    origins, directions, limits = fan_beams([10.0, 0.0, -20.0], level, [0.665, 0.0, 0.0], [0.3, 0.0, -0.1])
    ranges = limits.copy()
    bow = len(BEAM_ANGLES) + len(BEAM_ANGLES) // 2
    ranges[bow] = 21.0  # an echo 21 m ahead of the sonar
    memory.add_beams(origins, directions, ranges, limits)
    echo = origins[bow] + 21.0 * directions[bow]
    (ijk,), _ = memory.grid.index(echo[None])
    assert memory.odds[tuple(ijk)] == HIT and memory.occupied[tuple(ijk)] and memory.occupied.sum() == 1
    (half,), _ = memory.grid.index((origins[bow] + 10.0 * directions[bow])[None])
    assert memory.odds[tuple(half)] == -MISS
    (below,), _ = memory.grid.index(np.array([[10.3, 0.0, -40.0]]))  # the altimeter read nothing: crossed
    assert memory.odds[tuple(below)] == -MISS
    (behind,), _ = memory.grid.index(np.array([[-10.0, 0.0, -20.0]]))
    assert memory.odds[tuple(behind)] == 0


def test_the_voxel_scan_reads_the_nearest_voxel_in_each_sector_from_the_heading():
    """Echoed voxels in three sectors -- level 90 deg to port of the heading, 30 deg down and 180 deg round, 30 deg
    up and ahead -- and a farther one behind the first: each sector reads its nearest voxel's centre, every other
    sector the scan's reach; a voxel beyond the reach is not read."""
    memory = _voxel_memory()
    position, heading = np.array([20.0, 5.0, -25.0]), math.radians(40.0)
    expected = np.ones(FAN_MEMORY_BEAMS)
    marked = []
    for band, sector, distance in ((1, 3, 12.0), (1, 3, 20.0), (0, 6, 9.0), (2, 0, 15.0), (1, 9, 45.0)):
        elevation = (-2 * FAN_MEMORY_BAND, 0.0, 2 * FAN_MEMORY_BAND)[band]
        azimuth = heading + sector * 2 * math.pi / FAN_MEMORY_AZIMUTHS
        direction = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                              math.sin(elevation)])
        (ijk,), _ = memory.grid.index((position + distance * direction)[None])
        marked.append(np.ravel_multi_index(ijk, memory.grid.shape))
        memory.occupied[tuple(ijk)] = True
        centre = float(np.linalg.norm(memory.grid.centre(ijk[None])[0] - position))
        if centre < FAN_MEMORY_RANGE:
            k = band * FAN_MEMORY_AZIMUTHS + sector
            expected[k] = min(expected[k], centre / FAN_MEMORY_RANGE)
    memory.cells = np.sort(np.array(marked))
    scan = memory.scan(position, heading)
    assert scan.shape == (FAN_MEMORY_BEAMS,) == (len(FAN_MEMORY_NAMES),)
    np.testing.assert_allclose(scan, expected, rtol=0, atol=1e-12)
    assert np.count_nonzero(scan < 1.0) == 3


def test_the_voxel_maps_cells_are_its_occupied_voxels_ping_after_ping():
    """`VoxelMemory.cells`, which the scan reads, follows `occupied` as echoes mark voxels and clear passes free them
    (the counts of `cells.count_beams`)."""
    rng = np.random.default_rng(5)
    memory = _voxel_memory()
    odds = np.zeros(memory.grid.shape, np.int8)
    freed = 0
    for _ in range(150):
        position = np.array([*rng.uniform(0.0, 60.0, 2), rng.uniform(-40.0, -5.0)])
        attitude = np.array([math.cos(rng.uniform(-1.5, 1.5)), 0.0, 0.0, 0.0])
        attitude[3] = math.sqrt(1.0 - attitude[0] ** 2)
        origins, directions, limits = fan_beams(position, attitude, [0.665, 0.0, 0.0], [0.3, 0.0, -0.1])
        ranges = np.where(rng.random(28) < 0.5, rng.uniform(2.0, 30.0, 28), limits)
        before = memory.occupied.copy()
        memory.add_beams(origins, directions, ranges, limits)
        missed, echoes, hit = cells.beam_marks(memory.grid, origins, directions, ranges, limits, SONAR_RANGE,
                                               0.5 * float(np.min(memory.grid.cell)), float(memory.grid.cell[0]))
        cells.count_beams(odds, missed, memory.grid.flat_cells(echoes[hit]), HIT, MISS, 6)
        np.testing.assert_array_equal(memory.odds, odds)
        np.testing.assert_array_equal(memory.occupied, odds >= OCCUPIED)
        np.testing.assert_array_equal(memory.cells, np.flatnonzero(memory.occupied))
        freed += int(np.count_nonzero(before & ~memory.occupied))
    assert len(memory.cells) > 100 and freed > 0


def test_the_voxel_map_covers_the_route_below_the_surface():
    tube = np.array([[0.0, 0.0, -10.0], [40.0, 10.0, -15.0], [80.0, 0.0, -5.0]])
    grid_ = memory_grid3d(tube[0], tube[-1], tube, tube=True)
    low, high = grid_.origin, grid_.origin + np.array(grid_.shape) * grid_.cell
    assert np.all(low <= tube.min(axis=0) - TUBE_MAP_MARGIN_3D) and high[2] >= 0.0 - 1e-9 and high[2] < 1.0
    assert np.all(high[:2] >= tube.max(axis=0)[:2] + TUBE_MAP_MARGIN_3D[:2])
    assert grid_.cell[0] < memory_grid3d(tube[0], tube[-1], tube, tube=False).cell[0]  # a tube's voxels are finer
