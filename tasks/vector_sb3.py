"""Stable-Baselines3's `VecEnv` face of the batched planning envs (`auv_mj.tasks.vector.AUVVectorEnv`, planar;
`auv_mj.tasks.vector3d.AUV3DVectorEnv`, 6-DOF: both `GoalVectorEnv`s) and of the training mixture
(`auv_mj.tasks.mixture.PlanningMixtureVectorEnv`).

SB3 resets a finished sub-environment in the step that finished it and keeps the last observation in
info["terminal_observation"] (and info["TimeLimit.truncated"] for a time limit), as its `DummyVecEnv` does; that is
the batch's same-step autoreset. Infos come back as SB3's list of per-environment dicts, built from the batch's
dict of arrays (the keys each sub-environment reported). `env_method("compute_reward", ...)` reaches the task's
vectorised reward, so HER's relabelling works on it as on `AUVGymEnv`.

    env = SB3VectorEnv(AUVVectorEnv("obstacles", 64, {"arena": "random"}, autoreset_mode="SameStep"))
    PPO("MultiInputPolicy", env).learn(100_000)

`seed(s)` seeds the next reset as `env.reset(seed=s)` does (sub-environment i gets s + i; the mixture's rows
`train_seed(s, i)`, TRAIN seeds only), where SB3's own VecEnv would give each sub-environment s + i itself. A learner
of the observation vector alone (no goals in the world frame) reads it through SB3's own view,
`VecExtractDictObs(env, "observation")`, which takes the key out of info["terminal_observation"] too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn
except ImportError:  # SB3 is no dependency of auv-mj: this adapter is for those who use it
    raise ImportError("auv_mj.tasks.vector_sb3 is Stable-Baselines3's face of the batched environment: "
                      "pip install stable-baselines3") from None

from auv_mj.tasks.mixture import PlanningMixtureVectorEnv
from auv_mj.tasks.vector import GoalVectorEnv


class SB3VectorEnv(VecEnv):
    """A `VecEnv` over one batched env (`GoalVectorEnv`) or the training mixture (`PlanningMixtureVectorEnv`), built
    with autoreset_mode SAME_STEP."""

    def __init__(self, env: GoalVectorEnv | PlanningMixtureVectorEnv):
        if not isinstance(env, GoalVectorEnv | PlanningMixtureVectorEnv):
            raise ValueError(f"env must be an AUVVectorEnv, an AUV3DVectorEnv or a PlanningMixtureVectorEnv, got "
                             f"{type(env).__name__}")
        if env.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError(f"env: SB3 resets in the step that ends an episode; build the {type(env).__name__} "
                             "with autoreset_mode='SameStep'")
        self.env = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None
        self._seed: int | None = None

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds the next reset: `env.reset(seed=seed)` (see the module docstring); None draws one."""
        seeds = super().seed(seed)
        self._seed = seeds[0]
        return seeds

    def reset(self):
        """Resets every sub-environment, with the seed given to `seed` (then forgotten), else continuing each one's
        RandomState (the mixture: its seed stream)."""
        observation, info = self.env.reset(seed=self._seed)
        self._seed = None
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = self._split(info)
        return observation

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        observation, reward, terminated, truncated, info = self.env.step(self._actions)
        done = terminated | truncated
        infos = self._split(info)
        if "final_info" in info:
            finals = self._split(info["final_info"])
            for i in np.flatnonzero(done):
                infos[i] = finals[i]
                infos[i]["terminal_observation"] = info["final_obs"][i]
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return observation, reward.astype(np.float32), done, infos

    def _split(self, info: dict) -> list[dict]:
        """Gymnasium's dict of arrays with "_key" masks -> one dict per sub-environment."""
        keys = [k for k in info if not k.startswith("_") and k not in ("final_obs", "final_info")]
        out: list[dict] = [{} for _ in range(self.num_envs)]
        for key in keys:
            values, mask = info[key], info["_" + key]
            for i in np.flatnonzero(mask):
                value = values[i]
                out[i][key] = value.item() if isinstance(value, np.generic) else value
        return out

    def close(self) -> None:
        self.env.close()

    def _indices(self, indices: VecEnvIndices) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        return [indices] if isinstance(indices, int) else list(indices)

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The batch's attribute, once per index (the sub-environments share their options)."""
        return [getattr(self.env, attr_name) for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs) -> list[Any]:
        """The batch's method (e.g. compute_reward), called once per index."""
        method = getattr(self.env, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._indices(indices)]
