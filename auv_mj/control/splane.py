"""The S-plane controller of Eq. (32): the classical speed/heading executor the paper compares DDPG to.

For each channel i (surge speed V, heading psi)

    u_i = 2 / (1 + exp(-k_i1 e_i - k_i2 edot_i)) - 1 + du_i,      f_i = K_i u_i,

with e_V = V_cmd - u (surge speed), edot_V = -du/dt (derivative on measurement: a change of command
gives no derivative kick), e_psi = wrap(psi_cmd - psi), edot_psi = -r, and K_i the actuator limits
(20 N, 10 N m for the REMUS-100), read from the vehicle MJCF's ctrlranges. The sigmoid alone is zero at
e = 0, so a plain S-plane leaves a steady error wherever a
steady force is needed; du_i is the bias term S-plane controllers add for that (Liu et al., ref. [26]):

    du_V   = -X_uu V_cmd |V_cmd| / K_u  +  k_V3 int e_V dt      (drag feed-forward + slow integrator)
    du_psi =                               k_psi3 int e_psi dt  (slow integrator)

The integrators only run while |e_i| is inside a band (integral separation, so that large steps do not
wind them up) and are clamped to |k_i3 int e_i| <= `integral_limit`: a constant disturbance (the 30 N
current of Sec. 4.2) is rejected, and nothing grows without bound. The output is clipped to [-K_i, K_i].

Default gains were tuned on the REMUS-100 model of `models/auv.xml` by Nelder-Mead (log-gains, within
TUNING_BOUNDS, from the sluggish hand-set INITIAL_GAINS, 400 cost evaluations) on a cost summing
(i) a 0 -> 1 m/s speed step, (ii) a 90 deg heading step at 1 m/s, (iii) a 1 -> 2 m/s step with a 60 deg
turn, each over 30 s, and (iv) the Sec. 4.2 disturbance episode (`auv_mj.tasks.speed_heading`, 1100 executor
steps), each scored by the mean absolute speed and heading error, plus penalties on heading overshoot
and on output chatter (so that the search does not drift to bang-bang gains).
The defaults are the printed optimum (cost 0.654 -> 0.288); reproduce with (about 17 min on one core)

    python experiments/splane_tuning.py --tune

which prints the cost breakdown of the current defaults, then the optimum and its breakdown. The optimum
is a steep S-surface (it saturates at |e_psi| ~ 0.03 rad) with strong rate damping.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass, field

import numpy as np

from auv_mj.geometry import wrap_angle
from auv_mj.sim.vehicle import vehicle_facts

EXECUTOR_DT = 0.1
"""Executor period [s]: the controller is called at 10 Hz (cross-team contract)."""
def s_plane(e: float, edot: float, k1: float, k2: float) -> float:
    """The S-surface of Eq. (32): 2 / (1 + exp(-k1 e - k2 edot)) - 1, in (-1, 1); equal to tanh(x / 2)."""
    return math.tanh(0.5 * (k1 * e + k2 * edot))


@dataclass(frozen=True)
class SPlaneGains:
    """Gains of the two S-plane channels of Eq. (32) (defaults tuned on REMUS-100, see module docstring)."""

    k1_speed: float = 50.146
    """k_V1: weight of the speed error e_V [s/m]."""
    k2_speed: float = 0.554
    """k_V2: weight of the speed-error rate -du/dt [s^2/m]."""
    ki_speed: float = 0.43
    """k_V3: integral gain of du_V [1/m], the normalised thrust added per metre of accumulated error."""
    k1_heading: float = 147.931
    """k_psi1: weight of the heading error e_psi [1/rad]."""
    k2_heading: float = 31.717
    """k_psi2: weight of the heading-error rate -r [s/rad]."""
    ki_heading: float = 0.66
    """k_psi3: integral gain of du_psi [1/(rad s)]."""
    band_speed: float = 0.2
    """The speed integrator runs only while |e_V| is below this [m/s] (integral separation)."""
    band_heading: float = 0.2
    """The heading integrator runs only while |e_psi| is below this [rad]."""
    integral_limit: float = 0.5
    """Bound on each integral contribution |k_i3 int e_i dt|, as a fraction of the actuator limit K_i."""
    surge_drag: float = field(default_factory=lambda: vehicle_facts().surge_drag)
    """-X_uu of the nominal vehicle MJCF (`hydro_X_uu`), used by the drag feed-forward of du_V [N s^2/m^2];
    0 switches the feed-forward off."""
    surge_limit: float = field(default_factory=lambda: vehicle_facts().surge_limit)
    """K_V: thrust of u_V = 1 [N] (the tau_u ctrlrange of the vehicle MJCF)."""
    yaw_limit: float = field(default_factory=lambda: vehicle_facts().yaw_limit)
    """K_psi: yaw moment of u_psi = 1 [N m] (the tau_r ctrlrange of the vehicle MJCF)."""
    dt: float = EXECUTOR_DT
    """Call period [s]: the integrators and the finite-difference speed rate use it."""


OCEAN_GAINS = SPlaneGains(k1_speed=62.893, k2_speed=0.566, ki_speed=0.381,
                          k1_heading=48.005, k2_heading=23.423, ki_heading=0.62)
"""The gains re-tuned in ocean conditions (lagged thrusters, current, scaled vehicle) from the nominal optimum,
the printed optimum of `python experiments/splane_tuning.py --tune --conditions ocean --max-evaluations 200` (training
seeds only; cost 0.827 -> 0.514, about 12 min on one core). The heading gain k_psi1 drops from 148 to 48: with
the 0.2 s yaw-moment lag the nominal steep S-surface keeps a heading limit cycle (output chatter 0.25 -> 0.04).
The strongest classical executor where the water is not ideal; policy `splane-ocean`."""


class SPlaneController:
    """Speed/heading executor of Eq. (32): `controller((V_cmd, psi_cmd), (u, v, r, psi)) -> [tau_u, tau_r]`.

    Call it every `gains.dt` seconds (EXECUTOR_DT); `reset()` at the start of an episode clears the
    integrators and the stored speed used for the rate estimate.
    """

    def __init__(self, gains: SPlaneGains | None = None):
        self.gains = gains if gains is not None else SPlaneGains()
        self.reset()

    @property
    def parameters(self) -> np.ndarray:
        """The gains as one array in `SPlaneGains`' field order: what the batched C step reads (`auv_mj.sim.batch`)."""
        return np.array(astuple(self.gains), dtype=float)

    @property
    def memory(self) -> tuple[float, float, float | None]:
        """What Eq. (32) carries from one call to the next: the integrals of e_V and e_psi, and the last surge
        speed u (None before the first call)."""
        return self._int_speed, self._int_heading, self._last_u

    def reset(self) -> None:
        """Forgets the integrators and the previous surge speed."""
        self._int_speed = 0.0
        self._int_heading = 0.0
        self._last_u: float | None = None

    def __call__(self, command: Sequence[float], state: Sequence[float],
                 scale: Sequence[float] | None = None) -> np.ndarray:
        """(tau_u [N], tau_r [N m]) for command (V_cmd, psi_cmd) and state (u, v, r, psi); Eq. (32).

        `scale` multiplies (k_V1, k_V2, k_psi1, k_psi2) for this call only (a gain-scheduling executor's
        action); None leaves the gains as they are."""
        g = self.gains
        k1_speed, k2_speed, k1_heading, k2_heading = g.k1_speed, g.k2_speed, g.k1_heading, g.k2_heading
        if scale is not None:
            k1_speed, k2_speed, k1_heading, k2_heading = (k * float(f) for k, f in zip(
                (k1_speed, k2_speed, k1_heading, k2_heading), scale, strict=True))
        v_cmd, psi_cmd = float(command[0]), float(command[1])
        u, _, r, psi = (float(s) for s in state[:4])
        e_v = v_cmd - u
        edot_v = 0.0 if self._last_u is None else -(u - self._last_u) / g.dt
        self._last_u = u
        e_psi = wrap_angle(psi_cmd - psi)
        edot_psi = -r

        self._int_speed = _integrate(self._int_speed, e_v, g.ki_speed, g.band_speed, g)
        self._int_heading = _integrate(self._int_heading, e_psi, g.ki_heading, g.band_heading, g)
        feed_forward = g.surge_drag * v_cmd * abs(v_cmd) / g.surge_limit
        du_v = feed_forward + g.ki_speed * self._int_speed
        du_psi = g.ki_heading * self._int_heading

        u_v = s_plane(e_v, edot_v, k1_speed, k2_speed) + du_v
        u_psi = s_plane(e_psi, edot_psi, k1_heading, k2_heading) + du_psi
        return np.array([g.surge_limit * np.clip(u_v, -1.0, 1.0), g.yaw_limit * np.clip(u_psi, -1.0, 1.0)])


def _integrate(integral: float, error: float, ki: float, band: float, g: SPlaneGains) -> float:
    """One step of a separated, clamped integrator: int e dt, kept to |ki int| <= integral_limit."""
    if abs(error) < band:
        integral += error * g.dt
    if ki > 0:
        bound = g.integral_limit / ki
        integral = min(max(integral, -bound), bound)
    return integral
