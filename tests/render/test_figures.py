"""Figures a reader takes in at a glance: a trajectory PNG shaped like its map with the map's legend apart from the
tracks', a video frame with a key to its sonar colours and lines, an arena preview with a readable title and one
label per polygon."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from auv_mj.episode import record_episode
from auv_mj.figures import trajectory
from auv_mj.tasks import suite


def _cruise(time_step) -> np.ndarray:
    return np.array([0.0, 0.0])


@pytest.fixture(scope="module")
def tunnel_records():
    """Two short episodes in the paper's tunnel (a map about five times as wide as tall)."""
    env = suite.load("auv", "tunnel", task_kwargs={"random": 0})
    return [record_episode(env, _cruise, max_steps=8, task="tunnel", policy_name=name, seed=0)
            for name in ("first", "second")]


def _blank_fraction(path) -> tuple[float, float]:
    """Fractions of the PNG's rows and columns that are all white."""
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB"))
    blank = pixels.min(axis=2) >= 250
    return float(blank.all(axis=1).mean()), float(blank.all(axis=0).mean())


def _legend_texts(legend) -> list[str]:
    return [text.get_text() for text in legend.get_texts()]


def test_a_wide_map_gives_a_wide_figure_with_little_white_space(tunnel_records, tmp_path):
    path = trajectory.plot_trajectory(tunnel_records, tmp_path / "tunnel.png", labels=["a", "b"], width=1000)
    rows, cols = _blank_fraction(path)
    assert rows < 0.15 and cols < 0.1, (rows, cols)  # the margins and the gaps of title and labels (was 0.36)
    with Image.open(path) as image:
        width, height = image.size
    assert width == 1000 and height < 0.6 * width  # the tunnel is about five times as wide as tall


def test_the_map_legend_is_apart_from_the_tracks_legend(tunnel_records):
    fig = trajectory.trajectory_figure(tunnel_records, labels=["policy a", "policy b"], width=1000)
    legends = fig.legends + [child for ax in fig.axes for child in ax.get_children()
                             if type(child).__name__ == "Legend"]
    assert len(legends) == 2
    by_title = {legend.get_title().get_text(): _legend_texts(legend) for legend in legends}
    assert set(by_title) == {"map", "tracks"}
    assert by_title["tracks"] == ["policy a", "policy b"]
    assert {"walls (known)", "global path", "target area", "start", "AUV"} <= set(by_title["map"])
    assert not {"policy a", "policy b"} & set(by_title["map"])


def test_a_square_map_keeps_its_legends_beside_it(tmp_path):
    env = suite.load("auv", "moving_obstacles", task_kwargs={"random": 0})
    record = record_episode(env, _cruise, max_steps=8, task="moving_obstacles", policy_name="cruise", seed=0)
    path = trajectory.plot_trajectory(record, tmp_path / "square.png", width=900)
    rows, cols = _blank_fraction(path)
    assert rows < 0.15 and cols < 0.1, (rows, cols)  # was 0.31
    with Image.open(path) as image:
        assert image.size[0] == 900 and 0.5 * 900 < image.size[1] < 1.1 * 900


# --- the video's key ----------------------------------------------------------------------------------------------


def _ramps(frame: np.ndarray, least: int = 40) -> list[tuple[int, int, int]]:
    """(row, first column, last column) of horizontal runs of at least `least` pixels coloured as the sonar's echo
    colours (blue 25, red + green >= 255) that go from red to green: the key's colour ramp."""
    found = []
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    echo = (np.abs(b - 25) <= 1) & (r + g >= 250)
    for row in range(frame.shape[0]):
        columns = np.flatnonzero(echo[row])
        if len(columns) < least:
            continue
        runs = np.split(columns, np.flatnonzero(np.diff(columns) > 1) + 1)
        for run in runs:
            if len(run) >= least and r[row, run[0]] > 240 > g[row, run[0]] + 100 and g[row, run[-1]] > 240 > \
                    r[row, run[-1]] + 100:
                found.append((row, int(run[0]), int(run[-1])))
    return found


@pytest.mark.parametrize("camera", ["both", "follow", "overview"])
def test_a_video_frame_has_a_key_to_the_sonar_colours_and_lines(camera):
    from auv_mj import render

    env = suite.load("auv", "obstacles", task_kwargs={"random": 0})
    env.reset()
    frame = render.render_frame(env.physics, width=640, height=360, camera=camera)
    ramps = _ramps(frame)
    assert ramps, "no sonar colour ramp in the frame"
    row, first, last = ramps[0]
    assert row > 360 / 2 and first > 640 / 2, ramps  # in the bottom right corner, clear of the text overlay


