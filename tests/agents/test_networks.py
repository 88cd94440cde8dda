"""The gradient steps of auv_mj.agents.offpolicy.ddpg and auv_mj.agents.offpolicy.td3 (autograd's) against the numbers
of the hand-written code before them and against torch.optim.Adam on plain modules.

`ParameterVector` moves each network's parameters into one vector and `VectorAdam` is torch.optim.Adam(fused=True)
on those vectors.

tests/data/autograd_reference_d7f506e.npz and tests/data/adam_state_d7f506e.pt were written at commit d7f506e,
before the gradient steps went through autograd (they were then the hand-written passes and a private-call
Adam), by the steps the tests below repeat: `reference_steps` (DDPG and TD3 agents of the sizes and seeds
there, updated on `random_batch` batches of the seeds there, their flat parameters and gradient vectors after
the first and the third step) and, for the checkpoint, DDPG(6, 2, hidden (16, 16), batch 8, tau 0.05, seed 7)
after `update_many(random_batch(24, 6, 2, seed=20), 3)`, saved by `save_agent`, loaded by `load_agent`,
then `update_many(random_batch(16, 6, 2, seed=21), 2)`: the `resumed_*` arrays.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from auv_mj.agents.checkpoint import OFFPOLICY_FORMAT as CHECKPOINT_FORMAT
from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig, actor_loss, critic_loss, soft_update, td_target
from auv_mj.agents.offpolicy.learners import agent_tensors, load_agent, save_agent
from auv_mj.agents.offpolicy.networks import Critic, ParameterVector, VectorAdam, mlp
from auv_mj.agents.offpolicy.replay import Batch
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config, smoothed_target_action, twin_td_target

torch.set_num_threads(1)

DATA = Path(__file__).parents[1] / "data"
REFERENCE = DATA / "autograd_reference_d7f506e.npz"
OLD_CHECKPOINT = DATA / "adam_state_d7f506e.pt"
SHIPPED = sorted(p for p in (Path(__file__).parents[2] / "agents" / "checkpoints").glob("*.pt")
                 if torch.load(p, weights_only=True)["metadata"].get("format") == CHECKPOINT_FORMAT)
"""The shipped DDPG and TD3 checkpoints (the PPO planner's is another format, tested in test_planner_memory)."""
FLOAT32 = {"rtol": 1e-5, "atol": 1e-6}
"""float32 rounding: autograd and the hand-written passes summed the same products in different orders."""
CONFIG = DDPGConfig(hidden_sizes=(32, 24), batch_size=16, tau=0.05, seed=4)


def random_batch(n: int, obs_dim: int, act_dim: int, seed: int = 0) -> Batch:
    rng = np.random.default_rng(seed)
    return Batch(rng.normal(size=(n, obs_dim)).astype(np.float32), rng.uniform(-1, 1, (n, act_dim)).astype(np.float32),
                 rng.normal(size=n).astype(np.float32), rng.normal(size=(n, obs_dim)).astype(np.float32),
                 (rng.random(n) < 0.3).astype(np.float32))


def flat(module: torch.nn.Module) -> torch.Tensor:
    return torch.cat([p.detach().reshape(-1) for p in module.parameters()])


def grads(module: torch.nn.Module) -> torch.Tensor:
    return torch.cat([p.grad.reshape(-1) for p in module.parameters()])


def reference_steps() -> dict[str, np.ndarray]:
    """The arrays of REFERENCE, recomputed (the steps the module docstring names)."""
    out: dict[str, np.ndarray] = {}

    def record(prefix: str, agent: DDPG, names: tuple[str, ...], grad_names: tuple[str, ...] = ()) -> None:
        out.update({f"{prefix}_{n}": flat(getattr(agent, n)).numpy().copy() for n in names})
        out.update({f"{prefix}_{n}_grad": agent.vectors[n].grad.numpy().copy() for n in grad_names})

    agent = DDPG(6, 2, dataclasses.replace(CONFIG, action_l2=0.7))
    record("ddpg_init", agent, ("actor", "critic"))
    for step in range(3):
        agent.update(random_batch(16, 6, 2, seed=step))
        if step == 0:
            record("ddpg_step1", agent, ("actor", "critic", "actor_target", "critic_target"), ("critic", "actor"))
    record("ddpg_step3", agent, ("actor", "critic", "actor_target", "critic_target"), ("critic", "actor"))

    agent = TD3(5, 2, TD3Config(hidden_sizes=(32, 24), batch_size=16, tau=0.05, seed=2))
    record("td3_init", agent, ("actor", "critic", "critic2"))
    torch.manual_seed(9)  # the smoothing noise
    for step in range(3):  # policy_delay 2: the actor and the targets move at step 2
        agent.update(random_batch(16, 5, 2, seed=10 + step))
        if step == 0:
            record("td3_step1", agent, ("critic", "critic2", "critic_target", "critic2_target"), ("critic", "critic2"))
    record("td3_step3", agent, ("actor", "critic", "critic2", "actor_target", "critic_target", "critic2_target"))
    return out


def test_gradient_steps_reproduce_the_hand_written_path_of_d7f506e():
    with np.load(REFERENCE) as data:
        want = {k: data[k] for k in data.files if not k.startswith("resumed_")}
    got = reference_steps()
    assert sorted(got) == sorted(want)
    for key in sorted(want):
        rounding = {"rtol": 0, "atol": 0} if "_init_" in key else FLOAT32  # the same initial weights
        np.testing.assert_allclose(got[key], want[key], **rounding, err_msg=key)
    # The steps moved the networks well beyond rounding, so the comparison above has something to compare.
    assert np.abs(want["ddpg_step3_critic"] - want["ddpg_init_critic"]).max() > 1e-3
    assert np.abs(want["td3_step3_actor"] - want["td3_init_actor"]).max() > 1e-3


def test_a_checkpoint_with_the_adam_state_of_d7f506e_resumes():
    saved, _ = read_checkpoint(OLD_CHECKPOINT)
    agent, _ = load_agent(OLD_CHECKPOINT)
    assert agent.actor_opt.steps == agent.critic_opt.steps == 3
    # The per-parameter Adam state of the file is what the vectors' optimisers hold and write back.
    optimiser_state = {k: v for k, v in agent_tensors(agent).items() if "_opt.state." in k}
    assert sorted(optimiser_state) == sorted(k for k in saved if "_opt.state." in k)
    for key, value in optimiser_state.items():
        torch.testing.assert_close(value, saved[key], rtol=0, atol=0, msg=key)
    agent.update_many(random_batch(16, 6, 2, seed=21), 2)
    with np.load(REFERENCE) as data:
        for name in ("actor", "critic", "actor_target", "critic_target"):
            np.testing.assert_allclose(flat(getattr(agent, name)).numpy(), data[f"resumed_{name}"], **FLOAT32,
                                       err_msg=name)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_checkpoints_load_with_their_adam_state(path):
    saved, meta = read_checkpoint(path)
    agent, _ = load_agent(path)
    tensors = agent_tensors(agent)
    for key, value in saved.items():
        if key != "torch_rng":
            torch.testing.assert_close(tensors[key], value, rtol=0, atol=0, msg=key)
    assert agent.actor_opt.steps == int(saved["actor_opt.state.0.step"]) > 0
    assert agent.num_updates == meta["num_updates"]


def test_parameter_vector_shares_the_module_storage_and_gathers_autograd_gradients():
    torch.manual_seed(2)
    net = mlp(3, (4,), 2)
    reference = copy.deepcopy(net)
    vector = ParameterVector(net)
    x = torch.randn(5, 3)
    for _ in range(2):  # accumulates, as autograd does into .grad
        net(x).square().sum().backward()
        reference(x).square().sum().backward()
    torch.testing.assert_close(vector.grad, grads(reference))
    vector.zero_grad()
    assert not vector.grad.any() and all(not p.grad.any() for p in net.parameters())
    with torch.no_grad():
        vector.data.fill_(0.5)
    assert all(bool((p == 0.5).all()) for p in net.parameters())
    net.load_state_dict({k: torch.full_like(v, -1.0) for k, v in net.state_dict().items()})
    assert bool((vector.data == -1.0).all())  # load_state_dict copies into the vector's storage
    assert vector.data.numel() == sum(p.numel() for p in net.parameters())
    target = ParameterVector(copy.deepcopy(net).requires_grad_(False))
    assert target.grad is None and not target.flat.requires_grad


def test_vector_adam_is_torch_adam_and_keeps_its_per_parameter_state_layout():
    torch.manual_seed(1)
    nets = [mlp(3, (5,), 2), mlp(2, (4,), 1)]
    reference = copy.deepcopy(nets)
    vectors = [ParameterVector(net) for net in nets]
    ours = VectorAdam(vectors, lr=3e-3)
    assert ours.state_dict()["state"] == {}  # none before the first step, as torch.optim.Adam
    params = [p for net in reference for p in net.parameters()]
    theirs = torch.optim.Adam(params, lr=3e-3)  # the default, per-tensor implementation
    for _ in range(5):
        gradients = [torch.randn_like(p) for p in params]
        for p, g in zip(params, gradients, strict=True):
            p.grad = g.clone()
        for p, g in zip([p for net in nets for p in net.parameters()], gradients, strict=True):
            p.grad.copy_(g)  # the vectors' gradient views
        ours.step()
        theirs.step()
    for net, ref in zip(nets, reference, strict=True):
        torch.testing.assert_close(flat(net), flat(ref), **FLOAT32)
    state, torch_state = ours.state_dict(), theirs.state_dict()
    assert sorted(state["state"]) == sorted(torch_state["state"]) == list(range(8))
    assert state["param_groups"][0]["params"] == list(range(8)) and state["param_groups"][0]["lr"] == 3e-3
    for k, entry in torch_state["state"].items():
        for name in ("exp_avg", "exp_avg_sq", "step"):
            torch.testing.assert_close(state["state"][k][name], entry[name], **FLOAT32)
    fresh = VectorAdam([ParameterVector(copy.deepcopy(net)) for net in nets], lr=3e-3)
    fresh.load_state_dict(torch_state)  # torch's own state dict loads
    assert fresh.steps == 5
    for a, b in zip(fresh.vectors, ours.vectors, strict=True):
        for name in ("exp_avg", "exp_avg_sq", "step"):
            torch.testing.assert_close(fresh.moments(a)[name], ours.moments(b)[name], **FLOAT32)
    fresh.load_state_dict({"state": {}})  # an optimiser that never stepped
    assert fresh.steps == 0 and not fresh.moments(fresh.vectors[1])["exp_avg_sq"].any()
    bad = copy.deepcopy(torch_state)
    bad["state"][3]["exp_avg"] = torch.zeros(7)
    with pytest.raises(ValueError, match="Adam state 3.exp_avg has shape"):
        fresh.load_state_dict(bad)
    bad["state"][3]["exp_avg"] = torch_state["state"][3]["exp_avg"]
    bad["state"][3]["step"] = torch.tensor(4.0)
    with pytest.raises(ValueError, match="different step counts per parameter"):
        fresh.load_state_dict(bad)
    bad["state"].pop(3)
    with pytest.raises(ValueError, match="this optimiser has 8 parameters"):
        fresh.load_state_dict(bad)
    with pytest.raises(ValueError, match="set_to_none=True"):
        ours.zero_grad(set_to_none=True)


@pytest.mark.parametrize("action_l2", [0.0, 0.7])
def test_ddpg_steps_equal_torch_adam_on_plain_modules(action_l2):
    config = dataclasses.replace(CONFIG, action_l2=action_l2)
    agent = DDPG(6, 2, config)
    data = agent._to_tensors(random_batch(16, 6, 2))
    obs, next_obs = data.obs, data.next_obs
    nets = {name: copy.deepcopy(getattr(agent, name)) for name in ("actor", "critic", "actor_target", "critic_target")}
    target = td_target(nets["critic_target"], nets["actor_target"], data.rewards, next_obs, data.terminated,
                       config.gamma)
    optimizer = torch.optim.Adam(nets["critic"].parameters(), lr=config.critic_lr)
    want_loss = critic_loss(nets["critic"], obs, data.actions, target)
    want_loss.backward()
    optimizer.step()
    soft_update(nets["critic_target"], nets["critic"], config.tau)
    loss, _ = agent.critic_step(obs, data, next_obs)
    torch.testing.assert_close(loss, want_loss.detach())  # the loss before the step
    # The gradient itself (Adam would hide a wrong scale), then the step.
    torch.testing.assert_close(agent.vectors["critic"].grad, grads(nets["critic"]))
    for name in ("critic", "critic_target"):
        torch.testing.assert_close(flat(getattr(agent, name)), flat(nets[name]), **FLOAT32)

    critic = nets["critic"].requires_grad_(False)
    optimizer = torch.optim.Adam(nets["actor"].parameters(), lr=config.actor_lr)
    want_loss = actor_loss(nets["actor"], critic, obs, action_l2)
    want_loss.backward()
    optimizer.step()
    soft_update(nets["actor_target"], nets["actor"], config.tau)
    critic_before = flat(agent.critic).clone()
    loss = agent.actor_step(obs)
    torch.testing.assert_close(loss, want_loss.detach())
    torch.testing.assert_close(agent.vectors["actor"].grad, grads(nets["actor"]))
    for name in ("actor", "actor_target"):
        torch.testing.assert_close(flat(getattr(agent, name)), flat(nets[name]), **FLOAT32)
    torch.testing.assert_close(flat(agent.critic), critic_before, rtol=0, atol=0)  # the critic does not move


def test_td3_critic_step_equals_torch_adam_on_both_critics():
    config = TD3Config(hidden_sizes=(32, 24), batch_size=16, tau=0.05, seed=2)
    agent = TD3(5, 2, config)
    data = agent._to_tensors(random_batch(16, 5, 2, seed=3))
    critics = [copy.deepcopy(agent.critic), copy.deepcopy(agent.critic2)]
    targets = (copy.deepcopy(agent.critic_target), copy.deepcopy(agent.critic2_target))
    torch.manual_seed(9)
    next_actions = smoothed_target_action(agent.actor_target, data.next_obs, config.target_noise, config.noise_clip)
    target = twin_td_target(targets, data.next_obs, next_actions, data.rewards, data.terminated, config.gamma)
    optimizer = torch.optim.Adam([p for c in critics for p in c.parameters()], lr=config.critic_lr)
    want_loss = sum(critic_loss(c, data.obs, data.actions, target) for c in critics)
    want_loss.backward()
    optimizer.step()
    torch.manual_seed(9)  # the same smoothing noise
    loss, _ = agent.critic_step(data.obs, data, data.next_obs)
    torch.testing.assert_close(loss, want_loss.detach())
    for name, reference in zip(("critic", "critic2"), critics, strict=True):
        torch.testing.assert_close(agent.vectors[name].grad, grads(reference))
        torch.testing.assert_close(flat(getattr(agent, name)), flat(reference), **FLOAT32)


def test_checkpoint_round_trips_the_vectors_and_resumes_their_steps(tmp_path):
    agent = DDPG(6, 2, CONFIG)
    batch = random_batch(32, 6, 2, seed=5)
    agent.update_many(batch, 2)
    save_agent(tmp_path / "a.pt", agent, {"agent": "ddpg", "spec": {
        "kind": "box", "obs_dim": 6, "act_dim": 2, "obs_shape": [6], "action_low": [-1, -1], "action_high": [1, 1]}})
    loaded, _ = load_agent(tmp_path / "a.pt")
    assert loaded.actor_opt.steps == loaded.critic_opt.steps == 2
    agent.update_many(batch, 2)
    loaded.update_many(batch, 2)
    for name in ("actor", "critic", "actor_target", "critic_target"):
        torch.testing.assert_close(flat(getattr(agent, name)), flat(getattr(loaded, name)), rtol=0, atol=0)
    # The loaded agent's optimisers move the loaded modules (they see the loaded storage).
    assert isinstance(loaded.critic, Critic)
    assert loaded.critic_opt.param_groups[0]["params"][0].data_ptr() == loaded.critic.net[0].weight.data_ptr()


def test_agents_call_no_private_torch_functions():
    sources = sorted((Path(__file__).parents[2] / "agents").glob("*.py"))
    assert sources
    for source in sources:
        for number, line in enumerate(source.read_text().splitlines(), 1):
            assert "torch._" not in line, f"{source.name}:{number} calls a private torch function: {line.strip()}"
