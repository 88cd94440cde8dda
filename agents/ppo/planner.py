"""A planner learned from scratch with PPO on the batched training mixture, chosen on validation seeds.

`train_planner(run_dir, config, mixture, total_steps)` trains `auv_mj.agents.ppo` on
`auv_mj.tasks.mixture.PlanningMixtureVectorEnv` (random obstacles, moving obstacles and tunnels, both tiers, both
waters, TRAIN seeds only; `MixtureConfig.cell_weights` oversamples the hard cells) in chunks of
`MixtureConfig.validate_every` env steps. The learning rate and clip range follow their schedules over the whole
`total_steps` (`ppo.train`'s `schedule_steps`), across the chunks and across resumes. PPO logs every rollout to
`progress.csv` and, per cell of the mixture, the success, collision and return of the episodes that ended and their
mean speed over the ground to `cells.csv` (and TensorBoard where it is installed).

After each chunk the checkpoint is copied to `snapshots/steps_<N>.pt` and the deterministic policy is run on
`validation_episodes` episodes of each of the hard tier's cells with VALIDATION seeds (`validate`); a row per chunk
goes to `validation.csv` (env steps, training wall-clock, the mean success, its mean over the last
`validation_window` validations, success per cell). `best.pt` is the snapshot chosen on that windowed mean
(`windowed_choice`): the last snapshot of the window of `validation_window` consecutive validations with the highest
mean. The single best validation is biased upward by the choice itself (the shipped run: validation 0.54 and 0.57,
test 0.50 and 0.52); a mean over a window of snapshots, each on 50 or more episodes a cell, is less so. Test seeds
are never touched here.

The planner reads the task's planning observation (goal distance and bearing, its velocity, its command, the nine
sonars) and the desired goal, as every planner does; nothing classical steers it. Its memory is PPO's GRU
(`PPOConfig(recurrent="gru")`); `recurrent=None` is the ablation without memory. `PLANNER_CONFIG` and
`MixtureConfig()` are the shipped run's settings (docs/runs/planner-memory-ppo); `LEARNED_CONFIG` and
`LEARNED_MIXTURE` those of the new learning problem (issue 51): the geodesic reward, a longer discount, an annealed
learning rate, a KL limit, a critic of its own with privileged inputs, the hard cells oversampled, and the windowed
choice.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.vector import VectorEnv

from auv_mj.agents.checkpoint import config_to_dict
from auv_mj.agents.ppo.checkpoint import CHECKPOINT_NAME, read_ppo
from auv_mj.agents.ppo.config import PPOConfig
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.ppo import train
from auv_mj.agents.ppo.spaces import student_view
from auv_mj.seeds import VALIDATION
from auv_mj.tasks.mixture import (
    MIXTURE_TASKS,
    TIERS,
    WATERS,
    PlanningMixtureVectorEnv,
    cell_counts,
    mixture_cells,
    parse_weights,
)
from auv_mj.tasks.planning import POLICY_OPTIONS
from auv_mj.tasks.planning_rewards import GEODESIC_DISCOUNT
from auv_mj.tasks.planning_step import PLANNER_DT
from auv_mj.tasks.vector import AUVVectorEnv

VALIDATION_NAME = "validation.csv"
BEST_NAME = "best.pt"
MIXTURE_NAME = "mixture.json"
VALIDATION_FIRST_SEED = VALIDATION.start + 7000
"""Validation episodes use seeds VALIDATION_FIRST_SEED + i (inside `auv_mj.seeds.VALIDATION`)."""
SELECTION_FIELDS = ("validate_every", "validation_episodes", "validation_window", "validation_max_steps")
"""MixtureConfig's fields of validation and the snapshot choice: they do not touch training, so a resumed run may
change them (the shipped run validated more sparsely after 3.9 M steps); the others must equal the saved ones."""


@dataclasses.dataclass(frozen=True)
class MixtureConfig:
    """The planner's training beside PPO's: the mixture, its reward, the oversampling of hard cells, validation and
    the snapshot choice; frozen into `mixture.json` of the run. Defaults are the shipped run's training."""

    envs_per_cell: int = 8
    """Vehicles per (task, tier, water) cell before cell_weights: 3 x 2 x 2 cells, 96 vehicles by default."""
    tasks: tuple[str, ...] = MIXTURE_TASKS
    """Planning tasks, each on procedural arenas."""
    tiers: tuple[str, ...] = TIERS
    """Arena tiers."""
    waters: tuple[str, ...] = WATERS
    """Waters (conditions)."""
    reward: str = "progress"
    """The tasks' reward: "progress" pays 0.5 per metre gained on the current goal, +4 on reaching it, and Eq.
    (24)-(25)'s avoidance and time costs; its sum depends on where the vehicle ends, not how slowly it went."""
    collision_penalty: float | None = 10.0
    """Subtracted on a collision or leaving the map (the task option of that name; None: the task's own)."""
    reward_scale: float = 0.1
    """Multiplies every reward (keeps PPO's value targets near 1)."""
    action: str | None = None
    """The tasks' action map (`auv_mj.tasks.planning`'s `action` option: "rate" is linear onto the heading
    command's per-step change); None: the task's default, the paper's map (the shipped run's)."""
    observation: str | None = None
    """The tasks' observation (e.g. "planner": what the classical planners read); None: the task's default."""
    goal_input: bool = True
    """The learner reads the goal dict's `desired_goal` beside its `observation` (the shipped run's); False: the
    observation vector alone (`auv_mj.agents.ppo.spaces.student_view`), as the new problem asks (issue 51, item 3:
    desired_goal's absolute metres and world heading mean nothing without the pose, and the planner observation
    already holds the goal and the route target relative to the vehicle)."""
    cell_weights: tuple[str, ...] = ()
    """Oversampling, as "NAME=WEIGHT" entries naming a task, tier or water: a cell gets round(envs_per_cell x the
    product of its names' weights) vehicles (a name without an entry weighs 1; `cell_counts`)."""
    validate_every: int = 1_000_000
    """Env steps between validations and snapshots (rounded up to whole checkpoint periods)."""
    validation_episodes: int = 50
    """Validation-seed episodes per hard-tier cell at each validation."""
    validation_window: int = 1
    """Validations whose mean chooses the snapshot (`windowed_choice`); 1 is the single best, the shipped run's."""
    validation_max_steps: int | None = None
    """Cut validation episodes after this many steps (counted as failures); None: the tasks' time limits."""

    def __post_init__(self):
        checks = (("envs_per_cell", 1), ("validate_every", 1), ("validation_episodes", 1), ("validation_window", 1))
        for name, low in checks:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"MixtureConfig.{name} must be a whole number >= {low}, got {value!r}")
        limit = self.validation_max_steps
        if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
            raise ValueError(f"MixtureConfig.validation_max_steps must be None or a whole number >= 1, got {limit!r}")
        last = VALIDATION_FIRST_SEED + self.validation_episodes - 1
        if last not in VALIDATION:
            raise ValueError(f"MixtureConfig.validation_episodes {self.validation_episodes}: seeds "
                             f"{VALIDATION_FIRST_SEED}..{last} leave auv_mj.seeds.VALIDATION")
        cell_counts(self.envs_per_cell, self.cells(), self.weights())

    def weights(self) -> dict[str, float]:
        """cell_weights as {name: weight} (`auv_mj.tasks.mixture.parse_weights`)."""
        return parse_weights(self.cell_weights)

    def cells(self) -> list[tuple[str, str, str]]:
        """The (task, tier, water) cells in row order."""
        return mixture_cells(self.tasks, self.tiers, self.waters)

    def counts(self) -> list[int]:
        """Vehicles per cell, in row order (`cell_counts`)."""
        return cell_counts(self.envs_per_cell, self.cells(), self.weights())

    @property
    def num_envs(self) -> int:
        """Vehicles in the mixture."""
        return sum(self.counts())

    def task_kwargs(self) -> dict[str, Any]:
        """The task options every cell shares."""
        kwargs: dict[str, Any] = {"reward": self.reward}
        if self.collision_penalty is not None:
            kwargs["collision_penalty"] = self.collision_penalty
        return {**kwargs, **self.policy_kwargs()}

    def policy_kwargs(self) -> dict[str, Any]:
        """The task options that shape what the policy reads and does (action map, observation): validation and
        deployment must run the policy with them too."""
        return {name: getattr(self, name) for name in POLICY_OPTIONS if getattr(self, name) is not None}

    def make_env(self, threads: int | None = None, autoreset_mode: str = "NextStep",
                 serial: bool = False) -> PlanningMixtureVectorEnv:
        """The training env (autoreset NEXT_STEP, ours; "SameStep" for Stable-Baselines3's face of it,
        `auv_mj.tasks.vector_sb3`; `serial`: each vehicle in its own environment, `PlanningMixtureVectorEnv`)."""
        counts = self.counts()
        return PlanningMixtureVectorEnv(counts[0] if len(set(counts)) == 1 else counts, self.tasks, self.tiers,
                                        self.waters, task_kwargs=self.task_kwargs(), reward_scale=self.reward_scale,
                                        threads=threads, autoreset_mode=autoreset_mode, serial=serial)


