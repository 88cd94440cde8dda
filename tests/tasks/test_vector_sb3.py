"""Stable-Baselines3 on the batched planning env (`auv_mj.tasks.vector_sb3.SB3VectorEnv`)."""

from __future__ import annotations

import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor

from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.tasks.vector_sb3 import SB3VectorEnv

TIME_LIMIT = 5.0
"""Seconds: ten-step episodes, so that a few hundred steps hold many autoresets."""


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
