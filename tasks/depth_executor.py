"""A learned depth executor's inputs and outputs on the 6-DOF vehicle: `DepthExecutorMemory`.

The 3-D counterpart of the planar `auv_mj.tasks.speed_heading.ExecutorMemory`, shared by the `depth_heading` task
and a learned depth executor deployed under a 3-D planner (`auv_mj.zoo.registry`), so that the two cannot drift.

- plain (default): the action (thrust, rudder, stern) in [-1, 1]^3 is scaled to the actuator ranges;
- residual (`residual` R in (0, MAX_RESIDUAL]): the depth-heading S-plane (`DepthHeadingController`) runs inside and
  the action corrects its controls, u = clip(u_S-plane + R a (half-range)); the observation ends with the
  S-plane's normalised controls (RESIDUAL_NAMES);
- gain scheduling (`gains` G in (0, MAX_GAIN_OCTAVES]): one action per `SCHEDULED_GAINS` entry multiplies that
  S-surface gain by 2^(G a) for the step, and the S-plane acts.

In both S-plane modes a zero action gives the S-plane's controls exactly. `base` names the S-plane they build on
(BASES: the hand-set gains or `OCEAN_DEPTH_GAINS`, re-tuned in ocean water). Observation "sensors" is the task's
EXECUTOR_OBSERVATION; "history" appends the inner S-plane's three integral contributions over their limit (the
memory that cancels a steady force or the buoyancy) and the last HISTORY_STEPS normalised controls (the lagged
fins and thruster act on a filtered sum of them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from auv_mj.control.depth_heading import (
    OCEAN_DEPTH_GAINS,
    SCHEDULED_GAINS,
    DepthHeadingController,
    DepthHeadingGains,
    State3D,
)
from auv_mj.geometry import wrap_angle
from auv_mj.tasks import options

SENSOR_NAMES = ("V_cmd", "u", "v", "w", "p", "q", "r", "e_V", "cos_e_psi", "sin_e_psi", "e_depth", "roll", "pitch",
                "depth")
"""The "sensors" observation: the command, the sensed motion and attitude, the errors."""
INTEGRAL_NAMES = ("int_speed", "int_heading", "int_depth")
"""The inner S-plane's integral contributions over its integral_limit ("history")."""
HISTORY_STEPS = 3
"""Controls (normalised thrust, rudder, stern; newest first) the "history" observation appends: 0.3 s, about the
ocean conditions' thruster and fin lags."""
HISTORY_NAMES = tuple(f"{name}_cmd_{k}" for k in range(1, HISTORY_STEPS + 1) for name in ("thrust", "rudder",
                                                                                          "stern"))
RESIDUAL_NAMES = ("splane_thrust", "splane_rudder", "splane_stern")
"""Entries a residual executor's observation ends with: the S-plane's normalised controls."""
OBSERVATIONS = ("sensors", "history")
BASES = {"nominal": DepthHeadingGains(), "ocean": OCEAN_DEPTH_GAINS}
"""The S-plane a residual or gain-scheduling executor builds on (`base`)."""


def sensor_observation(command: Sequence[float], state: State3D) -> np.ndarray:
    """SENSOR_NAMES from command (V_cmd, psi_cmd, depth_cmd) and the sensed `state`."""
    v_cmd, psi_cmd, depth_cmd = (float(c) for c in command)
    e_psi = wrap_angle(psi_cmd - state.heading)
    return np.array([v_cmd, state.u, state.v, state.w, state.p, state.q, state.r, v_cmd - state.u, math.cos(e_psi),
                     math.sin(e_psi), depth_cmd - state.depth, state.roll, state.pitch, state.depth])


def observation_size(observation: str, residual: bool) -> int:
    """Entries of the observation of this kind, with or without the residual's S-plane controls."""
    extra = len(INTEGRAL_NAMES) + len(HISTORY_NAMES) if observation == "history" else 0
    return len(SENSOR_NAMES) + extra + len(RESIDUAL_NAMES) * bool(residual)


