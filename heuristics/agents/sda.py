"""SDA as message-driven agents: the simultaneous descending auction over a network.

The centralized engine (:func:`heuristics.sda`) runs the auction as one program.  Here the
same auction is run by agents that see only their own state and the messages that reach
them, in the discrete-event simulator of :mod:`heuristics.simulate` (``simulate(mission,
"sda", network)``) or as MPI processes (``mpi_run(mission, "sda", network)``), by
:class:`SdaProtocol`.  The schedule is ``max-wage`` with ``eps = 1`` (the centralized
defaults; :class:`SdaProtocol` takes another ``eps``).  Every agent knows the mission (the
robots' services, the tasks' requirements and utilities) and ``eps``, as the centralized
engine does; what it learns at run time is what is sold, to whom and when.

Agents and placement
--------------------
- One *service agent* per service type ``s``, hosted on robot ``s mod n``.  It keeps a
  *replica* of the auction: the unsold robots, the wages, the staffed tasks, who was
  sold to whom for which service.
- One *task agent* per task ``j``, hosted on robot ``(S + j) mod n`` (``S`` service
  types).  Its *home* is service agent ``j mod S``, the only agent it talks to.  It keeps
  its own *view* of the unsold robots and of the wages.
- Every robot runs one :class:`SdaRobot`, the host: it hands each message to the agent
  it is for, and learns its own slot from award messages.

A message between agents on different robots travels hop by hop through the simulator,
every hop with its own latency and loss; two agents on one robot talk without a
transmission.  A task that can never be staffed (it needs more robots of a service than
have it, or more robots in all than have one of its services: the tasks
:class:`heuristics._auction.BundleFinder` prunes) has an agent that ends at once, and no
service agent waits for it.

Wages
-----
A robot's wage after ``d`` decrements is ``max(0, w0 - d eps)``, ``w0 = u_max + eps``,
an exact :class:`fractions.Fraction`; ``D = ceil(w0 / eps)`` decrements bring it to 0.
Under ``max-wage`` each round decrements the unsold robot with the highest wage, ties to
the lowest index: the unsold robots are decremented round-robin in index order, so at any
time a prefix of them (in index order) is at some level ``c`` and the others at ``c - 1``.
A round's *announcement*, "robot ``b`` now has level ``c``", therefore gives every wage:
unsold robots with index ``<= b`` are at level ``c``, the others at ``c - 1`` (all at
``c`` when none is above ``b``).  Between two adjacent levels a cheapest bundle costs
``k lo + (hi - lo) h``, ``h`` the fewest high-wage robots of a complete bundle, found
exactly as the centralized engine finds it: the same 0/1 weights and the same
:meth:`heuristics._auction.BundleFinder.cheapest`, hence the same bundle.

A round
-------
Service agent ``s`` runs rounds ``t = 1, 2, ...``:

1. *Start.*  It applies round ``t``'s wage decrement to its replica and sends each
   active home task an ``Announce``: round ``t``, the decremented robot and its level,
   and the sales (robot, task) of the award rounds that task has not acknowledged --
   normally those of round ``t - 1``.  A home task staffed in an earlier round gets the
   announcement too, until it answers one.
2. *Answers.*  A task agent applies the sales to its view (learning from them whether it
   is staffed), prices its cheapest complete bundle of unsold robots at the announced
   wages and answers its home: ``Bid`` (the bundle's robots and services) when the cost
   is ``<= u_j``, ``NoBid`` otherwise, or ``Withdraw`` -- a no-bid for this round and
   every later one -- when its view has no complete bundle left (the unsold set only
   shrinks, so none comes back).  An answer to round ``t`` acknowledges the sales up to
   round ``t - 1``.  The matching is skipped when the cost provably cannot be
   affordable: always while ``k lo > u_j``, and otherwise unless ``h0 - p`` is at most the
   largest affordable ``h``, with ``h0`` the last matching's ``h`` in this sweep (``k`` at
   a sweep's start or after a sale) and ``p`` the robots of the task's services whose
   wage dropped since (a bundle's ``h`` drops by at most one per such robot).  A round
   then costs a task two binary searches and a few integer comparisons.
3. *Digests.*  When every active home task has answered -- or ``T_digest`` after the
   round started -- the service agent sends one ``Digest`` (the bids it received, in task
   order; a missing answer is a no-bid) to every robot hosting another service agent.  It
   has *heard from every task agent* once it holds its own answers and the digests of all
   ``S - 1`` others.  A digest still missing ``T_round`` after the round started counts as
   no bids: the round is closed without it (with resends, see below, it is first asked
   for again).
4. *Award.*  It runs the centralized award procedure on the bids it holds, over its own
   replica: each bid is priced on the replica (a bid whose robots are not all unsold
   there, or that the replica's wages make unaffordable, is first recomputed on the
   replica); bids are awarded in order of decreasing surplus ``u_j - cost``, ties to the
   lowest task index; a bid whose bundle lost a robot to an earlier award of the round is
   recomputed on the remaining robots at the same wages and, if still affordable,
   re-enters the order with its new surplus.  For every robot sold whose slot's service
   is ``s``, service agent ``s`` sends that robot an ``Award``.  Unless it stops, the
   service agent then starts round ``t + 1`` at once.

Timeouts, in clock periods of the network (10 ms by default) and its diameter ``d_G``
(at least 1): ``T_digest = 2 d_G + 1`` and ``T_round = 3 d_G + 2`` (:data:`DIGEST_PERIODS`,
:data:`ROUND_PERIODS`).  With hop
latencies below a period, answers arrive within ``2 d_G`` periods of a round's start and
digests within ``3 d_G``; the timeouts only keep lost or late messages from stalling the
auction.  A message for a round its receiver has already closed is late and ignored; a
digest for a round the receiver has not reached yet is kept until it gets there.

Equivalence.  Identical inputs give identical awards.  In a run without loss and without
a timeout firing -- ``network="complete sync=true"``: no latency, no loss, lock-step
clocks; the whole auction then happens at simulated time 0 -- every replica and every
view is the centralized state at every round, every service agent runs the award
procedure on the same bids, and the run makes exactly the awards of
:func:`heuristics.sda`: the same rounds, iterations, trajectory and assignment (with or
without resends).  A lost answer (or announcement) delays that task's bid by a round in
every replica alike; a lost digest, or a digest late for its round, gives replicas that
disagree, and then conflicting awards: a service agent that missed a bid may sell its
robots to another task, and once the replicas hold different unsold sets their wages
differ too, so the disagreement spreads to later rounds.

Resends (optional)
------------------
``SdaProtocol(resend_tries=k)`` with ``k > 0`` (:data:`RESEND_TRIES` = 10 is a sound
value; the default is 0, the plain protocol above; ``simulate(mission, "sda", network,
options={"resend_tries": k})`` runs the variant) adds three
acknowledgements, each retried every ``T_resend = 2 d_G + 1`` clock periods
(:data:`RESEND_PERIODS`) at most ``k`` times, then given up:

- a digest still missing ``T_round`` after the round started is asked for (``Resend``,
  answered from the digests of the last four rounds, even by a stopped service agent);
  the round is closed without it only when the requests are used up;
- a robot answers every award it receives with an ``Ack``; an award not acknowledged is
  sent again;
- the final announcement is sent again to a task that has not answered it.

A round then lasts at most ``T_round + k T_resend``.  With resends, replicas disagree
only when a digest is lost ``k + 1`` times in a row (or comes later than that), and a
robot stays idle only when its award is; on lossy networks the runs then end with the
centralized utility far more often.  Without them, every lost digest carrying a bid and
every lost award costs utility -- the behaviour the seed reports for its distributed SDA.

Robots, double sales
--------------------
A robot performs the *first* award it receives.  A robot sold twice (by service agents
whose replicas disagree, or through late messages) keeps the first, and the task of the
second stays short.  A lost award (with resends: lost every time) leaves its robot idle
and its task short.

Termination
-----------
A service agent stops running rounds at the end of a round after which, on its replica,
every robot is sold, every task is staffed, or every unsold wage is 0 (at wage 0 every
task with a complete bundle could afford it, so the round's awards placed all that can be
placed) -- the centralized stopping rules, evaluated on its own replica.  It sends its
active and not yet acknowledged home tasks a final ``Announce`` and ends (with resends:
once its awards and final announcements are acknowledged or given up).  A task agent ends
when it learns it is staffed, when it receives the final announcement, or when it
withdraws; an ended task agent answers any announcement that still reaches it
(``Withdraw`` if it withdrew, ``NoBid`` otherwise), which is how its home knows it was
heard.  Task agents keep no timer: one whose final announcement is lost does not end, and
the run does not count as converged.  The simulated time a run reports includes the
service agents' last pending timers (at most ``T_round`` after the last message).

What the run reports (:meth:`SdaProtocol.outcome`):

- ``trajectory``: every award a robot received (a resent copy once), in the order
  received -- ties in arrival time by round, then by position in the round's award order,
  then robot -- as ``(iteration, robot, task, service)``, ``iteration`` the rank of the
  award's round among the rounds of the awards received; a robot sold twice appears
  twice (it performs its first row).  ``iterations``: the number of those rounds;
  ``rounds``: the most rounds a service agent ran.  Lock-step, all three equal the
  centralized run's.
- ``beliefs_agree``: every service agent ended with the same replica (who is sold to
  which task for which service).
- ``converged``: every agent ended, no robot received two awards, the replicas agree and
  every robot performs what they say (no award was lost), within the time limit.
- ``convergence_seconds``: when the last award was delivered (0 when none was) for a
  converged run, ``None`` otherwise.
- ``messages``, ``bytes``: the transmissions and their encoded sizes (the simulator's
  counts); ``proposals``: the bids sent.

Messages
--------
Little-endian, no padding; ``u8``/``u32``/``u64`` unsigned integers.  ``kind`` tells them
apart (:func:`decode_message` reads any of them back):

============  ====  ========================================================  ============
message       kind  layout                                                    bytes
============  ====  ========================================================  ============
Announce      1, 2  kind u8, round u64, task u32, level u64, robot u32,       29 + 8 e
                    e u32, then e sales (robot u32, task u32); kind 2: final
Bid           3     kind u8, round u64, task u32, k u32, then k entries       17 + 8 k
                    (robot u32, service u32)
NoBid         4     kind u8, round u64, task u32                              13
Withdraw      5     kind u8, round u64, task u32                              13
Digest        6     kind u8, round u64, sender service u32, b u32, then b     17 + sum of
                    bids (task u32, k u32, then k entries (robot u32,         (8 + 8 k)
                    service u32))
Award         7     kind u8, round u64, rank u32, robot u32, task u32,        25
                    service u32
Resend        8     kind u8, round u64, asking service u32, missing           17
                    service u32 (with resends only)
Ack           9     kind u8, round u64, robot u32, service u32 (with          17
                    resends only)
============  ====  ========================================================  ============

``rank`` is the award's position in the round's award order (the robots of one task in
index order).  Prices are never sent: every agent prices a bundle on its own replica or
view.

Cost.  A round costs ``m_a`` announcements and ``m_a`` answers (``m_a`` the active
tasks) and ``S (S - 1)`` digests when every service agent has a robot of its own; a
service agent does O(1) Python work per message outside award rounds, a task agent
O(log n) per round plus a matching only when the bound above lets one through; an award
round costs the centralized award procedure in every replica.

Examples
--------
>>> import cfopt
>>> from heuristics import sda
>>> from heuristics.simulate import simulate
>>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
>>> run = simulate(m, "sda", "complete sync=true", seed=0)
>>> run.assignment == sda(m).assignment, run.rounds, run.iterations
(True, 19, 2)
>>> run.network.converged, run.network.beliefs_agree
(True, True)
"""

