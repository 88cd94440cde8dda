"""Ocean conditions (auv_mj/sim/ocean.py) and the `conditions` option of every task, against closed forms.

The current against an independent ODE lives in test_hydrodynamics.py; here: the Gauss-Markov statistics,
the thruster lag against the exact first-order response (and the lagged vehicle against the scipy
reference), sonar noise and dropouts, model uncertainty, the option on every task and Gymnasium id,
determinism per seed, and that "ideal" is the paper's world exactly as before the option existed.
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from vehicle_reference import ReferenceAUV, read_numerics

from auv_mj import cli
from auv_mj.arenas import arena
from auv_mj.control.splane import SPlaneGains
from auv_mj.episode import record_episode
from auv_mj.sim import ocean
from auv_mj.sim.hydrodynamics import HydroCoefficients
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.sim.vehicle import vehicle_facts
from auv_mj.tasks import planning_observation, suite
from auv_mj.tasks.gym_adapter import GYM_IDS
from auv_mj.zoo import registry as policies

NOMINAL = HydroCoefficients.from_mapping(read_numerics())
TAU_U, TAU_R = 0.4, 0.2
"""The thruster time constants of the shipped MJCF (actuator dynprm) [s]."""

# --- the option: presets, overrides, validation --------------------------------------------------------------


def test_presets_and_overrides():
    assert ocean.conditions("ideal") is ocean.IDEAL and ocean.conditions(None) is ocean.IDEAL
    assert ocean.IDEAL.ideal and not ocean.OCEAN.ideal and ocean.OCEAN.name == "ocean"
    every = ocean.OCEAN
    assert every.current is not None and every.thruster_lag and every.sonar is not None
    assert every.model_uncertainty is not None
    no_lag = ocean.conditions({"thruster_lag": False})
    assert no_lag == ocean.Conditions(every.current, False, every.sonar, every.model_uncertainty)
    only_current = ocean.conditions({"base": "ideal", "current": {"mean_speed": 0.4, "mean_direction": 1.0}})
    assert only_current.sonar is None and not only_current.thruster_lag and only_current.model_uncertainty is None
    assert only_current.current.mean_speed == 0.4 and only_current.current.mean_direction == 1.0
    assert only_current.current.speed_sigma == every.current.speed_sigma  # other fields: the ocean's
    assert ocean.conditions({"sonar": False, "current": True}).sonar is None
    assert ocean.conditions({"current": {"speed_bounds": [0.1, 0.6]}}).current.speed_bounds == (0.1, 0.6)


@pytest.mark.parametrize("spec, named", [
    ("stormy", "'stormy'"),
    (3, "conditions must be one of"),
    ({"wind": True}, "'wind'"),
    ({"base": "calm"}, "conditions.base"),
    ({"current": {"speeed": 1}}, "'speeed'"),
    ({"current": {"mean_speed": -0.1}}, "conditions.current.mean_speed"),
    ({"current": {"mean_speed": "fast"}}, "conditions.current.mean_speed"),
    ({"current": {"speed_time_constant": 0}}, "conditions.current.speed_time_constant"),
    ({"current": {"speed_bounds": [0.5, 0.1]}}, "conditions.current.speed_bounds"),
    ({"current": 1}, "conditions.current"),
    ({"sonar": {"dropout": 1.5}}, "conditions.sonar.dropout"),
    ({"sonar": {"latency": 0.5}}, "conditions.sonar.latency"),
    ({"sonar": {"floor": float("nan")}}, "conditions.sonar.floor"),
    ({"model_uncertainty": {"mass": 1.0}}, "conditions.model_uncertainty.mass"),
    ({"thruster_lag": "yes"}, "conditions.thruster_lag"),
])
def test_bad_conditions_are_refused_naming_the_field(spec, named):
    with pytest.raises(ValueError, match="conditions") as error:
        ocean.conditions(spec)
    assert named in str(error.value)


def test_a_task_refuses_bad_conditions_before_any_episode():
    with pytest.raises(ValueError, match="conditions.sonar.dropout"):
        suite.load("auv", "goal", task_kwargs={"conditions": {"sonar": {"dropout": 2}}})
    with pytest.raises(ValueError, match="conditions"):
        suite.load("auv", "speed_heading", task_kwargs={"conditions": "rough"})


def test_a_task_refuses_a_physics_compiled_for_other_conditions():
    with pytest.raises(ValueError, match="thruster_lag=True"):
        ocean.Ocean("ocean").start(arena.load(), np.random.RandomState(0))


# --- the current: Gauss-Markov statistics ---------------------------------------------------------------------

GM_STEP = 0.1
"""The executor's tick [s], at which tasks move the current on."""


