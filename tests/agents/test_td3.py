"""TD3 (agents/offpolicy/td3.py): twin-critic target, delayed actor, clipped target smoothing, and it learns.

The update pieces are checked against hand-built networks whose outputs are known in closed form; the
learning test is a one-step regression bandit whose optimal policy a*(x) = 0.6 x is known exactly.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium import spaces

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy import Policy
from auv_mj.agents.offpolicy.ddpg import DDPGConfig
from auv_mj.agents.offpolicy.learners import load_agent
from auv_mj.agents.offpolicy.replay import Batch
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config, smoothed_target_action, twin_td_target
from auv_mj.agents.offpolicy.train import train
from auv_mj.cli.train import config_overrides

torch.set_num_threads(1)

SMALL = TD3Config(hidden_sizes=(32, 32), batch_size=16, learning_starts=32, buffer_size=2000, epsilon_decay=50)


def constant_critic(critic: torch.nn.Module, value: float) -> None:
    """Makes `critic` output `value` for every input: zero last-layer weights, bias `value`."""
    last = critic.net[-1]
    with torch.no_grad():
        last.weight.zero_()
        last.bias.fill_(value)


def batch(n: int = 16, obs_dim: int = 3, act_dim: int = 2, seed: int = 0) -> Batch:
    rng = np.random.default_rng(seed)
    return Batch(rng.normal(size=(n, obs_dim)).astype(np.float32), rng.uniform(-1, 1, (n, act_dim)).astype(np.float32),
                 rng.normal(size=n).astype(np.float32), rng.normal(size=(n, obs_dim)).astype(np.float32),
                 (rng.random(n) < 0.3).astype(np.float32))


@pytest.mark.parametrize("q1, q2", [(1.0, 3.0), (3.0, -2.0)])
def test_twin_critic_target_takes_the_minimum(q1, q2):
    agent = TD3(3, 2, SMALL)
    constant_critic(agent.critic_target, q1)
    constant_critic(agent.critic2_target, q2)
    data = agent._to_tensors(batch())
    obs = agent.obs_norm(data.next_obs)
    target = twin_td_target((agent.critic_target, agent.critic2_target), obs, agent.actor_target(obs),
                            data.rewards, data.terminated, 0.9)
    expected = data.rewards + 0.9 * (1 - data.terminated) * min(q1, q2)
    torch.testing.assert_close(target.squeeze(), expected.squeeze())
    # and the agent's critic step learns towards exactly that target
    _, mean_target = agent.critic_step(agent.obs_norm(data.obs), data, obs)
    assert mean_target.item() == pytest.approx(expected.mean().item(), abs=1e-6)


def parameters(module: torch.nn.Module) -> torch.Tensor:
    return torch.cat([p.detach().flatten() for p in module.parameters()]).clone()


def test_actor_and_targets_update_at_the_stated_delay():
    agent = TD3(3, 2, TD3Config(hidden_sizes=(32, 32), batch_size=16, policy_delay=3))
    data = batch()
    moved = {"actor": [], "actor_target": [], "critic_target": [], "critic": [], "critic2": []}
    for _ in range(7):
        before = {name: parameters(getattr(agent, name)) for name in moved}
        agent.update(data)
        for name in moved:
            moved[name].append(not torch.equal(before[name], parameters(getattr(agent, name))))
    delayed = [False, False, True, False, False, True, False]  # after critic steps 3 and 6
    assert moved["actor"] == delayed and moved["actor_target"] == delayed and moved["critic_target"] == delayed
    assert all(moved["critic"]) and all(moved["critic2"])
    assert agent.num_updates == 7 and agent.actor_updates == 2


def test_target_policy_noise_is_clipped():
    agent = TD3(3, 2, SMALL)
    obs = torch.randn(4096, 3)
    clean = agent.actor_target(obs).detach()
    torch.manual_seed(1)
    noisy = smoothed_target_action(agent.actor_target, obs, target_noise=50.0, noise_clip=0.05)
    shift = noisy - clean.clamp(-1, 1)
    assert shift.abs().max().item() <= 0.05 + 1e-6  # noise of std 50 is cut to +-0.05
    assert (shift.abs() > 0.049).float().mean().item() > 0.5  # ... and it is there, mostly at the clip
    assert noisy.abs().max().item() <= 1.0
    # a target action at the bound stays inside [-1, 1]
    with torch.no_grad():
        agent.actor_target.net[-1].bias.fill_(50.0)
    edge = smoothed_target_action(agent.actor_target, obs, target_noise=1.0, noise_clip=0.5)
    assert edge.max().item() <= 1.0 and edge.min().item() >= 0.5 - 1e-6
    torch.testing.assert_close(smoothed_target_action(agent.actor_target, obs, 0.0, 0.5),
                               agent.actor_target(obs).clamp(-1, 1))


def test_config_refuses_bad_td3_fields():
    for field, value, message in (("policy_delay", 0, "policy_delay must be a whole number in \\[1, 1000\\]"),
                                  ("policy_delay", 1.5, "policy_delay"),
                                  ("target_noise", -0.1, "target_noise must be a number in \\[0, 10\\]"),
                                  ("noise_clip", float("nan"), "noise_clip")):
        with pytest.raises(ValueError, match=message):
            TD3Config(**{field: value})
    with pytest.raises(ValueError, match="TD3 needs a TD3Config"):
        TD3(3, 2, DDPGConfig())
    args = argparse.Namespace(agent="ddpg", policy_delay=3)
    with pytest.raises(ValueError, match="--policy-delay is a td3 option; agent ddpg"):
        config_overrides(args)


class GainBandit(gym.Env):
    """One-step task: observe x ~ U(-1, 1), act a, earn -(a - GAIN x)^2; the best policy is a = GAIN x."""

    GAIN = 0.6

    def __init__(self):
        self.observation_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(-1, 1, 1).astype(np.float32)
        return self.x.copy(), {}

    def step(self, action):
        reward = -float((np.clip(action, -1, 1)[0] - self.GAIN * self.x[0]) ** 2)
        return self.x.copy(), reward, True, False, {"is_success": reward > -0.01}


def test_td3_learns_a_small_task_within_a_few_thousand_steps(tmp_path):
    config = TD3Config(hidden_sizes=(64, 64), learning_starts=200, epsilon_decay=300, batch_size=64, seed=4)
    result = train(GainBandit, "td3", config, total_steps=2500, run_dir=tmp_path / "run", progress=False,
                   tensorboard=False)
    policy = Policy.load(result.checkpoint)
    x = np.linspace(-1, 1, 41, dtype=np.float32)[:, None]
    error = np.abs(policy(x)[:, 0] - GainBandit.GAIN * x[:, 0])
    assert error.mean() < 0.05, error.mean()
    # the checkpoint is a TD3 one: both critics come back, and a resumed run continues it
    agent, meta = load_agent(result.checkpoint)
    assert isinstance(agent, TD3) and meta["agent"] == "td3" and agent.num_updates == result.gradient_steps
    tensors, _ = read_checkpoint(result.checkpoint)
    torch.testing.assert_close(agent.critic2.net[0].weight, tensors["critic2.net.0.weight"])
    more = train(GainBandit, "td3", None, total_steps=2600, run_dir=tmp_path / "run", resume=True, progress=False,
                 tensorboard=False)
    assert more.env_steps == 2600


def test_td3_checkpoint_with_a_wrong_second_critic_is_refused(tmp_path):
    result = train(GainBandit, "td3", SMALL, total_steps=64, run_dir=tmp_path / "run", progress=False,
                   tensorboard=False)
    payload = torch.load(result.checkpoint, weights_only=True)
    payload["tensors"]["critic2.net.0.weight"] = torch.zeros(5, 5)
    bad = tmp_path / "bad.pt"
    torch.save(payload, bad)
    with pytest.raises(ValueError, match="critic2.net.0.weight has shape \\(5, 5\\)"):
        read_checkpoint(bad)
    with pytest.raises(ValueError, match="collectors: td3 trains serially"):
        train(GainBandit, "td3", SMALL, total_steps=64, run_dir=tmp_path / "c", collectors=1, progress=False,
              tensorboard=False)
