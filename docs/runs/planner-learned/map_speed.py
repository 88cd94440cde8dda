"""Vehicle steps a second of the student's 56-vehicle mixture (LEARNED_MIXTURE, 4 a cell before the weights) under
the planner observation and under planner-map (the sonar map kept and cast every step), one physics thread, the same
steering action for 100 steps after a reset. Run it on an idle machine.

    python docs/runs/planner-learned/map_speed.py [STEPS]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from auv_mj.jobs.student import student_mixture


def main(steps: int = 100) -> None:
    for observation in ("planner", "planner-map"):
        env = student_mixture(4, None, observation).make_env(1)
        try:
            env.reset(seed=0)
            action = np.zeros((env.num_envs, 2))
            action[:, 0] = 0.8
            start = time.perf_counter()
            for _ in range(steps):
                env.step(action)
            elapsed = time.perf_counter() - start
        finally:
            env.close()
        print(f"{observation}: {env.num_envs} vehicles, {steps * env.num_envs / elapsed:.0f} vehicle steps/s")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
