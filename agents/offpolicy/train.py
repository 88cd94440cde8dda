"""The training loop of DDPG, HER-DDPG (Algorithm 1) and the executor on Gymnasium tasks, as a library.

`train(env_fn, agent_name, config, run_dir=...)` reads top to bottom: open (or resume) the run, then
collect an episode, learn from the buffer every `train_every` steps, log the episode, checkpoint; the
`auv-mj train` command (`auv_mj.cli.train`) only parses options and builds `env_fn`.

Goal tasks (dict observations with observation / achieved_goal / desired_goal) train `her-ddpg` with a
`HerReplayBuffer`, or `ddpg` on the flat [observation, desired_goal] without relabelling; Box tasks train
`ddpg`, `executor` (the execution layer of Sec. 3.3) or `td3` (DDPG with TD3's twin critics, delayed actor
and target smoothing, `auv_mj.agents.offpolicy.td3`; on either kind of task, as `ddpg`). Every `train_every` env
steps the agent does round(train_every * updates_per_step) gradient steps on one batched sample. Episodes end on
`terminated` (goal, collision: no bootstrap) or `truncated` (time limit: bootstrap).

`collectors=N` (N >= 1) uses more cores: the environments are stepped, and the actor learnt, in N collector
processes while this process learns the critic (and, with one collector, steps a share of the environment
steps itself), in lock-step rounds (`auv_mj.agents.offpolicy.collector`); a run is then deterministic given its
seed and N, and the update-to-data ratio is the serial one.

A run directory holds `checkpoint.pt` (atomic, see auv_mj.agents.checkpoint), `replay-<steps>.npz`,
`progress.csv` (one row per episode), `config.json` and TensorBoard scalars in `tb/`. `resume=True`
continues the same run from its last checkpoint, replay buffer and RNG states included; each episode
resets the env with a seed derived from (seed, episode index), so a resumed run repeats the
uninterrupted one exactly when checkpoints fall on episode boundaries. With collectors a resumed run
continues from its checkpoint but does not repeat the uninterrupted run: the episodes the collectors had
in progress are dropped and begun afresh.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces

from auv_mj.agents.checkpoint import config_to_dict, read_replay, save_replay
from auv_mj.agents.offpolicy.collector import CATCH_UP, Collectors, env_action, episode_seed, flat_observation
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig, epsilon_at, updates_per_round
from auv_mj.agents.offpolicy.her import HerReplayBuffer
from auv_mj.agents.offpolicy.learners import AGENTS, agent_classes, load_agent, save_agent
from auv_mj.agents.offpolicy.networks import widen_inputs
from auv_mj.agents.offpolicy.replay import Batch, ReplayBuffer
from auv_mj.console import progress_bar
from auv_mj.goals import GOAL_KEYS
from auv_mj.inputs import unknown_name

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
    tracking_error: dict[str, float] | None = None
    """On a tracking task (speed_heading, depth_heading: no success to report), the mean |error| per tracked
    quantity over the last WINDOW episodes (speed [m/s], heading [rad], depth [m]); None elsewhere."""


TRACKED_ERRORS = {"speed_error": ("speed", "m/s", 1.0), "heading_error": ("heading", "deg", float(np.degrees(1.0))),
                  "depth_error": ("depth", "m", 1.0)}
"""The step info's tracking errors a tracking task reports, as the progress shows them: (name, unit, scale)."""


class EpisodeErrors:
    """Per stream of episodes, the sums of |tracking error| over the episode in progress, on a task that reports no
    success (speed_heading, depth_heading): how such a run is doing, where a success rate would read 0.00."""

    def __init__(self):
        self._sums: dict[int, tuple[dict[str, float], int]] = {}

    def add(self, stream: int, info: Mapping[str, Any]) -> None:
        """One step's info; a task that reports success has its success rate instead."""
        if "success" in info:
            return
        sums, count = self._sums.get(stream, ({}, 0))
        for key in TRACKED_ERRORS:
            if key in info:
                sums[key] = sums.get(key, 0.0) + abs(float(info[key]))
        self._sums[stream] = (sums, count + 1)

    def end(self, stream: int) -> dict[str, float] | None:
        """The episode's mean |error| per key (None without any), and a fresh sum for the stream's next one."""
        sums, count = self._sums.pop(stream, ({}, 0))
        return {key: value / count for key, value in sums.items()} if sums and count else None


