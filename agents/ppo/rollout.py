"""PPO's rollout: the `Collector` steps a Gymnasium vector env with the policy into a `Rollout` of (T, N) tensors.

Each env's memory is carried across the rollout and zeroed before the first observation of each episode; the
episodes that end are counted per cell of the env (`Episode`) for the logs. A critic with privileged inputs reads
the env's info["privileged"] (`privileged_inputs`).

Episode ends and autoreset (Gymnasium >= 1.0, `gymnasium.vector.AutoresetMode`): `env.metadata["autoreset_mode"]`,
NEXT_STEP when absent (the default of SyncVectorEnv and AsyncVectorEnv). NEXT_STEP: the step that ends an episode
returns its final observation; the next `step` resets that env and ignores its action, returning reward 0 and the
first observation. That extra step is kept in the rollout (its value V(final observation) is the bootstrap of a
truncation, computed with the episode's memory) but masked out of every loss (`valid`). SAME_STEP: the step returns
the next episode's first observation and `info["final_obs"]`; V(final observation) is computed from the episode's
memory for truncated envs. DISABLED is refused. GAE (`auv_mj.agents.ppo.ppo.gae`) bootstraps truncations (time
limits) from V(final observation) and not terminations, through a separate `next_values` array.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np
import torch
from gymnasium.vector import AutoresetMode, VectorEnv

from auv_mj.agents.ppo.config import PPOConfig
from auv_mj.agents.ppo.model import ActorCritic
from auv_mj.agents.ppo.spaces import autoreset_mode, env_action, final_observation, flatten_obs, normalised_action


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
    """V(s_{t+1}) of the same episode (`auv_mj.agents.ppo.ppo.gae`)."""
    initial_state: torch.Tensor
    privileged: torch.Tensor | None = None
    """The critic's privileged inputs (T, N, P) beside each observation (None: it has none)."""
    labels: torch.Tensor | None = None
    """A teacher's actions (T, N, act_dim) at each observation, in the networks' normalised space, or the frozen
    anchor's mean actions clipped to it (`Collector`'s `anchor`); None: no labels."""


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


def privileged_size(env: VectorEnv, seeds: list[int]) -> int:
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


class Collector:
    """Steps a vector env with the policy, carrying each env's memory and its episode bookkeeping.

    An env with `cells` (a list of names or tuples of names) and `cell_of_row` (row -> index into it), as
    `auv_mj.tasks.mixture.PlanningMixtureVectorEnv`, has its finished episodes counted per cell; any other env is
    one cell, "all". `step_speed(next_obs, info)`, if given, is each row's speed over the step just taken.
    Labels for an imitation term come from `teacher` (at the env's states) or `anchor` (a frozen actor that reads
    the rollout's observations with a memory of its own: PPOConfig.imitation_source "init"), not both.
    """

    def __init__(self, env: VectorEnv, model: ActorCritic, spec: Mapping[str, Any], config: PPOConfig,
                 generator: torch.Generator,
                 step_speed: Callable[[Any, Mapping[str, Any]], np.ndarray] | None = None,
                 teacher: Callable[[], np.ndarray] | None = None, anchor: ActorCritic | None = None):
        if teacher is not None and anchor is not None:
            raise ValueError("Collector: labels come from a teacher or an anchor, not both")
        self.env, self.model, self.spec, self.config, self.generator = env, model, spec, config, generator
        self.anchor = anchor
        """A frozen actor whose mean actions on the rollout's observations are its labels; None: none."""
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
        self.anchor_state = anchor.initial_state(self.num_envs, actor_only=True) if anchor is not None else None
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
        if self.anchor is not None:
            self.anchor_state = self.anchor.initial_state(self.num_envs, actor_only=True)
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
        if self.anchor is not None:  # the anchor reads what the actor read, its memory zeroed at the same starts
            anchor_mean, self.anchor_state = self.anchor.act(obs_buf, starts, self.anchor_state)
            labels = anchor_mean.clamp(-1.0, 1.0)
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
