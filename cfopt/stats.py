"""The non-parametric tests of the seed paper, each computed once, with the direction of
its effect.

The seed (Diehl and Adams, GRAPE-S, §5.1 and §6.1) compares algorithms with Friedman
tests and Conover's post-hoc test, the levels of a factor with Kruskal-Wallis tests and
pairwise Mann-Whitney-Wilcoxon post-hoc tests (Mann-Whitney-Wilcoxon alone for two
levels), and GRAPE-S with SDA by Wilcoxon's signed-rank test.  Every function here takes
labelled groups (``{"grape-s": [...], "sda": [...]}``) and returns one frozen
:class:`StatResult`: the statistic and p-value computed by ``scipy.stats`` and
``scikit_posthocs`` (never by hand), the number of values in each group, each group's
mean rank and median -- the direction of the effect, which group is lowest and which
highest -- and the smallest p-value the test could give at these group sizes, so that a
caller can tell "no difference" from "no power".

One edge rule for all of them: fewer groups than the test needs (three for Friedman and
Kruskal-Wallis, exactly two for Mann-Whitney-Wilcoxon and Wilcoxon), or groups too small
for it (an empty group, fewer than two blocks), give :attr:`Outcome.NOT_ENOUGH_DATA`;
values that are all equal give :attr:`Outcome.NO_VARIATION`.  Neither raises, and
neither is ``None``.  Malformed arguments (groups of a paired test of different
lengths, values that are not finite numbers) raise ``ValueError``.

Cost: one rank transform, ``O(N log N)`` for ``N`` values, plus ``O(k^2)`` post-hoc
pairs for ``k`` groups.

Examples
--------
>>> r = kruskal({"100": [1, 2, 3], "500": [4, 5, 6], "1000": [7, 8, 9]})
>>> round(r.statistic, 2), r.significant, r.lowest, r.highest, r.sizes
(7.2, True, '100', '1000', (3, 3, 3))
>>> mann_whitney({"a": [1, 2, 3], "b": [4, 5, 6]}).has_power  # 2/C(6,3) = 0.1 at best
False
>>> friedman({"a": [1, 1], "b": [2, 2]}).outcome.value
'not enough data'
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

__all__ = [
    "ALPHA",
    "Outcome",
    "PairResult",
    "StatResult",
    "complete_blocks",
    "friedman",
    "kruskal",
    "mann_whitney",
    "wilcoxon",
]

#: The significance level of every verdict (the seed's 5 %).
ALPHA = 0.05

FRIEDMAN, KRUSKAL = "Friedman", "Kruskal-Wallis"
MANN_WHITNEY, WILCOXON = "Mann-Whitney-Wilcoxon", "Wilcoxon signed-rank"


class Outcome(Enum):
    """How a test ended."""

    TESTED = "tested"
    NO_VARIATION = "no variation"
    NOT_ENOUGH_DATA = "not enough data"


@dataclass(frozen=True)
class PairResult:
    """One post-hoc comparison of two groups (frozen): Conover's after Friedman,
    Mann-Whitney-Wilcoxon after Kruskal-Wallis, unadjusted as in the seed."""

    a: str
    b: str
    p_value: float

    @property
    def significant(self) -> bool:
        """``p < ALPHA``."""
        return self.p_value < ALPHA


@dataclass(frozen=True)
class StatResult:
    """One test's result (frozen).

    Attributes
    ----------
    test : str
        ``"Friedman"``, ``"Kruskal-Wallis"``, ``"Mann-Whitney-Wilcoxon"`` or
        ``"Wilcoxon signed-rank"``.
    outcome : Outcome
    groups : tuple of str
        The group labels, in the order given.
    sizes : tuple of int
        Values per group (Friedman and Wilcoxon: the complete blocks, the same for all).
    statistic, p_value : float or None
        chi-square, ``H``, ``U`` or ``W`` and its p-value; ``None`` unless tested.
    mean_ranks : tuple of float
        Each group's mean rank -- within blocks for Friedman and Wilcoxon, among all
        values otherwise: a lower rank is a smaller value.  Empty when not enough data.
    medians : tuple of float
        Each group's median (empty when a group is empty).
    smallest_p : float
        The smallest p-value the test can give at these group sizes (perfectly separated
        values); ``1.0`` when not enough data.  At or above :data:`ALPHA` the test cannot
        find a difference whatever the data: it has no power.
    posthoc : tuple of PairResult
        Every pair of groups (Friedman: Conover; Kruskal-Wallis: Mann-Whitney-Wilcoxon).
    note : str
        Why not tested, in words.
    """

    test: str
    outcome: Outcome
    groups: tuple[str, ...]
    sizes: tuple[int, ...]
    statistic: float | None = None
    p_value: float | None = None
    mean_ranks: tuple[float, ...] = ()
    medians: tuple[float, ...] = ()
    smallest_p: float = 1.0
    posthoc: tuple[PairResult, ...] = field(default=())
    note: str = ""

    @property
    def n(self) -> int:
        """Observations: blocks for Friedman and Wilcoxon, all values otherwise."""
        if self.test in (FRIEDMAN, WILCOXON):
            return self.sizes[0] if self.sizes else 0
        return sum(self.sizes)

    @property
    def significant(self) -> bool:
        """Tested and ``p < ALPHA``."""
        return self.p_value is not None and self.p_value < ALPHA

    @property
    def has_power(self) -> bool:
        """Whether these group sizes can give ``p < ALPHA`` at all."""
        return self.smallest_p < ALPHA

    @property
    def lowest(self) -> str | None:
        """The group with the strictly lowest mean rank (``None``: a tie, or no ranks)."""
        return _extreme(self.groups, self.mean_ranks, min)

    @property
    def highest(self) -> str | None:
        """The group with the strictly highest mean rank (``None``: a tie, or no ranks)."""
        return _extreme(self.groups, self.mean_ranks, max)

    @property
    def trend(self) -> str:
        """``"increases"`` or ``"decreases"`` when the mean ranks move one way over the
        groups in their given order (the levels of a factor), else ``"not monotone"``;
        ``""`` without ranks."""
        ranks = self.mean_ranks
        if len(ranks) < 2:
            return ""
        if all(a < b for a, b in itertools.pairwise(ranks)):
            return "increases"
        if all(a > b for a, b in itertools.pairwise(ranks)):
            return "decreases"
        return "not monotone"

    def pair(self, a: str, b: str) -> PairResult | None:
        """The post-hoc result of groups ``a`` and ``b`` (either order), if any."""
        for r in self.posthoc:
            if {r.a, r.b} == {a, b}:
                return r
        return None

    def direction(self) -> str:
        """The groups by mean rank, lowest first: ``"sda 1.2 < grape-s 2.1 < ..."``."""
        ordered = sorted(zip(self.groups, self.mean_ranks, strict=False), key=lambda g: g[1])
        return " < ".join(f"{g} {r:.3g}" for g, r in ordered)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, with the direction (``lowest``, ``highest``, ``trend``)."""
        return {
            "test": self.test,
            "outcome": self.outcome.value,
            "groups": list(self.groups),
            "sizes": list(self.sizes),
            "statistic": self.statistic,
            "p_value": self.p_value,
            "mean_ranks": list(self.mean_ranks),
            "medians": list(self.medians),
            "lowest": self.lowest,
            "highest": self.highest,
            "trend": self.trend,
            "smallest_p": self.smallest_p,
            "posthoc": [{"a": r.a, "b": r.b, "p": r.p_value} for r in self.posthoc],
            "note": self.note,
        }


