"""`auv-mj benchmark`: the versioned held-out suite of planning cells in one command (`auv_mj.benchmark`).

    auv-mj benchmark [--domain auv|auv3d [--suite-version N]] --policy P [--task obstacles,tunnel]
                     [--tier standard,hard] [--water ideal,ocean] [--episodes N] [--workers N | --ray ADDRESS] -o DIR

The suite (`auv_mj.benchmark.suite.SUITE_V1`; with `--domain auv3d` the 6-DOF vehicle's `SUITE_3D_V3`, its own
suite with its own fingerprint and leaderboard; `--suite-version 1` or `2` runs an earlier version's cells against
its board) is one table of cells: a task with its options (a procedural arena of a tier in a water, and in
suite 3d v3 the execution layer) on a block of held-out TEST seeds. Episodes run through the one episode loop and metric
definitions of `auv-mj eval` (`auv_mj.episode`, `auv_mj.benchmark.metrics`); changing what the suite measures is a
new version with its own fingerprint.

Per cell (units in brackets): success with its 95 % Wilson interval, the outcome counts (collisions, left_map,
timeouts), mean time to the goal over successes [s], the least and the median of the episodes' least clearances
[m], and time efficiency against `oracle` (oracle time / own time on a success, capped at 1 as SPL caps path
ratios; 0 on a failure; SPL, Anderson et al. 2018) over the seeds where the oracle's stored result reached the goal
(`--oracle FILE`, by default the `oracle` entry of the leaderboard). Figures that are undefined are null.

It writes into DIR: `results.json` (strict JSON: the suite name, version and fingerprint, every cell's summary
and episodes), `episodes.csv` (one row per episode: cell, seed, outcome, duration, path length, least clearance,
return, ...), `leaderboard_row.md` (the policy's Markdown row) and `comparison.md` (the row beside the shipped
policies' results in the shipped leaderboard, `auv_mj/benchmark/data/leaderboard.json`, over the same cells; the
run's row, marked "(this run)", comes first and the policy's own published entry, if it has one, right under it,
marked "(published)").
Resuming. Each episode is kept as it ends in `DIR/journal.jsonl` (`auv_mj.benchmark.journal`); Ctrl-C (or a kill)
loses none that finished, and the same command run again runs only the others and writes what the uninterrupted
run would have (with any --workers). The journal goes once the outputs are written; one of another run (other
policy, cells, episodes, max steps or suite version) is refused unless `--force`.
`--publish` adds the run to that file (or to `--leaderboard`) and regenerates the `leaderboard.md` beside it; that
is how the shipped results are made.

Speed. The forkserver that spawns the workers starts importing while the cells are checked
(`auv_mj.benchmark.runner` says the rest).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from auv_mj.benchmark.journal import JOURNAL, JournalMismatch
from auv_mj.benchmark.leaderboard import (
    ROW_HEADER,
    board_path,
    comparison_table,
    markdown_row,
    oracle_results,
    publish,
    read_board,
    read_json,
)
from auv_mj.benchmark.runner import benchmark, cell_task_kwargs
from auv_mj.benchmark.suite import EPISODES, ORACLE, SEED_BLOCK, SUITES, TIERS, VERSIONS, WATERS, suite_for
from auv_mj.cli.evaluate import interrupted, write_episodes_csv
from auv_mj.cli.options import (
    MAX_PROCESSES,
    bounded_int,
    check_output,
    check_output_folder,
    check_ray,
    positive_int,
    usage_error,
)
from auv_mj.inputs import did_you_mean
from auv_mj.zoo import registry as policies


def suite_tasks(suite) -> tuple[str, ...]:
    """The tasks of a suite's cells, in the suite's order."""
    return tuple(dict.fromkeys(cell.task for cell in suite.cells))


SUITE_TASKS = tuple(dict.fromkeys(task for suite in SUITES.values() for task in suite_tasks(suite)))
"""The tasks `--task` takes: those of every domain's suite (the chosen domain's are checked in `run`)."""
EPISODES_CSV = "episodes.csv"
"""The per-episode table in --out: one row per episode (cell, seed, outcome, duration, path length, ...)."""


def _choices(values: tuple[str, ...], option: str):
    def parse(text: str) -> tuple[str, ...]:
        chosen = tuple(dict.fromkeys(v.strip() for v in text.split(",") if v.strip()))
        wrong = [v for v in chosen if v not in values]
        if wrong or not chosen:
            hint = did_you_mean(wrong[0], values) if wrong else ""
            raise argparse.ArgumentTypeError(f"comma-separated values of {', '.join(values)}, got {text!r}{hint}")
        return chosen

    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj benchmark`."""
    parser.add_argument("--domain", choices=list(SUITES), default="auv", help="the suite: auv (suite v1, the planar "
                        "vehicle, the default) or auv3d (the 3-D suite of the 6-DOF vehicle)")
    parser.add_argument("--suite-version", type=positive_int, default=None, metavar="N",
                        help="the domain's suite of this version and its board (default: the newest; "
                             + "; ".join(f"{d}: {', '.join(str(s.version) for s in v)}" for d, v in VERSIONS.items())
                             + ")")
    parser.add_argument("--policy", required=True, help=policies.policy_help())
    parser.add_argument("--task", type=_choices(SUITE_TASKS, "--task"), default=None, metavar="TASKS",
                        help="only the cells of these tasks, comma-separated: "
                             + "; ".join(f"{d}: {','.join(suite_tasks(SUITES[d]))}" for d in SUITES)
                             + " (default: every task of the suite)")
    parser.add_argument("--tier", type=_choices(TIERS, "--tier"), default=TIERS, metavar="TIERS",
                        help=f"only the cells of these tiers, comma-separated (default: {','.join(TIERS)})")
    parser.add_argument("--water", type=_choices(WATERS, "--water"), default=WATERS, metavar="WATERS",
                        help=f"only the cells of these waters, comma-separated (default: {','.join(WATERS)})")
    parser.add_argument("--episodes", type=bounded_int(1, SEED_BLOCK), default=None,
                        help=f"episodes per cell (default: the suite's, {EPISODES}); fewer are the first seeds")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="cut episodes after this many steps")
    parser.add_argument("--workers", type=bounded_int(1, MAX_PROCESSES), default=1,
                        help="run the episodes in this many local processes")
    parser.add_argument("--ray", default=None, metavar="ADDRESS", help="run the episodes as Ray tasks at ADDRESS "
                        "('local' starts Ray here, 'auto' or HOST:PORT joins a cluster)")
    parser.add_argument("-o", "--out", type=Path, required=True, metavar="DIR",
                        help="folder for results.json, episodes.csv, leaderboard_row.md and comparison.md "
                             f"({JOURNAL} keeps the finished episodes until then)")
    parser.add_argument("--oracle", type=Path, default=None, help="an oracle results.json for time efficiency "
                        f"(default: the `{ORACLE}` entry of the leaderboard)")
    parser.add_argument("--leaderboard", type=Path, default=None, help="the leaderboard to compare with and "
                        "publish to (default: the domain's shipped one)")
    parser.add_argument("--publish", action="store_true", help="add this run to --leaderboard and regenerate its "
                        "Markdown beside it")
    parser.add_argument("--record-failures", type=Path, default=None, metavar="DIR",
                        help="write an MP4 and a trajectory PNG of every episode that did not reach the goal here, "
                             "a folder per cell")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--force", action="store_true", help=f"start afresh where --out holds a {JOURNAL} of "
                        "another run (the same command resumes its own)")


