"""How fast the batched planning env runs (`vector_bench`), beside the physics limit and process-parallel vectors.

Rows (environment steps per second, random actions, autoresets included):
- "physics limit": plain `mujoco.mj_step` of the same task's model, PHYSICS_STEPS (50) steps per environment step,
  one thread, no hydrodynamics, no executor, no task: what no environment of this model can beat per core;
- "batch N=.., threads=..": `auv_mj.tasks.vector.AUVVectorEnv`, for each size and thread count;
- "AsyncVectorEnv" and "SubprocVecEnv": Gymnasium's and Stable-Baselines3's process vectors of `AUVGymEnv` on
  `processes` processes;
- "rss": the batch's resident memory over many steps (it should stay flat).
The machine's load average is recorded beside the figures: on a shared machine they move with it.

`python -m auv_mj.speed.vector [--task obstacles] [--seconds 2]` prints the table.
`auv-mj bench --sections vector` (`vector_section`) reports these rows for open water and the hard tier, beside
recurrent PPO's samples/s end to end over one checkpoint cycle.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from auv_mj.speed.sections import BenchSettings, Measurement, section
from auv_mj.tasks import suite
from auv_mj.tasks.gym_adapter import AUVGymEnv
from auv_mj.tasks.vector import AUVVectorEnv

SIZES = (1, 16, 64, 256)
"""Batch sizes measured."""
THREADS = (1, 2)
"""Thread counts measured."""
PHYSICS_STEPS = 50
"""Physics steps of one environment step (0.5 s of 0.01 s steps)."""
MEMORY_STEPS = 2_000
"""Batch steps over which the resident memory is followed."""
MEMORY_SIZE = 16
"""Batch size of the memory run."""


def rss_bytes() -> int:
    """This process's resident memory [bytes] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _timed(step, seconds: float, per_call: int) -> float:
    """Calls `step()` for about `seconds` (after one warm-up call); environment steps per second."""
    step()
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        step()
        calls += 1
    return calls * per_call / (time.perf_counter() - start)


def physics_limit(task: str, task_kwargs: Mapping[str, Any], seconds: float) -> float:
    """Environment steps per second of plain `mj_step` (PHYSICS_STEPS per environment step) of the task's model."""
    env = suite.load(suite.DOMAIN, task, task_kwargs=dict(task_kwargs))
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    return _timed(lambda: mujoco.mj_step(model, data, PHYSICS_STEPS), seconds, 1)


def _random_actions(env: AUVVectorEnv, seed: int) -> np.ndarray:
    """64 batches of uniform random actions in the env's action box, cycled through by the timed loops."""
    space = env.action_space
    return np.random.default_rng(seed).uniform(space.low, space.high, (64, *space.shape))


def batch_rate(task: str, task_kwargs: Mapping[str, Any], size: int, threads: int, seconds: float,
               seed: int = 0) -> float:
    """Environment steps per second of an `AUVVectorEnv` of `size` on `threads` threads, random actions."""
    env = AUVVectorEnv(task, size, task_kwargs, threads=threads)
    env.reset(seed=seed)
    actions = _random_actions(env, seed)
    counter = iter(range(1 << 62))
    rate = _timed(lambda: env.step(actions[next(counter) % len(actions)]), seconds, size)
    env.close()
    return rate


def cycle_rate(task: str, task_kwargs: Mapping[str, Any], size: int, threads: int, seeds: Sequence[int],
               steps_per_env: int, seed: int = 0) -> float:
    """Environment steps per second of an `AUVVectorEnv` of `size` on `threads` threads over one training cycle:
    the reset of every env with `seeds` (timed: a learner meets it at each of its checkpoints), then
    `steps_per_env` steps of uniform random actions with their autoresets.

    The batch's own rate over the very work that a learner's cycle asks of it, so that the two are compared like
    for like. `batch_rate`'s window of a few seconds is not that: it runs on other arenas (a step's cost depends on
    the arena) and holds few of the episodes' ends and resets (at N = 256 and 2 s, 128 steps a vehicle, it read
    37 % above the cycle's rate)."""
    if len(seeds) != size:
        raise ValueError(f"cycle_rate needs one seed per env: {len(seeds)} seeds for {size} envs")
    env = AUVVectorEnv(task, size, task_kwargs, threads=threads)
    env.reset(seed=list(seeds))  # untimed, as a learner's warm-up run before its timed cycle
    actions = _random_actions(env, seed)
    start = time.perf_counter()
    env.reset(seed=list(seeds))
    for k in range(steps_per_env):
        env.step(actions[k % len(actions)])
    rate = size * steps_per_env / (time.perf_counter() - start)
    env.close()
    return rate