def mixture_from_dict(values: Mapping[str, Any]) -> MixtureConfig:
    """A MixtureConfig from `mixture.json` (lists become tuples; fields an older run lacks take their defaults)."""
    return MixtureConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})


def ground_speed(next_obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
    """Each vehicle's speed over the ground in the step just taken (m/s): from where it began
    (info["previous_achieved_goal"], (x, y)) to where it is (the observation's achieved_goal, whose first two
    entries are (x, y); a student's view of the env, `auv_mj.agents.ppo.spaces.StudentView`, keeps it in
    info["achieved_goal"]), over PLANNER_DT."""
    achieved = next_obs["achieved_goal"] if isinstance(next_obs, Mapping) else info["achieved_goal"]
    moved = np.asarray(achieved, float)[:, :2] - np.asarray(info["previous_achieved_goal"], float)
    return np.linalg.norm(moved, axis=-1) / PLANNER_DT


def windowed_means(scores: Sequence[float], window: int) -> list[float]:
    """The mean of the last `window` scores (fewer at the start) at each index."""
    return [float(np.mean(scores[max(0, i - window + 1):i + 1])) for i in range(len(scores))]


def windowed_choice(scores: Sequence[float], window: int) -> int | None:
    """The index of the snapshot to choose among validations `scores` (in order): the last of the `window`
    consecutive validations with the highest mean (ties: the earlier). While fewer than `window` validations exist,
    the partial windows at the start compete; after that only full ones. None if there are no scores."""
    if not scores:
        return None
    means = windowed_means(scores, window)
    first = min(window, len(scores)) - 1
    return max(range(first, len(scores)), key=lambda i: (means[i], -i))


def validate(policy: PPOPolicy, episodes: int, tasks: Sequence[str] = MIXTURE_TASKS, tier: str = "hard",
             waters: Sequence[str] = WATERS, first_seed: int = VALIDATION_FIRST_SEED,
             threads: int | None = None, max_steps: int | None = None,
             task_kwargs: dict[str, Any] | None = None) -> dict[str, float]:
    """Success rate of the deterministic `policy` on `episodes` VALIDATION-seed episodes of each (task, water)
    cell of `tier`, all of a cell's episodes stepped together in one batched env; {"task/tier/water": rate}.
    `max_steps` cuts the episodes (those not over by then count as failures); None: the tasks' time limits.
    `task_kwargs`: the options the policy was trained with that shape its input and output (`policy_kwargs`)."""
    seeds = list(range(first_seed, first_seed + episodes))
    if seeds[0] not in VALIDATION or seeds[-1] not in VALIDATION:
        raise ValueError(f"validation seeds {seeds[0]}..{seeds[-1]} leave auv_mj.seeds.VALIDATION")
    rates = {}
    for task in tasks:
        for water in waters:
            env = AUVVectorEnv(task, num_envs=episodes, threads=threads,
                               task_kwargs={**(task_kwargs or {}), "arena": "random", "tier": tier,
                                            "conditions": water})
            try:
                obs, _ = env.reset(seed=seeds)
                policy.reset()
                done = np.zeros(episodes, dtype=bool)
                success = np.zeros(episodes, dtype=bool)
                steps = 0
                while not done.all() and (max_steps is None or steps < max_steps):
                    steps += 1
                    obs, _, term, trunc, info = env.step(policy(obs))
                    ended = (term | trunc) & ~done
                    success[ended] = info["success"][ended]
                    done |= ended
            finally:
                env.close()
            rates[f"{task}/{tier}/{water}"] = float(success.mean())
    return rates


def _validation_rows(path: Path, up_to_steps: int) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if int(row["env_steps"]) <= up_to_steps]


