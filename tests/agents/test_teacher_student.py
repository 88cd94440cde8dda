"""The privileged teacher and its student (issue 51, item 5): `geodesic-teacher`, DAgger and PPO's imitation term.

The teacher must reach the goal where line of sight crashes into a trap, and its batched face must label as the per-env
one does. DAgger (Ross et al. 2011) must label the states the student visits with the teacher's actions, aggregate
them round by round, fit them, and resume to the run it interrupts.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.imitation import CHECKPOINT_NAME, DaggerConfig, Sequences, collect, fit, imitation_loss, train_dagger
from auv_mj.agents.ppo import Minibatch, PPOConfig, build_model, ppo_loss
from auv_mj.agents.ppo.config import imitation_weight
from auv_mj.planners.teacher import BatchTeacher, geodesic_teacher, near_movers
from auv_mj.tasks import suite
from auv_mj.tasks.mixture import PlanningMixtureVectorEnv
from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.zoo import env_and_policy

HARD = {"arena": "random", "tier": "hard", "action": "rate", "reward": "geodesic", "observation": "planner"}
"""The student's problem."""
TINY = DaggerConfig(rounds=2, steps_per_round=6, epochs=2, batch_sequences=2, hidden_sizes=(16,), recurrent_size=8,
                    validation_episodes=0)
"""A DAgger run of seconds."""


def _run(env, policy) -> dict:
    time_step = env.reset()
    while not time_step.last():
        time_step = env.step(policy(time_step))
    return env.task.last_info


def test_the_teacher_reaches_an_open_water_goal():
    env = suite.load("auv", "goal", task_kwargs={"action": "rate", "random": 0})  # no potential: it searches one
    info = _run(env, geodesic_teacher(env))
    assert info["event"] == "goal"


@pytest.mark.parametrize(("task", "seed"), [("obstacles", 0), ("tunnel", 1)])
def test_the_teacher_goes_round_the_trap_that_line_of_sight_crashes_into(task, seed):
    """The certified hard-tier arenas of tests/test_learning_problem.py's TRAP_CASES, where `splane` crashes."""
    env, policy = env_and_policy("splane", task, seed, {"arena": "random", "tier": "hard"})
    assert _run(env, policy)["collision"]
    env, policy = env_and_policy("geodesic-teacher", task, seed, HARD)
    info = _run(env, policy)
    assert info["event"] == "goal" and not info["collision"]


def test_the_batched_teacher_labels_each_row_as_the_per_env_teacher_does():
    seeds = [20000, 20001, 20002]
    vec = AUVVectorEnv("obstacles", num_envs=3, task_kwargs=HARD, threads=1)
    vec.reset(seed=seeds)
    teacher = BatchTeacher(vec)
    for _ in range(3):
        batched = teacher.actions()
        vec.step(batched)
    batched = teacher.actions()
    for k, seed in enumerate(seeds):
        env = suite.load("auv", "obstacles", task_kwargs={**HARD, "random": seed})
        one = geodesic_teacher(env)
        time_step = env.reset()
        for _ in range(3):
            time_step = env.step(one(time_step))
        np.testing.assert_allclose(one(time_step), batched[k], atol=1e-9)
    vec.close()


class _Spy:
    """A teacher whose label is a function of the true position now, recording the positions it was asked at."""

    def __init__(self, env, scale: float = 1.0):
        self.env, self.scale, self.asked = env, scale, []

    def __call__(self) -> np.ndarray:
        position = self.env.privileged_state()["position"]
        self.asked.append(position.copy())
        return self.scale * np.tanh(np.stack([np.sin(position[:, 0]), np.cos(position[:, 1])], axis=1))


def test_dagger_labels_are_the_teachers_actions_at_the_states_the_student_drove_to():
    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    model = build_model(*_student(env, TINY))
    seeds = [1_000_001, 1_000_002]
    spy = _Spy(env)
    data = collect(env, model, spy, 8, 0.0, seeds, np.random.default_rng(0))
    expected = np.tanh(np.stack([np.sin(np.array(spy.asked)[..., 0]), np.cos(np.array(spy.asked)[..., 1])], -1))
    np.testing.assert_allclose(data.labels, expected, atol=1e-6)
    assert not data.teacher_drove.any()
    other = _Spy(env, scale=-1.0)  # other labels, the same student: the same states
    collect(env, model, other, 8, 0.0, seeds, np.random.default_rng(0))
    np.testing.assert_array_equal(np.array(other.asked), np.array(spy.asked))
    driven = _Spy(env, scale=-1.0)  # the teacher drives: other states
    collect(env, model, driven, 8, 1.0, seeds, np.random.default_rng(0))
    assert not np.allclose(np.array(driven.asked)[1:], np.array(spy.asked)[1:])
    env.close()


def _student(env, config: DaggerConfig):
    from auv_mj.agents.imitation import student_spec
    return student_spec(env), config.student_config()


