"""Draws learning_curve.png and writes learning_curve.csv from the runs' validation.csv files.

Usage (from the repository root): python docs/runs/planner-memory-ppo/learning_curve.py RUN_GRU RUN_FF [RUN_GRU_1]
where RUN_GRU and RUN_FF are the run directories of `auv-mj train ppo` with and without memory (seed 0), and
RUN_GRU_1 the GRU run of seed 1 (trained after the update was made faster).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent


def rows(run: Path) -> list[dict[str, str]]:
    with open(run / "validation.csv", newline="") as f:
        return list(csv.DictReader(f))


LABELS = {"gru": "GRU memory (planner-memory), seed 0", "none": "no memory (ablation), seed 0",
          "gru-seed1": "GRU memory, seed 1"}


def main(gru: Path, ff: Path, gru_seed1: Path | None = None) -> None:
    runs = {"gru": rows(gru), "none": rows(ff)}
    if gru_seed1 is not None:
        runs["gru-seed1"] = rows(gru_seed1)
    with open(HERE / "learning_curve.csv", "w", newline="") as f:
        fields = ["run", *next(iter(runs.values()))[0].keys()]
        writer = csv.DictWriter(f, fields)
        writer.writeheader()
        for name, data in runs.items():
            for row in data:
                writer.writerow({"run": name, **row})
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for name, data in runs.items():
        steps = [int(r["env_steps"]) / 1e6 for r in data]
        minutes = [float(r["train_wall_s"]) / 60 for r in data]
        success = [float(r["hard_success"]) for r in data]
        axes[0].plot(steps, success, marker="o", label=LABELS[name])
        axes[1].plot(minutes, success, marker="o", label=LABELS[name])
    axes[0].set_xlabel("training env steps [millions]")
    axes[1].set_xlabel("training wall-clock on the 2-core machine [min]")
    axes[0].set_ylabel("hard-tier validation success")
    for ax in axes:
        ax.axhline(0.9, color="grey", lw=0.8, ls="--")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    fig.suptitle("PPO from scratch on the planning mixture: success on 6 hard cells x validation seeds")
    fig.tight_layout()
    fig.savefig(HERE / "learning_curve.png", dpi=110)


if __name__ == "__main__":
    main(*(Path(a) for a in sys.argv[1:4]))
