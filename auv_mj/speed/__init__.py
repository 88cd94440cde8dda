"""How fast auv-mj runs (`auv-mj bench`): the simulator, the tasks, the renderer, the learners, the batched envs
and training with collector processes, each beside its limit, as a library a script can call.

Speed, not skill: how well a policy does is `auv_mj.benchmark`. The sections and their registry are
`auv_mj.speed.sections`; a module per thing measured holds its sections (`sim`, `tasks`, `render`, `learners`,
`vector`, `vector3d`, `collectors`). `auv_mj.speed.run_bench(["physics"], auv_mj.speed.BenchSettings(repeats=3))`
runs sections from Python, as `auv-mj bench --sections physics --repeats 3` does; the names here load on first use
(PEP 562), so that `import auv_mj.speed.vector` does not import every section.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["BenchSettings", "Measurement", "bench_payload", "default_sections", "load_sections", "run_bench",
           "section"]


def __getattr__(name: str) -> Any:
    """The bench's public names, from `auv_mj.speed.sections` on first use (PEP 562)."""
    if name in __all__:
        return getattr(importlib.import_module("auv_mj.speed.sections"), name)
    raise AttributeError(f"module 'auv_mj.speed' has no attribute {name!r}")
