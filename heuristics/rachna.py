"""RACHNA_dt: the ascending auction with the dynamic threshold ``eps = 1/n``, the seed's
second auction baseline.

Sources.  RACHNA is the market-based coalition formation system of Vig and Adams (L. Vig,
J. A. Adams, "Market-based multi-robot coalition formation", Distributed Autonomous Robotic
Systems 7, 2006; also their "Coalition formation: from software agents to robots", J.
Intell. Robot. Syst. 50, 2007, and Vig's Vanderbilt dissertation "Multi-robot coalition
formation", 2006).  Only their abstracts and opening pages could be read here: RACHNA
allocates robots to tasks with a modified winner-determination algorithm for multi-unit
combinatorial auctions, in a utility-based framework, for competitive (non-cooperative)
settings.  The protocol itself is known from the seed's summary (§3.1, paragraphs on RACHNA
and RACHNA_dt, which cite Vig and Adams 2006 and Diehl and Adams' 2022 study of scalable
collectives, not available either):

* the auction is ascending: bids rise as it runs;
* the sellers are service agents, one per service type, each keeping the wages of all the
  robots having its service (the robots are the goods); the buyers are task agents, which
  bid for bundles of services (SDA, §3.1, uses the same buyers and sellers);
* a task agent wins a bundle when its bid is at least the robots' current wages plus one
  increment ``eps`` per robot; a task never bids more than its utility;
* RACHNA_dt takes ``eps = 1/n``, so the condition that ``k_j eps`` stay within ``u_j``
  depends on the mission, not on a fixed parameter, and coalitions of any size up to ``n``
  can form;
* its bidding rounds are synchronized and run on the task and service agents (§6), and
  its computation is O(m n^3 log n u_max) (§3.1): ``u_max / eps = n u_max`` wage levels,
  in each of which all ``m`` tasks search a bundle -- tasks bidding together, every round.

The seed states no termination rule, no rule between equal bids and no message format;
cfopt's choices are in :func:`rachna_dt`'s Notes.  ``schedule="simultaneous"`` (the
default) is the reading these facts support: every task bids on the same prices each round
and the service agents then settle the bids.  ``schedule="sequential"`` keeps cfopt 0.1's
earlier reading, in which the tasks act one after another within a round.
"""

from __future__ import annotations

import heapq
import math
import time
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_flow

from cfopt import Assignment, Mission, MissionError, require_mission
from cfopt.checks import SeedLike, require_int, require_seed
from heuristics._auction import (
    ENTRY_BYTES,
    HEADER_BYTES,
    BundleFinder,
    check_eps,
    check_order,
)
from heuristics._rachna_fast import LastBundles, Ledger, match_slots
from heuristics._run import NO_DEADLINE, Deadline, Run, seed_label
from heuristics.communication import comm_model, media_table, table_cost

__all__ = ["MAX_ROUNDS", "SCHEDULES", "rachna_dt"]

#: Bidding schedules of :func:`rachna_dt`: the faithful reading first (the default).
SCHEDULES = ("simultaneous", "sequential")
#: Default ``max_rounds`` of :func:`rachna_dt` (the seed's missions need at most a few
#: times ``10 n``; a bidding war lasts about ``u / eps`` purchases).
MAX_ROUNDS = 10**5
#: Jumps keep every wage (in units of eps) below this, so int64 never overflows.
_WAGE_CAP = 2**62
#: The first checkpoint round at which the engine tries to prove that more than
#: ``max_rounds`` rounds are needed (the seed's missions end long before).
_PROVE_FROM = 16
#: The most words (8 bytes each) the simultaneous engine's log of bids since the last
#: checkpoint may hold (:class:`_BidLog`): 32 MiB; a full log starts a new checkpoint.
_LOG_CELLS = 1 << 22


