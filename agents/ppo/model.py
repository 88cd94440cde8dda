"""PPO's actor-critic: a Gaussian policy and a value function, feed-forward or with a GRU or LSTM memory.

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
  the update re-runs each sequence from the rollout's initial state with the same `starts`. A rollout steps
  `nn.GRUCell`; the update runs the same GRU over the whole sequence with its backward pass written out
  (`auv_mj.agents.ppo.gru.gru_sequence`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import torch
from torch import nn

from auv_mj.agents.normalizer import Normalizer
from auv_mj.agents.ppo.config import PPOConfig
from auv_mj.agents.ppo.gru import gru_sequence

ACTOR_OUT_GAIN, CRITIC_OUT_GAIN, HIDDEN_GAIN = 0.01, 1.0, math.sqrt(2.0)
"""Orthogonal initialisation gains of the policy head, value head and hidden layers (Huang et al. 2022, "The 37
implementation details of PPO", detail 2)."""


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


def build_model(spec: Mapping[str, Any], config: PPOConfig) -> ActorCritic:
    """A fresh actor-critic for `spec`, initialised from config.seed (without touching torch's global RNG)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        model = ActorCritic(int(spec["obs_dim"]), int(spec["act_dim"]), config, int(spec.get("privileged_dim", 0)))
    return model.to(config.device)


class ActorEnsemble(nn.Module):
    """K trained actors as one deployable actor: the mean of their action means, each clipped to [-1, 1] first
    (every member's action as `PPOPolicy` would send it on its own), so that one member's saturated output weighs
    no more than a full turn. Averaging students trained on other seeds or fits damps each one's own errors
    (bagging, Breiman 1996); docs/runs/planner-learned measures what it gives a closed loop.

    Each member keeps its own memory: the ensemble's state is the members' actor states side by side. It has no
    critic and takes no privileged input; `log_std` is the members' mean (for `PPOPolicy(stochastic=True)`).
    Members are read from and written to one checkpoint (`auv_mj.agents.ppo.checkpoint.load_model`,
    `auv_mj.agents.ppo.export.export_ensemble`)."""

    def __init__(self, members: Sequence[ActorCritic]):
        super().__init__()
        if not members:
            raise ValueError("an ensemble needs at least one member")
        self.members = nn.ModuleList(members)
        self.obs_dim, self.act_dim = members[0].obs_dim, members[0].act_dim
        self.member_state_sizes = [int(m.actor_state_size) for m in members]
        self.actor_state_size = self.state_size = sum(self.member_state_sizes)
        self.register_buffer("log_std", torch.stack([m.log_std.detach() for m in members]).mean(dim=0))

    def initial_state(self, batch: int, actor_only: bool = True) -> torch.Tensor:
        """The zero memory of `batch` envs: every member's actor state, (batch, sum of their sizes)."""
        return torch.cat([m.initial_state(batch, actor_only=True) for m in self.members], dim=1)

    def act(self, obs: torch.Tensor, starts: torch.Tensor, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(the members' mean of clipped action means (T, B, act_dim), their final memories (B, actor_state_size))
        of sequences obs (T, B, obs_dim), as `ActorCritic.act`."""
        means, states = [], []
        for member, part in zip(self.members, state.split(self.member_state_sizes, dim=-1), strict=True):
            mean, new = member.act(obs, starts, part)
            means.append(mean.clamp(-1.0, 1.0))
            states.append(new)
        return torch.stack(means).mean(dim=0), torch.cat(states, dim=-1)
