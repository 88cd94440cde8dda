"""How fast the off-policy learners update (`auv-mj bench --sections training`): gradient steps per second of DDPG
and TD3 at the paper's sizes, on one torch thread, the two taking turns in every repeat.
"""

from __future__ import annotations

import time

import gymnasium
import numpy as np
import torch

import auv_mj  # noqa: F401  (registers the auv_mj Gymnasium ids)
from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.replay import Batch
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config
from auv_mj.agents.offpolicy.train import env_spec
from auv_mj.speed.sections import BenchSettings, Measurement, section

TRAINING_UPDATES = 200
"""Gradient steps timed per repeat and learner in the "training" section."""


@section("training")
def training_section(settings: BenchSettings) -> list[Measurement]:
    """Gradient steps per second of DDPG and TD3 at Table 4's sizes (2 x 256 tanh, batch 64, one torch thread,
    the planner task's observation), the two learners taking turns in every repeat."""
    torch.set_num_threads(1)
    rng = np.random.default_rng(settings.seed)
    spec = env_spec(gymnasium.make("auv_mj/Goal-v0"))  # the planner's sizes, read from the task
    obs_dim, act_dim = spec["obs_dim"], spec["act_dim"]
    n = settings.calls(TRAINING_UPDATES)
    size = n * DDPGConfig().batch_size
    data = Batch(rng.standard_normal((size, obs_dim), dtype=np.float32),
                 rng.uniform(-1, 1, (size, act_dim)).astype(np.float32), rng.standard_normal(size, dtype=np.float32),
                 rng.standard_normal((size, obs_dim), dtype=np.float32), np.zeros(size, dtype=np.float32))
    agents = {"DDPG": DDPG(obs_dim, act_dim, DDPGConfig()), "TD3": TD3(obs_dim, act_dim, TD3Config())}
    times: dict[str, list[float]] = {name: [] for name in agents}
    for repeat in range(settings.repeats):
        for name in (list(agents) if repeat % 2 == 0 else list(agents)[::-1]):
            start = time.perf_counter()
            agents[name].update_many(data, n)
            times[name].append((time.perf_counter() - start) / n)
    return [Measurement(f"{name} gradient steps/s (batch 64, 2x256)", 1.0 / float(np.median(times[name])),
                        "updates/s", "one torch thread") for name in agents]
