"""Draws learning_curve.png and writes learning_curve.csv from the run logs kept beside this script.

Usage (from the repository root): `python docs/runs/planner-learned/learning_curve.py`. It reads the shipped
planner's phases: the `map-replan`-taught map student's DAgger rounds (map_mapteacher_dagger.csv, _cells.csv), its
final fit (map_mapteacher_fit128_dagger.csv's last row, map_mapteacher_fit128_validation.json) and its anchored PPO
stage (fit128_ppo_anchor_validation.csv); the planner shipped before, the privileged teacher's student: its DAgger
rounds (dagger.csv, dagger_cells.csv), its first fine-tune's validations (finetune_validation.csv), the later stages'
(stageK_validation.csv, each `auv-mj train ppo --init` from the stage before); and PPO from scratch without a teacher
(scratch_validation.csv). The x axes are env steps and wall-clock on this machine; the y axis is the mean hard-tier
validation success over the six hard cells (DAgger's rounds: 10 episodes a cell; the validations after: 50 a cell).
The DAgger points count the labelled steps collected; each later phase continues the one before on both axes.
"""

from __future__ import annotations

import csv
import json
import re
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent
STAGES = sorted((p.name.split("_")[0] for p in HERE.glob("stage*_validation.csv")
                 if re.fullmatch(r"stage\d+_validation\.csv", p.name)), key=lambda s: int(s[5:]))
"""The later stages of the planner shipped before whose validations are kept here (stage2, stage3), in order; not
the tries beside them (stage4_movers_...)."""
PHASES = ["dagger", "finetune", *STAGES]
"""The student's phases, each continuing the one before."""
HARD_CELLS = [f"{task}/hard/{water}" for task in ("obstacles", "moving_obstacles", "tunnel")
              for water in ("ideal", "ocean")]


def read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def validation_points(path: Path, phase: str, steps0: float = 0, wall0: float = 0.0) -> list[dict[str, float | str]]:
    """One point per validation row of `path` (a `validation.csv`), its steps and wall-clock after (steps0, wall0)."""
    return [{"phase": phase, "env_steps": steps0 + int(row["env_steps"]),
             "wall_s": round(wall0 + float(row["train_wall_s"]), 1), "hard_success": float(row["hard_success"]),
             **{c: float(row[c]) for c in HARD_CELLS if row.get(c)}} for row in read(path)]


def dagger_points(prefix: str, phase: str) -> list[dict[str, float | str]]:
    """One point per DAgger round of `{prefix}dagger.csv` (10 validation episodes a hard cell)."""
    cells: dict[int, dict[str, float]] = {}
    for row in read(HERE / f"{prefix}dagger_cells.csv"):
        cells.setdefault(int(row["round"]), {})[row["cell"]] = float(row["val_success"])
    points, wall = [], 0.0
    for row in read(HERE / f"{prefix}dagger.csv"):
        wall += float(row["wall_s"])
        points.append({"phase": phase, "env_steps": int(row["dataset_steps"]), "wall_s": round(wall, 1),
                       "hard_success": float(row["val_success"]), **cells.get(int(row["round"]), {})})
    return points


def shipped_points() -> list[dict[str, float | str]]:
    """The shipped planner: the `map-replan` teacher's DAgger rounds, the final fit (50 a hard cell), the anchored
    PPO stage's validations."""
    points = dagger_points("map_mapteacher_", "map-dagger")
    fit = json.loads((HERE / "map_mapteacher_fit128_validation.json").read_text())
    fit_wall = float(read(HERE / "map_mapteacher_fit128_dagger.csv")[-1]["wall_s"])
    points.append({"phase": "map-fit", "env_steps": points[-1]["env_steps"],
                   "wall_s": round(points[-1]["wall_s"] + fit_wall, 1), "hard_success": fit["mean"],
                   **{c: fit[c] for c in HARD_CELLS}})
    return points + validation_points(HERE / "fit128_ppo_anchor_validation.csv", "map-ppo", points[-1]["env_steps"],
                                      points[-1]["wall_s"])


def student_points() -> list[dict[str, float | str]]:
    """The planner shipped before: one point per DAgger round and per validation of each fine-tune: phase, env
    steps, wall seconds, mean and cells."""
    points = dagger_points("", "dagger")
    for phase in PHASES[1:]:
        points += validation_points(HERE / f"{phase}_validation.csv", phase, points[-1]["env_steps"],
                                    points[-1]["wall_s"])
    return points


def main() -> None:
    runs = {"shipped": shipped_points(), "student": student_points(),
            "scratch": validation_points(HERE / "scratch_validation.csv", "scratch")}
    with open(HERE / "learning_curve.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, ["run", "phase", "env_steps", "wall_s", "hard_success", *HARD_CELLS])
        writer.writeheader()
        for name, points in runs.items():
            for point in points:
                writer.writerow({"run": name, **point})
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    labels = {"map-dagger": "shipped: DAgger, map-replan labels the map student",
              "map-fit": "shipped: the fit of 128 epochs", "map-ppo": "shipped: PPO held by the anchor",
              "dagger": "before: DAgger (privileged teacher labels)",
              "finetune": "before: PPO fine-tune of the student",
              **{stage: f"before: stage {stage[5:]} (train ppo --init)" for stage in STAGES},
              "scratch": "PPO from scratch, no teacher (ablation)"}
    for points in runs.values():
        for phase in ("map-dagger", "map-fit", "map-ppo", *PHASES, "scratch"):
            mine = [p for p in points if p["phase"] == phase]
            if not mine:
                continue
            axes[0].plot([p["env_steps"] / 1e6 for p in mine], [p["hard_success"] for p in mine], marker="o",
                         label=labels[phase])
            axes[1].plot([p["wall_s"] / 60 for p in mine], [p["hard_success"] for p in mine], marker="o",
                         label=labels[phase])
    for cell in HARD_CELLS:
        mine = [p for p in runs["shipped"] if cell in p]
        axes[2].plot([p["wall_s"] / 60 for p in mine], [p[cell] for p in mine], marker=".", label=cell)
    axes[0].set_xlabel("env steps [millions]")
    axes[1].set_xlabel("wall-clock on the 2-core machine [min]")
    axes[2].set_xlabel("wall-clock [min] (the shipped planner, per hard cell)")
    axes[0].set_ylabel("hard-tier validation success")
    for ax in axes:
        ax.axhline(0.9, color="grey", lw=0.8, ls="--")
        ax.axhline(0.95, color="grey", lw=0.8, ls=":")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    axes[2].legend(loc="lower right", fontsize=7)
    fig.suptitle("planner-learned on the planning mixture (validation seeds): the shipped planner and the one before")
    fig.tight_layout()
    fig.savefig(HERE / "learning_curve.png", dpi=100)


if __name__ == "__main__":
    if len(sys.argv) != 1:
        raise SystemExit(__doc__)
    main()
