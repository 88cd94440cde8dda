"""`auv-mj train AGENT --task TASK`: a thin command over `auv_mj.agents.train.train` (the training library).

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
from auv_mj.agents.checkpoint import agent_classes, config_from_dict, read_checkpoint
from auv_mj.agents.ddpg import EPSILON_UNITS, DDPGConfig, field_docs
from auv_mj.agents.td3 import TD3Config
from auv_mj.agents.train import AGENTS, CHECKPOINT_NAME, WINDOW, train
from auv_mj.cli.options import (
    MAX_PROCESSES,
    bounded_int,
    json_object,
    positive_int,
    seed_int,
    task_kwargs,
    usage_error,
)
from auv_mj.inputs import check_json_depth, read_text
from auv_mj.planners.deploy import ChainConfig, deploy_env
from auv_mj.tasks.gym_adapter import GYM_IDS_3D

TASK_IDS: dict[str, str] = {}
"""Suite task name -> Gymnasium id, where the default `auv_mj/<CamelCase>-v0` rule does not apply."""


def task_env_id(task: str) -> str:
    """The Gymnasium id of a suite task: TASK_IDS[task], an id given as is, or `auv_mj/<CamelCase>-v0`."""
    if task in TASK_IDS:
        return TASK_IDS[task]
    if "/" in task or ":" in task:
        return task
    camel = "".join(part[:1].upper() + part[1:] for part in re.split(r"[-_\s]+", task) if part)
    return f"auv_mj/{camel}-v0"


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
        return deploy_env(gym.make(self.env_id, **_with_executor(rest, self.env_id in GYM_IDS_3D)), **chain)


def _with_executor(kwargs: dict, three_d: bool = False) -> dict:
    """`kwargs` with a planning task's executor named in its task_kwargs ("executor": one of
    `policies.EXECUTORS` or a speed_heading checkpoint; on a 6-DOF task, `three_d`, one of `EXECUTORS_3D` or a
    depth_heading checkpoint) built, so that a planner trains on the execution layer it will run on (e.g. the
    learned one of the two-layer system)."""
    task_kwargs = kwargs.get("task_kwargs")
    if isinstance(task_kwargs, dict) and isinstance(task_kwargs.get("executor"), str):
        from auv_mj.zoo.registry import named_executor

        executor = named_executor(task_kwargs["executor"], three_d)
        return {**kwargs, "task_kwargs": {**task_kwargs, "executor": executor}}
    return kwargs


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
        raise ValueError(f"Gymnasium id {env_id!r} is not registered; "
                         f"registered auv_mj ids: {known or 'none'}")
    return EnvFactory(env_id, kwargs, module)


_CLI_SKIP = ("seed", "device")
ENV_KWARGS_NAME = "env_kwargs.json"
"""File in the run directory holding the --env-kwargs of the run."""
TASK_KWARGS_NAME = "task_kwargs.json"
"""File in the run directory holding the --task-kwargs of the run."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj train AGENT --task TASK ...`; every DDPGConfig field is an option."""
    parser.add_argument("agent", choices=AGENTS,
                        help="ddpg | her-ddpg (goal tasks) | executor (SpeedHeading) | td3 (DDPG with twin "
                             "critics, delayed actor, target smoothing; any task)")
    parser.add_argument("--task", required=True, help="suite task name or Gymnasium id (auv_mj/...-v0)")
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
    parser.add_argument("--run-dir", type=Path, help="default runs/<task>/<agent>-seed<seed>")
    parser.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    parser.add_argument("--init", type=Path, metavar="CHECKPOINT",
                        help="start a new run from this checkpoint's networks (fine-tuning)")
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
                             "second core; deterministic given --seed and N, not the serial run) [0: serial]")
    add_config_options(parser)


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


def run(args: argparse.Namespace) -> int:
    """Runs `auv-mj train`; returns the exit status."""
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
            base = config_from_dict(read_checkpoint(run_dir / CHECKPOINT_NAME)[1]["config"], run_dir, config_class)
        config = dataclasses.replace(base, **config_overrides(args))
        result = train(env_fn, args.agent, config, total_steps=args.steps, episodes=args.episodes,
                       run_dir=run_dir, resume=args.resume, init=args.init,
                       checkpoint_every=args.checkpoint_every, progress=not args.no_progress,
                       tensorboard=not args.no_tensorboard, collectors=args.collectors,
                       zero_actor_head=args.zero_actor_head,
                       run_info={"task": args.task, "task_kwargs": kwargs or {}, "env_kwargs": env_kwargs or {},
                                 "zero_actor_head": args.zero_actor_head})
    except (ValueError, TypeError, FileNotFoundError, FileExistsError) as exc:
        usage_error(args, str(exc))
    print(f"{result.episodes} episodes, {result.env_steps} steps, {result.gradient_steps} gradient steps; "
          f"success {result.success_rate:.2f}, return {result.mean_return:.2f} (last {WINDOW} episodes); "
          f"{result.env_steps_per_s:.0f} steps/s, {result.updates_per_s:.0f} updates/s")
    print(f"checkpoint: {result.checkpoint}")
    return 130 if result.interrupted else 0
