"""One planning step over a batch axis: the action map, goals, events, rewards and the step's info, on arrays.

What a planning task does around the physics of a planner step is written once, on arrays whose leading axis is a
batch of episodes: `executor_command` (the action map below), `step_outcome` (goals, the passing rule, events, the
rewards of `auv_mj.tasks.planning_rewards`, the metrics, the privileged input) and, beside it,
`auv_mj.tasks.planning_observation.observe` (the observation). `PlanningTask` (`auv_mj.tasks.planning`) calls them
with N = 1 on its own episode, the batched env (`auv_mj.tasks.vector.AUVVectorEnv`) with N, so that a change to a
reward, an event or the observation is one edit. The records they read are here too: the task's episode state,
which it exports (`Episode`: the route, the command, goals reached, steps, the collision flag, the sonar), the model's
addresses (`Binding`), and their batch as padded arrays (`RouteBatch`) beside the vehicles' read-out (`Readout`).

One step is one planner decision, PLANNER_DT = 0.5 s (the sonar's 2 Hz). The action a in [-1, 1]^2 becomes the
executor's command (V_cmd, psi_cmd) by Table 3 and Table 1:

    V_cmd      = (a0 + 1)                                     Table 3's V in [-2, 2] m/s, forward only:
                                                              V in [0, 2] m/s (MIN_SPEED, MAX_SPEED)
    psi_target = psi + clip(90 deg * a1, -30 deg, 30 deg)     Table 3: heading in [-90, 90] deg, read as
                                                              relative to the current heading psi; Table 1:
                                                              at most pi/6 from the current heading
    psi_cmd   += clip(wrap_angle(psi_target - psi_cmd), -6, 6 deg)  Table 1: the heading command turns by at most
                                                              pi/30 per planner step
    psi_cmd    = psi + clip(wrap_angle(psi_cmd - psi), -30, 30 deg) keeps Table 1's pi/6 after a lagging turn

That is action="paper" (default). Its heading response is linear only for |a1| <= 6 / 90 (a band 2/15 wide): a1 is a
target 90 deg a1 from the heading, clipped to 30 deg, and the command moves at most 6 deg towards it, so nearly every
a1 is a full-rate turn. action="rate" (ours, issue 51) maps a1 onto the heading command's change itself,

    psi_cmd   += MAX_HEADING_CHANGE * a1                      linear over all of [-1, 1]: +-6 deg per step
    psi_cmd    = psi + clip(wrap_angle(psi_cmd - psi), -30, 30 deg) the executor's limit, Table 1's, as above

and a0 onto V_cmd as above (linear onto [0, 2] m/s). Both are `executor_command`, once for the batch.

Events (last_info["event"]): "collision" (a contact between the vehicle and any other geom, checked at
every executor tick), "left_map" (outside the arena's `arena_bounds`), "goal", "subgoal", or "".
Collisions, leaving the map and success end the episode (discount 0); the time limit truncates it
(discount 1). "safety_violation" is Table 1's d_{1-9} >= 5 m broken: a true sonar range below d_s.
"min_clearance" is the exact distance from the hull to the nearest other geom (`mj_geomDistance`,
capped at SONAR_RANGE), for metrics; so are "cross_track_error" (to the route's reference path, by
default the straight legs from the start through the goals) and the executor's tracking errors
"speed_error" (V_cmd - u) and "heading_error" (psi_cmd - psi). "tracked" marks the steps whose tracking
errors count in the metrics: on routes of several goals (paths, tunnels) only once the vehicle has reached
the first one, so that the drive to the path is left out, as the paper does for Tables 10-11.

Under observation="planner" or "planner-map" the step's info also holds "privileged" (PRIVILEGED_FIELDS: the route
length left on the true map, the true clearance, the time left, the cell) for a critic that the actor must not read
(`observe` never sees them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from auv_mj.arenas.arena import SAFETY_DISTANCE
from auv_mj.arenas.geodesic import distances
from auv_mj.arenas.sonar_memory import SonarMemory
from auv_mj.geometry import wrap_angle
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import planning_rewards as rewards
from auv_mj.tasks.routes import Route, RoutePotential, distances_to_polylines

PLANNER_DT = 0.5
"""Planner period [s]: one dm_env step, the 2 Hz of the sonar (Sec. 2.2)."""
MIN_SPEED, MAX_SPEED = 0.0, 2.0
"""V_cmd = MIN_SPEED + (a0 + 1) / 2 (MAX_SPEED - MIN_SPEED) [m/s]. Table 3 allows V down to -2 m/s, but the
nine sonars look forward (Fig. 3): a planner trained on `goal` with reverse allowed learned to run astern
at 2 m/s, blind, and rammed obstacles in 59 % of 100 random layouts. Forward-only keeps it looking ahead."""
ACTION_HEADING_RANGE = math.pi / 2
"""Heading offset of a1 = 1 [rad] (Table 3: [-90, 90] deg)."""
MAX_HEADING_DIFFERENCE = math.pi / 6
"""Largest difference between the commanded and the current heading [rad] (Table 1)."""
MAX_HEADING_CHANGE = math.pi / 30
"""Largest change of the heading command per planner step [rad] (Table 1: 6 deg)."""

ACTIONS = ("paper", "rate")
"""The action maps (module docstring): "paper", Table 3's heading offset; "rate", the heading command's change."""

PLANNER_OBSERVATIONS = ("planner", "planner-map")
"""The observations of the learning problem (issue 51, `auv_mj.tasks.planning_observation`): the planner's vector,
with or without the sonar map; under them the step's info holds the critic's privileged input."""

PASS_WINDOW = 5
"""How many sub-goals ahead of the current one the passing rule looks at."""

EVENTS = ("", "subgoal", "goal", "collision", "left_map")
"""Values of last_info["event"]."""

GOAL_DISTANCE_SCALE = 100.0
"""Distances a network reads are divided by this [m]: to the goal in the relative and planner observations
(`auv_mj.tasks.planning_observation`, capped at its GOAL_DISTANCE_CLIP) and along the route in the privileged input."""

PRIVILEGED_KINDS = ("goal", "waypoints", "obstacles", "moving_obstacles", "tunnel", "path")
"""The task kinds of the privileged input's cell (`PlanningTask.kind`)."""
PRIVILEGED_FIELDS = ("route_distance", "clearance", "time_left", "hard_tier", *(f"{k}_task" for k in PRIVILEGED_KINDS))
"""info["privileged"] under observation="planner": what a critic may know and the actor must not (issue 51;
an asymmetric critic, Pinto et al. 2018). route_distance: the route length left on the true static map
(`route_distance`) / GOAL_DISTANCE_SCALE; clearance: the hull's exact distance to the nearest geom / SONAR_RANGE
(info "min_clearance"); time_left: the planner steps left before the time limit after this observation * PLANNER_DT /
PRIVILEGED_TIME_SCALE; hard_tier: 1 on the hard tier; then the cell's task kind, one-hot over PRIVILEGED_KINDS."""
PRIVILEGED_TIME_SCALE = 600.0
"""Seconds that time_left is divided by (the goal task's time limit)."""

