"""Small planar geometry shared by every layer: the one angle wrap, and a point as messages write it."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle):
    """Angle(s) [rad] wrapped to [-pi, pi); a float for a scalar, an array for an array."""
    if np.ndim(angle) == 0:
        return (float(angle) + math.pi) % (2 * math.pi) - math.pi
    return (np.asarray(angle, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def xy_text(point) -> str:
    """A point (x, y) as messages write it: "x, y" to 0.1 m."""
    return f"{point[0]:.1f}, {point[1]:.1f}"
