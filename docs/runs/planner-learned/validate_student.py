"""Hard-tier validation of a planar learned planner: the deterministic policy on N validation episodes of each hard
cell (seeds 27000-, `auv_mj.agents.ppo.planner.validate`), run with the task options its checkpoint keeps (the action
map and the observation, "planner" or "planner-map"). Prints and writes the rates as JSON.

    python docs/runs/planner-learned/validate_student.py CHECKPOINT [EPISODES] [THREADS] [OUT.json]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.ppo.planner import validate
from auv_mj.agents.ppo.policy import PPOPolicy


def main(path: str, episodes: int = 50, threads: int = 1, out: str | None = None) -> dict[str, float]:
    options = read_checkpoint(path, "ppo").metadata["spec"].get("task_options", {})
    rates = validate(PPOPolicy.load(path), episodes, threads=threads, task_kwargs=options)
    result = {"checkpoint": path, "task_options": options, "episodes_per_cell": episodes,
              "mean": float(np.mean(list(rates.values()))), **rates}
    print(json.dumps(result))
    if out:
        Path(out).write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], *(int(a) for a in args[1:3]), *args[3:4])