ONE_ROW = slice(0, 1)
"""The rows of a task's own batch of one episode (N = 1)."""
POTENTIAL_INFO_KEYS = ("step_goal", "route_distance_before", "route_distance")
"""The step's info also holds these where the episodes have a geodesic potential (`StepRules.potential`): the goal
current when the step began, and the route length left [m] before and after it (`route_distance`); and "privileged"
under observation="planner" (PRIVILEGED_FIELDS)."""
STEP_INFO_KEYS = ("previous_achieved_goal", "goal_independent_reward", "reward_following", "reward_avoid",
                  "reward_navigation", "paper_reward", "collision", "left_map", "safety_violation", "success",
                  "is_success", "min_clearance", "min_sonar_range", "event", "goals_reached", "num_goals",
                  "last_goal", "steps_left", "goal_radius", "cross_track_error", "command", "tracked", "speed_error",
                  "heading_error")
"""The keys of a step's info (`PlanningTask.last_info`, the module docstring's events and metrics)."""


def speed_command(a0: float) -> float:
    """V_cmd [m/s] of the speed action a0 in [-1, 1] (Table 3, forward only)."""
    return MIN_SPEED + 0.5 * (a0 + 1.0) * (MAX_SPEED - MIN_SPEED)


def speed_action(speed: float) -> float:
    """The speed action a0 commanding V_cmd = `speed` [m/s]: the inverse of `speed_command`."""
    return 2.0 * (speed - MIN_SPEED) / (MAX_SPEED - MIN_SPEED) - 1.0


