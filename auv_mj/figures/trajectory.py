"""Maps with the vehicle's tracks (matplotlib, Agg): the paper's trajectory figures (Figs. 9-11, 13a, 14a, 16).

- `plot_trajectory` (`trajectory_figure`): the map (bounds, walls, obstacles as polygons, moving obstacles and their
  paths), the global path, start, goal area and the tracks of one or more episodes on it, with the map's legend and
  the tracks' legend beside or below it;
- `plot_gallery`: several such maps side by side (e.g. held-out procedural tunnels with their tracks);
- `draw_trajectory`: one map and its tracks on a given axes.

Inputs are `EpisodeRecord`s or their .npz files (`auv_mj.episode`); `auv-mj plot trajectory` wraps them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Polygon, Rectangle

from auv_mj.episode import EpisodeRecord
from auv_mj.figures.canvas import DEFAULT_SIZE, DPI, as_records, new_figure, save

VEHICLE_MARK = 0.02
"""The vehicle's red rectangle is drawn this fraction of the map's size long (the hull is 1.33 m)."""
MAP_MARGIN = 0.02
"""Water shown around the map, as a fraction of its larger side (the same in x and y: the axes are to scale)."""
TRACK_STYLES = (("tab:blue", "-", 3.6), ("tab:purple", (0, (6, 2)), 2.6), ("black", (0, (4, 1.5, 1, 1.5)), 1.7),
                ("tab:pink", (0, (1, 1.2)), 1.8), ("tab:brown", (0, (8, 3)), 1.3), ("tab:cyan", "-", 1.0))
"""(colour, dash pattern, width) of the trajectory figure's tracks, in the order of the records: each wider one is
drawn under the narrower ones after it, so that tracks that run together all show (one policy's under another's);
no colour of the map's own (the green global path, the red AUV, the orange movers, the gold goals)."""
TRACK_ALPHA = 0.85
"""Opacity of a track: one under another still shows through."""
LEGEND_BELOW_ASPECT = 0.75
"""A map flatter than this (height / width) has its legends below it, a taller one beside it: a tunnel is
several times as wide as tall, and legends beside it would make the figure tall and mostly white."""
FIT_PAD = 8
"""Margin [px] around a fitted trajectory figure's content, and between its legends."""
FIT_HEIGHT = (200, 1.5)
"""A fitted trajectory figure is at least this many pixels tall and at most this many times its width."""


# --- trajectory (Figs. 9-11, 13a, 14a, 16) ----------------------------------------------------------


