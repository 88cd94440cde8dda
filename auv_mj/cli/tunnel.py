"""`auv-mj tunnel`: build a tunnel arena MJCF from a centreline CSV/JSON (`auv_mj.arenas.tunnels`), or write
the procedural arena of a random episode (`--random SEED`, `auv_mj.arenas.procedural`).

Every option is checked by type and range as it is parsed, the output path before any work, and a built
arena by `auv-mj check-arena`'s own checks before it is written (atomically): a refused spec is a usage
error (exit 2, one line naming the file or option) and leaves no file behind.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from auv_mj.arenas import procedural, traps, tubes, tunnels
from auv_mj.arenas.arena_check import check_arena
from auv_mj.arenas.tunnels import (
    BOUNDS_MARGIN,
    END_CLEARANCE,
    MAX_END_CLEARANCE,
    MAX_MARGIN,
    MAX_MERGE_TOLERANCE,
    MAX_PATH_SPACING,
    MAX_SMOOTH_ITERATIONS,
    MAX_TUNNEL_LENGTH,
    MAX_WALL_THICKNESS,
    MAX_WIDTH,
    MERGE_TOLERANCE,
    MIN_PATH_SPACING,
    PATH_SPACING,
    SMOOTH_ITERATIONS,
    WALL_THICKNESS,
    MovingObstacle,
    Obstacle,
    check_unknown,
    check_unknown_spec,
    layout_tunnel,
    read_centreline,
    save,
    tunnel_element,
)
from auv_mj.cli.options import (
    add_force_option,
    add_output_option,
    bounded_float,
    bounded_int,
    check_output,
    seed_int,
    usage_error,
)
from auv_mj.console import counted
from auv_mj.tasks import obstacles, planning_physics, routes, tunnel

RANDOM_TASKS = ("tunnel", "obstacles", "moving_obstacles")
"""Tasks whose random arenas `--random` writes."""

MAX_MODEL_NAME = 100
"""Longest --name."""


def model_name(text: str) -> str:
    """argparse type of --name: printable text without quotes or angle brackets, at most MAX_MODEL_NAME long."""
    if not (text and len(text) <= MAX_MODEL_NAME and text.isprintable() and not set(text) & set("<>&\"'")):
        raise argparse.ArgumentTypeError(f"must be 1 to {MAX_MODEL_NAME} printable characters without <>&\"', "
                                         f"got {text[:60]!r}")
    return text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj tunnel`."""
    parser.add_argument("centreline", nargs="?", help="CSV of x,y[,width] rows [m] (header optional) or JSON")
    parser.add_argument("--width", type=bounded_float(0.0, MAX_WIDTH, "m", low_open=True),
                        help="constant tunnel width [m] (unless per point; with --random: this width instead of "
                             "a random one)")
    add_output_option(parser, "arena MJCF to write (default: the centreline's name, .xml)", old="--output",
                      metavar="FILE")
    add_force_option(parser)
    parser.add_argument("--smooth", action="store_true", help="round the corners (Chaikin corner cutting)")
    parser.add_argument("--smooth-iterations", type=bounded_int(0, MAX_SMOOTH_ITERATIONS), default=SMOOTH_ITERATIONS,
                        help=f"Chaikin rounds of --smooth (default {SMOOTH_ITERATIONS}, at most "
                             f"{MAX_SMOOTH_ITERATIONS})")
    parser.add_argument("--closed", action="store_true", help="the centreline is a loop: no end caps")
    parser.add_argument("--obstacle", action="append", default=[], metavar="X,Y,LENGTH,WIDTH[,ANGLE[,NAME]]",
                        help="a known box obstacle (angle in deg); repeatable")
    parser.add_argument("--unknown", action="append", default=[], metavar="X,Y,LENGTH,WIDTH[,ANGLE[,NAME]]",
                        help="an unknown box obstacle (unknown_NAME): the path may run through it, but it must "
                             "leave a way past; repeatable")
    parser.add_argument("--mover", action="append", default=[], metavar="X0,Y0,X1,Y1,SPEED,RADIUS[,NAME]",
                        help="a moving cylinder going back and forth (m, m/s); repeatable")
    parser.add_argument("--spacing", type=bounded_float(MIN_PATH_SPACING, MAX_PATH_SPACING, "m"),
                        default=PATH_SPACING, help=f"distance between path sites [m] (default {PATH_SPACING:g})")
    parser.add_argument("--wall-thickness", type=bounded_float(0.0, MAX_WALL_THICKNESS, "m", low_open=True),
                        default=WALL_THICKNESS)
    parser.add_argument("--end-clearance", type=bounded_float(0.0, MAX_END_CLEARANCE, "m"), default=END_CLEARANCE,
                        help=f"tunnel length past start and goal [m] (default {END_CLEARANCE:g})")
    parser.add_argument("--margin", type=bounded_float(0.0, MAX_MARGIN, "m"), default=BOUNDS_MARGIN,
                        help="arena_bounds margin [m]")
    parser.add_argument("--tolerance", type=bounded_float(0.0, MAX_MERGE_TOLERANCE, "m", low_open=True),
                        default=MERGE_TOLERANCE,
                        help=f"wall merging tolerance [m] (default {MERGE_TOLERANCE:g})")
    parser.add_argument("--name", type=model_name, default=None, help="model name (default: the output's stem)")
    parser.add_argument("--tube", action="store_true",
                        help="the centreline has x,y,z columns (z up, below 0), or is a tube JSON: write a 3-D tube "
                             "arena for the 6-DOF vehicle (auv_mj/arenas/tubes.py) of inner diameter --width "
                             f"({2 * tubes.MIN_RADIUS:g} to {2 * tubes.MAX_RADIUS:g} m, default "
                             f"{2 * tubes.TUBE_RADIUS:g} m); --obstacle X,Y,Z,RADIUS[,NAME] places a rock, --mover "
                             "X0,Y0,Z0,X1,Y1,Z1,SPEED,RADIUS[,NAME] a moving sphere")
    group = parser.add_argument_group(
        "procedural arenas", "--random SEED writes the arena of the first episode of `--arena random --seed "
        "SEED` (the same arena as `auv-mj eval` draws), unless an option below changes the distribution")
    group.add_argument("--random", type=seed_int, metavar="SEED", help="a random arena from this seed "
                            "(training, validation and test seed ranges: docs/evaluation.md)")
    group.add_argument("--task", default="tunnel", choices=RANDOM_TASKS,
                            help="whose random arena: a procedural tunnel (default), or the open-water layout of "
                                 "obstacles / moving_obstacles")
    group.add_argument("--length", type=bounded_float(0.0, MAX_TUNNEL_LENGTH, "m", low_open=True),
                            metavar="M", help="tunnel length [m] instead of a random one")
    group.add_argument("--obstacles", type=bounded_int(0, procedural.MAX_COUNT), metavar="N",
                            help="number of unknown obstacles in the tunnel")
    group.add_argument("--movers", type=bounded_int(0, procedural.MAX_COUNT), metavar="N",
                            help="number of movers in the tunnel")
    group.add_argument("--tier", default="standard", choices=traps.TIERS,
                       help="the task's `tier` option: today's distribution (standard, default) or the hard tier of "
                            "certified trap arenas (auv_mj/arenas/traps.py)")


