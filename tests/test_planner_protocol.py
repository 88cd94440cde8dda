"""One Planner protocol (`auv_mj.episode.Planner`: `reset()`, `act(time_step)`) for every policy the zoo builds,
and the episode loop calling it."""

from __future__ import annotations

import types

import numpy as np
import pytest

from auv_mj.episode import FunctionPlanner, Planner, PlannerBase, as_planner, record_episode
from auv_mj.tasks import suite
from auv_mj.zoo import registry


@pytest.mark.parametrize("name", sorted(n for n, s in registry.POLICIES.items() if s.tasks != "executor"))
def test_every_registered_planning_policy_is_a_planner(name):
    env = registry.make_env(name, "obstacles", 3)
    planner = registry.make_policy(name, env, 3, "obstacles")
    assert isinstance(planner, Planner) and not isinstance(planner, types.FunctionType)
    planner.reset()
    action = planner.act(env.reset())
    assert np.shape(action) == (2,) and np.all(np.isfinite(action))


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
