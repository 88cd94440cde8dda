"""What a newcomer meets (issue 53, items 1, 7, 8, 9, 12): nothing written is overwritten without --force, a
refused name suggests the nearest valid one and lists the valid set, a tube CSV reads as a planar one does, the help
says what the commands do under one name per concept, and `auv-mj ... | head` ends quietly."""

import subprocess

import numpy as np
import pytest
from cli_runner import AUV_MJ, ENV
from cli_runner import refused as _refused
from cli_runner import run as _run

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
    from auv_mj.agents.offpolicy.learners import AGENTS
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
    from auv_mj.figures.arenas import is_preview

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
                                              (["check-arena"], "--no-png"), (["train"], "--run-dir")])
def test_old_option_names_are_said_in_the_help(command, old):
    text = " ".join(_run(*command, "--help").stdout.split())
    assert f"({old}: its old name, accepted until 0.3)" in text


@pytest.mark.parametrize("command", [["tunnel"], ["arena"], ["render"], ["plot", "trajectory"], ["demo"],
                                     ["benchmark"], ["sweep"], ["reproduce"], ["train"]])
def test_every_output_is_named_o_out(command):
    text = _run(*command, "--help").stdout
    assert "-o FILE, --out FILE" in text or "-o DIR, --out DIR" in text, text


@pytest.mark.parametrize("command", [["arena"], ["check-arena"]])
def test_the_preview_is_named_preview(command):
    text = _run(*command, "--help").stdout
    assert "--preview PNG" in text and "--no-preview" in text, text


# --- item 7: every refused name suggests the nearest and lists the valid set ------------------------------------


def test_a_mistyped_policy_task_or_domain_suggests_the_nearest_and_lists_them():
    from auv_mj.tasks import suite
    from auv_mj.zoo import registry

    with pytest.raises(ValueError, match=r"unknown policy 'map-replann' \(did you mean 'map-replan'\?\); valid "
                                         r"policies: planner, .*, random; or a checkpoint file"):
        registry.resolve("map-replann")
    with pytest.raises(ValueError, match=r"unknown task, tag or domain 'obstacle' \(did you mean 'obstacles'\?\); "
                                         r"tasks of domain auv \(the planar vehicle\): goal, .*of domain auv3d "
                                         r"\(the 6-DOF vehicle\): depth_heading"):
        registry.resolve_tasks("obstacle")
    with pytest.raises(ValueError, match=r"unknown domain 'auv3' \(did you mean 'auv3d'\?\); valid domains: auv, "
                                         r"auv3d"):
        suite.load("auv3", "goal3d")
    with pytest.raises(ValueError, match=r"task 'goal3d' is not in domain 'auv' but in domain 'auv3d'"):
        suite.load("auv", "goal3d")
    with pytest.raises(ValueError, match=r"unknown task 'tunel' \(did you mean 'tunnel'\?\); valid tasks: goal,"):
        suite.domain_of("tunel")
    with pytest.raises(ValueError, match=r"unknown tag 'plannig' \(did you mean 'planning'\?\)"):
        suite.tasks_by_tag("plannig")


@pytest.mark.parametrize(("task", "options"), [
    ("obstacles", ["arena", "conditions", "goal_radius", "reward", "scenario", "tier"]),
    ("tunnel", ["arena", "arena_spec", "conditions", "tier"]),
    ("goal3d", ["arena", "conditions", "tier"]),
])
def test_a_mistyped_task_option_suggests_the_nearest_and_lists_the_options(task, options):
    from auv_mj.tasks import suite

    with pytest.raises(ValueError) as error:
        suite.load(suite.domain_of(task), task, {"teir": "hard"})
    text = str(error.value)
    assert f"task {task!r} has no option 'teir' (did you mean 'tier'?); its options: " in text
    listed = text.split("its options: ")[1].split(", ")
    assert set(options) <= set(listed)
    assert "given twice" not in text


def test_a_mistyped_option_value_suggests_the_nearest():
    from auv_mj.tasks import suite

    with pytest.raises(ValueError, match=r"tier must be one of 'standard', 'hard', got 'hrad' \(did you mean "
                                         r"'hard'\?\)"):
        suite.load("auv", "obstacles", {"tier": "hrad"})