def _extreme(groups: Sequence[str], ranks: Sequence[float], pick: Any) -> str | None:
    if not ranks:
        return None
    best = pick(ranks)
    winners = [g for g, r in zip(groups, ranks, strict=True) if r == best]
    return winners[0] if len(winners) == 1 else None


# --------------------------------------------------------------------------- inputs
def _arrays(groups: Mapping[str, Sequence[float]]) -> tuple[tuple[str, ...], list[np.ndarray]]:
    labels = tuple(str(g) for g in groups)
    arrays = []
    for label, values in groups.items():
        array = np.asarray(list(values), dtype=float)
        if array.ndim != 1 or not np.isfinite(array).all():
            raise ValueError(f"groups[{label!r}]: must be finite numbers, got {list(values)!r}")
        arrays.append(array)
    return labels, arrays


def _medians(arrays: Sequence[np.ndarray]) -> tuple[float, ...]:
    if any(len(a) == 0 for a in arrays):
        return ()
    return tuple(float(np.median(a)) for a in arrays)


def _too_few(test: str, labels: tuple[str, ...], sizes: tuple[int, ...], why: str) -> StatResult:
    return StatResult(test, Outcome.NOT_ENOUGH_DATA, labels, sizes, note=f"not enough data: {why}")


def _all_equal(arrays: Sequence[np.ndarray]) -> bool:
    return len(set(np.concatenate(arrays).tolist())) == 1


