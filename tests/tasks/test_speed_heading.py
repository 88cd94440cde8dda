"""The speed_heading task (Sec. 3.3, 4.2): dm_env contract, seeding, Eq. (30), the disturbance schedule."""

import math

import dm_env
import numpy as np
import pytest

from auv_mj.control.splane import OCEAN_GAINS, SPlaneController, SPlaneGains
from auv_mj.geometry import wrap_angle
from auv_mj.tasks import speed_heading as sh
from auv_mj.tasks.registry import SUITE


@pytest.fixture(scope="module")
def splane_paper_trace():
    return sh.rollout(SPlaneController())


def test_registered_with_tags():
    assert "speed_heading" in SUITE
    for tag in ("benchmarking", "tracking", "executor"):
        assert "speed_heading" in SUITE.tagged(tag)


def test_dm_env_contract():
    env = sh.speed_heading(time_limit=2.0, command="random", disturbances="random", random=3)
    spec = env.action_spec()
    assert spec.shape == (2,) and np.all(spec.minimum == -1) and np.all(spec.maximum == 1)
    obs_spec = env.observation_spec()
    assert list(obs_spec) == ["observation"]
    assert obs_spec["observation"].shape == (len(sh.OBSERVATION_NAMES),)
    assert env.control_timestep() == pytest.approx(sh.EXECUTOR_DT)
    time_step = env.reset()
    assert time_step.step_type == dm_env.StepType.FIRST and time_step.reward is None
    steps = 0
    while not time_step.last():
        time_step = env.step(np.array([0.3, -0.2]))
        steps += 1
        obs_spec["observation"].validate(time_step.observation["observation"])
        assert 0.0 <= time_step.reward <= 1.0
        assert np.all(np.isfinite(time_step.observation["observation"]))
    assert steps == 20
    assert time_step.discount == 1.0  # the time limit truncates; the task never terminates
    assert env.step(np.zeros(2)).first()


def test_action_scales_to_ctrlrange():
    env = sh.speed_heading(time_limit=1.0)
    env.reset()
    env.step(np.array([1.0, -0.5]))
    np.testing.assert_allclose(env.physics.data.ctrl, [20.0, -5.0])
    env.step(np.array([3.0, -3.0]))  # out-of-range actions are clipped
    np.testing.assert_allclose(env.physics.data.ctrl, [20.0, -10.0])


def _episode(seed, steps=60):
    env = sh.speed_heading(command="random", disturbances="random", random=seed)
    time_step = env.reset()
    observations = [time_step.observation["observation"]]
    for k in range(steps):
        time_step = env.step(np.array([np.sin(0.1 * k), np.cos(0.07 * k)]))
        observations.append(time_step.observation["observation"])
    return np.array(observations), env.task


def test_seeds_are_reproducible():
    a, task_a = _episode(7)
    b, task_b = _episode(7)
    c, _ = _episode(8)
    np.testing.assert_array_equal(a, b)
    def schedule(task):
        return [(w.kind, w.start, w.steps, w.frame) for w in task._windows]

    assert schedule(task_a) == schedule(task_b)
    assert not np.allclose(a, c)


def test_random_commands_change_and_stay_in_range():
    env = sh.speed_heading(command="random", disturbances="none", random=1)
    env.reset()
    commands = set()
    for _ in range(600):
        env.step(np.zeros(2))
        commands.add(tuple(env.task.last_info["command"]))
    assert len(commands) >= 3
    for v_cmd, psi_cmd in commands:
        assert sh.RANDOM_SPEED_RANGE[0] <= v_cmd <= sh.RANDOM_SPEED_RANGE[1]
        assert -math.pi <= psi_cmd < math.pi


