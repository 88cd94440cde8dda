"""One env's spaces as PPO's networks see them: a flat observation, and actions in [-1, 1] mapped onto the env's Box.

- Observations: a Box (flattened), or a goal Dict whose `observation` and `desired_goal` are concatenated in that
  order (OBS_KEYS; `achieved_goal` is not an input).
- Actions: the networks act in a normalised space whose [-1, 1] is the env's Box (`env_action`).
- `env_spec` is the JSON-able description of both that a network and a checkpoint need; `autoreset_mode` reads the
  vector env's autoreset mode (Gymnasium >= 1.0), which the rollout follows.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from gymnasium.wrappers.vector import TransformObservation

OBS_KEYS = ("observation", "desired_goal")
"""The keys of a goal Dict observation that form the network input, concatenated in this order."""


def env_spec(observation_space: spaces.Space, action_space: spaces.Space) -> dict[str, Any]:
    """The JSON-able description of one env's spaces that a network and a checkpoint need; ValueError for spaces
    PPO here cannot take (not a Box or goal Dict observation, not a bounded Box action)."""
    if isinstance(observation_space, spaces.Dict):
        missing = [k for k in OBS_KEYS if k not in observation_space.spaces]
        if missing or not all(isinstance(observation_space[k], spaces.Box) for k in OBS_KEYS):
            raise ValueError(f"a Dict observation space needs Box entries {OBS_KEYS}, got {observation_space}")
        parts = [int(np.prod(observation_space[k].shape)) for k in OBS_KEYS]
        spec: dict[str, Any] = {"kind": "goal", "obs_keys": list(OBS_KEYS), "obs_parts": parts,
                                "obs_shape": [sum(parts)]}
    elif isinstance(observation_space, spaces.Box):
        spec = {"kind": "box", "obs_shape": list(observation_space.shape)}
    else:
        raise ValueError(f"observation space must be a Box or a goal Dict, got {type(observation_space).__name__}")
    if not isinstance(action_space, spaces.Box):
        raise ValueError(f"action space must be a Box (continuous actions), got {type(action_space).__name__}")
    low, high = action_space.low.reshape(-1), action_space.high.reshape(-1)
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low < high)):
        raise ValueError(f"action space bounds must be finite with low < high, got {action_space}")
    spec.update(obs_dim=int(np.prod(spec["obs_shape"])), act_dim=int(low.size), act_shape=list(action_space.shape),
                action_low=low.astype(float).tolist(), action_high=high.astype(float).tolist())
    if spec["obs_dim"] < 1:
        raise ValueError(f"observation space has no entries: {observation_space}")
    return spec


def flatten_obs(obs: np.ndarray | Mapping[str, np.ndarray], spec: Mapping[str, Any]) -> np.ndarray:
    """The network input of an observation or a batch (leading dims kept): a Box flattened (a goal Dict's
    `observation` alone for a Box policy: a student of the vector alone), a goal Dict's OBS_KEYS flattened and
    concatenated for a goal policy."""
    if spec["kind"] == "goal":
        if not isinstance(obs, Mapping):
            raise ValueError(f"a goal policy takes a dict observation with keys {OBS_KEYS}, got {type(obs).__name__}")
        arrays = [np.asarray(obs[k], np.float32) for k in spec["obs_keys"]]
        lead = arrays[0].shape[:-1] if arrays[0].ndim else ()
        flat = np.concatenate([a.reshape(*lead, -1) for a in arrays], axis=-1)
    else:
        if isinstance(obs, Mapping):  # a student of the vector alone (`student_view`)
            if "observation" not in obs:
                raise ValueError(f"a Box policy takes an array or a dict with an 'observation' entry, got keys "
                                 f"{sorted(obs)}")
            obs = obs["observation"]
        arr = np.asarray(obs, np.float32)
        flat = arr.reshape(*arr.shape[: arr.ndim - len(spec["obs_shape"])], -1)
    if flat.shape[-1] != spec["obs_dim"]:
        raise ValueError(f"observation of size {flat.shape[-1]}, the policy expects {spec['obs_dim']}")
    return flat


def env_action(action: np.ndarray, spec: Mapping[str, Any]) -> np.ndarray:
    """A normalised action (..., act_dim), clipped to [-1, 1] and rescaled to the env's Box."""
    low, high = np.asarray(spec["action_low"]), np.asarray(spec["action_high"])
    a = np.clip(action, -1.0, 1.0)
    return low + (a + 1.0) * 0.5 * (high - low)


