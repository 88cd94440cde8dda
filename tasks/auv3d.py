"""The suite domain "auv3d" (issue 32): the 6-DOF REMUS-100 (`models/auv6.xml`) in depth.

- `depth_heading`: the execution layer in 3-D. Each EXECUTOR_DT = 0.1 s the agent sees the command (V, psi,
  depth) and the vehicle's sensors and sets (thrust, rudder, stern), scaled from [-1, 1]^3 by the actuator
  ranges. The "paper" schedule is Sec. 4.2's (1 m/s, pi/12, the sway burst, the constant and the periodic
  force) extended to depth: a 5 m dive from 10 m at the start, and each disturbance with a vertical part
  (VERTICAL_SHARE of its horizontal force). Metrics add mae_depth [m] (`last_info["depth_error"]`). A learned
  executor can act through the S-plane instead (`residual`, `gains`, `base`, `observation`;
  `auv_mj.tasks.depth_executor`).
- `goal3d`: reach a goal in 3-D among obstacles over a seabed (`arena="random"` draws them).
- `tunnel3d`: follow a tube along an x, y, z centreline to its end (`auv_mj.arenas.tubes`; `arena="random"`
  draws procedural tubes with climbs, dives and bends).

The two planning tasks act every PLANNER_DT = 0.5 s, as the planar ones: the action (a_speed, a_heading,
a_depth) in [-1, 1]^3 sets the speed (0..MAX_SPEED), a heading offset (up to HEADING_RANGE) and a depth offset
(up to DEPTH_RANGE) for the depth-heading executor, which runs at 10 Hz inside the step: the classical one
(`auv_mj.tasks.auv3d_control`) unless the `executor` option gives another (a re-tuned or a learned one). Their
observation is what the vehicle can know: its motion and attitude, depth and altitude, the 27 fan ranges, and the
goal (or the tube's look-ahead point) relative to itself.

Every task takes `conditions` ("ideal", "ocean" or a mapping, `auv_mj.sim.ocean3d`).
"""

from __future__ import annotations

import auv_mj  # noqa: F401  # isort: skip  (first: it picks MuJoCo's OpenGL backend before dm_control loads)
import collections
import math
from collections.abc import Callable, Sequence

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import containers, rewards
from dm_env import specs

from auv_mj.arenas import arena3d, tubes
from auv_mj.geometry import wrap_angle
from auv_mj.sim import ocean3d
from auv_mj.sim.physics6 import AUV6Physics, euler_angles, set_pose
from auv_mj.sim.sensors3d import ALTIMETER_RANGE, Sensors3D
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import options
from auv_mj.tasks.actions import checked_action
from auv_mj.tasks.auv3d_control import (
    EXECUTOR_DT,
    SCHEDULED_GAINS,
    DepthHeadingController,
    DepthHeadingGains,
    State3D,
    los_command,
)
from auv_mj.tasks.clock import ExecutorClock
from auv_mj.tasks.depth_executor import SENSOR_NAMES, DepthExecutorMemory

SUITE3D = containers.TaggedTasks()
"""Task name -> factory of the "auv3d" domain."""
DOMAIN = "auv3d"

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
WATER_DEPTH = 60.0
"""Depth of the goal3d seabed [m]."""
COLLISION_REWARD, GOAL_REWARD, PROGRESS_WEIGHT, STEP_COST = -50.0, 50.0, 1.0, 0.01
MIN_DEPTH = 1.0
"""Shallower than this [m] is broaching: an episode ends in "left_map"."""
TUBE_INFLUENCE = 2.5
"""d0 [m] of the protection domain inside a tube: the walls are always within the open-water domain's 30 m, so
in a tube only echoes nearer than the wall at its nominal 3 m repel (those of a vehicle off the centreline)."""
LOOKAHEAD = 8.0
"""Line-of-sight look-ahead [m] along a tube's centreline."""


class Physics3D(ExecutorClock, AUV6Physics):
    """AUV6Physics with the executor's clock (`auv_mj.tasks.clock.ExecutorClock`): `set_tick(callback)` calls it every
    EXECUTOR_DT while stepping."""

    TICK_PERIOD = EXECUTOR_DT

    @classmethod
    def load(cls, arena=None, conditions=None) -> Physics3D:
        """The vehicle in `arena` (`auv_mj.arenas.arena3d.compose_xml`), lagged where `conditions` ask for it."""
        xml, source = arena3d.compose_xml(arena, thruster_lag=ocean3d.conditions(conditions).thruster_lag)
        return cls.from_xml_string(xml, source=source)


def read_state(physics: AUV6Physics, sensed: dict[str, np.ndarray]) -> State3D:
    """The executor's State3D from the sensors: DVL (u, v, w), gyro (p, q, r), AHRS attitude, pressure depth."""
    u, v, w = (float(x) for x in sensed["dvl"])
    p, q, r = (float(x) for x in sensed["gyro"])
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, sensed["attitude"])
    roll, pitch, heading = euler_angles(rotation.reshape(3, 3))
    return State3D(u, v, w, p, q, r, float(roll), float(pitch), float(heading), float(sensed["depth"]))


