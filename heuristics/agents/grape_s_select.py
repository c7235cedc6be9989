"""GRAPE-S-Select as agents: one robot each, on its own belief.

The centralized algorithm (:mod:`heuristics.grape_s_select`) already runs on a shared
belief with a distributed mutex; this module runs it robot by robot on the simulator of
:mod:`heuristics.simulate` (``simulate(mission, "grape-s-select", network)``) or any other
transport, exactly as :class:`heuristics.agents.GrapeSAgent` runs GRAPE-S.

Belief
------
A :class:`SelectBelief` is GRAPE-S's belief ``(r, time, id, Pi)`` plus the two bits per
task of the centralized state: *closed* (the collective has given the task up) and
*reopened* (its one reopening is used).  Every viable task starts open, the others closed
and reopened.  The mutex compares beliefs by the key ``(r, time, id)`` alone, so the
partition and the task bits travel and are replaced together.  Message
(:func:`encode_select_belief`): GRAPE-S's ``16 + 4 n`` bytes, then the task bits, two per
task (bit ``2 j`` closed, ``2 j + 1`` reopened, little-endian bit order) in ``ceil(m / 4)``
bytes -- ``16 + 4 n + ceil(m / 4)``, the byte model of :func:`heuristics.grape_s_select`.

A robot's tick
--------------
At every tick of its clock a robot

1. runs the distributed mutex over its own belief and those received since its last tick,
   keeping the highest ``(r, time, id)``;
2. computes, on its belief, its best move under GRAPE-S-Select's reward (the highest
   reward; ties by slack, scarcity, index -- the centralized module's notes and its
   :meth:`~heuristics.grape_s_select._Engine.service_choice`).  If the move is strictly
   better than staying it makes it in its belief: ``r += 1``, ``time = now``,
   ``id = itself``;
3. otherwise, if *no* robot has a move on its belief (every robot can compute every
   robot's wish on the shared belief: the mission is common knowledge), it makes the
   *phase step* -- close, reopen or exchange, the first that applies -- in its belief as an
   update (``r += 1``, ``time = now``, ``id = itself``; released robots become
   unassigned, the task bits change).  The step is the centralized engine's own
   (:meth:`~heuristics.grape_s_select._Engine.phase_step` on the belief's state), so every
   robot holding the belief computes the same step, and concurrent identical steps are
   resolved by the mutex like any update;
4. broadcasts its belief.

A robot stops (as a GRAPE-S robot: no more selection, no more broadcasts; it performs
the slot its belief gives it) when its belief has not changed for ``quiet_limit``
consecutive ticks and nothing is left for it on its belief: no move of its own and no
phase step.  The observer calls a belief *final* when no robot has a move on it and no
phase step applies (:meth:`SelectModel.final`): what the centralized run ends on.

Lock-step runs
--------------
With lock-step clocks, no latency or loss and a complete topology, every robot holds the
same belief at every tick; the proposals of a tick carry the same ``r`` and time and the
mutex keeps the highest id -- the last robot in index order, as the centralized engine's
mutex does with ``order="index"``; in a tick without a move every robot makes the same
phase step.  The run makes exactly the centralized moves and phase steps and ends on the
same assignment.  The simulator numbers the trajectory like the centralized engine (an
iteration per update that changed the partition: a reopening changes only task bits).

Cost
----
Per belief (cached on it, so every robot holding it shares the work): the robots' rewards
and every service's best place, O(n + m S) numpy; per robot that wants to move its
service choice, O(n + K S).  The phase step is computed only on a belief on which no
robot has a move, once per belief: the engine is loaded with it (O(n log(m S))) and
makes its step; the beliefs the robots make by that step share one cache, their content
being the same.

Examples
--------
Three robots, two tasks needing two each (the centralized module's example): the robots
fill ``t0``, robot 0 starts ``t1``, which is closed (robot 0 released), and robot 0
over-fills ``t0``.

>>> import cfopt
>>> from heuristics.grape_s_select import grape_s_select
>>> from heuristics.simulate import simulate
>>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
>>> run = simulate(m, "grape-s-select", "complete sync=true", seed=0)
>>> run.trajectory.tolist()       # (iteration, robot, task, service); -1: released
[[1, 2, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0], [4, 0, -1, -1], [5, 0, 0, 0]]
>>> run.trajectory.tolist() == grape_s_select(m).trajectory.tolist()
True
>>> run.network.converged, run.assignment.task.tolist()
(True, [0, 0, 0])

A belief and its message:

>>> model = SelectModel(m)
>>> b = model.initial()
>>> b.closed.tolist(), b.used.tolist(), len(encode_select_belief(b))   # 16 + 4*3 + 1
([False, False], [False, False], 29)
>>> model.best_move(b, 2), model.any_move(b)    # slot 0 = (t0, s0)
(0, True)
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, MissionError
from heuristics.agents.belief import Belief, Changes, Problem, encode_belief
from heuristics.agents.grape_s import GrapeSAgent, GrapeSProtocol
from heuristics.agents.protocol import Agent, AgentContext, RunContext
from heuristics.grape_s_select import _Engine

__all__ = [
    "GrapeSSelectAgent",
    "GrapeSSelectProtocol",
    "SelectBelief",
    "SelectModel",
    "decode_select_belief",
    "encode_select_belief",
]

_HEADER = struct.Struct("<iiq")  # as encode_belief: r, robot id, time (ns)

Bits = npt.NDArray[np.bool_]


def _frozen(values: Any) -> Bits:
    if isinstance(values, np.ndarray) and values.dtype == bool and not values.flags.writeable:
        return values  # already a read-only bit array: shared, never copied
    out = np.array(values, dtype=bool).reshape(-1)
    out.setflags(write=False)
    return out


class SelectBelief(Belief):
    """A GRAPE-S belief plus per-task ``closed`` and ``used`` (reopened) bits (module
    docstring); immutable, the bits read-only boolean arrays of length ``m``."""

    __slots__ = ("closed", "used")

    def __init__(
        self,
        r: int,
        time: int,
        robot: int,
        slots: npt.NDArray[np.int32],
        trail: Any = None,
        closed: Bits | None = None,
        used: Bits | None = None,
    ) -> None:
        super().__init__(r, time, robot, slots, trail)
        self.closed = _frozen([] if closed is None else closed)
        self.used = _frozen([] if used is None else used)

    def updated(  # type: ignore[override]
        self,
        changes: tuple[tuple[int, int], ...],
        now: int,
        by: int,
        *,
        closed: Bits | None = None,
        used: Bits | None = None,
        cache: dict[Any, Any] | None = None,
        **_: Any,
    ) -> SelectBelief:
        """A new belief: these ``(robot, slot)`` changes and task bits (``None``: kept) by
        robot ``by`` at ``now``; ``cache`` shares computed results with a belief of the
        same content."""
        base = super().updated(changes, now, by)
        out = SelectBelief(
            base.r,
            base.time,
            base.robot,
            base.slots,
            base.trail,
            self.closed if closed is None else closed,
            self.used if used is None else used,
        )
        if cache is not None:
            out._cache = cache
        return out


def encode_select_belief(belief: SelectBelief) -> bytes:
    """The message a robot broadcasts: :func:`~heuristics.agents.encode_belief`'s ``16 +
    4 n`` bytes, then the task bits in ``ceil(m / 4)`` bytes; built once per belief.

    >>> b = SelectBelief(3, 7, 1, np.array([0, -1], dtype=np.int32), None,
    ...                  [True, False, False, False, True], [True, True, False, False, False])
    >>> data = encode_select_belief(b)
    >>> len(data)                                   # 16 + 4*2 + ceil(5/4)
    26
    >>> c = decode_select_belief(data, 2, 5)
    >>> c.key == b.key, c.closed.tolist() == b.closed.tolist(), c.used.tolist() == b.used.tolist()
    (True, True, True)
    """
    cached = belief._cache.get("payload")
    if cached is not None and cached[0] == belief.key:
        return cached[1]
    bits = np.empty(2 * belief.closed.size, dtype=bool)
    bits[0::2], bits[1::2] = belief.closed, belief.used
    body = encode_belief(belief) + np.packbits(bits, bitorder="little").tobytes()
    belief._cache["payload"] = (belief.key, body)  # the cache may be shared: keyed
    return body


def decode_select_belief(data: bytes, n: int, m: int) -> SelectBelief:
    """The belief :func:`encode_select_belief` encoded (without its trail)."""
    r, robot, time = _HEADER.unpack_from(data, 0)
    slots = np.frombuffer(data, dtype="<i4", count=n, offset=_HEADER.size).astype(np.int32)
    slots.setflags(write=False)
    raw = np.frombuffer(data, dtype=np.uint8, offset=_HEADER.size + 4 * n)
    bits = np.unpackbits(raw, bitorder="little", count=2 * m).astype(bool)
    return SelectBelief(r, time, robot, slots, None, bits[0::2], bits[1::2])


@dataclass(frozen=True)
class _Wishes:
    """The robots' wishes on one belief."""

    cnt: npt.NDArray[np.int64]  # robots per slot (m S,)
    cur: npt.NDArray[np.int64]  # per robot its reward code
    top: npt.NDArray[np.int64]  # per service the best reward code to join (-1: none)
    best: npt.NDArray[np.int64]  # per capability type the best reward code to join
    want: npt.NDArray[np.bool_]  # per robot: a strictly better move exists


