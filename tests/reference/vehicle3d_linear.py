"""An independent linear model of the 6-DOF REMUS (`models/auv6.xml`) and the simulator probes that test it.

The linear model (`Linear6`) is Fossen's (2011) body-frame equation

    (M_RB + M_A) nu_dot + C_RB(nu) nu + C_A(nu) nu - D(nu) nu + g(eta) = tau

linearised by hand in Prestero's frame (x forward, y starboard, z down) about a steady motion
nu0 = (u0, 0, w0, 0, 0, 0) with zero roll and pitch: every term is written out in `force_jacobian`, from
the rigid-body equations about the centre of buoyancy (Fossen 2011, Eq. 3.53 with r_g = (0, 0, z_g)), the
added-mass Coriolis force -C_A(nu) nu = (a x omega, a x nu1 + b x omega) with (a, b) = M_A nu (Eq. 6.43),
g(eta) of Eq. 4.6, and Prestero's drag, lift and fin terms. It calls no auv_mj code: the coefficients come in
from the project's reader and the rigid body from the compiled model (`Linear6.from_physics`), as numbers.

The probes (`simulated_jacobian`, `release_pitch_period`, `open_loop_run`) run the simulator itself, MuJoCo's
rigid body with `auv_mj.sim.hydro3d` inside its step, so that tests/sim/test_stability_3d.py can hold the two
against each other. `python tests/reference/vehicle3d_linear.py` prints every figure of docs/physics.md, "The 6-DOF
vehicle: trim, stability and sources".
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy.optimize import fsolve

STATES = ("u", "v", "w", "p", "q", "r", "phi", "theta")
"""The linear model's state: body velocities (FRD) and the roll and pitch angles (yaw and position drop out)."""
LONGITUDINAL = ("u", "w", "q", "theta")
LATERAL = ("v", "p", "r", "phi")
"""About nu0 = (u0, 0, w0, 0, 0, 0) the two sets decouple exactly: together they are the whole linear model."""
HORIZONTAL = ("v", "r")
VERTICAL = ("w", "q", "theta")
"""The textbook plane models (surge u and roll p held): Prestero 2001, Sec. 5; Fossen 2011, Sec. 7.5."""
CRUISE_SPEED = 1.54
"""[m/s] Prestero's trim speed for REMUS (his propeller thrust X_prop = 3.86 N is quoted at about this speed)."""
JACOBIAN_STEP = 1e-5
"""The difference step of `simulated_jacobian` [m/s, rad/s, rad]."""
RELEASE_DEPTH = 50.0
RELEASE_PITCH = 0.05
"""[rad] The nose-up pitch a release starts from (any small value: the rising vehicle ends on the same cycle)."""
RELEASE_TIME = 100.0
RELEASE_SETTLE = 40.0
"""[s] A release's period is measured over (RELEASE_SETTLE, RELEASE_TIME]: the heave transient (its time
constant (m - Z_wdot) / (2 |Z_ww| w_rise) is 1.6 s) and the growth of the pitch oscillation are over by then."""


