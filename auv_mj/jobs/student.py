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
and tunnel3d, both tiers and waters, the hard cells oversampled by MIXTURE_3D_WEIGHTS, reward="geodesic"), the 3-D
teacher (`auv_mj.planners.teacher3d.BatchTeacher3D`), and DAgger's validation on each hard cell
(`mixture_3d_validator`); the student reads the 3-D planning observation (`auv_mj.tasks.auv3d.PLANNING_OBSERVATION`
and the fan) alone. Its PPO fine-tune is not built yet (the privileged critic's inputs are the planar env's):
`finetune_steps` must be 0 there.
"""

from __future__ import annotations

import copy
import dataclasses
import json
from collections.abc import Mapping
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
from auv_mj.agents.imitation.dagger import VALIDATION_FIRST_SEED, Validator
from auv_mj.agents.ppo import CHECKPOINT_NAME as PPO_CHECKPOINT
from auv_mj.agents.ppo import PPOConfig, load_model, read_ppo
from auv_mj.agents.ppo.planner import LEARNED_CONFIG, LEARNED_MIXTURE, MixtureConfig, mixture_from_dict, train_planner
from auv_mj.agents.ppo.planner import VALIDATION_FIRST_SEED as MIXTURE_VALIDATION_SEED
from auv_mj.agents.ppo.planner import validate as validate_planner
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.spaces import student_view
from auv_mj.planners.teacher import BatchTeacher
from auv_mj.planners.teacher3d import BatchTeacher3D
from auv_mj.tasks.mixture import MIXTURE_TASKS_3D, PlanningMixtureVectorEnv, cell_counts, mixture_cells
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
MIXTURE_3D_OPTIONS = {"reward": "geodesic"}
"""The 6-DOF student's task options (beside each cell's arena, tier and water)."""


def mixture_3d_env(envs_per_cell: int, threads: int | None = None) -> PlanningMixtureVectorEnv:
    """The 6-DOF training mixture: `envs_per_cell` vehicles a cell before MIXTURE_3D_WEIGHTS."""
    cells = mixture_cells(MIXTURE_TASKS_3D)
    return PlanningMixtureVectorEnv(cell_counts(envs_per_cell, cells, MIXTURE_3D_WEIGHTS), tasks=MIXTURE_TASKS_3D,
                                    task_kwargs=MIXTURE_3D_OPTIONS, threads=threads)


def mixture_3d_validator(threads: int | None = None) -> Validator:
    """DAgger's per-round validation in 3-D: the deterministic student on config.validation_episodes episodes of each
    hard cell (goal3d and tunnel3d, ideal and ocean water; seeds from VALIDATION_FIRST_SEED), the mean as val_success
    and each cell as "cell:task/hard/water"."""
    def validate(model, config: DaggerConfig) -> dict[str, float]:
        rates, collisions = {}, []
        for task in MIXTURE_TASKS_3D:
            for water in ("ideal", "ocean"):
                options = {**MIXTURE_3D_OPTIONS, "arena": "random", "tier": "hard", "conditions": water}
                result = evaluate_student(
                    lambda n, task=task, options=options: AUV3DVectorEnv(task, n, options, threads=threads), model,
                    config.validation_episodes, VALIDATION_FIRST_SEED, config.validation_max_steps)
                rates[f"{task}/hard/{water}"] = result["val_success"]
                collisions.append(result["val_collision"])
        return {"val_success": float(np.mean(list(rates.values()))), "val_collision": float(np.mean(collisions)),
                "val_episodes": float(config.validation_episodes * len(rates)),
                **{f"cell:{name}": rate for name, rate in rates.items()}}
    return validate


def student_mixture(envs_per_cell: int = LEARNED_MIXTURE.envs_per_cell) -> MixtureConfig:
    """The student's mixture: `LEARNED_MIXTURE` (the geodesic reward, action="rate", observation="planner", the hard
    cells and tunnels oversampled, validation on 50 episodes a hard cell) with `envs_per_cell` before the weights."""
    return dataclasses.replace(LEARNED_MIXTURE, envs_per_cell=envs_per_cell)


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


def finetune_config(dagger: DaggerConfig, **overrides: Any) -> PPOConfig:
    """The fine-tune's PPOConfig: `LEARNED_CONFIG` (the privileged critic of its own, the discount, the schedules)
    on the student's network, an imitation term of weight 1 decaying linearly to 0, the student's log std, and the
    fit's torch threads (DaggerConfig.torch_threads, 1 by default: on a 2-core machine shared with the batch and
    the teacher, two intra-op threads made the update of the 56-vehicle mixture several times slower)."""
    base = dataclasses.replace(LEARNED_CONFIG, hidden_sizes=dagger.hidden_sizes, recurrent="gru",
                               recurrent_size=dagger.recurrent_size, init_log_std=dagger.init_log_std,
                               imitation_coef=1.0, min_imitation_coef=0.0, imitation_schedule="linear",
                               seed=dagger.seed, checkpoint_every=10, torch_threads=dagger.torch_threads)
    return dataclasses.replace(base, **overrides)


def train_student(run_dir: str | Path, task: str = "obstacles", task_kwargs: Mapping[str, Any] | None = None,
                  num_envs: int = 16, dagger: DaggerConfig | None = None, finetune_steps: int = 0,
                  ppo_config: PPOConfig | None = None, resume: bool = False, threads: int | None = None,
                  progress: bool = True, imitation_coef: float | None = None) -> dict[str, Any]:
    """DAgger in `run_dir` (module docstring), then `finetune_steps` env steps of PPO in run_dir/ppo (0: none);
    `resume` continues both where they stopped. `task` is a planning task (`num_envs` vehicles, `task_kwargs` laid
    over STUDENT_TASK_KWARGS) or MIXTURE_TASK (`student_mixture(num_envs)`: num_envs vehicles a cell before the
    weights; task_kwargs must be empty). The fine-tune's config is `ppo_config`, else `finetune_config` of the run's
    DaggerConfig (the saved one on resume) with `imitation_coef` where given. Returns the paths written, DAgger's
    last log row and, after a fine-tune, the student's validation (one task: on DAgger's validation episodes,
    `evaluate_student`; the mixture: `train_planner`'s choice)."""
    run_dir = Path(run_dir)
    options_path = run_dir / OPTIONS_NAME
    mixture: MixtureConfig | None = None
    if task == MIXTURE_TASK_3D or (resume and options_path.is_file()
                                   and json.loads(options_path.read_text())["task"] == MIXTURE_TASK_3D):
        return _train_student_3d(run_dir, task_kwargs, num_envs, dagger, finetune_steps, resume, threads, progress)
    if resume and options_path.is_file():
        saved = json.loads(options_path.read_text())
        task, kwargs, num_envs = saved["task"], saved["task_kwargs"], int(saved["num_envs"])
        mixture = mixture_from_dict(saved["mixture"]) if "mixture" in saved else None
    else:
        if task == MIXTURE_TASK:
            if task_kwargs:
                raise ValueError(f"task {MIXTURE_TASK}: the mixture sets the task options itself "
                                 f"({student_mixture().task_kwargs()}), got task_kwargs {dict(task_kwargs)}")
            mixture = student_mixture(num_envs)
            kwargs = mixture.task_kwargs()
        else:
            kwargs = {**STUDENT_TASK_KWARGS, **dict(task_kwargs or {})}
        run_dir.mkdir(parents=True, exist_ok=True)
        record = {"task": task, "task_kwargs": kwargs, "num_envs": num_envs}
        if mixture is not None:
            record["mixture"] = config_to_dict(mixture)
        options_path.write_text(json.dumps(record, indent=2))
    env = mixture.make_env(threads) if mixture is not None else AUVVectorEnv(task, num_envs=num_envs,
                                                                            task_kwargs=kwargs, threads=threads)
    try:
        teacher = BatchTeacher(env).actions
        again = resume and (run_dir / CHECKPOINT_NAME).is_file()
        if mixture is not None:
            checks = {"validate": mixture_validator(mixture, student_spec(env), threads)}
        else:
            checks = {"eval_env_fn": lambda n: AUVVectorEnv(task, num_envs=n, task_kwargs=kwargs, threads=threads)}
        result = train_dagger(env, teacher, run_dir, None if again else dagger, resume=again, progress=progress,
                              **checks)
        dagger = result.config
        out: dict[str, Any] = {"student": str(result.student), "dagger_rounds": result.rounds,
                               "dataset_steps": result.dataset_steps,
                               "last_round": result.log[-1] if result.log else {}}
        if finetune_steps:
            ppo_dir = run_dir / FINETUNE_DIR
            again = resume and (ppo_dir / PPO_CHECKPOINT).is_file()
            extra = {} if imitation_coef is None else {"imitation_coef": imitation_coef}
            config = None if again else (ppo_config or finetune_config(dagger, **extra))
            if mixture is not None:
                tuned = train_planner(ppo_dir, config, mixture, finetune_steps, resume=again, progress=progress,
                                      threads=threads, env=student_view(env), teacher=teacher,
                                      init=run_dir / STUDENT_NAME)
                out.update(finetune_checkpoint=str(tuned["checkpoint"]), finetune_steps=tuned["env_steps"],
                           best=str(tuned["best"]), best_steps=tuned["best_steps"],
                           best_success=tuned["best_success"])
                return out
            tuned = finetune(env, teacher, run_dir / STUDENT_NAME, ppo_dir, config, finetune_steps, resume=again,
                             progress=progress)
            out.update(finetune_checkpoint=str(tuned.checkpoint), finetune_steps=tuned.env_steps)
            episodes = dagger.validation_episodes
            if episodes:
                (tensors, meta), saved = read_ppo(tuned.checkpoint)
                model = load_model(tuned.checkpoint, tensors, meta["spec"], saved)
                out["finetune_validation"] = evaluate_student(
                    lambda n: AUVVectorEnv(task, num_envs=n, task_kwargs=kwargs, threads=threads), model, episodes,
                    VALIDATION_FIRST_SEED, dagger.validation_max_steps)
        return out
    finally:
        env.close()


