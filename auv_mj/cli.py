"""The `auv-mj` command line: one subcommand per job, each implemented in the module that owns it.

Every subcommand module exposes `add_arguments(parser)` and `run(args) -> int`; they are imported
only when their subcommand runs, so `auv-mj --help` stays fast and light.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

# (subcommand, module, one-line help)
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("demo", "agents.demo", "the two-layer planner+executor through the tunnel: table, video, plot"),
    ("manoeuvre", "auv_mj.manoeuvre", "a scripted zig-zag manoeuvre: prints the track and the sonar"),
    ("bench", "auv_mj.bench", "measure physics, sonar and task speed as ratios against their limits"),
    ("tunnel", "auv_mj.tunnels", "build a tunnel arena MJCF from a centreline CSV/JSON"),
    ("check-arena", "auv_mj.arena_check", "check an arena MJCF and write a top-down PNG preview"),
    ("train", "agents.train", "train an agent (ddpg, her-ddpg, executor) on a task"),
    ("eval", "agents.evaluate", "suite-style evaluation of a policy on tasks"),
    ("render", "auv_mj.render", "render an episode to MP4/GIF off-screen"),
    ("plot", "auv_mj.plots", "trajectory, tracking-error and learning-curve plots (PNG)"),
    ("reproduce", "agents.reproduce", "regenerate the reproduction report against the paper's numbers"),
)


def json_object(text: str) -> dict:
    """argparse type of the `--task-kwargs JSON` options: a JSON object, or a usage error naming the text."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"not valid JSON ({e}): {text!r}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object like '{{\"key\": 1}}', got {text!r}")
    return value


def progress_bar(**kwargs):
    """A tqdm bar on stderr; off a terminal (CI logs, pipes) it redraws every 10 s, not every 0.1 s,
    since there each redraw is a new write."""
    from tqdm import tqdm

    return tqdm(file=sys.stderr, mininterval=0.1 if sys.stderr.isatty() else 10.0, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser; subcommand arguments are added lazily in `main`."""
    parser = argparse.ArgumentParser(
        prog="auv-mj",
        description="MuJoCo simulator of an underactuated planar AUV with learned planning and control.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, _, help_text in COMMANDS:
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `auv-mj` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0].startswith("-"):
        parser.parse_args(argv)
        parser.print_help()
        return 0 if argv else 2
    modules = {name: (module, help_text) for name, module, help_text in COMMANDS}
    if argv[0] not in modules:
        parser.parse_args(argv)  # prints argparse's "invalid choice" error and exits 2
    module_name, help_text = modules[argv[0]]
    module = importlib.import_module(module_name)
    sub = argparse.ArgumentParser(prog=f"auv-mj {argv[0]}", description=help_text)
    module.add_arguments(sub)
    args = sub.parse_args(argv[1:])
    return int(module.run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
