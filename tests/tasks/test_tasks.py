"""Tests of the planning tasks (tasks/planning.py and the task modules) and the suite (tasks/suite.py).

Invariants are parametrised over every registered planning task; scripted episodes, rewards, events and
sonar are checked on the shipped arenas and on a small tunnel built here in memory.
"""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import dm_env
import mujoco
import numpy as np
import pytest

from auv_mj.arenas.arena import SAFETY_DISTANCE, arena_info
from auv_mj.control.splane import EXECUTOR_DT
from auv_mj.geometry import wrap_angle
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import (
    obstacles,
    planning_observation,
    planning_physics,
    planning_rewards,
    planning_step,
    routes,
    suite,
    tunnel,
)
from auv_mj.tasks.actions import ActionClipped
from auv_mj.tasks.registry import SUITE

PLANNING_TASKS = sorted(SUITE.tagged("planning"))
SONAR_OFFSET = 0.665
"""The sonar sites sit this far ahead of the vehicle's centre [m] (models/auv.xml)."""
AVOID_RANGE = 12.0
"""The scripted policy turns away when a forward beam sees something nearer than this [m]."""
HOLD = np.array([-1.0, 0.0])
"""Planner action commanding V = 0 and the current heading."""


def line_of_sight(observation, speed: float = 0.5) -> np.ndarray:
    """Scripted planner: head for the current (sub-)goal at V = 2 * speed m/s."""
    x, y, cos_psi, sin_psi = observation["achieved_goal"]  # the relative observation's pose
    gx, gy = observation["desired_goal"][:2]
    psi = math.atan2(sin_psi, cos_psi)
    error = wrap_angle(math.atan2(gy - y, gx - x) - psi)
    return np.array([speed, np.clip(error / planning_step.ACTION_HEADING_RANGE, -1.0, 1.0)])


def line_of_sight_avoiding(observation, speed: float = 0.5) -> np.ndarray:
    """`line_of_sight`, but turning hard to the clearer side when the forward beams S4..S6 see something."""
    sonar = observation["observation"][planning_observation.SONAR_SLICE] * SONAR_RANGE
    if sonar[3:6].min() < AVOID_RANGE:
        return np.array([speed, 1.0 if sonar[5:].sum() > sonar[:4].sum() else -1.0])
    return line_of_sight(observation, speed)


def run(env, policy, max_steps: int = 100_000):
    """Runs one episode; returns the time steps and the tasks' last_info of every step."""
    steps, infos = [env.reset()], []
    while not steps[-1].last() and len(infos) < max_steps:
        steps.append(env.step(policy(steps[-1].observation)))
        infos.append(env.task.last_info)
    return steps, infos


def small_tunnel(length: float = 120.0, half_width: float = 10.0, heading: float = 0.0,
                 bounds=(-20.0, -30.0, 150.0, 30.0), start_cap: bool = True, mover=None) -> ET.Element:
    """A straight tunnel along +x from (0, 0): walls at y = +-half_width, path sites every 10 m."""
    root = ET.Element("mujoco")
    custom = ET.SubElement(root, "custom")
    ET.SubElement(custom, "numeric", name="arena_bounds", data=" ".join(map(str, bounds)))
    world = ET.SubElement(root, "worldbody")
    for name, y in (("wall_north", half_width + 0.5), ("wall_south", -half_width - 0.5)):
        ET.SubElement(world, "geom", name=name, type="box", pos=f"{length / 2} {y} 0",
                      size=f"{length / 2 + 12} 0.5 3")
    ET.SubElement(world, "geom", name="wall_cap_end", type="box", pos=f"{length + 10.5} 0 0",
                  size=f"0.5 {half_width + 1} 3")
    if start_cap:
        ET.SubElement(world, "geom", name="wall_cap_start", type="box", pos="-10.5 0 0",
                      size=f"0.5 {half_width + 1} 3")
    ET.SubElement(world, "site", name="start", pos="0 0 0", euler=f"0 0 {heading}")
    for i, x in enumerate(np.arange(0.0, length + 1e-9, 10.0)):
        ET.SubElement(world, "site", name=f"path_{i}", pos=f"{x} 0 0")
    ET.SubElement(world, "site", name="goal", pos=f"{length} 0 0")
    if mover is not None:
        x0, y0, x1, y1, speed, radius = mover
        body = ET.SubElement(world, "body", name="mover_test", mocap="true", pos=f"{x0} {y0} 0")
        ET.SubElement(body, "geom", name="obstacle_mover_test", type="cylinder", size=f"{radius} 3")
        ET.SubElement(custom, "numeric", name="mover_test", data=f"{x0} {y0} {x1} {y1} {speed}")
    return root


