"""The fast gradient path of agents.networks against autograd and torch.optim.Adam, taken as the reference.

`DensePass` writes the backward pass of the tanh MLPs of Sec. 4 by hand, `ParameterVector` moves the
parameters into one vector and `Adam` steps that vector with torch's fused kernel. Each is checked against
what PyTorch computes on a separate copy of the same networks: autograd's gradients of the losses of
`agents.ddpg` (Eq. 16-18) and torch.optim.Adam's step.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
import torch

from agents.checkpoint import load_agent, save_checkpoint
from agents.ddpg import DDPG, DDPGConfig, actor_loss, critic_loss, soft_update, td_target
from agents.networks import Adam, Critic, DensePass, ParameterVector, mlp
from agents.replay import Batch
from agents.td3 import TD3, TD3Config, smoothed_target_action, twin_td_target

torch.set_num_threads(1)

CONFIG = DDPGConfig(hidden_sizes=(32, 24), batch_size=16, tau=0.05, seed=4)
ROUNDING = {"rtol": 4e-7, "atol": 1e-8}
"""A few float32 ulps: the fused kernel takes vectorised or scalar paths by an element's position in its
tensor, so one vector and many tensors round some elements differently."""


def random_batch(n: int, obs_dim: int, act_dim: int, seed: int = 0) -> Batch:
    rng = np.random.default_rng(seed)
    return Batch(rng.normal(size=(n, obs_dim)).astype(np.float32), rng.uniform(-1, 1, (n, act_dim)).astype(np.float32),
                 rng.normal(size=n).astype(np.float32), rng.normal(size=(n, obs_dim)).astype(np.float32),
                 (rng.random(n) < 0.3).astype(np.float32))


def flat(module: torch.nn.Module) -> torch.Tensor:
    return torch.cat([p.detach().reshape(-1) for p in module.parameters()])


def grads(module: torch.nn.Module) -> torch.Tensor:
    return torch.cat([p.grad.reshape(-1) for p in module.parameters()])


@pytest.mark.parametrize("sizes", [(5, (7,), 3), (6, (16, 8), 1), (4, (9, 9, 9), 2)])
def test_dense_pass_matches_the_module_and_autograd(sizes):
    torch.manual_seed(0)
    n_in, hidden, n_out = sizes
    net = mlp(n_in, hidden, n_out)
    reference = copy.deepcopy(net)
    vector = ParameterVector(net)
    dense = DensePass(net, vector.grads)
    x = torch.randn(11, n_in, requires_grad=True)
    activations = dense.forward(x.detach())
    torch.testing.assert_close(activations[-1], reference(x), rtol=0, atol=0)  # the same addmm calls
    upstream = torch.randn(11, n_out)
    (reference(x) * upstream).sum().backward()
    columns = slice(n_in - 2, None)
    grad_x = dense.backward(activations, upstream, input_columns=columns)
    torch.testing.assert_close(grad_x, x.grad[:, columns])
    for p, grad in zip(reference.parameters(), vector.grads, strict=True):
        torch.testing.assert_close(grad, p.grad)
    assert dense.backward(activations, upstream, weights=False) is None


def test_parameter_vector_shares_the_module_storage():
    net = mlp(3, (4,), 2)
    vector = ParameterVector(net)
    with torch.no_grad():
        vector.data.fill_(0.5)
    assert all(bool((p == 0.5).all()) for p in net.parameters())
    net.load_state_dict({k: torch.full_like(v, -1.0) for k, v in net.state_dict().items()})
    assert bool((vector.data == -1.0).all())  # load_state_dict copies into the vector's storage
    assert vector.data.numel() == sum(p.numel() for p in net.parameters())


def test_adam_is_torch_fused_adam_and_keeps_its_state_layout():
    torch.manual_seed(1)
    nets = [mlp(3, (5,), 2), mlp(2, (4,), 1)]
    reference = copy.deepcopy(nets)
    vectors = [ParameterVector(net) for net in nets]
    ours = Adam(vectors, lr=3e-3)
    theirs = torch.optim.Adam([p for net in reference for p in net.parameters()], lr=3e-3, fused=True)
    for _ in range(5):
        grads = [torch.randn_like(p) for net in reference for p in net.parameters()]
        for p, g in zip([p for net in reference for p in net.parameters()], grads, strict=True):
            p.grad = g.clone()
        for view, g in zip([v for vector in vectors for v in vector.grads], grads, strict=True):
            view.copy_(g)
        ours.step()
        theirs.step()
    for net, ref in zip(nets, reference, strict=True):
        torch.testing.assert_close(flat(net), flat(ref), **ROUNDING)
    state, torch_state = ours.state_dict(), theirs.state_dict()
    assert sorted(state["state"]) == sorted(torch_state["state"]) == list(range(8))
    for k, entry in torch_state["state"].items():
        for name in ("exp_avg", "exp_avg_sq", "step"):
            torch.testing.assert_close(state["state"][k][name], entry[name], **ROUNDING)
    fresh = Adam([ParameterVector(copy.deepcopy(net)) for net in nets], lr=3e-3)
    fresh.load_state_dict(torch_state)  # torch's own state dict loads
    assert fresh.steps == 5
    for a, b in zip(fresh.exp_avg_sq, ours.exp_avg_sq, strict=True):
        torch.testing.assert_close(a, b, **ROUNDING)
    bad = copy.deepcopy(torch_state)
    bad["state"][3]["exp_avg"] = torch.zeros(7)
    with pytest.raises(ValueError, match="Adam state 3.exp_avg has shape"):
        fresh.load_state_dict(bad)
    bad["state"].pop(3)
    with pytest.raises(ValueError, match="this optimiser has 8 parameters"):
        fresh.load_state_dict(bad)


def reference_critic_step(agent: DDPG, obs, batch, next_obs) -> dict[str, torch.nn.Module]:
    """The critic step by autograd and torch.optim.Adam(fused=True) on copies of `agent`'s networks."""
    nets = {name: copy.deepcopy(getattr(agent, name)) for name in ("actor", "critic", "actor_target", "critic_target")}
    target = td_target(nets["critic_target"], nets["actor_target"], batch.rewards, next_obs, batch.terminated,
                       agent.config.gamma)
    optimizer = torch.optim.Adam(nets["critic"].parameters(), lr=agent.config.critic_lr, fused=True)
    critic_loss(nets["critic"], obs, batch.actions, target).backward()
    optimizer.step()
    soft_update(nets["critic_target"], nets["critic"], agent.config.tau)
    return nets


