"""The planner learned from scratch: the training mixture's seeds, the registered recurrent policy's memory, and a
short `auv-mj train ppo` run that checkpoints, validates and resumes exactly."""

from __future__ import annotations

import csv
import dataclasses
import json

import dm_env
import numpy as np
import pytest
import torch

from auv_mj import seeds
from auv_mj.agents import ppo
from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.cli import main
from auv_mj.tasks import suite
from auv_mj.tasks.mixture import PlanningMixtureVectorEnv, mixture_cells
from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.zoo.registry import checkpoint_kind, make_env, make_policy, recurrent_policy

SHORT = {"time_limit": 1.0}
"""Episodes of two planner steps, so that autoresets come at once."""


def _mixture(**kwargs) -> PlanningMixtureVectorEnv:
    return PlanningMixtureVectorEnv(envs_per_cell=2, tasks=("obstacles", "moving_obstacles"), tiers=("hard",),
                                    waters=("ideal", "ocean"), **kwargs)


def test_mixture_cells_and_rows():
    assert len(mixture_cells()) == 12
    env = _mixture()
    assert env.num_envs == 8
    assert [env.cells[k] for k in env.cell_of_row] == [
        ("obstacles", "hard", "ideal")] * 2 + [("obstacles", "hard", "ocean")] * 2 + [
        ("moving_obstacles", "hard", "ideal")] * 2 + [("moving_obstacles", "hard", "ocean")] * 2
    with pytest.raises(ValueError, match="tier"):
        PlanningMixtureVectorEnv(envs_per_cell=1, task_kwargs={"tier": "hard"})
    with pytest.raises(ValueError, match="tasks"):
        PlanningMixtureVectorEnv(envs_per_cell=1, tasks=("goal",))


def test_mixture_seeds_are_training_seeds_and_deterministic():
    env = _mixture(task_kwargs=SHORT)
    obs, _ = env.reset(seed=5)
    first = env.episode_seeds.copy()
    assert first.tolist() == [seeds.train_seed(5, i) for i in range(8)]
    again, _ = _mixture(task_kwargs=SHORT).reset(seed=5)
    for key in obs:
        np.testing.assert_array_equal(obs[key], again[key])
    # row 3 (obstacles / hard / ocean, its second vehicle) is episode seed first[3]: the cell's own batch agrees
    alone, _ = AUVVectorEnv("obstacles", 1, task_kwargs={**SHORT, "arena": "random", "tier": "hard",
                                                         "conditions": "ocean"}).reset(seed=[int(first[3])])
    np.testing.assert_array_equal(obs["observation"][3], alone["observation"][0])
    actions = np.zeros(env.action_space.shape)
    ended = np.zeros(8, dtype=bool)
    while not ended.all():
        _, _, term, trunc, _ = env.step(actions)
        ended |= term | trunc
    # every episode ended together (the short time limit): the next seeds follow in row order
    assert env.episode_seeds.tolist() == [seeds.train_seed(5, 8 + j) for j in range(8)]
    assert all(int(s) in seeds.TRAIN for s in env.episode_seeds)
    obs, reward, _, _, _ = env.step(actions)  # NEXT_STEP: the autoreset
    assert np.all(reward == 0)
    fresh, _ = AUVVectorEnv("moving_obstacles", 1, task_kwargs={**SHORT, "arena": "random", "tier": "hard",
                                                                "conditions": "ideal"}).reset(
        seed=[int(env.episode_seeds[4])])
    np.testing.assert_array_equal(obs["observation"][4], fresh["observation"][0])


def test_mixture_refuses_validation_and_test_seeds():
    env = _mixture()
    good = [seeds.train_seed(0, i) for i in range(8)]
    env.reset(seed=good)
    for outside in (seeds.VALIDATION.start, seeds.TEST.start + 3):
        with pytest.raises(ValueError, match="training seeds only"):
            env.reset(seed=[outside, *good[1:]])


def _tiny_checkpoint(tmp_path, recurrent):
    env = AUVVectorEnv("obstacles", 1, task_kwargs={"arena": "random"})
    spec = ppo.env_spec(env.single_observation_space, env.single_action_space)
    config = ppo.PPOConfig(recurrent=recurrent, hidden_sizes=(16,), recurrent_size=8, init_log_std=0.0)
    model = ppo.build_model(spec, config)
    with torch.no_grad():  # a policy head that reads the memory (the initial 0.01 gain hides it)
        head = model.actor_head if recurrent else model.actor[-1]
        head.weight.normal_(0.0, 2.0, generator=torch.Generator().manual_seed(1))
    path = tmp_path / "planner.pt"
    ppo.save_ppo(path, model, None, None, config, spec, {"iteration": 0, "env_steps": 0})
    return path


