"""The batched planning env (`auv_mj.tasks.vector.AUVVectorEnv`, issue 45) against the single one (`AUVGymEnv`).

THE test: sub-environment i reset with seed s runs exactly the single environment's episode for seed s under the
same actions -- observations, rewards, terminated / truncated and every info entry to 1e-9 -- for the four
planning tasks, both tiers, ideal and ocean water, through autoresets (which continue each sub-environment's
RandomState, as `AUVGymEnv.reset()` without a seed does). The actions steer at the goal with noise, so that
episodes end in goals, collisions and time limits.
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from side_by_side import TOLERANCE
from side_by_side import run_side_by_side as side_by_side

import auv_mj.tasks  # noqa: F401  (registers the ids)
from auv_mj.tasks.gym_adapter import AUVGymEnv
from auv_mj.tasks.vector import AUVVectorEnv

SEEDS = (3, 4, 5)
TIME_LIMIT = 25.0
"""Seconds of an episode here (50 steps): every sub-environment reaches its time limit at least once."""
STEPS = 60
CASES = [("goal", "standard", water) for water in ("ideal", "ocean")] + [
    (task, tier, water) for task in ("obstacles", "moving_obstacles", "tunnel") for tier in ("standard", "hard")
    for water in ("ideal", "ocean")]


def task_options(task: str, tier: str, water: str) -> dict:
    options = {"conditions": water, "time_limit": TIME_LIMIT}
    if task != "goal":
        options.update(arena="random", tier=tier)
    return options


def steer(observation: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Actions towards the goal's bearing (relative observation: cos, sin at 1, 2), with noise, float32."""
    bearing = np.arctan2(observation[:, 2], observation[:, 1])
    heading = np.clip(bearing / (math.pi / 2) + rng.normal(0.0, 0.3, len(bearing)), -1.2, 1.2)
    speed = rng.uniform(0.5, 1.0, len(bearing))
    return np.stack([speed, heading], axis=1).astype(np.float32)


def run_side_by_side(task: str, options: dict, mode: AutoresetMode, steps: int = STEPS) -> dict:
    """The batch beside one AUVGymEnv per sub-environment on `steer`'s actions (`side_by_side`)."""
    vector = AUVVectorEnv(task, len(SEEDS), options, threads=2, autoreset_mode=mode)
    return side_by_side(vector, [AUVGymEnv(task, options) for _ in SEEDS], SEEDS, mode, steer, steps)


@pytest.mark.parametrize(("task", "tier", "water"), CASES)
def test_sub_environment_is_the_single_environment(task, tier, water):
    seen = run_side_by_side(task, task_options(task, tier, water), AutoresetMode.NEXT_STEP)
    assert seen["autoresets"] >= len(SEEDS)  # every sub-environment went through an autoreset
    assert seen["truncated"] >= 1


ISSUE_51_OPTIONS = {"reward": "geodesic", "observation": "planner", "action": "rate"}
"""The learning problem's options (issue 51): the geodesic reward, the planner observation, the rate action."""
MAP_OPTIONS = ISSUE_51_OPTIONS | {"observation": "planner-map"}
"""The same with the vehicle's own sonar map in the observation."""


@pytest.mark.parametrize(("task", "tier", "water", "changes"), [
    ("goal", "standard", "ideal", ISSUE_51_OPTIONS),
    ("obstacles", "standard", "ideal", ISSUE_51_OPTIONS),
    ("obstacles", "hard", "ocean", ISSUE_51_OPTIONS),
    ("tunnel", "hard", "ideal", ISSUE_51_OPTIONS),
    ("tunnel", "standard", "ideal", {"reward": "geodesic"}),
    ("tunnel", "hard", "ocean", MAP_OPTIONS),
    ("moving_obstacles", "standard", "ocean", MAP_OPTIONS),
])
def test_sub_environment_is_the_single_environment_on_the_learning_problem(task, tier, water, changes):
    """The geodesic reward (its fields, asked for the batch at once), the planner observation (route target, pose,
    previous action, geofence; with "planner-map" the sonar map too, one map a row through its autoresets) and its
    info["privileged"], and the rate action are the single env's in the batch."""
    seen = run_side_by_side(task, task_options(task, tier, water) | changes, AutoresetMode.NEXT_STEP)
    assert seen["autoresets"] >= len(SEEDS)


def test_same_step_autoreset_is_the_single_environment_on_the_learning_problem():
    options = task_options("moving_obstacles", "standard", "ocean") | ISSUE_51_OPTIONS
    seen = run_side_by_side("moving_obstacles", options, AutoresetMode.SAME_STEP)
    assert seen["autoresets"] >= len(SEEDS)


def test_same_step_autoreset_is_the_single_environment():
    seen = run_side_by_side("moving_obstacles", task_options("moving_obstacles", "standard", "ocean"),
                            AutoresetMode.SAME_STEP)
    assert seen["autoresets"] >= len(SEEDS)


