"""The GRAPE-S reward and its exact comparison.

A robot that is (or would be) one of ``c`` robots performing service ``s`` for task ``j``
earns ``R(j, s, c) = (u_js / req[j, s]) * exp(1 - c / req[j, s])``; an unassigned robot
earns 0.  Two weightings ``u_js`` are offered:

``"paper"`` (the seed's choice, the default)
    ``u_js = req[j, s]``, so ``R = exp(1 - c / req)``.  A reward is represented by its
    *key* ``c / req`` as an exact :class:`fractions.Fraction` (smaller key = larger
    reward); keys are compared by integer cross-multiplication, never with floats.
``"utility"``
    ``u_js = u_j * req[j, s] / REQ_j`` with ``REQ_j = sum_s req[j, s]`` (the task's utility
    shared in proportion to the robots each service needs), so
    ``R = w_j * exp(1 - c / req)`` with ``w_j = u_j / REQ_j``.  Comparing
    ``w_1 exp(-x_1)`` with ``w_2 exp(-x_2)`` is comparing ``ln(w_1 / w_2)`` with
    ``x_1 - x_2``.  Both ``w`` (utilities are binary floats, hence exact rationals) and
    ``x`` are exact rationals, and by the Lindemann-Weierstrass theorem ``ln q`` is
    irrational for every rational ``q != 1``, so two rewards are *equal* exactly when
    ``w_1 == w_2`` and ``x_1 == x_2`` (decided with fractions); otherwise the sign of
    ``ln(w_1/w_2) - (x_1 - x_2)`` is non-zero and is found in floats with a rigorous error
    bound (``log1p`` of the exact ``w_1/w_2 - 1`` near 1) or, when that bound cannot
    exclude zero, with :mod:`decimal` logarithms at increasing precision.  A task of
    utility 0 gives reward 0, equal to being unassigned.

Keys are totally ordered, *smaller is better*, and :data:`VOID` (``math.inf``) is the key
of the unassigned robot and of every zero reward.  Engines break ties between equally good
slots by the lowest ``(task, service)`` index: the order is ``(key, task, service)``.

Examples
--------
>>> import cfopt
>>> m = cfopt.Mission.from_arrays([[1, 1]], [[2, 0], [3, 3]], [10, 60])
>>> paper = reward_model(m, "paper")
>>> paper.key(0, 0, 1), paper.key(1, 0, 2)
(Fraction(1, 2), Fraction(2, 3))
>>> paper.key(0, 0, 1) < paper.key(1, 0, 2)       # 1/2 robots per need beats 2/3
True
>>> round(paper.value(0, 0, 1), 6)                 # exp(1 - 1/2)
1.648721
>>> util = reward_model(m, "utility")              # w_0 = 10/2 = 5, w_1 = 60/6 = 10
>>> util.key(0, 0, 1) < util.key(1, 0, 2)          # 5 e^(1/2) < 10 e^(1/3)
False
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal, localcontext
from fractions import Fraction
from functools import total_ordering
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, MissionError

__all__ = ["REWARDS", "VOID", "RewardModel", "UtilityKey", "reward_model"]

#: The key of an unassigned robot (reward 0): worse than every positive reward.
VOID: Any = math.inf
#: The reward weightings :func:`reward_model` accepts.
REWARDS = ("paper", "utility")


@total_ordering
class UtilityKey:
    """The exact key of a utility-weighted reward ``w * exp(1 - x)`` (smaller is better).

    Compares with other keys and with :data:`VOID`; see the module notes for the method.

    >>> UtilityKey(Fraction(5), Fraction(1, 2)) < UtilityKey(Fraction(5), Fraction(2, 3))
    True
    >>> UtilityKey(Fraction(1), Fraction(0)) < VOID
    True
    """

    __slots__ = ("w", "x")

    def __init__(self, w: Fraction, x: Fraction) -> None:
        if w <= 0:
            raise ValueError("a UtilityKey needs w > 0 (a zero reward is VOID)")
        self.w, self.x = w, x

    def __repr__(self) -> str:
        return f"UtilityKey(w={self.w}, x={self.x})"

    def __hash__(self) -> int:
        return hash((self.w, self.x))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, UtilityKey):
            return self.w == other.w and self.x == other.x
        if isinstance(other, float):
            return False  # VOID (inf) is never equal to a positive reward
        return NotImplemented

    def __lt__(self, other: object) -> bool:
        if isinstance(other, float):
            return other == math.inf
        if not isinstance(other, UtilityKey):
            return NotImplemented
        # self better (smaller key) <=> ln(w_s) - x_s > ln(w_o) - x_o
        if self.w == other.w:
            return self.x < other.x
        return _log_sign(self.w / other.w, self.x - other.x) > 0

    def __gt__(self, other: object) -> bool:
        if isinstance(other, float):
            return False
        if not isinstance(other, UtilityKey):
            return NotImplemented
        return other < self

    def score(self) -> float:
        """``ln w - x`` as a float (larger is better); only a fast filter, never decisive."""
        return math.log(self.w.numerator) - math.log(self.w.denominator) - float(self.x)


def _log_sign(q: Fraction, d: Fraction) -> int:
    """The sign of ``ln(q) - d`` for rationals ``q > 0``, ``q != 1`` (never zero).

    First in floats with a rigorous error bound (``log1p`` of the exactly computed
    ``q - 1`` when ``q`` is near 1, so ratios one ulp from 1 keep their relative
    accuracy), then, only when the bound cannot exclude zero, with :mod:`decimal`
    logarithms at doubling precision.  O(1) float operations on the usual path.

    >>> _log_sign(Fraction(3), Fraction(1))                 # ln 3 > 1: floats decide
    1
    >>> _log_sign(Fraction(2**53 + 1, 2**53), Fraction(1, 2**53))  # 2**-107 apart: decimal
    -1
    """
    sign = _float_log_sign(q, d)
    if sign:
        return sign
    scale = abs(math.log(q.numerator)) + abs(math.log(q.denominator)) + abs(float(d)) + 1.0
    precision = 40
    for _ in range(12):
        with localcontext() as ctx:
            ctx.prec = precision
            value = (
                Decimal(q.numerator).ln()
                - Decimal(q.denominator).ln()
                - Decimal(d.numerator) / Decimal(d.denominator)
            )
            bound = Decimal(10) ** (-(precision - 4)) * Decimal(scale)
            if abs(value) > bound:
                return 1 if value > 0 else -1
        precision *= 2
    raise ArithmeticError(f"cannot separate ln({q}) from {d}")  # pragma: no cover


_TINY = 2.2250738585072014e-308  # the least normal float


def _float_log_sign(q: Fraction, d: Fraction) -> int:
    """The sign of ``ln(q) - d`` when floats decide it for sure, else 0.

    Error bounds (generous): ``float`` of a fraction is correctly rounded (relative
    ``2**-53``); ``log1p`` and ``log`` are taken to err by at most 8 ulps; ``math.log`` of an
    integer too large for a float works on its mantissa and exponent (absolute error below
    ``2**-50`` times the exponent).  With ``|x| < 1/2``, ``|x| <= 1.5 |ln(1 + x)|``.
    """
    r = q - 1
    if -Fraction(1, 2) < r < Fraction(1, 2):
        x = float(r)
        if abs(x) < _TINY:  # underflow: no relative accuracy left
            return 0
        ln = math.log1p(x)
        err = 2.0**-46 * abs(ln)
    else:
        log_num, log_den = math.log(q.numerator), math.log(q.denominator)
        ln = log_num - log_den
        err = 2.0**-46 * (abs(log_num) + abs(log_den) + 1.0)
    dd = float(d)
    diff = ln - dd
    err += 2.0**-50 * (abs(dd) + abs(ln) + abs(diff))
    if diff > err:
        return 1
    if diff < -err:
        return -1
    return 0


@dataclass(frozen=True)
class RewardModel:
    """A reward weighting bound to a mission: exact keys and float values.

    Attributes
    ----------
    name : str
        ``"paper"`` or ``"utility"``.
    requirements : ndarray of int64, shape (m, S)
    weights : tuple of Fraction or None
        ``w_j = u_j / REQ_j`` for ``"utility"``; ``None`` for ``"paper"``.
    """

    name: str
    requirements: npt.NDArray[np.int64]
    weights: tuple[Fraction, ...] | None

    def key(self, task: int, service: int, count: int) -> Any:
        """The exact key of ``R(task, service, count)``; smaller is better, VOID for 0.

        O(1) (a fraction).
        """
        req = int(self.requirements[task, service])
        if self.weights is None:
            return Fraction(int(count), req)
        w = self.weights[task]
        if w == 0:
            return VOID
        return UtilityKey(w, Fraction(int(count), req))

    def value(self, task: int, service: int, count: int) -> float:
        """``R(task, service, count)`` as a float (for display; never for comparisons)."""
        req = int(self.requirements[task, service])
        weight = 1.0 if self.weights is None else float(self.weights[task])
        return weight * math.exp(1.0 - count / req)

    def scores(self) -> npt.NDArray[np.float64] | None:
        """Per task ``ln w_j`` as floats (``-inf`` for zero utility); ``None`` for "paper"."""
        if self.weights is None:
            return None
        with np.errstate(divide="ignore"):
            return np.array(
                [
                    -math.inf if w == 0 else math.log(w.numerator) - math.log(w.denominator)
                    for w in self.weights
                ],
                dtype=np.float64,
            )


def reward_model(mission: Mission, reward: str = "paper") -> RewardModel:
    """The reward model named ``reward`` for ``mission``.

    Raises :class:`cfopt.MissionError` for an unknown name.  O(m S).
    """
    if reward == "paper":
        return RewardModel("paper", mission.requirements, None)
    if reward == "utility":
        totals = mission.requirements.sum(axis=1).tolist()
        weights = tuple(
            Fraction(u) / int(total)
            for u, total in zip(mission.utilities.tolist(), totals, strict=True)
        )
        return RewardModel("utility", mission.requirements, weights)
    raise MissionError(f"reward: must be one of {', '.join(REWARDS)}, got {reward!r}")
