"""`auv-mj reproduce`: the reproduction report, our numbers measured now beside the paper's.

Covers Table 9 (executor vs S-plane under disturbances), Tables 10-11 (line and curve following),
Fig. 8 (HER-DDPG vs DDPG learning curves, from the training logs in `--runs`), the named scenarios
of Tables 6-8 and 12, the planner targets on random layouts, held-out arenas, and the same under ocean conditions
(`auv_mj.sim.ocean`) beside the ideal ones. Each section is a module of `experiments.report`, registered with
`@section(name)`; every number is printed with the command that reproduces it, and `--sections` runs a subset.

The sections and their data (the training logs and run records of docs/runs) are a checkout's, not the installed
package's: the command finds them beside the package (`experiments/` of the checkout it is installed from) or at
AUV_MJ_EXPERIMENTS, and from a wheel without either it says where they must be.
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import auv_mj
from auv_mj.cli.options import check_output, positive_int, usage_error
from auv_mj.console import progress_bar

EXPERIMENTS_ENV = "AUV_MJ_EXPERIMENTS"
"""The environment variable naming a checkout's experiments/ folder, for an install that is not that checkout."""


def experiments_folder() -> Path | None:
    """The experiments/ folder whose `report` package holds the sections: AUV_MJ_EXPERIMENTS, else the one beside
    the package's folder in a checkout; None when neither holds it (an installed wheel)."""
    named = os.environ.get(EXPERIMENTS_ENV)
    for folder in ([Path(named)] if named else []) + [Path(auv_mj.__file__).resolve().parents[1] / "experiments"]:
        if (folder / "report" / "__init__.py").is_file():
            return folder.resolve()
    return None


