"""Every checkpoint auv-mj writes, in one format: atomic, weights-only, tagged with its kind; and the one loader.

A checkpoint is `torch.save({"tensors": {name: Tensor}, "metadata": {...}})`: plain CPU tensors (weights,
normaliser statistics, Adam moments, random generator states) and a JSON-able metadata dict. The metadata names
the checkpoint's `kind`, the agent that wrote it (KINDS: "ddpg", "her-ddpg", "executor", "td3" of
`auv_mj.agents.offpolicy`, "ppo" of `auv_mj.agents.ppo`, "dagger" of `auv_mj.agents.imitation`: a student's network,
Adam and the aggregated dataset, in the PPO layout), and its `format`, the tensor layout of that kind's stack
(`KINDS[kind]`). Files are written atomically (`atomic_write`) and read with `torch.load(path, weights_only=True)`.

`read_checkpoint(path)` is the one loader: it returns what the file is (`Checkpoint`: its tensors, its metadata
and `.kind`), checked against its kind's schema before any network is built. The stacks build their agents and
policies from it (`auv_mj.agents.offpolicy.learners.load_agent`, `auv_mj.agents.offpolicy.Policy.load`,
`auv_mj.agents.ppo.PPOPolicy.load`), each reading `metadata["config"]` into its own config class; the policy zoo
dispatches on the kind. Files written before the kind tag (the shipped ones in `agents/checkpoints/`) load
unchanged: their kind follows from their format marker, and from the `agent` field of an off-policy one.

An off-policy run's replay buffer goes to a compressed .npz beside its checkpoint (`save_replay`), written first
under a name carrying the step count, so the checkpoint never points at a missing or newer file.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np
import torch
from torch import nn

from auv_mj.inputs import shown

OFFPOLICY_FORMAT = "auv-mj-ddpg/1"
"""Format marker of the off-policy checkpoints (DDPG, HER-DDPG, the executor, TD3: `auv_mj.agents.offpolicy`)."""
PPO_FORMAT = "auv-mj-ppo/1"
"""Format marker of the PPO checkpoints (`auv_mj.agents.ppo`)."""
KINDS: dict[str, str] = {"ddpg": OFFPOLICY_FORMAT, "her-ddpg": OFFPOLICY_FORMAT, "executor": OFFPOLICY_FORMAT,
                         "td3": OFFPOLICY_FORMAT, "ppo": PPO_FORMAT, "dagger": PPO_FORMAT}
"""Kind tag (the agent that wrote the checkpoint, as `auv-mj train AGENT` names it) -> the format of its tensors."""
MAX_CHECKPOINT_BYTES = 2**30
"""Largest checkpoint file read (1 GiB; the shipped ones are at most 3.5 MB)."""
MAX_OBS_DIM, MAX_ACT_DIM = 10_000, 100
"""Largest observation and action sizes an off-policy checkpoint may declare."""
MAX_HIDDEN_LAYERS, MAX_HIDDEN_WIDTH = 8, 8192
"""Deepest and widest hidden layers an off-policy config (and so its checkpoint) may ask for."""
SPEC_KINDS = ("goal", "box")


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


class Checkpoint(NamedTuple):
    """What a checkpoint file is: its tensors and metadata (unpacks as `tensors, metadata`), and its kind."""

    tensors: dict[str, torch.Tensor]
    metadata: dict[str, Any]
    """The file's metadata; "kind" is set, for files written before the tag too."""

    @property
    def kind(self) -> str:
        """The agent that wrote it, one of KINDS."""
        return self.metadata["kind"]


def save_checkpoint(path: str | Path, kind: str, tensors: Mapping[str, torch.Tensor],
                    metadata: Mapping[str, Any]) -> None:
    """Atomically writes `tensors` with `metadata`, tagged with `kind` and its format."""
    if kind not in KINDS:
        raise ValueError(f"unknown checkpoint kind {shown(kind)}; one of {tuple(KINDS)}")
    payload = {"tensors": dict(tensors), "metadata": {**metadata, "kind": kind, "format": KINDS[kind]}}
    atomic_write(path, lambda f: torch.save(payload, f))


def read_checkpoint(path: str | Path, kinds: str | tuple[str, ...] | None = None) -> Checkpoint:
    """The checkpoint at `path`, checked against its kind's schema before any network is built (`check_offpolicy`,
    `check_ppo`); `kinds`, if given, the kind or kinds the caller takes. FileNotFoundError, or ValueError naming
    the file if it is too large, unreadable, foreign, of another kind or inconsistent."""
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
    if not (isinstance(payload, dict) and isinstance(payload.get("tensors"), dict)
            and isinstance(payload.get("metadata"), dict)):
        raise ValueError(f"checkpoint {path} is not an auv-mj checkpoint (a dict of 'tensors' and 'metadata')")
    tensors, meta = payload["tensors"], payload["metadata"]
    kind = checkpoint_kind(meta, path)
    wanted = (kinds,) if isinstance(kinds, str) else kinds
    if wanted is not None and kind not in wanted:
        raise ValueError(f"checkpoint {path} is a {kind} checkpoint, not {' or '.join(wanted)}")
    if KINDS[kind] == PPO_FORMAT:
        check_ppo(tensors, meta, path)
    else:
        check_offpolicy(tensors, meta, path, kind)
    return Checkpoint(tensors, {**meta, "kind": kind})


