"""The one check of task options: each is tested for type and range once, where it enters a task factory.

A bad option is refused with a one-line ValueError naming the option, the value and what it accepts, e.g.
`task option goal_radius must be a number in (0, 50] m, got nan`. Booleans are not numbers here, strings are
never converted, and NaN or infinity is outside every range, so that nothing is silently accepted.
"""

from __future__ import annotations

import numbers
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.inputs import did_you_mean, shown

MAX_TIME_LIMIT = 100_000.0
"""Longest episode a task accepts [s] (28 hours simulated; the paper's longest run is minutes)."""
SEED_RANGE = (0, 2**32 - 1)
"""Integer seeds NumPy's RandomState takes."""
ENVIRONMENT_OPTIONS = {"flat_observation": bool, "legacy_step": bool}
"""environment_kwargs a task passes on to `control.Environment` (it sets the time limit and step itself)."""


def _refuse(option: str, what: str, value: Any) -> ValueError:
    return ValueError(f"task option {option} must be {what}, got {shown(value)}")


def is_number(value: Any) -> bool:
    """A real number (int, float or a NumPy scalar), not a bool and not a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def number(option: str, value: Any, low: float, high: float, unit: str = "", *, low_open: bool = False) -> float:
    """`value` as a float in [low, high] (`low_open`: in (low, high]); ValueError naming `option` otherwise."""
    interval = f"{'(' if low_open else '['}{low:g}, {high:g}]{' ' + unit if unit else ''}"
    if not is_number(value):
        raise _refuse(option, f"a number in {interval}", value)
    result = float(value)
    if not ((low < result if low_open else low <= result) and result <= high):  # NaN fails both
        raise _refuse(option, f"a number in {interval}", value)
    return result


def choice(option: str, value: Any, choices: Sequence[str]) -> str:
    """`value` if it is one of the strings `choices`; ValueError naming `option` and the choices otherwise."""
    if not isinstance(value, str) or value not in choices:
        hint = did_you_mean(value, choices) if isinstance(value, str) else ""
        raise ValueError(f"task option {option} must be one of {', '.join(map(repr, choices))}, got {shown(value)}"
                         f"{hint}")
    return value


def seed(value: Any, option: str = "random") -> int | np.random.RandomState | None:
    """A task's `random`: None, a seed in SEED_RANGE or a numpy RandomState (dm_control's convention)."""
    if value is None or isinstance(value, np.random.RandomState):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
        if SEED_RANGE[0] <= value <= SEED_RANGE[1]:
            return int(value)
    raise _refuse(option, f"None, a numpy RandomState or a whole number in [{SEED_RANGE[0]}, {SEED_RANGE[1]}]",
                  value)


def time_limit(value: Any) -> float:
    """An episode's time limit [s]: in (0, MAX_TIME_LIMIT]."""
    return number("time_limit", value, 0.0, MAX_TIME_LIMIT, "s", low_open=True)


def environment_kwargs(value: Any) -> dict:
    """environment_kwargs for `control.Environment`: None or a dict of ENVIRONMENT_OPTIONS."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise _refuse("environment_kwargs", "None or a dict", value)
    for key, item in value.items():
        kind = ENVIRONMENT_OPTIONS.get(key) if isinstance(key, str) else None
        if kind is None:
            raise _refuse("environment_kwargs", "a dict of " + ", ".join(ENVIRONMENT_OPTIONS), dict(value))
        if not isinstance(item, kind):
            raise _refuse(f"environment_kwargs[{key!r}]", f"a {kind.__name__}", item)
    return dict(value)


def function(option: str, value: Any, form: str) -> Callable | None:
    """None or a callable `form` (e.g. "executor(command, state)")."""
    if value is not None and not callable(value):
        raise _refuse(option, f"None or callable as {form}", value)
    return value


def arena_source(value: Any) -> str | Path | ET.Element | None:
    """An arena option: None, a file path or an ElementTree element (its contents are `check-arena`'s job)."""
    if value is None or isinstance(value, (Path, ET.Element)) or (isinstance(value, str) and value):
        return value
    raise _refuse("arena", "an arena MJCF file path or an ElementTree element", value)


def pair(option: str, value: Any, ranges: Sequence[tuple[float, float, str]]) -> tuple[float, ...]:
    """A fixed-size sequence of numbers, element i in ranges[i] = (low, high, unit)."""
    form = "(" + ", ".join(f"[{low:g}, {high:g}]{' ' + unit if unit else ''}" for low, high, unit in ranges) + ")"
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise _refuse(option, f"a pair {form}", value)
    items = list(value) if not isinstance(value, np.ndarray) else value.tolist()
    if len(items) != len(ranges) or not all(is_number(v) and low <= float(v) <= high
                                            for v, (low, high, _) in zip(items, ranges, strict=False)):
        raise _refuse(option, f"a pair {form}", value)
    return tuple(float(v) for v in items)


MAX_RESIDUAL = 2.0
"""Largest `residual` of an executor built on an S-plane: the correction's span as a multiple of the normalised
actuator range (the planar `speed_heading` and the 6-DOF `depth_executor` alike)."""
MAX_GAIN_OCTAVES = 4.0
"""Largest `gains` of a gain-scheduling executor: an action of +-1 multiplies a gain by 2^(+-gains)."""


def splane_building(residual: Any, gains: Any) -> tuple[float, float]:
    """(residual, gains) of a learned executor, each 0 or within its range: the two ways of building on an S-plane
    (a residual correction, or gain scheduling), of which at most one is set."""
    residual = number("residual", residual, 0.0, MAX_RESIDUAL)
    gains = number("gains", gains, 0.0, MAX_GAIN_OCTAVES)
    if residual and gains:
        raise ValueError("residual and gains are two ways of building on the S-plane: set one of them")
    return residual, gains