def mean_errors(errors: Sequence[Mapping[str, float]]) -> dict[str, float] | None:
    """The mean over episodes of each tracking error (None when no episode reported one)."""
    keys = [key for key in TRACKED_ERRORS if any(key in e for e in errors)]
    return {key: float(np.mean([e[key] for e in errors if key in e])) for key in keys} or None


def errors_text(errors: Mapping[str, float]) -> str:
    """Tracking errors in words: "|e| speed 0.031 m/s, heading 1.9 deg"."""
    parts = [f"{name} {errors[key] * scale:.3g} {unit}" for key, (name, unit, scale) in TRACKED_ERRORS.items()
             if key in errors]
    return "|e| " + ", ".join(parts)


def progress_text(run: _Run) -> str:
    """The progress bar's postfix: the success rate and return of the last WINDOW episodes, or on a tracking task
    (no success) its mean tracking errors and return; and the exploration's epsilon."""
    errors = mean_errors(run.errors)
    measure = errors_text(errors) if errors else f"success {np.mean(run.successes):.2f}"
    return f"{measure}, ret {np.mean(run.returns):.2f}, eps {run.agent.epsilon:.2f}"


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
        # A goal env whose observation already holds the goal relative to the agent says so with
        # `goal_in_observation`: its policy reads the observation alone, not the (absolute) desired goal.
        goal_input = not bool(getattr(env.unwrapped, "goal_in_observation", False))
        input_dim = obs_dim + goal_dim * goal_input
        spec.update(kind="goal", observation_dim=obs_dim, goal_dim=goal_dim, goal_input=goal_input,
                    obs_dim=input_dim, obs_shape=[input_dim])
        inserted = wrapper_attr(env, "inserted_inputs", None)
        if inserted is not None:  # inputs a guide added (guide="map-memory"): `--init` may widen a network
            spec["inserted_inputs"] = [int(v) for v in inserted]
    elif isinstance(space, spaces.Box):
        spec.update(kind="box", obs_dim=int(np.prod(space.shape)), obs_shape=list(space.shape))
    else:
        raise ValueError(f"expected a goal Dict {GOAL_KEYS} or a Box observation space, got {space}")
    return spec


def wrapper_attr(env: gym.Env, name: str, default: Any) -> Any:
    """Attribute `name` of `env` or of the first wrapper or environment under it that has it (a deployment chain's
    `inserted_inputs`, say), else `default`."""
    try:
        return env.get_wrapper_attr(name)
    except AttributeError:
        return default


def _check_agent_env(agent_name: str, kind: str) -> None:
    if agent_name not in AGENTS:
        raise ValueError(unknown_name("agent", agent_name, AGENTS))
    if agent_name == "her-ddpg" and kind != "goal":
        raise ValueError("her-ddpg needs a goal task (dict observation with achieved/desired goals)")
    if agent_name == "executor" and kind != "box":
        raise ValueError("executor needs a Box-observation task (e.g. SpeedHeading)")


