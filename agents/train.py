"""The training loop of DDPG, HER-DDPG (Algorithm 1) and the executor on Gymnasium tasks; `auv-mj train`.

Goal tasks (dict observations with observation / achieved_goal / desired_goal) train `her-ddpg` with a
`HerReplayBuffer`, or `ddpg` on the flat [observation, desired_goal] without relabelling; Box tasks train
`ddpg` or `executor` (the execution layer of Sec. 3.3). Every `train_every` env steps the agent does
round(train_every * updates_per_step) gradient steps on one batched sample. Episodes end on
`terminated` (goal, collision: no bootstrap) or `truncated` (time limit: bootstrap).

A run directory holds `checkpoint.pt` (atomic, see agents.checkpoint), `replay-<steps>.npz`,
`progress.csv` (one row per episode), `config.json` and TensorBoard scalars in `tb/`. `resume=True`
continues the same run from its last checkpoint, replay buffer and RNG states included; each episode
resets the env with a seed derived from (seed, episode index), so a resumed run repeats the
uninterrupted one exactly when checkpoints fall on episode boundaries.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import importlib
import json
import re
import sys
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces

from agents.checkpoint import (
    config_from_dict,
    config_to_dict,
    load_agent,
    read_checkpoint,
    read_replay,
    save_checkpoint,
    save_replay,
)
from agents.ddpg import DDPG, EPSILON_UNITS, DDPGConfig, epsilon_at, field_docs
from agents.her import GOAL_KEYS, HerReplayBuffer, flatten_goal_obs
from agents.replay import ReplayBuffer
from auv_mj.cli import json_object, progress_bar

AGENTS = ("ddpg", "her-ddpg", "executor")
"""Agent names of `auv-mj train AGENT`: her-ddpg needs a goal task, executor a Box task."""
TASK_IDS: dict[str, str] = {}
"""Suite task name -> Gymnasium id, where the default `auv_mj/<CamelCase>-v0` rule does not apply."""
ENV_MODULES: tuple[str, ...] = ("tasks",)
"""Modules imported by `run` before `gymnasium.make`, so that they register the auv_mj ids."""
CHECKPOINT_NAME = "checkpoint.pt"
LOG_NAME = "progress.csv"
LOG_FIELDS = ("episode", "steps", "length", "return", "success", "wall_time")
WINDOW = 100
"""Episodes in the running success rate and return shown on the progress bar."""


@dataclasses.dataclass
class TrainResult:
    """Where a run was written and how it went (counters are totals over resumes)."""

    run_dir: Path
    checkpoint: Path
    env_steps: int
    episodes: int
    gradient_steps: int
    success_rate: float
    """Mean success over the last WINDOW episodes (nan if none)."""
    mean_return: float
    """Mean return over the last WINDOW episodes (nan if none)."""
    wall_time: float
    """Seconds this call spent in its loop."""
    env_steps_per_s: float
    """Env steps of this call per second of loop wall time (updates and logging included)."""
    updates_per_s: float
    """Gradient steps per second spent in update rounds (sampling and relabelling included)."""
    interrupted: bool = False


def env_spec(env: gym.Env) -> dict[str, Any]:
    """A JSON-able description of the env's spaces; resume and Policy check it."""
    action_space = env.action_space
    if not isinstance(action_space, spaces.Box) or not np.all(np.isfinite(action_space.low)) \
            or not np.all(np.isfinite(action_space.high)):
        raise ValueError(f"DDPG needs a bounded Box action space, got {action_space}")
    space = env.observation_space
    spec: dict[str, Any] = {"act_dim": int(np.prod(action_space.shape)),
                            "action_low": action_space.low.ravel().tolist(),
                            "action_high": action_space.high.ravel().tolist()}
    if isinstance(space, spaces.Dict) and set(GOAL_KEYS) <= set(space.spaces):
        obs_dim = int(np.prod(space["observation"].shape))
        goal_dim = int(np.prod(space["desired_goal"].shape))
        spec.update(kind="goal", observation_dim=obs_dim, goal_dim=goal_dim, obs_dim=obs_dim + goal_dim,
                    obs_shape=[obs_dim + goal_dim])
    elif isinstance(space, spaces.Box):
        spec.update(kind="box", obs_dim=int(np.prod(space.shape)), obs_shape=list(space.shape))
    else:
        raise ValueError(f"expected a goal Dict {GOAL_KEYS} or a Box observation space, got {space}")
    return spec


