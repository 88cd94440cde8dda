"""User tubes of any width (`auv_mj.arenas.tubes`): a closed wall from 4 to 100 m across, checked from the written
MJCF's own capsules; rocks and movers that fit or are refused by name; a tube from a CSV through `auv-mj tunnel`,
`auv-mj check-arena` and `auv-mj eval --task tunnel3d --arena` to its end."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from auv_mj.arenas import tubes
from auv_mj.tasks import auv3d


def bending(diameter: float, spacing: float = 6.0) -> np.ndarray:
    """A centreline that turns through 100 deg on a radius of 2.5 diameters (at least 30 m) while it climbs."""
    radius = max(30.0, 2.5 * diameter)
    angle = math.radians(100.0)
    t = np.linspace(0.0, angle, max(4, int(radius * angle / spacing)))
    depth = 0.75 * diameter + 15.0 + 0.1 * radius * angle
    return np.column_stack([radius * np.sin(t), radius * (1 - np.cos(t)), -depth + 0.1 * radius * t])


def capsules(root: ET.Element) -> tuple[dict[tuple[int, int], np.ndarray], float]:
    """{(segment, stave): (2, 3) end points} of the wall geoms of a tube arena, and their radius."""
    ends, radii = {}, set()
    for geom in root.iter("geom"):
        name = geom.get("name") or ""
        if name.startswith("wall_"):
            segment, stave = (int(v) for v in name.split("_")[-2:])
            ends[segment, stave] = np.array([float(v) for v in geom.get("fromto").split()]).reshape(2, 3)
            radii.add(float(geom.get("size")))
    assert len(radii) == 1
    return ends, radii.pop()


def point_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of `points` (N, 3) from the segment a-b."""
    t = np.clip((points - a) @ (b - a) / max((b - a) @ (b - a), 1e-12), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1)


