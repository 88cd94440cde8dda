"""The suite domain "auv3d" (issue 32): the 6-DOF REMUS-100 (`models/auv6.xml`) in depth.

- `depth_heading`: the execution layer in 3-D. Each EXECUTOR_DT = 0.1 s the agent sees the command (V, psi,
  depth) and the vehicle's sensors and sets (thrust, rudder, stern), scaled from [-1, 1]^3 by the actuator
  ranges. The "paper" schedule is Sec. 4.2's (1 m/s, pi/12, the sway burst, the constant and the periodic
  force) extended to depth: a 5 m dive from 10 m at the start, and each disturbance with a vertical part
  (VERTICAL_SHARE of its horizontal force). Metrics add mae_depth [m] (`last_info["depth_error"]`). As on
  speed_heading, an episode ends by its schedule: it reports no success, only "within_tolerance" per step.
  A learned executor can act through the S-plane instead (`residual`, `gains`, `base`, `observation`;
  `auv_mj.tasks.depth_executor`).
- `goal3d`: reach a goal in 3-D among obstacles over a seabed (`arena="random"` draws them).
- `tunnel3d`: follow a tube along an x, y, z centreline to its end (`auv_mj.arenas.tubes`; `arena="random"`
  draws procedural tubes with climbs, dives and bends, `arena=PATH` flies a tube file from `auv-mj tunnel --tube`,
  its rocks and moving spheres included).
- Both take `tier="hard"`: arenas where depth is the way on (`auv_mj.arenas.traps3d`), certified by the 3-D
  oracle's search before use.

Time limits come from the route, as the planar tunnel's do (`auv_mj.tasks.routes.route_time_limit`): each
episode's is `route_time_limit` of its route's length (twice its time at the classical planners' CRUISE_SPEED plus
a minute), and never less than the task's floor (GOAL_TIME_LIMIT, TUNNEL_TIME_LIMIT). The route is the tube's
centreline on tunnel3d (a procedural tube or a user's), the oracle's certificate on a hard goal3d arena (the
pitch-limited path that certified it), the straight line from start to goal on a standard goal3d arena
(`Planning3D.route`). A `time_limit` the user gives replaces it, with a warning naming `time_limit` when the route
cannot be flown in it at CRUISE_SPEED (`RouteEnvironment`).

The two planning tasks act every PLANNER_DT = 0.5 s, as the planar ones: the action (a_speed, a_heading,
a_depth) in [-1, 1]^3 sets the speed (0..MAX_SPEED), a heading offset (up to HEADING_RANGE) and a depth offset
(up to DEPTH_RANGE) for the depth-heading executor, which runs at 10 Hz inside the step: the classical one
(`auv_mj.control.depth_heading`) unless the `executor` option names or gives another (`auv_mj.tasks.executors`).
Their observation is the Gymnasium-Robotics goal dict, as the planar goal tasks': "observation" is what the vehicle
can know (its motion and attitude, depth and altitude, the goal, or the tube's look-ahead point, relative to
itself, and the 27 fan ranges), "achieved_goal" and "desired_goal" are (x, y, z, cos psi, sin psi): where the vehicle
is and the heading it senses, and the goal (goal3d's, or the tube's end) with the heading of the way into it. The
reward (reward="progress", the default: progress towards the goal, a bonus on reaching it, a step cost, a penalty
for a collision or broaching) is `compute_reward(achieved_goal, desired_goal, info)`, vectorised, so that hindsight
relabelling (HER) recomputes it exactly; on goal3d, whose observation holds the goal, `relabel_observation`
recomputes the goal's entries. reward="geodesic" is the planar tasks' learning reward in 3-D
(`auv_mj.tasks.planning_rewards`, "The geodesic reward", with its constants and its discount GEODESIC_DISCOUNT):
potential-based shaping on the route length left on the arena's true static map, searched once at the reset over
the oracle's voxel map on the lattice the vehicle can fly at its pitch limit (`auv_mj.arenas.traps3d.geodesic_field`;
a tube's potential runs inside the tube), with the success bonus and the collision penalty that make no crash or
broach pay more than the way round, over or under. Straight-line progress pays the way into a wall that must be
climbed, a cave's mouth and a plug; the route length does not. The step's info then holds "route_distance_before",
"route_distance" and "step_goal", and "privileged" (PRIVILEGED_FIELDS), what an asymmetric critic may read and the
actor must not.

An arena is a function of the task seed, as in the planar domain: `arena="random"` draws each episode's arena from
the task's `random` first (the first episode of a task seeded s has the arena of `draw_arena(RandomState(s))`), so
that the seed ranges of `auv_mj.seeds` (train, validation, test) split the arenas too; `arena="fixed"` is one arena
(seed 0, outside every range).

Every task takes `conditions` ("ideal", "ocean" or a mapping, `auv_mj.sim.ocean3d`).
"""

from __future__ import annotations

import auv_mj  # noqa: F401  # isort: skip  (first: it picks MuJoCo's OpenGL backend before dm_control loads)
import collections
import math
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import rewards
from dm_env import specs

from auv_mj.arenas import arena3d, arena_check, traps3d, tubes
from auv_mj.arenas.geodesic import VoxelField, voxel_room
from auv_mj.arenas.sonar_memory import FAN_MEMORY_BEAMS, VoxelMemory, fan_beams, memory_grid3d
from auv_mj.arenas.voxels import CLIMB_MARGIN
from auv_mj.control.clock import ExecutorClock
from auv_mj.control.depth_heading import (
    EXECUTOR_DT,
    SCHEDULED_GAINS,
    DepthHeadingController,
    DepthHeadingGains,
    State3D,
    los_command,
)
from auv_mj.episode import FunctionPlanner, Planner
from auv_mj.geometry import wrap_angle
from auv_mj.inputs import MAX_XML_BYTES, parse_xml, read_text
from auv_mj.sim import ocean3d
from auv_mj.sim.physics3d import AUV3DPhysics, euler_angles, set_pose
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, FAN_BEAMS, FanFilter, Sensors3D
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import options
from auv_mj.tasks.actions import checked_action
from auv_mj.tasks.depth_executor import SENSOR_NAMES, DepthExecutorMemory
from auv_mj.tasks.planning_rewards import geodesic_reward, info_field
from auv_mj.tasks.planning_step import GOAL_DISTANCE_SCALE, PRIVILEGED_TIME_SCALE
from auv_mj.tasks.registry import DOMAIN_3D, SUITE3D

DOMAIN = DOMAIN_3D

# --- depth_heading -------------------------------------------------------------------------------------------
EPISODE_STEPS = 1100
"""Sec. 4.2's 1100 executor steps."""
PAPER_COMMAND = (1.5, math.pi / 12, 15.0)
"""Sec. 4.2's heading pi/12 [rad], at REMUS's 1.5 m/s cruise [m/s], and a depth of 15 m [m]. Not Sec. 4.2's
1 m/s: the positively buoyant REMUS needs 60 % of its stern-plane range just to trim at 1 m/s (0.14 of 0.237
rad), 30 % at 1.5 m/s, the speed Prestero's coefficients were measured for."""
START_DEPTH = 12.0
"""Depth of the episode start [m]: the paper command is a 3 m dive."""
DISTURBANCE_SCALE = 0.2
"""Sec. 4.2's forces are sized for the planar model's 10 N m yaw moment; REMUS's rudder gives 3.3 N m at
1.5 m/s, and the Munk moment of the sway a side force drives grows with the force. A fifth of each force keeps
the schedule within what the vehicle can reject (the full 30 N turns it off its heading for good)."""
VERTICAL_SHARE = 1.0 / 3.0
"""The vertical part of each disturbance, as a share of its horizontal force (downwards)."""
BURST = (250, 10, 180.0 * DISTURBANCE_SCALE)
CONSTANT = (350, 350, 30.0 * DISTURBANCE_SCALE)
PERIODIC = (750, 350, 25.0 * DISTURBANCE_SCALE, 0.01 * math.pi)
"""Sec. 4.2's windows (start step, steps, force [N][, rate rad/step]): body sway burst, world +y force,
world +y periodic force, each scaled by DISTURBANCE_SCALE."""
PHASES = ("none", "instantaneous", "constant", "periodic")
SETTLE_STEPS = 100
"""Steps left out of the tracking metrics (the start's dive and acceleration from rest)."""
SPEED_TOLERANCE, HEADING_TOLERANCE, DEPTH_TOLERANCE = 0.05, 0.05, 0.25
"""Errors [m/s, rad, m] within which the suite reward's terms are 1 and the command counts as met."""
SPEED_MARGIN, HEADING_MARGIN, DEPTH_MARGIN = 0.5, 0.5, 3.0
RANDOM_SPEED = (1.0, 1.8)
"""Speeds of the "random" commands [m/s]: below 1 m/s the stern planes cannot trim the buoyant REMUS."""
RANDOM_DEPTH = (5.0, 40.0)
"""Depths of the "random" commands [m]."""
RANDOM_DEPTH_STEP = 5.0
"""A new "random" depth command is the previous one plus up to this much either way [m]."""
RANDOM_TURN = math.pi / 2
COMMAND_HOLD_STEPS = (50, 250)
MAX_COMMAND_DEPTH = 500.0
"""Deepest depth command [m]."""
COMMANDS = ("paper", "random")
DISTURBANCES = ("paper", "none")
REWARDS = ("suite", "paper")
EXECUTOR_OBSERVATION = SENSOR_NAMES
"""The executor's observation (`auv_mj.tasks.depth_executor.SENSOR_NAMES`)."""

