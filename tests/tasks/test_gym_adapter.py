"""The Gymnasium adapter: env_checker, the GoalEnv reward invariant, seeding, SB3 HER, rendering."""

import os
import subprocess
import sys

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj.tasks import gym_adapter, suite
from auv_mj.tasks.gym_adapter import GYM_IDS, AUVGymEnv

pytestmark = pytest.mark.filterwarnings("ignore:.*Box observation space m.* value is .*infinity")

TASK_NAMES = {name for _, name in suite.PLANAR_TASKS}
AVAILABLE_IDS = [env_id for env_id, task in GYM_IDS.items() if task in TASK_NAMES]
GOAL_IDS = [env_id for env_id in AVAILABLE_IDS if env_id != "auv_mj/SpeedHeading-v0"]
SHORT = {"time_limit": 5.0}
"""Task kwargs for short episodes (10 planner steps, 50 executor steps)."""


def test_import_auv_mj_registers_every_id_beside_a_users_own_tasks_and_agents(tmp_path):
    """`import auv_mj` alone registers the ids, run from a project with its own `tasks` and `agents` packages
    (which must not be imported: auv-mj's are `auv_mj.tasks` and `auv_mj.agents`)."""
    for package in ("tasks", "agents"):
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("raise ImportError('a user package was imported')\n")
    code = (f"import gymnasium, auv_mj; ids = {list(GYM_IDS)!r}; "
            "missing = [i for i in ids if i not in gymnasium.registry]; assert not missing, missing; "
            "env = gymnasium.make('auv_mj/Goal-v0'); env.reset(seed=0); env.step(env.action_space.sample()); "
            "from auv_mj import zoo; from auv_mj.tasks import suite; "
            "e = suite.load('auv', 'obstacles', task_kwargs={'random': 1}); "
            "p = zoo.load_policy('bug', e, 'obstacles'); p(e.reset()); print('ran'); import tasks")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(tmp_path)})
    # everything ran; only the last statement, the user's own `import tasks`, reached the user's package
    assert done.returncode == 1 and done.stderr.count("ImportError: a user package was imported") == 1, done.stderr
    assert done.stdout.strip() == "ran", done.stderr


def test_registered_ids_cover_the_suite():
    assert set(GYM_IDS.values()) == TASK_NAMES
    for env_id in GYM_IDS:
        assert gymnasium.spec(env_id).entry_point == gym_adapter.ENTRY_POINT


@pytest.mark.parametrize("env_id", sorted(i for i in gymnasium.registry if i.startswith("auv_mj/")))
def test_env_checker_passes(env_id):
    """Every registered id, the Planning-v0 mixture included (its unseeded resets once were not repeatable)."""
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
    assert goal.observation_space["achieved_goal"].shape == (4,)  # (x, y, cos psi, sin psi): relative obs
    assert goal.observation_space["observation"].shape == (17,) and goal.goal_in_observation
    paper = AUVGymEnv("goal", task_kwargs={"observation": "paper"})
    assert paper.observation_space["achieved_goal"].shape == (2,) and not paper.goal_in_observation
    assert paper.observation_space["observation"].shape == (18,)


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


def test_relative_observation_is_invariant_to_moving_and_turning_the_world():
    """The body-frame goal: shifting and rotating the pose and the goal together changes nothing."""
    from auv_mj.tasks.planning_observation import relative_goal

    rng = np.random.default_rng(0)
    pose, goal = rng.uniform(-300, 300, (50, 2)), rng.uniform(-300, 300, (50, 2))
    psi = rng.uniform(-np.pi, np.pi, 50)
    angle, shift = 1.1, np.array([150.0, -300.0])
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])

    def features(p, g, heading):
        return relative_goal(np.column_stack([p, np.cos(heading), np.sin(heading)]), g)

    np.testing.assert_allclose(features(pose, goal, psi), features(pose @ rot.T + shift, goal @ rot.T + shift,
                                                                   psi + angle), atol=1e-9)
    ahead = features(np.zeros((1, 2)), np.array([[30.0, 40.0]]), np.array([np.arctan2(40, 30)]))
    np.testing.assert_allclose(ahead, [[0.5, 1.0, 0.0]], atol=1e-12)  # 50 m dead ahead
    left = features(np.zeros((1, 2)), np.array([[0.0, 20.0]]), np.array([0.0]))
    np.testing.assert_allclose(left, [[0.2, 0.0, 1.0]], atol=1e-12)  # 20 m to port