def rachna_dt(
    mission: Mission,
    *,
    eps: float | Fraction | None = None,
    seed: SeedLike = None,
    order: str = "index",
    schedule: str = "simultaneous",
    max_rounds: int = MAX_ROUNDS,
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
) -> Run:
    """Run RACHNA with dynamic threshold (centralized, synchronous rounds) on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    eps : float or Fraction, optional
        The wage increment; default exactly ``Fraction(1, n)`` (the dynamic threshold).
        A float is taken at its exact binary value.
    seed : None, int or numpy.random.Generator
        Recorded only: RACHNA_dt makes no random choice (every tie goes to the lowest index).
    order : {"index"}
        Accepted for the registry's common signature; ties go to the lowest index.
    schedule : {"simultaneous", "sequential"}, default "simultaneous"
        How the tasks bid within a round (see Notes): all on the round's opening prices,
        then the bids are awarded (the faithful reading), or one after another, each on the
        state the previous ones left (cfopt 0.1's reading).
    max_rounds : int, default MAX_ROUNDS (100000)
        The most rounds the auction may need; a run that needs more raises
        :class:`cfopt.MissionError` (see Notes, Termination).  The trajectory of a run has
        at least ``rounds - 1`` rows, so this also bounds its memory.

    medium : {"broadcast", "unicast"}, default "broadcast"
        How ``messages`` and ``bytes`` count a service agent's price announcement to the
        tasks needing its service: one transmission, or one message per task (Notes,
        Counting; :mod:`heuristics.communication`).
    encoding : {"full", "compact"}, default "full"
        Accepted and recorded for the common signature: the encoding is that of beliefs
        (partitions), and RACHNA_dt sends none, so both give the same counts.

    time_limit : float, optional
        Wall-clock seconds after which no further bidding round starts; the run then
        returns the holdings reached, ``status`` ``TIME_LIMIT``.

    Returns
    -------
    Run
        ``algorithm="rachna-dt"``; ``iterations`` = rounds with at least one purchase;
        ``trajectory`` one row ``(iteration, robot, task, service)`` per robot that changes
        hands (``task = service = -1``: released); ``options`` records ``eps``,
        ``schedule``, ``order``, ``medium`` and ``encoding``; ``communication`` the counts
        under every model.

    Raises
    ------
    cfopt.MissionError
        For a bad argument, and ``eps: ...`` when the auction needs more than
        ``max_rounds`` rounds; the message gives an ``eps`` that bounds the rounds.

    Notes
    -----
    Prices.  Wages are whole multiples of ``eps``, kept as integers (units of ``eps``), all
    0 at the start; a task's utility ``u[j]`` becomes the integer budget
    ``floor(u[j] / eps)`` (exact, with fractions and Python integers of any size), so every
    comparison is exact.  A task bidding prices every robot at ``wage + eps``: a task that
    is not fully staffed holds no robot (it released them all when it lost one), so it must
    outbid the current employer of any robot it wants, and free robots are priced the same
    way (choice; the seed's award rule adds one ``eps`` per robot of the bundle).  It finds
    its cheapest complete bundle among *all* robots having the services (free or held); if
    the bundle costs ``<= u[j]`` it bids for all of it.  Tie-break (choice): among bundles
    of equal cost, fewest robots held by other tasks, then the least sum of robot indices
    (see :mod:`heuristics._auction`).  Every robot a task buys then earns ``wage + eps``.
    A task that loses a robot is no longer staffed and releases its other robots, whose
    wages are kept.  A task that cannot afford its cheapest bundle, or has none, never bids
    again: wages never fall, so its cheapest cost never falls; the engine skips it (its
    work is still counted).  A task that can never be staffed (it needs more robots of a
    service than have it, or more robots in all than have one of its services) is pruned
    before the first round: never searched, and counted as the literal auction counts it
    (it searches, finds no bundle and gives up in round 1).  The auction stops after a
    round in which no task bid (that quiet round is counted).

    Simultaneous schedule (the default).  A round: every task that is neither staffed nor
    given up searches its cheapest bundle on the wages and holdings of the round's opening
    and bids if it can afford it -- all bids are made on the same prices.  The service
    agents then settle: the bids are taken in task-index order, and a bid wins when none of
    its robots went to an earlier bid of the round; a bundle is all or nothing (choice: two
    bids for one robot both offer its ``wage + eps``, a tie, broken like every tie by the
    lowest index).  So each robot is sold at most once a round, its wage rises by at most
    one unit a round, and the first bid always wins.  A bid that lost is made again, on the
    new prices, next round; a task robbed of a robot bids next round too.  Which slot a
    robot fills in a bundle is fixed by the robot set alone (it changes no price).

    Sequential schedule.  A round: the tasks that are not fully staffed act one after
    another in index order, each on the state left by the previous ones (no conflicting
    bids to settle); a task acting takes its whole bundle at once.  A task that loses a
    robot acts again in the same round if its index is after the acting task, otherwise
    in the next (so a task acts at most once per round).  A robot may change hands several
    times in one round.

    Termination.  Every purchase raises a wage by one unit, every bidding round has one,
    and no wage exceeds ``floor(u_max / eps)`` units (a robot is bought at ``wage + 1 <=
    budget``), so ``rounds <= n floor(u_max / eps) + 1``; with the default ``eps = 1/n``
    and integer utilities that is ``n^2 u_max + 1``.  Rounds grow with ``u / eps`` when
    tasks compete for too few robots (a bidding war ends only when a budget runs out: two
    tasks alone on one robot take about ``2 min(budget)`` simultaneous rounds, half as many
    sequential ones), and every round but the last adds trajectory rows, so the engine
    cannot skip them; with Brent's cycle detection on the state at the end of a round
    (holders, services, given-up tasks) it

    * adds repeating rounds at once when that state equals the last checkpoint's but for
      the wages, raised by ``delta``.  Sequential: when ``delta`` is one constant ``c_j``
      over all robots having a service of each task ``j`` that bought in between, every
      bundle search of the next period sees its cost matrix shifted by a constant and makes
      the same choice, for as long as every purchase price ``p`` stays within its budget:
      ``L = min (budget_j - p) // (k_j c_j)`` more periods.  Simultaneous: period ``l``
      (the period just run is period 0) repeats period 0 exactly if every bid of its rounds
      is again its task's cheapest bundle, and affordable, on that round's opening wages
      ``w + l delta`` -- then the same bids meet the same holdings and win or lose alike.
      For a bid ``B`` and any bundle ``B'`` the cost difference changes linearly in ``l``
      (``delta >= 0``), so the ``l`` at which ``B`` stays cheapest form an interval from 0;
      so do those at which its price stays within budget.  The engine takes the bound the
      budgets allow, replays the period there with real bundle searches and, if some bid
      changes, bisects.  (Bundles tied in cost, flags and index sum could in principle
      break the interval; their keys are then equal and the choice among them is the
      matching's.)  The periods are added in one step: wages, counts, and the trajectory
      rows with shifted iterations.  To replay a period the simultaneous engine logs which
      tasks bid in each of its rounds (one word a bid, one a round; the replay of period
      0 finds the bids again on the checkpoint's state), and Brent's span doubles, so on
      a long war with many tasks bidding the log would outgrow the trajectory (up to
      ``m`` bids a round against a few rows).  It is bounded (choice): when it holds 2^22
      words (32 MiB) the engine takes a new checkpoint at once, without doubling the
      span.  The trade-off: a cycle whose period holds more bids than that is never
      detected (its rounds are run one by one, with the same results), and the proof
      below is tried at every such checkpoint (a maximum flow and, when it fails, one
      bundle search per task not staffed), so once per 2^22 bids at most;
    * proves early that more than ``max_rounds`` rounds are needed, at every checkpoint
      from round 16 on (rounds 16, 32, 64, ... and after each jump): if the tasks not
      given up cannot all be staffed at once (a maximum flow from the robots to the
      services they demand), the auction cannot end before one of them gives up, and a
      task ``j`` that holds or can buy a bundle ``B`` at price ``p_j`` units cannot give
      up within ``(budget_j - p_j) // g_j`` rounds, where ``g_j`` bounds the rise of
      ``B``'s price per round: ``k_j`` simultaneous (each robot is sold at most once a
      round), the sum over ``B`` of the tasks that can buy each robot sequential;
    * raises :class:`cfopt.MissionError` (``eps: ...``, naming an ``eps`` with ``n
      floor(u_max / eps) + 1 <= max_rounds``) when such a proof, a jump or the round
      count passes ``max_rounds``.  A war that does not repeat and cannot be proven long
      is run round by round up to ``max_rounds``.

    Counting.  Messages go between task agents and service agents (header 8 bytes, entries
    12 bytes).  A task that bids sends one message to each service agent of its needed
    services (``r_js`` entries) and gets an answer from each (header only), whether it wins
    or not (simultaneous).  After purchases, every service agent with a robot whose wage or
    holder changed (the robots bought and the robots their losers released) tells every
    task needing its service, one entry per changed robot: once per round, to all those
    tasks (simultaneous), or after each purchase, to all but the buyer (sequential).  A
    task that lost a robot sends a release to the service agent of each service its
    released robots performed (one entry per robot).  A task that does not bid sends
    nothing.  These are ``medium="unicast"``'s counts; under ``"broadcast"`` (the default)
    a price announcement is one transmission per service agent that has receivers, and
    every other message (bids, answers, releases: addressed to one agent) counts the same.
    ``work`` counts cost-matrix entries of the bundle searches the literal
    auction performs: every task not staffed (given-up and pruned ones included) searches
    once each round (sequential: each time it acts), ``(robots having one of its services)
    x k_j`` entries.

    Complexity.  Simultaneous, as the literal engine runs it: per round simulated, one
    O(n log n) sort of the robots by (wage, flag, index), then per bidding task O(n) to
    rank its pool and O(k_j |S_j|) to take the cheapest robots -- exact when they can
    fill its slots or when each service's cheapest robots are disjoint, otherwise one
    matching on at most ``k_j |S_j|`` candidates; each jump costs O(log(u_max / eps))
    replays of a period.  The default engine keeps the sorted robots from round to round
    (:mod:`heuristics._rachna_fast`) and settles a bid without a search when it must lose:
    for each service ``s`` a task needs ``r_s`` times, the ``r_s`` robots of least
    (wage, flag, index) having ``s`` are in every cheapest bundle of that task (were one
    out, exchanging it for a robot filling an ``s`` slot would give a cheaper bundle), so
    a task one of whose such robots went to an earlier winner of the round loses, and it
    bids (does not give up) when a bundle it found before still fits its budget.  A
    round then costs O(m (S + max k_j)) in bulk, a search per bid that may win or give
    up, and a walk of the cheapest keys per win; in a war among many tasks most bids
    lose to the round's first winners.  Sequential: per round, one matching per acting
    task.  Both: O(n + m) per round for the cycle detection and O(m M + n S) at each of
    the O(log rounds) checkpoints.  The rounds simulated are at
    most ``max_rounds``; on the seed's missions, sequential runs end in 2-3 rounds and
    simultaneous ones take about one round per conflict of the first bids (up to ``m + 1``
    rounds: every task first wants the same cheapest robots); see
    ``benchmarks/bench_auctions.py``.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    >>> run = rachna_dt(m)   # both tasks bid for robot 0 in round 1, task 0 wins the tie;
    >>> run.trajectory.tolist()  # task 1 (only robot 0 has service 1) outbids it in round 2
    [[1, 0, 0, 0], [2, 0, 1, 1], [3, 1, 0, 0]]
    >>> run.assignment.task.tolist(), run.iterations, run.rounds
    ([1, 0], 3, 4)
    >>> seq = rachna_dt(m, schedule="sequential")  # task 1 outbids task 0 in round 1
    >>> seq.trajectory.tolist(), seq.rounds
    ([[1, 0, 0, 0], [1, 0, 1, 1], [2, 1, 0, 0]], 3)

    Two tasks bidding for one robot: a war of about ``2 u / eps`` rounds, jumped over.

    >>> war = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1e4, 2e4])
    >>> run = rachna_dt(war, eps=1)
    >>> run.rounds, len(run.trajectory), run.assignment.task.tolist()
    (10001, 10000, [1])
    >>> rachna_dt(war, eps=1, schedule="sequential").rounds
    5001
    >>> rachna_dt(war, eps=1, max_rounds=1000)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: eps: RACHNA_dt needs more than max_rounds=1000 rounds ...
    """
    started = time.perf_counter()
    deadline = Deadline(time_limit, started=started)
    require_mission(mission)
    n = mission.n_robots
    eps_q = Fraction(1, max(n, 1)) if eps is None else check_eps(eps)
    check_order(order)
    if schedule not in SCHEDULES:
        raise MissionError(f"schedule: must be one of {', '.join(SCHEDULES)}, got {schedule!r}")
    max_rounds = require_int("max_rounds", max_rounds, minimum=1)
    comm = comm_model(medium, encoding)
    require_seed("seed", seed)  # RACHNA_dt draws nothing
    out = _core(mission, eps_q, max_rounds, schedule=schedule, deadline=deadline)
    table = media_table((out.messages, out.bytes), (out.cast_messages, out.cast_bytes))
    messages, nbytes = table_cost(table, comm)
    return Run(
        algorithm="rachna-dt",
        assignment=Assignment(task=out.task, service=out.service),
        iterations=out.iterations,
        rounds=out.rounds,
        messages=messages,
        bytes=nbytes,
        work=out.work,
        seconds=time.perf_counter() - started,
        seed=seed_label(seed),
        trajectory=out.moves.array(),
        options=(("eps", str(eps_q)), ("schedule", schedule), ("order", order), *comm.options),
        communication=table,
        status=deadline.status,
    )


