"""The 6-DOF vehicle (`models/auv6.xml`, `auv_mj.sim.hydro3d`) against independent maths (issue 32).

The reference is Fossen's equations in Prestero's frames, integrated by scipy (tests/reference/vehicle3d_reference.py).
The manoeuvre is closed-loop, a yaw zig-zag with a dive to 30 m and a climb back, so that an open-loop
divergence of the (directionally and pitch-unstable) REMUS does not decide the comparison: the same control
law acts on each model's own state, the simulator's held over each step (zero-order hold).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle3d_reference import VEHICLE3D_XML, Reference3D, read_numerics, read_rigid_body

from auv_mj import AUVPhysics, model_path
from auv_mj.sim.hydro3d import FLU_TO_FRD, spec_from_xml
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose

MANOEUVRE_TIME = 60.0
CURRENT = np.array([0.3, -0.2, 0.0])
"""World current [m/s] (MuJoCo frame, `model.opt.wind`) during the manoeuvre."""
FIN_LIMIT = 0.237
START_DEPTH = 20.0
NU0 = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def clip(x: float, limit: float) -> float:
    return min(max(x, -limit), limit)


def manoeuvre_law(t: float, depth: float, theta: float, psi: float, pitch_rate: float, yaw_rate: float):
    """(thrust, rudder, stern) from depth [m], pitch (nose up) [rad], heading (ccw) [rad] and their rates."""
    depth_cmd = START_DEPTH + 5.0 * (1.0 - math.cos(2.0 * math.pi * t / MANOEUVRE_TIME))
    heading_cmd = 0.4 * math.sin(2.0 * math.pi * t / 30.0)
    theta_cmd = clip(-0.1 * (depth_cmd - depth), 0.4)
    stern = clip(theta - theta_cmd + pitch_rate, FIN_LIMIT)
    error = math.atan2(math.sin(heading_cmd - psi), math.cos(heading_cmd - psi))
    rudder = clip(0.5 * error - 0.7 * yaw_rate, FIN_LIMIT)
    return 10.0, rudder, stern


@functools.cache
def reference_solution():
    reference = Reference3D.from_xml()
    state0 = np.zeros(12)
    state0[2], state0[6:] = START_DEPTH, NU0
    current_ned = CURRENT * np.array([1.0, -1.0, -1.0])

    def law(t, s):  # the reference's state in MuJoCo's terms: psi and yaw rate flip, nose-up rate is q (FRD)
        return manoeuvre_law(t, s[2], s[4], -s[5], s[10], -s[11])

    solution = solve_ivp(lambda t, s: reference.derivative(s, law(t, s), current_ned), (0.0, MANOEUVRE_TIME),
                         state0, method="DOP853", rtol=1e-10, atol=1e-10, dense_output=True)
    assert solution.success
    return solution.sol


@functools.cache
def manoeuvre(timestep: float):
    """(times, positions, attitudes, fin commands) of the simulator over the manoeuvre."""
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    physics.model.opt.timestep = timestep
    physics.model.opt.wind[:] = CURRENT
    set_pose(physics, (0.0, 0.0, -START_DEPTH), nu=NU0)
    steps = int(round(MANOEUVRE_TIME / timestep))
    times, positions, attitudes, commands = (np.empty((steps, n)) for n in (1, 3, 3, 3))
    for k in range(steps):
        attitude, nu = physics.attitude(), physics.body_velocity()
        commands[k] = manoeuvre_law(physics.time(), physics.depth(), attitude[1], attitude[2], -nu[4], nu[5])
        physics.set_control(commands[k])
        physics.step()
        times[k], positions[k], attitudes[k] = physics.time(), physics.position(), physics.attitude()
    return times[:, 0], positions, attitudes, commands


def errors(timestep: float) -> tuple[float, float]:
    """Max position [m] and attitude [rad] error against the reference."""
    times, positions, attitudes, _ = manoeuvre(timestep)
    ref = reference_solution()(times)
    ref_positions = np.column_stack([ref[0], -ref[1], -ref[2]])
    ref_attitudes = np.column_stack([ref[3], ref[4], -ref[5]])
    position_error = np.max(np.linalg.norm(positions - ref_positions, axis=1))
    attitude_error = np.max(np.abs(np.angle(np.exp(1j * (attitudes - ref_attitudes)))))
    return float(position_error), float(attitude_error)


def test_zigzag_dive_and_climb_match_the_scipy_reference_at_the_default_timestep():
    assert AUV3DPhysics.from_xml_path(model_path("auv6.xml")).model.opt.timestep == 0.01
    position_error, attitude_error = errors(0.01)
    assert position_error <= 0.5
    assert attitude_error <= 0.05


def test_the_manoeuvre_dives_climbs_and_zigzags_within_the_fin_rate():
    times, positions, attitudes, commands = manoeuvre(0.01)
    depth = -positions[:, 2]
    assert depth.max() - START_DEPTH > 7.0 and depth.max() - depth[-1] > 5.0  # down ~10 m and back up
    assert np.ptp(attitudes[:, 2]) > 0.6 and np.ptp(attitudes[:, 1]) > 0.3 and positions[-1, 0] > 80.0
    rate = np.abs(np.diff(commands[:, 1:], axis=0)).max() / 0.01
    fin_rate = spec_from_xml(VEHICLE3D_XML.read_text()).fin_rate
    assert rate < fin_rate  # the fins follow their commands, as the reference assumes


def test_halving_the_timestep_halves_the_error():
    coarse, fine = errors(0.02), errors(0.01)
    for big, small in zip(coarse, fine, strict=True):
        assert 1.6 < big / small < 2.5


@pytest.mark.parametrize("timestep", [0.002, 0.005, 0.01, 0.02, 0.05])
def test_random_full_range_controls_stay_finite_and_bounded(timestep):
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    physics.model.opt.timestep = timestep
    set_pose(physics, (0.0, 0.0, -30.0), nu=(1.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    rng = np.random.default_rng(int(timestep * 1000))
    low, high = physics.model.actuator_ctrlrange.T
    hold = max(1, int(round(1.0 / timestep)))
    for _ in range(20):  # 20 s, a new random control every second
        physics.set_control(rng.uniform(low, high))
        physics.step(hold)
        nu = physics.body_velocity()
        assert np.all(np.isfinite(nu)) and np.all(np.abs(nu[:3]) < 5.0) and np.all(np.abs(nu[3:]) < 10.0)
    assert not np.any(physics.data.warning.number)


def neutral_xml() -> str:
    """The shipped vehicle with B = W: released at rest, it pitches about a fixed depth."""
    shipped = 'name="hydro_B" data="302.34"'
    text = VEHICLE3D_XML.read_text()
    assert shipped in text
    return text.replace(shipped, f'name="hydro_B" data="{read_rigid_body()[0] * 9.81!r}"')


def peak_times(values: np.ndarray, times: np.ndarray) -> np.ndarray:
    inside = (values[1:-1] > values[:-2]) & (values[1:-1] >= values[2:])
    return times[1:-1][inside]


def test_pitch_oscillation_period_matches_the_small_angle_closed_form():
    """T = 2 pi / sqrt(z_g W (M^-1)_qq), M = M_RB + M_A of the reference (the coupled small-angle mode)."""
    reference = Reference3D.from_xml()
    physics = AUV3DPhysics.from_xml_string(neutral_xml(), source="neutral REMUS")
    set_pose(physics, (0.0, 0.0, -20.0), pitch=0.01)  # small: the quadratic pitch damping stays negligible
    times, pitch = np.empty(4000), np.empty(4000)
    for k in range(4000):
        physics.step()
        times[k], pitch[k] = physics.time(), physics.attitude()[1]
    z_g, weight = reference.r_g[2], reference.m * 9.81
    inverse = np.linalg.inv(reference.rigid_body_mass() + reference.added_mass())
    closed_form = 2.0 * math.pi / math.sqrt(z_g * weight * inverse[4, 4])
    periods = np.diff(peak_times(pitch, times))
    assert len(periods) >= 3
    assert np.all(np.abs(periods - closed_form) < 0.005 * closed_form)


def test_the_positively_buoyant_vehicle_returns_to_trim_and_rises():
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    set_pose(physics, (0.0, 0.0, -20.0), pitch=0.2)
    physics.step(6000)
    assert abs(physics.attitude()[1]) < 0.01
    rise = physics.data.qvel[2]  # world z, up
    c = read_numerics()
    terminal = math.sqrt((c["B"] - read_rigid_body()[0] * 9.81) / -c["Z_ww"])
    assert rise == pytest.approx(terminal, rel=0.02)  # B - W = -Z_ww w |w| at the terminal rise rate
    assert 20.0 - physics.depth() > 0.8 * terminal * 60.0  # it floats up, near the terminal rate throughout


FIN_CASES = {"rudder": (0.1, 0.0), "stern": (0.0, -0.15), "both": (-0.2, 0.12)}


@pytest.mark.parametrize("case", FIN_CASES)
@pytest.mark.parametrize("current", [(0.0, 0.0, 0.0), (0.4, 0.3, 0.0)])
def test_each_fin_force_is_its_closed_form(case, current):
    """The change in the generalised force made by the fins is (0, Y_uudr, Z_uuds, 0, M_uuds, N_uudr) u_r^2 delta
    in Prestero's frame, turned into MuJoCo's (y, z, pitch and yaw flip) and rotated to the world."""
    rudder, stern = FIN_CASES[case]
    c = read_numerics()
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    physics.model.opt.wind[:] = current
    set_pose(physics, (0.0, 0.0, -20.0), roll=0.1, pitch=-0.2, yaw=0.7, nu=(1.8, 0.1, -0.05, 0.02, 0.03, -0.04))
    physics.forward()
    without = physics.data.qfrc_passive.copy()
    physics.reset_fins(rudder, stern)
    physics.forward()
    change = physics.data.qfrc_passive - without
    u_r = physics.relative_velocity()[0]
    frd = np.array([0.0, c["Y_uudr"] * rudder, c["Z_uuds"] * stern, 0.0, c["M_uuds"] * stern,
                    c["N_uudr"] * rudder]) * u_r ** 2
    body = FLU_TO_FRD * frd
    expected = np.concatenate([physics.rotation() @ body[:3], body[3:]])
    np.testing.assert_allclose(change, expected, rtol=1e-10, atol=1e-10)


def test_positive_rudder_turns_to_port_and_positive_stern_dives():
    for control, check in (((10.0, 0.1, 0.0), lambda p: p.heading() > 0.3),
                           ((10.0, 0.0, 0.05), lambda p: p.depth() > 21.0)):
        physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
        set_pose(physics, (0.0, 0.0, -20.0), nu=(2.0, 0, 0, 0, 0, 0))
        physics.set_control(control)
        physics.step(500)
        assert check(physics)


def test_fins_slew_at_the_rate_limit_and_stop_at_the_angle_limit():
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    spec = physics.hydrodynamics.spec
    physics.set_control([0.0, 1.0, -1.0])  # beyond the 0.237 rad limit both ways
    physics.step(10)
    np.testing.assert_allclose(physics.fins, [10 * 0.01 * spec.fin_rate, -10 * 0.01 * spec.fin_rate])
    physics.step(100)
    np.testing.assert_allclose(physics.fins, [FIN_LIMIT, -FIN_LIMIT])


def test_with_heave_roll_and_pitch_held_the_6dof_model_is_the_planar_model():
    """Held (an armature of 1e9 on the heave, roll and pitch dofs), the 6-DOF REMUS follows the planar REMUS of
    models/auv.xml step for step: thrust, and the planar yaw moment applied as a world torque."""
    planar = AUVPhysics.from_xml_path(model_path("auv.xml"))
    full = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    full.model.dof_armature[[2, 3, 4]] = 1e9

    def tau(t: float) -> tuple[float, float]:
        return 10.0 + 8.0 * math.sin(0.21 * t), 4.0 * math.sin(0.13 * t) + 3.0 * math.sin(0.37 * t + 0.5)

    with planar.reset_context():
        planar.data.qvel[:3] = 1.2, 0.2, 0.1  # psi = 0: body and world velocities coincide
    set_pose(full, (0.0, 0.0, -10.0), nu=(1.2, 0.2, 0.0, 0.0, 0.0, 0.1))
    full.disturbance = lambda t: np.array([0.0, 0.0, 0.0, 0.0, 0.0, tau(t)[1]])
    worst_position = worst_heading = 0.0
    for _ in range(6000):
        thrust, moment = tau(planar.time())
        planar.set_control([thrust, moment])
        planar.step()
        full.set_control([thrust, 0.0, 0.0])
        full.step()
        worst_position = max(worst_position, float(np.hypot(*(planar.pose()[:2] - full.position()[:2]))))
        worst_heading = max(worst_heading, abs(math.remainder(planar.pose()[2] - full.heading(), 2 * math.pi)))
    assert np.hypot(*planar.pose()[:2]) > 10.0
    assert worst_position < 1e-6 and worst_heading < 1e-6
    assert abs(full.depth() - 10.0) < 1e-3 and np.all(np.abs(full.attitude()[:2]) < 1e-5)
