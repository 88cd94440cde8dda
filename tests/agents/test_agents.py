"""Tests of the algorithm core (agents/): HER relabelling, DDPG learning, checkpoints, resume, policies.

All on a tiny 2-D point goal task with the project's goal-env conventions: dict observations, vectorised
compute_reward / compute_terminated(achieved, desired, info), per-step info with
previous_achieved_goal and goal_independent_reward, and a shaped reward like Eq. (23).
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium import spaces
from gymnasium.wrappers import TimeLimit

from auv_mj.agents.checkpoint import read_checkpoint, read_replay
from auv_mj.agents.offpolicy import Policy
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig, actor_loss, critic_loss, epsilon_at, soft_update, td_target
from auv_mj.agents.offpolicy.her import HerReplayBuffer, flatten_goal_obs
from auv_mj.agents.offpolicy.learners import load_agent
from auv_mj.agents.offpolicy.replay import Batch, ReplayBuffer
from auv_mj.agents.offpolicy.train import env_spec, episode_seed, train
from auv_mj.cli.train import task_env_id
from auv_mj.planners.deploy import deploy_env

torch.set_num_threads(1)

STEP = 0.15
"""Largest displacement per step of the point."""
GOAL_RADIUS = 0.15
"""The goal counts as reached within this distance (the paper's 2 m, scaled)."""
TIME_LIMIT = 30
"""Episode length before truncation."""
STEP_PENALTY = -0.05
"""The goal-independent per-step reward (Eq. 25)."""
DEADBAND = 0.5 * STEP
"""Distance changes smaller than this earn Eq. (23)'s "0 other conditions". Without it, creeping towards
the goal by tiny steps earns +0.45 forever, worth 0.45 / (1 - gamma) = 4.5 > 4 - 0.05 for reaching it."""
TEST_ID = "auv_mj_test/PointGoal-v0"


class PointGoalEnv(gym.Env):
    """A point in [-1, 1]^dim moved by actions in [-1, 1]^dim * STEP towards a random goal."""

    def __init__(self, dim: int = 2):
        self.dim = dim
        box = spaces.Box(-1.0, 1.0, (dim,), np.float64)
        self.observation_space = spaces.Dict(observation=box, achieved_goal=box, desired_goal=box)
        self.action_space = spaces.Box(-1.0, 1.0, (dim,), np.float32)

    def _obs(self):
        return {"observation": self.pos.copy(), "achieved_goal": self.pos.copy(),
                "desired_goal": self.goal.copy()}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = self.np_random.uniform(-1, 1, self.dim)
        self.goal = self.np_random.uniform(-1, 1, self.dim)
        while np.linalg.norm(self.goal - self.pos) <= GOAL_RADIUS:
            self.goal = self.np_random.uniform(-1, 1, self.dim)
        return self._obs(), {}

    def step(self, action):
        previous = self.pos.copy()
        self.pos = np.clip(self.pos + STEP * np.clip(action, -1, 1), -1, 1)
        info = {"previous_achieved_goal": previous, "goal_independent_reward": STEP_PENALTY,
                "collision": False, "min_clearance": 1.0}
        info["is_success"] = bool(np.linalg.norm(self.pos - self.goal) <= GOAL_RADIUS)
        reward = float(self.compute_reward(self.pos, self.goal, info))
        terminated = bool(self.compute_terminated(self.pos, self.goal, info))
        return self._obs(), reward, terminated, False, info

    def compute_reward(self, achieved_goal, desired_goal, info):
        """Eq. (23)-style: +4 reached, +0.5 closer, -0.5 farther, plus the goal-independent part."""
        d_now = np.linalg.norm(achieved_goal - desired_goal, axis=-1)
        progress = np.linalg.norm(info["previous_achieved_goal"] - desired_goal, axis=-1) - d_now
        shaped = np.where(d_now <= GOAL_RADIUS, 4.0, 0.5 * np.sign(progress) * (np.abs(progress) >= DEADBAND))
        return shaped + info["goal_independent_reward"]

    def compute_terminated(self, achieved_goal, desired_goal, info):
        return (np.linalg.norm(achieved_goal - desired_goal, axis=-1) <= GOAL_RADIUS) | info["collision"]


class RelativePointGoalEnv(PointGoalEnv):
    """Observation [position, goal - position] depends on the goal: the env gives relabel_observation."""

    def __init__(self):
        super().__init__(2)
        self.observation_space["observation"] = spaces.Box(-2.0, 2.0, (4,), np.float64)

    def _obs(self):
        obs = super()._obs()
        obs["observation"] = np.concatenate([self.pos, self.goal - self.pos])
        return obs

    def relabel_observation(self, observation, achieved_goal, desired_goal):
        return np.concatenate([observation[..., :2], desired_goal - achieved_goal], axis=-1)


def make_env(dim: int = 2):
    return TimeLimit(PointGoalEnv(dim), TIME_LIMIT)


class PointTrackEnv(gym.Env):
    """Box-observation sibling (like the executor's task): obs = [position, target]."""

    def __init__(self):
        self.observation_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.action_space = spaces.Box(-2.0, 2.0, (2,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos, self.target = self.np_random.uniform(-1, 1, (2, 2))
        return np.concatenate([self.pos, self.target]).astype(np.float32), {}

    def step(self, action):
        self.pos = np.clip(self.pos + 0.05 * action, -1, 1)
        obs = np.concatenate([self.pos, self.target]).astype(np.float32)
        return obs, -float(np.abs(self.pos - self.target).sum()), False, False, {}


if TEST_ID not in gym.registry:
    gym.register(TEST_ID, entry_point=PointGoalEnv, max_episode_steps=TIME_LIMIT)

FAST = DDPGConfig(hidden_sizes=(64, 64), learning_starts=64, buffer_size=5000, epsilon_decay=200)
"""A small, quick configuration for the loop tests (not for learning)."""


def fill_her_buffer(n_episodes: int, capacity: int = 10_000, seed: int = 0, env: gym.Env | None = None):
    env = env or make_env()
    base = env.unwrapped
    calls = {"reward": 0, "terminated": 0}

    def reward_fn(a, d, info):
        calls["reward"] += 1
        return base.compute_reward(a, d, info)

    def terminated_fn(a, d, info):
        calls["terminated"] += 1
        return base.compute_terminated(a, d, info)

    obs_dim = env.observation_space["observation"].shape[0]
    buf = HerReplayBuffer(obs_dim, 2, 2, capacity, reward_fn, terminated_fn, n_sampled_goal=4, seed=seed,
                          relabel_observation=getattr(base, "relabel_observation", None))
    rng = np.random.default_rng(seed)
    for episode in range(n_episodes):
        obs, _ = env.reset(seed=episode)
        while True:
            # Mostly random, sometimes straight to the goal, so both terminations and truncations occur.
            toward = obs["desired_goal"] - obs["achieved_goal"]
            action = toward / STEP if episode % 3 == 0 else rng.uniform(-1, 1, 2)
            next_obs, reward, terminated, truncated, info = env.step(action)
            buf.add(obs, action, reward, next_obs, terminated, truncated, info)
            obs = next_obs
            if terminated or truncated:
                break
        buf.end_episode()
    return env, buf, calls


def test_env_reward_invariant_and_conventions():
    env = make_env()
    obs, _ = env.reset(seed=1)
    for _ in range(TIME_LIMIT):
        next_obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert reward == pytest.approx(env.unwrapped.compute_reward(next_obs["achieved_goal"],
                                                                    next_obs["desired_goal"], info))
        np.testing.assert_array_equal(info["previous_achieved_goal"], obs["achieved_goal"])
        obs = next_obs
        if terminated or truncated:
            break


def test_her_relabelling_future_goals_rewards_and_terminations():
    env, buf, calls = fill_her_buffer(12)
    base = env.unwrapped
    assert buf.truncated.any() and buf.terminated.any()
    calls.update(reward=0, terminated=0)
    sample = buf.sample_relabelled(4096)
    # ONE vectorised call each for the whole batch.
    assert calls == {"reward": 1, "terminated": 1}
    idx, fut, rel, goals = sample.indices, sample.future_indices, sample.relabelled, sample.desired_goals
    assert 0.75 < rel.mean() < 0.85  # k = 4 -> 0.8
    # 'future': a same-or-later transition t' >= t of the SAME episode (SB3's inclusive convention), whose
    # next_achieved_goal is the achieved goal of the state s_{t'+1}, strictly later than s_t.
    assert np.all(buf.ep_start[fut] == buf.ep_start[idx])
    assert np.all(fut[rel] >= idx[rel]) and np.any(fut[rel] > idx[rel]) and np.any(fut[rel] == idx[rel])
    np.testing.assert_array_equal(goals[rel], buf.next_achieved_goal[fut[rel]])
    np.testing.assert_array_equal(goals[~rel], buf.desired_goal[idx[~rel]])
    # desired_goal relabelled in both obs and next_obs.
    batch = sample.batch
    np.testing.assert_array_equal(batch.obs, flatten_goal_obs(buf.observation[idx], goals))
    np.testing.assert_array_equal(batch.next_obs[rel],
                                  flatten_goal_obs(buf.next_observation[idx[rel]], goals[rel]))
    # Rewards and terminations are those of the relabelled goals.
    info = {k: v[idx] for k, v in buf.infos.items()}
    expected_reward = base.compute_reward(buf.next_achieved_goal[idx], goals, info)
    np.testing.assert_allclose(batch.rewards, expected_reward, rtol=1e-6)
    expected_done = base.compute_terminated(buf.next_achieved_goal[idx], goals, info)
    np.testing.assert_array_equal(batch.terminated, expected_done.astype(np.float32))
    # Relabelling with t' = t reaches the new goal: reward 4 - 0.05 and a true termination.
    same = rel & (fut == idx)
    assert np.all(batch.terminated[same] == 1.0)
    np.testing.assert_allclose(batch.rewards[same], 4.0 + STEP_PENALTY, rtol=1e-6)
    # Time-limit truncation is never a termination.
    truncated_real = ~rel & buf.truncated[idx]
    assert truncated_real.any() and np.all(batch.terminated[truncated_real] == 0.0)


def test_her_recomputes_goal_dependent_observations():
    _, buf, _ = fill_her_buffer(6, env=TimeLimit(RelativePointGoalEnv(), TIME_LIMIT))
    sample = buf.sample_relabelled(1024)
    idx, rel, goals, batch = sample.indices, sample.relabelled, sample.desired_goals, sample.batch
    assert rel.any() and (~rel).any()
    np.testing.assert_allclose(batch.obs[:, 2:4], goals - buf.achieved_goal[idx], atol=1e-6)
    np.testing.assert_allclose(batch.next_obs[rel, 2:4], goals[rel] - buf.next_achieved_goal[idx[rel]],
                               atol=1e-6)
    np.testing.assert_array_equal(batch.obs[:, :2], buf.observation[idx, :2])


def test_her_buffer_skips_open_episodes_and_overwritten_ones():
    env, buf, _ = fill_her_buffer(3, capacity=64)
    assert buf.size == 64 and buf.num_samplable < 64  # the ring overwrote an old episode's head
    obs, _ = env.reset(seed=99)
    next_obs, reward, terminated, truncated, info = env.step(np.zeros(2))
    buf.add(obs, np.zeros(2), reward, next_obs, terminated, truncated, info)
    open_slot = (buf.pos - 1) % buf.capacity
    sample = buf.sample_relabelled(2000)
    assert np.all(buf.valid[sample.indices]) and np.all(buf.valid[sample.future_indices])
    assert open_slot not in sample.indices
    assert np.all(buf.ep_start[sample.future_indices] == buf.ep_start[sample.indices])
    buf.end_episode()
    assert buf.valid[open_slot]


def test_replay_buffer_ring_and_state_round_trip():
    buf = ReplayBuffer(3, 1, capacity=5, seed=0)
    for i in range(7):
        buf.add(np.full(3, i), [i], i, np.full(3, i + 1), i == 6)
    assert len(buf) == 5 and buf.pos == 2
    assert sorted(buf.rewards) == [2, 3, 4, 5, 6]
    copy = ReplayBuffer(3, 1, capacity=5)
    copy.load_state_dict(buf.state_dict())
    np.testing.assert_array_equal(copy.sample(8).obs, buf.sample(8).obs)


def test_ddpg_update_functions_follow_eq_17_to_19():
    torch.manual_seed(0)
    agent = DDPG(4, 2, dataclasses.replace(FAST, tau=0.5))
    obs = torch.randn(8, 4)
    rewards, terminated = torch.randn(8), torch.tensor([0.0, 1.0] * 4)
    target = td_target(agent.critic_target, agent.actor_target, rewards, obs, terminated, 0.9)
    q_next = agent.critic_target(obs, agent.actor_target(obs))
    torch.testing.assert_close(target, rewards + 0.9 * (1 - terminated) * q_next)
    assert target[1] == rewards[1]  # terminal: no bootstrap
    actions = agent.actor(obs).detach()
    torch.testing.assert_close(critic_loss(agent.critic, obs, actions, target),
                               ((agent.critic(obs, actions) - target) ** 2).mean())
    torch.testing.assert_close(actor_loss(agent.actor, agent.critic, obs),
                               -agent.critic(obs, agent.actor(obs)).mean())
    before = [p.clone() for p in agent.actor_target.parameters()]
    rng = np.random.default_rng(0)
    batch = Batch(rng.normal(size=(64, 4)), rng.uniform(-1, 1, (64, 2)), rng.normal(size=64),
                  rng.normal(size=(64, 4)), np.zeros(64))
    metrics = agent.update(batch)
    assert set(metrics) == {"critic_loss", "actor_loss", "q_target"} and agent.num_updates == 1
    pairs = zip(before, agent.actor_target.parameters(), agent.actor.parameters(), strict=True)
    for old, new, online in pairs:
        torch.testing.assert_close(new, 0.5 * old + 0.5 * online)
    soft_update(agent.actor_target, agent.actor, 1.0)
    for new, online in zip(agent.actor_target.parameters(), agent.actor.parameters(), strict=True):
        torch.testing.assert_close(new, online)


@pytest.mark.parametrize("agent_name", ["ddpg", "td3"])
def test_zero_actor_head_and_critic_burn_in(agent_name):
    """A zero-headed actor outputs 0 (a residual planner's classical skeleton) and, during `actor_burn_in`
    gradient steps, stays so while the critic learns; after it, the actor moves (Silver et al. 2018)."""
    from auv_mj.agents.offpolicy.td3 import TD3, TD3Config

    learner, config = (DDPG, dataclasses.replace(FAST, actor_burn_in=4)) if agent_name == "ddpg" else \
        (TD3, TD3Config(hidden_sizes=(64, 64), actor_burn_in=4))
    torch.manual_seed(0)
    agent = learner(4, 2, config)
    agent.zero_actor_head()
    obs = torch.randn(16, 4)
    for actor in (agent.actor, agent.actor_target):
        torch.testing.assert_close(actor(obs), torch.zeros(16, 2), rtol=0, atol=0)
    rng = np.random.default_rng(0)
    batch = Batch(rng.normal(size=(64, 4)), rng.uniform(-1, 1, (64, 2)), rng.normal(size=64),
                  rng.normal(size=(64, 4)), np.zeros(64))
    critic = [p.clone() for p in agent.critic.parameters()]
    for _ in range(4):
        agent.update(batch)
    torch.testing.assert_close(agent.actor(obs), torch.zeros(16, 2), rtol=0, atol=0)
    assert any(not torch.equal(a, b) for a, b in zip(critic, agent.critic.parameters(), strict=True))
    for _ in range(4):
        agent.update(batch)
    assert agent.actor(obs).abs().max() > 0


def test_zero_actor_head_is_for_a_new_run(tmp_path):
    kwargs = dict(progress=False, tensorboard=False)
    run = train(make_env, "ddpg", FAST, total_steps=0, run_dir=tmp_path / "run", zero_actor_head=True, **kwargs)
    agent, _ = load_agent(run.checkpoint)
    torch.testing.assert_close(agent.actor(torch.randn(3, agent.obs_dim)), torch.zeros(3, agent.act_dim))
    with pytest.raises(ValueError, match="zero_actor_head starts a new run"):
        train(make_env, "ddpg", FAST, total_steps=0, run_dir=tmp_path / "run", resume=True, zero_actor_head=True,
              **kwargs)


def test_a_deployed_policy_is_its_network_in_float64():
    """`Policy` (the shipped executor) computes tanh(W3 tanh(W2 tanh(W1 x_n + b1) + b2) + b3) on the clipped
    standardised input x_n in float64 (numpy's arithmetic here, to 1e-12), rescaled to the action bounds."""
    from auv_mj.agents.checkpoint import read_checkpoint
    from auv_mj.agents.normalizer import NORM_CLIP

    path = Path(__file__).resolve().parents[2] / "agents" / "checkpoints" / "executor.pt"
    policy = Policy.load(path)
    tensors, _ = read_checkpoint(path)
    weights = {k: v.double().numpy() for k, v in tensors.items()}
    obs = np.random.default_rng(0).normal(size=(7, policy.obs_dim)).astype(np.float32)
    x = np.clip((obs.astype(np.float64) - weights["obs_norm.mean"]) / weights["obs_norm.std"], -NORM_CLIP, NORM_CLIP)
    layers = sorted({k.split(".")[2] for k in weights if k.startswith("actor.net.")}, key=int)
    for n, layer in enumerate(layers):
        x = x @ weights[f"actor.net.{layer}.weight"].T + weights[f"actor.net.{layer}.bias"]
        x = np.tanh(x) if n < len(layers) - 1 else x
    expected = policy.low + (np.tanh(x) + 1.0) * 0.5 * (policy.high - policy.low)
    got = policy(obs)
    assert got.dtype == np.float64
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_epsilon_schedule_table_4():
    cfg = DDPGConfig()
    assert (cfg.epsilon_start, cfg.epsilon_end, cfg.epsilon_decay) == (1.0, 0.01, 2000)
    assert (cfg.actor_lr, cfg.critic_lr, cfg.gamma, cfg.buffer_size, cfg.batch_size, cfg.tau,
            cfg.max_episodes, cfg.hidden_sizes) == (1e-3, 1e-3, 0.9, 50_000, 64, 0.01, 5000, (256, 256))
    assert epsilon_at(cfg, 0, 0) == 1.0
    assert epsilon_at(cfg, 1000, 0) == pytest.approx(0.505)
    assert epsilon_at(cfg, 10**6, 0) == pytest.approx(0.01)
    per_episode = dataclasses.replace(cfg, epsilon_unit="episodes")
    assert epsilon_at(per_episode, 10**6, 1000) == pytest.approx(0.505)


def evaluate(policy, episodes: int, seed: int = 1000, dim: int = 2):
    env = make_env(dim)
    successes, returns = [], []
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        total, done, info = 0.0, False, {}
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            total += reward
            done = terminated or truncated
        successes.append(info["is_success"])
        returns.append(total)
    return float(np.mean(successes)), returns


def test_her_ddpg_learns_point_goal_task(tmp_path):
    # Table 4 networks and rates; a short warm-up and epsilon decay, as the task is tiny.
    config = DDPGConfig(learning_starts=200, epsilon_decay=400, updates_per_step=0.5, seed=3)
    result = train(lambda: make_env(dim=1), "her-ddpg", config, total_steps=1500, run_dir=tmp_path / "run",
                   progress=False, tensorboard=False)
    assert result.env_steps == 1500 and result.gradient_steps >= 640
    success, _ = evaluate(Policy.load(result.checkpoint), 50, dim=1)
    assert success >= 0.9, success


def test_policy_is_deterministic_for_a_fixed_seed(tmp_path):
    result = train(make_env, "her-ddpg", FAST, episodes=6, run_dir=tmp_path / "a", progress=False,
                   tensorboard=False)
    policy, again = Policy.load(result.checkpoint), Policy.load(result.checkpoint)
    first, second = evaluate(policy, 5), evaluate(again, 5)
    assert first == second
    obs = make_env().reset(seed=5)[0]
    np.testing.assert_array_equal(policy(obs), policy(obs))
    batch = {k: np.stack([v, v]) for k, v in obs.items()}
    np.testing.assert_allclose(policy(batch), np.stack([policy(obs)] * 2), rtol=1e-6)
    # The same seed trains the same weights.
    twin = train(make_env, "her-ddpg", FAST, episodes=6, run_dir=tmp_path / "b", progress=False,
                 tensorboard=False)
    for a, b in zip(Policy.load(twin.checkpoint).actor.parameters(), policy.actor.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)


def test_resume_continues_the_same_run(tmp_path):
    kwargs = dict(progress=False, tensorboard=False, checkpoint_every=4)
    straight = train(make_env, "her-ddpg", FAST, episodes=10, run_dir=tmp_path / "straight", **kwargs)
    first = train(make_env, "her-ddpg", FAST, episodes=5, run_dir=tmp_path / "split", **kwargs)
    _, meta = read_checkpoint(first.checkpoint)
    saved_replay = read_replay(first.run_dir / meta["replay_file"])
    agent, _ = load_agent(first.checkpoint)
    assert meta["counters"]["episodes"] == 5 and meta["counters"]["env_steps"] == first.env_steps
    assert json.loads(json.dumps(meta)) == meta  # the metadata is plain JSON

    with pytest.raises(FileExistsError):
        train(make_env, "her-ddpg", FAST, episodes=10, run_dir=tmp_path / "split", **kwargs)
    resumed = train(make_env, "her-ddpg", None, episodes=10, run_dir=tmp_path / "split", resume=True,
                    **kwargs)
    assert (resumed.episodes, resumed.env_steps, resumed.gradient_steps) == (
        straight.episodes, straight.env_steps, straight.gradient_steps)
    assert resumed.env_steps > first.env_steps
    # The replay contents were carried over: the first run's transitions are still in the buffer.
    _, meta = read_checkpoint(resumed.checkpoint)
    replay = read_replay(resumed.run_dir / meta["replay_file"])
    n = len(saved_replay["rewards"])
    for key in ("observation", "actions", "rewards", "ep_start", "ep_length", "valid"):
        np.testing.assert_array_equal(replay[key][:n], saved_replay[key])
    assert sorted(p.name for p in resumed.run_dir.glob("replay-*.npz")) == [meta["replay_file"]]
    # ... and, with every RNG restored, the resumed run is the uninterrupted one, bit for bit.
    straight_agent, _ = load_agent(straight.checkpoint)
    resumed_agent, _ = load_agent(resumed.checkpoint)
    for a, b in zip(straight_agent.critic.parameters(), resumed_agent.critic.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    torch.testing.assert_close(straight_agent.obs_norm.mean, resumed_agent.obs_norm.mean, rtol=0, atol=0)
    assert agent.num_updates < resumed_agent.num_updates
    with open(resumed.run_dir / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["episode"]) for r in rows] == list(range(1, 11))
    assert [int(r["steps"]) for r in rows][-1] == resumed.env_steps


def test_init_fine_tunes_from_another_run(tmp_path):
    kwargs = dict(progress=False, tensorboard=False)
    source = train(make_env, "her-ddpg", FAST, episodes=4, run_dir=tmp_path / "source", **kwargs)
    trained, _ = load_agent(source.checkpoint)
    # Zero episodes: the new run is the source's networks and normaliser, with its own fresh counters.
    tuned = train(make_env, "her-ddpg", FAST, total_steps=0, run_dir=tmp_path / "tuned", init=source.checkpoint,
                  **kwargs)
    start, meta = load_agent(tuned.checkpoint)
    assert meta["counters"]["env_steps"] == 0 and meta["counters"]["episodes"] == 0
    for name, module in trained.modules().items():
        for key, value in module.state_dict().items():
            torch.testing.assert_close(start.modules()[name].state_dict()[key], value, rtol=0, atol=0)
    fresh = train(make_env, "her-ddpg", FAST, total_steps=0, run_dir=tmp_path / "fresh", **kwargs)
    assert not torch.equal(next(load_agent(fresh.checkpoint)[0].actor.parameters()),
                           next(trained.actor.parameters()))
    with pytest.raises(ValueError, match="observation/action sizes"):
        train(lambda: make_env(dim=1), "her-ddpg", FAST, total_steps=0, run_dir=tmp_path / "other",
              init=source.checkpoint, **kwargs)


def test_box_task_ddpg_and_action_rescaling(tmp_path):
    def make_track():
        return TimeLimit(PointTrackEnv(), 20)

    result = train(make_track, "executor", FAST, total_steps=150, run_dir=tmp_path / "box", progress=False,
                   tensorboard=True, checkpoint_every=2)
    assert result.env_steps == 150 and result.gradient_steps > 0
    assert any((tmp_path / "box" / "tb").iterdir())
    policy = Policy.load(result.checkpoint)
    obs, _ = make_track().reset(seed=0)
    action = policy(obs)
    assert action.shape == (2,) and np.all(np.abs(action) <= 2.0)
    assert env_spec(make_track())["kind"] == "box"
    with pytest.raises(ValueError, match="executor needs a Box"):
        train(make_env, "executor", FAST, episodes=1, run_dir=tmp_path / "x", progress=False,
              tensorboard=False)
    # a residual planner's actions depend on the goal: hindsight relabelling is refused, ddpg named
    with pytest.raises(ValueError, match="residual planner.*train it with ddpg"):
        train(lambda: deploy_env(gym.make("auv_mj/Goal-v0"), residual=0.5), "her-ddpg", FAST, episodes=1,
              run_dir=tmp_path / "r", progress=False, tensorboard=False)


def test_corrupt_truncated_and_foreign_checkpoints_raise_clear_errors(tmp_path):
    result = train(make_env, "ddpg", FAST, episodes=2, run_dir=tmp_path / "run", progress=False,
                   tensorboard=False)
    assert Policy.load(result.checkpoint)(make_env().reset(seed=0)[0]).shape == (2,)
    data = result.checkpoint.read_bytes()
    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(data[: len(data) // 2])
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint at all")
    for path in (truncated, garbage):
        with pytest.raises(ValueError, match=str(path.name)):
            Policy.load(path)
        with pytest.raises(ValueError, match=str(path.name)):
            load_agent(path)
    foreign = tmp_path / "foreign.pt"
    torch.save({"weights": torch.zeros(3)}, foreign)
    with pytest.raises(ValueError, match="foreign.pt.*not an auv-mj"):
        Policy.load(foreign)
    # Tensors that do not fit the architecture the metadata describes.
    tensors, meta = read_checkpoint(result.checkpoint)
    meta["config"]["hidden_sizes"] = [32, 32]
    wrong = tmp_path / "wrong.pt"
    torch.save({"tensors": tensors, "metadata": meta}, wrong)
    with pytest.raises(ValueError, match="wrong.pt.*architecture"):
        Policy.load(wrong)
    with pytest.raises(ValueError, match="wrong.pt.*architecture"):
        load_agent(wrong)
    with pytest.raises(ValueError, match="hidden sizes"):
        load_agent(result.checkpoint, config=dataclasses.replace(FAST, hidden_sizes=(32, 32)))
    with pytest.raises(ValueError, match="policy expects 4"):
        Policy.load(result.checkpoint)(np.zeros(3))


def test_cli_hooks(tmp_path, capsys):
    from auv_mj.cli import main

    assert task_env_id("speed_heading") == "auv_mj/SpeedHeading-v0"
    assert task_env_id("goal") == "auv_mj/Goal-v0"
    with pytest.raises(SystemExit) as exit_info:
        main(["train", "her-ddpg", "--task", "no-such-task", "--run-dir", str(tmp_path / "n")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "unknown task 'no-such-task'" in err
    args = ["train", "her-ddpg", "--task", TEST_ID, "--steps", "120", "--run-dir", str(tmp_path / "cli"),
            "--no-progress", "--no-tensorboard", "--hidden-sizes", "32", "32", "--learning-starts", "40"]
    assert main(args) == 0
    assert "checkpoint:" in capsys.readouterr().out
    assert main([*args[:5], "240", *args[6:], "--resume"]) == 0
    _, meta = read_checkpoint(tmp_path / "cli" / "checkpoint.pt")
    assert meta["counters"]["env_steps"] == 240 and meta["config"]["hidden_sizes"] == [32, 32]
    assert meta["spec"]["env_id"] == TEST_ID
    assert episode_seed(0, 1) != episode_seed(0, 2)


def test_learned_executor_feeds_the_integral_observation_it_was_trained_on():
    from auv_mj.tasks import speed_heading as sh
    from auv_mj.zoo.registry import LearnedExecutor

    class RecordingPolicy:
        obs_dim = 9

        def __init__(self):
            self.inputs = []

        def __call__(self, obs):
            self.inputs.append(np.array(obs))
            return np.array([0.5 * np.sin(0.3 * len(self.inputs)), 0.1 * np.cos(0.2 * len(self.inputs))])

    kwargs = dict(command="random", disturbances="random", random=5, time_limit=6.0)
    policy = RecordingPolicy()
    executor = LearnedExecutor(policy, np.array([-20.0, -10.0]), np.array([20.0, 10.0]))
    sh.rollout(executor, **kwargs)
    first = policy.inputs
    env = sh.speed_heading(observation="integral", **kwargs)
    time_step = env.reset()
    replay = RecordingPolicy()
    for seen in first:  # the env's own observations, under the same actions, are what the executor saw
        np.testing.assert_allclose(time_step.observation["observation"], seen, atol=1e-9)
        time_step = env.step(replay(seen))
    assert np.any(np.stack(first)[:, 7:] != 0.0)
    policy.inputs = []
    sh.rollout(executor, **kwargs)  # rollout resets the executor: the integrals start from zero again
    np.testing.assert_allclose(np.stack(policy.inputs), np.stack(first))
