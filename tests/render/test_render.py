"""Headless episode videos: MP4/GIF files that decode, show the vehicle moving, and clear GL errors."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from auv_mj import render
from auv_mj.episode import EpisodeRecord, EpisodeRecorder, Snapshot
from auv_mj.tasks import suite

SIZE = (160, 120)
CLI = [sys.executable, "-m", "auv_mj.cli", "render"]


def _cruise(time_step) -> np.ndarray:
    """Straight on at 1 m/s."""
    return np.array([0.5, 0.0])


def _marker_centroid(frame: np.ndarray) -> np.ndarray:
    """(column, row) of the red vehicle marker's pixels."""
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    rows, cols = np.nonzero((r > 150) & (g < 110) & (b < 110))
    assert rows.size, "no marker pixels"
    return np.array([cols.mean(), rows.mean()])


def _decode(path: Path) -> np.ndarray:
    with imageio.get_reader(path) as reader:
        return np.stack([frame for frame in reader.iter_data()])


@pytest.fixture(scope="module")
def overview_video(tmp_path_factory):
    """An MP4 of 120 goal-task steps seen in the overview, one frame every 6 steps (21 frames)."""
    env = suite.load("auv", "goal", task_kwargs={"random": 0})
    recorder = EpisodeRecorder(env, "goal", "cruise", 0)
    speedup = render.DEFAULT_FPS * env.control_timestep() * 6
    frames = render.iter_frames(env, _cruise, max_steps=120, width=SIZE[0], height=SIZE[1], camera="overview",
                                speedup=speedup, hold_end=0.0, recorder=recorder)
    path = render.write_video(frames, tmp_path_factory.mktemp("video") / "goal.mp4")
    return path, recorder.record()


def test_mp4_decodes_with_the_expected_frames(overview_video):
    path, record = overview_video
    assert path.suffix == ".mp4"
    video = _decode(path)
    assert video.shape == (21, SIZE[1], SIZE[0], 3)
    assert record.steps == 120
    assert all(frame.std() > 5 for frame in video), "blank frame"


def test_vehicle_marker_moves_as_the_vehicle(overview_video):
    path, record = overview_video
    video = _decode(path)
    _, _, width, height = render.arena_extent(record.arena)
    view_h = max(height, width * SIZE[1] / SIZE[0])
    metres = record.pose[-1, :2] - record.pose[0, :2]
    expected = np.array([metres[0], -metres[1]]) * SIZE[1] / view_h  # image rows grow downwards
    moved = _marker_centroid(video[-1]) - _marker_centroid(video[0])
    assert np.hypot(*expected) > 6, "test episode too short to see motion"
    assert np.hypot(*(moved - expected)) < 3, (moved, expected)


def test_follow_and_both_cameras_show_decorations():
    env = suite.load("auv", "moving_obstacles", task_kwargs={"random": 0})
    for camera in ("follow", "both"):
        frames = render.render_episode(env, _cruise, in_memory=True, max_steps=2, width=SIZE[0], height=SIZE[1],
                                       camera=camera, hold_end=0.0)
        assert frames.shape == (3, SIZE[1], SIZE[0], 3)
        assert frames.dtype == np.uint8 and frames[-1].std() > 5
        centre = _marker_centroid(frames[-1])
        if camera == "follow":  # the follow camera keeps the vehicle in the middle
            assert np.hypot(*(centre - np.array(SIZE) / 2)) < 4


def test_gif(tmp_path):
    frames = [np.full((SIZE[1], SIZE[0], 3), 40 * i, dtype=np.uint8) for i in range(4)]
    path = render.write_video(iter(frames), tmp_path / "clip.mp4", fps=10, gif=True)
    assert path == tmp_path / "clip.gif"
    video = np.stack(imageio.mimread(path))
    assert video.shape[:3] == (4, SIZE[1], SIZE[0])
    assert video[3, ..., :3].mean() > video[1, ..., :3].mean()


def test_render_frame_of_a_physics_state():
    env = suite.load("auv", "obstacles", task_kwargs={"random": 0})
    env.reset()
    frame = render.render_frame(env.physics, width=SIZE[0], height=SIZE[1], camera="overview")
    assert frame.shape == (SIZE[1], SIZE[0], 3) and frame.std() > 5


def test_interpolation_wraps_heading_and_holds_sonar():
    def snap(t, psi, sonar):
        return Snapshot(time=t, pose=np.array([0.0, 0.0, psi]), velocity=np.zeros(3), sonar=np.full(9, sonar),
                        control=np.zeros(2), desired_goal=np.zeros(2), movers=np.zeros((1, 2)), step=int(t))
    a, b = snap(0.0, math.pi - 0.1, 50.0), snap(1.0, -math.pi + 0.1, 10.0)
    mid = render.interpolate(a, b, 0.5)
    assert abs(abs(mid.pose[2]) - math.pi) < 1e-9  # through +-pi, not through 0
    assert np.all(mid.sonar == 50.0)  # the 2 Hz sonar holds its last sample
    assert render.interpolate(a, b, 1.0 - 1e-9) is b  # physics time drifts by ulps


