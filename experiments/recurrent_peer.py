"""The trainer's peer: sb3-contrib's RecurrentPPO on our training mixture, the learning problem of `--preset learned`.

`python -m experiments.recurrent_peer --run-dir runs/peer/recurrent-ppo --wall-clock 1800 --steps 10000000` trains
`sb3_contrib.RecurrentPPO("MlpLstmPolicy")` on the same problem as `auv-mj train ppo --preset learned`:
`LEARNED_MIXTURE`'s 12 cells (3 tasks x 2 tiers x 2 waters, its vehicles per cell with the hard cells
oversampled, 112 in all, TRAIN seeds only), its task options (reward="geodesic", action="rate",
observation="planner"), its reward scale (0.1) and the geodesic reward's own discount (GEODESIC_DISCOUNT). The env is
the mixture with autoreset SAME_STEP through our SB3 adapter (`auv_mj.tasks.vector_sb3.SB3VectorEnv`), seen through
SB3's `VecExtractDictObs(env, "observation")`: the learner reads the observation vector only, not the goals in the
world frame, as ours does.

Settings are an SB3 user's for this problem, matched to ours (`LEARNED_CONFIG`) where SB3 has the equivalent:
128-step rollouts, 4 epochs of 4 minibatches (batch_size 3,584 of the 14,336 transitions), gamma GEODESIC_DISCOUNT,
GAE lambda 0.95, clip 0.2, no value clipping, the learning rate linear from 3e-4 to 3e-5 over the step budget (SB3's
`LinearSchedule`; it spans `--steps` across resumes, as ours spans its run), target_kl 0.03 (SB3 stops an epoch's
minibatches past 1.5 x target_kl; ours stops after the epoch past it), observations normalised by `VecNormalize`
(running mean and std, as ours), rewards not (the mixture scales them), one torch thread and one C batch thread.
The network is sb3-contrib's: an LSTM of 128 units (ours a GRU of 128 after a 128-128 encoder) before 128-128 tanh
layers, with the critic's own LSTM (its default, `enable_critic_lstm`). sb3-contrib has no asymmetric critic: its
critic reads the actor's observation, where ours also reads info["privileged"] (geodesic distance, true clearance,
cell, time left).

The run stops at the wall-clock budget (`--wall-clock`, seconds, summed over resumes) or the step budget (`--steps`),
whichever comes first, after a whole update; `--resume` continues it (SB3's save and load of the model and of
VecNormalize's statistics, written atomically every `--save-every` rollouts and at the end; a resumed run starts new
episodes, with TRAIN seeds of a new stream). Logs: `progress.csv` a row per rollout (env steps, wall-clock, episodes
ended, their success, collision and return, SB3's KL, clip fraction and learning rate) and `cells.csv` the same per
cell. At the end the deterministic policy is validated on the hard cells with ours' validation seeds
(`auv_mj.agents.ppo.planner.validate`, its LSTM state carried and zeroed at each episode's start) and `result.json`
holds the figures.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import pickle
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from sb3_contrib import RecurrentPPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecExtractDictObs, VecNormalize

from auv_mj.agents.ppo.planner import LEARNED_CONFIG, LEARNED_MIXTURE, MixtureConfig, validate
from auv_mj.cli.options import positive_int, seed_int
from auv_mj.tasks.planning_rewards import GEODESIC_DISCOUNT
from auv_mj.tasks.vector_sb3 import SB3VectorEnv

MODEL_NAME = "model.zip"
NORMALIZER_NAME = "vecnormalize.pkl"
STATE_NAME = "state.json"
RESULT_NAME = "result.json"
PROGRESS_FIELDS = ("env_steps", "wall_s", "episodes", "success", "collision", "return", "approx_kl",
                   "clip_fraction", "learning_rate")
CELL_FIELDS = ("env_steps", "wall_s", "cell", "episodes", "success", "collision")


def peer_kwargs(mixture: MixtureConfig = LEARNED_MIXTURE, seed: int = 0) -> dict[str, Any]:
    """RecurrentPPO's arguments (see the module docstring). The learning rate's schedule spans a learn() call's
    steps; `train_peer` gives it what is left of the step budget with reset_num_timesteps=False, so it spans the
    budget across resumes."""
    config = LEARNED_CONFIG
    batch = config.num_steps * mixture.num_envs // config.num_minibatches
    return {"n_steps": config.num_steps, "batch_size": batch, "n_epochs": config.update_epochs,
            "gamma": GEODESIC_DISCOUNT, "gae_lambda": config.gae_lambda, "clip_range": config.clip_coef,
            "clip_range_vf": None, "ent_coef": config.ent_coef, "vf_coef": config.vf_coef,
            "max_grad_norm": config.max_grad_norm, "target_kl": config.target_kl,
            "learning_rate": LinearSchedule(config.learning_rate, config.min_learning_rate, 1.0),
            "policy_kwargs": {"lstm_hidden_size": config.recurrent_size, "net_arch": list(config.hidden_sizes),
                              "activation_fn": torch.nn.Tanh},
            "seed": seed, "device": "cpu", "verbose": 0}


def make_env(mixture: MixtureConfig = LEARNED_MIXTURE, threads: int = 1) -> SB3VectorEnv:
    """The mixture, SAME_STEP, as SB3's VecEnv (the observation dict: `VecExtractDictObs` takes the vector out)."""
    return SB3VectorEnv(mixture.make_env(threads, autoreset_mode="SameStep"))