class _Moves:
    """Trajectory rows, appended as small arrays; runs of small arrays are merged."""

    def __init__(self) -> None:
        self.parts: list[npt.NDArray[np.int64]] = []
        self.count = 0
        self._small = 0  # parts appended since the last merge

    def add(self, rows: npt.NDArray[np.int64]) -> None:
        self.parts.append(rows)
        self.count += rows.shape[0]
        self._small += 1
        if self._small > 4096:
            tail = self.parts[-self._small :]
            del self.parts[-self._small :]
            self.parts.append(np.concatenate(tail))
            self._small = 0

    def since(self, count: int) -> npt.NDArray[np.int64]:
        """The rows added after the first ``count`` (O(rows returned + parts walked))."""
        want, got, pieces = self.count - count, 0, []
        for part in reversed(self.parts):
            if got >= want:
                break
            pieces.append(part)
            got += part.shape[0]
        if not pieces:
            return np.zeros((0, 4), dtype=np.int64)
        rows = np.concatenate(pieces[::-1])
        return rows[rows.shape[0] - want :]

    def array(self) -> npt.NDArray[np.int64]:
        """All rows, in order."""
        if not self.parts:
            return np.zeros((0, 4), dtype=np.int64)
        return np.concatenate(self.parts)


@dataclass
class _Outcome:
    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    iterations: int = 0
    rounds: int = 0
    messages: int = 0  # medium="unicast": one message per receiver
    bytes: int = 0
    work: int = 0
    moves: _Moves = field(default_factory=_Moves)
    cast_messages: int = 0  # medium="broadcast": one transmission per announcement
    cast_bytes: int = 0

    def counts(self) -> tuple[int, int, int, int, int, int, int]:
        return (
            self.iterations,
            self.messages,
            self.bytes,
            self.work,
            self.moves.count,
            self.cast_messages,
            self.cast_bytes,
        )

    def direct(self, messages: int, nbytes: int) -> None:
        """Messages to one agent: the same under both media."""
        self.messages += messages
        self.bytes += nbytes
        self.cast_messages += messages
        self.cast_bytes += nbytes

    def announce(self, receivers: npt.NDArray[np.int64], entries: npt.NDArray[np.int64]) -> None:
        """Each service agent ``s`` with ``entries[s] > 0`` changed robots tells its
        ``receivers[s]`` tasks: that many messages unicast, one transmission broadcast."""
        size = HEADER_BYTES + ENTRY_BYTES * entries
        has = entries > 0
        self.messages += int(receivers[has].sum())
        self.bytes += int((receivers * size)[has].sum())
        sent = has & (receivers > 0)
        self.cast_messages += int(sent.sum())
        self.cast_bytes += int(size[sent].sum())


@dataclass
class _Checkpoint:
    """The state at the end of round ``rounds`` (cycle detection, see :func:`rachna_dt`)."""

    rounds: int
    holder: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    dead: npt.NDArray[np.bool_]
    wage: npt.NDArray[np.int64]
    counts: tuple[int, int, int, int, int, int, int]

    def same_but_wages(self, out: _Outcome, dead: npt.NDArray[np.bool_]) -> bool:
        """Whether the holders, services and given-up tasks are again this checkpoint's
        (the wages may have risen).  O(n + m)."""
        return (
            np.array_equal(out.task, self.holder)
            and np.array_equal(out.service, self.service)
            and np.array_equal(dead, self.dead)
        )


