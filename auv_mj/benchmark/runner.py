"""Running policies over episodes: `evaluate` (a policy on tasks, seeded episodes, as `auv-mj eval`) and `benchmark`
(a policy on the suite's cells, as `auv-mj benchmark`), serially or spread over workers (`auv_mj.jobs`).

Every episode goes through the one episode loop (`auv_mj.episode.record_episode`) and the one definition of each
metric (`auv_mj.episode.episode_metrics`, `auv_mj.benchmark.metrics`).

Resuming. With a `journal` (a file, `auv_mj.benchmark.journal`) each finished episode is kept there as it ends, and
the same call made again runs only the episodes the journal lacks: the results are the uninterrupted run's. Ctrl-C
raises `Interrupted` (a KeyboardInterrupt) saying how many episodes were kept and where.

Speed. A worker process builds each cell's environment once and reseeds it per episode (`run_cell_episode`), and the
episodes are queued longest cells first, so that two workers are busy to the end.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator, Sequence
from contextlib import closing, nullcontext
from pathlib import Path

import numpy as np

from auv_mj.benchmark.journal import Interrupted, Journal, policy_identity
from auv_mj.benchmark.metrics import cell_summary, oracle_times, success_rate, summarise
from auv_mj.benchmark.suite import ORACLE, SUITES, Cell, Suite, suite_for
from auv_mj.console import progress_bar
from auv_mj.episode import OUTCOMES, EpisodeRecord, episode_metrics, record_episode
from auv_mj.jobs import distributed
from auv_mj.zoo import registry as policies

TRACE = "trace"
"""Key of `run_episode`'s digest of the episode record; `evaluate` drops it from the rows it keeps."""
PROBE_EPISODES = 2
"""Episodes of a task that `evaluate` runs first, to find out whether its episodes depend on their seed."""


def record_digest(record: EpisodeRecord) -> str:
    """SHA-256 of every array of an episode record that the seed could change: the arena, and per instant and step
    time, pose, velocity, sonar, actuator forces, goal, movers, actions, commands, rewards, events and the task's
    info. Two records with the same digest are the same episode, bit for bit."""
    digest = hashlib.sha256()
    arena = record.arena
    parts = [record.time, record.pose, record.velocity, record.sonar, record.control, record.desired_goal,
             record.movers, record.action, record.command, record.reward, record.event.astype(str), record.success,
             arena.bounds, arena.start, arena.goal, arena.path, arena.goals, *arena.polygons]
    parts += [np.asarray(record.info[k]) for k in sorted(record.info)]
    for part in parts:
        array = np.ascontiguousarray(part)
        digest.update(str((array.dtype, array.shape)).encode())
        digest.update(repr(array.tolist()).encode() if array.dtype == object else array.tobytes())  # not addresses
    return digest.hexdigest()


def _rate(rows: list[dict]) -> str:
    """The progress bar's success so far: n/a before any result and on tracking tasks (they report none)."""
    rate = success_rate(rows) if rows else None
    return "n/a" if rate is None else f"{rate:.2f}"


def run_episode(policy_name: str, task_name: str, seed: int, task_kwargs: dict | None = None,
                max_steps: int | None = None) -> dict:
    """The metrics of one episode of `task_name` seeded `seed` under the named policy (`episode_metrics`), and under
    TRACE the digest of its record (`record_digest`), by which `evaluate` tells one episode from another."""
    env, policy = policies.env_and_policy(policy_name, task_name, seed, task_kwargs)
    record = record_episode(env, policy, max_steps, task_name, policy_name, seed)
    return {**episode_metrics(record), TRACE: record_digest(record)}


def episode_row(seed: int, metrics: dict) -> dict:
    """The record of one episode in `evaluate`'s results: its seed and its metrics (`episode_metrics`: outcome,
    success, duration [s], path length [m], least clearance [m], return, time to goal [s], ...)."""
    return {"seed": seed, **{k: v for k, v in metrics.items() if k != TRACE}}


