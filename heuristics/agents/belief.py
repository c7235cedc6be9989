"""Beliefs: what a GRAPE-S robot knows and broadcasts, how it chooses, and the encoder.

A robot's *belief* is the seed's ``(r, time, Pi)``: ``r`` the number of partition updates
it has seen, ``time`` the (simulated) time stamp of the latest one, the id of the robot
that made it, and the partition ``Pi`` -- one slot ``j * S + s`` per robot, ``-1`` for the
void task.  The distributed mutex keeps, of the beliefs a robot holds and receives, the
one with the highest *key* ``(r, time, id)``.  Beliefs are immutable: a move makes a new
one.  Pair-GRAPE-S beliefs also carry the pairwise step's pass state (``cursor``,
``made``), see :mod:`heuristics.agents.grape_s`.

Messages (:func:`encode_belief`): little-endian int32 ``r``, int32 robot id, int64 time in
nanoseconds, then one int32 slot per robot -- ``16 + 4 n`` bytes -- and for Pair-GRAPE-S
two more int32 (``cursor``, ``made``): ``24 + 4 n`` bytes.  Every robot sends its whole
belief (the seed's protocol); identical beliefs are identical bytes.

:class:`Problem` holds what every robot knows from the start (the mission) and the exact
selection rule of the seed's reward ``R = exp(1 - c / req)``: a robot compares *loads*
``c / req`` (smaller is better).  Per belief and service the best slot to join is the
lowest ``((c + 1) / req, task)``; a robot's best move is the lowest ``(key, task,
service)`` over its services, taken only when strictly better than its current load.
Loads are compared as floats when that is exact -- two different fractions ``a / b`` and
``c / d`` with numerators at most ``n + 1`` and denominators at most ``max req`` differ by
more than two roundings when ``(n + 2) max req < 2**51`` -- and as exact fractions
otherwise (and for the utility-weighted reward of :mod:`heuristics.reward`).
"""

from __future__ import annotations

import itertools
import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission
from heuristics.reward import VOID, reward_model

__all__ = [
    "GONE",
    "Belief",
    "Changes",
    "Problem",
    "belief_history",
    "decode_belief",
    "encode_belief",
]

_HEADER = struct.Struct("<iiq")  # r, robot id, time (ns)
_PASS = struct.Struct("<ii")  # Pair-GRAPE-S: cursor, made
#: Floats compare loads exactly while (n + 2) * max requirement stays below this.
_EXACT_FLOATS = 2**51
_NO_SLOT = -1
#: The slot of a robot presumed failed (a run with mission events): not unassigned, gone.
GONE = -2
_TOKENS = itertools.count()

Trail = tuple[Any, ...] | None
#: The ``(robot, slot)`` changes of one update.
Changes = tuple[tuple[int, int], ...]


class Belief:
    """One immutable belief ``(r, time, robot, slots)`` (see the module docstring).

    ``trail`` records the moves that led here in this process, one node ``(r, ((robot,
    slot), ...), previous)`` per update (:meth:`moves`); it is never part of a message
    (a run's trajectory comes from the agents' own records: :func:`belief_history`).
    """

    __slots__ = (
        "_cache",
        "_counts",
        "_payload",
        "cursor",
        "made",
        "r",
        "robot",
        "slots",
        "time",
        "trail",
    )

    def __init__(
        self,
        r: int,
        time: int,
        robot: int,
        slots: npt.NDArray[np.int32],
        trail: Trail = None,
        cursor: int = -1,
        made: int = 0,
    ) -> None:
        self.r, self.time, self.robot = r, time, robot
        self.slots, self.trail = slots, trail
        self.cursor, self.made = cursor, made
        self._counts: npt.NDArray[np.int64] | None = None
        self._cache: dict[Any, Any] = {}
        self._payload: tuple[bool, bytes] | None = None

    @classmethod
    def initial(cls, n: int) -> Belief:
        """Every robot on the void task, ``r = 0`` (the seed's initialization)."""
        slots = np.full(n, _NO_SLOT, dtype=np.int32)
        slots.setflags(write=False)
        return cls(0, 0, -1, slots)

    @property
    def key(self) -> tuple[int, int, int]:
        """``(r, time, id)``: the distributed mutex keeps the highest."""
        return (self.r, self.time, self.robot)

    def updated(
        self,
        changes: tuple[tuple[int, int], ...],
        now: int,
        by: int,
        *,
        cursor: int | None = None,
        made: int | None = None,
    ) -> Belief:
        """A new belief: these ``(robot, slot)`` changes made by robot ``by`` at ``now``."""
        slots = self.slots.copy()
        for robot, slot in changes:
            slots[robot] = slot
        slots.setflags(write=False)
        return Belief(
            self.r + 1,
            now,
            by,
            slots,
            (self.r + 1, changes, self.trail),
            self.cursor if cursor is None else cursor,
            self.made if made is None else made,
        )

    def counts(self, problem: Problem) -> npt.NDArray[np.int64]:
        """Robots per slot, ``(m S,)``; computed once per belief."""
        if self._counts is None:
            placed = self.slots[self.slots >= 0]
            self._counts = np.bincount(placed, minlength=problem.n_slots).astype(np.int64)
        return self._counts

    def moves(self) -> list[tuple[int, int, int]]:
        """The updates that led here, oldest first: ``(iteration, robot, slot)``."""
        out: list[tuple[int, int, int]] = []
        node = self.trail
        while node is not None:
            r, changes, node = node
            out.extend((r, robot, slot) for robot, slot in reversed(changes))
        out.reverse()
        return out

    def __repr__(self) -> str:
        return f"<Belief r={self.r} time={self.time} id={self.robot}>"


