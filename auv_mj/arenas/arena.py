"""Arenas: MJCF files of walls, obstacles and path sites, composed with the vehicle into one model.

The arena convention (what a task reads; see docs/arenas.md):
- static geoms in `<worldbody>` are walls and obstacles; the sonar sees every geom but the vehicle's;
  names start with `wall` (tunnel walls, map boundary), `obstacle` (anything else in the water), or
  `unknown` (an obstacle the global path does not know of, Table 12's unknown obstacle: the path may
  run through it, but it must leave a way past; `auv-mj check-arena` checks both);
- sites `start` (its z-euler is the initial heading) and `goal`;
- sites `path_0`, `path_1`, ... : the global path, in order (the tunnel's central axis);
- mocap bodies `mover_*` are moving obstacles; `<numeric name="mover_<name>" data="x0 y0 x1 y1 speed"/>`
  moves the body from (x0, y0) to (x1, y1) at `speed` m/s, then back (ping-pong); more waypoints,
  `data="x0 y0 x1 y1 ... xn yn speed"` (up to MAX_MOVER_WAYPOINTS), take it along that polyline and back;
- `<numeric name="arena_bounds" data="xmin ymin xmax ymax"/>` is the map: leaving it ends an episode.
Names of the vehicle model (`auv`, `hull`, `x`, `sonar_*`, ...) may not be reused.
"""

from __future__ import annotations

import copy
import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from auv_mj import inputs
from auv_mj.assets import model_path
from auv_mj.sim.ocean import lag_actuators
from auv_mj.sim.physics import AUVPhysics

SAFETY_DISTANCE = 5.0
"""d_s: the minimum distance between the vehicle and any obstacle or wall [m] (Table 1, Eq. 24)."""
MERGED_SECTIONS = ("asset", "default", "worldbody", "custom", "contact")
PATH_SITE_PREFIX = "path_"
MOVER_PREFIX = "mover_"
MAX_EXTENT = 100_000.0
"""Largest |coordinate| and size [m] anything in an arena may have (100 km; the paper's maps are 600 m)."""
MAX_MOVER_SPEED = 10.0
"""Fastest moving obstacle [m/s]: five times the vehicle's top commanded speed (Table 3)."""
MAX_MOVER_WAYPOINTS = 100
"""Most waypoints of one mover's path."""
ARENA_ELEMENTS = {
    "asset": {"texture", "material", "mesh", "hfield"},
    "default": {"default", "geom", "site", "mesh", "material", "camera", "light"},
    "worldbody": {"body", "geom", "site", "camera", "light", "frame", "inertial"},
    "custom": {"numeric", "text", "tuple"},
    "contact": {"pair", "exclude"},
}
"""The elements each arena section may hold: static and mocap geometry, sites and looks. No joints (moving
obstacles are mocap bodies), no file references, no generators (replicate, composite, flexcomp)."""
MAX_GRID = 4096
"""Largest texture or height field side [cells]."""
MAX_MESH_VALUES = 30_000
"""Most numbers in an inline mesh's vertex or face list (10 000 vertices)."""
UNKNOWN_OBSTACLE_PREFIX = "unknown"
"""Static geoms named so are unknown obstacles: the global path may cross them."""


def _read_xml(source: str | Path | ET.Element, what: str) -> tuple[ET.Element, str]:
    """The root of an MJCF file or element and its name for messages, within the bounds of `auv_mj.inputs`."""
    if isinstance(source, ET.Element):
        name = f"<{what} element>"
        inputs.check_element(source, name, what)
        return source, name
    if not isinstance(source, (str, Path)):
        raise ValueError(f"{what} must be a file path or an ElementTree element, got {type(source).__name__}")
    return inputs.read_xml(source, what), inputs.source_name(source)


@functools.lru_cache(maxsize=1)
def vehicle_names() -> frozenset[str]:
    """Every name in the vehicle model (`models/auv.xml`: `auv`, `hull`, `x`, `sonar_1`, ...), which an arena and
    the obstacles and movers an author names may not reuse."""
    root = inputs.read_xml(model_path("auv.xml"), "vehicle")
    return frozenset(el.get("name") for el in root.iter() if el.get("name"))


