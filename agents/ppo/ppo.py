"""Proximal Policy Optimisation (Schulman et al. 2017) with an optional GRU or LSTM memory, on Gymnasium vector envs.

This file reads top to bottom as CleanRL's `ppo_continuous_action.py` and `ppo_atari_lstm.py` do: GAE, the clipped
losses, the minibatches, the update, and the training loop that collects a rollout, updates, logs and checkpoints.
Every step of the update is a function that tests call. Its parts, each a module of the package:

- `config`: the hyper-parameters (`PPOConfig`, defaults CleanRL's) and the learning rate, clip range and imitation
  weight schedules over the run's planned env steps (`schedule_at`);
- `model`: the actor-critic (`ActorCritic`: a Gaussian policy, an optional GRU/LSTM memory, an optional critic of its
  own with privileged inputs that the actor never reads), with `gru`, the update's GRU over whole sequences;
- `rollout`: the `Collector`, which steps the env into a `Rollout`, carrying each env's memory through episode ends
  and autoresets (NEXT_STEP's reset steps are in the rollout but masked out of every loss, `valid`);
- `logs`: progress.csv, cells.csv (per cell of the env) and TensorBoard;
- `checkpoint`: the run's checkpoint (`checkpoint.pt`, kind "ppo" of `auv_mj.agents.checkpoint`);
- `spaces`: what the networks see of the env's spaces; `policy`: the deployable `PPOPolicy`.

Minibatches are whole environments for a memory (so the update re-runs each sequence from the rollout's initial state
with the same `starts`), single transitions otherwise. An optional `target_kl` stops an update's epochs early
(CleanRL's approx_kl stop); it is off by default.

Checkpoints fall every `checkpoint_every` rollouts and at the end of a `train` call. At every multiple of
`checkpoint_every`, and at the start of each `train` call, the envs are reset with seeds derived from (seed, rollout
index) (`auv_mj.seeds.train_seed`): env states cannot be saved, so no run carries one past a periodic checkpoint, and
a run resumed from one (after a crash, or a `train` call whose total_steps ended on a multiple of checkpoint_every
rollouts) repeats the uninterrupted run exactly. Resumed from an end checkpoint between multiples, it differs from
the uninterrupted run by that extra reset. The episodes cut by a reset end like a time limit (bootstrapped from the
last value).
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections import deque
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch
from gymnasium.vector import VectorEnv
from torch import nn

from auv_mj.agents.checkpoint import config_to_dict, load_optimizer
from auv_mj.agents.ppo.checkpoint import (
    CHECKPOINT_NAME,
    frozen_copy,
    load_actor,
    load_anchor,
    load_model,
    read_ppo,
    save_ppo,
)
from auv_mj.agents.ppo.config import PPOConfig, imitation_weight, schedule_at
from auv_mj.agents.ppo.logs import LOG_FIELDS, RETURN_WINDOW, RunLogs, episode_summary, progress_text
from auv_mj.agents.ppo.model import ActorCritic, build_model
from auv_mj.agents.ppo.rollout import Collector, Episode, Rollout, privileged_size
from auv_mj.agents.ppo.spaces import autoreset_mode, env_spec
from auv_mj.console import progress_bar
from auv_mj.seeds import train_seed


def gae(rewards: torch.Tensor, values: torch.Tensor, terminations: torch.Tensor, truncations: torch.Tensor,
        next_values: torch.Tensor, gamma: float, lam: float) -> tuple[torch.Tensor, torch.Tensor]:
    """(advantages, returns) by generalised advantage estimation (Schulman et al. 2016, Eq. 16), arrays (T, N).

    next_values[t] is V(s_{t+1}), the value of the observation that followed action t in the same episode: at a
    truncation (time limit) that is the episode's final observation, and the TD error bootstraps from it; at a
    termination it is ignored (no future). The advantage recursion stops at every episode end:
        delta_t = r_t + gamma (1 - term_t) next_values_t - values_t
        A_t = delta_t + gamma lam (1 - (term_t or trunc_t)) A_{t+1},   returns_t = A_t + values_t.
    The last step's A_{t+1} is 0 (the rollout's bootstrap is in next_values[T-1]).
    """
    terms, ends = terminations.to(values.dtype), torch.maximum(terminations, truncations).to(values.dtype)
    deltas = rewards + gamma * (1.0 - terms) * next_values - values
    advantages = torch.zeros_like(values)
    running = torch.zeros_like(values[0])
    for t in reversed(range(values.shape[0])):
        running = deltas[t] + gamma * lam * (1.0 - ends[t]) * running
        advantages[t] = running
    return advantages, advantages + values


def advantages_of(rollout: Rollout, config: PPOConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """GAE (advantages, returns) of a rollout, zero on the steps that are not in the loss."""
    adv, ret = gae(rollout.rewards, rollout.values, rollout.terminations, rollout.truncations, rollout.next_values,
                   config.gamma, config.gae_lambda)
    return adv * rollout.valid, ret * rollout.valid


def masked_mean(x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """Mean of x over the entries where mask is 1 (all when mask is None)."""
    if mask is None:
        return x.mean()
    return (x * mask).sum() / mask.sum().clamp_min(1.0)


def clipped_surrogate(logprob: torch.Tensor, old_logprob: torch.Tensor, advantages: torch.Tensor, clip_coef: float,
                      mask: torch.Tensor | None = None) -> torch.Tensor:
    """The clipped policy loss -L^CLIP (Schulman et al. 2017, Eq. 7): mean of max(-A r, -A clip(r, 1-e, 1+e)),
    r = pi/pi_old. Where the clipped term is the larger, its gradient is zero: no incentive to move r further."""
    ratio = (logprob - old_logprob).exp()
    return masked_mean(torch.maximum(-advantages * ratio, -advantages * ratio.clamp(1 - clip_coef, 1 + clip_coef)),
                       mask)


def value_loss(values: torch.Tensor, old_values: torch.Tensor, returns: torch.Tensor, clip_coef: float | None,
               mask: torch.Tensor | None = None) -> torch.Tensor:
    """0.5 (V - R)^2, or with clip_coef the larger of it and 0.5 (V_old + clip(V - V_old, +-clip_coef) - R)^2
    (the value clipping of OpenAI Baselines' PPO2)."""
    loss = (values - returns).square()
    if clip_coef is not None:
        clipped = old_values + (values - old_values).clamp(-clip_coef, clip_coef)
        loss = torch.maximum(loss, (clipped - returns).square())
    return 0.5 * masked_mean(loss, mask)


class Minibatch(NamedTuple):
    """Sequences (T, B, ...) of a rollout to replay: B whole envs (recurrent) or B single transitions (T = 1)."""

    obs: torch.Tensor
    starts: torch.Tensor
    state: torch.Tensor
    """Memory before obs[0], (B, S)."""
    actions: torch.Tensor
    logprobs: torch.Tensor
    values: torch.Tensor
    advantages: torch.Tensor
    returns: torch.Tensor
    valid: torch.Tensor
    """1 for transitions in the loss, 0 for NEXT_STEP's reset steps."""
    privileged: torch.Tensor | None = None
    """The critic's privileged inputs (T, B, P), or None."""
    labels: torch.Tensor | None = None
    """A teacher's actions (T, B, act_dim) in the normalised space, or None."""


def ppo_loss(model: ActorCritic, batch: Minibatch, config: PPOConfig, clip_coef: float | None = None,
             imitation: float = 0.0, critic_only: bool = False) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The PPO objective to minimise, -L^CLIP + vf_coef L^VF - ent_coef S (Schulman et al. 2017, Eq. 9), on one
    minibatch, and its parts (detached) for the logs; `clip_coef` is the scheduled clip range (None:
    config.clip_coef). With `imitation` > 0 and the batch's teacher labels, plus imitation times the squared error
    between the actor's mean action and the label (the decaying imitation term of a fine-tune, `imitation_weight`),
    averaged over the labelled states: a NaN label is a state the teacher leaves to RL (`BatchTeacher`'s
    mover_reach). With `critic_only` (config.critic_warmup_steps), vf_coef L^VF alone: the actor gets no gradient;
    the other parts are still measured for the logs."""
    clip_coef = config.clip_coef if clip_coef is None else clip_coef
    action_mean, value, _ = model(batch.obs, batch.starts, batch.state, batch.privileged)
    dist = model.distribution(action_mean)
    logprob, entropy = dist.log_prob(batch.actions).sum(-1), dist.entropy().sum(-1)
    advantages, mask = batch.advantages, batch.valid
    if config.norm_adv:
        mean = masked_mean(advantages, mask)
        std = masked_mean((advantages - mean).square(), mask).sqrt()
        advantages = (advantages - mean) / (std + 1e-8)
    pg = clipped_surrogate(logprob, batch.logprobs, advantages, clip_coef, mask)
    vf = value_loss(value, batch.values, batch.returns, clip_coef if config.clip_vloss else None, mask)
    ent = masked_mean(entropy, mask)
    bc = torch.zeros_like(vf)
    if imitation > 0 and batch.labels is not None:
        labelled = torch.isfinite(batch.labels).all(-1)  # a NaN label: a state the teacher leaves to RL
        error = ((action_mean - torch.nan_to_num(batch.labels)) ** 2).sum(-1)
        bc = masked_mean(error, mask * labelled.to(mask.dtype))
    # the critic warm-up trains the value alone; otherwise the sum in the order of Eq. 9, then the imitation term
    loss = config.vf_coef * vf if critic_only else pg + config.vf_coef * vf - config.ent_coef * ent + imitation * bc
    with torch.no_grad():
        log_ratio = logprob - batch.logprobs
        stats = {"policy_loss": pg.detach(), "value_loss": vf.detach(), "entropy": ent.detach(),
                 "approx_kl": masked_mean(log_ratio.exp() - 1 - log_ratio, mask),
                 "clip_fraction": masked_mean(((log_ratio.exp() - 1).abs() > clip_coef).to(mask.dtype), mask),
                 "imitation_loss": bc.detach()}
    return loss, stats


def minibatches(rollout: Rollout, advantages: torch.Tensor, returns: torch.Tensor, config: PPOConfig,
                generator: torch.Generator) -> list[Minibatch]:
    """One epoch's minibatches in a random order: groups of whole envs' sequences (recurrent, so the memory is
    re-run from the rollout's initial state), or of single transitions (feed-forward)."""
    r = rollout
    privileged = r.privileged if r.privileged is not None else r.obs.new_zeros(*r.obs.shape[:2], 0)
    labels = r.labels if r.labels is not None else r.obs.new_zeros(*r.obs.shape[:2], 0)
    fields = (r.obs, r.starts, r.actions, r.logprobs, r.values, advantages, returns, r.valid, privileged, labels)

    def batch(parts: list[torch.Tensor], state: torch.Tensor) -> Minibatch:
        obs, starts, actions, logprobs, values, adv, ret, valid, priv, lab = parts
        return Minibatch(obs, starts, state, actions, logprobs, values, adv, ret, valid,
                         priv if r.privileged is not None else None, lab if r.labels is not None else None)

    if r.initial_state.shape[-1]:
        n_envs = r.obs.shape[1]
        order = torch.randperm(n_envs, generator=generator, device=generator.device).to(r.obs.device)
        return [batch([x[:, envs] for x in fields], r.initial_state[envs])
                for envs in order.tensor_split(config.num_minibatches)]
    flat = [x.flatten(0, 1)[None] for x in fields]
    order = torch.randperm(flat[0].shape[1], generator=generator, device=generator.device).to(r.obs.device)
    return [batch([x[:, idx] for x in flat], r.initial_state.new_zeros(len(idx), 0))
            for idx in order.tensor_split(config.num_minibatches)]


def update(model: ActorCritic, optimizer: torch.optim.Optimizer, rollout: Rollout, config: PPOConfig,
           generator: torch.Generator, clip_coef: float | None = None, imitation: float = 0.0,
           critic_only: bool = False) -> dict[str, float]:
    """update_epochs passes of minibatch gradient steps on `ppo_loss` over one rollout (Schulman et al. 2017,
    Algorithm 1), with the optimiser's learning rate as it is and the clip range `clip_coef` (None:
    config.clip_coef); with config.target_kl the passes stop after the first epoch whose mean approximate KL
    exceeds it (CleanRL's early stop; with `critic_only` the actor is held, its KL is 0 and every epoch runs). The
    mean of each loss part over the steps, the explained variance of the returns, the gradient steps and the epochs
    run."""
    advantages, returns = advantages_of(rollout, config)
    totals: dict[str, float] = {}
    steps = epochs = 0
    for _ in range(config.update_epochs):
        kls = []
        epochs += 1
        for batch in minibatches(rollout, advantages, returns, config, generator):
            loss, stats = ppo_loss(model, batch, config, clip_coef, imitation, critic_only)
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), config.max_grad_norm)
            optimizer.step()
            for key, value in stats.items():
                totals[key] = totals.get(key, 0.0) + float(value)
            kls.append(stats["approx_kl"])
            steps += 1
        if config.target_kl is not None and float(torch.stack(kls).mean()) > config.target_kl:
            break
    out = {key: value / max(steps, 1) for key, value in totals.items()}
    valid = rollout.valid.bool()
    y, pred = returns[valid], rollout.values[valid]
    var = float(y.var()) if y.numel() > 1 else 0.0
    out["explained_variance"] = float("nan") if var == 0 else 1.0 - float((y - pred).var()) / var
    out["gradient_steps"], out["epochs"] = steps, epochs
    return out


