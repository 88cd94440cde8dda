"""The privileged teacher in 3-D (`auv_mj.planners.teacher3d`), its field's way down, and the 6-DOF training mixture.

The teacher must reach the goal on the certified hard arenas (a wall to climb, a curtain to dive under, a cave,
relief, a tube with plugs), act from any state, and label the batched env's rows exactly as it acts on the single
env; the way down the field (`VoxelField.next_hop`) must be the field's own shortest way; the mixture must hold one
domain's cells.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_mj.arenas import voxels
from auv_mj.arenas.geodesic import VoxelField, point_voxels
from auv_mj.planners import teacher3d
from auv_mj.planners.map_planner3d import LOOKAHEAD
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks.mixture import MIXTURE_TASKS_3D, PlanningMixtureVectorEnv
from auv_mj.tasks.vector3d import AUV3DVectorEnv
from auv_mj.zoo import env_and_policy


@pytest.mark.parametrize(("task", "seed"), [("goal3d", 0), ("goal3d", 1), ("goal3d", 3), ("goal3d", 5),
                                            ("tunnel3d", 1)])
def test_the_teacher_reaches_the_goal_of_certified_hard_arenas(task, seed):
    """Over a wall, under a curtain, out of a cave, over relief, past plugs (hard goal3d seeds 0, 1, 3, 5 draw those
    kinds; tunnel3d seed 1 a plugged tube), through the zoo's name on the 6-DOF domain."""
    env, policy = env_and_policy("geodesic-teacher", task, seed, {"arena": "random", "tier": "hard"})
    time_step = env.reset()
    while not time_step.last():
        time_step = env.step(policy(time_step))
    assert env.task.last_info["event"] == "goal"


def test_next_hops_walk_the_fields_shortest_way():
    """From every free voxel the next hops reach the goal region, each hop one lattice edge whose length (unit cost:
    the field is the route length) is what the field falls by: the predecessors are the search's own."""
    space = voxels.VoxelGrid.covering((-12.0, -10.0, -20.0), (12.0, 10.0, -8.0), 2.0, 1.0)
    free = np.ones(space.shape, bool)
    free[5:7, 2:9, :8] = False  # a wall to climb over
    field = VoxelField.on_map(space, free, space.centre(np.array([[10, 5, 4]]))[0], 0.0, math.radians(12.0))
    flat = field.field.ravel()
    for start in np.flatnonzero(np.isfinite(flat))[::7]:
        node, walked = int(start), 0.0
        for _ in range(200):
            nxt = int(field.next_hop[node])
            if nxt < 0:
                break
            a, b = (space.centre(np.array([np.unravel_index(k, space.shape)]))[0] for k in (node, nxt))
            walked += float(np.linalg.norm(b - a))
            node = nxt
        assert flat[node] == 0.0
        assert walked == pytest.approx(flat[start], abs=1e-9)


def test_in_open_water_the_teacher_aims_its_look_ahead_down_the_straight_way():
    """No walls: the way is straight to the goal on the goal's layer, so the aim lies LOOKAHEAD metres towards the
    goal (to a voxel's half diagonal), and the action turns by its bearing off the course."""
    space = voxels.VoxelGrid.covering((-40.0, -40.0, -30.0), (40.0, 40.0, -10.0), 2.0, 1.0)
    goal = space.centre(np.array([[35, 20, 10]]))[0]
    field = VoxelField.on_map(space, np.ones(space.shape, bool), goal, 3.0, math.radians(10.0))
    start = np.array([[-30.0, 1.0, goal[2]]])
    aim = teacher3d.aim_points(field, start)[0]
    toward = (goal - start[0]) / np.linalg.norm(goal - start[0])
    assert np.linalg.norm(aim - (start[0] + toward * np.dot(aim - start[0], toward))) <= 1.5  # on the line
    assert LOOKAHEAD <= np.dot(aim - start[0], toward) <= LOOKAHEAD + 3.0
    course = np.array([0.3])
    action = teacher3d.teacher_actions_3d([field], start, course)[0]
    bearing = math.atan2(aim[1] - start[0, 1], aim[0] - start[0, 0])
    assert action[1] == pytest.approx((bearing - 0.3) / auv3d.HEADING_RANGE, abs=1e-9)
    assert action[2] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(("task", "horizon", "steps"), [("goal3d", None, 30), ("tunnel3d", 8.0, 90)])
