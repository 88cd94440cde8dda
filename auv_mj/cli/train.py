"""`auv-mj train AGENT --task TASK`: a thin command over `auv_mj.agents.offpolicy.train.train` (the training library).

It parses the options (every `DDPGConfig` field is one), builds the Gymnasium factory of the task with
its `--task-kwargs` / `--arena`, and hands both to the library.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import re
from pathlib import Path
from typing import Any

import gymnasium as gym

import auv_mj  # noqa: F401  (registers the auv_mj Gymnasium ids)
from auv_mj import zoo
from auv_mj.agents import ppo
from auv_mj.agents.checkpoint import read_checkpoint, saved_config
from auv_mj.agents.imitation import DaggerConfig
from auv_mj.agents.offpolicy.ddpg import EPSILON_UNITS, DDPGConfig, field_docs
from auv_mj.agents.offpolicy.learners import agent_classes
from auv_mj.agents.offpolicy.td3 import TD3Config
from auv_mj.agents.offpolicy.train import AGENTS, CHECKPOINT_NAME, WINDOW, errors_text, train
from auv_mj.agents.ppo import PPOConfig
from auv_mj.agents.ppo.config import IMITATION_SOURCES, SCHEDULES
from auv_mj.agents.ppo.planner import (
    LEARNED_CONFIG,
    LEARNED_MIXTURE,
    MIXTURE_NAME,
    PLANNER_CONFIG,
    MixtureConfig,
    mixture_from_dict,
)
from auv_mj.cli.options import (
    MAX_PROCESSES,
    add_output_option,
    bounded_int,
    json_object,
    positive_int,
    seed_int,
    task_kwargs,
    usage_error,
)
from auv_mj.inputs import check_json_depth, did_you_mean, read_text, unknown_name
from auv_mj.jobs.student import (
    MIXTURE_TASK,
    MIXTURE_TASK_3D,
    TEACHERS,
    continue_planner,
    mixture_options,
    scratch_3d_config,
    train_ppo_3d,
    train_student,
)
from auv_mj.planners.deploy import ChainConfig, deploy_env
from auv_mj.tasks import suite
from auv_mj.tasks.gym_adapter import gym_id
from auv_mj.tasks.planning_rewards import REWARDS

TASK_IDS: dict[str, str] = {}
"""Suite task name -> Gymnasium id, where the default `auv_mj/<CamelCase>-v0` rule does not apply."""


def task_env_id(task: str) -> str:
    """The Gymnasium id of a suite task: TASK_IDS[task], an id given as is, the suite's own id of a task of either
    domain (`auv_mj.tasks.gym_adapter.gym_id`: goal3d -> auv_mj/Goal3D-v0), or `auv_mj/<CamelCase>-v0` where that
    is registered; ValueError naming the nearest task otherwise."""
    if task in TASK_IDS:
        return TASK_IDS[task]
    if "/" in task or ":" in task:
        return task
    if any(task in names for names in suite.TASKS_BY_DOMAIN.values()):
        return gym_id(task)
    camel = "".join(part[:1].upper() + part[1:] for part in re.split(r"[-_\s]+", task) if part)
    env_id = f"auv_mj/{camel}-v0"
    if env_id not in gym.registry:  # a mistyped task name is refused as one, with the nearest
        tasks = [t for names in suite.TASKS_BY_DOMAIN.values() for t in names]
        raise ValueError(unknown_name("task", task, tasks, " (domains auv, then auv3d); or a Gymnasium id, "
                                      "auv_mj/NAME-v0"))
    return env_id


@dataclasses.dataclass(frozen=True)
class EnvFactory:
    """`gymnasium.make(env_id, **kwargs)` as a picklable factory (for collector processes and Ray trials).

    Unpickling it imports this module, which registers the auv_mj ids; `module` (from Gymnasium's
    `module:id` form) is imported first too, for ids registered elsewhere.
    """

    env_id: str
    kwargs: dict = dataclasses.field(default_factory=dict)
    module: str | None = None

    def __call__(self) -> gym.Env:
        if self.module:
            importlib.import_module(self.module)
        chain = {k: v for k, v in self.kwargs.items() if k in ChainConfig.__dataclass_fields__}
        rest = {k: v for k, v in self.kwargs.items() if k not in chain}
        return deploy_env(gym.make(self.env_id, **rest), **chain)


def make_env_fn(env_id: str, **kwargs: Any) -> EnvFactory:
    """A factory of `gymnasium.make(env_id)`; ValueError listing the auv_mj ids if it is not registered.

    `module:id` (Gymnasium's form) imports `module` first, which registers `id`.
    """
    module = None
    if ":" in env_id:
        module, _, env_id = env_id.partition(":")
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise ValueError(f"Gymnasium id {module}:{env_id}: cannot import {module!r} ({exc})") from None
    if env_id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("auv_mj/"))
        raise ValueError(f"Gymnasium id {env_id!r} is not registered{did_you_mean(env_id, known)}; "
                         f"registered auv_mj ids: {', '.join(known) or 'none'}")
    return EnvFactory(env_id, kwargs, module)


_CLI_SKIP = ("seed", "device")
ENV_KWARGS_NAME = "env_kwargs.json"
"""File in the run directory holding the --env-kwargs of the run."""
TASK_KWARGS_NAME = "task_kwargs.json"
"""File in the run directory holding the --task-kwargs of the run."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj train AGENT --task TASK ...`; every DDPGConfig field is an option."""
    parser.add_argument("agent", choices=(*AGENTS, "ppo", "dagger"),
                        help="ddpg | her-ddpg (goal tasks) | executor (SpeedHeading) | td3 (DDPG with twin "
                             "critics, delayed actor, target smoothing; any task) | ppo (--task planning-mix: "
                             "the batched mixture of planning tasks, tiers and waters; options under 'ppo'; "
                             f"--task {MIXTURE_TASK_3D}: the 6-DOF mixture, from scratch) | "
                             "dagger (a sensor-only student of the privileged geodesic-teacher on one batched "
                             "planning task, then PPO with a decaying imitation term for --steps; options under "
                             "'dagger')")
    parser.add_argument("--task", required=True, help="suite task name ("
                        + "; ".join(f"domain {d}: {', '.join(names)}" for d, names in suite.TASKS_BY_DOMAIN.items())
                        + f"), {PPO_TASK} (ppo) or a Gymnasium id (auv_mj/...-v0)")
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON",
                        help='task options, e.g. \'{"command": "random", "disturbances": "random"}\'; '
                             "kept in the run directory and reused by --resume")
    parser.add_argument("--arena", default=None, metavar="PATH",
                        help="arena MJCF for the task (shortcut for --task-kwargs '{\"arena\": PATH}')")
    parser.add_argument("--env-kwargs", type=json_object, default=None, metavar="JSON",
                        help="keyword arguments of the Gymnasium environment, e.g. '{\"protection\": true}' "
                             "(the protection domain in the loop; \"speed-aware\" for ours) or, for --task "
                             "planning, '{\"tasks\": [\"goal\", \"tunnel\"], \"per_task_kwargs\": {\"tunnel\": "
                             "{\"arena\": \"random\"}}}'; kept in the run directory and reused by --resume")
    parser.add_argument("--steps", type=positive_int, help="total env steps (default: --episodes)")
    parser.add_argument("--episodes", type=positive_int, help="total episodes (default: max_episodes, Table 4)")
    add_output_option(parser, "the run directory: checkpoints, logs, options (default "
                      "runs/<task>/<agent>-seed<seed>)", old="--run-dir", type=Path, metavar="DIR")
    parser.add_argument("--resume", action="store_true", help="continue the run in -o/--out")
    parser.add_argument("--init", metavar="CHECKPOINT",
                        help="start a new run from this checkpoint's networks (fine-tuning): a checkpoint path or "
                             "a learned policy's name, for its shipped checkpoint (e.g. planner-route; "
                             "`auv-mj policies` lists them)")
    parser.add_argument("--teacher-mover-reach", type=float, metavar="M",
                        help=f"--task {PPO_TASK} with --ppo-imitation-coef: the privileged teacher labels only the "
                             "states with a mover within M metres of the vehicle, and the imitation term leaves the "
                             "rest to RL (default: every state)")
    parser.add_argument("--zero-actor-head", action="store_true",
                        help="a new run's actor output layer starts at zero: a residual planner starts as its "
                             "classical skeleton (with --actor-burn-in, the critic learns it first)")
    parser.add_argument("--seed", type=seed_int, help="run seed (default 0, or the checkpoint's)")
    parser.add_argument("--device", help="torch device, cpu or cuda (default cpu, or the checkpoint's)")
    parser.add_argument("--checkpoint-every", type=positive_int, default=100, help="episodes between checkpoints")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-tensorboard", action="store_true", help="no TensorBoard scalars")
    parser.add_argument("--collectors", type=bounded_int(0, MAX_PROCESSES), default=0, metavar="N",
                        help="step N environments in collector processes while this one learns (1 uses a "
                             "second core; deterministic given --seed and N, not the serial run) (default: 0, serial)")
    add_config_options(parser)
    add_ppo_options(parser)
    add_dagger_options(parser)