class DepthExecutorMemory:
    """Observation and controls of a (learned) depth executor (module docstring).

    `observe(command, state)` is called once per executor step with the command and sensed state the next action
    acts on; `controls(action)` turns that action into (thrust [N], rudder [rad], stern [rad]) within [low, high].
    """

    def __init__(self, observation: str = "sensors", residual: float = 0.0, gains: float = 0.0, base: str = "nominal",
                 low: Sequence[float] = (-1.0, -1.0, -1.0), high: Sequence[float] = (1.0, 1.0, 1.0)):
        self.observation = options.choice("observation", observation, OBSERVATIONS)
        self.residual, self.gains = options.splane_building(residual, gains)
        self.base = options.choice("base", base, tuple(BASES))
        if not (self.residual or self.gains) and (self.base != "nominal" or self.observation != "sensors"):
            raise ValueError(f"base {self.base!r} and observation {self.observation!r} concern the inner S-plane of "
                             "a residual or gain-scheduling executor: set residual or gains too")
        self.low, self.high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        self.splane = DepthHeadingController(BASES[self.base]) if (self.residual or self.gains) else None
        self.reset()

    @property
    def size(self) -> int:
        """Entries of the observation."""
        return observation_size(self.observation, self.residual > 0)

    @property
    def actions(self) -> int:
        """Entries of the action: one per SCHEDULED_GAINS entry when scheduling gains, else one per actuator."""
        return len(SCHEDULED_GAINS) if self.gains else len(self.low)

    def reset(self, low: Sequence[float] | None = None, high: Sequence[float] | None = None) -> None:
        """Start of an episode: a fresh S-plane, no history (and new actuator ranges if given)."""
        if low is not None and high is not None:
            self.low, self.high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        if self.splane is not None:
            self.splane.reset()
        self._history = np.zeros(len(HISTORY_NAMES) if self.observation == "history" else 0)
        self._splane_controls = np.zeros(len(self.low))
        self._seen: tuple[Sequence[float], State3D | None] = ((0.0, 0.0, 0.0), None)

    def _normalised(self, controls: np.ndarray) -> np.ndarray:
        return np.clip(2 * (controls - self.low) / (self.high - self.low) - 1, -1.0, 1.0)

    def observe(self, command: Sequence[float], state: State3D) -> np.ndarray:
        """The observation for `command` (V_cmd, psi_cmd, depth_cmd) and `state`; moves the residual's S-plane."""
        parts = [sensor_observation(command, state)]
        self._seen = (tuple(command), state)
        if self.residual:
            self._splane_controls = np.clip(self.splane(command, state), self.low, self.high)
        if self.observation == "history":
            parts += [self.splane.integrals / self.splane.gains.integral_limit, self._history]
        if self.residual:
            parts.append(self._normalised(self._splane_controls))
        return np.concatenate(parts)

    def controls(self, action: np.ndarray) -> np.ndarray:
        """(thrust [N], rudder [rad], stern [rad]) for the policy's `action` (entries in [-1, 1])."""
        action = np.asarray(action, dtype=float)
        if self.gains:
            if self._seen[1] is None:
                raise RuntimeError("DepthExecutorMemory.controls before observe: the S-plane has no state to act on")
            controls = np.clip(self.splane(*self._seen, scale=np.exp2(self.gains * action)), self.low, self.high)
        elif self.residual:
            controls = np.clip(self._splane_controls + self.residual * action * 0.5 * (self.high - self.low),
                               self.low, self.high)
        else:
            controls = self.low + 0.5 * (action + 1.0) * (self.high - self.low)
        if self._history.size:
            self._history = np.concatenate([self._normalised(controls), self._history[:-len(self.low)]])
        return controls


def executor_options(obs_dim: int, task_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The `DepthExecutorMemory` options (observation, residual, gains, base) of a learned depth executor with
    `obs_dim` inputs trained with `task_kwargs` (a checkpoint's run_info); ValueError when the two disagree."""
    task_kwargs = task_kwargs or {}
    observation = options.choice("observation", task_kwargs.get("observation", "sensors"), OBSERVATIONS)
    residual, gains = float(task_kwargs.get("residual", 0.0)), float(task_kwargs.get("gains", 0.0))
    if observation_size(observation, residual > 0) != obs_dim:
        raise ValueError(f"a depth executor trained with observation {observation!r} and residual {residual:g} has "
                         f"{observation_size(observation, residual > 0)} inputs, not {obs_dim}")
    return {"observation": observation, "residual": residual, "gains": gains,
            "base": str(task_kwargs.get("base", "nominal"))}
