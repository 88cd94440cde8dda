"""Table 9: the execution layer against the S-plane under disturbances."""

from __future__ import annotations

from auv_mj.benchmark import runner
from experiments.report.common import PAPER_TABLE9, fmt
from experiments.report.registry import ReportSettings, section


@section("table9")
def table9(lines: list[str], settings: ReportSettings | None = None) -> None:
    """Table 9: MAE of speed and heading per disturbance phase, learned executor vs S-plane."""
    lines += ["## Table 9: execution layer vs S-plane under disturbances", "",
              "Speed 1.0 m/s and heading pi/12 held through a 180 N burst (10 steps from step 250), a 30 N "
              "constant force (350 steps from 350) and a 25 sin(0.01 pi t) N force (350 steps from 750).", "",
              "| controller | phase | MAE speed ours | MAE speed paper | MAE heading ours | MAE heading paper |",
              "| --- | --- | --- | --- | --- | --- |"]
    for name in ("executor", "splane"):
        summary = runner.evaluate(name, ["speed_heading"], 1, 0, progress=False)["tasks"]["speed_heading"]
        for phase, (paper_v, paper_h) in PAPER_TABLE9[name].items():
            lines.append(f"| {name} | {phase} | {fmt(summary.get(f'mae_speed_{phase}'))} | {paper_v} | "
                         f"{fmt(summary.get(f'mae_heading_{phase}'))} | {paper_h} |")
    lines += ["", "Command: `auv-mj eval --policy executor --task speed_heading --episodes 1` (and "
              "`--policy splane`).", ""]
