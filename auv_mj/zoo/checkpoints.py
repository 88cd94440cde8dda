"""The shipped checkpoints of the zoo's learned policies, found by policy name (`shipped_checkpoint`), and the file
a name or a path stands for (`checkpoint_path`). Names are the registry's (`auv_mj.zoo.spec.POLICIES`)."""

from __future__ import annotations

from pathlib import Path

from auv_mj.zoo.spec import POLICIES


def _checkpoint_dir() -> Path:
    """The shipped checkpoints' folder: `checkpoints/` of the `auv_mj.agents` package (agents/ in a checkout)."""
    import auv_mj.agents

    return Path(auv_mj.agents.__file__).resolve().parent / "checkpoints"


def shipped_checkpoint(name: str, task: str | None = None) -> Path:
    """Path of policy `name`'s shipped checkpoint (on `task`), with a clear error when it is missing."""
    spec = POLICIES[name]
    file = spec.checkpoint_on.get(task, spec.checkpoint) if task is not None else spec.checkpoint
    if file is None:
        raise ValueError(f"policy {name!r} has no checkpoint")
    path = _checkpoint_dir() / file
    if not path.is_file():
        raise FileNotFoundError(f"the shipped {name} checkpoint {path} is missing; train one with "
                                f"`auv-mj train` (see docs/training.md) or pass a checkpoint path")
    return path


def checkpoint_path(name: str | Path, task: str | None = None) -> Path:
    """The checkpoint file that `name` stands for: a registered learned policy's shipped checkpoint (its own on
    `task` where it has one per task, e.g. `planner` on `tunnel`), or an existing checkpoint path as it is. What
    `auv-mj train --init NAME` starts from, so that a shipped network is fine-tuned by its name.
    ValueError naming the learned policies for anything else."""
    text = str(name)
    if text in POLICIES and POLICIES[text].checkpoint is not None:
        return shipped_checkpoint(text, task)
    if Path(text).is_file():
        return Path(text)
    learned = [n for n, s in POLICIES.items() if s.checkpoint is not None]
    what = "has no checkpoint (a classical policy)" if text in POLICIES else "is not a checkpoint file"
    raise ValueError(f"{text!r} {what}; give a checkpoint path or a learned policy: {', '.join(learned)}")