def _env_without_display(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL",
                                                            "PYOPENGL_PLATFORM")}
    env.update(extra)
    return env


def test_cli_renders_without_a_display(tmp_path):
    out, episode = tmp_path / "random.mp4", tmp_path / "random.npz"
    result = subprocess.run(CLI + ["--task", "goal", "--policy", "random", "--seed", "3", "-o", str(out),
                                   "--width", "161", "--height", "121", "--max-steps", "5", "--hold-end", "0",
                                   "--no-progress", "--save-episode", str(episode)],
                            env=_env_without_display(), capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    video = _decode(out)
    assert video.shape == (6, 120, 160, 3)  # odd sizes are made even for yuv420p
    assert EpisodeRecord.load(episode).steps == 5


def test_broken_mujoco_gl_is_a_clear_error(tmp_path):
    result = subprocess.run(CLI + ["--task", "goal", "-o", str(tmp_path / "x.mp4"), "--max-steps", "1"],
                            env=_env_without_display(MUJOCO_GL="nonsense"), capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 2
    assert "MUJOCO_GL='nonsense'" in result.stderr
    assert all(v in result.stderr for v in ("egl", "osmesa", "glfw"))
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "x.mp4").exists()


def test_missing_gl_libraries_name_the_packages(tmp_path):
    # Unloadable stand-ins for libEGL/libOSMesa, found first through LD_LIBRARY_PATH.
    for name in ("libEGL.so.1", "libEGL.so", "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"):
        (tmp_path / name).write_bytes(b"not a library")
    result = subprocess.run(CLI + ["--task", "goal", "-o", str(tmp_path / "x.mp4"), "--max-steps", "1"],
                            env=_env_without_display(LD_LIBRARY_PATH=str(tmp_path)), capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 2
    assert "libegl1" in result.stderr and "libosmesa6" in result.stderr
    assert "Traceback" not in result.stderr


def test_numpy_text_matches_mujoco_overlay():
    """The overlay drawn in numpy (glyph cells read back once) is pixel for pixel MuJoCo's mjr_overlay."""
    import mujoco

    from auv_mj.render.raster import BitmapFont

    env = suite.load("auv", "obstacles", task_kwargs={"random": 0})
    env.reset()
    width, height = 640, 360
    with render.FrameRenderer(env.physics, width, height, "follow") as renderer:
        ctx, full = renderer._context, mujoco.MjrRect(0, 0, width, height)
        font = BitmapFont(ctx, mujoco.mjtFont.mjFONT_NORMAL, width, height)
        text, values = "time\nspeed", "   12.5 s   step 25\n 1.00 m/s   cmd 1.00"
        mujoco.mjr_rectangle(full, 0.2, 0.4, 0.6, 1.0)
        mujoco.mjr_overlay(mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_TOPLEFT, full, text, values, ctx)
        mujoco.mjr_overlay(mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_BOTTOMRIGHT, full, "100 m", "",
                           ctx)
        expected = np.empty((height, width, 3), np.uint8)
        mujoco.mjr_readPixels(expected, None, full, ctx)
        expected = expected[::-1]
        mujoco.mjr_rectangle(full, 0.2, 0.4, 0.6, 1.0)
        ours = np.empty((height, width, 3), np.uint8)
        mujoco.mjr_readPixels(ours, None, full, ctx)
        ours = ours[::-1].copy()
        font.overlay(ours, mujoco.mjtGridPos.mjGRID_TOPLEFT, (0, 0, width, height), text, values)
        font.overlay(ours, mujoco.mjtGridPos.mjGRID_BOTTOMRIGHT, (0, 0, width, height), "100 m")
    assert np.array_equal(ours, expected), np.argwhere(np.any(ours != expected, axis=2))[:5]


def test_raster_lines_squares_and_polygons_cover_their_pixels():
    """numpy drawing: a wide line covers its pixels except hidden ones, in its opacity; a square and a
    polygon cover the pixels whose centres they contain."""
    from auv_mj.render import raster

    image = np.zeros((20, 30, 3), np.uint8)
    hidden = np.zeros((20, 30), bool)
    hidden[:, 10] = True
    clip = (0, 20, 0, 30)
    raster.lines(image, np.array([[2.5, 5.5], [3.5, 15.5]]), np.array([[20.5, 5.5], [3.5, 15.5]]),
                 np.array([[255, 0, 0], [0, 255, 0]]), np.array([2, 1]), np.array([1.0, 0.5]), clip, hidden)
    red = np.all(image == (255, 0, 0), axis=2)
    assert red[5:7, 2:21].sum() == 2 * 19 - 2 and not red[:, 10].any() and red.sum() == 2 * 19 - 2
    assert tuple(image[15, 3]) == (0, 128, 0)  # a one-pixel segment, half opaque over black
    raster.fill_squares(image, np.array([[25.0, 10.0]]), 5, np.array([[0, 0, 255]]), clip)
    assert np.all(image[7:12, 22:27] == (0, 0, 255)) and tuple(image[10, 27]) != (0, 0, 255)
    mask, row, col = raster.polygon_mask(np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 4.0], [1.0, 4.0]]))
    assert (row, col) == (1, 1) and mask.sum() == 12 and mask[:3, :4].all()


