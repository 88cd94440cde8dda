"""A batched planning environment on Gymnasium's vector API: N planar vehicles stepped in one process (issue 45).

`AUVVectorEnv(task_name, num_envs)` runs N episodes of one planning task ("goal", "obstacles",
"moving_obstacles", "tunnel"; any task option, e.g. {"arena": "random", "tier": "hard", "conditions": "ocean"})
as a `gymnasium.vector.VectorEnv`; `gymnasium.make_vec("auv_mj/Obstacles-v0", num_envs=64,
vectorization_mode="vector_entry_point", task_kwargs={...})` returns it. Spaces are the single env's
(`auv_mj.tasks.gym_adapter.AUVGymEnv`: GoalEnv dict observations), batched with `batch_space`.

The contract: sub-environment i reset with seed s gives exactly `AUVGymEnv`'s episode for seed s -- the same
observations, rewards, terminated / truncated and info -- in ideal and ocean water (tests/tasks/test_vector_env.py).
How, without one Python step per environment:
- Each sub-environment keeps its own suite environment (task, physics, RandomState, ocean). A reset is that
  environment's own reset, in Python, so routes, arenas and the ocean are drawn by the same code from the same
  generators.
- What the task does before and after the physics is the task's own code, run once over the batch: the action map
  (`planning_step.executor_command`, either action option), then goals, the passing rule, events, Eq. (23)-(26), the
  suite, progress and geodesic rewards (`planning_step.step_outcome`; the geodesic fields are each episode's, searched
  at its reset and asked for the whole batch at once) and the observation (`planning_observation.observe`, the planner
  observation and info["privileged"] included) -- the functions `PlanningTask` calls with N = 1. Only the time
  limits (`control.Environment`'s part) are here, and the ocean's sonar noise stays per environment (its generator
  is the episode's own). A reset's info beyond is_success (info["privileged"]) is the sub-environment's own.
- The physics is one call of the C batch (`auv_mj.sim.batch`) over all stepped vehicles, across `threads` threads:
  the five 10 Hz executor ticks (current, S-plane executor, movers, contacts) and the 50 physics steps, then the
  sonar and the clearance. NumPy's tanh and exp differ from libm's in the last bit, which a closed loop of 1,800
  steps would grow, so the executor runs in C with libm as the Python executor does with `math`; the C code reads
  the S-plane gains from the task's controller (`SPlaneController.parameters`). On two threads or more, the
  autoresets of the rows whose episode ended last step run on a helper thread while the C step runs
  (`GoalVectorEnv._physics_alongside`): each touches only its own rows, so the result is the serial one.
After each reset the batch reads the episode's record (`PlanningTask.episode`: route, command, goals reached,
collision, sonar; `PlanningTask.binding`: the model's addresses), the controller's memory
(`SPlaneController.memory`) and the current's processes.

Autoreset: `metadata["autoreset_mode"]` is `AutoresetMode.NEXT_STEP` by default, Gymnasium's own: the step
after a sub-environment's episode ended resets it (its action ignored) and returns the first observation with
reward 0, terminated and truncated False and the reset's info. `autoreset_mode=AutoresetMode.SAME_STEP`
resets in the step that ended the episode and puts the last observation and info in info["final_obs"] and
info["final_info"] (what Stable-Baselines3's `VecEnv` convention needs, `auv_mj.tasks.vector_sb3`). An autoreset
continues the sub-environment's RandomState, as `AUVGymEnv.reset()` without a seed does, unless `autoreset_seed` is
set: a function of the row that gives the seed of the episode an autoreset starts there (the training mixture's seed
stream, `auv_mj.tasks.mixture`), called in row order.

Infos are Gymnasium's dict of arrays, each key with its "_key" mask of the sub-environments that reported it.

`GoalVectorEnv` is the Gymnasium side this env shares with the 6-DOF batch (`auv_mj.tasks.vector3d.AUV3DVectorEnv`):
seeds, the autoreset modes, the actions' checks and the infos.

`vector_bench(...)` measures environment steps per second of this env, beside the physics limit and Gymnasium's
and Stable-Baselines3's process-parallel vectors (`auv-mj bench --sections vector`).
"""

