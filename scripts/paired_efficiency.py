"""Two policies' time efficiency paired by seed over `auv-mj benchmark` results (issue 30).

For every cell both results hold (filtered by --tier / --water) and every seed the oracle reached the goal on,
the difference A - B of the per-episode time efficiency (oracle time / own time, capped at 1; 0 on a failure, as
`auv_mj.cli.benchmark.cell_summary` scores it), its mean, a 95 % bootstrap interval (seeded) and the seeds each
policy was the faster on.

    python scripts/paired_efficiency.py runs/hard100/planner-general/results.json \
        runs/hard100/map-replan/results.json --oracle runs/hard100/oracle/results.json --tier hard --water ideal
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from auv_mj.cli.benchmark import oracle_times


def _score(episode: dict, reference: dict[int, float]) -> float:
    return min(1.0, reference[episode["seed"]] / episode["time_to_goal"]) if episode["success"] else 0.0


def paired(a: dict, b: dict, oracle: dict, tier: str | None, water: str | None) -> np.ndarray:
    """The per-seed differences of time efficiency, A - B."""
    references = oracle_times(oracle)
    diffs = []
    for name, cell in a["cells"].items():
        if name not in b["cells"] or (tier and cell["tier"] != tier) or (water and cell["water"] != water):
            continue
        ref = references.get(name, {})
        other = {e["seed"]: e for e in b["cells"][name]["episodes"]}

        diffs += [_score(e, ref) - _score(other[e["seed"]], ref) for e in cell["episodes"] if e["seed"] in ref
                  and e["seed"] in other]
    return np.array(diffs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    parser.add_argument("--oracle", type=Path, required=True)
    parser.add_argument("--tier")
    parser.add_argument("--water")
    parser.add_argument("--resamples", type=int, default=5000)
    args = parser.parse_args()
    a, b, oracle = (json.loads(p.read_text()) for p in (args.a, args.b, args.oracle))
    d = paired(a, b, oracle, args.tier, args.water)
    if d.size == 0:
        raise SystemExit("no seeds in common (check --tier / --water and the files)")
    rng = np.random.default_rng(0)
    means = rng.choice(d, (args.resamples, d.size)).mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    print(f"{a['policy']} - {b['policy']}: {d.size} seeds, mean {d.mean():+.3f} [{low:+.3f}, {high:+.3f}] "
          f"(95 % bootstrap); {a['policy']} faster on {(d > 0).sum()}, {b['policy']} on {(d < 0).sum()}")


if __name__ == "__main__":
    main()
