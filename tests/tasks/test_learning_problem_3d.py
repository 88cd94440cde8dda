"""The 6-DOF tasks' learning reward (reward="geodesic" on goal3d and tunnel3d) and its geodesic field.

As the planar test (`test_learning_problem.py`), on whole scripted episodes of certified arenas -- a wall to climb
over, a curtain to pass under, a cave, seabed relief, a tube with plugs, rocks in open water -- at the discount a
learner of it uses (GEODESIC_DISCOUNT): going round, over or under (the 3-D `oracle`, which reaches the goal)
returns more than crashing (`splane`, line of sight, which flies the straight line or the tube's axis into the
wall, the cave or the plug) and more than waiting at the start or half-way; of two arrivals (the oracle from the
start, and started late) the sooner returns more; each return is the closed form that potential-based shaping
telescopes to. The field itself is checked against
the lattice's own distances on open water (the octile distance on a level layer) and against the oracle's
certificate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from geodesic_returns import discounted, trap_runs

from auv_mj.arenas import traps3d, voxels
from auv_mj.arenas.geodesic import VoxelField
from auv_mj.arenas.sonar_memory import FAN_MEMORY_AZIMUTHS, FAN_MEMORY_BEAMS, FAN_MEMORY_RANGE
from auv_mj.control.depth_heading import DepthHeadingGains
from auv_mj.geometry import polyline_length
from auv_mj.tasks import auv3d, planning_rewards, suite
from auv_mj.zoo import env_and_policy

IDLE = np.array([-1.0, 0.0, 0.0])
"""Thrust off: V = 0, heading and depth kept."""
LATE_STEPS = 10
"""The late start idles this many planner steps (5 s) before the oracle drives: longer and the buoyant REMUS,
without way on, floats into a tube's wall or to the surface."""
TRAP_CASES = [("goal3d", "hard", 0), ("goal3d", "hard", 1), ("goal3d", "hard", 3), ("goal3d", "hard", 5),
              ("tunnel3d", "hard", 1), ("goal3d", "standard", 1)]
"""(task, tier, seed): certified arenas where `splane` crashes and the oracle goes over, under or round (hard goal3d
seeds 0, 1, 3, 5 draw a wall, a curtain, a cave and seabed relief; tunnel3d hard 1 a tube with plugs; goal3d
standard 1 rocks on the straight line)."""


@pytest.mark.parametrize(("task", "tier", "seed"), TRAP_CASES)
def test_going_round_returns_more_than_crashing_waiting_or_arriving_late(task, tier, seed):
    runs = trap_runs(task, tier, seed, IDLE, LATE_STEPS)
    returns = {name: discounted(rewards) for name, (rewards, _) in runs.items()}
    assert min(returns["round"], returns["late"]) > max(returns["crash"], returns["wait_start"], returns["wait_half"])
    # the sooner arrival returns more (the oracle replans from where the late start left it: its way may differ)
    sooner, later = sorted((runs["round"][0], runs["late"][0]), key=len)
    assert len(sooner) < len(later) and discounted(sooner) > discounted(later)


def test_on_open_water_the_field_is_the_lattices_octile_distance():
    """No walls: on the goal's own layer the shortest flyable route is level, along the 8-connected plane, so the
    field is the octile distance h (max + (sqrt 2 - 1) min) of the voxel offsets; off the layer it is at least the
    straight distance and climbs within the slope limit (no straight climb: above the goal's voxel it is longer)."""
    space = voxels.VoxelGrid.covering((-20.0, -16.0, -30.0), (20.0, 16.0, -10.0), 2.0, 1.0)
    goal = space.centre(np.array([[10, 8, 10]]))[0]
    slope = math.radians(20.0)
    field = VoxelField.on_map(space, np.ones(space.shape, bool), goal, 0.0, slope)
    di = np.abs(np.arange(space.shape[0]) - 10)[:, None]
    dj = np.abs(np.arange(space.shape[1]) - 8)[None, :]
    octile = 2.0 * (np.maximum(di, dj) + (math.sqrt(2.0) - 1.0) * np.minimum(di, dj))
    np.testing.assert_allclose(field.field[:, :, 10], octile, atol=1e-9)
    centres = space.centre(np.column_stack(np.unravel_index(np.arange(field.field.size), space.shape)))
    straight = np.linalg.norm(centres - goal, axis=1).reshape(space.shape)
    assert np.all(field.field >= straight - 1e-9)
    above = field.field[10, 8, 14]  # 4 m straight above the goal: the climb takes a run of 4 / tan(slope) at least
    assert above >= math.hypot(4.0, 4.0 / math.tan(slope)) - 1e-9
    # the look-up adds the point's offset from the voxel centre it routes through
    point = goal + np.array([0.3, -0.2, 0.0])
    assert field.distance(point)[0] == pytest.approx(np.linalg.norm(point - goal), abs=1e-9)


