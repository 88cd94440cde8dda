"""The teacher that senses what the student senses: `map-replan` acting beside the student on each vehicle's own
episode (`auv_mj.jobs.student.PlannerTeacher`), over the serial training mixture (`PlanningMixtureVectorEnv(serial=
True)`), and the classical planners' actions read in the rate action map (`auv_mj.planners.teacher.InTaskActions`)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from auv_mj.agents.ppo.planner import LEARNED_MIXTURE
from auv_mj.jobs.student import PlannerTeacher, mixture_3d_env, planar_map_replan, train_student
from auv_mj.planners.map_planner import map_replan
from auv_mj.planners.map_planner3d import sonar_voxel_planner
from auv_mj.planners.teacher import InTaskActions, rate_from_paper
from auv_mj.tasks import suite
from auv_mj.tasks.gym_adapter import AUVGymEnv
from auv_mj.tasks.mixture import MIXTURE_TASKS_3D, PlanningMixtureVectorEnv
from auv_mj.tasks.planning_step import MAX_HEADING_CHANGE, executor_command

TOLERANCE = 1e-9
"""The batch's contract with the single environment (tests/tasks/side_by_side.py)."""
OPTIONS_3D = {"reward": "geodesic", "executor": "splane-ocean", "observation": "fan-held"}
"""The 6-DOF student's task options."""


@pytest.mark.parametrize("three_d", [False, True])
def test_the_serial_mixture_runs_the_batched_mixtures_episodes(three_d):
    """Row i of the serial mixture is row i of the batched one: the same observations, rewards and endings from the
    same seeds and actions, through the autoresets (NEXT_STEP, each row's next training seed)."""
    if three_d:
        make = lambda serial: PlanningMixtureVectorEnv(1, tasks=MIXTURE_TASKS_3D, task_kwargs=OPTIONS_3D,  # noqa: E731
                                                       threads=1, serial=serial)
    else:
        make = lambda serial: LEARNED_MIXTURE.make_env(1, serial=serial)  # noqa: E731
    envs = [make(False), make(True)]
    first = [env.reset(seed=3)[0] for env in envs]
    for key in first[0]:
        np.testing.assert_allclose(first[0][key], first[1][key], rtol=0, atol=TOLERANCE)
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(60 if three_d else 200):
        action = rng.uniform(-1, 1, envs[0].action_space.shape).astype(np.float32)
        action[:, 0] = 1.0  # at the top speed
        (obs_a, reward_a, term_a, trunc_a, _), (obs_b, reward_b, term_b, trunc_b, _) = (e.step(action) for e in envs)
        for key in obs_a:
            np.testing.assert_allclose(obs_a[key], obs_b[key], rtol=0, atol=TOLERANCE, err_msg=key)
        np.testing.assert_allclose(reward_a, reward_b, rtol=0, atol=TOLERANCE)
        np.testing.assert_array_equal(term_a, term_b)
        np.testing.assert_array_equal(trunc_a, trunc_b)
        ended += int((term_a | trunc_a).sum())
    assert ended > 0  # the random actions crashed some: the autoresets were compared too
    np.testing.assert_array_equal(envs[0].episode_seeds, envs[1].episode_seeds)
    for env in envs:
        env.close()


def test_a_batched_mixture_has_no_row_environment_and_a_serial_one_resets_next_step_only():
    batched = PlanningMixtureVectorEnv(1, tasks=MIXTURE_TASKS_3D, task_kwargs=OPTIONS_3D, threads=1)
    with pytest.raises(ValueError, match="serial=True"):
        batched.row_env(0)
    batched.close()
    with pytest.raises(ValueError, match="NEXT_STEP only"):
        PlanningMixtureVectorEnv(1, tasks=MIXTURE_TASKS_3D, task_kwargs=OPTIONS_3D, serial=True,
                                 autoreset_mode="SameStep")
    with pytest.raises(ValueError, match="serial must be True or False"):
        PlanningMixtureVectorEnv(1, tasks=MIXTURE_TASKS_3D, task_kwargs=OPTIONS_3D, serial="yes")


