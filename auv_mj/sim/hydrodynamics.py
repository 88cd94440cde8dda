"""Planar hydrodynamics of Eq. (3)-(11): added mass M_A, its Coriolis C_A(nu) and damping D(nu).

MuJoCo integrates the rigid body (M_RB, C_RB) in world coordinates. This module adds the rest:
M_A enters the joint-space inertia (so it is implicit, and stable when -Y_vdot exceeds the hull's
mass), and the velocity terms enter as a passive generalised force. With generalised coordinates
q = (x, y, psi) and body velocity nu = R(psi)^T qdot (Eq. 1-2), the added-mass kinetic energy
1/2 nu^T M_A nu gives the joint-space inertia R M_A R^T and the body-frame velocity force

    M_A dR^T/dt qdot + C_A(nu) nu = ((a11 - a22) r v - a23 r^2, (a11 - a22) u r, (a22 - a11) u v),

with a11 = -X_udot, a22 = -Y_vdot, a23 = -Y_rdot, a33 = -N_rdot (Eq. 6). Damping is Eq. (11), with
|v| v (not v^2) so that drag always opposes motion; the optional lift terms Y_uv, Y_ur, N_uv, N_ur
are the speed-dependent lift of Prestero (2001), zero unless the MJCF gives them. The per-step hook
(`Hydrodynamics.bind`) also makes the stiff surge and yaw drag linearly implicit (see there).

Ocean current. `model.opt.wind[:2]` is the current V_c in the world frame [m/s] (MuJoCo's medium
velocity: `<option wind="..."/>` in the MJCF, or set at run time; the vehicle MJCF has density 0, so
MuJoCo's own fluid model stays off and only this module reads it). The water forces act on the velocity
relative to the water, nu_r = nu - nu_c with nu_c = R(psi)^T V_c (Fossen 2011, Sec. 8.3):

    M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + D(nu_r) nu_r - lift(nu_r) = tau.

For a constant, irrotational V_c, nu_c_dot = (r v_c, -r u_c, 0), so M_A nu_r_dot = M_A nu_dot -
M_A r (v_c, -u_c, 0), and with M_A dR^T/dt qdot = M_A r (v, -u, 0) the added-mass terms combine into
M_A r (v_r, -u_r, 0): the whole velocity force above is the still-water one evaluated at (u_r, v_r, r).
So the hook only replaces nu by nu_r (r_r = r), and the added mass stays implicit in the joint-space
inertia. A time-varying current (`auv_mj.sim.ocean`) is held constant between its updates.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path

import mujoco
import numpy as np

from auv_mj.inputs import MAX_XML_BYTES, parse_xml, read_text
from auv_mj.sim.native import NativeKernel
from auv_mj.sim.native import kernel as native_kernel

NUMERIC_PREFIX = "hydro_"
REQUIRED = ("X_udot", "Y_vdot", "Y_rdot", "N_rdot", "X_uu", "Y_vv", "Y_vr", "Y_rv", "Y_rr",
            "N_vv", "N_vr", "N_rv", "N_rr")
OPTIONAL = ("Y_uv", "Y_ur", "N_uv", "N_ur")
VEHICLE_JOINTS = ("x", "y", "yaw")
NON_POSITIVE = {"X_udot": "an added-mass", "Y_vdot": "an added-mass", "N_rdot": "an added-mass",
                "X_uu": "a drag", "Y_vv": "a drag", "N_rr": "a drag"}
"""Coefficients that are <= 0 in the SNAME convention (Eq. 6, 11): added mass adds inertia and drag takes
energy out; the wrong sign makes M_A negative or feeds energy in, and the step diverges."""
MAX_COEFFICIENT = 1e6
"""Largest |coefficient| accepted (SI units); REMUS's largest, Y_vv, is 1310."""
KERNEL_COEFFICIENTS = ("a11", "a22", "a23", "a33", "munk", "neg_munk", "X_uu", "Y_uv", "Y_ur", "N_uv", "N_ur",
                       "Y_vv", "Y_vr", "Y_rv", "Y_rr", "N_vv", "N_vr", "N_rv", "N_rr", "k_u", "k_v", "k_r",
                       "sway_mass", "cross_flow")
