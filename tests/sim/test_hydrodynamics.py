"""Vehicle physics against independent maths: Eq. (1)-(12) integrated by scipy, invariants, steady states."""

from __future__ import annotations

import functools
import math
import warnings

import mujoco
import numpy as np
import pytest
from vehicle_reference import ReferenceAUV, read_numerics, read_rigid_body, vehicle_xml_with

from auv_mj import AUVPhysics, model_path
from auv_mj.sim import native

COEFFICIENTS = read_numerics()
MASS, IZ = read_rigid_body()
MANOEUVRE_TIME = 60.0
INITIAL_STATES = {
    "from rest": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    "moving": (1.0, -2.0, 0.3, 1.2, 0.2, 0.1),  # (x, y, psi, u, v, r)
}
CURRENTS = {"still water": (0.0, 0.0), "current": (0.3, -0.2)}
"""World-frame currents V_c [m/s] (`model.opt.wind[:2]`): none, and a coastal one of 0.36 m/s."""


def manoeuvre_tau(t: float) -> tuple[float, float]:
    """A smooth, time-varying (tau_u, tau_r) inside the actuator limits: surging, weaving turns."""
    return 10.0 + 8.0 * math.sin(0.21 * t), 4.0 * math.sin(0.13 * t) + 3.0 * math.sin(0.37 * t + 0.5)


def new_physics(timestep: float | None = None, xml: str | None = None) -> AUVPhysics:
    physics = (AUVPhysics.from_xml_path(model_path("auv.xml")) if xml is None
               else AUVPhysics.from_xml_string(xml, source="test vehicle"))
    if timestep is not None:
        physics.model.opt.timestep = timestep
    return physics


def set_state(physics: AUVPhysics, x: float, y: float, psi: float, u: float, v: float, r: float) -> None:
    """Puts the vehicle at eta = (x, y, psi) with body velocity nu = (u, v, r) (qvel = R(psi) nu, Eq. 1)."""
    with physics.reset_context():
        physics.data.qpos[:3] = x, y, psi
        c, s = math.cos(psi), math.sin(psi)
        physics.data.qvel[:3] = c * u - s * v, s * u + c * v, r


def wrap(angle):
    return np.angle(np.exp(1j * np.asarray(angle)))


@functools.cache
def reference_solution(state_name: str, current_name: str = "still water"):
    return ReferenceAUV.from_xml().solve(INITIAL_STATES[state_name], MANOEUVRE_TIME, manoeuvre_tau,
                                         CURRENTS[current_name])


@functools.cache
def manoeuvre_errors(state_name: str, timestep: float, current_name: str = "still water") -> tuple[float, float]:
    """Max position [m] and heading [rad] error of the simulator against the reference over the manoeuvre.

    The simulator holds tau(t_k) over each step (zero-order hold), the reference sees tau(t): an O(dt)
    difference of the same order as the Euler step's own error.
    """
    physics = new_physics(timestep)
    physics.model.opt.wind[:2] = CURRENTS[current_name]
    set_state(physics, *INITIAL_STATES[state_name])
    steps = int(round(MANOEUVRE_TIME / timestep))
    times, poses = np.empty(steps), np.empty((steps, 3))
    for k in range(steps):
        physics.set_control(manoeuvre_tau(physics.time()))
        physics.step()
        times[k], poses[k] = physics.time(), physics.pose()
    reference = reference_solution(state_name, current_name)(times)
    position_error = np.max(np.hypot(*(poses[:, :2] - reference[:2].T).T))
    heading_error = np.max(np.abs(wrap(poses[:, 2] - reference[2])))
    return float(position_error), float(heading_error)


@pytest.mark.parametrize("current_name", CURRENTS)
@pytest.mark.parametrize("state_name", INITIAL_STATES)
def test_manoeuvre_matches_scipy_reference_at_default_timestep(state_name, current_name):
    assert new_physics().model.opt.timestep == 0.01
    position_error, heading_error = manoeuvre_errors(state_name, 0.01, current_name)
    assert position_error <= 0.5
    assert heading_error <= 0.1