def _command_line() -> str | None:
    """The `auv-mj tunnel ...` command line this process runs, if it runs one."""
    argv = sys.argv[1:]
    return shlex.join(["auv-mj", *argv]) if argv[:1] == ["tunnel"] else None


def _output_option(args: argparse.Namespace) -> str:
    """How a refusal names the output: -o where given, else the name it was given by default."""
    return "-o" if args.output else "the output (-o)"


def run(args: argparse.Namespace) -> int:
    """`auv-mj tunnel`: writes the arena and prints what it holds."""
    if args.random is not None:
        return _run_random(args)
    if args.tube:
        return _run_tube(args)
    if args.centreline is None:
        usage_error(args, "give a centreline file, or --random SEED")
    fixed = [f"--{name}" for name in ("length", "obstacles", "movers") if getattr(args, name) is not None]
    if fixed or args.task != "tunnel":
        usage_error(args, f"{', '.join(fixed) or '--task'} go with --random only")
    try:
        output = Path(args.output) if args.output else Path(args.centreline).with_suffix(".xml")
    except ValueError:
        usage_error(args, f"give the output file with -o: {args.centreline[:60]!r} has no name to derive one from")
    if output.resolve() == Path(args.centreline).resolve():
        usage_error(args, f"-o {output} would overwrite the centreline")
    check_output(args, output, _output_option(args), replace=args.force)
    try:
        line = read_centreline(args.centreline)
        obstacles = [Obstacle.parse(text) for text in args.obstacle]
        movers = [MovingObstacle.parse(text) for text in args.mover]
        unknown = [_unknown(text) for text in args.unknown]
        layout = layout_tunnel(line, args.width, closed=args.closed,
                               smooth=args.smooth_iterations if args.smooth else 0, path_spacing=args.spacing,
                               obstacles=obstacles, movers=movers, wall_thickness=args.wall_thickness,
                               end_clearance=args.end_clearance, margin=args.margin,
                               merge_tolerance=args.tolerance)
        check_unknown_spec(line.source, layout, obstacles, movers, unknown)
        check_unknown(layout, unknown, obstacles, args.wall_thickness, source=line.source)
        element = tunnel_element(layout, obstacles, movers, args.wall_thickness, args.name or output.stem,
                                 _command_line(), unknown)
        report = check_arena(element)
        if not report.ok:
            raise ValueError(f"{args.centreline}: the tunnel would not be a usable arena: {report.problems[0]}"
                             + (f" (and {len(report.problems) - 1} more problems)" if len(report.problems) > 1
                                else ""))
    except ValueError as e:
        usage_error(args, " ".join(str(e).split()))
    try:
        save(element, output)
    except OSError as e:
        print(f"{args.prog}: error: cannot write {output}: {e.strerror or e}", file=sys.stderr)
        return 1
    length = float(np.sum(np.hypot(*np.diff(layout.path, axis=0).T)))
    unknown_text = f"{counted(len(unknown), 'unknown obstacle')}, " if unknown else ""
    print(f"wrote {output}: {counted(len(layout.walls), 'wall box', 'wall boxes')}, "
          f"{counted(len(obstacles), 'obstacle')}, {unknown_text}{counted(len(movers), 'mover')}, "
          f"{counted(len(layout.path), 'path site')} over {length:.0f} m; "
          f"check it with: auv-mj check-arena {output}")
    return 0


