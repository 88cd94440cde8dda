"""How fast the batched 6-DOF env runs (`vector3d_bench`), beside the 6-DOF physics limit.

Rows (environment steps per second, autoresets included), as the planar `auv_mj.speed.vector`'s:
- "physics limit": plain `mujoco.mj_step` of the task's models, PHYSICS_STEPS (50) steps per environment step, one
  thread, no hydrodynamics, no executor, no sensors, no task: what no environment of these models can beat per core.
  The 3-D arenas differ in size (a tube is hundreds of wall geoms), so the limit is taken round the models of
  LIMIT_ARENAS episodes' arenas, as the batch meets many; each vehicle is put back at its episode's start before its
  50 steps (with no water to hold it up it would sink onto the wall, and solving that contact is no work of the
  limit's, as `auv_mj.speed.sim`'s physics3d section keeps its plain vehicle from falling);
- "batch N=.., threads=..": `auv_mj.tasks.vector3d.AUV3DVectorEnv` for each size and thread count, under two kinds of
  actions: "random" (uniform in the action box, as the planar bench; a 3-D vehicle driven so broaches or hits the wall
  within a minute, so that the episodes' resets, each drawing and compiling its arena in Python, weigh heavily) and
  "follow" (1.2 m/s towards the observation's target, its bearing and depth: episodes that last, as a trained
  planner's do; the step's own rate).
The machine's load average is recorded beside the figures, and the CPU the process had while a batch was timed
("cpu": its CPU seconds over the wall seconds): on a shared machine the figures move with them, and a batch on 2 threads
can only run faster than on 1 where the process gets more than one CPU.

`python -m auv_mj.speed.vector3d [--task tunnel3d] [--seconds 2]` prints the table;
`auv-mj bench --sections vector3d` (`vector3d_section`) reports the rows of tunnel3d and goal3d.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from auv_mj.speed.sections import BenchSettings, Measurement, section
from auv_mj.speed.vector import PHYSICS_STEPS, SIZES, THREADS, _timed
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks.vector3d import AUV3DVectorEnv

LIMIT_ARENAS = 8
"""Arenas (seeds 0..7) round which the physics limit is taken."""
ACTIONS = ("random", "follow")
"""The kinds of actions of the batch's rows (module docstring)."""
FOLLOW_SPEED = 0.2
"""The follow actions' speed action: 0.6 of the speed range, 1.2 m/s."""


def physics_limit(task: str, task_kwargs: Mapping[str, Any], seconds: float) -> float:
    """Environment steps per second of plain `mj_step` (PHYSICS_STEPS per environment step) round the models of
    LIMIT_ARENAS episodes of the task."""
    vehicles = []
    for seed in range(LIMIT_ARENAS):
        env = suite.load(auv3d.DOMAIN, task, task_kwargs={**task_kwargs, "random": seed})
        env.reset()
        data = env.physics.data.ptr
        vehicles.append((env.physics.model.ptr, data, data.qpos.copy(), data.qvel.copy()))
    counter = iter(range(1 << 62))

    def step() -> None:
        model, data, qpos, qvel = vehicles[next(counter) % len(vehicles)]
        data.qpos[:], data.qvel[:] = qpos, qvel  # without the water's forces it would sink onto the wall
        mujoco.mj_step(model, data, PHYSICS_STEPS)

    return _timed(step, seconds, 1)


def follow(observation: np.ndarray) -> np.ndarray:
    """The follow actions (module docstring) from a batch of planning observations (`auv3d.PLANNING_OBSERVATION`)."""
    target = observation[:, auv3d.TARGET_ENTRIES]
    bearing = np.arctan2(target[:, 2], target[:, 1])
    return np.column_stack([np.full(len(observation), FOLLOW_SPEED),
                            np.clip(bearing / auv3d.HEADING_RANGE, -1.0, 1.0),
                            np.clip(target[:, 3] / auv3d.DEPTH_RANGE, -1.0, 1.0)])


def timed_with_cpu(step, seconds: float, per_call: int) -> tuple[float, float]:
    """`auv_mj.speed.vector._timed`'s rate of `step`, and the CPU this process had meanwhile (CPU s / wall s)."""
    step()
    calls, start, cpu = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - start < seconds:
        step()
        calls += 1
    wall = time.perf_counter() - start
    return calls * per_call / wall, (time.process_time() - cpu) / wall


def batch_rates(task: str, task_kwargs: Mapping[str, Any], size: int, threads: Sequence[int], seconds: float,
                kinds: Sequence[str] = ACTIONS, seed: int = 0) -> dict[tuple[str, int], tuple[float, float]]:
    """Environment steps per second of one `AUV3DVectorEnv` of `size` under each kind of actions (ACTIONS) on each
    count of `threads`, each timed from a reset with `seed`, and the CPU the process had (`timed_with_cpu`):
    {(kind, threads): (rate, cpu)}."""
    env = AUV3DVectorEnv(task, size, task_kwargs)
    batches = np.random.default_rng(seed).uniform(-1.0, 1.0, (64, size, 3))
    rates = {}
    for kind in kinds:
        for count in threads:
            env.threads = count
            observation, _ = env.reset(seed=seed)
            counter = iter(range(1 << 62))
            last = [observation["observation"]]

            def step(kind=kind, counter=counter, last=last) -> None:
                actions = batches[next(counter) % len(batches)] if kind == "random" else follow(last[0])
                last[0] = env.step(actions)[0]["observation"]

            rates[kind, count] = timed_with_cpu(step, seconds, size)
    env.close()
    return rates


