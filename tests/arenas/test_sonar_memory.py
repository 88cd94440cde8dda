"""The sonar map a vehicle builds from its own echoes (`auv_mj.arenas.sonar_memory`), checked against the geometry of
the beams: where an echo lands, which cells a beam clears, what a scan cast on the map reads, in the body frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_mj.arenas import cells
from auv_mj.arenas.sonar_memory import (
    CELL,
    HIT,
    MEMORY_BEAMS,
    MEMORY_RANGE,
    MISS,
    OCCUPIED,
    SonarMemory,
    memory_bounds,
)
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
