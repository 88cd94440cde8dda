"""`auv-mj check-arena`: check an arena MJCF (`auv_mj.arenas.arena_check`) and write a top-down PNG preview
(`auv_mj.figures.arenas`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from auv_mj.arenas.arena_check import check_arena
from auv_mj.cli.options import OLD_NAMES_UNTIL, add_force_option, check_output, usage_error
from auv_mj.figures.arenas import is_preview, preview


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj check-arena`."""
    parser.add_argument("arena", help="arena MJCF file")
    parser.add_argument("--preview", "--png", dest="png", metavar="PNG",
                        help="top-down preview to write (default: next to the arena, .png; a preview auv-mj drew "
                             f"there is replaced, any other file needs --force) (--png: its old name, accepted until "
                             f"{OLD_NAMES_UNTIL})")
    parser.add_argument("--no-preview", "--no-png", dest="no_png", action="store_true",
                        help=f"write no preview (--no-png: its old name, accepted until {OLD_NAMES_UNTIL})")
    add_force_option(parser)
    parser.add_argument("--no-path", action="store_true",
                        help="the arena needs no global path (goal-reaching tasks of Tables 7-8)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar over the checks")


def run(args: argparse.Namespace) -> int:
    """`auv-mj check-arena`: prints the report; exit status 0 only for a usable arena."""
    try:
        png = None if args.no_png else Path(args.png) if args.png else Path(args.arena).with_suffix(".png")
    except ValueError:
        usage_error(args, f"give the preview file with --preview (or --no-preview): {args.arena[:60]!r} has no name")
    check_output(args, png, "--preview" if args.png else "the preview (--preview)", replace=args.force,
                 may_replace=is_preview)
    try:
        if png is None:
            report = check_arena(args.arena, need_path=not args.no_path, progress=not args.no_progress)
        else:
            report = preview(args.arena, png, need_path=not args.no_path, progress=not args.no_progress)
    except OSError as e:
        print(f"auv-mj check-arena: cannot write the preview: {e}")
        return 1
    print("\n".join(report.lines()))
    if report.png is not None:
        print(f"wrote preview {report.png}")
    return 0 if report.ok else 1
