"""`auv-mj bench`: the simulator's speed as ratios against its limits, all measured in one run.

Argparse over the library: the measurements, their registry and the JSON document are `auv_mj.speed`
(`auv_mj.speed.sections`); this module turns the options into `BenchSettings`, prints each section as it ends and
writes `--json`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from auv_mj.cli.options import bounded_int, check_output, seed_int, usage_error
from auv_mj.speed.sections import (
    ON_REQUEST,
    BenchSettings,
    Measurement,
    bench_payload,
    default_sections,
    load_sections,
    run_bench,
)


def print_section(name: str, measurements: list[Measurement]) -> None:
    """A section's figures, one a line, as they come."""
    print(f"[{name}]")
    for m in measurements:
        note = f"  ({m.note})" if m.note else ""
        print(f"  {m.name:<48} {m.value:10.2f} {m.unit}{note}", flush=True)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj bench`."""
    defaults = default_sections()
    parser.add_argument("--quick", action="store_true", help="a tenth of the calls and 3 repeats (seconds)")
    parser.add_argument("--repeats", type=bounded_int(1, 1000), default=None,
                        help="timed repeats (default 7, --quick 3)")
    parser.add_argument("--sections", default=None,
                        help=f"comma-separated sections to run (default all but {','.join(sorted(ON_REQUEST))}: "
                             f"{','.join(defaults)})")
    parser.add_argument("--json", type=Path, default=None, metavar="PATH",
                        help="also write the figures as JSON")
    parser.add_argument("--seed", type=seed_int, default=0, help="seed of the wall layouts")


def run(args: argparse.Namespace) -> int:
    """`auv-mj bench`: runs the sections, prints their figures, optionally writes them as JSON."""
    known = load_sections()
    names = default_sections() if args.sections is None else [n.strip() for n in args.sections.split(",") if n]
    unknown = [n for n in names if n not in known]
    if unknown:
        usage_error(args, f"--sections: unknown section(s) {', '.join(unknown)[:200]}; known: {', '.join(known)}")
    check_output(args, args.json, "--json")
    repeats = args.repeats if args.repeats is not None else (3 if args.quick else 7)
    settings = BenchSettings(repeats=repeats, scale=0.1 if args.quick else 1.0, seed=args.seed)
    print(f"auv-mj bench: medians over {settings.repeats} repeats; ratios of workloads timed side by side")
    results = run_bench(names, settings, print_section)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(bench_payload(settings, results), indent=2))
        print(f"wrote {args.json}")
    return 0
