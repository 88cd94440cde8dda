"""A batched 6-DOF planning environment on Gymnasium's vector API: N REMUS-100s stepped in one process (issue 52).

`AUV3DVectorEnv(task_name, num_envs)` runs N episodes of one 3-D planning task ("goal3d", "tunnel3d"; any task
option, e.g. {"arena": "random", "tier": "hard", "conditions": "ocean"}) as a `gymnasium.vector.VectorEnv`;
`gymnasium.make_vec("auv_mj/Tunnel3D-v0", num_envs=64, vectorization_mode="vector_entry_point", task_kwargs={...})`
returns it. Spaces are the single env's (`auv_mj.tasks.gym_adapter.AUVGymEnv`: GoalEnv dict observations), batched.
It is the planar `auv_mj.tasks.vector.AUVVectorEnv`'s 6-DOF twin and shares its Gymnasium side (`GoalVectorEnv`:
seeds, the autoreset modes, the actions' checks, infos as dicts of arrays).

The contract: sub-environment i reset with seed s gives exactly `AUVGymEnv`'s episode for seed s -- the same
observations, rewards, terminated / truncated and info -- in ideal and ocean water (tests/tasks/test_vector_env_3d.py).
How:
- Each sub-environment keeps its own suite environment (task, physics, RandomState, ocean). A reset is that
  environment's own reset, in Python: arenas, routes and the ocean are drawn by the same code from the same
  generators, and the reset's observation is the task's.
- The step is `Planning3D.before_step`, the physics and `after_step` / `observe` over the batch: the action map
  (speed, heading and depth offsets from the true heading and depth), then one call of the C batch
  (`auv_mj.sim.batch3d`) over all stepped vehicles across `threads` threads: the five 10 Hz ticks (movers, current,
  sensors, the depth-heading S-plane) with the 50 physics steps, and the after-step read of the sensors (on two
  threads or more, the autoresets of the rows whose episode ended run meanwhile on a helper thread:
  `GoalVectorEnv._physics_alongside`). The
  sensors' sample-and-hold and noise stay the episode's: which sensors each read samples is `Sensors3D`'s rule
  (`sample_schedule`), and the noise is drawn here from the episode's own generator in the order `Ocean3D.noise`
  draws it (`draw_noise`); the fan's noise (`NoisySonar`, its own generator) is the episode's `Sensors3D.noise`
  called on the raw fan the step sampled. Then the events, the info and the reward (`Planning3D.compute_reward`,
  vectorised; under reward="geodesic" each episode's route length left from its own field, `voxel_distances` over
  the batch) and the observation (`target_features`, vectorised; tunnel3d's look-ahead point is `Tunnel3D.target`'s,
  `auv3d.lookahead_targets`) over the batch. Only the time limits (`RouteEnvironment`'s, each episode's) are here.
- An episode leaves nothing to the next: the DVL's last noisy sample (`Ocean3D.last_dvl`, what a dropout holds) is
  the episode's own, read from the sub-environment after its reset.

Autoreset: as `AUVVectorEnv`'s (NEXT_STEP by default; SAME_STEP puts the last observation and info in
info["final_obs"] and info["final_info"]). An autoreset continues the sub-environment's RandomState.

`auv-mj bench --sections vector3d` measures its steps per second beside the 6-DOF physics limit
(`auv_mj.speed.vector3d`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from dm_control.rl.control import PhysicsError
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from auv_mj.arenas.geodesic import voxel_distances, voxel_room
from auv_mj.arenas.sonar_memory import FAN_MEMORY_BEAMS
from auv_mj.control.depth_heading import (
    EXECUTOR_DT,
    FIN_LIMIT,
    SURGE_DRAG,
    THRUST_LIMIT,
    DepthHeadingController,
    DepthHeadingGains,
)
from auv_mj.sim import batch3d
from auv_mj.sim.ocean3d import DVL_DROPOUT
from auv_mj.sim.sensors3d import FAN_BEAMS, fan_directions
from auv_mj.tasks import auv3d, suite
from auv_mj.tasks import options as checks
from auv_mj.tasks.gym_adapter import gym_spaces
from auv_mj.tasks.vector import GoalVectorEnv

TASKS = ("goal3d", "tunnel3d")
"""The 3-D planning tasks the batch runs."""
READS = batch3d.READ_BITS
SAMPLE_ORDER = batch3d.SAMPLE_ORDER
_SCHEDULES: dict = {}
"""Memo of `sample_schedule` (the same step of every episode reads the same sensors)."""
_MAX_SCHEDULES = 100_000


def sample_schedule(start: float, due: tuple[float, ...], rates: tuple[float, ...], timestep: float, ticks: int,
                    substeps: int) -> tuple[tuple[int, ...], tuple[float, ...], int]:
    """Which sensors each read of a planner step samples, by `Sensors3D.read`'s rule: the step's `ticks` reads at its
    executor ticks and the after-step read, at the times the physics reaches from `start` in steps of `timestep`
    (accumulated as MuJoCo does). `due`: when each sensor of SAMPLE_ORDER next samples; `rates` [Hz]. Returns the
    reads' masks (bits READ_BITS), the `due` times after the step and how many reads sample the fan."""
    key = (start, due, rates, timestep, ticks, substeps)
    found = _SCHEDULES.get(key)
    if found is not None:
        return found
    due_now = list(due)
    masks = []
    time = start
    for read in range(ticks + 1):
        if read:
            for _ in range(substeps):
                time = time + timestep
        mask = 0
        for k, name in enumerate(SAMPLE_ORDER):
            if time >= due_now[k] - 1e-9:
                period = 1.0 / rates[k]
                due_now[k] = (math.floor(time / period + 1e-9) + 1) * period
                mask |= READS[name]
        masks.append(mask)
    if len(_SCHEDULES) > _MAX_SCHEDULES:
        _SCHEDULES.clear()
    found = _SCHEDULES[key] = (tuple(masks), tuple(due_now), sum(bool(m & READS["sonar"]) for m in masks))
    return found


