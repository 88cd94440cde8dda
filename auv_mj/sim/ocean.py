"""Ocean conditions: current, thruster lag, sonar noise and model uncertainty, each switchable (issue 16).

The paper's world is ideal: still water, actuators that act at once, exact sonar, a vehicle known exactly
to its controllers. `Conditions` names what departs from it; "ideal" (the default of every task) leaves
everything as the paper has it, "ocean" switches on all four effects at the magnitudes a REMUS-100 class
vehicle meets in coastal water:

- current (`CurrentModel`): a first-order Gauss-Markov speed and direction about a mean (Fossen 2011,
  Handbook of Marine Craft Hydrodynamics and Motion Control, Sec. 8.3), saturated to bounds; the mean
  direction is drawn per episode. It is written to `model.opt.wind[:2]`, which the hydrodynamics read as
  the current (`auv_mj.sim.hydrodynamics`: the water forces act on the velocity relative to the water).
- thruster lag (`thruster_lag`): a first-order lag on tau_u and tau_r, MuJoCo's own actuator dynamics
  (dyntype="filterexact"); the time constants are the actuators' `dynprm` in the vehicle MJCF, and the
  lagged actuators are compiled only when the lag is on (`lag_actuators`), so that an ideal model is the
  paper's, bit for bit. Saturation stays the ctrlrange.
- sonar (`SonarNoise`): Gaussian range noise of a floor plus a part proportional to range, dropouts
  (no echo: SONAR_RANGE) and a latency of whole pings.
- model uncertainty (`ModelUncertainty`): each episode scales every hydrodynamic coefficient and the
  rigid-body mass and inertia within bounds. Controllers are not told: they read the nominal vehicle from
  the shipped MJCF (`auv_mj.sim.vehicle`).

`conditions(spec)` turns a task option ("ideal", "ocean", a `Conditions`, or a mapping that overrides
effects of a base preset) into a validated `Conditions`; an `Ocean` applies one to a physics episode by
episode. All randomness of an episode comes from one seed drawn from the task's RandomState after the
task has drawn its layout, so the same task seed gives the same layout in ideal and ocean conditions.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import mujoco
import numpy as np

from auv_mj.inputs import did_you_mean
from auv_mj.sim.hydrodynamics import OPTIONAL, REQUIRED
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.sim.vehicle import ACTUATORS

PRESETS = ("ideal", "ocean")
"""Names a `conditions` option may take besides a mapping."""
EFFECTS = ("current", "thruster_lag", "sonar", "model_uncertainty")
"""The effects a conditions mapping may set, each on its own."""
LAG_DYNTYPE = "filterexact"
"""MuJoCo actuator dynamics of the thruster lag: act += (ctrl - act) (1 - exp(-dt / tau)), exact for a
control held over the step."""
COEFFICIENT_NAMES = REQUIRED + OPTIONAL
"""The hydrodynamic coefficients model uncertainty scales (all of `hydro_*`)."""


MAX_CURRENT = 5.0
"""Fastest current a condition may ask for [m/s]: twice the vehicle's top speed."""
MAX_TIME_CONSTANT = 1e6
"""Longest correlation time [s]."""
MAX_LATENCY = 100
"""Most pings of sonar latency."""


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name} must be a number, got {value!r:.60}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r:.60}")
    return number


def _check(condition: bool, name: str, requirement: str, value: Any) -> None:
    if not condition:
        raise ValueError(f"{name} must be {requirement}, got {value!r:.60}")


