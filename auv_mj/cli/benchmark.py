"""`auv-mj benchmark`: the versioned held-out suite of planning cells in one command (issues 30 and 31).

    auv-mj benchmark --policy P [--tier standard,hard] [--water ideal,ocean] [--episodes N]
                     [--workers N | --ray ADDRESS] --out DIR

The suite is one table, `SUITE_V1`: each row (a `Cell`) is a task with its options (a procedural arena of a tier in
a water), a block of held-out TEST seeds (`auv_mj.seeds.TEST`) and its default number of episodes. Episode i of a
cell runs with seed `cell.seeds[i]`, through the one episode loop and metric definitions of `auv-mj eval`
(`auv_mj.episode`, `auv_mj.cli.evaluate.summarise`). Changing what the suite measures (a row, its seeds, options,
episodes or the metrics) is a new version: `SUITE_VERSION` goes up and `FINGERPRINTS` gets the new definition's
hash, which a test pins.

Per cell (units in brackets): success with its 95 % Wilson interval, the outcome counts (collisions, left_map,
timeouts), mean time to the goal over successes [s], the least and the median of the episodes' least clearances
[m], and time efficiency against `oracle` (oracle time / own time on a success, capped at 1 as SPL caps path
ratios; 0 on a failure; SPL, Anderson et al. 2018) over the seeds where the oracle's stored result reached the goal
(`--oracle FILE`, by default the `oracle` entry of the leaderboard). Figures that are undefined are null.

It writes into DIR: `results.json` (strict JSON: the suite name, version and fingerprint, every cell's summary
and episodes), `leaderboard_row.md` (the policy's Markdown row) and `comparison.md` (the row beside the shipped
policies' results in `docs/benchmark/leaderboard.json`, over the same cells). `--publish` adds the run to that
file and regenerates `docs/benchmark/leaderboard.md`; that is how the shipped results are made.

Speed. A worker process builds each cell's environment once and reseeds it per episode (`run_cell_episode`), the
forkserver that spawns the workers starts importing while the cells are checked, and the episodes are queued
longest cells first, so that two workers are busy to the end.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from auv_mj import seeds
from auv_mj.cli import distributed, policies
from auv_mj.cli.evaluate import summarise
from auv_mj.cli.options import (
    MAX_PROCESSES,
    bounded_int,
    check_output,
    check_output_folder,
    positive_int,
    usage_error,
)
from auv_mj.console import progress_bar
from auv_mj.episode import episode_metrics, record_episode

SUITE_NAME = "suite v1"
SUITE_VERSION = 1
TIERS = ("standard", "hard")
"""The `tier` task option (issue 30)."""
WATERS = ("ideal", "ocean")
"""The `conditions` task option: the paper's water, and current, lag and noise (`auv_mj.sim.ocean`)."""
SEED_BLOCK = 1000
"""Held-out seeds per set: set k uses TEST seeds [TEST.start + k * SEED_BLOCK, ... + SEED_BLOCK)."""
EPISODES = 50
"""Episodes per cell by default: the whole suite in <= 30 min with two workers on a 2-core machine."""


@dataclass(frozen=True)
class Cell:
    """One row of the suite: a task and its options, on a block of held-out seeds."""

    task: str
    tier: str
    water: str
    first_seed: int
    """Episode i runs with seed first_seed + i (inside `auv_mj.seeds.TEST`)."""
    episodes: int = EPISODES

    @property
    def name(self) -> str:
        return f"{self.task}/{self.tier}/{self.water}"

    @property
    def task_kwargs(self) -> dict:
        """The task's options: a procedural arena of the cell's tier, in the cell's water."""
        return {"arena": "random", "tier": self.tier, "conditions": self.water}

    def seeds(self, episodes: int | None = None) -> range:
        return range(self.first_seed, self.first_seed + (episodes or self.episodes))


def _block(k: int) -> int:
    return seeds.TEST.start + k * SEED_BLOCK