def autocorrelation(x: np.ndarray, lag: int) -> float:
    x = x - x.mean()
    return float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))


@functools.cache
def current_series(steps: int = 200_000):
    """Speed and direction of a Current with short time constants and bounds that never bind."""
    model = ocean.CurrentModel(mean_speed=0.3, speed_sigma=0.05, speed_time_constant=2.0, speed_bounds=(0.0, 1.0),
                               mean_direction=0.5, direction_sigma=0.2, direction_time_constant=5.0,
                               direction_bound=math.pi)
    current = ocean.Current(model, np.random.default_rng(7))
    speed, direction = np.empty(steps), np.empty(steps)
    for k in range(steps):
        current.advance(GM_STEP)
        speed[k], direction[k] = current.speed.value, current.direction.value
    return model, speed, direction


@pytest.mark.parametrize("process", ["speed", "direction"])
def test_gauss_markov_mean_spread_and_correlation_time_match_the_closed_forms(process):
    """Stationary first-order Gauss-Markov: mean mu, spread sigma, autocorrelation a^k = exp(-k dt / T).

    Tolerances are 4 standard errors of each estimator for an AR(1) of coefficient a = exp(-dt / T) and n
    samples: mean sigma sqrt((1 + a) / ((1 - a) n)); relative spread sqrt((1 + a^2) / ((1 - a^2) 2 n));
    lag-k autocorrelation Bartlett's sqrt(((1 + a^2)(1 - a^2k) / (1 - a^2) - 2k a^2k) / n); the correlation
    time T = -dt / ln(rho_1), that of rho_1 divided by a |ln a|.
    """
    model, speed, direction = current_series()
    x, mu, sigma, time_constant = ((speed, model.mean_speed, model.speed_sigma, model.speed_time_constant)
                                   if process == "speed" else
                                   (direction, model.mean_direction, model.direction_sigma,
                                    model.direction_time_constant))
    n, a = len(x), math.exp(-GM_STEP / time_constant)
    assert abs(x.mean() - mu) < 4 * sigma * math.sqrt((1 + a) / ((1 - a) * n))
    assert abs(x.std() / sigma - 1) < 4 * math.sqrt((1 + a * a) / ((1 - a * a) * 2 * n))
    for lag_time in (GM_STEP, time_constant / 2, time_constant, 2 * time_constant):
        k = int(round(lag_time / GM_STEP))
        bartlett = math.sqrt(((1 + a * a) * (1 - a ** (2 * k)) / (1 - a * a) - 2 * k * a ** (2 * k)) / n)
        assert abs(autocorrelation(x, k) - math.exp(-lag_time / time_constant)) < 4 * bartlett
    estimated = -GM_STEP / math.log(autocorrelation(x, 1))  # the correlation time
    tolerance = 4 * math.sqrt((1 - a * a) / n) / (a * abs(math.log(a)))
    assert abs(estimated / time_constant - 1) < tolerance < 0.1


def test_the_ocean_current_stays_within_its_bounds_and_wanders():
    model = ocean.CurrentModel(mean_direction=0.0, speed_sigma=0.2, direction_sigma=1.0)  # the bounds bind
    current = ocean.Current(model, np.random.default_rng(1))
    values = []
    for _ in range(20_000):
        current.advance(GM_STEP)
        values.append((current.speed.value, current.direction.value))
    speed, direction = np.array(values).T
    assert speed.min() >= model.speed_bounds[0] and speed.max() <= model.speed_bounds[1]
    assert speed.min() == model.speed_bounds[0] and speed.max() == model.speed_bounds[1]
    assert np.abs(direction).max() <= model.direction_bound
    vx, vy = current.velocity()
    assert math.hypot(vx, vy) == pytest.approx(speed[-1]) and math.atan2(vy, vx) == pytest.approx(direction[-1])


