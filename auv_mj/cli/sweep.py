"""`auv-mj sweep`: training over seeds, agents and a grid of hyper-parameters as Ray Tune trials.

One trial is one `auv_mj.agents.offpolicy.train.train` run, built from the same Gymnasium factory as `auv-mj train`, in
its own run directory `OUT/<agent>[-<field>=<value>...]-seed<S>` (checkpoints, replay, progress.csv), so
`auv-mj reproduce --runs OUT` and `auv-mj plot learning` read a sweep as they read single runs.

A trial that finds a checkpoint in its directory continues it (`train(resume=True)`): a trial Ray retries
after a lost worker, and every trial of `auv-mj sweep ... --resume` after an interrupted sweep, pick up
where their last checkpoint left off; a finished trial finishes at once, or trains on to a larger
--steps / --episodes. At the end the sweep writes `OUT/results.csv` and prints it: per trial the episodes
and steps to TARGET success over a WINDOW-episode window (Fig. 8's measure), the final success rate, the
wall time and the env steps per second.

`--ray local` (the default) starts Ray on this machine with `--workers` CPUs, one trial per CPU (per
N + 1 CPUs with `--collectors N`); `--ray auto` or `--ray HOST:PORT` joins a cluster started with
`ray start --head`, where OUT must be a folder every node sees at the same path (a shared file system,
as Ray Tune itself asks of its storage on a cluster).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import itertools
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy.ddpg import DDPGConfig
from auv_mj.agents.offpolicy.train import AGENTS, CHECKPOINT_NAME, LOG_NAME
from auv_mj.cli.options import (
    MAX_PROCESSES,
    MAX_RETRIES,
    bounded_int,
    json_object,
    positive_int,
    task_kwargs,
    usage_error,
)
from auv_mj.cli.train import add_config_options, config_overrides, make_env_fn, task_env_id
from auv_mj.jobs import distributed
from experiments.report.fig8 import episodes_to

TARGET = 0.9
"""Success rate a trial is timed to (Fig. 8)."""
WINDOW = 20
"""Episodes in the trailing success rate compared with TARGET (Fig. 8)."""
SPEC_NAME = "sweep.json"
"""The sweep's options, kept in OUT; `--resume` refuses other options."""
EXTENDABLE = ("steps", "episodes")
"""Options `--resume` may change: a resumed sweep can train its trials for longer."""
RESULTS_NAME = "results.csv"
RESULT_COLUMNS = ("trial", "agent", "seed", "episodes", "env_steps", "episodes_to_target", "steps_to_target",
                  "seconds_to_target", "final_success", "wall_s", "steps_per_s")


def _value_name(value: Any) -> str:
    return "x".join(map(str, value)) if isinstance(value, (list, tuple)) else str(value)


def trial_name(agent: str, seed: int, params: dict[str, Any]) -> str:
    """Run-directory name of a trial: agent, grid values in field order, seed (`her-ddpg-seed3` alone)."""
    parts = [agent, *(f"{k}={_value_name(v)}" for k, v in params.items()), f"seed{seed}"]
    return "-".join(parts)


def grid_points(grid: dict[str, list]) -> list[dict[str, Any]]:
    """Every combination of the grid's values, first field slowest; [{}] for an empty grid."""
    keys = list(grid)
    return [dict(zip(keys, values, strict=True)) for values in itertools.product(*(grid[k] for k in keys))]


def check_grid(grid: dict[str, Any]) -> dict[str, list]:
    """The grid with every field a DDPGConfig field and every value list non-empty; ValueError naming the field."""
    fields = {f.name: f for f in dataclasses.fields(DDPGConfig)}
    for key, values in grid.items():
        if key == "seed":
            raise ValueError("--grid: give the seeds with --seeds, not as a grid field")
        if key not in fields:
            raise ValueError(f"--grid field {key!r} is not a DDPGConfig field; fields: {sorted(fields)}")
        if not isinstance(values, list) or not values:
            raise ValueError(f"--grid field {key!r} needs a non-empty list of values, got {values!r}")
        for value in values:
            try:
                DDPGConfig(**{key: tuple(value) if isinstance(value, list) else value})
            except (TypeError, ValueError) as exc:
                raise ValueError(f"--grid {key}={value!r}: {exc}") from None
    return grid