def test_the_cli_suggests_for_policies_tasks_and_agents(tmp_path):
    _refused(_run("eval", "--policy", "map-replann", "--task", "obstacles"), "did you mean 'map-replan'?",
             "valid policies:")
    _refused(_run("eval", "--policy", "splane", "--task", "obstacle"), "did you mean 'obstacles'?", "auv3d")
    _refused(_run("train", "td3", "--task", "obstacle", "--run-dir", tmp_path / "r"), "unknown task 'obstacle'",
             "did you mean 'obstacles'?", "valid tasks:")
    _refused(_run("train", "td4", "--task", "goal"), "did you mean 'td3'?")
    _refused(_run("benchmark", "--policy", "splane", "--tier", "hrad", "--out", tmp_path / "b"),
             "did you mean 'hard'?")


def test_train_refuses_an_option_its_agent_would_ignore_and_names_the_agents_that_read_it(tmp_path):
    """One parser serves every `auv-mj train` agent: an option of another agent is refused, not silently ignored, and
    nothing is written; the options an agent does read still pass this check."""
    from auv_mj.cli.train import option_readers

    out = tmp_path / "r"
    _refused(_run("train", "ddpg", "--task", "goal", "--steps", "10", "--ppo-learning-rate", "0.1", "-o", out),
             "train ddpg does not read --ppo-learning-rate", "`auv-mj train ppo | dagger`")
    _refused(_run("train", "ppo", "--task", "planning-mix", "--steps", "10", "--dagger-epochs", "3", "-o", out),
             "train ppo does not read --dagger-epochs", "`auv-mj train dagger`")
    _refused(_run("train", "dagger", "--task", "planning-mix", "--steps", "10", "--init", "planner-learned",
                  "--actor-lr", "0.1", "-o", out), "train dagger does not read --init", "--actor-lr")
    assert not out.exists()
    readers = option_readers()
    assert readers["ppo_privileged_critic"][1] == ("ppo", "dagger") and readers["cell_weights"][1] == ("ppo", "dagger")
    assert readers["validate_every"][1] == ("ppo",) and readers["dagger_rounds"][1] == ("dagger",)
    assert "dagger" not in readers["actor_lr"][1] and "td3" in readers["policy_delay"][1]


def test_a_tube_arena_given_to_a_planar_task_points_to_tunnel3d(tmp_path):
    from auv_mj.arenas import tubes
    from auv_mj.arenas.tunnels import save
    from auv_mj.tasks import suite

    line = np.array([[0.0, 0.0, -20.0], [60.0, 0.0, -22.0], [120.0, 10.0, -25.0]])
    path = tmp_path / "my_tube.xml"
    save(tubes.tube_arena(tubes.Tube(line, tubes.TUBE_RADIUS), "my_tube"), path)
    for task in ("tunnel", "obstacles"):
        with pytest.raises(ValueError, match=r"my_tube\.xml: a tube arena .* --task tunnel3d"):
            suite.load("auv", task, {"arena": str(path)})
    (tmp_path / "tube.csv").write_text("x,y,z\n0,0,-20\n60,0,-22\n")
    _refused(_run("tunnel", "tube.csv", cwd=tmp_path), "tube.csv: row 1", "auv-mj tunnel --tube")


def test_a_tube_above_the_surface_says_so():
    from auv_mj.arenas import tubes

    line = np.array([[0.0, 0.0, -1.0], [60.0, 0.0, -1.0], [120.0, 0.0, -1.0]])
    problems = " ".join(tubes.check_tube(tubes.Tube(line, tubes.TUBE_RADIUS)))
    assert "m above the surface" in problems and "-" not in problems.split("top reaches ")[1][:4], problems


# --- item 8: a tube CSV reads as a planar one does --------------------------------------------------------------


def test_a_tube_csv_takes_comments_and_keeps_the_users_text(tmp_path):
    from auv_mj.arenas import tubes

    path = tmp_path / "tube.csv"
    path.write_text("# my tube, dives and climbs\nx,y,z\n0,0,-20\n# the dive\n60,0,-30\n\n120,10,-25\n")
    assert tubes.read_centreline(path).tolist() == [[0, 0, -20], [60, 0, -30], [120, 10, -25]]
    path.write_text("# mine\nX,Y,Depth\n0,0,-20\n")
    with pytest.raises(ValueError, match=r"row 2: the header must start x,y,z, got 'X,Y,Depth'"):
        tubes.read_centreline(path)
    path.write_text("X,Y,Z\n0,0,-20\n# a comment\n10,0,Deep\n")
    with pytest.raises(ValueError, match=r"row 4: z = 'Deep' is not a coordinate"):
        tubes.read_centreline(path)


