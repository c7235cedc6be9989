"""Nash and pairwise stability of a partition, checked exactly, with concrete violations.

The reward is the seed paper's GRAPE-S reward with ``u_js = req[j, s]``: a robot that is
one of ``c`` robots performing ``s`` for task ``j`` earns ``exp(1 - c / req[j, s])``, an
unassigned robot earns 0.  The reward is strictly decreasing in the *load*
``c / req[j, s]``, so every comparison here is a comparison of loads, done exactly by
integer cross-multiplication (never with floats); an unassigned robot has load
``+inf``.  This module implements the reward itself and imports nothing from
``heuristics`` (a checker that calls the code it checks proves nothing).

Definitions (the toolkit's, stated once here and in the README)
----------------------------------------------------------------
*Slot*: a pair ``(j, s)`` with ``req[j, s] > 0``; slots are ordered by task, then
service (flat index ``j * S + s``).  This order breaks every tie.

*Move* of robot ``i``: to a slot other than its current one whose service it has; it is
evaluated with the robot counted in, ``(c + 1) / req``.  ``capped=True`` forbids moving
into a slot that would then hold more than ``req`` robots.

*Nash violation*: a move that strictly lowers the robot's load.  :func:`nash_violations`
lists **one violation per robot that has one: its best move** (lowest resulting load,
ties to the first slot in task-then-service order — what a best-responding robot such
as a GRAPE-S robot would do).  So the list has at most ``n`` entries and replaying any
one of them is a best response.

*Joint deviation* of two robots ``a != b``: **each of the two changes position** (a robot
that keeps its slot is not deviating: a deviation in which one robot stays is an
individual deviation of the other, which the Nash part covers); each goes to a slot it
can perform or becomes unassigned; one may take the other's slot; loads are recomputed
after both moves.  ``capped=True``: a robot may only enter a slot that holds at most
``req`` robots after the deviation.  It is a violation when it leaves

- ``mode="strict"`` (the seed's Theorem 1): both robots strictly better off;
- ``mode="pareto"``: neither worse off and at least one strictly better off.

*Pairwise stable* = no individual (Nash) violation and no joint violation.
:func:`pairwise_violations` therefore lists the individual deviations first (one per
robot, exactly :func:`nash_violations` as one-robot entries, ``kind == "individual"``;
pass ``individual=False`` to omit them) and then the joint ones (``kind == "joint"``):
**for every robot** ``a`` **that takes part in some joint violation, one entry**
``robots == (a, b)`` where ``b`` is the lowest-index partner with which ``a`` has a joint
violation, and the moves are the best ones for ``a`` among that pair's joint violations
(lowest load for ``a``, then lowest load for ``b``, then first slot for ``a``, then for
``b``).  At most ``2 n`` entries in all, and the empty list means stable.

What the joint deviations can be (the reason the check is fast)
----------------------------------------------------------------
Loads depend on slot counts only.  Becoming unassigned never helps (load ``+inf``), so
both robots go to slots ``q_a != p_a`` and ``q_b != p_b``; four cases remain:

1. *swap* (``q_a = p_b``, ``q_b = p_a``): counts do not change and the robots exchange
   loads — never a violation in either mode;
2. *replacement* (``q_a = p_b``, ``q_b`` elsewhere): ``a`` gets ``b``'s current load,
   ``b`` gets ``(c[q_b] + 1) / req``, exactly as if it moved alone;
3. *same new slot* (``q_a = q_b = q``): both get ``(c[q] + 2) / req``;
4. *independent* (all other cases): each gets its individual-move load.

In strict mode cases 2-4 need an individually improving move, so strict pairwise
stability coincides with Nash stability (for this reward and these move sets, capped or
not).  In pareto mode a *tie* move (load unchanged) of ``b`` lets an unassigned or more
loaded ``a`` take ``b``'s slot — the exchange Pair-GRAPE-S makes — so the notions differ.

The checker groups robots into *classes* (current slot, service set): robots in a class
are interchangeable.  For each class it keeps the three best targets (exchanging at
most two excluded slots, ``p_b`` and the partner's target, always leaves one of them).
Every target is one of the per-service best slots ``T`` (``|T| <= 4 S``), and loads
are totally ordered, so each of cases 2-4 is answered for all classes at once — the
lowest partner class per class — by look-ups keyed on ``T`` and on exact load ranks
(prefix minima over rank-sorted classes), never by comparing every pair of classes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError
from cfopt.checks import (
    is_whole,
    require_assignment,
    require_bool,
    require_int,
    require_mission,
    shown,
)
from cfopt.errors import MissionTypeError

__all__ = [
    "MODES",
    "Move",
    "NashViolation",
    "PairwiseViolation",
    "is_nash_stable",
    "is_pairwise_stable",
    "nash_violations",
    "pairwise_violations",
]

#: The pairwise modes: both strictly better (the seed's), or a Pareto improvement.
MODES = ("strict", "pareto")
Mode = Literal["strict", "pareto"]
Slot = tuple[int, int]

_IntArray = npt.NDArray[np.int64]
_NONE = -1
_TOP = 3  # targets kept per class: enough to survive two excluded slots


# --------------------------------------------------------------------- violations
@dataclass(frozen=True)
class Move:
    """One robot going from ``source`` to ``target`` (``(task, service)`` rows/columns, or
    ``None`` for unassigned).

    Examples
    --------
    >>> m = Mission.from_arrays([[1, 1], [1, 0]], [[1, 1]], [3.0])
    >>> a = Assignment(task=[0, -1], service=[1, -1])
    >>> mv = Move(robot=0, source=(0, 1), target=(0, 0))
    >>> mv.apply(a).task.tolist(), mv.apply(a).service.tolist()
    ([0, -1], [0, -1])
    >>> mv.to_dict(m)
    {'robot': 'r0', 'from': {'task': 't0', 'service': 's1'}, 'to': {'task': 't0', 'service': 's0'}}
    """

    robot: int
    source: Slot | None
    target: Slot | None

    def __post_init__(self) -> None:
        require_int("robot", self.robot, minimum=0)
        _check_slot("source", self.source)
        _check_slot("target", self.target)

    def apply(self, assignment: Assignment) -> Assignment:
        """A new assignment with this move made (the robot must be at ``source``)."""
        return _apply((self,), assignment)

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """``{"robot", "from", "to"}`` with ids and names (what ``cfopt check --json`` lists)."""
        require_mission(mission)
        return {
            "robot": mission.robot_ids[self.robot],
            "from": _slot_dict(mission, self.source),
            "to": _slot_dict(mission, self.target),
        }

    def describe(self, mission: Mission) -> str:
        """``r3: t0/lift -> t2/survey`` (``-`` for unassigned)."""
        require_mission(mission)
        return (
            f"{mission.robot_ids[self.robot]}: {_slot_text(mission, self.source)} -> "
            f"{_slot_text(mission, self.target)}"
        )


@dataclass(frozen=True)
class NashViolation(Move):
    """A robot's best strictly improving move (see the module notes for the tie-break)."""