def _flat(
    test: str, labels: tuple[str, ...], sizes: tuple[int, ...], why: str, base: dict[str, Any]
) -> StatResult:
    return StatResult(
        test, Outcome.NO_VARIATION, labels, sizes, note=f"no variation: {why}", **base
    )


def _pooled_ranks(arrays: Sequence[np.ndarray]) -> tuple[float, ...]:
    from scipy import stats

    pooled = stats.rankdata(np.concatenate(arrays))
    out, start = [], 0
    for a in arrays:
        out.append(float(pooled[start : start + len(a)].mean()))
        start += len(a)
    return tuple(out)


def _block_ranks(matrix: np.ndarray) -> tuple[float, ...]:
    from scipy import stats

    return tuple(float(r) for r in stats.rankdata(matrix, axis=1).mean(axis=0))


def _separated(sizes: Sequence[int]) -> list[np.ndarray]:
    """Groups of these sizes whose values do not overlap: the most extreme data."""
    out, start = [], 0
    for size in sizes:
        out.append(np.arange(start, start + size, dtype=float))
        start += size
    return out


# ----------------------------------------------------------------------------- tests
def friedman(groups: Mapping[str, Sequence[float]], *, posthoc: bool = True) -> StatResult:
    """Friedman's test of ``k >= 3`` related groups (one value per group and block, in the
    same block order), with Conover's post-hoc test (``scikit_posthocs``).

    Parameters
    ----------
    groups : mapping of str to sequence of float
        Each group's values, block by block (e.g. each algorithm's result on each
        mission); all of the same length (see :func:`complete_blocks`).
    posthoc : bool, default True

    Returns
    -------
    StatResult
        Mean ranks within blocks; ``smallest_p`` from ``n`` identically ranked blocks.

    Raises
    ------
    ValueError
        Groups of different lengths, or values that are not finite.

    Examples
    --------
    >>> r = friedman({"a": [1, 2, 3], "b": [2, 3, 4], "c": [3, 4, 5]})
    >>> r.statistic, r.lowest, round(r.smallest_p, 4)
    (6.0, 'a', 0.0498)
    """
    labels, arrays = _arrays(groups)
    if len({len(a) for a in arrays}) > 1:
        raise ValueError(
            f"groups: Friedman needs one value per group and block, got lengths "
            f"{[len(a) for a in arrays]}"
        )
    blocks = len(arrays[0]) if arrays else 0
    sizes = (blocks,) * len(labels)
    if len(labels) < 3:
        return _too_few(FRIEDMAN, labels, sizes, f"{len(labels)} groups, Friedman needs 3")
    if blocks < 2:
        return _too_few(FRIEDMAN, labels, sizes, f"{blocks} blocks, Friedman needs 2")
    from scipy import stats

    matrix = np.column_stack(arrays)
    k = len(labels)
    base = dict(
        mean_ranks=_block_ranks(matrix),
        medians=_medians(arrays),
        smallest_p=float(stats.chi2.sf(blocks * (k - 1), k - 1)),
    )
    if (matrix == matrix[:, :1]).all():
        return _flat(FRIEDMAN, labels, sizes, "every block ties all groups", base)
    chi2, p = stats.friedmanchisquare(*arrays)
    pairs: tuple[PairResult, ...] = ()
    if posthoc:
        import scikit_posthocs

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            table = scikit_posthocs.posthoc_conover_friedman(matrix).to_numpy()
        pairs = tuple(
            PairResult(labels[i], labels[j], float(table[i, j]))
            for i, j in itertools.combinations(range(k), 2)
        )
    return StatResult(
        FRIEDMAN, Outcome.TESTED, labels, sizes, float(chi2), float(p), posthoc=pairs, **base
    )