def add_dagger_options(parser: argparse.ArgumentParser) -> None:
    """Options of `auv-mj train dagger --task TASK`: the batch and one `--dagger-FIELD` per DaggerConfig number
    (defaults: `auv_mj.agents.imitation.DaggerConfig`), and the fine-tune's imitation weight."""
    group = parser.add_argument_group(f"dagger (--task obstacles | moving_obstacles | tunnel | goal, --task-kwargs "
                                      "over the student's problem, hard tier, action rate, reward geodesic, "
                                      f"observation planner; or --task {MIXTURE_TASK}, the whole training mixture "
                                      "with the hard cells oversampled, --task-kwargs setting only its observation "
                                      "and action; --steps: PPO fine-tune steps after DAgger, "
                                      "default 0)")
    group.add_argument("--num-envs", type=positive_int, default=16,
                       help=f"vehicles of the batch (default 16); with --task {MIXTURE_TASK}, vehicles a cell before "
                            "the cells' weights")
    for f in dataclasses.fields(DaggerConfig):
        if f.type in ("int", "float") and f.name not in ("seed", "torch_threads"):
            group.add_argument(f"--dagger-{f.name.replace('_', '-')}", dest="dagger_" + f.name,
                               type=int if f.type == "int" else float,
                               help=f"DaggerConfig.{f.name}" + {
                                   "rounds": " (with --resume: the rounds to go on to)",
                                   "final_epochs": " (with --resume: a final fit of a finished run, or a further "
                                                   "one where it had one)",
                                   "final_lr_fraction": " (a cosine to it from the learning rate over the final "
                                                        "fit; with --resume: that of the fit it starts)"
                                   }.get(f.name, ""))
    group.add_argument("--teacher-horizon", type=float, metavar="M",
                       help=f"--task {MIXTURE_TASK_3D}: the teacher knows a tube's plug only once within M metres of "
                            "it (default: it knows the whole tube)")
    group.add_argument("--dagger-teacher", choices=TEACHERS,
                       help=f"who labels the student's states: geodesic, the privileged teacher on the true map "
                            f"(default), or map-replan acting on each vehicle's own episode, a teacher that senses "
                            f"what the student senses (--task {MIXTURE_TASK} or {MIXTURE_TASK_3D}; its vehicles "
                            f"step one by one, several times slower)")
    group.add_argument("--dagger-recurrent", choices=("gru", "lstm", "none"),
                       help="DaggerConfig.recurrent, the student's memory (none: a feed-forward student; default gru)")
    group.add_argument("--imitation-coef", type=float, help="the fine-tune's imitation weight at its start, "
                       "decaying linearly to 0 (default 1)")