class RecurrentPolicy:
    """An SB3 recurrent model as a policy over batched dict observations (`validate`'s interface): `reset()` starts
    every row's episode (a zero LSTM state); the state is carried from step to step after that. `validate` counts
    one episode a row, the first after the reset."""

    def __init__(self, model: RecurrentPPO, normalizer: VecNormalize | None, deterministic: bool = True):
        self.model, self.normalizer, self.deterministic = model, normalizer, deterministic
        self.reset()

    def reset(self) -> None:
        self.state: tuple[np.ndarray, ...] | None = None
        self.starts: np.ndarray | None = None

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        x = np.asarray(obs["observation"], np.float32)
        if self.normalizer is not None:
            x = self.normalizer.normalize_obs(x)
        starts = np.ones(len(x), bool) if self.starts is None else self.starts
        actions, self.state = self.model.predict(x, state=self.state, episode_start=starts,
                                                 deterministic=self.deterministic)
        self.starts = np.zeros(len(x), bool)
        return actions


class Log(BaseCallback):
    """Per-rollout CSV rows, periodic saves and the wall-clock stop (see the module docstring)."""

    def __init__(self, run_dir: Path, cells: list[str], cell_of_row: np.ndarray, wall_before: float,
                 wall_budget: float | None, save_every: int, save):
        super().__init__()
        self.run_dir, self.cells, self.cell_of_row = run_dir, cells, cell_of_row
        self.wall_before, self.wall_budget, self.save_every, self.save = wall_before, wall_budget, save_every, save
        self.rollouts = 0
        self.stop = False
        self.trained_steps = 0

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    def _on_training_start(self) -> None:
        self.started = time.perf_counter()
        self.trained_steps = self.num_timesteps
        self.returns = np.zeros(len(self.cell_of_row))
        self._clear()

    def _clear(self) -> None:
        n = len(self.cells)
        self.episodes, self.successes, self.collisions = np.zeros(n, int), np.zeros(n, int), np.zeros(n, int)
        self.ended_returns: list[float] = []

    def _on_step(self) -> bool:
        if self.stop:  # the first step of a rollout past the budget: nothing of it is trained on
            return False
        self.returns += self.locals["rewards"]
        for i in np.flatnonzero(self.locals["dones"]):
            info, cell = self.locals["infos"][i], self.cell_of_row[i]
            self.episodes[cell] += 1
            self.successes[cell] += bool(info.get("success", False))
            self.collisions[cell] += bool(info.get("collision", False))
            self.ended_returns.append(float(self.returns[i]))
            self.returns[i] = 0.0
        return True

    def _on_rollout_end(self) -> None:
        self.rollouts += 1

    def _on_rollout_start(self) -> None:  # the previous rollout's update is done
        if self.rollouts:
            self.write()
        if self.wall_budget is not None and self.rollouts and self.wall() >= self.wall_budget:
            self.stop = True

    def write(self) -> None:
        """The rows of the rollout just trained on; a save every `save_every` rollouts."""
        self.trained_steps = self.num_timesteps
        wall = round(self.wall(), 1)
        values = self.model.logger.name_to_value
        episodes = int(self.episodes.sum())

        def rate(counts, of):
            return round(float(counts.sum() / of.sum()), 4) if of.sum() else ""

        row = {"env_steps": self.num_timesteps, "wall_s": wall, "episodes": episodes,
               "success": rate(self.successes, self.episodes), "collision": rate(self.collisions, self.episodes),
               "return": round(float(np.mean(self.ended_returns)), 4) if self.ended_returns else "",
               **{key: round(float(values[f"train/{key}"]), 6) if f"train/{key}" in values else ""
                  for key in ("approx_kl", "clip_fraction", "learning_rate")}}
        _append(self.run_dir / "progress.csv", PROGRESS_FIELDS, [row])
        _append(self.run_dir / "cells.csv", CELL_FIELDS, [
            {"env_steps": self.num_timesteps, "wall_s": wall, "cell": cell, "episodes": int(self.episodes[k]),
             "success": round(self.successes[k] / self.episodes[k], 4) if self.episodes[k] else "",
             "collision": round(self.collisions[k] / self.episodes[k], 4) if self.episodes[k] else ""}
            for k, cell in enumerate(self.cells)])
        print(f"{self.num_timesteps} steps, {wall:.0f} s: {episodes} episodes, success {row['success']}, "
              f"collision {row['collision']}", flush=True)
        self._clear()
        if self.rollouts % self.save_every == 0:
            self.save(self.num_timesteps, self.wall())