@dataclass(frozen=True)
class _Holdings:
    """The arrays the rounds update in place that a checkpoint reads: the wages (units of
    eps), each task's robots, which tasks are staffed and which gave up (``dead``)."""

    wage: npt.NDArray[np.int64]
    members: list[npt.NDArray[np.int64]]
    staffed: npt.NDArray[np.bool_]
    dead: npt.NDArray[np.bool_]


@dataclass(frozen=True)
class _RoundLimit:
    """What bounds the rounds of one run: ``max_rounds``, what proves that the run needs
    more (:func:`_rounds_left`) and the error that says so (:meth:`too_many`).

    ``once``: a robot is sold at most once a round (the simultaneous schedule), so its
    wage rises by at most one unit a round; otherwise (sequential) by at most one unit per
    task that can buy it.
    """

    max_rounds: int
    eps: Fraction
    utilities: list[Fraction]
    finder: BundleFinder
    caps64: npt.NDArray[np.int64]
    reqs: npt.NDArray[np.int64]
    budget: list[int]
    once: bool

    def too_many(self) -> MissionError:
        """The error for a run that needs more than ``max_rounds`` rounds."""
        u_max = max(self.utilities, default=Fraction(0))
        return _too_many_rounds(self.max_rounds, self.finder.n, u_max, self.eps)


def _checkpoint(
    out: _Outcome,
    holdings: _Holdings,
    limit: _RoundLimit,
    price: Callable[[int], int] | None = None,
) -> _Checkpoint:
    """The state at the end of round ``out.rounds``, for Brent's cycle detection.

    From round ``_PROVE_FROM`` on it first tries to prove that the run needs more than
    ``limit.max_rounds`` rounds, and raises :meth:`_RoundLimit.too_many` if so (see
    :func:`rachna_dt` Notes, Termination); ``price`` as in :func:`_rounds_left`.  O(n +
    m), plus :func:`_rounds_left`.
    """
    if out.rounds >= _PROVE_FROM:
        rest = _rounds_left(limit, holdings, price)
        if rest is not None and out.rounds + rest > limit.max_rounds:
            raise limit.too_many()
    return _Checkpoint(
        out.rounds,
        out.task.copy(),
        out.service.copy(),
        holdings.dead.copy(),
        holdings.wage.copy(),
        out.counts(),
    )


def _core(
    mission: Mission,
    eps: Fraction,
    max_rounds: int,
    jump: bool = True,
    schedule: str = "simultaneous",
    fast: bool = True,
    deadline: Deadline = NO_DEADLINE,
) -> _Outcome:
    """The auction rounds of ``schedule``; see :func:`rachna_dt` Notes for the method.

    ``jump=False`` turns the jump over repeating rounds off; ``fast=False`` runs the
    simultaneous rounds on the literal price book (one sort of the robots and one search
    per bidding task every round) instead of :class:`heuristics._rachna_fast.Ledger`
    (the tests compare all of them).  Complexity as :func:`rachna_dt`.  ``deadline`` is
    checked before each round: once reached, the rounds stop with the holdings reached.
    """
    if schedule == "simultaneous":
        return _simultaneous(mission, eps, max_rounds, jump, fast, deadline)
    return _sequential(mission, eps, max_rounds, jump, deadline)


def _market(mission: Mission, eps: Fraction) -> tuple[Any, ...]:
    """What both schedules derive from the mission before the first round: capabilities,
    requirements, ``n``, ``m``, the bundle finder, exact utilities, integer budgets (units
    of ``eps``), int64 copies of the needs and capabilities, the tasks needing each
    service and each task's matching work per search."""
    caps, reqs = mission.capabilities, mission.requirements
    finder = BundleFinder(caps, reqs)
    utilities = [Fraction(float(x)) for x in mission.utilities.tolist()]
    budget = [math.floor(x / eps) for x in utilities]
    need64 = (reqs > 0).astype(np.int64)
    m_s = need64.sum(axis=0)
    match_work = [int(r) * kj for r, kj in zip(finder.reach.tolist(), finder.k, strict=True)]
    return (
        caps, reqs, caps.shape[0], reqs.shape[0], finder, utilities, budget, need64,
        caps.astype(np.int64), m_s, match_work,
    )  # fmt: skip


def _sequential(
    mission: Mission,
    eps: Fraction,
    max_rounds: int,
    jump: bool,
    deadline: Deadline = NO_DEADLINE,
) -> _Outcome:
    """The sequential reading (tasks act one after another); see :func:`rachna_dt`."""
    _, reqs, n, m, finder, utilities, budget, need64, caps64, m_s, match_work = _market(
        mission, eps
    )
    k = finder.k
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    wage = np.zeros(n, dtype=np.int64)  # units of eps
    held = np.zeros(n, dtype=np.int64)  # 1 when some task holds the robot
    holder = out.task  # shared: the assignment is the holder map
    members: list[npt.NDArray[np.int64]] = [np.zeros(0, dtype=np.int64) for _ in range(m)]
    staffed = np.zeros(m, dtype=bool)
    dead = ~finder.possible  # pruned: never staffable, never searched
    dead_work = sum(match_work[j] for j in np.flatnonzero(dead).tolist())
    pools = finder.robots_with
    next_round = list(range(m))
    holdings = _Holdings(wage, members, staffed, dead)
    limit = _RoundLimit(max_rounds, eps, utilities, finder, caps64, reqs, budget, once=False)

    # Brent's cycle detection on the state at the end of a round; ``log`` holds the
    # purchases (task, price in units) made since the checkpoint.
    check = _checkpoint(out, holdings, limit)
    span = 1
    log: list[tuple[int, int]] = []
    while not deadline.reached():
        if out.rounds >= max_rounds:
            raise limit.too_many()
        out.rounds += 1
        out.work += dead_work
        acted = False
        current = next_round
        heapq.heapify(current)
        next_round = []
        queued = set(current)
        while current:
            j = heapq.heappop(current)
            queued.discard(j)
            if staffed[j] or dead[j]:
                continue
            out.work += match_work[j]
            b = finder.cheapest(j, pools, wage, held)
            if b is None or int(b.weight) + k[j] > budget[j]:
                dead[j] = True
                dead_work += match_work[j]
                continue
            log.append((j, int(b.weight) + k[j]))
            if not acted:
                acted = True
                out.iterations += 1
            it = out.iterations
            robots = b.robots
            losers = sorted(set(holder[robots].tolist()) - {-1})
            released_parts = []
            for loser in losers:
                mem = members[loser]
                rel = mem[holder[mem] == loser]
                rel = rel[~np.isin(rel, robots)]
                # release message: one per service the released robots performed
                if rel.size:
                    performed = int(np.unique(out.service[rel]).size)
                    out.direct(performed, performed * HEADER_BYTES + ENTRY_BYTES * rel.size)
                    holder[rel] = -1
                    out.service[rel] = -1
                    held[rel] = 0
                    out.moves.add(_rows(it, rel, -1, -1))
                    released_parts.append(rel)
                members[loser] = np.zeros(0, dtype=np.int64)
                staffed[loser] = False
                if loser > j:
                    if loser not in queued:
                        heapq.heappush(current, loser)
                        queued.add(loser)
                else:
                    next_round.append(loser)
            wage[robots] += 1
            held[robots] = 1
            holder[robots] = j
            out.service[robots] = b.services
            members[j] = robots
            staffed[j] = True
            by_robot = np.argsort(robots, kind="stable")
            out.moves.add(_rows(it, robots[by_robot], j, b.services[by_robot]))
            # bid, answers
            counts = finder.counts[j]
            out.direct(2 * len(counts), 2 * len(counts) * HEADER_BYTES + ENTRY_BYTES * sum(counts))
            # notices about changed robots to every other task needing the service
            changed = np.concatenate([robots, *released_parts]) if released_parts else robots
            out.announce(m_s - need64[j], caps64[changed].sum(axis=0))
        if not acted:
            break
        # every unstaffed live task acts next round (those robbed late were queued above)
        live = {j for j in range(m) if not staffed[j] and not dead[j]}
        next_round = sorted(set(next_round) | live)
        if jump and check.same_but_wages(out, dead):
            if _jump(out, check, wage, log, finder, budget, max_rounds, limit.too_many):
                span = 1
            else:
                continue
        elif out.rounds - check.rounds >= span:
            span *= 2
        else:
            continue
        check = _checkpoint(out, holdings, limit)
        log = []
    return out


