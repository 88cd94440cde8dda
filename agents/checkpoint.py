"""Atomic, weights-only checkpoints of a DDPG agent and its replay buffer.

A checkpoint is `torch.save({"tensors": {name: Tensor}, "metadata": {...}})`: plain CPU tensors (network
weights, normaliser statistics, Adam moments, the torch RNG) and a JSON-able metadata dict (format tag,
config, observation/action specs, step counts, numpy RNG state, the replay file's name). It loads with
`torch.load(path, weights_only=True)`. The replay buffer goes to a compressed .npz beside it, written
first under a name carrying the step count, so the checkpoint never points at a missing or newer file.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
import torch
from torch import nn

from auv_mj.agents.ddpg import DDPG, DDPGConfig
from auv_mj.agents.td3 import TD3, TD3Config

FORMAT = "auv-mj-ddpg/1"
"""Format tag in every checkpoint's metadata."""


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> None:
    """Calls write(file) on a temporary file in `path`'s directory, fsyncs it, then os.replace()s it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    try:
        fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


AGENT_CLASSES: dict[str, tuple[type[DDPG], type[DDPGConfig]]] = {
    "ddpg": (DDPG, DDPGConfig), "her-ddpg": (DDPG, DDPGConfig), "executor": (DDPG, DDPGConfig), "td3": (TD3, TD3Config),
}
"""Agent name (`auv-mj train AGENT`) -> the learner and its one config dataclass."""


def agent_classes(agent_name: Any) -> tuple[type[DDPG], type[DDPGConfig]]:
    """(learner class, config class) of `agent_name`; a checkpoint without a name is a DDPG one."""
    if agent_name is None:
        return DDPG, DDPGConfig
    if agent_name not in AGENT_CLASSES:
        raise ValueError(f"unknown agent {_short(agent_name)}; choose one of {tuple(AGENT_CLASSES)}")
    return AGENT_CLASSES[agent_name]


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:40] + "..."


def config_to_dict(config: DDPGConfig) -> dict[str, Any]:
    """The config as a JSON-able dict (tuples become lists)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(config).items()}


def config_from_dict(values: Mapping[str, Any], source: str | Path = "config",
                     config_class: type[DDPGConfig] = DDPGConfig) -> DDPGConfig:
    """A `config_class` (DDPGConfig or TD3Config) from `config_to_dict` output; unknown fields or bad values
    raise ValueError naming `source`."""
    name = config_class.__name__
    if not isinstance(values, Mapping):
        raise ValueError(f"{source}: config must be a dict of {name} fields, got {type(values).__name__}")
    fields = {f.name: f for f in dataclasses.fields(config_class)}
    unknown = [str(k) for k in values if k not in fields]
    if unknown:
        raise ValueError(f"{source}: unknown {name} fields {sorted(unknown)[:10]}")
    kwargs = {}
    for name, value in values.items():
        if isinstance(value, list):
            value = tuple(value)
        elif fields[name].type in ("float", float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)  # JSON writes 1.0 as 1
        kwargs[name] = value
    try:
        return config_class(**kwargs)
    except ValueError as e:
        raise ValueError(f"{source}: {e}") from None


def agent_tensors(agent: DDPG) -> dict[str, torch.Tensor]:
    """Every tensor of the agent's state (modules, optimiser moments, torch RNG) as flat CPU tensors."""
    tensors: dict[str, torch.Tensor] = {}
    for prefix, module in agent.modules().items():
        tensors.update({f"{prefix}.{k}": v.detach().cpu() for k, v in module.state_dict().items()})
    for prefix, opt in agent.optimizers().items():
        for index, state in opt.state_dict()["state"].items():
            for name, value in state.items():
                tensors[f"{prefix}.state.{index}.{name}"] = torch.as_tensor(value).cpu()
    tensors.update({f"obs_norm_pending.{k}": v for k, v in agent.obs_norm.pending_state().items()})
    tensors["torch_rng"] = torch.get_rng_state()
    return tensors