def test_the_dataset_grows_each_round_and_resume_gives_the_uninterrupted_run(tmp_path):
    def run(path, stop_after: int | None = None):
        env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
        teacher, calls = BatchTeacher(env), [0]

        def label():
            calls[0] += 1
            if stop_after is not None and calls[0] > stop_after:
                raise KeyboardInterrupt
            return teacher.actions()

        try:
            return train_dagger(env, label, path, TINY, progress=False)
        finally:
            env.close()

    whole = run(tmp_path / "a")
    assert [row["dataset_steps"] for row in whole.log] == sorted({row["dataset_steps"] for row in whole.log})
    assert whole.log[0]["dataset_steps"] < whole.log[1]["dataset_steps"]
    assert whole.log[0]["teacher_share"] == 1.0 and whole.log[1]["teacher_share"] == 0.0
    with pytest.raises(KeyboardInterrupt):
        run(tmp_path / "b", stop_after=TINY.steps_per_round)
    assert read_checkpoint(tmp_path / "b" / CHECKPOINT_NAME, "dagger").metadata["counters"]["rounds"] == 1
    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    resumed = train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False)
    env.close()
    assert resumed.rounds == 2 and resumed.dataset_steps == whole.dataset_steps
    a = read_checkpoint(tmp_path / "a" / CHECKPOINT_NAME, "dagger").tensors
    b = read_checkpoint(tmp_path / "b" / CHECKPOINT_NAME, "dagger").tensors
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert a["data.obs"].shape[1] == 4  # two rounds of two vehicles
    # a finished run goes on to more rounds on resume, its config otherwise kept; never to fewer
    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    longer = train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False, rounds=3)
    with pytest.raises(ValueError, match="rounds"):
        train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False, rounds=2)
    env.close()
    assert longer.rounds == 3 and [row["round"] for row in longer.log] == [2]
    assert longer.config == dataclasses.replace(TINY, rounds=3)
    saved = read_checkpoint(tmp_path / "b" / CHECKPOINT_NAME, "dagger")
    assert saved.metadata["counters"]["rounds"] == 3 and saved.metadata["config"]["rounds"] == 3
    # a final fit over the whole aggregate after the last round, once: its row is round config.rounds
    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    student_before = read_checkpoint(tmp_path / "b" / "student.pt", "ppo").tensors
    fitted = train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False, final_epochs=5)
    again = train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False)
    env.close()
    assert [row["round"] for row in fitted.log] == [3] and np.isnan(fitted.log[0]["beta"])
    assert fitted.log[0]["loss_after"] < fitted.log[0]["loss_before"]
    assert fitted.dataset_steps == longer.dataset_steps and again.log == []  # no new data, and not fitted twice
    student_after = read_checkpoint(tmp_path / "b" / "student.pt", "ppo").tensors
    assert any(not torch.equal(student_before[k], student_after[k]) for k in student_before)
    saved = read_checkpoint(tmp_path / "b" / CHECKPOINT_NAME, "dagger")
    assert saved.metadata["counters"]["final_fit_after"] == 3 and saved.metadata["config"]["final_epochs"] == 5
    # final_epochs given again on a fitted run: a further fit from the fitted student, on the same data, its step
    # size annealed where final_lr_fraction says so
    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    further = train_dagger(env, BatchTeacher(env).actions, tmp_path / "b", resume=True, progress=False,
                           final_epochs=4, final_lr_fraction=0.0)
    env.close()
    assert [row["round"] for row in further.log] == [3] and further.dataset_steps == fitted.dataset_steps
    assert further.log[0]["loss_before"] == pytest.approx(fitted.log[0]["loss_after"], rel=1e-5)
    assert further.log[0]["loss_after"] < further.log[0]["loss_before"]
    assert further.config == dataclasses.replace(fitted.config, final_epochs=4, final_lr_fraction=0.0)
    saved = read_checkpoint(tmp_path / "b" / CHECKPOINT_NAME, "dagger")
    assert saved.metadata["counters"]["final_fit_after"] == 3 and saved.metadata["config"]["final_lr_fraction"] == 0
    with open(tmp_path / "b" / "dagger.csv") as f:
        assert [row["round"] for row in csv.DictReader(f)][-2:] == ["3", "3"]
    with pytest.raises(ValueError, match="final_lr_fraction"):
        DaggerConfig(final_lr_fraction=1.5)


def test_behaviour_cloning_drives_the_loss_down_on_a_toy_problem():
    """Labels that a memory must carry: the sign of the sequence's first input, held through the sequence."""
    rng = np.random.default_rng(0)
    T, N = 12, 32
    obs = rng.normal(size=(T, N, 3)).astype(np.float32)
    first = np.sign(obs[0, :, 0])
    labels = np.stack([np.broadcast_to(first, (T, N)), 0.5 * np.tanh(obs[..., 1])], -1).astype(np.float32)
    starts = np.zeros((T, N), np.float32)
    starts[0] = 1
    data = Sequences(obs, starts, np.ones((T, N), np.float32), labels, np.zeros((T, N), np.float32))
    config = dataclasses.replace(TINY, epochs=150, batch_sequences=8, learning_rate=3e-3, hidden_sizes=(32,),
                                 recurrent_size=16)
    spec = {"kind": "box", "obs_shape": [3], "obs_dim": 3, "act_dim": 2, "act_shape": [2],
            "action_low": [-1.0, -1.0], "action_high": [1.0, 1.0]}
    model = build_model(spec, config.student_config())
    model.norm_obs = False
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    before, after = fit(model, optimizer, data, config, torch.Generator().manual_seed(0))
    assert after < 0.2 * before
    with torch.no_grad():
        assert float(imitation_loss(model, data)) == pytest.approx(after)


