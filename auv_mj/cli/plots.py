"""Paper-style figures as PNG (matplotlib, Agg): trajectories, tracking errors and learning curves.

- `plot_trajectory`: the map (bounds, walls, obstacles as polygons, moving obstacles and their paths),
  the global path, start, goal area and the vehicle's trajectory (Figs. 9-11, 13a, 14a, 16);
  `plot_gallery`: several such maps side by side (e.g. held-out procedural tunnels with their tracks).
- `plot_tracking`: speed and heading against their commands over the steps, and the tracking errors
  (speed, heading, cross-track to the global path) (Figs. 12-14, 17); disturbance phases shaded.
- `plot_learning`: episode return and success rate against episodes from training CSV logs, mean over
  the runs of each group with a min-max or standard-deviation band (Fig. 8).

Inputs are `EpisodeRecord`s (or their .npz files, see `auv_mj.episode`), per-step tracking CSVs
(TRACKING_COLUMNS, as `tracking_csv` writes them) and training logs (`auv_mj.agents.offpolicy.train`'s progress.csv:
episode, steps, return, success, wall_time, ...). `auv-mj plot trajectory|tracking|learning` wraps them.
"""

from __future__ import annotations

import csv
import glob
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Polygon, Rectangle

from auv_mj.episode import EpisodeRecord

DPI = 100
DEFAULT_SIZE = (1000, 800)
"""Default figure size [px]; `width`, `height` arguments set it exactly (at DPI)."""
LEARNING_WINDOW = 5
"""Episodes averaged per point of a learning curve (Sec. 4.1: "recorded every five epochs")."""
BANDS = ("minmax", "std", "ci")
"""Shaded bands of the learning curves: range, one standard deviation, 95 % confidence of the mean."""
VEHICLE_MARK = 0.02
MAP_MARGIN = 0.02
"""Water shown around the map, as a fraction of its larger side (the same in x and y: the axes are to scale)."""
"""The vehicle's red rectangle is drawn this fraction of the map's size long (the hull is 1.33 m)."""
TRACKING_COLUMNS = ("step", "time", "speed", "speed_command", "heading", "heading_command",
                    "speed_error", "heading_error", "cross_track_error", "phase")
"""Columns of a per-step tracking CSV (heading in rad; errors = command - measured, heading wrapped)."""
LEARNING_COLUMNS = ("episode", "return", "success")
"""Columns a training log must have (auv_mj.agents.offpolicy.train writes episode, steps, length, return, success,
wall_time)."""
RUN_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown")
TRACK_STYLES = (("tab:blue", "-", 3.6), ("tab:purple", (0, (6, 2)), 2.6), ("black", (0, (4, 1.5, 1, 1.5)), 1.7),
                ("tab:pink", (0, (1, 1.2)), 1.8), ("tab:brown", (0, (8, 3)), 1.3), ("tab:cyan", "-", 1.0))
"""(colour, dash pattern, width) of the trajectory figure's tracks, in the order of the records: each wider one is
drawn under the narrower ones after it, so that tracks that run together all show (one policy's under another's);
no colour of the map's own (the green global path, the red AUV, the orange movers, the gold goals)."""
TRACK_ALPHA = 0.85
LEGEND_BELOW_ASPECT = 0.75
"""A map flatter than this (height / width) has its legends below it, a taller one beside it: a tunnel is
several times as wide as tall, and legends beside it would make the figure tall and mostly white."""
FIT_PAD = 8
"""Margin [px] around a fitted trajectory figure's content, and between its legends."""
FIT_HEIGHT = (200, 1.5)
"""A fitted trajectory figure is at least this many pixels tall and at most this many times its width."""
PHASE_COLOURS = {"instantaneous": "tab:red", "constant": "tab:orange", "periodic": "tab:purple"}


def _figure(width: int, height: int, rows: int = 1, cols: int = 1, **kwargs):
    """A Figure drawn by Agg without pyplot: no display, no global state, whatever backend a caller uses."""
    fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    return fig, fig.subplots(rows, cols, **kwargs)


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)  # no bbox_inches="tight": the PNG keeps the requested pixel size
    return path