def episode_seed(seed: int, episode: int) -> int:
    """The env reset seed of episode `episode` of a run seeded with `seed`."""
    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def _check_agent_env(agent_name: str, kind: str) -> None:
    if agent_name not in AGENTS:
        raise ValueError(f"unknown agent {agent_name!r}; choose one of {AGENTS}")
    if agent_name == "her-ddpg" and kind != "goal":
        raise ValueError("her-ddpg needs a goal task (dict observation with achieved/desired goals)")
    if agent_name == "executor" and kind != "box":
        raise ValueError("executor needs a Box-observation task (e.g. SpeedHeading)")


def _make_buffer(agent_name: str, spec: dict[str, Any], env: gym.Env,
                 config: DDPGConfig) -> ReplayBuffer | HerReplayBuffer:
    if agent_name == "her-ddpg":
        base = env.unwrapped
        for fn in ("compute_reward", "compute_terminated"):
            if not callable(getattr(base, fn, None)):
                raise ValueError(f"her-ddpg needs env.unwrapped.{fn}(achieved_goal, desired_goal, info)")
        return HerReplayBuffer(spec["observation_dim"], spec["goal_dim"], spec["act_dim"],
                               config.buffer_size, base.compute_reward, base.compute_terminated,
                               config.her_k, seed=config.seed + 1,
                               relabel_observation=getattr(base, "relabel_observation", None))
    return ReplayBuffer(spec["obs_dim"], spec["act_dim"], config.buffer_size, seed=config.seed + 1)


def _initialise_from(agent: DDPG, path: Path, spec: dict[str, Any]) -> None:
    """Copies the networks and the observation normaliser of checkpoint `path` into `agent`."""
    source, meta = load_agent(path, device=agent.config.device)
    saved_spec = {k: v for k, v in meta["spec"].items() if k != "env_id"}
    ours = {k: v for k, v in spec.items() if k != "env_id"}
    if (saved_spec["obs_dim"], saved_spec["act_dim"]) != (ours["obs_dim"], ours["act_dim"]):
        raise ValueError(f"--init checkpoint {path} has observation/action sizes "
                         f"{saved_spec['obs_dim']}/{saved_spec['act_dim']}, this task needs "
                         f"{ours['obs_dim']}/{ours['act_dim']}")
    if source.config.hidden_sizes != agent.config.hidden_sizes:
        raise ValueError(f"--init checkpoint {path} has hidden sizes {source.config.hidden_sizes}, "
                         f"the run asks for {agent.config.hidden_sizes}")
    for name, module in agent.modules().items():
        module.load_state_dict(source.modules()[name].state_dict())


