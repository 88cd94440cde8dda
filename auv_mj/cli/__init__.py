"""The `auv-mj` app: one subcommand per job, one module per subcommand in this package.

This package is the top layer (simulator core `auv_mj` < `tasks` < `agents` < `auv_mj.cli`) and the only
place that wires tasks and agents together: the policy-name registry (`policies`), evaluation and the
reproduction report live here. Every subcommand module exposes `add_arguments(parser)` and
`run(args) -> int`; they are imported only when their subcommand runs, so `auv-mj --help` stays fast.
"""

from __future__ import annotations

import argparse
import copy
import importlib
import os
import platform
import select
import sys

from auv_mj.inputs import did_you_mean

# (subcommand, module, one-line help)
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("demo", "auv_mj.cli.demo", "the two-layer planner+executor through the tunnel: table, video, plot"),
    ("manoeuvre", "auv_mj.cli.manoeuvre", "a scripted zig-zag manoeuvre: prints the track and the sonar"),
    ("bench", "auv_mj.cli.bench", "measure physics, sonar and task speed as ratios against their limits"),
    ("tunnel", "auv_mj.cli.tunnel", "build a tunnel arena MJCF from a centreline CSV/JSON"),
    ("arena", "auv_mj.cli.arena", "build an open-water arena MJCF from a JSON/CSV list of shapes"),
    ("check-arena", "auv_mj.cli.check_arena", "check an arena MJCF and write a top-down PNG preview"),
    ("train", "auv_mj.cli.train", "train an agent ({agents}) on a task"),
    ("sweep", "auv_mj.cli.sweep", "training over seeds and hyper-parameters on Ray Tune, with a results table"),
    ("eval", "auv_mj.cli.evaluate", "suite-style evaluation of a policy on tasks"),
    ("benchmark", "auv_mj.cli.benchmark", "the versioned held-out suite (suite v1): results JSON, leaderboard row"),
    ("render", "auv_mj.cli.render", "render an episode to MP4/GIF off-screen"),
    ("plot", "auv_mj.cli.plot", "trajectory, tracking-error and learning-curve plots (PNG)"),
    ("reproduce", "auv_mj.cli.reproduce", "regenerate the reproduction report against the paper's numbers"),
    ("policies", "auv_mj.cli.list_policies", "the registered policies: what each is, where it runs, on what"),
)


BROKEN_PIPE_STATUS = 128 + 13
"""Exit status when the reader of stdout goes away (`auv-mj policies | head`): a process killed by SIGPIPE's."""


TRAIN_AGENTS = ("ddpg", "her-ddpg", "executor", "td3", "ppo")
"""The agents `auv-mj train` takes, as the top-level help names them: the agent registry's names
(`auv_mj.agents.offpolicy.learners.AGENTS`) and PPO, written out because importing that registry imports torch and
doubles the time of `auv-mj --help`; tests/cli/test_names_and_outputs.py keeps the two equal."""


def command_help(text: str) -> str:
    """A subcommand's one-line help with the registry's names filled in."""
    return text.format(agents=", ".join(TRAIN_AGENTS)) if "{agents}" in text else text


def version_text() -> str:
    """`auv-mj --version`: this package's version and the versions a bug report needs."""
    import mujoco

    from auv_mj import __version__

    return f"auv-mj {__version__} (MuJoCo {mujoco.__version__}, Python {platform.python_version()})"


def shows_default(action: argparse.Action) -> bool:
    """Whether `--help` shows the default of `action`: an option that takes a value and has one (not None, not an
    empty list as a repeatable option starts with)."""
    default = action.default
    if default is None or default is argparse.SUPPRESS or action.help is argparse.SUPPRESS:
        return False
    if isinstance(default, list | tuple | dict) and not default:
        return False
    return action.nargs != 0 and (bool(action.option_strings) or action.nargs in ("?", "*"))


class HelpFormatter(argparse.HelpFormatter):
    """argparse's help with each option's default, `(default: VALUE)`, unless its help already says it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if shows_default(action) and "%(default)" not in text and "default" not in text.lower():
            text = f"{text} (default: %(default)s)" if text else "default: %(default)s"
        return text

    def _format_action(self, action: argparse.Action) -> str:
        if not action.help and shows_default(action):  # argparse prints no help line for an option without help
            action = copy.copy(action)
            action.help = self._get_help_string(action)
        return super()._format_action(action)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (`auv-mj COMMAND: error: ...` and exit status 2, no usage block) and help
    that shows every option's default, on every subcommand and sub-subcommand (`add_subparsers` makes them of
    this class)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")

    def _check_value(self, action: argparse.Action, value):
        """argparse's check of `choices`, with the nearest valid choice suggested."""
        if action.choices is not None and value not in action.choices:
            choices = ", ".join(map(repr, action.choices))
            raise argparse.ArgumentError(action, f"invalid choice: {value!r}{did_you_mean(value, action.choices)}; "
                                                 f"choose from {choices}")
        return super()._check_value(action, value)


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser; subcommand arguments are added lazily in `main`."""
    parser = Parser(
        prog="auv-mj",
        description="MuJoCo simulator of underactuated AUVs, the planar vehicle (domain auv) and the 6-DOF vehicle "
                    "(domain auv3d), with classical and learned planning and control.",
    )
    parser.add_argument("--version", action="version", version=version_text())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, _, help_text in COMMANDS:
        sub.add_parser(name, help=command_help(help_text), add_help=False)
    return parser


def command_parser(name: str) -> Parser:
    """The full parser of subcommand `name` (its module imported and its arguments added)."""
    module_name, help_text = next((module, text) for command, module, text in COMMANDS if command == name)
    parser = Parser(prog=f"auv-mj {name}", description=command_help(help_text))
    importlib.import_module(module_name).add_arguments(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `auv-mj` console script: one command, its output cut short quietly when the reader of
    stdout goes away (`auv-mj policies | head`)."""
    try:
        return _main(argv)
    except BrokenPipeError:
        if not _stdout_closed():
            raise  # a pipe or socket of the command's own (a worker's), not stdout: a real error
        return BROKEN_PIPE_STATUS


def _stdout_closed() -> bool:
    """Whether stdout's reader has gone; if so stdout is pointed at /dev/null, so that the interpreter's last
    flush at exit does not fail a second time ("Exception ignored ... BrokenPipeError")."""
    try:
        sys.stdout.flush()  # what the failed write left in the buffer fails again if stdout is the broken pipe
        fd = sys.stdout.fileno()
        closed = bool(_poll_errors(fd))  # an empty buffer: ask the pipe itself
    except BrokenPipeError:
        fd, closed = sys.stdout.fileno(), True
    except (OSError, ValueError):  # no file descriptor (a captured stdout): not a pipe
        return False
    if closed:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, fd)
        os.close(devnull)
    return closed


def _poll_errors(fd: int) -> int:
    """POLLERR on `fd` now (a pipe whose reader has closed), or 0."""
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return sum(events & select.POLLERR for _, events in poller.poll(0))


def _main(argv: list[str] | None) -> int:
    """Parses the command line and runs its subcommand (its module imported only now)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0].startswith("-"):
        parser.parse_args(argv)
        parser.print_help()
        return 0 if argv else 2
    modules = {name: module for name, module, _ in COMMANDS}
    if argv[0] not in modules:
        parser.parse_args(argv)  # prints argparse's "invalid choice" error, with the nearest command, and exits 2
    sub = command_parser(argv[0])
    args = sub.parse_args(argv[1:])
    args.prog = sub.prog
    return int(importlib.import_module(modules[argv[0]]).run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
