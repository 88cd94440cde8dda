"""`AUVPhysics`: a dm_control Physics for the planar AUV with the hydrodynamics of Eq. (3) switched on."""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from pathlib import Path

import mujoco
import numpy as np
from dm_control.mujoco import engine
from dm_control.rl.control import PhysicsError

from auv_mj.inputs import MAX_XML_BYTES, read_text, source_name
from auv_mj.sim.disturbances import Disturbance
from auv_mj.sim.hydrodynamics import Hydrodynamics, coefficients_from_xml
from auv_mj.sim.sonar import SONAR_NAMES, clip_ranges
from auv_mj.sim.vehicle import check_vehicle

SUPPORTED_INTEGRATORS = (mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
SENSOR_DISABLE_BIT = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
CONSTRAINT_DISABLE_BIT = int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
CONTACT_DISABLE_BIT = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
SETTLED_CACHE_SIZE = 256
"""Vehicles (coefficients, inertia, timestep, integrator) remembered as having passed the settle check."""
_SETTLED: set = set()
SETTLE_STATES = ((2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (2.0, 0.5, 0.5), (-1.0, -0.5, -0.5))
"""Body velocities (u, v, r) [m/s, m/s, rad/s] from which the load-time settle check coasts the vehicle."""
SETTLE_STEPS = 20
"""Physics steps of each settle run: an unstable step grows within a few steps."""
SETTLE_GROWTH = 2.0
"""Coasting without thrust, the kinetic energy may not grow by more than this factor (drag takes it out)."""


class AUVPhysics(engine.Physics):
    """Physics of one AUV (joints x, y, yaw; actuators tau_u, tau_r; sonars sonar_1..9).

    Hydrodynamics are applied in the step pipeline between `mj_step1` and `mj_step2`, where
    MuJoCo's own passive forces are applied, without a process-global callback: other MuJoCo
    models in the same process are unaffected, and each physics carries its own coefficients.
    Sensors are not evaluated on physics sub-steps; `sonar()` evaluates the rangefinders on demand.
    The ocean current is `model.opt.wind[:2]` (see `auv_mj.sim.hydrodynamics`); `scale_vehicle` departs from
    the MJCF's vehicle for model uncertainty (`auv_mj.sim.ocean`).
    """

    _hydro: Hydrodynamics | None = None
    _step_ready = False
    _bound: tuple | None = None

    @classmethod
    def from_xml_string(cls, xml_string: str, assets: dict | None = None, source: str = "<string>"):
        """Physics from MJCF text; `source` names it in error messages."""
        coefficients = coefficients_from_xml(xml_string, source)
        if coefficients is None:
            raise ValueError(f"{source}: no hydrodynamic coefficients (<numeric name=\"hydro_*\">): "
                             "not an auv-mj vehicle model")
        try:
            physics = super().from_xml_string(xml_string, assets=assets)
        except Exception as e:  # dm_control raises its own wrapper Error for compile failures
            raise ValueError(f"{source}: MuJoCo cannot compile this model: {' '.join(str(e).split())}") from None
        physics._setup(coefficients, source)
        return physics

    @classmethod
    def from_xml_path(cls, file_path: str | Path):
        """Physics from an MJCF file (includes resolved relative to the file)."""
        path = Path(file_path)
        name = source_name(path)
        text = read_text(path, "vehicle MJCF", MAX_XML_BYTES)
        coefficients = coefficients_from_xml(text, name)
        if coefficients is None:
            raise ValueError(f"{name}: no hydrodynamic coefficients (<numeric name=\"hydro_*\">): "
                             "not an auv-mj vehicle model")
        try:
            physics = super().from_xml_path(str(path))
        except Exception as e:  # dm_control raises its own wrapper Error for compile failures
            raise ValueError(f"{name}: MuJoCo cannot compile this model: {' '.join(str(e).split())}") from None
        physics._setup(coefficients, name)
        return physics

    def reload_from_xml_string(self, xml_string: str, assets: dict | None = None,
                               source: str = "<string>") -> None:
        """Recompiles this physics in place from MJCF text: a new arena around the vehicle.

        The object stays the same, so an environment holding it goes on with the new model (a task
        that draws a fresh arena per episode calls this from `initialize_episode`); disturbances are kept.
        """
        coefficients = coefficients_from_xml(xml_string, source)
        if coefficients is None:
            raise ValueError(f"{source}: no hydrodynamic coefficients (<numeric name=\"hydro_*\">): "
                             "not an auv-mj vehicle model")
        hydro, disturbances = self._hydro, list(self._disturbances)
        self._hydro = None  # dm_control runs a plain forward on the new model before `_setup` binds it
        try:
            super().reload_from_xml_string(xml_string, assets=assets)
        except Exception as e:  # dm_control raises its own wrapper Error for compile failures
            self._hydro = hydro
            raise ValueError(f"{source}: MuJoCo cannot compile this model: {e}") from None
        self._setup(coefficients, source)
        self._disturbances = disturbances

    def _setup(self, coefficients, source: str) -> None:
        model = self.model.ptr
        check_vehicle(model, source)
        if model.opt.integrator not in SUPPORTED_INTEGRATORS:
            raise ValueError(f"{source}: integrator must be Euler or implicitfast for the hydrodynamic "
                             f"step hook, got {mujoco.mjtIntegrator(model.opt.integrator).name}")
        self._hydro = Hydrodynamics(model, coefficients, source)
        self._nominal = coefficients
        body = int(model.jnt_bodyid[model.joint("x").id])
        self._vehicle_body = body
        self._nominal_mass = (float(model.body_mass[body]), model.body_inertia[body].copy())
        self.source = source
        self._settle_check()
        self._disturbances: list[Disturbance] = []
        addresses = [int(model.sensor_adr[model.sensor(n).id]) for n in SONAR_NAMES]
        contiguous = addresses == list(range(addresses[0], addresses[0] + len(addresses)))
        self._sonar_index = slice(addresses[0], addresses[-1] + 1) if contiguous else np.array(addresses)
        self._actuator_names = [model.actuator(i).name for i in range(model.nu)]
        self._pose_adr = np.array([model.jnt_qposadr[model.joint(n).id] for n in ("x", "y", "yaw")])
        model.opt.disableflags |= SENSOR_DISABLE_BIT
        self._step_ready = False
        self._bound = None
        self.forward()

    def _settle_check(self) -> None:
        """Coasts the vehicle briefly from SETTLE_STATES (no thrust, no contacts): a model whose numerics
        make the step diverge right after load is refused here, naming the suspicious coefficients.

        The coast depends only on the vehicle (coefficients, inertia, timestep, integrator), so a vehicle that
        passed once is not coasted again in this process (a vehicle in another arena is the same vehicle).
        """
        model = self.model.ptr
        key = (self._hydro.coefficients, self._hydro.total_mass.tobytes(), float(model.opt.timestep),
               int(model.opt.integrator))
        if key in _SETTLED:
            return
        data = mujoco.MjData(model)
        hook = self._hydro.bind(model, data)
        dofs = self._hydro.dofs
        flags = model.opt.disableflags
        model.opt.disableflags = flags | CONSTRAINT_DISABLE_BIT | CONTACT_DISABLE_BIT
        try:
            for start in SETTLE_STATES:
                mujoco.mj_resetData(model, data)
                data.qvel[dofs] = start  # psi = 0: body and world velocities coincide
                mujoco.mj_step1(model, data)
                history = [start]
                for _ in range(SETTLE_STEPS):
                    hook(1, model.opt.timestep)  # Eq. (3)-(11), then mj_step2 and mj_step1
                    history.append(self._hydro.body_velocity(data))
                nus = np.array(history)
                with np.errstate(over="ignore", invalid="ignore"):
                    energy = 0.5 * np.einsum("ij,jk,ik->i", nus, self._hydro.total_mass, nus)
                blown = bool(np.any(data.warning.number)) or not np.all(np.isfinite(energy))
                grown = not blown and energy.max() > SETTLE_GROWTH * energy[0]
                if blown or grown:
                    onset = np.flatnonzero(~(energy <= SETTLE_GROWTH * energy[0]))  # NaN counts
                    nu = nus[onset[0] - 1] if len(onset) else nus[np.argmax(energy)]  # the state before it
                    raise ValueError(
                        f"{self.source}: the vehicle's dynamics diverge right after load: coasting from "
                        f"(u, v, r) = {start} with steps of {model.opt.timestep:g} s "
                        f"{'blows up' if blown else 'gains energy'} near (u, v, r) = "
                        f"{tuple(np.round(nu, 3).tolist())}; suspicious numerics: {self._suspects(nu)}")
        finally:
            model.opt.disableflags = flags
        if len(_SETTLED) >= SETTLED_CACHE_SIZE:
            _SETTLED.clear()
        _SETTLED.add(key)

    def _suspects(self, nu) -> str:
        """The three hydrodynamic coefficients whose terms change the velocity most in one step at `nu`.

        A term F of a coefficient changes its velocity by |F| dt / m per explicit step (m: rigid-body plus
        added mass of that degree of freedom); near or above the velocity itself the step is unstable.
        """
        c = self._hydro.coefficients
        u, v, r = (float(x) for x in nu)
        au, av, ar = abs(u), abs(v), abs(r)
        terms = {"X_uu": (0, c.X_uu * au * u), "Y_vv": (1, c.Y_vv * av * v), "Y_vr": (1, c.Y_vr * ar * v),
                 "Y_rv": (1, c.Y_rv * av * r), "Y_rr": (1, c.Y_rr * ar * r), "Y_uv": (1, c.Y_uv * u * v),
                 "Y_ur": (1, c.Y_ur * u * r), "N_vv": (2, c.N_vv * av * v), "N_vr": (2, c.N_vr * ar * v),
                 "N_rv": (2, c.N_rv * av * r), "N_rr": (2, c.N_rr * ar * r), "N_uv": (2, c.N_uv * u * v),
                 "N_ur": (2, c.N_ur * u * r)}
        mass = self._hydro.total_mass.diagonal()
        dt = float(self.model.opt.timestep)
        change = {k: abs(force) * dt / mass[dof] for k, (dof, force) in terms.items()}
        units = ("m/s", "m/s", "rad/s")
        ranked = sorted(change, key=lambda k: -change[k])[:3]
        return ", ".join(f"hydro_{k} = {getattr(c, k):g} (changes {'uvr'[terms[k][0]]} by {change[k]:.3g} "
                         f"{units[terms[k][0]]} per step)" for k in ranked)

    @property
    def disturbances(self) -> tuple[Disturbance, ...]:
        """The disturbances applied while stepping (`add_disturbance`)."""
        return tuple(self._disturbances)

    @property
    def step_ready(self) -> bool:
        """Whether the next step may skip `mj_step1` (M and the passive forces are the current state's): a batched
        step that continues this physics starts the same way."""
        return self._step_ready

    @property
    def hydrodynamics(self) -> Hydrodynamics:
        """The hydrodynamic model of this physics (coefficients, body-frame force)."""
        return self._hydro

    def scale_vehicle(self, coefficients: Mapping[str, float] | None = None, mass: float = 1.0) -> None:
        """Scales the vehicle from its MJCF values: each named hydrodynamic coefficient (e.g. "X_uu") by its
        factor, the body's mass and inertia by `mass`; `scale_vehicle()` restores the MJCF vehicle.

        MuJoCo's constants that depend on the mass are recomputed (`mj_setConst`); the next step rebuilds
        the joint-space inertia. A ValueError names an unknown coefficient or a vehicle that is no longer
        physical (M_RB + M_A not positive definite).
        """
        coefficients = dict(coefficients or {})
        nominal = self._nominal
        unknown = [k for k in coefficients if not hasattr(nominal, k)]
        if unknown:
            raise ValueError(f"scale_vehicle: unknown hydrodynamic coefficient(s) {unknown}")
        if not (math.isfinite(mass) and mass > 0):
            raise ValueError(f"scale_vehicle: the mass factor must be positive, got {mass}")
        scaled = dataclasses.replace(nominal, **{k: getattr(nominal, k) * float(f) for k, f in coefficients.items()})
        model = self.model.ptr
        body = self._vehicle_body
        body_mass, body_inertia = self._nominal_mass
        model.body_mass[body] = body_mass * mass
        model.body_inertia[body] = body_inertia * mass
        mujoco.mj_setConst(model, mujoco.MjData(model))
        try:
            self._hydro = Hydrodynamics(model, scaled, self.source)
        except ValueError:
            if coefficients or mass != 1.0:  # leave the MJCF's vehicle, not a half-scaled one
                self.scale_vehicle()
            raise
        finally:
            self._bound = None
            self._step_ready = False

    # --- stepping -------------------------------------------------------------------------------

    def _reload_from_data(self, data) -> None:
        """dm_control's (re)binding to new MuJoCo data (construction, copy, reload): drops the step binding."""
        self._bound = None
        super()._reload_from_data(data)
        self._bound = None

    def _bind(self) -> tuple:
        """What `step` reads on every call, bound once per (model, data): MuJoCo's structs, the hydrodynamic
        stepper, the disturbance wrench and memoryviews of ctrl and the warning counts."""
        model, data = self.model.ptr, self.data.ptr
        self._bound = (model, data, model.opt, self._hydro.bind(model, data),
                       lambda: self._disturbance_wrench(data), memoryview(data.ctrl),
                       memoryview(self._warnings))
        return self._bound

    def _disturbance_wrench(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """Sum of the active disturbances, world frame (Fx, Fy, Mz), at the state's time and heading."""
        time, psi = data.time, data.qpos.item(self._hydro.qpos_yaw)
        fx = fy = mz = 0.0
        for disturbance in self._disturbances:
            if disturbance.active(time):
                wx, wy, wz = disturbance.wrench(time, psi)
                fx, fy, mz = fx + wx, fy + wy, mz + wz
        return fx, fy, mz

    def step(self, nstep: int = 1) -> None:
        """Advances `nstep` physics steps with hydrodynamics (semi-implicit Euler, timestep from the MJCF).

        Like dm_control's legacy step, each step is `mj_step2` then `mj_step1`, so that position and
        velocity dependent quantities are current afterwards; the hydrodynamics go in between. After
        a direct change of qpos or qvel, call `forward()` first. A new MuJoCo warning (e.g. an
        unstable state, which MuJoCo resets) raises PhysicsError after the call.
        """
        model, data, opt, advance, wrench, ctrl, warnings = self._bound or self._bind()
        if not math.isfinite(sum(ctrl)):  # one sum per call; a NaN or inf anywhere makes it non-finite
            self._check_control(data.ctrl)
        timestep = opt.timestep
        warnings_before = warnings.tobytes()
        start_time = data.time
        if not self._step_ready:  # after forward(), reset or copy: rebuild M and the passive forces
            mujoco.mj_step1(model, data)
        advance(nstep, timestep, wrench if self._disturbances else None)
        self._step_ready = True
        # MuJoCo auto-resets an unstable state, which rewinds time and may leave the counts unchanged.
        if warnings.tobytes() != warnings_before or data.time < start_time + (nstep - 0.5) * timestep:
            self._report_invalid_state(np.frombuffer(warnings_before, dtype=self._warnings.dtype))

    def _report_invalid_state(self, warnings_before: np.ndarray) -> None:
        """Raises dm_control's PhysicsError (or logs, inside `suppress_physics_errors`) as its step would."""
        names = list(mujoco.mjtWarning.__members__)
        new = [names[i] for i in np.flatnonzero(self._warnings != warnings_before)]
        message = (f"Physics state is invalid ({self.source}). Warning(s) raised: {', '.join(new)}" if new else
                   f"Physics state is invalid ({self.source}): MuJoCo reset it during the step (time went back)")
        if self._warnings_cause_exception:
            raise PhysicsError(message)
        logging.warning(message)

    def forward(self) -> None:
        """Recomputes the derived quantities of the state, accelerations of Eq. (3) included."""
        if self._hydro is None:  # still being constructed by dm_control
            super().forward()
            return
        model, data, _, advance, wrench, *_ = self._bound or self._bind()
        with self.check_invalid_state():
            mujoco.mj_forward(model, data)
            advance(0, 0.0, wrench if self._disturbances else None)
            mujoco.mj_fwdAcceleration(model, data)
            mujoco.mj_fwdConstraint(model, data)
        self._step_ready = False

    def set_control(self, control) -> None:
        """Sets (tau_u, tau_r); a NaN or infinite value raises ValueError and changes nothing."""
        control = np.asarray(control, dtype=float)
        self._check_control(control)
        super().set_control(control)

    def _check_control(self, control: np.ndarray) -> None:
        if all(map(math.isfinite, control.ravel().tolist())):
            return
        finite = np.isfinite(control)
        bad = ", ".join(f"{self._actuator_names[i]}={control[i]}" for i in np.flatnonzero(~finite))
        raise ValueError(f"control must be finite, got {bad}; the physics state was not changed")

    # --- disturbances ---------------------------------------------------------------------------

    def add_disturbance(self, force, start: float = 0.0, duration: float = math.inf,
                        frame: str = "world") -> Disturbance:
        """Applies (Fx, Fy[, Mz]) [N, N m] during [start, start + duration) s of simulation time.

        `force` may be a function of time; `frame` is "world" or "body". Returns the Disturbance,
        which `remove_disturbance` takes back.
        """
        disturbance = force if isinstance(force, Disturbance) else Disturbance(force, start, duration, frame)
        self._disturbances.append(disturbance)
        return disturbance

    def remove_disturbance(self, disturbance: Disturbance) -> None:
        """Stops applying one disturbance."""
        self._disturbances.remove(disturbance)

    def clear_disturbances(self) -> None:
        """Stops applying all disturbances."""
        self._disturbances.clear()

    # --- read-outs ------------------------------------------------------------------------------

    def pose(self) -> np.ndarray:
        """(x, y, psi): position [m] and heading [rad] in the world frame, eta of Eq. (1)."""
        return self.data.qpos[self._pose_adr]

    def body_velocity(self) -> np.ndarray:
        """(u, v, r): surge [m/s], sway [m/s] and yaw rate [rad/s] in the body frame, nu of Eq. (1)."""
        return np.array(self._hydro.body_velocity(self.data.ptr))

    def speed(self) -> float:
        """Speed over ground [m/s]."""
        u, v, _ = self.body_velocity()
        return math.hypot(u, v)

    def sonar(self) -> np.ndarray:
        """Ranges S1..S9 [m] at the current state; no echo reads the 120 m maximum (Sec. 2.2)."""
        model, data = self.model.ptr, self.data.ptr
        opt = model.opt
        flags = opt.disableflags
        opt.disableflags = flags & ~SENSOR_DISABLE_BIT
        try:
            mujoco.mj_sensorPos(model, data)
        finally:
            opt.disableflags = flags
        return clip_ranges(data.sensordata[self._sonar_index])

    def kinetic_energy(self) -> float:
        """1/2 nu^T (M_RB + M_A) nu [J] (Eq. 4), the energy that drag can only take away."""
        nu = self.body_velocity()
        return 0.5 * float(nu @ self._hydro.total_mass @ nu)

    def copy(self, share_model: bool = False) -> AUVPhysics:
        """A copy of this physics with the same hydrodynamics and disturbances."""
        new = super().copy(share_model=share_model)
        new._hydro = self._hydro
        new._nominal, new._vehicle_body, new._nominal_mass = self._nominal, self._vehicle_body, self._nominal_mass
        new.source = self.source
        new._disturbances = list(self._disturbances)
        new._sonar_index = self._sonar_index
        new._actuator_names = self._actuator_names
        new._pose_adr = self._pose_adr
        new._step_ready = False
        new._bound = None
        return new
