"""Options shared by the `auv-mj` commands, and the refusals every command makes before it starts work.

Every command that runs episodes (train, eval, render, plot trajectory/tracking, demo) takes the same
options through `add_episode_options`: `--task`, `--task-kwargs JSON`, `--arena PATH` (a shortcut for the
task's `arena` option), `--seed` and, where it applies, `--policy`. A refusal is a usage error: exit
status 2 and one line on stderr naming the option, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any, NoReturn

MAX_JSON_DEPTH = 32
"""Deepest nesting of `--task-kwargs` (objects and arrays) accepted; deeper input is refused, not recursed."""
MAX_JSON_CHARS = 100_000
"""Longest `--task-kwargs` text accepted."""


def _depth(text: str) -> int:
    """Deepest bracket nesting of JSON text outside strings (a scan, so it cannot recurse)."""
    depth = deepest = 0
    in_string = escaped = False
    for char in text:
        if in_string:
            escaped = not escaped and char == "\\"
            if char == '"' and not escaped:
                in_string = False
            continue
        if char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


def json_object(text: str) -> dict:
    """argparse type of the `--task-kwargs JSON` options: a JSON object, or a usage error naming the text."""
    if len(text) > MAX_JSON_CHARS:
        raise argparse.ArgumentTypeError(f"longer than {MAX_JSON_CHARS} characters ({len(text)})")
    if _depth(text) > MAX_JSON_DEPTH:
        raise argparse.ArgumentTypeError(f"nested deeper than {MAX_JSON_DEPTH} levels")
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"not valid JSON ({e}): {text!r}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object like '{{\"key\": 1}}', got {text!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type of counts (--steps, --episodes, --max-steps): an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def add_episode_options(parser: argparse.ArgumentParser, *, task: str | None = "goal",
                        task_help: str = "suite task name (goal, obstacles, tunnel, ...)",
                        policy: str | None = "splane", policy_required: bool = False, with_policy: bool = True,
                        seed_help: str = "task and policy seed") -> None:
    """--task, --task-kwargs, --arena, --seed and (with_policy) --policy, the same on every command."""
    parser.add_argument("--task", default=task, required=task is None, help=task_help)
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON",
                        help="task options as a JSON object, e.g. '{\"reward\": \"paper\"}'")
    parser.add_argument("--arena", default=None, metavar="PATH",
                        help="arena MJCF for the task (shortcut for --task-kwargs '{\"arena\": PATH}'); "
                             "`random` draws a fresh arena per episode where the task can")
    parser.add_argument("--seed", type=int, default=0, help=seed_help)
    if with_policy:
        parser.add_argument("--policy", default=policy, required=policy_required,
                            help="checkpoint path, shipped policy (planner, planner-raw, executor, two-layer, "
                                 "los-executor) or baseline (splane, los-avoid, random)")


def task_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The task options of `args`: --task-kwargs, with --arena as its `arena` entry."""
    kwargs = dict(args.task_kwargs or {})
    arena = getattr(args, "arena", None)
    if arena is not None:
        if "arena" in kwargs and kwargs["arena"] != arena:
            usage_error(args, f"--arena {arena!r} and --task-kwargs arena {kwargs['arena']!r} disagree")
        kwargs["arena"] = arena
    return kwargs


def usage_error(args: argparse.Namespace | str, message: str) -> NoReturn:
    """Prints `auv-mj COMMAND: error: message` on stderr and exits 2, as argparse does."""
    prog = args if isinstance(args, str) else getattr(args, "prog", "auv-mj")
    print(f"{prog}: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def check_output(args: argparse.Namespace, path: str | Path | None, option: str) -> Path | None:
    """Refuses (exit 2) an output file that cannot be written, before any work is done.

    The file's folder must exist or be creatable, and be writable; an existing folder in the file's place
    is refused too. Nothing is created here.
    """
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        usage_error(args, f"{option} {path} is a folder, not a file")
    parent = path.parent
    while not parent.exists():
        if parent == parent.parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        usage_error(args, f"{option} {path}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        usage_error(args, f"{option} {path} cannot be written (no write permission in {parent})")
    return path
