"""Names -> policies for every command that runs episodes: checkpoints, the shipped policies, baselines.

The one place where tasks and agents meet (the app layer):
- a checkpoint path: a trained `agents.policy.Policy`;
- `planner`: the shipped HER-DDPG planner (`planner.pt`; `planner_tunnel.pt` on the tunnel task), with
  the protection domain of Sec. 3.2.2 active (`tasks.avoidance`), on the task's default S-plane executor;
  `planner-raw`: the same without the protection domain;
- `executor`: the shipped DDPG execution layer (speed_heading);
- `ocean-executor`: the shipped execution layer trained in ocean water (speed_heading): TD3 scheduling the
  S-plane's gains every step from the errors and the last commands (issue 17, `executor_ocean.pt`);
- `splane-ocean`: the classical baseline with the S-plane gains re-tuned in ocean conditions
  (`tasks.splane.OCEAN_GAINS`);
- `two-layer`: the shipped planner (protection domain active) on the shipped learned executor (Sec. 4.3);
- `los-executor`: line-of-sight guidance on the shipped learned executor (the execution layer alone);
- `splane`: the classical baseline (line of sight + S-plane, or S-plane alone on speed_heading);
- `los-avoid`: line of sight along the route with the protection domain, on the S-plane executor: the
  classical local planner;
- `random`: uniform actions.
- `planner-general`, `two-layer-general`: the planner trained on the distribution of arenas
  (`planner_general.pt`, issue 15): a residual planner on line of sight along the route (`tasks.guidance`):
  it sets the speed and corrects the line-of-sight heading from the body-frame goal, its motion and the
  sonar, with the speed-aware protection domain in the loop (`tasks.avoidance.PROTECTIONS`); no map
  coordinates. On the S-plane / on the best learned executor, `ocean-executor` (issue 17).
- `planner-e2e`, `two-layer-e2e`: the first planner trained on that distribution, end to end (HER-DDPG, no
  line of sight under it; `planner_e2e.pt`), kept for comparison; on the S-plane / the paper's executor.
`planner=PATH`, `planner-raw=PATH` and `two-layer=PATH` run the planner checkpoint PATH in place of the
shipped one (to compare or choose candidates, e.g. on validation seeds).

On the planning tasks the executor under any planner is chosen by name in the task options,
`--task-kwargs '{"executor": NAME}'` with NAME one of EXECUTORS (or a speed_heading checkpoint path), e.g. the
general planner on the learned ocean executor:
`--policy planner-general --task-kwargs '{"executor": "ocean-executor"}'`.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from agents.baselines import uniform_random
from agents.checkpoint import read_checkpoint
from agents.policy import Policy
from auv_mj.arenas import arena
from tasks import suite
from tasks.avoidance import PROTECTIONS, map_fence, protection_field, with_repulsion
from tasks.guidance import classical, is_goal_task, line_of_sight, los_avoid, with_guidance
from tasks.speed_heading import ExecutorMemory, executor_options, executor_policy
from tasks.splane import OCEAN_GAINS, SPlaneController

SHIPPED = {"planner": "planner.pt", "planner-tunnel": "planner_tunnel.pt", "planner-general": "planner_general.pt",
           "planner-e2e": "planner_e2e.pt", "executor": "executor.pt", "ocean-executor": "executor_ocean.pt"}
"""Shipped checkpoints: name -> file in `agents/checkpoints/`."""
PLANNER_FOR_TASK = {"tunnel": "planner-tunnel"}
"""Tasks with a planner of their own (trained on that task, as the paper trains per environment)."""
BASELINES = ("splane", "splane-ocean", "los-avoid", "random")
EXECUTOR_TASKS = ("speed_heading",)
LEARNED_EXECUTOR_POLICIES = ("two-layer", "los-executor")
EXECUTOR_POLICIES = ("executor", "ocean-executor")
"""Policies of the speed_heading task alone."""
EXECUTORS = ("splane", "splane-ocean", "executor", "ocean-executor")
"""Executor names a planning task's `executor` option takes on the command line."""
PLANNERS = ("planner", "planner-raw", "two-layer", "los-executor", "los-avoid")
NAMES = ("planner", "planner-raw", "executor", "ocean-executor", "two-layer", "planner-general",
         "two-layer-general", "planner-e2e", "two-layer-e2e", "los-executor", *BASELINES)
