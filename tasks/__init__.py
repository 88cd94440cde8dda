"""auv-mj tasks: dm_control-style planning and control tasks for the AUV (see `tasks.suite`)."""