"""The values the C step (`hydro_kernel.c`) reads, in the order of its enum."""
KERNEL_INDICES = ("i_psi", "ix", "iy", "ir", "m_xx", "m_yx", "m_yy", "m_rx", "m_ry", "m_rr")
"""The addresses (in qpos, qvel and the CSR inertia M) the C step reads, in the order of its enum."""


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
        for name, value in kwargs.items():
            numeric = f"<numeric name=\"{NUMERIC_PREFIX}{name}\">"
            if abs(value) > MAX_COEFFICIENT:
                raise ValueError(f"{source}: {numeric} = {value:g} is beyond +-{MAX_COEFFICIENT:g}: not a "
                                 "vehicle's coefficient")
            if name in NON_POSITIVE and value > 0:
                effect = ("makes the added mass negative" if "mass" in NON_POSITIVE[name]
                          else "feeds energy in instead of taking it out")
                raise ValueError(f"{source}: {numeric} = {value:g} must be <= 0 (SNAME convention): "
                                 f"{NON_POSITIVE[name]} derivative of the wrong sign {effect}")
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
    root = parse_xml(xml, source, "vehicle MJCF")
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
    return coefficients_from_xml(read_text(path, "vehicle MJCF", MAX_XML_BYTES), str(path))


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
        self._dof_x, self._dof_y, self._dof_yaw = (int(i) for i in self.dofs)
        self._body_force = self._make_body_force()

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
        psi = data.qpos.item(self.qpos_yaw)
        qvel = data.qvel
        xd, yd, r = qvel.item(self._dof_x), qvel.item(self._dof_y), qvel.item(self._dof_yaw)
        c, s = math.cos(psi), math.sin(psi)
        return c * xd + s * yd, c * yd - s * xd, r

    def body_force(self, u: float, v: float, r: float) -> tuple[float, float, float]:
        """Body-frame force (X, Y, N) of Eq. (3) but M_A nu_dot: -(velocity terms) - D(nu) nu + lift."""
        return self._body_force(u, v, r)

    def _make_body_force(self) -> Callable[[float, float, float], tuple[float, float, float]]:
        """`body_force` with the coefficients bound as locals: it runs every physics step.

        The velocity terms are M_A dR^T/dt qdot + C_A(nu) nu (Eq. 9, see the module docstring), the
        damping is D(nu) nu of Eq. (11) with |v| v, the lift is Y_uv u v + Y_ur u r, N_uv u v + N_ur u r.
        """
        c = self.coefficients
        munk, a23 = self._a11 - self._a22, self._a23
        X_uu, Y_uv, Y_ur, N_uv, N_ur = c.X_uu, c.Y_uv, c.Y_ur, c.N_uv, c.N_ur
        Y_vv, Y_vr, Y_rv, Y_rr = c.Y_vv, c.Y_vr, c.Y_rv, c.Y_rr
        N_vv, N_vr, N_rv, N_rr = c.N_vv, c.N_vr, c.N_rv, c.N_rr

        def body_force(u: float, v: float, r: float) -> tuple[float, float, float]:
            au, av, ar = abs(u), abs(v), abs(r)
            X = -munk * r * v + a23 * r * r + X_uu * au * u
            Y = (-munk * u * r + (Y_vv * av + Y_vr * ar) * v + (Y_rv * av + Y_rr * ar) * r
                 + Y_uv * u * v + Y_ur * u * r)
            N = (munk * u * v + (N_vv * av + N_vr * ar) * v + (N_rv * av + N_rr * ar) * r
                 + N_uv * u * v + N_ur * u * r)
            return X, Y, N

        return body_force

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData, disturbance=None) -> None:
        """Adds M_A to `data.M` (re-factored) and the hydrodynamic (+ disturbance) force to qfrc_passive.

        `disturbance` is a world-frame (Fx, Fy, Mz), the g_0 of Eq. (3). For repeated use, `bind` once.
        """
        wrench = None if disturbance is None else tuple(float(f) for f in disturbance)
        self.bind(model, data)(0, model.opt.timestep, None if wrench is None else lambda: wrench)

    def kernel_arguments(self) -> tuple[np.ndarray, np.ndarray]:
        """(coefficients, addresses) of the C step `hydro_kernel.c`, in the orders KERNEL_COEFFICIENTS and
        KERNEL_INDICES: what `bind` hands the native stepper, and the batched step (`auv_mj.sim.batch`) too."""
        c = self.coefficients
        a11, a22, a23, a33 = self._a11, self._a22, self._a23, self._a33
        k_u, k_v, k_r = (max(0.0, -k) for k in (c.X_uu, c.Y_vv, c.N_rr))
        munk = a11 - a22
        values = dict(a11=a11, a22=a22, a23=a23, a33=a33, munk=munk, neg_munk=-munk, X_uu=c.X_uu,
                      Y_uv=c.Y_uv, Y_ur=c.Y_ur, N_uv=c.N_uv, N_ur=c.N_ur, Y_vv=c.Y_vv, Y_vr=c.Y_vr, Y_rv=c.Y_rv,
                      Y_rr=c.Y_rr, N_vv=c.N_vv, N_vr=c.N_vr, N_rv=c.N_rv, N_rr=c.N_rr, k_u=k_u, k_v=k_v, k_r=k_r,
                      sway_mass=float(self.total_mass[1, 1]),
                      cross_flow=float(any((c.Y_vr, c.Y_rv, c.N_vr, c.N_rv))))
        m_xx, m_yx, m_yy, m_rx, m_ry, m_rr = (int(i) for i in self._M_index)
        addresses = dict(i_psi=self.qpos_yaw, ix=self._dof_x, iy=self._dof_y, ir=self._dof_yaw, m_xx=m_xx, m_yx=m_yx,
                         m_yy=m_yy, m_rx=m_rx, m_ry=m_ry, m_rr=m_rr)
        return (np.array([values[k] for k in KERNEL_COEFFICIENTS]),
                np.array([addresses[k] for k in KERNEL_INDICES], dtype=np.dtype(ctypes.c_long)))

    def bind(self, model: mujoco.MjModel, data: mujoco.MjData, native: bool = True) -> Callable[..., None]:
        """The stepper of this vehicle in (`model`, `data`): `advance(nstep, dt, wrench=None)`.

        Each of `nstep` steps applies Eq. (3)-(11) and then runs `mj_step2` and `mj_step1`; `nstep = 0` only
        applies them (for `mj_forward`'s accelerations). Applying adds the body force at the velocity
        relative to the water, nu_r (rotated to the world; the current is `model.opt.wind[:2]`, read at
        every step), and the world-frame disturbance g_0 = `wrench()` -> (fx, fy, mz) to `qfrc_passive`,
        and R (M_A + dt K) R^T to the joint-space inertia `data.M`, which it re-factors. Call it after
        `mj_step1` (or `mj_forward`); dt is the timestep, or 0 for the plain dynamics (true accelerations).

        K makes MuJoCo's Euler step treat the quadratic drag of Eq. (11) linearly implicitly:
        K_uu = -2 X_uu |u_r| and K_rr = -2 N_rr |r| (backward Euler; this halves the position error
        against an exact solution at dt = 0.01 s). Sway stays explicit, which is more accurate (the
        diagonal-only linearisation of the stiff sway drag made errors 15x larger), except that
        K_vv = max(0, |Y_vv| |v_r| - m_v / dt) stops one step of sway drag from reversing v_r: large
        timesteps stay stable at any sway speed.

        This is the simulator's hot loop. By default it runs in C (`auv_mj.sim.native`, one call per `advance`,
        none into MuJoCo from Python); with `native=False`, or where no C compiler is found, in Python. The
        two compute the same floating-point values, operation for operation (tests/sim/test_hydrodynamics.py
        compares their trajectories bit for bit). The Python loop is written for CPython: the arrays are
        read and written through memoryviews (plain floats, no NumPy scalars), the coefficients are closure
        locals, MuJoCo's functions are called directly, and the force of `body_force` is inlined in the
        same order of operations (so the same floating-point values; terms whose coefficient is zero are
        skipped, as they add exactly nothing). tests/sim/test_hydrodynamics.py checks that the step's force is
        `body_force`, with and without cross-flow terms.
        """
        qpos, qvel, qfrc, M = (memoryview(a) for a in (data.qpos, data.qvel, data.qfrc_passive, data.M))
        wind = memoryview(model.opt.wind)
        ix, iy, ir = self._dof_x, self._dof_y, self._dof_yaw
        m_xx, m_yx, m_yy, m_rx, m_ry, m_rr = (int(i) for i in self._M_index)
        i_psi = self.qpos_yaw
        a11, a22, a23, a33 = self._a11, self._a22, self._a23, self._a33
        c = self.coefficients
        k_u, k_v, k_r = (max(0.0, -k) for k in (c.X_uu, c.Y_vv, c.N_rr))
        sway_mass = float(self.total_mass[1, 1])
        munk = a11 - a22
        neg_munk = -munk
        X_uu, Y_uv, Y_ur, N_uv, N_ur = c.X_uu, c.Y_uv, c.Y_ur, c.N_uv, c.N_ur
        Y_vv, Y_vr, Y_rv, Y_rr = c.Y_vv, c.Y_vr, c.Y_rv, c.Y_rr
        N_vv, N_vr, N_rv, N_rr = c.N_vv, c.N_vr, c.N_rv, c.N_rr
        cross_flow = any((Y_vr, Y_rv, N_vr, N_rv))  # REMUS has none: their zero terms are skipped
        compiled = native_kernel() if native else None
        if compiled is not None:
            return _native_advance(compiled, model, data, *self.kernel_arguments())
        factor, step1, step2 = mujoco.mj_factorM, mujoco.mj_step1, mujoco.mj_step2
        cos, sin = math.cos, math.sin

        def advance(nstep: int, dt: float, wrench: Callable[[], tuple[float, float, float]] | None = None) -> None:
            wx, wy = wind[0], wind[1]  # the current changes between calls, not within one
            implicit_u, implicit_v, implicit_r = 2.0 * dt * k_u, dt * k_v, 2.0 * dt * k_r
            for _ in range(nstep if nstep > 0 else 1):
                psi = qpos[i_psi]
                xd = qvel[ix] - wx
                yd = qvel[iy] - wy
                r = qvel[ir]
                cp = cos(psi)
                sp = sin(psi)
                u = cp * xd + sp * yd
                v = cp * yd - sp * xd
                au = u if u >= 0.0 else -u  # abs() without the call; a -0.0 here changes no sum
                av = v if v >= 0.0 else -v
                ar = r if r >= 0.0 else -r
                X = neg_munk * r * v + a23 * r * r + X_uu * au * u
                if cross_flow:
                    Y = (neg_munk * u * r + (Y_vv * av + Y_vr * ar) * v + (Y_rv * av + Y_rr * ar) * r
                         + Y_uv * u * v + Y_ur * u * r)
                    N = (munk * u * v + (N_vv * av + N_vr * ar) * v + (N_rv * av + N_rr * ar) * r
                         + N_uv * u * v + N_ur * u * r)
                else:  # the same sums without their zero terms, which add exactly nothing
                    Y = neg_munk * u * r + Y_vv * av * v + Y_rr * ar * r + Y_uv * u * v + Y_ur * u * r
                    N = munk * u * v + N_vv * av * v + N_rr * ar * r + N_uv * u * v + N_ur * u * r
                if wrench is None:
                    qfrc[ix] += cp * X - sp * Y
                    qfrc[iy] += sp * X + cp * Y
                    qfrc[ir] += N
                else:
                    fx, fy, mz = wrench()
                    qfrc[ix] += cp * X - sp * Y + fx
                    qfrc[iy] += sp * X + cp * Y + fy
                    qfrc[ir] += N + mz
                b11 = a11 + implicit_u * au
                excess = implicit_v * av - sway_mass
                b22 = a22 + excess if excess > 0.0 else a22
                cc = cp * cp
                ss = sp * sp
                cs = cp * sp
                M[m_xx] += b11 * cc + b22 * ss
                M[m_yx] += (b11 - b22) * cs
                M[m_yy] += b11 * ss + b22 * cc
                M[m_rx] -= a23 * sp
                M[m_ry] += a23 * cp
                M[m_rr] += a33 + implicit_r * ar
                factor(model, data)
                if nstep:
                    step2(model, data)
                    step1(model, data)

        return advance


