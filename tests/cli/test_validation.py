"""Every input is validated where it enters: one regression test per class of malformed input of issue 19.

Arenas (the tunnel task refuses what `check-arena` refuses), task options, the vehicle MJCF contract and
divergence at load, checkpoint metadata, tunnel specs, actions on both faces, and bounded parsing. The
property-based fuzz suite over the same surfaces is `test_fuzz.py`.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import time
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch

import auv_mj  # noqa: F401  (registers the Gymnasium ids)
from auv_mj import AUVPhysics, inputs, model_path
from auv_mj import cli as auv_mj_cli
from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy import Policy
from auv_mj.agents.offpolicy import policy as policy_module
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.learners import load_agent, save_agent
from auv_mj.arenas import arena_check, tunnels
from auv_mj.cli.options import json_object
from auv_mj.figures.arenas import preview
from auv_mj.tasks import suite
from auv_mj.tasks.actions import ActionClipped

ROOT = Path(__file__).resolve().parents[2]
CORRIDOR = (ROOT / "docs" / "arenas.md").read_text().split("```xml\n", 1)[1].split("```", 1)[0]
"""The minimal hand-written arena of docs/arenas.md: usable, with a path, a mover and an obstacle."""


def one_line(error: BaseException | str) -> str:
    text = str(error)
    assert "\n" not in text.strip(), text
    return text


def cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """`auv-mj ARGS` in a subprocess with this checkout first on the path."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "auv_mj.cli", *args], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=ROOT)


# --- arenas: the tunnel task refuses what check-arena refuses ------------------------------------------------

ARENA_CASES = {
    "no goal site": ('<site name="goal" pos="95 0 0"/>', "", 'no <site name="goal">'),
    "no arena_bounds": ('<numeric name="arena_bounds" data="-10 -20 110 20"/>', "", 'no <numeric name="arena_bounds"'),
    "NaN arena_bounds": ('data="-10 -20 110 20"', 'data="nan -20 110 20"', "arena_bounds nan"),
    "three arena_bounds": ('data="-10 -20 110 20"', 'data="-10 -20 110"', "has 3 values"),
    "skipped path site": ('<site name="path_2" pos="50 0 0"/>', "", "skips path_2"),
    "mover numeric without body": ('<numeric name="mover_diver" data="80 -8 80 8 0.2"/>',
                                   '<numeric name="mover_diver" data="80 -8 80 8 0.2"/>'
                                   '<numeric name="mover_ghost" data="1 1 2 2 0.1"/>', "mover_ghost"),
    "mover body without numeric": ('<numeric name="mover_diver" data="80 -8 80 8 0.2"/>', "",
                                   "mover body mover_diver has no"),
    "NaN mover speed": ("80 -8 80 8 0.2", "80 -8 80 8 nan", "speed nan"),
    "negative mover speed": ("80 -8 80 8 0.2", "80 -8 80 8 -5", "speed -5"),
    "absurd mover speed": ("80 -8 80 8 0.2", "80 -8 80 8 1e300", "speed 1e+300"),
    "start outside the bounds": ('<site name="start" pos="5 0 0"', '<site name="start" pos="500 0 0"',
                                 "start (500.0, 0.0) is outside arena_bounds"),
    "path site inside a wall": ('<site name="path_2" pos="50 0 0"/>', '<site name="path_2" pos="50 15 0"/>',
                                "path_2 (50.0, 15.0) lies inside wall_north"),
    "NaN start orientation": ('euler="0 0 0"', 'euler="0 0 nan"', "orientation is not a finite angle"),
    "geom size 1e308": ('size="5 2 3"', 'size="1e308 2 3"', "obstacle_rock (size 1e+308"),
    "5000 nested bodies": ("<worldbody>", "<worldbody>" + "<body>" * 5000 + "</body>" * 5000, "nested deeper"),
    "wall off the sonar plane": ('name="wall_north" type="box" pos="50 15.5 0"', 'name="wall_north" type="box" '
                                 'pos="50 15.5 10"', "wall_north: pos z spans 7.00..13.00 m"),
    "transparent wall": ('size="56 0.5 3"/>\n    <geom name="wall_west"',
                         'size="56 0.5 3" rgba="1 1 1 0"/>\n    <geom name="wall_west"', "wall_south: rgba alpha is 0"),
    "mover body not mocap": ('<body name="mover_diver" mocap="true"', '<body name="mover_diver"',
                             'body mover_diver: named as a mover but not mocap="true"'),
}


