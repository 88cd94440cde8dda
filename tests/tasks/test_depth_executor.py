"""The learned depth executor's plumbing on the 6-DOF vehicle (`auv_mj.tasks.depth_executor`): its observation,
how its residual or scheduled gains reach the depth-heading S-plane, the re-tuned gains, and the registry's
entries that run it (`depth-executor`, `two-layer-3d`, `splane-ocean` on the auv3d tasks)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj.control.depth_heading import (
    OCEAN_DEPTH_GAINS,
    SCHEDULED_GAINS,
    DepthHeadingController,
    DepthHeadingGains,
)
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks.depth_executor import (
    HISTORY_NAMES,
    INTEGRAL_NAMES,
    RESIDUAL_NAMES,
    SENSOR_NAMES,
    DepthExecutorMemory,
    executor_options,
)

SHORT = {"time_limit": 4.0, "command": "random", "conditions": "ocean"}


def _env(**kwargs):
    return suite.load("auv3d", "depth_heading", task_kwargs={"random": 5, **SHORT, **kwargs})


def _run_against_reference(env, reference: DepthHeadingController, action, expected):
    """Steps `env` with `action`; before each step `expected(reference output)` must be the control the task
    sets, bit for bit."""
    task, physics = env.task, env.physics
    env.reset()
    reference.reset()
    for _ in range(30):
        want = expected(reference(task.command(physics), task.state(physics)))
        env.step(action)
        np.testing.assert_array_equal(physics.control(), want)


@pytest.mark.parametrize("kwargs", [{"gains": 0.5, "base": "ocean"}, {"residual": 0.5, "observation": "history"}])
def test_a_zero_action_is_the_s_plane_bit_for_bit(kwargs):
    env = _env(**kwargs)
    low, high = env.physics.model.actuator_ctrlrange.T
    base = OCEAN_DEPTH_GAINS if kwargs.get("base") == "ocean" else DepthHeadingGains()
    zero = np.zeros(env.action_spec().shape)
    _run_against_reference(env, DepthHeadingController(base), zero, lambda u: np.clip(u, low, high))


def test_scheduled_gains_reach_the_controller_as_powers_of_two():
    env = _env(gains=1.0)
    assert env.action_spec().shape == (len(SCHEDULED_GAINS),)
    action = np.linspace(-1.0, 1.0, len(SCHEDULED_GAINS))
    scaled = dataclasses.replace(DepthHeadingGains(), **{
        name: getattr(DepthHeadingGains(), name) * 2.0 ** a for name, a in zip(SCHEDULED_GAINS, action, strict=True)})
    low, high = env.physics.model.actuator_ctrlrange.T
    want = DepthHeadingController(scaled)
    # the scaled controller computes the same S-surfaces (float products may differ in the last bit)
    task, physics = env.task, env.physics
    env.reset()
    for _ in range(30):
        expected = np.clip(want(task.command(physics), task.state(physics)), low, high)
        env.step(action)
        np.testing.assert_allclose(physics.control(), expected, rtol=1e-12, atol=1e-12)


def test_the_residual_adds_its_span_in_half_ranges():
    env = _env(residual=0.5)
    low, high = env.physics.model.actuator_ctrlrange.T
    action = np.array([0.4, -0.6, 1.0])
    _run_against_reference(env, DepthHeadingController(), action,
                           lambda u: np.clip(np.clip(u, low, high) + 0.5 * action * 0.5 * (high - low), low, high))


def test_the_history_observation_holds_integrals_last_controls_and_the_s_plane():
    env = _env(residual=1.0, observation="history")
    size = len(SENSOR_NAMES) + len(INTEGRAL_NAMES) + len(HISTORY_NAMES) + len(RESIDUAL_NAMES)
    assert env.observation_spec()["observation"].shape == (size,)
    physics = env.physics
    low, high = physics.model.actuator_ctrlrange.T
    env.reset()
    first = env.step(np.array([0.2, -0.3, 0.1]))
    applied = physics.control().copy()
    second = env.step(np.zeros(3))
    history = second.observation["observation"][len(SENSOR_NAMES) + len(INTEGRAL_NAMES):][:len(HISTORY_NAMES)]
    normalised = lambda u: 2 * (u - low) / (high - low) - 1  # noqa: E731
    np.testing.assert_allclose(history[:3], normalised(physics.control()))
    np.testing.assert_allclose(history[3:6], normalised(applied))
    np.testing.assert_array_equal(history[6:], 0.0)
    splane = second.observation["observation"][-3:]
    assert np.all(np.abs(splane) <= 1.0) and first.observation["observation"].shape == (size,)


def test_the_plain_observation_is_the_sensor_vector():
    env = _env()
    step = env.reset()
    state, command = env.task.state(env.physics), env.task.command(env.physics)
    obs = step.observation["observation"]
    assert obs.shape == (len(SENSOR_NAMES),) and auv3d.EXECUTOR_OBSERVATION == SENSOR_NAMES
    assert obs[0] == command[0] and obs[1] == state.u and obs[10] == command[2] - state.depth


def test_options_are_checked_and_read_back_from_a_checkpoint():
    with pytest.raises(ValueError, match="residual and gains"):
        DepthExecutorMemory(residual=0.5, gains=0.5)
    with pytest.raises(ValueError, match="set residual or gains"):
        DepthExecutorMemory(base="ocean")
    with pytest.raises(ValueError, match="gains"):
        DepthExecutorMemory(gains=9.0)
    size = len(SENSOR_NAMES) + len(INTEGRAL_NAMES) + len(HISTORY_NAMES)
    trained = {"gains": 0.5, "base": "ocean", "observation": "history", "command": "random"}
    assert executor_options(size, trained) == {"observation": "history", "residual": 0.0, "gains": 0.5,
                                               "base": "ocean"}
    with pytest.raises(ValueError, match="inputs, not 3"):
        executor_options(3, trained)


def test_the_ocean_gains_load_and_differ_from_the_hand_set_ones():
    assert isinstance(OCEAN_DEPTH_GAINS, DepthHeadingGains) and OCEAN_DEPTH_GAINS != DepthHeadingGains()
    assert all(getattr(OCEAN_DEPTH_GAINS, f.name) > 0 for f in dataclasses.fields(DepthHeadingGains))
    controller = DepthHeadingController(OCEAN_DEPTH_GAINS)
    env = _env()
    env.reset()
    out = controller(env.task.command(env.physics), env.task.state(env.physics))
    assert out.shape == (3,) and np.all(np.isfinite(out))


@pytest.mark.parametrize("policy,task", [("depth-executor", "depth_heading"), ("splane-ocean", "depth_heading"),
                                         ("two-layer-3d", "goal3d"), ("two-layer-3d", "tunnel3d"),
                                         ("splane-ocean", "tunnel3d")])
def test_registry_entries_run_a_few_steps(policy, task):
    from auv_mj.zoo.registry import LearnedExecutor, env_and_policy

    env, act = env_and_policy(policy, task, 20_000, {"conditions": "ocean", "time_limit": 2.0})
    step = env.reset()
    for _ in range(5):
        step = env.step(act(step))
        assert np.all(np.isfinite(env.physics.control()))
    if policy == "two-layer-3d":
        assert isinstance(env.task.executor, LearnedExecutor)
        assert isinstance(env.task.executor.memory, DepthExecutorMemory)
    if policy == "splane-ocean" and task == "tunnel3d":
        assert env.task.executor.gains == OCEAN_DEPTH_GAINS


def test_a_short_tuning_writes_its_best_gains_and_they_read_back(tmp_path):
    from experiments import depth_tuning

    best = tmp_path / "best.json"
    gains = depth_tuning.tune(max_evaluations=2, seeds=[depth_tuning.train_seed(1, 0)], best_file=best)
    assert depth_tuning.read_gains(best) == gains
    assert gains.band_depth == DepthHeadingGains().band_depth  # untuned fields stay as set
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ValueError, match="bad.json"):
        depth_tuning.read_gains(tmp_path / "bad.json")


def test_residual_and_gains_are_refused_together_and_out_of_range():
    """The depth executor takes the planar executor's rule for the two ways of building on an S-plane
    (`auv_mj.tasks.options.splane_building`): one of them, each within its range."""
    from auv_mj.tasks import options
    from auv_mj.tasks.depth_executor import DepthExecutorMemory

    with pytest.raises(ValueError, match="set one of them"):
        DepthExecutorMemory(residual=0.5, gains=1.0)
    with pytest.raises(ValueError, match="gains"):
        DepthExecutorMemory(gains=options.MAX_GAIN_OCTAVES + 1.0)
    assert DepthExecutorMemory(gains=options.MAX_GAIN_OCTAVES).gains == options.MAX_GAIN_OCTAVES
