"""The 3-D protection domain (issue 52): sized to the tube it is in, and deaf to one lost echo or one range that
jumps away."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj.arenas import tubes
from auv_mj.planners import los3d
from auv_mj.sim.sensors3d import FAN_AZIMUTHS, FAN_ELEVATIONS
from auv_mj.sim.sonar import SONAR_RANGE, SONAR_RATE_HZ
from auv_mj.tasks import auv3d

PING = 1.0 / SONAR_RATE_HZ
LEVEL = int(np.argmin(np.abs(FAN_ELEVATIONS)))
PORT = int(np.argmax(FAN_AZIMUTHS))
"""The level row's beam abeam to port (+90 deg)."""


def beam(row: int, column: int) -> int:
    """Index of a fan beam in `auv_mj.sim.sensors3d` order (elevation-major)."""
    return row * len(FAN_AZIMUTHS) + column


def fan_off_centre(radius: float, offset: float) -> np.ndarray:
    """The 27 ranges [m] of a vehicle on a straight tube's axis direction, `offset` m to port of the centreline:
    each beam's distance to the cylinder of `radius` (beyond SONAR_RANGE: no echo)."""
    elevation, azimuth = np.meshgrid(FAN_ELEVATIONS, FAN_AZIMUTHS, indexing="ij")
    y, z = (np.cos(elevation) * np.sin(azimuth)).ravel(), np.sin(elevation).ravel()  # across the tube
    a = y * y + z * z
    b = 2.0 * offset * y
    c = offset * offset - radius * radius
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-b + np.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    return np.where((a > 1e-12) & (t < SONAR_RANGE), t, SONAR_RANGE)


@pytest.mark.parametrize("radius", [1.0, 2.0, 3.0, 5.0, 50.0])
def test_a_tubes_domain_stays_inside_the_tube(radius):
    field = los3d.tube_field(radius)
    assert field.influence < radius
    # On the centreline no wall echo lies inside the domain: the command passes untouched.
    ranges = fan_off_centre(radius, 0.0)
    command = (1.5, 0.3, 20.0)
    assert los3d.protect_command(command, 0.3, ranges, field) == pytest.approx(command)
    # Well off it, the near wall pushes the heading away (starboard) and keeps the depth command within the domain.
    near = fan_off_centre(radius, 0.9 * radius)
    speed, heading, depth = los3d.protect_command(command, 0.3, near, field)
    assert heading < 0.3 and abs(depth - 20.0) <= field.influence + 1e-9
    with pytest.raises(ValueError, match="radius"):
        los3d.tube_field(0.0)


def test_the_domain_in_a_users_4_m_tube_is_sized_to_it(tmp_path):
    """A user's tube 4 m across (radius 2 m, under the 2.5 m of the fixed domain this replaces): the domain of every
    planner that uses it is within the tube's radius, and at the start, on the centreline, it leaves line of sight
    alone."""
    line = np.column_stack([np.linspace(0.0, 60.0, 16), np.zeros(16), np.full(16, -20.0)])
    path = tmp_path / "narrow.xml"
    ET.ElementTree(tubes.tube_arena(tubes.Tube(line, 2.0), "narrow")).write(path)
    env = auv3d.tunnel3d(arena=str(path))
    env.reset()
    task = env.task
    assert task.tube_radius == pytest.approx(2.0)
    field = los3d.domain_field(task)
    assert field.influence < task.tube_radius
    ranges = task.sensors.read(env.physics)["sonar"]
    heading = env.physics.heading()
    command = (1.5, heading, env.physics.depth())
    assert los3d.protect_command(command, heading, ranges, field) == pytest.approx(command)
    # In open water the domain is the paper's, and the mapping planner's its own.
    goal = auv3d.goal3d(random=0)
    goal.reset()
    assert goal.task.tube_radius is None and los3d.domain_field(goal.task) is los3d.OPEN_FIELD