def evaluate(policy_name: str, task_names: list[str], episodes: int, seed: int = 0,
             max_steps: int | None = None, progress: bool = True, task_kwargs: dict | None = None, *,
             workers: int = 1, ray_address: str | None = None, retries: int = distributed.RETRIES,
             episode_fn=None, on_episode=None, journal: str | Path | None = None, force: bool = False) -> dict:
    """Evaluates `policy_name` on each task over `episodes` seeded episodes (episode i: task and policy seed
    `seed` + i); returns {"policy", "seed", "episodes", "task_kwargs", "tasks": {task: summary}, "records": {task:
    [episode rows in seed order]}} (rows: `episode_row`).

    Deterministic runs. The first PROBE_EPISODES episodes of every task run first; when the two are the same
    episode bit for bit (`record_digest`: a fixed arena or named scenario in ideal water under a policy that
    draws no random number), no seed can change it, so the others are not run: the task's summary and records
    hold that one episode, and the summary says "deterministic": true and "stands_for": `episodes` (the seeds it
    stands for). Otherwise every episode runs (and the summary is `summarise`'s alone). An `episode_fn` whose
    metrics hold no TRACE always runs every episode.

    `task_kwargs` go to every task (e.g. random commands on speed_heading); the seed is the episode's.
    With `workers` > 1 or a `ray_address` the episodes run in parallel on local processes or a Ray cluster
    (`auv_mj.jobs.distributed`); `episode_fn(policy_name, task, seed, task_kwargs, max_steps)` runs one episode
    (by default `run_episode`; module level, for pickling). Results are summarised in episode order, so a
    parallel run equals the serial one. Episodes that gave no result (parallel runs only) are listed under "failed"
    ({task, episode, seed, error}); the summaries cover the others. `on_episode(task, seed, metrics)` is called for
    every episode kept (e.g. to find the failures): once for a deterministic task.

    `journal`: a file that keeps every finished episode as it ends (`auv_mj.benchmark.journal`); called again with
    the same arguments, `evaluate` runs only the episodes it lacks and returns the uninterrupted run's results. A
    journal of another run is refused (JournalMismatch) unless `force`, which starts it afresh. Ctrl-C raises
    `Interrupted`, with the count of episodes kept.
    """
    task_kwargs = dict(task_kwargs or {})
    episode_fn = episode_fn or run_episode
    parallel = workers > 1 or ray_address is not None
    run_name = {"command": "eval", **policy_identity(policy_name), "tasks": list(task_names), "episodes": episodes,
                "seed": seed, "max_steps": max_steps, "task_kwargs": task_kwargs}
    log = Journal(journal, run_name, force=force) if journal is not None else None
    finished: dict[tuple[str, int], dict] = dict(log.episodes) if log else {}
    failed: list[dict] = []
    desc = f"eval {task_names[0]}" if len(task_names) == 1 and not parallel else f"eval {len(task_names)} task(s)"
    bar = progress_bar(total=len(task_names) * episodes, desc=desc, unit="ep", disable=not progress,
                       initial=len(finished))

    def run(keys: list[tuple[str, int]]) -> Iterator[tuple[str, int]]:
        """Runs the episodes `keys` the journal lacks; yields every key of `keys` with a result."""
        yield from (key for key in keys if key in finished)
        keys = [key for key in keys if key not in finished]
        jobs = [(policy_name, task, seed + i, task_kwargs, max_steps) for task, i in keys]
        if not jobs:  # every task deterministic, or every episode in the journal: no workers (nor Ray) to start
            return
        if parallel:
            results = distributed.run_jobs(episode_fn, jobs, workers=workers, ray_address=ray_address,
                                           retries=retries)
        else:
            results = ((k, episode_fn(*job)) for k, job in enumerate(jobs))
        with closing(results):  # stops the workers at once, however the loop ends (Ctrl-C included)
            for k, result in results:
                task, i = keys[k]
                if isinstance(result, distributed.JobFailed):
                    failed.append({"task": task, "episode": i, "seed": seed + i, "error": result.error})
                else:
                    if log is not None:
                        log.add((task, i), result)
                    finished[task, i] = result
                bar.update(1)
                bar.set_postfix(success=_rate(list(finished.values())), failed=len(failed))
                yield task, i

    planned = len(task_names) * episodes
    try:
        probe = min(episodes, PROBE_EPISODES)
        with closing(run([(task, i) for task in task_names for i in range(probe)])) as steps:
            for _ in steps:
                pass  # on_episode waits until it is known whether the probe's episodes are one
        deterministic = {task: _same_episode([finished.get((task, i)) for i in range(probe)])
                         for task in task_names} if episodes >= PROBE_EPISODES else dict.fromkeys(task_names, False)
        kept = {task: [0] if deterministic[task] else list(range(probe)) for task in task_names}
        if on_episode is not None:
            for task in task_names:
                for i in kept[task]:
                    if (task, i) in finished:
                        on_episode(task, seed + i, finished[task, i])
        rest = [(task, i) for task in task_names if not deterministic[task] for i in range(probe, episodes)]
        planned = len(task_names) * probe + len(rest)  # a deterministic task's other seeds are not run
        bar.total = bar.n + sum(key not in finished for key in rest)  # so that the bar ends at 100 %
        bar.refresh()
        with closing(run(rest)) as steps:  # closed at once on Ctrl-C, and its workers with it
            for task, i in steps:
                kept[task].append(i)
                if on_episode is not None and (task, i) in finished:
                    on_episode(task, seed + i, finished[task, i])
    except KeyboardInterrupt:
        raise Interrupted(log.path if log else None, log.kept() if log else len(finished), planned) from None
    finally:
        bar.close()
        if log is not None:
            log.close()
    results, records = {}, {}
    for task in task_names:
        rows = [episode_row(seed + i, finished[task, i]) for i in sorted(kept[task]) if (task, i) in finished]
        summary = summarise(rows) if rows else {"episodes": 0, "outcomes": dict.fromkeys(OUTCOMES, 0)}
        if deterministic[task]:
            summary.update(deterministic=True, stands_for=episodes)
        results[task], records[task] = summary, rows
    out = {"policy": policy_name, "seed": seed, "episodes": episodes, "task_kwargs": task_kwargs,
           "tasks": results, "records": records}
    if failed:
        out["failed"] = sorted(failed, key=lambda f: (task_names.index(f["task"]), f["episode"]))
    return out


