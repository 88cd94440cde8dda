"""The one deployment chain of a trained planner: guide, residual, protection, around its network's action.

A planner is trained and evaluated inside the same layers, in this order:

1. the guide (`ChainConfig.guide`): "route" leaves the task's goal; "map" puts the virtual goal along the sonar map's
   planned path in the observation (`auv_mj.planners.map_planner.MapGuide`) and pays the path's progress as the
   reward; "map-memory" adds the map itself to the observation vector;
2. the residual (`residual` > 0): the action is a correction of that span to line of sight on the (guided) goal,
   `auv_mj.planners.guidance.guided_action`, its speed fixed, a correction to or as the classical planners' one
   (`speed`);
3. the protection domain (`protection`, Sec. 3.2.2, `auv_mj.planners.avoidance.PROTECTIONS`): the heading bent away
   from near echoes (and the map's edge for the speed-aware domain).

`Chain` is that sequence bound to one suite environment. Training sees it as a Gymnasium wrapper
(`DeployedEnv`, `deploy_env`), evaluation as a policy decorator (`deployed`): both call the same `Chain` methods,
so that what a network learned in and what it is run in cannot drift.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import dm_env
import gymnasium
import numpy as np
from gymnasium import spaces

from auv_mj.episode import FunctionPlanner, Planner, as_planner
from auv_mj.planners.avoidance import map_fence, protect, protection_field
from auv_mj.planners.guidance import MAX_RESIDUAL, SPEEDS, guided_action
from auv_mj.planners.map_planner import GUIDES, MapGuide
from auv_mj.tasks import options as checks
from auv_mj.tasks.actions import checked_action


@dataclass(frozen=True)
class ChainConfig:
    """How a planner is deployed: the options of the chain (module docstring), as a run keeps them in its
    checkpoint's `env_kwargs`."""

    protection: bool | str = False
    """The protection domain: False, True (the paper's), or a name of `PROTECTIONS` ("paper", "speed-aware")."""
    residual: float = 0.0
    """Span of the residual correction to line of sight (0: the network's action is the task's action)."""
    guide: str = "route"
    """What the planner's goal is: one of GUIDES."""
    speed: str = "absolute"
    """A residual planner's speed: one of SPEEDS ("absolute": its own; "top", "fixed": the classical one's)."""

    def __post_init__(self):
        protection_field(self.protection)  # ValueError naming a bad value
        object.__setattr__(self, "residual", checks.number("residual", self.residual, 0.0, MAX_RESIDUAL))
        if not isinstance(self.guide, str) or self.guide not in GUIDES:
            raise ValueError(f"guide must be one of {list(GUIDES)}, got {checks.shown(self.guide)}")
        if not isinstance(self.speed, str) or self.speed not in SPEEDS:
            raise ValueError(f"speed must be one of {list(SPEEDS)}, got {checks.shown(self.speed)}")
        if self.speed != "absolute" and not self.residual:
            raise ValueError(f"speed={self.speed!r} (a correction to the classical planners' speed) is a residual "
                             "planner's option: set residual > 0 too")

    @classmethod
    def from_kwargs(cls, kwargs: Mapping[str, Any] | None) -> ChainConfig:
        """The chain a run's `env_kwargs` name; ValueError naming an option the chain does not have."""
        kwargs = dict(kwargs or {})
        unknown = sorted(set(kwargs) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f"env_kwargs {unknown}: not options of the deployment chain "
                             f"({', '.join(cls.__dataclass_fields__)})")
        return cls(**kwargs)

    @property
    def is_identity(self) -> bool:
        """Whether the chain leaves actions, observations and rewards as the task's."""
        return not self.protection and not self.residual and self.guide == "route"

    def as_kwargs(self) -> dict[str, Any]:
        """The options that differ from the defaults (what a run records)."""
        default = ChainConfig()
        return {k: v for k, v in asdict(self).items() if v != getattr(default, k)}