def _generator(config: PPOConfig) -> torch.Generator:
    generator = torch.Generator(device=config.device)
    generator.manual_seed(config.seed)
    return generator


def make_optimizer(model: ActorCritic, config: PPOConfig) -> torch.optim.Adam:
    """Adam over every trained parameter (the normaliser's statistics are buffers, not parameters)."""
    return torch.optim.Adam(model.parameters(), lr=config.learning_rate, eps=config.adam_eps)


@dataclasses.dataclass
class PPOResult:
    """Where a run was written and how it went (counters are totals over resumes)."""

    run_dir: Path
    checkpoint: Path
    env_steps: int
    iterations: int
    episodes: int
    mean_return: float
    """Mean return of the episodes finished in the last rollout (nan if none)."""


def _open_env(env: VectorEnv | Callable[[], VectorEnv]) -> tuple[VectorEnv, bool]:
    """The vector env, and whether this module made it (and so closes it)."""
    if isinstance(env, VectorEnv):
        return env, False
    if not callable(env):
        raise ValueError(f"env must be a gymnasium VectorEnv or a function returning one, got {type(env).__name__}")
    made = env()
    if not isinstance(made, VectorEnv):
        raise ValueError(f"env_fn must return a gymnasium.vector.VectorEnv, got {type(made).__name__}")
    return made, True


