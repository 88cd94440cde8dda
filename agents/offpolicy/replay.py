"""The experience replay pool of DDPG (Sec. 3.1.2): a vectorised numpy ring buffer of (s, a, r, s', done).

Only true terminations (goal reached, collision) are stored as `terminated`; time-limit truncation is
not, so the critic target keeps bootstrapping through it (Eq. 17).
"""

from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np


class Batch(NamedTuple):
    """A minibatch of transitions as float32 numpy arrays; `terminated` is 1.0 where s' is terminal."""

    obs: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    next_obs: np.ndarray
    terminated: np.ndarray


def rng_state_to_array(rng: np.random.Generator) -> np.ndarray:
    """A generator's state as a 0-d string array, storable in an .npz."""
    return np.array(json.dumps(rng.bit_generator.state))


def rng_from_array(state: np.ndarray) -> np.random.Generator:
    """The generator whose state `rng_state_to_array` saved."""
    rng = np.random.default_rng()
    rng.bit_generator.state = json.loads(str(state))
    return rng


class ReplayBuffer:
    """Fixed-capacity FIFO of flat transitions; `sample` draws uniformly with replacement."""

    def __init__(self, obs_dim: int, act_dim: int, capacity: int, seed: int | None = None):
        self.capacity = int(capacity)
        self.obs = np.zeros((capacity, obs_dim), np.float32)
        self.actions = np.zeros((capacity, act_dim), np.float32)
        self.rewards = np.zeros(capacity, np.float32)
        self.next_obs = np.zeros((capacity, obs_dim), np.float32)
        self.terminated = np.zeros(capacity, np.float32)
        self.pos = 0
        self.size = 0
        self.rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        return self.size

    def add(self, obs: np.ndarray, action: np.ndarray, reward: float, next_obs: np.ndarray,
            terminated: bool) -> None:
        """Stores one transition, overwriting the oldest when full."""
        i = self.pos
        self.obs[i] = obs
        self.actions[i] = action
        self.rewards[i] = reward
        self.next_obs[i] = next_obs
        self.terminated[i] = terminated
        self.pos = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(self, batch_size: int) -> Batch:
        """`batch_size` transitions drawn uniformly with replacement."""
        if self.size == 0:
            raise ValueError("cannot sample from an empty replay buffer")
        idx = self.rng.integers(0, self.size, batch_size)
        return Batch(self.obs[idx], self.actions[idx], self.rewards[idx], self.next_obs[idx],
                     self.terminated[idx])

    def state_dict(self) -> dict[str, np.ndarray]:
        """The filled part of the buffer, the write position and the sampling RNG, as arrays."""
        n = self.size
        return {"obs": self.obs[:n], "actions": self.actions[:n], "rewards": self.rewards[:n],
                "next_obs": self.next_obs[:n], "terminated": self.terminated[:n],
                "pos": np.array(self.pos), "capacity": np.array(self.capacity),
                "rng": rng_state_to_array(self.rng)}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restores what `state_dict` saved; raises ValueError on a shape or capacity mismatch."""
        _check_capacity(state, self.capacity)
        n = len(state["rewards"])
        for name in ("obs", "actions", "rewards", "next_obs", "terminated"):
            _copy_into(getattr(self, name), state[name], name)
        self.size, self.pos = n, int(state["pos"])
        self.rng = rng_from_array(state["rng"])


def _check_capacity(state: dict[str, np.ndarray], capacity: int) -> None:
    if int(state["capacity"]) != capacity:
        raise ValueError(f"replay capacity {int(state['capacity'])} saved, {capacity} configured")


def _copy_into(dest: np.ndarray, src: np.ndarray, name: str) -> None:
    if src.shape[1:] != dest.shape[1:] or len(src) > len(dest):
        raise ValueError(f"replay field {name!r} has shape {src.shape}, expected (<= {len(dest)}, "
                         f"{', '.join(map(str, dest.shape[1:]))})")
    dest[: len(src)] = src
