"""`auv-mj reproduce`: the reproduction report, our numbers measured now beside the paper's.

Covers Table 9 (executor vs S-plane under disturbances), Tables 10-11 (line and curve following),
Fig. 8 (HER-DDPG vs DDPG learning curves, from the training logs in `--runs`), the named scenarios
of Tables 6-8 and 12, the issue's planner targets on random layouts, and the same under ocean conditions
(`auv_mj.sim.ocean`: current, thruster lag, sonar noise, model uncertainty) beside the ideal ones. Every number
is printed with the command that reproduces it; `--sections` runs a subset.
"""

from __future__ import annotations

import argparse
import datetime
import math
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from auv_mj import seeds
from auv_mj.cli import evaluate, plots, policies
from auv_mj.cli.options import check_output, positive_int, usage_error
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.sim import ocean

PAPER_TABLE9 = {  # Table 9: MAE of speed [m/s] and heading [rad] per disturbance phase
    "splane": {"instantaneous": (0.0089, 0.0080), "constant": (0.0460, 0.0028), "periodic": (0.0421, 0.0448)},
    "executor": {"instantaneous": (0.0032, 0.0041), "constant": (0.0174, 0.0001), "periodic": (0.0045, 0.0030)},
}
PAPER_TRACKING = {  # Tables 10-11: (MAE speed, MAE heading, MAX speed, MAX heading)
    "path_line": (0.00703, 0.02618, 0.03034, 0.04697),
    "path_curve": (0.01025, 0.03201, 0.05763, 0.07950),
}
SCENARIOS = (  # (label, paper table, task, task kwargs)
    ("goal a1", "Table 6 (a)1", "goal", {"scenario": "a1"}),
    ("goal a2", "Table 6 (a)2", "goal", {"scenario": "a2"}),
    ("goal a3", "Table 6 (a)3", "goal", {"scenario": "a3"}),
    ("waypoints b1", "Table 6 (b)1", "waypoints", {"layout": "b1"}),
    ("waypoints b2", "Table 6 (b)2", "waypoints", {"layout": "b2"}),
    ("waypoints c", "Table 6 (c), Fig. 9c", "waypoints", {"layout": "c"}),
    ("waypoints d", "Table 6 (d), Fig. 9d", "waypoints", {"layout": "d"}),
    ("obstacles a", "Table 7 a", "obstacles", {"scenario": "a"}),
    ("obstacles b", "Table 7 b", "obstacles", {"scenario": "b"}),
    ("moving a", "Table 8 a", "moving_obstacles", {"scenario": "a"}),
    ("moving b", "Table 8 b", "moving_obstacles", {"scenario": "b"}),
    ("tunnel", "Table 12", "tunnel", {}),
)
SCENARIO_POLICIES = ("two-layer", "planner", "splane")
TRACKING_POLICIES = ("los-executor", "splane")
RANDOM_TARGETS = (("goal", 0.95, None), ("obstacles", 0.90, 0.02))
"""(task, success target, collision ceiling) of the planner on random layouts (the issue's targets)."""
FIG8_TARGET = 0.9
OCEAN_TASKS = ("obstacles", "moving_obstacles")
"""Random-layout tasks of the ocean comparison (held-out seeds from 10000)."""
OCEAN_POLICIES = ("planner", "two-layer", "splane", "los-avoid")
"""The learned planners and the classical baselines, compared in ideal and ocean conditions."""
CONDITIONS = ("ideal", "ocean")
HELD_OUT_SEED = 10_000
"""First seed of the held-out layouts (never used in training)."""


def _fmt(value: float, digits: int = 4) -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def table9(lines: list[str]) -> None:
    """Table 9: MAE of speed and heading per disturbance phase, learned executor vs S-plane."""
    lines += ["## Table 9: execution layer vs S-plane under disturbances", "",
              "Speed 1.0 m/s and heading pi/12 held through a 180 N burst (10 steps from step 250), a 30 N "
              "constant force (350 steps from 350) and a 25 sin(0.01 pi t) N force (350 steps from 750).", "",
              "| controller | phase | MAE speed ours | MAE speed paper | MAE heading ours | MAE heading paper |",
              "| --- | --- | --- | --- | --- | --- |"]
    for name in ("executor", "splane"):
        summary = evaluate.evaluate(name, ["speed_heading"], 1, 0, progress=False)["tasks"]["speed_heading"]
        for phase, (paper_v, paper_h) in PAPER_TABLE9[name].items():
            lines.append(f"| {name} | {phase} | {_fmt(summary.get(f'mae_speed_{phase}'))} | {paper_v} | "
                         f"{_fmt(summary.get(f'mae_heading_{phase}'))} | {paper_h} |")
    lines += ["", "Command: `auv-mj eval --policy executor --task speed_heading --episodes 1` (and "
              "`--policy splane`).", ""]


def tracking_errors(name: str, task: str, conditions: str = "ideal") -> tuple[float, ...]:
    """(MAE speed, MAE heading, MAX speed, MAX heading, cross-track MAE) of one episode, once on the path
    (the steps the task marks `tracked`: `auv_mj.episode.episode_metrics`)."""
    m = evaluate.run_episode(name, task, 0, {"conditions": conditions})
    return m["mae_speed"], m["mae_heading"], m["max_speed"], m["max_heading"], m["mae_cross_track"]


