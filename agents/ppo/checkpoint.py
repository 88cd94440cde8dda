"""A PPO run's checkpoint, kind "ppo" of `auv_mj.agents.checkpoint`: written, read, and turned back into networks.

A training checkpoint holds the model (its normalisers included), Adam's moments and the generator, with the config,
the spaces and the counters; a deployable one (`auv_mj.agents.ppo.export`) the model alone. `load_actor` gives a new
run the actor of another's checkpoint (a DAgger student's, for a fine-tune).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from auv_mj.agents.checkpoint import (
    Checkpoint,
    config_from_dict,
    config_to_dict,
    load_module,
    module_tensors,
    optimizer_tensors,
    read_checkpoint,
    save_checkpoint,
    saved_config,
)
from auv_mj.agents.ppo.config import PPOConfig
from auv_mj.agents.ppo.model import ActorCritic, ActorEnsemble

ANCHOR_PREFIX = "anchor"
"""The tensors' prefix of a run's frozen anchor in its checkpoint (`save_ppo`, `load_anchor`)."""

CHECKPOINT_NAME = "checkpoint.pt"
"""The checkpoint's name in a run's directory (`auv_mj.agents.ppo.ppo.train` writes it every checkpoint_every
rollouts)."""


def save_ppo(path: str | Path, model: ActorCritic | ActorEnsemble, optimizer: torch.optim.Optimizer | None,
             generator: torch.Generator | None, config: PPOConfig, spec: Mapping[str, Any],
             counters: Mapping[str, Any], anchor: ActorCritic | None = None) -> None:
    """Atomically writes a checkpoint of kind "ppo": the model (normaliser included), Adam's moments and the
    generator (either None for a deployable file), with the config, the spaces and the counters; a training run
    under an imitation term of source "init" also its frozen anchor (`load_anchor`), which no deployable file has."""
    tensors = module_tensors(model, "model")
    if anchor is not None:
        tensors.update(module_tensors(anchor, ANCHOR_PREFIX))
    if optimizer is not None:
        tensors.update(optimizer_tensors(optimizer, "optimizer"))
    if generator is not None:
        tensors["generator"] = generator.get_state().cpu()
    save_checkpoint(path, "ppo", tensors, {"agent": "ppo", "config": config_to_dict(config), "spec": dict(spec),
                                           "counters": dict(counters)})


def load_anchor(path: str | Path, tensors: Mapping[str, torch.Tensor], model: ActorCritic) -> ActorCritic:
    """The frozen anchor a run under PPOConfig.imitation_source "init" saved beside its model (the actor it started
    from), with `model`'s architecture; ValueError naming the file where the checkpoint holds none."""
    if not any(k.startswith(ANCHOR_PREFIX + ".") for k in tensors):
        raise ValueError(f"checkpoint {path} holds no anchor: it was not trained with PPOConfig.imitation_source "
                         "'init'")
    anchor = frozen_copy(model)
    load_module(anchor, tensors, ANCHOR_PREFIX, Path(path))
    return anchor


def frozen_copy(model: ActorCritic) -> ActorCritic:
    """A copy of `model` in eval mode that asks for no gradient (an anchor: it labels, it never learns)."""
    return copy.deepcopy(model).requires_grad_(False).eval()


def read_ppo(path: str | Path) -> tuple[Checkpoint, PPOConfig]:
    """A checkpoint of kind "ppo" (`auv_mj.agents.checkpoint.read_checkpoint`) and its config; ValueError naming
    the file if it is unreadable, of another kind or its config is not a PPOConfig."""
    checkpoint = read_checkpoint(path, "ppo")
    return checkpoint, saved_config(checkpoint, path, PPOConfig)


def load_model(path: str | Path, tensors: Mapping[str, torch.Tensor], spec: Mapping[str, Any],
               config: PPOConfig) -> ActorCritic | ActorEnsemble:
    """The network of a checkpoint's tensors (under "model."): its actor-critic, or where its spec lists MEMBERS_KEY
    the ensemble of its members (`ActorEnsemble`, each built from its own config and spec in that list); ValueError
    naming the file if they do not fit."""
    model = _network(Path(path), spec, config)
    load_module(model, tensors, "model", Path(path))
    return model.to(config.device)


MEMBERS_KEY = "members"
"""The spec entry of an ensemble checkpoint (`auv_mj.agents.ppo.export.export_ensemble`): one {"config", "spec",
"source"} a member, in order."""


def _network(path: Path, spec: Mapping[str, Any], config: PPOConfig) -> ActorCritic | ActorEnsemble:
    members = spec.get(MEMBERS_KEY)
    if members is None:
        return ActorCritic(int(spec["obs_dim"]), int(spec["act_dim"]), config, int(spec.get("privileged_dim", 0)))
    if not isinstance(members, list) or not members:
        raise ValueError(f"checkpoint {path}: its spec's {MEMBERS_KEY!r} is not a list of members")
    networks = []
    for k, member in enumerate(members):
        own = member.get("spec") if isinstance(member, Mapping) else None
        if not (isinstance(own, Mapping) and isinstance(own.get("obs_dim"), int) and isinstance(own.get("act_dim"), int)
                and own.get(MEMBERS_KEY) is None):
            raise ValueError(f"checkpoint {path}: member {k} has no valid 'spec' (obs_dim, act_dim, no members)")
        own_config = config_from_dict(member.get("config"), f"checkpoint {path}: member {k}'s config", PPOConfig)
        networks.append(ActorCritic(own["obs_dim"], own["act_dim"], own_config, int(own.get("privileged_dim", 0))))
    return ActorEnsemble(networks)


def load_actor(model: ActorCritic, tensors: Mapping[str, torch.Tensor], path: Path, critic: bool = False) -> None:
    """A new run's actor (encoder, memory, head, log std) and observation normaliser from a checkpoint's tensors
    (a student's); the critic keeps its fresh weights, unless `critic` and the checkpoint's whole critic (its own
    networks and privileged normaliser) fits this one: a PPO run's own checkpoint continued on a new mixture
    (`auv-mj train ppo --init`), whose trained critic spares the actor the first updates' wrong advantages."""
    own = model.state_dict()
    taken = {k[len("model."):]: v for k, v in tensors.items() if k.startswith("model.")}
    fits = {k: v for k, v in taken.items() if k in own and own[k].shape == v.shape}
    actor = [k for k in own if not k.startswith(("critic", "privileged_norm"))]
    missing = [k for k in actor if k not in fits]
    if missing:
        raise ValueError(f"checkpoint {path} does not fit this actor: {missing[:4]}")
    critic_keys = [k for k in own if k not in actor]  # the critic's own networks and its privileged normaliser
    keep = actor + (critic_keys if critic and all(k in fits for k in critic_keys) else [])
    model.load_state_dict({**own, **{k: fits[k] for k in keep}})