class Chain:
    """`ChainConfig` bound to one suite (dm_env) environment of a planning task."""

    def __init__(self, config: ChainConfig, env):
        if not config.is_identity and "desired_goal" not in env.observation_spec():
            raise ValueError(f"the deployment chain {config.as_kwargs()} is for the planning tasks: this task has "
                             "no goal")
        self.config, self.env = config, env
        self.field = protection_field(config.protection)
        self.fence = map_fence(env) if self.field is not None and self.field.fence else None
        self.guide = MapGuide(env, memory=config.guide == "map-memory") if config.guide != "route" else None

    @property
    def inserted_inputs(self) -> tuple[int, int] | None:
        """(index, count) of the inputs the guide puts into the observation vector (guide="map-memory"), so that
        a network trained without them can be widened (`auv_mj.agents.offpolicy.train`, `--init`); None otherwise."""
        return None if self.guide is None else self.guide.inserted_inputs

    @property
    def goal_dependent_actions(self) -> bool:
        """Whether what an action does depends on the desired goal (a residual planner), or the reward is not the
        task's goal-conditioned one (a guide): hindsight relabelling would then store transitions that did not
        happen."""
        return self.config.residual > 0 or self.guide is not None

    def reset(self) -> None:
        """Forgets the map (the next time step starts an episode)."""
        if self.guide is not None:
            self.guide.reset()

    def observe(self, time_step: dm_env.TimeStep) -> Mapping[str, np.ndarray]:
        """The planner's observation of `time_step`: the task's, or the guide's."""
        return time_step.observation if self.guide is None else self.guide(time_step)[0]

    def reward(self, time_step: dm_env.TimeStep) -> float:
        """The step's reward the planner is trained on: the task's, or the guide's path progress (`path_reward`);
        call after `observe` of the same step."""
        return float(time_step.reward) if self.guide is None else self.guide.reward(self.env.task.last_info)

    def act(self, action, observation: Mapping[str, np.ndarray]) -> np.ndarray:
        """The network's `action` on `observation` (from `observe`) as the task's action: the residual, then the
        protection domain."""
        action = np.asarray(action, dtype=float)
        if self.config.residual:
            action = guided_action(action, observation["desired_goal"], self.env.physics.pose(), self.config.residual,
                                   self.config.speed, self.env.task)
        if self.field is not None:
            action = protect(action, observation["observation"], self.field,
                             self.fence() if self.fence is not None else None)
        return action


def deployed(policy: Planner, chain: Chain) -> Planner:
    """`policy` (a network on the planner's observation) run in the chain's environment through the chain: the
    evaluation side of the one chain."""
    inner = as_planner(policy)

    def act(time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first():
            chain.reset()
        observation = chain.observe(time_step)
        return chain.act(inner.act(time_step._replace(observation=observation)), observation)

    def reset() -> None:
        chain.reset()
        inner.reset()

    return FunctionPlanner(act, reset)


class DeployedEnv(gymnasium.Wrapper):
    """A planning task's Gymnasium environment (`AUVGymEnv`, or the mixture `PlanningMix`) through the chain: the
    training side of the one chain. Its observations, rewards and actions are the planner's (`Chain`)."""

    def __init__(self, env: gymnasium.Env, config: ChainConfig):
        super().__init__(env)
        self.config = config
        self._chains: dict[int, Chain] = {}
        self._observation: Mapping[str, np.ndarray] | None = None
        inserted = self._chain().inserted_inputs
        if inserted is not None:  # the map-memory scan widens the observation vector
            size = env.observation_space["observation"].shape[0] + inserted[1]
            self.observation_space = spaces.Dict({**env.observation_space.spaces,
                                                  "observation": spaces.Box(-np.inf, np.inf, (size,), np.float64)})

    def _base(self):
        """The active `AUVGymEnv` (the mixture's current task)."""
        base = self.env.unwrapped
        return getattr(base, "active", base)

    def _chain(self) -> Chain:
        base = self._base()
        key = id(base.dm_env)
        if key not in self._chains:
            self._chains[key] = Chain(self.config, base.dm_env)
        return self._chains[key]

    @property
    def protection(self) -> bool:
        """Whether a protection domain acts on every action."""
        return self._chain().field is not None

    @property
    def inserted_inputs(self) -> tuple[int, int] | None:
        return self._chain().inserted_inputs

    @property
    def goal_dependent_actions(self) -> bool:
        return self._chain().goal_dependent_actions

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        _, info = self.env.reset(seed=seed, options=options)
        chain = self._chain()
        chain.reset()
        self._observation = chain.observe(self._base().last_time_step)
        return self._base().gym_observation(self._observation), info

    def step(self, action):
        base, chain = self._base(), self._chain()
        action = chain.act(checked_action(action, base.dm_env.action_spec(), base.task), self._observation)
        _, _, terminated, truncated, info = self.env.step(action)
        time_step = base.last_time_step
        self._observation = chain.observe(time_step)
        return base.gym_observation(self._observation), chain.reward(time_step), terminated, truncated, info


def deploy_env(env: gymnasium.Env, **chain: Any) -> gymnasium.Env:
    """`env` through the chain that `chain` (ChainConfig's options) names; `env` itself for the identity chain."""
    config = ChainConfig.from_kwargs(chain)
    return env if config.is_identity else DeployedEnv(env, config)
