"""Nash stability under GRAPE-S-Select's completion reward, checked exactly.

This module implements the reward itself and imports nothing from ``heuristics`` (a
checker that calls the code it checks proves nothing); it shares only the data model
(:mod:`cfopt`) and :class:`proofs.stability.Move`.

Definitions
-----------
*Prices and priorities.*  ``N_s`` robots can perform service ``s``, the tasks demand
``D_s = sum_j req[j, s]`` of it; its price is ``p_s = max(1, D_s / N_s)`` (``N_s = 0``:
``max(1, D_s)``, immaterial since no task needing ``s`` can then be completed).  Task ``j``
is worth ``w_j = u_j / sum_s req[j, s] p_s``.  The *priority* ``pi_j`` is the position of
``j`` when the tasks are sorted by ``(w_j, -j)`` in increasing order: ``m - 1`` for the
most valuable task, equal worths favouring the lower index.  Worths are exact
:class:`fractions.Fraction` values throughout (no floats).

*Completion reward.*  Task ``j`` is *complete* when every slot holds at least ``req[j,
s]`` robots.  A robot that is one of ``c`` robots in slot ``(j, s)`` of a complete task of
positive utility earns ``(1, pi_j)`` (*needed*) when ``c <= req[j, s]`` and ``(0, pi_j)``
(*surplus*) when the slot is over-full; an unassigned robot, or one in an incomplete
task or a task of utility 0, earns ``bot``.  Rewards compare lexicographically, ``bot``
lowest; they are coded as the integers ``m + pi_j``, ``pi_j`` and :data:`BOTTOM` ``= -1``.

*Moves.*  Robot ``i`` may move to any slot ``(k, t)`` other than its own, ``t`` one of its
services.  The move earns the completion reward of ``(k, t)`` recomputed after the move
(the robot leaves its slot and joins ``(k, t)``).  A move is a *violation* when it earns
strictly more than the robot earns now.

Which moves can pay: joining a task that stays incomplete earns ``bot``; joining a
complete task earns a surplus place ``(0, pi_k)`` (its slots are full), which pays only
from another task; completing a task that is exactly one robot short, at ``t``, earns a
needed place ``(1, pi_k)`` -- from within that task only out of an over-full slot (else
the move opens a new gap).  :func:`select_violations` lists, per robot with a violation,
its best move: the highest reward, then the lowest ``(task, service)``.

Examples
--------
>>> import cfopt
>>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 1])
>>> a = cfopt.Assignment(task=[1, 0, -1], service=[0, 0, -1])  # t0 needs one more
>>> select_priorities(m)          # w = 10/2, 1/1 (price max(1, 3/3) = 1)
[1, 0]
>>> completion_rewards(m, a)      # r0 needed in t1: 2 + pi = 2; r1 in incomplete t0
[2, -1, -1]
>>> [v.describe(m) for v in select_violations(m, a)]
['r0: t1/s0 -> t0/s0', 'r1: t0/s0 -> t1/s0', 'r2: - -> t0/s0']
>>> is_select_stable(m, cfopt.Assignment(task=[1, 0, 0], service=[0, 0, 0]))
True
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from cfopt import Assignment, Mission
from proofs.stability import Move

__all__ = [
    "BOTTOM",
    "SelectViolation",
    "completion_rewards",
    "is_select_stable",
    "select_priorities",
    "select_violations",
]

#: The reward of an unassigned robot, or of one whose task is incomplete or worthless.
BOTTOM = -1


@dataclass(frozen=True)
class SelectViolation(Move):
    """A robot's best strictly improving move under the completion reward.

    ``before`` and ``after`` are its rewards, coded as in the module notes.
    """

    before: int = BOTTOM
    after: int = BOTTOM


def select_priorities(mission: Mission) -> list[int]:
    """Per task its priority ``pi_j`` (module notes), computed with fractions only.

    O(m S) fraction operations and a sort.

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 0], [0, 1]], [[2, 0], [0, 1]], [8, 3])
    >>> select_priorities(m)          # s0: D = 2 > N = 1, price 2: w = 8/4 = 2 < 3/1
    [0, 1]
    """
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    utilities = mission.utilities.tolist()
    n_services = mission.n_services
    supply = [sum(1 for row in caps if row[s]) for s in range(n_services)]
    demand = [sum(row[s] for row in reqs) for s in range(n_services)]
    price = [
        max(Fraction(1), Fraction(demand[s], supply[s]) if supply[s] else Fraction(demand[s]))
        for s in range(n_services)
    ]
    worth = []
    for j, row in enumerate(reqs):
        cost = sum((Fraction(r) * price[s] for s, r in enumerate(row) if r), Fraction(0))
        worth.append((Fraction(utilities[j]) / cost, -j))
    ranked = sorted(range(len(reqs)), key=lambda j: worth[j])
    out = [0] * len(reqs)
    for position, j in enumerate(ranked):
        out[j] = position
    return out


@dataclass
class _State:
    reqs: list[list[int]]
    counts: list[list[int]]
    missing: list[list[int]]
    slots: list[tuple[int, int] | None]
    pi: list[int]
    worthy: list[bool]  # positive utility

    def complete(self, j: int) -> bool:
        return sum(self.missing[j]) == 0

    def reward(self, i: int) -> int:
        slot = self.slots[i]
        if slot is None:
            return BOTTOM
        j, s = slot
        if not (self.worthy[j] and self.complete(j)):
            return BOTTOM
        m = len(self.reqs)
        return m + self.pi[j] if self.counts[j][s] <= self.reqs[j][s] else self.pi[j]


def _state(mission: Mission, assignment: Assignment) -> _State:
    assignment.validate(mission)
    reqs = mission.requirements.tolist()
    n_services = mission.n_services
    counts = [[0] * n_services for _ in reqs]
    slots: list[tuple[int, int] | None] = []
    for t, s in zip(assignment.task.tolist(), assignment.service.tolist(), strict=True):
        slots.append(None if t < 0 else (t, s))
        if t >= 0:
            counts[t][s] += 1
    missing = [
        [max(r - c, 0) for r, c in zip(reqs[j], counts[j], strict=True)] for j in range(len(reqs))
    ]
    worthy = [u > 0 for u in mission.utilities.tolist()]
    return _State(reqs, counts, missing, slots, select_priorities(mission), worthy)


def completion_rewards(mission: Mission, assignment: Assignment) -> list[int]:
    """Every robot's completion reward, coded as in the module notes.

    ``assignment`` must be valid for ``mission`` (else :class:`cfopt.MissionError`).
    """
    st = _state(mission, assignment)
    return [st.reward(i) for i in range(len(st.slots))]


def select_violations(mission: Mission, assignment: Assignment) -> list[SelectViolation]:
    """Every robot that has a strictly better move, with its best move.

    Parameters
    ----------
    mission : cfopt.Mission
    assignment : cfopt.Assignment
        Any valid assignment (over-full and short slots included).

    Returns
    -------
    list of SelectViolation
        In robot order; empty when the partition is Nash stable under the completion
        reward.

    Notes
    -----
    Per service, the tasks exactly one robot short there and the complete tasks needing
    it are ranked by priority; each robot looks, per service it has, at the best one it
    can use (the next one when the best is its own task and the move cannot pay).
    O(n S + m S + m log m), exact integers and fractions.
    """
    st = _state(mission, assignment)
    m = len(st.reqs)
    n_services = mission.n_services
    completes: list[list[int]] = [[] for _ in range(n_services)]  # one short at t
    joins: list[list[int]] = [[] for _ in range(n_services)]  # complete, needs t
    for k in range(m):
        if not st.worthy[k]:
            continue
        short = sum(st.missing[k])
        if short == 1:
            completes[st.missing[k].index(1)].append(k)
        elif short == 0:
            for t in range(n_services):
                if st.reqs[k][t] > 0:
                    joins[t].append(k)
    for lists in (completes, joins):
        for lst in lists:
            lst.sort(key=lambda k: -st.pi[k])
    caps = mission.capabilities.tolist()
    out: list[SelectViolation] = []
    for i, slot in enumerate(st.slots):
        own = None if slot is None else slot[0]
        spare = slot is not None and st.counts[own][slot[1]] > st.reqs[own][slot[1]]
        best: tuple[int, int, int] | None = None  # (reward, -task, -service)
        for t in range(n_services):
            if not caps[i][t]:
                continue
            for k in completes[t]:
                if k != own or spare:  # from within k only out of an over-full slot
                    best = max(best or (BOTTOM, 0, 0), (m + st.pi[k], -k, -t))
                    break
            for k in joins[t]:
                if k != own:
                    best = max(best or (BOTTOM, 0, 0), (st.pi[k], -k, -t))
                    break
        now = st.reward(i)
        if best is not None and best[0] > now:
            out.append(
                SelectViolation(
                    robot=i, source=slot, target=(-best[1], -best[2]), before=now, after=best[0]
                )
            )
    return out


def is_select_stable(mission: Mission, assignment: Assignment) -> bool:
    """Whether no robot has a strictly better move under the completion reward.

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1]], [[1]], [2.0])
    >>> is_select_stable(m, cfopt.Assignment.empty(m)), is_select_stable(
    ...     m, cfopt.Assignment(task=[0], service=[0]))
    (False, True)
    """
    return not select_violations(mission, assignment)
