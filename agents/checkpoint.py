"""Atomic, weights-only checkpoints of a DDPG agent and its replay buffer.

A checkpoint is `torch.save({"tensors": {name: Tensor}, "metadata": {...}})`: plain CPU tensors (network
weights, normaliser statistics, Adam moments, the torch RNG) and a JSON-able metadata dict (format tag,
config, observation/action specs, step counts, numpy RNG state, the replay file's name). It loads with
`torch.load(path, weights_only=True)`. The replay buffer goes to a compressed .npz beside it, written
first under a name carrying the step count, so the checkpoint never points at a missing or newer file.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
import torch
from torch import nn

from agents.ddpg import DDPG, DDPGConfig

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


def config_to_dict(config: DDPGConfig) -> dict[str, Any]:
    """The config as a JSON-able dict (tuples become lists)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(config).items()}


def config_from_dict(values: Mapping[str, Any], source: str | Path = "config") -> DDPGConfig:
    """A DDPGConfig from `config_to_dict` output; unknown fields raise ValueError naming `source`."""
    fields = {f.name for f in dataclasses.fields(DDPGConfig)}
    unknown = set(values) - fields
    if unknown:
        raise ValueError(f"{source}: unknown DDPGConfig fields {sorted(unknown)}")
    return DDPGConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})


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


def read_checkpoint(path: str | Path) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """(tensors, metadata) of a checkpoint; ValueError naming the file if it is unreadable or foreign."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no checkpoint at {path}")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for corrupt or truncated files
        raise ValueError(f"checkpoint {path} is corrupt or truncated, or holds more than plain tensors "
                         f"(torch.load with weights_only=True raised {type(exc).__name__})") from exc
    ok = (isinstance(payload, dict) and isinstance(payload.get("tensors"), dict)
          and isinstance(payload.get("metadata"), dict) and payload["metadata"].get("format") == FORMAT)
    if not ok:
        raise ValueError(f"checkpoint {path} is not an auv-mj DDPG checkpoint (format {FORMAT!r} expected)")
    return payload["tensors"], payload["metadata"]


def _load_module(module: nn.Module, tensors: Mapping[str, torch.Tensor], prefix: str, path: Path) -> None:
    state = {k[len(prefix) + 1:]: v for k, v in tensors.items() if k.startswith(prefix + ".")}
    try:
        module.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        raise ValueError(f"checkpoint {path} does not fit the architecture of {prefix!r}: {exc}") from exc


def _load_optimizer(opt: torch.optim.Optimizer, tensors: Mapping[str, torch.Tensor], prefix: str,
                    path: Path) -> None:
    state: dict[int, dict[str, torch.Tensor]] = {}
    for key, value in tensors.items():
        if key.startswith(prefix + ".state."):
            index, name = key[len(prefix) + 7:].split(".", 1)
            state.setdefault(int(index), {})[name] = value
    full = opt.state_dict()
    full["state"] = state
    try:
        opt.load_state_dict(full)
    except (RuntimeError, ValueError, KeyError) as exc:
        raise ValueError(f"checkpoint {path}: optimiser state {prefix!r} does not fit: {exc}") from exc


def load_agent(path: str | Path, device: str | None = None, config: DDPGConfig | None = None,
               ) -> tuple[DDPG, dict[str, Any]]:
    """Rebuilds the agent saved at `path` (optionally on another device or with a compatible config).

    Raises ValueError naming the file if it is corrupt, truncated, or of another architecture.
    """
    path = Path(path)
    tensors, meta = read_checkpoint(path)
    saved = config_from_dict(meta["config"], path)
    config = config or saved
    if device is not None:
        config = dataclasses.replace(config, device=device)
    if config.hidden_sizes != saved.hidden_sizes:
        raise ValueError(f"checkpoint {path} has hidden sizes {saved.hidden_sizes}, "
                         f"config asks for {config.hidden_sizes}")
    agent = DDPG(int(meta["obs_dim"]), int(meta["act_dim"]), config)
    for prefix, module in agent.modules().items():
        _load_module(module, tensors, prefix, path)
    for prefix, opt in agent.optimizers().items():
        _load_optimizer(opt, tensors, prefix, path)
    pending = {k.split(".", 1)[1]: v for k, v in tensors.items() if k.startswith("obs_norm_pending.")}
    if pending:
        agent.obs_norm.load_pending_state(pending)
    agent.rng.bit_generator.state = meta["agent_rng"]
    agent.num_updates = int(meta.get("num_updates", 0))
    if "torch_rng" in tensors:
        torch.set_rng_state(tensors["torch_rng"])
    return agent, meta


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
