"""A Gymnasium view of any auv-mj suite task, and the `auv_mj/*-v0` environment ids.

`AUVGymEnv(task_name)` wraps `auv_mj.tasks.suite.load("auv", task_name, ...)`. Goal-conditioned tasks get the
Gymnasium-Robotics GoalEnv convention: a Dict observation ("observation", "achieved_goal",
"desired_goal") and vectorised `compute_reward` / `compute_terminated` / `compute_truncated` that
delegate to the task, so that `reward == env.compute_reward(obs["achieved_goal"], obs["desired_goal"],
info)` and Stable-Baselines3's HerReplayBuffer can relabel goals. That invariant needs the
goal-decomposable reward, so planar goal tasks default to reward="paper" (Eq. 26) here (goal3d and tunnel3d have
only such a reward); the task's `compute_reward` reads "previous_achieved_goal" from `info`, so give SB3's
HerReplayBuffer `copy_info_dict=True`. Other tasks get a flat Box.

Time limits stay with the dm_control Environment: a LAST step with discount 0 is `terminated`, one with
discount 1 (the time limit) is `truncated`. `reset(seed=s)` reseeds the task's RandomState with s, so
it gives the same episode as `suite.load(..., task_kwargs={"random": s})`.

The ids are registered when this module is imported (`tasks/__init__.py` imports it), e.g.
`gymnasium.make("auv_mj/Goal-v0", task_kwargs={"reward": "paper"})`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from auv_mj.goals import GOAL_KEYS
from auv_mj.tasks import options as checks
from auv_mj.tasks import suite

DOMAIN = "auv"
"""The suite domain of every task."""
GOAL_TASK_REWARD = "paper"
"""Reward of goal tasks unless task_kwargs say otherwise: the goal-decomposable Eq. (26), which the tasks'
`compute_reward` reproduces, so that HER's relabelled rewards are the environment's own."""
RENDER_SIZE = (720, 1280)
"""Default (height, width) of `render()` images [pixels]: the videos' frame (`auv_mj.render.DEFAULT_SIZE`)."""
RENDER_DISTANCE = 120.0
"""Default height of the planar frame's follow view [m] (the videos' FOLLOW_VIEW)."""
MIN_RENDER_SIZE = 32
"""Smallest `render()` image side [pixels] (the 6-DOF frame's panels need it; the text overlay needs 240 rows)."""
MAX_RENDER_SIZE = 4096
"""Largest `render()` image side [pixels]."""
MAX_RENDER_DISTANCE = 10_000.0
"""Highest render camera [m]."""
ENTRY_POINT = "auv_mj.tasks.gym_adapter:AUVGymEnv"
VECTOR_ENTRY_POINT = "auv_mj.tasks.vector:make_vector_env"
"""`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")` of the VECTOR_TASKS' ids."""
VECTOR_TASKS = ("goal", "obstacles", "moving_obstacles", "tunnel")
"""The planning tasks with a batched environment (`auv_mj.tasks.vector.AUVVectorEnv`)."""
VECTOR_ENTRY_POINT_3D = "auv_mj.tasks.vector3d:make_vector_env"
"""`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")` of the VECTOR_TASKS_3D's ids."""
VECTOR_TASKS_3D = ("goal3d", "tunnel3d")
"""The 6-DOF planning tasks with a batched environment (`auv_mj.tasks.vector3d.AUV3DVectorEnv`)."""
VECTOR_ENTRY_POINTS = {**dict.fromkeys(VECTOR_TASKS, VECTOR_ENTRY_POINT),
                       **dict.fromkeys(VECTOR_TASKS_3D, VECTOR_ENTRY_POINT_3D)}
"""Each batched task's `vector_entry_point`."""


def gym_id(task_name: str) -> str:
    """The Gymnasium id of a suite task: its name in CamelCase, `auv_mj/<Name>-v0` (moving_obstacles ->
    auv_mj/MovingObstacles-v0, goal3d -> auv_mj/Goal3D-v0)."""
    return "auv_mj/" + "".join(part[:1].upper() + part[1:] for part in task_name.title().split("_")) + "-v0"


GYM_IDS = {gym_id(name): name for _, name in suite.PLANAR_TASKS}
"""Gymnasium id -> suite task name, one per task of the suite (derived from it)."""
GYM_IDS_3D = {gym_id(name): name for _, name in suite.TASKS_3D}
"""Gymnasium id -> task name of the 6-DOF domain "auv3d" (`auv_mj.tasks.auv3d`): goal3d and tunnel3d are goal envs
(their one reward is goal-decomposable), depth_heading has a flat Box observation."""


def _box(spec) -> spaces.Box:
    """An unbounded float64 Box of a dm_env observation spec's shape."""
    return spaces.Box(-np.inf, np.inf, shape=tuple(spec.shape), dtype=np.float64)