@dataclass(frozen=True)
class PairwiseViolation:
    """A deviation by one robot (``kind == "individual"``) or two (``"joint"``).

    ``moves[k]`` is the move of ``robots[k]``; :meth:`apply` makes them all at once.
    """

    robots: tuple[int, ...]
    moves: tuple[Move, ...]

    def __post_init__(self) -> None:
        robots, moves = self.robots, self.moves
        if not isinstance(robots, tuple) or not all(is_whole(i) and i >= 0 for i in robots):
            raise MissionTypeError(
                f"robots: must be a tuple of robot indices >= 0, got {shown(robots)}"
            )
        if not isinstance(moves, tuple) or not all(isinstance(mv, Move) for mv in moves):
            raise MissionTypeError(f"moves: must be a tuple of proofs.Move, got {shown(moves)}")
        if len(moves) != len(robots) or not 1 <= len(robots) <= 2:
            raise MissionError(
                f"moves: one move per robot of robots (one or two), got {len(moves)} moves "
                f"for {len(robots)} robots"
            )

    @property
    def kind(self) -> str:
        """``"individual"`` (a Nash violation) or ``"joint"``."""
        return "individual" if len(self.robots) == 1 else "joint"

    def apply(self, assignment: Assignment) -> Assignment:
        """A new assignment with every move of the deviation made simultaneously."""
        return _apply(self.moves, assignment)

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """``{"robots": [...], "moves": [...], "kind": ...}``, as ``cfopt check --json`` lists."""
        require_mission(mission)
        return {
            "robots": [mission.robot_ids[i] for i in self.robots],
            "moves": [mv.to_dict(mission) for mv in self.moves],
            "kind": self.kind,
        }

    def describe(self, mission: Mission) -> str:
        """The moves, joined by ``" & "``."""
        require_mission(mission)
        return " & ".join(mv.describe(mission) for mv in self.moves)


def _check_slot(name: str, slot: Any) -> None:
    if slot is not None and not (
        isinstance(slot, tuple) and len(slot) == 2 and all(is_whole(k) and k >= 0 for k in slot)
    ):
        raise MissionTypeError(
            f"{name}: must be a (task, service) pair of indices >= 0 or None, got {shown(slot)}"
        )


def _slot_dict(mission: Mission, slot: Slot | None) -> dict[str, str] | None:
    if slot is None:
        return None
    return {"task": mission.task_ids[slot[0]], "service": mission.services[slot[1]]}


def _slot_text(mission: Mission, slot: Slot | None) -> str:
    if slot is None:
        return "-"
    return f"{mission.task_ids[slot[0]]}/{mission.services[slot[1]]}"


def _apply(moves: tuple[Move, ...], assignment: Assignment) -> Assignment:
    require_assignment(assignment)
    task, service = assignment.task.copy(), assignment.service.copy()
    for mv in moves:
        if not 0 <= mv.robot < task.size:
            raise MissionError(f"move: robot {mv.robot} is not in the assignment")
        here = None if task[mv.robot] < 0 else (int(task[mv.robot]), int(service[mv.robot]))
        if here != mv.source:
            raise MissionError(
                f"move: robot {mv.robot} is at {here}, not at {mv.source} as the move says"
            )
    for mv in moves:
        task[mv.robot], service[mv.robot] = mv.target if mv.target is not None else (-1, -1)
    return Assignment(task=task, service=service)


# ------------------------------------------------------------------- public checks
def nash_violations(
    mission: Mission, assignment: Assignment, *, capped: bool = False
) -> list[NashViolation]:
    """Every robot that has a strictly better move, with its best move.

    Parameters
    ----------
    mission : cfopt.Mission
    assignment : cfopt.Assignment
        Must be valid for ``mission`` (otherwise :class:`cfopt.MissionError`).
    capped : bool, default False
        Only moves into slots that are not full (``c < req``) count.

    Returns
    -------
    list of NashViolation
        In robot order, one per robot that can strictly lower its load: its best move
        (lowest load ``(c + 1) / req``, ties to the first slot in task-then-service
        order).  Empty when the partition is Nash stable.

    Notes
    -----
    Exact (integer cross-multiplication).  O(n S + m S log(m S)) time: per service
    the two best slots, then per robot the best over its services.

    Examples
    --------
    >>> m = Mission.from_arrays([[1], [1], [1]], [[1], [2]], [1.0, 1.0])
    >>> a = Assignment(task=[0, 0, 1], service=[0, 0, 0])   # two robots crowd t0
    >>> [v.to_dict(m) for v in nash_violations(m, a)]  # doctest: +NORMALIZE_WHITESPACE
    [{'robot': 'r0', 'from': {'task': 't0', 'service': 's0'},
                     'to': {'task': 't1', 'service': 's0'}},
     {'robot': 'r1', 'from': {'task': 't0', 'service': 's0'},
                     'to': {'task': 't1', 'service': 's0'}}]
    >>> nash_violations(m, a, capped=False)[0].apply(a).task.tolist()
    [1, 0, 1]
    >>> nash_violations(m, Assignment(task=[0, 1, 1], service=[0, 0, 0]))
    []
    """
    state = _State(mission, assignment, capped)
    robots, targets = state.nash()
    return [
        state.nash_violation(i, q) for i, q in zip(robots.tolist(), targets.tolist(), strict=True)
    ]


def is_nash_stable(mission: Mission, assignment: Assignment, *, capped: bool = False) -> bool:
    """Whether no robot has a strictly better move (see :func:`nash_violations`).

    >>> m = Mission.from_arrays([[1], [1]], [[1], [1]], [1.0, 1.0])
    >>> is_nash_stable(m, Assignment(task=[0, 1], service=[0, 0]))
    True
    >>> is_nash_stable(m, Assignment.empty(m))
    False
    """
    robots, _ = _State(mission, assignment, capped).nash()
    return robots.size == 0


