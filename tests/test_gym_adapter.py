"""The Gymnasium adapter: env_checker, the GoalEnv reward invariant, seeding, SB3 HER, rendering."""

import subprocess
import sys

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
import tasks  # noqa: F401  (registers the auv_mj/* ids)
from tasks import gym_adapter, suite
from tasks.gym_adapter import GYM_IDS, AUVGymEnv

pytestmark = pytest.mark.filterwarnings("ignore:.*Box observation space m.* value is .*infinity")

TASK_NAMES = {name for _, name in suite.ALL_TASKS}
AVAILABLE_IDS = [env_id for env_id, task in GYM_IDS.items() if task in TASK_NAMES]
GOAL_IDS = [env_id for env_id in AVAILABLE_IDS if env_id != "auv_mj/SpeedHeading-v0"]
SHORT = {"time_limit": 5.0}
"""Task kwargs for short episodes (10 planner steps, 50 executor steps)."""


def test_every_id_is_registered_on_import_tasks():
    code = (f"import gymnasium, tasks; ids = {list(GYM_IDS)!r}; "
            "missing = [i for i in ids if i not in gymnasium.registry]; assert not missing, missing")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_registered_ids_cover_the_suite():
    assert set(GYM_IDS.values()) == TASK_NAMES
    for env_id in GYM_IDS:
        assert gymnasium.spec(env_id).entry_point == gym_adapter.ENTRY_POINT


@pytest.mark.parametrize("env_id", AVAILABLE_IDS)
def test_env_checker_passes(env_id):
    env = gymnasium.make(env_id, task_kwargs=SHORT)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_spaces():
    env = AUVGymEnv("speed_heading")
    assert isinstance(env.observation_space, gymnasium.spaces.Box)
    assert env.action_space.shape == (2,)
    np.testing.assert_array_equal(env.action_space.low, [-1, -1])
    np.testing.assert_array_equal(env.action_space.high, [1, 1])
    assert env.metadata["render_fps"] == 10
    goal = AUVGymEnv("goal")
    assert isinstance(goal.observation_space, gymnasium.spaces.Dict)
    assert set(goal.observation_space.spaces) == {"observation", "achieved_goal", "desired_goal"}
    assert goal.observation_space["achieved_goal"].shape == (2,)


def test_seed_gives_the_dm_control_episode():
    env = AUVGymEnv("speed_heading", task_kwargs={"command": "random", "disturbances": "random"})
    obs, _ = env.reset(seed=11)
    dm = suite.load("auv", "speed_heading", task_kwargs={"command": "random", "disturbances": "random",
                                                         "random": 11})
    np.testing.assert_array_equal(obs, dm.reset().observation["observation"])
    actions = np.random.default_rng(0).uniform(-1, 1, size=(30, 2))
    first = [env.step(a)[0] for a in actions]
    env.reset(seed=11)
    second = [env.step(a)[0] for a in actions]
    np.testing.assert_array_equal(first, second)
    env.reset(seed=12)
    assert not np.array_equal(first, [env.step(a)[0] for a in actions])


def test_truncation_and_termination():
    env = AUVGymEnv("speed_heading", task_kwargs={"time_limit": 0.3})
    env.reset(seed=0)
    flags = [env.step(np.zeros(2))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]  # the time limit truncates
    with pytest.raises(RuntimeError):
        env.step(np.zeros(2))
    env.reset(seed=0)
    env.task.get_termination = lambda physics: 0.0  # a task ending the episode (discount 0)
    assert env.step(np.zeros(2))[2:4] == (True, False)


@pytest.mark.parametrize("task_kwargs", [SHORT, {"reward": "paper", **SHORT}])
def test_reward_equals_compute_reward(task_kwargs):
    env = gymnasium.make("auv_mj/Goal-v0", task_kwargs=task_kwargs)
    assert env.unwrapped.task_kwargs["reward"] == "paper"  # the goal-decomposable default
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(1)
    achieved, desired, infos, rewards = [], [], [], []
    done = False
    while not done:
        obs, r, terminated, truncated, info = env.step(rng.uniform(-1, 1, size=2).astype(np.float32))
        done = terminated or truncated
        single = env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert float(single) == pytest.approx(r, abs=1e-9)
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        infos.append(info)
        rewards.append(r)
    batch = env.unwrapped.compute_reward(np.array(achieved), np.array(desired), np.array(infos, dtype=object))
    np.testing.assert_allclose(batch, rewards, atol=1e-9)
    achieved, desired = np.array(achieved), np.array(desired)
    assert np.shape(env.unwrapped.compute_terminated(achieved, desired, np.array(infos))) == (len(rewards),)
    assert np.shape(env.unwrapped.compute_truncated(achieved, desired, infos)) == (len(rewards),)
    assert "is_success" in infos[-1]


def test_speed_heading_is_not_goal_conditioned():
    env = AUVGymEnv("speed_heading")
    with pytest.raises(AttributeError, match="not goal-conditioned"):
        env.compute_reward(np.zeros(2), np.zeros(2), {})
    with pytest.raises(ValueError, match="reset"):
        AUVGymEnv("speed_heading", task_kwargs={"random": 1})


@pytest.fixture
def one_torch_thread():
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # tiny networks: more threads only contend for the two test cores
    yield
    torch.set_num_threads(threads)


def test_her_ddpg_runs_unmodified(one_torch_thread):
    from stable_baselines3 import DDPG, HerReplayBuffer

    env = gymnasium.make("auv_mj/Goal-v0", task_kwargs={"time_limit": 10.0})  # 20-step episodes
    model = DDPG("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                 replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                                       "copy_info_dict": True},  # compute_reward reads info
                 learning_starts=40, batch_size=32, policy_kwargs={"net_arch": [32, 32]}, seed=0, verbose=0)
    model.learn(total_timesteps=300)
    assert model.num_timesteps == 300
    action, _ = model.predict(env.reset(seed=0)[0], deterministic=True)
    assert env.action_space.contains(action)


def test_render_rgb_array():
    env = gymnasium.make("auv_mj/SpeedHeading-v0", render_mode="rgb_array", render_size=(64, 96))
    env.reset(seed=0)
    env.step(np.array([1.0, 0.0], dtype=np.float32))
    image = env.render()
    assert image.shape == (64, 96, 3) and image.dtype == np.uint8
    assert image.max() > 0  # the vehicle is in view
    env.close()
    env.close()
    assert AUVGymEnv("speed_heading").render() is None


def test_her_without_copied_infos_names_copy_info_dict(one_torch_thread):
    from stable_baselines3 import DDPG, HerReplayBuffer

    env = gymnasium.make("auv_mj/Goal-v0", task_kwargs={"time_limit": 10.0})
    model = DDPG("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                 replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
                 learning_starts=40, batch_size=32, policy_kwargs={"net_arch": [32, 32]}, seed=0, verbose=0)
    with pytest.raises(ValueError, match="copy_info_dict"):
        model.learn(total_timesteps=100)
