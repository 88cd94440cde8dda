"""A sensor-only student of the privileged teacher (issue 51, item 5): DAgger, then PPO under a decaying imitation term.

`train_student(run_dir, ...)` joins the pieces that live in separate layers: a batched env (one planning task,
`auv_mj.tasks.vector.AUVVectorEnv`, or the whole training mixture, `task="planning-mix"`,
`auv_mj.tasks.mixture.PlanningMixtureVectorEnv` as `LEARNED_MIXTURE` oversamples it; both with
observation="planner", action="rate", reward="geodesic"), the teacher that reads its true state
(`auv_mj.planners.teacher.BatchTeacher`; Chen et al. 2019), DAgger (`auv_mj.agents.imitation`; Ross et al. 2011)
and, with `finetune_steps`, PPO from the student with the teacher's labels under the imitation term
(`auv_mj.agents.ppo`, PPOConfig.imitation_coef): on one task `finetune`, on the mixture the planner's own training
loop (`auv_mj.agents.ppo.planner.train_planner`: validation on the hard cells, the windowed choice, best.pt).
`auv-mj train dagger` is argparse over it.

In 3-D (`task="planning-mix-3d"`, MIXTURE_TASK_3D): the 6-DOF training mixture (`PlanningMixtureVectorEnv` over goal3d
and tunnel3d, both tiers and waters, the hard cells oversampled by MIXTURE_3D_WEIGHTS, MIXTURE_3D_OPTIONS), the 3-D
teacher (`auv_mj.planners.teacher3d.BatchTeacher3D`), and DAgger's validation on each hard cell
(`mixture_3d_validator`); the student reads the 3-D planning observation (`auv_mj.tasks.auv3d.PLANNING_OBSERVATION`
and the fan) alone. Its PPO fine-tune (`finetune_steps`) is `finetune` on the mixture with the teacher's labels
under the decaying imitation term, a critic of its own that reads the 6-DOF env's privileged inputs
(`auv_mj.tasks.auv3d.PRIVILEGED_FIELDS`), then the validation of DAgger's rounds on the last snapshot.
"""

from __future__ import annotations

import copy
import dataclasses
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.agents.checkpoint import config_to_dict
from auv_mj.agents.imitation import (
    CHECKPOINT_NAME,
    STUDENT_NAME,
    DaggerConfig,
    evaluate_student,
    finetune,
    student_spec,
    train_dagger,
)
from auv_mj.agents.imitation.dagger import VALIDATION_FIRST_SEED, Validator, episodes_validator
from auv_mj.agents.ppo import CHECKPOINT_NAME as PPO_CHECKPOINT
from auv_mj.agents.ppo import PPOConfig, load_model, read_ppo
from auv_mj.agents.ppo import train as ppo_train
from auv_mj.agents.ppo.planner import LEARNED_CONFIG, LEARNED_MIXTURE, MixtureConfig, mixture_from_dict, train_planner
from auv_mj.agents.ppo.planner import VALIDATION_FIRST_SEED as MIXTURE_VALIDATION_SEED
from auv_mj.agents.ppo.planner import validate as validate_planner
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.spaces import student_view
from auv_mj.episode import Planner, as_planner
from auv_mj.planners.map_planner import map_replan
from auv_mj.planners.map_planner3d import sonar_voxel_planner
from auv_mj.planners.teacher import BatchTeacher, InTaskActions, checked_reach
from auv_mj.planners.teacher3d import BatchTeacher3D
from auv_mj.tasks import auv3d
from auv_mj.tasks.mixture import MIXTURE_TASKS_3D, PlanningMixtureVectorEnv, cell_counts, mixture_cells, parse_weights
from auv_mj.tasks.planning_step import ACTIONS, PLANNER_OBSERVATIONS
from auv_mj.tasks.vector import AUVVectorEnv
from auv_mj.tasks.vector3d import AUV3DVectorEnv

STUDENT_TASK_KWARGS = {"arena": "random", "tier": "hard", "action": "rate", "reward": "geodesic",
                       "observation": "planner"}