def vector3d_bench(task: str = "tunnel3d", task_kwargs: Mapping[str, Any] | None = None,
                   sizes: Sequence[int] = SIZES, threads: Sequence[int] = THREADS, seconds: float = 2.0,
                   kinds: Sequence[str] = ACTIONS) -> list[dict[str, Any]]:
    """The rows of the module docstring: dicts with "name", "steps_per_second", "ratio" to the physics limit, the
    1-minute load average ("load") and, for the batch, the CPU the process had ("cpu")."""
    task_kwargs = {"arena": "random"} if task_kwargs is None else dict(task_kwargs)
    rows = []

    def row(name: str, rate: float, **extra) -> None:
        rows.append({"name": name, "steps_per_second": rate, "load": os.getloadavg()[0], **extra})

    limit = physics_limit(task, task_kwargs, seconds)
    row("physics limit (mj_step x50, 1 thread)", limit)
    for size in sizes:
        for (kind, count), (rate, cpu) in batch_rates(task, task_kwargs, size, threads, seconds, kinds).items():
            row(f"batch {kind} N={size} threads={count}", rate, size=size, threads=count, kind=kind, cpu=cpu)
    for r in rows:
        r["ratio"] = r["steps_per_second"] / limit
    return rows


VECTOR3D_CASES = {"tunnel3d": {"arena": "random"}, "goal3d": {"arena": "random"}}
"""Tasks (and options) of the "vector3d" section: procedural tubes and open water with obstacles."""


@section("vector3d", on_request=True)
def vector3d_section(settings: BenchSettings) -> list[Measurement]:
    """The batched 6-DOF environment (`auv_mj.tasks.vector3d`): env steps/s for N in {1, 16, 64, 256} on 1 and 2
    threads, under random and follow actions, beside the 6-DOF physics limit (plain `mj_step`, 50 substeps per env
    step, one thread), for tunnel3d and goal3d; and the ratios of the issue's targets at N = 256."""
    seconds = max(0.5, 2.0 * settings.scale)
    measurements = []
    for task, task_kwargs in VECTOR3D_CASES.items():
        rows = vector3d_bench(task, task_kwargs, seconds=seconds)
        for r in rows:
            cpu = f", {r['cpu']:.2f} CPU" if "cpu" in r else ""
            measurements.append(Measurement(f"{task}: {r['name']}", r["steps_per_second"], "env steps/s",
                                            f"{r['ratio']:.2f} of the physics limit, load {r['load']:.1f}{cpu}"))
        by_name = {r["name"]: r for r in rows}
        for kind in ACTIONS:
            one, two = (by_name[f"batch {kind} N=256 threads={t}"] for t in (1, 2))
            measurements.append(Measurement(f"{task}: {kind}, N=256, 1 thread / the physics limit", one["ratio"],
                                            "x", "target >= 0.6"))
            measurements.append(Measurement(f"{task}: {kind}, N=256, 2 threads / 1 thread",
                                            two["steps_per_second"] / one["steps_per_second"], "x",
                                            f"target >= 1.7; the process had {one['cpu']:.2f} and {two['cpu']:.2f} "
                                            "CPU"))
    return measurements


def format_rows(rows: Sequence[Mapping[str, Any]]) -> str:
    """The rows as a text table."""
    lines = [f"{'':44s} {'steps/s':>9s} {'/limit':>7s} {'load':>5s} {'cpu':>5s}"]
    lines += [f"{r['name']:44s} {r['steps_per_second']:9.0f} {r['ratio']:7.2f} {r['load']:5.2f} "
              f"{r.get('cpu', float('nan')):5.2f}" for r in rows]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="tunnel3d", choices=tuple(VECTOR3D_CASES))
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--conditions", default="ideal", choices=("ideal", "ocean"))
    parser.add_argument("--tier", default=None, choices=auv3d.TIERS)
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--threads", type=int, nargs="+", default=list(THREADS))
    parser.add_argument("--actions", nargs="+", default=list(ACTIONS), choices=ACTIONS)
    args = parser.parse_args(argv)
    task_kwargs: dict[str, Any] = {"arena": "random", "conditions": args.conditions}
    if args.tier is not None:
        task_kwargs["tier"] = args.tier
    print(f"vector3d bench: task {args.task} {task_kwargs}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print(format_rows(vector3d_bench(args.task, task_kwargs, args.sizes, args.threads, args.seconds, args.actions)))


if __name__ == "__main__":
    main()