def test_benchmark_help_shows_its_defaults_as_typed_and_task_picks_cells(tmp_path):
    text = " ".join(_run("benchmark", "--help").stdout.split())
    assert "(default: standard,hard)" in text and "(default: ideal,ocean)" in text and "('standard'" not in text
    assert "--task TASKS" in text and "auv3d: goal3d,tunnel3d" in text
    _refused(_run("benchmark", "--policy", "splane", "--task", "goal3d", "-o", tmp_path / "b"),
             "--task goal3d has no cell in the auv suite", "is in --domain auv3d")
    _refused(_run("benchmark", "--policy", "splane", "--task", "tunel", "-o", tmp_path / "b"),
             "did you mean 'tunnel'?")


def test_benchmark_suite_version_picks_the_3d_suite_and_its_board(tmp_path):
    """--suite-version 1 runs suite 3d v1's cells and reads its board, the default is the newest (v3, on the re-tuned
    S-plane); a version the domain lacks is refused."""
    import json

    _refused(_run("benchmark", "--domain", "auv3d", "--suite-version", "4", "--policy", "splane", "-o", tmp_path / "b"),
             "--suite-version: the auv3d suite has no version 4; its versions are [1, 2, 3]")
    newest = tmp_path / "v3"
    done = _run("benchmark", "--domain", "auv3d", "--policy", "splane", "--task", "tunnel3d", "--tier", "standard",
                "--water", "ideal", "--episodes", "1", "--max-steps", "5", "--no-progress", "-o", newest, timeout=600)
    assert done.returncode == 0, done.stderr
    results = json.loads((newest / "results.json").read_text())
    assert (results["suite"], results["fingerprint"]) == ("suite 3d v3", "d835f10a7865ba36")
    assert results["cells"]["tunnel3d/standard/ideal"]["task_kwargs"]["executor"] == "splane-ocean"
    out = tmp_path / "v1"
    done = _run("benchmark", "--domain", "auv3d", "--suite-version", "1", "--policy", "splane", "--task", "tunnel3d",
                "--tier", "standard", "--water", "ideal", "--episodes", "1", "--max-steps", "5", "--no-progress",
                "-o", out, timeout=600)
    assert done.returncode == 0, done.stderr
    results = json.loads((out / "results.json").read_text())
    assert (results["suite"], results["suite_version"], results["fingerprint"]) == ("suite 3d v1", 1,
                                                                                     "80981134ec738137")
    assert list(results["cells"]) == ["tunnel3d/standard/ideal"]
    assert "suite 3d v1" in (out / "comparison.md").read_text()


def test_benchmark_task_runs_only_its_cells(tmp_path):
    import json

    out = tmp_path / "b"
    done = _run("benchmark", "--policy", "los-fast", "--task", "tunnel", "--tier", "standard", "--water", "ideal",
                "--episodes", "1", "--max-steps", "5", "--no-progress", "-o", out, "--leaderboard",
                tmp_path / "board.json", timeout=600)
    assert done.returncode == 0, done.stderr
    assert list(json.loads((out / "results.json").read_text())["cells"]) == ["tunnel/standard/ideal"]


@pytest.mark.parametrize("command", [["eval"], ["render"], ["demo"], ["train"], ["plot", "trajectory"]])
def test_task_help_names_the_domains(command):
    text = " ".join(_run(*command, "--help").stdout.split())
    assert "auv3d" in text and "depth_heading" in text and "goal, obstacles" in text, text


def test_a_second_demo_replaces_only_the_files_the_first_one_wrote(tmp_path):
    """The demo's folder lists what the demo wrote (its manifest): a second `auv-mj demo` may replace those, as the
    README's main command is meant to be run again, but never a file of the same name that the demo did not write."""
    from auv_mj.cli.demo import _note_written, demo_wrote

    ours, theirs = tmp_path / "tunnel.mp4", tmp_path / "tunnel_trajectory.png"
    ours.write_text("video")
    theirs.write_text("mine")
    assert not demo_wrote(ours) and not demo_wrote(theirs)
    _note_written(tmp_path, [ours])
    assert demo_wrote(ours) and not demo_wrote(theirs)
    _note_written(tmp_path, [tmp_path / "tunnel_episode.npz"])
    assert demo_wrote(ours) and demo_wrote(tmp_path / "tunnel_episode.npz") and not demo_wrote(theirs)
    assert not demo_wrote(tmp_path / "elsewhere" / "tunnel.mp4")
