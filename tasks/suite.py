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
import inspect
import re
import time
from collections.abc import Callable

import numpy as np
from dm_control.rl import control

from auv_mj.inputs import did_you_mean, shown, unknown_name
from auv_mj.tasks import goal, obstacles, path_following, speed_heading, tunnel, waypoints  # noqa: F401 (registers)
from auv_mj.tasks.auv3d import DOMAIN as DOMAIN_3D
from auv_mj.tasks.auv3d import SUITE3D
from auv_mj.tasks.domains import DOMAINS
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
_REGISTRIES = {name: domain.registry for name, domain in DOMAINS.items()}


def domain_of(task_name: str) -> str:
    """The domain of a task name ("auv" or "auv3d"); ValueError naming the valid tasks for an unknown one."""
    for domain, registry in _REGISTRIES.items():
        if task_name in registry:
            return domain
    domains = "; ".join(f"{domain}: {', '.join(registry)}" for domain, registry in _REGISTRIES.items())
    raise ValueError(unknown_name("task", task_name, [*SUITE, *SUITE3D], f" (by domain: {domains})"))
TAGS = tuple(sorted(SUITE.tags()))
"""Every tag in use."""


def tasks_by_tag(tag: str) -> tuple[tuple[str, str], ...]:
    """The (domain, task) pairs carrying `tag`; ValueError for an unknown tag."""
    if tag not in TAGS:
        raise ValueError(unknown_name("tag", tag, TAGS))
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
        raise ValueError(unknown_name("domain", domain_name, _REGISTRIES))
    registry = _REGISTRIES[domain_name]
    if not isinstance(task_name, str) or task_name not in registry:
        other = [d for d, r in _REGISTRIES.items() if isinstance(task_name, str) and task_name in r]
        raise ValueError(f"task {shown(task_name)} is not in domain {domain_name!r}"
                         + (f" but in domain {other[0]!r}" if other else did_you_mean(task_name, registry))
                         + f"; valid tasks: {', '.join(registry)} (domain {domain_name!r})")
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
        unknown = re.search(r"(unexpected|multiple values for) keyword argument '([^']*)'", str(e))
        if unknown is None:
            raise
        option = unknown.group(2)
        if unknown.group(1) != "unexpected":
            raise ValueError(f"task {task_name!r}: option {option!r} is given twice (it is also set by another "
                             "option or by the command)") from None
        valid = task_options(registry[task_name], e)
        raise ValueError(f"task {task_name!r} has no option {option!r}{did_you_mean(option, valid)}; its options: "
                         f"{', '.join(valid)}") from None
    env.task.visualize_reward = visualize_reward
    return env


def task_options(factory: Callable, error: TypeError | None = None) -> list[str]:
    """The option names a task factory takes: its own keyword parameters and, where it passes `**task_kwargs` on,
    those of the functions they reach. `error` (the TypeError of an option none of them took) has their frames:
    each function it passed through, and the one that refused, found from the last frame's globals or `self`."""
    names = _parameters(factory)
    traceback = error.__traceback__ if error is not None else None
    frames = []
    while traceback is not None:
        frames.append(traceback.tb_frame)
        traceback = traceback.tb_next
    codes = [frame.f_code for frame in frames]
    start = next((i for i, code in enumerate(codes) if code is getattr(factory, "__code__", None)), len(frames))
    for frame in frames[start:]:
        code = frame.f_code
        names += code.co_varnames[:code.co_argcount + code.co_kwonlyargcount]
    refusing = re.match(r"([\w.]+)\(\)", str(error)) if error is not None else None
    if refusing and len(frames) > start:
        callee = _find(refusing.group(1), frames[-1])
        if callee is not None:
            names += _parameters(callee)
    return sorted({name for name in names if not name.startswith("_") and name not in ("self", "cls")})


def _parameters(function: Callable) -> list[str]:
    """The names `function` takes by keyword (`__init__`'s for a class)."""
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):
        return []
    return [p.name for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]


def _find(qualname: str, frame) -> Callable | None:
    """The function of `qualname` ("Class.__init__", "function") as seen from `frame`: through its globals, or
    the MRO of its `self` (a `super().__init__(**kwargs)`)."""
    first, *rest = qualname.split(".")
    owner = frame.f_globals.get(first)
    if owner is None and "self" in frame.f_locals:
        owner = next((c for c in type(frame.f_locals["self"]).__mro__ if c.__name__ == first), None)
    for part in rest:
        owner = getattr(owner, part, None)
    return owner if callable(owner) else None


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
