"""Shared machinery of the auction baselines (SDA, RACHNA_dt): exact cheapest bundles,
argument checks and the task-agent / service-agent message model.

Cheapest bundle
---------------
A task ``j`` needing ``r_js`` robots of each service ``s`` (``k = sum_s r_js`` slots) buys
the bundle that minimises, lexicographically, ``(sum of prices, sum of flags, sum of robot
indices)`` over all complete, feasible bundles of *available* robots (a robot fills one
slot of a service it has).  Prices are given as integers ``weight[i]`` such that a bundle's
price is an increasing affine function of ``sum weight`` (every bundle has exactly ``k``
robots, so a common shift of the weights does not change the order); flags (RACHNA_dt:
"robot is held by another task") and indices only break ties.

Candidate restriction (exact).  For each needed service ``s`` only the ``k`` first
available robots having ``s`` in the per-robot order ``(weight, flag, index)`` are
candidates.  Proof: let ``B`` be an optimal bundle and ``x`` a robot of ``B`` serving
``s`` that is not among those ``k``.  ``B`` has ``k`` robots, ``x`` is one of them and lies
outside the ``k`` candidates of ``s``, so at most ``k - 1`` robots of ``B`` are candidates
of ``s``: some candidate ``y`` of ``s`` is not in ``B``.  ``y`` precedes ``x`` strictly in
the per-robot order, so putting ``y`` in ``x``'s slot gives a feasible bundle that is
strictly better in the lexicographic objective -- a contradiction.  Hence every optimal
bundle uses candidates only, and so does any feasible bundle after such exchanges (the
restricted problem is feasible iff the full one is).  The matching therefore has at most
``k * |services of j|`` rows instead of ``n``.

Matching.  ``scipy.optimize.linear_sum_assignment`` on a ``k x |candidates|`` matrix: one
row per slot copy, entry ``inf`` where the candidate lacks the slot's service
(``ValueError: cost matrix is infeasible`` means no complete bundle).  The lexicographic
objective is encoded as one integer per candidate, ``w' K_w + flag K_f + index`` with
``w' = weight - min(weight)``, ``K_f = k n`` and ``K_w = (k + 1) K_f`` (``K_f`` when no flag),
so every bundle sum is an integer.  When the largest bundle sum stays below 2**53 the float64
matching is exact; otherwise the index tie-break is dropped (then the flag), and only if even
the bare weights exceed 2**53 is the matching done on rounded floats (a case neither auction
reaches in practice: SDA's weights are 0 or 1 and a RACHNA_dt wage is at most its number of
purchases; the affordability comparison stays exact regardless).  Ties that remain
(equal sums of all three keys) are resolved by scipy's deterministic algorithm.  Which of
several services a multi-service robot performs inside a bundle does not change any price, so
it never changes an auction's trajectory.

Pruning.  A task that needs more robots of some service than the mission has robots with
it, or more robots in all (``k``) than have one of its services, has no complete bundle
ever, whatever is sold or held.  :class:`BundleFinder` marks such tasks at construction
(``possible``) and never builds their slots: :meth:`BundleFinder.cheapest` answers
``None`` for them at once, so a requirement of ``2**31 - 1`` costs O(1) time and memory.
Both auctions treat a pruned task exactly as the literal auction does (it never bids and
is counted as it would be), so pruning changes no trajectory and no count.  Every task
kept needs ``k <= n`` robots.

Message model (both auctions)
-----------------------------
Messages go between the ``m`` task agents and the ``S`` service agents (one per service
type; each holds the wages of all robots having its service).  Every message has an 8-byte
header (int32 round, int32 sender) and 12 bytes per entry (int32 robot, int64 price in the
auction's integer units); an answer is header only.  The kinds are listed in each auction's
docstring.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import linear_sum_assignment

from cfopt import MissionError
from cfopt.checks import require_number

__all__ = ["ENTRY_BYTES", "HEADER_BYTES", "Bundle", "BundleFinder", "check_eps"]

#: Message header: int32 round + int32 sender.
HEADER_BYTES = 8
#: One entry of a message: int32 robot + int64 price.
ENTRY_BYTES = 12
_EXACT = 2**53
_KEY_SAFE = 2**61


def check_eps(eps: Any, name: str = "eps") -> Fraction:
    """``eps`` as an exact :class:`fractions.Fraction` (a float is taken at its exact binary
    value); it must be a finite real number > 0."""
    require_number(name, eps, above=0, finite=False, what="a finite number")
    if isinstance(eps, numbers.Rational):
        return Fraction(int(eps.numerator), int(eps.denominator))
    f = float(eps)
    if not math.isfinite(f):
        raise MissionError(f"{name}: must be a finite number > 0, got {eps!r}")
    return Fraction(f)


def check_order(order: Any) -> str:
    """The auctions have no robot order: only ``"index"`` (ties by index) is accepted."""
    if order != "index":
        raise MissionError(
            f"order: the auctions break every tie by index and accept only 'index', got {order!r}"
        )
    return order


@dataclass(frozen=True)
class Bundle:
    """A complete bundle: ``robots[i]`` performs ``services[i]``; exact key sums."""

    robots: npt.NDArray[np.int64]
    services: npt.NDArray[np.int64]
    weight: int
    flags: int


class BundleFinder:
    """Cheapest complete bundles for the tasks of one mission (see the module docstring).

    Attributes
    ----------
    k : list of int
        ``k[j] = sum_s r_js``, the robots task ``j`` needs in all (exact Python ints).
    reach : ndarray of int64, shape (m,)
        Robots having at least one service task ``j`` needs.
    slot_service : indexable by task
        ``slot_service[j]``: the service of each of the ``k_j`` slots of a kept task, as an
        int64 array built on first use (``ValueError`` for a pruned task).
    kinds, kind_count : ndarray
        The distinct capability rows (``K x S`` bool, ``K <= n``) and how many robots have
        each.
    possible : ndarray of bool, shape (m,)
        ``False`` for a task pruned as never staffable (see "Pruning" in the module
        docstring): :meth:`cheapest` answers ``None`` for it at once.
    matchings, entries : int
        Calls of the matching and cost-matrix entries handed to it (the engine's own work,
        for profiling).

    Notes
    -----
    Construction is O(n S + K m S) with ``K <= n`` the distinct capability rows; nothing
    proportional to a requirement count is allocated (a pruned task never gets slots, a
    kept one needs ``k_j <= n``).
    """

    def __init__(self, caps: npt.NDArray[np.bool_], reqs: npt.NDArray[np.int64]) -> None:
        self.caps = caps
        self.n = caps.shape[0]
        m, n_services = reqs.shape
        self.robots_with = [np.flatnonzero(caps[:, s]).astype(np.int64) for s in range(n_services)]
        self.need: list[npt.NDArray[np.int64]] = []
        self.counts: list[list[int]] = []
        for j in range(m):
            need = np.flatnonzero(reqs[j]).astype(np.int64)
            self.need.append(need)
            self.counts.append(reqs[j, need].tolist())
        self.k = [sum(c) for c in self.counts]
        needs = reqs > 0
        self.kinds, self.kind_count = _kinds(caps.reshape(self.n, n_services))
        touches = (self.kinds.astype(np.int64) @ needs.T.astype(np.int64)) > 0  # K x m
        self.reach = self.kind_count @ touches.astype(np.int64)
        have = caps.sum(axis=0).astype(np.int64)  # robots per service
        enough = ~(reqs > have[None, :]).any(axis=1)
        within = np.array(
            [k <= r for k, r in zip(self.k, self.reach.tolist(), strict=True)], dtype=bool
        )
        self.possible = enough & within
        self.slot_service = _Slots(self.need, self.counts, self.possible)
        self._pool: dict[int, npt.NDArray[np.int64]] = {}
        self.matchings = 0
        self.entries = 0

    def pool(self, j: int) -> npt.NDArray[np.int64]:
        """Robots having at least one service task ``j`` needs, ascending.

        O(n |S_j|) on the first call for ``j``, O(1) after (cached).
        """
        robots = self._pool.get(j)
        if robots is None:
            robots = np.flatnonzero(self.caps[:, self.need[j]].any(axis=1)).astype(np.int64)
            self._pool[j] = robots
        return robots

    def cheapest(
        self,
        j: int,
        pools: list[npt.NDArray[np.int64]],
        weight: npt.NDArray[np.int64],
        flag: npt.NDArray[np.int64] | None = None,
    ) -> Bundle | None:
        """The optimal bundle of task ``j`` among ``pools[s]`` (available robots having
        ``s``, ascending), or ``None`` when no complete bundle exists.

        O(1) for a pruned task; otherwise O(sum_s |pools[s]|) to pick the candidates plus
        one matching on a ``k_j x`` (at most ``k_j |S_j|``) matrix.
        """
        if not self.possible[j]:
            return None
        k, n = self.k[j], self.n
        parts = []
        for s, r in zip(self.need[j].tolist(), self.counts[j], strict=True):
            pool = pools[s]
            if pool.size < r:
                return None
            if pool.size > k:
                pool = pool[self._first(pool, k, weight, flag)]
            parts.append(pool)
        cand = np.unique(np.concatenate(parts)) if len(parts) > 1 else np.sort(parts[0])
        if cand.size < k:
            return None
        w = weight[cand]
        wmin = int(w.min())
        wmax = int(w.max()) - wmin
        f = None if flag is None else flag[cand]
        k_f = k * n
        k_w = (k + 1) * k_f if f is not None else k_f
        use_index, use_flag = True, f is not None
        if k * (wmax * k_w + k_f + n) >= _EXACT:
            use_index = False
            k_f = 1
            k_w = k + 1 if use_flag else 1
            if k * (wmax * k_w + k_f) >= _EXACT:
                use_flag, k_w = False, 1
        comp = (w - wmin).astype(np.float64) * float(k_w)
        if use_flag:
            comp += f.astype(np.float64) * float(k_f)
        if use_index:
            comp += cand.astype(np.float64)
        slots = self.slot_service[j]
        allowed = self.caps[cand][:, slots].T
        cost = np.where(allowed, comp[None, :], np.inf)
        self.matchings += 1
        self.entries += cost.size
        try:
            rows, cols = linear_sum_assignment(cost)
        except ValueError:
            return None
        robots = cand[cols]
        return Bundle(
            robots=robots,
            services=slots[rows],
            weight=int(weight[robots].sum()),
            flags=0 if flag is None else int(flag[robots].sum()),
        )

    def _first(
        self,
        pool: npt.NDArray[np.int64],
        k: int,
        weight: npt.NDArray[np.int64],
        flag: npt.NDArray[np.int64] | None,
    ) -> npt.NDArray[np.intp]:
        """Positions of the ``k`` first robots of ``pool`` in the order (weight, flag, index)."""
        w = weight[pool]
        n = self.n
        if int(w.max(initial=0)) < _KEY_SAFE // (4 * max(n, 1)) and int(w.min(initial=0)) >= 0:
            key = w * 2 if flag is not None else w
            if flag is not None:
                key = key + flag[pool]
            key = key * n + pool
            return np.argpartition(key, k - 1)[:k]
        keys = (pool, w) if flag is None else (pool, flag[pool], w)
        return np.lexsort(keys)[:k]


class _Slots:
    """``slots[j]``: the service of each slot of kept task ``j``, built once on first use."""

    def __init__(
        self,
        need: list[npt.NDArray[np.int64]],
        counts: list[list[int]],
        possible: npt.NDArray[np.bool_],
    ) -> None:
        self._need, self._counts, self._possible = need, counts, possible
        self._cache: dict[int, npt.NDArray[np.int64]] = {}

    def __getitem__(self, j: int) -> npt.NDArray[np.int64]:
        slots = self._cache.get(j)
        if slots is None:
            if not self._possible[j]:
                raise ValueError(f"task {j} can never be staffed: its slots are not built")
            slots = np.repeat(self._need[j], self._counts[j])
            self._cache[j] = slots
        return slots


def _kinds(caps: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.int64]]:
    """The distinct rows of ``caps`` and how many times each occurs.  O(n S + n log n)."""
    n_services = caps.shape[1]
    if n_services <= 62:  # one int64 code per row: a 1-d unique is much faster
        codes = caps.astype(np.int64) @ (np.int64(1) << np.arange(n_services, dtype=np.int64))
        values, counts = np.unique(codes, return_counts=True)
        kinds = (values[:, None] >> np.arange(n_services, dtype=np.int64)[None, :]) & 1
        return kinds.astype(bool), counts.astype(np.int64)
    kinds, counts = np.unique(caps, axis=0, return_counts=True)
    return kinds, counts.astype(np.int64)
