"""SDA's engine: award round to award round, each task's first affordable round in O(1).

:func:`heuristics.sda.sda` runs :func:`core`; ``heuristics.sda._core_literal`` is the
previous engine, kept as the reference this one is tested equal to.  Both jump over the
rounds without an award and count them in closed form, and bid and award alike: all of it
is :class:`DescendingAuction`.  They differ only in how a task's first affordable round is
found (:meth:`DescendingAuction.first_round`).

Prefix ranks instead of a binary search
---------------------------------------
A task ``j`` needs ``r_js`` robots of each service ``s`` (``k_j`` in all).  The sets of
unsold robots that fit into distinct slots of ``j`` are the independent sets of a matroid
(a transversal matroid) and the complete bundles are its bases.  Under ``max-wage`` the
wages inside a sweep take two values: the robots at the first ``r`` positions of the unsold
robots (index order) have the low wage, the others the high one.  The cheapest complete
bundle then has ``k_j - rank(first r)`` high-wage robots (a minimum-weight basis of 0/1
weights takes as many low-weight elements as their rank), and ``rank(first r)`` is the
number of elements of the index-order greedy basis ``g_1 < g_2 < ...`` whose positions are
``< r``.  So the first ``r`` at which the cost ``k lo + (hi - lo) (k - rank)`` reaches
``u_j`` is one past the position of ``g_T``, ``T = k_j - floor((u_j - k_j lo) / (hi -
lo))``: a static ``T`` per task (the crossing sweep is static, see ``a_star``) and one
look-up, where the previous engine ran ``log2 q`` matchings.

The greedy basis changes only when one of its robots is sold (deleting non-basis elements
leaves an index-order greedy basis as it is), so it is cached per task and rebuilt lazily,
on the first look-up after such a sale.  It is built on the candidates of
:mod:`heuristics._auction` (the first ``k_j`` unsold robots of each needed service: the
greedy basis is the basis of least index sum, which uses candidates only) by scanning them
in index order and keeping each one that still fits (:func:`greedy_basis`).

The bundles that are actually bid and awarded are still chosen by
:meth:`heuristics._auction.BundleFinder.cheapest` on exactly the same inputs as before, so
every tie is broken as before.
"""

from __future__ import annotations

import heapq
import math
from abc import ABC, abstractmethod
from collections import defaultdict
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from cfopt import Mission
from heuristics._auction import ENTRY_BYTES, HEADER_BYTES, Bundle, BundleFinder
from heuristics._run import NO_DEADLINE, Deadline

__all__ = ["DescendingAuction", "Outcome", "Touched", "bid_messages", "core", "greedy_basis"]


@dataclass
class Outcome:
    """What one auction produced: the assignment and every count of :class:`heuristics.Run`."""

    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    iterations: int = 0
    rounds: int = 0
    messages: int = 0  # unicast: one per receiver
    bytes: int = 0
    cast_messages: int = 0  # broadcast: one per announcement, one per direct message
    cast_bytes: int = 0
    work: int = 0
    moves: list[tuple[int, int, int, int]] = field(default_factory=list)

    def direct(self, messages: int, nbytes: int) -> None:
        """Count direct messages (bids, answers): the same under both media."""
        self.messages += messages
        self.bytes += nbytes
        self.cast_messages += messages
        self.cast_bytes += nbytes

    def announce(
        self, receivers: npt.NDArray[np.int64], entries: npt.NDArray[np.int64], times: int = 1
    ) -> None:
        """Count ``times`` announcements of each service agent ``s`` with ``entries[s] > 0``
        robots to tell about: ``receivers[s]`` messages of ``entries[s]`` entries unicast,
        one transmission broadcast (none when it has no receiver)."""
        size = HEADER_BYTES + ENTRY_BYTES * entries
        has = entries > 0
        self.messages += times * int(receivers[has].sum())
        self.bytes += times * int((receivers * size)[has].sum())
        sent = has & (receivers > 0)
        self.cast_messages += times * int(sent.sum())
        self.cast_bytes += times * int(size[sent].sum())


