"""What a newcomer meets (issue 53, items 1, 7, 8, 9, 12): nothing written is overwritten without --force, a
refused name suggests the nearest valid one and lists the valid set, a tube CSV reads as a planar one does, the help
says what the commands do under one name per concept, and `auv-mj ... | head` ends quietly."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
ROOT = Path(__file__).resolve().parents[1]


def _run(*args, timeout=300, cwd=None):
    return subprocess.run([*AUV_MJ, *map(str, args)], capture_output=True, text=True, timeout=timeout, env=ENV,
                          cwd=cwd)


def _refused(done, *words):
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    for word in words:
        assert word in done.stderr, done.stderr


# --- item 12: a closed pipe ------------------------------------------------------------------------------------


def test_a_reader_that_goes_away_ends_the_command_quietly():
    """`auv-mj policies | head`: the reader is gone before the table is written; no traceback, SIGPIPE's status."""
    process = subprocess.Popen([*AUV_MJ, "policies"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=ENV)
    process.stdout.close()  # the reader has gone before the first line
    stderr = process.stderr.read().decode()
    assert process.wait(timeout=120) == 141, stderr
    assert "Traceback" not in stderr and "BrokenPipeError" not in stderr, stderr


def test_a_broken_pipe_that_is_not_stdout_is_still_an_error(monkeypatch):
    """Only stdout's reader going away is quiet: a worker's broken pipe stays an error."""
    from auv_mj import cli

    def broken(argv):
        raise BrokenPipeError("a worker's pipe")

    monkeypatch.setattr(cli, "_main", broken)
    with pytest.raises(BrokenPipeError):
        cli.main(["policies"])


# --- item 9: help -----------------------------------------------------------------------------------------------


def test_version():
    from auv_mj import __version__

    done = _run("--version")
    assert done.returncode == 0 and done.stdout.startswith(f"auv-mj {__version__} ("), done


def test_the_top_level_help_names_both_vehicles_and_every_agent():
    from auv_mj.agents.train import AGENTS
    from auv_mj.cli import TRAIN_AGENTS

    assert TRAIN_AGENTS == (*AGENTS, "ppo")
    text = " ".join(_run("--help").stdout.split())
    assert "planar" in text and "6-DOF" in text and "--version" in text
    assert f"train an agent ({', '.join(TRAIN_AGENTS)})" in text


def test_a_mistyped_choice_suggests_the_nearest():
    _refused(_run("polices"), "did you mean 'policies'?", "'check-arena'")
    _refused(_run("render", "--camera", "folow", "-o", "x.mp4"), "did you mean 'follow'?", "'overview'")