@dataclass(frozen=True)
class Binding:
    """Addresses of a compiled model that a task reads every step (cached per model: a procedural tunnel
    recompiles it)."""

    qpos: np.ndarray
    """qpos addresses of the x, y and yaw joints."""
    qvel: np.ndarray
    """qvel addresses of the x, y and yaw joints."""
    hull: int
    """The HULL geom."""
    vehicle_body: int
    """The vehicle's body: a contact with any of its geoms is a collision."""
    others: np.ndarray
    """The geoms whose distance to the hull counts for the clearance (all but the vehicle's and planes)."""
    goal_site: int
    """The arena's `goal` site (-1 where it has none)."""
    sonar_site: int
    """The bow sonar's site (SONAR_SITE)."""
    sonar_offset: float
    """How far ahead of the vehicle's origin the sonars sit [m] (SONAR_SITE's x in the vehicle's frame)."""
    repulsion_range: float
    """d0 of Eq. (21)-(24) [m] (`repulsion_range`)."""


@dataclass
class Episode:
    """A planning task's episode state, the record it exports (`PlanningTask.episode`): the route and its derived
    geometry, which stay, and what each step advances (command, goals reached, steps, collision, sonar)."""

    route: Route
    """The layout drawn for the episode."""
    goals: np.ndarray
    """(n, 2) goals [m], the route's."""
    goal_headings: np.ndarray
    """(n,) the route's direction at each goal [rad] (the relative observation's desired heading)."""
    tangents: np.ndarray | None
    """(n - 1, 2) unit directions from each goal to the next, for the passing rule; None without a corridor."""
    path: np.ndarray
    """The reference polyline of the cross-track error [m]."""
    bounds: np.ndarray | None
    """The arena's `arena_bounds` (xmin, ymin, xmax, ymax) [m], None without."""
    mover_slots: np.ndarray
    """Each mover's mocap slot (`arena.mover_slots`)."""
    command: tuple[float, float]
    """The executor's command (V_cmd [m/s], psi_cmd [rad]) of the step in progress."""
    previous: np.ndarray
    """(x, y) [m] where the step in progress began (Eq. 23's previous distance)."""
    reached: int = 0
    """Goals reached (or passed) so far; the current goal is goals[min(reached, n - 1)]."""
    steps: int = 0
    """Planner steps taken."""
    collided: bool = False
    """Whether the vehicle has touched anything since the episode began (checked at every executor tick)."""
    sonar: np.ndarray | None = None
    """The nine ranges as perceived at the last planner step [m] (None before the first observation)."""
    terminal: bool = False
    """Whether the last step ended the episode (success, collision, left the map)."""
    reward: float = 0.0
    """The last step's reward."""
    potential: RoutePotential | None = None
    """The geodesic potential (reward="geodesic" or observation="planner"; None otherwise)."""
    distance: float = math.nan
    """The route length left [m] where the step in progress began (`route_distance`; NaN without a potential)."""
    action: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """The last step's action (a0, a1), as clipped to [-1, 1]; 0 before the first step (the planner observation)."""
    cell: np.ndarray = field(default_factory=lambda: np.zeros(1 + len(PRIVILEGED_KINDS)))
    memory: SonarMemory | None = None
    """The vehicle's own sonar map under observation="planner-map" (None otherwise): every ping goes in as it is
    sensed."""

    """The privileged input's cell: hard tier, then the task kind one-hot (PRIVILEGED_FIELDS)."""

    @property
    def goal_index(self) -> int:
        """Index in `goals` of the current goal (the last one once all are reached)."""
        return min(self.reached, len(self.goals) - 1)


