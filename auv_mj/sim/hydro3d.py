"""Six-degree-of-freedom hydrodynamics of the REMUS-100 (Prestero 2001; Fossen 2011, Ch. 6-8), issue 32.

MuJoCo integrates the rigid body: M_RB and C_RB(nu) (with the centre of gravity z_g below the origin) and
the weight W = m g at the centre of gravity. This module adds the water's part of Fossen's equation

    M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + D(nu_r) nu_r + g(eta) = tau,

with nu_r = nu - nu_c the velocity relative to the water: the added mass M_A (6x6, Prestero's couplings
Y_rdot, Z_qdot), its Coriolis C_A(nu_r), the quadratic drag, the body and fin lift, the fins (u^2 delta, with
angle and rate limits) and the buoyancy B at the centre of buoyancy (the other half of g(eta)). Thrust is a
MuJoCo actuator (`thrust`).

How it enters MuJoCo's step (`Hydro3D.bind`), the planar scheme of `auv_mj.sim.hydrodynamics` in 6-DOF.
The free joint's velocity is qvel = (v_world, omega_body): the linear velocity of the body origin in the
world frame and the angular velocity in the body frame, so nu = J qvel with J = diag(R^T, I) (R the body's
rotation). Then nu1_dot = R^T v_world_dot - omega x nu1 and, for an irrotational current constant in the world,
nu_c1_dot = -omega x nu_c1, so M_A nu_r_dot = M_A J qacc - M_A (omega x nu_r1, 0). The added mass therefore goes
into the joint-space inertia as J^T M_A J (implicit, stable although M_A's heave and sway parts exceed the
hull's mass) and the rest is a body-frame force

    f = -C_A(nu_r) nu_r + M_A (omega x nu_r1, 0) - D(nu_r) nu_r + lift(nu_r) + fins(u_r, delta),

added to qfrc_passive as (R f_lin, f_ang), with the buoyancy (0, 0, B) at the origin (the centre of buoyancy).
With w = p = q = 0 the u, v, r rows of f are the planar model's body force term for term.

Frames. The MJCF's body frame is x forward, y port, z up (FLU); Prestero's coefficients are in his x forward,
y starboard, z down (FRD) frame, the same frame turned by pi about x. `force_frd` evaluates his force law in
his frame; `FLU_TO_FRD` turns velocities there and forces back. The current is `model.opt.wind` (world frame,
m/s), as in the plane; MuJoCo's own fluid model stays off (density 0).

The quadratic drag is linearly implicit where one explicit step would reverse a velocity, exactly as in the
planar model: K = 2 |X_uu| |u_r| in surge, 2 |N_rr| |r| in yaw, and by symmetry 2 |K_pp| |p| in roll and
2 |M_qq| |q| in pitch; sway and heave stay explicit except K = max(0, |c| |v_r| - m / dt). So the held-planar
6-DOF model and the planar model take the same steps.

The stepper runs in C by default (`bind_native`, `hydro3d_kernel.c`: one call per `AUV3DPhysics.step(n)`); this
module's NumPy loop (`bind`) is the reference and the fallback (`AUV_MJ_NATIVE=0`, or no C compiler), several
times slower (`auv-mj bench --section physics3d`).
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable
from dataclasses import dataclass, fields

import mujoco
import numpy as np

from auv_mj.inputs import parse_xml
from auv_mj.sim import native3d

NUMERIC_PREFIX = "hydro_"
FIN_RATE_NUMERIC = "fin_rate"
"""The MJCF numeric holding the fins' rate limit [rad/s]."""
FLU_TO_FRD = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
"""T: (u, v, w, p, q, r) and (X, Y, Z, K, M, N) between MuJoCo's FLU body frame and Prestero's FRD one (T = T^-1)."""
ROOT_JOINT = "root"
"""The vehicle's free joint."""
ACTUATORS = ("thrust", "rudder", "stern")
"""The public actuators: thrust [N], rudder and stern-plane angles [rad], in this order."""
NON_POSITIVE = ("X_udot", "Y_vdot", "Z_wdot", "K_pdot", "M_qdot", "N_rdot", "X_uu", "Y_vv", "Z_ww", "K_pp",
                "M_qq", "N_rr")