def test_reward_is_eq_30_on_hand_computed_cases():
    env = sh.speed_heading(reward="paper")
    env.reset()
    # Sec. 4.2 command (1 m/s, pi/12) from rest at psi = 0: r = -1 - pi/12.
    assert env.task.get_reward(env.physics) == pytest.approx(-1.0 - math.pi / 12)
    env = sh.speed_heading(reward="paper", command=(0.5, 3.0), disturbances="none")
    env.reset()
    physics = env.physics
    physics.named.data.qpos["yaw"] = -3.0
    physics.named.data.qvel["x"] = 0.2 * math.cos(-3.0)
    physics.named.data.qvel["y"] = 0.2 * math.sin(-3.0)
    physics.forward()
    env.task.after_step(physics)
    # e_V = 0.5 - 0.2; e_psi = wrap(3 - (-3)) = 6 - 2 pi (the short way round).
    assert env.task.get_reward(physics) == pytest.approx(-0.3 - (2 * math.pi - 6.0))
    assert env.task.last_info["heading_error"] == pytest.approx(6.0 - 2 * math.pi)


def test_suite_reward_is_one_on_command():
    env = sh.speed_heading(command=(0.0, 0.0), disturbances="none")
    time_step = env.reset()
    time_step = env.step(np.zeros(2))
    assert time_step.reward == pytest.approx(1.0)
    assert env.task.last_info["is_success"]


def test_executor_observation():
    obs = sh.executor_observation((1.0, 0.5), (0.8, 0.1, -0.2, 0.3))
    np.testing.assert_allclose(obs, [1.0, 0.8, 0.1, -0.2, 0.2, math.cos(0.2), math.sin(0.2)])


def test_paper_disturbance_windows():
    env = sh.speed_heading()
    env.reset()
    task = env.task
    expected = {0: "none", 249: "none", 250: "instantaneous", 349: "instantaneous", 350: "constant",
                749: "constant", 750: "periodic", 1099: "periodic"}
    for step, phase in expected.items():
        assert task.phase(step) == phase
    active = [task.disturbance_active(k) for k in range(sh.EPISODE_STEPS)]
    assert np.flatnonzero(np.diff(active)).tolist() == [249, 259, 349, 699, 749]
    assert active[250] and not active[260] and active[350] and not active[700] and active[750]


def test_disturbances_act_in_their_windows(splane_paper_trace):
    quiet = sh.rollout(SPlaneController(), disturbances="none")
    loud = splane_paper_trace
    differs = np.flatnonzero(np.abs(quiet["speed_error"] - loud["speed_error"])
                             + np.abs(quiet["heading_error"] - loud["heading_error"]) > 0)
    assert differs[0] == 250  # untouched until the burst: trace index k is the state after step k
    # The 180 N sway burst makes the vehicle slip sideways; the 30 N +y current makes it drift.
    env = sh.speed_heading()
    controller = SPlaneController()
    env.reset()
    sway = []
    for _ in range(700):
        env.step(np.clip(controller(env.task.command(env.physics), env.task.state(env.physics))
                         / [20.0, 10.0], -1, 1))
        sway.append(env.physics.body_velocity()[1])
    sway = np.array(sway)
    assert np.max(np.abs(sway[200:249])) < 0.01
    assert np.max(np.abs(sway[250:260])) > 0.1
    assert np.mean(sway[450:700]) > 0.05  # the +y force has a +sway component at psi = pi/12


def test_periodic_force_matches_the_paper():
    window = sh.paper_disturbances()[2]
    for k in (750.0, 800.0, 812.5, 1099.0):
        fx, fy = window.force(k * sh.EXECUTOR_DT)
        assert fx == pytest.approx(0.0, abs=1e-9)
        assert fy == pytest.approx(25.0 * math.sin(0.01 * math.pi * k))


def test_splane_tracks_the_paper_command_before_the_disturbances(splane_paper_trace):
    phases = splane_paper_trace["phase"]
    assert np.all(phases[:250] == "none") and phases[250] == "instantaneous"
    settled = slice(sh.SETTLE_STEPS, 250)
    assert np.mean(np.abs(splane_paper_trace["speed_error"][settled])) < 0.1
    assert np.mean(np.abs(splane_paper_trace["heading_error"][settled])) < 0.1
    mae = sh.phase_mae(splane_paper_trace)
    assert set(mae) == set(sh.PHASES)
    for mae_v, mae_psi in mae.values():
        assert mae_v < 0.2 and mae_psi < 0.2


