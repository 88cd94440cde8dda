"""The planning tasks' rewards: Eq. (23)-(26) of Lyu et al. (2023) and ours ("suite", "progress", "geodesic").

Each reward is a function on arrays (a batch of steps, or of relabelled goals), so that the one planning step
(`auv_mj.tasks.planning_step.step_outcome`) and the goal-conditioned API (`PlanningTask.compute_reward`, for hindsight
relabelling) compute it the same way. The constants are the paper's (Table 1, Eq. 21-26) and our bounds on them.

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
D = d_k(position) + the legs after goal k (`auv_mj.tasks.routes.RoutePotential`; `PlanningTask.geodesic_legs`: a
tunnel's potential runs to its end alone, its field following the tunnel, so no sub-goal pays; waypoints, path_line and
path_curve run through every goal in turn, their goals being the task; goal, obstacles and moving_obstacles have one
goal). A step pays

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
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from dm_control.utils import rewards

from auv_mj.arenas.arena import SAFETY_DISTANCE
from auv_mj.sim.physics import AUVPhysics
from auv_mj.tasks.routes import goal_distance

REWARDS = ("suite", "paper", "progress", "geodesic")
"""The values of the task option `reward` (module docstring)."""

GEODESIC_DISCOUNT = 0.998
"""The discount gamma of reward="geodesic" (ours, issue 51), the one a learner of it must use: its shaping term is
gamma Phi(s') - Phi(s) with this gamma, and its collision penalty is sized by it (module docstring, "The geodesic
reward"). 1 / (1 - gamma) = 500 planner steps, 500 m at the top speed: longer than a hard-tier detour (100-300 m) and
than an average episode (about 370 steps)."""

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

PROGRESS_GAIN = 0.5
"""reward="progress": reward per metre of distance gained on the current goal (a 1 m/s step earns Eq. 23's
+0.5). Its sum over an episode depends only on where the vehicle started and ended, not on how slowly it
went, so that Eq. (25)'s per-step cost makes reaching the goal sooner worth more; Eq. (23)'s +0.5 per
step closer instead pays for dawdling."""

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

HULL = "hull"
"""The vehicle geom whose length and beam are L and B of Eq. (21)."""


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


def suite_reward(goals: np.ndarray, n: np.ndarray, reached: np.ndarray, position: np.ndarray, failed: np.ndarray,
                 success: np.ndarray, steps_left: np.ndarray, radius: float) -> np.ndarray:
    """reward="suite": 0 on a failure, the success bonus (module docstring) on success, else (goals reached +
    tolerance(distance to the current goal)) / goals, in [0, 1)."""
    goal = goals[np.arange(len(n)), np.minimum(reached, n - 1)]
    distance = np.hypot(goal[:, 0] - position[:, 0], goal[:, 1] - position[:, 1])
    near = rewards.tolerance(distance, bounds=(0.0, radius), margin=SUITE_REWARD_MARGIN, sigmoid="long_tail",
                             value_at_margin=0.1)
    return np.where(failed, 0.0, np.where(success, success_bonus("suite", steps_left), (reached + near) / n))


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
