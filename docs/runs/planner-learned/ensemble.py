"""Hard-tier validation of an ensemble of learned planners: the mean of K students' deterministic actions.

Each member keeps its own memory and reads the same observation; the ensemble's action is the mean of the members'
actions, each clipped to the action box as it would be deployed (`auv_mj.agents.ppo.model.ActorEnsemble`, what
`python -m auv_mj.agents.ppo.export A.pt B.pt ... OUT.pt` ships). Averaging K imitation students trained on other
seeds or fits is the cheapest guard against one student's own errors (bagging; Breiman 1996); whether it helps a
closed loop is what this measures, before anything is exported.

    python docs/runs/planner-learned/ensemble.py 2d EPISODES THREADS OUT.json CHECKPOINT CHECKPOINT ...
    python docs/runs/planner-learned/ensemble.py 3d EPISODES THREADS OUT.json CHECKPOINT CHECKPOINT ...

2d: the planar hard cells (`auv_mj.agents.ppo.planner.validate`, seeds 27000-), with the task options the first
member keeps; 3d: the 6-DOF hard cells (`auv_mj.jobs.student.mixture_3d_validator`, seeds 28000-). Every member
must keep the same task options. Prints and writes the rates as JSON.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.imitation import DaggerConfig
from auv_mj.agents.ppo import load_model, read_ppo
from auv_mj.agents.ppo.model import ActorEnsemble
from auv_mj.agents.ppo.planner import validate
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.jobs.student import MIXTURE_3D_OPTIONS, mixture_3d_validator


def _options(path: str) -> dict:
    return read_checkpoint(path, "ppo").metadata["spec"].get("task_options", {})


def main(domain: str, episodes: int, threads: int, out: str, paths: list[str]) -> dict:
    options = [_options(p) for p in paths]
    if any(o != options[0] for o in options):
        raise ValueError(f"the members keep different task options: {options}")
    if domain not in ("2d", "3d"):
        raise ValueError(f"domain {domain!r}: give 2d or 3d")
    models, specs = [], []
    for p in paths:
        (tensors, meta), saved = read_ppo(p)
        models.append(load_model(p, tensors, meta["spec"], dataclasses.replace(saved, device="cpu")))
        specs.append(meta["spec"])
    ensemble = ActorEnsemble(models)
    if domain == "2d":
        rates = validate(PPOPolicy(ensemble, specs[0]), episodes, threads=threads, task_kwargs=options[0])
    else:
        validator = mixture_3d_validator(threads, {**MIXTURE_3D_OPTIONS, **options[0]})
        rates = {k: v for k, v in validator(ensemble.float().eval(), DaggerConfig(validation_episodes=episodes)).items()
                 if k.startswith("cell:")}
    result = {"members": paths, "task_options": options[0], "episodes_per_cell": episodes,
              "mean": float(np.mean(list(rates.values()))), **rates}
    print(json.dumps(result))
    Path(out).write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], int(args[1]), int(args[2]), args[3], args[4:])
