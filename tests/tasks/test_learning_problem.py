"""The learning problem of issue 51: the geodesic reward, the rate action and the planner observation.

The reward's property is tested on whole scripted episodes, as the issue's "Why" measured the old rewards: on
certified trap arenas of both tiers, tunnels included, at the discount a learner of it uses (GEODESIC_DISCOUNT),
going round (the `oracle`, which reaches the goal) returns more than crashing into a trap (`splane`, line of sight,
which follows the straight line or the tunnel's axis into the cup), more than waiting at the start or half-way round,
and more than the same way round started late.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from geodesic_returns import GAMMA, discounted, trap_runs

from auv_mj.arenas.geodesic import GeodesicField
from auv_mj.arenas.sonar_memory import CELL, MEMORY_BEAMS, MEMORY_NAMES, MEMORY_RANGE, SonarMemory, memory_bounds
from auv_mj.episode import VEHICLE_BODY, arena_geometry
from auv_mj.planners.guidance import classical
from auv_mj.planners.map_planner import route_target
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import planning_observation, planning_rewards, planning_step, suite
from auv_mj.tasks.routes import goal_distance

IDLE = np.array([-1.0, 0.0])
"""Thrust off: V = 0, the heading command kept (either action map)."""
LATE_STEPS = 60
"""The late start idles this many planner steps (30 s) before the oracle drives."""
TRAP_CASES = [("obstacles", "hard", 0), ("tunnel", "hard", 1), ("tunnel", "standard", 3)]
"""(task, tier, seed): certified arenas (random per seed) where `splane` crashes and the oracle goes round."""


@pytest.mark.parametrize(("task", "tier", "seed"), TRAP_CASES)
def test_going_round_returns_more_than_crashing_waiting_or_arriving_late(task, tier, seed):
    runs = trap_runs(task, tier, seed, IDLE, LATE_STEPS)
    returns = {name: discounted(rewards) for name, (rewards, _) in runs.items()}
    assert len(runs["late"][0]) > len(runs["round"][0])
    assert returns["round"] > max(returns["crash"], returns["wait_start"], returns["wait_half"], returns["late"])
    assert returns["late"] > max(returns["crash"], returns["wait_start"], returns["wait_half"])


@pytest.mark.parametrize("tier", ["standard", "hard"])
def test_the_field_is_the_episodes_own_arena(tier):
    """The potential is searched on the episode's obstacles where the route placed them (the standard tier moves mocap
    boxes in `route`), not on the last episode's: it equals a field built from the arena after the reset."""
    env = suite.load("auv", "obstacles", task_kwargs={"random": 3, "arena": "random", "tier": tier,
                                                      "reward": "geodesic"})
    for _ in range(2):
        env.reset()
        task = env.task
        geometry = arena_geometry(env.physics, task)
        static = [p for p, owner in zip(geometry.polygons, geometry.owners, strict=True) if owner == -1]
        assert static
        expected = GeodesicField.of_arena(static, task.episode.bounds, task.goals[-1], task.goal_radius)
        got = task.episode.potential.fields[0]
        assert isinstance(got, GeodesicField)
        np.testing.assert_array_equal(got.field, expected.field)


def test_the_constants_make_every_failure_worth_less_than_waiting_and_success_worth_more():
    """Sec. "The geodesic reward" of `planning_rewards`: with C >= W = step cost / (1 - gamma) and B >= 0, for any
    episode lengths a success returns more than waiting for ever, which returns at least as much as a failure."""
    assert 0.995 <= GAMMA <= 0.999
    horizon = planning_rewards.GEODESIC_STEP_COST / (1 - GAMMA)
    assert planning_rewards.GEODESIC_COLLISION_PENALTY >= horizon - 1e-9
    assert planning_rewards.GEODESIC_SUCCESS_BONUS >= 0
    gain, rng = planning_rewards.PROGRESS_GAIN, np.random.default_rng(0)
    for _ in range(200):
        d0, d_fail = rng.uniform(0, 800, 2)
        t_success, t_fail = rng.integers(1, 4000, 2)
        success = gain * d0 + GAMMA ** t_success * (planning_rewards.GEODESIC_SUCCESS_BONUS + horizon) - horizon
        wait = gain * d0 - horizon  # for ever: the potential's last term vanishes
        failure = gain * d0 \
            - GAMMA ** t_fail * (gain * d_fail + planning_rewards.GEODESIC_COLLISION_PENALTY - horizon) - horizon
        assert success > wait >= failure - 1e-9


