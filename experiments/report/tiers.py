"""The benchmark section (issue 30): suite v1's cells, every published policy, the ablation and the targets.

The figures are those of the published leaderboard (`auv_mj/benchmark/data/leaderboard.json`, made by `auv-mj benchmark
--policy P --publish`, one run per policy); this section lays them out per cell and checks the issue's targets on
them, so that regenerating it costs nothing and re-measuring is one command per policy (printed below the table).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from auv_mj.benchmark.leaderboard import LEADERBOARD
from auv_mj.benchmark.metrics import bootstrap_mean, decomposition, exact_mcnemar, oracle_times, paired_efficiency
from auv_mj.benchmark.suite import ORACLE, SUITE_V1, TIERS, WATERS
from experiments.report.common import fmt
from experiments.report.registry import ReportSettings, section

LEARNED = "planner-general"
"""The learned planner the targets are about."""
ABLATION = "planner-general-zeroed"
"""The same system with its learned output zeroed."""
COMPETITORS = ("map-replan", "los-fast", "los-avoid", "bug")
"""The non-oracle classical planners it must match in success and beat in time efficiency on the hard tier."""
SPEED_BASELINE = "los-fast"
"""The standard tier's time target is against this one."""
HARD_SUCCESS, HARD_COLLISIONS, OCEAN_SUCCESS = 0.95, 0.01, 0.90
"""Hard tier: success floor and collision ceiling in ideal water; success floor in ocean water."""
STANDARD_SUCCESS, STANDARD_TIME = 0.99, 0.95
"""Standard tier: success floor, and mean time at most this fraction of SPEED_BASELINE's."""
ORDER = (ORACLE, LEARNED, ABLATION, "planner-route", "two-layer-general", "planner-map", *COMPETITORS)
"""The order of the table's rows within a cell (policies not published are left out, others follow)."""


def _row(cell: str, name: str, s: dict) -> str:
    outcomes = s.get("outcomes", {})
    low, high = s.get("success_ci95", [None, None])
    clearance = f"{fmt(s.get('min_clearance'), 1)} / {fmt(s.get('median_min_clearance'), 1)}"
    return (f"| {cell} | `{name}` | {s['episodes']} | {fmt(s['success_rate'], 2)} [{fmt(low, 2)}, {fmt(high, 2)}] | "
            f"{outcomes.get('collision', 0)} | {outcomes.get('timeout', 0)} | {fmt(s.get('time_to_goal'), 0)} | "
            f"{fmt(s.get('time_efficiency'), 2)} | {clearance} |")


def _interval(mean: float, low: float, high: float) -> str:
    """A paired difference as the report writes it: mean [95 % interval]."""
    return f"{mean:+.3f} [{low:+.3f}, {high:+.3f}]"


def ahead(board: dict, cell: str, other: str) -> tuple[bool, str]:
    """Whether LEARNED's time efficiency on `cell` is higher than `other`'s, and how that was judged: paired by seed
    where both entries keep their episodes and the oracle is published (the 95 % bootstrap interval of the mean
    difference above 0), else on the point estimates."""
    ours, theirs = board[LEARNED], board[other]
    references = oracle_times(board.get(ORACLE))
    d = paired_efficiency(ours, theirs, references, [cell]) if references else None
    if d is None or d.size == 0:
        a = ours["cells"][cell]["summary"].get("time_efficiency") or 0.0
        b = theirs["cells"][cell]["summary"].get("time_efficiency") or 0.0
        return a > b, f"{other} {fmt(b, 2)} (unpaired)"
    mean, low, high = bootstrap_mean(d)
    return low > 0, f"{other} {_interval(mean, low, high)}"


def _oracle_ratio(reference: dict | None, base: dict) -> str:
    """The oracle's own mean time over SPEED_BASELINE's on a cell, as a clause of the standard tier's verdict.

    The oracle searches the true map (inflated by hull plus d_s) and flies it at the top speed, so a ratio above
    STANDARD_TIME says that the target asks for less time than the planner that knows the whole map takes. It is
    not a hard bound: the grid, the inflation and the movers' unknown future leave the oracle some slack."""
    if not reference or not reference.get("time_to_goal") or not base.get("time_to_goal"):
        return ""
    return f"; the oracle's own: {fmt(reference['time_to_goal'] / base['time_to_goal'], 3)} x"


