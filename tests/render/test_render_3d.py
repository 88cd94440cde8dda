"""Videos and plots of 6-DOF episodes (`auv_mj.render.frame3d`, `auv_mj.render.episode_video3d`,
`auv_mj.cli.render3d`): tiny frames, few steps."""

from __future__ import annotations

import math

import numpy as np

from auv_mj.figures.trajectory3d import plot_depth, plot_track
from auv_mj.planners.los3d import los_policy
from auv_mj.render.episode_video3d import Track3D, interpolate, render_episode_3d
from auv_mj.render.frame3d import BAR_RGB, Layout, State3D
from auv_mj.tasks import auv3d


def test_frames_interpolate_the_control_steps_and_carry_the_panels_the_hud_and_the_progress_bar(tmp_path):
    """At fps / speedup = 10 frames per simulated second a 0.5 s planning step gives five frames, the vehicle
    moving smoothly between them; each frame has the chase, top and side panels, the heads-up display (white text
    in the chase view's top-left corner), and a progress bar along the bottom."""
    env = auv3d.tunnel3d(random=0)
    track = Track3D()
    size = (320, 240)
    frames = render_episode_3d(env, los_policy(env), in_memory=True, max_steps=2, width=size[0], height=size[1], fps=10,
                               speedup=1.0, hold_end=0.0, track=track)
    assert frames.shape == (11, 240, 320, 3) and frames.dtype == np.uint8
    layout = Layout.of(*size)
    left, bottom, width, height = layout.panels["chase"]
    rows = slice(size[1] - bottom - height, size[1] - bottom)
    chase = frames[-1][rows, left:left + width]
    assert chase.std() > 5.0
    corner = chase[: height // 3, : width // 3]
    assert np.any(np.all(corner == 178, axis=-1))  # the HUD's labels, grey as MuJoCo's overlay draws them
    bar = frames[:, size[1] - layout.bar + 1]
    filled = np.all(bar == BAR_RGB, axis=-1).sum(axis=1)
    assert filled[0] == 0 and filled[-1] > 0 and np.all(np.diff(filled) >= 0)
    assert track.arrays()["position"].shape == (3, 3)
    changes = [float(np.abs(frames[k + 1].astype(int) - frames[k]).mean()) for k in range(len(frames) - 1)]
    assert min(changes) > 0.0  # every interpolated frame moves on


def test_interpolation_is_linear_between_control_steps_and_keeps_the_quaternion_a_rotation():
    qa, qb = np.array([0, 0, -10, 1, 0, 0, 0.0]), np.array([2, 0, -11, math.cos(0.2), 0, 0, math.sin(0.2)])
    a = State3D(0.0, qa, np.zeros((0, 3)), np.full(27, 5.0), np.zeros(6), 3.0, 10.0, 0.2)
    b = State3D(0.5, qb, np.zeros((0, 3)), np.full(27, 7.0), np.ones(6), 4.0, 9.0, 0.3, "goal")
    middle = interpolate(a, b, 0.25)
    np.testing.assert_allclose(middle.qpos[:3], [1.0, 0.0, -10.5])
    assert middle.altitude == 3.5 and middle.progress == 0.25 and np.all(middle.sonar == 5.0)  # sonar held
    assert interpolate(a, b, 0.5) is b


def test_plots_of_depth_and_track(tmp_path):
    env = auv3d.depth_heading(random=0)
    track = Track3D()
    frames = render_episode_3d(env, auv3d.splane_policy(env), in_memory=True, max_steps=2, width=64, height=48,
                               track=track, hold_end=0.0)
    assert frames.shape == (3, 48, 64, 3)
    arrays = track.arrays()
    assert arrays["position"].shape == (3, 3) and np.allclose(arrays["position"][0, 2], -auv3d.START_DEPTH)
    assert plot_depth(arrays, tmp_path / "depth.png").stat().st_size > 1000
    assert plot_track(arrays, tmp_path / "track.png", goal=np.zeros(3)).stat().st_size > 1000


def test_auv_mj_render_draws_a_6dof_task_and_its_plots(tmp_path):
    """`auv-mj render` on an auv3d task writes the three-panel video and the depth and track figures."""
    import subprocess
    import sys

    out = tmp_path / "dive.mp4"
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "render", "--task", "depth_heading", "--policy",
                           "splane", "--max-steps", "3", "--width", "160", "--height", "96", "-o", str(out),
                           "--plots", str(tmp_path / "dive")],
                          capture_output=True, text=True, timeout=300, env={"PATH": "/usr/bin:/bin",
                                                                            "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr
    import imageio.v3 as iio

    video = iio.imread(out, index=None)
    assert video.shape == (3 + 1 + 30, 96, 160, 3)  # the reset and three steps, a frame each, then 1 s held
    assert iio.immeta(out)["fps"] == 30
    assert (tmp_path / "dive_depth.png").stat().st_size > 0 and (tmp_path / "dive_track.png").stat().st_size > 0
    bad = subprocess.run([sys.executable, "-m", "auv_mj.cli", "render", "--task", "nope", "-o", str(out)],
                         capture_output=True, text=True, timeout=300, env={"PATH": "/usr/bin:/bin",
                                                                          "MUJOCO_GL": "egl"})
    assert bad.returncode == 2 and "unknown task 'nope'" in bad.stderr and "Traceback" not in bad.stderr
