"""Learned policies from their checkpoints, as the zoo deploys them: an off-policy planner or executor through the
one deployment chain it was trained in (`checkpoint_policy`), a PPO planner with its memory (`recurrent_policy`),
and the spec build of a checkpoint given by path (`from_checkpoint`), dispatched on the file's kind tag
(`auv_mj.agents.checkpoint`). Each file is read once per version in a process."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.agents.offpolicy.policy import Policy
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.arenas.sonar_memory import MEMORY_BEAMS
from auv_mj.episode import FunctionPlanner, Planner
from auv_mj.planners.deploy import Chain, ChainConfig, deployed
from auv_mj.tasks.gym_adapter import gym_spaces
from auv_mj.zoo.spec import Deployment


@lru_cache(maxsize=16)
def _loaded(path: str, mtime_ns: int, size: int) -> Policy:
    return Policy.load(path)


@lru_cache(maxsize=16)
def _checkpoint_kind(path: str, mtime_ns: int, size: int) -> str:
    return read_checkpoint(path).kind


def checkpoint_kind(path: Path) -> str:
    """The kind of checkpoint `path` (`auv_mj.agents.checkpoint.KINDS`: "ppo" or an off-policy agent), read once
    per version of the file in a process; what a checkpoint builds is dispatched on it."""
    stat = Path(path).stat()
    return _checkpoint_kind(str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)


def loaded_policy(path: Path) -> Policy:
    """`Policy.load(path)`, once per version of the file in a process. A Policy is stateless (the actor in eval
    mode, no exploration noise), so the episodes of an evaluation share it; reading a checkpoint (critic and
    optimiser state included) otherwise costs about as much as building the episode's environment."""
    stat = Path(path).stat()
    return _loaded(str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)


def checkpoint_policy(path: Path, env, protection: bool | str | None = None, guide: str | None = None,
                      zeroed: bool = False, speed: str | None = None) -> Planner:
    """The checkpoint's policy on time steps of `env`; a planner trained with a protection domain in the loop
    (`--env-kwargs '{"protection": true}'`, or "speed-aware") runs with that domain, as it was trained, a
    residual planner (`"residual": R`, `"speed"`) through line of sight (`auv_mj.planners.guidance.guided_action`),
    and a map-guided one (`"guide": "map"`) on the virtual goal along the sonar map's path
    (`auv_mj.planners.map_planner.MapGuide`),
    with the map's scan in its input too under "map-memory".
    `protection` as `PolicySpec.protection`; `guide` and `speed` (`auv_mj.planners.guidance.SPEEDS`) override the
    checkpoint's. `zeroed`: the network's output replaced by zeros, the rest as deployed (the ablation row: what
    the system is without what it learned). The layers are the one deployment chain (`auv_mj.planners.deploy`)
    that the network was trained in.
    ValueError naming the file if its observation or action sizes do not fit the task."""
    policy = loaded_policy(path)
    env_kwargs = policy.metadata.get("run_info", {}).get("env_kwargs", {}) or {}
    chain = {k: v for k, v in env_kwargs.items() if k in ChainConfig.__dataclass_fields__}
    if guide is not None:
        chain["guide"] = guide
    if speed is not None and float(chain.get("residual", 0.0)) > 0:
        chain["speed"] = speed
    if isinstance(protection, str):
        chain["protection"] = protection
    elif protection is not None:
        chain["protection"] = (chain.get("protection") or "paper") if protection else False
    config = ChainConfig(**chain)
    sample = {key: np.zeros(spec.shape) for key, spec in env.observation_spec().items()}
    if config.guide == "map-memory" and "observation" in sample:  # the map's scan is inserted into the vector
        sample["observation"] = np.zeros(sample["observation"].size + MEMORY_BEAMS)
    actions = tuple(env.action_spec().shape)
    try:
        policy.flat_obs(sample["observation"] if set(sample) == {"observation"} else sample)
        if actions != (len(policy.low),):
            raise ValueError(f"it gives {len(policy.low)} actions, the task takes shape {actions}")
    except (KeyError, ValueError) as e:
        raise ValueError(f"checkpoint {path} does not fit this task: {' '.join(str(e).split())}") from None

    def act(time_step):
        observation = time_step.observation
        if zeroed:
            return np.zeros(actions)
        if set(observation) == {"observation"}:
            return policy(np.asarray(observation["observation"]))
        return policy({k: np.asarray(v) for k, v in observation.items()})

    return FunctionPlanner(act) if config.is_identity else deployed(act, Chain(config, env))


def from_checkpoint(deployment: Deployment) -> Planner:
    """A learned spec's build: its checkpoint under its protection domain; a PPO one (a checkpoint path given as
    the name) with its memory, as `planner-memory` runs."""
    if checkpoint_kind(deployment.checkpoint) == "ppo":
        return recurrent_policy(deployment.checkpoint, deployment.env)
    return checkpoint_policy(deployment.checkpoint, deployment.env, deployment.spec.protection)


@lru_cache(maxsize=8)
def _loaded_ppo(path: str, mtime_ns: int, size: int) -> PPOPolicy:
    return PPOPolicy.load(path)


def recurrent_policy(path: Path, env, protection: str | None = None) -> Planner:
    """A PPO checkpoint's deterministic policy on time steps of `env`, its memory (GRU state) carried through
    the episode and zeroed on `time_step.first()`; the task's planning observation and desired goal are its
    input. `protection` (a domain of `auv_mj.planners.avoidance.PROTECTIONS`) runs it under that domain through
    the deployment chain; None: nothing between the network and the task."""
    stat = Path(path).stat()
    shared = _loaded_ppo(str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)
    policy = PPOPolicy(shared.model, shared.spec)  # this episode's own memory over the shared network
    observe = gym_spaces(env)[2]
    actions = tuple(env.action_spec().shape)
    if tuple(policy.spec["act_shape"]) != actions:
        raise ValueError(f"checkpoint {path} does not fit this task: it gives {policy.spec['act_shape']} actions, "
                         f"the task takes shape {actions}")

    def act(time_step):
        if time_step.first():
            policy.reset()
        return policy(observe(time_step.observation))

    planner = FunctionPlanner(act, policy.reset)
    return planner if protection is None else deployed(planner, Chain(ChainConfig(protection=protection), env))
