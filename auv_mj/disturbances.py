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

    def world_wrench(self, time: float, psi: float) -> np.ndarray:
        """(Fx, Fy, Mz) in the world frame at `time`, for a vehicle heading `psi`."""
        wrench = _as_wrench(self.force(time) if callable(self.force) else self.force)
        if self.frame == "body":
            c, s = math.cos(psi), math.sin(psi)
            wrench = np.array([c * wrench[0] - s * wrench[1], s * wrench[0] + c * wrench[1], wrench[2]])
        return wrench


def _as_wrench(value) -> np.ndarray:
    wrench = np.zeros(3)
    values = np.asarray(value, dtype=float).ravel()
    if values.size not in (2, 3) or not np.all(np.isfinite(values)):
        raise ValueError(f"a disturbance force is (Fx, Fy) or (Fx, Fy, Mz) of finite numbers, got {value!r}")
    wrench[:values.size] = values
    return wrench
