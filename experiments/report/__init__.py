"""The reproduction report (`auv-mj reproduce`): one module per section, each registered with `@section(name)`
(`registry.py`), in the order imported here; `common.py` holds what several sections share (the paper's tables
and scenarios, held-out seeds).

Adding a section is one module with one `@section` function, imported below.
"""

# The import order is the report's order: each module registers its sections as it is imported.
from experiments.report import (  # noqa: F401, I001
    table9,
    tracking,
    fig8,
    training_speed,
    scenarios,
    random_targets,
    generalisation,
    heldout,
    ocean,
    executors,
    tiers,
)
from experiments.report.registry import SECTIONS, ReportSettings, section

__all__ = ["SECTIONS", "ReportSettings", "section"]
