"""`auv-mj eval --record-failures DIR`: a video and a trajectory PNG of each episode that does not reach the goal."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from auv_mj.benchmark import failures

NEAR = {"name": "near", "start": [20, 100], "goal": [45, 100], "bounds": [0, 0, 200, 200],
        "shapes": [{"type": "box", "name": "rock", "x": 100, "y": 160, "length": 10, "width": 10}]}
"""A goal 25 m ahead (12.5 m outside its target area): the seeded `random` policy reaches it in 23 to 32 steps."""
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


def _cli(*args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "auv_mj.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env=ENV)


def test_one_video_and_trajectory_per_failed_episode_and_none_per_success(tmp_path):
    (tmp_path / "near.json").write_text(json.dumps(NEAR))
    assert _cli("arena", "near.json", "--no-preview", cwd=tmp_path).returncode == 0
    out = tmp_path / "failures"
    # Seeds 0, 1, 2 reach the goal after 26, 29 and 30 steps: cut at 28, seed 0 succeeds, 1 and 2 time out.
    done = _cli("eval", "--policy", "random", "--task", "goal", "--arena", "near.xml", "--episodes", "3",
                "--max-steps", "28", "--no-progress", "--json", "eval.json", "--record-failures", out, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    outcomes = json.loads((tmp_path / "eval.json").read_text())["tasks"]["goal"]["outcomes"]
    assert outcomes["goal"] == 1 and outcomes["timeout"] == 2
    videos = sorted(p.name for p in out.iterdir() if p.suffix in (".mp4", ".gif"))
    assert [Path(v).stem for v in videos] == ["goal_seed1_timeout", "goal_seed2_timeout"]
    pictures = sorted(p.name for p in out.glob("*.png"))
    assert pictures == ["goal_seed1_timeout_trajectory.png", "goal_seed2_timeout_trajectory.png"]
    assert all((out / name).stat().st_size > 1000 for name in videos + pictures)
    assert sorted(p.name for p in out.iterdir()) == sorted(videos + pictures)  # nothing half-written left
    assert "recorded 2 failed episode(s)" in done.stdout


def test_a_failures_folder_that_cannot_be_made_is_refused_before_any_episode(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    done = _cli("eval", "--policy", "random", "--task", "goal", "--episodes", "500", "--record-failures",
                blocker / "failures", cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "--record-failures" in done.stderr and "is not a folder" in done.stderr
    assert "eval goal" not in done.stderr  # no progress bar: no episode ran


def test_file_names_say_task_seed_and_outcome():
    assert failures.file_stem("obstacles", 10042, "collision") == "obstacles_seed10042_collision"
    assert failures.file_stem("tunnel", 3, "left_map", "runs/a b/checkpoint.pt") == "checkpoint_tunnel_seed3_left_map"
    assert failures.record_failures("random", [("goal", 0, "goal")], "unused") == []  # a success is not rerun
