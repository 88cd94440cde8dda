"""Ocean conditions for the 6-DOF vehicle (`auv_mj.sim.ocean3d`)."""

from __future__ import annotations

import numpy as np
import pytest

from auv_mj import model_path
from auv_mj.arenas.arena3d import compose_xml
from auv_mj.sim.ocean3d import CurrentProfile, Ocean3D
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose


def test_the_current_profile_is_the_seventh_power_law_above_the_bed():
    profile = CurrentProfile(water_depth=60.0)
    assert profile.factor(0.0) == 1.0 and profile.factor(60.0) == 0.0 and profile.factor(80.0) == 0.0
    assert profile.factor(30.0) == pytest.approx(0.5 ** (1 / 7))


def test_ocean_writes_the_current_at_the_vehicles_depth_and_moves_it():
    xml, source = compose_xml(None, thruster_lag=True)
    physics = AUV3DPhysics.from_xml_string(xml, source=source)
    set_pose(physics, (0.0, 0.0, -30.0))
    ocean = Ocean3D({"sonar": False, "model_uncertainty": False})
    ocean.start(physics, np.random.RandomState(0))
    vx, vy = ocean.current.velocity()
    np.testing.assert_allclose(physics.model.opt.wind[:2], np.array([vx, vy]) * ocean.profile.factor(30.0))
    first = physics.model.opt.wind.copy()
    physics.step(1000)
    ocean.tick(physics)
    assert not np.allclose(physics.model.opt.wind, first)


def test_a_neutral_vehicle_moving_with_the_water_drifts_with_it_exactly():
    """At zero velocity through the water there is no water force: the vehicle keeps the current's velocity."""
    xml = model_path("auv6.xml").read_text().replace('data="302.34"', f'data="{30.48 * 9.81!r}"')
    physics = AUV3DPhysics.from_xml_string(xml, source="neutral")
    current = np.array([0.3, -0.2, 0.0])
    physics.model.opt.wind[:] = current
    set_pose(physics, (0.0, 0.0, -20.0), yaw=0.6)
    physics.data.qvel[:3] = current
    physics.forward()
    physics.step(6000)
    np.testing.assert_allclose(physics.data.qvel[:3], current, atol=1e-6)
    np.testing.assert_allclose(physics.position(), [0.3 * 60.0, -0.2 * 60.0, -20.0], atol=1e-4)
    assert physics.heading() == pytest.approx(0.6, abs=1e-6)


def test_fin_lag_delays_the_fins_and_model_uncertainty_scales_and_restores_the_vehicle():
    ideal = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    xml, source = compose_xml(None, thruster_lag=True)
    lagged = AUV3DPhysics.from_xml_string(xml, source=source)
    for physics in (ideal, lagged):
        physics.set_control([0.0, 0.2, 0.0])
        physics.step(50)  # 0.5 s: the servo alone gets there in 0.38 s
    assert 0.0 < lagged.fins[0] < ideal.fins[0] == pytest.approx(0.2)
    nominal = lagged.hydrodynamics.coefficients
    lagged.scale_vehicle({"Z_ww": 1.2}, mass=1.1)
    assert lagged.hydrodynamics.coefficients.Z_ww == pytest.approx(1.2 * nominal.Z_ww)
    assert lagged.hydrodynamics.coefficients.B == pytest.approx(1.1 * nominal.B)
    lagged.scale_vehicle()
    assert lagged.hydrodynamics.coefficients == nominal
    with pytest.raises(ValueError, match="unknown 6-DOF coefficient"):
        lagged.scale_vehicle({"Q_xx": 2.0})
