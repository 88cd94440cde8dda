"""Previews of arenas (matplotlib): a planar arena from above, a 3-D tube from above and from the side.

`preview(arena, png)` checks an arena (`auv_mj.arenas.arena_check.check_arena`) and draws its preview in one call,
or draws the preview of a report already made; `auv-mj check-arena` and `auv-mj arena` draw theirs with it. Every
preview carries PREVIEW_SOFTWARE in its PNG text, by which `is_preview` knows one: a command may replace a preview
it drew without --force, never an image of the user's.
"""

from __future__ import annotations

import collections
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import shapely

from auv_mj.arenas.arena import MAX_EXTENT, ArenaInfo
from auv_mj.arenas.arena_check import (
    CHECK_STAGES,
    ArenaReport,
    ArenaView,
    TubeView,
    arena_name,
    check_arena,
    geom_outline,
)
from auv_mj.console import progress_bar
from auv_mj.sim.physics import AUVPhysics

PREVIEW_SOFTWARE = "auv-mj arena preview"
"""The PNG `Software` text of every preview drawn here, by which `is_preview` knows one: a command may replace a
preview it drew without --force, never an image of the user's."""
PREVIEW_STAGES = (*CHECK_STAGES, "preview")
"""The stages `preview` counts on its progress bar: the check's, then the drawing."""


def is_preview(path: str | Path) -> bool:
    """Whether `path` is a PNG preview drawn here (its `Software` text is PREVIEW_SOFTWARE)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            return image.format == "PNG" and image.info.get("Software") == PREVIEW_SOFTWARE
    except (OSError, UnidentifiedImageError, ValueError):
        return False


def preview(arena: ArenaReport | str | Path | ET.Element, png: str | Path, *, need_path: bool = True,
            name: str | None = None, progress: bool = False) -> ArenaReport:
    """Writes the preview of an arena to `png` and returns its report, with `png` set where one was drawn.

    `arena` is a report of `check_arena` (drawn as it is) or an arena (a file or an element), checked first with
    `need_path`, `name` and `progress` as `check_arena` takes them; the progress bar then counts PREVIEW_STAGES. An
    arena that does not load has no preview (`png` stays None); an unusable one that loads is drawn, problems and
    all, which is what its author needs to see.
    """
    if isinstance(arena, ArenaReport):
        return _draw(arena, png)
    name = arena_name(arena) if name is None else name
    bar = progress_bar(total=len(PREVIEW_STAGES), desc=f"check-arena {Path(name).name}"[:40], unit="stage",
                       disable=not progress)
    try:
        report = check_arena(arena, need_path=need_path, name=name, bar=bar)
        if report.view is not None:
            bar.n = PREVIEW_STAGES.index("preview")
            bar.set_postfix_str("preview")
            _draw(report, png)
        bar.set_postfix_str("done")
        bar.update(bar.total - bar.n)  # every stage done or not needed
        return report
    finally:
        bar.close()


def _draw(report: ArenaReport, png: str | Path) -> ArenaReport:
    """Draws `report.view` to `png` (nothing where it is None) and records the file in `report.png`."""
    view = report.view
    title = f"{Path(report.source).name}: {view.kind} arena" if view is not None else ""
    if isinstance(view, TubeView):
        report.png = plot_tube(view.tube, view.obstacles, view.movers, png, title=title)
    elif isinstance(view, ArenaView):
        report.png = plot_arena(view.physics, view.info, png, title=title, skip=view.skip)
    return report


# --- a planar arena from above ----------------------------------------------------------------------------------

LABEL_OFFSETS = ((0, 6), (0, -14), (8, -4), (-8, -4), (0, 18), (0, -26), (16, 10), (-16, 10), (16, -18),
                 (-16, -18), (0, 30), (0, -38), (40, 12), (-40, 12), (40, -20), (-40, -20), (0, 44), (0, -52),
                 (60, 28), (-60, 28), (60, -36), (-60, -36), (0, 60), (0, -68))
"""Where a geom's name may go [points from the centre of its outline, the text's bottom centre], tried in order
until it overlaps no label placed before it, nor a start, goal or mover marker; from the fifth on, a thin leader
line joins the label to what it names."""
LABEL_GAP = 3.0
"""Least gap [pixels] between two labels, or a label and a marker, of the preview."""
LABEL_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.85}
"""The labels' background: lines and shapes under a label do not cross its letters."""
LEADER_FROM = 4
"""Offsets from this index of LABEL_OFFSETS on are far enough from their point to need a leader line."""
PIECE_NAME = re.compile(r"(.+)_(\d+)")
"""A piece of a polygon cut into convex meshes: NAME_0, NAME_1, ... (`auv_mj.arenas.layout`)."""


