"""Control of the vehicles: the controllers' maths that tasks and planners both use.

`splane` is the S-plane of Eq. (32), the planar speed/heading executor; `depth_heading` is the same S-plane on the
6-DOF vehicle's speed, heading and depth channels, with 3-D line of sight; `clock` ticks an executor at its own
rate inside a planner's step. They read the vehicle from its compiled MJCF and know nothing of tasks.
"""
