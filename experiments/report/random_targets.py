"""The paper's planner on random layouts (held-out seeds)."""

from __future__ import annotations

from auv_mj.benchmark import runner
from experiments.report.common import HELD_OUT_SEED, fmt
from experiments.report.registry import ReportSettings, section

RANDOM_TARGETS = (("goal", 0.95, None), ("obstacles", 0.90, 0.02))
"""(task, success target, collision ceiling) of the planner on random layouts (the issue's targets)."""


def random_targets(lines: list[str], episodes: int) -> None:
    """The planner on random layouts: success and collision rates over held-out seeds."""
    lines += ["## Planner on random layouts (held-out seeds)", "",
              "| task | policy | episodes | success | target | collisions | ceiling | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task, target, ceiling in RANDOM_TARGETS:
        summary = runner.evaluate("planner", [task], episodes, HELD_OUT_SEED, progress=False)["tasks"][task]
        lines.append(f"| {task} | planner | {episodes} | {summary['success_rate']:.2f} | >= {target} | "
                     f"{summary['collision_rate']:.2f} | {'<= ' + str(ceiling) if ceiling else '-'} | "
                     f"{fmt(summary['min_clearance'], 1)} |")
    lines += ["", f"Command: `auv-mj eval --policy planner --task goal --episodes {episodes} --seed 10000` "
              "(seeds from 10000 are never used in training).", ""]


@section("random_targets")
def random_targets_section(lines: list[str], settings: ReportSettings) -> None:
    """The planner's targets over `--episodes` held-out layouts."""
    random_targets(lines, settings.episodes)
