"""Figures a reader takes in at a glance: a trajectory PNG shaped like its map with the map's legend apart from the
tracks', a video frame with a key to its sonar colours and lines, an arena preview with a readable title and one
label per polygon."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from auv_mj.cli import plots
from auv_mj.episode import record_episode
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
    path = plots.plot_trajectory(tunnel_records, tmp_path / "tunnel.png", labels=["a", "b"], width=1000)
    rows, cols = _blank_fraction(path)
    assert rows < 0.15 and cols < 0.1, (rows, cols)  # the margins and the gaps of title and labels (was 0.36)
    with Image.open(path) as image:
        width, height = image.size
    assert width == 1000 and height < 0.6 * width  # the tunnel is about five times as wide as tall


def test_the_map_legend_is_apart_from_the_tracks_legend(tunnel_records):
    fig = plots.trajectory_figure(tunnel_records, labels=["policy a", "policy b"], width=1000)
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
    path = plots.plot_trajectory(record, tmp_path / "square.png", width=900)
    rows, cols = _blank_fraction(path)
    assert rows < 0.15 and cols < 0.1, (rows, cols)  # was 0.31
    with Image.open(path) as image:
        assert image.size[0] == 900 and 0.5 * 900 < image.size[1] < 1.1 * 900
