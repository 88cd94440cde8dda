"""The suite domain "auv3d" (issue 32): dm_env and Gymnasium conformance, seeding, the classical baselines."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners import los3d
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks.gym_adapter import GYM_IDS_3D

pytestmark = pytest.mark.filterwarnings("ignore:.*Box observation space m.* value is .*infinity")
TASKS_3D = [name for _, name in suite.TASKS_3D]
SHORT = {"time_limit": 3.0}


def test_the_domain_holds_the_three_tasks_and_loads_by_name():
    assert set(TASKS_3D) == {"depth_heading", "goal3d", "tunnel3d"}
    assert set(suite.TASKS_BY_DOMAIN["auv3d"]) == set(TASKS_3D)
    assert all(suite.domain_of(name) == "auv3d" for name in TASKS_3D) and suite.domain_of("goal") == "auv"
    assert set(GYM_IDS_3D.values()) == set(TASKS_3D)
    with pytest.raises(ValueError, match="valid tasks"):
        suite.load("auv3d", "goal")
    with pytest.raises(ValueError, match="no option 'bogus'"):
        suite.load("auv3d", "depth_heading", task_kwargs={"bogus": 1})


@pytest.mark.parametrize("name", TASKS_3D)
def test_dm_env_conformance_and_seeding(name):
    env = suite.load("auv3d", name, task_kwargs={"random": 3, **SHORT})
    obs_spec, action_spec = env.observation_spec(), env.action_spec()
    first = env.reset()
    assert first.first() and first.reward is None and first.discount is None
    for key, spec in obs_spec.items():
        spec.validate(first.observation[key])
    steps = [first]
    rng = np.random.default_rng(0)
    while not steps[-1].last():
        step = env.step(rng.uniform(action_spec.minimum, action_spec.maximum, action_spec.shape))
        for key, spec in obs_spec.items():
            spec.validate(step.observation[key])
        assert np.isfinite(step.reward) and step.discount in (0.0, 1.0)
        steps.append(step)
    again = suite.load("auv3d", name, task_kwargs={"random": 3, **SHORT})
    repeat = again.reset()
    np.testing.assert_array_equal(repeat.observation["observation"], first.observation["observation"])
    rng = np.random.default_rng(0)
    for step in steps[1:]:
        np.testing.assert_array_equal(again.step(rng.uniform(action_spec.minimum, action_spec.maximum,
                                                              action_spec.shape)).observation["observation"],
                                      step.observation["observation"])


@pytest.mark.parametrize("env_id", sorted(GYM_IDS_3D))
def test_gymnasium_env_checker_passes(env_id):
    env = gymnasium.make(env_id, task_kwargs=SHORT)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_ocean_conditions_run_and_change_the_episode():
    ideal = suite.load("auv3d", "depth_heading", task_kwargs={"random": 1, **SHORT})
    wet = suite.load("auv3d", "depth_heading", task_kwargs={"random": 1, "conditions": "ocean", **SHORT})
    for env in (ideal, wet):
        env.reset()
        for _ in range(20):
            env.step(np.zeros(3))
    assert np.any(wet.physics.model.opt.wind != 0.0) and not np.any(ideal.physics.model.opt.wind != 0.0)
    assert wet.physics.model.actuator_dyntype[0] != ideal.physics.model.actuator_dyntype[0]  # lagged thrust
    assert not np.allclose(wet.physics.position(), ideal.physics.position())


def test_classical_executor_holds_depth_heading_within_half_a_metre():
    env = auv3d.depth_heading(random=0)
    record = record_episode(env, auv3d.splane_policy(env), task="depth_heading", policy_name="splane")
    metrics = episode_metrics(record)
    assert metrics["mae_depth"] <= 0.5
    assert metrics["mae_heading"] <= 0.15 and metrics["mae_speed"] <= 0.05
    assert np.ptp(record.info["depth_error"]) > 2.0  # the start's dive and the disturbances moved it


@pytest.mark.parametrize("seed, avoid", [(0, False), (1, True)])
def test_line_of_sight_gets_through_procedural_tubes_clear_of_the_wall(seed, avoid):
    env = auv3d.tunnel3d(random=seed)
    policy = los3d.los_policy(env, avoid=avoid)
    step = env.reset()
    tube = env.task.path
    assert np.ptp(tube[:, 2]) > 2.0  # it climbs or dives
    clearance = []
    while not step.last():
        step = env.step(policy(step))
        clearance.append(env.task.last_info["min_clearance"])
    assert env.task.last_info["event"] == "goal"
    assert min(clearance) > 0.5


def test_los_avoid_reaches_goal3d_over_the_seabed():
    env = auv3d.goal3d(random=0)
    policy = los3d.los_policy(env, avoid=True)
    step = env.reset()
    while not step.last():
        step = env.step(policy(step))
    assert env.task.last_info["event"] == "goal"
