"""speed_heading: the execution layer's task of Sec. 3.3 and 4.2 (follow a speed and heading command).

The agent is the executor: each step (EXECUTOR_DT = 0.1 s) it sees the command (V_cmd, psi_cmd) and the
vehicle's motion (Eq. 27) and outputs the thrust and yaw moment tau = (tau_u, tau_r) (Eq. 28-29), scaled
from [-1, 1]^2 by the actuator ranges of the model. The speed V is the surge speed u (the executor's
channel; sway is unactuated), the heading psi the yaw angle. Reward "paper" is Eq. (30),
r = -|e_V| - |e_psi|; "suite" (default) is in [0, 1], the mean of two `tolerance` terms.

Observation "paper" (default) is Eq. 27; "integral" appends the clamped integrals of e_V and e_psi
(`ErrorIntegral`), a memory Eq. 27 lacks: without it a learned executor is a static map and keeps a steady
error under a steady force, which the S-plane's integrating bias du removes. "history" appends, after the
integrals, the last HISTORY_STEPS commands sent to the actuators: with lagged thrusters (ocean conditions)
the force acting now is a filtered sum of those, which Eq. 27 cannot see.

Residual (`residual` > 0, ours after Johannink et al. 2019 and Silver et al. 2018): the S-plane of Eq. 32
with its nominal gains runs inside the task and the agent's action is a correction to it,
tau = clip(tau_S-plane + residual * a * (actuator half-range)); the observation then ends with the S-plane's
normalised command. Gain scheduling (`gains` > 0, ours): the agent's four actions set the S-plane's gains
(k_V1, k_V2, k_psi1, k_psi2) of Eq. 32 for the step, each times 2^(gains * a), and the S-plane acts. In both
a zero action gives exactly the S-plane's forces. `ExecutorMemory` holds the integrals, the history and the
S-plane: the task and a learned executor deployed in a planning task (`auv_mj.zoo.registry.LearnedExecutor`)
share it.

Commands: "paper" (default) holds the Sec. 4.2 command, 1.0 m/s and pi/12, from rest at psi = 0; a pair
(V, psi), V in [0, `top_speed()`] m/s and psi in [-pi, pi] rad, holds that command; "random" (training)
starts from a random speed and heading and changes the command every COMMAND_HOLD_STEPS, as the 2 Hz
planner would.

Disturbances: "paper" (default) is the Sec. 4.2 schedule, in executor steps k: a 180 N body-frame sway
burst for 10 steps from k = 250, a constant 30 N world +y ("E-eta") force for 350 steps from k = 350,
and a periodic 25 sin(0.01 pi k) N world +y force for 350 steps from k = 750 (k counts from the episode
start, continuous within a step), over 1100 steps. "random" draws bursts, currents and periodic forces
of random size, direction and timing; "none" applies nothing. `last_info["phase"]` names the latest
disturbance to have started ("none" before the first), so that the per-phase MAE of Table 9 covers each
disturbance and the recovery from it; `run_executor` computes it.

Conditions: "ideal" (default) is the paper's world; "ocean" or a mapping of effects (`auv_mj.sim.ocean`) adds
a current (moved on every step, beside the disturbances above), lagged actuators and a vehicle scaled per
episode that the executor does not know about.
"""

from __future__ import annotations

import auv_mj  # noqa: F401  # isort: skip  (first: it picks MuJoCo's OpenGL backend before dm_control loads)
import collections
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import rewards
from dm_env import specs

from auv_mj.arenas import arena
from auv_mj.control.splane import EXECUTOR_DT, OCEAN_GAINS, SPlaneController, SPlaneGains
from auv_mj.episode import FunctionPlanner, Planner, record_episode
from auv_mj.episode import phase_mae as _phase_mae
from auv_mj.geometry import wrap_angle
from auv_mj.sim import ocean
from auv_mj.sim.vehicle import vehicle_facts
from auv_mj.tasks import options
from auv_mj.tasks.actions import checked_action
from auv_mj.tasks.registry import SUITE

