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

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
from sortedcontainers import SortedList

#: Slot fillings remembered (a bundle fought over recurs); the memo is emptied when full.
_FILLS = 1 << 16
_MISSING = object()
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
    Memory O(n + m S + the kept bundles).  A search walks the sorted keys from the
    cheapest until the bundle is complete: O(k_j) when most robots of the pool are
    cheap enough, O(n) at worst.
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
        caps = np.asarray(finder.caps, dtype=bool)
        self.code = _codes(caps)
        self.need = [need.tolist() for need in finder.need]
        self.mask = [sum(1 << s for s in need) for need in self.need]
        self.need_matrix = np.zeros((len(self.need), caps.shape[1]), dtype=np.int64)
        for j, need in enumerate(self.need):
            self.need_matrix[j, need] = 1
        self.caps64 = caps.astype(np.int64)
        self.theta = np.full(len(self.need), -1, dtype=np.int64)  # -1: nothing kept
        self.kept: dict[int, Found] = {}
        self.kept_robots: dict[int, list[int]] = {}
        self.holders: list[set[int]] = [set() for _ in range(finder.n)]
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
        if not self.fast or self.max_wage > self.limit:
            self.fast = False
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
            for j in list(holders[i]):
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
        for i in self.kept_robots.pop(j):
            self.holders[i].discard(j)
        del self.kept[j]
        self.theta[j] = -1

    def _keep(self, j: int, found: Found, robots: list[int], theta: int) -> None:
        self.kept[j] = found
        self.kept_robots[j] = robots
        self.theta[j] = theta
        for i in robots:
            self.holders[i].add(j)

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
        services = self.fill(finder, j, robots_arr)
        assert services is not None
        return robots_arr, services, int(b.weight) + k

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
        order), or each has exactly one (that one, when the counts match)."""
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
        memo = (j, *robots)
        services = self.fills.get(memo, _MISSING)
        if services is _MISSING:
            services = self.fill(self.finder, j, np.asarray(robots, dtype=np.int64))
            if len(self.fills) >= _FILLS:
                self.fills.clear()
            self.fills[memo] = services
        return None if services is None else services.copy()


def _codes(caps: npt.NDArray[np.bool_]) -> list[int]:
    """Each robot's services as one Python integer (bit ``s`` set when it has ``s``).
    O(n S)."""
    n_services = caps.shape[1]
    if n_services <= 62:
        weights = np.int64(1) << np.arange(n_services, dtype=np.int64)
        return (caps.astype(np.int64) @ weights).tolist()
    return [sum(1 << int(s) for s in np.flatnonzero(row)) for row in caps]
