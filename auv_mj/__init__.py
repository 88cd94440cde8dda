"""auv-mj: a MuJoCo simulator of an underactuated planar AUV (Lyu et al. 2023, J. Mar. Sci. Eng. 11, 1796)."""

# First: sets MUJOCO_GL (headless by default) before mujoco and dm_control read it at import time.
from auv_mj.assets import model_path, models_dir
from auv_mj.render import glbackend  # noqa: F401
from auv_mj.sim.disturbances import Disturbance
from auv_mj.sim.hydrodynamics import HydroCoefficients, Hydrodynamics
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.sonar import SONAR_RANGE, SONAR_RATE_HZ, SampleAndHold

__all__ = ["AUVPhysics", "Disturbance", "HydroCoefficients", "Hydrodynamics", "SONAR_RANGE",
           "SONAR_RATE_HZ", "SampleAndHold", "model_path", "models_dir"]
__version__ = "0.1.0"
