"""DAgger for a recurrent student (issue 51, item 5; a feed-forward one too): the student drives, a privileged teacher
labels.

Learning by Cheating (Chen et al. 2019) splits a hard problem in two: an expert that sees the world as it is (here
`auv_mj.planners.teacher`, steering down the true map's geodesic field), then a student on the sensors alone trained
on the expert's labels. Behaviour cloning on the expert's own states alone drifts: the student's first mistakes take
it where the expert never was, and it has no label there. DAgger (Ross et al. 2011, Algorithm 3.1) asks the expert
at the states the student visits:

    for round i = 0, 1, ...:
        roll out pi_i = beta_i * teacher + (1 - beta_i) * student_i  (per step, per vehicle)
        label every visited state with the teacher's action; D <- D + those pairs
        student_{i+1} <- fit on all of D

with beta_0 = BETA0 and beta_i = BETA0 * BETA_DECAY^i (the default: the teacher drives round 0, the student after).

The student is PPO's actor (`auv_mj.agents.ppo.ActorCritic`, a GRU after a tanh encoder) reading the env's
observation vector alone (observation="planner": `PLANNER_FIELDS`, the sonar, the pose and the route target; not
`desired_goal`, nor info["privileged"]), so that PPO can fine-tune it afterwards (`auv_mj.agents.ppo`, whose
`imitation_coef` keeps a decaying term towards the teacher's labels). Each round resets every vehicle (fresh
training seeds), so a round's sequences start at episodes' first steps; the fit runs the GRU over the round's whole
sequences from a zero memory, the memory zeroed where an episode starts and carried everywhere else, exactly as in
the rollout, and minimises the squared error between the actor's mean action and the teacher's label on the steps
that were transitions. The actor's input normaliser (`auv_mj.agents.normalizer`) takes in each round's observations
before its fit, as PPO's does after each rollout.

A run writes `run_dir/dagger.pt` (kind "dagger" of `auv_mj.agents.checkpoint`: the student, Adam, the dataset, the
rounds done) after each round, `run_dir/student.pt` (kind "ppo": the student alone, for `PPOPolicy` and for PPO's
fine-tune) and `run_dir/dagger.csv` (a row a round: the dataset, the fit, the validation). Every random draw of round
i derives from (seed, i), so a resumed run gives the run it interrupts, and the same seed the same run.
"""

from __future__ import annotations

import csv
import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium.vector import AutoresetMode, VectorEnv

from auv_mj.agents.checkpoint import (
    config_from_dict,
    config_to_dict,
    load_module,
    load_optimizer,
    module_tensors,
    optimizer_tensors,
    read_checkpoint,
    save_checkpoint,
)
from auv_mj.agents.ppo import ActorCritic, PPOConfig, build_model, save_ppo
from auv_mj.agents.ppo import train as ppo_train
from auv_mj.agents.ppo.config import RECURRENT_KINDS, scheduled
from auv_mj.agents.ppo.spaces import autoreset_mode, env_spec, student_inputs, student_view
from auv_mj.seeds import VALIDATION, train_seed

CHECKPOINT_NAME = "dagger.pt"
STUDENT_NAME = "student.pt"
LOG_NAME = "dagger.csv"
CELLS_LOG_NAME = "dagger_cells.csv"
LOG_FIELDS = ("round", "beta", "dataset_steps", "teacher_share", "loss_before", "loss_after", "val_success",
              "val_collision", "val_episodes", "wall_s")
"""The columns of dagger.csv: a row a round (the fit's loss over the whole dataset before and after it)."""
VALIDATION_FIRST_SEED = VALIDATION.start + 8000
"""The first validation seed of DAgger's per-round check (a block of its own within auv_mj.seeds.VALIDATION)."""


