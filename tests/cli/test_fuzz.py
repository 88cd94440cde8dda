"""Property-based fuzzing of every input surface (Hypothesis): arenas, task options, vehicle MJCF, checkpoint
metadata, tunnel specs and the tunnel command, actions on both faces, and `--task-kwargs`.

One property everywhere: an input is either accepted and then runs sanely (finite observations, a usable
arena, a loadable policy), or refused with a one-line error naming the file, field or option (a ValueError in
Python, a usage error with exit status 2 on the command line) and no output file. Never a traceback, a hang
past its deadline or another exception. The examples per surface come from the profile in `conftest.py`
("fast" by default; `HYPOTHESIS_PROFILE=long` for a long run).
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import signal
import tempfile
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch
from hypothesis import event, given, settings
from hypothesis import strategies as st

from auv_mj import AUVPhysics, model_path
from auv_mj import cli as auv_mj_cli
from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy import Policy
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.learners import load_agent, save_agent
from auv_mj.arenas import arena_check
from auv_mj.figures import arenas
from auv_mj.tasks import suite
from auv_mj.tasks.gym_adapter import GYM_IDS, MIX_ID, AUVGymEnv

ROOT = Path(__file__).resolve().parents[2]
CORRIDOR = (ROOT / "docs" / "arenas.md").read_text().split("```xml\n", 1)[1].split("```", 1)[0]
VEHICLE = model_path("auv.xml").read_text()
EXAMPLES = settings.default.max_examples
"""Examples per surface in the loaded profile; a surface may scale it by its cost."""
DEADLINE = 60.0
"""Seconds one example may take before it counts as a hang."""


class Hang(BaseException):
    """An example ran past DEADLINE (a BaseException, so that no `except Exception` swallows it)."""


@contextlib.contextmanager
def deadline(seconds: float = DEADLINE):
    """Raises Hang in the body after `seconds` (SIGALRM; the tests run in the main thread)."""

    def expire(signum, frame):
        raise Hang(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def refusal(error: BaseException, *names: str) -> None:
    """A refusal is a one-line ValueError that names one of `names` (a file, a field, an option)."""
    assert isinstance(error, ValueError), f"{type(error).__name__}: {error}"
    event("refused")
    text = str(error)
    assert text and "\n" not in text.strip(), text
    assert any(name in text for name in names), f"names none of {names}: {text}"


# --- value pools ------------------------------------------------------------------------------------------------

NUMBER_TEXT = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e308", "-1e308", "1e300", "0", "-0", "-1", "1", "2", "10", "0.5",
                     "1e-300", "5e-324", "100000", "1e6", "", "abc", "1 2", "1 2 3", "1 2 3 4 5", "0x10", "1,2"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**6, 10**6).map(str))
"""Attribute values: numbers plain and absurd, words and lists of the wrong length."""
VECTOR_TEXT = st.lists(NUMBER_TEXT, min_size=0, max_size=6).map(" ".join)
ANY_VALUE = st.one_of(
    st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12), st.sampled_from(["paper", "suite", "random", "none", "a", "b", "a1", "b1", "c", "integral"]),
    st.lists(st.floats(allow_nan=True, allow_infinity=True) | st.integers(-5, 5) | st.booleans() | st.text(max_size=3),
             max_size=3),
    st.dictionaries(st.text(max_size=8), st.integers() | st.booleans(), max_size=2))
"""Python values of every kind a caller could pass as an option."""


# --- arenas -------------------------------------------------------------------------------------------------------

ARENA_ATTRIBUTES = ("pos", "size", "euler", "data", "name", "type", "mocap", "rgba", "quat", "fromto", "zaxis")


def _moved(draw, text: str, spread: float) -> str:
    """A list of numbers each moved by up to +-spread (relative for sizes and speeds)."""
    values = [float(v) for v in text.split()]
    return " ".join(repr(v + draw(st.floats(-spread, spread)) * max(1.0, abs(v) * 0.2)) for v in values)


@st.composite
def arena_texts(draw) -> str:
    """The corridor arena of docs/arenas.md with random edits: half the time small moves of what is there
    (positions, sizes, mover paths and speeds), else anything (attributes, deletions, copies, additions)."""
    root = ET.fromstring(CORRIDOR)
    if draw(st.booleans()):
        for _ in range(draw(st.integers(1, 3))):
            candidates = [e for e in root.iter() if e.get("pos") or e.get("size") or e.tag == "numeric"]
            element = draw(st.sampled_from(candidates))
            attribute = draw(st.sampled_from([a for a in ("pos", "size", "data") if element.get(a)]))
            element.set(attribute, _moved(draw, element.get(attribute), 3.0))
        return ET.tostring(root, encoding="unicode")
    for _ in range(draw(st.integers(1, 4))):
        elements = list(root.iter())
        kind = draw(st.sampled_from(["set", "set", "delete", "copy", "nest", "add"]))
        target = draw(st.sampled_from(elements))
        if kind == "set":
            value = draw(st.one_of(NUMBER_TEXT, VECTOR_TEXT, st.text(max_size=8)))
            target.set(draw(st.sampled_from(ARENA_ATTRIBUTES)), value)
        elif kind == "delete" and target is not root:
            parent = next(e for e in root.iter() if target in list(e))
            parent.remove(target)
        elif kind == "copy" and target is not root:
            parent = next(e for e in root.iter() if target in list(e))
            parent.append(copy.deepcopy(target))
        elif kind == "nest":
            holder = root.find("worldbody")
            if holder is not None:
                for _ in range(draw(st.integers(1, 90))):
                    holder = ET.SubElement(holder, "body")
                ET.SubElement(holder, "geom", size="1", pos=draw(VECTOR_TEXT))
        elif kind == "add":
            section = root.find(draw(st.sampled_from(["worldbody", "custom"])))
            if section is not None and section.tag == "custom":
                name = draw(st.sampled_from(["arena_bounds", "mover_diver", "mover_x", "hydro_X_uu", "other"]))
                ET.SubElement(section, "numeric", name=name, data=draw(VECTOR_TEXT))
            elif section is not None:
                name = draw(st.sampled_from(["start", "goal", "path_5", "path_9", "obstacle_new", "wall_new",
                                             "mover_new", "hull", "x"]))
                tag = "body" if name == "mover_new" else draw(st.sampled_from(["site", "geom"]))
                element = ET.SubElement(section, tag, name=name, pos=draw(VECTOR_TEXT))
                if tag == "body":
                    element.set("mocap", "true")
                    ET.SubElement(element, "geom", name="obstacle_on_mover", size="1 3", type="cylinder")
                elif tag == "geom":
                    element.set("size", draw(VECTOR_TEXT))
    text = ET.tostring(root, encoding="unicode")
    if draw(st.integers(0, 9)) == 0:  # now and then, damage the text itself
        cut = draw(st.integers(0, len(text)))
        text = text[:cut] + draw(st.text(max_size=5)) + text[cut + draw(st.integers(0, 20)):]
    return text


@given(text=arena_texts(), preview=st.booleans())
@settings(max_examples=2 * EXAMPLES)
def test_fuzz_arenas_are_refused_by_the_tunnel_task_or_run(text, preview):
    with tempfile.TemporaryDirectory() as folder, deadline():
        path = Path(folder) / "arena.xml"
        path.write_text(text)
        report = (arenas.preview(path, Path(folder) / "arena.png") if preview
                  else arena_check.check_arena(path))
        try:
            env = suite.load("auv", "tunnel", task_kwargs={"arena": str(path), "random": 0})
        except ValueError as error:
            refusal(error, str(path))
            assert not report.ok
            return
        assert report.ok, report.lines()  # the task runs exactly what check-arena accepts
        event("accepted")
        step = env.reset()
        for _ in range(4):
            step = env.step(np.zeros(2))
            assert np.all(np.isfinite(step.observation["observation"])) and np.isfinite(step.reward)


# --- task options -------------------------------------------------------------------------------------------------

OPTIONS = ("goal_radius", "time_limit", "reward", "scenario", "layout", "command", "disturbances", "observation",
           "random", "executor", "environment_kwargs", "arena", "colour")
PLANNING_OPTIONS = ("goal_radius", "time_limit", "reward", "random", "executor", "environment_kwargs", "observation",
                    "conditions")
TASK_OPTIONS = {"goal": PLANNING_OPTIONS + ("scenario",), "waypoints": PLANNING_OPTIONS + ("layout",),
                "obstacles": PLANNING_OPTIONS + ("scenario",), "moving_obstacles": PLANNING_OPTIONS + ("scenario",),
                "tunnel": PLANNING_OPTIONS + ("arena", "arena", "arena_spec"), "path_line": PLANNING_OPTIONS,
                "path_curve": PLANNING_OPTIONS,
                "speed_heading": ("time_limit", "reward", "random", "command", "disturbances", "observation",
                                  "environment_kwargs", "conditions")}
"""The options each task takes (the others are refused by name)."""
PLAUSIBLE_OPTIONS = {
    "goal_radius": st.floats(0.1, 60.0), "time_limit": st.floats(0.5, 30.0),
    "reward": st.sampled_from(["suite", "paper", "progress"]), "random": st.integers(0, 2**32), "executor": st.none(),
    "environment_kwargs": st.just({"legacy_step": True}), "scenario": st.sampled_from(["random", "a", "b", "a1"]),
    "layout": st.sampled_from(["random", "b1", "c", "z"]),
    "arena": st.sampled_from(["random", "random", "arenas/tunnel_inspection.xml",
                              str(model_path("arenas/tunnel_inspection.xml"))]),
    "arena_spec": st.dictionaries(
        st.sampled_from(["width", "length", "obstacles", "movers", "mover_radius", "tries", "placement", "colour"]),
        st.one_of(st.floats(0.0, 400.0), st.integers(0, 5), st.tuples(st.integers(0, 500), st.integers(0, 1500)),
                  ANY_VALUE), max_size=2),
    "command": st.one_of(st.sampled_from(["paper", "random"]),
                         st.tuples(st.floats(0.0, 4.0), st.floats(-4.0, 4.0)).map(list)),
    "disturbances": st.sampled_from(["paper", "random", "none"]),
    "observation": st.sampled_from(["paper", "integral", "relative"]),
    "conditions": st.one_of(st.sampled_from(["ideal", "ocean", "storm"]), st.dictionaries(
        st.sampled_from(["base", "current", "sonar", "model_uncertainty", "thruster_lag", "tide"]),
        st.one_of(st.booleans(), st.sampled_from(["ideal", "ocean"]), st.dictionaries(
            st.sampled_from(["mean_speed", "speed_sigma", "speed_time_constant", "speed_bounds", "mean_direction",
                             "floor", "proportional", "dropout", "latency", "hydrodynamics", "mass", "other"]),
            st.one_of(st.floats(0.0, 2.0), st.integers(0, 5), st.tuples(st.floats(0.0, 1.0), st.floats(1.0, 3.0)),
                      ANY_VALUE), max_size=2), ANY_VALUE), max_size=3))}
"""Values near or inside each option's range."""