def _train_student_3d(run_dir: Path, task_kwargs: Mapping[str, Any] | None, num_envs: int,
                      dagger: DaggerConfig | None, finetune_steps: int, resume: bool, threads: int | None,
                      progress: bool) -> dict[str, Any]:
    """`train_student` on the 6-DOF mixture (module docstring): DAgger only."""
    if task_kwargs:
        raise ValueError(f"task {MIXTURE_TASK_3D}: the mixture sets the task options itself ({MIXTURE_3D_OPTIONS}), "
                         f"got task_kwargs {dict(task_kwargs)}")
    if finetune_steps:
        raise ValueError(f"task {MIXTURE_TASK_3D}: the PPO fine-tune is not built in 3-D yet; give --steps 0")
    options_path = run_dir / OPTIONS_NAME
    if resume and options_path.is_file():
        num_envs = int(json.loads(options_path.read_text())["num_envs"])
    else:
        run_dir.mkdir(parents=True, exist_ok=True)
        options_path.write_text(json.dumps({"task": MIXTURE_TASK_3D, "task_kwargs": MIXTURE_3D_OPTIONS,
                                            "num_envs": num_envs, "weights": MIXTURE_3D_WEIGHTS}, indent=2))
    env = mixture_3d_env(num_envs, threads)
    try:
        again = resume and (run_dir / CHECKPOINT_NAME).is_file()
        result = train_dagger(env, BatchTeacher3D(env).actions, run_dir, None if again else dagger, resume=again,
                              progress=progress, validate=mixture_3d_validator(threads))
        return {"student": str(result.student), "dagger_rounds": result.rounds, "dataset_steps": result.dataset_steps,
                "last_round": result.log[-1] if result.log else {}}
    finally:
        env.close()
