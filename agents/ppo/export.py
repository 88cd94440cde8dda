"""Ships a PPO checkpoint: its network alone (no optimiser state, no RNG), for `agents/checkpoints/`.

`python -m auv_mj.agents.ppo.export RUN/best.pt agents/checkpoints/planner_memory.pt` writes the deployable part of a
training checkpoint (the actor-critic with its observation normaliser, the config, the spaces and the counters) so
that a shipped planner stays small; `PPOPolicy.load` reads it as it reads the full one.

Given several sources, `python -m auv_mj.agents.ppo.export A.pt B.pt C.pt TARGET.pt` writes one ensemble of them
(`export_ensemble`: `auv_mj.agents.ppo.model.ActorEnsemble`, the mean of their clipped actions), which loads and
deploys as one policy; its members must read the same input and act in the same space.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from auv_mj.agents.checkpoint import config_to_dict, module_tensors, save_checkpoint
from auv_mj.agents.ppo.checkpoint import MEMBERS_KEY, load_model, member_prefix, read_ppo, save_ppo

SHARED_SPEC = ("kind", "obs_shape", "obs_dim", "act_dim", "act_shape", "action_low", "action_high", "task_options")
"""What every member of an ensemble must share: its input (the observation and the task options that shape it) and its
action space. Anything else of a member's spec (a critic's privileged inputs) is its own."""


def export(source: str | Path, target: str | Path) -> Path:
    """Writes `source`'s network, config, spec and counters to `target` (atomically); returns `target`. An
    ensemble's checkpoint is written as it is (its members are networks alone already)."""
    (tensors, meta), config = read_ppo(source)
    if meta["spec"].get(MEMBERS_KEY) is not None:
        save_checkpoint(target, "ppo", tensors, {key: meta[key] for key in ("agent", "config", "spec", "counters")
                                                 if key in meta})
        return Path(target)
    model = load_model(source, tensors, meta["spec"], config)
    save_ppo(target, model, None, None, config, meta["spec"], meta.get("counters", {}))
    return Path(target)


def export_ensemble(sources: Sequence[str | Path], target: str | Path) -> Path:
    """Writes the ensemble of the PPO checkpoints `sources` (each member's whole network, config and spec, in
    order) to `target` (atomically), a checkpoint of kind "ppo" whose spec is the members' shared one
    (SHARED_SPEC) with MEMBERS_KEY beside it; returns `target`. ValueError naming the file where a source is an
    ensemble itself or differs from the first in what the members must share."""
    if len(sources) < 2:
        raise ValueError(f"an ensemble needs at least two sources, got {len(sources)}")
    members, tensors = [], {}
    first_spec, first_config = None, None
    for k, source in enumerate(sources):
        (saved, meta), config = read_ppo(source)
        spec = dict(meta["spec"])
        if spec.get(MEMBERS_KEY) is not None:
            raise ValueError(f"checkpoint {source} is an ensemble already: give its members' checkpoints")
        if first_spec is None:
            first_spec, first_config = spec, config
        for key in SHARED_SPEC:
            if spec.get(key) != first_spec.get(key):
                raise ValueError(f"checkpoint {source}: its {key} {spec.get(key)!r} differs from {sources[0]}'s "
                                 f"{first_spec.get(key)!r}; an ensemble's members read the same input and act in "
                                 "the same space")
        tensors.update(module_tensors(load_model(source, saved, spec, config), member_prefix(k)))
        members.append({"config": config_to_dict(config), "spec": spec, "source": str(source)})
    spec = {key: first_spec[key] for key in SHARED_SPEC if key in first_spec}
    spec[MEMBERS_KEY] = members
    save_checkpoint(target, "ppo", tensors, {"agent": "ppo", "config": config_to_dict(first_config), "spec": spec,
                                            "counters": {"members": len(members)}})
    return Path(target)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit("usage: python -m auv_mj.agents.ppo.export SOURCE.pt [SOURCE.pt ...] TARGET.pt")
    *given, out = sys.argv[1:]
    print(export(given[0], out) if len(given) == 1 else export_ensemble(given, out))