def test_the_corridor_arena_is_usable_by_check_arena_and_the_tunnel_task(tmp_path):
    path = tmp_path / "corridor.xml"
    path.write_text(CORRIDOR)
    assert arena_check.check_arena(path).ok
    env = suite.load("auv", "tunnel", task_kwargs={"arena": str(path), "random": 0})
    env.reset()
    assert np.all(np.isfinite(env.step([0.0, 0.0]).observation["observation"]))


@pytest.mark.parametrize("case", sorted(ARENA_CASES))
def test_the_tunnel_task_refuses_what_check_arena_refuses(case, tmp_path):
    old, new, problem = ARENA_CASES[case]
    assert old in CORRIDOR
    path = tmp_path / "arena.xml"
    path.write_text(CORRIDOR.replace(old, new))
    report = preview(path, tmp_path / "arena.png")  # never crashes, even drawing
    assert not report.ok and any(problem in p for p in report.problems), report.lines()
    assert (tmp_path / "arena.png").is_file() or case == "5000 nested bodies"
    with pytest.raises(ValueError) as error:
        suite.load("auv", "tunnel", task_kwargs={"arena": str(path)})
    assert one_line(error.value).startswith(f"{path}: not a usable arena") and problem in str(error.value)


def test_arena_verdicts_are_cached_by_content(tmp_path, monkeypatch):
    path = tmp_path / "corridor.xml"
    path.write_text(CORRIDOR.replace('pos="60 9 0"', 'pos="60 9.25 0"'))  # content no other test checks
    calls = []
    original = arena_check.check_arena
    monkeypatch.setattr(arena_check, "check_arena", lambda *a, **k: calls.append(a) or original(*a, **k))
    for _ in range(3):
        suite.load("auv", "tunnel", task_kwargs={"arena": str(path)})
    assert len(calls) == 1
    path.write_text(CORRIDOR.replace('pos="60 9 0"', 'pos="60 9.5 0"'))  # new content, new check
    suite.load("auv", "tunnel", task_kwargs={"arena": str(path)})
    assert len(calls) == 2


# --- task options ---------------------------------------------------------------------------------------------

OPTION_CASES = [
    ("goal", {"goal_radius": math.nan}, "goal_radius must be a number in (0, 50] m"),
    ("goal", {"goal_radius": 1e308}, "goal_radius must be a number in (0, 50] m"),
    ("goal", {"goal_radius": -1}, "goal_radius must be a number in (0, 50] m"),
    ("goal", {"goal_radius": "abc"}, "goal_radius must be a number in (0, 50] m, got 'abc'"),
    ("goal", {"time_limit": -1}, "time_limit must be a number in (0, 100000] s"),
    ("path_line", {"time_limit": math.nan}, "time_limit must be a number in (0, 100000] s"),
    ("speed_heading", {"time_limit": math.inf}, "time_limit must be a number"),
    ("speed_heading", {"command": [1e308, 0]}, "command must be a pair ([0, 3.5"),
    ("speed_heading", {"command": [-0.5, 0]}, "command must be a pair"),
    ("speed_heading", {"command": [True, 0.1]}, "command must be a pair"),
    ("speed_heading", {"command": ["1.0", 0.1]}, "command must be a pair"),
    ("speed_heading", {"disturbances": ["paper"]}, "disturbances must be one of 'paper', 'random', 'none'"),
    ("goal", {"random": -3}, "random must be None, a numpy RandomState or a whole number"),
    ("obstacles", {"scenario": {}}, "scenario must be one of 'random', 'a', 'b'"),
    ("tunnel", {"arena": 5}, "arena must be an arena MJCF file path"),
    ("waypoints", {"executor": "warp"}, "executor 'warp': not one of"),
    ("waypoints", {"executor": 5}, "executor must be None or callable"),
    ("goal", {"environment_kwargs": {"n_sub_steps": 2}}, "environment_kwargs must be a dict of"),
    ("goal", {"colour": "red"}, "has no option 'colour'"),
]


