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

The protocols (:class:`GrapeSProtocol`, :class:`PairGrapeSProtocol`,
:class:`PairGrapeSChainProtocol`) hand these agents to any transport
(:mod:`heuristics.agents.protocol`).  Every agent records the updates it makes (each with
the key of the belief it was made on); the observer rebuilds the newest final belief's
history -- the run's trajectory -- from those records, in one process or gathered from
many.
"""

from __future__ import annotations

import itertools
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from heuristics.agents.belief import (
    GONE,
    Belief,
    Changes,
    Problem,
    belief_history,
    decode_belief,
    encode_belief,
)
from heuristics.agents.protocol import (
    Agent,
    AgentContext,
    Key,
    MissionChanged,
    Protocol,
    ProtocolOutcome,
    RobotFailed,
    RobotRecovered,
    RunContext,
    RunEnd,
)
from heuristics.communication import HEADER_BYTES, ROBOT_ENTRY_BYTES, belief_size

__all__ = [
    "Answer",
    "BeliefReport",
    "ChainRequest",
    "GrapeSAgent",
    "GrapeSProtocol",
    "PairGrapeSAgent",
    "PairGrapeSChainAgent",
    "PairGrapeSChainProtocol",
    "PairGrapeSProtocol",
    "Request",
    "decode_message",
]

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


def decode_message(data: bytes) -> Any:
    """A direct message as its ``encode()`` built it (request, answer, chain request)."""
    kind = struct.unpack_from("<i", data)[0]
    if kind == 1:
        _, o, a, slot = _REQUEST.unpack(data)
        return Request(o, a, slot)
    if kind == 3:
        _, o, hop, k = _CHAIN_HEAD.unpack_from(data)
        values = struct.unpack_from(f"<{2 * k + 1}i", data, _CHAIN_HEAD.size)
        return ChainRequest(
            o, tuple(values[0 : 2 * k : 2]), tuple(values[1 : 2 * k : 2]), values[-1], hop
        )
    _, o, accepted = _ANSWER.unpack(data)
    return Answer(o, bool(accepted))


Outbox = list[tuple[int, Any]]


class GrapeSAgent(Agent):
    """One robot running GRAPE-S (module docstring).

    Parameters
    ----------
    robot : int
    problem : Problem
    quiet_limit : int
        Ticks without a change after which the robot stops (``K * d_G``).
    capped : bool
        Capped selection (no joining of full slots).

    Attributes
    ----------
    made : dict
        Every update this robot made: the new belief's key -> ``(changes, key of the
        belief it was made on)``.
    work : int
        Slot examinations: what the literal algorithm examines per selection
        (:attr:`Problem.examined`), once per tick.
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
        self.ticks = self.proposals = self.work = 0
        self.examined = int(problem.examined[robot])
        self.made: dict[Key, tuple[Changes, Key]] = {}
        self.failed: set[int] = set()  # neighbours its detector presumes failed

    def tick(self, now: int, received: Belief | None, inbox: list[Any]) -> tuple[Belief, Outbox]:
        """One clock tick: mutex, selection, then the belief to broadcast and direct sends."""
        self.ticks += 1
        self.work += self.examined
        changed = self._mutex(received)
        if self.failed or self.problem.absent_tasks:  # only in runs with mission events
            changed |= self._repair(now)
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

    # ------------------------------------------------------------ mission events
    def on_event(self, now: int, event: Any) -> bool:
        """GRAPE-S's reaction to a mission event: a neighbour presumed failed has its slot
        freed in this robot's belief (an update by this robot, made again whenever a
        belief shows it assigned); a withdrawn task's robots are freed and the selection
        rule follows the mission as it now stands; on any event (news, a join) the robot
        runs again, its quiet count reset, and moves if it has a better slot."""
        if isinstance(event, RobotRecovered):
            self.failed.discard(event.robot)
            return False
        if isinstance(event, RobotFailed):
            self.failed.add(event.robot)
        elif isinstance(event, MissionChanged):
            self.problem = _problem_for(event, self.problem)
            self.examined = int(self.problem.examined[self.robot])
        self._repair(now)
        self._restart()
        return True

    def _restart(self) -> None:
        self.quiet = 0
        self.stopped = False

    def _repair(self, now: int) -> bool:
        """Mark, in this robot's belief, the presumed-failed robots gone (:data:`GONE`:
        their slots freed, and no longer unassigned robots to the pairwise step) and free
        the robots on tasks no longer present (one update)."""
        slots = self.belief.slots
        changes = {f: GONE for f in self.failed if slots[f] != GONE}
        if self.problem.absent_tasks:
            placed = np.flatnonzero(slots >= 0)
            for r in placed[self.problem.req[slots[placed]] == 0].tolist():
                changes.setdefault(r, -1)
        if not changes:
            return False
        self._update(tuple(sorted((int(r), int(v)) for r, v in changes.items())), now)
        self.proposals += 1
        return True

    def _select(self, now: int) -> bool:
        target = self.problem.best_move(self.belief, self.robot, self.capped)
        if target is None:
            return False
        self._update(((self.robot, target),), now)
        self.proposals += 1
        return True

    def _update(self, changes: Changes, now: int, **fields: Any) -> None:
        """Make these changes in this robot's belief (an update by it, at ``now``) and
        record the update."""
        old = self.belief
        self.belief = old.updated(changes, now, self.robot, **fields)
        self.made[self.belief.key] = (changes, old.key)

    def _after(self, changed: bool) -> None:
        self.quiet = 0 if changed else self.quiet + 1
        if self.quiet >= self.quiet_limit:
            self.stopped = True