SUITE_V1: tuple[Cell, ...] = (
    Cell("obstacles", "standard", "ideal", _block(0)),
    Cell("obstacles", "standard", "ocean", _block(0)),
    Cell("obstacles", "hard", "ideal", _block(0)),
    Cell("obstacles", "hard", "ocean", _block(0)),
    Cell("moving_obstacles", "standard", "ideal", _block(1)),
    Cell("moving_obstacles", "standard", "ocean", _block(1)),
    Cell("moving_obstacles", "hard", "ideal", _block(1)),
    Cell("moving_obstacles", "hard", "ocean", _block(1)),
    Cell("tunnel", "standard", "ideal", _block(2)),
    Cell("tunnel", "standard", "ocean", _block(2)),
    Cell("tunnel", "hard", "ideal", _block(2)),
    Cell("tunnel", "hard", "ocean", _block(2)),
)
"""The benchmark, version 1: random obstacles, random moving obstacles and random tunnels, each in both tiers and
both waters; the tiers and waters of a set share its seeds (paired comparisons)."""
METRICS = ("success_rate", "success_ci95", "outcomes", "time_to_goal", "min_clearance", "median_min_clearance",
           "time_efficiency")
"""What each cell reports (part of the definition, and of its fingerprint)."""
FINGERPRINTS = {1: "4592ab23994f2ac5"}
"""Version -> the first 16 hex digits of `fingerprint()` of that version's definition."""
LEADERBOARD = Path(__file__).resolve().parents[2] / "docs" / "benchmark" / "leaderboard.json"
"""The shipped policies' results, made by `auv-mj benchmark --publish`."""
ORACLE = "oracle"
"""The policy whose times are the reference of time efficiency."""


def definition(suite: Sequence[Cell] = SUITE_V1) -> dict:
    """The suite's definition as plain data: what its fingerprint hashes and its JSON names."""
    return {"name": SUITE_NAME, "version": SUITE_VERSION, "metrics": list(METRICS),
            "cells": [{**asdict(c), "name": c.name, "task_kwargs": c.task_kwargs} for c in suite]}