def test_the_key_names_what_the_lines_are():
    from auv_mj.render.frame import FrameRenderer

    env = suite.load("auv", "moving_obstacles", task_kwargs={"random": 0})
    env.reset()
    with FrameRenderer(env.physics, 640, 360) as renderer:
        labels = renderer.key_labels
    assert {"sonar echo", "no echo", "map bounds", "trail", "obstacle path"} <= set(labels), labels


# --- the arena preview --------------------------------------------------------------------------------------------

HARBOUR = {
    "name": "harbour", "bounds": [0, 0, 600, 600], "border": True, "start": [60, 300], "heading": 0,
    "goal": [540, 300], "shapes": [
        {"type": "polygon", "name": "pier", "points": [[280, 240], [345, 240], [345, 360], [280, 360], [280, 346],
                                                       [331, 346], [331, 254], [280, 254]]},
        {"type": "polygon", "name": "jetty", "points": [[150, 420], [230, 420], [230, 500], [210, 500], [210, 440],
                                                        [170, 440], [170, 500], [150, 500]]},
        {"type": "box", "name": "buoy_a", "x": 200, "y": 150, "length": 10, "width": 10},
        {"type": "box", "name": "buoy_b", "x": 212, "y": 150, "length": 10, "width": 10},
        {"type": "cylinder", "name": "rock", "x": 450, "y": 420, "radius": 12},
        {"type": "mover", "name": "ferry", "waypoints": [[450, 100], [450, 200]], "speed": 0.2, "radius": 5},
    ]}


@pytest.fixture
def harbour(tmp_path):
    import json

    path = tmp_path / "harbour.json"
    path.write_text(json.dumps(HARBOUR))
    return path


def test_the_arena_preview_is_titled_by_its_file_and_kind(harbour, tmp_path, monkeypatch):
    from auv_mj.assets import model_path
    from auv_mj.cli import main
    from auv_mj.figures import arenas

    titles = []
    plot = arenas.plot_arena
    monkeypatch.setattr(arenas, "plot_arena", lambda *args, **kwargs: titles.append(kwargs["title"])
                        or plot(*args, **kwargs))
    assert main(["arena", str(harbour), "-o", str(tmp_path / "harbour.xml")]) == 0
    report = arenas.preview(model_path("arenas/validation/l_bend.xml"), tmp_path / "l_bend.png")
    assert titles == ["harbour.xml: open-water arena", "l_bend.xml: tunnel arena"]
    assert report.ok and (tmp_path / "harbour.png").exists() and report.png == tmp_path / "l_bend.png"


def test_the_check_draws_nothing_and_its_report_is_drawn_after(tmp_path):
    """The arenas layer checks; the figures draw: a report of `check_arena` holds what its preview needs, drawn
    later by `preview` exactly as the one call draws it."""
    from auv_mj.arenas import arena_check
    from auv_mj.assets import model_path
    from auv_mj.figures import arenas

    source = model_path("arenas/validation/l_bend.xml")
    report = arena_check.check_arena(source)
    assert report.ok and report.png is None and report.view.kind == "tunnel"
    assert not list(tmp_path.iterdir())
    assert arenas.preview(report, tmp_path / "later.png") is report and report.png == tmp_path / "later.png"
    assert arenas.is_preview(report.png)
    once = arenas.preview(source, tmp_path / "once.png")
    assert once.lines() == report.lines() and arenas.is_preview(once.png)
    assert arena_check.check_arena(tmp_path / "missing.xml").view is None  # nothing loads, nothing to draw
    assert arenas.preview(tmp_path / "missing.xml", tmp_path / "none.png").png is None


def test_a_polygon_is_labelled_once_and_no_labels_overlap(harbour):
    from auv_mj.arenas import layout
    from auv_mj.arenas.arena import arena_info, load
    from auv_mj.figures.arenas import arena_figure

    physics = load(layout.read_layout(harbour).element("test"))
    fig = arena_figure(physics, arena_info(physics), title="harbour")
    renderer = fig.canvas.get_renderer()
    texts = [t for t in fig.axes[0].texts if t.get_text()]
    names = [t.get_text() for t in texts]
    assert names.count("obstacle_pier") == 1 and names.count("obstacle_jetty") == 1, names
    assert not [n for n in names if re.fullmatch(r"obstacle_(pier|jetty)_\d+", n)], names
    assert {"obstacle_buoy_a", "obstacle_buoy_b", "obstacle_rock"} <= set(names), names
    boxes = [t.get_window_extent(renderer) for t in texts]
    overlaps = [(names[i], names[j]) for i in range(len(boxes)) for j in range(i) if boxes[i].overlaps(boxes[j])]
    assert not overlaps, overlaps