def _start_workers_early(workers: int) -> None:
    """Starts the forkserver that `distributed` spawns its workers from, so that it imports this module while the
    cells are checked here (one import of torch and MuJoCo less on the way to the first episode)."""
    import multiprocessing
    from multiprocessing import forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload(["auv_mj.benchmark.runner"])
    forkserver.ensure_running()


def run(args: argparse.Namespace) -> int:
    """Checks the outputs and every cell, runs the suite, writes the results and tables. Ctrl-C ends it in one line
    saying what was kept (`auv_mj.cli.evaluate.interrupted`)."""
    try:
        return _run(args)
    except KeyboardInterrupt as error:
        return interrupted(args, error, args.out / JOURNAL)


def _run(args: argparse.Namespace) -> int:
    try:
        suite = suite_for(args.domain, args.suite_version)
    except ValueError as e:
        usage_error(args, f"--suite-version: {e}")
    if args.leaderboard is None:
        args.leaderboard = board_path(suite)
    out = check_output_folder(args, args.out, "--out")
    if args.publish:
        check_output(args, args.leaderboard, "--leaderboard")
    check_output_folder(args, args.record_failures, "--record-failures")
    check_ray(args)
    if args.task is not None:
        own = suite_tasks(suite)
        wrong = [task for task in args.task if task not in own]
        if wrong:
            other = next((d for d, other in SUITES.items() if wrong[0] in suite_tasks(other)), None)
            where = f" ({wrong[0]} is in --domain {other})" if other else ""
            usage_error(args, f"--task {wrong[0]} has no cell in the {args.domain} suite{did_you_mean(wrong[0], own)}; "
                              f"its tasks: {', '.join(own)}{where}")
    cells = [c for c in suite.cells if c.tier in args.tier and c.water in args.water
             and (args.task is None or c.task in args.task)]
    if not cells:
        usage_error(args, "no cell of the suite has the --task, --tier and --water asked for")
    if args.workers > 1 and args.ray is None:
        _start_workers_early(args.workers)
    try:
        board = read_board(args.leaderboard)
        oracle = read_json(args.oracle, "--oracle") if args.oracle else oracle_results(board)
    except ValueError as e:
        usage_error(args, str(e))
    if oracle is not None and (oracle.get("suite_version") != suite.version
                               or oracle.get("suite", SUITES["auv"].name) != suite.name):
        usage_error(args, f"--oracle results are of {oracle.get('suite', SUITES['auv'].name)} version "
                    f"{oracle.get('suite_version')}, not {suite.name} version {suite.version}")
    try:
        for cell in {(c.task, c.tier, c.water): c for c in cells}.values():  # refuse before the first episode
            policies.env_and_policy(args.policy, cell.task, cell.first_seed, cell_task_kwargs(args.policy, cell))
    except (ValueError, FileNotFoundError) as e:
        usage_error(args, str(e))
    try:
        results = benchmark(args.policy, cells, args.episodes, args.max_steps, oracle=oracle, workers=args.workers,
                            ray_address=args.ray, progress=not args.no_progress, suite=suite, journal=out / JOURNAL,
                            force=args.force)
    except JournalMismatch as e:
        usage_error(args, str(e))
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=1, allow_nan=False))
    row = markdown_row(results)
    (out / "leaderboard_row.md").write_text(ROW_HEADER + "\n" + row + "\n")
    write_episodes_csv([{"cell": name, **e} for name, cell in results["cells"].items() for e in cell["episodes"]],
                       out / EPISODES_CSV, first=("cell",))
    comparison = comparison_table(results, board)
    (out / "comparison.md").write_text(comparison)
    print(comparison)
    if args.publish:
        publish(results, args.leaderboard)
        print(f"published to {args.leaderboard}")
    if args.record_failures is not None:
        from auv_mj.benchmark.failures import record_failures

        for cell in cells:
            episodes = [(cell.task, e["seed"], e["outcome"]) for e in results["cells"][cell.name]["episodes"]]
            record_failures(args.policy, episodes, args.record_failures / cell.name.replace("/", "-"),
                            cell_task_kwargs(args.policy, cell), args.max_steps)
    print(f"wrote {out / 'results.json'}, {out / EPISODES_CSV}, {out / 'leaderboard_row.md'}, {out / 'comparison.md'}")
    for failure in results.get("failed", []):
        print(f"{args.prog}: episode seed {failure['seed']} of {failure['cell']} failed: {failure['error']}",
              file=sys.stderr)
    if results.get("failed"):
        print(f"{args.prog}: the finished episodes stay in {out / JOURNAL}: the same command runs the failed ones "
              "again", file=sys.stderr)
    else:
        (out / JOURNAL).unlink(missing_ok=True)  # results.json holds every episode now
    return 1 if results.get("failed") else 0