from __future__ import annotations

import heapq
import math
import struct
from bisect import bisect_right
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, MissionError
from cfopt.checks import require_int
from heuristics._auction import BundleFinder, check_eps
from heuristics.agents.protocol import (
    Agent,
    AgentContext,
    Protocol,
    ProtocolOutcome,
    RunContext,
    RunEnd,
)

__all__ = [
    "DIGEST_PERIODS",
    "RESEND_PERIODS",
    "RESEND_TRIES",
    "ROUND_PERIODS",
    "Ack",
    "Announce",
    "Award",
    "Bid",
    "Digest",
    "NoBid",
    "Resend",
    "SdaProtocol",
    "SdaReport",
    "SdaRobot",
    "ServiceAgent",
    "TaskAgent",
    "Withdraw",
    "decode_message",
]

#: ``T_digest`` in clock periods, as ``(a, b)`` for ``a d_G + b``.
DIGEST_PERIODS = (2, 1)
#: ``T_round`` in clock periods, as ``(a, b)`` for ``a d_G + b``.
ROUND_PERIODS = (3, 2)
#: ``T_resend`` in clock periods, as ``(a, b)`` for ``a d_G + b``.
RESEND_PERIODS = (2, 1)
#: A sound ``resend_tries`` for :class:`SdaProtocol`: how many times a service agent asks
#: again for a digest it misses (then it closes the round without it), and resends an
#: award or a final announcement nobody acknowledged (then it gives up on it).
RESEND_TRIES = 10

ANNOUNCE, FINAL, BID, NO_BID, WITHDRAW, DIGEST, AWARD, RESEND, ACK = 1, 2, 3, 4, 5, 6, 7, 8, 9

_ANNOUNCE = struct.Struct("<BQIQII")  # kind, round, task, level, robot, sales
_PAIR = struct.Struct("<II")  # a sale (robot, task); a bid entry (robot, service); (task, k)
_BID = struct.Struct("<BQII")  # kind, round, task, k
_ANSWER = struct.Struct("<BQI")  # kind, round, task
_DIGEST = struct.Struct("<BQII")  # kind, round, sender, bids
_AWARD = struct.Struct("<BQIIII")  # kind, round, rank, robot, task, service
_RESEND = struct.Struct("<BQII")  # kind, round, sender, missing
_ACK = struct.Struct("<BQII")  # kind, round, robot, service
_U4 = np.dtype("<u4")
_MAX_LEVEL = 2**63
_SENT_KEPT = 4  # rounds of own digests a service agent keeps for resends

