"""Tables 10-11: line and curve following."""

from __future__ import annotations

from experiments.report.common import PAPER_TRACKING, TRACKING_POLICIES, fmt, tracking_errors
from experiments.report.registry import ReportSettings, section


@section("tracking")
def tracking(lines: list[str], settings: ReportSettings | None = None) -> None:
    """Tables 10-11: speed and heading tracking along the line and the curve, once on the path."""
    lines += ["## Tables 10-11: line and curve following", "",
              "Errors of speed and heading against the executor's command and the cross-track error, from the "
              "moment the vehicle reaches the path's first point (the drive to the path is left out, as the paper "
              "does; the tasks mark these steps `tracked`). `los-executor` = line-of-sight guidance on the "
              "learned DDPG executor; `splane` = the same guidance on the S-plane controller.", "",
              "| path | controller | MAE speed | MAE heading | MAX speed | MAX heading | cross-track MAE [m] |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for task, paper in PAPER_TRACKING.items():
        lines.append(f"| {task} | paper (DDPG) | {paper[0]} | {paper[1]} | {paper[2]} | {paper[3]} | n/a |")
        for name in TRACKING_POLICIES:
            *errors, cross = tracking_errors(name, task)
            lines.append(f"| {task} | {name} | {' | '.join(fmt(e) for e in errors)} | {fmt(cross, 2)} |")
    lines += ["", "Command: `auv-mj eval --policy los-executor --task path_line --episodes 1` (the same figures).",
              ""]
