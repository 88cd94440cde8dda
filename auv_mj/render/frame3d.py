"""One frame of a 6-DOF episode: a chase view beside top-down and side views, with a heads-up display.

This module holds the drawing of a single instant: the frame's layout (`Layout`), the state a frame shows
(`State3D`) and `FrameRenderer3D`, which draws it. Episodes (timing, interpolation, the 3-D track) are
`auv_mj.render.episode_video3d`.

A frame (DEFAULT_SIZE, 1280 x 720) holds three labelled panels drawn by MuJoCo from one off-screen buffer: the
chase camera of the vehicle MJCF (`models/auv6.xml`, two thirds of the frame), a top-down view (north up, as the
planar videos) and a side view from the vehicle's starboard, both centred on the vehicle. Every panel shows the
sonar fan (its 27 beams from the bow to their echoes, coloured by range; beams without an echo faint and cut at
FAN_DRAWN), the tube's or arena's geoms, the movers where they are, and the goal. On top, in numpy
(`auv_mj.render.raster`, MuJoCo's bitmap fonts), a heads-up display (time, depth, altitude, speed, pitch, heading,
the goal's distance), a banner at each event (goal, collision, ...) and a progress bar along the bottom (distance
made good towards the goal, or the time of a tracking episode).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from auv_mj.render import glbackend, raster
from auv_mj.render.frame import DEFAULT_SIZE, EVENT_COLOURS, WATER_RGBA, GLOwner, gl_context_class
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, fan_directions
from auv_mj.sim.sonar import SONAR_RANGE

CHASE_CAMERA = "chase"
"""The vehicle MJCF's camera behind and above the hull."""
TOP_DISTANCE = 40.0
"""Height of the top-down view's camera above the vehicle [m]."""
SIDE_DISTANCE = 30.0
"""Distance of the side view's camera from the vehicle [m]."""
VIEW_PER_RADIUS = 5.0
"""In a wide tube the top and side cameras stand back this many tube radii (at least TOP_DISTANCE and
SIDE_DISTANCE), so that the views hold the tube across."""
CHASE_SHARE = 2.0 / 3.0
"""Share of the frame's width the chase view takes; the top and side views share the rest, one above the other."""
PROGRESS_SHARE = 1.0 / 45.0
"""Height of the progress bar as a share of the frame's (16 px at 720p)."""
MIN_HUD_HEIGHT = 240
"""Below this frame height [px] the text is left out: MuJoCo's smallest font would cover the views."""
MESH_SLICES, MESH_STACKS = 10, 4
"""Capsule tessellation of the views (MuJoCo's defaults are 28 and 16): a tube holds thousands of staves, and the
renderer is often a CPU one."""
FAN_DRAWN = 20.0
"""Beams without an echo are drawn this long [m], faint: at full range they would cross the whole view."""
FAN_WIDTH = 2.0
"""Width of a beam [px]."""
COLOUR_RANGE = 30.0
"""Beams are coloured from red at zero range to green at this range [m] and beyond: the open-water protection
domain's reach (Sec. 3.2.2); a tube's wall is always nearer, so its echoes run from red to yellow."""
NEAR_RGBA, FAR_RGBA = np.array([1.0, 0.15, 0.1, 0.9]), np.array([0.2, 1.0, 0.4, 0.9])
"""A beam's colour at zero range and at COLOUR_RANGE (linear between)."""
NO_ECHO_RGBA = np.array([0.6, 0.85, 0.6, 0.25])
CHASE_RANGE = 40.0
"""The chase view draws the arena's geoms within this distance [m] of its camera, plus two tube radii in a tube
(a tube holds thousands of staves)."""
EXTRA_GEOMS = 64
"""Room in the scene beyond the model and the fan."""
WATER_RGB = np.floor(np.asarray(WATER_RGBA[:3]) * 255).astype(np.uint8)
"""The water behind the geoms, as in the planar videos (OpenGL clears to black; no lit geom is exactly black)."""
BAR_RGB, BAR_BACK_RGB = (60, 200, 255), (25, 35, 45)
LABEL_RGB = (255, 255, 255)
SCALES = ((200, 50), (420, 100), (800, 150), (1200, 200))
"""(frame height [px], MuJoCo font scale [%]) up to which each scale is used; taller frames get 250 %."""
PANELS = ("chase", "top", "side")