def test_the_final_fits_step_size_falls_by_a_cosine_to_its_fraction_and_returns_after():
    """DaggerConfig.final_lr_fraction: the step size of each minibatch is lr * (f + (1 - f) (1 + cos(pi t / T)) / 2),
    t = 0 .. T over the fit's minibatches (Loshchilov & Hutter 2017), and the optimizer's own again after the fit."""
    rng = np.random.default_rng(1)
    T, N = 4, 10
    obs = rng.normal(size=(T, N, 3)).astype(np.float32)
    starts = np.zeros((T, N), np.float32)
    starts[0] = 1
    data = Sequences(obs, starts, np.ones((T, N), np.float32), np.zeros((T, N, 2), np.float32),
                     np.zeros((T, N), np.float32))
    config = dataclasses.replace(TINY, epochs=3, batch_sequences=4, learning_rate=2e-3)  # 3 minibatches an epoch
    spec = {"kind": "box", "obs_shape": [3], "obs_dim": 3, "act_dim": 2, "act_shape": [2],
            "action_low": [-1.0, -1.0], "action_high": [1.0, 1.0]}
    model = build_model(spec, config.student_config())
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    seen: list[float] = []
    step = optimizer.step
    def recording_step(*args, **kwargs):
        seen.append(optimizer.param_groups[0]["lr"])
        return step(*args, **kwargs)
    optimizer.step = recording_step
    fit(model, optimizer, data, config, torch.Generator().manual_seed(0), lr_fraction=0.25)
    expected = [2e-3 * (0.25 + 0.75 * (1 + np.cos(np.pi * t / 8)) / 2) for t in range(9)]
    assert seen == pytest.approx(expected, rel=1e-12)
    assert seen[0] == pytest.approx(2e-3) and seen[-1] == pytest.approx(5e-4)
    assert optimizer.param_groups[0]["lr"] == 2e-3
    seen.clear()
    fit(model, optimizer, data, config, torch.Generator().manual_seed(0))  # the default: constant
    assert seen == [2e-3] * 9


def _labelled_batch(config: PPOConfig, steps: int, labels: torch.Tensor):
    """A model of `config` on a 3-input, 2-action box, and a minibatch of `steps` x 2 random states carrying `labels`
    (steps, 2, 2): what the imitation term's tests feed ppo_loss."""
    spec = {"kind": "box", "obs_shape": [3], "obs_dim": 3, "act_dim": 2, "act_shape": [2],
            "action_low": [-1.0, -1.0], "action_high": [1.0, 1.0]}
    model = build_model(spec, config)
    ones, zeros = torch.ones(steps, 2), torch.zeros(steps, 2)
    return model, Minibatch(torch.randn(steps, 2, 3), zeros, model.initial_state(2), torch.zeros(steps, 2, 2), zeros,
                            zeros, ones, ones, ones, None, labels)


def test_the_imitation_weight_decays_as_configured_and_enters_the_loss():
    config = PPOConfig(imitation_coef=2.0, min_imitation_coef=0.5, imitation_schedule="linear", recurrent="gru",
                       hidden_sizes=(8,), recurrent_size=4)
    assert [imitation_weight(config, s, 100) for s in (0, 50, 100, 200)] == [2.0, 1.25, 0.5, 0.5]
    assert imitation_weight(dataclasses.replace(config, imitation_schedule="constant"), 90, 100) == 2.0
    with pytest.raises(ValueError):
        PPOConfig(imitation_coef=0.1, min_imitation_coef=0.2)
    labels = torch.full((5, 2, 2), 0.7)
    model, batch = _labelled_batch(config, 5, labels)
    plain, _ = ppo_loss(model, batch, config, imitation=0.0)
    with_term, stats = ppo_loss(model, batch, config, imitation=1.5)
    assert float((with_term - plain).detach()) == pytest.approx(1.5 * float(stats["imitation_loss"]), rel=1e-5)
    with torch.no_grad():
        action_mean, _ = model.act(batch.obs, batch.starts, batch.state[:, :model.actor_state_size])
    expected = float(((action_mean - labels) ** 2).sum(-1).mean())
    assert float(stats["imitation_loss"]) == pytest.approx(expected, rel=1e-5) and expected > 0


