"""RACHNA_dt: the ascending auction with the dynamic threshold ``eps = 1/n``, the seed's
second auction baseline.

The original protocol paper is not available; this is the toolkit's reading of the seed's
§3.1 (algorithms.md §6), with every open choice stated in :func:`rachna_dt`'s Notes.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, require_mission
from heuristics._auction import (
    ENTRY_BYTES,
    HEADER_BYTES,
    BundleFinder,
    check_eps,
    check_order,
)
from heuristics._run import Run, seed_label

__all__ = ["rachna_dt"]

SeedLike = int | np.random.Generator | None


def rachna_dt(
    mission: Mission,
    *,
    eps: float | Fraction | None = None,
    seed: SeedLike = None,
    order: str = "index",
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

    Returns
    -------
    Run
        ``algorithm="rachna-dt"``; ``iterations`` = rounds with at least one acquisition;
        ``trajectory`` one row ``(iteration, robot, task, service)`` per robot that changes
        hands (``task = service = -1``: released).

    Notes
    -----
    The auction (algorithms.md §6).  Wages are whole multiples of ``eps``, kept as integers
    (units of ``eps``), all 0 at the start; a task's utility ``u[j]`` becomes the integer
    budget ``floor(u[j] / eps)`` (exact, with fractions), so every comparison is exact.
    A round: the tasks that are not fully staffed act one after another in index order, each
    on the state left by the previous ones (choice: sequential, not simultaneous, so there
    are no conflicting bids to resolve).  A task prices every robot at ``wage + eps`` -- a
    task that is not fully staffed holds no robot (it released them all when it lost one),
    so §6's "robots it already holds at their wage" never applies -- and finds its cheapest
    complete bundle; if the bundle costs ``<= u[j]`` it takes all of it.  Every robot it
    acquires, free or taken from another task, now earns ``wage + eps`` (choice: the price
    the bid was computed with; §6 names the taken robots, free robots are priced the same
    way).  A task that loses a robot is no longer staffed and releases its other robots,
    whose wages are kept; if its index is after the acting task it acts again in the same
    round, otherwise in the next.  The auction stops after a round in which no task bid
    (that quiet round is counted).

    Tie-break (choice): among bundles of equal cost, fewest robots taken from other tasks,
    then the least sum of robot indices (see :mod:`heuristics._auction`).  A task that
    cannot afford its cheapest bundle, or has none, never bids again: wages never fall, so
    its cheapest cost never falls; the engine skips it (its work is still counted).

    Termination.  Every acquisition raises at least one wage by one unit and no wage
    exceeds ``floor(u_max / eps)`` units (a robot is bought at ``wage + 1 <= budget``), so
    ``rounds <= n floor(u_max / eps) + 1``; with the default ``eps = 1/n`` and integer
    utilities that is ``n^2 u_max + 1``.

    Counting.  Messages (header 8 bytes, entries 12 bytes): an acting task that bids sends
    one message to each service agent of its needed services (``r_js`` entries) and gets an
    answer from each (header only); after an acquisition every service agent with a robot
    whose wage or holder changed (the bundle and the robots the losers released) tells every
    other task needing its service (one entry per changed robot); a task that lost a robot
    sends a release to the service agent of each service its released robots performed (one
    entry per robot).  A task that does not bid sends nothing.  ``work`` counts cost-matrix
    entries of the bundle selections the literal auction performs: each acting task, each
    time it acts, matches ``(robots having one of its services) x k_j`` entries.

    Complexity: O(rounds x acting tasks x M) where ``M`` is one matching on at most
    ``k_j |S_j|`` candidates; the number of rounds is bounded as above and in practice far
    smaller (see ``benchmarks/bench_auctions.py``).

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    >>> run = rachna_dt(m)          # task 0 takes robot 0; task 1 outbids it (only robot 0
    >>> run.trajectory.tolist()     # has service 1); task 0 re-forms with robot 1
    [[1, 0, 0, 0], [1, 0, 1, 1], [2, 1, 0, 0]]
    >>> run.assignment.task.tolist(), run.iterations, run.rounds
    ([1, 0], 2, 3)
    """
    started = time.perf_counter()
    require_mission(mission)
    n = mission.n_robots
    eps_q = Fraction(1, max(n, 1)) if eps is None else check_eps(eps)
    check_order(order)
    np.random.default_rng(seed)  # validates the seed; RACHNA_dt draws nothing
    out = _core(mission, eps_q)
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
        trajectory=np.array(out.moves, dtype=np.int64).reshape(-1, 4),
        options=(("eps", str(eps_q)), ("order", order)),
    )


@dataclass
class _Outcome:
    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    iterations: int = 0
    rounds: int = 0
    messages: int = 0
    bytes: int = 0
    work: int = 0
    moves: list[tuple[int, int, int, int]] = field(default_factory=list)


def _core(mission: Mission, eps: Fraction) -> _Outcome:
    """The auction rounds; see :func:`rachna_dt` Notes for the method."""
    caps, reqs = mission.capabilities, mission.requirements
    n = caps.shape[0]
    m = reqs.shape[0]
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    finder = BundleFinder(caps, reqs)
    k = finder.k
    budget = [math.floor(Fraction(float(x)) / eps) for x in mission.utilities.tolist()]
    need64 = (reqs > 0).astype(np.int64)
    caps64 = caps.astype(np.int64)
    m_s = need64.sum(axis=0)  # tasks needing each service
    rows = ((caps64 @ need64.T) > 0).sum(axis=0)
    match_work = [int(rows[j]) * k[j] for j in range(m)]
    wage = np.zeros(n, dtype=np.int64)  # units of eps
    held = np.zeros(n, dtype=np.int64)  # 1 when some task holds the robot
    holder = out.task  # shared: the assignment is the holder map
    members: list[npt.NDArray[np.int64]] = [np.zeros(0, dtype=np.int64) for _ in range(m)]
    staffed = np.zeros(m, dtype=bool)
    dead = np.zeros(m, dtype=bool)
    dead_work = 0
    pools = finder.robots_with
    next_round = list(range(m))
    while True:
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
                    for r in rel.tolist():
                        out.moves.append((it, r, -1, -1))
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
            for r, s in sorted(zip(robots.tolist(), b.services.tolist(), strict=True)):
                out.moves.append((it, r, j, s))
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
    return out
