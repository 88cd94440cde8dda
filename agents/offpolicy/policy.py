"""A trained deterministic policy a = mu(s) (Eq. 28-29) loaded from a checkpoint, for evaluation."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from auv_mj.agents.checkpoint import load_module, read_checkpoint, saved_config
from auv_mj.agents.normalizer import Normalizer
from auv_mj.agents.offpolicy.her import policy_input
from auv_mj.agents.offpolicy.learners import AGENTS, agent_classes
from auv_mj.agents.offpolicy.networks import Actor


class Policy:
    """Maps an observation (goal dict or flat array, single or batched) to an action in the env's bounds.

    Only the normaliser and the actor are loaded; no exploration noise, so equal inputs give equal
    actions. They run in float64: a float32 forward pass rounds differently on different CPUs (AVX2 against
    AVX-512 kernels), and a closed loop grows that last bit into metres (0.9 m in 60 steps of `two-layer`), so
    that an evaluation was the same only on the same kind of machine. In float64 the kernels still differ in
    the last bit, about 1e-16, which the same growth (1e5 in that episode) leaves far below a test's 1e-9 over
    60 steps; but over a whole scenario of several hundred steps the growth goes on, and the paper scenarios'
    `two-layer` rows move by metres with the MKL kernels (goal a1: 340 m / 177 s by default on AVX-512, 338 m /
    171 s with MKL_ENABLE_INSTRUCTIONS=AVX2, 344 m / 181 s with SSE4_2; `docs/reproduction.md`, "Scenarios").
    """

    def __init__(self, actor: Actor, obs_norm: Normalizer, metadata: Mapping[str, Any],
                 device: str = "cpu"):
        self.actor, self.obs_norm = actor.double().eval(), obs_norm.double().eval()
        self.metadata = dict(metadata)
        self.device = torch.device(device)
        spec = self.metadata["spec"]
        self.obs_dim = int(self.metadata["obs_dim"])
        self.obs_shape = tuple(spec["obs_shape"])
        self.low = np.asarray(spec["action_low"], np.float32)
        self.high = np.asarray(spec["action_high"], np.float32)

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu") -> Policy:
        """The policy saved in checkpoint `path`; ValueError naming the file if it is unusable."""
        path = Path(path)
        checkpoint = read_checkpoint(path, AGENTS)
        tensors, meta = checkpoint
        config = saved_config(checkpoint, path, agent_classes(checkpoint.kind)[1])
        obs_dim, act_dim = int(meta["obs_dim"]), int(meta["act_dim"])
        actor = Actor(obs_dim, act_dim, config.hidden_sizes)
        obs_norm = Normalizer(obs_dim)
        for prefix, module in (("actor", actor), ("obs_norm", obs_norm)):
            load_module(module, tensors, prefix, path)
        return cls(actor.to(device), obs_norm.to(device), meta, device)

    def flat_obs(self, obs: np.ndarray | Mapping[str, np.ndarray]) -> np.ndarray:
        """The network input: [observation, desired_goal] of a goal dict (the observation alone where it
        holds the goal), or the array itself."""
        if isinstance(obs, Mapping):
            flat = policy_input(np.asarray(obs["observation"]), np.asarray(obs["desired_goal"]),
                                self.metadata["spec"].get("goal_input", True))
        else:
            arr = np.asarray(obs, np.float32)
            flat = arr.reshape(*arr.shape[: arr.ndim - len(self.obs_shape)], -1)
        if flat.shape[-1] != self.obs_dim:
            raise ValueError(f"observation of size {flat.shape[-1]}, the policy expects {self.obs_dim}")
        return flat

    @torch.no_grad()
    def __call__(self, obs: np.ndarray | Mapping[str, np.ndarray]) -> np.ndarray:
        """mu(s), rescaled from [-1, 1] to the action bounds the policy was trained with."""
        x = torch.as_tensor(np.asarray(self.flat_obs(obs), np.float64), device=self.device)
        a = self.actor(self.obs_norm(x)).cpu().numpy()
        return self.low + (a + 1.0) * 0.5 * (self.high - self.low)