"""The student's problem (issue 51): hard-tier random arenas, the geodesic reward, the rate action, the planner
observation; a caller's task options are laid over these."""
FINETUNE_DIR = "ppo"
"""The fine-tune's run directory inside the student's."""
OPTIONS_NAME = "student.json"
"""The task, its options and the batch size of a run (read back on resume)."""
MIXTURE_TASK = "planning-mix"
"""The task name of the whole training mixture (`auv_mj.tasks.mixture`), as `auv-mj train ppo` names it."""
MIXTURE_TASK_3D = "planning-mix-3d"
"""The task name of the 6-DOF training mixture (goal3d and tunnel3d, both tiers and waters)."""
MIXTURE_3D_WEIGHTS = {"standard": 0.5, "hard": 1.5}
"""Cell weights of the 6-DOF mixture (`auv_mj.tasks.mixture.cell_counts`): three hard vehicles to a standard one."""
MIXTURE_3D_OPTIONS = {"reward": "geodesic", "executor": "splane-ocean"}
"""The 6-DOF student's task options (beside each cell's arena, tier and water): the geodesic reward, and the
execution layer the 3-D benchmark runs every planner on (suite 3d v3: the S-plane re-tuned in ocean water), which the
student's checkpoint keeps as a task option (`auv3d.POLICY_OPTIONS`) and the zoo applies."""


TEACHER_NAME = "teacher.json"
"""A continued planner run's teacher (`continue_planner`), read back on resume."""


def continue_planner(run_dir: str | Path, config: PPOConfig, mixture: MixtureConfig, steps: int, *,
                     resume: bool = False, progress: bool = True, tensorboard: bool = True,
                     threads: int | None = None, init: str | Path | None = None,
                     mover_reach: float | None = None) -> dict[str, Any]:
    """`auv-mj train ppo --task planning-mix`: `train_planner` (a new run from `init`, or the run in `run_dir`
    resumed), with the privileged teacher labelling the rollouts where config.imitation_coef > 0 and its
    imitation_source is "teacher" (the imitation term of issue 51, item 5, on a continued run; with "init" the
    run's frozen start labels them, `auv_mj.agents.ppo.train`): every state, or with `mover_reach` [m] only the
    states with a mover within that of the vehicle (`BatchTeacher`: imitation weighted against RL state by state).
    The teacher's options are kept in the run directory (TEACHER_NAME) and read back on resume."""
    path = Path(run_dir) / TEACHER_NAME
    if resume and path.is_file():
        saved = json.loads(path.read_text())
        if mover_reach is not None and mover_reach != saved.get("mover_reach"):
            raise ValueError(f"{path}: the run's teacher has mover_reach {saved.get('mover_reach')!r}, not "
                             f"{mover_reach!r}")
        mover_reach = saved.get("mover_reach")
    teaches = config.imitation_coef > 0 and config.imitation_source == "teacher"
    if mover_reach is not None and not teaches:
        raise ValueError(f"mover_reach {mover_reach!r} needs the teacher's imitation term: give the PPO config an "
                         "imitation_coef > 0 (--ppo-imitation-coef) and imitation_source 'teacher'")
    teacher_of = None
    if teaches:
        mover_reach = checked_reach(mover_reach)  # before the run starts

        def teacher_of(env):
            return BatchTeacher(env, mover_reach).actions

        if not resume:
            Path(run_dir).mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps({"teacher": "geodesic-teacher", "mover_reach": mover_reach}, indent=2))
    return train_planner(run_dir, config, mixture, steps, resume=resume, progress=progress,
                         tensorboard=tensorboard, threads=threads, init=init, init_critic=init is not None,
                         teacher_of=teacher_of)