def save_checkpoint(path: str | Path, agent: DDPG, metadata: Mapping[str, Any]) -> None:
    """Atomically writes the agent's tensors with `metadata` (which gets the format tag and config)."""
    meta = {**metadata, "format": FORMAT, "config": config_to_dict(agent.config),
            "obs_dim": agent.obs_dim, "act_dim": agent.act_dim,
            "agent_rng": agent.rng.bit_generator.state, "num_updates": agent.num_updates}
    payload = {"tensors": agent_tensors(agent), "metadata": meta}
    atomic_write(path, lambda f: torch.save(payload, f))


MAX_CHECKPOINT_BYTES = 2**30
"""Largest checkpoint file read (1 GiB; the shipped ones are 2.3 MB)."""
MAX_OBS_DIM, MAX_ACT_DIM = 10_000, 100
"""Largest observation and action sizes a checkpoint may declare."""
SPEC_KINDS = ("goal", "box")


def read_payload(path: str | Path, fmt: str, kind: str) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """(tensors, metadata) of an auv-mj checkpoint file of format `fmt` (a `kind` one: "DDPG", "PPO"), loaded with
    `weights_only=True`; FileNotFoundError, or ValueError naming the file if it is too large, unreadable or of
    another format. The schema of its contents is the caller's to check."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no checkpoint at {path}")
    if path.stat().st_size > MAX_CHECKPOINT_BYTES:
        raise ValueError(f"checkpoint {path} is larger than {MAX_CHECKPOINT_BYTES // 2**20} MiB")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for corrupt or truncated files
        raise ValueError(f"checkpoint {path} is corrupt or truncated, or holds more than plain tensors "
                         f"(torch.load with weights_only=True raised {type(exc).__name__})") from exc
    ok = (isinstance(payload, dict) and isinstance(payload.get("tensors"), dict)
          and isinstance(payload.get("metadata"), dict) and payload["metadata"].get("format") == fmt)
    if not ok:
        raise ValueError(f"checkpoint {path} is not an auv-mj {kind} checkpoint (format {fmt!r} expected)")
    return payload["tensors"], payload["metadata"]


def read_checkpoint(path: str | Path) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """(tensors, metadata) of a checkpoint, checked against the schema (`check_checkpoint`) before any
    network is built; ValueError naming the file if it is unreadable, foreign or inconsistent."""
    tensors, meta = read_payload(path, FORMAT, "DDPG")
    check_checkpoint(tensors, meta, Path(path))
    return tensors, meta


def _whole(value: Any, low: int, high: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and low <= value <= high


def _finite_numbers(value: Any, count: int) -> bool:
    return (isinstance(value, list) and len(value) == count
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value))


def expected_shapes(obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...],
                    twin: bool = False) -> dict[str, tuple[int, ...]]:
    """Tensor name -> shape of the networks and normaliser of an agent of these sizes (`auv_mj.agents.networks`);
    `twin` adds TD3's second critic."""
    shapes: dict[str, tuple[int, ...]] = {"obs_norm.count": ()}
    shapes.update({f"obs_norm.{k}": (obs_dim,) for k in ("sum", "sumsq", "mean", "std")})
    nets = [("actor", obs_dim, act_dim), ("critic", obs_dim + act_dim, 1)]
    if twin:
        nets.append(("critic2", obs_dim + act_dim, 1))
    for prefix, inputs, outputs in nets:
        widths = [inputs, *hidden_sizes, outputs]
        for layer, (n_in, n_out) in enumerate(zip(widths[:-1], widths[1:], strict=True)):
            for net in (prefix, f"{prefix}_target"):
                shapes[f"{net}.net.{2 * layer}.weight"] = (n_out, n_in)
                shapes[f"{net}.net.{2 * layer}.bias"] = (n_out,)
    return shapes


