"""Classical control of the 6-DOF vehicle: the executor the 3-D tasks run, and the baseline learned 3-D control
must beat.

- `DepthHeadingController`: the S-plane of Eq. (32) (`auv_mj.control.splane.s_plane`) on three channels: surge speed
  through the thrust (with the planar drag feed-forward and integrator), heading through the rudder, and depth
  through the pitch and the stern planes, cascaded: the depth error sets a pitch command, the pitch error sets
  the stern planes. A slow depth integrator finds the nose-down trim that holds the positively buoyant REMUS
  down. It is the executor of `depth_heading` and the inner loop of the 3-D planning tasks.
- `los_command`: line-of-sight guidance in 3-D (Fossen 2011, Ch. 10): heading to the look-ahead point in the
  horizontal plane, its depth as the depth command.

Gains were set by hand on `depth_heading` (paper schedule, ideal conditions), comparing sets by their
MAE (speed, heading, depth): the defaults give (0.003 m/s, 0.036 rad, 0.198 m); the first heading gains
(k1 6, k2 8, ki 0.05) gave 0.084 rad. They are `DepthHeadingGains`. `OCEAN_DEPTH_GAINS` are the same controller
re-tuned in ocean water (`experiments/depth_tuning.py`), the fair baseline of a learned depth executor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from auv_mj.control.splane import s_plane
from auv_mj.geometry import nearest_on_polyline, wrap_angle

EXECUTOR_DT = 0.1
"""The 3-D executor's period [s], as the planar executor's."""
THRUST_LIMIT = 20.0
"""|thrust| of the `thrust` actuator [N] (models/auv6.xml ctrlrange)."""
FIN_LIMIT = 0.237
"""|fin angle| [rad]: Prestero's stall angle, the `rudder` and `stern` ctrlrange of models/auv6.xml."""
SURGE_DRAG = 1.62
"""-X_uu [N s^2/m^2] of models/auv6.xml (Prestero's axial drag), for the thrust feed-forward."""


@dataclass(frozen=True)
class DepthHeadingGains:
    """S-plane gains of the three channels (module docstring)."""

    k1_speed: float = 50.146
    """Weight of the speed error [s/m] (the planar S-plane's tuned value: the surge dynamics are the same)."""
    k2_speed: float = 0.554
    ki_speed: float = 0.43
    k1_heading: float = 12.0
    """Weight of the heading error [1/rad]: the rudder saturates beyond ~0.15 rad of error."""
    k2_heading: float = 12.0
    """Weight of the yaw rate [s/rad]: damps the directionally unstable hull."""
    ki_heading: float = 0.3
    k1_depth: float = 1.0
    """Weight of the depth error [1/m] in the pitch command."""
    k2_depth: float = 2.0
    """Weight of the depth rate [s/m]."""
    ki_depth: float = 0.01
    """Depth integrator [rad/(m s)]: the nose-down trim against the positive buoyancy."""
    max_pitch: float = 0.25
    """Largest pitch command [rad] (14 deg): steeper, the Munk moment outgrows the stern planes."""
    k1_pitch: float = 10.0
    """Weight of the pitch error [1/rad] in the stern-plane angle."""
    k2_pitch: float = 6.0
    """Weight of the pitch rate [s/rad]."""
    band_depth: float = 2.0
    """The depth integrator runs only while |e_depth| is below this [m] (integral separation)."""
    integral_limit: float = 0.5
    """Bound on each integral contribution (fraction of its channel's range)."""


OCEAN_DEPTH_GAINS = DepthHeadingGains(k1_speed=25.56, k2_speed=1.006, ki_speed=0.3016, k1_heading=28.69,
                                      k2_heading=20.87, ki_heading=0.09276, k1_depth=1.466, k2_depth=0.9919,
                                      ki_depth=0.007252, max_pitch=0.4973, k1_pitch=14.57, k2_pitch=6.808)
"""The gains re-tuned in ocean water from the hand-set ones, the printed optimum of `python -m
experiments/depth_tuning.py --tune --max-evaluations 250` (4 training episodes of random command schedules in ocean
water; cost 1.012 -> 0.835: MAE speed 0.031 -> 0.029 m/s, heading 0.251 -> 0.197 rad, depth 1.17 -> 0.80 m, 237
evaluations). The largest change is the pitch limit, 0.25 -> 0.50 rad: the re-tuned loop dives and climbs twice as
steeply, which the cascade's stern loop (k_pitch1 10 -> 14.6) still holds. The strongest classical depth executor
in ocean water; policy `splane-ocean` on depth_heading."""

SCHEDULED_GAINS = ("k1_speed", "k2_speed", "k1_heading", "k2_heading", "k1_depth", "k2_depth", "k1_pitch",
                   "k2_pitch")
"""The S-surface gains a gain-scheduling executor sets each step (`DepthHeadingController.__call__`'s `scale`):
error and rate weights of the four S-planes."""


