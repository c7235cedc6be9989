"""A naive, literal reference for the stability checkers (tests only).

It enumerates every robot, every robot pair and every pair of positions (any slot the
robot can perform, or unassigned), recomputes the counts from scratch for each, and
compares rewards as :class:`fractions.Fraction` loads.  It shares no code with
``proofs.stability`` beyond the data model.
"""

from __future__ import annotations

import math
from fractions import Fraction

import cfopt


def _slots(mission: cfopt.Mission) -> list[tuple[int, int]]:
    m, s = mission.requirements.shape
    return [(j, k) for j in range(m) for k in range(s) if mission.requirements[j, k] > 0]


def _positions(assignment: cfopt.Assignment) -> list[tuple[int, int] | None]:
    return [
        None if t < 0 else (int(t), int(s))
        for t, s in zip(assignment.task.tolist(), assignment.service.tolist(), strict=True)
    ]


def _counts(positions):
    out: dict[tuple[int, int], int] = {}
    for p in positions:
        if p is not None:
            out[p] = out.get(p, 0) + 1
    return out


def reward(mission, positions, i) -> float:
    """The robot's reward exp(1 - c/req), 0 unassigned (floats, for replay sanity)."""
    p = positions[i]
    if p is None:
        return 0.0
    c = _counts(positions)[p]
    return math.exp(1 - c / int(mission.requirements[p]))


def load(mission, positions, i):
    """c/req of robot i's slot as a Fraction (the counts recomputed), inf when unassigned."""
    p = positions[i]
    if p is None:
        return math.inf
    return Fraction(_counts(positions)[p], int(mission.requirements[p]))


def _flat(mission, q):
    return -1 if q is None else q[0] * mission.n_services + q[1]


def naive_nash(mission, assignment, *, capped=False):
    """[(robot, source, target)]: per robot its best strictly improving move."""
    pos = _positions(assignment)
    counts = _counts(pos)
    out = []
    for i in range(mission.n_robots):
        cur = load(mission, pos, i)
        best = None
        for q in _slots(mission):  # task-then-service order: first wins ties
            if q == pos[i] or not mission.capabilities[i, q[1]]:
                continue
            c = counts.get(q, 0) + 1
            if capped and c > mission.requirements[q]:
                continue
            val = Fraction(c, int(mission.requirements[q]))
            if val < cur and (best is None or val < best[0]):
                best = (val, q)
        if best is not None:
            out.append((i, pos[i], best[1]))
    return out


COMBOS = [(mode, capped) for capped in (False, True) for mode in ("strict", "pareto")]


def joint_deviations(mission, assignment, a, b):
    """Every joint deviation of robots a and b (both change position) with its verdicts.

    Returns [(load_a, load_b, flat q_a, flat q_b, q_a, q_b, {(mode, capped): bool})].
    """
    pos = _positions(assignment)
    slots = _slots(mission)
    req = mission.requirements
    options = []
    for i in (a, b):
        opts = [q for q in [None, *slots] if q != pos[i]]
        options.append([q for q in opts if q is None or mission.capabilities[i, q[1]]])
    before = (load(mission, pos, a), load(mission, pos, b))
    found = []
    for qa in options[0]:
        for qb in options[1]:
            new = list(pos)
            new[a], new[b] = qa, qb
            counts = _counts(new)
            fits = all(q is None or counts[q] <= req[q] for q in (qa, qb))
            after = tuple(
                math.inf if q is None else Fraction(counts[q], int(req[q])) for q in (qa, qb)
            )
            better = [after[k] < before[k] for k in (0, 1)]
            worse = [after[k] > before[k] for k in (0, 1)]
            verdict = {}
            for mode, capped in COMBOS:
                ok = all(better) if mode == "strict" else any(better) and not any(worse)
                verdict[mode, capped] = ok and (fits or not capped)
            flat = (_flat(mission, qa), _flat(mission, qb))
            found.append((after[0], after[1], *flat, qa, qb, verdict))
    return found


def naive_joint(mission, assignment):
    """{(mode, capped): [(a, b, q_a, q_b)]}: per robot a its lowest partner b, and the
    joint deviation best for a (load_a, load_b, slot of a, slot of b)."""
    out = {combo: [] for combo in COMBOS}
    for a in range(mission.n_robots):
        todo = set(COMBOS)
        for b in range(mission.n_robots):
            if b == a or not todo:
                continue
            found = joint_deviations(mission, assignment, a, b)
            for combo in list(todo):
                valid = [f for f in found if f[6][combo]]
                if valid:
                    best = min(valid, key=lambda x: x[:4])
                    out[combo].append((a, b, best[4], best[5]))
                    todo.discard(combo)
    return out
