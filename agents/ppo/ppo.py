"""Proximal Policy Optimisation (Schulman et al. 2017) with an optional GRU or LSTM memory, on Gymnasium vector envs.

This file reads top to bottom as CleanRL's `ppo_continuous_action.py` and `ppo_atari_lstm.py` do: a frozen config,
the actor-critic, the rollout, GAE, the clipped losses, the update, the checkpoint and the training loop. Every step
of the update is a function that tests call. Beside it: `spaces` (what the networks see of the env's spaces),
`gru` (the update's GRU), `policy` (the deployable `PPOPolicy`) and `planner` (the planner trained with it).

- Actions: a Gaussian with a state-independent log std, in a normalised action space whose [-1, 1] is the env's
  Box; the sampled action is clipped to [-1, 1] and rescaled to the Box only when it is sent to the env, and the
  loss uses the unclipped sample (as CleanRL's `ClipAction`). The deployable policy takes the clipped mean.
- Observations: a Box, or a goal Dict's `observation` and `desired_goal` (`auv_mj.agents.ppo.spaces`). A running
  mean/std normaliser (`auv_mj.agents.normalizer.Normalizer`, in every checkpoint) standardises them; it is updated
  from each rollout after the update, so a rollout is replayed with the statistics it was collected with (the
  first ratio of an update is 1, to float rounding).
- Critic: by default the recurrent actor and critic share the encoder and cell; `separate_critic` gives the critic
  its own (sb3-contrib's RecurrentPPO's default), and `privileged_critic` feeds it the env's info["privileged"]
  (N, P) beside the observation (an asymmetric critic, Pinto et al. 2018). The actor's network never reads them:
  `ActorCritic.act`, what the deployed `PPOPolicy` runs, takes no privileged input.
- Memory (`recurrent="gru"` or `"lstm"`): an MLP encoder, one GRU/LSTM cell, then linear policy and value heads.
  The state is carried across a rollout and zeroed before the first observation of each episode (`starts`);
  minibatches are whole environments, and the update re-runs each sequence from the rollout's initial state
  with the same `starts`. A rollout steps `nn.GRUCell`; the update runs the same GRU over the whole sequence
  with its backward pass written out (`auv_mj.agents.ppo.gru.gru_sequence`).
- Episode ends and autoreset (Gymnasium >= 1.0, `gymnasium.vector.AutoresetMode`): `env.metadata
  ["autoreset_mode"]`, NEXT_STEP when absent (the default of SyncVectorEnv and AsyncVectorEnv).
  NEXT_STEP: the step that ends an episode returns its final observation; the next `step` resets that env and
  ignores its action, returning reward 0 and the first observation. That extra step is kept in the rollout
  (its value V(final observation) is the bootstrap of a truncation, computed with the episode's memory) but
  masked out of every loss (`valid`). SAME_STEP: the step returns the next episode's first observation and
  `info["final_obs"]`; V(final observation) is computed from the episode's memory for truncated envs.
  DISABLED is refused. GAE bootstraps truncations (time limits) from V(final observation) and not
  terminations, through a separate `next_values` array (`gae`).
- Schedules: the learning rate and the clip range fall to their floors over the run's planned env steps
  (`lr_schedule`, `clip_schedule`: constant, linear as CleanRL's, or cosine), as functions of the global step
  (`schedule_at`); the planned steps are in the checkpoint, so a resumed run continues the same schedule. An
  optional `target_kl` stops an update's epochs early (CleanRL's approx_kl stop); both are off by default.
- Logs: progress.csv a row per rollout; cells.csv, per cell of the env (`Collector`), the success, collision rate,
  speed and return of the episodes that ended; TensorBoard the same, where it is installed.
- Checkpoints (`checkpoint.pt`, kind "ppo" of `auv_mj.agents.checkpoint`) fall every `checkpoint_every` rollouts
  and at the end of a `train` call. At every multiple of `checkpoint_every`, and at the start of each `train`
  call, the envs are reset with seeds derived from (seed, rollout index) (`auv_mj.seeds.train_seed`): env
  states cannot be saved, so no run carries one past a periodic checkpoint, and a run resumed from one (after a
  crash, or a `train` call whose total_steps ended on a multiple of checkpoint_every rollouts) repeats the
  uninterrupted run exactly. Resumed from an end checkpoint between multiples, it differs from the uninterrupted
  run by that extra reset. The episodes cut by a reset end like a time limit (bootstrapped from the last value).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import time
import warnings
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch
from gymnasium.vector import AutoresetMode, VectorEnv
from torch import nn

from auv_mj.agents.checkpoint import (
    Checkpoint,
    config_to_dict,
    load_module,
    load_optimizer,
    module_tensors,
    optimizer_tensors,
    read_checkpoint,
    save_checkpoint,
    saved_config,
)
from auv_mj.agents.normalizer import Normalizer
from auv_mj.agents.ppo.gru import gru_sequence
from auv_mj.agents.ppo.spaces import (
    autoreset_mode,
    env_action,
    env_spec,
    final_observation,
    flatten_obs,
    normalised_action,
)
from auv_mj.console import progress_bar
from auv_mj.seeds import train_seed

CHECKPOINT_NAME = "checkpoint.pt"
LOG_NAME = "progress.csv"
CELLS_LOG_NAME = "cells.csv"
LOG_FIELDS = ("iteration", "env_steps", "episodes", "mean_return", "policy_loss", "value_loss", "entropy",
              "approx_kl", "clip_fraction", "explained_variance", "samples_per_s", "learning_rate", "clip_coef",
              "epochs", "success_rate", "collision_rate", "mean_speed", "imitation_coef", "imitation_loss")
"""The columns of progress.csv, a row per rollout (a run logged before the last eight were added resumes with them
empty in its old rows)."""
CELL_FIELDS = ("iteration", "env_steps", "cell", "episodes", "success_rate", "collision_rate", "mean_speed",
               "mean_return")
"""The columns of cells.csv: per rollout and cell, the episodes that ended in it and their means."""
RECURRENT_KINDS = (None, "gru", "lstm")
SCHEDULES = ("constant", "linear", "cosine")
"""How a scheduled hyper-parameter goes from its value to its floor over the run's planned steps (`scheduled`)."""
ACTOR_OUT_GAIN, CRITIC_OUT_GAIN, HIDDEN_GAIN = 0.01, 1.0, math.sqrt(2.0)
"""Orthogonal initialisation gains of the policy head, value head and hidden layers (Huang et al. 2022, "The 37
implementation details of PPO", detail 2)."""


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    """Hyper-parameters of PPO; defaults are CleanRL's `ppo_continuous_action.py` (Huang et al. 2022), but the
    schedules, the KL limit and the critic of its own are off, as in the runs made before them."""

    learning_rate: float = 3e-4
    """Adam step size."""
    adam_eps: float = 1e-5
    """Adam epsilon (CleanRL's 1e-5 rather than torch's 1e-8)."""
    num_steps: int = 2048
    """Environment steps per env in one rollout; a rollout holds num_steps x num_envs transitions."""
    gamma: float = 0.99
    """Discount factor."""
    gae_lambda: float = 0.95
    """GAE lambda (Schulman et al. 2016)."""
    num_minibatches: int = 32
    """Minibatches per epoch: of transitions (feed-forward) or of whole environments' sequences (recurrent)."""
    update_epochs: int = 10
    """Passes over each rollout."""
    clip_coef: float = 0.2
    """Clipping range epsilon of the probability ratio (Schulman et al. 2017, Eq. 7)."""
    clip_vloss: bool = True
    """Clip the value update to +-clip_coef around the rollout's values, as the policy's."""
    ent_coef: float = 0.0
    """Weight of the entropy bonus."""
    vf_coef: float = 0.5
    """Weight of the value loss."""
    max_grad_norm: float = 0.5
    """Global gradient norm clip."""
    norm_adv: bool = True
    """Standardise advantages within each minibatch."""
    target_kl: float | None = None
    """Stop an update's epochs early once an epoch's mean approximate KL exceeds this (CleanRL; None: never)."""
    lr_schedule: str = "constant"
    """The learning rate over the run's planned steps: "constant", "linear" (CleanRL's anneal) or "cosine"."""
    min_learning_rate: float = 0.0
    """The learning rate's floor, reached at the last planned step (not used by "constant")."""
    clip_schedule: str = "constant"
    """clip_coef over the run's planned steps, as lr_schedule (Habitat decays it linearly)."""
    min_clip_coef: float = 0.0
    """The clip range's floor, reached at the last planned step (not used by "constant")."""
    hidden_sizes: tuple[int, ...] = (64, 64)
    """Tanh hidden layers: of both MLPs (feed-forward), or of the encoder before the recurrent cell."""
    recurrent: str | None = None
    """Memory: None (feed-forward actor and critic), "gru" or "lstm" (a shared encoder and cell)."""
    recurrent_size: int = 64
    """Hidden units of the GRU/LSTM cell."""
    separate_critic: bool = False
    """The critic has its own encoder and GRU/LSTM (sb3-contrib's RecurrentPPO's default); feed-forward networks
    are always two."""
    privileged_critic: bool = False
    """The critic also reads the env's info["privileged"] (N, P), which the actor never sees (Pinto et al. 2018);
    needs separate_critic when recurrent."""
    init_log_std: float = 0.0
    """Initial log standard deviation of the Gaussian policy (in the normalised action space)."""
    norm_obs: bool = True
    """Standardise observations with running statistics (updated after each rollout)."""
    checkpoint_every: int = 10
    """Rollouts between checkpoints; the envs are reset at each, so that resuming is exact (module docstring)."""
    seed: int = 0
    """Seeds the networks, the action noise, the minibatch order and the env resets."""
    device: str = "cpu"
    """Torch device of the networks and the update."""
    imitation_coef: float = 0.0
    """Weight of an imitation term at the run's start: the squared error between the actor's mean action and a
    teacher's label of the same state, added to the loss (a fine-tune after DAgger, `auv_mj.agents.imitation`; Ross
    et al. 2011, Chen et al. 2019; kickstarting, Schmitt et al. 2018). 0: none, and no teacher is asked."""
    imitation_schedule: str = "linear"
    """imitation_coef over the run's planned steps, as lr_schedule: it decays so that RL has the last word."""
    min_imitation_coef: float = 0.0
    """The imitation weight's floor, reached at the last planned step (not used by "constant")."""
    torch_threads: int = 1
    """Intra-op CPU threads of the update (`torch.set_num_threads`). Rollouts always run the policy on one thread:
    its per-step batches are small, and a vector env's physics threads then have the cores to themselves (a second
    torch thread, spinning between operations, slowed a 2-core batch's steps by a quarter)."""

    def __post_init__(self):
        for names, valid, what in _CONFIG_CHECKS:
            for name in names:
                value = getattr(self, name)
                if not valid(value):
                    raise ValueError(f"PPOConfig.{name} must be {what}, got {value!r}")
        for floor, start in (("min_learning_rate", "learning_rate"), ("min_clip_coef", "clip_coef"),
                             ("min_imitation_coef", "imitation_coef")):
            if getattr(self, floor) > getattr(self, start):
                raise ValueError(f"PPOConfig.{floor} must be <= {start}, got {getattr(self, floor)!r}")
        if self.privileged_critic and self.recurrent is not None and not self.separate_critic:
            raise ValueError("PPOConfig.privileged_critic needs separate_critic=True with a memory: a shared "
                             "encoder would pass the privileged inputs to the actor")


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value: Any) -> bool:
    return isinstance(value, (int, float))