def mixture_options(task: str, task_kwargs: Mapping[str, Any] | None) -> dict[str, str]:
    """The task options a training mixture's `task_kwargs` may set ({} where they set none), checked: the observation
    (one of PLANNER_OBSERVATIONS on MIXTURE_TASK, of `auv3d.OBSERVATIONS` on MIXTURE_TASK_3D) and, on the planar
    mixture, the action map (one of `planning_step.ACTIONS`: "rate", the student's, or "paper", whose heading offset
    lets a teacher's label carry how much to turn). The mixture sets every other option itself; ValueError naming
    the options otherwise. What `auv-mj train dagger` takes on either mixture, and `auv-mj train ppo` on the 6-DOF
    one."""
    given = dict(task_kwargs or {})
    choices = {"observation": auv3d.OBSERVATIONS} if task == MIXTURE_TASK_3D else \
        {"observation": PLANNER_OBSERVATIONS, "action": ACTIONS}
    own = MIXTURE_3D_OPTIONS if task == MIXTURE_TASK_3D else student_mixture().task_kwargs()
    if not set(given) <= set(choices):
        raise ValueError(f"task {task}: the mixture sets the task options itself ({own}); task_kwargs takes only "
                         f"{' and '.join(f'an {name} (one of {values})' for name, values in choices.items())}, got "
                         f"{given}")
    for name, value in given.items():
        if value not in choices[name]:
            raise ValueError(f"task {task}: task_kwargs {name} must be one of {choices[name]}, got {value!r}")
    return given


def mixture_3d_options(observation: str | None = None) -> dict[str, str]:
    """The 6-DOF student's task options: MIXTURE_3D_OPTIONS, with `observation` (one of `auv3d.OBSERVATIONS`) where
    given (ValueError naming it otherwise)."""
    if observation is None:
        return dict(MIXTURE_3D_OPTIONS)
    if observation not in auv3d.OBSERVATIONS:
        raise ValueError(f"task {MIXTURE_TASK_3D}: task_kwargs observation must be one of {auv3d.OBSERVATIONS}, got "
                         f"{observation!r}")
    return {**MIXTURE_3D_OPTIONS, "observation": observation}


def mixture_3d_env(envs_per_cell: int, threads: int | None = None, weights: Mapping[str, float] | None = None,
                   options: Mapping[str, str] | None = None, serial: bool = False) -> PlanningMixtureVectorEnv:
    """The 6-DOF training mixture: `envs_per_cell` vehicles a cell before `weights` (names of tasks, tiers or
    waters, multiplied per cell; default MIXTURE_3D_WEIGHTS), with the task `options` (`mixture_3d_options`);
    `serial`: each vehicle in its own environment (what `PlannerTeacher` needs)."""
    cells = mixture_cells(MIXTURE_TASKS_3D)
    counts = cell_counts(envs_per_cell, cells, MIXTURE_3D_WEIGHTS if weights is None else weights)
    return PlanningMixtureVectorEnv(counts, tasks=MIXTURE_TASKS_3D,
                                    task_kwargs=dict(options or MIXTURE_3D_OPTIONS), threads=threads, serial=serial)


class PlannerTeacher:
    """A teacher that senses what the student senses (issue 51, item 5's other answer; Weihs et al. 2020's imitation
    gap): a classical planner acting beside the student on each vehicle's own episode, its action the label.

    The privileged teachers (`BatchTeacher`, `BatchTeacher3D`) read the true map; what they know a student on the
    sonars cannot, and it learns an average of their answers to states it cannot tell apart. `map-replan` knows only
    what the vehicle's own sonar has shown: each row of a serial mixture (`PlanningMixtureVectorEnv(serial=True)`)
    runs its own planner (`factory(dm_env)`), which is called once at every step of its row's episode, whoever
    drives, and so builds its map from the student's own flight. Called at the env's current states, it returns the
    planners' actions (N, act_dim) in the task's action space; a row whose episode has ended (NEXT_STEP's pending
    reset) gets the planner's action at the last state, which DAgger does not count as a transition."""

    def __init__(self, env: PlanningMixtureVectorEnv, factory) -> None:
        self.rows = [env.row_env(i) for i in range(env.num_envs)]
        self.planners: list[Planner] = [as_planner(factory(row.dm_env)) for row in self.rows]

    def actions(self) -> np.ndarray:
        """The planners' actions at every row's current state."""
        out = []
        for row, planner in zip(self.rows, self.planners, strict=True):
            time_step = row.last_time_step
            if time_step.first():
                planner.reset()
            out.append(np.asarray(planner.act(time_step), dtype=float))
        return np.stack(out)


def planar_map_replan(env) -> Planner:
    """`map-replan` on a planar planning task (inside its domain and geofence), acting in the task's action map
    (`InTaskActions`: the student's action="rate")."""
    return InTaskActions(map_replan(env), env)


