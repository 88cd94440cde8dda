"""The hard tier and the classical planners of the benchmark (issue 30): determinism, certificates, traps."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from auv_mj.arenas import grid, traps
from auv_mj.arenas.tunnels import MovingObstacle, Obstacle
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners.guidance import los_avoid
from auv_mj.planners.map_planner import map_replan, oracle
from auv_mj.tasks import obstacles, planning, planning_observation, planning_physics, planning_rewards, routes, suite
from auv_mj.tasks.tunnel import RANDOM_TUNNELS

BOUNDS = planning_physics.MAP_BOUNDS
SEEDS = (20_000, 20_001, 20_002)
"""Validation seeds (`auv_mj.seeds.VALIDATION`)."""


def _polygons(boxes) -> list:
    return [shapely.polygons(b.corners()) for b in boxes]


def test_certified_decides_as_the_certificate_search():
    """`traps.certified` (a connected-component labelling, `grid.reaches`) says yes exactly when `traps.certify`
    (Dijkstra) returns a path, on random boxes dense enough that about half the draws have none, with goal radii
    from the tunnel's 2 m to the planning tasks' 12.5 m and clearances up to 15 m."""
    rng = np.random.default_rng(7)
    x0, y0, x1, y1 = BOUNDS
    answers = []
    for _ in range(60):
        boxes = []
        for _ in range(rng.integers(5, 45)):
            centre = rng.uniform((x0, y0), (x1, y1))
            half = rng.uniform(5.0, 60.0, 2)
            c, s = math.cos(a := rng.uniform(0, math.pi)), math.sin(a)
            corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
            boxes.append(centre + corners @ np.array([[c, s], [-s, c]]))
        start, goal = rng.uniform((x0, y0), (x1, y1), (2, 2))
        radius, clearance = rng.choice([2.0, 12.5]), rng.uniform(2.0, 15.0)
        found = traps.certify(boxes, start, goal, BOUNDS, radius, clearance)
        assert traps.certified(boxes, start, goal, BOUNDS, radius, clearance) == (found is not None)
        answers.append(found is not None)
    assert 10 <= sum(answers) <= 50, "the draws test both answers"


@pytest.mark.parametrize("spec", [traps.HARD_OBSTACLES, traps.HARD_MOVING], ids=["obstacles", "moving"])
def test_hard_layout_is_deterministic_and_certified(spec):
    for seed in SEEDS:
        first = traps.random_hard_layout(seed, BOUNDS, spec)
        again = traps.random_hard_layout(seed, BOUNDS, spec)
        assert first.obstacles == again.obstacles and first.movers == again.movers
        np.testing.assert_array_equal(first.start, again.start)
        np.testing.assert_array_equal(first.goal, again.goal)
        assert first.obstacles, "a hard arena holds at least one trap"
        path = traps.certify([b.corners() for b in first.obstacles], first.start, first.goal, BOUNDS, 12.5)
        assert path is not None
        # Independently of the grid: the certificate's path keeps clear of every box (Shapely, exact).
        line = shapely.LineString(path)
        least = min(line.distance(p) for p in _polygons(first.obstacles))
        assert least >= traps.CERTIFY_CLEARANCE - grid.CELL * math.sqrt(2)
        assert np.hypot(*(path[-1] - first.goal)) <= 12.5 + grid.CELL
        union = shapely.union_all(_polygons(first.obstacles))
        for point in (first.start, first.goal):
            assert union.distance(shapely.Point(point)) >= traps.END_CLEARANCE
        for mover in first.movers:
            track = shapely.LineString([(mover.x0, mover.y0), (mover.x1, mover.y1)]).buffer(mover.radius)
            assert track.distance(union) >= traps.DENSE_GAP
            assert mover.speed <= 1.0


def test_hard_traps_keep_their_gaps():
    """Obstacles of different traps, and the boxes of a clutter field, are DENSE_GAP apart (hull + 2 d_s)."""
    for seed in range(20_010, 20_016):
        layout = traps.random_hard_layout(seed, BOUNDS, traps.HARD_OBSTACLES)
        groups: dict[str, list] = {}
        for box in layout.obstacles:
            trap, _, part = box.name.partition("_")
            key = f"{trap}_{part}" if part.isdigit() else trap  # each clutter box is a group of its own
            groups.setdefault(key, []).append(shapely.polygons(box.corners()))
        keys = sorted(groups)
        for i, a in enumerate(keys):
            for b in keys[i + 1:]:
                gap = min(p.distance(q) for p in groups[a] for q in groups[b])
                assert gap >= traps.DENSE_GAP - 1e-9, (seed, a, b, gap)


def test_hard_tunnel_is_deterministic_and_holds_traps():
    first = traps.random_hard_tunnel(20_000, RANDOM_TUNNELS)
    again = traps.random_hard_tunnel(20_000, RANDOM_TUNNELS)
    assert first.unknown == again.unknown and first.movers == again.movers
    assert 60.0 <= first.width <= 100.0
    assert any(o.name.startswith("trap") for o in first.unknown)


def _known_arena(boxes, start, goal, time_limit: float, movers: tuple[MovingObstacle, ...] = ()):
    """A planning environment on a hand-made arena (the `obstacles` task's route: its start and goal sites)."""
    layout = traps.HardLayout(None, np.array(start, float), 0.0, np.array(goal, float), BOUNDS, tuple(boxes),
                              movers, ())
    physics = planning_physics.Physics.load(layout.element("known"))
    task = obstacles.Obstacles(scenario="a")
    return planning.environment(physics, task, time_limit)


CUP = traps.cup(np.random.RandomState(0), (np.array([260.0, 300.0]), 0.0),
                traps.HardSpec(cup_width=(50.0, 50.0), cup_depth=(40.0, 40.0)), "cup")
"""A cup 50 m wide and 40 m deep open towards a start 160 m before it on the straight route to the goal."""


def test_map_replan_gets_out_of_a_cup_that_los_avoid_stalls_in():
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    stalled = episode_metrics(record_episode(env, los_avoid(env)))
    assert not stalled["success"]
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    escaped = episode_metrics(record_episode(env, map_replan(env)))
    assert escaped["success"] and escaped["outcome"] == "goal"


def test_oracle_finds_its_way_round_a_long_wall():
    """A wall 200 m across the route, ending 30 m past it with a hook: the oracle goes round the open end,
    on a path at most a quarter longer than the certificate's."""
    wall = traps.wall(np.random.RandomState(3), (np.array([300.0, 300.0]), 0.0),
                      traps.HardSpec(wall_length=(200.0, 200.0), wall_open_end=(30.0, 30.0), hook_chance=1.0), "w")
    start, goal = (120.0, 300.0), (480.0, 300.0)
    certificate = traps.certify([b.corners() for b in wall], np.array(start), np.array(goal), BOUNDS, 12.5)
    env = _known_arena(wall, start, goal, 600.0)
    metrics = episode_metrics(record_episode(env, oracle(env)))
    assert metrics["success"]
    assert metrics["path_length"] <= 1.25 * grid.path_length(certificate) + routes.GOAL_RADIUS


def test_known_arena_boxes_are_where_they_were_put():
    """The hand-made arena holds the cup's three walls as unknown obstacles (so the tests above test them)."""
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 10.0)
    env.reset()
    names = [env.physics.model.geom(i).name for i in range(env.physics.model.ngeom)]
    assert sum(name.startswith("unknown_cup") for name in names) == 3
    assert all(isinstance(b, Obstacle) for b in CUP)


