"""Actor and critic MLPs of Sec. 4 (two tanh hidden layers of 256) and a running input normaliser.

The normaliser follows the HER paper (Andrychowicz et al. 2017): inputs are standardised with running
statistics and clipped to [-NORM_CLIP, NORM_CLIP]; its statistics are module buffers, so they travel
with every checkpoint.

The gradient steps of `agents.ddpg` and `agents.td3` run on the same networks through a faster path: their
parameters live in one `ParameterVector` per network, `DensePass` does the forward and backward passes by
hand, and `Adam` steps the whole vector at once (a gradient step of Table 4's sizes costs about half of
autograd's and torch.optim's). The modules' own `forward` is unchanged, for policies and tests.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

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


class ParameterVector:
    """The parameters of some modules as views into one contiguous vector, and a gradient vector alike.

    At Table 4's sizes (2 x 256, batch 64) a call per tensor costs more than its arithmetic, so Adam's step
    and the soft target update (Eq. 19) act on the one vector in a few calls. The modules keep their
    `nn.Parameter`s (state dicts, `load_state_dict` and plain forward passes are unchanged); only their
    storage moves. Build it after the modules are on their device: `.to()` would re-point the parameters.
    """

    def __init__(self, *modules: nn.Module):
        self.params = [p for module in modules for p in module.parameters()]
        self.data = torch.cat([p.detach().reshape(-1) for p in self.params])
        self.grad = torch.zeros_like(self.data)
        self.grads: list[torch.Tensor] = []
        """Per parameter, the view of `grad` holding its gradient."""
        offset = 0
        for p in self.params:
            size = p.numel()
            p.data = self.data[offset:offset + size].view_as(p)
            self.grads.append(self.grad[offset:offset + size].view_as(p))
            offset += size

    def views(self, params: Sequence[nn.Parameter]) -> list[torch.Tensor]:
        """The gradient views of `params` (some of this vector's parameters), in their order."""
        index = {id(p): k for k, p in enumerate(self.params)}
        return [self.grads[index[id(p)]] for p in params]


class DensePass:
    """Forward and backward passes of an `mlp` written out by hand, on its weights' storage.

    Autograd records and replays a graph of small operations each step; for the two tanh layers of Sec. 4
    the gradients are a handful of matrix products (dL/dW = delta^T h, dL/dh = delta W, tanh' = 1 - tanh^2),
    so writing them down halves a gradient step. `tests/test_agents.py` checks them against autograd.
    Gradients go to `grads` (views of a `ParameterVector`'s gradient, weight then bias per layer).
    """

    def __init__(self, net: nn.Sequential, grads: Sequence[torch.Tensor] | None = None):
        linears = [m for m in net if isinstance(m, nn.Linear)]
        if len(linears) * 2 - 1 != len(net) or not all(isinstance(m, nn.Tanh) for m in list(net)[1::2]):
            raise ValueError("DensePass needs an `mlp`: Linear layers with tanh between them")
        self.weights = [m.weight.detach() for m in linears]
        self.biases = [m.bias.detach() for m in linears]
        self.grads = list(grads) if grads is not None else None

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        """[x, h_1, ..., h_L, output]: the input, each tanh layer's output and the last linear output."""
        activations = [x]
        last = len(self.weights) - 1
        for layer, (weight, bias) in enumerate(zip(self.weights, self.biases, strict=True)):
            z = torch.addmm(bias, activations[-1], weight.t())
            activations.append(z.tanh_() if layer < last else z)
        return activations

    def backward(self, activations: Sequence[torch.Tensor], grad_output: torch.Tensor, weights: bool = True,
                 input_columns: slice | None = None) -> torch.Tensor | None:
        """Back-propagates dL/d(output) through the layers of `forward`'s `activations`.

        `weights` writes dL/dW and dL/db into `grads`; `input_columns` returns dL/dx of those input columns
        (the action part of the critic's [s, a], for the actor's step), else None.
        """
        delta = grad_output
        for layer in range(len(self.weights) - 1, -1, -1):
            if weights:
                torch.mm(delta.t(), activations[layer], out=self.grads[2 * layer])
                torch.sum(delta, 0, out=self.grads[2 * layer + 1])
            if layer > 0:
                delta = delta.mm(self.weights[layer])
                h = activations[layer]
                delta = delta - delta * h * h  # through tanh: delta (1 - h^2)
            elif input_columns is not None:
                return delta.mm(self.weights[0][:, input_columns])
        return None


class Adam:
    """Adam (Kingma and Ba 2015) on `ParameterVector`s: torch.optim.Adam(fused=True)'s kernel, called once on
    the whole vectors instead of through the optimiser's per-tensor bookkeeping.

    `state_dict` has torch.optim.Adam's per-tensor layout (a state per parameter, in order), so checkpoints
    read and write as they did with torch's optimiser, and `load_state_dict` takes either.
    """

    def __init__(self, vectors: Sequence[ParameterVector], lr: float, betas: tuple[float, float] = (0.9, 0.999),
                 eps: float = 1e-8):
        self.vectors, self.lr, self.betas, self.eps = list(vectors), lr, betas, eps
        self.exp_avg = [torch.zeros_like(v.data) for v in self.vectors]
        self.exp_avg_sq = [torch.zeros_like(v.data) for v in self.vectors]
        self.step_counts = [torch.zeros((), dtype=torch.float32, device=v.data.device) for v in self.vectors]
        """Steps taken, one float32 tensor per vector as the fused kernel wants them (all equal)."""

    @property
    def steps(self) -> int:
        """Adam steps taken."""
        return int(self.step_counts[0])

    @torch.no_grad()
    def step(self) -> None:
        """One Adam step of every vector along its `grad`."""
        torch._foreach_add_(self.step_counts, 1)
        torch._fused_adam_([v.data for v in self.vectors], [v.grad for v in self.vectors], self.exp_avg,
                           self.exp_avg_sq, [], self.step_counts, lr=self.lr, beta1=self.betas[0],
                           beta2=self.betas[1], weight_decay=0.0, eps=self.eps, amsgrad=False, maximize=False)

    def _views(self, moments: list[torch.Tensor]) -> list[torch.Tensor]:
        out = []
        for vector, moment in zip(self.vectors, moments, strict=True):
            offset = 0
            for p in vector.params:
                out.append(moment[offset:offset + p.numel()].view_as(p))
                offset += p.numel()
        return out

    def state_dict(self) -> dict:
        """torch.optim.Adam's state dict: per parameter index its step, exp_avg and exp_avg_sq (none before
        the first step), and one param group."""
        count = sum(len(v.params) for v in self.vectors)
        state = {}
        if self.steps:
            step = torch.tensor(float(self.steps), dtype=torch.float32)
            state = {k: {"step": step.clone(), "exp_avg": m.clone(), "exp_avg_sq": s.clone()}
                     for k, (m, s) in enumerate(zip(self._views(self.exp_avg), self._views(self.exp_avg_sq),
                                                    strict=True))}
        group = {"lr": self.lr, "betas": self.betas, "eps": self.eps, "weight_decay": 0.0, "amsgrad": False,
                 "params": list(range(count))}
        return {"state": state, "param_groups": [group]}

    @torch.no_grad()
    def load_state_dict(self, state_dict: Mapping) -> None:
        """Restores `state_dict` (ours or torch.optim.Adam's over the same parameters); ValueError if it does
        not fit. The learning rate and betas stay this optimiser's (they come from the config)."""
        state = state_dict["state"]
        count = sum(len(v.params) for v in self.vectors)
        if not state:
            for moment in (*self.exp_avg, *self.exp_avg_sq, *self.step_counts):
                moment.zero_()
            return
        if sorted(int(k) for k in state) != list(range(count)):
            raise ValueError(f"Adam state has entries {sorted(state)[:8]}..., this optimiser has {count} parameters")
        steps = {float(state[k]["step"]) for k in state}
        if len(steps) != 1:
            raise ValueError(f"Adam state has different step counts per parameter: {sorted(steps)[:4]}")
        for name, moments in (("exp_avg", self.exp_avg), ("exp_avg_sq", self.exp_avg_sq)):
            for k, view in enumerate(self._views(moments)):
                value = torch.as_tensor(state[k][name])
                if tuple(value.shape) != tuple(view.shape):
                    raise ValueError(f"Adam state {k}.{name} has shape {tuple(value.shape)}, the parameter "
                                     f"{tuple(view.shape)}")
                view.copy_(value)
        step = steps.pop()
        for counter in self.step_counts:
            counter.fill_(step)
