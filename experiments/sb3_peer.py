"""The training-speed peer of the issue: Stable-Baselines3's DDPG + HerReplayBuffer on our Gymnasium adapter.

`python -m experiments.sb3_peer --steps 60000 --csv runs/sb3-peer.csv` trains SB3 with Table 4's settings on
`auv_mj/Goal-v0` (one gradient step per env step, one torch thread; learning starts after 1300 steps,
past the longest episode, as SB3's HER requires) and writes the same per-episode CSV as `auv-mj train`
(episode, steps, length, return, success, wall_time), so `time_to_success` compares both.

It is set up as an SB3 user would run it on this task: observations normalised by `VecNormalize`
(running mean and std, as our DDPG's input normaliser does; the raw goals are in metres, hundreds of them,
and saturate the tanh actor) and Gaussian action noise of std NOISE_STD. With raw observations and std 0.1
(`--raw --noise-std 0.1`) its actor saturates at V = 0 and never explores forward: 0 successes in 59k steps.
Stable-Baselines3 is a test dependency only; nothing else in auv-mj imports it.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

from auv_mj.cli.options import positive_int, seed_int

TARGET = 0.9
WINDOW = 20
NOISE_STD = 0.3
"""Std of SB3's Gaussian action noise: the setting with which it learns the task (0.1 does not)."""


def time_to_success(csv_path: str | Path, target: float = TARGET, window: int = WINDOW) -> tuple[float, int]:
    """(wall seconds, env steps) when the trailing `window`-episode success rate first reaches `target`."""
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    success = np.array([float(r["success"]) for r in rows])
    for i in range(window - 1, len(rows)):
        if success[i - window + 1:i + 1].mean() >= target:
            return float(rows[i]["wall_time"]), int(float(rows[i]["steps"]))
    return math.nan, -1


def train_sb3(steps: int, csv_path: Path, seed: int = 0, noise_std: float = NOISE_STD,
              normalize: bool = True) -> None:
    """Trains SB3 DDPG + HER (Table 4 settings, VecNormalize unless `normalize` is False) and logs every
    episode to `csv_path`."""
    import gymnasium as gym
    import torch
    from stable_baselines3 import DDPG, HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import auv_mj  # noqa: F401  (registers the auv_mj ids)

    torch.set_num_threads(1)
    env = DummyVecEnv([lambda: gym.make("auv_mj/Goal-v0")])
    if normalize:  # observations only: HER recomputes rewards from the stored raw goals
        env = VecNormalize(env, norm_obs=True, norm_reward=False, gamma=0.9)
    model = DDPG("MultiInputPolicy", env, learning_rate=1e-3, buffer_size=50_000, batch_size=64, tau=0.01,
                 gamma=0.9, learning_starts=1300, train_freq=1, gradient_steps=1,
                 action_noise=NormalActionNoise(np.zeros(2), noise_std * np.ones(2)),
                 replay_buffer_class=HerReplayBuffer,
                 replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                                       "copy_info_dict": True},
                 policy_kwargs={"net_arch": [256, 256], "activation_fn": torch.nn.Tanh}, seed=seed, verbose=0)
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    class Log(BaseCallback):
        def _on_training_start(self) -> None:
            self.file = open(csv_path, "w", newline="")  # noqa: SIM115  (closed at training end)
            self.writer = csv.writer(self.file)
            self.writer.writerow(["episode", "steps", "length", "return", "success", "wall_time"])
            self.episode, self.length, self.ret = 0, 0, 0.0

        def _on_step(self) -> bool:
            self.length += 1
            self.ret += float(self.locals["rewards"][0])
            if self.locals["dones"][0]:
                info = self.locals["infos"][0]
                self.episode += 1
                self.writer.writerow([self.episode, self.num_timesteps, self.length, round(self.ret, 3),
                                      float(info.get("is_success", False)),
                                      round(time.perf_counter() - start, 3)])
                self.file.flush()
                self.length, self.ret = 0, 0.0
            return True

        def _on_training_end(self) -> None:
            self.file.close()

    model.learn(total_timesteps=steps, callback=Log(), progress_bar=False)


def main(argv: list[str] | None = None) -> int:
    """Trains the SB3 peer and prints its time to TARGET success beside ours (if --ours is given)."""
    parser = argparse.ArgumentParser(prog="python -m experiments.sb3_peer", description=__doc__)
    parser.add_argument("--steps", type=positive_int, default=60_000)
    parser.add_argument("--seed", type=seed_int, default=0)
    parser.add_argument("--csv", type=Path, default=Path("runs/sb3-peer/progress.csv"))
    parser.add_argument("--noise-std", type=float, default=NOISE_STD, help="std of the Gaussian action noise")
    parser.add_argument("--raw", action="store_true", help="no VecNormalize: raw observations (as first shipped)")
    parser.add_argument("--ours", type=Path, default=None, help="progress.csv of an `auv-mj train her-ddpg` run")
    args = parser.parse_args(argv)
    train_sb3(args.steps, args.csv, args.seed, args.noise_std, normalize=not args.raw)
    sb3 = time_to_success(args.csv)
    print(f"SB3 DDPG+HER: {TARGET:.0%} success ({WINDOW}-episode window) after {sb3[0]:.0f} s, {sb3[1]} steps")
    if args.ours:
        ours = time_to_success(args.ours)
        print(f"auv-mj HER-DDPG: after {ours[0]:.0f} s, {ours[1]} steps; wall-clock ratio SB3 / ours = "
              f"{sb3[0] / ours[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
