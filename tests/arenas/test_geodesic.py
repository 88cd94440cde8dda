"""The geodesic distance field (`auv_mj.arenas.geodesic`) against plane geometry and the oracle's certified routes."""

import math

import numpy as np
import pytest

from auv_mj.arenas import grid, traps
from auv_mj.arenas.geodesic import GeodesicField

BOUNDS = (-300.0, -300.0, 300.0, 300.0)
"""The hard tier's map of the obstacles task [m]."""
EIGHT_CONNECTED_EXCESS = 1.0 / math.cos(math.pi / 8)
"""The most an 8-connected grid path can exceed the straight segment it stands for (at 22.5 degrees): 8.2 %."""


def _box(x0, y0, x1, y1) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def test_round_a_wall_the_field_is_the_two_segments_via_the_walls_end_within_the_grids_bias():
    """A wall x in [99, 101], y in [0, 160] of a 300 m x 200 m map between start (50, 100) and goal (150, 100): the
    shortest route goes over the wall's end, a clearance and a cell beyond it; the grid's route is no shorter than
    that and at most the 8-connected grid's excess (plus a cell each end) longer."""
    field = GeodesicField.of_arena([_box(99, 0, 101, 160)], (0, 0, 300, 200), (150, 100), 5.0)
    corner_y = 160 + grid.HARD_CLEARANCE
    exact = 2 * math.hypot(50, corner_y - 100) - 5.0
    got = float(field.distance([[50, 100]])[0])
    assert exact <= got <= exact * EIGHT_CONNECTED_EXCESS + 2 * grid.CELL
    assert field.distance([[150, 100], [152, 101]]).tolist() == [0.0, 0.0]
    beside = float(field.distance([[200, 100]])[0])  # in sight of the goal: the straight line, less the radius
    assert 45.0 <= beside <= 45.0 * EIGHT_CONNECTED_EXCESS + grid.CELL


def test_into_a_cup_facing_the_goal_the_straight_distance_falls_while_the_route_grows():
    """The trap of the hard tier: a cup open towards the goal at (200, 0), the vehicle behind it at (-100, 0). Going
    into the cup (x from 20 to 60) brings the goal nearer in a straight line but makes the way round longer; the
    straight-line reward pays that, the geodesic one does not."""
    cup = [_box(0, -40, 80, -38), _box(0, 38, 80, 40), _box(0, -40, 2, 40)]  # open at x = 80, facing the goal
    field = GeodesicField.of_arena(cup, BOUNDS, (200, 0), 10.0)
    inside = np.array([[20.0, 0.0], [40.0, 0.0], [60.0, 0.0]])
    straight = np.hypot(*(inside - [200, 0]).T)
    route = field.distance(inside)
    assert np.all(np.diff(straight) < 0)
    assert np.all(np.diff(route) < 0)  # inside the cup the open end is towards the goal: out is forward
    behind = np.array([[-60.0, 0.0], [-20.0, 0.0]])  # behind the cup's bottom: nearer in a straight line ...
    assert np.hypot(*(behind[1] - [200, 0])) < np.hypot(*(behind[0] - [200, 0]))
    up_close, further = field.distance(behind[[1, 0]])
    assert up_close > float(np.hypot(*(behind[1] - [200, 0]))) + 20  # ... but the route must go round the cup
    assert up_close - further < 40.0  # and closing on the bottom buys almost none of it


@pytest.mark.parametrize("seed", [1000, 1001, 1002, 1003])
def test_on_certified_hard_arenas_the_field_lies_between_the_straight_line_and_the_oracles_certificate(seed):
    """On hard-tier arenas the route length from the start is at least the straight distance to the goal region and
    at most the certificate's route (the oracle's, which keeps more clearance and prefers open water), plus a cell."""
    layout = traps.random_hard_layout(seed, BOUNDS, traps.HARD_OBSTACLES)
    boxes = [b.corners() for b in layout.obstacles]
    field = GeodesicField.of_arena(boxes, BOUNDS, layout.goal, 12.5)
    certificate = traps.certify(boxes, layout.start, layout.goal, BOUNDS, 12.5)
    assert certificate is not None
    oracle = grid.path_length(np.vstack([layout.start, certificate]))  # it ends in the goal region
    straight = float(np.hypot(*(layout.goal - layout.start))) - 12.5
    got = float(field.distance([layout.start])[0])
    assert straight <= got <= oracle + grid.CELL, (straight, got, oracle)


def test_distance_is_vectorised_and_walled_in_points_are_farther_than_any_route():
    pocket = [_box(-10, -10, 10, -8), _box(-10, 8, 10, 10), _box(-10, -10, -8, 10), _box(8, -10, 10, 10)]
    field = GeodesicField.of_arena(pocket, (-100, -100, 100, 100), (60, 0), 5.0)
    points = np.random.default_rng(0).uniform(-90, 90, size=(200, 2))
    one_by_one = np.array([field.distance(p)[0] for p in points])
    assert np.array_equal(field.distance(points), one_by_one)
    walled_in = float(field.distance([[0.0, 0.0]])[0])
    assert walled_in == field.unreachable > np.max(field.field[np.isfinite(field.field)])
