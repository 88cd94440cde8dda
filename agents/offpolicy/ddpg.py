"""DDPG (Sec. 3.1.2, Eq. 13-19) with the hyper-parameters of Table 4, update step as importable functions.

Exploration (Table 4: epsilon 1 -> 0.01, "final exploration frame T = 2000"). Table 4 borrows DQN's
vocabulary (Mnih et al. 2015), where epsilon is the probability of a uniformly random action and a
"frame" is one environment step. We read it the same way: with probability epsilon the action is drawn
uniformly from [-1, 1]^n, otherwise it is mu(s) plus Gaussian noise of std `noise_std`, clipped; epsilon
decays linearly from `epsilon_start` to `epsilon_end` over the first `epsilon_decay` environment steps
(`epsilon_unit="steps"`) or episodes (`epsilon_unit="episodes"`). The small Gaussian noise is our
addition (DDPG needs some exploration after epsilon has decayed); it is not in the paper.
"""

from __future__ import annotations

import ast
import copy
import inspect
import textwrap
from dataclasses import dataclass, field, fields

import numpy as np
import torch
from torch import nn

from auv_mj.agents.checkpoint import check_hidden_sizes
from auv_mj.agents.normalizer import Normalizer
from auv_mj.agents.offpolicy.networks import Actor, Critic, ParameterVector, VectorAdam
from auv_mj.agents.offpolicy.replay import Batch
from auv_mj.inputs import shown

EPSILON_UNITS = ("steps", "episodes")
"""What epsilon_decay counts."""


def bounded(default: float, low: float, high: float, *, above: bool = False):
    """A numeric config field with its inclusive range [low, high] (`above`: the value must also exceed low), the
    one place a field's bounds are written; `check_config` reads them from the field's metadata."""
    return field(default=default, metadata={"range": (low, high), "above": above})


@dataclass(frozen=True)
class DDPGConfig:
    """DDPG / HER-DDPG hyper-parameters; defaults from Table 4 unless marked as ours."""

    actor_lr: float = bounded(1e-3, 0.0, 1.0, above=True)
    """Learning rate alpha_1 of the actor (Table 4)."""
    critic_lr: float = bounded(1e-3, 0.0, 1.0, above=True)
    """Learning rate alpha_2 of the critic (Table 4)."""
    gamma: float = bounded(0.9, 0.0, 1.0)
    """Discount factor gamma of Eq. (14) and the critic target (Eq. 17) (Table 4)."""
    epsilon_start: float = bounded(1.0, 0.0, 1.0)
    """Initial exploration epsilon_0: probability of a uniformly random action (Table 4)."""
    epsilon_end: float = bounded(0.01, 0.0, 1.0)
    """Final exploration epsilon_end (Table 4)."""
    epsilon_decay: int = bounded(2000, 0, 10**9)
    """Final exploration frame T: epsilon reaches epsilon_end after this many units (Table 4)."""
    epsilon_unit: str = "steps"
    """Unit of epsilon_decay, "steps" (DQN's frames, our reading) or "episodes" (ours)."""
    noise_std: float = bounded(0.1, 0.0, 10.0)
    """Std of the Gaussian noise added to mu(s) on non-random exploratory actions (ours)."""
    hidden_sizes: tuple[int, ...] = (256, 256)
    """Widths of the tanh hidden layers of actor and critic (Sec. 4, Table 4)."""
    buffer_size: int = bounded(50_000, 1, 10**7)
    """Replay memory size (Table 4)."""
    batch_size: int = bounded(64, 1, 65_536)
    """Minibatch size m (Table 4)."""
    tau: float = bounded(0.01, 0.0, 1.0, above=True)
    """Soft target-update coefficient tau of Eq. (19) (Table 4)."""
    max_episodes: int = bounded(5000, 1, 10**9)
    """Max episodes M, the default length of a training run (Table 4)."""
    her_k: int = bounded(4, 0, 64)
    """HER 'future' goals per real transition; relabel probability k / (k + 1) (her-ddpg only; ours)."""
    train_every: int = bounded(16, 1, 10**6)
    """Environment steps between rounds of gradient steps (ours; speed)."""
    updates_per_step: float = bounded(1.0, 0.0, 1000.0, above=True)
    """Gradient steps per environment step; a round does round(train_every * this) of them (ours)."""
    learning_starts: int = bounded(1000, 0, 10**9)
    """Warm-up environment steps before the first gradient step (ours)."""
    actor_burn_in: int = bounded(0, 0, 10**9)
    """Gradient steps at the start of a run in which only the critic learns (ours, after the burn-in of residual
    policy learning, Silver et al. 2018): a fine-tuned or zero-headed residual actor is not moved by a critic
    that has not yet learned its own returns."""
    action_l2: float = bounded(0.0, 0.0, 1000.0)
    """Weight of the mean squared pre-scaling action in the actor loss (HER paper uses 1.0; ours)."""
    device: str = "cpu"
    """Torch device of the networks, "cpu" or "cuda" (ours)."""
    seed: int = bounded(0, 0, 2**32 - 1)
    """Seed of network initialisation, exploration, replay sampling and environment resets (ours)."""
    torch_threads: int = bounded(1, 1, 1024)
    """torch.set_num_threads for training; small MLPs are fastest on one thread (ours)."""

    def __post_init__(self):
        check_config(self)