def _append(path: Path, fields, rows) -> None:
    new = not path.exists()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, fields)
        if new:
            writer.writeheader()
        writer.writerows(rows)


def _write_json(path: Path, value: dict) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(value, indent=2))
    tmp.replace(path)


def train_peer(run_dir: str | Path, steps: int, wall_clock: float | None = None, *, resume: bool = False,
               seed: int = 0, threads: int = 1, torch_threads: int = 1, save_every: int = 10,
               mixture: MixtureConfig = LEARNED_MIXTURE) -> dict[str, Any]:
    """Trains (or resumes) the peer up to `steps` env steps or `wall_clock` seconds (over all its runs); returns
    the run's state {"env_steps", "wall_s", "runs", ...}."""
    run_dir = Path(run_dir)
    torch.set_num_threads(torch_threads)
    state_path = run_dir / STATE_NAME
    if resume:
        state = json.loads(state_path.read_text())
        if state["steps"] != steps:
            raise ValueError(f"{state_path}: the run's step budget (its learning rate's span) is {state['steps']}, "
                             f"not {steps}")
    else:
        if state_path.exists():
            raise FileExistsError(f"{state_path} exists: resume it or choose another run directory")
        run_dir.mkdir(parents=True, exist_ok=True)
        state = {"steps": steps, "env_steps": 0, "wall_s": 0.0, "runs": 0, "seed": seed,
                 "mixture": {"cells": ["/".join(c) for c in mixture.cells()], "counts": mixture.counts(),
                             "task_kwargs": mixture.task_kwargs(), "reward_scale": mixture.reward_scale}}
    base = make_env(mixture, threads)
    cells = ["/".join(c) for c in base.env.cells]
    cell_of_row = base.env.cell_of_row.copy()
    venv = VecExtractDictObs(base, "observation")
    if resume:
        venv = VecNormalize.load(str(run_dir / NORMALIZER_NAME), venv)
        model = RecurrentPPO.load(run_dir / MODEL_NAME, env=venv, device="cpu")
    else:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=False, gamma=GEODESIC_DISCOUNT)
        model = RecurrentPPO("MlpLstmPolicy", venv, **peer_kwargs(mixture, seed))
    venv.seed(seed + 7919 * state["runs"])  # a new stream of TRAIN seeds for each run
    state["runs"] += 1

    def save(env_steps: int, wall: float) -> None:
        model.save(run_dir / "model.tmp.zip")
        os.replace(run_dir / "model.tmp.zip", run_dir / MODEL_NAME)
        venv.save(str(run_dir / "vecnormalize.tmp.pkl"))
        os.replace(run_dir / "vecnormalize.tmp.pkl", run_dir / NORMALIZER_NAME)
        _write_json(state_path, {**state, "env_steps": int(env_steps), "wall_s": round(wall, 1)})

    log = Log(run_dir, cells, cell_of_row, state["wall_s"], wall_clock, save_every, save)
    remaining = steps - model.num_timesteps
    if remaining > 0 and (wall_clock is None or state["wall_s"] < wall_clock):
        model.learn(total_timesteps=remaining, callback=log, reset_num_timesteps=False, progress_bar=False)
        if log.rollouts and log.trained_steps < model.num_timesteps and not log.stop:
            log.write()  # the last rollout of the step budget
        model.num_timesteps = log.trained_steps  # a rollout cut at its first step past the wall-clock budget
        save(model.num_timesteps, log.wall())
    venv.close()
    state = json.loads(state_path.read_text())
    return state