from __future__ import annotations

import dataclasses
import os
import threading
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np
from dm_control.rl.control import PhysicsError
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from auv_mj.control.splane import EXECUTOR_DT, SPlaneController, SPlaneGains
from auv_mj.sim import batch
from auv_mj.sim.sonar import SONAR_NAMES, SONAR_RANGE, clip_ranges
from auv_mj.tasks import options as checks
from auv_mj.tasks import planning, planning_observation, planning_step, suite
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
STEP_INFO_KEYS = planning_step.STEP_INFO_KEYS
"""The keys of a step's info: `PlanningTask.last_info`'s."""


def default_threads() -> int:
    """The CPUs this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


class GoalVectorEnv(gymnasium.vector.VectorEnv):
    """What the batched goal envs share (`AUVVectorEnv`, planar; `auv_mj.tasks.vector3d.AUV3DVectorEnv`, 6-DOF): one
    suite environment per sub-environment for its resets, the Gymnasium API (seeds, the autoreset modes, the actions'
    checks, infos as dicts of arrays) and the goal-conditioned methods. A subclass reads a freshly reset episode into
    its batch (`_load_episode`) and steps the batch (`_step_batch`)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def _configure(self, num_envs, threads, autoreset_mode, task_kwargs, environment_kwargs) -> tuple[dict, dict]:
        """Checks and keeps the options every batch takes; returns the task and environment kwargs, checked."""
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
        environment_kwargs = checks.environment_kwargs(environment_kwargs)
        if environment_kwargs.get("flat_observation"):
            raise ValueError("environment_kwargs: flat_observation is not supported by the vector env")
        self.num_envs = int(num_envs)
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.autoreset_mode = mode
        self.autoreset_seed: Callable[[int], int] | None = None
        """The seed of the episode an autoreset starts in a row, given the row (called in row order, from the helper
        thread where NEXT_STEP resets run beside the step: `_physics_alongside`); None: continue the row's
        RandomState."""
        self._warned_clip = False
        self._needs_reset = True
        return task_kwargs, environment_kwargs

    def _load_episode(self, i: int) -> None:
        """Reads sub-environment i's freshly reset episode into the batch."""
        raise NotImplementedError

    def _step_batch(self, index: np.ndarray, actions: np.ndarray, alongside: Callable[[], None] | None):
        """One step of the sub-environments `index` with their `actions` -> (rewards, terminated, truncated, infos as
        `_batched_infos`). Calls `alongside` (the autoresets of other rows; None: none) once, through
        `_physics_alongside`."""
        raise NotImplementedError

    def _physics_alongside(self, index: np.ndarray, physics: Callable[[], None],
                           alongside: Callable[[], None] | None) -> None:
        """Runs `physics` (the C batch step, which releases the GIL) and `alongside` (Python work on rows the step
        does not touch: the autoresets of NEXT_STEP mode) together where `threads` > 1: the resets on a helper thread,
        the C step on this one across `threads` threads, so that a batch whose episodes end often (each reset draws
        and compiles its arena in Python) does not leave the other cores idle meanwhile. (This way round the C step
        starts at once: a helper thread would wait for the GIL the resets hold before it could enter it.) Each touches
        only its own rows of the batch's arrays and its own sub-environments, so the result is the serial one. On 1
        thread, or with no resets (`alongside` None) or no vehicle to step (`index` empty), one after the other."""
        if alongside is None or self.threads == 1 or len(index) == 0:
            if alongside is not None:
                alongside()
            physics()
            return
        failed: list[BaseException] = []

        def run() -> None:
            try:
                alongside()
            except BaseException as error:  # noqa: BLE001 -- raised again on the caller's thread below
                failed.append(error)

        helper = threading.Thread(target=run, name="auv-mj-autoresets")
        helper.start()
        try:
            physics()
        finally:
            helper.join()
        if failed:
            raise failed[0]

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
        for i in range(self.num_envs):
            self._put_reset_info(info, i)
        return self._copy_obs(), info

    def _put_reset_info(self, infos: dict, i: int) -> None:
        """Sub-environment i's reset info (beyond is_success) into row i of a batched info dict."""
        for key, value in self._reset_infos[i].items():
            value = np.asarray(value)
            if key not in infos:
                kind = object if value.dtype.kind in "UO" else value.dtype  # strings of any length
                infos[key] = np.zeros((self.num_envs, *value.shape), dtype=kind)
                infos["_" + key] = np.zeros(self.num_envs, dtype=bool)
            infos[key][i], infos["_" + key][i] = value, True

    def _reset_one(self, i: int, seed: int | None) -> dict:
        """`AUVGymEnv.reset(seed=seed)` of sub-environment i; its first observation."""
        env = self.envs[i]
        if seed is not None:
            checks.seed(seed, "seed")
            env.task.random.seed(seed)
        time_step = env.reset()
        self._load_episode(i)
        self._reset_infos[i] = dict(env.task.last_info)
        return self._observe(time_step.observation)

    def step(self, actions):
        """One planner step of every sub-environment (see the module docstring for autoreset)."""
        if self._needs_reset:
            raise RuntimeError("call reset() before step()")
        actions = self._checked(actions)
        resetting = self._autoreset if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(self.num_envs,
                                                                                                        bool)
        index = np.flatnonzero(~resetting)
        reset_rows = np.flatnonzero(resetting)
        first_observations: dict[int, dict] = {}

        def autoresets() -> None:  # NEXT_STEP: the rows whose episode ended last step, beside the physics
            for i in reset_rows:
                first_observations[int(i)] = self._reset_one(int(i), self._next_seed(int(i)))

        rewards_, terminated, truncated, infos = self._step_batch(index, actions[index],
                                                                  autoresets if len(reset_rows) else None)
        reward = np.zeros(self.num_envs)
        term = np.zeros(self.num_envs, dtype=bool)
        trunc = np.zeros(self.num_envs, dtype=bool)
        reward[index], term[index], trunc[index] = rewards_, terminated, truncated
        done = term | trunc
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            for i in reset_rows:
                self._write_obs(i, first_observations[int(i)])
                self._put_reset_info(infos, int(i))
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
                step_keys = [key for key in infos if not key.startswith("_")]  # STEP_INFO_KEYS and the options'
                for key in step_keys:
                    final_info["_" + key] = done.copy()
                infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
                infos["final_info"], infos["_final_info"] = final_info, done.copy()
                for key in step_keys:
                    infos["_" + key][done] = False
                infos["is_success"][done] = False
                infos["_is_success"][done] = True
                for i in ended:
                    self._write_obs(i, self._reset_one(int(i), self._next_seed(int(i))))
                    self._put_reset_info(infos, int(i))
        return self._copy_obs(), reward, term, trunc, infos

    def _next_seed(self, i: int) -> int | None:
        """The seed of row i's autoreset (`autoreset_seed`)."""
        return None if self.autoreset_seed is None else self.autoreset_seed(i)

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

    # --- goal-conditioned API -----------------------------------------------------------------------

    def compute_reward(self, achieved_goal, desired_goal, info):
        """The task's vectorised reward (`PlanningTask.compute_reward`) for batches of goals."""
        return self.envs[0].task.compute_reward(achieved_goal, desired_goal, info)

    def compute_terminated(self, achieved_goal, desired_goal, info):
        """The task's `compute_terminated` for batches of goals."""
        return self.envs[0].task.compute_terminated(achieved_goal, desired_goal, info)

    def _load_current_processes(self, i: int, current, ocean_time: float, at_state: Mapping[str, int],
                                at_parameter: Mapping[str, int]) -> None:
        """The current's two processes (their parameters, values and transitions) and their one stream of normal
        draws into the stepper's row i, at the indices of the batch's C state and parameters (both domains' kernels
        integrate the same processes, `auv_mj.sim.ocean`)."""
        state, parameters = self._stepper.state[i], self._stepper.parameters[i]
        state[at_state["current_on"]] = 1.0
        state[at_state["ocean_time"]] = ocean_time
        for process, name in ((current.speed, "speed"), (current.direction, "direction")):
            for field, value in (("mean", process.mean), ("sigma", process.sigma),
                                 ("time_constant", process.time_constant), ("low", process.low),
                                 ("high", process.high)):
                parameters[at_parameter[f"{name}_{field}"]] = value
            key = "current_speed" if name == "speed" else "current_direction"
            state[at_state[key]] = process.value
            state[at_state[f"{key}_dt"]], state[at_state[f"{key}_a"]], state[at_state[f"{key}_b"]] = process.transition
        normals = current.speed.normal
        if current.direction.normal is not normals:
            raise RuntimeError("the current's two processes must share one stream of normal draws")
        pending = normals.pending()
        self._stepper.normals[i, :len(pending)] = pending
        self._stepper.normals_end[i] = len(pending)
        self._current_rngs[i] = normals.rng

    def close_extras(self, **kwargs) -> None:
        """Drops the sub-environments."""
        self.envs = []