def test_tasks_move_the_current_at_the_executor_rate():
    """The current is model.opt.wind[:2], changed at every 0.1 s tick and constant in between."""
    env = suite.load("auv", "goal", task_kwargs={"random": 2, "conditions": {"base": "ideal", "current": True}})
    env.reset()
    physics = env.physics
    seen = []
    for _ in range(3):  # one planner step = 50 physics steps, stepped one at a time to watch the wind
        physics_steps = 0
        env.task.before_step(np.zeros(2), physics)
        while physics_steps < 50:
            physics.step(1)
            physics_steps += 1
            seen.append((physics.time(), *physics.model.opt.wind[:2]))
    t, wx, wy = np.array(seen).T
    changes = np.flatnonzero(np.diff(wx) != 0) + 1
    np.testing.assert_allclose(np.diff(t[changes]), 0.1, atol=1e-9)
    assert 0.0 < np.hypot(wx, wy).min() and np.hypot(wx, wy).max() <= ocean.CurrentModel().speed_bounds[1]


# --- thruster lag ---------------------------------------------------------------------------------------------


def test_ideal_actuators_have_no_dynamics():
    physics = arena.load()
    assert physics.model.na == 0 and not ocean.has_thruster_lag(physics.model.ptr)
    assert ocean.thruster_time_constants(physics.model.ptr) == {"tau_u": TAU_U, "tau_r": TAU_R}
    physics.set_control([12.0, -4.0])
    physics.step()
    np.testing.assert_array_equal(physics.data.actuator_force, [12.0, -4.0])


