"""Headless episode videos: a top-down view of the arena with the vehicle, sonar beams, trail and goals.

`auv-mj render --task goal --policy splane -o goal.mp4` runs one episode and writes an H.264 MP4
(GIF with --gif, or when no ffmpeg is found). Off-screen OpenGL through EGL or OSMesa
(`auv_mj.glbackend`); no display is needed.

What a frame shows: a follow camera (orthographic, looking straight down, FOLLOW_VIEW metres tall,
north up) and/or an overview of the whole arena (full frame, or as picture-in-picture with
`--camera both`); the model's own geoms (walls, obstacles, moving obstacles where the physics puts
them); decorations added to the MuJoCo scene after `mjv_updateScene` (never to the model): the water
and the map bounds, the global path, the goal area and sub-goals, the trajectory trail, the nine sonar
beams from the bow to their hit points coloured by range, and the vehicle as a scaled-up dart marker
(the 1.33 m hull would be a few pixels); and a text overlay (MuJoCo's `mjr_overlay`).

Timing: a video frame every `speedup / fps` simulation seconds. By default one frame per control step
(speedup = fps x control period: 15x real time for the 0.5 s planner at 30 fps); a smaller speedup
interpolates the recorded states between control steps (pose, velocity and moving obstacles linearly;
sonar held, as the 2 Hz sonar holds it), a larger one skips states. The environment is always stepped
exactly as in training and evaluation.

Python API: `render_episode(env, policy) -> (T, H, W, 3) uint8`, `iter_frames(...)` (streaming),
`write_video(frames, path, fps)`, `render_frame(physics)` (one picture of a physics state), and
`benchmark()` (frames/s against a bare `mujoco.Renderer`).
"""

from __future__ import annotations

import copy
import math
import time
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from auv_mj import glbackend
from auv_mj.console import progress_bar
from auv_mj.episode import EpisodeRecorder, Snapshot, arena_geometry, mover_positions
from auv_mj.geometry import wrap_angle
from auv_mj.sonar import SONAR_RANGE

DEFAULT_FPS = 30
DEFAULT_SIZE = (1280, 720)
FOLLOW_VIEW = 120.0
"""Height of the follow camera's view [m]."""
OVERVIEW_MARGIN = 0.06
"""Margin around the arena in the overview, as a fraction of its size."""
OPEN_WATER_VIEW = 200.0
"""Overview height [m] when the arena has no bounds (open water): grows with the trajectory."""
INSET_HEIGHT = 0.4
INSET_MAX_WIDTH = 0.45
"""Picture-in-picture overview: its height and largest width as fractions of the frame."""
INSET_BORDER = 2
"""Border of the inset [px]."""
MARKER_LENGTH = 0.06
"""Vehicle marker length as a fraction of the view height (never shorter than the hull)."""
TRAIL_SPACING = 1 / 500
"""A trail point is kept every this fraction of the view height."""
MAX_SEGMENTS = 400
"""At most this many segments of a polyline (trail, global path) are drawn per view (thinned evenly)."""
EVENT_HOLD = 1.5
"""An event (goal, collision) stays on screen for this many seconds of video."""
DEFAULT_HOLD_END = 1.0
"""The last frame is repeated for this many seconds of video."""
OVERLAY_MIN_HEIGHT = 240
"""Below this frame height [px] the text overlay is left out: MuJoCo's smallest font would cover the view."""
SAMPLES = 0
"""Multisampling (MSAA) of the off-screen buffer: 4x costs about half the frame rate on a CPU rasteriser
(Mesa llvmpipe) for slightly smoother lines; 0 is sharp enough at 720p."""
TIME_TOLERANCE = 1e-6
"""Frame times within this of a recorded instant [s] show that instant (physics time drifts by ulps)."""
EXTRA_GEOMS = 3000
"""Room in the scene for the decorations."""

WATER_RGBA = (0.06, 0.20, 0.34, 1.0)
BOUNDS_RGBA = (0.9, 0.9, 0.9, 1.0)
PATH_RGBA = (0.65, 0.65, 1.0, 1.0)
MOVER_PATH_RGBA = (1.0, 0.6, 0.2, 0.9)
GOAL_RGBA = (1.0, 0.85, 0.1, 0.55)
SUBGOAL_RGBA = (1.0, 1.0, 1.0, 0.35)
REACHED_RGBA = (0.3, 0.9, 0.4, 0.45)
TRAIL_RGBA = (0.25, 0.85, 1.0, 1.0)
MARKER_RGBA = (1.0, 0.15, 0.15, 1.0)
NO_ECHO_RGBA = (0.5, 0.8, 0.5, 0.25)
EVENT_COLOURS = {"goal": (0.3, 1.0, 0.4), "collision": (1.0, 0.3, 0.3), "left_map": (1.0, 0.6, 0.2)}
"""Banner colour per event (others are white)."""
QUIET_EVENTS = ("subgoal",)
"""Events counted in the overlay but given no banner (a path's virtual sub-goals come every 10 m)."""
CAMERAS = ("follow", "overview", "both")
SCALE_RGBA = (1.0, 1.0, 1.0, 1.0)
SCALE_FRACTION = 0.2
"""The scale bar is the 1-2-5 length nearest below this fraction of the view's width."""