@pytest.mark.parametrize("kind", ["goal", "tube"])
def test_the_field_is_no_longer_than_the_oracles_certificate(kind):
    """The certificate (the oracle's pitch-limited path, kept off the walls by its soft cost) is one flyable route on
    the same voxels: the route length at the start is at most its length, and at least the straight distance to the
    goal region."""
    max_pitch = DepthHeadingGains().max_pitch
    for seed in range(3):
        random = np.random.RandomState(seed)
        if kind == "goal":
            arena = traps3d.hard_goal_arena(random, auv3d.WATER_DEPTH, max_pitch, auv3d.MIN_DEPTH, auv3d.GOAL_RADIUS)
            field = traps3d.geodesic_field(arena, max_pitch, auv3d.MIN_DEPTH, auv3d.GOAL_RADIUS)
        else:
            arena = traps3d.hard_tube(random, max_pitch)
            field = traps3d.geodesic_field(arena, max_pitch, None, auv3d.GOAL_RADIUS,
                                           (arena.path, traps3d.HARD_TUBE_RADIUS))
        start = field.distance(arena.start)[0]
        certificate = polyline_length(np.vstack([arena.start, arena.route]))
        assert np.linalg.norm(arena.goal - arena.start) - auv3d.GOAL_RADIUS <= start <= certificate + 1e-6


def test_compute_reward_is_the_step_reward_and_relabels_on_the_straight_distance():
    env, drive = env_and_policy("oracle", "goal3d", 0, {"arena": "random", "tier": "hard", "reward": "geodesic"})
    task = env.task
    time_step = env.reset()
    rewards, infos, achieved, desired = [], [], [], []
    while not time_step.last() and len(rewards) < 120:
        desired.append(time_step.observation["desired_goal"])
        time_step = env.step(drive(time_step))
        rewards.append(time_step.reward)
        infos.append(task.last_info)
        achieved.append(auv3d.pose_goal(env.physics.position(), 0.0))
    achieved, desired = np.array(achieved), np.array(desired)
    np.testing.assert_array_equal(task.compute_reward(achieved, desired, infos), rewards)
    relabelled = task.compute_reward(achieved, achieved, infos)  # reached at once: the bonus on every step
    previous = np.array([info["previous_achieved_goal"] for info in infos])
    before = np.maximum(auv3d.goal_distance(previous, achieved) - auv3d.GOAL_RADIUS, 0.0)
    np.testing.assert_allclose(relabelled, planning_rewards.geodesic_reward(before, 0.0, True, False), atol=1e-12)
    # the route length left falls along the oracle's way over the wall, and the progress reward's option stays
    distances = [info["route_distance"] for info in infos]
    assert distances[-1] < distances[0] - 60.0
    with pytest.raises(ValueError, match="reward"):
        suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={"reward": "paper"})


@pytest.mark.parametrize(("task_name", "tube"), [("tunnel3d", True), ("goal3d", False)])
def test_the_critics_privileged_input_is_the_route_the_room_and_the_time_left(task_name, tube):
    """info["privileged"] (auv3d.PRIVILEGED_FIELDS) from the reset on: the route length left the reward shapes on,
    the room (the true map's clearance, within a tube's radius in a tube), the route's time left falling a planner
    step a step, and the episode's tier and kind."""
    env, drive = env_and_policy("oracle", task_name, 1, {"arena": "random", "tier": "hard", "reward": "geodesic"})
    task = env.task
    time_step = env.reset()
    at_reset = task.last_info["privileged"]
    assert at_reset.shape == (len(auv3d.PRIVILEGED_FIELDS),)
    fields = dict(zip(auv3d.PRIVILEGED_FIELDS, at_reset.tolist(), strict=True))
    assert fields["route_distance"] * auv3d.GOAL_DISTANCE_SCALE == pytest.approx(task.route_distance, abs=1e-9)
    assert fields["time_left"] * auv3d.PRIVILEGED_TIME_SCALE == pytest.approx(task.episode_time_limit, abs=1e-9)
    assert (fields["hard_tier"], fields["tube"]) == (1.0, float(tube))
    for step in range(1, 41):
        time_step = env.step(drive(time_step))
        now = dict(zip(auv3d.PRIVILEGED_FIELDS, task.last_info["privileged"].tolist(), strict=True))
        assert now["route_distance"] * auv3d.GOAL_DISTANCE_SCALE == pytest.approx(task.last_info["route_distance"],
                                                                                 abs=1e-9)
        assert now["time_left"] * auv3d.PRIVILEGED_TIME_SCALE == pytest.approx(
            task.episode_time_limit - step * auv3d.PLANNER_DT, abs=1e-6)
        room = now["room"] * auv3d.SONAR_RANGE
        assert room > 0.0  # the oracle flies in free water
        if tube:
            assert room <= task.tube_radius + 1.0
        assert not time_step.last()


# --- observation="fan-map": the vehicle's own sonar map beside the fan ---------------------------------------


