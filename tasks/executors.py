"""Executors by name: what a planning task's `executor` option takes, besides a callable.

    suite.load("auv", "tunnel", task_kwargs={"executor": "splane-ocean"})

The tasks build the classical executors themselves: the S-plane of Eq. (32) and its gains re-tuned in ocean water
(the domain record's `executors`, `auv_mj.tasks.domains`; on the 6-DOF tasks the depth-heading S-plane). Any other
name is a plugin of the domain's entry-point group (`Domain.executor_plugins`), declared by an installed package as
Gymnasium's plugins are; a checkpoint path goes to the group's CHECKPOINT_PLUGIN. auv-mj declares its learned
executors there (pyproject.toml: `executor`, `ocean-executor`, `depth-executor`), so the names work here while the
tasks name no layer above them. The policy zoo resolves its names itself (`auv_mj.zoo.executors`) and hands the
tasks callables.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any

from auv_mj.inputs import did_you_mean
from auv_mj.tasks import options as checks
from auv_mj.tasks.domains import DOMAINS

Executor = Callable[[Any, Any], Any]
"""`executor(command, state) -> (tau_u, tau_r)`, with `reset()` where it keeps state."""
CHECKPOINT_PLUGIN = "checkpoint"
"""The plugin of a group that makes an executor of a checkpoint file: `function(path) -> executor`."""


def plugins(domain: str = "auv") -> dict[str, EntryPoint]:
    """The installed executor plugins of `domain`'s tasks, by name."""
    return {point.name: point for point in entry_points(group=DOMAINS[domain].executor_plugins)}


def executor_names(domain: str = "auv") -> list[str]:
    """Every executor name `domain`'s tasks take: the classical ones, then the plugins'."""
    classical = DOMAINS[domain].executors
    return [*classical, *sorted(n for n in plugins(domain) if n != CHECKPOINT_PLUGIN and n not in classical)]


def unknown_executor(name: object, names: list[str]) -> ValueError:
    """The refusal of an executor name: the nearest valid one, and the valid set."""
    if not isinstance(name, str | Path):
        return ValueError(f"executor: a name of {names}, a checkpoint path or a callable, got {checks.shown(name)}")
    return ValueError(f"executor {str(name)!r}: not one of {names} nor a checkpoint file"
                      + did_you_mean(str(name), names))


def named_executor(name: str, domain: str = "auv") -> Executor:
    """The executor `name` of `domain`'s tasks (one of `executor_names(domain)`, or a checkpoint path: a
    speed_heading one on the planar tasks, a depth_heading one on the 6-DOF tasks); ValueError naming it otherwise."""
    classical = DOMAINS[domain].executors
    if isinstance(name, str) and name in classical:
        return classical[name]()
    found = plugins(domain)
    if isinstance(name, str) and name in found and name != CHECKPOINT_PLUGIN:
        return found[name].load()()
    if isinstance(name, str | Path) and Path(name).is_file() and CHECKPOINT_PLUGIN in found:
        return found[CHECKPOINT_PLUGIN].load()(Path(name))
    raise unknown_executor(name, executor_names(domain))
