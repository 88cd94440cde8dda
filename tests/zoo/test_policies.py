"""The policy registry (`auv_mj.zoo.registry.POLICIES`): every name is listed, runs, and behaves as before."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from auv_mj.benchmark import runner
from auv_mj.zoo import registry as policies

ROOT = Path(__file__).resolve().parents[2]
AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
RECORDED = json.loads((ROOT / "tests" / "data" / "policy_outcomes_d7f506e_float64.json").read_text())
"""Outcome and path length of 60-step episodes of each name that existed before the registry, recorded at
d7f506e (the parallel tables of names) with `runner.run_episode(name, task, seed, {}, 60)`, its `Policy` run in
float64 as `auv_mj.agents.offpolicy.Policy` is now (the float32 record, `policy_outcomes_d7f506e.json`, holds only on
the kind of CPU it was made on)."""
RENAMED = {"planner-general": "planner-route", "two-layer-general": "two-layer-route"}
"""Names whose policy moved to another name since (issue 30 shipped a new general planner; the old one, on the
same checkpoint file, is `planner-route`)."""


@pytest.mark.parametrize("command", ["eval", "render", "plot trajectory", "plot tracking", "demo"])
def test_every_registered_policy_is_listed_by_help(command):
    done = subprocess.run([*AUV_MJ, *command.split(), "--help"], capture_output=True, text=True, timeout=120,
                          env={"COLUMNS": "10000", "PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr
    text = " ".join(done.stdout.split())
    missing = [name for name in policies.POLICIES if name not in text]
    assert not missing, f"auv-mj {command} --help does not list {missing}"


@pytest.mark.parametrize("name", list(policies.POLICIES))
def test_every_registered_policy_runs_a_short_episode(name):
    task = policies.resolve_tasks("all", name)[0]
    metrics = runner.run_episode(name, task, 20_000, {}, 5)
    assert metrics["steps"] == 5 and metrics["outcome"] == "timeout"


def test_names_behave_as_before_the_registry():
    """The shipped names give the outcomes and path lengths recorded before the registry (one seed each)."""
    for key, recorded in RECORDED.items():
        name, task, seed = key.split("|")
        name = RENAMED.get(name, name)
        if seed != "10000":
            continue
        metrics = runner.run_episode(name, task, int(seed), {}, 60)
        assert metrics["outcome"] == recorded["outcome"], key
        assert metrics["path_length"] == pytest.approx(recorded["path_length"], rel=1e-9, abs=1e-9), key


def test_a_new_policy_is_one_entry():
    spec = policies.PolicySpec("a test planner: line of sight inside the speed-aware domain",
                               lambda d: policies.line_of_sight(d.env), tasks="planning", protection="speed-aware")
    policies.register("test-planner", spec)
    try:
        assert "test-planner" in policies.policy_help()
        assert "| `test-planner` |" in policies.markdown_table()
        assert policies.resolve_tasks("all", "test-planner") == policies.resolve_tasks("all", "bug")
        assert runner.run_episode("test-planner", "obstacles", 3, {}, 5)["steps"] == 5
        with pytest.raises(ValueError, match="registered twice"):
            policies.register("test-planner", spec)
    finally:
        del policies.POLICIES["test-planner"]


def test_tasks_follow_the_spec():
    assert "speed_heading" not in policies.resolve_tasks("all", "planner-general")
    assert policies.resolve_tasks("all", "ocean-executor") == ["speed_heading"]
    assert "speed_heading" in policies.resolve_tasks("all", "splane")
    with pytest.raises(ValueError, match="tasks"):
        policies.PolicySpec("bad", lambda d: None, tasks="nowhere")
    with pytest.raises(ValueError, match="unknown policy 'nope'"):
        policies.resolve("nope")


def test_an_executor_of_its_own_refuses_another():
    with pytest.raises(ValueError, match="runs the learned executor 'ocean-executor'"):
        policies.env_and_policy("two-layer-general", "goal", 0, {"executor": "splane"})
