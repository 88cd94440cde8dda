"""Tunnel arenas (`auv_mj.arenas.tunnels`) and the arena checker (`auv_mj.arenas.arena_check`)."""

from __future__ import annotations

import math
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
import shapely

from auv_mj import cli
from auv_mj.arenas import arena, arena_check, tunnels
from auv_mj.assets import model_path
from auv_mj.sim.vehicle import vehicle_facts

HULL_HALF_LENGTH = vehicle_facts().hull_half_length

AUV_MJ = Path(sys.executable).with_name("auv-mj")
STRAIGHT_WIDTH = 40.0


def _s_curve() -> np.ndarray:
    x = np.linspace(0.0, 300.0, 31)
    return np.column_stack([x, 40.0 * np.sin(x / 300.0 * 2 * np.pi)])


def _ellipse() -> np.ndarray:
    angle = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    return np.column_stack([100.0 * np.cos(angle), 60.0 * np.sin(angle)])


TUNNELS = {
    "straight": ([[0.0, 0.0], [200.0, 0.0]], {"width": STRAIGHT_WIDTH}),
    "s_curve": (_s_curve(), {"width": 30.0, "smooth": 2}),
    "closed": (_ellipse(), {"width": 30.0, "smooth": 2, "closed": True}),
}


def _physics_at(physics, x: float, y: float, yaw: float):
    physics.named.data.qpos[["x", "y", "yaw"]] = [x, y, yaw]
    physics.named.data.qvel[:] = 0.0
    physics.forward()
    return physics


@pytest.mark.parametrize("kind", sorted(TUNNELS))
def test_round_trip_build_save_load_check(kind, tmp_path):
    centreline, kwargs = TUNNELS[kind]
    element = tunnels.build_tunnel(centreline, **kwargs)
    path = tunnels.save(element, tmp_path / f"{kind}.xml")
    info = arena.arena_info(arena.load(path))
    report = arena_check.check_arena(path)
    assert report.ok, report.lines()
    path_points = info.path
    assert _escaping_rays(arena.load(path), path_points) == 0  # the walls close the tunnel all round
    steps = np.hypot(*np.diff(path_points, axis=0).T)
    assert steps.max() <= tunnels.PATH_SPACING + 1e-6
    np.testing.assert_allclose(info.start, path_points[0])
    np.testing.assert_allclose(info.goal, path_points[-1])
    xmin, ymin, xmax, ymax = info.bounds
    assert np.all((path_points >= [xmin, ymin]) & (path_points <= [xmax, ymax]))
    if kind == "closed":
        # the start is the first centreline point; the goal one spacing short of coming back
        assert np.hypot(*(info.start - centreline[0])) < 1.0
        assert 0 < np.hypot(*(info.goal - info.start)) <= tunnels.PATH_SPACING + 1e-6
        assert not any(name.startswith("wall_cap") for name in _geom_names(element))
    else:
        np.testing.assert_allclose(info.start, centreline[0], atol=1e-6)
        np.testing.assert_allclose(info.goal, centreline[-1], atol=1e-6)
        assert {"wall_cap_start", "wall_cap_goal"} <= set(_geom_names(element))
        first = np.asarray(centreline[1]) - np.asarray(centreline[0])
        assert info.start_heading == pytest.approx(math.atan2(first[1], first[0]), abs=1e-6)


def _escaping_rays(physics, origins: np.ndarray, count: int = 72) -> int:
    """How many of `count` horizontal rays from each origin hit nothing at all (mujoco.mj_ray)."""
    model, data = physics.model.ptr, physics.data.ptr
    geomid = np.zeros(1, np.int32)
    auv = model.body("auv").id
    missed = 0
    for x, y in origins:
        for angle in np.linspace(0.0, 2 * np.pi, count, endpoint=False):
            direction = np.array([math.cos(angle), math.sin(angle), 0.0])
            missed += mujoco.mj_ray(model, data, np.array([x, y, 0.0]), direction, None, 1, auv, geomid) < 0
    return missed


def _geom_names(element: ET.Element) -> list[str]:
    return [g.get("name") for g in element.find("worldbody").iter("geom")]


def test_straight_tunnel_is_four_boxes_even_from_many_collinear_points():
    x = np.linspace(0.0, 200.0, 41)
    element = tunnels.build_tunnel(np.column_stack([x, np.zeros_like(x)]), STRAIGHT_WIDTH)
    assert sorted(_geom_names(element)) == ["wall_cap_goal", "wall_cap_start", "wall_left_0", "wall_right_0"]


