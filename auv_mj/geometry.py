"""Small geometry shared by every layer: the one angle wrap, polylines in the plane or in space, and a point as
messages write it.

The polyline functions take points of shape (..., 2) or (..., 3), so that the planar modules and their 3-D
counterparts (the grid and the voxels, the planar and the 6-DOF videos, line of sight along a tube) measure a route
with one piece of code. A length is `np.hypot` in the plane and `np.linalg.norm` in space (`segment_lengths`): the
two round differently in the last bit, and each domain keeps the one its results were recorded with.
"""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle):
    """Angle(s) [rad] wrapped to [-pi, pi); a float for a scalar, an array for an array."""
    if np.ndim(angle) == 0:
        return (float(angle) + math.pi) % (2 * math.pi) - math.pi
    return (np.asarray(angle, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def segment_lengths(vectors) -> np.ndarray:
    """The Euclidean length of each vector of `vectors` (..., d) [m]: `np.hypot` for d = 2, `np.linalg.norm` else."""
    vectors = np.asarray(vectors, dtype=float)
    if vectors.shape[-1] == 2:
        return np.hypot(vectors[..., 0], vectors[..., 1])
    return np.linalg.norm(vectors, axis=-1)


def polyline_length(path) -> float:
    """Length [m] of the polyline `path` (m, d); 0 for fewer than two points."""
    path = np.asarray(path, dtype=float)
    return float(np.sum(segment_lengths(np.diff(path, axis=0)))) if len(path) > 1 else 0.0


def arc_lengths(path) -> np.ndarray:
    """(m,) the arc length [m] of each vertex of the polyline `path` (m, d), from 0 at the first."""
    return np.concatenate([[0.0], np.cumsum(segment_lengths(np.diff(path, axis=0)))])


def nearest_on_polyline(path: np.ndarray, point: np.ndarray) -> tuple[int, float, np.ndarray]:
    """(k, t, lengths): the segment k of the polyline `path` (m >= 2, d) whose nearest point to `point` (d,) is the
    nearest of all (the first, on a tie), that point's share t in [0, 1] of the way along it, and the lengths (m - 1,)
    [m] of all segments."""
    a, ab = path[:-1], np.diff(path, axis=0)
    lengths = segment_lengths(ab)
    t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(lengths ** 2, 1e-12), 0.0, 1.0)
    k = int(np.argmin(segment_lengths(a + t[:, None] * ab - point)))
    return k, float(t[k]), lengths


def distance_along(path: np.ndarray, point: np.ndarray) -> float:
    """How far along the polyline `path` (m >= 2, d) [m] its point nearest to `point` lies: the distance made good
    along a route."""
    k, t, lengths = nearest_on_polyline(path, point)
    return float(np.sum(lengths[:k]) + t * lengths[k])


def xy_text(point) -> str:
    """A point (x, y) as messages write it: "x, y" to 0.1 m."""
    return f"{point[0]:.1f}, {point[1]:.1f}"