"""Coefficients that are <= 0 in the SNAME convention: added mass adds inertia, drag takes energy out."""
SYMMETRIC = (("M_wdot", "Z_qdot"), ("N_vdot", "Y_rdot"))
"""Pairs M_A's symmetry makes equal (a non-symmetric added mass would create energy)."""
MAX_COEFFICIENT = 1e6
"""Largest |coefficient| accepted (SI units)."""
SYMMETRY_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Hydro3DCoefficients:
    """Prestero's derivatives in SNAME notation, SI units, FRD frame (the tables are cited in models/auv6.xml)."""

    X_udot: float
    Y_vdot: float
    Y_rdot: float
    Z_wdot: float
    Z_qdot: float
    K_pdot: float
    M_wdot: float
    M_qdot: float
    N_vdot: float
    N_rdot: float
    X_uu: float
    Y_vv: float
    Y_rr: float
    Z_ww: float
    Z_qq: float
    K_pp: float
    M_ww: float
    M_qq: float
    N_vv: float
    N_rr: float
    Y_uv: float
    Y_ur: float
    Z_uw: float
    Z_uq: float
    M_uw: float
    M_uq: float
    N_uv: float
    N_ur: float
    Y_uudr: float
    N_uudr: float
    Z_uuds: float
    M_uuds: float
    B: float
    """Buoyancy [N] (Prestero's measured value), acting upwards at the centre of buoyancy, the body origin."""

    def added_mass(self) -> np.ndarray:
        """M_A [kg, kg m, kg m^2] in the FRD frame: minus the acceleration derivatives of Table C.5."""
        a = np.zeros((6, 6))
        a[0, 0] = -self.X_udot
        a[1, 1], a[1, 5], a[5, 1], a[5, 5] = -self.Y_vdot, -self.Y_rdot, -self.N_vdot, -self.N_rdot
        a[2, 2], a[2, 4], a[4, 2], a[4, 4] = -self.Z_wdot, -self.Z_qdot, -self.M_wdot, -self.M_qdot
        a[3, 3] = -self.K_pdot
        return a

    @classmethod
    def from_mapping(cls, values: dict[str, object], source: str = "<dict>") -> Hydro3DCoefficients:
        """Coefficients from {"X_udot": ..., ...}; a ValueError names the file and any missing or bad field."""
        kwargs = {}
        for name in COEFFICIENT_NAMES:
            numeric = f'<numeric name="{NUMERIC_PREFIX}{name}">'
            if name not in values:
                raise ValueError(f"{source}: missing 6-DOF hydrodynamic coefficient {numeric}")
            try:
                value = float(values[name])
            except (TypeError, ValueError):
                raise ValueError(f"{source}: {numeric} has data={values[name]!r}, which is not a number") from None
            if not math.isfinite(value) or abs(value) > MAX_COEFFICIENT:
                raise ValueError(f"{source}: {numeric} = {value!r} must be finite and within +-{MAX_COEFFICIENT:g}")
            if name in NON_POSITIVE and value > 0:
                raise ValueError(f"{source}: {numeric} = {value:g} must be <= 0 (SNAME convention: added mass "
                                 "adds inertia, drag takes energy out)")
            kwargs[name] = value
        for a, b in SYMMETRIC:
            if abs(kwargs[a] - kwargs[b]) > SYMMETRY_TOLERANCE * max(1.0, abs(kwargs[b])):
                raise ValueError(f"{source}: {NUMERIC_PREFIX}{a} = {kwargs[a]:g} must equal {NUMERIC_PREFIX}{b} = "
                                 f"{kwargs[b]:g}: the added-mass matrix is symmetric")
        if kwargs["B"] <= 0:
            raise ValueError(f"{source}: {NUMERIC_PREFIX}B = {kwargs['B']:g} must be a positive buoyancy [N]")
        return cls(**kwargs)


COEFFICIENT_NAMES = tuple(f.name for f in fields(Hydro3DCoefficients))
"""The coefficients' names, in the dataclass's order (`<numeric name="hydro_NAME">`)."""