def compose_xml(arena: str | Path | ET.Element | None = None,
                vehicle: str | Path | ET.Element | None = None, thruster_lag: bool = False) -> tuple[str, str]:
    """MJCF text of the vehicle with the arena's sections merged in, and a name for error messages.

    `thruster_lag` compiles the vehicle's actuators with their first-order lag (`auv_mj.sim.ocean`).
    """
    vroot, vname = _read_xml(vehicle if vehicle is not None else model_path("auv.xml"), "vehicle")
    vroot = copy.deepcopy(vroot)
    if thruster_lag:
        lag_actuators(vroot, vname)
    if arena is None:
        return ET.tostring(vroot, encoding="unicode"), vname
    aroot, aname = _read_xml(arena, "arena")
    if aroot.tag != "mujoco":
        raise ValueError(f"{aname}: an arena's root element must be <mujoco>, got <{aroot.tag}>")
    taken = {el.get("name") for el in vroot.iter() if el.get("name")}
    for el in aroot.iter():
        name = el.get("name")
        if name and name in taken and el.tag != "mujoco":
            raise ValueError(f"{aname}: <{el.tag} name=\"{name}\"> clashes with a name of the vehicle model")
    check_arena_elements(aroot, aname)
    for section in aroot:
        if section.tag not in MERGED_SECTIONS:
            raise ValueError(f"{aname}: arenas may only hold {MERGED_SECTIONS}, found <{section.tag}>")
        target = vroot.find(section.tag)
        if target is None:
            target = ET.SubElement(vroot, section.tag)
        for child in section:
            target.append(copy.deepcopy(child))
    return ET.tostring(vroot, encoding="unicode"), aname if vehicle is None else f"{aname} with vehicle {vname}"


def check_arena_elements(root: ET.Element, name: str) -> None:
    """Refuses (ValueError naming the arena and the element) what an arena may not hold: elements outside
    ARENA_ELEMENTS, joints, references to other files, and grids or meshes beyond MAX_GRID / MAX_MESH_VALUES,
    which MuJoCo would read or allocate before any other check could run."""
    for section in root:
        allowed = ARENA_ELEMENTS.get(section.tag)
        if allowed is None:
            continue  # refused by section in `compose_xml`
        stack = list(section)
        while stack:
            element = stack.pop()
            if element.tag not in allowed:
                hint = (": moving obstacles are mocap bodies" if element.tag in ("joint", "freejoint") else "")
                raise ValueError(f"{name}: <{element.tag}> may not appear in an arena's <{section.tag}>{hint}")
            files = [a for a in element.attrib if a.startswith("file")]
            if files:
                raise ValueError(f"{name}: <{element.tag} {files[0]}=...>: an arena may not read other files")
            for attribute in ("width", "height", "nrow", "ncol"):
                value = element.get(attribute)
                if element.tag in ("texture", "hfield") and value is not None and not _count_within(value, MAX_GRID):
                    raise ValueError(f"{name}: <{element.tag} {attribute}=\"{value[:20]}\"> must be a whole number "
                                     f"up to {MAX_GRID}")
            for attribute in ("vertex", "face", "normal", "texcoord"):
                if len(element.get(attribute, "").split()) > MAX_MESH_VALUES:
                    raise ValueError(f"{name}: <{element.tag} {attribute}> holds more than {MAX_MESH_VALUES} numbers")
            stack.extend(element)


def _count_within(text: str, limit: int) -> bool:
    try:
        return 0 <= int(text) <= limit
    except ValueError:
        return False


def load(arena: str | Path | ET.Element | None = None, vehicle=None, thruster_lag: bool = False) -> AUVPhysics:
    """AUVPhysics of the vehicle inside `arena` (a path, an ElementTree root, or None for open water);
    `thruster_lag` compiles the actuators with their first-order lag."""
    xml, source = compose_xml(arena, vehicle, thruster_lag)
    return AUVPhysics.from_xml_string(xml, source=source)