def _make_buffer(agent_name: str, spec: dict[str, Any], env: gym.Env,
                 config: DDPGConfig) -> ReplayBuffer | HerReplayBuffer:
    if agent_name == "her-ddpg":
        base = env.unwrapped
        if wrapper_attr(env, "goal_dependent_actions", False):
            raise ValueError("her-ddpg relabels goals, but this environment's actions depend on the goal (a "
                             "residual planner, env option residual > 0): relabelled transitions would not have "
                             "happened; train it with ddpg")
        for fn in ("compute_reward", "compute_terminated"):
            if not callable(getattr(base, fn, None)):
                raise ValueError(f"her-ddpg needs env.unwrapped.{fn}(achieved_goal, desired_goal, info)")
        return HerReplayBuffer(spec["observation_dim"], spec["goal_dim"], spec["act_dim"],
                               config.buffer_size, base.compute_reward, base.compute_terminated,
                               config.her_k, seed=config.seed + 1,
                               relabel_observation=getattr(base, "relabel_observation", None),
                               goal_input=spec["goal_input"])
    return ReplayBuffer(spec["obs_dim"], spec["act_dim"], config.buffer_size, seed=config.seed + 1)


def _initialise_from(agent: DDPG, path: Path, spec: dict[str, Any]) -> None:
    """Copies the networks and the observation normaliser of checkpoint `path` into `agent`; a checkpoint
    trained without the inputs that the env's guide inserts (`inserted_inputs`) is widened to them
    (`auv_mj.agents.offpolicy.networks.widen_inputs`)."""
    source, meta = load_agent(path, device=agent.config.device)
    saved_spec = {k: v for k, v in meta["spec"].items() if k != "env_id"}
    ours = {k: v for k, v in spec.items() if k != "env_id"}
    if source.config.hidden_sizes != agent.config.hidden_sizes:
        raise ValueError(f"--init checkpoint {path} has hidden sizes {source.config.hidden_sizes}, "
                         f"the run asks for {agent.config.hidden_sizes}")
    at, count = ours.get("inserted_inputs", (0, 0))
    widen = count > 0 and "inserted_inputs" not in saved_spec and saved_spec["act_dim"] == ours["act_dim"] \
        and saved_spec["obs_dim"] + count == ours["obs_dim"]
    if widen:  # a network trained without the guide's new inputs: they start with zero weights
        for name, module in agent.modules().items():
            module.load_state_dict(widen_inputs(source.modules()[name].state_dict(), at, count))
        return
    if (saved_spec["obs_dim"], saved_spec["act_dim"]) != (ours["obs_dim"], ours["act_dim"]):
        raise ValueError(f"--init checkpoint {path} has observation/action sizes "
                         f"{saved_spec['obs_dim']}/{saved_spec['act_dim']}, this task needs "
                         f"{ours['obs_dim']}/{ours['act_dim']}")
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


@dataclasses.dataclass
class _Run:
    """Everything one call of `train` works on: the agent, its buffer, the counters and the logs."""

    agent_name: str
    agent: DDPG
    buffer: ReplayBuffer | HerReplayBuffer
    spec: dict[str, Any]
    run_dir: Path
    counters: dict[str, Any]
    """env_steps, episodes, gradient_steps and wall_time, totals over resumes, and the gradient steps owed
    (`_learn`)."""
    log_file: Any
    writer: Any
    returns: deque
    successes: deque
    errors: deque = dataclasses.field(default_factory=lambda: deque(maxlen=WINDOW))
    """Per episode of a tracking task, its mean |tracking error| per key (`EpisodeErrors`)."""
    episode_errors: EpisodeErrors = dataclasses.field(default_factory=EpisodeErrors)
    started: float = dataclasses.field(default_factory=time.perf_counter)
    start_counts: tuple[int, int] = (0, 0)
    update_time: float = 0.0
    run_info: dict = dataclasses.field(default_factory=dict)
    """What the caller says made the environment (task, options), kept in every checkpoint."""

    @property
    def her(self) -> bool:
        return self.agent_name == "her-ddpg"

    def wall_time(self) -> float:
        return self.counters["wall_time"] + time.perf_counter() - self.started


