"""Issue 17: every executor in ideal and ocean water, and the two-layer system on it."""

from __future__ import annotations

from auv_mj import seeds
from auv_mj.benchmark import runner
from experiments.report.common import CONDITIONS, HELD_OUT_SEED, PAPER_TRACKING, fmt
from experiments.report.registry import ReportSettings, section

EXECUTOR_ROWS = (("executor", "DDPG executor, Eq. 27-30 (the paper's row)"),
                 ("ocean-executor", "TD3 scheduling the S-plane's gains, trained in ocean water"),
                 ("splane", "S-plane, nominal gains"), ("splane-ocean", "S-plane re-tuned in ocean water"))
"""Every executor of the executor comparison: speed_heading policy name, what it is."""


EXECUTOR_SEED = seeds.TEST.start
"""First held-out seed of the executor comparison (the ocean draw differs per seed)."""


SYSTEM_TASKS = (("obstacles", {}), ("moving_obstacles", {}), ("tunnel", {"arena": "random"}))
"""Held-out random arenas of the two-layer comparison under ocean conditions."""


SYSTEM_EPISODES = 100
"""Held-out arenas per task for the two-layer system in ocean water (issue 17: does success drop?)."""


def _executor_table9(lines: list[str], episodes: int) -> dict:
    """Table 9 in ideal and ocean water for every executor, mean over `episodes` held-out seeds."""
    lines += ["### Table 9, ideal and ocean water", "",
              f"The Sec. 4.2 schedule (1.0 m/s, pi/12; burst, constant and periodic forces), {episodes} held-out seeds "
              f"from {EXECUTOR_SEED} (in ideal water every seed is the same episode; in ocean water each draws its "
              "own current, lag and vehicle). MAE of speed [m/s] / heading [rad] per phase.", "",
              "| executor | water | instantaneous | constant | periodic | all steps |",
              "| --- | --- | --- | --- | --- | --- |"]
    results = {}
    for name, _ in EXECUTOR_ROWS:
        for condition in CONDITIONS:
            summary = runner.evaluate(name, ["speed_heading"], episodes, EXECUTOR_SEED, progress=False,
                                        task_kwargs={"conditions": condition})["tasks"]["speed_heading"]
            results[name, condition] = summary
            cells = [f"{fmt(summary.get(f'mae_speed_{p}'))} / {fmt(summary.get(f'mae_heading_{p}'))}"
                     for p in ("instantaneous", "constant", "periodic")]
            lines.append(f"| {name} | {condition} | {' | '.join(cells)} | {fmt(summary['mae_speed'])} / "
                         f"{fmt(summary['mae_heading'])} |")
    lines += ["", f"Command: `auv-mj eval --policy ocean-executor --task speed_heading --episodes {episodes} "
              f"--seed {EXECUTOR_SEED} --task-kwargs '{{\"conditions\": \"ocean\"}}'` (and each executor; "
              "`\"ideal\"`).", ""]
    return results


def _beats(results: dict, name: str, other: str, condition: str) -> str:
    """Whether executor `name` has MAE of speed AND heading at most `other`'s in every phase (issue 17's target)."""
    worse = [f"{p} {q}" for p in ("instantaneous", "constant", "periodic") for q in ("speed", "heading")
             if results[name, condition][f"mae_{q}_{p}"] > results[other, condition][f"mae_{q}_{p}"]]
    return "yes" if not worse else "no (worse in " + ", ".join(worse) + ")"


def executors(lines: list[str], episodes: int, workers: int = 1) -> None:
    """Issue 17: every executor in ideal and ocean water (Tables 9-11), and the two-layer system on it."""
    lines += ["## Executors in ideal and ocean water", "",
              "Every executor: " + "; ".join(f"`{n}` = {what}" for n, what in EXECUTOR_ROWS) + ". The nominal "
              "S-plane keeps the gains tuned on the nominal model (as a practitioner would); `splane-ocean` is the "
              "strongest classical executor we have, re-tuned in ocean water on training seeds.", ""]
    n_exec = max(10, min(episodes, 20))
    results = _executor_table9(lines, n_exec)
    lines += ["Target: the learned executor's MAE of speed and heading at most the S-plane's in every "
              "phase, in ocean water.", "", "| learned executor | against | ocean: at most in every phase? | "
              "ideal: at most in every phase? |", "| --- | --- | --- | --- |"]
    for name in ("ocean-executor", "executor"):
        for other in ("splane", "splane-ocean"):
            lines.append(f"| {name} | {other} | {_beats(results, name, other, 'ocean')} | "
                         f"{_beats(results, name, other, 'ideal')} |")
    lines += ["", "### Tables 10-11, ideal and ocean water", "",
              "Line-of-sight guidance on each executor (`--task-kwargs '{\"executor\": NAME}'` on the path "
              "tasks), errors once on the path, one episode (seed 0).", "",
              "| path | executor | water | MAE speed | MAE heading | MAX speed | MAX heading | cross-track MAE [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task in PAPER_TRACKING:
        for name, _ in EXECUTOR_ROWS:
            for condition in CONDITIONS:
                m = runner.run_episode("splane", task, 0, {"conditions": condition, "executor": name})
                errors = (m["mae_speed"], m["mae_heading"], m["max_speed"], m["max_heading"])
                lines.append(f"| {task} | {name} | {condition} | {' | '.join(fmt(e) for e in errors)} | "
                             f"{fmt(m['mae_cross_track'], 2)} |")
    lines += ["", "Command: `auv-mj eval --policy splane --task path_line --episodes 1 --task-kwargs "
              "'{\"conditions\": \"ocean\", \"executor\": \"ocean-executor\"}'`.", "",
              "### The two-layer system in ocean water", "",
              f"The general planner (`planner-general`, its protection domain on) on each S-plane and on the learned "
              f"ocean executor (`two-layer-general`), {SYSTEM_EPISODES} held-out random arenas per task (test seeds "
              f"from {HELD_OUT_SEED}), ocean water.", "",
              "| task | executor | episodes | success | collisions | outcomes | time to goal [s] | min clearance [m] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for task, kwargs in SYSTEM_TASKS:
        for name in ("splane", "splane-ocean", "ocean-executor"):
            s = runner.evaluate("planner-general", [task], SYSTEM_EPISODES, HELD_OUT_SEED, progress=False,
                                  task_kwargs={**kwargs, "conditions": "ocean", "executor": name},
                                  workers=workers)["tasks"][task]
            outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
            lines.append(f"| {task} | {name} | {s['episodes']} | {s['success_rate']:.2f} | {s['collision_rate']:.2f} "
                         f"| {outcomes} | {fmt(s['time_to_goal'], 0)} | {fmt(s['min_clearance'], 1)} |")
    lines += ["", f"Command: `auv-mj eval --policy planner-general --task obstacles --episodes {SYSTEM_EPISODES} "
              f"--seed {HELD_OUT_SEED} --workers 2 --task-kwargs '{{\"conditions\": \"ocean\", \"executor\": "
              "\"ocean-executor\"}'` (and `\"splane\"`; `--task tunnel --arena random`).", ""]


@section("executors")
def executors_section(lines: list[str], settings: ReportSettings) -> None:
    """Every executor, over `--episodes` held-out seeds, on `--workers` processes."""
    executors(lines, settings.episodes, settings.workers)
