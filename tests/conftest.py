"""Hypothesis profiles: ``ci`` (derandomized, bounded) and ``dev`` (the default).

Select one with ``HYPOTHESIS_PROFILE=ci pytest``; when the variable is unset, CI runs
(``CI`` set, as in ``.ci/run``) use ``ci`` and everything else uses ``dev``.
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=60,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "dev",
    max_examples=100,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(
    os.environ.get("HYPOTHESIS_PROFILE") or ("ci" if os.environ.get("CI") else "dev")
)