def test_rate_from_paper_gives_the_executor_the_paper_actions_command():
    """The rate action it returns commands what the paper action does (`executor_command`), over heading offsets
    inside and outside the clipped band and commands on either side of the heading."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        action = rng.uniform(-1, 1, 2)
        psi = rng.uniform(-np.pi, np.pi)
        command = psi + rng.uniform(-np.pi / 6, np.pi / 6)  # the executor keeps its command within 30 deg
        rate = rate_from_paper(action, psi, command)
        assert -1.0 <= rate[1] <= 1.0 and rate[0] == action[0]
        paper = executor_command(action[None], np.array([psi]), np.array([command]), "paper")[0]
        got = executor_command(rate[None], np.array([psi]), np.array([command]), "rate")[0]
        np.testing.assert_allclose(got, paper, rtol=0, atol=1e-12)
    # a hard turn: the command moves by the largest change, a rate of 1
    assert rate_from_paper(np.array([0.0, 1.0]), 0.0, 0.0)[1] == pytest.approx(1.0)
    assert rate_from_paper(np.array([0.0, 0.02]), 0.0, 0.0)[1] == pytest.approx(np.pi / 2 * 0.02 / MAX_HEADING_CHANGE)


def test_map_replan_in_the_rate_action_map_flies_its_own_episode():
    """`map-replan` read through `InTaskActions` on action="rate" flies the episode it flies on action="paper": the
    same poses at every step, to the same end."""
    poses, infos = [], []
    for action in ("paper", "rate"):
        env = suite.load("auv", "obstacles", task_kwargs={"arena": "random", "tier": "hard", "action": action,
                                                          "random": 12_345})
        planner = InTaskActions(map_replan(env), env)
        planner.reset()
        time_step, trace = env.reset(), []
        while not time_step.last():
            time_step = env.step(planner.act(time_step))
            trace.append(np.array(env.physics.pose(), dtype=float))
        poses.append(np.array(trace))
        infos.append(env.task.last_info)
    assert len(poses[0]) == len(poses[1]) > 20
    np.testing.assert_allclose(poses[0], poses[1], rtol=0, atol=1e-6)
    assert infos[0]["is_success"] == infos[1]["is_success"]


def test_the_sensed_teacher_labels_each_row_with_map_replan_on_that_rows_own_episode():
    """The student drives; each label is the action `map-replan` takes at that state having seen that episode, as a
    `map-replan` run beside the same episode in a single environment, fed the same actions, gives it."""
    env = mixture_3d_env(1, threads=1, options=OPTIONS_3D, serial=True)
    teacher = PlannerTeacher(env, sonar_voxel_planner)
    rows = [0, env.num_envs - 1]  # a standard goal3d and a hard tunnel3d vehicle
    singles = [AUVGymEnv(env.cells[env.cell_of_row[r]][0],
                         {**OPTIONS_3D, "arena": "random", "tier": env.cells[env.cell_of_row[r]][1],
                          "conditions": env.cells[env.cell_of_row[r]][2]}) for r in rows]
    shadows = [sonar_voxel_planner(single.dm_env) for single in singles]
    env.reset(seed=5)
    for single, r in zip(singles, rows, strict=True):
        single.reset(seed=int(env.episode_seeds[r]))
    rng = np.random.default_rng(2)
    for _ in range(25):
        labels = teacher.actions()
        assert labels.shape == (env.num_envs, 3)
        for single, shadow, r in zip(singles, shadows, rows, strict=True):
            np.testing.assert_allclose(labels[r], shadow.act(single.last_time_step), rtol=0, atol=1e-6)
        student = rng.uniform(-0.3, 0.3, env.action_space.shape).astype(np.float32)  # the student drives
        _, _, term, trunc, _ = env.step(student)
        for single, r in zip(singles, rows, strict=True):
            single.step(student[r])
        assert not (term[rows] | trunc[rows]).any()
    env.close()


def test_the_sensed_teacher_is_refused_where_it_does_not_run_and_kept_for_the_resume(tmp_path):
    with pytest.raises(ValueError, match="teacher must be one of"):
        train_student(tmp_path / "a", "planning-mix-3d", teacher="bug")
    with pytest.raises(ValueError, match="planning-mix and planning-mix-3d only"):
        train_student(tmp_path / "b", "obstacles", teacher="map-replan")
    with pytest.raises(ValueError, match="without teacher_horizon"):
        train_student(tmp_path / "c", "planning-mix-3d", teacher="map-replan", teacher_horizon=8.0)
    assert not any((tmp_path / name).exists() for name in "abc")  # refused before anything is written
    command = [sys.executable, "-m", "auv_mj.cli", "train", "dagger", "--task", "planning-mix", "--num-envs", "1",
               "--dagger-teacher", "map-replan", "--dagger-rounds", "1", "--dagger-steps-per-round", "3",
               "--dagger-epochs", "1", "--dagger-validation-episodes", "0", "-o", str(tmp_path / "run"),
               "--no-progress", "--threads", "1"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "run" / "student.json").read_text())["teacher"] == "map-replan"
    again = subprocess.run(command[:command.index("--dagger-teacher")] + command[command.index("--dagger-rounds"):]
                           + ["--resume", "--dagger-teacher", "geodesic"], capture_output=True, text=True, timeout=300)
    assert again.returncode != 0 and "keeps its own ('map-replan')" in again.stderr


def test_planar_map_replan_labels_in_the_students_rate_action_map():
    """On the planar student's problem (action="rate") the teacher's heading label is the command's change over the
    largest change, so it lies in [-1, 1] and commands what `map-replan` commands."""
    env = LEARNED_MIXTURE.make_env(1, serial=True)
    teacher = PlannerTeacher(env, planar_map_replan)
    env.reset(seed=0)
    for _ in range(5):
        labels = teacher.actions()
        assert labels.shape == (env.num_envs, 2) and np.all(np.abs(labels) <= 1.0)
        env.step(labels.astype(np.float32))
    assert np.all([row.task.action_kind == "rate" for row in teacher.rows]) and env.action_kind == "rate"
    with pytest.raises(ValueError, match="row_env"):
        env.privileged_state()  # the batched teachers' read-out is the batch's alone
    env.close()
