"""The batched planar step (`batch_kernel.c`): N vehicles, each in its own MuJoCo model, advanced in one C call.

Why: a planning environment's step is 50 physics steps and five ticks of the 10 Hz executor. Stepped one
environment at a time from Python, the calls around the physics cost twice the physics itself; here one ctypes
call (which releases the GIL) advances a whole batch, shared out to POSIX threads, and returns what the tasks
read after a step (pose, body velocity, contacts, the nine sonar ranges, the hull's clearance) as one array.

The C tick is the planning tasks' own (`auv_mj.tasks.planning.PlanningTask._tick`): the ocean current's Gauss-Markov
step, the S-plane executor of Eq. (32), the movers and the contact check, written again in the same order of
floating-point operations and built like `hydro_kernel.c` (whose step it includes), so that a vehicle follows
the single environment's trajectory to the bit. What the tick needs that is not MuJoCo's comes as numbers: the
executor's gains, read from the array its controller gives (`SPlaneController.parameters`, in the order GAINS),
the current's parameters (`PARAMETERS`), the mutable state (`STATE`: command, integrators, current), the current's
normal draws (`normals`, filled by the caller from the episode's own generator, since NumPy's stream cannot be
drawn in C) and the movers' paths (`mover_record`).

The library is compiled against the MuJoCo headers and shared library of the `mujoco` package (the same
library the bindings loaded), into the cache of `auv_mj.sim.native`. `kernel()` is None where it cannot be
built (no compiler, no headers, AUV_MJ_NATIVE=0): the batch then cannot run and says why.
"""

from __future__ import annotations

import ctypes
import math
import subprocess
from functools import cache
from pathlib import Path

import mujoco
import numpy as np

from auv_mj.sim import native
from auv_mj.sim.sonar import SONAR_NAMES

SOURCE = Path(__file__).with_name("batch_kernel.c")
INCLUDED = (Path(__file__).with_name("hydro_kernel.c"), Path(__file__).with_name("tick_kernel.c"))
"""Files `batch_kernel.c` includes (they key the compiled library too)."""
STATE = ("speed_command", "heading_command", "int_speed", "int_heading", "last_u", "has_last_u", "collided",
         "ready", "ocean_time", "current_on", "current_speed", "current_speed_dt", "current_speed_a",
         "current_speed_b", "current_direction", "current_direction_dt", "current_direction_a",
         "current_direction_b", "normal_position")
"""A vehicle's mutable row, in batch_kernel.c's order."""
GAINS = ("k1_speed", "k2_speed", "ki_speed", "k1_heading", "k2_heading", "ki_heading", "band_speed", "band_heading",
         "integral_limit", "surge_drag", "surge_limit", "yaw_limit", "dt")
"""The S-plane gains as batch_kernel.c reads them from a vehicle's controller (`bind`'s `gains`): the fields of
`auv_mj.control.splane.SPlaneGains`, in their order (the batched env checks that they are)."""
PARAMETERS = ("speed_mean", "speed_sigma", "speed_time_constant", "speed_low", "speed_high",
              "direction_mean", "direction_sigma", "direction_time_constant", "direction_low", "direction_high")
"""A vehicle's constant row: the current's Gauss-Markov parameters (`auv_mj.sim.ocean.GaussMarkov`: mean, sigma,
time constant, low, high)."""
OUTPUTS = ("x", "y", "psi", "cos_psi", "sin_psi", "u", "v", "r", "time", "collided", "invalid", "clearance",
           *SONAR_NAMES)
"""What a step reports per vehicle: pose, cos and sin of the heading (libm's, as `math`), body velocity
(u, v, r), time, whether the vehicle touched anything since the episode began, whether MuJoCo warned or reset
the state, the hull's clearance (capped) and the raw rangefinder readings S1..S9."""
STATE_INDEX = {name: i for i, name in enumerate(STATE)}
PARAMETER_INDEX = {name: i for i, name in enumerate(PARAMETERS)}
OUTPUT_INDEX = {name: i for i, name in enumerate(OUTPUTS)}
NORMALS_BLOCK = 256
"""Normal draws per refill of a vehicle's buffer: `auv_mj.sim.ocean.Normals`'s block."""
NORMALS_CAPACITY = 2 * NORMALS_BLOCK
"""Size of a vehicle's buffer of normal draws."""
MOVER_STRAIGHT, MOVER_POLYLINE = 1.0, 2.0
"""Kinds of mover record (`mover_record`; a straight one of zero length or speed stands still)."""