def test_the_step_reward_is_gamma_phi_next_minus_phi():
    before, after = np.array([100.0, 50.0, 10.0]), np.array([99.0, 0.0, 12.0])
    reward = planning_rewards.geodesic_reward(before, after, [False, True, False], [False, False, True])
    phi = -planning_rewards.PROGRESS_GAIN
    expected = GAMMA * phi * after - phi * before - planning_rewards.GEODESIC_STEP_COST \
        + np.array([0.0, planning_rewards.GEODESIC_SUCCESS_BONUS, -planning_rewards.GEODESIC_COLLISION_PENALTY])
    np.testing.assert_allclose(reward, expected, atol=1e-12)


@pytest.mark.parametrize(("name", "options"), [
    ("waypoints", {"layout": "b2", "time_limit": 470.0}),
    ("tunnel", {"arena": "random", "arena_spec": {"length": [300, 300]}, "random": 1}),
])
def test_compute_reward_is_the_step_reward_and_relabels_on_the_straight_distance(name, options):
    """GoalEnv's invariant under reward="geodesic": compute_reward(achieved, desired, info) is the step's reward for
    the step's own goal (a route of many goals included: its potential adds the legs after the current goal); a
    relabelled goal is shaped on the straight distance to its region, and succeeds where reached without a failure."""
    env = suite.load("auv", name, task_kwargs={**options, "reward": "geodesic"})
    task, drive = env.task, classical(env)
    time_step = env.reset()
    rewards, infos, achieved, desired = [], [], [], []
    while not time_step.last() and len(rewards) < 400:
        desired.append(time_step.observation["desired_goal"])
        time_step = env.step(drive(time_step))
        rewards.append(time_step.reward)
        infos.append(task.last_info)
        achieved.append(time_step.observation["achieved_goal"])
    achieved, desired = np.array(achieved), np.array(desired)
    assert any(info["event"] == "subgoal" for info in infos)
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, infos), rewards)
    as_dict = {key: np.array([info[key] for info in infos]) for key in infos[0]}
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, as_dict), rewards)
    relabelled = task.compute_reward(achieved, achieved, as_dict)  # reached at once: the bonus on every step
    radius = as_dict["goal_radius"]
    before = np.maximum(goal_distance(as_dict["previous_achieved_goal"], achieved) - radius, 0.0)
    np.testing.assert_allclose(relabelled, planning_rewards.geodesic_reward(before, 0.0, True, False), atol=1e-12)
    assert np.all(task.compute_terminated(achieved, achieved, as_dict))


# --- the rate action -------------------------------------------------------------------------------------------


def test_the_rate_action_maps_a1_linearly_onto_the_heading_commands_change_and_a0_onto_the_speed():
    """action="rate": psi_cmd += a1 MAX_HEADING_CHANGE, linear over the whole of [-1, 1] (Table 1's 6 deg per step);
    V_cmd = a0 + 1, linear onto [0, 2] m/s; the one limit is the executor's, Table 1's 30 deg from the heading."""
    a = np.linspace(-1.0, 1.0, 41)
    psi = np.full(len(a), 0.3)
    command = planning_step.executor_command(np.stack([a, a], axis=1), psi, psi.copy(), "rate")
    np.testing.assert_allclose(command[:, 1] - psi, a * planning_step.MAX_HEADING_CHANGE, atol=1e-12)
    np.testing.assert_allclose(command[:, 0], a + 1.0, atol=1e-12)
    assert command[0, 0] == planning_step.MIN_SPEED and command[-1, 0] == planning_step.MAX_SPEED
    # A command already 27 deg to port: a turn further to port saturates at 30 deg, the rest is still linear.
    lead = np.full(len(a), math.radians(27.0))
    command = planning_step.executor_command(np.stack([a, a], axis=1), psi, psi + lead, "rate")
    change = command[:, 1] - (psi + lead)
    free = lead + a * planning_step.MAX_HEADING_CHANGE <= planning_step.MAX_HEADING_DIFFERENCE
    np.testing.assert_allclose(change[free], a[free] * planning_step.MAX_HEADING_CHANGE, atol=1e-12)
    np.testing.assert_allclose(command[~free, 1] - psi[~free], planning_step.MAX_HEADING_DIFFERENCE, atol=1e-12)
    # The paper's map, for contrast: linear only on |a1| <= MAX_HEADING_CHANGE / ACTION_HEADING_RANGE (1/15).
    paper = planning_step.executor_command(np.stack([a, a], axis=1), psi, psi.copy())
    linear = np.abs(a) <= planning_step.MAX_HEADING_CHANGE / planning_step.ACTION_HEADING_RANGE
    np.testing.assert_allclose(np.abs(paper[~linear, 1] - psi[~linear]), planning_step.MAX_HEADING_CHANGE, atol=1e-12)