@dataclass(frozen=True)
class VehicleSpec3D:
    """What the MJCF says of the 6-DOF vehicle beyond MuJoCo's own model: coefficients and fin rate limit."""

    coefficients: Hydro3DCoefficients
    fin_rate: float
    """Largest fin slew rate [rad/s] (`<numeric name="fin_rate">`)."""


def spec_from_xml(xml: str, source: str = "<string>") -> VehicleSpec3D | None:
    """The `hydro_*` numerics and `fin_rate` of MJCF text, or None when it has no `hydro_*` numeric."""
    root = parse_xml(xml, source, "6-DOF vehicle MJCF")
    return _spec_from_numerics(((numeric.get("name", ""), (numeric.get("data") or "").split())
                                for numeric in root.iter("numeric")), source)


def spec_from_model(model: mujoco.MjModel, source: str = "model") -> VehicleSpec3D | None:
    """`spec_from_xml` of a compiled model: its numerics as MuJoCo compiled them (the vehicle's facts read from the
    compiled MJCF, with no second parse of its text at every reload)."""
    data, first, size = model.numeric_data, model.numeric_adr, model.numeric_size
    return _spec_from_numerics(((mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i),
                                 data[first[i]:first[i] + size[i]].tolist()) for i in range(model.nnumeric)), source)


def _spec_from_numerics(numerics, source: str) -> VehicleSpec3D | None:
    """The spec from (name, values) pairs of an MJCF's numerics (`spec_from_xml`: the data's words,
    `spec_from_model`: the compiled numbers)."""
    values: dict[str, object] = {}
    fin_rate: object = None
    known = set(COEFFICIENT_NAMES)
    for name, data in numerics:
        if name == FIN_RATE_NUMERIC:
            fin_rate = data[0] if len(data) == 1 else " ".join(map(str, data))
        if not name.startswith(NUMERIC_PREFIX):
            continue
        key = name[len(NUMERIC_PREFIX):]
        if key not in known:
            raise ValueError(f'{source}: unknown 6-DOF coefficient <numeric name="{name}">; known: '
                             f"{', '.join(NUMERIC_PREFIX + k for k in sorted(known))}")
        if len(data) != 1:
            raise ValueError(f'{source}: <numeric name="{name}"> must have exactly one value, got data='
                             f'{" ".join(map(str, data))!r}')
        values[key] = data[0]
    if not values:
        return None
    coefficients = Hydro3DCoefficients.from_mapping(values, source)
    try:
        rate = float(fin_rate)
    except (TypeError, ValueError):
        raise ValueError(f'{source}: <numeric name="{FIN_RATE_NUMERIC}"> must give the fin rate limit [rad/s], '
                         f"got {fin_rate!r}") from None
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f'{source}: <numeric name="{FIN_RATE_NUMERIC}"> = {rate!r} must be a positive rate [rad/s]')
    return VehicleSpec3D(coefficients, rate)


def force_frd(c: Hydro3DCoefficients, added_mass: np.ndarray, nu: np.ndarray, rudder: float,
              stern: float) -> np.ndarray:
    """The body force f of the module docstring, in Prestero's FRD frame, at relative velocity `nu` (FRD).

    -C_A(nu) nu + M_A (omega x nu1, 0) (the added-mass terms of Fossen 2011, Eq. 6.43, in MuJoCo's velocity
    coordinates), minus the quadratic drag, plus the body/fin lift and the fin forces u^2 delta (Table C.10).
    """
    u, v, w, p, q, r = (float(x) for x in nu)
    a = added_mass @ nu
    a1, a2, a3, b1, b2, b3 = (float(x) for x in a)
    c1, c2, c3 = q * w - r * v, r * u - p * w, p * v - q * u  # omega x nu1
    m = added_mass
    # -C_A nu = (a1 x nu2, a1 x nu1 + b x nu2), a = M_A nu; then + M_A (omega x nu1, 0).
    X = a2 * r - a3 * q + m[0, 0] * c1
    Y = a3 * p - a1 * r + m[1, 1] * c2
    Z = a1 * q - a2 * p + m[2, 2] * c3
    K = a2 * w - a3 * v + b2 * r - b3 * q
    M = a3 * u - a1 * w + b3 * p - b1 * r + m[4, 2] * c3
    N = a1 * v - a2 * u + b1 * q - b2 * p + m[5, 1] * c2
    uu = u * u
    X += c.X_uu * abs(u) * u
    Y += c.Y_vv * abs(v) * v + c.Y_rr * abs(r) * r + c.Y_uv * u * v + c.Y_ur * u * r + c.Y_uudr * uu * rudder
    Z += c.Z_ww * abs(w) * w + c.Z_qq * abs(q) * q + c.Z_uw * u * w + c.Z_uq * u * q + c.Z_uuds * uu * stern
    K += c.K_pp * abs(p) * p
    M += c.M_ww * abs(w) * w + c.M_qq * abs(q) * q + c.M_uw * u * w + c.M_uq * u * q + c.M_uuds * uu * stern
    N += c.N_vv * abs(v) * v + c.N_rr * abs(r) * r + c.N_uv * u * v + c.N_ur * u * r + c.N_uudr * uu * rudder
    return np.array([X, Y, Z, K, M, N])