"""Every policy name `--policy` takes besides a checkpoint path."""


def _checkpoint_dir() -> Path:
    """`agents/checkpoints`, in a checkout or an installed wheel (the `agents` package's folder)."""
    import agents

    return Path(agents.__file__).resolve().parent / "checkpoints"


def shipped_checkpoint(name: str) -> Path:
    """Path of a shipped checkpoint, with a clear error when it is missing."""
    path = _checkpoint_dir() / SHIPPED[name]
    if not path.is_file():
        raise FileNotFoundError(f"the shipped {name} checkpoint {path} is missing; train one with "
                                f"`auv-mj train` (see README) or pass a checkpoint path")
    return path


class LearnedExecutor:
    """A trained speed_heading policy as a planning task's executor: (command, state) -> (tau_u, tau_r).

    Its input is the speed_heading observation it was trained on and its output becomes the actuator command
    exactly as in the speed_heading task (Eq. 28-29; a residual executor's output corrects the S-plane's),
    through the task's own `ExecutorMemory` (integrals, command history, the S-plane), set up from the
    checkpoint's training options. Call it once per executor step, as the tasks do; `reset` starts an episode.
    """

    def __init__(self, policy, low: np.ndarray, high: np.ndarray):
        self.policy, self.low, self.high = policy, np.asarray(low), np.asarray(high)
        kwargs = getattr(policy, "metadata", {}).get("run_info", {}).get("task_kwargs", {})
        self.memory = ExecutorMemory(**executor_options(policy.obs_dim, kwargs), low=self.low, high=self.high)

    def reset(self) -> None:
        """Zeroes the memories (the start of an episode)."""
        self.memory.reset()

    def __call__(self, command, state) -> np.ndarray:
        return self.memory.forces(np.clip(self.policy(self.memory.observe(command, state)), -1.0, 1.0))


def learned_executor(path: Path | None = None) -> LearnedExecutor:
    """The shipped (or given) learned execution layer as a task executor."""
    low, high = arena.load().model.actuator_ctrlrange.T
    return LearnedExecutor(Policy.load(path or shipped_checkpoint("executor")), low, high)


def named_executor(name: str):
    """The executor `name` (one of EXECUTORS, or a speed_heading checkpoint path) as `executor(command, state)`."""
    if name == "splane":
        return SPlaneController()
    if name == "splane-ocean":
        return SPlaneController(OCEAN_GAINS)
    if name in EXECUTOR_POLICIES:
        return learned_executor(shipped_checkpoint(name))
    if Path(name).is_file():
        return learned_executor(Path(name))
    raise ValueError(f"task_kwargs executor {name!r}: not one of {list(EXECUTORS)} nor a checkpoint file")


class General(NamedTuple):
    """A planner trained on the distribution of arenas, as a named policy."""

    system: str
    """"planner" (on the task's S-plane executor, or the one the task options name) or "two-layer"."""
    checkpoint: str
    """Its SHIPPED checkpoint."""
    executor: str = "executor"
    """The learned executor of its two-layer system (one of EXECUTOR_POLICIES)."""
    protection: str | None = None
    """The protection domain it is deployed with (`tasks.avoidance.PROTECTIONS`); None: the one it trained with."""


GENERAL = {"planner-general": General("planner", "planner-general", protection="speed-aware"),
           "two-layer-general": General("two-layer", "planner-general", "ocean-executor", "speed-aware"),
           "planner-e2e": General("planner", "planner-e2e"), "two-layer-e2e": General("two-layer", "planner-e2e")}
"""Names of the planners trained on the distribution of arenas. The residual planner trained with the paper's
domain in the loop and runs with the speed-aware one, as chosen on validation (docs/runs/planner-speed-aware)."""