def test_the_rate_action_turns_the_vehicle_at_the_commanded_rate():
    env = suite.load("auv", "goal", task_kwargs={"random": 0, "action": "rate"})
    env.reset()
    commands = []
    for a1 in (0.5, 0.5, -0.25):
        env.step(np.array([0.0, a1]))
        commands.append(env.task.last_info["command"][1])
    change = planning_step.MAX_HEADING_CHANGE
    np.testing.assert_allclose(np.diff(commands), [0.5 * change, -0.25 * change], atol=1e-12)
    with pytest.raises(ValueError, match="action"):
        suite.load("auv", "goal", task_kwargs={"action": "offset"})


# --- the planner observation -----------------------------------------------------------------------------------


def test_the_planner_observation_shows_map_replans_target_and_no_privileged_input():
    env = suite.load("auv", "tunnel", task_kwargs={"arena": "random", "random": 1, "observation": "planner"})
    task = env.task
    assert task.observation_fields == planning_observation.PLANNER_FIELDS
    assert not set(planning_observation.PLANNER_FIELDS) & set(planning_step.PRIVILEGED_FIELDS)
    time_step = env.reset()
    assert set(time_step.observation) == {"observation", "achieved_goal", "desired_goal"}
    first = dict(zip(planning_step.PRIVILEGED_FIELDS, task.last_info["privileged"], strict=True))  # the reset's info
    assert first["time_left"] == pytest.approx(task.step_limit * planning_step.PLANNER_DT
                                               / planning_step.PRIVILEGED_TIME_SCALE)
    assert first["route_distance"] > 0 and 0 < first["clearance"] <= 1
    assert len(time_step.observation["observation"]) == len(planning_observation.PLANNER_FIELDS)
    for _ in range(40):
        cos_target, sin_target = time_step.observation["observation"][1:3]
        action = np.array([0.0, np.clip(math.atan2(sin_target, cos_target) / (math.pi / 2), -1.0, 1.0)])
        time_step = env.step(action)
        assert not time_step.last()
        vector = time_step.observation["observation"]
        pose = env.physics.pose()
        achieved = np.array([pose[0], pose[1], math.cos(pose[2]), math.sin(pose[2])])
        np.testing.assert_allclose(vector[:3], planning_observation.relative_goal(achieved, route_target(task)[0]),
                                   atol=1e-12)
        fields = dict(zip(planning_observation.PLANNER_FIELDS, vector, strict=True))
        np.testing.assert_allclose([fields["previous_speed_action"], fields["previous_heading_action"]], action)
        fence = [fields[name] for name in planning_observation.FENCE_NAMES]
        np.testing.assert_allclose(fence, task.map_fence(env.physics) / SONAR_RANGE, atol=1e-9)
        np.testing.assert_allclose(vector[planning_observation.SONAR_SLICE] * SONAR_RANGE, env.physics.sonar(),
                                   atol=1e-9)
    privileged = task.last_info["privileged"]
    assert privileged.shape == (len(planning_step.PRIVILEGED_FIELDS),)
    values = dict(zip(planning_step.PRIVILEGED_FIELDS, privileged, strict=True))
    assert values["route_distance"] == pytest.approx(task.last_info["route_distance"]
                                                     / planning_step.GOAL_DISTANCE_SCALE)
    assert values["tunnel_task"] == 1.0 and values["hard_tier"] == 0.0
    # The actor's observation cannot read the privileged quantities: `observe` runs without the true map's fields,
    # the true clearance and ranges, and gives the same vector.
    routes = task._routes
    blind = planning_step.RouteBatch(**{**vars(routes), "fields": [None], "cell": np.zeros_like(routes.cell)})
    readout = task._readout(env.physics)
    args = (planning_step.ONE_ROW, np.array([task.episode.reached]), readout, np.array([task.episode.command]),
            "planner", task.episode.action[None])
    np.testing.assert_array_equal(planning_observation.observe(blind, *args)["observation"],
                                  planning_observation.observe(routes, *args)["observation"])
    assert readout.clearance is None and readout.true_ranges is None


