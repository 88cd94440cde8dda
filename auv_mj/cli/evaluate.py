"""`auv-mj eval`: dm_control suite-style evaluation of a policy over seeded episodes of one or more tasks.

Episode i of a task runs with task seed `seed + i` and the policy seeded the same, through the one
episode loop (`auv_mj.episode.EpisodeRecorder`); its metrics are `auv_mj.episode.episode_metrics`.
Per task the summary holds (units in brackets):
- `episodes`; `outcomes`: {goal, collision, left_map, timeout} counts, summing to `episodes`;
- `success_rate`, `collision_rate`, `safety_violation_rate` (entering d_s = 5 m) [fraction of episodes];
- `min_clearance` (least over episodes) and `median_min_clearance` [m], hull to the nearest geom;
- `path_length` [m], `time_to_goal` [s] (mean over successful episodes), `return` and `return_std`;
- tracking tasks: `mae_speed`, `max_speed` [m/s], `mae_heading`, `max_heading` [rad], `mae_cross_track`,
  `max_cross_track` [m], and on speed_heading `mae_speed_<phase>`, `mae_heading_<phase>` (Table 9).
A figure that is undefined is null in the JSON (never NaN): `time_to_goal` when no episode succeeded,
clearances on a task without obstacles to measure (speed_heading), tracking errors where the task
reports none. The JSON is strict (any parser reads it); the CSV leaves such cells empty.

`--workers N` runs the episodes in N local processes and `--ray ADDRESS` (or `local`) as Ray tasks on a
cluster (`auv_mj.cli.distributed`); each episode is seeded as in the serial loop and the summaries are
taken over the episodes in index order, so the JSON is the serial one. An episode that produced no result
(its worker died more than `--retries` times, or it raised) is listed under "failed" by task, episode
index and seed; the summaries cover the finished episodes, and the exit status is 1.

`--record-failures DIR` writes an MP4 and a trajectory PNG of every episode that did not reach the goal
(`auv_mj.cli.failures`: each is run again, seeded as before, through the renderer), named
`TASK_seedSEED_OUTCOME`; the folder is checked before the first episode.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.cli import distributed, failures, policies
from auv_mj.cli.options import (
    MAX_PROCESSES,
    MAX_RETRIES,
    add_episode_options,
    bounded_int,
    check_output,
    check_output_folder,
    positive_int,
    task_kwargs,
    usage_error,
)
from auv_mj.console import progress_bar
from auv_mj.episode import OUTCOMES, episode_metrics, record_episode

SEED_LIMIT = 2**32 - 1
"""Largest task seed (NumPy's RandomState); episode i of a run uses --seed + i."""


def run_episode(policy_name: str, task_name: str, seed: int, task_kwargs: dict | None = None,
                max_steps: int | None = None) -> dict:
    """The metrics of one episode of `task_name` seeded `seed` under the named policy."""
    env, policy = policies.env_and_policy(policy_name, task_name, seed, task_kwargs)
    return episode_metrics(record_episode(env, policy, max_steps, task_name, policy_name, seed))


def _mean(values: list) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def summarise(episodes: list[dict]) -> dict:
    """Per-task summary of episode metrics (rates, means; time to goal over successful episodes)."""
    clearances = [e["min_clearance"] for e in episodes if e["min_clearance"] is not None]
    summary = {"episodes": len(episodes),
               "outcomes": {name: sum(e["outcome"] == name for e in episodes) for name in OUTCOMES},
               "success_rate": _mean([e["success"] for e in episodes]),
               "collision_rate": _mean([e["collision"] for e in episodes]),
               "safety_violation_rate": _mean([e["safety_violation"] for e in episodes]),
               "min_clearance": float(np.min(clearances)) if clearances else None,
               "median_min_clearance": float(np.median(clearances)) if clearances else None,
               "path_length": _mean([e["path_length"] for e in episodes]),
               "time_to_goal": _mean([e["time_to_goal"] for e in episodes if e["success"]]),
               "return": _mean([e["return"] for e in episodes]),
               "return_std": float(np.std([e["return"] for e in episodes]))}
    extra = sorted({k for e in episodes for k in e if k.startswith(("mae_", "max_"))})
    for key in extra:
        values = [e[key] for e in episodes if e.get(key) is not None]
        summary[key] = (float(np.max(values)) if key.startswith("max_") else float(np.mean(values))) \
            if values else None
    return summary


def evaluate(policy_name: str, task_names: list[str], episodes: int, seed: int = 0,
             max_steps: int | None = None, progress: bool = True, task_kwargs: dict | None = None, *,
             workers: int = 1, ray_address: str | None = None, retries: int = distributed.RETRIES,
             episode_fn=None, on_episode=None) -> dict:
    """Evaluates `policy_name` on each task; returns {"policy", "seed", "tasks": {task: summary}}.

    `task_kwargs` go to every task (e.g. random commands on speed_heading); the seed is the episode's.
    With `workers` > 1 or a `ray_address` the episodes run in parallel (`evaluate_parallel`).
    `on_episode(task, seed, metrics)` is called for every finished episode (e.g. to find the failures).
    """
    if workers > 1 or ray_address is not None:
        return evaluate_parallel(policy_name, task_names, episodes, seed, max_steps, progress, task_kwargs,
                                 workers=workers, ray_address=ray_address, retries=retries,
                                 episode_fn=episode_fn, on_episode=on_episode)
    task_kwargs = dict(task_kwargs or {})
    results = {}
    for task_name in task_names:
        runs = []
        bar = progress_bar(total=episodes, desc=f"eval {task_name}", unit="ep", disable=not progress)
        for i in range(episodes):
            runs.append(run_episode(policy_name, task_name, seed + i, task_kwargs, max_steps))
            if on_episode is not None:
                on_episode(task_name, seed + i, runs[-1])
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in runs]):.2f}")
        bar.close()
        results[task_name] = summarise(runs)
    return {"policy": policy_name, "seed": seed, "episodes": episodes, "task_kwargs": task_kwargs,
            "tasks": results}