def test_relabelled_observation_is_the_one_the_env_gives_for_that_goal():
    env = AUVGymEnv("goal")
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        obs, *_ = env.step(np.array([0.5, 0.3], dtype=np.float32))
    relabelled = env.relabel_observation(obs["observation"][None], obs["achieved_goal"][None],
                                         obs["desired_goal"][None])[0]
    np.testing.assert_allclose(relabelled, obs["observation"], atol=1e-12)
    other = obs["achieved_goal"][:2] + [0.0, 100.0]
    moved = env.relabel_observation(obs["observation"], obs["achieved_goal"], np.r_[other, 1.0, 0.0])
    assert moved[0] == pytest.approx(1.0) and np.array_equal(moved[3:], obs["observation"][3:])


def test_planning_mix_draws_the_task_from_the_seed_and_relabels_with_each_steps_radius():
    env = gymnasium.make("auv_mj/Planning-v0", tasks=("goal", "path_line"), weights=(1.0, 1.0))
    drawn = {}
    for seed in range(12):
        env.reset(seed=seed)
        drawn[seed] = env.unwrapped.task_name
    assert set(drawn.values()) == {"goal", "path_line"}
    for seed in (0, 5):
        env.reset(seed=seed)
        assert env.unwrapped.task_name == drawn[seed]  # the same seed, the same task
    # one relabelled batch over both tasks' steps: each step's own goal radius decides "reached"
    achieved = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    desired = np.array([[5.0, 0.0, 1.0, 0.0], [5.0, 0.0, 1.0, 0.0]])
    info = {"previous_achieved_goal": np.zeros((2, 4)), "goal_independent_reward": np.zeros(2),
            "collision": np.zeros(2), "left_map": np.zeros(2), "goal_radius": np.array([12.5, 2.0])}
    np.testing.assert_array_equal(env.unwrapped.compute_terminated(achieved, desired, info), [True, False])


@pytest.mark.parametrize("protection", [True, "speed-aware"])
def test_protection_in_the_loop_bends_the_heading_as_the_planner_policy_does(protection):
    from auv_mj.planners.avoidance import protect, protection_field
    from auv_mj.planners.deploy import deploy_env

    env = deploy_env(AUVGymEnv("obstacles", task_kwargs={"scenario": "a"}), protection=protection)
    bare = AUVGymEnv("obstacles", task_kwargs={"scenario": "a"})
    obs, _ = env.reset(seed=0)
    bare_obs, _ = bare.reset(seed=0)
    for _ in range(200):
        action = np.array([0.8, 0.0], dtype=np.float32)  # 1.8 m/s: the speed-aware domain acts on it
        obs, _, terminated, truncated, _ = env.step(action)
        fence = bare.task.map_fence(bare.physics)  # read by a domain with a geofence
        bare_obs, *_ = bare.step(protect(action, bare_obs["observation"], protection_field(protection), fence))
        np.testing.assert_allclose(obs["observation"], bare_obs["observation"], atol=1e-12)
        if terminated or truncated:
            break


def test_guide_option_is_checked_and_puts_the_map_goal_in_the_observation():
    from auv_mj.planners.deploy import deploy_env
    from auv_mj.planners.map_planner import PATH_STEP
    from auv_mj.tasks.planning_rewards import PROGRESS_GAIN

    with pytest.raises(ValueError, match="guide must be one of"):
        deploy_env(AUVGymEnv("obstacles"), guide="maps")
    with pytest.raises(ValueError, match="for the planning tasks"):
        deploy_env(AUVGymEnv("speed_heading"), guide="map")
    env = deploy_env(AUVGymEnv("obstacles", {"arena": "random", "tier": "hard"}), protection="speed-aware",
                     residual=1.0, guide="map")
    assert env.goal_dependent_actions  # its reward is not the task's compute_reward: no hindsight relabelling
    observation, _ = env.reset(seed=20_000)
    goal = np.asarray(env.unwrapped.task.goals[-1])
    straight = np.hypot(*(goal - observation["achieved_goal"][:2]))
    assert np.hypot(*(observation["desired_goal"][:2] - observation["achieved_goal"][:2])) >= straight - 1e-6
    rewards = []
    for _ in range(40):
        observation, reward, terminated, truncated, info = env.step(np.zeros(2))
        rewards.append(reward - info["goal_independent_reward"])
        assert not (terminated or truncated)
    assert max(abs(r) for r in rewards) <= PROGRESS_GAIN * PATH_STEP + 1e-9  # path progress, capped, no goal reached
    assert sum(rewards) > 0  # line of sight along the path gains on it
