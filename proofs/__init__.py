"""Verification of coalition-formation partitions, independent of ``heuristics``.

:func:`nash_violations` and :func:`pairwise_violations` return concrete, replayable
deviations (empty list: stable); :func:`is_nash_stable` and :func:`is_pairwise_stable`
answer yes or no.  ``proofs.strategies`` holds hypothesis strategies for missions and
assignments (it needs the ``test`` extra, hypothesis; ``import proofs`` does not).

>>> import cfopt, proofs
>>> m = cfopt.Mission.from_arrays([[1], [1]], [[1], [1]], [1.0, 1.0])
>>> proofs.is_nash_stable(m, cfopt.Assignment(task=[0, 1], service=[0, 0]))
True
"""

from __future__ import annotations

import importlib
from typing import Any

from proofs.stability import (
    MODES,
    Move,
    NashViolation,
    PairwiseViolation,
    is_nash_stable,
    is_pairwise_stable,
    nash_violations,
    pairwise_violations,
)

__all__ = [
    "MODES",
    "Move",
    "NashViolation",
    "PairwiseViolation",
    "is_nash_stable",
    "is_pairwise_stable",
    "nash_violations",
    "pairwise_violations",
    "strategies",
]


def __getattr__(name: str) -> Any:
    # ``proofs.strategies`` imports hypothesis, a test extra: load it on first use only.
    if name == "strategies":
        return importlib.import_module("proofs.strategies")
    raise AttributeError(f"module 'proofs' has no attribute {name!r}")
