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
must share its input and action space (`auv_mj.agents.ppo.export.ensemble` checks). Prints and writes the rates as
JSON.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.agents.imitation import DaggerConfig
from auv_mj.agents.ppo.export import ensemble
from auv_mj.agents.ppo.planner import validate
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.jobs.student import MIXTURE_3D_OPTIONS, mixture_3d_validator


def main(domain: str, episodes: int, threads: int, out: str, paths: list[str]) -> dict:
    if domain not in ("2d", "3d"):
        raise ValueError(f"domain {domain!r}: give 2d or 3d")
    model, spec, _ = ensemble(paths)
    options = spec.get("task_options", {})
    if domain == "2d":
        rates = validate(PPOPolicy(model, spec), episodes, threads=threads, task_kwargs=options)
    else:
        validator = mixture_3d_validator(threads, {**MIXTURE_3D_OPTIONS, **options})
        rates = {k: v for k, v in validator(model.eval(), DaggerConfig(validation_episodes=episodes)).items()
                 if k.startswith("cell:")}
    result = {"members": paths, "task_options": options, "episodes_per_cell": episodes,
              "mean": float(np.mean(list(rates.values()))), **rates}
    print(json.dumps(result))
    Path(out).write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], int(args[1]), int(args[2]), args[3], args[4:])