class AUVVectorEnv(GoalVectorEnv):
    """N episodes of one planning task, stepped together in C (see the module docstring)."""

    def __init__(self, task_name: str, num_envs: int = 1, task_kwargs: Mapping[str, Any] | None = None,
                 environment_kwargs: Mapping[str, Any] | None = None, threads: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP):
        """`task_kwargs` go to every sub-environment's task factory (not "random": seed through `reset`);
        goal tasks default to reward="paper" as `AUVGymEnv`'s. `threads` (default: this process's CPUs) share
        out the physics."""
        checks.choice("task_name", task_name, TASKS)
        task_kwargs, environment_kwargs = self._configure(num_envs, threads, autoreset_mode, task_kwargs,
                                                          environment_kwargs)
        task_kwargs.setdefault("reward", GOAL_TASK_REWARD)
        self.task_name, self.task_kwargs = task_name, task_kwargs
        self.policy_options = planning.policy_options(task_kwargs)
        """The options of `auv_mj.tasks.planning.POLICY_OPTIONS` given: what a policy trained here must run with."""
        self.envs = [suite.load(suite.DOMAIN, task_name, task_kwargs=task_kwargs,
                                environment_kwargs=environment_kwargs) for _ in range(self.num_envs)]
        first = self.envs[0]
        task = first.task
        if type(task.executor) is not SPlaneController:
            raise ValueError("task option executor: the vector env runs the S-plane executor "
                             "(auv_mj.control.splane.SPlaneController, any gains) only")
        if tuple(f.name for f in dataclasses.fields(SPlaneGains)) != batch.GAINS:
            raise RuntimeError("auv_mj.sim.batch.GAINS is out of step with SPlaneGains' fields")
        self.single_observation_space, self.single_action_space, self._observe = gym_spaces(first)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._low = self.single_action_space.low.astype(float)
        self._high = self.single_action_space.high.astype(float)
        tick_steps = first.physics.tick_steps
        substeps = first._n_sub_steps
        self._substeps = int(round(EXECUTOR_DT / first.physics.timestep()))
        if tick_steps not in (None, self._substeps) or substeps % self._substeps:
            raise ValueError(f"the planner step ({substeps} physics steps) must be whole executor periods of "
                             f"{self._substeps}")
        self._ticks = substeps // self._substeps
        self._step_limit = first._step_limit
        self.rules = task.rules
        """The task options of every step (`planning_step.StepRules`)."""
        self._stepper = batch.BatchStepper(self.num_envs)
        self._allocate()


    # --- per-environment arrays ---------------------------------------------------------------------

    def _allocate(self) -> None:
        n = self.num_envs
        self._routes = planning_step.RouteBatch.empty(n)
        self._reached = np.zeros(n, dtype=int)
        self._distance = np.full(n, np.nan)
        """Each episode's route length left where its next step begins (`Episode.distance`)."""
        self._action = np.zeros((n, 2))
        """Each episode's last action (`Episode.action`: the planner observation's)."""
        self._position = np.zeros((n, 2))
        self._psi = np.zeros(n)
        self._steps = np.zeros(n, dtype=int)
        self._task_step_limit = np.zeros(n, dtype=int)
        """Each episode's `PlanningTask.step_limit` (a procedural tunnel's is its own): the success bonus's K."""
        self._time_limit = np.full(n, np.inf)
        self._autoreset = np.zeros(n, dtype=bool)
        self._oceans: list = [None] * n
        self._current_rngs: list = [None] * n
        self._last_obs = {key: np.zeros(space.shape) for key, space in self.observation_space.spaces.items()}
        self._reset_infos: list[dict] = [{} for _ in range(n)]
        """Each sub-environment's last reset info beyond is_success (info["privileged"] of the planner observation)."""

    def _load_episode(self, i: int) -> None:
        """Reads sub-environment i's freshly reset episode into the batch (see the module docstring)."""
        env = self.envs[i]
        task, physics = env.task, env.physics
        if physics.disturbances:
            raise ValueError("the vector env steps vehicles without disturbances")
        if not physics.at_tick:
            raise RuntimeError("the sub-environment's executor clock is not at a tick after its reset")
        episode, binding = task.episode, task.binding
        self._routes.put(i, episode, binding.repulsion_range, binding.sonar_offset)
        self._action[i] = episode.action
        self._distance[i] = episode.distance
        self._reached[i] = episode.reached
        self._task_step_limit[i] = task.step_limit
        data = physics.data.ptr
        self._position[i] = data.qpos[binding.qpos[:2]]
        self._psi[i] = data.qpos[binding.qpos[2]]
        self._steps[i] = 0
        limit = task.episode_time_limit
        self._time_limit[i] = np.inf if limit is None else limit
        movers = [batch.mover_record(int(slot), m.start, m.end, m.speed,
                                     m.waypoints if m.via is not None and len(m.via) else None)
                  for m, slot in zip(episode.route.movers, episode.mover_slots, strict=True)]
        self._stepper.bind(i, physics, task.executor.parameters, np.concatenate(movers) if movers else np.zeros(0),
                           binding.others, binding.hull, binding.vehicle_body)
        self._load_executor(i, task)
        self._oceans[i] = None if task.ocean.sonar is None else task.ocean

    def _load_executor(self, i: int, task) -> None:
        """The episode's command, the executor's memory and the current's processes into the stepper's rows."""
        at_state, at_parameter = batch.STATE_INDEX, batch.PARAMETER_INDEX
        state = self._stepper.state[i]
        state[:] = 0.0
        state[at_state["speed_command"]], state[at_state["heading_command"]] = task.episode.command
        int_speed, int_heading, last_u = task.executor.memory
        state[at_state["int_speed"]], state[at_state["int_heading"]] = int_speed, int_heading
        if last_u is not None:
            state[at_state["last_u"]], state[at_state["has_last_u"]] = last_u, 1.0
        state[at_state["collided"]] = float(task.episode.collided)
        state[at_state["ready"]] = float(self.envs[i].physics.step_ready)
        ocean = task.ocean
        current = ocean.current if ocean.conditions.current is not None else None
        self._current_rngs[i] = None
        self._stepper.normals_end[i] = 0
        if current is None:
            return
        self._load_current_processes(i, current, ocean.time, at_state, at_parameter)

    # --- the batched step: PlanningTask.before_step, the physics, after_step, get_observation -----

    def _step_batch(self, index: np.ndarray, actions: np.ndarray, alongside: Callable[[], None] | None):
        at_state, at_out = batch.STATE_INDEX, batch.OUTPUT_INDEX
        stepper = self._stepper
        heading_command = stepper.state[index, at_state["heading_command"]]
        command = planning_step.executor_command(actions, self._psi[index], heading_command, self.rules.action)
        self._action[index] = actions
        stepper.state[index, at_state["speed_command"]] = command[:, 0]
        stepper.state[index, at_state["heading_command"]] = command[:, 1]
        previous = self._position[index].copy()
        for i in index:
            rng = self._current_rngs[i]
            if rng is not None:
                stepper.top_up(i, rng, 2 * self._ticks)
        self._physics_alongside(
            index, lambda: stepper.step(index, self._ticks, self._substeps, SONAR_RANGE, self.threads), alongside)
        out = stepper.out[index]
        if np.any(out[:, at_out["invalid"]] != 0):
            bad = index[out[:, at_out["invalid"]] != 0]
            raise PhysicsError(f"Physics state is invalid in sub-environment(s) {bad[:8].tolist()}: MuJoCo warned "
                               "or reset the state during the step")
        position = out[:, [at_out["x"], at_out["y"]]]
        self._position[index], self._psi[index] = position, out[:, at_out["psi"]]
        true_ranges = clip_ranges(out[:, at_out["sonar_1"]:at_out["sonar_1"] + len(SONAR_NAMES)])
        sensed = true_ranges.copy()
        for k, i in enumerate(index):
            ocean = self._oceans[i]
            if ocean is not None:
                sensed[k] = ocean.sense(true_ranges[k])
        readout = planning_step.Readout(position=position, psi=out[:, at_out["psi"]], cos_psi=out[:, at_out["cos_psi"]],
                                   sin_psi=out[:, at_out["sin_psi"]],
                                   velocity=out[:, [at_out["u"], at_out["v"], at_out["r"]]], sonar=sensed,
                                   true_ranges=true_ranges, collision=out[:, at_out["collided"]] != 0,
                                   clearance=out[:, at_out["clearance"]])
        steps_left = np.maximum(self._task_step_limit[index] - self._steps[index], 1)  # this step included
        outcome = planning_step.step_outcome(self._routes, index, self._reached[index], steps_left, previous, readout,
                                        command, self.rules, self._distance[index])
        self._reached[index] = outcome.reached
        if self.rules.potential:
            self._distance[index] = outcome.info["route_distance"]
        scans = None
        if self.rules.observation == "planner-map":  # each row's sonar map is its single env's episode's
            scans = planning_observation.remember([self.envs[i].task.episode.memory for i in index], readout,
                                                  self._routes.sonar_offset[index])
        observation = planning_observation.observe(self._routes, index, outcome.reached, readout, command,
                                                   self.rules.observation, self._action[index], scans)
        for key, value in observation.items():
            self._last_obs[key][index] = value
        self._steps[index] += 1
        at_limit = self._steps[index] >= self._step_limit
        route_limit = ~outcome.terminal & (out[:, at_out["time"]]
                                           >= self._time_limit[index] - planning_step.PLANNER_DT / 2)
        truncated = at_limit | route_limit
        terminated = ~at_limit & outcome.terminal
        return outcome.reward, terminated, truncated, self._batched_infos(index, outcome.info)

    @property
    def action_kind(self) -> str:
        """The action map of the batch's task (`planning.ACTIONS`)."""
        return self.rules.action

    def privileged_state(self) -> dict[str, Any]:
        """The true state of every row for a privileged teacher (`auv_mj.planners.teacher`; Chen et al. 2019), never
        a learner's input: each episode's geodesic potential ("potentials", `routes.RoutePotential`; needs
        reward="geodesic" or observation="planner"), the current goal ("goal_index"), the pose ("position" (N, 2),
        "psi" (N,)), the executor's heading command ("heading_command") and the movers now ("movers",
        `planning.mover_states`). Rows awaiting an autoreset still show the episode that ended."""
        if not self.rules.potential:
            raise ValueError("privileged_state needs the geodesic potential: reward=\"geodesic\" or "
                             "observation=\"planner\"")
        heading = self._stepper.state[:, batch.STATE_INDEX["heading_command"]].copy()
        goal_index = np.minimum(self._reached, self._routes.n_goals - 1)
        return {"potentials": [env.task.episode.potential for env in self.envs], "goal_index": goal_index,
                "position": self._position.copy(), "psi": self._psi.copy(), "heading_command": heading,
                "movers": [planning.mover_states(env.physics, env.task) for env in self.envs]}


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

