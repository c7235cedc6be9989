"""The argument checks every public entry point shares.

Each ``require_*`` function returns the value (normalised where it says so) or raises an
error whose message starts with the argument's name, e.g. ``seed: must be None, a whole
number >= 0 or a numpy.random.Generator, got [1, 2]``.  A value of the wrong type raises
:class:`~cfopt.errors.MissionTypeError`, which is both a :class:`TypeError` and a
:class:`~cfopt.errors.MissionError`; a value of the right type that is out of range
raises :class:`~cfopt.errors.MissionError` (a :class:`ValueError`).  With ``flag=True``
the command-line wording names the option (``--services-per-robot``) instead.

Booleans are never numbers here (``True`` is not a count, a seed or a time limit), and
``numpy`` integers and floats are numbers.

>>> require_int("robots", 3, minimum=1)
3
>>> require_int("robots", True, minimum=1)
Traceback (most recent call last):
...
cfopt.errors.MissionTypeError: robots: must be a whole number >= 1, got true
>>> require_seed("seed", -1)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
cfopt.errors.MissionError: seed: must be None, a whole number >= 0 or a ..., got -1
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Collection
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np

from cfopt.errors import MissionError, MissionTypeError, describe

if TYPE_CHECKING:
    from cfopt.assignment import Assignment
    from cfopt.mission import Mission

__all__ = [
    "SeedLike",
    "is_real",
    "is_whole",
    "require_assignment",
    "require_bool",
    "require_choice",
    "require_int",
    "require_mission",
    "require_number",
    "require_seed",
    "require_text",
    "shown",
]

#: What every ``seed=`` argument takes: ``None`` (fresh entropy), a whole number >= 0,
#: or a :class:`numpy.random.Generator` to draw from.
SeedLike: TypeAlias = int | np.random.Generator | None

_SCALARS = (str, int, float, type(None))


def shown(value: Any) -> str:
    """How a message shows a user's value: JSON-like for plain data and numbers, else the
    name of its type.

    >>> shown(True), shown("2"), shown([1]), shown(np.int64(7)), shown(object())
    ('true', '"2"', '[1]', '7', 'object')
    """
    if is_whole(value):
        return describe(int(value))
    if is_real(value):
        return describe(_float(value))
    if isinstance(value, _SCALARS) or type(value) in (list, tuple, dict):
        return describe(value)
    return type(value).__name__


def _error(name: str, problem: str, *, wrong_type: bool, flag: bool) -> MissionError:
    kind = MissionTypeError if wrong_type else MissionError
    cli = f"--{name.replace('_', '-')}: {problem}" if flag else None
    return kind(f"{name}: {problem}", cli=cli)


def _bounds(
    minimum: float | None, maximum: float | None, above: float | None, below: float | None
) -> str:
    """`` >= 1``, `` between 1 and 5``, `` in [0, 1)``: the range a message states."""
    low, opening = (minimum, "[") if above is None else (above, "(")
    high, closing = (maximum, "]") if below is None else (below, ")")
    if low is not None and high is not None:
        if opening + closing == "[]":
            return f" between {_number(low)} and {_number(high)}"
        return f" in {opening}{_number(low)}, {_number(high)}{closing}"
    if low is not None:
        return f" {'>=' if opening == '[' else '>'} {_number(low)}"
    if high is not None:
        return f" {'<=' if closing == ']' else '<'} {_number(high)}"
    return ""


def _number(bound: float) -> str:
    return str(bound) if isinstance(bound, int) else f"{bound:g}"


def is_whole(value: Any) -> bool:
    """Whether ``value`` is a whole number: an integer (numpy's too), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def is_real(value: Any) -> bool:
    """Whether ``value`` is a real number (int, float, Fraction, numpy's), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def _float(value: numbers.Real) -> float:
    """``float(value)``, or an infinity for a number beyond the floats (``10**400``)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def require_int(
    name: str,
    value: Any,
    *,
    minimum: int | None = None,
    maximum: int | None = None,
    flag: bool = False,
) -> int:
    """``value`` as an ``int``: a whole number (not a bool) within the bounds given.

    >>> require_int("count", 4, minimum=0, maximum=9)
    4
    >>> require_int("count", 10, minimum=0, maximum=9)
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: count: must be a whole number between 0 and 9, got 10
    """
    problem = f"must be a whole number{_bounds(minimum, maximum, None, None)}, got {shown(value)}"
    if not is_whole(value):
        raise _error(name, problem, wrong_type=True, flag=flag)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        raise _error(name, problem, wrong_type=False, flag=flag)
    return int(value)


def require_number(
    name: str,
    value: Any,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    above: float | None = None,
    below: float | None = None,
    finite: bool = True,
    what: str | None = None,
    or_none: bool = False,
    flag: bool = False,
) -> float:
    """``value`` as a ``float``: a real number (not a bool), finite unless ``finite=False``,
    within the bounds given.

    ``minimum`` and ``maximum`` are inclusive bounds, ``above`` and ``below`` exclusive
    ones; ``what`` is the noun of the message (default ``"a finite number"``, or ``"a
    number"`` when infinities and NaN are allowed); ``or_none=True`` says in the message
    that ``None`` is accepted too (the caller lets ``None`` through before calling).

    >>> require_number("load", 2, above=0)
    2.0
    >>> require_number("load", float("nan"), above=0)
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: load: must be a finite number > 0, got NaN
    """
    noun = what or ("a finite number" if finite else "a number")
    bounds = _bounds(minimum, maximum, above, below) + (" or None" if or_none else "")
    problem = f"must be {noun}{bounds}, got {shown(value)}"
    if not is_real(value):
        raise _error(name, problem, wrong_type=True, flag=flag)
    number = _float(value)
    if (
        (finite and not math.isfinite(number))
        or (above is not None and not value > above)
        or (below is not None and not value < below)
        or (minimum is not None and value < minimum)
        or (maximum is not None and value > maximum)
    ):
        raise _error(name, problem, wrong_type=False, flag=flag)
    return number


def require_bool(name: str, value: Any) -> bool:
    """``value`` if it is ``True`` or ``False`` (a ``numpy.bool_`` too); nothing else is.

    >>> require_bool("capped", [])
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: capped: must be a bool (True or False), got []
    """
    if not isinstance(value, bool | np.bool_):
        raise _error(
            name, f"must be a bool (True or False), got {shown(value)}", wrong_type=True, flag=False
        )
    return bool(value)


def require_seed(name: str, value: Any, *, generator: bool = True) -> SeedLike:
    """``value`` if it is a :data:`SeedLike`: ``None``, a whole number >= 0 (returned as
    ``int``) or, unless ``generator=False``, a :class:`numpy.random.Generator`.

    >>> require_seed("seed", None), require_seed("seed", np.int64(3))
    (None, 3)
    """
    if value is None or (generator and isinstance(value, np.random.Generator)):
        return value
    kinds = "None, a whole number >= 0 or a numpy.random.Generator"
    problem = f"must be {kinds if generator else 'None or a whole number >= 0'}, got {shown(value)}"
    if not is_whole(value):
        raise _error(name, problem, wrong_type=True, flag=False)
    if value < 0:
        raise _error(name, problem, wrong_type=False, flag=False)
    return int(value)


def require_text(name: str, value: Any, *, empty: bool = False) -> str:
    """``value`` if it is a ``str`` (a non-empty one unless ``empty=True``).

    >>> require_text("network", None)
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: network: must be a non-empty string, got null
    """
    what = "a string" if empty else "a non-empty string"
    if not isinstance(value, str):
        raise _error(name, f"must be {what}, got {shown(value)}", wrong_type=True, flag=False)
    if not (value or empty):
        raise _error(name, f"must be {what}, got {shown(value)}", wrong_type=False, flag=False)
    return value


def require_choice(name: str, value: Any, choices: Collection[str]) -> str:
    """``value`` if it is one of the strings ``choices``.

    >>> require_choice("order", "random", ("index", "random"))
    'random'
    >>> require_choice("order", 3, ("index", "random"))
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: order: must be one of index, random, got 3
    """
    problem = f"must be one of {', '.join(choices)}, got {shown(value)}"
    if not isinstance(value, str):
        raise _error(name, problem, wrong_type=True, flag=False)
    if value not in choices:
        raise _error(name, problem, wrong_type=False, flag=False)
    return value


def require_mission(value: Any) -> Mission:
    """``value`` if it is a :class:`cfopt.Mission`.

    The one mission check every solver, heuristic and checker entry point shares.

    >>> require_mission("m.json")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: mission: must be a cfopt.Mission, got str
    """
    from cfopt.mission import Mission  # the model imports these checks: import on use

    if not isinstance(value, Mission):
        raise MissionTypeError(f"mission: must be a cfopt.Mission, got {type(value).__name__}")
    return value


def require_assignment(value: Any) -> Assignment:
    """``value`` if it is a :class:`cfopt.Assignment`.

    >>> require_assignment({"assignment": []})
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: assignment: must be a cfopt.Assignment, got dict
    """
    from cfopt.assignment import Assignment  # the model imports these checks: import on use

    if not isinstance(value, Assignment):
        got = type(value).__name__
        raise MissionTypeError(f"assignment: must be a cfopt.Assignment, got {got}")
    return value
