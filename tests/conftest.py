"""The test tree's set-up: its folders on the import path, and the Hypothesis profiles of the fuzz suite.

Tests live in folders that mirror the package (sim/, tasks/, agents/, ...; reference/ holds the independent models
the physics is checked against). pytest imports each test module by its file name, and some import another's
helpers (the reference models, test_agents' tiny goal task), so every folder of tests/ is put on the path; file
names are unique across the tree.

Hypothesis profiles of the fuzz suite (`cli/test_fuzz.py`).

"fast" (the default, in the test command): few examples per surface, derandomised, so the suite stays quick
and every run tries the same inputs. "long" (`HYPOTHESIS_PROFILE=long`): many fresh random examples per
surface, for a run on demand. Neither keeps an example database in the checkout.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from hypothesis import HealthCheck, settings

for folder in sorted(p for p in Path(__file__).parent.iterdir() if p.is_dir() and not p.name.startswith(("_", "."))
                     and p.name != "data"):
    if str(folder) not in sys.path:
        sys.path.insert(0, str(folder))

SLOW_IS_FINE = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]
settings.register_profile("fast", max_examples=12, deadline=None, derandomize=True, database=None,
                          suppress_health_check=SLOW_IS_FINE, print_blob=True)
settings.register_profile("long", max_examples=400, deadline=None, database=None,
                          suppress_health_check=SLOW_IS_FINE, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fast"))
