"""Sequential best-response dynamics with the checkers' reward (for strategies and benchmarks).

Not a heuristic under audit: a small, exact way to reach a Nash-stable partition so that
``proofs.strategies.near_stable_assignments`` and the benchmarks have stable partitions
without importing ``heuristics``.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

import numpy as np

from cfopt import Assignment, Mission

__all__ = ["best_response"]


def best_response(
    mission: Mission,
    start: Assignment | None = None,
    *,
    capped: bool = False,
    order: Sequence[int] | None = None,
) -> Assignment:
    """Let robots, one at a time, make their best strictly improving move until none can.

    Parameters
    ----------
    mission : cfopt.Mission
    start : cfopt.Assignment, optional
        The starting partition (default: everyone unassigned).
    capped : bool, default False
        Moves only into slots with fewer than ``req`` robots.
    order : sequence of int, optional
        The order in which robots are visited in every sweep (default: index order).

    Returns
    -------
    cfopt.Assignment
        A Nash-stable partition (for the same ``capped``).

    Notes
    -----
    A robot's best move is the slot with the lowest load ``(c + 1) / req`` among the slots
    of its services, ties to the first slot in task-then-service order (the checkers'
    rule).  The dynamics terminate: the potential ``sum over slots of sum_{k <= c}
    k / req`` plus ``n + 1`` per unassigned robot drops with every move (a singleton
    congestion game).  Each visit costs O(m S) numpy work; exact (floats only
    short-list the minimum, which is then decided with fractions).

    Examples
    --------
    >>> import cfopt, proofs
    >>> m = cfopt.generate_mission(30, 10, 5, 2, seed=4)
    >>> a = best_response(m)
    >>> proofs.is_nash_stable(m, a)
    True
    """
    n, S = mission.n_robots, mission.n_services
    start = Assignment.empty(mission) if start is None else start
    cnt = start.counts(mission).reshape(-1).astype(np.int64)
    req = mission.requirements.reshape(-1).astype(np.int64)
    valid = req > 0
    svc = np.arange(req.size) % S
    able = mission.capabilities[:, svc] & valid[None, :]  # n x (m S)
    pos = np.where(start.task >= 0, start.task * S + start.service, -1)
    visit = list(range(n)) if order is None else [int(i) for i in order]
    if sorted(visit) != list(range(n)):
        raise ValueError("order: must be a permutation of the robots")
    safe_req = np.where(valid, req, 1)
    moved = True
    while moved:
        moved = False
        for i in visit:
            mask = able[i].copy()
            p = int(pos[i])
            if p >= 0:
                mask[p] = False
            if capped:
                mask &= cnt + 1 <= req
            cands = np.flatnonzero(mask)
            if cands.size == 0:
                continue
            f = (cnt[cands] + 1) / safe_req[cands]
            short = cands[f == f.min()]
            q = int(min(short.tolist(), key=lambda x: (Fraction(int(cnt[x]) + 1, int(req[x])), x)))
            if p >= 0 and (cnt[q] + 1) * req[p] >= cnt[p] * req[q]:
                continue
            if p >= 0:
                cnt[p] -= 1
            cnt[q] += 1
            pos[i] = q
            moved = True
    task = np.where(pos >= 0, pos // S, -1)
    service = np.where(pos >= 0, pos % S, -1)
    return Assignment(task=task, service=service)
