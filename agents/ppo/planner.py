"""A planner learned from scratch with PPO on the batched training mixture, chosen on validation seeds.

`train_planner(run_dir, config, mixture, total_steps)` trains `auv_mj.agents.ppo` on
`auv_mj.tasks.mixture.PlanningMixtureVectorEnv` (random obstacles, moving obstacles and tunnels, both tiers, both
waters, TRAIN seeds only) in chunks of `validate_every` env steps. After each chunk the checkpoint is copied to
`snapshots/steps_<N>.pt` and the deterministic policy is run on the hard tier's cells with VALIDATION seeds
(`validate`); a row per chunk goes to `validation.csv` (env steps, training wall-clock, success per cell).
`best.pt` is the snapshot of the highest mean hard-tier validation success (ties: the earlier one). Test seeds
are never touched here.

The planner reads the task's planning observation (goal distance and bearing, its velocity, its command, the nine
sonars) and the desired goal, as every planner does; nothing classical steers it. Its memory is PPO's GRU
(`PPOConfig(recurrent="gru")`); `recurrent=None` is the ablation without memory.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import shutil
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.agents.checkpoint import config_to_dict
from auv_mj.agents.ppo import ppo
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.seeds import VALIDATION
from auv_mj.tasks.mixture import MIXTURE_TASKS, TIERS, WATERS, PlanningMixtureVectorEnv
from auv_mj.tasks.vector import AUVVectorEnv

VALIDATION_NAME = "validation.csv"
BEST_NAME = "best.pt"
MIXTURE_NAME = "mixture.json"
VALIDATION_FIRST_SEED = VALIDATION.start + 7000
"""Validation episodes use seeds VALIDATION_FIRST_SEED + i (inside `auv_mj.seeds.VALIDATION`)."""


@dataclasses.dataclass(frozen=True)
class MixtureConfig:
    """The training mixture and its reward; frozen into `mixture.json` of the run."""

    envs_per_cell: int = 8
    """Vehicles per (task, tier, water) cell: 3 x 2 x 2 cells, 96 vehicles by default."""
    tasks: tuple[str, ...] = MIXTURE_TASKS
    """Planning tasks, each on procedural arenas."""
    tiers: tuple[str, ...] = TIERS
    """Arena tiers."""
    waters: tuple[str, ...] = WATERS
    """Waters (conditions)."""
    reward: str = "progress"
    """The tasks' reward: "progress" pays 0.5 per metre gained on the current goal, +4 on reaching it, and Eq.
    (24)-(25)'s avoidance and time costs; its sum depends on where the vehicle ends, not how slowly it went."""
    collision_penalty: float = 10.0
    """Subtracted on a collision or leaving the map (the task option of that name)."""
    reward_scale: float = 0.1
    """Multiplies every reward (keeps PPO's value targets near 1)."""

    def task_kwargs(self) -> dict[str, Any]:
        """The task options every cell shares."""
        return {"reward": self.reward, "collision_penalty": self.collision_penalty}

    def make_env(self, threads: int | None = None) -> PlanningMixtureVectorEnv:
        """The training env."""
        return PlanningMixtureVectorEnv(self.envs_per_cell, self.tasks, self.tiers, self.waters,
                                        task_kwargs=self.task_kwargs(), reward_scale=self.reward_scale,
                                        threads=threads)


def validate(policy: PPOPolicy, episodes: int, tasks: Sequence[str] = MIXTURE_TASKS, tier: str = "hard",
             waters: Sequence[str] = WATERS, first_seed: int = VALIDATION_FIRST_SEED,
             threads: int | None = None, max_steps: int | None = None) -> dict[str, float]:
    """Success rate of the deterministic `policy` on `episodes` VALIDATION-seed episodes of each (task, water)
    cell of `tier`, all of a cell's episodes stepped together in one batched env; {"task/tier/water": rate}.
    `max_steps` cuts the episodes (those not over by then count as failures); None: the tasks' time limits."""
    seeds = list(range(first_seed, first_seed + episodes))
    if seeds[0] not in VALIDATION or seeds[-1] not in VALIDATION:
        raise ValueError(f"validation seeds {seeds[0]}..{seeds[-1]} leave auv_mj.seeds.VALIDATION")
    rates = {}
    for task in tasks:
        for water in waters:
            env = AUVVectorEnv(task, num_envs=episodes, threads=threads,
                               task_kwargs={"arena": "random", "tier": tier, "conditions": water})
            try:
                obs, _ = env.reset(seed=seeds)
                policy.reset()
                done = np.zeros(episodes, dtype=bool)
                success = np.zeros(episodes, dtype=bool)
                steps = 0
                while not done.all() and (max_steps is None or steps < max_steps):
                    steps += 1
                    obs, _, term, trunc, info = env.step(policy(obs))
                    ended = (term | trunc) & ~done
                    success[ended] = info["success"][ended]
                    done |= ended
            finally:
                env.close()
            rates[f"{task}/{tier}/{water}"] = float(success.mean())
    return rates


def _validation_rows(path: Path, up_to_steps: int) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if int(row["env_steps"]) <= up_to_steps]