def _run_dagger(args: argparse.Namespace) -> int:
    """`auv-mj train dagger`: `auv_mj.jobs.student.train_student`."""
    try:
        run_dir = args.run_dir or Path("runs") / f"dagger-{args.task}" / f"seed{args.seed or 0}"
        overrides = {f.name: getattr(args, "dagger_" + f.name) for f in dataclasses.fields(DaggerConfig)
                     if getattr(args, "dagger_" + f.name, None) is not None}
        if overrides.get("recurrent") == "none":
            overrides["recurrent"] = None
        if args.seed is not None:
            overrides["seed"] = args.seed
        finetune = {name: value for name, value in _ppo_overrides(args).items() if name not in ("seed", "device")}
        if finetune and not args.steps:
            raise ValueError(f"{', '.join('--ppo-' + n.replace('_', '-') for n in sorted(finetune))}: options of the "
                             "fine-tune after DAgger; give its env steps with --steps")
        result = train_student(run_dir, args.task, task_kwargs(args) or None, args.num_envs,
                               DaggerConfig(**overrides), args.steps or 0, resume=args.resume, threads=args.threads,
                               progress=not args.no_progress, imitation_coef=args.imitation_coef,
                               rounds=args.dagger_rounds if args.resume else None,
                               teacher_horizon=args.teacher_horizon,
                               final_epochs=args.dagger_final_epochs if args.resume else None,
                               final_lr_fraction=args.dagger_final_lr_fraction if args.resume else None,
                               cell_weights=args.cell_weights, finetune_options=finetune or None,
                               teacher=args.dagger_teacher)
    except (ValueError, TypeError, FileNotFoundError, FileExistsError) as exc:
        usage_error(args, str(exc))
    print(json.dumps(result, indent=2, default=str))
    return 0