@dataclass(frozen=True)
class StepRules:
    """The task options a planning step reads, the same for every episode of a batch."""

    reward_kind: str
    """One of REWARDS."""
    goal_radius: float
    """Radius of every goal [m]."""
    collision_penalty: float
    """Subtracted from "paper" and "progress" on a collision or on leaving the map."""
    relative: bool
    """The relative observation (RELATIVE_FIELDS), else the paper's (OBSERVATION_FIELDS)."""
    observation: str = "relative"
    """One of OBSERVATIONS."""
    action: str = "paper"
    """One of ACTIONS."""
    potential: bool = False
    """Whether the episodes have a geodesic potential (`RoutePotential`: reward="geodesic" or observation="planner"):
    the step's info then holds the route distances ("route_distance_before", "route_distance", "step_goal")."""


@dataclass
class RouteBatch:
    """The routes of N episodes as arrays padded along axis 1: what `step_outcome` and `observe` read."""

    goals: np.ndarray
    """(N, G, 2) [m]."""
    goal_cos_sin: np.ndarray
    """(N, G, 2) cos and sin of each goal's heading (`Episode.goal_headings`, by `math`)."""
    n_goals: np.ndarray
    """(N,) goals of each route."""
    tangents: np.ndarray
    """(N, G, 2) `Episode.tangents`."""
    corridor: np.ndarray
    """(N,) `Route.pass_corridor` [m], NaN where the passing rule is off."""
    path: np.ndarray
    """(N, P, 2) `Episode.path`, a short one padded with its last vertex."""
    bounds: np.ndarray
    """(N, 4) `Episode.bounds`."""
    has_bounds: np.ndarray
    """(N,) whether the arena has bounds."""
    repulsion: np.ndarray
    """(N,) d0 of Eq. (24) [m]."""
    fields: list
    """(N,) each row's `RoutePotential.fields` (None where the episode has no potential)."""
    leg: np.ndarray
    """(N, G) `RoutePotential.leg`."""
    rest: np.ndarray
    """(N, G) `RoutePotential.rest` [m]."""
    sonar_offset: np.ndarray
    """(N,) `Binding.sonar_offset` [m]."""
    cell: np.ndarray
    """(N, 1 + len(PRIVILEGED_KINDS)) `Episode.cell`."""

    @classmethod
    def empty(cls, n: int) -> RouteBatch:
        """N rows of one goal at the origin, to be filled by `put`."""
        return cls(goals=np.zeros((n, 1, 2)), goal_cos_sin=np.zeros((n, 1, 2)), n_goals=np.ones(n, dtype=int),
                   tangents=np.zeros((n, 1, 2)), corridor=np.full(n, np.nan), path=np.zeros((n, 2, 2)),
                   bounds=np.zeros((n, 4)), has_bounds=np.zeros(n, dtype=bool), repulsion=np.zeros(n),
                   fields=[None] * n, leg=np.zeros((n, 1), dtype=int), rest=np.zeros((n, 1)),
                   sonar_offset=np.zeros(n), cell=np.zeros((n, 1 + len(PRIVILEGED_KINDS))))

    @classmethod
    def of(cls, episode: Episode, repulsion_range: float, sonar_offset: float = 0.0) -> RouteBatch:
        """The batch of one episode (N = 1)."""
        batch = cls.empty(1)
        batch.put(0, episode, repulsion_range, sonar_offset)
        return batch

    def put(self, i: int, episode: Episode, repulsion_range: float, sonar_offset: float = 0.0) -> None:
        """Row i becomes `episode`'s route (the arrays grow when it has more goals or vertices); `sonar_offset`:
        `Binding.sonar_offset` [m] (the geofence of the planner observation)."""
        count = len(episode.goals)
        self.goals, self.goal_cos_sin, self.tangents = (_grown(a, count) for a in
                                                        (self.goals, self.goal_cos_sin, self.tangents))
        self.goals[i] = 0.0
        self.goals[i, :count] = episode.goals
        self.goal_cos_sin[i, :count] = [(math.cos(h), math.sin(h)) for h in episode.goal_headings]
        corridor = episode.route.pass_corridor
        if episode.tangents is not None:
            self.tangents[i, :count - 1] = episode.tangents
            self.corridor[i] = corridor
        else:
            self.corridor[i] = np.nan
        path = episode.path
        self.path = _grown(self.path, len(path))
        self.path[i, :len(path)] = path
        self.path[i, len(path):] = path[-1]
        self.n_goals[i] = count
        self.has_bounds[i] = episode.bounds is not None
        self.bounds[i] = episode.bounds if episode.bounds is not None else 0.0
        self.repulsion[i] = repulsion_range
        self.leg, self.rest = _grown(self.leg, count), _grown(self.rest, count)
        potential = episode.potential
        self.fields[i] = None if potential is None else potential.fields
        self.leg[i] = 0
        self.rest[i] = 0.0
        if potential is not None:
            self.leg[i, :count], self.rest[i, :count] = potential.leg, potential.rest
        self.sonar_offset[i] = sonar_offset
        self.cell[i] = episode.cell