@pytest.mark.parametrize(("task", "kwargs", "message"), OPTION_CASES)
def test_bad_task_options_are_refused_naming_the_option_and_range(task, kwargs, message):
    with pytest.raises(ValueError) as error:
        suite.load("auv", task, task_kwargs=kwargs)
    assert message in one_line(error.value)


def test_options_at_the_edges_of_their_ranges_are_accepted():
    env = suite.load("auv", "goal", task_kwargs={"goal_radius": 50, "time_limit": 1.0, "random": 2**32 - 1})
    assert env.task.goal_radius == 50.0 and env.reset().first()
    env = suite.load("auv", "speed_heading", task_kwargs={"command": np.array([0.0, -math.pi])})
    env.reset()
    assert np.all(np.isfinite(env.step([0.0, 0.0]).observation["observation"]))


def test_max_steps_below_one_is_a_usage_error(capsys):
    done = cli("eval", "--policy", "splane", "--task", "goal", "--episodes", "1", "--max-steps", "0")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "argument --max-steps: must be >= 1" in done.stderr and "Traceback" not in done.stderr
    for command in (["eval", "--policy", "splane"], ["render", "-o", "x.mp4"], ["plot", "trajectory", "-o", "x.png"]):
        with pytest.raises(SystemExit) as exit_:
            auv_mj_cli.main([*command, "--task", "goal", "--max-steps", "-5"])
        assert exit_.value.code == 2
        assert "argument --max-steps: must be >= 1, got -5" in capsys.readouterr().err


def test_bad_task_kwargs_value_is_a_one_line_usage_error():
    done = cli("eval", "--policy", "splane", "--task", "goal", "--episodes", "1",
               "--task-kwargs", '{"goal_radius": 1e308}')
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "goal_radius must be a number in (0, 50] m" in done.stderr


# --- the vehicle MJCF contract ----------------------------------------------------------------------------------

def _vehicle(tmp_path, change) -> Path:
    root = ET.parse(model_path("auv.xml")).getroot()
    text = change(root) or ET.tostring(root, encoding="unicode")
    path = tmp_path / "vehicle.xml"
    path.write_text(text)
    return path


def _remove(xpath):
    def change(root):
        for parent in root.iter():
            for child in list(parent):
                if child in root.findall(xpath):
                    parent.remove(child)
    return change


def _set(xpath, attribute, value):
    return lambda root: root.find(xpath).set(attribute, value)


def _extra_joint(root):
    ET.SubElement(root.find(".//body[@name='auv']"), "joint", name="pitch", type="hinge", axis="0 1 0")