def test_info_errors_match_the_physics():
    env = sh.speed_heading(command=(1.2, -0.4), disturbances="none")
    env.reset()
    for _ in range(5):
        env.step(np.array([0.5, -0.3]))
    info = env.task.last_info
    u = env.physics.body_velocity()[0]
    assert info["speed_error"] == pytest.approx(1.2 - u)
    assert info["heading_error"] == pytest.approx(wrap_angle(-0.4 - env.physics.pose()[2]))
    assert info["phase"] == "none" and not info["disturbance_active"]


def test_error_integral_accumulates_inside_its_band_and_clamps():
    integral = sh.ErrorIntegral()
    state = (0.9, 0.0, 0.0, 0.0)
    for k in range(1, 6):  # e_V = 0.1 (inside the band), e_psi = 0
        value = integral.update((1.0, 0.0), state)
        assert value[0] * sh.INTEGRAL_LIMIT[0] == pytest.approx(0.1 * k * sh.EXECUTOR_DT)
        assert value[1] == 0.0
    before = value.copy()
    np.testing.assert_array_equal(integral.update((2.0, 1.0), state), before)  # both errors beyond the band
    for _ in range(2000):
        value = integral.update((1.0, -0.15), state)
    np.testing.assert_allclose(value, [1.0, -1.0])  # clamped at the limits
    integral.reset()
    np.testing.assert_array_equal(integral.value, [0.0, 0.0])


def test_integral_observation_extends_eq_27_with_the_integrals():
    env = sh.speed_heading(command="random", disturbances="random", observation="integral", random=3)
    time_step = env.reset()
    assert time_step.observation["observation"].shape == (9,)
    integral = sh.ErrorIntegral()
    task, physics = env.task, env.physics
    for k in range(40):
        expected = integral.update(task.command(physics), task.state(physics))
        obs = time_step.observation["observation"]
        np.testing.assert_allclose(obs[:7], sh.executor_observation(task.command(physics), task.state(physics)))
        np.testing.assert_allclose(obs[7:], expected)
        time_step = env.step(np.array([0.3 * math.sin(0.2 * k), 0.2]))
    assert np.any(integral.value != 0.0)
    assert sh.observation_kind(7) == "paper" and sh.observation_kind(9) == "integral"
    with pytest.raises(ValueError, match="not 8"):
        sh.observation_kind(8)


@pytest.mark.parametrize("kwargs", [{"command": "fast"}, {"disturbances": "storm"}, {"reward": "dense"},
                                    {"observation": "full"},
                                    {"command": (1.0,)}, {"command": (1.0, math.nan)}])
def test_bad_settings_are_rejected(kwargs):
    with pytest.raises(ValueError):
        sh.SpeedHeading(**kwargs)


def test_speed_heading_refuses_an_infinite_action_as_the_planning_tasks_do():
    env = SUITE["speed_heading"](random=0)
    env.reset()
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.inf, 0.0]))


# --- residual executor and the "history" observation (issue 17) -------------------------------------------


@pytest.mark.parametrize("conditions", ["ideal", "ocean"])
def test_a_residual_executor_with_zero_correction_is_exactly_the_splane(conditions):
    kwargs = dict(command="random", disturbances="random", conditions=conditions, random=7, time_limit=40.0)
    env = sh.speed_heading(residual=0.8, observation="history", **kwargs)
    low, high = env.physics.model.actuator_ctrlrange.T
    shadow = SPlaneController()  # the S-plane, called on the states the vehicle reaches
    time_step, task, physics = env.reset(), env.task, env.physics
    steps = 0
    while not time_step.last():
        expected = np.clip(shadow(task.command(physics), task.state(physics)), low, high)
        time_step = env.step(np.zeros(2))
        np.testing.assert_array_equal(physics.data.ctrl, expected)  # bit for bit the S-plane's forces
        steps += 1
    assert steps == 400


def test_residual_observation_ends_with_the_splane_command_and_the_action_corrects_it():
    env = sh.speed_heading(command="random", disturbances="random", residual=0.5, random=2)
    low, high = env.physics.model.actuator_ctrlrange.T
    shadow = SPlaneController()  # the S-plane the task runs, replayed outside it
    time_step = env.reset()
    task, physics = env.task, env.physics
    assert time_step.observation["observation"].shape == (sh.observation_size("paper", True),) == (9,)
    for k in range(30):
        tau = np.clip(shadow(task.command(physics), task.state(physics)), low, high)
        np.testing.assert_allclose(time_step.observation["observation"][-2:], 2 * (tau - low) / (high - low) - 1,
                                   atol=1e-12)
        action = np.array([0.9 * math.sin(0.4 * k), -0.7])
        time_step = env.step(action)
        np.testing.assert_allclose(physics.data.ctrl, np.clip(tau + 0.5 * action * 0.5 * (high - low), low, high),
                                   atol=1e-12)


