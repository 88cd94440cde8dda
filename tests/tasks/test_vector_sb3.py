"""Stable-Baselines3 on the batched planning env and the training mixture (`auv_mj.tasks.vector_sb3.SB3VectorEnv`),
and sb3-contrib's RecurrentPPO on the mixture (the peer of issue 51, `experiments/recurrent_peer.py`)."""

from __future__ import annotations

import numpy as np
from sb3_contrib import RecurrentPPO
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecExtractDictObs, VecMonitor

from auv_mj.seeds import TRAIN
from auv_mj.tasks.mixture import PlanningMixtureVectorEnv
from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.tasks.vector_sb3 import SB3VectorEnv

TIME_LIMIT = 5.0
"""Seconds: ten-step episodes, so that a few hundred steps hold many autoresets."""
MIXTURE_KWARGS = {"time_limit": TIME_LIMIT, "reward": "geodesic", "action": "rate", "observation": "planner"}
"""The new learning problem's options (`LEARNED_MIXTURE.task_kwargs()`) with ten-step episodes."""


def test_ppo_runs_on_the_batch():
    env = VecMonitor(SB3VectorEnv(AUVVectorEnv("obstacles", 4, {"arena": "random", "time_limit": TIME_LIMIT},
                                               threads=2, autoreset_mode="SameStep")))
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=256)
    assert model.num_timesteps >= 256
    lengths = [episode["l"] for episode in model.ep_info_buffer]
    assert len(lengths) >= 256 // 10 - 4  # ten-step episodes, fewer only where one collided
    assert all(1 <= length <= 10 for length in lengths)
    env.close()


def test_sb3_step_reports_the_ended_episodes():
    env = SB3VectorEnv(AUVVectorEnv("goal", 3, {"time_limit": TIME_LIMIT}, threads=1, autoreset_mode="SameStep"))
    env.seed(11)
    observation = env.reset()
    ended = 0
    for _ in range(25):
        env.step_async(np.tile([0.5, 0.1], (3, 1)))
        next_observation, reward, done, infos = env.step_wait()
        assert reward.dtype == np.float32 and reward.shape == (3,)
        for i in np.flatnonzero(done):
            ended += 1
            final = infos[i]["terminal_observation"]
            assert infos[i]["TimeLimit.truncated"]
            assert not np.allclose(final["observation"], next_observation["observation"][i])
            assert "min_clearance" in infos[i]
        observation = next_observation
    assert ended == 2 * 3  # two 10-step episodes each in 25 steps
    assert set(observation) == {"observation", "achieved_goal", "desired_goal"}
    env.close()


def small_mixture(autoreset_mode: str, counts=1) -> PlanningMixtureVectorEnv:
    return PlanningMixtureVectorEnv(counts, task_kwargs=MIXTURE_KWARGS, reward_scale=0.1, threads=1,
                                    autoreset_mode=autoreset_mode)


def test_mixture_same_step_runs_next_steps_episodes():
    """SAME_STEP resets in the ending step the episode NEXT_STEP resets in the next one: same TRAIN seeds, same
    first observation; the ended episode's last observation is in info["final_obs"]."""
    same, nxt = small_mixture("SameStep"), small_mixture("NextStep")
    actions = np.tile([0.5, 0.1], (same.num_envs, 1))
    same.reset(seed=3)
    nxt.reset(seed=3)
    for _ in range(10):
        obs, reward, term, trunc, info = same.step(actions)
        last, reward_next, term_next, trunc_next, _ = nxt.step(actions)
        np.testing.assert_array_equal(reward, reward_next)
        np.testing.assert_array_equal(term | trunc, term_next | trunc_next)
    done = term | trunc
    assert done.all() and info["_final_obs"].all()  # ten-step episodes
    for i in range(same.num_envs):
        np.testing.assert_array_equal(info["final_obs"][i]["observation"], last["observation"][i])
    assert info["final_info"]["_success"].all() and not info["_success"].any()
    first, *_ = nxt.step(actions)  # NEXT_STEP's reset step
    np.testing.assert_array_equal(obs["observation"], first["observation"])
    np.testing.assert_array_equal(same.episode_seeds, nxt.episode_seeds)
    assert all(int(seed) in TRAIN for seed in same.episode_seeds)  # (a numpy int would scan the range)
    same.close()
    nxt.close()


def test_sb3_mixture_reports_ended_episodes_in_the_same_step():
    env = VecExtractDictObs(SB3VectorEnv(small_mixture("SameStep", [1, 2] * 6)), "observation")
    assert env.num_envs == 18 and env.observation_space.shape == (32,)
    env.seed(5)
    observation = env.reset()
    assert observation.shape == (18, 32)
    for step in range(10):
        env.step_async(np.tile([0.5, 0.0], (18, 1)))
        next_observation, reward, done, infos = env.step_wait()
        assert done.all() == (step == 9) and reward.dtype == np.float32
    for i in range(18):
        assert infos[i]["TimeLimit.truncated"] and "success" in infos[i]
        assert infos[i]["terminal_observation"].shape == (32,)
        assert not np.allclose(infos[i]["terminal_observation"], next_observation[i])
    env.close()


def test_recurrent_ppo_learns_on_the_mixture():
    env = VecExtractDictObs(SB3VectorEnv(small_mixture("SameStep")), "observation")
    model = RecurrentPPO("MlpLstmPolicy", env, n_steps=16, batch_size=96, n_epochs=2, seed=0, device="cpu",
                         policy_kwargs={"lstm_hidden_size": 16, "net_arch": [16]})
    model.learn(total_timesteps=12 * 16 * 2)
    assert model.num_timesteps == 12 * 16 * 2
    env.close()
