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
most two excluded slots, ``p_b`` and the partner's target, always leaves one of them),
and decides cases 2-4 for one class against all classes at once with numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError

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

    def apply(self, assignment: Assignment) -> Assignment:
        """A new assignment with this move made (the robot must be at ``source``)."""
        return _apply((self,), assignment)

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """``{"robot", "from", "to"}`` with ids and names (what ``cfopt check --json`` lists)."""
        return {
            "robot": mission.robot_ids[self.robot],
            "from": _slot_dict(mission, self.source),
            "to": _slot_dict(mission, self.target),
        }

    def describe(self, mission: Mission) -> str:
        """``r3: t0/lift -> t2/survey`` (``-`` for unassigned)."""
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

    @property
    def kind(self) -> str:
        """``"individual"`` (a Nash violation) or ``"joint"``."""
        return "individual" if len(self.robots) == 1 else "joint"

    def apply(self, assignment: Assignment) -> Assignment:
        """A new assignment with every move of the deviation made simultaneously."""
        return _apply(self.moves, assignment)

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """``{"robots": [...], "moves": [...], "kind": ...}``, as ``cfopt check --json`` lists."""
        return {
            "robots": [mission.robot_ids[i] for i in self.robots],
            "moves": [mv.to_dict(mission) for mv in self.moves],
            "kind": self.kind,
        }

    def describe(self, mission: Mission) -> str:
        """The moves, joined by ``" & "``."""
        return " & ".join(mv.describe(mission) for mv in self.moves)


def _slot_dict(mission: Mission, slot: Slot | None) -> dict[str, str] | None:
    if slot is None:
        return None
    return {"task": mission.task_ids[slot[0]], "service": mission.services[slot[1]]}


def _slot_text(mission: Mission, slot: Slot | None) -> str:
    if slot is None:
        return "-"
    return f"{mission.task_ids[slot[0]]}/{mission.services[slot[1]]}"


def _apply(moves: tuple[Move, ...], assignment: Assignment) -> Assignment:
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
    one class is checked against all classes with O(S) numpy operations, so the time
    is O(C^2 + n S + m S log(m S)) — never all robot pairs times all slot pairs.

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
    _check_mode(mode)
    state = _State(mission, assignment, capped)
    out: list[PairwiseViolation] = []
    if individual:
        robots, targets = state.nash()
        for i, q in zip(robots.tolist(), targets.tolist(), strict=True):
            v = state.nash_violation(i, q)
            out.append(PairwiseViolation(robots=(i,), moves=(v,)))
    out.extend(_Joint(state, mode).violations())
    return out


def is_pairwise_stable(
    mission: Mission, assignment: Assignment, *, mode: Mode = "strict", capped: bool = False
) -> bool:
    """Whether no one robot and no two robots can deviate profitably.

    Stops at the first violation found.  See :func:`pairwise_violations`.

    >>> m = Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 2]], [5.0, 5.0])
    >>> a = Assignment(task=[-1, 0, 1], service=[-1, 0, 1])
    >>> is_pairwise_stable(m, a, capped=True), is_pairwise_stable(m, a, mode="pareto", capped=True)
    (True, False)
    """
    _check_mode(mode)
    state = _State(mission, assignment, capped)
    robots, _ = state.nash()
    if robots.size:
        return False
    return not _Joint(state, mode).any()


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
        if not isinstance(mission, Mission):
            raise TypeError(f"mission: expected a cfopt.Mission, got {type(mission).__name__}")
        if not isinstance(assignment, Assignment):
            raise TypeError(
                f"assignment: expected a cfopt.Assignment, got {type(assignment).__name__}"
            )
        counts = assignment.counts(mission)  # validates
        self.mission = mission
        self.capped = bool(capped)
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
    """The joint (two-robot) deviations, decided class against class."""

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

    def violations(self) -> list[PairwiseViolation]:
        if self.C == 0:
            return []
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
