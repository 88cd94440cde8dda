"""One frame of a planar episode: a top-down picture of the arena with the vehicle, sonar beams, trail and goals.

This module holds the drawing of a single instant: the frame's layout (`View`), its constants (sizes, colours, the
follow view's height), `FrameRenderer`, which draws a `Snapshot` of the state into an (H, W, 3) uint8 array, and
`render_frame`, one picture of a live physics. Episodes (timing, interpolation, the trail) are
`auv_mj.render.episode_video`; files are `auv_mj.render.writers`. Off-screen OpenGL through EGL or OSMesa
(`auv_mj.render.glbackend`); no display is needed.

What a frame shows: a follow camera (orthographic, looking straight down, FOLLOW_VIEW metres tall,
north up) and/or an overview of the whole arena (full frame, or as picture-in-picture with
`--camera both`); the model's own geoms (walls, obstacles, moving obstacles where the physics puts
them) drawn by MuJoCo; the water, the map bounds, the global path, the goal area and sub-goals, the
trajectory trail, the nine sonar beams from the bow to their hit points coloured by range, and the vehicle
as a scaled-up dart marker (the 1.33 m hull would be a few pixels); a text overlay (laid out as
MuJoCo's `mjr_overlay`); and, in the bottom right corner, a key: the sonar's range colours as a ramp from 0 m
(red) to 120 m (green), and what each line is (beams without an echo, map bounds, global path, trail, movers'
paths).

How: OpenGL here is usually a CPU rasteriser (Mesa llvmpipe), which pays for every pixel it clears or
fills, and numpy pays for the pixels it touches. So OpenGL draws only boxes around the model's geoms, each
on a patch of water in a viewport of its own (the view's frustum cut to the box, so the camera and its
headlight do not move), and only those are read back; the open water, the decorations and the text
(MuJoCo's bitmap fonts, read back once) are drawn in numpy (`auv_mj.render.raster`); geoms taller than the
decorations hide them, as before. Only what changed is drawn again: the follow view's static geoms come
from a layer redrawn when the camera has moved SHADE_DRIFT, the overview's arena (water, static geoms,
bounds, paths, goals) from a layer redrawn when its window or the goals change, and the overview is
repainted only when what moves in it moves by a pixel. The vehicle's own geoms are left out of the
follow view: its marker covers the hull.

`GLOwner` (freeing the OpenGL and MuJoCo render contexts) and `gl_context_class` (the headless backend's context)
are shared with the 6-DOF renderer (`auv_mj.render.frame3d`); how fast `FrameRenderer` draws beside a bare
`mujoco.Renderer` is measured in `auv_mj.speed.render`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from auv_mj.episode import Snapshot, arena_geometry, mover_positions
from auv_mj.render import glbackend, raster
from auv_mj.sim.sonar import SONAR_RANGE

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
MAX_SEGMENTS = 400
"""At most this many segments of a polyline (trail, global path) are drawn per view (thinned evenly)."""
OVERLAY_MIN_HEIGHT = 240
"""Below this frame height [px] the text overlay is left out: MuJoCo's smallest font would cover the view."""
SAMPLES = 0
"""Multisampling (MSAA) of the off-screen buffer: 4x costs about half the frame rate on a CPU rasteriser
(Mesa llvmpipe) for slightly smoother lines; 0 is sharp enough at 720p."""
GEOM_SLICES = (16, 6)
"""Slices and stacks of round geoms (MuJoCo's defaults 28 and 16): the hull is a few pixels long under its
marker, and the rasteriser pays per vertex."""
EXTRA_GEOMS = 100
"""Room in the scene beyond the model and the patches of water (decorations MuJoCo adds itself)."""
SHADE_DRIFT = 4.0
"""The follow view's static geoms are drawn again when its camera has moved this far [m]: MuJoCo's headlight
shades them by where the camera is, by about one grey level over this distance (and they may sit half a
pixel off)."""
MERGE_AREA = 40000
"""Boxes around geoms are drawn in one OpenGL pass when that adds fewer pixels than this (a pass costs about
as much as shading them on a CPU rasteriser)."""
HEADLIGHT_GAIN = 0.5
"""Light on a face seen head-on from MuJoCo's default headlight (ambient 0.1 + diffuse 0.4)."""

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

KEY_RAMP_CHARS = 8
"""The key's colour ramp of sonar echoes is as wide as this many characters of the overlay's font."""
KEY_SWATCH_CHARS = 3
"""A line's swatch in the key is as long as this many characters."""

Z_WATER = -2.0
"""Height [m] of the patches of water OpenGL draws under the model's geoms (below every geom)."""
DECORATION_HEIGHT = 1.5
"""Geoms whose top is higher than this [m] hide the decorations (beams end at obstacles' sides, not on top)."""


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


def gl_context_class():
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


def _line(rgba) -> np.ndarray:
    """The colour [0-255] MuJoCo gives a decoration line of `rgba` (drawn unlit, as given)."""
    return np.floor(np.asarray(rgba[:3], float) * 255)


def _fill(rgba, emission: float) -> np.ndarray:
    """The colour [0-255] MuJoCo gives a flat decoration of `rgba` seen head-on: emission plus the
    headlight's ambient and diffuse light (HEADLIGHT_GAIN), saturating at white."""
    return np.floor(np.minimum(np.asarray(rgba[:3], float) * (emission + HEADLIGHT_GAIN), 1.0) * 255)


