"""Training with collector processes (agents.collector): it learns, it is deterministic given the seed and the
number of collectors, it keeps the update-to-data ratio, and HER stores each collector's episodes whole."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import torch
from test_agents import FAST, evaluate, make_env

from agents.checkpoint import read_checkpoint, read_replay
from agents.collector import Collectors
from agents.ddpg import DDPG, DDPGConfig
from agents.policy import Policy
from agents.train import _owed_updates, env_spec, train


def _log(run_dir):
    """progress.csv without the wall-time column."""
    return [row.rsplit(",", 1)[0] for row in (run_dir / "progress.csv").read_text().splitlines()]


def test_owed_updates_match_the_serial_schedule():
    config = DDPGConfig(train_every=16, updates_per_step=0.5, learning_starts=100)
    serial = sum(_owed_updates(config, s, s + 1) for s in range(1000))
    assert serial == (1000 // 16 - 100 // 16) * 8  # a round of 8 at 112, 128, ..., 992
    assert sum(_owed_updates(config, s, s + 32) for s in range(0, 992, 32)) + _owed_updates(config, 992, 1000) \
        == serial


def test_one_collector_learns(tmp_path):
    # The learning test of test_agents.py, with the environment stepped and the actor learnt in a collector.
    config = DDPGConfig(learning_starts=200, epsilon_decay=400, updates_per_step=0.5, seed=3)
    result = train(functools.partial(make_env, dim=1), "her-ddpg", config, total_steps=1500,
                   run_dir=tmp_path / "run", progress=False, tensorboard=False, collectors=1)
    serial_updates = sum(_owed_updates(config, s, s + 1) for s in range(1500))
    assert result.env_steps == 1500 and result.gradient_steps == serial_updates
    success, _ = evaluate(Policy.load(result.checkpoint), 50, dim=1)
    assert success >= 0.9, success


def test_two_collectors_are_deterministic_store_whole_episodes_and_resume(tmp_path):
    kwargs = dict(progress=False, tensorboard=False, collectors=2)
    runs = [train(make_env, "her-ddpg", FAST, total_steps=150, run_dir=tmp_path / name, **kwargs)
            for name in ("a", "b")]
    assert _log(runs[0].run_dir) == _log(runs[1].run_dir)
    for a, b in zip(Policy.load(runs[0].checkpoint).actor.parameters(),
                    Policy.load(runs[1].checkpoint).actor.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    result = train(make_env, "her-ddpg", None, total_steps=300, resume=True, run_dir=tmp_path / "a",
                   **{**kwargs, "collectors": 1})  # a run may resume with another count
    assert (runs[0].env_steps, result.env_steps) == (150, 300)
    assert result.gradient_steps > runs[0].gradient_steps > 0
    meta = read_checkpoint(result.checkpoint)[1]
    replay = read_replay(result.run_dir / meta["replay_file"])
    valid = replay["valid"].astype(bool)
    starts, lengths = replay["ep_start"][valid], replay["ep_length"][valid]
    assert valid.sum() == len(valid) == 300  # every step stored, the cut last episodes too
    for start, length in set(zip(starts.tolist(), lengths.tolist(), strict=True)):
        goals = replay["desired_goal"][start:start + length]
        assert np.all(goals == goals[0])  # one episode, one goal: no step of the other collector inside
        assert not replay["terminated"][start:start + length - 1].any()  # it ends only at its last step
    assert sum(1 for _ in open(result.run_dir / "progress.csv")) - 1 == result.episodes


def test_a_failing_collector_is_reported():
    env = make_env()
    broken = functools.partial(int, "no such ocean")  # raises in the collector process, importing nothing
    with pytest.raises(RuntimeError, match="collector process 0 failed: ValueError.*no such ocean"):
        with Collectors(broken, env_spec(env), DDPG(4, 2, FAST), 1) as pool:
            pool.start_round(16, 0, 0)
            pool.finish_round()
    with pytest.raises(ValueError, match="collectors must be >= 0"):
        train(make_env, "her-ddpg", FAST, total_steps=10, collectors=-1)