def _grown(array: np.ndarray, length: int) -> np.ndarray:
    """`array` with its axis 1 grown to at least `length` (new entries zero)."""
    if array.shape[1] >= length:
        return array
    grown = np.zeros((array.shape[0], length, *array.shape[2:]), dtype=array.dtype)
    grown[:, :array.shape[1]] = array
    return grown


@dataclass(frozen=True)
class Readout:
    """What a planning step reads of N vehicles once the physics has run (arrays over the batch axis)."""

    position: np.ndarray
    """(N, 2) x, y [m]."""
    psi: np.ndarray
    """(N,) heading [rad]."""
    cos_psi: np.ndarray
    """(N,) cos psi, by libm (`math`, or the C batch), for the observation."""
    sin_psi: np.ndarray
    """(N,) sin psi, likewise."""
    velocity: np.ndarray
    """(N, 3) body velocity u, v [m/s], r [rad/s]."""
    sonar: np.ndarray
    """(N, 9) ranges as perceived (the ocean's noisy sonar) [m]: the observation and r_avoid."""
    true_ranges: np.ndarray | None = None
    """(N, 9) true ranges [m] (safety_violation, min_sonar_range); None for an observation alone."""
    collision: np.ndarray | None = None
    """(N,) whether the vehicle touched anything since the episode began."""
    clearance: np.ndarray | None = None
    """(N,) the hull's exact distance to the nearest other geom [m], capped at SONAR_RANGE."""


@dataclass(frozen=True)
class StepOutcome:
    """What `step_outcome` gives for N vehicles."""

    reward: np.ndarray
    """(N,) the step's reward of `StepRules.reward_kind`."""
    terminal: np.ndarray
    """(N,) success, a collision or leaving the map: the episode ends (discount 0)."""
    reached: np.ndarray
    """(N,) goals reached after the step."""
    info: dict[str, np.ndarray]
    """`PlanningTask.last_info`'s keys (STEP_INFO_KEYS), each an array over the batch."""


def executor_command(action: np.ndarray, psi: np.ndarray, heading_command: np.ndarray,
                     kind: str = "paper") -> np.ndarray:
    """The action map: the executor's commands (V_cmd, psi_cmd) (N, 2) of actions (N, 2) in [-1, 1], from the
    heading psi (N,) and the previous heading command (N,) (Table 3, Table 1; the module docstring). `kind` "paper"
    reads a1 as Table 3's heading offset; "rate" as the heading command's change, a1 MAX_HEADING_CHANGE."""
    action = np.asarray(action, dtype=float)
    if kind == "rate":
        turn = MAX_HEADING_CHANGE * action[:, 1]
    else:
        offset = np.minimum(np.maximum(ACTION_HEADING_RANGE * action[:, 1], -MAX_HEADING_DIFFERENCE),
                            MAX_HEADING_DIFFERENCE)
        turn = np.minimum(np.maximum(wrap_angle(psi + offset - heading_command), -MAX_HEADING_CHANGE),
                          MAX_HEADING_CHANGE)
    difference = np.minimum(np.maximum(wrap_angle(heading_command + turn - psi), -MAX_HEADING_DIFFERENCE),
                            MAX_HEADING_DIFFERENCE)
    return np.stack([speed_command(action[:, 0]), psi + difference], axis=1)