def reset_seeds(seed: int, iteration: int, num_envs: int) -> list[int]:
    """The seeds the envs are reset with before rollout `iteration` (distinct, in auv_mj.seeds.TRAIN)."""
    return [train_seed(seed, iteration * num_envs + i) for i in range(num_envs)]


def train(env: VectorEnv | Callable[[], VectorEnv], config: PPOConfig | None, run_dir: str | Path, total_steps: int,
          *, resume: bool = False, progress: bool = True, tensorboard: bool = False,
          schedule_steps: int | None = None,
          step_speed: Callable[[Any, Mapping[str, Any]], np.ndarray] | None = None,
          teacher: Callable[[], np.ndarray] | None = None, init: str | Path | None = None,
          init_critic: bool = False) -> PPOResult:
    """Trains PPO on a Gymnasium vector env (or a zero-argument function making one) for `total_steps` env steps
    (rounded up to whole rollouts of num_steps x num_envs), checkpointing to `run_dir/checkpoint.pt`.

    `config` None takes PPOConfig's defaults (or, resuming, the checkpoint's). `resume=True` continues the run in
    `run_dir` from its checkpoint (`config`, if given, must equal the saved one) and gives exactly the result of
    an uninterrupted run to the same `total_steps` (see the module docstring for when).

    `schedule_steps` are the env steps the whole run is planned for, over which the learning rate and clip range
    follow their schedules (`schedule_at`): by default `total_steps` of the call that starts the run. It is kept
    in the checkpoint's counters, and a resumed run continues it (a different value given on resume is refused),
    so a run trained in pieces (`auv_mj.agents.ppo.planner`, or after an interruption) has at every update the
    learning rate of the uninterrupted run; steps past the planned ones train at the floors.

    Logs: a row per rollout to `progress.csv` (`LOG_FIELDS`), and per cell of the env (`Collector`) the episodes
    that ended in the rollout to `cells.csv` (`CELL_FIELDS`; rows after the checkpoint, from a crashed run, are
    dropped from both on resume); with `tensorboard`, the same as TensorBoard scalars in `run_dir/tb`.
    `step_speed(next_obs, info)` gives each row's speed over a step, for the logs' mean speed.

    Fine-tuning a student (issue 51): `init`, a checkpoint of kind "ppo" for the same spaces (a DAgger run's
    student.pt, `auv_mj.agents.imitation`), gives a new run its networks and observation statistics; `teacher()`,
    the teacher's actions (N, act_dim) at the env's current states, labels every rollout step, and with
    config.imitation_coef > 0 the update adds the decaying imitation term (`imitation_weight`, `ppo_loss`).
    With `init_critic`, `init`'s critic comes too where the whole of it fits (a PPO run's own checkpoint,
    continued on a new mixture: `load_actor`). With config.imitation_source "init" no teacher is given: a frozen
    copy of `init`'s actor labels the rollouts (its anchor, kept in the run's checkpoint for a resume), and the
    imitation term holds the actor near where it started.
    """
    if not isinstance(total_steps, int) or isinstance(total_steps, bool) or total_steps < 1:
        raise ValueError(f"total_steps must be a whole number >= 1, got {total_steps!r}")
    if schedule_steps is not None and (not isinstance(schedule_steps, int) or isinstance(schedule_steps, bool)
                                       or schedule_steps < 1):
        raise ValueError(f"schedule_steps must be a whole number >= 1, got {schedule_steps!r}")
    run_dir = Path(run_dir)
    ckpt_path = run_dir / CHECKPOINT_NAME
    vec_env, owned = _open_env(env)
    threads = torch.get_num_threads()  # the caller's, given back at the end (the loop sets its own)
    try:
        spec = env_spec(vec_env.single_observation_space, vec_env.single_action_space)
        options = dict(getattr(vec_env, "policy_options", None) or {})
        if options:  # the task options the policy must run with (the zoo applies them when it deploys the file)
            spec["task_options"] = options
        autoreset_mode(vec_env)
        num_envs = int(vec_env.num_envs)
        if resume:
            (tensors, meta), saved = read_ppo(ckpt_path)
            if config is not None and config != saved:
                raise ValueError(f"checkpoint {ckpt_path} was trained with {saved}, not {config}")
            config = saved
            if {k: v for k, v in meta["spec"].items() if k != "privileged_dim"} != spec:
                raise ValueError(f"checkpoint {ckpt_path} is for spaces {meta['spec']}, this env has {spec}")
            spec = dict(meta["spec"])
            counters = dict(meta.get("counters", {}))
            planned = int(counters.get("schedule_steps", schedule_steps or total_steps))
            if schedule_steps is not None and schedule_steps != planned:
                raise ValueError(f"checkpoint {ckpt_path}: its schedules span {planned} env steps, not "
                                 f"schedule_steps={schedule_steps}; a resumed run keeps its schedule")
            counters["schedule_steps"] = planned
        else:
            if ckpt_path.exists():
                raise FileExistsError(f"{ckpt_path} exists: resume it or choose another run directory")
            config = config or PPOConfig()
            counters = {"iteration": 0, "env_steps": 0, "episodes": 0, "wall_time": 0.0,
                        "schedule_steps": schedule_steps or total_steps}
            if config.privileged_critic:
                spec["privileged_dim"] = privileged_size(vec_env, reset_seeds(config.seed, 0, num_envs))
        if config.recurrent is not None and config.num_minibatches > num_envs:
            raise ValueError(f"PPOConfig.num_minibatches {config.num_minibatches} exceeds the {num_envs} envs: a "
                             "recurrent minibatch holds whole envs' sequences")
        if config.num_minibatches > config.num_steps * num_envs:
            raise ValueError(f"PPOConfig.num_minibatches {config.num_minibatches} exceeds the rollout's "
                             f"{config.num_steps * num_envs} transitions")
        generator = _generator(config)
        if resume:
            model = load_model(ckpt_path, tensors, spec, config)
            optimizer = make_optimizer(model, config)
            load_optimizer(optimizer, tensors, "optimizer", ckpt_path)
            if "generator" in tensors:
                generator.set_state(tensors["generator"])
        else:
            model = build_model(spec, config)
            if init is not None:
                (init_tensors, init_meta), _ = read_ppo(init)
                if {k: v for k, v in init_meta["spec"].items() if k != "privileged_dim"} != {
                        k: v for k, v in spec.items() if k != "privileged_dim"}:
                    raise ValueError(f"checkpoint {init} is for spaces {init_meta['spec']}, this env has {spec}")
                load_actor(model, init_tensors, Path(init), critic=init_critic)
            optimizer = make_optimizer(model, config)
        anchor = None
        if config.imitation_coef > 0 and config.imitation_source == "init":
            if teacher is not None:
                raise ValueError("PPOConfig.imitation_source 'init' labels with the run's starting actor: give no "
                                 "teacher, or imitation_source 'teacher'")
            if not resume and init is None:
                raise ValueError("PPOConfig.imitation_source 'init' needs init, the checkpoint whose actor anchors "
                                 "the run (train(..., init=...), --init)")
            anchor = load_anchor(ckpt_path, tensors, model) if resume else frozen_copy(model)
        elif config.imitation_coef > 0 and teacher is None:
            raise ValueError("PPOConfig.imitation_coef > 0 needs a teacher (train(..., teacher=...)), or "
                             "imitation_source 'init'")
        collector = Collector(vec_env, model, spec, config, generator, step_speed,
                              teacher if config.imitation_coef > 0 and anchor is None else None, anchor)
        return _train_loop(collector, optimizer, config, run_dir, counters, total_steps, resume, progress,
                           tensorboard)
    finally:
        torch.set_num_threads(threads)
        if owned:
            vec_env.close()