def tracking(lines: list[str]) -> None:
    """Tables 10-11: speed and heading tracking along the line and the curve, once on the path."""
    lines += ["## Tables 10-11: line and curve following", "",
              "Errors of speed and heading against the executor's command and the cross-track error, from the "
              "moment the vehicle reaches the path's first point (the drive to the path is left out, as the paper "
              "does; the tasks mark these steps `tracked`). `los-executor` = line-of-sight guidance on the "
              "learned DDPG executor; `splane` = the same guidance on the S-plane controller.", "",
              "| path | controller | MAE speed | MAE heading | MAX speed | MAX heading | cross-track MAE [m] |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for task, paper in PAPER_TRACKING.items():
        lines.append(f"| {task} | paper (DDPG) | {paper[0]} | {paper[1]} | {paper[2]} | {paper[3]} | n/a |")
        for name in TRACKING_POLICIES:
            *errors, cross = tracking_errors(name, task)
            lines.append(f"| {task} | {name} | {' | '.join(_fmt(e) for e in errors)} | {_fmt(cross, 2)} |")
    lines += ["", "Command: `auv-mj eval --policy los-executor --task path_line --episodes 1` (the same figures).",
              ""]


def episodes_to(success: np.ndarray, target: float, window: int = 20) -> float:
    """First episode at which the trailing `window`-episode success rate reaches `target` (NaN if never)."""
    if len(success) < window:
        return math.nan
    rates = np.convolve(success, np.ones(window) / window, mode="valid")
    hits = np.flatnonzero(rates >= target)
    return float(hits[0] + window) if hits.size else math.nan


def fig8_logs(runs: Path, agent: str) -> list[Path]:
    """The training logs of `agent` in `runs`: `<agent>-seed*.csv` files, or the `<agent>-seed*/progress.csv`
    of the run directories an `auv-mj sweep` (or `auv-mj train --run-dir`) writes there."""
    files = sorted(runs.glob(f"{agent}-seed*.csv"))
    runs_dirs = sorted(p / "progress.csv" for p in runs.glob(f"{agent}-seed*") if (p / "progress.csv").is_file())
    return sorted(files + runs_dirs, key=lambda p: _seed_of(p))


def _seed_of(path: Path) -> int:
    name = path.parent.name if path.name == "progress.csv" else path.stem
    digits = name.rpartition("seed")[2]
    return int(digits) if digits.isdigit() else -1


def mean_ci(values: list[float]) -> tuple[float, float]:
    """Mean and the half-width of its 95 % confidence interval (Student's t); half-width NaN for one value."""
    from scipy import stats

    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        return float(np.mean(values)) if len(values) else math.nan, math.nan
    half = stats.t.ppf(0.975, len(values) - 1) * values.std(ddof=1) / math.sqrt(len(values))
    return float(values.mean()), float(half)


def fig8(lines: list[str], runs: Path, figures: Path, observation: str = "relative") -> None:
    """Fig. 8: HER-DDPG vs DDPG on `goal`, learning curves over seeds from the training logs in `runs`, made
    with the task's `observation` ("relative", its default, or "paper", Table 2's absolute one).

    The claim is tested, not eyeballed: a one-sided Mann-Whitney U test of the episodes to FIG8_TARGET
    (runs that never reach it rank last), HER-DDPG fewer; the band of the curves is the 95 % confidence
    interval of the mean over seeds.
    """
    from scipy import stats

    paper = observation == "paper"
    lines += ["## Fig. 8: HER-DDPG vs plain DDPG on `goal`"
              + (", on the paper's absolute observation (Table 2)" if paper else ""), ""]
    groups = [(label, fig8_logs(runs, agent)) for label, agent in (("HER-DDPG", "her-ddpg"), ("DDPG", "ddpg"))]
    if not all(files for _, files in groups):
        lines += [f"No training logs in `{runs}` (expected `her-ddpg-seed*.csv` and `ddpg-seed*.csv`, or the "
                  "run directories `her-ddpg-seed*/` and `ddpg-seed*/` of `auv-mj sweep`).", ""]
        return
    figure = plots.plot_learning([(label, [str(f) for f in files]) for label, files in groups],
                                 figures / ("fig8_paper_observation.png" if paper else "fig8_learning.png"),
                                 band="ci", title=f"goal{' (paper observation)' if paper else ''}: HER-DDPG vs "
                                                  "DDPG (band: 95 % confidence interval of the mean)")
    lines += [f"![learning curves]({figure.relative_to(figures.parent)})", "",
              f"| algorithm | run | episodes | env steps | mean success over the run | final success (last 20) | "
              f"episodes to {FIG8_TARGET:.0%} success (20-episode window) |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    reached_by: dict[str, list[float]] = {}
    for label, files in groups:
        reached = []
        for f in files:
            data = plots.read_learning_csv(f)
            success = np.asarray(data["success"], dtype=float)
            first = episodes_to(success, FIG8_TARGET)
            reached.append(first)
            name = f.parent.name if f.name == "progress.csv" else f.stem
            lines.append(f"| {label} | {name} | {len(success)} | {int(data['steps'][-1])} | "
                         f"{success.mean():.2f} | {success[-20:].mean():.2f} | {_fmt(first, 0)} |")
        reached_by[label] = [math.inf if math.isnan(r) else r for r in reached]
    lines += ["", f"| algorithm | runs | reached {FIG8_TARGET:.0%} | median episodes to {FIG8_TARGET:.0%} | "
              "mean +- 95 % CI (runs that reached it) |", "| --- | --- | --- | --- | --- |"]
    for label, reached in reached_by.items():
        finite = [r for r in reached if math.isfinite(r)]
        mean, half = mean_ci(finite) if finite else (math.nan, math.nan)
        lines.append(f"| {label} | {len(reached)} | {len(finite)} | {float(np.median(reached)):.0f} | "
                     f"{_fmt(mean, 1)} +- {_fmt(half, 1)} |")
    her, ddpg = reached_by["HER-DDPG"], reached_by["DDPG"]
    p_fewer = float(stats.mannwhitneyu(her, ddpg, alternative="less").pvalue)
    p_more = float(stats.mannwhitneyu(her, ddpg, alternative="greater").pvalue)
    if all(math.isinf(r) for r in her + ddpg):
        verdict = "undecided: no run reached the target within the budget"
    elif p_fewer < 0.05:
        verdict = f"reproduced (one-sided Mann-Whitney U, p = {p_fewer:.3f})"
    elif p_more < 0.05:
        verdict = f"NOT reproduced: plain DDPG reaches it in fewer episodes (p = {p_more:.3f})"
    else:
        verdict = (f"not shown: the difference is within the spread of the seeds (one-sided Mann-Whitney U, "
                   f"p = {p_fewer:.3f} for HER-DDPG fewer)")
    lines += ["", f"Fig. 8's claim (HER-DDPG reaches {FIG8_TARGET:.0%} in fewer episodes): **{verdict}**.", "",
              "Command: `auv-mj sweep her-ddpg ddpg --task goal "
              + ("--task-kwargs '{\"observation\": \"paper\"}' " if paper else "")
              + f"--seeds 0-9 --steps N --out OUT`, then `auv-mj reproduce --{'paper-' if paper else ''}runs OUT` "
              f"(or single `auv-mj train` runs' `progress.csv` copied to `{runs}` as `<agent>-seed<S>.csv`).", ""]


PEER_GROUPS = {"auv-mj HER-DDPG": "auv-mj-her-ddpg-seed*.csv",
               "auv-mj HER-DDPG, --collectors 1": "auv-mj-collectors1-seed*.csv",
               "SB3 DDPG+HER": "sb3-*.csv"}
"""Trainer -> the logs of its runs in the peer folder (the collectors runs are optional)."""


def training_speed(lines: list[str], runs: Path) -> None:
    """Ours against the SB3 DDPG+HER peer on `goal`, from logs of runs made one after another: raw env steps/s
    at the same updates per step (the speed figure), and wall-clock to 90 % success where both reached it (a
    learning figure too, so no ratio is drawn where one did not)."""
    from auv_mj.cli.sb3_peer import TARGET, WINDOW, time_to_success

    lines += ["## Training speed: auv-mj vs the Stable-Baselines3 peer", "",
              f"Each run alone on the machine, one after another (`--collectors 1` uses both cores, the others one); "
              f"time to {TARGET:.0%} success over a {WINDOW}-episode window.", "",
              "| trainer | run | wall s to target | env steps to target | env steps | wall s | env steps/s | "
              f"final success (last {WINDOW}) |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    groups = {label: sorted(runs.glob(pattern)) for label, pattern in PEER_GROUPS.items()}
    ours, peer = "auv-mj HER-DDPG", "SB3 DDPG+HER"
    if not (groups[ours] and groups[peer]):
        lines += [f"No peer logs in `{runs}` (expected `{PEER_GROUPS[ours]}` and `{PEER_GROUPS[peer]}`).", ""]
        return
    rates: dict[str, float] = {}
    to_target: dict[str, list[float]] = {}
    for label, files in groups.items():
        speeds, times = [], []
        for f in files:
            data = plots.read_learning_csv(f)
            wall, steps = time_to_success(f)
            total_steps, total_wall = int(data["steps"][-1]), float(data["wall_time"][-1])
            times.append(wall)
            speeds.append(total_steps / total_wall)
            final = float(np.mean(np.asarray(data["success"], dtype=float)[-WINDOW:]))
            lines.append(f"| {label} | {f.stem} | {_fmt(wall, 0)} | {steps if steps >= 0 else 'never'} | "
                         f"{total_steps} | {total_wall:.0f} | {total_steps / total_wall:.0f} | {final:.2f} |")
        if files:
            rates[label] = float(np.median(speeds))
            to_target[label] = times
    lines += ["", "Raw throughput at the same updates per step (one gradient step per env step each), medians over "
              f"runs: {', '.join(f'{label} {rate:.0f}' for label, rate in rates.items())} env steps/s; "
              f"auv-mj / SB3 = **{rates[ours] / rates[peer]:.2f}** in one process each"]
    both = "auv-mj HER-DDPG, --collectors 1"
    if both in rates:
        lines[-1] += (f", and **{rates[both] / rates[peer]:.2f}** with a collector (two processes against "
                      f"SB3's one; **{rates[both] / rates[ours]:.2f}** over our serial loop)")
    lines[-1] += "."
    sentences = []
    for label, times in to_target.items():
        reached = [t for t in times if not math.isnan(t)]
        sentences.append(f"{label} in {len(reached)} of {len(times)} runs"
                         + (f" (median {np.median(reached):.0f} s)" if reached else ""))
    lines += ["", f"Reached {TARGET:.0%} success: " + "; ".join(sentences) + "."]
    if all(not math.isnan(t) for t in to_target[ours] + to_target[peer]):
        lines[-1] += (f" SB3 / auv-mj wall-clock to the target = "
                      f"**{np.median(to_target[peer]) / np.median(to_target[ours]):.2f}**.")
    else:
        lines[-1] += (" Where a trainer did not reach the target no time ratio is drawn: that is a difference in "
                      "learning at these settings, not in speed.")
    lines += ["", "The peer is SB3 as its users would run it here: observations normalised by `VecNormalize` and "
              "Gaussian action noise of std 0.3 (with raw goals in metres and std 0.1 its actor saturates at V = 0 "
              "and never explores forward).", "",
              "Commands: `python -m auv_mj.cli.sb3_peer --steps N --seed S --csv sb3-ddpg-her-seedS.csv`, "
              "`auv-mj train her-ddpg --task goal --seed S --steps N` and the same with `--collectors 1` (their "
              f"`progress.csv` as `auv-mj-her-ddpg-seedS.csv` and `auv-mj-collectors1-seedS.csv`), in `{runs}`.", ""]


def scenarios(lines: list[str], figures: Path) -> None:
    """The named scenarios of Tables 6-8 and 12 with each policy (one deterministic episode each)."""
    lines += ["## Scenarios of Tables 6-8 and 12", "",
              "One episode per scenario (start, goal and obstacles from the table; obstacle shapes ours). "
              "`two-layer` = HER-DDPG planner on the DDPG executor (Sec. 4.3); `planner` = HER-DDPG on the "
              "S-plane executor; `splane` = line-of-sight guidance on S-plane (no avoidance).", "",
              "| scenario | paper | policy | outcome | min clearance [m] | path length [m] | time [s] |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for label, table, task, kwargs in SCENARIOS:
        records = []
        for name in SCENARIO_POLICIES:
            env, policy = policies.env_and_policy(name, task, 0, kwargs)
            record = record_episode(env, policy, task=task, policy_name=name)
            records.append(record)
            m = episode_metrics(record)
            lines.append(f"| {label} | {table} | {name} | {m['outcome']} | {_fmt(m['min_clearance'], 1)} | "
                         f"{m['path_length']:.0f} | {record.time[-1]:.0f} |")
        name = label.replace(" ", "_")
        plots.plot_trajectory(records, figures / f"{name}.png", labels=list(SCENARIO_POLICIES),
                              title=f"{label} ({table})")
    lines += ["", "Figures: " + ", ".join(f"[{label}](figures/{label.replace(' ', '_')}.png)"
                                         for label, *_ in SCENARIOS), "",
              "Command: e.g. `auv-mj render --task tunnel --policy two-layer -o tunnel.mp4` or "
              "`auv-mj eval --policy two-layer --task tunnel --episodes 1`.", ""]


def random_targets(lines: list[str], episodes: int) -> None:
    """The planner on random layouts: success and collision rates over held-out seeds."""
    lines += ["## Planner on random layouts (held-out seeds)", "",
              "| task | policy | episodes | success | target | collisions | ceiling | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task, target, ceiling in RANDOM_TARGETS:
        summary = evaluate.evaluate("planner", [task], episodes, HELD_OUT_SEED, progress=False)["tasks"][task]
        lines.append(f"| {task} | planner | {episodes} | {summary['success_rate']:.2f} | >= {target} | "
                     f"{summary['collision_rate']:.2f} | {'<= ' + str(ceiling) if ceiling else '-'} | "
                     f"{_fmt(summary['min_clearance'], 1)} |")
    lines += ["", f"Command: `auv-mj eval --policy planner --task goal --episodes {episodes} --seed 10000` "
              "(seeds from 10000 are never used in training).", ""]


GENERALISATION_POLICIES = ("two-layer-general", "two-layer-e2e", "two-layer", "los-avoid", "splane")
"""The planners trained on random arenas (residual on line of sight, and end to end) and the paper's planner (all
with the protection domain, on the learned executor) against the classical local planner and plain line of
sight."""
BENCHMARK_EPISODES = 200
"""Held-out arenas per set in the "benchmark" section (issue 15's size)."""
BENCHMARK_POLICIES = (("two-layer-general", {}), ("planner-general", {}), ("planner-general", {"executor": "executor"}),
                      ("los-avoid", {}))
"""(policy, extra task options): the general planner on the best learned executor (its two-layer system), on the
S-plane and on the paper's DDPG executor (Eq. 27-30), and the classical local planner."""
BENCHMARK_TARGETS = (0.95, 0.01)
"""(success floor, collision ceiling) of the general planner on each held-out set (issue 15)."""
SCENARIO_CLEARANCE = 5.0
"""Least clearance [m] the general planner keeps in every scenario of Tables 6-8 and 12 (issue 15)."""
GENERALISATION_SETS = (  # (label, task, task kwargs)
    ("random tunnels", "tunnel", {"arena": "random"}),
    ("random obstacles", "obstacles", {}),
    ("random moving obstacles", "moving_obstacles", {}),
)
TRAINING_RUN_SEED = 0
"""Run seed of the shipped planner's training: its episodes' arenas are the "training arenas" rows."""


def _policy_set(name: str, task: str, kwargs: dict, seeds: list[int]) -> dict:
    return evaluate.summarise([evaluate.run_episode(name, task, s, kwargs) for s in seeds])


def generalisation(lines: list[str], episodes: int, figures: Path, workers: int = 1) -> None:
    """Success, collisions and time on arenas the planner trained on versus held-out ones, every policy."""
    held_out = [seeds.TEST.start + i for i in range(episodes)]
    trained = [seeds.train_seed(TRAINING_RUN_SEED, i) for i in range(max(1, episodes // 4))]
    lines += ["## Generalisation: held-out arenas", "",
              f"Held-out arenas are drawn from test seeds {held_out[0]}..{held_out[-1]} (never used to train or to "
              f"choose a model; validation seeds {seeds.VALIDATION.start}+ chose the planner); training arenas "
              f"from the seeds of the planner's own training episodes (`auv_mj.seeds.train_seed(0, i)`, "
              f"{len(trained)} of them). Time to goal is over successful episodes.", "",
              "| set | arenas | policy | episodes | success | collisions | outcomes | time to goal [s] | "
              "min clearance [m] |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    gallery = []
    for label, task, kwargs in GENERALISATION_SETS:
        for split, chosen in (("held-out", held_out), ("training", trained)):
            for name in GENERALISATION_POLICIES:
                s = (evaluate.evaluate(name, [task], episodes, held_out[0], progress=False, task_kwargs=kwargs,
                                       workers=workers)["tasks"][task] if split == "held-out"
                     else _policy_set(name, task, kwargs, chosen))
                outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
                lines.append(f"| {label} | {split} | {name} | {s['episodes']} | {s['success_rate']:.2f} | "
                             f"{s['collision_rate']:.2f} | {outcomes} | {_fmt(s['time_to_goal'], 0)} | "
                             f"{_fmt(s['min_clearance'], 1)} |")
        if task == "tunnel":
            for seed in held_out[:6]:
                records = []
                for name in ("two-layer-general", "los-avoid"):
                    env, policy = policies.env_and_policy(name, task, seed, kwargs)
                    records.append(record_episode(env, policy, task=task, policy_name=name, seed=seed))
                gallery.append(records)
    if gallery:
        titles = [f"seed {r[0].seed}: " + ", ".join(f"{x.policy} {episode_metrics(x)['outcome']}" for x in r)
                  for r in gallery]
        plots.plot_gallery(gallery, figures / "heldout_tunnels.png", titles=titles)
        lines += ["", "![held-out tunnels](figures/heldout_tunnels.png)"]
    lines += ["",
              f"Commands: `auv-mj eval --policy two-layer-general --task tunnel --arena random --episodes {episodes} "
              f"--seed {seeds.TEST.start} --workers 2` (and `--task obstacles`, `--task moving_obstacles`; `--policy "
              "two-layer`, `los-avoid`, `splane`).", ""]


def benchmark(lines: list[str], workers: int) -> None:
    """Issue 15's bar: BENCHMARK_EPISODES held-out arenas per set for the general planner and `los-avoid`, and
    every paper scenario with at least SCENARIO_CLEARANCE of clearance."""
    floor, ceiling = BENCHMARK_TARGETS
    lines += ["## Held-out benchmark: the general planner against the classical local planner", "",
              f"{BENCHMARK_EPISODES} held-out arenas per set (test seeds {seeds.TEST.start}.."
              f"{seeds.TEST.start + BENCHMARK_EPISODES - 1}); target: success >= {floor}, collisions <= {ceiling}, "
              "at least `los-avoid`'s success and a shorter mean time to the goal (over each policy's "
              "successful episodes).", "",
              "| set | policy | episodes | success | collisions | outcomes | time to goal [s] | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    verdicts = []
    for label, task, kwargs in GENERALISATION_SETS:
        results = {}
        for name, extra in BENCHMARK_POLICIES:
            run = evaluate.evaluate(name, [task], BENCHMARK_EPISODES, seeds.TEST.start, progress=False,
                                    task_kwargs={**kwargs, **extra}, workers=workers)
            shown = name + (f" (executor: {extra['executor']})" if extra else "")
            s = results[shown] = run["tasks"][task]
            outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
            lines.append(f"| {label} | {shown} | {s['episodes']} | {s['success_rate']:.3f} | {s['collision_rate']:.3f} "
                         f"| {outcomes} | {_fmt(s['time_to_goal'], 0)} | {_fmt(s['min_clearance'], 1)} |")
        ours, classical = results["two-layer-general"], results["los-avoid"]
        met = (ours["success_rate"] >= floor and ours["collision_rate"] <= ceiling
               and ours["success_rate"] >= classical["success_rate"]
               and (ours["time_to_goal"] or math.inf) < (classical["time_to_goal"] or math.inf))
        verdicts.append(f"{label}: **{'met' if met else 'NOT met'}**")
    lines += ["", "Target (two-layer-general): " + "; ".join(verdicts) + ".", "",
              "### Every paper scenario", "",
              f"`two-layer-general` on the scenarios of Tables 6-8 and 12 (one episode each); target: the goal with "
              f">= {SCENARIO_CLEARANCE:g} m clearance.", "",
              "| scenario | paper | outcome | min clearance [m] | time [s] |", "| --- | --- | --- | --- | --- |"]
    short = []
    for label, table, task, kwargs in SCENARIOS:
        m = evaluate.run_episode("two-layer-general", task, 0, kwargs)
        ok = m["outcome"] == "goal" and (m["min_clearance"] is None or m["min_clearance"] >= SCENARIO_CLEARANCE)
        short += [] if ok else [label]
        lines.append(f"| {label} | {table} | {m['outcome']} | {_fmt(m['min_clearance'], 1)} | "
                     f"{_fmt(m['time_to_goal'], 0)} |")
    lines += ["", f"Scenarios: **{'all met' if not short else 'NOT met: ' + ', '.join(short)}**.", "",
              f"Commands: `auv-mj eval --policy two-layer-general --task tunnel --arena random --episodes "
              f"{BENCHMARK_EPISODES} --seed {seeds.TEST.start} --workers 2` (and `--task obstacles`, `--task "
              "moving_obstacles`; `--policy planner-general`, `los-avoid`; the paper's executor: `--policy "
              "planner-general --task-kwargs '{\"executor\": \"executor\"}'`); `auv-mj eval --policy two-layer-general "
              "--task obstacles --task-kwargs '{\"scenario\": \"a\"}' --episodes 1 --seed 0`.", ""]


def _worse(label: str, speed: tuple, heading: tuple) -> list[str]:
    """"label: speed/heading MAE a -> b" for each (ideal, ocean) MAE pair that at least tripled and grew by
    0.02 or more: what the report calls broken."""
    return [f"{label}: {what} MAE {before:.4f} -> {after:.4f}" for what, (before, after) in
            (("speed", speed), ("heading", heading))
            if before is not None and after is not None and after > max(3 * before, before + 0.02)]


def ocean_conditions(lines: list[str], episodes: int) -> None:
    """The same planners, executors and baselines under ocean conditions beside ideal ones, and what breaks."""
    c = ocean.OCEAN
    lines += ["## Ocean conditions", "",
              "`conditions=\"ocean\"` (`auv_mj/sim/ocean.py`, README \"Ocean conditions\"): a Gauss-Markov current of "
              f"{c.current.mean_speed} m/s mean (spread {c.current.speed_sigma} m/s, at most "
              f"{c.current.speed_bounds[1]} m/s, direction random per episode), thrust and yaw moment lagged "
              "(0.4 s and 0.2 s, MuJoCo filterexact), sonar noise of "
              f"{c.sonar.floor} m + {c.sonar.proportional:.0%} of range with {c.sonar.dropout:.0%} dropouts and "
              f"the previous ping ({c.sonar.latency} ping latency), and every hydrodynamic coefficient scaled by "
              f"up to +-{c.model_uncertainty.hydrodynamics:.0%} and the mass by up to "
              f"+-{c.model_uncertainty.mass:.0%} per episode, unknown to the controllers. The same seeds give the "
              "same layouts in both columns.", "",
              f"### Planners and classical baselines on held-out random layouts (seeds from {HELD_OUT_SEED})", "",
              "| task | policy | episodes | success ideal | success ocean | collisions ideal | collisions ocean | "
              "min clearance ideal [m] | min clearance ocean [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    broken = []
    for task in OCEAN_TASKS:
        for name in OCEAN_POLICIES:
            summary = {condition: evaluate.evaluate(name, [task], episodes, HELD_OUT_SEED, progress=False,
                                                    task_kwargs={"conditions": condition})["tasks"][task]
                       for condition in CONDITIONS}
            ideal, rough = summary["ideal"], summary["ocean"]
            lines.append(f"| {task} | {name} | {episodes} | {ideal['success_rate']:.2f} | "
                         f"{rough['success_rate']:.2f} | {ideal['collision_rate']:.2f} | "
                         f"{rough['collision_rate']:.2f} | {_fmt(ideal['min_clearance'], 1)} | "
                         f"{_fmt(rough['min_clearance'], 1)} |")
            if rough["success_rate"] < ideal["success_rate"] - 0.1:
                broken.append(f"`{name}` on `{task}`: success {ideal['success_rate']:.2f} -> "
                              f"{rough['success_rate']:.2f}, collisions {ideal['collision_rate']:.2f} -> "
                              f"{rough['collision_rate']:.2f}")
    lines += ["", f"Command: `auv-mj eval --policy planner --task obstacles --episodes {episodes} "
              f"--seed {HELD_OUT_SEED} --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (and `\"ideal\"`, the default).", "",
              "### Table 9 under ocean conditions", "",
              "| controller | phase | MAE speed ideal | MAE speed ocean | MAE heading ideal | MAE heading ocean |",
              "| --- | --- | --- | --- | --- | --- |"]
    for name in ("executor", "splane"):
        summary = {condition: evaluate.evaluate(name, ["speed_heading"], 1, 0, progress=False,
                                                task_kwargs={"conditions": condition})["tasks"]["speed_heading"]
                   for condition in CONDITIONS}
        for phase in PAPER_TABLE9[name]:
            speed = [summary[condition].get(f"mae_speed_{phase}") for condition in CONDITIONS]
            heading = [summary[condition].get(f"mae_heading_{phase}") for condition in CONDITIONS]
            lines.append(f"| {name} | {phase} | {_fmt(speed[0])} | {_fmt(speed[1])} | {_fmt(heading[0])} | "
                         f"{_fmt(heading[1])} |")
            broken += _worse(f"`{name}` on speed_heading, {phase} phase", speed, heading)
    lines += ["", "Command: `auv-mj eval --policy executor --task speed_heading --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (and `--policy splane`).", "",
              "### Tables 10-11 under ocean conditions", "",
              "| path | controller | conditions | MAE speed | MAE heading | MAX speed | MAX heading | "
              "cross-track MAE [m] |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task in PAPER_TRACKING:
        for name in TRACKING_POLICIES:
            errors = {}
            for condition in CONDITIONS:
                errors[condition] = tracking_errors(name, task, condition)
                *maes, cross = errors[condition]
                lines.append(f"| {task} | {name} | {condition} | {' | '.join(_fmt(e) for e in maes)} | "
                             f"{_fmt(cross, 2)} |")
            (speed, heading, *_), (rough_speed, rough_heading, *_) = errors["ideal"], errors["ocean"]
            broken += _worse(f"`{name}` on {task}", (speed, rough_speed), (heading, rough_heading))
    lines += ["", "Command: `auv-mj eval --policy los-executor --task path_line --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (errors once on the path).", "",
              "What breaks (success down by more than 0.1, or a tracking MAE tripled and up by 0.02 or more): "
              + ("; ".join(broken) if broken else "nothing by these measures") + ".", ""]


EXECUTOR_ROWS = (("executor", "DDPG executor, Eq. 27-30 (the paper's row)"),
                 ("ocean-executor", "TD3 scheduling the S-plane's gains, trained in ocean water"),
                 ("splane", "S-plane, nominal gains"), ("splane-ocean", "S-plane re-tuned in ocean water"))
"""Every executor of the executor comparison: speed_heading policy name, what it is."""
EXECUTOR_SEED = seeds.TEST.start
"""First held-out seed of the executor comparison (the ocean draw differs per seed)."""
SYSTEM_TASKS = (("obstacles", {}), ("moving_obstacles", {}), ("tunnel", {"arena": "random"}))
"""Held-out random arenas of the two-layer comparison under ocean conditions."""
SYSTEM_EPISODES = 100
"""Held-out arenas per task for the two-layer system in ocean water (issue 17: does success drop?)."""


def _executor_table9(lines: list[str], episodes: int) -> dict:
    """Table 9 in ideal and ocean water for every executor, mean over `episodes` held-out seeds."""
    lines += ["### Table 9, ideal and ocean water", "",
              f"The Sec. 4.2 schedule (1.0 m/s, pi/12; burst, constant and periodic forces), {episodes} held-out seeds "
              f"from {EXECUTOR_SEED} (in ideal water every seed is the same episode; in ocean water each draws its "
              "own current, lag and vehicle). MAE of speed [m/s] / heading [rad] per phase.", "",
              "| executor | water | instantaneous | constant | periodic | all steps |",
              "| --- | --- | --- | --- | --- | --- |"]
    results = {}
    for name, _ in EXECUTOR_ROWS:
        for condition in CONDITIONS:
            summary = evaluate.evaluate(name, ["speed_heading"], episodes, EXECUTOR_SEED, progress=False,
                                        task_kwargs={"conditions": condition})["tasks"]["speed_heading"]
            results[name, condition] = summary
            cells = [f"{_fmt(summary.get(f'mae_speed_{p}'))} / {_fmt(summary.get(f'mae_heading_{p}'))}"
                     for p in ("instantaneous", "constant", "periodic")]
            lines.append(f"| {name} | {condition} | {' | '.join(cells)} | {_fmt(summary['mae_speed'])} / "
                         f"{_fmt(summary['mae_heading'])} |")
    lines += ["", f"Command: `auv-mj eval --policy ocean-executor --task speed_heading --episodes {episodes} "
              f"--seed {EXECUTOR_SEED} --task-kwargs '{{\"conditions\": \"ocean\"}}'` (and each executor; "
              "`\"ideal\"`).", ""]
    return results


def _beats(results: dict, name: str, other: str, condition: str) -> str:
    """Whether executor `name` has MAE of speed AND heading at most `other`'s in every phase (issue 17's target)."""
    worse = [f"{p} {q}" for p in ("instantaneous", "constant", "periodic") for q in ("speed", "heading")
             if results[name, condition][f"mae_{q}_{p}"] > results[other, condition][f"mae_{q}_{p}"]]
    return "yes" if not worse else "no (worse in " + ", ".join(worse) + ")"


def executors(lines: list[str], episodes: int, workers: int = 1) -> None:
    """Issue 17: every executor in ideal and ocean water (Tables 9-11), and the two-layer system on it."""
    lines += ["## Executors in ideal and ocean water", "",
              "Every executor: " + "; ".join(f"`{n}` = {what}" for n, what in EXECUTOR_ROWS) + ". The nominal "
              "S-plane keeps the gains tuned on the nominal model (as a practitioner would); `splane-ocean` is the "
              "strongest classical executor we have, re-tuned in ocean water on training seeds.", ""]
    n_exec = max(10, min(episodes, 20))
    results = _executor_table9(lines, n_exec)
    lines += ["Target (issue 17): the learned executor's MAE of speed and heading at most the S-plane's in every "
              "phase, in ocean water.", "", "| learned executor | against | ocean: at most in every phase? | "
              "ideal: at most in every phase? |", "| --- | --- | --- | --- |"]
    for name in ("ocean-executor", "executor"):
        for other in ("splane", "splane-ocean"):
            lines.append(f"| {name} | {other} | {_beats(results, name, other, 'ocean')} | "
                         f"{_beats(results, name, other, 'ideal')} |")
    lines += ["", "### Tables 10-11, ideal and ocean water", "",
              "Line-of-sight guidance on each executor (`--task-kwargs '{\"executor\": NAME}'` on the path "
              "tasks), errors once on the path, one episode (seed 0).", "",
              "| path | executor | water | MAE speed | MAE heading | MAX speed | MAX heading | cross-track MAE [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task in PAPER_TRACKING:
        for name, _ in EXECUTOR_ROWS:
            for condition in CONDITIONS:
                m = evaluate.run_episode("splane", task, 0, {"conditions": condition, "executor": name})
                errors = (m["mae_speed"], m["mae_heading"], m["max_speed"], m["max_heading"])
                lines.append(f"| {task} | {name} | {condition} | {' | '.join(_fmt(e) for e in errors)} | "
                             f"{_fmt(m['mae_cross_track'], 2)} |")
    lines += ["", "Command: `auv-mj eval --policy splane --task path_line --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\", \"executor\": \"ocean-executor\"}'`.", "",
              "### The two-layer system in ocean water", "",
              f"The general planner (`planner-general`, its protection domain on) on each S-plane and on the learned "
              f"ocean executor (`two-layer-general`), {SYSTEM_EPISODES} held-out random arenas per task (test seeds "
              f"from {HELD_OUT_SEED}), ocean water.", "",
              "| task | executor | episodes | success | collisions | outcomes | time to goal [s] | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task, kwargs in SYSTEM_TASKS:
        for name in ("splane", "splane-ocean", "ocean-executor"):
            s = evaluate.evaluate("planner-general", [task], SYSTEM_EPISODES, HELD_OUT_SEED, progress=False,
                                  task_kwargs={**kwargs, "conditions": "ocean", "executor": name},
                                  workers=workers)["tasks"][task]
            outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
            lines.append(f"| {task} | {name} | {s['episodes']} | {s['success_rate']:.2f} | {s['collision_rate']:.2f} "
                         f"| {outcomes} | {_fmt(s['time_to_goal'], 0)} | {_fmt(s['min_clearance'], 1)} |")
    lines += ["", f"Command: `auv-mj eval --policy planner-general --task obstacles --episodes {SYSTEM_EPISODES} "
              f"--seed {HELD_OUT_SEED} --workers 2 --task-kwargs '{{\"conditions\": \"ocean\", \"executor\": "
              "\"ocean-executor\"}'` (and `\"splane\"`; `--task tunnel --arena random`).", ""]


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj reproduce`."""
    parser.add_argument("--out", type=Path, default=Path("docs/reproduction.md"), help="report file")
    parser.add_argument("--runs", type=Path, default=Path("docs/runs/fig8"),
                        help="folder of the Fig. 8 training logs (her-ddpg-seed*.csv, ddpg-seed*.csv)")
    parser.add_argument("--paper-runs", type=Path, default=Path("docs/runs/fig8-paper-observation"),
                        help="folder of the Fig. 8 logs on the paper's observation (section fig8_paper)")
    parser.add_argument("--peer-runs", type=Path, default=Path("docs/runs/peer"),
                        help="folder of the training-speed logs (auv-mj-*.csv, sb3-*.csv)")
    parser.add_argument("--episodes", type=positive_int, default=100,
                        help="held-out episodes per task and policy on random layouts (random targets, ocean)")
    parser.add_argument("--quick", action="store_true", help="10 episodes for the random targets")
    parser.add_argument("--workers", type=positive_int, default=1,
                        help="local processes for the held-out episodes of the generalisation and benchmark "
                             "sections (the result is the serial one)")
    parser.add_argument("--sections", default=None,
                        help=f"comma-separated sections to run (default all: {','.join(SECTIONS)}); into an "
                             "existing report they are written in place, the other sections kept")


SECTIONS = ("table9", "tracking", "fig8", "fig8_paper", "training_speed", "scenarios", "random_targets",
            "generalisation", "benchmark", "ocean", "executors")
"""The report's sections, in order."""


SECTION_START, SECTION_END = "<!-- section: {} -->", "<!-- /section: {} -->"
"""Markers around each section of the report, so that `--sections` can rewrite some and keep the rest."""


def _blocks(text: str) -> dict[str, str]:
    """The marked sections of a report: name -> its block, markers included."""
    blocks = {}
    for name in SECTIONS:
        start, end = SECTION_START.format(name), SECTION_END.format(name)
        if start in text and end in text[text.index(start):]:
            i = text.index(start)
            blocks[name] = text[i:text.index(end, i) + len(end)]
    return blocks


def merge_report(old: str, new_blocks: dict[str, str], header: list[str]) -> str:
    """The report `old` with `new_blocks` in place of its sections of the same names (the others kept), in
    SECTIONS order, under `header`; sections of neither are left out."""
    kept = _blocks(old)
    kept.update(new_blocks)
    return "\n".join(header) + "\n" + "\n\n".join(kept[name] for name in SECTIONS if name in kept) + "\n"


def run(args: argparse.Namespace) -> int:
    """Measures everything (or `--sections`) and writes the Markdown report with its figures; sections into
    an existing report replace their own blocks and keep the others (each block says when it was measured)."""
    names = list(SECTIONS) if args.sections is None else [n.strip() for n in args.sections.split(",") if n.strip()]
    unknown = [n for n in names if n not in SECTIONS]
    if unknown:
        usage_error(args, f"--sections: unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    check_output(args, args.out, "--out")
    start = time.perf_counter()
    figures = args.out.parent / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    episodes = 10 if args.quick else args.episodes
    lines = ["# auv-mj reproduction report", "",
             "Lyu et al. 2023, *End-to-End AUV Local Motion Planning Method Based on Deep Reinforcement "
             "Learning*, J. Mar. Sci. Eng. 11, 1796: the paper's numbers beside ours, measured by `auv-mj "
             "reproduce`.", "",
             f"Generated {datetime.date.today().isoformat()} at commit `{_commit()}` on {platform.machine()} "
             f"({platform.python_implementation()} {platform.python_version()}), CPU only.", "",
             "Our vehicle is REMUS-100 (Prestero 2001), not the paper's unnamed AUV, so absolute errors differ; "
             "the comparisons that carry over are the orderings (learned vs classical, HER vs plain DDPG).", ""]
    sections = {"table9": lambda: table9(lines), "tracking": lambda: tracking(lines),
                "fig8": lambda: fig8(lines, args.runs, figures),
                "fig8_paper": lambda: fig8(lines, args.paper_runs, figures, observation="paper"),
                "training_speed": lambda: training_speed(lines, args.peer_runs),
                "scenarios": lambda: scenarios(lines, figures),
                "random_targets": lambda: random_targets(lines, episodes),
                "generalisation": lambda: generalisation(lines, episodes, figures, args.workers),
                "benchmark": lambda: benchmark(lines, args.workers),
                "ocean": lambda: ocean_conditions(lines, episodes),
                "executors": lambda: executors(lines, episodes, args.workers)}
    header, blocks = list(lines), {}
    for name in names:
        print(f"reproduce: {name} ...", file=sys.stderr)
        began, lines[:] = time.perf_counter(), []
        sections[name]()
        stamp = (f"_Section `{name}` measured {datetime.date.today().isoformat()} at commit `{_commit()}` in "
                 f"{time.perf_counter() - began:.0f} s (`--episodes {episodes}`)._")
        blocks[name] = "\n".join([SECTION_START.format(name), *lines, stamp, SECTION_END.format(name)])
    old = args.out.read_text() if args.out.is_file() else ""
    header[header.index(next(h for h in header if h.startswith("Generated")))] = (
        f"Last updated {datetime.date.today().isoformat()} at commit `{_commit()}` on {platform.machine()} "
        f"({platform.python_implementation()} {platform.python_version()}), CPU only; each section says when it "
        "was measured.")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(merge_report(old, blocks, header))
    print(f"wrote {args.out} in {time.perf_counter() - start:.0f} s")
    return 0
