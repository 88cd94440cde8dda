"""The shipped planar student driving one validation episode, `map-replan` and the privileged teacher labelling it.

    python docs/runs/planner-learned/teacher_labels.py tunnel hard ideal 27025 [MAX_STEPS]

`map-replan` runs beside the student as DAgger's teacher does (`auv_mj.jobs.student.planar_map_replan`: called at
every step, its sonar map built from the student's flight, its action read in the student's rate action map), and
so does the privileged `geodesic-teacher` (the true map). Prints the vehicle's position, heading and the three actions
(speed, heading rate, each in [-1, 1]) at 60 points of the episode, then for three spans of it: how often each heading
action is saturated (|a1| > 0.95), how often the student's and `map-replan`'s agree in sign,
and their mean turn. Validation seeds only (`auv_mj.seeds.VALIDATION`).
"""

from __future__ import annotations

import sys

import numpy as np

from auv_mj.jobs.student import planar_map_replan
from auv_mj.seeds import VALIDATION
from auv_mj.zoo import registry as policies


def main(task: str, tier: str, water: str, seed: int, max_steps: int = 1500) -> None:
    if seed not in VALIDATION:
        raise ValueError(f"seed {seed} is not a validation seed (auv_mj.seeds.VALIDATION)")
    env = policies.make_env("planner-learned", task, seed, arena="random", tier=tier, conditions=water)
    student = policies.make_policy("planner-learned", env, seed, task)
    teacher = planar_map_replan(env)
    privileged = policies.make_policy("geodesic-teacher", env, seed, task)
    time_step = env.reset()
    for planner in (student, teacher, privileged):
        planner.reset()
    rows = []
    while not time_step.last() and len(rows) < max_steps:
        action = np.asarray(student.act(time_step), dtype=float).ravel()
        label = np.asarray(teacher.act(time_step), dtype=float).ravel()
        known = np.asarray(privileged.act(time_step), dtype=float).ravel()
        x, y, psi = env.physics.pose()
        rows.append([len(rows), x, y, np.degrees(psi), *action, *label, *known])
        time_step = env.step(action)
    table = np.array(rows)
    for r in table[::max(1, len(table) // 60)]:
        print(f"step {int(r[0]):5d}  ({r[1]:7.1f}, {r[2]:7.1f})  psi {r[3]:7.0f}  student {r[4]:+.2f} {r[5]:+.2f}  "
              f"map-replan {r[6]:+.2f} {r[7]:+.2f}  privileged {r[8]:+.2f} {r[9]:+.2f}")
    third = len(table) // 3
    for lo, hi in ((0, third), (third, 2 * third), (2 * third, len(table))):
        part = table[lo:hi]
        if len(part):
            saturated = [np.mean(np.abs(part[:, k]) > 0.95) for k in (5, 7, 9)]
            agree = np.mean(np.sign(part[:, 5]) == np.sign(part[:, 7]))
            print(f"steps {lo}-{hi}: saturated heading, student {saturated[0]:.2f}, map-replan {saturated[1]:.2f}, "
                  f"privileged {saturated[2]:.2f}; same sign {agree:.2f}; "
                  f"mean turn, student {part[:, 5].mean():+.2f}, map-replan {part[:, 7].mean():+.2f}")
    print("ended:", env.task.last_info.get("event", "") or ("timeout" if time_step.last() else "cut"))


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], args[1], args[2], int(args[3]), *(int(a) for a in args[4:5]))