@pytest.mark.parametrize("offset", [0.0, 6.0, -9.0])
def test_sonar_across_straight_tunnel_reads_half_width_minus_offset(offset):
    physics = arena.load(tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH))
    ranges = _physics_at(physics, 100.0, offset, 0.0).sonar()
    half = STRAIGHT_WIDTH / 2
    assert ranges[0] == pytest.approx(half + offset, abs=1e-4)  # S1, starboard (-y)
    assert ranges[8] == pytest.approx(half - offset, abs=1e-4)  # S9, port (+y)
    nose = 100.0 + HULL_HALF_LENGTH
    assert ranges[4] == pytest.approx(200.0 + tunnels.END_CLEARANCE - nose, abs=1e-4)  # S5 ahead: the end cap


def test_sonar_sees_the_walls_of_a_curved_tunnel_at_half_width():
    physics = arena.load(tunnels.build_tunnel(_s_curve(), 30.0, smooth=2))
    path = arena.arena_info(physics).path
    for k in range(1, len(path) - 1):
        heading = path[k + 1] - path[k - 1]
        ranges = _physics_at(physics, *path[k], math.atan2(heading[1], heading[0])).sonar()
        assert ranges[[0, 8]] == pytest.approx([15.0, 15.0], abs=0.5), f"at path_{k}"


def test_vehicle_pushed_into_a_wall_stays_inside():
    physics = arena.load(tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH))
    _physics_at(physics, 100.0, 14.0, math.pi / 2)  # 6 m from the left wall, nose towards it
    physics.set_control([20.0, 0.0])  # full surge thrust
    highest = -np.inf
    for _ in range(1000):  # 10 s
        physics.step()
        highest = max(highest, physics.pose()[1])
    wall = STRAIGHT_WIDTH / 2
    assert highest > wall - HULL_HALF_LENGTH - 0.2  # it reached the wall ...
    assert highest < wall - HULL_HALF_LENGTH + 0.1  # ... and did not go through it
    assert physics.pose()[1] < wall


def test_obstacles_and_movers_follow_the_convention():
    element = tunnels.build_tunnel(
        [[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH,
        obstacles=[tunnels.Obstacle(100.0, 12.0, 20.0, 4.0, 30.0, "rock")],
        movers=[tunnels.MovingObstacle(150.0, 10.0, 150.0, -10.0, 0.5, 2.0, "diver")])
    physics = arena.load(element)
    info = arena.arena_info(physics)
    assert physics.model.geom("obstacle_rock").id >= 0
    (mover,) = info.movers
    assert mover.body == "mover_diver" and mover.speed == 0.5
    np.testing.assert_allclose(mover.position(20.0), [150.0, 0.0])
    assert arena_check.check_arena(element).ok


# --- malformed input ------------------------------------------------------------------------------


def _csv(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "centreline.csv"
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, width, expected", [
    ("x,y\n0,0\n100,zero\n", 30, r"centreline\.csv: row 3, column y: 'zero' is not a number"),
    ("x,y\n0,0\n", 30, r"centreline\.csv: an open tunnel needs at least 2 centreline points, got 1"),
    ("0,0\nnan,5\n100,0\n", 30, r"centreline\.csv: row 2, x = nan: not a finite number"),
    ("0,0\n100,0\n", 10, r"centreline\.csv: width 10 m is too narrow.* at least 11\.33 m wide"),
    ("0,0,30\n100,0,8\n", None, r"centreline\.csv: row 2: width 8 m is too narrow"),
    ("0,0\n100,0\n100,100\n50,-50\n", 20,
     r"centreline\.csv: the centreline crosses itself: the segment row 1 - row 2 crosses row 3 - row 4"),
    ("0,0\n100,0\n100,15\n0,15\n", 20,
     r"centreline\.csv: the left wall folds over itself near row 2 and row 3"),
    ("0,0\n200,0\n200,100\n100,100\n100,12\n", 20,
     r"centreline\.csv: the tunnel walls cross at \(110\.0, 10\.0\)"),
    ("0,0\n100,0\n0,10\n", 20, r"centreline\.csv: the centreline turns 174 deg at row 2"),
    ("0,0\n0,0\n100,0\n", 20, r"centreline\.csv: row 1 and row 2 are the same point"),
    ("0,0\n100,0\n", None, r"centreline\.csv: no tunnel width"),
])
def test_malformed_centreline_raises_a_clear_error(tmp_path, text, width, expected):
    with pytest.raises(ValueError, match=expected):
        tunnels.build_tunnel(tunnels.read_centreline(_csv(tmp_path, text)), width)


def test_obstacle_on_the_path_raises_naming_it():
    with pytest.raises(ValueError, match=r"obstacle_rock at \(50\.0, 3\.0\) is 2\.00 m from the global path"):
        tunnels.build_tunnel([[0, 0], [100, 0]], 40, obstacles=[tunnels.Obstacle(50, 3, 10, 2, name="rock")])


@pytest.mark.parametrize("option, parse, expected", [
    ("10,20,5", tunnels.Obstacle.parse, r"expected x,y,length,width"),
    ("10,20,5,-1", tunnels.Obstacle.parse, r"must be positive"),
    ("1,2,3,4,0.1,abc,name", tunnels.MovingObstacle.parse, r"'abc' is not a finite number"),
])
def test_malformed_options_raise(option, parse, expected):
    with pytest.raises(ValueError, match=expected):
        parse(option)


def test_json_centreline_forms(tmp_path):
    listed = tmp_path / "listed.json"
    listed.write_text("[[0, 0, 30], [100, 0, 20]]")
    line = tunnels.read_centreline(listed)
    np.testing.assert_allclose(line.widths, [30, 20])
    wrapped = tmp_path / "wrapped.json"
    wrapped.write_text('{"centreline": [[0, 0], [100, 0]], "width": 25}')
    element = tunnels.build_tunnel(tunnels.read_centreline(wrapped))
    left = next(g for g in element.iter("geom") if g.get("name") == "wall_left_0")
    assert float(left.get("pos").split()[1]) == pytest.approx(12.5 + tunnels.WALL_THICKNESS / 2)
    broken = tmp_path / "broken.json"
    broken.write_text('[[0, 0], [100, "x"]]')
    with pytest.raises(ValueError, match=r"broken\.json: point 1, y: 'x' is not a number"):
        tunnels.read_centreline(broken)


# --- check-arena ----------------------------------------------------------------------------------


def _straight(tmp_path: Path, edit=None) -> Path:
    element = tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH)
    if edit is not None:
        edit(element)
    return tunnels.save(element, tmp_path / "edited.xml")


