"""The batched 6-DOF step (`batch3d_kernel.c`): N vehicles, each in its own MuJoCo model, advanced in one C call.

The 6-DOF twin of `auv_mj.sim.batch`: one ctypes call (which releases the GIL) advances a batch of 3-D planning
vehicles by a planner step, shared out to POSIX threads, and returns what the task reads after a step (position,
true heading, the hull's contact, the held sensor samples and the attitude they give) as one array.

The C tick is the 3-D planning tasks' own (`auv_mj.tasks.auv3d.Planning3D._tick`): the movers, the current with its
depth profile, the sensors' sample-and-hold and the depth-heading S-plane, in the same order of floating-point
operations as the Python, so that a vehicle follows the single environment's trajectory to the bit. What is not
MuJoCo's comes as numbers: the executor's gains (`GAINS`), the current's parameters (`PARAMETERS`), the mutable
state (`STATE`: command, integrators, current, held samples), the current's normal draws (`normals`), and, for each
read of a step, which sensors are due (`masks`, bits `READ_BITS`) and the sensors' noise in the order it is drawn
(`noise`): both are the caller's, worked out by the rules of `Sensors3D` and `Ocean3D.noise` from the episode's own
generators, since NumPy's streams cannot be drawn in C.

The library is built like `auv_mj.sim.batch`'s (against the `mujoco` package's headers and library, into the cache of
`auv_mj.sim.native`); `kernel()` is None where it cannot be built (no compiler, no headers, AUV_MJ_NATIVE=0), and
the batch then says why.
"""

from __future__ import annotations

import ctypes
import subprocess
from functools import cache
from pathlib import Path

import numpy as np

from auv_mj.sim import batch, native, native3d
from auv_mj.sim.ocean3d import SENSOR_NOISE
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, FAN_BEAMS, GRAVITY, RHO_WATER, SAMPLE_RATES_HZ, SURFACE_Z
from auv_mj.sim.sonar import SONAR_RANGE

SOURCE = Path(__file__).with_name("batch3d_kernel.c")
INCLUDED = (native3d.SOURCE, Path(__file__).with_name("tick_kernel.c"))
"""Files `batch3d_kernel.c` includes (they key the compiled library too)."""
FLAGS = (*native3d.FLAGS, "-fno-builtin-sin", "-fno-builtin-cos")
"""hydro3d_kernel.c's flags (its step then rounds as the single physics'); libm's own sin and cos, as `math`."""
STATE = ("speed_command", "heading_command", "depth_command", "int_speed", "int_heading", "int_depth", "last_u",
         "has_last_u", "ready", "noise_on", "ocean_time", "current_on", "current_speed", "current_speed_dt",
         "current_speed_a", "current_speed_b", "current_direction", "current_direction_dt", "current_direction_a",
         "current_direction_b", "normal_position", "last_dvl_x", "last_dvl_y", "last_dvl_z", "altimeter", "depth",
         "dvl_x", "dvl_y", "dvl_z", "gyro_x", "gyro_y", "gyro_z", "accelerometer_x", "accelerometer_y",
         "accelerometer_z", "attitude_w", "attitude_x", "attitude_y", "attitude_z")
"""A vehicle's mutable row, in batch3d_kernel.c's order: the command, the executor's memory, the current, the noise
switch, the DVL's last noisy sample (what a dropout holds) and the held samples of `Sensors3D`."""
GAINS = ("k1_speed", "k2_speed", "ki_speed", "k1_heading", "k2_heading", "ki_heading", "k1_depth", "k2_depth",
         "ki_depth", "max_pitch", "k1_pitch", "k2_pitch", "band_depth", "integral_limit", "dt", "thrust_limit",
         "fin_limit", "surge_drag")
"""The executor's row as batch3d_kernel.c reads it: the fields of `auv_mj.control.depth_heading.DepthHeadingGains` in
their order (the batched env checks that they are), then the executor's period [s], thrust limit [N], fin limit [rad]
and surge drag [N s^2/m^2]."""
PARAMETERS = ("speed_mean", "speed_sigma", "speed_time_constant", "speed_low", "speed_high",
              "direction_mean", "direction_sigma", "direction_time_constant", "direction_low", "direction_high",
              "profile_on", "water_depth", "exponent")
"""A vehicle's constant row: the current's Gauss-Markov processes and its depth profile (`ocean3d.CurrentProfile`)."""
CONSTANTS = ("rho_g", "surface_z", "sonar_range", "altimeter_range", "sigma_altimeter", "sigma_depth", "sigma_dvl",
             "sigma_gyro", "sigma_accelerometer")
"""The sensors' constants (`auv_mj.sim.sensors3d`, `ocean3d.SENSOR_NOISE`)."""
OUTPUTS = ("x", "y", "z", "heading", "time", "collided", "invalid", "sonar_samples", "roll", "pitch",
           "sensed_heading", *(f"sonar_{k + 1}" for k in range(FAN_BEAMS)))