VEHICLE_CASES = {
    "missing tau_r": (_remove("actuator/general[@name='tau_r']"), "actuators must be ['tau_u', 'tau_r']"),
    "missing sonar": (_remove("sensor/rangefinder[@name='sonar_4']"), 'no rangefinder <rangefinder name="sonar_4">'),
    "renamed sonar": (_set("sensor/rangefinder[@name='sonar_9']", "name", "sonar_10"), "sonar_9"),
    "yaw as a slide joint": (_set(".//joint[@name='yaw']", "type", "slide"), 'joint "yaw" must be a hinge joint'),
    "an extra joint": (_extra_joint, "joints ['pitch'] beyond x, y, yaw"),
    "x along z": (_set(".//joint[@name='x']", "axis", "0 0 1"), 'joint "x" must turn or slide about the world axis'),
    "zero timestep": (_set("option", "timestep", "0"), '<option timestep="0"> must be in'),
    "NaN ctrlrange": (_set("actuator/general[@name='tau_u']", "ctrlrange", "nan 20"), 'ctrlrange="nan 20"'),
    "world-frame thrust": (_set("actuator/general[@name='tau_u']", "gear", "2 0 0 0 0 0"),
                           "tau_u must apply a body-frame surge force"),
    "no hull": (_set(".//geom[@name='hull']", "name", "shell"), 'no hull geom <geom name="hull">'),
    "X_uu > 0": (_set("custom/numeric[@name='hydro_X_uu']", "data", "1.62"),
                 '<numeric name="hydro_X_uu"> = 1.62 must be <= 0'),
    "Y_vv 1e308": (_set("custom/numeric[@name='hydro_Y_vv']", "data", "1e308"), '<numeric name="hydro_Y_vv">'),
    "N_rr +94": (_set("custom/numeric[@name='hydro_N_rr']", "data", "94"), '<numeric name="hydro_N_rr"> = 94'),
    "5000 nested bodies": (lambda root: ET.tostring(root, encoding="unicode").replace(
        "<worldbody>", "<worldbody>" + "<body>" * 5000 + "</body>" * 5000), "nested deeper than"),
}


@pytest.mark.parametrize("case", sorted(VEHICLE_CASES))
def test_the_vehicle_contract_is_checked_at_load(case, tmp_path):
    change, message = VEHICLE_CASES[case]
    path = _vehicle(tmp_path, change)
    with pytest.raises(ValueError) as error:
        AUVPhysics.from_xml_path(path)
    assert one_line(error.value).startswith(str(path)) and message in str(error.value)


@pytest.mark.parametrize(("name", "value"), [("N_vv", "-900000"), ("Y_rr", "900000")])
def test_a_coefficient_that_makes_the_step_diverge_is_named(name, value, tmp_path):
    """Of the right sign and size alone, but coupling sway and yaw so strongly that the step blows up."""
    path = _vehicle(tmp_path, _set(f"custom/numeric[@name='hydro_{name}']", "data", value))
    with pytest.raises(ValueError, match="diverge right after load") as error:
        AUVPhysics.from_xml_path(path)
    suspects = one_line(error.value).split("suspicious numerics: ")[1]
    assert suspects.startswith(f"hydro_{name} = {float(value):g}")


def test_the_shipped_vehicle_and_its_settle_check_are_cheap():
    start = time.perf_counter()
    for _ in range(10):
        AUVPhysics.from_xml_path(model_path("auv.xml"))
    assert (time.perf_counter() - start) / 10 < 0.2


# --- checkpoints ----------------------------------------------------------------------------------------------

SPEC = {"act_dim": 2, "action_low": [-1.0, -1.0], "action_high": [1.0, 1.0], "kind": "box", "obs_dim": 4,
        "obs_shape": [4], "env_id": None}


