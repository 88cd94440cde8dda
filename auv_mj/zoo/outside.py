"""Policies from outside the project, plugged into the policy registry (`auv_mj.zoo.registry.RESOLVERS`).

Two forms of `--policy` name are resolved here, on every command that runs episodes (eval, render, plot, demo,
benchmark):
- `MODULE:FACTORY`: `FACTORY(env)` of an importable module returns a Planner (`reset()`, `act(time_step)`,
  `auv_mj.episode.Planner`) or a plain callable `policy(time_step) -> action`;
  `env` is the suite's dm_env environment of the episode (`auv_mj.tasks.suite.load`), `time_step` its `dm_env.TimeStep`.
  A factory may also take the episode seed as a keyword, `FACTORY(env, seed=...)`.
- `PATH.zip`: a Stable-Baselines3 model (DDPG, TD3, SAC, PPO, A2C) trained on our Gymnasium ids
  (`auv_mj.tasks.gym_adapter`). It reads the observation the Gymnasium adapter would give it, through the adapter's own
  map (`auv_mj.tasks.gym_adapter.gym_spaces`), and acts deterministically. Its actions go to the task as the adapter's
  `step` passes them (no protection domain, no residual); a model trained under `VecNormalize` needs its
  statistics, which the zip does not hold, so train such a model without it or fold them into the policy.

Everything that can be refused is refused before the first episode, as a ValueError naming the name (a usage
error, exit 2, on every command): a module that does not import, a missing attribute, a factory that raises or
returns something that is not callable, an action of the wrong shape or not finite, and a model whose spaces do
not fit the task. The action is checked on the real first time step of the task: the environment is reset once
with its random state saved and restored, so the episode itself is unchanged, on a policy made only for the check.
"""

from __future__ import annotations

import importlib
import inspect
import json
import re
import zipfile
from collections.abc import Callable
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from auv_mj.episode import Planner
from auv_mj.zoo.spec import DOMAINS, RESOLVERS, Deployment, PolicySpec

FACTORY_FORM = re.compile(r"^(?P<module>[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*):(?P<factory>[A-Za-z_][\w]*)$")
"""`MODULE:FACTORY`: a dotted module path, a colon and an attribute name (as entry points write them)."""
SB3_ALGORITHMS = ("DDPG", "TD3", "SAC", "PPO", "A2C")
"""The Stable-Baselines3 classes a `PATH.zip` is loaded with, when its own data does not name one."""


def _one_line(error: BaseException) -> str:
    return f"{type(error).__name__}: {' '.join(str(error).split())}"


