"""`auv-mj manoeuvre`: a scripted zig-zag of the vehicle in a walled channel, printing track and sonar.

The classic zig-zag manoeuvre (here in yaw moment rather than rudder angle): run straight up to speed,
then put tau_r hard over to port; when the heading passes +angle, hard over to starboard; when it
passes -angle, back to port; and so on. The overshoot angles and the period characterise the
vehicle's yaw response (Eq. 3 with REMUS's coefficients); the sonars (Sec. 2.2) see the channel walls.
"""

from __future__ import annotations

import argparse
import math
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from auv_mj.arena import load
from auv_mj.physics import AUVPhysics

CHANNEL_HALF_WIDTH = 12.0
"""Distance [m] from the start line to each channel wall."""
CHANNEL_LENGTH = 400.0
"""Length [m] of the channel, which starts 20 m behind the vehicle."""
WALL_HALF_THICKNESS = 0.5
ZIGZAG_ANGLE = 20.0
"""Heading switch angle [deg] (a 20/20 zig-zag)."""
SURGE_FORCE = 10.0
"""Constant tau_u [N] during the manoeuvre (steady surge about 2.5 m/s)."""
YAW_MOMENT = 5.0
"""Magnitude [N m] of the bang-bang tau_r."""
APPROACH_TIME = 15.0
"""Straight run [s] before the first switch, to reach a steady surge speed."""


def channel_arena(half_width: float = CHANNEL_HALF_WIDTH, length: float = CHANNEL_LENGTH) -> ET.Element:
    """Arena MJCF (in memory) of a straight channel along +x: walls at y = +-half_width, an end wall."""
    root = ET.Element("mujoco")
    worldbody = ET.SubElement(root, "worldbody")
    t = WALL_HALF_THICKNESS
    centre_x = length / 2 - 20.0
    for name, y in (("wall_port", half_width + t), ("wall_starboard", -half_width - t)):
        ET.SubElement(worldbody, "geom", name=name, type="box", pos=f"{centre_x} {y} 0",
                      size=f"{length / 2} {t} 2", rgba="0.5 0.5 0.55 1")
    ET.SubElement(worldbody, "geom", name="wall_end", type="box", pos=f"{centre_x + length / 2 + t} 0 0",
                  size=f"{t} {half_width + 2 * t} 2", rgba="0.5 0.5 0.55 1")
    return root


@dataclass(frozen=True)
class ZigZagResult:
    """Track of a zig-zag: rows (t, x, y, psi, u, v, r, tau_r) at every physics step, and the sonar."""

    track: np.ndarray
    sonar: np.ndarray
    """Rows (t, S1..S9) [s, m] sampled at the sonar rate of 2 Hz (Sec. 2.2)."""
    switch_times: np.ndarray
    """Times [s] of the first helm order (end of the approach) and of every switch after it."""
    overshoots: np.ndarray
    """Heading overshoot beyond the switch angle after each switch, until the next one [deg]."""

    @property
    def period(self) -> float:
        """Mean time [s] of one full zig-zag cycle (two switches), NaN before one cycle is complete."""
        cycles = np.diff(self.switch_times[1::2])
        return float(np.mean(cycles)) if len(cycles) else math.nan