_CONFIG_CHECKS: tuple[tuple[tuple[str, ...], Callable[[Any], bool], str], ...] = (
    (("num_steps", "num_minibatches", "update_epochs", "recurrent_size", "checkpoint_every", "torch_threads"),
     lambda v: _whole(v) and v >= 1, "a whole number >= 1"),
    (("learning_rate", "adam_eps", "clip_coef", "max_grad_norm"), lambda v: _number(v) and 0 < v < math.inf,
     "a finite number > 0"),
    (("gamma", "gae_lambda"), lambda v: _number(v) and 0 <= v <= 1, "in [0, 1]"),
    (("ent_coef", "vf_coef", "min_learning_rate", "min_clip_coef", "imitation_coef", "min_imitation_coef"),
     lambda v: _number(v) and 0 <= v < math.inf,
     "a finite number >= 0"),
    (("lr_schedule", "clip_schedule", "imitation_schedule"), lambda v: v in SCHEDULES, f"one of {SCHEDULES}"),
    (("target_kl",), lambda v: v is None or (_number(v) and v > 0), "None or a number > 0"),
    (("hidden_sizes",), lambda v: isinstance(v, tuple) and all(_whole(n) and n >= 1 for n in v),
     "a tuple of whole numbers >= 1"),
    (("recurrent",), lambda v: v in RECURRENT_KINDS, f"one of {RECURRENT_KINDS}"),
    (("init_log_std",), lambda v: _number(v) and -20 <= v <= 2, "in [-20, 2]"),
    (("seed",), lambda v: _whole(v) and v >= 0, "a whole number >= 0"),
    (("clip_vloss", "norm_adv", "norm_obs", "separate_critic", "privileged_critic"), lambda v: isinstance(v, bool),
     "True or False"),
    (("device",), lambda v: isinstance(v, str) and bool(v), "a torch device name"),
)
"""PPOConfig's fields, checked in this order: (names, the test each value passes, what it must be)."""


