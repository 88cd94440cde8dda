"""An independent 6-DOF reference for the tests of `models/auv6.xml`: Fossen's equations integrated by scipy.

Nothing here calls auv_mj: the coefficients and the rigid body are read from the MJCF with ElementTree, and the
equations are written in Prestero's frames (body x forward, y starboard, z down; world north, east, down) with
Euler angles, as Fossen (2011) gives them:

    M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + g(eta) = tau + tau_hydro(nu_r) + tau_fins,
    p_dot = R(Theta) nu1,  Theta_dot = T(Theta) nu2,

with C(nu) of any mass matrix from Fossen's Theorem 3.2 (Eq. 3.51), g(eta) of Eq. 4.6, the drag, lift and fin
terms written out as Prestero's force equations, and nu_r = nu - (R^T V_c, 0) for a constant current V_c
(nu_c_dot = (-omega x nu_c1, 0)).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from auv_mj import model_path

VEHICLE3D_XML = model_path("auv6.xml")
GRAVITY = 9.81
FLIP = np.array([1.0, -1.0, -1.0])
"""MuJoCo's frames (body x forward, y port, z up; world z up) to Prestero's (FRD; NED): a half turn about x."""


def read_numerics(xml_path=VEHICLE3D_XML) -> dict[str, float]:
    root = ET.parse(xml_path).getroot()
    return {n.get("name")[len("hydro_"):]: float(n.get("data")) for n in root.iter("numeric")
            if n.get("name", "").startswith("hydro_")}


def read_rigid_body(xml_path=VEHICLE3D_XML) -> tuple[float, np.ndarray, np.ndarray, float]:
    """(m, principal inertia about the CG, CG in FRD [m], roll torque per newton of thrust [m])."""
    root = ET.parse(xml_path).getroot()
    inertial = root.find(".//body[@name='auv']/inertial")
    com = np.array([float(x) for x in inertial.get("pos").split()]) * FLIP
    inertia = np.array([float(x) for x in inertial.get("diaginertia").split()])
    gear = [float(x) for x in root.find(".//actuator/general[@name='thrust']").get("gear").split()]
    return float(inertial.get("mass")), inertia, com, gear[3]


def skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def coriolis_times_nu(mass: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """C(nu) nu of Fossen's Theorem 3.2 for the symmetric 6x6 `mass`."""
    nu1, nu2 = nu[:3], nu[3:]
    a = mass[:3, :3] @ nu1 + mass[:3, 3:] @ nu2
    b = mass[3:, :3] @ nu1 + mass[3:, 3:] @ nu2
    c = np.zeros((6, 6))
    c[:3, 3:] = -skew(a)
    c[3:, :3] = -skew(a)
    c[3:, 3:] = -skew(b)
    return c @ nu


def rotation_zyx(phi: float, theta: float, psi: float) -> np.ndarray:
    """R(Theta), body FRD to NED (Fossen 2011, Eq. 2.18)."""
    cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    return np.array([[cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st],
                     [sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf],
                     [-st, ct * sf, ct * cf]])


def euler_rates(phi: float, theta: float) -> np.ndarray:
    """T(Theta) of Fossen 2011, Eq. 2.28."""
    cf, sf, ct, tt = math.cos(phi), math.sin(phi), math.cos(theta), math.tan(theta)
    return np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])