# --- planning ------------------------------------------------------------------------------------------------
PLANNER_DT = 0.5
MAX_SPEED = 2.0
"""Top speed command of the planning action [m/s]."""
CRUISE_SPEED = 1.5
"""Speed of the classical planners [m/s]."""
HEADING_RANGE = math.pi / 4
"""Largest heading offset of a planning action [rad]."""
DEPTH_RANGE = 5.0
"""Largest depth offset of a planning action [m]."""
GOAL_RADIUS = 3.0
"""Reaching within this of the goal [m] ends a goal3d episode in success."""
GOAL_TIME_LIMIT, TUNNEL_TIME_LIMIT = 200.0, 250.0
"""The least time limit [s] of a goal3d and a tunnel3d episode: the limits of suite 3d v1, where every episode had
them; a longer route has longer (`route_time_limit`)."""
ROUTE_TIME_FACTOR, ROUTE_TIME_MARGIN, ROUTE_TIME_STEP = 2.0, 60.0, 10.0
"""A route's time limit is ROUTE_TIME_FACTOR times its time at CRUISE_SPEED plus ROUTE_TIME_MARGIN [s], rounded up
to ROUTE_TIME_STEP [s]: the planar tunnel's rule (`auv_mj.tasks.routes.route_time_limit`) at the 3-D planners'
speed."""
WATER_DEPTH = 60.0
"""Depth of the goal3d seabed [m]."""
COLLISION_REWARD, GOAL_REWARD, PROGRESS_WEIGHT, STEP_COST = -50.0, 50.0, 1.0, 0.01
"""The planning reward: PROGRESS_WEIGHT per metre gained on the goal, -STEP_COST a step, +GOAL_REWARD on reaching
it, COLLISION_REWARD on a collision or broaching. The progress telescopes, so reaching the goal beats waiting
outside it at every discount (as reward="progress" in `auv_mj.tasks.planning`): along any path that stays outside the
radius, summation by parts bounds sum_k gamma^k (d_k - d_{k+1}) by d_0 - GOAL_RADIUS, and the other terms are
< 0; the step that reaches it pays at least that + GOAL_REWARD - STEP_COST (tests/tasks/test_rewards.py)."""
MIN_DEPTH = 1.0
"""Shallower than this [m] is broaching: an episode ends in "left_map"."""
LOOKAHEAD = 8.0
"""Line-of-sight look-ahead [m] along a tube's centreline."""
PRIVILEGED_FIELDS = ("route_distance", "room", "time_left", "hard_tier", "tube")
"""info["privileged"] under reward="geodesic" (at the reset and every step): what a critic may know and the actor
must not (an asymmetric critic, Pinto et al. 2018; the planar tasks' `planning_step.PRIVILEGED_FIELDS` in 3-D).
route_distance: the route length left on the true static map (the reward's potential) / GOAL_DISTANCE_SCALE; room:
the distance from the vehicle's voxel of that map to its nearest closed voxel (`geodesic.voxel_room`: the true
clearance at the map's resolution) / SONAR_RANGE; time_left: the episode's route time limit (`episode_time_limit`;
a user's `time_limit` is not counted) less its time [s] / PRIVILEGED_TIME_SCALE; hard_tier: 1 on the hard tier; tube:
1 in an episode along a tube (tunnel3d's)."""
GOAL_SIZE = 5
"""Entries of achieved_goal / desired_goal: x, y, z [m] and the heading as (cos, sin), which no reward reads (it lets
hindsight relabelling recompute goal3d's body-frame goal)."""
FIXED_ARENA_SEED = 0
"""The seed of `arena="fixed"`'s one arena (outside the train, validation and test ranges of `auv_mj.seeds`)."""
TARGET_ENTRIES = slice(10, 14)
"""Where PLANNING_OBSERVATION holds the target (distance, cos and sin of its bearing, depth offset)."""
POLICY_OPTIONS = ("executor", "observation")
"""The 6-DOF planning tasks' options a learned planner trained with runs with (a batched env reports them as
`policy_options`, a PPO checkpoint keeps them, the zoo applies them): the execution layer under it, by name, and
its observation."""
OBSERVATIONS = ("fan", "fan-map", "fan-held")
"""The planning tasks' `observation` option: "fan" (PLANNING_OBSERVATION and the fan), "fan-map": that vector
with the vehicle's own sonar map beside it (FAN_MEMORY_NAMES before the fan; `auv_mj.arenas.sonar_memory.VoxelMemory`,
the map `map-replan` plans on, filled from the fan and the altimeter this episode, nothing of the true map), what the
fan has shown and no longer shows: a plug passed under, a wall beside or behind; or "fan-held": the "fan" vector
with the fan filtered over pings as the 3-D protection domain reads it in a tube (`auv_mj.sim.sensors3d.FanFilter`:
each beam the nearer of its newest ping and its median over the last three), so that a lost echo (ocean water's
dropouts) does not show open water where a wall is."""
PLANNING_REWARDS = ("progress", "geodesic")
"""The planning tasks' `reward` option (module docstring)."""
TIERS = ("standard", "hard")
"""The planning tasks' `tier` option: the standard arenas, or the hard ones where depth is the way on
(`auv_mj.arenas.traps3d`: walls to pass over or under, caves, seabed relief; tubes with plugs), each certified by
the 3-D oracle's search."""


class Physics3D(ExecutorClock, AUV3DPhysics):
    """AUV3DPhysics with the executor's clock (`auv_mj.control.clock.ExecutorClock`): `set_tick(callback)` calls it
    every EXECUTOR_DT while stepping."""

    TICK_PERIOD = EXECUTOR_DT

    @classmethod
    def load(cls, arena=None, conditions=None) -> Physics3D:
        """The vehicle in `arena` (`auv_mj.arenas.arena3d.compose_xml`), lagged where `conditions` ask for it."""
        xml, source = arena3d.compose_xml(arena, thruster_lag=ocean3d.conditions(conditions).thruster_lag)
        return cls.from_xml_string(xml, source=source)


def read_state(physics: AUV3DPhysics, sensed: dict[str, np.ndarray]) -> State3D:
    """The executor's State3D from the sensors: DVL (u, v, w), gyro (p, q, r), AHRS attitude, pressure depth."""
    u, v, w = (float(x) for x in sensed["dvl"])
    p, q, r = (float(x) for x in sensed["gyro"])
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, sensed["attitude"])
    roll, pitch, heading = euler_angles(rotation.reshape(3, 3))
    return State3D(u, v, w, p, q, r, float(roll), float(pitch), float(heading), float(sensed["depth"]))