def scheduled(kind: str, start: float, floor: float, progress: float) -> float:
    """A hyper-parameter `progress` (the fraction of the run's planned env steps done, clipped to [0, 1]) into its
    schedule: `start` throughout ("constant"), or falling from `start` to `floor` on a line ("linear", CleanRL's
    anneal) or on half a cosine ("cosine", Loshchilov and Hutter 2017, without restarts)."""
    p = min(max(progress, 0.0), 1.0)
    if kind == "constant":
        return start
    if kind == "linear":
        return floor + (start - floor) * (1.0 - p)
    if kind == "cosine":
        return floor + (start - floor) * 0.5 * (1.0 + math.cos(math.pi * p))
    raise ValueError(f"schedule must be one of {SCHEDULES}, got {kind!r}")


def imitation_weight(config: PPOConfig, env_steps: int, schedule_steps: int) -> float:
    """The imitation term's weight in the update after the rollout starting at global step `env_steps`: imitation_coef
    decaying on imitation_schedule to min_imitation_coef over the run's planned `schedule_steps` (as `schedule_at`)."""
    return scheduled(config.imitation_schedule, config.imitation_coef, config.min_imitation_coef,
                     env_steps / schedule_steps)


def schedule_at(config: PPOConfig, env_steps: int, schedule_steps: int) -> tuple[float, float]:
    """(learning rate, clip_coef) of the update that follows the rollout starting at global step `env_steps`, in a
    run planned for `schedule_steps` env steps: a function of the global step alone, so that a resumed run
    continues the uninterrupted run's schedule exactly."""
    progress = env_steps / schedule_steps
    return (scheduled(config.lr_schedule, config.learning_rate, config.min_learning_rate, progress),
            scheduled(config.clip_schedule, config.clip_coef, config.min_clip_coef, progress))


# ---------------------------------------------------------------------------------------------------------------------
# The actor-critic


def _linear(n_in: int, n_out: int, gain: float) -> nn.Linear:
    layer = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


def _tanh_mlp(n_in: int, hidden_sizes: Sequence[int], n_out: int | None = None, out_gain: float = 1.0) -> nn.Sequential:
    layers: list[nn.Module] = []
    for width in hidden_sizes:
        layers += [_linear(n_in, width, HIDDEN_GAIN), nn.Tanh()]
        n_in = width
    if n_out is not None:
        layers.append(_linear(n_in, n_out, out_gain))
    return nn.Sequential(*layers)


def _memory_cell(n_in: int, config: PPOConfig) -> tuple[nn.Sequential, nn.Module]:
    """An encoder (tanh MLP) and a GRU/LSTM cell after it, the cell's weights orthogonal and biases zero."""
    encoder = _tanh_mlp(n_in, config.hidden_sizes)
    features = config.hidden_sizes[-1] if config.hidden_sizes else n_in
    core = (nn.GRUCell if config.recurrent == "gru" else nn.LSTMCell)(features, config.recurrent_size)
    for name, param in core.named_parameters():
        if name.startswith("weight"):
            nn.init.orthogonal_(param, 1.0)
        else:
            nn.init.zeros_(param)
    return encoder, core


def _run_memory(encoder: nn.Module, core: nn.Module, x: torch.Tensor, starts: torch.Tensor, state: torch.Tensor,
                ) -> tuple[torch.Tensor, torch.Tensor]:
    """(outputs (T, B, H), final state (B, S)) of an encoder and GRU/LSTM cell over sequences x (T, B, F), the
    state zeroed before each step where starts is 1."""
    features = encoder(x)
    if isinstance(core, nn.GRUCell) and torch.is_grad_enabled():  # the update: the sequence at once
        out = gru_sequence(core, features, starts, state)
        return out, out[-1]
    outputs = []
    for t in range(x.shape[0]):
        state = state * (1.0 - starts[t]).unsqueeze(-1)
        if isinstance(core, nn.GRUCell):
            state = core(features[t], state)
            outputs.append(state)
        else:
            h, c = core(features[t], tuple(state.chunk(2, dim=-1)))
            state = torch.cat([h, c], dim=-1)
            outputs.append(h)
    return torch.stack(outputs), state