def _site(element: ET.Element, name: str) -> ET.Element:
    return next(s for s in element.iter("site") if s.get("name") == name)


def test_check_arena_names_a_path_too_close_to_a_wall(tmp_path):
    path = _straight(tmp_path, lambda e: _site(e, "path_5").set("pos", "50 17 0"))  # 3 m from the wall
    report = arena_check.check_arena(path)
    assert not report.ok
    assert any("path_4 to path_6" in p and "wall_left_0" in p and "closer than d_s = 5 m" in p
               for p in report.problems), report.problems


def test_check_arena_names_a_missing_goal_and_a_path_through_a_wall(tmp_path):
    def edit(element):
        world = element.find("worldbody")
        world.remove(_site(element, "goal"))
        _site(element, "path_20").set("pos", "200 30 0")
    report = arena_check.check_arena(_straight(tmp_path, edit))
    assert 'no <site name="goal">' in report.problems
    assert any(p.startswith("segment path_19-path_20 runs through wall_left_0") for p in report.problems)


def test_check_arena_finds_crossing_walls_but_not_joins(tmp_path):
    def edit(element):
        world = element.find("worldbody")
        ET.SubElement(world, "geom", {"name": "wall_cross", "type": "box", "pos": "150 0 0",
                                      "size": "30 0.5 3", "euler": "0 0 1.2"})
    report = arena_check.check_arena(_straight(tmp_path, edit))
    crossings = [p for p in report.problems if p.startswith("walls ")]
    assert len(crossings) == 2, report.problems  # wall_cross through both side walls, not at an end
    assert all("wall_cross" in p and "intersects itself" in p for p in crossings)


def test_check_arena_reports_an_unparsable_file(tmp_path):
    path = tmp_path / "broken.xml"
    path.write_text('<mujoco><worldbody><geom name="wall" type="box" size="1"/></worldbody></mujoco>')
    report = arena_check.check_arena(path)
    assert not report.ok and str(path) in report.problems[0] and "MuJoCo" in report.problems[0]