Sends = list[tuple[int, Any]]
Sales = tuple[tuple[int, int], ...]


def _entries(robots: npt.NDArray[np.int64], services: npt.NDArray[np.int64]) -> bytes:
    return np.column_stack((robots, services)).astype(_U4).tobytes()


def _shown(value: Any) -> Any:
    return value.tolist() if isinstance(value, np.ndarray) else value


class _Shown:
    """``repr`` as ``Kind(field=value, ...)`` over the fields in ``_fields``."""

    __slots__ = ()
    _fields: tuple[str, ...] = ()

    def __repr__(self) -> str:
        inner = ", ".join(f"{f}={_shown(getattr(self, f))!r}" for f in self._fields)
        return f"{type(self).__name__}({inner})"


# ----------------------------------------------------------------------------- messages
class Announce(_Shown):
    """A round's start, from a service agent to one of its home tasks (kind 1; 2: final).

    ``robot`` now has wage level ``level`` (see the module docstring for what that says
    about every wage); ``sales`` are ``(robot, task)`` pairs the task has not yet
    acknowledged.  The final announcement ends the auction for the task.  29 + 8 bytes
    per sale.
    """

    __slots__ = ("kind", "level", "robot", "round", "sales", "task")
    _fields = ("round", "task", "level", "robot", "sales", "final")

    def __init__(
        self, round: int, task: int, level: int, robot: int, sales: Sales = (), final: bool = False
    ) -> None:
        self.kind = FINAL if final else ANNOUNCE
        self.round, self.task, self.level, self.robot, self.sales = round, task, level, robot, sales

    @property
    def final(self) -> bool:
        return self.kind == FINAL

    def encode(self) -> bytes:
        head = _ANNOUNCE.pack(
            self.kind, self.round, self.task, self.level, self.robot, len(self.sales)
        )
        if not self.sales:
            return head
        return head + b"".join(_PAIR.pack(r, j) for r, j in self.sales)


class Bid(_Shown):
    """Task ``task`` bids for round ``round`` on a bundle: ``robots[i]`` performs
    ``services[i]``.  17 + 8 k bytes."""

    __slots__ = ("robots", "round", "services", "task")
    _fields = ("round", "task", "robots", "services")
    kind = BID

    def __init__(
        self,
        round: int,
        task: int,
        robots: npt.NDArray[np.int64],
        services: npt.NDArray[np.int64],
    ) -> None:
        self.round, self.task, self.robots, self.services = round, task, robots, services

    def encode(self) -> bytes:
        head = _BID.pack(BID, self.round, self.task, self.robots.size)
        return head + _entries(self.robots, self.services)


class NoBid(_Shown):
    """Task ``task`` does not bid in round ``round``.  13 bytes."""

    __slots__ = ("round", "task")
    _fields = ("round", "task")
    kind = NO_BID

    def __init__(self, round: int, task: int) -> None:
        self.round, self.task = round, task

    def encode(self) -> bytes:
        return _ANSWER.pack(self.kind, self.round, self.task)


class Withdraw(NoBid):
    """Task ``task`` has no complete bundle left: no bid in round ``round`` nor after.
    13 bytes."""

    __slots__ = ()
    kind = WITHDRAW


class Digest(_Shown):
    """Service agent ``sender``'s bids of round ``round``: ``bids`` is a tuple of
    ``(task, robots, services)``, in task order.  17 bytes plus 8 + 8 k per bid; the
    encoding is made once however many robots the digest is sent to."""

    __slots__ = ("_bytes", "bids", "round", "sender")
    _fields = ("round", "sender", "bids")
    kind = DIGEST

    def __init__(
        self,
        round: int,
        sender: int,
        bids: tuple[tuple[int, npt.NDArray[np.int64], npt.NDArray[np.int64]], ...] = (),
    ) -> None:
        self.round, self.sender, self.bids = round, sender, bids
        self._bytes: bytes | None = None

    def encode(self) -> bytes:
        if self._bytes is None:
            parts = [_DIGEST.pack(DIGEST, self.round, self.sender, len(self.bids))]
            for task, robots, services in self.bids:
                parts.append(_PAIR.pack(task, robots.size))
                parts.append(_entries(robots, services))
            self._bytes = b"".join(parts)
        return self._bytes


class Award(_Shown):
    """Robot ``robot`` is sold to ``task`` for ``service`` in round ``round``, the
    ``rank``-th robot of the round's award order; sent by service agent ``service``.
    25 bytes."""

    __slots__ = ("rank", "robot", "round", "service", "task")
    _fields = ("round", "rank", "robot", "task", "service")
    kind = AWARD

    def __init__(self, round: int, rank: int, robot: int, task: int, service: int) -> None:
        self.round, self.rank, self.robot, self.task, self.service = (
            round,
            rank,
            robot,
            task,
            service,
        )

    def encode(self) -> bytes:
        return _AWARD.pack(AWARD, self.round, self.rank, self.robot, self.task, self.service)


class Resend(_Shown):
    """Service agent ``sender`` misses service agent ``missing``'s digest of round
    ``round`` and asks for it again.  17 bytes."""

    __slots__ = ("missing", "round", "sender")
    _fields = ("round", "sender", "missing")
    kind = RESEND

    def __init__(self, round: int, sender: int, missing: int) -> None:
        self.round, self.sender, self.missing = round, sender, missing

    def encode(self) -> bytes:
        return _RESEND.pack(RESEND, self.round, self.sender, self.missing)


class Ack(_Shown):
    """Robot ``robot`` received service agent ``service``'s award of round ``round``.
    17 bytes."""

    __slots__ = ("robot", "round", "service")
    _fields = ("round", "robot", "service")
    kind = ACK

    def __init__(self, round: int, robot: int, service: int) -> None:
        self.round, self.robot, self.service = round, robot, service

    def encode(self) -> bytes:
        return _ACK.pack(ACK, self.round, self.robot, self.service)


Message = Announce | Bid | NoBid | Withdraw | Digest | Award | Resend | Ack


def _pairs(data: bytes, offset: int, count: int) -> npt.NDArray[np.int64]:
    flat = np.frombuffer(data, dtype=_U4, count=2 * count, offset=offset)
    return flat.astype(np.int64).reshape(count, 2)


