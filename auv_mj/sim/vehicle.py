"""Vehicle facts read from the compiled vehicle MJCF (`models/auv.xml`), never copied into code, and the
contract every vehicle MJCF must keep (`check_vehicle`, run at load by `AUVPhysics`).

Controllers need the actuator limits (K_V, K_psi of Eq. 32) and the surge drag X_uu; tunnel authoring
needs the hull's size. Editing the vehicle's XML changes all of them at once.

The contract (Eq. 1-2, 12 and Sec. 2.2): slide joints `x`, `y` along the world x and y axes and a hinge
`yaw` about z, in that order on one body, and no other joint in the model; actuators `tau_u` (a body-frame
surge force) and `tau_r` (a yaw moment), in that order, instantaneous or behind a first-order lag, with finite
control ranges around 0; rangefinders
`sonar_1`..`sonar_9` on sites of the vehicle; a capsule `hull` on the vehicle; a positive timestep within
TIMESTEP_RANGE and a mass and inertia an AUV can have (MASS_RANGE, GYRATION_RANGE). A model that breaks it is
refused with a ValueError naming the file and the element.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from auv_mj.assets import model_path

HULL_GEOM = "hull"
"""Name of the vehicle's hull geom (a capsule along the body x axis)."""
ACTUATORS = ("tau_u", "tau_r")
"""Names of the surge force and yaw moment actuators."""
JOINTS = (("x", "slide", (1.0, 0.0, 0.0)), ("y", "slide", (0.0, 1.0, 0.0)), ("yaw", "hinge", (0.0, 0.0, 1.0)))
"""The vehicle's joints: name, type and world axis (Eq. 1: eta = (x, y, psi))."""
ACTUATOR_AXES = {"tau_u": (1.0, 0.0, 0.0), "tau_r": (0.0, 0.0, 1.0)}
"""Generalised force per unit control of each actuator in the body frame (surge, sway, yaw) (Eq. 12)."""
SONARS = tuple(f"sonar_{i}" for i in range(1, 10))
"""The nine rangefinders S1..S9 (Sec. 2.2)."""
TIMESTEP_RANGE = (1e-4, 0.1)
"""Physics timesteps a vehicle may use [s]: above 0.1 s a control step holds no whole step; below 1e-4 s
one second of simulation takes minutes."""
MAX_CONTROL = 1e6
"""Largest |ctrlrange| bound [N or N m]."""
MAX_HULL_SIZE = 100.0
"""Largest hull radius or half length [m]."""
AXIS_TOLERANCE = 1e-6
LAG_DYNAMICS = (int(mujoco.mjtDyn.mjDYN_FILTER), int(mujoco.mjtDyn.mjDYN_FILTEREXACT))
"""Actuator dynamics a vehicle may have: a first-order lag (thruster lag, `auv_mj.sim.ocean`), whose force
settles to the control."""
MAX_LAG = 60.0
"""Longest actuator time constant (dynprm) [s]."""
MASS_RANGE = (1.0, 1e5)
"""Vehicle masses [kg] a vehicle MJCF may give: from a 1 kg model-scale vehicle to a 100 t large-displacement
UUV (the REMUS-100 is 30.48 kg). Beyond them lies a typo or a unit slip (grams, tonnes), not an AUV, and the
added-mass and drag coefficients, sized for a vehicle, would swamp or vanish beside it."""
GYRATION_RANGE = (0.01, 100.0)
"""Radii of gyration sqrt(I / m) [m] each principal moment of inertia may have: the REMUS-100's are 0.08 m (roll)
and 0.34 m (pitch, yaw), a 30 m, 100 t vehicle's about 9 m. Outside them the inertia does not belong to the mass
(a moment in g cm^2, or one left at MuJoCo's tiny default)."""


@dataclass(frozen=True)
class VehicleFacts:
    """What code needs to know of the vehicle, as compiled."""

    surge_limit: float
    """|tau_u| limit [N]: the tau_u actuator's ctrlrange."""
    yaw_limit: float
    """|tau_r| limit [N m]: the tau_r actuator's ctrlrange."""
    surge_drag: float
    """-X_uu [N s^2/m^2] (`hydro_X_uu`): steady thrust surge_drag u |u| holds surge speed u."""
    hull_radius: float
    """Radius of the hull capsule [m]."""
    hull_half_length: float
    """Farthest point of the hull from the vehicle's centre [m], whatever its yaw."""


def facts_of(model: mujoco.MjModel) -> VehicleFacts:
    """The facts of a compiled vehicle (or vehicle + arena) model."""
    limits = []
    for name in ACTUATORS:
        low, high = model.actuator_ctrlrange[model.actuator(name).id]
        limits.append(float(min(-low, high)))
    hull = model.geom(HULL_GEOM)
    radius, half = float(hull.size[0]), float(hull.size[1])
    offset = float(np.hypot(*model.geom_pos[hull.id][:2]))
    x_uu = float(model.numeric("hydro_X_uu").data[0])
    return VehicleFacts(surge_limit=limits[0], yaw_limit=limits[1], surge_drag=-x_uu, hull_radius=radius,
                        hull_half_length=offset + half + radius)