def draw_trajectory(ax, records: Sequence[EpisodeRecord], labels: Sequence[str] | None = None,
                    legend: bool = True) -> tuple[list, list]:
    """Draws the map of the first record and the trajectories of all on `ax` (paper's Sec. 4.1 legend:
    black square map, black obstacles, yellow target area, blue path, red rectangle AUV).

    Returns the handles of the two legends: the map's (walls, obstacles, route, goals, movers, start, AUV) and the
    tracks' (one per record, labelled with `labels`). With `legend`, both are drawn in the axes' corners (a
    gallery's panel); `trajectory_figure` lays them out beside or below the map instead.
    """
    arena = records[0].arena
    walls_done = obstacles_done = False
    for polygon, kind, owner in zip(arena.polygons, arena.kinds, arena.owners, strict=True):
        if owner >= 0:
            continue
        wall = kind == "wall"
        label = None
        if wall and not walls_done:
            label, walls_done = "walls (known)", True
        elif not wall and not obstacles_done:
            label, obstacles_done = "obstacles", True
        ax.add_patch(Polygon(polygon, closed=True, facecolor="0.55" if wall else "black",
                             edgecolor="0.3" if wall else "black", linewidth=0.5, label=label, zorder=2))
    bounds = arena.bounds
    if np.all(np.isfinite(bounds)):
        ax.add_patch(Rectangle(bounds[:2], bounds[2] - bounds[0], bounds[3] - bounds[1], fill=False,
                               edgecolor="black", linewidth=1.5, zorder=1))
    if len(arena.path) > 1:
        ax.plot(*arena.path.T, "--", color="tab:green", linewidth=1.2, label="global path", zorder=3)
    size = _map_size(records)
    tracks = []
    for i, record in enumerate(records):
        colour, dashes, width = TRACK_STYLES[i % len(TRACK_STYLES)]
        label = labels[i] if labels else ("AUV path" if len(records) == 1 else f"{record.task} {record.seed}")
        goals = record.arena.goals if len(record.arena.goals) else record.subgoals()
        radius = record.arena.goal_radius
        for j, goal in enumerate(goals):
            last = j == len(goals) - 1
            ax.add_patch(Circle(goal, radius, facecolor="gold", alpha=0.6 if last else 0.35,
                                edgecolor="goldenrod", linewidth=0.8, zorder=3,
                                label="target area" if (i == 0 and last) else None))
        _draw_movers(ax, record, first=i == 0)
        xy = record.pose[:, :2]
        tracks += ax.plot(*xy.T, linestyle=dashes, color=colour, linewidth=width, alpha=TRACK_ALPHA, label=label,
                          zorder=5 + i / 100, solid_capstyle="butt", dash_capstyle="butt")
        ax.plot(*xy[0], "o", color=colour, markersize=5, zorder=6)
        _draw_vehicle(ax, record.pose[-1], size * VEHICLE_MARK, first=i == 0)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    extent = _extent(records)
    ax.set_xlim(extent[0], extent[2])
    ax.set_ylim(extent[1], extent[3])
    # Each track starts at a dot of its colour; the map's legend shows one neutral dot for all.
    start = Line2D([], [], marker="o", color="0.35", linestyle="none", markersize=5, label="start")
    handles = [h for h in ax.get_legend_handles_labels()[0] if not any(h is t for t in tracks)]
    vehicle = [h for h in handles if h.get_label() == "AUV"]
    map_handles = [h for h in handles if h.get_label() != "AUV"] + [start] + vehicle
    if legend:
        first = ax.legend(handles=map_handles, title="map", loc="upper left", fontsize="x-small",
                          title_fontsize="x-small", framealpha=0.8)
        ax.add_artist(first)
        ax.legend(handles=tracks, title="tracks", loc="lower right", fontsize="x-small", title_fontsize="x-small",
                  framealpha=0.8)
    return map_handles, tracks


def _draw_movers(ax, record: EpisodeRecord, first: bool) -> None:
    """Moving obstacles: their footprints at the last step and the tracks they moved along (dotted)."""
    arena = record.arena
    labelled = not first
    for m in range(len(arena.mover_names)):
        track = record.movers[:, m]
        ax.plot(*track.T, ":", color="tab:orange", linewidth=1.5, zorder=4,
                label=None if labelled else "obstacle path")
        shift = track[-1] - track[0]
        for polygon in (p for p, owner in zip(arena.polygons, arena.owners, strict=True) if owner == m):
            ax.add_patch(Polygon(polygon + shift, closed=True, facecolor="tab:orange", edgecolor="black",
                                 linewidth=0.5, zorder=4, label=None if labelled else "moving obstacle"))
            labelled = True
        labelled = True


def _draw_vehicle(ax, pose: np.ndarray, length: float, first: bool) -> None:
    """The AUV as a red rectangle (3:1) at `pose`."""
    x, y, psi = pose
    c, s = math.cos(psi), math.sin(psi)
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * (length / 2, length / 6)
    corners = half @ np.array([[c, s], [-s, c]]) + (x, y)
    ax.add_patch(Polygon(corners, closed=True, facecolor="red", edgecolor="darkred", zorder=7,
                         label="AUV" if first else None))