def _open_run(env: gym.Env, agent_name: str, config: DDPGConfig | None, run_dir: Path, resume: bool,
              init: str | Path | None, tensorboard: bool, run_info: Mapping[str, Any] | None,
              collectors: int = 0, zero_actor_head: bool = False) -> _Run:
    """Builds the agent and buffer of a new run, or restores them (and the counters) from `run_dir`."""
    spec = env_spec(env)
    spec["env_id"] = getattr(env.spec, "id", None)
    _check_agent_env(agent_name, spec["kind"])
    ckpt_path = run_dir / CHECKPOINT_NAME
    meta: dict[str, Any] = {}
    if resume:
        agent, meta = load_agent(ckpt_path, config=config)
        missing = [k for k in ("agent", "counters", "replay_file") if k not in meta]
        if missing:
            raise ValueError(f"checkpoint {ckpt_path} cannot be resumed: its metadata lacks {missing}")
        saved_spec = {k: v for k, v in meta["spec"].items() if k != "env_id"}
        if meta["agent"] != agent_name or saved_spec != {k: v for k, v in spec.items() if k != "env_id"}:
            raise ValueError(f"checkpoint {ckpt_path} is a {meta['agent']} run on {meta['spec']}, "
                             f"not {agent_name} on {spec}")
        counters = dict(meta["counters"])
    else:
        if ckpt_path.exists():
            raise FileExistsError(f"{ckpt_path} exists: resume it or choose another run directory")
        learner, config_class = agent_classes(agent_name)
        config = config or config_class()
        if not isinstance(config, config_class):
            raise ValueError(f"agent {agent_name} takes a {config_class.__name__}, got a {type(config).__name__}")
        agent = learner(spec["obs_dim"], spec["act_dim"], config)
        if init is not None:
            _initialise_from(agent, Path(init), spec)
        if zero_actor_head:
            agent.zero_actor_head()
        counters = {"env_steps": 0, "episodes": 0, "gradient_steps": 0, "owed_updates": 0, "wall_time": 0.0}
    torch.set_num_threads(agent.config.torch_threads)
    buffer = _make_buffer(agent_name, spec, env, agent.config)
    if resume:
        replay_path = run_dir / meta["replay_file"]
        try:
            buffer.load_state_dict(read_replay(replay_path))
        except (KeyError, ValueError) as exc:
            raise ValueError(f"replay file {replay_path} does not fit this run: {exc}") from exc

    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(json.dumps(
        {"agent": agent_name, "config": config_to_dict(agent.config), "spec": spec, "collectors": collectors},
        indent=2))
    kept = _restore_log(run_dir / LOG_NAME, counters["episodes"]) if resume else []
    log_file = open(run_dir / LOG_NAME, "a" if resume else "w", newline="")
    if log_file.tell() == 0:
        csv.writer(log_file).writerow(LOG_FIELDS)
    writer = _tensorboard(run_dir, counters["env_steps"] if resume else None) if tensorboard else None
    if writer is not None and not resume:
        writer.add_text("config", json.dumps(config_to_dict(agent.config), indent=2))
    return _Run(agent_name, agent, buffer, spec, run_dir, counters, log_file, writer,
                returns=deque((float(r["return"]) for r in kept[-WINDOW:]), maxlen=WINDOW),
                successes=deque((float(r["success"]) for r in kept[-WINDOW:]), maxlen=WINDOW),
                start_counts=(counters["env_steps"], counters["gradient_steps"]),
                run_info=dict(run_info if run_info is not None else meta.get("run_info", {})))


def _learn(run: _Run) -> None:
    """round(train_every * updates_per_step) gradient steps on one batched sample (Algorithm 1, l. 12-16).

    Steps owed while nothing can be sampled yet (HER samples whole episodes, and the first may end after
    learning_starts) are kept in the counters and taken in the next rounds, at most CATCH_UP times a
    round's own each, so that a run takes the update-to-data ratio of its config, serially or with
    collectors."""
    config, counters = run.agent.config, run.counters
    if counters["env_steps"] % config.train_every or counters["env_steps"] < config.learning_starts:
        return
    counters["owed_updates"] = counters.get("owed_updates", 0) + updates_per_round(config)
    counters["owed_updates"] -= _update(run, min(counters["owed_updates"], CATCH_UP * updates_per_round(config)))


