"""`AUVPhysics`: a dm_control Physics for the planar AUV with the hydrodynamics of Eq. (3) switched on."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
from dm_control.mujoco import engine

from auv_mj.disturbances import Disturbance
from auv_mj.hydrodynamics import Hydrodynamics, coefficients_from_xml
from auv_mj.sonar import SONAR_NAMES, clip_ranges

SUPPORTED_INTEGRATORS = (mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)


class AUVPhysics(engine.Physics):
    """Physics of one AUV (joints x, y, yaw; actuators tau_u, tau_r; sonars sonar_1..9).

    Hydrodynamics are applied in the step pipeline between `mj_step1` and `mj_step2`, where
    MuJoCo's own passive forces are applied, without a process-global callback: other MuJoCo
    models in the same process are unaffected, and each physics carries its own coefficients.
    Sensors are not evaluated on physics sub-steps; `sonar()` evaluates the rangefinders on demand.
    """

    _hydro: Hydrodynamics | None = None

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
            raise ValueError(f"{source}: MuJoCo cannot compile this model: {e}") from None
        physics._setup(coefficients, source)
        return physics

    @classmethod
    def from_xml_path(cls, file_path: str | Path):
        """Physics from an MJCF file (includes resolved relative to the file)."""
        path = Path(file_path)
        try:
            text = path.read_text()
        except OSError as e:
            raise ValueError(f"{path}: cannot read: {e}") from None
        coefficients = coefficients_from_xml(text, str(path))
        if coefficients is None:
            raise ValueError(f"{path}: no hydrodynamic coefficients (<numeric name=\"hydro_*\">): "
                             "not an auv-mj vehicle model")
        try:
            physics = super().from_xml_path(str(path))
        except Exception as e:  # dm_control raises its own wrapper Error for compile failures
            raise ValueError(f"{path}: MuJoCo cannot compile this model: {e}") from None
        physics._setup(coefficients, str(path))
        return physics

    def _setup(self, coefficients, source: str) -> None:
        model = self.model.ptr
        if model.opt.integrator not in SUPPORTED_INTEGRATORS:
            raise ValueError(f"{source}: integrator must be Euler or implicitfast for the hydrodynamic "
                             f"step hook, got {mujoco.mjtIntegrator(model.opt.integrator).name}")
        self._hydro = Hydrodynamics(model, coefficients, source)
        self.source = source
        self._disturbances: list[Disturbance] = []
        self._sonar_adr = np.array([model.sensor_adr[model.sensor(n).id] for n in SONAR_NAMES])
        self._actuator_names = [model.actuator(i).name for i in range(model.nu)]
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
        self._hydro_applied = False
        self.forward()

    @property
    def hydrodynamics(self) -> Hydrodynamics:
        """The hydrodynamic model of this physics (coefficients, body-frame force)."""
        return self._hydro

    # --- stepping -------------------------------------------------------------------------------

    def _apply_hydrodynamics(self) -> None:
        if self._hydro_applied:
            return
        model, data = self.model.ptr, self.data.ptr
        disturbance = None
        if self._disturbances:
            time, psi = data.time, data.qpos[self._hydro.qpos_yaw]
            active = [d.world_wrench(time, psi) for d in self._disturbances if d.active(time)]
            if active:
                disturbance = np.sum(active, axis=0)
        self._hydro.apply(model, data, disturbance)
        self._hydro_applied = True

    def step(self, nstep: int = 1) -> None:
        """Advances `nstep` physics steps with hydrodynamics (semi-implicit Euler, timestep from the MJCF)."""
        model, data = self.model.ptr, self.data.ptr
        self._check_control(data.ctrl)
        with self.check_invalid_state():
            for _ in range(nstep):
                self._apply_hydrodynamics()
                mujoco.mj_step2(model, data)
                mujoco.mj_step1(model, data)
                self._hydro_applied = False

    def forward(self) -> None:
        """Recomputes the derived quantities (accelerations included, with hydrodynamics) of the state."""
        if self._hydro is None:  # still being constructed by dm_control
            super().forward()
            return
        model, data = self.model.ptr, self.data.ptr
        with self.check_invalid_state():
            mujoco.mj_forward(model, data)
            self._hydro_applied = False
            self._apply_hydrodynamics()
            mujoco.mj_fwdAcceleration(model, data)
            mujoco.mj_fwdConstraint(model, data)

    def set_control(self, control) -> None:
        """Sets (tau_u, tau_r); a NaN or infinite value raises ValueError and changes nothing."""
        control = np.asarray(control, dtype=float)
        self._check_control(control)
        super().set_control(control)

    def _check_control(self, control: np.ndarray) -> None:
        finite = np.isfinite(control)
        if not np.all(finite):
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
        self._hydro_applied = False
        return disturbance

    def remove_disturbance(self, disturbance: Disturbance) -> None:
        """Stops applying one disturbance."""
        self._disturbances.remove(disturbance)
        self._hydro_applied = False

    def clear_disturbances(self) -> None:
        """Stops applying all disturbances."""
        self._disturbances.clear()
        self._hydro_applied = False

    # --- read-outs ------------------------------------------------------------------------------

    def pose(self) -> np.ndarray:
        """(x, y, psi): position [m] and heading [rad] in the world frame, eta of Eq. (1)."""
        return self.named.data.qpos[["x", "y", "yaw"]].copy()

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
        model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
        try:
            mujoco.mj_sensorPos(model, data)
        finally:
            model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
        return clip_ranges(data.sensordata[self._sonar_adr].copy())

    def kinetic_energy(self) -> float:
        """1/2 nu^T (M_RB + M_A) nu [J] (Eq. 4), the energy that drag can only take away."""
        nu = self.body_velocity()
        return 0.5 * float(nu @ self._hydro.total_mass @ nu)

    def copy(self, share_model: bool = False) -> AUVPhysics:
        """A copy of this physics with the same hydrodynamics and disturbances."""
        new = super().copy(share_model=share_model)
        new._hydro = self._hydro
        new.source = self.source
        new._disturbances = list(self._disturbances)
        new._sonar_adr = self._sonar_adr
        new._actuator_names = self._actuator_names
        new._hydro_applied = False
        return new