"""What a step reports per vehicle: position, true heading, time, whether the hull touches anything now, whether
MuJoCo warned or reset the state, how many fan samples the step took (their raw ranges follow), and the roll, pitch
and heading of the held attitude sample."""
READ_BITS = {"sonar": 1, "altimeter": 2, "depth": 4, "dvl": 8, "imu": 16}
"""A read's mask: the due sensors, in `SAMPLE_RATES_HZ`' order (the order `Sensors3D.read` samples them)."""
STATE_INDEX = {name: i for i, name in enumerate(STATE)}
PARAMETER_INDEX = {name: i for i, name in enumerate(PARAMETERS)}
OUTPUT_INDEX = {name: i for i, name in enumerate(OUTPUTS)}
MOVER_SIZE = 9
"""A mover record: mocap slot, speed, span, start (3), end (3)."""
MAX_READS = 16
"""Reads of one step (ticks and the after-step read) a mask row holds."""
NOISE_CAPACITY = 256
"""Noise draws one vehicle's step may use."""


class Slot(ctypes.Structure):
    """batch3d_kernel.c's `auv3d_slot`: what stays the same through an episode (pointers into kept arrays)."""

    _fields_ = [("model", ctypes.c_void_p), ("data", ctypes.c_void_p), ("hydro", ctypes.c_void_p),
                ("hydro_ix", ctypes.c_void_p), ("gains", ctypes.c_void_p), ("movers", ctypes.c_void_p),
                ("fan", ctypes.c_void_p), ("fins", ctypes.c_void_p), ("source", ctypes.c_void_p),
                ("nmover", ctypes.c_int), ("hull", ctypes.c_int), ("sonar_site", ctypes.c_int),
                ("sonar_body", ctypes.c_int), ("altimeter_site", ctypes.c_int), ("altimeter_body", ctypes.c_int),
                ("pressure_adr", ctypes.c_int), ("dvl_adr", ctypes.c_int), ("gyro_adr", ctypes.c_int),
                ("accelerometer_adr", ctypes.c_int), ("attitude_adr", ctypes.c_int)]


@cache
def kernel() -> ctypes.CDLL | None:
    """The compiled batch step, or None when it cannot be built or loaded (see `unavailable`)."""
    return _load()[0]


def unavailable() -> str:
    """Why `kernel()` is None ("" when it is not)."""
    return _load()[1]


@cache
def _load() -> tuple[ctypes.CDLL | None, str]:
    if not native.enabled():
        return None, "AUV_MJ_NATIVE=0 switches the C kernels off"
    try:
        include = batch.mujoco_include()
        if not (include / "mujoco" / "mujoco.h").exists():
            raise OSError(f"no MuJoCo headers in {include}")
        library = native.mujoco_library_path()
        flags = (*FLAGS, "-pthread", f"-I{include}", f"-I{SOURCE.parent}")
        path = native.compiled(SOURCE, flags, INCLUDED, (str(library), f"-Wl,-rpath,{library.parent}"))
        lib = ctypes.CDLL(str(path))
    except (OSError, subprocess.SubprocessError) as e:
        return None, str(e)
    sizes = tuple(lib.auv3d_batch_sizes(k) for k in range(8))
    expected = (len(STATE), len(PARAMETERS), len(OUTPUTS), ctypes.sizeof(Slot), len(GAINS), len(CONSTANTS),
                MOVER_SIZE, MAX_READS)
    if sizes != expected:
        raise RuntimeError(f"batch3d_kernel.c has sizes {sizes}, auv_mj.sim.batch3d {expected}: the two are out of "
                           "step")
    lib.auv3d_batch_step.restype = ctypes.c_int
    lib.auv3d_batch_step.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p,
                                     ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p,
                                     ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                     ctypes.c_int, ctypes.c_int]
    return lib, ""


def constants() -> np.ndarray:
    """The CONSTANTS row, each computed as `auv_mj.sim.sensors3d` and `ocean3d` compute it."""
    return np.array([RHO_WATER * GRAVITY, SURFACE_Z, SONAR_RANGE, ALTIMETER_RANGE, SENSOR_NOISE["altimeter"],
                     SENSOR_NOISE["depth"], SENSOR_NOISE["dvl"], SENSOR_NOISE["gyro"], SENSOR_NOISE["accelerometer"]])


def mover_record(slot: int, start, end, speed: float) -> np.ndarray:
    """A moving sphere (`auv_mj.arenas.tubes.TubeMover`) as batch3d_kernel.c reads it; its span is computed here by
    `TubeMover.position`'s own NumPy call, so the C code repeats only the per-tick arithmetic."""
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    return np.array([slot, speed, float(np.linalg.norm(b - a)), *a, *b], dtype=float)


