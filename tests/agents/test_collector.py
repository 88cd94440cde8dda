"""Training with collector processes (auv_mj.agents.offpolicy.collector): it learns, it is deterministic given the seed
and the number of collectors, it keeps the update-to-data ratio, and HER stores each collector's episodes whole."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import torch
from test_agents import FAST, evaluate, make_env

from auv_mj.agents.checkpoint import read_checkpoint, read_replay
from auv_mj.agents.offpolicy import Policy
from auv_mj.agents.offpolicy.collector import LEARNER_SHARE, Collectors, episode_seed
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.train import _owed_updates, env_spec, train


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


def test_steps_owed_before_anything_can_be_sampled_are_taken_later(tmp_path):
    # HER samples whole episodes: with learning_starts below the first episode's end, both loops owe steps at
    # first and take them later, so both take exactly the serial schedule's gradient steps.
    config = DDPGConfig(hidden_sizes=(32, 32), learning_starts=8, train_every=4, buffer_size=2000, seed=5)
    schedule = sum(_owed_updates(config, s, s + 1) for s in range(400))
    runs = {count: train(make_env, "her-ddpg", config, total_steps=400, run_dir=tmp_path / f"c{count}",
                         progress=False, tensorboard=False, collectors=count) for count in (0, 1)}
    first_end = int((runs[0].run_dir / "progress.csv").read_text().splitlines()[1].split(",")[1])
    assert first_end > config.learning_starts  # the serial loop owed steps before its first episode ended
    for result in runs.values():
        assert result.gradient_steps == schedule, (result.gradient_steps, schedule)


def test_the_learner_steps_its_share_of_a_round_as_a_stream_of_its_own():
    env = make_env()
    spec = env_spec(env)
    agent = DDPG(spec["obs_dim"], spec["act_dim"], FAST)
    with Collectors(make_env, spec, agent, 1, local_env=make_env()) as pool:
        assert pool.streams == 2
        pool.start_round(16, 0, 0)
        rounds, actor_loss = pool.finish_round()
    local = round(16 * LEARNER_SHARE[1])
    assert [len(r) for r in rounds] == [16 - local, local] and actor_loss is None
    # The learner's stream is stream 1 of 2: it resets episode 1 first (collector 0 resets episode 0).
    first_obs = rounds[1][0][0]
    expected, _ = make_env().reset(seed=episode_seed(FAST.seed, 1))
    np.testing.assert_array_equal(first_obs["desired_goal"], expected["desired_goal"])
    with Collectors(make_env, spec, agent, 2, local_env=make_env()) as pool:
        assert pool.streams == 2  # with more collectors than spare cores the learner steps none


def test_a_run_by_episodes_stops_at_its_episode_count(tmp_path):
    result = train(make_env, "her-ddpg", FAST, episodes=12, run_dir=tmp_path / "run", progress=False,
                   tensorboard=False, collectors=1)
    assert result.episodes == 12
    rows = (result.run_dir / "progress.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in rows] == list(range(1, 13))
    assert result.gradient_steps > 0