EPISODE_STEPS = 1100
"""Length of the Sec. 4.2 experiment, in executor steps."""
_DEFAULT_TIME_LIMIT = EPISODE_STEPS * EXECUTOR_DT
PAPER_COMMAND = (1.0, math.pi / 12)
"""Target speed [m/s] and heading [rad] of Sec. 4.2."""

BURST_FORCE = 180.0
"""Sec. 4.2 instantaneous disturbance: lateral (body sway) force [N] ..."""
BURST_START, BURST_STEPS = 250, 10
"""... from executor step 250, for 10 steps."""
CONSTANT_FORCE = 30.0
"""Sec. 4.2 constant disturbance: force [N] in the world "E-eta" (+y) direction ..."""
CONSTANT_START, CONSTANT_STEPS = 350, 350
"""... from step 350, for 350 steps."""
PERIODIC_AMPLITUDE = 25.0
"""Sec. 4.2 periodic disturbance: 25 sin(PERIODIC_RATE k) N in the world +y direction ..."""
PERIODIC_RATE = 0.01 * math.pi
"""... with k in executor steps (a period of 200 steps, 20 s) ..."""
PERIODIC_START, PERIODIC_STEPS = 750, 350
"""... from step 750, for 350 steps."""

PHASES = ("none", "instantaneous", "constant", "periodic")
"""Values of last_info["phase"]: the kind of the latest disturbance to have started."""

RANDOM_SPEED_RANGE = (0.5, 2.0)
"""Range of random speed commands [m/s]."""
RANDOM_TURN = math.pi / 2
"""A random heading command is the previous one plus up to this much either way [rad]."""
COMMAND_HOLD_STEPS = (20, 200)
"""A random command holds for this many executor steps (uniform, inclusive), then changes."""
RANDOM_INITIAL_SPEED = (0.0, 2.0)
"""Range of the initial surge speed of "random" episodes [m/s]."""
RANDOM_DISTURBANCE_PROBABILITY = 0.7
"""Chance that a "random" episode has each kind of disturbance (burst, constant, periodic)."""
RANDOM_BURST_FORCE = (50.0, 200.0)
RANDOM_BURST_STEPS = (5, 15)
RANDOM_CONSTANT_FORCE = (5.0, 40.0)
RANDOM_PERIODIC_AMPLITUDE = (5.0, 30.0)
RANDOM_PERIODIC_RATE = (0.005 * math.pi, 0.03 * math.pi)
RANDOM_WINDOW_STEPS = (100, 400)
"""Ranges of the "random" disturbances: sizes [N], rates [rad/step] and lengths [steps]."""

SPEED_TOLERANCE = 0.05
"""|e_V| [m/s] within which the suite reward's speed term is 1 and the command counts as met."""
HEADING_TOLERANCE = 0.05
"""|e_psi| [rad] within which the suite reward's heading term is 1 and the command counts as met."""
SPEED_MARGIN = 0.5
"""|e_V| beyond the tolerance [m/s] at which the suite speed term has fallen to 0.1."""
HEADING_MARGIN = 0.5
"""|e_psi| beyond the tolerance [rad] at which the suite heading term has fallen to 0.1."""
SETTLE_STEPS = 100
"""`run_executor` leaves the first 100 steps (the start from rest) out of the "none" phase's MAE."""

OBSERVATION_NAMES = ("V_cmd", "u", "v", "r", "e_V", "cos_e_psi", "sin_e_psi")
"""Entries of the flat "observation" vector of Eq. 27 ("paper" observation)."""
INTEGRAL_NAMES = ("int_e_V", "int_e_psi")
"""Entries the "integral" observation appends: the clamped error integrals over their limits."""
INTEGRAL_BAND = (0.2, 0.2)
"""The error integrals accumulate only while |e_V| [m/s], |e_psi| [rad] are below these (integral
separation, as in the S-plane's du of Eq. 32, so that large command steps do not wind them up)."""
INTEGRAL_LIMIT = (1.0, 1.0)
"""Clamp of the integrals of e_V [m] and e_psi [rad s]; the observation holds integral / limit."""
HISTORY_STEPS = 3
"""Commands (normalised tau_u, tau_r; newest first) the "history" observation appends: 0.3 s, about the
thruster lags of the ocean conditions (0.4 s surge, 0.2 s yaw)."""
HISTORY_NAMES = tuple(f"{name}_cmd_{k}" for k in range(1, HISTORY_STEPS + 1) for name in ("tau_u", "tau_r"))
RESIDUAL_NAMES = ("splane_tau_u", "splane_tau_r")
"""Entries a residual executor's observation ends with: the S-plane's normalised command."""
GAIN_NAMES = ("k1_speed", "k2_speed", "k1_heading", "k2_heading")
"""The S-plane gains a gain-scheduling executor sets, one action each."""
BASES = {"nominal": SPlaneGains(), "ocean": OCEAN_GAINS}
"""The S-plane a residual or gain-scheduling executor builds on (`base`): the gains tuned on the nominal model
(`experiments/splane_tuning.py`) or re-tuned in ocean water (`OCEAN_GAINS`, `--conditions ocean`)."""
OBSERVATIONS = ("paper", "integral", "history")
REWARDS = ("suite", "paper")
COMMANDS = ("paper", "random")
DISTURBANCES = ("paper", "random", "none")

