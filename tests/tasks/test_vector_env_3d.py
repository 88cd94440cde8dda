"""The batched 6-DOF env (`auv_mj.tasks.vector3d.AUV3DVectorEnv`, issue 52) against the single one (`AUVGymEnv`).

Sub-environment i reset with seed s runs exactly the single environment's episode for seed s under the same actions --
observations, rewards, terminated / truncated and every info entry to 1e-9 -- for goal3d and tunnel3d, ideal and ocean
water, through autoresets (which continue each sub-environment's RandomState, as `AUVGymEnv.reset()` without a seed
does). The actions steer at the target with noise, or wander at full speed into the tube's wall.
"""

from __future__ import annotations

import math
import threading

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from side_by_side import TOLERANCE
from side_by_side import run_side_by_side as side_by_side

import auv_mj.tasks  # noqa: F401  (registers the ids)
from auv_mj.control.depth_heading import DepthHeadingController
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks.gym_adapter import AUVGymEnv
from auv_mj.tasks.vector3d import AUV3DVectorEnv

SEEDS = (3, 4)
TIME_LIMIT = 12.0
"""Seconds of an episode here (24 steps): every sub-environment goes through an autoreset."""
STEPS = 40


def steer(observation: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Actions towards the target's bearing and depth (observation entries 11-13), with noise, float32."""
    bearing = np.arctan2(observation[:, 12], observation[:, 11])
    heading = np.clip(bearing / (math.pi / 4) + rng.normal(0.0, 0.3, len(bearing)), -1.2, 1.2)
    depth = np.clip(observation[:, 13] / 5.0 + rng.normal(0.0, 0.3, len(bearing)), -1.0, 1.0)
    return np.stack([rng.uniform(0.2, 0.8, len(bearing)), heading, depth], axis=1).astype(np.float32)


def wander(observation: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Uniform actions at full speed, float32: the vehicle hits the tube's wall or broaches."""
    actions = rng.uniform(-1.0, 1.0, (len(observation), 3))
    actions[:, 0] = 1.0
    return actions.astype(np.float32)


def run_side_by_side(task: str, options: dict, mode: AutoresetMode, policy=steer) -> dict:
    """The batch beside one AUVGymEnv per sub-environment on `policy`'s actions (`side_by_side`), each step where
    no row awaits its reset run on two threads."""
    vector = AUV3DVectorEnv(task, len(SEEDS), options, threads=2, autoreset_mode=mode)

    def on_two_threads(pending: np.ndarray) -> None:
        if not pending.any():  # both vehicles stepped, on two threads
            assert vector._stepper.threads_used == 2

    return side_by_side(vector, [AUVGymEnv(task, options) for _ in SEEDS], SEEDS, mode, policy, STEPS,
                        on_two_threads)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
@pytest.mark.parametrize("water", ["ideal", "ocean"])
@pytest.mark.parametrize("task", ["goal3d", "tunnel3d"])
def test_sub_environment_is_the_single_environment(task, water):
    options = {"conditions": water, "arena": "random", "time_limit": TIME_LIMIT}
    seen = run_side_by_side(task, options, AutoresetMode.NEXT_STEP)
    assert seen["autoresets"] >= len(SEEDS)
    assert seen["truncated"] >= 1


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
def test_hard_goal3d_arenas_in_ocean_water():
    """Walls, caves and seabed relief: the fan's and the altimeter's rays meet every kind of geom."""
    options = {"conditions": "ocean", "arena": "random", "tier": "hard", "time_limit": TIME_LIMIT}
    seen = run_side_by_side("goal3d", options, AutoresetMode.NEXT_STEP)
    assert seen["autoresets"] >= len(SEEDS)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
def test_collisions_and_same_step_autoresets_in_ocean_water():
    options = {"conditions": "ocean", "arena": "random", "time_limit": TIME_LIMIT}
    seen = run_side_by_side("tunnel3d", options, AutoresetMode.SAME_STEP, wander)
    assert seen["autoresets"] >= len(SEEDS)
    assert seen.get("collision", 0) >= 1 and seen["terminated"] >= 1


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
@pytest.mark.parametrize(("task", "policy"), [("goal3d", steer), ("tunnel3d", wander)])
def test_the_geodesic_reward_is_the_single_environments(task, policy):
    """reward="geodesic": each episode's route length left, from its own field over the batch, and so the reward and
    the info's route distances, are the single environment's, through autoresets onto new hard arenas."""
    options = {"conditions": "ocean", "arena": "random", "tier": "hard", "reward": "geodesic",
               "time_limit": TIME_LIMIT}
    seen = run_side_by_side(task, options, AutoresetMode.SAME_STEP, policy)
    assert seen["autoresets"] >= len(SEEDS)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
@pytest.mark.parametrize(("task", "tier", "mode"), [("tunnel3d", "hard", AutoresetMode.NEXT_STEP),
                                                    ("goal3d", "hard", AutoresetMode.SAME_STEP)])
def test_the_sonar_map_is_the_single_environments(task, tier, mode):
    """observation="fan-map": each row's sonar map (its pings cast from the pose of a ping a step late in ocean
    water) and so its scan are the single environment's, through autoresets onto new arenas."""
    options = {"conditions": "ocean", "arena": "random", "tier": tier, "observation": "fan-map",
               "time_limit": TIME_LIMIT}
    seen = run_side_by_side(task, options, mode)
    assert seen["autoresets"] >= len(SEEDS)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
def test_the_held_fan_is_the_single_environments():
    """observation="fan-held": each row's fan filtered over its own pings (ocean water's dropouts and noise) is the
    single environment's, through same-step autoresets onto new arenas."""
    options = {"conditions": "ocean", "arena": "random", "tier": "hard", "observation": "fan-held",
               "time_limit": TIME_LIMIT}
    seen = run_side_by_side("tunnel3d", options, AutoresetMode.SAME_STEP, wander)
    assert seen["autoresets"] >= len(SEEDS)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
@pytest.mark.parametrize("observation", ["fan", "fan-map", "fan-held"])
def test_a_step_where_every_row_resets_steps_no_vehicle(observation):
    """Next-step autoreset with one vehicle: the step after its episode ends resets it and steps no vehicle at all
    (an empty batch), under every observation."""
    env = AUV3DVectorEnv("tunnel3d", 1, {"arena": "random", "observation": observation, "time_limit": 2.0},
                         autoreset_mode=AutoresetMode.NEXT_STEP)
    env.reset(seed=5)
    action = np.zeros((1, 3))
    ended = False
    for _ in range(10):
        _, _, terminated, truncated, _ = env.step(action)
        ended = bool(terminated[0] or truncated[0])
        if ended:
            break
    assert ended
    observation_after, reward, terminated, truncated, _ = env.step(action)
    assert reward[0] == 0.0 and not (terminated[0] or truncated[0])
    assert np.all(np.isfinite(observation_after["observation"]))
    env.close()


def test_make_vec_returns_the_batch():
    env = gymnasium.make_vec("auv_mj/Tunnel3D-v0", num_envs=2, vectorization_mode="vector_entry_point",
                             task_kwargs={"arena": "random"})
    assert isinstance(env, AUV3DVectorEnv) and env.num_envs == 2
    assert env.single_observation_space == AUVGymEnv("tunnel3d").observation_space
    env.close()


def test_other_executors_are_refused():
    class Other(DepthHeadingController):
        pass

    with pytest.raises(ValueError, match="depth-heading S-plane"):
        AUV3DVectorEnv("goal3d", 1, {"executor": Other()})


def test_lookahead_targets_are_the_tubes_targets():
    """`auv3d.lookahead_targets` (the batch's) against `Tunnel3D.target` (the single env's), anywhere about tubes of
    different lengths: before their start, along them, off them and past their end."""
    envs = [suite.load("auv3d", "tunnel3d", task_kwargs={"arena": "random", "random": seed}) for seed in (0, 1, 2)]
    tasks = []
    for env in envs:
        env.reset()
        tasks.append(env.task)
    longest = max(len(task.path) for task in tasks)
    rng = np.random.default_rng(0)
    for _ in range(50):
        paths = np.stack([np.vstack([t.path, np.repeat(t.path[-1:], longest - len(t.path), axis=0)]) for t in tasks])
        along = rng.uniform(-0.2, 1.2, len(tasks))
        positions = np.stack([t.path[0] + a * (t.path[-1] - t.path[0]) + rng.normal(0.0, 4.0, 3)
                              for t, a in zip(tasks, along, strict=True)])
        got = auv3d.lookahead_targets(positions, paths, [len(t.path) for t in tasks])
        for k, task in enumerate(tasks):
            np.testing.assert_allclose(got[k], task.target(positions[k]), rtol=0, atol=TOLERANCE)


@pytest.mark.filterwarnings("ignore:auv-mj. time_limit")
def test_autoresets_run_beside_the_physics_on_two_threads():
    """NEXT_STEP autoresets run on a helper thread while the C step of the other rows runs
    (`GoalVectorEnv._physics_alongside`): the reset and the step each wait for the other to begin, which one after the
    other, in either order, never happens; on one thread the reset runs first. The side-by-side tests above show that
    the result is the serial one."""
    for threads in (2, 1):
        vector = AUV3DVectorEnv("goal3d", 2, {"arena": "random", "time_limit": 2.0}, threads=threads)
        began = {"reset": threading.Event(), "step": threading.Event()}
        met: dict[str, list[bool]] = {"reset": [], "step": []}
        reset_one, step = vector._reset_one, vector._stepper.step

        def waiting_reset(i, seed, reset_one=reset_one, began=began, met=met, threads=threads):
            began["reset"].set()
            if threads == 2:
                met["reset"].append(began["step"].wait(timeout=10.0))
            return reset_one(i, seed)

        def waiting_step(index, *args, step=step, began=began, met=met, vector=vector, threads=threads):
            if vector._autoreset.any():
                assert list(index) == [0]  # row 1 resets, row 0 steps
                began["step"].set()
                met["step"].append(began["reset"].wait(timeout=10.0 if threads == 2 else 0.0))
            step(index, *args)

        vector.reset(seed=0)
        vector._stepper.step, vector._reset_one = waiting_step, waiting_reset
        vector._step_limit[1] = 1  # row 1's episode ends after one step, row 0's goes on (4 steps)
        actions = np.zeros((2, 3), dtype=np.float32)
        for _ in range(2):
            vector.step(actions)
        assert met["step"] == [True] and met["reset"] == ([True] if threads == 2 else [])
        vector.close()