class BatchStepper3D:
    """N vehicle slots and their state, parameter, output, normal-draw, mask and noise rows; `step` advances a set.

    A slot is (re)bound with `bind` whenever its episode starts (its model may be new); the owner fills the rows of
    `state`, `parameters`, `masks` and `noise` (names: STATE, PARAMETERS) and tops up `normals`
    (`auv_mj.sim.batch.BatchStepper.top_up`'s rule)."""

    def __init__(self, num: int):
        lib = kernel()
        if lib is None:
            raise RuntimeError(f"the batched 6-DOF step needs its C kernel, which is unavailable: {unavailable()}")
        self._lib = lib
        self.num = num
        self.slots = (Slot * num)()
        self.state = np.zeros((num, len(STATE)))
        self.parameters = np.zeros((num, len(PARAMETERS)))
        self.out = np.zeros((num, len(OUTPUTS)))
        self.normals = np.zeros((num, batch.NORMALS_CAPACITY))
        self.normals_end = np.zeros(num, dtype=int)
        self.masks = np.zeros((num, MAX_READS), dtype=np.intc)
        self.noise = np.zeros((num, NOISE_CAPACITY))
        self.constants = constants()
        self.threads_used = 0
        self._keep: list = [None] * num

    def bind(self, i: int, physics, gains: np.ndarray, movers: np.ndarray, fan: np.ndarray) -> None:
        """Points slot `i` at `physics` (a `Physics3D` after its episode's reset), its executor's `gains` (GAINS), its
        packed `movers` (concatenated `mover_record`s) and the fan's body-frame beam directions (FAN_BEAMS, 3)."""
        model, data = physics.model.ptr, physics.data.ptr
        hydro = physics.hydrodynamics
        lagged = physics.fin_lagged
        source = data.act if lagged else data.ctrl
        first = int(model.actuator_actadr[1]) if lagged else 1
        parameters, indices = hydro.kernel_arguments(first, physics.fin_limits, physics.fin_rate)
        gains = np.ascontiguousarray(gains, dtype=float)
        if gains.shape != (len(GAINS),):
            raise ValueError(f"gains must be the {len(GAINS)} numbers {GAINS}, got shape {gains.shape}")
        movers = np.ascontiguousarray(movers, dtype=float)
        fan = np.ascontiguousarray(fan, dtype=float)
        if fan.shape != (FAN_BEAMS, 3):
            raise ValueError(f"fan must be ({FAN_BEAMS}, 3) beam directions, got shape {fan.shape}")
        if len(movers) % MOVER_SIZE:
            raise ValueError(f"movers must be records of {MOVER_SIZE} numbers, got {len(movers)}")
        fins = physics.fins
        slot = self.slots[i]
        slot.model, slot.data = model._address, data._address
        slot.hydro, slot.hydro_ix = parameters.ctypes.data, indices.ctypes.data
        slot.gains, slot.movers, slot.fan = gains.ctypes.data, movers.ctypes.data, fan.ctypes.data
        slot.fins, slot.source = fins.ctypes.data, source.ctypes.data
        slot.nmover = len(movers) // MOVER_SIZE
        slot.hull = int(model.geom("hull").id)
        for name in ("sonar", "altimeter"):
            site = model.site(name).id
            setattr(slot, f"{name}_site", int(site))
            setattr(slot, f"{name}_body", int(model.site_bodyid[site]))
        for name, field in (("pressure_port", "pressure_adr"), ("dvl", "dvl_adr"), ("gyro", "gyro_adr"),
                            ("accelerometer", "accelerometer_adr"), ("attitude", "attitude_adr")):
            setattr(slot, field, int(model.sensor_adr[model.sensor(name).id]))
        self._keep[i] = (model, data, parameters, indices, gains, movers, fan, fins, source)

    def top_up(self, i: int, rng: np.random.Generator, needed: int) -> None:
        """Makes at least `needed` normal draws of vehicle `i` ready (`auv_mj.sim.batch.top_up_normals`)."""
        at = STATE_INDEX["normal_position"]
        position, self.normals_end[i] = batch.top_up_normals(self.normals[i], int(self.state[i, at]),
                                                             int(self.normals_end[i]), rng, needed)
        self.state[i, at] = position

    def step(self, index: np.ndarray, ticks: int, substeps: int, threads: int) -> None:
        """Advances the vehicles `index` by `ticks` executor periods of `substeps` physics steps each, then the
        after-step read, on `threads` threads; fills their rows of `out`."""
        index = np.ascontiguousarray(index, dtype=np.intc)
        if len(index) == 0:
            return
        if not 0 < ticks < MAX_READS:
            raise ValueError(f"ticks must be in [1, {MAX_READS - 1}], got {ticks}")
        used = self._lib.auv3d_batch_step(index.ctypes.data, len(index), ctypes.addressof(self.slots),
                                          self.state.ctypes.data, self.parameters.ctypes.data,
                                          self.normals.ctypes.data, batch.NORMALS_CAPACITY, self.masks.ctypes.data,
                                          self.noise.ctypes.data, NOISE_CAPACITY, self.constants.ctypes.data,
                                          self.out.ctypes.data, int(ticks), int(substeps), int(threads))
        if used < 1:
            raise RuntimeError("batch3d_kernel.c refused the step")
        self.threads_used = used
        """The threads the last step ran on (the caller's among them)."""


SAMPLE_ORDER = tuple(SAMPLE_RATES_HZ)
"""The sensors in the order `Sensors3D.read` samples them."""