Executor = Callable[[Sequence[float], Sequence[float]], np.ndarray]


def top_speed() -> float:
    """The vehicle's top surge speed [m/s]: full thrust against the surge drag, sqrt(tau_u max / -X_uu).

    A fixed `command` may ask for any speed from 0 up to this (read from the vehicle MJCF)."""
    facts = vehicle_facts()
    return math.sqrt(facts.surge_limit / facts.surge_drag)


def executor_observation(command: Sequence[float], state: Sequence[float]) -> np.ndarray:
    """The task's observation (Eq. 27) from command (V_cmd, psi_cmd) and state (u, v, r, psi).

    (V_cmd, u, v, r, e_V, cos e_psi, sin e_psi): a learned executor wrapped as the contract's callable
    `executor(command, state)` builds its input with this function.
    """
    v_cmd, psi_cmd = float(command[0]), float(command[1])
    u, v, r, psi = (float(s) for s in state[:4])
    e_psi = wrap_angle(psi_cmd - psi)
    return np.array([v_cmd, u, v, r, v_cmd - u, math.cos(e_psi), math.sin(e_psi)])


class ErrorIntegral:
    """The memory of the "integral" observation: clamped integrals of e_V and e_psi (integral separation).

    A static map from Eq. 27's observation to tau leaves a steady error under a steady force; with these
    two entries a learned executor can act like the integrator of the S-plane's bias du (Eq. 32).
    `update` is called once per executor step, with the command and state the executor acts on.
    """

    def __init__(self):
        self.value = np.zeros(2)

    def reset(self) -> None:
        """Zero integrals (the start of an episode)."""
        self.value = np.zeros(2)

    def update(self, command: Sequence[float], state: Sequence[float]) -> np.ndarray:
        """Adds this step's errors (those inside INTEGRAL_BAND) and returns integral / INTEGRAL_LIMIT."""
        error = np.array([float(command[0]) - float(state[0]), wrap_angle(float(command[1]) - float(state[3]))])
        inside = np.abs(error) < INTEGRAL_BAND
        limit = np.asarray(INTEGRAL_LIMIT)
        self.value = np.clip(self.value + inside * error * EXECUTOR_DT, -limit, limit)
        return self.value / limit