def decode_message(data: bytes) -> Message:
    """The message :meth:`encode` made ``data`` from (the module docstring's layouts).

    Parameters
    ----------
    data : bytes

    Returns
    -------
    Announce, Bid, NoBid, Withdraw, Digest, Award, Resend or Ack

    Notes
    -----
    O(len(data)).  The MPI transport rebuilds what was sent with it; the simulator hands
    agents the objects.

    Examples
    --------
    >>> import numpy as np
    >>> bid = Bid(7, 2, np.array([4, 1]), np.array([0, 3]))
    >>> data = bid.encode()
    >>> len(data), decode_message(data).robots.tolist()
    (33, [4, 1])
    >>> a = decode_message(Announce(9, 1, 3, 5, ((4, 0),)).encode())
    >>> a.round, a.task, a.level, a.robot, a.sales, a.final
    (9, 1, 3, 5, ((4, 0),), False)
    """
    kind = data[0]
    if kind in (ANNOUNCE, FINAL):
        _, rnd, task, level, robot, count = _ANNOUNCE.unpack_from(data)
        pairs = _pairs(data, _ANNOUNCE.size, count)
        sales = tuple((int(r), int(j)) for r, j in pairs.tolist())
        return Announce(rnd, task, level, robot, sales, final=kind == FINAL)
    if kind == BID:
        _, rnd, task, k = _BID.unpack_from(data)
        pairs = _pairs(data, _BID.size, k)
        return Bid(rnd, task, pairs[:, 0].copy(), pairs[:, 1].copy())
    if kind in (NO_BID, WITHDRAW):
        _, rnd, task = _ANSWER.unpack_from(data)
        return (Withdraw if kind == WITHDRAW else NoBid)(rnd, task)
    if kind == DIGEST:
        _, rnd, sender, count = _DIGEST.unpack_from(data)
        offset = _DIGEST.size
        bids = []
        for _ in range(count):
            task, k = _PAIR.unpack_from(data, offset)
            pairs = _pairs(data, offset + _PAIR.size, k)
            bids.append((task, pairs[:, 0].copy(), pairs[:, 1].copy()))
            offset += _PAIR.size + 8 * k
        return Digest(rnd, sender, tuple(bids))
    if kind == AWARD:
        _, rnd, rank, robot, task, service = _AWARD.unpack(data)
        return Award(rnd, rank, robot, task, service)
    if kind == RESEND:
        _, rnd, sender, missing = _RESEND.unpack(data)
        return Resend(rnd, sender, missing)
    if kind == ACK:
        _, rnd, robot, service = _ACK.unpack(data)
        return Ack(rnd, robot, service)
    raise ValueError(f"not an SDA message: kind {kind}")


# ------------------------------------------------------------------------------ market
class _Market:
    """What every agent knows from the start: the mission, ``eps``, the wage schedule,
    the placement and the timeouts."""

    def __init__(
        self, mission: Mission, eps: Fraction, period_ns: int, diameter: int, resend_tries: int
    ) -> None:
        caps, reqs = mission.capabilities, mission.requirements
        self.resend_tries = resend_tries
        self.caps = caps
        self.n, self.m, self.S = mission.n_robots, mission.n_tasks, mission.n_services
        self.eps = eps
        self.u = [Fraction(float(x)) for x in mission.utilities.tolist()]
        self.w0 = (max(self.u) if self.u else Fraction(0)) + eps
        self.D = math.ceil(self.w0 / eps)
        if self.D >= _MAX_LEVEL:
            raise MissionError(
                f"eps: {eps} makes {self.D} wage levels; the messages carry levels as uint64"
            )
        active = self.n > 0 and self.m > 0
        self.finder = BundleFinder(caps, reqs) if active else None
        finder = self.finder
        self.k: list[int] = finder.k if finder is not None else []
        self.possible = finder.possible.tolist() if finder is not None else [False] * self.m
        self.a_star = [
            min(self.D, max(0, math.ceil((k * self.w0 - u) / (k * eps))))
            for k, u in zip(self.k, self.u, strict=False)
        ]
        d = max(1, int(diameter))
        self.t_digest = (DIGEST_PERIODS[0] * d + DIGEST_PERIODS[1]) * period_ns
        self.t_round = (ROUND_PERIODS[0] * d + ROUND_PERIODS[1]) * period_ns
        self.t_resend = (RESEND_PERIODS[0] * d + RESEND_PERIODS[1]) * period_ns
        n = max(self.n, 1)
        self.service_host = [s % n for s in range(self.S)]
        self.task_host = [(self.S + j) % n for j in range(self.m)]
        #: The service agents and the task agents robot i hosts, in index order.
        self.hosted: dict[int, tuple[list[int], list[int]]] = {}
        for s, robot in enumerate(self.service_host):
            self.hosted.setdefault(robot, ([], []))[0].append(s)
        for j, robot in enumerate(self.task_host):
            self.hosted.setdefault(robot, ([], []))[1].append(j)
        #: Where service agent s sends its digests: the robots hosting another one.
        self.digest_to = [
            sorted({h for x, h in enumerate(self.service_host) if x != s}) for s in range(self.S)
        ]

    def wage(self, level: int) -> Fraction:
        return max(Fraction(0), self.w0 - level * self.eps)

    def split(self, level: int, pos: int, q: int) -> tuple[int, int]:
        """``(a, r)``: the unsold robots at positions ``< r`` are at level ``a + 1``, the
        others at ``a``, given a prefix ``alive[:pos + 1]`` at ``level`` (``pos < 0``: none)
        and the rest at ``level - 1``."""
        if pos < 0:
            level, pos = level - 1, q - 1
        if pos >= q - 1:
            return level, 0
        return level - 1, pos + 1


def _cheapest(
    agent: ServiceAgent | TaskAgent,
    j: int,
    pools: list[npt.NDArray[np.int64]],
    weight: npt.NDArray[np.int64],
) -> Any:
    """The market's cheapest bundle of task ``j`` (:meth:`BundleFinder.cheapest`), its
    work counted to ``agent``."""
    finder = agent.mk.finder
    assert finder is not None
    before = finder.entries
    bundle = finder.cheapest(j, pools, weight)
    agent.work += finder.entries - before
    return bundle