def _update(run: _Run, n_updates: int) -> int:
    """`n_updates` gradient steps on one batched sample, if the buffer has anything to sample; how many."""
    config, counters = run.agent.config, run.counters
    if not n_updates or not (run.buffer.num_samplable if run.her else len(run.buffer)):
        return 0
    t0 = time.perf_counter()
    metrics = run.agent.update_many(run.buffer.sample(config.batch_size * n_updates), n_updates)
    run.update_time += time.perf_counter() - t0
    counters["gradient_steps"] += n_updates
    if run.writer is not None:
        for key, value in metrics.items():
            run.writer.add_scalar(f"train/{key}", value, counters["env_steps"])
    return n_updates


def _collect_episode(run: _Run, env: gym.Env, total_steps: int | None) -> tuple[float, int, bool, dict]:
    """Acts with exploration until the episode ends (or `total_steps`), storing and learning as it goes.

    Returns (return, length, ended, last info); `ended` is False when cut at `total_steps`.
    """
    agent, config, counters = run.agent, run.agent.config, run.counters
    obs, info = env.reset(seed=episode_seed(config.seed, counters["episodes"]))
    x = flat_observation(run.spec, obs)
    ep_return, ep_len, ended = 0.0, 0, False
    while not ended:
        agent.obs_norm.update(x)
        agent.epsilon = epsilon_at(config, counters["env_steps"], counters["episodes"])
        action = agent.act(x, explore=True)
        next_obs, reward, terminated, truncated, info = env.step(env_action(run.spec, action,
                                                                            env.action_space.dtype))
        next_x = flat_observation(run.spec, next_obs)
        if run.her:
            run.buffer.add(obs, action, reward, next_obs, terminated, truncated, info)
        else:
            run.buffer.add(x, action, reward, next_x, terminated)
        counters["env_steps"] += 1
        ep_len += 1
        ep_return += float(reward)
        run.episode_errors.add(0, info)
        ended = bool(terminated or truncated)
        _learn(run)
        if total_steps is not None and counters["env_steps"] >= total_steps:
            break
        obs, x = next_obs, next_x
    if run.her:
        run.buffer.end_episode()
    return ep_return, ep_len, ended, info


def _train_serial(run: _Run, env: gym.Env, total_steps: int | None, episodes: int | None,
                  checkpoint_every: int, bar: Any) -> None:
    """Episode after episode in this process, learning every train_every steps (Algorithm 1)."""
    counters, by_steps = run.counters, total_steps is not None
    while not ((by_steps and counters["env_steps"] >= total_steps)
               or (episodes is not None and counters["episodes"] >= episodes)):
        ep_return, ep_len, ended, info = _collect_episode(run, env, total_steps)
        bar.update(ep_len if by_steps else int(ended))
        if not ended:
            break  # stopped mid-episode at total_steps: the partial episode is stored but not logged
        _log_episode(run, ep_return, ep_len, info)
        bar.set_postfix_str(progress_text(run), refresh=False)
        if counters["episodes"] % checkpoint_every == 0:
            _save(run)