def check_checkpoint(tensors: Mapping[str, Any], meta: Mapping[str, Any], path: str | Path) -> None:
    """The checkpoint schema, checked before any network is allocated; ValueError naming the file and field.

    The metadata must hold a valid `config` (no unknown field), `obs_dim` and `act_dim` within MAX_OBS_DIM
    and MAX_ACT_DIM, a `spec` that agrees with them (finite action bounds, low < high), and the tensors
    must be finite and have exactly the shapes those sizes give: an allocation never exceeds the file.
    """
    where = f"checkpoint {path}"
    if "config" not in meta:
        raise ValueError(f"{where}: its metadata has no 'config'")
    try:
        learner, config_class = agent_classes(meta.get("agent"))
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
    config = config_from_dict(meta["config"], f"{where}: config", config_class)
    obs_dim, act_dim = meta.get("obs_dim"), meta.get("act_dim")
    if not _whole(obs_dim, 1, MAX_OBS_DIM):
        raise ValueError(f"{where}: obs_dim must be a whole number in [1, {MAX_OBS_DIM}], got {obs_dim!r:.60}")
    if not _whole(act_dim, 1, MAX_ACT_DIM):
        raise ValueError(f"{where}: act_dim must be a whole number in [1, {MAX_ACT_DIM}], got {act_dim!r:.60}")
    spec = meta.get("spec")
    if not isinstance(spec, Mapping):
        raise ValueError(f"{where}: its metadata has no 'spec' dict")
    shape = spec.get("obs_shape")
    low, high = spec.get("action_low"), spec.get("action_high")
    problems = []
    if spec.get("obs_dim") != obs_dim or spec.get("act_dim") != act_dim:
        problems.append(f"spec obs_dim/act_dim {spec.get('obs_dim')!r:.30}/{spec.get('act_dim')!r:.30} differ "
                        f"from obs_dim/act_dim {obs_dim}/{act_dim}")
    if spec.get("kind") not in SPEC_KINDS:
        problems.append(f"spec kind must be one of {SPEC_KINDS}, got {spec.get('kind')!r:.30}")
    if not (isinstance(shape, list) and 1 <= len(shape) <= 8 and all(_whole(n, 1, MAX_OBS_DIM) for n in shape)
            and int(np.prod(shape)) == obs_dim):
        problems.append(f"spec obs_shape must be a list of sizes whose product is obs_dim {obs_dim}, "
                        f"got {shape!r:.60}")
    if not (_finite_numbers(low, act_dim) and _finite_numbers(high, act_dim)
            and all(a < b for a, b in zip(low, high, strict=True))):
        problems.append(f"spec action_low/action_high must be {act_dim} finite numbers each, low < high, got "
                        f"{low!r:.40} / {high!r:.40}")
    if spec.get("kind") == "goal":
        parts = (spec.get("observation_dim"), spec.get("goal_dim"))
        goal_input = spec.get("goal_input", True)
        if not isinstance(goal_input, bool):
            problems.append(f"spec goal_input must be true or false, got {goal_input!r:.40}")
        elif not (all(_whole(n, 1, MAX_OBS_DIM) for n in parts) and parts[0] + parts[1] * goal_input == obs_dim):
            problems.append(f"spec observation_dim (+ goal_dim when goal_input) must equal obs_dim {obs_dim}, got "
                            f"{parts!r:.40}")
    if not _whole(meta.get("num_updates", 0), 0, 2**62):
        problems.append(f"num_updates must be a whole number >= 0, got {meta.get('num_updates')!r:.40}")
    replay = meta.get("replay_file")
    if replay is not None and not (isinstance(replay, str) and replay not in ("", ".", "..")
                                   and replay == Path(replay).name):
        problems.append(f"replay_file must be a file name beside the checkpoint, got {replay!r:.60}")
    run_info = meta.get("run_info", {})
    if not (isinstance(run_info, Mapping) and all(isinstance(run_info.get(k, {}), Mapping)
                                                  for k in ("task_kwargs", "env_kwargs"))):
        problems.append(f"run_info must be a dict whose task_kwargs and env_kwargs are dicts, got {run_info!r:.60}")
    counters = meta.get("counters", {})
    if not (isinstance(counters, Mapping) and all(
            isinstance(k, str) and isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < math.inf
            for k, v in counters.items())):
        problems.append(f"counters must be a dict of counts >= 0, got {counters!r:.60}")
    if problems:
        raise ValueError(f"{where}: {problems[0]}")
    if not all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in tensors.items()):
        raise ValueError(f"{where}: its tensors must be a dict of name -> tensor")
    for name, want in expected_shapes(obs_dim, act_dim, config.hidden_sizes, twin=learner is TD3).items():
        if name.startswith(("critic", "actor_target")) and name not in tensors:
            continue  # a policy-only file needs the actor and the normaliser
        got = tuple(tensors[name].shape) if name in tensors else None
        if got != want:
            raise ValueError(f"{where} does not fit the architecture its metadata describes: tensor {name} has "
                             f"shape {got}, obs_dim {obs_dim}, act_dim {act_dim} and hidden_sizes "
                             f"{list(config.hidden_sizes)} need {want}")
    pending = {f"obs_norm_pending.{k}": shape for k, shape in (("count", ()), ("sum", (obs_dim,)),
                                                                 ("sumsq", (obs_dim,)))}
    if 0 < sum(name in tensors for name in pending) < len(pending):
        raise ValueError(f"{where}: it holds some but not all of the tensors {sorted(pending)}")
    for name, want in pending.items():
        if name in tensors and tuple(tensors[name].shape) != want:
            raise ValueError(f"{where}: tensor {name} has shape {tuple(tensors[name].shape)}, obs_dim {obs_dim} "
                             f"needs {want}")
    for name, value in tensors.items():
        if value.is_floating_point() and not bool(torch.isfinite(value).all()):
            raise ValueError(f"{where}: tensor {name} holds NaN or infinite values: the checkpoint is damaged "
                             "(or its training diverged)")


