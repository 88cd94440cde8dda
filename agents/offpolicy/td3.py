"""TD3 (Fujimoto, van Hoof and Meger 2018): DDPG with twin critics, delayed actor updates and target smoothing.

The paper's learner is DDPG (Sec. 3.1.2, Eq. 13-19); TD3 is the same actor-critic with three changes
against DDPG's over-estimated Q (Fujimoto et al. 2018, Algorithm 1), and shares every other piece of
`auv_mj.agents.offpolicy.ddpg` (networks, normaliser, exploration, soft updates, checkpoints, the training loop):

1. **Twin critics.** Two critics Q_1, Q_2 learn the same target, which takes the smaller of their two
   target estimates: y = r + gamma (1 - terminated) min_j Q'_j(s', a') (clipped double Q-learning).
2. **Delayed policy updates.** The actor and all three targets move once every `policy_delay` critic steps,
   so the actor climbs a critic that has had time to settle.
3. **Target policy smoothing.** a' = clip(mu'(s') + clip(eps, -noise_clip, noise_clip), -1, 1) with
   eps ~ N(0, target_noise^2): the target averages Q over a small neighbourhood of the target action,
   so the actor cannot exploit a narrow peak of the critic.

Defaults for the three are the TD3 paper's (d = 2, sigma~ = 0.2, c = 0.5 on actions in [-1, 1]); every
other field keeps `DDPGConfig`'s default (Table 4).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import torch
from torch import nn

from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig, bounded, critic_loss, soft_update
from auv_mj.agents.offpolicy.networks import Actor, Critic, ParameterVector, VectorAdam
from auv_mj.agents.offpolicy.replay import Batch

MAX_POLICY_DELAY = 1000
"""Largest `policy_delay` a config may ask for."""


@dataclass(frozen=True)
class TD3Config(DDPGConfig):
    """TD3 hyper-parameters: DDPG's (`DDPGConfig`, Table 4) and TD3's three of Fujimoto et al. (2018)."""

    policy_delay: int = bounded(2, 1, MAX_POLICY_DELAY)
    """Critic steps per actor (and target) step, d of TD3's Algorithm 1 (TD3 paper)."""
    target_noise: float = bounded(0.2, 0.0, 10.0)
    """Std sigma~ of the Gaussian smoothing noise added to the target action mu'(s') (TD3 paper)."""
    noise_clip: float = bounded(0.5, 0.0, 10.0)
    """The smoothing noise is clipped to [-noise_clip, noise_clip] before it is added (TD3 paper)."""


def smoothed_target_action(actor_target: Actor, next_obs: torch.Tensor, target_noise: float,
                           noise_clip: float, generator: torch.Generator | None = None) -> torch.Tensor:
    """a' = clip(mu'(s') + clip(eps, -c, c), -1, 1), eps ~ N(0, sigma~^2) (TD3's target policy smoothing)."""
    with torch.no_grad():
        action = actor_target(next_obs)
        if target_noise > 0:
            eps = torch.randn(action.shape, generator=generator, device=action.device) * target_noise
            action = action + eps.clamp(-noise_clip, noise_clip)
        return action.clamp(-1.0, 1.0)


def twin_td_target(critic_targets: tuple[Critic, Critic], next_obs: torch.Tensor, next_actions: torch.Tensor,
                   rewards: torch.Tensor, terminated: torch.Tensor, gamma: float) -> torch.Tensor:
    """y = r + gamma (1 - terminated) min(Q'_1(s', a'), Q'_2(s', a')) (clipped double Q-learning)."""
    with torch.no_grad():
        q1, q2 = (critic(next_obs, next_actions) for critic in critic_targets)
        return rewards + gamma * (1.0 - terminated) * torch.minimum(q1, q2)


class TD3(DDPG):
    """DDPG's agent with a second critic (and its target); `update` follows TD3's Algorithm 1."""

    def __init__(self, obs_dim: int, act_dim: int, config: TD3Config | None = None):
        config = config or TD3Config()
        if not isinstance(config, TD3Config):
            raise ValueError(f"TD3 needs a TD3Config, got {type(config).__name__}")
        super().__init__(obs_dim, act_dim, config)
        self.critic2 = Critic(obs_dim, act_dim, config.hidden_sizes).to(self.device)
        self.critic2_target = copy.deepcopy(self.critic2).requires_grad_(False)
        self.vectors.update({name: ParameterVector(getattr(self, name)) for name in ("critic2", "critic2_target")})
        self.critic_opt = VectorAdam([self.vectors["critic"], self.vectors["critic2"]], lr=config.critic_lr)

    @property
    def actor_updates(self) -> int:
        """Actor steps so far: one per `policy_delay` critic steps."""
        return self.num_updates // self.config.policy_delay

    def modules(self) -> dict[str, nn.Module]:
        """DDPG's modules and the second critic with its target."""
        return {**super().modules(), "critic2": self.critic2, "critic2_target": self.critic2_target}

    def critic_step(self, obs: torch.Tensor, batch: Batch, next_obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Both critics towards the twin target with a smoothed target action, one Adam step moving both;
        (summed loss, mean target).

        A vmap over the two critics (torch.func.stack_module_state and functional_call) was tried: on a CPU at
        Table 4's sizes it is slower than the two calls, as is torch.compile of the losses (issue 29).
        """
        cfg = self.config
        next_actions = smoothed_target_action(self.actor_target, next_obs, cfg.target_noise, cfg.noise_clip)
        target = twin_td_target((self.critic_target, self.critic2_target), next_obs, next_actions,
                                batch.rewards, batch.terminated, cfg.gamma)
        loss = sum(critic_loss(critic, obs, batch.actions, target) for critic in (self.critic, self.critic2))
        self.critic_opt.zero_grad()
        loss.backward()
        self.critic_opt.step()
        return loss.detach(), target.mean()

    def _step(self, batch: Batch) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """A critic step; every `policy_delay`-th step also an actor step (against Q_1) and the target updates."""
        with torch.no_grad():
            obs, next_obs = self.obs_norm(batch.obs), self.obs_norm(batch.next_obs)
        q_loss, q_target = self.critic_step(obs, batch, next_obs)
        self.num_updates += 1
        pi_loss = torch.zeros((), device=self.device)
        if self.num_updates % self.config.policy_delay == 0 and self.num_updates > self.config.actor_burn_in:
            pi_loss = self.actor_step(obs)  # also moves the actor's target (Eq. 19)
            for name in ("critic", "critic2"):
                soft_update(self.vectors[f"{name}_target"], self.vectors[name], self.config.tau)
        return q_loss, pi_loss, q_target
