"""The map-memory input of a map-guided planner (guide="map-memory", issue 30): the scan cast on the sonar map, where
it sits in the observation, and the widening of a network trained without it."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch
from test_hard_tier_arenas import CUP, _known_arena

from auv_mj.agents.normalizer import Normalizer
from auv_mj.agents.offpolicy.networks import Actor, Critic, widen_inputs
from auv_mj.arenas import grid
from auv_mj.arenas.sonar_memory import MEMORY_BEAMS, MEMORY_RANGE
from auv_mj.planners.deploy import deploy_env
from auv_mj.planners.map_planner import MapGuide
from auv_mj.sim.sonar import SONAR_NAMES
from auv_mj.tasks import planning_observation

CHECKPOINTS = Path(__file__).resolve().parents[2] / "agents" / "checkpoints"


def _entry_distance(origin, angle, boxes, cell) -> float:
    """Slab method: the distance along the ray to where it first enters one of the axis-aligned cells `boxes`
    ((i, j) of a grid with its origin at 0), or inf."""
    direction = np.array([math.cos(angle), math.sin(angle)])
    best = math.inf
    for i, j in boxes:
        low, high = np.array([i, j]) * cell, np.array([i + 1, j + 1]) * cell
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (low - origin) / direction, (high - origin) / direction
        t_near = np.max(np.where(direction == 0, np.where((origin >= low) & (origin < high), -np.inf, np.inf),
                                 np.minimum(t1, t2)))
        t_far = np.min(np.where(direction == 0, np.inf, np.maximum(t1, t2)))
        if t_near <= t_far and t_far >= 0:
            best = min(best, max(t_near, 0.0))
    return best


def test_ray_ranges_find_the_first_occupied_cell_within_half_a_cell():
    """Against the exact ray-box entry distance (slab method): the cast range is the first half-cell sample inside
    an occupied cell, so it lies at or beyond the exact entry and less than half a cell past it."""
    rng = np.random.RandomState(0)
    g = grid.Grid(np.zeros(2), 2.0, (60, 60))
    occupied = rng.uniform(size=g.shape) < 0.03
    boxes = list(zip(*np.nonzero(occupied), strict=True))
    checked = 0
    for _ in range(200):
        origin = rng.uniform(20.0, 100.0, 2)
        if occupied[tuple((origin // g.cell).astype(int))]:
            continue
        angles = rng.uniform(-math.pi, math.pi, 5)
        got = grid.ray_ranges(g, occupied, origin, angles, 40.0)
        for angle, r in zip(angles, got, strict=True):
            exact = _entry_distance(origin, angle, boxes, g.cell)
            if exact >= 40.0 - g.cell:
                assert r >= min(exact, 40.0) - 1e-9
                continue
            # a ray grazing a cell's corner may pass between samples: it is then seen at a later cell
            assert r >= exact - 1e-9
            checked += r < exact + g.cell / 2
    assert checked > 400


def test_ray_ranges_report_the_reach_on_an_empty_map():
    g = grid.Grid(np.zeros(2), 2.0, (10, 10))
    np.testing.assert_array_equal(grid.ray_ranges(g, np.zeros(g.shape, bool), (10.0, 10.0), [0.0, 1.0], 30.0), 30.0)


def test_memory_scan_is_in_the_body_frame_and_before_the_sonar():
    """The scan's beam k looks at psi + k 2 pi / MEMORY_BEAMS: a wall marked in the map 20 m to the vehicle's left
    shows on beam MEMORY_BEAMS / 4 and nowhere else; the scan sits just before the sonar block, which SONAR_SLICE
    still reads, and the rest of the observation is MapGuide's without memory."""
    env = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    plain, memory = MapGuide(env), MapGuide(env, memory=True)
    time_step = env.reset()
    without, _ = plain(time_step)
    pose = np.array(env.physics.pose())
    left = pose[:2] + 20.0 * np.array([math.cos(pose[2] + math.pi / 2), math.sin(pose[2] + math.pi / 2)])
    memory(time_step)  # builds the map
    i, j, _ = memory.follower.grid.index(left[None])
    memory.follower.occupied[i[0], j[0]] = True
    scan = memory.memory_scan(pose)
    assert scan.shape == (MEMORY_BEAMS,)
    assert scan[MEMORY_BEAMS // 4] * MEMORY_RANGE == pytest.approx(20.0, abs=memory.follower.grid.cell * 1.5)
    assert np.all(np.delete(scan, MEMORY_BEAMS // 4) == 1.0)
    with_memory, _ = MapGuide(env, memory=True)(time_step)
    at, count = memory.inserted_inputs
    vector = with_memory["observation"]
    assert count == MEMORY_BEAMS and vector.size == without["observation"].size + MEMORY_BEAMS
    np.testing.assert_array_equal(vector[planning_observation.SONAR_SLICE],
                                  without["observation"][planning_observation.SONAR_SLICE])
    np.testing.assert_array_equal(np.delete(vector, range(at, at + count)), without["observation"])


def test_the_gym_space_is_widened_and_holds_the_observations():
    env = deploy_env(gymnasium.make("auv_mj/Obstacles-v0", task_kwargs={"reward": "progress"}), residual=1.0,
                     speed="fixed", guide="map-memory", protection="speed-aware")
    plain = deploy_env(gymnasium.make("auv_mj/Obstacles-v0", task_kwargs={"reward": "progress"}), residual=1.0,
                       speed="fixed", guide="map", protection="speed-aware")
    observation, _ = env.reset(seed=20_000)
    size = plain.observation_space["observation"].shape[0]
    assert env.observation_space["observation"].shape == (size + MEMORY_BEAMS,)
    assert env.observation_space.contains(observation)
    at, count = env.inserted_inputs
    assert (at, count) == (size - len(SONAR_NAMES), MEMORY_BEAMS)
    for _ in range(5):
        observation, *_ = env.step(np.zeros(2))
        assert env.observation_space.contains(observation)
        scan = observation["observation"][at:at + count]
        assert np.all((scan > 0) & (scan <= 1))


@pytest.mark.parametrize("at", [0, 5, 12])
def test_a_widened_network_computes_what_it_did_whatever_the_new_inputs(at):
    torch.manual_seed(0)
    n, count, actions = 12, 4, 2
    actor, critic, norm = Actor(n, actions, (32, 32)), Critic(n, actions, (32, 32)), Normalizer(n)
    norm.update(np.random.RandomState(1).normal(3.0, 2.0, (500, n)))
    norm.sync()
    wide_actor, wide_critic, wide_norm = (Actor(n + count, actions, (32, 32)), Critic(n + count, actions, (32, 32)),
                                          Normalizer(n + count))
    for wide, old in ((wide_actor, actor), (wide_critic, critic), (wide_norm, norm)):
        wide.load_state_dict(widen_inputs(old.state_dict(), at, count))
    x = torch.as_tensor(np.random.RandomState(2).normal(3.0, 2.0, (50, n)), dtype=torch.float32)
    extra = torch.as_tensor(np.random.RandomState(3).uniform(0, 1, (50, count)), dtype=torch.float32)
    wide_x = torch.cat([x[:, :at], extra, x[:, at:]], dim=1)
    a = torch.as_tensor(np.random.RandomState(4).uniform(-1, 1, (50, actions)), dtype=torch.float32)
    with torch.no_grad():
        torch.testing.assert_close(wide_actor(wide_norm(wide_x)), actor(norm(x)), rtol=0, atol=1e-6)
        torch.testing.assert_close(wide_critic(wide_norm(wide_x), a), critic(norm(x), a), rtol=0, atol=1e-6)
        # the new inputs are standardised with the prior and do reach the first layer's (zero) weights
        new = wide_norm(wide_x)[:, at:at + count]
        torch.testing.assert_close(new, (extra - 0.5) / 0.5, rtol=0, atol=1e-6)
    # the normaliser keeps counting: the new inputs' statistics move to their data
    wide_norm.update(np.full((int(wide_norm.count.item()), n + count), 0.9))
    wide_norm.sync()
    assert float(wide_norm.mean[at]) == pytest.approx((0.5 + 0.9) / 2, abs=1e-6)


def test_init_widens_planner_general_to_the_memory_input_and_it_drives_as_before(tmp_path):
    """`auv-mj train --init planner_general.pt` on guide="map-memory": the run's first checkpoint (no gradient step
    yet) acts as the shipped network, action for action on a cup, where the memory scan is not all 1s."""
    from auv_mj.agents.offpolicy.ddpg import DDPGConfig
    from auv_mj.agents.offpolicy.train import train
    from auv_mj.zoo.registry import checkpoint_policy

    options = {"residual": 1.0, "speed": "fixed", "guide": "map-memory", "protection": "speed-aware"}

    def make():
        return deploy_env(gymnasium.make("auv_mj/Obstacles-v0", task_kwargs={"reward": "progress"}), **options)

    train(make, "ddpg", DDPGConfig(seed=0, learning_starts=10_000), total_steps=20, run_dir=tmp_path,
          init=CHECKPOINTS / "planner_general.pt", run_info={"env_kwargs": options}, progress=False,
          tensorboard=False)
    arena = _known_arena(CUP, (100.0, 300.0), (450.0, 300.0), 500.0)
    widened = checkpoint_policy(tmp_path / "checkpoint.pt", arena, "speed-aware")
    shipped = checkpoint_policy(CHECKPOINTS / "planner_general.pt", arena, "speed-aware", speed="fixed")
    time_step, seen = arena.reset(), 0.0
    guide = MapGuide(arena, memory=True)
    for _ in range(200):
        expected, got = shipped(time_step), widened(time_step)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
        observation, _ = guide(time_step)
        at, count = guide.inserted_inputs
        seen = max(seen, 1.0 - float(np.min(observation["observation"][at:at + count])))
        time_step = arena.step(expected)
        if time_step.last():
            break
    assert seen > 0.3, "the map-memory scan saw the cup"
