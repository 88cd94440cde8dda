"""How fast training runs with a collector process beside it (`auv-mj bench --sections cores`): `auv-mj train
her-ddpg --task goal` serially and with `--collectors 1`, the two runs alternating in every repeat.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import gymnasium
import numpy as np

import auv_mj  # noqa: F401  (registers the auv_mj Gymnasium ids)
from auv_mj.agents.offpolicy.ddpg import DDPGConfig
from auv_mj.agents.offpolicy.train import train
from auv_mj.speed.sections import BenchSettings, Measurement, section

ENV_ID = "auv_mj/Goal-v0"
"""The task trained on: the goal task's Gymnasium id (Table 4's config)."""


def goal_env() -> gymnasium.Env:
    """A fresh goal-task environment: the training runs' factory (a module function, so collector processes can
    unpickle it)."""
    return gymnasium.make(ENV_ID)


CORE_STEPS = 20_000
"""Env steps of each timed training run of the "cores" section (the collector's start, 2-3 s, is timed too)."""
CORE_REPEATS = 3
"""At most this many repeats of the "cores" section (one is two training runs of about a minute)."""


@section("cores")
def cores_section(settings: BenchSettings) -> list[Measurement]:
    """Training env steps/s of `auv-mj train her-ddpg --task goal` (Table 4's config) serially and with one
    collector process (`--collectors 1`), the two runs alternating in every repeat, each timed whole (the
    collector's start included); and each run's gradient steps per env step, which must agree."""
    steps = max(2400, settings.calls(CORE_STEPS))
    config = DDPGConfig(learning_starts=min(DDPGConfig().learning_starts, steps // 4), seed=settings.seed)
    repeats = min(settings.repeats, CORE_REPEATS)
    rates = np.empty((repeats, 2))
    ratios = np.empty((repeats, 2))
    with tempfile.TemporaryDirectory(prefix="auv-mj-bench-") as scratch:
        for i in range(repeats):
            for j, count in enumerate((0, 1)):
                result = train(goal_env, "her-ddpg", config, total_steps=steps, run_dir=Path(scratch) / f"{i}-{count}",
                               progress=False, tensorboard=False, collectors=count)
                rates[i, j] = result.env_steps_per_s
                ratios[i, j] = result.gradient_steps / result.env_steps
    note = f"goal, {steps} steps per run, {repeats} repeats, {os.cpu_count()} CPUs"
    return [Measurement("train env steps/s, serial", float(np.median(rates[:, 0])), "steps/s", note),
            Measurement("train env steps/s, --collectors 1", float(np.median(rates[:, 1])), "steps/s", note),
            Measurement("--collectors 1 / serial", float(np.median(rates[:, 1] / rates[:, 0])), "x",
                        "median of the repeats' ratios"),
            Measurement("gradient steps per env step, serial", float(np.median(ratios[:, 0])), "updates/step"),
            Measurement("gradient steps per env step, --collectors 1", float(np.median(ratios[:, 1])),
                        "updates/step")]
