"""Hypothesis profiles of the fuzz suite (`test_fuzz.py`).

"fast" (the default, in the test command): few examples per surface, derandomised, so the suite stays quick
and every run tries the same inputs. "long" (`HYPOTHESIS_PROFILE=long`): many fresh random examples per
surface, for a run on demand. Neither keeps an example database in the checkout.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

SLOW_IS_FINE = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]
settings.register_profile("fast", max_examples=12, deadline=None, derandomize=True, database=None,
                          suppress_health_check=SLOW_IS_FINE, print_blob=True)
settings.register_profile("long", max_examples=400, deadline=None, database=None,
                          suppress_health_check=SLOW_IS_FINE, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fast"))
