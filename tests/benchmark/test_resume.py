"""An interrupted `eval` or `benchmark` loses no finished episode: each is kept in a journal as it ends, and the same
run made again resumes from it and gives the uninterrupted run's results, serially and over workers; Ctrl-C ends in
one line; a journal of another run is refused by name unless --force."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from auv_mj.benchmark import runner
from auv_mj.benchmark.journal import JOURNAL, Interrupted, Journal, JournalMismatch
from auv_mj.benchmark.suite import SUITE_V1
from auv_mj.cli import main

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
TASKS, POLICY, EPISODES, SEED, MAX_STEPS = ["goal", "obstacles"], "random", 4, 5, 12
"""Small episodes for `evaluate`: the point is the bookkeeping, not the driving."""
BENCHMARK = ["benchmark", "--policy", "los-fast", "--tier", "hard", "--water", "ideal", "--episodes", "2",
             "--max-steps", "300", "--no-progress"]
"""Six episodes of a few seconds each: long enough to be interrupted midway."""


def _dump(results: dict) -> str:
    return json.dumps(results, indent=2, allow_nan=False)


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def test_a_journal_keeps_whole_lines_and_drops_one_cut_by_a_kill(tmp_path):
    path = tmp_path / "j.jsonl"
    with Journal(path, {"policy": "p", "episodes": 3}) as journal:
        journal.add(("goal", 0), {"return": 0.1, "outcome": "goal"})
        journal.add(("goal", 1), {"return": 1 / 3, "outcome": "timeout"})
    with open(path, "ab") as f:
        f.write(b'{"key": ["goal", 2], "metrics": {"ret')  # a kill in the middle of a write
    with Journal(path, {"episodes": 3, "policy": "p"}) as journal:  # the same run, its keys in another order
        assert journal.episodes == {("goal", 0): {"return": 0.1, "outcome": "goal"},
                                    ("goal", 1): {"return": 1 / 3, "outcome": "timeout"}}
        journal.add(("goal", 2), {"return": 2.0, "outcome": "collision"})
    assert [json.loads(line) for line in _lines(path)][1:] == [
        {"key": ["goal", 0], "metrics": {"return": 0.1, "outcome": "goal"}},
        {"key": ["goal", 1], "metrics": {"return": 1 / 3, "outcome": "timeout"}},
        {"key": ["goal", 2], "metrics": {"return": 2.0, "outcome": "collision"}}]


def test_a_journal_counts_what_its_file_holds_for_the_interrupted_message(tmp_path):
    """Ctrl-C can fall between an episode's line reaching the file and the run taking it: the count the message gives
    (`kept`) is the file's, the episodes a resumed run will find, and includes those of an earlier run."""
    path = tmp_path / "j.jsonl"
    with Journal(path, {"policy": "p"}) as journal:
        assert journal.kept() == 0
        journal.add(("goal", 0), {"return": 0.1})
        journal._append({"key": ["goal", 1], "metrics": {"return": 0.2}})  # on disk, not yet in `episodes`
        assert (journal.kept(), len(journal.episodes)) == (2, 1)
    with Journal(path, {"policy": "p"}) as journal:
        journal.add(("goal", 2), {"return": 0.3})
        assert journal.kept() == len(journal.episodes) == 3


def test_another_runs_journal_is_refused_by_name_unless_forced(tmp_path):
    path = tmp_path / "j.jsonl"
    with Journal(path, {"policy": "p", "max_steps": 10}) as journal:
        journal.add(("goal", 0), {"outcome": "goal"})
        with pytest.raises(JournalMismatch, match="in use by another run"):
            Journal(path, {"policy": "p", "max_steps": 10})
    with pytest.raises(JournalMismatch) as refused:
        Journal(path, {"policy": "p", "max_steps": 20})
    assert str(path) in str(refused.value) and "max_steps: 10 there, 20 here" in str(refused.value)
    assert "force" in str(refused.value) and len(_lines(path)) == 2  # refused: left as it was
    with Journal(path, {"policy": "p", "max_steps": 20}, force=True) as journal:
        assert journal.episodes == {}
    assert json.loads(_lines(path)[0]) == {"journal": 1, "run": {"policy": "p", "max_steps": 20}}
    other = tmp_path / "notes.jsonl"
    other.write_text('{"mine": 1}\n')
    with pytest.raises(JournalMismatch, match="is no episode journal"):
        Journal(other, {"policy": "p"})
    assert other.read_text() == '{"mine": 1}\n'