@dataclasses.dataclass(frozen=True)
class DaggerConfig:
    """Hyper-parameters of DAgger (Ross et al. 2011) and of the student's behaviour cloning."""

    rounds: int = 4
    """DAgger rounds (each a rollout, labels, then a fit on the aggregate)."""
    steps_per_round: int = 256
    """Env steps per vehicle in one round's rollout."""
    beta0: float = 1.0
    """Probability that the teacher's action is executed in round 0 (per step, per vehicle)."""
    beta_decay: float = 0.0
    """beta_i = beta0 * beta_decay^i (0: the student drives from round 1 on, Ross et al.'s usual choice)."""
    epochs: int = 8
    """Passes over the aggregated dataset in each fit."""
    final_epochs: int = 0
    """Passes of one more fit over the whole aggregate after the last round (0: none): the student of the last
    round's fit is the one DAgger's rollouts needed, not a fitted one (the 3-D student's imitation loss was still
    falling at 4 epochs a round)."""
    final_lr_fraction: float = 1.0
    """The final fit's step size at its last minibatch, as a fraction of learning_rate, reached by a cosine from
    learning_rate (Loshchilov & Hutter 2017, without restarts; 1: constant, the fits before it had). A step size
    that falls lets the fit settle where a constant one keeps stepping across the minimum's floor."""
    batch_sequences: int = 16
    """Whole vehicles' sequences in one minibatch of the fit."""
    learning_rate: float = 1e-3
    """Adam step size of the fit."""
    max_grad_norm: float = 1.0
    """Global gradient norm clip of the fit."""
    max_dataset_rounds: int | None = None
    """Keep only the last this many rounds of data (None: all of them, DAgger's aggregate)."""
    hidden_sizes: tuple[int, ...] = (128, 128)
    """The student's tanh encoder (as `auv_mj.agents.ppo.planner.PLANNER_CONFIG`)."""
    recurrent: str | None = "gru"
    """The student's memory: "gru" (the shipped students), "lstm", or None, a feed-forward student (the no-memory
    ablation of issue 52, item 6)."""
    recurrent_size: int = 128
    """The student's memory units (unused without a memory)."""
    init_log_std: float = -1.0
    """The student's Gaussian log std for PPO's fine-tune (the fit leaves it as it is)."""
    validation_episodes: int = 8
    """Validation episodes after each round (VALIDATION seeds from VALIDATION_FIRST_SEED; 0: none)."""
    validation_max_steps: int | None = None
    """Cut the validation episodes at this many steps (None: the task's time limits)."""
    seed: int = 0
    """Seeds the student, the beta draws, the minibatch order and the env resets."""
    torch_threads: int = 1
    """Intra-op CPU threads of the fit."""

    def __post_init__(self):
        for name in ("rounds", "steps_per_round", "epochs", "batch_sequences", "recurrent_size", "torch_threads"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"DaggerConfig.{name} must be a whole number >= 1, got {value!r}")
        if not isinstance(self.final_epochs, int) or isinstance(self.final_epochs, bool) or self.final_epochs < 0:
            raise ValueError(f"DaggerConfig.final_epochs must be a whole number >= 0, got {self.final_epochs!r}")
        if not 0.0 <= float(self.final_lr_fraction) <= 1.0:
            raise ValueError(f"DaggerConfig.final_lr_fraction must be in [0, 1], got {self.final_lr_fraction!r}")
        for name in ("beta0", "beta_decay"):
            value = getattr(self, name)
            if not 0.0 <= float(value) <= 1.0:
                raise ValueError(f"DaggerConfig.{name} must be in [0, 1], got {value!r}")
        if self.learning_rate <= 0 or self.max_grad_norm <= 0:
            raise ValueError("DaggerConfig.learning_rate and max_grad_norm must be > 0")
        if self.recurrent not in RECURRENT_KINDS:
            raise ValueError(f"DaggerConfig.recurrent must be one of {RECURRENT_KINDS}, got {self.recurrent!r}")

    def beta(self, round_index: int) -> float:
        """beta_i, the teacher's share of the executed actions in round i."""
        return float(self.beta0) * float(self.beta_decay) ** int(round_index)

    def student_config(self) -> PPOConfig:
        """The PPOConfig of the student's network (an actor-critic PPO can fine-tune)."""
        return PPOConfig(hidden_sizes=self.hidden_sizes, recurrent=self.recurrent, recurrent_size=self.recurrent_size,
                         init_log_std=self.init_log_std, seed=self.seed)


Teacher = Callable[[], np.ndarray]
"""The teacher's actions (N, act_dim) at the env's current states (e.g. `auv_mj.planners.teacher.BatchTeacher`)."""