def test_tunnel_command_writes_the_hard_arena_of_a_seed(tmp_path):
    """`auv-mj tunnel --random SEED --tier hard` writes the first episode's arena of the task seeded SEED."""
    import subprocess
    import sys

    out = tmp_path / "hard.xml"
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "tunnel", "--random", "20000", "--tier", "hard",
                           "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    text = out.read_text()
    expected = traps.random_hard_tunnel(20_000, RANDOM_TUNNELS)
    traps_in_file = text.count('name="unknown_trap')
    assert traps_in_file == sum(o.name.startswith("trap") for o in expected.unknown) > 0


def _zero_residual_on_the_map(env, speed: str = "fixed"):
    """A residual planner whose learned output is zero, at the classical speed (`speed`, "top" or "fixed"), on
    `MapGuide`'s virtual goal, inside the speed-aware domain: the skeleton of a map-guided learned planner, through
    the one deployment chain."""
    from auv_mj.planners.deploy import Chain, ChainConfig, deployed

    config = ChainConfig(protection="speed-aware", residual=1.0, guide="map", speed=speed)
    return deployed(lambda time_step: np.zeros(2), Chain(config, env))


def test_map_guide_gets_a_residual_planner_out_of_a_cup():
    """The map is the memory: line of sight on the virtual goal along the sonar map's path leaves the cup that
    line of sight on the straight route (`los_avoid`, above) stalls in."""
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    metrics = episode_metrics(record_episode(env, _zero_residual_on_the_map(env)))
    assert metrics["success"] and metrics["outcome"] == "goal"


