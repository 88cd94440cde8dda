"""`auv-mj eval`: dm_control suite-style evaluation of a policy over seeded episodes of one or more tasks.

Episode i of a task runs with task seed `seed + i` and the policy seeded the same, through the one
episode loop (`auv_mj.episode.EpisodeRecorder`); its metrics are `auv_mj.episode.episode_metrics`.
Per task the summary holds (units in brackets):
- `episodes`; `outcomes`: {goal, collision, left_map, timeout} counts, summing to `episodes`;
- `success_rate`, `collision_rate`, `safety_violation_rate` (entering d_s = 5 m) [fraction of episodes];
- `min_clearance` (least over episodes) and `median_min_clearance` [m], hull to the nearest geom;
- `path_length` [m], `time_to_goal` [s] (mean over successful episodes), `return` and `return_std`;
- tracking tasks: `mae_speed`, `max_speed` [m/s], `mae_heading`, `max_heading` [rad], `mae_cross_track`,
  `max_cross_track` [m], on depth_heading `mae_depth`, `max_depth` [m], and on speed_heading and depth_heading
  `mae_speed_<phase>`, `mae_heading_<phase>` (Table 9). Their episodes end by their schedule, not at a goal:
  `success_rate` and `time_to_goal` are null for them.
The JSON's `records` hold every episode ({task: [rows in seed order]}: seed, outcome, duration, path length,
least clearance, return, ...), written also one row per episode to `NAME_episodes.csv` beside --csv (or --json).
A task whose first two seeds give the same episode bit for bit (a fixed arena in ideal water under a policy that
draws no random number) runs no more: its summary holds that one episode, says `deterministic` and the seeds it
`stands_for`, and the table says so under its row (`auv_mj.benchmark.runner.evaluate`).
A figure that is undefined is null in the JSON (never NaN): `time_to_goal` when no episode succeeded,
clearances on a task without obstacles to measure (speed_heading), tracking errors where the task
reports none. The JSON is strict (any parser reads it); the CSV leaves such cells empty.

`--workers N` runs the episodes in N local processes and `--ray ADDRESS` (or `local`) as Ray tasks on a
cluster (`auv_mj.jobs.distributed`); each episode is seeded as in the serial loop and the summaries are
taken over the episodes in index order, so the JSON is the serial one. An episode that produced no result
(its worker died more than `--retries` times, or it raised) is listed under "failed" by task, episode
index and seed; the summaries cover the finished episodes, and the exit status is 1.

Resuming. With --json or --csv, each episode is kept as it ends in a journal beside them (`NAME_journal.jsonl`,
`auv_mj.benchmark.journal`); Ctrl-C (or a kill) loses none that finished, and the same command run again runs only
the others and writes what the uninterrupted run would have. The journal goes once the outputs are written; one of
another run (other policy, tasks, episodes, seed or options) is refused unless `--force`.

`--record-failures DIR` writes an MP4 and a trajectory PNG of every episode that did not reach the goal
(`auv_mj.benchmark.failures`: each is run again, seeded as before, through the renderer), named
`TASK_seedSEED_OUTCOME`, each episode once; the folder is checked before the first episode.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

from auv_mj.benchmark import failures
from auv_mj.benchmark.journal import Interrupted, JournalMismatch
from auv_mj.benchmark.runner import evaluate
from auv_mj.cli.options import (
    MAX_PROCESSES,
    MAX_RETRIES,
    add_episode_options,
    bounded_int,
    check_output,
    check_output_folder,
    check_ray,
    positive_int,
    task_kwargs,
    usage_error,
)
from auv_mj.episode import CUT
from auv_mj.jobs import distributed
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.zoo import registry as policies

SEED_LIMIT = 2**32 - 1
"""Largest task seed (NumPy's RandomState); episode i of a run uses --seed + i."""


TABLE_COLUMNS = ("success_rate", "collision_rate", "safety_violation_rate", "min_clearance", "path_length",
                 "time_to_goal", "return", "mae_speed", "mae_heading", "mae_depth")
"""The table's columns; a tracking column no task of the table reports (mae_depth outside depth_heading) is left
out. On a tracking task success_rate and time_to_goal read n/a: its episodes end by their schedule.
safety_violation_rate is the share of episodes in which a sonar range fell below the safety distance d_s = 5 m
(`auv_mj.episode.episode_metrics`), as an episode that reached its goal may have done."""
OPTIONAL_COLUMNS = ("mae_depth",)


def table_cell(value, width: int = 15, digits: int = 3) -> str:
    """A right-aligned cell of a plain-text table: n/a for None, a string as it is, a number to `digits`
    (a rounded -0.0, e.g. a clearance of -0.001 m at contact, shows as 0)."""
    if value is None:
        return f"{'n/a':>{width}}"
    if isinstance(value, str):
        return f"{value:>{width}}"
    return f"{round(value, digits) + 0.0:>{width}.{digits}f}"


NONE_SEEN = "none seen"
"""What the tables show for a clearance at its cap, the sonar's range: nothing was within it all episode."""


def shown_clearance(value: float | None) -> float | str | None:
    """A least clearance as the tables show it: the task measures it up to SONAR_RANGE (120 m), so a value at the cap
    (open water) is NONE_SEEN rather than 120 m."""
    return NONE_SEEN if value is not None and value >= SONAR_RANGE else value


def shown_outcomes(summary: dict, results: dict, task: str) -> dict[str, int]:
    """A task's outcome counts as the table shows them: episodes stopped by --max-steps before the task ended them
    count as "cut" rather than "timeout" (their recorded outcome, as the summary counts it)."""
    counts = dict(summary["outcomes"])
    rows = results.get("records", {}).get(task, [])
    cut = sum(bool(row.get("cut")) and row.get("outcome") == "timeout" for row in rows)
    if cut:
        counts["timeout"] = counts.get("timeout", 0) - cut
        counts[CUT] = cut
    return counts


def format_table(results: dict) -> str:
    """A plain-text table of the headline metrics and the outcomes, one row per task."""
    columns = [c for c in TABLE_COLUMNS if c not in OPTIONAL_COLUMNS
               or any(s.get(c) is not None for s in results["tasks"].values())]
    widths = [max(15, len(c) + 2) for c in columns]
    header = f"{'task':<18}" + "".join(f"{c:>{w}}" for c, w in zip(columns, widths, strict=True)) + "   outcomes"
    lines = [f"policy: {results['policy']}   episodes: {results['episodes']}   seed: {results['seed']}",
             header, "-" * len(header)]
    for task, summary in results["tasks"].items():
        cells = "".join(table_cell(shown_clearance(summary.get(c)) if c == "min_clearance" else summary.get(c), w)
                        for c, w in zip(columns, widths, strict=True))
        outcomes = ", ".join(f"{name} {n}" for name, n in shown_outcomes(summary, results, task).items() if n)
        lines.append(f"{task:<18}{cells}   {outcomes}")
    if any(shown_clearance(summary.get("min_clearance")) == NONE_SEEN for summary in results["tasks"].values()):
        lines.append(f"{NONE_SEEN}: nothing within the sonar's {SONAR_RANGE:.0f} m, up to which clearance is measured")
    if any(shown_outcomes(summary, results, task).get(CUT) for task, summary in results["tasks"].items()):
        lines.append(f"{CUT}: stopped by --max-steps before the task ended the episode (recorded as timeout)")
    for task, summary in results["tasks"].items():
        if summary.get("deterministic"):
            lines.append(deterministic_note(task, results["seed"], summary["stands_for"]))
    return "\n".join(lines)


def deterministic_note(task: str, seed: int, stands_for: int) -> str:
    """The line under the table for a task whose episodes are one (`auv_mj.benchmark.runner.evaluate`)."""
    return (f"{task}: deterministic: 1 episode stands for {stands_for} seeds (seeds {seed} and {seed + 1} gave the "
            "same episode step for step, so the seed changes nothing here; a random arena or ocean water varies it)")


EPISODE_CSV_SUFFIX = "_episodes.csv"
"""The per-episode CSV is written beside --csv (or --json): `out.csv` -> `out_episodes.csv`."""


def episodes_csv_path(json_path: Path | None, csv_path: Path | None) -> Path | None:
    """Where the per-episode CSV goes: beside --csv, else beside --json; None without either."""
    beside = csv_path or json_path
    return None if beside is None else beside.with_name(beside.stem + EPISODE_CSV_SUFFIX)


JOURNAL_SUFFIX = "_journal.jsonl"
"""The journal of finished episodes is kept beside --csv (or --json) while the run is unfinished: `out.json` ->
`out_journal.jsonl`."""


def journal_path(json_path: Path | None, csv_path: Path | None) -> Path | None:
    """Where the journal goes: beside --csv, else beside --json; None without either (nothing is kept)."""
    beside = csv_path or json_path
    return None if beside is None else beside.with_name(beside.stem + JOURNAL_SUFFIX)


def interrupted(args: argparse.Namespace, error: KeyboardInterrupt, journal: Path | None) -> int:
    """The one line that ends a run stopped by Ctrl-C: what was kept and how to resume; exit status 130."""
    if isinstance(error, Interrupted) and error.journal is not None:
        print(f"{args.prog}: interrupted: {error.kept} of {error.total} episodes kept in {error.journal}; run the "
              "same command again to resume", file=sys.stderr)
    elif journal is not None and journal.exists():
        print(f"{args.prog}: interrupted: the finished episodes are kept in {journal}; run the same command again "
              "to resume", file=sys.stderr)
    elif journal is not None:
        print(f"{args.prog}: interrupted before the first episode; nothing to resume", file=sys.stderr)
    else:
        kept = f" after {error.kept} of {error.total} episodes" if isinstance(error, Interrupted) else ""
        print(f"{args.prog}: interrupted{kept}; nothing was kept (give --json or --csv to keep finished episodes "
              "and resume)", file=sys.stderr)
    return 130


def write_episodes_csv(rows: list[dict], path: Path, first: tuple[str, ...] = ("task",)) -> None:
    """One row per episode (`evaluate`'s "records", the benchmark's cell episodes): the `first` columns, then the
    seed and every metric (the union of the rows' keys); empty cells for undefined figures."""
    keys = list(first) + ["seed"]
    keys += sorted({k for row in rows for k in row} - set(keys))
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(keys)
        for row in rows:
            writer.writerow(["" if row.get(k) is None else row[k] for k in keys])


def write_outputs(results: dict, json_path: Path | None, csv_path: Path | None) -> Path | None:
    """Writes the results as strict JSON ({"tasks": {...}, "records": {...}}), a CSV of one row per task, and beside
    them a CSV of one row per episode (`episodes_csv_path`); returns the last one's path (None when not written)."""
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(results, indent=2, allow_nan=False))
    if csv_path:
        csv_path.parent.mkdir(parents=True, exist_ok=True)
        rows = {task: {**{k: v for k, v in s.items() if k != "outcomes"},
                       **{f"outcome_{k}": v for k, v in s["outcomes"].items()}}
                for task, s in results["tasks"].items()}
        keys = sorted({k for row in rows.values() for k in row})
        with open(csv_path, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["task", *keys])
            for task, row in rows.items():
                writer.writerow([task, *("" if row.get(k) is None else row[k] for k in keys)])
    episodes_path = episodes_csv_path(json_path, csv_path)
    if episodes_path is not None:
        write_episodes_csv([{"task": task, **row} for task, rows in results.get("records", {}).items()
                            for row in rows], episodes_path)
    return episodes_path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj eval`."""
    add_episode_options(parser, task="all",
                        task_help="task name, tag (e.g. benchmarking, planning), domain (auv, auv3d) or 'all'",
                        policy=None, policy_required=True, seed_help="seed of the first episode")
    parser.add_argument("--episodes", type=positive_int, default=10, help="episodes per task")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="cut episodes after this many steps")
    parser.add_argument("--json", type=Path, default=None, help="write results as JSON here")
    parser.add_argument("--csv", type=Path, default=None, help="write results as CSV here (one row per task; "
                        f"one row per episode beside it, NAME{EPISODE_CSV_SUFFIX}, also written beside --json)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--workers", type=bounded_int(1, MAX_PROCESSES), default=1,
                        help="run the episodes in this many local processes (with --ray local: Ray's CPUs)")
    parser.add_argument("--ray", default=None, metavar="ADDRESS",
                        help="run the episodes as Ray tasks: 'local' starts Ray here, 'auto' or HOST:PORT "
                             "joins a running cluster (`ray start --head`)")
    parser.add_argument("--retries", type=bounded_int(0, MAX_RETRIES), default=distributed.RETRIES,
                        help="reruns of an episode whose worker process died, before it is reported failed")
    parser.add_argument("--record-failures", type=Path, default=None, metavar="DIR",
                        help="write an MP4 and a trajectory PNG of each episode that does not reach the goal "
                             "here, named TASK_seedSEED_OUTCOME")
    parser.add_argument("--force", action="store_true", help="start afresh where a journal of another run lies "
                        f"beside --csv/--json (NAME{JOURNAL_SUFFIX}; the same command resumes its own)")


def run(args: argparse.Namespace) -> int:
    """Runs the evaluation, prints the table, writes JSON/CSV (their paths checked first). Ctrl-C ends it in one
    line saying what was kept (`interrupted`)."""
    journal = journal_path(args.json, args.csv)
    try:
        return _run(args, journal)
    except KeyboardInterrupt as error:
        return interrupted(args, error, journal)


def _run(args: argparse.Namespace, journal: Path | None) -> int:
    check_output(args, args.json, "--json")
    check_output(args, args.csv, "--csv")
    check_output(args, episodes_csv_path(args.json, args.csv), "--csv/--json (its per-episode CSV beside it)")
    check_output(args, journal, "--csv/--json (the journal beside it)")
    check_output_folder(args, args.record_failures, "--record-failures")
    if args.seed + args.episodes - 1 > SEED_LIMIT:
        usage_error(args, f"--seed {args.seed} + --episodes {args.episodes} passes the largest seed {SEED_LIMIT}")
    kwargs = task_kwargs(args)
    if args.retries < 0:
        usage_error(args, f"--retries must be >= 0, got {args.retries}")
    check_ray(args)
    try:
        task_names = policies.resolve_tasks(args.task, args.policy)
        if "random" in kwargs:
            raise ValueError("task_kwargs: 'random' is set by --seed (episode i gets seed + i), leave it out")
        for task_name in task_names:  # refuse bad options before the first episode
            policies.env_and_policy(args.policy, task_name, args.seed, kwargs)
    except (ValueError, FileNotFoundError) as e:
        usage_error(args, str(e))
    ended: list[tuple[str, int, str]] = []

    def on_episode(task: str, seed: int, metrics: dict) -> None:
        if metrics["success"] is not None:  # a tracking episode (no goal) is no failure to record
            ended.append((task, seed, metrics["outcome"]))

    try:
        results = evaluate(args.policy, task_names, args.episodes, args.seed, args.max_steps,
                           progress=not args.no_progress, task_kwargs=kwargs, workers=args.workers,
                           ray_address=args.ray, retries=args.retries,
                           on_episode=on_episode, journal=journal, force=args.force)
    except JournalMismatch as e:
        usage_error(args, str(e))
    except (ValueError, FileNotFoundError) as e:
        print(f"{args.prog}: error: {e}", file=sys.stderr)
        return 1
    print(format_table(results))
    episodes_path = write_outputs(results, args.json, args.csv)
    for path in (args.json, args.csv, episodes_path):
        if path:
            print(f"wrote {path}")
    if args.record_failures is not None:
        written = failures.record_failures(args.policy, sorted(ended), args.record_failures, kwargs, args.max_steps)
        print(f"recorded {len(written)} failed episode(s) in {args.record_failures}")
    for failure in results.get("failed", []):
        print(f"{args.prog}: episode {failure['episode']} of {failure['task']} (seed {failure['seed']}) failed: "
              f"{failure['error']}", file=sys.stderr)
    if journal is not None and results.get("failed"):
        print(f"{args.prog}: the finished episodes stay in {journal}: the same command runs the failed ones again",
              file=sys.stderr)
    elif journal is not None:
        journal.unlink(missing_ok=True)  # the outputs hold every episode now
    return 1 if results.get("failed") else 0