def evaluate_parallel(policy_name: str, task_names: list[str], episodes: int, seed: int = 0,
                      max_steps: int | None = None, progress: bool = True, task_kwargs: dict | None = None, *,
                      workers: int = 2, **options) -> dict:
    """`evaluate` over `workers` local processes (or a Ray cluster, `ray_address`)."""
    return evaluate(policy_name, task_names, episodes, seed, max_steps, progress, task_kwargs, workers=workers,
                    **options)


def _same_episode(rows: list[dict | None]) -> bool:
    """Whether the probe's episodes (their rows, None where one failed) are one and the same episode."""
    traces = [row.get(TRACE) if row is not None else None for row in rows]
    return len(traces) >= 2 and traces[0] is not None and all(t == traces[0] for t in traces)


# --- the benchmark's cells ---------------------------------------------------------------------------------------

_ENVIRONMENTS: dict[tuple, object] = {}
"""(policy, task, options) -> the environment this process built for it, reseeded per episode."""


def run_cell_episode(policy_name: str, task: str, seed: int, task_kwargs: dict, max_steps: int | None) -> dict:
    """The metrics of episode `seed` of `task`, as `auv_mj.cli.evaluate.run_episode` gives them, on an
    environment built once per (policy, task, options) in this process and reseeded: the task's RandomState
    seeded `seed` is the state a fresh environment with random=seed starts with, so the episode is the same."""
    import torch

    torch.set_num_threads(1)
    key = (policy_name, task, json.dumps(task_kwargs, sort_keys=True))
    env = _ENVIRONMENTS.get(key)
    if env is None:
        env = _ENVIRONMENTS[key] = policies.make_env(policy_name, task, seed, **dict(task_kwargs))
    else:
        env.task.random.seed(seed)
    policy = policies.make_policy(policy_name, env, seed, task)
    metrics = episode_metrics(record_episode(env, policy, max_steps, task, policy_name, seed))
    return {"seed": seed, **{k: metrics[k] for k in ("success", "outcome", "collision", "safety_violation",
                                                     "min_clearance", "path_length", "time_to_goal", "duration",
                                                     "return")}}