def _merge(boxes: np.ndarray, merge_area: float) -> np.ndarray:
    """Pixel boxes (N, 4) of (row0, row1, col0, col1) grouped into fewer, disjoint ones: overlapping boxes
    always, others while their bounding box adds fewer than `merge_area` pixels (a pass of OpenGL costs
    about as much as shading that many). Greedy, the cheapest pair first."""
    boxes = np.asarray(boxes, float).reshape(-1, 4)
    union = np.array([boxes[:, 0].min(), boxes[:, 1].max(), boxes[:, 2].min(), boxes[:, 3].max()])
    areas = (boxes[:, 1] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 2])
    if (union[1] - union[0]) * (union[3] - union[2]) - areas.sum() < merge_area:  # all in one pass
        return union[None].astype(int)
    while len(boxes) > 1:
        lo = np.minimum(boxes[:, None, [0, 2]], boxes[None, :, [0, 2]])
        hi = np.maximum(boxes[:, None, [1, 3]], boxes[None, :, [1, 3]])
        area = (boxes[:, 1] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 2])
        overlap = np.prod(np.clip(np.minimum(boxes[:, None, [1, 3]], boxes[None, :, [1, 3]])
                                  - np.maximum(boxes[:, None, [0, 2]], boxes[None, :, [0, 2]]), 0, None), axis=2)
        added = np.prod(hi - lo, axis=2) - area[:, None] - area[None, :] + overlap
        added = np.where(overlap > 0, -1.0, added)
        added[np.diag_indices(len(boxes))] = np.inf
        i, j = np.unravel_index(np.argmin(added), added.shape)
        if added[i, j] >= merge_area:
            break
        boxes[i] = (lo[i, j, 0], hi[i, j, 0], lo[i, j, 1], hi[i, j, 1])
        boxes = np.delete(boxes, j, axis=0)
    return boxes.astype(int)


def _opacity(alpha):
    """How opaque MuJoCo draws a translucent decoration of `alpha`: it blends the back and then the front
    faces (a line twice), so 1 - (1 - alpha)^2."""
    return 1.0 - (1.0 - np.asarray(alpha, float)) ** 2


def _range_colours(distance: np.ndarray) -> np.ndarray:
    """RGBA (N, 4): red (touching) through yellow to green (120 m) for sonar echoes at `distance` (N,)."""
    f = np.clip(np.asarray(distance, float) / SONAR_RANGE, 0.0, 1.0)
    return np.stack([np.minimum(1.0, 2 * (1 - f)), np.minimum(1.0, 2 * f), np.full_like(f, 0.1), np.ones_like(f)],
                    axis=1)


class GLOwner:
    """Frees a renderer's OpenGL context (`_gl`) and MuJoCo render context (`_context`): on `close()`, at the end of
    a `with` block, and at garbage collection. The planar and the 6-DOF frame renderers both hold them."""

    def close(self) -> None:
        """Frees the OpenGL resources (also done at garbage collection)."""
        if getattr(self, "_context", None) is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
        if getattr(self, "_gl", None) is not None:
            self._gl.free()
            self._gl = None

    def __enter__(self) -> GLOwner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: the GL library may already be gone
            pass


