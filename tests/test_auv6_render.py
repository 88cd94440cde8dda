"""Videos and plots of 6-DOF episodes (`auv_mj.render.video3d`, `auv_mj.cli.render3d`)."""

from __future__ import annotations

import numpy as np

from auv_mj.cli.render3d import plot_depth, plot_track
from auv_mj.render.video3d import Track3D, render_episode_3d
from auv_mj.tasks import auv3d


def test_three_panels_per_control_step_and_the_track_beside_them(tmp_path):
    env = auv3d.depth_heading(random=0)
    track = Track3D()
    frames = render_episode_3d(env, auv3d.splane_policy(env), max_steps=3, size=(64, 48), track=track)
    assert frames.shape == (4, 48, 3 * 64, 3) and frames.dtype == np.uint8
    chase = np.split(frames[-1], 3, axis=1)[0]
    assert chase.std() > 1.0  # the hull fills the chase view (open water leaves the others dark)
    arrays = track.arrays()
    assert arrays["position"].shape == (4, 3) and np.allclose(arrays["position"][0, 2], -auv3d.START_DEPTH)
    assert plot_depth(arrays, tmp_path / "depth.png").stat().st_size > 1000
    assert plot_track(arrays, tmp_path / "track.png", goal=np.zeros(3)).stat().st_size > 1000


def test_auv_mj_render_draws_a_6dof_task_and_its_plots(tmp_path):
    """`auv-mj render` on an auv3d task writes the three-panel video and the depth and track figures."""
    import subprocess
    import sys

    out = tmp_path / "dive.mp4"
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "render", "--task", "depth_heading", "--policy",
                           "splane", "--max-steps", "8", "-o", str(out), "--plots", str(tmp_path / "dive")],
                          capture_output=True, text=True, timeout=300, env={"PATH": "/usr/bin:/bin",
                                                                            "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 0
    assert (tmp_path / "dive_depth.png").stat().st_size > 0 and (tmp_path / "dive_track.png").stat().st_size > 0
    bad = subprocess.run([sys.executable, "-m", "auv_mj.cli", "render", "--task", "nope", "-o", str(out)],
                         capture_output=True, text=True, timeout=300, env={"PATH": "/usr/bin:/bin",
                                                                          "MUJOCO_GL": "egl"})
    assert bad.returncode == 2 and "task 'nope' does not exist" in bad.stderr and "Traceback" not in bad.stderr
