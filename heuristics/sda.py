"""SDA: the simultaneous descending auction, the seed's first auction baseline.

The original protocol paper is not available; this is the toolkit's reading of the seed's
short description, with the semantics and every open choice stated in :func:`sda`'s Notes.
"""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np

from cfopt import Assignment, Mission, MissionError, require_mission
from cfopt.checks import SeedLike, require_seed
from heuristics._auction import check_eps, check_order
from heuristics._run import Deadline, Run, seed_label
from heuristics._sda_fast import DescendingAuction
from heuristics._sda_fast import Outcome as _Outcome
from heuristics._sda_fast import Touched as _Touched  # noqa: F401 - the tests import it here
from heuristics._sda_fast import core as _core
from heuristics.communication import comm_model, media_table, table_cost

__all__ = ["SCHEDULES", "sda"]

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
    time_limit: float | None = None,
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

    time_limit : float, optional
        Wall-clock seconds after which no further award round starts; the run then
        returns the sales made so far, ``status`` ``TIME_LIMIT``.

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
    deadline = Deadline(time_limit, started=started)
    require_mission(mission)
    eps_q = check_eps(eps)
    if schedule not in SCHEDULES:
        raise MissionError(f"schedule: must be one of {', '.join(SCHEDULES)}, got {schedule!r}")
    check_order(order)
    comm = comm_model(medium, encoding)
    require_seed("seed", seed)  # SDA draws nothing
    out = _core(mission, eps_q, schedule, deadline)
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
        status=deadline.status,
    )


def _core_literal(mission: Mission, eps: Fraction, schedule: str) -> _Outcome:
    """The previous engine, kept as the reference :func:`_core` is tested equal to.

    Same auction (:func:`sda` Notes) and the same rounds, bids and awards
    (:class:`heuristics._sda_fast.DescendingAuction`); only a task's first affordable round
    is found differently: by a binary search of ``log2 q`` matchings
    (:class:`_BinarySearchAuction`) instead of the prefix ranks of
    :mod:`heuristics._sda_fast`.
    """
    return _BinarySearchAuction(mission, eps, schedule).run()


class _BinarySearchAuction(DescendingAuction):
    """The reference engine: a task's first affordable round by a binary search on the clock.

    Inside the task's crossing sweep the cheapest cost only falls as the clock runs, so the
    first affordable clock is found by bisection, one matching (:meth:`_min_cost`) per step.
    """

    def _min_cost(self, j: int, x: int) -> Fraction | None:
        """Task ``j``'s cheapest complete bundle cost at clock ``x`` (``None``: no bundle)."""
        hi, lo, wt = self.weights_at(x)
        self.wfull[self.alive] = wt
        b = self.finder.cheapest(j, self.pools, self.wfull)
        if b is None:
            return None
        return self.k[j] * lo + (hi - lo) * b.weight

    def first_round(self, j: int) -> int | None:
        """First round > R in which task j can afford a bundle (None: never)."""
        zero = np.zeros(self.n, dtype=np.int64)
        if self.finder.cheapest(j, self.pools, zero) is None:
            return None
        a_star = self.a_star[j]
        if self.uniform:
            return max(self.R + 1, a_star)
        q = self.alive.size
        hi_x = a_star * q  # all robots at level a_star: affordable
        lo_x = max(self.total, (a_star - 1) * q)  # not affordable
        hi_x = max(hi_x, lo_x + 1)
        while hi_x - lo_x > 1:
            mid = (lo_x + hi_x) // 2
            c = self._min_cost(j, mid)
            if c is not None and c <= self.u[j]:
                hi_x = mid
            else:
                lo_x = mid
        return self.R + (hi_x - self.total)
