"""Scores depth executors on validation seeds, the way `depth-executor` was chosen (docs/executors.md).

Each policy (a registered name or a depth_heading checkpoint) runs EPISODES episodes of depth_heading with random
command schedules in ocean water, on the validation seeds 20000 on (never the test seeds the table reports); its
MAE of speed, heading and depth over all of them is printed, with the mean of the three ratios to the reference
policy's (`splane-ocean`, the S-plane re-tuned in ocean water) and how many of the three are below it.

    python experiments/select_depth_executor.py runs/depth/gains-ocean/snapshots/*.pt --episodes 10
"""

from __future__ import annotations

import argparse

import numpy as np

from auv_mj.console import progress_bar
from auv_mj.episode import episode_metrics, record_episode
from auv_mj.seeds import VALIDATION
from auv_mj.zoo.registry import env_and_policy

TASK_KWARGS = {"conditions": "ocean", "command": "random"}
CHANNELS = ("mae_speed", "mae_heading", "mae_depth")


def scores(policy: str, episodes: int) -> np.ndarray:
    """Mean (MAE speed, heading, depth) of `policy` over `episodes` validation episodes."""
    per_episode = []
    for seed in VALIDATION[:episodes]:
        env, act = env_and_policy(policy, "depth_heading", seed, TASK_KWARGS)
        metrics = episode_metrics(record_episode(env, act))
        per_episode.append([metrics[c] for c in CHANNELS])
    return np.mean(per_episode, axis=0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("policies", nargs="+", help="registered names or depth_heading checkpoints")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--reference", default="splane-ocean")
    args = parser.parse_args(argv)
    if not 1 <= args.episodes <= len(VALIDATION):
        parser.error(f"--episodes must be in [1, {len(VALIDATION)}], got {args.episodes}")
    reference = scores(args.reference, args.episodes)
    print(f"{args.reference}: MAE speed {reference[0]:.4f} heading {reference[1]:.4f} depth {reference[2]:.4f}")
    for policy in progress_bar(iterable=args.policies, desc="validation"):
        mae = scores(policy, args.episodes)
        ratio = mae / reference
        print(f"{policy}: ratio {ratio.mean():.3f} below {int(np.sum(ratio < 1))}/3  MAE speed {mae[0]:.4f} "
              f"heading {mae[1]:.4f} depth {mae[2]:.4f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
