"""The leaderboard: every published policy's results on a suite, as package data, and its Markdown tables.

`LEADERBOARD` is the shipped board of suite v1 (`auv_mj/benchmark/data/leaderboard.json`, with `leaderboard.md` beside
it), `LEADERBOARD_3D` the current 3-D suite's (suite 3d v3, `leaderboard3d_v3.json`; suite 3d v1's and v2's stay in
`leaderboard3d.json` and `leaderboard3d_v2.json`), made by `auv-mj benchmark [--domain auv3d] --policy P
--publish`; `publish` adds a run to a board at any path the caller gives. A board holds one suite's runs.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

from auv_mj.benchmark.metrics import pooled
from auv_mj.benchmark.suite import EPISODES, ORACLE, SUITES, TIERS, WATERS, Suite, suite_named


def board_path(suite: Suite) -> Path:
    """The shipped leaderboard of `suite` (package data)."""
    return Path(str(resources.files("auv_mj.benchmark.data"))) / suite.board


LEADERBOARD = board_path(SUITES["auv"])
"""The shipped policies' results on suite v1 (package data), made by `auv-mj benchmark --publish`."""
LEADERBOARD_3D = board_path(SUITES["auv3d"])
"""The shipped policies' results on the current 3-D suite, made by `auv-mj benchmark --domain auv3d --publish`."""


def read_board(path: Path = LEADERBOARD) -> dict:
    """The leaderboard at `path` ({} if there is none); ValueError naming the file if it cannot be read."""
    path = Path(path)
    if not path.is_file():
        return {}
    return read_json(path, "leaderboard")


def oracle_results(board: dict | None = None) -> dict | None:
    """The oracle's published results (the reference of time efficiency) in `board` (the shipped one by default)."""
    board = read_board() if board is None else board
    return board.get("policies", {}).get(ORACLE)


def read_json(path: Path, what: str) -> dict:
    """The JSON object in `path`; ValueError naming `what` and the file if it cannot be read."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(f"{what} {path} cannot be read: {e}") from None


ROW_HEADER = ("| policy | suite | episodes | success [95 % CI] | standard | hard | ideal | ocean | collisions | "
              "timeouts | time to goal [s] | time efficiency | least clearance [m] |\n"
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")


def _rate(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def markdown_row(results: dict, names: Sequence[str] | None = None, mark: str = "") -> str:
    """A leaderboard row of a results dict, pooled over the cells `names` (all of its own by default); `mark`
    follows the policy's name."""
    names = list(results["cells"]) if names is None else [n for n in names if n in results["cells"]]
    total = pooled(results, names)
    split = {value: pooled(results, [n for n in names if value in n.split("/")[1:]]) for value in TIERS + WATERS}
    low, high = total["ci95"]
    time = "-" if total["time_to_goal"] is None else f"{total['time_to_goal']:.0f}"
    clearance = "-" if total["min_clearance"] is None else f"{round(total['min_clearance'], 1) + 0.0:.1f}"  # no -0.0
    return (f"| `{results['policy']}`{mark} | {results['suite']} | {total['episodes']} | {_rate(total['success'])} "
            f"[{low:.2f}, {high:.2f}] | " + " | ".join(_rate(split[v]["success"]) for v in TIERS + WATERS) +
            f" | {_rate(total['collision'])} | {_rate(total['timeout'])} | {time} | "
            f"{_rate(total['time_efficiency'])} | {clearance} |")


PUBLISHED_MARK = " (published)"
"""Follows a policy's name in `comparison_table` where its own published row stands beside this run's."""
RUN_MARK = " (this run)"
"""Follows this run's policy name in `comparison_table`."""


def comparison_table(results: dict, board: dict) -> str:
    """This run's row beside every leaderboard entry of the same suite version, over this run's cells. The run comes
    first (marked RUN_MARK) and, where the board holds the same policy, its published entry right under it (marked
    PUBLISHED_MARK), so that a short run reads against the policy's published figures; then the others by success."""
    names = list(results["cells"])
    policy = results["policy"]
    suite = suite_named(results["suite"])
    entries = {name: r for name, r in board.get("policies", {}).items()
               if r.get("suite", suite.name) == suite.name and r.get("suite_version") == results["suite_version"]}
    rows = [markdown_row(results, mark=RUN_MARK)]
    if policy in entries:
        rows.append(markdown_row(entries[policy], names, PUBLISHED_MARK))
    others = sorted((r for name, r in entries.items() if name != policy),
                    key=lambda r: -(pooled(r, names)["success"] or 0.0))
    rows += [markdown_row(r, names) for r in others]
    cells = f"all {len(names)} cells" if len(names) == len(suite.cells) else ", ".join(names)
    note = (f" First this run of `{policy}`, then its published entry over the same cells." if policy in entries
            else "")
    return (f"{suite.name} over {cells}; rates pooled over their episodes, time efficiency against `{ORACLE}`.{note}"
            "\n\n" + ROW_HEADER + "\n" + "\n".join(rows) + "\n")


def leaderboard_markdown(board: dict) -> str:
    """The leaderboard's Markdown (`leaderboard.md`): every published policy over the whole suite."""
    suite = suite_named(board.get("suite", SUITES["auv"].name))
    entries = sorted(board.get("policies", {}).values(), key=lambda r: -(pooled(r, list(r["cells"]))["success"]
                                                                        or 0.0))
    domain = next(d for d, s in SUITES.items() if s is suite)
    command = "auv-mj benchmark" + ("" if domain == "auv" else f" --domain {domain}")
    lines = [f"# Leaderboard, {suite.name} (fingerprint {suite.fingerprint()})", "",
             f"Made by `{command} --policy P --publish` (`auv_mj/benchmark/suite.py` defines the suite). "
             "Episodes: the total over the cells run; rates pooled over them; time efficiency against "
             f"`{ORACLE}` on the same seeds. Episodes per cell in these entries: "
             f"{sorted({c['summary']['episodes'] for r in entries for c in r['cells'].values()})} (the suite's "
             f"default is {EPISODES}).", "", ROW_HEADER]
    lines += [markdown_row(r) for r in entries]
    return "\n".join(lines) + "\n"




def publish(results: dict, path: Path = LEADERBOARD) -> dict:
    """Adds a benchmark run (`runner.benchmark`'s results) to the board at `path` and writes its Markdown beside it
    (`leaderboard.md`); returns the new board. ValueError if the run is of another suite or suite version than the
    board's."""
    suite = suite_named(results.get("suite", SUITES["auv"].name))
    if results.get("suite_version") != suite.version:
        raise ValueError(f"results of suite version {results.get('suite_version')}, the board is {suite.version}")
    path = Path(path)
    board = read_board(path)
    if board and board.get("suite", SUITES["auv"].name) != suite.name:
        raise ValueError(f"results of {suite.name!r}, the board {path} holds {board.get('suite')!r}")
    board = {"suite": suite.name, "suite_version": suite.version, "fingerprint": suite.fingerprint(),
             "policies": {**board.get("policies", {}), results["policy"]: results}}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(board, indent=1, allow_nan=False))
    tmp.replace(path)
    path.with_suffix(".md").write_text(leaderboard_markdown(board))
    return board
