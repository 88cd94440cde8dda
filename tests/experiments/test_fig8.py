"""Fig. 8 from a sweep's run directories: the per-run table, the 95 % confidence band and the tested verdict."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from auv_mj.figures import curves
from experiments.report.fig8 import fig8, fig8_logs, mean_ci


def _run_dir(root: Path, name: str, first_success: int, episodes: int = 120) -> None:
    """A run directory whose progress.csv fails `first_success` episodes, then always succeeds."""
    folder = root / name
    folder.mkdir(parents=True)
    rows = ["episode,steps,length,return,success,wall_time"]
    for i in range(1, episodes + 1):
        rows.append(f"{i},{100 * i},100,0.0,{float(i > first_success)},{i}")
    (folder / "progress.csv").write_text("\n".join(rows) + "\n")


def test_fig8_reads_sweep_run_directories_and_tests_the_claim(tmp_path):
    runs = tmp_path / "sweep"
    for seed in range(10):
        _run_dir(runs, f"her-ddpg-seed{seed}", 20 + seed)
        _run_dir(runs, f"ddpg-seed{seed}", 50 + seed)
    _run_dir(runs, "her-ddpg-noise_std=0.3-seed0", 0)  # another grid point: not part of Fig. 8
    assert [p.parent.name for p in fig8_logs(runs, "her-ddpg")] == [f"her-ddpg-seed{s}" for s in range(10)]
    lines: list[str] = []
    fig8(lines, runs, tmp_path / "figures")
    report = "\n".join(lines)
    assert (tmp_path / "figures" / "fig8_learning.png").stat().st_size > 1000
    # a run that fails its first 20 + s episodes reaches 90 % over 20 episodes at episode 20 + s + 18
    assert "| HER-DDPG | her-ddpg-seed3 | 120 | 12000 | " in report and "| 41 |" in report
    assert "| HER-DDPG | 10 | 10 | 42 | 42.5 +- " in report
    assert "**reproduced (one-sided Mann-Whitney U, p = 0.000)**" in report

    close = tmp_path / "close"
    for seed, (her, ddpg) in enumerate(((30, 32), (40, 31), (35, 38))):
        _run_dir(close, f"her-ddpg-seed{seed}", her)
        _run_dir(close, f"ddpg-seed{seed}", ddpg)
    lines = []
    fig8(lines, close, tmp_path / "figures")
    assert "**not shown: the difference is within the spread of the seeds" in "\n".join(lines)
    # The same logs made on the paper's observation: their own heading, figure and command.
    lines = []
    fig8(lines, close, tmp_path / "figures", observation="paper")
    report = "\n".join(lines)
    assert report.startswith("## Fig. 8: HER-DDPG vs plain DDPG on `goal`, on the paper's absolute observation")
    assert (tmp_path / "figures" / "fig8_paper_observation.png").is_file()
    assert """--task-kwargs '{"observation": "paper"}'""" in report and "--paper-runs OUT" in report


def test_confidence_interval_of_the_mean():
    values = [3.0, 5.0, 7.0, 9.0]
    mean, half = mean_ci(values)
    assert mean == 6.0
    assert math.isclose(half, stats.t.ppf(0.975, 3) * np.std(values, ddof=1) / 2)
    runs = [{"episode": np.arange(1.0, 4.0), "success": np.array(v)} for v in ([0, 1, 1], [0, 0, 1], [1, 1, 1])]
    _, mean_curve, low, high = curves.learning_curve(runs, "success", window=1, band="ci")
    np.testing.assert_allclose(mean_curve, [1 / 3, 2 / 3, 1])
    np.testing.assert_allclose(high - mean_curve, stats.t.ppf(0.975, 2) * np.std([0, 0, 1], ddof=1) / np.sqrt(3)
                               * np.array([1, 1, 0]))
    np.testing.assert_allclose(mean_curve - low, high - mean_curve)


def test_peer_report_gives_throughput_and_time_to_target_side_by_side(tmp_path):
    from experiments.report.training_speed import training_speed

    for name, seconds in (("auv-mj-her-ddpg-seed11", 2.0), ("sb3-ddpg-her-seed11", 8.0)):
        _run_dir(tmp_path, name, 10, episodes=40)
        rows = (tmp_path / name / "progress.csv").read_text().splitlines()
        scaled = [rows[0]] + [",".join([*r.split(",")[:5], str(seconds * (i + 1))]) for i, r in enumerate(rows[1:])]
        (tmp_path / f"{name}.csv").write_text("\n".join(scaled) + "\n")
    lines: list[str] = []
    training_speed(lines, tmp_path)
    report = "\n".join(lines)
    # 100 steps per episode: 50 vs 12.5 env steps/s; both reach 90 % at episode 28: 56 s vs 224 s
    assert "auv-mj HER-DDPG 50, SB3 DDPG+HER 12 env steps/s; auv-mj / SB3 = **4.00**" in report
    assert "SB3 / auv-mj wall-clock to the target = **4.00**" in report


def test_reproduce_sections_rewrite_their_blocks_in_place_and_keep_the_others(tmp_path):
    from auv_mj.cli import main
    from auv_mj.cli.reproduce import SECTION_END, SECTION_START, merge_report

    def block(name, body):
        return f"{SECTION_START.format(name)}\n{body}\n{SECTION_END.format(name)}"

    old = "# old header\n" + "\n\n".join([block("table9", "T9 old"), block("fig8", "F8 old"), block("ocean", "OC old")])
    merged = merge_report(old, {"fig8": block("fig8", "F8 new"), "tracking": block("tracking", "TR new")}, ["# new"])
    assert merged.startswith("# new\n") and "old header" not in merged
    assert [line for line in merged.splitlines() if not line.startswith(("<!--", "#")) and line] == \
        ["T9 old", "TR new", "F8 new", "OC old"]  # SECTIONS order, the others kept as they were
    report = tmp_path / "report.md"
    report.write_text(old)
    assert main(["reproduce", "--sections", "training_speed", "--out", str(report),
                 "--peer-runs", str(tmp_path / "no-peer-logs")]) == 0
    text = report.read_text()
    assert "T9 old" in text and "F8 old" in text and "OC old" in text
    assert text.index("T9 old") < text.index(SECTION_START.format("training_speed")) < text.index("OC old")
    assert "_Section `training_speed` measured" in text


def _summary(success: float, collisions: float, time: float | None) -> dict:
    return {"episodes": 200, "success_rate": success, "collision_rate": collisions, "time_to_goal": time,
            "min_clearance": 2.0, "outcomes": {"goal": int(200 * success), "collision": int(200 * collisions)}}


def test_the_heldout_section_judges_each_set_by_the_issue_15_bar(monkeypatch):
    from auv_mj.benchmark import runner
    from experiments.report import heldout

    figures = {  # (policy, task) -> summary; los-avoid is slower everywhere
        ("two-layer-general", "tunnel"): _summary(0.97, 0.005, 400.0),  # met
        ("two-layer-general", "obstacles"): _summary(0.97, 0.02, 140.0),  # too many collisions
        ("two-layer-general", "moving_obstacles"): _summary(0.96, 0.0, 300.0),  # slower than los-avoid
        ("los-avoid", "tunnel"): _summary(0.96, 0.0, 800.0),
        ("los-avoid", "obstacles"): _summary(1.0, 0.0, 280.0),
        ("los-avoid", "moving_obstacles"): _summary(0.96, 0.0, 280.0),
    }
    calls = []

    def fake_evaluate(name, tasks, episodes, seed, **kwargs):
        calls.append((name, tasks[0], episodes, seed, kwargs["workers"]))
        return {"tasks": {tasks[0]: figures.get((name, tasks[0]), _summary(0.5, 0.1, 100.0))}}

    def fake_episode(name, task, seed, kwargs):  # the scenarios: one too close to an obstacle
        short = kwargs.get("scenario") == "b" and task == "obstacles"
        return {"outcome": "goal", "min_clearance": 4.2 if short else 8.0, "time_to_goal": 100.0}

    monkeypatch.setattr(runner, "evaluate", fake_evaluate)
    monkeypatch.setattr(runner, "run_episode", fake_episode)
    lines: list[str] = []
    heldout.heldout(lines, workers=2)
    report = "\n".join(lines)
    assert {c[2:] for c in calls} == {(heldout.HELDOUT_EPISODES, 10_000, 2)}
    assert "random tunnels: **met**; random obstacles: **NOT met**; random moving obstacles: **NOT met**" in report
    assert "Scenarios: **NOT met: obstacles b**." in report


def test_report_sections_are_registered_once_each_in_report_order():
    from experiments.report import SECTIONS, section

    assert list(SECTIONS)[:3] == ["table9", "tracking", "fig8"] and "heldout" in SECTIONS
    # "heldout" is issue 15's bar; "benchmark" lays out what `auv-mj benchmark --publish` measured (issue 30)
    assert SECTIONS["benchmark"].__module__ == "experiments.report.tiers"
    with pytest.raises(ValueError, match="registered twice"):
        section("table9")(lambda lines, settings: None)