def _fan_map_pair(task_name: str, seed: int) -> tuple:
    """The same episode under observation="fan" and "fan-map" (a standard tube in ideal water)."""
    options = {"arena": "random", "conditions": "ideal"}
    return tuple(suite.load(auv3d.DOMAIN, task_name, task_kwargs={**options, "observation": kind, "random": seed})
                 for kind in ("fan", "fan-map"))


def test_the_sonar_map_is_inserted_before_the_fan_and_remembers_the_walls_passed():
    """The "fan-map" vector is the "fan" one with FAN_MEMORY_BEAMS entries before the fan, step after step of the same
    episode; at the reset the map holds the first ping alone, so the scan's rays back along the tube's walls (120 and
    150 deg either side of the bow, level) read nothing, and after 30 m flown they read the walls the fan showed on
    the way, which it no longer shows: about the tube's radius off."""
    plain, mapped = _fan_map_pair("tunnel3d", 7)
    fan, memory = plain.reset().observation["observation"], mapped.reset().observation["observation"]
    head, scan = len(auv3d.PLANNING_OBSERVATION), slice(len(auv3d.PLANNING_OBSERVATION),
                                                        len(auv3d.PLANNING_OBSERVATION) + FAN_MEMORY_BEAMS)
    assert memory.shape == (fan.size + FAN_MEMORY_BEAMS,)
    assert mapped.observation_spec()["observation"].shape == memory.shape
    behind = [FAN_MEMORY_AZIMUTHS + k for k in (4, 5, 7, 8)]  # level row, +120, +150, -150, -120 deg
    assert np.all(memory[scan][behind] == 1.0)
    action = np.array([0.5, 0.0, 0.0])
    for _ in range(20):  # 10 s at about 1.5 m/s
        fan, memory = plain.step(action).observation["observation"], mapped.step(action).observation["observation"]
        np.testing.assert_array_equal(memory[:head], fan[:head])
        np.testing.assert_array_equal(memory[scan.stop:], fan[head:])
    assert not mapped.task.last_info["event"]
    radius = mapped.task.tube_radius
    assert np.all(memory[scan][behind] * FAN_MEMORY_RANGE < 2.0 * radius)


def test_the_held_fan_is_the_fan_filtered_over_pings_and_shows_the_wall_a_lost_echo_hid():
    """Under observation="fan-held" the vector is the "fan" one with each fan beam the nearer of its newest ping and
    its median over the last three (worked out here from the "fan" episode's pings), step after step of the same
    episode in ocean water; and some beam that read nothing (a lost echo: ocean water's dropouts) reads a wall in the
    held fan."""
    options = {"arena": "random", "conditions": "ocean", "random": 7}
    plain, held = (suite.load(auv3d.DOMAIN, "tunnel3d", task_kwargs={**options, "observation": kind})
                   for kind in ("fan", "fan-held"))
    head = len(auv3d.PLANNING_OBSERVATION)
    first, first_held = plain.reset().observation["observation"], held.reset().observation["observation"]
    np.testing.assert_array_equal(first_held, first)
    pings, hidden = [first[head:]], 0
    action = np.array([0.5, 0.0, 0.0])
    for _ in range(40):  # 20 s along the tube
        fan, fan_held = plain.step(action).observation["observation"], held.step(action).observation["observation"]
        np.testing.assert_array_equal(fan_held[:head], fan[:head])
        pings.append(fan[head:])
        np.testing.assert_allclose(fan_held[head:], np.minimum(np.median(np.stack(pings[-3:]), axis=0), pings[-1]))
        hidden += int(np.sum((fan[head:] == 1.0) & (fan_held[head:] < 1.0)))
    assert not held.task.last_info["event"]
    assert hidden >= 1


def test_a_mistyped_observation_is_refused_with_a_suggestion():
    with pytest.raises(ValueError, match="fan-map"):
        suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={"observation": "fan_map"})


def test_an_episode_in_ocean_water_is_the_same_after_another_on_the_same_environment():
    """An environment reseeded for each episode (as `auv-mj benchmark` reuses one) flies a seed as a fresh one does:
    goal3d seed 13011 in ocean water drops its first DVL read, and a dropout holds the episode's last sample, not the
    last episode's (there the vehicle had been flown hard for 15 s: its velocity showed in the first observation)."""
    options = {"arena": "random", "conditions": "ocean", "executor": "splane-ocean"}
    used = suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={**options, "random": 13_000})
    used.reset()
    for _ in range(30):
        used.step(np.array([1.0, 0.5, 0.0]))
    used.task.random.seed(13_011)
    fresh = suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={**options, "random": 13_011})
    np.testing.assert_array_equal(used.reset().observation["observation"], fresh.reset().observation["observation"])
    for _ in range(10):
        np.testing.assert_array_equal(used.step(np.zeros(3)).observation["observation"],
                                      fresh.step(np.zeros(3)).observation["observation"])
