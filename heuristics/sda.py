"""SDA: the simultaneous descending auction, the seed's first auction baseline.

The original protocol paper is not available; this is the toolkit's reading of the seed's
short description, with the semantics and every open choice stated in :func:`sda`'s Notes.
"""

from __future__ import annotations

import heapq
import math
import time
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError, require_mission
from heuristics._auction import (
    ENTRY_BYTES,
    HEADER_BYTES,
    BundleFinder,
    check_eps,
    check_order,
)
from heuristics._run import Run, seed_label
from heuristics._sda_fast import Outcome as _Outcome
from heuristics._sda_fast import Touched as _Touched
from heuristics._sda_fast import bid_messages as _bid_messages
from heuristics._sda_fast import core as _core
from heuristics.communication import comm_model, media_table, table_cost

__all__ = ["SCHEDULES", "sda"]

SeedLike = int | np.random.Generator | None
#: The wage decrement schedules.
SCHEDULES = ("max-wage", "uniform")


def sda(
    mission: Mission,
    *,
    eps: float | Fraction = 1.0,
    schedule: str = "max-wage",
    seed: SeedLike = None,
    order: str = "index",
    medium: str = "broadcast",
    encoding: str = "full",
) -> Run:
    """Run the simultaneous descending auction (centralized, synchronous) on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    eps : float or Fraction, default 1.0
        The wage decrement ``eps_d`` (> 0), taken at its exact value.
    schedule : {"max-wage", "uniform"}
        ``"max-wage"`` (the seed's example): each round lowers by ``eps`` the wage of the
        single unsold robot with the highest wage, ties to the lowest index.
        ``"uniform"``: each round lowers every unsold robot's wage by ``eps``.
    seed : None, int or numpy.random.Generator
        Recorded only: SDA makes no random choice (every tie goes to the lowest index).
    order : {"index"}
        Accepted for the registry's common signature; there is no robot order to choose.
    medium : {"broadcast", "unicast"}, default "broadcast"
        How ``messages`` and ``bytes`` count an announcement to several agents: one
        transmission, or one message per receiver (Counting below,
        :mod:`heuristics.communication`).
    encoding : {"full", "compact"}, default "full"
        Accepted and recorded for the common signature: the encoding is that of beliefs
        (partitions), and SDA sends none, so both give the same counts.

    Returns
    -------
    Run
        ``algorithm="sda"``; ``iterations`` = rounds with at least one award; ``trajectory``
        one row ``(iteration, robot, task, service)`` per sold robot; ``options`` records
        ``medium`` and ``encoding``, ``communication`` the counts under every model.

    Notes
    -----
    The auction.  Every robot has a wage ``max(0, u_max + eps - d eps)``
    after ``d`` decrements.  Round ``t``: (1) the schedule decrements (floored at 0; when
    every unsold wage is 0 nothing changes); (2) every task not yet staffed finds its
    cheapest complete bundle of unsold robots (the cost is the sum of their current wages)
    and bids when the cost is ``<= u[j]``; (3) bids are awarded in order of decreasing
    surplus ``u[j] - cost``, ties to the lowest task index; a bid whose bundle lost a robot
    to an earlier award of the round is recomputed on the remaining robots at the same wages
    and, if still affordable, re-enters the order with its new surplus (a lazy priority
    queue: the awarded bid is always the one with the largest *current* surplus); awarded
    robots are sold for good.  The auction stops at the end of the round in which all robots
    are sold, every task is staffed, or every unsold wage is 0 (at wage 0 every task that
    has a complete bundle can afford it, so step 3 has then placed all that can be placed).
    A task that cannot be staffed still waits until that round: the quiet rounds are counted.

    Choices the seed's description leaves open: the bundle tie-break (among bundles of equal
    cost, the least sum of robot indices; see :mod:`heuristics._auction`); the award order
    on re-bids (current surplus, above); wages are exact rationals (``fractions.Fraction``)
    and every comparison ``cost <= u[j]`` and every surplus comparison is exact; the
    stopping round.

    Exact engine.  Between two award rounds the unsold set is fixed, so the wages are a
    closed-form function of the round: under ``max-wage`` the unsold robots, in index order,
    are decremented round-robin (the robot with the highest wage is the one with the fewest
    decrements, ties lowest index), so after ``x`` decrements among ``q`` unsold robots the
    one at position ``p`` has had ``ceil((x - p) / q)`` (capped at ``D = ceil((u_max + eps) /
    eps)``, when its wage is 0) -- at most two wage levels at any time; under ``uniform``
    all unsold robots have the same wage.  A task's cheapest cost never rises while the
    unsold set is fixed, and at most two wage levels make it ``k lo + (hi - lo) h`` where
    ``h`` is the least number of high-wage robots in a complete bundle (a 0/1-weighted
    matching, exact).  The engine therefore jumps from award round to award round: after
    each award round it finds every task's first affordable round -- the sweep in which
    ``k wage`` crosses ``u[j]`` in closed form, then the position inside that sweep, read
    off the task's index-order greedy basis (``h`` is ``k`` minus the number of basis robots
    at the low wage, so the crossing is one past the basis robot number ``T_j``, a static
    rank; see :mod:`heuristics._sda_fast`) -- visiting tasks in order of that sweep and
    stopping as soon as the next sweep starts after the best round found.  A basis is
    rebuilt only after one of its robots is sold.  The bids and awards themselves use the
    matching below.  It produces exactly the round-by-round trajectory (tests compare it
    with a literal transcription, and with the previous engine, which found the position
    by a binary search of ``log2 q`` matchings).

    Any utility and requirement.  Wages, costs and utilities are fractions, and the round
    and decrement clocks Python integers, so nothing overflows however large ``u_max /
    eps`` is (``rounds`` and the counts can then be huge exact integers: the engine jumps
    over the rounds, it does not run them).  A robot's decrement count is never stored:
    at clock ``x = a q + r`` the robots at positions ``< r`` have had ``a + 1`` decrements
    and the others ``a``.  A task that can never be staffed (it needs more robots of a
    service than have it, or more robots in all than have one of its services) is pruned
    before the first round: it is never searched, and it still counts as unstaffed for the
    stopping rule and the messages, exactly as in the literal auction.

    Counting.  ``rounds``: rounds run (at most ``n D`` under ``max-wage``, ``D`` under
    ``uniform``; ``D = ceil(u_max / eps) + 1``).  Messages (header 8 bytes, entries 12
    bytes): each wage decrement is announced by every service agent of the robot to every
    unstaffed task needing that service (one entry; ``uniform``: one message per service
    agent and unstaffed task needing it, one entry per unsold robot of the service); a bid
    is one message to each service agent of the task's needed services (``r_js`` entries);
    every bid message is answered (accept or reject, header only); after an award round
    each service agent that sold robots tells every still unstaffed task needing its service
    (one entry per sold robot).  These counts are ``medium="unicast"``'s: one message per
    receiver.  Under ``"broadcast"`` (the default) the announcements -- a wage decrement
    and a sale, whose content is the same for every task told -- are one transmission per
    service agent announcing (to at least one task), of the same size; bids and answers
    are direct messages (their content is the receiver's), one transmission each under
    both media.  The encoding changes nothing (no partition is sent).  ``work`` counts the
    cost-matrix entries of the bundle selections the literal auction performs: every
    round, every unstaffed task matches ``(unsold robots having one of its services) x
    k_j`` entries, and so does each re-bid; the engine itself does far less (it restricts
    candidates, see :mod:`heuristics._auction`).

    Complexity: O(m) award rounds, each costing O(m' B) where ``m'`` is the number of
    tasks whose crossing sweep is near the front and ``B`` the rebuild of a greedy basis on
    at most ``k_j |S_j|`` candidates (only for tasks that lost a basis robot), plus one
    matching per bid and O(n S) bookkeeping; arithmetic on numbers of O(log(u_max / eps))
    digits, independent of the number of rounds.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
    >>> run = sda(m)
    >>> run.assignment.task.tolist(), run.assignment.utility(m)
    ([0, 0, 1], 14.0)
    >>> run.rounds, run.iterations
    (19, 2)
    >>> # 19 decrement notices (one broadcast each, 8 + 12 bytes; unicast: to the 2 tasks
    >>> # for 17 rounds, then to t1 alone: 36), 2 bids and 2 answers (direct), 1 sale
    >>> # notice of 2 entries to t1 (after t1's sale there is no task left to tell)
    >>> run.messages, run.bytes, run.communication_cost("unicast")
    (24, 480, (41, 820))
    """
    started = time.perf_counter()
    require_mission(mission)
    eps_q = check_eps(eps)
    if schedule not in SCHEDULES:
        raise MissionError(f"schedule: must be one of {', '.join(SCHEDULES)}, got {schedule!r}")
    check_order(order)
    comm = comm_model(medium, encoding)
    np.random.default_rng(seed)  # validates the seed; SDA draws nothing
    out = _core(mission, eps_q, schedule)
    table = media_table((out.messages, out.bytes), (out.cast_messages, out.cast_bytes))
    messages, nbytes = table_cost(table, comm)
    return Run(
        algorithm="sda",
        assignment=Assignment(task=out.task, service=out.service),
        iterations=out.iterations,
        rounds=out.rounds,
        messages=messages,
        bytes=nbytes,
        work=out.work,
        seconds=time.perf_counter() - started,
        seed=seed_label(seed),
        trajectory=np.array(out.moves, dtype=np.int64).reshape(-1, 4),
        options=(("eps", str(eps_q)), ("schedule", schedule), ("order", order), *comm.options),
        communication=table,
    )