def step_outcome(routes: RouteBatch, rows: np.ndarray | slice, reached: np.ndarray, steps_left: np.ndarray,
                 previous: np.ndarray, readout: Readout, command: np.ndarray, rules: StepRules,
                 distance: np.ndarray | None = None) -> StepOutcome:
    """Goals, events and rewards of a planner step of the episodes `rows` of `routes` (the module docstring).

    `rows` indexes N rows of `routes` (an index array, or a slice), `reached` (N,) goals reached before the step,
    `steps_left` (N,) the success bonus's K (this step included), `previous` (N, 2) where the step began,
    `readout` the vehicles after it, `command` (N, 2) the step's command; with a potential, `distance` (N,) the route
    length left where the step began (the last step's info "route_distance"; computed where None).
    """
    goals, n = routes.goals[rows], routes.n_goals[rows]
    position, radius = readout.position, rules.goal_radius
    count = len(reached)
    line = np.arange(count)
    bounds = routes.bounds[rows]
    collision = np.asarray(readout.collision, dtype=bool)
    left_map = routes.has_bounds[rows] & ~np.all((bounds[:, :2] <= position) & (position <= bounds[:, 2:]), axis=1)
    failed = collision | left_map
    desired = goals[line, reached]
    now = goals_hit(goals, n, reached, position, radius)
    now = np.maximum(now, goals_passed(goals, n, now, position, routes.tangents[rows], routes.corridor[rows]))
    success = (now == n) & ~failed
    nearest, true_nearest = readout.sonar.min(axis=1), readout.true_ranges.min(axis=1)
    r_follow = rewards.following_reward(previous, position, desired, radius)
    r_avoid = np.where(failed, rewards.COLLISION_REWARD, rewards.avoid_reward(nearest, routes.repulsion[rows]))
    k1, k2, k3 = rewards.REWARD_WEIGHTS
    independent = k2 * r_avoid + k3 * rewards.NAVIGATION_REWARD - rules.collision_penalty * failed
    paper = k1 * r_follow + independent + np.where(success, rewards.success_bonus("paper", steps_left), 0.0)
    event = np.full(count, "", dtype=object)
    event[now > reached] = "subgoal"
    event[(now > reached) & (now == n)] = "goal"
    event[left_map] = "left_map"
    event[collision] = "collision"
    if rules.reward_kind == "paper":
        reward = paper
    elif rules.reward_kind == "progress":
        reward = (k1 * rewards.progress_reward(previous, position, desired, radius) + independent
                  + rewards.success_bonus("progress", steps_left) * success)
    elif rules.reward_kind == "suite":
        reward = rewards.suite_reward(goals, n, now, position, failed, success, steps_left, radius)
    if rules.potential:
        before = route_distance(routes, rows, reached, previous) if distance is None else distance
        after = np.where(success, 0.0, route_distance(routes, rows, now, position))
    if rules.reward_kind == "geodesic":
        reward = rewards.geodesic_reward(before, after, success, failed, rules.collision_penalty)
    info = {
        "previous_achieved_goal": previous,
        "goal_independent_reward": independent,
        "reward_following": r_follow,
        "reward_avoid": r_avoid,
        "reward_navigation": np.full(count, rewards.NAVIGATION_REWARD),
        "paper_reward": paper,
        "collision": collision,
        "left_map": left_map,
        "safety_violation": true_nearest < SAFETY_DISTANCE,
        "success": success,
        "is_success": success,
        "min_clearance": readout.clearance,
        "min_sonar_range": true_nearest,
        "event": event,
        "goals_reached": now,
        "num_goals": n,
        "last_goal": reached == n - 1,
        "steps_left": steps_left,
        "goal_radius": np.full(count, radius),
        "cross_track_error": distances_to_polylines(position, routes.path[rows]),
        "command": command,
        "tracked": (n == 1) | (now >= 1),
        "speed_error": command[:, 0] - readout.velocity[:, 0],
        "heading_error": wrap_angle(command[:, 1] - readout.psi),
    }
    if rules.potential:
        info.update({"step_goal": desired, "route_distance_before": before, "route_distance": after})
    if rules.observation in PLANNER_OBSERVATIONS:
        info["privileged"] = privileged(routes, rows, after, readout.clearance, steps_left - 1)
    return StepOutcome(reward=reward, terminal=failed | (now == n), reached=now, info=info)