@pytest.fixture(scope="module")
def small_checkpoint(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("checkpoint") / "small.pt"
    agent = DDPG(4, 2, DDPGConfig(hidden_sizes=(8, 8)))
    save_agent(path, agent, {"agent": "ddpg", "spec": SPEC, "replay_file": "replay.npz",
                                  "counters": {"env_steps": 0, "episodes": 0}})
    return path


def _mutated(path: Path, tmp_path: Path, change) -> Path:
    tensors, meta = read_checkpoint(path)
    change(tensors, meta)
    out = tmp_path / "mutated.pt"
    torch.save({"tensors": tensors, "metadata": meta}, out)
    return out


CHECKPOINT_CASES = {
    "obs_dim -1": (lambda t, m: m.update(obs_dim=-1), "obs_dim must be a whole number in [1, 10000]"),
    "obs_dim 10^12": (lambda t, m: m.update(obs_dim=10**12), "obs_dim must be a whole number"),
    "hidden_sizes 1e9": (lambda t, m: m["config"].update(hidden_sizes=[10**9, 10**9]), "hidden_sizes must be"),
    "missing config": (lambda t, m: m.pop("config"), "has no 'config'"),
    "unknown config field": (lambda t, m: m["config"].update(learning_rate=0.1),
                             "unknown DDPGConfig fields ['learning_rate']"),
    "NaN weights": (lambda t, m: t["actor.net.0.weight"].fill_(math.nan),
                    "tensor actor.net.0.weight holds NaN or infinite values"),
    "spec disagrees": (lambda t, m: m["spec"].update(action_low=[1.0, math.nan]), "spec action_low/action_high"),
    "replay file elsewhere": (lambda t, m: m.update(replay_file="../../etc/passwd"), "replay_file must be"),
    "hidden sizes unlike the tensors": (lambda t, m: m["config"].update(hidden_sizes=[8, 9]),
                                        "does not fit the architecture"),
}


@pytest.mark.parametrize("case", sorted(CHECKPOINT_CASES))
def test_checkpoint_metadata_is_checked_before_any_network_is_built(case, small_checkpoint, tmp_path, monkeypatch):
    change, message = CHECKPOINT_CASES[case]
    path = _mutated(small_checkpoint, tmp_path, change)

    def no_network(*args, **kwargs):
        raise AssertionError("a network was built before the metadata was checked")

    monkeypatch.setattr(policy_module, "Actor", no_network)
    for load in (Policy.load, load_agent):
        with pytest.raises(ValueError) as error:
            load(path)
        assert str(path) in one_line(error.value) and message in str(error.value)


@pytest.mark.parametrize(("garbage", "field"), [
    (lambda state: state["state"].update(state=1.5), "agent_rng.state"),
    (lambda state: state["state"].update(inc=2), "agent_rng.state"),  # PCG64's increment is odd
    (lambda state: state["state"].update(state=-5), "agent_rng.state"),
    (lambda state: state.update(extra=1), "agent_rng must be a dict"),
    (lambda state: state.update(bit_generator="MT19937"), "agent_rng.bit_generator"),
    (lambda state: state.update(has_uint32=True), "agent_rng.has_uint32"),
])
def test_a_checkpoint_whose_generator_state_is_garbage_is_refused_naming_agent_rng(garbage, field, small_checkpoint,
                                                                                    tmp_path):
    path = _mutated(small_checkpoint, tmp_path, lambda t, m: garbage(m["agent_rng"]))
    with pytest.raises(ValueError) as error:
        load_agent(path)
    assert str(path) in one_line(error.value) and field in str(error.value)


def test_the_small_checkpoint_itself_loads(small_checkpoint):
    action = Policy.load(small_checkpoint)(np.zeros(4))
    assert action.shape == (2,) and np.all(np.abs(action) <= 1.0)
    assert load_agent(small_checkpoint)[0].obs_dim == 4


# --- tunnel specs -----------------------------------------------------------------------------------------------

LINE = [[0.0, 0.0], [150.0, 0.0], [250.0, 80.0]]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"smooth": 100}, "smoothing rounds must be a whole number in [0, 8]"),
    ({"smooth": 2.5}, "smoothing rounds must be a whole number"),
    ({"path_spacing": 1e-9}, "path spacing = 1e-09 must be a finite number in [1, 1000]"),
    ({"width": 1e308}, "width = 1e+308 must be a finite number in [0, 1000]"),
    ({"width": math.nan}, "width = nan must be a finite number"),
    ({"obstacles": [tunnels.Obstacle(60, 5, 10, 3, name="a"), tunnels.Obstacle(100, -5, 10, 3, name="a")]},
     "obstacle_a is given twice"),
    ({"obstacles": [tunnels.Obstacle(6000, 5, 10, 3)]}, "obstacle_0 at (6000.0, 5.0) is outside the tunnel"),
    ({"movers": [tunnels.MovingObstacle(60, -100, 60, 10, 0.1, 2.0)]}, "track start (60.0, -100.0) is outside"),
])
def test_tunnel_specs_are_bounded_unique_and_inside(kwargs, message):
    kwargs = {"width": 30.0, **kwargs}
    with pytest.raises(ValueError) as error:
        tunnels.build_tunnel(LINE, **kwargs)
    assert message in one_line(error.value)