@dataclasses.dataclass
class Sequences:
    """Sequences of N vehicles over T steps, (T, N, ...) arrays: the aggregated dataset when concatenated along N."""

    obs: np.ndarray
    """(T, N, obs_dim) the student's inputs."""
    starts: np.ndarray
    """(T, N) 1 where obs[t] is an episode's first observation (the memory is zeroed before it)."""
    valid: np.ndarray
    """(T, N) 1 where the step was a transition (not NEXT_STEP's reset step)."""
    labels: np.ndarray
    """(T, N, act_dim) the teacher's actions at those states."""
    teacher_drove: np.ndarray
    """(T, N) 1 where the teacher's action was the one executed."""

    def joined(self, other: Sequences) -> Sequences:
        """Both sets of sequences side by side (they must have the same T)."""
        return Sequences(*(np.concatenate([a, b], axis=1) for a, b in
                           zip(dataclasses.astuple(self), dataclasses.astuple(other), strict=True)))

    @property
    def steps(self) -> int:
        """Labelled transitions."""
        return int(self.valid.sum())


def student_spec(env: VectorEnv) -> dict[str, Any]:
    """The student's spaces (`auv_mj.agents.ppo.env_spec`): the observation vector alone, the env's actions, and the
    task options it must run with (the env's `policy_options`, which the zoo applies when it deploys the file)."""
    space = env.single_observation_space
    if hasattr(space, "spaces") and "observation" in space.spaces:
        space = space["observation"]
    spec = env_spec(space, env.single_action_space)
    options = dict(getattr(env, "policy_options", None) or {})
    if options:  # the task options the student must run with (as `auv_mj.agents.ppo.train` keeps them)
        spec["task_options"] = options
    return spec


def finetune(env: VectorEnv, teacher: Teacher, student: str | Path, run_dir: str | Path, config: PPOConfig,
             total_steps: int, *, resume: bool = False, progress: bool = True, tensorboard: bool = False) -> Any:
    """PPO from the DAgger student `student` (its student.pt) on `env` seen as the student sees it (`student_view`),
    with the teacher's labels under PPO's decaying imitation term (config.imitation_coef, `auv_mj.agents.ppo`); the
    critic is PPO's own (privileged where config says). Returns `auv_mj.agents.ppo.train`'s result."""
    return ppo_train(student_view(env), config, run_dir, total_steps, resume=resume, progress=progress,
                     tensorboard=tensorboard, teacher=teacher, init=None if resume else student)


def collect(env: VectorEnv, model: ActorCritic, teacher: Teacher, steps: int, beta: float, seeds: Sequence[int],
            rng: np.random.Generator) -> Sequences:
    """One DAgger rollout (module docstring): every vehicle reset with `seeds`, `steps` steps each, the teacher's
    action executed with probability `beta` (per step and vehicle), else the student's mean action; every state
    labelled with the teacher's action. The env's autoreset mode is followed (NEXT_STEP's reset steps are not
    transitions)."""
    n = int(env.num_envs)
    mode = autoreset_mode(env)
    obs, _ = env.reset(seed=list(seeds))
    state = model.initial_state(n, actor_only=True)
    starts_now = np.ones(n, bool)
    pending = np.zeros(n, bool)
    act_dim = int(np.prod(env.single_action_space.shape))
    out = Sequences(np.zeros((steps, n, model.obs_dim), np.float32), np.zeros((steps, n), np.float32),
                    np.zeros((steps, n), np.float32), np.zeros((steps, n, act_dim), np.float32),
                    np.zeros((steps, n), np.float32))
    low, high = env.single_action_space.low, env.single_action_space.high
    for t in range(steps):
        x = student_inputs(obs)
        labels = np.clip(np.asarray(teacher(), np.float32).reshape(n, act_dim), low, high)
        with torch.no_grad():
            mean, state = model.act(torch.as_tensor(x)[None], torch.as_tensor(starts_now, dtype=torch.float32)[None],
                                    state)
        student = np.clip(mean[0].numpy(), low, high)
        drove = rng.random(n) < beta
        action = np.where(drove[:, None], labels, student)
        out.obs[t], out.starts[t], out.valid[t], out.labels[t] = x, starts_now, ~pending, labels
        out.teacher_drove[t] = drove
        obs, _, term, trunc, _ = env.step(action.astype(env.single_action_space.dtype))
        ended = np.asarray(term, bool) | np.asarray(trunc, bool)
        if mode == AutoresetMode.SAME_STEP:
            starts_now = ended
        else:
            starts_now, pending = pending.copy(), ended & ~pending
    return out


