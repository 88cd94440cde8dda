"""Rewards that cannot be gamed (issue 45): on every planning task and under every reward kind, reaching the goal
returns more than waiting just outside it or idling, at every discount (tasks/planning_rewards.py, "The success bonus").

Three policies run from the same seed: line of sight on the S-plane executor (`auv_mj.planners.guidance.classical`, the
`splane` policy) reaching the goal; a waiter that drives the same way and cuts its thrust STOP_MARGIN outside the
goal, with the route's last goal current; and an idler whose thrust is off from the start (action [-1, 0] is
V = 0). The waiter's episode is the reaching one up to the step where it stops, reward for reward, so the two
returns differ by gamma^split times the returns from that step on: those are compared, as a whole-episode
return at gamma = 0.9 loses them below the last bit of the shared part's (0.9^300 ~ 1e-14).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from auv_mj.planners import los3d
from auv_mj.planners.guidance import classical
from auv_mj.tasks import auv3d, planning_rewards, routes, suite
from auv_mj.tasks.registry import SUITE

GAMMAS = (0.9, 0.99, 0.999, 1.0)
STOP_MARGIN = 3.0
"""The waiter cuts its thrust this far [m] outside the goal's radius; it coasts about 1.5 m on."""
STOP_MARGIN_3D = 4.0
"""The same for the 6-DOF vehicle, which starts at 1 m/s and coasts farther."""
IDLE = np.array([-1.0, 0.0])
"""Thrust off: V = 0, the heading kept."""
SHORT_TUNNEL = {"arena": "random", "arena_spec": {"length": [300, 300]}}
"""A procedural tunnel of 300 m, the shortest the generator draws."""
CASES = [
    ("goal", {"random": 0}, 130.0),
    ("goal", {"random": 6}, 180.0),
    ("obstacles", {"random": 4}, 250.0),
    ("obstacles", {"random": 6}, 180.0),
    ("moving_obstacles", {"random": 0}, 130.0),
    ("waypoints", {"layout": "b2"}, 470.0),
    ("tunnel", {"random": 1, **SHORT_TUNNEL}, 320.0),
    ("path_line", {}, 430.0),
    ("path_curve", {}, 530.0),
]
"""(task, options, time limit [s]): layouts that line of sight reaches, with 20 s or more to spare."""


@dataclass
class Episode:
    rewards: np.ndarray
    infos: list
    achieved: np.ndarray
    desired: np.ndarray
    """The goal current when each step began."""
    split: int | None
    """The waiter's first step with its thrust cut (None: it never stopped)."""
    step_limit: int


def run(name: str, task_kwargs: dict, mode: str) -> Episode:
    """One episode of `mode` ("reach", "wait" or "idle") on task `name`."""
    env = suite.load("auv", name, task_kwargs=task_kwargs)
    task, reach = env.task, classical(env)
    time_step = env.reset()
    rewards, infos, achieved, desired, split = [], [], [], [], None
    while not time_step.last():
        last_leg = task.goal_index == len(task.goals) - 1
        near = np.hypot(*(task.goals[-1] - env.physics.pose()[:2])) < task.goal_radius + STOP_MARGIN
        if mode == "wait" and split is None and last_leg and near:
            split = len(rewards)
        action = IDLE if mode == "idle" or split is not None else reach(time_step)
        desired.append(time_step.observation["desired_goal"][:2])
        time_step = env.step(action)
        rewards.append(time_step.reward)
        infos.append(task.last_info)
        achieved.append(time_step.observation["achieved_goal"][:2])
    return Episode(np.array(rewards), infos, np.array(achieved), np.array(desired), split, task.step_limit)


def discounted(rewards: np.ndarray, gamma: float) -> float:
    return float(np.sum(rewards * gamma ** np.arange(len(rewards))))


def test_the_cases_cover_every_planning_task():
    assert {name for name, _, _ in CASES} == set(SUITE.tagged("planning"))