def test_history_observation_holds_the_last_commands_newest_first():
    env = sh.speed_heading(command="random", disturbances="random", observation="history", random=4)
    time_step = env.reset()
    size = sh.observation_size("history", False)
    assert size == len(sh.OBSERVATION_NAMES) + len(sh.INTEGRAL_NAMES) + len(sh.HISTORY_NAMES) == 15
    start = len(sh.OBSERVATION_NAMES) + len(sh.INTEGRAL_NAMES)
    np.testing.assert_array_equal(time_step.observation["observation"][start:], np.zeros(6))
    actions = [np.array([0.1 * k, -0.05 * k]) for k in range(1, 6)]
    for k, action in enumerate(actions):
        time_step = env.step(action)
        recent = actions[max(0, k - 2):k + 1][::-1]
        expected = np.concatenate(recent + [np.zeros(2)] * (3 - len(recent)))
        np.testing.assert_allclose(time_step.observation["observation"][start:], expected)


@pytest.mark.parametrize("residual", [-0.1, 2.5, math.nan, "big"])
def test_bad_residual_is_refused_by_name(residual):
    with pytest.raises(ValueError, match="residual"):
        sh.SpeedHeading(residual=residual)


def test_executor_options_follow_the_checkpoint_and_refuse_a_mismatch():
    assert sh.executor_options(9) == {"observation": "integral", "residual": 0.0, "gains": 0.0, "base": "nominal"}
    assert sh.executor_options(17, {"observation": "history", "residual": 0.5}) == \
        {"observation": "history", "residual": 0.5, "gains": 0.0, "base": "nominal"}
    assert sh.executor_options(15, {"observation": "history", "gains": 2})["gains"] == 2.0
    assert sh.executor_options(15, {"observation": "history", "gains": 1, "base": "ocean"})["base"] == "ocean"
    with pytest.raises(ValueError, match="has 17 inputs, not 15"):
        sh.executor_options(15, {"observation": "history", "residual": 0.5})


@pytest.mark.parametrize("action, base", [(np.zeros(4), "nominal"), (np.array([0.3, -0.2, -0.8, 0.5]), "nominal"),
                                          (np.zeros(4), "ocean"), (np.array([-0.6, 0.1, 0.4, -0.3]), "ocean")])
def test_a_gain_scheduling_executor_is_the_splane_with_the_gains_it_chose(action, base):
    import dataclasses

    env = sh.speed_heading(command="random", disturbances="random", conditions="ocean", gains=2.0,
                           observation="history", random=5, time_limit=30.0, base=base)
    assert env.action_spec().shape == (4,)
    low, high = env.physics.model.actuator_ctrlrange.T
    nominal = OCEAN_GAINS if base == "ocean" else SPlaneGains()  # the tuned gains each base names
    factors = dict(zip(sh.GAIN_NAMES, np.exp2(2.0 * action), strict=True))
    shadow = SPlaneController(dataclasses.replace(nominal, **{k: getattr(nominal, k) * f for k, f in factors.items()}))
    time_step, task, physics = env.reset(), env.task, env.physics
    while not time_step.last():
        expected = np.clip(shadow(task.command(physics), task.state(physics)), low, high)
        time_step = env.step(action)
        np.testing.assert_array_equal(physics.data.ctrl, expected)
    with pytest.raises(ValueError, match="set one of them"):
        sh.SpeedHeading(residual=0.5, gains=1.0)
    with pytest.raises(ValueError, match="gains"):
        sh.SpeedHeading(gains=5.0)


@pytest.mark.parametrize("kwargs, message", [({"gains": 1.0, "base": "tuned"}, "base"),
                                             ({"base": "ocean"}, "set residual or gains too")])
def test_a_bad_base_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        sh.SpeedHeading(**kwargs)