def check_numeric_fields(config) -> None:
    """ValueError naming the first `bounded` field of `config` of the wrong type or out of its range."""
    for f in fields(config):
        if "range" not in f.metadata:
            continue
        (low, high), above, value = f.metadata["range"], f.metadata["above"], getattr(config, f.name)
        whole = f.type in ("int", int)
        number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
        if whole and not isinstance(value, (int, np.integer)):
            number = False
        if not number or not low <= value <= high or (above and not value > low):
            interval = f"{'(' if above else '['}{low:g}, {high:g}]"
            what = "a whole number" if whole else "a number"
            raise ValueError(f"{type(config).__name__}.{f.name} must be {what} in {interval}, got {shown(value)}")


def check_config(config: DDPGConfig) -> None:
    """ValueError naming the first field of `config` of the wrong type or out of its range."""
    check_numeric_fields(config)
    if config.epsilon_unit not in EPSILON_UNITS:
        raise ValueError(f"DDPGConfig.epsilon_unit must be one of {EPSILON_UNITS}, got {shown(config.epsilon_unit)}")
    if not isinstance(config.hidden_sizes, tuple):
        raise ValueError(f"{type(config).__name__}.hidden_sizes must be a tuple, got {shown(config.hidden_sizes)}")
    check_hidden_sizes(config.hidden_sizes, type(config).__name__)  # the bounds a checkpoint is read with
    if not isinstance(config.device, str):
        raise ValueError(f"DDPGConfig.device must be a torch device name like 'cpu' or 'cuda', "
                         f"got {shown(config.device)}")
    try:
        torch.device(config.device)
    except (RuntimeError, ValueError):
        raise ValueError(f"DDPGConfig.device must be a torch device name like 'cpu' or 'cuda', "
                         f"got {shown(config.device)}") from None


def field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of a dataclass (for --help)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    docs = {}
    for node, after in zip(body, body[1:], strict=False):
        if isinstance(node, ast.AnnAssign) and isinstance(after, ast.Expr) \
                and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str):
            docs[node.target.id] = after.value.value
    return docs


def updates_per_round(config: DDPGConfig) -> int:
    """Gradient steps a round of `train_every` env steps takes: round(train_every * updates_per_step), >= 1."""
    return max(1, round(config.train_every * config.updates_per_step))


def epsilon_at(config: DDPGConfig, steps: int, episodes: int) -> float:
    """Exploration epsilon after `steps` env steps / `episodes` episodes: linear decay, then constant."""
    progress = steps if config.epsilon_unit == "steps" else episodes
    fraction = min(1.0, progress / max(1, config.epsilon_decay))
    return config.epsilon_start + fraction * (config.epsilon_end - config.epsilon_start)


