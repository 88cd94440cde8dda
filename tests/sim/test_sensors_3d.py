"""The 6-DOF vehicle's sensors (`auv_mj.sim.sensors3d`) against geometry worked out by hand."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from auv_mj.arenas.arena3d import arena_root, compose_xml, seabed
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose
from auv_mj.sim.sensors3d import (
    ALTIMETER_RANGE,
    FAN_AZIMUTHS,
    FAN_BEAMS,
    FAN_ELEVATIONS,
    SAMPLE_RATES_HZ,
    Sensors3D,
    altimeter,
    depth_from_pressure,
    fan_directions,
    pressure,
    sonar_fan,
)
from auv_mj.sim.sonar import SONAR_RANGE

BED = 40.0


def physics_over_seabed(*extra: ET.Element) -> AUV3DPhysics:
    xml, source = compose_xml(arena_root("bed", [seabed(BED), *extra]))
    return AUV3DPhysics.from_xml_string(xml, source=source)


def test_fan_has_three_rows_of_the_planar_nine_beams():
    directions = fan_directions()
    assert directions.shape == (FAN_BEAMS, 3) == (27, 3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
    rows = directions.reshape(3, 9, 3)
    for row, elevation in zip(rows, FAN_ELEVATIONS, strict=True):
        np.testing.assert_allclose(np.arcsin(row[:, 2]), elevation)
        np.testing.assert_allclose(np.arctan2(row[:, 1], row[:, 0]), FAN_AZIMUTHS, atol=1e-12)
    assert FAN_ELEVATIONS[0] < 0 < FAN_ELEVATIONS[2]


@pytest.mark.parametrize("attitude", [(0.0, 0.0, 0.0), (0.2, -0.3, 1.0), (-0.1, 0.25, -2.5)])
def test_fan_ranges_to_a_seabed_are_height_over_the_beams_downward_cosine(attitude):
    physics = physics_over_seabed()
    roll, pitch, yaw = attitude
    set_pose(physics, (3.0, -2.0, -10.0), roll=roll, pitch=pitch, yaw=yaw)
    physics.forward()
    site = physics.model.site("sonar").id
    origin = physics.data.site_xpos[site]
    world = fan_directions() @ physics.data.site_xmat[site].reshape(3, 3).T
    height = origin[2] + BED
    with np.errstate(divide="ignore"):
        expected = np.where(world[:, 2] < 0, height / -world[:, 2], np.inf)
    expected = np.where(expected > SONAR_RANGE, SONAR_RANGE, expected)
    np.testing.assert_allclose(sonar_fan(physics), expected, rtol=1e-9)
    down = -physics.data.site_xmat[physics.model.site("altimeter").id].reshape(3, 3)[:, 2]
    altitude = physics.data.site_xpos[physics.model.site("altimeter").id][2] + BED
    assert altimeter(physics) == pytest.approx(min(altitude / -down[2], ALTIMETER_RANGE), rel=1e-9)


def test_a_wall_ahead_is_seen_by_the_level_rows_centre_beam_at_its_distance():
    wall = ET.Element("geom", name="wall", type="box", size="1 30 30", pos="21 0 -10")
    physics = physics_over_seabed(wall)
    set_pose(physics, (0.0, 0.0, -10.0))
    physics.forward()
    ranges = sonar_fan(physics).reshape(3, 9)
    sonar_x = physics.data.site_xpos[physics.model.site("sonar").id][0]
    assert ranges[1, 4] == pytest.approx(20.0 - sonar_x)
    assert ranges[1, 3] == pytest.approx((20.0 - sonar_x) / math.cos(math.pi / 8))
    assert ranges[1, 0] == SONAR_RANGE and ranges[1, 8] == SONAR_RANGE  # abeam: nothing


def test_depth_from_pressure_dvl_and_imu():
    physics = physics_over_seabed()
    nu = (1.2, -0.1, 0.05, 0.0, 0.02, -0.03)
    set_pose(physics, (0.0, 0.0, -12.5), pitch=0.1, yaw=0.4, nu=nu)
    physics.evaluate_sensors()
    port = physics.data.site_xpos[physics.model.site("pressure").id]
    assert depth_from_pressure(pressure(physics)) == pytest.approx(-port[2])
    dvl_site = physics.data.site_xpos[physics.model.site("dvl").id] - physics.position()
    omega = np.array(nu[3:])
    lever = physics.rotation().T @ dvl_site
    np.testing.assert_allclose(physics.named.data.sensordata["dvl"], np.array(nu[:3]) + np.cross(omega, lever),
                               atol=1e-12)
    np.testing.assert_allclose(physics.named.data.sensordata["gyro"], omega, atol=1e-12)


def test_sensors_sample_at_their_rates_and_hold():
    physics = physics_over_seabed()
    set_pose(physics, (0.0, 0.0, -10.0), nu=(1.0, 0, 0, 0, 0, 0))
    physics.set_control([10.0, 0.0, 0.1])
    sensors = Sensors3D()
    first = sensors.read(physics)
    assert set(first) == {"sonar", "altimeter", "depth", "dvl", "gyro", "accelerometer", "attitude"}
    physics.step(5)  # 0.05 s: only the 50 Hz IMU is due again
    second = sensors.read(physics)
    assert second["depth"] == first["depth"] and np.array_equal(second["sonar"], first["sonar"])
    assert not np.array_equal(second["gyro"], first["gyro"])
    physics.step(int(round(100 / SAMPLE_RATES_HZ["depth"])) - 5)
    assert sensors.read(physics)["depth"] != first["depth"]
