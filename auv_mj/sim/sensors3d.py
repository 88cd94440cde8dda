"""The 6-DOF vehicle's sensors (issue 32): a 3-D sonar fan, an altimeter, depth from pressure, a DVL and an IMU.

- Sonar fan: the planar vehicle's nine beams (Sec. 2.2, -90..+90 deg in azimuth) in each of three elevations
  (FAN_ELEVATIONS), 27 ranges cast from the `sonar` site by one `mj_multiRay` call; no echo reads SONAR_RANGE.
  Beams are ordered elevation by elevation (down, level, up), each starboard to port.
- Altimeter: one beam straight down the body's -z axis from the `altimeter` site, up to ALTIMETER_RANGE.
- Depth from pressure: the `pressure_port` framepos sensor gives the port's height; the gauge reads the
  hydrostatic pressure p = RHO_WATER g (surface - z) [Pa] (`pressure`), and `depth` inverts it, as a vehicle's
  depth cell does.
- DVL: MuJoCo's `velocimeter` at the `dvl` site, the velocity over ground in the body frame (bottom lock).
- IMU: MuJoCo's `gyro` and `accelerometer` at the `imu` site, and the `attitude` framequat (an AHRS).

`Sensors3D` samples each at its rate (SAMPLE_RATES_HZ) and holds the sample in between, as `SampleAndHold`
does for the planar sonar; noise and dropouts are added by `auv_mj.sim.ocean3d` under ocean conditions.
`FanFilter` reads the fan over pings (each beam the nearer of its newest ping and its median over the last
FILTER_PINGS), as the 3-D protection domain and the planning tasks' observation="fan-held" take it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_RANGE, SONAR_RATE_HZ

FAN_AZIMUTHS = BEAM_ANGLES
"""Beam azimuths in the body frame [rad], the planar S1..S9: starboard (-90 deg) to port (+90 deg)."""
FAN_ELEVATIONS = np.radians([-30.0, 0.0, 30.0])
"""Beam elevations [rad]: a row looking down, the planar row, a row looking up."""
FAN_BEAMS = len(FAN_AZIMUTHS) * len(FAN_ELEVATIONS)
FILTER_PINGS = 3
"""Pings of each beam `FanFilter` takes the median of: a lost echo (reading SONAR_RANGE) or a range that jumps away
on one ping of three is outvoted."""
ALTIMETER_RANGE = 50.0
"""Farthest seabed the altimeter sees [m] (a 200 kHz class echo sounder); beyond, it reads this."""
RHO_WATER = 1025.0
"""Sea water density [kg/m^3] of the pressure-to-depth conversion."""
GRAVITY = 9.81
SURFACE_Z = 0.0
"""Height of the sea surface in the world [m]: depth is SURFACE_Z - z."""
SAMPLE_RATES_HZ = {"sonar": SONAR_RATE_HZ, "altimeter": 5.0, "depth": 10.0, "dvl": 10.0, "imu": 50.0}
"""How often each sensor delivers a new sample [Hz]: the sonar as in the plane (Sec. 2.2), the others at rates
of their common hardware."""
SENSOR_NAMES = ("pressure_port", "dvl", "gyro", "accelerometer", "attitude")
"""The MJCF sensors this module reads."""


def fan_directions() -> np.ndarray:
    """(27, 3) unit beam directions in the body frame (x forward, y port, z up), elevation-major."""
    elevation, azimuth = np.meshgrid(FAN_ELEVATIONS, FAN_AZIMUTHS, indexing="ij")
    return np.stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                     np.sin(elevation)], axis=-1).reshape(-1, 3)


_FAN = fan_directions()


def _rays(model: mujoco.MjModel, data: mujoco.MjData, origin: np.ndarray, directions: np.ndarray, body: int,
          cutoff: float) -> np.ndarray:
    """Ranges [m] along world `directions` from `origin`, ignoring `body`; cutoff where nothing is hit."""
    n = len(directions)
    geoms = np.zeros(n, dtype=np.int32)
    dist = np.zeros(n)
    mujoco.mj_multiRay(model, data, np.ascontiguousarray(origin, dtype=float),
                       np.ascontiguousarray(directions, dtype=float).ravel(), None, 1, body, geoms, dist, None, n,
                       cutoff)
    return np.where((dist < 0) | (dist > cutoff), cutoff, dist)


def sonar_fan(physics) -> np.ndarray:
    """The 27 fan ranges [m] at the current state (module docstring)."""
    model, data = physics.model.ptr, physics.data.ptr
    site = model.site("sonar").id
    rotation = data.site_xmat[site].reshape(3, 3)
    body = int(model.site_bodyid[site])
    return _rays(model, data, data.site_xpos[site], _FAN @ rotation.T, body, SONAR_RANGE)


def altimeter(physics) -> float:
    """Range straight down the body's -z axis to the nearest geom [m], ALTIMETER_RANGE when none is in range."""
    model, data = physics.model.ptr, physics.data.ptr
    site = model.site("altimeter").id
    down = -data.site_xmat[site].reshape(3, 3)[:, 2]
    return float(_rays(model, data, data.site_xpos[site], down[None, :], int(model.site_bodyid[site]),
                       ALTIMETER_RANGE)[0])


