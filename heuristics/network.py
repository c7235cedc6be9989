"""The network of the discrete-event simulator: topology, clocks and link physics.

Every robot of a mission runs its coalition-formation algorithm as a message-driven agent;
this module says who can hear whom (:class:`Network`), when each robot's clock ticks
(:class:`Clocks`) and what happens to a transmission on its way (:class:`Links`: a
latency per reception and a loss decision).  A network is described by one line, the
``--network`` spec (:meth:`NetworkSpec.parse`)::

    geometric radius=0.2 latency=uniform:1ms:5ms loss=ge:0.01:0.3:0.5 period=10ms

or by a network JSON file (``cfopt.network/1``, :meth:`NetworkSpec.from_dict`) holding
the same keys, in which a realised graph can be written down edge by edge and replayed
(:meth:`Network.to_dict`).

Time is simulated in integer nanoseconds (int64) everywhere.  Nothing here touches a
global random state: every draw comes from a :class:`numpy.random.Generator` passed in,
in the documented order, so the same spec, mission and generators give the same network,
ticks, delays and losses, byte for byte.

>>> import numpy as np
>>> from cfopt import Mission
>>> m = Mission.from_arrays(np.ones((6, 1), bool), [[1]], [1.0])
>>> spec = NetworkSpec.parse("ring latency=constant:2ms loss=0.1")
>>> net = spec.build(m, np.random.default_rng(0))
>>> net.diameter, net.neighbours(0).tolist(), net.next_hop(0, 3), net.hops(0, 3)
(3, [1, 5], 1, 3)
>>> links = Links(net, np.random.default_rng(1), np.random.default_rng(2))
>>> delays, lost = links.transmit(0, net.neighbours(0))
>>> delays.tolist()
[2000000, 2000000]
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from typing import Any

import networkx as nx
import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import KDTree

from cfopt._jsonio import (
    Source,
    check_keys,
    check_text,
    expect_list,
    expect_object,
    read_json,
)
from cfopt.checks import is_whole
from cfopt.errors import MissionError, describe, is_unicode, plural
from cfopt.mission import Mission
from heuristics._edgelist import EDGE_LIST_MEMORY_PER_BYTE, EdgeTable, read_edge_list
from heuristics._graphs import bfs_distances
from heuristics._graphs import diameter as exact_diameter

__all__ = [
    "AIR_ENCODINGS",
    "CHANNELS",
    "DEFAULT_QUEUE",
    "EDGE_LIST_MEMORY_PER_BYTE",
    "MAX_DELAY_NS",
    "MAX_DURATION_NS",
    "NETWORK_FORMAT",
    "TOPOLOGIES",
    "Clocks",
    "Latency",
    "Links",
    "Loss",
    "Network",
    "NetworkSpec",
    "format_bitrate",
    "format_duration",
    "parse_bitrate",
    "parse_duration",
]

NETWORK_FORMAT = "cfopt.network/1"
#: The topology names of the spec (``file`` is written ``file=PATH`` on the one line).
TOPOLOGIES = ("complete", "ring", "grid", "geometric", "er", "smallworld", "file")
#: The longest duration a spec may state (2**53 ns, about 104 days): exact as a float.
MAX_DURATION_NS = 2**53
#: Sampled latencies are clipped to this (2**62 ns, about 146 years), so that adding one
#: to any reasonable simulated time cannot overflow int64.
MAX_DELAY_NS = 2**62
#: How many times ``er`` redraws G(n, p) before giving up on a connected graph.
ER_DRAWS = 100
#: How many Watts-Strogatz graphs ``smallworld`` draws before giving up.
SMALLWORLD_TRIES = 100

_TOPOLOGY_PARAMS: Mapping[str, tuple[str, ...]] = {
    "complete": (),
    "ring": (),
    "grid": (),
    "geometric": ("radius",),
    "er": ("p",),
    "smallworld": ("k", "p"),
    "file": (),
}
_PARAM_USAGE = {"radius": "radius=R", "p": "p=P", "k": "k=K"}
_GENERAL_KEYS = ("latency", "loss", "medium", "period", "jitter", "sync")
#: The radio channel's keys (:mod:`heuristics.transport.channel`), after the others.
_CHANNEL_KEYS = ("bitrate", "channel", "queue", "encoding")
_SPEC_KEYS = (*_GENERAL_KEYS, *_CHANNEL_KEYS)
_MEDIA = ("broadcast", "unicast")
#: The channel models: one channel shared by robots in range, or one per link.
CHANNELS = ("shared", "per-link")
#: The belief encodings on the air (:mod:`heuristics.communication`).
AIR_ENCODINGS = ("full", "compact")
#: The default bound of a sender's queue, in frames waiting (the one on the air not counted).
DEFAULT_QUEUE = 16
_RATE_UNITS = {"Mbit/s": 10**6, "kbit/s": 10**3, "bit/s": 1}
_TOPOLOGY_LIST = "complete, ring, grid, geometric, er, smallworld or file=PATH"
#: Generated topologies whose realised graph :meth:`Network.to_dict` writes edge by edge.
_RANDOM_TOPOLOGIES = ("geometric", "er", "smallworld", "file")


class _Problem(Exception):
    """What is wrong with one value; the caller adds the place (a token or a key)."""


# ------------------------------------------------------------------------ values
_NUMBER = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d{1,4})?"
# re.ASCII: \d is 0-9 only (Python's \d, float() and int() also take other scripts' digits)
_NUMBER_RE = re.compile(rf"{_NUMBER}\Z", re.ASCII)
_DURATION_RE = re.compile(rf"({_NUMBER})(ns|us|ms|s)\Z", re.ASCII)
_WHOLE_RE = re.compile(r"\d{1,18}\Z", re.ASCII)
_UNITS = {"s": 10**9, "ms": 10**6, "us": 10**3, "ns": 1}
_LONGEST_TEXT = 64


def _duration(text: str) -> int:
    match = _DURATION_RE.match(text) if len(text) <= _LONGEST_TEXT else None
    if match is None:
        raise _Problem(
            f"{text!r} is not a duration: expected a number and a unit (ns, us, ms or s), "
            "e.g. '5ms'"
        )
    value = Fraction(match[1]) * _UNITS[match[2]]
    if value < 0:
        raise _Problem(f"durations must be >= 0, got {text}")
    if value.denominator != 1:
        raise _Problem(f"{text} is not a whole number of nanoseconds")
    if value > MAX_DURATION_NS:
        raise _Problem(
            f"{text} is longer than the longest duration cfopt simulates "
            f"({format_duration(MAX_DURATION_NS)}, about 104 days)"
        )
    return int(value)


def parse_duration(text: str) -> int:
    """A duration with its unit (``ns``, ``us``, ``ms`` or ``s``) in integer nanoseconds.

    The number may be decimal (``0.2s``) but must come to a whole number of nanoseconds,
    be >= 0 and at most :data:`MAX_DURATION_NS`; anything else is a
    :class:`~cfopt.MissionError` starting with the text.  O(len(text)).

    >>> parse_duration("5ms"), parse_duration("0.2s"), parse_duration("1.5us")
    (5000000, 200000000, 1500)
    >>> parse_duration("5")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: 5: '5' is not a duration: expected a number and a unit (ns, us, ms or s), e.g. '5ms'
    """  # noqa: E501
    try:
        return _duration(text)
    except _Problem as exc:
        raise MissionError(f"{text}: {exc}") from None


def format_duration(ns: int) -> str:
    """The canonical text of a duration: the largest unit that keeps it whole.

    >>> format_duration(0), format_duration(200_000_000), format_duration(1500)
    ('0ms', '200ms', '1500ns')
    >>> parse_duration(format_duration(123_456_789)) == 123_456_789
    True
    """
    ns = int(ns)
    if ns == 0:
        return "0ms"
    for unit, scale in _UNITS.items():
        if ns % scale == 0:
            return f"{ns // scale}{unit}"
    raise AssertionError("unreachable: every whole number is a whole number of ns")


_RATE_RE = re.compile(rf"({_NUMBER})(Mbit/s|kbit/s|bit/s)\Z", re.ASCII)


def _bitrate(text: str) -> int:
    match = _RATE_RE.match(text) if len(text) <= _LONGEST_TEXT else None
    if match is None:
        raise _Problem(
            f"{text!r} is not a bit rate: expected a number and a unit (bit/s, kbit/s or "
            "Mbit/s), e.g. '2Mbit/s'"
        )
    value = Fraction(match[1]) * _RATE_UNITS[match[2]]
    if value.denominator != 1 or value < 1:
        raise _Problem(f"the bit rate must be a whole number of bit/s >= 1, got {text}")
    if value > MAX_DURATION_NS:
        raise _Problem(f"the bit rate must be at most {MAX_DURATION_NS} bit/s, got {text}")
    return int(value)


def parse_bitrate(text: str) -> int:
    """A bit rate with its unit (``bit/s``, ``kbit/s`` or ``Mbit/s``) in whole bit/s.

    >>> parse_bitrate("2Mbit/s"), parse_bitrate("0.5kbit/s"), parse_bitrate("9600bit/s")
    (2000000, 500, 9600)
    """
    try:
        return _bitrate(text)
    except _Problem as exc:
        raise MissionError(f"{text}: {exc}") from None


def format_bitrate(bits_per_second: int) -> str:
    """The canonical text of a bit rate: the largest unit that keeps it whole.

    >>> format_bitrate(2_000_000), format_bitrate(54_500_000), format_bitrate(9600)
    ('2Mbit/s', '54500kbit/s', '9600bit/s')
    """
    rate = int(bits_per_second)
    for unit, scale in _RATE_UNITS.items():
        if rate % scale == 0:
            return f"{rate // scale}{unit}"
    raise AssertionError("unreachable: every whole number is a whole number of bit/s")


def _number(text: str, what: str) -> float:
    if len(text) > _LONGEST_TEXT or not _NUMBER_RE.match(text):
        raise _Problem(f"{what} must be a number, got {text!r}")
    value = float(text)
    if not math.isfinite(value):
        raise _Problem(f"{what} must be a finite number, got {text}")
    return value


def _number_text(value: float) -> str:
    """The shortest text that reads back as the same float (``0.1``, ``1e-05``)."""
    return repr(float(value))


def _is_real(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    )


def _in_range(value: Any, what: str, low: float, high: float, closed: str = "[]") -> str | None:
    """``None`` when ``value`` is a real number in the interval, else the problem."""
    shown = f"{closed[0]}{low:g}, {high:g}{closed[1]}"
    if not _is_real(value) or not math.isfinite(value):
        return f"{what} must be a number in {shown}, got {describe(value)}"
    too_low = value < low if closed[0] == "[" else value <= low
    too_high = value > high if closed[1] == "]" else value >= high
    if too_low or too_high:
        return f"{what} must be in {shown}, got {_number_text(value)}"
    return None


def _duration_problem(value: Any, what: str) -> str | None:
    if not is_whole(value):
        return f"{what} must be a whole number of nanoseconds, got {describe(value)}"
    if value < 0:
        return f"{what} must be >= 0, got {value} ns"
    if value > MAX_DURATION_NS:
        return f"{what} must be at most {MAX_DURATION_NS} ns (about 104 days), got {value}"
    return None


def _raise(problem: str | None, place: str) -> None:
    if problem is not None:
        raise MissionError(f"{place}: {problem}")


# ------------------------------------------------------------------------ latency
_LATENCY_ARGS: Mapping[str, tuple[str, ...]] = {
    "constant": ("D",),
    "uniform": ("A", "B"),
    "exponential": ("MEAN",),
    "lognormal": ("MEDIAN", "SIGMA"),
}
_LATENCY_FORMS = "constant:D, uniform:A:B, exponential:MEAN or lognormal:MEDIAN:SIGMA"


def _latency_problem(kind: Any, durations: Any, sigma: Any) -> str | None:
    if kind not in _LATENCY_ARGS:
        return f"unknown latency model {describe(kind)} (expected {_LATENCY_FORMS})"
    wanted = 1 if kind != "uniform" else 2
    if not isinstance(durations, tuple | list) or len(durations) != wanted:
        return f"{kind} latency takes {plural(wanted, 'duration')}, got {describe(durations)}"
    for value in durations:
        problem = _duration_problem(value, "a latency")
        if problem:
            return problem
    if kind == "uniform" and durations[0] > durations[1]:
        low, high = (format_duration(v) for v in durations)
        return f"the low bound {low} is above the high bound {high}"
    if kind == "lognormal":
        if durations[0] == 0:
            return "the lognormal median must be > 0"
        if not _is_real(sigma) or not math.isfinite(sigma) or sigma < 0:
            return f"the lognormal SIGMA must be a finite number >= 0, got {describe(sigma)}"
    elif sigma is not None:
        return f"only lognormal latency has a SIGMA, got {describe(sigma)}"
    return None


@dataclass(frozen=True)
class Latency:
    """The delay of one reception, in integer nanoseconds (frozen).

    Parameters
    ----------
    kind : {"constant", "uniform", "exponential", "lognormal"}
    durations_ns : tuple of int
        ``(D,)`` for constant, ``(A, B)`` for uniform on the whole nanoseconds of
        ``[A, B]``, ``(MEAN,)`` for exponential, ``(MEDIAN,)`` for lognormal; each
        between 0 and :data:`MAX_DURATION_NS`, ``A <= B`` and ``MEDIAN > 0``.
    sigma : float, optional
        The lognormal's shape (the standard deviation of the delay's logarithm), >= 0;
        ``None`` for the other kinds.

    Examples
    --------
    >>> lat = Latency.parse("uniform:1ms:5ms")
    >>> lat, lat.to_text()
    (Latency(kind='uniform', durations_ns=(1000000, 5000000), sigma=None), 'uniform:1ms:5ms')
    >>> lat.sample(np.random.default_rng(0), 3).dtype
    dtype('int64')
    >>> Latency.parse("lognormal:5ms:0.5").mean_ns
    5665742.26...
    """

    kind: str = "constant"
    durations_ns: tuple[int, ...] = (0,)
    sigma: float | None = None

    def __post_init__(self) -> None:
        _raise(_latency_problem(self.kind, self.durations_ns, self.sigma), "latency")
        object.__setattr__(self, "durations_ns", tuple(int(v) for v in self.durations_ns))
        if self.sigma is not None:
            object.__setattr__(self, "sigma", float(self.sigma))

    @classmethod
    def parse(cls, text: str) -> Latency:
        """Read ``constant:D``, ``uniform:A:B``, ``exponential:MEAN`` or
        ``lognormal:MEDIAN:SIGMA`` (durations with units, SIGMA a plain number).

        Bad text is a :class:`~cfopt.MissionError` starting with the text.
        """
        try:
            return cls._parse(text)
        except _Problem as exc:
            raise MissionError(f"{text}: {exc}") from None

    @classmethod
    def _parse(cls, text: str) -> Latency:
        kind, *args = text.split(":")
        if kind not in _LATENCY_ARGS:
            raise _Problem(
                f"unknown latency model {kind!r} (expected {_LATENCY_FORMS}, e.g. constant:5ms)"
            )
        names = _LATENCY_ARGS[kind]
        if len(args) != len(names):
            raise _Problem(f"expected {':'.join((kind, *names))}, got {text!r}")
        if kind == "lognormal":
            durations, sigma = (_duration(args[0]),), _number(args[1], "the lognormal SIGMA")
        else:
            durations, sigma = tuple(_duration(a) for a in args), None
        problem = _latency_problem(kind, durations, sigma)
        if problem:
            raise _Problem(problem)
        return cls(kind, durations, sigma)

    def to_text(self) -> str:
        """The canonical text, e.g. ``uniform:1ms:5ms`` or ``lognormal:5ms:0.5``."""
        parts = [self.kind, *(format_duration(v) for v in self.durations_ns)]
        if self.sigma is not None:
            parts.append(_number_text(self.sigma))
        return ":".join(parts)

    @property
    def is_fixed(self) -> bool:
        """Whether every delay is the same (then :meth:`sample` draws nothing)."""
        first = self.durations_ns[0]
        return (
            self.kind == "constant"
            or (self.kind == "uniform" and first == self.durations_ns[1])
            or (self.kind == "exponential" and first == 0)
            or (self.kind == "lognormal" and self.sigma == 0)
        )

    @property
    def mean_ns(self) -> float:
        """The mean delay in nanoseconds (before rounding to whole nanoseconds)."""
        first = self.durations_ns[0]
        if self.kind == "uniform":
            return (first + self.durations_ns[1]) / 2
        if self.kind == "lognormal":
            return first * math.exp(self.sigma**2 / 2)  # type: ignore[operator]
        return float(first)

    def sample(self, rng: np.random.Generator, size: int) -> npt.NDArray[np.int64]:
        """``size`` independent delays (int64 ns) from one numpy call on ``rng``.

        The draws: none when :attr:`is_fixed`; otherwise ``rng.integers(A, B,
        endpoint=True)`` for uniform, ``rng.exponential(MEAN)`` for exponential and
        ``rng.lognormal(log(MEDIAN), SIGMA)`` for lognormal, each of ``size`` values,
        rounded to the nearest nanosecond and clipped to ``[0, MAX_DELAY_NS]``.  O(size).
        """
        first = self.durations_ns[0]
        if self.is_fixed:
            return np.full(size, first, dtype=np.int64)
        if self.kind == "uniform":
            return rng.integers(first, self.durations_ns[1], size=size, endpoint=True)
        if self.kind == "exponential":
            raw = rng.exponential(float(first), size=size)
        else:
            raw = rng.lognormal(math.log(first), self.sigma, size=size)
        return np.clip(np.rint(raw), 0, MAX_DELAY_NS).astype(np.int64)

    def sample_one(self, rng: np.random.Generator) -> int:
        """One delay as a Python int: the same draw from ``rng`` as ``sample(rng, 1)`` and
        the same value (scalar generator calls consume the stream as size-1 calls do)."""
        return self.scalar_sampler(rng)()

    def scalar_sampler(self, rng: np.random.Generator) -> Callable[[], int]:
        """A function drawing one delay from ``rng`` per call, as :meth:`sample_one` does,
        with the kind's checks done once: O(1) per call without numpy arrays (the
        simulator's direct messages take this path)."""
        first = int(self.durations_ns[0])
        if self.is_fixed:
            return lambda: first
        if self.kind == "uniform":
            last = int(self.durations_ns[1])
            integers = rng.integers
            return lambda: int(integers(first, last, endpoint=True))
        if self.kind == "exponential":
            exponential, mean = rng.exponential, float(first)
            return lambda: _whole_ns(float(exponential(mean)))
        lognormal, mu, sigma = rng.lognormal, math.log(first), self.sigma
        return lambda: _whole_ns(float(lognormal(mu, sigma)))