def verdicts(board: dict) -> list[str]:
    """The issue's targets for LEARNED, one line per cell it applies to: what was measured and met / NOT met.
    "A higher time efficiency" is judged paired by seed (`ahead`): a difference inside the noise is not higher."""
    out = []
    for cell in SUITE_V1:
        get = {name: r["cells"][cell.name]["summary"] for name, r in board.items() if cell.name in r["cells"]}
        ours = get.get(LEARNED)
        if ours is None:
            continue
        success, efficiency = ours["success_rate"], ours.get("time_efficiency") or 0.0
        if cell.tier == "hard" and cell.water == "ideal":
            others = {n: get[n] for n in COMPETITORS if n in get}
            judged = {n: ahead(board, cell.name, n) for n in others}
            met = (success >= HARD_SUCCESS and ours["collision_rate"] <= HARD_COLLISIONS
                   and all(success >= o["success_rate"] for o in others.values())
                   and all(higher for higher, _ in judged.values()))
            against = ", ".join(f"{n} {fmt(o['success_rate'], 2)} / {fmt(o.get('time_efficiency'), 2)}"
                                for n, o in others.items())
            text = (f"success {fmt(success, 2)} (>= {HARD_SUCCESS} and each classical planner's), time efficiency "
                    f"{fmt(efficiency, 2)} (above each; paired difference, 95 % bootstrap: "
                    f"{', '.join(how for _, how in judged.values())}), collisions {fmt(ours['collision_rate'], 3)} "
                    f"(<= {HARD_COLLISIONS}); classical success / efficiency: {against}")
        elif cell.tier == "hard":
            met, text = success >= OCEAN_SUCCESS, f"success {fmt(success, 2)} (>= {OCEAN_SUCCESS})"
        elif cell.water == "ideal" and SPEED_BASELINE in get:
            base = get[SPEED_BASELINE]
            ratio = (ours["time_to_goal"] / base["time_to_goal"]) if ours.get("time_to_goal") and \
                base.get("time_to_goal") else None
            met = (success >= STANDARD_SUCCESS and success >= base["success_rate"]
                   and ratio is not None and ratio <= STANDARD_TIME)
            text = (f"success {fmt(success, 2)} (>= {STANDARD_SUCCESS} and {SPEED_BASELINE}'s "
                    f"{fmt(base['success_rate'], 2)}), mean time {fmt(ratio, 3)} x {SPEED_BASELINE}'s (<= "
                    f"{STANDARD_TIME}{_oracle_ratio(get.get(ORACLE), base)})")
        else:
            continue
        out.append(f"- {cell.name}: {text}: **{'met' if met else 'NOT met'}**")
    return out


def goals_apart(a: dict, b: dict, cells: Sequence[str]) -> tuple[int, int] | None:
    """Seeds on which only A reached the goal, and only B, over `cells` (the discordant pairs of a paired success
    comparison); None where either entry does not keep its episodes."""
    only_a = only_b = 0
    for name in cells:
        ours = {e["seed"]: e["success"] for e in a["cells"].get(name, {}).get("episodes", [])}
        theirs = {e["seed"]: e["success"] for e in b["cells"].get(name, {}).get("episodes", [])}
        if not ours or not theirs:
            return None
        only_a += sum(ours[k] and not theirs[k] for k in ours if k in theirs)
        only_b += sum(theirs[k] and not ours[k] for k in ours if k in theirs)
    return only_a, only_b


def _paired(board: dict, cells: Sequence[str]) -> str:
    """LEARNED minus ABLATION over `cells`: paired time efficiency (mean [95 % bootstrap]) and goals apart, with the
    exact McNemar p-value of the difference in success."""
    references = oracle_times(board.get(ORACLE))
    d = paired_efficiency(board[LEARNED], board[ABLATION], references, cells) if references else None
    apart = goals_apart(board[LEARNED], board[ABLATION], cells)
    if d is None or d.size == 0:
        efficiency = "n/a"
    else:
        efficiency = f"{_interval(*bootstrap_mean(d))} ({d.size})"
    goals = "n/a" if apart is None else f"{apart[0]} / {apart[1]} (exact McNemar p {exact_mcnemar(*apart):.2f})"
    return f"{efficiency} | {goals}"


