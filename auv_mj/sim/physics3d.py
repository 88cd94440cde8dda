"""`AUV3DPhysics`: a dm_control Physics for the 6-DOF REMUS-100 (`models/auv6.xml`) with `auv_mj.sim.hydro3d` on.

The contract of a 6-DOF vehicle MJCF (checked at load, a ValueError names the file and the element): one free
joint `root` on the vehicle body and no other joint; actuators `thrust` [N], `rudder` [rad] and `stern` [rad] in
that order, with finite control ranges around 0; a colliding capsule `hull` on the vehicle; the `hydro_*`
coefficients and `fin_rate` of `auv_mj.sim.hydro3d`; sites `sonar`, `altimeter`, `pressure`, `dvl`, `imu` and the
sensors of `auv_mj.sim.sensors3d`; a timestep within TIMESTEP_RANGE and the Euler or implicitfast integrator.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping
from pathlib import Path

import mujoco
import numpy as np
from dm_control.mujoco import engine, index, wrapper
from dm_control.rl.control import PhysicsError

from auv_mj.inputs import MAX_XML_BYTES, read_text, source_name
from auv_mj.sim.hydro3d import ACTUATORS, Hydro3D, slew, spec_from_model
from auv_mj.sim.sensors3d import sonar_fan

SUPPORTED_INTEGRATORS = (mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
SENSOR_DISABLE_BIT = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
TIMESTEP_RANGE = (1e-4, 0.1)
"""Physics timesteps a vehicle may use [s], as for the planar vehicle."""
HULL_GEOM = "hull"
SITES = ("sonar", "altimeter", "pressure", "dvl", "imu")
"""Sites of the vehicle the 3-D sensors read."""
FIN_LAG = int(mujoco.mjtDyn.mjDYN_FILTEREXACT)


def _fail(source: str, message: str) -> ValueError:
    return ValueError(f"{source}: the 6-DOF vehicle model breaks its contract: {message}")


class AUV3DPhysics(engine.Physics):
    """Physics of one 6-DOF AUV: free joint `root`, actuators thrust, rudder, stern (module docstring).

    The water's forces go in between `mj_step1` and `mj_step2`, as for the planar vehicle, with no global
    callback. The fins are servo states: each physics step slews the fin angles towards their commands
    (`data.ctrl`, or the lagged command `data.act` under ocean conditions) at the MJCF's `fin_rate`, within
    the actuators' ctrlrange (the fin angle limit). The current is `model.opt.wind` (world frame, m/s).
    """

    _hydro: Hydro3D | None = None
    _bound: tuple | None = None
    _step_ready = False

    @classmethod
    def from_xml_string(cls, xml_string: str, assets: dict | None = None, source: str = "<string>"):
        """Physics from MJCF text; `source` names it in error messages."""
        try:
            physics = super().from_xml_string(xml_string, assets=assets)
        except Exception as e:  # dm_control wraps compile errors in its own Error
            raise ValueError(f"{source}: MuJoCo cannot compile this model: {' '.join(str(e).split())}") from None
        physics._setup(source)
        return physics

    @classmethod
    def from_xml_path(cls, file_path: str | Path):
        """Physics from an MJCF file."""
        path = Path(file_path)
        name = source_name(path)
        read_text(path, "6-DOF vehicle MJCF", MAX_XML_BYTES)  # a missing or oversized file named as such
        try:
            physics = super().from_xml_path(str(path))
        except Exception as e:
            raise ValueError(f"{name}: MuJoCo cannot compile this model: {' '.join(str(e).split())}") from None
        physics._setup(name)
        return physics

    def reload_from_xml_string(self, xml_string: str, assets: dict | None = None, source: str = "<string>") -> None:
        """Recompiles in place (a new arena around the vehicle); the disturbance is kept."""
        disturbance = self.disturbance
        self._hydro = None
        try:
            super().reload_from_xml_string(xml_string, assets=assets)
        except Exception as e:
            raise ValueError(f"{source}: MuJoCo cannot compile this model: {' '.join(str(e).split())}") from None
        self._setup(source)
        self.disturbance = disturbance

    def _setup(self, source: str) -> None:
        model = self.model.ptr
        spec = spec_from_model(model, source)
        if spec is None:
            raise ValueError(f'{source}: no 6-DOF coefficients (<numeric name="hydro_*">): not an auv-mj vehicle')
        self.source = source
        _check_contract(model, source)
        self._hydro = Hydro3D(model, spec, source)
        body = self._hydro.body
        self._nominal = (spec, (float(model.body_mass[body]), model.body_inertia[body].copy()))
        self.fin_rate = spec.fin_rate
        self._fin_limits = model.actuator_ctrlrange[1:3].copy()
        self._fin_lagged = bool(all(int(model.actuator_dyntype[i]) == FIN_LAG for i in (1, 2)))
        self.fins = np.zeros(2)
        """The fin angles (rudder, stern) [rad] now: the servo states."""
        self.disturbance: Callable[[float], np.ndarray] | None = None
        """A callable(time) -> world (Fx, Fy, Fz, Mx, My, Mz) [N, N m] added at every step, or None."""
        self._qpos, self._dof = self._hydro.qpos_adr, self._hydro.dof_adr
        model.opt.disableflags |= SENSOR_DISABLE_BIT
        self._bound = None
        self._step_ready = False
        self.forward()

    @property
    def hydrodynamics(self) -> Hydro3D:
        """The 6-DOF water model of this physics."""
        return self._hydro

    # --- stepping -------------------------------------------------------------------------------------------

    def _reload_from_data(self, data) -> None:
        """dm_control's reload (the base class's steps: the data, the warning buffers, the render contexts freed,
        `after_reset`) less one: it builds the named indexers of every field of the model and the data, about 4 ms
        for a 6-DOF arena (more than MuJoCo's compile of it), at every episode's reset, which needs none of them (the
        sensors read MuJoCo's own named access). Here `named` builds them at its first use."""
        if not isinstance(data, wrapper.MjData):
            raise TypeError(f"Expected wrapper.MjData. Got: {type(data)}.")
        self._bound = None
        self._data = data
        self._warnings = data.warning.number
        self._warnings_before = np.empty_like(self._warnings)
        self._new_warnings = np.empty(len(self._warnings), dtype=bool)
        with self._contexts_lock:
            if self._contexts:
                self._free_rendering_contexts()
        self._named = None
        try:
            self.after_reset()
        except PhysicsError as e:
            logging.warning(e)
        self._bound = None

    @property
    def named(self) -> engine.NamedIndexStructs:
        """dm_control's named indexing (`physics.named.data.qpos["root"]`), built at first use after a reload."""
        if self._named is None:
            axes = index.make_axis_indexers(self.model)
            self._named = engine.NamedIndexStructs(model=index.struct_indexer(self.model, "mjmodel", axes),
                                                   data=index.struct_indexer(self.data, "mjdata", axes))
        return self._named

    def _bind(self) -> tuple:
        model, data = self.model.ptr, self.data.ptr
        source = data.act if self._fin_lagged else data.ctrl
        first = int(model.actuator_actadr[1]) if self._fin_lagged else 1
        advance = self._hydro.bind_native(model, data, self.fins, source, first, self._fin_limits, self.fin_rate)
        if advance is None:
            advance = self._hydro.bind(model, data)
        self._bound = (model, data, advance, self._fin_step(data), memoryview(data.ctrl), memoryview(data.qvel),
                       memoryview(data.warning.number))
        return self._bound

    def _fin_step(self, data: mujoco.MjData) -> Callable[[float], tuple[float, float]]:
        """fins(dt): slews the fin angles one step towards their (clipped) commands; returns them."""
        fins, limits, rate = self.fins, self._fin_limits, self.fin_rate
        source = data.act if self._fin_lagged else data.ctrl
        first = 1 if not self._fin_lagged else int(self.model.ptr.actuator_actadr[1])

        def step(dt: float) -> tuple[float, float]:
            if dt > 0:
                for k in range(2):
                    command = min(max(float(source[first + k]), limits[k, 0]), limits[k, 1])
                    fins[k] = slew(fins[k], command, rate, dt)
            return float(fins[0]), float(fins[1])

        return step

    def step(self, nstep: int = 1) -> None:
        """Advances `nstep` semi-implicit Euler steps with the water's forces; raises PhysicsError on a MuJoCo
        warning or a non-finite state. After a direct change of qpos or qvel, call `forward()` first."""
        model, data, advance, fins, ctrl, qvel, warnings = self._bound or self._bind()
        if not math.isfinite(sum(ctrl)):  # one sum per call: a NaN or inf anywhere makes it non-finite
            raise ValueError(f"control must be finite, got {data.ctrl.tolist()}; the physics state was not changed")
        warnings_before = warnings.tobytes()
        start = data.time
        timestep = model.opt.timestep
        if not self._step_ready:
            mujoco.mj_step1(model, data)
        wrench = None
        if self.disturbance is not None:
            disturbance = self.disturbance

            def wrench():
                return np.asarray(disturbance(data.time), dtype=float)
        advance(nstep, timestep, fins, wrench)
        self._step_ready = True
        rewound = data.time < start + (nstep - 0.5) * timestep  # MuJoCo reset an unstable state
        if rewound or not math.isfinite(sum(qvel)) or warnings.tobytes() != warnings_before:
            message = f"Physics state is invalid ({self.source}): the 6-DOF step diverged or MuJoCo reset it"
            if self._warnings_cause_exception:
                raise PhysicsError(message)
            logging.warning(message)

    def forward(self) -> None:
        """Recomputes the derived quantities of the state, accelerations with the water's forces included."""
        if self._hydro is None:
            super().forward()
            return
        model, data, advance, fins, *_ = self._bound or self._bind()
        with self.check_invalid_state():
            mujoco.mj_forward(model, data)
            advance(0, 0.0, fins)
            mujoco.mj_fwdAcceleration(model, data)
            mujoco.mj_fwdConstraint(model, data)
        self._step_ready = False

    def set_control(self, control) -> None:
        """Sets (thrust [N], rudder [rad], stern [rad]); a NaN or infinite value raises ValueError."""
        control = np.asarray(control, dtype=float)
        if not np.all(np.isfinite(control)):
            raise ValueError(f"control must be finite, got {dict(zip(ACTUATORS, control.tolist(), strict=False))}")
        super().set_control(control)

    def scale_vehicle(self, coefficients: Mapping[str, float] | None = None, mass: float = 1.0) -> None:
        """Scales the vehicle from its MJCF values (model uncertainty): each named `hydro_*` coefficient by its
        factor, the mass, inertia and buoyancy by `mass` (so that trim stays); `scale_vehicle()` restores it."""
        coefficients = dict(coefficients or {})
        nominal_spec, (body_mass, body_inertia) = self._nominal
        known = {f.name for f in dataclasses.fields(nominal_spec.coefficients)}
        unknown = sorted(set(coefficients) - known)
        if unknown:
            raise ValueError(f"scale_vehicle: unknown 6-DOF coefficient(s) {unknown}")
        if not (math.isfinite(mass) and mass > 0):
            raise ValueError(f"scale_vehicle: the mass factor must be positive, got {mass}")
        c = nominal_spec.coefficients
        values = {k: getattr(c, k) * float(coefficients.get(k, 1.0)) for k in known}
        values["B"] = c.B * mass * float(coefficients.get("B", 1.0))
        spec = dataclasses.replace(nominal_spec, coefficients=dataclasses.replace(c, **values))
        model = self.model.ptr
        body = self._hydro.body
        model.body_mass[body] = body_mass * mass
        model.body_inertia[body] = body_inertia * mass
        mujoco.mj_setConst(model, mujoco.MjData(model))
        self._hydro = Hydro3D(model, spec, self.source)
        self._bound, self._step_ready = None, False

    @property
    def fin_lagged(self) -> bool:
        """Whether the fins follow the lagged commands (data.act, ocean conditions' thruster lag) or data.ctrl."""
        return self._fin_lagged

    @property
    def fin_limits(self) -> np.ndarray:
        """The fins' angle limits (rudder, stern) x (low, high) [rad]: the actuators' ctrlrange."""
        return self._fin_limits

    @property
    def step_ready(self) -> bool:
        """Whether the next step may skip `mj_step1` (M and the passive forces are the current state's): a batched
        step that continues this physics starts the same way (`AUVPhysics.step_ready`)."""
        return self._step_ready

    def reset_fins(self, rudder: float = 0.0, stern: float = 0.0) -> None:
        """Puts the fins at these angles [rad] (an episode start)."""
        self.fins[:] = rudder, stern

    # --- read-outs --------------------------------------------------------------------------------------------

    def position(self) -> np.ndarray:
        """(x, y, z) of the body origin, the centre of buoyancy [m], world frame (z up)."""
        return self.data.qpos[self._qpos:self._qpos + 3].copy()

    def depth(self) -> float:
        """Depth of the centre of buoyancy below z = 0 [m] (the true value; sensors3d gives the measured one)."""
        return -float(self.data.qpos[self._qpos + 2])

    def rotation(self) -> np.ndarray:
        """R: body (x forward, y port, z up) to world."""
        return self._hydro.rotation(self.data.ptr)

    def attitude(self) -> np.ndarray:
        """(roll phi, pitch theta, yaw psi) [rad]: phi > 0 starboard down, theta > 0 nose up, psi as the planar
        heading (counter-clockwise from the world x axis seen from above)."""
        return euler_angles(self.rotation())

    def heading(self) -> float:
        """psi [rad], as the planar vehicle's."""
        return float(self.attitude()[2])

    def body_velocity(self) -> np.ndarray:
        """nu = (u, v, w, p, q, r) over ground in the body frame (x forward, y port, z up) [m/s, rad/s]."""
        return self._hydro.body_velocity(self.data.ptr)

    def relative_velocity(self) -> np.ndarray:
        """nu_r: the body velocity relative to the water (the current `model.opt.wind`)."""
        return self._hydro.body_velocity(self.data.ptr, self.model.ptr.opt.wind)

    def pose(self) -> np.ndarray:
        """(x, y, psi): the planar read-out (the episode recorder and the planar tools read it)."""
        x, y, _ = self.position()
        return np.array([x, y, self.heading()])

    def sonar(self) -> np.ndarray:
        """The 27 ranges of the 3-D sonar fan [m] at the current state (`auv_mj.sim.sensors3d`)."""
        return sonar_fan(self)

    def speed(self) -> float:
        """Speed over ground [m/s]."""
        return float(np.linalg.norm(self.data.qvel[self._dof:self._dof + 3]))

    def evaluate_sensors(self) -> None:
        """Runs MuJoCo's sensor stages at the current state (they are off during steps)."""
        model, data = self.model.ptr, self.data.ptr
        flags = model.opt.disableflags
        model.opt.disableflags = flags & ~SENSOR_DISABLE_BIT
        try:
            mujoco.mj_sensorPos(model, data)
            mujoco.mj_sensorVel(model, data)
            mujoco.mj_sensorAcc(model, data)
        finally:
            model.opt.disableflags = flags

    def copy(self, share_model: bool = False) -> AUV3DPhysics:
        """A copy of this physics with the same vehicle, fins and disturbance."""
        new = super().copy(share_model=share_model)
        new._hydro, new.source, new.fin_rate, new._nominal = self._hydro, self.source, self.fin_rate, self._nominal
        new._fin_limits, new._fin_lagged = self._fin_limits, self._fin_lagged
        new.fins, new.disturbance = self.fins.copy(), self.disturbance
        new._qpos, new._dof = self._qpos, self._dof
        new._bound, new._step_ready = None, False
        return new


def euler_angles(rotation: np.ndarray) -> np.ndarray:
    """(phi, theta, psi) of a body (FLU) to world (z up) rotation: roll about x, pitch nose-up positive, yaw."""
    theta = math.asin(max(-1.0, min(1.0, float(rotation[2, 0]))))
    psi = math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    phi = math.atan2(float(rotation[2, 1]), float(rotation[2, 2]))
    return np.array([phi, theta, psi])


def quaternion(roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """MuJoCo's (w, x, y, z) quaternion of `euler_angles`' (phi, theta, psi): yaw, then pitch, then roll."""
    out = np.empty(4)
    qz = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    qy = np.array([math.cos(-pitch / 2), 0.0, math.sin(-pitch / 2), 0.0])  # nose-up is negative about +y (port)
    qx = np.array([math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0])
    tmp = np.empty(4)
    mujoco.mju_mulQuat(tmp, qz, qy)
    mujoco.mju_mulQuat(out, tmp, qx)
    return out


def set_pose(physics: AUV3DPhysics, position=(0.0, 0.0, 0.0), roll: float = 0.0, pitch: float = 0.0,
             yaw: float = 0.0, nu=None) -> None:
    """Puts the vehicle at `position` [m] with this attitude [rad] and body velocity `nu` (FLU, 6), at rest if None."""
    with physics.reset_context():
        adr, dof = physics.hydrodynamics.qpos_adr, physics.hydrodynamics.dof_adr
        physics.data.qpos[adr:adr + 3] = position
        physics.data.qpos[adr + 3:adr + 7] = quaternion(roll, pitch, yaw)
        physics.data.qvel[dof:dof + 6] = 0.0
        if nu is not None:
            nu = np.asarray(nu, dtype=float)
            rotation = np.empty(9)
            mujoco.mju_quat2Mat(rotation, physics.data.qpos[adr + 3:adr + 7])
            physics.data.qvel[dof:dof + 3] = rotation.reshape(3, 3) @ nu[:3]
            physics.data.qvel[dof + 3:dof + 6] = nu[3:]


def _check_contract(model: mujoco.MjModel, source: str) -> None:
    """The module docstring's contract, as far as the hydrodynamics do not check it themselves."""
    timestep = float(model.opt.timestep)
    if not TIMESTEP_RANGE[0] <= timestep <= TIMESTEP_RANGE[1]:
        raise _fail(source, f'<option timestep="{timestep:g}"> must be in [{TIMESTEP_RANGE[0]:g}, '
                            f"{TIMESTEP_RANGE[1]:g}] s")
    if model.opt.integrator not in SUPPORTED_INTEGRATORS:
        raise _fail(source, "the integrator must be Euler or implicitfast for the hydrodynamic step")
    if model.njnt != 1 or model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise _fail(source, 'the model needs exactly one joint, the vehicle\'s <freejoint name="root">')
    names = [model.actuator(i).name for i in range(model.nu)]
    if names != list(ACTUATORS):
        raise _fail(source, f"the actuators must be {list(ACTUATORS)} in that order, got {names}")
    for i, name in enumerate(ACTUATORS):
        low, high = (float(v) for v in model.actuator_ctrlrange[i])
        if not (model.actuator_ctrllimited[i] and low < 0 < high and math.isfinite(low) and math.isfinite(high)):
            raise _fail(source, f'actuator {name} needs ctrllimited="true" and a finite ctrlrange low < 0 < high')
    body = int(model.jnt_bodyid[0])
    try:
        hull = model.geom(HULL_GEOM)
    except KeyError:
        raise _fail(source, f'no hull geom <geom name="{HULL_GEOM}">') from None
    if hull.type[0] != mujoco.mjtGeom.mjGEOM_CAPSULE or model.geom_bodyid[hull.id] != body:
        raise _fail(source, f"geom {HULL_GEOM} must be a capsule of the vehicle body")
    for site in SITES:
        try:
            found = model.site(site)
        except KeyError:
            raise _fail(source, f'no site <site name="{site}"> on the vehicle (the 3-D sensors read it)') from None
        if model.site_bodyid[found.id] != body:
            raise _fail(source, f"site {site} must be on the vehicle body")
