"""auv-mj: a MuJoCo simulator of an AUV with learned planning and control (Lyu et al. 2023, J. Mar. Sci. Eng. 11,
1796).

One import name. Everything of auv-mj lives under `auv_mj`: the simulator core (`auv_mj.sim`, `auv_mj.arenas`,
`auv_mj.render`), the dm_control suite and its Gymnasium face (`auv_mj.tasks`), the policies (`auv_mj.agents`,
`auv_mj.planners`), the library that names and runs them (`auv_mj.zoo`, `auv_mj.benchmark`, `auv_mj.jobs`) and the
app (`auv_mj.cli`). A user's own `tasks` or `agents` package cannot shadow any of it.

Importing the package registers the Gymnasium ids (`gymnasium.make("auv_mj/Goal-v0")`).
"""

# First: sets MUJOCO_GL (headless by default) before mujoco and dm_control read it at import time.
from auv_mj.assets import model_path, models_dir
from auv_mj.render import glbackend  # noqa: F401
from auv_mj.sim.disturbances import Disturbance
from auv_mj.sim.hydrodynamics import HydroCoefficients, Hydrodynamics
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.sonar import SONAR_RANGE, SONAR_RATE_HZ, SampleAndHold
from auv_mj.tasks import gym_adapter as _gym_ids  # noqa: F401, I001  (registers the auv_mj/*-v0 Gymnasium ids)

__all__ = ["AUVPhysics", "Disturbance", "HydroCoefficients", "Hydrodynamics", "SONAR_RANGE",
           "SONAR_RATE_HZ", "SampleAndHold", "model_path", "models_dir"]
__version__ = "0.2.0"
