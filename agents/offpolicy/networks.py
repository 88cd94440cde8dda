"""Actor and critic MLPs of Sec. 4 (two tanh hidden layers of 256); their input normaliser is
`auv_mj.agents.normalizer.Normalizer`, shared with PPO.

The gradient steps of `auv_mj.agents.offpolicy.ddpg` and `auv_mj.agents.offpolicy.td3` are autograd's: their losses
are code and `loss.backward()` gives the gradients. Each network's parameters live in one `ParameterVector`, so that
`VectorAdam` (torch.optim.Adam(fused=True) on the vectors) and the soft target updates (Eq. 19) take one call
per network: at Table 4's sizes on a CPU, Adam on the six tensors of a network costs about three times its step
on one vector. The backward passes written out by hand that these steps used before (`DensePass`, until issue
29) were only 1.2x (DDPG) and 1.1-1.2x (TD3) faster than autograd with this optimiser (`auv-mj bench --sections
training` and alternating in-process timings), below the 1.3x that would have kept them. The modules' own
`forward` is unchanged, for policies and tests.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch
from torch import nn


def mlp(in_dim: int, hidden_sizes: Sequence[int], out_dim: int) -> nn.Sequential:
    """Fully connected layers with tanh activations after every hidden layer (Eq. 31, Sec. 4)."""
    layers: list[nn.Module] = []
    for width in hidden_sizes:
        layers += [nn.Linear(in_dim, width), nn.Tanh()]
        in_dim = width
    layers.append(nn.Linear(in_dim, out_dim))
    return nn.Sequential(*layers)


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


NEW_INPUT_MEAN, NEW_INPUT_STD = 0.5, 0.5
"""The normaliser's prior for inputs added to a trained network (`widen_inputs`): a feature in [0, 1]."""


def widen_inputs(state: Mapping[str, torch.Tensor], at: int, count: int) -> dict[str, torch.Tensor]:
    """The state dict of an actor, critic or `Normalizer` trained on inputs without `count` new ones inserted at
    index `at`, for the same module on the wider input: the first layer gets zero weights from the new inputs,
    so the widened network computes exactly what it did, and learns to use them from there (as a residual
    planner's zeroed head starts as its skeleton, Silver et al. 2018); a normaliser takes the new inputs' mean
    and std as NEW_INPUT_MEAN and NEW_INPUT_STD over the count it had seen (a prior that the data then moves)."""
    out = dict(state)
    if "count" in state:  # a Normalizer
        n = state["count"]
        values = {"sum": NEW_INPUT_MEAN * n, "sumsq": (NEW_INPUT_MEAN**2 + NEW_INPUT_STD**2) * n,
                  "mean": NEW_INPUT_MEAN, "std": NEW_INPUT_STD}
        for key, value in values.items():
            old = state[key]
            new = torch.full((count,), float(value), dtype=old.dtype, device=old.device)
            out[key] = torch.cat([old[:at], new, old[at:]])
        return out
    weight = state["net.0.weight"]
    zeros = torch.zeros(weight.shape[0], count, dtype=weight.dtype, device=weight.device)
    out["net.0.weight"] = torch.cat([weight[:, :at], zeros, weight[:, at:]], dim=1)
    return out


class ParameterVector:
    """The parameters of some modules as views into one flat leaf tensor `flat`, their gradients as views into
    `flat.grad`.

    At Table 4's sizes (2 x 256, batch 64) a call per tensor costs more than its arithmetic: Adam's step on the
    six tensors of a network costs three times its step on one vector. So the optimiser (`VectorAdam`) and the
    soft target update (Eq. 19) act on the one vector in one call each. The modules keep their `nn.Parameter`s
    (state dicts, `load_state_dict` and forward passes are unchanged); only their storage moves. Each
    parameter's `.grad` is its view of `grad`, and `loss.backward()` accumulates into an existing `.grad` in
    place (the gradient layout contract of `torch.autograd.backward`), so after it `grad` holds the whole
    gradient. Clear it with `zero_grad` (setting a `.grad` to None would cut it from `grad`). Build the vector
    after the modules are on their device: `.to()` would re-point the parameters.
    """

    def __init__(self, *modules: nn.Module):
        self.params = [p for module in modules for p in module.parameters()]
        trained = any(p.requires_grad for p in self.params)
        self.flat = nn.Parameter(torch.cat([p.detach().reshape(-1) for p in self.params]), requires_grad=trained)
        """The leaf tensor an optimiser steps."""
        self.data = self.flat.data
        """The parameters' values, one vector."""
        self.grad = torch.zeros_like(self.data) if trained else None
        """The parameters' gradients, one vector (None for a vector that is not trained: a target network)."""
        self.flat.grad = self.grad
        offset = 0
        for p in self.params:
            size = p.numel()
            p.data = self.data[offset:offset + size].view_as(p)
            if trained:
                p.grad = self.grad[offset:offset + size].view_as(p)
            offset += size

    def zero_grad(self) -> None:
        """Zeroes the gradient vector in place (every parameter's `.grad` stays its view of it)."""
        if self.grad is not None:
            self.grad.zero_()

    def split(self, vector: torch.Tensor) -> list[torch.Tensor]:
        """A vector laid out like `data` (an optimiser moment), as views shaped like the parameters."""
        sizes = [p.numel() for p in self.params]
        return [part.view_as(p) for part, p in zip(vector.split(sizes), self.params, strict=True)]