class Slot(ctypes.Structure):
    """batch_kernel.c's `auv_slot`: what stays the same through an episode (pointers into kept arrays)."""

    _fields_ = [("model", ctypes.c_void_p), ("data", ctypes.c_void_p), ("hydro", ctypes.c_void_p),
                ("gains", ctypes.c_void_p), ("hydro_ix", ctypes.c_void_p), ("movers", ctypes.c_void_p),
                ("others", ctypes.c_void_p),
                ("nmover", ctypes.c_int), ("nothers", ctypes.c_int), ("hull", ctypes.c_int),
                ("vehicle_body", ctypes.c_int), ("qpos_x", ctypes.c_int), ("qpos_y", ctypes.c_int),
                ("qpos_psi", ctypes.c_int), ("dof_x", ctypes.c_int), ("dof_y", ctypes.c_int),
                ("dof_r", ctypes.c_int), ("sonar_adr", ctypes.c_int * len(SONAR_NAMES))]


def mujoco_include() -> Path:
    """The C headers shipped in the `mujoco` package."""
    return Path(mujoco.__file__).parent / "include"


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
        if not (mujoco_include() / "mujoco" / "mujoco.h").exists():
            raise OSError(f"no MuJoCo headers in {mujoco_include()}")
        library = native.mujoco_library_path()
        flags = (*native.FLAGS, "-pthread", f"-I{mujoco_include()}", f"-I{SOURCE.parent}")
        path = native.compiled(SOURCE, flags, INCLUDED, (str(library), f"-Wl,-rpath,{library.parent}"))
        lib = ctypes.CDLL(str(path))
    except (OSError, subprocess.SubprocessError) as e:
        return None, str(e)
    sizes = tuple(lib.auv_batch_sizes(k) for k in range(6))
    expected = (len(STATE), len(PARAMETERS), len(OUTPUTS), ctypes.sizeof(Slot), len(SONAR_NAMES), len(GAINS))
    if sizes != expected:
        raise RuntimeError(f"batch_kernel.c has sizes {sizes}, auv_mj.sim.batch {expected}: the two are out of step")
    lib.auv_batch_step.restype = ctypes.c_int
    lib.auv_batch_step.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p,
                                   ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_int,
                                   ctypes.c_int, ctypes.c_double, ctypes.c_int]
    return lib, ""


def mover_record(slot: int, start, end, speed: float, waypoints=None) -> np.ndarray:
    """A mover (`auv_mj.arenas.arena.Mover`) as batch_kernel.c reads it: its mocap `slot`, then its path.

    The path's lengths are computed here by the same NumPy calls as `Mover.position`, so the C code repeats
    only the per-tick arithmetic. `waypoints` is the whole polyline (`Mover.waypoints`) of a mover with `via`
    points, None for a straight one.
    """
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    if waypoints is not None:
        points = np.asarray(waypoints, dtype=float)
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        head = [slot, MOVER_POLYLINE, speed, float(arc[-1]), *start, 0.0, 0.0, len(points)]
        return np.concatenate([head, points.ravel(), arc])
    delta = end - start
    head = [slot, MOVER_STRAIGHT, speed, float(np.hypot(*delta)), *start, *delta, 0.0]
    return np.array(head, dtype=float)


def top_up_normals(normals: np.ndarray, position: int, end: int, rng: np.random.Generator,
                   needed: int) -> tuple[int, int]:
    """Makes at least `needed` draws of a vehicle's buffer `normals` (NORMALS_CAPACITY) ready after `position`
    (its next draw; `end` is past its last), drawing blocks of NORMALS_BLOCK from `rng` (the current's generator)
    as `auv_mj.sim.ocean.Normals` does, so that the stream is the same; returns the new (position, end)."""
    while end - position < needed:
        if end + NORMALS_BLOCK > NORMALS_CAPACITY:
            left = end - position
            normals[:left] = normals[position:end]
            position, end = 0, left
        normals[end:end + NORMALS_BLOCK] = rng.standard_normal(NORMALS_BLOCK)
        end += NORMALS_BLOCK
    return position, end