@dataclass(frozen=True, slots=True)
class _Bid:
    """One task's bid in a simultaneous round: its bundle (robots ascending, each with the
    service it would perform) and its price in units of eps."""

    task: int
    robots: npt.NDArray[np.int64]
    services: npt.NDArray[np.int64]
    price: int


#: A bid found again by :func:`_leap`: task, robots ascending, price in units of eps.
Bought = tuple[int, npt.NDArray[np.int64], int]


class _BidLog:
    """Which tasks bid in each simultaneous round since the last checkpoint: what
    :func:`_leap` replays (it searches the bundles again on the checkpoint's state, so
    the bundles themselves are not kept).

    :attr:`cells` counts the words held (one a bid, one a round), which
    :data:`_LOG_CELLS` bounds.
    """

    def __init__(self) -> None:
        self.tasks = array("q")
        self.round_ends = array("q")  # per round: where its bids end
        self.cells = 0

    def add(self, tasks: list[int]) -> None:
        """Log one round's bidding tasks (at least one), in index order.  O(tasks)."""
        self.tasks.extend(tasks)
        self.round_ends.append(len(self.tasks))
        self.cells += len(tasks) + 1

    def rounds(self) -> Iterator[list[int]]:
        """Each logged round's bidding tasks, in order.  O(the bids logged)."""
        first = 0
        for last in self.round_ends:
            yield self.tasks[first:last].tolist()
            first = last


def _simultaneous(
    mission: Mission,
    eps: Fraction,
    max_rounds: int,
    jump: bool,
    fast: bool = True,
    deadline: Deadline = NO_DEADLINE,
) -> _Outcome:
    """The simultaneous reading (every task bids on the round's opening wages, then the
    bids are awarded); see :func:`rachna_dt` Notes for the method and the proofs."""
    _, reqs, n, m, finder, utilities, budget, _, caps64, m_s, match_work = _market(mission, eps)
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    # a bid and its answer, per service agent the task bids to: messages and bytes
    agents2 = np.asarray([2 * len(c) for c in finder.counts], dtype=np.int64)
    bid_bytes = np.asarray(
        [2 * len(c) * HEADER_BYTES + ENTRY_BYTES * sum(c) for c in finder.counts], dtype=np.int64
    )
    work64 = np.asarray(match_work, dtype=np.int64)
    wage = np.zeros(n, dtype=np.int64)  # units of eps
    held = np.zeros(n, dtype=np.int64)  # 1 when some task holds the robot
    holder, service = out.task, out.service  # shared: the assignment is the holder map
    members: list[npt.NDArray[np.int64]] = [np.zeros(0, dtype=np.int64) for _ in range(m)]
    staffed = np.zeros(m, dtype=bool)
    dead = ~finder.possible  # pruned: never staffable, never searched
    dead_work = sum(match_work[j] for j in np.flatnonzero(dead).tolist())
    market = _Market(finder)
    ledger = Ledger(market, wage, held, _services) if fast else None
    taken = np.zeros(n, dtype=bool)  # scratch: robots awarded in the current round
    last = LastBundles(finder.k, n, budget) if fast and LastBundles.fits(finder.k) else None
    holdings = _Holdings(wage, members, staffed, dead)
    limit = _RoundLimit(max_rounds, eps, utilities, finder, caps64, reqs, budget, once=True)

    # Brent's cycle detection on the state at the end of a round; ``log`` holds the bids
    # of every round since the checkpoint, up to _LOG_CELLS words.
    check = _checkpoint(out, holdings, limit)
    span = 1
    log = _BidLog()
    while not deadline.reached():
        if out.rounds >= max_rounds:
            raise limit.too_many()
        out.rounds += 1
        out.work += dead_work
        book = market.book(wage, held) if ledger is None else ledger.book()
        live = np.flatnonzero(~staffed & ~dead)
        out.work += int(work64[live].sum())  # every task not staffed searches
        lazy = ledger if ledger is not None and ledger.exact and last is not None else None
        bidders, winners, gave_up = _settle(live, book, lazy, last, taken, wage, budget)
        for j in gave_up:
            dead[j] = True  # wages never fall: it can never afford a bundle again
            dead_work += match_work[j]
            if ledger is not None:
                ledger.drop(j)
        if not bidders:
            break
        out.direct(int(agents2[bidders].sum()), int(bid_bytes[bidders].sum()))  # bid, answer
        out.iterations += 1
        it = out.iterations
        won = np.concatenate([bid.robots for bid in winners])
        taken[won] = False
        before = holder[won]
        losers = np.unique(before[before >= 0]).tolist()
        for bid in winners:
            wage[bid.robots] += 1
            held[bid.robots] = 1
            holder[bid.robots] = bid.task
            service[bid.robots] = bid.services
            members[bid.task] = bid.robots
            staffed[bid.task] = True
            out.moves.add(_rows(it, bid.robots, bid.task, bid.services))
        changed = [won]
        for loser in losers:
            mem = members[loser]
            rel = np.sort(mem[holder[mem] == loser])
            if rel.size:  # release: one message per service the released robots performed
                performed = int(np.unique(service[rel]).size)
                out.direct(performed, performed * HEADER_BYTES + ENTRY_BYTES * rel.size)
                holder[rel] = -1
                service[rel] = -1
                held[rel] = 0
                out.moves.add(_rows(it, rel, -1, -1))
                changed.append(rel)
            members[loser] = np.zeros(0, dtype=np.int64)
            staffed[loser] = False
        # price announcements: every service agent with a changed robot tells every task
        # needing its service, one entry per changed robot
        moved = np.concatenate(changed)
        out.announce(m_s, caps64[moved].sum(axis=0))
        if ledger is not None:
            ledger.update(moved)
        if jump:
            log.add(bidders)
        if jump and check.same_but_wages(out, dead):
            if _leap(out, check, wage, log, market, budget, max_rounds, limit.too_many):
                span = 1
                if ledger is not None:
                    ledger.rebuild()
            elif log.cells < _LOG_CELLS:
                continue
        elif out.rounds - check.rounds >= span:
            span *= 2
        elif log.cells < _LOG_CELLS:  # a full log starts a new checkpoint, span unchanged
            continue
        check = _checkpoint(out, holdings, limit, _ledger_price(ledger))
        log = _BidLog()
    return out


