"""`auv-mj manoeuvre`: a scripted zig-zag of the vehicle in a walled channel, printing track and sonar.

The classic zig-zag manoeuvre (here in yaw moment rather than rudder angle): run straight up to speed,
then put tau_r hard over to port; when the heading passes +angle, hard over to starboard; when it
passes -angle, back to port; and so on. The overshoot angles and the period characterise the
vehicle's yaw response (Eq. 3 with REMUS's coefficients); the sonars (Sec. 2.2) see the channel walls.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from auv_mj.sim.physics import AUVPhysics

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
