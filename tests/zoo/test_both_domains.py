"""The 6-DOF domain "auv3d" as a first-class domain: every registered policy runs on its tasks or is refused in one
line, commands cover both domains, goal3d and tunnel3d are goal envs that HER can relabel, their arenas follow the
seed ranges, and the tracking tasks report no success."""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj import seeds
from auv_mj.benchmark.metrics import summarise
from auv_mj.cli.evaluate import format_table
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.tasks import auv3d, suite
from auv_mj.zoo import registry
from auv_mj.zoo.spec import PolicySpec

pytestmark = pytest.mark.filterwarnings("ignore:.*Box observation space m.* value is .*infinity")
TASKS_3D = [name for _, name in suite.TASKS_3D]
GOAL_TASKS_3D = ("goal3d", "tunnel3d")
STEPS = 5


# --- domain parity ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("task", TASKS_3D)
@pytest.mark.parametrize("name", list(registry.POLICIES))
def test_every_policy_runs_five_steps_on_a_6dof_task_or_is_refused_in_one_line(name, task):
    spec = registry.POLICIES[name]
    expected = "auv3d" in spec.domains and task in registry.domain_tasks("auv3d", spec.tasks)
    try:
        env, policy = registry.env_and_policy(name, task, seed=0)
    except ValueError as e:
        message = str(e)
        assert not expected, f"{name} should run on {task}: {message}"
        assert "\n" not in message and f"'{name}'" in message and f"'{task}'" in message
        assert "6-DOF" in message and "option" not in message  # no option the user did not give
        assert all(other in message for other in registry.task_policies(task))
        return
    assert expected
    record = record_episode(env, policy, max_steps=STEPS, task=task, policy_name=name, seed=0)
    assert record.steps == STEPS and np.all(np.isfinite(record.action))


def test_the_refusal_names_what_the_policy_runs_on_and_the_task_s_policies():
    with pytest.raises(ValueError) as caught:
        registry.resolve_tasks("tunnel3d", "bug")
    message = str(caught.value)
    assert message.startswith("policy 'bug' runs on the planar planning tasks (goal, ")
    known = [n for n, s in registry.POLICIES.items() if "auv3d" in s.domains and s.tasks in ("planning", "any")]
    assert f"'tunnel3d' is a 6-DOF planning task: its policies are {', '.join(known)}" in message
    assert {"splane", "los-avoid", "map-replan", "oracle", "random"} <= set(known)


def test_all_and_the_tags_cover_both_domains_for_the_policies_that_run_there():
    every = [name for _, name in suite.ALL_TASKS]
    assert sorted(registry.resolve_tasks("all", "splane")) == sorted(every)
    assert set(registry.resolve_tasks("planning", "los-avoid")) >= {"goal", "tunnel", "goal3d", "tunnel3d"}
    assert "depth_heading" in registry.resolve_tasks("executor", "splane")
    assert "depth_heading" in registry.resolve_tasks("benchmarking", "random")
    assert registry.resolve_tasks("auv3d", "splane") == TASKS_3D
    assert not set(registry.resolve_tasks("all", "bug")) & set(TASKS_3D)
    assert registry.resolve_tasks("all", "executor") == ["speed_heading"]
    with pytest.raises(ValueError, match="runs on the planar planning tasks .* none of 'auv3d'"):
        registry.resolve_tasks("auv3d", "bug")


def test_load_policy_refuses_a_planar_policy_in_a_6dof_environment():
    env = suite.load("auv3d", "goal3d", task_kwargs={"random": 0})
    with pytest.raises(ValueError, match="policy 'bug' runs on the planar planning tasks .*, not on a 6-DOF task"):
        registry.load_policy("bug", env)
    with pytest.raises(ValueError, match="'goal3d' is a 6-DOF planning task"):
        registry.load_policy("los-fast", env, "goal3d")
    assert callable(registry.load_policy("los-avoid", env))


