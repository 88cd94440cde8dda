"""Ocean conditions beside ideal ones, and what breaks."""

from __future__ import annotations

from auv_mj.benchmark import runner
from auv_mj.sim import ocean
from experiments.report.common import (
    CONDITIONS,
    HELD_OUT_SEED,
    PAPER_TABLE9,
    PAPER_TRACKING,
    TRACKING_POLICIES,
    fmt,
    tracking_errors,
)
from experiments.report.registry import ReportSettings, section

OCEAN_TASKS = ("obstacles", "moving_obstacles")
"""Random-layout tasks of the ocean comparison (held-out seeds from 10000)."""


OCEAN_POLICIES = ("planner", "two-layer", "splane", "los-avoid")
"""The learned planners and the classical baselines, compared in ideal and ocean conditions."""


def _worse(label: str, speed: tuple, heading: tuple) -> list[str]:
    """"label: speed/heading MAE a -> b" for each (ideal, ocean) MAE pair that at least tripled and grew by
    0.02 or more: what the report calls broken."""
    return [f"{label}: {what} MAE {before:.4f} -> {after:.4f}" for what, (before, after) in
            (("speed", speed), ("heading", heading))
            if before is not None and after is not None and after > max(3 * before, before + 0.02)]


def ocean_conditions(lines: list[str], episodes: int) -> None:
    """The same planners, executors and baselines under ocean conditions beside ideal ones, and what breaks."""
    c = ocean.OCEAN
    lines += ["## Ocean conditions", "",
              "`conditions=\"ocean\"` (`auv_mj/sim/ocean.py`, docs/physics.md \"Ocean conditions\"): a Gauss-Markov "
              "current of "
              f"{c.current.mean_speed} m/s mean (spread {c.current.speed_sigma} m/s, at most "
              f"{c.current.speed_bounds[1]} m/s, direction random per episode), thrust and yaw moment lagged "
              "(0.4 s and 0.2 s, MuJoCo filterexact), sonar noise of "
              f"{c.sonar.floor} m + {c.sonar.proportional:.0%} of range with {c.sonar.dropout:.0%} dropouts and "
              f"the previous ping ({c.sonar.latency} ping latency), and every hydrodynamic coefficient scaled by "
              f"up to +-{c.model_uncertainty.hydrodynamics:.0%} and the mass by up to "
              f"+-{c.model_uncertainty.mass:.0%} per episode, unknown to the controllers. The same seeds give the "
              "same layouts in both columns.", "",
              f"### Planners and classical baselines on held-out random layouts (seeds from {HELD_OUT_SEED})", "",
              "| task | policy | episodes | success ideal | success ocean | collisions ideal | collisions ocean | "
              "min clearance ideal [m] | min clearance ocean [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    broken = []
    for task in OCEAN_TASKS:
        for name in OCEAN_POLICIES:
            summary = {condition: runner.evaluate(name, [task], episodes, HELD_OUT_SEED, progress=False,
                                                    task_kwargs={"conditions": condition})["tasks"][task]
                       for condition in CONDITIONS}
            ideal, rough = summary["ideal"], summary["ocean"]
            lines.append(f"| {task} | {name} | {episodes} | {ideal['success_rate']:.2f} | "
                         f"{rough['success_rate']:.2f} | {ideal['collision_rate']:.2f} | "
                         f"{rough['collision_rate']:.2f} | {fmt(ideal['min_clearance'], 1)} | "
                         f"{fmt(rough['min_clearance'], 1)} |")
            if rough["success_rate"] < ideal["success_rate"] - 0.1:
                broken.append(f"`{name}` on `{task}`: success {ideal['success_rate']:.2f} -> "
                              f"{rough['success_rate']:.2f}, collisions {ideal['collision_rate']:.2f} -> "
                              f"{rough['collision_rate']:.2f}")
    lines += ["", f"Command: `auv-mj eval --policy planner --task obstacles --episodes {episodes} "
              f"--seed {HELD_OUT_SEED} --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (and `\"ideal\"`, the default).", "",
              "### Table 9 under ocean conditions", "",
              "| controller | phase | MAE speed ideal | MAE speed ocean | MAE heading ideal | MAE heading ocean |",
              "| --- | --- | --- | --- | --- | --- |"]
    for name in ("executor", "splane"):
        summary = {condition: runner.evaluate(name, ["speed_heading"], 1, 0, progress=False,
                                                task_kwargs={"conditions": condition})["tasks"]["speed_heading"]
                   for condition in CONDITIONS}
        for phase in PAPER_TABLE9[name]:
            speed = [summary[condition].get(f"mae_speed_{phase}") for condition in CONDITIONS]
            heading = [summary[condition].get(f"mae_heading_{phase}") for condition in CONDITIONS]
            lines.append(f"| {name} | {phase} | {fmt(speed[0])} | {fmt(speed[1])} | {fmt(heading[0])} | "
                         f"{fmt(heading[1])} |")
            broken += _worse(f"`{name}` on speed_heading, {phase} phase", speed, heading)
    lines += ["", "Command: `auv-mj eval --policy executor --task speed_heading --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (and `--policy splane`).", "",
              "### Tables 10-11 under ocean conditions", "",
              "| path | controller | conditions | MAE speed | MAE heading | MAX speed | MAX heading | "
              "cross-track MAE [m] |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task in PAPER_TRACKING:
        for name in TRACKING_POLICIES:
            errors = {}
            for condition in CONDITIONS:
                errors[condition] = tracking_errors(name, task, condition)
                *maes, cross = errors[condition]
                lines.append(f"| {task} | {name} | {condition} | {' | '.join(fmt(e) for e in maes)} | "
                             f"{fmt(cross, 2)} |")
            (speed, heading, *_), (rough_speed, rough_heading, *_) = errors["ideal"], errors["ocean"]
            broken += _worse(f"`{name}` on {task}", (speed, rough_speed), (heading, rough_heading))
    lines += ["", "Command: `auv-mj eval --policy los-executor --task path_line --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\"}'` (errors once on the path).", "",
              "What breaks (success down by more than 0.1, or a tracking MAE tripled and up by 0.02 or more): "
              + ("; ".join(broken) if broken else "nothing by these measures") + ".", ""]


@section("ocean")
def ocean_section(lines: list[str], settings: ReportSettings) -> None:
    """Ideal against ocean water over `--episodes` held-out layouts."""
    ocean_conditions(lines, settings.episodes)
