"""An independent reference for the vehicle tests: Eq. (1)-(12) written out and integrated with scipy.

Nothing here calls auv_mj's force code: the coefficients are read from the MJCF with ElementTree and
the equations are the paper's matrices (Eq. 5, 6, 9, 10, 11) plus the lift terms of the MJCF.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from auv_mj import model_path

VEHICLE_XML = model_path("auv.xml")


def read_numerics(xml_path=VEHICLE_XML) -> dict[str, float]:
    """All `hydro_*` numerics of a vehicle MJCF, by coefficient name (e.g. "X_uu")."""
    root = ET.parse(xml_path).getroot()
    return {n.get("name")[len("hydro_"):]: float(n.get("data")) for n in root.iter("numeric")
            if n.get("name", "").startswith("hydro_")}


def read_rigid_body(xml_path=VEHICLE_XML) -> tuple[float, float]:
    """(m, I_z) of the vehicle body from its <inertial> element."""
    inertial = ET.parse(xml_path).getroot().find(".//body[@name='auv']/inertial")
    return float(inertial.get("mass")), float(inertial.get("diaginertia").split()[2])


def vehicle_xml_with(**numerics: float) -> str:
    """The vehicle MJCF text with some `hydro_*` numerics replaced, e.g. `vehicle_xml_with(X_uu=-3.24)`."""
    root = ET.parse(VEHICLE_XML).getroot()
    for n in root.iter("numeric"):
        key = n.get("name", "")[len("hydro_"):]
        if key in numerics:
            n.set("data", repr(float(numerics.pop(key))))
    assert not numerics, f"unknown numerics {numerics}"
    return ET.tostring(root, encoding="unicode")


@dataclass(frozen=True)
class ReferenceAUV:
    """Eq. (3) in the body frame: M nu_dot + C_RB nu + C_A nu + D nu = tau + lift + g_0 (body frame)."""

    c: dict[str, float]
    m: float
    iz: float

    @classmethod
    def from_xml(cls, xml_path=VEHICLE_XML) -> ReferenceAUV:
        m, iz = read_rigid_body(xml_path)
        return cls(read_numerics(xml_path), m, iz)

    def mass_matrix(self) -> np.ndarray:
        """M = M_RB + M_A, Eq. (4)-(6)."""
        c = self.c
        return np.array([[self.m - c["X_udot"], 0.0, 0.0],
                         [0.0, self.m - c["Y_vdot"], -c["Y_rdot"]],
                         [0.0, -c["Y_rdot"], self.iz - c["N_rdot"]]])

    def coriolis(self, u: float, v: float, r: float) -> np.ndarray:
        """C(nu) = C_RB(nu) + C_A(nu), Eq. (8)-(10)."""
        c, m = self.c, self.m
        c_rb = np.array([[0.0, 0.0, -m * v], [0.0, 0.0, m * u], [m * v, -m * u, 0.0]])
        c_a = np.array([[0.0, 0.0, c["Y_vdot"] * v + c["Y_rdot"] * r],
                        [0.0, 0.0, -c["X_udot"] * u],
                        [-c["Y_vdot"] * v - c["Y_rdot"] * r, c["X_udot"] * u, 0.0]])
        return c_rb + c_a

    def damping(self, u: float, v: float, r: float) -> np.ndarray:
        """D(nu) of Eq. (11)."""
        c, au, av, ar = self.c, abs(u), abs(v), abs(r)
        return -np.array([[c["X_uu"] * au, 0.0, 0.0],
                          [0.0, c["Y_vv"] * av + c["Y_vr"] * ar, c["Y_rv"] * av + c["Y_rr"] * ar],
                          [0.0, c["N_vv"] * av + c["N_vr"] * ar, c["N_rv"] * av + c["N_rr"] * ar]])

    def lift(self, u: float, v: float, r: float) -> np.ndarray:
        """The speed-dependent lift (0, Y_uv u v + Y_ur u r, N_uv u v + N_ur u r) given in the MJCF."""
        c = self.c
        return np.array([0.0, c.get("Y_uv", 0.0) * u * v + c.get("Y_ur", 0.0) * u * r,
                         c.get("N_uv", 0.0) * u * v + c.get("N_ur", 0.0) * u * r])

    def rhs(self, tau: Callable[[float], tuple[float, float]]) -> Callable[[float, np.ndarray], np.ndarray]:
        """d/dt (x, y, psi, u, v, r) under tau(t) = (tau_u, tau_r), Eq. (1)-(3), (12)."""
        m_inv = np.linalg.inv(self.mass_matrix())

        def f(t, s):
            _, _, psi, u, v, r = s
            tau_u, tau_r = tau(t)
            nu = np.array([u, v, r])
            force = np.array([tau_u, 0.0, tau_r]) + self.lift(u, v, r) - (
                self.coriolis(u, v, r) + self.damping(u, v, r)) @ nu
            c, s_ = math.cos(psi), math.sin(psi)
            return np.concatenate(([c * u - s_ * v, s_ * u + c * v, r], m_inv @ force))

        return f

    def solve(self, state0, t_end: float, tau) -> Callable[[np.ndarray], np.ndarray]:
        """Dense DOP853 solution (rtol = atol = 1e-10) of the state (x, y, psi, u, v, r) on [0, t_end]."""
        sol = solve_ivp(self.rhs(tau), (0.0, t_end), np.asarray(state0, float), method="DOP853",
                        rtol=1e-10, atol=1e-10, dense_output=True)
        assert sol.success, sol.message
        return sol.sol