def is_goal_env(env) -> bool:
    """Whether a suite environment is goal-conditioned (its observation holds GOAL_KEYS)."""
    return all(key in env.observation_spec() for key in GOAL_KEYS)


def gym_spaces(env) -> tuple[spaces.Space, spaces.Box, Callable[[Mapping[str, np.ndarray]], Any]]:
    """The Gymnasium view of a suite (dm_env) environment: (observation space, action space, the map from a
    dm_env observation to the Gymnasium one).

    A goal task's observation is the GoalEnv Dict of GOAL_KEYS, any other task's the flat float64 vector of its
    observation entries in spec order; actions are a float32 Box of the action spec's bounds. `AUVGymEnv` and
    outside policies trained on its ids (`--policy model.zip`) read observations through this one map.
    """
    obs_spec = env.observation_spec()
    if is_goal_env(env):
        observation_space = spaces.Dict({key: _box(obs_spec[key]) for key in GOAL_KEYS})

        def observe(observation):
            return {key: np.array(observation[key], dtype=np.float64) for key in GOAL_KEYS}
    else:
        keys = tuple(obs_spec)
        size = sum(int(np.prod(obs_spec[key].shape)) for key in keys)
        observation_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)

        def observe(observation):
            return np.concatenate([np.asarray(observation[key], dtype=np.float64).ravel() for key in keys])
    action_spec = env.action_spec()
    low, high = (np.broadcast_to(np.asarray(bound, dtype=np.float32), action_spec.shape).copy()
                 for bound in (action_spec.minimum, action_spec.maximum))
    return observation_space, spaces.Box(low, high, dtype=np.float32), observe


