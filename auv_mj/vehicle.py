"""Vehicle facts read from the compiled vehicle MJCF (`models/auv.xml`), never copied into code.

Controllers need the actuator limits (K_V, K_psi of Eq. 32) and the surge drag X_uu; tunnel authoring
needs the hull's size. Editing the vehicle's XML changes all of them at once.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from auv_mj.assets import model_path

HULL_GEOM = "hull"
"""Name of the vehicle's hull geom (a capsule along the body x axis)."""
ACTUATORS = ("tau_u", "tau_r")
"""Names of the surge force and yaw moment actuators."""


@dataclass(frozen=True)
class VehicleFacts:
    """What code needs to know of the vehicle, as compiled."""

    surge_limit: float
    """|tau_u| limit [N]: the tau_u actuator's ctrlrange."""
    yaw_limit: float
    """|tau_r| limit [N m]: the tau_r actuator's ctrlrange."""
    surge_drag: float
    """-X_uu [N s^2/m^2] (`hydro_X_uu`): steady thrust surge_drag u |u| holds surge speed u."""
    hull_radius: float
    """Radius of the hull capsule [m]."""
    hull_half_length: float
    """Farthest point of the hull from the vehicle's centre [m], whatever its yaw."""


def facts_of(model: mujoco.MjModel) -> VehicleFacts:
    """The facts of a compiled vehicle (or vehicle + arena) model."""
    limits = []
    for name in ACTUATORS:
        low, high = model.actuator_ctrlrange[model.actuator(name).id]
        limits.append(float(min(-low, high)))
    hull = model.geom(HULL_GEOM)
    radius, half = float(hull.size[0]), float(hull.size[1])
    offset = float(np.hypot(*model.geom_pos[hull.id][:2]))
    x_uu = float(model.numeric("hydro_X_uu").data[0])
    return VehicleFacts(surge_limit=limits[0], yaw_limit=limits[1], surge_drag=-x_uu, hull_radius=radius,
                        hull_half_length=offset + half + radius)


@functools.lru_cache(maxsize=8)
def vehicle_facts(path: str | Path | None = None) -> VehicleFacts:
    """The facts of the vehicle MJCF at `path` (default: the shipped `models/auv.xml`), compiled once."""
    return facts_of(mujoco.MjModel.from_xml_path(str(path or model_path("auv.xml"))))