def _problem_for(event: MissionChanged, old: Problem) -> Problem:
    """The selection rule on the mission as ``event`` says it stands (built once per
    event, shared by the robots)."""
    problem = event.cache.get("problem")
    if problem is None:
        problem = event.cache["problem"] = Problem(event.mission, old.reward, event.active)
    return problem


class PairGrapeSAgent(GrapeSAgent):
    """One robot running Pair-GRAPE-S (module docstring); ``hops(a, b)`` gives route
    lengths for the request timeout."""

    pairwise = True

    def __init__(self, robot: int, problem: Problem, quiet_limit: int, hops: Any):
        super().__init__(robot, problem, quiet_limit, capped=True)
        self.phase = 1
        self.hops = hops
        self.pending: tuple[int, int] | None = None  # (patience in ticks, tick of the request)
        self.exchanges = 0
        self.step_needed = False  # the pairwise step had work when this robot reached it

    def _restart(self) -> None:
        super()._restart()
        self.phase, self.pending = 1, None  # GRAPE-S moves again, then the pairwise step

    def tick(self, now: int, received: Belief | None, inbox: list[Any]) -> tuple[Belief, Outbox]:
        self.ticks += 1
        self.work += self.examined
        changed = self._mutex(received)
        if self.failed or self.problem.absent_tasks:
            changed |= self._repair(now)
        out: Outbox = []
        for message in inbox:
            if isinstance(message, Answer):
                if self.pending is not None and not message.accepted:
                    self.pending = None
                continue
            sends, accepted = self._on_request(message, now)
            changed |= accepted
            out += sends
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
            and self.plan(self.belief) is None
        ):
            self.stopped = True
        return self.belief, out

    def plan(self, belief: Belief) -> Any:
        """The pairwise step's next exchange on ``belief`` (its actor first), or ``None``."""
        return pairwise_plan(self.problem, belief)

    def _request(self, plan: Any) -> tuple[int, Any, int]:
        """The message that starts ``plan``'s exchange, its first recipient, and the hops
        the exchange's messages travel before the answer can be back."""
        _, partner, slot = plan
        return partner, Request(self.robot, partner, slot), int(self.hops(self.robot, partner))

    def _on_request(self, request: Any, now: int) -> tuple[Outbox, bool]:
        accepted = self._answer(request, now)
        return [(request.o, Answer(request.o, accepted))], accepted

    def _act(self) -> Outbox:
        belief = self.belief
        if self.pending is not None:
            patience, since = self.pending
            settled = belief.slots[self.robot] >= 0
            if not settled and self.ticks - since <= patience:
                return []
            self.pending = None
        plan = self.plan(belief)
        if plan is None or plan[0] != self.robot:
            return []
        first, message, hops = self._request(plan)
        self.pending = (4 + 2 * hops, self.ticks)  # ticks to wait for the answer
        return [(first, message)]

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
        self._update(
            ((request.o, request.slot), (self.robot, target)),
            now,
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
    key = ("plan", problem.token)
    if key in belief._cache:
        return belief._cache[key]
    plan = _plan(problem, belief)
    belief._cache[key] = plan
    return plan


def _plan(problem: Problem, belief: Belief) -> tuple[int, int, int] | None:
    short = _short(problem, belief)
    slots = belief.slots.astype(np.int64)
    unassigned = np.flatnonzero(slots == -1)  # not the failed (GONE)
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


# ------------------------------------------------------------------- chain exchanges
_CHAIN_HEAD = struct.Struct("<iiii")  # kind 3, o, hop, k


@dataclass(frozen=True)
class ChainRequest:
    """Unassigned robot ``o`` asks the chain ``robots`` (``a_1 .. a_k``) to shift: ``o``
    takes ``slots[0]`` (``a_1``'s), each ``a_i`` the next one's, ``a_k`` the short slot
    ``end``.  It travels from ``a_1`` to ``a_k``; ``hop`` is the recipient's position."""

    o: int
    robots: tuple[int, ...]
    slots: tuple[int, ...]
    end: int
    hop: int = 0

    def encode(self) -> bytes:
        body = _CHAIN_HEAD.pack(3, self.o, self.hop, len(self.robots))
        pairs = [v for pair in zip(self.robots, self.slots, strict=True) for v in pair]
        return body + struct.pack(f"<{len(pairs) + 1}i", *pairs, self.end)


class PairGrapeSChainAgent(PairGrapeSAgent):
    """One robot running Pair-GRAPE-S with chain exchanges (``pair-grape-s-chain``).

    Phase 1 and the pass state are Pair-GRAPE-S's; the actor is the first unassigned robot
    after the cursor that has a chain (the centralized variant's shortest chain, its ties
    and end slot: :func:`chain_plan`).  Its :class:`ChainRequest` goes to ``a_1`` and is
    forwarded along the chain, each member checking its own slot on its own belief; the
    last member checks the whole chain and the end slot on its belief, makes the exchange
    in it (``r += 1``: one iteration, every robot on the chain one step) and answers
    *accept*; a member that finds the request stale answers *refuse*.  Request ``16 + 8 k``
    bytes; answers as Pair-GRAPE-S's.
    """

    def plan(self, belief: Belief) -> Any:
        return chain_plan(self.problem, belief)

    def _request(self, plan: Any) -> tuple[int, Any, int]:
        o, robots, slots, end = plan
        path = (o, *robots)
        hops = sum(int(self.hops(a, b)) for a, b in itertools.pairwise(path))
        hops += int(self.hops(path[-1], o))
        first = robots[0] if robots else o  # no partner: o moves into the short slot itself
        return first, ChainRequest(o, robots, slots, end), hops

    def _on_request(self, request: Any, now: int) -> tuple[Outbox, bool]:
        belief = self.belief
        if not request.robots:
            accepted = request.o == self.robot and self._apply_chain(request, now)
            return [], accepted
        valid = (
            request.robots[request.hop] == self.robot
            and int(belief.slots[request.o]) < 0
            and int(belief.slots[self.robot]) == request.slots[request.hop]
        )
        last = request.hop == len(request.robots) - 1
        if valid and not last:
            nxt = ChainRequest(
                request.o, request.robots, request.slots, request.end, request.hop + 1
            )
            return [(request.robots[request.hop + 1], nxt)], False
        accepted = valid and self._apply_chain(request, now)
        return [(request.o, Answer(request.o, accepted))], accepted

    def _apply_chain(self, request: ChainRequest, now: int) -> bool:
        belief = self.belief
        slots = belief.slots
        if any(int(slots[r]) != s for r, s in zip(request.robots, request.slots, strict=True)):
            return False
        short = _short(self.problem, belief)
        if not short[request.end] or request.end == int(slots[self.robot]):
            return False
        movers = (request.o, *request.robots)
        targets = (*request.slots, request.end)
        same_pass = request.o > belief.cursor
        self._update(
            tuple(zip(movers, targets, strict=True)),
            now,
            cursor=request.o,
            made=belief.made + 1 if same_pass else 1,
        )
        self.exchanges += 1
        self.proposals += 1
        return True


def chain_plan(problem: Problem, belief: Belief) -> tuple[int, tuple, tuple, int] | None:
    """``(o, (a_1..a_k), their slots, end slot)`` of the chain step on ``belief``, or
    ``None``: the centralized variant's choice (:mod:`heuristics.pair_grape_s_chain`)
    with the pass state of the belief.  Cached per belief; one shortest-path search."""
    key = ("chain", problem.token)
    if key in belief._cache:
        return belief._cache[key]
    plan = _chain(problem, belief)
    belief._cache[key] = plan
    return plan


def _chain(problem: Problem, belief: Belief) -> tuple[int, tuple, tuple, int] | None:
    from heuristics.pair_grape_s_chain import chain_distances, end_slot, trace_chain

    S = problem.S
    short = _short(problem, belief).reshape(problem.m, S)
    slots = belief.slots.astype(np.int64)
    unassigned = np.flatnonzero(slots == -1)  # not the failed (GONE)
    if not short.any() or unassigned.size == 0:
        return None
    task = np.where(slots >= 0, slots // S, -1)
    service = np.where(slots >= 0, slots % S, -1)
    lengths, _ = chain_distances(problem.caps, short, task, service)
    for start in (belief.cursor, -1) if belief.made > 0 else (belief.cursor,):
        candidates = unassigned[unassigned > start]
        ready = candidates[np.isfinite(lengths[candidates])]
        if ready.size == 0:
            continue
        o = int(ready[0])
        chain, _ = trace_chain(o, lengths, problem.caps, task, service, np.arange(problem.n))
        counts = belief.counts(problem).reshape(problem.m, S)
        found, _ = end_slot(
            chain[-1], problem.caps, short, counts, task, service, problem.model.key
        )
        if found is None:
            return None
        robots = tuple(chain[1:])
        return o, robots, tuple(int(slots[r]) for r in robots), found[0] * S + found[1]
    return None


# ------------------------------------------------------------------------ protocols
@dataclass(frozen=True)
class BeliefReport:
    """What a GRAPE-S-family agent tells the observer at the end of a run.

    Attributes
    ----------
    payload : bytes
        Its final belief, encoded (the observer decodes the newest).
    made : dict
        Its :attr:`GrapeSAgent.made` records.
    step_needed : bool
        The pairwise step had work when this robot reached it (Pair-GRAPE-S).
    """

    payload: bytes
    made: Mapping[Key, tuple[Changes, Key]]
    step_needed: bool = False


class GrapeSProtocol(Protocol):
    """GRAPE-S's agents (:class:`GrapeSAgent`) for any transport; final = Nash stable.

    The robots share a :class:`~heuristics.agents.Problem` (the mission and the reward
    the run asks for).  Beliefs travel as :func:`~heuristics.agents.encode_belief`'s
    ``16 + 4 n`` bytes (``24 + 4 n`` with Pair-GRAPE-S's pass state).  The outcome: the
    robots agree when they end on one key, converge when that belief is final; the
    trajectory and ``iterations`` are the newest final belief's history.

    Examples
    --------
    >>> import cfopt, heuristics
    >>> m = cfopt.generate_mission(robots=12, percent_tasks=25, service_types=3,
    ...                            services_per_robot=2, seed=4)
    >>> run = heuristics.simulate(m, GrapeSProtocol(), "complete sync=true", seed=0)
    >>> run.trajectory.tolist() == heuristics.grape_s(m).trajectory.tolist()
    True
    """

    name = "grape-s"
    pairwise = False

    def prepare(self, context: RunContext) -> Any:
        return Problem(context.mission, context.reward)

    def make_agent(self, context: AgentContext) -> Agent:
        return GrapeSAgent(context.robot, context.shared, context.quiet_limit)

    def encode(self, belief: Any) -> bytes:
        return encode_belief(belief, pairwise=self.pairwise)

    def decode(self, data: bytes, context: RunContext) -> Any:
        return decode_belief(data, context.n, pairwise=self.pairwise)

    def encoded_size(self, belief: Any, encoding: str, context: RunContext) -> int:
        """``compact``: the slots bit-packed (:func:`heuristics.communication.belief_size`),
        the header and the belief's other fields as :meth:`encode` writes them."""
        full = len(self.encode(belief))
        if encoding != "compact":
            return full
        n, mission = context.n, context.mission
        extra = full - HEADER_BYTES - ROBOT_ENTRY_BYTES * n
        slots = mission.n_tasks * max(mission.n_services, 1)
        return belief_size(n, slots, encoding="compact", extra_bits=8 * extra)

    def decode_message(self, data: bytes, context: RunContext) -> Any:
        return decode_message(data)

    def final(self, shared: Any, belief: Any) -> bool:
        """Whether ``belief`` is final for the algorithm (no robot has a move)."""
        return shared.stable(belief, capped=False)

    def initial(self, shared: Any, context: RunContext) -> Any:
        """The belief every robot starts from."""
        return Belief.initial(context.n)

    def report(self, agent: Any) -> BeliefReport:
        return BeliefReport(
            self.encode(agent.belief), agent.made, bool(getattr(agent, "step_needed", False))
        )

    def outcome(self, end: RunEnd) -> ProtocolOutcome:
        newest = end.newest_key
        if newest is None:
            belief = self.initial(end.shared, end.context)
        else:
            belief = self.decode(end.reports[end.keys.index(newest)].payload, end.context)
        agree = end.beliefs_agree
        converged = agree and self.final(end.shared, belief)
        made: dict[Key, tuple[Changes, Key]] = {}
        for report in end.reports:
            made.update(report.made)
        history = belief_history(made, belief.key)
        iterations, trajectory, exchanges = self.numbered(history, end.context.mission)
        return ProtocolOutcome(
            iterations=iterations,
            trajectory=trajectory,
            converged=bool(converged),
            beliefs_agree=agree,
            convergence_ns=end.settled_ns if converged else None,
            exchanges=exchanges,
            pairwise_step_ran=any(report.step_needed for report in end.reports),
            options=self.options(end.context),
        )

    def numbered(
        self, history: list[tuple[int, Changes]], mission: Any
    ) -> tuple[int, list[tuple[int, int, int, int]], int]:
        """``(iterations, trajectory, exchanges)`` from the newest belief's history
        (oldest update first): every update is iteration ``r``."""
        S = max(mission.n_services, 1)
        trajectory = [
            (r, robot, slot // S if slot >= 0 else -1, slot % S if slot >= 0 else -1)
            for r, changes in history
            for robot, slot in changes
        ]
        iterations = history[-1][0] if history else 0
        return iterations, trajectory, sum(1 for _, changes in history if len(changes) >= 2)

    def options(self, context: RunContext) -> tuple[tuple[str, Any], ...]:
        """What ``run.options`` records of this protocol."""
        return (("capped", self.pairwise), ("reward", context.reward))


class PairGrapeSProtocol(GrapeSProtocol):
    """Pair-GRAPE-S's agents (:class:`PairGrapeSAgent`); final = nothing left for the
    pairwise step."""

    name = "pair-grape-s"
    pairwise = True

    def make_agent(self, context: AgentContext) -> Agent:
        return PairGrapeSAgent(context.robot, context.shared, context.quiet_limit, context.hops)

    def final(self, shared: Any, belief: Any) -> bool:
        return pairwise_plan(shared, belief) is None


class PairGrapeSChainProtocol(PairGrapeSProtocol):
    """Pair-GRAPE-S with chain exchanges (:class:`PairGrapeSChainAgent`); final = no
    chain left for the step."""

    name = "pair-grape-s-chain"

    def make_agent(self, context: AgentContext) -> Agent:
        return PairGrapeSChainAgent(
            context.robot, context.shared, context.quiet_limit, context.hops
        )

    def final(self, shared: Any, belief: Any) -> bool:
        return chain_plan(shared, belief) is None
