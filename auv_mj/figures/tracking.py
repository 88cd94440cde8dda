"""Tracking figures (matplotlib, Agg): speed and heading against their commands and the tracking errors over an
episode (the paper's Figs. 12-14, 17), from an episode record or a per-step tracking CSV.

`tracking_table` / `tracking_csv` give an episode's per-step columns (TRACKING_COLUMNS), `read_tracking_csv` reads
them back (or a CSV of the user's), `plot_tracking` draws them with the disturbance phases shaded.
`auv-mj plot tracking` wraps them.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from auv_mj.episode import EpisodeRecord
from auv_mj.figures.canvas import DEFAULT_SIZE, as_records, new_figure, save
from auv_mj.geometry import wrap_angle

TRACKING_COLUMNS = ("step", "time", "speed", "speed_command", "heading", "heading_command",
                    "speed_error", "heading_error", "cross_track_error", "phase")
"""Columns of a per-step tracking CSV (heading in rad; errors = command - measured, heading wrapped)."""
PHASE_COLOURS = {"instantaneous": "tab:red", "constant": "tab:orange", "periodic": "tab:purple"}
"""Shade of each disturbance phase of speed_heading (Table 9) behind the curves."""


def tracking_table(record: EpisodeRecord) -> dict[str, np.ndarray]:
    """Per-step tracking columns (TRACKING_COLUMNS) of an episode: values after each step."""
    n = record.steps
    speed = record.velocity[1:, 0]  # surge speed u: the executor's controlled speed (auv_mj.tasks.speed_heading)
    heading = record.pose[1:, 2]
    table = {"step": np.arange(1, n + 1), "time": record.time[1:], "speed": speed,
             "speed_command": record.command[:, 0], "heading": heading,
             "heading_command": record.command[:, 1],
             "speed_error": record.command[:, 0] - speed,
             "heading_error": wrap_angle(record.command[:, 1] - heading),
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
    table.setdefault("heading_error", wrap_angle(table["heading_command"] - table["heading"]))
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
    fig, axes = new_figure(width, height, 4 if has_cross else 3, 1, sharex=True)
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
    return save(fig, path)