def _labelled_shapes(model: mujoco.MjModel, outlines: dict[int, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """(name, outline) of each static shape to label: a polygon's convex pieces (meshes NAME_0, NAME_1, ... whose
    outlines join into one) once, as NAME at the middle of the whole; other geoms by their own name."""
    groups: dict[str, list[int]] = collections.defaultdict(list)
    for g in outlines:
        match = PIECE_NAME.fullmatch(model.geom(g).name)
        if match and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            groups[match.group(1)].append(g)
    merged: dict[int, tuple[str, np.ndarray]] = {}
    for stem, pieces in groups.items():
        numbers = sorted(int(PIECE_NAME.fullmatch(model.geom(g).name).group(2)) for g in pieces)
        if len(pieces) < 2 or numbers != list(range(len(pieces))):
            continue
        union = shapely.union_all([shapely.Polygon(outlines[g]).buffer(1e-6) for g in pieces])
        if isinstance(union, shapely.Polygon):  # the pieces join: one polygon
            point = union.representative_point()
            merged.update({g: (stem, np.array([[point.x, point.y]])) for g in pieces})
    shapes, done = [], set()
    for g, outline in outlines.items():
        name, where = merged.get(g, (model.geom(g).name, outline))
        if name not in done:
            done.add(name)
            shapes.append((name, where))
    return shapes


def _place_labels(ax, labels: list[tuple[str, np.ndarray, dict]], markers: list | None = None) -> None:
    """Annotates each (text, point, style) on a white ground at the first of LABEL_OFFSETS where it keeps LABEL_GAP
    pixels from every label placed before it (and any fixed text on `ax`) and from the `markers` (start, goal,
    movers' starts: their drawn extents); far ones get a leader line. One that fits nowhere is left out rather than
    drawn over another."""
    from matplotlib.text import Text

    renderer = ax.figure.canvas.get_renderer()
    ax.apply_aspect()
    placed = [t.get_window_extent(renderer).padded(LABEL_GAP) for t in ax.texts if t.get_text()]
    for artist in markers or []:
        placed.append(artist.get_window_extent(renderer).padded(LABEL_GAP))
    for text, point, style in labels:
        for k, (dx, dy) in enumerate(LABEL_OFFSETS):
            leader = ({"arrowprops": {"arrowstyle": "-", "lw": 0.5, "color": style.get("color", "0.3"),
                                      "shrinkA": 0, "shrinkB": 1}} if k >= LEADER_FROM else {})
            note = ax.annotate(text, point, xytext=(dx, dy), textcoords="offset points", ha="center",
                               va="bottom", bbox=LABEL_BOX, zorder=6, **leader, **style)
            note.update_positions(renderer)
            box = Text.get_window_extent(note, renderer).padded(LABEL_GAP)  # the letters, not the leader line
            if not any(box.overlaps(other) for other in placed):
                placed.append(box)
                break
            note.remove()


def _drawable(points) -> bool:
    """Finite and within MAX_EXTENT: what the preview can draw (matplotlib fails on huge or NaN limits)."""
    return points is not None and bool(np.all(np.abs(np.asarray(points, dtype=float)) <= MAX_EXTENT))


def plot_arena(physics: AUVPhysics, info: ArenaInfo | None, png: str | Path, title: str = "",
               skip: set[int] | frozenset[int] = frozenset()) -> Path:
    """Writes `arena_figure` as a PNG."""
    import matplotlib.pyplot as plt

    fig = arena_figure(physics, info, title, skip)
    png = Path(png)
    fig.savefig(png, dpi=110, bbox_inches="tight", metadata={"Software": PREVIEW_SOFTWARE})
    plt.close(fig)
    return png


def arena_figure(physics: AUVPhysics, info: ArenaInfo | None, title: str = "",
                 skip: set[int] | frozenset[int] = frozenset()):
    """A top-down figure of walls, obstacles, movers and their paths, the global path, start and goal: each static
    shape named once (a polygon cut into pieces by its own name), the names placed where they overlap no other.

    Geoms in `skip`, and anything not at finite coordinates within MAX_EXTENT, are left out.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon, Rectangle

    model, data = physics.model.ptr, physics.data.ptr
    mujoco.mj_kinematics(model, data)
    fig, ax = plt.subplots(figsize=(10, 7))
    movers = {model.body(m.body).id: m for m in info.movers} if info is not None else {}
    named: dict[int, np.ndarray] = {}
    markers = []  # what a label must not cover: the movers, the start and the goal
    for g in range(model.ngeom):
        body = model.geom_bodyid[g]
        if (body != 0 and body not in movers) or g in skip:
            continue
        outline = geom_outline(model, data, g)
        if outline is None or not _drawable(outline):
            continue
        name = model.geom(g).name
        colour = "#d9342b" if body in movers else "#73787f" if name.startswith("wall") else "#9a6a3f"
        patch = ax.add_patch(Polygon(outline, closed=True, facecolor=colour, edgecolor=colour, lw=0.5, zorder=2))
        if body in movers:
            markers.append(patch)
        if body == 0 and not name.startswith("wall") and name:
            named[g] = outline
    labels = []
    for mover in movers.values():
        if not (_drawable(mover.waypoints) and math.isfinite(mover.speed)):
            continue
        track = mover.waypoints
        if len(track) > 2:
            ax.plot(*track[:-1].T, "--", color="#d9342b", lw=1.0, zorder=3)
        ax.annotate("", track[-1], track[-2], zorder=3,
                    arrowprops={"arrowstyle": "->", "color": "#d9342b", "ls": "--"})
        labels.append((f"{mover.body} ({mover.speed:g} m/s)", mover.start, {"fontsize": 7, "color": "#d9342b"}))
    labels += [(name, where.mean(axis=0), {"fontsize": 7}) for name, where in _labelled_shapes(model, named)]
    if info is not None:
        path = info.path[np.all(np.abs(info.path) <= MAX_EXTENT, axis=1)] if len(info.path) else info.path
        if len(path):
            ax.plot(*path.T, "-", color="#1f77b4", lw=1.2, label="global path", zorder=3)
            ax.plot(*path.T, ".", color="#1f77b4", ms=3, zorder=3)
        if _drawable(info.start):
            markers += ax.plot(*info.start, "o", color="#2ca02c", ms=8, label="start", zorder=4)
            if math.isfinite(info.start_heading):
                ax.annotate("", info.start + 15 * np.array([math.cos(info.start_heading),
                                                             math.sin(info.start_heading)]),
                            info.start, arrowprops={"arrowstyle": "->", "color": "#2ca02c", "lw": 1.5}, zorder=4)
        if _drawable(info.goal):
            markers += ax.plot(*info.goal, "*", color="#e6b800", ms=14, mec="k", mew=0.5, label="goal", zorder=4)
        if info.bounds is not None and len(info.bounds) == 4 and _drawable(info.bounds):
            xmin, ymin, xmax, ymax = info.bounds
            ax.add_patch(Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False, ls=":", color="k",
                                   lw=0.8, label="arena_bounds"))
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    _place_labels(ax, labels, markers)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8)
    return fig


# --- a tube from above and from the side --------------------------------------------------------------------


def plot_tube(tube, obstacles, movers, png: str | Path, title: str = "") -> Path:
    """Writes a PNG of a tube arena (`auv_mj.arenas.tubes`): from above (x, y) and from the side, unrolled along
    the centreline (depth against distance along it), with the wall's inner surface, rocks, movers' tracks, start
    and goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    from auv_mj.arenas.tubes import distance_to_centreline

    line = tube.centreline
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    heading = np.diff(line[:, :2], axis=0)
    heading = np.vstack([heading[:1], heading[:-1] + heading[1:], heading[-1:]])
    side = np.column_stack([-heading[:, 1], heading[:, 0]]) / np.maximum(
        np.linalg.norm(heading, axis=1, keepdims=True), 1e-12)
    fig, (top, profile) = plt.subplots(2, 1, figsize=(10, 9), gridspec_kw={"height_ratios": [3, 2]})
    wall = dict(color="#73787f", lw=1.5)
    for sign in (1.0, -1.0):
        edge = line[:, :2] + sign * tube.radius * side
        top.plot(*edge.T, **wall, label="wall (inner surface)" if sign > 0 else None)
        profile.plot(arc, -(line[:, 2] + sign * tube.radius), **wall)
    top.plot(*line[:, :2].T, "--", color="#1f77b4", lw=1.0, label="centreline")
    profile.plot(arc, -line[:, 2], "--", color="#1f77b4", lw=1.0)

    def place(point):
        return distance_to_centreline(tube, np.asarray(point, dtype=float)[None])[1][0]

    for o in obstacles:
        top.add_patch(Circle((o.x, o.y), o.radius, color="#9a6a3f", zorder=3))
        profile.add_patch(Circle((place(o.centre), -o.z), o.radius, color="#9a6a3f", zorder=3))
        top.annotate(o.name, (o.x, o.y), fontsize=7, ha="center", xytext=(0, 8), textcoords="offset points")
    for m in movers:
        a, b = np.asarray(m.start, dtype=float), np.asarray(m.end, dtype=float)
        top.plot([a[0], b[0]], [a[1], b[1]], ":", color="#d9342b", lw=1.2)
        top.add_patch(Circle(a[:2], m.radius, color="#d9342b", alpha=0.8, zorder=3))
        profile.plot([place(a), place(b)], [-a[2], -b[2]], ":", color="#d9342b", lw=1.2)
        profile.add_patch(Circle((place(a), -a[2]), m.radius, color="#d9342b", alpha=0.8, zorder=3))
        top.annotate(f"{m.name} ({m.speed:g} m/s)", a[:2], fontsize=7, color="#d9342b", ha="center",
                     xytext=(0, 8), textcoords="offset points")
    for ax, start, goal in ((top, line[0, :2], line[-1, :2]), (profile, (0.0, -line[0, 2]), (arc[-1], -line[-1, 2]))):
        ax.plot(*start, "o", color="#2ca02c", ms=8, label="start", zorder=4)
        ax.plot(*goal, "*", color="#e6b800", ms=14, mec="k", mew=0.5, label="goal", zorder=4)
        ax.grid(alpha=0.3)
    top.set_aspect("equal")
    top.set(xlabel="x [m]", ylabel="y [m]", title=f"{title}, from above" if title else "from above")
    profile.set(xlabel="distance along the centreline [m]", ylabel="depth [m]",
                title="from the side, unrolled along the centreline (depth not to scale)")
    profile.invert_yaxis()
    top.legend(loc="best", fontsize=8)
    fig.tight_layout()
    png = Path(png)
    fig.savefig(png, dpi=110, bbox_inches="tight", metadata={"Software": PREVIEW_SOFTWARE})
    plt.close(fig)
    return png
