"""The auv-mj task suite, dm_control style: `load("auv", "goal")`, `ALL_TASKS`, tags.

Every planar task lives in the domain "auv" and is registered in `auv_mj.tasks.registry.SUITE` by its module:
goal, waypoints, obstacles, moving_obstacles, tunnel, path_line, path_curve (planning, one step per
0.5 s planner decision) and speed_heading (execution, one step per 0.1 s executor tick). The 6-DOF vehicle's
tasks (depth_heading, goal3d, tunnel3d) are the domain "auv3d" (`auv_mj.tasks.auv3d.SUITE3D`): `load("auv3d", ...)`;
`ALL_TASKS` and `domain_of` cover both domains; `PLANAR_TASKS`, BENCHMARKING and `tasks_by_tag` are the planar
domain's, `TASKS_3D` the 6-DOF one's.

`python -m auv_mj.tasks.suite [--steps N]` prints each task's environment steps per second under random actions.
"""

from __future__ import annotations

import argparse
import re
import time

import numpy as np
from dm_control.rl import control

from auv_mj.tasks import goal, obstacles, path_following, speed_heading, tunnel, waypoints  # noqa: F401 (registers)
from auv_mj.tasks.auv3d import DOMAIN as DOMAIN_3D
from auv_mj.tasks.auv3d import SUITE3D
from auv_mj.tasks.registry import SUITE

DOMAIN = "auv"
"""The suite's only domain."""

PLANAR_TASKS = tuple((DOMAIN, name) for name in SUITE)
"""Every (domain, task) pair of the planar domain "auv" (the paper's)."""
BENCHMARKING = tuple((DOMAIN, name) for name in SUITE.tagged("benchmarking"))
"""The (domain, task) pairs tagged "benchmarking"."""
TASKS_BY_DOMAIN = {DOMAIN: tuple(SUITE), DOMAIN_3D: tuple(SUITE3D)}
"""Domain -> its task names."""
TASKS_3D = tuple((DOMAIN_3D, name) for name in SUITE3D)
"""Every (domain, task) pair of the 6-DOF domain "auv3d"."""
ALL_TASKS = PLANAR_TASKS + TASKS_3D
"""Every (domain, task) pair of both domains, as dm_control's `suite.ALL_TASKS`."""
_REGISTRIES = {DOMAIN: SUITE, DOMAIN_3D: SUITE3D}


def domain_of(task_name: str) -> str:
    """The domain of a task name ("auv" or "auv3d"); ValueError naming the valid tasks for an unknown one."""
    for domain, registry in _REGISTRIES.items():
        if task_name in registry:
            return domain
    raise ValueError(f"task {task_name!r} does not exist; valid tasks: {', '.join([*SUITE, *SUITE3D])}")
TAGS = tuple(sorted(SUITE.tags()))
"""Every tag in use."""


def tasks_by_tag(tag: str) -> tuple[tuple[str, str], ...]:
    """The (domain, task) pairs carrying `tag`; ValueError for an unknown tag."""
    if tag not in TAGS:
        raise ValueError(f"unknown tag {tag!r}; valid tags: {', '.join(TAGS)}")
    return tuple((DOMAIN, name) for name in SUITE.tagged(tag))


def load(domain_name: str, task_name: str, task_kwargs: dict | None = None,
         environment_kwargs: dict | None = None, visualize_reward: bool = False) -> control.Environment:
    """The environment of `task_name` in `domain_name` ("auv"), as `dm_control.suite.load`.

    `task_kwargs` go to the task's factory (e.g. {"random": 0, "reward": "paper", "scenario": "a"}; every
    task takes "conditions": "ideal" (default), "ocean" or a mapping of effects, see `auv_mj.sim.ocean`);
    `environment_kwargs` to `control.Environment`. Raises ValueError naming the valid choices, or the option
    the task refuses (`auv_mj.tasks.options`).
    """
    if domain_name not in _REGISTRIES:
        raise ValueError(f"domain {domain_name!r} does not exist; valid domains: {', '.join(_REGISTRIES)}")
    registry = _REGISTRIES[domain_name]
    if not isinstance(task_name, str) or task_name not in registry:
        raise ValueError(f"task {task_name!r} does not exist in domain {domain_name!r}; "
                         f"valid tasks: {', '.join(registry)}")
    if task_kwargs is not None and not isinstance(task_kwargs, dict):
        raise ValueError(f"task_kwargs must be a dict of task options, got {type(task_kwargs).__name__}")
    task_kwargs = dict(task_kwargs or {})
    if not all(isinstance(key, str) for key in task_kwargs):
        raise ValueError(f"task option names must be strings, got {sorted(map(repr, task_kwargs))[:5]}")
    if environment_kwargs is not None:
        task_kwargs["environment_kwargs"] = environment_kwargs
    try:
        env = registry[task_name](**task_kwargs)
    except TypeError as e:  # an option the task does not take: a bad option, as any other
        unknown = re.search(r"keyword argument '([^']*)'", str(e))
        if unknown is None:
            raise
        raise ValueError(f"task {task_name!r} has no option {unknown.group(1)!r} (or it is given twice)") from None
    env.task.visualize_reward = visualize_reward
    return env


def steps_per_second(task_name: str, steps: int = 2000, seed: int = 0) -> float:
    """Environment steps per second of `task_name` under uniform random actions (resets included)."""
    env = load(DOMAIN, task_name, task_kwargs={"random": seed})
    spec = env.action_spec()
    actions = np.random.RandomState(seed)
    step = env.reset()
    start = time.perf_counter()
    for _ in range(steps):
        action = actions.uniform(spec.minimum, spec.maximum, spec.shape)
        step = env.reset() if step.last() else env.step(action)
    return steps / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> int:
    """Prints steps/s of every task (`python -m auv_mj.tasks.suite`)."""
    parser = argparse.ArgumentParser(prog="python -m auv_mj.tasks.suite", description=steps_per_second.__doc__)
    parser.add_argument("--steps", type=int, default=2000, help="environment steps per task")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("tasks", nargs="*", default=list(SUITE), help="task names (default: all)")
    args = parser.parse_args(argv)
    for name in args.tasks:
        env = load(DOMAIN, name)
        rate = steps_per_second(name, args.steps, args.seed)
        print(f"{name:18s} {rate:8.0f} steps/s  ({rate * env.control_timestep():7.0f}x real time, "
              f"step {env.control_timestep():g} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
