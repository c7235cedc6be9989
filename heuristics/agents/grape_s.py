"""GRAPE-S and Pair-GRAPE-S as agents: one robot each, on its own belief.

**GRAPE-S** (the seed's Algorithm 1, as a clock-driven agent).  At every tick of its
clock a robot

1. runs the distributed mutex over its own belief and the beliefs received since its last
   tick, keeping the highest ``(r, time, id)``;
2. selects on its own partition (:meth:`heuristics.agents.Problem.best_move`; capped in
   Pair-GRAPE-S's first phase): if a slot is strictly better, it moves there in its belief,
   ``r += 1``, ``time = now``, ``id = itself``;
3. broadcasts its belief to its neighbours.

It stops -- no more selection, no more broadcasts; it performs the slot its belief gives
it -- when its belief has not changed for ``quiet_limit`` consecutive ticks (``K * d_G``,
``K = 2`` by default: a change anywhere reaches every robot within ``d_G`` hops, each hop
taking at most about a tick when latencies are below the clock period).

**Pair-GRAPE-S** (the seed's Algorithm 2).  Phase 1 is capped GRAPE-S.  When a robot's
own termination rule fires in phase 1 it enters phase 2, the pairwise step, and keeps
ticking (mutex, broadcast) without GRAPE-S moves.  The step's state travels in the belief:
``cursor`` (the last robot that exchanged in the current pass, -1 at a pass's start) and
``made`` (exchanges in the pass).  On a belief where some slot is short and some robot is
unassigned, the *actor* is the first unassigned robot after ``cursor`` in index order that
has a *partner* -- the first assigned robot (index order) whose slot it can perform and
that can itself perform some short slot other than its own; if there is none and the pass
made exchanges, a new pass starts from the first unassigned robot; otherwise the step is
over.  Every robot evaluates this on its own belief; the actor alone acts:

- it sends a *request* ``(o, a, slot of a)`` to its partner ``a`` (routed hop by hop);
- ``a``, at its next tick, checks the request on its own belief (``a`` still in that slot,
  ``o`` unassigned, a short slot ``a`` can take).  If it holds, ``a`` makes the exchange in
  its belief -- ``o`` takes ``a``'s slot, ``a`` moves to its best short slot (lowest
  ``(key, task, service)``) -- with ``r += 1``, ``cursor = o`` and ``made`` counted in the
  pass, broadcasts it, and answers *accept*; otherwise it answers *refuse*;
- the actor waits for the answer (and, after an accept, for the new belief), at most
  ``4 + 2 hops`` ticks, then evaluates again.

Concurrent exchanges (stale beliefs) are resolved by the mutex like any other update.  A
robot in phase 2 stops when its belief has not changed for ``quiet_limit`` ticks and the
step has nothing left to do on it.  With lock-step clocks, no latency or loss and a complete
topology both agents make exactly the moves of :func:`heuristics.grape_s` and
:func:`heuristics.pair_grape_s` with ``order="index"``: every robot holds the same belief
at every tick, the proposals of a tick carry the same ``r`` and time, and the mutex keeps
the highest id -- the last robot in index order, as the centralized engine does; the
pairwise actor is the robot the centralized pass reaches next.

Direct messages (little-endian int32 fields): request ``(1, o, a, slot)`` 16 bytes;
answer ``(2, o, accepted)`` 12 bytes.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

from heuristics.agents.belief import Belief, Problem

__all__ = ["Answer", "GrapeSAgent", "PairGrapeSAgent", "Request"]

_REQUEST = struct.Struct("<iiii")
_ANSWER = struct.Struct("<iii")


@dataclass(frozen=True)
class Request:
    """Unassigned robot ``o`` asks ``a`` to give it slot ``slot`` (``a``'s current one)."""

    o: int
    a: int
    slot: int

    def encode(self) -> bytes:
        return _REQUEST.pack(1, self.o, self.a, self.slot)


@dataclass(frozen=True)
class Answer:
    """``a``'s answer to ``o``'s request."""

    o: int
    accepted: bool

    def encode(self) -> bytes:
        return _ANSWER.pack(2, self.o, int(self.accepted))


def decode_message(data: bytes) -> Request | Answer:
    """A direct message as :meth:`Request.encode` / :meth:`Answer.encode` built it."""
    kind = struct.unpack_from("<i", data)[0]
    if kind == 1:
        _, o, a, slot = _REQUEST.unpack(data)
        return Request(o, a, slot)
    _, o, accepted = _ANSWER.unpack(data)
    return Answer(o, bool(accepted))


Outbox = list[tuple[int, Any]]


class GrapeSAgent:
    """One robot running GRAPE-S (module docstring).

    Parameters
    ----------
    robot : int
    problem : Problem
    quiet_limit : int
        Ticks without a change after which the robot stops (``K * d_G``).
    capped : bool
        Capped selection (no joining of full slots).
    """

    pairwise = False
    clocked = True

    def __init__(self, robot: int, problem: Problem, quiet_limit: int, capped: bool = False):
        self.robot, self.problem = robot, problem
        self.quiet_limit = max(1, int(quiet_limit))
        self.capped = capped
        self.belief = Belief.initial(problem.n)
        self.quiet = 0
        self.stopped = False
        self.ticks = self.proposals = 0

    def tick(self, now: int, received: Belief | None, inbox: list[Any]) -> tuple[Belief, Outbox]:
        """One clock tick: mutex, selection, then the belief to broadcast and direct sends."""
        self.ticks += 1
        changed = self._mutex(received)
        changed |= self._select(now)
        self._after(changed)
        return self.belief, []

    def performed_slot(self) -> int:
        """The slot this robot's own belief gives it (what it does at the end)."""
        return int(self.belief.slots[self.robot])

    def _mutex(self, received: Belief | None) -> bool:
        if received is not None and received.key > self.belief.key:
            self.belief = received
            return True
        return False

    def _select(self, now: int) -> bool:
        target = self.problem.best_move(self.belief, self.robot, self.capped)
        if target is None:
            return False
        self.belief = self.belief.updated(((self.robot, target),), now, self.robot)
        self.proposals += 1
        return True

    def _after(self, changed: bool) -> None:
        self.quiet = 0 if changed else self.quiet + 1
        if self.quiet >= self.quiet_limit:
            self.stopped = True


class PairGrapeSAgent(GrapeSAgent):
    """One robot running Pair-GRAPE-S (module docstring); ``hops(a, b)`` gives route
    lengths for the request timeout."""

    pairwise = True

    def __init__(self, robot: int, problem: Problem, quiet_limit: int, hops: Any):
        super().__init__(robot, problem, quiet_limit, capped=True)
        self.phase = 1
        self.hops = hops
        self.pending: tuple[int, int] | None = None  # (partner, tick of the request)
        self.exchanges = 0
        self.step_needed = False  # the pairwise step had work when this robot reached it

    def tick(self, now: int, received: Belief | None, inbox: list[Any]) -> tuple[Belief, Outbox]:
        self.ticks += 1
        changed = self._mutex(received)
        out: Outbox = []
        for message in inbox:
            if isinstance(message, Request):
                accepted = self._answer(message, now)
                changed |= accepted
                out.append((message.o, Answer(message.o, accepted)))
            elif self.pending is not None and not message.accepted:
                self.pending = None
        if self.phase == 1:
            changed |= self._select(now)
            self.quiet = 0 if changed else self.quiet + 1
            if self.quiet >= self.quiet_limit:
                self.phase, self.quiet = 2, 0
                short = _short(self.problem, self.belief)
                self.step_needed = bool(short.any()) and bool((self.belief.slots < 0).any())
            return self.belief, out
        out += self._act()
        self.quiet = 0 if changed else self.quiet + 1
        if (
            self.quiet >= self.quiet_limit
            and self.pending is None
            and pairwise_plan(self.problem, self.belief) is None
        ):
            self.stopped = True
        return self.belief, out

    def _act(self) -> Outbox:
        belief = self.belief
        if self.pending is not None:
            partner, since = self.pending
            settled = belief.slots[self.robot] >= 0
            patience = 4 + 2 * int(self.hops(self.robot, partner))
            if not settled and self.ticks - since <= patience:
                return []
            self.pending = None
        plan = pairwise_plan(self.problem, belief)
        if plan is None or plan[0] != self.robot:
            return []
        _, partner, slot = plan
        self.pending = (partner, self.ticks)
        return [(partner, Request(self.robot, partner, slot))]

    def _answer(self, request: Request, now: int) -> bool:
        belief, problem = self.belief, self.problem
        if (
            request.a != self.robot
            or int(belief.slots[self.robot]) != request.slot
            or int(belief.slots[request.o]) >= 0
        ):
            return False
        target = best_short_slot(problem, belief, self.robot)
        if target is None:
            return False
        same_pass = request.o > belief.cursor
        self.belief = belief.updated(
            ((request.o, request.slot), (self.robot, target)),
            now,
            self.robot,
            cursor=request.o,
            made=belief.made + 1 if same_pass else 1,
        )
        self.exchanges += 1
        self.proposals += 1
        return True


def _short(problem: Problem, belief: Belief) -> np.ndarray:
    counts = belief.counts(problem)
    return (counts < problem.req) & (problem.req > 0)


def pairwise_plan(problem: Problem, belief: Belief) -> tuple[int, int, int] | None:
    """``(actor o, partner a, a's slot)`` of the pairwise step on ``belief``, or ``None``.

    Cached per belief; O(U A) numpy work for ``U`` unassigned and ``A`` assigned robots.
    """
    if "plan" in belief._cache:
        return belief._cache["plan"]
    plan = _plan(problem, belief)
    belief._cache["plan"] = plan
    return plan


def _plan(problem: Problem, belief: Belief) -> tuple[int, int, int] | None:
    short = _short(problem, belief)
    slots = belief.slots.astype(np.int64)
    unassigned = np.flatnonzero(slots < 0)
    if not short.any() or unassigned.size == 0:
        return None
    S = problem.S
    caps = problem.caps
    assigned = np.flatnonzero(slots >= 0)
    own = slots[assigned]
    short_per_service = short.reshape(problem.m, S).sum(axis=0)
    options = caps[assigned].astype(np.int64) @ short_per_service - short[own]
    able = assigned[options > 0]
    if able.size == 0:
        return None
    able_service = slots[able] % S
    for start in (belief.cursor, -1) if belief.made > 0 else (belief.cursor,):
        candidates = unassigned[unassigned > start]
        if candidates.size == 0:
            continue
        fits = caps[candidates][:, able_service]
        rows = np.flatnonzero(fits.any(axis=1))
        if rows.size:
            o = int(candidates[rows[0]])
            a = int(able[int(fits[rows[0]].argmax())])
            return o, a, int(slots[a])
    return None


def best_short_slot(problem: Problem, belief: Belief, robot: int) -> int | None:
    """The short slot (not its own) ``robot`` moves to in an exchange: the lowest
    ``(key of joining, task, service)``."""
    short = _short(problem, belief)
    own = int(belief.slots[robot])
    counts = belief.counts(problem)
    S = problem.S
    best: tuple[Any, int] | None = None
    for s in np.flatnonzero(problem.caps[robot]).tolist():
        for slot in (np.flatnonzero(short.reshape(problem.m, S)[:, s]) * S + s).tolist():
            if slot == own:
                continue
            key = problem.model.key(slot // S, s, int(counts[slot]) + 1)
            if best is None or (key, slot) < best:
                best = (key, slot)
    return None if best is None else best[1]