def _core_literal(mission: Mission, eps: Fraction, schedule: str) -> _Outcome:
    """The previous engine, kept as the reference :func:`_core` is tested equal to.

    Same auction (:func:`sda` Notes); a task's first affordable round is found by a binary
    search of ``log2 q`` matchings instead of the prefix ranks of :mod:`heuristics._sda_fast`.
    """
    caps, reqs = mission.capabilities, mission.requirements
    n = caps.shape[0]
    m = reqs.shape[0]
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    if n == 0 or m == 0:
        return out
    uniform = schedule == "uniform"
    finder = BundleFinder(caps, reqs)
    u = [Fraction(float(x)) for x in mission.utilities.tolist()]
    w0 = max(u) + eps
    D = math.ceil(w0 / eps)  # decrements that bring a wage to 0

    def wage(d: int) -> Fraction:
        return max(Fraction(0), w0 - d * eps)

    k = finder.k
    # the first sweep level a at which k wage(a) <= u[j]: static per task
    a_star = [min(D, max(0, math.ceil((k[j] * w0 - u[j]) / (k[j] * eps)))) for j in range(m)]
    by_level = sorted(range(m), key=lambda j: (a_star[j], j))

    needmask = reqs > 0  # m x S
    caps64 = caps.astype(np.int64)
    need64 = needmask.astype(np.int64)
    touched = _Touched(needmask)
    rows = finder.reach.copy()  # unsold robots having one of the task's services
    # the literal work of a round, sum rows[j] k[j], in int64 unless that could overflow
    k_arr = np.array(k, dtype=np.int64 if n * sum(k) < 2**62 else object)
    staffed = np.zeros(m, dtype=bool)
    dead = ~finder.possible  # pruned: never staffable, never searched
    unsold = np.ones(n, dtype=bool)
    alive = np.arange(n, dtype=np.int64)  # unsold robots, ascending
    pos = np.arange(n, dtype=np.int64)  # position in ``alive``; -1 when sold
    pools = [r.copy() for r in finder.robots_with]
    A = need64.sum(axis=0)  # unstaffed tasks needing each service
    R = 0  # rounds completed
    total = 0  # max-wage: decrements among the unsold robots (sum of their d)

    def clock(t: int) -> int:
        """Decrement clock at round t (> R): decrements under max-wage, rounds otherwise."""
        if uniform:
            return min(t, D)
        return min(alive.size * D, total + (t - R))

    def weights_at(x: int, robots: npt.NDArray[np.int64]) -> tuple[Fraction, Fraction, npt.NDArray]:
        """(high wage, low wage, 0/1 weight of ``robots`` = has the high wage) at clock x."""
        if uniform:
            return wage(x), wage(x), np.zeros(robots.size, dtype=np.int64)
        # x = a q + r: the robots at positions < r have had a + 1 decrements, the others a
        a, r = divmod(x, alive.size)
        hi, lo = wage(a), wage(a + 1)
        if hi == lo:
            return hi, lo, np.zeros(robots.size, dtype=np.int64)
        return hi, lo, (pos[robots] >= r).astype(np.int64)

    wfull = np.zeros(n, dtype=np.int64)

    def min_cost(j: int, x: int) -> Fraction | None:
        hi, lo, wt = weights_at(x, alive)
        wfull[alive] = wt
        b = finder.cheapest(j, pools, wfull)
        if b is None:
            return None
        return k[j] * lo + (hi - lo) * b.weight

    def first_round(j: int) -> int | None:
        """First round > R in which task j can afford a bundle (None: never)."""
        zero = np.zeros(n, dtype=np.int64)
        if finder.cheapest(j, pools, zero) is None:
            return None
        if uniform:
            return max(R + 1, a_star[j])
        q = alive.size
        hi_x = a_star[j] * q  # all robots at level a_star: affordable
        lo_x = max(total, (a_star[j] - 1) * q)  # not affordable
        hi_x = max(hi_x, lo_x + 1)
        while hi_x - lo_x > 1:
            mid = (lo_x + hi_x) // 2
            c = min_cost(j, mid)
            if c is not None and c <= u[j]:
                hi_x = mid
            else:
                lo_x = mid
        return R + (hi_x - total)

    def lower_bound(j: int) -> int:
        if uniform:
            return max(R + 1, a_star[j])
        q = alive.size
        return R + max(1, (a_star[j] - 1) * q + 1 - total)

    def quiet(t_from: int, t_to: int) -> None:
        """Account rounds t_from..t_to (inclusive): decrement notices and literal work."""
        if t_to < t_from:
            return
        nr = t_to - t_from + 1
        unst = ~staffed
        out.work += nr * int((rows[unst] * k_arr[unst]).sum())
        if uniform:
            dec_rounds = max(0, min(t_to, D) - t_from + 1)
            sizes = np.array([p.size for p in pools], dtype=np.int64)
            has = sizes > 0
            out.messages += dec_rounds * int(A[has].sum())
            out.bytes += dec_rounds * int((A * (HEADER_BYTES + ENTRY_BYTES * sizes))[has].sum())
            cast = has & (A > 0)  # one broadcast per service agent with a task to tell
            out.cast_messages += dec_rounds * int(cast.sum())
            out.cast_bytes += dec_rounds * int((HEADER_BYTES + ENTRY_BYTES * sizes)[cast].sum())
            return
        q = alive.size
        x0 = min(q * D, total + (t_from - 1 - R))
        x1 = min(q * D, total + (t_to - R))
        if x1 <= x0:
            return
        wt = caps64[alive] @ A  # notices per decrement of each unsold robot
        pref = np.concatenate(([0], np.cumsum(wt)))
        # broadcast: one notice per service agent of the robot with a task to tell
        pref_cast = np.concatenate(([0], np.cumsum(caps64[alive] @ (A > 0).astype(np.int64))))

        def upto(x: int, prefix: npt.NDArray[np.int64]) -> int:
            full, rest = divmod(x, q)
            return full * int(prefix[q]) + int(prefix[rest])

        msgs = upto(x1, pref) - upto(x0, pref)
        out.messages += msgs
        out.bytes += msgs * (HEADER_BYTES + ENTRY_BYTES)
        casts = upto(x1, pref_cast) - upto(x0, pref_cast)
        out.cast_messages += casts
        out.cast_bytes += casts * (HEADER_BYTES + ENTRY_BYTES)

    while alive.size and not staffed.all():
        # ---- find the next award round and its bidders
        best: int | None = None
        bidders: list[int] = []
        for j in by_level:
            if staffed[j] or dead[j]:
                continue
            if best is not None and lower_bound(j) > best:
                break
            t = first_round(j)
            if t is None:
                dead[j] = True
            elif best is None or t < best:
                best, bidders = t, [j]
            elif t == best:
                bidders.append(j)
        if best is None:  # nobody will ever bid: the wages run down to 0
            end = R + (D - R if uniform else alive.size * D - total)
            quiet(R + 1, end)
            R = max(R, end)
            break
        quiet(R + 1, best)
        x = clock(best)
        hi, lo, wt = weights_at(x, alive)
        wfull[alive] = wt
        R = best
        out.iterations += 1
        it = out.iterations
        sold_round = np.zeros(n, dtype=bool)
        heap: list[tuple[Fraction, int, int]] = []
        bundles = {}
        for j in sorted(bidders):
            b = finder.cheapest(j, pools, wfull)
            assert b is not None
            bundles[j] = b
            cost = k[j] * lo + (hi - lo) * b.weight
            heapq.heappush(heap, (cost - u[j], j, 0))
            _bid_messages(out, finder, j)
        while heap:
            _, j, _ = heapq.heappop(heap)
            b = bundles[j]
            n_msg = len(finder.need[j])
            out.direct(n_msg, n_msg * HEADER_BYTES)  # the answers
            if sold_round[b.robots].any():  # rejected: recompute on what is left
                out.work += int(rows[j]) * k[j]
                nb = finder.cheapest(j, pools, wfull)
                if nb is None:
                    dead[j] = True
                    continue
                cost = k[j] * lo + (hi - lo) * nb.weight
                if cost <= u[j]:
                    bundles[j] = nb
                    heapq.heappush(heap, (cost - u[j], j, 0))
                    _bid_messages(out, finder, j)
                continue
            staffed[j] = True
            sold_round[b.robots] = True
            out.task[b.robots] = j
            out.service[b.robots] = b.services
            for r, s in sorted(zip(b.robots.tolist(), b.services.tolist(), strict=True)):
                out.moves.append((it, r, j, s))
            A -= need64[j]
            rows -= touched(caps[b.robots])
            for s in np.flatnonzero(caps[b.robots].any(axis=0)).tolist():
                pools[s] = pools[s][~sold_round[pools[s]]]
        # sold notices to the tasks still unstaffed
        sold_per_service = caps64[sold_round].sum(axis=0)
        has = sold_per_service > 0
        out.messages += int(A[has].sum())
        out.bytes += int((A * (HEADER_BYTES + ENTRY_BYTES * sold_per_service))[has].sum())
        cast = has & (A > 0)
        out.cast_messages += int(cast.sum())
        out.cast_bytes += int((HEADER_BYTES + ENTRY_BYTES * sold_per_service)[cast].sum())
        unsold &= ~sold_round
        if not uniform:  # decrements of the robots left: a + (1 if position < r)
            a, r = divmod(x, alive.size)
            left = alive[~sold_round[alive]]
            total = a * left.size + int((pos[left] < r).sum())
        alive = np.flatnonzero(unsold).astype(np.int64)
        pos[:] = -1
        pos[alive] = np.arange(alive.size)
        if uniform:
            if x >= D:
                break
        elif alive.size and total >= alive.size * D:
            break
    out.rounds = R
    return out