def imitation_loss(model: ActorCritic, data: Sequences, columns: np.ndarray | slice = slice(None)) -> torch.Tensor:
    """Mean squared error between the actor's mean action and the teacher's label over the valid steps of the
    sequences `columns`, the GRU run over each whole sequence from a zero memory (zeroed at episode starts)."""
    obs = torch.as_tensor(data.obs[:, columns])
    starts = torch.as_tensor(data.starts[:, columns])
    valid = torch.as_tensor(data.valid[:, columns])
    labels = torch.as_tensor(data.labels[:, columns])
    mean, _ = model.act(obs, starts, model.initial_state(obs.shape[1], actor_only=True))
    error = ((mean - labels) ** 2).sum(-1)
    return (error * valid).sum() / valid.sum().clamp(min=1.0)


def fit(model: ActorCritic, optimizer: torch.optim.Optimizer, data: Sequences, config: DaggerConfig,
        generator: torch.Generator, lr_fraction: float = 1.0) -> tuple[float, float]:
    """Behaviour cloning of the teacher's labels on the dataset (`imitation_loss`, minibatches of whole vehicles'
    sequences); the loss over all of it (before, after). `lr_fraction` < 1: the step size falls by a cosine from
    config.learning_rate to that fraction of it at the last minibatch (DaggerConfig.final_lr_fraction), and is
    config.learning_rate again after the fit (the next round's fit, or a resumed run's, starts from it)."""
    columns = data.obs.shape[1]
    last = max(config.epochs * -(-columns // config.batch_sequences) - 1, 1)  # the last minibatch's index
    with torch.no_grad():
        before = float(imitation_loss(model, data))
    step = 0
    for _ in range(config.epochs):
        order = torch.randperm(columns, generator=generator).numpy()
        for at in range(0, columns, config.batch_sequences):
            if lr_fraction < 1.0:
                for group in optimizer.param_groups:
                    group["lr"] = scheduled("cosine", config.learning_rate, config.learning_rate * lr_fraction,
                                            step / last)
            loss = imitation_loss(model, data, np.sort(order[at:at + config.batch_sequences]))
            optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), config.max_grad_norm)
            optimizer.step()
            step += 1
    for group in optimizer.param_groups:
        group["lr"] = config.learning_rate
    with torch.no_grad():
        after = float(imitation_loss(model, data))
    return before, after


def evaluate_student(env_fn: Callable[[int], VectorEnv], model: ActorCritic, episodes: int, first_seed: int,
                     max_steps: int | None = None) -> dict[str, float]:
    """Success and collision rates of the deterministic student on `episodes` episodes, seeds first_seed + k, all
    stepped together (`env_fn(n)` makes an n-vehicle batch); an episode not over at `max_steps` is a failure."""
    env = env_fn(episodes)
    try:
        obs, _ = env.reset(seed=list(range(first_seed, first_seed + episodes)))
        state = model.initial_state(episodes, actor_only=True)
        starts = torch.ones(1, episodes)
        done = np.zeros(episodes, bool)
        success = np.zeros(episodes, bool)
        collision = np.zeros(episodes, bool)
        low, high = env.single_action_space.low, env.single_action_space.high
        steps = 0
        while not done.all() and (max_steps is None or steps < max_steps):
            with torch.no_grad():
                mean, state = model.act(torch.as_tensor(student_inputs(obs))[None], starts, state)
            starts = torch.zeros(1, episodes)
            obs, _, term, trunc, info = env.step(np.clip(mean[0].numpy(), low, high))
            ended = (np.asarray(term, bool) | np.asarray(trunc, bool)) & ~done
            success[ended] = np.asarray(info["success"], bool)[ended]
            collision[ended] = np.asarray(info.get("collision", np.zeros(episodes)), bool)[ended]
            done |= ended
            steps += 1
    finally:
        env.close()
    return {"val_success": float(success.mean()), "val_collision": float(collision.mean()),
            "val_episodes": float(episodes)}


def _save(run_dir: Path, model: ActorCritic, optimizer: torch.optim.Optimizer, data: Sequences | None,
          config: DaggerConfig, spec: Mapping[str, Any], rounds_done: int, round_sizes: Sequence[int],
          final_fit: bool = False) -> None:
    tensors = module_tensors(model, "model")
    tensors.update(optimizer_tensors(optimizer, "optimizer"))
    if data is not None:
        for name, value in dataclasses.asdict(data).items():
            tensors[f"data.{name}"] = torch.as_tensor(value)
    save_checkpoint(run_dir / CHECKPOINT_NAME, "dagger", tensors,
                    {"agent": "dagger", "config": config_to_dict(config), "spec": dict(spec),
                     "counters": {"rounds": rounds_done, "round_sizes": list(round_sizes),
                                  "final_fit_after": rounds_done if final_fit else -1}})
    save_ppo(run_dir / STUDENT_NAME, model, None, None, config.student_config(), spec,
             {"env_steps": 0, "iterations": 0, "episodes": 0, "dagger_rounds": rounds_done})