def draw_noise(rng: np.random.Generator, masks, has_last_dvl: bool, out: np.ndarray) -> bool:
    """The sensors' noise of a step's reads (`masks`), drawn from the episode's generator `rng` in the order
    `Ocean3D.noise` draws it, into `out` in the order batch3d_kernel.c reads it: the altimeter's and the depth's
    normal, the DVL's dropout (1.0 dropped: only where a noisy sample is held already, `has_last_dvl`) and, if kept,
    its 3 normals, the gyro's and the accelerometer's 3 each. Consecutive normals are drawn in one call (the stream is
    the same). Returns whether a noisy DVL sample is held after the step."""
    at, run = 0, 0

    def flush() -> None:
        if run:
            out[at - run:at] = rng.standard_normal(run)

    for mask in masks:
        if mask & READS["altimeter"]:
            at, run = at + 1, run + 1
        if mask & READS["depth"]:
            at, run = at + 1, run + 1
        if mask & READS["dvl"]:
            flush()
            run = 0
            dropped = rng.random() < DVL_DROPOUT and has_last_dvl
            out[at] = 1.0 if dropped else 0.0
            at += 1
            if not dropped:
                at, run = at + 3, 3
                has_last_dvl = True
        if mask & READS["imu"]:
            at, run = at + 6, run + 6
    flush()
    return has_last_dvl


def executor_row(gains: DepthHeadingGains) -> np.ndarray:
    """The C batch's executor row (`auv_mj.sim.batch3d.GAINS`) of depth-heading gains."""
    return np.array([*(float(getattr(gains, f.name)) for f in dataclasses.fields(DepthHeadingGains)), EXECUTOR_DT,
                     THRUST_LIMIT, FIN_LIMIT, SURGE_DRAG])


