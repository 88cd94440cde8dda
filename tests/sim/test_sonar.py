"""The nine sonars S1..S9 of Sec. 2.2: ranges to known walls, beam directions, no echo, own hull."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from auv_mj import SONAR_RANGE, AUVPhysics, model_path
from auv_mj.arenas.arena import load
from auv_mj.sim.sonar import BEAM_ANGLES, SampleAndHold

BOW = 0.665  # sonar sites sit at the nose of the 1.33 m hull (models/auv.xml)
HALF_THICKNESS = 0.25


def arena_of_walls(*walls: tuple[str, tuple[float, float], tuple[float, float]]) -> ET.Element:
    """An arena of box walls (name, centre (x, y), half sizes (hx, hy)), built in memory."""
    root = ET.Element("mujoco")
    worldbody = ET.SubElement(root, "worldbody")
    for name, (x, y), (hx, hy) in walls:
        ET.SubElement(worldbody, "geom", name=name, type="box", pos=f"{x} {y} 0", size=f"{hx} {hy} 2")
    return root


def place(physics: AUVPhysics, x: float, y: float, psi: float) -> None:
    with physics.reset_context():
        physics.data.qpos[:3] = x, y, psi


def beam_ray(x: float, y: float, psi: float, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Origin and unit direction in the world of the beam at `angle` in the body frame."""
    origin = np.array([x + BOW * math.cos(psi), y + BOW * math.sin(psi)])
    return origin, np.array([math.cos(psi + angle), math.sin(psi + angle)])


def expected_range(origin: np.ndarray, direction: np.ndarray, walls) -> float:
    """Ray-box (slab) intersection with every wall, capped at the sonar range."""
    best = SONAR_RANGE
    for _, centre, half in walls:
        lo, hi = np.array(centre) - half, np.array(centre) + half
        near, far = 0.0, math.inf
        for axis in range(2):
            if abs(direction[axis]) < 1e-12:
                if not lo[axis] <= origin[axis] <= hi[axis]:
                    near, far = math.inf, -math.inf
                continue
            t1, t2 = sorted(((lo[axis] - origin[axis]) / direction[axis],
                             (hi[axis] - origin[axis]) / direction[axis]))
            near, far = max(near, t1), min(far, t2)
        if near <= far:
            best = min(best, near)
    return best


def test_wall_ahead_reads_its_distance_from_the_bow():
    physics = load(arena_of_walls(("wall_ahead", (20.0 + HALF_THICKNESS, 0.0), (HALF_THICKNESS, 50.0))))
    ranges = physics.sonar()
    assert ranges[4] == pytest.approx(20.0 - BOW, abs=1e-6)
    assert ranges[3] == pytest.approx((20.0 - BOW) / math.cos(math.pi / 8), abs=1e-6)
    np.testing.assert_array_equal(ranges[[0, 8]], SONAR_RANGE)


def test_beam_directions_s1_starboard_to_s9_port():
    """A wall to port is seen by S9 (+90 deg) at its distance, by S6..S8 obliquely, not by S1..S5."""
    physics = load(arena_of_walls(("wall_port", (0.0, 7.0 + HALF_THICKNESS), (100.0, HALF_THICKNESS))))
    ranges = physics.sonar()
    assert ranges[8] == pytest.approx(7.0, abs=1e-6)
    for k in (5, 6, 7):
        assert ranges[k] == pytest.approx(7.0 / math.sin(BEAM_ANGLES[k]), abs=1e-6)
    np.testing.assert_array_equal(ranges[:5], SONAR_RANGE)
    np.testing.assert_allclose(np.degrees(BEAM_ANGLES), np.arange(-90, 91, 22.5))


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (3.0, -2.0, 0.7), (-4.0, 5.0, -2.4), (1.0, 1.0, math.pi)])
def test_every_beam_reads_the_ray_box_distance(pose):
    """A box room with an obstacle: each beam's range equals an independent ray-box intersection."""
    walls = (("wall_n", (0.0, 15.0), (20.0, 0.5)), ("wall_s", (0.0, -12.0), (20.0, 0.5)),
             ("wall_e", (18.0, 0.0), (0.5, 20.0)), ("wall_w", (-16.0, 0.0), (0.5, 20.0)),
             ("obstacle_block", (6.0, 4.0), (1.0, 2.0)))
    physics = load(arena_of_walls(*walls))
    place(physics, *pose)
    ranges = physics.sonar()
    for k, angle in enumerate(BEAM_ANGLES):
        assert ranges[k] == pytest.approx(expected_range(*beam_ray(*pose, angle), walls), abs=1e-6), k