def _restore_log(path: Path, episodes: int) -> list[dict[str, str]]:
    """Drops log rows of episodes after the checkpoint (a crash may have left some); returns the kept ones."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        rows = [row for row in csv.DictReader(f)
                if None not in row.values() and int(row["episode"]) <= episodes]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, LOG_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    return rows


def _tensorboard(run_dir: Path, purge_step: int | None) -> Any:
    from torch.utils.tensorboard import SummaryWriter  # slow import, only when asked for

    return SummaryWriter(str(run_dir / "tb"), purge_step=purge_step)


def train(env_fn: Callable[[], gym.Env], agent_name: str, config: DDPGConfig | None = None, *,
          total_steps: int | None = None, episodes: int | None = None, run_dir: str | Path | None = None,
          resume: bool = False, init: str | Path | None = None, checkpoint_every: int = 100,
          progress: bool = True, tensorboard: bool = True) -> TrainResult:
    """Trains `agent_name` on env_fn() until `total_steps` env steps or `episodes` episodes (totals).

    With neither given, trains for config.max_episodes (Table 4). `resume=True` continues the run in
    `run_dir` (its config unless `config` is given; the network sizes and replay size must match).
    `init` starts a new run from another checkpoint's networks and normaliser (fine-tuning, e.g. the
    `goal` planner on `obstacles`), with fresh counters, replay buffer and random streams.
    Checkpoints every `checkpoint_every` episodes and at the end (also on Ctrl-C).
    """
    env = env_fn()
    spec = env_spec(env)
    spec["env_id"] = getattr(env.spec, "id", None)
    _check_agent_env(agent_name, spec["kind"])
    if run_dir is None:
        run_dir = Path("runs") / f"{agent_name}-{time.strftime('%Y%m%d-%H%M%S')}"
    run_dir = Path(run_dir)
    ckpt_path = run_dir / CHECKPOINT_NAME
    log_path = run_dir / LOG_NAME

    if resume:
        agent, meta = load_agent(ckpt_path, config=config)
        saved_spec = {k: v for k, v in meta["spec"].items() if k != "env_id"}
        if meta["agent"] != agent_name or saved_spec != {k: v for k, v in spec.items() if k != "env_id"}:
            raise ValueError(f"checkpoint {ckpt_path} is a {meta['agent']} run on {meta['spec']}, "
                             f"not {agent_name} on {spec}")
        counters = dict(meta["counters"])
    else:
        if ckpt_path.exists():
            raise FileExistsError(f"{ckpt_path} exists: resume it or choose another run directory")
        agent = DDPG(spec["obs_dim"], spec["act_dim"], config or DDPGConfig())
        if init is not None:
            _initialise_from(agent, Path(init), spec)
        counters = {"env_steps": 0, "episodes": 0, "gradient_steps": 0, "wall_time": 0.0}
    config = agent.config
    torch.set_num_threads(config.torch_threads)
    buffer = _make_buffer(agent_name, spec, env, config)
    if resume:
        replay_path = run_dir / meta["replay_file"]
        try:
            buffer.load_state_dict(read_replay(replay_path))
        except (KeyError, ValueError) as exc:
            raise ValueError(f"replay file {replay_path} does not fit this run: {exc}") from exc

    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(json.dumps(
        {"agent": agent_name, "config": config_to_dict(config), "spec": spec}, indent=2))
    kept = _restore_log(log_path, counters["episodes"]) if resume else []
    returns = deque((float(r["return"]) for r in kept[-WINDOW:]), maxlen=WINDOW)
    successes = deque((float(r["success"]) for r in kept[-WINDOW:]), maxlen=WINDOW)
    log_file = open(log_path, "a" if resume else "w", newline="")
    log = csv.writer(log_file)
    if log_file.tell() == 0:
        log.writerow(LOG_FIELDS)
    writer = _tensorboard(run_dir, counters["env_steps"] if resume else None) if tensorboard else None
    if writer is not None and not resume:
        writer.add_text("config", json.dumps(config_to_dict(config), indent=2))

    is_goal, is_her = spec["kind"] == "goal", agent_name == "her-ddpg"
    low = np.asarray(spec["action_low"], np.float32)
    span = np.asarray(spec["action_high"], np.float32) - low
    action_dtype = env.action_space.dtype

    def flat(obs: Any) -> np.ndarray:
        if is_goal:
            return flatten_goal_obs(obs["observation"], obs["desired_goal"])
        return np.asarray(obs, np.float32).ravel()

    if total_steps is None and episodes is None:
        episodes = config.max_episodes
    n_updates = max(1, round(config.train_every * config.updates_per_step))
    steps, n_eps, grad_steps = counters["env_steps"], counters["episodes"], counters["gradient_steps"]
    start_steps, start_grads = steps, grad_steps
    update_time = 0.0
    t_start = time.perf_counter()

    def finished() -> bool:
        return ((total_steps is not None and steps >= total_steps)
                or (episodes is not None and n_eps >= episodes))

    def save() -> None:
        replay_name = f"replay-{steps:012d}.npz"
        save_replay(run_dir / replay_name, buffer.state_dict())
        wall = counters["wall_time"] + time.perf_counter() - t_start
        counts = {"env_steps": steps, "episodes": n_eps, "gradient_steps": grad_steps, "wall_time": wall}
        save_checkpoint(ckpt_path, agent, {"agent": agent_name, "spec": spec, "replay_file": replay_name,
                                           "counters": counts})
        for old in run_dir.glob("replay-*.npz"):
            if old.name != replay_name:
                old.unlink()

    bar = progress_bar(total=total_steps if total_steps is not None else episodes,
                       initial=steps if total_steps is not None else n_eps,
                       unit="step" if total_steps is not None else "ep", disable=not progress,
                       dynamic_ncols=True)
    interrupted = False
    try:
        while not finished():
            obs, info = env.reset(seed=episode_seed(config.seed, n_eps))
            x = flat(obs)
            ep_return, ep_len, ended = 0.0, 0, False
            while not ended:
                agent.obs_norm.update(x)
                agent.epsilon = epsilon_at(config, steps, n_eps)
                action = agent.act(x, explore=True)
                next_obs, reward, terminated, truncated, info = env.step((low + (action + 1.0) * 0.5 * span)
                                                                          .astype(action_dtype))
                next_x = flat(next_obs)
                if is_her:
                    buffer.add(obs, action, reward, next_obs, terminated, truncated, info)
                else:
                    buffer.add(x, action, reward, next_x, terminated)
                steps += 1
                ep_len += 1
                ep_return += float(reward)
                ended = bool(terminated or truncated)
                if steps % config.train_every == 0 and steps >= config.learning_starts and (
                        buffer.num_samplable if is_her else len(buffer)):
                    t0 = time.perf_counter()
                    metrics = agent.update_many(buffer.sample(config.batch_size * n_updates), n_updates)
                    update_time += time.perf_counter() - t0
                    grad_steps += n_updates
                    if writer is not None:
                        for key, value in metrics.items():
                            writer.add_scalar(f"train/{key}", value, steps)
                if total_steps is not None and steps >= total_steps:
                    break
                obs, x = next_obs, next_x
            if is_her:
                buffer.end_episode()
            if total_steps is not None:
                bar.update(ep_len)
            if not ended:
                break  # stopped mid-episode at total_steps: the partial episode is stored but not logged
            n_eps += 1
            success = float(info.get("is_success", 0.0))
            returns.append(ep_return)
            successes.append(success)
            wall = counters["wall_time"] + time.perf_counter() - t_start
            log.writerow((n_eps, steps, ep_len, f"{ep_return:.6g}", success, f"{wall:.3f}"))
            log_file.flush()
            if writer is not None:
                for key, value in (("return", ep_return), ("success", success), ("length", ep_len),
                                   ("epsilon", agent.epsilon)):
                    writer.add_scalar(f"episode/{key}", value, steps)
            if total_steps is None:
                bar.update(1)
            bar.set_postfix(success=f"{np.mean(successes):.2f}", ret=f"{np.mean(returns):.2f}",
                            eps=f"{agent.epsilon:.2f}", refresh=False)
            if n_eps % checkpoint_every == 0:
                save()
    except KeyboardInterrupt:
        interrupted = True
        if is_her:
            buffer.end_episode()
    finally:
        bar.close()
        log_file.close()
    save()
    if writer is not None:
        writer.close()
    env.close()
    wall_time = time.perf_counter() - t_start
    return TrainResult(
        run_dir=run_dir, checkpoint=ckpt_path, env_steps=steps, episodes=n_eps, gradient_steps=grad_steps,
        success_rate=float(np.mean(successes)) if successes else float("nan"),
        mean_return=float(np.mean(returns)) if returns else float("nan"), wall_time=wall_time,
        env_steps_per_s=(steps - start_steps) / max(wall_time, 1e-9),
        updates_per_s=(grad_steps - start_grads) / update_time if update_time else float("nan"),
        interrupted=interrupted)


def task_env_id(task: str) -> str:
    """The Gymnasium id of a suite task: TASK_IDS[task], an id given as is, or `auv_mj/<CamelCase>-v0`."""
    if task in TASK_IDS:
        return TASK_IDS[task]
    if "/" in task:
        return task
    camel = "".join(part[:1].upper() + part[1:] for part in re.split(r"[-_\s]+", task) if part)
    return f"auv_mj/{camel}-v0"


def make_env_fn(env_id: str, **kwargs: Any) -> Callable[[], gym.Env]:
    """A factory of `gymnasium.make(env_id)`; ValueError listing the auv_mj ids if it is not registered."""
    for module in ENV_MODULES:
        try:
            importlib.import_module(module)
        except ImportError:
            pass
    if env_id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("auv_mj/"))
        raise ValueError(f"Gymnasium id {env_id!r} is not registered; "
                         f"registered auv_mj ids: {known or 'none'}")
    return lambda: gym.make(env_id, **kwargs)


_CLI_SKIP = ("seed", "device")
TASK_KWARGS_NAME = "task_kwargs.json"
"""File in the run directory holding the --task-kwargs of the run."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj train AGENT --task TASK ...`; every DDPGConfig field is an option."""
    parser.add_argument("agent", choices=AGENTS,
                        help="ddpg | her-ddpg (goal tasks) | executor (SpeedHeading)")
    parser.add_argument("--task", required=True, help="suite task name or Gymnasium id (auv_mj/...-v0)")
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON",
                        help='task options, e.g. \'{"command": "random", "disturbances": "random"}\'; '
                             "kept in the run directory and reused by --resume")
    parser.add_argument("--steps", type=int, help="total env steps (default: --episodes)")
    parser.add_argument("--episodes", type=int, help="total episodes (default: max_episodes, Table 4)")
    parser.add_argument("--run-dir", type=Path, help="default runs/<task>/<agent>-seed<seed>")
    parser.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    parser.add_argument("--init", type=Path, metavar="CHECKPOINT",
                        help="start a new run from this checkpoint's networks (fine-tuning)")
    parser.add_argument("--seed", type=int, help="run seed (default 0, or the checkpoint's)")
    parser.add_argument("--device", help="torch device, cpu or cuda (default cpu, or the checkpoint's)")
    parser.add_argument("--checkpoint-every", type=int, default=100, help="episodes between checkpoints")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-tensorboard", action="store_true", help="no TensorBoard scalars")
    group = parser.add_argument_group("hyper-parameters (DDPGConfig; default Table 4 or the checkpoint's)")
    docs = field_docs(DDPGConfig)
    for field in dataclasses.fields(DDPGConfig):
        if field.name in _CLI_SKIP:
            continue
        flag, help_text = "--" + field.name.replace("_", "-"), f"{docs.get(field.name, '')} [{field.default}]"
        if field.name == "hidden_sizes":
            group.add_argument(flag, type=int, nargs="+", help=help_text)
        elif field.name == "epsilon_unit":
            group.add_argument(flag, choices=EPSILON_UNITS, help=help_text)
        else:
            group.add_argument(flag, type=type(field.default), help=help_text)


