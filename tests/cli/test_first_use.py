"""What a newcomer meets first: a deterministic run is one episode said plainly, every episode is a record (JSON and
CSV), the benchmark's comparison shows the policy's own published row, long work ends its bar at 100 %, and a shipped
network is named by its policy name (`auv-mj train --init NAME`, `auv_mj.zoo.checkpoint_path`)."""

import copy
import csv
import json

import numpy as np
import pytest

from auv_mj import zoo
from auv_mj.benchmark import metrics, runner, suite
from auv_mj.benchmark.leaderboard import PUBLISHED_MARK, RUN_MARK, comparison_table, publish
from auv_mj.cli import evaluate as evaluate_cli
from auv_mj.cli import main
from auv_mj.episode import EpisodeRecorder, episode_metrics

STEPS = 5
"""Steps per episode in these tests: enough for two seeds to tell their episodes apart."""


# --- deterministic runs --------------------------------------------------------------------------------------------


def test_a_fixed_tunnel_in_ideal_water_is_one_episode_standing_for_every_seed():
    kept = []
    results = runner.evaluate("splane", ["tunnel"], 4, 0, STEPS, progress=False,
                              on_episode=lambda task, seed, m: kept.append((task, seed)))
    summary = results["tasks"]["tunnel"]
    assert summary["deterministic"] is True and summary["stands_for"] == 4
    assert summary["episodes"] == 1 and sum(summary["outcomes"].values()) == 1
    assert [row["seed"] for row in results["records"]["tunnel"]] == [0]
    assert kept == [("tunnel", 0)]  # a failure is filmed once, not once per seed
    for seed in (2, 3):  # the seeds that were not run give that very episode
        again = runner.run_episode("splane", "tunnel", seed, None, STEPS)
        assert runner.episode_row(0, again) == results["records"]["tunnel"][0]


@pytest.mark.parametrize(("policy", "task", "options"), [
    ("random", "tunnel", {}),                         # a policy that draws its actions from the seed
    ("splane", "goal", {}),                           # a task that draws its start and goal from the seed
    ("splane", "tunnel", {"conditions": "ocean"}),    # water that draws its current from the seed
])
def test_episodes_that_depend_on_their_seed_all_run(policy, task, options):
    results = runner.evaluate(policy, [task], 3, 0, STEPS, progress=False, task_kwargs=options)
    summary = results["tasks"][task]
    assert "deterministic" not in summary and "stands_for" not in summary
    assert summary["episodes"] == 3 and [row["seed"] for row in results["records"][task]] == [0, 1, 2]
    assert len({row["return"] for row in results["records"][task]}) > 1


def test_a_parallel_deterministic_run_is_the_serial_one():
    serial = runner.evaluate("splane", ["tunnel", "goal"], 3, 0, STEPS, progress=False)
    parallel = runner.evaluate("splane", ["tunnel", "goal"], 3, 0, STEPS, progress=False, workers=2)
    assert parallel == serial
    assert serial["tasks"]["tunnel"]["deterministic"] and "deterministic" not in serial["tasks"]["goal"]