def normalised_action(action: np.ndarray, spec: Mapping[str, Any]) -> np.ndarray:
    """An action of the env's Box (..., act_dim) in the networks' normalised space, clipped to [-1, 1]: the inverse
    of `env_action` (a teacher's label, for the imitation term)."""
    low, high = np.asarray(spec["action_low"]), np.asarray(spec["action_high"])
    return np.clip(2.0 * (np.asarray(action, dtype=float) - low) / (high - low) - 1.0, -1.0, 1.0)


def autoreset_mode(env: VectorEnv) -> AutoresetMode:
    """The env's autoreset mode from `env.metadata["autoreset_mode"]` (NEXT_STEP, Gymnasium's default, when
    absent); ValueError for DISABLED or an unknown value."""
    mode = (getattr(env, "metadata", None) or {}).get("autoreset_mode", AutoresetMode.NEXT_STEP)
    try:
        mode = mode if isinstance(mode, AutoresetMode) else AutoresetMode(mode)
    except ValueError:
        raise ValueError(f"unknown autoreset_mode {mode!r} in the env's metadata") from None
    if mode == AutoresetMode.DISABLED:
        raise ValueError("autoreset_mode DISABLED is not supported: PPO needs an autoresetting vector env")
    return mode


def final_observation(info: Mapping[str, Any], i: int) -> Any:
    """Env i's final observation from a SAME_STEP info dict (an object array, or a dict of arrays for Dict spaces)."""
    if "final_obs" not in info:
        raise ValueError("a SAME_STEP vector env must return info['final_obs'] for the envs that ended")
    final = info["final_obs"]
    if isinstance(final, Mapping):
        return {k: v[i] for k, v in final.items()}
    return final[i]


def student_inputs(obs: Any) -> np.ndarray:
    """The student's input of a (batched) observation: a goal dict's `observation` vector alone, else the array."""
    if isinstance(obs, Mapping):
        obs = obs["observation"]
    return np.asarray(obs, np.float32)


class StudentView(TransformObservation):
    """A goal-dict vector env as the student sees it (`student_view`); the dict's `achieved_goal` (the vehicle's
    position) moves to info["achieved_goal"], for the training logs' speed, never an input."""

    def __init__(self, env: VectorEnv):
        single = env.single_observation_space["observation"]
        super().__init__(env, student_inputs, batch_space(single, env.num_envs), single)
        # a wrapper forwards no attributes: the options a policy must run with, and a mixture's cells for PPO's
        # per-cell logs (`auv_mj.agents.ppo.Collector`)
        self.policy_options = dict(getattr(env, "policy_options", None) or {})
        for name in ("cells", "cell_of_row"):
            if hasattr(env, name):
                setattr(self, name, getattr(env, name))

    def reset(self, *, seed: Any = None, options: dict | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        return self.func(obs), {**info, "achieved_goal": obs["achieved_goal"]}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(actions)
        return self.func(obs), reward, terminated, truncated, {**info, "achieved_goal": obs["achieved_goal"]}


def student_view(env: VectorEnv) -> VectorEnv:
    """`env` as the student sees it, for PPO's fine-tune: its observation vector alone (a goal dict's `observation`;
    no `desired_goal`), actions and the info unchanged (info["privileged"] for the critic) but for the achieved goal
    (`StudentView`)."""
    space = env.single_observation_space
    if not (hasattr(space, "spaces") and "observation" in space.spaces):
        return env
    return StudentView(env)
