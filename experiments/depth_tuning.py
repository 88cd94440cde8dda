"""Tuning the 6-DOF depth-heading S-plane in ocean water: `python experiments/depth_tuning.py --tune`.

The search behind `auv_mj.control.depth_heading.OCEAN_DEPTH_GAINS`, the fair classical baseline of a learned depth
executor, made as the planar `splane-ocean` was (`experiments/splane_tuning.py`): Nelder-Mead over the log-gains
(TUNED_FIELDS, within TUNING_BOUNDS) from the hand-set defaults (`DepthHeadingGains`), on training seeds only.

The cost is the evaluation's own distribution: TUNING_EPISODES episodes of `depth_heading` with random command
schedules and the task's disturbances, in ocean water (current profile, fin and thruster lag, sensor noise, a
scaled vehicle), on the training seeds `train_seed(TUNING_RUN_SEED, k)`. Each episode's MAE of speed, heading
and depth (`auv_mj.episode.episode_metrics`, after the settling steps) is divided by the hand-set controller's
on the same episode, the three ratios are averaged, and CHATTER_WEIGHT times the mean step-to-step change of
the normalised controls is added (as the planar cost does, so that the search does not drift to bang-bang
fins). `--validate N` scores a gain set on N validation seeds (never the test seeds figures are reported on).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from auv_mj.control.depth_heading import OCEAN_DEPTH_GAINS, DepthHeadingGains
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.seeds import VALIDATION, train_seed
from auv_mj.tasks.auv3d import depth_heading, splane_policy

TUNED_FIELDS = ("k1_speed", "k2_speed", "ki_speed", "k1_heading", "k2_heading", "ki_heading", "k1_depth",
                "k2_depth", "ki_depth", "max_pitch", "k1_pitch", "k2_pitch")
"""The gains `--tune` searches over (every gain of the three channels and the pitch loop); bands and the
integral limit stay as set."""
TUNING_BOUNDS = ((0.1, 500.0), (0.01, 100.0), (0.001, 1.0), (0.1, 500.0), (0.01, 100.0), (0.001, 1.0),
                 (0.01, 50.0), (0.01, 50.0), (0.0001, 1.0), (0.05, 0.5), (0.1, 500.0), (0.01, 100.0))
"""Search box of TUNED_FIELDS; max_pitch [rad] stays below 0.5 (29 deg), where REMUS's Munk moment outgrows
the stern planes."""
TASK_KWARGS = {"conditions": "ocean", "command": "random"}
"""The depth_heading episodes of the cost: random command schedules, the task's disturbances, ocean water."""
TUNING_EPISODES = 4
"""Training seeds `train_seed(TUNING_RUN_SEED, k)`, k < TUNING_EPISODES, the cost averages over."""
TUNING_RUN_SEED = 42
"""Run seed of the tuning's training seeds."""
INITIAL_STEP = 0.3
"""Size of the first simplex in log-gain (x1.35 either way)."""
CHATTER_WEIGHT = 0.1
"""Weight of the mean step-to-step change of the normalised controls |du| in the cost."""
CHANNELS = ("mae_speed", "mae_heading", "mae_depth")


def episode_scores(gains: DepthHeadingGains, seed: int, conditions: str | dict = "ocean") -> tuple[np.ndarray, float]:
    """((MAE speed [m/s], heading [rad], depth [m]), chatter) of the S-plane with `gains` on one episode."""
    env = depth_heading(random=seed, **{**TASK_KWARGS, "conditions": conditions})
    record = record_episode(env, splane_policy(env, gains))
    metrics = episode_metrics(record)
    low, high = env.physics.model.actuator_ctrlrange.T
    controls = (record.control[1:] - low) / (high - low) * 2.0
    return np.array([metrics[c] for c in CHANNELS]), float(np.mean(np.abs(np.diff(controls, axis=0))))


class TuningCost:
    """The cost `--tune` minimises (module docstring), on `seeds`; the hand-set controller's MAEs are computed
    once per seed as the reference the ratios are taken to."""

    def __init__(self, seeds: list[int], conditions: str | dict = "ocean"):
        self.seeds, self.conditions = list(seeds), conditions
        self.reference = [episode_scores(DepthHeadingGains(), s, conditions)[0] for s in self.seeds]

    def breakdown(self, gains: DepthHeadingGains) -> tuple[float, np.ndarray, float]:
        """(cost, mean MAEs (speed, heading, depth), mean chatter) of `gains`."""
        scores = [episode_scores(gains, s, self.conditions) for s in self.seeds]
        maes = np.array([m for m, _ in scores])
        chatter = float(np.mean([c for _, c in scores]))
        ratio = float(np.mean(maes / np.maximum(np.array(self.reference), 1e-9)))
        return ratio + CHATTER_WEIGHT * chatter, maes.mean(axis=0), chatter

    def __call__(self, gains: DepthHeadingGains) -> float:
        return self.breakdown(gains)[0]