def test_obstacle_and_mover_fields_are_range_checked():
    with pytest.raises(ValueError, match="mover hull: name 'hull' reuses a name of the vehicle model"):
        tunnels.MovingObstacle(0, 0, 1, 1, speed=0.1, radius=1, name="hull")
    with pytest.raises(ValueError, match="merge tolerance must be above 0 m, got 0"):
        tunnels.build_tunnel(LINE, width=30.0, merge_tolerance=0.0)
    with pytest.raises(ValueError, match=r"speed 1e\+300 must be in \[0, 10\] m/s"):
        tunnels.MovingObstacle(0, 0, 1, 1, speed=1e300, radius=1)
    with pytest.raises(ValueError, match="name"):
        tunnels.Obstacle(0, 0, 10, 3, name="a b")
    with pytest.raises(ValueError, match="length"):
        tunnels.Obstacle(0, 0, 1e308, 3)


def test_centreline_files_are_read_within_bounds(tmp_path):
    extra = tmp_path / "extra.json"
    extra.write_text('{"centreline": [[0, 0], [150, 0]], "width": 30, "colour": "red"}')
    with pytest.raises(ValueError, match=r"extra.json: unknown keys \['colour'\]"):
        tunnels.read_centreline(extra)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(128, 256)) * 4)
    with pytest.raises(ValueError, match="binary.csv: the centreline is not UTF-8 text"):
        tunnels.read_centreline(binary)
    nul = tmp_path / "nul.csv"
    nul.write_bytes(b"x,y\n0,0\x00\n")
    with pytest.raises(ValueError, match="nul.csv: the centreline holds a NUL character"):
        tunnels.read_centreline(nul)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 30_000 + "]" * 30_000)
    with pytest.raises(ValueError, match="deep.json: JSON nested deeper than 32 levels"):
        tunnels.read_centreline(deep)


def test_the_tunnel_command_refuses_as_a_usage_error_and_writes_nothing(tmp_path, capsys):
    line = tmp_path / "line.csv"
    line.write_text("x,y\n0,0\n150,0\n250,80\n")
    out = tmp_path / "out.xml"
    cases = ((("--width", "30", "--smooth", "--smooth-iterations", "100"), "--smooth-iterations"),
             (("--width", "30", "--spacing", "1e-9"), "--spacing"),
             (("--width", "1e308"), "--width"),
             (("--width", "30", "--obstacle", "60,5,10,3,0,a", "--obstacle", "100,-5,10,3,0,a"),
              "obstacle_a is given twice"))
    for args, message in cases[1:3]:  # the command as a user runs it
        done = cli("tunnel", str(line), "-o", str(out), *args)
        assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
        assert "Traceback" not in done.stderr and not out.exists()
    for args, message in cases:  # and in this process, for speed
        with pytest.raises(SystemExit) as exit_:
            auv_mj_cli.main(["tunnel", str(line), "-o", str(out), *args])
        err = capsys.readouterr().err
        assert exit_.value.code == 2 and err.count("\n") == 1 and message in err, err
        assert not out.exists()


# --- actions on the Gymnasium face ------------------------------------------------------------------------------