def load_module(module: nn.Module, tensors: Mapping[str, torch.Tensor], prefix: str, path: Path) -> None:
    """Loads the tensors under `prefix.` into `module`, strictly; ValueError naming the file and the module where
    the checkpoint does not fit the architecture."""
    state = {k[len(prefix) + 1:]: v for k, v in tensors.items() if k.startswith(prefix + ".")}
    try:
        module.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        raise ValueError(f"checkpoint {path} does not fit the architecture of {prefix!r}: "
                         f"{' '.join(str(exc).split())}") from None


def _load_optimizer(opt: torch.optim.Optimizer, tensors: Mapping[str, torch.Tensor], prefix: str,
                    path: Path) -> None:
    state: dict[int, dict[str, torch.Tensor]] = {}
    for key, value in tensors.items():
        if key.startswith(prefix + ".state."):
            index, _, name = key[len(prefix) + 7:].partition(".")
            if not (index.isdigit() and name):
                raise ValueError(f"checkpoint {path}: tensor {key!r:.80} is not an optimiser state entry")
            state.setdefault(int(index), {})[name] = value
    full = opt.state_dict()
    full["state"] = state
    try:
        opt.load_state_dict(full)
    except (RuntimeError, ValueError, KeyError) as exc:
        raise ValueError(f"checkpoint {path}: optimiser state {prefix!r} does not fit: "
                         f"{' '.join(str(exc).split())}") from None


