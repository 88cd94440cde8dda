"""Validation of the fixed-speed fine-tuning runs (fx0, fx1; issue 30): each candidate's time efficiency per set and
its paired difference, with a 95 % bootstrap interval, against `map-replan` and the shipped `planner-general` on
the same validation seeds. The candidates' episodes are the JSON files beside this script
(`experiments/benchmark_tiers.py --seed 20000 --policies CHECKPOINT`); the references are those of `../validation_230/`.

    python docs/runs/planner-top/validation_fixed/analyse.py
    python docs/runs/planner-top/validation_fixed/analyse.py FOLDER NAME...   # other candidates: FOLDER/*_NAME.json
    python docs/runs/planner-top/validation_fixed/analyse.py FOLDER NAME... --reference DIR   # other references
    python docs/runs/planner-top/validation_fixed/analyse.py FOLDER NAME... --per-set   # each set's difference too

A reference folder holds `open_ref.json` and `tunnel_ref.json` (the oracle and `map-replan`) and `open_pg.json` and
`tunnel_pg.json` (`planner-general`), all on the candidates' seeds and water.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.benchmark.metrics import bootstrap_mean, episode_efficiency

HERE = Path(__file__).parent
REFERENCE = HERE.parent / "validation_230"
CANDIDATES = ("fixed0_snaps_ep40", "fixed0_snaps_ep70", "fixed0_snaps_final", "fixed1_snaps_ep41",
              "fixed1_snaps_ep71", "fixed1_snaps_final", "fixed0_long180k", "fixed1_long180k")


def load(folder: Path, pattern: str) -> dict:
    """Task -> policy -> cell of the result files matching `pattern`, their rows pooled."""
    merged: dict = {}
    for path in sorted(folder.glob(pattern)):
        for task, cells in json.loads(path.read_text()).items():
            for policy, cell in cells.items():
                merged.setdefault(task, {}).setdefault(policy, []).extend(cell["rows"])
    return merged


def difference(mine: dict, theirs: dict) -> str:
    """Mean [95 % bootstrap] of the per-seed differences of two {task: {seed: efficiency}}, on their common seeds."""
    d = np.array([e - theirs[t][s] for t, es in mine.items() for s, e in es.items() if s in theirs.get(t, {})])
    mean, low, high = bootstrap_mean(d)
    return f"{mean:+.3f} [{low:+.3f}, {high:+.3f}]"


def main(folder: Path = HERE, candidates: tuple[str, ...] = CANDIDATES, reference: Path = REFERENCE,
         per_set: bool = False) -> None:
    ref = {**load(reference, "open_ref.json"), **load(reference, "tunnel_ref.json")}
    shipped = {**load(reference, "open_pg.json"), **load(reference, "tunnel_pg.json")}
    oracle = {t: {r["seed"]: r["time_to_goal"] for r in ref[t]["oracle"] if r["success"]} for t in ref}

    def scores(rows: list[dict], task: str) -> dict[int, float]:
        return {r["seed"]: episode_efficiency(r, oracle[task]) for r in rows if r["seed"] in oracle[task]}

    bases = {"map-replan": {t: scores(ref[t]["map-replan"], t) for t in ref},
             "planner-general": {t: scores(shipped[t]["planner-general"], t) for t in shipped}}
    for name in candidates:
        cells = load(folder, f"*_{name}.json")
        mine = {t: scores(next(iter(c.values())), t) for t, c in cells.items()}
        failures = sum(not r["success"] for c in cells.values() for rows in c.values() for r in rows)
        parts = [f"{t} {np.mean(list(s.values())):.3f} ({len(s)})" for t, s in mine.items()]
        parts += [f"minus {base} {difference(mine, theirs)}" for base, theirs in bases.items()]
        print(f"{name}: " + ", ".join(parts) + f", failures {failures}")
        for task in mine if per_set else ():
            print(f"  {task}: " + ", ".join(f"minus {base} {difference({task: mine[task]}, theirs)}"
                                            for base, theirs in bases.items()))


if __name__ == "__main__":
    args = sys.argv[1:]
    where, per_set = REFERENCE, "--per-set" in args
    args = [a for a in args if a != "--per-set"]
    if "--reference" in args:
        k = args.index("--reference")
        where, args = Path(args[k + 1]), args[:k] + args[k + 2:]
    if len(args) > 1:
        main(Path(args[0]), tuple(args[1:]), where, per_set)
    else:
        main(reference=where, per_set=per_set)