class AUVGymEnv(gymnasium.Env):
    """Gymnasium adapter over the suite task `task_name` (GoalEnv convention for goal tasks)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, task_name: str, task_kwargs: Mapping[str, Any] | None = None,
                 environment_kwargs: Mapping[str, Any] | None = None, render_mode: str | None = None,
                 render_size: tuple[int, int] = RENDER_SIZE, render_distance: float = RENDER_DISTANCE):
        """`task_kwargs` go to the task factory (not "random": seed through `reset(seed=...)`).

        A trained planner's layers (guide, residual, protection domain) are not the task's: they wrap this
        environment as `auv_mj.planners.deploy.DeployedEnv`, the one deployment chain.
        """
        from auv_mj.tasks import suite  # imported here so that registering the ids stays light

        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, "
                             f"got {render_mode!r}")
        if task_kwargs is not None and not isinstance(task_kwargs, Mapping):
            raise ValueError(f"task_kwargs must be a dict of task options, got {checks.shown(task_kwargs)}")
        task_kwargs = dict(task_kwargs or {})
        if "random" in task_kwargs:
            raise ValueError("seed the task through reset(seed=...), not task_kwargs['random']")
        self.task_name = task_name
        self.render_mode = render_mode
        self.render_size = tuple(int(v) for v in checks.pair("render_size", render_size,
                                                              ((MIN_RENDER_SIZE, MAX_RENDER_SIZE, "px"),) * 2))
        self.render_distance = checks.number("render_distance", render_distance, 0.0, MAX_RENDER_DISTANCE, "m",
                                              low_open=True)
        environment_kwargs = checks.environment_kwargs(environment_kwargs)
        self._domain = suite.domain_of(task_name) if isinstance(task_name, str) else DOMAIN
        self._env = suite.load(self._domain, task_name, task_kwargs=task_kwargs,
                               environment_kwargs=environment_kwargs)
        self.is_goal_task = is_goal_env(self._env)
        if self.is_goal_task and self._domain == DOMAIN and "reward" not in task_kwargs:  # auv3d: one reward
            task_kwargs["reward"] = GOAL_TASK_REWARD
            self._env = suite.load(self._domain, task_name, task_kwargs=task_kwargs,
                                   environment_kwargs=environment_kwargs)
        self.task_kwargs = task_kwargs
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._env.control_timestep())}
        self.observation_space, self.action_space, self._observation = gym_spaces(self._env)
        self._view = None
        self._needs_reset = True
        self.last_time_step = None
        """The dm_env time step of the last reset or step (what a wrapper such as the deployment chain reads)."""

    # --- the wrapped dm_control objects ------------------------------------------------------------

    @property
    def dm_env(self):
        """The wrapped `dm_control.rl.control.Environment`."""
        return self._env

    @property
    def task(self):
        """The suite task (compute_reward, last_info, ...)."""
        return self._env.task

    @property
    def physics(self):
        """The task's `AUVPhysics`."""
        return self._env.physics

    # --- Gymnasium API ------------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts an episode; a `seed` reseeds the task's RandomState (same episode as random=seed)."""
        if seed is not None:
            checks.seed(seed, "seed")
        super().reset(seed=seed)
        if seed is not None:
            self.task.random.seed(seed)
        time_step = self.last_time_step = self._env.reset()
        self._needs_reset = False
        if self.render_mode == "rgb_array":
            self._live_view().start(time_step)
        return self._observation(time_step.observation), self._info()

    def step(self, action):
        """One task step; `terminated` on a LAST step with discount 0, `truncated` at the time limit.

        The action follows the suite's one convention (`auv_mj.tasks.actions`): not numbers (strings included),
        the wrong shape or NaN/inf raise ValueError; a finite action outside the space is clipped to it with
        an `ActionClipped` warning, once per task.
        """
        if self._needs_reset:
            raise RuntimeError("call reset() before step() (and after an episode has ended)")
        time_step = self.last_time_step = self._env.step(action)
        if self._view is not None:
            self._view.add(time_step, action)
        terminated = bool(time_step.last() and time_step.discount == 0.0)
        truncated = bool(time_step.last() and not terminated)
        self._needs_reset = time_step.last()
        return self._observation(time_step.observation), float(time_step.reward), terminated, truncated, self._info()

    def gym_observation(self, observation: Mapping[str, np.ndarray]):
        """The Gymnasium observation of a dm_env observation of this task (`gym_spaces`' map)."""
        return self._observation(observation)

    def compute_reward(self, achieved_goal, desired_goal, info):
        """The task's vectorised reward for (batches of) goals; `info` as from `step` (or a batch of them)."""
        return self._goal_method("compute_reward")(achieved_goal, desired_goal, info)

    def compute_terminated(self, achieved_goal, desired_goal, info):
        """The task's vectorised termination for (batches of) goals."""
        return self._goal_method("compute_terminated")(achieved_goal, desired_goal, info)

    def relabel_observation(self, observation, achieved_goal, desired_goal):
        """The task's observation had `desired_goal` been the goal (hindsight relabelling), vectorised."""
        return self._goal_method("relabel_observation")(observation, achieved_goal, desired_goal)

    @property
    def goal_in_observation(self) -> bool:
        """Whether the observation holds the goal (relative to the vehicle): a policy then reads it alone."""
        return bool(getattr(self.task, "goal_in_observation", False))

    def compute_truncated(self, achieved_goal, desired_goal, info):
        """Truncation (the time limit) does not depend on the goals: all False unless the task decides."""
        method = getattr(self.task, "compute_truncated", None)
        if method is not None:
            return method(achieved_goal, desired_goal, info)
        achieved_goal = np.asarray(achieved_goal)
        return np.zeros(achieved_goal.shape[:-1], dtype=bool) if achieved_goal.ndim > 1 else False

    def render(self):
        """With render_mode="rgb_array", the (H, W, 3) uint8 frame the videos show of the current step (`auv-mj
        render`, `auv_mj.render`), `render_size` (height, width) pixels: planar tasks a top-down view following the
        vehicle (`render_distance` metres tall) with the arena's overview inset, the goal, the global path, the sonar
        beams, the trail since the reset, a text overlay and a key; 6-DOF tasks the chase, top and side views with
        the heads-up display. Else None."""
        if self.render_mode != "rgb_array":
            return None
        if self._needs_reset and self.last_time_step is None:
            raise RuntimeError("call reset() before render()")
        return self._live_view().frame()

    def _live_view(self):
        """The frame drawer of the video renderer (`auv_mj.render`), made on first use."""
        if self._view is None:
            height, width = self.render_size
            title = gym_id(self.task_name) if isinstance(self.task_name, str) else ""
            if self._domain == DOMAIN:
                from auv_mj.render.episode_video import LiveView

                self._view = LiveView(self._env, width, height, follow_view=self.render_distance, title=title)
            else:
                from auv_mj.render.episode_video3d import LiveView3D

                self._view = LiveView3D(self._env, width, height, title=title)
        return self._view

    def close(self):
        """Frees the renderer's OpenGL context; safe to call twice."""
        if self._view is not None:
            self._view.close()

    # --- helpers ------------------------------------------------------------------------------------

    def _goal_method(self, name: str):
        method = getattr(self.task, name, None)
        if method is None:
            raise AttributeError(f"task {self.task_name!r} is not goal-conditioned: it has no {name}()")
        return method

    def _info(self) -> dict:
        info = dict(getattr(self.task, "last_info", None) or {})
        info["is_success"] = bool(info.get("is_success", info.get("success", False)))
        return info


MIX_ID = "auv_mj/Planning-v0"
"""Gymnasium id of the mixture of planning tasks (`PlanningMix`)."""
MIX_TASKS = ("goal", "obstacles", "moving_obstacles", "tunnel")
"""The default mixture: open water, static and moving obstacles, tunnels."""


