"""External disturbance forces g_0 of Eq. (3), applied over a time window (Sec. 4.2 experiments)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

FRAMES = ("world", "body")


@dataclass(frozen=True)
class Disturbance:
    """A force (Fx, Fy) [N] and moment Mz [N m] on the vehicle during [start, start + duration) s.

    `force` is a constant 2- or 3-vector, or a function of simulation time returning one, e.g. the
    periodic `lambda t: (0.0, 25 * math.sin(0.01 * math.pi * t))`. `frame` is "world" or "body".
    """

    force: Sequence[float] | Callable[[float], Sequence[float]]
    start: float = 0.0
    duration: float = math.inf
    frame: str = "world"

    def __post_init__(self):
        if self.frame not in FRAMES:
            raise ValueError(f"disturbance frame must be one of {FRAMES}, got {self.frame!r}")
        if not (self.duration >= 0 and math.isfinite(self.start)):
            raise ValueError(f"disturbance needs a finite start and duration >= 0, got "
                             f"start={self.start}, duration={self.duration}")
        if not callable(self.force):
            _as_wrench(self.force)

    def active(self, time: float) -> bool:
        """Whether the window covers `time`."""
        return self.start <= time < self.start + self.duration

    def wrench(self, time: float, psi: float) -> tuple[float, float, float]:
        """(Fx, Fy, Mz) in the world frame at `time`, for a vehicle heading `psi`, as floats (per step)."""
        fx, fy, mz = _as_wrench(self.force(time) if callable(self.force) else self.force)
        if self.frame == "body":
            c, s = math.cos(psi), math.sin(psi)
            fx, fy = c * fx - s * fy, s * fx + c * fy
        return fx, fy, mz

    def world_wrench(self, time: float, psi: float) -> np.ndarray:
        """(Fx, Fy, Mz) in the world frame at `time`, for a vehicle heading `psi`."""
        return np.array(self.wrench(time, psi))


def _as_wrench(value) -> tuple[float, float, float]:
    try:
        values = [float(v) for v in value]
    except (TypeError, ValueError):
        values = []
    if len(values) not in (2, 3) or not all(map(math.isfinite, values)):
        raise ValueError(f"a disturbance force is (Fx, Fy) or (Fx, Fy, Mz) of finite numbers, got {value!r}")
    return values[0], values[1], values[2] if len(values) == 3 else 0.0
