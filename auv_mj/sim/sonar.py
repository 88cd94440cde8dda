"""The nine single-beam obstacle-avoidance sonars S1..S9 of Sec. 2.2 (MuJoCo rangefinders)."""

from __future__ import annotations

import numpy as np

SONAR_RANGE = 120.0
"""Maximum detection range [m]; a beam that sees nothing reads this (Sec. 2.2)."""
SONAR_RATE_HZ = 2.0
"""Sampling frequency of the sonars [Hz] (Sec. 2.2)."""
SONAR_NAMES = tuple(f"sonar_{i}" for i in range(1, 10))
BEAM_ANGLES = np.linspace(-np.pi / 2, np.pi / 2, 9)
"""Beam directions in the body frame [rad]: S1 starboard (-90 deg) ... S5 ahead ... S9 port (+90 deg)."""


def clip_ranges(raw: np.ndarray) -> np.ndarray:
    """Rangefinder readings -> sonar ranges: no hit (-1) or beyond range reads SONAR_RANGE."""
    return np.where((raw < 0) | (raw > SONAR_RANGE), SONAR_RANGE, raw)


class SampleAndHold:
    """Holds the last sonar sample and refreshes it at SONAR_RATE_HZ of simulation time.

    Call `read(physics)` as often as you like; the rangefinders are only evaluated when a new
    sample is due (at t = 0, 0.5 s, 1 s, ... for 2 Hz), as a real 2 Hz sonar would deliver them.
    """

    def __init__(self, rate_hz: float = SONAR_RATE_HZ):
        if not rate_hz > 0:
            raise ValueError(f"sonar rate must be positive, got {rate_hz}")
        self.period = 1.0 / rate_hz
        self.reset()

    def reset(self) -> None:
        """Forgets the held sample; the next read samples afresh."""
        self._next_time = -np.inf
        self._held = np.full(len(SONAR_NAMES), SONAR_RANGE)

    def read(self, physics) -> np.ndarray:
        """The held ranges [m], sampling the physics when a new sample is due."""
        time = physics.time()
        if time >= self._next_time - 1e-9:
            self._held = physics.sonar()
            self._next_time = (np.floor(time / self.period + 1e-9) + 1) * self.period
        return self._held.copy()


def fence_ranges(origin: np.ndarray, heading, bounds) -> np.ndarray:
    """What the nine beams would read if the edge of the map were a wall (a geofence; ours).

    `origin`: the sonars' (x, y) [m]; `heading`: psi [rad]; `bounds`: the map (x_min, y_min, x_max, y_max) [m].
    Each beam (heading + BEAM_ANGLES) is followed to where it leaves the rectangle; the distance is capped at
    SONAR_RANGE, and is 0 for a beam from outside the map. The map's edge is no geom, so the rangefinders
    cannot see it; a vehicle that knows its map (the paper's 600 m square) knows this instead. Vectorised: origins
    (N, 2), headings (N,) and bounds (N, 4) give (N, 9).
    """
    origin, bounds = np.asarray(origin, dtype=float), np.asarray(bounds, dtype=float)
    x, y = origin[..., 0:1], origin[..., 1:2]
    x_min, y_min, x_max, y_max = (bounds[..., k:k + 1] for k in range(4))
    inside = (x_min <= x) & (x <= x_max) & (y_min <= y) & (y <= y_max)
    angles = np.asarray(heading, dtype=float)[..., None] + BEAM_ANGLES
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        to_x = np.where(c > 0, (x_max - x) / c, np.where(c < 0, (x_min - x) / c, np.inf))
        to_y = np.where(s > 0, (y_max - y) / s, np.where(s < 0, (y_min - y) / s, np.inf))
    return np.where(inside, np.minimum(np.minimum(to_x, to_y), SONAR_RANGE), 0.0)
