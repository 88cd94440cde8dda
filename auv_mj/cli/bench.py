"""`auv-mj bench`: the simulator's speed as ratios against its limits, all measured in one run.

Absolute times depend on the machine and its load; ratios of things timed side by side in the same
repeats do much less, so each section reports both and the medians over repeats. A section is a
function `(BenchSettings) -> list[Measurement]` registered in SECTIONS with `@section(name)`; add
one (e.g. "tasks": environment steps per second of each task) and it runs, prints and goes to --json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import gymnasium
import mujoco
import numpy as np
import torch

import auv_mj  # noqa: F401  (registers the auv_mj Gymnasium ids)
from auv_mj import model_path
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.replay import Batch
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config
from auv_mj.agents.offpolicy.train import env_spec, train
from auv_mj.arenas.arena import load
from auv_mj.cli.options import bounded_int, check_output, seed_int, usage_error
from auv_mj.cli.train import make_env_fn
from auv_mj.planners.guidance import line_of_sight
from auv_mj.render import glbackend
from auv_mj.sim import native, native3d
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose
from auv_mj.speed.render import time_against_bare_renderer
from auv_mj.tasks import suite

SUB_STEPS = 10
"""Physics steps per `AUVPhysics.step(n)` call in the batched timing (one 10 Hz executor step)."""
WALL_COUNTS = (20, 200)
"""Numbers of wall geoms in the sonar timing, besides open water."""
WALL_FIELD = 200.0
"""Side [m] of the square the timing walls are scattered in, around the vehicle."""


@dataclass(frozen=True)
class BenchSettings:
    """How long to measure."""

    repeats: int = 7
    """Timed repeats; every figure is the median over them."""
    scale: float = 1.0
    """Multiplies the calls per repeat (`--quick` uses 0.1)."""
    seed: int = 0
    """Seed of the random controls and wall layouts."""

    def calls(self, full: int) -> int:
        return max(1, int(full * self.scale))


@dataclass(frozen=True)
class Measurement:
    """One figure of a section."""

    name: str
    value: float
    unit: str
    note: str = ""


Section = Callable[[BenchSettings], list[Measurement]]
SECTIONS: dict[str, Section] = {}
ON_REQUEST: set[str] = set()
"""Sections run only when `--sections` names them (minutes long: the batched env's)."""


def section(name: str, on_request: bool = False) -> Callable[[Section], Section]:
    """Registers a benchmark section under `name` (run in registration order); `on_request`: not in the default
    run, only when `--sections` names it."""
    def register(function: Section) -> Section:
        SECTIONS[name] = function
        if on_request:
            ON_REQUEST.add(name)
        return function
    return register


def interleaved_times(workloads: Sequence[Callable[[], None]], calls_per_repeat: Sequence[int],
                      repeats: int) -> np.ndarray:
    """Seconds per call, shape (repeats, workloads); the workloads alternate inside every repeat."""
    times = np.empty((repeats, len(workloads)))
    for workload in workloads:  # warm-up: caches, lazy allocations
        workload()
    for i in range(repeats):
        for j, (workload, calls) in enumerate(zip(workloads, calls_per_repeat, strict=True)):
            start = time.perf_counter()
            for _ in range(calls):
                workload()
            times[i, j] = (time.perf_counter() - start) / calls
    return times


def median_ratio(times: np.ndarray, numerator: int, denominator: int) -> float:
    return float(np.median(times[:, numerator] / times[:, denominator]))


@section("physics")
def physics_section(settings: BenchSettings) -> list[Measurement]:
    """AUVPhysics.step (hydrodynamics in the step) against plain mj_step of the same compiled model."""
    physics = load()
    physics.set_control([12.0, 3.0])
    physics.step(1000)  # a moving, turning vehicle
    model = physics.model.ptr
    plain = mujoco.MjData(model)  # same model, no hydrodynamics: MuJoCo's own cost, the limit
    plain.ctrl[:] = physics.data.ctrl

    def plain_steps() -> None:
        mujoco.mj_step(model, plain, SUB_STEPS)
        plain.qvel[:] = 0.0  # without drag the vehicle would only speed up

    def hydro_steps() -> None:
        physics.step(SUB_STEPS)

    def single_steps() -> None:
        for _ in range(SUB_STEPS):
            physics.step()

    disturbed = load()
    disturbed.set_control([12.0, 3.0])
    disturbed.add_disturbance(lambda t: (0.0, 25.0 * np.sin(0.01 * np.pi * t)))
    disturbed.step(1000)

    def disturbed_steps() -> None:
        disturbed.step(SUB_STEPS)

    python_data = mujoco.MjData(model)  # the same stepper with its Python loop (the fallback without cc)
    mujoco.mju_copy(python_data.qvel, physics.data.qvel)
    mujoco.mju_copy(python_data.qpos, physics.data.qpos)
    python_data.ctrl[:] = physics.data.ctrl
    mujoco.mj_step1(model, python_data)
    python_advance = physics.hydrodynamics.bind(model, python_data, native=False)

    def python_steps() -> None:
        python_advance(SUB_STEPS, model.opt.timestep)

    calls = settings.calls(400)
    times = interleaved_times([plain_steps, hydro_steps, single_steps, disturbed_steps, python_steps],
                              [calls] * 5, settings.repeats) / SUB_STEPS
    median = np.median(times, axis=0) * 1e6
    loop = "C loop" if native.kernel() is not None else "Python loop: no C compiler"
    return [
        Measurement("mj_step (plain, same model)", median[0], "us/step", "the limit"),
        Measurement(f"AUVPhysics.step({SUB_STEPS})", median[1], "us/step", loop),
        Measurement("AUVPhysics.step() per call", median[2], "us/step", "one step per call"),
        Measurement(f"AUVPhysics.step({SUB_STEPS}) + disturbance", median[3], "us/step", "periodic g_0"),
        Measurement(f"Python loop, {SUB_STEPS} steps per call", median[4], "us/step", "native=False"),
        Measurement("hydrodynamic step / plain mj_step", median_ratio(times, 1, 0), "x", loop),
        Measurement("single-step calls / plain mj_step", median_ratio(times, 2, 0), "x"),
        Measurement("disturbed step / plain mj_step", median_ratio(times, 3, 0), "x"),
        Measurement("Python loop / plain mj_step", median_ratio(times, 4, 0), "x", "native=False"),
        Measurement("simulated / wall-clock time", physics.timestep() / (median[1] * 1e-6), "x",
                    f"AUVPhysics.step({SUB_STEPS})"),
    ]


@section("physics3d")
def physics3d_section(settings: BenchSettings) -> list[Measurement]:
    """AUV3DPhysics.step (the 6-DOF water forces of `auv_mj.sim.hydro3d` in the step) against plain mj_step of the
    same compiled model (issue 32: at most 1.5x), and its NumPy reference loop."""
    physics = AUV3DPhysics.from_xml_path(model_path("auv3d.xml"))
    set_pose(physics, (0.0, 0.0, -20.0), nu=(1.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    physics.set_control([10.0, 0.1, 0.05])
    physics.step(1000)  # a moving, turning, diving vehicle
    model = physics.model.ptr
    plain = mujoco.MjData(model)
    plain.ctrl[:] = physics.data.ctrl

    def plain_steps() -> None:
        mujoco.mj_step(model, plain, SUB_STEPS)
        plain.qvel[:] = 0.0  # without drag and buoyancy it would only fall faster

    def hydro_steps() -> None:
        physics.step(SUB_STEPS)

    python_data = mujoco.MjData(model)
    mujoco.mju_copy(python_data.qvel, physics.data.qvel)
    mujoco.mju_copy(python_data.qpos, physics.data.qpos)
    python_data.ctrl[:] = physics.data.ctrl
    mujoco.mj_step1(model, python_data)
    python_advance = physics.hydrodynamics.bind(model, python_data)
    fins = tuple(float(f) for f in physics.fins)

    def python_steps() -> None:
        python_advance(SUB_STEPS, model.opt.timestep, lambda dt: fins)

    calls = settings.calls(400)
    times = interleaved_times([plain_steps, hydro_steps, python_steps], [calls] * 3, settings.repeats) / SUB_STEPS
    median = np.median(times, axis=0) * 1e6
    loop = "C loop" if native3d.kernel() is not None else "Python loop: no C compiler"
    return [
        Measurement("mj_step (plain, same 6-DOF model)", median[0], "us/step", "the limit"),
        Measurement(f"AUV3DPhysics.step({SUB_STEPS})", median[1], "us/step", loop),
        Measurement(f"6-DOF NumPy loop, {SUB_STEPS} steps per call", median[2], "us/step", "the reference"),
        Measurement("6-DOF step / plain mj_step", median_ratio(times, 1, 0), "x", loop),
        Measurement("6-DOF NumPy loop / plain mj_step", median_ratio(times, 2, 0), "x", "the reference"),
    ]


def scattered_walls(count: int, rng: np.random.Generator) -> ET.Element:
    """Arena of `count` box walls scattered over WALL_FIELD, none within 10 m of the origin."""
    root = ET.Element("mujoco")
    worldbody = ET.SubElement(root, "worldbody")
    placed = 0
    while placed < count:
        x, y = rng.uniform(-WALL_FIELD / 2, WALL_FIELD / 2, size=2)
        if np.hypot(x, y) < 10.0:
            continue
        hx, hy = rng.uniform(0.5, 8.0, size=2)
        ET.SubElement(worldbody, "geom", name=f"wall_{placed}", type="box", pos=f"{x:.3f} {y:.3f} 0",
                      size=f"{hx:.3f} {hy:.3f} 2", euler=f"0 0 {rng.uniform(0, np.pi):.4f}")
        placed += 1
    return root


@section("sonar")
def sonar_section(settings: BenchSettings) -> list[Measurement]:
    """One read of the nine rangefinders in open water and among 20 or 200 wall geoms."""
    rng = np.random.default_rng(settings.seed)
    arenas: list[tuple[str, AUVPhysics]] = [("open water", load())]
    arenas += [(f"{n} walls", load(scattered_walls(n, rng))) for n in WALL_COUNTS]
    for _, physics in arenas:
        with physics.reset_context():
            physics.data.qpos[2] = 0.3
    step_physics = arenas[0][1]

    def one_step() -> None:
        step_physics.step()

    workloads = [physics.sonar for _, physics in arenas] + [one_step]
    calls = settings.calls(2000)
    times = interleaved_times(workloads, [calls] * len(workloads), settings.repeats)
    median = np.median(times, axis=0) * 1e6
    seen = [int(np.sum(physics.sonar() < 120.0)) for _, physics in arenas]
    results = [Measurement(f"sonar read, {label}", median[i], "us/read", f"{seen[i]} of 9 beams echo")
               for i, (label, _) in enumerate(arenas)]
    results += [Measurement(f"sonar read {label} / open water", median_ratio(times, i, 0), "x")
                for i, (label, _) in enumerate(arenas) if i]
    results.append(Measurement(f"sonar read {arenas[-1][0]} / {arenas[1][0]}",
                               median_ratio(times, len(arenas) - 1, 1), "x"))
    results.append(Measurement(f"sonar read {arenas[-1][0]} / AUVPhysics.step()",
                               median_ratio(times, len(arenas) - 1, len(arenas)), "x",
                               "the tasks read the sonar once per 50 steps (2 Hz)"))
    return results


def environment() -> dict[str, str]:
    """What the figures were measured on."""
    return {"python": platform.python_version(), "mujoco": mujoco.__version__,
            "machine": platform.machine(), "processor": platform.processor() or "unknown",
            "time": time.strftime("%Y-%m-%dT%H:%M:%S")}


TASK_STEPS = 2000
"""Environment steps per task in the "tasks" section (uniform random actions, resets included)."""
OCEAN_TASKS = ("goal", "obstacles", "speed_heading")
"""Tasks whose ocean-conditions speed the "ocean" section sets beside their ideal speed."""
OCEAN_STEPS = 25
"""Environment steps per timed call in the "ocean" section (one of each conditions, alternating)."""


@section("tasks")
def tasks_section(settings: BenchSettings) -> list[Measurement]:
    """Environment steps per second of every suite task, and how many times faster than real time."""
    measurements = []
    for domain, name in suite.PLANAR_TASKS:
        env = suite.load(domain, name)
        rates = [suite.steps_per_second(name, settings.calls(TASK_STEPS), settings.seed)
                 for _ in range(max(1, settings.repeats // 3))]
        rate = float(np.median(rates))
        measurements.append(Measurement(f"{name} env steps/s", rate, "steps/s",
                                        f"{rate * env.control_timestep():.0f}x real time, "
                                        f"step {env.control_timestep():g} s"))
    return measurements


def random_stepper(name: str, conditions: str, seed: int) -> Callable[[], None]:
    """`OCEAN_STEPS` environment steps of `name` under uniform random actions per call (resets included)."""
    env = suite.load("auv", name, task_kwargs={"random": seed, "conditions": conditions})
    spec = env.action_spec()
    actions = np.random.RandomState(seed)
    state = {"step": env.reset()}

    def steps() -> None:
        for _ in range(OCEAN_STEPS):
            if state["step"].last():
                state["step"] = env.reset()
            else:
                state["step"] = env.step(actions.uniform(spec.minimum, spec.maximum, spec.shape))

    return steps


@section("ocean")
def ocean_section(settings: BenchSettings) -> list[Measurement]:
    """Environment steps per second under "ocean" conditions (current, thruster lag, sonar noise, model
    uncertainty) against "ideal" ones, the two environments stepped alternately in every repeat."""
    measurements = []
    for name in OCEAN_TASKS:
        workloads = [random_stepper(name, conditions, settings.seed) for conditions in ("ideal", "ocean")]
        calls = settings.calls(40)
        times = interleaved_times(workloads, [calls, calls], settings.repeats) / OCEAN_STEPS
        ideal, rough = 1.0 / np.median(times, axis=0)
        measurements.append(Measurement(f"{name} ideal env steps/s", ideal, "steps/s"))
        measurements.append(Measurement(f"{name} ocean env steps/s", rough, "steps/s"))
        measurements.append(Measurement(f"{name} ocean / ideal steps/s", median_ratio(times, 0, 1), "x",
                                        "goal >= 0.8"))
    return measurements


@section("render")
def render_section(settings: BenchSettings) -> list[Measurement]:
    """Frames per second of the episode renderer against a bare mujoco.Renderer of the same scene."""
    try:
        glbackend.require()
    except glbackend.RenderingUnavailable as e:
        return [Measurement("rendering unavailable", float("nan"), "", str(e))]
    env = suite.load("auv", "obstacles", task_kwargs={"random": settings.seed})
    measurements = []
    timings = time_against_bare_renderer(env, line_of_sight(env), frames=max(10, settings.calls(60)))
    for size, r in timings.items():
        measurements.append(Measurement(f"render {size} ours", r["ours_fps"], "frames/s"))
        measurements.append(Measurement(f"render {size} bare mujoco.Renderer (limit)", r["bare_fps"], "frames/s"))
        measurements.append(Measurement(f"render {size} ours / bare", r["ratio"], "x"))
    return measurements


TRAINING_UPDATES = 200
"""Gradient steps timed per repeat and learner in the "training" section."""


@section("training")
def training_section(settings: BenchSettings) -> list[Measurement]:
    """Gradient steps per second of DDPG and TD3 at Table 4's sizes (2 x 256 tanh, batch 64, one torch thread,
    the planner task's observation), the two learners taking turns in every repeat."""
    torch.set_num_threads(1)
    rng = np.random.default_rng(settings.seed)
    spec = env_spec(gymnasium.make("auv_mj/Goal-v0"))  # the planner's sizes, read from the task
    obs_dim, act_dim = spec["obs_dim"], spec["act_dim"]
    n = settings.calls(TRAINING_UPDATES)
    size = n * DDPGConfig().batch_size
    data = Batch(rng.standard_normal((size, obs_dim), dtype=np.float32),
                 rng.uniform(-1, 1, (size, act_dim)).astype(np.float32), rng.standard_normal(size, dtype=np.float32),
                 rng.standard_normal((size, obs_dim), dtype=np.float32), np.zeros(size, dtype=np.float32))
    agents = {"DDPG": DDPG(obs_dim, act_dim, DDPGConfig()), "TD3": TD3(obs_dim, act_dim, TD3Config())}
    times: dict[str, list[float]] = {name: [] for name in agents}
    for repeat in range(settings.repeats):
        for name in (list(agents) if repeat % 2 == 0 else list(agents)[::-1]):
            start = time.perf_counter()
            agents[name].update_many(data, n)
            times[name].append((time.perf_counter() - start) / n)
    return [Measurement(f"{name} gradient steps/s (batch 64, 2x256)", 1.0 / float(np.median(times[name])),
                        "updates/s", "one torch thread") for name in agents]


VECTOR_CASES = {"goal": {}, "obstacles hard": {"arena": "random", "tier": "hard"}}
"""Tasks (and options) of the "vector" section: open water, and the hard tier's procedural arenas (resets and all)."""
VECTOR_MEMORY_STEPS = 1_000_000
"""Environment steps over which the "vector" section follows the batch's resident memory (N = 256)."""
PPO_BENCH_ENVS = (64, 256)
"""Batch sizes of the "vector" section's PPO runs: the planner's size (96) rounded, and the batch's own target
size. A recurrent update's cost is mostly per time step, not per vehicle, so it falls per sample as N grows."""
PPO_BENCH_ROLLOUTS = 20
"""Rollouts (of 128 steps per env) of the "vector" section's timed PPO run, after one untimed rollout: one whole
checkpoint cycle of the `planner-memory` run (`--ppo-checkpoint-every 20`). PPO resets every env at each checkpoint
(so that resuming is exact), and on the hard tier a reset draws and certifies an arena; timing a whole cycle weighs
those resets as training meets them, neither more (a cycle of 4 rollouts would count them 5 times over) nor less.
The batch alone is timed over the same cycle (`vector_bench.cycle_rate`: the same resets, as many steps, random
actions), the learner's network and update are the planner's own (`auv_mj.agents.ppo.planner.PLANNER_CONFIG`)."""


@section("vector", on_request=True)
def vector_section(settings: BenchSettings) -> list[Measurement]:
    """The batched planning environment (`auv_mj.tasks.vector`): env steps/s for N in {1, 16, 64, 256} on 1 and 2
    threads beside the physics limit (plain `mj_step`, 50 substeps per env step, one thread), Gymnasium's
    AsyncVectorEnv and SB3's SubprocVecEnv on 2 processes; the resident memory over 10^6 env steps; and recurrent
    PPO's samples/s end to end (`auv_mj.agents.ppo`, the planner's GRU network, N = 64 and 256) against the batch
    alone over the same checkpoint cycle."""
    from auv_mj.agents.ppo import reset_seeds
    from auv_mj.agents.ppo import train as train_ppo
    from auv_mj.agents.ppo.planner import PLANNER_CONFIG
    from auv_mj.speed.vector import MEMORY_SIZE, cycle_rate, vector_bench
    from auv_mj.tasks.vector import AUVVectorEnv

    seconds = max(0.5, 2.0 * settings.scale)
    measurements = []
    for case, task_kwargs in VECTOR_CASES.items():
        task = case.split()[0]
        memory = settings.calls(VECTOR_MEMORY_STEPS) // MEMORY_SIZE if case == "goal" else 0
        rows = vector_bench(task, task_kwargs, seconds=seconds, memory_steps=memory)
        for row in rows:
            if "rss_early" in row:
                measurements.append(Measurement(f"{case}: resident memory after {memory * MEMORY_SIZE} env steps / "
                                                "after a tenth of them", row["rss_late"] / row["rss_early"], "x",
                                                f"{row['rss_early'] / 2**20:.0f} -> {row['rss_late'] / 2**20:.0f} "
                                                "MiB"))
            else:
                measurements.append(Measurement(f"{case}: {row['name']}", row["steps_per_second"], "env steps/s",
                                                f"{row['ratio']:.2f} of the physics limit, load "
                                                f"{row['load']:.1f}"))
        by_name = {r["name"]: r["steps_per_second"] for r in rows if "steps_per_second" in r}
        one, two = by_name["batch N=256 threads=1"], by_name["batch N=256 threads=2"]
        measurements.append(Measurement(f"{case}: N=256, 2 threads / 1 thread", two / one, "x"))
        measurements.append(Measurement(f"{case}: N=256, 2 threads / AsyncVectorEnv (2 processes)",
                                        two / by_name["AsyncVectorEnv (2 processes)"], "x"))
    rollouts = settings.calls(PPO_BENCH_ROLLOUTS)
    config = replace(PLANNER_CONFIG, seed=settings.seed, checkpoint_every=rollouts)
    for size in PPO_BENCH_ENVS:
        steps = size * config.num_steps
        first = reset_seeds(config.seed, 0, size)  # the timed run's first reset (it is a fresh run)
        batch = cycle_rate("obstacles", VECTOR_CASES["obstacles hard"], size, 2, first, config.num_steps * rollouts,
                           seed=settings.seed)
        with tempfile.TemporaryDirectory() as folder:
            env = AUVVectorEnv("obstacles", size, VECTOR_CASES["obstacles hard"], threads=2)
            train_ppo(env, config, Path(folder) / "warm", steps, progress=False)  # one rollout: imports, resets
            start = time.perf_counter()
            train_ppo(env, config, Path(folder) / "timed", steps * rollouts, progress=False)
            rate = steps * rollouts / (time.perf_counter() - start)
            env.close()
        measurements.append(Measurement(f"obstacles hard: PPO (GRU) end to end, N={size}", rate, "env steps/s",
                                        f"one checkpoint cycle ({rollouts} rollouts): resets, collection, "
                                        f"updates, checkpoint; the planner's network, {config.torch_threads} "
                                        "torch threads in the update"))
        measurements.append(Measurement(f"obstacles hard: PPO end to end / the batch alone, N={size}", rate / batch,
                                        "x", f"batch N={size}, 2 threads, over the same cycle: {batch:.0f} env "
                                        "steps/s"))
    return measurements


CORE_STEPS = 20_000
"""Env steps of each timed training run of the "cores" section (the collector's start, 2-3 s, is timed too)."""
CORE_REPEATS = 3
"""At most this many repeats of the "cores" section (one is two training runs of about a minute)."""


@section("cores")
def cores_section(settings: BenchSettings) -> list[Measurement]:
    """Training env steps/s of `auv-mj train her-ddpg --task goal` (Table 4's config) serially and with one
    collector process (`--collectors 1`), the two runs alternating in every repeat, each timed whole (the
    collector's start included); and each run's gradient steps per env step, which must agree."""
    steps = max(2400, settings.calls(CORE_STEPS))
    config = DDPGConfig(learning_starts=min(DDPGConfig().learning_starts, steps // 4), seed=settings.seed)
    env_fn = make_env_fn("auv_mj/Goal-v0")
    repeats = min(settings.repeats, CORE_REPEATS)
    rates = np.empty((repeats, 2))
    ratios = np.empty((repeats, 2))
    with tempfile.TemporaryDirectory(prefix="auv-mj-bench-") as scratch:
        for i in range(repeats):
            for j, count in enumerate((0, 1)):
                result = train(env_fn, "her-ddpg", config, total_steps=steps, run_dir=Path(scratch) / f"{i}-{count}",
                               progress=False, tensorboard=False, collectors=count)
                rates[i, j] = result.env_steps_per_s
                ratios[i, j] = result.gradient_steps / result.env_steps
    note = f"goal, {steps} steps per run, {repeats} repeats, {os.cpu_count()} CPUs"
    return [Measurement("train env steps/s, serial", float(np.median(rates[:, 0])), "steps/s", note),
            Measurement("train env steps/s, --collectors 1", float(np.median(rates[:, 1])), "steps/s", note),
            Measurement("--collectors 1 / serial", float(np.median(rates[:, 1] / rates[:, 0])), "x",
                        "median of the repeats' ratios"),
            Measurement("gradient steps per env step, serial", float(np.median(ratios[:, 0])), "updates/step"),
            Measurement("gradient steps per env step, --collectors 1", float(np.median(ratios[:, 1])),
                        "updates/step")]


def run_sections(names: Sequence[str], settings: BenchSettings,
                 report: Callable[[str, list[Measurement]], None] | None = None
                 ) -> dict[str, list[Measurement]]:
    """Runs the named sections in order; `report(name, measurements)` is called after each."""
    results = {}
    for name in names:
        results[name] = SECTIONS[name](settings)
        if report is not None:
            report(name, results[name])
    return results


def print_section(name: str, measurements: list[Measurement]) -> None:
    print(f"[{name}]")
    for m in measurements:
        note = f"  ({m.note})" if m.note else ""
        print(f"  {m.name:<48} {m.value:10.2f} {m.unit}{note}", flush=True)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj bench`."""
    parser.add_argument("--quick", action="store_true", help="a tenth of the calls and 3 repeats (seconds)")
    parser.add_argument("--repeats", type=bounded_int(1, 1000), default=None,
                        help="timed repeats (default 7, --quick 3)")
    parser.add_argument("--sections", default=None,
                        help=f"comma-separated sections to run (default all but {','.join(sorted(ON_REQUEST))}: "
                             f"{','.join(n for n in SECTIONS if n not in ON_REQUEST)})")
    parser.add_argument("--json", type=Path, default=None, metavar="PATH",
                        help="also write the figures as JSON")
    parser.add_argument("--seed", type=seed_int, default=0, help="seed of the wall layouts")


def run(args: argparse.Namespace) -> int:
    """`auv-mj bench`: runs the sections, prints their figures, optionally writes them as JSON."""
    names = [n for n in SECTIONS if n not in ON_REQUEST] if args.sections is None else \
        [n.strip() for n in args.sections.split(",") if n]
    unknown = [n for n in names if n not in SECTIONS]
    if unknown:
        usage_error(args, f"--sections: unknown section(s) {', '.join(unknown)[:200]}; known: {', '.join(SECTIONS)}")
    check_output(args, args.json, "--json")
    repeats = args.repeats if args.repeats is not None else (3 if args.quick else 7)
    settings = BenchSettings(repeats=repeats, scale=0.1 if args.quick else 1.0, seed=args.seed)
    print(f"auv-mj bench: medians over {settings.repeats} repeats; ratios of workloads timed side by side")
    results = run_sections(names, settings, print_section)
    if args.json is not None:
        payload = {"settings": asdict(settings), "environment": environment(),
                   "sections": {name: [asdict(m) for m in ms] for name, ms in results.items()}}
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(payload, indent=2))
        print(f"wrote {args.json}")
    return 0