@dataclasses.dataclass(frozen=True)
class Linear6:
    """The REMUS of a coefficient set, linearised (module docstring). Every matrix is in Prestero's FRD frame."""

    c: Any
    """The coefficients, with attributes X_udot, ..., M_uuds, B (a `Hydro3DCoefficients`)."""
    m: float
    inertia: np.ndarray
    """Principal moments of inertia about the centre of gravity (I_xx, I_yy, I_zz) [kg m^2]."""
    z_g: float
    """The centre of gravity below the centre of buoyancy, the body origin [m]."""
    gravity: float

    @classmethod
    def from_physics(cls, physics) -> Linear6:
        """From an `AUV3DPhysics`: its coefficients as the project reads them, its compiled rigid body."""
        model = physics.model.ptr
        body = physics.hydrodynamics.body
        com = model.body_ipos[body]
        if abs(com[0]) > 0 or abs(com[1]) > 0 or np.any(model.body_iquat[body] != [1.0, 0.0, 0.0, 0.0]):
            raise ValueError("Linear6 needs the centre of gravity on the body's z axis and principal axes along it")
        return cls(physics.hydrodynamics.coefficients, float(model.body_mass[body]), model.body_inertia[body].copy(),
                   -float(com[2]), -float(model.opt.gravity[2]))

    @property
    def weight(self) -> float:
        return self.m * self.gravity

    def replace(self, **coefficients: float) -> Linear6:
        """The same vehicle with some coefficients changed (e.g. B = W, neutrally buoyant)."""
        return dataclasses.replace(self, c=dataclasses.replace(self.c, **coefficients))

    def mass_matrix(self) -> np.ndarray:
        """M_RB + M_A about the centre of buoyancy: I_o = I_g + m z_g^2 in roll and pitch, the m z_g couplings of
        surge with pitch and sway with roll (Fossen 2011, Eq. 3.44), minus Prestero's acceleration derivatives."""
        c, m, zg = self.c, self.m, self.z_g
        out = np.zeros((6, 6))
        out[:3, :3] = m * np.eye(3)
        out[3:, 3:] = np.diag(self.inertia + m * zg * zg * np.array([1.0, 1.0, 0.0]))
        out[0, 4] = out[4, 0] = m * zg
        out[1, 3] = out[3, 1] = -m * zg
        out[0, 0] -= c.X_udot
        out[1, 1] -= c.Y_vdot
        out[1, 5] -= c.Y_rdot
        out[5, 1] -= c.N_vdot
        out[5, 5] -= c.N_rdot
        out[2, 2] -= c.Z_wdot
        out[2, 4] -= c.Z_qdot
        out[4, 2] -= c.M_wdot
        out[4, 4] -= c.M_qdot
        out[3, 3] -= c.K_pdot
        return out

    def force_jacobian(self, u0: float, w0: float = 0.0) -> np.ndarray:
        """d(X, Y, Z, K, M, N)/d(u, v, w, p, q, r, phi, theta) of everything but M nu_dot, at nu0 = (u0, 0, w0, 0, 0,
        0), phi = theta = 0, fins at zero (6 x 8). The thrust is a constant and drops out."""
        c, m, zg, W, B = self.c, self.m, self.z_g, self.weight, self.c.B
        U, V, Wv, P, Q, R, PHI, TH = range(8)
        X, Y, Z, K, M, N = range(6)
        f = np.zeros((6, 8))
        # -C_A nu = (a x omega, a x nu1 + b x omega), a = M_A nu1-part: a_x = -X_udot u, a_z = -Z_wdot w - Z_qdot q,
        # a_y = -Y_vdot v - Y_rdot r; b_y = -M_wdot w - M_qdot q, b_z = -N_vdot v - N_rdot r, b_x = -K_pdot p.
        f[X, Q] += c.Z_wdot * w0                                  # a_y r - a_z q
        f[Y, P] += -c.Z_wdot * w0                                 # a_z p - a_x r
        f[Y, R] += c.X_udot * u0
        f[Z, Q] += -c.X_udot * u0                                 # a_x q - a_y p
        f[K, V] += (c.Z_wdot - c.Y_vdot) * w0                     # a_y w - a_z v + b_y r - b_z q
        f[K, R] += -(c.Y_rdot + c.M_wdot) * w0
        f[M, U] += (c.X_udot - c.Z_wdot) * w0                     # a_z u - a_x w + b_z p - b_x r
        f[M, Wv] += (c.X_udot - c.Z_wdot) * u0
        f[M, Q] += -c.Z_qdot * u0
        f[N, V] += (c.Y_vdot - c.X_udot) * u0                     # a_x v - a_y u + b_x q - b_y p
        f[N, R] += c.Y_rdot * u0
        f[N, P] += c.M_wdot * w0
        # -C_RB nu: X = m(u_dot - v r + w q + z_g(p r + q_dot)), Y = m(v_dot - w p + u r + z_g(q r - p_dot)),
        # Z = m(w_dot - u q + v p - z_g(p^2 + q^2)), K = I_x p_dot - m z_g(v_dot - w p + u r) + .., M = I_y q_dot +
        # m z_g(u_dot - v r + w q) + .., N = I_z r_dot + .. (the products of two rates are second order).
        f[X, Q] += -m * w0
        f[Y, P] += m * w0
        f[Y, R] += -m * u0
        f[Z, Q] += m * u0
        f[K, P] += -m * zg * w0
        f[K, R] += m * zg * u0
        f[M, Q] += -m * zg * w0
        # -g(eta), CB at the origin (Eq. 4.6): g = ((W - B) s_theta, -(W - B) c_theta s_phi, -(W - B) c_theta c_phi,
        # z_g W c_theta s_phi, z_g W s_theta, 0).
        f[X, TH] += -(W - B)
        f[Y, PHI] += W - B
        f[K, PHI] += -zg * W
        f[M, TH] += -zg * W
        # Prestero's drag c |x| x (slope 2 c |x0|) and lift c u x, linearised.
        f[X, U] += 2.0 * c.X_uu * abs(u0)
        f[Z, Wv] += 2.0 * c.Z_ww * abs(w0)
        f[M, Wv] += 2.0 * c.M_ww * abs(w0)
        f[Y, V] += c.Y_uv * u0
        f[Y, R] += c.Y_ur * u0
        f[Z, U] += c.Z_uw * w0
        f[Z, Wv] += c.Z_uw * u0
        f[Z, Q] += c.Z_uq * u0
        f[M, U] += c.M_uw * w0
        f[M, Wv] += c.M_uw * u0
        f[M, Q] += c.M_uq * u0
        f[N, V] += c.N_uv * u0
        f[N, R] += c.N_ur * u0
        return f

    def state_matrix(self, u0: float, w0: float = 0.0, states: tuple[str, ...] = STATES) -> np.ndarray:
        """A of x_dot = A x over `states` (a subset of STATES); the velocities left out are held at nu0.

        With all of STATES, or LONGITUDINAL / LATERAL, this is the linearisation itself; HORIZONTAL and VERTICAL
        hold u and p as the textbook plane models do. phi_dot = p and theta_dot = q at zero roll and pitch.
        """
        index = [STATES.index(s) for s in states]
        dofs = [i for i in index if i < 6]
        mass = self.mass_matrix()[np.ix_(dofs, dofs)]
        force = self.force_jacobian(u0, w0)[np.ix_(dofs, index)]
        out = np.zeros((len(index), len(index)))
        out[:len(dofs)] = np.linalg.solve(mass, force)
        for row, i in enumerate(index):
            if i >= 6:
                rate = STATES.index("p" if STATES[i] == "phi" else "q")
                if rate not in index:
                    raise ValueError(f"states {states}: {STATES[i]} needs its rate {STATES[rate]}")
                out[row, index.index(rate)] = 1.0
        return out

    def cruise_thrust(self, u0: float) -> float:
        """[N] The thrust of a steady straight run at u0: -X_uu u0 |u0|."""
        return -self.c.X_uu * u0 * abs(u0)

    def rising_equilibrium(self) -> np.ndarray:
        """(u, w, theta) of the unpowered vehicle's steady motion, fins at zero (FRD: w < 0 rises).

        X: X_uu |u| u - (W - B) sin theta = 0; Z: Z_ww |w| w + Z_uw u w + (W - B) cos theta = 0;
        M: M_ww |w| w + (M_uw + X_udot - Z_wdot) u w - z_g W sin theta = 0 (q = 0, so no Coriolis term but the
        Munk moment (X_udot - Z_wdot) u w is left). With B > W it rises at about sqrt((B - W) / -Z_ww) with a
        small drift and tilt; the guess starts there.
        """
        c, W, B = self.c, self.weight, self.c.B

        def residual(x: np.ndarray) -> list[float]:
            u, w, th = x
            return [c.X_uu * abs(u) * u - (W - B) * math.sin(th),
                    c.Z_ww * abs(w) * w + c.Z_uw * u * w + (W - B) * math.cos(th),
                    c.M_ww * abs(w) * w + (c.M_uw + c.X_udot - c.Z_wdot) * u * w - self.z_g * W * math.sin(th)]

        guess = [0.0, -math.copysign(math.sqrt(abs(B - W) / -c.Z_ww), B - W), 0.0]
        solution, _, found, message = fsolve(residual, guess, xtol=1e-13, full_output=True)
        if found != 1 or max(abs(r) for r in residual(solution)) > 1e-9:
            raise RuntimeError(f"no steady unpowered motion found: {message}")
        return solution

    def pitch_period(self, u0: float = 0.0, w0: float = 0.0) -> float:
        """[s] 2 pi / omega of the longitudinal oscillation (the pitch mode) about (u0, w0)."""
        roots = np.linalg.eigvals(self.state_matrix(u0, w0, LONGITUDINAL))
        oscillating = roots[roots.imag > 1e-9]
        if len(oscillating) != 1:
            raise RuntimeError(f"expected one oscillating longitudinal mode, got roots {roots}")
        return 2.0 * math.pi / float(oscillating[0].imag)

    def pitch_period_formula(self, w_rise: float = 0.0) -> float:
        """[s] The small-angle pitch period in closed form, 2 pi / omega with

            omega^2 = (M^-1)_qq [z_g W + (m z_g (B - W) + (X_udot - Z_wdot + M_uw) (m - Z_wdot) w_rise^2)
                                 / (m - X_udot)],

        M the whole mass matrix, w_rise the vertical speed through the water (0 at the instant of release). The
        first term is the centre of gravity under the centre of buoyancy. The others come through the surge: the net
        buoyancy's component (B - W) theta along the axis accelerates the hull, a pitch moment through M_RB's m z_g
        coupling of surge and pitch; and a rising hull pitching at q turns its heave momentum into surge,
        (m - X_udot) u_dot = (Z_wdot - m) w q, so u follows (m - Z_wdot) / (m - X_udot) |w| theta, which the Munk
        and lift moment (X_udot - Z_wdot + M_uw) u w turns back towards level. The formula lets the surge follow
        the pitch at once (at rest it has neither stiffness nor a drag slope); the roots of `state_matrix` are the
        linear model's exact answer.
        """
        c, m, zg, weight = self.c, self.m, self.z_g, self.weight
        inertia = np.linalg.inv(self.mass_matrix())[4, 4]
        munk = (c.X_udot - c.Z_wdot + c.M_uw) * (m - c.Z_wdot) * w_rise ** 2
        surge = (m * zg * (c.B - weight) + munk) / (m - c.X_udot)
        return 2.0 * math.pi / math.sqrt(inertia * (zg * weight + surge))

    def pitch_alone_period(self) -> float:
        """[s] 2 pi sqrt((I_yy - M_qdot) / (z_g W)): pitch with every other motion held, as models/auv6.xml's
        header used to give for the vehicle (its I_yy about the CG; the centre of buoyancy adds m z_g^2)."""
        return 2.0 * math.pi * math.sqrt((self.inertia[1] - self.c.M_qdot) / (self.z_g * self.weight))


