"""Discounted returns of whole episodes under reward="geodesic", and the closed form its shaping telescopes to: what
the planar and the 6-DOF learning-problem tests check their episodes against, written once."""

from __future__ import annotations

import numpy as np

from auv_mj.tasks import planning_rewards

GAMMA = planning_rewards.GEODESIC_DISCOUNT


def discounted(rewards, gamma: float = GAMMA) -> float:
    """sum_t gamma^t r_t."""
    rewards = np.asarray(rewards, dtype=float)
    return float(np.sum(rewards * gamma ** np.arange(len(rewards))))


def closed_form(infos: list[dict]) -> float:
    """The discounted return that potential-based shaping telescopes to (module docstring of `planning_rewards`): the
    route length at the start, less the discounted route length where the episode ended, the step costs, the bonus or
    the penalty at the end."""
    last, end = infos[-1], GAMMA ** len(infos)
    value = planning_rewards.PROGRESS_GAIN * (infos[0]["route_distance_before"] - end * last["route_distance"])
    value -= planning_rewards.GEODESIC_STEP_COST * (1 - end) / (1 - GAMMA)
    if last["success"]:
        value += end / GAMMA * planning_rewards.GEODESIC_SUCCESS_BONUS
    if last["collision"] or last["left_map"]:
        value -= end / GAMMA * planning_rewards.GEODESIC_COLLISION_PENALTY
    return value


def episode(task: str, tier: str, seed: int, driver: str, idle: np.ndarray, idle_from: int | None = None,
            idle_until: int = 0) -> tuple[np.ndarray, list[dict]]:
    """One whole episode under reward="geodesic" on a random arena of `tier`: `driver` (a zoo name) acts, except
    that `idle` (thrust off) is the action before step `idle_until` (a late start) and from step `idle_from` on
    (waiting there until the episode ends). Returns the rewards and the step infos."""
    from auv_mj.zoo import env_and_policy

    env, policy = env_and_policy(driver, task, seed, {"arena": "random", "tier": tier, "reward": "geodesic"})
    time_step, rewards, infos = env.reset(), [], []
    while not time_step.last():
        t = len(rewards)
        waiting = t < idle_until or (idle_from is not None and t >= idle_from)
        time_step = env.step(idle if waiting else policy(time_step))
        rewards.append(time_step.reward)
        infos.append(env.task.last_info)
    return np.array(rewards), infos


def trap_runs(task: str, tier: str, seed: int, idle: np.ndarray, late_steps: int) -> dict:
    """The five episodes of a trap arena the learning-problem tests compare: "round" (the oracle), "crash"
    (`splane`), "wait_start" and "wait_half" (the oracle idling from the start or half-way) and "late" (the oracle
    after `late_steps` idle steps); each (rewards, infos). Asserts that the oracle reached the goal, `splane` crashed
    and the waits did not reach it, and that each return is its closed form."""
    runs = {"round": episode(task, tier, seed, "oracle", idle), "crash": episode(task, tier, seed, "splane", idle)}
    half = len(runs["round"][0]) // 2
    runs["wait_start"] = episode(task, tier, seed, "oracle", idle, idle_from=0)
    runs["wait_half"] = episode(task, tier, seed, "oracle", idle, idle_from=half)
    runs["late"] = episode(task, tier, seed, "oracle", idle, idle_until=late_steps)
    assert runs["round"][1][-1]["success"] and runs["crash"][1][-1]["collision"] and runs["late"][1][-1]["success"]
    assert not runs["wait_start"][1][-1]["success"] and not runs["wait_half"][1][-1]["success"]
    for name in ("round", "crash", "wait_half"):
        rewards, infos = runs[name]
        assert abs(discounted(rewards) - closed_form(infos)) <= 1e-6 + 1e-9 * abs(closed_form(infos)), name
    print(task, tier, seed, {name: round(discounted(r), 1) for name, (r, _) in runs.items()},
          {name: len(r) for name, (r, _) in runs.items()})
    return runs