def _train_loop(collector: Collector, optimizer: torch.optim.Optimizer, config: PPOConfig, run_dir: Path,
                counters: dict[str, Any], total_steps: int, resume: bool, progress: bool,
                tensorboard: bool) -> PPOResult:
    """Rollout, update, log, checkpoint, until total_steps; the envs are reset at every checkpoint."""
    model, spec, generator = collector.model, collector.spec, collector.generator
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(json.dumps({"agent": "ppo", "config": config_to_dict(config),
                                                     "spec": spec}, indent=2))
    logs = RunLogs(run_dir, counters["iteration"], resume, tensorboard, counters["env_steps"])
    per_rollout = config.num_steps * collector.num_envs
    iterations = math.ceil(total_steps / per_rollout)
    bar = progress_bar(total=iterations * per_rollout, initial=counters["env_steps"], unit="step",
                       disable=not progress)
    started, wall_before = time.perf_counter(), float(counters.get("wall_time", 0.0))
    mean_return = float("nan")
    recent: deque[Episode] = deque(maxlen=RETURN_WINDOW)
    try:
        while counters["iteration"] < iterations:
            t0 = time.perf_counter()
            if counters["iteration"] % config.checkpoint_every == 0 or collector.obs is None:
                collector.reset(reset_seeds(config.seed, counters["iteration"], collector.num_envs))
            lr, clip = schedule_at(config, counters["env_steps"], counters["schedule_steps"])
            imitation = imitation_weight(config, counters["env_steps"], counters["schedule_steps"])
            for group in optimizer.param_groups:
                group["lr"] = lr
            model.eval()
            torch.set_num_threads(1)
            rollout = collector.rollout(config.num_steps)
            model.train()
            torch.set_num_threads(config.torch_threads)
            critic_only = counters["env_steps"] < config.critic_warmup_steps
            stats = update(model, optimizer, rollout, config, generator, clip, imitation, critic_only)
            model.obs_norm.sync()
            if model.privileged_dim:
                model.privileged_norm.sync()
            finished = collector.take_finished()
            counters["iteration"] += 1
            counters["env_steps"] += per_rollout
            counters["episodes"] += len(finished)
            summary = episode_summary(finished)
            mean_return = summary["mean_return"]
            sps = per_rollout / max(time.perf_counter() - t0, 1e-9)
            row = {"iteration": counters["iteration"], "env_steps": counters["env_steps"],
                   "episodes": counters["episodes"], "samples_per_s": sps, "learning_rate": lr, "clip_coef": clip,
                   **summary, **{k: stats.get(k, float("nan")) for k in LOG_FIELDS[4:10]},
                   "epochs": stats["epochs"], "imitation_coef": imitation,
                   "imitation_loss": stats.get("imitation_loss", float("nan"))}
            cell_rows = []
            for cell, name in enumerate(collector.cell_names):
                episodes = [e for e in finished if e.cell == cell]
                if episodes:
                    cell_rows.append({"iteration": counters["iteration"], "env_steps": counters["env_steps"],
                                      "cell": name, "episodes": len(episodes), **episode_summary(episodes)})
            logs.write(row, cell_rows)
            bar.update(per_rollout)
            recent.extend(finished)
            bar.set_postfix_str(progress_text(recent, counters["episodes"], lr, sps))
            if counters["iteration"] % config.checkpoint_every == 0 or counters["iteration"] == iterations:
                counters["wall_time"] = wall_before + time.perf_counter() - started
                save_ppo(run_dir / CHECKPOINT_NAME, model, optimizer, generator, config, spec, counters,
                         collector.anchor)
    finally:
        bar.close()
        logs.close()
    return PPOResult(run_dir, run_dir / CHECKPOINT_NAME, counters["env_steps"], counters["iteration"],
                     counters["episodes"], mean_return)
