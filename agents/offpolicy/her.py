"""Hindsight experience replay (Algorithm 1, Sec. 3.2.1) as a replay-buffer concern, 'future' strategy.

Whole episodes are stored in a ring buffer with each transition's episode start and length. At sampling
time a fraction k / (k + 1) of the transitions get a new desired goal g' = phi(s''): the achieved goal of
a state s'' later in the same episode. Concretely g' = next_achieved_goal[t'] with t' uniform in
[t, T - 1] (SB3's inclusive convention over transitions), i.e. the achieved goal of a state s_{t'+1}
strictly later than s_t. `desired_goal` is replaced in both obs and next_obs, and the reward (Eq. 23-26)
and the termination are recomputed with ONE vectorised `compute_reward` and ONE `compute_terminated`
call over the relabelled part of the batch, passing the stored per-step `info` as a dict of stacked
arrays. Time-limit truncation is never stored as termination.

HER is only sound if `observation` does not depend on the desired goal. A task whose observation holds
goal-relative features (distance or bearing to the goal) must supply a vectorised
`relabel_observation(observation, achieved_goal, desired_goal) -> observation` that recomputes them;
the buffer then applies it to obs and next_obs of every relabelled transition.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np

from auv_mj.agents.offpolicy.replay import Batch, rng_from_array, rng_state_to_array

GoalFn = Callable[[np.ndarray, np.ndarray, dict[str, np.ndarray]], np.ndarray]
"""Signature of the env's vectorised compute_reward / compute_terminated(achieved, desired, info)."""
ObsFn = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""Signature of an optional vectorised relabel_observation(observation, achieved_goal, desired_goal)."""


def flatten_goal_obs(observation: np.ndarray, desired_goal: np.ndarray) -> np.ndarray:
    """The network input of a goal task: [observation, desired_goal] along the last axis."""
    return np.concatenate([observation, desired_goal], axis=-1).astype(np.float32, copy=False)


def policy_input(observation: np.ndarray, desired_goal: np.ndarray, goal_input: bool = True) -> np.ndarray:
    """The network input of a goal task: [observation, desired_goal], or the observation alone when it
    already holds the goal (an env with `goal_in_observation`, e.g. the goal in the body frame)."""
    if goal_input:
        return flatten_goal_obs(observation, desired_goal)
    return np.asarray(observation, dtype=np.float32)


def her_ratio(n_sampled_goal: int) -> float:
    """Fraction of relabelled transitions for k hindsight goals per real one: k / (k + 1)."""
    return n_sampled_goal / (n_sampled_goal + 1.0)


class HerSample(NamedTuple):
    """A relabelled minibatch with the bookkeeping that produced it (for tests and diagnostics)."""

    batch: Batch
    indices: np.ndarray
    """Buffer slots of the sampled transitions."""
    relabelled: np.ndarray
    """Boolean mask of the transitions that got a hindsight goal."""
    future_indices: np.ndarray
    """Buffer slot t' whose next_achieved_goal became the new goal (== indices where not relabelled)."""
    desired_goals: np.ndarray
    """The desired goal used for each transition (in obs and next_obs where relabelled)."""


