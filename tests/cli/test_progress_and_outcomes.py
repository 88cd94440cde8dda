"""What the commands print and draw for a newcomer (issue 53, item 10): counts in words, honest progress bars and
tables, figures whose labels and tracks can be read."""

from __future__ import annotations

from auv_mj.cli import main


def test_counts_read_as_words(tmp_path, capsys):
    from auv_mj.console import counted

    assert (counted(1, "mover"), counted(2, "mover"), counted(0, "unknown obstacle")) == (
        "1 mover", "2 movers", "0 unknown obstacles")
    assert counted(1, "wall box", "wall boxes") == "1 wall box" and counted(3, "box", "boxes") == "3 boxes"
    centreline = tmp_path / "straight.csv"
    centreline.write_text("x,y\n0,0\n100,0\n200,0\n")
    arena = tmp_path / "straight.xml"
    assert main(["tunnel", str(centreline), "--width", "40", "--unknown", "100,6,6,4", "--mover",
                 "150,-10,150,10,0.1,2", "-o", str(arena)]) == 0
    written = capsys.readouterr().out
    assert "1 unknown obstacle, 1 mover, " in written and "1 movers" not in written, written
    assert main(["check-arena", str(arena)]) == 0
    checked = capsys.readouterr().out
    assert "1 unknown obstacle, 1 mover, " in checked and "1 movers" not in checked, checked


# --- the demo on an arena of one's own ------------------------------------------------------------------------------


