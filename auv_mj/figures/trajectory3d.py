"""Figures of a 6-DOF episode (matplotlib, Agg): depth against time, and the track in 3-D with a tube's centreline
or the goal. `auv-mj render --task tunnel3d ... --plots PREFIX` draws both (`TrackFigures`, the 6-DOF domain's
`figures`); `track` is the dict of arrays of `auv_mj.episode.Track3D.arrays` (time, position, depth_command).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from auv_mj.episode import Track3D
from auv_mj.figures.canvas import DPI


def plot_depth(track: dict[str, np.ndarray], path: str | Path, title: str = "") -> Path:
    """Depth [m] against time [s], the depth command dashed where there is one; depth grows downwards."""
    fig = Figure(figsize=(8, 4), dpi=DPI)
    ax = fig.add_subplot()
    ax.plot(track["time"], -track["position"][:, 2], label="depth")
    if np.any(np.isfinite(track["depth_command"])):
        ax.plot(track["time"], track["depth_command"], "--", label="command")
    ax.invert_yaxis()
    ax.set(xlabel="time [s]", ylabel="depth [m]", title=title)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


def plot_track(track: dict[str, np.ndarray], path: str | Path, centreline: np.ndarray | None = None,
               goal: np.ndarray | None = None, title: str = "") -> Path:
    """The 3-D track (x, y, depth), with a tube's centreline and the goal if given."""
    fig = Figure(figsize=(7, 6), dpi=DPI)
    ax = fig.add_subplot(projection="3d")
    p = track["position"]
    ax.plot(p[:, 0], p[:, 1], -p[:, 2], label="vehicle")
    if centreline is not None and len(centreline) >= 2:
        ax.plot(centreline[:, 0], centreline[:, 1], -centreline[:, 2], "--", label="tube centreline")
    if goal is not None:
        ax.scatter([goal[0]], [goal[1]], [-goal[2]], color="tab:red", label="goal")
    ax.invert_zaxis()
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="depth [m]", title=title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


class TrackFigures:
    """The 6-DOF domain's figures of an episode (`auv_mj.tasks.domains.Domain.figures`): the 3-D track gathered
    beside the episode (`add`, a video's `track`) and drawn as PREFIX_depth.png and PREFIX_track.png (`write`),
    with the task's tube centreline or goal."""

    def __init__(self, prefix: str, title: str = ""):
        self.prefix, self.title = prefix, title
        self.track = Track3D()

    def files(self) -> list[str]:
        """The figures' file names."""
        return [f"{self.prefix}_depth.png", f"{self.prefix}_track.png"]

    def add(self, env) -> None:
        """The environment's state now (after the reset and each control step)."""
        self.track.add(env)

    def write(self, env) -> list[Path]:
        """Draws the figures of the episode gathered, with `env`'s task's centreline and goal; the paths."""
        arrays = self.track.arrays()
        depth, track = self.files()
        return [plot_depth(arrays, depth, self.title),
                plot_track(arrays, track, getattr(env.task, "path", None), getattr(env.task, "goal", None),
                           self.title)]
