"""Facts shared by several sections: the paper's tables, its named scenarios, held-out seeds, number format."""

from __future__ import annotations

import math

from auv_mj.benchmark import runner

PAPER_TABLE9 = {  # Table 9: MAE of speed [m/s] and heading [rad] per disturbance phase
    "splane": {"instantaneous": (0.0089, 0.0080), "constant": (0.0460, 0.0028), "periodic": (0.0421, 0.0448)},
    "executor": {"instantaneous": (0.0032, 0.0041), "constant": (0.0174, 0.0001), "periodic": (0.0045, 0.0030)},
}


PAPER_TRACKING = {  # Tables 10-11: (MAE speed, MAE heading, MAX speed, MAX heading)
    "path_line": (0.00703, 0.02618, 0.03034, 0.04697),
    "path_curve": (0.01025, 0.03201, 0.05763, 0.07950),
}


SCENARIOS = (  # (label, paper table, task, task kwargs)
    ("goal a1", "Table 6 (a)1", "goal", {"scenario": "a1"}),
    ("goal a2", "Table 6 (a)2", "goal", {"scenario": "a2"}),
    ("goal a3", "Table 6 (a)3", "goal", {"scenario": "a3"}),
    ("waypoints b1", "Table 6 (b)1", "waypoints", {"layout": "b1"}),
    ("waypoints b2", "Table 6 (b)2", "waypoints", {"layout": "b2"}),
    ("waypoints c", "Table 6 (c), Fig. 9c", "waypoints", {"layout": "c"}),
    ("waypoints d", "Table 6 (d), Fig. 9d", "waypoints", {"layout": "d"}),
    ("obstacles a", "Table 7 a", "obstacles", {"scenario": "a"}),
    ("obstacles b", "Table 7 b", "obstacles", {"scenario": "b"}),
    ("moving a", "Table 8 a", "moving_obstacles", {"scenario": "a"}),
    ("moving b", "Table 8 b", "moving_obstacles", {"scenario": "b"}),
    ("tunnel", "Table 12", "tunnel", {}),
)


TRACKING_POLICIES = ("los-executor", "splane")


CONDITIONS = ("ideal", "ocean")


HELD_OUT_SEED = 10_000
"""First seed of the held-out layouts (never used in training)."""


def fmt(value: float, digits: int = 4) -> str:
    """`value` to `digits` decimals, "n/a" for None or NaN."""
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def tracking_errors(name: str, task: str, conditions: str = "ideal") -> tuple[float, ...]:
    """(MAE speed, MAE heading, MAX speed, MAX heading, cross-track MAE) of one episode, once on the path
    (the steps the task marks `tracked`: `auv_mj.episode.episode_metrics`)."""
    m = runner.run_episode(name, task, 0, {"conditions": conditions})
    return m["mae_speed"], m["mae_heading"], m["max_speed"], m["max_heading"], m["mae_cross_track"]