def cell_task_kwargs(policy_name: str, cell: Cell) -> dict:
    """The task options `policy_name` runs `cell` with: the cell's, less its executor for a policy that brings its
    own (a `PolicySpec.executor`: `two-layer-3d` is line of sight on the learned depth executor in every suite)."""
    options = cell.task_kwargs
    if "executor" in options and policies.resolve(policy_name)[0].executor is not None:
        options = {k: v for k, v in options.items() if k != "executor"}
    return options


def _jobs(policy_name: str, cells: Sequence[Cell], episodes: int | None, max_steps: int | None) -> list[tuple]:
    return [(policy_name, c.task, s, cell_task_kwargs(policy_name, c), max_steps) for c in cells
            for s in c.seeds(episodes)]


def run_episodes(policy_name: str, cells: Sequence[Cell], episodes: int | None = None, max_steps: int | None = None,
                 *, workers: int = 1, ray_address: str | None = None, progress: bool = True,
                 journal: Journal | None = None) -> tuple[dict, list]:
    """({cell name: [episode rows in seed order]}, failed jobs) of every cell's episodes; those `journal` holds are
    not run again, and each one run is kept there as it ends. Ctrl-C raises `Interrupted`."""
    jobs = _jobs(policy_name, cells, episodes, max_steps)
    owner = [c.name for c in cells for _ in c.seeds(episodes)]
    kept = journal.episodes if journal is not None else {}
    rows: dict[int, dict] = {k: kept[owner[k], job[2]] for k, job in enumerate(jobs) if (owner[k], job[2]) in kept}
    todo = [k for k in range(len(jobs)) if k not in rows]
    failed = []
    bar = progress_bar(total=len(jobs), desc=f"benchmark {policy_name}", unit="ep", disable=not progress,
                       initial=len(rows))
    try:
        if not todo:
            results = iter(())
        elif workers == 1 and ray_address is None:
            results = ((k, run_cell_episode(*jobs[k])) for k in todo)
        else:  # the tunnel cells' long episodes first, so that no worker is left with one at the end
            order = sorted(todo, key=lambda k: not jobs[k][1].startswith("tunnel"))
            queued = [jobs[k] for k in order]
            results = ((order[k], r) for k, r in distributed.run_jobs(run_cell_episode, queued, workers=workers,
                                                                      ray_address=ray_address))
        with closing(results):  # stops the workers at once, however the loop ends (Ctrl-C included)
            for k, result in results:
                if isinstance(result, distributed.JobFailed):
                    failed.append({"cell": owner[k], "seed": jobs[k][2], "error": result.error})
                else:
                    if journal is not None:
                        journal.add((owner[k], jobs[k][2]), result)
                    rows[k] = result
                bar.update(1)
                bar.set_postfix(success=_rate(list(rows.values())), failed=len(failed))
    except KeyboardInterrupt:
        raise Interrupted(journal.path if journal else None, journal.kept() if journal else len(rows),
                          len(jobs)) from None
    finally:
        bar.close()
    by_cell = {c.name: [] for c in cells}
    for k in sorted(rows):
        by_cell[owner[k]].append(rows[k])
    return by_cell, failed


