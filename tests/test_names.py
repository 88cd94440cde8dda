"""What a newcomer meets (issue 53, items 1, 7, 8, 9, 12): nothing written is overwritten without --force, a
refused name suggests the nearest valid one and lists the valid set, a tube CSV reads as a planar one does, the help
says what the commands do under one name per concept, and `auv-mj ... | head` ends quietly."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),  # this checkout's auv_mj, from any folder
       "PYTHONPATH": os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}


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


# --- item 1: nothing written is overwritten without --force -------------------------------------------------------

SBEND = "x,y,width\n0,0,30\n100,0,30\n200,60,30\n300,60,30\n"


def test_a_hand_made_tunnel_is_not_overwritten_without_force(tmp_path):
    (tmp_path / "sbend.csv").write_text(SBEND)
    mine = tmp_path / "sbend.xml"
    mine.write_text("<mujoco><!-- smoothed by hand, a rock and a mover --></mujoco>")
    _refused(_run("tunnel", "sbend.csv", cwd=tmp_path), "sbend.xml exists", "--force")
    assert "by hand" in mine.read_text()
    _refused(_run("tunnel", "sbend.csv", "-o", "sbend.xml", cwd=tmp_path), "-o sbend.xml exists", "--force")
    assert "by hand" in mine.read_text()
    done = _run("tunnel", "sbend.csv", "--force", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "path_0" in mine.read_text()


def test_every_command_refuses_an_existing_output_before_any_work(tmp_path):
    (tmp_path / "sbend.csv").write_text(SBEND)
    (tmp_path / "shapes.json").write_text('{"start": [0, 0], "goal": [100, 0]}')
    for name in ("taken.xml", "taken.png", "taken.mp4", "taken.npz", "out/tunnel.mp4", "out/tunnel_episode.npz"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text("mine")
    cases = [
        (["tunnel", "--random", "3", "-o", "taken.xml"], "-o taken.xml exists"),
        (["tunnel", "--tube", "sbend.csv", "-o", "taken.xml"], "-o taken.xml exists"),
        (["arena", "shapes.json", "-o", "taken.xml"], "-o taken.xml exists"),
        (["arena", "shapes.json", "-o", "new.xml", "--preview", "taken.png"], "--preview taken.png exists"),
        (["render", "--task", "goal", "-o", "taken.mp4"], "-o taken.mp4 exists"),
        (["render", "--task", "goal", "-o", "new.mp4", "--save-episode", "taken.npz"], "--save-episode taken.npz"),
        (["plot", "trajectory", "--task", "goal", "-o", "taken.png"], "-o taken.png exists"),
        (["demo", "-o", "out", "--no-video"], "out/tunnel.mp4 exists"),
    ]
    for args, words in cases:
        done = _run(*args, cwd=tmp_path, timeout=120)
        _refused(done, words, "--force")
        assert "wrote" not in done.stdout
    assert all((tmp_path / name).read_text() == "mine" for name in ("taken.xml", "taken.png", "taken.mp4"))
    assert not (tmp_path / "new.xml").exists()


def test_check_arena_replaces_its_own_preview_but_not_a_users_image(tmp_path):
    from auv_mj.arenas.arena_check import is_preview

    (tmp_path / "sbend.csv").write_text(SBEND)
    assert _run("tunnel", "sbend.csv", cwd=tmp_path).returncode == 0
    for _ in range(2):  # the preview it drew is its own: checked again after an edit, it is drawn again
        done = _run("check-arena", "sbend.xml", "--no-progress", cwd=tmp_path)
        assert done.returncode == 0 and "wrote preview" in done.stdout, done.stderr
    assert is_preview(tmp_path / "sbend.png")
    photo = tmp_path / "photo.png"
    photo.write_bytes((tmp_path / "sbend.png").read_bytes().replace(b"auv-mj arena preview", b"my own image, kept"))
    assert not is_preview(photo)
    _refused(_run("check-arena", "sbend.xml", "--no-progress", "--preview", "photo.png", cwd=tmp_path),
             "--preview photo.png exists", "--force")
    assert b"my own image" in photo.read_bytes()
    done = _run("check-arena", "sbend.xml", "--no-progress", "--png", "photo.png", "--force", cwd=tmp_path)
    assert done.returncode == 0 and is_preview(photo), done.stderr


# --- item 9: one name per concept ---------------------------------------------------------------------------------


@pytest.mark.parametrize(("command", "old"), [(["tunnel"], "--output"), (["render"], "--output"),
                                              (["plot", "trajectory"], "--output"), (["check-arena"], "--png"),
                                              (["check-arena"], "--no-png")])
def test_old_option_names_are_said_in_the_help(command, old):
    text = " ".join(_run(*command, "--help").stdout.split())
    assert f"({old}: its old name, accepted until 0.3)" in text


@pytest.mark.parametrize("command", [["tunnel"], ["arena"], ["render"], ["plot", "trajectory"], ["demo"],
                                     ["benchmark"], ["sweep"], ["reproduce"]])
def test_every_output_is_named_o_out(command):
    text = _run(*command, "--help").stdout
    assert "-o FILE, --out FILE" in text or "-o DIR, --out DIR" in text, text


@pytest.mark.parametrize("command", [["arena"], ["check-arena"]])
def test_the_preview_is_named_preview(command):
    text = _run(*command, "--help").stdout
    assert "--preview PNG" in text and "--no-preview" in text, text
