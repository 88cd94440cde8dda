"""A batched env at N = 256 with its autoresets after the C step and beside it, alternately, in one process.

`python docs/runs/vector3d-bench/overlap_ab.py TASK KIND` (TASK goal3d or tunnel3d, KIND random or follow, as in
`auv_mj.speed.vector3d`; or a planar task, e.g. obstacles, with KIND random: the planar `AUVVectorEnv`): 3 repeats
of 5 s each of 1 thread, 2 threads with the resets after the step (the serial order, put in place of
`GoalVectorEnv._physics_alongside`), and 2 threads with the resets beside it (main); prints each timing and the
means with their ratio to 1 thread.
"""

from __future__ import annotations

import sys

import numpy as np

from auv_mj.speed.vector3d import follow, timed_with_cpu
from auv_mj.tasks.vector import AUVVectorEnv, GoalVectorEnv
from auv_mj.tasks.vector3d import TASKS as TASKS_3D
from auv_mj.tasks.vector3d import AUV3DVectorEnv

SIZE, REPEATS, SECONDS = 256, 3, 5.0


def serial(self, index, physics, alongside) -> None:
    """The order before: the resets, then the step, on the calling thread."""
    if alongside is not None:
        alongside()
    physics()


def main(task: str, kind: str) -> None:
    if task in TASKS_3D:
        env = AUV3DVectorEnv(task, SIZE, {"arena": "random"})
    elif kind == "random":
        env = AUVVectorEnv(task, SIZE, {"arena": "random"})
    else:
        raise ValueError(f"a planar task runs KIND random only, got {kind!r}")
    beside = GoalVectorEnv._physics_alongside
    batches = np.random.default_rng(0).uniform(-1.0, 1.0, (64, SIZE, *env.single_action_space.shape))
    rates: dict[tuple[str, int], list[float]] = {}
    for repeat in range(REPEATS):
        for name, threads, method in (("serial", 1, serial), ("after", 2, serial), ("beside", 2, beside)):
            GoalVectorEnv._physics_alongside = method
            env.threads = threads
            observation, _ = env.reset(seed=repeat)
            last = [observation["observation"]]
            counter = iter(range(1 << 60))

            def step(last=last, counter=counter) -> None:
                actions = batches[next(counter) % len(batches)] if kind == "random" else follow(last[0])
                last[0] = env.step(actions)[0]["observation"]

            rate, cpu = timed_with_cpu(step, SECONDS, SIZE)
            rates.setdefault((name, threads), []).append(rate)
            print(f"repeat {repeat}: {name}, {threads} thread(s): {rate:.0f} env steps/s, {cpu:.2f} CPU", flush=True)
    one = np.mean(rates["serial", 1])
    for (name, threads), values in rates.items():
        print(f"{name}, {threads} thread(s): {np.mean(values):.0f} env steps/s, {np.mean(values) / one:.2f}x")
    env.close()


if __name__ == "__main__":
    main(*sys.argv[1:3])
