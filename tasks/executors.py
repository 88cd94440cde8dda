"""Executors by name: what a planning task's `executor` option takes, besides a callable.

    suite.load("auv", "tunnel", task_kwargs={"executor": "splane-ocean"})

The tasks build the classical executors themselves: the S-plane of Eq. (32) and its gains re-tuned in ocean water
(CLASSICAL; on the 6-DOF tasks the depth-heading S-plane, CLASSICAL_3D). Any other name is a plugin of the
entry-point group PLUGINS (PLUGINS_3D on the 6-DOF tasks), declared by an installed package as Gymnasium's plugins
are; a checkpoint path goes to the group's CHECKPOINT_PLUGIN. auv-mj declares its learned executors there
(pyproject.toml: `executor`, `ocean-executor`, `depth-executor`), so the names work here while the tasks name no
layer above them. The policy zoo resolves its names itself (`auv_mj.zoo.executors`) and hands the tasks callables.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any

from auv_mj.control.depth_heading import OCEAN_DEPTH_GAINS, DepthHeadingController
from auv_mj.control.splane import OCEAN_GAINS, SPlaneController
from auv_mj.tasks import options as checks

Executor = Callable[[Any, Any], Any]
"""`executor(command, state) -> (tau_u, tau_r)`, with `reset()` where it keeps state."""

CLASSICAL: dict[str, Callable[[], Executor]] = {
    "splane": SPlaneController,
    "splane-ocean": lambda: SPlaneController(OCEAN_GAINS),
}
"""Executor name -> a function making it, on the planar planning tasks: the S-planes (Eq. 32)."""
CLASSICAL_3D: dict[str, Callable[[], Executor]] = {
    "splane": DepthHeadingController,
    "splane-ocean": lambda: DepthHeadingController(OCEAN_DEPTH_GAINS),
}
"""The same on the 6-DOF planning tasks (goal3d, tunnel3d): the depth-heading S-plane, and it re-tuned in ocean
water (`OCEAN_DEPTH_GAINS`)."""
PLUGINS = "auv_mj.executors"
"""Entry-point group of executor plugins on the planar tasks: name -> a function of no argument making one."""
PLUGINS_3D = "auv_mj.executors_3d"
"""Entry-point group of executor plugins on the 6-DOF tasks."""
CHECKPOINT_PLUGIN = "checkpoint"
"""The plugin of a group that makes an executor of a checkpoint file: `function(path) -> executor`."""


def plugins(three_d: bool = False) -> dict[str, EntryPoint]:
    """The installed executor plugins of the planar (or, `three_d`, the 6-DOF) tasks, by name."""
    return {point.name: point for point in entry_points(group=PLUGINS_3D if three_d else PLUGINS)}


def executor_names(three_d: bool = False) -> list[str]:
    """Every executor name the tasks take: the classical ones, then the plugins'."""
    classical = CLASSICAL_3D if three_d else CLASSICAL
    return [*classical, *sorted(n for n in plugins(three_d) if n != CHECKPOINT_PLUGIN and n not in classical)]


def unknown_executor(name: object, names: list[str]) -> ValueError:
    """The refusal of an executor name: the nearest valid one, and the valid set."""
    if not isinstance(name, str | Path):
        return ValueError(f"executor: a name of {names}, a checkpoint path or a callable, got {checks.shown(name)}")
    near = difflib.get_close_matches(str(name), names, n=1)
    hint = f"; did you mean {near[0]!r}?" if near else ""
    return ValueError(f"executor {str(name)!r}: not one of {names} nor a checkpoint file{hint}")


def named_executor(name: str, three_d: bool = False) -> Executor:
    """The executor `name` (one of `executor_names(three_d)`, or a checkpoint path: a speed_heading one on the planar
    tasks, a depth_heading one on the 6-DOF tasks); ValueError naming it otherwise."""
    classical = CLASSICAL_3D if three_d else CLASSICAL
    if isinstance(name, str) and name in classical:
        return classical[name]()
    found = plugins(three_d)
    if isinstance(name, str) and name in found and name != CHECKPOINT_PLUGIN:
        return found[name].load()()
    if isinstance(name, str | Path) and Path(name).is_file() and CHECKPOINT_PLUGIN in found:
        return found[CHECKPOINT_PLUGIN].load()(Path(name))
    raise unknown_executor(name, executor_names(three_d))
