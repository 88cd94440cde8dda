"""`auv-mj benchmark`: the suite's definition is pinned to its version, its figures follow their definitions, and
the command writes strict JSON, the leaderboard row and the comparison (end to end, on two episodes)."""

import csv
import json
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from auv_mj import seeds
from auv_mj.benchmark import metrics, runner, suite
from auv_mj.benchmark.leaderboard import board_path, read_board
from auv_mj.benchmark.runner import run_episode

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


def _run(*args, timeout=600):
    return subprocess.run([*AUV_MJ, "benchmark", *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=ENV)


def _strict(text: str) -> dict:
    def refuse(constant):
        raise ValueError(f"non-strict JSON constant {constant}")

    return json.loads(text, parse_constant=refuse)


def test_the_suite_definition_is_pinned_to_its_version():
    """Changing what suite v1 measures must bump SUITE_VERSION and add the new fingerprint."""
    assert suite.fingerprint() == suite.FINGERPRINTS[suite.SUITE_VERSION]
    assert suite.SUITE_NAME == f"suite v{suite.SUITE_VERSION}"
    changed = [suite.Cell("tunnel", "hard", "ocean", seeds.TEST.start, episodes=suite.EPISODES + 1)]
    assert suite.fingerprint(changed) != suite.fingerprint(suite.SUITE_V1[-1:])


def test_the_3d_suite_is_pinned_to_its_version_and_apart_from_suite_v1():
    """The 3-D suite has its own name, fingerprint and board; suite v1's fingerprint does not move with it."""
    three = suite.SUITES["auv3d"]
    assert three.fingerprint() == suite.FINGERPRINTS_3D[three.version]
    assert suite.SUITES["auv"].fingerprint() == suite.FINGERPRINTS[suite.SUITE_VERSION] == suite.fingerprint()
    assert three.fingerprint() != suite.fingerprint() and three.board != suite.SUITES["auv"].board
    assert {c.task for c in three.cells} == {"goal3d", "tunnel3d"}
    assert {(c.tier, c.water) for c in three.cells} == {(t, w) for t in suite.TIERS for w in suite.WATERS}
    blocks = {c.first_seed for c in three.cells} | {c.first_seed for c in suite.SUITE_V1}
    assert all(first in seeds.TEST and first + suite.SEED_BLOCK - 1 in seeds.TEST for first in blocks)
    assert len({c.first_seed for c in three.cells} & {c.first_seed for c in suite.SUITE_V1}) == 0


def test_suite_3d_v3_is_the_current_3d_suite_and_v1_and_v2_keep_their_fingerprints_and_boards():
    """suite 3d v2 and v3 pair with v1 seed by seed under their own names, fingerprints and boards; v1 and v2 and
    their published boards stay as they were (a board of a version's results names its fingerprint)."""
    one, two, three = suite.VERSIONS["auv3d"]
    assert suite.SUITES["auv3d"] is three and suite.suite_for("auv3d") is three
    assert suite.suite_for("auv3d", 1) is one and suite.suite_for("auv3d", 2) is two
    assert [(s.version, s.name) for s in (one, two, three)] == [(1, "suite 3d v1"), (2, "suite 3d v2"),
                                                                 (3, "suite 3d v3")]
    assert one.fingerprint() == suite.FINGERPRINTS_3D[1] == "80981134ec738137"
    assert two.fingerprint() == suite.FINGERPRINTS_3D[2] == "f8d702707f88071c"
    assert three.fingerprint() == suite.FINGERPRINTS_3D[3] not in (one.fingerprint(), two.fingerprint())
    assert [(c.name, c.first_seed) for c in two.cells] == [(c.name, c.first_seed) for c in one.cells]
    assert [(c.name, c.first_seed) for c in three.cells] == [(c.name, c.first_seed) for c in one.cells]
    assert len({one.board, two.board, three.board}) == 3 and suite.suite_named("suite 3d v1") is one
    for version in (one, two, three):
        board = read_board(board_path(version))
        assert board["suite"] == version.name and board["fingerprint"] == version.fingerprint()
        assert {"oracle", "map-replan", "los-avoid", "splane", "two-layer-3d"} <= set(board["policies"])
        assert all(run["fingerprint"] == version.fingerprint() for run in board["policies"].values())
    with pytest.raises(ValueError, match="no version 4; its versions are \\[1, 2, 3\\]"):
        suite.suite_for("auv3d", 4)
    with pytest.raises(ValueError, match="no benchmark domain 'auv4d'"):
        suite.suite_for("auv4d")


def test_suite_3d_v3_runs_every_policy_on_the_re_tuned_s_plane_unless_it_brings_its_own_executor():
    """v3's cells name `splane-ocean`, and the options a policy runs a cell with keep it, except for a policy that
    always runs its own executor (two-layer-3d's learned depth executor); v1 and v2's cells name no executor, so
    their definitions (and fingerprints) are what they were before cells could name one."""
    one, two, three = suite.VERSIONS["auv3d"]
    for old, new in zip(two.cells, three.cells, strict=True):
        assert old.executor is None and "executor" not in old.task_kwargs
        assert new.executor == "splane-ocean" and new.task_kwargs == {**old.task_kwargs, "executor": "splane-ocean"}
        assert runner.cell_task_kwargs("map-replan", new) == new.task_kwargs
        assert runner.cell_task_kwargs("two-layer-3d", new) == old.task_kwargs
        assert runner.cell_task_kwargs("two-layer-3d", old) == old.task_kwargs
    assert all("executor" not in cell for cell in suite.definition(two.cells, two.name)["cells"])
    assert all(cell["executor"] == "splane-ocean" for cell in suite.definition(three.cells, three.name)["cells"])
    assert suite.fingerprint([replace(two.cells[0], executor="splane")]) != suite.fingerprint(two.cells[:1])


def test_the_suite_covers_every_set_tier_and_water_on_held_out_seeds():
    cells = suite.SUITE_V1
    assert {(c.task, c.tier, c.water) for c in cells} == {
        (t, tier, w) for t in ("obstacles", "moving_obstacles", "tunnel") for tier in suite.TIERS
        for w in suite.WATERS}
    assert len({c.name for c in cells}) == len(cells)
    for cell in cells:
        block = cell.seeds(suite.SEED_BLOCK)
        assert block[0] in seeds.TEST and block[-1] in seeds.TEST
        assert cell.task_kwargs == {"arena": "random", "tier": cell.tier, "conditions": cell.water}
    firsts = {c.task: c.first_seed for c in cells}
    starts = sorted(firsts.values())
    assert all(b - a >= suite.SEED_BLOCK for a, b in zip(starts, starts[1:], strict=False))  # sets never share


@pytest.mark.parametrize(("wins", "n"), [(0, 10), (5, 10), (10, 10), (37, 40), (1, 200)])
def test_wilson_interval_matches_scipy(wins, n):
    from scipy.stats import binomtest

    expected = binomtest(wins, n).proportion_ci(0.95, method="wilson")
    low, high = metrics.wilson(wins, n)
    assert low == pytest.approx(expected.low, abs=1e-4) and high == pytest.approx(expected.high, abs=1e-4)


def test_time_efficiency_is_oracle_time_over_own_time_and_zero_on_failure():
    rows = [{"seed": 1, "success": True, "time_to_goal": 100.0, "outcome": "goal"},
            {"seed": 2, "success": False, "time_to_goal": None, "outcome": "collision"},
            {"seed": 3, "success": True, "time_to_goal": 40.0, "outcome": "goal"},  # faster than the oracle: 1
            {"seed": 4, "success": True, "time_to_goal": 80.0, "outcome": "goal"}]  # no oracle success: left out
    rows = [{**r, "collision": r["outcome"] == "collision", "safety_violation": False, "min_clearance": 3.0,
             "path_length": 1.0, "return": 0.0} for r in rows]
    summary = metrics.cell_summary(rows, {1: 60.0, 2: 50.0, 3: 50.0})
    assert summary["time_efficiency"] == pytest.approx((0.6 + 0.0 + 1.0) / 3)
    assert summary["time_efficiency_episodes"] == 3
    assert summary["success_rate"] == 0.75 and summary["outcomes"]["collision"] == 1
    assert metrics.cell_summary(rows, None)["time_efficiency"] is None


def test_a_reused_environment_gives_the_episodes_of_fresh_ones():
    cell = suite.SUITE_V1[2]  # obstacles, hard, ideal
    for seed in cell.seeds(2):
        got = runner.run_cell_episode("los-fast", cell.task, seed, cell.task_kwargs, 60)
        expected = run_episode("los-fast", cell.task, seed, cell.task_kwargs, 60)
        assert {k: got[k] for k in got if k != "seed"} == {k: expected[k] for k in got if k != "seed"}


def test_benchmark_on_two_episodes_writes_json_row_and_comparison(tmp_path):
    board = tmp_path / "board.json"
    first = tmp_path / "first"
    done = _run("--policy", "los-fast", "--tier", "hard", "--water", "ideal", "--episodes", "2", "--max-steps", "40",
                "--workers", "2", "--out", first, "--leaderboard", board, "--publish")
    assert done.returncode == 0, done.stderr
    results = _strict((first / "results.json").read_text())
    assert results["suite"] == "suite v1" and results["suite_version"] == suite.SUITE_VERSION
    assert results["fingerprint"] == suite.fingerprint()
    assert list(results["cells"]) == ["obstacles/hard/ideal", "moving_obstacles/hard/ideal", "tunnel/hard/ideal"]
    for name, cell in results["cells"].items():
        summary = cell["summary"]
        assert summary["episodes"] == 2 and sum(summary["outcomes"].values()) == 2
        low, high = summary["success_ci95"]
        assert 0.0 <= low <= summary["success_rate"] <= high <= 1.0
        assert [e["seed"] for e in cell["episodes"]] == list(cell["seeds"]) == [cell["seeds"][0], cell["seeds"][0] + 1]
        task = name.split("/")[0]
        for episode in cell["episodes"]:  # the parallel run's episodes are the serial loop's
            again = runner.run_cell_episode("los-fast", task, episode["seed"], cell["task_kwargs"], 40)
            assert again == episode
    with open(first / "episodes.csv", newline="") as f:  # one row per episode, as results.json holds them
        table = list(csv.DictReader(f))
    assert [(r["cell"], int(r["seed"]), r["outcome"]) for r in table] == [
        (name, e["seed"], e["outcome"]) for name, cell in results["cells"].items() for e in cell["episodes"]]
    assert all(float(r["duration"]) > 0 for r in table)
    row = (first / "leaderboard_row.md").read_text().splitlines()
    assert row[0].startswith("| policy |") and row[2].startswith("| `los-fast` | suite v1 | 6 |")
    assert row[2].count("|") == row[0].count("|")
    assert "los-fast" in _strict(board.read_text())["policies"]
    assert "`los-fast`" in board.with_suffix(".md").read_text()

    second = tmp_path / "second"
    done = _run("--policy", "los-avoid", "--tier", "hard", "--water", "ideal", "--episodes", "2", "--max-steps",
                "40", "--out", second, "--leaderboard", board, "--no-progress")
    assert done.returncode == 0, done.stderr
    comparison = (second / "comparison.md").read_text()
    assert "`los-fast` |" in comparison and "`los-avoid` (this run)" in comparison


def test_refusals_come_before_any_episode(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    for args, words in ((["--policy", "los-fast", "--out", blocker / "out"], "--out"),
                        (["--policy", "los-fast", "--tier", "medium", "--out", tmp_path / "o"], "--tier"),
                        (["--policy", "no-such-policy", "--out", tmp_path / "o"], "unknown policy")):
        done = _run(*args, timeout=120)
        assert done.returncode == 2, done.stderr
        assert words in done.stderr and "Traceback" not in done.stderr
        assert "ep/s" not in done.stderr  # no progress bar: nothing ran


def _flown(seed: int, length: float, time: float, success: bool = True) -> dict:
    return {"seed": seed, "success": success, "outcome": "goal" if success else "collision",
            "path_length": length, "time_to_goal": time if success else None}


def test_path_efficiency_times_speed_ratio_is_the_uncapped_time_efficiency():
    """The identity the report's "where the time goes" table rests on, against oracle time / own time computed here
    from the raw numbers, over random lengths and times (both faster and slower than the oracle)."""
    rng = np.random.RandomState(0)
    for _ in range(2000):
        length, time, oracle_length, oracle_time = 10.0 ** rng.uniform(-2, 4, 4)
        path, speed = metrics.efficiency_parts(_flown(1, length, time), _flown(1, oracle_length, oracle_time))
        expected = oracle_time / time
        assert abs(path * speed - expected) <= 1e-12 * max(1.0, expected)
        assert path == oracle_length / length


def test_efficiency_parts_of_a_known_case_and_none_on_a_failure():
    oracle = _flown(7, 400.0, 200.0)
    path, speed = metrics.efficiency_parts(_flown(7, 500.0, 250.0), oracle)  # same 2 m/s, 100 m longer
    assert path == pytest.approx(0.8, abs=1e-15) and speed == pytest.approx(1.0, abs=1e-15)
    path, speed = metrics.efficiency_parts(_flown(7, 400.0, 400.0), oracle)  # same path at half the speed
    assert path == 1.0 and speed == pytest.approx(0.5, abs=1e-15)
    assert metrics.efficiency_parts(_flown(7, 500.0, 250.0, success=False), oracle) is None
    assert metrics.efficiency_parts(_flown(7, 500.0, 250.0), _flown(7, 400.0, 200.0, success=False)) is None


def test_decomposition_pairs_by_seed_and_counts_the_shared_successes():
    cell, other = "obstacles/hard/ideal", "tunnel/hard/ideal"
    oracle = {"cells": {cell: {"episodes": [_flown(1, 100.0, 50.0), _flown(2, 200.0, 100.0), _flown(3, 300.0, 150.0),
                                            _flown(4, 100.0, 50.0, success=False)]},
                        other: {"episodes": [_flown(1, 90.0, 30.0)]}}}
    ours = {"cells": {cell: {"episodes": [  # another order, seed 2 missing, seed 5 not in the oracle's, 4 its failure
        _flown(3, 600.0, 300.0),  # 0.5 / 1.0
        _flown(5, 1.0, 1.0), _flown(4, 100.0, 50.0),
        _flown(1, 100.0, 100.0)]},  # 1.0 / 0.5
        other: {"episodes": [_flown(1, 120.0, 60.0, success=False)]}}}
    d = metrics.decomposition(ours, oracle, [cell, other])
    assert d["seeds"] == 2
    assert d["path_efficiency"] == pytest.approx(0.75) and d["speed_ratio"] == pytest.approx(0.75)
    assert d["time_efficiency"] == pytest.approx(0.5)  # 150 / 300 and 50 / 100, not 0.75 x 0.75
    ours["cells"][other]["episodes"][0]["success"] = True
    ours["cells"][other]["episodes"][0]["time_to_goal"] = 60.0  # 0.75 / (2 / 3)
    d = metrics.decomposition(ours, oracle, [cell, other])
    assert d["seeds"] == 3 and d["path_efficiency"] == pytest.approx((0.5 + 1.0 + 0.75) / 3)
    assert d["speed_ratio"] == pytest.approx((1.0 + 0.5 + 2.0 / 3.0) / 3)
    assert metrics.decomposition(ours, oracle, [cell])["seeds"] == 2  # only the cells asked for
    assert metrics.decomposition(ours, oracle, ["moving_obstacles/hard/ideal"]) is None


def test_the_oracle_is_its_own_time_reference_beside_a_published_oracle():
    """A new oracle run is measured against itself (time efficiency 1 on its successes), never against an older
    published oracle's times: those may be from an earlier planner, here 1 s to the goal, which would score it
    near 0."""
    cell = next(c for c in suite.SUITE_V1 if c.name == "obstacles/standard/ideal")
    older = {"cells": {cell.name: {"episodes": [{"seed": cell.first_seed, "success": True, "time_to_goal": 1.0}]}}}
    results = runner.benchmark("oracle", [cell], episodes=1, oracle=older, progress=False)
    summary = results["cells"][cell.name]["summary"]
    assert results["cells"][cell.name]["episodes"][0]["success"]
    assert results["time_efficiency_reference"] == "oracle" and summary["time_efficiency"] == 1.0


def test_rescore_gives_a_run_its_time_efficiency_against_an_oracle_that_came_after_it():
    """A row run before its suite's oracle was published takes its time efficiency from it afterwards: the same
    figures as a run after it (the shipped board's rows, rescored against the shipped oracle, are unchanged), the
    oracle's time over the policy's on a success, 0 on a failure, and none without an oracle."""
    board = read_board(board_path(suite.SUITES["auv"]))
    oracle = board["policies"]["oracle"]
    for name in ("planner-learned", "map-replan", "bug"):
        entry = board["policies"][name]
        assert json.dumps(runner.rescore(entry, oracle)) == json.dumps(entry)
    bare = runner.rescore(board["policies"]["bug"], None)
    assert bare["time_efficiency_reference"] is None
    assert all(c["summary"]["time_efficiency"] is None for c in bare["cells"].values())
    real = board["policies"]["bug"]["cells"]["tunnel/hard/ideal"]["episodes"][0]
    cell = {"task": "tunnel", "tier": "hard", "water": "ideal", "episodes": [
        {**real, "seed": 1, "success": True, "time_to_goal": 20.0, "outcome": "goal"},
        {**real, "seed": 2, "success": False, "time_to_goal": None, "outcome": "collision"}]}
    mine = {"policy": "mine", "cells": {"tunnel/hard/ideal": cell}}
    theirs = {"policy": "oracle", "cells": {"tunnel/hard/ideal": {"episodes": [
        {"seed": 1, "success": True, "time_to_goal": 10.0}, {"seed": 2, "success": True, "time_to_goal": 12.0}]}}}
    summary = runner.rescore(mine, theirs)["cells"]["tunnel/hard/ideal"]["summary"]
    assert summary["time_efficiency"] == pytest.approx((10.0 / 20.0 + 0.0) / 2)
    assert summary["time_efficiency_episodes"] == 2