# --- the simulator's side ----------------------------------------------------------------------------------------

FLIP = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
"""FRD to MuJoCo's FLU body frame and back, for velocities, accelerations and forces alike."""


def simulated_acceleration(physics, x: np.ndarray, thrust: float) -> np.ndarray:
    """nu_dot (FRD) of the simulator at state x over STATES (FRD), fins at zero, deep water.

    MuJoCo's free joint moves in qvel = (world linear velocity, body angular velocity); the body-frame linear
    acceleration is R^T v_dot - omega x nu1 (both FLU).
    """
    from auv_mj.sim.physics3d import set_pose

    nu = FLIP * np.asarray(x[:6], dtype=float)
    set_pose(physics, (0.0, 0.0, -RELEASE_DEPTH), roll=float(x[6]), pitch=float(x[7]), nu=nu)
    physics.reset_fins()
    physics.set_control([thrust, 0.0, 0.0])
    physics.forward()
    qacc = physics.data.qacc[physics.hydrodynamics.dof_adr:physics.hydrodynamics.dof_adr + 6]
    linear = physics.rotation().T @ qacc[:3] - np.cross(nu[3:], nu[:3])
    return FLIP * np.concatenate([linear, qacc[3:]])


def simulated_jacobian(physics, u0: float, w0: float = 0.0, thrust: float = 0.0,
                       step: float = JACOBIAN_STEP) -> np.ndarray:
    """The simulator's A over STATES at (u0, 0, w0, 0, 0, 0), zero attitude, by differences of its accelerations;
    the angle rows are the kinematics phi_dot = p, theta_dot = q of zero roll and pitch.

    A central difference D(h) of the drag c |x| x across x = 0 is c h, not its slope 0; of a smooth term it is the
    slope + O(h^2). 2 D(h / 2) - D(h) removes the first exactly and keeps the second's O(h^2).
    """
    x0 = np.zeros(len(STATES))
    x0[0], x0[2] = u0, w0

    def central(h: float) -> np.ndarray:
        out = np.zeros((6, len(STATES)))
        for j in range(len(STATES)):
            e = np.zeros(len(STATES))
            e[j] = h
            out[:, j] = (simulated_acceleration(physics, x0 + e, thrust)
                         - simulated_acceleration(physics, x0 - e, thrust)) / (2.0 * h)
        return out

    out = np.zeros((len(STATES), len(STATES)))
    out[:6] = 2.0 * central(step / 2.0) - central(step)
    out[6, 3] = out[7, 4] = 1.0
    return out