def _extent(records: Sequence[EpisodeRecord]) -> np.ndarray:
    """(xmin, ymin, xmax, ymax) showing the map, or everything drawn when there is no map."""
    bounds = records[0].arena.bounds
    if np.all(np.isfinite(bounds)):
        lo, hi = bounds[:2], bounds[2:]
    else:
        points = [r.pose[:, :2] for r in records] + [r.arena.path for r in records]
        points += [p for r in records for p in r.arena.polygons]
        points += [r.arena.goals for r in records] + [r.movers.reshape(-1, 2) for r in records]
        points = np.concatenate([p.reshape(-1, 2) for p in points])
        points = points[np.all(np.isfinite(points), axis=1)]
        lo, hi = points.min(axis=0), points.max(axis=0)
        pad = max(records[0].arena.goal_radius, 5.0)
        lo, hi = lo - pad, hi + pad
    margin = MAP_MARGIN * max(hi - lo)
    return np.array([*(lo - margin), *(hi + margin)])


def _map_size(records: Sequence[EpisodeRecord]) -> float:
    e = _extent(records)
    return float(max(e[2] - e[0], e[3] - e[1]))


def trajectory_figure(records, labels: Sequence[str] | None = None, title: str | None = None,
                      width: int = DEFAULT_SIZE[0], height: int | None = None) -> Figure:
    """The figure of `plot_trajectory`: the map and its tracks, with the map's legend and the tracks' legend apart,
    below a map flatter than LEGEND_BELOW_ASPECT and beside a taller one.

    `height` None fits the figure to its content: the map at its own aspect ratio across the width, its labels,
    the title and the legends, FIT_PAD around them (a tunnel gives a wide, low figure; the 600 m map square a
    squarer one).
    """
    records = as_records(records)
    extent = _extent(records)
    aspect = (extent[3] - extent[1]) / (extent[2] - extent[0])
    below = aspect < LEGEND_BELOW_ASPECT
    fig, ax = new_figure(width, height or width)
    map_handles, tracks = draw_trajectory(ax, records, labels, legend=False)
    record = records[0]
    ax.set_title(title if title is not None else
                 f"{record.task or 'episode'}: {record.policy or 'policy'}, "
                 f"{'success' if record.succeeded else 'no success'} after {record.time[-1]:.0f} s")
    groups = (("map", map_handles), ("tracks", tracks))
    legends = [_figure_legend(fig, handles, name, 1) for name, handles in groups]
    _lay_out(fig, ax, legends, groups, aspect, below, fit=height is None)
    return fig


def _figure_legend(fig, handles: list, title: str, columns: int, old=None):
    """A legend of the figure, in `columns` columns, in place of `old` (a legend's columns are fixed when it is
    made)."""
    if old is not None:
        old.remove()
    return fig.legend(handles=handles, title=title, loc="lower left", ncols=columns, borderaxespad=0.0,
                      fontsize="small", title_fontsize="small", framealpha=0.8)