def evaluate_parallel(policy_name: str, task_names: list[str], episodes: int, seed: int = 0,
                      max_steps: int | None = None, progress: bool = True, task_kwargs: dict | None = None, *,
                      workers: int = 2, ray_address: str | None = None, retries: int = distributed.RETRIES,
                      episode_fn=None, on_episode=None) -> dict:
    """`evaluate` with the episodes of every task spread over `workers` local processes or a Ray cluster.

    Episode i of a task runs `episode_fn(policy_name, task, seed + i, task_kwargs, max_steps)` (by default
    `run_episode`; a module-level function, for pickling), as the serial loop does; results are kept as they arrive and
    summarised in episode order, so the result equals the serial one. Episodes that gave no result are
    listed under "failed" ({task, episode, seed, error}); the summaries cover the others.
    """
    task_kwargs = dict(task_kwargs or {})
    jobs = [(policy_name, task, seed + i, task_kwargs, max_steps) for task in task_names for i in range(episodes)]
    finished: dict[int, dict] = {}
    failed = []
    bar = progress_bar(total=len(jobs), desc=f"eval {len(task_names)} task(s)", unit="ep", disable=not progress)
    try:
        for k, result in distributed.run_jobs(episode_fn or run_episode, jobs, workers=workers,
                                              ray_address=ray_address, retries=retries):
            if isinstance(result, distributed.JobFailed):
                failed.append({"task": jobs[k][1], "episode": k % episodes, "seed": jobs[k][2],
                               "error": result.error})
            else:
                finished[k] = result
                if on_episode is not None:
                    on_episode(jobs[k][1], jobs[k][2], result)
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in finished.values()] or [0]):.2f}",
                            failed=len(failed))
    finally:
        bar.close()
    results = {}
    for t, task_name in enumerate(task_names):
        runs = [finished[k] for k in range(t * episodes, (t + 1) * episodes) if k in finished]
        results[task_name] = summarise(runs) if runs else {"episodes": 0, "outcomes": dict.fromkeys(OUTCOMES, 0)}
    out = {"policy": policy_name, "seed": seed, "episodes": episodes, "task_kwargs": task_kwargs,
           "tasks": results}
    if failed:
        out["failed"] = sorted(failed, key=lambda f: (task_names.index(f["task"]), f["episode"]))
    return out


TABLE_COLUMNS = ("success_rate", "collision_rate", "min_clearance", "path_length", "time_to_goal", "return",
                 "mae_speed", "mae_heading")


