"""Ocean conditions for the 6-DOF vehicle (issue 32), built on the planar `auv_mj.sim.ocean`.

The same `conditions` option ("ideal", "ocean" or a mapping of effects, `ocean.conditions`) switches the same
four effects, in 3-D:

- current: the planar Gauss-Markov current (`ocean.Current`), horizontal, times a depth profile
  (`CurrentProfile`, by default the 1/7 power law of a bottom boundary layer above the seabed: full speed
  at the surface, half at 0.5^7 of the water depth above the bed); written to `model.opt.wind` at every tick;
- thruster and fin lag: MuJoCo's first-order lag on thrust, rudder and stern (`auv_mj.arenas.arena3d`), the fins'
  servo slew coming after it;
- sensors: the planar sonar noise, dropouts and latency on the 27 fan ranges (`ocean.NoisySonar`), and
  Gaussian noise on depth, DVL and gyro (SENSOR_NOISE), with DVL dropouts (the held sample stays);
- model uncertainty: each episode scales every `hydro_*` coefficient and the rigid body (`AUV3DPhysics.
  scale_vehicle`) within the planar bounds; the controllers are not told.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from auv_mj.sim import ocean
from auv_mj.sim.hydro3d import Hydro3DCoefficients
from auv_mj.sim.sensors3d import FAN_BEAMS

conditions = ocean.conditions
"""The validated `ocean.Conditions` of a task's `conditions` option (the planar function)."""
SENSOR_NOISE = {"depth": 0.02, "dvl": 0.01, "gyro": 0.002, "accelerometer": 0.02, "altimeter": 0.1}
"""Standard deviation of each sensor's Gaussian noise under ocean conditions [m, m/s, rad/s, m/s^2, m]: a
strain-gauge depth cell of 0.1 % of a 20 m range, a 1 cm/s DVL, a MEMS gyro's 0.1 deg/s."""
DVL_DROPOUT = 0.05
"""Chance that a DVL ping is lost (no bottom lock): the previous sample is held."""
COEFFICIENT_NAMES = tuple(f.name for f in fields(Hydro3DCoefficients) if f.name != "B")
"""What model uncertainty scales: every coefficient but the buoyancy (which `mass` moves with the weight)."""


@dataclass(frozen=True)
class CurrentProfile:
    """The factor on the surface current at a depth: (height above the bed / water depth)^(1/exponent)."""

    water_depth: float = 60.0
    """Depth of the seabed [m]."""
    exponent: float = 7.0
    """The power law's 1/exponent (7: a turbulent boundary layer)."""

    def factor(self, depth: float) -> float:
        height = min(max(self.water_depth - float(depth), 0.0), self.water_depth)
        return (height / self.water_depth) ** (1.0 / self.exponent)


class Ocean3D:
    """Applies `Conditions` to a 6-DOF task: `start` per episode, `tick` per executor tick, `noise` per sample."""

    def __init__(self, spec: str | ocean.Conditions | Mapping[str, Any] | None = "ideal",
                 profile: CurrentProfile | None = CurrentProfile()):
        self.conditions = ocean.conditions(spec)
        self.profile = profile
        self.current: ocean.Current | None = None
        self.scales: dict[str, float] = {}
        self._sonar: ocean.NoisySonar | None = None
        self._rng: np.random.Generator | None = None
        self._last_dvl: np.ndarray | None = None
        self._time = 0.0

    @property
    def ideal(self) -> bool:
        return self.conditions.ideal

    @property
    def time(self) -> float:
        """The time [s] the current was last moved on to."""
        return self._time

    @property
    def noise_generator(self) -> np.random.Generator | None:
        """The episode's generator of the sensors' noise (`noise`), None where `noise` adds none: what a batched
        step draws the same noise from (`auv_mj.tasks.vector3d`)."""
        if self.ideal or self._rng is None or self.conditions.sonar is None:
            return None
        return self._rng

    @property
    def sonar_latency(self) -> int:
        """Pings between a fan measurement and the task seeing it (`ocean.SonarNoise.latency`; 0 without sonar
        effects): what a planner that registers the fan with the vehicle's pose needs, as a real sonar's ping
        carries the time it was taken."""
        sonar = self.conditions.sonar
        return 0 if sonar is None else sonar.latency

    @property
    def last_dvl(self) -> np.ndarray | None:
        """The episode's last noisy DVL sample (what a dropout holds), None before its first."""
        return self._last_dvl

    def start(self, physics, random: np.random.RandomState) -> None:
        """Draws this episode's ocean from one seed of `random`; applies the vehicle scaling and the current; forgets
        the last episode's DVL sample, so that an episode is a function of its seed alone: held into the next episode,
        a dropout at its first read gave it the last episode's velocity, and an environment reseeded for each episode
        (as `auv-mj benchmark` reuses one) flew a seed differently after different episodes (goal3d seeds 13011, 13017
        and 13025 in ocean water drop their first read)."""
        self._last_dvl = None
        if self.ideal:
            return
        seeds = np.random.SeedSequence(int(random.randint(2**31 - 1))).spawn(3)
        c = self.conditions
        if c.model_uncertainty is not None:
            rng = np.random.default_rng(seeds[2])
            h, m = c.model_uncertainty.hydrodynamics, c.model_uncertainty.mass
            self.scales = dict(zip(COEFFICIENT_NAMES, rng.uniform(1 - h, 1 + h, len(COEFFICIENT_NAMES)).tolist(),
                                   strict=True))
            self.scales["mass"] = float(rng.uniform(1 - m, 1 + m))
            physics.scale_vehicle({k: v for k, v in self.scales.items() if k != "mass"}, self.scales["mass"])
        self._time = physics.time()
        self.current = None if c.current is None else ocean.Current(c.current, np.random.default_rng(seeds[0]))
        self._sonar = None if c.sonar is None else ocean.NoisySonar(c.sonar, np.random.default_rng(seeds[1]),
                                                                    FAN_BEAMS)
        self._rng = np.random.default_rng(seeds[1].spawn(1)[0])
        self._write_current(physics)

    def _write_current(self, physics) -> None:
        if self.current is None:
            return
        vx, vy = self.current.velocity()
        factor = 1.0 if self.profile is None else self.profile.factor(physics.depth())
        physics.model.opt.wind[:] = (vx * factor, vy * factor, 0.0)

    def tick(self, physics) -> None:
        """Moves the current on to the physics' time and applies it at the vehicle's depth."""
        if self.current is None:
            return
        time = physics.time()
        if time > self._time:
            self.current.advance(time - self._time)
            self._time = time
        self._write_current(physics)

    def noise(self, name: str, value: np.ndarray) -> np.ndarray:
        """A new sample of sensor `name` as the vehicle receives it (`Sensors3D`'s noise hook)."""
        if self.ideal or self._rng is None:
            return value
        if name == "sonar":
            return value if self._sonar is None else self._sonar.ping(value)
        if self.conditions.sonar is None or name not in SENSOR_NOISE:
            return value
        if name == "dvl" and self._rng.random() < DVL_DROPOUT and self._last_dvl is not None:
            return self._last_dvl
        noisy = np.asarray(value, dtype=float) + SENSOR_NOISE[name] * self._rng.standard_normal(np.shape(value))
        if name == "dvl":
            self._last_dvl = noisy
        return noisy