def ablation(board: dict) -> list[str]:
    """LEARNED against ABLATION per cell, then pooled per tier and water and over the suite: what the learned output
    adds in success and time efficiency, paired by seed where the episodes are kept."""
    if LEARNED not in board or ABLATION not in board:
        return [f"(`{ABLATION}` is not published: no ablation)"]
    lines = ["| cell | success: learned / zeroed | time efficiency: learned / zeroed | mean time [s]: learned / "
             "zeroed | time efficiency, learned minus zeroed, paired [95 % bootstrap] (seeds) | goals only learned "
             "/ only zeroed |", "| --- | --- | --- | --- | --- | --- |"]
    both = []
    for cell in SUITE_V1:
        pair = [board[n]["cells"].get(cell.name, {}).get("summary") for n in (LEARNED, ABLATION)]
        if None in pair:
            continue
        both.append(cell)
        a, b = pair
        lines.append(f"| {cell.name} | {fmt(a['success_rate'], 2)} / {fmt(b['success_rate'], 2)} | "
                     f"{fmt(a.get('time_efficiency'), 2)} / {fmt(b.get('time_efficiency'), 2)} | "
                     f"{fmt(a.get('time_to_goal'), 0)} / {fmt(b.get('time_to_goal'), 0)} | "
                     f"{_paired(board, [cell.name])} |")
    groups = {}
    for cell in both:
        groups.setdefault(f"{cell.tier}, {cell.water}", []).append(cell.name)
    if len(both) > 1:
        groups["all"] = [cell.name for cell in both]
    for label, names in groups.items():
        lines.append(f"| pooled: {label} | | | | {_paired(board, names)} |")
    return lines


def time_split(board: dict, names: Sequence[str] | None = None) -> list[str]:
    """Where each published policy's time goes against ORACLE, per tier and water (the three sets pooled): mean path
    efficiency / mean speed ratio (`auv_mj.benchmark.metrics.decomposition`) over the seeds both reached the goal on."""
    if ORACLE not in board:
        return [f"(`{ORACLE}` is not published: no decomposition)"]
    names = [n for n in (names or board) if n != ORACLE]
    groups = [(tier, water) for tier in TIERS for water in WATERS]
    lines = ["| policy | " + " | ".join(f"{tier}, {water}" for tier, water in groups) + " |",
             "| --- " * (len(groups) + 1) + "|"]
    for name in names:
        row = []
        for tier, water in groups:
            d = decomposition(board[name], board[ORACLE],
                              [c.name for c in SUITE_V1 if c.tier == tier and c.water == water])
            row.append("n/a" if d is None else
                       f"{fmt(d['path_efficiency'], 3)} / {fmt(d['speed_ratio'], 3)} ({d['seeds']})")
        lines.append(f"| `{name}` | " + " | ".join(row) + " |")
    return lines


def tiers(lines: list[str], leaderboard: Path = LEADERBOARD) -> None:
    """The section's Markdown (module docstring)."""
    board = json.loads(Path(leaderboard).read_text())["policies"]
    names = [n for n in ORDER if n in board] + [n for n in board if n not in ORDER]
    episodes = sorted({c["summary"].get("episodes", 0) for r in board.values() for c in r["cells"].values()})
    lines += ["## Benchmark: the standard and hard tiers (suite v1)", "",
              f"Every published policy on every cell of suite v1 (task / tier / water; `auv_mj/cli/benchmark.py`), "
              f"held-out test seeds, episodes per cell: {episodes}. Time efficiency is the oracle's time on the same "
              "seed over the policy's, capped at 1, 0 on a failure (SPL); clearances are the least distance from "
              "hull to any geom over an episode, least and median over the cell.", "",
              "| cell | policy | episodes | success [95 % Wilson] | collisions | timeouts | mean time [s] | "
              "time efficiency | least / median clearance [m] |", "| --- " * 9 + "|"]
    for cell in SUITE_V1:
        for name in names:
            summary = board[name]["cells"].get(cell.name, {}).get("summary")
            if summary is not None:
                lines.append(_row(cell.name, name, summary))
    lines += ["", f"### Where the time goes: path efficiency / speed ratio against `{ORACLE}`", "",
              "On a seed both reached the goal on, time efficiency (uncapped) = path efficiency (the oracle's path "
              "length over the policy's) x speed ratio (the policy's mean speed, path length / time, over the "
              "oracle's). A speed ratio near 1 means the policy flies as fast as the oracle, so the time it loses "
              "is path length; `map-replan` runs the oracle's search and follower, so its lost length is what it "
              "did not yet know of the map. Means over those seeds of the three sets (obstacles, "
              "moving_obstacles, tunnel) per tier and water, paired by seed (seeds in brackets).", "",
              *time_split(board, names), "",
              f"### Ablation: `{LEARNED}` against its learned output zeroed (`{ABLATION}`)", "", *ablation(board),
              "", f"### Targets (`{LEARNED}`)", "", *verdicts(board), "",
              "Commands: `auv-mj benchmark --policy P --episodes N --workers 2 --out runs/benchmark/P --publish` for "
              "each P above (the oracle first: it is the reference of time efficiency), then `auv-mj reproduce "
              "--sections benchmark`.", ""]


@section("benchmark")
def benchmark_section(lines: list[str], settings: ReportSettings) -> None:
    """Suite v1 from the published leaderboard."""
    tiers(lines)