@dataclass(frozen=True)
class Reference3D:
    """REMUS-100 per Prestero's equations; state (n, e, d, phi, theta, psi, u, v, w, p, q, r), FRD / NED."""

    c: dict[str, float]
    m: float
    inertia: np.ndarray
    r_g: np.ndarray
    prop_roll: float

    @classmethod
    def from_xml(cls, xml_path=VEHICLE3D_XML) -> Reference3D:
        m, inertia, com, prop = read_rigid_body(xml_path)
        return cls(read_numerics(xml_path), m, inertia, com, prop)

    def rigid_body_mass(self) -> np.ndarray:
        """M_RB about the CB (Fossen 2011, Eq. 3.44), with I_o = I_g - m S(r_g)^2."""
        s = skew(self.r_g)
        out = np.zeros((6, 6))
        out[:3, :3] = self.m * np.eye(3)
        out[:3, 3:] = -self.m * s
        out[3:, :3] = self.m * s
        out[3:, 3:] = np.diag(self.inertia) - self.m * s @ s
        return out

    def added_mass(self) -> np.ndarray:
        c = self.c
        return -np.array([[c["X_udot"], 0, 0, 0, 0, 0],
                          [0, c["Y_vdot"], 0, 0, 0, c["Y_rdot"]],
                          [0, 0, c["Z_wdot"], 0, c["Z_qdot"], 0],
                          [0, 0, 0, c["K_pdot"], 0, 0],
                          [0, 0, c["M_wdot"], 0, c["M_qdot"], 0],
                          [0, c["N_vdot"], 0, 0, 0, c["N_rdot"]]], dtype=float)

    def restoring(self, phi: float, theta: float) -> np.ndarray:
        """g(eta) of Fossen 2011, Eq. 4.6, CB at the origin."""
        w, b = self.m * GRAVITY, self.c["B"]
        xg, yg, zg = self.r_g
        cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
        return np.array([(w - b) * st, -(w - b) * ct * sf, -(w - b) * ct * cf,
                         -yg * w * ct * cf + zg * w * ct * sf, zg * w * st + xg * w * ct * cf,
                         -xg * w * ct * sf - yg * w * st])

    def hydrodynamic(self, nu_r: np.ndarray, rudder: float, stern: float) -> np.ndarray:
        """Drag, lift and fins as Prestero writes the force equations (Tables C.1-C.4, C.10)."""
        c = self.c
        u, v, w, p, q, r = nu_r
        return np.array([
            c["X_uu"] * u * abs(u),
            c["Y_vv"] * v * abs(v) + c["Y_rr"] * r * abs(r) + c["Y_uv"] * u * v + c["Y_ur"] * u * r
            + c["Y_uudr"] * u * u * rudder,
            c["Z_ww"] * w * abs(w) + c["Z_qq"] * q * abs(q) + c["Z_uw"] * u * w + c["Z_uq"] * u * q
            + c["Z_uuds"] * u * u * stern,
            c["K_pp"] * p * abs(p),
            c["M_ww"] * w * abs(w) + c["M_qq"] * q * abs(q) + c["M_uw"] * u * w + c["M_uq"] * u * q
            + c["M_uuds"] * u * u * stern,
            c["N_vv"] * v * abs(v) + c["N_rr"] * r * abs(r) + c["N_uv"] * u * v + c["N_ur"] * u * r
            + c["N_uudr"] * u * u * rudder])

    def derivative(self, state: np.ndarray, controls: tuple[float, float, float],
                   current_ned: np.ndarray) -> np.ndarray:
        phi, theta, psi = state[3:6]
        nu = state[6:]
        rotation = rotation_zyx(phi, theta, psi)
        nu_c = np.concatenate([rotation.T @ current_ned, np.zeros(3)])
        nu_r = nu - nu_c
        nu_c_dot = np.concatenate([-np.cross(nu[3:], nu_c[:3]), np.zeros(3)])
        m_rb, m_a = self.rigid_body_mass(), self.added_mass()
        thrust, rudder, stern = controls
        tau = np.array([thrust, 0.0, 0.0, self.prop_roll * thrust, 0.0, 0.0])
        rhs = (tau + self.hydrodynamic(nu_r, rudder, stern) - self.restoring(phi, theta)
               - coriolis_times_nu(m_rb, nu) - coriolis_times_nu(m_a, nu_r) + m_a @ nu_c_dot)
        nu_dot = np.linalg.solve(m_rb + m_a, rhs)
        return np.concatenate([rotation @ nu[:3], euler_rates(phi, theta) @ nu[3:], nu_dot])

    def solve(self, state0: np.ndarray, duration: float, controls: Callable[[float], tuple[float, float, float]],
              current_ned=(0.0, 0.0, 0.0)):
        """Dense solution t -> state (12,) over [0, duration]."""
        current = np.asarray(current_ned, dtype=float)
        solution = solve_ivp(lambda t, s: self.derivative(s, controls(t), current), (0.0, duration), state0,
                             method="DOP853", rtol=1e-10, atol=1e-10, dense_output=True)
        assert solution.success, solution.message
        return solution.sol