def test_a_spec_names_known_domains_and_the_table_shows_them():
    with pytest.raises(ValueError, match="PolicySpec.domains"):
        PolicySpec("x", build=lambda d: None, domains=("mars",))
    with pytest.raises(ValueError, match="PolicySpec.domains"):
        PolicySpec("x", build=lambda d: None, domains="auv")
    assert registry.runs_on_label(registry.POLICIES["splane"]) == "planar + 6-DOF tasks"
    assert registry.runs_on_label(registry.POLICIES["los-avoid"]) == "planar + 6-DOF planning tasks"
    assert registry.runs_on_label(registry.POLICIES["bug"]) == "planar planning tasks"
    assert "| `random` | reference | planar + 6-DOF tasks |" in registry.markdown_table()


# --- goal interface -----------------------------------------------------------------------------------------


def _step_infos(env, policy, steps: int):
    """(achieved, desired, reward, terminated, info) of each step of a Gymnasium goal env under `policy(obs)`."""
    observation, _ = env.reset(seed=10_000)
    rows = []
    for _ in range(steps):
        observation, reward, terminated, truncated, info = env.step(policy(observation))
        rows.append((observation, reward, terminated, info))
        if terminated or truncated:
            break
    return rows


@pytest.mark.parametrize("task", GOAL_TASKS_3D)
def test_reward_is_compute_reward_over_an_episode_one_by_one_and_batched(task):
    env = gymnasium.make(auv3d_gym_id(task), task_kwargs={"time_limit": 15.0}).unwrapped
    assert isinstance(env.observation_space, gymnasium.spaces.Dict)
    assert set(env.observation_space.spaces) == {"observation", "achieved_goal", "desired_goal"}
    rng = np.random.default_rng(0)
    rows = _step_infos(env, lambda _: rng.uniform(-1, 1, 3).astype(np.float32), 40)
    assert len(rows) >= 20
    for observation, reward, terminated, info in rows:
        assert reward == env.compute_reward(observation["achieved_goal"], observation["desired_goal"], info)
        assert terminated == bool(env.compute_terminated(observation["achieved_goal"], observation["desired_goal"],
                                                         info)) or not terminated
    achieved = np.array([r[0]["achieved_goal"] for r in rows])
    desired = np.array([r[0]["desired_goal"] for r in rows])
    batched = env.compute_reward(achieved, desired, [r[3] for r in rows])
    np.testing.assert_array_equal(batched, [r[1] for r in rows])


def test_compute_reward_against_its_terms():
    task = auv3d.goal3d(random=0).task
    previous, desired = np.zeros(5), np.array([10.0, 0.0, -5.0, 1.0, 0.0])
    info = {"previous_achieved_goal": np.stack([previous] * 3), "goal_independent_reward": np.array([-0.01] * 3),
            "collision": np.array([False, False, True]), "left_map": np.zeros(3, bool)}
    achieved = np.array([[3.0, 4.0, 0.0, 1, 0], [9.0, 0.0, -4.0, 1, 0], [9.0, 0.0, -4.0, 1, 0]])
    before = math.sqrt(125.0)
    expected = [before - math.sqrt(49 + 16 + 25) - 0.01,             # 4.39 m nearer
                before - math.sqrt(2.0) + auv3d.GOAL_REWARD - 0.01,  # within GOAL_RADIUS: the bonus
                before - math.sqrt(2.0) - 0.01]                      # within it but collided: no bonus
    np.testing.assert_allclose(task.compute_reward(achieved, np.stack([desired] * 3), info), expected, rtol=1e-12)
    np.testing.assert_array_equal(task.compute_terminated(achieved, np.stack([desired] * 3), info),
                                  [False, True, True])


def test_goal3d_relabelling_recomputes_the_goal_in_the_observation():
    env = auv3d.goal3d(random=10_000, time_limit=5.0)
    step = env.reset()
    for _ in range(4):
        step = env.step(np.array([0.5, 0.3, 0.2]))
    obs, achieved, desired = (step.observation[k] for k in ("observation", "achieved_goal", "desired_goal"))
    np.testing.assert_allclose(env.task.relabel_observation(obs, achieved, desired), obs, atol=1e-9)
    other = desired + np.array([-20.0, 15.0, 4.0, 0.0, 0.0])
    relabelled = env.task.relabel_observation(obs, achieved, other)
    offset = other[:3] - achieved[:3]
    heading = math.atan2(achieved[4], achieved[3])
    bearing = math.atan2(offset[1], offset[0]) - heading
    np.testing.assert_allclose(relabelled[auv3d.TARGET_ENTRIES],
                               [np.linalg.norm(offset), math.cos(bearing), math.sin(bearing), -offset[2]], atol=1e-9)
    keep = np.ones(obs.size, bool)
    keep[auv3d.TARGET_ENTRIES] = False
    np.testing.assert_array_equal(relabelled[keep], obs[keep])
    tunnel = auv3d.tunnel3d(random=0, time_limit=5.0)
    first = tunnel.reset().observation
    np.testing.assert_array_equal(tunnel.task.relabel_observation(first["observation"], first["achieved_goal"],
                                                                  other), first["observation"])


