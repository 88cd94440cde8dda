"""The 230-episode validation of planner-general's two deployments (issue 30): success, time efficiency and the
paired differences with their 95 % bootstrap intervals, from the JSON files beside this script
(`experiments/benchmark_tiers.py --seed 20000`, validation seeds).

    python docs/runs/planner-top/validation_230/analyse.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from auv_mj.benchmark.metrics import bootstrap_mean, episode_efficiency

HERE = Path(__file__).parent
PAIRS = (("planner-general", "planner-general-speed"), ("planner-general", "map-replan"),
         ("planner-general-speed", "map-replan"))


def load(*names: str) -> dict:
    """The tasks of the named result files, merged."""
    merged: dict = {}
    for name in names:
        merged.update(json.loads((HERE / name).read_text()))
    return merged


def main() -> None:
    ref, ours = load("open_ref.json", "tunnel_ref.json"), load("open_pg.json", "tunnel_pg.json")
    efficiency: dict[str, dict[str, dict[int, float]]] = {}
    for task in ref:
        oracle = {r["seed"]: r["time_to_goal"] for r in ref[task]["oracle"]["rows"] if r["success"]}
        cells = {"map-replan": ref[task]["map-replan"]["rows"], **{p: c["rows"] for p, c in ours[task].items()}}
        for policy, rows in cells.items():
            scores = {r["seed"]: episode_efficiency(r, oracle) for r in rows if r["seed"] in oracle}
            efficiency.setdefault(policy, {})[task] = scores
            print(f"{task} {policy}: success {np.mean([r['success'] for r in rows]):.2f}, time efficiency "
                  f"{np.mean(list(scores.values())):.3f} ({len(rows)} episodes)")
    for a, b in PAIRS:
        for task in [None, *efficiency[a]]:
            tasks = list(efficiency[a]) if task is None else [task]
            d = np.array([efficiency[a][t][s] - efficiency[b][t][s] for t in tasks for s in efficiency[a][t]
                          if s in efficiency[b][t]])
            mean, low, high = bootstrap_mean(d)
            print(f"{a} - {b} [{task or 'all'}]: {d.size} seeds, {mean:+.3f} [{low:+.3f}, {high:+.3f}]")


if __name__ == "__main__":
    main()