def pairwise_violations(
    mission: Mission,
    assignment: Assignment,
    *,
    mode: Mode = "strict",
    capped: bool = False,
    individual: bool = True,
) -> list[PairwiseViolation]:
    """Deviations by one or two robots that make the deviators better off.

    Parameters
    ----------
    mission : cfopt.Mission
    assignment : cfopt.Assignment
        Must be valid for ``mission`` (otherwise :class:`cfopt.MissionError`).
    mode : {"strict", "pareto"}, default "strict"
        ``"strict"``: both robots strictly better off (the seed's Theorem 1);
        ``"pareto"``: neither worse off, at least one strictly better off.
    capped : bool, default False
        Robots may only enter slots that hold at most ``req`` robots afterwards.
    individual : bool, default True
        List the individual deviations (the Nash violations, as one-robot entries)
        before the joint ones.  With ``False`` only joint deviations are listed (and an
        empty list no longer means pairwise stable).

    Returns
    -------
    list of PairwiseViolation
        Individual deviations in robot order, then for every robot ``a`` that takes part
        in a joint violation one entry ``robots == (a, b)``: ``b`` the lowest-index
        partner, moves the best for ``a`` (module notes give the full tie-break).
        Empty (with ``individual=True``) exactly when the partition is pairwise stable.

    Notes
    -----
    Exact.  Robots are grouped into ``C <= n`` classes by (current slot, service set);
    each case of a joint deviation is answered for all classes at once by indexed
    look-ups (module notes), so the time is O(n S + (S + |T|) C log C + |T|^2 G +
    m S log(m S)), ``|T| <= 4 S`` the per-service best slots and ``G <= C`` the
    classes' distinct target signatures — never all pairs of robots or of classes.

    Examples
    --------
    Slots are capped.  ``r1`` fills ``t0`` (which needs one robot); ``r0`` is unassigned
    and can only do ``t0``'s service; ``t1`` needs two robots and has one.  No robot can
    improve alone, but if ``r1`` moves to ``t1`` (same load, 2/2 = 1/1) and ``r0`` takes
    ``t0``, ``r0`` is strictly better off and ``r1`` no worse: a Pareto deviation — the
    exchange Pair-GRAPE-S makes — and not a strict one.

    >>> m = Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 2]], [5.0, 5.0])
    >>> a = Assignment(task=[-1, 0, 1], service=[-1, 0, 1])
    >>> pairwise_violations(m, a, capped=True)
    []
    >>> [v.describe(m) for v in pairwise_violations(m, a, mode="pareto", capped=True)]
    ['r0: - -> t0/s0 & r1: t0/s0 -> t1/s1', 'r1: t0/s0 -> t1/s1 & r0: - -> t0/s0']
    >>> pairwise_violations(m, a, mode="pareto", capped=True)[0].apply(a).task.tolist()
    [0, 1, 1]
    >>> [v.kind for v in pairwise_violations(m, a, mode="pareto")]  # uncapped: r0 can crowd t0
    ['individual', 'joint', 'joint']
    """
    return _pairwise(mission, assignment, mode, capped, individual, _FastJoint)


def _pairwise_violations_reference(
    mission: Mission,
    assignment: Assignment,
    *,
    mode: Mode = "strict",
    capped: bool = False,
    individual: bool = True,
) -> list[PairwiseViolation]:
    """:func:`pairwise_violations` by the original O(C^2) class-against-class loop.

    Kept as the reference the indexed decision is tested against (same list, same order).
    """
    return _pairwise(mission, assignment, mode, capped, individual, _Joint)


def _pairwise(
    mission: Mission,
    assignment: Assignment,
    mode: Mode,
    capped: bool,
    individual: bool,
    joint: type[_Joint],
) -> list[PairwiseViolation]:
    _check_mode(mode)
    individual = require_bool("individual", individual)
    state = _State(mission, assignment, capped)
    out: list[PairwiseViolation] = []
    if individual:
        robots, targets = state.nash()
        for i, q in zip(robots.tolist(), targets.tolist(), strict=True):
            v = state.nash_violation(i, q)
            out.append(PairwiseViolation(robots=(i,), moves=(v,)))
    out.extend(joint(state, mode).violations())
    return out


def is_pairwise_stable(
    mission: Mission, assignment: Assignment, *, mode: Mode = "strict", capped: bool = False
) -> bool:
    """Whether no one robot and no two robots can deviate profitably.

    Answers ``False`` as soon as one robot can deviate alone; otherwise decides the joint
    deviations of all classes at once, without building the violations.  See
    :func:`pairwise_violations`.

    >>> m = Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 2]], [5.0, 5.0])
    >>> a = Assignment(task=[-1, 0, 1], service=[-1, 0, 1])
    >>> is_pairwise_stable(m, a, capped=True), is_pairwise_stable(m, a, mode="pareto", capped=True)
    (True, False)
    """
    return _stable(mission, assignment, mode, capped, _FastJoint)


def _is_pairwise_stable_reference(
    mission: Mission, assignment: Assignment, *, mode: Mode = "strict", capped: bool = False
) -> bool:
    """:func:`is_pairwise_stable` by the original O(C^2) loop (the tests' reference)."""
    return _stable(mission, assignment, mode, capped, _Joint)


def _stable(
    mission: Mission, assignment: Assignment, mode: Mode, capped: bool, joint: type[_Joint]
) -> bool:
    _check_mode(mode)
    state = _State(mission, assignment, capped)
    robots, _ = state.nash()
    if robots.size:
        return False
    return not joint(state, mode).any()


def _check_mode(mode: object) -> None:
    if mode not in MODES:
        raise ValueError(f"mode: must be one of {', '.join(map(repr, MODES))}, got {mode!r}")


# ------------------------------------------------------------------------ the state
def _exact_order(num: _IntArray, den: _IntArray, key: _IntArray) -> _IntArray:
    """Permutation sorting ``num/den`` ascending, ties by ``key``, exactly.

    Floats propose the order (equal fractions give equal correctly-rounded floats); the
    order is then verified pair by pair with integers, with an exact fallback.
    """
    if num.size < 2:
        return np.arange(num.size)
    order = np.lexsort((key, num / den))
    a, b = order[:-1], order[1:]
    lhs, rhs = num[a] * den[b], num[b] * den[a]
    if np.all((lhs < rhs) | ((lhs == rhs) & (key[a] < key[b]))):
        return order
    exact = sorted(range(num.size), key=lambda k: (Fraction(int(num[k]), int(den[k])), int(key[k])))
    return np.asarray(exact, dtype=np.int64)