def auv3d_gym_id(task: str) -> str:
    from auv_mj.tasks.gym_adapter import gym_id

    return gym_id(task)


def test_train_finds_the_6dof_gymnasium_ids_by_task_name():
    from auv_mj.cli.train import task_env_id

    assert [task_env_id(t) for t in TASKS_3D] == ["auv_mj/DepthHeading-v0", "auv_mj/Goal3D-v0", "auv_mj/Tunnel3D-v0"]
    assert task_env_id("moving_obstacles") == "auv_mj/MovingObstacles-v0"


# --- seeds --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("task, factory", [("goal3d", auv3d.Goal3D), ("tunnel3d", auv3d.Tunnel3D)])
def test_the_first_episode_s_arena_is_drawn_from_the_task_seed(task, factory):
    drawer = factory(random=0)
    for seed in (seeds.TEST.start, seeds.VALIDATION.start, seeds.train_seed(0, 0)):
        env = suite.load("auv3d", task, task_kwargs={"random": seed, "time_limit": 1.0})
        env.reset()
        _, start, _, goal, path = drawer.draw_arena(np.random.RandomState(seed))
        np.testing.assert_array_equal(env.task.goal, goal)
        np.testing.assert_array_equal(env.physics.position(), start)
        gym_env = gymnasium.make(auv3d_gym_id(task), task_kwargs={"time_limit": 1.0}).unwrapped
        observation, _ = gym_env.reset(seed=seed)
        np.testing.assert_array_equal(observation["desired_goal"][:3], goal)
    goals = {seed: suite.load("auv3d", task, task_kwargs={"random": seed}) for seed in (10_000, 20_000)}
    for env in goals.values():
        env.reset()
    assert not np.allclose(goals[10_000].task.goal, goals[20_000].task.goal)
    fixed = [suite.load("auv3d", task, task_kwargs={"random": s, "arena": "fixed"}) for s in (10_000, 20_000)]
    for env in fixed:
        env.reset()
    np.testing.assert_array_equal(fixed[0].task.goal, fixed[1].task.goal)


# --- tracking tasks -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("task", ["speed_heading", "depth_heading"])
def test_tracking_tasks_report_no_success_and_their_mae_in_the_table(task):
    rows = []
    for seed in (0, 1):
        env, policy = registry.env_and_policy("splane", task, seed, {"time_limit": 12.0})
        rows.append(episode_metrics(record_episode(env, policy, task=task, policy_name="splane", seed=seed)))
    assert all(r["success"] is None and r["time_to_goal"] is None and r["outcome"] == "timeout" for r in rows)
    summary = summarise(rows)
    assert summary["success_rate"] is None and summary["time_to_goal"] is None
    assert summary["mae_speed"] is not None and summary["mae_heading"] is not None
    table = format_table({"policy": "splane", "episodes": 2, "seed": 0, "tasks": {task: summary}})
    header, row = table.splitlines()[1], table.splitlines()[3]
    cells = dict(zip(header.split()[1:-1], row.split()[1:], strict=False))
    assert cells["success_rate"] == "n/a" and cells["time_to_goal"] == "n/a"
    assert float(cells["mae_heading"]) == pytest.approx(summary["mae_heading"], abs=5e-4)
    if task == "depth_heading":
        assert float(cells["mae_depth"]) == pytest.approx(summary["mae_depth"], abs=5e-4)
    else:
        assert "mae_depth" not in header
    planning = episode_metrics(record_episode(*registry.env_and_policy("splane", "goal3d", 0), max_steps=3))
    assert planning["success"] is False