def zigzag(physics: AUVPhysics, duration: float, angle_deg: float = ZIGZAG_ANGLE, surge: float = SURGE_FORCE,
           yaw_moment: float = YAW_MOMENT, approach: float = APPROACH_TIME,
           sonar_period: float = 0.5) -> ZigZagResult:
    """Runs the zig-zag (bang-bang tau_r on the heading, switching at +-angle) and records it."""
    angle = math.radians(angle_deg)
    heading0 = physics.pose()[2]
    dt = physics.timestep()
    steps = int(round(duration / dt))
    sonar_every = max(1, int(round(sonar_period / dt)))
    track, sonar, switches, overshoots = [], [], [], []
    tau_r, peak = 0.0, 0.0
    for k in range(steps):
        t = physics.time()
        psi = physics.pose()[2] - heading0
        if t >= approach - dt / 2:  # time accumulates rounding errors
            if tau_r == 0.0:
                tau_r = yaw_moment
                switches.append(t)
            elif (tau_r > 0 and psi >= angle) or (tau_r < 0 and psi <= -angle):
                if len(switches) > 1:
                    overshoots.append(peak)
                tau_r, peak = -tau_r, 0.0
                switches.append(t)
            if len(switches) > 1:
                peak = max(peak, abs(psi) - angle)
        if k % sonar_every == 0:
            sonar.append((t, *physics.sonar()))
        physics.set_control([surge, tau_r])
        physics.step()
        track.append((physics.time(), *physics.pose(), *physics.body_velocity(), tau_r))
    return ZigZagResult(np.array(track), np.array(sonar), np.array(switches), np.degrees(overshoots))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj manoeuvre`."""
    parser.add_argument("--duration", type=float, default=60.0, help="simulated time [s] (default 60)")
    parser.add_argument("--angle", type=float, default=ZIGZAG_ANGLE,
                        help=f"heading switch angle [deg] (default {ZIGZAG_ANGLE:g}: a 20/20 zig-zag)")
    parser.add_argument("--tau-u", type=float, default=SURGE_FORCE,
                        help=f"surge force [N] (default {SURGE_FORCE:g})")
    parser.add_argument("--tau-r", type=float, default=YAW_MOMENT,
                        help=f"bang-bang yaw moment [N m] (default {YAW_MOMENT:g})")
    parser.add_argument("--approach", type=float, default=APPROACH_TIME,
                        help=f"straight run before the first switch [s] (default {APPROACH_TIME:g})")
    parser.add_argument("--print-every", type=float, default=2.0, help="track print interval [s] (default 2)")
    parser.add_argument("--half-width", type=float, default=CHANNEL_HALF_WIDTH,
                        help=f"channel half width [m] (default {CHANNEL_HALF_WIDTH:g})")


def run(args: argparse.Namespace) -> int:
    """`auv-mj manoeuvre`: runs the zig-zag and prints the track, the sonar and the zig-zag figures."""
    if not (args.duration > 0 and args.print_every > 0 and args.half_width > 1.0 and 0 < args.angle < 90):
        raise SystemExit("auv-mj manoeuvre: need duration > 0, print-every > 0, half-width > 1 m "
                         "and 0 < angle < 90")
    wall_clock = time.perf_counter()
    physics = load(channel_arena(args.half_width))
    result = zigzag(physics, args.duration, args.angle, args.tau_u, args.tau_r, args.approach)
    elapsed = time.perf_counter() - wall_clock

    print(f"{args.angle:g}/{args.angle:g} zig-zag: tau_u = {args.tau_u:g} N, tau_r = +-{args.tau_r:g} N m "
          f"after {args.approach:g} s, channel walls at y = +-{args.half_width:g} m, "
          f"dt = {physics.timestep():g} s")
    print(f"{'t [s]':>7} {'x [m]':>8} {'y [m]':>7} {'psi [deg]':>9} {'u [m/s]':>8} {'v [m/s]':>8} "
          f"{'r [deg/s]':>9} {'tau_r':>6}   sonar S1..S9 [m] (120 = no echo)")
    every = max(1, int(round(args.print_every / physics.timestep())))
    sonar_times = result.sonar[:, 0]
    for row in result.track[every - 1::every]:
        t, x, y, psi, u, v, r, tau_r = row
        ranges = result.sonar[np.searchsorted(sonar_times, t + 1e-9) - 1, 1:]
        print(f"{t:7.1f} {x:8.2f} {y:7.2f} {math.degrees(psi):9.2f} {u:8.3f} {v:8.3f} {math.degrees(r):9.2f} "
              f"{tau_r:6.1f}   " + " ".join(f"{d:5.1f}" for d in ranges))
    overshoots = ", ".join(f"{o:.1f}" for o in result.overshoots) or "none"
    print(f"switches at t = {', '.join(f'{t:.1f}' for t in result.switch_times)} s")
    print(f"overshoot angles [deg]: {overshoots}; period {result.period:.1f} s")
    print(f"closest wall by sonar: {result.sonar[:, 1:].min():.2f} m; "
          f"{args.duration:g} s simulated in {elapsed:.2f} s wall clock")
    return 0
