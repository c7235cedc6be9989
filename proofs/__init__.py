"""Verification of coalition-formation partitions, independent of ``heuristics``.

:func:`nash_violations` and :func:`pairwise_violations` return concrete, replayable
deviations (empty list: stable); :func:`is_nash_stable` and :func:`is_pairwise_stable`
answer yes or no.  ``proofs.strategies`` holds hypothesis strategies for missions and
assignments (it needs the ``test`` extra, hypothesis; ``import proofs`` does not).

Claims: :mod:`proofs.claimkit` states and checks a claim about any algorithm,
:func:`register_claim` adds one to the registry the audit checks
(:data:`proofs.claims.CLAIMS`); both load on first use.

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
    "claimkit",
    "is_nash_stable",
    "is_pairwise_stable",
    "nash_violations",
    "pairwise_violations",
    "register_claim",
    "strategies",
]

#: Loaded on first use: ``strategies`` imports hypothesis (a test extra), the claims'
#: modules build every claim.
_LAZY = {
    "strategies": ("proofs.strategies", None),
    "claimkit": ("proofs.claimkit", None),
    "register_claim": ("proofs.claims", "register_claim"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attribute = _LAZY[name]
        loaded = importlib.import_module(module)
        return loaded if attribute is None else getattr(loaded, attribute)
    raise AttributeError(f"module 'proofs' has no attribute {name!r}")
