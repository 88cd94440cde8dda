"""Running policies over episodes: `evaluate` (a policy on tasks, seeded episodes, as `auv-mj eval`) and `benchmark`
(a policy on the suite's cells, as `auv-mj benchmark`), serially or spread over workers (`auv_mj.jobs`).

Every episode goes through the one episode loop (`auv_mj.episode.record_episode`) and the one definition of each
metric (`auv_mj.episode.episode_metrics`, `auv_mj.benchmark.metrics`).

Speed. A worker process builds each cell's environment once and reseeds it per episode (`run_cell_episode`), and the
episodes are queued longest cells first, so that two workers are busy to the end.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from auv_mj.benchmark.metrics import cell_summary, oracle_times, summarise
from auv_mj.benchmark.suite import ORACLE, SUITES, Cell, Suite
from auv_mj.console import progress_bar
from auv_mj.episode import OUTCOMES, episode_metrics, record_episode
from auv_mj.jobs import distributed
from auv_mj.zoo import registry as policies


def run_episode(policy_name: str, task_name: str, seed: int, task_kwargs: dict | None = None,
                max_steps: int | None = None) -> dict:
    """The metrics of one episode of `task_name` seeded `seed` under the named policy."""
    env, policy = policies.env_and_policy(policy_name, task_name, seed, task_kwargs)
    return episode_metrics(record_episode(env, policy, max_steps, task_name, policy_name, seed))


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
                                                     "min_clearance", "path_length", "time_to_goal", "return")}}


def _jobs(policy_name: str, cells: Sequence[Cell], episodes: int | None, max_steps: int | None) -> list[tuple]:
    return [(policy_name, c.task, s, c.task_kwargs, max_steps) for c in cells for s in c.seeds(episodes)]


def run_episodes(policy_name: str, cells: Sequence[Cell], episodes: int | None = None, max_steps: int | None = None,
                 *, workers: int = 1, ray_address: str | None = None, progress: bool = True) -> tuple[dict, list]:
    """({cell name: [episode rows in seed order]}, failed jobs) of every cell's episodes."""
    jobs = _jobs(policy_name, cells, episodes, max_steps)
    owner = [c.name for c in cells for _ in c.seeds(episodes)]
    rows: dict[int, dict] = {}
    failed = []
    bar = progress_bar(total=len(jobs), desc=f"benchmark {policy_name}", unit="ep", disable=not progress)
    try:
        if workers == 1 and ray_address is None:
            results = ((k, run_cell_episode(*job)) for k, job in enumerate(jobs))
        else:  # the tunnel cells' long episodes first, so that no worker is left with one at the end
            order = sorted(range(len(jobs)), key=lambda k: not jobs[k][1].startswith("tunnel"))
            queued = [jobs[k] for k in order]
            results = ((order[k], r) for k, r in distributed.run_jobs(run_cell_episode, queued, workers=workers,
                                                                      ray_address=ray_address))
        for k, result in results:
            if isinstance(result, distributed.JobFailed):
                failed.append({"cell": owner[k], "seed": jobs[k][2], "error": result.error})
            else:
                rows[k] = result
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in rows.values()] or [0]):.2f}", failed=len(failed))
    finally:
        bar.close()
    by_cell = {c.name: [] for c in cells}
    for k in sorted(rows):
        by_cell[owner[k]].append(rows[k])
    return by_cell, failed


def benchmark(policy_name: str, cells: Sequence[Cell], episodes: int | None = None, max_steps: int | None = None,
              *, oracle: dict | None = None, workers: int = 1, ray_address: str | None = None,
              progress: bool = True, suite: Suite = SUITES["auv"]) -> dict:
    """Runs the cells (of `suite`, suite v1 by default) and returns the results dict that `results.json` holds."""
    by_cell, failed = run_episodes(policy_name, cells, episodes, max_steps, workers=workers,
                                   ray_address=ray_address, progress=progress)
    references = oracle_times(oracle)
    out = {"suite": suite.name, "suite_version": suite.version, "fingerprint": suite.fingerprint(),
           "policy": policy_name,
           "episodes_per_cell": episodes or None, "max_steps": max_steps,
           "time_efficiency_reference": ORACLE if references else None, "cells": {}}
    for cell in cells:
        rows = by_cell[cell.name]
        if policy_name == ORACLE and not references:  # the oracle is its own reference
            reference = {r["seed"]: r["time_to_goal"] for r in rows if r["success"]}
            out["time_efficiency_reference"] = ORACLE
        else:
            reference = references.get(cell.name)
        out["cells"][cell.name] = {"task": cell.task, "tier": cell.tier, "water": cell.water,
                                   "task_kwargs": cell.task_kwargs, "seeds": [cell.first_seed, cell.first_seed
                                                                              + len(cell.seeds(episodes)) - 1],
                                   "summary": cell_summary(rows, reference), "episodes": rows}
    if failed:
        out["failed"] = failed
    return out


def run_suite(policy_name: str, cells: Sequence[Cell] | None = None, episodes: int | None = None, *,
              max_steps: int | None = None, oracle: dict | str | None = "published", workers: int = 1,
              ray_address: str | None = None, progress: bool = True, domain: str = "auv") -> dict:
    """The named policy on the suite's `cells` (all of the `domain`'s suite by default: suite v1 of "auv", the 3-D
    suite of "auv3d"): the results dict of `benchmark`.

    `oracle`: the oracle's results that time efficiency is measured against; "published" (the default) takes the
    shipped leaderboard's, None measures none (unless the policy is the oracle itself)."""
    from auv_mj.benchmark.leaderboard import board_path, oracle_results, read_board

    suite = SUITES[domain]
    if isinstance(oracle, str):
        if oracle != "published":
            raise ValueError(f"oracle must be 'published', a results dict or None, got {oracle!r}")
        oracle = oracle_results(read_board(board_path(suite)))
    return benchmark(policy_name, suite.cells if cells is None else cells, episodes, max_steps, oracle=oracle,
                     workers=workers, ray_address=ray_address, progress=progress, suite=suite)


def run_cell(policy_name: str, cell: Cell, episodes: int | None = None, **options) -> dict:
    """One cell of the suite: {"summary", "episodes", ...} as `run_suite` gives it for that cell (same options)."""
    return run_suite(policy_name, [cell], episodes, **options)["cells"][cell.name]