def split_name(policy_name: str) -> tuple[str, Path | None]:
    """("two-layer", PATH) for "two-layer=PATH" (also planner, planner-raw) and for the general planner's
    names; (name, None) otherwise."""
    if policy_name in GENERAL:
        general = GENERAL[policy_name]
        return general.system, shipped_checkpoint(general.checkpoint)
    base, sep, path = policy_name.partition("=")
    if sep and base in ("planner", "planner-raw", "two-layer"):
        if not Path(path).is_file():
            raise FileNotFoundError(f"policy {policy_name!r}: no checkpoint at {path}")
        return base, Path(path)
    return policy_name, None


def make_env(policy_name: str, task_name: str, seed: int, **task_kwargs):
    """The suite environment for one episode; `two-layer` plugs in the learned executor, and a checkpoint
    gets the observation it was trained on (read from its metadata)."""
    task_kwargs["random"] = seed
    executor = task_kwargs.get("executor")
    if split_name(policy_name)[0] in LEARNED_EXECUTOR_POLICIES and task_name not in EXECUTOR_TASKS:
        if executor is not None:
            raise ValueError(f"policy {policy_name!r} runs the learned executor; leave 'executor' out of "
                             f"task_kwargs (or use a planner policy with it)")
        task_kwargs["executor"] = named_executor(GENERAL[policy_name].executor if policy_name in GENERAL
                                                 else "executor")
    elif isinstance(executor, str):
        task_kwargs["executor"] = named_executor(executor)
    elif policy_name == "splane-ocean" and task_name not in EXECUTOR_TASKS:
        task_kwargs["executor"] = named_executor("splane-ocean")
    checkpoint = _checkpoint_path(policy_name, task_name)
    if checkpoint is not None and "observation" not in task_kwargs:
        meta = read_checkpoint(checkpoint)[1]
        if task_name in EXECUTOR_TASKS:  # the executor's observation (residual, gains, base) it was trained with
            trained = meta.get("run_info", {}).get("task_kwargs", {})
            memory = executor_options(int(meta["obs_dim"]), trained)
            task_kwargs.update({k: v for k, v in memory.items() if k not in task_kwargs})
        elif meta["spec"].get("kind") == "goal":  # a planner reading the goal beside the paper's vector
            task_kwargs["observation"] = "paper" if meta["spec"].get("goal_input", True) else "relative"
    return suite.load("auv", task_name, task_kwargs=task_kwargs)


def _checkpoint_path(policy_name: str, task_name: str | None = None) -> Path | None:
    """The checkpoint behind `policy_name` (on `task_name`), or None for a baseline."""
    base, path = split_name(policy_name)
    if path is not None:
        return path
    if policy_name in EXECUTOR_POLICIES:
        return shipped_checkpoint(policy_name)
    if policy_name in ("planner", "planner-raw", "two-layer") and task_name not in EXECUTOR_TASKS:
        return shipped_checkpoint(PLANNER_FOR_TASK.get(task_name, "planner"))
    path = Path(policy_name)
    return path if path.is_file() else None


def _checkpoint_policy(path: Path, env, protection: bool | str | None = None):
    """The checkpoint's policy on time steps of `env`; a planner trained with a protection domain in the loop
    (`--env-kwargs '{"protection": true}'`, or "speed-aware") runs with that domain, as it was trained, and a
    residual planner (`"residual": R`) through line of sight (`tasks.guidance.guided_action`). `protection`
    False runs it without a domain, True with its own (the paper's if it was trained with none), a name of
    `tasks.avoidance.PROTECTIONS` with that one.
    ValueError naming the file if its observation or action sizes do not fit the task."""
    policy = Policy.load(path)
    sample = {key: np.zeros(spec.shape) for key, spec in env.observation_spec().items()}
    actions = tuple(env.action_spec().shape)
    try:
        policy.flat_obs(sample["observation"] if set(sample) == {"observation"} else sample)
        if actions != (len(policy.low),):
            raise ValueError(f"it gives {len(policy.low)} actions, the task takes shape {actions}")
    except (KeyError, ValueError) as e:
        raise ValueError(f"checkpoint {path} does not fit this task: {' '.join(str(e).split())}") from None

    def act(time_step):
        observation = time_step.observation
        if set(observation) == {"observation"}:
            return policy(np.asarray(observation["observation"]))
        return policy({k: np.asarray(v) for k, v in observation.items()})

    env_kwargs = policy.metadata.get("run_info", {}).get("env_kwargs", {}) or {}
    if float(env_kwargs.get("residual", 0.0)) > 0:  # a residual planner acts through line of sight
        act = with_guidance(act, env, float(env_kwargs["residual"]))
    field = protection_field(env_kwargs.get("protection", False))
    if isinstance(protection, str):
        field = protection_field(protection)
    elif protection is not None:
        field = (field or PROTECTIONS["paper"]) if protection else None
    return with_repulsion(act, field, map_fence(env)) if field is not None else act