TEACHERS = ("geodesic", "map-replan")
"""Who labels DAgger's states: the privileged geodesic teacher (`BatchTeacher`, `BatchTeacher3D`), or `map-replan`
acting on the student's own episodes (`PlannerTeacher`; the two mixtures only)."""


def mixture_3d_validator(threads: int | None = None, options: Mapping[str, str] | None = None) -> Validator:
    """DAgger's per-round validation in 3-D: the deterministic student on config.validation_episodes episodes of each
    hard cell (goal3d and tunnel3d, ideal and ocean water; seeds from VALIDATION_FIRST_SEED), the mean as val_success
    and each cell as "cell:task/hard/water"; the task `options` the student was trained with (`mixture_3d_options`)."""
    trained = dict(options or MIXTURE_3D_OPTIONS)

    def validate(model, config: DaggerConfig) -> dict[str, float]:
        rates, collisions = {}, []
        for task in MIXTURE_TASKS_3D:
            for water in ("ideal", "ocean"):
                options = {**trained, "arena": "random", "tier": "hard", "conditions": water}
                result = evaluate_student(
                    lambda n, task=task, options=options: AUV3DVectorEnv(task, n, options, threads=threads), model,
                    config.validation_episodes, VALIDATION_FIRST_SEED, config.validation_max_steps)
                rates[f"{task}/hard/{water}"] = result["val_success"]
                collisions.append(result["val_collision"])
        return {"val_success": float(np.mean(list(rates.values()))), "val_collision": float(np.mean(collisions)),
                "val_episodes": float(config.validation_episodes * len(rates)),
                **{f"cell:{name}": rate for name, rate in rates.items()}}
    return validate


def validate_3d(checkpoint: str | Path, episodes: int = 50, threads: int | None = None) -> dict[str, float]:
    """The deterministic policy of a PPO-kind checkpoint (a student.pt, a fine-tune's or a run's checkpoint.pt) on
    `episodes` validation episodes of each hard 6-DOF cell (`mixture_3d_validator`: the choice between 3-D students)."""
    (tensors, meta), saved = read_ppo(checkpoint)
    model = load_model(checkpoint, tensors, meta["spec"], saved)
    options = {**MIXTURE_3D_OPTIONS, **meta["spec"].get("task_options", {})}
    return dict(mixture_3d_validator(threads, options)(model, DaggerConfig(validation_episodes=episodes)))


def scratch_3d_config(**overrides: Any) -> PPOConfig:
    """PPO from scratch on the 6-DOF mixture: `LEARNED_CONFIG` (the geodesic reward's discount, the annealed learning
    rate, the KL limit, the privileged critic of its own) with the student's network (DaggerConfig's encoder and GRU)
    and one torch thread (`finetune_config`'s reason); no teacher, so no imitation term."""
    student = DaggerConfig()
    base = dataclasses.replace(LEARNED_CONFIG, hidden_sizes=student.hidden_sizes, recurrent=student.recurrent,
                               recurrent_size=student.recurrent_size, torch_threads=student.torch_threads,
                               checkpoint_every=10)
    return dataclasses.replace(base, **overrides)


