"""Hypothesis profiles: ``ci`` (derandomized, bounded) and ``dev`` (the default).

Select one with ``HYPOTHESIS_PROFILE=ci pytest``; when the variable is unset, CI runs
(``CI`` set, as in ``.ci/run``) use ``ci`` and everything else uses ``dev``.

A suite started in the background of a non-interactive shell (``bash .ci/run &``, nohup)
inherits SIGINT ignored, and so would every command the tests start: Python keeps an
ignored SIGINT ignored, so the tests that press Ctrl-C would see a command that does not
stop. The suite restores Python's default handler, which its children then start with.
"""

import os
import signal

from hypothesis import HealthCheck, settings

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

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