@dataclass(frozen=True)
class CurrentModel:
    """A horizontal current V_c whose speed and direction are first-order Gauss-Markov processes.

    Each of x = speed, direction follows dx = -(x - mean) / T dt + sigma sqrt(2 / T) dW, stepped exactly
    (`GaussMarkov`) at every update (the executor's 10 Hz tick), then saturated to its bounds (Fossen 2011,
    Sec. 8.3). Stationary: mean `mean`, spread `sigma`, autocorrelation exp(-|lag| / T). The episode starts
    from a stationary draw.

    Magnitudes ("ocean"): tidal and wind-driven currents on continental shelves and in coastal water are a
    few tenths of a metre per second (Simpson & Sharples 2012, Introduction to the Physical and Biological
    Oceanography of Shelf Seas, Ch. 3-4), a quarter of the 1 m/s that the tasks command and a sixth of a
    REMUS-100's 1.5 m/s cruise (Prestero 2001): 0.25 m/s mean, 0.05 m/s spread, at most 0.5 m/s. Tides turn
    over hours; the time constants (2 and 5 min) put a few fluctuations into a 10-minute episode instead.
    Direction: uniform per episode, wandering 10 deg (at most 30 deg) about it.
    """

    mean_speed: float = 0.25
    """Mean current speed [m/s]."""
    speed_sigma: float = 0.05
    """Stationary standard deviation of the speed [m/s]."""
    speed_time_constant: float = 120.0
    """Correlation time of the speed [s]."""
    speed_bounds: tuple[float, float] = (0.0, 0.5)
    """The speed is saturated to this range [m/s]."""
    mean_direction: float | None = None
    """Mean direction the water flows towards [rad, world frame]; None draws it uniformly per episode."""
    direction_sigma: float = math.radians(10.0)
    """Stationary standard deviation of the direction about its mean [rad]."""
    direction_time_constant: float = 300.0
    """Correlation time of the direction [s]."""
    direction_bound: float = math.radians(30.0)
    """The direction stays within this of its mean [rad]."""

    def __post_init__(self):
        name = "current"
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "speed_bounds":
                if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
                    raise ValueError(f"{name}.speed_bounds must be a pair (min, max) [m/s], got {value!r:.60}")
                low, high = (_number(v, f"{name}.speed_bounds") for v in value)
                _check(0.0 <= low <= high <= MAX_CURRENT, f"{name}.speed_bounds",
                       f"a pair 0 <= min <= max <= {MAX_CURRENT:g} m/s", value)
                object.__setattr__(self, f.name, (low, high))
            elif not (f.name == "mean_direction" and value is None):
                object.__setattr__(self, f.name, _number(value, f"{name}.{f.name}"))
        low, high = self.speed_bounds
        _check(low <= self.mean_speed <= high, f"{name}.mean_speed", f"within speed_bounds {self.speed_bounds}",
               self.mean_speed)
        for field_name, high in (("speed_sigma", MAX_CURRENT), ("direction_sigma", 2 * math.pi),
                                 ("direction_bound", math.pi)):
            value = getattr(self, field_name)
            _check(0 <= value <= high, f"{name}.{field_name}", f"in [0, {high:g}]", value)
        for field_name in ("speed_time_constant", "direction_time_constant"):
            value = getattr(self, field_name)
            _check(0 < value <= MAX_TIME_CONSTANT, f"{name}.{field_name}", f"in (0, {MAX_TIME_CONSTANT:g}] s", value)
        _check(self.direction_bound <= math.pi, f"{name}.direction_bound", "<= pi", self.direction_bound)


@dataclass(frozen=True)
class SonarNoise:
    """What a real single-beam sonar adds to the exact rangefinder ranges, ping by ping.

    An echo at range d reads d + N(0, (floor + proportional d)^2), kept within [0, SONAR_RANGE]; with
    probability `dropout` a beam's echo is lost and it reads SONAR_RANGE, as if it saw nothing; the task
    sees the ping `latency` pings old (before the first pings arrive, nothing: SONAR_RANGE).

    Magnitudes ("ocean"): a sonar turns echo time into range with an assumed sound speed, and the sound
    speed of coastal water varies by a few percent with temperature and salinity (Urick 1983, Principles of
    Underwater Sound, Ch. 5): 1 % of range; the floor of 0.05 m is the resolution of a ~65 us pulse.
    Smooth walls at oblique incidence reflect the beam away (specular miss; Leonard & Durrant-Whyte 1992,
    Directed Sonar Sensing for Mobile Robot Navigation): 5 % of echoes are lost. The planner acts on the
    previous 2 Hz ping (latency 1), the time the echoes of a 120 m range take and the processing after it.
    """

    floor: float = 0.05
    """Standard deviation of the range noise at zero range [m]."""
    proportional: float = 0.01
    """Standard deviation added per metre of range [m/m]."""
    dropout: float = 0.05
    """Probability that a beam's echo is lost on a ping."""
    latency: int = 1
    """Pings between a measurement and the task seeing it."""

    def __post_init__(self):
        name = "sonar"
        for field_name, high in (("floor", SONAR_RANGE), ("proportional", 1.0), ("dropout", 1.0)):
            value = _number(getattr(self, field_name), f"{name}.{field_name}")
            _check(0 <= value <= high, f"{name}.{field_name}", f"in [0, {high:g}]", value)
            object.__setattr__(self, field_name, value)
        _check(self.dropout < 1, f"{name}.dropout", "a probability in [0, 1)", self.dropout)
        latency = self.latency
        _check(isinstance(latency, (int, np.integer)) and not isinstance(latency, bool) and 0 <= latency <= MAX_LATENCY,
               f"{name}.latency", f"a whole number of pings in [0, {MAX_LATENCY}]", latency)
        object.__setattr__(self, "latency", int(latency))