def test_registered_policy_resets_its_memory_at_episode_start(tmp_path):
    path = _tiny_checkpoint(tmp_path, "gru")
    assert checkpoint_kind(path) == "ppo" and read_checkpoint(path).metadata["kind"] == "ppo"
    name = f"planner-memory={path}"
    env = make_env(name, "obstacles", 20_000, arena="random", tier="hard")
    act = make_policy(name, env, task="obstacles").act
    first = env.reset()
    a0 = act(first)
    time_step = first
    for _ in range(4):
        time_step = env.step(act(time_step))
    carried = act(time_step._replace(step_type=dm_env.StepType.MID, observation=first.observation))
    assert not np.allclose(carried, a0)  # the memory changes the action: the test below can fail
    env2 = make_env(name, "obstacles", 20_000, arena="random", tier="hard")
    restart = env2.reset()
    np.testing.assert_allclose(act(restart), a0, rtol=0, atol=1e-12)  # first(): the memory was zeroed
    fresh = recurrent_policy(path, env2)
    np.testing.assert_allclose(fresh.act(restart), a0, rtol=0, atol=1e-12)


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _train(run_dir, steps, *extra):
    return main(["train", "ppo", "--task", "planning-mix", "--steps", str(steps), "--envs-per-cell", "1",
                 "--ppo-num-steps", "8", "--ppo-num-minibatches", "2", "--ppo-update-epochs", "1",
                 "--ppo-hidden-sizes", "16", "--ppo-recurrent-size", "8", "--ppo-checkpoint-every", "1",
                 "--validate-every", "96", "--validation-episodes", "1", "--validation-max-steps", "3",
                 "--run-dir", str(run_dir), "--no-progress", "--no-tensorboard", *extra])


def test_train_ppo_checkpoints_validates_and_resumes_exactly(tmp_path):
    assert _train(tmp_path / "a", 192) == 0
    assert (tmp_path / "a" / "snapshots" / "steps_96.pt").is_file()
    assert (tmp_path / "a" / "best.pt").is_file()
    assert [r["env_steps"] for r in _rows(tmp_path / "a" / "validation.csv")] == ["96", "192"]
    assert _train(tmp_path / "a", 288, "--resume") == 0
    assert _train(tmp_path / "b", 288) == 0
    (resumed, meta), config = ppo.read_ppo(tmp_path / "a" / "checkpoint.pt")
    straight = read_checkpoint(tmp_path / "b" / "checkpoint.pt", "ppo").tensors
    assert config.recurrent == "gru" and meta["counters"]["env_steps"] == 288
    for key, value in straight.items():
        if key.startswith("model."):
            torch.testing.assert_close(resumed[key], value, rtol=0, atol=0)
    assert [r["env_steps"] for r in _rows(tmp_path / "a" / "validation.csv")] == ["96", "192", "288"]
    with pytest.raises(SystemExit):
        _train(tmp_path / "b", 288)  # the run exists: --resume or another directory
    assert suite.DOMAIN == "auv"


# ---------------------------------------------------------------------------------------------------------------------
# Oversampling and the snapshot choice (issue 51, item 4)


