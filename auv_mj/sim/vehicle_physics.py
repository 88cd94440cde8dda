"""`VehiclePhysics`: what every vehicle's physics offers, planar (`AUVPhysics`) and 6-DOF (`AUV3DPhysics`) alike.

Code that works on any vehicle (the episode loop and its records, rendering a state, the suite's tasks, the zoo)
types against this Protocol rather than one class, so that a new vehicle is a class that satisfies it (tested in
tests/sim/test_vehicle_model.py for both vehicles). What a domain adds (disturbances of the planar vehicle, the 6-DOF
vehicle's depth, attitude and fins) stays on its own class.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class VehiclePhysics(Protocol):
    """A dm_control Physics of an AUV with its hydrodynamics inside MuJoCo's step."""

    @classmethod
    def from_xml_string(cls, xml_string: str, assets: dict | None = None, source: str = "<string>") -> Any:
        """Physics from MJCF text; `source` names it in error messages."""

    @classmethod
    def from_xml_path(cls, file_path: str | Path) -> Any:
        """Physics from an MJCF file."""

    def reload_from_xml_string(self, xml_string: str, assets: dict | None = None, source: str = "<string>") -> None:
        """Recompiles in place from MJCF text: a new arena around the vehicle."""

    def copy(self, share_model: bool = False) -> Any:
        """A copy of this physics with the same vehicle and water."""

    @property
    def hydrodynamics(self) -> Any:
        """The vehicle's water model (coefficients and forces, read from the MJCF)."""

    def scale_vehicle(self, coefficients: Any = None, mass: float = 1.0) -> None:
        """Scales the vehicle from its MJCF values (model uncertainty); with no arguments restores it."""

    def set_control(self, control: Any) -> None:
        """Sets the actuators' controls; a non-finite value raises ValueError and changes nothing."""

    def step(self, nstep: int = 1) -> None:
        """Advances `nstep` physics steps with the hydrodynamics."""

    def forward(self) -> None:
        """Recomputes the state's derived quantities, the water's forces included."""

    def pose(self) -> np.ndarray:
        """(x, y, psi): the planar pose [m, m, rad] every tool reads (the 6-DOF vehicle's projection)."""

    def body_velocity(self) -> np.ndarray:
        """The body-frame velocity nu [m/s, rad/s]: (u, v, r) planar, (u, v, w, p, q, r) in 6-DOF."""

    def speed(self) -> float:
        """Speed over ground [m/s]."""

    def sonar(self) -> np.ndarray:
        """The sonar's ranges [m] now: nine beams planar, the 27-beam fan in 6-DOF."""
