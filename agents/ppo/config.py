"""PPO's hyper-parameters, one frozen dataclass checked as it is built, and the schedules a run follows.

`PPOConfig`'s defaults are CleanRL's `ppo_continuous_action.py` (Huang et al. 2022). Schedules: the learning rate, the
clip range and the imitation weight fall to their floors over the run's planned env steps (`lr_schedule`,
`clip_schedule`, `imitation_schedule`: constant, linear as CleanRL's, or cosine), as functions of the global step
(`schedule_at`, `imitation_weight`); the planned steps are in the checkpoint, so a resumed run continues the same
schedule. The algorithm that reads them is `auv_mj.agents.ppo.ppo`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

RECURRENT_KINDS = (None, "gru", "lstm")
SCHEDULES = ("constant", "linear", "cosine")
"""How a scheduled hyper-parameter goes from its value to its floor over the run's planned steps (`scheduled`)."""

IMITATION_SOURCES = ("teacher", "init")
"""Who labels the imitation term (PPOConfig.imitation_source): the caller's teacher, or the run's frozen start."""


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
    """Rollouts between checkpoints; the envs are reset at each, so that resuming is exact (`auv_mj.agents.ppo.ppo`)."""
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
    imitation_source: str = "teacher"
    """Who labels the imitation term's states (IMITATION_SOURCES): "teacher", the caller's teacher
    (`train(..., teacher=...)`); "init", the run's starting actor, frozen (the `init` checkpoint's, kept in the run's
    checkpoint as its anchor): the term then holds the actor near the policy it started from while RL moves it, with
    no teacher in the loop (a behaviour-regularised fine-tune, as the reference-policy penalty of a PPO fine-tune;
    here on the mean action, as the teacher's term, so the log std stays free)."""
    critic_warmup_steps: int = 0
    """Env steps at the start of a run (global steps, so a resumed run keeps them) whose updates train the critic
    alone: the actor's weights and log std are held as loaded while a new critic learns its values. For a fine-tune
    from an imitation student, whose actor is good and whose critic starts untrained: the first updates' advantages
    are then the critic's noise, and PPO spends the student on them (a critic warm-up, as in fine-tunes after
    behaviour cloning; PPO's counterpart of the off-policy agents' `actor_burn_in`, counted in env steps). Its
    observation statistics keep their running update. 0: none."""
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
        if self.critic_warmup_steps and self.recurrent is not None and not self.separate_critic:
            raise ValueError("PPOConfig.critic_warmup_steps needs separate_critic=True with a memory: the value "
                             "loss would train the encoder the actor shares")


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value: Any) -> bool:
    return isinstance(value, (int, float))


_CONFIG_CHECKS: tuple[tuple[tuple[str, ...], Callable[[Any], bool], str], ...] = (
    (("num_steps", "num_minibatches", "update_epochs", "recurrent_size", "checkpoint_every", "torch_threads"),
     lambda v: _whole(v) and v >= 1, "a whole number >= 1"),
    (("critic_warmup_steps",), lambda v: _whole(v) and v >= 0, "a whole number >= 0"),
    (("learning_rate", "adam_eps", "clip_coef", "max_grad_norm"), lambda v: _number(v) and 0 < v < math.inf,
     "a finite number > 0"),
    (("gamma", "gae_lambda"), lambda v: _number(v) and 0 <= v <= 1, "in [0, 1]"),
    (("ent_coef", "vf_coef", "min_learning_rate", "min_clip_coef", "imitation_coef", "min_imitation_coef"),
     lambda v: _number(v) and 0 <= v < math.inf,
     "a finite number >= 0"),
    (("lr_schedule", "clip_schedule", "imitation_schedule"), lambda v: v in SCHEDULES, f"one of {SCHEDULES}"),
    (("imitation_source",), lambda v: v in IMITATION_SOURCES, f"one of {IMITATION_SOURCES}"),
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