def fin_forces_frd(c: Hydro3DCoefficients, u: float, rudder: float, stern: float) -> np.ndarray:
    """The fins' part of `force_frd` alone (Table C.10): (0, Y_uudr, Z_uuds, 0, M_uuds, N_uudr) u^2 delta."""
    uu = u * u
    return np.array([0.0, c.Y_uudr * uu * rudder, c.Z_uuds * uu * stern, 0.0, c.M_uuds * uu * stern,
                     c.N_uudr * uu * rudder])


def slew(angle: float, command: float, rate: float, dt: float) -> float:
    """The fin angle after dt [s]: towards `command` at no more than `rate` [rad/s] (the servo's rate limit)."""
    step = rate * dt
    return angle + min(step, max(-step, command - angle))


class Hydro3D:
    """Applies the water's forces of the module docstring to the free-jointed vehicle of a compiled model."""

    def __init__(self, model: mujoco.MjModel, spec: VehicleSpec3D, source: str = "model"):
        self.spec = spec
        self.coefficients = c = spec.coefficients
        try:
            joint = model.joint(ROOT_JOINT)
        except KeyError:
            raise ValueError(f'{source}: the 6-DOF vehicle needs a free joint named "{ROOT_JOINT}"') from None
        if joint.type[0] != mujoco.mjtJoint.mjJNT_FREE:
            raise ValueError(f'{source}: joint "{ROOT_JOINT}" must be a free joint')
        self.body = body = int(joint.bodyid[0])
        if model.body_simple[body]:
            raise ValueError(f"{source}: body '{model.body(body).name}' is 'simple' to MuJoCo (diagonal mass "
                             "matrix), which cannot hold the coupled added mass: put its centre of gravity off the "
                             'origin, e.g. <inertial pos="0 0 -0.0196">')
        self.qpos_adr = int(joint.qposadr[0])
        self.dof_adr = int(joint.dofadr[0])
        self.added_mass_frd = c.added_mass()
        self.added_mass = FLU_TO_FRD[:, None] * self.added_mass_frd * FLU_TO_FRD[None, :]
        mass = float(model.body_mass[body])
        inertia = model.body_inertia[body]
        com = model.body_ipos[body]
        self.rigid_body_mass = _rigid_body_mass(mass, inertia, com)
        self.total_mass = self.rigid_body_mass + self.added_mass
        if np.any(np.linalg.eigvalsh(self.total_mass) <= 0):
            raise ValueError(f"{source}: M_RB + M_A is not positive definite; added-mass derivatives are <= 0 in "
                             "the SNAME convention")
        rows, cols = np.tril_indices(6)
        index = []
        for i in range(6):  # where row i's columns 0..i of the free joint's block sit in MuJoCo's sparse M
            row = self.dof_adr + i
            start = int(model.M_rowadr[row])
            columns = model.M_colind[start:start + model.M_rownnz[row]].tolist()
            for j in range(i + 1):
                if columns.count(self.dof_adr + j) != 1:
                    raise ValueError(f"{source}: the free joint's dofs must form a dense block of the mass matrix")
                index.append(start + columns.index(self.dof_adr + j))
        self._m_index, self._m_rows, self._m_cols = np.array(index), rows, cols
        # Drag slopes |dF/dx| / |x| of each dof's own quadratic drag (FRD and FLU agree: T K T = K).
        self._drag = np.array([-c.X_uu, -c.Y_vv, -c.Z_ww, -c.K_pp, -c.M_qq, -c.N_rr])
        self._explicit = np.array([False, True, True, False, False, False])  # sway and heave, as the planar sway
        self._mass_diagonal = self.total_mass.diagonal().copy()

    def body_velocity(self, data: mujoco.MjData, current=None) -> np.ndarray:
        """nu = (u, v, w, p, q, r) in the FLU body frame [m/s, rad/s], relative to `current` (world, m/s) if given."""
        rotation = self.rotation(data)
        qvel = data.qvel[self.dof_adr:self.dof_adr + 6]
        linear = qvel[:3] if current is None else qvel[:3] - np.asarray(current, dtype=float)
        return np.concatenate([rotation.T @ linear, qvel[3:]])

    def rotation(self, data: mujoco.MjData) -> np.ndarray:
        """R: body (FLU) to world."""
        out = np.empty(9)
        mujoco.mju_quat2Mat(out, data.qpos[self.qpos_adr + 3:self.qpos_adr + 7])
        return out.reshape(3, 3)

    def body_force(self, nu_r: np.ndarray, rudder: float = 0.0, stern: float = 0.0) -> np.ndarray:
        """f of the module docstring in the FLU body frame at the relative velocity `nu_r` (FLU), fins in rad."""
        return FLU_TO_FRD * force_frd(self.coefficients, self.added_mass_frd, FLU_TO_FRD * nu_r, rudder, stern)

    def implicit_damping(self, nu_r: np.ndarray, dt: float) -> np.ndarray:
        """The diagonal dt K added to the inertia (module docstring): backward Euler on the drag of surge, roll,
        pitch and yaw; in sway and heave only what stops one explicit step from reversing the velocity."""
        speed = np.abs(nu_r)
        implicit = np.where(self._explicit, np.maximum(0.0, dt * self._drag * speed - self._mass_diagonal),
                            2.0 * dt * self._drag * speed)
        return implicit

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData, rudder: float, stern: float, dt: float,
              wrench: np.ndarray | None = None) -> None:
        """Adds the body force, the buoyancy and `wrench` (world force, world torque) to qfrc_passive and
        J^T (M_A + dt K) J to the joint-space inertia, which it re-factors. Call after `mj_step1`/`mj_forward`."""
        rotation = self.rotation(data)
        dof = self.dof_adr
        qvel = data.qvel[dof:dof + 6]
        linear = rotation.T @ (qvel[:3] - model.opt.wind)
        nu_r = np.concatenate([linear, qvel[3:]])
        f = self.body_force(nu_r, rudder, stern)
        force = rotation @ f[:3]
        torque = f[3:].copy()
        force[2] += self.coefficients.B
        if wrench is not None:
            force += wrench[:3]
            torque += rotation.T @ wrench[3:]
        data.qfrc_passive[dof:dof + 3] += force
        data.qfrc_passive[dof + 3:dof + 6] += torque
        inertia = self.added_mass.copy()
        inertia[np.diag_indices(6)] += self.implicit_damping(nu_r, dt)
        jacobian = np.zeros((6, 6))
        jacobian[:3, :3] = rotation.T
        jacobian[3:, 3:] = np.eye(3)
        joint_space = jacobian.T @ inertia @ jacobian
        data.M[self._m_index] += joint_space[self._m_rows, self._m_cols]
        mujoco.mj_factorM(model, data)

    def bind(self, model: mujoco.MjModel, data: mujoco.MjData) -> Callable[..., None]:
        """The stepper `advance(nstep, dt, fins, wrench=None)` of this vehicle in (`model`, `data`).

        `fins` is a callable(dt) -> (rudder, stern) that advances the fin angles by one step and returns them.
        Each step applies the forces, then `mj_step2` and `mj_step1`; nstep = 0 only applies them (with dt = 0,
        for `mj_forward`'s accelerations).
        """
        step1, step2, apply = mujoco.mj_step1, mujoco.mj_step2, self.apply

        def advance(nstep: int, dt: float, fins: Callable[[float], tuple[float, float]],
                    wrench: Callable[[], np.ndarray] | None = None) -> None:
            for _ in range(nstep if nstep > 0 else 1):
                rudder, stern = fins(dt)
                apply(model, data, rudder, stern, dt, None if wrench is None else wrench())
                if nstep:
                    step2(model, data)
                    step1(model, data)

        return advance

    def kernel_arguments(self, source_index: int, limits: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
        """hydro3d_kernel.c's parameters (native3d.COEFFICIENTS among them) and addresses for this vehicle, its fins'
        commands at `source_index` of their source array, within `limits` (2, 2) at `rate` [rad/s]."""
        c = self.coefficients
        parameters = np.concatenate([self.added_mass_frd.ravel(), self.added_mass.ravel(),
                                     [getattr(c, name) for name in native3d.COEFFICIENTS], self._drag,
                                     self._explicit.astype(float), self._mass_diagonal,
                                     [rate, *np.asarray(limits, dtype=float).ravel()]])
        indices = np.array([self.qpos_adr, self.dof_adr, *self._m_index, source_index],
                           dtype=np.dtype(ctypes.c_long))
        return parameters, indices

    def bind_native(self, model: mujoco.MjModel, data: mujoco.MjData, fins: np.ndarray, source: np.ndarray,
                    source_index: int, limits: np.ndarray, rate: float) -> Callable[..., None] | None:
        """`bind`'s stepper on the C loop (`auv_mj.sim.native3d`), or None where it cannot be built.

        The C loop slews the fin angles itself: `fins` (2,) is their state, updated in place, towards the
        commands source[source_index], source[source_index + 1] (data.ctrl, or data.act when lagged), within
        `limits` (2, 2) at `rate` [rad/s]; the `fins` callable `advance` is given is not called.
        """
        compiled = native3d.kernel()
        if compiled is None:
            return None
        parameters, indices = self.kernel_arguments(source_index, limits, rate)
        if (len(parameters), len(indices)) != compiled.sizes:
            raise RuntimeError(f"hydro3d_kernel.c expects {compiled.sizes} values, auv_mj gives "
                               f"{(len(parameters), len(indices))}: the two are out of step")
        vp = ctypes.c_void_p
        wrench_now = np.zeros(6)
        keep = (model, data, parameters, indices, wrench_now, fins, source)  # owners of every address below
        head = (vp(model._address), vp(data._address), *compiled.functions, vp(parameters.ctypes.data),
                vp(indices.ctypes.data), *(vp(a.ctypes.data) for a in (data.qpos, data.qvel, data.qfrc_passive,
                                                                         data.M, model.opt.wind)))
        tail = (vp(fins.ctypes.data), vp(source.ctypes.data))
        wrench_at = vp(wrench_now.ctypes.data)
        step, c_int, c_double = compiled.advance, ctypes.c_int, ctypes.c_double

        def advance(nstep: int, dt: float, fins_step=None, wrench: Callable[[], np.ndarray] | None = None,
                    _keep=keep) -> None:
            if wrench is None:
                step(*head, None, *tail, c_int(nstep), c_double(dt))
                return
            for _ in range(nstep if nstep > 0 else 1):
                wrench_now[:] = wrench()
                step(*head, wrench_at, *tail, c_int(1 if nstep else 0), c_double(dt))

        return advance


def _rigid_body_mass(mass: float, inertia: np.ndarray, com: np.ndarray) -> np.ndarray:
    """M_RB about the body origin (Fossen 2011, Eq. 3.44), FLU, for a body of `mass`, principal `inertia` about
    its centre of gravity at `com` (axes aligned with the body frame)."""
    s = np.array([[0.0, -com[2], com[1]], [com[2], 0.0, -com[0]], [-com[1], com[0], 0.0]])
    out = np.zeros((6, 6))
    out[:3, :3] = mass * np.eye(3)
    out[:3, 3:] = -mass * s
    out[3:, :3] = mass * s
    out[3:, 3:] = np.diag(inertia) - mass * s @ s
    return out
