"""How fast the simulator core runs (`auv-mj bench --sections physics,physics3d,sonar`): the planar and the 6-DOF
physics step with their water forces against plain `mj_step` of the same compiled model, and the sonar read in open
water and among scattered walls.

Each section times its workloads side by side (`auv_mj.speed.sections.interleaved_times`) and reports the medians
and their ratios: plain `mj_step` is the limit no physics of this model can beat.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from auv_mj import model_path
from auv_mj.arenas.arena import load
from auv_mj.sim import native, native3d
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose
from auv_mj.speed.sections import BenchSettings, Measurement, interleaved_times, median_ratio, section

SUB_STEPS = 10
"""Physics steps per `AUVPhysics.step(n)` call in the batched timing (one 10 Hz executor step)."""
WALL_COUNTS = (20, 200)
"""Numbers of wall geoms in the sonar timing, besides open water."""
WALL_FIELD = 200.0
"""Side [m] of the square the timing walls are scattered in, around the vehicle."""


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
    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
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