@dataclass(frozen=True)
class _Step:
    """A phase step's update: released robots, the new task bits, a shared cache."""

    changes: tuple[tuple[int, int], ...]
    closed: Bits
    used: Bits
    cache: dict[Any, Any]


class SelectModel:
    """What every robot knows from the start and its computations on a belief.

    Parameters
    ----------
    mission : cfopt.Mission
    exchange : bool, default True
        Enable the exchange step (as :func:`heuristics.grape_s_select`'s ``exchange``).

    Notes
    -----
    The static data (priorities, viability, capability types, scarcities) and the phase
    steps are those of the centralized engine, one instance of which this model holds and
    loads with a belief's state to compute a phase step.  Rewards are coded as in the
    centralized module: ``m + pi_j`` needed, ``pi_j`` surplus, ``-1`` nothing.  Results
    are cached on the belief: :meth:`wishes` under ``"wishes"``, :meth:`phase_step`
    under ``"step"``.
    """

    def __init__(self, mission: Mission, exchange: bool = True) -> None:
        self.engine = _Engine(mission, "index", bool(exchange), np.random.default_rng(0))
        e = self.engine
        self.n, self.m, self.S = e.n, e.m, e.S
        self.exchange = bool(exchange)
        self.rank = np.asarray(e.rank, dtype=np.int64)
        self.viable = np.array(e.viable, dtype=bool)
        self.single = np.asarray(e.REQ, dtype=np.int64) == 1
        self.req = np.asarray(e.req, dtype=np.int64)
        slot = np.flatnonzero(self.req)  # the slots (j, s) with req > 0
        self.g_slot = slot
        self.g_task = slot // max(self.S, 1)
        self.g_svc = slot % max(self.S, 1)
        self.g_req = self.req[slot]

    def initial(self) -> SelectBelief:
        """Every robot unassigned, ``r = 0``; viable tasks open, the others closed and
        reopened."""
        slots = np.full(self.n, -1, dtype=np.int32)
        slots.setflags(write=False)
        return SelectBelief(0, 0, -1, slots, None, ~self.viable, ~self.viable)

    # ---------------------------------------------------------------- the moves
    def wishes(self, belief: SelectBelief) -> _Wishes:
        """Every robot's reward and whether it has a strictly better move; cached."""
        found = belief._cache.get("wishes")
        if found is not None:
            return found
        m, S, n = self.m, max(self.S, 1), self.n
        slots = belief.slots.astype(np.int64)
        placed = slots >= 0
        cnt = np.bincount(slots[placed], minlength=m * S).astype(np.int64)
        closed = belief.closed
        g_cnt = cnt[self.g_slot]
        missing = np.bincount(
            self.g_task, weights=np.maximum(self.g_req - g_cnt, 0), minlength=m
        ).astype(np.int64)
        alive = self.viable & ((missing == 0) | ~closed)  # complete or open
        # a robot in slot (k, s) of an alive task: needed (m + pi_k) or surplus (pi_k)
        cur = np.full(n, -1, dtype=np.int64)
        own = slots[placed]
        k = own // S
        code = np.where(cnt[own] <= self.req[own], m + self.rank[k], self.rank[k])
        cur[placed] = np.where(alive[k], code, -1)
        # joining (k, s): joinable tasks are viable and open, or closed needing one robot
        # (the engine's rule; a closed task needing more is empty and no move completes it)
        joinable = self.viable & (~closed | self.single)
        gk = self.rank[self.g_task]
        join = np.where(g_cnt < self.g_req, m + gk, gk)
        join = np.where(joinable[self.g_task], join, -1)
        top = np.full(self.S, -1, dtype=np.int64)
        np.maximum.at(top, self.g_svc, join)
        best, want = self.engine.wants(top, cur)
        found = _Wishes(cnt, cur, top, best, want)
        belief._cache["wishes"] = found
        return found

    def any_move(self, belief: SelectBelief) -> bool:
        """Whether some robot has a strictly better move on ``belief``."""
        return bool(self.wishes(belief).want.any())

    def best_move(self, belief: SelectBelief, robot: int) -> int | None:
        """The slot ``robot`` moves to on ``belief`` (``j * S + s``), or ``None`` to stay."""
        w = self.wishes(belief)
        if not w.want[robot]:
            return None
        e = self.engine
        T = int(e.rtype[robot])
        key = int(w.best[T])
        k = e.task_of_key(key)
        options = [s for s in e.svc_of_type[T] if int(w.top[s]) == key]
        s = e.service_choice(options, w.cur, robot, key, k, w.cnt)
        return k * self.S + s

    # ---------------------------------------------------------------- phase steps
    def phase_step(self, belief: SelectBelief) -> tuple[_Step | None, int]:
        """The phase step on ``belief`` (``None``: none applies) and the work of finding
        it (the centralized unit); cached.  Meant for beliefs on which no robot has a
        move (the step of a round without a proposal)."""
        found = belief._cache.get("step")
        if found is not None:
            return found
        e, S = self.engine, max(self.S, 1)
        slots = belief.slots.astype(np.int64)
        task = np.where(slots >= 0, slots // S, -1)
        service = np.where(slots >= 0, slots % S, -1)
        e.load(task, service, belief.closed, belief.used)
        step = None
        if e.phase_step():
            step = _Step(
                tuple((robot, -1) for _, robot, _, _ in e.out.moves),
                _frozen(e.closed),
                _frozen(e.used),
                {},
            )
        found = (step, int(e.phase_work[0]))
        belief._cache["step"] = found
        return found

    def final(self, belief: SelectBelief) -> bool:
        """No robot has a move on ``belief`` and no phase step applies."""
        return not self.any_move(belief) and self.phase_step(belief)[0] is None


class GrapeSSelectAgent(GrapeSAgent):
    """One robot running GRAPE-S-Select (module docstring).

    Parameters
    ----------
    robot : int
    problem : heuristics.agents.Problem
        The mission as the simulator shares it (GRAPE-S's; used for ``n``).
    model : SelectModel
        GRAPE-S-Select's view of the mission, shared by the robots (it holds only what
        every robot knows and per-belief caches).
    quiet_limit : int
        Ticks without a change after which the robot stops (``K * d_G``).

    Attributes
    ----------
    steps : int
        Phase steps this robot made (the mutex may have discarded some).
    work : int
        Phase-step work: what finding the step cost, once per belief the robot checked.
    """

    def __init__(self, robot: int, problem: Problem, model: SelectModel, quiet_limit: int):
        super().__init__(robot, problem, quiet_limit)
        self.model = model
        self.belief: SelectBelief = model.initial()
        self.steps = self.work = 0
        self._checked: tuple[int, int, int] | None = None

    def _select(self, now: int) -> bool:
        model, belief = self.model, self.belief
        target = model.best_move(belief, self.robot)
        if target is not None:
            self._update(((self.robot, target),), now)
            self.proposals += 1
            return True
        if model.any_move(belief):
            return False  # another robot's move comes first
        step, work = model.phase_step(belief)
        if self._checked != belief.key:
            self._checked = belief.key
            self.work += work
        if step is None:
            return False
        self._update(step.changes, now, closed=step.closed, used=step.used, cache=step.cache)
        self.steps += 1
        self.proposals += 1
        return True

    def on_event(self, now: int, event: Any) -> bool:
        """GRAPE-S-Select does not react to mission events (the agent API's default)."""
        return False

    def _after(self, changed: bool) -> None:
        self.quiet = 0 if changed else self.quiet + 1
        if self.quiet >= self.quiet_limit and self._idle():
            self.stopped = True

    def _idle(self) -> bool:
        """Nothing left for this robot on its belief: no move, no phase step to make."""
        belief, model = self.belief, self.model
        if model.best_move(belief, self.robot) is not None:
            return False
        return model.any_move(belief) or model.phase_step(belief)[0] is None


class GrapeSSelectProtocol(GrapeSProtocol):
    """GRAPE-S-Select's agents (:class:`GrapeSSelectAgent`) for any transport; final = no
    robot has a move and no phase step applies.  Beliefs carry the task bits (``16 + 4 n +
    ceil(m / 4)`` bytes); the trajectory and ``iterations`` count, as the centralized
    engine does, the updates that changed the partition (moves, close and exchange steps,
    not reopenings).

    Parameters
    ----------
    exchange : bool, default True
        The exchange phase step (as :func:`heuristics.grape_s_select`'s).
    """

    name = "grape-s-select"

    def __init__(self, exchange: bool = True) -> None:
        if not isinstance(exchange, bool | np.bool_):
            raise MissionError(f"options: exchange must be True or False, got {exchange!r}")
        self.exchange = bool(exchange)

    def prepare(self, context: RunContext) -> Any:
        if context.reward != "paper":
            raise MissionError(
                f"reward: grape-s-select has its own reward, got reward={context.reward!r}"
            )
        return Problem(context.mission, context.reward), SelectModel(
            context.mission, exchange=self.exchange
        )

    def make_agent(self, context: AgentContext) -> Agent:
        problem, model = context.shared
        return GrapeSSelectAgent(context.robot, problem, model, context.quiet_limit)

    def encode(self, belief: Any) -> bytes:
        return encode_select_belief(belief)

    def decode(self, data: bytes, context: RunContext) -> Any:
        return decode_select_belief(data, context.n, context.mission.n_tasks)

    def final(self, shared: Any, belief: Any) -> bool:
        return shared[1].final(belief)

    def initial(self, shared: Any, context: RunContext) -> Any:
        return shared[1].initial()

    def numbered(
        self, history: list[tuple[int, Changes]], mission: Any
    ) -> tuple[int, list[tuple[int, int, int, int]], int]:
        """Iterations count only the updates that changed the partition; no exchanges
        are reported."""
        S = max(mission.n_services, 1)
        iterations = 0
        trajectory = []
        for _, changes in history:
            if changes:
                iterations += 1
                trajectory += [
                    (iterations, robot, *((slot // S, slot % S) if slot >= 0 else (-1, -1)))
                    for robot, slot in changes
                ]
        return iterations, trajectory, 0

    def options(self, context: RunContext) -> tuple[tuple[str, Any], ...]:
        return (("exchange", self.exchange),)