def test_cell_weights_oversample_the_hard_cells_and_the_mixture_takes_a_count_per_cell():
    from auv_mj.agents.ppo.planner import LEARNED_MIXTURE, MixtureConfig
    from auv_mj.tasks.mixture import cell_counts

    cells = mixture_cells()
    counts = dict(zip(cells, cell_counts(8, cells, {"hard": 1.5, "standard": 0.5, "tunnel": 1.5}), strict=True))
    assert counts[("obstacles", "standard", "ideal")] == 4 and counts[("moving_obstacles", "hard", "ocean")] == 12
    assert counts[("tunnel", "standard", "ocean")] == 6 and counts[("tunnel", "hard", "ideal")] == 18
    assert MixtureConfig().counts() == [8] * 12  # the shipped run's mixture, unchanged
    assert LEARNED_MIXTURE.num_envs == sum(counts.values()) == 112
    for bad in (("hard",), ("deep=2",), ("hard=0",), ("hard=x",)):
        with pytest.raises(ValueError, match="cell weight|NAME=WEIGHT"):
            MixtureConfig(cell_weights=bad)
    env = PlanningMixtureVectorEnv(envs_per_cell=[1, 2], tasks=("obstacles",), tiers=("hard",),
                                   waters=("ideal", "ocean"), task_kwargs=SHORT)
    assert env.num_envs == 3 and env.cell_of_row.tolist() == [0, 1, 1]
    obs, _ = env.reset(seed=7)
    ended = np.zeros(3, dtype=bool)
    while not ended.all():
        _, _, term, trunc, _ = env.step(np.zeros(env.action_space.shape))
        ended |= term | trunc
    obs, _, _, _, _ = env.step(np.zeros(env.action_space.shape))  # NEXT_STEP: the autoreset, row 2 = cell 1's 2nd
    alone, _ = AUVVectorEnv("obstacles", 1, task_kwargs={**SHORT, "arena": "random", "tier": "hard",
                                                         "conditions": "ocean"}).reset(seed=[int(env.episode_seeds[2])])
    np.testing.assert_array_equal(obs["observation"][2], alone["observation"][0])
    with pytest.raises(ValueError, match="one per cell"):
        PlanningMixtureVectorEnv(envs_per_cell=[1, 2, 3], tasks=("obstacles",), tiers=("hard",))


def test_windowed_choice_takes_the_last_snapshot_of_the_best_window_not_the_single_best_point():
    from auv_mj.agents.ppo.planner import windowed_choice, windowed_means

    # a lucky spike at index 1, a plateau at 3-5, then a fall: the single best is the spike
    scores = [0.30, 0.62, 0.35, 0.50, 0.55, 0.52, 0.30]
    assert windowed_choice(scores, 1) == 1
    assert windowed_means(scores, 3)[:3] == pytest.approx([0.30, 0.46, 0.42333333])
    assert windowed_choice(scores, 3) == 5  # (0.50 + 0.55 + 0.52) / 3 = 0.523, the best full window
    assert windowed_choice(scores, 2) == 5  # (0.55 + 0.52) / 2 = 0.535 > (0.50 + 0.55) / 2 > (0.62 + 0.35) / 2
    assert windowed_choice(scores[:2], 3) == 1  # partial windows while fewer than 3 exist: 0.46 > 0.30
    assert windowed_choice([0.5, 0.5, 0.5], 2) == 1  # ties: the earlier window
    assert windowed_choice([], 3) is None


def test_train_planner_validates_on_validation_seeds_and_copies_the_windowed_choice_to_best(tmp_path, monkeypatch):
    from auv_mj.agents.ppo import planner

    scripted = iter([0.30, 0.62, 0.50, 0.55, 0.20])
    seen = []

    def scripted_validate(policy, episodes, tasks, threads=None, max_steps=None, **kwargs):
        seen.append(episodes)
        return {f"{task}/hard/ideal": next(scripted) for task in tasks}

    monkeypatch.setattr(planner, "validate", scripted_validate)
    mixture = planner.MixtureConfig(envs_per_cell=1, tasks=("obstacles",), tiers=("hard",), waters=("ideal",),
                                    validate_every=8, validation_episodes=50, validation_window=2)
    config = ppo.PPOConfig(num_steps=8, num_minibatches=1, update_epochs=1, hidden_sizes=(8,), recurrent="gru",
                           recurrent_size=8, checkpoint_every=1, lr_schedule="linear")
    result = planner.train_planner(tmp_path, config, mixture, 40, progress=False, tensorboard=False)
    assert seen == [50] * 5
    rows = _rows(tmp_path / "validation.csv")
    assert [float(r["hard_success_window"]) for r in rows] == pytest.approx([0.30, 0.46, 0.56, 0.525, 0.375])
    # the single best point is 0.62 at 16 steps; the best window of two ends at 24 steps
    assert (result["best_steps"], result["best_point"]) == (24, 0.50)
    assert result["best_success"] == pytest.approx(0.56)
    best = read_checkpoint(tmp_path / "best.pt").tensors
    chosen = read_checkpoint(tmp_path / "snapshots" / "steps_24.pt").tensors
    assert all(torch.equal(best[k], chosen[k]) for k in chosen)
    progress = _rows(tmp_path / "progress.csv")  # one schedule over the five chunks: lr falls by a fifth a rollout
    assert [float(r["learning_rate"]) for r in progress] == pytest.approx([3e-4 * (1 - k / 5) for k in range(5)])
    assert (tmp_path / "cells.csv").is_file()


