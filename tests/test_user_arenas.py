"""A user's arena on every planning task (`arena=PATH`), and open-water arenas authored from shapes
(`auv_mj.arenas.layout`, `auv-mj arena`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from auv_mj.arenas import arena_check
from tasks import suite

ROOT = Path(__file__).resolve().parents[1]
CORRIDOR = (ROOT / "docs" / "arenas.md").read_text().split("```xml\n", 1)[1].split("```", 1)[0]
"""The hand-written arena of docs/arenas.md: start (5, 0), goal (95, 0), path sites every 20-25 m, a mover."""
OPEN_WATER_TASKS = ("goal", "waypoints", "obstacles", "moving_obstacles")


@pytest.fixture
def corridor(tmp_path) -> Path:
    path = tmp_path / "corridor.xml"
    path.write_text(CORRIDOR)
    return path


@pytest.mark.parametrize("task", OPEN_WATER_TASKS)
def test_every_open_water_task_runs_on_a_users_arena(task, corridor):
    env = suite.load("auv", task, task_kwargs={"arena": str(corridor), "random": 0})
    env.reset()
    np.testing.assert_allclose(env.physics.pose(), [5.0, 0.0, 0.0], atol=1e-9)  # the start site, its heading
    goals = env.task.goals
    np.testing.assert_allclose(goals[-1], [95.0, 0.0])
    if task == "waypoints":  # the path sites after the start, in order, then the goal (path_4 is the goal)
        np.testing.assert_allclose(goals, [[25, 0], [50, 0], [75, 0], [95, 0]])
    else:
        assert len(goals) == 1
    model = env.physics.model.ptr
    before = env.physics.data.mocap_pos[model.body_mocapid[model.body("mover_diver").id]][:2].copy()
    for _ in range(20):  # 10 s: the diver (0.2 m/s from (80, -8) to (80, 8)) moves on every task
        step = env.step([0.0, 0.0])
    after = env.physics.data.mocap_pos[model.body_mocapid[model.body("mover_diver").id]][:2]
    np.testing.assert_allclose(after, before + [0.0, 0.2 * env.physics.time()], atol=0.05)
    assert np.all(np.isfinite(step.observation["observation"]))


@pytest.mark.parametrize("task", OPEN_WATER_TASKS)
def test_a_users_arena_is_checked_before_use_and_conflicts_are_named(task, corridor, tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text(CORRIDOR.replace('<site name="goal" pos="95 0 0"/>', ""))
    with pytest.raises(ValueError, match=r"broken.xml: not a usable arena: no <site name=\"goal\">"):
        suite.load("auv", task, task_kwargs={"arena": str(broken)})
    choice = "layout" if task == "waypoints" else "scenario"
    named = {"goal": "a1", "waypoints": "b1"}.get(task, "a")
    with pytest.raises(ValueError, match=f"and {choice}='{named}' conflict"):
        suite.load("auv", task, task_kwargs={"arena": str(corridor), choice: named})
    with pytest.raises(ValueError, match=f"{choice}='arena' is set by arena=PATH"):
        suite.load("auv", task, task_kwargs={choice: "arena"})


def test_a_users_arena_without_a_path_is_accepted_as_check_arena_no_path_accepts(tmp_path):
    text = CORRIDOR
    for k in range(5):
        text = "\n".join(line for line in text.splitlines() if f'name="path_{k}"' not in line)
    path = tmp_path / "no_path.xml"
    path.write_text(text)
    assert arena_check.check_arena(path, need_path=False).ok and not arena_check.check_arena(path).ok
    env = suite.load("auv", "waypoints", task_kwargs={"arena": str(path), "random": 0})
    env.reset()
    np.testing.assert_allclose(env.task.goals, [[95.0, 0.0]])  # no path sites: the goal alone