def _whole_ns(raw: float) -> int:
    """A drawn delay rounded as :meth:`Latency.sample` rounds it: half to even (numpy's
    ``rint``), clipped to ``[0, MAX_DELAY_NS]``."""
    if not raw < MAX_DELAY_NS:
        return MAX_DELAY_NS
    return max(round(raw), 0)


# ---------------------------------------------------------------------------- loss
_LOSS_FORMS = "P or ge:P_GOOD_TO_BAD:P_BAD_TO_GOOD:LOSS_IN_BAD"


def _loss_problem(kind: Any, probabilities: Any) -> str | None:
    if kind not in ("bernoulli", "ge"):
        return f"unknown loss model {describe(kind)} (expected bernoulli or ge)"
    wanted = 1 if kind == "bernoulli" else 3
    if not isinstance(probabilities, tuple | list) or len(probabilities) != wanted:
        return f"{kind} loss takes {plural(wanted, 'probability', 'probabilities')}"
    if kind == "bernoulli":
        return _in_range(probabilities[0], "the loss probability", 0, 1, "[)")
    good_to_bad, bad_to_good, loss_in_bad = probabilities
    problem = _in_range(good_to_bad, "P_GOOD_TO_BAD", 0, 1)
    if problem is None and bad_to_good == 0:
        return "P_BAD_TO_GOOD must be > 0 (a bad state that is never left kills the link)"
    return (
        problem
        or _in_range(bad_to_good, "P_BAD_TO_GOOD", 0, 1, "(]")
        or _in_range(loss_in_bad, "LOSS_IN_BAD", 0, 1)
    )


@dataclass(frozen=True)
class Loss:
    """Whether a reception is lost (frozen).

    Parameters
    ----------
    kind : {"bernoulli", "ge"}
    probabilities : tuple of float
        ``(P,)`` for Bernoulli loss, ``0 <= P < 1``: each reception is lost
        independently with probability ``P``.  ``(P_GOOD_TO_BAD, P_BAD_TO_GOOD,
        LOSS_IN_BAD)`` for Gilbert-Elliott loss: every directed link starts in the good
        state, where nothing is lost; before each transmission on a link its state moves
        good -> bad with probability ``P_GOOD_TO_BAD`` (in [0, 1]) and bad -> good with
        ``P_BAD_TO_GOOD`` (in (0, 1]); in the bad state the reception is lost with
        probability ``LOSS_IN_BAD`` (in [0, 1]).

    Examples
    --------
    >>> Loss.parse("0.1").rate, Loss.parse("ge:0.1:0.3:0.5").rate
    (0.1, 0.125)
    >>> Loss.parse("ge:0.1:0.3:0.5").to_text()
    'ge:0.1:0.3:0.5'
    """

    kind: str = "bernoulli"
    probabilities: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        _raise(_loss_problem(self.kind, self.probabilities), "loss")
        object.__setattr__(self, "probabilities", tuple(float(v) for v in self.probabilities))

    @classmethod
    def parse(cls, text: str) -> Loss:
        """Read ``P`` or ``ge:P_GOOD_TO_BAD:P_BAD_TO_GOOD:LOSS_IN_BAD``.

        Bad text is a :class:`~cfopt.MissionError` starting with the text.
        """
        try:
            return cls._parse(text)
        except _Problem as exc:
            raise MissionError(f"{text}: {exc}") from None

    @classmethod
    def _parse(cls, text: str) -> Loss:
        if ":" not in text:
            kind, values = "bernoulli", (_number(text, "the loss probability"),)
        else:
            model, *args = text.split(":")
            if model != "ge":
                raise _Problem(f"unknown loss model {model!r} (expected {_LOSS_FORMS})")
            if len(args) != 3:
                raise _Problem(f"expected ge:P_GOOD_TO_BAD:P_BAD_TO_GOOD:LOSS_IN_BAD, got {text!r}")
            names = ("P_GOOD_TO_BAD", "P_BAD_TO_GOOD", "LOSS_IN_BAD")
            kind, values = "ge", tuple(_number(a, w) for a, w in zip(args, names, strict=True))
        problem = _loss_problem(kind, values)
        if problem:
            raise _Problem(problem)
        return cls(kind, values)

    def to_text(self) -> str:
        """The canonical text: ``0.1`` or ``ge:0.1:0.3:0.5``."""
        values = ":".join(_number_text(v) for v in self.probabilities)
        return values if self.kind == "bernoulli" else f"ge:{values}"

    @property
    def rate(self) -> float:
        """The long-run fraction of receptions lost: ``P``, or for Gilbert-Elliott the
        stationary bad-state probability times ``LOSS_IN_BAD``,
        ``P_GOOD_TO_BAD / (P_GOOD_TO_BAD + P_BAD_TO_GOOD) * LOSS_IN_BAD``."""
        if self.kind == "bernoulli":
            return self.probabilities[0]
        good_to_bad, bad_to_good, loss_in_bad = self.probabilities
        return good_to_bad / (good_to_bad + bad_to_good) * loss_in_bad

    @property
    def is_lossless(self) -> bool:
        """Whether nothing is ever lost (then :class:`Links` draws nothing for losses)."""
        if self.kind == "bernoulli":
            return self.probabilities[0] == 0
        return self.probabilities[0] == 0 or self.probabilities[2] == 0


