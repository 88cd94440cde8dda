"""Fig. 8: HER-DDPG against plain DDPG on `goal`, from training logs (sections fig8 and fig8_paper)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from auv_mj.figures import curves
from experiments.report.common import fmt
from experiments.report.registry import ReportSettings, section

FIG8_TARGET = 0.9


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
    figure = curves.plot_learning([(label, [str(f) for f in files]) for label, files in groups],
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
            data = curves.read_learning_csv(f)
            success = np.asarray(data["success"], dtype=float)
            first = episodes_to(success, FIG8_TARGET)
            reached.append(first)
            name = f.parent.name if f.name == "progress.csv" else f.stem
            lines.append(f"| {label} | {name} | {len(success)} | {int(data['steps'][-1])} | "
                         f"{success.mean():.2f} | {success[-20:].mean():.2f} | {fmt(first, 0)} |")
        reached_by[label] = [math.inf if math.isnan(r) else r for r in reached]
    lines += ["", f"| algorithm | runs | reached {FIG8_TARGET:.0%} | median episodes to {FIG8_TARGET:.0%} | "
              "mean +- 95 % CI (runs that reached it) |", "| --- | --- | --- | --- | --- |"]
    for label, reached in reached_by.items():
        finite = [r for r in reached if math.isfinite(r)]
        mean, half = mean_ci(finite) if finite else (math.nan, math.nan)
        lines.append(f"| {label} | {len(reached)} | {len(finite)} | {float(np.median(reached)):.0f} | "
                     f"{fmt(mean, 1)} +- {fmt(half, 1)} |")
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


@section("fig8")
def fig8_section(lines: list[str], settings: ReportSettings) -> None:
    """Fig. 8 on the default (relative) observation, from `--runs`."""
    fig8(lines, settings.runs, settings.figures)


@section("fig8_paper")
def fig8_paper_section(lines: list[str], settings: ReportSettings) -> None:
    """Fig. 8 on the paper's absolute observation (Table 2), from `--paper-runs`."""
    fig8(lines, settings.paper_runs, settings.figures, observation="paper")