def _ledger_price(ledger: Ledger | None) -> Callable[[int], int] | None:
    """``price(j)``: task ``j``'s least price (units of eps) on the ledger's current wages,
    for :func:`_rounds_left`; ``None`` without a ledger whose keys still fit (the proof
    then searches on the literal finder)."""
    if ledger is None or not ledger.fast:
        return None

    def price(j: int) -> int:
        found = ledger.best(j)
        if found is None:  # pragma: no cover - a kept task always has a bundle of all robots
            raise ValueError(f"task {j} has no bundle")
        return found[2]

    return price


def _settle(
    live: npt.NDArray[np.int64],
    book: Any,
    lazy: Ledger | None,
    last: LastBundles | None,
    taken: npt.NDArray[np.bool_],
    wage: npt.NDArray[np.int64],
    budget: list[int],
) -> tuple[list[int], list[_Bid], list[int]]:
    """One simultaneous round's bids by the tasks ``live`` (ascending), all on the
    round's opening wages, settled in index order: a bid wins when none of its robots
    went to an earlier winner of the round (``taken``, which it marks).  Returns the
    bidders, the winning bids and the tasks that cannot afford a bundle (they give up).

    With ``lazy`` (a ledger whose keys order bundles exactly) a task loses without a
    search when its cheapest bundle surely holds a taken robot (:meth:`Ledger.blocked`)
    and a bundle it found before (``last``) still fits its budget on these wages: its
    cheapest bundle is then affordable too.  Within a round the wages and keys do not
    change, so these tests are made once for all the tasks and again, for the tasks
    after it, after each win.  O(|live| (S + max k) + searches + wins (|live| S + the
    keys walked)).
    """
    bidders: list[int] = []
    winners: list[_Bid] = []
    gave_up: list[int] = []
    blocked = sure = None
    if lazy is not None and last is not None and live.size:
        blocked = lazy.blocked(live, taken)
        sure = last.affordable(live, wage)
    pos, size = 0, live.size
    while pos < size:
        if blocked is not None and sure is not None:
            lose = sure[pos:] & blocked[pos:]
            run = size - pos if lose.all() else int(np.argmin(lose))
            if run:
                bidders.extend(live[pos : pos + run].tolist())
                pos += run
                continue
        j = int(live[pos])
        pos += 1
        found = book.best(j)
        if found is None or found[2] > budget[j]:
            gave_up.append(j)
            continue
        bidders.append(j)
        robots = found[0]
        if last is not None:
            last.keep(j, robots)
        if not taken[robots].any():
            taken[robots] = True
            winners.append(_Bid(j, *found))
            if lazy is not None and blocked is not None and pos < size:
                blocked[pos:] = lazy.blocked(live[pos:], taken)
    return bidders, winners, gave_up


def _services(
    finder: BundleFinder, j: int, robots: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64] | None:
    """The service each robot of ``robots`` (ascending) performs in task ``j``'s bundle,
    fixed by the robot set alone; ``None`` when the robots cannot fill ``j``'s slots.

    Which slot a robot fills changes no price, so any valid filling serves; this one
    depends on nothing but ``robots`` and the mission, so a repeated bundle repeats its
    services exactly (the jump copies trajectory rows).  Robots having every service the
    task needs fill its slots in order; a robot having exactly one performs it; otherwise
    a matching of robots to slots (scipy's deterministic ``linear_sum_assignment`` on a
    0/1 matrix).  O(k |S_j|), or O(k^3) for the matching.
    """
    need = finder.need[j]
    allowed = finder.caps[robots][:, need]
    if allowed.all():
        return finder.slot_service[j].copy()
    if (allowed.sum(axis=1) == 1).all():
        choice = np.argmax(allowed, axis=1)
        if np.bincount(choice, minlength=need.size).tolist() != finder.counts[j]:
            return None
        return need[choice]
    slots = finder.slot_service[j]
    return match_slots(finder.caps[robots][:, slots], slots)


class _Market:
    """The fixed parts of the simultaneous engine's bundle search (see :class:`_Book`).

    Robot keys ``wage K_w + held K_f + index`` with ``K_f = n^2`` and ``K_w = (n + 1) K_f``
    order bundles exactly as :mod:`heuristics._auction` does (sum of wages, then of flags,
    then of indices: a bundle has at most ``n`` robots) while they fit in int64.
    """

    def __init__(self, finder: BundleFinder) -> None:
        self.finder = finder
        n = finder.n
        self.k_f = max(n * n, 1)
        self.k_w = (n + 1) * self.k_f
        self.limit = (2**62 - self.k_w) // self.k_w  # largest wage the int64 keys allow
        self.caps = finder.caps
        need_sets: dict[tuple[int, ...], int] = {}
        self.pool_of = []  # task -> index of its need set
        for j in range(len(finder.k)):
            key = tuple(finder.need[j].tolist())
            self.pool_of.append(need_sets.setdefault(key, len(need_sets)))
        self.pool_masks = [
            finder.caps[:, list(key)].any(axis=1) if key else np.zeros(n, dtype=bool)
            for key in need_sets
        ]

    def book(self, wage: npt.NDArray[np.int64], held: npt.NDArray[np.int64]) -> _Book:
        """The price book of one round: the bundle search on these wages and flags."""
        return _Book(self, wage, held)