PPO_PRESETS = {"shipped": (PLANNER_CONFIG, MixtureConfig()), "learned": (LEARNED_CONFIG, LEARNED_MIXTURE)}
"""`auv-mj train ppo --preset`: the PPOConfig and MixtureConfig every option defaults to."""
PPO_TASK = MIXTURE_TASK
"""The task name of `auv-mj train ppo`: `auv_mj.tasks.mixture.PlanningMixtureVectorEnv`."""


def add_ppo_options(parser: argparse.ArgumentParser) -> None:
    """Options of `auv-mj train ppo --task planning-mix`: the mixture, validation, and one `--ppo-FIELD` per
    PPOConfig field but seed and device (defaults: `auv_mj.agents.ppo.planner.PLANNER_CONFIG`)."""
    group = parser.add_argument_group("ppo (--task planning-mix: obstacles, moving_obstacles, tunnel on random arenas, "
                                      "both tiers, both waters, training seeds only; validation on the hard tier's "
                                      "validation seeds)")
    mix = MixtureConfig()
    group.add_argument("--preset", choices=tuple(PPO_PRESETS), default="shipped",
                       help="the defaults of every option below: shipped (PLANNER_CONFIG and MixtureConfig(), the "
                            "published planner-memory run) or learned (LEARNED_CONFIG and LEARNED_MIXTURE: the "
                            "geodesic reward, annealed learning rate, KL limit, privileged critic, hard cells "
                            "oversampled, windowed choice) [shipped; on --resume, the run's own]")
    group.add_argument("--envs-per-cell", type=positive_int,
                       help=f"vehicles per (task, tier, water) before --cell-weights [{mix.envs_per_cell}]")
    group.add_argument("--cell-weights", nargs="+", metavar="NAME=WEIGHT",
                       help="oversample cells: weights of tasks, tiers or waters, multiplied per cell, e.g. "
                            "hard=1.5 standard=0.5 tunnel=1.5 [none]; dagger on a mixture: in place of its own "
                            f"(--task {MIXTURE_TASK_3D}: standard=0.5 hard=1.5), kept for --resume")
    group.add_argument("--reward", choices=REWARDS, help=f"the tasks' reward [{mix.reward}]")
    group.add_argument("--collision-penalty", type=float, help=f"penalty on a collision or leaving the map "
                                                               f"[{mix.collision_penalty}]")
    group.add_argument("--reward-scale", type=float, help=f"multiplies every reward [{mix.reward_scale}]")
    group.add_argument("--validate-every", type=positive_int, metavar="STEPS",
                       help=f"env steps between validations and snapshots (rounded up to checkpoint periods) "
                            f"[{mix.validate_every}]")
    group.add_argument("--validation-episodes", type=positive_int, metavar="N",
                       help=f"validation-seed episodes per hard-tier cell [{mix.validation_episodes}]")
    group.add_argument("--validation-window", type=positive_int, metavar="K",
                       help=f"choose best.pt on the mean of K consecutive validations [{mix.validation_window}]")
    group.add_argument("--validation-max-steps", type=positive_int, metavar="N",
                       help="cut validation episodes after N steps (counted as failures) [the tasks' time limits]")
    group.add_argument("--goal-input", type=_boolean, metavar="true|false",
                       help=f"the learner reads desired_goal beside the observation [{mix.goal_input}]")
    group.add_argument("--threads", type=positive_int, help="threads of the batched physics [this process's CPUs]")
    docs = field_docs(PPOConfig)
    for field in dataclasses.fields(PPOConfig):
        if field.name in _CLI_SKIP:
            continue
        default = getattr(PLANNER_CONFIG, field.name)
        flag, help_text = "--ppo-" + field.name.replace("_", "-"), f"{docs.get(field.name, '')} [{default}]"
        if field.name == "hidden_sizes":
            group.add_argument(flag, type=int, nargs="+", help=help_text)
        elif field.name == "recurrent":
            group.add_argument(flag, choices=("gru", "lstm", "none"), help=help_text + " (none: no memory)")
        elif field.name == "target_kl":
            group.add_argument(flag, type=float, help=help_text)
        elif field.name in ("lr_schedule", "clip_schedule", "imitation_schedule"):
            group.add_argument(flag, choices=SCHEDULES, help=help_text)
        elif field.name == "imitation_source":
            group.add_argument(flag, choices=IMITATION_SOURCES, help=help_text)
        elif isinstance(default, bool):
            group.add_argument(flag, type=_boolean, help=help_text)
        else:
            group.add_argument(flag, type=type(default), help=help_text)


