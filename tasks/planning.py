"""The planning layer of Sec. 3.2 as dm_control tasks: the shared Task, Physics and rewards.

One dm_env step is one planner decision, PLANNER_DT = 0.5 s (the sonar's 2 Hz). The action
a in [-1, 1]^2 becomes the executor's command (V_cmd, psi_cmd) by Table 3 and Table 1:

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

Observations. observation="relative" (default, RELATIVE_FIELDS): the current goal in the body frame, the motion, the
command and the sonar; "paper" (OBSERVATION_FIELDS): Table 2's vector beside the absolute `desired_goal`; "planner"
(ours, issue 51, PLANNER_FIELDS): what the classical planners read (docs/planners.md) -- the route target ROUTE_HORIZON
ahead (`route_target_index`, the rule `map-replan` and `bug` aim by), the pose across the map, the previous action,
the motion, the command, the geofence and the sonar. With it the step's info also holds "privileged"
(PRIVILEGED_FIELDS: the route length left on the true map, the true clearance, the time left, the cell) for a critic
that the actor must not read (`observe` never sees them).

The executor (`executor(command, state)`, default the S-plane controller of Eq. 32) turns the command into
(tau_u, tau_r) every EXECUTOR_DT = 0.1 s on the full dynamics. The task's `Physics` calls it between
physics steps, so `control.Environment` still owns the 50 physics steps of a planner step and the time
limit; moving obstacles are moved on the same 10 Hz tick.

One step over a batch axis. What the task does around the physics is written once, on arrays whose leading axis
is a batch of episodes: `executor_command` (the action map above), `step_outcome` (goals, the passing rule, events,
the rewards below, the metrics) and `observe` (the observation). `PlanningTask` calls them with N = 1 on its own
episode, the batched env (`auv_mj.tasks.vector.AUVVectorEnv`) with N, so that a change to a reward, an event or the
observation is one edit. The task's episode state is a record it exports, `PlanningTask.episode` (`Episode`: the
route, the command, goals reached, steps, the collision flag, the sonar), beside the model's addresses
(`PlanningTask.binding`); the batched env reads these, not the task's internals.

Goals. Every task is a sequence of goals g_0..g_n (Sec. 3.2.4): `desired_goal` is the current one, and
reaching it (within the task's goal radius) makes the next one current; reaching a later one kills every
goal before it. Reaching the last is success. GOAL_RADIUS = 12.5 m is the 25 m target area of Tables 6-8
(goal, waypoints, obstacles, moving_obstacles); SUBGOAL_RADIUS = 2 m is Table 1's L_target <= 2 m for the
virtual sub-goals of a global path (tunnel, path_line, path_curve), spaced SUBGOAL_SPACING apart. On a
global path (routes with `pass_corridor`) a sub-goal other than the last also dies once the vehicle is
past it (ahead of it along the path, within PASS_CORRIDOR across it), with no +4: a vehicle that went
around an obstacle on the path goes on rather than turning back.

Rewards. reward="paper" is Eq. (26), r = K1 r_following + K2 r_avoid + K3 r_navigation, with
- r_following (Eq. 23) against the goal that was current when the step began: +4 if reached, else +0.5
  if the step ended closer to it, -0.5 if farther, 0 if neither;
- r_avoid (Eq. 24) from the nearest sonar echo d (what the vehicle perceives, Sec. 3.2.2): -1 if
  d <= d_s = 5 m (Table 1) or on a collision or leaving the map, -k (1/d - 1/d0) if d < d0, else 0, with
  k = 0.1, d0 = delta max(L1, L2), L1 = delta B, L2 = delta L (Eq. 21), delta = 3 and the hull's L, B
  (d0 = 11.97 m). Eq. (24)'s ellipse with semi-axes L1, L2 (4 m at most) lies inside d_s, so its
  graded term is read on the disc d < d0 that Sec. 3.2.2 calls the protection field's reach;
- r_navigation = -0.05 (Eq. 25).
reward="suite" (default) is in [0, 1] on every other step: (goals reached + tolerance(distance to the current
goal)) / number of goals, 0 on a collision or leaving the map.
reward="progress" is PROGRESS_GAIN per metre gained on the current goal in place of Eq. (23)'s +-0.5, the rest
as "paper".
reward="geodesic" (ours, issue 51; "The geodesic reward" below) is potential-based shaping on the route length left on
the arena's true static map, with a success bonus and a collision penalty; its optimum is the goal by the shortest
safe route at GEODESIC_DISCOUNT, the discount a learner of it must use. The paper's rewards stay for reproducing it.

The success bonus (ours, not the paper's). Success ends the episode, so per-step rewards that can be positive
paid waiting: driving towards the goal and stopping just outside it returned a mean of 847 on `goal` (seeds
0-2, "suite"; issue 45) against 93 for reaching it; under "paper", moving 1 m away and back in three 0.3 m steps
nets +0.8 every four steps. So the step that ends the episode in success also pays STEP_REWARD_BOUND[kind] for each
of the K steps left in the episode, itself included (`success_bonus`; K from `PlanningTask.step_limit`):
"suite" pays K in all, what staying in the goal would have earned had the episode gone on (dm_control's suite
does not end on success); "paper" pays Eq. (26)'s terms + 0.45 K; "progress" needs none. Proof that stepping
into the goal beats every continuation from the same state that does not end in success (waiting, idling,
oscillating, failing), at every discount gamma in [0, 1]: such a continuation lasts at most K steps, gamma^k
<= 1, and
- "suite": each of its steps pays < 1 (not all goals reached, or 0 on a failure): it returns < K;
- "paper": each pays at most STEP_REWARD_BOUND = k1 0.5 + k3 (-0.05) = 0.45 (r_avoid <= 0; no goal is left to
  pay +4), but a last step that enters the goal while colliding, which pays at most the success step's Eq. (26)
  terms, themselves at least SUCCESS_TERMS_FLOOR = k1 4 - k2 - k3 0.05 = 2.95 > 0: it returns at most
  0.45 (K - 1) + max(0.45, terms) < terms + 0.45 K, the success step;
- "progress": for distances d_0 (now), d_1, ..., d_m to the goal, all but d_0 outside its radius, summation by
  parts gives sum_k gamma^k (d_k - d_{k+1}) = d_0 - (1 - gamma) sum_{k=1}^{m-1} gamma^(k-1) d_k
  - gamma^(m-1) d_m < d_0 - radius, and its other terms are <= 0: it returns < PROGRESS_GAIN (d_0 - radius),
  while the success step pays at least that + SUCCESS_TERMS_FLOOR. (A collision inside the goal area may
  gain up to PROGRESS_GAIN times the one step's travel deeper in; it is not waiting.)
At gamma = 1 the bonus also makes each step before success cost STEP_REWARD_BOUND - r_t >= 0 ("suite",
"paper"), so sooner is better. The bound compares continuations of one state: no shaping makes a route that
first turns away from the goal worth more than idling at gamma = 0.9, whose ~10-step horizon ends long before a
goal 100 m away. Sub-goals of a route keep Eq. (23)'s +4 and no bonus; under "suite" every step after a sub-goal
already pays more than any step before it. `compute_reward` pays the "paper" bonus where the relabelled goal is
reached on a step of the route's last leg (info "last_goal"; `compute_terminated` ends a relabelled episode
there) or where the route succeeded by reaching its last goal while an earlier one was current (info
"success"), with K = info "steps_left": it equals the step's reward.

The geodesic reward (ours, issue 51). Straight-line progress ("progress", and "paper"'s +-0.5) pays the way into a
trap: a cup's mouth faces the goal, and in a tunnel the sub-goals lie on the axis, which runs into each trap's
mouth; every metre of the way round is paid negatively. Here the potential is Phi(s) = -PROGRESS_GAIN D(s), D the
route length left: at reset the arena's static footprints (`auv_mj.episode.arena_geometry`, movers left out) are
searched once for the geodesic distance to each goal (`auv_mj.arenas.geodesic`: Dijkstra on a 2 m grid keeping
HARD_CLEARANCE, or the exact straight distance where the arena has no footprints), and while goal k is current
D = d_k(position) + the legs after goal k (`RoutePotential`; `PlanningTask.geodesic_legs`: a tunnel's potential runs
to its end alone, its field following the tunnel, so no sub-goal pays; waypoints, path_line and path_curve run through
every goal in turn, their goals being the task; goal, obstacles and moving_obstacles have one goal). A step pays

    r = gamma Phi(s') - Phi(s) - c + B [success] - (C + collision_penalty) [collision or left the map]
      = PROGRESS_GAIN (D - gamma D') - c + ...,   gamma = GEODESIC_DISCOUNT, c = GEODESIC_STEP_COST (Eq. 25's 0.05),
                                                  B = GEODESIC_SUCCESS_BONUS, C = GEODESIC_COLLISION_PENALTY,

with D' = 0 on success (inside the last goal's region) and D' where the vehicle is on a failure. Ng et al. (1999):
F = gamma Phi(s') - Phi(s) changes no policy's ranking when the potential of the absorbing state is 0; here a
failure's is kept, which is the same shaping of a base reward whose failure penalty is C + gamma PROGRESS_GAIN D'
>= C: it only lowers failures. Summed over an episode of T steps the shaping telescopes, so with
W = c / (1 - gamma) = GEODESIC_HORIZON_COST, G = PROGRESS_GAIN and D_0 the route length at the start:
- success at step T returns G D_0 + gamma^(T-1) B - W (1 - gamma^T), which falls as T grows: sooner is better;
- waiting until a time limit T returns G D_0 - gamma^T G D_T - W (1 - gamma^T) < the success at any earlier step
  (and, bootstrapped for ever, G D_0 - W, still less);
- a failure at step T returns G D_0 - gamma^(T-1) (gamma G D_T + C) - W (1 - gamma^T), less than waiting for ever
  since C >= W, so no crash, at any time and any place, returns more than reaching the goal at any time.
B >= 0 and C >= W are all the proof needs; B = C = W (25) make success and failure weigh alike. The positive part of
a step, G (1 - gamma) D', pays for being far from the goal, but it is the potential's own: it telescopes away. At the
time limit an episode is truncated (discount 1), and a learner bootstraps V(s'), as the telescoped sum assumes.
tests/tasks/test_learning_problem.py checks this on whole episodes of certified trap arenas, both tiers, tunnels
included.
`compute_reward` recomputes the step's reward exactly for the step's own goal (info "step_goal",
"route_distance_before", "route_distance"); for a relabelled goal it has no field of that goal (a search per sample),
so it shapes on the straight distance to the goal's region, the geodesic of open water, and pays B where the goal is
reached without a failure (`compute_terminated` ends a relabelled episode there).

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

Conditions. `conditions="ideal"` (default) is the paper's world; "ocean" or a mapping of effects
(`auv_mj.sim.ocean`) adds a current (moved on at every executor tick), lagged actuators (`Physics.load` compiles
them), a noisy, delayed sonar with dropouts (what the observation and r_avoid see; the metrics
"safety_violation" and "min_sonar_range" keep the true ranges) and a vehicle scaled per episode that the
executor does not know about. The ocean's seed is drawn from the task's RandomState after the route, so a
seed gives the same layout in both.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import rewards
from dm_env import specs

from auv_mj.arenas import arena, arena_check, tubes
from auv_mj.arenas.arena import SAFETY_DISTANCE
from auv_mj.arenas.geodesic import Field, distances, field_of_arena
from auv_mj.control.clock import ExecutorClock
from auv_mj.control.splane import EXECUTOR_DT, SPlaneController
from auv_mj.episode import arena_geometry
from auv_mj.geometry import wrap_angle
from auv_mj.sim import ocean
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.sonar import BEAM_ANGLES, SONAR_NAMES, SONAR_RANGE, fence_ranges
from auv_mj.tasks import options
from auv_mj.tasks.actions import checked_action

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
TARGET_SPEED = 1.0
"""Target velocity of every experiment [m/s] (Tables 6-8, 12); sizes the time limits."""
GEODESIC_DISCOUNT = 0.998
"""The discount gamma of reward="geodesic" (ours, issue 51), the one a learner of it must use: its shaping term is
gamma Phi(s') - Phi(s) with this gamma, and its collision penalty is sized by it (module docstring, "The geodesic
reward"). 1 / (1 - gamma) = 500 planner steps, 500 m at the top speed: longer than a hard-tier detour (100-300 m) and
than an average episode (about 370 steps)."""

GOAL_RADIUS = 12.5
"""Radius of a target area [m]: Tables 6-8's target area diameter of 25 m."""
SUBGOAL_RADIUS = 2.0
"""Radius of a virtual sub-goal on a global path [m] (Table 1: L_target <= 2 m)."""
MAX_GOAL_RADIUS = 50.0
"""Largest `goal_radius` a task accepts [m]: four target areas; beyond it a start can count as the goal."""
SUBGOAL_SPACING = 10.0
"""Largest distance between consecutive virtual sub-goals of a discretised path [m]."""
PASS_CORRIDOR = 15.0
"""A path sub-goal (not the last) also dies once the vehicle is past it, within this distance of it
across the path [m]: it need not turn back to a sub-goal it went around (an obstacle on the path)."""
PASS_WINDOW = 5
"""How many sub-goals ahead of the current one the passing rule looks at."""

AVOID_GAIN = 0.1
"""k of Eq. (24)."""
INFLATION = 3.0
"""delta of Eq. (21)-(24)."""
FOLLOW_CLOSER, FOLLOW_FARTHER, FOLLOW_REACHED = 0.5, -0.5, 4.0
"""r_following of Eq. (23): closer to, farther from, or at the goal."""
PROGRESS_DEADBAND = 0.25
"""|d_{t+1} - d_t| [m] below which a step is neither closer nor farther (Eq. 23's "0 other conditions").
Half a planner step at the 1 m/s target speed: without it, creeping towards the goal at any speed earns
+0.5 a step forever, worth 0.45 / (1 - gamma) = 4.5 at Table 4's gamma = 0.9, more than reaching the goal."""
COLLISION_REWARD = -1.0
"""r_avoid inside d_s, on a collision and on leaving the map (Eq. 24)."""
NAVIGATION_REWARD = -0.05
"""r_navigation per planner step (Eq. 25)."""
MAX_COLLISION_PENALTY = 1000.0
"""Largest `collision_penalty` (a whole route's progress reward is at most a few hundred)."""
REWARD_WEIGHTS = (1.0, 1.0, 1.0)
"""(k1, k2, k3) of Eq. (26); the paper leaves them open, and equal weights keep its term sizes."""
SUITE_REWARD_MARGIN = 100.0
"""Distance [m] beyond the goal radius at which the suite reward's tolerance falls to 0.1."""
STEP_REWARD_BOUND = {"suite": 1.0,
                     "paper": REWARD_WEIGHTS[0] * FOLLOW_CLOSER + REWARD_WEIGHTS[2] * NAVIGATION_REWARD,
                     "progress": 0.0, "geodesic": 0.0}
"""The success bonus per step left (ours, module docstring): the most a step of the route's last leg that does not
end in success can pay ("suite" 1, "paper" 0.45); "progress" needs none, its per-metre term telescopes; "geodesic"
pays a constant GEODESIC_SUCCESS_BONUS instead (module docstring, "The geodesic reward")."""
SUCCESS_TERMS_FLOOR = REWARD_WEIGHTS[0] * FOLLOW_REACHED + REWARD_WEIGHTS[1] * COLLISION_REWARD \
    + REWARD_WEIGHTS[2] * NAVIGATION_REWARD
"""The least Eq. (26)'s terms of a success step can pay, beside "progress"'s per-metre term (2.95): > 0, so that
"paper" and "progress" reward reaching the goal over any continuation that does not (module docstring)."""

GEODESIC_STEP_COST = -NAVIGATION_REWARD
"""reward="geodesic": the cost of every planner step (Eq. 25's 0.05)."""
GEODESIC_HORIZON_COST = GEODESIC_STEP_COST / (1.0 - GEODESIC_DISCOUNT)
"""What the step cost sums to over an endless episode at GEODESIC_DISCOUNT (25): the most any continuation can lose
to it, waiting for ever included."""
GEODESIC_COLLISION_PENALTY = GEODESIC_HORIZON_COST
"""reward="geodesic": paid on a collision or on leaving the map (25), beside the `collision_penalty` option: at least
GEODESIC_HORIZON_COST, so that ending the episode in a failure never returns more than waiting for ever does."""
GEODESIC_SUCCESS_BONUS = GEODESIC_HORIZON_COST
"""reward="geodesic": paid on success (25). Any bonus >= 0 makes success beat every other ending (module docstring);
this one is the step costs that success saves, so reaching the goal is worth as much as a crash costs."""

MAP_BOUNDS = (0.0, 0.0, 600.0, 600.0)
"""The 600 m x 600 m map of Sec. 4.1 (xmin, ymin, xmax, ymax) [m]."""
POSITION_SCALE = 600.0
"""Positions in the observation vector are divided by this [m]."""
MAP_MARGIN = 25.0
"""Random starts and goals keep this far inside the map [m]."""
GOAL_DISTANCE_RANGE = (100.0, 400.0)
"""A random goal is this far from the random start [m]."""

OBSERVATION_FIELDS = ("x", "y", "cos_psi", "sin_psi", "u", "v", "r", "heading_command", "speed_command",
                      *SONAR_NAMES)
"""The paper's "observation" vector (observation="paper", Table 2): x, y / POSITION_SCALE; cos, sin psi;
u, v / MAX_SPEED; r [rad/s]; wrap_angle(psi_cmd - psi) / MAX_HEADING_DIFFERENCE; V_cmd / MAX_SPEED; the nine
sonar ranges / SONAR_RANGE. A policy reads it with the absolute `desired_goal` beside it."""
RELATIVE_FIELDS = ("goal_distance", "cos_goal_bearing", "sin_goal_bearing", "u", "v", "r", "heading_command",
                   "speed_command", *SONAR_NAMES)
"""The "relative" observation (the default): what the vehicle could know of itself and its goal, nothing tied
to map coordinates -- the distance to the current goal / GOAL_DISTANCE_SCALE (at most GOAL_DISTANCE_CLIP),
the goal's bearing in the body frame (cos, sin), then u, v, r, the command and the sonar as in the paper's
vector. The goal is inside the observation, so a policy reads this vector alone (`goal_in_observation`)."""
FENCE_NAMES = tuple(f"fence_{k + 1}" for k in range(len(BEAM_ANGLES)))
"""The map's edge as each sonar beam would read it were it a wall (the geofence, `map_fence`), S1..S9's directions."""
PLANNER_FIELDS = ("target_distance", "cos_target_bearing", "sin_target_bearing", "map_x", "map_y", "cos_psi",
                  "sin_psi", "previous_speed_action", "previous_heading_action", "u", "v", "r", "heading_command",
                  "speed_command", *FENCE_NAMES, *SONAR_NAMES)
"""The "planner" observation (issue 51): what the classical planners read (docs/planners.md), for a learner that must
beat them. target_distance, cos and sin of target_bearing: the route target, the goal or on a route of many goals the
route point ROUTE_HORIZON on (`route_target_index`, the one rule `map-replan` and `bug` aim by), as the relative
observation gives its goal (distance / GOAL_DISTANCE_SCALE capped at GOAL_DISTANCE_CLIP, body-frame bearing); map_x,
map_y: the position across the arena's `arena_bounds`, each in [-1, 1] (x / POSITION_SCALE where an arena has none),
and cos, sin psi -- the pose the planners place their map by (`env.physics.pose()`), in the map's own frame, which the
route target and the geofence are measured in too; the previous action (a0, a1) (0 before the first step); u, v, r,
the heading and speed commands as in the paper's vector; fence_1..fence_9: the geofence / SONAR_RANGE (`map_fence`,
what the planners' protection domain adds to the echoes); then the nine sonar ranges / SONAR_RANGE (last, as in
every observation: SONAR_SLICE). No goal coordinates: `desired_goal` is for rewards and relabelling only."""
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
OBSERVATIONS = ("relative", "paper", "planner")
GOAL_DISTANCE_SCALE = 100.0
"""Distances to the goal in the relative observation are divided by this [m]..."""
GOAL_DISTANCE_CLIP = 5.0
"""... and capped here (500 m): far goals differ only in bearing."""
SONAR_SLICE = slice(-len(SONAR_NAMES), None)
"""The nine sonar ranges / SONAR_RANGE end both observation vectors."""
REWARDS = ("suite", "paper", "progress", "geodesic")
ACTIONS = ("paper", "rate")
POLICY_OPTIONS = ("action", "observation")
"""The task options that shape what a policy reads and does: a policy trained with them runs with them (the batched
envs report theirs as `policy_options`, a PPO checkpoint keeps them, the zoo applies them)."""


def policy_options(task_kwargs: Mapping) -> dict:
    """The POLICY_OPTIONS given in `task_kwargs`."""
    return {name: task_kwargs[name] for name in POLICY_OPTIONS if name in task_kwargs}
"""The action maps (module docstring): "paper", Table 3's heading offset; "rate", the heading command's change."""
ROUTE_HORIZON = 80.0
"""On a route of many goals a planner aims at the route point this far [m] along it from the current goal
(`route_target_index`: `map-replan`'s and `bug`'s target, and the planner observation's)."""
PROGRESS_GAIN = 0.5
"""reward="progress": reward per metre of distance gained on the current goal (a 1 m/s step earns Eq. 23's
+0.5). Its sum over an episode depends only on where the vehicle started and ended, not on how slowly it
went, so that Eq. (25)'s per-step cost makes reaching the goal sooner worth more; Eq. (23)'s +0.5 per
step closer instead pays for dawdling."""
EVENTS = ("", "subgoal", "goal", "collision", "left_map")
"""Values of last_info["event"]."""
HULL = "hull"
"""The vehicle geom whose length and beam are L and B of Eq. (21)."""
SONAR_SITE = "sonar_site_5"
"""The site of the bow sonar S5 in the vehicle's MJCF, where the map's edge is measured from (`map_fence`)."""


# --- rewards ------------------------------------------------------------------------------------------


def goal_distance(a, b) -> np.ndarray:
    """Distance [m] between (x, y) points along the last axis, elementwise over leading axes."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def following_reward(previous_achieved, achieved, desired, radius: float) -> np.ndarray:
    """r_following of Eq. (23) for a step from `previous_achieved` to `achieved`, vectorised over goals."""
    before = goal_distance(previous_achieved, desired)
    after = goal_distance(achieved, desired)
    return np.where(after <= radius, FOLLOW_REACHED,
                    np.where(after < before - PROGRESS_DEADBAND, FOLLOW_CLOSER,
                             np.where(after > before + PROGRESS_DEADBAND, FOLLOW_FARTHER, 0.0)))


def progress_reward(previous_achieved, achieved, desired, radius) -> np.ndarray:
    """reward="progress": PROGRESS_GAIN per metre gained on `desired`, +4 (Eq. 23) on reaching it; vectorised."""
    before = goal_distance(previous_achieved, desired)
    after = goal_distance(achieved, desired)
    return PROGRESS_GAIN * (before - after) + np.where(after <= radius, FOLLOW_REACHED, 0.0)


def geodesic_reward(before, after, success, failed, collision_penalty=0.0) -> np.ndarray:
    """reward="geodesic" (module docstring) of steps whose route length left went from `before` to `after` [m] (0 on
    success), elementwise: PROGRESS_GAIN (before - GEODESIC_DISCOUNT after), which is gamma Phi(s') - Phi(s) for
    Phi = -PROGRESS_GAIN d (Ng et al. 1999), less the step cost, with the success bonus and the collision penalty."""
    shaping = PROGRESS_GAIN * (np.asarray(before, dtype=float) - GEODESIC_DISCOUNT * np.asarray(after, dtype=float))
    return (shaping - GEODESIC_STEP_COST + np.where(success, GEODESIC_SUCCESS_BONUS, 0.0)
            - np.where(failed, GEODESIC_COLLISION_PENALTY + collision_penalty, 0.0))


def success_bonus(kind: str, steps_left) -> np.ndarray:
    """Ours (module docstring): what a step that ends the episode in success pays under reward `kind` beside its
    own terms ("paper", "progress") or in all ("suite"), with `steps_left` steps left, itself included."""
    return STEP_REWARD_BOUND[kind] * np.asarray(steps_left, dtype=float)


def relative_goal(achieved_goal, desired_goal) -> np.ndarray:
    """The goal features of the relative observation from the pose (x, y, cos psi, sin psi) and the goal:
    (distance / GOAL_DISTANCE_SCALE capped at GOAL_DISTANCE_CLIP, cos and sin of the body-frame bearing)."""
    achieved, desired = np.asarray(achieved_goal, dtype=float), np.asarray(desired_goal, dtype=float)
    dx, dy = desired[..., 0] - achieved[..., 0], desired[..., 1] - achieved[..., 1]
    c, s = achieved[..., 2], achieved[..., 3]
    forward, left = c * dx + s * dy, -s * dx + c * dy
    distance = np.hypot(forward, left)
    safe = np.where(distance > 1e-9, distance, 1.0)
    return np.stack([np.minimum(distance / GOAL_DISTANCE_SCALE, GOAL_DISTANCE_CLIP),
                     np.where(distance > 1e-9, forward / safe, 1.0), np.where(distance > 1e-9, left / safe, 0.0)],
                    axis=-1)


def avoid_reward(nearest_echo, repulsion_range) -> np.ndarray:
    """r_avoid of Eq. (24) for the nearest sonar echo [m] and d0 = `repulsion_range` [m], elementwise."""
    nearest, reach = np.asarray(nearest_echo, dtype=float), np.asarray(repulsion_range, dtype=float)
    with np.errstate(divide="ignore"):
        graded = -AVOID_GAIN * (1.0 / nearest - 1.0 / reach)
    return np.where(nearest <= SAFETY_DISTANCE, COLLISION_REWARD, np.where(nearest < reach, graded, 0.0))


def repulsion_range(physics: AUVPhysics) -> float:
    """d0 = delta max(L1, L2) with L1 = delta B, L2 = delta L (Eq. 21-22), from the hull capsule [m]."""
    radius, half_length = physics.named.model.geom_size[HULL][:2]
    length, beam = 2 * (half_length + radius), 2 * radius
    return INFLATION * max(INFLATION * beam, INFLATION * length)


def info_field(info, key: str) -> np.ndarray:
    """`info[key]` as an array from a dict of arrays, or stacked from a sequence / array of step dicts.

    A missing key is a ValueError that says where the info came from: Stable-Baselines3's HerReplayBuffer
    passes empty info dicts unless it is built with `copy_info_dict=True`, and Eq. (23)'s reward needs the
    previous position the step's info carries.
    """
    try:
        if isinstance(info, Mapping):
            return np.asarray(info[key])
        steps = np.asarray(info, dtype=object)
        values = np.array([step[key] for step in steps.ravel()])
    except KeyError:
        raise ValueError(f"compute_reward/compute_terminated need info[{key!r}], which the step's info holds; "
                         "with Stable-Baselines3's HerReplayBuffer pass replay_buffer_kwargs="
                         "{'copy_info_dict': True} so that infos are stored") from None
    return values.reshape(steps.shape + values.shape[1:])


# --- geometry helpers ---------------------------------------------------------------------------------


def speed_command(a0: float) -> float:
    """V_cmd [m/s] of the speed action a0 in [-1, 1] (Table 3, forward only)."""
    return MIN_SPEED + 0.5 * (a0 + 1.0) * (MAX_SPEED - MIN_SPEED)


def speed_action(speed: float) -> float:
    """The speed action a0 commanding V_cmd = `speed` [m/s]: the inverse of `speed_command`."""
    return 2.0 * (speed - MIN_SPEED) / (MAX_SPEED - MIN_SPEED) - 1.0


def discretise(polyline: np.ndarray, spacing: float = SUBGOAL_SPACING) -> np.ndarray:
    """Points along `polyline` (its vertices kept) no more than `spacing` apart: the virtual sub-goals."""
    polyline = np.asarray(polyline, dtype=float).reshape(-1, 2)
    points = [polyline[:1]]
    for a, b in zip(polyline[:-1], polyline[1:], strict=True):
        pieces = max(1, math.ceil(np.hypot(*(b - a)) / spacing - 1e-9))
        points.append(a + (b - a) * (np.arange(1, pieces + 1)[:, None] / pieces))
    return np.concatenate(points)


def path_length(polyline: np.ndarray) -> float:
    """Length of a polyline [m]."""
    return float(np.sum(np.hypot(*np.diff(np.asarray(polyline, dtype=float), axis=0).T)))


def distance_to_polyline(point: np.ndarray, polyline: np.ndarray) -> float:
    """Shortest distance from `point` to the polyline [m] (the cross-track error)."""
    point, polyline = np.asarray(point, dtype=float), np.asarray(polyline, dtype=float)
    return float(distances_to_polylines(point[None], polyline[None])[0])


def distances_to_polylines(points: np.ndarray, polylines: np.ndarray) -> np.ndarray:
    """`distance_to_polyline` of N points (N, 2) to N polylines (N, P, 2) of as many vertices (a shorter one
    padded with its last vertex: a zero-length segment changes no distance)."""
    a, b = polylines[:, :-1], polylines[:, 1:]
    d = b - a
    point = points[:, None, :]
    pa = point - a
    dot = pa[..., 0] * d[..., 0] + pa[..., 1] * d[..., 1]
    length = np.maximum(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1], 1e-12)
    closest = a + np.clip(dot / length, 0, 1)[..., None] * d
    return np.min(np.hypot(closest[..., 0] - point[..., 0], closest[..., 1] - point[..., 1]), axis=1)


def random_point(random: np.random.RandomState, bounds: Sequence[float], margin: float = MAP_MARGIN,
                 avoid: np.ndarray | None = None, min_distance: float = 0.0,
                 max_distance: float = math.inf, tries: int = 1000) -> np.ndarray:
    """A uniform point `margin` inside `bounds`, `min_distance`..`max_distance` from `avoid` if given."""
    low = np.array(bounds[:2], dtype=float) + margin
    high = np.array(bounds[2:], dtype=float) - margin
    for _ in range(tries):
        point = random.uniform(low, high)
        if avoid is None or min_distance <= np.hypot(*(point - avoid)) <= max_distance:
            return point
    raise ValueError(f"no point {min_distance}..{max_distance} m from {avoid} inside {bounds} "
                     f"(margin {margin})")


def random_start_and_goal(random: np.random.RandomState,
                          bounds: Sequence[float]) -> tuple[np.ndarray, float, np.ndarray]:
    """A random start, heading and goal (GOAL_DISTANCE_RANGE apart) inside `bounds`."""
    start = random_point(random, bounds)
    goal = random_point(random, bounds, avoid=start, min_distance=GOAL_DISTANCE_RANGE[0],
                        max_distance=GOAL_DISTANCE_RANGE[1])
    return start, random.uniform(-math.pi, math.pi), goal


def heading_to(start: np.ndarray, target: np.ndarray) -> float:
    """The heading [rad] from `start` towards `target`."""
    return math.atan2(target[1] - start[1], target[0] - start[0])


# --- arenas and physics -------------------------------------------------------------------------------


def open_water_arena(bounds: Sequence[float] = MAP_BOUNDS) -> ET.Element:
    """An empty map: `arena_bounds` and a `goal` site (the target area, moved to each episode's goal)."""
    root = ET.Element("mujoco")
    ET.SubElement(ET.SubElement(root, "custom"), "numeric", name="arena_bounds",
                  data=" ".join(f"{b:g}" for b in bounds))
    worldbody = ET.SubElement(root, "worldbody")
    ET.SubElement(worldbody, "site", name="goal", type="cylinder", size=f"{GOAL_RADIUS:g} 0.05",
                  rgba="1 0.9 0 0.3")
    return root


class Physics(ExecutorClock, AUVPhysics):
    """AUVPhysics with the executor layer's clock (`auv_mj.control.clock.ExecutorClock`): `set_tick(callback)` calls the
    low-level controller every EXECUTOR_DT while it steps; the callback sets the controls and moves the obstacles.
    """

    TICK_PERIOD = EXECUTOR_DT

    @classmethod
    def load(cls, arena_source: str | Path | ET.Element | None, conditions=None) -> Physics:
        """The vehicle in `arena_source` (an arena MJCF path or ElementTree root; see `auv_mj.arenas.arena`), compiled
        for the task option `conditions` (`auv_mj.sim.ocean.conditions`: lagged actuators where they ask for it)."""
        xml, source = arena.compose_xml(arena_source, thruster_lag=ocean.conditions(conditions).thruster_lag)
        return cls.from_xml_string(xml, source=source)


def environment(physics: Physics, task: PlanningTask, time_limit: float,
                environment_kwargs: dict | None = None) -> control.Environment:
    """The `control.Environment` of a planning task: one step per PLANNER_DT, `time_limit` seconds.

    The options every planning factory shares (time_limit, environment_kwargs) are checked here, and the task
    learns the time limit's steps (`PlanningTask.step_limit`, for the success bonus).
    """
    time_limit = options.time_limit(time_limit)
    environment_kwargs = options.environment_kwargs(environment_kwargs)
    check_timestep(physics, PLANNER_DT, EXECUTOR_DT)
    task.time_limit_steps = episode_steps(physics, time_limit)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=PLANNER_DT,
                               **environment_kwargs)


def episode_steps(physics: AUVPhysics, time_limit: float) -> int:
    """Planner steps in an episode of `time_limit` seconds, counted as `control.Environment` counts them (it ends
    an episode at the first step count >= time_limit / (timestep * physics steps per planner step))."""
    return math.ceil(time_limit / (physics.timestep() * control.compute_n_steps(PLANNER_DT, physics.timestep())))


def check_timestep(physics: AUVPhysics, *periods: float) -> None:
    """ValueError naming the model unless each period [s] is a whole number of its physics timesteps."""
    for period in periods:
        try:
            control.compute_n_steps(period, physics.timestep())
        except ValueError:
            raise ValueError(f"{physics.source}: the timestep {physics.timestep():g} s must divide the "
                             f"{period:g} s control period into whole steps") from None


def load_arena(source: str | Path | ET.Element, need_path: bool, conditions=None) -> Physics:
    """Physics of the vehicle in an arena file or element, refused unless `auv-mj check-arena` finds it usable.

    The arena is checked once where it enters a task, by `arena_check.require_usable` (cached by content). A tube
    arena (`auv-mj tunnel --tube`) is the 6-DOF vehicle's and is refused naming the file and the task that flies it.
    """
    source = options.arena_source(source)
    if tubes.is_tube_arena(source):
        name = "the arena element" if isinstance(source, ET.Element) else str(source)
        raise ValueError(f"{name}: a tube arena (`auv-mj tunnel --tube`) is for the 6-DOF vehicle: fly it with "
                         "--task tunnel3d; the planar tasks take arenas from `auv-mj tunnel` (without --tube) or "
                         "`auv-mj arena`")
    arena_check.require_usable(source, need_path)
    return Physics.load(source, conditions)


def route_time_limit(length: float) -> float:
    """A time limit [s] for a route of `length` m: twice its time at TARGET_SPEED plus a minute, in 10 s."""
    return 10.0 * math.ceil((2.0 * length / TARGET_SPEED + 60.0) / 10.0)


ARENA_SCENARIO = "arena"
"""The scenario (or layout) of an open-water task run on a user's arena (`arena=PATH`): its sites, walls,
obstacles and movers instead of a random or a named layout."""
RANDOM_ARENA = "random"
"""`arena="random"`, the `--arena random` of every command: the task's own random layouts."""


def arena_scenario(arena_option, choice: str, value: str, default: str = "random") -> str:
    """The scenario an open-water task runs with its `arena` option and its `choice` option (scenario or layout)
    set to `value`: ARENA_SCENARIO for an arena file or element, which may not come with another `choice`; `value`
    for None or "random" (read as `choice`="random")."""
    if arena_option is None:
        if value == ARENA_SCENARIO:
            raise ValueError(f"{choice}={ARENA_SCENARIO!r} is set by arena=PATH (an arena MJCF file); give the arena")
        return value
    if isinstance(arena_option, str) and arena_option == RANDOM_ARENA:
        if value != default:
            raise ValueError(f"arena='random' draws a {default} {choice}; it cannot go with {choice}={value!r}")
        return default
    options.arena_source(arena_option)
    if value not in (default, ARENA_SCENARIO):
        raise ValueError(f"arena={arena_option!r:.80} and {choice}={value!r} conflict: a user's arena gives the "
                         f"start, the goal and the obstacles itself; leave {choice} out")
    return ARENA_SCENARIO


def arena_route(info: arena.ArenaInfo, radius: float, waypoints: bool = False) -> Route:
    """A user's open-water arena as a route (`docs/arenas.md`): from its `start` site on that site's heading to
    its `goal` site, past its movers on their paths. With `waypoints` its `path_*` sites, in order, are targets
    before the goal (those within `radius` of the start are not: `path_0` is usually the start itself)."""
    goals = info.goal[None]
    if waypoints and len(info.path):
        targets = info.path[goal_distance(info.path, info.start) > radius]
        if len(targets) and goal_distance(targets[-1], info.goal) <= 1e-6:
            targets = targets[:-1]
        goals = np.vstack([targets, goals])
    return Route(start=info.start, heading=info.start_heading, goals=goals, movers=info.movers)


def open_water_physics(arena_option, conditions, default: ET.Element) -> tuple[Physics, bool]:
    """The physics of an open-water task and whether it is a user's arena: `arena_option` (a file or element,
    refused unless `auv-mj check-arena --no-path` finds it usable) or the task's own `default` arena."""
    if arena_option is None or (isinstance(arena_option, str) and arena_option == RANDOM_ARENA):
        return Physics.load(default, conditions), False
    return load_arena(arena_option, need_path=False, conditions=conditions), True


def arena_time_limit(time_limit: float | None, default: float, physics: Physics, user_arena: bool) -> float:
    """An open-water task's time limit [s]: `time_limit` if given; on a user's arena the longer of `default`
    and `route_time_limit` of the straight legs from its start through its path sites to its goal."""
    if time_limit is not None:
        return time_limit
    if not user_arena:
        return default
    info = arena.arena_info(physics)
    return max(default, route_time_limit(path_length(np.vstack([info.start, info.path.reshape(-1, 2),
                                                                    info.goal]))))


# --- the task -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Route:
    """One episode's layout: start pose, goal sequence, reference path and moving obstacles."""

    start: np.ndarray
    """(x, y) [m]; the vehicle starts at rest."""
    heading: float
    """Initial heading psi [rad]."""
    goals: np.ndarray
    """(n, 2) goals in the order they must be reached [m]; the last is the episode's goal."""
    path: np.ndarray | None = None
    """Reference polyline for the cross-track error [m]; None: from the start through the goals."""
    movers: tuple[arena.Mover, ...] = ()
    """Moving obstacles (mocap bodies of the arena) and their paths."""
    pass_corridor: float | None = None
    """If set, goals but the last also die when passed within this distance across the route [m]."""


GEODESIC_LEGS = ("each", "last")
"""What the geodesic potential runs to (`PlanningTask.geodesic_legs`): "each" goal of the route in turn (target areas,
a path to follow), or the "last" alone (a tunnel: its sub-goals lie on the axis, which runs into each trap's mouth)."""


@dataclass(frozen=True)
class RoutePotential:
    """The potential of reward="geodesic" on one episode's route: while goal k is current, the route length left is
    fields[leg[k]].distance(position) + rest[k] [m] (module docstring, "The geodesic reward")."""

    fields: tuple[Field, ...]
    """The geodesic field of each leg's goal on the arena's true static map (`auv_mj.arenas.geodesic`)."""
    leg: np.ndarray
    """(n,) the field in use while goal k is current."""
    rest: np.ndarray
    """(n,) the route's length [m] beyond that field's goal: the legs after it, each from one goal to the next."""


def route_potential(physics: AUVPhysics, task: PlanningTask, legs: str = "each") -> RoutePotential:
    """The geodesic potential of `task`'s episode (call it once the episode's route is drawn): fields over the arena's
    static footprints (`auv_mj.episode.arena_geometry`; movers are left out), within `arena_bounds`, or the box round
    the start and goals grown by SONAR_RANGE where the arena has none, to each goal (`legs`="each") or the last."""
    episode = task.episode
    # The route has just placed the obstacles (mocap bodies of a random layout): bring the geoms' poses up to date
    # before reading their footprints (positions only; the reset's mj_forward follows, so no state changes).
    mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
    geometry = arena_geometry(physics, task)
    static = [polygon for polygon, owner in zip(geometry.polygons, geometry.owners, strict=True) if owner == -1]
    goals = episode.goals
    if episode.bounds is not None:
        bounds = np.asarray(episode.bounds, dtype=float)
    else:
        points = np.vstack([episode.route.start, goals])
        bounds = np.concatenate([points.min(axis=0) - SONAR_RANGE, points.max(axis=0) + SONAR_RANGE])
    count = len(goals)
    if options.choice("geodesic_legs", legs, GEODESIC_LEGS) == "last" or count == 1:
        field = field_of_arena(static, bounds, goals[-1], task.goal_radius)
        return RoutePotential((field,), np.zeros(count, dtype=int), np.zeros(count))
    fields = tuple(field_of_arena(static, bounds, goal, task.goal_radius) for goal in goals)
    legs_after = [float(fields[k + 1].distance(goals[k])[0]) for k in range(count - 1)]
    rest = np.concatenate([np.cumsum(legs_after[::-1])[::-1], [0.0]])
    return RoutePotential(fields, np.arange(count), rest)


def mover_states(physics, task) -> np.ndarray:
    """The movers of a planning task's episode now, (M, 5): x, y, radius [m] (the footprint's reach from the mover's
    centre), vx, vy [m/s] (their true velocity, from their paths): privileged, for the teacher."""
    movers = tuple(getattr(task.episode.route, "movers", ()) or ())
    if not movers:
        return np.zeros((0, 5))
    radii = _mover_radii(physics, task, movers)
    now, dt = float(physics.data.time), 0.1
    rows = []
    for mover, radius in zip(movers, radii, strict=True):
        here = mover.position(now)
        rows.append([*here, radius, *((mover.position(now + dt) - here) / dt)])
    return np.array(rows, dtype=float)


_MOVER_RADII: dict[int, tuple[object, np.ndarray]] = {}


def _mover_radii(physics, task, movers) -> np.ndarray:
    """Each mover's footprint reach [m] from its centre, once per episode (cached on the episode record)."""
    key = id(task.episode)
    cached = _MOVER_RADII.get(key)
    if cached is not None and cached[0] is task.episode:
        return cached[1]
    geometry = arena_geometry(physics, task)
    now = float(physics.data.time)
    radii = np.zeros(len(movers))
    for polygon, owner in zip(geometry.polygons, geometry.owners, strict=True):
        if owner >= 0:
            centre = movers[owner].position(now)
            radii[owner] = max(radii[owner], float(np.max(np.hypot(*(polygon - centre).T))))
    if len(_MOVER_RADII) > 4096:
        _MOVER_RADII.clear()
    _MOVER_RADII[key] = (task.episode, radii)
    return radii


# --- one planning step over a batch axis ----------------------------------------------------------------
# What the task does around the physics of a planner step -- the action map, goals, the passing rule, events,
# Eq. (23)-(26), the suite and progress rewards, the observation -- written once, on arrays whose leading axis is
# the batch: `PlanningTask` calls it with N = 1, `auv_mj.tasks.vector.AUVVectorEnv` with N.


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
    r_follow = following_reward(previous, position, desired, radius)
    r_avoid = np.where(failed, COLLISION_REWARD, avoid_reward(nearest, routes.repulsion[rows]))
    k1, k2, k3 = REWARD_WEIGHTS
    independent = k2 * r_avoid + k3 * NAVIGATION_REWARD - rules.collision_penalty * failed
    paper = k1 * r_follow + independent + np.where(success, success_bonus("paper", steps_left), 0.0)
    event = np.full(count, "", dtype=object)
    event[now > reached] = "subgoal"
    event[(now > reached) & (now == n)] = "goal"
    event[left_map] = "left_map"
    event[collision] = "collision"
    if rules.reward_kind == "paper":
        reward = paper
    elif rules.reward_kind == "progress":
        reward = (k1 * progress_reward(previous, position, desired, radius) + independent
                  + success_bonus("progress", steps_left) * success)
    elif rules.reward_kind == "suite":
        reward = suite_reward(goals, n, now, position, failed, success, steps_left, radius)
    if rules.potential:
        before = route_distance(routes, rows, reached, previous) if distance is None else distance
        after = np.where(success, 0.0, route_distance(routes, rows, now, position))
    if rules.reward_kind == "geodesic":
        reward = geodesic_reward(before, after, success, failed, rules.collision_penalty)
    info = {
        "previous_achieved_goal": previous,
        "goal_independent_reward": independent,
        "reward_following": r_follow,
        "reward_avoid": r_avoid,
        "reward_navigation": np.full(count, NAVIGATION_REWARD),
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
    if rules.observation == "planner":
        info["privileged"] = privileged(routes, rows, after, readout.clearance, steps_left - 1)
    return StepOutcome(reward=reward, terminal=failed | (now == n), reached=now, info=info)


def route_target_index(goals: np.ndarray, n: np.ndarray, index: np.ndarray) -> np.ndarray:
    """The route target of N routes (goals (N, G, 2), n (N,) goals each, `index` (N,) the current goal's): the first
    goal after the current one that lies ROUTE_HORIZON or more along the route from it, else the last; the goal itself
    on a route of one. What `map-replan` and `bug` aim at (`auv_mj.planners.map_planner.route_target`) and the planner
    observation shows. The route's length is summed leg by leg from the current goal, in order."""
    goals = np.asarray(goals, dtype=float)
    n, index = np.asarray(n, dtype=int), np.asarray(index, dtype=int)
    if goals.shape[1] < 2:
        return n - 1
    legs = np.hypot(goals[:, 1:, 0] - goals[:, :-1, 0], goals[:, 1:, 1] - goals[:, :-1, 1])
    slot = np.arange(legs.shape[1])
    use = (slot >= index[:, None]) & (slot < n[:, None] - 1)
    walked = np.cumsum(np.where(use, legs, 0.0), axis=1)
    far = use & (walked >= ROUTE_HORIZON)
    return np.where(far.any(axis=1), np.argmax(far, axis=1) + 1, n - 1)


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


def suite_reward(goals: np.ndarray, n: np.ndarray, reached: np.ndarray, position: np.ndarray, failed: np.ndarray,
                 success: np.ndarray, steps_left: np.ndarray, radius: float) -> np.ndarray:
    """reward="suite": 0 on a failure, the success bonus (module docstring) on success, else (goals reached +
    tolerance(distance to the current goal)) / goals, in [0, 1)."""
    goal = goals[np.arange(len(n)), np.minimum(reached, n - 1)]
    distance = np.hypot(goal[:, 0] - position[:, 0], goal[:, 1] - position[:, 1])
    near = rewards.tolerance(distance, bounds=(0.0, radius), margin=SUITE_REWARD_MARGIN, sigmoid="long_tail",
                             value_at_margin=0.1)
    return np.where(failed, 0.0, np.where(success, success_bonus("suite", steps_left), (reached + near) / n))


def observe(routes: RouteBatch, rows: np.ndarray | slice, reached: np.ndarray, readout: Readout, command: np.ndarray,
            kind: str | bool, action: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """`PlanningTask.get_observation` of N vehicles, rows `rows` of `routes`: "observation" (of `kind`: "relative"
    RELATIVE_FIELDS, "paper" OBSERVATION_FIELDS, "planner" PLANNER_FIELDS, which reads `action` (N, 2), the last
    step's; True and False stand for "relative" and "paper"), "achieved_goal" and "desired_goal", each (N, k)."""
    if isinstance(kind, bool | np.bool_):
        kind = "relative" if kind else "paper"
    relative = kind in ("relative", "planner")
    psi, (u, v, r) = readout.psi, readout.velocity.T
    motion = np.stack([u / MAX_SPEED, v / MAX_SPEED, r, wrap_angle(command[:, 1] - psi) / MAX_HEADING_DIFFERENCE,
                       command[:, 0] / MAX_SPEED], axis=1)
    at = np.minimum(reached, routes.n_goals[rows] - 1)
    line = np.arange(len(reached))
    goal = routes.goals[rows][line, at]
    x, y = readout.position[:, 0], readout.position[:, 1]
    c, s = readout.cos_psi, readout.sin_psi
    sonar = readout.sonar / SONAR_RANGE
    if relative:
        achieved = np.stack([x, y, c, s], axis=1)
        desired = np.concatenate([goal, routes.goal_cos_sin[rows][line, at]], axis=1)
        if kind == "planner":
            head, fence = planner_inputs(routes, rows, at, readout, action)
            vector = np.concatenate([head, motion, fence, sonar], axis=1)
        else:
            vector = np.concatenate([relative_goal(achieved, desired), motion, sonar], axis=1)
    else:
        achieved, desired = np.stack([x, y], axis=1), goal
        vector = np.concatenate([np.stack([x / POSITION_SCALE, y / POSITION_SCALE, c, s], axis=1), motion, sonar],
                                axis=1)
    return {"observation": vector, "achieved_goal": achieved, "desired_goal": desired}


def planner_inputs(routes: RouteBatch, rows: np.ndarray | slice, at: np.ndarray, readout: Readout,
                   action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The planner observation's entries but the motion and sonar blocks (PLANNER_FIELDS): the route target, the pose
    and the previous action (N, 9); and the geofence / SONAR_RANGE (N, 9). Rows `rows` of `routes`, goal `at` (N,)
    current."""
    goals, n = routes.goals[rows], routes.n_goals[rows]
    line = np.arange(len(at))
    target = goals[line, route_target_index(goals, n, at)]
    x, y = readout.position[:, 0], readout.position[:, 1]
    c, s = readout.cos_psi, readout.sin_psi
    pose = np.stack([x, y, c, s], axis=1)
    bounds, has_bounds = routes.bounds[rows], routes.has_bounds[rows]
    span = np.where(has_bounds[:, None], bounds[:, 2:] - bounds[:, :2], 1.0)
    across = 2.0 * (readout.position - bounds[:, :2]) / span - 1.0
    across = np.where(has_bounds[:, None], across, readout.position / POSITION_SCALE)
    offset = routes.sonar_offset[rows]
    origins = readout.position + offset[:, None] * np.stack([c, s], axis=1)
    fence = np.where(has_bounds[:, None], fence_ranges(origins, readout.psi, bounds), SONAR_RANGE)
    head = np.concatenate([relative_goal(pose, target), across, np.stack([c, s], axis=1),
                           np.asarray(action, dtype=float).reshape(len(at), 2)], axis=1)
    return head, fence / SONAR_RANGE


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


class PlanningTask(base.Task):
    """A planner task: action (V, heading offset) -> executor -> dynamics; goals, events, rewards.

    Subclasses implement `route(physics, info) -> Route` (and may move obstacles there); everything else,
    including `compute_reward` / `compute_terminated` for hindsight relabelling, lives here. A step is the batch
    functions (`executor_command`, `step_outcome`, `observe`) at N = 1 on `episode`.
    """

    geodesic_legs = "each"
    """What the geodesic potential runs to (GEODESIC_LEGS): each goal in turn; a tunnel's runs to its end alone."""
    kind = "goal"
    """The task's kind among PRIVILEGED_KINDS (the privileged input's cell)."""

    def __init__(self, executor: Callable | str | None = None, reward: str = "suite",
                 goal_radius: float = GOAL_RADIUS, observation: str = "relative", random=None,
                 conditions="ideal", collision_penalty: float = 0.0, action: str = "paper"):
        """`executor(command, state) -> (tau_u, tau_r)` (default `SPlaneController()`), or its name
        (`auv_mj.tasks.executors.executor_names()`, or a speed_heading checkpoint path); `reward` one of
        REWARDS; `observation` "relative" (RELATIVE_FIELDS, the default) or "paper" (OBSERVATION_FIELDS);
        `conditions`: "ideal", "ocean" or a mapping of ocean effects (`auv_mj.sim.ocean.conditions`);
        `collision_penalty`: subtracted from the "paper" and "progress" rewards on a collision or on leaving
        the map, beside Eq. 24's -1 (ours, 0 by default: the paper's reward), in [0, MAX_COLLISION_PENALTY] (under
        reward="geodesic", beside GEODESIC_COLLISION_PENALTY); `action` one of ACTIONS: "paper" (Table 3's heading
        offset, the default) or "rate" (the heading command's change per step, module docstring); `observation` may
        also be "planner" (PLANNER_FIELDS, with info["privileged"] for a critic)."""
        self.reward_kind = options.choice("reward", reward, REWARDS)
        self.action_kind = options.choice("action", action, ACTIONS)
        self.observation_kind = options.choice("observation", observation, OBSERVATIONS)
        if isinstance(executor, str):
            from auv_mj.tasks.executors import named_executor  # the learned ones load torch: only when named

            executor = named_executor(executor)
        executor = options.function("executor", executor, "executor(command, state) -> (tau_u, tau_r)")
        self.goal_radius = options.number("goal_radius", goal_radius, 0.0, MAX_GOAL_RADIUS, "m", low_open=True)
        self.collision_penalty = options.number("collision_penalty", collision_penalty, 0.0, MAX_COLLISION_PENALTY)
        super().__init__(random=options.seed(random))
        self.executor = SPlaneController() if executor is None else executor
        self.ocean = ocean.Ocean(conditions)
        self.last_info: dict = {}
        self.time_limit_steps: int | None = None
        """Planner steps of the environment's time limit, set by `environment` (None: not known)."""
        self.episode: Episode | None = None
        """The episode's state (`Episode`), set by `initialize_episode`: what the batched env reads of it."""
        self.binding: Binding | None = None
        """The model's addresses (`Binding`), set with the first episode of a model."""
        self._model_ptr = None
        self._routes: RouteBatch | None = None

    # --- subclass API -------------------------------------------------------------------------------

    def route(self, physics: Physics, info: arena.ArenaInfo) -> Route:
        """The episode's start, goals, path and movers, drawn from `self.random` where random."""
        raise NotImplementedError

    # --- episode ------------------------------------------------------------------------------------

    def _bind(self, physics: Physics) -> None:
        """Caches model addresses (once per model)."""
        model = physics.model.ptr
        if self._model_ptr is model:
            return
        self._model_ptr = model
        hull = model.geom(HULL).id
        vehicle_body = int(model.geom_bodyid[hull])
        vehicle_geoms = model.geom_bodyid == vehicle_body
        self.binding = Binding(
            qpos=np.array([model.jnt_qposadr[model.joint(n).id] for n in ("x", "y", "yaw")]),
            qvel=np.array([model.jnt_dofadr[model.joint(n).id] for n in ("x", "y", "yaw")]),
            hull=hull, vehicle_body=vehicle_body,
            others=np.flatnonzero(~vehicle_geoms & (model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)),
            goal_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "goal"),
            sonar_site=model.site(SONAR_SITE).id, sonar_offset=float(model.site(SONAR_SITE).pos[0]),
            repulsion_range=repulsion_range(physics))

    def initialize_episode(self, physics: Physics) -> None:
        """Draws the route, places the vehicle at rest and the movers at t = 0, resets the executor."""
        self._bind(physics)
        info = arena.arena_info(physics)
        route = self.route(physics, info)
        goals = np.asarray(route.goals, dtype=float).reshape(-1, 2)
        if len(goals) == 0:
            raise ValueError("a route needs at least one goal")
        legs = np.diff(np.vstack([route.start, goals]), axis=0)
        tangents = None
        if route.pass_corridor is not None and len(goals) > 1:
            tangents = np.diff(goals, axis=0)
            tangents = tangents / np.hypot(tangents[:, :1], tangents[:, 1:])
        binding = self.binding
        data = physics.data.ptr
        data.qpos[binding.qpos] = (route.start[0], route.start[1], route.heading)
        data.qvel[binding.qvel] = 0.0
        data.ctrl[:] = 0.0
        if binding.goal_site >= 0:
            physics.model.ptr.site_pos[binding.goal_site][:2] = goals[-1]
        slots = arena.mover_slots(physics, route.movers)
        arena.move_movers(physics, route.movers, 0.0, slots)
        reset = getattr(self.executor, "reset", None)
        if reset is not None:
            reset()
        self.episode = Episode(
            route=route, goals=goals, goal_headings=np.arctan2(legs[:, 1], legs[:, 0]), tangents=tangents,
            path=np.vstack([route.start, goals]) if route.path is None else np.asarray(route.path, float),
            bounds=info.bounds, mover_slots=slots, command=(0.0, float(route.heading)),
            previous=np.array(route.start, dtype=float))
        if self.rules.potential:
            self.episode.potential = route_potential(physics, self, self.geodesic_legs)
            self.episode.distance = float(self.episode.potential.fields[0].distance(route.start)[0]
                                          + self.episode.potential.rest[0])
        self.episode.cell = np.array([float(getattr(self, "tier", "standard") == "hard"),
                                      *(float(self.kind == k) for k in PRIVILEGED_KINDS)])
        self._routes = RouteBatch.of(self.episode, binding.repulsion_range, binding.sonar_offset)
        self.last_info = {}
        physics.set_tick(self._tick, EXECUTOR_DT)
        self.ocean.start(physics, self.random, len(SONAR_NAMES))

    def _tick(self, physics: Physics) -> None:
        """The executor's 10 Hz tick: controls from the command, movers moved, contacts checked."""
        data = physics.data.ptr
        episode = self.episode
        self.ocean.tick(physics)
        psi = data.qpos[self.binding.qpos[2]]
        u, v, r = physics.hydrodynamics.body_velocity(data)
        data.ctrl[:] = self.executor(episode.command, (u, v, r, psi))
        if episode.route.movers:
            arena.move_movers(physics, episode.route.movers, data.time, episode.mover_slots)
        if data.ncon and not episode.collided:
            episode.collided = self._vehicle_contact(physics)

    def _vehicle_contact(self, physics: Physics) -> bool:
        data = physics.data.ptr
        bodies = physics.model.ptr.geom_bodyid[data.contact.geom[:data.ncon]]
        return bool(np.any(bodies == self.binding.vehicle_body))

    def before_step(self, action, physics: Physics) -> None:
        """Turns the action into the executor's command (V_cmd, psi_cmd) (`executor_command`, N = 1)."""
        a0, a1 = checked_action(action, self.action_spec(physics), self)
        data, qpos, episode = physics.data.ptr, self.binding.qpos, self.episode
        command = executor_command(np.array([[a0, a1]], dtype=float), data.qpos[qpos[2:]],
                                   np.array([episode.command[1]]), self.action_kind)
        episode.action = np.array([a0, a1], dtype=float)
        episode.command = (float(command[0, 0]), float(command[0, 1]))
        episode.previous = data.qpos[qpos[:2]].copy()

    def after_step(self, physics: Physics) -> None:
        """Senses, then `step_outcome` (N = 1): events, goals, the step's reward and `last_info`."""
        data, episode = physics.data.ptr, self.episode
        true_ranges = physics.sonar()
        episode.sonar = self.ocean.sense(true_ranges)
        episode.collided = episode.collided or (data.ncon > 0 and self._vehicle_contact(physics))
        episode.steps += 1
        readout = self._readout(physics, true_ranges=np.asarray(true_ranges, dtype=float)[None],
                                collision=np.array([episode.collided]), clearance=np.array([self._clearance(physics)]))
        steps_left = max(self.step_limit - episode.steps + 1, 1)
        outcome = step_outcome(self._routes, ONE_ROW, np.array([episode.reached]),
                               np.array([steps_left]), episode.previous[None], readout,
                               np.array([episode.command]), self.rules, np.array([episode.distance]))
        episode.reached = int(outcome.reached[0])
        episode.terminal = bool(outcome.terminal[0])
        episode.reward = float(outcome.reward[0])
        self.last_info = info_row(outcome.info, 0)
        if "route_distance" in outcome.info:
            episode.distance = float(outcome.info["route_distance"][0])

    def _readout(self, physics: Physics, **after_step) -> Readout:
        """The vehicle as `step_outcome` and `observe` read it (N = 1): cos and sin of the heading by `math`, as
        the C batch takes them from libm."""
        data = physics.data.ptr
        pose = data.qpos[self.binding.qpos]
        psi = float(pose[2])
        return Readout(position=pose[None, :2], psi=pose[2:], cos_psi=np.array([math.cos(psi)]),
                       sin_psi=np.array([math.sin(psi)]),
                       velocity=np.asarray(physics.hydrodynamics.body_velocity(data), dtype=float)[None],
                       sonar=self.episode.sonar[None], **after_step)

    @property
    def rules(self) -> StepRules:
        """The options `step_outcome` and `observe` read."""
        return StepRules(reward_kind=self.reward_kind, goal_radius=self.goal_radius,
                         collision_penalty=self.collision_penalty, relative=self.goal_in_observation,
                         observation=self.observation_kind, action=self.action_kind,
                         potential=self.reward_kind == "geodesic" or self.observation_kind == "planner")

    @property
    def episode_time_limit(self) -> float | None:
        """The episode's own time limit [s] where it has one shorter than the environment's (None: none)."""
        return None

    @property
    def _command(self) -> tuple[float, float]:
        """`episode.command`, under the name tests written before the record set it by."""
        return self.episode.command

    @_command.setter
    def _command(self, command: tuple[float, float]) -> None:
        self.episode.command = command

    @property
    def _route(self) -> Route:
        """`episode.route`, under the name tests written before the record read it by."""
        return self.episode.route

    def _clearance(self, physics: Physics) -> float:
        """Exact distance [m] from the hull to the nearest other geom, capped at SONAR_RANGE."""
        model, data = physics.model.ptr, physics.data.ptr
        others, hull = self.binding.others, self.binding.hull
        if others.size == 0:
            return SONAR_RANGE
        gap = (np.linalg.norm(data.geom_xpos[others] - data.geom_xpos[hull], axis=1)
               - model.geom_rbound[others] - model.geom_rbound[hull])
        best = SONAR_RANGE
        for geom in others[gap < best]:
            best = min(best, mujoco.mj_geomDistance(model, data, hull, int(geom), best, None))
        return float(best)

    # --- dm_control Task API ------------------------------------------------------------------------

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        """(a0, a1) in [-1, 1]^2: speed and heading offset (see the module docstring)."""
        return specs.BoundedArray((2,), float, -np.ones(2), np.ones(2), name="speed\theading_offset")

    @property
    def goal_in_observation(self) -> bool:
        """Whether "observation" holds the goal itself (relative, planner) so that a policy needs no desired_goal."""
        return self.observation_kind in ("relative", "planner")

    @property
    def observation_fields(self) -> tuple[str, ...]:
        """Names of the "observation" vector's entries."""
        return {"relative": RELATIVE_FIELDS, "paper": OBSERVATION_FIELDS,
                "planner": PLANNER_FIELDS}[self.observation_kind]

    def observation_spec(self, physics: Physics) -> collections.OrderedDict:
        """"observation" (observation_fields); "achieved_goal" and "desired_goal": (x, y) [m], and with the
        relative observation also the heading as (cos, sin) -- the vehicle's, and the route's at the goal
        (which no reward reads) -- so that hindsight relabelling can recompute the body-frame goal."""
        goal = 4 if self.goal_in_observation else 2
        return collections.OrderedDict(
            observation=specs.Array((len(self.observation_fields),), float, name="observation"),
            achieved_goal=specs.Array((goal,), float, name="achieved_goal"),
            desired_goal=specs.Array((goal,), float, name="desired_goal"))

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Vehicle state, command and sonar, normalised (`observe`, N = 1); the goals in metres."""
        episode = self.episode
        if episode.sonar is None:
            episode.sonar = self.ocean.sense(physics.sonar())
        readout = self._readout(physics)
        observation = observe(self._routes, ONE_ROW, np.array([episode.reached]), readout,
                              np.array([episode.command]), self.observation_kind, episode.action[None])
        if self.observation_kind == "planner" and episode.steps == 0:  # the reset's info: the critic's first input
            distance = np.array([episode.distance])
            self.last_info = {"privileged": privileged(self._routes, ONE_ROW, distance,
                                                       np.array([self._clearance(physics)]),
                                                       np.array([self.step_limit]))[0]}
        return collections.OrderedDict((key, observation[key][0]) for key in ("observation", "achieved_goal",
                                                                              "desired_goal"))

    def map_fence(self, physics: Physics) -> np.ndarray:
        """The map's edge as the nine beams would read it were it a wall, from where the sonars are now
        (`auv_mj.sim.sonar.fence_ranges`): what a protection domain with a geofence adds to the echoes. SONAR_RANGE on
        every beam in an arena without `arena_bounds`."""
        bounds = self.episode.bounds
        if bounds is None:
            return np.full(len(SONAR_NAMES), SONAR_RANGE)
        data = physics.data.ptr
        return fence_ranges(data.site_xpos[self.binding.sonar_site], data.qpos[self.binding.qpos[2]], bounds)

    def relabel_observation(self, observation, achieved_goal, desired_goal) -> np.ndarray:
        """The observation had `desired_goal` been the goal (hindsight relabelling; vectorised over rows).

        Only the relative and planner observations depend on the goal: their first three entries (the goal, or the
        route target, which on a relabelled episode of one goal is that goal) are recomputed from the vehicle's pose
        in `achieved_goal`; the paper's vector is returned unchanged.
        """
        observation = np.array(observation, dtype=float, copy=True)
        if self.goal_in_observation:
            observation[..., :3] = relative_goal(achieved_goal, desired_goal)
        return observation

    def get_reward(self, physics: Physics) -> float:
        """The reward of the step just taken (`reward_kind`, see the module docstring)."""
        return self.episode.reward

    def get_termination(self, physics: Physics) -> float | None:
        """0.0 after success, a collision or leaving the map; None otherwise."""
        return 0.0 if self.episode.terminal else None

    # --- goal-conditioned API (hindsight relabelling) -----------------------------------------------

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """The "paper" reward (Eq. 26 and our success bonus; "progress" under reward="progress") of steps that
        reached `achieved_goal`, had the goal been `desired_goal`.

        `info` holds "previous_achieved_goal", "goal_independent_reward", "last_goal", "steps_left", "success",
        "collision" and "left_map" per step: a dict of arrays with the goals' leading shape, or a sequence /
        object array of `last_info` dicts. For the step's own goal this equals that step's reward exactly. The
        bonus is paid where `desired_goal` is reached without a failure on a step of the route's last leg (a
        relabelled episode ends there, `compute_terminated`), or where the route itself succeeded.
        """
        if self.reward_kind == "geodesic":
            return self._geodesic_reward(achieved_goal, desired_goal, info)
        kind = "progress" if self.reward_kind == "progress" else "paper"
        previous = info_field(info, "previous_achieved_goal")
        independent = info_field(info, "goal_independent_reward")
        radius = self._radius(info)
        follow = progress_reward if kind == "progress" else following_reward
        reward = REWARD_WEIGHTS[0] * follow(previous, achieved_goal, desired_goal, radius) + independent
        reached = (goal_distance(achieved_goal, desired_goal) <= radius) & ~self._failed(info)
        ended = np.where(info_field(info, "last_goal").astype(bool), reached, info_field(info, "success").astype(bool))
        return reward + np.where(ended, success_bonus(kind, info_field(info, "steps_left")), 0.0)

    def _geodesic_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """reward="geodesic" for (relabelled) goals. Where `desired_goal` is the step's own goal (info "step_goal") the
        step's route distances are in its info ("route_distance_before", "route_distance", and "success"), and the
        step's reward is returned exactly. Elsewhere (hindsight) no field of that goal exists (a Dijkstra search per
        relabelled sample): the potential is the straight distance to the goal region, the geodesic of open water,
        and the relabelled episode succeeds where the goal is reached without a failure (`compute_terminated`)."""
        achieved, desired = np.asarray(achieved_goal, dtype=float), np.asarray(desired_goal, dtype=float)
        radius = self._radius(info)
        failed = self._failed(info)
        previous = info_field(info, "previous_achieved_goal")
        own = np.all(desired[..., :2] == info_field(info, "step_goal"), axis=-1)
        straight_before = np.maximum(goal_distance(previous, desired) - radius, 0.0)
        straight_after = np.maximum(goal_distance(achieved, desired) - radius, 0.0)
        reached = (goal_distance(achieved, desired) <= radius) & ~failed
        before = np.where(own, info_field(info, "route_distance_before"), straight_before)
        after = np.where(own, info_field(info, "route_distance"), straight_after)
        success = np.where(own, info_field(info, "success").astype(bool), reached)
        return geodesic_reward(before, after, success, failed, self.collision_penalty)

    def compute_terminated(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Whether a step ends the episode had `desired_goal` been its only goal: reached, collided or left.

        For the last goal of a route this equals the environment's termination; for an earlier sub-goal
        the environment goes on to the next goal, while the relabelled single-goal episode ends.
        """
        reached = goal_distance(achieved_goal, desired_goal) <= self._radius(info)
        return reached | self._failed(info)

    @staticmethod
    def _failed(info) -> np.ndarray:
        """Whether each step collided or left the map."""
        return info_field(info, "collision").astype(bool) | info_field(info, "left_map").astype(bool)

    def _radius(self, info) -> np.ndarray | float:
        """The goal radius of each step: from its info when recorded there (a mix of tasks), else ours."""
        try:
            return info_field(info, "goal_radius")
        except ValueError:
            return self.goal_radius

    @property
    def step_limit(self) -> int:
        """Planner steps in an episode at most: those of the environment's time limit (`time_limit_steps`), or of
        options.MAX_TIME_LIMIT, the longest any factory takes, where no `environment` told the task."""
        if self.time_limit_steps is None:
            return math.ceil(options.MAX_TIME_LIMIT / PLANNER_DT)
        return self.time_limit_steps

    @property
    def goals(self) -> np.ndarray:
        """The episode's goal sequence (n, 2) [m]."""
        return self.episode.goals.copy()

    @property
    def goal_index(self) -> int:
        """Index in `goals` of the current goal (the last one once all are reached)."""
        return self.episode.goal_index
