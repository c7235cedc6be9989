"""The algorithm registry: command-line names -> heuristic functions.

``cfopt run``, the audit and the sweeps look algorithms up here, so a heuristic added to
:data:`ALGORITHMS` is available everywhere.  Every entry takes ``(mission, *, seed=None,
order="index", ...)`` and returns a :class:`heuristics.Run`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any

from cfopt import Mission, MissionError
from cfopt.checks import shown
from cfopt.errors import MissionTypeError
from heuristics._run import Run
from heuristics.grape_s import grape_s
from heuristics.grape_s_select import grape_s_select
from heuristics.pair_grape_s import pair_grape_s
from heuristics.pair_grape_s_chain import pair_grape_s_chain
from heuristics.rachna import rachna_dt
from heuristics.sda import sda

__all__ = ["ALGORITHMS", "algorithm_names", "get_algorithm", "run_algorithm"]

Algorithm = Callable[..., Run]

#: Name -> function, read-only: the seed's four algorithms, then cfopt's own.
ALGORITHMS: Mapping[str, Algorithm] = MappingProxyType(
    {
        "grape-s": grape_s,
        "pair-grape-s": pair_grape_s,
        "sda": sda,
        "rachna-dt": rachna_dt,
        "pair-grape-s-chain": pair_grape_s_chain,
        "grape-s-select": grape_s_select,
    }
)


def algorithm_names() -> list[str]:
    """The registered names, sorted.

    >>> algorithm_names()
    ['grape-s', 'grape-s-select', 'pair-grape-s', 'pair-grape-s-chain', 'rachna-dt', 'sda']
    """
    return sorted(ALGORITHMS)


def get_algorithm(name: str) -> Algorithm:
    """The function registered as ``name``; :class:`cfopt.MissionError` listing the known
    names otherwise.

    >>> get_algorithm("grape-s").__name__
    'grape_s'
    >>> get_algorithm("grape")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: unknown algorithm 'grape' (known: grape-s, grape-s-select, ...)
    """
    if not isinstance(name, str):
        raise MissionTypeError(f"algorithm: must be a name (a string), got {shown(name)}")
    try:
        return ALGORITHMS[name]
    except KeyError:
        raise MissionError(
            f"unknown algorithm {name!r} (known: {', '.join(algorithm_names())})"
        ) from None


def run_algorithm(name: str, mission: Mission, **options: Any) -> Run:
    """Look ``name`` up and run it on ``mission`` with ``options``."""
    return get_algorithm(name)(mission, **options)
