"""The report's benchmark section (issue 30): its targets are checked on the figures, not assumed."""

from __future__ import annotations

import json

import numpy as np

from experiments.report import tiers


def _summary(success: float, efficiency: float, time: float, collisions: float = 0.0) -> dict:
    return {"episodes": 100, "success_rate": success, "success_ci95": [success - 0.05, min(1.0, success + 0.05)],
            "collision_rate": collisions, "outcomes": {"collision": int(100 * collisions)}, "time_to_goal": time,
            "time_efficiency": efficiency, "min_clearance": 1.0, "median_min_clearance": 9.0}


def _board(cells: dict[str, dict[str, dict]]) -> dict:
    """{policy: {cell: summary}} -> the leaderboard's "policies" shape."""
    return {name: {"episodes_per_cell": 100, "cells": {c: {"summary": s} for c, s in by_cell.items()}}
            for name, by_cell in cells.items()}


HARD = "obstacles/hard/ideal"
STANDARD = "obstacles/standard/ideal"


def test_hard_tier_target_needs_success_and_a_higher_efficiency_than_every_classical_planner():
    board = _board({"planner-general": {HARD: _summary(0.99, 0.90, 250)},
                    "map-replan": {HARD: _summary(0.99, 0.88, 255)}, "los-fast": {HARD: _summary(0.6, 0.5, 280)}})
    (line,) = tiers.verdicts(board)
    assert line.startswith(f"- {HARD}:") and line.endswith("**met**")
    board["map-replan"]["cells"][HARD]["summary"] = _summary(0.99, 0.91, 245)  # now more efficient than ours
    assert tiers.verdicts(board)[0].endswith("**NOT met**")
    board["map-replan"]["cells"][HARD]["summary"] = _summary(0.99, 0.88, 255)
    board["planner-general"]["cells"][HARD]["summary"] = _summary(0.99, 0.90, 250, collisions=0.02)
    assert tiers.verdicts(board)[0].endswith("**NOT met**")


def _with_episodes(times) -> dict:
    """A hard cell's entry with its episodes (seeds 0..n-1 at these times, all reached)."""
    episodes = [{"seed": k, "success": True, "time_to_goal": float(t)} for k, t in enumerate(times)]
    return {"summary": _summary(1.0, 0.0, float(np.mean(times))), "episodes": episodes}


def test_a_higher_efficiency_is_judged_paired_by_seed():
    """Ahead of a planner by a margin inside the seed-to-seed noise is not "higher": the paired 95 % bootstrap
    interval of the difference must clear 0 (`tiers.ahead`)."""
    rng = np.random.default_rng(0)
    oracle = 200.0 + 50.0 * rng.random(60)
    theirs = oracle * (1.15 + 0.1 * rng.random(60))
    noisy = theirs * (1.0 + 0.08 * rng.standard_normal(60))  # now faster, now slower, by 8 %
    board = {name: {"cells": {HARD: _with_episodes(times)}}
             for name, times in (("oracle", oracle), ("map-replan", theirs), ("planner-general", noisy))}
    higher, how = tiers.ahead(board, HARD, "map-replan")
    assert not higher and "[-0." in how and how.split("]")[0].split(", ")[1].startswith("+")
    board["planner-general"]["cells"][HARD] = _with_episodes(theirs * 0.95)  # 5 % faster on every seed
    higher, how = tiers.ahead(board, HARD, "map-replan")
    assert higher and how.startswith("map-replan +0.0")


def test_standard_tier_target_is_a_time_ratio_to_los_fast():
    board = _board({"planner-general": {STANDARD: _summary(1.0, 0.99, 94)},
                    "los-fast": {STANDARD: _summary(1.0, 0.95, 100)}})
    (line,) = tiers.verdicts(board)
    assert "0.940 x los-fast" in line and line.endswith("**met**")
    board["planner-general"]["cells"][STANDARD]["summary"] = _summary(1.0, 0.99, 96)
    assert tiers.verdicts(board)[0].endswith("**NOT met**")


def test_standard_tier_verdict_gives_the_oracles_own_time_ratio():
    """The target is a time ratio to los-fast; the oracle's own ratio beside it shows where it lies below the
    reference (only when the oracle is published on the cell)."""
    board = _board({"planner-general": {STANDARD: _summary(1.0, 0.99, 98)},
                    "los-fast": {STANDARD: _summary(1.0, 0.95, 100)}})
    assert "oracle" not in tiers.verdicts(board)[0]
    board["oracle"] = _board({"oracle": {STANDARD: _summary(1.0, 1.0, 97)}})["oracle"]
    (line,) = tiers.verdicts(board)
    assert "(<= 0.95; the oracle's own: 0.970 x)" in line and line.endswith("**NOT met**")


def test_section_lays_out_every_published_cell_and_the_ablation(tmp_path):
    board = _board({"oracle": {HARD: _summary(1.0, 1.0, 220)}, "planner-general": {HARD: _summary(0.99, 0.9, 250)},
                    "planner-general-zeroed": {HARD: _summary(0.97, 0.5, 420)}})
    path = tmp_path / "leaderboard.json"
    path.write_text(json.dumps({"policies": board}))
    lines: list[str] = []
    tiers.tiers(lines, path)
    text = "\n".join(lines)
    assert text.count(f"| {HARD} | `") == 3  # a row per published policy
    assert f"| {HARD} | 0.99 / 0.97 | 0.90 / 0.50 | 250 / 420 | n/a | n/a |" in text  # no episodes kept: unpaired