def release_pitch_period(physics, pitch: float = RELEASE_PITCH, duration: float = RELEASE_TIME,
                         settle: float = RELEASE_SETTLE) -> tuple[float, float]:
    """(period [s], pitch amplitude [rad]) of the vehicle released at rest at `pitch`, thrust and fins at zero:
    the mean interval between upward zero crossings of the pitch rate after `settle` (the rate's mean is zero,
    where the pitch angle's drifts with the rise), and half the pitch's range over the last period."""
    from auv_mj.sim.physics3d import set_pose

    set_pose(physics, (0.0, 0.0, -RELEASE_DEPTH), pitch=pitch)
    physics.reset_fins()
    physics.set_control([0.0, 0.0, 0.0])
    steps = int(round(duration / physics.model.opt.timestep))
    times, rate, angle = np.empty(steps), np.empty(steps), np.empty(steps)
    for k in range(steps):
        physics.step()
        times[k], rate[k], angle[k] = physics.time(), physics.body_velocity()[4], physics.attitude()[1]
    up = np.flatnonzero((rate[:-1] < 0.0) & (rate[1:] >= 0.0) & (times[:-1] > settle))
    crossings = times[up] - rate[up] * (times[up + 1] - times[up]) / (rate[up + 1] - rate[up])
    if len(crossings) < 3:
        raise RuntimeError(f"the released vehicle's pitch rate crossed zero upwards {len(crossings)} times")
    period = float(np.mean(np.diff(crossings)))
    last = times > times[-1] - period
    return period, float(np.ptp(angle[last]) / 2.0)