def report_sections():
    """The report's registry module (`experiments.report`: SECTIONS, ReportSettings) from `experiments_folder()`;
    LookupError saying where it must be when there is none."""
    folder = experiments_folder()
    if folder is None:
        raise LookupError(f"the reproduction's sections and data are in a checkout of auv-mj, not in the installed "
                          f"package: run it from a clone (its experiments/ and docs/runs), or set {EXPERIMENTS_ENV} "
                          f"to a clone's experiments/ folder")
    if str(folder.parent) not in sys.path:
        sys.path.insert(0, str(folder.parent))
    module = importlib.import_module("experiments.report")
    if Path(module.__file__).resolve().parent != folder / "report":
        raise LookupError(f"another 'experiments' package ({module.__file__}) shadows {folder}")
    return module


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj reproduce`."""
    parser.add_argument("-o", "--out", type=Path, metavar="FILE", default=Path("docs/reproduction.md"),
                        help="report file")
    parser.add_argument("--runs", type=Path, default=Path("docs/runs/fig8"),
                        help="folder of the Fig. 8 training logs (her-ddpg-seed*.csv, ddpg-seed*.csv)")
    parser.add_argument("--paper-runs", type=Path, default=Path("docs/runs/fig8-paper-observation"),
                        help="folder of the Fig. 8 logs on the paper's observation (section fig8_paper)")
    parser.add_argument("--peer-runs", type=Path, default=Path("docs/runs/peer"),
                        help="folder of the training-speed logs (auv-mj-*.csv, sb3-*.csv)")
    parser.add_argument("--episodes", type=positive_int, default=100,
                        help="held-out episodes per task and policy on random layouts (random targets, ocean)")
    parser.add_argument("--quick", action="store_true", help="10 episodes for the random targets")
    parser.add_argument("--workers", type=positive_int, default=1,
                        help="local processes for the held-out episodes of the generalisation, heldout and executors "
                             "sections (the result is the serial one)")
    parser.add_argument("--sections", default=None,
                        help="comma-separated sections to run (default all, in the report's order: one module each in "
                             "a checkout's experiments/report); into an existing report they are written in place, "
                             "the other sections kept")


SECTION_START, SECTION_END = "<!-- section: {} -->", "<!-- /section: {} -->"
"""Markers around each section of the report, so that `--sections` can rewrite some and keep the rest."""


def _blocks(text: str, order: list[str]) -> dict[str, str]:
    """The marked sections `order` of a report: name -> its block, markers included."""
    blocks = {}
    for name in order:
        start, end = SECTION_START.format(name), SECTION_END.format(name)
        if start in text and end in text[text.index(start):]:
            i = text.index(start)
            blocks[name] = text[i:text.index(end, i) + len(end)]
    return blocks


def merge_report(old: str, new_blocks: dict[str, str], header: list[str], order: list[str] | None = None) -> str:
    """The report `old` with `new_blocks` in place of its sections of the same names (the others kept), in the
    report's section order (`order`, default the registry's), under `header`; sections of neither are left out."""
    order = list(report_sections().SECTIONS) if order is None else order
    kept = _blocks(old, order)
    kept.update(new_blocks)
    return "\n".join(header) + "\n" + "\n\n".join(kept[name] for name in order if name in kept) + "\n"


def run(args: argparse.Namespace) -> int:
    """Measures everything (or `--sections`) and writes the Markdown report with its figures; sections into
    an existing report replace their own blocks and keep the others (each block says when it was measured)."""
    try:
        report = report_sections()
    except LookupError as e:
        usage_error(args, str(e))
    SECTIONS, ReportSettings = report.SECTIONS, report.ReportSettings  # noqa: N806  (the registry's names)
    names = list(SECTIONS) if args.sections is None else [n.strip() for n in args.sections.split(",") if n.strip()]
    unknown = [n for n in names if n not in SECTIONS]
    if unknown:
        usage_error(args, f"--sections: unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    check_output(args, args.out, "--out")
    start = time.perf_counter()
    figures = args.out.parent / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    episodes = 10 if args.quick else args.episodes
    lines = ["# auv-mj reproduction report", "",
             "Lyu et al. 2023, *End-to-End AUV Local Motion Planning Method Based on Deep Reinforcement "
             "Learning*, J. Mar. Sci. Eng. 11, 1796: the paper's numbers beside ours, measured by `auv-mj "
             "reproduce`.", "",
             f"Generated {datetime.date.today().isoformat()} at commit `{_commit()}` on {platform.machine()} "
             f"({platform.python_implementation()} {platform.python_version()}), CPU only.", "",
             "Our vehicle is REMUS-100 (Prestero 2001), not the paper's unnamed AUV, so absolute errors differ; "
             "the comparisons that carry over are the orderings (learned vs classical, HER vs plain DDPG).", ""]
    settings = ReportSettings(episodes=episodes, workers=args.workers, figures=figures, runs=args.runs,
                              paper_runs=args.paper_runs, peer_runs=args.peer_runs)
    header, blocks = list(lines), {}
    bar = progress_bar(total=len(names), desc="reproduce", unit="section")
    for name in names:
        bar.set_postfix(section=name)  # a section takes minutes: the bar names the one running
        began, lines[:] = time.perf_counter(), []
        SECTIONS[name](lines, settings)
        stamp = (f"_Section `{name}` measured {datetime.date.today().isoformat()} at commit `{_commit()}` in "
                 f"{time.perf_counter() - began:.0f} s (`--episodes {episodes}`)._")
        blocks[name] = "\n".join([SECTION_START.format(name), *lines, stamp, SECTION_END.format(name)])
        bar.update(1)
    bar.close()
    old = args.out.read_text() if args.out.is_file() else ""
    header[header.index(next(h for h in header if h.startswith("Generated")))] = (
        f"Last updated {datetime.date.today().isoformat()} at commit `{_commit()}` on {platform.machine()} "
        f"({platform.python_implementation()} {platform.python_version()}), CPU only; each section says when it "
        "was measured.")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(merge_report(old, blocks, header, list(SECTIONS)))
    print(f"wrote {args.out} in {time.perf_counter() - start:.0f} s")
    return 0