def checkpoint_kind(meta: Mapping[str, Any], path: str | Path) -> str:
    """The kind of a checkpoint's metadata: its "kind" tag, or for a file written before the tag, its format marker
    (and an off-policy one's `agent` field, none meaning DDPG); ValueError naming the file if it is foreign."""
    fmt, agent = meta.get("format"), meta.get("agent")
    if fmt not in KINDS.values():
        raise ValueError(f"checkpoint {path} is not an auv-mj checkpoint (format {shown(fmt)}, one of "
                         f"{sorted(set(KINDS.values()))} expected)")
    if "kind" in meta:
        kind = meta["kind"]
    elif fmt == PPO_FORMAT:
        kind = "ppo"
    else:
        kind = "ddpg" if agent is None else agent
    if not isinstance(kind, str) or kind not in KINDS or KINDS[kind] != fmt:
        raise ValueError(f"checkpoint {path}: kind {shown(kind)} is not one of the {fmt} kinds "
                         f"{[k for k, f in KINDS.items() if f == fmt]}")
    if agent is not None and agent != kind:
        raise ValueError(f"checkpoint {path}: its agent {shown(agent)} and its kind {kind!r} differ")
    return kind


def check_hidden_sizes(sizes: Any, source: str) -> tuple[int, ...]:
    """`sizes` as a tuple of 1 to MAX_HIDDEN_LAYERS widths in [1, MAX_HIDDEN_WIDTH]; ValueError naming `source`
    otherwise."""
    if not (isinstance(sizes, (list, tuple)) and 1 <= len(sizes) <= MAX_HIDDEN_LAYERS
            and all(isinstance(w, (int, np.integer)) and not isinstance(w, bool) and 1 <= w <= MAX_HIDDEN_WIDTH
                    for w in sizes)):
        raise ValueError(f"{source}.hidden_sizes must be 1 to {MAX_HIDDEN_LAYERS} whole numbers in "
                         f"[1, {MAX_HIDDEN_WIDTH}], got {shown(sizes)}")
    return tuple(int(w) for w in sizes)


def config_to_dict(config: Any) -> dict[str, Any]:
    """A config dataclass as a JSON-able dict (tuples become lists)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(config).items()}


def config_from_dict(values: Any, source: str | Path, config_class: type) -> Any:
    """A `config_class` (a frozen config dataclass: DDPGConfig, TD3Config, PPOConfig) from `config_to_dict`
    output; unknown fields or bad values raise ValueError naming `source`."""
    name = config_class.__name__
    if not isinstance(values, Mapping):
        raise ValueError(f"{source}: config must be a dict of {name} fields, got {type(values).__name__}")
    fields = {f.name: f for f in dataclasses.fields(config_class)}
    unknown = [str(k) for k in values if k not in fields]
    if unknown:
        raise ValueError(f"{source}: unknown {name} fields {sorted(unknown)[:10]}")
    kwargs = {}
    for key, value in values.items():
        if isinstance(value, list):
            value = tuple(value)
        elif fields[key].type in ("float", float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)  # JSON writes 1.0 as 1
        kwargs[key] = value
    try:
        return config_class(**kwargs)
    except ValueError as e:
        raise ValueError(f"{source}: {e}") from None


def saved_config(checkpoint: Checkpoint, path: str | Path, config_class: type) -> Any:
    """The checkpoint's `config` as a `config_class`; ValueError naming the file if it does not fit."""
    return config_from_dict(checkpoint.metadata.get("config"), f"checkpoint {path}: config", config_class)


def check_ppo(tensors: Mapping[str, Any], meta: Mapping[str, Any], path: str | Path) -> None:
    """The schema of a PPO checkpoint (`auv_mj.agents.ppo`): a `spec` with plausible sizes and finite tensors
    (the stack reads `config` into its PPOConfig and checks the tensors against it); ValueError naming the file."""
    spec = meta.get("spec")
    if not (isinstance(spec, Mapping) and isinstance(spec.get("obs_dim"), int) and isinstance(spec.get("act_dim"), int)
            and 1 <= spec["obs_dim"] <= 10**6 and 1 <= spec["act_dim"] <= 10**4):
        raise ValueError(f"checkpoint {path}: its metadata has no valid 'spec' (obs_dim, act_dim)")
    for name, value in tensors.items():
        if not isinstance(value, torch.Tensor):
            raise ValueError(f"checkpoint {path}: entry {shown(name)} is not a tensor")
        if value.is_floating_point() and not bool(torch.isfinite(value).all()):
            raise ValueError(f"checkpoint {path}: tensor {name} holds NaN or infinite values")