@st.composite
def task_options(draw) -> tuple[str, dict]:
    """A task and options for it: mostly its own options with plausible values, now and then anything."""
    task = draw(st.sampled_from([name for _, name in suite.PLANAR_TASKS]))
    names = draw(st.lists(st.sampled_from(TASK_OPTIONS[task]) | st.sampled_from(OPTIONS), max_size=3, unique=True))
    return task, {name: draw(PLAUSIBLE_OPTIONS.get(name, ANY_VALUE) if draw(st.integers(0, 3)) else ANY_VALUE)
                  for name in names}


@given(spec=task_options())
@settings(max_examples=3 * EXAMPLES)
def test_fuzz_task_options_are_refused_by_name_or_run(spec):
    task, kwargs = spec
    with deadline():
        try:
            env = suite.load("auv", task, task_kwargs=kwargs)
        except ValueError as error:
            refusal(error, *kwargs)
            return
        event("accepted")
        spec = env.action_spec()
        step = env.reset()
        for action in (spec.minimum, spec.maximum, np.zeros(spec.shape)):
            step = env.step(np.broadcast_to(action, spec.shape))
            assert all(np.all(np.isfinite(v)) for v in step.observation.values())
            if step.last():
                break


GYM_KWARGS = {"task_kwargs": st.one_of(st.none(), task_options().map(lambda spec: {
                   k: v for k, v in spec[1].items() if k != "random"}), ANY_VALUE),
              "environment_kwargs": st.one_of(st.none(), st.just({"legacy_step": True}), ANY_VALUE),
              "render_size": st.one_of(st.tuples(st.integers(-5, 5000), st.integers(-5, 5000)), ANY_VALUE),
              "render_distance": st.one_of(st.floats(-1.0, 2e4), ANY_VALUE),
              "render_mode": st.one_of(st.none(), st.sampled_from(["rgb_array", "human", "rgb_array_list", ""]))}