def _native_advance(compiled: NativeKernel, model: mujoco.MjModel, data: mujoco.MjData, coefficients: np.ndarray,
                    indices: np.ndarray) -> Callable[..., None]:
    """`Hydrodynamics.bind`'s stepper on the C loop: one ctypes call per `advance(nstep, dt)`, or one per
    step when a disturbance `wrench()` must be read at each step's time and heading."""
    if (len(coefficients), len(indices)) != compiled.sizes:
        raise RuntimeError(f"hydro_kernel.c expects {compiled.sizes} values, auv_mj gives "
                           f"{(len(coefficients), len(indices))}: the two are out of step")
    vp = ctypes.c_void_p
    wrench_now = np.zeros(3)
    keep = (model, data, coefficients, indices, wrench_now)  # owners of every address below
    head = (vp(model._address), vp(data._address), *compiled.functions, vp(coefficients.ctypes.data),
            vp(indices.ctypes.data), *(vp(a.ctypes.data) for a in (data.qpos, data.qvel, data.qfrc_passive,
                                                                     data.M, model.opt.wind)))
    wrench_at = vp(wrench_now.ctypes.data)
    step, c_int, c_double = compiled.advance, ctypes.c_int, ctypes.c_double

    def advance(nstep: int, dt: float, wrench: Callable[[], tuple[float, float, float]] | None = None,
                _keep=keep) -> None:
        if wrench is None:
            step(*head, None, c_int(nstep), c_double(dt))
            return
        for _ in range(nstep if nstep > 0 else 1):
            wrench_now[:] = wrench()
            step(*head, wrench_at, c_int(1 if nstep else 0), c_double(dt))

    return advance