def polyline_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distances of `points` (N, 3) from the polyline `line` (K, 3)."""
    return np.min([point_segment(points, line[j], line[j + 1]) for j in range(len(line) - 1)], axis=0)


@pytest.mark.parametrize("diameter", [4.0, 8.0, 30.0, 100.0])
def test_the_wall_of_a_bending_tube_is_closed_at_any_width(diameter):
    """Along every stave, the neighbouring stave's surface overlaps it (the largest gap between the two capsules'
    surfaces is negative), and no stave comes inside the free radius."""
    line = bending(diameter)
    tube = tubes.Tube(line, diameter / 2)
    assert tubes.check_tube(tube) == []
    ends, radius = capsules(tubes.tube_arena(tube))
    segments = max(i for i, _ in ends) + 1
    staves = max(k for _, k in ends) + 1
    assert segments == len(line) - 1 and len(ends) == segments * staves
    s = np.linspace(0.0, 1.0, 21)[:, None]
    largest_gap, nearest = -math.inf, math.inf
    for i in range(segments):
        along = [ends[i, k][0] + s * (ends[i, k][1] - ends[i, k][0]) for k in range(staves)]
        for k in range(staves):
            na, nb = ends[i, (k + 1) % staves]
            largest_gap = max(largest_gap, float(np.max(point_segment(along[k], na, nb))) - 2 * radius)
        nearest = min(nearest, float(np.min(polyline_distance(np.concatenate(along), line))) - radius)
    assert largest_gap < -0.2 * radius  # overlapping, with a wall left where two staves meet
    assert nearest >= diameter / 2 - 1e-4  # the MJCF holds 8 significant digits


def test_a_ring_too_sparse_for_its_tube_and_a_bend_too_tight_for_its_width_are_refused():
    line = bending(8.0)
    assert any("the wall has gaps" in p for p in tubes.check_tube(tubes.Tube(line, 4.0, staves=10)))
    wide = tubes.Tube(bending(8.0), 50.0)  # 100 m across round a 30 m bend
    assert any("folds on the inside of the bend" in p for p in tubes.check_tube(wide))


def test_rocks_and_movers_that_do_not_fit_are_refused_by_name():
    tube = tubes.Tube(bending(8.0), 4.0)
    middle = tube.centreline[len(tube.centreline) // 2]
    fits = tubes.TubeObstacle(*(middle + [0.0, 0.0, -2.5]), 1.5, "rock")
    tubes.check_items(tube, [fits], [])
    cases = [
        ([tubes.TubeObstacle(*(middle + [0.0, 0.0, -6.0]), 1.0, "out")], [], "obstacle out .* outside the tube"),
        ([tubes.TubeObstacle(*middle, 3.5, "big")], [], "obstacle big .* blocks the tube"),
        ([tubes.TubeObstacle(*tube.centreline[1], 1.0, "early")], [], "early .* from the tube's start"),
        ([], [tubes.TubeMover(tuple(middle), tuple(middle + [0.0, 0.0, -9.0]), 0.5, 0.5, "diver")],
         "mover diver .* outside the tube.* along its track"),
        ([fits, fits], [], "obstacle_rock is named twice"),
    ]
    for obstacles, movers, message in cases:
        with pytest.raises(ValueError, match=message):
            tubes.check_items(tube, obstacles, movers)
    for text, message in (("1,2,3", "expected x,y,z,radius"), ("1,2,3,nan", "radius"), ("1,2,3,4,a b", "name")):
        with pytest.raises(ValueError, match=message):
            tubes.TubeObstacle.parse(text)
    with pytest.raises(ValueError, match="speed"):
        tubes.TubeMover.parse("0,0,-10,5,0,-10,99,1")


def test_a_tube_json_with_a_rock_and_a_mover_runs_and_the_mover_moves(tmp_path):
    line = bending(8.0, spacing=3.0)
    middle, later = line[len(line) // 2], line[len(line) // 2 + 2]
    spec = {"centreline": line.tolist(), "width": 8,
            "obstacles": [{"x": middle[0], "y": middle[1], "z": middle[2] - 2.5, "radius": 1.0, "name": "rock"}],
            "movers": [{"start": (later + [0, 0, 2.0]).tolist(), "end": (later - [0, 0, 2.0]).tolist(),
                        "speed": 0.5, "radius": 0.5, "name": "fish"}]}
    path = tmp_path / "tube.json"
    path.write_text(json.dumps(spec))
    read = tubes.read_tube(path)
    assert read.width == 8 and [o.name for o in read.obstacles] == ["rock"] and read.movers[0].speed == 0.5
    arena = tmp_path / "tube.xml"
    tree = tubes.tube_arena(tubes.Tube(read.centreline, 4.0), obstacles=list(read.obstacles),
                            movers=list(read.movers))
    ET.ElementTree(tree).write(arena)
    env = auv3d.tunnel3d(random=0, arena=str(arena))
    env.reset()
    for _ in range(4):
        env.step(np.zeros(3))
    body = env.physics.model.ptr.body("mover_fish").id
    expected = read.movers[0].position(env.physics.time())
    # moved at each executor tick: at most one tick behind
    np.testing.assert_allclose(env.physics.data.ptr.xpos[body], expected, atol=0.5 * auv3d.EXECUTOR_DT + 1e-9)
    assert np.linalg.norm(expected - read.movers[0].start) > 0.5  # it has moved
    path.write_text(json.dumps({**spec, "colour": "red"}))
    with pytest.raises(ValueError, match="unknown key 'colour'"):
        tubes.read_tube(path)


def test_tunnel3d_refuses_what_is_not_a_usable_tube(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        auv3d.tunnel3d(arena=str(tmp_path / "none.xml"))
    planar = tmp_path / "planar.xml"
    planar.write_text('<mujoco model="p"><worldbody><geom name="wall" type="box" size="1 1 1"/></worldbody></mujoco>')
    with pytest.raises(ValueError, match="not a tube arena"):
        auv3d.tunnel3d(arena=str(planar))
    broken = tubes.tube_arena(tubes.Tube(bending(8.0), 4.0))
    world = broken.find("worldbody")
    world.remove(next(g for g in world if (g.get("name") or "").startswith("wall_")))
    ET.ElementTree(broken).write(tmp_path / "broken.xml")
    with pytest.raises(ValueError, match="not a usable arena: .*wall staves"):
        auv3d.tunnel3d(arena=str(tmp_path / "broken.xml"))
    leaky = tubes.tube_arena(tubes.Tube(bending(8.0), 4.0))  # as many staves, one pulled out of the ring
    stave = next(g for g in leaky.iter("geom") if g.get("name") == "wall_tube_3_5")
    ends = np.array([float(v) for v in stave.get("fromto").split()]).reshape(2, 3)
    stave.set("fromto", " ".join(f"{v:.8g}" for v in (ends + [0.0, 0.0, -3.0]).ravel()))
    ET.ElementTree(leaky).write(tmp_path / "leaky.xml")
    with pytest.raises(ValueError, match="not a usable arena: .*the wall has a gap: a ray from the middle of "
                                         "segment 3"):
        auv3d.tunnel3d(arena=str(tmp_path / "leaky.xml"))


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "auv_mj.cli", *args], capture_output=True, text=True, timeout=300)


def test_a_tube_from_a_csv_through_check_arena_and_eval_to_its_end(tmp_path):
    """A 30 m tube, smoothed, from an x,y,z CSV: built, checked (with its preview), and flown to its end by the
    mapping planner (`map-replan`: its voxel map of the 3-D fan, a pitch-limited search, line of sight)."""
    corners = np.array([[0.0, 0.0, -40.0], [40.0, 0.0, -40.0], [80.0, 15.0, -37.0], [120.0, 15.0, -36.0]])
    csv = tmp_path / "my_xyz.csv"
    csv.write_text("x,y,z\n" + "\n".join(",".join(f"{v:g}" for v in p) for p in corners) + "\n")
    tube = tmp_path / "my_tube.xml"
    built = run_cli("tunnel", "--tube", str(csv), "--width", "30", "--smooth", "-o", str(tube))
    assert built.returncode == 0, built.stderr
    checked = run_cli("check-arena", str(tube))
    assert checked.returncode == 0 and checked.stdout.strip().endswith(f"wrote preview {tube.with_suffix('.png')}")
    assert tube.with_suffix(".png").stat().st_size > 20_000
    out = tmp_path / "eval.json"
    flown = run_cli("eval", "--task", "tunnel3d", "--arena", str(tube), "--policy", "map-replan", "--episodes", "1",
                    "--json", str(out))
    assert flown.returncode == 0, flown.stderr
    result = json.loads(out.read_text())["tasks"]["tunnel3d"]
    assert result["outcomes"] == {"goal": 1, "collision": 0, "left_map": 0, "timeout": 0}
    length = float(np.sum(np.linalg.norm(np.diff(corners, axis=0), axis=1)))
    assert result["path_length"] > length - 2 * auv3d.GOAL_RADIUS
    outside = run_cli("tunnel", "--tube", str(csv), "--width", "30", "--smooth", "-o", str(tmp_path / "rock.xml"),
                      "--obstacle", "60,40,-40,3,boulder")
    assert outside.returncode == 2 and "obstacle boulder at (60, 40, -40) is outside the tube" in outside.stderr
    csv.write_text("x,y,z\n0,0,-40\n40,0,-40\n20,35,-40\n")  # a 120 deg corner
    sharp = run_cli("tunnel", "--tube", str(csv), "--width", "30", "-o", str(tmp_path / "sharp.xml"))
    assert sharp.returncode == 2 and "bend at point 1" in sharp.stderr and not (tmp_path / "sharp.xml").exists()