"""Keyword arguments of `gymnasium.make` for the task ids (render_mode a string or None: `gymnasium.make`
itself reads it before the environment sees it)."""
MIX_KWARGS = {"tasks": st.one_of(st.lists(st.sampled_from(["goal", "obstacles", "tunnel", "speed_heading", "x"]),
                                          max_size=3), ANY_VALUE),
              "weights": st.one_of(st.none(), st.lists(st.floats(-1.0, 3.0), max_size=3), ANY_VALUE),
              "per_task_kwargs": st.one_of(st.none(), st.just({"goal": {"goal_radius": 20.0}}), ANY_VALUE)}
"""Keyword arguments of `gymnasium.make("auv_mj/Planning-v0")`."""


@st.composite
def gym_specs(draw) -> tuple[str, dict]:
    """A Gymnasium id and keyword arguments for it."""
    env_id = draw(st.sampled_from(sorted(GYM_IDS) + [MIX_ID]))
    pool = MIX_KWARGS if env_id == MIX_ID else GYM_KWARGS
    names = draw(st.lists(st.sampled_from(sorted(pool)), max_size=3, unique=True))
    return env_id, {name: draw(pool[name]) for name in names}


@given(spec=gym_specs())
@settings(max_examples=EXAMPLES)
def test_fuzz_gymnasium_kwargs_are_refused_by_name_or_run(spec):
    env_id, kwargs = spec
    with deadline(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Gymnasium's own checker warnings
        try:
            env = gymnasium.make(env_id, disable_env_checker=True, **kwargs).unwrapped
        except ValueError as error:
            refusal(error, *kwargs, "task option", "task ")
            return
        event("accepted")
        observation, _ = env.reset(seed=1)
        observation, reward, *_ = env.step(env.action_space.sample())
        values = observation.values() if isinstance(observation, dict) else [observation]
        assert all(np.all(np.isfinite(v)) for v in values) and np.isfinite(reward)


# --- the vehicle MJCF ---------------------------------------------------------------------------------------------

VEHICLE_TARGETS = (
    ("custom/numeric", "data"), ("custom/numeric", "name"), (".//joint", "type"), (".//joint", "axis"),
    (".//joint", "name"), ("actuator/general", "ctrlrange"), ("actuator/general", "gear"),
    ("actuator/general", "name"), ("sensor/rangefinder", "name"), ("sensor/rangefinder", "site"),
    ("option", "timestep"), ("option", "integrator"), (".//inertial", "mass"), (".//inertial", "diaginertia"),
    (".//inertial", "pos"), (".//geom[@name='hull']", "size"), (".//geom[@name='hull']", "type"),
    (".//body[@name='auv']", "pos"), (".//body[@name='auv']", "euler"),
)


@st.composite
def vehicle_texts(draw) -> str:
    """The shipped vehicle with random attribute edits, deletions and additions."""
    root = ET.fromstring(VEHICLE)
    if draw(st.booleans()):  # a plausible other vehicle: coefficients, mass, limits and timestep rescaled
        for numeric in root.findall("custom/numeric"):
            if draw(st.booleans()):
                numeric.set("data", repr(float(numeric.get("data")) * draw(st.floats(0.2, 5.0))))
        inertial = root.find(".//inertial")
        inertial.set("mass", repr(30.48 * draw(st.floats(0.2, 5.0))))
        for actuator in root.findall("actuator/general"):
            low, high = (float(v) * draw(st.floats(0.1, 5.0)) for v in actuator.get("ctrlrange").split())
            actuator.set("ctrlrange", f"{low!r} {high!r}")
        root.find("option").set("timestep", draw(st.sampled_from(["0.002", "0.005", "0.01", "0.02", "0.05", "0.1"])))
        return ET.tostring(root, encoding="unicode")
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["coefficient", "coefficient", "set", "delete", "joint"]))
        if kind == "coefficient":
            numeric = draw(st.sampled_from(root.findall("custom/numeric")))
            try:
                value = float(numeric.get("data"))
            except (TypeError, ValueError):  # an earlier edit wrote a word there
                value = 1.0
            factor = draw(st.sampled_from([-1.0, 0.0, 10.0, 100.0, 1e3, 1e4, 1e6]))
            scaled = draw(st.one_of(st.just(factor * value), st.floats(-1e7, 1e7),
                                    st.sampled_from([math.nan, math.inf, 1e308, -1e308])))
            numeric.set("data", repr(scaled))
        elif kind == "set":
            xpath, attribute = draw(st.sampled_from(VEHICLE_TARGETS))
            found = root.findall(xpath)
            if found:
                value = draw(st.one_of(NUMBER_TEXT, VECTOR_TEXT, st.text(max_size=8)))
                draw(st.sampled_from(found)).set(attribute, value)
        elif kind == "delete":
            xpath = draw(st.sampled_from(["custom/numeric", "actuator/general", "sensor/rangefinder", ".//joint",
                                          ".//site", ".//geom"]))
            found = root.findall(xpath)
            if found:
                element = draw(st.sampled_from(found))
                parent = next(e for e in root.iter() if element in list(e))
                parent.remove(element)
        else:
            body = root.find(".//body[@name='auv']")
            ET.SubElement(body, "joint", name=draw(st.sampled_from(["x", "extra", "yaw"])),
                          type=draw(st.sampled_from(["slide", "hinge", "ball", "free"])), axis=draw(VECTOR_TEXT))
    return ET.tostring(root, encoding="unicode")