def place(env, x: float, y: float, psi: float) -> np.ndarray:
    """Puts the vehicle at (x, y, psi) at rest, recomputes the state and returns the sonar ranges."""
    physics = env.physics
    physics.named.data.qpos[["x", "y", "yaw"]] = (x, y, psi)
    physics.named.data.qvel[:] = 0.0
    physics.forward()
    return physics.sonar()


# --- suite ------------------------------------------------------------------------------------------


def test_suite_lists_every_task_and_rejects_unknown_names():
    names = {name for _, name in suite.PLANAR_TASKS}
    assert {"goal", "waypoints", "obstacles", "moving_obstacles", "tunnel", "path_line", "path_curve",
            "speed_heading"} <= names
    assert all(domain == "auv" for domain, _ in suite.PLANAR_TASKS)
    assert set(suite.ALL_TASKS) == set(suite.PLANAR_TASKS) | {("auv3d", n) for n in ("depth_heading", "goal3d",
                                                                                      "tunnel3d")}
    assert all(suite.domain_of(name) == domain for domain, name in suite.ALL_TASKS)
    assert set(suite.TASKS_BY_DOMAIN["auv"]) == names
    assert set(suite.BENCHMARKING) <= set(suite.PLANAR_TASKS)
    assert {name for _, name in suite.tasks_by_tag("planning")} == set(PLANNING_TASKS)
    assert "tracking" in suite.TAGS and ("auv", "tunnel") in suite.tasks_by_tag("tracking")
    with pytest.raises(ValueError, match="valid domains: auv"):
        suite.load("cartpole", "goal")
    with pytest.raises(ValueError, match="valid tasks: .*path_curve"):
        suite.load("auv", "flying")
    with pytest.raises(ValueError, match="valid tags"):
        suite.tasks_by_tag("nope")
    with pytest.raises(ValueError, match="scenario must be one of 'random', 'a1'"):
        suite.load("auv", "goal", task_kwargs={"scenario": "z"})
    with pytest.raises(ValueError, match="reward must be"):
        suite.load("auv", "goal", task_kwargs={"reward": "dense"})


def test_benchmark_command_prints_steps_per_second():
    out = subprocess.run([sys.executable, "-m", "auv_mj.tasks.suite", "goal", "tunnel", "--steps", "20"],
                         capture_output=True, text=True, check=True, timeout=120).stdout
    assert [line.split()[0] for line in out.splitlines()] == ["goal", "tunnel"] and "steps/s" in out


# --- invariants over every planning task ------------------------------------------------------------


