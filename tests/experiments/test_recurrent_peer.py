"""The RecurrentPPO peer (`experiments.recurrent_peer`): a wall-clock stop after a whole update, a resume that keeps
the learning rate's schedule over the step budget, and validation through ours' `validate`."""

from __future__ import annotations

import csv
import dataclasses
import json

import pytest

from auv_mj.agents.ppo.planner import LEARNED_MIXTURE
from experiments.recurrent_peer import RESULT_NAME, main, train_peer

TINY = dataclasses.replace(LEARNED_MIXTURE, envs_per_cell=1, cell_weights=(), validation_max_steps=3)
"""The learned mixture's problem, one vehicle a cell (12 in all: 1,536 steps a rollout), validation cut short."""


def test_peer_stops_on_the_wall_clock_resumes_and_validates(tmp_path):
    budget = 2 * 128 * TINY.num_envs
    state = train_peer(tmp_path, budget, wall_clock=1e-6, mixture=TINY)
    assert state["env_steps"] == budget // 2 and state["runs"] == 1  # one whole update, then the budget stops it
    with pytest.raises(ValueError, match="step budget"):
        train_peer(tmp_path, 2 * budget, resume=True, mixture=TINY)
    state = train_peer(tmp_path, budget, resume=True, mixture=TINY)
    assert state["env_steps"] == budget and state["runs"] == 2
    with open(tmp_path / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["env_steps"]) for r in rows] == [budget // 2, budget]
    # linear from 3e-4 to 3e-5 over the budget, across the resume: each update at the steps done by then
    assert [float(r["learning_rate"]) for r in rows] == pytest.approx([1.65e-4, 3e-5])
    with open(tmp_path / "cells.csv") as f:
        assert len(list(csv.DictReader(f))) == 2 * 12
    assert main(["--run-dir", str(tmp_path), "--steps", str(budget), "--resume", "--validation-episodes", "2"],
                TINY) == 0
    result = json.loads((tmp_path / RESULT_NAME).read_text())
    assert result["env_steps"] == budget and len(result["validation"]) == 6  # the hard cells
    assert all(0.0 <= rate <= 1.0 for rate in result["validation"].values())
