"""GRAPE-S rounds in O(S B) per round: robots grouped by the exact key of their slot.

The private fast path of :func:`heuristics.grape_s._core`; ``_core_literal`` there is the
O(n)-per-round engine it must agree with move for move, and :mod:`heuristics._reference`
the literal transcription of the seed's Algorithm 1.

Method.  A robot wants to move exactly when one of its services ``s`` has a best slot
whose joining key ``best(s)`` beats the key of the robot's own slot: ``best(s) <
key(slot)``.  The robot's type enters only through "has service ``s``" and its slot only
through the slot's *key*, so robots are grouped into *buckets*, one per distinct exact key
(``c / req`` reduced, with the task's weight class for ``reward="utility"``; the void task
is bucket 0).  Per service ``s`` and bucket ``b`` the engine keeps ``top[s, b]``, the
highest robot index among the robots that have service ``s`` and sit in a slot of key
``b``.  A round compares the ``S`` service bests with the ``B`` bucket keys (an ``S x B``
array, exact) and the mover, in index order, is the largest ``top[s, b]`` over the wanting
pairs: every wanting robot is bounded by the ``top`` of a wanting pair, which is itself a
wanting robot.  Its target is the best of its own services by ``(key, task, service)``,
exactly as in ``_core_literal``.

``top`` is maintained with lazy max-heaps at two levels: per (slot, service) the robots
of the slot that have the service, and per (service, bucket) the slots of that key with
their (slot, service) maximum.  A move changes two slots' members and keys, so it pushes
O(S) entries and refreshes O(S) heaps: O(S log n) Python work per move, independent of how
many robots share the slots.  A round costs O(S B + S log S) with ``B`` the number of
distinct keys seen (a few dozen for the paper reward; up to the number of occupied slots
for the utility reward, whose weights differ by task).

Random order.  The mover of a round is the wanting robot latest in a uniformly random
order of the robots; only the end of that order up to its first wanting robot matters, so
the engine draws the order lazily from its end: uniform robot indices, independent, in
doubling blocks (64, 128, ...), whose first appearances are a uniformly random order (the
lazy counterpart of ``rng.permutation(n)`` read from its end), stopping at the block that
holds a wanting robot.  The mover is the first wanting robot drawn: uniform over the
wanting robots, as the last wanting robot of a uniform permutation is.  A robot's wish is
read from the ``S x B`` table (its services x its slot's bucket).  With ``w`` wanting
robots a round draws about ``n / w`` indices instead of a whole permutation; a round
without a wanting robot (found from the bucket tops, as in index order) draws nothing.
``eager=True`` draws ``rng.permutation(n)`` every round, as the literal engine does, and
scans it from its end in doubling blocks: the same moves and draws as that engine (the
cross-check of the bucket bookkeeping in random order).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt._limits import require_memory
from heuristics._run import NO_DEADLINE, Deadline
from heuristics.reward import VOID, RewardModel, UtilityKey

#: Float filter width for utility-weighted rewards of different tasks.
BAND = 1e-9
#: Below this, (c + 1) / req as a float is an exact key for the paper reward.
EXACT_FLOAT_LIMIT = 2**26
#: First block of the permutation scanned from its end (random order).
_FIRST_BLOCK = 64


@dataclass
class Outcome:
    """What a GRAPE-S core returns: final slots, counters and the applied moves."""

    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    iterations: int = 0
    rounds: int = 0
    work: int = 0
    moves: list[tuple[int, int, int, int]] = field(default_factory=list)
    #: Whether the rounds were cut at the engine's time limit.
    cut: bool = False


class _BestSlots:
    """Per service the best slot to join, by lazy heaps of ``(hint, key, task, count)``.

    The same heaps, entries and tie-breaks as ``heuristics.grape_s._core_literal``.
    """

    def __init__(
        self, reqs: npt.NDArray[np.int64], model: RewardModel, capped: bool, n: int
    ) -> None:
        self.S = reqs.shape[1]
        self.req = reqs.ravel().tolist()
        self.cnt = [0] * (reqs.size + 1)
        self.capped = capped
        self.key = model.key
        self.paper = model.weights is None
        self.small = self.paper and max(n + 1, max(self.req, default=1)) < EXACT_FLOAT_LIMIT
        self.best_key: list[Any] = [None] * self.S
        self.best_task = [-1] * self.S
        self.best_num = np.ones(self.S, dtype=np.int64)
        self.best_den = np.zeros(self.S, dtype=np.int64)
        self.heaps: list[list[tuple[Any, ...]]] = []
        for s in range(self.S):
            heap = [self._entry(j, s, 0) for j in np.flatnonzero(reqs[:, s]).tolist()]
            heap = [e for e in heap if e[1] is not VOID]
            heapq.heapify(heap)
            self.heaps.append(heap)
        for s in range(self.S):
            self.refresh(s)

    def _entry(self, j: int, s: int, c: int) -> tuple[Any, ...]:
        hint = (c + 1) / self.req[j * self.S + s]
        if self.small:
            return (hint, 0, j, c)
        return (hint if self.paper else 0.0, self.key(j, s, c + 1), j, c)

    def refresh(self, s: int) -> None:
        """Drop stale entries of service ``s`` and record its best slot."""
        heap, cnt, S = self.heaps[s], self.cnt, self.S
        while heap and cnt[heap[0][2] * S + s] != heap[0][3]:
            heapq.heappop(heap)
        if heap:
            h, k, j, c = heap[0]
            self.best_key[s], self.best_task[s] = (h, k), j
            self.best_num[s], self.best_den[s] = c + 1, self.req[j * S + s]
        else:
            self.best_key[s], self.best_task[s] = None, -1
            self.best_num[s], self.best_den[s] = 1, 0

    def push(self, j: int, s: int) -> None:
        """Offer slot ``(j, s)`` at its current count (unless full when capped)."""
        c = self.cnt[j * self.S + s]
        if self.capped and c >= self.req[j * self.S + s]:
            return
        e = self._entry(j, s, c)
        if e[1] is not VOID:
            heapq.heappush(self.heaps[s], e)

    def target(self, services: list[int]) -> int:
        """The best service among ``services`` by ``(key, task, service)``, or -1."""
        live = [s for s in services if self.best_task[s] >= 0]
        if not live:
            return -1
        return min(live, key=lambda s: (*self.best_key[s], self.best_task[s], s))


class _Buckets:
    """Distinct exact slot keys and, per (service, bucket), the highest robot index."""

    def __init__(self, model: RewardModel, S: int) -> None:
        self.S = S
        self.index: dict[tuple[int, int, int], int] = {}
        self.num = [1]  # bucket 0: the void task, key 1/0
        self.den = [0]
        self.cls = [-1]
        self.exact: list[Any] = [VOID]
        self.weights = model.weights
        if model.weights is not None:
            distinct = sorted(set(model.weights))
            rank = {w: k for k, w in enumerate(distinct)}
            self.weight_class = [rank[w] for w in model.weights]
            self.class_weight = distinct
        self.top = np.full((S, 64), -1, dtype=np.int64)
        self.heaps: dict[int, list[tuple[int, int]]] = {}
        self.arrays: tuple[npt.NDArray[Any], ...] = ()

    @property
    def size(self) -> int:
        return len(self.num)

    def of(self, j: int, c: int, req: int) -> int:
        """The bucket of a slot of task ``j`` with ``c`` robots and requirement ``req``."""
        g = math.gcd(c, req)
        cls = 0 if self.weights is None else self.weight_class[j]
        code = (cls, c // g, req // g)
        b = self.index.get(code)
        if b is None:
            b = self._add(code)
        return b

    def _add(self, code: tuple[int, int, int]) -> int:
        cls, num, den = code
        b = len(self.num)
        self.index[code] = b
        self.num.append(num)
        self.den.append(den)
        self.cls.append(cls)
        if self.weights is not None:
            w = self.class_weight[cls]
            self.exact.append(VOID if w == 0 else UtilityKey(w, Fraction(num, den)))
        if b >= self.top.shape[1]:
            grown = np.full((self.S, 2 * self.top.shape[1]), -1, dtype=np.int64)
            grown[:, : self.top.shape[1]] = self.top
            self.top = grown
        self.arrays = ()
        return b

    def columns(self) -> tuple[npt.NDArray[Any], ...]:
        """``num``, ``den``, ``cls`` as arrays (rebuilt only when a bucket was added)."""
        if not self.arrays:
            self.arrays = (
                np.array(self.num, dtype=np.int64),
                np.array(self.den, dtype=np.int64),
                np.array(self.cls, dtype=np.int64),
            )
        return self.arrays


def core_fast(
    caps: npt.NDArray[np.bool_],
    reqs: npt.NDArray[np.int64],
    model: RewardModel,
    order: str,
    capped: bool,
    rng: np.random.Generator,
    deadline: Deadline = NO_DEADLINE,
    eager: bool = False,
) -> Outcome:
    """The GRAPE-S rounds with robots grouped by slot key; see the module notes.

    ``deadline`` is checked before each round: once reached, the rounds stop and the
    outcome is marked ``cut``.  ``eager`` (random order only): draw a whole permutation
    every round, as the literal engine does, instead of the lazy order."""
    n, S = caps.shape
    m = reqs.shape[0]
    tasks_per_service = (reqs > 0).sum(axis=0).astype(np.int64)
    per_round_work = int(caps.astype(np.int64).sum(axis=0) @ tasks_per_service)
    out = Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    if n == 0:
        out.rounds = 1
        return out
    state = _State(caps, reqs, model, capped, m * S)
    while True:
        if deadline.reached():
            out.cut = True
            break
        out.rounds += 1
        if order == "random" and eager:
            mover = state.last_wanting_in(rng.permutation(n))
        elif order == "random":
            mover = state.first_wanting_drawn(rng)
        else:
            mover = state.last_wanting()
        if mover < 0:
            break
        out.iterations += 1
        j1, s1 = state.move(mover)
        out.task[mover], out.service[mover] = j1, s1
        out.moves.append((out.iterations, mover, j1, s1))
    out.work = out.rounds * per_round_work
    return out


#: Bytes per entry of the member table (a Python list: one pointer each).
_TABLE_ENTRY_BYTES = 8


def _check_member_table(m: int, S: int) -> None:
    """Refuse, with the memory it would need, a mission whose (slot, service) member
    table -- ``(m S + 1) S`` entries, one per slot and service -- cannot fit."""
    entries = (m * S + 1) * S
    what = (
        f"{m} tasks x {S} services: GRAPE-S's table of the robots per (slot, service), "
        f"(m S + 1) S = {entries:.3g} entries,"
    )
    require_memory(entries * _TABLE_ENTRY_BYTES, f"mission: {what}")


class _State:
    """The partition, the best slots and the bucket tops of one GRAPE-S run."""

    def __init__(
        self,
        caps: npt.NDArray[np.bool_],
        reqs: npt.NDArray[np.int64],
        model: RewardModel,
        capped: bool,
        void: int,
    ) -> None:
        n, S = caps.shape
        _check_member_table(reqs.shape[0], S)
        self.S, self.void, self.model = S, void, model
        self.best = _BestSlots(reqs, model, capped, n)
        self.buckets = _Buckets(model, S)
        kinds, rtype = np.unique(caps, axis=0, return_inverse=True)
        self.caps = caps
        self.rtype = rtype.reshape(-1)
        self.type_services = [np.flatnonzero(k).tolist() for k in kinds]
        self.rtype_list = self.rtype.tolist()
        self.robot_slot = [void] * n
        self.slot_bucket = [0] * (void + 1)
        self.slot_bucket_arr = np.zeros(void + 1, dtype=np.int64)
        self.robot_slot_arr = np.full(n, void, dtype=np.int64)
        if model.weights is not None:
            scores = model.scores()
            assert scores is not None
            self.log_weight = scores
            self.weight_class = np.array(self.buckets.weight_class, dtype=np.int64)
            self.class_logw = np.full(len(self.buckets.class_weight), -np.inf)
            self.class_logw[self.weight_class] = scores
        # per (slot, service): lazy max-heap of member robots (negated) and its top
        self.members: dict[int, list[int]] = {}
        self.mtop = [-1] * ((void + 1) * S)
        for s in range(S):
            robots = np.flatnonzero(caps[:, s])
            if robots.size:
                self.members[void * S + s] = (-robots[::-1]).tolist()  # already a heap
                self.mtop[void * S + s] = int(robots[-1])
                self._offer(void, s)
                self._settle(s, 0)

    # ------------------------------------------------------------------ heaps
    def _offer(self, x: int, s: int) -> None:
        """Enter slot ``x``'s top robot of service ``s`` in its bucket's heap."""
        v = self.mtop[x * self.S + s]
        if v >= 0:
            b = self.slot_bucket[x]
            heapq.heappush(self.buckets.heaps.setdefault(b * self.S + s, []), (-v, x))

    def _settle(self, s: int, b: int) -> None:
        """Drop stale entries of heap (``s``, ``b``) and record its top."""
        heap = self.buckets.heaps.get(b * self.S + s)
        slot_bucket, mtop, S = self.slot_bucket, self.mtop, self.S
        while heap and (slot_bucket[heap[0][1]] != b or mtop[heap[0][1] * S + s] != -heap[0][0]):
            heapq.heappop(heap)
        self.buckets.top[s, b] = -heap[0][0] if heap else -1

    def _leave(self, x: int, s: int) -> None:
        """Recompute the top member of (slot ``x``, service ``s``) after a departure."""
        heap = self.members.get(x * self.S + s)
        robot_slot = self.robot_slot
        while heap and robot_slot[-heap[0]] != x:
            heapq.heappop(heap)
        self.mtop[x * self.S + s] = -heap[0] if heap else -1

    def _join(self, x: int, s: int, i: int) -> None:
        k = x * self.S + s
        heapq.heappush(self.members.setdefault(k, []), -i)
        if i > self.mtop[k]:
            self.mtop[k] = i

    # ------------------------------------------------------------------ rounds
    def wanting(self) -> npt.NDArray[np.bool_]:
        """``want[s, b]``: service ``s``'s best slot beats key ``b`` (exact), S x B."""
        num, den, cls = self.buckets.columns()
        best = self.best
        want = best.best_num[:, None] * den[None, :] < num[None, :] * best.best_den[:, None]
        if self.model.weights is not None:
            want = self._wanting_general(want, num, den, cls)
        return want

    def _wanting_general(
        self,
        want: npt.NDArray[np.bool_],
        num: npt.NDArray[np.int64],
        den: npt.NDArray[np.int64],
        cls: npt.NDArray[np.int64],
    ) -> npt.NDArray[np.bool_]:
        """Utility reward: exact within a weight class, float-filtered across classes."""
        best = self.best
        task = np.array(best.best_task, dtype=np.int64)
        ok = task >= 0
        safe = np.maximum(task, 0)
        a_class = np.where(ok, self.weight_class[safe], -2)
        with np.errstate(invalid="ignore", divide="ignore"):
            a_score = np.where(ok, self.log_weight[safe] - best.best_num / best.best_den, -np.inf)
            b_logw = np.where(cls >= 0, self.class_logw[np.maximum(cls, 0)], -np.inf)
            b_score = np.where(den > 0, b_logw - num / np.maximum(den, 1), -np.inf)
            same = a_class[:, None] == cls[None, :]
            by_float = a_score[:, None] > b_score[None, :] + BAND
            undecided = ~same & (np.abs(a_score[:, None] - b_score[None, :]) <= BAND)
        result = np.where(same, want, by_float)
        result[:, 0] = ok  # the void task: any best slot beats it
        undecided[:, 0] = False
        undecided &= self.buckets.top[:, : num.size] >= 0
        for s, b in np.argwhere(undecided).tolist():
            join = self.model.key(best.best_task[s], s, int(best.best_num[s]))
            result[s, b] = join < self.buckets.exact[b]
        return result

    def last_wanting(self, want: npt.NDArray[np.bool_] | None = None) -> int:
        """The highest-index robot that wants to move, or -1 (index order).

        ``want``: the :meth:`wanting` table, if already computed this round."""
        if want is None:
            want = self.wanting()
        if not want.size:
            return -1
        top = self.buckets.top[:, : want.shape[1]]
        return int(np.where(want, top, -1).max())

    def _hits(self, want_t: npt.NDArray[np.bool_], robots: npt.NDArray[np.int64]) -> Any:
        """Whether each of ``robots`` wants to move, given the B x S ``want_t`` table."""
        bucket = self.slot_bucket_arr[self.robot_slot_arr[robots]]
        return (want_t[bucket] & self.caps[robots]).any(axis=1)

    def last_wanting_in(self, perm: npt.NDArray[np.int64]) -> int:
        """The wanting robot latest in ``perm``, or -1 (random order, eager)."""
        want_t = self.wanting().T  # B x S
        end, block = perm.size, _FIRST_BLOCK
        while end > 0:
            start = max(0, end - block)
            robots = perm[start:end][::-1]
            hit = self._hits(want_t, robots)
            if hit.any():
                return int(robots[int(hit.argmax())])
            end, block = start, 2 * block
        return -1

    def first_wanting_drawn(self, rng: np.random.Generator) -> int:
        """The first wanting robot among uniform draws, or -1 (random order, lazy).

        Draws nothing when no robot wants to move; otherwise independent uniform robot
        indices in doubling blocks (at most ``n`` a block) until a block holds a wanting
        robot, and returns the first: a uniform choice among the wanting robots."""
        want = self.wanting()
        if self.last_wanting(want) < 0:
            return -1
        want_t, n = want.T, self.robot_slot_arr.size
        block = min(_FIRST_BLOCK, n)
        while True:
            robots = rng.integers(0, n, size=block)
            hit = self._hits(want_t, robots)
            if hit.any():
                return int(robots[int(hit.argmax())])
            block = min(2 * block, n)

    def move(self, i: int) -> tuple[int, int]:
        """Apply robot ``i``'s best move; returns its new (task, service)."""
        S, best = self.S, self.best
        services = self.type_services[self.rtype_list[i]]
        s1 = best.target(services)
        j1 = best.best_task[s1]
        x0, x1 = self.robot_slot[i], j1 * S + s1
        self.robot_slot[i] = x1
        self.robot_slot_arr[i] = x1
        for s in services:
            self._join(x1, s, i)
            self._leave(x0, s)
        best.cnt[x1] += 1
        best.push(j1, s1)
        touched = [(x0, self.slot_bucket[x0]), (x1, self.slot_bucket[x1])]
        if x0 != self.void:
            best.cnt[x0] -= 1
            j0, s0 = divmod(x0, S)
            best.push(j0, s0)
            if s0 != s1:
                best.refresh(s0)
        best.refresh(s1)
        self._rebucket(touched, services)
        return j1, s1

    def _rebucket(self, touched: list[tuple[int, int]], services: list[int]) -> None:
        """Re-key the two touched slots and settle every heap they were or are in.

        A real slot changes key with its count, so its (slot, service) tops are offered
        under the new key; the void task keeps its key and only the mover's services'
        tops changed.  Only the (service, bucket) heaps holding an entry of a touched slot
        for a service it has (or had: the mover's) are settled.
        """
        S, best, mtop = self.S, self.best, self.mtop
        stale = set()
        for x, b_old in touched:
            if x == self.void:
                changed, b_new = services, b_old
            else:
                changed = [s for s in range(S) if mtop[x * S + s] >= 0 or s in services]
                b_new = self.buckets.of(x // S, best.cnt[x], best.req[x])
                self.slot_bucket[x] = b_new
                self.slot_bucket_arr[x] = b_new
            for s in changed:
                self._offer(x, s)
                stale.add((s, b_old))
                stale.add((s, b_new))
        for s, b in stale:
            self._settle(s, b)