@dataclass(frozen=True)
class ModelUncertainty:
    """Per-episode scaling of the vehicle the controllers do not know about.

    Every `hydro_*` coefficient is scaled by its own factor drawn uniformly from [1 - hydrodynamics,
    1 + hydrodynamics], and the mass and yaw inertia by one factor from [1 - mass, 1 + mass].

    Magnitudes ("ocean"): semi-empirical hydrodynamic derivatives such as Prestero's (2001) for REMUS are
    uncertain by tens of percent (he corrected several against field trials): +-20 %. Payload and trim
    weights change a 30 kg REMUS-100 by a kilogram or two: +-5 %.
    """

    hydrodynamics: float = 0.2
    """Half-width of the relative scaling of each hydrodynamic coefficient."""
    mass: float = 0.05
    """Half-width of the relative scaling of the mass and yaw inertia."""

    def __post_init__(self):
        for field_name in ("hydrodynamics", "mass"):
            value = _number(getattr(self, field_name), f"model_uncertainty.{field_name}")
            _check(0 <= value < 1, f"model_uncertainty.{field_name}", "in [0, 1)", value)
            object.__setattr__(self, field_name, value)


@dataclass(frozen=True)
class Conditions:
    """Which ocean effects are on, and how strong (None / False: off, the paper's ideal world)."""

    current: CurrentModel | None = None
    """The time-varying current, or None for still water (or the MJCF's constant `wind`)."""
    thruster_lag: bool = False
    """First-order lag on tau_u and tau_r with the vehicle MJCF's time constants (actuator `dynprm`): in
    `models/auv.xml` 0.4 s for the thrust (propeller spin-up and inflow) and 0.2 s for the yaw moment
    (rudder servos), a few tenths of a second as thruster-dynamics studies find for small vehicles
    (Yoerger, Cooke & Slotine 1990, IEEE J. Oceanic Eng. 15(3); Fossen 2011, Ch. 9)."""
    sonar: SonarNoise | None = None
    """Range noise, dropouts and latency of the sonar, or None for exact ranges."""
    model_uncertainty: ModelUncertainty | None = None
    """Per-episode scaling of the vehicle's coefficients and mass, or None for the nominal vehicle."""

    def __post_init__(self):
        for name, kind in (("current", CurrentModel), ("sonar", SonarNoise),
                           ("model_uncertainty", ModelUncertainty)):
            value = getattr(self, name)
            _check(value is None or isinstance(value, kind), f"conditions.{name}", f"a {kind.__name__} or None",
                   value)
        _check(isinstance(self.thruster_lag, bool), "conditions.thruster_lag", "true or false", self.thruster_lag)

    @property
    def ideal(self) -> bool:
        """Whether every effect is off (the paper's world)."""
        return self == IDEAL

    @property
    def name(self) -> str:
        """"ideal", "ocean" or "custom"."""
        return "ideal" if self == IDEAL else "ocean" if self == OCEAN else "custom"


IDEAL = Conditions()
"""The paper's world: still water, instant actuators, exact sonar, the nominal vehicle."""
OCEAN = Conditions(current=CurrentModel(), thruster_lag=True, sonar=SonarNoise(),
                   model_uncertainty=ModelUncertainty())
"""Coastal water for a REMUS-100 class vehicle: every effect at the magnitudes documented on its class."""
_PRESET = {"ideal": IDEAL, "ocean": OCEAN}
_EFFECT_CLASSES = {"current": CurrentModel, "sonar": SonarNoise, "model_uncertainty": ModelUncertainty}