def _normalise(control_values: np.ndarray, physics: AUV3DPhysics) -> np.ndarray:
    low, high = physics.model.actuator_ctrlrange.T
    return np.clip(2.0 * (np.asarray(control_values, dtype=float) - low) / (high - low) - 1.0, -1.0, 1.0)


class DepthHeading(base.Task):
    """Follow (V, psi, depth) with (thrust, rudder, stern) under disturbances (module docstring)."""

    def __init__(self, command: str | Sequence[float] = "paper", disturbances: str = "paper", reward: str = "suite",
                 random=None, conditions="ideal", observation: str = "sensors", residual: float = 0.0,
                 gains: float = 0.0, base: str = "nominal"):
        """`command`: "paper", "random" or (V [m/s], psi [rad], depth [m]); `disturbances`: "paper" or "none";
        `reward`: "suite" ([0, 1]) or "paper" (-|e_V| - |e_psi| - |e_depth| / DEPTH_MARGIN); `conditions`: ocean;
        `observation`, `residual`, `gains`, `base`: a learned executor's view and action
        (`auv_mj.tasks.depth_executor.DepthExecutorMemory`: plain controls, a residual on the S-plane or its
        gains scheduled; "history" appends the S-plane's integrals and the last controls)."""
        if isinstance(command, str):
            options.choice("command", command, COMMANDS)
        else:
            command = options.pair("command", command, ((0.0, MAX_SPEED, "m/s"), (-math.pi, math.pi, "rad"),
                                                        (MIN_DEPTH, MAX_COMMAND_DEPTH, "m")))
        self._command_mode = command
        self._disturbances = options.choice("disturbances", disturbances, DISTURBANCES)
        self._reward_mode = options.choice("reward", reward, REWARDS)
        self.ocean = ocean3d.Ocean3D(conditions)
        self.sensors = Sensors3D(noise=self.ocean.noise)
        self._schedule: list[tuple[int, float, float, float]] = [(0, *PAPER_COMMAND)]
        self._errors = (0.0, 0.0, 0.0)
        self.last_info: dict = {}
        self.memory = DepthExecutorMemory(observation, residual, gains, base)
        self._observation = np.zeros(self.memory.size)
        super().__init__(random=options.seed(random))

    def initialize_episode(self, physics: AUV3DPhysics) -> None:
        if self._command_mode == "random":
            heading = self.random.uniform(-math.pi, math.pi)
            depth = self.random.uniform(*RANDOM_DEPTH)
            self._schedule = [(0, self.random.uniform(*RANDOM_SPEED), heading, depth)]
            step = 0
            while step < EPISODE_STEPS * 10:
                step += int(self.random.randint(COMMAND_HOLD_STEPS[0], COMMAND_HOLD_STEPS[1] + 1))
                _, _, psi, _ = self._schedule[-1]
                depth = float(np.clip(depth + self.random.uniform(-RANDOM_DEPTH_STEP, RANDOM_DEPTH_STEP),
                                      *RANDOM_DEPTH))
                self._schedule.append((step, self.random.uniform(*RANDOM_SPEED),
                                       wrap_angle(psi + self.random.uniform(-RANDOM_TURN, RANDOM_TURN)), depth))
            offset = self.random.uniform(-RANDOM_DEPTH_STEP, RANDOM_DEPTH_STEP)
            start_depth = float(np.clip(self._schedule[0][3] + offset, *RANDOM_DEPTH))
            speed = self.random.uniform(0.0, 1.5)
        else:
            heading, start_depth, speed = 0.0, START_DEPTH, 0.0
            fixed = PAPER_COMMAND if self._command_mode == "paper" else self._command_mode
            self._schedule = [(0, *fixed)]
        set_pose(physics, (0.0, 0.0, -start_depth), yaw=heading, nu=(speed, 0, 0, 0, 0, 0))
        physics.reset_fins()
        physics.set_control(np.zeros(physics.model.nu))
        self.memory.reset(*physics.model.actuator_ctrlrange.T)
        physics.disturbance = self._disturbance() if self._disturbances == "paper" else None
        self.ocean.start(physics, self.random)
        self.sensors.reset()
        self._step = 0
        self._step_command = self.command(physics)
        super().initialize_episode(physics)

    @staticmethod
    def _disturbance() -> Callable[[float], np.ndarray]:
        """The Sec. 4.2 schedule extended to depth, as a world wrench of time (module docstring)."""
        b0, bn, bf = BURST
        c0, cn, cf = CONSTANT
        p0, pn, pa, rate = PERIODIC

        def wrench(time: float) -> np.ndarray:
            k = time / EXECUTOR_DT
            force = np.zeros(6)
            if c0 <= k < c0 + cn:
                force[1] += cf
                force[2] -= VERTICAL_SHARE * cf
            if p0 <= k < p0 + pn:
                magnitude = pa * math.sin(rate * k)
                force[1] += magnitude
                force[2] -= VERTICAL_SHARE * magnitude
            return force

        burst_force = bf

        def with_burst(time: float) -> np.ndarray:
            out = wrench(time)
            k = time / EXECUTOR_DT
            if b0 <= k < b0 + bn:  # a body-frame sway burst: applied along the world y of a vehicle near psi_cmd
                psi = PAPER_COMMAND[1]
                out[0] -= burst_force * math.sin(psi)
                out[1] += burst_force * math.cos(psi)
                out[2] -= VERTICAL_SHARE * burst_force
            return out

        return with_burst

    def command(self, physics) -> tuple[float, float, float]:
        """(V_cmd [m/s], psi_cmd [rad], depth_cmd [m]) in force now."""
        step = int(round(physics.time() / EXECUTOR_DT))
        for start, v, psi, depth in reversed(self._schedule):
            if start <= step:
                return v, psi, depth
        return self._schedule[0][1:]

    def phase(self, step: int) -> str:
        if self._disturbances == "none":
            return "none"
        started = [name for name, start in (("instantaneous", BURST[0]), ("constant", CONSTANT[0]),
                                            ("periodic", PERIODIC[0])) if start <= step]
        return started[-1] if started else "none"

    def state(self, physics) -> State3D:
        """The executor's view of the vehicle now (through the sensors)."""
        return read_state(physics, self.sensors.read(physics))

    def action_spec(self, physics) -> specs.BoundedArray:
        """(thrust, rudder, stern) in [-1, 1]^3, or one action per scheduled gain (`gains`)."""
        if self.memory.gains:
            return specs.BoundedArray((len(SCHEDULED_GAINS),), float, -1.0, 1.0, name=",".join(SCHEDULED_GAINS))
        return specs.BoundedArray((physics.model.nu,), float, -1.0, 1.0, name="thrust,rudder,stern")

    def before_step(self, action, physics) -> None:
        self.ocean.tick(physics)
        self._step = int(round(physics.time() / EXECUTOR_DT))
        self._step_command = self.command(physics)
        physics.set_control(self.memory.controls(checked_action(action, self.action_spec(physics), self)))

    def after_step(self, physics) -> None:
        v_cmd, psi_cmd, depth_cmd = self._step_command
        u = physics.body_velocity()[0]
        self._errors = (v_cmd - float(u), wrap_angle(psi_cmd - physics.heading()), depth_cmd - physics.depth())
        e_v, e_psi, e_d = self._errors
        met = abs(e_v) < SPEED_TOLERANCE and abs(e_psi) < HEADING_TOLERANCE and abs(e_d) < DEPTH_TOLERANCE
        self.last_info = {"phase": self.phase(self._step), "speed_error": e_v, "heading_error": e_psi,
                          "depth_error": e_d, "command": np.array([v_cmd, psi_cmd]), "depth_command": depth_cmd,
                          "tracked": self._step >= SETTLE_STEPS, "within_tolerance": met, "is_success": met}
        self._observation = self.memory.observe(self.command(physics), self.state(physics))

    def get_observation(self, physics) -> collections.OrderedDict:
        """"observation": EXECUTOR_OBSERVATION from the command in force and the sensors' samples (then the
        memories of the "history" observation and a residual's S-plane controls, `DepthExecutorMemory`)."""
        return collections.OrderedDict(observation=self._observation.copy())

    def get_reward(self, physics) -> float:
        e_v, e_psi, e_d = self._errors
        if self._reward_mode == "paper":
            return -abs(e_v) - abs(e_psi) - abs(e_d) / DEPTH_MARGIN
        terms = (rewards.tolerance(e_v, bounds=(-SPEED_TOLERANCE, SPEED_TOLERANCE), margin=SPEED_MARGIN),
                 rewards.tolerance(e_psi, bounds=(-HEADING_TOLERANCE, HEADING_TOLERANCE), margin=HEADING_MARGIN),
                 rewards.tolerance(e_d, bounds=(-DEPTH_TOLERANCE, DEPTH_TOLERANCE), margin=DEPTH_MARGIN))
        return float(np.mean(terms))

    def get_termination(self, physics) -> None:
        return None