class FrameRenderer(GLOwner):
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
        # The framebuffer holds the follow view's static layer: the frame and a margin of SHADE_DRIFT.
        margin = 2 * (int(math.ceil(SHADE_DRIFT * self.height / self.follow_view)) + 1)
        vis.global_.offwidth = max(vis.global_.offwidth, self.width + margin)
        vis.global_.offheight = max(vis.global_.offheight, self.height + margin)
        vis.global_.orthographic = 1
        vis.quality.offsamples = samples
        vis.quality.numquads = 1  # boxes seen from above need no subdivided faces
        vis.quality.numslices, vis.quality.numstacks = GEOM_SLICES
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
            self._gl = gl_context_class()(self.width, self.height)
            self._gl.make_current()
        except Exception as e:  # each backend raises its own error type
            raise glbackend.RenderingUnavailable(
                f"cannot create an OpenGL context with MUJOCO_GL={glbackend.backend}: {e}; "
                f"{glbackend.install_hint()}, or set MUJOCO_GL to one of: {glbackend.VALID_VALUES}") from None
        self._context = mujoco.MjrContext(self.model, getattr(mujoco.mjtFontScale,
                                                              f"mjFONTSCALE_{_font_scale(self.height)}"))
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        # Room for the model (geoms, sites) and a patch of water per OpenGL pass (at most one per shape).
        self.scene = mujoco.MjvScene(self.model, 2 * (self.model.ngeom + self.model.nsite) + EXTRA_GEOMS)
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                     mujoco.mjtRndFlag.mjRND_SKYBOX, mujoco.mjtRndFlag.mjRND_FOG):
            self.scene.flags[flag] = 0
        self.option = mujoco.MjvOption()
        self.option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = 0  # the render copy computes no sensors
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.azimuth, self.camera.elevation = 90.0, -90.0  # +x right, +y up
        self.camera.orthographic = 1
        self._eye = np.eye(3).ravel()
        self._classify_shapes()
        # Caches: marker masks, the overview's arena layer, the follow view's static layer, the last overview.
        self._darts: dict[tuple[float, int], tuple[np.ndarray, int, int]] = {}
        self._layer, self._layer_key = None, None
        self._follow_layer = None
        self._inset_key, self._inset_pixels = None, None
        self._marker_colour = _fill(MARKER_RGBA, 1.0)
        a = self.arena  # map bounds and movers' paths in world coordinates, drawn in every view
        corners = (np.array([a.bounds[:2], a.bounds[[2, 1]], a.bounds[2:], a.bounds[[0, 3]], a.bounds[:2]])
                   if np.all(np.isfinite(a.bounds)) else np.zeros((1, 2)))
        paths = np.asarray(a.mover_paths, float).reshape(-1, 2, 2)
        self._fixed_lines = ((corners[:-1], corners[1:], BOUNDS_RGBA, 2),
                             (paths[:, 0], paths[:, 1], MOVER_PATH_RGBA, 1))
        # Water as large as a view with the follow layer's margin, to copy from.
        self._water_image = np.empty((self.height + margin, self.width + margin, 3), np.uint8)
        self._hidden = np.zeros((self.height, self.width), bool)  # pixels of geoms above the decorations
        self._water_image[:] = self._water_colour()
        self._font = raster.BitmapFont(self._context, mujoco.mjtFont.mjFONT_NORMAL, self.width, self.height)
        self._font_big = raster.BitmapFont(self._context, mujoco.mjtFont.mjFONT_BIG, self.width, self.height)
        self.key_labels = self._key_entries()[1]
        self._key = self._key_patch() if self.height >= OVERLAY_MIN_HEIGHT else None

    def _classify_shapes(self) -> None:
        """Masks over the model's shapes (its geoms, then its sites) OpenGL draws: those that never move (the
        arena: cached layers), the movers' (drawn each frame), and the follow view's (all but the vehicle's
        own, which its marker covers). Obstacles are mocap bodies too, but only the arena's movers move;
        visible sites (the goal area's) are drawn as MuJoCo draws them."""
        m = self.model
        movers = [m.body(n).id for n in self.arena.mover_names]
        moving_roots = {int(m.body_rootid[b]) for b in range(1, m.nbody) if m.body_dofnum[b]} | set(movers)
        moving = np.isin(m.body_rootid[m.geom_bodyid], list(moving_roots)) | np.isin(m.geom_bodyid, movers)
        self._mover_geoms = [g for g in (np.flatnonzero(m.geom_bodyid == b) for b in movers) if len(g)]
        mover = np.isin(np.arange(m.ngeom), np.concatenate([[], *self._mover_geoms]).astype(int))
        site_moving = np.isin(m.body_rootid[m.site_bodyid], list(moving_roots))
        site_shown = (self.option.sitegroup[np.clip(m.site_group, 0, 5)] > 0) & (m.site_rgba[:, 3] > 0)
        self._static_mask = np.concatenate([~moving, site_shown & ~site_moving])
        self._mover_mask = np.concatenate([mover, np.zeros(m.nsite, bool)])
        self._follow_mask = self._static_mask | self._mover_mask
        self._moving_shapes = ~self._static_mask
        self._static_shapes = np.flatnonzero(self._static_mask)
        self._mover_colours: list[np.ndarray] = []
        mujoco.mj_kinematics(self.model, self.data)
        self._static_boxes = self._world_boxes(self._static_shapes)

    def _water_colour(self) -> np.ndarray:
        """The colour OpenGL gives the patches of water (numpy paints the rest of the sea with it)."""
        self.camera.lookat[:] = (1e7, 1e7, 0.0)  # nothing of the model there
        self.camera.distance = 0.5 * self.model.stat.extent
        self.model.vis.global_.fovy = 10.0
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        self.scene.ngeom = 0
        self._add(mujoco.mjtGeom.mjGEOM_BOX, WATER_RGBA, np.array([1e7, 1e7, Z_WATER]), np.array([50.0, 50.0, 0.05]))
        mujoco.mjr_render(mujoco.MjrRect(0, 0, 4, 4), self.scene, self._context)
        pixel = np.empty((1, 1, 3), np.uint8)
        mujoco.mjr_readPixels(pixel, None, mujoco.MjrRect(2, 2, 1, 1), self._context)
        return pixel[0, 0]

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

    def _add(self, kind: int, rgba, pos, size, emission: float = 1.0) -> None:
        """Appends a decoration geom to the MuJoCo scene (only the water under the model's geoms)."""
        scene = self.scene
        if scene.ngeom >= scene.maxgeom:
            return
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, kind, size, pos, self._eye, np.asarray(rgba, dtype=np.float32))
        geom.emission = emission
        geom.specular = 0.0  # flat colours: no highlight of the headlight on the water
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1

    def _world_boxes(self, shapes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World bounding boxes seen from above, (lo (N, 2), hi (N, 2)), and tops [m] of the model's geoms
        and sites (all, or the indices `shapes` into geoms then sites)."""
        d, m = self.data, self.model
        pos = np.concatenate([d.geom_xpos, d.site_xpos])
        mat = np.concatenate([d.geom_xmat, d.site_xmat]).reshape(-1, 3, 3)
        sizes = np.concatenate([m.geom_size, m.site_size])
        kind = np.concatenate([m.geom_type, m.site_type])
        bound = np.concatenate([m.geom_rbound, m.site_size.max(axis=1)])
        if shapes is not None:
            pos, mat, sizes, kind, bound = pos[shapes], mat[shapes], sizes[shapes], kind[shapes], bound[shapes]
        box = kind == mujoco.mjtGeom.mjGEOM_BOX
        half = np.where(box[:, None], np.einsum("gij,gj->gi", np.abs(mat[:, :2]), sizes), bound[:, None])
        half[kind == mujoco.mjtGeom.mjGEOM_PLANE] = np.inf
        top = pos[:, 2] + np.where(box, np.einsum("gj,gj->g", np.abs(mat[:, 2]), sizes), bound)
        return pos[:, :2] - half, pos[:, :2] + half, top

    def _geom_boxes(self, window: tuple[float, float, float], size: tuple[int, int], geoms: np.ndarray
                    ) -> list[tuple[tuple[int, int, int, int], bool]]:
        """Pixel boxes (row0, row1, col0, col1) around the model's geoms and visible sites selected by `geoms`
        (a mask over geoms, then sites) in a view, and whether each stands above the decorations (its top
        higher than DECORATION_HEIGHT). Static shapes' world boxes are computed once."""
        cx, cy, view_h = window
        w, h = size
        s = h / view_h
        lo, hi, top = self._static_boxes
        moving = np.flatnonzero(geoms & self._moving_shapes)
        if len(moving):
            mlo, mhi, mtop = self._world_boxes(moving)
            lo, hi, top = np.concatenate([lo, mlo]), np.concatenate([hi, mhi]), np.concatenate([top, mtop])
        x0, y1 = cx - view_h * w / h / 2, cy + view_h / 2
        c0 = np.clip(np.floor((lo[:, 0] - x0) * s) - 1, 0, w)
        c1 = np.clip(np.ceil((hi[:, 0] - x0) * s) + 1, 0, w)
        r0 = np.clip(np.floor((y1 - hi[:, 1]) * s) - 1, 0, h)
        r1 = np.clip(np.ceil((y1 - lo[:, 1]) * s) + 1, 0, h)
        show = (c0 < c1) & (r0 < r1)
        if len(self._static_boxes[0]):
            show[:len(self._static_boxes[0])] &= geoms[self._static_shapes]
        return [((int(a), int(b), int(c), int(e)), bool(t)) for a, b, c, e, t in
                zip(r0[show], r1[show], c0[show], c1[show], top[show] > DECORATION_HEIGHT, strict=True)]

    def _draw_geoms(self, image: np.ndarray, clip: raster.Clip, window: tuple[float, float, float],
                    geoms: np.ndarray, hidden: np.ndarray, background: bool = True) -> bool:
        """Water, and the model's geoms `geoms` (a mask) as MuJoCo draws them, into the part `clip` of `image`.

        Each box around the geoms is drawn by OpenGL on its own patch of water, in a viewport of its size
        (packed from the corner of the framebuffer), and read back: a software rasteriser pays for every
        pixel it clears or fills, and most of a view is open water. Marks in `hidden` (cleared in `clip`)
        the pixels of geoms that stand above the decorations; returns whether there are any. Without
        `background`, only the boxes are drawn (over what `image` and `hidden` already hold).
        """
        r0, r1, c0, c1 = clip
        w, h = c1 - c0, r1 - r0
        if background:
            if h <= self._water_image.shape[0] and w <= self._water_image.shape[1]:
                np.copyto(image[r0:r1, c0:c1], self._water_image[:h, :w])
            else:
                image[r0:r1, c0:c1] = self._water_image[0, 0]
            hidden[r0:r1, c0:c1] = False
        found = self._geom_boxes(window, (w, h), geoms)
        if not found:
            return False
        tall = [box for box, is_tall in found if is_tall]
        boxes = _merge([box for box, _ in found], MERGE_AREA)
        cx, cy, view_h = window
        px = view_h / h
        x0, y1 = cx - view_h * w / h / 2, cy + view_h / 2
        self.camera.lookat[:] = (cx, cy, 0.0)
        self.camera.distance = 0.5 * self.model.stat.extent
        self.model.vis.global_.fovy = view_h  # orthographic: the view height in metres
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        for b0, b1, a0, a1 in boxes:
            centre = np.array([x0 + (a0 + a1) / 2 * px, y1 - (b0 + b1) / 2 * px, Z_WATER])
            self._add(mujoco.mjtGeom.mjGEOM_BOX, WATER_RGBA, centre, np.array([(a1 - a0) * px, (b1 - b0) * px, 0.05]))
        buffer_w, buffer_h = self.model.vis.global_.offwidth, self.model.vis.global_.offheight
        pending, x, y, shelf = [], 0, 0, 0
        for b0, b1, a0, a1 in boxes:
            bw, bh = a1 - a0, b1 - b0
            if x + bw > buffer_w:  # next shelf of the framebuffer
                x, y, shelf = 0, y + shelf, 0
            if y + bh > buffer_h:  # the framebuffer is full: read back what it holds, start again
                self._read_patches(image, clip, pending)
                pending, x, y, shelf = [], 0, 0, 0
            # The box's part of the view's frustum, so the camera and its headlight stay where they are.
            for cam in self.scene.camera:
                cam.frustum_center = x0 + (a0 + a1) / 2 * px - cx
                cam.frustum_bottom, cam.frustum_top = view_h / 2 - b1 * px, view_h / 2 - b0 * px
                cam.frustum_width = 0.0
            mujoco.mjr_render(mujoco.MjrRect(x, y, bw, bh), self.scene, self._context)
            pending.append(((b0, b1, a0, a1), (x, y)))
            x, shelf = x + bw, max(shelf, bh)
        self._read_patches(image, clip, pending)
        water = self._water_image[0, 0, 2]
        for b0, b1, a0, a1 in tall:  # the tall geoms' own pixels: not water (the blue channel tells)
            hidden[r0 + b0:r0 + b1, c0 + a0:c0 + a1] = image[r0 + b0:r0 + b1, c0 + a0:c0 + a1, 2] != water
        return bool(tall)

    def _read_patches(self, image: np.ndarray, clip: raster.Clip, patches: list) -> None:
        """Reads back boxes drawn at places of the framebuffer into their part of `clip` in `image`."""
        for (b0, b1, a0, a1), (x, y) in patches:
            patch = np.empty((b1 - b0, a1 - a0, 3), np.uint8)
            mujoco.mjr_readPixels(patch, None, mujoco.MjrRect(x, y, a1 - a0, b1 - b0), self._context)
            image[clip[0] + b0:clip[0] + b1, clip[2] + a0:clip[2] + a1] = patch[::-1]

    def _follow_geoms(self, image: np.ndarray, clip: raster.Clip, window: tuple[float, float, float]) -> bool:
        """The follow view's water and geoms: the static ones cut from a layer drawn around the view (drawn
        again when the camera has moved SHADE_DRIFT), the moving ones (movers) drawn over it by OpenGL.
        Returns whether any geom stands above the decorations (marked in `self._hidden`)."""
        r0, r1, c0, c1 = clip
        w, h = c1 - c0, r1 - r0
        cx, cy, view_h = window
        px = view_h / h
        layer = self._follow_layer
        if (layer is None or layer[1] != px or abs(cx - layer[0][0]) > SHADE_DRIFT
                or abs(cy - layer[0][1]) > SHADE_DRIFT):
            margin = int(math.ceil(SHADE_DRIFT / px)) + 1
            pixels = np.empty((h + 2 * margin, w + 2 * margin, 3), np.uint8)
            hidden = np.zeros(pixels.shape[:2], bool)
            tall = self._draw_geoms(pixels, (0, h + 2 * margin, 0, w + 2 * margin), (cx, cy, (h + 2 * margin) * px),
                                    self._static_mask, hidden)
            layer = self._follow_layer = ((cx, cy), px, pixels, hidden if tall else None, margin)
        (lx, ly), _, pixels, hidden, margin = layer
        dx, dy = margin + int(round((cx - lx) / px)), margin + int(round((ly - cy) / px))
        image[r0:r1, c0:c1] = pixels[dy:dy + h, dx:dx + w]
        if hidden is None:
            self._hidden[r0:r1, c0:c1] = False
        else:
            self._hidden[r0:r1, c0:c1] = hidden[dy:dy + h, dx:dx + w]
        moving = self._follow_mask & ~self._static_mask
        if np.any(moving):
            return self._draw_geoms(image, clip, window, moving, self._hidden, background=False) or hidden is not None
        return hidden is not None

    @staticmethod
    def _to_pixels(points, window: tuple[float, float, float], clip: raster.Clip) -> np.ndarray:
        """(column, row) pixel coordinates in the image of world points (N, 2) seen in `window` at `clip`."""
        cx, cy, view_h = window
        r0, r1, c0, c1 = clip
        s = (r1 - r0) / view_h
        return (np.asarray(points, float).reshape(-1, 2) - (cx, cy)) * (s, -s) + ((c0 + c1) / 2, (r0 + r1) / 2)

    def _static_lines(self, window: tuple[float, float, float], clip: raster.Clip) -> tuple[np.ndarray, ...]:
        """Segments of what does not move, in pixels: map bounds, global path (what the view shows),
        movers' paths, scale bar; as (starts, ends, colours, widths, opacities)."""
        r0, r1, c0, c1 = clip
        w, h = c1 - c0, r1 - r0
        bounds, movers = self._fixed_lines
        path = _in_view(self.arena.path, window, w / h) if len(self.arena.path) > 1 else (np.zeros((0, 2)),) * 2
        groups = (bounds, (*path, PATH_RGBA, 2), movers)
        ends = self._to_pixels(np.concatenate([g[i] for i in (0, 1) for g in groups]), window, clip)
        n = sum(len(g[0]) for g in groups)
        # Scale bar in the bottom-left corner, above its label.
        bar, line_h = scale_bar_length(window[2] * w / h) * h / window[2], self._context.charHeight
        x, y = c0 + 0.6 * line_h, r1 - 1.8 * line_h
        tick = 0.3 * line_h
        bar_starts = np.array([[x, y], [x, y - tick], [x + bar, y - tick]])
        bar_ends = np.array([[x + bar, y], [x, y + tick], [x + bar, y + tick]])
        rgba = np.concatenate([np.broadcast_to(np.asarray(g[2], float), (len(g[0]), 4)) for g in groups]
                              + [np.broadcast_to(np.asarray(SCALE_RGBA, float), (3, 4))])
        widths = np.concatenate([np.full(len(g[0]), g[3]) for g in groups] + [np.array([3, 2, 2])])
        return (np.concatenate([ends[:n], bar_starts]), np.concatenate([ends[n:], bar_ends]),
                np.floor(rgba[:, :3] * 255), widths, _opacity(rgba[:, 3]))

    def _draw_goals(self, image: np.ndarray, clip: raster.Clip, window: tuple[float, float, float],
                    goal: np.ndarray, subgoals: np.ndarray, reached: int, hidden: np.ndarray | None) -> None:
        """The goal area and the sub-goals (reached ones green)."""
        r0, r1, c0, c1 = clip
        cx, cy, view_h = window
        w, h = c1 - c0, r1 - r0
        view_w, px, a = view_h * w / h, view_h / h, self.arena
        visible = np.all(np.abs(subgoals - (cx, cy)) < np.array([view_w, view_h]) / 2 + a.goal_radius, axis=1)
        for i in np.flatnonzero(visible):
            if not np.allclose(subgoals[i], goal):
                rgba = REACHED_RGBA if i < reached else SUBGOAL_RGBA
                raster.fill_disc(image, self._to_pixels(subgoals[i], window, clip)[0], a.goal_radius / px,
                                 _fill(rgba, 0.8), clip, hidden, _opacity(rgba[3]))
        if np.all(np.isfinite(goal)):
            centre = self._to_pixels(goal, window, clip)[0]
            raster.fill_disc(image, centre, a.goal_radius / px, _fill(GOAL_RGBA, 0.8), clip, hidden,
                             _opacity(GOAL_RGBA[3]))
            raster.fill_disc(image, centre, max(1.5 * px, 0.5) / px, _fill(GOAL_RGBA, 0.8), clip, hidden)

    def _moving_plan(self, view: View, window: tuple[float, float, float], clip: raster.Clip, state: Snapshot,
                     trail: np.ndarray, snap: bool) -> dict[str, np.ndarray]:
        """Where what moves lands in pixels: trail and beam segments, beam-hit squares, the marker and the
        movers. With `snap`, points sit on pixel centres, so that an unchanged plan draws the same pixels
        (the overview repaints only when its plan changes)."""
        follow = view.kind == "follow"
        points = np.concatenate([trail.reshape(-1, 2), state.pose[None, :2]])
        trail_a, trail_b = _in_view(points, window, (clip[3] - clip[2]) / (clip[1] - clip[0]))
        d = self.data
        origin = d.site_xpos[self._sonar_sites, :2]
        heading = d.site_xmat[self._sonar_sites].reshape(-1, 3, 3)[:, :2, 2]
        distance = np.asarray(state.sonar, float)
        echo = distance < SONAR_RANGE - 1e-6
        n = len(trail_a)
        ends = self._to_pixels(np.concatenate([trail_a, trail_b, origin, origin + heading * distance[:, None]]),
                               window, clip)
        if snap:
            ends = np.floor(ends) + 0.5
        starts, ends = np.concatenate([ends[:n], ends[2 * n:2 * n + 9]]), np.concatenate([ends[n:2 * n], ends[-9:]])
        if snap and n:  # a trail that stays within a pixel adds nothing to draw (or to the plan)
            moved = np.any(starts[:n] != ends[:n], axis=1)
            moved[-1] = True
            keep = np.concatenate([moved, np.ones(9, bool)])
            starts, ends, n = starts[keep], ends[keep], int(moved.sum())
        beams = _range_colours(distance)
        beams[~echo] = NO_ECHO_RGBA
        colours = np.concatenate([np.broadcast_to(np.floor(np.asarray(TRAIL_RGBA[:3]) * 255), (n, 3)),
                                  np.floor(beams[:, :3] * 255)])
        alphas = np.concatenate([np.ones(n), _opacity(beams[:, 3])])
        widths = np.concatenate([np.full(n, 2), np.where(echo, 2 if follow else 1, 1)])
        length = max(MARKER_LENGTH * window[2], 1.4) * (clip[1] - clip[0]) / window[2]
        marker = np.array([*np.round(self._to_pixels(state.pose[:2], window, clip)[0]), round(length, 1),
                           round(math.degrees(state.pose[2]) * 2) % 720])
        plan = {"starts": starts, "ends": ends, "colours": colours, "alphas": alphas, "widths": widths,
                "squares": ends[-9:][echo], "square_colours": np.floor(np.minimum(beams[echo, :3] * 1.5, 1.0) * 255),
                "marker": marker}
        if snap and self._mover_geoms:
            movers = np.concatenate(self._mover_geoms)
            plan["movers"] = np.concatenate([np.round(self._to_pixels(d.geom_xpos[movers, :2], window, clip), 1),
                                             np.round(d.geom_xmat[movers][:, [0, 3]], 2)], axis=1)
        return plan

    def _draw_plan(self, image: np.ndarray, clip: raster.Clip, window: tuple[float, float, float], plan: dict,
                   hidden: np.ndarray | None, static: tuple[np.ndarray, ...] | None = None,
                   goals: tuple | None = None) -> None:
        """Draws a `_moving_plan` over `static` (`_static_lines` still to draw), the `goals` (goal, sub-goals,
        reached) over the lines as MuJoCo blends its translucent discs over them, then the movers
        (when the plan has them: where OpenGL did not draw them) and the vehicle marker."""
        starts, ends, colours, alphas, widths = (plan[k] for k in ("starts", "ends", "colours", "alphas", "widths"))
        if static is not None:
            starts, ends = np.concatenate([static[0], starts]), np.concatenate([static[1], ends])
            colours, widths = np.concatenate([static[2], colours]), np.concatenate([static[3], widths])
            alphas = np.concatenate([static[4], alphas])
        raster.lines(image, starts, ends, colours, widths, alphas, clip, hidden)
        if goals is not None:
            self._draw_goals(image, clip, window, *goals, hidden)
        raster.fill_squares(image, plan["squares"], 5, plan["square_colours"], clip, hidden)
        if "movers" in plan:
            for geoms, colour in zip(self._mover_geoms, self._mover_colours, strict=True):
                for g in geoms:
                    self._fill_geom(image, clip, g, window, colour)
        # The vehicle: a dart pointing along its heading, MARKER_LENGTH of the view tall.
        col, row, length, half_degrees = plan["marker"]
        mask, r, c = self._dart(float(length), math.radians(half_degrees / 2))
        raster.stamp(image, mask, r + int(row), c + int(col), self._marker_colour, clip, hidden)

    def _dart(self, length: float, heading: float) -> tuple[np.ndarray, int, int]:
        """The vehicle marker `length` pixels long pointing along `heading`, as a mask around (0, 0), cached
        by length and heading (to 0.5 degrees)."""
        key = (round(length, 1), round(math.degrees(heading) * 2) % 720)
        dart = self._darts.get(key)
        if dart is None:
            psi = math.radians(key[1] / 2)
            fwd, left = np.array([math.cos(psi), -math.sin(psi)]), np.array([-math.sin(psi), -math.cos(psi)])
            tip, notch = 0.6 * length * fwd, -0.2 * length * fwd
            port, starboard = -0.4 * length * fwd + 0.35 * length * left, -0.4 * length * fwd - 0.35 * length * left
            (m1, r1, c1), (m2, r2, c2) = raster.polygon_mask([tip, port, notch]), raster.polygon_mask(
                [tip, notch, starboard])
            r0, c0 = min(r1, r2), min(c1, c2)
            mask = np.zeros((max(r1 + m1.shape[0], r2 + m2.shape[0]) - r0,
                             max(c1 + m1.shape[1], c2 + m2.shape[1]) - c0), bool)
            mask[r1 - r0:r1 - r0 + m1.shape[0], c1 - c0:c1 - c0 + m1.shape[1]] |= m1
            mask[r2 - r0:r2 - r0 + m2.shape[0], c2 - c0:c2 - c0 + m2.shape[1]] |= m2
            if len(self._darts) > 8192:
                self._darts.clear()
            dart = self._darts[key] = (mask, r0, c0)
        return dart

    def _fill_geom(self, image: np.ndarray, clip: raster.Clip, geom: int, window: tuple[float, float, float],
                   colour) -> None:
        """A model geom's footprint seen from above, in one colour (moving obstacles in the overview)."""
        m, d = self.model, self.data
        centre, size = d.geom_xpos[geom, :2], m.geom_size[geom]
        if m.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX:
            axes = d.geom_xmat[geom].reshape(3, 3)[:2, :2] * size[:2]
            corners = centre + np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) @ axes.T
            raster.fill_polygon(image, self._to_pixels(corners, window, clip), colour, clip)
        else:
            raster.fill_disc(image, self._to_pixels(centre, window, clip)[0],
                             size[0] * (clip[1] - clip[0]) / window[2], colour, clip)

    def _labels(self, image: np.ndarray, view: View, window: tuple[float, float, float]) -> None:
        """The scale bar's length under it, and the overview's height, at the corners of `view` in the
        frame `image` (a label wider than the inset spills over its edge, as with mjr_overlay)."""
        if self.height < OVERLAY_MIN_HEIGHT:
            return
        _, _, w, h = view.rect
        bar = scale_bar_length(window[2] * w / h)
        self._font.overlay(image, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT, view.rect, f"{bar:g} m")
        if view.kind == "overview":
            self._font.overlay(image, mujoco.mjtGridPos.mjGRID_BOTTOMRIGHT, view.rect,
                               f"overview, {window[2]:.0f} m tall")

    def _key_entries(self) -> tuple[list[tuple[np.ndarray, int]], tuple[str, ...]]:
        """The lines the key explains, as ((colour [0-255] as drawn over water, width [px]) per line, labels):
        the sonar echo (its colour ramp), then the beams without an echo, the map bounds, the global path, the
        trail and the moving obstacles' paths, each where the arena has it."""
        water = self._water_image[0, 0].astype(float)

        def drawn(rgba) -> np.ndarray:
            alpha = float(_opacity(rgba[3]))
            return np.floor(water * (1.0 - alpha) + _line(rgba) * alpha + 0.5)

        a = self.arena
        entries = [(None, 0, "sonar echo"), (drawn(NO_ECHO_RGBA), 1, "no echo")]
        if np.all(np.isfinite(a.bounds)):
            entries.append((drawn(BOUNDS_RGBA), 2, "map bounds"))
        if len(a.path) > 1:
            entries.append((drawn(PATH_RGBA), 2, "global path"))
        entries.append((drawn(TRAIL_RGBA), 2, "trail"))
        if len(a.mover_names):
            entries.append((drawn(MOVER_PATH_RGBA), 1, "obstacle path"))
        return [(c, w) for c, w, _ in entries[1:]], tuple(label for _, _, label in entries)

    def _key_patch(self) -> tuple[np.ndarray, np.ndarray]:
        """The key as (pixels (h, w, 3), mask of the lit ones (h, w)), drawn once: on its first row the sonar's
        range colours from 0 m (red) to SONAR_RANGE (green) as a ramp, below it a swatch and a name per line, two
        to a row."""
        font, pad = self._font, raster.OVERLAY_PAD
        lines, labels = self._key_entries()
        char = max(int(font.widths[ord("0")]), 1)
        ramp_w, swatch_w = KEY_RAMP_CHARS * char, KEY_SWATCH_CHARS * char
        first = [font.mask("sonar echo 0 m "), None, font.mask(f" {SONAR_RANGE:g} m")]
        items = [(colour, width, font.mask(" " + label)) for (colour, width), label in zip(lines, labels[1:],
                                                                                             strict=True)]
        cell = max(swatch_w + m.shape[1] for _, _, m in items) + 2 * char
        inner = max(first[0].shape[1] + ramp_w + first[2].shape[1], 2 * cell)
        rows = 1 + math.ceil(len(items) / 2)
        pitch = font.height + pad
        pixels = np.zeros((pad + rows * pitch, inner + 2 * pad, 3), np.uint8)
        mask = np.zeros(pixels.shape[:2], bool)

        def text(glyphs: np.ndarray, row: int, col: int) -> None:
            mask[row:row + glyphs.shape[0], col:col + glyphs.shape[1]] |= glyphs
            pixels[row:row + glyphs.shape[0], col:col + glyphs.shape[1]][glyphs] = 255

        def bar(colours: np.ndarray, row: int, col: int, thickness: int) -> None:
            top = row + font.height // 2 - thickness // 2
            pixels[top:top + thickness, col:col + len(colours)] = colours
            mask[top:top + thickness, col:col + len(colours)] = True

        col = pad
        text(first[0], pad, col)
        col += first[0].shape[1]
        ramp = np.floor(_range_colours(np.linspace(0.0, SONAR_RANGE, ramp_w))[:, :3] * 255)
        bar(ramp, pad, col, max(font.height // 3, 3))
        text(first[2], pad, col + ramp_w)
        for k, (colour, width, glyphs) in enumerate(items):
            row, col = pad + (1 + k // 2) * pitch, pad + (k % 2) * cell
            bar(np.broadcast_to(colour, (swatch_w, 3)), row, col, max(width, 1) + (font.height > 20))
            text(glyphs, row, col + swatch_w)
        return pixels, mask

    @property
    def key_rect(self) -> tuple[int, int, int, int] | None:
        """(top row, left column, height, width) [px] of the key in a frame (None below OVERLAY_MIN_HEIGHT): the
        bottom right corner, above the overview's label when the overview fills the frame."""
        if self._key is None:
            return None
        h, w = self._key[1].shape
        pad = raster.OVERLAY_PAD
        lifted = any(view.kind == "overview" and not view.inset for view in self.views)
        bottom = pad + (self._font.height + 3 * pad if lifted else 0)
        return self.height - bottom - h, self.width - pad - w, h, w

    def _draw_key(self, image: np.ndarray) -> None:
        """The key on a half-black box, as the text overlay is drawn."""
        top, left, h, w = self.key_rect
        if top < 0 or left < 0:  # a frame too small for it
            return
        pixels, mask = self._key
        region = image[top:top + h, left:left + w]
        raster.darken(region, 0.5)
        region[mask] = pixels[mask]

    def _overview_layer(self, view: View, window: tuple[float, float, float], goal: np.ndarray,
                        subgoals: np.ndarray, reached: int) -> tuple[np.ndarray, np.ndarray | None]:
        """The overview without what moves (vehicle, trail, beams, movers), framed by its border when it is
        an inset, and its pixels of tall geoms (or None); drawn again only when the window or goals change."""
        key = (window, tuple(np.round(goal, 9)), subgoals.tobytes(), min(reached, len(subgoals)))
        if self._layer_key == key:
            return self._layer
        _, _, w, h = view.rect
        border = INSET_BORDER if view.inset else 0
        layer = np.full((h + 2 * border, w + 2 * border, 3), 230, np.uint8)  # 0.9 grey, as mjr_rectangle
        hidden = np.zeros(layer.shape[:2], bool)
        clip = (border, border + h, border, border + w)
        qpos, mocap = self.data.qpos.copy(), self.data.mocap_pos.copy()
        try:
            # Movers in place first, to find the colour OpenGL gives them from this far away.
            self.data.qpos[self._qpos[:2]] = 1e7
            mujoco.mj_kinematics(self.model, self.data)
            probe = layer.copy()
            self._draw_geoms(probe, clip, window, self._mover_mask, hidden)
            self._mover_colours = []
            for geoms in self._mover_geoms:
                c, r = self._to_pixels(self.data.geom_xpos[geoms[0], :2], window, clip)[0].astype(int)
                inside = border <= r < border + h and border <= c < border + w
                self._mover_colours.append(probe[r, c].copy() if inside else _fill(self.model.geom_rgba[
                    geoms[0]], 0.0))
            self.data.mocap_pos[self._movers] = 1e7
            mujoco.mj_kinematics(self.model, self.data)
            tall = self._draw_geoms(layer, clip, window, self._static_mask, hidden)
        finally:
            self.data.qpos[:], self.data.mocap_pos[:] = qpos, mocap
            mujoco.mj_kinematics(self.model, self.data)
        self._draw_goals(layer, clip, window, goal, subgoals, reached, hidden)
        starts, ends, colours, widths, alphas = self._static_lines(window, clip)
        raster.lines(layer, starts, ends, colours, widths, alphas, clip, hidden)
        self._layer, self._layer_key = (layer, hidden if tall else None), key
        return self._layer

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
        subgoals = np.zeros((0, 2)) if subgoals is None else np.asarray(subgoals, float).reshape(-1, 2)
        if out is None:
            out = np.empty((self.height, self.width, 3), np.uint8)
        self._gl.make_current()
        self.set_state(state)
        goal = state.desired_goal if np.all(np.isfinite(state.desired_goal)) else self.arena.goal
        for view in self.views:
            window = self._view_window(view, state, trail)
            left, bottom, w, h = view.rect
            top = self.height - bottom - h
            clip = (top, top + h, left, left + w)
            if view.kind == "follow":
                tall = self._follow_geoms(out, clip, window)
                hidden = self._hidden if tall else None
                plan = self._moving_plan(view, window, clip, state, trail, snap=False)
                self._draw_plan(out, clip, window, plan, hidden, self._static_lines(window, clip),
                                (goal, subgoals, reached))
            else:
                self._draw_overview(out, clip, view, window, state, trail, goal, subgoals, reached)
            self._labels(out, view, window)
        if self.height >= OVERLAY_MIN_HEIGHT:
            self._draw_key(out)
            self._overlay(out, state, event, reached, len(subgoals))
        return out

    def _draw_overview(self, out: np.ndarray, clip: raster.Clip, view: View, window: tuple[float, float, float],
                       state: Snapshot, trail: np.ndarray, goal: np.ndarray, subgoals: np.ndarray,
                       reached: int) -> None:
        """The overview: its cached arena layer with what moves drawn over it, or, when nothing moved by a
        pixel, the last overview again."""
        top, bottom, left, right = clip
        layer, layer_hidden = self._overview_layer(view, window, goal, subgoals, reached)
        b = (layer.shape[0] - (bottom - top)) // 2
        region = (slice(top - b, bottom + b), slice(left - b, right + b))
        plan = self._moving_plan(view, window, clip, state, trail, snap=True)
        key = (self._layer_key, tuple(v.tobytes() for v in plan.values()))
        if key == self._inset_key:
            out[region] = self._inset_pixels
            return
        out[region] = layer
        hidden = None
        if layer_hidden is not None:
            self._hidden[region] = layer_hidden
            hidden = self._hidden
        self._draw_plan(out, clip, window, plan, hidden)
        self._inset_key, self._inset_pixels = key, out[region].copy()

    def _overlay(self, image: np.ndarray, state: Snapshot, event: str, reached: int, goals: int) -> None:
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
        self._font.overlay(image, mujoco.mjtGridPos.mjGRID_TOPLEFT, (0, 0, self.width, self.height),
                           "\n".join(labels), "\n".join(values))
        if event and event not in QUIET_EVENTS:
            self._banner(image, event.upper().replace("_", " "), EVENT_COLOURS.get(event, (1.0, 1.0, 1.0)))

    def _banner(self, image: np.ndarray, text: str, colour: tuple[float, float, float]) -> None:
        """`text` in the big font, centred near the bottom of the frame on a dark box."""
        raster.banner(image, self._font_big, text, colour, self.width // 2, self.height // 12)


def render_frame(physics, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], camera: str = "both",
                 follow_view: float = FOLLOW_VIEW, task=None) -> np.ndarray:
    """One (H, W, 3) uint8 picture of the current state of an AUVPhysics (a fresh context; for notebooks)."""
    state = Snapshot(time=float(physics.time()), pose=physics.pose(), velocity=physics.body_velocity(),
                     sonar=physics.sonar(), control=physics.data.ctrl.copy(), desired_goal=np.full(2, np.nan),
                     movers=np.zeros((0, 2)))
    with FrameRenderer(physics, width, height, camera, follow_view, task=task) as renderer:
        state.movers = mover_positions(physics, renderer.arena.mover_names)
        return renderer.render(state)
