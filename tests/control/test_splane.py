"""The S-plane controller of Eq. (32): step responses on the REMUS model, output bounds, reset."""

import math

import numpy as np
import pytest

from auv_mj.control.splane import EXECUTOR_DT, SPlaneController, SPlaneGains, s_plane
from auv_mj.geometry import wrap_angle
from auv_mj.sim.vehicle import vehicle_facts
from experiments.splane_tuning import step_response

SURGE_LIMIT = vehicle_facts().surge_limit
YAW_LIMIT = vehicle_facts().yaw_limit


@pytest.mark.parametrize("x", [-7.0, -0.3, 0.0, 0.4, 12.0])
def test_s_surface_is_eq_32(x):
    assert s_plane(x, 0.0, 1.0, 0.0) == pytest.approx(2.0 / (1.0 + math.exp(-x)) - 1.0, abs=1e-12)
    assert s_plane(1.0, 2.0, 0.5, x) == pytest.approx(2.0 / (1.0 + math.exp(-0.5 - 2.0 * x)) - 1.0, abs=1e-12)


def test_wrap_angle():
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-3 * math.pi / 2) == pytest.approx(math.pi / 2)
    assert wrap_angle(0.3) == pytest.approx(0.3)


def test_speed_step_settles_within_a_few_percent_in_30s():
    e_v, e_psi = step_response(SPlaneGains(), (1.0, 0.0), seconds=30.0)
    assert np.max(np.abs(e_v[-50:])) < 0.03  # the last 5 s within 3 % of 1 m/s
    assert np.max(np.abs(e_psi)) < 1e-9  # a straight run needs no yaw moment


def test_heading_step_of_90_degrees_settles():
    e_v, e_psi = step_response(SPlaneGains(), (1.0, math.pi / 2), initial_speed=1.0, seconds=30.0)
    assert np.max(np.abs(e_psi[-100:])) < 0.05  # the last 10 s within 0.05 rad
    assert np.min(e_psi) > -0.1  # little overshoot
    assert np.max(np.abs(e_v[-100:])) < 0.05


def test_output_stays_within_actuator_limits():
    rng = np.random.default_rng(0)
    controller = SPlaneController()
    for _ in range(2000):
        command = (rng.uniform(-5, 5), rng.uniform(-10, 10))
        state = rng.normal(0, 3, size=4)
        tau = controller(command, state)
        assert tau.shape == (2,)
        assert abs(tau[0]) <= SURGE_LIMIT and abs(tau[1]) <= YAW_LIMIT


def test_integrators_are_bounded():
    gains = SPlaneGains()
    controller = SPlaneController(gains)
    for _ in range(100_000 // 100):
        controller((1.0, 0.1), (0.9, 0.0, 0.0, 0.0))  # errors inside the bands, forever
    assert abs(gains.ki_speed * controller._int_speed) <= gains.integral_limit + 1e-12
    assert abs(gains.ki_heading * controller._int_heading) <= gains.integral_limit + 1e-12


def test_reset_clears_state():
    fresh = SPlaneController()
    used = SPlaneController()
    for k in range(200):
        used((1.0, 0.1), (0.9 + 0.001 * k, 0.0, 0.01, 0.05))
    state = (0.95, 0.0, 0.0, 0.08)
    assert not np.allclose(used((1.0, 0.1), state), fresh((1.0, 0.1), state))
    used.reset()
    fresh.reset()
    assert np.array_equal(used((1.0, 0.1), state), fresh((1.0, 0.1), state))


def test_steady_state_uses_drag_feed_forward():
    """At the command, with no integral yet, the thrust is the REMUS drag 1.62 V^2 (du_V of Eq. 32)."""
    controller = SPlaneController()
    tau = controller((1.5, 0.0), (1.5, 0.0, 0.0, 0.0))
    assert tau[0] == pytest.approx(1.62 * 1.5**2)
    assert tau[1] == pytest.approx(0.0)


def test_gains_are_frozen():
    with pytest.raises(AttributeError):
        SPlaneGains().k1_speed = 1.0  # type: ignore[misc]
    assert SPlaneGains().dt == EXECUTOR_DT
