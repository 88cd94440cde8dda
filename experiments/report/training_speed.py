"""Training speed: auv-mj against the Stable-Baselines3 peer, from logs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from auv_mj.figures import curves
from experiments.report.common import fmt
from experiments.report.registry import ReportSettings, section

PEER_GROUPS = {"auv-mj HER-DDPG": "auv-mj-her-ddpg-seed*.csv",
               "auv-mj HER-DDPG, --collectors 1": "auv-mj-collectors1-seed*.csv",
               "SB3 DDPG+HER": "sb3-*.csv"}
"""Trainer -> the logs of its runs in the peer folder (the collectors runs are optional)."""


def training_speed(lines: list[str], runs: Path) -> None:
    """Ours against the SB3 DDPG+HER peer on `goal`, from logs of runs made one after another: raw env steps/s
    at the same updates per step (the speed figure), and wall-clock to 90 % success where both reached it (a
    learning figure too, so no ratio is drawn where one did not)."""
    from experiments.sb3_peer import TARGET, WINDOW, time_to_success

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
            data = curves.read_learning_csv(f)
            wall, steps = time_to_success(f)
            total_steps, total_wall = int(data["steps"][-1]), float(data["wall_time"][-1])
            times.append(wall)
            speeds.append(total_steps / total_wall)
            final = float(np.mean(np.asarray(data["success"], dtype=float)[-WINDOW:]))
            lines.append(f"| {label} | {f.stem} | {fmt(wall, 0)} | {steps if steps >= 0 else 'never'} | "
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
              "Commands: `python -m experiments.sb3_peer --steps N --seed S --csv sb3-ddpg-her-seedS.csv`, "
              "`auv-mj train her-ddpg --task goal --seed S --steps N` and the same with `--collectors 1` (their "
              f"`progress.csv` as `auv-mj-her-ddpg-seedS.csv` and `auv-mj-collectors1-seedS.csv`), in `{runs}`.", ""]


@section("training_speed")
def training_speed_section(lines: list[str], settings: ReportSettings) -> None:
    """The peer comparison from `--peer-runs`."""
    training_speed(lines, settings.peer_runs)