@given(text=vehicle_texts(), seed=st.integers(0, 2**16))
@settings(max_examples=3 * EXAMPLES)
def test_fuzz_vehicle_models_are_refused_by_field_or_run(text, seed):
    with deadline():
        try:
            physics = AUVPhysics.from_xml_string(text, source="fuzz-vehicle.xml")
        except ValueError as error:
            refusal(error, "fuzz-vehicle.xml")
            return
        event("accepted")
        low, high = physics.model.actuator_ctrlrange.T
        controls = np.random.default_rng(seed).uniform(low, high, size=(20, 2))
        for control in controls:  # 20 s of random full-range controls
            physics.set_control(control)
            physics.step(int(round(1.0 / physics.timestep())))
        assert np.all(np.isfinite(physics.pose())) and np.all(np.isfinite(physics.body_velocity()))


# --- checkpoints --------------------------------------------------------------------------------------------------

SPEC = {"act_dim": 2, "action_low": [-1.0, -1.0], "action_high": [1.0, 1.0], "kind": "box", "obs_dim": 4,
        "obs_shape": [4], "env_id": None}


@pytest.fixture(scope="module")
def checkpoint_parts(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "small.pt"
    save_agent(path, DDPG(4, 2, DDPGConfig(hidden_sizes=(8, 8))),
                    {"agent": "ddpg", "spec": SPEC, "replay_file": "replay.npz",
                     "counters": {"env_steps": 0, "episodes": 0}})
    return read_checkpoint(path)


META_FIELDS = ("obs_dim", "act_dim", "num_updates", "replay_file", "config", "spec", "agent_rng", "counters",
               "config.hidden_sizes", "config.gamma", "config.buffer_size", "config.actor_lr", "config.device",
               "config.seed", "config.unknown", "spec.obs_shape", "spec.action_low", "spec.action_high",
               "spec.obs_dim", "spec.kind")
SIZES = st.one_of(st.integers(-5, 20), st.sampled_from([10**9, 10**12, 2**63]), st.floats(allow_nan=True),
                  st.lists(st.integers(-2, 10**9) | st.floats(allow_nan=True), max_size=4))


PLAUSIBLE = st.one_of(st.tuples(st.just("num_updates"), st.integers(0, 10**6)),
                     st.tuples(st.just("config.gamma"), st.floats(0.0, 1.0)),
                     st.tuples(st.just("config.seed"), st.integers(0, 2**32 - 1)),
                     st.tuples(st.just("config.buffer_size"), st.integers(1, 10**6)),
                     st.tuples(st.just("spec.action_high"), st.lists(st.floats(1.0, 50.0), min_size=2, max_size=2)),
                     st.tuples(st.just("note"), st.text(max_size=10)))
"""Edits a real checkpoint could carry (another seed, other bounds, an extra note)."""


@given(edits=st.lists(st.one_of(PLAUSIBLE, PLAUSIBLE, st.tuples(st.sampled_from(META_FIELDS),
                                                                 st.one_of(ANY_VALUE, SIZES))), max_size=3),
       tensor_edits=st.lists(st.tuples(st.integers(0, 100), st.sampled_from(["nan", "inf", "shape", "drop", "int"])),
                             max_size=1))
@settings(max_examples=2 * EXAMPLES)
def test_fuzz_checkpoints_are_refused_before_allocation_or_load(checkpoint_parts, edits, tensor_edits):
    tensors = {k: v.clone() for k, v in checkpoint_parts[0].items()}
    meta = copy.deepcopy(checkpoint_parts[1])
    for field, value in edits:
        holder, _, key = field.rpartition(".")
        target = meta[holder] if holder and isinstance(meta.get(holder), dict) else meta
        if value is None and field in meta:
            del meta[field]
        else:
            target[key] = value
    names = sorted(tensors)
    for index, change in tensor_edits:
        name = names[index % len(names)]
        if change == "nan" and tensors[name].is_floating_point():
            tensors[name].view(-1)[:1] = math.nan
        elif change == "inf" and tensors[name].is_floating_point():
            tensors[name].view(-1)[:1] = math.inf
        elif change == "shape":
            tensors[name] = torch.zeros(3, 5)
        elif change == "drop":
            del tensors[name]
        elif change == "int":
            tensors[name] = tensors[name].to(torch.int64)
    with tempfile.TemporaryDirectory() as folder, deadline():
        path = Path(folder) / "fuzzed.pt"
        torch.save({"tensors": tensors, "metadata": meta}, path)
        for load in (Policy.load, load_agent):
            try:
                loaded = load(path)
            except ValueError as error:
                refusal(error, str(path))
                continue
            event("accepted")
            policy = loaded if isinstance(loaded, Policy) else Policy.load(path)
            action = policy(np.zeros(policy.obs_dim))
            assert action.shape == (len(policy.low),) and np.all(np.isfinite(action))
            assert np.all(action >= policy.low - 1e-6) and np.all(action <= policy.high + 1e-6)


# --- tunnel specs through the command line ------------------------------------------------------------------------

COORDINATE = st.one_of(st.floats(-400, 400), st.sampled_from([math.nan, math.inf, 1e308, -1e308, 1e6]))


@st.composite
def centreline_files(draw) -> bytes:
    """A CSV or JSON centreline: a random walk of sensible legs, arbitrary numbers, or damaged text."""
    kind = draw(st.sampled_from(["walk", "walk", "walk", "numbers", "json", "garbage"]))
    if kind in ("walk", "json"):
        points, heading = [(0.0, 0.0)], 0.0
        for _ in range(draw(st.integers(1, 6))):
            heading += draw(st.floats(-1.2, 1.2))
            length = draw(st.floats(20.0, 200.0))
            points.append((points[-1][0] + length * math.cos(heading), points[-1][1] + length * math.sin(heading)))
        if kind == "json":
            body = {"centreline": [list(p) for p in points]}
            body.update(draw(st.dictionaries(st.sampled_from(["width", "centerline", "colour"]), ANY_VALUE,
                                             max_size=1)))
            return json.dumps(body).encode()
        return ("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in points)).encode()
    if kind == "numbers":
        rows = draw(st.lists(st.lists(NUMBER_TEXT, min_size=1, max_size=4), max_size=6))
        return "\n".join(",".join(row) for row in rows).encode()
    return draw(st.binary(max_size=64))


def _spec(draw, fields: int) -> str:
    return ",".join(draw(st.one_of(COORDINATE.map(repr), NUMBER_TEXT)) for _ in range(fields)) + \
        draw(st.sampled_from(["", ",a", ",rock", ",a b", ",x" * 2]))


@st.composite
def tunnel_options(draw) -> list[str]:
    """Random options of `auv-mj tunnel`: sensible values, absurd ones and non-numbers."""
    number = st.one_of(st.floats(0.5, 80.0).map(repr), NUMBER_TEXT)
    options = ["--width", draw(st.one_of(st.floats(12.0, 60.0).map(repr), NUMBER_TEXT))] if draw(st.booleans()) \
        else []
    for flag in draw(st.lists(st.sampled_from(["--smooth", "--closed", "--smooth-iterations", "--spacing",
                                               "--wall-thickness", "--end-clearance", "--margin", "--tolerance",
                                               "--obstacle", "--unknown", "--mover", "--name", "--random",
                                               "--length", "--obstacles", "--movers", "--task"]), max_size=4)):
        if flag in ("--smooth", "--closed"):
            options.append(flag)
        elif flag in ("--random", "--obstacles", "--movers"):
            options += [flag, draw(st.one_of(st.integers(-3, 30).map(str), NUMBER_TEXT))]
        elif flag == "--task":
            options += [flag, draw(st.sampled_from(["tunnel", "obstacles", "moving_obstacles", "goal"]))]
        elif flag in ("--obstacle", "--unknown"):
            options += [flag, _spec(draw, draw(st.integers(3, 6)))]
        elif flag == "--mover":
            options += [flag, _spec(draw, draw(st.integers(5, 7)))]
        elif flag == "--name":
            options += [flag, draw(st.text(max_size=10))]
        else:
            options += [flag, draw(number)]
    return options


def _along(draw, points: list[tuple[float, float]], low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """A point on the centreline between fractions low..high of its legs, and the leg's unit normal."""
    leg = draw(st.integers(0, len(points) - 2))
    a, b = np.array(points[leg]), np.array(points[leg + 1])
    t = draw(st.floats(low, high))
    direction = (b - a) / np.hypot(*(b - a))
    return a + t * (b - a), np.array([-direction[1], direction[0]])


def _numbers(*values) -> str:
    return ",".join(repr(float(v)) for v in values)


@st.composite
def tunnel_specs(draw) -> tuple[bytes, list[str]]:
    """A centreline file and `auv-mj tunnel` options: half the time sensible (a random walk of gentle legs,
    obstacles and movers placed in the tunnel), half the time anything (absurd numbers, words, garbage)."""
    kind = draw(st.integers(0, 5))
    if kind < 3:
        return draw(centreline_files()), draw(tunnel_options())
    if kind == 3:  # a procedural arena of a seed, the command's other form
        options = ["--random", str(draw(st.integers(0, 2**20)))]
        if draw(st.booleans()):
            options += ["--task", draw(st.sampled_from(["tunnel", "obstacles", "moving_obstacles"]))]
        elif draw(st.booleans()):
            options += ["--length", repr(draw(st.floats(120.0, 500.0))), "--movers", str(draw(st.integers(0, 2)))]
        return b"", options
    points, heading = [(0.0, 0.0)], 0.0
    for _ in range(draw(st.integers(1, 4))):
        heading += draw(st.floats(-0.6, 0.6))
        length = draw(st.floats(60.0, 200.0))
        points.append((points[-1][0] + length * math.cos(heading), points[-1][1] + length * math.sin(heading)))
    width = draw(st.floats(20.0, 60.0))
    options = ["--width", repr(width), "--spacing", repr(draw(st.floats(2.0, 30.0)))]
    if draw(st.booleans()):
        options += ["--smooth", "--smooth-iterations", str(draw(st.integers(0, 4)))]
    for k in range(draw(st.integers(0, 2))):
        centre, normal = _along(draw, points, 0.2, 0.8)
        size = draw(st.floats(1.0, 6.0))
        near, far = 6.0 + size / 2, width / 2 - size / 2 - 0.5  # beside the path, inside the walls
        if near < far:
            centre = centre + normal * draw(st.floats(near, far)) * draw(st.sampled_from([-1.0, 1.0]))
            options += ["--obstacle", f"{_numbers(*centre, size, size, 0)},rock{k}"]
    for k in range(draw(st.integers(0, 2))):
        centre, normal = _along(draw, points, 0.3, 0.9)
        reach = width / 2 - 3.0
        ends = centre - reach * normal, centre + reach * normal
        speed = draw(st.floats(0.0, 0.5))
        options += ["--mover", f"{_numbers(*ends[0], *ends[1], speed, 1.0)},m{k}"]
    text = "x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in points)
    return text.encode(), options


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """`auv-mj ARGV` in this process: (exit status, stdout, stderr); any exception but SystemExit escapes."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = auv_mj_cli.main(argv)
        except SystemExit as exit_:
            status = exit_.code if isinstance(exit_.code, int) else 1
    return status, out.getvalue(), err.getvalue()


@given(spec=tunnel_specs(), suffix=st.sampled_from([".csv", ".json", ".txt"]))
@settings(max_examples=3 * EXAMPLES)
def test_fuzz_tunnel_command_writes_a_usable_arena_or_refuses(spec, suffix):
    centreline, options = spec
    with tempfile.TemporaryDirectory() as folder, deadline():
        source = Path(folder) / f"line{suffix}"
        source.write_bytes(centreline)
        output = Path(folder) / "tunnel.xml"
        line = [] if options[:1] == ["--random"] else [str(source)]
        status, out, err = run_cli(["tunnel", *line, "-o", str(output), *options])
        event("accepted" if status == 0 else "refused")
        if status == 0:
            open_water = any(task in options for task in ("obstacles", "moving_obstacles"))  # --random layouts
            assert output.is_file() and arena_check.check_arena(output, need_path=not open_water).ok
            if not open_water:
                env = suite.load("auv", "tunnel", task_kwargs={"arena": str(output)})
                env.reset()
                assert np.all(np.isfinite(env.step(np.zeros(2)).observation["observation"]))
        else:
            assert status == 2, (status, err)
            assert err.startswith("auv-mj tunnel: error: ") and err.count("\n") == 1, err
            assert not output.exists() and sorted(p.name for p in Path(folder).iterdir()) == [source.name]


# --- actions ------------------------------------------------------------------------------------------------------

ACTIONS = st.one_of(
    st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30), st.booleans(),
                       st.text(max_size=4), st.none()), max_size=3),
    st.lists(st.floats(-1e308, 1e308), min_size=2, max_size=2),
    st.builds(np.array, st.lists(st.floats(width=32), min_size=2, max_size=2)).map(lambda a: a.astype(np.float32)),
    st.builds(np.zeros, st.lists(st.integers(0, 3), max_size=3).map(tuple)),
    st.text(max_size=6), st.none(), st.dictionaries(st.text(max_size=3), st.floats(), max_size=2))


@pytest.fixture(scope="module")
def faces():
    return {"dm_env goal": suite.load("auv", "goal", task_kwargs={"random": 0}),
            "dm_env speed_heading": suite.load("auv", "speed_heading", task_kwargs={"random": 0}),
            "gym goal": AUVGymEnv("goal")}


def _is_good_action(action) -> bool:
    value = np.asarray(action) if not isinstance(action, dict) else np.array(None)
    return value.dtype.kind in "biuf" and value.shape == (2,) and bool(np.all(np.isfinite(value.astype(float))))


@given(face=st.sampled_from(["dm_env goal", "dm_env speed_heading", "gym goal"]), action=ACTIONS)
@settings(max_examples=5 * EXAMPLES)
def test_fuzz_actions_follow_one_convention_on_both_faces(faces, face, action):
    env = faces[face]
    with deadline(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ActionClipped, asserted in test_validation
        if face.startswith("gym"):
            env.reset(seed=0)
            step = lambda a: env.step(a)[0]  # noqa: E731
        else:
            env.reset()
            step = lambda a: env.step(a).observation  # noqa: E731
        try:
            observation = step(action)
        except ValueError as error:
            refusal(error, "Goal:", "SpeedHeading:")
            assert not _is_good_action(action)
            return
        assert _is_good_action(action)
        event("accepted")
        values = observation.values() if isinstance(observation, dict) else [observation]
        assert all(np.all(np.isfinite(v)) for v in values)


# --- --task-kwargs ------------------------------------------------------------------------------------------------

JSON_VALUES = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers(-10**20, 10**20)
                           | st.text(max_size=6) | st.sampled_from(["paper", "random", "a", "none"]),
                           lambda children: st.lists(children, max_size=3)
                           | st.dictionaries(st.text(max_size=5), children, max_size=3), max_leaves=8)
TASK_KWARGS = st.one_of(
    task_options().map(lambda spec: json.dumps({k: v for k, v in spec[1].items()
                                                if k not in ("random", "executor", "environment_kwargs")})),
    st.dictionaries(st.sampled_from(OPTIONS), JSON_VALUES, max_size=3).map(json.dumps),
    JSON_VALUES.map(json.dumps),
    st.text(max_size=30),
    st.integers(1, 40_000).map(lambda depth: "[" * depth + "]" * depth),
    st.integers(1, 40_000).map(lambda depth: '{"a": ' * depth + "1" + "}" * depth))


@given(task=st.sampled_from(["goal", "speed_heading", "tunnel", "waypoints"]), text=TASK_KWARGS)
@settings(max_examples=2 * EXAMPLES)
def test_fuzz_task_kwargs_run_an_episode_or_are_a_usage_error(task, text):
    with deadline():
        status, out, err = run_cli(["eval", "--policy", "splane", "--task", task, "--episodes", "1",
                                    "--max-steps", "3", "--no-progress", "--task-kwargs", text])
    event("accepted" if status == 0 else "refused")
    if status == 0:
        assert "policy: splane" in out and not err
    else:
        assert status == 2, (status, err)
        assert err.startswith("auv-mj eval: error: ") and err.count("\n") == 1, err