class VectorAdam(torch.optim.Adam):
    """torch.optim.Adam(fused=True) (Kingma and Ba 2015) stepping `ParameterVector`s, one tensor per vector.

    Its state dict has the per-parameter layout of torch.optim.Adam on the modules' own parameters (a state
    per parameter, in order, none before the first step), so checkpoints read and write as they did before
    the parameters moved into vectors. The state exists from the start (zero moments, step 0), so that the
    collectors (`auv_mj.agents.offpolicy.collector`) can copy it through shared memory before the first step.
    """

    def __init__(self, vectors: Sequence[ParameterVector], lr: float, betas: tuple[float, float] = (0.9, 0.999),
                 eps: float = 1e-8):
        self.vectors = list(vectors)
        super().__init__([v.flat for v in self.vectors], lr=lr, betas=betas, eps=eps, fused=True)
        for v in self.vectors:
            self.state[v.flat] = {"step": torch.zeros((), dtype=torch.float32, device=v.data.device),
                                  "exp_avg": torch.zeros_like(v.data), "exp_avg_sq": torch.zeros_like(v.data)}

    @property
    def steps(self) -> int:
        """Adam steps taken."""
        return int(self.state[self.vectors[0].flat]["step"])

    def moments(self, vector: ParameterVector) -> dict[str, torch.Tensor]:
        """The live state of `vector`: its step count and its first and second moments (exp_avg, exp_avg_sq)."""
        return self.state[vector.flat]

    def zero_grad(self, set_to_none: bool = False) -> None:
        """Zeroes the vectors' gradients in place; `set_to_none` is refused (it would cut the views)."""
        if set_to_none:
            raise ValueError("VectorAdam.zero_grad(set_to_none=True) would detach the parameters' gradient views")
        for v in self.vectors:
            v.zero_grad()

    def _parameter_count(self) -> int:
        return sum(len(v.params) for v in self.vectors)

    def state_dict(self) -> dict:
        """torch.optim.Adam's state dict over the modules' parameters: per parameter index its step, exp_avg
        and exp_avg_sq (none before the first step), and one param group."""
        state: dict[int, dict[str, torch.Tensor]] = {}
        if self.steps:
            for v in self.vectors:
                moments = self.moments(v)
                for exp_avg, exp_avg_sq in zip(v.split(moments["exp_avg"]), v.split(moments["exp_avg_sq"]),
                                               strict=True):
                    state[len(state)] = {"step": moments["step"].detach().clone().cpu(),
                                         "exp_avg": exp_avg.clone(), "exp_avg_sq": exp_avg_sq.clone()}
        group = {key: value for key, value in self.param_groups[0].items() if key != "params"}
        group["params"] = list(range(self._parameter_count()))
        return {"state": state, "param_groups": [group]}

    @torch.no_grad()
    def load_state_dict(self, state_dict: Mapping) -> None:
        """Restores `state_dict` (ours, or torch.optim.Adam's over the same parameters, as in checkpoints
        written before `VectorAdam`); ValueError if it does not fit. The learning rate and betas stay this
        optimiser's (they come from the config)."""
        state = state_dict["state"]
        count = self._parameter_count()
        if not state:
            for v in self.vectors:
                for value in self.moments(v).values():
                    value.zero_()
            return
        if sorted(int(k) for k in state) != list(range(count)):
            raise ValueError(f"Adam state has entries {sorted(state)[:8]}..., this optimiser has {count} parameters")
        steps = {float(state[k]["step"]) for k in state}
        if len(steps) != 1:
            raise ValueError(f"Adam state has different step counts per parameter: {sorted(steps)[:4]}")
        step, index = steps.pop(), 0
        for v in self.vectors:
            moments = self.moments(v)
            views = {name: v.split(moments[name]) for name in ("exp_avg", "exp_avg_sq")}
            for k in range(index, index + len(v.params)):
                for name, parts in views.items():
                    value, view = torch.as_tensor(state[k][name]), parts[k - index]
                    if tuple(value.shape) != tuple(view.shape):
                        raise ValueError(f"Adam state {k}.{name} has shape {tuple(value.shape)}, the parameter "
                                         f"{tuple(view.shape)}")
                    view.copy_(value)
            index += len(v.params)
            moments["step"].fill_(step)