class _State:
    """Counts, loads and the per-service best slots of one (mission, assignment)."""

    def __init__(self, mission: Mission, assignment: Assignment, capped: bool) -> None:
        require_mission(mission)
        require_assignment(assignment)
        self.capped = require_bool("capped", capped)
        counts = assignment.counts(mission)  # validates
        self.mission = mission
        m, S = mission.n_tasks, mission.n_services
        self.S = S
        self.caps = mission.capabilities
        self.req = mission.requirements.reshape(-1).astype(np.int64)
        self.cnt = counts.reshape(-1).astype(np.int64)
        self.valid = self.req > 0
        slots = np.arange(m * S, dtype=np.int64)
        self.svc = slots % S
        # robot positions and loads; unassigned = (1, 0), i.e. +inf
        t = assignment.task
        self.pos = np.where(t >= 0, t * S + assignment.service, _NONE)
        on = self.pos >= 0
        safe = np.where(on, self.pos, 0)
        padded_cnt, padded_req = np.append(self.cnt, 0), np.append(self.req, 0)
        self.vnum = np.where(on, padded_cnt[safe], 1)
        self.vden = np.where(on, padded_req[safe], 0)
        # one robot joining (w1) / two joining (w2); allowed sets
        cap = self.req if self.capped else np.iinfo(np.int64).max
        self.ok1 = self.valid & (self.cnt + 1 <= cap)
        self.ok2 = self.valid & (self.cnt + 2 <= cap)
        self.ok0 = self.valid & (self.cnt <= cap)
        self.n_slots = m * S
        self.rank1, self.top1, self.order1 = self._ranking(self.cnt + 1, self.ok1, 4)
        self.rank2, self.top2, _ = self._ranking(self.cnt + 2, self.ok2, 3)

    def _ranking(self, num: _IntArray, ok: npt.NDArray[np.bool_], k: int):
        """Exact rank of every allowed slot by (num/req, slot) and the top ``k`` per service."""
        idx = np.flatnonzero(ok)
        order = idx[_exact_order(num[idx], self.req[idx], idx)]
        big = self.n_slots + 1
        rank = np.full(self.n_slots + 1, big, dtype=np.int64)  # rank[-1] = big: no slot
        rank[order] = np.arange(order.size)
        top = np.full((self.S, k), _NONE, dtype=np.int64)
        by_service = order[np.argsort(self.svc[order], kind="stable")]
        starts = np.searchsorted(self.svc[by_service], np.arange(self.S + 1))
        for s in range(self.S):
            chunk = by_service[starts[s] : min(starts[s + 1], starts[s] + k)]
            top[s, : chunk.size] = chunk
        return rank, top, order

    # ------------------------------------------------------------------------ Nash
    def nash(self) -> tuple[_IntArray, _IntArray]:
        """Robots with a strictly improving move and their best targets."""
        n = self.pos.size
        if n == 0 or self.n_slots == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        first, second = self.top1[:, 0], self.top1[:, 1]
        cand = np.where(first[None, :] == self.pos[:, None], second[None, :], first[None, :])
        ranks = np.where(self.caps, self.rank1[cand], self.n_slots + 1)
        best_s = np.argmin(ranks, axis=1)
        rows = np.arange(n)
        target = cand[rows, best_s]
        has = ranks[rows, best_s] <= self.n_slots
        t = np.where(has, target, 0)
        better = has & ((self.cnt[t] + 1) * self.vden < self.vnum * self.req[t])
        robots = np.flatnonzero(better)
        return robots, target[robots]

    def slot(self, q: int) -> Slot | None:
        return None if q < 0 else (q // self.S, q % self.S)

    def nash_violation(self, i: int, q: int) -> NashViolation:
        return NashViolation(robot=i, source=self.slot(int(self.pos[i])), target=self.slot(q))


# ------------------------------------------------------------------ joint deviations
def _lt(an, ad, bn, bd):
    """a < b for fractions a = an/ad, b = bn/bd (denominators >= 0, x/0 = +inf)."""
    return an * bd < bn * ad


def _le(an, ad, bn, bd):
    return an * bd <= bn * ad


class _Joint:
    """The joint (two-robot) deviations, decided class against class.

    The O(C^2) reference; the public functions use :class:`_FastJoint`, which shares
    everything but the decision of which class pairs have a violation.
    """

    def __init__(self, state: _State, mode: str) -> None:
        self.st = st = state
        self.strict = mode == "strict"
        n = st.pos.size
        if n < 2 or state.n_slots == 0:
            self.C = 0
            return
        S = st.S
        key = np.concatenate([st.pos[:, None], st.caps.astype(np.int64)], axis=1)
        rows, inverse = np.unique(key, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        self.C = C = rows.shape[0]
        self.robot_class = inverse
        self.p = rows[:, 0].copy()
        self.K = rows[:, 1:].astype(bool)
        on = self.p >= 0
        safe = np.where(on, self.p, 0)
        self.vn = np.where(on, st.cnt[safe], 1)
        self.vd = np.where(on, st.req[safe], 0)
        # members: first and second robot index of each class
        order = np.lexsort((np.arange(n), inverse))
        starts = np.searchsorted(inverse[order], np.arange(C))
        ends = np.append(starts[1:], n)
        self.first = order[starts]
        self.second = np.where(ends - starts >= 2, order[np.minimum(starts + 1, n - 1)], _NONE)
        # top weak targets per class (load <= current), from the per-service top 4
        cand = np.broadcast_to(st.top1[None, :, :], (C, S, st.top1.shape[1]))
        cand = np.where(self.K[:, :, None], cand, _NONE).reshape(C, -1)
        cand = np.where(cand == self.p[:, None], _NONE, cand)
        ranks = np.sort(st.rank1[cand], axis=1)[:, :_TOP]
        slot_of_rank = np.full(st.n_slots + 2, _NONE, dtype=np.int64)
        slot_of_rank[: st.order1.size] = st.order1
        t = slot_of_rank[ranks]
        ts = np.where(t >= 0, t, 0)
        weak = (t >= 0) & _le(st.cnt[ts] + 1, st.req[ts], self.vn[:, None], self.vd[:, None])
        self.t = np.where(weak, t, _NONE)
        ts = np.where(self.t >= 0, self.t, 0)
        self.tstrict = (self.t >= 0) & _lt(
            st.cnt[ts] + 1, st.req[ts], self.vn[:, None], self.vd[:, None]
        )

    # ----------------------------------------------------------------- per class
    def _compatible(self, A: int) -> npt.NDArray[np.bool_]:
        """Over all classes B: some a in A, b in B (a != b) have a joint violation."""
        st, strict = self.st, self.strict
        pA, vnA, vdA = int(self.p[A]), int(self.vn[A]), int(self.vd[A])
        pB, vnB, vdB, K = self.p, self.vn, self.vd, self.K
        tB, sB = self.t, self.tstrict
        tA, sA = self.t[A], self.tstrict[A]
        ok = np.zeros(self.C, dtype=bool)
        # case 4, independent moves: q_a in top(A), q_b in top(B), distinct, not the
        # other's current slot
        for i in range(_TOP):
            qa = int(tA[i])
            if qa < 0:
                break
            base = pB != qa
            for j in range(_TOP):
                good = base & (tB[:, j] >= 0) & (tB[:, j] != pA) & (tB[:, j] != qa)
                good &= (sA[i] & sB[:, j]) if strict else (sA[i] | sB[:, j])
                ok |= good
        # case 3, same new slot q (only needed when case 4 fails, so q is in top(A))
        for i in range(_TOP):
            q = int(tA[i])
            if q < 0:
                break
            if not st.ok2[q]:
                continue
            n2, d2 = int(st.cnt[q]) + 2, int(st.req[q])
            a_lt, a_le = n2 * vdA < vnA * d2, n2 * vdA <= vnA * d2
            if not a_le:
                continue
            b_lt, b_le = _lt(n2, d2, vnB, vdB), _le(n2, d2, vnB, vdB)
            good = (pB != q) & K[:, st.svc[q]] & b_le
            good &= (a_lt & b_lt) if strict else (a_lt | b_lt)
            ok |= good
        # case 2a, a takes p_B, b goes to its best target other than p_A
        pBs = np.where(pB >= 0, pB, 0)
        bt_first = tB[:, 0] != pA
        bt = np.where(bt_first, tB[:, 0], tB[:, 1])
        bst = np.where(bt_first, sB[:, 0], sB[:, 1])
        caps_a = st.caps[self.first[A]]
        good = (pB >= 0) & (pB != pA) & caps_a[st.svc[pBs]] & st.ok0[pBs] & (bt >= 0)
        b_lt_a, b_le_a = _lt(vnB, vdB, vnA, vdA), _le(vnB, vdB, vnA, vdA)
        good &= (b_lt_a & bst) if strict else (b_le_a & (b_lt_a | bst))
        ok |= good
        # case 2b, b takes p_A, a goes to its best target other than p_B
        if pA >= 0 and st.ok0[pA]:
            at_first = tA[0] != pB
            at = np.where(at_first, tA[0], tA[1])
            ast = np.where(at_first, sA[0], sA[1])
            a_lt_b, a_le_b = _lt(vnA, vdA, vnB, vdB), _le(vnA, vdA, vnB, vdB)
            good = (pB != pA) & K[:, st.svc[pA]] & (at >= 0)
            good &= (a_lt_b & ast) if strict else (a_le_b & (a_lt_b | ast))
            ok |= good
        # a != b: the own class needs a second member
        if self.second[A] < 0:
            ok[A] = False
        return ok

    def any(self) -> bool:
        return any(self._compatible(A).any() for A in range(self.C))

    def partners(self) -> tuple[_IntArray, _IntArray, npt.NDArray[np.bool_]]:
        """Per class ``A``: the first robot of the lowest other class with a joint violation
        with ``A`` and that class (``-1``: none), and whether two robots of ``A`` have one.

        The reference: one :meth:`_compatible` per class, O(C^2).
        """
        partner_first = np.full(self.C, _NONE, dtype=np.int64)  # best other class's first
        partner_class = np.full(self.C, _NONE, dtype=np.int64)
        own = np.zeros(self.C, dtype=bool)
        for A in range(self.C):
            ok = self._compatible(A)
            own[A] = ok[A]
            ok[A] = False
            cls = np.flatnonzero(ok)
            if cls.size:
                k = cls[np.argmin(self.first[cls])]
                partner_first[A], partner_class[A] = self.first[k], k
        return partner_first, partner_class, own

    def violations(self) -> list[PairwiseViolation]:
        if self.C == 0:
            return []
        partner_first, partner_class, own = self.partners()
        out: list[PairwiseViolation] = []
        cache: dict[tuple[int, int], tuple[int, int]] = {}
        for a in range(self.st.pos.size):
            A = int(self.robot_class[a])
            best, B = int(partner_first[A]), int(partner_class[A])
            if own[A]:
                mate = int(self.first[A]) if self.first[A] != a else int(self.second[A])
                if best < 0 or mate < best:
                    best, B = mate, A
            if best < 0:
                continue
            if (A, B) not in cache:
                cache[A, B] = self._best_moves(A, B)
            qa, qb = cache[A, B]
            st = self.st
            out.append(
                PairwiseViolation(
                    robots=(a, best),
                    moves=(
                        Move(a, st.slot(int(st.pos[a])), st.slot(qa)),
                        Move(best, st.slot(int(st.pos[best])), st.slot(qb)),
                    ),
                )
            )
        return out

    # ----------------------------------------------------------- canonical moves
    def _load(self, X: int) -> Fraction | float:
        return math.inf if self.vd[X] == 0 else Fraction(int(self.vn[X]), int(self.vd[X]))

    def _w(self, q: int, extra: int) -> Fraction:
        return Fraction(int(self.st.cnt[q]) + extra, int(self.st.req[q]))

    def _best_moves(self, A: int, B: int) -> tuple[int, int]:
        """The best joint violation for a in A with b in B: key (load_a, load_b, q_a, q_b)."""
        st = self.st
        pA, pB = int(self.p[A]), int(self.p[B])
        vA, vB = self._load(A), self._load(B)
        cands: list[tuple[Any, Any, int, int]] = []

        def accept(la: Any, lb: Any) -> bool:
            if la > vA or lb > vB:
                return False
            return (la < vA and lb < vB) if self.strict else (la < vA or lb < vB)

        tA = [int(q) for q in self.t[A] if q >= 0]
        tB = [int(q) for q in self.t[B] if q >= 0]
        for qa in tA:  # independent
            for qb in tB:
                if qa != qb and qa != pB and qb != pA:
                    la, lb = self._w(qa, 1), self._w(qb, 1)
                    if accept(la, lb):
                        cands.append((la, lb, qa, qb))
        common = np.flatnonzero(self.K[A] & self.K[B])
        same = [
            int(q)
            for s in common.tolist()
            for q in st.top2[s].tolist()
            if q >= 0 and q != pA and q != pB
        ]
        if same:  # same new slot: the best by (load, slot) decides
            q = min(same, key=lambda x: st.rank2[x])
            lq = self._w(q, 2)
            if accept(lq, lq):
                cands.append((lq, lq, q, q))
        caps_a, caps_b = st.caps[self.first[A]], st.caps[self.first[B]]
        if pB >= 0 and pB != pA and caps_a[pB % st.S] and st.ok0[pB]:  # a takes p_B
            rest = [q for q in tB if q != pA]
            if rest and accept(vB, self._w(rest[0], 1)):
                cands.append((vB, self._w(rest[0], 1), pB, rest[0]))
        if pA >= 0 and pA != pB and caps_b[pA % st.S] and st.ok0[pA]:  # b takes p_A
            rest = [q for q in tA if q != pB]
            if rest and accept(self._w(rest[0], 1), vA):
                cands.append((self._w(rest[0], 1), vA, rest[0], pA))
        if not cands:  # the class test and this enumeration disagree: a bug
            raise RuntimeError(f"internal error: classes {A} and {B} have no joint deviation")
        best = min(cands)
        return best[2], best[3]


# ------------------------------------------------------- joint deviations, indexed
class _FastJoint(_Joint):
    """The same relation as :class:`_Joint`, decided without comparing every class pair.

    ``ok(A, B)`` (some ``a`` in ``A`` and ``b`` in ``B``, ``a != b``, have a joint
    violation) is exactly :meth:`_Joint._compatible`'s test.  Each of its four cases is
    answered for all classes at once, as *the lowest first robot of a class* ``B != A``
    *satisfying it*, with lookups that only exploit where the case's conditions can
    differ between classes:

    - every target (a slot in some ``t``) lies in the set ``T`` of per-service best
      slots, ``|T| <= 4 S``; so a class's slot matters to the target conditions only
      when it lies in ``T``, and the queries of the target cases number O(|T|^2);
    - loads are compared through exact dense ranks, so "``b``'s load below ``a``'s" is
      a prefix of a rank-sorted list, answered by prefix minima and binary search;
    - "``B != A``" is kept by remembering the two lowest classes of every query.

    Time O((S + |T|) C log C + |T|^2 G), ``G <= C`` the distinct target signatures;
    memory O(C S).
    """

    def __init__(self, state: _State, mode: str) -> None:
        super().__init__(state, mode)
        self.big = state.pos.size  # stands for "no class": above every robot index
        if self.C == 0:
            return
        self.rank = _load_ranks(self.vn, self.vd)
        self.in_T = np.zeros(state.n_slots + 1, dtype=bool)  # [-1]: unassigned, not in T
        self.in_T[np.unique(self.t[self.t >= 0])] = True

    def partners(self) -> tuple[_IntArray, _IntArray, npt.NDArray[np.bool_]]:
        """As :meth:`_Joint.partners`, in O((S + |T|) C log C + |T|^2 G)."""
        everyone = np.arange(self.C)
        own = self._pair_ok(everyone, everyone) & (self.second >= 0)
        big = self.big
        best = np.minimum.reduce(
            [self._independent(), self._same_new_slot(), self._a_takes(), self._b_takes()]
        )
        found = best < big
        partner_first = np.where(found, best, _NONE)
        partner_class = np.where(found, self.robot_class[np.where(found, best, 0)], _NONE)
        return partner_first, partner_class, own

    def any(self) -> bool:
        if self.C == 0:
            return False
        partner_first, _, own = self.partners()
        return bool(own.any() or (partner_first >= 0).any())

    # --------------------------------------------------------------- literal pairs
    def _pair_ok(self, A: _IntArray, B: _IntArray) -> npt.NDArray[np.bool_]:
        """``_compatible(A[k])[B[k]]`` for every ``k``, without the ``a != b`` rule."""
        return (
            self._pair_independent(A, B)
            | self._pair_same_new_slot(A, B)
            | self._pair_a_takes(A, B)
            | self._pair_b_takes(A, B)
        )

    def _pair_independent(self, A: _IntArray, B: _IntArray) -> npt.NDArray[np.bool_]:
        """Case 4 of :meth:`_Joint._compatible` for the pairs ``(A[k], B[k])``."""
        pA, pB, tA, sA, tB, sB = self._sides(A, B)
        ok = np.zeros(A.size, dtype=bool)
        for i in range(_TOP):
            qa = tA[:, i]
            for j in range(_TOP):
                qb = tB[:, j]
                good = (qa >= 0) & (pB != qa) & (qb >= 0) & (qb != pA) & (qb != qa)
                ok |= good & ((sA[:, i] & sB[:, j]) if self.strict else (sA[:, i] | sB[:, j]))
        return ok

    def _pair_same_new_slot(self, A: _IntArray, B: _IntArray) -> npt.NDArray[np.bool_]:
        """Case 3 of :meth:`_Joint._compatible` for the pairs ``(A[k], B[k])``."""
        st = self.st
        _, pB, tA, _, _, _ = self._sides(A, B)
        ok = np.zeros(A.size, dtype=bool)
        for i in range(_TOP):
            q = tA[:, i]
            qs = np.where(q >= 0, q, 0)
            n2, d2 = st.cnt[qs] + 2, st.req[qs]
            a_lt, a_le = _lt(n2, d2, self.vn[A], self.vd[A]), _le(n2, d2, self.vn[A], self.vd[A])
            b_lt, b_le = _lt(n2, d2, self.vn[B], self.vd[B]), _le(n2, d2, self.vn[B], self.vd[B])
            good = (q >= 0) & st.ok2[qs] & a_le & (pB != q) & self.K[B, st.svc[qs]] & b_le
            ok |= good & ((a_lt & b_lt) if self.strict else (a_lt | b_lt))
        return ok

    def _pair_a_takes(self, A: _IntArray, B: _IntArray) -> npt.NDArray[np.bool_]:
        """Case 2a of :meth:`_Joint._compatible`: ``a`` takes ``p_B``, ``b`` moves on."""
        st = self.st
        pA, pB, _, _, tB, sB = self._sides(A, B)
        lt = _lt(self.vn[B], self.vd[B], self.vn[A], self.vd[A])
        le = _le(self.vn[B], self.vd[B], self.vn[A], self.vd[A])
        pBs = np.where(pB >= 0, pB, 0)
        bt_first = tB[:, 0] != pA
        bt = np.where(bt_first, tB[:, 0], tB[:, 1])
        bst = np.where(bt_first, sB[:, 0], sB[:, 1])
        good = (pB >= 0) & (pB != pA) & self.K[A, st.svc[pBs]] & st.ok0[pBs] & (bt >= 0)
        return good & ((lt & bst) if self.strict else (le & (lt | bst)))

    def _pair_b_takes(self, A: _IntArray, B: _IntArray) -> npt.NDArray[np.bool_]:
        """Case 2b of :meth:`_Joint._compatible`: ``b`` takes ``p_A``, ``a`` moves on --
        case 2a with the two robots' roles swapped."""
        return self._pair_a_takes(B, A)

    def _sides(self, A: _IntArray, B: _IntArray) -> tuple[_IntArray, ...]:
        """Slots, targets and strict flags of both sides: ``pA, pB, tA, sA, tB, sB``."""
        return self.p[A], self.p[B], self.t[A], self.tstrict[A], self.t[B], self.tstrict[B]

    def _other_than_self(self, owner: _IntArray, lowest: _IntArray, second: _IntArray) -> _IntArray:
        """Per entry: ``lowest`` unless that is the owner class itself, then ``second``."""
        return np.where(lowest == self.first[owner], second, lowest)

    # -------------------------------------------------------- case 4, independent
    def _independent(self) -> _IntArray:
        """Lowest first robot of a class ``B != A`` with an independent-moves violation.

        ``B`` qualifies for ``a``'s target ``q_a`` when ``p_B != q_a`` and ``B`` has a
        target outside ``{p_A, q_a}`` that is strict (strict mode, or ``q_a`` only a tie)
        or any (pareto mode with ``q_a`` strict).  ``p_A`` and ``p_B`` matter only inside
        ``T``, so classes reduce to signatures (slot in ``T`` or not, targets, flags).
        """
        C, big = self.C, self.big
        here = np.where(self.in_T[self.p], self.p, -2)  # -2: not a target of anyone
        sig = np.concatenate([here[:, None], self.t, self.tstrict.astype(np.int64)], axis=1)
        group, at = _distinct_rows(sig)
        rows = sig[at]
        low1, low2 = _grouped_two_lowest(group, self.first, at.size, big)
        g_here, g_t, g_s = rows[:, 0], rows[:, 1 : 1 + _TOP], rows[:, 1 + _TOP :].astype(bool)
        # one query per (q_a, p_A in T or -2, any-target) occurring
        qa = self.t.reshape(-1)
        owner = np.repeat(np.arange(C), _TOP)
        weak_ok = np.zeros(qa.size, dtype=bool) if self.strict else self.tstrict.reshape(-1)
        use = (qa >= 0) & (self.tstrict.reshape(-1) | (not self.strict))
        qa, owner, weak_ok = qa[use], owner[use], weak_ok[use]
        asked = np.stack([qa, here[owner], weak_ok.astype(np.int64)], axis=1)
        which, at = _distinct_rows(asked)
        ans1 = np.full(at.size, big, dtype=np.int64)
        ans2 = ans1.copy()
        for k, (q, pa, weak) in enumerate(asked[at].tolist()):
            outside = (g_t >= 0) & (g_t != pa) & (g_t != q) & (g_s | bool(weak))
            ans1[k], ans2[k] = _two_lowest_of_groups(
                (g_here != q) & outside.any(axis=1), low1, low2, big
            )
        value = self._other_than_self(owner, ans1[which], ans2[which])
        return _min_per(owner, value, C, big)

    # -------------------------------------------------------- case 3, same new slot
    def _same_new_slot(self) -> _IntArray:
        """Lowest first robot of a class ``B != A`` joining ``a`` on one of ``a``'s targets.

        For ``q`` a target of ``a`` with room for two and ``(c_q + 2) / req_q`` no more than
        ``a``'s load, ``B`` qualifies when ``p_B != q``, it has ``q``'s service, and its
        load exceeds (or, when the mode lets ``a``'s gain carry it, reaches) that value.
        """
        st, C, big = self.st, self.C, self.big
        q = self.t.reshape(-1)
        owner = np.repeat(np.arange(C), _TOP)
        qs = np.where(q >= 0, q, 0)
        n2, d2 = st.cnt[qs] + 2, st.req[qs]
        a_lt = _lt(n2, d2, self.vn[owner], self.vd[owner])
        a_le = _le(n2, d2, self.vn[owner], self.vd[owner])
        use = (q >= 0) & st.ok2[qs] & (a_lt if self.strict else a_le)
        le = a_lt & (not self.strict)  # a strictly better: b's load may equal the new one
        q, owner, le = q[use], owner[use], le[use]
        asked = np.stack([q, le.astype(np.int64)], axis=1)
        which, at = _distinct_rows(asked)
        ans1 = np.full(at.size, big, dtype=np.int64)
        ans2 = ans1.copy()
        for k, (slot, le) in enumerate(asked[at].tolist()):
            n2, d2 = int(st.cnt[slot]) + 2, int(st.req[slot])
            above = (_le if le else _lt)(n2, d2, self.vn, self.vd)
            mask = (self.p != slot) & self.K[:, st.svc[slot]] & above
            ans1[k], ans2[k] = _two_lowest(self.first[mask], big)
        value = self._other_than_self(owner, ans1[which], ans2[which])
        return _min_per(owner, value, C, big)

    # ------------------------------------------------------ case 2a, a takes p_B
    def _a_takes(self) -> _IntArray:
        """Lowest first robot of a class ``B`` whose slot ``a`` takes while ``b`` moves on.

        ``B`` sits on a slot of a service ``a`` has, other than ``p_A``, that can take
        ``a``; ``b`` goes to its first target other than ``p_A``.  Strict: ``b``'s load is
        below ``a``'s and that target strict; pareto: ``b``'s load is below ``a``'s (any
        target), or equal with a strict target.  ``b``'s target depends on ``p_A`` only
        when ``p_A`` is in ``T``: those slots are decided one by one, the others by
        service with rank-sorted prefix minima.
        """
        st, C, big = self.st, self.C, self.big
        best = np.full(C, big, dtype=np.int64)
        on = self.p >= 0
        home = np.where(on, self.p, 0)
        seat = on & st.ok0[home]  # B's slot can take a
        svc_B = st.svc[home]
        general = ~self.in_T[self.p]
        below = seat & (self.t[:, 0] >= 0)  # load below a's: any target does
        strict_t = seat & self.tstrict[:, 0]
        if self.strict:
            below = strict_t
        for s in range(st.S):
            ask = np.flatnonzero(general & self.K[:, s])
            if ask.size == 0:
                continue
            items = np.flatnonzero(below & (svc_B == s))
            found = _lowest_below(self.rank[items], self.first[items], self.rank[ask], big)
            if not self.strict:
                eq = np.flatnonzero(strict_t & (svc_B == s))
                found = np.minimum(
                    found,
                    _lowest_equal(
                        self.rank[eq], self.p[eq], self.first[eq], self.rank[ask], self.p[ask], big
                    ),
                )
            best[ask] = np.minimum(best[ask], found)
        for x in np.flatnonzero(self.in_T[:-1]).tolist():
            ask = np.flatnonzero(self.p == x)
            if ask.size == 0:
                continue
            bt_first = self.t[:, 0] != x
            bt = np.where(bt_first, self.t[:, 0], self.t[:, 1])
            bst = np.where(bt_first, self.tstrict[:, 0], self.tstrict[:, 1])
            r = self.rank[ask[0]]  # one slot, one load
            lt, eq = self.rank < r, self.rank == r
            good = seat & (self.p != x) & (bt >= 0)
            good &= (lt & bst) if self.strict else (lt | (eq & bst))
            per_service = _min_per(svc_B[good], self.first[good], st.S, big)
            got = np.where(self.K[ask], per_service[None, :], big).min(axis=1)
            best[ask] = np.minimum(best[ask], got)
        return best

    # ------------------------------------------------------ case 2b, b takes p_A
    def _b_takes(self) -> _IntArray:
        """Lowest first robot of a class ``B`` that takes ``p_A`` while ``a`` moves on.

        ``p_A`` can take ``b``, ``B`` has its service and sits elsewhere; ``a`` goes to its
        first target other than ``p_B``.  Strict: ``a``'s load is below ``b``'s and that
        target strict; pareto: below (any target), or equal with a strict target.
        Classes off ``T`` never meet ``a``'s target: by service, rank-sorted suffix
        minima; the classes on ``T`` are decided slot by slot.
        """
        st, C, big = self.st, self.C, self.big
        best = np.full(C, big, dtype=np.int64)
        on = self.p >= 0
        home = np.where(on, self.p, 0)
        askers = on & st.ok0[home]
        svc_A = st.svc[home]
        t0, t1 = self.t[:, 0], self.t[:, 1]
        s0, s1 = self.tstrict[:, 0], self.tstrict[:, 1]
        off_T = ~self.in_T[self.p]
        for s in range(st.S):
            ask = np.flatnonzero(askers & (svc_A == s) & (t0 >= 0))
            if ask.size == 0:
                continue
            items = np.flatnonzero(off_T & self.K[:, s])
            found = _lowest_above(self.rank[items], self.first[items], self.rank[ask], big)
            if self.strict:
                found = np.where(s0[ask], found, big)
            else:
                eq = _lowest_equal(
                    self.rank[items], self.p[items], self.first[items], self.rank[ask],
                    self.p[ask], big,
                )  # fmt: skip
                found = np.minimum(found, np.where(s0[ask], eq, big))
            best[ask] = np.minimum(best[ask], found)
        ask = np.flatnonzero(askers)
        if ask.size == 0:
            return best
        rank_A, p_A, need = self.rank[ask], self.p[ask], svc_A[ask]
        for x in np.flatnonzero(self.in_T[:-1]).tolist():
            there = np.flatnonzero(self.p == x)
            if there.size == 0:
                continue
            per_service = _min_per(
                np.nonzero(self.K[there])[1], np.repeat(self.first[there], self.K[there].sum(1)),
                st.S, big,
            )  # fmt: skip
            r = self.rank[there[0]]
            moved = t0[ask] == x
            at = np.where(moved, t1[ask], t0[ask])
            ast = np.where(moved, s1[ask], s0[ask])
            lt, eq = rank_A < r, rank_A == r
            good = (p_A != x) & (at >= 0)
            good &= (lt & ast) if self.strict else (lt | (eq & ast))
            got = np.where(good, per_service[need], big)
            best[ask] = np.minimum(best[ask], got)
        return best


# ------------------------------------------------------------------ index helpers
def _distinct_rows(rows: _IntArray) -> tuple[_IntArray, _IntArray]:
    """Ids of the distinct rows of an integer matrix and the first row of each id.

    Ids number the distinct rows ``0 .. G - 1`` in lexicographic order.  Column by
    column, the ids so far and the next column are packed into one integer and
    re-numbered (1-d sorts: much faster than ``np.unique(axis=0)``; no overflow, the ids
    stay below the row count).
    """
    ids = np.zeros(rows.shape[0], dtype=np.int64)
    if rows.shape[0] == 0:
        return ids, ids.copy()
    for col in rows.T:
        col = col.astype(np.int64) - int(col.min())
        _, ids = np.unique(ids * (int(col.max()) + 1) + col, return_inverse=True)
        ids = ids.reshape(-1)
    _, at = np.unique(ids, return_index=True)
    return ids, at


def _load_ranks(vn: _IntArray, vd: _IntArray) -> _IntArray:
    """Dense ranks of the loads ``vn / vd`` (``vd == 0``: ``+inf``, the top rank), exactly:
    equal loads share a rank and a lower load has a lower rank."""
    finite = np.flatnonzero(vd > 0)
    order = finite[_exact_order(vn[finite], vd[finite], finite)]
    new = np.ones(order.size, dtype=np.int64)
    a, b = order[:-1], order[1:]
    new[1:] = vn[a] * vd[b] != vn[b] * vd[a]
    ranks = np.full(vn.size, int(new.sum()), dtype=np.int64)
    ranks[order] = np.cumsum(new) - 1
    return ranks


def _two_lowest(values: _IntArray, big: int) -> tuple[int, int]:
    """The two smallest entries of ``values``; ``big`` stands in for missing ones."""
    if values.size == 0:
        return big, big
    if values.size == 1:
        return int(values[0]), big
    two = np.partition(values, 1)[:2]
    return int(two[0]), int(two[1])


def _grouped_two_lowest(
    group: _IntArray, value: _IntArray, n_groups: int, big: int
) -> tuple[_IntArray, _IntArray]:
    """Per group ``0 .. n_groups - 1``, its two smallest values (``big`` when missing)."""
    order = np.lexsort((value, group))
    g, v = group[order], np.append(value[order], big)  # v[g.size]: the stand-in
    start = np.searchsorted(g, np.arange(n_groups))
    size = np.searchsorted(g, np.arange(n_groups), side="right") - start
    low1 = v[np.where(size >= 1, start, g.size)]
    low2 = v[np.where(size >= 2, start + 1, g.size)]
    return low1, low2


def _two_lowest_of_groups(
    chosen: npt.NDArray[np.bool_], low1: _IntArray, low2: _IntArray, big: int
) -> tuple[int, int]:
    """The two smallest values over the chosen groups, given each group's two smallest."""
    first = np.where(chosen, low1, big)
    if first.size == 0:
        return big, big
    k = int(np.argmin(first))
    best = int(first[k])
    first[k] = big
    second = min(int(first.min()), int(low2[k]) if chosen[k] else big)
    return best, second


def _min_per(key: _IntArray, value: _IntArray, n_keys: int, big: int) -> _IntArray:
    """Per key ``0 .. n_keys - 1`` the smallest value of its entries (``big``: none)."""
    out = np.full(n_keys, big, dtype=np.int64)
    np.minimum.at(out, key, value)
    return out


def _lowest_below(rank: _IntArray, value: _IntArray, ask: _IntArray, big: int) -> _IntArray:
    """Per asked rank, the smallest value among the items of a lower rank."""
    order = np.argsort(rank, kind="stable")
    prefix = np.concatenate([[big], np.minimum.accumulate(value[order])]).astype(np.int64)
    return prefix[np.searchsorted(rank[order], ask, side="left")]


def _lowest_above(rank: _IntArray, value: _IntArray, ask: _IntArray, big: int) -> _IntArray:
    """Per asked rank, the smallest value among the items of a higher rank."""
    order = np.argsort(rank, kind="stable")
    suffix = np.concatenate([np.minimum.accumulate(value[order][::-1])[::-1], [big]])
    return suffix.astype(np.int64)[np.searchsorted(rank[order], ask, side="right")]


def _lowest_equal(
    rank: _IntArray,
    slot: _IntArray,
    value: _IntArray,
    ask_rank: _IntArray,
    ask_slot: _IntArray,
    big: int,
) -> _IntArray:
    """Per query, the smallest value among the items of the same rank on another slot.

    Per (rank, slot) only the smallest value can matter, and per rank the two smallest
    of those (they lie on different slots), so one of them answers every query.
    """
    if rank.size == 0:
        return np.full(ask_rank.size, big, dtype=np.int64)
    order = np.lexsort((value, slot, rank))
    r, p, v = rank[order], slot[order], value[order]
    head = np.ones(r.size, dtype=bool)
    head[1:] = (r[1:] != r[:-1]) | (p[1:] != p[:-1])
    r, p, v = r[head], p[head], v[head]
    order = np.lexsort((v, r))
    r, p, v = r[order], p[order], v[order]
    ranks, start, size = np.unique(r, return_index=True, return_counts=True)
    low2 = np.where(size >= 2, v[np.minimum(start + 1, v.size - 1)], big)
    k = np.minimum(np.searchsorted(ranks, ask_rank), ranks.size - 1)
    pick = np.where(p[start[k]] != ask_slot, v[start[k]], low2[k])
    return np.where(ranks[k] == ask_rank, pick, big)
