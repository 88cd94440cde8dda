"""auv-mj tasks: dm_control-style planning and control tasks for the AUV (see `tasks.suite`).

Importing the package registers the Gymnasium ids `auv_mj/*-v0` (see `tasks.gym_adapter`).
"""

import auv_mj  # noqa: F401  (chooses the headless OpenGL backend before any task imports dm_control)
from tasks import gym_adapter  # noqa: F401  (registers the auv_mj/*-v0 Gymnasium ids)