def fingerprint(suite: Sequence[Cell] = SUITE_V1) -> str:
    """SHA-256 (first 16 hex digits) of the definition: any change to what the suite measures changes it."""
    text = json.dumps({k: v for k, v in definition(suite).items() if k != "version"}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of a success rate (Wilson 1927): sound at rates of 0 and 1, unlike the
    normal approximation; (0, 1) for no episodes."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


# --- episodes ---------------------------------------------------------------------------------------------------

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
            order = sorted(range(len(jobs)), key=lambda k: jobs[k][1] != "tunnel")
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


# --- figures ----------------------------------------------------------------------------------------------------


def oracle_times(results: dict | None) -> dict[str, dict[int, float]]:
    """{cell: {seed: the oracle's time to the goal}} of an oracle results dict (its successes only)."""
    if not results:
        return {}
    return {name: {int(e["seed"]): float(e["time_to_goal"]) for e in cell.get("episodes", []) if e["success"]}
            for name, cell in results.get("cells", {}).items()}


def episode_efficiency(episode: dict, reference: dict[int, float]) -> float:
    """One episode's time efficiency (SPL's form, Anderson et al. 2018): the oracle's time on its seed over its
    own, capped at 1, on a success; 0 on a failure. `reference`: the oracle's times by seed (the seed in it)."""
    return min(1.0, reference[episode["seed"]] / episode["time_to_goal"]) if episode["success"] else 0.0


def efficiency_parts(episode: dict, oracle_episode: dict) -> tuple[float, float] | None:
    """Time efficiency on a success split in two, to tell a longer path from a slower flight: (path efficiency, the
    oracle's path length over the episode's; speed ratio, the episode's mean speed, path length / time to the goal,
    over the oracle's), on a seed both reached the goal on; None otherwise (or where a length or time is not
    positive). Their product is the oracle's time over the episode's, uncapped (`episode_efficiency` before its cap):
    (L_o / L) (L / T) / (L_o / T_o) = T_o / T."""
    if not (episode["success"] and oracle_episode["success"]):
        return None
    length, time = episode["path_length"], episode["time_to_goal"]
    oracle_length, oracle_time = oracle_episode["path_length"], oracle_episode["time_to_goal"]
    if None in (length, time, oracle_length, oracle_time) or min(length, time, oracle_length, oracle_time) <= 0:
        return None
    return oracle_length / length, (length / time) / (oracle_length / oracle_time)


def decomposition(results: dict, oracle: dict, cells: Sequence[str]) -> dict | None:
    """`efficiency_parts` pooled over the cells `cells` of a results dict against the oracle's, paired by seed within
    each cell (the seeds both hold and both reached the goal on): {"path_efficiency", "speed_ratio",
    "time_efficiency" (uncapped, the per-seed product), the means over those seeds, and "seeds", how many}; None
    where there is no such seed."""
    parts: list[tuple[float, float]] = []
    for name in cells:
        ours = results.get("cells", {}).get(name, {}).get("episodes", [])
        theirs = {int(e["seed"]): e for e in oracle.get("cells", {}).get(name, {}).get("episodes", [])}
        for episode in ours:
            reference = theirs.get(int(episode["seed"]))
            split = efficiency_parts(episode, reference) if reference is not None else None
            if split is not None:
                parts.append(split)
    if not parts:
        return None
    path, speed = np.array(parts).T
    return {"path_efficiency": float(path.mean()), "speed_ratio": float(speed.mean()),
            "time_efficiency": float((path * speed).mean()), "seeds": len(parts)}


def paired_efficiency(a: dict, b: dict, references: dict[str, dict[int, float]],
                      cells: Sequence[str] | None = None) -> np.ndarray:
    """Per-seed differences of time efficiency, A - B, over the cells both results dicts hold (`cells` only, if
    given) and the seeds both ran that the oracle reached the goal on (`references`, as `oracle_times`)."""
    diffs: list[float] = []
    for name, cell in a.get("cells", {}).items():
        if name not in b.get("cells", {}) or (cells is not None and name not in cells):
            continue
        ref = references.get(name, {})
        other = {e["seed"]: e for e in b["cells"][name].get("episodes", [])}
        diffs += [episode_efficiency(e, ref) - episode_efficiency(other[e["seed"]], ref)
                  for e in cell.get("episodes", []) if e["seed"] in ref and e["seed"] in other]
    return np.array(diffs)


def exact_mcnemar(only_a: int, only_b: int) -> float:
    """The two-sided exact McNemar p-value of a paired success comparison: the binomial test of `only_a` against
    `only_b` discordant pairs (seeds only one side reached the goal on) at 1/2 (McNemar 1947, exact form)."""
    n = only_a + only_b
    tail = sum(math.comb(n, k) for k in range(min(only_a, only_b) + 1)) / 2 ** n
    return min(1.0, 2.0 * tail)


def bootstrap_mean(values: np.ndarray, resamples: int = 5000, seed: int = 0) -> tuple[float, float, float]:
    """The mean of `values` and its 95 % percentile-bootstrap interval (`resamples` resamples, seeded)."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        raise ValueError("bootstrap_mean: no values")
    means = np.random.default_rng(seed).choice(values, (resamples, values.size)).mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return float(values.mean()), float(low), float(high)


def cell_summary(rows: list[dict], reference: dict[int, float] | None) -> dict:
    """A cell's figures (module docstring) from its episode rows; `reference` the oracle's times by seed."""
    summary = summarise(rows) if rows else {"episodes": 0, "outcomes": {}}
    wins = sum(bool(r["success"]) for r in rows)
    summary["success_ci95"] = list(wilson(wins, len(rows)))
    summary["timeout_rate"] = summary["outcomes"].get("timeout", 0) / len(rows) if rows else None
    scored = [r for r in rows if reference and r["seed"] in reference]
    summary["time_efficiency"] = float(np.mean([episode_efficiency(r, reference) for r in scored])) \
        if scored else None
    summary["time_efficiency_episodes"] = len(scored)
    return summary


def pooled(results: dict, names: Sequence[str]) -> dict:
    """Figures over the episodes of the cells `names` of a results dict (those it has)."""
    cells = [results["cells"][n] for n in names if n in results.get("cells", {})]
    episodes = [e for c in cells for e in c["episodes"]]
    n = len(episodes)
    wins = [e for e in episodes if e["success"]]
    efficiency = [(c["summary"]["time_efficiency"], c["summary"]["time_efficiency_episodes"]) for c in cells
                  if c["summary"].get("time_efficiency") is not None]
    weight = sum(w for _, w in efficiency)
    clearances = [e["min_clearance"] for e in episodes if e["min_clearance"] is not None]
    return {"episodes": n, "success": len(wins) / n if n else None, "ci95": wilson(len(wins), n),
            "collision": sum(e["outcome"] == "collision" for e in episodes) / n if n else None,
            "timeout": sum(e["outcome"] == "timeout" for e in episodes) / n if n else None,
            "time_to_goal": float(np.mean([e["time_to_goal"] for e in wins])) if wins else None,
            "time_efficiency": sum(v * w for v, w in efficiency) / weight if weight else None,
            "min_clearance": float(np.min(clearances)) if clearances else None}


def benchmark(policy_name: str, cells: Sequence[Cell], episodes: int | None = None, max_steps: int | None = None,
              *, oracle: dict | None = None, workers: int = 1, ray_address: str | None = None,
              progress: bool = True) -> dict:
    """Runs the cells and returns the results dict that `results.json` holds."""
    by_cell, failed = run_episodes(policy_name, cells, episodes, max_steps, workers=workers,
                                   ray_address=ray_address, progress=progress)
    references = oracle_times(oracle)
    out = {"suite": SUITE_NAME, "suite_version": SUITE_VERSION, "fingerprint": fingerprint(), "policy": policy_name,
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


# --- tables -----------------------------------------------------------------------------------------------------

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


def comparison_table(results: dict, board: dict) -> str:
    """This run's row beside every leaderboard entry of the same suite version, over this run's cells."""
    names = list(results["cells"])
    entries = {name: r for name, r in board.get("policies", {}).items()
               if r.get("suite_version") == results["suite_version"] and name != results["policy"]}
    rows = [(pooled(r, names)["success"] or 0.0, markdown_row(r, names)) for r in entries.values()]
    rows.append((pooled(results, names)["success"] or 0.0, markdown_row(results, mark=" (this run)")))
    rows.sort(key=lambda row: -row[0])
    cells = f"all {len(names)} cells" if len(names) == len(SUITE_V1) else ", ".join(names)
    return (f"{SUITE_NAME} over {cells}; rates pooled over their episodes, time efficiency against `{ORACLE}`.\n\n"
            + ROW_HEADER + "\n" + "\n".join(row for _, row in rows) + "\n")


def leaderboard_markdown(board: dict) -> str:
    """`docs/benchmark/leaderboard.md`: every published policy over the whole suite."""
    entries = sorted(board.get("policies", {}).values(), key=lambda r: -(pooled(r, list(r["cells"]))["success"]
                                                                        or 0.0))
    lines = [f"# Leaderboard, {SUITE_NAME} (fingerprint {fingerprint()})", "",
             "Made by `auv-mj benchmark --policy P --publish` (`auv_mj/cli/benchmark.py` defines the suite). "
             "Episodes: the total over the cells run; rates pooled over them; time efficiency against "
             f"`{ORACLE}` on the same seeds. Episodes per cell in these entries: "
             f"{sorted({c['summary']['episodes'] for r in entries for c in r['cells'].values()})} (the suite's "
             f"default is {EPISODES}).", "", ROW_HEADER]
    lines += [markdown_row(r) for r in entries]
    return "\n".join(lines) + "\n"


def read_json(path: Path, what: str, args: argparse.Namespace | None = None) -> dict:
    try:
        return json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as e:
        if args is None:
            raise ValueError(f"{what} {path}: {e}") from None
        usage_error(args, f"{what} {path} cannot be read: {e}")


# --- the command ------------------------------------------------------------------------------------------------


def _choices(values: tuple[str, ...], option: str):
    def parse(text: str) -> tuple[str, ...]:
        chosen = tuple(dict.fromkeys(v.strip() for v in text.split(",") if v.strip()))
        wrong = [v for v in chosen if v not in values]
        if wrong or not chosen:
            raise argparse.ArgumentTypeError(f"comma-separated values of {values}, got {text!r}")
        return chosen

    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj benchmark`."""
    parser.add_argument("--policy", required=True, help=policies.policy_help())
    parser.add_argument("--tier", type=_choices(TIERS, "--tier"), default=TIERS, help="tiers, e.g. standard,hard")
    parser.add_argument("--water", type=_choices(WATERS, "--water"), default=WATERS, help="waters, e.g. ideal,ocean")
    parser.add_argument("--episodes", type=bounded_int(1, SEED_BLOCK), default=None,
                        help=f"episodes per cell (default: the suite's, {EPISODES}); fewer are the first seeds")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="cut episodes after this many steps")
    parser.add_argument("--workers", type=bounded_int(1, MAX_PROCESSES), default=1,
                        help="run the episodes in this many local processes")
    parser.add_argument("--ray", default=None, metavar="ADDRESS", help="run the episodes as Ray tasks at ADDRESS "
                        "('local' starts Ray here, 'auto' or HOST:PORT joins a cluster)")
    parser.add_argument("--out", type=Path, required=True, help="folder for results.json, leaderboard_row.md and "
                        "comparison.md")
    parser.add_argument("--oracle", type=Path, default=None, help="an oracle results.json for time efficiency "
                        f"(default: the `{ORACLE}` entry of the leaderboard)")
    parser.add_argument("--leaderboard", type=Path, default=LEADERBOARD, help="the shipped results to compare with")
    parser.add_argument("--publish", action="store_true", help="add this run to --leaderboard and regenerate its "
                        "Markdown beside it")
    parser.add_argument("--record-failures", type=Path, default=None, metavar="DIR",
                        help="write an MP4 and a trajectory PNG of every episode that did not reach the goal here, "
                             "a folder per cell")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def _start_workers_early(workers: int) -> None:
    """Starts the forkserver that `distributed` spawns its workers from, so that it imports this module while the
    cells are checked here (one import of torch and MuJoCo less on the way to the first episode)."""
    import multiprocessing
    from multiprocessing import forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload([__name__])
    forkserver.ensure_running()


