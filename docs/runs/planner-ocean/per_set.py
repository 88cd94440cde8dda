"""Per-set paired differences of the ocean-trained candidates against `map-replan` and the shipped
`planner-general` on the validation seeds, in ideal and in ocean water (docs/runs/planner-ocean/selection.md).

    python docs/runs/planner-ocean/per_set.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from auv_mj.cli.benchmark import bootstrap_mean, episode_efficiency

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "planner-top" / "validation_fixed"))
from analyse import REFERENCE, load  # noqa: E402

WATERS = {"ideal": (HERE / "validation_ideal", REFERENCE),
          "ocean": (HERE / "validation_ocean", HERE / "reference_ocean")}


def main() -> None:
    for water, (folder, reference) in WATERS.items():
        ref = {**load(reference, "open_ref.json"), **load(reference, "tunnel_ref.json")}
        shipped = {**load(reference, "open_pg.json"), **load(reference, "tunnel_pg.json")}
        oracle = {t: {r["seed"]: r["time_to_goal"] for r in ref[t]["oracle"] if r["success"]} for t in ref}
        bases = {"map-replan": ref, "planner-general": shipped}
        for name in ("ocean0_final", "ocean1_final"):
            cells = load(folder, f"*_{name}.json")
            for task, by_policy in cells.items():
                mine = {r["seed"]: episode_efficiency(r, oracle[task]) for r in next(iter(by_policy.values()))
                        if r["seed"] in oracle[task]}
                parts = []
                for base, src in bases.items():
                    theirs = {r["seed"]: episode_efficiency(r, oracle[task]) for r in src[task][base]}
                    d = np.array([e - theirs[s] for s, e in mine.items() if s in theirs])
                    mean, low, high = bootstrap_mean(d)
                    parts.append(f"minus {base} {mean:+.3f} [{low:+.3f}, {high:+.3f}]")
                print(f"{water} {name} {task}: {np.mean(list(mine.values())):.3f}, " + ", ".join(parts))


if __name__ == "__main__":
    main()