def kruskal(groups: Mapping[str, Sequence[float]], *, posthoc: bool = True) -> StatResult:
    """The Kruskal-Wallis test of ``k >= 3`` independent groups, with pairwise
    Mann-Whitney-Wilcoxon post-hoc tests (two-sided, unadjusted).

    Parameters
    ----------
    groups : mapping of str to sequence of float
        Each level's values, levels in their natural order (so that :attr:`StatResult.trend`
        reads along the factor).
    posthoc : bool, default True

    Returns
    -------
    StatResult
        Mean ranks among all values; ``smallest_p`` from perfectly separated groups.

    Examples
    --------
    >>> kruskal({"1": [1.0], "10": [2.0]}).note
    'not enough data: 2 groups, Kruskal-Wallis needs 3 (two groups: Mann-Whitney-Wilcoxon)'
    """
    labels, arrays = _arrays(groups)
    sizes = tuple(len(a) for a in arrays)
    if len(labels) < 3:
        why = f"{len(labels)} groups, Kruskal-Wallis needs 3 (two groups: Mann-Whitney-Wilcoxon)"
        return _too_few(KRUSKAL, labels, sizes, why)
    if min(sizes) == 0:
        return _too_few(KRUSKAL, labels, sizes, f"an empty group (sizes {list(sizes)})")
    from scipy import stats

    base = dict(
        mean_ranks=_pooled_ranks(arrays),
        medians=_medians(arrays),
        smallest_p=_kruskal_smallest_p(sizes),
    )
    if _all_equal(arrays):
        return _flat(KRUSKAL, labels, sizes, "every value is the same", base)
    h, p = stats.kruskal(*arrays)
    pairs: tuple[PairResult, ...] = ()
    if posthoc:
        pairs = tuple(
            PairResult(labels[i], labels[j], _mann_whitney_p(arrays[i], arrays[j]))
            for i, j in itertools.combinations(range(len(labels)), 2)
        )
    return StatResult(
        KRUSKAL, Outcome.TESTED, labels, sizes, float(h), float(p), posthoc=pairs, **base
    )


def _kruskal_smallest_p(sizes: Sequence[int]) -> float:
    from scipy import stats

    orders = set(itertools.permutations(sizes)) if len(sizes) <= 6 else [sorted(sizes)]
    best = max(float(stats.kruskal(*_separated(order))[0]) for order in orders)
    return float(stats.chi2.sf(best, len(sizes) - 1))


def _mann_whitney_p(a: np.ndarray, b: np.ndarray) -> float:
    from scipy import stats

    if _all_equal([a, b]):
        return 1.0
    return float(stats.mannwhitneyu(a, b, alternative="two-sided")[1])