def tune(start: DepthHeadingGains | None = None, max_evaluations: int = 400, seeds: list[int] | None = None,
         best_file: Path | None = None) -> DepthHeadingGains:
    """Nelder-Mead over log-gains of TUNED_FIELDS (within TUNING_BOUNDS) from `start` (the hand-set defaults), its
    first simplex INITIAL_STEP either way of each log-gain; returns the best gains seen, rounded to 4 significant
    figures. `best_file`: the best so far is written there (JSON, atomically) at each improvement, so that a search
    cut short still leaves its optimum, and `--start` can resume from it."""
    from scipy.optimize import minimize

    from auv_mj.console import progress_bar

    start = start or DepthHeadingGains()
    seeds = seeds or [train_seed(TUNING_RUN_SEED, k) for k in range(TUNING_EPISODES)]
    cost = TuningCost(seeds)
    x0 = np.log([getattr(start, f) for f in TUNED_FIELDS])
    simplex = np.vstack([x0, x0 + INITIAL_STEP * np.eye(len(x0))])
    bar = progress_bar(total=max_evaluations, desc="tune depth S-plane")
    best: dict = {"cost": np.inf, "gains": None, "evaluations": 0}

    def gains_of(x: np.ndarray) -> DepthHeadingGains:
        x = np.clip(x, *np.log(TUNING_BOUNDS).T)
        return replace(start, **{f: float(f"{v:.4g}") for f, v in zip(TUNED_FIELDS, np.exp(x), strict=True)})

    def objective(x: np.ndarray) -> float:
        gains = gains_of(x)
        value = cost(gains)
        best["evaluations"] += 1
        if value < best["cost"]:
            best.update(cost=value, gains=gains)
            if best_file is not None:
                record = {"cost": value, "evaluations": best["evaluations"], "seeds": seeds,
                          "gains": {f: getattr(gains, f) for f in TUNED_FIELDS}}
                temporary = Path(f"{best_file}.tmp")
                temporary.write_text(json.dumps(record, indent=1))
                temporary.replace(best_file)
        if bar.n < max_evaluations:
            bar.update(1)
        bar.set_postfix(best=f"{best['cost']:.4f}")
        return value

    minimize(objective, x0, method="Nelder-Mead", bounds=np.log(TUNING_BOUNDS),
             options={"maxfev": max_evaluations, "xatol": 0.02, "fatol": 1e-4, "adaptive": True,
                      "initial_simplex": simplex})
    bar.update(max_evaluations - bar.n)
    bar.close()
    return best["gains"]


def read_gains(path: Path) -> DepthHeadingGains:
    """The gains of a `--best` file (hand-set values for any field it leaves out)."""
    try:
        record = json.loads(Path(path).read_text())
        return replace(DepthHeadingGains(), **{f: float(v) for f, v in record["gains"].items() if f in TUNED_FIELDS})
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: not a tuning record with a 'gains' object ({e})") from None


def main(argv: list[str] | None = None) -> int:
    """`python experiments/depth_tuning.py [--tune] [--validate N]`."""
    parser = argparse.ArgumentParser(prog="python experiments/depth_tuning.py", description=__doc__.splitlines()[0])
    parser.add_argument("--tune", action="store_true", help="run the Nelder-Mead search from the hand-set gains")
    parser.add_argument("--max-evaluations", type=int, default=400)
    parser.add_argument("--validate", type=int, default=0, metavar="N",
                        help="score the hand-set and the ocean gains (and the tuned ones) on N validation seeds")
    parser.add_argument("--best", type=Path, help="write the best gains so far here (JSON) while tuning")
    parser.add_argument("--start", type=Path, help="start (or resume) from the gains of a --best file")
    args = parser.parse_args(argv)
    if args.max_evaluations < 1 or args.validate < 0:
        parser.error(f"--max-evaluations must be >= 1 and --validate >= 0, got {args.max_evaluations}, "
                     f"{args.validate}")
    if args.best is not None and not args.best.parent.is_dir():
        parser.error(f"--best {args.best}: folder {args.best.parent} does not exist")
    start = read_gains(args.start) if args.start else None
    candidates = {"hand-set": DepthHeadingGains(), "OCEAN_DEPTH_GAINS": OCEAN_DEPTH_GAINS}
    if start is not None:
        candidates["start"] = start
    if args.tune:
        seeds = [train_seed(TUNING_RUN_SEED, k) for k in range(TUNING_EPISODES)]
        gains = tune(start, max_evaluations=args.max_evaluations, seeds=seeds, best_file=args.best)
        print("tuned:", ", ".join(f"{k}={v}" for k, v in asdict(gains).items() if k in TUNED_FIELDS))
        for name, g in {"hand-set": DepthHeadingGains(), "tuned": gains}.items():
            cost, maes, chatter = TuningCost(seeds).breakdown(g)
            print(f"training cost {name}: {cost:.4f}  MAE speed {maes[0]:.4f} heading {maes[1]:.4f} "
                  f"depth {maes[2]:.4f}  chatter {chatter:.4f}")
        candidates["tuned"] = gains
    if args.validate:
        seeds = list(VALIDATION[:args.validate])
        cost = TuningCost(seeds)
        for name, g in candidates.items():
            value, maes, chatter = cost.breakdown(g)
            print(f"validation ({args.validate} seeds) {name}: cost {value:.4f}  MAE speed {maes[0]:.4f} "
                  f"heading {maes[1]:.4f} depth {maes[2]:.4f}  chatter {chatter:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