def encode_belief(belief: Belief, *, pairwise: bool = False) -> bytes:
    """The message a robot broadcasts (see the module docstring for the layout); built
    once per belief.

    >>> b = Belief.initial(3).updated(((1, 4),), now=7_000_000, by=1)
    >>> len(encode_belief(b)), len(encode_belief(b, pairwise=True))
    (28, 36)
    >>> decode_belief(encode_belief(b), 3).key == b.key
    True
    """
    cached = belief._payload
    if cached is not None and cached[0] == pairwise:
        return cached[1]
    body = _HEADER.pack(belief.r, belief.robot, belief.time)
    body += belief.slots.astype("<i4", copy=False).tobytes()
    if pairwise:
        body += _PASS.pack(belief.cursor, belief.made)
    belief._payload = (pairwise, body)
    return body


def decode_belief(data: bytes, n: int, *, pairwise: bool = False) -> Belief:
    """The belief :func:`encode_belief` encoded (without its trail)."""
    r, robot, time = _HEADER.unpack_from(data, 0)
    slots = np.frombuffer(data, dtype="<i4", count=n, offset=_HEADER.size).astype(np.int32)
    slots.setflags(write=False)
    cursor, made = _PASS.unpack_from(data, _HEADER.size + 4 * n) if pairwise else (-1, 0)
    return Belief(r, time, robot, slots, None, cursor, made)


def belief_history(
    made: Mapping[tuple[int, int, int], tuple[Changes, tuple[int, int, int]]],
    key: tuple[int, int, int],
) -> list[tuple[int, Changes]]:
    """``(r, changes)`` of every update behind the belief of key ``key``, oldest first,
    from records ``new key -> (changes, key of the belief the update was made on)`` (the
    agents' :attr:`~heuristics.agents.GrapeSAgent.made`, of one process or many).

    >>> b = Belief.initial(3).updated(((1, 4),), 5, 1)
    >>> c = b.updated(((0, 2), (2, 4)), 9, 0)
    >>> made = {b.key: (((1, 4),), (0, 0, -1)), c.key: (((0, 2), (2, 4)), b.key)}
    >>> belief_history(made, c.key)
    [(1, ((1, 4),)), (2, ((0, 2), (2, 4)))]
    """
    out = []
    while key in made:
        changes, parent = made[key]
        out.append((key[0], changes))
        key = parent
    out.reverse()
    return out