def test_gym_actions_follow_the_one_convention():
    env = gymnasium.make("auv_mj/Goal-v0").unwrapped
    env.reset(seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.step([1e308, 1e308])
    assert any(issubclass(w.category, ActionClipped) for w in caught)
    assert env.task.last_info["command"][0] == pytest.approx(2.0)  # clipped to a0 = 1: V = 2 m/s
    for bad in (["1.0", "0.0"], np.array(["1", "0"]), "1,0", [math.nan, 0.0], [0.0], None):
        with pytest.raises(ValueError, match="Goal: an action must"):
            env.step(bad)


def test_deep_task_kwargs_are_refused_without_recursion():
    with pytest.raises(Exception, match="nested deeper than 32 levels"):
        json_object("[" * 30_000 + "]" * 30_000)
    assert inputs.json_depth('{"a": "[[[\\"[[["}') == 1  # brackets inside strings (escaped quotes too)


def test_bounded_xml_refuses_deep_and_huge_input():
    with pytest.raises(ValueError, match="src: MJCF nested deeper than 64"):
        inputs.parse_xml("<a>" * 100 + "</a>" * 100, "src")
    with pytest.raises(ValueError, match="more than 100000 elements"):
        inputs.parse_xml("<a>" + "<b/>" * 100_001 + "</a>", "src")
    with pytest.raises(ValueError, match="src: not well-formed XML"):
        inputs.parse_xml("<a>", "src")
    assert re.fullmatch(r"mujoco", inputs.parse_xml(CORRIDOR, "corridor").tag)


@pytest.mark.parametrize(("insert", "message"), [
    ('<body name="door" pos="50 0 0"><joint name="hinge" type="hinge"/><geom size="1"/></body>',
     "<joint> may not appear in an arena's <worldbody>: moving obstacles are mocap bodies"),
    ('<replicate count="1000000"><geom size="1"/></replicate>', "<replicate> may not appear"),
])
def test_arenas_hold_only_what_the_convention_reads(insert, message, tmp_path):
    path = tmp_path / "arena.xml"
    path.write_text(CORRIDOR.replace("<worldbody>", "<worldbody>" + insert))
    with pytest.raises(ValueError) as error:
        suite.load("auv", "tunnel", task_kwargs={"arena": str(path)})
    assert str(path) in one_line(error.value) and message in str(error.value)


@pytest.mark.parametrize(("asset", "message"), [
    ('<mesh name="m" file="/etc/passwd"/>', "an arena may not read other files"),
    ('<texture name="t" type="2d" builtin="checker" width="100000" height="100000"/>',
     '<texture width="100000"> must be a whole number up to 4096'),
    ('<hfield name="h" nrow="100000" ncol="100000" size="1 1 1 1"/>', "<hfield nrow="),
])
def test_arena_assets_cannot_read_files_or_allocate_without_bound(asset, message, tmp_path):
    path = tmp_path / "arena.xml"
    path.write_text(CORRIDOR.replace("<worldbody>", f"<asset>{asset}</asset><worldbody>"))
    report = arena_check.check_arena(path)
    assert not report.ok and message in report.problems[0]


def test_a_checkpoint_of_another_task_is_refused_before_the_episode(capsys):
    from auv_mj.zoo import registry as policies

    executor = policies.shipped_checkpoint("executor")
    with pytest.raises(ValueError, match="executor.pt does not fit this task: observation of size 21, the "
                                         "policy expects 9"):
        policies.env_and_policy(str(executor), "goal", 0)


def test_a_file_that_is_not_an_episode_record_is_named(tmp_path):
    from auv_mj.episode import EpisodeRecord

    for name, content in (("garbage.npz", b"not a zip"), ("empty.npz", b"")):
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(ValueError, match=f"{name}: not an episode record"):
            EpisodeRecord.load(path)
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="other.npz: not an episode record .*KeyError"):
        EpisodeRecord.load(tmp_path / "other.npz")
