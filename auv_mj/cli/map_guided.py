"""`planner-map`: the shipped residual planner run over `map-replan`'s planned path (issue 30, part 4).

A first, cheap attempt at giving the learned planner memory: the memory is `map-replan`'s occupancy grid
(`tasks.map_planner.SonarMap`), and the residual planner (`planner-general`, which corrects line of sight)
steers along the path searched on it instead of along the straight route. Its goal input is a virtual goal on
the bearing of the path's look-ahead point, as far away as the planned path is long, so that the body-frame
goal it reads (distance and bearing, `tasks.planning.RELATIVE_FIELDS`) stays in the range it was trained on.
Its ablation, the same system with the learned output zeroed, is `map-replan` itself (the zero action is line
of sight at 1 m/s, so the ablation row is `map-replan`, which cruises at 2 m/s: the speed is part of what the
planner decides).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tasks.map_planner import SonarMap


def map_guided(checkpoint: Path, env, inner_policy):
    """The residual planner `inner_policy` (a `checkpoint_policy` of `checkpoint` on `env`, with its guidance
    and protection domain) fed the virtual goal along `map-replan`'s path (module docstring)."""
    follower = SonarMap(env)

    def act(time_step):
        point, left = follower.waypoint(time_step)
        pose = np.array(env.physics.pose(), dtype=float)
        bearing = math.atan2(point[1] - pose[1], point[0] - pose[0])
        virtual = pose[:2] + left * np.array([math.cos(bearing), math.sin(bearing)])
        observation = dict(time_step.observation)
        desired = np.asarray(observation["desired_goal"], dtype=float).copy()
        desired[:2] = virtual
        if desired.size == 4:
            desired[2:] = (math.cos(bearing), math.sin(bearing))
        observation["observation"] = env.task.relabel_observation(observation["observation"],
                                                                  observation["achieved_goal"], desired)
        observation["desired_goal"] = desired
        return inner_policy(time_step._replace(observation=observation))

    act.reset = follower.reset
    return act