def goals_hit(goals: np.ndarray, n: np.ndarray, reached: np.ndarray, position: np.ndarray,
              radius: float) -> np.ndarray:
    """Goals reached after reaching any of them: one past the last goal (not before `reached`) within `radius`
    of `position`, which kills every goal before it; `reached` where none is (Sec. 3.2.4)."""
    distance = np.hypot(goals[..., 0] - position[:, None, 0], goals[..., 1] - position[:, None, 1])
    slots = np.arange(goals.shape[1])
    hit = (slots >= reached[:, None]) & (slots < n[:, None]) & (distance <= radius)
    last = goals.shape[1] - 1 - np.argmax(hit[:, ::-1], axis=1)
    return np.where(hit.any(axis=1), last + 1, reached)


def goals_passed(goals: np.ndarray, n: np.ndarray, reached: np.ndarray, position: np.ndarray, tangents: np.ndarray,
                 corridor: np.ndarray) -> np.ndarray:
    """The passing rule: how many goals are behind the vehicle, of those PASS_WINDOW from the current one but the
    last -- ahead of a goal along the route, within `corridor` across it (0 where none is, or NaN corridor)."""
    if np.all(np.isnan(corridor)):
        return np.zeros(len(n), dtype=int)
    line = np.arange(len(n))[:, None]
    slots = reached[:, None] + np.arange(PASS_WINDOW)
    at = np.minimum(slots, goals.shape[1] - 1)
    offset = position[:, None, :] - goals[line, at]
    tangent = tangents[line, at]
    along = offset[..., 0] * tangent[..., 0] + offset[..., 1] * tangent[..., 1]
    across = offset[..., 0] * tangent[..., 1] - offset[..., 1] * tangent[..., 0]
    passed = (slots < np.minimum(reached + PASS_WINDOW, n - 1)[:, None]) & (along > 0) \
        & (np.abs(across) < corridor[:, None])
    last = PASS_WINDOW - 1 - np.argmax(passed[:, ::-1], axis=1)
    return np.where(passed.any(axis=1), reached + last + 1, 0)


def route_distance(routes: RouteBatch, rows: np.ndarray | slice, goal_index: np.ndarray,
                   points: np.ndarray) -> np.ndarray:
    """The route length left [m] of N vehicles at `points` (N, 2) with goal `goal_index` (N,) current (clipped to the
    last), rows `rows` of `routes`: the current leg's geodesic distance plus the legs after it (`RoutePotential`)."""
    line = np.arange(len(goal_index))
    at = np.minimum(goal_index, routes.n_goals[rows] - 1)
    legs = routes.leg[rows][line, at]
    rows_of = np.arange(len(routes.fields))[rows]
    fields = [routes.fields[row][leg] for row, leg in zip(rows_of.tolist(), legs.tolist(), strict=True)]
    return distances(fields, points) + routes.rest[rows][line, at]


def privileged(routes: RouteBatch, rows: np.ndarray | slice, distance: np.ndarray, clearance: np.ndarray,
               steps_left: np.ndarray) -> np.ndarray:
    """info["privileged"] (N, len(PRIVILEGED_FIELDS)) of N vehicles: the route length left [m], the true clearance
    [m], the planner steps left after this observation, and the episode's cell (PRIVILEGED_FIELDS). For a critic:
    never in the actor's observation."""
    return np.concatenate([np.stack([np.asarray(distance, dtype=float) / GOAL_DISTANCE_SCALE,
                                     np.asarray(clearance, dtype=float) / SONAR_RANGE,
                                     np.asarray(steps_left, dtype=float) * PLANNER_DT / PRIVILEGED_TIME_SCALE], axis=1),
                           routes.cell[rows]], axis=1)


def info_row(info: Mapping[str, np.ndarray], k: int) -> dict:
    """Row k of a batch's step info as a single step's `last_info`: numbers as Python scalars, the command as a
    tuple, points as arrays."""
    row = {}
    for key, value in info.items():
        if value.ndim > 1:
            row[key] = value[k].copy()
        else:
            row[key] = value[k] if value.dtype == object else value.tolist()[k]
    row["command"] = tuple(info["command"][k].tolist())
    return row