def _true_range(physics, psi: float) -> float:
    """The distance [m] from the vehicle's centre to the nearest geom along the world direction `psi`, in the plane
    of the vehicle (mujoco.mj_ray, the vehicle's own body left out); inf where nothing lies on the ray."""
    model, data = physics.model.ptr, physics.data.ptr
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, VEHICLE_BODY)
    x, y, _ = physics.pose()
    geom = np.zeros(1, np.int32)
    start = np.array([x, y, data.xpos[body][2]])
    hit = mujoco.mj_ray(model, data, start, np.array([math.cos(psi), math.sin(psi), 0.0]), None, 1, body, geom)
    return math.inf if hit < 0 else float(hit)


def test_the_planner_map_observation_is_the_planner_one_and_what_its_sonar_has_shown():
    """observation="planner-map" is the planner vector with the sonar map's scan before the sonar block. The scan
    remembers: flying a tunnel, the side rays read the true walls beside the vehicle (mj_ray) within two cells (but
    where a ray slips between the echoes' cells, a map of nine points a ping being sparse in a bend), never a wall
    nearer than the true one, and a new episode starts from an empty map."""
    options = {"arena": "random", "random": 2, "observation": "planner-map", "reward": "geodesic", "action": "rate"}
    env = suite.load("auv", "tunnel", task_kwargs=options)
    plain = suite.load("auv", "tunnel", task_kwargs={**options, "observation": "planner"})
    fields = planning_observation.PLANNER_MAP_FIELDS
    assert env.task.observation_fields == fields and len(fields) == len(planning_observation.PLANNER_FIELDS) + 16
    memory = [fields.index(name) for name in MEMORY_NAMES]
    assert memory == list(range(memory[0], memory[0] + MEMORY_BEAMS))
    assert memory[-1] + 1 == planning_observation.SONAR_SLICE.indices(len(fields))[0]  # just before the sonar
    errors = []
    for _ in range(2):  # the second episode starts from an empty map again
        time_step, other = env.reset(), plain.reset()
        for step in range(60):
            vector, without = time_step.observation["observation"], other.observation["observation"]
            np.testing.assert_array_equal(np.delete(vector, memory), without)
            if step == 0:
                x, y, psi = env.physics.pose()
                fresh = SonarMemory(memory_bounds(env.task.episode.bounds, np.vstack([[x, y], env.task.goals]),
                                                  SONAR_RANGE))
                fresh.add_ping([x, y], psi, env.task.binding.sonar_offset,
                               vector[planning_observation.SONAR_SLICE] * SONAR_RANGE)
                np.testing.assert_allclose(vector[memory], fresh.scan([x, y], psi), atol=1e-12)
            elif step > 20:
                psi = env.physics.pose()[2]
                for beam in (4, 12):  # port and starboard, square to the hull
                    true = _true_range(env.physics, psi + beam * 2 * math.pi / MEMORY_BEAMS)
                    if true < MEMORY_RANGE - 2 * CELL:
                        remembered = vector[memory[beam]] * MEMORY_RANGE
                        assert remembered > true - 2 * CELL  # no wall where there is none
                        errors.append(abs(remembered - true))
            cos_target, sin_target = vector[1:3]
            action = np.array([0.0, np.clip(math.atan2(sin_target, cos_target) / planning_step.MAX_HEADING_CHANGE
                                            * 0.1, -1.0, 1.0)])
            time_step, other = env.step(action), plain.step(action)
            assert not time_step.last()
    assert len(errors) > 100 and np.mean(np.array(errors) <= 2 * CELL) >= 0.95
