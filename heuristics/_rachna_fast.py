"""The simultaneous RACHNA_dt engine's incremental price book (private).

:class:`Ledger` answers the same question as :class:`heuristics.rachna._Book` -- task
``j``'s cheapest bundle on the current wages and flags -- with the same answers, but it
keeps its state from round to round instead of rebuilding it:

* the robots stay in one sorted list of keys ``wage K_w + held K_f + index`` (the keys of
  :class:`heuristics.rachna._Market`), updated for the few robots a round changes, so a
  round costs no O(n log n) sort and a search no O(n) pool mask;
* a task's bundle is kept between rounds while it provably stays the one the search would
  return (see :meth:`Ledger.update`), so a task whose candidates did not move is not
  searched again.

Why the cache is exact.  The search's two shortcuts each return the *unique* optimum (keys
are distinct: the ``k_j`` least keys of the pool, or the ``r_js`` least keys having each
service when these sets are disjoint), so their answer depends on the order of the keys
alone, and only on the keys up to the bundle's largest, ``theta_j``.  Bought robots' keys
rise, released robots' keys fall.  If no robot of the bundle changed and every changed
robot of the pool has a new key above ``theta_j``, the ``k_j`` least keys of the pool, and
the ``r_js`` least keys having each service, are the same robots, so either shortcut (and
the search tries them in that order) gives the same unique optimum.  A bundle found by the
matching is never kept: every such search is run again, as the literal engine runs it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import linear_sum_assignment
from sortedcontainers import SortedList

#: Slot fillings remembered (a capability pattern recurs); the memo is emptied when full.
_FILLS = 1 << 16
_MISSING = object()
_NO_KEY = np.iinfo(np.int64).max  # above every key of the ledger
_RANKED = 32  # the most robots per service :meth:`Ledger.blocked` looks at
#: The most words :class:`LastBundles` may take (128 MiB); above, it is not made.
_LAST_CELLS = 1 << 24
Found = tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], int]
Fill = Callable[[Any, int, npt.NDArray[np.int64]], npt.NDArray[np.int64] | None]


class Ledger:
    """Incremental cheapest bundles for the simultaneous engine (module docstring).

    Parameters
    ----------
    market : heuristics.rachna._Market
        The fixed parts of the search (finder, key multipliers, the int64 wage limit).
    wage, held : ndarray of int64, shape (n,)
        The engine's wage and flag arrays, read (never written) by the ledger; after the
        engine changes them it calls :meth:`update` with the robots changed, or
        :meth:`rebuild` after a jump.
    fill : callable
        ``fill(finder, j, robots)``: the literal engine's slot filling (``_services``),
        used where the fast filling here does not decide.

    Notes
    -----
    Memory O(n + m S + the kept bundles + the memo of at most 2^16 slot fillings), plus
    the holders: one integer of at most ``m`` bits per robot of a kept bundle, so at most
    ``min(n, sum k_j) m / 8`` bytes, whatever bundles were kept before.  A search walks
    the sorted keys from the cheapest until the bundle is complete: O(k_j) when most
    robots of the pool are cheap enough, O(n) at worst.
    """

    def __init__(
        self,
        market: Any,
        wage: npt.NDArray[np.int64],
        held: npt.NDArray[np.int64],
        fill: Fill,
    ) -> None:
        finder = market.finder
        self.market, self.finder, self.wage, self.held, self.fill = (
            market,
            finder,
            wage,
            held,
            fill,
        )
        self.k_f, self.k_w, self.limit = market.k_f, market.k_w, market.limit
        self.exact_limit = _exact_limit(finder)
        caps = np.asarray(finder.caps, dtype=bool)
        self.code = _codes(caps)
        self.narrow = caps.shape[1] <= 62  # the codes fit in int64
        self.need = [need.tolist() for need in finder.need]
        self.mask = [sum(1 << s for s in need) for need in self.need]
        slots: dict[tuple[tuple[int, ...], tuple[int, ...]], int] = {}
        self.slots_of = [  # tasks with the same services and counts share their fillings
            slots.setdefault((tuple(need), tuple(counts)), len(slots))
            for need, counts in zip(self.need, finder.counts, strict=True)
        ]
        self.need_matrix = np.zeros((len(self.need), caps.shape[1]), dtype=np.int64)
        for j, need in enumerate(self.need):
            self.need_matrix[j, need] = 1
        self.caps64 = caps.astype(np.int64)
        # per task and service the count r_js (0: not needed), capped for the walk of
        # :meth:`blocked`, and per service the largest such count
        self.rank_counts = np.zeros_like(self.need_matrix)
        for j, (need, c) in enumerate(zip(self.need, finder.counts, strict=True)):
            self.rank_counts[j, need] = np.minimum(c, _RANKED)
        self.rank_top = self.rank_counts.max(axis=0, initial=0).tolist()
        present = 0  # every service some robot has and some task needs
        for c in set(self.code):
            present |= c
        self.open_mask = present & sum(1 << s for s, r in enumerate(self.rank_top) if r > 0)
        self.theta = np.full(len(self.need), -1, dtype=np.int64)  # -1: nothing kept
        self.kept: dict[int, Found] = {}
        self.kept_robots: dict[int, list[int]] = {}
        # per robot, bit j set when task j's kept bundle has it: an integer shrinks with
        # its highest bit, where a set keeps the table of its largest size (n tables of up
        # to m tasks, hundreds of MB when all tasks once kept the same cheap robots)
        self.holders = [0] * finder.n
        self.fills: dict[tuple[int, ...], Any] = {}
        self.rebuild()

    # ------------------------------------------------------------------ state
    def rebuild(self) -> None:
        """Recompute every key from the wage and flag arrays and drop every kept bundle.
        O(n log n)."""
        wage, held = self.wage, self.held
        n = wage.size
        self.max_wage = int(wage.max(initial=0))
        self.fast = self.max_wage <= self.limit
        self.exact = self.fast and self.max_wage <= self.exact_limit
        for j in list(self.kept):
            self._forget(j)
        if not self.fast:
            self.keys: list[int] = []
            self.sorted = SortedList()
            return
        keys = wage * self.k_w + held * self.k_f + np.arange(n, dtype=np.int64)
        self.keys = keys.tolist()
        self.sorted = SortedList(self.keys)

    def update(self, changed: npt.NDArray[np.int64]) -> None:
        """Take the new wages and flags of ``changed`` robots into account.

        A kept bundle is dropped when one of its robots changed, or when a changed robot
        of its pool now has a key below its largest (module docstring).  O(|changed|
        (log n + the bundles holding them) + m S |released|).
        """
        if changed.size == 0:
            return
        top = int(self.wage[changed].max())
        if top > self.max_wage:
            self.max_wage = top
            self.exact = self.exact and top <= self.exact_limit
        if not self.fast or self.max_wage > self.limit:
            self.fast = self.exact = False
            for j in list(self.kept):
                self._forget(j)
            return
        new = (self.wage[changed] * self.k_w + self.held[changed] * self.k_f + changed).tolist()
        keys, ordered, holders = self.keys, self.sorted, self.holders
        fallen_robots, fallen_keys = [], []
        for i, key in zip(changed.tolist(), new, strict=True):
            old = keys[i]
            if old == key:
                continue
            ordered.remove(old)
            ordered.add(key)
            keys[i] = key
            for j in _bits(holders[i]):
                self._forget(j)
            if key < old:
                fallen_robots.append(i)
                fallen_keys.append(key)
        if fallen_robots and self.kept:
            in_pool = (self.need_matrix @ self.caps64[fallen_robots].T) > 0  # m x fallen
            below = self.theta[:, None] > np.asarray(fallen_keys, dtype=np.int64)[None, :]
            for j in np.flatnonzero((in_pool & below).any(axis=1)).tolist():
                self._forget(j)

    def drop(self, j: int) -> None:
        """Forget task ``j``'s bundle (the task gave up: it is never searched again)."""
        if j in self.kept:
            self._forget(j)

    def _forget(self, j: int) -> None:
        bit, holders = 1 << j, self.holders
        for i in self.kept_robots.pop(j):
            holders[i] ^= bit
        del self.kept[j]
        self.theta[j] = -1

    def _keep(self, j: int, found: Found, robots: list[int], theta: int) -> None:
        self.kept[j] = found
        self.kept_robots[j] = robots
        self.theta[j] = theta
        bit, holders = 1 << j, self.holders
        for i in robots:
            holders[i] |= bit

    # ------------------------------------------------------------------ search
    def book(self) -> Any:
        """The object whose ``best(j)`` answers this round: the ledger itself, or the
        literal engine's book when the wages passed the int64 keys' limit."""
        if self.fast:
            return self
        return self.market.book(self.wage, self.held)

    def best(self, j: int) -> Found | None:
        """``(robots ascending, their services, price in units)`` of task ``j``'s cheapest
        bundle, or ``None`` when it has none: exactly :meth:`heuristics.rachna._Book.best`
        on the current wages and flags."""
        found = self.kept.get(j)
        if found is not None:
            return found
        finder = self.finder
        if not finder.possible[j]:
            return None
        k = finder.k[j]
        picked, theta = self._least_of_pool(j, k)
        robots = sorted(picked)
        services = self._fill(j, robots)
        if services is None:
            picked, theta = self._least_per_service(j)
            robots = sorted(picked)
            if len(robots) == k:
                services = self._fill(j, robots)
        if services is not None:
            wage_unit = self.k_w
            price = sum(self.keys[i] // wage_unit for i in robots) + k
            found = (np.asarray(robots, dtype=np.int64), services, price)
            self._keep(j, found, robots, theta)
            return found
        b = finder.cheapest(j, self._least_having(j, k), self.wage, self.held)
        if b is None:
            return None
        robots_arr = np.sort(b.robots)
        services = self._fill(j, robots_arr.tolist())
        assert services is not None
        return robots_arr, services, int(b.weight) + k

    def blocked(
        self, tasks: npt.NDArray[np.int64], taken: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.bool_]:
        """Per task of ``tasks`` (all possible): whether its cheapest bundle surely holds a
        robot of ``taken``, while :attr:`exact` holds (the keys then order bundles
        exactly and the cheapest is unique).

        For each service ``s`` a task needs ``r_s`` times, the ``r_s`` robots of least key
        having ``s`` are in its cheapest bundle: were one of them out, a robot filling one
        of its ``s`` slots would be outside them, of larger key, and exchanging the two
        would give a cheaper bundle.  So a task is blocked when, for some ``s``, a taken
        robot ranks among the first ``min(r_s, 32)`` having ``s``.  One walk of the sorted
        keys finds each service's first taken robot (it stops when every service has one
        or is past its largest count).  O(the keys walked x S + |tasks| S).
        """
        code, k_f, counts = self.code, self.k_f, self.rank_counts
        rank = np.full(counts.shape[1], _NO_KEY, dtype=np.int64)
        seen = [0] * counts.shape[1]
        top = self.rank_top
        open_mask = self.open_mask
        for key in self.sorted:
            i = key % k_f
            has = code[i] & open_mask
            if not has:
                continue
            if taken[i]:
                for s in _bits(has):
                    rank[s] = seen[s]
                open_mask &= ~has
            else:
                for s in _bits(has):
                    seen[s] += 1
                    if seen[s] >= top[s]:
                        open_mask &= ~(1 << s)
            if not open_mask:
                break
        return (counts[tasks] > rank[None, :]).any(axis=1)

    def _least_of_pool(self, j: int, k: int) -> tuple[list[int], int]:
        """The ``k`` robots of least key having a service ``j`` needs, and the largest key
        among them.  O(the keys walked)."""
        mask, code, k_f = self.mask[j], self.code, self.k_f
        picked: list[int] = []
        theta = -1
        for key in self.sorted:
            i = key % k_f
            if code[i] & mask:
                picked.append(i)
                if len(picked) == k:
                    theta = key
                    break
        return picked, theta

    def _least_per_service(self, j: int) -> tuple[set[int], int]:
        """The union over ``j``'s services ``s`` of the ``r_js`` robots of least key having
        ``s``, and the largest key among them.  O(the keys walked)."""
        code, k_f = self.code, self.k_f
        want = dict(zip(self.need[j], self.finder.counts[j], strict=True))
        open_mask = self.mask[j]
        picked: set[int] = set()
        theta = -1
        for key in self.sorted:
            i = key % k_f
            has = code[i] & open_mask
            if not has:
                continue
            for s in self.need[j]:
                if has >> s & 1:
                    picked.add(i)
                    theta = key
                    want[s] -= 1
                    if want[s] == 0:
                        open_mask &= ~(1 << s)
            if not open_mask:
                break
        return picked, theta

    def _least_having(self, j: int, k: int) -> dict[int, npt.NDArray[np.int64]]:
        """For each service ``s`` task ``j`` needs, the ``k`` robots of least key having
        ``s`` (all of them when fewer have it).  These are exactly the candidates the
        matching of :meth:`BundleFinder.cheapest` keeps from the full pools, and a pool of
        at most ``k`` robots is taken whole, so the matching sees the same candidates.
        O(the keys walked)."""
        code, k_f = self.code, self.k_f
        parts: dict[int, list[int]] = {s: [] for s in self.need[j]}
        open_mask = self.mask[j]
        for key in self.sorted:
            i = key % k_f
            has = code[i] & open_mask
            if not has:
                continue
            for s in self.need[j]:
                if has >> s & 1:
                    parts[s].append(i)
                    if len(parts[s]) == k:
                        open_mask &= ~(1 << s)
            if not open_mask:
                break
        return {s: np.asarray(part, dtype=np.int64) for s, part in parts.items()}

    def _fill(self, j: int, robots: list[int]) -> npt.NDArray[np.int64] | None:
        """The literal slot filling (``fill``) for ``robots`` ascending, decided here in
        its two simple cases: every robot has every service ``j`` needs (the slots in
        order), or each has exactly one (that one, when the counts match).

        Otherwise ``fill`` sees nothing of the robots but which of ``j``'s services each
        has (its 0/1 matrix of robots by slots), so its answer is remembered under ``j``'s
        services and counts and that sequence of capability bits: a pattern recurs far
        more often than a robot set, and tasks needing the same services share it."""
        mask = self.mask[j]
        have = [self.code[i] & mask for i in robots]
        if all(h == mask for h in have):
            return self.finder.slot_service[j].copy()
        if all(h and not h & (h - 1) for h in have):
            chosen = [h.bit_length() - 1 for h in have]
            counts = dict.fromkeys(self.need[j], 0)
            for s in chosen:
                counts[s] += 1
            if list(counts.values()) != self.finder.counts[j]:
                return None
            return np.asarray(chosen, dtype=np.int64)
        memo = (self.slots_of[j], *have)
        services = self.fills.get(memo, _MISSING)
        if services is _MISSING:
            services = self._match(j, robots, have)
            if len(self.fills) >= _FILLS:
                self.fills.clear()
            self.fills[memo] = services
        return None if services is None else services.copy()

    def _match(self, j: int, robots: list[int], have: list[int]) -> npt.NDArray[np.int64] | None:
        """``fill``'s matching for ``robots``, built from their capability bits ``have``
        (the same 0/1 matrix, without ``fill``'s indexing), or ``fill`` itself when the
        bits do not fit in int64.  O(k |S_j| + the matching)."""
        if not self.narrow:
            return self.fill(self.finder, j, np.asarray(robots, dtype=np.int64))
        slots = self.finder.slot_service[j]
        bits = np.asarray(have, dtype=np.int64)[:, None] >> slots
        return match_slots(bits & 1 == 1, slots)


class LastBundles:
    """Each task's latest bundle found, padded to one row per task, so that whether each
    of them still fits its task's budget on the current wages is one gather
    (:meth:`affordable`).

    Parameters
    ----------
    k : list of int
        Each task's bundle size.
    n : int
        The robots; index ``n`` pads the rows (a robot of wage 0).
    budget : list of int
        Each task's budget in units of eps (capped at 2^62 here: a cap only makes
        :meth:`affordable` say ``False`` more often).
    """

    def __init__(self, k: list[int], n: int, budget: list[int]) -> None:
        self.robots = np.full((len(k), max(k, default=1)), n, dtype=np.int64)
        self.has = np.zeros(len(k), dtype=bool)
        self.k = np.asarray(k, dtype=np.int64)
        self.budget = np.asarray([min(b, 2**62) for b in budget], dtype=np.int64)

    @staticmethod
    def fits(k: list[int]) -> bool:
        """Whether the rows for bundles of sizes ``k`` stay within 2^24 words."""
        return len(k) * max(k, default=1) <= _LAST_CELLS

    def keep(self, j: int, robots: npt.NDArray[np.int64]) -> None:
        """Remember ``robots`` (a complete bundle of task ``j``).  O(k_j)."""
        self.robots[j, : robots.size] = robots
        self.has[j] = True

    def affordable(
        self, tasks: npt.NDArray[np.int64], wage: npt.NDArray[np.int64]
    ) -> npt.NDArray[np.bool_]:
        """Per task of ``tasks``: whether its latest bundle, priced ``wage + 1`` a robot,
        is within its budget (``False`` when it has none).  ``wage`` must be small
        enough for the sums to stay in int64 (the ledger's keys ensure it).  O(n +
        |tasks| max k)."""
        padded = np.append(wage, 0)
        price = padded[self.robots[tasks]].sum(axis=1) + self.k[tasks]
        return self.has[tasks] & (price <= self.budget[tasks])


def _exact_limit(finder: Any) -> int:
    """The largest wage (units of eps) up to which :meth:`BundleFinder.cheapest`'s
    matching orders bundles exactly by (wages, flags, indices) for every task: its costs
    stay below 2^53 with the flag and index terms kept, for the largest bundle.  O(m)."""
    n = max(finder.n, 1)
    k = max([int(x) for x in finder.k] + [1])
    k_f = k * n
    return ((2**53 - 1) // k - k_f - n) // ((k + 1) * k_f)


def match_slots(
    fits: npt.NDArray[np.bool_], slots: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64] | None:
    """The service each robot performs when ``fits[r, c]`` says whether robot ``r`` can
    fill slot ``c`` (of service ``slots[c]``), or ``None`` when the robots cannot fill all
    the slots: scipy's deterministic ``linear_sum_assignment`` on the 0/1 cost matrix, so
    the same matrix always gives the same filling.  O(k^3)."""
    cost = np.where(fits, 0.0, 1.0)
    rows, cols = linear_sum_assignment(cost)
    if cost[rows, cols].any():
        return None
    out = np.empty(fits.shape[0], dtype=np.int64)
    out[rows] = slots[cols]
    return out


def _bits(x: int) -> Iterator[int]:
    """The positions of the set bits of ``x >= 0``, lowest first.  O(bits x x's words).

    >>> list(_bits(0b101001))
    [0, 3, 5]
    """
    while x:
        low = x & -x
        yield low.bit_length() - 1
        x ^= low


def _codes(caps: npt.NDArray[np.bool_]) -> list[int]:
    """Each robot's services as one Python integer (bit ``s`` set when it has ``s``).
    O(n S)."""
    n_services = caps.shape[1]
    if n_services <= 62:
        weights = np.int64(1) << np.arange(n_services, dtype=np.int64)
        return (caps.astype(np.int64) @ weights).tolist()
    return [sum(1 << int(s) for s in np.flatnonzero(row)) for row in caps]