class ExecutorMemory:
    """A learned executor's inputs and output, the one implementation for the task and a deployed executor.

    `observe(command, state)` is called once per executor step, with the command and state the next action
    acts on: it moves the integrals (observation "integral", "history") and, for a residual executor, the
    S-plane (Eq. 32; gains BASES[base]), and returns the observation. `forces(action)` turns the policy's action
    (one per actuator, or one per GAIN_NAMES entry, in [-1, 1]) into the actuator forces (tau_u, tau_r):
    - plain: the action scaled to the actuator ranges `low`, `high` (Eq. 28-29);
    - residual: the S-plane's forces plus `residual` times the action in half-ranges, clipped to the ranges;
    - gains: the S-plane on the observed command and state with (k_V1, k_V2, k_psi1, k_psi2) times
      2^(gains * action).
    In both S-plane modes a zero action gives the S-plane's forces exactly. It remembers the normalised
    command for the "history" observation.
    """

    def __init__(self, observation: str = "paper", residual: float = 0.0, gains: float = 0.0,
                 low: Sequence[float] = (-1.0, -1.0), high: Sequence[float] = (1.0, 1.0), base: str = "nominal"):
        self.observation = options.choice("observation", observation, OBSERVATIONS)
        self.residual, self.gains = options.splane_building(residual, gains)
        self.base = options.choice("base", base, tuple(BASES))
        if self.base != "nominal" and not (self.residual or self.gains):
            raise ValueError(f"base {self.base!r} is the S-plane a residual or gain-scheduling executor builds on: "
                             "set residual or gains too")
        self.low, self.high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        self._integral = ErrorIntegral() if observation in ("integral", "history") else None
        self._splane = SPlaneController(BASES[self.base]) if self.residual > 0 or self.gains > 0 else None
        self.reset()

    @property
    def size(self) -> int:
        """Entries of the observation."""
        return observation_size(self.observation, self.residual > 0)

    def reset(self, low: Sequence[float] | None = None, high: Sequence[float] | None = None) -> None:
        """Start of an episode: zero integrals and history, a fresh S-plane (and new actuator ranges if given)."""
        if low is not None and high is not None:
            self.low, self.high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        if self._integral is not None:
            self._integral.reset()
        if self._splane is not None:
            self._splane.reset()
        self._history = np.zeros(2 * HISTORY_STEPS if self.observation == "history" else 0)
        self._splane_forces = np.zeros(2)
        self._seen: tuple[Sequence[float], Sequence[float]] = ((0.0, 0.0), (0.0, 0.0, 0.0, 0.0))

    def _normalised(self, forces: np.ndarray) -> np.ndarray:
        return np.clip(2 * (forces - self.low) / (self.high - self.low) - 1, -1.0, 1.0)

    def observe(self, command: Sequence[float], state: Sequence[float]) -> np.ndarray:
        """The observation for `command` (V_cmd, psi_cmd) and `state` (u, v, r, psi); moves the memories."""
        parts = [executor_observation(command, state)]
        if self._integral is not None:
            parts.append(self._integral.update(command, state))
        parts.append(self._history)
        self._seen = (tuple(command), tuple(state))
        if self.residual:
            self._splane_forces = np.clip(self._splane(command, state), self.low, self.high)
            parts.append(self._normalised(self._splane_forces))
        return np.concatenate(parts)

    def forces(self, action: np.ndarray) -> np.ndarray:
        """The actuator forces (tau_u [N], tau_r [N m]) for the policy's `action` (entries in [-1, 1])."""
        action = np.asarray(action, dtype=float)
        if self.gains:  # the S-plane on the state observed, with this step's gains
            forces = np.clip(self._splane(*self._seen, scale=np.exp2(self.gains * action)), self.low, self.high)
        elif self._splane is None:
            forces = self.low + 0.5 * (action + 1.0) * (self.high - self.low)
        else:
            forces = np.clip(self._splane_forces + self.residual * action * 0.5 * (self.high - self.low),
                             self.low, self.high)
        if self._history.size:
            self._history = np.concatenate([self._normalised(forces), self._history[:-2]])
        return forces


def observation_size(observation: str, residual: bool) -> int:
    """Entries of the executor observation of this kind, with or without the residual's S-plane command."""
    extra = {"paper": 0, "integral": len(INTEGRAL_NAMES), "history": len(INTEGRAL_NAMES) + len(HISTORY_NAMES)}
    return len(OBSERVATION_NAMES) + extra[observation] + len(RESIDUAL_NAMES) * bool(residual)