def test_thruster_lag_is_the_exact_first_order_response():
    """With the lag, the force after t s of a step input f is f (1 - exp(-t / tau)), to rounding, and the
    ctrlrange still saturates the input."""
    physics = arena.load(thruster_lag=True)
    assert physics.model.na == 2 and ocean.has_thruster_lag(physics.model.ptr)
    physics.set_control([25.0, -6.0])  # tau_u beyond its 20 N range: saturated to 20
    times, forces = [], []
    for _ in range(300):
        physics.step()
        times.append(physics.time())
        forces.append(physics.data.actuator_force.copy())
    t, forces = np.array(times), np.array(forces)
    np.testing.assert_allclose(forces[:, 0], 20.0 * (1 - np.exp(-t / TAU_U)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(forces[:, 1], -6.0 * (1 - np.exp(-t / TAU_R)), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(physics.data.act, forces[-1])
    physics.set_control([0.0, 0.0])  # and back down from where it was
    start, f0 = physics.time(), forces[-1]
    for _ in range(50):
        physics.step()
    decay = np.exp(-(physics.time() - start) / np.array([TAU_U, TAU_R]))
    np.testing.assert_allclose(physics.data.actuator_force, f0 * decay, rtol=0, atol=1e-12)


@functools.cache
def lagged_manoeuvre_error(timestep: float) -> float:
    """Max position error [m] of the lagged simulator against scipy integrating the vehicle and both lags."""
    def tau(t):
        return 10.0 + 8.0 * math.sin(0.21 * t), 4.0 * math.sin(0.13 * t) + 3.0 * math.sin(0.37 * t + 0.5)

    reference = ReferenceAUV.from_xml()
    dynamics = reference.rhs(lambda t: (0.0, 0.0))

    def lagged(t, s):
        u_cmd, r_cmd = tau(t)
        derivative = dynamics(t, s[:6])
        m_inv = np.linalg.inv(reference.mass_matrix())
        derivative[3:] += m_inv @ np.array([s[6], 0.0, s[7]])  # the filtered thrust acts, not the command
        return np.concatenate([derivative, [(u_cmd - s[6]) / TAU_U, (r_cmd - s[7]) / TAU_R]])

    from scipy.integrate import solve_ivp

    solution = solve_ivp(lagged, (0.0, 40.0), np.zeros(8), method="DOP853", rtol=1e-10, atol=1e-10,
                         dense_output=True)
    physics = arena.load(thruster_lag=True)
    physics.model.opt.timestep = timestep
    steps = int(round(40.0 / timestep))
    times, poses = np.empty(steps), np.empty((steps, 2))
    for k in range(steps):
        physics.set_control(tau(physics.time()))
        physics.step()
        times[k], poses[k] = physics.time(), physics.pose()[:2]
    return float(np.max(np.hypot(*(poses - solution.sol(times)[:2].T).T)))


def test_lagged_vehicle_matches_the_scipy_reference_with_first_order_thrusters():
    coarse, fine = lagged_manoeuvre_error(0.01), lagged_manoeuvre_error(0.005)
    assert coarse <= 0.5
    assert 1.6 <= coarse / fine <= 2.4


# --- sonar ----------------------------------------------------------------------------------------------------

RANGES = np.array([0.5, 5.0, 10.0, 20.0, 40.0, 60.0, 80.0, 110.0, SONAR_RANGE])
"""True ranges of the nine beams [m]; the last sees nothing."""


def test_sonar_noise_and_dropouts_match_their_model():
    noise = ocean.SonarNoise(floor=0.05, proportional=0.01, dropout=0.05, latency=0)
    sonar = ocean.NoisySonar(noise, np.random.default_rng(3), len(RANGES))
    pings = np.array([sonar.ping(RANGES) for _ in range(20_000)])
    assert np.all(pings[:, -1] == SONAR_RANGE)  # no echo, no noise
    lost = pings[:, :-1] == SONAR_RANGE
    p, n = noise.dropout, lost.size
    assert abs(lost.mean() - p) < 4 * math.sqrt(p * (1 - p) / n)
    for beam, true in enumerate(RANGES[1:-1], start=1):  # 0.5 m is clipped at 0 in 0.0 % of pings: skip
        kept = pings[~lost[:, beam], beam]
        sigma = noise.floor + noise.proportional * true
        assert abs(kept.mean() - true) < 4 * sigma / math.sqrt(len(kept))
        assert kept.std() / sigma == pytest.approx(1.0, abs=4 / math.sqrt(2 * len(kept)))
    assert np.all(pings >= 0) and np.all(pings <= SONAR_RANGE)


def test_sonar_latency_delivers_the_previous_ping():
    prompt = ocean.NoisySonar(ocean.SonarNoise(latency=0), np.random.default_rng(5), 9)
    late = ocean.NoisySonar(ocean.SonarNoise(latency=1), np.random.default_rng(5), 9)
    truths = [RANGES * f for f in (1.0, 0.8, 0.6, 0.4)]
    first = late.ping(truths[0])
    np.testing.assert_array_equal(first, SONAR_RANGE)  # nothing has come back yet
    previous = prompt.ping(truths[0])
    for truth in truths[1:]:
        np.testing.assert_array_equal(late.ping(truth), previous)
        previous = prompt.ping(truth)


def test_the_planner_sees_the_previous_ping_and_the_metrics_the_true_ranges():
    kwargs = {"random": 0, "scenario": "a", "conditions": {
        "base": "ideal", "sonar": {"floor": 0.0, "proportional": 0.0, "dropout": 0.0, "latency": 1}}}
    env = suite.load("auv", "obstacles", task_kwargs=kwargs)
    step = env.reset()
    # no ping back yet
    np.testing.assert_array_equal(step.observation["observation"][planning_observation.SONAR_SLICE], 1.0)
    truth = env.physics.sonar()
    seen_echo = False
    for _ in range(120):
        step = env.step(np.array([0.0, 0.0]))
        sonar = step.observation["observation"][planning_observation.SONAR_SLICE]
        np.testing.assert_allclose(sonar * SONAR_RANGE, truth, rtol=1e-15)
        truth = env.physics.sonar()
        assert env.task.last_info["min_sonar_range"] == truth.min()
        seen_echo |= truth.min() < SONAR_RANGE
    assert seen_echo


# --- model uncertainty ---------------------------------------------------------------------------------------


def test_model_uncertainty_scales_every_coefficient_and_the_mass_within_bounds():
    facts = vehicle_facts()
    scales = []
    for seed in range(3):
        env = suite.load("auv", "goal", task_kwargs={"random": seed, "conditions": {
            "base": "ideal", "model_uncertainty": {"hydrodynamics": 0.2, "mass": 0.05}}})
        env.reset()
        task, physics = env.task, env.physics
        coefficients = physics.hydrodynamics.coefficients
        for name in ocean.COEFFICIENT_NAMES:
            factor = task.ocean.scales[name]
            assert 0.8 <= factor <= 1.2
            assert getattr(coefficients, name) == getattr(NOMINAL, name) * factor
        assert 0.95 <= task.ocean.scales["mass"] <= 1.05
        assert physics.model.body_mass[1] == pytest.approx(30.48 * task.ocean.scales["mass"])
        scales.append(task.ocean.scales)
        # Controllers are not told: they still read the nominal MJCF.
        assert SPlaneGains().surge_drag == facts.surge_drag == -NOMINAL.X_uu
    assert scales[0] != scales[1] != scales[2]


def test_a_scaled_vehicle_moves_as_its_scaled_coefficients_say():
    physics = arena.load()
    physics.scale_vehicle({"X_uu": 1.2, "X_udot": 0.9}, mass=1.05)
    physics.set_control([10.0, 0.0])
    physics.forward()
    # From rest, surge acceleration = tau_u / (m + a11) with the scaled mass and added mass.
    assert physics.data.qacc[0] == pytest.approx(10.0 / (30.48 * 1.05 - NOMINAL.X_udot * 0.9), rel=1e-12)
    physics.step(6000)
    assert physics.body_velocity()[0] == pytest.approx(math.sqrt(10.0 / (-NOMINAL.X_uu * 1.2)), rel=1e-3)
    physics.scale_vehicle()  # back to the MJCF's vehicle: it then runs as a fresh one does
    fresh = arena.load()
    for p in (physics, fresh):
        with p.reset_context():
            p.data.qvel[:3] = 1.0, 0.2, 0.1
        p.set_control([5.0, 2.0])
        p.step(500)
    np.testing.assert_array_equal(physics.data.qpos, fresh.data.qpos)
    with pytest.raises(ValueError, match="X_uuu"):
        physics.scale_vehicle({"X_uuu": 1.1})


# --- the option on every task and Gymnasium id ----------------------------------------------------------------


def ocean_effects(env) -> dict[str, bool]:
    physics = env.physics
    return {"thruster_lag": physics.model.na == 2,
            "current": bool(np.any(physics.model.opt.wind[:2] != 0)),
            "model_uncertainty": physics.hydrodynamics.coefficients != NOMINAL}


@pytest.mark.parametrize("domain, name", suite.PLANAR_TASKS)
def test_every_task_takes_the_conditions_option(domain, name):
    for conditions, on in (("ideal", False), ("ocean", True)):
        env = suite.load(domain, name, task_kwargs={"random": 1, "conditions": conditions})
        spec = env.action_spec()
        env.reset()
        for _ in range(3):
            env.step(np.zeros(spec.shape))
        assert ocean_effects(env) == dict.fromkeys(("thruster_lag", "current", "model_uncertainty"), on)
        assert env.task.ocean.conditions == ocean.conditions(conditions)


@pytest.mark.parametrize("env_id", ["auv_mj/Goal-v0", "auv_mj/SpeedHeading-v0"])
def test_gymnasium_ids_take_the_conditions_option(env_id):
    env = gymnasium.make(env_id, task_kwargs={"conditions": "ocean"})
    first, _ = env.reset(seed=4)
    again, _ = env.reset(seed=4)
    assert ocean_effects(env.unwrapped.dm_env)["thruster_lag"]
    flat = (lambda o: np.concatenate([np.ravel(v) for v in o.values()])) if isinstance(first, dict) else np.ravel
    np.testing.assert_array_equal(flat(first), flat(again))
    for _ in range(5):
        env.step(env.action_space.sample())
    assert set(GYM_IDS) >= {env_id}


def trajectory(name: str, seed: int, conditions, steps: int = 40, **kwargs) -> np.ndarray:
    """Poses and velocities of `steps` steps of a fixed action sequence."""
    env = suite.load("auv", name, task_kwargs={"random": seed, "conditions": conditions, **kwargs})
    spec = env.action_spec()
    actions = np.random.RandomState(0).uniform(spec.minimum, spec.maximum, (steps, *spec.shape))
    env.reset()
    rows = []
    for action in actions:
        env.step(action)
        rows.append(np.concatenate([env.physics.pose(), env.physics.body_velocity(),
                                    env.task.get_observation(env.physics)["observation"]]))
    return np.array(rows)


@pytest.mark.parametrize("name, kwargs", [("goal", {"scenario": "a1"}), ("speed_heading", {}),
                                          ("obstacles", {"scenario": "a"})])
def test_ocean_episodes_are_deterministic_per_seed(name, kwargs):
    """Same seed, same episode; a new seed, a new ocean (on a fixed layout, so the ocean is what differs)."""
    first = trajectory(name, 3, "ocean", **kwargs)
    np.testing.assert_array_equal(first, trajectory(name, 3, "ocean", **kwargs))
    assert np.abs(first - trajectory(name, 4, "ocean", **kwargs)).max() > 1e-3
    assert np.abs(first - trajectory(name, 3, "ideal", **kwargs)).max() > 1e-3


def test_ideal_and_ocean_share_the_layout_of_a_seed():
    ideal = suite.load("auv", "obstacles", task_kwargs={"random": 10004})
    rough = suite.load("auv", "obstacles", task_kwargs={"random": 10004, "conditions": "ocean"})
    for env in (ideal, rough):
        env.reset()
    np.testing.assert_array_equal(ideal.task.goals, rough.task.goals)
    np.testing.assert_array_equal(ideal.physics.data.mocap_pos, rough.physics.data.mocap_pos)


def test_eval_runs_under_ocean_conditions(tmp_path, capsys):
    out = tmp_path / "ocean.json"
    assert cli.main(["eval", "--policy", "splane", "--task", "speed_heading", "--episodes", "1", "--max-steps", "20",
                     "--task-kwargs", '{"conditions": "ocean"}', "--json", str(out), "--no-progress"]) == 0
    assert json.loads(out.read_text())["task_kwargs"] == {"conditions": "ocean"}
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["eval", "--policy", "splane", "--task", "goal", "--episodes", "1",
                  "--task-kwargs", '{"conditions": {"current": {"mean_speed": -1}}}'])
    assert exit_info.value.code == 2
    assert "conditions.current.mean_speed" in capsys.readouterr().err


# --- "ideal" is the world before the option existed -----------------------------------------------------------

IDEAL_TRAJECTORIES = {
    # (task, policy, seed, steps): (x, y, psi, u, v, r) at 8 evenly spaced instants of the episode, recorded
    # with `auv-mj eval`'s episode loop at the commit before ocean conditions existed (b0a8d13). A learned
    # policy's float32 forward pass rounds differently on different CPUs (AVX2 against AVX-512 kernels), and
    # a closed loop grows that last bit into metres; so the learned policies' actions were recorded too, at the
    # same commit (tests/data/ideal_actions.npz), and are replayed: what is checked to 1e-12 is the world
    # the actions act in, which is what the option must leave alone.
    ('speed_heading', 'splane', 0, 1100): [
        (0.0, 0.0, 0.0,
         0.0, 0.0, 0.0),
        (14.421081870006082, 3.7817830092161233, 0.2623493292365819,
         1.000570221455676, -1.7291084454029715e-05, -5.7540422444258405e-06),
        (29.484423338162753, 8.276326836520353, 0.2624205310374579,
         1.000511761264499, 0.001979213984505346, -0.0008524692738524919),
        (44.413300449854475, 13.935412693304626, 0.25815832926756066,
         1.0130227760261472, 0.13815093316320215, 3.615464128523056e-05),
        (59.30332361941158, 20.12936904843447, 0.25867983182074705,
         1.0097565861235047, 0.1381742141434426, 3.0233934957416382e-05),
        (74.26384759305284, 24.861183560921976, 0.26648755563629695,
         0.9889057003421997, -0.08508559154435552, -0.0009190768793659833),
        (89.26607254552863, 29.398317405348948, 0.26749833115397786,
         0.981551005044038, -0.12262319573789174, 0.0002630867536145411),
        (104.32483044443981, 33.759895429968935, 0.2615477274652149,
         0.9961360915278781, 0.0381325507050749, 0.0014154824572804722),
    ],
    ('speed_heading', 'executor', 1, 200): [
        (0.0, 0.0, 0.0,
         0.0, 0.0, 0.0),
        (2.0668746805691063, 0.49036704134825637, 0.3007610462538464,
         0.9830004830137924, -0.01858719488832694, -0.020511804634439846),
        (4.654676791837533, 1.226283367309335, 0.22664178547368677,
         1.0420164003705406, 0.013128472949894054, 0.05874909036552332),
        (7.466067638830525, 1.9820045084101725, 0.2932582360352093,
         0.9606513607591618, -0.007100932116548331, 0.03181392139798186),
        (10.171303989020911, 2.685087627771568, 0.24757454336757528,
         0.9876362490613838, 0.0004421185937019678, 0.013836418069286257),
        (12.962714186955365, 3.4649493091013204, 0.2667046688619056,
         1.0083644185781813, 0.0018412680055003294, -0.11954845592226543),
        (15.683081596162271, 4.162717145730041, 0.28034289663977574,
         0.9757197170202077, -0.007762577108012647, 0.08641282058690328),
        (18.460859142983644, 4.926708930607708, 0.22548670685566874,
         1.0349685262069248, 0.01309351979501494, 0.06572692945742123),
    ],
    ('goal', 'splane', 3, 300): [
        (327.93884641601653, 414.48130243995763, 2.468958530058152,
         0.0, -0.0, 0.0),
        (310.78399395827296, 405.03778915649775, 3.812587564812115,
         1.0006268876872584, 3.1506751422216706e-05, -5.623416239542665e-05),
        (293.92863855987054, 391.6724707596812, 3.811384780394291,
         1.0004340600742752, 4.5370918089759904e-05, -5.1865050845766026e-05),
        (277.0610300418899, 378.3281934214481, 3.8103458406631865,
         1.0003008614990287, 3.951142862240742e-05, -4.859355793583211e-05),
        (260.5748470070921, 365.31171139657124, 3.809441489944666,
         1.0002103254712322, 3.5585978871766066e-05, -4.6499467984963895e-05),
        (243.68570950009578, 352.0011967065386, 3.8085847175471574,
         1.0001457869240962, 3.3373592655594475e-05, -4.6192048688739876e-05),
        (226.78625237832406, 338.7056651006249, 3.807744173231627,
         1.00010105243538, 3.36415589407002e-05, -4.948176994450748e-05),
        (209.87589229520174, 325.42530732252516, 3.806817911810106,
         1.0000700447202395, 3.9487049569131294e-05, -6.284665887586646e-05),
    ],
    ('goal', 'planner', 10001, 100): [
        (468.9982652603472, 89.07883478318597, -2.1507342675703645,
         -0.0, 0.0, 0.0),
        (459.6864806139621, 87.87583124610259, -3.617293204331951,
         1.9603336913510092, 0.06849645454139486, -0.10962533630943308),
        (451.8435521914528, 99.76105470653494, -4.267990799210306,
         1.984638168808401, -0.03597397331172958, 0.24375984866112013),
        (445.9574968009672, 112.29775035030595, -4.332549034269533,
         1.9584238518163513, 0.053743522730640425, -0.1504957109849209),
        (440.5349214833663, 125.06745534037562, -4.330761662731387,
         1.9696363704255717, 0.017394904741702133, -0.12042914880533238),
        (435.0865568846246, 137.73222575213867, -4.309151607761363,
         1.9243397356774878, 0.006109894775271796, -0.24030456968444996),
        (429.75074417991596, 151.151698559311, -4.283487923413768,
         1.9536061066709551, -0.06054441040049652, 0.22807212231437568),
        (425.1865266876125, 163.2946717933209, -4.43426913762204,
         1.8023875505439477, 0.05568893090659577, -0.14370203306776294),
    ],
    ('obstacles', 'los-avoid', 10002, 400): [
        (273.53838039721785, 485.2418554566934, -1.9765333805236065,
         -0.0, 0.0, 0.0),
        (261.78646050028647, 483.70179709627297, -3.272699970944836,
         1.0007332450521438, 0.0006257696441155924, 7.737357816680118e-05),
        (248.88880948058252, 485.3948820179653, -3.2716571797020064,
         1.0005706245556163, -6.505135365142412e-05, 7.348483056692901e-05),
        (235.49521384190962, 487.14055657105143, -3.270618734721697,
         1.0004532479017212, -6.537387473856682e-05, 7.719931075334663e-05),
        (222.5973055835556, 488.8083017898023, -3.269619583390816,
         1.0003631480049464, -6.593354765876969e-05, 8.36110994992792e-05),
        (209.20263478790648, 490.5261568295224, -3.2685279375702567,
         1.0002884914501626, -7.060701236302758e-05, 9.641314286616791e-05),
        (196.30295666403728, 492.16498168326365, -3.2673476137999495,
         1.000231148186324, -7.522259926652508e-05, 0.00012460056979418093),
        (182.90559394842023, 493.84899240542927, -3.2655800727587097,
         1.000183627086746, -0.0001305094278850477, 0.00022118921129364623),
    ],
    ('moving_obstacles', 'planner', 10003, 60): [
        (531.3431765586483, 344.31854742447365, -1.8710351374101706,
         -0.0, 0.0, 0.0),
        (527.1963801793604, 340.7933205738786, -2.8113877295936165,
         1.9911955755928812, 0.06900294570871823, -0.10150496413639673),
        (519.4093709923216, 341.0483739705496, -3.3262378807692246,
         1.9893207974279836, -0.04807608432094784, 0.2716730584042268),
        (510.48606295546364, 341.6954108570207, -3.32058760489537,
         1.991359749455681, 0.0524942500576841, -0.14086387979617704),
        (502.58764238965614, 342.7120759552024, -3.2951676906545213,
         1.9926557096903146, 0.004027216217189322, -0.23592529487282118),
        (493.9029367095913, 344.8141029051777, -3.2740389250038233,
         1.9947387134099281, -0.05683608817742586, 0.30188013900599553),
        (486.0930209446514, 346.3453776966434, -3.4244726391498608,
         1.9954332192843311, 0.02914436826442446, -0.030729053110083705),
        (477.39514264209737, 348.4809411585161, -3.357696223787608,
         1.9878959874421298, -0.01891128539966097, 0.22575981759608874),
    ],
    ('path_curve', 'random', 4, 200): [
        (35.0, 230.0, 0.0,
         0.0, 0.0, 0.0),
        (50.58490993431617, 229.92142648450485, -0.036805836801692235,
         1.2167965183255967, 0.0541558125305472, -0.11877386202315586),
        (62.74131036051795, 230.84567057955317, 0.12443377923960904,
         0.8971862946278768, 0.002808714338003726, 0.13605895871100224),
        (72.38207079435693, 240.9572583857862, 1.3800504516072238,
         1.2548120877590805, -0.0428571493847025, 0.1291323204973188),
        (74.60551209290989, 257.48227965981914, 1.798548219364664,
         1.6836397408230448, -0.05920788784068265, 0.11776290562656332),
        (66.7744363153756, 266.50146322844694, 2.821454725579255,
         0.6508830071741727, 0.005467941316015912, -0.247065391964879),
        (53.651470002247166, 266.7412861789147, 3.24993807051378,
         0.8763020274566976, 0.030654617385565602, -0.267255124493378),
        (44.25602796273313, 261.018308403825, 3.7914302281172723,
         1.1004831351260016, -0.003643652452813062, 0.207563016838665),
    ],
}

LEARNED = ("executor", "planner")
"""Policies of IDEAL_TRAJECTORIES that are networks: their recorded actions are replayed."""
RECORDED_ACTIONS = dict(np.load(Path(__file__).parents[1] / "data" / "ideal_actions.npz"))


@pytest.mark.parametrize("case", IDEAL_TRAJECTORIES, ids=lambda case: f"{case[0]}-{case[1]}")
def test_ideal_conditions_reproduce_the_trajectories_recorded_before_the_option(case):
    task, policy_name, seed, steps = case
    expected = np.array(IDEAL_TRAJECTORIES[case])
    env, policy = policies.env_and_policy(policy_name, task, seed)
    if policy_name in LEARNED:
        recorded = iter(RECORDED_ACTIONS[f"{task}-{policy_name}-{seed}-{steps}"])
        policy = lambda time_step: next(recorded)  # noqa: E731
    record = record_episode(env, policy, steps)
    states = np.hstack([record.pose, record.velocity])
    index = np.linspace(0, len(states) - 1, len(expected)).round().astype(int)
    np.testing.assert_allclose(states[index], expected, rtol=0, atol=1e-12)


def test_reproduce_refuses_unknown_sections(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["reproduce", "--sections", "ocean,weather", "--out", str(tmp_path / "r.md")])
    assert exit_info.value.code == 2
    assert "weather" in capsys.readouterr().err
    assert not (tmp_path / "r.md").exists()


def test_an_unphysical_scaling_is_refused_and_leaves_the_mjcf_vehicle():
    physics = arena.load()
    with pytest.raises(ValueError, match="not positive definite"):
        physics.scale_vehicle({"Y_vdot": -2.0}, mass=0.1)  # added mass turned into negative mass
    assert physics.hydrodynamics.coefficients == NOMINAL
    assert physics.model.body_mass[1] == 30.48
