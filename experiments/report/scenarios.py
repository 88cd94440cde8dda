"""The named scenarios of Tables 6-8 and 12."""

from __future__ import annotations

from pathlib import Path

from auv_mj.episode import episode_metrics, record_episode
from auv_mj.figures.trajectory import plot_trajectory
from auv_mj.zoo import registry as policies
from experiments.report.common import SCENARIOS, fmt
from experiments.report.registry import ReportSettings, section

SCENARIO_POLICIES = ("two-layer", "planner", "splane", "planner-learned")


def scenarios(lines: list[str], figures: Path) -> None:
    """The named scenarios of Tables 6-8 and 12 with each policy (one deterministic episode each)."""
    lines += ["## Scenarios of Tables 6-8 and 12", "",
              "One episode per scenario (start, goal and obstacles from the table; obstacle shapes ours). "
              "`two-layer` = HER-DDPG planner on the DDPG executor (Sec. 4.3); `planner` = HER-DDPG on the "
              "S-plane executor; `splane` = line-of-sight guidance on S-plane (no avoidance); `planner-learned` = "
              "ours, a student taught by `map-replan` on its own sonar map, then PPO (not the paper's), on the same "
              "executor.", "",
              "| scenario | paper | policy | outcome | min clearance [m] | path length [m] | time [s] |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for label, table, task, kwargs in SCENARIOS:
        records = []
        for name in SCENARIO_POLICIES:
            env, policy = policies.env_and_policy(name, task, 0, kwargs)
            record = record_episode(env, policy, task=task, policy_name=name)
            records.append(record)
            m = episode_metrics(record)
            lines.append(f"| {label} | {table} | {name} | {m['outcome']} | {fmt(m['min_clearance'], 1)} | "
                         f"{m['path_length']:.0f} | {record.time[-1]:.0f} |")
        name = label.replace(" ", "_")
        plot_trajectory(records, figures / f"{name}.png", labels=list(SCENARIO_POLICIES),
                              title=f"{label} ({table})")
    lines += ["", "`two-layer`'s rows depend on the CPU's maths kernels: its learned executor's closed loop grows "
              "last-bit differences (the networks run in float64) into metres over a long episode, so that goal a1 "
              "gives 340 m / 177 s with MKL's AVX-512 kernels and 338 m / 171 s with MKL_ENABLE_INSTRUCTIONS=AVX2, "
              "and the other policies' rows do not move.", "",
              "Figures: " + ", ".join(f"[{label}](figures/{label.replace(' ', '_')}.png)"
                                         for label, *_ in SCENARIOS), "",
              "Command: e.g. `auv-mj render --task tunnel --policy two-layer -o tunnel.mp4` or "
              "`auv-mj eval --policy two-layer --task tunnel --episodes 1`.", ""]


@section("scenarios")
def scenarios_section(lines: list[str], settings: ReportSettings) -> None:
    """The scenarios, their figures in the report's figures folder."""
    scenarios(lines, settings.figures)
