"""The policy zoo: every named policy (`registry.POLICIES`), the executors by name, and loading a policy for an
environment.

    from auv_mj import zoo
    env, policy = zoo.env_and_policy("map-replan", "obstacles", seed=10_000)
    path = zoo.checkpoint_path("planner-route")     # a learned policy's shipped checkpoint file, by name

The names below load the registry on first use (it imports torch), so that importing `auv_mj.zoo.spec` stays light.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_NAMES = ("POLICIES", "EXECUTORS", "load_policy", "make_env", "make_policy", "env_and_policy", "named_executor",
          "shipped_checkpoint", "checkpoint_path", "register", "PolicySpec")

__all__ = list(_NAMES)


def __getattr__(name: str) -> Any:
    if name not in _NAMES:
        raise AttributeError(f"module 'auv_mj.zoo' has no attribute {name!r}")
    return getattr(import_module("auv_mj.zoo.registry"), name)