def train_ppo_3d(run_dir: str | Path, total_steps: int, config: PPOConfig | None = None, envs_per_cell: int = 4, *,
                 observation: str | None = None, resume: bool = False, threads: int | None = None,
                 progress: bool = True, tensorboard: bool = False, validation_episodes: int = 50) -> dict[str, Any]:
    """PPO without a teacher on the 6-DOF mixture (`mixture_3d_env(envs_per_cell)`, the student's problem and batch):
    the learned 3-D planner's no-teacher ablation. `observation` (one of `auv3d.OBSERVATIONS`; the task's own where
    None) is the input it learns from, as a student's (`mixture_3d_options`): the checkpoint keeps it and a resume
    reads it back (another one given on resume is refused). `config` defaults to `scratch_3d_config()` (on resume:
    the checkpoint's). Then the last snapshot's validation (`validate_3d`, `validation_episodes` a hard cell; 0:
    none). Returns the checkpoint, the env steps and the validation."""
    run_dir = Path(run_dir)
    checkpoint = run_dir / PPO_CHECKPOINT
    if not resume and checkpoint.exists():
        raise FileExistsError(f"{checkpoint} exists: give --resume or another -o/--out")
    options = mixture_3d_options(observation)
    if resume and checkpoint.is_file():
        kept = {**MIXTURE_3D_OPTIONS, **read_ppo(checkpoint)[0].metadata["spec"].get("task_options", {})}
        if observation is not None and kept.get("observation") != options["observation"]:
            raise ValueError(f"observation {observation!r}: the run in {run_dir} learns from its own "
                             f"({kept.get('observation', 'the task default')!r}); leave it out on resume")
        options = kept
    env = mixture_3d_env(envs_per_cell, threads, None, options)
    try:
        result = ppo_train(student_view(env), None if resume else (config or scratch_3d_config()), run_dir,
                           total_steps, resume=resume, progress=progress, tensorboard=tensorboard)
    finally:
        env.close()
    out: dict[str, Any] = {"checkpoint": str(result.checkpoint), "env_steps": result.env_steps}
    if validation_episodes:
        out["validation"] = validate_3d(result.checkpoint, validation_episodes, threads)
    return out


def student_mixture(envs_per_cell: int = LEARNED_MIXTURE.envs_per_cell,
                    cell_weights: Sequence[str] | None = None, observation: str | None = None,
                    action: str | None = None) -> MixtureConfig:
    """The student's mixture: `LEARNED_MIXTURE` (the geodesic reward, action="rate", observation="planner", the hard
    cells and tunnels oversampled, validation on 50 episodes a hard cell) with `envs_per_cell` before the weights
    (`cell_weights`, "NAME=WEIGHT" entries, in place of LEARNED_MIXTURE's where given), `observation` in place of
    "planner" where given ("planner-map": the vehicle's own sonar map beside it) and `action` in place of "rate"
    where given ("paper")."""
    weights = LEARNED_MIXTURE.cell_weights if cell_weights is None else tuple(cell_weights)
    return dataclasses.replace(LEARNED_MIXTURE, envs_per_cell=envs_per_cell, cell_weights=weights,
                               observation=observation or LEARNED_MIXTURE.observation,
                               action=action or LEARNED_MIXTURE.action)


def mixture_validator(mixture: MixtureConfig, spec: Mapping[str, Any], threads: int | None = None) -> Validator:
    """DAgger's per-round validation on the mixture: the deterministic student on config.validation_episodes
    episodes of each hard cell (`auv_mj.agents.ppo.planner.validate`, the fine-tune's validation seeds), the mean as
    val_success and each cell as "cell:task/tier/water"."""
    def validate(model, config: DaggerConfig) -> dict[str, float]:
        policy = PPOPolicy(copy.deepcopy(model), spec)  # a float64 copy: the fit goes on
        rates = validate_planner(policy, config.validation_episodes, mixture.tasks, threads=threads,
                                 first_seed=MIXTURE_VALIDATION_SEED, max_steps=config.validation_max_steps,
                                 task_kwargs=mixture.policy_kwargs())
        return {"val_success": float(np.mean(list(rates.values()))), "val_collision": float("nan"),
                "val_episodes": float(config.validation_episodes * len(rates)),
                **{f"cell:{name}": rate for name, rate in rates.items()}}
    return validate


STUDENT_NETWORK_FIELDS = ("hidden_sizes", "recurrent", "recurrent_size", "init_log_std")
"""PPOConfig fields a fine-tune takes from its student (DaggerConfig's), not from `finetune_options`."""


def finetune_config(dagger: DaggerConfig, **overrides: Any) -> PPOConfig:
    """The fine-tune's PPOConfig: `LEARNED_CONFIG` (the privileged critic of its own, the discount, the schedules)
    on the student's network, an imitation term of weight 1 decaying linearly to 0, the student's log std, and the
    fit's torch threads (DaggerConfig.torch_threads, 1 by default: on a 2-core machine shared with the batch and
    the teacher, two intra-op threads made the update of the 56-vehicle mixture several times slower)."""
    base = dataclasses.replace(LEARNED_CONFIG, **{name: getattr(dagger, name) for name in STUDENT_NETWORK_FIELDS},
                               imitation_coef=1.0, min_imitation_coef=0.0, imitation_schedule="linear",
                               seed=dagger.seed, checkpoint_every=10, torch_threads=dagger.torch_threads)
    return dataclasses.replace(base, **overrides)


