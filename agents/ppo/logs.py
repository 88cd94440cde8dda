"""A PPO run's logs: progress.csv a row per rollout, cells.csv per cell of the env, TensorBoard, the progress bar.

cells.csv holds, per cell of the env (`auv_mj.agents.ppo.rollout.Collector`), the success, collision rate, speed and
return of the episodes that ended in the rollout; TensorBoard the same, where it is installed. A resumed run reopens
the logs with their rows up to its checkpoint (`RunLogs`).
"""

from __future__ import annotations

import csv
import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.agents.ppo.rollout import Episode

LOG_NAME = "progress.csv"
CELLS_LOG_NAME = "cells.csv"
LOG_FIELDS = ("iteration", "env_steps", "episodes", "mean_return", "policy_loss", "value_loss", "entropy",
              "approx_kl", "clip_fraction", "explained_variance", "samples_per_s", "learning_rate", "clip_coef",
              "epochs", "success_rate", "collision_rate", "mean_speed", "imitation_coef", "imitation_loss")
"""The columns of progress.csv, a row per rollout (a run logged before the last eight were added resumes with them
empty in its old rows)."""
CELL_FIELDS = ("iteration", "env_steps", "cell", "episodes", "success_rate", "collision_rate", "mean_speed",
               "mean_return")
"""The columns of cells.csv: per rollout and cell, the episodes that ended in it and their means."""

RETURN_WINDOW = 100
"""Finished episodes whose means the progress bar shows."""


def _tensorboard(run_dir: Path, purge_step: int | None) -> Any:
    """A TensorBoard writer in run_dir/tb, or None with a warning where TensorBoard is not installed (the CSV logs
    are written either way)."""
    try:
        from torch.utils.tensorboard import SummaryWriter  # slow import, only when asked for
    except ImportError:
        warnings.warn("TensorBoard is not installed: the training curves go to the CSV logs only", stacklevel=3)
        return None
    return SummaryWriter(str(run_dir / "tb"), purge_step=purge_step)


def _logged_rows(path: Path, iterations: int, fields: Sequence[str]) -> list[dict[str, str]]:
    """The rows of a run's log up to rollout `iterations` (those a resumed run keeps); rows of an older log that
    lack some of `fields` keep them empty."""
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if row.get("iteration", "").isdigit()
                and int(row["iteration"]) <= iterations and None not in row and set(row) <= set(fields)]


def _nanmean(values: Sequence[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return float(np.mean(finite)) if finite else float("nan")


def episode_summary(episodes: Sequence[Episode]) -> dict[str, float]:
    """Means over finished episodes: success_rate, collision_rate, mean_speed, mean_return (nan where none)."""
    return {"success_rate": _nanmean([e.success for e in episodes]),
            "collision_rate": _nanmean([e.collision for e in episodes]),
            "mean_speed": _nanmean([e.speed for e in episodes]),
            "mean_return": _nanmean([e.ret for e in episodes])}


def progress_text(recent: Sequence[Episode], episodes: int, learning_rate: float, steps_per_s: float) -> str:
    """The progress bar's postfix: the means over the last RETURN_WINDOW finished episodes (return, and success and
    collisions where the env reports them), or, before the first has ended, that none has (not NaN); then the
    episodes so far, the learning rate and the env steps per second."""
    if recent:
        summary = episode_summary(recent)
        parts = [f"ret {summary['mean_return']:.3g}"] + [
            f"{label} {summary[key]:.2f}" for key, label in (("success_rate", "succ"), ("collision_rate", "coll"))
            if not math.isnan(summary[key])]
        shown = ", ".join(parts) + f" (last {len(recent)})"
    else:
        shown = "no episode ended yet"
    return f"{shown}, episodes {episodes}, lr {learning_rate:.2g}, {steps_per_s:.0f} steps/s"


class RunLogs:
    """progress.csv, cells.csv and TensorBoard of a run, reopened on resume with the rows up to its checkpoint."""

    def __init__(self, run_dir: Path, iterations: int, resume: bool, tensorboard: bool, purge_step: int):
        self.files, self.writers = [], []
        for name, fields in ((LOG_NAME, LOG_FIELDS), (CELLS_LOG_NAME, CELL_FIELDS)):
            kept = _logged_rows(run_dir / name, iterations, fields) if resume else []
            f = open(run_dir / name, "w", newline="")
            writer = csv.DictWriter(f, fields)
            writer.writeheader()
            writer.writerows(kept)
            self.files.append(f)
            self.writers.append(writer)
        self.board = _tensorboard(run_dir, purge_step if resume else None) if tensorboard else None

    def write(self, row: Mapping[str, Any], cell_rows: Sequence[Mapping[str, Any]]) -> None:
        """One rollout's row and its cells' rows."""
        self.writers[0].writerow(row)
        self.writers[1].writerows(cell_rows)
        for f in self.files:
            f.flush()
        if self.board is None:
            return
        step = row["env_steps"]
        for key, value in row.items():
            if key not in ("iteration", "env_steps") and np.isfinite(value):
                self.board.add_scalar(f"ppo/{key}", value, step)
        for cell in cell_rows:
            for key in CELL_FIELDS[3:]:
                if np.isfinite(cell[key]):
                    self.board.add_scalar(f"cells/{cell['cell']}/{key}", cell[key], step)

    def close(self) -> None:
        for f in self.files:
            f.close()
        if self.board is not None:
            self.board.close()