def run(args: argparse.Namespace) -> int:
    """Runs `auv-mj train`; returns the exit status."""
    try:
        run_dir = args.run_dir or (Path("runs") / args.task.replace("/", "_")
                                   / f"{args.agent}-seed{args.seed or 0}")
        kwargs_file = run_dir / TASK_KWARGS_NAME
        task_kwargs = args.task_kwargs
        if task_kwargs is None and args.resume and kwargs_file.is_file():
            task_kwargs = json.loads(kwargs_file.read_text())
        if args.resume and args.init:
            raise ValueError("--init starts a new run; it cannot be combined with --resume")
        env_fn = make_env_fn(task_env_id(args.task), **({"task_kwargs": task_kwargs} if task_kwargs else {}))
        if task_kwargs:
            run_dir.mkdir(parents=True, exist_ok=True)
            kwargs_file.write_text(json.dumps(task_kwargs))
        base = DDPGConfig()
        if args.resume:
            base = config_from_dict(read_checkpoint(run_dir / CHECKPOINT_NAME)[1]["config"])
        overrides = {f.name: getattr(args, f.name) for f in dataclasses.fields(DDPGConfig)
                     if getattr(args, f.name, None) is not None}
        if "hidden_sizes" in overrides:
            overrides["hidden_sizes"] = tuple(overrides["hidden_sizes"])
        result = train(env_fn, args.agent, dataclasses.replace(base, **overrides), total_steps=args.steps,
                       episodes=args.episodes, run_dir=run_dir, resume=args.resume, init=args.init,
                       checkpoint_every=args.checkpoint_every, progress=not args.no_progress,
                       tensorboard=not args.no_tensorboard)
    except (ValueError, FileNotFoundError, FileExistsError) as exc:
        print(f"auv-mj train: error: {exc}", file=sys.stderr)
        return 2
    print(f"{result.episodes} episodes, {result.env_steps} steps, {result.gradient_steps} gradient steps; "
          f"success {result.success_rate:.2f}, return {result.mean_return:.2f} (last {WINDOW} episodes); "
          f"{result.env_steps_per_s:.0f} steps/s, {result.updates_per_s:.0f} updates/s")
    print(f"checkpoint: {result.checkpoint}")
    return 130 if result.interrupted else 0