def open_loop_run(physics, u0: float, thrust: float, duration: float, every: float = 1.0) -> np.ndarray:
    """Rows (t, x, y, depth, roll, pitch, heading, u) [s, m, rad, m/s] every `every` s of a straight, level run
    started at u0 with this thrust and the fins held at zero (MuJoCo's frames: heading counter-clockwise)."""
    from auv_mj.sim.physics3d import set_pose

    set_pose(physics, (0.0, 0.0, -RELEASE_DEPTH), nu=(u0, 0.0, 0.0, 0.0, 0.0, 0.0))
    physics.reset_fins()
    physics.set_control([thrust, 0.0, 0.0])
    chunk = int(round(every / physics.model.opt.timestep))
    rows = [(0.0, *physics.position()[:2], physics.depth(), *physics.attitude(), u0)]
    for _ in range(int(round(duration / every))):
        physics.step(chunk)
        rows.append((physics.time(), *physics.position()[:2], physics.depth(), *physics.attitude(),
                     physics.body_velocity()[0]))
    return np.array(rows)


def _roots(matrix: np.ndarray) -> str:
    roots = sorted(np.linalg.eigvals(matrix), key=lambda z: (-z.real, -z.imag))
    return ", ".join(f"{z.real:+.4f}" + (f" {z.imag:+.4f}j" if abs(z.imag) > 1e-9 else "") for z in roots)


