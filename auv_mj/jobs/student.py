"""A sensor-only student of the privileged teacher (issue 51, item 5): DAgger, then PPO under a decaying imitation term.

`train_student(run_dir, ...)` joins the pieces that live in separate layers: the batched env
(`auv_mj.tasks.vector.AUVVectorEnv`, observation="planner", action="rate", reward="geodesic"), the teacher that reads
its true state (`auv_mj.planners.teacher.BatchTeacher`; Chen et al. 2019), DAgger (`auv_mj.agents.imitation`; Ross et
al. 2011) and, with `finetune_steps`, PPO from the student with the teacher's labels under the imitation term
(`auv_mj.agents.ppo`, PPOConfig.imitation_coef). `auv-mj train dagger` is argparse over it.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from auv_mj.agents.imitation import (
    CHECKPOINT_NAME,
    STUDENT_NAME,
    DaggerConfig,
    evaluate_student,
    finetune,
    train_dagger,
)
from auv_mj.agents.imitation.dagger import VALIDATION_FIRST_SEED
from auv_mj.agents.ppo import CHECKPOINT_NAME as PPO_CHECKPOINT
from auv_mj.agents.ppo import PPOConfig, load_model, read_ppo
from auv_mj.agents.ppo.planner import LEARNED_CONFIG
from auv_mj.planners.teacher import BatchTeacher
from auv_mj.tasks.vector import AUVVectorEnv

STUDENT_TASK_KWARGS = {"arena": "random", "tier": "hard", "action": "rate", "reward": "geodesic",
                       "observation": "planner"}
"""The student's problem (issue 51): hard-tier random arenas, the geodesic reward, the rate action, the planner
observation; a caller's task options are laid over these."""
FINETUNE_DIR = "ppo"
"""The fine-tune's run directory inside the student's."""
OPTIONS_NAME = "student.json"
"""The task, its options and the batch size of a run (read back on resume)."""


def finetune_config(dagger: DaggerConfig, **overrides: Any) -> PPOConfig:
    """The fine-tune's PPOConfig: `LEARNED_CONFIG` (the privileged critic of its own, the discount, the schedules)
    on the student's network, an imitation term of weight 1 decaying linearly to 0, the student's log std."""
    base = dataclasses.replace(LEARNED_CONFIG, hidden_sizes=dagger.hidden_sizes, recurrent="gru",
                               recurrent_size=dagger.recurrent_size, init_log_std=dagger.init_log_std,
                               imitation_coef=1.0, min_imitation_coef=0.0, imitation_schedule="linear",
                               seed=dagger.seed, checkpoint_every=10)
    return dataclasses.replace(base, **overrides)


def train_student(run_dir: str | Path, task: str = "obstacles", task_kwargs: Mapping[str, Any] | None = None,
                  num_envs: int = 16, dagger: DaggerConfig | None = None, finetune_steps: int = 0,
                  ppo_config: PPOConfig | None = None, resume: bool = False, threads: int | None = None,
                  progress: bool = True, imitation_coef: float | None = None) -> dict[str, Any]:
    """DAgger in `run_dir` (module docstring), then `finetune_steps` env steps of PPO in run_dir/ppo (0: none);
    `resume` continues both where they stopped. The fine-tune's config is `ppo_config`, else `finetune_config` of the
    run's DaggerConfig (the saved one on resume) with `imitation_coef` where given. The paths written, DAgger's last
    log row and, after a fine-tune, its student's validation (on DAgger's validation episodes, `evaluate_student`)."""
    run_dir = Path(run_dir)
    options_path = run_dir / OPTIONS_NAME
    if resume and options_path.is_file():
        saved = json.loads(options_path.read_text())
        task, kwargs, num_envs = saved["task"], saved["task_kwargs"], int(saved["num_envs"])
    else:
        kwargs = {**STUDENT_TASK_KWARGS, **dict(task_kwargs or {})}
        run_dir.mkdir(parents=True, exist_ok=True)
        options_path.write_text(json.dumps({"task": task, "task_kwargs": kwargs, "num_envs": num_envs}, indent=2))
    env = AUVVectorEnv(task, num_envs=num_envs, task_kwargs=kwargs, threads=threads)
    try:
        teacher = BatchTeacher(env).actions
        again = resume and (run_dir / CHECKPOINT_NAME).is_file()
        result = train_dagger(env, teacher, run_dir, None if again else dagger, resume=again, progress=progress,
                              eval_env_fn=lambda n: AUVVectorEnv(task, num_envs=n, task_kwargs=kwargs, threads=threads))
        dagger = result.config
        out: dict[str, Any] = {"student": str(result.student), "dagger_rounds": result.rounds,
                               "dataset_steps": result.dataset_steps,
                               "last_round": result.log[-1] if result.log else {}}
        if finetune_steps:
            ppo_dir = run_dir / FINETUNE_DIR
            again = resume and (ppo_dir / PPO_CHECKPOINT).is_file()
            extra = {} if imitation_coef is None else {"imitation_coef": imitation_coef}
            config = None if again else (ppo_config or finetune_config(dagger, **extra))
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