class BatchStepper:
    """N vehicle slots and their state, parameter, output and normal-draw rows; `step` advances a set of them.

    A slot is (re)bound to a physics with `bind` whenever its episode starts (its model may be new); the owner
    fills the rows of `state` and `parameters` (names: STATE, PARAMETERS) and tops up `normals`.
    """

    def __init__(self, num: int):
        lib = kernel()
        if lib is None:
            raise RuntimeError(f"the batched step needs its C kernel, which is unavailable: {unavailable()}")
        self._lib = lib
        self.num = num
        self.slots = (Slot * num)()
        self.state = np.zeros((num, len(STATE)))
        self.parameters = np.zeros((num, len(PARAMETERS)))
        self.out = np.zeros((num, len(OUTPUTS)))
        self.normals = np.zeros((num, NORMALS_CAPACITY))
        self.normals_end = np.zeros(num, dtype=int)
        """Index past the last valid draw of each vehicle's buffer (its next draw is `state[:, normal_position]`)."""
        self._keep: list = [None] * num

    def bind(self, i: int, physics, gains: np.ndarray, movers: np.ndarray, others: np.ndarray, hull: int,
             vehicle_body: int) -> None:
        """Points slot `i` at `physics` (an `AUVPhysics` after its episode's reset), its executor's `gains` (GAINS,
        the controller's own array, read in place), its packed `movers` (concatenated `mover_record`s), the geoms
        whose clearance counts and the hull geom."""
        model, data = physics.model.ptr, physics.data.ptr
        hydro = physics.hydrodynamics
        coefficients, addresses = hydro.kernel_arguments()
        if np.shape(gains) != (len(GAINS),):
            raise ValueError(f"gains must be the {len(GAINS)} numbers {GAINS}, got shape {np.shape(gains)}")
        gains = np.ascontiguousarray(gains, dtype=float)
        others = np.ascontiguousarray(others, dtype=np.intc)
        movers = np.ascontiguousarray(movers, dtype=float)
        count = 0
        at = 0
        while at < len(movers):
            count += 1
            at += 9 + 3 * int(movers[at + 8])
        slot = self.slots[i]
        slot.model, slot.data = model._address, data._address
        slot.hydro, slot.hydro_ix = coefficients.ctypes.data, addresses.ctypes.data
        slot.gains = gains.ctypes.data
        slot.movers, slot.nmover = movers.ctypes.data, count
        slot.others, slot.nothers = others.ctypes.data, len(others)
        slot.hull, slot.vehicle_body = int(hull), int(vehicle_body)
        qpos = [int(model.jnt_qposadr[model.joint(n).id]) for n in ("x", "y", "yaw")]
        dofs = [int(a) for a in hydro.dofs]
        slot.qpos_x, slot.qpos_y, slot.qpos_psi = qpos
        slot.dof_x, slot.dof_y, slot.dof_r = dofs
        for k, name in enumerate(SONAR_NAMES):
            slot.sonar_adr[k] = int(model.sensor_adr[model.sensor(name).id])
        self._keep[i] = (model, data, coefficients, addresses, gains, movers, others)

    def top_up(self, i: int, rng: np.random.Generator, needed: int) -> None:
        """Makes at least `needed` normal draws of vehicle `i` ready (`top_up_normals`)."""
        at = STATE_INDEX["normal_position"]
        position, self.normals_end[i] = top_up_normals(self.normals[i], int(self.state[i, at]),
                                                       int(self.normals_end[i]), rng, needed)
        self.state[i, at] = position

    def step(self, index: np.ndarray, ticks: int, substeps: int, cap: float, threads: int) -> None:
        """Advances the vehicles `index` by `ticks` executor periods of `substeps` physics steps each, on
        `threads` threads; fills their rows of `out`. `cap` caps the clearance [m]."""
        index = np.ascontiguousarray(index, dtype=np.intc)
        if len(index) == 0:
            return
        if not (math.isfinite(cap) and cap > 0):
            raise ValueError(f"cap must be a positive distance [m], got {cap}")
        self._lib.auv_batch_step(index.ctypes.data, len(index), ctypes.addressof(self.slots),
                                 self.state.ctypes.data, self.parameters.ctypes.data, self.normals.ctypes.data,
                                 NORMALS_CAPACITY, self.out.ctypes.data, int(ticks), int(substeps), float(cap),
                                 int(threads))