def table_cell(value, width: int = 15, digits: int = 3) -> str:
    """A right-aligned cell of a plain-text table: n/a for None, a string as it is, a number to `digits`
    (a rounded -0.0, e.g. a clearance of -0.001 m at contact, shows as 0)."""
    if value is None:
        return f"{'n/a':>{width}}"
    if isinstance(value, str):
        return f"{value:>{width}}"
    return f"{round(value, digits) + 0.0:>{width}.{digits}f}"


def format_table(results: dict) -> str:
    """A plain-text table of the headline metrics and the outcomes, one row per task."""
    header = f"{'task':<18}" + "".join(f"{c:>15}" for c in TABLE_COLUMNS) + "   outcomes"
    lines = [f"policy: {results['policy']}   episodes: {results['episodes']}   seed: {results['seed']}",
             header, "-" * len(header)]
    for task, summary in results["tasks"].items():
        cells = "".join(table_cell(summary.get(c)) for c in TABLE_COLUMNS)
        outcomes = ", ".join(f"{name} {n}" for name, n in summary["outcomes"].items() if n)
        lines.append(f"{task:<18}{cells}   {outcomes}")
    return "\n".join(lines)


def write_outputs(results: dict, json_path: Path | None, csv_path: Path | None) -> None:
    """Writes the results as strict JSON ({"tasks": {...}}) and as a CSV of one row per task."""
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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj eval`."""
    add_episode_options(parser, task="all", task_help="task name, tag (e.g. benchmarking, planning) or 'all'",
                        policy=None, policy_required=True, seed_help="seed of the first episode")
    parser.add_argument("--episodes", type=positive_int, default=10, help="episodes per task")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="cut episodes after this many steps")
    parser.add_argument("--json", type=Path, default=None, help="write results as JSON here")
    parser.add_argument("--csv", type=Path, default=None, help="write results as CSV here")
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


def run(args: argparse.Namespace) -> int:
    """Runs the evaluation, prints the table, writes JSON/CSV (their paths checked first)."""
    check_output(args, args.json, "--json")
    check_output(args, args.csv, "--csv")
    check_output_folder(args, args.record_failures, "--record-failures")
    if args.seed + args.episodes - 1 > SEED_LIMIT:
        usage_error(args, f"--seed {args.seed} + --episodes {args.episodes} passes the largest seed {SEED_LIMIT}")
    kwargs = task_kwargs(args)
    if args.retries < 0:
        usage_error(args, f"--retries must be >= 0, got {args.retries}")
    if args.ray not in (None, distributed.LOCAL) and args.workers > 1:
        usage_error(args, "--workers sets the CPUs of --ray local only; a cluster's CPUs are its own")
    if args.ray is not None:
        try:
            import ray  # noqa: F401
        except ImportError:
            usage_error(args, "--ray needs Ray: pip install 'ray[tune]'")
    try:
        task_names = policies.resolve_tasks(args.task, args.policy)
        if "random" in kwargs:
            raise ValueError("task_kwargs: 'random' is set by --seed (episode i gets seed + i), leave it out")
        for task_name in task_names:  # refuse bad options before the first episode
            policies.env_and_policy(args.policy, task_name, args.seed, kwargs)
    except (ValueError, FileNotFoundError) as e:
        usage_error(args, str(e))
    ended: list[tuple[str, int, str]] = []
    try:
        results = evaluate(args.policy, task_names, args.episodes, args.seed, args.max_steps,
                           progress=not args.no_progress, task_kwargs=kwargs, workers=args.workers,
                           ray_address=args.ray, retries=args.retries,
                           on_episode=lambda task, seed, metrics: ended.append((task, seed, metrics["outcome"])))
    except (ValueError, FileNotFoundError) as e:
        print(f"{args.prog}: error: {e}", file=sys.stderr)
        return 1
    print(format_table(results))
    write_outputs(results, args.json, args.csv)
    for path in (args.json, args.csv):
        if path:
            print(f"wrote {path}")
    if args.record_failures is not None:
        written = failures.record_failures(args.policy, sorted(ended), args.record_failures, kwargs, args.max_steps)
        print(f"recorded {len(written)} failed episode(s) in {args.record_failures}")
    for failure in results.get("failed", []):
        print(f"{args.prog}: episode {failure['episode']} of {failure['task']} (seed {failure['seed']}) failed: "
              f"{failure['error']}", file=sys.stderr)
    return 1 if results.get("failed") else 0