# ------------------------------------------------------------------------ service agent
class ServiceAgent:
    """Service agent ``s``: a replica of the auction, rounds, digests and awards.

    Parameters
    ----------
    s : int
        The service type.
    market : _Market
        What every agent knows (built by :class:`SdaProtocol`).

    Attributes
    ----------
    round : int
        Rounds started.
    task_of, service_of : ndarray of int64, shape (n,)
        The replica's sales (-1: unsold).
    ended : bool
    late : int
        Answers and digests that came after their round was closed here.
    work : int
        Its bundle matchings' work (cost-matrix entries).

    Notes
    -----
    O(1) Python work per message outside award rounds; an award round runs the
    centralized award procedure (a matching per recomputed bid) and O(n S) numpy
    bookkeeping.  See the module docstring for the protocol.

    Examples
    --------
    One service, two robots, one task needing one robot (utility 3, so ``w0 = 4``):

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1]], [[1]], [3])
    >>> robots = SdaProtocol().agents(m)  # service agent 0 on robot 0, task agent 0 on 1
    >>> service = robots[0].services[0]
    >>> service.start(0)  # round 1: robot 0 down to level 1, wage 3
    [(1, Announce(round=1, task=0, level=1, robot=0, sales=(), final=False))]
    >>> sends = service.on_answer(0, Bid(1, 0, np.array([0]), np.array([0])))
    >>> sends[0]  # then the final announcement: every task is staffed
    (0, Award(round=1, rank=0, robot=0, task=0, service=0))
    >>> service.task_of.tolist(), service.auction_over, service.ended
    ([0, -1], True, True)
    """

    def __init__(self, s: int, market: _Market) -> None:
        mk = self.mk = market
        self.s = s
        n = mk.n
        self.alive: list[int] = list(range(n))
        self.alive_np = np.arange(n, dtype=np.int64)
        self.sold = np.zeros(n, dtype=bool)
        self.task_of = np.full(n, -1, dtype=np.int64)
        self.service_of = np.full(n, -1, dtype=np.int64)
        finder = mk.finder
        self.pools = [p.copy() for p in finder.robots_with] if finder is not None else []
        self.staffed = np.zeros(mk.m, dtype=bool)
        self.level, self.pos = 0, n - 1  # everyone at level 0
        self.round = 0
        home = [j for j in range(s, mk.m, max(mk.S, 1)) if mk.possible[j]]
        self.active: set[int] = set(home)
        self.notify: set[int] = set()  # staffed, has not answered since
        self.acked = dict.fromkeys(home, 0)
        self.log: list[tuple[int, Sales]] = []  # (round, sales) of award rounds
        self.pending: set[int] = set()
        self.bids: dict[int, Bid] = {}
        self.digests: dict[int, dict[int, Digest]] = {}
        self.digest_sent = False
        self.t1 = self.t2 = 0
        self.peers = len(mk.service_host) - 1
        self.peer_ids = [x for x in range(mk.S) if x != s]
        self.sent: dict[int, Digest] = {}  # the last digests sent, for resends
        self.tries = 0
        self.gave_up = 0
        self.auction_over = False
        #: Awards and final announcements not yet acknowledged: (AWARD, robot) or
        #: (FINAL, task) -> [robot to send to, message, when to resend, resends so far].
        self.unacked: dict[tuple[int, int], list[Any]] = {}
        self.given_up = {AWARD: 0, FINAL: 0}
        self.ended = False
        self.deadline: int | None = None
        self.late = self.work = 0

    # ------------------------------------------------------------------ events
    def start(self, now: int) -> Sends:
        out: Sends = []
        if self._done():
            self._end(now, out)
        else:
            self._start(now, out)
            self._progress(now, out)
        self._arm()
        return out

    def on_answer(self, now: int, msg: NoBid | Bid) -> Sends:
        j = msg.task
        if j in self.acked and msg.round - 1 > self.acked[j]:
            self.acked[j] = msg.round - 1
        self.notify.discard(j)
        if msg.kind == WITHDRAW:
            self.active.discard(j)
        if self.unacked and self.unacked.pop((FINAL, j), None) is not None:
            self._arm()
        if self.auction_over:
            return []
        if msg.round != self.round or self.digest_sent:
            self.late += 1
            return []
        if j in self.pending:
            self.pending.discard(j)
            if msg.kind == BID:
                self.bids[j] = msg  # type: ignore[assignment]
        out: Sends = []
        if not self.pending:
            self._progress(now, out)
            self._arm()
        return out

    def on_digest(self, now: int, msg: Digest) -> Sends:
        if self.auction_over or msg.round < self.round:
            self.late += 1
            return []
        got = self.digests.get(msg.round)
        if got is None:
            got = self.digests[msg.round] = {}
        got[msg.sender] = msg
        if msg.round != self.round or len(got) < self.peers or not self.digest_sent:
            return []
        out: Sends = []
        self._progress(now, out)
        self._arm()
        return out

    def on_resend(self, now: int, msg: Resend) -> Sends:
        """A peer misses this agent's digest of ``msg.round``: send it again if it was
        sent (ended agents too); a digest not sent yet will go out in due course."""
        digest = self.sent.get(msg.round)
        if digest is None:
            return []
        return [(self.mk.service_host[msg.sender], digest)]

    def on_ack(self, now: int, msg: Ack) -> Sends:
        held = self.unacked.get((AWARD, msg.robot))
        if held is not None and held[1].round == msg.round:
            del self.unacked[(AWARD, msg.robot)]
            self._arm()
        return []

    def on_timer(self, now: int) -> Sends:
        out: Sends = []
        if not self.auction_over:
            self._progress(now, out)
        if self.unacked:
            for key, held in list(self.unacked.items()):
                dest, message, due, tries = held
                if due > now:
                    continue
                if tries >= self.mk.resend_tries:  # given up: robot idle, task waiting
                    del self.unacked[key]
                    self.given_up[key[0]] += 1
                    continue
                held[2], held[3] = now + self.mk.t_resend, tries + 1
                out.append((dest, message))
        self._arm()
        return out

    # ------------------------------------------------------------------ rounds
    def _arm(self) -> None:
        deadline = None
        if not self.auction_over:
            deadline = self.t2 if self.digest_sent else self.t1
        if self.unacked:
            due = min(held[2] for held in self.unacked.values())
            deadline = due if deadline is None else min(deadline, due)
        self.deadline = deadline
        self.ended = self.auction_over and not self.unacked

    def _progress(self, now: int, out: Sends) -> None:
        while not self.auction_over:
            if not self.digest_sent:
                if self.pending and now < self.t1:
                    return
                self._send_digest(out)
            got = self.digests.get(self.round)
            if (len(got) if got else 0) < self.peers:
                if now < self.t2:
                    return
                if self.tries < self.mk.resend_tries:  # ask the missing peers again
                    self.tries += 1
                    self.t2 = now + self.mk.t_resend
                    hosts = self.mk.service_host
                    for x in self.peer_ids:
                        if got is None or x not in got:
                            out.append((hosts[x], Resend(self.round, self.s, x)))
                    return
                self.gave_up += 1
            self._close(now, out)
            if self.auction_over:
                return
            self._start(now, out)

    def _start(self, now: int, out: Sends) -> None:
        """Round ``round + 1``: the wage decrement, then the announcements."""
        if self.pos >= len(self.alive) - 1:  # everyone at ``level``: a new sweep
            self.level += 1
            self.pos = 0
        else:
            self.pos += 1
        self.round += 1
        robot = self.alive[self.pos]
        self.pending = set(self.active)
        self.bids = {}
        self.digest_sent = False
        self.tries = 0
        self.t1 = now + self.mk.t_digest
        self.t2 = now + self.mk.t_round
        self._announce(now, out, robot, final=False)

    def _announce(self, now: int, out: Sends, robot: int, *, final: bool) -> None:
        hosts = self.mk.task_host
        for j in sorted(self.active | self.notify):
            message = Announce(self.round, j, self.level, robot, self._sales(j), final)
            out.append((hosts[j], message))
            if final and self.mk.resend_tries > 0:
                self.unacked[(FINAL, j)] = [hosts[j], message, now + self.mk.t_resend, 0]

    def _sales(self, j: int) -> Sales:
        log = self.log
        acked = self.acked[j]
        if not log or log[-1][0] <= acked:
            return ()
        sales: list[tuple[int, int]] = []
        for rnd, entries in reversed(log):
            if rnd <= acked:
                break
            sales[:0] = entries
        return tuple(sales)

    def _send_digest(self, out: Sends) -> None:
        self.digest_sent = True
        if self.peers <= 0:
            return
        bids = tuple((j, b.robots, b.services) for j, b in sorted(self.bids.items()))
        digest = Digest(self.round, self.s, bids)
        self.sent[self.round] = digest
        self.sent.pop(self.round - _SENT_KEPT, None)
        for robot in self.mk.digest_to[self.s]:
            out.append((robot, digest))

    def _close(self, now: int, out: Sends) -> None:
        """Award the round's bids on the replica; stop or carry on."""
        rnd = self.round
        bids: dict[int, tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]] = {
            j: (b.robots, b.services) for j, b in self.bids.items()
        }
        got = self.digests.pop(rnd, None)
        if got:
            for sender in sorted(got):
                for j, robots, services in got[sender].bids:
                    bids.setdefault(j, (robots, services))
        for old in [r for r in self.digests if r < rnd]:
            del self.digests[old]
        if bids:
            awards = self._award(bids)
            if awards:
                self.log.append((rnd, tuple((r, j) for _, r, j, _ in awards)))
                due = now + self.mk.t_resend
                reliable = self.mk.resend_tries > 0
                for rank, robot, j, service in awards:
                    if service == self.s:
                        award = Award(rnd, rank, robot, j, service)
                        if reliable:
                            self.unacked[(AWARD, robot)] = [robot, award, due, 0]
                        out.append((robot, award))
                    if j in self.active:
                        self.active.discard(j)
                        self.notify.add(j)
        if self._done():
            self._end(now, out)

    def _done(self) -> bool:
        q = len(self.alive)
        if q == 0 or self.mk.m == 0 or bool(self.staffed.all()):
            return True
        return self.pos >= q - 1 and self.level >= self.mk.D  # every unsold wage is 0

    def _end(self, now: int, out: Sends) -> None:
        self.auction_over = True
        robot = self.alive[self.pos] if self.alive else 0
        self._announce(now, out, robot, final=True)

    def _weights(self) -> tuple[Fraction, Fraction, npt.NDArray[np.int64]]:
        mk = self.mk
        a, r = mk.split(self.level, self.pos, len(self.alive))
        hi, lo = mk.wage(a), mk.wage(a + 1)
        weight = np.zeros(mk.n, dtype=np.int64)
        if hi != lo:
            weight[self.alive_np[r:]] = 1
        return hi, lo, weight

    def _award(
        self, bids: dict[int, tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]]
    ) -> list[tuple[int, int, int, int]]:
        """The centralized award procedure on the replica: ``(rank, robot, task, service)``."""
        mk = self.mk
        finder, k, u = mk.finder, mk.k, mk.u
        assert finder is not None
        hi, lo, weight = self._weights()
        pools, sold, staffed = self.pools, self.sold, self.staffed
        heap: list[tuple[Fraction, int]] = []
        bundles: dict[int, tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]] = {}
        for j in sorted(bids):
            if staffed[j] or not mk.possible[j]:
                continue
            robots, services = bids[j]
            cost = None
            if robots.size == k[j] and not sold[robots].any():
                cost = k[j] * lo + (hi - lo) * int(weight[robots].sum())
            if cost is None or cost > u[j]:
                b = _cheapest(self, j, pools, weight)
                if b is None:
                    continue
                robots, services = b.robots, b.services
                cost = k[j] * lo + (hi - lo) * b.weight
                if cost > u[j]:
                    continue
            bundles[j] = (robots, services)
            heapq.heappush(heap, (cost - u[j], j))
        sold_round = np.zeros(mk.n, dtype=bool)
        awards: list[tuple[int, int, int, int]] = []
        while heap:
            _, j = heapq.heappop(heap)
            robots, services = bundles[j]
            if sold_round[robots].any():  # rejected: recompute on what is left
                b = _cheapest(self, j, pools, weight)
                if b is None:
                    continue
                cost = k[j] * lo + (hi - lo) * b.weight
                if cost <= u[j]:
                    bundles[j] = (b.robots, b.services)
                    heapq.heappush(heap, (cost - u[j], j))
                continue
            staffed[j] = True
            sold_round[robots] = True
            self.task_of[robots] = j
            self.service_of[robots] = services
            for r, s in sorted(zip(robots.tolist(), services.tolist(), strict=True)):
                awards.append((len(awards), r, j, s))
            for s in np.flatnonzero(mk.caps[robots].any(axis=0)).tolist():
                pools[s] = pools[s][~sold_round[pools[s]]]
        if awards:
            boundary = self.alive[self.pos]
            sold |= sold_round
            self.alive_np = self.alive_np[~sold_round[self.alive_np]]
            self.alive = self.alive_np.tolist()
            self.pos = bisect_right(self.alive, boundary) - 1
            if self.pos < 0:  # the whole prefix was sold: everyone left at level - 1
                self.level -= 1
                self.pos = len(self.alive) - 1
        return awards


