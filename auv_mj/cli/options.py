"""Options shared by the `auv-mj` commands, and the refusals every command makes before it starts work.

Every command that runs episodes (train, eval, render, plot trajectory/tracking, demo) takes the same
options through `add_episode_options`: `--task`, `--task-kwargs JSON`, `--arena PATH` (a shortcut for the
task's `arena` option), `--seed` and, where it applies, `--policy`. A refusal is a usage error: exit
status 2 and one line on stderr naming the option, never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from auv_mj.inputs import MAX_JSON_DEPTH, json_depth, shown

MAX_JSON_CHARS = 100_000
"""Longest `--task-kwargs` text accepted."""


SEED_RANGE = (0, 2**31 - 1)
"""Seeds `--seed` takes; episode i of a run uses seed + i, which stays below NumPy's 2**32 limit."""


def json_object(text: str) -> dict:
    """argparse type of the `--task-kwargs JSON` options: a JSON object, or a usage error naming the text."""
    if len(text) > MAX_JSON_CHARS:
        raise argparse.ArgumentTypeError(f"longer than {MAX_JSON_CHARS} characters ({len(text)})")
    if json_depth(text) > MAX_JSON_DEPTH:
        raise argparse.ArgumentTypeError(f"nested deeper than {MAX_JSON_DEPTH} levels")
    try:
        value = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as e:
        raise argparse.ArgumentTypeError(f"not valid JSON ({e}): {shown(text)}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object like '{{\"key\": 1}}', got {shown(text)}")
    return value


def positive_int(text: str) -> int:
    """argparse type of counts (--steps, --episodes, --max-steps): an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {shown(text)}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def bounded_int(low: int, high: int) -> Callable[[str], int]:
    """argparse type of a whole number in [low, high]; argparse names the option in its error."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be a whole number in [{low}, {high}], got {shown(text)}")
        return value

    return parse


def bounded_float(low: float, high: float, unit: str = "", *, low_open: bool = False) -> Callable[[str], float]:
    """argparse type of a finite number in [low, high] (`low_open`: in (low, high]) with its unit."""
    interval = f"{'(' if low_open else '['}{low:g}, {high:g}]{' ' + unit if unit else ''}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        inside = (low < value if low_open else low <= value) and value <= high
        if not inside:  # NaN fails both comparisons
            raise argparse.ArgumentTypeError(f"must be a number in {interval}, got {shown(text)}")
        return value

    return parse


seed_int = bounded_int(*SEED_RANGE)
"""argparse type of `--seed`."""
MAX_PROCESSES = 256
"""Most worker or collector processes a command starts."""
MAX_RETRIES = 100
"""Most reruns of a failed episode or trial."""
MAX_PIXELS = 4096
"""Largest image or video side [pixels] a command draws."""
pixels = bounded_int(16, MAX_PIXELS)
"""argparse type of --width / --height of images and videos."""
MAX_FPS = 240.0
"""Highest video frame rate [frames/s]."""
fps = bounded_float(0.0, MAX_FPS, "frames/s", low_open=True)
"""argparse type of --fps."""


def add_episode_options(parser: argparse.ArgumentParser, *, task: str | None = "goal",
                        task_help: str = "suite task name",
                        policy: str | None = "splane", policy_required: bool = False, with_policy: bool = True,
                        seed_help: str = "task and policy seed", task_required: bool | None = None) -> None:
    """--task, --task-kwargs, --arena, --seed and (with_policy) --policy, the same on every command. --task is
    required where it has no default, unless `task_required` is False (a command that can read its episodes)."""
    from auv_mj.zoo.registry import tasks_text  # the suite's names by domain (imported only by episode commands)

    required = task is None if task_required is None else task_required
    parser.add_argument("--task", default=task, required=required, help=f"{task_help}; {tasks_text()}")
    parser.add_argument("--task-kwargs", type=json_object, default=None, metavar="JSON",
                        help="task options as a JSON object, e.g. '{\"reward\": \"paper\"}'")
    parser.add_argument("--arena", default=None, metavar="PATH",
                        help="arena MJCF for the task (shortcut for --task-kwargs '{\"arena\": PATH}'); "
                             "`random` draws a fresh arena per episode where the task can")
    parser.add_argument("--seed", type=seed_int, default=0, help=seed_help)
    if with_policy:
        from auv_mj.zoo.registry import policy_help  # the registry's names (imported only by episode commands)

        parser.add_argument("--policy", default=policy, required=policy_required, help=policy_help())