@functools.lru_cache(maxsize=8)
def vehicle_facts(path: str | Path | None = None) -> VehicleFacts:
    """The facts of the vehicle MJCF at `path` (default: the shipped `models/auv.xml`), compiled once."""
    return facts_of(mujoco.MjModel.from_xml_path(str(path or model_path("auv.xml"))))


def _fail(source: str, message: str) -> ValueError:
    return ValueError(f"{source}: the vehicle model breaks its contract: {message}")


def check_vehicle(model: mujoco.MjModel, source: str) -> None:
    """Refuses a compiled model that breaks the vehicle contract (module docstring), naming `source`."""
    data = mujoco.MjData(model)
    _check_joints(model, data, source)
    body = int(model.jnt_bodyid[model.joint("x").id])
    timestep = float(model.opt.timestep)
    if not TIMESTEP_RANGE[0] <= timestep <= TIMESTEP_RANGE[1]:
        raise _fail(source, f'<option timestep="{timestep:g}"> must be in [{TIMESTEP_RANGE[0]:g}, '
                            f"{TIMESTEP_RANGE[1]:g}] s")
    check_inertia(float(model.body_subtreemass[body]), model.body_inertia[body], source, model.body(body).name)
    _check_actuators(model, data, source)
    for name in SONARS:
        try:
            sensor = model.sensor(name)
        except KeyError:
            raise _fail(source, f"no rangefinder <rangefinder name=\"{name}\">: the vehicle needs "
                                f"{SONARS[0]}..{SONARS[-1]}") from None
        if (sensor.type[0] != mujoco.mjtSensor.mjSENS_RANGEFINDER or sensor.objtype[0] != mujoco.mjtObj.mjOBJ_SITE
                or model.site_bodyid[sensor.objid[0]] != body):
            raise _fail(source, f"sensor {name} must be a rangefinder on a site of the vehicle body")
    try:
        hull = model.geom(HULL_GEOM)
    except KeyError:
        raise _fail(source, f'no hull geom <geom name="{HULL_GEOM}">') from None
    if hull.type[0] != mujoco.mjtGeom.mjGEOM_CAPSULE or model.geom_bodyid[hull.id] != body:
        raise _fail(source, f"geom {HULL_GEOM} must be a capsule of the vehicle body")
    if not (model.geom_contype[hull.id] or model.geom_conaffinity[hull.id]):
        raise _fail(source, f"geom {HULL_GEOM} must collide (contype or conaffinity non-zero): collisions are "
                            "detected by its contacts")
    if not np.all((hull.size[:2] > 0) & (hull.size[:2] <= MAX_HULL_SIZE)):
        raise _fail(source, f"hull radius and half length {hull.size[:2].tolist()} must be in (0, "
                            f"{MAX_HULL_SIZE:g}] m")


def check_inertia(mass: float, inertia: np.ndarray, source: str, body: str) -> None:
    """Refuses a vehicle mass [kg] outside MASS_RANGE, and principal moments of inertia [kg m^2] that are not
    positive, break the triangle inequality (no rigid body has one moment above the sum of the other two) or give a
    radius of gyration outside GYRATION_RANGE; the error names `source`, the body and the field."""
    where = f"body '{body}' (<inertial>, or its geoms' mass)"
    if not MASS_RANGE[0] <= mass <= MASS_RANGE[1]:
        raise _fail(source, f"{where}: mass = {mass:g} kg must be in [{MASS_RANGE[0]:g}, {MASS_RANGE[1]:g}] kg, "
                            "the masses of AUVs")
    moments = np.asarray(inertia, dtype=float)
    if not np.all(np.isfinite(moments) & (moments > 0)):
        raise _fail(source, f"{where}: principal moments of inertia {_moments(moments)} kg m^2 must be positive")
    if np.any(moments > (moments.sum() - moments) * (1 + 1e-9)):
        raise _fail(source, f"{where}: principal moments of inertia {_moments(moments)} kg m^2 break the triangle "
                            "inequality (each at most the sum of the other two)")
    gyration = np.sqrt(moments / mass)
    if np.any((gyration < GYRATION_RANGE[0]) | (gyration > GYRATION_RANGE[1])):
        raise _fail(source, f"{where}: principal moments of inertia {_moments(moments)} kg m^2 on {mass:g} kg give "
                            f"radii of gyration {_moments(gyration)} m, outside [{GYRATION_RANGE[0]:g}, "
                            f"{GYRATION_RANGE[1]:g}] m")


