"""Episode records and paper-style figures: records round-trip through .npz, PNGs have the asked size."""

from __future__ import annotations

import csv
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from auv_mj.episode import EpisodeRecord, record_episode
from auv_mj.figures import curves, tracking, trajectory
from auv_mj.tasks import suite


def _cruise(time_step) -> np.ndarray:
    return np.array([0.0, 0.05])


@pytest.fixture(scope="module")
def moving_record() -> EpisodeRecord:
    env = suite.load("auv", "moving_obstacles", task_kwargs={"random": 0})
    return record_episode(env, _cruise, max_steps=30, task="moving_obstacles", policy_name="cruise", seed=0)


def _png(path, width: int, height: int) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG" and image.size == (width, height)
        pixels = np.asarray(image.convert("RGB"))
    assert pixels.std() > 10, "blank figure"
    return pixels


def test_record_holds_the_episode(moving_record):
    r = moving_record
    assert r.steps == 30 and r.pose.shape == (31, 3) and r.sonar.shape == (31, 9)
    assert r.action.shape == (30, 2) and r.command.shape == (30, 2) and r.reward.shape == (30,)
    np.testing.assert_allclose(np.diff(r.time), r.control_dt)
    assert np.all(r.command[:, 0] == pytest.approx(1.0))  # V = a0 + 1 (Table 3, forward only)
    assert r.movers.shape[1] == len(r.arena.mover_names) > 0
    assert np.any(np.abs(r.movers[-1] - r.movers[0]) > 0.1), "moving obstacles did not move"
    assert np.all(r.arena.owners[r.arena.owners >= 0] < len(r.arena.mover_names))
    assert "min_clearance" in r.info and r.info["event"].dtype.kind == "U"


def test_record_round_trips_through_npz(moving_record, tmp_path):
    r = moving_record
    loaded = EpisodeRecord.load(r.save(tmp_path / "episode.npz"))
    assert (loaded.task, loaded.policy, loaded.seed) == ("moving_obstacles", "cruise", 0)
    for name in ("time", "pose", "velocity", "sonar", "control", "desired_goal", "movers", "action",
                 "command", "reward", "event", "success"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(r, name))
    assert loaded.info.keys() == r.info.keys()
    assert len(loaded.arena.polygons) == len(r.arena.polygons)
    for a, b in zip(loaded.arena.polygons, r.arena.polygons, strict=True):
        np.testing.assert_array_equal(a, b)
    assert loaded.arena.mover_names == r.arena.mover_names
    assert loaded.arena.goal_radius == r.arena.goal_radius


def test_trajectory_png(moving_record, tmp_path):
    path = trajectory.plot_trajectory([moving_record, moving_record], tmp_path / "traj.png", labels=["a", "b"],
                                 width=640, height=480)
    pixels = _png(path, 640, 480)
    red = (pixels[..., 0] > 200) & (pixels[..., 1] < 60) & (pixels[..., 2] < 60)
    assert red.any(), "no vehicle drawn"


def test_gallery_png_has_a_panel_per_map(moving_record, tmp_path):
    path = trajectory.plot_gallery([moving_record, [moving_record, moving_record], moving_record], tmp_path / "g.png",
                              cols=2, panel_size=(300, 250))
    pixels = _png(path, 600, 500)
    black = pixels.max(axis=-1) < 60  # the map's frame and axes
    assert black[:250, :300].any() and black[:250, 300:].any() and black[250:, :300].any()  # a map per panel
    assert pixels[250:, 300:].min() > 250  # the fourth cell is left blank
    with pytest.raises(ValueError, match="at least one panel"):
        trajectory.plot_gallery([], tmp_path / "none.png")


