"""The benchmark's figure (issue 30): a few hard arenas of held-out seeds with each policy's track.

    python experiments/benchmark_figure.py --task obstacles --seeds 10000,10001,10002 --out docs/figures/hard_tier.png
"""

from __future__ import annotations

import argparse

from auv_mj.episode import record_episode
from auv_mj.figures.trajectory import plot_gallery
from auv_mj.zoo.registry import env_and_policy

POLICIES = ("los-avoid", "los-fast", "planner-route", "map-replan", "planner-general", "oracle")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="obstacles")
    parser.add_argument("--seeds", default="10000,10001,10002")
    parser.add_argument("--policies", default=",".join(POLICIES))
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    panels, titles = [], []
    for seed in (int(s) for s in args.seeds.split(",")):
        records = []
        for policy in args.policies.split(","):
            env, act = env_and_policy(policy, args.task, seed, {"arena": "random", "tier": "hard"})
            # the gallery labels a track "TASK SEED": name it by its policy
            records.append(record_episode(env, act, task=policy, policy_name=policy, seed=seed))
        panels.append(records)
        failed = [r.policy for r in records if not r.succeeded]
        titles.append(f"{args.task} hard, seed {seed}\nfailed: {', '.join(failed) or 'none'}")
    print(plot_gallery(panels, args.out, titles, cols=len(panels), panel_size=(620, 560)))


if __name__ == "__main__":
    main()
