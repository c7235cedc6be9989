"""RACHNA_dt: the ascending auction with the dynamic threshold ``eps = 1/n``, the seed's
second auction baseline.

The original protocol paper is not available; this is the toolkit's reading of the seed's
short description, with the semantics and every open choice stated in :func:`rachna_dt`'s
Notes.
"""

from __future__ import annotations

import heapq
import math
import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_flow

from cfopt import Assignment, Mission, MissionError, require_mission
from heuristics._auction import (
    ENTRY_BYTES,
    HEADER_BYTES,
    BundleFinder,
    check_eps,
    check_order,
)
from heuristics._run import Run, seed_label

__all__ = ["MAX_ROUNDS", "rachna_dt"]

SeedLike = int | np.random.Generator | None
#: Default ``max_rounds`` of :func:`rachna_dt` (the seed's missions need at most a few
#: times ``10 n``; a bidding war lasts about ``u / eps`` purchases).
MAX_ROUNDS = 10**5
#: Jumps keep every wage (in units of eps) below this, so int64 never overflows.
_WAGE_CAP = 2**62
#: The first checkpoint round at which the engine tries to prove that more than
#: ``max_rounds`` rounds are needed (the seed's missions end long before).
_PROVE_FROM = 16


def rachna_dt(
    mission: Mission,
    *,
    eps: float | Fraction | None = None,
    seed: SeedLike = None,
    order: str = "index",
    max_rounds: int = MAX_ROUNDS,
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
        Accepted for the registry's common signature; tasks act in index order.
    max_rounds : int, default MAX_ROUNDS (100000)
        The most rounds the auction may need; a run that needs more raises
        :class:`cfopt.MissionError` (see Notes, Termination).  The trajectory of a run has
        at least ``rounds - 1`` rows, so this also bounds its memory.

    Returns
    -------
    Run
        ``algorithm="rachna-dt"``; ``iterations`` = rounds with at least one acquisition;
        ``trajectory`` one row ``(iteration, robot, task, service)`` per robot that changes
        hands (``task = service = -1``: released).

    Raises
    ------
    cfopt.MissionError
        For a bad argument, and ``eps: ...`` when the auction needs more than
        ``max_rounds`` rounds; the message gives an ``eps`` that bounds the rounds.

    Notes
    -----
    The auction.  Wages are whole multiples of ``eps``, kept as integers (units of
    ``eps``), all 0 at the start; a task's utility ``u[j]`` becomes the integer budget
    ``floor(u[j] / eps)`` (exact, with fractions and Python integers of any size), so every
    comparison is exact.  A round: the tasks that are not fully staffed act one after
    another in index order, each on the state left by the previous ones (choice:
    sequential, not simultaneous, so there are no conflicting bids to resolve).  A task
    prices every robot at ``wage + eps`` -- a task that is not fully staffed holds no robot
    (it released them all when it lost one), so "robots a task already holds are priced at
    their wage" never applies -- and finds its cheapest complete bundle among *all* robots
    having the services (free or held); if the bundle costs ``<= u[j]`` it takes all of it.
    Every robot it acquires, free or taken from another task, now earns ``wage + eps``
    (choice: the price the bid was computed with; the seed names the taken robots, free
    robots are priced the same way).  A task that loses a robot is no longer staffed and
    releases its other robots, whose wages are kept; if its index is after the acting task
    it acts again in the same round, otherwise in the next (so a task acts at most once per
    round).  The auction stops after a round in which no task bid (that quiet round is
    counted).

    Tie-break (choice): among bundles of equal cost, fewest robots taken from other tasks,
    then the least sum of robot indices (see :mod:`heuristics._auction`).  A task that
    cannot afford its cheapest bundle, or has none, never bids again: wages never fall, so
    its cheapest cost never falls; the engine skips it (its work is still counted).  A task
    that can never be staffed (it needs more robots of a service than have it, or more
    robots in all than have one of its services) is pruned before the first round: it is
    never searched, and counted exactly as the literal auction counts it (it acts, finds
    no bundle and gives up in round 1).

    Termination.  Every acquisition raises at least one wage by one unit and no wage
    exceeds ``floor(u_max / eps)`` units (a robot is bought at ``wage + 1 <= budget``), so
    ``rounds <= n floor(u_max / eps) + 1``; with the default ``eps = 1/n`` and integer
    utilities that is ``n^2 u_max + 1``.  The rounds really do grow with ``u / eps`` when
    tasks compete for too few robots (a bidding war ends only when a budget runs out), and
    every round but the last adds trajectory rows, so the engine cannot skip them; it

    * adds repeating rounds at once: when the state at the end of a round (holders,
      services, given-up tasks) equals that of the last checkpoint of Brent's cycle
      detection but for the wages, raised by ``delta``, and ``delta`` is one constant
      ``c_j`` over all robots having a service of each task ``j`` that bought in between,
      then every bundle search of the next period sees its cost matrix shifted by a
      constant, makes the same choice, and the period repeats -- for as long as every
      purchase price ``p`` of the period stays within its budget, ``L = min (budget_j - p)
      // (k_j c_j)`` more times (and wages stay below ``2**62`` units).  The ``L`` periods
      are added in one step: wages, counts, and the trajectory rows with shifted
      iterations;
    * proves early that more than ``max_rounds`` rounds are needed, at every checkpoint
      from round 16 on (rounds 16, 32, 64, ... and after each jump): if the tasks not
      given up cannot all be staffed at once (a maximum flow from the robots to the
      services they demand), the auction cannot end before one of them gives up, and a
      task ``j`` that holds or can buy a bundle ``B`` at price ``p_j`` units cannot give
      up within ``(budget_j - p_j) // g_j`` rounds, where ``g_j`` sums, over ``B``, the
      tasks that can buy each robot (a task acts at most once per round, so this bounds
      the wage rise of ``B`` per round);
    * raises :class:`cfopt.MissionError` (``eps: ...``, naming an ``eps`` with ``n
      floor(u_max / eps) + 1 <= max_rounds``) when such a proof, a jump or the round
      count passes ``max_rounds``.  A war that does not repeat and cannot be proven long
      (budgets of about ``max_rounds`` times the bound ``g_j``) is run round by round up
      to ``max_rounds``.

    Counting.  Messages (header 8 bytes, entries 12 bytes): an acting task that bids sends
    one message to each service agent of its needed services (``r_js`` entries) and gets an
    answer from each (header only); after an acquisition every service agent with a robot
    whose wage or holder changed (the bundle and the robots the losers released) tells every
    other task needing its service (one entry per changed robot); a task that lost a robot
    sends a release to the service agent of each service its released robots performed (one
    entry per robot).  A task that does not bid sends nothing.  ``work`` counts cost-matrix
    entries of the bundle selections the literal auction performs: each acting task, each
    time it acts, matches ``(robots having one of its services) x k_j`` entries.

    Complexity: O(rounds simulated x acting tasks x M) where ``M`` is one matching on at
    most ``k_j |S_j|`` candidates, plus O(n + m) per round for the cycle detection and
    O(m M + n S) at each of the O(log rounds) checkpoints; the rounds simulated are at most
    ``max_rounds`` and, on the seed's missions, a few (see
    ``benchmarks/bench_auctions.py``).

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    >>> run = rachna_dt(m)          # task 0 takes robot 0; task 1 outbids it (only robot 0
    >>> run.trajectory.tolist()     # has service 1); task 0 re-forms with robot 1
    [[1, 0, 0, 0], [1, 0, 1, 1], [2, 1, 0, 0]]
    >>> run.assignment.task.tolist(), run.iterations, run.rounds
    ([1, 0], 2, 3)

    Two tasks bidding for one robot: a war of about ``u / eps`` rounds, jumped over.

    >>> war = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1e4, 2e4])
    >>> run = rachna_dt(war, eps=1)
    >>> run.rounds, len(run.trajectory), run.assignment.task.tolist()
    (5001, 10000, [1])
    >>> rachna_dt(war, eps=1, max_rounds=1000)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: eps: RACHNA_dt needs more than max_rounds=1000 rounds ...
    """
    started = time.perf_counter()
    require_mission(mission)
    n = mission.n_robots
    eps_q = Fraction(1, max(n, 1)) if eps is None else check_eps(eps)
    check_order(order)
    if (
        isinstance(max_rounds, bool)
        or not isinstance(max_rounds, numbers.Integral)
        or max_rounds < 1
    ):
        raise MissionError(f"max_rounds: must be a whole number >= 1, got {max_rounds!r}")
    np.random.default_rng(seed)  # validates the seed; RACHNA_dt draws nothing
    out = _core(mission, eps_q, int(max_rounds))
    return Run(
        algorithm="rachna-dt",
        assignment=Assignment(task=out.task, service=out.service),
        iterations=out.iterations,
        rounds=out.rounds,
        messages=out.messages,
        bytes=out.bytes,
        work=out.work,
        seconds=time.perf_counter() - started,
        seed=seed_label(seed),
        trajectory=out.moves.array(),
        options=(("eps", str(eps_q)), ("order", order)),
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
    messages: int = 0
    bytes: int = 0
    work: int = 0
    moves: _Moves = field(default_factory=_Moves)

    def counts(self) -> tuple[int, int, int, int, int]:
        return self.iterations, self.messages, self.bytes, self.work, self.moves.count


@dataclass
class _Checkpoint:
    """The state at the end of round ``rounds`` (cycle detection, see :func:`rachna_dt`)."""

    rounds: int
    holder: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    dead: npt.NDArray[np.bool_]
    wage: npt.NDArray[np.int64]
    counts: tuple[int, int, int, int, int]


def _core(mission: Mission, eps: Fraction, max_rounds: int, jump: bool = True) -> _Outcome:
    """The auction rounds; see :func:`rachna_dt` Notes for the method.

    ``jump=False`` turns the jump over repeating rounds off (the tests compare both).
    Complexity as :func:`rachna_dt`.
    """
    caps, reqs = mission.capabilities, mission.requirements
    n = caps.shape[0]
    m = reqs.shape[0]
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    finder = BundleFinder(caps, reqs)
    k = finder.k
    utilities = [Fraction(float(x)) for x in mission.utilities.tolist()]
    budget = [math.floor(x / eps) for x in utilities]
    need64 = (reqs > 0).astype(np.int64)
    caps64 = caps.astype(np.int64)
    m_s = need64.sum(axis=0)  # tasks needing each service
    match_work = [int(r) * kj for r, kj in zip(finder.reach.tolist(), k, strict=True)]
    wage = np.zeros(n, dtype=np.int64)  # units of eps
    held = np.zeros(n, dtype=np.int64)  # 1 when some task holds the robot
    holder = out.task  # shared: the assignment is the holder map
    members: list[npt.NDArray[np.int64]] = [np.zeros(0, dtype=np.int64) for _ in range(m)]
    staffed = np.zeros(m, dtype=bool)
    dead = ~finder.possible  # pruned: never staffable, never searched
    dead_work = sum(match_work[j] for j in np.flatnonzero(dead).tolist())
    pools = finder.robots_with
    next_round = list(range(m))

    def too_many() -> MissionError:
        return _too_many_rounds(max_rounds, n, max(utilities, default=Fraction(0)), eps)

    def checkpoint() -> _Checkpoint:
        if out.rounds >= _PROVE_FROM:
            rest = _rounds_left(finder, caps64, reqs, budget, wage, members, staffed, dead)
            if rest is not None and out.rounds + rest > max_rounds:
                raise too_many()
        return _Checkpoint(
            out.rounds, holder.copy(), out.service.copy(), dead.copy(), wage.copy(), out.counts()
        )

    # Brent's cycle detection on the state at the end of a round; ``log`` holds the
    # purchases (task, price in units) made since the checkpoint.
    check = checkpoint()
    span = 1
    log: list[tuple[int, int]] = []
    while True:
        if out.rounds >= max_rounds:
            raise too_many()
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
                    svc = out.service[rel]
                    out.messages += int(np.unique(svc).size)
                    out.bytes += int(np.unique(svc).size) * HEADER_BYTES + ENTRY_BYTES * rel.size
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
            out.messages += 2 * len(counts)
            out.bytes += 2 * len(counts) * HEADER_BYTES + ENTRY_BYTES * sum(counts)
            # notices about changed robots to every other task needing the service
            changed = np.concatenate([robots, *released_parts]) if released_parts else robots
            per_service = caps64[changed].sum(axis=0)
            has = per_service > 0
            to = m_s - need64[j]
            out.messages += int(to[has].sum())
            out.bytes += int((to * (HEADER_BYTES + ENTRY_BYTES * per_service))[has].sum())
        if not acted:
            break
        # every unstaffed live task acts next round (those robbed late were queued above)
        live = {j for j in range(m) if not staffed[j] and not dead[j]}
        next_round = sorted(set(next_round) | live)
        if (
            jump
            and np.array_equal(holder, check.holder)
            and np.array_equal(out.service, check.service)
            and np.array_equal(dead, check.dead)
        ):
            if _jump(out, check, wage, log, finder, budget, max_rounds, too_many):
                span = 1
            else:
                continue
        elif out.rounds - check.rounds >= span:
            span *= 2
        else:
            continue
        check = checkpoint()
        log = []
    return out


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
    iterations, messages, nbytes, work, rows = check.counts
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
    return True


def _rounds_left(
    finder: BundleFinder,
    caps64: npt.NDArray[np.int64],
    reqs: npt.NDArray[np.int64],
    budget: list[int],
    wage: npt.NDArray[np.int64],
    members: list[npt.NDArray[np.int64]],
    staffed: npt.NDArray[np.bool_],
    dead: npt.NDArray[np.bool_],
) -> int | None:
    """A proven lower bound on the rounds still to come, or ``None`` (no bound found).

    See :func:`rachna_dt` Notes (Termination): if the tasks not given up cannot all be
    staffed at once, the auction ends only after one of them gives up, and task ``j``
    cannot give up while the price of a bundle it holds or can buy stays within its budget.
    O(n S + K S) for the flow, plus one bundle search per unstaffed task when it fails.
    """
    live = np.flatnonzero(~dead)
    if live.size == 0 or staffed[live].all():  # all staffed: jointly staffable
        return None
    demand = reqs[live].sum(axis=0)  # live tasks need k_j <= n robots each: no overflow
    if _staffable(finder, demand):
        return None
    tasks_per_service = (reqs[live] > 0).sum(axis=0).astype(np.int64)
    # a robot's wage rises by at most one per task that can buy it, per round
    rise = np.minimum(caps64 @ tasks_per_service, live.size)
    least = None
    for j in live.tolist():
        if staffed[j]:
            bundle = members[j]
        else:
            b = finder.cheapest(j, finder.robots_with, wage)
            if b is None:  # pragma: no cover - a kept task always has a bundle of all robots
                return None
            bundle = b.robots
        price = int(wage[bundle].sum()) + finder.k[j]
        t = (budget[j] - price) // int(rise[bundle].sum())
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