def test_the_batch_teacher_labels_the_rows_as_the_teacher_acts_on_each_single_env(task, horizon, steps):
    """The batched env's rows are the single envs' episodes (tests/tasks/test_vector_env_3d.py): the teacher's labels
    from `privileged_state` equal the single-env teacher's actions, step by step, while the teacher drives; with a
    horizon too, through the steps where a plug comes into it."""
    seeds = (1, 3)
    options = {"arena": "random", "tier": "hard", "conditions": "ocean"}
    batch = AUV3DVectorEnv(task, len(seeds), options, threads=1)
    labels = teacher3d.BatchTeacher3D(batch, horizon)
    singles = [suite.load(auv3d.DOMAIN, task, task_kwargs={**options, "random": s}) for s in seeds]
    teachers = [teacher3d.GeodesicTeacher3D(env, horizon) for env in singles]
    batch.reset(seed=list(seeds))
    time_steps = [env.reset() for env in singles]
    unseen = []
    for _ in range(steps):
        batched = labels.actions()
        single = np.array([t(step) for t, step in zip(teachers, time_steps, strict=True)])
        np.testing.assert_allclose(batched, single, rtol=0, atol=1e-9)
        batch.step(batched.astype(np.float32))
        time_steps = [env.step(a.astype(np.float32)) for env, a in zip(singles, batched, strict=True)]
        if horizon is not None:
            unseen.append([len(env.task.unseen_plugs(env.physics.position(), horizon)) for env in singles])
    if horizon is not None:  # a plug came into the horizon on the way
        assert np.any(np.diff(np.array(unseen), axis=0) < 0)
    batch.close()


def test_a_teacher_with_a_horizon_knows_a_plug_only_once_near_it():
    """`Planning3D.unseen_plugs`: every plug is unknown from afar, a plug is known once the vehicle comes within the
    horizon of it and stays known until the reset; the steering field without the unknown plugs runs through them."""
    env = suite.load(auv3d.DOMAIN, "tunnel3d", task_kwargs={"arena": "random", "tier": "hard", "random": 1})
    env.reset()
    task = env.task
    names = [env.physics.model.geom(g).name for g in range(env.physics.model.ngeom)]
    plugs = {n: env.physics.named.data.geom_xpos[n].copy() for n in names if n.startswith("plug_")}
    assert plugs
    far = np.array([1e4, 1e4, -1e4])
    assert task.unseen_plugs(far, 8.0) == frozenset(plugs)
    first, centre = sorted(plugs.items())[0]
    assert first not in task.unseen_plugs(centre + np.array([0.0, 0.0, 7.0]), 8.0)
    assert first not in task.unseen_plugs(far, 8.0)  # kept
    full, blind = task.steering_field(None), task.steering_field(None, frozenset(plugs))
    i, j, k = point_voxels(full, centre[None])[0]
    assert not np.isfinite(full.field[i, j, k]) and np.isfinite(blind.field[i, j, k])  # the plug is water to it
    env.reset()  # the next episode's plugs, none seen
    names = [env.physics.model.geom(g).name for g in range(env.physics.model.ngeom)]
    assert task.unseen_plugs(far, 8.0) == frozenset(n for n in names if n.startswith("plug_"))


def test_the_mixture_holds_one_domains_cells():
    env = PlanningMixtureVectorEnv(1, tasks=MIXTURE_TASKS_3D, tiers=("hard",), waters=("ocean",),
                                   task_kwargs={"reward": "geodesic", "executor": "splane-ocean"}, threads=1)
    assert [type(sub) for sub in env.subenvs] == [AUV3DVectorEnv] * 2
    assert env.policy_options == {"executor": "splane-ocean"}  # what a student trained here runs on
    obs, _ = env.reset(seed=0)
    assert obs["observation"].shape == (2, len(auv3d.PLANNING_OBSERVATION) + 27)
    state = env.privileged_state(teacher3d.OPEN_WATER_SLOPE)
    assert len(state["steering"]) == 2 and state["position"].shape == (2, 3)
    env.close()
    with pytest.raises(ValueError, match="tasks"):
        PlanningMixtureVectorEnv(1, tasks=("goal3d", "obstacles"))
