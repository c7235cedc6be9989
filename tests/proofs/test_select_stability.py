"""The completion-reward checker against a brute-force enumeration of single-robot moves."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from cfopt import Assignment, Mission
from proofs import select_stability as sel
from proofs.strategies import assignments, missions


# ------------------------------------------------------------------ brute force
def naive_priorities(mission: Mission) -> list[int]:
    """pi_j = how many tasks rank below j by (w, -j): pairwise, from the definition."""
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    S = mission.n_services
    price = []
    for s in range(S):
        supply = sum(row[s] for row in caps)
        demand = sum(row[s] for row in reqs)
        price.append(max(Fraction(1), Fraction(demand, max(supply, 1)) if supply else demand))
    worth = [
        Fraction(u) / sum(Fraction(r) * price[s] for s, r in enumerate(row))
        for u, row in zip(mission.utilities.tolist(), reqs, strict=True)
    ]
    keys = [(w, -j) for j, w in enumerate(worth)]
    return [sum(1 for other in keys if other < key) for key in keys]


def naive_reward(mission: Mission, positions, i: int) -> tuple[int, int] | None:
    """(tier, pi) of robot i on ``positions`` with counts recomputed; None is bottom."""
    p = positions[i]
    if p is None:
        return None
    j, s = p
    reqs = mission.requirements
    count = {}
    for q in positions:
        if q is not None:
            count[q] = count.get(q, 0) + 1
    complete = all(count.get((j, t), 0) >= reqs[j, t] for t in range(mission.n_services))
    if not complete or mission.utilities[j] <= 0:
        return None
    return (1 if count[(j, s)] <= reqs[j, s] else 0, naive_priorities(mission)[j])


def _code(mission: Mission, reward) -> int:
    return -1 if reward is None else reward[0] * mission.n_tasks + reward[1]


def naive_violations(mission: Mission, assignment: Assignment):
    """[(robot, source, target, before, after)]: every robot's best strictly better move."""
    positions = [
        None if t < 0 else (int(t), int(s))
        for t, s in zip(assignment.task.tolist(), assignment.service.tolist(), strict=True)
    ]
    out = []
    for i in range(len(positions)):
        now = _code(mission, naive_reward(mission, positions, i))
        best = None
        for k in range(mission.n_tasks):
            for t in range(mission.n_services):
                if not mission.capabilities[i, t] or not mission.requirements[k, t]:
                    continue
                if positions[i] == (k, t):
                    continue
                moved = list(positions)
                moved[i] = (k, t)
                value = _code(mission, naive_reward(mission, moved, i))
                if value > now and (best is None or (value, -k, -t) > best):
                    best = (value, -k, -t)
        if best is not None:
            out.append((i, positions[i], (-best[1], -best[2]), now, best[0]))
    return out


def _listed(mission: Mission, assignment: Assignment):
    return [
        (v.robot, v.source, v.target, v.before, v.after)
        for v in sel.select_violations(mission, assignment)
    ]


# -------------------------------------------------------- checker = brute force
@st.composite
def missions_and_assignments(draw, **kwargs):
    mission = draw(missions(**kwargs))
    return mission, draw(assignments(mission))


@settings(max_examples=300)
@given(case=missions_and_assignments(max_robots=6, max_tasks=4, max_services=3))
def test_checker_matches_brute_force_on_any_partition(case) -> None:
    mission, assignment = case
    assert sel.select_priorities(mission) == naive_priorities(mission)
    assert _listed(mission, assignment) == naive_violations(mission, assignment)
    assert sel.is_select_stable(mission, assignment) == (not naive_violations(mission, assignment))


@st.composite
def near_complete(draw):
    """Partitions where tasks are complete or one robot short: the interesting cases."""
    mission = draw(missions(max_robots=7, max_tasks=3, max_services=3, max_requirement=2))
    n = mission.n_robots
    task = np.full(n, -1, dtype=np.int64)
    service = np.full(n, -1, dtype=np.int64)
    free = list(range(n))
    for j in range(mission.n_tasks):
        for s in np.flatnonzero(mission.requirements[j]).tolist():
            want = int(mission.requirements[j, s]) + draw(st.integers(-1, 1))
            able = [i for i in free if mission.capabilities[i, s]]
            for i in able[: max(want, 0)]:
                task[i], service[i] = j, s
                free.remove(i)
    return mission, Assignment(task=task, service=service)


@settings(max_examples=300)
@given(case=near_complete())
def test_checker_matches_brute_force_near_completion(case) -> None:
    mission, assignment = case
    assert _listed(mission, assignment) == naive_violations(mission, assignment)