class AUV3DVectorEnv(GoalVectorEnv):
    """N episodes of one 3-D planning task, stepped together in C (see the module docstring)."""

    def __init__(self, task_name: str, num_envs: int = 1, task_kwargs: Mapping[str, Any] | None = None,
                 environment_kwargs: Mapping[str, Any] | None = None, threads: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP):
        """`task_kwargs` go to every sub-environment's task factory (not "random": seed through `reset`; a
        "time_limit" replaces each episode's route time limit, as in the factory). `threads` (default: this process's
        CPUs) share out the physics."""
        checks.choice("task_name", task_name, TASKS)
        task_kwargs, environment_kwargs = self._configure(num_envs, threads, autoreset_mode, task_kwargs,
                                                          environment_kwargs)
        self.task_name, self.task_kwargs = task_name, task_kwargs
        self.envs = [suite.load(auv3d.DOMAIN, task_name, task_kwargs=task_kwargs,
                                environment_kwargs=environment_kwargs) for _ in range(self.num_envs)]
        first = self.envs[0]
        task = first.task
        if type(task.executor) is not DepthHeadingController:
            raise ValueError("task option executor: the 6-DOF vector env runs the depth-heading S-plane "
                             "(auv_mj.control.depth_heading.DepthHeadingController, any gains) only")
        if tuple(f.name for f in dataclasses.fields(DepthHeadingGains)) != batch3d.GAINS[:-4]:
            raise RuntimeError("auv_mj.sim.batch3d.GAINS is out of step with DepthHeadingGains' fields")
        self.single_observation_space, self.single_action_space, self._observe = gym_spaces(first)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._low = self.single_action_space.low.astype(float)
        self._high = self.single_action_space.high.astype(float)
        physics = first.physics
        self._timestep = float(physics.timestep())
        self._substeps = int(round(EXECUTOR_DT / self._timestep))
        substeps = first._n_sub_steps
        if physics.tick_steps not in (None, self._substeps) or substeps % self._substeps:
            raise ValueError(f"the planner step ({substeps} physics steps) must be whole executor periods of "
                             f"{self._substeps}")
        self._ticks = substeps // self._substeps
        if self._ticks + 1 > batch3d.MAX_READS:
            raise ValueError(f"a planner step of {self._ticks} executor periods is longer than the batch reads")
        self._goal_task = isinstance(task, auv3d.Goal3D)
        self._geodesic = task.reward_kind == "geodesic"
        self._fan_map = task.observation_kind == "fan-map"
        self._fan_held = task.observation_kind == "fan-held"
        self._fan = fan_directions()
        self._stepper = batch3d.BatchStepper3D(self.num_envs)
        self._allocate()

    # --- per-environment arrays ---------------------------------------------------------------------

    def _allocate(self) -> None:
        n = self.num_envs
        self._position = np.zeros((n, 3))
        self._previous_position = np.zeros((n, 3))
        self._time = np.zeros(n)
        """Each vehicle's physics time [s] (MuJoCo's data.time)."""
        self._heading = np.zeros(n)
        """Each vehicle's true heading [rad] (`AUV3DPhysics.heading`): what the action's heading offset adds to."""
        self._goal = np.zeros((n, 3))
        self._paths = np.zeros((n, 2, 3))
        """Each episode's path (tunnel3d: the tube's centreline), padded with its last point (`lookahead_targets`)."""
        self._path_counts = np.zeros(n, dtype=int)
        self._fields: list = [None] * n
        """reward="geodesic": each episode's geodesic field (`Planning3D.potential`)."""
        self._route_distance = np.full(n, np.nan)
        """reward="geodesic": each vehicle's route length left [m] where its last step ended."""
        self._route_limit = np.zeros(n)
        """Each episode's route time limit [s] (`Planning3D.episode_time_limit`: the privileged time left's)."""
        self._hard = np.zeros(n, dtype=bool)
        """Whether each episode is on the hard tier (the privileged input's)."""
        self._desired = np.zeros((n, auv3d.GOAL_SIZE))
        self._achieved = np.zeros((n, auv3d.GOAL_SIZE))
        self._sonar = np.zeros((n, FAN_BEAMS))
        """Each vehicle's held fan sample, noisy as the episode's sensors deliver it."""
        self._due = [()] * n
        self._rates = [()] * n
        self._has_last_dvl = np.zeros(n, dtype=bool)
        self._noise_rngs: list = [None] * n
        self._current_rngs: list = [None] * n
        self._steps = np.zeros(n, dtype=int)
        self._autoreset = np.zeros(n, dtype=bool)
        self._step_limit = np.full(n, np.inf)
        """Each episode's step limit (`RouteEnvironment`'s, from its route or the given time limit)."""
        self._last_obs = {key: np.zeros(space.shape) for key, space in self.observation_space.spaces.items()}
        self._reset_infos: list[dict] = [{} for _ in range(n)]

    def _load_episode(self, i: int) -> None:
        """Reads sub-environment i's freshly reset episode into the batch (see the module docstring)."""
        env = self.envs[i]
        task, physics = env.task, env.physics
        if physics.disturbance is not None:
            raise ValueError("the 6-DOF vector env steps vehicles without disturbances")
        if not physics.at_tick:
            raise RuntimeError("the sub-environment's executor clock is not at a tick after its reset")
        sensors = task.sensors
        if tuple(sensors.rates) != SAMPLE_ORDER:
            raise ValueError(f"the 6-DOF vector env reads the sensors {SAMPLE_ORDER}, got {tuple(sensors.rates)}")
        self._position[i] = physics.position()
        self._previous_position[i] = self._position[i]
        self._time[i] = physics.data.time
        self._heading[i] = physics.heading()
        self._goal[i] = task.goal
        self._put_path(i, task.path)
        self._fields[i] = task.potential
        self._route_distance[i] = task.route_distance
        self._route_limit[i] = task.episode_time_limit
        self._hard[i] = task.tier == "hard"
        self._desired[i] = task.desired_goal
        self._achieved[i] = task.achieved_goal
        self._steps[i] = 0
        self._step_limit[i] = env._step_limit
        due = sensors.due
        self._due[i] = tuple(due[name] for name in SAMPLE_ORDER)
        self._rates[i] = tuple(float(sensors.rates[name]) for name in SAMPLE_ORDER)
        held = sensors.held
        self._sonar[i] = held["sonar"]
        movers = [batch3d.mover_record(slot, m.start, m.end, m.speed) for slot, m in task.movers]
        self._stepper.bind(i, physics, executor_row(task.executor.gains),
                           np.concatenate(movers) if movers else np.zeros(0), self._fan)
        at = batch3d.STATE_INDEX
        state = self._stepper.state[i]
        state[:] = 0.0
        for k, name in enumerate(("speed_command", "heading_command", "depth_command")):
            state[at[name]] = task.command[k]
        state[at["int_speed"]:at["int_depth"] + 1] = task.executor.integrals
        last_u = task.executor.last_speed
        if last_u is not None:
            state[at["last_u"]], state[at["has_last_u"]] = last_u, 1.0
        state[at["ready"]] = float(physics.step_ready)
        state[at["altimeter"]] = held["altimeter"]
        state[at["depth"]] = held["depth"]
        for name in ("dvl", "gyro", "accelerometer", "attitude"):
            first = at[f"{name}_x" if name != "attitude" else "attitude_w"]
            state[first:first + len(held[name])] = held[name]
        ocean = task.ocean
        rng = ocean.noise_generator
        self._noise_rngs[i] = rng
        state[at["noise_on"]] = float(rng is not None)
        last_dvl = ocean.last_dvl
        self._has_last_dvl[i] = last_dvl is not None
        if last_dvl is not None:
            state[at["last_dvl_x"]:at["last_dvl_x"] + 3] = last_dvl
        self._load_current(i, ocean)

    def _put_path(self, i: int, path: np.ndarray) -> None:
        """Episode i's path into the padded paths (grown to the longest)."""
        count = len(path)
        if count > self._paths.shape[1]:
            grown = np.repeat(self._paths[:, -1:], count, axis=1)
            grown[:, :self._paths.shape[1]] = self._paths
            self._paths = grown
        self._path_counts[i] = count
        if count:
            self._paths[i, :count] = path
            self._paths[i, count:] = path[-1]

    def _load_current(self, i: int, ocean) -> None:
        """The current's processes and its depth profile into the stepper's rows."""
        at_state, at_parameter = batch3d.STATE_INDEX, batch3d.PARAMETER_INDEX
        parameters = self._stepper.parameters[i]
        current = ocean.current
        self._current_rngs[i] = None
        self._stepper.normals_end[i] = 0
        parameters[:] = 0.0
        if current is None:
            return
        if ocean.profile is not None:
            parameters[at_parameter["profile_on"]] = 1.0
            parameters[at_parameter["water_depth"]] = ocean.profile.water_depth
            parameters[at_parameter["exponent"]] = ocean.profile.exponent
        self._load_current_processes(i, current, ocean.time, at_state, at_parameter)

    # --- the batched step: Planning3D.before_step, the physics, after_step, get_observation ---------

    def _step_batch(self, index: np.ndarray, actions: np.ndarray, alongside: Callable[[], None] | None):
        at_state, at_out = batch3d.STATE_INDEX, batch3d.OUTPUT_INDEX
        stepper = self._stepper
        command = auv3d.planning_command(actions, self._heading[index], -self._position[index, 2])  # before_step
        stepper.state[index, at_state["speed_command"]:at_state["depth_command"] + 1] = command
        sonar_reads = 0
        schedules = []
        for i in index:
            masks, self._due[i], fans = sample_schedule(float(self._time[i]), self._due[i], self._rates[i],
                                                        self._timestep, self._ticks, self._substeps)
            schedules.append(masks)
            sonar_reads = max(sonar_reads, fans)
            rng = self._noise_rngs[i]
            if rng is not None:
                self._has_last_dvl[i] = draw_noise(rng, masks, bool(self._has_last_dvl[i]), stepper.noise[i])
            rng = self._current_rngs[i]
            if rng is not None:
                stepper.top_up(i, rng, 2 * self._ticks)
        if sonar_reads > 1:
            raise ValueError("the 6-DOF vector env samples the fan at most once a planner step")
        if len(index):
            stepper.masks[index, :self._ticks + 1] = schedules
        self._physics_alongside(index, lambda: stepper.step(index, self._ticks, self._substeps, self.threads),
                                alongside)
        out = stepper.out[index]
        if np.any(out[:, at_out["invalid"]] != 0):
            bad = index[out[:, at_out["invalid"]] != 0]
            raise PhysicsError(f"Physics state is invalid in sub-environment(s) {bad[:8].tolist()}: the 6-DOF step "
                               "diverged or MuJoCo reset it")
        position = out[:, at_out["x"]:at_out["z"] + 1]
        self._previous_position[index] = self._position[index]
        self._position[index], self._heading[index] = position, out[:, at_out["heading"]]
        self._time[index] = out[:, at_out["time"]]
        first_beam = at_out["sonar_1"]
        sampled = out[:, at_out["sonar_samples"]] != 0
        self._sonar[index[sampled]] = out[sampled, first_beam:first_beam + FAN_BEAMS]
        for k in np.flatnonzero(sampled):
            i = index[k]
            if self._noise_rngs[i] is not None:  # the fan's noise (Ocean3D.noise: NoisySonar), as the sensors add it
                self._sonar[i] = np.asarray(self.envs[i].task.sensors.noise("sonar", self._sonar[i].copy()),
                                            dtype=float)
        state = stepper.state[index]
        ranges = self._sonar[index]
        # Planning3D.after_step
        depth = -position[:, 2]
        route = None
        if self._geodesic:
            after = voxel_distances([self._fields[i] for i in index], position)
            route = (self._route_distance[index], after, self._goal[index])
        info = auv3d.step_info(out[:, at_out["collided"]] != 0, depth, auv3d.goal_distance(position, self._goal[index]),
                               ranges, self._achieved[index].copy(), route)
        if route is not None:
            self._route_distance[index] = info["route_distance"]
            info["privileged"] = auv3d.privileged(info["route_distance"], voxel_room([self._fields[i] for i in index],
                                                                                    position),
                                                  self._route_limit[index] - self._time[index], self._hard[index],
                                                  self._path_counts[index] >= 2)
        at_position = np.column_stack([position, np.ones(len(index)), np.zeros(len(index))])  # pose_goal(p, 0.0)
        reward = self.envs[0].task.compute_reward(at_position, self._desired[index], info)
        # Planning3D.observe, from the held samples
        heading = out[:, at_out["sensed_heading"]]
        achieved = np.column_stack([position, np.cos(heading), np.sin(heading)])
        self._achieved[index] = achieved
        if self._goal_task:
            target = self._goal[index]
        else:
            counts = self._path_counts[index]
            target = self._goal[index].copy()
            tube = counts >= 2  # Tunnel3D.target: the goal before a tube
            if np.any(tube):
                target[tube] = auv3d.lookahead_targets(position[tube], self._paths[index[tube]], counts[tube])
        head = np.column_stack([state[:, at_state["dvl_x"]:at_state["dvl_z"] + 1],
                                state[:, at_state["gyro_x"]:at_state["gyro_z"] + 1], out[:, at_out["roll"]],
                                out[:, at_out["pitch"]], state[:, at_state["depth"]], state[:, at_state["altimeter"]]])
        memory = None
        if self._fan_map:  # Planning3D.remember: each row's ping into its own sonar map, and the map's scan
            attitude = state[:, at_state["attitude_w"]:at_state["attitude_z"] + 1]
            altitude = state[:, at_state["altimeter"]]
            memory = np.zeros((len(index), FAN_MEMORY_BEAMS))
            for k, i in enumerate(index):
                memory[k] = self.envs[i].task.remember(position[k], attitude[k], ranges[k], float(altitude[k]),
                                                       float(heading[k]))
        fan = ranges
        if self._fan_held:  # Planning3D.observe: each row's fan through its own filter over pings
            fan = np.array([self.envs[i].task.fan_filter(self._time[i], ranges[k]) for k, i in enumerate(index)],
                           dtype=float).reshape(ranges.shape)
        observation = auv3d.planning_observation(head, achieved, target, fan, memory)
        self._last_obs["observation"][index] = observation
        self._last_obs["achieved_goal"][index] = achieved
        self._last_obs["desired_goal"][index] = self._desired[index]
        # RouteEnvironment: the step count and each episode's limit
        self._steps[index] += 1
        at_limit = self._steps[index] >= self._step_limit[index]
        truncated = at_limit
        terminated = ~at_limit & (info["event"] != "")
        return reward, terminated, truncated, self._batched_infos(index, info)

    def privileged_state(self, open_water_slope: float | None = None,
                         horizon: float | None = None) -> dict[str, Any]:
        """The true state of every row for a privileged teacher (`auv_mj.planners.teacher3d`; Chen et al. 2019),
        never a learner's input: each episode's steering field ("steering", `Planning3D.steering_field`: the true
        map's way to the goal, searched at the first call of an episode; with `horizon` [m], without the plugs the
        vehicle has not yet come within that of, `Planning3D.unseen_plugs`), the position ("position" (N, 3)), where
        the last step began ("previous_position"; the position itself after a reset) and the true heading
        ("heading" (N,)). Rows awaiting an autoreset still show the episode that ended."""
        hidden = [frozenset() if horizon is None else env.task.unseen_plugs(self._position[i], horizon)
                  for i, env in enumerate(self.envs)]
        return {"steering": [env.task.steering_field(open_water_slope, unseen)
                             for env, unseen in zip(self.envs, hidden, strict=True)],
                "position": self._position.copy(), "previous_position": self._previous_position.copy(),
                "heading": self._heading.copy()}

    def relabel_observation(self, observation, achieved_goal, desired_goal):
        """The task's observation had `desired_goal` been the goal (`Planning3D.relabel_observation`), vectorised."""
        return self.envs[0].task.relabel_observation(observation, achieved_goal, desired_goal)


SINGLE_ENV_OPTIONS = ("render_mode", "render_size", "render_distance")
"""`AUVGymEnv` options the batch does not implement (wrap single envs: vectorization_mode="sync" or "async")."""


def make_vector_env(num_envs: int = 1, task_name: str = "tunnel3d", **kwargs) -> AUV3DVectorEnv:
    """The `vector_entry_point` of the 3-D planning tasks' Gymnasium ids: what `gymnasium.make_vec` returns for them
    by default (vectorization_mode None or "vector_entry_point"); kwargs are `AUV3DVectorEnv`'s."""
    kwargs.pop("max_episode_steps", None)
    single = sorted(set(kwargs) & set(SINGLE_ENV_OPTIONS))
    if single:
        raise ValueError(f"{', '.join(single)}: options of the single env AUVGymEnv, not of the batched one; give "
                         "vectorization_mode='sync' or 'async' to vectorise single envs with them")
    return AUV3DVectorEnv(task_name, num_envs=num_envs, **kwargs)
