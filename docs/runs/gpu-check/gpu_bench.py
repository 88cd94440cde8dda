"""Device check (issue 45 part 6): the batched env on 1-16 threads, and PPO's update on the GPU against the CPU."""
import dataclasses
import json
import os
import time

import numpy as np
import torch

out = os.environ.get("OUT", "/tmp")
QUICK = bool(os.environ.get("QUICK"))
SIZES, THREADS, SECONDS, N = ((16,), (1, 2), 0.3, 16) if QUICK else ((256, 1024), (1, 2, 4, 8, 16), 3.0, 256)
results = {"cpus": os.cpu_count(), "torch": torch.__version__, "cuda": torch.cuda.is_available()}

from auv_mj.speed.vector import batch_rate, physics_limit  # noqa: E402

for case, kwargs in (("goal", {}), ("obstacles", {"arena": "random", "tier": "hard"})):
    rows = {"physics_limit_1_thread": physics_limit(case, kwargs, 2.0)}
    for size in (SIZES if case == "goal" else SIZES[:1]):
        for threads in THREADS:
            rows[f"N={size} threads={threads}"] = batch_rate(case, kwargs, size, threads, SECONDS)
            print(case, size, threads, rows[f"N={size} threads={threads}"], flush=True)
    results[case] = rows

from auv_mj.agents.ppo import Collector, PPOConfig, build_model, env_spec, make_optimizer, update  # noqa: E402
from auv_mj.tasks.vector import AUVVectorEnv  # noqa: E402

env = AUVVectorEnv("obstacles", N, {"arena": "random", "tier": "hard"}, threads=min(16, os.cpu_count()))
timing = {}
for recurrent in ("gru", None):
    config = PPOConfig(num_steps=16 if QUICK else 128, num_minibatches=8, update_epochs=4, recurrent=recurrent, seed=0,
                       hidden_sizes=(256, 256))
    spec = env_spec(env.single_observation_space, env.single_action_space)
    model = build_model(spec, config)
    gen = torch.Generator().manual_seed(0)
    collector = Collector(env, model, spec, config, gen)
    collector.reset(list(range(N)))
    t0 = time.perf_counter()
    rollout = collector.rollout(config.num_steps)
    collect = time.perf_counter() - t0
    for device in ("cpu", "cuda") if torch.cuda.is_available() else ("cpu",):
        for threads in ((1, min(16, os.cpu_count())) if device == "cpu" else (1,)):
            torch.set_num_threads(threads)
            cfg = dataclasses.replace(config, device=device)
            m = build_model(spec, cfg)
            opt = make_optimizer(m, cfg)
            r = dataclasses.replace(rollout, **{f.name: getattr(rollout, f.name).to(device)
                                                for f in dataclasses.fields(rollout)})
            g = torch.Generator(device=device).manual_seed(0)
            update(m, opt, r, cfg, g)  # warm-up
            if device == "cuda":
                torch.cuda.synchronize()
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                update(m, opt, r, cfg, g)
                if device == "cuda":
                    torch.cuda.synchronize()
                times.append(time.perf_counter() - t0)
            key = f"{recurrent or 'mlp'} {device} threads={threads}"
            timing[key] = float(np.median(times))
            print(key, timing[key], "collect", collect, flush=True)
results["ppo_update_seconds"] = timing
results["ppo_rollout"] = "256 envs x 128 steps, 4 epochs x 8 minibatches, hidden (256, 256)"
json.dump(results, open(os.path.join(out, "gpu_bench.json"), "w"), indent=1)
print(json.dumps(results, indent=1))