@pytest.mark.parametrize("kind", planning_rewards.REWARDS)
@pytest.mark.parametrize(("name", "options", "time_limit"), CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_reaching_the_goal_returns_more_than_waiting_outside_it_or_idling(name, options, time_limit, kind):
    task_kwargs = {**options, "reward": kind, "time_limit": time_limit}
    reach, wait, idle = (run(name, task_kwargs, mode) for mode in ("reach", "wait", "idle"))
    assert reach.infos[-1]["success"]
    assert wait.split is not None and not any(info["success"] for info in wait.infos + idle.infos)
    assert len(wait.rewards) > wait.split + 20  # it waited, not just failed
    np.testing.assert_array_equal(reach.rewards[:wait.split], wait.rewards[:wait.split])
    for gamma in GAMMAS:
        assert discounted(reach.rewards[wait.split:], gamma) > discounted(wait.rewards[wait.split:], gamma), gamma
        assert discounted(reach.rewards, gamma) > discounted(idle.rewards, gamma), gamma

    # The argument's premises, on these episodes: the idler runs to the time limit, so step_limit counts the
    # environment's steps; the success step pays STEP_REWARD_BOUND for every step left, itself included; and no
    # step of the last leg short of success pays more than STEP_REWARD_BOUND (suite: < 1).
    if not idle.infos[-1]["collision"]:
        assert len(idle.rewards) == idle.step_limit and idle.infos[-1]["steps_left"] == 1
    left = reach.step_limit - len(reach.rewards) + 1
    assert reach.infos[-1]["steps_left"] == left
    bonus = planning_rewards.STEP_REWARD_BOUND[kind] * left
    info = reach.infos[-1]
    own = {"suite": 0.0, "paper": info["reward_following"] + info["goal_independent_reward"]}.get(kind)
    if own is not None:
        assert reach.rewards[-1] == pytest.approx(own + bonus, abs=1e-9)
    last_leg = np.array([i["last_goal"] and not i["success"] for i in wait.infos + reach.infos])
    rewards = np.concatenate([wait.rewards, reach.rewards])[last_leg]
    if kind == "suite":
        assert np.all((rewards >= 0.0) & (rewards < 1.0))
    elif kind == "paper":
        assert np.all(rewards <= planning_rewards.STEP_REWARD_BOUND["paper"])


def test_the_bonus_covers_every_step_left_by_the_task_constants():
    """STEP_REWARD_BOUND is the most a last-leg step can pay short of success under Eq. (23)-(26), and a success
    step's own terms are positive, so bonus + terms > STEP_REWARD_BOUND * (steps left - 1) + any last step."""
    assert set(planning_rewards.STEP_REWARD_BOUND) == set(planning_rewards.REWARDS)
    k1, k2, k3 = planning_rewards.REWARD_WEIGHTS
    assert min(planning_rewards.REWARD_WEIGHTS) >= 0.0
    follows = (planning_rewards.FOLLOW_CLOSER, 0.0, planning_rewards.FOLLOW_FARTHER)
    avoids = (planning_rewards.COLLISION_REWARD, -0.5 * planning_rewards.AVOID_GAIN, 0.0)  # Eq. (24) lies in [-1, 0]
    step = max(k1 * f + k2 * a + k3 * planning_rewards.NAVIGATION_REWARD for f in follows for a in avoids)
    assert planning_rewards.STEP_REWARD_BOUND["paper"] == pytest.approx(step) == pytest.approx(0.45)
    floor = min(k1 * planning_rewards.FOLLOW_REACHED + k2 * a + k3 * planning_rewards.NAVIGATION_REWARD for a in avoids)
    assert planning_rewards.SUCCESS_TERMS_FLOOR == pytest.approx(floor) and floor > 0.0
    assert planning_rewards.STEP_REWARD_BOUND["suite"] == 1.0  # rewards.tolerance is at most 1
    for steps_left in (1, 2, 100, 8000):
        best_continuation = step * (steps_left - 1) + max(step, floor)  # a last step may enter and collide
        assert floor + planning_rewards.success_bonus("paper", steps_left) > best_continuation
        assert planning_rewards.success_bonus("suite", steps_left) == steps_left
    # "progress" needs none: by summation by parts its per-metre sum stays below PROGRESS_GAIN (d_0 - radius)
    # on any path outside the goal, whatever the discount; checked here on random paths.
    rng = np.random.default_rng(0)
    radius = routes.GOAL_RADIUS
    for _ in range(200):
        d = radius + rng.exponential(3.0, size=rng.integers(2, 60))
        gamma = rng.choice([0.0, 0.5, 0.9, 0.99, 1.0])
        gained = discounted(planning_rewards.PROGRESS_GAIN * (d[:-1] - d[1:]), gamma)
        assert gained < planning_rewards.PROGRESS_GAIN * (d[0] - radius) + 1e-12
    assert planning_rewards.success_bonus("progress", 100) == 0.0


@pytest.mark.parametrize("kind", ["paper", "progress"])
def test_compute_reward_pays_the_bonus_as_the_step_did(kind):
    options = {"layout": "b2", "reward": kind, "time_limit": 470.0}
    reach = run("waypoints", options, "reach")
    env = suite.load("auv", "waypoints", task_kwargs=options)
    task = env.task
    np.testing.assert_array_equal(task.compute_reward(reach.achieved, reach.desired, reach.infos), reach.rewards)
    # Relabelled to the achieved goal: reached, so the bonus is paid on the last leg's steps (a relabelled
    # episode ends there) and not on the earlier legs' (the route went on).
    as_dict = {key: np.array([info[key] for info in reach.infos]) for key in reach.infos[0]}
    relabelled = task.compute_reward(reach.achieved, reach.achieved, as_dict)
    last_leg = as_dict["last_goal"]
    assert 0 < last_leg.sum() < len(last_leg)
    bonus = planning_rewards.success_bonus(kind, as_dict["steps_left"]) * last_leg
    gained = routes.goal_distance(as_dict["previous_achieved_goal"], reach.achieved) * planning_rewards.PROGRESS_GAIN
    follow = planning_rewards.FOLLOW_REACHED + (gained if kind == "progress" else 0.0)
    np.testing.assert_allclose(relabelled, follow + as_dict["goal_independent_reward"] + bonus)


def test_compute_reward_pays_a_route_that_skipped_to_its_last_goal():
    env = suite.load("auv", "waypoints", task_kwargs={"layout": "b2", "reward": "paper"})
    info = {"previous_achieved_goal": np.zeros(2), "goal_independent_reward": -0.05, "collision": False,
            "left_map": False, "steps_left": 10, "goal_radius": 12.5}
    far = np.array([100.0, 0.0])
    skipped = env.task.compute_reward(np.zeros(2), far, {**info, "last_goal": False, "success": True})
    assert skipped == pytest.approx(-0.05 + planning_rewards.success_bonus("paper", 10))
    assert env.task.compute_reward(np.zeros(2), np.zeros(2), {**info, "last_goal": False, "success": False}) == \
        pytest.approx(planning_rewards.FOLLOW_REACHED - 0.05)
    collided = {**info, "last_goal": True, "success": False, "collision": True}
    assert env.task.compute_reward(np.zeros(2), np.zeros(2), collided) \
        == pytest.approx(planning_rewards.FOLLOW_REACHED - 0.05)


def test_a_procedural_tunnel_counts_the_steps_of_its_own_time_limit():
    env = suite.load("auv", "tunnel", task_kwargs={"random": 1, **SHORT_TUNNEL})
    time_step, steps = env.reset(), 0
    while not time_step.last():
        time_step, steps = env.step(IDLE), steps + 1
    assert env.task.last_info["event"] == "" and env.task.last_info["steps_left"] == 1
    assert steps == env.task.step_limit < env.task.time_limit_steps


# --- the 6-DOF planning tasks ----------------------------------------------------------------------------------


def run_3d(name: str, seed: int, mode: str) -> tuple[np.ndarray, str, int | None]:
    """One goal3d / tunnel3d episode of `mode`: (rewards, last event, the waiter's split step)."""
    env = suite.load("auv3d", name, task_kwargs={"random": seed})
    task, reach = env.task, los3d.los_policy(env, avoid=True)
    time_step, rewards, split = env.reset(), [], None
    while not time_step.last():
        near = np.linalg.norm(task.goal - env.physics.position()) < auv3d.GOAL_RADIUS + STOP_MARGIN_3D
        if mode == "wait" and split is None and near:
            split = len(rewards)
        action = np.array([-1.0, 0.0, 0.0]) if mode == "idle" or split is not None else reach(time_step)
        time_step = env.step(action)
        rewards.append(time_step.reward)
    return np.array(rewards), task.last_info["event"], split


@pytest.mark.parametrize(("name", "seed"), [("goal3d", 1), ("goal3d", 2), ("tunnel3d", 0), ("tunnel3d", 1)])
def test_3d_planning_reward_pays_reaching_over_waiting_or_idling(name, seed):
    """The 6-DOF tasks' reward (progress - STEP_COST, +GOAL_REWARD, COLLISION_REWARD) telescopes as "progress"
    does: a path that stays outside the goal earns < d_0 - radius, reaching it at least that + GOAL_REWARD.

    Against the waiter the comparison holds at every discount, from the step where the two part. Against an idler
    (thrust off from the start) it is a whole-episode comparison, which a distance-shaped reward cannot win at a
    short horizon when the way to the goal first turns away from it (tunnel3d, seed 0: at gamma = 0.9 the first
    dozen steps decide, and the turn costs more than idling); it holds from gamma = 0.99 on."""
    assert auv3d.GOAL_REWARD - auv3d.STEP_COST > 0.0 and auv3d.COLLISION_REWARD < 0.0 < auv3d.STEP_COST
    (reach, reach_event, _), (wait, wait_event, split), (idle, idle_event, _) = (
        run_3d(name, seed, mode) for mode in ("reach", "wait", "idle"))
    assert reach_event == "goal" and "goal" not in (wait_event, idle_event)
    np.testing.assert_array_equal(reach[:split], wait[:split])
    for gamma in GAMMAS:
        assert discounted(reach[split:], gamma) > discounted(wait[split:], gamma), gamma
        if gamma >= 0.99:
            assert discounted(reach, gamma) > discounted(idle, gamma), gamma