def as_records(records) -> list[EpisodeRecord]:
    items = records if isinstance(records, list | tuple) else [records]
    return [r if isinstance(r, EpisodeRecord) else EpisodeRecord.load(r) for r in items]


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


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
    fig, ax = _figure(width, height or width)
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
    return _save(trajectory_figure(records, labels, title, width, height), path)


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
    fig, axes = _figure(panel_size[0] * cols, panel_size[1] * rows, rows, cols, squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(panels):
            ax.set_axis_off()
            continue
        draw_trajectory(ax, panels[k], legend=k == 0)
        record = panels[k][0]
        ax.set_title(titles[k] if titles else f"{record.task} seed {record.seed}: "
                     f"{'success' if record.succeeded else 'no success'}", fontsize="small")
    fig.tight_layout()
    return _save(fig, path)


# --- tracking (Figs. 12-14, 17) ----------------------------------------------------------------------


def tracking_table(record: EpisodeRecord) -> dict[str, np.ndarray]:
    """Per-step tracking columns (TRACKING_COLUMNS) of an episode: values after each step."""
    n = record.steps
    speed = record.velocity[1:, 0]  # surge speed u: the executor's controlled speed (auv_mj.tasks.speed_heading)
    heading = record.pose[1:, 2]
    table = {"step": np.arange(1, n + 1), "time": record.time[1:], "speed": speed,
             "speed_command": record.command[:, 0], "heading": heading,
             "heading_command": record.command[:, 1],
             "speed_error": record.command[:, 0] - speed,
             "heading_error": _wrap(record.command[:, 1] - heading),
             "cross_track_error": record.info.get("cross_track_error", np.full(n, np.nan)),
             "phase": record.info.get("phase", np.full(n, "", dtype=str))}
    return table


def tracking_csv(record: EpisodeRecord, path: str | Path) -> Path:
    """Writes `tracking_table(record)` as CSV (the format `plot_tracking` reads)."""
    table = tracking_table(record)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(TRACKING_COLUMNS)
        for i in range(len(table["step"])):
            writer.writerow([table[c][i] for c in TRACKING_COLUMNS])
    return path


def read_tracking_csv(path: str | Path) -> dict[str, np.ndarray]:
    """A tracking CSV as columns; needs step or time, speed, speed_command, heading, heading_command."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    columns = set(rows[0])
    needed = {"speed", "speed_command", "heading", "heading_command"}
    if not needed <= columns or not columns & {"step", "time"}:
        raise ValueError(f"{path}: a tracking CSV needs columns step or time, {', '.join(sorted(needed))}; "
                         f"found {', '.join(sorted(columns))}")
    table = {}
    for c in columns:
        values = [r[c] for r in rows]
        try:
            table[c] = np.array([float(v) if v != "" else np.nan for v in values])
        except ValueError:
            table[c] = np.array(values, dtype=str)
    n = len(rows)
    if "step" not in table:
        table["step"] = np.arange(1, n + 1)
    table.setdefault("time", table["step"].astype(float))
    table.setdefault("speed_error", table["speed_command"] - table["speed"])
    table.setdefault("heading_error", _wrap(table["heading_command"] - table["heading"]))
    table.setdefault("cross_track_error", np.full(n, np.nan))
    table.setdefault("phase", np.full(n, "", dtype=str))
    return table


def _shade_phases(ax, steps: np.ndarray, phases: np.ndarray) -> None:
    """Shades the spans of steps under each disturbance phase (speed_heading's last_info["phase"])."""
    phases = np.asarray(phases).astype(str)
    if len(phases) == 0:
        return
    change = np.flatnonzero(phases[1:] != phases[:-1]) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [len(phases)]])
    for a, b in zip(starts, ends, strict=True):
        colour = PHASE_COLOURS.get(phases[a])
        if colour:
            ax.axvspan(steps[a], steps[b - 1], color=colour, alpha=0.08, linewidth=0)