def main() -> None:
    """Prints the figures of docs/physics.md's 6-DOF section."""
    from auv_mj import model_path
    from auv_mj.sim.physics3d import AUV3DPhysics

    physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    model = Linear6.from_physics(physics)
    c, u0 = model.c, CRUISE_SPEED
    print(f"m = {model.m} kg, W = {model.weight:.3f} N, B = {c.B} N, B - W = {c.B - model.weight:.3f} N, "
          f"z_g = {model.z_g} m")
    thrust = model.cruise_thrust(u0)
    analytic, simulated = model.state_matrix(u0), simulated_jacobian(physics, u0, thrust=thrust)
    print(f"\nstraight run at u0 = {u0} m/s (thrust {thrust:.3f} N), states {STATES}")
    print(f"  max |A_analytic - A_simulator| = {np.abs(analytic - simulated).max():.2e} "
          f"(largest entry {np.abs(analytic).max():.2f})")
    for name, states in (("lateral (v, p, r, phi)", LATERAL), ("longitudinal (u, w, q, theta)", LONGITUDINAL),
                         ("horizontal plane (v, r)", HORIZONTAL), ("vertical plane (w, q, theta)", VERTICAL)):
        print(f"  {name:32s} {_roots(model.state_matrix(u0, 0.0, states))}")
    print(f"  simulator, all 8 states          {_roots(simulated)}")
    print(f"  analytic, all 8 states           {_roots(analytic)}")

    neutral = model.replace(B=model.weight)
    print("\npitch period, small angles")
    print(f"  pitch alone, 2 pi sqrt((I_yy - M_qdot) / (z_g W))      {model.pitch_alone_period():.3f} s")
    print(f"  neutral (B = W), coupled to surge and heave            {neutral.pitch_period():.3f} s  "
          f"(formula {neutral.pitch_period_formula():.3f} s)")
    print(f"  as built, at the instant of release (w = 0)            {model.pitch_period():.3f} s  "
          f"(formula {model.pitch_period_formula():.3f} s)")
    equilibrium = model.rising_equilibrium()
    print(f"  rising equilibrium (u, w, theta) = {np.array2string(equilibrium, precision=5)} (FRD)")
    period = model.pitch_period(equilibrium[0], equilibrium[1])
    roots = _roots(model.state_matrix(equilibrium[0], equilibrium[1], LONGITUDINAL))
    print(f"  as built, about the rising equilibrium                 {period:.3f} s  (roots {roots})")
    print(f"  formula at the rise rate sqrt((B - W) / -Z_ww)         "
          f"{model.pitch_period_formula(math.sqrt((c.B - model.weight) / -c.Z_ww)):.3f} s")
    measured, amplitude = release_pitch_period(AUV3DPhysics.from_xml_path(model_path("auv6.xml")))
    print(f"  simulator, released at rest at {RELEASE_PITCH} rad                {measured:.3f} s  "
          f"(pitch amplitude {amplitude:.4f} rad after {RELEASE_TIME:g} s)")
    heavy_drag = model.replace(Z_ww=c.Y_vv)
    rise = heavy_drag.rising_equilibrium()
    print(f"  with Z_ww = Y_vv = {c.Y_vv:g}: rises at {-rise[1]:.3f} m/s, period "
          f"{heavy_drag.pitch_period(rise[0], rise[1]):.3f} s")

    duration = 300.0
    run = open_loop_run(AUV3DPhysics.from_xml_path(model_path("auv6.xml")), u0, thrust, duration)
    late = run[:, 0] >= 100.0
    t, heading = run[late, 0], np.unwrap(run[late, 6])
    turn = np.polyfit(t, heading, 1)[0]
    descent = np.polyfit(t, run[late, 3], 1)[0]
    speed = float(np.mean(run[late, 7]))
    print(f"\nopen-loop straight run, fins at zero, {duration:g} s from {RELEASE_DEPTH:g} m: depth "
          f"{run[-1, 3]:.1f} m; from 100 s on: turn {turn:+.4f} rad/s (positive: to port), descent "
          f"{descent:.3f} m/s, u {speed:.3f} m/s, radius u / r = {speed / abs(turn):.1f} m, "
          f"roll {np.degrees(run[late, 4]).mean():+.1f} deg, pitch {np.degrees(run[late, 5]).min():+.1f} to "
          f"{np.degrees(run[late, 5]).max():+.1f} deg")
    from vehicle3d_reference import Reference3D

    start = np.zeros(12)
    start[2], start[6] = RELEASE_DEPTH, u0
    reference = Reference3D.from_xml().solve(start, duration, lambda t: (thrust, 0.0, 0.0))
    print(f"  the scipy reference (tests/reference/vehicle3d_reference.py): depth {reference(duration)[2]:.2f} m "
          f"against the simulator's {run[-1, 3]:.2f} m")
    text = model_path("auv6.xml").read_text()
    for name, old, new in (("B = W", f'name="hydro_B" data="{c.B!r}"', f'name="hydro_B" data="{model.weight!r}"'),
                           ("B = W and no propeller torque", 'gear="1 0 0 -0.1407 0 0"', 'gear="1 0 0 0 0 0"')):
        if old not in text:
            raise RuntimeError(f"models/auv6.xml has no {old}")
        text = text.replace(old, new)
        run = open_loop_run(AUV3DPhysics.from_xml_string(text), u0, thrust, duration)
        print(f"  and with {name}: depth change {run[-1, 3] - run[0, 3]:+.3f} m, heading change "
              f"{np.unwrap(run[:, 6])[-1] - run[0, 6]:+.3f} rad")


if __name__ == "__main__":
    main()