@dataclass(frozen=True)
class Layout:
    """The panels' viewports (left, bottom, width, height) [px, OpenGL: rows counted from the bottom]."""

    width: int
    height: int
    bar: int
    panels: dict

    @classmethod
    def of(cls, width: int, height: int) -> Layout:
        bar = max(2, round(PROGRESS_SHARE * height))
        chase_w = round(CHASE_SHARE * width)
        rest = height - bar
        lower = rest // 2
        return cls(width, height, bar, {"chase": (0, bar, chase_w, rest),
                                        "top": (chase_w, bar + lower, width - chase_w, rest - lower),
                                        "side": (chase_w, bar, width - chase_w, lower)})


@dataclass
class State3D:
    """The state a frame shows: what the physics held at an instant, and the step's information."""

    time: float
    qpos: np.ndarray
    mocap_pos: np.ndarray
    sonar: np.ndarray
    """The 27 fan ranges [m] (`auv_mj.sim.sensors3d` order)."""
    velocity: np.ndarray
    """nu (u, v, w, p, q, r) [m/s, rad/s]."""
    altitude: float
    goal_distance: float
    progress: float
    """Share of the episode done, in [0, 1]."""
    event: str = ""


def _quaternion_slots(model: mujoco.MjModel) -> list[int]:
    """qpos addresses of the free and ball joints' quaternions."""
    slots = []
    for j in range(model.njnt):
        kind, adr = model.jnt_type[j], model.jnt_qposadr[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            slots.append(adr + 3)
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            slots.append(adr)
    return slots


def _range_colours(ranges: np.ndarray) -> np.ndarray:
    share = np.clip(ranges / COLOUR_RANGE, 0.0, 1.0)[:, None]
    colours = NEAR_RGBA + share * (FAR_RGBA - NEAR_RGBA)
    colours[ranges >= SONAR_RANGE] = NO_ECHO_RGBA
    return colours


class FrameRenderer3D(GLOwner):
    """Draws `State3D`s of a 6-DOF physics into (H, W, 3) uint8 frames (module docstring); a copy of the model
    is posed for each frame, so the environment's own data is never touched."""

    def __init__(self, physics, width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], title: str = ""):
        if width < 32 or height < 32:
            raise ValueError(f"frame size must be at least 32 x 32 pixels, got {width} x {height}")
        glbackend.require()
        self.width, self.height = int(width) // 2 * 2, int(height) // 2 * 2  # even, for yuv420p
        self.layout = Layout.of(self.width, self.height)
        self.title = title
        self.model = copy.copy(physics.model.ptr)
        vis = self.model.vis
        vis.global_.offwidth = max(vis.global_.offwidth, self.width)
        vis.global_.offheight = max(vis.global_.offheight, self.height)
        vis.quality.offsamples = 0
        vis.quality.numslices, vis.quality.numstacks = MESH_SLICES, MESH_STACKS
        self.data = mujoco.MjData(self.model)
        self.data.qpos[:] = physics.data.qpos
        mujoco.mj_kinematics(self.model, self.data)
        self._quaternions = _quaternion_slots(self.model)
        self._cull_setup()
        self._sonar = self.model.site("sonar").id
        self._fan = fan_directions()
        try:
            self._gl = gl_context_class()(self.width, self.height)
            self._gl.make_current()
        except glbackend.RenderingUnavailable:
            raise
        except Exception as e:  # each backend raises its own error type
            raise glbackend.RenderingUnavailable(
                f"cannot create an OpenGL context with MUJOCO_GL={glbackend.backend}: {e}; "
                f"{glbackend.install_hint()}, or set MUJOCO_GL to one of: {glbackend.VALID_VALUES}") from None
        scale = next((s for limit, s in SCALES if self.height <= limit), 250)
        self._context = mujoco.MjrContext(self.model, getattr(mujoco.mjtFontScale, f"mjFONTSCALE_{scale}"))
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self.scene = mujoco.MjvScene(self.model, self.model.ngeom + self.model.nsite + len(self._fan) + EXTRA_GEOMS)
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
            self.scene.flags[flag] = 0  # a CPU rasteriser pays for each pass
        self.option = mujoco.MjvOption()
        self.option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = 0
        self.cameras = {"chase": mujoco.MjvCamera(), "top": mujoco.MjvCamera(), "side": mujoco.MjvCamera()}
        self.cameras["chase"].type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.cameras["chase"].fixedcamid = self.model.camera(CHASE_CAMERA).id
        tube = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_NUMERIC, "tube_radius")
        reach = VIEW_PER_RADIUS * float(self.model.numeric_data[self.model.numeric_adr[tube]]) if tube >= 0 else 0.0
        self._distance = {"top": max(TOP_DISTANCE, reach), "side": max(SIDE_DISTANCE, reach),
                          "chase": CHASE_RANGE + 2.0 * reach / VIEW_PER_RADIUS}
        for name, elevation in (("top", -90.0), ("side", 0.0)):
            camera = self.cameras[name]
            camera.type = mujoco.mjtCamera.mjCAMERA_FREE
            camera.distance, camera.elevation = self._distance[name], elevation
        self._pixels = np.empty((self.height, self.width, 3), np.uint8)
        self._hud = self.height >= MIN_HUD_HEIGHT
        if self._hud:
            self._font = raster.BitmapFont(self._context, mujoco.mjtFont.mjFONT_NORMAL, self.width, self.height)
            self._font_big = raster.BitmapFont(self._context, mujoco.mjtFont.mjFONT_BIG, self.width, self.height)

    def _cull_setup(self) -> None:
        """The arena's static geoms (not planes) and where they are: each view draws only those it can see, and
        the top and side views cut away the half of a tube's wall between them and the vehicle."""
        m = self.model
        static = (m.geom_bodyid == 0) & (m.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
        self._static = np.flatnonzero(static)
        self._alpha = m.geom_rgba[self._static, 3].copy()
        self._centres = self.data.geom_xpos[self._static].copy()
        self._radii = m.geom_rbound[self._static].copy()
        self._wall = np.array([m.geom(int(g)).name.startswith("wall") for g in self._static], dtype=bool)

    def _window(self, name: str, distance: float) -> tuple[float, float]:
        """Half width and half height [m] of a free camera's view at the vehicle, `distance` away."""
        _, _, w, h = self.layout.panels[name]
        half_h = distance * math.tan(math.radians(0.5 * self.model.vis.global_.fovy))
        return half_h * w / max(h, 1), half_h

    def _cull(self, name: str, position: np.ndarray, forward: np.ndarray) -> None:
        """Shows only the static geoms panel `name` can see (the others get alpha 0: MuJoCo leaves them out)."""
        offset = self._centres - position
        r = self._radii
        if name == "chase":
            camera = self.data.cam_xpos[self.cameras["chase"].fixedcamid]
            ahead = (self._centres - camera) @ forward
            visible = (np.linalg.norm(self._centres - camera, axis=1) < self._distance["chase"] + r) & (ahead > -r)
        elif name == "top":
            half_w, half_h = self._window(name, self._distance[name])
            visible = (np.abs(offset[:, 0]) < half_w + r) & (np.abs(offset[:, 1]) < half_h + r)
            visible &= ~(self._wall & (offset[:, 2] > 0.0))  # the wall above the vehicle is cut away
        else:
            half_w, half_h = self._window(name, self._distance[name])
            across = np.array([-forward[1], forward[0], 0.0]) / max(float(np.hypot(*forward[:2])), 1e-9)
            along = np.array([across[1], -across[0], 0.0])
            visible = (np.abs(offset @ along) < half_w + r) & (np.abs(offset[:, 2]) < half_h + r)
            visible &= ~(self._wall & (offset @ across < 0.0))  # the starboard wall, facing the camera, cut away
        self.model.geom_rgba[self._static, 3] = np.where(visible, self._alpha, 0.0)

    def _pose(self, state: State3D) -> None:
        self.data.qpos[:] = state.qpos
        for slot in self._quaternions:
            q = self.data.qpos[slot:slot + 4]
            q /= max(float(np.linalg.norm(q)), 1e-12)
        if self.model.nmocap:
            self.data.mocap_pos[:] = state.mocap_pos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def _add_fan(self, ranges: np.ndarray) -> None:
        """The fan's beams as line geoms of the scene, from the sonar site to each echo."""
        origin = self.data.site_xpos[self._sonar]
        directions = self._fan @ self.data.site_xmat[self._sonar].reshape(3, 3).T
        shown = np.where(ranges >= SONAR_RANGE, FAN_DRAWN, ranges)
        colours = _range_colours(ranges)
        scene = self.scene
        for direction, length, rgba in zip(directions, shown, colours, strict=True):
            if scene.ngeom >= scene.maxgeom:
                return
            geom = scene.geoms[scene.ngeom]
            mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.eye(3).ravel(),
                                rgba.astype(np.float32))
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_LINE, FAN_WIDTH, origin, origin + length * direction)
            scene.ngeom += 1

    def render(self, state: State3D, event: str = "") -> np.ndarray:
        """One frame of `state`, with `event` (if any) as a banner."""
        self._gl.make_current()
        self._pose(state)
        position = state.qpos[:3]
        heading = math.degrees(math.atan2(*self._heading_vector()[::-1]))
        self.cameras["top"].lookat[:] = position
        self.cameras["top"].azimuth = 90.0  # north (+y) up, +x right, as the planar videos
        self.cameras["side"].lookat[:] = position
        self.cameras["side"].azimuth = heading + 90.0  # from starboard, looking to port: the bow to the right
        forward = self.data.xmat[self.model.site_bodyid[self._sonar]].reshape(3, 3)[:, 0]
        for name in PANELS:
            self._cull(name, position, forward)
            mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.cameras[name],
                                   mujoco.mjtCatBit.mjCAT_ALL, self.scene)
            self._add_fan(state.sonar)
            mujoco.mjr_render(mujoco.MjrRect(*self.layout.panels[name]), self.scene, self._context)
        mujoco.mjr_readPixels(self._pixels, None, mujoco.MjrRect(0, 0, self.width, self.height), self._context)
        frame = self._pixels[::-1].copy()
        frame[~frame.any(axis=-1)] = WATER_RGB
        self._borders(frame)
        self._progress(frame, state.progress)
        if self._hud:
            self._labels(frame)
            self._overlay(frame, state)
            if event:
                self._banner(frame, event.upper().replace("_", " "), EVENT_COLOURS.get(event, (1.0, 1.0, 1.0)))
        return frame

    def _heading_vector(self) -> np.ndarray:
        body = self.model.site_bodyid[self._sonar]
        return self.data.xmat[body].reshape(3, 3)[:2, 0]

    def _borders(self, frame: np.ndarray) -> None:
        """A dark line between the panels."""
        chase_w = self.layout.panels["chase"][2]
        top = self.layout.panels["top"]
        frame[:self.height - self.layout.bar, chase_w - 1:chase_w + 1] = 0
        row = self.height - top[1]
        frame[row - 1:row + 1, chase_w:] = 0

    def _progress(self, frame: np.ndarray, share: float) -> None:
        """The progress bar along the bottom of the frame."""
        bar = frame[self.height - self.layout.bar:]
        bar[:] = BAR_BACK_RGB
        bar[1:-1, :int(round(float(np.clip(share, 0.0, 1.0)) * self.width))] = BAR_RGB

    def _labels(self, frame: np.ndarray) -> None:
        names = {"chase": "chase", "top": "top (north up)", "side": "side (from starboard)"}
        for name, rect in self.layout.panels.items():
            self._font.overlay(frame, mujoco.mjtGridPos.mjGRID_TOPRIGHT, rect, names[name])

    def _overlay(self, frame: np.ndarray, state: State3D) -> None:
        u, v, w = state.velocity[:3]
        rotation = self.data.xmat[self.model.site_bodyid[self._sonar]].reshape(3, 3)
        pitch = math.degrees(math.asin(float(np.clip(rotation[2, 0], -1.0, 1.0))))
        heading = math.degrees(math.atan2(rotation[1, 0], rotation[0, 0]))
        labels = ["time", "depth", "altitude", "speed", "pitch", "heading", "goal", "progress"]
        values = [f"{state.time:7.1f} s", f"{-state.qpos[2]:6.1f} m",
                  f"{state.altitude:6.1f} m" if state.altitude < ALTIMETER_RANGE else f"  > {ALTIMETER_RANGE:g} m",
                  f"{math.sqrt(u * u + v * v + w * w):5.2f} m/s", f"{pitch:+6.1f} deg", f"{heading:+7.1f} deg",
                  f"{state.goal_distance:6.1f} m away" if math.isfinite(state.goal_distance) else "  -",
                  f"{100 * state.progress:5.1f} %"]
        if self.title:
            labels.insert(0, "task")
            values.insert(0, self.title)
        self._font.overlay(frame, mujoco.mjtGridPos.mjGRID_TOPLEFT, self.layout.panels["chase"], "\n".join(labels),
                           "\n".join(values))

    def _banner(self, frame: np.ndarray, text: str, colour: tuple[float, float, float]) -> None:
        """`text` in the big font on a dark box, centred near the bottom of the chase panel."""
        left, bottom, width, height = self.layout.panels["chase"]
        raster.banner(frame, self._font_big, text, colour, left + width // 2, bottom + height // 10)
