"""Planar hydrodynamics of Eq. (3)-(11): added mass M_A, its Coriolis C_A(nu) and damping D(nu).

MuJoCo integrates the rigid body (M_RB, C_RB) in world coordinates. This module adds the rest:
M_A enters the joint-space inertia (so it is implicit, and stable when -Y_vdot exceeds the hull's
mass), and the velocity terms enter as a passive generalised force. With generalised coordinates
q = (x, y, psi) and body velocity nu = R(psi)^T qdot (Eq. 1-2), the added-mass kinetic energy
1/2 nu^T M_A nu gives the joint-space inertia R M_A R^T and the body-frame velocity force

    M_A dR^T/dt qdot + C_A(nu) nu = ((a11 - a22) r v - a23 r^2, (a11 - a22) u r, (a22 - a11) u v),

with a11 = -X_udot, a22 = -Y_vdot, a23 = -Y_rdot, a33 = -N_rdot (Eq. 6). Damping is Eq. (11), with
|v| v (not v^2) so that drag always opposes motion; the optional lift terms Y_uv, Y_ur, N_uv, N_ur
are the speed-dependent lift of Prestero (2001), zero unless the MJCF gives them.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, fields
from pathlib import Path

import mujoco
import numpy as np

NUMERIC_PREFIX = "hydro_"
REQUIRED = ("X_udot", "Y_vdot", "Y_rdot", "N_rdot", "X_uu", "Y_vv", "Y_vr", "Y_rv", "Y_rr",
            "N_vv", "N_vr", "N_rv", "N_rr")
OPTIONAL = ("Y_uv", "Y_ur", "N_uv", "N_ur")
VEHICLE_JOINTS = ("x", "y", "yaw")


@dataclass(frozen=True)
class HydroCoefficients:
    """Hydrodynamic derivatives in SNAME notation, SI units (Eq. 6, 9, 11; lift terms optional)."""

    X_udot: float
    Y_vdot: float
    Y_rdot: float
    N_rdot: float
    X_uu: float
    Y_vv: float
    Y_vr: float
    Y_rv: float
    Y_rr: float
    N_vv: float
    N_vr: float
    N_rv: float
    N_rr: float
    Y_uv: float = 0.0
    Y_ur: float = 0.0
    N_uv: float = 0.0
    N_ur: float = 0.0

    def added_mass(self) -> np.ndarray:
        """M_A of Eq. (6), symmetric: N_vdot is taken equal to Y_rdot."""
        return np.array([[-self.X_udot, 0.0, 0.0],
                         [0.0, -self.Y_vdot, -self.Y_rdot],
                         [0.0, -self.Y_rdot, -self.N_rdot]])

    @classmethod
    def from_mapping(cls, values: dict[str, float], source: str = "<dict>") -> HydroCoefficients:
        """Coefficients from {"X_udot": ..., ...}; a ValueError names any missing or bad field."""
        kwargs = {}
        for f in fields(cls):
            if f.name not in values:
                if f.name in REQUIRED:
                    raise ValueError(f"{source}: missing hydrodynamic coefficient "
                                     f"<numeric name=\"{NUMERIC_PREFIX}{f.name}\">")
                continue
            kwargs[f.name] = _as_float(values[f.name], f.name, source)
        return cls(**kwargs)


def _as_float(value, name: str, source: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{source}: <numeric name=\"{NUMERIC_PREFIX}{name}\"> has data={value!r}, "
                         "which is not a number") from None
    if not math.isfinite(number):
        raise ValueError(f"{source}: <numeric name=\"{NUMERIC_PREFIX}{name}\"> has data={value!r}, "
                         "which is not finite")
    return number


def coefficients_from_xml(xml: str, source: str = "<string>") -> HydroCoefficients | None:
    """Reads the `hydro_*` numerics from MJCF text before MuJoCo compiles it.

    Returns None when the file has no `hydro_*` numeric at all (a model without a vehicle).
    Parsing ourselves lets a bad value be reported by field and file rather than by MuJoCo.
    """
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as e:
        raise ValueError(f"{source}: not well-formed XML: {e}") from None
    values: dict[str, str] = {}
    for numeric in root.iter("numeric"):
        name = numeric.get("name", "")
        if name.startswith(NUMERIC_PREFIX):
            key = name[len(NUMERIC_PREFIX):]
            if key not in REQUIRED and key not in OPTIONAL:
                raise ValueError(f"{source}: unknown hydrodynamic coefficient <numeric name=\"{name}\">; "
                                 f"known: {', '.join(NUMERIC_PREFIX + k for k in REQUIRED + OPTIONAL)}")
            data = numeric.get("data")
            if data is None or len(data.split()) != 1:
                raise ValueError(f"{source}: <numeric name=\"{name}\"> must have exactly one value in "
                                 f"its data attribute, got data={data!r}")
            values[key] = data
    if not values:
        return None
    return HydroCoefficients.from_mapping(values, source)


def coefficients_from_path(path: str | Path) -> HydroCoefficients | None:
    """`coefficients_from_xml` for a file."""
    path = Path(path)
    return coefficients_from_xml(path.read_text(), str(path))


class Hydrodynamics:
    """Applies M_A, C_A(nu) and D(nu) (Eq. 3-11) to one vehicle of a compiled MuJoCo model.

    `apply(model, data, disturbance)` must run after `mj_step1` (or `mj_forward`) has built the joint-space
    inertia and the passive forces, and before the accelerations are computed (`mj_step2`).
    """

    def __init__(self, model: mujoco.MjModel, coefficients: HydroCoefficients, source: str = "model"):
        self.coefficients = c = coefficients
        try:
            joint_ids = [model.joint(name).id for name in VEHICLE_JOINTS]
        except KeyError as e:
            raise ValueError(f"{source}: the vehicle needs joints named {VEHICLE_JOINTS}: {e}") from None
        self.dofs = np.array([model.jnt_dofadr[j] for j in joint_ids])
        self.qpos_yaw = int(model.jnt_qposadr[joint_ids[2]])
        body = int(model.jnt_bodyid[joint_ids[0]])
        if any(model.jnt_bodyid[j] != body for j in joint_ids):
            raise ValueError(f"{source}: joints {VEHICLE_JOINTS} must all belong to the vehicle body")
        if model.body_simple[body]:
            raise ValueError(
                f"{source}: body '{model.body(body).name}' is 'simple' to MuJoCo, whose mass matrix is "
                "then diagonal and cannot hold the coupled added mass: offset its <inertial pos> along "
                "the yaw axis, e.g. pos=\"0 0 0.001\"")
        self.M_A = c.added_mass()
        mass = float(model.body_subtreemass[body])
        izz = float(model.body_inertia[body][2])
        self.M_RB = np.diag([mass, mass, izz])
        self.total_mass = total = self.M_RB + self.M_A
        if np.any(np.linalg.eigvalsh(total) <= 0):
            raise ValueError(
                f"{source}: M_RB + M_A is not positive definite (eigenvalues "
                f"{np.linalg.eigvalsh(total).round(3).tolist()}); added-mass derivatives are negative "
                "in the SNAME convention (e.g. hydro_Y_vdot < 0)")
        self._M_index = self._mass_matrix_index(model)
        self._a11, self._a22 = -c.X_udot, -c.Y_vdot
        self._a23, self._a33 = -c.Y_rdot, -c.N_rdot

    def _mass_matrix_index(self, model: mujoco.MjModel) -> np.ndarray:
        """Addresses in the CSR lower triangle `d.M` of (x,x), (y,x), (y,y), (yaw,x), (yaw,y), (yaw,yaw)."""
        index = []
        for i, j in ((0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2)):
            row, col = self.dofs[i], self.dofs[j]
            start = model.M_rowadr[row]
            cols = model.M_colind[start:start + model.M_rownnz[row]]
            hit = np.flatnonzero(cols == col)
            if hit.size != 1:
                raise ValueError("the vehicle's dofs must form one chain x -> y -> yaw in the mass matrix")
            index.append(start + hit[0])
        return np.array(index)

    def body_velocity(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """(u, v, r): surge, sway and yaw rate in the body frame, Eq. (1)."""
        psi = data.qpos[self.qpos_yaw]
        xd, yd, r = data.qvel[self.dofs]
        c, s = math.cos(psi), math.sin(psi)
        return c * xd + s * yd, -s * xd + c * yd, r

    def body_force(self, u: float, v: float, r: float) -> tuple[float, float, float]:
        """Body-frame hydrodynamic force (X, Y, N) other than M_A nu_dot: -(velocity terms) - D(nu) nu + lift."""
        c = self.coefficients
        a11, a22, a23 = self._a11, self._a22, self._a23
        au, av, ar = abs(u), abs(v), abs(r)
        X = -((a11 - a22) * r * v - a23 * r * r) + c.X_uu * au * u
        Y = (-(a11 - a22) * u * r + (c.Y_vv * av + c.Y_vr * ar) * v + (c.Y_rv * av + c.Y_rr * ar) * r
             + c.Y_uv * u * v + c.Y_ur * u * r)
        N = (-(a22 - a11) * u * v + (c.N_vv * av + c.N_vr * ar) * v + (c.N_rv * av + c.N_rr * ar) * r
             + c.N_uv * u * v + c.N_ur * u * r)
        return X, Y, N

    def joint_added_mass(self, psi: float) -> np.ndarray:
        """Lower triangle of R M_A R^T in joint coordinates, in the order of `_M_index`."""
        c, s = math.cos(psi), math.sin(psi)
        a11, a22, a23 = self._a11, self._a22, self._a23
        return np.array([a11 * c * c + a22 * s * s, (a11 - a22) * s * c, a11 * s * s + a22 * c * c,
                         -a23 * s, a23 * c, self._a33])

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData, disturbance: np.ndarray | None = None) -> None:
        """Adds M_A to `data.M` (re-factored) and the hydrodynamic (+ disturbance) force to qfrc_passive.

        `disturbance` is a world-frame (Fx, Fy, Mz), the g_0 of Eq. (3).
        """
        psi = data.qpos[self.qpos_yaw]
        c, s = math.cos(psi), math.sin(psi)
        xd, yd, r = data.qvel[self.dofs]
        u, v = c * xd + s * yd, -s * xd + c * yd
        X, Y, N = self.body_force(u, v, r)
        force = np.array([c * X - s * Y, s * X + c * Y, N])
        if disturbance is not None:
            force += disturbance
        data.qfrc_passive[self.dofs] += force
        data.M[self._M_index] += self.joint_added_mass(psi)
        mujoco.mj_factorM(model, data)