def task_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The task options of `args`: --task-kwargs, with --arena as its `arena` entry."""
    kwargs = dict(args.task_kwargs or {})
    arena = getattr(args, "arena", None)
    if arena is not None:
        if "arena" in kwargs and kwargs["arena"] != arena:
            usage_error(args, f"--arena {arena!r} and --task-kwargs arena {kwargs['arena']!r} disagree")
        kwargs["arena"] = arena
    return kwargs


def check_ray(args: argparse.Namespace) -> None:
    """Refuses (exit 2) `--workers` beside a Ray cluster (its CPUs are its own) and `--ray` where Ray is not
    installed, before any work: the one check of every command that takes `--ray` and `--workers`."""
    from auv_mj.jobs import distributed

    if args.ray not in (None, distributed.LOCAL) and args.workers > 1:
        usage_error(args, "--workers sets the CPUs of --ray local only; a cluster's CPUs are its own")
    if args.ray is not None:
        try:
            distributed.require_ray()
        except ImportError as e:
            usage_error(args, f"--ray: {e}")


def usage_error(args: argparse.Namespace | str, message: str) -> NoReturn:
    """Prints `auv-mj COMMAND: error: message` on stderr and exits 2, as argparse does."""
    prog = args if isinstance(args, str) else getattr(args, "prog", "auv-mj")
    print(f"{prog}: error: {message}", file=sys.stderr)
    raise SystemExit(2)


FORCE_HELP = "replace output files that exist (without --force an existing file is refused, before any work)"
"""The help of --force, the same on every command that writes files a user names or that are named after theirs."""


OLD_NAMES_UNTIL = "0.3"
"""The release up to which an option's old name (before issue 53 gave each concept one name) is still accepted."""


def add_output_option(parser: argparse.ArgumentParser, help_text: str, *, old: str | None = None,
                      **kwargs: Any) -> argparse.Action:
    """-o/--out, the one name of "where a command writes" (a file, or the folder of a command that writes several);
    `old` is the option's former name, still accepted (and said so in --help) until OLD_NAMES_UNTIL."""
    names = ["-o", "--out", *([old] if old else [])]
    kwargs.setdefault("dest", (old or "--out").lstrip("-").replace("-", "_"))
    if old:
        help_text = f"{help_text} ({old}: its old name, accepted until {OLD_NAMES_UNTIL})"
    return parser.add_argument(*names, help=help_text, **kwargs)


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """--force: the one way to replace an existing output file (`check_output(..., replace=args.force)`)."""
    parser.add_argument("--force", action="store_true", help=FORCE_HELP)


def check_output(args: argparse.Namespace, path: str | Path | None, option: str, *,
                 replace: bool | None = None, may_replace: Callable[[Path], bool] | None = None) -> Path | None:
    """Refuses (exit 2) an output file that cannot be written, before any work is done.

    With `replace` False (a command with --force, run without it) an existing file is refused too, naming --force:
    nothing a user wrote is overwritten unasked. `may_replace(path)` says which existing files are the command's
    own and may be replaced all the same (a preview auv-mj drew). None (commands without --force) keeps the old
    rule: an existing file is replaced.

    The check is done by trying: the missing folders are made and the file opened for writing (appended to,
    so an existing file keeps its content), then whatever was made is removed again. Asking for permissions
    instead (`os.access`) says yes to root on paths no one can create (`/proc/nope/x.json`). A folder in the
    file's place and a regular file where a folder should be are refused by name.
    """
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        usage_error(args, f"{option} {path} is a folder, not a file")
    if replace is False and path.exists() and not (may_replace is not None and may_replace(path)):
        usage_error(args, f"{option} {path} exists: give --force to replace it, or another name")
    _check_parent(args, path, option)
    _try_writing(args, path, option, folder=False)
    return path


def check_output_folder(args: argparse.Namespace, path: str | Path | None, option: str) -> Path | None:
    """Refuses (exit 2) an output folder in which files cannot be written, before any work is done.

    As `check_output`: the folder (and its missing parents) is made, a file written in it and removed, and
    then whatever was made is removed again.
    """
    if path is None:
        return None
    path = Path(path)
    if path.exists() and not path.is_dir():
        usage_error(args, f"{option} {path} is a file, not a folder")
    _check_parent(args, path, option)
    _try_writing(args, path, option, folder=True)
    return path


def _check_parent(args: argparse.Namespace, path: Path, option: str) -> None:
    """Refuses a path whose nearest existing ancestor is not a folder (a file where a folder should be)."""
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        usage_error(args, f"{option} {path}: {parent} is not a folder")


def _try_writing(args: argparse.Namespace, path: Path, option: str, folder: bool) -> None:
    """Makes the missing folders down to `path` (itself too if `folder`), writes a file there (a probe in
    the folder, or the file itself), then removes what it made; an OSError on the way is a usage error."""
    folder_path = path if folder else path.parent
    made = []
    for ancestor in reversed([folder_path, *folder_path.parents]):
        if not ancestor.exists():
            made.append(ancestor)
    probe = folder_path / f".auv-mj-write-test-{os.getpid()}" if folder else path
    existed = probe.exists()
    try:
        folder_path.mkdir(parents=True, exist_ok=True)
        with open(probe, "a"):
            pass
    except OSError as e:
        where = f" ({e.filename})" if e.filename and str(e.filename) != str(path) else ""
        usage_error(args, f"{option} {path} cannot be written: {e.strerror or e}{where}")
    finally:
        with contextlib.suppress(OSError):  # leave the file system as it was; the folders are empty again
            if not existed and probe.exists():
                probe.unlink()
            for made_folder in reversed(made):
                made_folder.rmdir()
