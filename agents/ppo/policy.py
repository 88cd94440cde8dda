"""A trained PPO policy as a deterministic controller, loaded from a checkpoint of kind "ppo"."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from auv_mj.agents.ppo.checkpoint import load_model, read_ppo
from auv_mj.agents.ppo.model import ActorCritic
from auv_mj.agents.ppo.spaces import env_action, flatten_obs


class PPOPolicy:
    """A trained PPO policy as a deterministic controller: observation -> the clipped mean action in the env's Box.

    Runs in float64 (as `auv_mj.agents.offpolicy.Policy`, so that a closed loop does not depend on the CPU's float32
    kernels) and carries the actor's memory from call to call; `reset()` before each episode. It runs the actor
    alone (`ActorCritic.act`): a policy trained with a privileged critic needs no privileged input here. It takes
    one observation (a Box array or goal dict) or a batch of them with a leading env dimension; the memory is sized
    on the first call after a reset.

    With `stochastic`, it acts as in training instead: the mean plus the policy's Gaussian noise (std exp(log_std),
    drawn from a generator seeded with `seed`), then clipped; what the issue's "report the stochastic policy beside
    the deterministic one" measures (issue 51, item 2).
    """

    def __init__(self, model: ActorCritic, spec: Mapping[str, Any], device: str = "cpu", stochastic: bool = False,
                 seed: int = 0):
        self.model = model.to(device).double().eval()
        self.spec = dict(spec)
        self.device = torch.device(device)
        self.state: torch.Tensor | None = None
        self.stochastic = stochastic
        self.rng = np.random.default_rng(seed)

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", stochastic: bool = False, seed: int = 0) -> PPOPolicy:
        """The policy of checkpoint `path` (of kind "ppo"); ValueError naming the file if it is unusable."""
        (tensors, meta), config = read_ppo(path)
        model = load_model(path, tensors, meta["spec"], dataclasses.replace(config, device="cpu"))
        return cls(model, meta["spec"], device, stochastic, seed)

    def reset(self) -> None:
        """Forgets the memory: the next call starts an episode."""
        self.state = None

    @torch.no_grad()
    def __call__(self, obs: np.ndarray | Mapping[str, np.ndarray]) -> np.ndarray:
        """The action for `obs`, continuing the episode since the last reset."""
        flat = flatten_obs(obs, self.spec)
        single = flat.ndim == 1
        x = torch.as_tensor(np.asarray(flat, np.float64).reshape(-1, self.spec["obs_dim"]), device=self.device)
        starts = torch.zeros(1, x.shape[0], dtype=torch.float64, device=self.device)
        if self.state is None:
            self.state = self.model.initial_state(x.shape[0], actor_only=True)
        elif self.state.shape[0] != x.shape[0]:
            raise ValueError(f"a batch of {x.shape[0]} observations, the policy's memory holds {self.state.shape[0]} "
                             "envs: reset() before changing the batch size")
        mean, self.state = self.model.act(x[None], starts, self.state)
        normalised = mean[0].cpu().numpy()
        if self.stochastic:
            std = self.model.log_std.detach().exp().cpu().numpy()
            normalised = normalised + std * self.rng.standard_normal(normalised.shape)
        action = env_action(normalised, self.spec).reshape(-1, *self.spec["act_shape"])
        return action[0] if single else action
