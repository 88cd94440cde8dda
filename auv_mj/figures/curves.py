"""Learning curves (matplotlib, Agg): episode return and success rate against episodes or steps, from training logs,
the mean over the runs of each group with a shaded band (the paper's Fig. 8).

Training logs are CSVs as `auv_mj.agents.offpolicy.train` writes them (progress.csv: episode, steps, length, return,
success, wall_time); `auv-mj plot learning` wraps `plot_learning`.
"""

from __future__ import annotations

import csv
import glob
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from auv_mj.figures.canvas import DEFAULT_SIZE, new_figure, save

LEARNING_WINDOW = 5
"""Episodes averaged per point of a learning curve (Sec. 4.1: "recorded every five epochs")."""
BANDS = ("minmax", "std", "ci")
"""Shaded bands of the learning curves: range, one standard deviation, 95 % confidence of the mean."""
LEARNING_COLUMNS = ("episode", "return", "success")
"""Columns a training log must have (auv_mj.agents.offpolicy.train writes episode, steps, length, return, success,
wall_time)."""
RUN_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown")
"""Colour of each group of runs, in the order given."""


def read_learning_csv(path: str | Path) -> dict[str, np.ndarray]:
    """A training log as float columns; needs LEARNING_COLUMNS. A directory means its progress.csv."""
    path = Path(path)
    if path.is_dir():
        path = path / "progress.csv"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    missing = [c for c in LEARNING_COLUMNS if c not in rows[0]]
    if missing:
        raise ValueError(f"{path}: a training log needs columns {', '.join(LEARNING_COLUMNS)}; "
                         f"missing {', '.join(missing)}")
    columns = {}
    for c in rows[0]:
        try:
            columns[c] = np.array([float(r[c]) for r in rows])
        except ValueError:
            continue
    return columns


def expand_runs(patterns: Sequence[str | Path]) -> list[Path]:
    """Files (or run directories) named by paths or glob patterns, sorted; ValueError if none."""
    found = []
    for pattern in patterns:
        matches = sorted(glob.glob(str(pattern))) or ([str(pattern)] if Path(pattern).exists() else [])
        found.extend(Path(m) for m in matches)
    if not found:
        raise ValueError(f"no training logs match {', '.join(map(str, patterns))}")
    return found


def smooth(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving average over `window` points (shorter at the start)."""
    values = np.asarray(values, dtype=float)
    if window <= 1:
        return values
    csum = np.cumsum(np.insert(values, 0, 0.0))
    idx = np.arange(1, len(values) + 1)
    lo = np.maximum(idx - window, 0)
    return (csum[idx] - csum[lo]) / (idx - lo)


def learning_curve(runs: Sequence[dict[str, np.ndarray]], column: str, window: int, x: str = "episode",
                   band: str = "minmax") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x, mean, low, high) of a column over runs, each smoothed over `window` episodes.

    Runs are cut to the shortest; `x` is "episode" or "steps" (the mean over runs of the step counts);
    `band` "minmax" (range of the runs), "std" (mean +- one standard deviation) or "ci" (the 95 %
    confidence interval of the mean over runs, Student's t with runs - 1 degrees of freedom).
    """
    if band not in BANDS:
        raise ValueError(f"band must be one of {BANDS}, got {band!r}")
    n = min(len(r[column]) for r in runs)
    values = np.stack([smooth(r[column][:n], window) for r in runs])
    if x == "steps" and all("steps" in r for r in runs):
        xs = np.mean([r["steps"][:n] for r in runs], axis=0)
    else:
        xs = runs[0]["episode"][:n]
    mean = values.mean(axis=0)
    if band == "std":
        std = values.std(axis=0)
        return xs, mean, mean - std, mean + std
    if band == "ci":
        if len(runs) < 2:
            return xs, mean, mean, mean
        from scipy import stats

        half = stats.t.ppf(0.975, len(runs) - 1) * values.std(axis=0, ddof=1) / np.sqrt(len(runs))
        return xs, mean, mean - half, mean + half
    return xs, mean, values.min(axis=0), values.max(axis=0)


def plot_learning(groups: Sequence[tuple[str, Sequence[str | Path]]], path: str | Path,
                  window: int = LEARNING_WINDOW, band: str = "minmax", x: str = "episode",
                  title: str | None = None, width: int = DEFAULT_SIZE[0],
                  height: int = DEFAULT_SIZE[1]) -> Path:
    """PNG of episode return and success rate vs episodes: per group (label, CSV files/globs), the mean
    over its runs with a shaded band (Fig. 8 compares HER-DDPG with DDPG this way)."""
    fig, (ret_ax, succ_ax) = new_figure(width, height, 2, 1, sharex=True)
    for i, (label, patterns) in enumerate(groups):
        runs = [read_learning_csv(p) for p in expand_runs(patterns)]
        colour = RUN_COLOURS[i % len(RUN_COLOURS)]
        for ax, column in ((ret_ax, "return"), (succ_ax, "success")):
            xs, mean, low, high = learning_curve(runs, column, window, x, band)
            ax.plot(xs, mean, color=colour, label=f"{label} ({len(runs)} run{'s' * (len(runs) > 1)})")
            if len(runs) > 1:
                ax.fill_between(xs, low, high, color=colour, alpha=0.2, linewidth=0)
    ret_ax.set_ylabel(f"episode return ({window}-episode mean)")
    succ_ax.set_ylabel(f"success rate ({window}-episode mean)")
    succ_ax.set_ylim(-0.05, 1.05)
    succ_ax.set_xlabel("environment steps" if x == "steps" else "episode")
    for ax in (ret_ax, succ_ax):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    band_name = {"minmax": "min-max over runs", "std": "mean +- std over runs",
                 "ci": "95 % confidence interval of the mean"}[band]
    ret_ax.set_title(title if title is not None else f"learning curves (band: {band_name})")
    fig.tight_layout()
    return save(fig, path)