def test_start_outside_bounds_is_a_problem(tmp_path):
    path = _straight(tmp_path, lambda e: e.find("custom/numeric").set("data", "10 -30 230 30"))
    assert "start (0.0, 0.0) is outside arena_bounds 10 -30 230 30" in arena_check.check_arena(path).problems


# --- the shipped Sec. 4.3 tunnel ------------------------------------------------------------------


def test_shipped_tunnel_inspection_matches_table_12_and_passes_the_check():
    path = model_path("arenas/tunnel_inspection.xml")
    report = arena_check.check_arena(path)
    assert report.ok, report.lines()
    physics = arena.load(path)
    info = arena.arena_info(physics)
    np.testing.assert_allclose(info.start, [670, 125])
    np.testing.assert_allclose(info.goal, [0, 150])
    model = physics.model.ptr
    known = model.geom("obstacle_known").id
    np.testing.assert_allclose(model.geom_pos[known][:2], [150, 140])
    np.testing.assert_allclose(model.geom_size[known][:2], [14, 3.25])
    (mover,) = info.movers
    assert mover.body == "mover_unknown" and mover.speed == pytest.approx(0.1)
    assert mover.end[0] < mover.start[0] and mover.end[1] == mover.start[1]  # moves left (-x)
    # it crosses the global path, ahead of the vehicle's start
    assert shapely.intersects(shapely.linestrings([mover.start, mover.end]), shapely.linestrings(info.path))


def test_shipped_tunnel_inspection_is_reproduced_by_its_command(tmp_path):
    path = model_path("arenas/tunnel_inspection.xml")
    root = ET.parse(path).getroot()
    command = shlex.split(root.find("custom/text[@name='tunnel_command']").get("data"))
    assert command[:2] == ["auv-mj", "tunnel"]
    rebuilt = tmp_path / "tunnel_inspection.xml"
    argv = command[1:]
    argv[argv.index("-o") + 1] = str(rebuilt)
    argv[1] = str(model_path("arenas/tunnel_inspection.csv"))
    assert cli.main(argv) == 0
    for tree in (root, rebuilt_root := ET.parse(rebuilt).getroot()):
        for text in tree.findall("custom/text"):
            tree.find("custom").remove(text)
    assert ET.tostring(rebuilt_root) == ET.tostring(root)


# --- command line ---------------------------------------------------------------------------------


def test_cli_tunnel_and_check_arena(tmp_path):
    csv_path = _csv(tmp_path, "x,y\n0,0\n150,0\n250,80\n")
    xml_path = tmp_path / "arena.xml"
    command = [str(AUV_MJ), "tunnel", str(csv_path), "--width", "30", "--smooth", "-o", str(xml_path),
               "--obstacle", "60,10,20,3,0,rock"]
    built = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert built.returncode == 0, built.stderr
    assert f"wrote {xml_path}" in built.stdout
    checked = subprocess.run([str(AUV_MJ), "check-arena", str(xml_path)], capture_output=True, text=True,
                             timeout=120)
    assert checked.returncode == 0, checked.stdout
    assert "\nOK\n" in checked.stdout
    png = xml_path.with_suffix(".png")
    assert f"wrote preview {png}" in checked.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_errors_exit_nonzero_naming_the_problem(tmp_path):
    bad = _csv(tmp_path, "x,y\n0,0\n100,zero\n")
    built = subprocess.run([str(AUV_MJ), "tunnel", str(bad), "--width", "30"], capture_output=True, text=True,
                           timeout=120)
    assert built.returncode == 2  # a usage error: one line, no file written
    assert "row 3, column y: 'zero' is not a number" in built.stderr and built.stderr.count("\n") == 1
    assert not bad.with_suffix(".xml").exists()
    no_goal = _straight(tmp_path, lambda e: e.find("worldbody").remove(_site(e, "goal")))
    checked = subprocess.run([str(AUV_MJ), "check-arena", str(no_goal), "--no-png"], capture_output=True,
                             text=True, timeout=120)
    assert checked.returncode == 1
    assert 'problem: no <site name="goal">' in checked.stdout


def test_the_minimal_arena_of_the_docs_passes_the_check(tmp_path):
    docs = (Path(__file__).parents[2] / "docs" / "arenas.md").read_text()
    example = docs.split("```xml\n", 1)[1].split("```", 1)[0]
    path = tmp_path / "corridor.xml"
    path.write_text(example)
    report = arena_check.check_arena(path)
    assert report.ok, report.lines()
    info = arena.arena_info(arena.load(path))
    assert len(info.path) == 5 and info.movers[0].body == "mover_diver"