def _training_fields(mixture: MixtureConfig) -> dict[str, Any]:
    return {k: v for k, v in config_to_dict(mixture).items() if k not in SELECTION_FIELDS}


def _replace_file(source: Path, target: Path) -> None:
    tmp = target.with_name(target.name + ".tmp")
    shutil.copyfile(source, tmp)
    tmp.replace(target)


def _view(env: VectorEnv, student: bool) -> VectorEnv:
    return student_view(env) if student else env


def train_planner(run_dir: str | Path, config: PPOConfig | None, mixture: MixtureConfig, total_steps: int,
                  *, resume: bool = False, progress: bool = True, tensorboard: bool = True,
                  threads: int | None = None, env: VectorEnv | None = None,
                  teacher: Callable[[], np.ndarray] | None = None, init: str | Path | None = None,
                  init_critic: bool = False,
                  teacher_of: Callable[[VectorEnv], Callable[[], np.ndarray]] | None = None) -> dict[str, Any]:
    """Trains the planner (see the module docstring) for `total_steps` env steps, the steps its schedules span;
    returns {"env_steps", "best_steps", "best_success" (the chosen window's mean), "best_point" (the chosen
    snapshot's own validation), "checkpoint", "best"}.

    Resuming continues from the last chunk's checkpoint (`ppo.train`'s exact resume when `validate_every` is a whole
    number of checkpoint periods) with the schedules the run started with. The mixture's training fields must be the
    saved ones; its validation fields (SELECTION_FIELDS) may change, and are saved anew.

    A student's fine-tune (issue 51, `auv_mj.jobs.student`) passes `env`, the mixture as the student sees it (made by
    the caller, kept open across the chunks), `teacher`, the teacher's labels on it (`ppo.train`'s imitation term),
    and `init`, the student's checkpoint that a new run starts from. `auv-mj train ppo --init` continues a trained
    planner (its checkpoint, or a learned policy's name) on a new mixture as a new run, its critic included
    (`init_critic`); the mixture is seen as `init` (or the resumed run's checkpoint) saw it: a student's
    observation vector alone (`student_view`) where it read no goal dict, with the action map and observation it was
    trained with (its checkpoint's task options, e.g. a student of observation="planner-map"). `teacher_of(env)`,
    where no `env` is given, labels the mixture this function makes (the teacher of its privileged state, e.g.
    `auv_mj.planners.teacher.BatchTeacher(env, mover_reach).actions`): a continued run under an imitation term."""
    if teacher_of is not None and (env is not None or teacher is not None):
        raise ValueError("train_planner: give teacher_of (a teacher of the env made here) or env and teacher, not both")
    run_dir = Path(run_dir)
    mixture_path = run_dir / MIXTURE_NAME
    if resume:
        saved = _training_fields(mixture_from_dict(json.loads(mixture_path.read_text())))
        if saved != _training_fields(mixture):
            raise ValueError(f"{mixture_path}: the run was trained on {saved}, not {_training_fields(mixture)}")
        (_, meta), saved_config = read_ppo(run_dir / CHECKPOINT_NAME)
        config = saved_config if config is None else config
        done_steps = int(meta["counters"]["env_steps"])
        student = not mixture.goal_input or meta["spec"]["kind"] == "box"
    else:
        if (run_dir / CHECKPOINT_NAME).exists():
            raise FileExistsError(f"{run_dir / CHECKPOINT_NAME} exists: resume it or choose another run "
                                  "directory")
        run_dir.mkdir(parents=True, exist_ok=True)
        config = config or PPOConfig()
        done_steps = 0
        student = not mixture.goal_input or (init is not None
                                             and read_ppo(init)[0].metadata["spec"]["kind"] == "box")
        if init is not None:  # the network reads and does what it was trained on: its action map and observation
            trained = read_ppo(init)[0].metadata["spec"].get("task_options", {})
            mixture = dataclasses.replace(mixture, **{k: trained[k] for k in POLICY_OPTIONS if k in trained})
    mixture_path.write_text(json.dumps(config_to_dict(mixture), indent=2))
    per_rollout = config.num_steps * mixture.num_envs
    period = per_rollout * config.checkpoint_every
    chunk = max(1, math.ceil(mixture.validate_every / period)) * period
    target = math.ceil(total_steps / per_rollout) * per_rollout
    rows = _validation_rows(run_dir / VALIDATION_NAME, done_steps)
    snapshots = run_dir / "snapshots"
    snapshots.mkdir(exist_ok=True)
    fields = ["env_steps", "train_wall_s", "episodes", "hard_success", "hard_success_window", *(
        f"{task}/hard/{water}" for task in mixture.tasks for water in WATERS)]
    with open(run_dir / VALIDATION_NAME, "w", newline="") as f:
        writer = csv.DictWriter(f, fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    scores = [float(r["hard_success"]) for r in rows]
    labels: list[Callable[[], np.ndarray]] = []

    def make_env() -> VectorEnv:  # the chunk's mixture, and its teacher where one labels it
        made = mixture.make_env(threads)
        if teacher_of is not None:
            labels[:] = [teacher_of(made)]
        return _view(made, student)

    def chunk_teacher() -> np.ndarray:  # the current chunk's env's teacher
        return labels[0]()

    if teacher_of is not None:
        teacher = chunk_teacher
    steps = done_steps
    while steps < target:
        goal = min(target, (steps // chunk + 1) * chunk)
        result = train(env if env is not None else make_env, config, run_dir, goal,
                       resume=steps > 0, progress=progress, tensorboard=tensorboard,
                       schedule_steps=None if steps else target, step_speed=ground_speed, teacher=teacher,
                       init=None if steps else init, init_critic=init_critic)
        steps = result.env_steps
        meta = read_ppo(result.checkpoint)[0].metadata
        snapshot = snapshots / f"steps_{steps}.pt"
        shutil.copyfile(result.checkpoint, snapshot)
        started = time.perf_counter()
        rates = validate(PPOPolicy.load(snapshot), mixture.validation_episodes, mixture.tasks, threads=threads,
                         max_steps=mixture.validation_max_steps, task_kwargs=mixture.policy_kwargs())
        scores.append(round(float(np.mean(list(rates.values()))), 4))
        row = {"env_steps": steps, "train_wall_s": round(float(meta["counters"]["wall_time"]), 1),
               "episodes": mixture.validation_episodes, "hard_success": scores[-1],
               "hard_success_window": round(windowed_means(scores, mixture.validation_window)[-1], 4), **rates}
        rows.append(row)
        with open(run_dir / VALIDATION_NAME, "a", newline="") as f:
            csv.DictWriter(f, fields).writerow(row)
        chosen = windowed_choice(scores, mixture.validation_window)
        print(f"validation at {steps} steps ({time.perf_counter() - started:.0f} s): hard-tier success "
              f"{row['hard_success']:.3f} (mean of the last {mixture.validation_window}: "
              f"{row['hard_success_window']:.3f}) {rates}; chosen: {rows[chosen]['env_steps']} steps", flush=True)
        if (snapshots / f"steps_{rows[chosen]['env_steps']}.pt").is_file():  # an old run's may have been removed
            _replace_file(snapshots / f"steps_{rows[chosen]['env_steps']}.pt", run_dir / BEST_NAME)
    chosen = windowed_choice(scores, mixture.validation_window)
    best = rows[chosen] if chosen is not None else None
    return {"env_steps": steps, "best_steps": int(best["env_steps"]) if best else None,
            "best_success": windowed_means(scores, mixture.validation_window)[chosen] if best else None,
            "best_point": scores[chosen] if best else None,
            "checkpoint": run_dir / CHECKPOINT_NAME, "best": run_dir / BEST_NAME}


PLANNER_CONFIG = PPOConfig(num_steps=128, num_minibatches=4, update_epochs=4, hidden_sizes=(128, 128),
                               recurrent="gru", recurrent_size=128, clip_vloss=False, checkpoint_every=40,
                               torch_threads=2)
"""The planner's PPO defaults (`auv-mj train ppo`): 128-step rollouts of the 96 vehicles (12,288 transitions),
4 epochs of 4 minibatches of whole vehicles' sequences, a 128-128 tanh encoder and a 128-unit GRU, no value
clipping (the returns are not on the policy ratio's scale), a checkpoint (and reset of the envs) every 40
rollouts, about 0.5 M steps, and the update on two threads (the batch's physics threads are idle while it runs).
Others are CleanRL's (`PPOConfig`)."""


LEARNED_CONFIG = dataclasses.replace(
    PLANNER_CONFIG, gamma=GEODESIC_DISCOUNT, lr_schedule="linear", min_learning_rate=3e-5, target_kl=0.03,
    separate_critic=True, privileged_critic=True)
"""PPO for the new learning problem (issue 51, item 4): PLANNER_CONFIG with the geodesic reward's own discount
(`auv_mj.tasks.planning_rewards.GEODESIC_DISCOUNT`: its shaping is policy-invariant at that discount only), the
learning rate annealed linearly to a tenth over the whole run (CleanRL anneals to 0; the floor keeps the late
snapshots learning), a KL limit of 0.03 (an update stops after the first epoch past it), and a critic of its own
(an encoder and GRU of its own, sb3-contrib's default) that reads the env's info["privileged"] (the geodesic
distance to the goal, the true clearance, the cell and the time left), which the actor never sees."""

LEARNED_MIXTURE = MixtureConfig(
    reward="geodesic", collision_penalty=None, action="rate", observation="planner", goal_input=False,
    cell_weights=("standard=0.5", "hard=1.5", "tunnel=1.5"),
    validate_every=500_000, validation_episodes=50, validation_window=3)
"""The training mixture of the new learning problem (issue 51): the geodesic reward with the task's own success
bonus and collision penalty (item 1), the action map linear onto the heading command's per-step change (item 2)
and the observation the classical planners read, that vector alone (item 3; `goal_input`). The hard cells are
oversampled: a hard cell weighs 1.5 and a standard one 0.5 (kept, as the standard tier is half of the
benchmark's targets, but a third as often), a tunnel 1.5 more (the cells the shipped planner fails): 4 vehicles
in each standard obstacles and movers cell, 6 in each standard tunnel cell, 12 in each hard obstacles and movers
cell and 18 in each hard tunnel cell, 112 in all, three quarters of them on the hard tier. Validation on 50
episodes a hard cell every 0.5 M steps, the snapshot chosen on the mean of 3 validations."""