def _run_tube(args: argparse.Namespace) -> int:
    """`auv-mj tunnel --tube CENTRELINE`: a 3-D tube along an x, y, z centreline (CSV, or JSON with obstacles and
    movers), `--smooth`ed if asked, with `--obstacle X,Y,Z,RADIUS` rocks and `--mover` spheres, checked before it
    is written."""
    if args.centreline is None:
        usage_error(args, "--tube needs a centreline CSV of x,y,z rows (or a tube JSON)")
    planar = [option for option, value in (("--unknown", args.unknown), ("--closed", args.closed)) if value]
    if planar:
        usage_error(args, f"{', '.join(planar)} are planar tunnel options, not for --tube")
    output = Path(args.output) if args.output else Path(args.centreline).with_suffix(".xml")
    if output.resolve() == Path(args.centreline).resolve():
        usage_error(args, f"-o {output} would overwrite the centreline")
    check_output(args, output, _output_option(args), replace=args.force)
    try:
        spec = tubes.read_tube(args.centreline)
        line = tunnels.chaikin(spec.centreline, args.smooth_iterations) if args.smooth else spec.centreline
        if len(line) > tubes.MAX_POINTS:
            raise ValueError(f"{args.centreline}: --smooth makes {len(line)} centreline points, more than "
                             f"{tubes.MAX_POINTS}: fewer --smooth-iterations")
        width = args.width if args.width else spec.width
        tube = tubes.Tube(line, 0.5 * width if width else tubes.TUBE_RADIUS)
        problems = tubes.check_tube(tube)
        if problems:
            raise ValueError(f"{args.centreline}: the tube would not be a usable arena: {problems[0]}"
                             + (f" (and {len(problems) - 1} more problems)" if len(problems) > 1 else ""))
        obstacles = [*spec.obstacles, *(tubes.TubeObstacle.parse(text) for text in args.obstacle)]
        movers = [*spec.movers, *(tubes.TubeMover.parse(text) for text in args.mover)]
        element = tubes.tube_arena(tube, args.name or output.stem, obstacles=obstacles, movers=movers)
        report = check_arena(element)
        if not report.ok:
            raise ValueError(f"{args.centreline}: the tube would not be a usable arena: {report.problems[0]}")
    except ValueError as e:
        usage_error(args, " ".join(str(e).split()))
    try:
        save(element, output)
    except OSError as e:
        print(f"{args.prog}: error: cannot write {output}: {e.strerror or e}", file=sys.stderr)
        return 1
    print(f"wrote {output}: a tube of {tube.length():.0f} m, inner radius {tube.radius:g} m, "
          f"{tube.staves * (len(line) - 1)} staves ({tube.staves} round, {tube.stave_radius:g} m thick), "
          f"{counted(len(obstacles), 'obstacle')}, {counted(len(movers), 'mover')}; check it with: "
          f"auv-mj check-arena {output}")
    return 0