def _normalise(control_values: np.ndarray, physics: AUV6Physics) -> np.ndarray:
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

    def initialize_episode(self, physics: AUV6Physics) -> None:
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
                          "tracked": self._step >= SETTLE_STEPS, "success": met, "is_success": met}
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


def splane_policy(env, gains: DepthHeadingGains | None = None) -> Callable:
    """The classical executor (`DepthHeadingController`, with `gains` or the hand-set ones) as a policy(time_step)
    of a depth_heading env."""
    task, physics = env.task, env.physics
    controller = DepthHeadingController(gains)

    def policy(time_step) -> np.ndarray:
        if time_step.first():
            controller.reset()
        return _normalise(controller(task.command(physics), task.state(physics)), physics)

    policy.reset = controller.reset
    return policy


# --- planning tasks ------------------------------------------------------------------------------------------

PLANNING_OBSERVATION = ("u", "v", "w", "p", "q", "r", "roll", "pitch", "depth", "altitude", "target_distance",
                        "cos_target_bearing", "sin_target_bearing", "target_depth_offset")
"""The planning observation's first entries; the 27 fan ranges / SONAR_RANGE follow."""


class Planning3D(base.Task):
    """The planning layer in 3-D: (a_speed, a_heading, a_depth) every PLANNER_DT, a classical executor inside.

    Subclasses give the arena (`arena_root`), the start and the target: a goal (goal3d) or a look-ahead point
    along a path (tunnel3d)."""

    time_limit = GOAL_TIME_LIMIT

    def __init__(self, arena: str = "random", random=None, conditions="ideal", executor=None):
        """`arena`: "random" (one per episode) or "fixed"; `conditions`: ocean (`auv_mj.sim.ocean3d`); `executor`:
        None (the hand-set depth-heading S-plane) or a callable executor(command, State3D) -> (thrust [N],
        rudder [rad], stern [rad]) with `reset()`, called every EXECUTOR_DT (a re-tuned S-plane, a learned depth
        executor: `auv_mj.zoo.registry` turns names into these)."""
        self._arena_mode = options.choice("arena", arena, ("random", "fixed"))
        self.ocean = ocean3d.Ocean3D(conditions)
        self.sensors = Sensors3D(noise=self.ocean.noise)
        if executor is not None and not (callable(executor) and hasattr(executor, "reset")):
            raise ValueError(f"task option executor must be an executor(command, state) with reset(), got "
                             f"{options.shown(executor)} (names are resolved by `auv_mj.zoo.registry`)")
        self.executor = executor if executor is not None else DepthHeadingController()
        self.command = (0.0, 0.0, START_DEPTH)
        self.path = np.zeros((0, 3))
        self.goal = np.zeros(3)
        self.last_info: dict = {}
        self._loaded_key = None
        super().__init__(random=options.seed(random))

    # subclass hooks
    def draw_arena(self, random: np.random.RandomState):  # -> (arena root, start (3,), heading, goal (3,), path)
        raise NotImplementedError

    def target(self, position: np.ndarray) -> np.ndarray:
        """The point the observation and line of sight steer to."""
        return self.goal

    def initialize_episode(self, physics: Physics3D) -> None:
        seed = 0 if self._arena_mode == "fixed" else int(self.random.randint(2**31 - 1))
        root, start, heading, goal, path = self.draw_arena(np.random.RandomState(seed))
        if self._loaded_key != seed:
            xml, source = arena3d.compose_xml(root, thruster_lag=self.ocean.conditions.thruster_lag)
            physics.reload_from_xml_string(xml, source=source)
            self._loaded_key = seed
        self.goal, self.path = np.asarray(goal, dtype=float), np.asarray(path, dtype=float).reshape(-1, 3)
        set_pose(physics, start, yaw=heading, nu=(1.0, 0, 0, 0, 0, 0))
        physics.reset_fins()
        self.command = (1.0, heading, -float(start[2]))
        self.executor.reset()
        self.sensors.reset()
        self.ocean.start(physics, self.random)
        physics.set_tick(self._tick, EXECUTOR_DT)
        self._distance = self._target_distance(physics)
        super().initialize_episode(physics)

    def _tick(self, physics: Physics3D) -> None:
        self.ocean.tick(physics)
        state = read_state(physics, self.sensors.read(physics))
        physics.set_control(self.executor(self.command, state))

    def _target_distance(self, physics) -> float:
        return float(np.linalg.norm(self.goal - physics.position()))

    def action_spec(self, physics) -> specs.BoundedArray:
        return specs.BoundedArray((3,), float, -1.0, 1.0, name="speed,heading,depth")

    def before_step(self, action, physics) -> None:
        a = checked_action(action, self.action_spec(physics), self)
        speed = 0.5 * (float(a[0]) + 1.0) * MAX_SPEED
        self.command = (speed, wrap_angle(physics.heading() + float(a[1]) * HEADING_RANGE),
                        max(MIN_DEPTH, physics.depth() + float(a[2]) * DEPTH_RANGE))

    def _collided(self, physics) -> bool:
        model, data = physics.model.ptr, physics.data.ptr
        hull = model.geom("hull").id
        return any(hull in (data.contact[i].geom1, data.contact[i].geom2) for i in range(data.ncon))

    def after_step(self, physics) -> None:
        distance = self._target_distance(physics)
        progress, self._distance = self._distance - distance, distance
        event = ""
        if self._collided(physics):
            event = "collision"
        elif physics.depth() < MIN_DEPTH:
            event = "left_map"
        elif distance < GOAL_RADIUS:
            event = "goal"
        ranges = self.sensors.read(physics)["sonar"]
        self.last_info = {"event": event, "success": event == "goal", "is_success": event == "goal",
                          "collision": event == "collision", "min_clearance": float(np.min(ranges)),
                          "depth": physics.depth(), "distance": distance}
        self._reward = (PROGRESS_WEIGHT * progress - STEP_COST + (GOAL_REWARD if event == "goal" else 0.0)
                        + (COLLISION_REWARD if event in ("collision", "left_map") else 0.0))

    def observe(self, physics) -> np.ndarray:
        """PLANNING_OBSERVATION, then the fan ranges over SONAR_RANGE."""
        sensed = self.sensors.read(physics)
        state = read_state(physics, sensed)
        offset = self.target(physics.position()) - physics.position()
        bearing = wrap_angle(math.atan2(offset[1], offset[0]) - state.heading)
        head = [state.u, state.v, state.w, state.p, state.q, state.r, state.roll, state.pitch, state.depth,
                float(sensed["altimeter"]) / ALTIMETER_RANGE, float(np.linalg.norm(offset)), math.cos(bearing),
                math.sin(bearing), -float(offset[2])]
        return np.concatenate([head, sensed["sonar"] / SONAR_RANGE])

    def get_observation(self, physics) -> collections.OrderedDict:
        return collections.OrderedDict(observation=self.observe(physics))

    def get_reward(self, physics) -> float:
        return float(getattr(self, "_reward", 0.0))

    def get_termination(self, physics):
        return 0.0 if self.last_info.get("event") else None


