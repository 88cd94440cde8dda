"""The task registry shared by every task module: `@SUITE.add("benchmarking", ...)` on a factory."""

import collections.abc  # noqa: F401  (dm_control's containers uses collections.abc without importing it)

from dm_control.utils import containers

SUITE = containers.TaggedTasks()
"""Task name -> factory `(time_limit=..., random=None, environment_kwargs=None, **task_kwargs)`."""