class _Book:
    """Task ``j``'s cheapest bundle on one round's wages and flags (:meth:`best`).

    Exact shortcuts of :meth:`BundleFinder.cheapest`, on one sort of the robots per round:
    the ``k_j`` robots of least key having a service ``j`` needs bound every bundle from
    below, so they are the optimal bundle when they can fill its slots; so are the ``r_js``
    robots of least key having each service ``s`` when these sets are disjoint.  Keys are
    distinct, so both are the unique optimum, the one the matching finds.  Otherwise (and
    for wages too large for the keys) the matching of :class:`BundleFinder` decides.
    """

    def __init__(
        self, market: _Market, wage: npt.NDArray[np.int64], held: npt.NDArray[np.int64]
    ) -> None:
        self.market, self.wage, self.held = market, wage, held
        self.fast = int(wage.max(initial=0)) <= market.limit
        if self.fast:
            n = wage.size
            key = wage * market.k_w + held * market.k_f + np.arange(n, dtype=np.int64)
            self.order = np.argsort(key)
        self._pools: dict[int, npt.NDArray[np.int64]] = {}
        self._services: dict[int, npt.NDArray[np.int64]] = {}

    def best(self, j: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], int] | None:
        """``(robots ascending, their services, price in units)`` of task ``j``'s cheapest
        bundle, or ``None`` when it has none.  O(n) for a pool not yet sorted this round,
        then O(k_j |S_j|) or a matching."""
        market = self.market
        finder = market.finder
        if not finder.possible[j]:
            return None
        k = finder.k[j]
        if self.fast:
            p = market.pool_of[j]
            pool = self._pools.get(p)
            if pool is None:
                pool = self.order[market.pool_masks[p][self.order]]
                self._pools[p] = pool
            if pool.size < k:
                return None
            robots = np.sort(pool[:k])
            services = _services(finder, j, robots)
            if services is None:
                parts = []
                for s, r in zip(finder.need[j].tolist(), finder.counts[j], strict=True):
                    ranked = self._services.get(s)
                    if ranked is None:
                        ranked = self.order[market.caps[self.order, s]]
                        self._services[s] = ranked
                    parts.append(ranked[:r])
                robots = np.unique(np.concatenate(parts))
                if robots.size == k:  # disjoint: each service's cheapest robots
                    services = _services(finder, j, robots)
            if services is not None:
                return robots, services, int(self.wage[robots].sum()) + k
        b = finder.cheapest(j, finder.robots_with, self.wage, self.held)
        if b is None:
            return None
        robots = np.sort(b.robots)
        services = _services(finder, j, robots)
        assert services is not None
        return robots, services, int(b.weight) + k