def make_policy(policy_name: str, env, seed: int = 0, task: str | None = None):
    """A callable `policy(time_step) -> action` for `env` (of suite task `task`, which picks the planner)."""
    planner = PLANNER_FOR_TASK.get(task, "planner")
    base, path = split_name(policy_name)
    if path is not None:
        deployed = GENERAL[policy_name].protection if policy_name in GENERAL else None
        return _checkpoint_policy(path, env, protection=deployed or base != "planner-raw")
    if policy_name == "random":
        return uniform_random(env, seed)
    if policy_name == "splane":
        return classical(env)
    if policy_name == "splane-ocean":  # on a planning task its executor was set by make_env
        return line_of_sight(env) if is_goal_task(env) else executor_policy(env, named_executor("splane-ocean"))
    if policy_name == "los-executor":
        return line_of_sight(env)
    if policy_name == "los-avoid":
        return los_avoid(env)
    if policy_name in ("planner", "two-layer"):
        return _checkpoint_policy(shipped_checkpoint(planner), env, protection=True)
    if policy_name == "planner-raw":
        return _checkpoint_policy(shipped_checkpoint(planner), env, protection=False)
    if policy_name in EXECUTOR_POLICIES:
        return _checkpoint_policy(shipped_checkpoint(policy_name), env)
    path = Path(policy_name)
    if not path.is_file():
        raise ValueError(f"unknown policy {policy_name!r}: not a checkpoint file, nor one of {list(NAMES)}")
    return _checkpoint_policy(path, env)


def resolve_tasks(spec: str, policy_name: str = "splane") -> list[str]:
    """A task name, a tag or 'all' -> task names the policy can run (planners skip speed_heading)."""
    names = [task for domain, task in suite.ALL_TASKS if domain == "auv"]
    if spec == "all":
        chosen = names
    elif spec in names:
        chosen = [spec]
    else:
        chosen = [t for d, t in suite.tasks_by_tag(spec) if d == "auv"] if spec in suite.TAGS else []
        if not chosen:
            raise ValueError(f"unknown task or tag {spec!r}; tasks: {names}; tags: {sorted(suite.TAGS)}")
    if split_name(policy_name)[0] in PLANNERS:
        chosen = [t for t in chosen if t not in EXECUTOR_TASKS]
    elif policy_name in EXECUTOR_POLICIES:
        chosen = [t for t in chosen if t in EXECUTOR_TASKS]
    if not chosen:
        raise ValueError(f"policy {policy_name!r} cannot run any task of {spec!r}")
    return chosen


def env_and_policy(policy_name: str, task_name: str, seed: int, task_kwargs: dict | None = None):
    """The environment of one episode of `task_name` (seeded `seed`) and the named policy acting in it.

    Raises ValueError naming the option when the task does not take one of `task_kwargs`. Policies infer on
    one torch thread: their small MLPs are fastest so, and parallel episodes do not oversubscribe the cores.
    """
    torch.set_num_threads(1)
    task_kwargs = dict(task_kwargs or {})
    if "random" in task_kwargs:
        raise ValueError("task_kwargs: 'random' is set by --seed (episode i gets seed + i), leave it out")
    try:
        env = make_env(policy_name, task_name, seed, **task_kwargs)
    except TypeError as e:  # an option the task does not take
        raise ValueError(f"task_kwargs {task_kwargs} do not fit task {task_name!r}: {e}") from None
    return env, make_policy(policy_name, env, seed, task_name)