def test_tracking_png_from_record_and_csv(moving_record, tmp_path):
    _png(tracking.plot_tracking(moving_record, tmp_path / "a.png", width=500, height=700), 500, 700)
    csv_path = tracking.tracking_csv(moving_record, tmp_path / "tracking.csv")
    table = tracking.read_tracking_csv(csv_path)
    np.testing.assert_allclose(table["speed"], moving_record.velocity[1:, 0])
    np.testing.assert_allclose(table["heading_error"], tracking.tracking_table(moving_record)["heading_error"])
    _png(tracking.plot_tracking(csv_path, tmp_path / "b.png", x="time", width=500, height=700), 500, 700)


def _fake_run(path, returns, successes) -> None:
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["episode", "steps", "length", "return", "success", "wall_time"])
        for i, (ret, ok) in enumerate(zip(returns, successes, strict=True)):
            writer.writerow([i + 1, 100 * (i + 1), 100, ret, float(ok), 0.1 * i])


def test_learning_curve_mean_and_band(tmp_path):
    _fake_run(tmp_path / "a.csv", [0.0, 2.0, 4.0], [0, 1, 1])
    _fake_run(tmp_path / "b.csv", [2.0, 4.0, 6.0, 8.0], [0, 0, 1, 1])
    runs = [curves.read_learning_csv(tmp_path / n) for n in ("a.csv", "b.csv")]
    xs, mean, low, high = curves.learning_curve(runs, "return", window=1)
    np.testing.assert_array_equal(xs, [1, 2, 3])  # cut to the shortest run
    np.testing.assert_allclose(mean, [1.0, 3.0, 5.0])
    np.testing.assert_allclose(low, [0.0, 2.0, 4.0])
    np.testing.assert_allclose(high, [2.0, 4.0, 6.0])
    _, mean, low, high = curves.learning_curve(runs, "return", window=2, band="std")
    np.testing.assert_allclose(mean, [1.0, 2.0, 4.0])
    np.testing.assert_allclose(high - mean, [1.0, 1.0, 1.0])


def test_learning_png_from_two_groups_of_runs(tmp_path):
    rng = np.random.default_rng(0)
    for group in ("her", "ddpg"):
        for seed in range(2):
            (tmp_path / group).mkdir(exist_ok=True)
            returns, successes = np.cumsum(rng.normal(1, 1, 40)), rng.random(40) < 0.5
            _fake_run(tmp_path / group / f"run{seed}.csv", returns, successes)
    groups = [("HER-DDPG", [tmp_path / "her" / "*.csv"]), ("DDPG", [tmp_path / "ddpg" / "run*.csv"])]
    path = curves.plot_learning(groups, tmp_path / "learning.png", width=800, height=600)
    _png(path, 800, 600)


def test_plot_learning_cli(tmp_path):
    for name in ("r1", "r2"):
        _fake_run(tmp_path / f"{name}.csv", [1.0, 2.0, 3.0, 4.0], [0, 0, 1, 1])
    out = tmp_path / "fig8.png"
    result = subprocess.run([sys.executable, "-m", "auv_mj.cli", "plot", "learning", "--runs",
                             str(tmp_path / "r*.csv"), "--label", "fake", "-o", str(out), "--width", "400",
                             "--height", "300"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    _png(out, 400, 300)
    missing = subprocess.run([sys.executable, "-m", "auv_mj.cli", "plot", "learning", "--runs",
                              str(tmp_path / "none*.csv"), "-o", str(tmp_path / "none.png")], capture_output=True,
                             text=True, timeout=120)
    assert missing.returncode != 0 and "no training logs match" in missing.stderr


def test_plot_trajectory_reads_saved_episodes_without_a_task(moving_record, tmp_path):
    """`auv-mj plot trajectory EPISODE.npz -o PNG` needs no --task (it reads the episode)."""
    import subprocess
    import sys

    episode = moving_record.save(tmp_path / "episode.npz")
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "plot", "trajectory", str(episode), "-o",
                           str(tmp_path / "t.png")], capture_output=True, text=True, timeout=300,
                          env={"PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "t.png").stat().st_size > 1000
