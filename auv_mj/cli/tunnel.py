"""`auv-mj tunnel`: build a tunnel arena MJCF from a centreline CSV/JSON (`auv_mj.tunnels`)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from auv_mj.tunnels import (
    BOUNDS_MARGIN,
    END_CLEARANCE,
    MERGE_TOLERANCE,
    PATH_SPACING,
    SMOOTH_ITERATIONS,
    WALL_THICKNESS,
    MovingObstacle,
    Obstacle,
    layout_tunnel,
    read_centreline,
    save,
    tunnel_element,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj tunnel`."""
    parser.add_argument("centreline", help="CSV of x,y[,width] rows [m] (header optional) or JSON")
    parser.add_argument("--width", type=float, help="constant tunnel width [m] (unless per point)")
    parser.add_argument("-o", "--output", help="arena MJCF to write (default: the centreline's name, .xml)")
    parser.add_argument("--smooth", action="store_true", help="round the corners (Chaikin corner cutting)")
    parser.add_argument("--smooth-iterations", type=int, default=SMOOTH_ITERATIONS,
                        help=f"Chaikin rounds of --smooth (default {SMOOTH_ITERATIONS})")
    parser.add_argument("--closed", action="store_true", help="the centreline is a loop: no end caps")
    parser.add_argument("--obstacle", action="append", default=[], metavar="X,Y,LENGTH,WIDTH[,ANGLE[,NAME]]",
                        help="a known box obstacle (angle in deg); repeatable")
    parser.add_argument("--mover", action="append", default=[], metavar="X0,Y0,X1,Y1,SPEED,RADIUS[,NAME]",
                        help="a moving cylinder going back and forth (m, m/s); repeatable")
    parser.add_argument("--spacing", type=float, default=PATH_SPACING,
                        help=f"distance between path sites [m] (default {PATH_SPACING:g})")
    parser.add_argument("--wall-thickness", type=float, default=WALL_THICKNESS)
    parser.add_argument("--end-clearance", type=float, default=END_CLEARANCE,
                        help=f"tunnel length past start and goal [m] (default {END_CLEARANCE:g})")
    parser.add_argument("--margin", type=float, default=BOUNDS_MARGIN, help="arena_bounds margin [m]")
    parser.add_argument("--tolerance", type=float, default=MERGE_TOLERANCE,
                        help=f"wall merging tolerance [m] (default {MERGE_TOLERANCE:g})")
    parser.add_argument("--name", default=None, help="model name (default: the output's stem)")


def _command_line() -> str | None:
    """The `auv-mj tunnel ...` command line this process runs, if it runs one."""
    argv = sys.argv[1:]
    return shlex.join(["auv-mj", *argv]) if argv[:1] == ["tunnel"] else None


def run(args: argparse.Namespace) -> int:
    """`auv-mj tunnel`: writes the arena and prints what it holds."""
    output = Path(args.output) if args.output else Path(args.centreline).with_suffix(".xml")
    try:
        line = read_centreline(args.centreline)
        obstacles = [Obstacle.parse(text) for text in args.obstacle]
        movers = [MovingObstacle.parse(text) for text in args.mover]
        layout = layout_tunnel(line, args.width, closed=args.closed,
                               smooth=args.smooth_iterations if args.smooth else 0, path_spacing=args.spacing,
                               obstacles=obstacles, movers=movers, wall_thickness=args.wall_thickness,
                               end_clearance=args.end_clearance, margin=args.margin,
                               merge_tolerance=args.tolerance)
        element = tunnel_element(layout, obstacles, movers, args.wall_thickness, args.name or output.stem,
                                 _command_line())
        save(element, output)
    except (ValueError, OSError) as e:
        print(f"auv-mj tunnel: error: {e}", file=sys.stderr)
        return 1
    length = float(np.sum(np.hypot(*np.diff(layout.path, axis=0).T)))
    print(f"wrote {output}: {len(layout.walls)} wall boxes, {len(obstacles)} obstacles, "
          f"{len(movers)} movers, {len(layout.path)} path sites over {length:.0f} m; "
          f"check it with: auv-mj check-arena {output}")
    return 0