@pytest.mark.parametrize("current_name", CURRENTS)
@pytest.mark.parametrize("state_name", INITIAL_STATES)
def test_halving_the_timestep_halves_the_error(state_name, current_name):
    """Semi-implicit Euler is first order: errors scale with dt."""
    coarse = manoeuvre_errors(state_name, 0.01, current_name)
    fine = manoeuvre_errors(state_name, 0.005, current_name)
    assert 1.6 <= coarse[0] / fine[0] <= 2.4
    assert 1.6 <= coarse[1] / fine[1] <= 2.4


def test_the_reference_is_nontrivial():
    """The manoeuvre turns, sways and travels far, so the comparison above tests every term; the current
    moves the track by far more than the errors allowed, so the comparison in a current tests it too."""
    times = np.linspace(0, MANOEUVRE_TIME, 601)
    states = reference_solution("from rest")(times)
    assert np.ptp(states[2]) > 3.0 and np.max(np.abs(states[4])) > 0.05 and np.max(states[3]) > 2.0
    assert np.max(np.hypot(states[0], states[1])) > 15.0
    drifted = reference_solution("from rest", "current")(times)
    assert np.max(np.hypot(*(drifted[:2] - states[:2]))) > 10.0


# --- the current: relative velocity, drift, Galilean invariance -------------------------------------------

@pytest.mark.parametrize("cross_flow", [{}, {"Y_vr": -40.0, "Y_rv": -6.0, "N_vr": 3.0, "N_rv": -20.0}],
                         ids=["REMUS", "with cross-flow terms"])
def test_force_is_the_still_water_force_at_the_relative_velocity(cross_flow):
    """After forward(), qfrc_passive is R(psi) body_force(u_r, v_r, r), with nu_r = nu - R^T V_c: the step's
    inlined force is `body_force`, for REMUS (no cross-flow terms) and for a hull with them."""
    physics = new_physics(xml=vehicle_xml_with(**cross_flow))
    rng = np.random.default_rng(3)
    for psi, u, v, r, vcx, vcy in rng.uniform([-3, -2, -1, -1, -0.5, -0.5], [3, 2, 1, 1, 0.5, 0.5], size=(50, 6)):
        physics.model.opt.wind[:2] = vcx, vcy
        set_state(physics, 0.0, 0.0, psi, u, v, r)
        c, s = math.cos(psi), math.sin(psi)
        X, Y, N = physics.hydrodynamics.body_force(u - (c * vcx + s * vcy), v - (-s * vcx + c * vcy), r)
        np.testing.assert_allclose(physics.data.qfrc_passive[:3], [c * X - s * Y, s * X + c * Y, N],
                                   rtol=1e-12, atol=1e-12)