def _leap(
    out: _Outcome,
    check: _Checkpoint,
    wage: npt.NDArray[np.int64],
    log: _BidLog,
    market: _Market,
    budget: list[int],
    max_rounds: int,
    too_many: Callable[[], MissionError],
) -> bool:
    """Add the simultaneous rounds ``check.rounds + 1 .. out.rounds`` again while they
    provably repeat; returns whether it added any.

    Called when the state now equals the checkpoint's but for the wages, ``wage =
    check.wage + delta``.  Period ``l`` (the one just run is period 0) repeats period 0
    exactly when, on its opening wages ``w + l delta`` of each round, every bid of the
    round is again its task's cheapest bundle and affordable; the set of such ``l`` is an
    interval from 0 (see :func:`rachna_dt` Notes, Termination), so the largest is found by
    checking the bound the budgets allow, then bisecting, each check replaying the period
    with real bundle searches.  Raises :class:`cfopt.MissionError` when the repetitions
    alone pass ``max_rounds``.  O(log(u_max / eps) x the period's bundle searches + the
    trajectory rows added).
    """
    length = out.rounds - check.rounds
    delta = wage - check.wage
    top = int(delta.max())
    if top <= 0:
        return False
    rows = out.moves.since(check.counts[4])
    first = check.counts[0] + 1  # the iteration of the period's first round
    cuts = np.searchsorted(rows[:, 0], np.arange(first, first + length + 1))

    def replay(periods: int, against: list[list[Bought]] | None) -> list[list[Bought]] | None:
        """Period 0's bids searched again on the opening wages of period ``periods``:
        all of them, or ``None`` as soon as one is unaffordable or differs from its bid
        in ``against``."""
        w = check.wage + periods * delta
        flags = (check.holder >= 0).astype(np.int64)
        found_rounds: list[list[Bought]] = []
        for r, tasks in enumerate(log.rounds()):
            book = market.book(w, flags)
            found_bids: list[Bought] = []
            for b, task in enumerate(tasks):
                found = book.best(task)
                if found is None or found[2] > budget[task]:
                    return None
                if against is not None and not np.array_equal(found[0], against[r][b][1]):
                    return None
                found_bids.append((task, found[0], found[2]))
            found_rounds.append(found_bids)
            part = rows[cuts[r] : cuts[r + 1]]
            bought = part[part[:, 2] >= 0, 1]
            w[bought] += 1
            flags[bought] = 1
            flags[part[part[:, 2] < 0, 1]] = 0
        return found_rounds

    base = replay(0, None)  # the bids of the period just run
    assert base is not None
    hi = (_WAGE_CAP - int(wage.max())) // top
    hi = min(hi, (max_rounds - out.rounds - 1) // length + 1)  # passing it proves too many
    for bids in base:
        for task, robots, price in bids:
            rise = int(delta[robots].sum())
            if rise > 0:
                hi = min(hi, (budget[task] - price) // rise)
    if hi <= 0:
        return False

    def repeats(periods: int) -> bool:
        return replay(periods, base) is not None

    if repeats(hi):
        periods = hi
    else:
        good, bad = 0, hi
        while bad - good > 1:
            mid = (good + bad) // 2
            if repeats(mid):
                good = mid
            else:
                bad = mid
        periods = good
    if periods <= 0:
        return False
    if out.rounds + periods * length + 1 > max_rounds:  # at least one round follows
        raise too_many()
    _add_periods(out, check, wage, delta, periods, length)
    return True


def _add_periods(
    out: _Outcome,
    check: _Checkpoint,
    wage: npt.NDArray[np.int64],
    delta: npt.NDArray[np.int64],
    periods: int,
    length: int,
) -> None:
    """Repeat the rounds since ``check`` ``periods`` more times: wages, counts, and the
    trajectory rows with shifted iterations.  O(n + the rows added)."""
    iterations, messages, nbytes, work, rows, cast_messages, cast_bytes = check.counts
    per = out.iterations - iterations
    period = out.moves.since(rows)
    if period.size:
        copies = np.tile(period, (periods, 1))
        copies[:, 0] += np.repeat(np.arange(1, periods + 1, dtype=np.int64) * per, len(period))
        out.moves.add(copies)
    wage += periods * delta
    out.rounds += periods * length
    out.iterations += periods * per
    out.messages += periods * (out.messages - messages)
    out.bytes += periods * (out.bytes - nbytes)
    out.work += periods * (out.work - work)
    out.cast_messages += periods * (out.cast_messages - cast_messages)
    out.cast_bytes += periods * (out.cast_bytes - cast_bytes)


def _rows(it: int, robots: npt.NDArray[np.int64], task: int, services: Any) -> npt.NDArray:
    """Trajectory rows ``(it, robot, task, service)``, one per robot.  O(robots)."""
    rows = np.empty((robots.size, 4), dtype=np.int64)
    rows[:, 0] = it
    rows[:, 1] = robots
    rows[:, 2] = task
    rows[:, 3] = services
    return rows


def _jump(
    out: _Outcome,
    check: _Checkpoint,
    wage: npt.NDArray[np.int64],
    log: list[tuple[int, int]],
    finder: BundleFinder,
    budget: list[int],
    max_rounds: int,
    too_many: Callable[[], MissionError],
) -> bool:
    """Add the rounds ``check.rounds + 1 .. out.rounds`` again while they provably repeat.

    Called when the state now equals the checkpoint's but for the wages, ``wage =
    check.wage + delta``.  See :func:`rachna_dt` Notes (Termination) for the proof; returns
    whether it jumped.  Raises :class:`cfopt.MissionError` past ``max_rounds``.  O(n + the
    robots of the tasks that bought + the trajectory rows added).
    """
    if not log:
        return False
    delta = wage - check.wage
    shift: dict[int, int] = {}
    for j in {j for j, _ in log}:
        d = delta[finder.pool(j)]
        if d[0] <= 0 or not (d == d[0]).all():
            return False
        shift[j] = int(d[0])
    periods = min((budget[j] - price) // (finder.k[j] * shift[j]) for j, price in log)
    top = int(delta.max())
    periods = min(periods, (_WAGE_CAP - int(wage.max())) // top)
    if periods <= 0:
        return False
    length = out.rounds - check.rounds
    if out.rounds + periods * length + 1 > max_rounds:  # at least one round follows
        raise too_many()
    _add_periods(out, check, wage, delta, periods, length)
    return True


def _rounds_left(
    limit: _RoundLimit, holdings: _Holdings, price: Callable[[int], int] | None = None
) -> int | None:
    """A proven lower bound on the rounds still to come, or ``None`` (no bound found).

    See :func:`rachna_dt` Notes (Termination): if the tasks not given up cannot all be
    staffed at once, the auction ends only after one of them gives up, and task ``j``
    cannot give up while the price of a bundle it holds or can buy stays within its budget.
    How fast a wage can rise is ``limit.once``'s (:class:`_RoundLimit`).  With
    ``limit.once`` every bundle of ``j`` rises by at most ``k_j`` a round, so only the
    least price matters: ``price(j)``, when given, is it (on the current wages, units of
    eps, the ``k_j`` increments included), from a price book the caller keeps current.
    O(n S + K S) for the flow, plus one bundle search per unstaffed task when it fails.
    """
    finder, caps64, reqs, budget = limit.finder, limit.caps64, limit.reqs, limit.budget
    wage, members, staffed, dead = holdings.wage, holdings.members, holdings.staffed, holdings.dead
    live = np.flatnonzero(~dead)
    if live.size == 0 or staffed[live].all():  # all staffed: jointly staffable
        return None
    demand = reqs[live].sum(axis=0)  # live tasks need k_j <= n robots each: no overflow
    if _staffable(finder, demand):
        return None
    if limit.once:
        rise = np.ones(caps64.shape[0], dtype=np.int64)
    else:  # a robot's wage rises by at most one per task that can buy it, per round
        tasks_per_service = (reqs[live] > 0).sum(axis=0).astype(np.int64)
        rise = np.minimum(caps64 @ tasks_per_service, live.size)
    least = None
    for j in live.tolist():
        if limit.once and price is not None and not staffed[j]:
            t = (budget[j] - price(j)) // finder.k[j]
            least = t if least is None else min(least, t)
            continue
        if staffed[j]:
            bundle = members[j]
        else:
            b = finder.cheapest(j, finder.robots_with, wage)
            if b is None:  # pragma: no cover - a kept task always has a bundle of all robots
                return None
            bundle = b.robots
        cost = int(wage[bundle].sum()) + finder.k[j]
        t = (budget[j] - cost) // int(rise[bundle].sum())
        least = t if least is None else min(least, t)
    assert least is not None
    return max(least, 0) + 1


def _staffable(finder: BundleFinder, demand: npt.NDArray[np.int64]) -> bool:
    """Whether ``demand[s]`` robots can perform service ``s`` for every ``s`` at once.

    A maximum flow source -> capability kind (its robot count) -> service (if the kind has
    it) -> sink (the demand): O(K + S) nodes and O(K S) edges, ``K`` the distinct
    capability rows, solved by scipy's Dinic algorithm.
    """
    total = int(demand.sum())
    if total == 0:
        return True
    if total > finder.n:
        return False
    kinds, per_kind = finder.kinds, finder.kind_count
    n_kinds, n_services = kinds.shape
    sink = n_kinds + n_services + 1
    kind_at, service_at = np.nonzero(kinds & (demand > 0)[None, :])
    tails = np.concatenate(
        [np.zeros(n_kinds, dtype=np.int64), kind_at + 1, 1 + n_kinds + np.arange(n_services)]
    )
    heads = np.concatenate(
        [1 + np.arange(n_kinds), 1 + n_kinds + service_at, np.full(n_services, sink)]
    )
    capacity = np.concatenate([per_kind, per_kind[kind_at], demand]).astype(np.int32)
    graph = csr_matrix((capacity, (tails, heads)), shape=(sink + 1, sink + 1))
    return int(maximum_flow(graph, 0, sink).flow_value) == total


def _too_many_rounds(max_rounds: int, n: int, u_max: Fraction, eps: Fraction) -> MissionError:
    """The one-line error for an auction that needs more than ``max_rounds`` rounds."""
    per_robot = (max_rounds - 1) // max(n, 1)  # floor(u_max / eps) <= this bounds the rounds
    enough = u_max / per_robot if per_robot >= 1 else 2 * u_max
    return MissionError(
        f"eps: RACHNA_dt needs more than max_rounds={max_rounds} rounds on this mission "
        f"(a bidding war that only budgets of up to {_sci(u_max / eps, up=False)} units of "
        f"eps end); use eps >= {_sci(enough)} (at most n floor(u_max / eps) + 1 <= "
        f"max_rounds rounds) or a larger max_rounds"
    )


def _sci(value: Fraction, up: bool = True) -> str:
    """``value`` in scientific notation, 3 significant digits, rounded up (or down).

    >>> _sci(Fraction(12345)), _sci(Fraction(12345), up=False), _sci(Fraction(1, 3))
    ('1.24e+04', '1.23e+04', '3.34e-01')
    """
    if value <= 0:
        return "0"
    exponent = len(str(value.numerator)) - len(str(value.denominator))
    while Fraction(10) ** exponent > value:
        exponent -= 1
    while Fraction(10) ** (exponent + 1) <= value:
        exponent += 1
    scaled = value / Fraction(10) ** (exponent - 2)  # in [100, 1000)
    digits = math.ceil(scaled) if up else math.floor(scaled)
    if digits == 1000:
        digits, exponent = 100, exponent + 1
    return f"{digits // 100}.{digits % 100:02d}e{exponent:+03d}"
