"""An independent reference for the vehicle tests: Eq. (1)-(12) written out and integrated with scipy.

Nothing here calls auv_mj's force code: the coefficients are read from the MJCF with ElementTree and
the equations are the paper's matrices (Eq. 5, 6, 9, 10, 11) plus the lift terms of the MJCF. With an
ocean current the equations are Fossen's (2011, Sec. 8.3) in the relative velocity, term by term as the
matrices read, not the simulator's rearrangement of them.
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
    """Eq. (3) in the body frame: M nu_dot + C_RB nu + C_A nu + D nu = tau + lift + g_0 (body frame).

    In a constant world-frame current V_c the water terms take the relative velocity nu_r = nu - nu_c,
    nu_c = R(psi)^T V_c: M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + D(nu_r) nu_r = tau +
    lift(nu_r), with nu_r_dot = nu_dot - nu_c_dot and nu_c_dot = (r v_c, -r u_c, 0).
    """

    c: dict[str, float]
    m: float
    iz: float

    @classmethod
    def from_xml(cls, xml_path=VEHICLE_XML) -> ReferenceAUV:
        m, iz = read_rigid_body(xml_path)
        return cls(read_numerics(xml_path), m, iz)

    def mass_matrix(self) -> np.ndarray:
        """M = M_RB + M_A, Eq. (4)-(6)."""
        return self.rigid_body_mass() + self.added_mass()

    def rigid_body_mass(self) -> np.ndarray:
        """M_RB, Eq. (5)."""
        return np.diag([self.m, self.m, self.iz])

    def added_mass(self) -> np.ndarray:
        """M_A, Eq. (6)."""
        c = self.c
        return -np.array([[c["X_udot"], 0.0, 0.0], [0.0, c["Y_vdot"], c["Y_rdot"]], [0.0, c["Y_rdot"], c["N_rdot"]]])

    def coriolis(self, u: float, v: float, r: float) -> np.ndarray:
        """C(nu) = C_RB(nu) + C_A(nu), Eq. (8)-(10)."""
        return self.rigid_body_coriolis(u, v, r) + self.added_mass_coriolis(u, v, r)

    def rigid_body_coriolis(self, u: float, v: float, r: float) -> np.ndarray:
        """C_RB(nu), Eq. (8)."""
        m = self.m
        return np.array([[0.0, 0.0, -m * v], [0.0, 0.0, m * u], [m * v, -m * u, 0.0]])

    def added_mass_coriolis(self, u: float, v: float, r: float) -> np.ndarray:
        """C_A(nu), Eq. (9)."""
        c = self.c
        return np.array([[0.0, 0.0, c["Y_vdot"] * v + c["Y_rdot"] * r],
                         [0.0, 0.0, -c["X_udot"] * u],
                         [-c["Y_vdot"] * v - c["Y_rdot"] * r, c["X_udot"] * u, 0.0]])

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

    def rhs(self, tau: Callable[[float], tuple[float, float]],
            current: tuple[float, float] = (0.0, 0.0)) -> Callable[[float, np.ndarray], np.ndarray]:
        """d/dt (x, y, psi, u, v, r) under tau(t) = (tau_u, tau_r) in a constant world-frame `current`
        (V_cx, V_cy) [m/s], Eq. (1)-(3), (12); (u, v, r) is the velocity over ground."""
        m_inv = np.linalg.inv(self.mass_matrix())
        m_a = self.added_mass()
        vcx, vcy = current

        def f(t, s):
            _, _, psi, u, v, r = s
            tau_u, tau_r = tau(t)
            c, s_ = math.cos(psi), math.sin(psi)
            u_c, v_c = c * vcx + s_ * vcy, -s_ * vcx + c * vcy  # nu_c = R^T V_c
            ur, vr = u - u_c, v - v_c
            nu, nu_r = np.array([u, v, r]), np.array([ur, vr, r])
            nu_c_dot = np.array([r * v_c, -r * u_c, 0.0])
            force = (np.array([tau_u, 0.0, tau_r]) + self.lift(ur, vr, r) - self.rigid_body_coriolis(u, v, r) @ nu
                     - (self.added_mass_coriolis(ur, vr, r) + self.damping(ur, vr, r)) @ nu_r + m_a @ nu_c_dot)
            return np.concatenate(([c * u - s_ * v, s_ * u + c * v, r], m_inv @ force))

        return f

    def solve(self, state0, t_end: float, tau,
              current: tuple[float, float] = (0.0, 0.0)) -> Callable[[np.ndarray], np.ndarray]:
        """Dense DOP853 solution (rtol = atol = 1e-10) of the state (x, y, psi, u, v, r) on [0, t_end]."""
        sol = solve_ivp(self.rhs(tau, current), (0.0, t_end), np.asarray(state0, float), method="DOP853",
                        rtol=1e-10, atol=1e-10, dense_output=True)
        assert sol.success, sol.message
        return sol.sol