@pytest.mark.parametrize("name", PLANNING_TASKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_dm_env_contract(name, seed):
    env = suite.load("auv", name, task_kwargs={"random": seed, "time_limit": 5.0})
    obs_spec, action_spec = env.observation_spec(), env.action_spec()
    assert action_spec.shape == (2,)
    assert np.all(action_spec.minimum == -1) and np.all(action_spec.maximum == 1)
    assert env.control_timestep() == pytest.approx(planning_step.PLANNER_DT)
    actions = np.random.RandomState(seed)
    for _ in range(2):
        step = env.reset()
        assert step.step_type == dm_env.StepType.FIRST and step.reward is None and step.discount is None
        count = 0
        while True:
            for key, spec in obs_spec.items():
                spec.validate(step.observation[key])
            if step.last():
                break
            step = env.step(actions.uniform(-1, 1, 2))
            count += 1
            assert np.isfinite(step.reward) and 0.0 <= step.reward <= 1.0  # the suite reward
            if not step.last():
                assert step.step_type == dm_env.StepType.MID and step.discount == 1.0
        truncated = count == 10
        assert step.discount == (1.0 if truncated else 0.0)
        assert truncated or env.task.last_info["event"] in ("collision", "left_map", "goal")
    assert env.step(np.zeros(2)).step_type == dm_env.StepType.FIRST


@pytest.mark.parametrize("name", PLANNING_TASKS)
def test_same_seed_gives_the_same_episode(name):
    def episode(seed):
        env = suite.load("auv", name, task_kwargs={"random": seed, "time_limit": 10.0})
        actions = np.random.RandomState(7)
        steps = [env.reset()]
        while not steps[-1].last():
            steps.append(env.step(actions.uniform(-1, 1, 2)))
        return (np.array([np.concatenate(list(s.observation.values())) for s in steps]),
                np.array([s.reward or 0.0 for s in steps]))

    (obs_a, rew_a), (obs_b, rew_b) = episode(3), episode(3)
    np.testing.assert_array_equal(obs_a, obs_b)
    np.testing.assert_array_equal(rew_a, rew_b)
    if name in ("goal", "waypoints", "obstacles", "moving_obstacles"):  # random by default
        assert not np.array_equal(episode(4)[0][0], obs_a[0])


@pytest.mark.parametrize("name", PLANNING_TASKS)
def test_compute_reward_equals_the_paper_reward(name):
    env = suite.load("auv", name, task_kwargs={"random": 2, "reward": "paper", "time_limit": 20.0})
    task = env.task
    actions = np.random.RandomState(2)
    step = env.reset()
    achieved, desired, rewards, infos = [], [], [], []
    while not step.last():
        desired.append(step.observation["desired_goal"][:2])
        step = env.step(actions.uniform(-1, 1, 2))
        achieved.append(step.observation["achieved_goal"][:2])
        rewards.append(step.reward)
        infos.append(task.last_info)
        assert task.last_info["paper_reward"] == step.reward
        assert task.compute_reward(achieved[-1], desired[-1], task.last_info) == step.reward
    achieved, desired, rewards = np.array(achieved), np.array(desired), np.array(rewards)
    as_dict = {key: np.array([info[key] for info in infos]) for key in infos[0]}
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, as_dict), rewards)
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, infos), rewards)
    objects = np.empty(len(infos), dtype=object)
    objects[:] = infos
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, objects), rewards)
    # Relabelled to the achieved goal itself: reached, so r_following = +4 and the episode ends there, with the
    # success bonus for the steps left where the step was on the route's last leg.
    relabelled = task.compute_reward(achieved, achieved, as_dict)
    bonus = planning_rewards.success_bonus("paper", as_dict["steps_left"]) * as_dict["last_goal"]
    np.testing.assert_allclose(relabelled, planning_rewards.FOLLOW_REACHED + as_dict["goal_independent_reward"] + bonus)
    assert np.all(task.compute_terminated(achieved, achieved, infos))
    # Leading axes beyond one: a (2, n) batch.
    batch = task.compute_reward(np.stack([achieved, achieved]), np.stack([desired, achieved]),
                                {k: np.stack([v, v]) for k, v in as_dict.items()})
    np.testing.assert_array_equal(batch[0], rewards)


# --- action, executor and rewards -------------------------------------------------------------------


