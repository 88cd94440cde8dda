"""The batched 6-DOF env's C step alone, on 1 and 2 threads: how well the physics itself scales, resets aside.

    python docs/runs/vector3d-bench/c_step_scaling.py goal3d      # or tunnel3d

N = 256 vehicles flying `auv_mj.speed.vector3d.follow` with a time limit of 1,000 s (few resets), 1 and 2 threads
twice in turn, 4 s each; prints the env steps/s, the C step's share of the wall time and the C step's own rate
(vehicle steps per second of C time).
"""

from __future__ import annotations

import sys
import time

from auv_mj.speed.vector3d import follow
from auv_mj.tasks.vector3d import AUV3DVectorEnv

SIZE, SECONDS = 256, 4.0


def main(task: str) -> None:
    env = AUV3DVectorEnv(task, SIZE, {"arena": "random", "time_limit": 1000.0})
    observation = env.reset(seed=0)[0]["observation"]
    stepper, step = env._stepper, env._stepper.step
    timings: list[tuple[float, int]] = []

    def timed_step(index, *args) -> None:
        start = time.perf_counter()
        step(index, *args)
        timings.append((time.perf_counter() - start, len(index)))

    stepper.step = timed_step
    for threads in (1, 2, 1, 2):
        env.threads = threads
        timings.clear()
        start, steps = time.perf_counter(), 0
        while time.perf_counter() - start < SECONDS:
            observation = env.step(follow(observation))[0]["observation"]
            steps += 1
        wall = time.perf_counter() - start
        c_time = sum(t for t, _ in timings)
        vehicles = sum(n for _, n in timings)
        print(f"{threads} thread(s): {steps * SIZE / wall:.0f} env steps/s, C step {c_time / wall:.2f} of the wall "
              f"time, {vehicles / c_time:.0f} vehicle steps per C second")
    env.close()


if __name__ == "__main__":
    main(sys.argv[1])
