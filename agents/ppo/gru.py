"""The GRU of PPO's update: a GRU cell run over whole sequences with its backward pass through time written out.

A rollout steps `nn.GRUCell` one observation at a time, without gradients; the update replays each sequence from
the rollout's initial state, and there `gru_sequence` computes the same states in one autograd node. On a CPU it
makes the recurrent update about 2.2x faster than autograd through T cell calls (docs/runs/vector-bench/). It is
checked against `nn.GRUCell` under autograd, and against finite differences, in tests/agents/test_ppo.py.
"""

from __future__ import annotations

import torch
from torch import nn


class _GRUSequence(torch.autograd.Function):
    """A GRU cell run over a whole sequence, with the backward pass through time written out (not taped).

    The same recurrence as `nn.GRUCell` (Cho et al. 2014, as torch writes it), with the state zeroed where keep is 0:
        h'_t = keep_t h_{t-1},   g_t = W_hh h'_t + b_hh,   [r, z] = sigmoid(gi_t[:2H] + g_t[:2H]),
        n_t = tanh(gi_t[2H:] + r g_t[2H:]),   h_t = (h'_t - n_t) z + n_t,
    where gi_t = W_ih x_t + b_ih is computed for every step at once outside (one matrix product). The forward
    keeps each step's gates; the backward runs the recurrence in reverse with six or seven tensor operations a step
    and forms dW_hh and db_hh in one product over all steps. Autograd through T `GRUCell` calls records some twenty
    nodes a step, and on a CPU those per-node costs, not the arithmetic, were most of a recurrent PPO update (twice
    as slow at 128 units). Checked against `nn.GRUCell` under autograd in tests/agents/test_ppo.py.
    """

    @staticmethod
    def forward(ctx, gi: torch.Tensor, keep: torch.Tensor, h0: torch.Tensor, w_hh: torch.Tensor,
                b_hh: torch.Tensor) -> torch.Tensor:
        T, B, H = gi.shape[0], gi.shape[1], h0.shape[-1]
        outputs, diffs, n_all = (gi.new_empty(T, B, H) for _ in range(3))
        gates, hidden = gi.new_empty(T, B, 2 * H), gi.new_empty(T, B, 3 * H)
        zeroed = (keep == 0).flatten(1).any(1).tolist()  # steps where some env's state is zeroed
        w_t, h = w_hh.t().contiguous(), h0  # a contiguous W_hh^T: its products are a third faster than the view's
        steps = zip(zeroed, gi[..., : 2 * H].unbind(0), gi[..., 2 * H:].unbind(0), keep.unbind(0),
                    outputs.unbind(0), diffs.unbind(0), n_all.unbind(0), gates.unbind(0), hidden.unbind(0),
                    strict=True)
        for any_zeroed, gi_rz, gi_n, keep_t, out, diff, n, rz, gh in steps:
            hp = h * keep_t if any_zeroed else h
            torch.addmm(b_hh, hp, w_t, out=gh)
            torch.add(gh[:, : 2 * H], gi_rz, out=rz).sigmoid_()
            torch.addcmul(gi_n, gh[:, 2 * H:], rz[:, :H], out=n).tanh_()
            h = torch.addcmul(n, torch.sub(hp, n, out=diff), rz[:, H:], out=out)
        kept = torch.cat((h0[None], outputs[:-1])) * keep  # h'_t for every step
        z = gates[..., H:]
        # d[r, z] = [dn g_n, dh (h' - n)] sigmoid'; dn = dh (1 - z) tanh'
        gate_coef = torch.cat((hidden[..., 2 * H:], diffs), -1).mul_(gates * (1.0 - gates))
        ctx.zeroed = zeroed
        ctx.save_for_backward(keep, w_hh, kept, gates, gate_coef, (1.0 - z) * (1.0 - n_all * n_all))
        return outputs

    @staticmethod
    def backward(ctx, d_outputs: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        keep, w_hh, kept, gates, gate_coef, dn_coef = ctx.saved_tensors
        T, B, H = kept.shape
        d_hidden = d_outputs.new_empty(T, B, 3 * H)  # d g_t = d [r, z] (through the sigmoids), d g_t[2H:]
        carried = d_outputs.new_empty(T, B, 2 * H)  # [dn_t, dh_t]
        dh = d_outputs.new_zeros(B, H)
        for t in reversed(range(T)):
            dg, rz, dn_dh = d_hidden[t], gates[t], carried[t]
            dh = torch.add(dh, d_outputs[t], out=dn_dh[:, H:])
            dn = torch.mul(dh, dn_coef[t], out=dn_dh[:, :H])
            torch.mul(dn_dh, gate_coef[t], out=dg[:, : 2 * H])
            torch.mul(dn, rz[:, :H], out=dg[:, 2 * H:])
            dh = torch.addmm(dh * rz[:, H:], dg, w_hh)
            if ctx.zeroed[t]:
                dh = dh * keep[t]
        d_gi = torch.cat((d_hidden[..., : 2 * H], carried[..., :H]), -1) if ctx.needs_input_grad[0] else None
        flat = d_hidden.reshape(-1, 3 * H)
        d_w = flat.t() @ kept.reshape(-1, H) if ctx.needs_input_grad[3] else None
        d_b = flat.sum(0) if ctx.needs_input_grad[4] else None
        return d_gi, None, dh if ctx.needs_input_grad[2] else None, d_w, d_b


def gru_sequence(cell: nn.GRUCell, inputs: torch.Tensor, starts: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
    """The GRU cell's states (T, B, H) over inputs (T, B, F), from state (B, H), zeroed before each step where
    starts is 1: what T calls of `cell(inputs[t], state * (1 - starts[t]))` give, differentiated by `_GRUSequence`."""
    gi = nn.functional.linear(inputs, cell.weight_ih, cell.bias_ih)
    keep = (1.0 - starts).unsqueeze(-1)
    return _GRUSequence.apply(gi, keep, state, cell.weight_hh, cell.bias_hh)