def run_trial(config: dict[str, Any], *, env_id: str, env_kwargs: dict, base: dict[str, Any], root: str,
              steps: int | None, episodes: int | None, collectors: int, checkpoint_every: int) -> dict[str, Any]:
    """One trial (in a Ray worker): train in ROOT/<trial name>, resuming its checkpoint if there is one."""
    from auv_mj.agents.offpolicy.learners import agent_classes
    from auv_mj.agents.offpolicy.train import train

    agent, seed, params = config["agent"], config["seed"], config["params"]
    overrides = {k: tuple(v) if isinstance(v, list) else v for k, v in {**base, **params}.items()}
    run_dir = Path(root) / trial_name(agent, seed, params)
    resume = (run_dir / CHECKPOINT_NAME).is_file()
    result = train(make_env_fn(env_id, **env_kwargs), agent, agent_classes(agent)[1](**overrides, seed=seed),
                   total_steps=steps, episodes=episodes, run_dir=run_dir, resume=resume,
                   checkpoint_every=checkpoint_every, progress=False, tensorboard=False, collectors=collectors)
    metrics = {"env_steps": result.env_steps, "episodes": result.episodes, "success_rate": result.success_rate,
               "run_dir": str(run_dir)}
    return metrics


def _tune_trial(config: dict[str, Any], **kwargs: Any) -> None:
    from ray import tune

    tune.report(run_trial(config, **kwargs))


def trial_row(run_dir: Path, agent: str, seed: int, params: dict[str, Any]) -> dict[str, Any]:
    """The results-table row of one trial, from its progress.csv."""
    with open(run_dir / LOG_NAME, newline="") as f:
        rows = list(csv.DictReader(f))
    success = np.array([float(r["success"]) for r in rows])
    first = episodes_to(success, TARGET, WINDOW)
    hit = None if math.isnan(first) else rows[int(first) - 1]
    counters = read_checkpoint(run_dir / CHECKPOINT_NAME)[1]["counters"]  # a cut last episode counts too
    steps, wall = int(counters["env_steps"]), float(counters["wall_time"])
    return {"trial": run_dir.name, "agent": agent, "seed": seed, **{k: _value_name(v) for k, v in params.items()},
            "episodes": len(rows), "env_steps": steps,
            "episodes_to_target": None if hit is None else int(first),
            "steps_to_target": None if hit is None else int(hit["steps"]),
            "seconds_to_target": None if hit is None else round(float(hit["wall_time"]), 1),
            "final_success": round(float(success[-WINDOW:].mean()), 3) if rows else None,
            "wall_s": round(wall, 1), "steps_per_s": round(steps / wall, 1) if wall else None}