def pressure(physics) -> float:
    """Gauge pressure at the pressure port [Pa]: RHO_WATER g (SURFACE_Z - z) (the sensors must be evaluated)."""
    z = physics.data.ptr.sensor("pressure_port").data[2]
    return RHO_WATER * GRAVITY * (SURFACE_Z - float(z))


def depth_from_pressure(p: float) -> float:
    """Depth [m] of a gauge pressure `p` [Pa]."""
    return p / (RHO_WATER * GRAVITY)


class Sensors3D:
    """Samples the 6-DOF vehicle's sensors at SAMPLE_RATES_HZ and holds each sample until the next.

    `read(physics)` returns {"sonar": (27,), "altimeter": (), "depth": (), "dvl": (3,), "gyro": (3,),
    "accelerometer": (3,), "attitude": (4,)}; `noise`, if given, is called as noise(name, value) -> value on
    each new sample (ocean conditions).
    """

    def __init__(self, rates: dict[str, float] | None = None, noise=None):
        self.rates = dict(SAMPLE_RATES_HZ if rates is None else rates)
        for name, rate in self.rates.items():
            if not (math.isfinite(rate) and rate > 0):
                raise ValueError(f"sensor {name}: the sample rate must be positive [Hz], got {rate!r}")
        self.noise = noise
        self.reset()

    def reset(self) -> None:
        """Forgets every held sample; the next read samples all sensors afresh."""
        self._due = dict.fromkeys(self.rates, -math.inf)
        self._held: dict[str, np.ndarray] = {}

    @property
    def due(self) -> dict[str, float]:
        """When each sensor next samples [s] (a copy)."""
        return dict(self._due)

    @property
    def held(self) -> dict[str, np.ndarray]:
        """The held samples (copies), as `read` returns them, without sampling."""
        return {k: v.copy() for k, v in self._held.items()}

    def read(self, physics) -> dict[str, np.ndarray]:
        """The held samples, refreshing those that are due at the physics' time."""
        time = physics.time()
        due = [name for name, at in self._due.items() if time >= at - 1e-9]
        if due:
            physics.evaluate_sensors()
            data = physics.data.ptr  # MuJoCo's own named access (no dm_control indexers: see AUV3DPhysics.named)
            for name in due:
                period = 1.0 / self.rates[name]
                self._due[name] = (math.floor(time / period + 1e-9) + 1) * period
                if name == "sonar":
                    value = sonar_fan(physics)
                elif name == "altimeter":
                    value = np.array(altimeter(physics))
                elif name == "depth":
                    value = np.array(depth_from_pressure(pressure(physics)))
                elif name == "dvl":
                    value = data.sensor("dvl").data.copy()
                else:  # imu
                    self._held["gyro"] = self._noisy("gyro", data.sensor("gyro").data.copy())
                    self._held["accelerometer"] = self._noisy("accelerometer", data.sensor("accelerometer").data.copy())
                    self._held["attitude"] = data.sensor("attitude").data.copy()
                    continue
                self._held[name] = self._noisy(name, value)
        return {k: v.copy() for k, v in self._held.items()}

    def _noisy(self, name: str, value: np.ndarray) -> np.ndarray:
        return value if self.noise is None else np.asarray(self.noise(name, value), dtype=float)


class FanFilter:
    """The fan filtered over pings: each beam the nearer of its newest ping and its median over the last
    FILTER_PINGS pings. The 3-D protection domain reads the fan so in a tube (`auv_mj.planners.los3d.domain_ranges`),
    and the planning tasks' observation="fan-held" gives it to a learner (`auv_mj.tasks.auv3d.OBSERVATIONS`).

    A beam's range is filtered over time, as an occupancy grid accumulates readings (Borenstein and Koren's vector
    field histogram, 1991; Thrun et al., *Probabilistic Robotics*, Ch. 6, on max-range readings as failures): an echo
    lost for one ping (SONAR_RANGE) or a range that jumps away for one ping does not move the median, so the domain
    does not let go of a wall whose echo dropped, which turned the vehicle into it. An echo that comes nearer is
    taken at once, as the domain's purpose asks: waiting for a second ping would cost a ping (0.5 s, 0.75 m at
    cruise speed) on every obstacle, and a false near echo only turns the vehicle away for a ping. Call it with
    the time and the fan's held ranges; it takes a new ping once per sonar period (`SONAR_RATE_HZ`)."""

    def __init__(self, pings: int = FILTER_PINGS):
        if isinstance(pings, bool) or not isinstance(pings, int) or pings < 1:
            raise ValueError(f"a fan filter needs a whole number of pings >= 1, got {pings!r}")
        self.pings = pings
        self.reset()

    def reset(self) -> None:
        """Forgets the pings (a new episode)."""
        self._history: list[np.ndarray] = []
        self._ping = None

    def __call__(self, time: float, ranges: np.ndarray) -> np.ndarray:
        """The filtered ranges [m] after the fan's `ranges` [m] held at `time` [s]: per beam, the nearer of the
        newest ping and the median of the last FILTER_PINGS."""
        ping = math.floor(float(time) * SONAR_RATE_HZ + 1e-9)
        if ping != self._ping or not self._history:
            self._ping = ping
            kept = self._history[max(len(self._history) - self.pings + 1, 0):]
            self._history = [*kept, np.asarray(ranges, dtype=float).copy()]
        return np.minimum(np.median(np.stack(self._history), axis=0), self._history[-1])