def conditions(spec: str | Conditions | Mapping[str, Any] | None = "ideal") -> Conditions:
    """The validated `Conditions` of a task's `conditions` option.

    `spec` is "ideal" (or None), "ocean", a `Conditions`, or a mapping such as {"thruster_lag": false} or
    {"base": "ideal", "current": {"mean_speed": 0.4}}: "base" (default "ocean") is the preset it starts from;
    "current", "sonar" and "model_uncertainty" are true (the ocean magnitudes), false (off) or a mapping of
    fields overriding the ocean magnitudes; "thruster_lag" is true or false. A ValueError names the bad
    field and value.
    """
    if spec is None:
        return IDEAL
    if isinstance(spec, Conditions):
        return spec
    if isinstance(spec, str):
        if spec not in _PRESET:
            raise ValueError(f"conditions must be one of {PRESETS} or a mapping of effects, got {spec!r:.60}"
                             f"{did_you_mean(spec, PRESETS)}")
        return _PRESET[spec]
    if not isinstance(spec, Mapping):
        raise ValueError(f"conditions must be one of {PRESETS} or a mapping of effects, got {spec!r:.60}")
    unknown = [k for k in spec if k not in ("base", *EFFECTS)]
    if unknown:
        raise ValueError(f"conditions: unknown key(s) {', '.join(map(repr, unknown))}"
                         f"{did_you_mean(unknown[0], ('base', *EFFECTS))}; known: base, {', '.join(EFFECTS)}")
    base = spec.get("base", "ocean")
    if not isinstance(base, str) or base not in _PRESET:
        raise ValueError(f"conditions.base must be one of {PRESETS}, got {base!r:.60}{did_you_mean(base, PRESETS)}")
    changes: dict[str, Any] = {}
    for effect, value in spec.items():
        if effect == "base":
            continue
        if effect == "thruster_lag":
            _check(isinstance(value, bool), "conditions.thruster_lag", "true or false", value)
            changes[effect] = value
        else:
            changes[effect] = _effect(effect, value)
    return replace(_PRESET[base], **changes)


def _effect(effect: str, value: Any):
    """One effect of a conditions mapping: True (ocean magnitudes), False / None (off) or field overrides."""
    if value is None or value is False:
        return None
    default = getattr(OCEAN, effect)
    if value is True:
        return default
    if isinstance(value, _EFFECT_CLASSES[effect]):
        return value
    if not isinstance(value, Mapping):
        raise ValueError(f"conditions.{effect} must be true, false or a mapping of its fields, got {value!r:.60}")
    known = [f.name for f in fields(_EFFECT_CLASSES[effect])]
    unknown = [k for k in value if k not in known]
    if unknown:
        raise ValueError(f"conditions.{effect}: unknown field(s) {', '.join(map(repr, unknown))}; "
                         f"known: {', '.join(known)}")
    try:
        return replace(default, **value)
    except ValueError as e:
        raise ValueError(f"conditions.{str(e)}") from None


# --- thruster lag: compiled into the vehicle's actuators ---------------------------------------------------


def lag_actuators(root: ET.Element, source: str = "vehicle") -> ET.Element:
    """Gives the vehicle's actuators (tau_u, tau_r) MuJoCo's first-order dynamics, in place; returns `root`.

    Each actuator's time constant is its `dynprm` in the MJCF (ignored by MuJoCo while dyntype is "none",
    the ideal default). `actearly` makes the force of a step the filter's value at the step's end, so the
    lag is exactly the first-order response sampled at the steps. A ValueError names a missing constant.
    """
    found = {el.get("name"): el for el in root.iter() if el.get("name") in ACTUATORS and el.tag == "general"}
    for name in ACTUATORS:
        actuator = found.get(name)
        if actuator is None:
            raise ValueError(f"{source}: thruster lag needs a <general name=\"{name}\"> actuator")
        parameters = (actuator.get("dynprm") or "").split()
        try:
            time_constant = float(parameters[0]) if parameters else math.nan
        except ValueError:
            time_constant = math.nan
        if not (math.isfinite(time_constant) and time_constant > 0):
            raise ValueError(f"{source}: thruster lag needs the time constant [s] of actuator '{name}' as a "
                             f"positive dynprm, e.g. dynprm=\"0.4\"; got dynprm={actuator.get('dynprm')!r}")
        actuator.set("dyntype", LAG_DYNTYPE)
        actuator.set("actearly", "true")
    return root


def thruster_time_constants(model: mujoco.MjModel) -> dict[str, float]:
    """Time constant [s] of each vehicle actuator as the MJCF gives it (its dynprm[0])."""
    return {name: float(model.actuator_dynprm[model.actuator(name).id][0]) for name in ACTUATORS}


