"""Issue 15's held-out bar: the general planner against the classical local planner, and every paper scenario."""

from __future__ import annotations

import math

from auv_mj import seeds
from auv_mj.benchmark import runner
from experiments.report.common import SCENARIOS, fmt
from experiments.report.generalisation import GENERALISATION_SETS
from experiments.report.registry import ReportSettings, section

HELDOUT_EPISODES = 200
"""Held-out arenas per set in the "heldout" section (issue 15's size)."""


HELDOUT_POLICIES = (("two-layer-general", {}), ("planner-general", {}), ("planner-general", {"executor": "executor"}),
                      ("los-avoid", {}))
"""(policy, extra task options): the general planner on the best learned executor (its two-layer system), on the
S-plane and on the paper's DDPG executor (Eq. 27-30), and the classical local planner."""


HELDOUT_TARGETS = (0.95, 0.01)
"""(success floor, collision ceiling) of the general planner on each held-out set (issue 15)."""


SCENARIO_CLEARANCE = 5.0
"""Least clearance [m] the general planner keeps in every scenario of Tables 6-8 and 12 (issue 15)."""


def heldout(lines: list[str], workers: int) -> None:
    """Issue 15's bar: HELDOUT_EPISODES held-out arenas per set for the general planner and `los-avoid`, and
    every paper scenario with at least SCENARIO_CLEARANCE of clearance."""
    floor, ceiling = HELDOUT_TARGETS
    lines += ["## Held-out benchmark: the general planner against the classical local planner", "",
              f"{HELDOUT_EPISODES} held-out arenas per set (test seeds {seeds.TEST.start}.."
              f"{seeds.TEST.start + HELDOUT_EPISODES - 1}); target: success >= {floor}, collisions <= {ceiling}, "
              "at least `los-avoid`'s success and a shorter mean time to the goal (over each policy's "
              "successful episodes).", "",
              "| set | policy | episodes | success | collisions | outcomes | time to goal [s] | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    verdicts = []
    for label, task, kwargs in GENERALISATION_SETS:
        results = {}
        for name, extra in HELDOUT_POLICIES:
            run = runner.evaluate(name, [task], HELDOUT_EPISODES, seeds.TEST.start, progress=False,
                                    task_kwargs={**kwargs, **extra}, workers=workers)
            shown = name + (f" (executor: {extra['executor']})" if extra else "")
            s = results[shown] = run["tasks"][task]
            outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
            lines.append(f"| {label} | {shown} | {s['episodes']} | {s['success_rate']:.3f} | {s['collision_rate']:.3f} "
                         f"| {outcomes} | {fmt(s['time_to_goal'], 0)} | {fmt(s['min_clearance'], 1)} |")
        ours, classical = results["two-layer-general"], results["los-avoid"]
        met = (ours["success_rate"] >= floor and ours["collision_rate"] <= ceiling
               and ours["success_rate"] >= classical["success_rate"]
               and (ours["time_to_goal"] or math.inf) < (classical["time_to_goal"] or math.inf))
        verdicts.append(f"{label}: **{'met' if met else 'NOT met'}**")
    lines += ["", "Target (two-layer-general): " + "; ".join(verdicts) + ".", "",
              "### Every paper scenario", "",
              f"`two-layer-general` on the scenarios of Tables 6-8 and 12 (one episode each); target: the goal with "
              f">= {SCENARIO_CLEARANCE:g} m clearance.", "",
              "| scenario | paper | outcome | min clearance [m] | time [s] |", "| --- | --- | --- | --- | --- |"]
    short = []
    for label, table, task, kwargs in SCENARIOS:
        m = runner.run_episode("two-layer-general", task, 0, kwargs)
        ok = m["outcome"] == "goal" and (m["min_clearance"] is None or m["min_clearance"] >= SCENARIO_CLEARANCE)
        short += [] if ok else [label]
        lines.append(f"| {label} | {table} | {m['outcome']} | {fmt(m['min_clearance'], 1)} | "
                     f"{fmt(m['time_to_goal'], 0)} |")
    lines += ["", f"Scenarios: **{'all met' if not short else 'NOT met: ' + ', '.join(short)}**.", "",
              f"Commands: `auv-mj eval --policy two-layer-general --task tunnel --arena random --episodes "
              f"{HELDOUT_EPISODES} --seed {seeds.TEST.start} --workers 2` (and `--task obstacles`, `--task "
              "moving_obstacles`; `--policy planner-general`, `los-avoid`; the paper's executor: `--policy "
              "planner-general --task-kwargs '{\"executor\": \"executor\"}'`); `auv-mj eval --policy two-layer-general "
              "--task obstacles --task-kwargs '{\"scenario\": \"a\"}' --episodes 1 --seed 0`.", ""]


@section("heldout")
def heldout_section(lines: list[str], settings: ReportSettings) -> None:
    """Issue 15's bar, on `--workers` processes."""
    heldout(lines, settings.workers)