# --------------------------------------------------------------------------- task agent
class TaskAgent:
    """Task agent ``j``: its view of the unsold robots and wages, and its answers.

    Parameters
    ----------
    j : int
        The task.
    market : _Market

    Attributes
    ----------
    bids : int
        Bids sent.
    staffed, withdrawn, ended : bool
    matchings : int
        Bundle matchings run (the skipped ones are the point of the bound).
    work : int
        Their work (cost-matrix entries).

    Notes
    -----
    A round costs O(log n) (two binary searches and integer comparisons) unless the bound
    of the module docstring lets a matching through; applying sales costs O(n + S n)
    numpy work.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1]], [[1]], [3])
    >>> task = SdaProtocol().agents(m)[1].tasks[0]  # its home is on robot 0
    >>> task.on_announce(0, Announce(1, 0, 1, 0))  # robot 0 at level 1: wage 3 <= 3
    [(0, Bid(round=1, task=0, robots=[0], services=[0]))]
    >>> task.on_announce(0, Announce(2, 0, 1, 1, sales=((0, 0),)))  # staffed: it ends
    [(0, NoBid(round=2, task=0))]
    >>> task.staffed, task.ended
    (True, True)
    """

    def __init__(self, j: int, market: _Market) -> None:
        mk = self.mk = market
        self.j = j
        self.home = mk.service_host[j % mk.S]
        n = mk.n
        self.k, self.u, self.a_star = mk.k[j], mk.u[j], mk.a_star[j]
        self.alive: list[int] = list(range(n))
        self.alive_np = np.arange(n, dtype=np.int64)
        self.sold = np.zeros(n, dtype=bool)
        finder = mk.finder
        assert finder is not None
        self.reach_np = finder.pool(j) if mk.possible[j] else np.zeros(0, dtype=np.int64)
        self.reach: list[int] = self.reach_np.tolist()
        self.pools: list[Any] = [None] * mk.S
        for s in finder.need[j].tolist():
            self.pools[s] = finder.robots_with[s]
        self.sweep: int | None = None  # the level a for which hmax, h0, p0 hold
        self.hmax = self.h0 = self.p0 = 0
        self.last_round = 0
        self.dead = False
        self.staffed = self.withdrawn = False
        self.ended = not mk.possible[j]
        self.bids = self.matchings = self.work = 0

    def start(self, now: int) -> Sends:
        return []

    def on_announce(self, now: int, msg: Announce) -> Sends:
        j = self.j
        if self.ended:  # acknowledge: the home resends until it hears from this task
            return [(self.home, (Withdraw if self.withdrawn else NoBid)(msg.round, j))]
        final = msg.kind == FINAL
        if msg.round <= self.last_round and not final:
            return []  # a late copy
        self.last_round = max(self.last_round, msg.round)
        if (msg.sales and self._apply(msg.sales)) or final:
            self._end()
            return [(self.home, NoBid(msg.round, j))]
        return [(self.home, self._answer(msg))]

    def _end(self) -> None:
        self.ended = True

    def _apply(self, sales: Sales) -> bool:
        """Apply sales to the view; True when they staff this task."""
        sold = self.sold
        fresh = []
        for robot, task in sales:
            if task == self.j:
                self.staffed = True
                return True
            if not sold[robot]:
                sold[robot] = True
                fresh.append(robot)
        if not fresh:
            return False
        self.alive_np = self.alive_np[~sold[self.alive_np]]
        self.alive = self.alive_np.tolist()
        self.sweep = None
        if not sold[self.reach_np].any():
            return False
        self.reach_np = self.reach_np[~sold[self.reach_np]]
        self.reach = self.reach_np.tolist()
        mk = self.mk
        finder = mk.finder
        assert finder is not None
        for s in finder.need[self.j].tolist():
            pool = self.pools[s]
            self.pools[s] = pool[~sold[pool]]
        self.matchings += 1
        if _cheapest(self, self.j, self.pools, np.zeros(mk.n, dtype=np.int64)) is None:
            self.dead = True
        return False

    def _answer(self, msg: Announce) -> NoBid | Bid:
        j, mk = self.j, self.mk
        alive = self.alive
        q = len(alive)
        if self.dead or q == 0:
            self.withdrawn = True
            self._end()
            return Withdraw(msg.round, j)
        a, r = mk.split(msg.level, bisect_right(alive, msg.robot) - 1, q)
        if a + 1 < self.a_star:  # k lo > u: no bundle is affordable
            return NoBid(msg.round, j)
        k = self.k
        if a != self.sweep:
            self.sweep = a
            if a >= mk.D:
                self.hmax = k
            else:
                lo = mk.wage(a + 1)
                self.hmax = int((self.u - k * lo) // (mk.wage(a) - lo))
            self.h0, self.p0 = k, 0
        p = bisect_right(self.reach, alive[r - 1]) if r else 0
        if self.h0 - (p - self.p0) > self.hmax:
            return NoBid(msg.round, j)
        weight = np.zeros(mk.n, dtype=np.int64)
        if a < mk.D:
            weight[self.alive_np[r:]] = 1
        finder = mk.finder
        assert finder is not None
        self.matchings += 1
        bundle = _cheapest(self, j, self.pools, weight)
        if bundle is None:
            self.dead = self.withdrawn = True
            self._end()
            return Withdraw(msg.round, j)
        self.h0, self.p0 = bundle.weight, p
        if bundle.weight > self.hmax:
            return NoBid(msg.round, j)
        self.bids += 1
        return Bid(msg.round, j, bundle.robots, bundle.services)


# -------------------------------------------------------------------------------- robot
class SdaRobot(Agent):
    """One robot: the host of the agents placed on it, and the performer of its award.

    Parameters
    ----------
    robot : int
    market : _Market

    Attributes
    ----------
    services : dict of int to ServiceAgent
    tasks : dict of int to TaskAgent
    awards : list of tuple
        Every award received, ``(arrival ns, round, rank, task, service)``, in order.
    wake_at : int or None
        The earliest timer of the hosted agents (the transport wakes the robot then).
    work : int
        The bundle matchings' work (cost-matrix entries) of the hosted agents.

    Notes
    -----
    Dispatch is O(1) per message (a digest: one call per hosted service agent).

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1]], [[1]], [3])
    >>> robot = SdaProtocol().agents(m)[0]
    >>> robot.receive(0, Award(1, 0, 0, 0, 0)), robot.performed_slot()
    ([], 0)
    >>> robot = SdaProtocol(resend_tries=RESEND_TRIES).agents(m)[0]  # acknowledged awards
    >>> robot.receive(0, Award(1, 0, 0, 0, 0))
    [(0, Ack(round=1, robot=0, service=0))]
    """

    clocked = False
    pairwise = False

    def __init__(self, robot: int, market: _Market) -> None:
        self.robot, self.mk = robot, market
        self.services: dict[int, ServiceAgent] = {}
        self.tasks: dict[int, TaskAgent] = {}
        self.agents: list[ServiceAgent | TaskAgent] = []
        self.timed: list[ServiceAgent] = []  # task agents keep no timer
        self.awards: list[tuple[int, int, int, int, int]] = []
        self.wake_at: int | None = None

    def host(self, agent: ServiceAgent | TaskAgent) -> None:
        if isinstance(agent, ServiceAgent):
            self.services[agent.s] = agent
            self.timed.append(agent)
        else:
            self.tasks[agent.j] = agent
        self.agents.append(agent)

    @property
    def ticks(self) -> int:
        """Rounds run by the service agents hosted here (the run's ``rounds``)."""
        return max((a.round for a in self.services.values()), default=0)

    @property
    def proposals(self) -> int:
        """Bids sent by the task agents hosted here."""
        return sum(t.bids for t in self.tasks.values())

    @property
    def ended(self) -> bool:
        return all(a.ended for a in self.agents)

    @property
    def work(self) -> int:  # type: ignore[override]
        """The bundle matchings' work of the agents hosted here (cost-matrix entries)."""
        return sum(a.work for a in self.agents)

    def _rearm(self) -> None:
        timed = self.timed
        if len(timed) == 1:
            self.wake_at = timed[0].deadline
        elif timed:
            times = [a.deadline for a in timed if a.deadline is not None]
            self.wake_at = min(times) if times else None

    def start(self, now: int) -> Sends:
        out: Sends = []
        for agent in self.agents:
            out += agent.start(now)
        self._rearm()
        return out

    def receive(self, now: int, msg: Message) -> Sends:
        kind = msg.kind
        if kind == AWARD:
            return self._awarded(now, msg)  # type: ignore[arg-type]
        if kind <= FINAL:
            out = self.tasks[msg.task].on_announce(now, msg)  # type: ignore[union-attr,arg-type]
        elif kind == DIGEST:
            out = []
            for s, agent in self.services.items():
                if s != msg.sender:  # type: ignore[union-attr]
                    out += agent.on_digest(now, msg)  # type: ignore[arg-type]
        elif kind == RESEND:
            out = self.services[msg.missing].on_resend(now, msg)  # type: ignore[union-attr,arg-type]
        elif kind == ACK:
            out = self.services[msg.service].on_ack(now, msg)  # type: ignore[union-attr,arg-type]
        else:
            home = msg.task % self.mk.S  # type: ignore[union-attr]
            out = self.services[home].on_answer(now, msg)  # type: ignore[arg-type]
        self._rearm()
        return out

    def _awarded(self, now: int, msg: Award) -> Sends:
        """Keep the award (a resent copy once) and acknowledge it."""
        if not any(
            a[1] == msg.round and a[3] == msg.task and a[4] == msg.service for a in self.awards
        ):
            self.awards.append((now, msg.round, msg.rank, msg.task, msg.service))
        if not self.mk.resend_tries:
            return []
        return [(self.mk.service_host[msg.service], Ack(msg.round, self.robot, msg.service))]

    def wake(self, now: int) -> Sends:
        out: Sends = []
        for agent in self.timed:
            if agent.deadline is not None and agent.deadline <= now:
                out += agent.on_timer(now)
        self._rearm()
        return out

    def performed_slot(self) -> int:
        """The slot ``task * S + service`` of the first award received, or -1."""
        if not self.awards:
            return -1
        _, _, _, task, service = self.awards[0]
        return task * max(self.mk.S, 1) + service


# ----------------------------------------------------------------------------- protocol
@dataclass(frozen=True)
class SdaReport:
    """What a robot tells the observer at the end of an SDA run.

    Attributes
    ----------
    awards : tuple
        :attr:`SdaRobot.awards`.
    replicas : tuple of (task_of, service_of)
        The final replica of every service agent it hosts (service order).
    ended : bool
        Every agent it hosts ended.
    """

    awards: tuple[tuple[int, int, int, int, int], ...]
    replicas: tuple[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]], ...]
    ended: bool