def _log_cells(path: Path, round_index: int, cells: Mapping[str, float], fresh_file: bool) -> None:
    """Appends a round's per-cell validation to `path` (a row a cell: round, cell, success)."""
    new = fresh_file or not path.exists()
    with open(path, "w" if new else "a", newline="") as f:
        writer = csv.writer(f)
        if new:
            writer.writerow(("round", "cell", "val_success"))
        writer.writerows((round_index, name, value) for name, value in cells.items())


@dataclasses.dataclass
class DaggerResult:
    """Where a run was written and how its last round went."""

    run_dir: Path
    student: Path
    rounds: int
    dataset_steps: int
    log: list[dict[str, float]]
    """The rows of dagger.csv written by this call."""
    config: DaggerConfig
    """The run's config (the saved one on resume)."""


Validator = Callable[[ActorCritic, DaggerConfig], Mapping[str, float]]
"""A round's validation of the student: {"val_success", "val_collision", "val_episodes"} and, optionally, per-cell
entries "cell:NAME" (success rates, written to dagger_cells.csv)."""


def episodes_validator(env_fn: Callable[[int], VectorEnv]) -> Validator:
    """The validation of one batched task: `evaluate_student` on config.validation_episodes episodes from
    VALIDATION_FIRST_SEED, `env_fn(n)` making the n-vehicle batch."""
    def validate(model: ActorCritic, config: DaggerConfig) -> Mapping[str, float]:
        return evaluate_student(env_fn, model, config.validation_episodes, VALIDATION_FIRST_SEED,
                                config.validation_max_steps)
    return validate


