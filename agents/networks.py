"""Actor and critic MLPs of Sec. 4 (two tanh hidden layers of 256) and a running input normaliser.

The normaliser follows the HER paper (Andrychowicz et al. 2017): inputs are standardised with running
statistics and clipped to [-NORM_CLIP, NORM_CLIP]; its statistics are module buffers, so they travel
with every checkpoint.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

NORM_CLIP = 5.0
"""Standardised inputs are clipped to +-NORM_CLIP (HER paper)."""
NORM_MIN_STD = 1e-2
"""Lower bound on the running standard deviation, so constant inputs do not blow up (HER paper)."""


def mlp(in_dim: int, hidden_sizes: Sequence[int], out_dim: int) -> nn.Sequential:
    """Fully connected layers with tanh activations after every hidden layer (Eq. 31, Sec. 4)."""
    layers: list[nn.Module] = []
    for width in hidden_sizes:
        layers += [nn.Linear(in_dim, width), nn.Tanh()]
        in_dim = width
    layers.append(nn.Linear(in_dim, out_dim))
    return nn.Sequential(*layers)


class Normalizer(nn.Module):
    """Running mean/std standardisation of network inputs, clipped to +-NORM_CLIP.

    `update` only accumulates numpy sums on the host (cheap, once per environment step); `sync`
    folds them into the buffers used by `forward`, once per round of gradient steps.
    """

    def __init__(self, size: int, clip: float = NORM_CLIP, min_std: float = NORM_MIN_STD):
        super().__init__()
        self.size, self.clip, self.min_std = size, clip, min_std
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))
        self.register_buffer("sum", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("sumsq", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("std", torch.ones(size))
        self._pending = [0.0, np.zeros(size), np.zeros(size)]

    def update(self, x: np.ndarray) -> None:
        """Accumulates one input (size,) or a batch (n, size); takes effect at the next `sync`."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, self.size)
        self._pending[0] += x.shape[0]
        self._pending[1] += x.sum(axis=0)
        self._pending[2] += np.square(x).sum(axis=0)

    @torch.no_grad()
    def sync(self) -> None:
        """Folds pending statistics into mean and std."""
        count, total, total_sq = self._pending
        if count == 0:
            return
        self.count += count
        self.sum += torch.as_tensor(total, device=self.sum.device)
        self.sumsq += torch.as_tensor(total_sq, device=self.sumsq.device)
        mean = self.sum / self.count
        var = (self.sumsq / self.count - mean.square()).clamp_min(self.min_std**2)
        self.mean.copy_(mean)
        self.std.copy_(var.sqrt())
        self._pending = [0.0, np.zeros(self.size), np.zeros(self.size)]

    def pending_state(self) -> dict[str, torch.Tensor]:
        """Statistics accumulated since the last `sync`, as CPU tensors (so a resumed run syncs alike)."""
        count, total, total_sq = self._pending
        return {"count": torch.tensor(count, dtype=torch.float64), "sum": torch.from_numpy(total.copy()),
                "sumsq": torch.from_numpy(total_sq.copy())}

    def load_pending_state(self, state: dict[str, torch.Tensor]) -> None:
        """Restores what `pending_state` returned."""
        self._pending = [float(state["count"]), state["sum"].double().numpy().copy(),
                         state["sumsq"].double().numpy().copy()]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return ((x - self.mean) / self.std).clamp(-self.clip, self.clip)


class Actor(nn.Module):
    """Deterministic policy mu(s | theta^mu) with tanh output in [-1, 1]^act_dim (Eq. 15, 28)."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: Sequence[int] = (256, 256)):
        super().__init__()
        self.net = mlp(obs_dim, hidden_sizes, act_dim)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.net(obs))


class Critic(nn.Module):
    """Action-value Q(s, a | theta^Q) of (normalised state, action in [-1, 1]) (Eq. 16-17)."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: Sequence[int] = (256, 256)):
        super().__init__()
        self.net = mlp(obs_dim + act_dim, hidden_sizes, 1)

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([obs, action], dim=-1)).squeeze(-1)