# ---------------------------------------------------------------------------- spec
def _token_error(token: str, problem: str) -> MissionError:
    return MissionError(f"{token}: {problem}", cli=f"--network: token {token!r}: {problem}")


def _network_error(message: str) -> MissionError:
    return MissionError(message, cli=f"--network: {message}")


def _param_problem(topology: str, key: str, value: Any) -> str | None:
    if key == "radius":
        if not _is_real(value) or not math.isfinite(value) or value <= 0:
            return f"the radius must be a finite number > 0, got {describe(value)}"
        return None
    if key == "p":
        if topology == "er":
            return _in_range(value, "the er edge probability p", 0, 1, "(]")
        return _in_range(value, "the smallworld rewiring probability p", 0, 1)
    if not is_whole(value):
        return f"k must be a whole number, got {describe(value)}"
    if value < 2 or value % 2:
        return (
            f"k must be an even whole number >= 2 (each robot links to k/2 robots on "
            f"either side of the ring), got {value}"
        )
    return None


def _channel_problem(key: str, value: Any) -> str | None:
    if key == "bitrate":
        if value is None:
            return None
        if not is_whole(value) or not 1 <= value <= MAX_DURATION_NS:
            return f"the bit rate must be a whole number of bit/s >= 1, got {describe(value)}"
        return None
    if key == "queue":
        if not is_whole(value) or not 1 <= value <= 10**9:
            return (
                f"the queue bound must be a whole number of frames in [1, 1e9], got "
                f"{describe(value)}"
            )
        return None
    choices = CHANNELS if key == "channel" else AIR_ENCODINGS
    if value not in choices:
        shown = repr(value) if isinstance(value, str) else describe(value)
        return f"must be {' or '.join(choices)}, got {shown}"
    return None


def _general_problem(key: str, value: Any) -> str | None:
    if key in _CHANNEL_KEYS:
        return _channel_problem(key, value)
    if key == "medium":
        shown = repr(value) if isinstance(value, str) else describe(value)
        return None if value in _MEDIA else f"must be broadcast or unicast, got {shown}"
    if key == "period":
        problem = _duration_problem(value, "the clock period")
        if problem is None and value == 0:
            return "the clock period must be > 0"
        return problem
    if key == "jitter":
        return _in_range(value, "the jitter (a fraction of the period)", 0, 1, "[)")
    if key == "sync":
        return None if isinstance(value, bool) else f"must be true or false, got {describe(value)}"
    if key == "latency":
        return None if isinstance(value, Latency) else "must be a Latency"
    return None if isinstance(value, Loss) else "must be a Loss"


def _convert_general(key: str, text: str) -> Any:
    """A general key's token value -> its typed value (syntax only)."""
    if key == "latency":
        return Latency._parse(text)
    if key == "loss":
        return Loss._parse(text)
    if key == "period":
        return _duration(text)
    if key == "jitter":
        return _number(text, "the jitter")
    if key == "sync":
        if text not in ("true", "false"):
            raise _Problem(f"must be true or false, got {text!r}")
        return text == "true"
    if key == "bitrate":
        return _bitrate(text)
    if key == "queue":
        if not _WHOLE_RE.match(text):
            raise _Problem(f"the queue bound must be a whole number of frames, got {text!r}")
        return int(text)
    return text  # medium, channel, encoding


def _convert_param(key: str, text: str) -> Any:
    if key == "k":
        if not _WHOLE_RE.match(text):
            raise _Problem(f"k must be a whole number, got {text!r}")
        return int(text)
    return _number(text, "the radius" if key == "radius" else "p")


_FIELD_OF = {"period": "period_ns"}