def test_the_demo_flies_the_general_planner_on_an_arena_of_ones_own_and_says_so(tmp_path, capsys):
    from auv_mj.cli.demo import ARENA_SYSTEM, SYSTEM, demo_policy

    assert demo_policy(None, {}) == (SYSTEM, "")
    assert demo_policy("map-replan", {"arena": "mine.xml"}) == ("map-replan", "")  # asked for: flown
    assert demo_policy(None, {"arena": "mine.xml"})[0] == ARENA_SYSTEM == "planner-general"
    centreline = tmp_path / "short.csv"
    centreline.write_text("x,y\n0,0\n60,0\n")
    arena = tmp_path / "short.xml"
    assert main(["tunnel", str(centreline), "--width", "30", "-o", str(arena)]) == 0
    capsys.readouterr()
    assert main(["demo", "--no-video", "--arena", str(arena), "--out", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out
    assert f"flying {ARENA_SYSTEM}" in out and f"--policy {SYSTEM}" in out
    rows = [line.split() for line in out.splitlines() if line.split()[:1] and line.split()[0] in (ARENA_SYSTEM, SYSTEM)]
    assert rows and rows[0][:2] == [ARENA_SYSTEM, "goal"] and all(row[0] != SYSTEM for row in rows), out


# --- the eval table and its CSV ---------------------------------------------------------------------------------------


def test_an_episode_cut_by_max_steps_is_labelled_cut_and_still_recorded_as_a_timeout(tmp_path, capsys):
    import csv

    from auv_mj import zoo
    from auv_mj.episode import EpisodeRecord, episode_metrics, outcome_label, record_episode

    env, policy = zoo.env_and_policy("splane", "goal", 0)
    cut = record_episode(env, policy, 3)
    assert cut.cut and episode_metrics(cut)["outcome"] == "timeout" and episode_metrics(cut)["cut"]
    assert EpisodeRecord.load(cut.save(tmp_path / "cut.npz")).cut
    assert outcome_label("timeout", True, 3) == "cut (--max-steps 3)" and outcome_label("timeout", False) == "timeout"
    env, policy = zoo.env_and_policy("splane", "goal", 0, {"goal_radius": 50.0})
    ended = record_episode(env, policy, 10_000)
    assert not ended.cut and episode_metrics(ended)["outcome"] == "goal"
    assert main(["eval", "--policy", "splane", "--task", "goal", "--episodes", "1", "--max-steps", "20",
                 "--no-progress", "--csv", str(tmp_path / "goal.csv")]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("goal "))
    assert row.endswith("cut 1") and "timeout" not in row, out
    assert "cut: stopped by --max-steps" in out
    assert "none seen" in row and "120.000" not in row  # open water: nothing within the sonar's range
    with open(tmp_path / "goal_episodes.csv") as f:
        episode = next(csv.DictReader(f))
    assert episode["outcome"] == "timeout" and episode["cut"] == "True"  # what the benchmark counts is unchanged
    assert episode["duration"] == "10.0"  # twenty 0.5 s steps, not 10.000000000000126


def test_times_are_rounded_to_the_microsecond():
    from auv_mj import zoo
    from auv_mj.episode import TIME_DECIMALS, episode_metrics, record_episode

    env, policy = zoo.env_and_policy("splane", "speed_heading", 0)
    metrics = episode_metrics(record_episode(env, policy, 201))  # 201 steps of 0.1 s: 20.1 s, as the clock sums
    assert metrics["duration"] == round(metrics["duration"], TIME_DECIMALS) and len(repr(metrics["duration"])) < 10


# --- training's progress ---------------------------------------------------------------------------------------------


def test_training_on_a_tracking_task_shows_the_tracking_error_not_a_success_rate(tmp_path, capsys):
    from auv_mj.agents.offpolicy.train import EpisodeErrors, errors_text

    errors = EpisodeErrors()
    errors.add(0, {"success": False, "speed_error": 1.0})  # a goal task: its success rate tells
    assert errors.end(0) is None
    for e_v, e_psi in ((0.1, -0.02), (-0.3, 0.04)):
        errors.add(1, {"speed_error": e_v, "heading_error": e_psi, "is_success": False})
    mean = errors.end(1)
    assert mean == {"speed_error": 0.2, "heading_error": 0.03} and errors.end(1) is None
    assert errors_text(mean) == "|e| speed 0.2 m/s, heading 1.72 deg"
    assert main(["train", "td3", "--task", "speed_heading", "--episodes", "1", "--run-dir", str(tmp_path / "run"),
                 "--no-tensorboard", "--learning-starts", "100000"]) == 0
    captured = capsys.readouterr()
    assert "success" not in captured.out and "tracking |e| speed " in captured.out, captured.out
    assert "success" not in captured.err and "|e| speed" in captured.err


# --- figures ---------------------------------------------------------------------------------------------------------


def test_a_hard_arenas_preview_keeps_every_label_apart_and_readable(tmp_path):
    """The preview of a hard arena (traps and four movers crowded round the path): every shape and mover named, each
    name on a white ground, LABEL_GAP pixels clear of every other name and of the start and goal markers."""
    import matplotlib.pyplot as plt

    from auv_mj.arenas.arena import arena_info, load
    from auv_mj.figures.arenas import LABEL_GAP, arena_figure

    arena = tmp_path / "hard.xml"
    assert main(["tunnel", "--random", "2", "--task", "moving_obstacles", "--tier", "hard", "-o", str(arena)]) == 0
    physics = load(arena)
    info = arena_info(physics)
    fig = arena_figure(physics, info)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    labels = [t for t in ax.texts if t.get_text()]
    names = {t.get_text().split(" ")[0] for t in labels}
    assert {m.body for m in info.movers} <= names and sum(n.startswith("unknown") for n in names) >= 3, names
    assert all(t.get_bbox_patch() is not None for t in labels)  # a white ground under each name
    from matplotlib.text import Text

    boxes = [Text.get_window_extent(t, renderer) for t in labels]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.padded(LABEL_GAP - 1).overlaps(b), (a, b)
    markers = [line.get_window_extent(renderer) for line in ax.lines if line.get_label() in ("start", "goal")]
    assert len(markers) == 2 and not any(a.overlaps(m) for a in boxes for m in markers)
    plt.close(fig)


def test_the_trajectory_figure_shows_tracks_that_run_together(tmp_path):
    """Two policies on the same line: each track its own colour and dashes, the earlier one wider and under the later
    one, both a little transparent, so that neither hides the other; the map's colours left to the map."""
    import matplotlib.pyplot as plt

    from auv_mj import zoo
    from auv_mj.episode import record_episode
    from auv_mj.figures import trajectory

    env, policy = zoo.env_and_policy("splane", "goal", 0)
    record = record_episode(env, policy, 10)
    fig = trajectory.trajectory_figure([record, record, record], labels=["a", "b", "c"], width=800)
    ax = fig.axes[0]
    tracks = {line.get_label(): line for line in ax.lines if line.get_label() in ("a", "b", "c")}
    assert len({t.get_color() for t in tracks.values()}) == 3
    assert [t.get_linestyle() for t in tracks.values()] == ["-", "--", "--"]  # then two dash patterns of their own
    assert tracks["b"]._unscaled_dash_pattern != tracks["c"]._unscaled_dash_pattern
    a, b, c = tracks["a"], tracks["b"], tracks["c"]
    assert a.get_linewidth() > b.get_linewidth() > c.get_linewidth()
    assert a.get_zorder() < b.get_zorder() < c.get_zorder()
    assert all(t.get_alpha() is not None and t.get_alpha() < 1 for t in tracks.values())
    assert not {t.get_color() for t in tracks.values()} & {"tab:green", "tab:red", "tab:orange"}
    plt.close(fig)