def train_dagger(env: VectorEnv, teacher: Teacher, run_dir: str | Path, config: DaggerConfig | None = None, *,
                 resume: bool = False, eval_env_fn: Callable[[int], VectorEnv] | None = None,
                 validate: Validator | None = None, progress: bool = True,
                 rounds: int | None = None, final_epochs: int | None = None,
                 final_lr_fraction: float | None = None) -> DaggerResult:
    """Runs DAgger (module docstring) on the batched `env` with `teacher` labelling its current states, until
    config.rounds rounds are done, checkpointing after each; `resume=True` continues the run in `run_dir` (its
    config; `config` must be None or the same; `rounds` more than it had extends it to that many rounds, the rest of
    its config kept; `final_epochs` likewise sets the final fit's, which runs after the last round where it has not
    yet, and again, from the fitted student, where it has: a further fit; `final_lr_fraction` sets that fit's
    DaggerConfig.final_lr_fraction). After each round, and after the final fit, the student is validated (when
    config.validation_episodes > 0) by `validate`, or on `eval_env_fn(n)`'s batch (`episodes_validator`); the final
    fit's row in dagger.csv has the round number config.rounds and beta nan."""
    if validate is None and eval_env_fn is not None:
        validate = episodes_validator(eval_env_fn)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    spec = student_spec(env)
    data: Sequences | None = None
    rounds_done, round_sizes = 0, []
    final_done = False
    if resume:
        checkpoint = read_checkpoint(run_dir / CHECKPOINT_NAME, "dagger")
        saved = config_from_dict(checkpoint.metadata["config"], run_dir / CHECKPOINT_NAME, DaggerConfig)
        if config is not None and config != saved:
            raise ValueError(f"{run_dir / CHECKPOINT_NAME} was written with another DaggerConfig; pass None to resume")
        config = saved
        if rounds is not None:
            if isinstance(rounds, bool) or not isinstance(rounds, int) or rounds < saved.rounds:
                raise ValueError(f"rounds: a resumed DAgger run goes on to at least its {saved.rounds} rounds, got "
                                 f"{rounds!r}")
            config = dataclasses.replace(saved, rounds=rounds)
        if final_epochs is not None:
            config = dataclasses.replace(config, final_epochs=final_epochs)
        if final_lr_fraction is not None:
            config = dataclasses.replace(config, final_lr_fraction=final_lr_fraction)
    config = config or DaggerConfig()
    torch.set_num_threads(config.torch_threads)
    model = build_model(spec, config.student_config())
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    if resume:
        tensors = checkpoint.tensors
        load_module(model, tensors, "model", run_dir / CHECKPOINT_NAME)
        load_optimizer(optimizer, tensors, "optimizer", run_dir / CHECKPOINT_NAME)
        counters = checkpoint.metadata["counters"]
        rounds_done, round_sizes = int(counters["rounds"]), [int(s) for s in counters["round_sizes"]]
        final_done = int(counters.get("final_fit_after", -1)) == rounds_done and final_epochs is None
        if "data.obs" in tensors:
            data = Sequences(*(tensors[f"data.{f.name}"].numpy() for f in dataclasses.fields(Sequences)))
    log_path = run_dir / LOG_NAME
    rows: list[dict[str, float]] = []
    if not resume or not log_path.exists():
        with open(log_path, "w", newline="") as f:
            csv.writer(f).writerow(LOG_FIELDS)
    n = int(env.num_envs)
    def finish(index: int, beta: float, teacher_share: float, losses: tuple[float, float], started: float,
               final_fit: bool) -> None:
        """A round's (or the final fit's) validation, checkpoint and log rows."""
        row = {"round": index, "beta": beta, "dataset_steps": data.steps, "teacher_share": teacher_share,
               "loss_before": losses[0], "loss_after": losses[1], "val_success": float("nan"),
               "val_collision": float("nan"), "val_episodes": 0.0}
        cells: dict[str, float] = {}
        if validate is not None and config.validation_episodes:
            for key, value in validate(model, config).items():
                (cells if key.startswith("cell:") else row)[key.removeprefix("cell:")] = float(value)
        row["wall_s"] = time.perf_counter() - started
        _save(run_dir, model, optimizer, data, config, spec, min(index + 1, config.rounds), round_sizes,
              final_fit=final_fit)
        with open(log_path, "a", newline="") as f:
            csv.writer(f).writerow([row[k] for k in LOG_FIELDS])
        if cells:
            _log_cells(run_dir / CELLS_LOG_NAME, index, cells, fresh_file=not resume and index == 0)
        rows.append(row)
        if progress:
            print(" ".join(f"{k}={row[k]:.4g}" if isinstance(row[k], float) else f"{k}={row[k]}" for k in LOG_FIELDS),
                  flush=True)

    for i in range(rounds_done, config.rounds):
        started = time.perf_counter()
        rng = np.random.default_rng([config.seed, i])
        seeds = [train_seed(config.seed, i * n + k) for k in range(n)]
        beta = config.beta(i)
        fresh = collect(env, model, teacher, config.steps_per_round, beta, seeds, rng)
        model.obs_norm.update(fresh.obs[fresh.valid.astype(bool)])
        model.obs_norm.sync()  # the fit, the next rollout and PPO's fine-tune read the same statistics
        data = fresh if data is None else data.joined(fresh)
        round_sizes.append(n)
        if config.max_dataset_rounds is not None and len(round_sizes) > config.max_dataset_rounds:
            drop = sum(round_sizes[:-config.max_dataset_rounds])
            round_sizes = round_sizes[-config.max_dataset_rounds:]
            data = Sequences(*(a[:, drop:] for a in dataclasses.astuple(data)))
        generator = torch.Generator().manual_seed(config.seed * 1_000_003 + i)
        losses = fit(model, optimizer, data, config, generator)
        finish(i, beta, float((fresh.teacher_drove * fresh.valid).sum() / max(fresh.valid.sum(), 1.0)), losses,
               started, final_fit=False)
        final_done = False
    if config.final_epochs and data is not None and not final_done:
        started = time.perf_counter()
        generator = torch.Generator().manual_seed(config.seed * 1_000_003 + config.rounds)
        losses = fit(model, optimizer, data, dataclasses.replace(config, epochs=config.final_epochs), generator,
                     config.final_lr_fraction)
        finish(config.rounds, float("nan"), float("nan"), losses, started, final_fit=True)
    elif data is None or rounds_done >= config.rounds and not rows:
        _save(run_dir, model, optimizer, data, config, spec, max(rounds_done, 0), round_sizes, final_fit=final_done)
    return DaggerResult(run_dir, run_dir / STUDENT_NAME, config.rounds, 0 if data is None else data.steps, rows,
                        config)