class Problem:
    """The mission as every robot knows it, and the selection rule (module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    reward : {"paper", "utility"}
        The reward weighting of :mod:`heuristics.reward`.
    active : ndarray of bool, optional
        Which tasks are present (a run with mission events): an absent task's slots
        are nobody's to join.  Default: every task.

    Notes
    -----
    Per belief, the best joining slot of every service is computed once (numpy,
    O(slots)) and the best of every capability type once (O(S)); a robot's decision is
    then a comparison with its current load.  ``examined[i]`` is what the literal
    algorithm examines per selection of robot ``i`` (every slot of every service it has),
    the unit of ``work``.
    """

    def __init__(
        self, mission: Mission, reward: str = "paper", active: npt.ArrayLike | None = None
    ) -> None:
        caps, reqs = mission.capabilities, mission.requirements
        if active is not None:
            reqs = np.where(np.asarray(active, dtype=bool)[:, None], reqs, 0)
        self.caps = caps
        self.n, self.S = caps.shape
        self.m = reqs.shape[0]
        self.n_slots = self.m * self.S
        self.req = reqs.ravel().astype(np.int64)
        self.model = reward_model(mission, reward)
        self.reward = reward
        #: Tells this rule's cached results on a belief from another rule's.
        self.token = next(_TOKENS)
        #: Some task is absent (its requirements zero here).
        self.absent_tasks = bool((self.req.reshape(self.m, self.S).sum(axis=1) == 0).any())
        slots = np.flatnonzero(self.req)
        order = np.lexsort((slots // max(self.S, 1), slots % max(self.S, 1)))
        self.group_slots = slots[order]
        services = self.group_slots % max(self.S, 1)
        self.group_services, self.group_starts, self.group_sizes = np.unique(
            services, return_index=True, return_counts=True
        )
        kinds, rtype = np.unique(caps.reshape(self.n, self.S), axis=0, return_inverse=True)
        self.robot_type = rtype.reshape(-1).astype(np.int64)
        self.type_services = [np.flatnonzero(kind) for kind in kinds]
        per_service = np.bincount(services, minlength=self.S)
        self.examined = (caps.astype(np.int64) @ per_service).astype(np.int64)
        max_req = int(self.req.max(initial=1))
        self.fast = self.model.weights is None and (self.n + 2) * max_req < _EXACT_FLOATS

    # ------------------------------------------------------------------ selection
    def best_move(self, belief: Belief, robot: int, capped: bool) -> int | None:
        """The slot robot ``robot`` moves to on ``belief``, or ``None`` to stay."""
        key, slot = self.type_best(belief, int(self.robot_type[robot]), capped)
        if slot < 0:
            return None
        return slot if key < self.current_key(belief, robot) else None

    def current_key(self, belief: Belief, robot: int) -> Any:
        """The robot's current key (its load; ``inf``/VOID when unassigned)."""
        own = int(belief.slots[robot])
        if own < 0:
            return math.inf if self.fast else VOID
        c = int(belief.counts(self)[own])
        if self.fast:
            return c / int(self.req[own])
        return self.model.key(own // self.S, own % self.S, c)

    def type_best(self, belief: Belief, kind: int, capped: bool) -> tuple[Any, int]:
        """``(key, slot)`` of the best slot a robot of capability type ``kind`` can join."""
        cache_key = (capped, kind, self.token)
        found = belief._cache.get(cache_key)
        if found is None:
            keys, slots = self.service_bests(belief, capped)
            found = self._type_best(keys, slots, self.type_services[kind])
            belief._cache[cache_key] = found
        return found

    def _type_best(self, keys: Any, slots: npt.NDArray[np.int64], services: Any) -> tuple[Any, int]:
        if self.fast:
            ks = keys[services]
            if ks.size == 0:
                return math.inf, _NO_SLOT
            low = ks.min()
            if low == math.inf:
                return math.inf, _NO_SLOT
            return float(low), int(slots[services][ks == low].min())
        best: tuple[Any, int] = (VOID, _NO_SLOT)
        for s in services.tolist():
            if slots[s] >= 0 and (keys[s], int(slots[s])) < best:
                best = (keys[s], int(slots[s]))
        return best

    def service_bests(self, belief: Belief, capped: bool) -> tuple[Any, npt.NDArray[np.int64]]:
        """Per service the best joining key and slot (``-1``: none) on ``belief``."""
        cache_key = ("services", capped, self.token)
        found = belief._cache.get(cache_key)
        if found is None:
            found = (
                self._fast_bests(belief, capped) if self.fast else self._exact_bests(belief, capped)
            )
            belief._cache[cache_key] = found
        return found

    def _fast_bests(self, belief: Belief, capped: bool) -> tuple[Any, npt.NDArray[np.int64]]:
        keys_out = np.full(self.S, math.inf)
        slots_out = np.full(self.S, _NO_SLOT, dtype=np.int64)
        if self.group_slots.size == 0:
            return keys_out, slots_out
        c = belief.counts(self)[self.group_slots]
        req = self.req[self.group_slots]
        keys = (c + 1) / req
        if capped:
            keys = np.where(c >= req, math.inf, keys)
        mins = np.minimum.reduceat(keys, self.group_starts)
        hit = keys == np.repeat(mins, self.group_sizes)
        positions = np.where(hit, np.arange(keys.size), keys.size)
        first = np.minimum.reduceat(positions, self.group_starts)
        ok = mins < math.inf
        keys_out[self.group_services] = mins
        slots_out[self.group_services[ok]] = self.group_slots[first[ok]]
        return keys_out, slots_out

    def _exact_bests(self, belief: Belief, capped: bool) -> tuple[Any, npt.NDArray[np.int64]]:
        counts = belief.counts(self)
        keys: list[Any] = [VOID] * self.S
        slots = np.full(self.S, _NO_SLOT, dtype=np.int64)
        for slot in self.group_slots.tolist():
            j, s = divmod(slot, self.S)
            c = int(counts[slot])
            if capped and c >= self.req[slot]:
                continue
            key = self.model.key(j, s, c + 1)
            if key is VOID:
                continue
            if slots[s] < 0 or key < keys[s]:
                keys[s], slots[s] = key, slot
        return keys, slots

    # --------------------------------------------------------------- whole beliefs
    def stable(self, belief: Belief, capped: bool) -> bool:
        """Whether no robot has a strictly better move on ``belief`` (Nash stable)."""
        if self.fast:
            counts = belief.counts(self)
            own = belief.slots.astype(np.int64)
            placed = own >= 0
            current = np.full(self.n, math.inf)
            current[placed] = counts[own[placed]] / self.req[own[placed]]
            current[own == GONE] = -math.inf  # a failed robot has no move
            best = np.array(
                [self.type_best(belief, kind, capped)[0] for kind in range(len(self.type_services))]
            )
            return not bool((best[self.robot_type] < current).any()) if self.n else True
        return all(
            self.best_move(belief, i, capped) is None
            for i in range(self.n)
            if belief.slots[i] != GONE
        )
