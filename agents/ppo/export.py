"""Ships a PPO checkpoint: its network alone (no optimiser state, no RNG), for `agents/checkpoints/`.

`python -m auv_mj.agents.ppo.export RUN/best.pt agents/checkpoints/planner_memory.pt` writes the deployable part of a
training checkpoint (the actor-critic with its observation normaliser, the config, the spaces and the counters) so
that a shipped planner stays small; `PPOPolicy.load` reads it as it reads the full one.
"""

from __future__ import annotations

import sys
from pathlib import Path

from auv_mj.agents.ppo.checkpoint import load_model, read_ppo, save_ppo


def export(source: str | Path, target: str | Path) -> Path:
    """Writes `source`'s network, config, spec and counters to `target` (atomically); returns `target`."""
    (tensors, meta), config = read_ppo(source)
    model = load_model(source, tensors, meta["spec"], config)
    save_ppo(target, model, None, None, config, meta["spec"], meta.get("counters", {}))
    return Path(target)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: python -m auv_mj.agents.ppo.export SOURCE.pt TARGET.pt")
    print(export(sys.argv[1], sys.argv[2]))