def test_action_becomes_a_rate_limited_heading_command_and_executor_runs_at_10_hz():
    calls = []

    class Recorder:
        resets = 0

        def reset(self):
            Recorder.resets += 1

        def __call__(self, command, state):
            calls.append((command, tuple(state)))
            return np.array([20.0 * command[0] / 2.0, 0.0])  # no yaw moment: the heading stays put

    env = suite.load("auv", "goal", task_kwargs={"random": 0, "executor": Recorder(), "scenario": "a2"})
    step = env.reset()
    assert Recorder.resets == 1
    psi0 = env.physics.pose()[2]
    commands = []
    for _ in range(8):
        step = env.step(np.array([0.0, 1.0]))  # V = a0 + 1 = 1 m/s
        commands.append(env.task.last_info["command"])
    assert len(calls) == 8 * round(planning_step.PLANNER_DT / EXECUTOR_DT)
    assert all(len(state) == 4 for _, state in calls)
    assert all(speed == pytest.approx(1.0) for speed, _ in commands)
    offsets = np.array([heading - psi0 for _, heading in commands])
    # +6 deg per planner step (Table 1) until pi/6 from the current heading (which barely moves here).
    np.testing.assert_allclose(offsets[:4], np.arange(1, 5) * planning_step.MAX_HEADING_CHANGE, atol=1e-3)
    psi = env.physics.pose()[2]
    assert abs(commands[-1][1] - psi) <= planning_step.MAX_HEADING_DIFFERENCE + 1e-9
    heading_entry = env.task.observation_fields.index("heading_command")
    assert step.observation["observation"][heading_entry] == pytest.approx((commands[-1][1] - psi) / (math.pi / 6))
    for a0, speed in ((-1.0, 0.0), (1.0, 2.0)):  # forward only: never astern, blind
        env.step(np.array([a0, 0.0]))
        assert env.task.last_info["command"][0] == pytest.approx(speed)
    with pytest.warns(ActionClipped, match="clipped"):  # the one action convention (auv_mj.tasks.actions)
        env.step(np.array([-5.0, 0.0]))
    assert env.task.last_info["command"][0] == pytest.approx(0.0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="must be numbers"):
        env.step(np.array(["1", "0"]))


def test_paper_reward_terms_on_hand_computed_cases():
    d0 = 3.0 * max(3.0 * 0.191, 3.0 * 1.33)  # Eq. (21)-(22) with delta = 3, B = 0.191 m, L = 1.33 m
    env = suite.load("auv", "goal", task_kwargs={"random": 0})
    assert planning_rewards.repulsion_range(env.physics) == pytest.approx(d0)
    goal = np.array([100.0, 0.0])
    follow = planning_rewards.following_reward
    assert follow([0, 0], [1, 0], goal, 12.5) == 0.5  # closer
    assert follow([1, 0], [0, 0], goal, 12.5) == -0.5  # farther
    assert follow([0, 10], [0, -10], goal, 12.5) == 0.0  # neither
    assert follow([0, 0], [0.2, 0], goal, 12.5) == 0.0  # creeping closer by less than the dead-band
    assert follow([0.2, 0], [0, 0], goal, 12.5) == 0.0
    assert follow([80, 0], [88, 0], goal, 12.5) == 4.0  # reached: 12 m <= 12.5 m
    assert follow([80, 0], [87, 0], goal, 12.5) == 0.5
    np.testing.assert_array_equal(follow(np.zeros((3, 2)), [[1, 0], [-1, 0], [98.5, 0]], goal, 2.0),
                                  [0.5, -0.5, 4.0])
    avoid = planning_rewards.avoid_reward
    assert avoid(3.0, d0) == -1.0 and avoid(5.0, d0) == -1.0  # inside d_s = 5 m
    assert avoid(8.0, d0) == pytest.approx(-0.1 * (1 / 8.0 - 1 / 11.97))
    assert avoid(11.0, d0) == pytest.approx(-0.1 * (1 / 11.0 - 1 / 11.97))
    assert avoid(12.0, d0) == 0.0 and avoid(120.0, d0) == 0.0
    # One real step, open water: r = r_following - 0.05 (Eq. 26 with k1 = k2 = k3 = 1).
    env = suite.load("auv", "goal", task_kwargs={"scenario": "a2", "reward": "paper"})
    first = step = env.reset()
    for _ in range(20):  # from rest the first steps move less than the dead-band: r = 0 - 0.05
        previous, step = step, env.step(np.array([0.5, 0.0]))
    before = np.hypot(*(previous.observation["achieved_goal"][:2] - first.observation["desired_goal"][:2]))
    after = np.hypot(*(step.observation["achieved_goal"][:2] - first.observation["desired_goal"][:2]))
    assert after < before - planning_rewards.PROGRESS_DEADBAND and step.reward == pytest.approx(0.5 - 0.05)