# Heights of the decorations above the water (all drawn from straight above, so only the order matters).
Z_WATER, Z_PATH, Z_GOAL, Z_TRAIL, Z_BEAM, Z_MARKER = -2.0, 0.3, 0.2, 0.6, 0.9, 1.5


# --- one frame -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class View:
    """One camera's viewport [px] and what it looks at."""

    kind: str
    """"follow" or "overview"."""
    rect: tuple[int, int, int, int]
    """(left, bottom, width, height) in the OpenGL framebuffer."""
    inset: bool = False


def _layout(camera: str, width: int, height: int, arena_aspect: float) -> tuple[View, ...]:
    """The views of a frame for `camera` (follow, overview or both = follow with an overview inset)."""
    if camera == "follow":
        return (View("follow", (0, 0, width, height)),)
    if camera == "overview":
        return (View("overview", (0, 0, width, height)),)
    inset_h = int(INSET_HEIGHT * height)
    inset_w = int(min(INSET_MAX_WIDTH * width, inset_h * float(np.clip(arena_aspect, 0.6, 2.5))))
    left = width - inset_w - INSET_BORDER
    bottom = height - inset_h - INSET_BORDER
    return (View("follow", (0, 0, width, height)), View("overview", (left, bottom, inset_w, inset_h), True))


def arena_extent(arena) -> np.ndarray:
    """(cx, cy, width, height) [m] the overview shows of an ArenaGeometry: its bounds (or everything in it)
    with OVERVIEW_MARGIN around."""
    if np.all(np.isfinite(arena.bounds)):
        lo, hi = arena.bounds[:2], arena.bounds[2:]
    else:
        points = [p for p in (*arena.polygons, arena.path, arena.goals, arena.start[None], arena.goal[None])
                  if len(p)]
        points = np.concatenate(points) if points else np.zeros((1, 2))
        points = points[np.all(np.isfinite(points), axis=1)]
        if len(points) == 0:
            points = np.zeros((1, 2))
        lo, hi = points.min(axis=0), points.max(axis=0)
    centre, size = (lo + hi) / 2, np.maximum(hi - lo, 1.0)
    return np.array([*centre, *(size * (1 + 2 * OVERVIEW_MARGIN))])


def scale_bar_length(view_width: float) -> float:
    """The scale bar's length [m]: 1, 2 or 5 times a power of ten, at most SCALE_FRACTION of the view."""
    target = max(SCALE_FRACTION * view_width, 1e-9)
    power = 10.0 ** math.floor(math.log10(target))
    return max(m * power for m in (1.0, 2.0, 5.0) if m * power <= target)


def _gl_context_class():
    """MuJoCo's GLContext of the configured backend.

    `mujoco` picks its own GLContext when first imported, which may precede `auv_mj` (and so MUJOCO_GL)
    when a caller imports mujoco first; importing the headless backend's class directly avoids GLFW.
    """
    backend = glbackend.require()
    if backend == "egl":
        from mujoco.egl import GLContext
    elif backend == "osmesa":
        from mujoco.osmesa import GLContext
    else:
        GLContext = mujoco.GLContext
    return GLContext


def _font_scale(height: int) -> int:
    """MuJoCo font scale (percent) that keeps the overlay readable at `height` pixels."""
    for limit, scale in ((200, 50), (420, 100), (800, 150), (1200, 200)):
        if height <= limit:
            return scale
    return 250