def test_one_lost_echo_or_one_spike_does_not_push_the_vehicle():
    """A vehicle 2.2 m off the centreline of a 3 m tube, its wall inside the domain: one ping that loses the near
    echo, or whose noise throws the near echo 1 m long, leaves the filtered command as it was; the raw fan would
    have turned the vehicle towards the wall."""
    field = los3d.tube_field(3.0)
    steady = fan_off_centre(3.0, 2.2)
    assert steady[beam(LEVEL, PORT)] < field.influence
    command = (1.5, 0.0, 20.0)
    expected = los3d.protect_command(command, 0.0, steady, field)
    assert expected[1] < 0.0  # the near (port) wall turns it to starboard
    lost = steady.copy()
    lost[beam(LEVEL, PORT)] = SONAR_RANGE
    spike = steady.copy()
    spike[beam(LEVEL, PORT)] += 1.0  # out of the domain
    for odd in (lost, spike):
        assert los3d.protect_command(command, 0.0, odd, field)[1] > expected[1] + 0.2  # raw: towards the wall
        fan = los3d.FanFilter()
        pings = [steady, steady, odd, steady, steady]
        for k, ranges in enumerate(pings):
            for sub in (0.0, 0.5 * PING):  # the planner may read a held ping twice: still one ping
                filtered = fan(k * PING + sub, ranges)
                assert los3d.protect_command(command, 0.0, filtered, field) == pytest.approx(expected)
    # An echo that comes nearer is heard at once; one that goes away waits for a second ping.
    fan = los3d.FanFilter()
    clear = fan_off_centre(3.0, 0.0)
    for k, ranges in enumerate([clear, clear, steady]):
        filtered = fan(k * PING, ranges)
    nearer = steady < clear
    assert nearer[beam(LEVEL, PORT)] and filtered[nearer] == pytest.approx(steady[nearer])
    assert filtered[~nearer] == pytest.approx(clear[~nearer])
    with pytest.raises(ValueError, match="pings"):
        los3d.FanFilter(0)


@pytest.mark.parametrize("pings", [1, 2, 3])
def test_the_filter_is_the_nearer_of_the_newest_ping_and_the_median(pings):
    fan = los3d.FanFilter(pings)
    rng = np.random.default_rng(0)
    history = [rng.uniform(0.5, 10.0, 27) for _ in range(6)]
    for k, ranges in enumerate(history):
        out = fan(k * PING, ranges)
        median = np.median(np.stack(history[max(0, k - pings + 1):k + 1]), axis=0)
        assert out == pytest.approx(np.minimum(median, ranges))
    fan.reset()
    assert fan(100.0, history[0]) == pytest.approx(history[0])


def test_los_avoid_holds_a_tube_in_ocean_water():
    """los-avoid through a standard tube in ocean water (current, lag, noise, dropouts), which it left through the
    wall with the fixed 2.5 m domain at k_2 = 120: it reaches the end clear of the wall."""
    env = auv3d.tunnel3d(random=3, conditions="ocean")
    policy = los3d.los_policy(env, avoid=True)
    step = env.reset()
    clearance = []
    while not step.last():
        step = env.step(policy(step))
        clearance.append(env.task.last_info["min_clearance"])
    assert env.task.last_info["event"] == "goal"
    assert min(clearance) > 0.3


def test_the_filter_is_the_tubes_and_open_water_reads_the_fan_as_it_is():
    """In a tube the domain reads the filtered fan; in open water (where the vehicle turns fast round obstacles and
    a per-beam filter would smear echoes across the turn) the fan as it is."""
    steady = fan_off_centre(3.0, 2.2)
    lost = steady.copy()
    lost[beam(LEVEL, PORT)] = SONAR_RANGE
    tube, open_water = auv3d.Tunnel3D(), auv3d.Goal3D()
    tube.tube_radius = 3.0
    for task, expected in ((tube, steady), (open_water, lost)):
        fan = los3d.FanFilter()
        for k, ranges in enumerate([steady, steady, lost]):
            out = los3d.domain_ranges(task, fan, k * PING, ranges)
        assert out == pytest.approx(expected)


def test_crab_estimate_settles_on_the_course_over_ground():
    """A vehicle at 1.5 m/s through the water carried 0.25 m/s sideways by a current, flying straight: its DVL
    reads (1.5, -0.25) over the ground, its course is atan2(-0.25, 1.5) off its heading. Turning, or too slow to
    tell a course, the angle is held."""
    crab = los3d.CrabEstimate()
    straight = np.zeros(3)
    for _ in range(60):
        angle = crab({"dvl": np.array([1.5, -0.25, 0.0]), "gyro": straight})
    assert angle == pytest.approx(math.atan2(-0.25, 1.5), abs=1e-4)
    assert crab({"dvl": np.array([0.1, 0.3, 0.0]), "gyro": straight}) == angle
    turning = np.array([0.0, 0.0, 2.0 * los3d.CRAB_MAX_RATE])
    assert crab({"dvl": np.array([1.5, 0.4, 0.0]), "gyro": turning}) == angle
    assert crab({"dvl": np.array([1.5, 0.4, 0.0]), "gyro": -turning}) == angle
    crab.reset()
    assert crab({"dvl": np.zeros(3), "gyro": straight}) == 0.0
    with pytest.raises(ValueError, match="gain"):
        los3d.CrabEstimate(gain=0.0)
    assert los3d.course_command((1.5, 0.3, 20.0), -0.2) == pytest.approx((1.5, 0.5, 20.0))
