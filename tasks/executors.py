"""Executors by name: what a planning task's `executor` option takes, besides a callable.

    suite.load("auv", "tunnel", task_kwargs={"executor": "ocean-executor"})

The S-planes (Eq. 32, and its gains re-tuned in ocean water) are built here. The learned executors are policies, a
layer above the tasks, so they are named by entry point, a "module:function" string loaded on first use, as
Gymnasium's registry names environments: the tasks import no policy, yet every executor name resolves wherever the
tasks are used. A speed_heading checkpoint file resolves through CHECKPOINT_EXECUTOR.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from pathlib import Path
from typing import Any

from auv_mj.tasks import options as checks
from auv_mj.tasks.auv3d_control import OCEAN_DEPTH_GAINS, DepthHeadingController
from auv_mj.tasks.splane import OCEAN_GAINS, SPlaneController

Executor = Callable[[Any, Any], Any]
"""`executor(command, state) -> (tau_u, tau_r)`, with `reset()` where it keeps state."""

EXECUTORS: dict[str, Callable[[], Executor] | str] = {
    "splane": SPlaneController,
    "splane-ocean": lambda: SPlaneController(OCEAN_GAINS),
    "executor": "auv_mj.zoo.registry:paper_executor",
    "ocean-executor": "auv_mj.zoo.registry:ocean_executor",
}
"""Executor name -> a function making it, or the entry point ("module:function") of one."""
CHECKPOINT_EXECUTOR = "auv_mj.zoo.registry:learned_executor"
"""Entry point of `function(path) -> executor` for a speed_heading checkpoint file given as the executor."""
EXECUTORS_3D: dict[str, Callable[[], Executor] | str] = {
    "splane": DepthHeadingController,
    "splane-ocean": lambda: DepthHeadingController(OCEAN_DEPTH_GAINS),
    "depth-executor": "auv_mj.zoo.registry:depth_executor",
}
"""The same on the 6-DOF planning tasks (goal3d, tunnel3d): the depth-heading S-plane, re-tuned in ocean water
(`OCEAN_DEPTH_GAINS`), or the learned depth executor."""
CHECKPOINT_EXECUTOR_3D = "auv_mj.zoo.registry:learned_depth_executor"
"""Entry point of `function(path) -> executor` for a depth_heading checkpoint file given as a 6-DOF executor."""


def register_executor(name: str, make: Callable[[], Executor] | str) -> None:
    """Adds an executor name (a function making it, or its "module:function" entry point); a name is added once."""
    if name in EXECUTORS:
        raise ValueError(f"executor {name!r} is registered twice")
    EXECUTORS[name] = make


def _load(entry_point: str) -> Callable:
    module, _, function = entry_point.partition(":")
    return getattr(import_module(module), function)


def named_executor(name: str, three_d: bool = False) -> Executor:
    """The executor `name` (one of EXECUTORS, or a speed_heading checkpoint path; with `three_d`, of a 6-DOF task,
    one of EXECUTORS_3D or a depth_heading checkpoint path); ValueError naming it otherwise."""
    table = EXECUTORS_3D if three_d else EXECUTORS
    if not isinstance(name, str):
        raise ValueError(f"executor: a name of {list(table)}, a checkpoint path or a callable, got "
                         f"{checks.shown(name)}")
    if name in table:
        make = table[name]
        return _load(make)() if isinstance(make, str) else make()
    if Path(name).is_file():
        return _load(CHECKPOINT_EXECUTOR_3D if three_d else CHECKPOINT_EXECUTOR)(Path(name))
    raise ValueError(f"executor {name!r}: not one of {list(table)} nor a checkpoint file")