def test_auv_mj_train_dagger_runs_and_resumes_into_the_fine_tune(tmp_path):
    command = [sys.executable, "-m", "auv_mj.cli", "train", "dagger", "--task", "obstacles", "--num-envs", "4",
               "--dagger-rounds", "1", "--dagger-steps-per-round", "4", "--dagger-epochs", "1",
               "--dagger-validation-episodes", "0", "-o", str(tmp_path), "--no-progress", "--threads", "1"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "student.pt").is_file() and (tmp_path / "dagger.csv").is_file()
    assert read_checkpoint(tmp_path / "student.pt", "ppo").metadata["spec"]["kind"] == "box"
    again = subprocess.run(command + ["--resume", "--steps", "64"], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    tuned = read_checkpoint(tmp_path / "ppo" / "checkpoint.pt", "ppo")
    assert tuned.metadata["config"]["imitation_coef"] == 1.0 and tuned.metadata["config"]["recurrent_size"] == 128


def test_the_fine_tune_after_dagger_takes_ppo_options_keeps_them_for_the_resume_and_refuses_the_wrong_ones(tmp_path):
    """`auv-mj train dagger --ppo-FIELD ...`: PPOConfig fields of the fine-tune (an ablation of the pipeline, e.g. its
    critic without privileged inputs), written to the run's options and kept on resume; a field of the student's
    network, an unknown field, options without a fine-tune and other options on resume are refused before anything
    runs."""
    from auv_mj.jobs.student import OPTIONS_NAME, checked_finetune_options, train_student

    command = [sys.executable, "-m", "auv_mj.cli", "train", "dagger", "--task", "obstacles", "--num-envs", "4",
               "--dagger-rounds", "1", "--dagger-steps-per-round", "4", "--dagger-epochs", "1",
               "--dagger-validation-episodes", "0", "-o", str(tmp_path / "run"), "--no-progress", "--threads", "1"]
    refused = subprocess.run(command + ["--ppo-privileged-critic", "false"], capture_output=True, text=True,
                             timeout=300)
    assert refused.returncode == 2 and "--ppo-privileged-critic" in refused.stderr and "--steps" in refused.stderr
    assert not (tmp_path / "run").exists()
    network = subprocess.run(command + ["--steps", "64", "--ppo-recurrent-size", "8"], capture_output=True,
                             text=True, timeout=300)
    assert network.returncode == 2 and "recurrent_size" in network.stderr and "--dagger-" in network.stderr
    assert not (tmp_path / "run").exists()
    done = subprocess.run(command + ["--steps", "32", "--ppo-privileged-critic", "false", "--ppo-target-kl", "0.05"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    kept = {"privileged_critic": False, "target_kl": 0.05}
    assert json.loads((tmp_path / "run" / OPTIONS_NAME).read_text())["finetune_options"] == kept
    tuned = read_checkpoint(tmp_path / "run" / "ppo" / "checkpoint.pt", "ppo").metadata["config"]
    assert tuned["privileged_critic"] is False and tuned["target_kl"] == 0.05 and tuned["imitation_coef"] == 1.0
    with pytest.raises(ValueError, match="keeps its own"):
        train_student(tmp_path / "run", resume=True, progress=False, threads=1, finetune_steps=64,
                      finetune_options={"privileged_critic": True})
    again = train_student(tmp_path / "run", resume=True, progress=False, threads=1, finetune_steps=64)
    assert again["finetune_steps"] >= 64
    assert read_checkpoint(tmp_path / "run" / "ppo" / "checkpoint.pt", "ppo").metadata["config"][
        "privileged_critic"] is False
    later = tmp_path / "later"  # DAgger alone, then the options on the resume that starts the fine-tune
    train_student(later, "obstacles", None, 4, TINY, progress=False, threads=1)
    train_student(later, resume=True, progress=False, threads=1, finetune_steps=32,
                  finetune_options={"privileged_critic": False})
    assert json.loads((later / OPTIONS_NAME).read_text())["finetune_options"] == {"privileged_critic": False}
    assert read_checkpoint(later / "ppo" / "checkpoint.pt", "ppo").metadata["config"]["privileged_critic"] is False
    with pytest.raises(ValueError, match="keeps its own"):
        train_student(later, resume=True, progress=False, threads=1, finetune_steps=64,
                      finetune_options={"target_kl": 0.01})
    with pytest.raises(ValueError, match="no_such_field"):
        checked_finetune_options({"no_such_field": 1})
    with pytest.raises(ValueError, match="clip_coef"):
        checked_finetune_options({"clip_coef": -1.0})
    with pytest.raises(ValueError, match="not both"):
        checked_finetune_options({"target_kl": 0.05}, PPOConfig())
    with pytest.raises(ValueError, match="imitation_coef or finetune_options"):
        train_student(tmp_path / "twice", "obstacles", None, 4, TINY, finetune_steps=32, imitation_coef=0.5,
                      finetune_options={"imitation_coef": 0.2})
    assert not (tmp_path / "twice").exists()


def test_auv_mj_train_dagger_on_the_6dof_mixture_runs_validates_and_fine_tunes(tmp_path):
    """`--task planning-mix-3d`: the 6-DOF mixture (both tasks, tiers and waters), the 3-D teacher, the validation on
    each hard cell, and the fine-tune on resume; the student reads the 3-D planning observation and the fan alone."""
    from auv_mj.tasks.auv3d import PLANNING_OBSERVATION, PRIVILEGED_FIELDS

    command = [sys.executable, "-m", "auv_mj.cli", "train", "dagger", "--task", "planning-mix-3d", "--num-envs", "1",
               "--dagger-rounds", "1", "--dagger-steps-per-round", "4", "--dagger-epochs", "1",
               "--dagger-validation-episodes", "1", "--teacher-horizon", "8", "-o", str(tmp_path), "--no-progress",
               "--threads", "1"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "student.json").read_text())["teacher_horizon"] == 8.0  # kept for the resume
    spec = read_checkpoint(tmp_path / "student.pt", "ppo").metadata["spec"]
    assert spec["obs_shape"] == [len(PLANNING_OBSERVATION) + 27] and spec["act_shape"] == [3]
    assert spec["task_options"] == {"executor": "splane-ocean"}  # the benchmark's execution layer, which it keeps
    with open(tmp_path / "dagger_cells.csv") as f:
        cells = [row.split(",")[1] for row in f.read().splitlines()[1:]]
    assert cells == ["goal3d/hard/ideal", "goal3d/hard/ocean", "tunnel3d/hard/ideal", "tunnel3d/hard/ocean"]
    again = subprocess.run(command + ["--resume", "--steps", "64"], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    tuned = read_checkpoint(tmp_path / "ppo" / "checkpoint.pt", "ppo").metadata
    # the critic of its own reads the 6-DOF env's privileged inputs; the actor reads the observation alone
    assert tuned["config"]["imitation_coef"] == 1.0 and tuned["config"]["privileged_critic"]
    assert tuned["spec"]["privileged_dim"] == len(PRIVILEGED_FIELDS)
    assert tuned["spec"]["obs_shape"] == spec["obs_shape"]
    assert '"finetune_validation"' in again.stdout


def test_dagger_on_a_mixture_takes_its_cell_weights_and_keeps_them_for_the_resume(tmp_path):
    """`cell_weights` (`--cell-weights`) oversample a mixture's cells in place of its own weights: on the 6-DOF
    mixture tunnel3d=2 adds one vehicle to each hard tube cell (1 a cell before the weights: 14 vehicles, not 12), a
    resume keeps them, and a weight that names no cell, or a task that is no mixture, is refused before the run is
    written."""
    from auv_mj.jobs.student import MIXTURE_3D_WEIGHTS, student_mixture, train_student

    config = DaggerConfig(rounds=1, steps_per_round=2, epochs=1, batch_sequences=2, hidden_sizes=(8,),
                          recurrent_size=4, validation_episodes=0)
    weights = ["standard=0.5", "hard=1.5", "tunnel3d=2"]
    run = tmp_path / "tubes"
    first = train_student(run, "planning-mix-3d", num_envs=1, dagger=config, progress=False, threads=1,
                          cell_weights=weights)
    assert first["dataset_steps"] == 14 * 2  # goal3d 1 + 2, tunnel3d 1 + 3, in each water
    assert json.loads((run / "student.json").read_text())["weights"] == {"standard": 0.5, "hard": 1.5,
                                                                         "tunnel3d": 2.0}
    again = train_student(run, resume=True, progress=False, threads=1, rounds=2)
    assert again["dataset_steps"] == 2 * 14 * 2  # the resume's batch is the run's own
    with pytest.raises(ValueError, match="keeps its own"):  # other weights on resume are refused, not ignored
        train_student(run, resume=True, progress=False, threads=1, rounds=3, cell_weights=["tunnel3d=3"])
    default = train_student(tmp_path / "default", "planning-mix-3d", num_envs=1, dagger=config, progress=False,
                            threads=1)
    assert default["dataset_steps"] == 12 * 2
    assert json.loads((tmp_path / "default" / "student.json").read_text())["weights"] == MIXTURE_3D_WEIGHTS
    planar = student_mixture(2, ["tunnel=3"])
    assert planar.cell_weights == ("tunnel=3",) and sum(planar.counts()) == 4 * 2 + 4 * 2 + 4 * 6
    for task, bad in (("planning-mix-3d", ["deep=2"]), ("planning-mix-3d", ["hard"]), ("obstacles", ["hard=2"]),
                      ("planning-mix", ["tunnel3d=2"])):
        with pytest.raises(ValueError, match="cell weight|NAME=WEIGHT|cell_weights"):
            train_student(tmp_path / "refused", task, num_envs=1, dagger=config, progress=False, cell_weights=bad)
        assert not (tmp_path / "refused").exists()


def test_a_student_without_memory_is_feed_forward(tmp_path):
    """`--dagger-recurrent none` (the no-memory ablation): the student has no memory, and DaggerConfig refuses a
    memory it does not know."""
    command = [sys.executable, "-m", "auv_mj.cli", "train", "dagger", "--task", "obstacles", "--num-envs", "2",
               "--dagger-rounds", "1", "--dagger-steps-per-round", "4", "--dagger-epochs", "1",
               "--dagger-validation-episodes", "0", "--dagger-recurrent", "none", "-o", str(tmp_path),
               "--no-progress", "--threads", "1"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    student = read_checkpoint(tmp_path / "student.pt", "ppo").metadata["config"]
    assert student["recurrent"] is None
    dagger = read_checkpoint(tmp_path / CHECKPOINT_NAME, "dagger").metadata["config"]
    assert dagger["recurrent"] is None
    with pytest.raises(ValueError, match="recurrent"):
        DaggerConfig(recurrent="rnn")
    refused = subprocess.run(command + ["--teacher-horizon", "8", "-o", str(tmp_path / "refused")],
                             capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "teacher_horizon" in refused.stderr  # the 3-D teacher's only
    assert not (tmp_path / "refused").exists()


def test_auv_mj_train_ppo_on_the_6dof_mixture_learns_without_a_teacher(tmp_path):
    from auv_mj.tasks.auv3d import PRIVILEGED_FIELDS

    """`auv-mj train ppo --task planning-mix-3d` (the no-teacher ablation): PPO from scratch on the student's batch and
    problem, its critic reading the privileged inputs, no imitation term; the planar mixture's options are refused,
    and an existing run is not overwritten."""
    command = [sys.executable, "-m", "auv_mj.cli", "train", "ppo", "--task", "planning-mix-3d", "--steps", "32",
               "--envs-per-cell", "1", "--ppo-num-steps", "4", "--validation-episodes", "1", "-o", str(tmp_path),
               "--no-progress", "--no-tensorboard", "--threads", "1"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    tuned = read_checkpoint(tmp_path / "checkpoint.pt", "ppo").metadata
    assert tuned["config"]["privileged_critic"] and tuned["config"]["imitation_coef"] == 0.0
    assert tuned["spec"]["privileged_dim"] == len(PRIVILEGED_FIELDS)
    assert '"cell:tunnel3d/hard/ocean"' in done.stdout
    again = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert again.returncode == 2 and "--resume" in again.stderr
    planar = subprocess.run(command + ["--reward", "progress"], capture_output=True, text=True, timeout=300)
    assert planar.returncode == 2 and "--reward" in planar.stderr
    other = subprocess.run(command + ["--task-kwargs", '{"reward": "suite"}', "-o", str(tmp_path / "refused")],
                           capture_output=True, text=True, timeout=300)
    assert other.returncode == 2 and "observation" in other.stderr and "reward" in other.stderr
    assert not (tmp_path / "refused").exists()


def test_ppo_from_scratch_on_the_6dof_mixture_learns_from_the_observation_given_and_keeps_it(tmp_path):
    """`auv-mj train ppo --task planning-mix-3d --task-kwargs '{"observation": "fan-held"}'`: the no-teacher ablation
    learns from the input its student had (the batch's tasks are built with it, and the checkpoint names it, so the
    zoo and the validation deploy it so); the resume reads it back, another one on resume is refused, and an
    observation the 6-DOF tasks do not know is refused before the run is written."""
    from auv_mj.jobs.student import scratch_3d_config, train_ppo_3d

    config = dataclasses.replace(scratch_3d_config(), num_steps=4, num_minibatches=1, update_epochs=1)
    out = train_ppo_3d(tmp_path / "held", 16, config, 1, observation="fan-held", threads=1, progress=False,
                       validation_episodes=0)
    spec = read_checkpoint(out["checkpoint"], "ppo").metadata["spec"]
    assert spec["task_options"] == {"executor": "splane-ocean", "observation": "fan-held"}
    again = train_ppo_3d(tmp_path / "held", 2 * out["env_steps"], None, 1, resume=True, threads=1, progress=False,
                         validation_episodes=0)
    assert again["env_steps"] == 2 * out["env_steps"]
    assert read_checkpoint(again["checkpoint"], "ppo").metadata["spec"]["task_options"]["observation"] == "fan-held"
    with pytest.raises(ValueError, match="observation 'fan'"):
        train_ppo_3d(tmp_path / "held", 3 * out["env_steps"], None, 1, observation="fan", resume=True, threads=1,
                     progress=False, validation_episodes=0)
    with pytest.raises(ValueError, match="planner-map"):
        train_ppo_3d(tmp_path / "refused", 16, config, 1, observation="planner-map", threads=1, progress=False,
                     validation_episodes=0)
    assert not (tmp_path / "refused").exists()


def test_the_teacher_labels_a_mixture_row_as_it_labels_that_cells_own_batch():
    """`PlanningMixtureVectorEnv.privileged_state` is its cells' read-outs in row order: the teacher's labels on the
    mixture are those on each cell's own batch, reset with the same seeds."""
    options = {k: v for k, v in HARD.items() if k not in ("arena", "tier")}
    mixture = PlanningMixtureVectorEnv(1, tasks=("obstacles", "tunnel"), tiers=("hard",), waters=("ideal",),
                                       task_kwargs=options, threads=1)
    mixture.reset(seed=3)
    labels = BatchTeacher(mixture).actions()
    assert mixture.action_kind == "rate" and labels.shape == (2, 2)
    for k, (task, tier, water) in enumerate(mixture.cells):
        one = AUVVectorEnv(task, num_envs=1, threads=1,
                           task_kwargs={**options, "arena": "random", "tier": tier, "conditions": water})
        one.reset(seed=[int(mixture.episode_seeds[k])])
        np.testing.assert_allclose(BatchTeacher(one).actions()[0], labels[k], atol=1e-12)
        one.close()
    mixture.close()


def test_the_student_keeps_the_task_options_it_must_run_with_and_deploys_on_the_dict_observation(tmp_path):
    """student.pt records action="rate" and observation="planner" (the zoo applies them), and its policy reads a
    goal dict's `observation` vector alone."""
    from auv_mj.agents.ppo.policy import PPOPolicy

    env = AUVVectorEnv("obstacles", num_envs=2, task_kwargs=HARD, threads=1)
    try:
        train_dagger(env, BatchTeacher(env).actions, tmp_path, dataclasses.replace(TINY, rounds=1), progress=False)
        obs, _ = env.reset(seed=[5, 6])
    finally:
        env.close()
    spec = read_checkpoint(tmp_path / "student.pt", "ppo").metadata["spec"]
    assert spec["task_options"] == {"action": "rate", "observation": "planner"}
    policy = PPOPolicy.load(tmp_path / "student.pt")
    from_dict = policy(obs)
    policy.reset()
    np.testing.assert_array_equal(policy(obs["observation"]), from_dict)
    with pytest.raises(ValueError, match="'observation'"):
        policy({"desired_goal": obs["desired_goal"]})


def test_dagger_on_the_mixture_validates_every_hard_cell(tmp_path):
    """`train_student(..., "planning-mix")`: the student's mixture, a row of dagger_cells.csv per hard cell."""
    from auv_mj.jobs.student import MIXTURE_TASK, train_student

    config = dataclasses.replace(TINY, rounds=1, validation_episodes=1, validation_max_steps=3)
    with pytest.raises(ValueError, match="sets the task options itself"):
        train_student(tmp_path / "bad", MIXTURE_TASK, {"reward": "suite"}, 1, config)
    out = train_student(tmp_path, MIXTURE_TASK, None, 1, config, threads=1, progress=False)
    assert out["dagger_rounds"] == 1
    cells = (tmp_path / "dagger_cells.csv").read_text().splitlines()
    assert cells[0] == "round,cell,val_success" and len(cells) == 1 + 6
    assert {line.split(",")[1] for line in cells[1:]} == {
        f"{task}/hard/{water}" for task in ("obstacles", "moving_obstacles", "tunnel") for water in ("ideal", "ocean")}


@pytest.mark.parametrize(("task", "observation", "other"), [("planning-mix", "planner-map", "paper"),
                                                           ("planning-mix-3d", "fan-map", "planner-map")])
def test_dagger_on_a_mixture_takes_the_sonar_map_observation_and_its_student_keeps_it(tmp_path, task, observation,
                                                                                      other):
    """`--task planning-mix --task-kwargs '{"observation": "planner-map"}'`: the student reads the planner vector and
    its own sonar map (MEMORY_BEAMS inputs more); on `planning-mix-3d` with "fan-map" the fan and its own voxel map
    (FAN_MEMORY_BEAMS more). Its checkpoint names the observation (beside the 3-D executor: what the zoo and the
    validation deploy it with), and the resume keeps it; another observation or any other task option of the mixture
    is refused before the run is written."""
    from auv_mj.arenas.sonar_memory import FAN_MEMORY_BEAMS, MEMORY_BEAMS
    from auv_mj.jobs.student import train_student
    from auv_mj.tasks.auv3d import PLANNING_OBSERVATION
    from auv_mj.tasks.planning_observation import PLANNER_FIELDS, PLANNER_MAP_FIELDS

    if observation == "planner-map":
        assert len(PLANNER_MAP_FIELDS) == len(PLANNER_FIELDS) + MEMORY_BEAMS
    size = {"planner-map": len(PLANNER_MAP_FIELDS), "fan-map": len(PLANNING_OBSERVATION) + FAN_MEMORY_BEAMS + 27}
    config = dataclasses.replace(TINY, rounds=1)
    out = train_student(tmp_path / "map", task, {"observation": observation}, 1, config, threads=1, progress=False)
    spec = read_checkpoint(out["student"], "ppo").metadata["spec"]
    assert spec["task_options"]["observation"] == observation
    if task == "planning-mix-3d":
        assert spec["task_options"] == {"executor": "splane-ocean", "observation": observation}
    assert spec["obs_shape"] == [size[observation]]
    again = train_student(tmp_path / "map", resume=True, progress=False, threads=1, rounds=2)
    assert again["dagger_rounds"] == 2
    assert read_checkpoint(again["student"], "ppo").metadata["spec"]["task_options"]["observation"] == observation
    for bad in ({"observation": other}, {"observation": observation, "reward": "suite"}):
        with pytest.raises(ValueError, match="observation"):
            train_student(tmp_path / "refused", task, bad, 1, config, progress=False)
        assert not (tmp_path / "refused").exists()


def test_the_students_view_of_the_mixture_keeps_its_cells_and_the_vehicles_position():
    """PPO's per-cell logs read `cells` and `cell_of_row`, its speed log info["achieved_goal"]: the student's view
    (its observation vector alone) keeps them."""
    from auv_mj.agents.ppo.spaces import student_view

    options = {k: v for k, v in HARD.items() if k not in ("arena", "tier")}
    mixture = PlanningMixtureVectorEnv(1, tasks=("obstacles",), tiers=("hard",), waters=("ideal", "ocean"),
                                       task_kwargs=options, threads=1)
    view = student_view(mixture)
    try:
        obs, info = view.reset(seed=0)
        raw = mixture.privileged_state()["position"]
        assert view.cells == mixture.cells and list(view.cell_of_row) == [0, 1]
        assert obs.shape == (2, view.single_observation_space.shape[0])
        np.testing.assert_allclose(info["achieved_goal"][0, :2], raw[0])
        assert view.policy_options == {"action": "rate", "observation": "planner"}
    finally:
        view.close()


def test_near_movers_measures_from_the_movers_disc_not_its_centre():
    position = np.array([[0.0, 0.0], [100.0, 0.0]])
    movers = [np.array([[10.0, 0.0, 2.0, -1.0, 0.0]]), np.zeros((0, 5))]  # 8 m from the first vehicle's disc
    assert near_movers(position, movers, 9.0).tolist() == [True, False]
    assert near_movers(position, movers, 7.0).tolist() == [False, False]
    with pytest.raises(ValueError, match="mover_reach"):
        BatchTeacher(AUVVectorEnv("obstacles", num_envs=1, task_kwargs=HARD, threads=1), -1.0)


def test_the_teacher_with_a_mover_reach_labels_the_rows_near_a_mover_alone_as_the_full_teacher_does():
    """State-by-state imitation: with mover_reach the teacher's rows near a mover are the full teacher's labels and
    the others NaN; a reach past the arena labels every row, one of a millimetre none of them (no collision here)."""
    vec = AUVVectorEnv("moving_obstacles", num_envs=4, task_kwargs=HARD, threads=1)
    vec.reset(seed=[20000, 20001, 20002, 20003])
    full, near, everywhere, nowhere = (BatchTeacher(vec), BatchTeacher(vec, 120.0), BatchTeacher(vec, 1e4),
                                       BatchTeacher(vec, 1e-3))
    seen = set()
    for _ in range(20):
        labels, gated = full.actions(), near.actions()
        state = vec.privileged_state()
        gaps = [np.min(np.hypot(*(m[:, :2] - p).T) - m[:, 2])
                for p, m in zip(state["position"], state["movers"], strict=True)]
        expected = np.array(gaps) < 120.0  # at these seeds' starts: one vehicle 85-104 m from a mover, the rest 155+
        np.testing.assert_array_equal(np.isfinite(gated).all(1), expected)
        np.testing.assert_allclose(gated[expected], labels[expected], atol=1e-12)
        seen |= set(expected.tolist())
        np.testing.assert_allclose(everywhere.actions(), labels, atol=1e-12)
        assert np.isnan(nowhere.actions()).all()
        vec.step(labels)
    assert seen == {True, False}  # both kinds of row were met
    vec.close()


def test_the_imitation_term_skips_the_states_the_teacher_left_unlabelled():
    config = PPOConfig(imitation_coef=1.0, recurrent="gru", hidden_sizes=(8,), recurrent_size=4)
    labels = torch.full((6, 2, 2), 0.7)
    labels[::2, 0] = float("nan")  # every other step of the first vehicle: left to RL
    model, batch = _labelled_batch(config, 6, labels)
    loss, stats = ppo_loss(model, batch, config, imitation=1.0)
    loss.backward()
    assert torch.isfinite(loss) and all(torch.isfinite(p.grad).all() for p in model.parameters() if p.grad is not None)
    with torch.no_grad():
        action_mean, _ = model.act(batch.obs, batch.starts, batch.state[:, :model.actor_state_size])
    labelled = torch.isfinite(labels).all(-1)
    expected = float(((action_mean - 0.7) ** 2).sum(-1)[labelled].mean())
    assert float(stats["imitation_loss"]) == pytest.approx(expected, rel=1e-5)
    plain, _ = ppo_loss(model, batch, config, imitation=0.0)
    unlabelled = batch._replace(labels=torch.full_like(labels, float("nan")))
    none, stats = ppo_loss(model, unlabelled, config, imitation=1.0)
    assert float(stats["imitation_loss"]) == 0.0
    assert float(none.detach()) == pytest.approx(float(plain.detach()), rel=1e-6)


def test_auv_mj_train_ppo_continues_a_planner_under_the_teacher_near_movers_and_resumes_with_it(tmp_path,
                                                                                                monkeypatch):
    """`auv-mj train ppo --init ... --ppo-imitation-coef C --teacher-mover-reach M`: the run keeps its teacher
    (teacher.json) for the resume, imitates only where labelled (a reach past the arena: a term > 0; a millimetre:
    none), and a reach without an imitation term, or another reach on resume, is refused before anything is run."""
    from auv_mj.agents.ppo import planner
    from auv_mj.cli import main
    from auv_mj.jobs.student import continue_planner

    monkeypatch.setattr(planner, "validate", lambda policy, episodes, tasks, **kwargs: {
        f"{task}/hard/ideal": 0.5 for task in tasks})
    config = PPOConfig(num_steps=8, num_minibatches=1, update_epochs=1, hidden_sizes=(8,), recurrent="gru",
                       recurrent_size=8, checkpoint_every=1, separate_critic=True)
    mixture = planner.MixtureConfig(envs_per_cell=2, tasks=("moving_obstacles",), tiers=("hard",), waters=("ideal",),
                                    validate_every=16, reward="geodesic", action="rate", observation="planner",
                                    goal_input=False)
    first = planner.train_planner(tmp_path / "first", config, mixture, 16, progress=False, tensorboard=False)
    taught = dataclasses.replace(config, imitation_coef=1.0)
    losses = {}
    for name, reach in (("far", 1e4), ("none", 1e-3)):
        continue_planner(tmp_path / name, taught, mixture, 16, progress=False, tensorboard=False,
                         init=first["checkpoint"], mover_reach=reach)
        assert json.loads((tmp_path / name / "teacher.json").read_text())["mover_reach"] == reach
        with open(tmp_path / name / "progress.csv") as f:
            losses[name] = [float(row["imitation_loss"]) for row in csv.DictReader(f)]
    assert min(losses["far"]) > 0 and max(losses["none"]) == 0
    again = continue_planner(tmp_path / "far", taught, mixture, 32, resume=True, progress=False, tensorboard=False)
    assert again["env_steps"] == 32
    with pytest.raises(ValueError, match="mover_reach"):
        continue_planner(tmp_path / "far", taught, mixture, 48, resume=True, progress=False, tensorboard=False,
                         mover_reach=5.0)
    with pytest.raises(ValueError, match="not both"):  # a teacher of its own env, or the caller's env and teacher
        planner.train_planner(tmp_path / "both", taught, mixture, 16, progress=False, tensorboard=False,
                              teacher=lambda: np.zeros((2, 2)), teacher_of=lambda env: BatchTeacher(env).actions)
    assert not (tmp_path / "both").exists()
    with pytest.raises(SystemExit):
        main(["train", "ppo", "--task", "planning-mix", "--init", str(first["checkpoint"]), "--steps", "16",
              "--teacher-mover-reach", "20", "-o", str(tmp_path / "refused"), "--no-progress"])
    assert not (tmp_path / "refused").exists()


def test_a_mixture_takes_an_observation_alone_and_names_what_it_refuses():
    """`mixture_options`, the one reading of a mixture's task options for `train dagger` and `train ppo`."""
    from auv_mj.jobs.student import mixture_options

    assert mixture_options("planning-mix", None) == {} and mixture_options("planning-mix-3d", {}) == {}
    assert mixture_options("planning-mix", {"observation": "planner-map"}) == {"observation": "planner-map"}
    assert mixture_options("planning-mix-3d", {"observation": "fan-held"}) == {"observation": "fan-held"}
    with pytest.raises(ValueError, match="observation must be one of .*got 'fan-held'"):
        mixture_options("planning-mix", {"observation": "fan-held"})  # the 6-DOF one's, not the planar one's
    with pytest.raises(ValueError, match="takes only an observation .*'tier': 'hard'"):
        mixture_options("planning-mix-3d", {"observation": "fan-held", "tier": "hard"})


def test_the_planar_mixture_takes_an_action_map_and_the_6dof_one_does_not():
    """`mixture_options`: the planar mixture's action map ("paper": a heading offset, whose labels carry how much to
    turn) reaches the student's mixture; the 6-DOF mixture keeps its own action, and a map that is none is named."""
    from auv_mj.jobs.student import mixture_options, student_mixture

    chosen = mixture_options("planning-mix", {"observation": "planner-map", "action": "paper"})
    assert chosen == {"observation": "planner-map", "action": "paper"}
    options = student_mixture(4, None, chosen["observation"], chosen["action"]).task_kwargs()
    assert options["action"] == "paper" and options["observation"] == "planner-map"
    assert student_mixture().task_kwargs()["action"] == "rate"
    with pytest.raises(ValueError, match="task_kwargs action must be one of .*got 'turn'"):
        mixture_options("planning-mix", {"action": "turn"})
    with pytest.raises(ValueError, match="takes only an observation .*got {'action': 'paper'}"):
        mixture_options("planning-mix-3d", {"action": "paper"})
