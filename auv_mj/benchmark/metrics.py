"""The benchmark's metrics: one definition of each, from episode records (`auv_mj.episode.episode_metrics` rows).

- `summarise`: a set of episodes' rates and means (success, collisions, clearances, time to the goal, return, and
  the tracking tasks' `mae_*`);
- `wilson`: the 95 % Wilson interval of a success rate;
- time efficiency against the oracle (`episode_efficiency`, SPL's form, Anderson et al. 2018), its split into path
  and speed (`efficiency_parts`, `decomposition`), and the paired comparison of two policies by seed
  (`paired_efficiency`, `bootstrap_mean`, `exact_mcnemar`);
- a suite cell's figures (`cell_summary`) and figures pooled over cells (`pooled`).

It reads plain dicts and imports neither torch nor matplotlib (a contract in pyproject.toml), so that an analysis
script can import it alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from auv_mj.episode import OUTCOMES


def _mean(values: list) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def success_rate(episodes: list[dict]) -> float | None:
    """The share of `episodes` that reached the goal; None where none has a success (tracking tasks report none)."""
    return _mean([e["success"] for e in episodes])


def summarise(episodes: list[dict]) -> dict:
    """Per-task summary of episode metrics (rates, means; time to goal over successful episodes). On a tracking task
    (no success: its episodes end by their schedule) success_rate and time_to_goal are None and its headline figures
    are the `mae_*`."""
    clearances = [e["min_clearance"] for e in episodes if e["min_clearance"] is not None]
    summary = {"episodes": len(episodes),
               "outcomes": {name: sum(e["outcome"] == name for e in episodes) for name in OUTCOMES},
               "success_rate": success_rate(episodes),
               "collision_rate": _mean([e["collision"] for e in episodes]),
               "safety_violation_rate": _mean([e["safety_violation"] for e in episodes]),
               "min_clearance": float(np.min(clearances)) if clearances else None,
               "median_min_clearance": float(np.median(clearances)) if clearances else None,
               "path_length": _mean([e["path_length"] for e in episodes]),
               "time_to_goal": _mean([e["time_to_goal"] for e in episodes if e["success"]]),
               "return": _mean([e["return"] for e in episodes]),
               "return_std": float(np.std([e["return"] for e in episodes]))}
    extra = sorted({k for e in episodes for k in e if k.startswith(("mae_", "max_"))})
    for key in extra:
        values = [e[key] for e in episodes if e.get(key) is not None]
        summary[key] = (float(np.max(values)) if key.startswith("max_") else float(np.mean(values))) \
            if values else None
    return summary


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of a success rate (Wilson 1927): sound at rates of 0 and 1, unlike the
    normal approximation; (0, 1) for no episodes."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def oracle_times(results: dict | None) -> dict[str, dict[int, float]]:
    """{cell: {seed: the oracle's time to the goal}} of an oracle results dict (its successes only)."""
    if not results:
        return {}
    return {name: {int(e["seed"]): float(e["time_to_goal"]) for e in cell.get("episodes", []) if e["success"]}
            for name, cell in results.get("cells", {}).items()}


def episode_efficiency(episode: dict, reference: dict[int, float]) -> float:
    """One episode's time efficiency (SPL's form, Anderson et al. 2018): the oracle's time on its seed over its
    own, capped at 1, on a success; 0 on a failure. `reference`: the oracle's times by seed (the seed in it)."""
    return min(1.0, reference[episode["seed"]] / episode["time_to_goal"]) if episode["success"] else 0.0


def efficiency_parts(episode: dict, oracle_episode: dict) -> tuple[float, float] | None:
    """Time efficiency on a success split in two, to tell a longer path from a slower flight: (path efficiency, the
    oracle's path length over the episode's; speed ratio, the episode's mean speed, path length / time to the goal,
    over the oracle's), on a seed both reached the goal on; None otherwise (or where a length or time is not
    positive). Their product is the oracle's time over the episode's, uncapped (`episode_efficiency` before its cap):
    (L_o / L) (L / T) / (L_o / T_o) = T_o / T."""
    if not (episode["success"] and oracle_episode["success"]):
        return None
    length, time = episode["path_length"], episode["time_to_goal"]
    oracle_length, oracle_time = oracle_episode["path_length"], oracle_episode["time_to_goal"]
    if None in (length, time, oracle_length, oracle_time) or min(length, time, oracle_length, oracle_time) <= 0:
        return None
    return oracle_length / length, (length / time) / (oracle_length / oracle_time)


def decomposition(results: dict, oracle: dict, cells: Sequence[str]) -> dict | None:
    """`efficiency_parts` pooled over the cells `cells` of a results dict against the oracle's, paired by seed within
    each cell (the seeds both hold and both reached the goal on): {"path_efficiency", "speed_ratio",
    "time_efficiency" (uncapped, the per-seed product), the means over those seeds, and "seeds", how many}; None
    where there is no such seed."""
    parts: list[tuple[float, float]] = []
    for name in cells:
        ours = results.get("cells", {}).get(name, {}).get("episodes", [])
        theirs = {int(e["seed"]): e for e in oracle.get("cells", {}).get(name, {}).get("episodes", [])}
        for episode in ours:
            reference = theirs.get(int(episode["seed"]))
            split = efficiency_parts(episode, reference) if reference is not None else None
            if split is not None:
                parts.append(split)
    if not parts:
        return None
    path, speed = np.array(parts).T
    return {"path_efficiency": float(path.mean()), "speed_ratio": float(speed.mean()),
            "time_efficiency": float((path * speed).mean()), "seeds": len(parts)}


def paired_efficiency(a: dict, b: dict, references: dict[str, dict[int, float]],
                      cells: Sequence[str] | None = None) -> np.ndarray:
    """Per-seed differences of time efficiency, A - B, over the cells both results dicts hold (`cells` only, if
    given) and the seeds both ran that the oracle reached the goal on (`references`, as `oracle_times`)."""
    diffs: list[float] = []
    for name, cell in a.get("cells", {}).items():
        if name not in b.get("cells", {}) or (cells is not None and name not in cells):
            continue
        ref = references.get(name, {})
        other = {e["seed"]: e for e in b["cells"][name].get("episodes", [])}
        diffs += [episode_efficiency(e, ref) - episode_efficiency(other[e["seed"]], ref)
                  for e in cell.get("episodes", []) if e["seed"] in ref and e["seed"] in other]
    return np.array(diffs)


def exact_mcnemar(only_a: int, only_b: int) -> float:
    """The two-sided exact McNemar p-value of a paired success comparison: the binomial test of `only_a` against
    `only_b` discordant pairs (seeds only one side reached the goal on) at 1/2 (McNemar 1947, exact form)."""
    n = only_a + only_b
    tail = sum(math.comb(n, k) for k in range(min(only_a, only_b) + 1)) / 2 ** n
    return min(1.0, 2.0 * tail)


def bootstrap_mean(values: np.ndarray, resamples: int = 5000, seed: int = 0) -> tuple[float, float, float]:
    """The mean of `values` and its 95 % percentile-bootstrap interval (`resamples` resamples, seeded)."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        raise ValueError("bootstrap_mean: no values")
    means = np.random.default_rng(seed).choice(values, (resamples, values.size)).mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return float(values.mean()), float(low), float(high)


def cell_summary(rows: list[dict], reference: dict[int, float] | None) -> dict:
    """A cell's figures (module docstring) from its episode rows; `reference` the oracle's times by seed."""
    summary = summarise(rows) if rows else {"episodes": 0, "outcomes": {}}
    wins = sum(bool(r["success"]) for r in rows)
    summary["success_ci95"] = list(wilson(wins, len(rows)))
    summary["timeout_rate"] = summary["outcomes"].get("timeout", 0) / len(rows) if rows else None
    scored = [r for r in rows if reference and r["seed"] in reference]
    summary["time_efficiency"] = float(np.mean([episode_efficiency(r, reference) for r in scored])) \
        if scored else None
    summary["time_efficiency_episodes"] = len(scored)
    return summary


def pooled(results: dict, names: Sequence[str]) -> dict:
    """Figures over the episodes of the cells `names` of a results dict (those it has)."""
    cells = [results["cells"][n] for n in names if n in results.get("cells", {})]
    episodes = [e for c in cells for e in c["episodes"]]
    n = len(episodes)
    wins = [e for e in episodes if e["success"]]
    efficiency = [(c["summary"]["time_efficiency"], c["summary"]["time_efficiency_episodes"]) for c in cells
                  if c["summary"].get("time_efficiency") is not None]
    weight = sum(w for _, w in efficiency)
    clearances = [e["min_clearance"] for e in episodes if e["min_clearance"] is not None]
    return {"episodes": n, "success": len(wins) / n if n else None, "ci95": wilson(len(wins), n),
            "collision": sum(e["outcome"] == "collision" for e in episodes) / n if n else None,
            "timeout": sum(e["outcome"] == "timeout" for e in episodes) / n if n else None,
            "time_to_goal": float(np.mean([e["time_to_goal"] for e in wins])) if wins else None,
            "time_efficiency": sum(v * w for v, w in efficiency) / weight if weight else None,
            "min_clearance": float(np.min(clearances)) if clearances else None}