# --- render_episode: streamed to its file, in memory only when asked ------------------------------------------------


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_render_episode_streams_to_its_file_with_memory_flat_in_the_episodes_length(tmp_path, suffix):
    """The frames go to the file as they are drawn: eight times the steps take about the same peak memory (a
    640 x 480 frame is 0.9 MB; keeping 70 more of them would add 64 MB, the episode record adds about 2 MB)."""
    import tracemalloc

    peaks = {}
    for steps in (10, 80):
        env = suite.load("auv", "goal", task_kwargs={"random": 0})
        tracemalloc.start()
        path = render.render_episode(env, _cruise, tmp_path / f"goal{steps}{suffix}", max_steps=steps, width=640,
                                     height=480, hold_end=0.0)
        peaks[steps] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert path == tmp_path / f"goal{steps}{suffix}" and len(_decode(path)) == steps + 1
    assert peaks[80] - peaks[10] < 8 * 640 * 480 * 3, peaks


class _Stop(Exception):
    pass


def _stop(time_step):
    """A policy that ends the render at its first step (after the warnings that come before it)."""
    raise _Stop


def test_render_episode_in_memory_is_asked_for_and_says_its_size():
    env = suite.load("auv", "tunnel", task_kwargs={"random": 0})
    with pytest.raises(ValueError, match=r"path=.*in_memory=True.*frames of 1280 x 720: [0-9.]+ GB"):
        render.render_episode(env, _cruise)  # neither: no 2 GB array unless asked for
    with pytest.raises(_Stop), pytest.warns(UserWarning, match=r"every frame in memory, up to \d+ frames of "
                                                                r"1280 x 720: [0-9.]+ GB; give path="):
        render.render_episode(env, _stop, in_memory=True)
    small = render.render_episode(env, _cruise, in_memory=True, max_steps=1, width=SIZE[0], height=SIZE[1],
                                  hold_end=0.0)
    assert small.shape == (2, SIZE[1], SIZE[0], 3)


def test_render_episode_has_an_explicit_signature_and_the_defaults_of_render_frame():
    import inspect

    parameters = inspect.signature(render.render_episode).parameters
    assert not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())
    assert {"path", "in_memory", "max_steps", "width", "height", "camera", "fps", "progress"} <= set(parameters)
    for function in (render.render_episode, render.iter_frames, render.render_frame):
        signature = inspect.signature(function).parameters
        assert (signature["width"].default, signature["height"].default) == render.DEFAULT_SIZE, function.__name__


# --- the Gymnasium frame is the video's ------------------------------------------------------------------------------


@pytest.mark.parametrize("gym_id", ["auv_mj/Obstacles-v0", "auv_mj/Goal3D-v0"])
def test_the_gymnasium_frame_is_the_videos_frame(gym_id):
    """render_mode="rgb_array" draws what `auv-mj render` draws at each control step (goal, path, sonar, trail, text
    overlay and key; the 6-DOF panels and heads-up display), at the videos' size, by the same renderer."""
    import gymnasium

    from auv_mj.render.episode_video3d import iter_frames_3d

    steps, size = 4, (320, 240)
    env = gymnasium.make(gym_id, render_mode="rgb_array", render_size=size[::-1])
    action = np.resize([0.5, 0.25], env.action_space.shape)  # numbers float32 holds exactly, as the face passes them
    assert gymnasium.make(gym_id, render_mode="rgb_array").unwrapped.render_size == render.DEFAULT_SIZE[::-1]
    env.reset(seed=0)
    shown = [env.render()]
    for _ in range(steps):
        env.step(action.astype(np.float32))
        shown.append(env.render())
    dm_env = env.unwrapped.dm_env
    dm_env.task.random.seed(0)
    frames = iter_frames_3d if "3D" in gym_id else render.iter_frames
    video = list(frames(dm_env, lambda time_step: action, max_steps=steps, width=size[0], height=size[1], hold_end=0.0,
                        title=gym_id))
    env.close()
    assert len(video) == len(shown) == steps + 1
    for k, (ours, theirs) in enumerate(zip(shown, video, strict=True)):
        assert ours.shape == (size[1], size[0], 3) and ours.dtype == np.uint8
        assert np.array_equal(ours, theirs), f"step {k}: {np.abs(ours.astype(int) - theirs).max()}"
    assert shown[-1].std() > 20  # not the nearly black frame of a bare camera