class PlanningMix(gymnasium.Env):
    """A distribution of planning tasks as one goal env: each `reset(seed=...)` draws the task from the seed
    (weights `weights`), then runs that task's episode with the same seed.

    Planning tasks share observation and action spaces, and their rewards are recomputed per step from
    the step's info (its goal radius included), so that hindsight relabelling is exact across the mix.
    `task_kwargs` go to every task, `per_task_kwargs[task]` to one (e.g. {"tunnel": {"arena": "random"}}).
    """

    metadata = {"render_modes": [], "render_fps": 2}

    def __init__(self, tasks: tuple[str, ...] = MIX_TASKS, weights: tuple[float, ...] | None = None,
                 task_kwargs: Mapping[str, Any] | None = None,
                 per_task_kwargs: Mapping[str, Mapping[str, Any]] | None = None):
        if isinstance(tasks, str) or not isinstance(tasks, (list, tuple)) or not all(isinstance(t, str) for t in tasks):
            raise ValueError(f"tasks: a list of planning task names, got {checks.shown(tasks)}")
        tasks = tuple(tasks)
        if not tasks:
            raise ValueError("tasks: give at least one planning task")
        try:
            weights = np.ones(len(tasks)) if weights is None else np.asarray(weights, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"weights: {len(tasks)} non-negative numbers, got {checks.shown(weights)}") from None
        if per_task_kwargs is not None and not (isinstance(per_task_kwargs, Mapping) and all(
                isinstance(v, Mapping) for v in per_task_kwargs.values())):
            raise ValueError(f"per_task_kwargs: a dict of task name -> dict of options, got "
                             f"{checks.shown(per_task_kwargs)}")
        if weights.shape != (len(tasks),) or not np.all(np.isfinite(weights)) or np.any(weights < 0) \
                or weights.sum() <= 0:
            raise ValueError(f"weights: {len(tasks)} non-negative numbers with a positive sum, got {weights}")
        unknown = set(per_task_kwargs or {}) - set(tasks)
        if unknown:
            raise ValueError(f"per_task_kwargs: {sorted(unknown)} not among the tasks {tasks}")
        self.tasks, self.weights = tasks, weights / weights.sum()
        self.envs = [AUVGymEnv(name, {**dict(task_kwargs or {}), **dict((per_task_kwargs or {}).get(name, {}))})
                     for name in tasks]
        first = self.envs[0]
        for name, env in zip(tasks, self.envs, strict=True):
            if not env.is_goal_task:
                raise ValueError(f"tasks: {name!r} is not a planning (goal) task")
            if env.observation_space != first.observation_space or env.action_space != first.action_space:
                raise ValueError(f"tasks: {name!r} has other spaces than {tasks[0]!r}: give the tasks one "
                                 "observation")
        self.observation_space, self.action_space = first.observation_space, first.action_space
        self.active = first

    @property
    def goal_in_observation(self) -> bool:
        return self.active.goal_in_observation

    @property
    def task_name(self) -> str:
        """The task of the current episode."""
        return self.active.task_name

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Draws the episode's task from `seed`, then resets that task with the same seed.

        Without a seed both the task and its episode seed come from the mixture's own generator, so that
        `reset(seed=s)` then `reset()` gives the same second episode every time (Gymnasium's `check_env`):
        the drawn task's own RandomState may have been left anywhere by earlier episodes.
        """
        super().reset(seed=seed)
        self.active = self.envs[int(self.np_random.choice(len(self.envs), p=self.weights))]
        if seed is None:
            seed = int(self.np_random.integers(checks.SEED_RANGE[0], checks.SEED_RANGE[1] + 1))
        return self.active.reset(seed=seed, options=options)

    def step(self, action):
        return self.active.step(action)

    def compute_reward(self, achieved_goal, desired_goal, info):
        return self.active.compute_reward(achieved_goal, desired_goal, info)

    def compute_terminated(self, achieved_goal, desired_goal, info):
        return self.active.compute_terminated(achieved_goal, desired_goal, info)

    def compute_truncated(self, achieved_goal, desired_goal, info):
        return self.active.compute_truncated(achieved_goal, desired_goal, info)

    def relabel_observation(self, observation, achieved_goal, desired_goal):
        return self.active.relabel_observation(observation, achieved_goal, desired_goal)


def register_envs() -> None:
    """Registers the `auv_mj/*-v0` ids (GYM_IDS, and MIX_ID) with Gymnasium; idempotent."""
    for env_id, task_name in {**GYM_IDS, **GYM_IDS_3D}.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=ENTRY_POINT, kwargs={"task_name": task_name},
                               vector_entry_point=VECTOR_ENTRY_POINTS.get(task_name))
    if MIX_ID not in gymnasium.registry:
        gymnasium.register(id=MIX_ID, entry_point="auv_mj.tasks.gym_adapter:PlanningMix")


register_envs()