def _check_action(name: str, action: Any, shape: tuple[int, ...]) -> None:
    """ValueError naming the policy unless `action` is a finite numeric array of the task's action shape."""
    try:
        values = np.asarray(action, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"policy {name!r} returned {type(action).__name__} {action!r:.60}, not an action of "
                         f"shape {shape}") from None
    if values.shape != shape:
        raise ValueError(f"policy {name!r} returned an action of shape {values.shape}; the task takes shape "
                         f"{shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"policy {name!r} returned a non-finite action {values.tolist()}")


def _first_time_step(env):
    """The episode's first time step, leaving the environment's random state where it was (the episode that
    follows is the one it would have been)."""
    random = env.task.random
    state = random.get_state()
    try:
        return env.reset()
    finally:
        random.set_state(state)


_checked: set[tuple[str, str | None]] = set()
"""(policy name, task) whose first action was checked in this process; later episodes skip the check."""


def _checked_build(name: str, make: Callable[[Deployment], Planner]) -> Callable[[Deployment], Planner]:
    """A spec's build: `make(deployment)`, whose first action on each task is checked once per process."""

    def build(deployment: Deployment) -> Planner:
        if (name, deployment.task) not in _checked:
            probe = make(deployment)
            _check_action(name, probe(_first_time_step(deployment.env)), tuple(deployment.env.action_spec().shape))
            _checked.add((name, deployment.task))
        return make(deployment)

    return build


# --- MODULE:FACTORY ---------------------------------------------------------------------------------------------


def _factory(name: str, module_name: str, attribute: str) -> Callable:
    try:
        module = importlib.import_module(module_name)
    except Exception as e:  # noqa: BLE001  (any import failure of a user's module is the user's error)
        raise ValueError(f"policy {name!r}: module {module_name!r} does not import ({_one_line(e)})") from None
    factory = getattr(module, attribute, None)
    if factory is None:
        raise ValueError(f"policy {name!r}: module {module_name!r} ({getattr(module, '__file__', '?')}) has no "
                         f"attribute {attribute!r}")
    if not callable(factory):
        raise ValueError(f"policy {name!r}: {module_name}.{attribute} is a {type(factory).__name__}, not a "
                         f"factory FACTORY(env)")
    return factory


def _takes_seed(factory: Callable) -> bool:
    try:
        return "seed" in inspect.signature(factory).parameters
    except (TypeError, ValueError):
        return False


def _factory_build(name: str, factory: Callable) -> Callable[[Deployment], Planner]:
    seeded = _takes_seed(factory)

    def make(deployment: Deployment) -> Planner:
        try:
            policy = factory(deployment.env, seed=deployment.seed) if seeded else factory(deployment.env)
        except Exception as e:  # noqa: BLE001  (a user's factory may raise anything; it is named, not hidden)
            raise ValueError(f"policy {name!r}: the factory raised {_one_line(e)}") from None
        if not callable(policy):
            raise ValueError(f"policy {name!r}: the factory returned {type(policy).__name__} {policy!r:.40}, "
                             f"not a callable policy(time_step) -> action")
        return policy

    return make


@cache
def _factory_spec(name: str, module_name: str, attribute: str) -> PolicySpec:
    factory = _factory(name, module_name, attribute)
    doc = (inspect.getdoc(factory) or "").split("\n")[0]
    return PolicySpec(f"outside policy {name}" + (f": {doc}" if doc else ""),
                      _checked_build(name, _factory_build(name, factory)), family="outside",
                      domains=tuple(DOMAINS))


def resolve_factory(name: str) -> tuple[PolicySpec, None] | None:
    """`MODULE:FACTORY` -> (its spec, no checkpoint); None for a name of another form."""
    match = FACTORY_FORM.match(name)
    if match is None:
        return None
    return _factory_spec(name, match["module"], match["factory"]), None


# --- PATH.zip: a Stable-Baselines3 model ------------------------------------------------------------------------


def _named_algorithm(path: Path) -> str | None:
    """The SB3 algorithm a saved model names: its policy class's module (`stable_baselines3.td3.policies`)."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (OSError, KeyError, zipfile.BadZipFile, json.JSONDecodeError, UnicodeDecodeError):
        return None
    module = str(data.get("policy_class", {}).get("__module__", ""))
    match = re.match(r"stable_baselines3\.(\w+)\.policies", module)
    return match[1].upper() if match and match[1].upper() in SB3_ALGORITHMS else None


@lru_cache(maxsize=8)
def load_sb3(path: Path):
    """The SB3 model saved at `path`, on the CPU: with the algorithm its data names, else the first of
    SB3_ALGORITHMS that loads it. ValueError naming the file when none does or SB3 is not installed."""
    try:
        import stable_baselines3
    except ImportError:
        raise ValueError(f"policy {str(path)!r}: running a Stable-Baselines3 model needs stable-baselines3 "
                         f"(pip install stable-baselines3)") from None
    if not zipfile.is_zipfile(path):
        raise ValueError(f"policy {str(path)!r}: not a zip file (a Stable-Baselines3 model saved with model.save)")
    named = _named_algorithm(path)
    errors = []
    for algorithm in [named] if named else SB3_ALGORITHMS:
        try:
            return getattr(stable_baselines3, algorithm).load(path, device="cpu")
        except Exception as e:  # noqa: BLE001  (a class that does not fit the file: try the next)
            errors.append(f"{algorithm}: {_one_line(e)}")
    raise ValueError(f"policy {str(path)!r}: no Stable-Baselines3 class loads it ({'; '.join(errors)})")


def _space_text(space) -> str:
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return "Dict(" + ", ".join(f"{k}: {_space_text(v)}" for k, v in space.spaces.items()) + ")"
    if isinstance(space, spaces.Box):
        return f"Box{tuple(space.shape)}"
    return str(space)


def _fits(model_space, task_space) -> bool:
    """Whether spaces agree in kind, keys and shapes (bounds and dtypes may differ: SB3 stores float32)."""
    from gymnasium import spaces

    if isinstance(task_space, spaces.Dict):
        return isinstance(model_space, spaces.Dict) and set(model_space.spaces) == set(task_space.spaces) and all(
            _fits(model_space[key], space) for key, space in task_space.spaces.items())
    return type(model_space) is type(task_space) and tuple(model_space.shape) == tuple(task_space.shape)


def sb3_policy(name: str, path: Path, env) -> Planner:
    """The SB3 model at `path` acting on `env`'s time steps through the Gymnasium adapter's observation;
    ValueError naming both spaces when the model's observation or action space does not fit the task's."""
    from auv_mj.tasks.gym_adapter import gym_spaces

    model = load_sb3(path)
    observation_space, action_space, observe = gym_spaces(env)
    for what, mine, theirs in (("observation", model.observation_space, observation_space),
                               ("action", model.action_space, action_space)):
        if not _fits(mine, theirs):
            raise ValueError(f"policy {name!r}: the model's {what} space {_space_text(mine)} does not fit the "
                             f"task's {_space_text(theirs)}")

    def act(time_step) -> np.ndarray:
        action, _ = model.predict(observe(time_step.observation), deterministic=True)
        return np.asarray(action, dtype=float)

    return act


@cache
def _sb3_spec(name: str) -> PolicySpec:
    path = Path(name)
    load_sb3(path)  # refuse a file that is no model before any environment is built
    build = _checked_build(name, lambda deployment: sb3_policy(name, path, deployment.env))
    return PolicySpec(f"Stable-Baselines3 model {path.name}", build, family="outside", domains=tuple(DOMAINS))


def resolve_sb3(name: str) -> tuple[PolicySpec, None] | None:
    """`PATH.zip` -> (its spec, no checkpoint); None for a name of another form; ValueError for a missing file."""
    if not name.endswith(".zip"):
        return None
    if not Path(name).is_file():
        raise ValueError(f"policy {name!r}: no Stable-Baselines3 model file at {name}")
    return _sb3_spec(name), None


RESOLVERS.extend([resolve_factory, resolve_sb3])