def mann_whitney(groups: Mapping[str, Sequence[float]]) -> StatResult:
    """The Mann-Whitney-Wilcoxon rank-sum test of two independent groups (two-sided;
    scipy's exact distribution for small samples without ties).

    Examples
    --------
    >>> r = mann_whitney({"5": [1, 2, 3, 4], "10": [5, 6, 7, 8]})
    >>> r.statistic, round(r.p_value, 4), r.highest
    (0.0, 0.0286, '10')
    """
    labels, arrays = _arrays(groups)
    sizes = tuple(len(a) for a in arrays)
    if len(labels) != 2:
        return _too_few(MANN_WHITNEY, labels, sizes, f"{len(labels)} groups, the test compares 2")
    if min(sizes) == 0:
        return _too_few(MANN_WHITNEY, labels, sizes, f"an empty group (sizes {list(sizes)})")
    from scipy import stats

    base = dict(
        mean_ranks=_pooled_ranks(arrays),
        medians=_medians(arrays),
        smallest_p=float(stats.mannwhitneyu(*_separated(sizes), alternative="two-sided")[1]),
    )
    if _all_equal(arrays):
        return _flat(MANN_WHITNEY, labels, sizes, "every value is the same", base)
    u, p = stats.mannwhitneyu(*arrays, alternative="two-sided")
    return StatResult(MANN_WHITNEY, Outcome.TESTED, labels, sizes, float(u), float(p), **base)


def wilcoxon(groups: Mapping[str, Sequence[float]]) -> StatResult:
    """Wilcoxon's signed-rank test of two related groups (pairs in the same order;
    two-sided, zero differences dropped as scipy's default ``zero_method="wilcox"``).

    ``smallest_p`` is that of as many pairs as have a non-zero difference, all of one sign.

    Examples
    --------
    >>> r = wilcoxon({"grape-s": [1, 2, 3, 4, 5, 6], "sda": [2, 4, 6, 8, 10, 12]})
    >>> r.statistic, round(r.p_value, 4), r.lowest
    (0.0, 0.0312, 'grape-s')
    """
    labels, arrays = _arrays(groups)
    if len(labels) != 2:
        sizes = tuple(len(a) for a in arrays)
        return _too_few(WILCOXON, labels, sizes, f"{len(labels)} groups, the test compares 2")
    a, b = arrays
    if len(a) != len(b):
        raise ValueError(f"groups: Wilcoxon needs pairs, got lengths {len(a)} and {len(b)}")
    sizes = (len(a), len(b))
    if len(a) == 0:
        return _too_few(WILCOXON, labels, sizes, "no pairs")
    from scipy import stats

    differing = int(np.count_nonzero(a - b))
    smallest = float(stats.wilcoxon(np.arange(1.0, differing + 1))[1]) if differing else 1.0
    base = dict(
        mean_ranks=_block_ranks(np.column_stack(arrays)),
        medians=_medians(arrays),
        smallest_p=smallest,
    )
    if differing == 0:
        return _flat(WILCOXON, labels, sizes, "every pair is equal", base)
    w, p = stats.wilcoxon(a, b)
    return StatResult(WILCOXON, Outcome.TESTED, labels, sizes, float(w), float(p), **base)


# ------------------------------------------------------------------------- helpers
def complete_blocks(
    observations: Iterable[tuple[Hashable, str, float | None]], groups: Sequence[str]
) -> dict[str, list[float]]:
    """Align ``(block, group, value)`` observations for a related-samples test: the
    blocks that have a value for every group, in the order first seen, as
    ``{group: [value per block]}``.  Non-finite values are left out (so is their block).

    >>> complete_blocks([(1, "a", 1.0), (1, "b", 2.0), (2, "a", 3.0)], ["a", "b"])
    {'a': [1.0], 'b': [2.0]}
    """
    blocks: dict[Hashable, dict[str, float]] = {}
    for block, group, value in observations:
        if group in groups and value is not None and math.isfinite(value):
            blocks.setdefault(block, {})[group] = float(value)
    full = [b for b in blocks.values() if len(b) == len(groups)]
    return {g: [b[g] for b in full] for g in groups}