def test_avoid_reward_and_safety_violation_from_the_sonar():
    # Facing the end cap of a 60 m wide tunnel from 4 .. 20 m (its face is at x = 130 m).
    env = tunnel.tunnel(arena=small_tunnel(half_width=30.0, bounds=(-20, -40, 150, 40)), reward="paper")
    env.reset()
    d0 = planning_rewards.repulsion_range(env.physics)
    for gap in (20.0, 9.0, 5.5):
        env.reset()
        place(env, 130.0 - gap - SONAR_OFFSET, 0.0, 0.0)
        env.step(HOLD)
        info = env.task.last_info
        assert info["min_sonar_range"] == pytest.approx(gap, abs=0.05)
        assert info["reward_avoid"] == pytest.approx(planning_rewards.avoid_reward(info["min_sonar_range"], d0))
        assert info["goal_independent_reward"] == pytest.approx(info["reward_avoid"] - 0.05)
        assert info["safety_violation"] == (gap < SAFETY_DISTANCE + 0.05)
    env.reset()
    place(env, 130.0 - 4.0 - SONAR_OFFSET, 0.0, 0.0)
    env.step(HOLD)
    info = env.task.last_info
    assert info["safety_violation"] and info["reward_avoid"] == -1.0 and not info["collision"]
    assert info["min_clearance"] == pytest.approx(4.0, abs=0.05)


# --- scripted episodes ------------------------------------------------------------------------------


def test_line_of_sight_reaches_the_goal():
    env = suite.load("auv", "goal", task_kwargs={"scenario": "a2", "reward": "paper"})
    steps, infos = run(env, line_of_sight)
    assert infos[-1]["event"] == "goal" and infos[-1]["success"] and steps[-1].discount == 0.0
    assert np.hypot(*(steps[-1].observation["achieved_goal"][:2] - [200, 200])) <= routes.GOAL_RADIUS
    assert len(steps) < 0.8 * env._step_limit and not any(i["collision"] for i in infos)


def test_waypoints_advance_in_turn_with_the_reached_bonus():
    env = suite.load("auv", "waypoints", task_kwargs={"layout": "b2", "reward": "paper"})
    steps, infos = run(env, lambda obs: line_of_sight(obs, speed=1.0))
    events = [(i, info) for i, info in enumerate(infos) if info["event"]]
    assert [info["event"] for _, info in events] == ["subgoal", "subgoal", "goal"]
    targets = [steps[i].observation["desired_goal"][:2] for i, _ in events]  # the goal each step aimed at
    np.testing.assert_array_equal(targets, env.task.goals)
    for i, info in events:  # steps[i + 1] is the step after which the event was reported
        assert info["reward_following"] == planning_rewards.FOLLOW_REACHED
        before, after = steps[i].observation["desired_goal"][:2], steps[i + 1].observation["desired_goal"][:2]
        assert (info["event"] == "goal") == np.array_equal(before, after)
    assert steps[-1].discount == 0.0 and infos[-1]["success"]


def test_scripted_traversal_of_the_tunnel_inspection_arena():
    """The full Sec. 4.3 tunnel (about 1400 planner steps), past its unknown moving obstacle."""
    env = suite.load("auv", "tunnel", task_kwargs={"reward": "paper"})
    info = arena_info(env.physics)
    np.testing.assert_allclose(info.start, [670, 125])
    steps, infos = run(env, line_of_sight_avoiding)
    assert infos[-1]["event"] == "goal" and infos[-1]["success"], infos[-1]
    np.testing.assert_allclose(steps[-1].observation["achieved_goal"][:2], [0, 150], atol=routes.SUBGOAL_RADIUS)
    assert not any(i["collision"] for i in infos)
    assert infos[-1]["goals_reached"] == infos[-1]["num_goals"] == len(env.task.goals)
    cross_track = np.array([i["cross_track_error"] for i in infos])
    assert np.all(np.isfinite(cross_track)) and cross_track.max() < 15.0