class HerReplayBuffer:
    """Episode-aware ring buffer of goal transitions with vectorised 'future' relabelling.

    Transitions of the episode in progress are stored as they come but only become samplable once
    `end_episode` closes the episode. When the ring overwrites the first transition of an old episode,
    the rest of that episode is invalidated, so hindsight goals never come from overwritten data.
    """

    def __init__(self, obs_dim: int, goal_dim: int, act_dim: int, capacity: int,
                 compute_reward: GoalFn, compute_terminated: GoalFn, n_sampled_goal: int = 4,
                 seed: int | None = None, relabel_observation: ObsFn | None = None, goal_input: bool = True):
        self.capacity = int(capacity)
        self.compute_reward, self.compute_terminated = compute_reward, compute_terminated
        self.relabel_observation = relabel_observation
        self.goal_input = goal_input
        """Whether the network input holds desired_goal beside the observation (see `policy_input`)."""
        self.n_sampled_goal = n_sampled_goal
        self.her_ratio = her_ratio(n_sampled_goal)
        c = self.capacity
        self.observation = np.zeros((c, obs_dim), np.float32)
        self.achieved_goal = np.zeros((c, goal_dim), np.float32)
        self.desired_goal = np.zeros((c, goal_dim), np.float32)
        self.next_observation = np.zeros((c, obs_dim), np.float32)
        self.next_achieved_goal = np.zeros((c, goal_dim), np.float32)
        self.next_desired_goal = np.zeros((c, goal_dim), np.float32)
        self.actions = np.zeros((c, act_dim), np.float32)
        self.rewards = np.zeros(c, np.float32)
        self.terminated = np.zeros(c, bool)
        self.truncated = np.zeros(c, bool)
        self.ep_start = np.zeros(c, np.int64)
        self.ep_length = np.zeros(c, np.int64)
        self.valid = np.zeros(c, bool)
        self.infos: dict[str, np.ndarray] = {}
        self.pos = 0
        self.size = 0
        self.current_start = 0
        self.current_length = 0
        self.rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        return self.size

    @property
    def num_samplable(self) -> int:
        """Transitions of completed, not overwritten episodes."""
        return int(self.valid.sum())

    def add(self, obs: Mapping[str, np.ndarray], action: np.ndarray, reward: float,
            next_obs: Mapping[str, np.ndarray], terminated: bool, truncated: bool,
            info: Mapping[str, Any]) -> None:
        """Stores one step of the episode in progress, with its numeric info entries."""
        if self.current_length >= self.capacity:
            raise ValueError(f"an episode longer than the replay capacity {self.capacity}")
        i = self.pos
        if self.valid[i]:
            stale = (self.ep_start[i] + np.arange(self.ep_length[i])) % self.capacity
            self.valid[stale] = False
        if not self.infos:
            self._allocate_infos(info)
        self.observation[i] = obs["observation"]
        self.achieved_goal[i] = obs["achieved_goal"]
        self.desired_goal[i] = obs["desired_goal"]
        self.next_observation[i] = next_obs["observation"]
        self.next_achieved_goal[i] = next_obs["achieved_goal"]
        self.next_desired_goal[i] = next_obs["desired_goal"]
        self.actions[i] = action
        self.rewards[i] = reward
        self.terminated[i] = terminated
        self.truncated[i] = truncated and not terminated
        for key, store in self.infos.items():
            if key not in info:
                raise KeyError(f"info of this step lacks {key!r}, present at the first step")
            store[i] = info[key]
        self.pos = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)
        self.current_length += 1

    def end_episode(self) -> None:
        """Closes the episode in progress: records its start and length and makes it samplable."""
        if self.current_length == 0:
            return
        idx = (self.current_start + np.arange(self.current_length)) % self.capacity
        self.ep_start[idx] = self.current_start
        self.ep_length[idx] = self.current_length
        self.valid[idx] = True
        self.current_start, self.current_length = self.pos, 0

    def sample(self, batch_size: int) -> Batch:
        """A minibatch with a fraction `her_ratio` of hindsight goals (see `sample_relabelled`)."""
        return self.sample_relabelled(batch_size).batch

    def sample_relabelled(self, batch_size: int) -> HerSample:
        """Uniform transitions of completed episodes, relabelled with the 'future' strategy."""
        candidates = np.flatnonzero(self.valid)
        if len(candidates) == 0:
            raise ValueError("no completed episode in the HER buffer to sample from")
        idx = candidates[self.rng.integers(0, len(candidates), batch_size)]
        relabel = self.rng.random(batch_size) < self.her_ratio
        start, length = self.ep_start[idx], self.ep_length[idx]
        t = (idx - start) % self.capacity
        future = np.where(relabel, (start + self.rng.integers(t, length)) % self.capacity, idx)

        desired = self.desired_goal[idx]
        next_desired = self.next_desired_goal[idx]
        rewards = self.rewards[idx]
        terminated = self.terminated[idx]
        observation, next_observation = self.observation[idx], self.next_observation[idx]
        if relabel.any():
            r_idx = idx[relabel]
            new_goal = self.next_achieved_goal[future[relabel]]
            achieved = self.next_achieved_goal[r_idx]
            info = {key: store[r_idx] for key, store in self.infos.items()}
            desired[relabel] = new_goal
            next_desired[relabel] = new_goal
            rewards[relabel] = self.compute_reward(achieved, new_goal, info)
            terminated[relabel] = self.compute_terminated(achieved, new_goal, info)
            if self.relabel_observation is not None:
                observation[relabel] = self.relabel_observation(observation[relabel],
                                                                self.achieved_goal[r_idx], new_goal)
                next_observation[relabel] = self.relabel_observation(next_observation[relabel], achieved,
                                                                     new_goal)
        batch = Batch(obs=policy_input(observation, desired, self.goal_input), actions=self.actions[idx],
                      rewards=rewards, next_obs=policy_input(next_observation, next_desired, self.goal_input),
                      terminated=terminated.astype(np.float32))
        return HerSample(batch, idx, relabel, future, desired)

    def _allocate_infos(self, info: Mapping[str, Any]) -> None:
        for key, value in info.items():
            value = np.asarray(value)
            if value.dtype.kind in "biuf":
                self.infos[key] = np.zeros((self.capacity, *value.shape), value.dtype)

    def state_dict(self) -> dict[str, np.ndarray]:
        """The whole buffer (slots, episode bookkeeping, infos, RNG) as arrays for an .npz."""
        n = self.size
        state = {name: getattr(self, name)[:n] for name in _SLOT_FIELDS}
        state.update({f"info.{key}": store[:n] for key, store in self.infos.items()})
        state["info_keys"] = np.array(json.dumps(list(self.infos)))
        state["counters"] = np.array([self.pos, self.current_start, self.current_length, self.capacity])
        state["rng"] = rng_state_to_array(self.rng)
        return state

    def load_state_dict(self, state: Mapping[str, np.ndarray]) -> None:
        """Restores what `state_dict` saved; raises ValueError on a shape or capacity mismatch."""
        pos, current_start, current_length, capacity = (int(v) for v in state["counters"])
        if capacity != self.capacity:
            raise ValueError(f"replay capacity {capacity} saved, {self.capacity} configured")
        for name in _SLOT_FIELDS:
            dest, src = getattr(self, name), state[name]
            if src.shape[1:] != dest.shape[1:] or len(src) > len(dest):
                raise ValueError(f"replay field {name!r} has shape {src.shape}, expected "
                                 f"{dest.shape[1:]} per transition")
            dest[: len(src)] = src
        self.infos = {}
        for key in json.loads(str(state["info_keys"])):
            src = state[f"info.{key}"]
            self.infos[key] = np.zeros((self.capacity, *src.shape[1:]), src.dtype)
            self.infos[key][: len(src)] = src
        self.size = len(state["rewards"])
        self.pos, self.current_start, self.current_length = pos, current_start, current_length
        self.rng = rng_from_array(state["rng"])


_SLOT_FIELDS = ("observation", "achieved_goal", "desired_goal", "next_observation", "next_achieved_goal",
                "next_desired_goal", "actions", "rewards", "terminated", "truncated", "ep_start",
                "ep_length", "valid")