def td_target(critic_target: Critic, actor_target: Actor, rewards: torch.Tensor, next_obs: torch.Tensor,
              terminated: torch.Tensor, gamma: float) -> torch.Tensor:
    """Q_Target = r + gamma * (1 - terminated) * Q'(s', mu'(s')) (Eq. 17); s' already normalised."""
    with torch.no_grad():
        next_q = critic_target(next_obs, actor_target(next_obs))
        return rewards + gamma * (1.0 - terminated) * next_q


def critic_loss(critic: Critic, obs: torch.Tensor, actions: torch.Tensor,
                target: torch.Tensor) -> torch.Tensor:
    """Mean squared TD error L = E[(Q_Target - Q(s, a))^2] (Eq. 17-18)."""
    return (critic(obs, actions) - target).square().mean()


def actor_loss(actor: Actor, critic: Critic, obs: torch.Tensor, action_l2: float = 0.0) -> torch.Tensor:
    """Negated J(theta^mu) = E[Q(s, mu(s))] (Eq. 13, 16), plus an optional action-magnitude penalty."""
    actions = actor(obs)
    loss = -critic(obs, actions).mean()
    if action_l2:
        loss = loss + action_l2 * actions.square().mean()
    return loss


@torch.no_grad()
def soft_update(target: nn.Module | ParameterVector, source: nn.Module | ParameterVector, tau: float) -> None:
    """theta' <- tau * theta + (1 - tau) * theta' (Eq. 19), of modules or, in one call, of parameter vectors."""
    if isinstance(target, ParameterVector) and isinstance(source, ParameterVector):
        target.data.lerp_(source.data, tau)
        return
    for t, s in zip(target.parameters(), source.parameters(), strict=True):
        t.lerp_(s, tau)


