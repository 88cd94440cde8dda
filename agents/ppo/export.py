"""Ships a PPO checkpoint: its network alone (no optimiser state, no RNG), for `agents/checkpoints/`.

`python -m auv_mj.agents.ppo.export RUN/best.pt agents/checkpoints/planner_memory.pt` writes the deployable part of a
training checkpoint (the actor-critic with its observation normaliser, the config, the spaces and the counters) so
that a shipped planner stays small; `PPOPolicy.load` reads it as it reads the full one.

Given several sources, `python -m auv_mj.agents.ppo.export A.pt B.pt C.pt TARGET.pt` writes one ensemble of them
(`export_ensemble`: `auv_mj.agents.ppo.model.ActorEnsemble`, the mean of their clipped actions), which loads and
deploys as one policy; its members must read the same input and act in the same space.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path

from auv_mj.agents.checkpoint import config_to_dict
from auv_mj.agents.ppo.checkpoint import MEMBERS_KEY, load_model, read_ppo, save_ppo
from auv_mj.agents.ppo.config import PPOConfig
from auv_mj.agents.ppo.model import ActorEnsemble

SHARED_SPEC = ("kind", "obs_shape", "obs_dim", "act_dim", "act_shape", "action_low", "action_high", "task_options")
"""What every member of an ensemble must share: its input (the observation and the task options that shape it) and its
action space. Anything else of a member's spec (a critic's privileged inputs) is its own."""


def export(source: str | Path, target: str | Path) -> Path:
    """Writes `source`'s network (an ensemble's too), config, spec and counters to `target` (atomically); returns
    `target`."""
    (tensors, meta), config = read_ppo(source)
    model = load_model(source, tensors, meta["spec"], config)
    save_ppo(target, model, None, None, config, meta["spec"], meta.get("counters", {}))
    return Path(target)


def ensemble(sources: Sequence[str | Path]) -> tuple[ActorEnsemble, dict, PPOConfig]:
    """The ensemble of the PPO checkpoints `sources`, in order, with the spec an ensemble checkpoint keeps (the
    members' shared SHARED_SPEC, and MEMBERS_KEY: each member's config, spec and source) and the first member's
    config; the networks on the CPU. ValueError naming the file where a source is an ensemble itself or differs from
    the first in what the members must share."""
    if len(sources) < 2:
        raise ValueError(f"an ensemble needs at least two sources, got {len(sources)}")
    networks, members, specs, configs = [], [], [], []
    for source in sources:
        (tensors, meta), config = read_ppo(source)
        spec = dict(meta["spec"])
        if spec.get(MEMBERS_KEY) is not None:
            raise ValueError(f"checkpoint {source} is an ensemble already: give its members' checkpoints")
        for key in SHARED_SPEC:
            if specs and spec.get(key) != specs[0].get(key):
                raise ValueError(f"checkpoint {source}: its {key} {spec.get(key)!r} differs from {sources[0]}'s "
                                 f"{specs[0].get(key)!r}; an ensemble's members read the same input and act in "
                                 "the same space")
        networks.append(load_model(source, tensors, spec, dataclasses.replace(config, device="cpu")))
        members.append({"config": config_to_dict(config), "spec": spec, "source": str(source)})
        specs.append(spec)
        configs.append(config)
    shared = {key: specs[0][key] for key in SHARED_SPEC if key in specs[0]}
    return ActorEnsemble(networks), {**shared, MEMBERS_KEY: members}, configs[0]


def export_ensemble(sources: Sequence[str | Path], target: str | Path) -> Path:
    """Writes `ensemble(sources)` to `target` (atomically) as a checkpoint of kind "ppo" that `load_model` reads
    back into the same ensemble; returns `target`."""
    model, spec, config = ensemble(sources)
    save_ppo(target, model, None, None, config, spec, {"members": len(spec[MEMBERS_KEY])})
    return Path(target)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit("usage: python -m auv_mj.agents.ppo.export SOURCE.pt [SOURCE.pt ...] TARGET.pt")
    *given, out = sys.argv[1:]
    print(export(given[0], out) if len(given) == 1 else export_ensemble(given, out))