def bid_messages(out: Outcome, finder: BundleFinder, j: int) -> None:
    """Count task ``j``'s bid: one message per needed service, ``r_js`` entries each."""
    counts = finder.counts[j]
    out.direct(len(counts), len(counts) * HEADER_BYTES + ENTRY_BYTES * sum(counts))


class Touched:
    """Per task, how many robots of a set have at least one service the task needs.

    ``touched(caps_rows)`` equals ``((caps_rows @ needmask.T) > 0).sum(axis=0)`` (the
    literal count), computed per capability type: the distinct rows of ``caps_rows`` with
    their multiplicities, each tested against every task at once.  With at most 62
    services a type and a task's needs are bit codes and "shares a service" is one AND,
    so a call costs O(k S + U m) time and O(U m) memory for ``U <= k`` types, instead of
    the O(k S m) product; otherwise the ``U x m`` product decides.
    """

    def __init__(self, needmask: npt.NDArray[np.bool_]) -> None:
        self.need = needmask  # m x S
        n_services = needmask.shape[1]
        self.bits = (
            (np.int64(1) << np.arange(n_services, dtype=np.int64)) if n_services <= 62 else None
        )
        self.codes = None if self.bits is None else needmask.astype(np.int64) @ self.bits

    def __call__(self, caps_rows: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
        """The count per task (int64, length m) for the robots ``caps_rows`` (k x S)."""
        if self.bits is None:
            kinds, counts = np.unique(caps_rows, axis=0, return_counts=True)
            shares = (kinds.astype(np.int64) @ self.need.T.astype(np.int64)) > 0
        else:
            kinds, counts = np.unique(caps_rows.astype(np.int64) @ self.bits, return_counts=True)
            shares = (kinds[:, None] & self.codes[None, :]) != 0  # U x m
        return counts.astype(np.int64) @ shares


# ------------------------------------------------------------------- greedy bases

_BITS: dict[int, tuple[int, ...]] = {}


def _bits(code: int) -> tuple[int, ...]:
    """The positions of the set bits of ``code`` (cached)."""
    out = _BITS.get(code)
    if out is None:
        out = tuple(i for i in range(code.bit_length()) if code >> i & 1)
        _BITS[code] = out
    return out


class _Slots:
    """Which robots (by type) fill each needed service, for :func:`greedy_basis`.

    A type is the bit code of the needed services a robot has.  ``load[s]`` robots sit on
    service ``s`` (at most ``cap[s]``), ``held[s][code]`` of them of type ``code``.
    """

    def __init__(self, cap: list[int]) -> None:
        self.cap = cap
        self.load = [0] * len(cap)
        self.held: list[defaultdict[int, int]] = [defaultdict(int) for _ in cap]

    def add(self, code: int) -> bool:
        """Seat one robot of type ``code``, moving others if needed; ``False``: no room."""
        for s in _bits(code):
            if self.load[s] < self.cap[s]:
                self.load[s] += 1
                self.held[s][code] += 1
                return True
        return self._augment(code)

    def _augment(self, code: int) -> bool:
        """Breadth-first search for a chain of moves ending on a service with room."""
        parent: dict[int, tuple[int, int] | None] = dict.fromkeys(_bits(code))
        queue = list(parent)
        for s in queue:  # the queue grows while it is read
            for other, count in self.held[s].items():
                if not count:
                    continue
                for t in _bits(other):
                    if t in parent:
                        continue
                    parent[t] = (s, other)
                    if self.load[t] < self.cap[t]:
                        self._shift(t, parent, code)
                        return True
                    queue.append(t)
        return False

    def _shift(self, t: int, parent: dict[int, tuple[int, int] | None], code: int) -> None:
        """Apply the chain found by :meth:`_augment`, which ends on ``t``."""
        self.load[t] += 1
        while (step := parent[t]) is not None:
            s, other = step
            self.held[s][other] -= 1
            self.held[t][other] += 1
            t = s
        self.held[t][code] += 1


def greedy_basis(robots: list[int], codes: list[int], cap: list[int], k: int) -> list[int]:
    """The index-order greedy basis: scan ``robots`` (ascending) and keep each that fits.

    Parameters
    ----------
    robots : list of int
        Candidate robots, ascending.
    codes : list of int
        Each candidate's type: bit ``l`` set when it has the task's ``l``-th needed service
        (never 0).
    cap : list of int
        ``r_js`` per needed service.
    k : int
        ``sum(cap)``: the scan stops once ``k`` robots are kept.

    Returns
    -------
    list of int
        The kept robots, ascending; fewer than ``k`` when no complete bundle exists.

    Notes
    -----
    A robot fits when the kept ones and it can fill distinct slots (an augmenting chain
    over the services, :class:`_Slots`).  A type that once did not fit never fits again
    (the set of services that blocked it stays full), so it is skipped in O(1): at most
    one search per type.  O(C + U B) for ``C`` candidates, ``U`` types and a search cost
    ``B = O(|S_j| * types per service)``.
    """
    slots = _Slots(cap)
    blocked: set[int] = set()
    kept: list[int] = []
    for robot, code in zip(robots, codes, strict=True):
        if code in blocked:
            continue
        if not slots.add(code):
            blocked.add(code)
            continue
        kept.append(robot)
        if len(kept) == k:
            break
    return kept


class _Bases:
    """Each task's greedy basis over the unsold robots, cached until one of it is sold."""

    def __init__(self, finder: BundleFinder, caps: npt.NDArray[np.bool_]) -> None:
        self.finder = finder
        self.caps = caps
        self.cache: dict[int, npt.NDArray[np.int64]] = {}
        n_services = caps.shape[1]
        # up to 62 services: a robot's type for task j is its capability code AND j's needs
        self.code_arr = (
            np.array(_codes(caps), dtype=np.int64).reshape(-1) if n_services <= 62 else None
        )
        self.n_services = n_services
        self._caps_by_service: dict[int, list[int]] = {}

    def _full_cap(self, j: int) -> list[int]:
        """``r_js`` for every service ``s`` (0 where ``j`` needs none), cached."""
        cap = self._caps_by_service.get(j)
        if cap is None:
            cap = [0] * self.n_services
            for s, r in zip(self.finder.need[j].tolist(), self.finder.counts[j], strict=True):
                cap[s] = r
            self._caps_by_service[j] = cap
        return cap

    def get(
        self, j: int, pools: list[npt.NDArray[np.int64]], unsold: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.int64] | None:
        """Task ``j``'s greedy basis (ascending robots), or ``None`` when it is short."""
        basis = self.cache.get(j)
        if basis is not None and unsold[basis].all():
            return basis
        basis = self._build(j, pools)
        if basis is None:
            self.cache.pop(j, None)
        else:
            self.cache[j] = basis
        return basis

    def _build(self, j: int, pools: list[npt.NDArray[np.int64]]) -> npt.NDArray[np.int64] | None:
        finder = self.finder
        k, need, cap = finder.k[j], finder.need[j], finder.counts[j]
        parts = []
        for s, r in zip(need.tolist(), cap, strict=True):
            if pools[s].size < r:
                return None
            parts.append(pools[s][:k])  # pools are ascending: the first k by index
        cands = np.unique(np.concatenate(parts))
        if cands.size < k:
            return None
        if self.code_arr is None:
            codes = _codes(self.caps[cands][:, need])
        else:  # global service positions: the requirement of every service, 0 if not needed
            mask = sum(1 << s for s in need.tolist())
            codes = (self.code_arr[cands] & mask).tolist()
            cap = self._full_cap(j)
        kept = greedy_basis(cands.tolist(), codes, cap, k)
        if len(kept) < k:
            return None
        return np.array(kept, dtype=np.int64)


def _codes(rows: npt.NDArray[np.bool_]) -> list[int]:
    """Each row of a boolean matrix as a bit code (bit ``l``: column ``l``)."""
    width = rows.shape[1]
    if width <= 62:
        return (rows.astype(np.int64) @ (np.int64(1) << np.arange(width, dtype=np.int64))).tolist()
    return [sum(1 << int(c) for c in np.flatnonzero(row)) for row in rows]


# -------------------------------------------------------------------------- engine


def core(
    mission: Mission, eps: Fraction, schedule: str, deadline: Deadline = NO_DEADLINE
) -> Outcome:
    """Run the auction; see :func:`heuristics.sda.sda` Notes and this module's docstring.

    ``deadline`` is checked before each award round: once reached, the auction stops
    with the sales made so far."""
    return _Auction(mission, eps, schedule).run(deadline)


class DescendingAuction(ABC):
    """The state of one auction between award rounds (the unsold robots, the clocks).

    Everything but the search for a task's first affordable round: the jump from award
    round to award round, the counts of the rounds jumped over, the bids and awards.  A
    subclass finds the first affordable round (:meth:`first_round`): :class:`_Auction` by
    prefix ranks, ``heuristics.sda._core_literal``'s engine by a binary search of
    matchings, the reference it is tested equal to.

    Parameters
    ----------
    mission : cfopt.Mission
    eps : Fraction
        The wage decrement (> 0).
    schedule : {"max-wage", "uniform"}
    """

    def __init__(self, mission: Mission, eps: Fraction, schedule: str) -> None:
        caps, reqs = mission.capabilities, mission.requirements
        self.caps = caps
        self.n, self.m = caps.shape[0], reqs.shape[0]
        self.out = Outcome(np.full(self.n, -1, dtype=np.int64), np.full(self.n, -1, np.int64))
        self.uniform = schedule == "uniform"
        if self.n == 0 or self.m == 0:
            return
        self.finder = finder = BundleFinder(caps, reqs)
        self.u = [Fraction(float(x)) for x in mission.utilities.tolist()]
        self.eps = eps
        self.w0 = max(self.u) + eps
        self.D = math.ceil(self.w0 / eps)  # decrements that bring a wage to 0
        self.k = finder.k
        self.a_star = self._crossing_sweeps()
        self.by_level = sorted(range(self.m), key=lambda j: (self.a_star[j], j))
        needmask = reqs > 0
        self.caps64 = caps.astype(np.int64)
        self.need64 = needmask.astype(np.int64)
        self.touched = Touched(needmask)
        self.rows = finder.reach.copy()  # unsold robots having one of the task's services
        n, k = self.n, self.k
        self.k_arr = np.array(k, dtype=np.int64 if n * sum(k) < 2**62 else object)
        self.staffed = np.zeros(self.m, dtype=bool)
        self.dead = ~finder.possible  # pruned: never staffable, never searched
        self.unsold = np.ones(n, dtype=bool)
        self.alive = np.arange(n, dtype=np.int64)  # unsold robots, ascending
        self.pos = np.arange(n, dtype=np.int64)  # position in ``alive``; -1 when sold
        self.pools = [r.copy() for r in finder.robots_with]
        self.A = self.need64.sum(axis=0)  # unstaffed tasks needing each service
        self.R = 0  # rounds completed
        self.total = 0  # max-wage: decrements among the unsold robots (sum of their d)
        self.wfull = np.zeros(n, dtype=np.int64)

    def wage(self, d: int) -> Fraction:
        """The wage after ``d`` decrements."""
        return max(Fraction(0), self.w0 - d * self.eps)

    def _crossing_sweeps(self) -> list[int]:
        """Per task, the first sweep level ``a`` at which ``k wage(a) <= u[j]`` (static)."""
        k, u, w0, eps, D = self.k, self.u, self.w0, self.eps, self.D
        return [min(D, max(0, math.ceil((k[j] * w0 - u[j]) / (k[j] * eps)))) for j in range(self.m)]

    # ---------------------------------------------------------------- the search
    def clock(self, t: int) -> int:
        """Decrement clock at round t (> R): decrements under max-wage, rounds otherwise."""
        if self.uniform:
            return min(t, self.D)
        return min(self.alive.size * self.D, self.total + (t - self.R))

    def weights_at(self, x: int) -> tuple[Fraction, Fraction, npt.NDArray[np.int64]]:
        """(high wage, low wage, 0/1 weight of the unsold robots = has the high wage) at x."""
        alive = self.alive
        if self.uniform:
            return self.wage(x), self.wage(x), np.zeros(alive.size, dtype=np.int64)
        # x = a q + r: the robots at positions < r have had a + 1 decrements, the others a
        a, r = divmod(x, alive.size)
        hi, lo = self.wage(a), self.wage(a + 1)
        if hi == lo:
            return hi, lo, np.zeros(alive.size, dtype=np.int64)
        return hi, lo, (self.pos[alive] >= r).astype(np.int64)

    @abstractmethod
    def first_round(self, j: int) -> int | None:
        """First round > R in which task j can afford a bundle (None: never)."""

    def lower_bound(self, j: int) -> int:
        """A round no earlier than task j's first affordable one."""
        if self.uniform:
            return max(self.R + 1, self.a_star[j])
        q = self.alive.size
        return self.R + max(1, (self.a_star[j] - 1) * q + 1 - self.total)

    def next_award(self) -> tuple[int | None, list[int]]:
        """The next round with a bid and its bidders (``None``: no task ever bids)."""
        best: int | None = None
        bidders: list[int] = []
        staffed, dead = self.staffed, self.dead
        for j in self.by_level:
            if staffed[j] or dead[j]:
                continue
            if best is not None and self.lower_bound(j) > best:
                break
            t = self.first_round(j)
            if t is None:
                dead[j] = True
            elif best is None or t < best:
                best, bidders = t, [j]
            elif t == best:
                bidders.append(j)
        return best, bidders

    # ------------------------------------------------------------ the counting
    def quiet(self, t_from: int, t_to: int) -> None:
        """Account rounds t_from..t_to (inclusive): decrement notices and literal work."""
        if t_to < t_from:
            return
        out = self.out
        nr = t_to - t_from + 1
        unst = ~self.staffed
        out.work += nr * int((self.rows[unst] * self.k_arr[unst]).sum())
        if self.uniform:
            self._quiet_uniform(t_from, t_to)
        else:
            self._quiet_max_wage(t_from, t_to)

    def _quiet_uniform(self, t_from: int, t_to: int) -> None:
        """Rounds t_from..t_to under ``uniform``: each round that decrements, every service
        agent tells each unstaffed task needing its service, one entry per unsold robot."""
        dec_rounds = max(0, min(t_to, self.D) - t_from + 1)
        sizes = np.array([p.size for p in self.pools], dtype=np.int64)
        self.out.announce(self.A, sizes, times=dec_rounds)

    def _quiet_max_wage(self, t_from: int, t_to: int) -> None:
        """Rounds t_from..t_to under ``max-wage``: the decrements x0 < x <= x1, each
        announced to the unstaffed tasks needing one of the robot's services."""
        out, q = self.out, self.alive.size
        x0 = min(q * self.D, self.total + (t_from - 1 - self.R))
        x1 = min(q * self.D, self.total + (t_to - self.R))
        if x1 <= x0:
            return
        mine = self.caps64[self.alive]
        pref = np.concatenate(([0], np.cumsum(mine @ self.A)))
        # broadcast: one notice per service agent of the robot with a task to tell
        pref_cast = np.concatenate(([0], np.cumsum(mine @ (self.A > 0).astype(np.int64))))

        def upto(x: int, prefix: npt.NDArray[np.int64]) -> int:
            full, rest = divmod(x, q)
            return full * int(prefix[q]) + int(prefix[rest])

        msgs = upto(x1, pref) - upto(x0, pref)
        out.messages += msgs
        out.bytes += msgs * (HEADER_BYTES + ENTRY_BYTES)
        casts = upto(x1, pref_cast) - upto(x0, pref_cast)
        out.cast_messages += casts
        out.cast_bytes += casts * (HEADER_BYTES + ENTRY_BYTES)

    # ---------------------------------------------------------------- the awards
    def award_round(self, best: int, bidders: list[int]) -> tuple[int, npt.NDArray[np.bool_]]:
        """Run the award round ``best``: bids, awards, re-bids, sale notices.

        Returns the decrement clock of the round and the robots it sold.
        """
        out, finder, u = self.out, self.finder, self.u
        x = self.clock(best)
        hi, lo, wt = self.weights_at(x)
        self.wfull[self.alive] = wt
        self.R = best
        out.iterations += 1
        sold_round = np.zeros(self.n, dtype=bool)
        bids = _Bids(out, finder, u)
        for j in sorted(bidders):
            b = finder.cheapest(j, self.pools, self.wfull)
            assert b is not None
            bids.make(j, b, self._cost(j, b, hi, lo))
        while (bid := bids.answer()) is not None:
            j, b = bid
            if sold_round[b.robots].any():  # rejected: recompute on what is left
                out.work += int(self.rows[j]) * self.k[j]
                nb = finder.cheapest(j, self.pools, self.wfull)
                if nb is None:
                    self.dead[j] = True
                    continue
                cost = self._cost(j, nb, hi, lo)
                if cost <= u[j]:
                    bids.make(j, nb, cost)
                continue
            self.sell(j, b, sold_round)
        self.sale_notices(sold_round)
        return x, sold_round

    def _cost(self, j: int, b: Bundle, hi: Fraction, lo: Fraction) -> Fraction:
        """The price of task ``j``'s bundle ``b`` (``b.weight`` robots at the high wage)."""
        return self.k[j] * lo + (hi - lo) * b.weight

    def sell(self, j: int, b: Bundle, sold_round: npt.NDArray[np.bool_]) -> None:
        """Award task ``j`` its bundle ``b``."""
        out, caps = self.out, self.caps
        self.staffed[j] = True
        sold_round[b.robots] = True
        out.task[b.robots] = j
        out.service[b.robots] = b.services
        it = out.iterations
        for r, s in sorted(zip(b.robots.tolist(), b.services.tolist(), strict=True)):
            out.moves.append((it, r, j, s))
        self.A -= self.need64[j]
        self.rows -= self.touched(caps[b.robots])
        for s in np.flatnonzero(caps[b.robots].any(axis=0)).tolist():
            self.pools[s] = self.pools[s][~sold_round[self.pools[s]]]

    def sale_notices(self, sold_round: npt.NDArray[np.bool_]) -> None:
        """After an award round, each service agent that sold tells the unstaffed tasks."""
        self.out.announce(self.A, self.caps64[sold_round].sum(axis=0))

    def settle(self, x: int, sold_round: npt.NDArray[np.bool_]) -> bool:
        """Remove the sold robots; ``True`` when every unsold wage is now 0."""
        self.unsold &= ~sold_round
        alive = self.alive
        if not self.uniform:  # decrements of the robots left: a + (1 if position < r)
            a, r = divmod(x, alive.size)
            left = alive[~sold_round[alive]]
            self.total = a * left.size + int((self.pos[left] < r).sum())
        self.alive = np.flatnonzero(self.unsold).astype(np.int64)
        self.pos[:] = -1
        self.pos[self.alive] = np.arange(self.alive.size)
        if self.uniform:
            return x >= self.D
        return bool(self.alive.size) and self.total >= self.alive.size * self.D

    def run(self, deadline: Deadline = NO_DEADLINE) -> Outcome:
        """The auction to its stopping round, or to ``deadline``."""
        out = self.out
        if self.n == 0 or self.m == 0:
            return out
        while self.alive.size and not self.staffed.all() and not deadline.reached():
            best, bidders = self.next_award()
            if best is None:  # nobody will ever bid: the wages run down to 0
                R = self.R
                end = R + (self.D - R if self.uniform else self.alive.size * self.D - self.total)
                self.quiet(R + 1, end)
                self.R = max(R, end)
                break
            self.quiet(self.R + 1, best)
            x, sold_round = self.award_round(best, bidders)
            if self.settle(x, sold_round):
                break
        out.rounds = self.R
        return out


class _Bids:
    """The open bids of one award round, the largest current surplus first.

    A lazy priority queue: a task has at most one open bid; :meth:`answer` takes the next
    one and counts its answers, and a re-bid re-enters with its new surplus.
    """

    def __init__(self, out: Outcome, finder: BundleFinder, u: list[Fraction]) -> None:
        self.out, self.finder, self.u = out, finder, u
        self.heap: list[tuple[Fraction, int]] = []  # (cost - u[j], j): ties to the lowest j
        self.bundles: dict[int, Bundle] = {}

    def make(self, j: int, b: Bundle, cost: Fraction) -> None:
        """Task ``j`` bids ``cost`` for its bundle ``b``: one message per needed service."""
        self.bundles[j] = b
        heapq.heappush(self.heap, (cost - self.u[j], j))
        bid_messages(self.out, self.finder, j)

    def answer(self) -> tuple[int, Bundle] | None:
        """The next bid ``(task, bundle)``, its answers counted; ``None`` when none is open."""
        if not self.heap:
            return None
        _, j = heapq.heappop(self.heap)
        n_msg = len(self.finder.need[j])
        self.out.direct(n_msg, n_msg * HEADER_BYTES)  # the answers
        return j, self.bundles[j]


class _Auction(DescendingAuction):
    """The prefix-rank engine: a task's first affordable round read off its greedy basis.

    See this module's docstring; :meth:`first_round` is O(1) but for the lazy rebuild of a
    basis after one of its robots is sold.
    """

    def __init__(self, mission: Mission, eps: Fraction, schedule: str) -> None:
        super().__init__(mission, eps, schedule)
        if self.n == 0 or self.m == 0:
            return
        self.need_low = self._need_low()
        self.bases = _Bases(self.finder, self.caps)

    def _need_low(self) -> list[int]:
        """Per task, the rank ``T`` its greedy basis needs at the low wage to be affordable.

        ``a_star[j]``: the first sweep level ``a`` at which ``k wage(a) <= u[j]``.  Under
        ``max-wage`` the task first affords a bundle inside sweep ``a_star - 1``, when its
        cheapest bundle has at most ``floor((u - k lo) / (hi - lo))`` high-wage robots, i.e.
        when at least ``T = k - that`` of its basis robots have the low wage (0 when
        ``a_star`` is 0 or the task needs no robot).
        """
        k, u = self.k, self.u
        need_low = [0] * self.m
        for j, a in enumerate(self.a_star):
            if a == 0 or k[j] == 0:
                continue
            hi, lo = self.wage(a - 1), self.wage(a)
            high = math.floor((u[j] - k[j] * lo) / (hi - lo))
            need_low[j] = k[j] - high
            assert 1 <= need_low[j] <= k[j]
        return need_low

    def first_round(self, j: int) -> int | None:
        """First round > R in which task j can afford a bundle (None: never)."""
        basis = self.bases.get(j, self.pools, self.unsold)
        if basis is None:
            return None
        a = self.a_star[j]
        if self.uniform:
            return max(self.R + 1, a)
        if a == 0:
            return self.R + 1
        q = self.alive.size
        x = (a - 1) * q + int(self.pos[basis[self.need_low[j] - 1]]) + 1
        return self.R + max(1, x - self.total)