def run(args: argparse.Namespace) -> int:
    """Checks the outputs and every cell, runs the suite, writes the results and tables."""
    out = check_output_folder(args, args.out, "--out")
    if args.publish:
        check_output(args, args.leaderboard, "--leaderboard")
    check_output_folder(args, args.record_failures, "--record-failures")
    if args.ray not in (None, distributed.LOCAL) and args.workers > 1:
        usage_error(args, "--workers sets the CPUs of --ray local only; a cluster's CPUs are its own")
    cells = [c for c in SUITE_V1 if c.tier in args.tier and c.water in args.water]
    if args.workers > 1 and args.ray is None:
        _start_workers_early(args.workers)
    board = read_json(args.leaderboard, "--leaderboard", args) if args.leaderboard.is_file() else {}
    oracle = read_json(args.oracle, "--oracle", args) if args.oracle else board.get("policies", {}).get(ORACLE)
    if oracle is not None and oracle.get("suite_version") != SUITE_VERSION:
        usage_error(args, f"--oracle results are of suite version {oracle.get('suite_version')}, not {SUITE_VERSION}")
    try:
        for cell in {(c.task, c.tier, c.water): c for c in cells}.values():  # refuse before the first episode
            policies.env_and_policy(args.policy, cell.task, cell.first_seed, cell.task_kwargs)
    except (ValueError, FileNotFoundError) as e:
        usage_error(args, str(e))
    results = benchmark(args.policy, cells, args.episodes, args.max_steps, oracle=oracle, workers=args.workers,
                        ray_address=args.ray, progress=not args.no_progress)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=1, allow_nan=False))
    row = markdown_row(results)
    (out / "leaderboard_row.md").write_text(ROW_HEADER + "\n" + row + "\n")
    comparison = comparison_table(results, board)
    (out / "comparison.md").write_text(comparison)
    print(comparison)
    if args.publish:
        board = {"suite": SUITE_NAME, "suite_version": SUITE_VERSION, "fingerprint": fingerprint(),
                 "policies": {**board.get("policies", {}), args.policy: results}}
        args.leaderboard.parent.mkdir(parents=True, exist_ok=True)
        args.leaderboard.write_text(json.dumps(board, indent=1, allow_nan=False))
        args.leaderboard.with_suffix(".md").write_text(leaderboard_markdown(board))
        print(f"published to {args.leaderboard}")
    if args.record_failures is not None:
        from auv_mj.cli.failures import record_failures

        for cell in cells:
            episodes = [(cell.task, e["seed"], e["outcome"]) for e in results["cells"][cell.name]["episodes"]]
            record_failures(args.policy, episodes, args.record_failures / cell.name.replace("/", "-"),
                            cell.task_kwargs, args.max_steps)
    print(f"wrote {out / 'results.json'}, {out / 'leaderboard_row.md'}, {out / 'comparison.md'}")
    for failure in results.get("failed", []):
        print(f"{args.prog}: episode seed {failure['seed']} of {failure['cell']} failed: {failure['error']}",
              file=sys.stderr)
    return 1 if results.get("failed") else 0