@pytest.mark.parametrize(("task", "changes", "event", "steps"), [
    ("goal", {"goal_radius": 50.0, "time_limit": 150.0}, "goal", 230),
    ("obstacles", {"time_limit": 60.0}, "collision", 140),
    ("tunnel", {}, "subgoal", 140),
])
def test_episodes_end_every_way(task, changes, event, steps):
    """Goals, sub-goals and collisions happen (and match) under the steering actions."""
    options = task_options(task, "standard", "ideal") | changes
    seen = run_side_by_side(task, options, AutoresetMode.NEXT_STEP, steps=steps)
    assert seen.get(event, 0) >= 1, seen


def test_make_vec_returns_the_batch():
    env = gymnasium.make_vec("auv_mj/Tunnel-v0", num_envs=2, vectorization_mode="vector_entry_point",
                             task_kwargs={"arena": "random"}, threads=1)
    single = AUVGymEnv("tunnel", {"arena": "random"})
    assert isinstance(env.unwrapped, AUVVectorEnv)
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert env.single_observation_space == single.observation_space
    assert env.single_action_space == single.action_space
    assert env.observation_space["observation"].shape == (2, *single.observation_space["observation"].shape)
    observation, _ = env.reset(seed=7)
    assert env.observation_space.contains(observation)
    env.close()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"num_envs": 0}, "num_envs"),
    ({"threads": 0}, "threads"),
    ({"autoreset_mode": "Disabled"}, "autoreset_mode"),
    ({"task_kwargs": {"random": 3}}, "reset"),
])
def test_bad_options_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        AUVVectorEnv("goal", **({"num_envs": 1} | kwargs))


def test_bad_actions_are_refused():
    env = AUVVectorEnv("goal", 2, threads=1)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([[0.0, 0.0], [np.nan, 0.0]]))
    with pytest.raises(ValueError, match="AUVGymEnv"):
        gymnasium.make_vec("auv_mj/Goal-v0", num_envs=2, protection=True)


def test_the_bench_times_the_batch_over_a_learners_cycle_and_refuses_a_seed_count_that_does_not_fit(monkeypatch):
    """`vector_bench.cycle_rate` resets with the learner's seeds (once untimed, once timed) and then steps."""
    from auv_mj.speed import vector as vector_bench

    resets, steps = [], []
    reset, step = AUVVectorEnv.reset, AUVVectorEnv.step
    monkeypatch.setattr(AUVVectorEnv, "reset", lambda self, **kw: resets.append(kw["seed"]) or reset(self, **kw))
    monkeypatch.setattr(AUVVectorEnv, "step", lambda self, a: steps.append(a.shape) or step(self, a))
    with pytest.raises(ValueError, match="one seed per env: 1 seeds for 2 envs"):
        vector_bench.cycle_rate("goal", {}, 2, 1, [1_000_000], 3)
    assert vector_bench.cycle_rate("goal", {}, 2, 1, [1_000_000, 1_000_001], 3) > 0
    assert resets == [[1_000_000, 1_000_001]] * 2 and steps == [(2, 2)] * 3


def test_a_reward_constant_changes_the_suite_task_and_the_batch_alike(monkeypatch):
    """The planning step is written once (`planning_step.step_outcome`, called with N = 1 by the suite task and with N
    by the batch): a constant at the head of the rewards module, here Eq. (25)'s r_navigation, changes the suite
    task's reward and the batched env's by the same amount."""
    from auv_mj.tasks import planning_rewards, planning_step, suite

    actions = np.array([[0.5, 0.2], [1.0, -0.3], [0.0, 0.0], [0.8, 0.1]])

    def rewards() -> tuple[np.ndarray, np.ndarray]:
        env = suite.load("auv", "goal", task_kwargs={"reward": "paper", "random": 7})
        env.reset()
        single = np.array([env.step(a).reward for a in actions])
        batch = AUVVectorEnv("goal", 2, task_kwargs={"reward": "paper"}, threads=1)
        batch.reset(seed=[7, 7])
        batched = np.array([batch.step(np.stack([a, a]))[1] for a in actions])
        return single, batched

    sizes = []
    step_outcome = planning_step.step_outcome
    monkeypatch.setattr(planning_step, "step_outcome", lambda routes, rows, reached, *args: sizes.append(len(reached))
                        or step_outcome(routes, rows, reached, *args))
    single, batched = rewards()
    assert sizes == [1] * len(actions) + [2] * len(actions)
    np.testing.assert_allclose(batched, np.stack([single, single], axis=1), rtol=0, atol=TOLERANCE)
    monkeypatch.setattr(planning_rewards, "NAVIGATION_REWARD", planning_rewards.NAVIGATION_REWARD - 0.25)
    changed_single, changed_batched = rewards()
    np.testing.assert_allclose(changed_single - single, -0.25, rtol=0, atol=1e-12)
    np.testing.assert_allclose(changed_batched - batched, -0.25, rtol=0, atol=1e-12)