@dataclass(frozen=True)
class State3D:
    """What the executor reads of the vehicle (its sensors): body velocity, attitude, depth."""

    u: float
    v: float
    w: float
    p: float
    q: float
    """Pitch rate about the body y (port) axis [rad/s]: positive pitches the nose down."""
    r: float
    roll: float
    pitch: float
    """Nose-up positive [rad]."""
    heading: float
    depth: float

    @property
    def depth_rate(self) -> float:
        """d depth / dt [m/s] from the body velocity and attitude."""
        st, ct = math.sin(self.pitch), math.cos(self.pitch)
        sf, cf = math.sin(self.roll), math.cos(self.roll)
        return -(self.u * st + self.v * ct * sf + self.w * ct * cf)


class DepthHeadingController:
    """(V_cmd, psi_cmd, depth_cmd), State3D -> (thrust [N], rudder [rad], stern [rad]) every EXECUTOR_DT."""

    def __init__(self, gains: DepthHeadingGains | None = None):
        self.gains = gains or DepthHeadingGains()
        self.reset()

    def reset(self) -> None:
        """Zero integrators (an episode start)."""
        self._integral = np.zeros(3)
        self._last_u: float | None = None

    @property
    def integrals(self) -> np.ndarray:
        """The speed, heading and depth integral contributions (each within +-integral_limit)."""
        return self._integral.copy()

    @property
    def last_speed(self) -> float | None:
        """The surge speed of the last call (its rate is the speed channel's derivative), None after a reset."""
        return self._last_u

    def __call__(self, command: Sequence[float], state: State3D, scale: Sequence[float] | None = None) -> np.ndarray:
        """(thrust [N], rudder [rad], stern [rad]) for command (V_cmd, psi_cmd, depth_cmd) and `state`.

        `scale` multiplies the SCHEDULED_GAINS for this call only (a gain-scheduling executor's action); None
        leaves the gains as they are."""
        g = self.gains
        if scale is not None:
            g = replace(g, **{name: getattr(g, name) * float(f) for name, f in zip(SCHEDULED_GAINS, scale,
                                                                                     strict=True)})
        v_cmd, psi_cmd, depth_cmd = (float(c) for c in command)
        e_v = v_cmd - state.u
        e_psi = wrap_angle(psi_cmd - state.heading)
        e_d = depth_cmd - state.depth
        u_dot = 0.0 if self._last_u is None else (state.u - self._last_u) / EXECUTOR_DT
        self._last_u = state.u
        limit = g.integral_limit
        if abs(e_v) < 0.2:
            self._integral[0] = np.clip(self._integral[0] + g.ki_speed * e_v * EXECUTOR_DT, -limit, limit)
        if abs(e_psi) < 0.2:
            self._integral[1] = np.clip(self._integral[1] + g.ki_heading * e_psi * EXECUTOR_DT, -limit, limit)
        if abs(e_d) < g.band_depth:
            self._integral[2] = np.clip(self._integral[2] + g.ki_depth * e_d * EXECUTOR_DT / g.max_pitch,
                                        -limit, limit)
        feed = SURGE_DRAG * v_cmd * abs(v_cmd) / THRUST_LIMIT
        thrust = THRUST_LIMIT * (s_plane(e_v, -u_dot, g.k1_speed, g.k2_speed) + feed + self._integral[0])
        rudder = FIN_LIMIT * (s_plane(e_psi, -state.r, g.k1_heading, g.k2_heading) + self._integral[1])
        # To go deeper the nose goes down: the pitch command is minus the depth channel's S-surface.
        pitch_cmd = -g.max_pitch * (s_plane(e_d, -state.depth_rate, g.k1_depth, g.k2_depth) + self._integral[2])
        pitch_cmd = min(max(pitch_cmd, -g.max_pitch), g.max_pitch)
        # Positive stern pitches the nose down: act on (pitch - command) and the nose-up rate -q.
        stern = FIN_LIMIT * s_plane(state.pitch - pitch_cmd, -state.q, g.k1_pitch, g.k2_pitch)
        return np.array([min(max(thrust, -THRUST_LIMIT), THRUST_LIMIT), min(max(rudder, -FIN_LIMIT), FIN_LIMIT),
                         min(max(stern, -FIN_LIMIT), FIN_LIMIT)])


def los_command(position: Sequence[float], path: np.ndarray, lookahead: float, speed: float,
                ) -> tuple[float, float, float]:
    """(V_cmd, psi_cmd, depth_cmd) towards the point `lookahead` metres ahead along `path` (K, 3) (world, z up).

    The vehicle's nearest path point is found, the look-ahead point is the point of the path that far further
    on (the last point at the end); heading and depth of the command are its bearing and its depth.
    """
    path = np.asarray(path, dtype=float)
    here = np.asarray(position, dtype=float)
    k, along, lengths = nearest_on_polyline(path, here) if len(path) >= 2 else (0, 0.0, np.zeros(0))
    if not np.any(lengths > 0):
        target = path[-1]
    else:
        arc = np.concatenate([[0.0], np.cumsum(lengths)])
        s = arc[k] + along * lengths[k] + lookahead
        if s >= arc[-1]:
            target = path[-1]
        else:
            j = int(np.searchsorted(arc, s, side="right") - 1)
            target = path[j] + (s - arc[j]) / max(lengths[j], 1e-12) * (path[j + 1] - path[j])
    heading = math.atan2(target[1] - here[1], target[0] - here[0])
    return speed, heading, -float(target[2])