def has_thruster_lag(model: mujoco.MjModel) -> bool:
    """Whether the vehicle's actuators were compiled with the first-order lag."""
    lag = int(mujoco.mjtDyn.mjDYN_FILTEREXACT)
    return all(int(model.actuator_dyntype[model.actuator(name).id]) == lag for name in ACTUATORS)


# --- the random processes ----------------------------------------------------------------------------------


class Normals:
    """Standard normal draws of `rng`, one NumPy call per `block` of them (a scalar call costs a microsecond)."""

    def __init__(self, rng: np.random.Generator, block: int = 256):
        self._rng, self._block = rng, block
        self._draws: list[float] = []

    @property
    def rng(self) -> np.random.Generator:
        """The generator the draws come from."""
        return self._rng

    def pending(self) -> list[float]:
        """The draws already taken from `rng` and not yet used, the next first (a batched step continues them)."""
        return self._draws[::-1]

    def __call__(self) -> float:
        if not self._draws:
            self._draws = self._rng.standard_normal(self._block).tolist()[::-1]
        return self._draws.pop()


class GaussMarkov:
    """A first-order Gauss-Markov process x about `mean`, stepped exactly and saturated to `bounds`.

    x(t + dt) = mean + a (x(t) - mean) + sigma sqrt(1 - a^2) w, a = exp(-dt / T), w ~ N(0, 1): the exact
    transition of dx = -(x - mean) / T dt + sigma sqrt(2 / T) dW for any dt. Without saturation the process
    is stationary with mean `mean`, standard deviation `sigma` and autocorrelation exp(-|lag| / T).
    """

    def __init__(self, mean: float, sigma: float, time_constant: float, bounds: tuple[float, float],
                 normal: Normals):
        self.mean, self.sigma, self.time_constant = float(mean), float(sigma), float(time_constant)
        self.low, self.high = (float(b) for b in bounds)
        self._normal = normal
        self._dt, self._a, self._b = 0.0, 1.0, 0.0
        self.value = min(max(self.mean + self.sigma * normal(), self.low), self.high)

    @property
    def normal(self) -> Normals:
        """The stream of normal draws w."""
        return self._normal

    @property
    def transition(self) -> tuple[float, float, float]:
        """(dt, a, sigma sqrt(1 - a^2)) of the last `advance`: the exact transition, kept while dt stays."""
        return self._dt, self._a, self._b

    def advance(self, dt: float) -> float:
        """Moves the process on by `dt` [s] and returns its new value."""
        if dt != self._dt:  # the executor's tick keeps dt fixed: the transition is computed once
            self._dt, self._a = dt, math.exp(-dt / self.time_constant)
            self._b = self.sigma * math.sqrt(1.0 - self._a * self._a)
        x = self.mean + self._a * (self.value - self.mean) + self._b * self._normal()
        self.value = min(max(x, self.low), self.high)
        return self.value


class Current:
    """One episode of a `CurrentModel`: the speed and direction processes and the world velocity V_c."""

    def __init__(self, model: CurrentModel, rng: np.random.Generator):
        self.model = model
        direction = (float(rng.uniform(-math.pi, math.pi)) if model.mean_direction is None
                     else model.mean_direction)
        normal = Normals(rng)
        self.speed = GaussMarkov(model.mean_speed, model.speed_sigma, model.speed_time_constant,
                                 model.speed_bounds, normal)
        self.direction = GaussMarkov(direction, model.direction_sigma, model.direction_time_constant,
                                     (direction - model.direction_bound, direction + model.direction_bound), normal)

    def advance(self, dt: float) -> None:
        """Moves both processes on by `dt` [s]."""
        self.speed.advance(dt)
        self.direction.advance(dt)

    def velocity(self) -> tuple[float, float]:
        """V_c = speed (cos direction, sin direction) in the world frame [m/s]."""
        speed, direction = self.speed.value, self.direction.value
        return speed * math.cos(direction), speed * math.sin(direction)


