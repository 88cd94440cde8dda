"""The benchmark as a library: its definition (`suite`), its metrics (`metrics`), running policies over episodes
(`runner`) and the leaderboard (`leaderboard`).

    from auv_mj.benchmark import run_suite, SUITE_V1
    results = run_suite("map-replan", [c for c in SUITE_V1 if c.tier == "hard"], episodes=5, workers=2)
    results_3d = run_suite("map-replan", episodes=5, workers=2, domain="auv3d")   # the 3-D suite, SUITE_3D_V3

The names below load their module on first use, so that `import auv_mj.benchmark.metrics` stays light (no torch).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_NAMES = {"SUITE_V1": "suite", "SUITE_3D_V1": "suite", "SUITE_3D_V2": "suite", "SUITE_3D_V3": "suite",
          "SUITES": "suite", "VERSIONS": "suite",
          "suite_for": "suite", "Cell": "suite",
          "fingerprint": "suite", "evaluate": "runner",
          "run_episode": "runner", "run_cell": "runner", "run_suite": "runner", "publish": "leaderboard",
          "read_board": "leaderboard", "LEADERBOARD": "leaderboard", "summarise": "metrics", "wilson": "metrics"}

__all__ = sorted(_NAMES)


def __getattr__(name: str) -> Any:
    if name not in _NAMES:
        raise AttributeError(f"module 'auv_mj.benchmark' has no attribute {name!r}")
    return getattr(import_module(f"auv_mj.benchmark.{_NAMES[name]}"), name)
