"""Draws learning_curve.png from the run logs kept beside this script.

Usage (from the repository root): `python docs/runs/planner-learned-3d/learning_curve.py`. It reads the student's
DAgger rounds (dagger.csv, dagger_cells.csv: 10 validation episodes a hard cell after each round), the fine-tune's
training log (finetune_progress.csv: success of the stochastic policy over the mixture's last 100 episodes, every
cell) and the validations of 50 episodes a hard cell (validation.csv). The x axes are env steps (DAgger: labelled
steps collected) and training wall-clock on this 2-core machine; the fine-tune continues DAgger on both.
"""

from __future__ import annotations

import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent
PLOTTED = ("dagger", "final fit", "finetune")
"""The validations drawn (validation.csv's other rows, the ablations and tries, are in the README's table)."""


def rows(name: str) -> list[dict]:
    with open(HERE / name, newline="") as f:
        return list(csv.DictReader(f))


def main() -> None:
    dagger = rows("dagger.csv")
    steps = [float(r["dataset_steps"]) for r in dagger]
    wall = []
    total = 0.0
    for r in dagger:
        total += float(r["wall_s"])
        wall.append(total)
    tune = rows("finetune_progress.csv")
    rounds = [k for k, r in enumerate(dagger) if r["beta"] != "nan"]  # the final fit's row has no beta
    tune_steps = [steps[rounds[-1]] + float(r["env_steps"]) for r in tune]
    tune_wall, at = [], wall[rounds[-1]]
    last = 0.0
    for r in tune:
        at += (float(r["env_steps"]) - last) / max(float(r["samples_per_s"]), 1e-9)
        last = float(r["env_steps"])
        tune_wall.append(at)
    validation = [r for r in rows("validation.csv") if r["phase"] in PLOTTED]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, x_dagger, x_tune, label in ((axes[0], steps, tune_steps, "env steps"),
                                        (axes[1], [w / 60 for w in wall], [w / 60 for w in tune_wall],
                                         "training wall-clock [min]")):
        ax.plot(x_dagger, [float(r["val_success"]) for r in dagger], "o-", label="DAgger: validation, 10 a hard cell")
        ax.plot(x_tune, [float(r["success_rate"]) for r in tune], "-", alpha=0.6,
                label="fine-tune from the DAgger student: training success (stochastic, every cell)")
        for r in validation:
            x = float(r["env_steps"]) if label == "env steps" else float(r["wall_s"]) / 60
            ax.plot([x], [float(r["hard_mean"])], "k*", markersize=12)
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].plot([], [], "k*", label="validation, 50 a hard cell (deterministic)")
    axes[0].set_ylabel("success")
    axes[0].set_ylim(0, 1)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle("planner-learned in 3-D: DAgger from the 3-D geodesic teacher, its final fit (shipped), "
                 "and a PPO fine-tune (not shipped)")
    fig.tight_layout()
    fig.savefig(HERE / "learning_curve.png", dpi=120)


if __name__ == "__main__":
    main()