def plot_tracking(source, path: str | Path, title: str | None = None, x: str = "step",
                  width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1]) -> Path:
    """PNG of speed and heading against their commands and of the tracking errors over the episode.

    `source`: an EpisodeRecord, an episode .npz or a tracking CSV; `x`: "step" (the paper's axis) or "time".
    """
    if isinstance(source, str | Path) and Path(source).suffix.lower() == ".csv":
        table, name = read_tracking_csv(source), Path(source).stem
    else:
        record = as_records(source)[0]
        table, name = tracking_table(record), f"{record.task or 'episode'}: {record.policy or 'policy'}"
    if x not in ("step", "time"):
        raise ValueError(f"x must be 'step' or 'time', got {x!r}")
    t = table[x]
    cross = np.asarray(table["cross_track_error"], dtype=float)
    has_cross = bool(np.any(np.isfinite(cross)))
    fig, axes = _figure(width, height, 4 if has_cross else 3, 1, sharex=True)
    speed_ax, heading_ax, error_ax = axes[:3]
    speed_ax.plot(t, table["speed_command"], "--", color="tab:red", label="commanded")
    speed_ax.plot(t, table["speed"], "-", color="tab:blue", label="AUV (surge u)")
    speed_ax.set_ylabel("speed [m/s]")
    heading_cmd = np.unwrap(np.asarray(table["heading_command"], dtype=float))
    heading = np.unwrap(np.asarray(table["heading"], dtype=float))
    heading -= 2 * np.pi * np.round((heading - heading_cmd) / (2 * np.pi))  # same branch as the command
    heading_ax.plot(t, heading_cmd, "--", color="tab:red", label="commanded")
    heading_ax.plot(t, heading, "-", color="tab:blue", label="AUV")
    heading_ax.set_ylabel("heading [rad]")
    error_ax.plot(t, table["speed_error"], color="tab:blue", label="speed error [m/s]")
    error_ax.plot(t, table["heading_error"], color="tab:green", label="heading error [rad]")
    error_ax.axhline(0.0, color="0.5", linewidth=0.5)
    error_ax.set_ylabel("error")
    mae = (np.nanmean(np.abs(table["speed_error"])), np.nanmean(np.abs(table["heading_error"])))
    error_ax.set_title(f"MAE speed {mae[0]:.4f} m/s, heading {mae[1]:.4f} rad", fontsize="small")
    if has_cross:
        axes[3].plot(t, cross, color="tab:purple")
        axes[3].set_ylabel("cross-track [m]")
        axes[3].set_title(f"path following error: mean {np.nanmean(cross):.2f} m, "
                          f"max {np.nanmax(cross):.2f} m", fontsize="small")
    for ax in axes:
        _shade_phases(ax, t, table["phase"])
        ax.grid(alpha=0.3)
    for ax in axes[:3]:
        ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("step" if x == "step" else "time [s]")
    fig.suptitle(title if title is not None else name)
    fig.tight_layout()
    return _save(fig, path)


# --- learning curves (Fig. 8) ---------------------------------------------------------------------------


def read_learning_csv(path: str | Path) -> dict[str, np.ndarray]:
    """A training log as float columns; needs LEARNING_COLUMNS. A directory means its progress.csv."""
    path = Path(path)
    if path.is_dir():
        path = path / "progress.csv"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    missing = [c for c in LEARNING_COLUMNS if c not in rows[0]]
    if missing:
        raise ValueError(f"{path}: a training log needs columns {', '.join(LEARNING_COLUMNS)}; "
                         f"missing {', '.join(missing)}")
    columns = {}
    for c in rows[0]:
        try:
            columns[c] = np.array([float(r[c]) for r in rows])
        except ValueError:
            continue
    return columns


