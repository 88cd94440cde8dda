"""The shipped 3-D student driving one validation episode, the teacher labelling each of its states.

    EXECUTOR=splane-ocean python docs/runs/planner-learned-3d/teacher_labels.py goal3d standard ocean 28047

Prints, every second step, the vehicle's position and the two actions (speed, heading offset, depth offset, each in
[-1, 1]): the student's, which the episode flies, and the geodesic teacher's on the same state (what DAgger would have
labelled it with); then how the episode ended. Validation seeds only (`auv_mj.seeds.VALIDATION`).
"""

from __future__ import annotations

import os
import sys

import numpy as np

from auv_mj.zoo import registry as policies


def main(task: str, tier: str, water: str, seed: int) -> None:
    executor = {"executor": os.environ["EXECUTOR"]} if os.environ.get("EXECUTOR") else {}
    env = policies.make_env("planner-learned", task, seed, arena="random", tier=tier, conditions=water, **executor)
    student = policies.make_policy("planner-learned", env, seed, task)
    teacher = policies.make_policy("geodesic-teacher", env, seed, task)
    time_step = env.reset()
    student.reset()
    teacher.reset()
    step = 0
    while not time_step.last():
        action = np.asarray(student.act(time_step), dtype=float).ravel()
        label = np.asarray(teacher.act(time_step), dtype=float).ravel()
        if step % 2 == 0:
            print(f"step {step:3d}  position {np.round(env.physics.position(), 1)}  student {np.round(action, 2)}  "
                  f"teacher {np.round(label, 2)}")
        time_step = env.step(action)
        step += 1
    print("ended:", env.task.last_info.get("event", "") or "timeout")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]))
