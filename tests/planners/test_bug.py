"""`bug`, the complete sensor-based planner of the benchmark (issue 30): its geometry and the traps it leaves."""

from __future__ import annotations

import math

import numpy as np
import shapely
from test_hard_tier_arenas import CUP, _known_arena

from auv_mj.arenas import traps
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners import bug
from auv_mj.planners.avoidance import map_fence, with_repulsion
from auv_mj.zoo.registry import POLICIES


def test_corridor_blocked_matches_a_buffered_segment():
    """An echo blocks exactly when it lies in the rectangle `reach` long and 2 CORRIDOR wide ahead along the line
    to the goal (Shapely's exact geometry, independent of the planner's projections)."""
    rng = np.random.default_rng(0)
    position, goal, reach = np.array([10.0, -5.0]), np.array([70.0, 40.0]), 50.0
    unit = (goal - position) / np.hypot(*(goal - position))
    normal = np.array([-unit[1], unit[0]])
    end = position + reach * unit
    box = shapely.Polygon([position + bug.CORRIDOR * normal, end + bug.CORRIDOR * normal,
                           end - bug.CORRIDOR * normal, position - bug.CORRIDOR * normal])
    for point in rng.uniform(-40.0, 110.0, size=(400, 2)):
        inside = box.contains(shapely.Point(point))
        assert bug.corridor_blocked(point[None, :], position, goal, reach) == inside, point
    assert not bug.corridor_blocked(np.empty((0, 2)), position, goal, reach)


def test_follow_heading_is_the_wall_tangent_at_the_wall_distance():
    """A wall point due north at exactly WALL_DISTANCE of a vehicle heading east: on port, the heading is east;
    heading west, it is on starboard and the heading is west; heading east with the wall to follow on starboard,
    it is no wall (on the wrong side) and the follower arcs to starboard. Farther off, the heading turns towards
    the wall, nearer, away; with no wall in FOLLOW_RANGE, an arc to its side."""
    here = np.zeros(2)
    wall = np.array([[0.0, bug.WALL_DISTANCE]])
    assert math.isclose(bug.follow_heading(wall, here, 0.0, +1)[0], 0.0, abs_tol=1e-12)
    assert math.isclose(bug.follow_heading(wall, here, math.pi, -1)[0], math.pi, abs_tol=1e-12)
    assert math.isclose(bug.follow_heading(wall, here, 0.0, -1)[0], -bug.CORNER_TURN, abs_tol=1e-12)
    far = bug.follow_heading(wall * 1.5, here, 0.0, +1)[0]
    near = bug.follow_heading(wall * 0.5, here, 0.0, +1)[0]
    assert far > 0.0 > near, "turn towards a wall too far, away from one too near"
    assert math.isclose(far, bug.WALL_GAIN * 0.5 * bug.WALL_DISTANCE)
    lost = np.array([[0.0, bug.FOLLOW_RANGE + 1.0]])
    assert math.isclose(bug.follow_heading(lost, here, 0.3, -1)[0], 0.3 - bug.CORNER_TURN)
    # With the boundary followed a step before at (0, 14), a nearer echo of another body (south, 8 m off, on the
    # wrong side) and one 30 m along the boundary are not it; an echo 10 m along it is, and becomes the anchor.
    others = np.array([[0.0, -8.0], [30.0, bug.WALL_DISTANCE], [10.0, bug.WALL_DISTANCE]])
    heading, anchor = bug.follow_heading(others, here, 0.0, +1, anchor=wall[0])
    np.testing.assert_array_equal(anchor, others[2])
    assert math.isclose(heading, math.atan2(bug.WALL_DISTANCE, 10.0) - math.pi / 2
                        + bug.WALL_GAIN * (math.hypot(10.0, bug.WALL_DISTANCE) - bug.WALL_DISTANCE))


def test_choose_side_goes_round_the_end_that_the_fan_sees():
    """TangentBug's heuristic on a wall across the way east: the fan sees it end to port (the two port beams see
    open water) and run on to starboard, so the follower turns to port (wall on starboard, side -1); mirrored,
    to starboard. With both ends in view, the end nearer the target's line wins."""
    planner = bug.BugPlanner.__new__(bug.BugPlanner)
    here, target = np.zeros(2), np.array([100.0, 0.0])
    wall = np.full(9, 30.0)
    port_open = wall.copy()
    port_open[7:] = 120.0
    assert planner.choose_side(port_open, here, 0.0, target) == -1
    assert planner.choose_side(port_open[::-1].copy(), here, 0.0, target) == 1
    both = wall.copy()
    both[0] = both[8] = 120.0  # open at +-90 deg: ends at +-67.5 deg, the same way round
    both[7] = 120.0  # port opens a beam sooner: its end is at +45 deg, nearer the line to the target
    assert planner.choose_side(both, here, 0.0, target) == -1


def test_bug_gets_out_of_a_cup_and_round_a_long_wall():
    """The trap `los-avoid` stalls in (tests/arenas/test_hard_tier_arenas.py) and a wall 200 m across the route with a
    hooked open end: the leave rule takes the Bug planner out of both, without a collision."""
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    metrics = episode_metrics(record_episode(env, bug.bug(env)))
    assert metrics["success"] and metrics["outcome"] == "goal"
    wall = traps.wall(np.random.RandomState(3), (np.array([300.0, 300.0]), 0.0),
                      traps.HardSpec(wall_length=(200.0, 200.0), wall_open_end=(30.0, 30.0), hook_chance=1.0), "w")
    env = _known_arena(wall, (120.0, 300.0), (480.0, 300.0), 600.0)
    metrics = episode_metrics(record_episode(env, bug.bug(env)))
    assert metrics["success"] and metrics["outcome"] == "goal"


def test_bug_leaves_the_boundary_only_nearer_the_goal():
    """The leave rule on the cup: every switch from boundary following back to motion to goal is made at least
    LEAVE_MARGIN nearer the goal than that boundary's hit point (what makes the Bug planners complete)."""
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    raw = bug.bug_planner(env)
    policy = with_repulsion(raw, bug.PROTECTION, map_fence(env))  # what `bug.bug` builds
    planner = raw
    time_step = env.reset()
    goal = np.asarray(time_step.observation["desired_goal"], float)[:2]
    hits = leaves = 0
    while not time_step.last():
        was_following, hit_distance = planner.following, planner.hit_distance
        position = np.array(env.physics.pose()[:2], float)
        action = policy(time_step)
        if was_following and not planner.following:
            leaves += 1
            assert np.hypot(*(position - goal)) <= hit_distance - bug.LEAVE_MARGIN
        hits += int(planner.following and not was_following)
        time_step = env.step(action)
    assert hits >= 1 and leaves >= 1


def test_bug_is_a_registered_planner():
    assert "bug" in POLICIES and POLICIES["bug"].protection == "speed-aware"