@SUITE3D.add("benchmarking", "tracking", "executor")
def depth_heading(time_limit: float = EPISODE_STEPS * EXECUTOR_DT, random=None, environment_kwargs=None,
                  **task_kwargs) -> control.Environment:
    """The execution layer in 3-D: speed, heading and depth through disturbances."""
    time_limit = options.time_limit(time_limit)
    environment_kwargs = options.environment_kwargs(environment_kwargs)
    physics = Physics3D.load(None, task_kwargs.get("conditions"))
    task = DepthHeading(random=random, **task_kwargs)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=EXECUTOR_DT,
                               **environment_kwargs)


def splane_policy(env, gains: DepthHeadingGains | None = None) -> Planner:
    """The classical executor (`DepthHeadingController`, with `gains` or the hand-set ones) as a policy(time_step)
    of a depth_heading env."""
    task, physics = env.task, env.physics
    controller = DepthHeadingController(gains)

    def policy(time_step) -> np.ndarray:
        if time_step.first():
            controller.reset()
        return _normalise(controller(task.command(physics), task.state(physics)), physics)

    return FunctionPlanner(policy, controller.reset)


# --- planning tasks ------------------------------------------------------------------------------------------

PLANNING_OBSERVATION = ("u", "v", "w", "p", "q", "r", "roll", "pitch", "depth", "altitude", "target_distance",
                        "cos_target_bearing", "sin_target_bearing", "target_depth_offset")
"""The planning observation's first entries; the 27 fan ranges / SONAR_RANGE follow."""


def goal_distance(a, b) -> np.ndarray:
    """3-D distance [m] between the (x, y, z) of goals along the last axis, elementwise over leading axes."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.linalg.norm(a[..., :3] - b[..., :3], axis=-1)


def pose_goal(position, heading: float) -> np.ndarray:
    """A goal vector (GOAL_SIZE): the position (x, y, z) [m] and the heading as (cos, sin)."""
    return np.array([*np.asarray(position, dtype=float)[:3], math.cos(heading), math.sin(heading)])


def target_features(achieved_goal, target) -> np.ndarray:
    """The observation's target entries (TARGET_ENTRIES) from the vehicle's goal vector (position, sensed heading)
    and a target point: distance [m], cos and sin of its bearing off the heading, and its depth below the vehicle
    [m]; vectorised over leading axes."""
    achieved, target = np.asarray(achieved_goal, dtype=float), np.asarray(target, dtype=float)
    offset = target[..., :3] - achieved[..., :3]
    c, s = achieved[..., 3], achieved[..., 4]
    forward, left = c * offset[..., 0] + s * offset[..., 1], -s * offset[..., 0] + c * offset[..., 1]
    across = np.hypot(forward, left)
    safe = np.where(across > 1e-12, across, 1.0)
    return np.stack([np.linalg.norm(offset, axis=-1), np.where(across > 1e-12, forward / safe, 1.0),
                     np.where(across > 1e-12, left / safe, 0.0), -offset[..., 2]], axis=-1)


def planning_command(actions, heading, depth) -> np.ndarray:
    """The executor's commands (V [m/s], psi [rad], depth [m]) of planning actions (N, 3) in [-1, 1]^3 from vehicles at
    true `heading` [rad] and `depth` [m] (N,): speed 0..MAX_SPEED, heading offset up to HEADING_RANGE, depth offset up
    to DEPTH_RANGE (not above MIN_DEPTH)."""
    actions = np.asarray(actions, dtype=float)
    return np.column_stack([0.5 * (actions[:, 0] + 1.0) * MAX_SPEED,
                            wrap_angle(np.asarray(heading, dtype=float) + actions[:, 1] * HEADING_RANGE),
                            np.maximum(MIN_DEPTH, np.asarray(depth, dtype=float) + actions[:, 2] * DEPTH_RANGE)])


def step_info(collided, depth, distance, ranges, previous_achieved, route=None) -> dict[str, np.ndarray]:
    """A 3-D planning step's info (`Planning3D.after_step`'s `last_info`) over a batch axis: the event ("collision":
    the hull touches something; else "left_map": shallower than MIN_DEPTH; else "goal": within GOAL_RADIUS of the goal;
    else ""), its flags, the closest fan range, the true depth [m], the distance to the goal [m], the achieved goal
    before the step and the reward's goal-independent part. `collided`, `depth`, `distance` (N,); `ranges` (N, 27),
    the fan as sensed; `previous_achieved` (N, GOAL_SIZE). Under reward="geodesic" `route` is (the route length left
    before the step (N,), after it (N,), the goal (N, 3)): the info then holds "route_distance_before",
    "route_distance" (0 on success) and "step_goal"."""
    collided = np.asarray(collided, dtype=bool)
    depth, distance = np.asarray(depth, dtype=float), np.asarray(distance, dtype=float)
    left_map = ~collided & (depth < MIN_DEPTH)
    goal = ~collided & ~left_map & (distance < GOAL_RADIUS)
    event = np.full(collided.shape, "", dtype=object)
    event[collided], event[left_map], event[goal] = "collision", "left_map", "goal"
    failed = collided | left_map
    extra = {}
    if route is not None:
        before, after, step_goal = (np.asarray(v, dtype=float) for v in route)
        extra = {"route_distance_before": before, "route_distance": np.where(goal, 0.0, after),
                 "step_goal": step_goal}
    return {**extra, "event": event, "success": goal, "is_success": goal.copy(), "collision": collided,
            "left_map": left_map, "min_clearance": np.min(ranges, axis=-1), "depth": depth, "distance": distance,
            "previous_achieved_goal": np.asarray(previous_achieved, dtype=float),
            "goal_independent_reward": -STEP_COST + np.where(failed, COLLISION_REWARD, 0.0)}


def privileged(route_distance, room, time_left, hard_tier, tube) -> np.ndarray:
    """info["privileged"] (N, len(PRIVILEGED_FIELDS)) of N vehicles from the route length left [m], the room [m],
    the time left [s] and the episode's tier (1: hard) and kind (1: along a tube), each (N,). For a critic: never in
    the actor's observation."""
    return np.stack([np.asarray(route_distance, dtype=float) / GOAL_DISTANCE_SCALE,
                     np.asarray(room, dtype=float) / SONAR_RANGE,
                     np.asarray(time_left, dtype=float) / PRIVILEGED_TIME_SCALE,
                     np.asarray(hard_tier, dtype=float), np.asarray(tube, dtype=float)], axis=1)


def planning_observation(head, achieved_goal, target, fan, memory=None) -> np.ndarray:
    """The planning observation (PLANNING_OBSERVATION, then the sonar map's scan if `memory` is given, then the fan /
    SONAR_RANGE) over leading axes, from `head`: the sensed (u, v, w, p, q, r, roll, pitch, depth, altitude [m]); the
    achieved goal (position and sensed heading); the target point; the map's scan (FAN_MEMORY_BEAMS, in [0, 1]:
    observation="fan-map"); and the 27 fan ranges as sensed [m]."""
    head = np.array(head, dtype=float)
    head[..., 9] = head[..., 9] / ALTIMETER_RANGE
    blocks = [head, target_features(achieved_goal, target)]
    if memory is not None:
        blocks.append(np.asarray(memory, dtype=float))
    return np.concatenate([*blocks, np.asarray(fan) / SONAR_RANGE], axis=-1)


