"""Which protocol an algorithm stands for: the one place above the transports where a
distributed algorithm is found by name.

:func:`protocol_for` turns what :func:`heuristics.simulate` and :func:`heuristics.mpi_run`
are given -- a registered name or ``MODULE:ATTR`` with the agents' options (its
:class:`heuristics.AlgorithmSpec`'s :meth:`~heuristics.AlgorithmSpec.make_protocol`), or
a :class:`heuristics.agents.Protocol` object -- into a protocol; the transports never see
a name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cfopt import MissionError
from cfopt.checks import shown
from cfopt.errors import MissionTypeError
from heuristics.agents.protocol import Protocol
from heuristics.registry import get_algorithm

__all__ = ["protocol_for"]


def protocol_for(algorithm: Any, options: Mapping[str, Any] | None = None) -> Protocol:
    """The protocol ``algorithm`` stands for: a name's (built with ``options``), or the
    object itself.

    Raises :class:`cfopt.MissionError` naming ``algorithm`` (a name without agents, a
    wrong type) or ``options`` (one the agents do not take, or options with an object).

    >>> protocol_for("sda", {"resend_tries": 3}).resend_tries
    3
    >>> protocol_for("rachna-dt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: algorithm: 'rachna-dt' has no distributed agents (available: ...)
    """
    if options is not None and not isinstance(options, Mapping):
        raise MissionTypeError(
            f"options: must be a mapping of the agents' options or None, got {shown(options)}"
        )
    if isinstance(algorithm, Protocol):
        if options:
            raise MissionError(
                f"options: only with an algorithm's name; a protocol object takes its "
                f"options when it is built, got {sorted(options)}"
            )
        return algorithm
    if not isinstance(algorithm, str):
        raise MissionTypeError(
            "algorithm: must be an algorithm's name or a heuristics.agents.Protocol, "
            f"got {shown(algorithm)}"
        )
    protocol = get_algorithm(algorithm).make_protocol(**dict(options or {}))
    if not isinstance(protocol, Protocol):
        raise MissionError(
            f"algorithm: {algorithm}'s protocol must be a heuristics.agents.Protocol, "
            f"got {shown(protocol)}"
        )
    return protocol