def validate_peer(run_dir: str | Path, episodes: int, threads: int = 1,
                  mixture: MixtureConfig = LEARNED_MIXTURE) -> dict[str, float]:
    """The deterministic policy's success per hard cell on `episodes` validation seeds each (ours' `validate`)."""
    run_dir = Path(run_dir)
    model = RecurrentPPO.load(run_dir / MODEL_NAME, device="cpu")
    with open(run_dir / NORMALIZER_NAME, "rb") as f:
        normalizer = pickle.load(f)  # our own run's VecNormalize statistics (VecNormalize.load wants an env)
    normalizer.training = False
    return validate(RecurrentPolicy(model, normalizer), episodes, mixture.tasks, threads=threads,
                    max_steps=mixture.validation_max_steps, task_kwargs=mixture.policy_kwargs())


def plot_curves(run_dir: str | Path, path: str | Path) -> Path:
    """PNG of the training episodes' success and collision rates per rollout against env steps and against
    wall-clock (progress.csv)."""
    from auv_mj.figures.canvas import new_figure, save

    with open(Path(run_dir) / "progress.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["success"] != ""]
    fig, axes = new_figure(1100, 420, 1, 2, sharey=True)
    for ax, x, label in ((axes[0], "env_steps", "environment steps"), (axes[1], "wall_s", "wall-clock (s)")):
        xs = [float(r[x]) for r in rows]
        for column, colour in (("success", "tab:blue"), ("collision", "tab:red")):
            ax.plot(xs, [float(r[column]) for r in rows], color=colour, label=f"{column} (training episodes)")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("rate per rollout")
    axes[0].set_ylim(-0.05, 1.05)
    axes[0].legend(loc="best", fontsize="small")
    fig.suptitle("sb3-contrib RecurrentPPO on the learned mixture (all 12 cells)")
    fig.tight_layout()
    return save(fig, path)


def main(argv: list[str] | None = None, mixture: MixtureConfig = LEARNED_MIXTURE) -> int:
    """Trains the peer (or resumes it) on `mixture`, validates it and writes result.json."""
    parser = argparse.ArgumentParser(prog="python -m experiments.recurrent_peer", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run-dir", type=Path, default=Path("runs/peer/recurrent-ppo"))
    parser.add_argument("--steps", type=positive_int, default=10_000_000,
                        help="step budget, the learning rate's span (ours': 10 M)")
    parser.add_argument("--wall-clock", type=float, default=None, help="wall-clock budget in seconds, all runs")
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--seed", type=seed_int, default=0)
    parser.add_argument("--threads", type=positive_int, default=1, help="C batch threads of each cell")
    parser.add_argument("--torch-threads", type=positive_int, default=1)
    parser.add_argument("--save-every", type=positive_int, default=10, help="rollouts between saves")
    parser.add_argument("--validation-episodes", type=int, default=20, help="per hard cell; 0: no validation")
    args = parser.parse_args(argv)
    state = train_peer(args.run_dir, args.steps, args.wall_clock, resume=args.resume, seed=args.seed,
                       threads=args.threads, torch_threads=args.torch_threads, save_every=args.save_every,
                       mixture=mixture)
    result: dict[str, Any] = {"env_steps": state["env_steps"], "wall_s": state["wall_s"], "runs": state["runs"],
                              "samples_per_s": round(state["env_steps"] / state["wall_s"], 1) if state["wall_s"]
                              else None, "steps_budget": args.steps, "wall_clock_budget": args.wall_clock,
                              "seed": args.seed, "threads": args.threads, "torch_threads": args.torch_threads}
    if args.validation_episodes > 0:
        started = time.perf_counter()
        rates = validate_peer(args.run_dir, args.validation_episodes, args.threads, mixture)
        result.update(validation_episodes_per_cell=args.validation_episodes, validation=rates,
                      hard_success=round(float(np.mean(list(rates.values()))), 4),
                      validation_wall_s=round(time.perf_counter() - started, 1))
    _write_json(args.run_dir / RESULT_NAME, result)
    if (args.run_dir / "progress.csv").is_file():
        plot_curves(args.run_dir, args.run_dir / "curves.png")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