class _StopAfter:
    """An `on_episode` that presses Ctrl-C (raises KeyboardInterrupt in the main thread) at its `n`-th call."""

    def __init__(self, n: int):
        self.n, self.calls = n, 0

    def __call__(self, task: str, seed: int, metrics: dict) -> None:
        self.calls += 1
        if self.calls == self.n:
            raise KeyboardInterrupt


@pytest.mark.parametrize("workers", [1, 2])
def test_evaluate_interrupted_resumes_to_the_uninterrupted_result(tmp_path, workers):
    whole = runner.evaluate(POLICY, TASKS, EPISODES, SEED, MAX_STEPS, progress=False)
    path = tmp_path / "eval.jsonl"
    with pytest.raises(Interrupted) as stopped:
        runner.evaluate(POLICY, TASKS, EPISODES, SEED, MAX_STEPS, progress=False, workers=workers, journal=path,
                        on_episode=_StopAfter(6))
    kept = len(_lines(path)) - 1
    assert stopped.value.journal == path and stopped.value.kept == kept and 6 <= kept < 8
    assert stopped.value.total == 8 and isinstance(stopped.value, KeyboardInterrupt)
    seen: list[tuple[str, int]] = []
    resumed = runner.evaluate(POLICY, TASKS, EPISODES, SEED, MAX_STEPS, progress=False, workers=3 - workers,
                              journal=path, on_episode=lambda task, seed, metrics: seen.append((task, seed)))
    assert _dump(resumed) == _dump(whole)
    assert sorted(seen) == [(task, SEED + i) for task in TASKS for i in range(EPISODES)]  # the kept ones too
    assert len(_lines(path)) == 1 + 8


@pytest.mark.parametrize("workers", [1, 2])
def test_a_benchmark_killed_midway_resumes_to_the_uninterrupted_result(tmp_path, workers):
    cells = [SUITE_V1[2]]  # obstacles, hard, ideal
    whole = runner.run_suite("los-fast", cells, 3, max_steps=20, progress=False)
    path = tmp_path / JOURNAL
    runner.run_suite("los-fast", cells, 3, max_steps=20, progress=False, journal=path, workers=workers)
    lines = _lines(path)
    path.write_text("\n".join(lines[:2]) + "\n" + lines[2][:25])  # one episode kept, the next cut by a kill
    resumed = runner.run_suite("los-fast", cells, 3, max_steps=20, progress=False, journal=path, workers=workers)
    assert _dump(resumed) == _dump(whole)
    with pytest.raises(JournalMismatch, match="episodes: 3 there, 2 here"):
        runner.run_suite("los-fast", cells, 2, max_steps=20, progress=False, journal=path)


