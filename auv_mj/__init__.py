"""auv-mj: a MuJoCo simulator of an underactuated planar AUV (Lyu et al. 2023, J. Mar. Sci. Eng. 11, 1796)."""

import os

# Headless by default: dm_control picks its OpenGL backend at import time.
os.environ.setdefault("MUJOCO_GL", "egl")

from auv_mj.assets import model_path, models_dir
from auv_mj.disturbances import Disturbance
from auv_mj.hydrodynamics import HydroCoefficients, Hydrodynamics
from auv_mj.physics import AUVPhysics
from auv_mj.sonar import SONAR_RANGE, SONAR_RATE_HZ, SampleAndHold

__all__ = ["AUVPhysics", "Disturbance", "HydroCoefficients", "Hydrodynamics", "SONAR_RANGE",
           "SONAR_RATE_HZ", "SampleAndHold", "model_path", "models_dir"]
__version__ = "0.1.0"