def test_eval_says_deterministic_writes_records_and_films_the_failure_once(tmp_path, capsys):
    out, films = tmp_path / "out.json", tmp_path / "films"
    assert main(["eval", "--policy", "splane", "--task", "tunnel", "--episodes", "3", "--max-steps", str(STEPS),
                 "--json", str(out), "--csv", str(tmp_path / "out.csv"), "--record-failures", str(films),
                 "--no-progress"]) == 0
    assert "tunnel: deterministic: 1 episode stands for 3 seeds" in capsys.readouterr().out
    results = json.loads(out.read_text())
    assert results["tasks"]["tunnel"]["deterministic"] is True and results["tasks"]["tunnel"]["stands_for"] == 3
    assert len(results["records"]["tunnel"]) == 1
    assert sorted(p.name for p in films.iterdir() if p.suffix == ".png") == ["tunnel_seed0_timeout_trajectory.png"]
    with open(tmp_path / "out_episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(r["task"], r["seed"], r["outcome"]) for r in rows] == [("tunnel", "0", "timeout")]
    assert float(rows[0]["return"]) == results["records"]["tunnel"][0]["return"]


# --- per-episode records ---------------------------------------------------------------------------------------------


def test_eval_records_are_the_episodes_and_the_csv_holds_them(tmp_path):
    results = runner.evaluate("splane", ["goal"], 2, 5, STEPS, progress=False)
    rows = results["records"]["goal"]
    env, policy = zoo.env_and_policy("splane", "goal", 6)
    recorder = EpisodeRecorder(env, "goal", "splane", 6)
    for _ in recorder.run(policy, STEPS):
        pass
    record = recorder.record()
    expected = episode_metrics(record)
    assert rows[1]["seed"] == 6
    for key in ("outcome", "path_length", "min_clearance", "return", "time_to_goal"):
        assert rows[1][key] == expected[key]
    assert rows[1]["duration"] == pytest.approx(STEPS * env.control_timestep())  # five 0.5 s planner steps
    assert rows[1]["path_length"] == pytest.approx(np.sum(np.hypot(*np.diff(record.pose[:, :2], axis=0).T)))
    assert metrics.summarise(rows) == results["tasks"]["goal"]

    evaluate_cli.write_outputs(results, None, tmp_path / "goal.csv")
    with open(tmp_path / "goal_episodes.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert [int(r["seed"]) for r in table] == [5, 6]
    for got, row in zip(table, rows, strict=True):
        assert got["outcome"] == row["outcome"] and float(got["return"]) == row["return"]
        assert float(got["duration"]) == row["duration"] and got["min_clearance"] == str(row["min_clearance"])


# --- the benchmark's comparison ------------------------------------------------------------------------------------


def test_the_comparison_puts_the_policys_published_row_beside_the_run(tmp_path):
    cells = [c for c in suite.SUITE_V1 if c.tier == "hard" and c.water == "ideal"][:1]
    published = runner.benchmark("los-fast", cells, 2, 20, progress=False)
    board = publish(published, tmp_path / "board.json")
    short = copy.deepcopy(published)
    for cell in short["cells"].values():  # a shorter run of the same policy: its first episode
        cell["episodes"] = cell["episodes"][:1]
        cell["summary"] = metrics.cell_summary(cell["episodes"], None)
    table = comparison_table(short, board)
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    run, mine = rows[:2]  # the run, and right under it its published entry
    assert run.startswith(f"| `los-fast`{RUN_MARK} |") and mine.startswith(f"| `los-fast`{PUBLISHED_MARK} |")
    assert run.split("|")[3].strip() == "1" and mine.split("|")[3].strip() == "2"  # episodes: the run's, the board's
    assert len(rows) == 2  # the board holds no other policy
    other = comparison_table({**short, "policy": "los-avoid"}, board).splitlines()
    assert not any(PUBLISHED_MARK in line for line in other)  # no published row of its own: none marked


# --- progress bars end at 100 % --------------------------------------------------------------------------------------


def _last_bar(text: str) -> str:
    return [line for line in text.replace("\r", "\n").splitlines() if "|" in line][-1]


def test_the_render_bar_ends_at_100_percent_when_the_episode_ends_early(capsys):
    """The bar counts the metres made good along the route, its total fixed from the first draw (not the time limit's
    steps, rewritten to the steps done at the end); it ends full at the goal, and short of it when the run is cut."""
    import re

    from auv_mj.render.episode_video import iter_frames

    env, policy = zoo.env_and_policy("splane", "goal", 0, {"goal_radius": 50.0})
    recorder = EpisodeRecorder(env, "goal", "splane", 0)
    for _ in iter_frames(env, policy, width=96, height=64, hold_end=0.0, recorder=recorder, progress=True):
        pass
    assert recorder.record().steps < env._step_limit  # the goal was reached before the time limit
    text = capsys.readouterr().err
    totals = {int(total) for total in re.findall(r"\d+/(\d+) m", text)}
    last = _last_bar(text)
    assert len(totals) == 1 and "100%" in last and f"{min(totals)}/{min(totals)} m" in last and "goal" in last
    for _ in iter_frames(env, policy, max_steps=4, width=96, height=64, hold_end=0.0, progress=True):
        pass
    last = _last_bar(capsys.readouterr().err)
    assert "100%" not in last and "cut (--max-steps 4)" in last, last


def test_the_demo_shows_its_table_episodes_to_100_percent(tmp_path, capsys):
    from auv_mj.cli.demo import COMPARED

    assert main(["demo", "--no-video", "--task", "goal", "--task-kwargs", '{"goal_radius": 50}', "--out",
                 str(tmp_path)]) == 0  # a near goal: four short episodes
    last = _last_bar(capsys.readouterr().err)
    assert last.startswith("demo: table episodes: 100%") and f"{len(COMPARED) + 1}/{len(COMPARED) + 1}" in last


def test_reproduce_counts_its_sections_to_100_percent(tmp_path, capsys):
    assert main(["reproduce", "--sections", "fig8,training_speed", "--out", str(tmp_path / "report.md")]) == 0
    last = _last_bar(capsys.readouterr().err)  # two sections that read the shipped training logs
    assert last.startswith("reproduce: 100%") and "2/2" in last


def test_check_arena_shows_its_stages_to_100_percent(tmp_path, capsys):
    from auv_mj.arenas.arena_check import CHECK_STAGES, check_arena
    from auv_mj.figures.arenas import PREVIEW_STAGES, preview

    assert preview("models/arenas/obstacles_table7_a.xml", tmp_path / "a.png", need_path=False, progress=True).ok
    last = _last_bar(capsys.readouterr().err)
    assert "100%" in last and f"{len(PREVIEW_STAGES)}/{len(PREVIEW_STAGES)}" in last
    assert check_arena("models/arenas/obstacles_table7_a.xml", need_path=False, progress=True).ok
    last = _last_bar(capsys.readouterr().err)
    assert "100%" in last and f"{len(CHECK_STAGES)}/{len(CHECK_STAGES)}" in last
    assert check_arena(tmp_path / "missing.xml", progress=True).problems  # a check that stops early ends at 100 % too
    last = _last_bar(capsys.readouterr().err)
    assert "100%" in last


# --- shipped networks by name --------------------------------------------------------------------------------------


def test_checkpoint_path_names_the_shipped_network():
    shipped = zoo.checkpoint_path("planner-route")
    assert shipped.is_file() and shipped == zoo.shipped_checkpoint("planner-route")
    assert zoo.checkpoint_path("planner", "tunnel").name == "planner_tunnel.pt"  # the paper's per-task planner
    assert zoo.checkpoint_path(shipped) == shipped
    for wrong, words in (("splane", "no checkpoint"), ("no-such-net", "not a checkpoint file")):
        with pytest.raises(ValueError, match=words):
            zoo.checkpoint_path(wrong)


def test_train_init_by_policy_name_starts_from_its_shipped_networks(tmp_path, capsys):
    import torch

    from auv_mj.agents.checkpoint import read_checkpoint

    options = read_checkpoint(zoo.checkpoint_path("planner-route"))[1]["run_info"]  # what it was trained on
    assert main(["train", "ddpg", "--task", "planning", "--task-kwargs", json.dumps(options["task_kwargs"]),
                 "--env-kwargs", json.dumps(options["env_kwargs"]), "--steps", "3", "--init", "planner-route",
                 "--run-dir", str(tmp_path / "run"), "--no-progress", "--no-tensorboard"]) == 0
    mine = read_checkpoint(tmp_path / "run" / "checkpoint.pt")[0]
    shipped = read_checkpoint(zoo.checkpoint_path("planner-route"))[0]
    actor = [k for k in shipped if k.startswith("actor.net.")]
    assert actor
    for key in actor:  # no gradient step in three steps: the run's actor is the shipped one
        assert torch.equal(mine[key], shipped[key]), key
    capsys.readouterr()
    with pytest.raises(SystemExit) as refused:
        main(["train", "ddpg", "--task", "goal", "--steps", "3", "--init", "splane", "--run-dir", str(tmp_path / "x")])
    error = capsys.readouterr().err
    assert refused.value.code == 2 and "no checkpoint" in error and "planner-route" in error
