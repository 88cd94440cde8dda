"""What every figure of `auv_mj.figures` is drawn on: a matplotlib Figure rendered by Agg without pyplot, its size in
pixels, and saving it at exactly that size; and the episode records a figure reads (records or their .npz files)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from auv_mj.episode import EpisodeRecord

DPI = 100
"""Dots per inch of every figure: sizes are given in pixels and divided by this."""
DEFAULT_SIZE = (1000, 800)
"""Default figure size [px]; `width`, `height` arguments set it exactly (at DPI)."""


def new_figure(width: int, height: int, rows: int = 1, cols: int = 1, **kwargs) -> tuple[Figure, object]:
    """A Figure drawn by Agg without pyplot (no display, no global state, whatever backend a caller uses) and its
    axes, `rows` x `cols` of them (`kwargs` go to `Figure.subplots`)."""
    fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    return fig, fig.subplots(rows, cols, **kwargs)


def save(fig: Figure, path: str | Path) -> Path:
    """Writes `fig` as a PNG of its own pixel size to `path`, making its folder if missing."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)  # no bbox_inches="tight": the PNG keeps the requested pixel size
    return path


def as_records(records) -> list[EpisodeRecord]:
    """One record, an episode .npz path, or a list or tuple of them, as a list of `EpisodeRecord`s."""
    items = records if isinstance(records, list | tuple) else [records]
    return [r if isinstance(r, EpisodeRecord) else EpisodeRecord.load(r) for r in items]
