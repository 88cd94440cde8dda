"""One Planner protocol (`auv_mj.episode.Planner`: `reset()`, `act(time_step)`) for every policy the zoo builds,
and the episode loop calling it."""

from __future__ import annotations

import types

import numpy as np
import pytest

from auv_mj.episode import FunctionPlanner, Planner, PlannerBase, as_planner, record_episode
from auv_mj.tasks import suite
from auv_mj.zoo import registry


@pytest.mark.parametrize(("name", "task"), sorted(
    (n, task) for n, s in registry.POLICIES.items() if s.tasks != "executor"
    for domain, task in (("auv", "obstacles"), ("auv3d", "goal3d")) if domain in s.domains))
def test_every_registered_planning_policy_is_a_planner(name, task):
    env = registry.make_env(name, task, 3)
    planner = registry.make_policy(name, env, 3, task)
    assert isinstance(planner, Planner) and not isinstance(planner, types.FunctionType)
    planner.reset()
    action = planner.act(env.reset())
    assert np.shape(action) == env.action_spec().shape and np.all(np.isfinite(action))


def test_a_plain_function_becomes_a_planner_and_a_planner_stays_itself():
    calls = []
    plain = as_planner(lambda time_step: calls.append(time_step) or np.zeros(2))
    assert isinstance(plain, FunctionPlanner)
    plain.reset()  # nothing to reset
    assert np.array_equal(plain.act("ts"), np.zeros(2)) and calls == ["ts"]
    kept = FunctionPlanner(lambda time_step: np.ones(2))
    assert as_planner(kept) is kept
    with pytest.raises(TypeError, match="Planner"):
        as_planner(42)


def test_the_episode_loop_resets_the_planner_once_then_acts_every_step():
    class Counting(PlannerBase):
        def __init__(self):
            self.resets, self.acts = 0, 0

        def reset(self):
            self.resets += 1

        def act(self, time_step):
            self.acts += 1
            return np.zeros(2)

    env = suite.load("auv", "goal", task_kwargs={"random": 0})
    planner = Counting()
    record = record_episode(env, planner, max_steps=7)
    assert planner.resets == 1 and planner.acts == 7 == len(record.action)
    record_episode(env, planner, max_steps=3)
    assert planner.resets == 2 and planner.acts == 10


def test_suite_load_takes_every_executor_name():
    """`suite.load` takes every executor name: the tasks' own S-planes, and the learned ones through the declared
    entry points (the tasks name no layer above them); an episode on a named executor is the zoo's episode on it,
    and both know the same names."""
    from auv_mj.benchmark.runner import run_episode
    from auv_mj.episode import episode_metrics
    from auv_mj.tasks.executors import executor_names
    from auv_mj.zoo.executors import EXECUTORS

    assert executor_names() == list(EXECUTORS["auv"]) and executor_names("auv3d") == list(EXECUTORS["auv3d"])
    for name in executor_names():
        env = suite.load("auv", "path_line", task_kwargs={"random": 0, "executor": name})
        assert callable(env.task.executor)
    with pytest.raises(ValueError, match="executor 'warp'"):
        suite.load("auv", "path_line", task_kwargs={"random": 0, "executor": "warp"})
    with pytest.raises(ValueError, match="did you mean 'ocean-executor'"):
        suite.load("auv", "path_line", task_kwargs={"random": 0, "executor": "ocean-executer"})
    env = suite.load("auv", "path_line", task_kwargs={"random": 0, "executor": "ocean-executor"})
    ours = episode_metrics(record_episode(env, registry.make_policy("splane", env, 0, "path_line"), 40))
    zoo = run_episode("splane", "path_line", 0, {"executor": "ocean-executor"}, 40)
    assert ours["path_length"] == zoo["path_length"] and ours["return"] == zoo["return"]