def _moments(values: np.ndarray) -> str:
    return " ".join(f"{v:.4g}" for v in values)


def _check_joints(model: mujoco.MjModel, data: mujoco.MjData, source: str) -> None:
    """x, y, yaw of the right types and world axes, in that order on one body, and no other joint."""
    ids = []
    for name, kind, _ in JOINTS:
        try:
            joint = model.joint(name)
        except KeyError:
            raise _fail(source, f'no joint "{name}": the vehicle needs joints x, y (slide) and yaw (hinge)') from None
        actual = mujoco.mjtJoint(int(joint.type[0])).name.removeprefix("mjJNT_").lower()
        if actual != kind:
            raise _fail(source, f'joint "{name}" must be a {kind} joint, got {actual}')
        ids.append(joint.id)
    others = [model.joint(j).name or f"#{j}" for j in range(model.njnt) if j not in ids]
    if others:
        raise _fail(source, f"joints {others} beyond x, y, yaw: the vehicle moves in the plane only and "
                            "arenas hold no joints")
    bodies = {int(model.jnt_bodyid[j]) for j in ids}
    if len(bodies) != 1 or ids != sorted(ids):
        raise _fail(source, "joints x, y, yaw must belong to one body, in that order")
    mujoco.mj_kinematics(model, data)
    for (name, _, axis), j in zip(JOINTS, ids, strict=True):
        if not np.allclose(data.xaxis[j], axis, atol=AXIS_TOLERANCE):
            raise _fail(source, f'joint "{name}" must turn or slide about the world axis {list(axis)}, got '
                                f"{np.round(data.xaxis[j], 6).tolist()}")


def _check_actuators(model: mujoco.MjModel, data: mujoco.MjData, source: str) -> None:
    """tau_u and tau_r, in that order, a body-frame surge force and a yaw moment of one unit per unit control."""
    names = [model.actuator(i).name for i in range(model.nu)]
    if names != list(ACTUATORS):
        raise _fail(source, f"the actuators must be {list(ACTUATORS)} in that order, got {names}")
    for i, name in enumerate(ACTUATORS):
        low, high = (float(v) for v in model.actuator_ctrlrange[i])
        if not (model.actuator_ctrllimited[i] and -MAX_CONTROL <= low < 0 < high <= MAX_CONTROL):
            raise _fail(source, f'actuator {name} needs ctrllimited="true" and a finite ctrlrange low < 0 < high '
                                f"within +-{MAX_CONTROL:g}, got ctrlrange=\"{low:g} {high:g}\"")
    yaw = 0.5  # a turned vehicle tells a body-frame force from a world-frame one
    data.qpos[model.jnt_qposadr[model.joint("yaw").id]] = yaw
    mujoco.mj_forward(model, data)
    dofs = [int(model.jnt_dofadr[model.joint(n).id]) for n, _, _ in JOINTS]
    c, s = math.cos(yaw), math.sin(yaw)
    for i, name in enumerate(ACTUATORS):
        moment = np.zeros(model.nv)
        start, count = data.moment_rowadr[i], data.moment_rownnz[i]
        moment[data.moment_colind[start:start + count]] = data.actuator_moment[start:start + count]
        gain = model.actuator_gainprm[i, 0] if model.actuator_gaintype[i] == mujoco.mjtGain.mjGAIN_FIXED else math.nan
        surge, sway, turn = ACTUATOR_AXES[name]
        expected = np.array([c * surge - s * sway, s * surge + c * sway, turn])
        dyntype = int(model.actuator_dyntype[i])
        lag = float(model.actuator_dynprm[i, 0])
        settles = dyntype == mujoco.mjtDyn.mjDYN_NONE or (dyntype in LAG_DYNAMICS and 0 < lag <= MAX_LAG)
        plain = settles and model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_NONE
        if not (plain and np.allclose(gain * moment[dofs], expected, atol=AXIS_TOLERANCE)):
            what = "a body-frame surge force" if name == "tau_u" else "a yaw moment"
            raise _fail(source, f"actuator {name} must apply {what} equal to its control (Eq. 12: gear, gain 1, "
                                f"no bias; dynamics none, or a first-order lag with a time constant in (0, "
                                f"{MAX_LAG:g}] s)")


@functools.lru_cache(maxsize=8)
def _ctrlranges(name: str) -> np.ndarray:
    return mujoco.MjModel.from_xml_path(str(model_path(name))).actuator_ctrlrange.copy()


def actuator_ranges(name: str = "auv.xml") -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the actuators' ctrlranges of the shipped vehicle `name` (`auv.xml`, or `auv6.xml` for the
    6-DOF vehicle), read from the compiled vehicle alone: what an executor built outside a task scales its output by."""
    low, high = _ctrlranges(name).T.copy()
    return low, high
