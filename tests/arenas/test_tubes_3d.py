"""Tube arenas (`auv_mj.arenas.tubes`): authoring, the closed wall, `check_tube`, and the CLI round trip."""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from auv_mj.arenas import tubes
from auv_mj.arenas.arena3d import compose_xml
from auv_mj.arenas.arena_check import check_arena
from auv_mj.sim.physics3d import AUV3DPhysics


def straight(length: float = 40.0, depth: float = 15.0, slope: float = 0.0) -> np.ndarray:
    s = np.linspace(0.0, length, int(length / 4.0) + 1)
    return np.column_stack([s * math.cos(slope), np.zeros_like(s), -depth + s * math.sin(slope)])


def bend(radius: float, angle: float = math.pi / 2, depth: float = 15.0) -> np.ndarray:
    t = np.linspace(0.0, angle, 12)
    return np.column_stack([radius * np.sin(t), radius * (1 - np.cos(t)), np.full_like(t, -depth)])


@pytest.mark.parametrize("seed", range(8))
def test_procedural_tubes_pass_the_check_and_climb_dive_and_bend(seed):
    tube = tubes.random_tube(np.random.RandomState(seed))
    assert tubes.check_tube(tube) == []
    assert tube.length() >= tubes.RANDOM_LENGTH[0] - tubes.SEGMENT_LENGTH
    assert np.ptp(tube.centreline[:, 2]) > 1.0
    headings = np.unwrap(np.arctan2(*np.diff(tube.centreline[:, :2], axis=0).T[::-1]))
    assert np.ptp(headings) > 0.2


def test_the_wall_is_closed_round_the_centreline():
    """Rays from the centreline in every direction across it hit a stave between radius and wall radius."""
    tube = tubes.Tube(bend(30.0))
    xml, _ = compose_xml(tubes.tube_arena(tube))
    physics = AUV3DPhysics.from_xml_string(xml, source="tube")
    model, data = physics.model.ptr, physics.data.ptr
    mujoco.mj_forward(model, data)
    vehicle = model.body("auv").id
    for i in range(1, len(tube.centreline) - 1):
        centre = tube.centreline[i]
        t = tube.centreline[i + 1] - tube.centreline[i - 1]
        t /= np.linalg.norm(t)
        a = np.cross(t, [0.0, 0.0, 1.0])
        a /= np.linalg.norm(a)
        b = np.cross(t, a)
        for angle in np.linspace(0.0, 2 * math.pi, 72, endpoint=False):
            direction = math.cos(angle) * a + math.sin(angle) * b
            geom = np.zeros(1, dtype=np.int32)
            distance = mujoco.mj_ray(model, data, centre, direction, None, 1, vehicle, geom)
            assert tube.radius - 0.05 <= distance <= tube.wall_radius + 1e-6
            assert model.geom(int(geom[0])).name.startswith("wall_tube_")


@pytest.mark.parametrize("line, radius, problem", [
    (straight(), 0.5, "inner radius"),
    (bend(10.0), tubes.TUBE_RADIUS, "bend"),
    (straight(slope=math.radians(30.0)), tubes.TUBE_RADIUS, "climbs or dives"),
    (straight(depth=3.0), tubes.TUBE_RADIUS, "of water above"),
    (bend(25.0, angle=2.2 * math.pi), tubes.TUBE_RADIUS, "crosses itself"),
])
def test_check_tube_names_what_is_wrong(line, radius, problem):
    problems = tubes.check_tube(tubes.Tube(line, radius))
    assert any(problem in p for p in problems), problems


def test_a_good_tube_passes_and_a_vehicle_starts_inside_it():
    tube = tubes.Tube(bend(30.0))
    assert tubes.check_tube(tube) == []
    report = check_arena(tubes.tube_arena(tube))
    assert report.ok, report.problems
    assert "inner radius 3 m" in report.summary


def test_cli_writes_a_tube_from_an_xyz_centreline_and_check_arena_accepts_it(tmp_path):
    line = bend(30.0)
    csv = tmp_path / "tube.csv"
    csv.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.4f}" for v in p) for p in line) + "\n")
    out = tmp_path / "tube.xml"
    run = subprocess.run([sys.executable, "-m", "auv_mj.cli", "tunnel", "--tube", str(csv), "-o", str(out),
                          "--width", "5"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    arena = tubes.tube_from_arena(ET.parse(out).getroot())
    np.testing.assert_allclose(arena.centreline, line, atol=1e-4)
    assert arena.radius == 2.5
    check = subprocess.run([sys.executable, "-m", "auv_mj.cli", "check-arena", str(out), "--no-png"],
                           capture_output=True, text=True, timeout=120)
    assert check.returncode == 0 and "OK" in check.stdout, check.stdout + check.stderr
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,z\n0,0,-10\n4,0,-10\n6,3,-10\n")
    refused = subprocess.run([sys.executable, "-m", "auv_mj.cli", "tunnel", "--tube", str(bad), "-o",
                              str(tmp_path / "bad.xml")], capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "bend" in refused.stderr and not (tmp_path / "bad.xml").exists()
