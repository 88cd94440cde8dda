"""A batched planning environment on Gymnasium's vector API: N planar vehicles stepped in one process (issue 45).

`AUVVectorEnv(task_name, num_envs)` runs N episodes of one planning task ("goal", "obstacles",
"moving_obstacles", "tunnel"; any task option, e.g. {"arena": "random", "tier": "hard", "conditions": "ocean"})
as a `gymnasium.vector.VectorEnv`; `gymnasium.make_vec("auv_mj/Obstacles-v0", num_envs=64,
vectorization_mode="vector_entry_point", task_kwargs={...})` returns it. Spaces are the single env's
(`auv_mj.tasks.gym_adapter.AUVGymEnv`: GoalEnv dict observations), batched with `batch_space`.

The contract: sub-environment i reset with seed s gives exactly `AUVGymEnv`'s episode for seed s -- the same
observations, rewards, terminated / truncated and info -- in ideal and ocean water (tests/test_vector_env.py).
How, without one Python step per environment:
- Each sub-environment keeps its own suite environment (task, physics, RandomState, ocean). A reset is that
  environment's own reset, in Python, so routes, arenas and the ocean are drawn by the same code from the same
  generators.
- A step is one call of the C batch (`auv_mj.sim.batch`) over all stepped vehicles, across `threads` threads:
  the five 10 Hz executor ticks (current, S-plane executor, movers, contacts) and the 50 physics steps, then the
  sonar and the clearance. NumPy's tanh and exp differ from libm's in the last bit, which a closed loop of 1,800
  steps would grow, so the executor runs in C with libm as the Python executor does with `math`.
- What the task does after the step (`PlanningTask.after_step`, `get_observation`, the time limits) is written
  here once more, vectorised over the batch with NumPy: goals, the passing rule, events, Eq. (23)-(26), the
  suite reward, the observation. Only the ocean's sonar noise stays per environment (its generator is the
  episode's own).
The batch reads the task's episode state after each reset (its command, route, movers, executor gains, the
current's processes); that coupling to `auv_mj.tasks.planning`'s internals is checked by the identity test.

Autoreset: `metadata["autoreset_mode"]` is `AutoresetMode.NEXT_STEP` by default, Gymnasium's own: the step
after a sub-environment's episode ended resets it (its action ignored) and returns the first observation with
reward 0, terminated and truncated False and the reset's info. `autoreset_mode=AutoresetMode.SAME_STEP`
resets in the step that ended the episode and puts the last observation and info in info["final_obs"] and
info["final_info"] (what Stable-Baselines3's `VecEnv` convention needs, `auv_mj.tasks.vector_sb3`). An autoreset
continues the sub-environment's RandomState, as `AUVGymEnv.reset()` without a seed does.

Infos are Gymnasium's dict of arrays, each key with its "_key" mask of the sub-environments that reported it.

`vector_bench(...)` measures environment steps per second of this env, beside the physics limit and Gymnasium's
and Stable-Baselines3's process-parallel vectors (`auv-mj bench --sections vector`).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np
from dm_control.rl.control import PhysicsError
from dm_control.utils import rewards
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from auv_mj.arenas.arena import SAFETY_DISTANCE
from auv_mj.control.splane import SPlaneController
from auv_mj.geometry import wrap_angle
from auv_mj.sim import batch
from auv_mj.sim.sonar import SONAR_RANGE, clip_ranges
from auv_mj.tasks import options as checks
from auv_mj.tasks import planning, suite
from auv_mj.tasks.actions import ActionClipped
from auv_mj.tasks.gym_adapter import GOAL_TASK_REWARD, VECTOR_TASKS, gym_spaces

TASKS = VECTOR_TASKS
"""The planning tasks the batch runs."""
MAX_ENVS = 65_536
"""Most sub-environments of one batch."""
MAX_THREADS = 64
"""Most threads of the C batch step (batch_kernel.c's MAX_THREADS)."""
AUTORESET_MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
"""The autoreset modes this env implements."""
STEP_INFO_KEYS = ("previous_achieved_goal", "goal_independent_reward", "reward_following", "reward_avoid",
                  "reward_navigation", "paper_reward", "collision", "left_map", "safety_violation", "success",
                  "is_success", "min_clearance", "min_sonar_range", "event", "goals_reached", "num_goals",
                  "last_goal", "steps_left", "goal_radius", "cross_track_error", "command", "tracked", "speed_error",
                  "heading_error")
"""The keys of a step's info: `PlanningTask.last_info`'s."""


def default_threads() -> int:
    """The CPUs this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def _fit(array: np.ndarray, length: int, fill: float = 0.0) -> np.ndarray:
    """`array` with its axis 1 grown to at least `length` (new entries `fill`)."""
    if array.shape[1] >= length:
        return array
    grown = np.full((array.shape[0], length, *array.shape[2:]), fill, dtype=array.dtype)
    grown[:, :array.shape[1]] = array
    return grown


class AUVVectorEnv(gymnasium.vector.VectorEnv):
    """N episodes of one planning task, stepped together in C (see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, task_name: str, num_envs: int = 1, task_kwargs: Mapping[str, Any] | None = None,
                 environment_kwargs: Mapping[str, Any] | None = None, threads: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP):
        """`task_kwargs` go to every sub-environment's task factory (not "random": seed through `reset`);
        goal tasks default to reward="paper" as `AUVGymEnv`'s. `threads` (default: this process's CPUs) share
        out the physics."""
        checks.choice("task_name", task_name, TASKS)
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or not 1 <= num_envs <= MAX_ENVS:
            raise ValueError(f"num_envs must be a whole number in [1, {MAX_ENVS}], got {checks.shown(num_envs)}")
        self.threads = default_threads() if threads is None else threads
        if isinstance(self.threads, bool) or not isinstance(self.threads, int | np.integer) \
                or not 1 <= self.threads <= MAX_THREADS:
            raise ValueError(f"threads must be a whole number in [1, {MAX_THREADS}], got {checks.shown(threads)}")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in AUTORESET_MODES:
            raise ValueError(f"autoreset_mode must be one of {[m.value for m in AUTORESET_MODES]}, got "
                             f"{checks.shown(autoreset_mode)}")
        if task_kwargs is not None and not isinstance(task_kwargs, Mapping):
            raise ValueError(f"task_kwargs must be a dict of task options, got {checks.shown(task_kwargs)}")
        task_kwargs = dict(task_kwargs or {})
        if "random" in task_kwargs:
            raise ValueError("seed the sub-environments through reset(seed=...), not task_kwargs['random']")
        task_kwargs.setdefault("reward", GOAL_TASK_REWARD)
        environment_kwargs = checks.environment_kwargs(environment_kwargs)
        if environment_kwargs.get("flat_observation"):
            raise ValueError("environment_kwargs: flat_observation is not supported by the vector env")
        self.task_name, self.task_kwargs = task_name, task_kwargs
        self.num_envs = int(num_envs)
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.autoreset_mode = mode
        self.envs = [suite.load(suite.DOMAIN, task_name, task_kwargs=task_kwargs,
                                environment_kwargs=environment_kwargs) for _ in range(self.num_envs)]
        first = self.envs[0]
        task = first.task
        if type(task.executor) is not SPlaneController:
            raise ValueError("task option executor: the vector env runs the S-plane executor "
                             "(auv_mj.control.splane.SPlaneController, any gains) only")
        self.single_observation_space, self.single_action_space, self._observe = gym_spaces(first)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._low = self.single_action_space.low.astype(float)
        self._high = self.single_action_space.high.astype(float)
        tick_steps = first.physics._tick_steps if first.physics._tick else None
        substeps = first._n_sub_steps
        self._substeps = int(round(planning.EXECUTOR_DT / first.physics.timestep()))
        if tick_steps not in (None, self._substeps) or substeps % self._substeps:
            raise ValueError(f"the planner step ({substeps} physics steps) must be whole executor periods of "
                             f"{self._substeps}")
        self._ticks = substeps // self._substeps
        self._step_limit = first._step_limit
        self.goal_radius = task.goal_radius
        self.reward_kind = task.reward_kind
        self.relative = task.goal_in_observation
        self.collision_penalty = task.collision_penalty
        self._stepper = batch.BatchStepper(self.num_envs)
        self._allocate()
        self._warned_clip = False
        self._needs_reset = True

    # --- per-environment arrays ---------------------------------------------------------------------

    def _allocate(self) -> None:
        n = self.num_envs
        self._goals = np.zeros((n, 1, 2))
        self._goal_cos_sin = np.zeros((n, 1, 2))
        self._tangents = np.zeros((n, 1, 2))
        self._path = np.zeros((n, 2, 2))
        self._n_goals = np.ones(n, dtype=int)
        self._reached = np.zeros(n, dtype=int)
        self._corridor = np.full(n, np.nan)
        self._bounds = np.zeros((n, 4))
        self._has_bounds = np.zeros(n, dtype=bool)
        self._repulsion = np.zeros(n)
        self._position = np.zeros((n, 2))
        self._psi = np.zeros(n)
        self._previous = np.zeros((n, 2))
        self._steps = np.zeros(n, dtype=int)
        self._task_step_limit = np.zeros(n, dtype=int)
        """Each episode's `PlanningTask.step_limit` (a procedural tunnel's is its own): the success bonus's K."""
        self._time_limit = np.full(n, np.inf)
        self._sonar = np.zeros((n, len(planning.SONAR_NAMES)))
        self._autoreset = np.zeros(n, dtype=bool)
        self._oceans: list = [None] * n
        self._current_rngs: list = [None] * n
        self._last_obs = {key: np.zeros(space.shape) for key, space in self.observation_space.spaces.items()}

    def _load_episode(self, i: int) -> None:
        """Reads sub-environment i's freshly reset episode into the batch (see the module docstring)."""
        env = self.envs[i]
        task, physics = env.task, env.physics
        if physics._disturbances:
            raise ValueError("the vector env steps vehicles without disturbances")
        if physics._steps_to_tick != 0:
            raise RuntimeError("the sub-environment's executor clock is not at a tick after its reset")
        route = task._route
        goals = task._goals
        count = len(goals)
        self._goals = _fit(self._goals, count)
        self._goal_cos_sin = _fit(self._goal_cos_sin, count)
        self._tangents = _fit(self._tangents, count)
        self._goals[i] = 0.0
        self._goals[i, :count] = goals
        self._goal_cos_sin[i, :count] = [(math.cos(h), math.sin(h)) for h in task._goal_headings]
        corridor = route.pass_corridor
        if corridor is not None and count > 1:
            self._tangents[i, :count - 1] = task._tangents
            self._corridor[i] = corridor
        else:
            self._corridor[i] = np.nan
        path = task._path
        self._path = _fit(self._path, len(path))
        self._path[i, :len(path)] = path
        self._path[i, len(path):] = path[-1]  # a zero-length tail changes no distance
        self._n_goals[i] = count
        self._reached[i] = task._reached
        self._task_step_limit[i] = task.step_limit
        bounds = task._bounds
        self._has_bounds[i] = bounds is not None
        self._bounds[i] = bounds if bounds is not None else 0.0
        self._repulsion[i] = task._repulsion_range
        data = physics.data.ptr
        qpos = task._qpos
        self._position[i] = data.qpos[qpos[:2]]
        self._psi[i] = data.qpos[qpos[2]]
        self._steps[i] = 0
        limit = getattr(task, "_time_limit", None)
        self._time_limit[i] = np.inf if limit is None else limit
        self._sonar[i] = task._sonar
        movers = [batch.mover_record(int(slot), m.start, m.end, m.speed,
                                     m.waypoints if m.via is not None and len(m.via) else None)
                  for m, slot in zip(route.movers, task._mover_slots, strict=True)]
        self._stepper.bind(i, physics, np.concatenate(movers) if movers else np.zeros(0), task._others,
                           task._hull, task._vehicle_body)
        self._load_executor(i, task)
        self._oceans[i] = None if task.ocean.sonar is None else task.ocean

    def _load_executor(self, i: int, task) -> None:
        """The executor's gains and state, and the current's processes, into the stepper's rows."""
        at_state, at_parameter = batch.STATE_INDEX, batch.PARAMETER_INDEX
        state, parameters = self._stepper.state[i], self._stepper.parameters[i]
        executor = task.executor
        gains = executor.gains
        for name in ("k1_speed", "k2_speed", "ki_speed", "k1_heading", "k2_heading", "ki_heading", "band_speed",
                     "band_heading", "integral_limit", "surge_drag", "surge_limit", "yaw_limit", "dt"):
            parameters[at_parameter[name]] = getattr(gains, name)
        state[:] = 0.0
        state[at_state["speed_command"]], state[at_state["heading_command"]] = task._command
        state[at_state["int_speed"]], state[at_state["int_heading"]] = executor._int_speed, executor._int_heading
        if executor._last_u is not None:
            state[at_state["last_u"]], state[at_state["has_last_u"]] = executor._last_u, 1.0
        state[at_state["collided"]] = float(task._collided)
        state[at_state["ready"]] = float(task_physics_ready(self.envs[i].physics))
        ocean = task.ocean
        current = ocean.current if ocean.conditions.current is not None else None
        self._current_rngs[i] = None
        self._stepper.normals_end[i] = 0
        if current is None:
            return
        state[at_state["current_on"]] = 1.0
        state[at_state["ocean_time"]] = ocean._time
        for process, name in ((current.speed, "speed"), (current.direction, "direction")):
            for field, value in (("mean", process.mean), ("sigma", process.sigma),
                                 ("time_constant", process.time_constant), ("low", process.low),
                                 ("high", process.high)):
                parameters[at_parameter[f"{name}_{field}"]] = value
            key = "current_speed" if name == "speed" else "current_direction"
            state[at_state[key]], state[at_state[f"{key}_dt"]] = process.value, process._dt
            state[at_state[f"{key}_a"]], state[at_state[f"{key}_b"]] = process._a, process._b
        normals = current.speed._normal
        if current.direction._normal is not normals:
            raise RuntimeError("the current's two processes must share one stream of normal draws")
        pending = normals._draws[::-1]  # Normals pops from the end: the next draws, in order
        self._stepper.normals[i, :len(pending)] = pending
        self._stepper.normals_end[i] = len(pending)
        self._current_rngs[i] = normals._rng

    # --- Gymnasium API ------------------------------------------------------------------------------

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict | None = None):
        """Starts every sub-environment's episode: `seed` an int (sub-environment i gets seed + i), a list of
        seeds (None: continue its RandomState) or None."""
        if seed is None:
            seeds = [None] * self.num_envs
        elif isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed: {self.num_envs} seeds (one per sub-environment), got {len(seeds)}")
        if options:
            raise ValueError(f"reset options are not supported, got {checks.shown(options)}")
        observations = []
        for i, s in enumerate(seeds):
            observations.append(self._reset_one(i, s))
        for key in self._last_obs:
            self._last_obs[key] = np.stack([o[key] for o in observations])
        self._autoreset[:] = False
        self._needs_reset = False
        info = {"is_success": np.zeros(self.num_envs, dtype=bool), "_is_success": np.ones(self.num_envs, dtype=bool)}
        return self._copy_obs(), info

    def _reset_one(self, i: int, seed: int | None) -> dict:
        """`AUVGymEnv.reset(seed=seed)` of sub-environment i; its first observation."""
        env = self.envs[i]
        if seed is not None:
            checks.seed(seed, "seed")
            env.task.random.seed(seed)
        time_step = env.reset()
        self._load_episode(i)
        return self._observe(time_step.observation)

    def step(self, actions):
        """One planner step of every sub-environment (see the module docstring for autoreset)."""
        if self._needs_reset:
            raise RuntimeError("call reset() before step()")
        actions = self._checked(actions)
        resetting = self._autoreset if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(self.num_envs,
                                                                                                        bool)
        index = np.flatnonzero(~resetting)
        rewards_, terminated, truncated, infos = self._step_batch(index, actions[index])
        reward = np.zeros(self.num_envs)
        term = np.zeros(self.num_envs, dtype=bool)
        trunc = np.zeros(self.num_envs, dtype=bool)
        reward[index], term[index], trunc[index] = rewards_, terminated, truncated
        done = term | trunc
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            for i in np.flatnonzero(resetting):
                self._write_obs(i, self._reset_one(int(i), None))
            infos["is_success"][resetting] = False
            infos["_is_success"][resetting] = True
            self._autoreset = done
        else:
            ended = np.flatnonzero(done)
            if ended.size:
                final_obs = np.full(self.num_envs, None, dtype=object)
                for i in ended:
                    final_obs[i] = {key: value[i].copy() for key, value in self._last_obs.items()}
                final_info = {key: value.copy() for key, value in infos.items()}
                for key in STEP_INFO_KEYS:
                    final_info["_" + key] = done.copy()
                infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
                infos["final_info"], infos["_final_info"] = final_info, done.copy()
                for key in STEP_INFO_KEYS:
                    infos["_" + key][done] = False
                infos["is_success"][done] = False
                infos["_is_success"][done] = True
                for i in ended:
                    self._write_obs(i, self._reset_one(int(i), None))
        return self._copy_obs(), reward, term, trunc, infos

    def _copy_obs(self) -> dict:
        return {key: value.copy() for key, value in self._last_obs.items()}

    def _write_obs(self, i: int, observation: dict) -> None:
        for key, value in observation.items():
            self._last_obs[key][i] = value

    def _checked(self, actions) -> np.ndarray:
        """The batch of actions as floats, by `auv_mj.tasks.actions.checked_action`'s convention for each row."""
        try:
            raw = np.asarray(actions)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"actions must be numbers of shape {self.action_space.shape}, got "
                             f"{checks.shown(actions)}") from None
        if raw.dtype.kind not in "biuf":
            raise ValueError(f"actions must be numbers, got {checks.shown(actions)} (dtype {raw.dtype})")
        value = raw.astype(float)
        if value.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {value.shape}")
        if not np.all(np.isfinite(value)):
            rows = np.flatnonzero(~np.all(np.isfinite(value), axis=1))
            raise ValueError(f"actions must be finite; sub-environment(s) {rows[:8].tolist()} are not")
        if np.any(value < self._low) or np.any(value > self._high):
            if not self._warned_clip:
                warnings.warn(f"{type(self).__name__}: actions outside [{self._low.tolist()}, {self._high.tolist()}] "
                              "are clipped (warned once)", ActionClipped, stacklevel=3)
                self._warned_clip = True
            value = np.clip(value, self._low, self._high)
        return value

    # --- the batched step: PlanningTask.before_step, the physics, after_step, get_observation -----

    def _step_batch(self, index: np.ndarray, actions: np.ndarray):
        at_state, at_out = batch.STATE_INDEX, batch.OUTPUT_INDEX
        stepper = self._stepper
        psi = self._psi[index]
        a0, a1 = actions[:, 0], actions[:, 1]
        offset = np.minimum(np.maximum(planning.ACTION_HEADING_RANGE * a1, -planning.MAX_HEADING_DIFFERENCE),
                            planning.MAX_HEADING_DIFFERENCE)
        previous = stepper.state[index, at_state["heading_command"]]
        turn = np.minimum(np.maximum(wrap_angle(psi + offset - previous), -planning.MAX_HEADING_CHANGE),
                          planning.MAX_HEADING_CHANGE)
        difference = np.minimum(np.maximum(wrap_angle(previous + turn - psi), -planning.MAX_HEADING_DIFFERENCE),
                                planning.MAX_HEADING_DIFFERENCE)
        speed = planning.MIN_SPEED + 0.5 * (a0 + 1.0) * (planning.MAX_SPEED - planning.MIN_SPEED)
        command = np.stack([speed, psi + difference], axis=1)
        stepper.state[index, at_state["speed_command"]] = command[:, 0]
        stepper.state[index, at_state["heading_command"]] = command[:, 1]
        previous_position = self._position[index].copy()
        self._previous[index] = previous_position
        for i in index:
            rng = self._current_rngs[i]
            if rng is not None:
                stepper.top_up(i, rng, 2 * self._ticks)
        stepper.step(index, self._ticks, self._substeps, SONAR_RANGE, self.threads)
        out = stepper.out[index]
        if np.any(out[:, at_out["invalid"]] != 0):
            bad = index[out[:, at_out["invalid"]] != 0]
            raise PhysicsError(f"Physics state is invalid in sub-environment(s) {bad[:8].tolist()}: MuJoCo warned "
                               "or reset the state during the step")
        position = out[:, [at_out["x"], at_out["y"]]]
        psi = out[:, at_out["psi"]]
        self._position[index], self._psi[index] = position, psi
        true_ranges = clip_ranges(out[:, at_out["sonar_1"]:at_out["sonar_1"] + len(planning.SONAR_NAMES)])
        sensed = true_ranges.copy()
        for k, i in enumerate(index):
            ocean = self._oceans[i]
            if ocean is not None:
                sensed[k] = ocean.sense(true_ranges[k])
        self._sonar[index] = sensed
        collision = out[:, at_out["collided"]] != 0
        bounds = self._bounds[index]
        x, y = position[:, 0], position[:, 1]
        left_map = self._has_bounds[index] & ~((bounds[:, 0] <= x) & (x <= bounds[:, 2])
                                               & (bounds[:, 1] <= y) & (y <= bounds[:, 3]))
        failed = collision | left_map
        rows = np.arange(len(index))
        goals = self._goals[index]
        n = self._n_goals[index]
        reached_before = self._reached[index]
        desired = goals[rows, reached_before]
        reached = self._hits(goals, n, reached_before, position)
        reached = np.maximum(reached, self._passed(index, goals, n, reached, position))
        self._reached[index] = reached
        success = (reached == n) & ~failed
        nearest, true_nearest = sensed.min(axis=1), true_ranges.min(axis=1)
        radius = self.goal_radius
        r_follow = planning.following_reward(previous_position, position, desired, radius)
        repulsion = self._repulsion[index]
        with np.errstate(divide="ignore"):
            graded = -planning.AVOID_GAIN * (1.0 / nearest - 1.0 / repulsion)
        avoid = np.where(nearest <= SAFETY_DISTANCE, planning.COLLISION_REWARD,
                         np.where(nearest < repulsion, graded, 0.0))
        r_avoid = np.where(failed, planning.COLLISION_REWARD, avoid)
        k1, k2, k3 = planning.REWARD_WEIGHTS
        independent = k2 * r_avoid + k3 * planning.NAVIGATION_REWARD - self.collision_penalty * failed
        steps_left = np.maximum(self._task_step_limit[index] - self._steps[index], 1)  # this step included
        paper = k1 * r_follow + independent + np.where(success, planning.success_bonus("paper", steps_left), 0.0)
        progressed = reached > reached_before
        event = np.where(collision, "collision", np.where(left_map, "left_map", np.where(
            progressed, np.where(reached == n, "goal", "subgoal"), ""))).astype(object)
        terminal = failed | (reached == n)
        if self.reward_kind == "paper":
            reward = paper
        elif self.reward_kind == "progress":
            reward = (k1 * planning.progress_reward(previous_position, position, desired, radius) + independent
                      + planning.success_bonus("progress", steps_left) * success)
        else:
            reward = self._suite_reward(goals, n, reached, position, failed, success, steps_left)
        u = out[:, at_out["u"]]
        infos = {
            "previous_achieved_goal": previous_position,
            "goal_independent_reward": independent,
            "reward_following": r_follow,
            "reward_avoid": r_avoid,
            "reward_navigation": np.full(len(index), planning.NAVIGATION_REWARD),
            "paper_reward": paper,
            "collision": collision,
            "left_map": left_map,
            "safety_violation": true_nearest < SAFETY_DISTANCE,
            "success": success,
            "is_success": success,
            "min_clearance": out[:, at_out["clearance"]],
            "min_sonar_range": true_nearest,
            "event": event,
            "goals_reached": reached,
            "num_goals": n,
            "last_goal": reached_before == n - 1,
            "steps_left": steps_left,
            "goal_radius": np.full(len(index), radius),
            "cross_track_error": self._cross_track(index, position),
            "command": command,
            "tracked": (n == 1) | (reached >= 1),
            "speed_error": command[:, 0] - u,
            "heading_error": wrap_angle(command[:, 1] - psi),
        }
        self._observe_batch(index, out, command, sensed)
        self._steps[index] += 1
        at_limit = self._steps[index] >= self._step_limit
        route_limit = ~terminal & (out[:, at_out["time"]] >= self._time_limit[index] - planning.PLANNER_DT / 2)
        truncated = at_limit | route_limit
        terminated = ~at_limit & terminal
        return reward, terminated, truncated, self._batched_infos(index, infos)

    def _batched_infos(self, index: np.ndarray, infos: dict) -> dict:
        """Rows of the stepped sub-environments -> Gymnasium's dict of arrays with "_key" masks."""
        batched = {}
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[index] = True
        for key, value in infos.items():
            value = np.asarray(value)
            full = np.zeros((self.num_envs, *value.shape[1:]), dtype=value.dtype)
            if value.dtype == object:
                full[:] = ""
            full[index] = value
            batched[key] = full
            batched["_" + key] = mask.copy()
        return batched

    def _hits(self, goals, n, reached, position) -> np.ndarray:
        """`PlanningTask.after_step`'s goal rule: past the last goal (not before `reached`) within the radius."""
        distance = np.hypot(goals[..., 0] - position[:, None, 0], goals[..., 1] - position[:, None, 1])
        slots = np.arange(goals.shape[1])
        hit = (slots >= reached[:, None]) & (slots < n[:, None]) & (distance <= self.goal_radius)
        last = goals.shape[1] - 1 - np.argmax(hit[:, ::-1], axis=1)
        return np.where(hit.any(axis=1), last + 1, reached)

    def _passed(self, index, goals, n, reached, position) -> np.ndarray:
        """`PlanningTask._passed`: goals behind the vehicle along the route, within its corridor (0 if none)."""
        corridor = self._corridor[index]
        tangents = self._tangents[index]
        rows = np.arange(len(index))
        last = np.minimum(reached + planning.PASS_WINDOW, n - 1)
        passed = np.zeros(len(index), dtype=int)
        with np.errstate(invalid="ignore"):
            for k in range(planning.PASS_WINDOW):
                slot = reached + k
                valid = (slot < last) & ~np.isnan(corridor)
                at = np.minimum(slot, goals.shape[1] - 1)
                offset = position - goals[rows, at]
                tangent = tangents[rows, at]
                along = offset[:, 0] * tangent[:, 0] + offset[:, 1] * tangent[:, 1]
                across = offset[:, 0] * tangent[:, 1] - offset[:, 1] * tangent[:, 0]
                passed = np.where(valid & (along > 0) & (np.abs(across) < corridor), slot + 1, passed)
        return passed

    def _suite_reward(self, goals, n, reached, position, failed, success, steps_left) -> np.ndarray:
        """`PlanningTask._suite_reward`, vectorised (the success bonus of `steps_left` steps on success)."""
        at = np.minimum(reached, n - 1)
        goal = goals[np.arange(len(n)), at]
        distance = np.hypot(goal[:, 0] - position[:, 0], goal[:, 1] - position[:, 1])
        near = rewards.tolerance(distance, bounds=(0.0, self.goal_radius), margin=planning.SUITE_REWARD_MARGIN,
                                 sigmoid="long_tail", value_at_margin=0.1)
        bonus = planning.success_bonus("suite", steps_left)
        return np.where(failed, 0.0, np.where(success, bonus, (reached + near) / n))

    def _cross_track(self, index, position) -> np.ndarray:
        """`planning.distance_to_polyline` of each vehicle to its route's reference path."""
        path = self._path[index]
        a, b = path[:, :-1], path[:, 1:]
        d = b - a
        point = position[:, None, :]
        pa = point - a
        dot = pa[..., 0] * d[..., 0] + pa[..., 1] * d[..., 1]
        length = np.maximum(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1], 1e-12)
        t = np.clip(dot / length, 0, 1)
        closest = a + t[..., None] * d
        return np.min(np.hypot(closest[..., 0] - point[..., 0], closest[..., 1] - point[..., 1]), axis=1)

    def _observe_batch(self, index, out, command, sensed) -> None:
        """`PlanningTask.get_observation` of the stepped vehicles into the batch's last observation."""
        at_out = batch.OUTPUT_INDEX
        psi = out[:, at_out["psi"]]
        c, s = out[:, at_out["cos_psi"]], out[:, at_out["sin_psi"]]
        motion = np.stack([out[:, at_out["u"]] / planning.MAX_SPEED, out[:, at_out["v"]] / planning.MAX_SPEED,
                           out[:, at_out["r"]],
                           wrap_angle(command[:, 1] - psi) / planning.MAX_HEADING_DIFFERENCE,
                           command[:, 0] / planning.MAX_SPEED], axis=1)
        at = np.minimum(self._reached[index], self._n_goals[index] - 1)
        goal = self._goals[index, at]
        x, y = out[:, at_out["x"]], out[:, at_out["y"]]
        if self.relative:
            heading = self._goal_cos_sin[index, at]
            achieved = np.stack([x, y, c, s], axis=1)
            desired = np.concatenate([goal, heading], axis=1)
            vector = np.concatenate([planning.relative_goal(achieved, desired), motion, sensed / SONAR_RANGE], axis=1)
        else:
            achieved = np.stack([x, y], axis=1)
            desired = goal
            vector = np.concatenate([np.stack([x / planning.POSITION_SCALE, y / planning.POSITION_SCALE, c, s],
                                              axis=1), motion, sensed / SONAR_RANGE], axis=1)
        self._last_obs["observation"][index] = vector
        self._last_obs["achieved_goal"][index] = achieved
        self._last_obs["desired_goal"][index] = desired

    # --- goal-conditioned API -----------------------------------------------------------------------

    def compute_reward(self, achieved_goal, desired_goal, info):
        """The task's vectorised reward (`PlanningTask.compute_reward`) for batches of goals."""
        return self.envs[0].task.compute_reward(achieved_goal, desired_goal, info)

    def compute_terminated(self, achieved_goal, desired_goal, info):
        """The task's `compute_terminated` for batches of goals."""
        return self.envs[0].task.compute_terminated(achieved_goal, desired_goal, info)

    def close_extras(self, **kwargs) -> None:
        """Drops the sub-environments."""
        self.envs = []


def task_physics_ready(physics) -> bool:
    """Whether the physics' next step may skip `mj_step1` (`AUVPhysics.step`'s flag)."""
    return bool(physics._step_ready)


SINGLE_ENV_OPTIONS = ("protection", "residual", "guide", "speed", "render_mode", "render_size", "render_distance")
"""`AUVGymEnv` options the batch does not implement (wrap single envs: vectorization_mode="sync" or "async")."""


def make_vector_env(num_envs: int = 1, task_name: str = "goal", **kwargs) -> AUVVectorEnv:
    """The `vector_entry_point` of the planning tasks' Gymnasium ids: what `gymnasium.make_vec` returns for them
    by default (vectorization_mode None or "vector_entry_point"); kwargs are `AUVVectorEnv`'s."""
    kwargs.pop("max_episode_steps", None)
    single = sorted(set(kwargs) & set(SINGLE_ENV_OPTIONS))
    if single:
        raise ValueError(f"{', '.join(single)}: options of the single env AUVGymEnv, not of the batched one; give "
                         "vectorization_mode='sync' or 'async' to vectorise single envs with them")
    return AUVVectorEnv(task_name, num_envs=num_envs, **kwargs)