class DDPG:
    """Actor, critic, their targets, the input normaliser and the two Adam optimisers."""

    def __init__(self, obs_dim: int, act_dim: int, config: DDPGConfig | None = None):
        config = config or DDPGConfig()
        self.config, self.obs_dim, self.act_dim = config, obs_dim, act_dim
        self.device = torch.device(config.device)
        if self.device.type == "cuda" and not torch.cuda.is_available():
            raise ValueError(f"DDPGConfig.device {config.device!r}: no CUDA device is available here (use 'cpu')")
        torch.manual_seed(config.seed)
        self.obs_norm = Normalizer(obs_dim).to(self.device)
        self.actor = Actor(obs_dim, act_dim, config.hidden_sizes).to(self.device)
        self.critic = Critic(obs_dim, act_dim, config.hidden_sizes).to(self.device)
        self.actor_target = copy.deepcopy(self.actor).requires_grad_(False)
        self.critic_target = copy.deepcopy(self.critic).requires_grad_(False)
        # Each network's parameters in one vector (`auv_mj.agents.offpolicy.networks`), so that Adam and the soft target
        # updates take one call per network; backward passes fill the vectors' gradients.
        self.vectors = {name: ParameterVector(getattr(self, name))
                        for name in ("actor", "critic", "actor_target", "critic_target")}
        self.actor_opt = VectorAdam([self.vectors["actor"]], lr=config.actor_lr)
        self.critic_opt = VectorAdam([self.vectors["critic"]], lr=config.critic_lr)
        self.rng = np.random.default_rng(config.seed)
        self.epsilon = config.epsilon_start
        """Current exploration epsilon, set by the training loop from `epsilon_at`."""
        self.num_updates = 0

    def zero_actor_head(self) -> None:
        """Sets the actor's (and its target's) output layer to zero: mu(s) = 0 everywhere, so that a residual
        policy starts as exactly its classical skeleton (Silver et al. 2018); the hidden layers keep their
        weights, so the gradient still reaches the head."""
        with torch.no_grad():
            for actor in (self.actor, self.actor_target):
                actor.net[-1].weight.zero_()
                actor.net[-1].bias.zero_()

    def modules(self) -> dict[str, nn.Module]:
        """The agent's modules by checkpoint prefix."""
        return {"obs_norm": self.obs_norm, "actor": self.actor, "critic": self.critic,
                "actor_target": self.actor_target, "critic_target": self.critic_target}

    def optimizers(self) -> dict[str, VectorAdam]:
        """The agent's optimisers by checkpoint prefix."""
        return {"actor_opt": self.actor_opt, "critic_opt": self.critic_opt}

    @torch.no_grad()
    def act(self, obs: np.ndarray, explore: bool = False) -> np.ndarray:
        """mu(s) in [-1, 1]^act_dim for a flat obs (or a batch); exploratory per the module docstring."""
        obs = np.asarray(obs, dtype=np.float32)
        shape = (*obs.shape[:-1], self.act_dim)
        if explore and self.rng.random() < self.epsilon:
            return self.rng.uniform(-1.0, 1.0, shape).astype(np.float32)
        x = self.obs_norm(torch.as_tensor(obs, device=self.device)).reshape(-1, self.obs_dim)
        action = self.actor(x).reshape(shape).cpu().numpy()
        if explore and self.config.noise_std > 0:
            action = np.clip(action + self.config.noise_std * self.rng.standard_normal(shape), -1.0, 1.0)
        return action.astype(np.float32, copy=False)

    def _to_tensors(self, batch: Batch) -> Batch:
        return Batch(*(torch.as_tensor(np.asarray(a, dtype=np.float32), device=self.device) for a in batch))

    def critic_step(self, obs: torch.Tensor, batch: Batch, next_obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """One critic step (Eq. 17-18) on normalised obs / next_obs, then its target (Eq. 19); (loss, mean target)."""
        cfg = self.config
        target = td_target(self.critic_target, self.actor_target, batch.rewards, next_obs, batch.terminated,
                           cfg.gamma)
        loss = critic_loss(self.critic, obs, batch.actions, target)
        self.critic_opt.zero_grad()
        loss.backward()
        self.critic_opt.step()
        soft_update(self.vectors["critic_target"], self.vectors["critic"], cfg.tau)
        return loss.detach(), target.mean()

    def actor_step(self, obs: torch.Tensor) -> torch.Tensor:
        """One actor step (Eq. 16) on normalised obs against the current critic, then its target (Eq. 19).

        The gradient of `actor_loss` flows through the critic to the action but only the actor's parameters
        receive it (`backward(inputs=...)`): the critic stays as it is, and its weight gradients are never
        computed.
        """
        cfg = self.config
        loss = actor_loss(self.actor, self.critic, obs, cfg.action_l2)
        self.actor_opt.zero_grad()
        loss.backward(inputs=self.vectors["actor"].params)
        self.actor_opt.step()
        soft_update(self.vectors["actor_target"], self.vectors["actor"], cfg.tau)
        return loss.detach()

    def _step(self, batch: Batch) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        with torch.no_grad():
            obs, next_obs = self.obs_norm(batch.obs), self.obs_norm(batch.next_obs)
        q_loss, q_target = self.critic_step(obs, batch, next_obs)
        burnt_in = self.num_updates >= self.config.actor_burn_in
        pi_loss = self.actor_step(obs) if burnt_in else torch.zeros((), device=self.device)
        self.num_updates += 1
        return q_loss, pi_loss, q_target

    def update(self, batch: Batch) -> dict[str, float]:
        """One gradient step on critic (Eq. 17-18) then actor (Eq. 16), then the targets (Eq. 19)."""
        self.obs_norm.sync()
        q_loss, pi_loss, q_target = self._step(self._to_tensors(batch))
        return {"critic_loss": q_loss.item(), "actor_loss": pi_loss.item(), "q_target": q_target.item()}

    def update_many(self, batch: Batch, n_updates: int) -> dict[str, float]:
        """`n_updates` gradient steps on consecutive equal slices of `batch` (one host->device copy).

        `batch` holds n_updates * batch_size transitions; returns the mean metrics over the steps.
        """
        self.obs_norm.sync()
        data = self._to_tensors(batch)
        size = len(batch.rewards) // n_updates
        sums = torch.zeros(3, device=self.device)
        for k in range(n_updates):
            part = Batch(*(a[k * size:(k + 1) * size] for a in data))
            sums += torch.stack(self._step(part))
        q_loss, pi_loss, q_target = (sums / n_updates).tolist()
        return {"critic_loss": q_loss, "actor_loss": pi_loss, "q_target": q_target}
