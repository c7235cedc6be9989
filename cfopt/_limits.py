"""What fits on this machine: sizes that cannot fit in memory are refused up front, and
so are time limits the clocks cannot hold (:data:`MAX_TIME_LIMIT`).

A request whose arrays would not fit in the machine's physical memory is bad input, not
a crash: it is refused with a :class:`~cfopt.MissionError` that says how much memory it
would need, before anything is allocated.
"""

from __future__ import annotations

import os

from cfopt.errors import MissionError

__all__ = [
    "CONNECT_TIMEOUT",
    "MAX_TIME_LIMIT",
    "format_bytes",
    "physical_memory",
    "require_memory",
]

#: The longest time limit an exact solve takes, in seconds (about 31 years; the
#: operating system's timers end not far beyond, from about 9.2e9 s).  No limit at all
#: is ``None`` in the Python API.
MAX_TIME_LIMIT = 1e9

#: Seconds for a dask scheduler to answer (TCP connection, dask's handshake, its first
#: answer), and to reconnect to one that went away, before giving up
#: (:mod:`cfopt.cluster`).
CONNECT_TIMEOUT = 5.0

#: Used when the operating system does not say how much memory there is.
_FALLBACK_MEMORY = 2**34


def physical_memory() -> int:
    """The machine's physical memory in bytes (16 GiB when the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return _FALLBACK_MEMORY


def format_bytes(count: float) -> str:
    """A byte count for people.

    >>> format_bytes(512), format_bytes(3 * 2**30), format_bytes(1.6e24)
    ('512 B', '3.0 GiB', '1.3 YiB')
    """
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB", "YiB")
    value = float(count)
    for unit in units[:-1]:
        if value < 1024:
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{value:.1f} {units[-1]}" if value < 1000 else f"{value:.2g} {units[-1]}"


def require_memory(needed: float, what: str, *, cli: str | None = None) -> None:
    """Raise :class:`MissionError` when ``needed`` bytes exceed the physical memory.

    ``what`` starts the message (the place, e.g. ``"robots: 10**22 robots"``); ``cli`` is
    the command-line wording of the same place.

    >>> require_memory(1e30, "robots: 10**22 robots")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: robots: 10**22 robots would need about ... YiB of memory; ...
    """
    available = physical_memory()
    if needed <= available:
        return
    tail = (
        f" would need about {format_bytes(needed)} of memory; "
        f"this machine has {format_bytes(available)}"
    )
    raise MissionError(what + tail, cli=(cli or what) + tail)