@pytest.mark.parametrize("speed", ["top", "fixed"])
def test_a_zero_top_speed_residual_on_the_map_is_map_replan_exactly(speed):
    """speed="top" or "fixed": with its learned output zeroed, a map-guided residual planner is `map-replan`, action for
    action along map-replan's own run (the ablation row of such a planner is map-replan itself)."""
    env = suite.load("auv", "obstacles", task_kwargs={"arena": "random", "tier": "hard", "random": 20_003})
    classical, zeroed = map_replan(env), _zero_residual_on_the_map(env, speed)
    time_step, turned = env.reset(), 0.0
    for _ in range(250):
        expected, got = classical(time_step), zeroed(time_step)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
        turned = max(turned, abs(float(expected[1])))
        time_step = env.step(expected)
        if time_step.last():
            break
    assert turned > 0.3  # the run steers round obstacles: the comparison is not of straight lines


def test_map_guide_goal_lies_along_the_planned_path():
    """The virtual goal is on the bearing of the follower's look-ahead point, as far as the path left is long,
    and the observation's goal features are the task's own for that goal (distance, body-frame bearing)."""
    from auv_mj.planners.map_planner import MapGuide

    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    guide, drive = MapGuide(env), _zero_residual_on_the_map(env)
    time_step, detour = env.reset(), 0.0
    while not time_step.last():
        observation, left = guide(time_step)
        pose = np.array(env.physics.pose())
        point, _ = guide.follower.carrot(pose, env.task.goals[0])
        desired = observation["desired_goal"]
        assert np.hypot(*(desired[:2] - pose[:2])) == pytest.approx(left, rel=1e-9)
        bearing = math.atan2(desired[1] - pose[1], desired[0] - pose[0])
        assert math.cos(bearing - math.atan2(point[1] - pose[1], point[0] - pose[0])) == pytest.approx(1.0)
        np.testing.assert_allclose(observation["observation"][:3],
                                   planning_observation.relative_goal(observation["achieved_goal"], desired),
                                   atol=1e-12)
        detour = max(detour, left - np.hypot(*(env.task.goals[0] - pose[:2])))
        time_step = env.step(drive(time_step))
    assert detour > 10.0, "once the cup's back wall is in the map, the path goes round it"


def test_path_reward_pays_path_progress_capped():
    from auv_mj.planners.map_planner import PATH_STEP, path_reward

    info = {"goal_independent_reward": -0.05, "event": ""}
    assert path_reward(100.0, 99.0, info) == pytest.approx(planning_rewards.PROGRESS_GAIN * 1.0 - 0.05)
    assert path_reward(100.0, 150.0, info) == pytest.approx(-planning_rewards.PROGRESS_GAIN * PATH_STEP - 0.05)
    assert path_reward(100.0, 0.0, info) == pytest.approx(planning_rewards.PROGRESS_GAIN * PATH_STEP - 0.05)
    reached = path_reward(1.0, 0.5, {**info, "event": "goal"})
    assert reached == pytest.approx(planning_rewards.PROGRESS_GAIN * 0.5 + planning_rewards.FOLLOW_REACHED - 0.05)