def expand_runs(patterns: Sequence[str | Path]) -> list[Path]:
    """Files (or run directories) named by paths or glob patterns, sorted; ValueError if none."""
    found = []
    for pattern in patterns:
        matches = sorted(glob.glob(str(pattern))) or ([str(pattern)] if Path(pattern).exists() else [])
        found.extend(Path(m) for m in matches)
    if not found:
        raise ValueError(f"no training logs match {', '.join(map(str, patterns))}")
    return found


def smooth(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving average over `window` points (shorter at the start)."""
    values = np.asarray(values, dtype=float)
    if window <= 1:
        return values
    csum = np.cumsum(np.insert(values, 0, 0.0))
    idx = np.arange(1, len(values) + 1)
    lo = np.maximum(idx - window, 0)
    return (csum[idx] - csum[lo]) / (idx - lo)


def learning_curve(runs: Sequence[dict[str, np.ndarray]], column: str, window: int, x: str = "episode",
                   band: str = "minmax") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x, mean, low, high) of a column over runs, each smoothed over `window` episodes.

    Runs are cut to the shortest; `x` is "episode" or "steps" (the mean over runs of the step counts);
    `band` "minmax" (range of the runs), "std" (mean +- one standard deviation) or "ci" (the 95 %
    confidence interval of the mean over runs, Student's t with runs - 1 degrees of freedom).
    """
    if band not in BANDS:
        raise ValueError(f"band must be one of {BANDS}, got {band!r}")
    n = min(len(r[column]) for r in runs)
    values = np.stack([smooth(r[column][:n], window) for r in runs])
    if x == "steps" and all("steps" in r for r in runs):
        xs = np.mean([r["steps"][:n] for r in runs], axis=0)
    else:
        xs = runs[0]["episode"][:n]
    mean = values.mean(axis=0)
    if band == "std":
        std = values.std(axis=0)
        return xs, mean, mean - std, mean + std
    if band == "ci":
        if len(runs) < 2:
            return xs, mean, mean, mean
        from scipy import stats

        half = stats.t.ppf(0.975, len(runs) - 1) * values.std(axis=0, ddof=1) / np.sqrt(len(runs))
        return xs, mean, mean - half, mean + half
    return xs, mean, values.min(axis=0), values.max(axis=0)


def plot_learning(groups: Sequence[tuple[str, Sequence[str | Path]]], path: str | Path,
                  window: int = LEARNING_WINDOW, band: str = "minmax", x: str = "episode",
                  title: str | None = None, width: int = DEFAULT_SIZE[0],
                  height: int = DEFAULT_SIZE[1]) -> Path:
    """PNG of episode return and success rate vs episodes: per group (label, CSV files/globs), the mean
    over its runs with a shaded band (Fig. 8 compares HER-DDPG with DDPG this way)."""
    fig, (ret_ax, succ_ax) = _figure(width, height, 2, 1, sharex=True)
    for i, (label, patterns) in enumerate(groups):
        runs = [read_learning_csv(p) for p in expand_runs(patterns)]
        colour = RUN_COLOURS[i % len(RUN_COLOURS)]
        for ax, column in ((ret_ax, "return"), (succ_ax, "success")):
            xs, mean, low, high = learning_curve(runs, column, window, x, band)
            ax.plot(xs, mean, color=colour, label=f"{label} ({len(runs)} run{'s' * (len(runs) > 1)})")
            if len(runs) > 1:
                ax.fill_between(xs, low, high, color=colour, alpha=0.2, linewidth=0)
    ret_ax.set_ylabel(f"episode return ({window}-episode mean)")
    succ_ax.set_ylabel(f"success rate ({window}-episode mean)")
    succ_ax.set_ylim(-0.05, 1.05)
    succ_ax.set_xlabel("environment steps" if x == "steps" else "episode")
    for ax in (ret_ax, succ_ax):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    band_name = {"minmax": "min-max over runs", "std": "mean +- std over runs",
                 "ci": "95 % confidence interval of the mean"}[band]
    ret_ax.set_title(title if title is not None else f"learning curves (band: {band_name})")
    fig.tight_layout()
    return _save(fig, path)