@settings(max_examples=100)
@given(case=missions_and_assignments(max_robots=6, max_tasks=4, max_services=3))
def test_a_violation_replays_to_its_reward(case) -> None:
    mission, assignment = case
    for v in sel.select_violations(mission, assignment):
        after = v.apply(assignment)
        assert sel.completion_rewards(mission, after)[v.robot] == v.after > v.before


# ----------------------------------------------------------------- by hand
def test_the_reward_tiers() -> None:
    # t0 needs 2 x s0 and has 3 (one over); t1 needs 1 x s1, empty; t2 worthless, complete
    m = Mission.from_arrays([[1, 1]] * 4 + [[0, 1]], [[2, 0], [0, 1], [0, 1]], [6, 9, 0])
    a = Assignment(task=[0, 0, 0, -1, 2], service=[0, 0, 0, -1, 1])
    pi = sel.select_priorities(m)
    assert pi == [1, 2, 0]
    assert sel.completion_rewards(m, a) == [1, 1, 1, -1, -1]  # surplus (0, pi_0) = 1
    found = {v.robot: (v.target, v.after) for v in sel.select_violations(m, a)}
    # everyone who can do s1 completes t1 (needed, 3 + 2 = 5); r4 included
    assert found == {i: ((1, 1), 5) for i in range(5)}


def test_leaving_a_needed_slot_to_complete_the_own_task_does_not_pay() -> None:
    # t0 needs s0 + s1; r0 is on s0, s1 is short; r0 could do s1 but would open s0
    m = Mission.from_arrays([[1, 1]], [[1, 1]], [5])
    a = Assignment(task=[0], service=[0])
    assert sel.select_violations(m, a) == []
    # with a second robot on s0 (over-full), moving to s1 completes t0: a violation
    m2 = Mission.from_arrays([[1, 1], [1, 0]], [[1, 1]], [5])
    a2 = Assignment(task=[0, 0], service=[0, 0])
    assert [(v.robot, v.target) for v in sel.select_violations(m2, a2)] == [(0, (0, 1))]


def test_surplus_joins_only_pay_from_another_task() -> None:
    m = Mission.from_arrays([[1]] * 3, [[1], [1]], [5, 4])
    stable = Assignment(task=[0, 0, 1], service=[0, 0, 0])  # t0 over-full, t1 complete
    # r2 (needed in t1, pi 0) would be surplus in t0: (0, 1) < (1, 0); stable
    assert sel.is_select_stable(m, stable)
    lone = Assignment(task=[0, -1, 1], service=[0, -1, 0])
    assert [(v.robot, v.target, v.after) for v in sel.select_violations(m, lone)] == [
        (1, (0, 0), 1)
    ]


def test_bad_assignments_are_rejected() -> None:
    m = Mission.from_arrays([[1]], [[1]], [5])
    with pytest.raises(cfopt.MissionError):
        sel.select_violations(m, Assignment(task=[3], service=[0]))


def test_priorities_break_exact_ties_by_index() -> None:
    u = 2.0**53  # u and u + 2 are neighbours among floats; t0 and t2 tie exactly
    m = Mission.from_arrays([[1]], [[1], [1], [1]], [u, u + 2, u])
    assert sel.select_priorities(m) == [1, 2, 0]


# ------------------------------------------------------------------ the claims
def test_claims_o1_holds_and_catches_a_broken_implementation() -> None:
    from proofs.claims_cfopt import SELECT_ALGORITHM, select_claims

    o1 = select_claims()[0]
    assert o1.check(2, seed=0).verdict.value == "holds"

    def idle(mission, **options):  # a "heuristic" that leaves everyone unassigned
        from types import SimpleNamespace

        return SimpleNamespace(assignment=Assignment.empty(mission))

    broken = o1.with_algorithm(SELECT_ALGORITHM, idle).check(2, seed=0)
    assert broken.verdict.value == "fails"
    ce = broken.counterexample
    assert ce is not None and not sel.is_select_stable(ce.mission, ce.assignment)
    assert ce.size[0] <= 2  # shrunk to a tiny mission


def test_claim_o2_finds_the_smallest_counterexample_in_the_sweep() -> None:
    from proofs.claims_cfopt import select_claims

    verdict = select_claims()[1].check(3, seed=0)
    assert verdict.verdict.value == "fails"
    ce = verdict.counterexample
    assert ce is not None and ce.size[0] <= 5
    assert "< 95 %" in ce.detail