def test_path_following_reports_cross_track_error():
    env = suite.load("auv", "path_line", task_kwargs={"reward": "paper"})
    steps, infos = run(env, lambda obs: line_of_sight(obs, speed=1.0))
    assert infos[-1]["success"]
    assert infos[0]["cross_track_error"] == pytest.approx(130.0, abs=1.0)  # from (70, 40) to (200, 40)
    on_path = [i["cross_track_error"] for i in infos if i["goals_reached"] > 0]
    assert max(on_path) < 10.0
    goals = env.task.goals
    np.testing.assert_allclose(goals[0], [200, 40]) and np.testing.assert_allclose(goals[-1], [300, 300])
    assert np.max(np.hypot(*np.diff(goals, axis=0).T)) <= routes.SUBGOAL_SPACING + 1e-9
    env = suite.load("auv", "path_curve")
    env.reset()
    goals = env.task.goals
    np.testing.assert_allclose(goals[:, 1], 30 * np.sin(0.02 * goals[:, 0]) + 180, atol=5e-3)  # 1 m chords
    assert goals[0, 0] == pytest.approx(65) and goals[-1, 0] == pytest.approx(500)


# --- events, walls and sonar ------------------------------------------------------------------------


def test_driving_into_a_wall_is_a_collision_and_the_wall_holds():
    # Start 6 m from the north wall (inner face y = 10), heading straight at it.
    env = tunnel.tunnel(arena=small_tunnel(heading=math.pi / 2), reward="paper")
    env.reset()
    place(env, 0.0, 4.0, math.pi / 2)
    steps, infos = [], []
    while not (steps and steps[-1].last()):
        steps.append(env.step(np.array([0.5, 0.0])))
        infos.append(env.task.last_info)
    assert len(steps) < 30
    info = infos[-1]
    assert info["event"] == "collision" and info["collision"] and steps[-1].discount == 0.0
    assert info["reward_avoid"] == -1.0 and not info["success"] and info["min_clearance"] < 0.01
    assert not any(i["collision"] for i in infos[:-1])
    assert env.step(np.zeros(2)).first()  # the next step resets
    place(env, 0.0, 4.0, math.pi / 2)
    env.task._command = (2.0, math.pi / 2)  # full ahead into the wall for 30 s, through the executor
    env.physics.step(3000)
    assert env.physics.pose()[1] < 10.0 - 0.665 + 0.05  # the hull's nose is held at the wall face
    assert env.physics.data.ncon > 0


def test_leaving_the_map_ends_the_episode():
    env = tunnel.tunnel(arena=small_tunnel(heading=math.pi, start_cap=False, bounds=(-5, -30, 150, 30)),
                        reward="paper")
    steps, infos = run(env, lambda obs: np.array([0.5, 0.0]), max_steps=100)
    assert infos[-1]["event"] == "left_map" and infos[-1]["left_map"] and steps[-1].discount == 0.0
    assert steps[-1].observation["achieved_goal"][0] < -5 and infos[-1]["reward_avoid"] == -1.0


def test_sonar_sees_the_walls_of_a_tunnel_exactly():
    env = tunnel.tunnel(arena=small_tunnel())
    env.reset()
    sonar = place(env, 40.0, 2.0, 0.0)
    assert sonar[0] == pytest.approx(12.0, abs=1e-6)  # S1, starboard: wall face at y = -10
    assert sonar[8] == pytest.approx(8.0, abs=1e-6)  # S9, port: wall face at y = +10
    assert sonar[4] == pytest.approx(130.0 - 40.0 - SONAR_OFFSET, abs=1e-6)  # S5 ahead: end cap
    assert sonar[2] == pytest.approx(12.0 * math.sqrt(2), abs=1e-6)  # S3, -45 deg
    observation = env.task.get_observation(env.physics)  # sampled once per planner step (2 Hz) ...
    # ... so still the reset's
    assert observation["observation"][planning_observation.SONAR_SLICE][0] * SONAR_RANGE == pytest.approx(10.0)


