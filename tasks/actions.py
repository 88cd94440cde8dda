"""The one action convention of every suite task and Gymnasium id (dm_env and Gymnasium faces alike).

An action must be numeric (numbers or booleans are not strings), of the spec's shape and finite; anything
else is refused with a ValueError naming the task and the value. A finite action outside the spec's
bounds is clipped to them with a warning (once per task instance), as an actuator saturates.
"""

from __future__ import annotations

import warnings

import numpy as np
from dm_env import specs

from auv_mj.tasks.options import shown


class ActionClipped(UserWarning):
    """A finite action outside the action spec's bounds was clipped."""


def checked_action(action, spec: specs.BoundedArray, task: object) -> np.ndarray:
    """`action` as a float array within `spec`, or a ValueError; see the module docstring."""
    name = type(task).__name__
    try:
        raw = np.asarray(action)
    except (TypeError, ValueError, OverflowError):  # ragged sequences and objects numpy cannot read
        raise ValueError(f"{name}: an action must be numbers of shape {spec.shape}, got {shown(action)}") from None
    if raw.dtype.kind not in "biuf":
        raise ValueError(f"{name}: an action must be numbers, got {shown(action)} (dtype {raw.dtype})")
    value = raw.astype(float)
    if value.shape != spec.shape:
        raise ValueError(f"{name}: an action must have shape {spec.shape}, got {value.shape}: {shown(action)}")
    if not np.all(np.isfinite(value)):
        raise ValueError(f"{name}: an action must be finite, got {shown(action)}")
    low, high = np.broadcast_to(spec.minimum, spec.shape), np.broadcast_to(spec.maximum, spec.shape)
    if np.any(value < low) or np.any(value > high):
        if not getattr(task, "_warned_clip", False):
            warnings.warn(f"{name}: action {value.tolist()} outside [{low.tolist()}, {high.tolist()}] is clipped "
                          "(warned once per task)", ActionClipped, stacklevel=3)
            try:
                task._warned_clip = True
            except AttributeError:
                pass
        value = np.clip(value, low, high)
    return value
