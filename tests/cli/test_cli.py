"""The app's shared contract: every refusal is a usage error before any work, outputs are strict and
complete, and a tunnel a user authors goes through build, check, eval, render and plot by the CLI alone."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from cli_runner import refused as _refused
from cli_runner import run as _run

from auv_mj.benchmark import runner


@pytest.mark.parametrize(("args", "words"), [
    (["train", "her-ddpg", "--task", "goal", "--steps", "0"], ["--steps", "must be >= 1, got 0"]),
    (["train", "her-ddpg", "--task", "goal", "--episodes", "-5"], ["--episodes", "must be >= 1, got -5"]),
    (["eval", "--policy", "splane", "--task", "goal", "--episodes", "0"], ["--episodes", "must be >= 1"]),
    (["eval", "--policy", "splane", "--task", "goal", "--max-steps", "-1"], ["--max-steps", "must be >= 1"]),
    (["render", "--task", "goal", "--max-steps", "0", "-o", "x.mp4"], ["--max-steps", "must be >= 1"]),
    (["eval", "--policy", "splane", "--task", "goal", "--task-kwargs", "[" * 40 + "]" * 40],
     ["--task-kwargs", "nested deeper"]),
])
def test_bad_counts_are_usage_errors(args, words, tmp_path):
    _refused(_run(*args, cwd=tmp_path), *words)


def test_unwritable_outputs_are_refused_before_the_first_episode(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    target = blocker / "out.json"
    # A long evaluation: refused at once, so nothing is measured and then lost.
    done = _run("eval", "--policy", "splane", "--task", "goal", "--episodes", "1000", "--json", target,
                timeout=60)
    _refused(done, "--json", "is not a folder")
    assert "eval goal" not in done.stderr  # no progress bar: no episode ran
    _refused(_run("eval", "--policy", "splane", "--task", "goal", "--csv", tmp_path, timeout=60),
             "--csv", "is a folder")
    _refused(_run("render", "--task", "goal", "-o", blocker / "v.mp4", timeout=60), "-o ")
    _refused(_run("plot", "trajectory", "--task", "goal", "-o", blocker / "p.png", timeout=60), "-o ")
    _refused(_run("demo", "--out", blocker, "--no-video", timeout=60), "--out")
    _refused(_run("reproduce", "--out", blocker / "r.md", timeout=60), "--out")



def test_an_output_no_one_can_create_is_refused_before_the_first_episode():
    """Root may write anywhere by its permissions, yet /proc holds no new folders: the check tries."""
    done = _run("eval", "--policy", "splane", "--task", "goal", "--episodes", "1000", "--json", "/proc/nope/x.json",
                timeout=60)
    _refused(done, "--json /proc/nope/x.json cannot be written")
    assert len(done.stderr.strip().splitlines()) == 1 and "eval goal" not in done.stderr


def test_checking_an_output_leaves_nothing_behind(tmp_path):
    from auv_mj.cli.options import check_output, check_output_folder

    existing = tmp_path / "kept.json"
    existing.write_text("old")
    assert check_output("auv-mj test", existing, "--json") == existing
    assert existing.read_text() == "old"  # opened for appending, not truncated
    assert check_output("auv-mj test", tmp_path / "a" / "b" / "c.json", "--json") is not None
    assert check_output_folder("auv-mj test", tmp_path / "d" / "e", "--record-failures") is not None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.json"]
    with pytest.raises(SystemExit) as refused:
        check_output_folder("auv-mj test", existing, "--record-failures")
    assert refused.value.code == 2


def test_an_infeasible_arena_spec_is_a_usage_error_before_any_episode():
    done = _run("eval", "--policy", "splane", "--task", "tunnel", "--arena", "random", "--episodes", "5",
                "--task-kwargs", '{"arena_spec": {"length": 200, "obstacles": 5, "tries": 5}}', timeout=120)
    _refused(done, "arena_spec: length=[200, 200], obstacles=[5, 5]", "conflict")
    assert len(done.stderr.strip().splitlines()) == 1 and "None" not in done.stderr
    assert "eval tunnel" not in done.stderr  # no progress bar: no episode ran

def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def test_eval_json_is_strict_and_outcomes_sum_to_the_episodes(tmp_path):
    out = tmp_path / "out.json"
    done = _run("eval", "--policy", "splane", "--task", "speed_heading", "--episodes", "2", "--max-steps", "20",
                "--task-kwargs", '{"command": "random"}',  # two episodes that differ (a fixed command is one)
                "--json", out, "--csv", tmp_path / "out.csv", "--no-progress")
    assert done.returncode == 0, done.stderr
    results = _strict(out.read_text())
    summary = results["tasks"]["speed_heading"]
    assert summary["outcomes"] == {"goal": 0, "collision": 0, "left_map": 0, "timeout": 2}
    assert summary["min_clearance"] is None  # no obstacles to measure: undefined, not NaN
    assert "cut 2" in done.stdout  # stopped by --max-steps: recorded as timeouts, shown as cut
    done = _run("eval", "--policy", "splane", "--task", "goal", "--episodes", "1", "--max-steps", "3",
                "--json", out, "--no-progress")
    summary = _strict(out.read_text())["tasks"]["goal"]
    assert summary["time_to_goal"] is None and summary["success_rate"] == 0.0  # no success: no time
    header = (tmp_path / "out.csv").read_text().splitlines()[0].split(",")
    assert "outcome_timeout" in header


def test_every_episode_ends_in_one_named_outcome():

    results = runner.evaluate("splane", ["obstacles", "goal"], 3, seed=0, max_steps=60, progress=False)
    for summary in results["tasks"].values():
        assert sum(summary["outcomes"].values()) == summary["episodes"] == 3
        assert set(summary["outcomes"]) == {"goal", "collision", "left_map", "timeout"}
    # line of sight through Table 7 b's obstacles collides: a named outcome, not an empty event
    summary = runner.evaluate("splane", ["obstacles"], 1, task_kwargs={"scenario": "b"}, progress=False)
    assert summary["tasks"]["obstacles"]["outcomes"]["collision"] == 1


def test_an_authored_tunnel_through_the_cli_alone(tmp_path):
    (tmp_path / "line.csv").write_text("x,y\n0,0\n80,0\n140,40\n200,40\n")
    arena = tmp_path / "my_tunnel.xml"
    built = _run("tunnel", tmp_path / "line.csv", "--width", "30", "--smooth", "-o", arena)
    assert built.returncode == 0, built.stderr
    checked = _run("check-arena", arena, "--no-png")
    assert checked.returncode == 0, checked.stdout
    out = tmp_path / "eval.json"
    done = _run("eval", "--policy", "los-avoid", "--task", "tunnel", "--arena", arena, "--episodes", "1",
                "--json", out, "--no-progress")
    assert done.returncode == 0, done.stderr
    summary = _strict(out.read_text())["tasks"]["tunnel"]
    assert summary["outcomes"]["goal"] == 1 and summary["min_clearance"] > 5.0
    assert 200 < summary["path_length"] < 300 and math.isfinite(summary["time_to_goal"])
    video = tmp_path / "t.gif"
    rendered = _run("render", "--task", "tunnel", "--arena", arena, "--policy", "los-avoid", "--max-steps", "10",
                    "--width", "160", "--height", "96", "--fps", "5", "--gif", "-o", video, "--no-progress")
    assert rendered.returncode == 0, rendered.stderr
    assert video.stat().st_size > 1000 and "outcome cut (--max-steps 10)" in rendered.stdout
    figure = tmp_path / "t.png"
    plotted = _run("plot", "trajectory", "--task", "tunnel", "--arena", arena, "--policy", "los-avoid",
                   "--max-steps", "40", "-o", figure)
    assert plotted.returncode == 0, plotted.stderr
    assert figure.stat().st_size > 5000
    # the arena given twice, differently, is refused
    _refused(_run("eval", "--policy", "splane", "--task", "tunnel", "--arena", arena,
                  "--task-kwargs", json.dumps({"arena": "other.xml"})), "--arena")


def _help(capsys, *args) -> str:
    from auv_mj.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main([*args, "--help"])
    assert exit_info.value.code == 0
    return capsys.readouterr().out


def test_commands_that_run_episodes_take_the_same_options(capsys):
    for command in ("eval", "render", "demo", "train"):
        text = _help(capsys, command)
        for option in ("--task", "--task-kwargs", "--arena", "--seed"):
            assert option in text, (command, option)
    for kind in ("trajectory", "tracking"):
        text = _help(capsys, "plot", kind)
        for option in ("--task", "--task-kwargs", "--arena", "--seed", "--policy"):
            assert option in text, (kind, option)


def test_python_m_runs_the_app():
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "--help"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0 and "check-arena" in done.stdout
    assert Path(__file__).exists()


def test_a_candidate_planner_checkpoint_runs_under_the_shipped_names(tmp_path):
    """`two-layer=PATH` runs the checkpoint PATH as the planner of the two-layer system."""
    from auv_mj.zoo import registry as policies

    path = policies.shipped_checkpoint("planner")
    ours = runner.evaluate(f"two-layer={path}", ["goal"], 1, max_steps=5, progress=False)
    shipped = runner.evaluate("two-layer", ["goal"], 1, max_steps=5, progress=False)
    assert ours["tasks"] == shipped["tasks"]
    with pytest.raises(FileNotFoundError, match="no checkpoint"):
        policies.split_name(f"planner={tmp_path / 'missing.pt'}")