def test_the_ablation_is_paired_by_seed_per_cell_and_pooled():
    """The ablation row pairs the learned system with its zeroed self seed by seed: the mean difference of time
    efficiency with its bootstrap interval, and the goals only one of them reached, per cell and pooled."""
    oracle = np.full(10, 100.0)
    learned = np.full(10, 125.0)  # 0.80 on every seed
    zeroed = np.full(10, 100.0)  # 1.00 on every seed
    board = {"oracle": {"cells": {HARD: _with_episodes(oracle), STANDARD: _with_episodes(oracle)}},
             "planner-general": {"cells": {HARD: _with_episodes(learned), STANDARD: _with_episodes(oracle)}},
             "planner-general-zeroed": {"cells": {HARD: _with_episodes(zeroed), STANDARD: _with_episodes(oracle)}}}
    board["planner-general-zeroed"]["cells"][HARD]["episodes"][3]["success"] = False  # zeroed fails one seed
    lines = tiers.ablation(board)
    (hard,) = [line for line in lines if line.startswith(f"| {HARD} |")]
    # nine seeds at 0.80 - 1.00 and one at 0.80 - 0: the mean is (9 * -0.2 + 0.8) / 10 = -0.1
    assert "| -0.100 [" in hard and hard.endswith("(10) | 1 / 0 (exact McNemar p 1.00) |")
    (standard,) = [line for line in lines if line.startswith(f"| {STANDARD} |")]
    assert "+0.000 [+0.000, +0.000] (10) | 0 / 0 (exact McNemar p 1.00) |" in standard
    (pooled,) = [line for line in lines if line.startswith("| pooled: all |")]
    assert "-0.050 [" in pooled and pooled.endswith("(20) | 1 / 0 (exact McNemar p 1.00) |")
    assert tiers.goals_apart(board["planner-general"], {"cells": {HARD: {"summary": {}}}}, [HARD]) is None


def test_the_exact_mcnemar_p_value_is_the_two_sided_binomial_test_of_the_discordant_pairs():
    """Checked against scipy's binomial test, an independent implementation, and the closed forms at the edges."""
    from scipy.stats import binomtest

    from auv_mj.benchmark.metrics import exact_mcnemar

    for only_a, only_b in [(7, 2), (2, 7), (11, 6), (0, 5), (10, 0), (3, 3), (1, 0), (25, 12)]:
        expected = binomtest(only_a, only_a + only_b, 0.5).pvalue
        assert abs(exact_mcnemar(only_a, only_b) - expected) < 1e-12
    assert exact_mcnemar(0, 0) == 1.0  # no discordant pair: no evidence either way
    assert abs(exact_mcnemar(6, 0) - 2 / 2 ** 6) < 1e-15  # the one most extreme outcome on each side


def _flown(times_and_lengths, fail=()) -> dict:
    """A cell entry with its episodes: seed k flew lengths[k] metres in times[k] seconds (reached, but for `fail`)."""
    episodes = [{"seed": k, "success": k not in fail, "path_length": length, "time_to_goal": time}
                for k, (length, time) in enumerate(times_and_lengths)]
    return {"summary": _summary(1.0, 1.0, 100.0), "episodes": episodes}


def test_where_the_time_goes_splits_time_efficiency_per_tier_and_water(tmp_path):
    """Path efficiency / speed ratio (seeds) per tier and water, the three sets pooled, for every policy but the
    oracle: a planner at the oracle's speed on longer paths reads as a speed ratio of 1 and its path loss."""
    oracle = {"cells": {HARD: _flown([(400.0, 200.0), (300.0, 150.0)]),
                        "tunnel/hard/ideal": _flown([(100.0, 100.0)]),
                        STANDARD: _flown([(200.0, 100.0)])}}
    board = {"oracle": oracle,
             "planner-general": {"cells": {HARD: _flown([(500.0, 250.0), (600.0, 300.0)]),  # 0.8 and 0.5, at 1.0
                                           "tunnel/hard/ideal": _flown([(125.0, 125.0)]),  # 0.8 at 1.0
                                           STANDARD: _flown([(200.0, 200.0)])}},  # 1.0 at half the speed
             "los-avoid": {"cells": {HARD: _flown([(400.0, 400.0), (1.0, 1.0)], fail={1})}}}
    lines = tiers.time_split(board)
    assert lines[0] == "| policy | standard, ideal | standard, ocean | hard, ideal | hard, ocean |"
    assert lines[2] == "| `planner-general` | 1.000 / 0.500 (1) | n/a | 0.700 / 1.000 (3) | n/a |"
    assert lines[3] == "| `los-avoid` | n/a | n/a | 1.000 / 0.500 (1) | n/a |"
    assert not any("`oracle`" in line for line in lines)
    assert tiers.time_split({"los-avoid": board["los-avoid"]}) == ["(`oracle` is not published: no decomposition)"]
    path = tmp_path / "leaderboard.json"
    path.write_text(json.dumps({"policies": board}))
    text: list[str] = []
    tiers.tiers(text, path)
    start = text.index("### Where the time goes: path efficiency / speed ratio against `oracle`")
    assert "path efficiency" in text[start + 2] and "x speed ratio" in text[start + 2]
    assert text[start + 4:start + 8] == lines