def results_table(rows: list[dict[str, Any]]) -> str:
    """The results as aligned text, one trial a line ('-' where a trial never reached the target)."""
    columns = list(rows[0]) if rows else list(RESULT_COLUMNS)
    cells = [[("-" if row.get(c) is None else str(row.get(c))) for c in columns] for row in rows]
    widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(columns, widths, strict=True))]
    lines += ["  ".join(v.rjust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(lines)


def write_results(rows: list[dict[str, Any]], path: Path) -> None:
    """results.csv: one row per trial (empty cells where a trial never reached the target)."""
    columns = list(rows[0]) if rows else list(RESULT_COLUMNS)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, columns)
        writer.writeheader()
        writer.writerows({k: ("" if v is None else v) for k, v in row.items()} for row in rows)


def run_sweep(out: str | Path, agents: list[str], seeds: list[int], grid: dict[str, list], *, task: str = "goal",
              env_kwargs: dict | None = None, base: dict[str, Any] | None = None, steps: int | None = None,
              episodes: int | None = None, collectors: int = 0, ray_address: str = "local", workers: int | None = None,
              resume: bool = False, checkpoint_every: int = 20, retries: int = 2,
              progress: bool = True) -> list[dict[str, Any]]:
    """Runs every (agent, grid point, seed) trial on Ray Tune; returns the results table rows (trial order).

    An already started Ray session is used as it is; otherwise Ray starts at `ray_address` ("local" with
    `workers` CPUs) and is shut down at the end. `retries`: reruns of a trial whose worker died (each
    resumes its checkpoint).
    """
    import ray
    from ray import tune

    from auv_mj.console import progress_bar

    out = Path(out).resolve()
    grid = check_grid(dict(grid))
    env_kwargs, base = dict(env_kwargs or {}), dict(base or {})
    env_id = task_env_id(task)
    make_env_fn(env_id, **env_kwargs)().close()  # a bad task or option is refused before any trial starts
    trials = [(agent, params, seed) for agent in agents for params in grid_points(grid) for seed in seeds]
    spec = {"task": task, "env_kwargs": env_kwargs, "agents": agents, "seeds": seeds, "grid": grid, "base": base,
            "steps": steps, "episodes": episodes, "collectors": collectors}
    spec_path = out / SPEC_NAME
    if resume:
        if not spec_path.is_file():
            raise FileNotFoundError(f"--resume: no sweep in {out} ({SPEC_NAME} is missing)")
        saved = json.loads(spec_path.read_text())
        differ = sorted(k for k in spec if k not in EXTENDABLE and saved.get(k) != json.loads(json.dumps(spec[k])))
        if differ:
            raise ValueError(f"--resume: {spec_path} was a sweep with other {', '.join(differ)}: "
                             + "; ".join(f"{k} {saved.get(k)!r}" for k in differ))
    elif spec_path.exists() or any((out / trial_name(a, s, p) / CHECKPOINT_NAME).exists() for a, p, s in trials):
        raise FileExistsError(f"{out} holds a sweep: add --resume to continue it, or choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    spec_path.write_text(json.dumps(spec, indent=2))

    started_here = not ray.is_initialized()
    if started_here:
        if ray_address == "local":
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=ray_address, log_to_driver=False)
    bar = progress_bar(total=len(trials), desc="sweep", unit="trial", disable=not progress)

    class _Bar(tune.Callback):
        def on_trial_complete(self, iteration, trials, trial, **info):
            bar.update(1)

        def on_trial_error(self, iteration, trials, trial, **info):
            bar.update(1)

    try:
        trainable = tune.with_resources(
            tune.with_parameters(_tune_trial, env_id=env_id, env_kwargs=env_kwargs, base=base, root=str(out),
                                 steps=steps, episodes=episodes, collectors=collectors,
                                 checkpoint_every=checkpoint_every),
            {"cpu": collectors + 1})
        space = {"agent": tune.grid_search(agents), "params": tune.grid_search(grid_points(grid)),
                 "seed": tune.grid_search(seeds)}
        tuner = tune.Tuner(trainable, param_space=space, run_config=tune.RunConfig(
            name="tune", storage_path=str(out), verbose=0, callbacks=[_Bar()],
            failure_config=tune.FailureConfig(max_failures=retries)))
        grid_result = tuner.fit()
    finally:
        bar.close()
        if started_here:
            ray.shutdown()
    errors = [r for r in grid_result if r.error is not None]
    rows = [trial_row(out / trial_name(a, s, p), a, s, p) for a, p, s in trials
            if (out / trial_name(a, s, p) / CHECKPOINT_NAME).is_file()]
    write_results(rows, out / RESULTS_NAME)
    if errors:
        failed = ", ".join(trial_name(r.config["agent"], r.config["seed"], r.config["params"]) for r in errors)
        raise RuntimeError(f"{len(errors)} trial(s) failed after {retries} retries: {failed} "
                           f"(the others are in {out / RESULTS_NAME}); first error: {errors[0].error}")
    return rows


def seed_list(text: str) -> list[int]:
    """argparse type of --seeds items: `3` or a range `0-9` (both ends included)."""
    match = re.fullmatch(r"(\d+)(?:-(\d+))?", text.strip())
    if not match:
        raise argparse.ArgumentTypeError(f"a seed is a whole number >= 0 or a range like 0-9, got {text!r}")
    low, high = int(match[1]), int(match[2] or match[1])
    if high < low:
        raise argparse.ArgumentTypeError(f"empty seed range {text!r}")
    return list(range(low, high + 1))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj sweep`."""
    parser.add_argument("agents", nargs="+", choices=AGENTS, help="agents to train (e.g. her-ddpg ddpg)")
    parser.add_argument("--task", default="goal", help="suite task name (domain auv: planar, auv3d: 6-DOF; "
                        "`auv-mj eval --help` lists them) or Gymnasium id")
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON", help="task options")
    parser.add_argument("--arena", default=None, metavar="PATH", help="arena MJCF for the task")
    parser.add_argument("--seeds", type=seed_list, nargs="+", default=[[0]],
                        help="run seeds: 0 1 2 or 0-9 (default: 0)")
    parser.add_argument("--grid", type=json_object, default={}, metavar="JSON",
                        help='DDPGConfig fields and their values, e.g. \'{"noise_std": [0.1, 0.3]}\'')
    parser.add_argument("--steps", type=positive_int, help="env steps per trial (default: --episodes)")
    parser.add_argument("--episodes", type=positive_int, help="episodes per trial (default: max_episodes)")
    parser.add_argument("--collectors", type=bounded_int(0, MAX_PROCESSES), default=0, metavar="N",
                        help="collector processes per trial (`auv-mj train --collectors`); a trial then "
                             "takes N + 1 CPUs (default: 0, serial on one CPU)")
    parser.add_argument("-o", "--out", type=Path, required=True, metavar="DIR",
                        help="sweep folder: one run directory per trial")
    parser.add_argument("--resume", action="store_true", help="continue the sweep in --out from its checkpoints")
    parser.add_argument("--ray", default="local", metavar="ADDRESS",
                        help="'local' (default) starts Ray here; 'auto' or HOST:PORT joins a cluster")
    parser.add_argument("--workers", type=bounded_int(1, MAX_PROCESSES), default=None,
                        help="CPUs of the local Ray (default: all); a trial takes one (N + 1 with --collectors N)")
    parser.add_argument("--checkpoint-every", type=positive_int, default=20, help="episodes between checkpoints")
    parser.add_argument("--retries", type=bounded_int(0, MAX_RETRIES), default=2,
                        help="reruns of a trial whose worker died")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_config_options(parser)


def run(args: argparse.Namespace) -> int:
    """Runs the sweep, prints the results table and writes OUT/results.csv."""
    try:
        distributed.require_ray()
    except ImportError as e:
        usage_error(args, f"auv-mj sweep runs on Ray Tune: {e}")
    if args.workers is not None and args.ray != "local":
        usage_error(args, "--workers sets the CPUs of --ray local only; a cluster's CPUs are its own")
    if args.retries < 0:
        usage_error(args, f"--retries must be >= 0, got {args.retries}")
    if args.collectors < 0:
        usage_error(args, f"--collectors must be >= 0, got {args.collectors}")
    seeds = sorted({s for group in args.seeds for s in group})
    agents = list(dict.fromkeys(args.agents))
    try:
        kwargs = task_kwargs(args)
        others = [a for a in agents if a != "td3"]
        base = config_overrides(argparse.Namespace(**{**vars(args), "agent": others[0] if others else "td3"}))
        rows = run_sweep(args.out, agents, seeds, args.grid, task=args.task,
                         env_kwargs={"task_kwargs": kwargs} if kwargs else {}, base=base,
                         steps=args.steps, episodes=args.episodes, collectors=args.collectors, ray_address=args.ray,
                         workers=args.workers, resume=args.resume, checkpoint_every=args.checkpoint_every,
                         retries=args.retries, progress=not args.no_progress)
    except (ValueError, TypeError, FileNotFoundError, FileExistsError) as exc:
        usage_error(args, str(exc))
    except RuntimeError as exc:
        print(f"{args.prog}: error: {exc}", file=sys.stderr)
        return 1
    print(results_table(rows))
    print(f"wrote {Path(args.out) / RESULTS_NAME}")
    return 0
