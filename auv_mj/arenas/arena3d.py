"""3-D arenas around the 6-DOF vehicle (issue 32): the vehicle MJCF (`models/auv6.xml`) with an arena's world.

An arena is MJCF whose `<worldbody>` holds static geoms (a seabed, obstacles, a tube's walls) and sites (start,
goal) and whose `<custom>` may hold numerics (a tube's centreline); `compose_xml` copies them into the vehicle's
model, as `auv_mj.arenas.arena` does in the plane, and compiles the vehicle's actuators with their first-order
lag when ocean conditions ask for it.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from pathlib import Path

from auv_mj.assets import model_path
from auv_mj.inputs import MAX_XML_BYTES, parse_xml, read_text
from auv_mj.sim.hydro3d import ACTUATORS

VEHICLE_XML = "auv6.xml"
LAG_DYNTYPE = "filterexact"
SEABED_GEOM = "seabed"
"""Name of an arena's seabed plane (the altimeter's target)."""


def lag_actuators(root: ET.Element, source: str = "vehicle") -> ET.Element:
    """Gives thrust, rudder and stern MuJoCo's first-order lag (their `dynprm` [s]), in place; returns `root`.

    The fins' lag acts on the command the servos then slew to (`auv_mj.sim.physics3d`)."""
    found = {el.get("name"): el for el in root.iter("general")}
    for name in ACTUATORS:
        actuator = found.get(name)
        if actuator is None:
            raise ValueError(f'{source}: the lag needs a <general name="{name}"> actuator')
        try:
            tau = float((actuator.get("dynprm") or "nan").split()[0])
        except ValueError:
            tau = math.nan
        if not (math.isfinite(tau) and tau > 0):
            raise ValueError(f"{source}: actuator {name} needs a positive time constant dynprm [s], got "
                             f"{actuator.get('dynprm')!r}")
        actuator.set("dyntype", LAG_DYNTYPE)
        actuator.set("actearly", "true")
    return root


ARENA_SECTIONS = ("worldbody", "custom")
"""The sections of an arena that `compose_xml` copies into the vehicle's."""
_MARK = "auv-mj arena {}"
"""The comment that marks where an arena's section goes in the vehicle's text (`_vehicle_template`)."""


@functools.lru_cache(maxsize=8)
def _vehicle_template(text: str, source: str, thruster_lag: bool) -> str:
    """The vehicle's MJCF text, lagged if asked, with a marker comment (_MARK) at the end of each of ARENA_SECTIONS:
    parsed and written once per vehicle text, not at every episode's reset (the arena's children are written into
    the markers as text)."""
    root = parse_xml(text, source, "6-DOF vehicle MJCF")
    if thruster_lag:
        lag_actuators(root, source)
    for section in ARENA_SECTIONS:
        target = root.find(section)
        if target is None:
            target = ET.SubElement(root, section)
        target.append(ET.Comment(_MARK.format(section)))
    return ET.tostring(root, encoding="unicode")


def compose_xml(arena: ET.Element | str | Path | None = None, thruster_lag: bool = False) -> tuple[str, str]:
    """(MJCF text, source name) of the 6-DOF vehicle inside `arena` (an ElementTree root, an MJCF path, or None
    for open water)."""
    path = model_path(VEHICLE_XML)
    xml = _vehicle_template(read_text(path, "6-DOF vehicle MJCF", MAX_XML_BYTES), str(path), thruster_lag)
    source = VEHICLE_XML
    world = None
    if isinstance(arena, ET.Element):
        world, source = arena, arena.get("model", "arena")
    elif arena is not None:
        path = Path(arena)
        world = parse_xml(read_text(path, "3-D arena MJCF", MAX_XML_BYTES), str(path), "3-D arena MJCF")
        source = str(path)
    for section in ARENA_SECTIONS:
        found = None if world is None else world.find(section)
        children = [] if found is None else list(found)
        for child in children:
            if child.tag not in ("geom", "site", "numeric", "light", "body"):
                raise ValueError(f"{source}: a 3-D arena's <{section}> may hold geoms, sites, lights, mocap "
                                 f"bodies and numerics only, got <{child.tag}>")
            if child.tag == "body":
                _check_mocap(child, source)
        text = "".join(ET.tostring(child, encoding="unicode") for child in children)
        xml = xml.replace(f"<!--{_MARK.format(section)}-->", text, 1)
    return xml, source


def _check_mocap(body: ET.Element, source: str) -> None:
    """A 3-D arena's bodies are moving obstacles: mocap bodies holding geoms (and sites) only."""
    if body.get("mocap") != "true" or any(child.tag not in ("geom", "site") for child in body):
        raise ValueError(f"{source}: body {body.get('name')!r}: a 3-D arena's bodies must be mocap=\"true\" and hold "
                         "geoms and sites only (moving obstacles)")


def seabed(depth: float, size: float = 500.0) -> ET.Element:
    """A seabed plane `depth` metres below the surface (a geom named SEABED_GEOM)."""
    return ET.Element("geom", name=SEABED_GEOM, type="plane", pos=f"0 0 {-float(depth)!r}", size=f"{size} {size} 1",
                      rgba="0.45 0.4 0.3 1")


def arena_root(name: str, elements: list[ET.Element], numerics: dict[str, list[float]] | None = None) -> ET.Element:
    """An arena MJCF root holding `elements` in its worldbody and `numerics` in its custom section."""
    root = ET.Element("mujoco", model=name)
    world = ET.SubElement(root, "worldbody")
    for element in elements:
        world.append(element)
    if numerics:
        custom = ET.SubElement(root, "custom")
        for key, values in numerics.items():
            ET.SubElement(custom, "numeric", name=key, data=" ".join(repr(float(v)) for v in values))
    return root
