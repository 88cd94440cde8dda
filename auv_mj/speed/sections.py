"""The bench's sections and how they are run: a registry of measurements, timed side by side, reported as ratios.

Absolute times depend on the machine and its load; ratios of things timed side by side in the same repeats do much
less, so each section reports both and the medians over repeats. A section is a function
`(BenchSettings) -> list[Measurement]` registered in SECTIONS with `@section(name)`; add one and it runs, prints and
goes to `auv-mj bench --json`. The sections themselves live in a module per thing measured (`SECTION_MODULES`):
the simulator (`auv_mj.speed.sim`), the suite's tasks (`auv_mj.speed.tasks`), the renderer (`auv_mj.speed.render`),
the learners' updates (`auv_mj.speed.learners`), the batched envs (`auv_mj.speed.vector`, planar;
`auv_mj.speed.vector3d`, 6-DOF) and training with collector processes (`auv_mj.speed.collectors`);
`load_sections()` imports them, in the order they run.

From Python: `run_bench(["physics", "sonar"], BenchSettings(repeats=3))` returns the measurements of each section;
`bench_payload` is what `auv-mj bench --json` writes. The command (`auv_mj.cli.bench`) parses its options into
these calls and nothing more.
"""

from __future__ import annotations

import importlib
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np


@dataclass(frozen=True)
class BenchSettings:
    """How long to measure."""

    repeats: int = 7
    """Timed repeats; every figure is the median over them."""
    scale: float = 1.0
    """Multiplies the calls per repeat (`--quick` uses 0.1)."""
    seed: int = 0
    """Seed of the random controls and wall layouts."""

    def calls(self, full: int) -> int:
        """`full` calls scaled by `scale`, at least one."""
        return max(1, int(full * self.scale))


@dataclass(frozen=True)
class Measurement:
    """One figure of a section."""

    name: str
    value: float
    unit: str
    note: str = ""


Section = Callable[[BenchSettings], list[Measurement]]
SECTIONS: dict[str, Section] = {}
"""Every registered section by name, in registration order (the order they run in)."""
ON_REQUEST: set[str] = set()
"""Sections run only when asked for by name (minutes long: the batched env's)."""
SECTION_MODULES = ("auv_mj.speed.sim", "auv_mj.speed.tasks", "auv_mj.speed.render", "auv_mj.speed.learners",
                   "auv_mj.speed.vector", "auv_mj.speed.vector3d", "auv_mj.speed.collectors")
"""The modules whose `@section`s are the bench, in the order their sections run."""
Report = Callable[[str, list[Measurement]], None]


def section(name: str, on_request: bool = False) -> Callable[[Section], Section]:
    """Registers a bench section under `name` (run in registration order); `on_request`: not in the default run,
    only when asked for by name."""
    def register(function: Section) -> Section:
        SECTIONS[name] = function
        if on_request:
            ON_REQUEST.add(name)
        return function
    return register


def load_sections() -> dict[str, Section]:
    """SECTIONS with every section of SECTION_MODULES registered (importing them: torch and the agents among
    them)."""
    for module in SECTION_MODULES:
        importlib.import_module(module)
    return SECTIONS


def default_sections() -> list[str]:
    """The sections a run without names runs: all but those ON_REQUEST."""
    return [name for name in load_sections() if name not in ON_REQUEST]


def run_bench(names: Sequence[str] | None = None, settings: BenchSettings | None = None,
              report: Report | None = None) -> dict[str, list[Measurement]]:
    """Runs the named sections in order (`default_sections()` if None) and returns their measurements by section;
    `report(name, measurements)` is called after each. ValueError naming the known sections for an unknown name."""
    settings = settings if settings is not None else BenchSettings()
    load_sections()
    names = default_sections() if names is None else list(names)
    unknown = [n for n in names if n not in SECTIONS]
    if unknown:
        raise ValueError(f"unknown section(s) {', '.join(unknown)[:200]}; known: {', '.join(SECTIONS)}")
    results = {}
    for name in names:
        results[name] = SECTIONS[name](settings)
        if report is not None:
            report(name, results[name])
    return results


def interleaved_times(workloads: Sequence[Callable[[], None]], calls_per_repeat: Sequence[int],
                      repeats: int) -> np.ndarray:
    """Seconds per call, shape (repeats, workloads); the workloads alternate inside every repeat."""
    times = np.empty((repeats, len(workloads)))
    for workload in workloads:  # warm-up: caches, lazy allocations
        workload()
    for i in range(repeats):
        for j, (workload, calls) in enumerate(zip(workloads, calls_per_repeat, strict=True)):
            start = time.perf_counter()
            for _ in range(calls):
                workload()
            times[i, j] = (time.perf_counter() - start) / calls
    return times


def median_ratio(times: np.ndarray, numerator: int, denominator: int) -> float:
    """The median over repeats of workload `numerator`'s time over workload `denominator`'s."""
    return float(np.median(times[:, numerator] / times[:, denominator]))


def environment() -> dict[str, str]:
    """What the figures were measured on."""
    return {"python": platform.python_version(), "mujoco": mujoco.__version__,
            "machine": platform.machine(), "processor": platform.processor() or "unknown",
            "time": time.strftime("%Y-%m-%dT%H:%M:%S")}


def bench_payload(settings: BenchSettings, results: dict[str, list[Measurement]]) -> dict[str, Any]:
    """The JSON document of a run (`auv-mj bench --json`): its settings, the machine, and every section's figures."""
    return {"settings": asdict(settings), "environment": environment(),
            "sections": {name: [asdict(m) for m in ms] for name, ms in results.items()}}
