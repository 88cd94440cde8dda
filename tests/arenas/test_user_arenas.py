"""A user's arena on every planning task (`arena=PATH`), and open-water arenas authored from shapes
(`auv_mj.arenas.layout`, `auv-mj arena`)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
import shapely

from auv_mj.arenas import arena, arena_check, layout
from auv_mj.cli import main
from auv_mj.tasks import suite

ROOT = Path(__file__).resolve().parents[2]
CORRIDOR = (ROOT / "docs" / "arenas.md").read_text().split("```xml\n", 1)[1].split("```", 1)[0]
"""The hand-written arena of docs/arenas.md: start (5, 0), goal (95, 0), path sites every 20-25 m, a mover."""
OPEN_WATER_TASKS = ("goal", "waypoints", "obstacles", "moving_obstacles")


@pytest.fixture
def corridor(tmp_path) -> Path:
    path = tmp_path / "corridor.xml"
    path.write_text(CORRIDOR)
    return path


@pytest.mark.parametrize("task", OPEN_WATER_TASKS)
def test_every_open_water_task_runs_on_a_users_arena(task, corridor):
    env = suite.load("auv", task, task_kwargs={"arena": str(corridor), "random": 0})
    env.reset()
    np.testing.assert_allclose(env.physics.pose(), [5.0, 0.0, 0.0], atol=1e-9)  # the start site, its heading
    goals = env.task.goals
    np.testing.assert_allclose(goals[-1], [95.0, 0.0])
    if task == "waypoints":  # the path sites after the start, in order, then the goal (path_4 is the goal)
        np.testing.assert_allclose(goals, [[25, 0], [50, 0], [75, 0], [95, 0]])
    else:
        assert len(goals) == 1
    model = env.physics.model.ptr
    before = env.physics.data.mocap_pos[model.body_mocapid[model.body("mover_diver").id]][:2].copy()
    for _ in range(20):  # 10 s: the diver (0.2 m/s from (80, -8) to (80, 8)) moves on every task
        step = env.step([0.0, 0.0])
    after = env.physics.data.mocap_pos[model.body_mocapid[model.body("mover_diver").id]][:2]
    np.testing.assert_allclose(after, before + [0.0, 0.2 * env.physics.time()], atol=0.05)
    assert np.all(np.isfinite(step.observation["observation"]))


@pytest.mark.parametrize("task", OPEN_WATER_TASKS)
def test_a_users_arena_is_checked_before_use_and_conflicts_are_named(task, corridor, tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text(CORRIDOR.replace('<site name="goal" pos="95 0 0"/>', ""))
    with pytest.raises(ValueError, match=r"broken.xml: not a usable arena: no <site name=\"goal\">"):
        suite.load("auv", task, task_kwargs={"arena": str(broken)})
    choice = "layout" if task == "waypoints" else "scenario"
    named = {"goal": "a1", "waypoints": "b1"}.get(task, "a")
    with pytest.raises(ValueError, match=f"and {choice}='{named}' conflict"):
        suite.load("auv", task, task_kwargs={"arena": str(corridor), choice: named})
    with pytest.raises(ValueError, match=f"{choice}='arena' is set by arena=PATH"):
        suite.load("auv", task, task_kwargs={choice: "arena"})


def test_a_users_arena_without_a_path_is_accepted_as_check_arena_no_path_accepts(tmp_path):
    text = CORRIDOR
    for k in range(5):
        text = "\n".join(line for line in text.splitlines() if f'name="path_{k}"' not in line)
    path = tmp_path / "no_path.xml"
    path.write_text(text)
    assert arena_check.check_arena(path, need_path=False).ok and not arena_check.check_arena(path).ok
    env = suite.load("auv", "waypoints", task_kwargs={"arena": str(path), "random": 0})
    env.reset()
    np.testing.assert_allclose(env.task.goals, [[95.0, 0.0]])  # no path sites: the goal alone



# --- open-water arenas from shapes: auv_mj.arenas.layout and `auv-mj arena` -------------------------------

BLOCKED = {
    "name": "blocked",
    "start": [20, 100],
    "goal": [220, 100],
    "bounds": [0, 0, 260, 200],
    "shapes": [
        {"type": "box", "name": "breakwater", "x": 120, "y": 100, "length": 6, "width": 60, "role": "wall"},
        {"type": "cylinder", "name": "buoy", "x": 60, "y": 160, "radius": 3},
        {"type": "polygon", "name": "reef", "points": [[160, 20], [200, 20], [200, 50], [180, 35], [160, 50]]},
        {"type": "mover", "name": "ferry", "waypoints": [[60, 20], [90, 20], [90, 40]], "speed": 0.5, "radius": 2},
    ],
}
"""A breakwater across the straight line from start to goal: line of sight alone runs into it."""
BLOCKED_CSV = """# the BLOCKED layout as CSV rows
start,20,100
goal,220,100
bounds,0,0,260,200
box,breakwater,120,100,6,60,0,wall
cylinder,buoy,60,160,3
polygon,reef,160,20,200,20,200,50,180,35,160,50
mover,ferry,0.5,2,60,20,90,20,90,40
"""


def test_a_csv_layout_reads_as_its_json_twin(tmp_path):
    json_path, csv_path = tmp_path / "blocked.json", tmp_path / "blocked.csv"
    json_path.write_text(json.dumps(BLOCKED))
    csv_path.write_text(BLOCKED_CSV)
    from_json = ET.tostring(layout.read_layout(json_path).element())
    assert ET.tostring(layout.read_layout(csv_path, name="blocked").element()) == from_json


def test_a_concave_polygon_keeps_its_notch_for_the_sonar_and_the_hull():
    """MuJoCo collides a mesh by its convex hull, so a concave reef is cut into convex pieces: a ray into the
    notch of the reef above travels to the notch's bottom (35 m at x = 180), not to the hull's top edge (50 m)."""
    reef = layout.make_shape(BLOCKED["shapes"][2], "reef")
    pieces = reef.pieces()
    assert len(pieces) > 1
    assert sum(shapely.Polygon(p).area for p in pieces) == pytest.approx(reef.outline().area)
    physics = arena.load(layout.make_layout(BLOCKED).element())
    model, data = physics.model.ptr, physics.data.ptr
    mujoco.mj_forward(model, data)
    geom = np.zeros(1, np.int32)
    for x, expected in ((180.0, 35.0), (165.0, 46.25), (190.0, 42.5)):  # the notch and its two slopes
        depth = mujoco.mj_ray(model, data, np.array([x, 100.0, 0.0]), np.array([0.0, -1.0, 0.0]), None, 1,
                              model.body("auv").id, geom)
        assert 100.0 - depth == pytest.approx(expected, abs=1e-6)
        assert model.geom(geom[0]).name.startswith("obstacle_reef")


def test_a_mover_goes_along_its_waypoints_and_back():
    mover = arena.Mover("mover_ferry", np.array([60.0, 20.0]), np.array([90.0, 40.0]), 0.5, np.array([[90.0, 20.0]]))
    # 50 m of path at 0.5 m/s: 100 s out, 100 s back
    for time, expected in ((0, (60, 20)), (30, (75, 20)), (80, (90, 30)), (100, (90, 40)), (140, (90, 20)),
                           (200, (60, 20)), (260, (90, 20))):
        np.testing.assert_allclose(mover.position(time), expected, atol=1e-9)


def test_the_arena_command_builds_a_checked_arena_and_its_preview(tmp_path, capsys):
    shapes = tmp_path / "blocked.json"
    shapes.write_text(json.dumps(BLOCKED))
    out = tmp_path / "blocked.xml"
    assert main(["arena", str(shapes), "-o", str(out)]) == 0
    assert out.is_file() and out.with_suffix(".png").is_file()
    assert "wrote" in capsys.readouterr().out
    assert arena_check.check_arena(out, need_path=False).ok
    info = arena.arena_info(arena.load(out))
    np.testing.assert_allclose(info.start, [20, 100])
    np.testing.assert_allclose(info.goal, [220, 100])
    np.testing.assert_allclose(info.start_heading, 0.0, atol=1e-9)  # facing the goal by default
    np.testing.assert_allclose(info.movers[0].waypoints, [[60, 20], [90, 20], [90, 40]])


@pytest.mark.parametrize(("change", "words"), [
    (lambda d: d.update(start=[120, 100]), "start (120, 100) lies inside shape 0 (wall_breakwater)"),
    (lambda d: d["shapes"][0].update(height=3), "a box has no field(s) height"),
    (lambda d: d["shapes"][1].update(radius=-1), "shape 1 (cylinder buoy): radius = '-1'"),
    (lambda d: d["shapes"][2].update(points=[[0, 0], [10, 10], [10, 0], [0, 10]]), "simple polygon"),
    (lambda d: d["shapes"][3].update(name="hull"), "reuses a name of the vehicle model"),
    (lambda d: d["shapes"][3].update(speed=20), "speed = '20' must be a finite number in [0, 10]"),
    (lambda d: d["shapes"][1].update(name="breakwater", role="wall"), "wall_breakwater is given twice"),
    (lambda d: d.update(goal=[500, 100]), "goal (500, 100) is outside the bounds"),
    (lambda d: d["shapes"][3].update(waypoints=[[20, 103], [40, 103]]),  # check-arena's own verdict
     "mover_ferry starts"),
])
def test_the_arena_command_refuses_a_bad_layout_in_one_line_and_writes_nothing(change, words, tmp_path, capsys):
    data = json.loads(json.dumps(BLOCKED))
    change(data)
    shapes = tmp_path / "bad.json"
    shapes.write_text(json.dumps(data))
    with pytest.raises(SystemExit) as refused:
        main(["arena", str(shapes), "-o", str(tmp_path / "bad.xml")])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and len(err.strip().splitlines()) == 1 and words in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]


def _eval(*args: str, cwd: Path) -> dict:
    out = cwd / "eval.json"
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "eval", *args, "--episodes", "1", "--no-progress",
                           "--json", str(out)], capture_output=True, text=True, timeout=300, cwd=cwd,
                          env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")})
    assert done.returncode == 0, done.stderr
    return json.loads(out.read_text())


def test_a_users_open_water_arena_runs_on_goal_and_obstacles_through_the_cli(tmp_path):
    """End to end: shapes -> `auv-mj arena` -> `auv-mj eval --arena`. On `goal`, line of sight alone (splane) meets
    the breakwater it does not know of; on `obstacles` the sonar-based los-avoid goes round it to the goal."""
    shapes = tmp_path / "blocked.csv"
    shapes.write_text(BLOCKED_CSV)
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "arena", str(shapes), "--no-preview"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    built = tmp_path / "blocked.xml"
    goal = _eval("--task", "goal", "--arena", str(built), "--policy", "splane", cwd=tmp_path)["tasks"]["goal"]
    assert goal["outcomes"]["collision"] == 1 and goal["min_clearance"] < 0.1  # it hit the breakwater
    obstacles = _eval("--task", "obstacles", "--task-kwargs", json.dumps({"arena": str(built)}),
                      "--policy", "los-avoid", cwd=tmp_path)["tasks"]["obstacles"]
    assert obstacles["outcomes"]["goal"] == 1 and obstacles["min_clearance"] > 0
    assert obstacles["path_length"] > 200.0  # longer than the straight 200 m: it went round


def test_the_docs_layouts_build_usable_arenas_and_the_csv_is_the_json(tmp_path):
    text = (ROOT / "docs" / "arenas.md").read_text()
    section = text.split("## Building an open-water arena", 1)[1]
    (tmp_path / "harbour.json").write_text(section.split("```json\n", 1)[1].split("```", 1)[0])
    (tmp_path / "harbour.csv").write_text(section.split("as CSV", 1)[1].split("```\n", 1)[1].split("```", 1)[0])
    built = layout.read_layout(tmp_path / "harbour.json").element()
    assert ET.tostring(layout.read_layout(tmp_path / "harbour.csv", name="harbour").element()) == ET.tostring(built)
    report = arena_check.check_arena(built)  # with its path: the path's clearance is checked too
    assert report.ok, report.lines()


def test_a_users_arena_passes_gymnasiums_checker(corridor):
    import gymnasium
    from gymnasium.utils.env_checker import check_env

    import auv_mj  # noqa: F401  (registers the ids)

    env = gymnasium.make("auv_mj/MovingObstacles-v0", task_kwargs={"arena": str(corridor), "time_limit": 5.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the unbounded Box's infinity warning
        check_env(env.unwrapped, skip_render_check=True)
    observation, _ = env.reset(seed=3)
    np.testing.assert_allclose(observation["achieved_goal"][:2], [5.0, 0.0])


def test_a_concave_polygon_has_its_exact_footprint():
    """A concave `polygon` is several convex meshes: their footprints (what the oracle, the clearance and the
    figures read) union to the polygon itself, by the shoelace formula and vertex for vertex."""
    from auv_mj.episode import geom_footprint

    layout_ = json.loads((ROOT / "models" / "arenas" / "traps" / "u_polygon.json").read_text())
    (shape,) = layout_["shapes"]
    corners = np.array(shape["points"], float)
    x, y = corners.T
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    env = suite.load("auv", "obstacles", task_kwargs={"arena": str(ROOT / "models/arenas/traps/u_polygon.xml")})
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    meshes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
    union = shapely.union_all([shapely.Polygon(geom_footprint(model, data, g)) for g in meshes])
    assert union.area == pytest.approx(area, rel=1e-6)
    assert union.symmetric_difference(shapely.Polygon(corners)).area < 1e-3
