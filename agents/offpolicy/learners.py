"""The off-policy learners by name (`auv-mj train AGENT`), and an agent's whole state in a checkpoint and back.

A checkpoint of kind "ddpg", "her-ddpg", "executor" or "td3" (`auv_mj.agents.checkpoint`) holds the agent's
networks and normaliser, Adam's moments, the pending normaliser statistics and both random generators (torch's and
the agent's numpy one), with the config, the sizes and the update count in its metadata: a run resumed from it
continues exactly. The file's schema is checked by `read_checkpoint` before any network is built.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from auv_mj.agents.checkpoint import (
    Checkpoint,
    config_to_dict,
    is_whole,
    load_module,
    load_optimizer,
    module_tensors,
    optimizer_tensors,
    read_checkpoint,
    save_checkpoint,
    saved_config,
)
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config
from auv_mj.inputs import unknown_name

AGENT_CLASSES: dict[str, tuple[type[DDPG], type[DDPGConfig]]] = {
    "ddpg": (DDPG, DDPGConfig), "her-ddpg": (DDPG, DDPGConfig), "executor": (DDPG, DDPGConfig), "td3": (TD3, TD3Config),
}
"""Agent name (`auv-mj train AGENT`) -> the learner and its one config dataclass."""
AGENTS = tuple(AGENT_CLASSES)
"""Agent names of `auv-mj train AGENT`, which are also their checkpoints' kinds: her-ddpg needs a goal task,
executor a Box task; ddpg and td3 take either."""


def agent_classes(agent_name: Any) -> tuple[type[DDPG], type[DDPGConfig]]:
    """(learner class, config class) of `agent_name`."""
    if agent_name not in AGENT_CLASSES:
        raise ValueError(unknown_name("agent", agent_name, AGENTS))
    return AGENT_CLASSES[agent_name]


def agent_tensors(agent: DDPG) -> dict[str, torch.Tensor]:
    """Every tensor of the agent's state (modules, optimiser moments, torch RNG) as flat CPU tensors."""
    tensors: dict[str, torch.Tensor] = {}
    for prefix, module in agent.modules().items():
        tensors.update(module_tensors(module, prefix))
    for prefix, opt in agent.optimizers().items():
        tensors.update(optimizer_tensors(opt, f"{prefix}.state"))
    tensors.update({f"obs_norm_pending.{k}": v for k, v in agent.obs_norm.pending_state().items()})
    tensors["torch_rng"] = torch.get_rng_state()
    return tensors


def save_agent(path: str | Path, agent: DDPG, metadata: Mapping[str, Any]) -> None:
    """Atomically writes the agent's whole state with `metadata` (its "agent", the kind, defaults to the learner's
    own: "td3" or "ddpg"), adding the config, the sizes, the numpy generator and the update count."""
    kind = metadata.get("agent") or ("td3" if isinstance(agent, TD3) else "ddpg")
    meta = {**metadata, "agent": kind, "config": config_to_dict(agent.config), "obs_dim": agent.obs_dim,
            "act_dim": agent.act_dim, "agent_rng": agent.rng.bit_generator.state, "num_updates": agent.num_updates}
    save_checkpoint(path, kind, agent_tensors(agent), meta)


def load_agent(path: str | Path, device: str | None = None, config: DDPGConfig | None = None,
               ) -> tuple[DDPG, dict[str, Any]]:
    """Rebuilds the agent saved at `path` (optionally on another device or with a compatible config).

    Raises ValueError naming the file if it is corrupt, truncated, or of another architecture.
    """
    path = Path(path)
    tensors, meta = read_checkpoint(path, AGENTS)
    learner, config_class = agent_classes(meta["kind"])
    saved = saved_config(Checkpoint(tensors, meta), path, config_class)
    config = config or saved
    if device is not None:
        config = dataclasses.replace(config, device=device)
    if config.hidden_sizes != saved.hidden_sizes:
        raise ValueError(f"checkpoint {path} has hidden sizes {saved.hidden_sizes}, "
                         f"config asks for {config.hidden_sizes}")
    if not isinstance(config, config_class):
        raise ValueError(f"checkpoint {path} is a {meta.get('agent')} agent: it needs a {config_class.__name__}, "
                         f"got a {type(config).__name__}")
    agent = learner(int(meta["obs_dim"]), int(meta["act_dim"]), config)
    for prefix, module in agent.modules().items():
        load_module(module, tensors, prefix, path)
    for prefix, opt in agent.optimizers().items():
        load_optimizer(opt, tensors, f"{prefix}.state", path)
    pending = {k.split(".", 1)[1]: v for k, v in tensors.items() if k.startswith("obs_norm_pending.")}
    if pending:
        agent.obs_norm.load_pending_state(pending)
    try:
        agent.rng.bit_generator.state = _generator_state(meta.get("agent_rng"), agent.rng.bit_generator)
        if "torch_rng" in tensors:
            torch.set_rng_state(tensors["torch_rng"])
    except (KeyError, TypeError, ValueError, RuntimeError, OverflowError) as exc:
        raise ValueError(f"checkpoint {path}: its random generator states (agent_rng, torch_rng) are not "
                         f"restorable: {' '.join(str(exc).split())}") from None
    agent.num_updates = int(meta.get("num_updates", 0))
    return agent, meta


def _generator_state(state, generator: np.random.BitGenerator) -> dict:
    """`agent_rng` as a state `generator` (PCG64) takes, or ValueError naming what is wrong with it: NumPy's
    setter alone accepts floats, bools, unknown keys and an even PCG64 increment, and restores a generator
    that no run ever had."""
    keys = {"bit_generator", "state", "has_uint32", "uinteger"}
    if not isinstance(state, Mapping) or set(state) != keys:
        raise ValueError(f"agent_rng must be a dict of {sorted(keys)}, got {str(state)[:80]}")
    kind = type(generator).__name__
    if state["bit_generator"] != kind:
        raise ValueError(f"agent_rng.bit_generator must be {kind!r}, got {str(state['bit_generator'])[:40]!r}")
    inner = state["state"]
    if kind == "PCG64" and not (isinstance(inner, Mapping) and set(inner) == {"state", "inc"}
                                and is_whole(inner["state"], 0, 2**128 - 1)
                                and is_whole(inner["inc"], 0, 2**128 - 1) and inner["inc"] % 2):
        raise ValueError(f"agent_rng.state must be {{'state', 'inc'}}: whole numbers below 2**128, inc odd, "
                         f"got {str(inner)[:80]}")
    if not (is_whole(state["has_uint32"], 0, 1) and is_whole(state["uinteger"], 0, 2**32 - 1)):
        raise ValueError(f"agent_rng.has_uint32 must be 0 or 1 and uinteger a whole number below 2**32, got "
                         f"{str(state['has_uint32'])[:20]} and {str(state['uinteger'])[:20]}")
    return dict(state)