def test_nothing_in_range_reads_120():
    physics = load(arena_of_walls(("wall_far", (130.0, 0.0), (0.5, 200.0))))
    np.testing.assert_array_equal(physics.sonar(), SONAR_RANGE)
    place(physics, 20.0, 0.0, 0.0)  # now the wall is 109.335 m from the bow
    assert physics.sonar()[4] == pytest.approx(129.5 - 20.0 - BOW, abs=1e-6)
    open_water = AUVPhysics.from_xml_path(model_path("auv.xml"))
    np.testing.assert_array_equal(open_water.sonar(), SONAR_RANGE)


def test_beams_do_not_see_the_own_hull():
    """Rays leaving from inside the hull (site moved to the centre, beams crossing hull and fins) see
    past it: MuJoCo's rangefinder excludes the sensor's own body."""
    root = ET.parse(model_path("auv.xml")).getroot()
    for site in root.iter("site"):
        if site.get("name", "").startswith("sonar_site_"):
            site.set("pos", "-0.55 0 0")  # among the fins, inside the hull capsule
    xml = ET.tostring(root, encoding="unicode")
    physics = AUVPhysics.from_xml_string(xml, source="sonar inside the hull")
    np.testing.assert_array_equal(physics.sonar(), SONAR_RANGE)


def test_sonar_follows_the_vehicle_after_steps_and_holds_at_2_hz():
    physics = load(arena_of_walls(("wall_ahead", (30.5, 0.0), (0.5, 50.0))))
    physics.set_control([15.0, 0.0])
    sampler = SampleAndHold()
    first = sampler.read(physics)[4]
    physics.step(20)
    assert sampler.read(physics)[4] == first  # held until 0.5 s
    physics.step(30)
    x = physics.pose()[0]
    assert sampler.read(physics)[4] == pytest.approx(30.0 - x - BOW, abs=1e-6) and x > 0.05


# --- the map's edge as the beams would read it (a geofence, issue 15) --------------------------------------


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (37.0, -5.0, 0.4), (-52.0, 30.0, 2.9), (10.0, 38.5, -1.2),
                                  (-60.0, -39.0, -2.3)])
def test_the_fence_reads_what_the_sonar_would_if_the_map_edge_were_walls(pose):
    """`fence_ranges` against MuJoCo's own rangefinders in a room whose inner faces are the map's bounds."""
    from auv_mj.sim.sonar import fence_ranges

    bounds = (-70.0, -45.0, 55.0, 40.0)
    x_min, y_min, x_max, y_max = bounds
    cx, cy, hx, hy = (x_min + x_max) / 2, (y_min + y_max) / 2, (x_max - x_min) / 2 + 1, (y_max - y_min) / 2 + 1
    physics = load(arena_of_walls(("wall_n", (cx, y_max + 0.5), (hx, 0.5)), ("wall_s", (cx, y_min - 0.5), (hx, 0.5)),
                                  ("wall_e", (x_max + 0.5, cy), (0.5, hy)), ("wall_w", (x_min - 0.5, cy), (0.5, hy))))
    place(physics, *pose)
    origin = beam_ray(*pose, 0.0)[0]
    np.testing.assert_allclose(fence_ranges(origin, pose[2], bounds), physics.sonar(), atol=1e-6)


def test_the_fence_is_at_most_the_sonar_range_and_zero_outside_the_map():
    from auv_mj.sim.sonar import fence_ranges

    bounds = (0.0, 0.0, 600.0, 600.0)
    np.testing.assert_array_equal(fence_ranges((300.0, 300.0), 0.3, bounds), SONAR_RANGE)
    near_east = fence_ranges((590.0, 300.0), 0.0, bounds)  # heading east, 10 m from the edge
    assert near_east[4] == pytest.approx(10.0) and near_east[3] == pytest.approx(10.0 / math.cos(math.pi / 8))
    assert near_east[0] == near_east[8] == SONAR_RANGE  # beams along the edge see nothing within range
    np.testing.assert_array_equal(fence_ranges((600.5, 300.0), 0.0, bounds), 0.0)