def route_time_limit(length: float) -> float:
    """The time limit [s] of a 3-D route of `length` m: ROUTE_TIME_FACTOR times its time at the classical planners'
    CRUISE_SPEED plus ROUTE_TIME_MARGIN, in steps of ROUTE_TIME_STEP (the planar tunnel's rule at 1.5 m/s)."""
    seconds = ROUTE_TIME_FACTOR * float(length) / CRUISE_SPEED + ROUTE_TIME_MARGIN
    return ROUTE_TIME_STEP * math.ceil(seconds / ROUTE_TIME_STEP - 1e-9)


def path_length(path: np.ndarray) -> float:
    """The length [m] of the polyline `path` (K, 3)."""
    path = np.asarray(path, dtype=float).reshape(-1, 3)
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


class Planning3D(base.Task):
    """The planning layer in 3-D: (a_speed, a_heading, a_depth) every PLANNER_DT, a classical executor inside.

    Subclasses give the arena (`arena_root`), the start and the target: a goal (goal3d) or a look-ahead point
    along a path (tunnel3d)."""

    time_limit = GOAL_TIME_LIMIT
    """The least time limit [s] of an episode; a longer route's is longer (`episode_time_limit`)."""
    goal_in_observation = False
    """Whether "observation" holds the goal itself (relative): then a policy needs no desired_goal, and hindsight
    relabelling recomputes those entries (`relabel_observation`)."""
    goal_radius = GOAL_RADIUS

    ARENAS = ("random", "fixed")
    """The `arena` choices every planning task has (a task may take arena files too: `_arena_option`)."""

    def __init__(self, arena: str = "random", random=None, conditions="ideal", tier: str = "standard",
                 executor=None, reward: str = "progress", observation: str = "fan"):
        """`arena`: "random" (one per episode), "fixed" or (tunnel3d) a tube file; `conditions`: ocean
        (`auv_mj.sim.ocean3d`); `tier`: TIERS; `reward`: PLANNING_REWARDS (module docstring); `observation`:
        OBSERVATIONS; `executor`: None (the
        hand-set depth-heading S-plane), a name of
        `auv_mj.tasks.executors.executor_names("auv3d")` (or a depth_heading checkpoint path), or a callable
        executor(command, State3D) -> (thrust [N], rudder [rad], stern [rad]) with `reset()`, called every
        EXECUTOR_DT."""
        self._arena_mode = self._arena_option(arena)
        self.tier = options.choice("tier", tier, TIERS)
        self.reward_kind = options.choice("reward", reward, PLANNING_REWARDS)
        self.observation_kind = options.choice("observation", observation, OBSERVATIONS)
        self.memory: VoxelMemory | None = None
        """The vehicle's own sonar map this episode under observation="fan-map" (`remember`), else None."""
        self.fan_filter = FanFilter() if self.observation_kind == "fan-held" else None
        """The fan's filter over pings under observation="fan-held" (`observe`; the batched env calls it too), else
        None."""
        self._ping_poses: collections.deque = collections.deque(maxlen=1)
        self._remembered_at = math.nan
        self._scan = np.zeros(FAN_MEMORY_BEAMS)
        self._sites = (np.zeros(3), np.zeros(3))
        self.potential: VoxelField | None = None
        """The geodesic field of the episode's goal once searched (`geodesic_potential`; at the reset under
        reward="geodesic"), else None."""
        self._episode_arena = None
        self._steering: dict[tuple, VoxelField] = {}
        self._oracle_maps: dict[frozenset[str], tuple] = {}
        self._plugs: dict[str, np.ndarray] = {}
        self._seen_plugs: set[str] = set()
        self.route_distance = math.nan
        """reward="geodesic": the route length left [m] where the last step ended (at the reset, the start's)."""
        self.movers: list[tuple[int, tubes.TubeMover]] = []
        """(mocap index, track) of each moving obstacle of the arena."""
        self.ocean = ocean3d.Ocean3D(conditions)
        self.sensors = Sensors3D(noise=self.ocean.noise)
        if isinstance(executor, str):
            from auv_mj.tasks.executors import named_executor  # the learned ones load torch: only when named

            executor = named_executor(executor, DOMAIN)
        if executor is not None and not (callable(executor) and hasattr(executor, "reset")):
            raise ValueError(f"task option executor must be an executor(command, state) with reset() or its name, "
                             f"got {options.shown(executor)}")
        self.executor = executor if executor is not None else DepthHeadingController()
        self.command = (0.0, 0.0, START_DEPTH)
        self.path = np.zeros((0, 3))
        self.goal = np.zeros(3)
        self.route = np.zeros((0, 3))
        """The episode's route (K, 3) [m], whose length sets its time limit (`episode_time_limit`): the tube's
        centreline, a hard arena's certificate or the straight line to the goal (module docstring)."""
        self.tube_radius: float | None = None
        """The inner radius [m] of the episode's tube (tunnel3d), None in open water: what a planner's protection
        domain is sized to (`auv_mj.planners.los3d.tube_field`)."""
        self.last_info: dict = {}
        self._loaded_xml = None
        self._desired = np.zeros(GOAL_SIZE)
        self._achieved = np.zeros(GOAL_SIZE)
        super().__init__(random=options.seed(random))

    @property
    def desired_goal(self) -> np.ndarray:
        """The episode's desired_goal (GOAL_SIZE): the goal, with the heading of the way into it."""
        return self._desired.copy()

    @property
    def achieved_goal(self) -> np.ndarray:
        """The achieved_goal of the last observation (GOAL_SIZE): the position and the sensed heading."""
        return self._achieved.copy()

    @property
    def max_pitch(self) -> float:
        """The executor's pitch limit [rad], which the hard arenas' certified paths climb and dive within: its
        S-plane's, or the hand-set S-plane's for an executor with no gains of its own."""
        return (getattr(self.executor, "gains", None) or DepthHeadingGains()).max_pitch

    # subclass hooks
    def _arena_option(self, arena) -> str:
        """The arena mode of option `arena` (ValueError naming it)."""
        return options.choice("arena", arena, self.ARENAS)

    def draw_arena(self, random: np.random.RandomState):  # -> (arena root, start (3,), heading, goal (3,), path)
        raise NotImplementedError

    def target(self, position: np.ndarray) -> np.ndarray:
        """The point the observation and line of sight steer to."""
        return self.goal

    def goal_heading(self, start: np.ndarray) -> float:
        """The heading of desired_goal: that of the way into the goal (here the straight line from the start)."""
        offset = self.goal - np.asarray(start, dtype=float)
        return math.atan2(offset[1], offset[0])

    def episode_route(self, start: np.ndarray) -> np.ndarray:
        """The route (K, 3) [m] of the episode just drawn: its global path from `start`, or the straight line from
        `start` to the goal where it has none."""
        if len(self.path) >= 2:
            return self.path.copy()
        return np.vstack([np.asarray(start, dtype=float), self.goal])

    @property
    def episode_time_limit(self) -> float:
        """This episode's time limit [s]: `route_time_limit` of its route's length, at least `time_limit`."""
        return max(self.time_limit, route_time_limit(path_length(self.route)))

    def known_time_limit(self) -> float:
        """The time limit [s] known before an episode is drawn (what a progress bar counts to before the first
        reset): here the least, `time_limit`."""
        return self.time_limit

    def initialize_episode(self, physics: Physics3D) -> None:
        random = np.random.RandomState(FIXED_ARENA_SEED) if self._arena_mode == "fixed" else self.random
        root, start, heading, goal, path = self.draw_arena(random)
        xml, source = arena3d.compose_xml(root, thruster_lag=self.ocean.conditions.thruster_lag)
        if self._loaded_xml != xml:  # recompile only for a new arena
            physics.reload_from_xml_string(xml, source=source)
            self._loaded_xml = xml
        self.goal, self.path = np.asarray(goal, dtype=float), np.asarray(path, dtype=float).reshape(-1, 3)
        tube = tubes.tube_from_arena(root) if len(self.path) >= 2 else None
        self.tube_radius = None if tube is None else float(tube.radius)
        self.route = self.episode_route(start)
        model = physics.model.ptr
        self.movers = [(int(model.body_mocapid[model.body(f"mover_{m.name}").id]), m)
                       for m in tubes.items_from_arena(root)[1]]
        self._move(physics)
        self._episode_arena = (traps3d.Arena3D(root, np.asarray(start, dtype=float), float(heading), self.goal,
                                               self.path, ""), None if tube is None else (self.path, tube.radius))
        self.potential = None
        self._oracle_maps = {}
        self._steering = {}
        self._plugs = traps3d.plug_centres(root)
        self._seen_plugs: set[str] = set()
        if self.reward_kind == "geodesic":
            self.route_distance = float(self.geodesic_potential().distance(start)[0])
        self._desired = pose_goal(self.goal, self.goal_heading(start))
        set_pose(physics, start, yaw=heading, nu=(1.0, 0, 0, 0, 0, 0))
        physics.reset_fins()
        self.command = (1.0, heading, -float(start[2]))
        self.executor.reset()
        self.sensors.reset()
        self.ocean.start(physics, self.random)
        physics.set_tick(self._tick, EXECUTOR_DT)
        self._achieved = pose_goal(physics.position(), heading)
        if self.observation_kind == "fan-map":
            self.memory = VoxelMemory(memory_grid3d(start, self.goal, self.path, self.tube_radius is not None))
            self._ping_poses = collections.deque(maxlen=1 + self.ocean.sonar_latency)
            model = physics.model.ptr
            self._sites = (model.site_pos[model.site("sonar").id].copy(),
                           model.site_pos[model.site("altimeter").id].copy())
        self._remembered_at = math.nan
        if self.fan_filter is not None:
            self.fan_filter.reset()
        self.last_info = {}  # a reset's info is its own, not the last episode's end (as the planar tasks')
        if self.reward_kind == "geodesic":
            self.last_info["privileged"] = self._privileged(physics)[0]
        super().initialize_episode(physics)

    def geodesic_potential(self) -> VoxelField:
        """The geodesic field of this episode's goal on its arena's true static map (`traps3d.geodesic_field`: the
        oracle's voxels, a tube's inside, the surface a wall in open water), searched at the first call of the episode
        (at the reset under reward="geodesic") and kept: the reward's potential."""
        if self.potential is None:
            arena, corridor = self._episode_arena
            self.potential = traps3d.geodesic_field(arena, self.max_pitch, None if corridor is not None else MIN_DEPTH,
                                                    GOAL_RADIUS, corridor, mapped=self._static_map())
        return self.potential

    def _static_map(self, hidden: frozenset[str] = frozenset()) -> tuple:
        """The oracle's voxel map of this episode's static geoms (`traps3d.oracle_map`) but those named in `hidden`,
        made once an episode for each `hidden`."""
        if hidden not in self._oracle_maps:
            arena, corridor = self._episode_arena
            if hidden:
                arena = traps3d.without_geoms(arena, hidden)
            self._oracle_maps[hidden] = traps3d.oracle_map(arena, None if corridor is not None else MIN_DEPTH,
                                                           corridor, static_only=True)
        return self._oracle_maps[hidden]

    def steering_field(self, open_water_slope: float | None = None,
                       hidden: frozenset[str] = frozenset()) -> VoxelField:
        """This episode's field weighed by the oracle's soft clearance (`traps3d.geodesic_field(soft=True)`), searched
        at the first call of the episode and kept: the way down it (`VoxelField.next_hop`) is a privileged teacher's
        map (`auv_mj.planners.teacher3d`), never a learner's input. `open_water_slope` [rad]: the steepest climb of its
        lattice in open water (None: the certificate's, max_pitch times CLIMB_MARGIN; a tube's is always that).
        `hidden`: geoms left off the map (`unseen_plugs`: a teacher that knows a plug only once near it)."""
        key = (open_water_slope, hidden)
        if self._steering.get(key) is None:
            arena, corridor = self._episode_arena
            pitch = self.max_pitch if corridor is not None or open_water_slope is None \
                else open_water_slope / CLIMB_MARGIN
            self._steering[key] = traps3d.geodesic_field(arena, pitch, None if corridor is not None else MIN_DEPTH,
                                                         GOAL_RADIUS, corridor, soft=True,
                                                         mapped=self._static_map(hidden))
        return self._steering[key]

    def unseen_plugs(self, position, horizon: float) -> frozenset[str]:
        """The plugs of this episode's tube (`traps3d.plug_centres`) whose centre the vehicle has not yet come within
        `horizon` [m] of, counting `position` (3,): what a teacher limited to a sensing horizon does not know. The
        plugs seen are kept until the next reset."""
        position = np.asarray(position, dtype=float)
        self._seen_plugs.update(name for name, centre in self._plugs.items()
                                if np.linalg.norm(centre - position) <= horizon)
        return frozenset(self._plugs) - frozenset(self._seen_plugs)

    def _privileged(self, physics) -> np.ndarray:
        """info["privileged"] (1, len(PRIVILEGED_FIELDS)) of the vehicle now (`privileged`)."""
        position = physics.position()[None]
        return privileged([self.route_distance], voxel_room([self.potential], position),
                          [self.episode_time_limit - physics.time()], [self.tier == "hard"], [len(self.path) >= 2])

    def _move(self, physics: Physics3D) -> None:
        """Puts the moving obstacles where their tracks have them now."""
        for slot, mover in self.movers:
            physics.data.ptr.mocap_pos[slot] = mover.position(physics.time())

    def _tick(self, physics: Physics3D) -> None:
        self._move(physics)
        self.ocean.tick(physics)
        state = read_state(physics, self.sensors.read(physics))
        physics.set_control(self.executor(self.command, state))

    def _target_distance(self, physics) -> float:
        return float(goal_distance(physics.position(), self.goal))

    def action_spec(self, physics) -> specs.BoundedArray:
        return specs.BoundedArray((3,), float, -1.0, 1.0, name="speed,heading,depth")

    def before_step(self, action, physics) -> None:
        a = checked_action(action, self.action_spec(physics), self)
        command = planning_command(np.asarray(a, dtype=float)[None], np.array([physics.heading()]),
                                   np.array([physics.depth()]))
        self.command = tuple(command[0].tolist())

    def _collided(self, physics) -> bool:
        model, data = physics.model.ptr, physics.data.ptr
        hull = model.geom("hull").id
        return any(hull in (data.contact[i].geom1, data.contact[i].geom2) for i in range(data.ncon))

    def after_step(self, physics) -> None:
        ranges = self.sensors.read(physics)["sonar"]
        route = None
        if self.potential is not None:
            route = (np.array([self.route_distance]), self.potential.distance(physics.position()), self.goal[None])
        info = step_info(np.array([self._collided(physics)]), np.array([physics.depth()]),
                         np.array([self._target_distance(physics)]), ranges[None], self._achieved[None].copy(), route)
        if route is not None:
            self.route_distance = float(info["route_distance"][0])
        self.last_info = {key: value[0].copy() if value.ndim > 1 else value[0] if value.dtype == object
                          else value.tolist()[0] for key, value in info.items()}
        if route is not None:
            self.last_info["privileged"] = self._privileged(physics)[0]
        # the reward is compute_reward's: one definition for the step and for relabelled goals
        self._reward = float(self.compute_reward(pose_goal(physics.position(), 0.0), self._desired, self.last_info))

    def observe(self, physics) -> np.ndarray:
        """PLANNING_OBSERVATION, then (observation="fan-map") the sonar map's scan, then the fan ranges over
        SONAR_RANGE (observation="fan-held": filtered over pings) (and sets the achieved goal)."""
        sensed = self.sensors.read(physics)
        state = read_state(physics, sensed)
        position = physics.position()
        self._achieved = pose_goal(position, state.heading)
        head = [state.u, state.v, state.w, state.p, state.q, state.r, state.roll, state.pitch, state.depth,
                float(sensed["altimeter"])]
        memory = None
        if self.memory is not None:
            if self._remembered_at != physics.time():  # one ping a planner step, however often this is called
                self._remembered_at = physics.time()
                self._scan = self.remember(position, sensed["attitude"], sensed["sonar"], float(sensed["altimeter"]),
                                           state.heading)
            memory = self._scan
        fan = sensed["sonar"] if self.fan_filter is None else self.fan_filter(physics.time(), sensed["sonar"])
        return planning_observation(np.array(head), self._achieved, self.target(position), fan, memory)

    def remember(self, position, attitude, fan, altitude: float, heading: float) -> np.ndarray:
        """Adds the ping seen now to the episode's sonar map (observation="fan-map") and returns the map's scan
        (FAN_MEMORY_BEAMS, `VoxelMemory.scan`) from `position` (3,) [m] at the sensed `heading` [rad]. The fan's
        ranges `fan` (27,) [m] were taken `Ocean3D.sonar_latency` pings ago (a planner step is one ping), so they are
        cast from the pose of then (as `map-replan`'s, `auv_mj.planners.map_planner3d.SonarVoxelMap.beams`); the
        altimeter's `altitude` [m] from now. The pose is the true position and the attitude sample held
        (`attitude` (w, x, y, z)), what the single and the batched env both hold."""
        pose = (np.asarray(position, dtype=float).copy(), np.asarray(attitude, dtype=float).copy())
        self._ping_poses.append(pose)
        origins, directions, limits = fan_beams(pose[0], pose[1], *self._sites, ping_pose=self._ping_poses[0])
        self.memory.add_beams(origins, directions, np.append(np.asarray(fan, dtype=float), altitude), limits)
        return self.memory.scan(pose[0], heading)

    def observation_spec(self, physics) -> collections.OrderedDict:
        """"observation" (PLANNING_OBSERVATION, the map's scan under observation="fan-map", and the fan),
        "achieved_goal" and "desired_goal" (GOAL_SIZE)."""
        size = len(PLANNING_OBSERVATION) + FAN_BEAMS + (FAN_MEMORY_BEAMS if self.observation_kind == "fan-map" else 0)
        return collections.OrderedDict(observation=specs.Array((size,), float, name="observation"),
                                       achieved_goal=specs.Array((GOAL_SIZE,), float, name="achieved_goal"),
                                       desired_goal=specs.Array((GOAL_SIZE,), float, name="desired_goal"))

    def get_observation(self, physics) -> collections.OrderedDict:
        """The goal dict: "observation", "achieved_goal" (the vehicle), "desired_goal" (the goal)."""
        observation = self.observe(physics)
        return collections.OrderedDict(observation=observation, achieved_goal=self._achieved.copy(),
                                       desired_goal=self._desired.copy())

    def get_reward(self, physics) -> float:
        return float(getattr(self, "_reward", 0.0))

    def get_termination(self, physics):
        return 0.0 if self.last_info.get("event") else None

    # --- goal-conditioned API (hindsight relabelling) -------------------------------------------------------

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """The reward of steps that reached `achieved_goal` had the goal been `desired_goal`: PROGRESS_WEIGHT per
        metre gained on it, GOAL_REWARD on coming within GOAL_RADIUS (unless the step failed), and the step's
        goal-independent part (STEP_COST, COLLISION_REWARD). `info`: a step's `last_info` (or a sequence / a dict of
        arrays of them) with "previous_achieved_goal", "goal_independent_reward", "collision" and "left_map".

        reward="geodesic": `planning_rewards.geodesic_reward` of the route lengths left before and after the step,
        exactly the step's where `desired_goal` is its own goal (info "step_goal", "route_distance_before",
        "route_distance", "success"); for a relabelled goal, which has no field (a search per sample), shaped on the
        straight distance to its region, the geodesic of open water, with the bonus where it is reached without a
        failure (as the planar tasks' `PlanningTask.compute_reward`)."""
        previous = info_field(info, "previous_achieved_goal")
        after = goal_distance(achieved_goal, desired_goal)
        failed = info_field(info, "collision").astype(bool) | info_field(info, "left_map").astype(bool)
        reached = (after < GOAL_RADIUS) & ~failed
        if self.reward_kind == "geodesic":
            desired = np.asarray(desired_goal, dtype=float)
            own = np.all(desired[..., :3] == info_field(info, "step_goal"), axis=-1)
            straight_before = np.maximum(goal_distance(previous, desired) - GOAL_RADIUS, 0.0)
            straight_after = np.where(reached, 0.0, np.maximum(after - GOAL_RADIUS, 0.0))
            return geodesic_reward(np.where(own, info_field(info, "route_distance_before"), straight_before),
                                   np.where(own, info_field(info, "route_distance"), straight_after),
                                   np.where(own, info_field(info, "success").astype(bool), reached), failed)
        return (PROGRESS_WEIGHT * (goal_distance(previous, desired_goal) - after) + np.where(reached, GOAL_REWARD, 0.0)
                + info_field(info, "goal_independent_reward"))

    def compute_terminated(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Whether a step ends the episode had `desired_goal` been the goal: reached, collided or broached."""
        failed = info_field(info, "collision").astype(bool) | info_field(info, "left_map").astype(bool)
        return (goal_distance(achieved_goal, desired_goal) < GOAL_RADIUS) | failed

    def relabel_observation(self, observation, achieved_goal, desired_goal) -> np.ndarray:
        """The observation had `desired_goal` been the goal (vectorised over rows): with the goal in the observation
        (goal3d) its TARGET_ENTRIES are recomputed from `achieved_goal`; otherwise it is unchanged."""
        observation = np.array(observation, dtype=float, copy=True)
        if self.goal_in_observation:
            observation[..., TARGET_ENTRIES] = target_features(achieved_goal, desired_goal)
        return observation


class Goal3D(Planning3D):
    """Reach a goal in 3-D among obstacles over a seabed (module docstring)."""

    goal_in_observation = True

    def __init__(self, *args, **kwargs):
        self._certificate: np.ndarray | None = None
        super().__init__(*args, **kwargs)

    def draw_arena(self, random: np.random.RandomState):
        """A hard arena (`traps3d.hard_goal_arena`, keeping the oracle's certificate as the route) or a standard
        one (`tubes.goal_arena`)."""
        if self.tier == "hard":
            arena = traps3d.hard_goal_arena(random, WATER_DEPTH, self.max_pitch, MIN_DEPTH, GOAL_RADIUS)
            self._certificate = arena.route
            return arena.as_tuple()
        self._certificate = None
        return tubes.goal_arena(random, WATER_DEPTH)

    def episode_route(self, start: np.ndarray) -> np.ndarray:
        """A hard arena's route is the oracle's certificate (from the start to within GOAL_RADIUS of the goal, at a
        flyable pitch round or over what is in the way), a standard one's the straight line to the goal."""
        if self._certificate is not None and len(self._certificate):
            return np.vstack([np.asarray(start, dtype=float), self._certificate])
        return super().episode_route(start)


class Tunnel3D(Planning3D):
    """Follow a tube to its end (module docstring); an episode's time limit is its centreline's (`route_time_limit`),
    at least TUNNEL_TIME_LIMIT."""

    time_limit = TUNNEL_TIME_LIMIT

    def _arena_option(self, arena) -> str:
        """"random", "fixed", or a tube arena file (`auv-mj tunnel --tube`, or written by hand), which must pass
        `auv-mj check-arena`."""
        if isinstance(arena, str) and arena in self.ARENAS:
            return arena
        if not isinstance(arena, (str, Path)):
            raise ValueError(f"task option arena must be one of 'random', 'fixed' or a tube arena file "
                             f"(`auv-mj tunnel --tube`), got {arena!r:.60}")
        if not Path(arena).is_file():
            raise ValueError(f"task option arena: no such file {str(arena)!r:.200} (give 'random', 'fixed' or a tube "
                             "arena file from `auv-mj tunnel --tube`)")
        if not tubes.is_tube_arena(arena):
            raise ValueError(f"{arena}: not a tube arena (no tube_centreline numeric): tunnel3d flies tubes made by "
                             "`auv-mj tunnel --tube`; planar tunnels are for the task tunnel")
        arena_check.require_usable(arena)
        root = parse_xml(read_text(Path(arena), "tube arena", MAX_XML_BYTES), str(arena), "tube arena")
        self._file = (root, tubes.tube_from_arena(root))
        return "file"

    def draw_arena(self, random: np.random.RandomState):
        if self._arena_mode == "file":
            root, tube = self._file
        elif self.tier == "hard":
            return traps3d.hard_tube(random, self.max_pitch).as_tuple()
        else:
            tube = tubes.random_tube(random)
            root = tubes.tube_arena(tube)
        return root, tube.centreline[0], tube.start_heading(), tube.centreline[-1], tube.centreline

    def known_time_limit(self) -> float:
        """A tube file's time limit [s] (its centreline is known before any episode), else `time_limit`."""
        if self._arena_mode == "file":
            return max(self.time_limit, route_time_limit(self._file[1].length()))
        return self.time_limit

    def goal_heading(self, start: np.ndarray) -> float:
        """The heading of the tube's last segment: the way into its end."""
        if len(self.path) < 2:
            return super().goal_heading(start)
        d = self.path[-1] - self.path[-2]
        return math.atan2(d[1], d[0])

    def target(self, position: np.ndarray) -> np.ndarray:
        """The line-of-sight look-ahead point LOOKAHEAD metres on along the centreline (the goal before a tube)."""
        if len(self.path) < 2:
            return self.goal
        _, heading, depth = _los(position, self.path, LOOKAHEAD)
        return np.array([position[0] + LOOKAHEAD * math.cos(heading), position[1] + LOOKAHEAD * math.sin(heading),
                         -depth])




def _los(position, path, lookahead):
    return los_command(position, path, lookahead, CRUISE_SPEED)


def lookahead_targets(positions: np.ndarray, paths: np.ndarray, counts: np.ndarray,
                      lookahead: float = LOOKAHEAD) -> np.ndarray:
    """`Tunnel3D.target` of N vehicles at once (the batched env's, `auv_mj.tasks.vector3d`): the point `lookahead`
    metres on from each vehicle towards `los_command`'s look-ahead point along its path, at that point's depth.

    `positions` (N, 3); `paths` (N, K, 3), path i's first counts[i] points, the rest padding. The same arithmetic as
    `los_command` on a batch axis (equal to rounding: tests/tasks/test_vector_env_3d.py)."""
    positions, paths = np.asarray(positions, dtype=float), np.asarray(paths, dtype=float)
    counts = np.asarray(counts, dtype=int)
    n, k = paths.shape[:2]
    rows = np.arange(n)
    segments = np.diff(paths, axis=1)
    lengths = np.linalg.norm(segments, axis=-1)
    valid = np.arange(k - 1)[None, :] < (counts - 1)[:, None]
    to_start = positions[:, None, :] - paths[:, :-1]
    along = np.clip(np.sum(to_start * segments, axis=-1) / np.maximum(lengths ** 2, 1e-12), 0.0, 1.0)
    nearest = paths[:, :-1] + along[..., None] * segments
    gap = np.where(valid, np.linalg.norm(nearest - positions[:, None, :], axis=-1), np.inf)
    best = np.argmin(gap, axis=1) if k > 1 else np.zeros(n, dtype=int)
    arc = np.concatenate([np.zeros((n, 1)), np.cumsum(np.where(valid, lengths, 0.0), axis=1)], axis=1)
    last = paths[rows, counts - 1]
    total = arc[rows, counts - 1]
    if k > 1:
        s = arc[rows, best] + along[rows, best] * lengths[rows, best] + lookahead
        inside = (np.arange(k)[None, :] < counts[:, None]) & (arc <= s[:, None])
        j = np.minimum(np.sum(inside, axis=1) - 1, k - 2)
        share = (s - arc[rows, j]) / np.maximum(lengths[rows, j], 1e-12)
        target = paths[rows, j] + share[:, None] * segments[rows, j]
        on_path = (counts >= 2) & np.any(valid & (lengths > 0), axis=1) & (s < total)
        target = np.where(on_path[:, None], target, last)
    else:
        target = last
    heading = np.arctan2(target[:, 1] - positions[:, 1], target[:, 0] - positions[:, 0])
    return np.column_stack([positions[:, 0] + lookahead * np.cos(heading),
                            positions[:, 1] + lookahead * np.sin(heading), target[:, 2]])


class RouteEnvironment(control.Environment):
    """The environment of a 3-D planning task: its time limit is each episode's route's
    (`Planning3D.episode_time_limit`, set at every reset), or the `time_limit` a user gave for every episode.

    A given time_limit too short to fly an episode's route at CRUISE_SPEED is kept (a user may want short
    episodes), with a warning naming `time_limit`, the route's length and its own limit, once per environment."""

    def __init__(self, physics: Physics3D, task: Planning3D, time_limit: float | None, **kwargs):
        """`time_limit` [s]: None for the route's, else every episode's."""
        # until the first reset draws a route, the limit known without it
        super().__init__(physics, task, time_limit=task.known_time_limit() if time_limit is None else time_limit,
                         **kwargs)
        self.given_time_limit = time_limit
        """The user's time limit [s], or None: each episode's route sets its own."""
        self._warned = False

    def reset(self):
        time_step = super().reset()
        task = self._task
        route_limit = task.episode_time_limit
        if self.given_time_limit is None:
            self._step_limit = route_limit / (self._physics.timestep() * self._n_sub_steps)
        else:
            length = path_length(task.route)
            needed = length / CRUISE_SPEED
            if needed > self.given_time_limit and not self._warned:
                self._warned = True
                warnings.warn(f"auv-mj: time_limit={self.given_time_limit:g} s is shorter than the {needed:.0f} s "
                              f"this episode's {length:.0f} m route takes at the planners' {CRUISE_SPEED:g} m/s: "
                              f"its episodes will time out before the goal. Leave time_limit out for the route's "
                              f"own limit ({route_limit:g} s here) or give at least that.", UserWarning,
                              stacklevel=2)
        return time_step

    @property
    def time_limit(self) -> float:
        """The current episode's time limit [s] (the route's, or the given one)."""
        return self._step_limit * self._physics.timestep() * self._n_sub_steps


def _planning_env(task: Planning3D, time_limit: float | None, environment_kwargs, conditions) -> RouteEnvironment:
    time_limit = None if time_limit is None else options.time_limit(time_limit)
    environment_kwargs = options.environment_kwargs(environment_kwargs)
    physics = Physics3D.load(None, conditions)
    return RouteEnvironment(physics, task, time_limit, control_timestep=PLANNER_DT, **environment_kwargs)


@SUITE3D.add("planning")
def goal3d(time_limit: float | None = None, random=None, environment_kwargs=None,
           **task_kwargs) -> RouteEnvironment:
    """Reach a 3-D goal among obstacles over a seabed. `time_limit` [s]: by default each episode's route's
    (`route_time_limit` of the straight line to the goal, or of a hard arena's certified route; at least
    GOAL_TIME_LIMIT)."""
    return _planning_env(Goal3D(random=random, **task_kwargs), time_limit, environment_kwargs,
                         task_kwargs.get("conditions"))


@SUITE3D.add("planning")
def tunnel3d(time_limit: float | None = None, random=None, environment_kwargs=None,
             **task_kwargs) -> RouteEnvironment:
    """Follow a tube along an x, y, z centreline to its end. `time_limit` [s]: by default each episode's tube's
    (`route_time_limit` of its centreline's length; at least TUNNEL_TIME_LIMIT)."""
    return _planning_env(Tunnel3D(random=random, **task_kwargs), time_limit, environment_kwargs,
                         task_kwargs.get("conditions"))


def is_3d(env) -> bool:
    """Whether `env` is an environment of the "auv3d" domain (the 6-DOF vehicle)."""
    return isinstance(getattr(env, "physics", None), AUV3DPhysics)