def checked_finetune_options(options: Mapping[str, Any] | None, ppo_config: PPOConfig | None = None
                             ) -> dict[str, Any]:
    """`train_student`'s finetune_options, checked before anything is written: PPOConfig fields (ValueError naming
    an unknown one, one of STUDENT_NETWORK_FIELDS, which the student's network fixes, or options beside a whole
    `ppo_config`) with values PPOConfig takes; a JSON-able dict (for the run's options file)."""
    options = dict(options or {})
    if not options:
        return {}
    if ppo_config is not None:
        raise ValueError("train_student: give ppo_config (the whole fine-tune config) or finetune_options, not both")
    names = {f.name for f in dataclasses.fields(PPOConfig)}
    unknown = sorted(set(options) - names)
    if unknown:
        raise ValueError(f"finetune_options: {', '.join(unknown)} not PPOConfig fields (of {sorted(names)})")
    fixed = sorted(set(options) & set(STUDENT_NETWORK_FIELDS))
    if fixed:
        raise ValueError(f"finetune_options: {', '.join(fixed)} come from the student's network; set them with "
                         "the DaggerConfig (auv-mj train dagger --dagger-*)")
    dataclasses.replace(PPOConfig(), **options)  # a value PPOConfig refuses is refused here, before the run
    return options