def train_planner(run_dir: str | Path, config: ppo.PPOConfig | None, mixture: MixtureConfig, total_steps: int,
                  *, validate_every: int = 1_000_000, validation_episodes: int = 16, resume: bool = False,
                  progress: bool = True, tensorboard: bool = True, threads: int | None = None,
                  validation_max_steps: int | None = None) -> dict[str, Any]:
    """Trains the planner (see the module docstring); returns {"env_steps", "best_steps", "best_success",
    "checkpoint", "best"}. Resuming continues from the last chunk's checkpoint (`ppo.train`'s exact resume when
    `validate_every` is a whole number of checkpoint periods)."""
    run_dir = Path(run_dir)
    mixture_path = run_dir / MIXTURE_NAME
    if resume:
        saved = json.loads(mixture_path.read_text())
        if saved != config_to_dict(mixture):
            raise ValueError(f"{mixture_path}: the run was trained on {saved}, not {config_to_dict(mixture)}")
        (_, meta), saved_config = ppo.read_ppo(run_dir / ppo.CHECKPOINT_NAME)
        config = saved_config if config is None else config
        done_steps = int(meta["counters"]["env_steps"])
    else:
        if (run_dir / ppo.CHECKPOINT_NAME).exists():
            raise FileExistsError(f"{run_dir / ppo.CHECKPOINT_NAME} exists: resume it or choose another run "
                                  "directory")
        run_dir.mkdir(parents=True, exist_ok=True)
        mixture_path.write_text(json.dumps(config_to_dict(mixture), indent=2))
        config = config or ppo.PPOConfig()
        done_steps = 0
    per_rollout = config.num_steps * mixture.envs_per_cell * len(mixture.tasks) * len(mixture.tiers) \
        * len(mixture.waters)
    period = per_rollout * config.checkpoint_every
    chunk = max(1, math.ceil(validate_every / period)) * period
    target = math.ceil(total_steps / per_rollout) * per_rollout
    rows = _validation_rows(run_dir / VALIDATION_NAME, done_steps)
    snapshots = run_dir / "snapshots"
    snapshots.mkdir(exist_ok=True)
    fields = ["env_steps", "train_wall_s", "hard_success", *(
        f"{task}/hard/{water}" for task in mixture.tasks for water in WATERS)]
    with open(run_dir / VALIDATION_NAME, "w", newline="") as f:
        writer = csv.DictWriter(f, fields)
        writer.writeheader()
        writer.writerows(rows)
    best = max(rows, key=lambda r: float(r["hard_success"]), default=None)
    steps = done_steps
    while steps < target:
        goal = min(target, (steps // chunk + 1) * chunk)
        result = ppo.train(lambda: mixture.make_env(threads), config, run_dir, goal, resume=steps > 0,
                           progress=progress, tensorboard=tensorboard)
        steps = result.env_steps
        meta = ppo.read_ppo(result.checkpoint)[0].metadata
        snapshot = snapshots / f"steps_{steps}.pt"
        shutil.copyfile(result.checkpoint, snapshot)
        started = time.perf_counter()
        rates = validate(PPOPolicy.load(snapshot), validation_episodes, mixture.tasks, threads=threads,
                         max_steps=validation_max_steps)
        row = {"env_steps": steps, "train_wall_s": round(float(meta["counters"]["wall_time"]), 1),
               "hard_success": round(float(np.mean(list(rates.values()))), 4), **rates}
        with open(run_dir / VALIDATION_NAME, "a", newline="") as f:
            csv.DictWriter(f, fields).writerow(row)
        print(f"validation at {steps} steps ({time.perf_counter() - started:.0f} s): hard-tier success "
              f"{row['hard_success']:.3f} {rates}", flush=True)
        if best is None or float(row["hard_success"]) > float(best["hard_success"]):
            best = row
            shutil.copyfile(snapshot, run_dir / (BEST_NAME + ".tmp"))
            (run_dir / (BEST_NAME + ".tmp")).replace(run_dir / BEST_NAME)
    return {"env_steps": steps, "best_steps": int(best["env_steps"]) if best else None,
            "best_success": float(best["hard_success"]) if best else None,
            "checkpoint": run_dir / ppo.CHECKPOINT_NAME, "best": run_dir / BEST_NAME}


PLANNER_CONFIG = ppo.PPOConfig(num_steps=128, num_minibatches=4, update_epochs=4, hidden_sizes=(128, 128),
                               recurrent="gru", recurrent_size=128, clip_vloss=False, checkpoint_every=40,
                               torch_threads=2)
"""The planner's PPO defaults (`auv-mj train ppo`): 128-step rollouts of the 96 vehicles (12,288 transitions),
4 epochs of 4 minibatches of whole vehicles' sequences, a 128-128 tanh encoder and a 128-unit GRU, no value
clipping (the returns are not on the policy ratio's scale), a checkpoint (and reset of the envs) every 40
rollouts, about 0.5 M steps, and the update on two threads (the batch's physics threads are idle while it runs).
Others are CleanRL's (`ppo.PPOConfig`)."""