def process_rate(kind: str, task: str, task_kwargs: Mapping[str, Any], processes: int, seconds: float) -> float:
    """Environment steps per second of Gymnasium's AsyncVectorEnv ("async") or SB3's SubprocVecEnv ("subproc") of
    `processes` AUVGymEnv processes, random actions."""
    def make():
        return AUVGymEnv(task, dict(task_kwargs))

    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (64, processes, 2)).astype(np.float32)
    counter = iter(range(1 << 62))
    if kind == "async":
        import gymnasium

        env = gymnasium.vector.AsyncVectorEnv([make] * processes)
        env.reset(seed=0)
        rate = _timed(lambda: env.step(actions[next(counter) % len(actions)]), seconds, processes)
    else:
        from stable_baselines3.common.vec_env import SubprocVecEnv

        env = SubprocVecEnv([make] * processes)
        env.reset()
        rate = _timed(lambda: env.step(actions[next(counter) % len(actions)]), seconds, processes)
    env.close()
    return rate


def memory_run(task: str, task_kwargs: Mapping[str, Any], steps: int = MEMORY_STEPS,
               size: int = MEMORY_SIZE) -> tuple[int, int]:
    """Resident memory [bytes] after a tenth of `steps` batch steps and after all of them."""
    env = AUVVectorEnv(task, size, task_kwargs)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    early = 0
    for k in range(steps):
        env.step(rng.uniform(-1.0, 1.0, (size, 2)))
        if k == steps // 10:
            early = rss_bytes()
    late = rss_bytes()
    env.close()
    return early, late


def vector_bench(task: str = "goal", task_kwargs: Mapping[str, Any] | None = None, sizes: Sequence[int] = SIZES,
                 threads: Sequence[int] = THREADS, seconds: float = 2.0, processes: int = 2,
                 memory_steps: int = MEMORY_STEPS) -> list[dict[str, Any]]:
    """The rows of the module docstring: dicts with "name", "steps_per_second" (or "rss_early"/"rss_late" [bytes]),
    "ratio" to the physics limit, and the 1-minute load average when measured ("load")."""
    if task_kwargs is None:
        task_kwargs = {} if task == "goal" else {"arena": "random"}
    rows = []

    def row(name: str, rate: float, **extra) -> None:
        rows.append({"name": name, "steps_per_second": rate, "load": os.getloadavg()[0], **extra})

    limit = physics_limit(task, task_kwargs, seconds)
    row("physics limit (mj_step x50, 1 thread)", limit)
    for size in sizes:
        for count in threads:
            row(f"batch N={size} threads={count}", batch_rate(task, task_kwargs, size, count, seconds),
                size=size, threads=count)
    if processes:
        row(f"AsyncVectorEnv ({processes} processes)", process_rate("async", task, task_kwargs, processes, seconds))
        row(f"SubprocVecEnv ({processes} processes)", process_rate("subproc", task, task_kwargs, processes, seconds))
    for r in rows:
        r["ratio"] = r["steps_per_second"] / limit
    if memory_steps:
        early, late = memory_run(task, task_kwargs, memory_steps)
        rows.append({"name": f"rss N={MEMORY_SIZE} after {memory_steps // 10} and {memory_steps} steps",
                     "rss_early": early, "rss_late": late, "load": os.getloadavg()[0]})
    return rows


def format_rows(rows: Sequence[Mapping[str, Any]]) -> str:
    """The rows as a text table."""
    lines = [f"{'':44s} {'steps/s':>9s} {'/limit':>7s} {'load':>5s}"]
    for r in rows:
        if "rss_early" in r:
            lines.append(f"{r['name']:44s} {r['rss_early'] / 2**20:7.1f} -> {r['rss_late'] / 2**20:.1f} MiB "
                         f"{r['load']:5.2f}")
        else:
            lines.append(f"{r['name']:44s} {r['steps_per_second']:9.0f} {r['ratio']:7.2f} {r['load']:5.2f}")
    return "\n".join(lines)


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
The batch alone is timed over the same cycle (`cycle_rate`: the same resets, as many steps, random
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


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="goal", choices=("goal", "obstacles", "moving_obstacles", "tunnel"))
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--conditions", default="ideal", choices=("ideal", "ocean"))
    parser.add_argument("--tier", default=None, choices=("standard", "hard"))
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--threads", type=int, nargs="+", default=list(THREADS))
    args = parser.parse_args(argv)
    task_kwargs: dict[str, Any] = {"conditions": args.conditions}
    if args.task != "goal":
        task_kwargs["arena"] = "random"
    if args.tier is not None:
        task_kwargs["tier"] = args.tier
    print(f"vector bench: task {args.task} {task_kwargs}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print(format_rows(vector_bench(args.task, task_kwargs, args.sizes, args.threads, args.seconds)))


if __name__ == "__main__":
    main()