class ActorCritic(nn.Module):
    """A Gaussian policy and a value function, feed-forward or with a GRU/LSTM memory, the critic optionally on
    its own network with privileged inputs.

    The memory state is one tensor (batch, state_size): the actor's part (h for a GRU, [h, c] for an LSTM), then
    the critic's own part when it has its own cell; empty (size 0) for the feed-forward networks, so carrying,
    zeroing and saving it is the same code for all. The actor reads the observation alone: the privileged inputs
    (`privileged_dim` of them, with their own normaliser) enter the critic's network only, so nothing of them
    reaches an action (`act`, what a deployed policy runs, takes none).
    """

    def __init__(self, obs_dim: int, act_dim: int, config: PPOConfig, privileged_dim: int = 0):
        super().__init__()
        self.obs_dim, self.act_dim, self.kind = obs_dim, act_dim, config.recurrent
        self.privileged_dim = int(privileged_dim) if config.privileged_critic else 0
        self.own_critic_memory = config.recurrent is not None and config.separate_critic
        self.obs_norm = Normalizer(obs_dim)
        if self.privileged_dim:
            self.privileged_norm = Normalizer(self.privileged_dim)
        self.norm_obs = config.norm_obs
        critic_in = obs_dim + self.privileged_dim
        cell_state = config.recurrent_size * (2 if self.kind == "lstm" else 1)
        if self.kind is None:
            self.actor = _tanh_mlp(obs_dim, config.hidden_sizes, act_dim, ACTOR_OUT_GAIN)
            self.critic = _tanh_mlp(critic_in, config.hidden_sizes, 1, CRITIC_OUT_GAIN)
            self.actor_state_size = 0
        else:
            self.encoder, self.core = _memory_cell(obs_dim, config)
            self.actor_head = _linear(config.recurrent_size, act_dim, ACTOR_OUT_GAIN)
            if self.own_critic_memory:
                self.critic_encoder, self.critic_core = _memory_cell(critic_in, config)
            self.critic_head = _linear(config.recurrent_size, 1, CRITIC_OUT_GAIN)
            self.actor_state_size = cell_state
        self.state_size = self.actor_state_size + (cell_state if self.own_critic_memory else 0)
        self.log_std = nn.Parameter(torch.full((act_dim,), float(config.init_log_std)))

    def initial_state(self, batch: int, actor_only: bool = False) -> torch.Tensor:
        """The zero memory of `batch` envs, (batch, state_size), or the actor's alone (batch, actor_state_size)."""
        ref = self.log_std
        size = self.actor_state_size if actor_only else self.state_size
        return torch.zeros(batch, size, dtype=ref.dtype, device=ref.device)

    def _inputs(self, obs: torch.Tensor) -> torch.Tensor:
        return self.obs_norm(obs) if self.norm_obs else obs

    def _critic_inputs(self, x: torch.Tensor, privileged: torch.Tensor | None) -> torch.Tensor:
        if not self.privileged_dim:
            return x
        if privileged is None or privileged.shape[-1] != self.privileged_dim:
            got = None if privileged is None else privileged.shape[-1]
            raise ValueError(f"the critic reads {self.privileged_dim} privileged inputs, got {got}")
        p = self.privileged_norm(privileged) if self.norm_obs else privileged
        return torch.cat([x, p.to(x.dtype)], dim=-1)

    def act(self, obs: torch.Tensor, starts: torch.Tensor, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(action means (T, B, act_dim), the actor's final memory (B, actor_state_size)) of sequences obs
        (T, B, obs_dim) from the actor's memory `state`: the actor alone, with no privileged input."""
        x = self._inputs(obs)
        if self.kind is None:
            return self.actor(x), state
        out, state = _run_memory(self.encoder, self.core, x, starts, state)
        return self.actor_head(out), state

    def forward(self, obs: torch.Tensor, starts: torch.Tensor, state: torch.Tensor,
                privileged: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(action means (T, B, act_dim), values (T, B), final state (B, S)) of sequences obs (T, B, obs_dim), with
        the critic's privileged inputs (T, B, P) when it has them.

        starts (T, B) is 1 where obs[t] is an episode's first observation: the state is zeroed before it, so
        nothing of the previous episode reaches it. Feed-forward networks ignore starts and state.
        """
        x = self._inputs(obs)
        if self.kind is None:
            return self.actor(x), self.critic(self._critic_inputs(x, privileged)).squeeze(-1), state
        actor_state, critic_state = state.split([self.actor_state_size, self.state_size - self.actor_state_size], -1)
        out, actor_state = _run_memory(self.encoder, self.core, x, starts, actor_state)
        if not self.own_critic_memory:
            return self.actor_head(out), self.critic_head(out).squeeze(-1), actor_state
        critic_out, critic_state = _run_memory(self.critic_encoder, self.critic_core,
                                               self._critic_inputs(x, privileged), starts, critic_state)
        return (self.actor_head(out), self.critic_head(critic_out).squeeze(-1),
                torch.cat([actor_state, critic_state], dim=-1))

    def distribution(self, mean: torch.Tensor) -> torch.distributions.Normal:
        """The Gaussian policy around `mean`, with the state-independent std exp(log_std)."""
        return torch.distributions.Normal(mean, self.log_std.exp().expand_as(mean))

    def evaluate(self, obs: torch.Tensor, starts: torch.Tensor, state: torch.Tensor, actions: torch.Tensor,
                 privileged: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(log pi(a|s), entropy, V(s)), each (T, B), of a replayed sequence of actions (T, B, act_dim)."""
        mean, value, _ = self(obs, starts, state, privileged)
        dist = self.distribution(mean)
        return dist.log_prob(actions).sum(-1), dist.entropy().sum(-1), value


# ---------------------------------------------------------------------------------------------------------------------
# The rollout


@dataclasses.dataclass
class Rollout:
    """num_steps x num_envs transitions, (T, N, ...) tensors, with the memory before the first."""

    obs: torch.Tensor
    starts: torch.Tensor
    valid: torch.Tensor
    actions: torch.Tensor
    logprobs: torch.Tensor
    values: torch.Tensor
    rewards: torch.Tensor
    terminations: torch.Tensor
    truncations: torch.Tensor
    next_values: torch.Tensor
    """V(s_{t+1}) of the same episode (`gae`)."""
    initial_state: torch.Tensor
    privileged: torch.Tensor | None = None
    """The critic's privileged inputs (T, N, P) beside each observation (None: it has none)."""
    labels: torch.Tensor | None = None
    """A teacher's actions (T, N, act_dim) at each observation, in the networks' normalised space (None: no teacher)."""

    def advantages(self, config: PPOConfig) -> tuple[torch.Tensor, torch.Tensor]:
        """GAE (advantages, returns), zero on the steps that are not in the loss."""
        adv, ret = gae(self.rewards, self.values, self.terminations, self.truncations, self.next_values,
                       config.gamma, config.gae_lambda)
        return adv * self.valid, ret * self.valid


class Episode(NamedTuple):
    """An episode that ended during a rollout, as the training logs count it."""

    ret: float
    """Its undiscounted return."""
    length: int
    """Its transitions."""
    cell: int
    """Index into `Collector.cell_names` of the row it ran in."""
    success: float
    """info["is_success"] at its last step (nan if the env reports none)."""
    collision: float
    """info["collision"] at its last step (nan if the env reports none)."""
    speed: float
    """Mean of `step_speed` over its steps (nan without one)."""


def privileged_inputs(info: Mapping[str, Any], num_envs: int, size: int) -> np.ndarray:
    """The critic's privileged inputs (num_envs, size) from a vector env's info["privileged"]; rows the env did not
    report ("_privileged" False) are zero. ValueError if the env gives none or another size."""
    if size == 0:
        return np.zeros((num_envs, 0), np.float32)
    if "privileged" not in info:
        raise ValueError("PPOConfig.privileged_critic needs an env whose info holds 'privileged', an (N, P) array")
    values = np.asarray(info["privileged"], np.float32).reshape(num_envs, -1)
    if values.shape[1] != size:
        raise ValueError(f"info['privileged'] has {values.shape[1]} entries a row, the critic reads {size}")
    mask = info.get("_privileged")
    return values if mask is None else np.where(np.asarray(mask, bool)[:, None], values, 0.0).astype(np.float32)


def _info_flag(info: Mapping[str, Any], key: str, i: int) -> float:
    """Row i's info[key] as 1.0 or 0.0, nan where the env did not report it."""
    mask = info.get("_" + key)
    if key not in info or (mask is not None and not mask[i]):
        return float("nan")
    return float(bool(np.asarray(info[key])[i]))


class Collector:
    """Steps a vector env with the policy, carrying each env's memory and its episode bookkeeping.

    An env with `cells` (a list of names or tuples of names) and `cell_of_row` (row -> index into it), as
    `auv_mj.tasks.mixture.PlanningMixtureVectorEnv`, has its finished episodes counted per cell; any other env is
    one cell, "all". `step_speed(next_obs, info)`, if given, is each row's speed over the step just taken.
    """

    def __init__(self, env: VectorEnv, model: ActorCritic, spec: Mapping[str, Any], config: PPOConfig,
                 generator: torch.Generator,
                 step_speed: Callable[[Any, Mapping[str, Any]], np.ndarray] | None = None,
                 teacher: Callable[[], np.ndarray] | None = None):
        self.env, self.model, self.spec, self.config, self.generator = env, model, spec, config, generator
        self.teacher = teacher
        """The teacher's actions (N, act_dim) in the env's action space at the env's current states, recorded in
        the rollout as labels (`Rollout.labels`); None: no labels."""
        self.mode = autoreset_mode(env)
        self.num_envs = int(env.num_envs)
        self.device = torch.device(config.device)
        self.step_speed = step_speed
        cells, rows = getattr(env, "cells", None), getattr(env, "cell_of_row", None)
        if cells is not None and rows is not None:
            self.cell_names = [c if isinstance(c, str) else "/".join(map(str, c)) for c in cells]
            self.cell_of_row = np.asarray(rows, int)
        else:
            self.cell_names, self.cell_of_row = ["all"], np.zeros(self.num_envs, int)
        self.obs: np.ndarray | None = None
        self.privileged = np.zeros((self.num_envs, model.privileged_dim), np.float32)
        self.state = model.initial_state(self.num_envs)
        self.starts = np.ones(self.num_envs, bool)
        self.pending_reset = np.zeros(self.num_envs, bool)
        """NEXT_STEP: envs whose last step ended an episode; their next step is a reset, not a transition."""
        self.episode_returns = np.zeros(self.num_envs)
        self.episode_lengths = np.zeros(self.num_envs, int)
        self.episode_distance = np.zeros(self.num_envs)
        self.finished: list[Episode] = []
        """The episodes ended since the last `take_finished`."""

    def reset(self, seeds: list[int]) -> None:
        """Resets every env (new episodes, zero memory)."""
        obs, info = self.env.reset(seed=seeds)
        self.obs = flatten_obs(obs, self.spec)
        self.privileged = privileged_inputs(info, self.num_envs, self.model.privileged_dim)
        self.state = self.model.initial_state(self.num_envs)
        self.starts[:] = True
        self.pending_reset[:] = False
        self.episode_returns[:] = 0.0
        self.episode_lengths[:] = 0
        self.episode_distance[:] = 0.0

    def _tensor(self, x: np.ndarray, dtype: torch.dtype = torch.float32) -> torch.Tensor:
        return torch.as_tensor(x, dtype=dtype, device=self.device)

    def _record_ends(self, ended: np.ndarray, info: Mapping[str, Any]) -> None:
        """Adds the episodes of rows `ended` to `finished`, with their last step's success and collision."""
        for i in np.flatnonzero(ended):
            length = int(self.episode_lengths[i])
            speed = self.episode_distance[i] / length if self.step_speed is not None and length else float("nan")
            self.finished.append(Episode(float(self.episode_returns[i]), length, int(self.cell_of_row[i]),
                                         _info_flag(info, "is_success", i), _info_flag(info, "collision", i),
                                         float(speed)))

    @torch.no_grad()
    def rollout(self, num_steps: int) -> Rollout:
        """num_steps steps of every env; the observations are also added to the normaliser's pending stats."""
        T, N, P, model = num_steps, self.num_envs, self.model.privileged_dim, self.model
        f32 = {"dtype": torch.float32, "device": self.device}
        obs_buf = torch.zeros(T, N, self.spec["obs_dim"], **f32)
        priv_buf = torch.zeros(T, N, P, **f32)
        actions = torch.zeros(T, N, self.spec["act_dim"], **f32)
        starts, valid, logprobs, values, rewards, terms, truncs, next_values = (
            torch.zeros(T, N, **f32) for _ in range(8))
        initial_state = self.state.clone()
        act_shape = (N, *self.spec["act_shape"])
        labels = torch.zeros(T, N, self.spec["act_dim"], **f32) if self.teacher is not None else None
        for t in range(T):
            if labels is not None:
                labels[t] = self._tensor(normalised_action(np.asarray(self.teacher()).reshape(N, -1), self.spec))
            obs, priv = self._tensor(self.obs), self._tensor(self.privileged)
            obs_buf[t], priv_buf[t], starts[t] = obs, priv, self._tensor(self.starts)
            valid[t] = self._tensor(~self.pending_reset)
            mean, value, self.state = model(obs[None], starts[t][None], self.state, priv[None])
            dist = model.distribution(mean[0])
            noise = torch.randn(mean.shape[1:], generator=self.generator, device=self.generator.device)
            action = mean[0] + dist.stddev * noise.to(self.device)
            actions[t], logprobs[t], values[t] = action, dist.log_prob(action).sum(-1), value[0]
            sent = env_action(action.cpu().numpy(), self.spec).reshape(act_shape)
            next_obs, reward, term, trunc, info = self.env.step(sent.astype(self.env.single_action_space.dtype))
            reward, term, trunc = (np.asarray(reward, np.float64), np.asarray(term, bool), np.asarray(trunc, bool))
            rewards[t], terms[t], truncs[t] = self._tensor(reward), self._tensor(term), self._tensor(trunc)
            ended = term | trunc
            was_transition = ~self.pending_reset
            self.episode_returns += np.where(was_transition, reward, 0.0)
            self.episode_lengths += was_transition
            if self.step_speed is not None:
                self.episode_distance += np.where(was_transition, self.step_speed(next_obs, info), 0.0)
            self._record_ends(ended & was_transition, info)
            self.episode_returns[ended] = 0.0
            self.episode_lengths[ended] = 0
            self.episode_distance[ended] = 0.0
            next_priv = privileged_inputs(info, N, P)
            if self.mode == AutoresetMode.SAME_STEP:
                bootstrap = trunc & ~term
                if bootstrap.any():
                    final = np.stack([flatten_obs(final_observation(info, i), self.spec) if bootstrap[i]
                                      else self.obs[i] for i in range(N)])
                    final_info = info.get("final_info", {})
                    final_priv = privileged_inputs(final_info, N, P) if "privileged" in final_info else next_priv
                    # V(final observation) continues the episode's memory, so no start here
                    _, final_value, _ = model(self._tensor(final)[None], torch.zeros(1, N, **f32), self.state,
                                              self._tensor(final_priv)[None])
                    next_values[t] = torch.where(self._tensor(bootstrap).bool(), final_value[0], next_values[t])
                self.starts = ended
            else:
                # NEXT_STEP: an env that just ended shows its final observation now and resets at its next step
                self.starts = self.pending_reset.copy()
                self.pending_reset = ended
            self.obs, self.privileged = flatten_obs(next_obs, self.spec), next_priv
        _, last_value, _ = model(self._tensor(self.obs)[None], self._tensor(self.starts)[None], self.state,
                                 self._tensor(self.privileged)[None])
        following = torch.cat([values[1:], last_value], dim=0)
        if self.mode == AutoresetMode.SAME_STEP:
            next_values = torch.where(truncs.bool() & ~terms.bool(), next_values, following)
        else:
            next_values = following
        if self.config.norm_obs:
            model.obs_norm.update(obs_buf.reshape(-1, self.spec["obs_dim"]).cpu().numpy())
            if P:
                model.privileged_norm.update(priv_buf.reshape(-1, P).cpu().numpy())
        return Rollout(obs_buf, starts, valid, actions, logprobs, values, rewards, terms, truncs, next_values,
                       initial_state, priv_buf if P else None, labels)

    def take_finished(self) -> list[Episode]:
        """The episodes finished since the last call."""
        out, self.finished = self.finished, []
        return out


# ---------------------------------------------------------------------------------------------------------------------
# GAE and the clipped losses


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
             imitation: float = 0.0) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The PPO objective to minimise, -L^CLIP + vf_coef L^VF - ent_coef S (Schulman et al. 2017, Eq. 9), on one
    minibatch, and its parts (detached) for the logs; `clip_coef` is the scheduled clip range (None:
    config.clip_coef). With `imitation` > 0 and the batch's teacher labels, plus imitation times the squared error
    between the actor's mean action and the label (the decaying imitation term of a fine-tune, `imitation_weight`)."""
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
    loss = pg + config.vf_coef * vf - config.ent_coef * ent
    bc = torch.zeros((), dtype=loss.dtype, device=loss.device)
    if imitation > 0 and batch.labels is not None:
        bc = masked_mean(((action_mean - batch.labels) ** 2).sum(-1), mask)
        loss = loss + imitation * bc
    with torch.no_grad():
        log_ratio = logprob - batch.logprobs
        stats = {"policy_loss": pg.detach(), "value_loss": vf.detach(), "entropy": ent.detach(),
                 "approx_kl": masked_mean(log_ratio.exp() - 1 - log_ratio, mask),
                 "clip_fraction": masked_mean(((log_ratio.exp() - 1).abs() > clip_coef).to(mask.dtype), mask),
                 "imitation_loss": bc.detach()}
    return loss, stats


# ---------------------------------------------------------------------------------------------------------------------
# The update


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
           generator: torch.Generator, clip_coef: float | None = None, imitation: float = 0.0) -> dict[str, float]:
    """update_epochs passes of minibatch gradient steps on `ppo_loss` over one rollout (Schulman et al. 2017,
    Algorithm 1), with the optimiser's learning rate as it is and the clip range `clip_coef` (None:
    config.clip_coef); with config.target_kl the passes stop after the first epoch whose mean approximate KL
    exceeds it (CleanRL's early stop). The mean of each loss part over the steps, the explained variance of the
    returns, the gradient steps and the epochs run."""
    advantages, returns = rollout.advantages(config)
    totals: dict[str, float] = {}
    steps = epochs = 0
    for _ in range(config.update_epochs):
        kls = []
        epochs += 1
        for batch in minibatches(rollout, advantages, returns, config, generator):
            loss, stats = ppo_loss(model, batch, config, clip_coef, imitation)
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


# ---------------------------------------------------------------------------------------------------------------------
# Building, saving and loading a run


def _generator(config: PPOConfig) -> torch.Generator:
    generator = torch.Generator(device=config.device)
    generator.manual_seed(config.seed)
    return generator


def build_model(spec: Mapping[str, Any], config: PPOConfig) -> ActorCritic:
    """A fresh actor-critic for `spec`, initialised from config.seed (without touching torch's global RNG)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        model = ActorCritic(int(spec["obs_dim"]), int(spec["act_dim"]), config, int(spec.get("privileged_dim", 0)))
    return model.to(config.device)


def make_optimizer(model: ActorCritic, config: PPOConfig) -> torch.optim.Adam:
    """Adam over every trained parameter (the normaliser's statistics are buffers, not parameters)."""
    return torch.optim.Adam(model.parameters(), lr=config.learning_rate, eps=config.adam_eps)


def save_ppo(path: str | Path, model: ActorCritic, optimizer: torch.optim.Optimizer | None,
             generator: torch.Generator | None, config: PPOConfig, spec: Mapping[str, Any],
             counters: Mapping[str, Any]) -> None:
    """Atomically writes a checkpoint of kind "ppo": the model (normaliser included), Adam's moments and the
    generator (either None for a deployable file), with the config, the spaces and the counters."""
    tensors = module_tensors(model, "model")
    if optimizer is not None:
        tensors.update(optimizer_tensors(optimizer, "optimizer"))
    if generator is not None:
        tensors["generator"] = generator.get_state().cpu()
    save_checkpoint(path, "ppo", tensors, {"agent": "ppo", "config": config_to_dict(config), "spec": dict(spec),
                                           "counters": dict(counters)})


def read_ppo(path: str | Path) -> tuple[Checkpoint, PPOConfig]:
    """A checkpoint of kind "ppo" (`auv_mj.agents.checkpoint.read_checkpoint`) and its config; ValueError naming
    the file if it is unreadable, of another kind or its config is not a PPOConfig."""
    checkpoint = read_checkpoint(path, "ppo")
    return checkpoint, saved_config(checkpoint, path, PPOConfig)


def load_model(path: str | Path, tensors: Mapping[str, torch.Tensor], spec: Mapping[str, Any],
               config: PPOConfig) -> ActorCritic:
    """The actor-critic of a checkpoint's tensors; ValueError naming the file if they do not fit its config."""
    model = ActorCritic(int(spec["obs_dim"]), int(spec["act_dim"]), config, int(spec.get("privileged_dim", 0)))
    load_module(model, tensors, "model", Path(path))
    return model.to(config.device)


# ---------------------------------------------------------------------------------------------------------------------
# The training loop


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


def _tensorboard(run_dir: Path, purge_step: int | None) -> Any:
    """A TensorBoard writer in run_dir/tb, or None with a warning where TensorBoard is not installed (the CSV logs
    are written either way)."""
    try:
        from torch.utils.tensorboard import SummaryWriter  # slow import, only when asked for
    except ImportError:
        warnings.warn("TensorBoard is not installed: the training curves go to the CSV logs only", stacklevel=3)
        return None
    return SummaryWriter(str(run_dir / "tb"), purge_step=purge_step)


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


def _privileged_size(env: VectorEnv, seeds: list[int]) -> int:
    """P of the env's info["privileged"] (N, P), read from a reset with `seeds` (those the run starts with, so
    the run's own first reset repeats it)."""
    _, info = env.reset(seed=seeds)
    if "privileged" not in info:
        raise ValueError("PPOConfig.privileged_critic needs an env whose info holds 'privileged', an (N, P) array, "
                         "from the first reset on")
    values = np.asarray(info["privileged"])
    if values.ndim != 2 or values.shape[0] != env.num_envs or values.shape[1] < 1:
        raise ValueError(f"info['privileged'] must be an (N, P) array with N = {env.num_envs}, P >= 1; got shape "
                         f"{values.shape}")
    return int(values.shape[1])


def train(env: VectorEnv | Callable[[], VectorEnv], config: PPOConfig | None, run_dir: str | Path, total_steps: int,
          *, resume: bool = False, progress: bool = True, tensorboard: bool = False,
          schedule_steps: int | None = None,
          step_speed: Callable[[Any, Mapping[str, Any]], np.ndarray] | None = None,
          teacher: Callable[[], np.ndarray] | None = None, init: str | Path | None = None) -> PPOResult:
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
                spec["privileged_dim"] = _privileged_size(vec_env, reset_seeds(config.seed, 0, num_envs))
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
                _load_actor(model, init_tensors, Path(init))
            optimizer = make_optimizer(model, config)
        if config.imitation_coef > 0 and teacher is None:
            raise ValueError("PPOConfig.imitation_coef > 0 needs a teacher (train(..., teacher=...))")
        collector = Collector(vec_env, model, spec, config, generator, step_speed,
                              teacher if config.imitation_coef > 0 else None)
        return _train_loop(collector, optimizer, config, run_dir, counters, total_steps, resume, progress,
                           tensorboard)
    finally:
        torch.set_num_threads(threads)
        if owned:
            vec_env.close()


def _load_actor(model: ActorCritic, tensors: Mapping[str, torch.Tensor], path: Path) -> None:
    """A new run's actor (encoder, memory, head, log std) and observation normaliser from a checkpoint's tensors
    (a student's); the critic keeps its fresh weights where the checkpoint's does not fit (a privileged critic)."""
    own = model.state_dict()
    taken = {k[len("model."):]: v for k, v in tensors.items() if k.startswith("model.")}
    fits = {k: v for k, v in taken.items() if k in own and own[k].shape == v.shape
            and not k.startswith(("critic", "privileged_norm"))}
    actor = [k for k in own if k.startswith(("encoder", "core", "actor", "obs_norm"))]
    missing = [k for k in actor if k not in fits]
    if missing:
        raise ValueError(f"checkpoint {path} does not fit this actor: {missing[:4]}")
    model.load_state_dict({**own, **fits})


def _logged_rows(path: Path, iterations: int, fields: Sequence[str]) -> list[dict[str, str]]:
    """The rows of a run's log up to rollout `iterations` (those a resumed run keeps); rows of an older log that
    lack some of `fields` keep them empty."""
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if row.get("iteration", "").isdigit()
                and int(row["iteration"]) <= iterations and None not in row and set(row) <= set(fields)]


def _nanmean(values: Sequence[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return float(np.mean(finite)) if finite else float("nan")


def episode_summary(episodes: Sequence[Episode]) -> dict[str, float]:
    """Means over finished episodes: success_rate, collision_rate, mean_speed, mean_return (nan where none)."""
    return {"success_rate": _nanmean([e.success for e in episodes]),
            "collision_rate": _nanmean([e.collision for e in episodes]),
            "mean_speed": _nanmean([e.speed for e in episodes]),
            "mean_return": _nanmean([e.ret for e in episodes])}


class _Logs:
    """progress.csv, cells.csv and TensorBoard of a run, reopened on resume with the rows up to its checkpoint."""

    def __init__(self, run_dir: Path, iterations: int, resume: bool, tensorboard: bool, purge_step: int):
        self.files, self.writers = [], []
        for name, fields in ((LOG_NAME, LOG_FIELDS), (CELLS_LOG_NAME, CELL_FIELDS)):
            kept = _logged_rows(run_dir / name, iterations, fields) if resume else []
            f = open(run_dir / name, "w", newline="")
            writer = csv.DictWriter(f, fields)
            writer.writeheader()
            writer.writerows(kept)
            self.files.append(f)
            self.writers.append(writer)
        self.board = _tensorboard(run_dir, purge_step if resume else None) if tensorboard else None

    def write(self, row: Mapping[str, Any], cell_rows: Sequence[Mapping[str, Any]]) -> None:
        """One rollout's row and its cells' rows."""
        self.writers[0].writerow(row)
        self.writers[1].writerows(cell_rows)
        for f in self.files:
            f.flush()
        if self.board is None:
            return
        step = row["env_steps"]
        for key, value in row.items():
            if key not in ("iteration", "env_steps") and np.isfinite(value):
                self.board.add_scalar(f"ppo/{key}", value, step)
        for cell in cell_rows:
            for key in CELL_FIELDS[3:]:
                if np.isfinite(cell[key]):
                    self.board.add_scalar(f"cells/{cell['cell']}/{key}", cell[key], step)

    def close(self) -> None:
        for f in self.files:
            f.close()
        if self.board is not None:
            self.board.close()


RETURN_WINDOW = 100
"""Finished episodes whose means the progress bar shows."""


def progress_text(recent: Sequence[Episode], episodes: int, learning_rate: float, steps_per_s: float) -> str:
    """The progress bar's postfix: the means over the last RETURN_WINDOW finished episodes (return, and success and
    collisions where the env reports them), or, before the first has ended, that none has (not NaN); then the
    episodes so far, the learning rate and the env steps per second."""
    if recent:
        summary = episode_summary(recent)
        parts = [f"ret {summary['mean_return']:.3g}"] + [
            f"{label} {summary[key]:.2f}" for key, label in (("success_rate", "succ"), ("collision_rate", "coll"))
            if not math.isnan(summary[key])]
        shown = ", ".join(parts) + f" (last {len(recent)})"
    else:
        shown = "no episode ended yet"
    return f"{shown}, episodes {episodes}, lr {learning_rate:.2g}, {steps_per_s:.0f} steps/s"


def _train_loop(collector: Collector, optimizer: torch.optim.Optimizer, config: PPOConfig, run_dir: Path,
                counters: dict[str, Any], total_steps: int, resume: bool, progress: bool,
                tensorboard: bool) -> PPOResult:
    """Rollout, update, log, checkpoint, until total_steps; the envs are reset at every checkpoint."""
    model, spec, generator = collector.model, collector.spec, collector.generator
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(json.dumps({"agent": "ppo", "config": config_to_dict(config),
                                                     "spec": spec}, indent=2))
    logs = _Logs(run_dir, counters["iteration"], resume, tensorboard, counters["env_steps"])
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
            stats = update(model, optimizer, rollout, config, generator, clip, imitation)
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
                save_ppo(run_dir / CHECKPOINT_NAME, model, optimizer, generator, config, spec, counters)
    finally:
        bar.close()
        logs.close()
    return PPOResult(run_dir, run_dir / CHECKPOINT_NAME, counters["env_steps"], counters["iteration"],
                     counters["episodes"], mean_return)