def load_agent(path: str | Path, device: str | None = None, config: DDPGConfig | None = None,
               ) -> tuple[DDPG, dict[str, Any]]:
    """Rebuilds the agent saved at `path` (optionally on another device or with a compatible config).

    Raises ValueError naming the file if it is corrupt, truncated, or of another architecture.
    """
    path = Path(path)
    tensors, meta = read_checkpoint(path)
    learner, config_class = agent_classes(meta.get("agent"))
    saved = config_from_dict(meta["config"], path, config_class)
    config = config or saved
    if device is not None:
        config = dataclasses.replace(config, device=device)
    if config.hidden_sizes != saved.hidden_sizes:
        raise ValueError(f"checkpoint {path} has hidden sizes {saved.hidden_sizes}, "
                         f"config asks for {config.hidden_sizes}")
    if not isinstance(config, config_class):
        raise ValueError(f"checkpoint {path} is a {meta.get('agent')} agent: it needs a {config_class.__name__}, "
                         f"got a {type(config).__name__}")
    agent = learner(int(meta["obs_dim"]), int(meta["act_dim"]), config)
    for prefix, module in agent.modules().items():
        load_module(module, tensors, prefix, path)
    for prefix, opt in agent.optimizers().items():
        _load_optimizer(opt, tensors, prefix, path)
    pending = {k.split(".", 1)[1]: v for k, v in tensors.items() if k.startswith("obs_norm_pending.")}
    if pending:
        agent.obs_norm.load_pending_state(pending)
    try:
        agent.rng.bit_generator.state = _generator_state(meta.get("agent_rng"), agent.rng.bit_generator)
        if "torch_rng" in tensors:
            torch.set_rng_state(tensors["torch_rng"])
    except (KeyError, TypeError, ValueError, RuntimeError, OverflowError) as exc:
        raise ValueError(f"checkpoint {path}: its random generator states (agent_rng, torch_rng) are not "
                         f"restorable: {' '.join(str(exc).split())}") from None
    agent.num_updates = int(meta.get("num_updates", 0))
    return agent, meta


def _generator_state(state, generator: np.random.BitGenerator) -> dict:
    """`agent_rng` as a state `generator` (PCG64) takes, or ValueError naming what is wrong with it: NumPy's
    setter alone accepts floats, bools, unknown keys and an even PCG64 increment, and restores a generator
    that no run ever had."""
    keys = {"bit_generator", "state", "has_uint32", "uinteger"}
    if not isinstance(state, Mapping) or set(state) != keys:
        raise ValueError(f"agent_rng must be a dict of {sorted(keys)}, got {str(state)[:80]}")
    kind = type(generator).__name__
    if state["bit_generator"] != kind:
        raise ValueError(f"agent_rng.bit_generator must be {kind!r}, got {str(state['bit_generator'])[:40]!r}")
    inner = state["state"]
    if kind == "PCG64" and not (isinstance(inner, Mapping) and set(inner) == {"state", "inc"}
                                and _whole(inner["state"], 0, 2**128 - 1)
                                and _whole(inner["inc"], 0, 2**128 - 1) and inner["inc"] % 2):
        raise ValueError(f"agent_rng.state must be {{'state', 'inc'}}: whole numbers below 2**128, inc odd, "
                         f"got {str(inner)[:80]}")
    if not (_whole(state["has_uint32"], 0, 1) and _whole(state["uinteger"], 0, 2**32 - 1)):
        raise ValueError(f"agent_rng.has_uint32 must be 0 or 1 and uinteger a whole number below 2**32, got "
                         f"{str(state['has_uint32'])[:20]} and {str(state['uinteger'])[:20]}")
    return dict(state)


def save_replay(path: str | Path, state: Mapping[str, np.ndarray]) -> None:
    """Atomically writes a replay buffer's `state_dict()` as a compressed .npz."""
    atomic_write(path, lambda f: np.savez_compressed(f, **state))


def read_replay(path: str | Path) -> dict[str, np.ndarray]:
    """The arrays of a replay .npz; ValueError naming the file if it is missing or corrupt."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"replay file {path} referenced by the checkpoint is missing")
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except Exception as exc:  # zipfile / numpy raise many types for damaged archives
        raise ValueError(f"replay file {path} is corrupt or truncated: {type(exc).__name__}: {exc}") from exc