def train_student(run_dir: str | Path, task: str = "obstacles", task_kwargs: Mapping[str, Any] | None = None,
                  num_envs: int = 16, dagger: DaggerConfig | None = None, finetune_steps: int = 0,
                  ppo_config: PPOConfig | None = None, resume: bool = False, threads: int | None = None,
                  progress: bool = True, imitation_coef: float | None = None,
                  rounds: int | None = None, teacher_horizon: float | None = None,
                  final_epochs: int | None = None, final_lr_fraction: float | None = None,
                  cell_weights: Sequence[str] | None = None,
                  finetune_options: Mapping[str, Any] | None = None, teacher: str | None = None) -> dict[str, Any]:
    """DAgger in `run_dir` (module docstring), then `finetune_steps` env steps of PPO in run_dir/ppo (0: none);
    `resume` continues both where they stopped. `task` is a planning task (`num_envs` vehicles, `task_kwargs` laid
    over STUDENT_TASK_KWARGS), MIXTURE_TASK (`student_mixture(num_envs)`: num_envs vehicles a cell before the
    weights) or MIXTURE_TASK_3D (`mixture_3d_env(num_envs)`); a mixture takes no task_kwargs but {"observation": ...}
    (the planar one's: one of PLANNER_OBSERVATIONS; the 6-DOF one's: `auv3d.OBSERVATIONS`). `rounds`: on resume,
    DAgger goes on to that many rounds (its config's otherwise), `final_epochs` sets its final fit's epochs (a further
    fit where one was done) and `final_lr_fraction` that fit's step-size schedule (`train_dagger`).
    The fine-tune's config is `ppo_config`, else
    `finetune_config` of the run's DaggerConfig (the saved one on resume) with `imitation_coef` where given and the
    PPOConfig fields of `finetune_options` laid over it (`checked_finetune_options`: an ablation of the pipeline such
    as privileged_critic=False), given when the run starts or on the resume that starts its fine-tune, and kept in
    the run's options for every resume after.
    Returns the paths written, DAgger's last log row and, after a fine-tune, the student's validation (one task: on
    DAgger's validation episodes, `evaluate_student`; the planar mixture: `train_planner`'s choice; the 6-DOF
    mixture: `mixture_3d_validator` on the last snapshot). `teacher_horizon` [m] (MIXTURE_TASK_3D only; kept for
    resume): the 3-D teacher knows a tube's plug only once within that of it (`BatchTeacher3D`'s horizon), a teacher
    whose knowledge the fan can follow. `cell_weights` (a mixture only; kept for resume): "NAME=WEIGHT" entries
    that oversample cells by task, tier or water, in place of the mixture's own (LEARNED_MIXTURE's,
    MIXTURE_3D_WEIGHTS). `teacher` (one of TEACHERS; kept for resume; default "geodesic"): "map-replan" labels
    with `map-replan` on each vehicle's own episode (`PlannerTeacher`; the mixtures only, whose rows then run
    serially)."""
    if teacher is not None and teacher not in TEACHERS:
        raise ValueError(f"teacher must be one of {TEACHERS}, got {teacher!r}")
    run_dir = Path(run_dir)
    weights: dict[str, float] | None = None
    options_path = run_dir / OPTIONS_NAME
    mixture: MixtureConfig | None = None
    finetune_options = checked_finetune_options(finetune_options, ppo_config)
    if imitation_coef is not None and "imitation_coef" in finetune_options:
        raise ValueError("train_student: give imitation_coef or finetune_options' imitation_coef, not both")
    if resume and options_path.is_file():
        saved = json.loads(options_path.read_text())
        task, kwargs, num_envs = saved["task"], saved["task_kwargs"], int(saved["num_envs"])
        kept_options = saved.get("finetune_options")
        started = (run_dir / FINETUNE_DIR / PPO_CHECKPOINT).is_file()
        if finetune_options and (kept_options is not None or started) and finetune_options != kept_options:
            raise ValueError(f"finetune_options {finetune_options}: the run in {run_dir} keeps its own "
                             f"({kept_options or 'those its fine-tune started with'}); leave them out on resume")
        newly_given = bool(finetune_options) and kept_options is None  # on the resume that starts the fine-tune
        finetune_options = finetune_options or kept_options or {}
        teacher_horizon = saved.get("teacher_horizon")
        if teacher is not None and teacher != saved.get("teacher", "geodesic"):
            raise ValueError(f"teacher {teacher!r}: the run in {run_dir} keeps its own "
                             f"({saved.get('teacher', 'geodesic')!r}); leave it out on resume")
        teacher = saved.get("teacher", "geodesic")
        mixture = mixture_from_dict(saved["mixture"]) if "mixture" in saved else None
        weights = saved.get("weights")
        kept = mixture.weights() if mixture is not None else weights
        if cell_weights is not None and parse_weights(cell_weights) != kept:
            raise ValueError(f"cell_weights {list(cell_weights)}: the run in {run_dir} keeps its own ({kept}); "
                             "leave them out on resume")
        if newly_given:  # kept for every resume after, once nothing else is refused
            options_path.write_text(json.dumps({**saved, "finetune_options": finetune_options}, indent=2))
    else:
        own = {MIXTURE_TASK: student_mixture().task_kwargs(), MIXTURE_TASK_3D: MIXTURE_3D_OPTIONS}
        observation = action = None
        if task in own:
            chosen = mixture_options(task, task_kwargs)
            observation, action = chosen.get("observation"), chosen.get("action")
            task_kwargs = None
            if task == MIXTURE_TASK_3D:
                own[task] = mixture_3d_options(observation)
        if cell_weights is not None and task not in own:
            raise ValueError(f"cell_weights: the mixtures' option ({MIXTURE_TASK}, {MIXTURE_TASK_3D}), got "
                             f"{list(cell_weights)} for task {task}")
        if task == MIXTURE_TASK:
            mixture = student_mixture(num_envs, cell_weights, observation, action)
        elif task == MIXTURE_TASK_3D:
            weights = MIXTURE_3D_WEIGHTS if cell_weights is None else parse_weights(cell_weights)
            cell_counts(num_envs, mixture_cells(MIXTURE_TASKS_3D), weights)  # refused before the run is written
        kwargs = mixture.task_kwargs() if mixture is not None else dict(own[task]) if task in own \
            else {**STUDENT_TASK_KWARGS, **dict(task_kwargs or {})}
        if teacher_horizon is not None and (task != MIXTURE_TASK_3D or not teacher_horizon > 0):
            raise ValueError(f"teacher_horizon: a distance > 0 [m] for task {MIXTURE_TASK_3D} (the 3-D teacher's), "
                             f"got {teacher_horizon!r} for task {task}")
        teacher = teacher or "geodesic"
        if teacher == "map-replan" and (task not in (MIXTURE_TASK, MIXTURE_TASK_3D) or teacher_horizon is not None):
            raise ValueError(f"teacher 'map-replan': tasks {MIXTURE_TASK} and {MIXTURE_TASK_3D} only, without "
                             f"teacher_horizon (its map is what its own sonar has shown), got task {task}"
                             + ("" if teacher_horizon is None else f" and teacher_horizon {teacher_horizon!r}"))
        run_dir.mkdir(parents=True, exist_ok=True)
        record: dict[str, Any] = {"task": task, "task_kwargs": kwargs, "num_envs": num_envs}
        if teacher != "geodesic":
            record["teacher"] = teacher
        if teacher_horizon is not None:
            record["teacher_horizon"] = float(teacher_horizon)
        if finetune_options:
            record["finetune_options"] = finetune_options
        if mixture is not None:
            record["mixture"] = config_to_dict(mixture)
        if task == MIXTURE_TASK_3D:
            record["weights"] = weights
        options_path.write_text(json.dumps(record, indent=2))
    in_3d = task == MIXTURE_TASK_3D
    sensed = teacher == "map-replan"
    if in_3d:
        env = mixture_3d_env(num_envs, threads, weights, kwargs, serial=sensed)
    elif mixture is not None:
        env = mixture.make_env(threads, serial=sensed)
    else:
        env = AUVVectorEnv(task, num_envs=num_envs, task_kwargs=kwargs, threads=threads)
    try:
        labels = (PlannerTeacher(env, sonar_voxel_planner if in_3d else planar_map_replan) if sensed
                  else BatchTeacher3D(env, teacher_horizon) if in_3d else BatchTeacher(env)).actions
        if in_3d:
            validate = mixture_3d_validator(threads, kwargs)
        elif mixture is not None:
            validate = mixture_validator(mixture, student_spec(env), threads)
        else:
            validate = episodes_validator(lambda n: AUVVectorEnv(task, num_envs=n, task_kwargs=kwargs,
                                                                 threads=threads))
        again = resume and (run_dir / CHECKPOINT_NAME).is_file()
        result = train_dagger(env, labels, run_dir, None if again else dagger, resume=again, progress=progress,
                              rounds=rounds if again else None, validate=validate,
                              final_epochs=final_epochs if again else None,
                              final_lr_fraction=final_lr_fraction if again else None)
        dagger = result.config
        out: dict[str, Any] = {"student": str(result.student), "dagger_rounds": result.rounds,
                               "dataset_steps": result.dataset_steps,
                               "last_round": result.log[-1] if result.log else {}}
        if finetune_steps:
            ppo_dir = run_dir / FINETUNE_DIR
            again = resume and (ppo_dir / PPO_CHECKPOINT).is_file()
            extra = {**finetune_options, **({} if imitation_coef is None else {"imitation_coef": imitation_coef})}
            config = None if again else (ppo_config or finetune_config(dagger, **extra))
            if mixture is not None:
                tuned = train_planner(ppo_dir, config, mixture, finetune_steps, resume=again, progress=progress,
                                      threads=threads, env=student_view(env), teacher=labels,
                                      init=run_dir / STUDENT_NAME)
                out.update(finetune_checkpoint=str(tuned["checkpoint"]), finetune_steps=tuned["env_steps"],
                           best=str(tuned["best"]), best_steps=tuned["best_steps"],
                           best_success=tuned["best_success"])
                return out
            tuned = finetune(env, labels, run_dir / STUDENT_NAME, ppo_dir, config, finetune_steps, resume=again,
                             progress=progress)
            out.update(finetune_checkpoint=str(tuned.checkpoint), finetune_steps=tuned.env_steps)
            if dagger.validation_episodes:
                (tensors, meta), saved = read_ppo(tuned.checkpoint)
                model = load_model(tuned.checkpoint, tensors, meta["spec"], saved)
                out["finetune_validation"] = dict(validate(model, dagger))
        return out
    finally:
        env.close()