class SdaProtocol(Protocol):
    """SDA's agents for any transport (see the module docstring).

    Parameters
    ----------
    eps : float or Fraction, default 1
        The wage decrement, taken at its exact value.
    resend_tries : int, default 0
        Resends (module docstring): 0 for the plain protocol, the seed's; ``simulate(m,
        "sda", network, options={"resend_tries": RESEND_TRIES})`` runs the acknowledged
        variant.

    Notes
    -----
    :meth:`prepare` is O(n S + K m S) (the bundle finder); the agents of a robot start
    with the mission's pools, O((S + m) n S) for all of them; :meth:`outcome` O(awards
    log awards + S n).

    Examples
    --------
    >>> import cfopt
    >>> from heuristics.simulate import simulate
    >>> m = cfopt.generate_mission(robots=12, percent_tasks=25, service_types=3,
    ...                            services_per_robot=2, seed=4)
    >>> run = simulate(m, "sda", "complete latency=uniform:1ms:10ms", seed=0)
    >>> run.network.converged, run.assignment.utility(m) > 0
    (True, True)
    """

    name = "sda"

    def __init__(self, eps: float | Fraction = 1, resend_tries: int = 0) -> None:
        self.eps = check_eps(eps)
        self.resend_tries = require_int("resend_tries", resend_tries, minimum=0)

    def prepare(self, context: RunContext) -> _Market:
        return _Market(
            context.mission, self.eps, context.period_ns, context.diameter, self.resend_tries
        )

    def make_agent(self, context: AgentContext) -> SdaRobot:
        market: _Market = context.shared
        robot = SdaRobot(context.robot, market)
        services, tasks = market.hosted.get(context.robot, ((), ()))
        for s in services:
            robot.host(ServiceAgent(s, market))
        for j in tasks:
            robot.host(TaskAgent(j, market))
        return robot

    def agents(
        self, mission: Mission, period_ns: int = 10_000_000, diameter: int = 1
    ) -> list[SdaRobot]:
        """One :class:`SdaRobot` per robot, hosting the agents placed on it (outside any
        transport: for tests and tools).

        Parameters
        ----------
        mission : cfopt.Mission
        period_ns : int, default 10 ms
            The clock period the timeouts are counted in.
        diameter : int, default 1
            ``d_G``.

        Returns
        -------
        list of SdaRobot

        Notes
        -----
        O(n + (S + m) n S): every replica and view starts with the mission's pools.
        """
        context = RunContext(
            mission, "paper", 1, diameter, period_ns, hops=_one_hop, neighbours=_nobody
        )
        market = self.prepare(context)
        return [self.make_agent(context.for_robot(i, market)) for i in range(market.n)]

    def decode_message(self, data: bytes, context: RunContext) -> Message:
        return decode_message(data)

    def report(self, agent: SdaRobot) -> SdaReport:
        return SdaReport(
            tuple(agent.awards),
            tuple((a.task_of, a.service_of) for a in agent.services.values()),
            agent.ended,
        )

    def outcome(self, end: RunEnd) -> ProtocolOutcome:
        reports: tuple[SdaReport, ...] = end.reports
        rows = sorted(
            (at, rnd, rank, robot, task, service)
            for robot, report in enumerate(reports)
            for at, rnd, rank, task, service in report.awards
        )
        order = {rnd: i + 1 for i, rnd in enumerate(sorted({row[1] for row in rows}))}
        trajectory = [(order[rnd], r, task, service) for _, rnd, _, r, task, service in rows]
        replicas = [replica for report in reports for replica in report.replicas]
        agree = all(
            np.array_equal(task_of, replicas[0][0]) and np.array_equal(service_of, replicas[0][1])
            for task_of, service_of in replicas[1:]
        )
        twice = any(len(report.awards) > 1 for report in reports)
        delivered = True
        if replicas:
            task_of, service_of = replicas[0]
            S = max(end.context.mission.n_services, 1)
            wanted = np.where(task_of >= 0, task_of * S + service_of, -1)
            delivered = bool(np.array_equal(wanted, end.slots))
        ended = all(report.ended for report in reports)
        converged = ended and agree and delivered and not twice and not end.cut
        when = None
        if converged:
            when = max((row[0] for row in rows), default=0)
        return ProtocolOutcome(
            iterations=len(order),
            trajectory=trajectory,
            converged=bool(converged),
            beliefs_agree=bool(agree),
            convergence_ns=when,
            options=(
                ("eps", str(self.eps)),
                ("schedule", "max-wage"),
                ("resend_tries", self.resend_tries),
            ),
        )


def _one_hop(a: int, b: int) -> int:
    return 0 if a == b else 1


def _nobody(i: int) -> npt.NDArray[np.int64]:
    return np.zeros(0, dtype=np.int64)