class NoisySonar:
    """One episode of `SonarNoise`: call `ping(ranges)` once per sonar sample, in order."""

    def __init__(self, noise: SonarNoise, rng: np.random.Generator, beams: int):
        self.noise = noise
        self._rng = rng
        self._queue = [np.full(beams, SONAR_RANGE) for _ in range(noise.latency)]

    def ping(self, ranges: np.ndarray) -> np.ndarray:
        """The ranges [m] the task sees for this ping: noisy, with dropouts, `latency` pings old."""
        n = self.noise
        ranges = np.asarray(ranges, dtype=float)
        noise = self._rng.standard_normal(ranges.shape)
        lost = self._rng.random(ranges.shape) < n.dropout
        echo = ranges < SONAR_RANGE
        measured = np.clip(ranges + (n.floor + n.proportional * ranges) * noise, 0.0, SONAR_RANGE)
        measured = np.where(echo & ~lost, measured, SONAR_RANGE)
        if not self._queue:
            return measured
        self._queue.append(measured)
        return self._queue.pop(0)


# --- an episode's ocean ------------------------------------------------------------------------------------


class Ocean:
    """Applies `Conditions` to a task's physics: per episode (`start`), per executor tick (`tick`), per
    sonar ping (`sense`). With ideal conditions every call leaves the physics and the ranges untouched and
    draws nothing from the task's RandomState.
    """

    def __init__(self, spec: str | Conditions | Mapping[str, Any] | None = "ideal"):
        self.conditions = conditions(spec)
        self.current: Current | None = None
        self.sonar: NoisySonar | None = None
        self.scales: dict[str, float] = {}
        """This episode's factors: "mass" and each hydrodynamic coefficient's name (empty: nominal)."""
        self._time = 0.0
        self._clock: tuple | None = None  # (MjData, memoryview of opt.wind) of the episode's physics

    @property
    def time(self) -> float:
        """The physics time [s] the current was last moved on to."""
        return self._time

    @property
    def ideal(self) -> bool:
        """Whether the conditions are the paper's (then this object does nothing)."""
        return self.conditions.ideal

    def check(self, physics) -> None:
        """Refuses a physics compiled without the thruster lag these conditions ask for, or with it unasked."""
        lag = self.conditions.thruster_lag
        if has_thruster_lag(physics.model.ptr) != lag:
            raise ValueError(f"conditions {self.conditions.name!r} {'need' if lag else 'do not want'} the lagged "
                             f"actuators, but the physics has {'none' if lag else 'them'}: compile it with "
                             f"thruster_lag={lag} (`auv_mj.arenas.arena.load`)")

    def start(self, physics, random: np.random.RandomState, beams: int = 0) -> None:
        """Draws this episode's ocean from one seed of `random` and applies it to `physics` (at rest, t = 0).

        Model uncertainty rescales the vehicle, the current is written to `model.opt.wind`, and the sonar
        queue is emptied; `beams` is the number of sonar ranges a ping holds.
        """
        if self.ideal:
            return
        self.check(physics)
        current_seed, sonar_seed, model_seed = np.random.SeedSequence(int(random.randint(2**31 - 1))).spawn(3)
        c = self.conditions
        if c.model_uncertainty is not None:
            rng = np.random.default_rng(model_seed)
            h, m = c.model_uncertainty.hydrodynamics, c.model_uncertainty.mass
            factors = rng.uniform(1.0 - h, 1.0 + h, len(COEFFICIENT_NAMES))
            self.scales = dict(zip(COEFFICIENT_NAMES, factors.tolist(), strict=True))
            self.scales["mass"] = float(rng.uniform(1.0 - m, 1.0 + m))
            physics.scale_vehicle({k: v for k, v in self.scales.items() if k != "mass"}, self.scales["mass"])
        data = physics.data.ptr
        self._time = data.time
        if c.current is not None:
            self.current = Current(c.current, np.random.default_rng(current_seed))
            self._clock = (data, memoryview(physics.model.ptr.opt.wind))
            self._clock[1][0], self._clock[1][1] = self.current.velocity()
        self.sonar = None if c.sonar is None else NoisySonar(c.sonar, np.random.default_rng(sonar_seed), beams)

    def tick(self, physics) -> None:
        """Moves the current on to the physics' time (call at least at the executor's 10 Hz)."""
        current = self.current
        if current is None:
            return
        data, wind = self._clock
        time = data.time
        if time > self._time:
            current.advance(time - self._time)
            self._time = time
            wind[0], wind[1] = current.velocity()

    def sense(self, ranges: np.ndarray) -> np.ndarray:
        """The ranges a task sees of one ping of true `ranges` [m] (the same array when the sonar is exact)."""
        return ranges if self.sonar is None else self.sonar.ping(ranges)