def test_sonar_sees_moving_obstacles_where_they_are():
    mover = (60.0, -6.0, 60.0, 6.0, 0.1, 2.0)
    env = tunnel.tunnel(arena=small_tunnel(mover=mover))
    env.reset()
    for _ in range(40):  # 20 s: the mover has gone 2 m north
        env.step(HOLD)
    (moving,) = env.task._route.movers
    centre = moving.position(env.physics.time())
    assert centre[1] == pytest.approx(-6.0 + 0.1 * env.physics.time(), abs=0.02)
    np.testing.assert_allclose(env.physics.named.data.mocap_pos["mover_test"][:2], centre, atol=0.02)
    sonar = place(env, centre[0] - 20.0, centre[1], 0.0)
    assert sonar[4] == pytest.approx(20.0 - 2.0 - SONAR_OFFSET, abs=0.03)


def _free_direction(centre, reach, blockers):
    """A direction from which a ray of length `reach` to `centre` passes no other bounding circle."""
    for angle in np.linspace(0, 2 * np.pi, 32, endpoint=False):
        direction = np.array([math.cos(angle), math.sin(angle)])
        origin = centre + reach * direction
        if all(routes.distance_to_polyline(c, np.array([origin, centre])) > r + 1.0 for c, r in blockers):
            return direction
    return None


ARENAS = [("obstacles", {"scenario": "a"}), ("obstacles", {"scenario": "b"}),
          ("obstacles", {"random": 5}), ("moving_obstacles", {"scenario": "a"}),
          ("moving_obstacles", {"scenario": "b"}), ("moving_obstacles", {"random": 5}), ("tunnel", {})]


@pytest.mark.parametrize("name, kwargs", ARENAS)
def test_sonar_sees_every_obstacle_of_every_arena(name, kwargs):
    env = suite.load("auv", name, task_kwargs=kwargs)
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    vehicle = model.body("auv").id
    geoms = [g for g in range(model.ngeom)
             if model.geom_bodyid[g] != vehicle and abs(data.geom_xpos[g][2]) < 1]  # not parked
    assert geoms
    circles = {g: (data.geom_xpos[g][:2].copy(), float(model.geom_rbound[g])) for g in geoms}
    seen = 0
    for g in geoms:
        centre, radius = circles[g]
        reach = radius + 15.0
        direction = _free_direction(centre, reach, [c for h, c in circles.items() if h != g])
        if direction is None:  # a wall of a tunnel, boxed in by its neighbours: checked below
            continue
        origin = centre + reach * direction
        sonar = place(env, *origin, math.atan2(*(-direction)[::-1]))
        assert reach - radius - SONAR_OFFSET - 1e-6 <= sonar[4] <= reach - SONAR_OFFSET, model.geom(g).name
        seen += 1
    assert seen >= (len(geoms) if name != "tunnel" else 2)
    if name == "tunnel":  # from every path point, both side beams hit a wall within the 50 m tunnel's width
        for point, after in zip(arena_info(env.physics).path[:-1], arena_info(env.physics).path[1:],
                                strict=True):
            sonar = place(env, *point, math.atan2(*(after - point)[::-1]))
            assert SAFETY_DISTANCE < sonar[0] < 40.0 and SAFETY_DISTANCE < sonar[8] < 40.0