# --- unknown obstacles ----------------------------------------------------------------------------


def test_unknown_obstacle_on_the_path_passes_the_check_when_it_leaves_a_way_past():
    rock = tunnels.Obstacle(100.0, -10.0, 10.0, 20.0, name="rock")  # y -20..0: a 20 m gap on the left
    element = tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH, unknown=[rock])
    assert "unknown_rock" in _geom_names(element)
    report = arena_check.check_arena(element)
    assert report.ok, report.lines()
    assert "1 unknown obstacle," in report.summary


def test_unknown_obstacle_closing_the_tunnel_is_refused_naming_it():
    gap = 2 * (tunnels.route_clearance() + tunnels.ROUTE_MARGIN)
    # from inside the right wall (y = -20) up to gap - 0.5 m short of the left wall (y = 20)
    closing = tunnels.Obstacle(100.0, -8.0, 10.0, 2 * (28.0 - gap + 0.5), name="rock")
    with pytest.raises(ValueError, match=rf"unknown_rock at \(100\.0, -8\.0\) closes the tunnel.* {gap:.2f} m"):
        tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH, unknown=[closing])
    element = tunnels.build_tunnel([[0.0, 0.0], [200.0, 0.0]], STRAIGHT_WIDTH)
    ET.SubElement(element.find("worldbody"), "geom", {"name": "unknown_rock", "type": "box", "pos": "100 -8 0",
                                                     "size": f"5 {closing.width / 2} 3"})
    report = arena_check.check_arena(element)
    assert any(p.startswith("unknown_rock at (100.0, -8.0) closes the way") for p in report.problems), report.lines()


def test_a_known_obstacle_behind_an_unknown_one_is_still_seen_by_the_path_check(tmp_path):
    def edit(element):
        world = element.find("worldbody")
        ET.SubElement(world, "geom", {"name": "unknown_rock", "type": "box", "pos": "100 0 0", "size": "2 5 3"})
        ET.SubElement(world, "geom", {"name": "obstacle_wreck", "type": "box", "pos": "110 0 0", "size": "2 2 3"})
    report = arena_check.check_arena(_straight(tmp_path, edit))
    assert any("runs through obstacle_wreck" in p for p in report.problems), report.problems
    assert not any("runs through unknown_rock" in p for p in report.problems)


def test_cli_unknown_option(tmp_path):
    csv_path = _csv(tmp_path, "x,y\n0,0\n200,0\n")
    xml_path = tmp_path / "arena.xml"
    built = subprocess.run([str(AUV_MJ), "tunnel", str(csv_path), "--width", "40", "-o", str(xml_path),
                            "--unknown", "100,-10,10,20,0,rock"], capture_output=True, text=True, timeout=120)
    assert built.returncode == 0, built.stderr
    assert "1 unknown obstacle," in built.stdout
    bad = subprocess.run([str(AUV_MJ), "tunnel", str(csv_path), "--width", "40", "-o", str(tmp_path / "bad.xml"),
                          "--unknown", "100,-10,10"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "--unknown '100,-10,10': expected x,y,length,width" in bad.stderr


# --- the validation tunnels -----------------------------------------------------------------------

VALIDATION = sorted((Path(__file__).parents[2] / "models" / "arenas" / "validation").glob("*.xml"))


def test_the_six_validation_tunnels_are_shipped():
    assert [p.stem for p in VALIDATION] == ["diagonal_crossing", "l_bend", "long_wave", "straight_drifter",
                                            "u_turn", "zigzag"]


@pytest.mark.parametrize("path", VALIDATION, ids=lambda p: p.stem)
def test_validation_tunnel_passes_the_check_and_is_reproduced_by_its_command(path, tmp_path):
    report = arena_check.check_arena(path)
    assert report.ok, report.lines()
    root = ET.parse(path).getroot()
    argv = shlex.split(root.find("custom/text[@name='tunnel_command']").get("data"))[1:]
    argv[argv.index("-o") + 1] = str(tmp_path / path.name)
    argv[1] = str(path.with_suffix(".csv"))
    assert cli.main(argv) == 0
    rebuilt = ET.parse(tmp_path / path.name).getroot()
    for tree in (root, rebuilt):
        for text in tree.findall("custom/text"):
            tree.find("custom").remove(text)
        ET.indent(tree)
    assert ET.tostring(rebuilt) == ET.tostring(root)
