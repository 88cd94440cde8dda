"""Videos and plots of 6-DOF episodes (`auv_mj.render.video3d`, `auv_mj.cli.render3d`)."""

from __future__ import annotations

import numpy as np

from auv_mj.cli.render3d import plot_depth, plot_track
from auv_mj.render.video3d import Track3D, render_episode_3d
from tasks import auv3d


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
