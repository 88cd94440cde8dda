"""The running input normaliser both learning stacks put in front of their networks (`auv_mj.agents.offpolicy`'s
actor and critic, `auv_mj.agents.ppo`'s actor-critic).

It follows the HER paper (Andrychowicz et al. 2017): inputs are standardised with running statistics and clipped to
[-NORM_CLIP, NORM_CLIP]; its statistics are module buffers, so they travel with every checkpoint.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

NORM_CLIP = 5.0
"""Standardised inputs are clipped to +-NORM_CLIP (HER paper)."""
NORM_MIN_STD = 1e-2
"""Lower bound on the running standard deviation, so constant inputs do not blow up (HER paper)."""



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