def _lay_out(fig, ax, legends: list, groups: Sequence[tuple[str, list]], aspect: float, below: bool,
            fit: bool) -> None:
    """Places the map's axes and the legends in pixels: the axes' labels and title measured as drawn, the map
    across the width left by the legends, the legends below it (side by side while they fit, in as few rows as
    they fit in) or beside it (stacked); with `fit` the figure's height is what they need."""
    renderer = FigureCanvasAgg(fig).get_renderer()
    width, pad = fig.get_figwidth() * DPI, FIT_PAD
    for _ in range(2):  # tick labels change with the axes' size: measure again once placed
        height = fig.get_figheight() * DPI
        box, tight = ax.get_window_extent(renderer), ax.get_tightbbox(renderer)
        left, right = box.x0 - tight.x0, tight.x1 - box.x1
        bottom, top = box.y0 - tight.y0, tight.y1 - box.y1
        inner = width - 2 * pad - left - right
        if below:
            row = _fit_columns(fig, legends, groups, inner, renderer)
            sizes = [legend.get_window_extent(renderer) for legend in legends]
            legend_h = max(s.height for s in sizes) if row else sum(s.height for s in sizes) + pad
            axes_w, under, beside = inner, legend_h + pad, 0.0
        else:
            sizes = [legend.get_window_extent(renderer) for legend in legends]
            beside = max(s.width for s in sizes) + pad
            axes_w, under = inner - beside, 0.0
        if fit:
            need = 2 * pad + top + bottom + under + axes_w * aspect
            if not below:
                need = max(need, sum(s.height for s in sizes) + 3 * pad)
            height = float(np.clip(need, FIT_HEIGHT[0], FIT_HEIGHT[1] * width))
            fig.set_size_inches(width / DPI, round(height) / DPI)
            height = round(height)
        axes_h = max(height - 2 * pad - top - bottom - under, 1.0)
        ax.set_position([(pad + left) / width, (pad + bottom + under) / height, max(axes_w, 1.0) / width,
                         axes_h / height])
        ax.apply_aspect()
        shown = ax.get_position()  # the box the equal aspect leaves, inside the one given
        if below:
            x = shown.x0 * width
            for legend, size in zip(legends, sizes, strict=True):
                if row:  # side by side, tops aligned
                    legend.set_bbox_to_anchor((x / width, (pad + legend_h - size.height) / height), fig.transFigure)
                    x += size.width + pad
                else:
                    legend.set_bbox_to_anchor((shown.x0, (pad + legend_h - size.height) / height), fig.transFigure)
                    legend_h -= size.height + pad
        else:
            y = shown.y1 * height
            for legend, size in zip(legends, sizes, strict=True):
                y -= size.height
                legend.set_bbox_to_anchor(((width - pad - beside + pad) / width, y / height), fig.transFigure)
                y -= pad


def _fit_columns(fig, legends: list, groups: Sequence[tuple[str, list]], room: float, renderer) -> bool:
    """Remakes the legends of `groups` (title, handles) in place in `legends`, in the columns that, side by side,
    take the fewest rows within `room` pixels; False when even one column each does not fit (they are then
    stacked, each in as many columns as fit)."""
    counts = [len(handles) for _, handles in groups]

    def remake(k: int, columns: int) -> float:
        legends[k] = _figure_legend(fig, groups[k][1], groups[k][0], columns, legends[k])
        return legends[k].get_window_extent(renderer).width

    for rows in range(1, max(counts) + 1):
        used = sum(remake(k, math.ceil(count / rows)) for k, count in enumerate(counts))
        if used + FIT_PAD * (len(legends) - 1) <= room:
            return True
    for k, count in enumerate(counts):
        for columns in range(count, 0, -1):
            if remake(k, columns) <= room:
                break
    return False


def plot_trajectory(records, path: str | Path, labels: Sequence[str] | None = None, title: str | None = None,
                    width: int = DEFAULT_SIZE[0], height: int | None = None) -> Path:
    """PNG of the map and the trajectories of one or more episodes (records or .npz paths) on it
    (`trajectory_figure`); `height` None fits the figure to the map's aspect ratio and its legends."""
    return save(trajectory_figure(records, labels, title, width, height), path)


def plot_gallery(panels: Sequence, path: str | Path, titles: Sequence[str] | None = None, cols: int = 3,
                 panel_size: tuple[int, int] = (500, 420)) -> Path:
    """PNG of several maps side by side, each with its episodes' trajectories (`draw_trajectory`): e.g.
    a handful of held-out procedural tunnels with a policy's tracks. `panels` holds one record (or .npz
    path), or a list of records on the same map, per panel."""
    panels = [as_records(panel) for panel in panels]
    if not panels:
        raise ValueError("plot_gallery needs at least one panel")
    cols = max(1, min(cols, len(panels)))
    rows = math.ceil(len(panels) / cols)
    fig, axes = new_figure(panel_size[0] * cols, panel_size[1] * rows, rows, cols, squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(panels):
            ax.set_axis_off()
            continue
        draw_trajectory(ax, panels[k], legend=k == 0)
        record = panels[k][0]
        ax.set_title(titles[k] if titles else f"{record.task} seed {record.seed}: "
                     f"{'success' if record.succeeded else 'no success'}", fontsize="small")
    fig.tight_layout()
    return save(fig, path)
