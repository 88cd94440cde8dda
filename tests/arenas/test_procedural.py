"""Procedural arenas (`auv_mj.arenas.procedural`): deterministic per seed, valid (`check-arena`), feasible
(`los-avoid` gets through), and exposed on the tunnel task (`arena="random"`), in Gymnasium and by
`auv-mj tunnel --random`."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import dm_env
import gymnasium
import numpy as np
import pytest
import shapely

from auv_mj.arenas import arena, arena_check, procedural, tunnels
from auv_mj.console import counted
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners.guidance import los_avoid
from auv_mj.tasks import obstacles, planning_physics, planning_step, routes, suite, tunnel

AUV_MJ = Path(sys.executable).with_name("auv-mj")
SHORT_OPTIONS = {"arena": "random", "arena_spec": {"length": [300, 300]}}
"""Task options of a random 300 m tunnel."""
SHORT = dataclasses.replace(tunnel.RANDOM_TUNNELS, length=(300.0, 400.0))
"""Short random tunnels, so that checking one takes a fraction of a second."""


def _lateral(points: np.ndarray, centreline: np.ndarray) -> np.ndarray:
    """Signed distances of points from a polyline (positive on its left)."""
    line = shapely.linestrings(centreline)
    s = shapely.line_locate_point(line, shapely.points(points))
    foot = shapely.get_coordinates(shapely.line_interpolate_point(line, s))
    ahead = shapely.get_coordinates(shapely.line_interpolate_point(line, np.minimum(s + 0.5, line.length)))
    behind = shapely.get_coordinates(shapely.line_interpolate_point(line, np.maximum(s - 0.5, 0.0)))
    tangent = ahead - behind
    offset = points - foot
    return np.sign(tangent[:, 0] * offset[:, 1] - tangent[:, 1] * offset[:, 0]) * np.hypot(*offset.T)


def _turn_radii(points: np.ndarray) -> np.ndarray:
    """Radius of the circle through every three consecutive points [m] (inf on a straight)."""
    a, b, c = points[:-2], points[1:-1], points[2:]
    cross = np.abs((b - a)[:, 0] * (c - b)[:, 1] - (b - a)[:, 1] * (c - b)[:, 0])
    sides = np.hypot(*(b - a).T) * np.hypot(*(c - b).T) * np.hypot(*(c - a).T)
    with np.errstate(divide="ignore"):
        return np.where(cross > 1e-9, sides / (2 * cross), np.inf)


# --- the generator --------------------------------------------------------------------------------


def test_the_same_seed_gives_the_same_arena_and_another_seed_another():
    first = procedural.random_tunnel(7, SHORT)
    again = procedural.random_tunnel(np.random.RandomState(7), SHORT)
    assert ET.tostring(first.element("t")) == ET.tostring(again.element("t"))
    other = procedural.random_tunnel(8, SHORT)
    assert ET.tostring(other.element("t")) != ET.tostring(first.element("t"))


@pytest.mark.parametrize("seed", [0, 10_000, 20_000])
def test_random_tunnels_pass_check_arena(seed):
    drawn = procedural.random_tunnel(seed, SHORT)
    report = arena_check.check_arena(drawn.element())
    assert report.ok, report.lines()
    assert counted(len(drawn.unknown), "unknown obstacle") in report.summary
    info = arena.arena_info(arena.load(drawn.element()))
    assert len(info.movers) == len(drawn.movers) >= SHORT.movers[0]


def test_tunnels_keep_their_construction_rules():
    spec = tunnel.RANDOM_TUNNELS
    drawn = [procedural.random_tunnel(seed, spec) for seed in range(12)]
    starts = np.array([t.centreline[0] for t in drawn])
    headings = np.array([math.atan2(*(t.centreline[1] - t.centreline[0])[::-1]) for t in drawn])
    assert np.ptp(starts, axis=0).min() > 300.0  # placed anywhere ...
    assert len({int((h + math.pi) // (math.pi / 2)) for h in headings}) >= 3  # ... facing any way
    gap = procedural.passing_gap()
    bend = (spec.obstacle_length[1] / 2) ** 2 / (2 * procedural.OBSTACLE_BEND_RADIUS)  # a gentle bend's sagitta
    bend += spec.obstacle_length[1] / 2 * procedural.ARC_STEP[1] / (2 * procedural.OBSTACLE_BEND_RADIUS)
    for t in drawn:
        assert spec.width[0] <= t.width <= spec.width[1] and spec.length[0] <= t.length <= spec.length[1] + 1e-6
        assert spec.obstacles[0] <= len(t.unknown) <= spec.obstacles[1]
        assert spec.movers[0] <= len(t.movers) <= spec.movers[1]
        # every bend no tighter than the vehicle's turn radius on its inner wall
        assert _turn_radii(t.centreline).min() >= spec.turn_radius + t.width / 2 - 1e-6
        axis = shapely.linestrings(t.centreline)
        for obstacle in t.unknown:
            lateral = _lateral(obstacle.corners(), t.centreline)
            reach = min(lateral.max(), -lateral.min())  # past the axis, on the side it does not fill
            assert reach <= spec.obstacle_reach + 1e-6
            free = max(t.width / 2 - lateral.max(), lateral.min() + t.width / 2)
            assert free >= gap - 1e-6  # one gap wide enough for d_s each side and room to steer
            if t.width / 2 - gap - bend >= -tunnels.path_clearance():  # room to come within d_s of the path
                assert shapely.distance(axis, shapely.polygons(obstacle.corners())) <= tunnels.path_clearance()
            s = shapely.line_locate_point(axis, shapely.points([obstacle.x, obstacle.y]))
            assert procedural.END_CLEARANCE <= s <= t.length - procedural.END_CLEARANCE
        for mover in t.movers:
            assert mover.speed < routes.TARGET_SPEED / 2


def test_obstacles_let_a_passing_vehicle_kill_the_subgoals_it_goes_around():
    # passing an obstacle d_s off (hull any way) with LANE to spare keeps within PASS_CORRIDOR of the path
    passing = tunnel.RANDOM_TUNNELS.obstacle_reach + tunnels.route_clearance() + procedural.LANE
    assert passing <= routes.PASS_CORRIDOR


def test_least_turn_radius_is_speed_over_the_heading_rate():
    rate = math.radians(6.0) / 0.5  # Table 1: 6 deg per 0.5 s planner step
    assert tunnel.least_turn_radius() == pytest.approx(planning_step.MAX_SPEED / rate)


def test_seed_ranges_are_disjoint_and_named():
    ranges = sorted(procedural.SEEDS.values(), key=lambda r: r.start)
    assert all(a.stop <= b.start for a, b in zip(ranges, ranges[1:], strict=False))  # disjoint
    assert procedural.seed_split(1_000_000) == "train" and procedural.seed_split(10_042) == "test"
    assert procedural.seed_split(0) == "unassigned"  # free for examples
    assert procedural.seed_split(20_000) == "validation" and procedural.seed_split(-1) == "unassigned"


def test_a_tunnel_that_cannot_be_drawn_says_so():
    impossible = dataclasses.replace(SHORT, obstacles=(9, 9), tries=3)
    with pytest.raises(RuntimeError, match="no feasible tunnel in 3 draws"):
        procedural.random_tunnel(1, impossible)
    with pytest.raises(RuntimeError, match="from a running random stream") as drawn:
        procedural.random_tunnel(np.random.RandomState(1), impossible)  # a task's stream has no seed to name
    assert "None" not in str(drawn.value) and set(drawn.value.fields) == {"length", "obstacles", "movers"}


@pytest.mark.parametrize(("options", "named"), [
    ({"length": 200, "obstacles": 5}, ["length=[200, 200]", "obstacles=[5, 5]"]),
    ({"width": 12, "obstacles": 3}, ["width=[12, 12]", "obstacles=[3, 3]", "passing gap"]),
])
def test_an_infeasible_arena_spec_is_refused_when_the_task_is_made_naming_the_fields(options, named):
    with pytest.raises(ValueError, match="arena_spec: .* conflict") as refused:
        suite.load("auv", "tunnel", task_kwargs={"arena": "random", "arena_spec": {**options, "tries": 5}})
    for words in named:
        assert words in str(refused.value)
    assert "None" not in str(refused.value)


# --- the tunnel task ------------------------------------------------------------------------------


def test_random_arena_runs_the_dm_env_contract_with_a_fresh_arena_per_episode():
    env = suite.load("auv", "tunnel", task_kwargs={**SHORT_OPTIONS, "random": 3})
    obs_spec = env.observation_spec()
    seen = []
    for _ in range(2):
        step = env.reset()
        assert step.step_type == dm_env.StepType.FIRST
        assert set(step.observation) == set(obs_spec)
        for key, spec in obs_spec.items():
            assert step.observation[key].shape == spec.shape
        drawn = env.task.arena
        info = arena.arena_info(env.physics)
        np.testing.assert_allclose(step.observation["achieved_goal"][:2], info.start)
        np.testing.assert_allclose(info.path, drawn.layout.path, atol=1e-6)
        assert env.task._time_limit == tunnel.route_limit(info)
        for _ in range(3):
            step = env.step(np.array([0.0, 0.2]))
            assert step.step_type == dm_env.StepType.MID and np.isfinite(step.reward)
            assert np.all(np.isfinite(step.observation["observation"]))
        seen.append(info.start)
    assert not np.allclose(*seen)  # the second episode is in another tunnel
    first = procedural.random_tunnel(3, tunnel.tunnel_spec({"length": [300, 300]}))
    np.testing.assert_allclose(seen[0], first.layout.path[0])  # episode 1 of seed 3 is the arena of seed 3


def test_random_tunnel_episode_ends_at_its_own_time_limit():
    env = suite.load("auv", "tunnel", task_kwargs={**SHORT_OPTIONS, "random": 4})
    env.reset()
    env.task._time_limit = 2.0  # four planner steps
    steps = [env.step(np.array([-1.0, 0.0])) for _ in range(4)]
    assert [s.last() for s in steps] == [False, False, False, True] and steps[-1].discount == 1.0


def test_gymnasium_reset_seed_draws_the_seeds_arena():
    env = gymnasium.make("auv_mj/Tunnel-v0", task_kwargs={"arena": "random"})
    starts = []
    for seed in (5, 6, 5):
        observation, _ = env.reset(seed=seed)
        starts.append(observation["achieved_goal"][:2])
        env.step(np.zeros(2, dtype=np.float32))
    np.testing.assert_array_equal(starts[0], starts[2])
    assert not np.allclose(starts[0], starts[1])
    np.testing.assert_allclose(starts[0], tunnel.random_arena(5).layout.path[0])


def test_los_avoid_gets_past_an_unknown_obstacle_on_the_path():
    spec = dataclasses.replace(tunnel.RANDOM_TUNNELS, length=(300.0, 300.0), width=(40.0, 40.0), obstacles=(1, 1),
                               movers=(0, 0))
    env = suite.load("auv", "tunnel", task_kwargs={"arena": "random", "random": 2, "arena_spec": spec})
    record = record_episode(env, los_avoid(env))
    (obstacle,) = env.task.arena.unknown
    box = shapely.polygons(obstacle.corners())
    path = shapely.linestrings(env.task.arena.layout.path)
    assert shapely.distance(path, box) < tunnels.path_clearance()  # the global path does not clear it
    metrics = episode_metrics(record)
    assert metrics["outcome"] == "goal", metrics
    assert metrics["min_clearance"] > 0.0
    track = shapely.linestrings(record.pose[:, :2])
    assert shapely.distance(track, box) > 1.0  # it went round


def test_physics_reloaded_in_place_moves_as_a_fresh_one():
    element = procedural.random_tunnel(9, SHORT).element()
    reloaded = planning_physics.Physics.load(planning_physics.open_water_arena())
    reloaded.reload_from_xml_string(arena.compose_xml(element)[0])
    fresh = planning_physics.Physics.load(element)
    for physics in (reloaded, fresh):
        physics.named.data.qpos[["x", "y", "yaw"]] = [*arena.arena_info(physics).start, 0.3]
        physics.forward()
        physics.set_control([15.0, 2.0])
        physics.step(500)
    np.testing.assert_array_equal(reloaded.data.qpos, fresh.data.qpos)
    np.testing.assert_array_equal(reloaded.sonar(), fresh.sonar())


# --- open water -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["obstacles", "moving_obstacles"])
def test_open_water_layout_of_a_seed_is_the_tasks_first_episode_and_passes_check_arena(name):
    layout = obstacles.random_layout(np.random.RandomState(12), moving=name == "moving_obstacles")
    env = suite.load("auv", name, task_kwargs={"arena": "random", "random": 12})
    step = env.reset()
    np.testing.assert_array_equal(step.observation["achieved_goal"][:2], layout.start)
    np.testing.assert_array_equal(env.task.goals[-1], layout.goal)
    model, data = env.physics.model.ptr, env.physics.data.ptr
    for box in layout.boxes:
        np.testing.assert_array_equal(data.mocap_pos[model.body(f"obstacle_{box.size}").mocapid[0]][:2], box.centre)
    assert len(layout.boxes if name == "obstacles" else layout.movers) >= 1
    report = arena_check.check_arena(layout.element())
    assert report.ok, report.lines()


def test_open_water_tasks_take_an_arena_file_and_name_one_they_cannot_read():
    """arena=PATH is a user's arena on the open-water tasks (tests/arenas/test_user_arenas.py); a missing one is
    named."""
    with pytest.raises(ValueError, match="x.xml: cannot read arena"):
        suite.load("auv", "obstacles", task_kwargs={"arena": "x.xml"})


# --- auv-mj tunnel --random -----------------------------------------------------------------------


def test_cli_tunnel_random_writes_the_seeds_arena(tmp_path):
    output = tmp_path / "arena.xml"
    built = subprocess.run([str(AUV_MJ), "tunnel", "--random", "10003", "--length", "320", "-o", str(output)],
                           capture_output=True, text=True, timeout=120)
    assert built.returncode == 0, built.stderr
    assert "(seed 10003, test range)" in built.stdout
    root = ET.parse(output).getroot()
    command = root.find("custom/text[@name='tunnel_command']").get("data")
    assert command.startswith("auv-mj tunnel --random 10003")
    drawn = tunnel.random_arena(10003, tunnel.tunnel_spec({"length": [320, 320]}))
    expected = drawn.element("arena")
    assert [g.attrib for g in root.iter("geom")] == [g.attrib for g in expected.iter("geom")]
    checked = subprocess.run([str(AUV_MJ), "check-arena", str(output), "--no-png"], capture_output=True,
                             text=True, timeout=120)
    assert checked.returncode == 0 and checked.stdout.rstrip().endswith("OK"), checked.stdout


def test_cli_tunnel_random_refuses_a_centreline_too(tmp_path):
    refused = subprocess.run([str(AUV_MJ), "tunnel", "--random", "1", "--mover", "0,0,1,1,0.1,1",
                              "-o", str(tmp_path / "a.xml")], capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "--mover cannot go with it" in refused.stderr


@pytest.mark.parametrize("options, message", [
    ({"width": 8}, r"TunnelSpec.width = \(8, 8\): below the narrowest tunnel, 11.33 m"),
    ({"movers": [2, 1]}, r"TunnelSpec.movers = \(2, 1\): expected 0 <= low <= high"),
    ({"length": 100}, r"shorter than the 120 m kept clear"),
    ({"wdth": 30}, r"unknown field\(s\) wdth; valid: along_length"),
    ({"width": [20, 30, 40]}, r"width must be \[low, high\] or one number"),
])
def test_arena_spec_refuses_bad_options_naming_them(options, message):
    with pytest.raises(ValueError, match=message):
        suite.load("auv", "tunnel", task_kwargs={"arena": "random", "arena_spec": options})


def test_random_tunnels_take_the_ocean_conditions_too():
    """A fresh arena per episode keeps the task's conditions: the lagged thrusters are recompiled with it."""
    env = tunnel.tunnel(arena="random", arena_spec=SHORT, conditions="ocean", random=10_001)
    env.reset()
    assert env.physics.model.na == 2  # the two filterexact actuators
    for _ in range(3):
        env.step(np.array([0.5, 0.0]))
    ideal = tunnel.tunnel(arena="random", arena_spec=SHORT, random=10_001)
    ideal.reset()
    assert ideal.physics.model.na == 0