class Goal3D(Planning3D):
    """Reach a goal in 3-D among obstacles over a seabed (module docstring)."""

    def draw_arena(self, random: np.random.RandomState):
        return tubes.goal_arena(random, WATER_DEPTH)


class Tunnel3D(Planning3D):
    """Follow a tube to its end (module docstring)."""

    time_limit = TUNNEL_TIME_LIMIT

    def draw_arena(self, random: np.random.RandomState):
        tube = tubes.random_tube(random)
        return tubes.tube_arena(tube), tube.centreline[0], tube.start_heading(), tube.centreline[-1], tube.centreline

    def target(self, position: np.ndarray) -> np.ndarray:
        """The line-of-sight look-ahead point LOOKAHEAD metres on along the centreline (the goal before a tube)."""
        if len(self.path) < 2:
            return self.goal
        _, heading, depth = _los(position, self.path, LOOKAHEAD)
        return np.array([position[0] + LOOKAHEAD * math.cos(heading), position[1] + LOOKAHEAD * math.sin(heading),
                         -depth])




def _los(position, path, lookahead):
    return los_command(position, path, lookahead, CRUISE_SPEED)


def _planning_env(task: Planning3D, time_limit: float, environment_kwargs, conditions) -> control.Environment:
    time_limit = options.time_limit(time_limit)
    environment_kwargs = options.environment_kwargs(environment_kwargs)
    physics = Physics3D.load(None, conditions)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=PLANNER_DT,
                               **environment_kwargs)


@SUITE3D.add("planning")
def goal3d(time_limit: float = GOAL_TIME_LIMIT, random=None, environment_kwargs=None,
           **task_kwargs) -> control.Environment:
    """Reach a 3-D goal among obstacles over a seabed."""
    return _planning_env(Goal3D(random=random, **task_kwargs), time_limit, environment_kwargs,
                         task_kwargs.get("conditions"))


@SUITE3D.add("planning")
def tunnel3d(time_limit: float = TUNNEL_TIME_LIMIT, random=None, environment_kwargs=None,
             **task_kwargs) -> control.Environment:
    """Follow a tube along an x, y, z centreline to its end."""
    return _planning_env(Tunnel3D(random=random, **task_kwargs), time_limit, environment_kwargs,
                         task_kwargs.get("conditions"))


def is_3d(env) -> bool:
    """Whether `env` is an environment of the "auv3d" domain (the 6-DOF vehicle)."""
    return isinstance(getattr(env, "physics", None), AUV6Physics)