def is_whole(value: Any, low: int, high: int) -> bool:
    """Whether `value` is an int (not a bool) in [low, high]."""
    return isinstance(value, int) and not isinstance(value, bool) and low <= value <= high


def _finite_numbers(value: Any, count: int) -> bool:
    return (isinstance(value, list) and len(value) == count
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value))


def expected_shapes(obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...],
                    twin: bool = False) -> dict[str, tuple[int, ...]]:
    """Tensor name -> shape of the networks and normaliser of an off-policy agent of these sizes
    (`auv_mj.agents.offpolicy.networks`); `twin` adds TD3's second critic."""
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


def check_offpolicy(tensors: Mapping[str, Any], meta: Mapping[str, Any], path: str | Path, kind: str) -> None:
    """The schema of an off-policy checkpoint (`auv_mj.agents.offpolicy`), checked before any network is allocated;
    ValueError naming the file and field.

    The metadata must hold a `config` whose hidden sizes are within MAX_HIDDEN_LAYERS and MAX_HIDDEN_WIDTH (the
    stack reads the rest of it into its config class), `obs_dim` and `act_dim` within MAX_OBS_DIM and MAX_ACT_DIM,
    a `spec` that agrees with them (finite action bounds, low < high), and the tensors must be finite and have
    exactly the shapes those sizes give (with TD3's second critic for kind "td3"): an allocation never exceeds the
    file.
    """
    where = f"checkpoint {path}"
    if "config" not in meta:
        raise ValueError(f"{where}: its metadata has no 'config'")
    config = meta["config"]
    if not isinstance(config, Mapping):
        raise ValueError(f"{where}: config must be a dict of config fields, got {type(config).__name__}")
    hidden_sizes = check_hidden_sizes(config.get("hidden_sizes"), f"{where}: config")
    obs_dim, act_dim = meta.get("obs_dim"), meta.get("act_dim")
    if not is_whole(obs_dim, 1, MAX_OBS_DIM):
        raise ValueError(f"{where}: obs_dim must be a whole number in [1, {MAX_OBS_DIM}], got {obs_dim!r:.60}")
    if not is_whole(act_dim, 1, MAX_ACT_DIM):
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
    if not (isinstance(shape, list) and 1 <= len(shape) <= 8 and all(is_whole(n, 1, MAX_OBS_DIM) for n in shape)
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
        elif not (all(is_whole(n, 1, MAX_OBS_DIM) for n in parts) and parts[0] + parts[1] * goal_input == obs_dim):
            problems.append(f"spec observation_dim (+ goal_dim when goal_input) must equal obs_dim {obs_dim}, got "
                            f"{parts!r:.40}")
    if not is_whole(meta.get("num_updates", 0), 0, 2**62):
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
    for name, want in expected_shapes(obs_dim, act_dim, hidden_sizes, twin=kind == "td3").items():
        if name.startswith(("critic", "actor_target")) and name not in tensors:
            continue  # a policy-only file needs the actor and the normaliser
        got = tuple(tensors[name].shape) if name in tensors else None
        if got != want:
            raise ValueError(f"{where} does not fit the architecture its metadata describes: tensor {name} has "
                             f"shape {got}, obs_dim {obs_dim}, act_dim {act_dim} and hidden_sizes "
                             f"{list(hidden_sizes)} need {want}")
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


def module_tensors(module: nn.Module, prefix: str) -> dict[str, torch.Tensor]:
    """The module's state dict as CPU tensors named `prefix.NAME`."""
    return {f"{prefix}.{k}": v.detach().cpu().clone() for k, v in module.state_dict().items()}


def optimizer_tensors(optimizer: torch.optim.Optimizer, prefix: str) -> dict[str, torch.Tensor]:
    """The optimiser's per-parameter state (Adam's step and moments) as CPU tensors named `prefix.INDEX.NAME`."""
    return {f"{prefix}.{index}.{name}": torch.as_tensor(value).detach().cpu().clone()
            for index, state in optimizer.state_dict()["state"].items() for name, value in state.items()}


def load_optimizer(optimizer: torch.optim.Optimizer, tensors: Mapping[str, torch.Tensor], prefix: str,
                   path: str | Path) -> None:
    """Restores what `optimizer_tensors(optimizer, prefix)` saved; ValueError naming the file where it does not
    fit the optimiser."""
    state: dict[int, dict[str, torch.Tensor]] = {}
    for key, value in tensors.items():
        if key.startswith(prefix + "."):
            index, _, name = key[len(prefix) + 1:].partition(".")
            if not (index.isdigit() and name):
                raise ValueError(f"checkpoint {path}: tensor {shown(key, 80)} is not an optimiser state entry")
            state.setdefault(int(index), {})[name] = value
    full = optimizer.state_dict()
    full["state"] = state
    try:
        optimizer.load_state_dict(full)
    except (RuntimeError, ValueError, KeyError) as exc:
        raise ValueError(f"checkpoint {path}: optimiser state {prefix!r} does not fit: "
                         f"{' '.join(str(exc).split())}") from None


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