@pytest.mark.parametrize("action_l2", [0.0, 0.7])
def test_ddpg_steps_equal_autograd_and_torch_adam(action_l2):
    config = dataclasses.replace(CONFIG, action_l2=action_l2)
    agent = DDPG(6, 2, config)
    data = agent._to_tensors(random_batch(16, 6, 2))
    obs, next_obs = data.obs, data.next_obs
    expected = reference_critic_step(agent, obs, data, next_obs)
    loss, _ = agent.critic_step(obs, data, next_obs)
    # The gradient itself (Adam would hide a wrong scale), then the step.
    torch.testing.assert_close(agent.vectors["critic"].grad, grads(expected["critic"]))
    for name in ("critic", "critic_target"):
        torch.testing.assert_close(flat(getattr(agent, name)), flat(expected[name]))
    want_loss = critic_loss(expected["critic"], obs, data.actions, td_target(
        expected["critic_target"], expected["actor_target"], data.rewards, next_obs, data.terminated, config.gamma))
    assert loss.item() != pytest.approx(want_loss.item())  # the returned loss is the one before the step

    actor, actor_target = copy.deepcopy(agent.actor), copy.deepcopy(agent.actor_target)
    critic = copy.deepcopy(agent.critic).requires_grad_(False)
    optimizer = torch.optim.Adam(actor.parameters(), lr=config.actor_lr, fused=True)
    reference_loss = actor_loss(actor, critic, obs, action_l2)
    reference_loss.backward()
    optimizer.step()
    soft_update(actor_target, actor, config.tau)
    loss = agent.actor_step(obs)
    torch.testing.assert_close(loss, reference_loss.detach())
    torch.testing.assert_close(agent.vectors["actor"].grad, grads(actor))
    torch.testing.assert_close(flat(agent.actor), flat(actor))
    torch.testing.assert_close(flat(agent.actor_target), flat(actor_target))
    torch.testing.assert_close(flat(agent.critic), flat(critic), rtol=0, atol=0)  # the critic does not move


def test_td3_critic_step_equals_autograd_on_both_critics():
    config = TD3Config(hidden_sizes=(32, 24), batch_size=16, tau=0.05, seed=2)
    agent = TD3(5, 2, config)
    data = agent._to_tensors(random_batch(16, 5, 2, seed=3))
    critics = [copy.deepcopy(agent.critic), copy.deepcopy(agent.critic2)]
    targets = (copy.deepcopy(agent.critic_target), copy.deepcopy(agent.critic2_target))
    torch.manual_seed(9)
    next_actions = smoothed_target_action(agent.actor_target, data.next_obs, config.target_noise, config.noise_clip)
    target = twin_td_target(targets, data.next_obs, next_actions, data.rewards, data.terminated, config.gamma)
    optimizer = torch.optim.Adam([p for c in critics for p in c.parameters()], lr=config.critic_lr, fused=True)
    sum(critic_loss(c, data.obs, data.actions, target) for c in critics).backward()
    optimizer.step()
    torch.manual_seed(9)  # the same smoothing noise
    agent.critic_step(data.obs, data, data.next_obs)
    torch.testing.assert_close(agent.vectors["critic"].grad, grads(critics[0]))
    torch.testing.assert_close(agent.vectors["critic2"].grad, grads(critics[1]))
    torch.testing.assert_close(flat(agent.critic), flat(critics[0]))
    torch.testing.assert_close(flat(agent.critic2), flat(critics[1]))


def test_checkpoint_round_trips_the_vectors_and_resumes_their_steps(tmp_path):
    agent = DDPG(6, 2, CONFIG)
    batch = random_batch(32, 6, 2, seed=5)
    agent.update_many(batch, 2)
    save_checkpoint(tmp_path / "a.pt", agent, {"agent": "ddpg", "spec": {
        "kind": "box", "obs_dim": 6, "act_dim": 2, "obs_shape": [6], "action_low": [-1, -1], "action_high": [1, 1]}})
    loaded, _ = load_agent(tmp_path / "a.pt")
    assert loaded.actor_opt.steps == loaded.critic_opt.steps == 2
    for a, b in ((agent, loaded),):
        a.update_many(batch, 2)
        b.update_many(batch, 2)
        for name in ("actor", "critic", "actor_target", "critic_target"):
            torch.testing.assert_close(flat(getattr(a, name)), flat(getattr(b, name)), rtol=0, atol=0)
    # The loaded agent's fast path moves the loaded modules (its passes see the loaded storage).
    assert isinstance(loaded.critic, Critic)
    assert loaded.critic_pass.weights[0].data_ptr() == loaded.critic.net[0].weight.data_ptr()