def benchmark(policy_name: str, cells: Sequence[Cell], episodes: int | None = None, max_steps: int | None = None,
              *, oracle: dict | None = None, workers: int = 1, ray_address: str | None = None,
              progress: bool = True, suite: Suite = SUITES["auv"], journal: str | Path | None = None,
              force: bool = False) -> dict:
    """Runs the cells (of `suite`, suite v1 by default) and returns the results dict that `results.json` holds.

    `journal`: a file that keeps every finished episode as it ends (`auv_mj.benchmark.journal`); called again with
    the same policy, cells, episodes and max_steps on the same suite version, `benchmark` runs only the episodes it
    lacks and returns the uninterrupted run's results (workers and oracle may differ). A journal of another run is
    refused (JournalMismatch) unless `force`, which starts it afresh. Ctrl-C raises `Interrupted`."""
    run_name = {"command": "benchmark", "suite": suite.name, "suite_version": suite.version,
                "fingerprint": suite.fingerprint(), **policy_identity(policy_name), "cells": [c.name for c in cells],
                "episodes": episodes or None, "max_steps": max_steps}
    with Journal(journal, run_name, force=force) if journal is not None else nullcontext() as log:
        by_cell, failed = run_episodes(policy_name, cells, episodes, max_steps, workers=workers,
                                       ray_address=ray_address, progress=progress, journal=log)
    out = {"suite": suite.name, "suite_version": suite.version, "fingerprint": suite.fingerprint(),
           "policy": policy_name,
           "episodes_per_cell": episodes or None, "max_steps": max_steps, "time_efficiency_reference": None,
           "cells": {}}
    for cell in cells:
        last = cell.first_seed + len(cell.seeds(episodes)) - 1
        out["cells"][cell.name] = {"task": cell.task, "tier": cell.tier, "water": cell.water,
                                   "task_kwargs": cell_task_kwargs(policy_name, cell), "seeds": [cell.first_seed, last],
                                   "episodes": by_cell[cell.name]}
    if failed:
        out["failed"] = failed
    return rescore(out, oracle)


def rescore(results: dict, oracle: dict | None) -> dict:
    """`results` (a `benchmark` results dict) with every cell's summary made again from its episodes, time efficiency
    against `oracle`'s results (None: none). A run keeps its episodes, so the reference can come after it: a suite's
    rows run before its oracle is published take their time efficiency from it afterwards, the figures the same
    as had they run after it. The oracle's own run is always its own reference, never an older oracle run's."""
    references = oracle_times(oracle)
    own = results["policy"] == ORACLE
    out = {**results, "time_efficiency_reference": ORACLE if references or own else None, "cells": {}}
    for name, cell in results["cells"].items():
        rows = cell["episodes"]
        reference = {r["seed"]: r["time_to_goal"] for r in rows if r["success"]} if own else references.get(name)
        out["cells"][name] = {**{k: v for k, v in cell.items() if k not in ("summary", "episodes")},
                              "summary": cell_summary(rows, reference), "episodes": rows}
    return out


def run_suite(policy_name: str, cells: Sequence[Cell] | None = None, episodes: int | None = None, *,
              max_steps: int | None = None, oracle: dict | str | None = "published", workers: int = 1,
              ray_address: str | None = None, progress: bool = True, domain: str = "auv",
              version: int | None = None, journal: str | Path | None = None, force: bool = False) -> dict:
    """The named policy on the suite's `cells` (all of the `domain`'s suite by default: suite v1 of "auv", the 3-D
    suite of "auv3d", its newest `version` unless one is given): the results dict of `benchmark`.

    `oracle`: the oracle's results that time efficiency is measured against; "published" (the default) takes the
    shipped leaderboard's, None measures none (unless the policy is the oracle itself). `journal`: a file that keeps
    each finished episode, from which the same call resumes (`benchmark`)."""
    from auv_mj.benchmark.leaderboard import board_path, oracle_results, read_board

    suite = suite_for(domain, version)
    if isinstance(oracle, str):
        if oracle != "published":
            raise ValueError(f"oracle must be 'published', a results dict or None, got {oracle!r}")
        oracle = oracle_results(read_board(board_path(suite)))
    return benchmark(policy_name, suite.cells if cells is None else cells, episodes, max_steps, oracle=oracle,
                     workers=workers, ray_address=ray_address, progress=progress, suite=suite, journal=journal,
                     force=force)


def run_cell(policy_name: str, cell: Cell, episodes: int | None = None, **options) -> dict:
    """One cell of the suite: {"summary", "episodes", ...} as `run_suite` gives it for that cell (same options)."""
    return run_suite(policy_name, [cell], episodes, **options)["cells"][cell.name]
