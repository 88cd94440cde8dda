"""Generalisation: held-out arenas against training arenas."""

from __future__ import annotations

from pathlib import Path

from auv_mj import seeds
from auv_mj.benchmark import metrics, runner
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.figures.trajectory import plot_gallery
from auv_mj.zoo import registry as policies
from experiments.report.common import fmt
from experiments.report.registry import ReportSettings, section

GENERALISATION_POLICIES = ("two-layer-general", "two-layer-e2e", "two-layer", "los-avoid", "splane")
"""The planners trained on random arenas (residual on line of sight, and end to end) and the paper's planner (all
with the protection domain, on the learned executor) against the classical local planner and plain line of
sight."""


GENERALISATION_SETS = (  # (label, task, task kwargs)
    ("random tunnels", "tunnel", {"arena": "random"}),
    ("random obstacles", "obstacles", {}),
    ("random moving obstacles", "moving_obstacles", {}),
)


TRAINING_RUN_SEED = 0
"""Run seed of the shipped planner's training: its episodes' arenas are the "training arenas" rows."""


def _policy_set(name: str, task: str, kwargs: dict, seeds: list[int]) -> dict:
    return metrics.summarise([runner.run_episode(name, task, s, kwargs) for s in seeds])


def generalisation(lines: list[str], episodes: int, figures: Path, workers: int = 1) -> None:
    """Success, collisions and time on arenas the planner trained on versus held-out ones, every policy."""
    held_out = [seeds.TEST.start + i for i in range(episodes)]
    trained = [seeds.train_seed(TRAINING_RUN_SEED, i) for i in range(max(1, episodes // 4))]
    lines += ["## Generalisation: held-out arenas", "",
              f"Held-out arenas are drawn from test seeds {held_out[0]}..{held_out[-1]} (never used to train or to "
              f"choose a model; validation seeds {seeds.VALIDATION.start}+ chose the planner); training arenas "
              f"from the seeds of the planner's own training episodes (`auv_mj.seeds.train_seed(0, i)`, "
              f"{len(trained)} of them). Time to goal is over successful episodes.", "",
              "| set | arenas | policy | episodes | success | collisions | outcomes | time to goal [s] | "
              "min clearance [m] |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    gallery = []
    for label, task, kwargs in GENERALISATION_SETS:
        for split, chosen in (("held-out", held_out), ("training", trained)):
            for name in GENERALISATION_POLICIES:
                s = (runner.evaluate(name, [task], episodes, held_out[0], progress=False, task_kwargs=kwargs,
                                       workers=workers)["tasks"][task] if split == "held-out"
                     else _policy_set(name, task, kwargs, chosen))
                outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v)
                lines.append(f"| {label} | {split} | {name} | {s['episodes']} | {s['success_rate']:.2f} | "
                             f"{s['collision_rate']:.2f} | {outcomes} | {fmt(s['time_to_goal'], 0)} | "
                             f"{fmt(s['min_clearance'], 1)} |")
        if task == "tunnel":
            for seed in held_out[:6]:
                records = []
                for name in ("two-layer-general", "los-avoid"):
                    env, policy = policies.env_and_policy(name, task, seed, kwargs)
                    records.append(record_episode(env, policy, task=task, policy_name=name, seed=seed))
                gallery.append(records)
    if gallery:
        titles = [f"seed {r[0].seed}: " + ", ".join(f"{x.policy} {episode_metrics(x)['outcome']}" for x in r)
                  for r in gallery]
        plot_gallery(gallery, figures / "heldout_tunnels.png", titles=titles)
        lines += ["", "![held-out tunnels](figures/heldout_tunnels.png)"]
    lines += ["",
              f"Commands: `auv-mj eval --policy two-layer-general --task tunnel --arena random --episodes {episodes} "
              f"--seed {seeds.TEST.start} --workers 2` (and `--task obstacles`, `--task moving_obstacles`; `--policy "
              "two-layer`, `los-avoid`, `splane`).", ""]


@section("generalisation")
def generalisation_section(lines: list[str], settings: ReportSettings) -> None:
    """Held-out against training arenas over `--episodes` held-out seeds."""
    generalisation(lines, settings.episodes, settings.figures, settings.workers)