def _unknown(text: str) -> Obstacle:
    """An `--unknown` obstacle (the `--obstacle` form)."""
    try:
        return Obstacle.parse(text)
    except ValueError as e:
        raise ValueError(str(e).replace("--obstacle", "--unknown", 1)) from None


def _spec(args: argparse.Namespace) -> procedural.TunnelSpec:
    """The tunnel task's distribution with the options that fix a width, length or count."""
    changes = {name: getattr(args, name) for name in ("width", "length", "obstacles", "movers")
               if getattr(args, name) is not None}
    try:
        return tunnel.tunnel_spec(changes)
    except ValueError as e:
        usage_error(args, str(e))


def _run_random(args: argparse.Namespace) -> int:
    """`auv-mj tunnel --random SEED`: the procedural arena of that seed."""
    given = [option for option, value in (("CENTRELINE", args.centreline), ("--obstacle", args.obstacle),
                                          ("--unknown", args.unknown), ("--mover", args.mover),
                                          ("--closed", args.closed), ("--smooth", args.smooth)) if value]
    if given:
        usage_error(args, f"--random draws the whole arena: {', '.join(given)} cannot go with it")
    if args.task != "tunnel":
        fixed = [f"--{n}" for n in ("width", "length", "obstacles", "movers") if getattr(args, n) is not None]
        if fixed:
            usage_error(args, f"{', '.join(fixed)} apply to --task tunnel only")
    if args.tier == "hard":
        fixed = [f"--{n}" for n in ("width", "length", "obstacles", "movers") if getattr(args, n) is not None]
        if fixed:
            usage_error(args, f"--tier hard draws its own arena: {', '.join(fixed)} cannot go with it")
    name = args.name or (Path(args.output).stem if args.output else f"random_{args.task}_{args.random}")
    output = Path(args.output) if args.output else Path(f"{name}.xml")
    check_output(args, output, _output_option(args), replace=args.force)
    if args.task == "tunnel":
        spec = _spec(args)
        try:
            arena = tunnel.random_arena(args.random, spec, args.tier)
        except RuntimeError as e:  # the options leave no feasible tunnel: refuse them
            usage_error(args, " ".join(str(e).split()))
        element = arena.element(name, _command_line())
        what = (f"a {arena.width:.1f} m wide tunnel over {arena.length:.0f} m, "
                f"{counted(len(arena.unknown), 'unknown obstacle')}, {counted(len(arena.movers), 'mover')}")
    elif args.tier == "hard":  # the first episode's arena of the task seeded SEED with tier="hard"
        spec = traps.HARD_MOVING if args.task == "moving_obstacles" else traps.HARD_OBSTACLES
        layout = traps.random_hard_layout(np.random.RandomState(args.random), planning_physics.MAP_BOUNDS, spec,
                                          routes.GOAL_RADIUS)
        element = layout.element(name, _command_line())
        boxes = counted(len(layout.obstacles), "unknown box", "unknown boxes")
        what = (f"open water, traps {', '.join(layout.kinds)}: {boxes}, {counted(len(layout.movers), 'mover')}, "
                f"start to goal {np.hypot(*(layout.goal - layout.start)):.0f} m")
    else:
        layout = obstacles.random_layout(np.random.RandomState(args.random), moving=args.task == "moving_obstacles")
        element = layout.element(name, _command_line())
        what = (f"open water, {counted(len(layout.boxes), 'unknown obstacle')}, {counted(len(layout.movers), 'mover')}"
                f", start to goal {np.hypot(*(layout.goal - layout.start)):.0f} m")
    try:
        save(element, output)
    except OSError as e:
        print(f"auv-mj tunnel: error: {e}", file=sys.stderr)
        return 1
    print(f"wrote {output}: {what} (seed {args.random}, {procedural.seed_split(args.random)} range); "
          f"check it with: auv-mj check-arena {output}")
    return 0