@dataclass(frozen=True)
class NetworkSpec:
    """What network to build: a topology, its parameters and the link and clock physics.

    Parameters
    ----------
    topology : {"complete", "ring", "grid", "geometric", "er", "smallworld", "file"}
        ``complete``: everyone hears everyone.  ``ring``: robot i hears i - 1 and i + 1
        (mod n).  ``grid``: networkx's 2-D grid with ceil(sqrt(n)) columns, robots in
        row-major order on its first n nodes.  ``geometric``: robots uniform in the unit
        square, linked within ``radius`` (the edges of ``nx.random_geometric_graph``).
        ``er``: the Erdos-Renyi G(n, p), redrawn until connected (at most 100 draws).
        ``smallworld``: ``nx.connected_watts_strogatz_graph(n, k, p)``.  ``file``: the
        ``edges`` given, by robot id.
    radius : float, optional
        ``geometric`` only, > 0.
    p : float, optional
        ``er`` (in (0, 1]) and ``smallworld`` (the rewiring probability, in [0, 1]).
    k : int, optional
        ``smallworld`` only: an even whole number >= 2, below the number of robots.
    edges : tuple of (str, str), optional
        ``file`` only: undirected links by robot id (no robot linked to itself).
    latency : Latency
        Default ``constant:0ms``.
    loss : Loss
        Default ``0`` (nothing lost).
    medium : {"broadcast", "unicast"}
        ``broadcast`` (default): one transmission reaches every neighbour;
        ``unicast``: one transmission per receiver.  The simulator counts messages by
        it; the physics of a reception (:class:`Links`) is the same.
    period_ns : int
        The clock period, > 0 (default 10 ms).
    jitter : float
        Each tick's jitter bound as a fraction of the period, in [0, 1) (default 0.1).
    sync : bool
        ``True``: every robot ticks at ``k * period`` (no offset, no jitter).
    profile : str, optional
        The named profile (:data:`heuristics.profiles.PROFILES`, e.g. ``seed``) the spec
        was written with: the spec is the profile's, with the tokens given after it
        applied, and the profile's halting rule sets the run's quiet factor
        (:meth:`quiet_factor`).  Its topology is the profile's.
    path : str, optional
        ``file`` only: the edge-list file the edges were read from (written back by
        :meth:`to_text`; not compared).

    Notes
    -----
    Every field is validated on construction (:class:`~cfopt.MissionError` naming the
    field).  Specs compare equal when everything but :attr:`path` does; the edges are
    compared, not the file they came from.  Building costs O(n + edges) plus the
    topology's generator (see :meth:`build`).

    Examples
    --------
    >>> spec = NetworkSpec.parse("geometric radius=0.3 latency=exponential:2ms period=0.02s")
    >>> spec.radius, spec.latency.durations_ns, spec.period_ns, spec.jitter
    (0.3, (2000000,), 20000000, 0.1)
    >>> spec.to_text()
    'geometric radius=0.3 latency=exponential:2ms period=20ms'
    >>> NetworkSpec.parse(spec.to_text()) == spec == NetworkSpec.from_dict(spec.to_dict())
    True
    >>> NetworkSpec.parse("geometric")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: geometric: needs radius=R (e.g. geometric radius=0.2)
    """

    topology: str = "complete"
    radius: float | None = None
    p: float | None = None
    k: int | None = None
    edges: tuple[tuple[str, str], ...] | None = None
    latency: Latency = field(default_factory=Latency)
    loss: Loss = field(default_factory=Loss)
    medium: str = "broadcast"
    period_ns: int = 10_000_000
    jitter: float = 0.1
    sync: bool = False
    profile: str | None = None
    path: str | None = field(default=None, compare=False)
    #: Where the edges came from, for messages ("file=edges.txt", "net.json").
    origin: str | None = field(default=None, compare=False, repr=False)
    #: The key of the edge list in the JSON they came from ("" for a bare list).
    edge_key: str = field(default="edges", compare=False, repr=False)
    #: The line of each edge in a text edge list (for messages).
    edge_lines: Sequence[int] | None = field(default=None, compare=False, repr=False)
    #: The edges as read from a text edge list (distinct ids and an index table), so
    #: that :meth:`build` looks each id up once.
    edge_table: EdgeTable | None = field(default=None, compare=False, repr=False)
    #: The radio channel's bit rate in bit/s (``None``: no channel, links of unlimited
    #: capacity; :mod:`heuristics.transport.channel`).
    bitrate: int | None = None
    #: ``shared`` (robots in range contend for one channel) or ``per-link``.
    channel: str = "shared"
    #: The bound of each sender's queue: frames waiting, the one on the air not counted.
    queue: int = DEFAULT_QUEUE
    #: How beliefs are encoded on the air: ``full`` or ``compact`` (bit-packed slots).
    encoding: str = "full"

    def __post_init__(self) -> None:
        if self.topology not in TOPOLOGIES:
            raise MissionError(
                f"topology: unknown topology {describe(self.topology)} "
                f"(expected {', '.join(TOPOLOGIES)})"
            )
        wanted = _TOPOLOGY_PARAMS[self.topology]
        for key in ("radius", "p", "k"):
            value = getattr(self, key)
            if key in wanted:
                if value is None:
                    raise MissionError(f"{key}: the {self.topology} topology needs {key}")
                _raise(_param_problem(self.topology, key, value), key)
                object.__setattr__(self, key, int(value) if key == "k" else float(value))
            elif value is not None:
                raise MissionError(f"{key}: {_only_for(key)}, not to {self.topology}")
        for key in _SPEC_KEYS:
            _raise(_general_problem(key, getattr(self, _FIELD_OF.get(key, key))), key)
        object.__setattr__(self, "period_ns", int(self.period_ns))
        object.__setattr__(self, "jitter", float(self.jitter))
        self._check_channel()
        self._check_profile()
        self._check_edges()

    def _check_profile(self) -> None:
        if self.profile is None:
            return
        from heuristics.profiles import PROFILES

        if self.profile not in PROFILES:
            raise MissionError(
                f"profile: unknown network profile {describe(self.profile)} (expected "
                f"{', '.join(PROFILES)})"
            )
        wanted = _profile_base(self.profile)["topology"]
        if self.topology != wanted:
            raise MissionError(
                f"profile: the {self.profile} profile's topology is {wanted}, got "
                f"{describe(self.topology)}"
            )

    def quiet_factor(self, n_robots: int) -> int | None:
        """The quiet factor ``K`` its profile's halting rule gives a run of ``n_robots``
        robots (``None`` without a profile: the simulator's default applies).

        >>> NetworkSpec.parse("seed").quiet_factor(100), NetworkSpec().quiet_factor(100)
        (334, None)
        """
        if self.profile is None:
            return None
        from heuristics.profiles import PROFILES

        return PROFILES[self.profile].quiet(int(n_robots), self)

    def _check_channel(self) -> None:
        if self.bitrate is not None:
            object.__setattr__(self, "bitrate", int(self.bitrate))
            object.__setattr__(self, "queue", int(self.queue))
            return
        for key, default in (("channel", "shared"), ("queue", DEFAULT_QUEUE)):
            if getattr(self, key) != default:
                raise MissionError(f"{key}: only a network with a channel (bitrate=RATE) has {key}")

    def _check_edges(self) -> None:
        if self.topology != "file":
            for key in ("edges", "path"):
                if getattr(self, key) is not None:
                    raise MissionError(f"{key}: only the file topology has {key}")
            return
        if self.edges is None:
            raise MissionError("edges: the file topology needs its edges")
        if self.path is not None and not _one_line_path(self.path):
            raise MissionError(
                f"path: must be a non-empty path without line breaks or leading or trailing "
                f"spaces (write a network JSON file for other paths), got {describe(self.path)}"
            )
        table = self.edge_table
        read = table is not None and len(table.index) == len(self.edges)
        if not read and not _plain_pairs(self.edges):
            object.__setattr__(self, "edges", self._checked_pairs())

    def _checked_pairs(self) -> tuple[tuple[str, str], ...]:
        """The edges as tuples, or the first broken rule named by its place."""
        edges = []
        for index, pair in enumerate(self.edges):  # type: ignore[arg-type]
            place = f"edges[{index}]"
            if not isinstance(pair, tuple | list) or len(pair) != 2:
                raise MissionError(f"{place}: must be a pair of robot ids, got {describe(pair)}")
            for j in (0, 1):
                check_text(pair[j], f"{place}[{j}]", "a robot id (a non-empty string)")
            if pair[0] == pair[1]:
                raise MissionError(f"{place}: links robot {describe(pair[0])} to itself")
            edges.append(pair if type(pair) is tuple else (pair[0], pair[1]))
        return tuple(edges)

    # ------------------------------------------------------------------ parsing
    @classmethod
    def parse(cls, text: str) -> NetworkSpec:
        """Read the one-line ``--network`` spec, or the network JSON file it names.

        The line is a topology, then ``key=value`` tokens separated by spaces::

            complete | ring | grid | geometric radius=R | er p=P | smallworld k=K p=P
                     | file=PATH
            latency=constant:D | uniform:A:B | exponential:MEAN | lognormal:MEDIAN:SIGMA
            loss=P | ge:P_GOOD_TO_BAD:P_BAD_TO_GOOD:LOSS_IN_BAD
            medium=broadcast|unicast  period=D  jitter=F  sync=true|false
            bitrate=RATE  channel=shared|per-link  queue=N  encoding=full|compact

        A profile name (``seed``, :mod:`heuristics.profiles`) may stand for the topology:
        the spec is then the profile's, and the tokens after it override its fields
        (``seed loss=0.05``).  Durations carry a unit (``ns``, ``us``, ``ms``, ``s``:
        ``5ms``, ``0.2s``).
        Bit rates carry theirs (``bit/s``, ``kbit/s``, ``Mbit/s``: ``2Mbit/s``).
        ``bitrate`` gives the network a radio channel of that capacity (``channel``,
        ``queue``: its model and each sender's queue bound, default 16 frames; see
        :mod:`heuristics.transport.channel`); ``encoding`` how beliefs are sized on the
        air.
        ``file=PATH`` reads an edge list now: a ``.json`` file holding a list of
        ``[robot_id, robot_id]`` pairs, or any other file with two robot ids per line
        (blank lines and ``#`` comments allowed); a path with spaces is taken whole
        when it names an existing file (the longest such run of tokens).  When ``text``
        is an existing path (spaces allowed) that does not start with a topology, or one
        word ending in ``.json``, it is read as a network JSON file (:meth:`from_json`).
        Numbers take ASCII digits only.  A network is never read from stdin: ``-`` and
        ``file=-`` are refused.

        Every mistake (an unknown topology or key, a key given twice, a malformed or
        out-of-range value, a missing or misplaced topology parameter) is a
        :class:`~cfopt.MissionError` whose message starts with the offending token and
        whose command-line wording starts ``--network: ``.  O(len(text)), plus reading
        the file.

        >>> NetworkSpec.parse("er p=0.2 loss=ge:0.01:0.2:0.5 sync=true").loss.rate
        0.023809523809523808
        >>> err = None
        >>> try:
        ...     NetworkSpec.parse("ring loss=1.5")
        ... except MissionError as exc:
        ...     err = exc
        >>> str(err)
        'loss=1.5: the loss probability must be in [0, 1), got 1.5'
        >>> err.cli_message
        "--network: token 'loss=1.5': the loss probability must be in [0, 1), got 1.5"
        """
        if not isinstance(text, str):
            raise TypeError(f"NetworkSpec.parse takes a string, got {type(text).__name__}")
        stripped = text.strip()
        tokens = stripped.split()
        if not tokens:
            raise _network_error(f"empty network spec; expected a topology ({_TOPOLOGY_LIST})")
        if stripped in ("-", "file=-"):
            raise _token_error(stripped, _NO_STDIN)
        if _names_a_file(stripped, tokens):
            try:
                return cls.from_json(stripped)
            except MissionError as exc:
                raise _network_error(str(exc)) from None
        return cls._parse_tokens(_join_file_path(stripped, tokens))

    @classmethod
    def _parse_tokens(cls, tokens: Sequence[str]) -> NetworkSpec:
        head = tokens[0]
        values: dict[str, Any] = {}
        key, sep, value = head.partition("=")
        if head in _profile_names():
            base = _profile_base(head)
            topology = base.pop("topology")
            values.update(base, profile=head)
        elif sep and key == "file":
            topology = "file"
            values.update(cls._read_edges(head, value))
        elif sep and (key in _SPEC_KEYS or key in _PARAM_USAGE):
            raise _token_error(head, f"the spec must start with a topology ({_TOPOLOGY_LIST})")
        elif head == "file":
            raise _token_error(head, "give the edge list as file=PATH")
        elif head not in _TOPOLOGY_PARAMS:
            raise _token_error(
                head,
                f"unknown topology {head!r} (expected {_TOPOLOGY_LIST}, or a profile: "
                f"{', '.join(_profile_names())})",
            )
        else:
            topology = head
        params = _TOPOLOGY_PARAMS[topology]
        seen: dict[str, str] = {}
        for token in tokens[1:]:
            key, sep, value = token.partition("=")
            if not sep or not key:
                raise _token_error(token, "expected key=value")
            if key in seen:
                raise _token_error(token, f"key {key!r} given twice (first as {seen[key]!r})")
            seen[key] = token
            if key == "file" or key in _TOPOLOGY_PARAMS:
                raise _token_error(token, "the topology comes first, and only once")
            if key in _PARAM_USAGE and key not in params:
                raise _token_error(token, f"{_only_for(key)}, not to {topology}")
            if key not in params and key not in _SPEC_KEYS:
                allowed = ", ".join((*params, *_SPEC_KEYS))
                raise _token_error(token, f"unknown key {key!r} (expected one of: {allowed})")
            try:
                if key in params:
                    typed = _convert_param(key, value)
                    problem = _param_problem(topology, key, typed)
                else:
                    typed = _convert_general(key, value)
                    problem = _general_problem(key, typed)
            except _Problem as exc:
                problem = str(exc)
            if problem:
                raise _token_error(token, problem)
            values[_FIELD_OF.get(key, key)] = typed
        for key in params:
            if key not in values:
                needed = " ".join(_PARAM_USAGE[k] for k in params)
                example = {"geometric": "radius=0.2", "er": "p=0.1", "smallworld": "k=4 p=0.1"}
                raise _token_error(head, f"needs {needed} (e.g. {topology} {example[topology]})")
        return cls(topology=topology, **values)

    @staticmethod
    def _read_edges(token: str, path: str) -> dict[str, Any]:
        """The fields of ``file=PATH``: a text edge list, a JSON list of pairs, or the
        edges of a network JSON file of topology ``file`` (its other keys unused)."""
        if not path:
            raise _token_error(token, "give the edge list's path: file=PATH")
        fields: dict[str, Any] = {"path": path, "origin": token, "edge_key": ""}
        try:
            if not path.endswith(".json"):
                table = read_edge_list(path)
                fields.update(edges=table.pairs(), edge_lines=table.lines, edge_table=table)
                return fields
            data, _ = read_json(path, stdin_hint=False)
            if not isinstance(data, dict):
                fields["edges"] = _json_edges(data, "")
                return fields
            spec = NetworkSpec.from_dict(data)
        except MissionError as exc:
            message = str(exc).removeprefix(f"{path}: ")
            raise _token_error(token, message) from None
        if spec.topology != "file":
            raise _token_error(
                token,
                f"a network JSON file of topology {spec.topology!r} has no edge list; "
                f"give it whole as --network {path}",
            )
        fields.update(edges=spec.edges, edge_key="edges")
        return fields

    @classmethod
    def from_dict(cls, data: Any, *, origin: str | None = None) -> NetworkSpec:
        """Validate a ``cfopt.network/1`` object (as parsed from JSON) and build the spec.

        Keys: ``format`` (optional, ``"cfopt.network/1"``), ``topology`` (required),
        its parameters (``radius``, ``p``, ``k``), ``edges`` (a list of ``[robot_id,
        robot_id]`` pairs, for ``"file"`` only, required there), and the optional
        ``latency``, ``loss``, ``medium``, ``period``, ``jitter`` and ``sync``, with the
        defaults of :meth:`parse`.  Values have the token syntax (``"latency":
        "uniform:1ms:5ms"``, ``"period": "10ms"``); numbers may also be JSON numbers and
        ``sync`` a JSON boolean.  ``profile`` (optional, a profile name such as
        ``"seed"``) starts from that profile's spec, the other keys overriding it
        (``topology`` may then be left out).  Unknown keys are errors; the first broken rule raises
        :class:`~cfopt.MissionError` naming the key.  ``origin`` (a file name) starts the
        messages of errors found later, when the edges meet a mission in :meth:`build`.
        O(keys + edges).

        >>> NetworkSpec.from_dict({"topology": "file", "edges": [["a", "b"]], "loss": 0.2})
        NetworkSpec(topology='file', radius=None, p=None, k=None, edges=(('a', 'b'),), ...)
        """
        top = expect_object(data, "")
        optional = ("format", "profile", "radius", "p", "k", "edges", *_SPEC_KEYS)
        if "profile" in top:
            optional = ("topology", *optional)
        check_keys(top, "", () if "profile" in top else ("topology",), optional)
        if "format" in top and top["format"] != NETWORK_FORMAT:
            raise MissionError(f'format: must be "{NETWORK_FORMAT}", got {describe(top["format"])}')
        values: dict[str, Any] = {}
        if "profile" in top:
            if top["profile"] not in _profile_names():
                raise MissionError(
                    f"profile: unknown network profile {describe(top['profile'])} (expected "
                    f"{', '.join(_profile_names())})"
                )
            values.update(_profile_base(top["profile"]), profile=top["profile"])
        topology = top.get("topology", values.pop("topology", None))
        if topology not in TOPOLOGIES:
            raise MissionError(
                f"topology: unknown topology {describe(topology)} (expected "
                f"{', '.join(TOPOLOGIES)})"
            )
        params = _TOPOLOGY_PARAMS[topology]
        for key, raw in top.items():
            if key in ("format", "topology", "profile", "edges"):
                continue
            if key in _PARAM_USAGE and key not in params:
                raise MissionError(f"{key}: {_only_for(key)}, not to {topology}")
            try:
                text = _json_token(key, raw)
                if key in params:
                    typed = _convert_param(key, text)
                    problem = _param_problem(topology, key, typed)
                else:
                    typed = _convert_general(key, text)
                    problem = _general_problem(key, typed)
            except _Problem as exc:
                problem = str(exc)
            _raise(problem, key)
            values[_FIELD_OF.get(key, key)] = typed
        for key in params:
            if key not in values:
                raise MissionError(f'top level: missing key "{key}" (the {topology} topology)')
        if "edges" in top and topology != "file":
            raise MissionError('edges: only the topology "file" has edges')
        if topology == "file":
            if "edges" not in top:
                raise MissionError('top level: missing key "edges" (the file topology)')
            values["edges"] = _json_edges(top["edges"], "edges")
            values["origin"] = origin
        return cls(topology=topology, **values)

    @classmethod
    def from_json(cls, source: Source) -> NetworkSpec:
        """Read a network JSON file (see :meth:`from_dict`); errors start with its name.

        A ``file`` network read from a path keeps it as :attr:`path`, so that
        :meth:`to_text` can name the edges (``file=net.json`` reads them back).
        """
        data, name = read_json(source, stdin_hint=False)
        try:
            spec = cls.from_dict(data, origin=name)
        except MissionError as exc:
            raise exc.prefixed(name) from None
        if spec.topology == "file" and isinstance(source, str | os.PathLike):
            path = os.fspath(source)
            if _one_line_path(path):
                object.__setattr__(spec, "path", path)
        return spec

    # ------------------------------------------------------------------ writing
    def to_text(self) -> str:
        """The canonical one-line spec: the topology and its parameters, then the keys
        that differ from their defaults, in the order latency, loss, medium, period,
        jitter, sync.  ``parse(spec.to_text()) == spec``.  A profile's spec is its name,
        then the keys that differ from the profile's values (``seed loss=0.05``).

        A ``file`` spec names its edges by the file they were read from (an edge list,
        or a network JSON file: ``file=net.json`` reads its edges); one built from a
        dict has no file, hence no one-line form: write it with :meth:`to_dict`.
        O(1).

        >>> NetworkSpec.parse("smallworld p=0.1 k=4 jitter=0.1 loss=0 sync=false").to_text()
        'smallworld k=4 p=0.1'
        """
        if self.topology == "file":
            if self.path is None:
                raise MissionError(
                    "network: a file network given by its edges has no one-line spec; "
                    "write it as a network JSON file (NetworkSpec.to_dict)"
                )
            parts = [f"file={self.path}"]
        else:
            parts = [self.profile or self.topology]
        for key in _TOPOLOGY_PARAMS[self.topology]:
            value = getattr(self, key)
            parts.append(f"{key}={value if key == 'k' else _number_text(value)}")
        reference = _DEFAULT_TEXTS if self.profile is None else _profile_texts(self.profile)
        for key, text in self._general_texts().items():
            if text != reference[key]:
                parts.append(f"{key}={text}")
        return " ".join(parts)

    def _general_texts(self) -> dict[str, str]:
        return {
            "latency": self.latency.to_text(),
            "loss": self.loss.to_text(),
            "medium": self.medium,
            "period": format_duration(self.period_ns),
            "jitter": _number_text(self.jitter),
            "sync": "true" if self.sync else "false",
            "bitrate": "" if self.bitrate is None else format_bitrate(self.bitrate),
            "channel": self.channel,
            "queue": str(self.queue),
            "encoding": self.encoding,
        }

    def to_dict(self) -> dict[str, Any]:
        """The network JSON object (``cfopt.network/1``) with every key written.

        Numbers are JSON numbers, ``sync`` a boolean, durations, latency and
        Gilbert-Elliott loss strings with the token syntax; ``from_dict(spec.to_dict())
        == spec``.  O(edges).

        >>> NetworkSpec.parse("geometric radius=0.25").to_dict()
        {'format': 'cfopt.network/1', 'topology': 'geometric', 'radius': 0.25, 'latency': 'constant:0ms', 'loss': 0.0, 'medium': 'broadcast', 'period': '10ms', 'jitter': 0.1, 'sync': False}
        """  # noqa: E501
        data: dict[str, Any] = {"format": NETWORK_FORMAT, "topology": self.topology}
        if self.profile is not None:
            data["profile"] = self.profile
        for key in _TOPOLOGY_PARAMS[self.topology]:
            data[key] = getattr(self, key)
        if self.edges is not None:
            data["edges"] = [list(pair) for pair in self.edges]
        return self._with_physics(data)

    def _with_physics(self, data: dict[str, Any]) -> dict[str, Any]:
        texts = self._general_texts()
        data["latency"] = texts["latency"]
        bernoulli = self.loss.kind == "bernoulli"
        data["loss"] = self.loss.probabilities[0] if bernoulli else texts["loss"]
        data["medium"] = self.medium
        data["period"] = texts["period"]
        data["jitter"] = self.jitter
        data["sync"] = self.sync
        if self.encoding != "full":
            data["encoding"] = self.encoding
        if self.bitrate is not None:
            data.update(bitrate=texts["bitrate"], channel=self.channel, queue=self.queue)
        return data

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text, one edge per line."""
        return _layout(self.to_dict())

    # ------------------------------------------------------------------ building
    def build(self, mission: Mission, rng: np.random.Generator) -> Network:
        """The concrete network over the mission's robots (node i = robot index i).

        Draws from ``rng``, in this order and nothing else: ``geometric`` the positions,
        ``rng.random((n, 2))`` (row i is robot i's (x, y)); ``er`` per attempt
        ``rng.binomial(n(n-1)/2, p)`` edges, then that many distinct robot pairs with
        ``rng.choice(n(n-1)/2, size, replace=False)`` (pairs numbered row by row of the
        upper triangle), redrawn until connected, at most :data:`ER_DRAWS` times;
        ``smallworld`` one integer ``rng.integers(2**63)``, the seed of
        ``nx.connected_watts_strogatz_graph`` (at most :data:`SMALLWORLD_TRIES` tries).
        ``complete``, ``ring``, ``grid`` and ``file`` draw nothing.  Give a generator of
        its own (e.g. one child of a :class:`numpy.random.SeedSequence`), so that a run
        replayed from :meth:`Network.to_dict`, which draws nothing, keeps its other draws.

        The graph must be connected: otherwise :class:`~cfopt.MissionError` saying how
        many components there are and what to change.  A ``file`` edge naming a robot
        the mission does not have is an error too.  Costs O(n + edges) beyond the
        generator (``geometric`` uses a k-d tree, O(n log n + edges)); the complete
        graph is held implicitly, O(1).

        >>> m = Mission.from_arrays(np.ones((5, 1), bool), [[1]], [1.0])
        >>> NetworkSpec.parse("grid").build(m, np.random.default_rng(0)).edges.tolist()
        [[0, 1], [0, 3], [1, 2], [1, 4], [3, 4]]
        """
        _check_generator(rng, "rng")
        if not isinstance(mission, Mission):
            raise TypeError(f"build takes a Mission, got {type(mission).__name__}")
        n = mission.n_robots
        if self.topology == "complete":
            return Network(self, n)
        positions = None
        if self.topology == "ring":
            edges = _nx_edges(nx.cycle_graph(n)) if n >= 2 else _no_edges()
        elif self.topology == "grid":
            edges = _grid_edges(n)
        elif self.topology == "geometric":
            positions = rng.random((n, 2))
            edges = _geometric_edges(positions, self.radius)  # type: ignore[arg-type]
        elif self.topology == "er":
            return self._build_er(n, rng)
        elif self.topology == "smallworld":
            edges = self._smallworld_edges(n, rng)
        else:
            edges = self._file_edges(mission)
        network = Network._from_edges(self, n, edges, positions)
        count, labels = network._components()
        if count > 1:
            raise self._disconnected(mission, count, labels)
        return network

    def _build_er(self, n: int, rng: np.random.Generator) -> Network:
        pairs = n * (n - 1) // 2
        count = 1
        for _ in range(ER_DRAWS):
            m = int(rng.binomial(pairs, self.p))
            chosen = np.sort(rng.choice(pairs, size=m, replace=False)) if m else _no_pairs()
            network = Network._from_edges(self, n, _pair_edges(n, chosen))
            count, _ = network._components()
            if count == 1:
                return network
        threshold = math.log(n) / n
        raise _token_error(
            f"p={_number_text(self.p)}",  # type: ignore[arg-type]
            f"{ER_DRAWS} draws of G({n}, p) were all disconnected (the last had "
            f"{count} components); use a larger p (G(n, p) is usually connected above "
            f"ln(n)/n = {threshold:.3g}, e.g. p={min(1.0, 2 * threshold):.3g})",
        )

    def _smallworld_edges(self, n: int, rng: np.random.Generator) -> npt.NDArray[np.int64]:
        seed = int(rng.integers(2**63))
        if n <= 1:
            return _no_edges()
        if self.k >= n:  # type: ignore[operator]
            raise _token_error(
                f"k={self.k}", f"smallworld needs k below the number of robots ({n})"
            )
        try:
            graph = nx.connected_watts_strogatz_graph(
                n, self.k, self.p, tries=SMALLWORLD_TRIES, seed=seed
            )
        except nx.NetworkXError:
            raise _token_error(
                f"smallworld k={self.k} p={_number_text(self.p)}",  # type: ignore[arg-type]
                f"no connected graph in {SMALLWORLD_TRIES} Watts-Strogatz draws over {n} "
                "robots; use a larger k or a smaller p",
            ) from None
        return _nx_edges(graph)

    def _file_edges(self, mission: Mission) -> npt.NDArray[np.int64]:
        """The edges as robot indices: one C-level pass of dict look-ups, then, only when
        an id is unknown, the pass that finds the first one."""
        index = mission.robot_index
        edges = self.edges or ()
        table = self.edge_table
        if table is not None:
            robots = np.array([index.get(rid, -1) for rid in table.names], dtype=np.int64)
            if (robots >= 0).all():
                return robots[table.index].reshape(-1, 2)
        try:
            flat = np.fromiter(
                map(index.__getitem__, itertools.chain.from_iterable(edges)),
                dtype=np.int64,
                count=2 * len(edges),
            )
        except KeyError:
            pass
        else:
            return flat.reshape(-1, 2)
        for row, pair in enumerate(edges):
            for j, rid in enumerate(pair):
                if rid not in index:
                    raise self._edges_error(
                        f"unknown robot id {describe(rid)} (the mission has "
                        f"{plural(mission.n_robots, 'robot')}: {_some_ids(mission.robot_ids)})",
                        row,
                        j,
                    )
        raise AssertionError("unreachable: some id was unknown")

    def _edges_error(self, problem: str, row: int | None = None, j: int = 0) -> MissionError:
        """An error about the edges (``row``: about edge ``row``, end ``j``), placed in the
        file or object they came from."""
        if row is None:
            where = self.edge_key
        elif self.edge_lines is not None:
            where = f"line {self.edge_lines[row]}"
        else:
            where = f"{self.edge_key}[{row}][{j}]"
        message = f"{where}: {problem}" if where else problem
        if self.origin and self.origin.startswith("file="):
            return _token_error(self.origin, message)
        return _network_error(f"{self.origin}: {message}" if self.origin else message)

    def _disconnected(
        self, mission: Mission, count: int, labels: npt.NDArray[np.int64]
    ) -> MissionError:
        n = mission.n_robots
        where = f"the {self.topology} network over {plural(n, 'robot')} is disconnected"
        if self.topology == "geometric":
            threshold = math.sqrt(math.log(n) / (math.pi * n))
            return _token_error(
                f"radius={_number_text(self.radius)}",  # type: ignore[arg-type]
                f"{where} ({count} components); use a larger radius (about "
                f"{min(1.5, 2 * threshold):.2g} usually connects {plural(n, 'robot')})",
            )
        apart = np.flatnonzero(labels != labels[0])
        cut_off = _some_ids([mission.robot_ids[i] for i in apart.tolist()])
        problem = (
            f"{where} ({count} components; {cut_off} cannot reach "
            f"{mission.robot_ids[0]}); add edges linking them"
        )
        return self._edges_error(problem)


_DEFAULT_TEXTS = NetworkSpec()._general_texts()
_NO_STDIN = (
    "a network is not read from stdin; give a network JSON file, or file=PATH for an edge list"
)


def _one_line_path(path: Any) -> bool:
    """Whether ``path`` can stand in a one-line spec: a non-empty string without line
    breaks or leading or trailing whitespace (inner spaces are fine)."""
    return (
        isinstance(path, str)
        and bool(path)
        and path == path.strip()
        and len(path.splitlines()) == 1
    )


def _names_a_file(stripped: str, tokens: Sequence[str]) -> bool:
    """Whether the whole spec is the path of a network JSON file: an existing path (of
    any name, spaces included) that does not start as a spec does, or one word ending
    in ``.json`` (then a missing file is said to be missing)."""
    head = tokens[0]
    if head in _TOPOLOGY_PARAMS or head in _profile_names() or head.startswith("file="):
        return False
    if os.path.lexists(stripped):
        return True
    return len(tokens) == 1 and stripped.endswith(".json") and "=" not in stripped


def _join_file_path(stripped: str, tokens: Sequence[str]) -> list[str]:
    """The tokens, with ``file=PATH`` extended over the following tokens when that
    makes the longest existing path (an edge list's path may contain spaces)."""
    if not tokens[0].startswith("file="):
        return list(tokens)
    ends = [match.end() for match in re.finditer(r"\S+", stripped)]
    for count in range(len(tokens), 1, -1):
        if os.path.lexists(stripped[len("file=") : ends[count - 1]]):
            return [stripped[: ends[count - 1]], *tokens[count:]]
    return list(tokens)


def _profile_names() -> tuple[str, ...]:
    from heuristics.profiles import PROFILES

    return tuple(PROFILES)


@functools.cache
def _profile_spec(name: str) -> NetworkSpec:
    from heuristics.profiles import PROFILES

    return NetworkSpec._parse_tokens(PROFILES[name].spec.split())


def _profile_base(name: str) -> dict[str, Any]:
    """The fields the profile ``name`` stands for (a fresh dict): topology and physics."""
    spec = _profile_spec(name)
    fields = ("topology", "latency", "loss", "medium", "period_ns", "jitter", "sync")
    return {key: getattr(spec, key) for key in fields}


def _profile_texts(name: str) -> dict[str, str]:
    return _profile_spec(name)._general_texts()


def _only_for(key: str) -> str:
    owners = [t for t, params in _TOPOLOGY_PARAMS.items() if key in params]
    return f"{key} applies only to {' and '.join(owners)}"


def _json_token(key: str, raw: Any) -> str:
    """A network JSON value -> the token text it stands for."""
    if isinstance(raw, str):
        return raw
    if key == "sync" and isinstance(raw, bool):
        return "true" if raw else "false"
    if key in ("radius", "p", "jitter", "loss") and _is_real(raw):
        return _number_text(raw) if math.isfinite(raw) else describe(raw)
    if key in ("k", "queue") and is_whole(raw) and raw >= 0:
        return str(raw)
    if key == "k" and isinstance(raw, float) and raw.is_integer() and raw >= 0:
        return str(int(raw))
    shown = {
        "period": 'a duration with a unit, e.g. "10ms"',
        "latency": 'a string such as "uniform:1ms:5ms"',
        "medium": '"broadcast" or "unicast"',
        "sync": "true or false",
        "k": "a whole number",
        "queue": "a whole number",
        "bitrate": 'a bit rate with a unit, e.g. "2Mbit/s"',
        "channel": '"shared" or "per-link"',
        "encoding": '"full" or "compact"',
    }.get(key, "a number")
    raise _Problem(f"must be {shown}, got {describe(raw)}")


def _json_edges(value: Any, place: str) -> tuple[tuple[str, str], ...]:
    items = expect_list(value, place)
    edges = []
    for row, item in enumerate(items):
        where = f"{place}[{row}]"
        if not isinstance(item, list) or len(item) != 2:
            raise MissionError(
                f"{where}: must be a pair [robot_id, robot_id], got {describe(item)}"
            )
        for j in (0, 1):
            check_text(item[j], f"{where}[{j}]", "a robot id (a non-empty string)")
        if item[0] == item[1]:
            raise MissionError(f"{where}: links robot {describe(item[0])} to itself")
        edges.append((item[0], item[1]))
    return tuple(edges)


def _plain_pairs(edges: Any) -> bool:
    """Whether ``edges`` is already a tuple of pairs of distinct robot ids (each a
    non-empty string): C-level passes, each distinct id checked once."""
    if type(edges) is not tuple or not all(type(p) is tuple and len(p) == 2 for p in edges):
        return False
    ids = set(itertools.chain.from_iterable(edges))
    if not all(type(rid) is str and rid and is_unicode(rid) for rid in ids):
        return False
    return not any(first == second for first, second in edges)


def _some_ids(ids: Sequence[str], shown: int = 3) -> str:
    head = ", ".join(ids[:shown])
    return head + (f" and {len(ids) - shown} more" if len(ids) > shown else "")


def _layout(data: dict[str, Any]) -> str:
    lines = ["{"]
    keys = list(data)
    for position, key in enumerate(keys):
        comma = "," if position < len(keys) - 1 else ""
        value = data[key]
        if key == "edges" and value:
            lines.append('  "edges": [')
            lines.append(",\n".join(f"    {json.dumps(e, ensure_ascii=False)}" for e in value))
            lines.append(f"  ]{comma}")
        else:
            lines.append(f"  {json.dumps(key)}: {json.dumps(value, ensure_ascii=False)}{comma}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _check_generator(rng: Any, name: str) -> None:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"{name} must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), "
            f"got {type(rng).__name__}"
        )


# ------------------------------------------------------------------------ graphs
def _no_edges() -> npt.NDArray[np.int64]:
    return np.empty((0, 2), dtype=np.int64)


def _no_pairs() -> npt.NDArray[np.int64]:
    return np.empty(0, dtype=np.int64)


def _nx_edges(graph: nx.Graph) -> npt.NDArray[np.int64]:
    return np.array(list(graph.edges()), dtype=np.int64).reshape(-1, 2)


def _geometric_edges(positions: npt.NDArray[np.float64], radius: float) -> npt.NDArray[np.int64]:
    """Pairs of robots at Euclidean distance <= radius: the edges
    ``nx.random_geometric_graph(n, radius, pos=positions)`` makes, found by the same
    k-d tree query (``scipy.spatial.KDTree.query_pairs``) without building a networkx
    graph (100 times faster at 5000 robots).  O(n log n + edges)."""
    if len(positions) < 2:
        return _no_edges()
    pairs = KDTree(positions).query_pairs(radius, output_type="ndarray")
    return pairs.astype(np.int64).reshape(-1, 2)


def _grid_shape(n: int) -> tuple[int, int]:
    """(rows, columns) of the grid over n robots: ceil(sqrt(n)) columns."""
    columns = math.isqrt(n)
    columns += columns * columns < n
    return (-(-n // columns), columns) if n else (0, 0)


def _grid_edges(n: int) -> npt.NDArray[np.int64]:
    rows, columns = _grid_shape(n)
    if n <= 1:
        return _no_edges()
    graph = nx.grid_2d_graph(rows, columns)
    edges = [(r1 * columns + c1, r2 * columns + c2) for (r1, c1), (r2, c2) in graph.edges()]
    return np.array([e for e in edges if e[0] < n and e[1] < n], dtype=np.int64).reshape(-1, 2)


def _pair_edges(n: int, pairs: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Pair numbers (row by row of the strict upper triangle) -> (i, j) with i < j."""
    rows = np.arange(n, dtype=np.int64)
    starts = rows * (2 * n - rows - 1) // 2  # number of pairs before row i
    i = np.searchsorted(starts, pairs, side="right") - 1
    j = pairs - starts[i] + i + 1
    return np.stack([i, j], axis=1)


def _csr(n: int, edges: npt.NDArray[np.int64]) -> tuple[npt.NDArray[np.int64], ...]:
    """Sorted, duplicate-free symmetric adjacency (indptr, indices) of undirected edges."""
    u = np.concatenate([edges[:, 0], edges[:, 1]])
    v = np.concatenate([edges[:, 1], edges[:, 0]])
    u, v = u[u != v], v[u != v]
    keys = np.sort(u * n + v)  # np.unique hashes in recent numpy, 20 times slower here
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])] if len(keys) else keys
    sources, targets = np.divmod(keys, n) if n else (keys, keys)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(sources, minlength=n), out=indptr[1:])
    return indptr, targets.astype(np.int64)


def _unique_inverse(
    values: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Sorted distinct values and, for each value, the index of its distinct value.

    One stable sort, O(size log size).
    """
    order = np.argsort(values, kind="stable")
    ordered = values[order]
    first = np.ones(len(ordered), dtype=bool)
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    inverse = np.empty(len(values), dtype=np.int64)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


@dataclass(frozen=True, eq=False)
class Network:
    """A concrete, connected network over a mission's robots (frozen; node i = robot i).

    Built by :meth:`NetworkSpec.build`.  Links are undirected.  The adjacency is held in
    compressed sparse rows (:attr:`indptr`, :attr:`indices`: robot i's neighbours are
    ``indices[indptr[i]:indptr[i + 1]]``, sorted), except for the complete graph, which
    is held implicitly (both ``None``) so that thousands of robots cost no memory.

    Attributes
    ----------
    spec : NetworkSpec
    n : int
        The number of robots.
    indptr, indices : ndarray of int64 or None
        The read-only adjacency (``None`` for the complete graph).
    positions : ndarray of float64, shape (n, 2), or None
        Robot positions in the unit square (``geometric`` only).

    Notes
    -----
    :attr:`diameter` is computed on first use; routes (:meth:`next_hop`, :meth:`hops`)
    by one breadth-first search per target, cached.

    Examples
    --------
    >>> m = Mission.from_arrays(np.ones((1000, 1), bool), [[1]], [1.0])
    >>> net = NetworkSpec().build(m, np.random.default_rng(0))
    >>> net.diameter, net.degree(7), net.n_edges, net.next_hop(3, 999)
    (1, 999, 499500, 999)
    """

    spec: NetworkSpec
    n: int
    indptr: npt.NDArray[np.int64] | None = field(default=None, repr=False)
    indices: npt.NDArray[np.int64] | None = field(default=None, repr=False)
    positions: npt.NDArray[np.float64] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        for name in ("indptr", "indices", "positions"):
            value = getattr(self, name)
            if value is not None:
                value = np.array(value, dtype=np.float64 if name == "positions" else np.int64)
                value.setflags(write=False)
                object.__setattr__(self, name, value)
        if (self.indptr is None) != (self.indices is None):
            raise ValueError("indptr and indices go together")
        if self.indptr is not None and len(self.indptr) != self.n + 1:
            raise ValueError(f"indptr must have n + 1 = {self.n + 1} entries")
        object.__setattr__(self, "_neighbour_cache", {})
        object.__setattr__(self, "_route_cache", {})

    @classmethod
    def _from_edges(
        cls,
        spec: NetworkSpec,
        n: int,
        edges: npt.NDArray[np.int64],
        positions: npt.NDArray[np.float64] | None = None,
    ) -> Network:
        indptr, indices = _csr(n, edges)
        return cls(spec, n, indptr, indices, positions)

    def __repr__(self) -> str:
        return f"<Network {self.spec.topology}: {plural(self.n, 'robot')}, {self.n_edges} links>"

    # --------------------------------------------------------------- structure
    @property
    def is_complete(self) -> bool:
        """Whether this is the implicit complete graph."""
        return self.indptr is None

    @property
    def n_edges(self) -> int:
        """The number of undirected links."""
        if self.indices is None:
            return self.n * (self.n - 1) // 2
        return len(self.indices) // 2

    @property
    def degrees(self) -> npt.NDArray[np.int64]:
        """Every robot's number of neighbours (int64, shape (n,)).  O(n)."""
        if self.indptr is None:
            return np.full(self.n, max(self.n - 1, 0), dtype=np.int64)
        return np.diff(self.indptr)

    def degree(self, i: int) -> int:
        """Robot ``i``'s number of neighbours.  O(1)."""
        self._check_robot(i)
        if self.indptr is None:
            return self.n - 1
        return int(self.indptr[i + 1] - self.indptr[i])

    def neighbours(self, i: int) -> npt.NDArray[np.int64]:
        """Robot ``i``'s neighbours, sorted (a read-only int64 array).

        O(1) (a view of :attr:`indices`); for the complete graph every other robot,
        built in O(n) on first use and cached while the cache stays under 64 MiB.
        """
        self._check_robot(i)
        if self.indptr is not None:
            return self.indices[self.indptr[i] : self.indptr[i + 1]]  # type: ignore[index]
        cache: dict[int, npt.NDArray[np.int64]] = self._neighbour_cache  # type: ignore[attr-defined]
        found = cache.get(i)
        if found is None:
            found = np.concatenate(
                [np.arange(i, dtype=np.int64), np.arange(i + 1, self.n, dtype=np.int64)]
            )
            found.setflags(write=False)
            if (len(cache) + 1) * self.n * 8 <= 64 * 2**20:
                cache[int(i)] = found
        return found

    @property
    def edges(self) -> npt.NDArray[np.int64]:
        """Every undirected link once, as an (E, 2) int64 array of (i, j) with i < j,
        sorted.  O(edges), O(n**2) for the complete graph."""
        if self.indptr is None:
            i, j = np.triu_indices(self.n, k=1)
            return np.stack([i, j], axis=1).astype(np.int64)
        rows = self._rows
        upper = rows < self.indices
        return np.stack([rows[upper], self.indices[upper]], axis=1)  # type: ignore[index]

    @cached_property
    def _rows(self) -> npt.NDArray[np.int64]:
        return np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.indptr))  # type: ignore[arg-type]

    @cached_property
    def _graph(self) -> csr_array:
        data = np.ones(len(self.indices), dtype=np.int8)  # type: ignore[arg-type]
        index_type = np.int32 if len(self.indices) < 2**31 else np.int64  # type: ignore[arg-type]
        arrays = (self.indices.astype(index_type), self.indptr.astype(index_type))  # type: ignore[union-attr]
        return csr_array((data, *arrays), shape=(self.n, self.n))

    def _components(self) -> tuple[int, npt.NDArray[np.int64]]:
        if self.indptr is None or self.n <= 1:
            return 1, np.zeros(self.n, dtype=np.int64)
        count, labels = connected_components(self._graph, directed=False)
        return int(count), labels

    def to_networkx(self) -> nx.Graph:
        """The network as a networkx graph over 0..n-1.  O(n + edges)."""
        graph = nx.Graph()
        graph.add_nodes_from(range(self.n))
        graph.add_edges_from(self.edges.tolist())
        return graph

    @cached_property
    def diameter(self) -> int:
        """``d_G``: the most hops a shortest path takes (0 for fewer than two robots).

        Closed forms for ``complete`` (1), ``ring`` (n // 2) and ``grid`` ((rows - 1) +
        (columns - 1)); otherwise exact by breadth-first searches run by scipy, each
        O(n log n + edges), certified by eccentricity bounds and pair lists
        (:func:`heuristics._graphs.diameter`): a handful of searches on graphs with
        peripheral fringes (geometric, grids, trees), about a dominating set's worth
        (order n / degree) on G(n, p), where nearly every robot is one hop from the
        diameter.
        """
        if self.n <= 1:
            return 0
        if self.spec.topology == "complete":
            return 1
        if self.spec.topology == "ring":
            return self.n // 2
        if self.spec.topology == "grid":
            rows, columns = _grid_shape(self.n)
            return rows - 1 + columns - 1
        return exact_diameter(self._graph)

    # ------------------------------------------------------------------ routes
    def _check_robot(self, i: Any) -> None:
        if not isinstance(i, int | np.integer) or not 0 <= i < self.n:
            raise IndexError(f"robot index {i!r} is not in 0..{self.n - 1}")

    def _routes(self, target: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        cache: dict[int, tuple[Any, Any]] = self._route_cache  # type: ignore[attr-defined]
        found = cache.get(target)
        if found is None:
            dist = bfs_distances(self._graph, target)
            rows = self._rows
            toward = dist[self.indices] == dist[rows] - 1
            candidates = np.where(toward, self.indices, self.n)  # type: ignore[arg-type]
            hop = np.minimum.reduceat(candidates, self.indptr[:-1])  # type: ignore[index]
            hop[target] = target
            found = (hop.astype(np.int32), dist.astype(np.int32))
            cache[int(target)] = found
        return found

    def next_hop(self, source: int, target: int) -> int:
        """The first robot on a shortest path from ``source`` to ``target``: of the
        neighbours one hop nearer ``target``, the lowest index (``target`` itself when
        adjacent; ``source`` when ``source == target``).

        The first call for a target runs one breadth-first search from it, O(n + edges),
        and keeps the next hop of every robot toward it (8 n bytes); later calls O(1).

        >>> m = Mission.from_arrays(np.ones((9, 1), bool), [[1]], [1.0])
        >>> net = NetworkSpec.parse("grid").build(m, np.random.default_rng(0))
        >>> net.next_hop(0, 8), net.path(0, 8)
        (1, [0, 1, 2, 5, 8])
        """
        self._check_robot(source)
        self._check_robot(target)
        if source == target:
            return int(source)
        if self.indptr is None:
            return int(target)
        return int(self._routes(int(target))[0][source])

    def hops(self, source: int, target: int) -> int:
        """The hop distance between two robots (cost as :meth:`next_hop`)."""
        self._check_robot(source)
        self._check_robot(target)
        if source == target:
            return 0
        if self.indptr is None:
            return 1
        return int(self._routes(int(target))[1][source])

    def path(self, source: int, target: int) -> list[int]:
        """The shortest path :meth:`next_hop` follows, both ends included."""
        route = [int(source)]
        while route[-1] != target:
            route.append(self.next_hop(route[-1], target))
        return route

    # ----------------------------------------------------------------- writing
    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """The network JSON object that rebuilds exactly this network for ``mission``.

        ``complete``, ``ring`` and ``grid`` are written by name (they depend on nothing
        but n); the random topologies and ``file`` as topology ``"file"`` with their
        realised edges by robot id, so that ``--network`` with the written file replays
        the run's graph without drawing.  The physics keys are the spec's.  O(edges).

        >>> m = Mission.from_arrays(np.ones((3, 1), bool), [[1]], [1.0])
        >>> net = NetworkSpec.parse("er p=0.9").build(m, np.random.default_rng(1))
        >>> net.to_dict(m)["edges"]
        [['r0', 'r1'], ['r0', 'r2'], ['r1', 'r2']]
        """
        if not isinstance(mission, Mission) or mission.n_robots != self.n:
            got = mission.n_robots if isinstance(mission, Mission) else type(mission).__name__
            raise MissionError(
                f"network: built for {plural(self.n, 'robot')}, the mission has {got}"
            )
        if self.spec.topology not in _RANDOM_TOPOLOGIES:
            return self.spec.to_dict()
        ids = mission.robot_ids
        data: dict[str, Any] = {
            "format": NETWORK_FORMAT,
            "topology": "file",
            "edges": [[ids[i], ids[j]] for i, j in self.edges.tolist()],
        }
        return self.spec._with_physics(data)

    def to_json(self, mission: Mission) -> str:
        """:meth:`to_dict` as JSON text, one edge per line."""
        return _layout(self.to_dict(mission))


# ------------------------------------------------------------------------ clocks
class Clocks:
    """Every robot's clock: robot i's k-th tick (k = 0, 1, ...) is at
    ``offset_i + k * period + e_ik`` nanoseconds.

    ``offset_i`` is uniform on the whole nanoseconds of [0, period) and ``e_ik`` on those
    of [0, jitter * period); with ``sync`` both are 0 and tick k of every robot is at
    ``k * period``.  Ticks of a robot are strictly increasing (jitter < 1).

    Draws, the same whatever the spec: ``u = rng.random(n)`` (``offset_i = floor(u_i *
    period)``), then two words ``rng.integers(2**63, size=2)``, the key of the jitter.
    The jitter of robot i's ticks ``128 b .. 128 b + 127`` is block b, drawn from its own
    generator ``PCG64(SeedSequence(key, spawn_key=(i, b)))`` as ``floor(random(128) *
    jitter * period)`` when one of its ticks is asked for (the last max(8192, 2 n)
    blocks are kept, 1 KiB each; older ones are drawn again, identically), so a tick's
    time depends only on the seed, i and k, never on the order ticks are asked for in.

    Parameters
    ----------
    spec : NetworkSpec
    n : int
    rng : numpy.random.Generator

    Examples
    --------
    >>> clocks = Clocks(NetworkSpec.parse("ring period=10ms"), 3, np.random.default_rng(0))
    >>> t = clocks.tick_times([0, 1, 2], 5)
    >>> bool(np.all((t >= 50_000_000) & (t < 50_000_000 + 11_000_000)))
    True
    >>> clocks.tick_time(1, 5) == int(t[1]), clocks.next_tick(1, int(t[1]) + 1)[0]
    (True, 6)
    >>> Clocks(NetworkSpec.parse("ring sync=true"), 3, np.random.default_rng(0)).tick_time(2, 7)
    70000000
    """

    #: Ticks per jitter block.
    BLOCK = 128

    def __init__(self, spec: NetworkSpec, n: int, rng: np.random.Generator) -> None:
        _check_generator(rng, "rng")
        if not isinstance(n, int | np.integer) or n < 0:
            raise ValueError(f"n must be a whole number >= 0, got {n!r}")
        self.spec = spec
        self.n = int(n)
        self.period_ns = spec.period_ns
        uniforms = rng.random(self.n)
        self._key = [int(word) for word in rng.integers(2**63, size=2)]
        if spec.sync:
            offsets = np.zeros(self.n, dtype=np.int64)
            self.jitter_ns = 0.0
        else:
            offsets = np.floor(uniforms * self.period_ns).astype(np.int64)
            np.minimum(offsets, self.period_ns - 1, out=offsets)
            self.jitter_ns = spec.jitter * self.period_ns
        offsets.setflags(write=False)
        self.offsets_ns = offsets
        #: The largest jitter a tick can get (whole nanoseconds below jitter * period).
        self._jitter_cap = max(math.ceil(self.jitter_ns) - 1, 0)
        self._blocks: dict[tuple[int, int], npt.NDArray[np.int64]] = {}
        #: How many jitter blocks are kept (the oldest is dropped first).
        self.kept_blocks = max(8192, 2 * self.n)

    def __repr__(self) -> str:
        return f"<Clocks: {plural(self.n, 'robot')}, period {format_duration(self.period_ns)}>"

    def _block(self, i: int, b: int) -> npt.NDArray[np.int64]:
        found = self._blocks.get((i, b))
        if found is None:
            seed = np.random.SeedSequence(self._key, spawn_key=(i, b))
            draws = np.random.Generator(np.random.PCG64(seed)).random(self.BLOCK)
            found = np.floor(draws * self.jitter_ns).astype(np.int64)
            np.minimum(found, self._jitter_cap, out=found)
            if len(self._blocks) >= self.kept_blocks:
                del self._blocks[next(iter(self._blocks))]  # the oldest
            self._blocks[(i, b)] = found
        return found

    def tick_time(self, i: int, k: int) -> int:
        """The time of robot ``i``'s tick ``k``, in ns.  O(1) (O(128) for a new block)."""
        if not 0 <= i < self.n or k < 0:
            raise IndexError(f"no tick {k!r} of robot {i!r} (robots 0..{self.n - 1}, k >= 0)")
        time = int(self.offsets_ns[i]) + int(k) * self.period_ns
        if self.jitter_ns:
            time += int(self._block(int(i), int(k) // self.BLOCK)[int(k) % self.BLOCK])
        return time

    def tick_times(self, robots: npt.ArrayLike, ks: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """:meth:`tick_time` for arrays of robots and tick numbers (broadcast together).

        O(size log size), plus O(128) per new block.
        """
        i, k = np.broadcast_arrays(
            np.asarray(robots, dtype=np.int64), np.asarray(ks, dtype=np.int64)
        )
        if i.size and (i.min() < 0 or i.max() >= self.n or k.min() < 0):
            raise IndexError(f"robots must be in 0..{self.n - 1} and tick numbers >= 0")
        times = self.offsets_ns[i] + k * self.period_ns
        if not self.jitter_ns or not i.size:
            return times
        block, within = np.divmod(k, self.BLOCK)
        keys, inverse = _unique_inverse((block * self.n + i).ravel())
        blocks, robots_of = np.divmod(keys, self.n)
        table = np.stack(
            [self._block(a, b) for a, b in zip(robots_of.tolist(), blocks.tolist(), strict=True)]
        )
        return times + table[inverse.reshape(i.shape), within]

    def next_tick(self, i: int, time: int) -> tuple[int, int]:
        """Robot ``i``'s first tick at or after ``time``: ``(k, its time)``.  O(1)."""
        if not 0 <= i < self.n:
            raise IndexError(f"robot index {i!r} is not in 0..{self.n - 1}")
        k = max(0, (int(time) - int(self.offsets_ns[i])) // self.period_ns)
        at = self.tick_time(i, k)
        if at < time:
            k += 1
            at = self.tick_time(i, k)
        return k, at


# -------------------------------------------------------------------------- links
class Links:
    """The physics of transmissions: a delay and a loss decision per reception.

    Holds the Gilbert-Elliott state of every directed link (one bool array of n per
    sender, made on its first transmission), so it is not frozen.

    Draws per :meth:`transmit` with k receivers: from ``latency_rng`` one call of k
    values (:meth:`Latency.sample`; none when the latency is fixed); from ``loss_rng``
    none when nothing can be lost, else for Bernoulli loss ``random(k)`` (lost when
    below P) and for Gilbert-Elliott ``random((2, k))``: row 0 moves each link's state
    (good -> bad when below P_GOOD_TO_BAD, bad -> good when below P_BAD_TO_GOOD), row 1
    decides the loss in the bad state (lost when below LOSS_IN_BAD).  Column j belongs
    to ``receivers[j]``.  The same calls with the same generators give the same delays
    and losses, byte for byte.

    Parameters
    ----------
    network : Network
    latency_rng, loss_rng : numpy.random.Generator

    Attributes
    ----------
    transmissions, receptions, losses : int
        Counts so far.

    Examples
    --------
    >>> m = Mission.from_arrays(np.ones((4, 1), bool), [[1]], [1.0])
    >>> net = NetworkSpec.parse("complete latency=uniform:1ms:2ms loss=0.5").build(
    ...     m, np.random.default_rng(0))
    >>> links = Links(net, np.random.default_rng(1), np.random.default_rng(2))
    >>> delays, lost = links.transmit(0, [1, 2, 3])
    >>> delays.dtype, lost.dtype, bool(np.all((delays >= 10**6) & (delays <= 2 * 10**6)))
    (dtype('int64'), dtype('bool'), True)
    """

    def __init__(
        self, network: Network, latency_rng: np.random.Generator, loss_rng: np.random.Generator
    ) -> None:
        _check_generator(latency_rng, "latency_rng")
        _check_generator(loss_rng, "loss_rng")
        self.network = network
        self.latency = network.spec.latency
        self.loss = network.spec.loss
        self._latency_rng = latency_rng
        self._loss_rng = loss_rng
        self._bad: dict[int, npt.NDArray[np.bool_]] = {}
        self._one_delay = self.latency.scalar_sampler(latency_rng)
        # transmit_one's loss probability: 0 lossless, p Bernoulli, None Gilbert-Elliott
        self._one_loss: float | None = (
            0.0
            if self.loss.is_lossless
            else self.loss.probabilities[0]
            if self.loss.kind == "bernoulli"
            else None
        )
        self.transmissions = 0
        self.receptions = 0
        self.losses = 0

    def transmit(
        self, sender: int, receivers: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        """One transmission from ``sender`` heard by ``receivers`` (distinct robots other
        than the sender, normally its neighbours: this is not checked).

        Returns ``(delays_ns, lost)``, aligned with ``receivers``: the int64 delay of
        each reception and whether it is lost.  O(k) in a constant number of numpy calls.
        """
        n = self.network.n
        if not 0 <= sender < n:
            raise IndexError(f"sender {sender!r} is not in 0..{n - 1}")
        targets = np.asarray(receivers, dtype=np.int64)
        if targets.ndim != 1:
            raise ValueError("receivers must be a 1-D sequence of robot indices")
        size = targets.size
        if size and (targets.min() < 0 or targets.max() >= n or bool((targets == sender).any())):
            raise IndexError(f"receivers must be robots in 0..{n - 1} other than the sender")
        delays = self.latency.sample(self._latency_rng, size)
        lost = self._lost(int(sender), targets)
        self.transmissions += 1
        self.receptions += size
        self.losses += int(lost.sum())
        return delays, lost

    def transmit_one(self, sender: int, receiver: int) -> tuple[int, bool]:
        """:meth:`transmit` to one receiver, as ``(delay_ns, lost)`` plain values: the same
        draws from the same generators, so the same result and the same later draws.
        O(1) without numpy arrays for Bernoulli or no loss (the simulator sends every
        direct message hop this way); Gilbert-Elliott loss goes through :meth:`transmit`.
        """
        if self._one_loss is None:
            delays, losts = self.transmit(sender, [receiver])
            return int(delays[0]), bool(losts[0])
        n = self.network.n
        if not 0 <= sender < n:
            raise IndexError(f"sender {sender!r} is not in 0..{n - 1}")
        if not 0 <= receiver < n or receiver == sender:
            raise IndexError(f"receivers must be robots in 0..{n - 1} other than the sender")
        delay = self._one_delay()
        lost = self._one_loss > 0 and self._loss_rng.random() < self._one_loss
        self.transmissions += 1
        self.receptions += 1
        self.losses += int(lost)
        return delay, bool(lost)

    def broadcast(
        self, sender: int
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        """:meth:`transmit` to every neighbour: ``(receivers, delays_ns, lost)``."""
        receivers = self.network.neighbours(sender)
        return (receivers, *self.transmit(sender, receivers))

    def _lost(self, sender: int, targets: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        size = targets.size
        if self.loss.is_lossless or not size:
            return np.zeros(size, dtype=bool)
        if self.loss.kind == "bernoulli":
            return self._loss_rng.random(size) < self.loss.probabilities[0]
        ordered = np.sort(targets)
        if bool((ordered[1:] == ordered[:-1]).any()):
            raise ValueError("receivers must be distinct (each link's state moves once)")
        good_to_bad, bad_to_good, loss_in_bad = self.loss.probabilities
        state = self._bad.get(sender)
        if state is None:
            state = self._bad[sender] = np.zeros(self.network.n, dtype=bool)
        draws = self._loss_rng.random((2, size))
        bad = np.where(state[targets], draws[0] >= bad_to_good, draws[0] < good_to_bad)
        state[targets] = bad
        return bad & (draws[1] < loss_in_bad)
