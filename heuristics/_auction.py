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
the bare weights exceed 2**53 is the matching done on rounded floats (a case the seed's
missions never reach; the affordability comparison stays exact regardless).  Ties that remain
(equal sums of all three keys) are resolved by scipy's deterministic algorithm.  Which of
several services a multi-service robot performs inside a bundle does not change any price, so
it never changes an auction's trajectory.

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
    if isinstance(eps, bool) or not isinstance(eps, numbers.Real):
        raise MissionError(f"{name}: must be a finite number > 0, got {eps!r}")
    if isinstance(eps, numbers.Rational):
        value = Fraction(int(eps.numerator), int(eps.denominator))
    else:
        f = float(eps)
        if not math.isfinite(f):
            raise MissionError(f"{name}: must be a finite number > 0, got {eps!r}")
        value = Fraction(f)
    if value <= 0:
        raise MissionError(f"{name}: must be a finite number > 0, got {eps!r}")
    return value


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

    ``entries`` counts the cost-matrix entries handed to the matching (the engine's own
    work, for profiling); ``matchings`` the calls.
    """

    def __init__(self, caps: npt.NDArray[np.bool_], reqs: npt.NDArray[np.int64]) -> None:
        self.caps = caps
        self.n = caps.shape[0]
        m, n_services = reqs.shape
        self.robots_with = [np.flatnonzero(caps[:, s]).astype(np.int64) for s in range(n_services)]
        self.need: list[npt.NDArray[np.int64]] = []
        self.counts: list[list[int]] = []
        self.slot_service: list[npt.NDArray[np.int64]] = []
        for j in range(m):
            need = np.flatnonzero(reqs[j]).astype(np.int64)
            self.need.append(need)
            self.counts.append(reqs[j, need].tolist())
            self.slot_service.append(np.repeat(need, reqs[j, need]))
        self.k = [int(x) for x in reqs.sum(axis=1)]
        self.matchings = 0
        self.entries = 0

    def cheapest(
        self,
        j: int,
        pools: list[npt.NDArray[np.int64]],
        weight: npt.NDArray[np.int64],
        flag: npt.NDArray[np.int64] | None = None,
    ) -> Bundle | None:
        """The optimal bundle of task ``j`` among ``pools[s]`` (available robots having
        ``s``, ascending), or ``None`` when no complete bundle exists."""
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
