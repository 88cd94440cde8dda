"""The task registries shared by every task module, one per domain: `@SUITE.add("benchmarking", ...)` on a factory of
the planar domain "auv", `@SUITE3D.add(...)` of the 6-DOF domain "auv3d" (`auv_mj.tasks.domains`)."""

import collections.abc  # noqa: F401  (dm_control's containers uses collections.abc without importing it)

from dm_control.utils import containers

SUITE = containers.TaggedTasks()
"""Task name -> factory `(time_limit=..., random=None, environment_kwargs=None, **task_kwargs)`."""
SUITE3D = containers.TaggedTasks()
"""Task name -> factory of the "auv3d" domain."""
DOMAIN_3D = "auv3d"
"""The 6-DOF domain's name."""