def _boolean(text: str) -> bool:
    if text.lower() in ("true", "1", "yes"):
        return True
    if text.lower() in ("false", "0", "no"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {text!r}")


def _run_ppo(args: argparse.Namespace) -> int:
    """`auv-mj train ppo --task planning-mix`: `auv_mj.agents.ppo.planner.train_planner`; `--task planning-mix-3d`:
    `auv_mj.jobs.student.train_ppo_3d`."""
    try:
        if args.task not in (PPO_TASK, MIXTURE_TASK_3D):
            raise ValueError(f"agent ppo trains on --task {PPO_TASK} (the batched mixture) or {MIXTURE_TASK_3D} (the "
                             f"6-DOF mixture), got {args.task!r}")
        if args.steps is None:
            raise ValueError("agent ppo needs --steps (total env steps)")
        if args.task == MIXTURE_TASK_3D:
            return _run_ppo_3d(args)
        run_dir = args.run_dir or Path("runs") / PPO_TASK / f"ppo-seed{args.seed or 0}"
        overrides = _ppo_overrides(args)
        mix_fields = {"envs_per_cell": args.envs_per_cell, "reward": args.reward,
                      "collision_penalty": args.collision_penalty, "reward_scale": args.reward_scale,
                      "cell_weights": tuple(args.cell_weights) if args.cell_weights else None,
                      "validate_every": args.validate_every, "validation_episodes": args.validation_episodes,
                      "validation_window": args.validation_window,
                      "validation_max_steps": args.validation_max_steps, "goal_input": args.goal_input}
        mix_overrides = {k: v for k, v in mix_fields.items() if v is not None}
        if args.resume and args.init:
            raise ValueError("--init starts a new run; it cannot be combined with --resume")
        init = None if args.init is None else zoo.checkpoint_path(args.init, args.task)
        if args.resume:
            base_mix = mixture_from_dict(_read_options(run_dir / MIXTURE_NAME))
            base = ppo.read_ppo(run_dir / ppo.CHECKPOINT_NAME)[1]
        else:
            base, base_mix = PPO_PRESETS[args.preset]
            if (run_dir / ppo.CHECKPOINT_NAME).exists():
                raise FileExistsError(f"{run_dir / ppo.CHECKPOINT_NAME} exists: give --resume or another -o/--out")
        mixture = dataclasses.replace(base_mix, **mix_overrides)
        config = dataclasses.replace(base, **overrides)
        result = continue_planner(run_dir, config, mixture, args.steps, resume=args.resume,
                                  progress=not args.no_progress, tensorboard=not args.no_tensorboard,
                                  threads=args.threads, init=init, mover_reach=args.teacher_mover_reach)
    except (ValueError, TypeError, FileNotFoundError, FileExistsError) as exc:
        usage_error(args, str(exc))
    print(f"{result['env_steps']} steps; chosen: the snapshot at {result['best_steps']} steps, hard-tier "
          f"validation success {result['best_point']:.3f} (mean of its window {result['best_success']:.3f})")
    print(f"checkpoint: {result['checkpoint']}  best: {result['best']}")
    return 0


def _ppo_overrides(args: argparse.Namespace) -> dict:
    """The PPOConfig fields given as `--ppo-FIELD` options (and --seed, --device)."""
    overrides = {f.name: getattr(args, "ppo_" + f.name) for f in dataclasses.fields(PPOConfig)
                 if getattr(args, "ppo_" + f.name, None) is not None}
    if "hidden_sizes" in overrides:
        overrides["hidden_sizes"] = tuple(overrides["hidden_sizes"])
    if overrides.get("recurrent") == "none":
        overrides["recurrent"] = None
    for name in ("seed", "device"):
        if getattr(args, name) is not None:
            overrides[name] = getattr(args, name)
    return overrides


def _run_ppo_3d(args: argparse.Namespace) -> int:
    """`auv-mj train ppo --task planning-mix-3d`: PPO without a teacher on the 6-DOF mixture (the learned 3-D
    planner's no-teacher ablation), `--envs-per-cell` vehicles a cell before its weights, the `--ppo-*` options over
    `scratch_3d_config()`; the mixture options of the planar one do not apply."""
    planar = [name for name in ("reward", "collision_penalty", "reward_scale", "cell_weights", "validate_every",
                                "validation_max_steps", "goal_input", "init")
              if getattr(args, name, None) is not None]
    if planar:
        raise ValueError(f"--task {MIXTURE_TASK_3D} takes its own problem and batch (--preset does not apply either); "
                         "drop " + ", ".join(f"--{name.replace('_', '-')}" for name in planar))
    observation = mixture_options(MIXTURE_TASK_3D, task_kwargs(args)).get("observation")
    run_dir = args.run_dir or Path("runs") / MIXTURE_TASK_3D / f"ppo-seed{args.seed or 0}"
    config = None if args.resume else scratch_3d_config(**_ppo_overrides(args))
    result = train_ppo_3d(run_dir, args.steps, config, args.envs_per_cell or 4,
                          observation=observation, resume=args.resume,
                          threads=args.threads, progress=not args.no_progress, tensorboard=not args.no_tensorboard,
                          validation_episodes=args.validation_episodes or 50)
    print(json.dumps(result, indent=2, default=str))
    return 0


def add_config_options(parser: argparse.ArgumentParser) -> None:
    """One option per TD3Config field (DDPGConfig's and TD3's three) but seed and device (`--hidden-sizes 64 64`,
    `--noise-std 0.3`, `--policy-delay 2`, ...)."""
    group = parser.add_argument_group("hyper-parameters (DDPGConfig, and TD3Config for td3; default Table 4 "
                                      "or the checkpoint's)")
    docs = {**field_docs(DDPGConfig), **field_docs(TD3Config)}
    td3_only = _td3_only()
    for field in dataclasses.fields(TD3Config):
        if field.name in _CLI_SKIP:
            continue
        flag, help_text = "--" + field.name.replace("_", "-"), f"{docs.get(field.name, '')} [{field.default}]"
        if field.name in td3_only:
            help_text = "td3 only: " + help_text
        if field.name == "hidden_sizes":
            group.add_argument(flag, type=int, nargs="+", help=help_text)
        elif field.name == "epsilon_unit":
            group.add_argument(flag, choices=EPSILON_UNITS, help=help_text)
        else:
            group.add_argument(flag, type=type(field.default), help=help_text)


def _td3_only() -> set[str]:
    return {f.name for f in dataclasses.fields(TD3Config)} - {f.name for f in dataclasses.fields(DDPGConfig)}


def config_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The config fields given on the command line (hidden_sizes as a tuple); ValueError for a TD3 option
    given to another agent."""
    overrides = {f.name: getattr(args, f.name) for f in dataclasses.fields(TD3Config)
                 if getattr(args, f.name, None) is not None}
    stray = sorted(set(overrides) & _td3_only()) if getattr(args, "agent", "td3") != "td3" else []
    if stray:
        raise ValueError(f"--{stray[0].replace('_', '-')} is a td3 option; agent {args.agent} does not take it")
    if "hidden_sizes" in overrides:
        overrides["hidden_sizes"] = tuple(overrides["hidden_sizes"])
    return overrides


def _read_options(path: Path) -> dict:
    """The JSON object of options a run directory keeps (task_kwargs.json, env_kwargs.json), read within bounds."""
    text = read_text(path, "the run's options")
    check_json_depth(text, str(path))
    value = json.loads(text)
    if not isinstance(value, dict):
        raise ValueError(f"{path}: must hold a JSON object of options")
    return value


OFF_POLICY = tuple(AGENTS)
"""The agents of `auv_mj.agents.offpolicy.train.train`."""
ONLY_READ_BY = {"zero_actor_head": OFF_POLICY, "collectors": OFF_POLICY, "checkpoint_every": OFF_POLICY,
                "episodes": OFF_POLICY, "env_kwargs": OFF_POLICY, "teacher_mover_reach": ("ppo",),
                "init": (*OFF_POLICY, "ppo"), "no_tensorboard": (*OFF_POLICY, "ppo")}
"""Options of the shared parser that only some agents read (their groups' options: `option_readers`)."""
DAGGER_READS_PPO = ("cell_weights", "threads")
"""Options of the ppo group that `train dagger` reads too, beside its fine-tune's --ppo-FIELD options."""


def _dests(add) -> list[str]:
    """The options `add(parser)` adds, by dest (read off a parser of their own)."""
    probe = argparse.ArgumentParser(add_help=False)
    add(probe)
    return list(vars(probe.parse_args([])))


def option_readers() -> dict[str, tuple[str, tuple[str, ...], Any]]:
    """Each agent-specific option: dest -> (its flag, the agents that read it, its default in `add_arguments`). One
    parser serves every agent, so an option of another agent would otherwise parse and be ignored without a word."""
    readers: dict[str, tuple[str, ...]] = dict(ONLY_READ_BY)
    for add, agents in ((add_config_options, OFF_POLICY), (add_dagger_options, ("dagger",))):
        readers.update(dict.fromkeys(_dests(add), agents))
    for dest in _dests(add_ppo_options):
        readers[dest] = ("ppo", "dagger") if dest.startswith("ppo_") or dest in DAGGER_READS_PPO else ("ppo",)
    full = argparse.ArgumentParser(add_help=False)
    add_arguments(full)
    return {dest: ("--" + dest.replace("_", "-"), agents, full.get_default(dest)) for dest, agents in readers.items()}


def stray_options(args: argparse.Namespace) -> list[str]:
    """Messages for the options given that `args.agent` does not read (empty: none)."""
    found = []
    for dest, (flag, agents, default) in option_readers().items():
        if args.agent not in agents and getattr(args, dest, default) != default:
            found.append(f"train {args.agent} does not read {flag} (an option of `auv-mj train "
                         f"{' | '.join(agents)}`)")
    return found


def run(args: argparse.Namespace) -> int:
    """Runs `auv-mj train`; returns the exit status."""
    stray = stray_options(args)
    if stray:
        usage_error(args, "; ".join(stray) + ": leave it out")
    if args.agent == "ppo":
        return _run_ppo(args)
    if args.agent == "dagger":
        return _run_dagger(args)
    if args.collectors < 0:
        usage_error(args, f"--collectors must be >= 0, got {args.collectors}")
    try:
        run_dir = args.run_dir or (Path("runs") / args.task.replace("/", "_")
                                   / f"{args.agent}-seed{args.seed or 0}")
        kwargs_file, env_file = run_dir / TASK_KWARGS_NAME, run_dir / ENV_KWARGS_NAME
        kwargs = task_kwargs(args) or None
        if kwargs is None and args.resume and kwargs_file.is_file():
            kwargs = _read_options(kwargs_file)
        env_kwargs = args.env_kwargs
        if env_kwargs is None and args.resume and env_file.is_file():
            env_kwargs = _read_options(env_file)
        if args.resume and args.init:
            raise ValueError("--init starts a new run; it cannot be combined with --resume")
        init = None if args.init is None else zoo.checkpoint_path(args.init, args.task)
        env_fn = make_env_fn(task_env_id(args.task), **({"task_kwargs": kwargs} if kwargs else {}),
                             **(env_kwargs or {}))
        env_fn().close()  # a bad task option is refused here, before the run directory is touched
        for data, path in ((kwargs, kwargs_file), (env_kwargs, env_file)):
            if data:
                run_dir.mkdir(parents=True, exist_ok=True)
                path.write_text(json.dumps(data))
        config_class = agent_classes(args.agent)[1]
        base = config_class()
        if args.resume:
            base = saved_config(read_checkpoint(run_dir / CHECKPOINT_NAME), run_dir, config_class)
        config = dataclasses.replace(base, **config_overrides(args))
        result = train(env_fn, args.agent, config, total_steps=args.steps, episodes=args.episodes,
                       run_dir=run_dir, resume=args.resume, init=init,
                       checkpoint_every=args.checkpoint_every, progress=not args.no_progress,
                       tensorboard=not args.no_tensorboard, collectors=args.collectors,
                       zero_actor_head=args.zero_actor_head,
                       run_info={"task": args.task, "task_kwargs": kwargs or {}, "env_kwargs": env_kwargs or {},
                                 "zero_actor_head": args.zero_actor_head})
    except (ValueError, TypeError, FileNotFoundError, FileExistsError) as exc:
        usage_error(args, str(exc))
    measure = (f"tracking {errors_text(result.tracking_error)}" if result.tracking_error
               else f"success {result.success_rate:.2f}")
    print(f"{result.episodes} episodes, {result.env_steps} steps, {result.gradient_steps} gradient steps; "
          f"{measure}, return {result.mean_return:.2f} (last {WINDOW} episodes); "
          f"{result.env_steps_per_s:.0f} steps/s, {result.updates_per_s:.0f} updates/s")
    print(f"checkpoint: {result.checkpoint}")
    return 130 if result.interrupted else 0