@dataclass(frozen=True)
class Mover:
    """A moving obstacle: mocap body `body` ping-ponging from `start` to `end` at `speed` m/s, through the
    waypoints `via` ((k, 2), in order) when given."""

    body: str
    start: np.ndarray
    end: np.ndarray
    speed: float
    via: np.ndarray | None = None

    @property
    def waypoints(self) -> np.ndarray:
        """The whole path (n, 2) [m]: start, the waypoints between, end."""
        middle = np.zeros((0, 2)) if self.via is None else np.asarray(self.via, dtype=float).reshape(-1, 2)
        return np.vstack([self.start, middle, self.end])

    def position(self, time: float) -> np.ndarray:
        """(x, y) at simulation time `time`."""
        if self.via is not None and len(self.via):
            return self._along_polyline(time)
        delta = self.end - self.start
        length = float(np.hypot(*delta))
        if length == 0 or self.speed == 0:
            return self.start.copy()
        travelled = (self.speed * time) % (2 * length)
        s = travelled if travelled <= length else 2 * length - travelled
        return self.start + delta * (s / length)

    def _along_polyline(self, time: float) -> np.ndarray:
        points = self.waypoints
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        length = float(arc[-1])
        if length == 0 or self.speed == 0:
            return self.start.copy()
        travelled = (self.speed * time) % (2 * length)
        s = travelled if travelled <= length else 2 * length - travelled
        return np.array([np.interp(s, arc, points[:, 0]), np.interp(s, arc, points[:, 1])])


@dataclass(frozen=True)
class ArenaInfo:
    """What a task reads from a composed arena model (all positions in metres, world frame)."""

    start: np.ndarray | None
    start_heading: float
    goal: np.ndarray | None
    path: np.ndarray
    bounds: np.ndarray | None
    movers: tuple[Mover, ...]


def arena_info(physics: AUVPhysics) -> ArenaInfo:
    """Reads the arena convention (start, goal, path, bounds, movers) from a composed model."""
    model = physics.model.ptr
    sites = {model.site(i).name: i for i in range(model.nsite)}

    def site_xy(name):
        return model.site_pos[sites[name]][:2].copy() if name in sites else None

    start_heading = 0.0
    if "start" in sites:
        quat = model.site_quat[sites["start"]]
        start_heading = float(2 * np.arctan2(quat[3], quat[0]))
    path_names = sorted((n for n in sites if n.startswith(PATH_SITE_PREFIX) and n[5:].isdigit()),
                        key=lambda n: int(n[len(PATH_SITE_PREFIX):]))
    path = np.array([site_xy(n) for n in path_names]).reshape(-1, 2)
    numerics = {model.numeric(i).name: i for i in range(model.nnumeric)}

    def numeric(name):
        i = numerics[name]
        adr, size = model.numeric_adr[i], model.numeric_size[i]
        return model.numeric_data[adr:adr + size].copy()

    bounds = numeric("arena_bounds") if "arena_bounds" in numerics else None
    movers = []
    for i in range(model.nbody):
        name = model.body(i).name
        if name.startswith(MOVER_PREFIX) and model.body_mocapid[i] >= 0:
            if name in numerics:
                values = numeric(name)
                points = values[:-1].reshape(-1, 2) if len(values) % 2 else np.zeros((0, 2))
                if len(points) < 2:  # check-arena names the count; read no path
                    points = np.vstack([model.body_pos[i][:2]] * 2)
                via = points[1:-1] if len(points) > 2 else None
                speed = float(values[-1]) if len(values) else 0.0
                movers.append(Mover(name, points[0].copy(), points[-1].copy(), speed, via))
            else:
                pos = model.body_pos[i][:2].copy()
                movers.append(Mover(name, pos, pos, 0.0))
    return ArenaInfo(site_xy("start"), start_heading, site_xy("goal"), path, bounds, tuple(movers))


def mover_slots(physics: AUVPhysics, movers: tuple[Mover, ...]) -> np.ndarray:
    """Mocap indices of the movers' bodies: resolve them once per episode, not on every tick."""
    model = physics.model.ptr
    return np.array([model.body_mocapid[model.body(m.body).id] for m in movers], dtype=int)


def move_movers(physics: AUVPhysics, movers: tuple[Mover, ...], time: float | None = None,
                slots: np.ndarray | None = None) -> None:
    """Places every moving obstacle where its path puts it at `time` (default: physics time).

    `slots` are the movers' mocap indices from `mover_slots` (looked up here when not given).
    """
    time = physics.time() if time is None else time
    slots = mover_slots(physics, movers) if slots is None else slots
    mocap_pos = physics.data.ptr.mocap_pos
    for mover, slot in zip(movers, slots, strict=True):
        mocap_pos[slot][:2] = mover.position(time)