def _terminal_interrupt() -> None:
    """In the command's process before it starts: Ctrl-C's default action, as in a terminal. A process started by
    one that ignores SIGINT (a background job of a non-interactive shell, say) inherits the ignoring, and Python
    then never raises KeyboardInterrupt: the command would run to its end whatever the test sends."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt(args: list[str], journal: Path, episodes: int, sig: int) -> subprocess.CompletedProcess:
    """Runs `auv-mj ARGS` in its own process group and sends `sig` to the whole group (as Ctrl-C in a terminal
    does to the command and its workers) once `journal` holds `episodes` episodes."""
    process = subprocess.Popen([*AUV_MJ, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env=ENV, start_new_session=True, preexec_fn=_terminal_interrupt)
    deadline = time.monotonic() + 300
    while not (journal.exists() and len(_lines(journal)) > episodes) and time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)
    os.killpg(process.pid, sig)
    out, err = process.communicate(timeout=120)
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


def test_benchmark_ctrl_c_with_workers_ends_in_one_line_and_the_same_command_resumes(tmp_path):
    reference = subprocess.run([*AUV_MJ, *BENCHMARK, "--out", tmp_path / "whole"], capture_output=True, text=True,
                               env=ENV, timeout=600)
    assert reference.returncode == 0, reference.stderr
    assert not (tmp_path / "whole" / JOURNAL).exists()  # results.json holds every episode: no journal left
    out = tmp_path / "out"
    stopped = _interrupt([*BENCHMARK, "--workers", "2", "--out", str(out)], out / JOURNAL, 2, signal.SIGINT)
    assert stopped.returncode == 130, (stopped.returncode, stopped.stderr[-2000:])
    kept = len(_lines(out / JOURNAL)) - 1
    assert stopped.stderr.splitlines() == [f"auv-mj benchmark: interrupted: {kept} of 6 episodes kept in "
                                           f"{out / JOURNAL}; run the same command again to resume"]
    assert 2 <= kept < 6 and not (out / "results.json").exists()
    resumed = subprocess.run([*AUV_MJ, *BENCHMARK, "--out", out], capture_output=True, text=True, env=ENV,
                             timeout=600)  # serially this time
    assert resumed.returncode == 0, resumed.stderr
    assert (out / "results.json").read_text() == (tmp_path / "whole" / "results.json").read_text()
    assert not (out / JOURNAL).exists()

    killed = tmp_path / "killed"
    _interrupt([*BENCHMARK, "--out", str(killed)], killed / JOURNAL, 1, signal.SIGKILL)
    assert not (killed / "results.json").exists() and len(_lines(killed / JOURNAL)) >= 2
    resumed = subprocess.run([*AUV_MJ, *BENCHMARK, "--workers", "2", "--out", killed], capture_output=True,
                             text=True, env=ENV, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert (killed / "results.json").read_text() == (tmp_path / "whole" / "results.json").read_text()


def test_benchmark_refuses_another_runs_journal_before_any_episode_unless_forced(tmp_path):
    with Journal(tmp_path / JOURNAL, {"command": "benchmark", "policy": "map-replan"}) as journal:
        journal.add(("tunnel/hard/ideal", 12000), {"outcome": "goal"})
    args = [*AUV_MJ, "benchmark", "--policy", "los-fast", "--tier", "hard", "--water", "ideal", "--episodes", "1",
            "--max-steps", "5", "--out", tmp_path]
    refused = subprocess.run(args, capture_output=True, text=True, env=ENV, timeout=300)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert f"{tmp_path / JOURNAL} holds the episodes of another run" in refused.stderr
    assert '"map-replan" there, "los-fast" here' in refused.stderr and "--force" in refused.stderr
    forced = subprocess.run([*args, "--force"], capture_output=True, text=True, env=ENV, timeout=300)
    assert forced.returncode == 0, forced.stderr
    assert json.loads((tmp_path / "results.json").read_text())["policy"] == "los-fast"


def test_eval_ctrl_c_keeps_the_episodes_beside_its_json_and_says_so_in_one_line(tmp_path, monkeypatch, capsys):
    episode = runner.run_episode

    def pressed_on_third(policy_name, task_name, seed, task_kwargs, max_steps):
        if (task_name, seed) == ("goal", SEED + 2):
            raise KeyboardInterrupt
        return episode(policy_name, task_name, seed, task_kwargs, max_steps)

    out = tmp_path / "run.json"
    args = ["eval", "--policy", POLICY, "--task", "goal", "--episodes", str(EPISODES), "--seed", str(SEED),
            "--max-steps", str(MAX_STEPS), "--no-progress", "--json", str(out)]
    monkeypatch.setattr(runner, "run_episode", pressed_on_third)
    assert main(args) == 130
    journal = tmp_path / "run_journal.jsonl"
    assert capsys.readouterr().err.splitlines() == [
        f"auv-mj eval: interrupted: 2 of {EPISODES} episodes kept in {journal}; run the same command again to "
        "resume"]
    assert not out.exists() and len(_lines(journal)) == 3
    monkeypatch.setattr(runner, "run_episode", episode)
    assert main(args) == 0
    assert out.read_text() == _dump(runner.evaluate(POLICY, ["goal"], EPISODES, SEED, MAX_STEPS, progress=False))
    assert not journal.exists()
