"""The planning layer of Sec. 3.2 as dm_control tasks: `PlanningTask`, the base of every planar suite task.

One dm_env step is one planner decision (PLANNER_DT, 0.5 s): the action becomes the executor's command, the executor
drives the full dynamics, and the step ends in goals, events, a reward and an observation. The task holds the
episode's state (`Episode`) and calls the one planning step with N = 1 on it, as the batched env calls it with N.
Its parts, each a module of its own:

- `auv_mj.tasks.planning_step`: the action map (Table 3, Table 1), events and metrics, the step's info, and the
  records the step reads (`Episode`, `Binding`, `RouteBatch`, `Readout`), on arrays over a batch axis;
- `auv_mj.tasks.planning_rewards`: the rewards, Eq. (23)-(26) ("paper") and ours ("suite", "progress", "geodesic"),
  with our success bonus and the proofs of what they pay for;
- `auv_mj.tasks.planning_observation`: the observation vectors ("relative", "paper", "planner");
- `auv_mj.tasks.routes`: goals and routes (Sec. 3.2.4), the passing rule, the geodesic potential's record;
- `auv_mj.tasks.planning_physics`: the `Physics`, arena loading and the open-water tasks' arena options.

Here: the task itself, its `control.Environment` (`environment`: the time limit, the physics steps of a planner step),
the geodesic potential of an episode (`route_potential`) and its movers' states (`mover_states`), and the
goal-conditioned API for hindsight relabelling (`PlanningTask.compute_reward`, `compute_terminated`).

The executor (`executor(command, state)`, default the S-plane controller of Eq. 32) turns the command into
(tau_u, tau_r) every EXECUTOR_DT = 0.1 s on the full dynamics. The task's `Physics` calls it between
physics steps, so `control.Environment` still owns the 50 physics steps of a planner step and the time
limit; moving obstacles are moved on the same 10 Hz tick.

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
from collections.abc import Callable, Mapping

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_env import specs

from auv_mj.arenas import arena
from auv_mj.arenas.geodesic import field_of_arena
from auv_mj.arenas.sonar_memory import SonarMemory, memory_bounds
from auv_mj.control.splane import EXECUTOR_DT, SPlaneController
from auv_mj.episode import arena_geometry
from auv_mj.sim import ocean
from auv_mj.sim.physics import AUVPhysics
from auv_mj.sim.sonar import SONAR_NAMES, SONAR_RANGE, fence_ranges
from auv_mj.tasks import options, planning_observation, planning_step
from auv_mj.tasks.actions import checked_action
from auv_mj.tasks.planning_observation import (
    OBSERVATION_FIELDS,
    OBSERVATIONS,
    PLANNER_FIELDS,
    PLANNER_MAP_FIELDS,
    RELATIVE_FIELDS,
)
from auv_mj.tasks.planning_physics import Physics
from auv_mj.tasks.planning_rewards import (
    HULL,
    MAX_COLLISION_PENALTY,
    REWARD_WEIGHTS,
    REWARDS,
    following_reward,
    geodesic_reward,
    info_field,
    progress_reward,
    repulsion_range,
    success_bonus,
)
from auv_mj.tasks.planning_step import (
    ACTIONS,
    ONE_ROW,
    PLANNER_DT,
    PLANNER_OBSERVATIONS,
    PRIVILEGED_KINDS,
    Binding,
    Episode,
    Readout,
    RouteBatch,
    StepRules,
    info_row,
)
from auv_mj.tasks.routes import GEODESIC_LEGS, GOAL_RADIUS, MAX_GOAL_RADIUS, Route, RoutePotential, goal_distance

SONAR_SITE = "sonar_site_5"
"""The site of the bow sonar S5 in the vehicle's MJCF, where the map's edge is measured from (`map_fence`)."""

POLICY_OPTIONS = ("action", "observation")
"""The task options that shape what a policy reads and does: a policy trained with them runs with them (the batched
envs report theirs as `policy_options`, a PPO checkpoint keeps them, the zoo applies them)."""


def policy_options(task_kwargs: Mapping) -> dict:
    """The POLICY_OPTIONS given in `task_kwargs`."""
    return {name: task_kwargs[name] for name in POLICY_OPTIONS if name in task_kwargs}


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
        offset, the default) or "rate" (the heading command's change per step, `planning_step`); `observation` may
        also be "planner" (PLANNER_FIELDS, with info["privileged"] for a critic) or "planner-map" (PLANNER_MAP_FIELDS:
        that and the vehicle's own sonar map, `auv_mj.arenas.sonar_memory`)."""
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
        if self.observation_kind == "planner-map":
            self.episode.memory = SonarMemory(memory_bounds(info.bounds, np.vstack([route.start, goals]),
                                                            SONAR_RANGE))
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
        command = planning_step.executor_command(np.array([[a0, a1]], dtype=float), data.qpos[qpos[2:]],
                                   np.array([episode.command[1]]), self.action_kind)
        episode.action = np.array([a0, a1], dtype=float)
        episode.command = (float(command[0, 0]), float(command[0, 1]))
        episode.previous = data.qpos[qpos[:2]].copy()

    def _sense(self, physics: Physics, true_ranges) -> None:
        """The ping of this planner step: the ranges as perceived (`ocean.sense`), and under "planner-map" the ping
        added to the vehicle's sonar map at the pose of now (`SonarMemory.add_ping`), once a ping."""
        episode = self.episode
        episode.sonar = self.ocean.sense(true_ranges)
        if episode.memory is not None:
            pose = physics.data.ptr.qpos[self.binding.qpos]
            episode.memory.add_ping(pose[:2], float(pose[2]), self.binding.sonar_offset, episode.sonar)

    def after_step(self, physics: Physics) -> None:
        """Senses, then `step_outcome` (N = 1): events, goals, the step's reward and `last_info`."""
        data, episode = physics.data.ptr, self.episode
        true_ranges = physics.sonar()
        self._sense(physics, true_ranges)
        episode.collided = episode.collided or (data.ncon > 0 and self._vehicle_contact(physics))
        episode.steps += 1
        readout = self._readout(physics, true_ranges=np.asarray(true_ranges, dtype=float)[None],
                                collision=np.array([episode.collided]), clearance=np.array([self._clearance(physics)]))
        steps_left = max(self.step_limit - episode.steps + 1, 1)
        outcome = planning_step.step_outcome(self._routes, ONE_ROW, np.array([episode.reached]),
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
                         potential=self.reward_kind == "geodesic" or self.observation_kind in PLANNER_OBSERVATIONS)

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
        """(a0, a1) in [-1, 1]^2: speed and heading offset (the action map of `auv_mj.tasks.planning_step`)."""
        return specs.BoundedArray((2,), float, -np.ones(2), np.ones(2), name="speed\theading_offset")

    @property
    def goal_in_observation(self) -> bool:
        """Whether "observation" holds the goal itself (relative, planner) so that a policy needs no desired_goal."""
        return self.observation_kind in ("relative", *PLANNER_OBSERVATIONS)

    @property
    def observation_fields(self) -> tuple[str, ...]:
        """Names of the "observation" vector's entries."""
        return {"relative": RELATIVE_FIELDS, "paper": OBSERVATION_FIELDS,
                "planner": PLANNER_FIELDS, "planner-map": PLANNER_MAP_FIELDS}[self.observation_kind]

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
            self._sense(physics, physics.sonar())
        readout = self._readout(physics)
        scan = None if episode.memory is None else episode.memory.scan(readout.position[0], float(readout.psi[0]))
        observation = planning_observation.observe(self._routes, ONE_ROW, np.array([episode.reached]), readout,
                              np.array([episode.command]), self.observation_kind, episode.action[None],
                              None if scan is None else scan[None])
        if self.observation_kind in PLANNER_OBSERVATIONS and episode.steps == 0:  # the reset's info: the critic's input
            distance = np.array([episode.distance])
            self.last_info = {"privileged": planning_step.privileged(self._routes, ONE_ROW, distance,
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
            observation[..., :3] = planning_observation.relative_goal(achieved_goal, desired_goal)
        return observation

    def get_reward(self, physics: Physics) -> float:
        """The reward of the step just taken (`reward_kind`, see `auv_mj.tasks.planning_rewards`)."""
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