def test_a_vehicle_at_rest_in_the_water_drifts_with_it_exactly():
    """Moving with the water (nu_r = 0, tau = 0) nothing acts on the hull: it keeps V_c and its heading."""
    physics = new_physics()
    physics.model.opt.wind[:2] = 0.3, -0.2
    with physics.reset_context():
        physics.data.qpos[:3] = 5.0, 1.0, 0.8
        physics.data.qvel[:3] = 0.3, -0.2, 0.0
    physics.step(3000)
    np.testing.assert_allclose(physics.data.qvel[:3], [0.3, -0.2, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(physics.pose(), [5.0 + 0.3 * 30.0, 1.0 - 0.2 * 30.0, 0.8], atol=1e-9)


def test_motion_relative_to_a_current_is_the_still_water_motion():
    """Galilean invariance: a constant current only carries the whole still-water motion along.

    For a constant, irrotational V_c the equations in nu_r are the still-water equations (Fossen 2011,
    Property 8.1), so a manoeuvre started at nu_0 + nu_c in the current, seen from the water, is the same
    manoeuvre started at nu_0 in still water: same heading and relative velocity, track shifted by V_c t.
    """
    current = np.array([-0.25, 0.35])
    still, drifting = new_physics(), new_physics()
    drifting.model.opt.wind[:2] = current
    psi = 0.4
    set_state(still, 0.0, 0.0, psi, 1.0, 0.1, 0.05)
    with drifting.reset_context():
        drifting.data.qpos[:3] = still.data.qpos[:3]
        drifting.data.qvel[:3] = still.data.qvel[:3] + [*current, 0.0]
    for _ in range(60):
        for physics in (still, drifting):
            physics.set_control(manoeuvre_tau(physics.time()))
            physics.step(100)
        t = drifting.time()
        np.testing.assert_allclose(drifting.data.qvel[:3] - [*current, 0.0], still.data.qvel[:3], atol=1e-9)
        np.testing.assert_allclose(drifting.pose(), still.pose() + [*(current * t), 0.0], atol=1e-8)
    assert np.hypot(*still.pose()[:2]) > 10.0 and abs(still.pose()[2] - psi) > 1.0  # it really manoeuvred


@pytest.mark.parametrize("along", [0.3, -0.3])
def test_thrust_along_the_current_adds_the_current_to_the_terminal_speed(along):
    """Heading along V_c, the surge balance holds on the relative speed: u = sqrt(tau_u / -X_uu) + V_c."""
    physics = new_physics()
    physics.model.opt.wind[:2] = along * math.cos(0.7), along * math.sin(0.7)
    set_state(physics, 0.0, 0.0, 0.7, 0.0, 0.0, 0.0)
    physics.set_control([10.0, 0.0])
    physics.step(6000)
    u, v, r = physics.body_velocity()
    assert u == pytest.approx(math.sqrt(10.0 / -COEFFICIENTS["X_uu"]) + along, rel=1e-3)
    assert abs(v) < 1e-9 and abs(r) < 1e-9


# --- structure of the force: C_A(nu) does no work, drag is |v| v -------------------------------------

def test_added_mass_coriolis_does_no_work():
    """C_A(nu) = -C_A(nu)^T (Eq. 9): nu . C_A(nu) nu = 0.

    `body_force` acts on the joint-space form (inertia R M_A R^T): without damping and lift it equals
    -C_A(nu) nu + M_A S nu r, where S nu r = R^T dR/dt nu = r (-v, u, 0). So the invariant is
    nu . (F - r M_A S nu) = 0, and F - r M_A S nu must equal -C_A(nu) nu of Eq. (9).
    """
    inviscid = {k: 0.0 for k in COEFFICIENTS if k not in ("X_udot", "Y_vdot", "Y_rdot", "N_rdot")}
    hydro = new_physics(xml=vehicle_xml_with(**inviscid)).hydrodynamics
    c = COEFFICIENTS
    m_a = -np.array([[c["X_udot"], 0, 0], [0, c["Y_vdot"], c["Y_rdot"]], [0, c["Y_rdot"], c["N_rdot"]]])
    rng = np.random.default_rng(0)
    for u, v, r in rng.uniform(-3, 3, size=(200, 3)):
        force = np.array(hydro.body_force(u, v, r))
        coriolis_part = force - r * m_a @ np.array([-v, u, 0.0])
        c_a = np.array([[0, 0, c["Y_vdot"] * v + c["Y_rdot"] * r], [0, 0, -c["X_udot"] * u],
                        [-c["Y_vdot"] * v - c["Y_rdot"] * r, c["X_udot"] * u, 0]])
        np.testing.assert_allclose(coriolis_part, -c_a @ [u, v, r], atol=1e-10)
        assert abs(np.dot([u, v, r], coriolis_part)) < 1e-9 * (1 + np.dot(force, force))


def test_inviscid_vehicle_keeps_its_kinetic_energy():
    """Without damping and lift, tau = 0: 1/2 nu^T M nu is conserved (to the Euler step's O(dt) drift)."""
    inviscid = {k: 0.0 for k in COEFFICIENTS if k not in ("X_udot", "Y_vdot", "Y_rdot", "N_rdot")}
    drift = []
    for timestep in (0.002, 0.001):
        physics = new_physics(timestep, vehicle_xml_with(**inviscid))
        set_state(physics, 0.0, 0.0, 0.4, 1.5, 0.4, 0.5)
        energy0 = physics.kinetic_energy()
        physics.step(int(round(2.0 / timestep)))
        drift.append(abs(physics.kinetic_energy() / energy0 - 1))
    assert drift[0] < 0.02
    assert 1.6 <= drift[0] / drift[1] <= 2.4


def test_drag_is_odd_and_opposes_motion():
    """D(nu) nu of Eq. (11) with |v| v: odd in nu and its power nu . D(nu) nu > 0 for REMUS's numbers."""
    no_inertia_no_lift = {"X_udot": 0.0, "Y_vdot": 0.0, "Y_rdot": 0.0, "N_rdot": 0.0,
                          "Y_uv": 0.0, "Y_ur": 0.0, "N_uv": 0.0, "N_ur": 0.0}
    hydro = new_physics(xml=vehicle_xml_with(**no_inertia_no_lift)).hydrodynamics
    reference = ReferenceAUV(dict(COEFFICIENTS, **no_inertia_no_lift), MASS, IZ)
    rng = np.random.default_rng(1)
    for nu in rng.uniform(-2, 2, size=(200, 3)) * rng.uniform(0, 1, size=(200, 1)) ** 2:
        force = np.array(hydro.body_force(*nu))
        np.testing.assert_allclose(force, -reference.damping(*nu) @ nu, atol=1e-12)
        np.testing.assert_allclose(hydro.body_force(*-nu), -force, atol=1e-12)
        assert np.dot(nu, force) < 0
    # Quadratic, not linear: doubling the speed quadruples the drag.
    assert hydro.body_force(2.0, 0, 0)[0] == pytest.approx(4 * hydro.body_force(1.0, 0, 0)[0])
    assert hydro.body_force(2.0, 0, 0)[0] == pytest.approx(4 * COEFFICIENTS["X_uu"])


def test_lift_power_sign():
    """The lift alone dissipates going ahead (u > 0) but feeds energy going astern (u < 0).

    Its power u (Y_uv v^2 + (Y_ur + N_uv) v r + N_ur r^2) is a quadratic form in (v, r), negative
    definite for REMUS's numbers; so only the surge drag keeps the astern vehicle's energy falling.
    """
    c = COEFFICIENTS
    assert c["Y_uv"] < 0 and (c["Y_ur"] + c["N_uv"]) ** 2 < 4 * c["Y_uv"] * c["N_ur"]
    base = {k: 0.0 for k in COEFFICIENTS if k not in ("Y_uv", "Y_ur", "N_uv", "N_ur")}
    lift_only = new_physics(xml=vehicle_xml_with(**base)).hydrodynamics
    for u in (1.5, -1.5):
        power = np.dot([u, 0.2, -0.1], lift_only.body_force(u, 0.2, -0.1))
        assert power == pytest.approx(u * (c["Y_uv"] * 0.04 - (c["Y_ur"] + c["N_uv"]) * 0.02
                                           + c["N_ur"] * 0.01))
        assert (power < 0) == (u > 0)


def test_kinetic_energy_never_increases_without_thrust():
    """tau = 0, lift included, random nu (astern too): 1/2 nu^T (M_RB + M_A) nu falls at every step.

    The lift feeds energy astern (see above) but the surge drag outweighs it everywhere for REMUS.
    """
    physics = new_physics()
    rng = np.random.default_rng(2)
    for u, v, r, psi in rng.uniform([-3, -1, -1, -3], [3, 1, 1, 3], size=(6, 4)):
        set_state(physics, 0.0, 0.0, psi, u, v, r)
        expected = 0.5 * np.array([u, v, r]) @ ReferenceAUV.from_xml().mass_matrix() @ [u, v, r]
        assert physics.kinetic_energy() == pytest.approx(expected)
        energy = [physics.kinetic_energy()]
        for _ in range(1500):
            physics.step()
            energy.append(physics.kinetic_energy())
        assert np.all(np.diff(energy) < 0)
        assert energy[-1] < 0.5 * energy[0]


# --- steady states --------------------------------------------------------------------------------------

@pytest.mark.parametrize("tau_u", [4.0, 10.0, 20.0])
def test_straight_run_settles_at_terminal_speed(tau_u):
    """Surge balance tau_u + X_uu |u| u = 0: u = sqrt(tau_u / -X_uu); the course stays straight."""
    physics = new_physics()
    set_state(physics, 0.0, 0.0, 0.7, 0.0, 0.0, 0.0)
    physics.set_control([tau_u, 0.0])
    physics.step(6000)
    u, v, r = physics.body_velocity()
    assert u == pytest.approx(math.sqrt(tau_u / -COEFFICIENTS["X_uu"]), rel=0.01)
    assert abs(v) < 1e-12 and abs(r) < 1e-12
    x, y, psi = physics.pose()
    assert psi == pytest.approx(0.7, abs=1e-12) and math.atan2(y, x) == pytest.approx(0.7, abs=1e-12)


def linear_stability_index(c: dict[str, float], m: float) -> float:
    """det of the linearised sway-yaw force about straight running at unit surge, Eq. (3) at nu = (1, 0, 0).

    Y_v = Y_uv, Y_r = Y_ur + X_udot - m, N_v = N_uv + Y_vdot - X_udot (Munk), N_r = N_ur + Y_rdot.
    The course is directionally stable iff this is > 0 (M is positive definite).
    """
    y_v, y_r = c["Y_uv"], c["Y_ur"] + c["X_udot"] - m
    n_v, n_r = c["N_uv"] + c["Y_vdot"] - c["X_udot"], c["N_ur"] + c["Y_rdot"]
    return y_v * n_r - n_v * y_r


def yaw_kick_response(xml: str | None) -> np.ndarray:
    """(u, v, r) every 5 s after a 0.1 rad/s yaw-rate kick during a straight run at tau = (10, 0)."""
    physics = new_physics(xml=xml)
    physics.set_control([10.0, 0.0])
    physics.step(4000)
    physics.data.qvel[2] += 0.1
    physics.forward()
    track = []
    for _ in range(12):
        physics.step(500)
        track.append(physics.body_velocity())
    return np.array(track)


def test_directionally_stable_hull_returns_to_a_straight_course():
    """With enough fin lift moment (N_uv) the linear criterion holds and a yaw kick dies out."""
    stable = dict(N_uv=40.0)
    assert linear_stability_index(dict(COEFFICIENTS, **stable), MASS) > 0
    track = yaw_kick_response(vehicle_xml_with(**stable))
    assert abs(track[-1, 2]) < 1e-4 and abs(track[-1, 1]) < 1e-4
    assert abs(track[-1, 0] - math.sqrt(10.0 / -COEFFICIENTS["X_uu"])) < 1e-3


def test_remus_is_directionally_unstable_and_spirals_into_a_steady_turn():
    """Prestero's REMUS numbers fail the linear criterion (Munk moment N_uv + Y_vdot - X_udot = -24 kg
    dominates): after a yaw kick with tau_r = 0 the vehicle settles into a steady turn, held by the
    cross-flow drag N_rr |r| r, not back on a straight course. Heading control is the controller's job.
    """
    assert linear_stability_index(COEFFICIENTS, MASS) < 0
    track = yaw_kick_response(None)
    assert np.all(np.abs(track[-3:, 2] - track[-1, 2]) < 1e-4)
    assert 0.1 < abs(track[-1, 2]) < 0.3


@pytest.mark.parametrize("tau_r", [-6.0, 3.0])
def test_constant_yaw_moment_gives_a_steady_turn(tau_r):
    physics = new_physics()
    physics.set_control([10.0, tau_r])
    physics.step(6000)
    u0, v0, r0 = physics.body_velocity()
    physics.step(1000)
    u1, v1, r1 = physics.body_velocity()
    assert math.copysign(1.0, r1) == math.copysign(1.0, tau_r) and abs(r1) > 0.1
    assert abs(r1 - r0) < 1e-6 and abs(u1 - u0) < 1e-6 and abs(v1 - v0) < 1e-6
    # A steady turn: over one revolution the track is a circle of radius U / |r|.
    track = []
    for _ in range(int(2 * math.pi / abs(r1) / 0.1) + 1):
        physics.step(10)
        track.append(physics.pose()[:2])
    x, y = np.array(track).T
    a, b, c = np.linalg.lstsq(np.column_stack([2 * x, 2 * y, np.ones_like(x)]), x * x + y * y, rcond=None)[0]
    radius = math.sqrt(c + a * a + b * b)
    assert radius == pytest.approx(math.hypot(u1, v1) / abs(r1), rel=1e-3)
    assert np.max(np.abs(np.hypot(x - a, y - b) - radius)) < 1e-3


# --- stability over timesteps, several vehicles in one process -------------------------------------------

@pytest.mark.parametrize("timestep", [0.002, 0.005, 0.01, 0.02, 0.05])
def test_ten_minutes_of_random_controls_stay_finite_without_warnings(timestep):
    physics = new_physics(timestep)
    rng = np.random.default_rng(int(timestep * 1000))
    steps_per_second = int(round(1.0 / timestep))
    low, high = physics.model.actuator_ctrlrange.T
    peak = np.zeros(3)
    for second in range(600):
        # Piecewise-constant controls, a third of them at the limits.
        control = rng.uniform(low, high) if second % 3 else np.where(rng.random(2) < 0.5, low, high)
        physics.set_control(control)
        physics.step(steps_per_second)
        peak = np.maximum(peak, np.abs(physics.body_velocity()))
    assert np.all(np.isfinite(physics.data.qpos)) and np.all(np.isfinite(physics.data.qvel))
    assert all(w.number == 0 for w in physics.data.warning)
    assert physics.time() == pytest.approx(600.0)
    assert peak[0] > 2.0 and peak[2] > 0.3  # the controls really drove it hard


@pytest.mark.parametrize("timestep", [0.01, 0.05])
def test_large_sway_velocity_decays_without_overshoot(timestep):
    """A 3 m/s sideways kick (e.g. a collision) decays monotonically even at dt = 0.05 s.

    The explicit sway drag alone would reverse v when dt |Y_vv| |v| > m - Y_vdot and blow up.
    """
    physics = new_physics(timestep)
    set_state(physics, 0.0, 0.0, 0.0, 3.5, 3.0, 0.0)
    sway = [3.0]
    for _ in range(int(round(1.0 / timestep))):
        physics.step()
        sway.append(physics.body_velocity()[1])
    assert np.all(np.isfinite(sway)) and sway[-1] < 0.2
    assert np.all(np.diff(sway[:5]) < 0) and min(sway) > -0.2


def test_vehicles_with_different_coefficients_coexist():
    """Interleaved steps of two vehicles (X_uu and 2 X_uu): each reaches its own terminal speed."""
    x_uu = COEFFICIENTS["X_uu"]
    first, second = new_physics(), new_physics(xml=vehicle_xml_with(X_uu=2 * x_uu))
    for physics in (first, second):
        physics.set_control([10.0, 0.0])
    for _ in range(600):
        first.step(10)
        second.step(10)
    assert first.body_velocity()[0] == pytest.approx(math.sqrt(10.0 / -x_uu), rel=1e-3)
    assert second.body_velocity()[0] == pytest.approx(math.sqrt(10.0 / (-2 * x_uu)), rel=1e-3)


FALLING_BALL = """
<mujoco><option timestep="0.001"/>
  <worldbody><body name="ball"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body></worldbody>
</mujoco>"""


def test_other_mujoco_models_are_unaffected():
    """No global callback: a plain MuJoCo model falls freely beside a live vehicle, which is unchanged."""
    alone = new_physics()
    alone.set_control([12.0, 3.0])
    alone.step(1000)

    vehicle = new_physics()
    vehicle.set_control([12.0, 3.0])
    model = mujoco.MjModel.from_xml_string(FALLING_BALL)
    data = mujoco.MjData(model)
    for _ in range(100):
        vehicle.step(10)
        mujoco.mj_step(model, data, 10)
    t = data.time
    assert data.qpos[2] == pytest.approx(-0.5 * 9.81 * t * t, rel=2e-3)  # Euler: O(dt) from the parabola
    np.testing.assert_array_equal(data.qpos[3:], [1, 0, 0, 0])
    assert data.qvel[2] == pytest.approx(-9.81 * t, rel=1e-9)
    np.testing.assert_array_equal(vehicle.data.qpos, alone.data.qpos)
    np.testing.assert_array_equal(vehicle.data.qvel, alone.data.qvel)


# --- the C step (auv_mj.sim.native) against the Python loop ----------------------------------------------------

@pytest.mark.parametrize("cross_flow", [{}, {"Y_vr": -40.0, "Y_rv": -6.0, "N_vr": 3.0, "N_rv": -20.0}],
                         ids=["REMUS", "with cross-flow terms"])
def test_the_c_step_gives_the_python_loops_bits(cross_flow):
    """`Hydrodynamics.bind` in C and in Python give the same trajectory, bit for bit: steps of 1 and 10, a
    current changed between calls, a disturbance read at every step, and nstep = 0 (forward's accelerations)."""
    assert native.kernel() is not None, "the C step was not built: is a C compiler (cc) on this machine?"
    physics = new_physics(xml=vehicle_xml_with(**cross_flow))
    model, hydro = physics.model.ptr, physics.hydrodynamics
    datas = [mujoco.MjData(model), mujoco.MjData(model)]
    advances = [hydro.bind(model, datas[0]), hydro.bind(model, datas[1], native=False)]
    for data in datas:
        data.qvel[:3] = 1.2, 0.4, 0.2
        mujoco.mj_step1(model, data)
    rng = np.random.default_rng(5)
    for k in range(300):
        controls, wind = rng.uniform([-20, -10], [20, 10]), rng.uniform(-0.5, 0.5, 2)
        nstep = (0, 1, 10)[k % 3]
        wrenches = [(lambda d=d: (5.0 * math.sin(d.time), -3.0 * math.cos(d.qpos[2]), 0.5 * d.qpos[2]))
                    if k % 4 == 0 else None for d in datas]
        model.opt.wind[:2] = wind
        for data, advance, wrench in zip(datas, advances, wrenches, strict=True):
            data.ctrl[:] = controls
            advance(nstep, model.opt.timestep, wrench)
        for name in ("qpos", "qvel", "qfrc_passive", "M", "qacc"):
            np.testing.assert_array_equal(getattr(datas[0], name), getattr(datas[1], name), err_msg=name)
        if nstep == 0:  # an unstepped apply leaves M and the passive force to the next mj_step1
            for data in datas:
                mujoco.mj_step1(model, data)
    assert datas[0].time > 10.0 and np.all(np.isfinite(datas[0].qpos))


def test_the_c_step_is_built_into_its_cache_or_the_python_loop_runs(tmp_path, monkeypatch):
    """The library is compiled into AUV_MJ_CACHE and loads; with no compiler, one warning and no kernel
    (the Python loop runs); AUV_MJ_NATIVE=0 chooses the Python loop without a word."""
    build = native.kernel.__wrapped__  # uncached: each call looks again
    monkeypatch.setenv("AUV_MJ_CACHE", str(tmp_path / "cache"))
    built = build()
    files = [path.name for path in (tmp_path / "cache").iterdir()]
    assert built is not None and len(files) == 1 and files[0].startswith("hydro_kernel-"), files  # no temporary
    monkeypatch.setenv("AUV_MJ_CACHE", str(tmp_path / "other"))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    with pytest.warns(RuntimeWarning, match="no C compiler found"):
        assert build() is None
    monkeypatch.setenv("AUV_MJ_NATIVE", "0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert build() is None


if __name__ == "__main__":  # the accuracy figures of the issue: python tests/sim/test_hydrodynamics.py
    for current in CURRENTS:
        for name in INITIAL_STATES:
            for dt in (0.01, 0.005):
                position, heading = manoeuvre_errors(name, dt, current)
                print(f"{current:>11}  {name:>9}  dt {dt:<6} max position error {position:.3f} m  "
                      f"max heading error {heading:.4f} rad")
