"""The AUV-centred repulsive protection domain of Sec. 3.2.2 as an active avoidance layer on a planner.

When sonar echoes enter the protection domain, a repulsive field (the gradient of U_2 of Eq. 22,
k (1/d - 1/d0)) pushes the planner's heading away from them; once the obstacle leaves the domain the
planner's own heading is restored. It works on the observation alone (the nine sonar ranges), so it
wraps any planning policy: `with_repulsion(policy)`.

The paper sizes the domain for its 1 m/s target speed. A planner that cruises faster (up to Table 3's
2 m/s) has less time to turn away from an echo at the same distance: at 2 m/s and Table 1's 6 deg per step
it closes 10 m in the 10 steps a 60 deg turn takes. The speed-aware domain (ours, `PROTECTIONS["speed-aware"]`)
keeps the paper's domain in time to contact instead of metres: above the reference speed V_ref the echoes
are read as d V_ref / V_cmd, and an echo within SLOW_CONE of the bow nearer than `slow_distance` brings the
command back to V_ref, where the domain is the paper's again. At or below V_ref it is the paper's domain
(with its own gain k_2, see PROTECTIONS); `los-avoid` keeps the paper's domain and is unchanged.

The map's edge is no obstacle the rangefinders can see, yet leaving the map ends an episode. A planner that
swings wide round obstacles at speed can cross it where `los-avoid` does not, so the speed-aware domain also
reads the edge as a wall along each beam (`fence`, `PlanningTask.map_fence`, a geofence; ours): the vehicle
knows its map, as it knows its goal.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import dm_env
import numpy as np

from auv_mj.episode import FunctionPlanner, Planner, as_planner
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_RANGE
from auv_mj.tasks import options as checks
from auv_mj.tasks.planning_observation import SONAR_SLICE
from auv_mj.tasks.planning_step import ACTION_HEADING_RANGE as MAX_HEADING_OFFSET
from auv_mj.tasks.planning_step import speed_action, speed_command
from auv_mj.tasks.routes import TARGET_SPEED

SLOW_CONE = math.pi / 8
"""Half-width [rad] of the cone ahead whose echoes slow a speed-aware domain's planner: beams S4-S6."""
_AHEAD = np.abs(BEAM_ANGLES) <= SLOW_CONE + 1e-9
"""The beams inside SLOW_CONE."""


@dataclass(frozen=True)
class RepulsiveField:
    """Parameters of the protection domain (ours: the paper leaves k_2 and the domain size to the vehicle)."""

    influence: float = 30.0
    """d0 [m]: echoes nearer than this repel. Eq. (22)'s delta max(L1, L2) is only 12 m for a 1.3 m REMUS,
    too short to get round a tunnel obstacle at 1 m/s with Table 1's 6 deg per step; 30 m is."""
    gain: float = 120.0
    """k_2 of Eq. (22): an echo at d_s = 5 m outweighs the planner's heading 4:1. Chosen by a scan of
    (gain, influence) on the Table 7, 8 and 12 scenarios with line-of-sight guidance: the smallest gain
    keeping every scenario's clearance above d_s (5.7 m at the least)."""
    reference_speed: float | None = None
    """V_ref [m/s] of the speed-aware domain (module docstring); None is the paper's domain at any speed."""
    slow_distance: float = 0.0
    """Above V_ref, an echo within SLOW_CONE of the bow nearer than this [m] brings the command back to V_ref.
    20 m (10 s at 2 m/s): of 20, 25 and 30 m, each without a failure on 60 validation tunnels, the fastest
    (docs/runs/planner-speed-aware)."""
    fence: bool = False
    """Whether the map's edge counts as an echo where it is nearer than the sonar's (`PlanningTask.map_fence`, a
    geofence; ours): the rangefinders cannot see it, and a planner passing obstacles at speed can leave the map
    on the side of its edge."""

    def speed_and_ranges(self, speed: float, ranges: np.ndarray) -> tuple[float, np.ndarray]:
        """The commanded speed [m/s] after the slow-down rule, and the ranges [m] as the domain reads them at
        that speed (unchanged for the paper's domain or at or below V_ref)."""
        if self.reference_speed is None or speed <= self.reference_speed:
            return speed, ranges
        if np.min(ranges[_AHEAD]) < self.slow_distance:
            return self.reference_speed, ranges
        return speed, ranges * (self.reference_speed / speed)

    def heading_offset(self, ranges: np.ndarray, planner_offset: float) -> float:
        """The planner's heading offset [rad] (body frame) bent by the repulsion of the echoes [m]."""
        near = ranges < self.influence
        if not near.any():
            return planner_offset
        d = np.maximum(ranges[near], 0.5)
        angles = BEAM_ANGLES[near]
        weight = self.gain * (1.0 / d - 1.0 / self.influence) / d
        push_x = -np.sum(weight * np.cos(angles))
        push_y = -np.sum(weight * np.sin(angles))
        ahead = np.sum(weight * np.cos(angles) * (np.abs(angles) < math.pi / 8))
        if ahead > 0:  # an echo dead ahead pushes straight back: break the tie towards the freer side
            port, starboard = ranges[BEAM_ANGLES > 0].sum(), ranges[BEAM_ANGLES < 0].sum()
            push_y += ahead if port >= starboard else -ahead
        x = math.cos(planner_offset) + push_x
        y = math.sin(planner_offset) + push_y
        return float(np.clip(math.atan2(y, x), -MAX_HEADING_OFFSET, MAX_HEADING_OFFSET))