def _in_view(points: np.ndarray, window: tuple[float, float, float], aspect: float,
             max_segments: int = MAX_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Segments (starts, ends) of a polyline that cross a view's window, at most `max_segments`:
    the polyline is thinned by a power-of-two stride until the visible segments are few enough."""
    cx, cy, view_h = window
    half = np.array([view_h * aspect, view_h]) / 2
    lo, hi = np.array([cx, cy]) - half, np.array([cx, cy]) + half
    stride = 1
    while True:
        thinned = points if stride == 1 else np.concatenate([points[:-1:stride], points[-1:]])
        a, b = thinned[:-1], thinned[1:]
        keep = np.all(np.minimum(a, b) <= hi, axis=1) & np.all(np.maximum(a, b) >= lo, axis=1)
        if np.count_nonzero(keep) <= max_segments or len(thinned) <= 2:
            return a[keep], b[keep]
        stride *= 2


def _range_colour(distance: float) -> tuple[float, float, float, float]:
    """Red (touching) through yellow to green (120 m) for a sonar echo."""
    f = float(np.clip(distance / SONAR_RANGE, 0.0, 1.0))
    return (min(1.0, 2 * (1 - f)), min(1.0, 2 * f), 0.1, 1.0)


class FrameRenderer:
    """Draws frames of one model; owns one OpenGL context, one MjrContext and one scene, reused per frame.

    The renderer works on its own copy of the model and data (visual settings changed, physics untouched)
    and takes the state to draw as a `Snapshot` (pose, sonar, movers, goal, ...), so it can draw recorded
    and interpolated states as well as live ones.
    """

    def __init__(self, physics, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                 camera: str = "both", follow_view: float = FOLLOW_VIEW, arena=None, task=None,
                 title: str = "", samples: int = SAMPLES):
        if camera not in CAMERAS:
            raise ValueError(f"camera must be one of {CAMERAS}, got {camera!r}")
        if width < 16 or height < 16:
            raise ValueError(f"frame size must be at least 16 x 16 pixels, got {width} x {height}")
        glbackend.require()
        self.width, self.height = int(width) // 2 * 2, int(height) // 2 * 2  # even, for yuv420p
        self.follow_view = float(follow_view)
        self.title = title
        self.arena = arena if arena is not None else arena_geometry(physics, task)
        self.model = copy.copy(physics.model.ptr)
        self.data = mujoco.MjData(self.model)
        vis = self.model.vis
        vis.global_.offwidth = max(vis.global_.offwidth, self.width)
        vis.global_.offheight = max(vis.global_.offheight, self.height)
        vis.global_.orthographic = 1
        vis.quality.offsamples = samples
        vis.quality.numquads = 1  # boxes seen from above need no subdivided faces
        vis.map.znear, vis.map.zfar = 0.001, 10.0
        self._extent = arena_extent(self.arena)
        self.model.stat.extent = max(self._extent[2], self._extent[3], follow_view, 10.0)
        self.views = _layout(camera, self.width, self.height, self._extent[2] / max(self._extent[3], 1e-9))

        self._qpos = [self.model.joint(n).qposadr[0] for n in ("x", "y", "yaw")]
        self._movers = [self.model.body_mocapid[self.model.body(n).id] for n in self.arena.mover_names]
        self._sonar_sites = [self.model.site(f"sonar_site_{i}").id for i in range(1, 10)]
        self.data.qpos[:] = physics.data.qpos
        self.data.mocap_pos[:] = physics.data.mocap_pos

        try:
            self._gl = _gl_context_class()(self.width, self.height)
            self._gl.make_current()
        except Exception as e:  # each backend raises its own error type
            raise glbackend.RenderingUnavailable(
                f"cannot create an OpenGL context with MUJOCO_GL={glbackend.backend}: {e}; "
                f"{glbackend.install_hint()}, or set MUJOCO_GL to one of: {glbackend.VALID_VALUES}") from None
        self._context = mujoco.MjrContext(self.model, getattr(mujoco.mjtFontScale,
                                                              f"mjFONTSCALE_{_font_scale(self.height)}"))
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self.scene = mujoco.MjvScene(self.model, self.model.ngeom + EXTRA_GEOMS)
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                     mujoco.mjtRndFlag.mjRND_SKYBOX, mujoco.mjtRndFlag.mjRND_FOG):
            self.scene.flags[flag] = 0
        self.option = mujoco.MjvOption()
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.azimuth, self.camera.elevation = 90.0, -90.0  # +x right, +y up
        self.camera.orthographic = 1
        self._full = mujoco.MjrRect(0, 0, self.width, self.height)
        self._rects = [mujoco.MjrRect(*v.rect) for v in self.views]
        self._pixels = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self._eye = np.eye(3).ravel()
        self._zero = np.zeros(3)
        self._trail_bounds = np.full(4, np.nan)  # bounding box of the trail (open-water overview)

    # --- geometry of the views ----------------------------------------------------------------------

    def _view_window(self, view: View, state: Snapshot, trail: np.ndarray) -> tuple[float, float, float]:
        """(cx, cy, height [m]) seen by `view`."""
        _, _, w, h = view.rect
        aspect = w / h
        if view.kind == "follow":
            return float(state.pose[0]), float(state.pose[1]), self.follow_view
        cx, cy, ew, eh = self._extent
        if not np.all(np.isfinite(self.arena.bounds)):  # open water: keep the trajectory in view
            pts = np.concatenate([trail.reshape(-1, 2), state.pose[None, :2], [[cx - ew / 2, cy - eh / 2],
                                                                               [cx + ew / 2, cy + eh / 2]]])
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            grow = 1 + 2 * OVERVIEW_MARGIN
            size = np.maximum(hi - lo, OPEN_WATER_VIEW / grow) * grow
            (cx, cy), (ew, eh) = (lo + hi) / 2, size
        return float(cx), float(cy), float(max(eh, ew / aspect))

    # --- decorations ------------------------------------------------------------------------------------

    def _add(self, kind: int, rgba, pos=None, size=None, mat=None, emission: float = 0.6):
        scene = self.scene
        if scene.ngeom >= scene.maxgeom:
            return None
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, kind, self._zero if size is None else size,
                            self._zero if pos is None else pos, self._eye if mat is None else mat,
                            np.asarray(rgba, dtype=np.float32))
        geom.emission = emission
        geom.specular = 0.0  # flat colours: no highlight of the headlight on the water
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1
        return geom

    def _line(self, a, b, rgba, width: float, z: float) -> None:
        geom = self._add(mujoco.mjtGeom.mjGEOM_LINE, rgba)
        if geom is not None:
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_LINE, width,
                                 np.array([a[0], a[1], z]), np.array([b[0], b[1], z]))

    def _polyline(self, points: np.ndarray, rgba, width: float, z: float, closed: bool = False) -> None:
        if closed and len(points) > 2:
            points = np.concatenate([points, points[:1]])
        self._segments((points[:-1], points[1:]), rgba, width, z)

    def _segments(self, segments: tuple[np.ndarray, np.ndarray], rgba, width: float, z: float) -> None:
        for a, b in zip(*segments, strict=True):
            self._line(a, b, rgba, width, z)

    def _disc(self, centre, radius: float, rgba, z: float) -> None:
        self._add(mujoco.mjtGeom.mjGEOM_CYLINDER, rgba, np.array([centre[0], centre[1], z]),
                  np.array([radius, radius, 0.05]), emission=0.8)

    def _box(self, centre, half_size, rgba, z: float) -> None:
        self._add(mujoco.mjtGeom.mjGEOM_BOX, rgba, np.array([centre[0], centre[1], z]),
                  np.array([half_size[0], half_size[1], 0.05]), emission=1.0)

    def _triangle(self, p0, p1, p2, rgba, z: float) -> None:
        # MuJoCo's triangle geom spans (0,0,0), (size0,0,0), (0,size1,0) through `mat`: a shear puts
        # its corners anywhere. Both windings are drawn so that it shows from above whatever the order.
        for a, b in ((p1, p2), (p2, p1)):
            mat = np.array([[a[0] - p0[0], b[0] - p0[0], 0.0],
                            [a[1] - p0[1], b[1] - p0[1], 0.0],
                            [0.0, 0.0, 1.0]]).ravel()
            self._add(mujoco.mjtGeom.mjGEOM_TRIANGLE, rgba, np.array([p0[0], p0[1], z]),
                      np.array([1.0, 1.0, 1.0]), mat, emission=1.0)

    def _decorate(self, view: View, state: Snapshot, trail: np.ndarray, subgoals: np.ndarray,
                  reached: int, window: tuple[float, float, float]) -> None:
        cx, cy, view_h = window
        _, _, w, h = view.rect
        view_w = view_h * w / h
        px = view_h / h  # metres per pixel
        a = self.arena
        # Water: one box over the whole view (the sea goes on past the map's bounds, drawn as lines).
        self._box((cx, cy), (view_w / 2, view_h / 2), WATER_RGBA, Z_WATER)
        if np.all(np.isfinite(a.bounds)):
            corners = np.array([a.bounds[:2], a.bounds[[2, 1]], a.bounds[2:], a.bounds[[0, 3]]])
            self._polyline(corners, BOUNDS_RGBA, 2.0, Z_PATH, closed=True)
        # Scale bar in the bottom-left corner, above its label (drawn by `render`).
        bar, line_h = scale_bar_length(view_w), self._context.charHeight * px
        start = np.array([cx - view_w / 2 + 0.6 * line_h, cy - view_h / 2 + 1.8 * line_h])
        self._line(start, start + (bar, 0.0), SCALE_RGBA, 3.0, Z_MARKER)
        for end in (start, start + (bar, 0.0)):
            self._line(end - (0.0, 0.3 * line_h), end + (0.0, 0.3 * line_h), SCALE_RGBA, 2.0, Z_MARKER)
        # Global path, moving obstacles' paths, goals: only what the view shows.
        if len(a.path) > 1:
            self._segments(_in_view(a.path, window, w / h), PATH_RGBA, 2.0, Z_PATH)
        for start, end in a.mover_paths:
            self._line(start, end, MOVER_PATH_RGBA, 1.0, Z_PATH)
        visible = np.all(np.abs(subgoals - (cx, cy)) < np.array([view_w, view_h]) / 2 + a.goal_radius, axis=1)
        for i in np.flatnonzero(visible):
            if not np.allclose(subgoals[i], state.desired_goal):
                self._disc(subgoals[i], a.goal_radius, REACHED_RGBA if i < reached else SUBGOAL_RGBA, Z_GOAL)
        goal = state.desired_goal if np.all(np.isfinite(state.desired_goal)) else a.goal
        if np.all(np.isfinite(goal)):
            self._disc(goal, a.goal_radius, GOAL_RGBA, Z_GOAL + 0.05)
            self._disc(goal, max(1.5 * px, 0.5), GOAL_RGBA[:3] + (1.0,), Z_GOAL + 0.1)
        # Trail.
        points = np.concatenate([trail.reshape(-1, 2), state.pose[None, :2]])
        self._segments(_in_view(points, window, w / h), TRAIL_RGBA, 2.0 if view.kind == "follow" else 1.5,
                       Z_TRAIL)
        # Sonar beams from the bow to their hit points.
        d = self.data
        for site, distance in zip(self._sonar_sites, state.sonar, strict=True):
            start = d.site_xpos[site]
            end = start + d.site_xmat[site].reshape(3, 3)[:, 2] * distance
            if distance >= SONAR_RANGE - 1e-6:
                self._line(start, end, NO_ECHO_RGBA, 1.0, Z_BEAM)
            else:
                colour = _range_colour(distance)
                self._line(start, end, colour, 2.0 if view.kind == "follow" else 1.0, Z_BEAM)
                self._box(end, (2.5 * px, 2.5 * px), colour, Z_BEAM + 0.1)  # square: fewer triangles
        # The vehicle: a dart pointing along its heading, MARKER_LENGTH of the view tall.
        x, y, psi = state.pose
        length = max(MARKER_LENGTH * view_h, 1.4)
        c, s = math.cos(psi), math.sin(psi)
        fwd, left = np.array([c, s]), np.array([-s, c])
        centre = np.array([x, y])
        tip, notch = centre + 0.6 * length * fwd, centre - 0.2 * length * fwd
        port, starboard = centre - 0.4 * length * fwd + 0.35 * length * left, \
            centre - 0.4 * length * fwd - 0.35 * length * left
        self._triangle(tip, port, notch, MARKER_RGBA, Z_MARKER)
        self._triangle(tip, notch, starboard, MARKER_RGBA, Z_MARKER)

    # --- drawing ------------------------------------------------------------------------------------------

    def set_state(self, state: Snapshot) -> None:
        """Puts the vehicle and the moving obstacles where `state` says (render copy only)."""
        self.data.qpos[self._qpos] = state.pose
        for mocap, position in zip(self._movers, state.movers, strict=True):
            self.data.mocap_pos[mocap][:2] = position
        mujoco.mj_kinematics(self.model, self.data)

    def render(self, state: Snapshot, trail: np.ndarray | None = None, subgoals: np.ndarray | None = None,
               reached: int = 0, event: str = "", out: np.ndarray | None = None) -> np.ndarray:
        """One (H, W, 3) uint8 frame of `state`; `trail` (K, 2) the path so far, `event` a banner."""
        trail = np.zeros((0, 2)) if trail is None else trail
        subgoals = np.zeros((0, 2)) if subgoals is None else subgoals
        self._gl.make_current()
        self.set_state(state)
        model, ctx = self.model, self._context
        for view, rect in zip(self.views, self._rects, strict=True):
            cx, cy, view_h = window = self._view_window(view, state, trail)
            self.camera.lookat[:] = (cx, cy, 0.0)
            self.camera.distance = 0.5 * model.stat.extent
            model.vis.global_.fovy = view_h  # orthographic: the view height in metres
            mujoco.mjv_updateScene(model, self.data, self.option, None, self.camera,
                                   mujoco.mjtCatBit.mjCAT_ALL, self.scene)
            self._decorate(view, state, trail, subgoals, reached, window)
            if view.inset:
                left, bottom, w, h = view.rect
                border = mujoco.MjrRect(left - INSET_BORDER, bottom - INSET_BORDER,
                                        w + 2 * INSET_BORDER, h + 2 * INSET_BORDER)
                mujoco.mjr_rectangle(border, 0.9, 0.9, 0.9, 1.0)
            mujoco.mjr_render(rect, self.scene, ctx)
            if self.height >= OVERLAY_MIN_HEIGHT:
                bar = scale_bar_length(window[2] * view.rect[2] / view.rect[3])
                mujoco.mjr_overlay(mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT, rect,
                                   f"{bar:g} m", "", ctx)
                if view.inset or (view.kind == "overview" and len(self.views) == 1):
                    mujoco.mjr_overlay(mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_BOTTOMRIGHT, rect,
                                       f"overview, {window[2]:.0f} m tall", "", ctx)
        if self.height >= OVERLAY_MIN_HEIGHT:
            self._overlay(state, event, reached, len(subgoals))
        mujoco.mjr_readPixels(self._pixels, None, self._full, ctx)
        if out is None:
            out = np.empty_like(self._pixels)
        np.copyto(out, self._pixels[::-1])
        return out

    def _overlay(self, state: Snapshot, event: str, reached: int, goals: int) -> None:
        u, v, r = state.velocity
        heading = math.degrees(state.pose[2])
        labels = ["time", "speed", "heading", "reward"]
        values = [f"{state.time:7.1f} s   step {state.step}",
                  f"{math.hypot(u, v):5.2f} m/s", f"{(heading + 180) % 360 - 180:6.1f} deg",
                  f"{state.reward:+.3f}  (return {state.episode_return:+.2f})"]
        if state.command is not None and np.all(np.isfinite(state.command)):
            values[1] += f"   cmd {state.command[0]:.2f}"
            values[2] += f"   cmd {math.degrees(state.command[1] + math.pi) % 360 - 180:6.1f}"
        if goals > 1:
            labels.append("goals")
            values.append(f"{min(reached, goals)} / {goals} reached")
        if self.title:
            labels.insert(0, "task")
            values.insert(0, self.title)
        mujoco.mjr_overlay(mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_TOPLEFT, self._full,
                           "\n".join(labels), "\n".join(values), self._context)
        if event and event not in QUIET_EVENTS:
            self._banner(event.upper().replace("_", " "), EVENT_COLOURS.get(event, (1.0, 1.0, 1.0)))

    def _banner(self, text: str, colour: tuple[float, float, float]) -> None:
        """`text` in the big font, centred near the bottom of the frame on a dark box."""
        ctx = self._context
        text_w = sum(ctx.charWidthBig[ord(c)] for c in text if ord(c) < len(ctx.charWidthBig))
        text_h = ctx.charHeightBig
        pad = text_h // 2
        box = mujoco.MjrRect(self.width // 2 - text_w // 2 - pad, self.height // 12,
                             text_w + 2 * pad, text_h + 2 * pad)
        mujoco.mjr_rectangle(box, 0.0, 0.0, 0.0, 0.6)  # also makes `box` the viewport mjr_text is relative to
        mujoco.mjr_text(mujoco.mjtFont.mjFONT_BIG, text, ctx, pad / box.width, pad / box.height, *colour)

    def close(self) -> None:
        """Frees the OpenGL resources (also done at garbage collection)."""
        if getattr(self, "_context", None) is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
        if getattr(self, "_gl", None) is not None:
            self._gl.free()
            self._gl = None

    def __enter__(self) -> FrameRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: the GL library may already be gone
            pass


# --- episodes -----------------------------------------------------------------------------------------


def interpolate(a: Snapshot, b: Snapshot, t: float) -> Snapshot:
    """The state at time t in [a.time, b.time]: pose, velocity and movers linear, sonar held from `a`."""
    span = b.time - a.time
    if t >= b.time - TIME_TOLERANCE or span <= 0:
        return b
    alpha = float(np.clip((t - a.time) / span, 0.0, 1.0))
    pose = a.pose + alpha * (b.pose - a.pose)
    pose[2] = a.pose[2] + alpha * wrap_angle(b.pose[2] - a.pose[2])
    return replace(a, time=t, pose=pose, velocity=a.velocity + alpha * (b.velocity - a.velocity),
                   movers=a.movers + alpha * (b.movers - a.movers))


class _Trail:
    """Positions so far, one kept every `spacing` metres (amortised O(1) appends, no per-frame copies)."""

    def __init__(self, spacing: float):
        self.spacing = spacing
        self._points = np.empty((1024, 2))
        self.count = 0

    def add(self, point: np.ndarray) -> None:
        if self.count and np.hypot(*(point - self._points[self.count - 1])) < self.spacing:
            return
        if self.count == len(self._points):
            self._points = np.concatenate([self._points, np.empty_like(self._points)])
        self._points[self.count] = point
        self.count += 1

    def view(self) -> np.ndarray:
        return self._points[: self.count]


def iter_frames(env, policy, *, max_steps: int | None = None, width: int = DEFAULT_SIZE[0],
                height: int = DEFAULT_SIZE[1], camera: str = "both", fps: float = DEFAULT_FPS,
                speedup: float | None = None, follow_view: float = FOLLOW_VIEW,
                hold_end: float = DEFAULT_HOLD_END, title: str = "", recorder: EpisodeRecorder | None = None,
                progress: bool = False) -> Iterator[np.ndarray]:
    """Runs one episode of `policy(time_step) -> action` on `env`, yielding (H, W, 3) uint8 frames.

    A frame every `speedup / fps` simulation seconds (default: one per control step). Pass a `recorder`
    to keep the episode's record as well.
    """
    recorder = recorder if recorder is not None else EpisodeRecorder(env)
    frame_dt = (speedup if speedup is not None else fps * env.control_timestep()) / fps
    if not frame_dt > 0:
        raise ValueError(f"speedup and fps must be positive, got speedup={speedup}, fps={fps}")
    glbackend.require()
    trail = _Trail(TRAIL_SPACING * follow_view)
    seen_goals: list[np.ndarray] = []
    renderer, previous, frame = None, None, None
    event, event_until, next_time = "", -math.inf, 0.0
    total = getattr(env, "_step_limit", None)
    total = min(total if total and math.isfinite(total) else math.inf, max_steps or math.inf)
    bar = _progress(total if math.isfinite(total) else None, progress)
    try:
        for snap in recorder.run(policy, max_steps):
            if renderer is None:  # after the reset: the task has drawn its route
                renderer = FrameRenderer(env.physics, width, height, camera, follow_view,
                                         arena=recorder.arena, title=title)
                previous, next_time = snap, snap.time
            if np.all(np.isfinite(snap.desired_goal)) and (
                    not seen_goals or not np.allclose(seen_goals[-1], snap.desired_goal)):
                seen_goals.append(snap.desired_goal)
            goals = recorder.arena.goals if len(recorder.arena.goals) else np.array(seen_goals).reshape(-1, 2)
            reached = int(snap.info.get("goals_reached", len(seen_goals) - 1))
            if snap.event:
                event, event_until = snap.event, snap.time + EVENT_HOLD * fps * frame_dt
            while next_time <= snap.time + TIME_TOLERANCE:
                state = interpolate(previous, snap, next_time)
                trail.add(state.pose[:2])
                shown = event if next_time <= event_until else ""
                frame = renderer.render(state, trail.view(), goals, reached, shown)
                yield frame
                next_time += frame_dt
            previous = snap
            if snap.step:
                bar.update(1)
        for _ in range(int(round(hold_end * fps)) if frame is not None else 0):
            yield frame.copy()
    finally:
        bar.close()
        if renderer is not None:
            renderer.close()


def _progress(total: float | None, enabled: bool):
    return progress_bar(total=None if total is None else math.ceil(total), unit="step", desc="render",
                        disable=not enabled)


def render_episode(env, policy, **kwargs) -> np.ndarray:
    """All frames of one episode as a (T, H, W, 3) uint8 array (see `iter_frames` for the options)."""
    frames = list(iter_frames(env, policy, **kwargs))
    return np.stack(frames) if frames else np.zeros((0, 0, 0, 3), dtype=np.uint8)


def render_frame(physics, width: int = 640, height: int = 360, camera: str = "both",
                 follow_view: float = FOLLOW_VIEW, task=None) -> np.ndarray:
    """One (H, W, 3) uint8 picture of the current state of an AUVPhysics (a fresh context; for notebooks)."""
    state = Snapshot(time=float(physics.time()), pose=physics.pose(), velocity=physics.body_velocity(),
                     sonar=physics.sonar(), control=physics.data.ctrl.copy(), desired_goal=np.full(2, np.nan),
                     movers=np.zeros((0, 2)))
    with FrameRenderer(physics, width, height, camera, follow_view, task=task) as renderer:
        state.movers = mover_positions(physics, renderer.arena.mover_names)
        return renderer.render(state)


# --- files -------------------------------------------------------------------------------------------------


def ffmpeg_available() -> bool:
    """Whether imageio-ffmpeg can find an ffmpeg binary."""
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
        return True
    except (ImportError, RuntimeError):
        return False


def write_video(frames: Iterable[np.ndarray], path: str | Path, fps: float = DEFAULT_FPS,
                gif: bool | None = None) -> Path:
    """Writes frames to `path`: H.264 MP4 (yuv420p), or GIF when asked, named .gif, or without ffmpeg.

    Frames stream to ffmpeg (a long episode never sits in memory as MP4); a GIF collects them first.
    Returns the path written (its suffix is .gif when it fell back to GIF).
    """
    path = Path(path)
    gif = path.suffix.lower() == ".gif" if gif is None else gif
    if not gif and not ffmpeg_available():
        warnings.warn("no ffmpeg binary (imageio-ffmpeg) found: writing a GIF instead of an MP4",
                      stacklevel=2)
        gif = True
    if gif and path.suffix.lower() != ".gif":
        path = path.with_suffix(".gif")
    path.parent.mkdir(parents=True, exist_ok=True)
    if gif:
        import imageio.v3 as iio

        stack = np.stack(list(frames))
        iio.imwrite(path, stack, extension=".gif", duration=1000.0 / fps, loop=0)
        return path
    import imageio_ffmpeg

    writer = None
    try:
        for frame in frames:
            if writer is None:
                h, w = frame.shape[:2]
                if h % 2 or w % 2:
                    raise ValueError(f"H.264 (yuv420p) needs even frame sizes, got {w} x {h}")
                writer = imageio_ffmpeg.write_frames(
                    str(path), (w, h), fps=fps, codec="libx264", pix_fmt_out="yuv420p", quality=7,
                    macro_block_size=1, output_params=["-preset", "veryfast"])
                writer.send(None)
            writer.send(np.ascontiguousarray(frame))
    finally:
        if writer is not None:
            writer.close()
    if writer is None:
        raise ValueError("no frames to write")
    return path


# --- benchmark ---------------------------------------------------------------------------------------


def benchmark(env, policy, sizes: tuple[tuple[int, int], ...] = ((1280, 720), (640, 360)), frames: int = 60,
              repeats: int = 3) -> dict[str, dict[str, float]]:
    """Frames/s of FrameRenderer (camera "both") vs a bare `mujoco.Renderer` of the same scene and size.

    Both draw the same recorded states of `env` run by `policy` (`auv-mj bench` uses the obstacles task
    with line of sight) from the same orthographic top-down camera with the same multisampling; the bare renderer
    draws the model's geoms only, one view, no decorations or text (the limit). The best of `repeats`
    passes counts (the machine may be shared). Returns {"WxH": {"ours_fps", "bare_fps", "ratio"}}.
    """
    recorder = EpisodeRecorder(env)
    states = list(recorder.run(policy, frames))
    trail = np.array([s.pose[:2] for s in states])
    results = {}
    for width, height in sizes:
        with FrameRenderer(env.physics, width, height, "both", arena=recorder.arena) as renderer:
            out = np.empty((renderer.height, renderer.width, 3), np.uint8)
            renderer.render(states[0], out=out)  # warm-up

            def ours(renderer=renderer, out=out) -> None:
                for i, state in enumerate(states):
                    renderer.render(state, trail[: i + 1], out=out)

            ours_fps = len(states) / _best_time(ours, repeats)
        bare_fps = _bare_fps(env.physics, states, width, height, repeats)
        results[f"{width}x{height}"] = {"ours_fps": ours_fps, "bare_fps": bare_fps,
                                        "ratio": ours_fps / bare_fps}
    return results


def _best_time(work, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        work()
        best = min(best, time.perf_counter() - start)
    return best


def _bare_fps(physics, states: list[Snapshot], width: int, height: int, repeats: int) -> float:
    model = copy.copy(physics.model.ptr)
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    model.vis.global_.orthographic = 1
    model.vis.global_.fovy = FOLLOW_VIEW
    model.vis.quality.offsamples = SAMPLES
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.azimuth, camera.elevation, camera.distance = 90.0, -90.0, 0.5 * model.stat.extent
    qpos = [model.joint(n).qposadr[0] for n in ("x", "y", "yaw")]
    renderer = mujoco.Renderer(model, height, width)
    try:
        renderer.render()

        def bare() -> None:
            for state in states:
                data.qpos[qpos] = state.pose
                mujoco.mj_kinematics(model, data)
                camera.lookat[:] = (state.pose[0], state.pose[1], 0.0)
                renderer.update_scene(data, camera)
                renderer.render()

        return len(states) / _best_time(bare, repeats)
    finally:
        renderer.close()