def _owed_updates(config: DDPGConfig, before: int, after: int) -> int:
    """Gradient steps the serial loop does while env steps go from `before` to `after`: a round of them
    at every multiple of train_every reached, from learning_starts on."""
    first = max(before + 1, config.learning_starts)
    rounds = max(0, after // config.train_every - (first - 1) // config.train_every)
    return rounds * updates_per_round(config)


def _critic_round(run: _Run, n_updates: int) -> tuple[Any, torch.Tensor | None]:
    """Samples the round's batch; returns a thunk doing its `n_updates` critic steps and the normalised
    observations of the matching actor steps (None when there is nothing to learn yet)."""
    agent, config = run.agent, run.agent.config
    if not n_updates or not (run.buffer.num_samplable if run.her else len(run.buffer)):
        return None, None
    t0 = time.perf_counter()
    agent.obs_norm.sync()
    data = agent._to_tensors(run.buffer.sample(config.batch_size * n_updates))
    size = config.batch_size
    with torch.no_grad():
        obs, next_obs = agent.obs_norm(data.obs), agent.obs_norm(data.next_obs)
    parts = [slice(k * size, (k + 1) * size) for k in range(n_updates)]
    run.update_time += time.perf_counter() - t0

    def critic_steps() -> dict[str, float]:
        t1 = time.perf_counter()
        sums = torch.zeros(2)
        for part in parts:
            batch = Batch(*(a[part] for a in data))
            sums += torch.stack(agent.critic_step(obs[part], batch, next_obs[part]))
        agent.num_updates += n_updates
        run.counters["gradient_steps"] += n_updates
        run.update_time += time.perf_counter() - t1
        q_loss, q_target = (sums / n_updates).tolist()
        return {"critic_loss": q_loss, "q_target": q_target}

    return critic_steps, obs


def _train_with_collectors(run: _Run, env: gym.Env, env_fn: Callable[[], gym.Env], count: int,
                           total_steps: int | None, episodes: int | None, checkpoint_every: int, bar: Any) -> None:
    """The lock-step rounds of `auv_mj.agents.offpolicy.collector`: `count` collector processes (and this one, for its
    share) step their environments, and collector 0 learns the actor, while this process learns the critic.

    The rounds are pipelined so that neither side waits on the other's bookkeeping: while round k is
    stepped, this process does the critic steps owed by round k - 1 and samples the batch of round k + 1
    from the transitions stored so far (through round k - 1); once round k's transitions arrive it starts
    round k + 1 at once, then stores them.
    """
    config, counters = run.agent.config, run.counters
    by_steps = total_steps is not None
    with Collectors(env_fn, run.spec, run.agent, count, first_episode=counters["episodes"], local_env=env) as pool:
        open_episodes: list[list[tuple]] = [[] for _ in range(pool.streams)]
        """Per stream, the transitions of its episode in progress (HER stores an episode when it ends)."""
        running = [[0.0, 0] for _ in range(pool.streams)]
        """Per stream, return and length of its episode in progress."""

        def round_steps(env_steps: int) -> int:
            steps = config.train_every * count
            return min(steps, total_steps - env_steps) if by_steps else steps

        def finished() -> bool:
            return (by_steps and counters["env_steps"] >= total_steps) or (
                episodes is not None and counters["episodes"] >= episodes)

        if finished():
            return
        critic_steps = None
        submitted = counters["env_steps"] + round_steps(counters["env_steps"])
        """Env steps once the round in flight is stored."""
        pool.start_round(submitted - counters["env_steps"], counters["env_steps"], counters["episodes"])
        while True:
            metrics = critic_steps() if critic_steps else {}  # while the collectors step and learn the actor
            pool.step_local()
            before = counters["env_steps"]
            # The round in flight owes the serial loop's gradient steps; the next round takes them (and any
            # still owed from before anything could be sampled, as `_learn` does, CATCH_UP rounds' worth).
            counters["owed_updates"] = counters.get("owed_updates", 0) + _owed_updates(config, before, submitted)
            following = round_steps(submitted)
            critic_steps, actor_obs = None, None
            if following:
                most = CATCH_UP * updates_per_round(config) * count
                critic_steps, actor_obs = _critic_round(run, min(counters["owed_updates"], most))
                counters["owed_updates"] -= len(actor_obs) // config.batch_size if actor_obs is not None else 0
            rounds, actor_loss = pool.finish_round()
            if following:
                pool.start_round(following, submitted, counters["episodes"], actor_obs)
                submitted += following
            if run.writer is not None and metrics:
                for key, value in {**metrics, "actor_loss": actor_loss}.items():
                    run.writer.add_scalar(f"train/{key}", value, before)
            save = False
            for index, transitions in enumerate(rounds):
                for obs, x, action, reward, next_obs, terminated, truncated, info in transitions:
                    run.agent.obs_norm.update(x)
                    if run.her:
                        open_episodes[index].append((obs, action, reward, next_obs, terminated, truncated, info))
                    else:
                        run.buffer.add(x, action, reward, flat_observation(run.spec, next_obs), terminated)
                    counters["env_steps"] += 1
                    run.episode_errors.add(index, info)
                    running[index][0] += reward
                    running[index][1] += 1
                    if not (terminated or truncated):
                        continue
                    if run.her:
                        for transition in open_episodes[index]:
                            run.buffer.add(*transition)
                        run.buffer.end_episode()
                        open_episodes[index] = []
                    if episodes is None or counters["episodes"] < episodes:
                        run.agent.epsilon = epsilon_at(config, counters["env_steps"], counters["episodes"])
                        _log_episode(run, *running[index], info, index)
                        save |= counters["episodes"] % checkpoint_every == 0
                        if not by_steps:
                            bar.update(1)
                    running[index] = [0.0, 0]
            if by_steps:
                bar.update(counters["env_steps"] - before)
            if run.successes:
                bar.set_postfix_str(progress_text(run), refresh=False)
            if save:
                _save(run)
            if finished() or not following:
                break
    # the last round's gradient steps, here (the collectors are done), as many as `_learn` would take
    owed = counters.get("owed_updates", 0)
    counters["owed_updates"] = owed - _update(run, min(owed, CATCH_UP * updates_per_round(config) * count))
    if run.her:  # episodes cut at the end are stored, not logged, as the serial loop does
        for transitions in open_episodes:
            for transition in transitions:
                run.buffer.add(*transition)
            run.buffer.end_episode()


def _log_episode(run: _Run, ep_return: float, ep_len: int, info: dict, stream: int = 0) -> None:
    """One progress.csv row and the TensorBoard scalars of a finished episode (of collector `stream`)."""
    counters = run.counters
    counters["episodes"] += 1
    errors = run.episode_errors.end(stream)
    if errors is not None:
        run.errors.append(errors)
    success = float(info.get("is_success", 0.0))
    run.returns.append(ep_return)
    run.successes.append(success)
    csv.writer(run.log_file).writerow((counters["episodes"], counters["env_steps"], ep_len, f"{ep_return:.6g}",
                                       success, f"{run.wall_time():.3f}"))
    run.log_file.flush()
    if run.writer is not None:
        for key, value in (("return", ep_return), ("success", success), ("length", ep_len),
                           ("epsilon", run.agent.epsilon)):
            run.writer.add_scalar(f"episode/{key}", value, counters["env_steps"])


def _save(run: _Run) -> None:
    """The replay buffer, then the checkpoint that names it (both atomic); older replay files go."""
    steps = run.counters["env_steps"]
    replay_name = f"replay-{steps:012d}.npz"
    save_replay(run.run_dir / replay_name, run.buffer.state_dict())
    counts = {**run.counters, "wall_time": run.wall_time()}
    save_agent(run.run_dir / CHECKPOINT_NAME, run.agent, {"agent": run.agent_name, "spec": run.spec,
                                                         "replay_file": replay_name, "counters": counts,
                                                         "run_info": run.run_info})
    for old in run.run_dir.glob("replay-*.npz"):
        if old.name != replay_name:
            old.unlink()


def _result(run: _Run, interrupted: bool) -> TrainResult:
    wall_time = time.perf_counter() - run.started
    steps, grads = run.counters["env_steps"], run.counters["gradient_steps"]
    return TrainResult(
        run_dir=run.run_dir, checkpoint=run.run_dir / CHECKPOINT_NAME, env_steps=steps,
        episodes=run.counters["episodes"], gradient_steps=grads,
        success_rate=float(np.mean(run.successes)) if run.successes else float("nan"),
        mean_return=float(np.mean(run.returns)) if run.returns else float("nan"), wall_time=wall_time,
        env_steps_per_s=(steps - run.start_counts[0]) / max(wall_time, 1e-9),
        updates_per_s=(grads - run.start_counts[1]) / run.update_time if run.update_time else float("nan"),
        interrupted=interrupted, tracking_error=mean_errors(run.errors))


def train(env_fn: Callable[[], gym.Env], agent_name: str, config: DDPGConfig | None = None, *,
          total_steps: int | None = None, episodes: int | None = None, run_dir: str | Path | None = None,
          resume: bool = False, init: str | Path | None = None, checkpoint_every: int = 100,
          progress: bool = True, tensorboard: bool = True, run_info: Mapping[str, Any] | None = None,
          collectors: int = 0, zero_actor_head: bool = False) -> TrainResult:
    """Trains `agent_name` on env_fn() until `total_steps` env steps or `episodes` episodes (totals).

    With neither given, trains for config.max_episodes (Table 4). `resume=True` continues the run in
    `run_dir` (its config unless `config` is given; the network sizes and replay size must match).
    `init` starts a new run from another checkpoint's networks and normaliser (fine-tuning, e.g. the
    `goal` planner on `obstacles`), with fresh counters, replay buffer and random streams.
    `zero_actor_head` (a new run) then sets the actor's output layer to zero: a residual planner starts as
    exactly its classical skeleton (Silver et al. 2018; with `actor_burn_in`, the critic learns it first).
    Checkpoints every `checkpoint_every` episodes and at the end (also on Ctrl-C). `run_info` (JSON-able:
    the task and its options, say) is kept in every checkpoint's metadata; a resumed run keeps its own.
    `collectors` >= 1 steps that many environments in collector processes while this process learns
    (`auv_mj.agents.offpolicy.collector`: deterministic given the seed and the count, but not the serial run); `env_fn`
    must then pickle.
    """
    for name, value, least in (("total_steps", total_steps, 0), ("episodes", episodes, 0),
                               ("checkpoint_every", checkpoint_every, 1), ("collectors", collectors, 0)):
        if value is not None and value < least:
            raise ValueError(f"{name} must be >= {least}, got {value}")
    if collectors and agent_name == "td3":
        raise ValueError("collectors: td3 trains serially (its delayed actor steps are not split across "
                         "collector processes); use collectors=0")
    env = env_fn()
    run_dir = Path(run_dir) if run_dir is not None else Path("runs") / f"{agent_name}-{time.strftime('%Y%m%d-%H%M%S')}"
    if zero_actor_head and resume:
        raise ValueError("zero_actor_head starts a new run; a resumed run keeps its actor")
    run = _open_run(env, agent_name, config, run_dir, resume, init, tensorboard, run_info, collectors,
                    zero_actor_head)
    if total_steps is None and episodes is None:
        episodes = run.agent.config.max_episodes
    counters = run.counters
    by_steps = total_steps is not None
    bar = progress_bar(total=total_steps if by_steps else episodes,
                       initial=counters["env_steps"] if by_steps else counters["episodes"],
                       unit="step" if by_steps else "ep", disable=not progress, dynamic_ncols=True)
    interrupted = False
    try:
        if collectors:
            _train_with_collectors(run, env, env_fn, collectors, total_steps, episodes, checkpoint_every, bar)
        else:
            _train_serial(run, env, total_steps, episodes, checkpoint_every, bar)
    except KeyboardInterrupt:
        interrupted = True
        if run.her:
            run.buffer.end_episode()
    finally:
        bar.close()
        run.log_file.close()
    _save(run)
    if run.writer is not None:
        run.writer.close()
    env.close()
    return _result(run, interrupted)