def test_train_ppo_takes_the_new_options_and_a_resume_may_change_validation_but_not_training(tmp_path, capsys):
    run = tmp_path / "run"
    extra = ("--ppo-lr-schedule", "linear", "--ppo-separate-critic", "true", "--cell-weights", "hard=2",
             "--validation-window", "2", "--goal-input", "false")
    assert _train(run, 288, *extra) == 0  # 18 vehicles (the hard cells doubled), 144 steps a rollout
    mixture = json.loads((run / "mixture.json").read_text())
    assert (mixture["cell_weights"], mixture["validation_window"], mixture["goal_input"]) == (["hard=2"], 2, False)
    (_, meta), config = ppo.read_ppo(run / "checkpoint.pt")
    assert config.separate_critic and config.lr_schedule == "linear" and meta["counters"]["schedule_steps"] == 288
    assert [float(r["learning_rate"]) for r in _rows(run / "progress.csv")] == pytest.approx([3e-4, 1.5e-4])
    assert "mean of its window" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        _train(run, 432, "--resume", "--cell-weights", "hard=3")  # a training field: refused
    assert _train(run, 432, "--resume", "--validation-window", "3") == 0  # the schedule stays the run's own
    assert json.loads((run / "mixture.json").read_text())["validation_window"] == 3
    assert float(_rows(run / "progress.csv")[-1]["learning_rate"]) == 0.0  # past the planned 288 steps: the floor


def test_a_learner_without_the_goal_input_reads_the_observation_alone_and_a_new_run_continues_it(tmp_path,
                                                                                                 monkeypatch):
    from auv_mj.agents.ppo import planner

    monkeypatch.setattr(planner, "validate", lambda policy, episodes, tasks, **kwargs: {
        f"{task}/hard/ideal": 0.5 for task in tasks})
    config = ppo.PPOConfig(num_steps=8, num_minibatches=1, update_epochs=1, hidden_sizes=(8,), recurrent="gru",
                           recurrent_size=8, checkpoint_every=1, separate_critic=True)
    cell = {"envs_per_cell": 1, "tasks": ("obstacles",), "tiers": ("hard",), "waters": ("ideal",),
            "validate_every": 8, "observation": "planner"}
    alone = planner.MixtureConfig(**cell, goal_input=False)
    first = planner.train_planner(tmp_path / "alone", config, alone, 8, progress=False, tensorboard=False)
    (tensors, meta), _ = ppo.read_ppo(first["checkpoint"])
    with_goal = planner.MixtureConfig(**cell)
    env = with_goal.make_env()
    try:
        parts = [int(np.prod(env.single_observation_space[k].shape)) for k in ("observation", "desired_goal")]
    finally:
        env.close()
    assert meta["spec"]["kind"] == "box" and meta["spec"]["obs_dim"] == parts[0]
    # a new run from it on a mixture that offers the goal dict sees it as the checkpoint did, its critic included
    second = planner.train_planner(tmp_path / "on", dataclasses.replace(config, learning_rate=1e-12), with_goal, 8,
                                   progress=False, tensorboard=False, init=first["checkpoint"], init_critic=True)
    (again, meta2), _ = ppo.read_ppo(second["checkpoint"])
    assert meta2["spec"]["obs_dim"] == parts[0]
    for key in ("model.actor_head.weight", "model.critic_head.weight"):
        torch.testing.assert_close(again[key], tensors[key], rtol=1e-6, atol=1e-9)
    on_goal = planner.train_planner(tmp_path / "goal", config, with_goal, 8, progress=False, tensorboard=False)
    assert ppo.read_ppo(on_goal["checkpoint"])[0].metadata["spec"]["obs_dim"] == sum(parts)
    # a learner of the sonar map: a new run from it on the planner mixture keeps its observation, and says so
    mapped = planner.train_planner(tmp_path / "map", config, dataclasses.replace(alone, observation="planner-map"), 8,
                                   progress=False, tensorboard=False)
    third = planner.train_planner(tmp_path / "from-map", dataclasses.replace(config, learning_rate=1e-12), alone, 8,
                                  progress=False, tensorboard=False, init=mapped["checkpoint"], init_critic=True)
    spec = ppo.read_ppo(third["checkpoint"])[0].metadata["spec"]
    assert spec["task_options"]["observation"] == "planner-map" and spec["obs_dim"] == parts[0] + 16
    assert json.loads((tmp_path / "from-map" / "mixture.json").read_text())["observation"] == "planner-map"