def executor_options(obs_dim: int, task_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The `ExecutorMemory` options (observation, residual, gains, base) of a learned executor with `obs_dim` inputs
    trained with `task_kwargs` (a checkpoint's run_info); without them, the observation its input size gives
    ("paper" or "integral"). ValueError when the two disagree."""
    task_kwargs = task_kwargs or {}
    observation = task_kwargs.get("observation") or observation_kind(obs_dim)
    residual, gains = float(task_kwargs.get("residual", 0.0)), float(task_kwargs.get("gains", 0.0))
    options.choice("observation", observation, OBSERVATIONS)
    if observation_size(observation, residual > 0) != obs_dim:
        raise ValueError(f"an executor trained with observation {observation!r} and residual {residual:g} has "
                         f"{observation_size(observation, residual > 0)} inputs, not {obs_dim}")
    return {"observation": observation, "residual": residual, "gains": gains,
            "base": str(task_kwargs.get("base", "nominal"))}


def observation_kind(size: int) -> str:
    """The observation ("paper" or "integral") of a learned executor whose input has `size` entries."""
    sizes = {"paper": len(OBSERVATION_NAMES), "integral": len(OBSERVATION_NAMES) + len(INTEGRAL_NAMES)}
    for kind, n in sizes.items():
        if size == n:
            return kind
    raise ValueError(f"an executor's input has {sizes['paper']} (Eq. 27) or {sizes['integral']} "
                     f"(Eq. 27 and the error integrals) entries, not {size}")


@dataclass(frozen=True)
class DisturbanceWindow:
    """One disturbance of an episode: `kind` (a PHASES entry) over executor steps [start, start + steps)."""

    kind: str
    start: int
    steps: int
    force: tuple[float, float] | Callable[[float], tuple[float, float]]
    frame: str


def _periodic(amplitude: float, rate: float, direction: float) -> Callable[[float], tuple[float, float]]:
    """amplitude sin(rate k) along world `direction`, with k = t / EXECUTOR_DT in executor steps."""
    c, s = math.cos(direction), math.sin(direction)

    def force(time: float) -> tuple[float, float]:
        magnitude = amplitude * math.sin(rate * time / EXECUTOR_DT)
        return (magnitude * c, magnitude * s)

    return force


def paper_disturbances() -> tuple[DisturbanceWindow, ...]:
    """The Sec. 4.2 schedule: sway burst, constant +y force, periodic +y force."""
    return (DisturbanceWindow("instantaneous", BURST_START, BURST_STEPS, (0.0, BURST_FORCE), "body"),
            DisturbanceWindow("constant", CONSTANT_START, CONSTANT_STEPS, (0.0, CONSTANT_FORCE), "world"),
            DisturbanceWindow("periodic", PERIODIC_START, PERIODIC_STEPS,
                              _periodic(PERIODIC_AMPLITUDE, PERIODIC_RATE, math.pi / 2), "world"))


def random_disturbances(random: np.random.RandomState,
                        horizon: int = EPISODE_STEPS) -> tuple[DisturbanceWindow, ...]:
    """Each kind with RANDOM_DISTURBANCE_PROBABILITY, random in size, direction and timing."""

    def steps(bounds: tuple[int, int]) -> int:
        return int(random.randint(bounds[0], bounds[1] + 1))

    windows = []
    if random.uniform() < RANDOM_DISTURBANCE_PROBABILITY:
        force = random.uniform(*RANDOM_BURST_FORCE) * random.choice([-1.0, 1.0])
        windows.append(DisturbanceWindow("instantaneous", steps((0, horizon - 1)), steps(RANDOM_BURST_STEPS),
                                         (0.0, force), "body"))
    if random.uniform() < RANDOM_DISTURBANCE_PROBABILITY:
        magnitude, direction = random.uniform(*RANDOM_CONSTANT_FORCE), random.uniform(-math.pi, math.pi)
        windows.append(DisturbanceWindow("constant", steps((0, horizon - 1)), steps(RANDOM_WINDOW_STEPS),
                                         (magnitude * math.cos(direction), magnitude * math.sin(direction)),
                                         "world"))
    if random.uniform() < RANDOM_DISTURBANCE_PROBABILITY:
        amplitude, rate = random.uniform(*RANDOM_PERIODIC_AMPLITUDE), random.uniform(*RANDOM_PERIODIC_RATE)
        force = _periodic(amplitude, rate, random.uniform(-math.pi, math.pi))
        windows.append(DisturbanceWindow("periodic", steps((0, horizon - 1)), steps(RANDOM_WINDOW_STEPS),
                                         force, "world"))
    return tuple(sorted(windows, key=lambda w: w.start))


class SpeedHeading(base.Task):
    """Follow (V_cmd, psi_cmd) with (tau_u, tau_r) under disturbances (Sec. 3.3, 4.2)."""

    def __init__(self, command: str | Sequence[float] = "paper", disturbances: str = "paper",
                 reward: str = "suite", observation: str = "paper", random=None, conditions="ideal",
                 residual: float = 0.0, gains: float = 0.0, base: str = "nominal"):
        """`command`: "paper", "random" or (V, psi); `disturbances`: "paper", "random", "none";
        `reward`: "suite" ([0, 1]) or "paper" (Eq. 30); `observation`: "paper" (Eq. 27) or "integral"
        (Eq. 27 and the error integrals of `ErrorIntegral`); `random`: seed, RandomState or None;
        `conditions`: "ideal", "ocean" or a mapping of ocean effects (`auv_mj.sim.ocean.conditions`; the
        sonar's play no part here); `residual`: 0 (the action is the command, Eq. 28-29) or the span of the
        agent's correction to the S-plane's command, in (0, options.MAX_RESIDUAL]; `gains`: 0 or the octaves by which
        a gain-scheduling action moves the S-plane's gains, in (0, options.MAX_GAIN_OCTAVES] (module docstring);
        `base`: the S-plane those two build on, "nominal" or "ocean" (BASES)."""
        if isinstance(command, str):
            options.choice("command", command, COMMANDS)
        else:
            command = options.pair("command", command, ((0.0, top_speed(), "m/s"), (-math.pi, math.pi, "rad")))
        options.choice("disturbances", disturbances, DISTURBANCES)
        options.choice("reward", reward, REWARDS)
        self.memory = ExecutorMemory(observation, residual, gains, base=base)
        random = options.seed(random)
        self.ocean = ocean.Ocean(conditions)
        self._observation = np.zeros(self.memory.size)
        self._command_mode = command
        self._disturbance_mode = disturbances
        self._reward_mode = reward
        self._windows: tuple[DisturbanceWindow, ...] = ()
        self._schedule: list[tuple[int, float, float]] = [(0, *PAPER_COMMAND)]  # until the first reset
        self._next_change: float = math.inf
        self._step, self._step_command = 0, PAPER_COMMAND
        self._errors = (0.0, 0.0)
        self.last_info: dict = {}
        super().__init__(random=random)

    # --- episode set-up --------------------------------------------------------------------------

    def initialize_episode(self, physics) -> None:
        """Draws the commands and disturbances, places the vehicle, and attaches the disturbances."""
        if self._command_mode == "random":
            speed = self.random.uniform(*RANDOM_INITIAL_SPEED)
            heading = self.random.uniform(-math.pi, math.pi)
            self._schedule = [(0, self.random.uniform(*RANDOM_SPEED_RANGE),
                               wrap_angle(heading + self.random.uniform(-RANDOM_TURN, RANDOM_TURN)))]
            self._next_change = self._hold()
        else:
            speed, heading = 0.0, 0.0
            fixed = PAPER_COMMAND if self._command_mode == "paper" else self._command_mode
            self._schedule = [(0, *fixed)]
            self._next_change = math.inf
        physics.named.data.qpos["x"] = 0.0
        physics.named.data.qpos["y"] = 0.0
        physics.named.data.qpos["yaw"] = heading
        physics.named.data.qvel["x"] = speed * math.cos(heading)
        physics.named.data.qvel["y"] = speed * math.sin(heading)
        physics.named.data.qvel["yaw"] = 0.0

        if self._disturbance_mode == "paper":
            self._windows = paper_disturbances()
        elif self._disturbance_mode == "random":
            self._windows = random_disturbances(self.random)
        else:
            self._windows = ()
        physics.clear_disturbances()
        half_step = 0.5 * physics.timestep()  # so a window covers whole physics steps despite rounding
        for w in self._windows:
            physics.add_disturbance(w.force, start=w.start * EXECUTOR_DT - half_step,
                                    duration=w.steps * EXECUTOR_DT, frame=w.frame)
        physics.set_control(np.zeros(physics.model.nu))
        self._step, self._step_command = 0, self.command(physics)
        self.memory.reset(*physics.model.actuator_ctrlrange.T)
        self.ocean.start(physics, self.random)
        super().initialize_episode(physics)  # calls after_step: errors and last_info of the start

    def _hold(self) -> int:
        return int(self.random.randint(COMMAND_HOLD_STEPS[0], COMMAND_HOLD_STEPS[1] + 1))

    # --- read-outs --------------------------------------------------------------------------------

    @staticmethod
    def step_index(physics) -> int:
        """Executor steps since the episode start."""
        return int(round(physics.time() / EXECUTOR_DT))

    def command(self, physics) -> tuple[float, float]:
        """The command (V_cmd [m/s], psi_cmd [rad]) in force at the current step."""
        step = self.step_index(physics)
        while step >= self._next_change:
            _, _, psi = self._schedule[-1]
            turn = self.random.uniform(-RANDOM_TURN, RANDOM_TURN)
            self._schedule.append((self._next_change, self.random.uniform(*RANDOM_SPEED_RANGE),
                                   wrap_angle(psi + turn)))
            self._next_change += self._hold()
        for start, v_cmd, psi_cmd in reversed(self._schedule):
            if start <= step:
                return v_cmd, psi_cmd
        raise AssertionError("the command schedule starts at step 0")

    @staticmethod
    def state(physics) -> tuple[float, float, float, float]:
        """(u, v, r, psi): the executor's state of the cross-team contract."""
        u, v, r = physics.body_velocity()
        return float(u), float(v), float(r), float(physics.pose()[2])

    def phase(self, step: int) -> str:
        """Kind of the latest disturbance started at or before `step` ("none" before the first)."""
        started = [w.kind for w in self._windows if w.start <= step]
        return started[-1] if started else "none"

    def disturbance_active(self, step: int) -> bool:
        """Whether a disturbance acts during executor step `step`."""
        return any(w.start <= step < w.start + w.steps for w in self._windows)

    def _tracking_errors(self, physics, command: tuple[float, float]) -> tuple[float, float]:
        u, _, _, psi = self.state(physics)
        return command[0] - u, wrap_angle(command[1] - psi)

    def _info(self, step: int, command: tuple[float, float]) -> dict:
        """last_info of executor step `step`, which followed `command`. A tracking episode ends by its schedule, not
        at a goal: it reports no "success" (`auv_mj.episode.episode_metrics` then gives none), only whether the
        command is met this step ("within_tolerance", and Gymnasium's "is_success", which training logs read at an
        episode's end)."""
        e_v, e_psi = self._errors
        met = abs(e_v) < SPEED_TOLERANCE and abs(e_psi) < HEADING_TOLERANCE
        return {"phase": self.phase(step), "speed_error": e_v, "heading_error": e_psi,
                "command": np.array(command), "disturbance_active": self.disturbance_active(step),
                "tracked": step >= SETTLE_STEPS,
                "within_tolerance": met, "is_success": met}

    # --- dm_control Task ---------------------------------------------------------------------------

    def action_spec(self, physics) -> specs.BoundedArray:
        """Normalised (tau_u, tau_r) in [-1, 1]^2, or the four gain-scheduling actions in [-1, 1]^4."""
        if self.memory.gains:
            return specs.BoundedArray((len(GAIN_NAMES),), float, -1.0, 1.0, name=",".join(GAIN_NAMES))
        return specs.BoundedArray((physics.model.nu,), float, -1.0, 1.0, name="tau_u,tau_r")

    def before_step(self, action, physics) -> None:
        """Scales the action from [-1, 1] to the actuator ranges (ctrlrange) and applies it (as a correction to
        the S-plane's command for a residual executor)."""
        self.ocean.tick(physics)
        self._step = self.step_index(physics)
        self._step_command = self.command(physics)
        physics.set_control(self.memory.forces(checked_action(action, self.action_spec(physics), self)))

    def after_step(self, physics) -> None:
        """Errors against the command that was in force during the step; the step's info."""
        self._errors = self._tracking_errors(physics, self._step_command)
        self.last_info = self._info(self._step, self._step_command)
        # the memories move with the errors the next action will act on
        self._observation = self.memory.observe(self.command(physics), self.state(physics))

    def get_observation(self, physics) -> collections.OrderedDict:
        """"observation": (V_cmd, u, v, r, e_V, cos e_psi, sin e_psi) for the current command (Eq. 27),
        then the error integrals ("integral", "history"), the last commands ("history") and the S-plane's
        command (residual), as `ExecutorMemory.observe` built them after the step."""
        obs = collections.OrderedDict()
        obs["observation"] = self._observation.copy()
        return obs

    def get_reward(self, physics) -> float:
        """Eq. (30) -|e_V| - |e_psi| ("paper"), or the mean of two tolerances in [0, 1] ("suite")."""
        e_v, e_psi = self._errors
        if self._reward_mode == "paper":
            return -abs(e_v) - abs(e_psi)
        speed = rewards.tolerance(e_v, bounds=(-SPEED_TOLERANCE, SPEED_TOLERANCE), margin=SPEED_MARGIN)
        heading = rewards.tolerance(e_psi, bounds=(-HEADING_TOLERANCE, HEADING_TOLERANCE),
                                    margin=HEADING_MARGIN)
        return float(0.5 * (speed + heading))

    def get_termination(self, physics) -> None:
        """Never terminates: episodes end at the time limit (truncation)."""
        return None


@SUITE.add("benchmarking", "tracking", "executor")
def speed_heading(time_limit: float = _DEFAULT_TIME_LIMIT, random=None, environment_kwargs=None,
                  **task_kwargs) -> control.Environment:
    """The execution layer's speed/heading tracking task (Sec. 3.3, 4.2) in open water."""
    time_limit = options.time_limit(time_limit)
    environment_kwargs = options.environment_kwargs(environment_kwargs)
    physics = arena.load(None, thruster_lag=ocean.conditions(task_kwargs.get("conditions")).thruster_lag)
    task = SpeedHeading(random=random, **task_kwargs)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=EXECUTOR_DT,
                               **environment_kwargs)


# --- evaluation (Table 9) ---------------------------------------------------------------------------------


def executor_policy(env, executor: Executor) -> Planner:
    """`executor(command, state) -> (tau_u, tau_r)` as a policy(time_step) of the speed_heading env: its
    output is clipped to the actuator ranges and scaled to the task's [-1, 1] action (Eq. 28-29)."""
    task, physics = env.task, env.physics
    low, high = physics.model.actuator_ctrlrange.T

    def policy(time_step) -> np.ndarray:
        if time_step.first() and hasattr(executor, "reset"):
            executor.reset()
        tau = np.clip(np.asarray(executor(task.command(physics), task.state(physics)), dtype=float), low, high)
        return np.clip(2 * (tau - low) / (high - low) - 1, -1.0, 1.0)

    return FunctionPlanner(policy)


def rollout(executor: Executor, random=0, time_limit: float = _DEFAULT_TIME_LIMIT,
            **task_kwargs) -> dict[str, np.ndarray]:
    """Runs `executor(command, state)` through one speed_heading episode (the core episode loop).

    Returns per-step arrays "speed_error", "heading_error", "phase", "tracked" (from last_info) and
    "tau" (the actuator forces the executor applied, within the actuator ranges).
    """
    env = speed_heading(time_limit=time_limit, random=random, **task_kwargs)
    record = record_episode(env, executor_policy(env, executor))
    trace = {key: record.info[key] for key in ("speed_error", "heading_error", "phase")}
    trace["tracked"] = record.info["tracked"] > 0.5
    trace["tau"] = record.control[1:]
    return trace


def phase_mae(trace: dict[str, np.ndarray]) -> dict[str, tuple[float, float]]:
    """Table 9's MAE per phase of a `rollout` trace, after the SETTLE_STEPS settling steps
    (`auv_mj.episode.phase_mae`, the definition `auv-mj eval` uses too)."""
    return _phase_mae(trace["speed_error"], trace["heading_error"], trace["phase"], trace["tracked"])


def run_executor(executor: Executor, random=0, **task_kwargs) -> dict[str, tuple[float, float]]:
    """Per-phase MAE (speed, heading) of `executor` on speed_heading (Sec. 4.2 schedule by default)."""
    return phase_mae(rollout(executor, random=random, **task_kwargs))