def test_random_obstacles_keep_off_the_start_and_the_goal():
    env = suite.load("auv", "obstacles", task_kwargs={"random": 11})
    model, data = env.physics.model.ptr, env.physics.data.ptr
    counts = set()
    for _ in range(10):
        step = env.reset()
        start, goal = step.observation["achieved_goal"][:2], step.observation["desired_goal"][:2]
        active = [g for g in range(model.ngeom) if model.geom(g).name.startswith("obstacle_")
                  and abs(data.geom_xpos[g][2]) < 1]
        counts.add(len(active))
        for g in active:
            centre, radius = data.geom_xpos[g][:2], model.geom_rbound[g]
            for point in (start, goal):
                assert np.hypot(*(centre - point)) >= radius + obstacles.CLUTTER.clearance - 1e-9
            exact = mujoco.mj_geomDistance(model, data, model.geom("hull").id, g, 1e3, None)
            assert exact > obstacles.CLUTTER.clearance - 1.0
    assert len(counts) > 1 and min(counts) >= obstacles.CLUTTER.obstacles[0]


def test_named_layouts_fit_their_time_limits():
    for name, kwargs in [("waypoints", {"layout": "c"}), ("waypoints", {"layout": "d"}), ("tunnel", {}),
                         ("path_curve", {}), ("goal", {"scenario": "a1"})]:
        env = suite.load("auv", name, task_kwargs=kwargs)
        step = env.reset()
        route = np.vstack([step.observation["achieved_goal"][:2], env.task.goals])
        limit = env._step_limit * planning_step.PLANNER_DT
        assert routes.path_length(route) / routes.TARGET_SPEED < 0.75 * limit, (name, kwargs)


@pytest.mark.parametrize("reward", ["progress", "paper"])
def test_a_collision_penalty_is_subtracted_on_the_collision_step_only(reward):
    rewards, events = {}, {}
    for penalty in (0.0, 40.0):  # the same seed and actions: the runs differ only in the reward
        env = suite.load("auv", "obstacles", task_kwargs={"random": 3, "reward": reward, "collision_penalty": penalty})
        env.reset()
        trace = []
        for _ in range(400):
            time_step = env.step(np.array([1.0, 0.0]))  # full speed ahead, into whatever is there
            trace.append(time_step.reward)
            if time_step.last():
                break
        rewards[penalty], events[penalty] = np.array(trace), env.task.last_info["event"]
    assert events[0.0] == events[40.0] in ("collision", "left_map")
    np.testing.assert_array_equal(rewards[0.0][:-1], rewards[40.0][:-1])
    assert rewards[40.0][-1] == pytest.approx(rewards[0.0][-1] - 40.0)
    with pytest.raises(ValueError, match="collision_penalty"):
        suite.load("auv", "goal", task_kwargs={"collision_penalty": -1.0})


@pytest.mark.parametrize("load", [lambda: planning_physics.Physics.load(planning_physics.open_water_arena()),
                                  lambda: __import__("auv_mj.tasks.auv3d", fromlist=["Physics3D"]).Physics3D.load()],
                         ids=["planar", "6dof"])
def test_the_executor_clock_ticks_before_the_first_step_and_then_every_period(load):
    """`auv_mj.control.clock.ExecutorClock`: over n physics steps of dt, a period of k steps ticks ceil(n / k) times, in
    whatever chunks `step` is called, a copy keeps the clock and a reset starts it at a tick."""
    physics = load()
    ticks: list[float] = []
    physics.set_tick(lambda p: ticks.append(p.data.time))
    k = round(physics.TICK_PERIOD / physics.timestep())
    assert k >= 2
    for chunk in (1, 3, k, 2 * k + 1, 5):
        physics.step(chunk)
    n = 1 + 3 + k + 2 * k + 1 + 5
    assert len(ticks) == math.ceil(n / k)
    np.testing.assert_allclose(np.diff(ticks), physics.TICK_PERIOD, atol=1e-9)
    twin = physics.copy()
    before = len(ticks)
    twin.step(k)
    physics.step(k)
    assert len(ticks) == before + 2  # one tick each: the copy shares the callback and where the clock stood
    physics.reset()
    physics.step(1)
    assert len(ticks) == before + 3
    physics.set_tick(None)
    physics.step(3 * k)
    assert len(ticks) == before + 3