PROTECTIONS = {"paper": RepulsiveField(),
               "speed-aware": RepulsiveField(gain=150.0, reference_speed=TARGET_SPEED, slow_distance=20.0,
                                             fence=True)}
"""The protection domains by name: the paper's (Sec. 3.2.2) and the speed-aware one (module docstring), which
also reads the map's edge and pushes with k_2 = 150 (chosen on validation, docs/runs/planner-speed-aware,
section 5)."""


def protection_field(value) -> RepulsiveField | None:
    """The protection domain an option names: True or "paper" the paper's, "speed-aware" ours, False or None
    none. ValueError naming the value otherwise."""
    if value is None or value is False:
        return None
    if value is True:
        return PROTECTIONS["paper"]
    if isinstance(value, str) and value in PROTECTIONS:
        return PROTECTIONS[value]
    raise ValueError(f"protection must be True, False or one of {list(PROTECTIONS)}, got {checks.shown(value)}")


def protect(action, observation: np.ndarray, field: RepulsiveField | None = None,
            fence: np.ndarray | None = None) -> np.ndarray:
    """A planning action (speed, heading offset) with its heading bent by the echoes in `observation`
    (a planning task's "observation" vector, either layout: the sonar ends both), and with a speed-aware
    domain its speed capped near echoes ahead. A field with `fence` also reads `fence`, the map's edge per
    beam [m] (`PlanningTask.map_fence`), as echoes."""
    field = field or RepulsiveField()
    action = np.array(action, dtype=float)
    ranges = np.asarray(observation)[SONAR_SLICE] * SONAR_RANGE
    if field.fence and fence is not None:
        ranges = np.minimum(ranges, fence)
    speed = speed_command(float(action[0]))
    limited, ranges = field.speed_and_ranges(speed, ranges)
    if limited != speed:
        action[0] = speed_action(limited)
    action[1] = field.heading_offset(ranges, float(action[1]) * MAX_HEADING_OFFSET) / MAX_HEADING_OFFSET
    return action


def with_repulsion(policy: Planner, field: RepulsiveField | None = None,
                   fence: Callable[[], np.ndarray] | None = None) -> Planner:
    """`policy` with the protection domain active: its heading action is bent away from near echoes.
    `fence()`: the map's edge per beam now (e.g. `map_fence(env)`), read by a field with `fence`."""
    field = field or RepulsiveField()

    inner = as_planner(policy)

    def act(time_step: dm_env.TimeStep) -> np.ndarray:
        edge = fence() if field.fence and fence is not None else None
        return protect(inner.act(time_step), time_step.observation["observation"], field, edge)

    return FunctionPlanner(act, inner.reset)


def map_fence(env) -> Callable[[], np.ndarray] | None:
    """`fence()` for `with_repulsion`: the map's edge per beam in `env` (a planning task's suite environment)
    at its current state; None for a task without a map."""
    task = getattr(env, "task", None)
    if not hasattr(task, "map_fence"):
        return None
    return lambda: task.map_fence(env.physics)
