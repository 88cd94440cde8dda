"""A batched training mixture of planning tasks: one batched env per (task, tier, water), side by side.

Either domain: the planar tasks (MIXTURE_TASKS, each cell an `AUVVectorEnv`) or the 6-DOF ones (MIXTURE_TASKS_3D,
goal3d and tunnel3d, each cell an `auv_mj.tasks.vector3d.AUV3DVectorEnv`); one mixture holds one domain's.

`PlanningMixtureVectorEnv` holds `envs_per_cell` vehicles of each combination of MIXTURE_TASKS (random
obstacles, random moving obstacles, random tunnels: every task with `arena="random"`), the two tiers and the two
waters of the held-out benchmark, and presents them as one `gymnasium.vector.VectorEnv` whose sub-environments
are the cells' concatenated (cell k holds rows `cell_start[k]` ... `cell_start[k + 1] - 1`; `cell_of_row` maps a
row to its cell). A policy trained on it sees every kind of arena in every water in each rollout: in equal shares,
or, with one vehicle count per cell (`envs_per_cell` a list; `cell_counts` makes one from weights), with the hard
cells oversampled.

Seeds: it is a training env and draws every episode from `auv_mj.seeds.TRAIN` only. `reset(seed=s)` (an int)
starts row i with `train_seed(s, i)`; a list of seeds must lie in TRAIN (ValueError otherwise: validation and
test seeds never reach training). Each later episode of a row, started by the autoreset, gets the next training
seed of the same stream, `train_seed(base, num_envs + j)` for the j-th autoreset in row order, where `base` is the
int (or the first seed of the list) of the last reset: the whole sequence of episodes follows from the reset
seeds, which PPO derives from its run seed. (The row's task RandomState is re-seeded with that seed as the
episode ends, so that the sub-env's own NEXT_STEP autoreset is exactly `reset(seed=that seed)`.)

Autoreset: NEXT_STEP by default, Gymnasium's (and `auv_mj.agents.ppo`'s). `autoreset_mode="SameStep"` resets a row
in the step that ended its episode, with the same seed stream (each cell's `AUVVectorEnv.autoreset_seed` draws it),
and puts the last observation and info in info["final_obs"] and info["final_info"], as `AUVVectorEnv` does: what
Stable-Baselines3's `VecEnv` needs (`auv_mj.tasks.vector_sb3.SB3VectorEnv` takes either env).

`reward_scale` multiplies every reward (PPO's value targets stay near 1 with the progress reward's metres).

`serial=True` steps each vehicle in its own suite environment instead (`auv_mj.tasks.gym_adapter.AUVGymEnv`, a cell
a `gymnasium.vector.SyncVectorEnv` of them; NEXT_STEP autoreset only): the same episodes from the same seeds (the
batch's contract), many times slower, but each row's environment is there to read as one episode (`row_env`), so that
a planner written for one environment (`map-replan`) can act on it beside the learner: a teacher that senses what
the student senses (`auv_mj.jobs.student.PlannerTeacher`).
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from auv_mj import seeds as seed_ranges
from auv_mj.tasks import auv3d, planning, vector3d
from auv_mj.tasks import options as checks
from auv_mj.tasks.gym_adapter import AUVGymEnv
from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.tasks.vector3d import AUV3DVectorEnv

MIXTURE_TASKS = ("obstacles", "moving_obstacles", "tunnel")
"""The planning tasks of the mixture, each on procedural arenas (`arena="random"`)."""
MIXTURE_TASKS_3D = vector3d.TASKS
"""The 6-DOF planning tasks a mixture may hold instead (goal3d, tunnel3d; random arenas too)."""
TIERS = ("standard", "hard")
"""The arena tiers (the benchmark's `tier` option)."""
WATERS = ("ideal", "ocean")
"""The waters (the benchmark's `conditions` option)."""
MAX_ENVS_PER_CELL = 1024
"""Most vehicles per (task, tier, water) cell."""
OWN_OPTIONS = ("arena", "tier", "conditions", "random")
"""Task options the mixture sets itself per cell; `task_kwargs` may not give them."""


def mixture_cells(tasks: Sequence[str] = MIXTURE_TASKS, tiers: Sequence[str] = TIERS,
                  waters: Sequence[str] = WATERS) -> list[tuple[str, str, str]]:
    """The (task, tier, water) cells of a mixture, in row order; the tasks all of one domain (MIXTURE_TASKS or
    MIXTURE_TASKS_3D)."""
    domain = MIXTURE_TASKS_3D if not isinstance(tasks, str) and tasks and tasks[0] in MIXTURE_TASKS_3D \
        else MIXTURE_TASKS
    for name, values, allowed in (("tasks", tasks, domain), ("tiers", tiers, TIERS),
                                  ("waters", waters, WATERS)):
        if not values or isinstance(values, str):
            raise ValueError(f"{name} must be a non-empty list drawn from {list(allowed)}, got {checks.shown(values)}")
        for value in values:
            checks.choice(name, value, allowed)
        if len(set(values)) != len(values):
            raise ValueError(f"{name} repeats an entry: {list(values)}")
    return list(itertools.product(tasks, tiers, waters))


def cell_counts(envs_per_cell: int, cells: Sequence[tuple[str, str, str]],
                weights: Mapping[str, float] | None = None) -> list[int]:
    """Vehicles per cell, in `cells`' order, for oversampling: round(envs_per_cell x the product of the weights of
    the cell's task, tier and water) (a name without a weight weighs 1), at least 1 each; ValueError for a weight
    that is not a finite number > 0 or names no task, tier or water of the cells."""
    weights = dict(weights or {})
    names = {name for cell in cells for name in cell}
    for name, weight in weights.items():
        if name not in names:
            raise ValueError(f"cell weight {checks.shown(name)} names no task, tier or water of the mixture "
                             f"({sorted(names)})")
        if isinstance(weight, bool) or not isinstance(weight, int | float) or not 0 < weight < np.inf:
            raise ValueError(f"cell weight of {name!r} must be a finite number > 0, got {checks.shown(weight)}")
    return [max(1, round(envs_per_cell * float(np.prod([weights.get(n, 1.0) for n in cell])))) for cell in cells]


def parse_weights(entries: Sequence[str]) -> dict[str, float]:
    """Cell weights written as "NAME=WEIGHT" (the command line's `--cell-weights hard=1.5 tunnel=2.5`) as
    {name: weight}; ValueError naming an entry that is not NAME=WEIGHT. `cell_counts` checks the names and values."""
    out = {}
    for entry in entries:
        name, sep, weight = str(entry).partition("=")
        try:
            out[name.strip()] = float(weight)
        except ValueError:
            sep = ""
        if not sep:
            raise ValueError(f"cell weights are NAME=WEIGHT (e.g. hard=1.5), got {checks.shown(entry)}")
    return out


def _merged_box(boxes: Sequence[spaces.Box], name: str) -> spaces.Box:
    shapes = {b.shape for b in boxes}
    if len(shapes) != 1:
        raise ValueError(f"the mixture's tasks disagree on the shape of {name}: {sorted(shapes)}")
    low = np.minimum.reduce([b.low for b in boxes])
    high = np.maximum.reduce([b.high for b in boxes])
    return spaces.Box(low, high, dtype=boxes[0].dtype)


class PlanningMixtureVectorEnv(gymnasium.vector.VectorEnv):
    """Planning tasks x tiers x waters on procedural arenas as one batched env (see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, envs_per_cell: int | Sequence[int] = 8, tasks: Sequence[str] = MIXTURE_TASKS,
                 tiers: Sequence[str] = TIERS, waters: Sequence[str] = WATERS,
                 task_kwargs: Mapping[str, Any] | None = None, reward_scale: float = 1.0,
                 threads: int | None = None, autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 serial: bool = False):
        """`envs_per_cell` is the vehicles of every cell, or a list of one count per cell in `mixture_cells`
        order; `task_kwargs` go to every cell's tasks (e.g. {"reward": "progress"}), beside the cell's own arena,
        tier and conditions; `threads` are each cell's C batch threads (default: this process's CPUs);
        `autoreset_mode` one of `auv_mj.tasks.vector.AUTORESET_MODES` (the module docstring); `serial` each vehicle
        in its own suite environment (the module docstring; NEXT_STEP only, `threads` unused)."""
        self.cells = mixture_cells(tasks, tiers, waters)
        counts = [envs_per_cell] * len(self.cells) if isinstance(envs_per_cell, int | np.integer) \
            else list(envs_per_cell) if isinstance(envs_per_cell, Sequence) else [envs_per_cell]
        if len(counts) != len(self.cells) or any(
                isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= MAX_ENVS_PER_CELL
                for n in counts):
            raise ValueError(f"envs_per_cell must be a whole number in [1, {MAX_ENVS_PER_CELL}] or a list of "
                             f"{len(self.cells)} of them (one per cell), got {checks.shown(envs_per_cell)}")
        if isinstance(reward_scale, bool) or not isinstance(reward_scale, int | float) \
                or not 0 < reward_scale < np.inf:
            raise ValueError(f"reward_scale must be a finite number > 0, got {checks.shown(reward_scale)}")
        if task_kwargs is not None and not isinstance(task_kwargs, Mapping):
            raise ValueError(f"task_kwargs must be a dict of task options, got {checks.shown(task_kwargs)}")
        task_kwargs = dict(task_kwargs or {})
        own = sorted(set(task_kwargs) & set(OWN_OPTIONS))
        if own:
            raise ValueError(f"task_kwargs: {', '.join(own)} are set by the mixture per cell (arena 'random', its "
                             "tier and water; seeds through reset)")
        self.cell_sizes = [int(n) for n in counts]
        """Vehicles of each cell."""
        self.cell_start = np.concatenate([[0], np.cumsum(self.cell_sizes)]).astype(int)
        """Cell k's rows are cell_start[k] ... cell_start[k + 1] - 1."""
        self.envs_per_cell = self.cell_sizes[0] if len(set(self.cell_sizes)) == 1 else self.cell_sizes
        self.reward_scale = float(reward_scale)
        self.task_kwargs = task_kwargs
        three_d = self.cells[0][0] in MIXTURE_TASKS_3D
        self.policy_options = {k: v for k, v in task_kwargs.items() if k in auv3d.POLICY_OPTIONS
                               and isinstance(v, str)} if three_d else planning.policy_options(task_kwargs)
        """The options of `auv_mj.tasks.planning.POLICY_OPTIONS` (6-DOF: `auv3d.POLICY_OPTIONS`, given by name)
        given: what a policy trained here must run with."""
        if not isinstance(serial, bool):
            raise ValueError(f"serial must be True or False, got {checks.shown(serial)}")
        if serial and AutoresetMode(autoreset_mode) != AutoresetMode.NEXT_STEP:
            raise ValueError(f"autoreset_mode: a serial mixture resets NEXT_STEP only, got "
                             f"{checks.shown(autoreset_mode)}")
        self.serial = serial
        batch = _serial_cell if serial else AUV3DVectorEnv if three_d else AUVVectorEnv
        self.subenvs = [batch(task, num_envs=n, threads=threads, autoreset_mode=autoreset_mode,
                              task_kwargs={**task_kwargs, "arena": "random", "tier": tier, "conditions": water})
                        for (task, tier, water), n in zip(self.cells, self.cell_sizes, strict=True)]
        self.autoreset_mode = self.subenvs[0].autoreset_mode
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            for k, sub in enumerate(self.subenvs):
                sub.autoreset_seed = functools.partial(self._autoreset_seed, k)
        self.num_envs = int(self.cell_start[-1])
        first = self.subenvs[0].single_observation_space
        for sub in self.subenvs[1:]:
            if set(sub.single_observation_space.spaces) != set(first.spaces):
                raise ValueError("the mixture's tasks have different observation keys")
        self.single_observation_space = spaces.Dict({
            key: _merged_box([sub.single_observation_space[key] for sub in self.subenvs], key)
            for key in first.spaces})
        self.single_action_space = _merged_box([sub.single_action_space for sub in self.subenvs], "the action")
        if any(not np.array_equal(sub.single_action_space.low, self.single_action_space.low)
               or not np.array_equal(sub.single_action_space.high, self.single_action_space.high)
               for sub in self.subenvs):
            raise ValueError("the mixture's tasks have different action bounds")
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.cell_of_row = np.repeat(np.arange(len(self.subenvs)), self.cell_sizes)
        """Row -> index into `cells`."""
        self._base: int | None = None
        self._episodes = 0
        self.episode_seeds = np.zeros(self.num_envs, dtype=np.int64)
        """The training seed of each row's current (or pending, after an episode ended) episode."""

    # --- seeds -----------------------------------------------------------------------------------------

    def _next_seed(self) -> int:
        seed = seed_ranges.train_seed(self._base, self.num_envs + self._episodes)
        self._episodes += 1
        return seed

    def _autoreset_seed(self, cell: int, row: int) -> int:
        """The seed of the episode a SAME_STEP autoreset starts in row `row` of cell `cell` (the cells step in row
        order, so the stream is NEXT_STEP's)."""
        seed = self._next_seed()
        self.episode_seeds[self.cell_start[cell] + row] = seed
        return seed

    def reset(self, *, seed: int | Sequence[int] | None = None, options: dict | None = None):
        """Starts every row's episode: `seed` an int (row i: `train_seed(seed, i)`), a list of TRAIN seeds, or
        None (the next seeds of the current stream; the stream of seed 0 before any reset)."""
        if options:
            raise ValueError(f"reset options are not supported, got {checks.shown(options)}")
        if seed is None:
            if self._base is None:
                self._base = 0
                seed_list = [seed_ranges.train_seed(0, i) for i in range(self.num_envs)]
            else:
                seed_list = [self._next_seed() for _ in range(self.num_envs)]
        elif isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            checks.seed(int(seed), "seed")
            self._base, self._episodes = int(seed), 0
            seed_list = [seed_ranges.train_seed(int(seed), i) for i in range(self.num_envs)]
        else:
            seed_list = [int(s) for s in seed]
            if len(seed_list) != self.num_envs:
                raise ValueError(f"seed: {self.num_envs} seeds (one per sub-environment), got {len(seed_list)}")
            outside = [s for s in seed_list if s not in seed_ranges.TRAIN]
            if outside:
                raise ValueError(f"seed: the training mixture takes training seeds only (auv_mj.seeds.TRAIN, "
                                 f"[{seed_ranges.TRAIN.start}, {seed_ranges.TRAIN.stop})), got {outside[0]}")
            self._base, self._episodes = seed_list[0], 0
        self.episode_seeds[:] = seed_list
        observations, infos = [], []
        for k, sub in enumerate(self.subenvs):
            obs, info = sub.reset(seed=seed_list[self.cell_start[k]:self.cell_start[k + 1]])
            observations.append(obs)
            infos.append(info)
        return self._concat_obs(observations), self._concat_infos(infos)

    # --- stepping --------------------------------------------------------------------------------------

    def step(self, actions):
        """One planner step of every row; an ended episode's row gets the next training seed and resets at its next
        step (NEXT_STEP autoreset) or in this one (SAME_STEP, info["final_obs"] and info["final_info"] the ended
        episodes')."""
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {actions.shape}")
        start = self.cell_start
        parts = [sub.step(actions[start[k]:start[k + 1]]) for k, sub in enumerate(self.subenvs)]
        reward = np.concatenate([p[1] for p in parts]) * self.reward_scale
        terminated = np.concatenate([p[2] for p in parts])
        truncated = np.concatenate([p[3] for p in parts])
        done = terminated | truncated
        infos = self._concat_infos([p[4] for p in parts])
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            if done.any():  # the cells' autoresets drew their seeds (`_autoreset_seed`)
                final_obs = np.full(self.num_envs, None, dtype=object)
                for k, part in enumerate(parts):
                    if "final_obs" in part[4]:
                        final_obs[start[k]:start[k + 1]] = part[4]["final_obs"]
                infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
                infos["final_info"] = self._concat_infos([part[4].get("final_info", {}) for part in parts])
                infos["_final_info"] = done.copy()
            return self._concat_obs([p[0] for p in parts]), reward, terminated, truncated, infos
        for row in np.flatnonzero(done):
            seed = self._next_seed()
            self.episode_seeds[row] = seed
            cell = self.cell_of_row[row]
            sub = self.subenvs[cell]
            # the sub-env's autoreset is then reset(seed=seed)
            sub.envs[row - self.cell_start[cell]].task.random.seed(seed)
        return self._concat_obs([p[0] for p in parts]), reward, terminated, truncated, infos

    def _concat_obs(self, observations: list[dict]) -> dict:
        return {key: np.concatenate([o[key] for o in observations]).astype(space.dtype, copy=False)
                for key, space in self.single_observation_space.spaces.items()}

    def _concat_infos(self, infos: list[dict]) -> dict:
        """Gymnasium's dict of arrays over all rows; a key some cells lack is masked out for their rows."""
        keys = [k for k in dict.fromkeys(itertools.chain.from_iterable(infos)) if not k.startswith("_")]
        start = self.cell_start
        merged: dict[str, Any] = {}
        for key in keys:
            sample = next(np.asarray(info[key]) for info in infos if key in info)
            if sample.dtype == object or isinstance(infos[0].get(key), dict):
                continue  # final_obs / final_info: SAME_STEP's, merged by `step`
            values = np.zeros((self.num_envs, *sample.shape[1:]), dtype=sample.dtype)
            mask = np.zeros(self.num_envs, dtype=bool)
            for k, info in enumerate(infos):
                if key in info:
                    rows = slice(start[k], start[k + 1])
                    values[rows] = info[key]
                    mask[rows] = info.get("_" + key, np.ones(start[k + 1] - start[k], bool))
            merged[key], merged["_" + key] = values, mask
        return merged

    # --- what a teacher reads ---------------------------------------------------------------------------------

    def row_env(self, row: int) -> AUVGymEnv:
        """Row `row`'s own environment (a serial mixture's: `AUVGymEnv`, its `dm_env` and `last_time_step` the
        episode's as one environment runs it); ValueError on a batched mixture, whose rows share the C batch."""
        if not self.serial:
            raise ValueError("row_env: a batched mixture's rows have no environment of their own; build it with "
                             "serial=True")
        cell = int(self.cell_of_row[row])
        return self.subenvs[cell].envs[row - int(self.cell_start[cell])]

    @property
    def action_kind(self) -> str:
        """The action map of every cell (`planning.ACTIONS`; the task options are the same in every cell)."""
        if self.serial:
            return self.row_env(0).task.action_kind
        return self.subenvs[0].rules.action

    def privileged_state(self, *args) -> dict[str, Any]:
        """The cells' `privileged_state(*args)` (`AUVVectorEnv`'s, `AUV3DVectorEnv`'s), rows concatenated in row order
        (a privileged teacher's input, `auv_mj.planners.teacher.BatchTeacher`, `teacher3d.BatchTeacher3D`; never a
        learner's). A serial mixture has none (ValueError): its rows are read one by one (`row_env`)."""
        if self.serial:
            raise ValueError("privileged_state: a serial mixture's rows are read one by one (row_env); the batched "
                             "teachers need the batched mixture (serial=False)")
        parts = [sub.privileged_state(*args) for sub in self.subenvs]
        return {key: (list(itertools.chain.from_iterable(p[key] for p in parts)) if isinstance(parts[0][key], list)
                      else np.concatenate([p[key] for p in parts]))
                for key in parts[0]}

    def close_extras(self, **kwargs) -> None:
        """Closes every cell's batch."""
        for sub in self.subenvs:
            sub.close()
        self.subenvs = []


def _serial_cell(task: str, num_envs: int, threads: int | None, autoreset_mode, task_kwargs: Mapping[str, Any]
                 ) -> gymnasium.vector.SyncVectorEnv:
    """One cell of a serial mixture: `num_envs` suite environments of `task` stepped one after another (`threads`
    unused)."""
    return gymnasium.vector.SyncVectorEnv([functools.partial(AUVGymEnv, task, dict(task_kwargs))] * num_envs,
                                          autoreset_mode=autoreset_mode)
