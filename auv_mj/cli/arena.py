"""`auv-mj arena`: an open-water arena MJCF and its preview from a JSON or CSV list of shapes (`auv_mj.arenas.layout`).

The open-water counterpart of `auv-mj tunnel`: boxes, cylinders and polygons (walls, obstacles or unknown
obstacles) and movers with waypoints and speeds, a start, a goal and optionally a global path. The built arena is
checked by `check-arena`'s own code (`--no-path` unless the layout has a path) before it is written, atomically;
a refused layout or arena is a usage error (exit status 2, one line) and leaves no file. The arena then runs on
every planning task: `auv-mj eval --task obstacles --arena OUT.xml`.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from auv_mj.arenas import arena_check, layout
from auv_mj.arenas.tunnels import save
from auv_mj.cli.options import add_force_option, add_output_option, check_output, usage_error
from auv_mj.figures.arenas import is_preview, preview

SHOWN_PROBLEMS = 3
"""Problems of a refused arena named in the one-line error (`auv-mj check-arena` lists them all)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj arena`."""
    parser.add_argument("shapes", help="the layout: JSON or CSV of shapes, start and goal (see docs/arenas.md)")
    add_output_option(parser, "arena MJCF to write (default: SHAPES with .xml)", metavar="FILE")
    parser.add_argument("--preview", default=None, metavar="PNG", help="top-down PNG to write (default: OUT with .png)")
    parser.add_argument("--no-preview", action="store_true", help="write no preview")
    add_force_option(parser)
    parser.add_argument("--name", default=None, help="model name (default: the layout's name, or open_water)")


def run(args: argparse.Namespace) -> int:
    """Reads, builds, checks and writes the arena; prints its summary and any warnings."""
    source = Path(args.shapes)
    out = Path(args.out) if args.out else source.with_suffix(".xml")
    if out.resolve() == source.resolve():
        usage_error(args, f"-o {out} would overwrite the layout; give another output")
    png = None if args.no_preview else Path(args.preview) if args.preview else out.with_suffix(".png")
    check_output(args, out, "-o" if args.out else "the output (-o)", replace=args.force)
    check_output(args, png, "--preview" if args.preview else "the preview (--preview)", replace=args.force,
                 may_replace=is_preview)
    try:
        shapes = layout.read_layout(source, args.name)
        command = " ".join(["auv-mj arena", shlex.quote(str(source)), "-o", shlex.quote(str(out))]
                           + (["--name", shlex.quote(args.name)] if args.name else []))
        element = shapes.element(command)
        need_path = shapes.path is not None
        report = (arena_check.check_arena(element, need_path=need_path, name=str(out)) if png is None
                  else preview(element, png, need_path=need_path, name=str(out)))
    except ValueError as e:
        usage_error(args, " ".join(str(e).split()))
    if not report.ok:
        if report.png is not None:
            report.png.unlink(missing_ok=True)
        shown = "; ".join(" ".join(p.split()) for p in report.problems[:SHOWN_PROBLEMS])
        more = f"; and {len(report.problems) - SHOWN_PROBLEMS} more" if len(report.problems) > SHOWN_PROBLEMS else ""
        usage_error(args, f"{source}: not a usable arena: {shown}{more}")
    try:
        save(element, out, layout.HEADER)
    except OSError as e:
        print(f"{args.prog}: error: {e}", file=sys.stderr)
        return 1
    for warning in report.warnings:
        print(f"warning: {warning}")
    print(f"wrote {out}: {report.summary}"
          + (f"; preview {report.png}" if report.png is not None else ""))
    print(f"run it with: auv-mj eval --task obstacles --arena {out} --policy los-avoid")
    return 0
