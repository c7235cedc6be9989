"""RACHNA_dt on hand-built missions with known answers, its two bidding schedules, an
independent literal simultaneous auction, and its derived round bound."""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import cfopt
from heuristics import rachna
from heuristics.rachna import SCHEDULES, rachna_dt
from tests.heuristics.test_auctions_common import (
    best_bundle,
    independent_utility,
    small_missions,
)

# ------------------------------------------------------- the sequential reading


def test_outbidding_reassigns_a_robot():
    """Robot 0 has A and B, robot 1 only A; task 0 needs A, task 1 needs B.  Task 0 takes
    robot 0 (index tie-break); task 1 can only use robot 0 and outbids task 0 (wage 1 -> 2
    units); task 0 re-forms with robot 1 next round."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    run = rachna_dt(m, schedule="sequential")
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [1, 0, 1, 1], [2, 1, 0, 0]]
    assert run.assignment.task.tolist() == [1, 0]
    assert run.assignment.service.tolist() == [1, 0]
    assert (run.iterations, run.rounds) == (2, 3)


def test_outbidding_releases_the_losers_other_robots():
    """Task 0 needs 2 x A and takes robots 0 and 1; task 1 needs B, only robot 0 has it: it
    takes robot 0, task 0 releases robot 1 and re-forms next round with robots 1 and 2."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0], [1, 0]], [[2, 0], [0, 1]], [5, 5])
    run = rachna_dt(m, schedule="sequential")
    assert run.trajectory.tolist() == [
        [1, 0, 0, 0],
        [1, 1, 0, 0],
        [1, 1, -1, -1],
        [1, 0, 1, 1],
        [2, 1, 0, 0],
        [2, 2, 0, 0],
    ]
    assert run.assignment.task.tolist() == [1, 0, 0]
    assert independent_utility(m, run.assignment.task, run.assignment.service) == 10


def test_bidding_war_until_a_budget_runs_out():
    """One robot, two tasks wanting it: u = 1 and u = 2 with eps = 1/4 (budgets 4 and 8
    units).  Wages 1, 2 (round 1), 3, 4 (round 2: task 0 retakes it, task 1 outbids it in
    the same round); in round 3 task 0 would pay 5 > 4 and gives up."""
    m = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1, 2])
    run = rachna_dt(m, eps=0.25, schedule="sequential")
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [1, 0, 1, 0], [2, 0, 0, 0], [2, 0, 1, 0]]
    assert (run.iterations, run.rounds) == (2, 3)
    assert run.assignment.task.tolist() == [1]


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_dynamic_threshold_staffs_large_coalitions(schedule):
    """Three robots for a task worth 2: with eps = 1 the bundle costs 3 > 2 (the fixed-eps
    RACHNA restriction of the seed); with eps = 1/n = 1/3 it costs 1 <= 2."""
    m = cfopt.Mission.from_arrays([[1], [1], [1]], [[3]], [2])
    assert rachna_dt(m, eps=1, schedule=schedule).assignment.n_assigned == 0
    run = rachna_dt(m, schedule=schedule)
    assert run.assignment.task.tolist() == [0, 0, 0]
    assert dict(run.options)["eps"] == "1/3"
    assert dict(run.options)["schedule"] == schedule


# ------------------------------------------- the simultaneous reading, by hand


def test_simultaneous_tie_then_outbid():
    """The mission of the first test, simultaneous (n = 2: eps = 1/2, budgets 10 units).

    Round 1, wages (0, 0): task 0 prices robots 0 and 1 at 1 each and picks robot 0
    (index); task 1 needs B, which only robot 0 has: it bids 1 for robot 0 too.  Both bids
    want robot 0; task 0 comes first and wins it (wage 1).  Round 2: task 1 bids 1 + 1 = 2
    for robot 0 and wins (wage 2); task 0 loses it.  Round 3: task 0 prices robot 0 at 3
    (held) and robot 1 at 1: it buys robot 1.  Round 4: nobody bids.  The sequential
    reading does round 1's two purchases and round 2's in 3 rounds (first test)."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    run = rachna_dt(m)
    assert dict(run.options)["schedule"] == "simultaneous"
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [2, 0, 1, 1], [3, 1, 0, 0]]
    assert run.assignment.task.tolist() == [1, 0]
    assert run.assignment.service.tolist() == [1, 0]
    assert (run.iterations, run.rounds) == (3, 4)
    seq = rachna_dt(m, schedule="sequential")
    assert seq.assignment == run.assignment and seq.rounds == 3


def test_simultaneous_release_waits_for_the_next_round():
    """The second test's mission (n = 3: eps = 1/3, budgets 15 units), simultaneous.

    Round 1: task 0 (2 x A) bids 2 for robots {0, 1}; task 1 (B: robot 0 only) bids 1 for
    robot 0; task 0 comes first and wins both (wages 1, 1, 0).  Round 2: task 1 bids 2 for
    robot 0 and wins (wage 2); task 0 lost a robot and releases robot 1 (wage kept at 1).
    Round 3: task 0 prices robot 0 at 3, robots 1 and 2 at 2 and 1: it buys {1, 2} for 3.
    Round 4: nobody bids.  Sequential: task 1 outbids task 0 inside round 1; 3 rounds."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0], [1, 0]], [[2, 0], [0, 1]], [5, 5])
    run = rachna_dt(m)
    assert run.trajectory.tolist() == [
        [1, 0, 0, 0],
        [1, 1, 0, 0],
        [2, 0, 1, 1],
        [2, 1, -1, -1],
        [3, 1, 0, 0],
        [3, 2, 0, 0],
    ]
    assert (run.iterations, run.rounds) == (3, 4)
    assert run.assignment.task.tolist() == [1, 0, 0]
    assert rachna_dt(m, schedule="sequential").rounds == 3


def test_simultaneous_bidding_war_sells_the_robot_once_a_round():
    """One robot, u = 1 and u = 2, eps = 1/4 (budgets 4 and 8 units), simultaneous.

    Round 1: both bid 1, task 0 wins the tie (wage 1).  Round 2: task 1 alone bids 2 and
    wins (wage 2).  Round 3: task 0 bids 3 <= 4 and wins; round 4: task 1 bids 4 and wins.
    Round 5: task 0 would pay 5 > 4: it gives up, nobody bids.  One sale a round: 5 rounds,
    where the sequential reading (two sales a round) needs 3."""
    m = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1, 2])
    run = rachna_dt(m, eps=0.25)
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [2, 0, 1, 0], [3, 0, 0, 0], [4, 0, 1, 0]]
    assert (run.iterations, run.rounds) == (4, 5)
    assert run.assignment.task.tolist() == [1]


def test_simultaneous_loses_a_task_the_sequential_reading_staffs():
    """Two robots (service A), three tasks: t0 needs 1 (u = 2), t1 needs 2 (u = 2), t2
    needs 1 (u = 1); n = 2, eps = 1/2: budgets 4, 4, 2 units.  The optimum staffs t0 and
    t2: 3.

    Simultaneous.  Round 1, wages (0, 0): t0 bids 1 for robot 0, t1 2 for {0, 1}, t2 1 for
    robot 0; t0 comes first and wins robot 0 (wages 1, 0); t1 and t2 lose the tie.  Round
    2: t1 bids 2 + 1 = 3 <= 4 for {0, 1}, t2 1 for robot 1; t1 comes first and wins both
    (wages 2, 1); t0 loses robot 0.  Round 3: t0 bids 2 for robot 1 (robot 0 costs 3), t2
    bids 2 <= 2 for robot 1 too; t0 wins (wages 2, 2); t1 loses robot 1 and releases robot
    0.  Round 4: t1 would pay 3 + 3 = 6 > 4, t2 3 > 2: both give up, nobody bids.  t0
    alone: 2.

    Sequential.  Round 1: t0 buys robot 0 (1); t1 buys {0, 1} (2 + 1 = 3), t0 loses robot
    0; t2 buys robot 1 (2 <= 2; robot 0 costs 3), t1 loses it and releases robot 0.  Round
    2: t0 buys robot 0 (free, 3 <= 4; robot 1 costs 3 too but is held); t1 would pay 7 > 4
    and gives up.  Round 3: nobody bids.  t0 and t2: 3, the optimum."""
    m = cfopt.Mission.from_arrays([[1], [1]], [[1], [2], [1]], [2, 2, 1])
    run = rachna_dt(m)
    assert run.trajectory.tolist() == [
        [1, 0, 0, 0],
        [2, 0, 1, 0],
        [2, 1, 1, 0],
        [3, 1, 0, 0],
        [3, 0, -1, -1],
    ]
    assert (run.iterations, run.rounds) == (3, 4)
    assert run.assignment.task.tolist() == [-1, 0]
    seq = rachna_dt(m, schedule="sequential")
    assert seq.assignment.task.tolist() == [0, 2] and seq.rounds == 3
    best = cfopt.solve_exact(m).utility
    assert run.assignment.utility(m) == 2 < seq.assignment.utility(m) == best == 3


def test_simultaneous_staffs_a_task_the_sequential_reading_loses():
    """The same robots and requirements with u = (1, 1.5, 5): budgets 2, 3, 10 units.  The
    optimum staffs t0 and t2: 6.

    Simultaneous.  Round 1: as above, t0 wins robot 0 (wages 1, 0).  Round 2: t1 bids 3 <=
    3 for {0, 1}, t2 1 for robot 1; t1 wins both (wages 2, 1), t0 loses robot 0.  Round 3:
    t0 bids 2 <= 2 for robot 1, t2 2 for robot 1; t0 wins (wages 2, 2), t1 releases robot
    0.  Round 4: t1 would pay 6 > 3 and gives up; t2 bids 3 for robot 0 (free: it beats
    held robot 1 at 3) and wins.  Round 5: nobody bids.  t0 and t2: 6.

    Sequential.  Round 1: t0 buys robot 0; t1 buys {0, 1} for 3; t2 buys robot 1 for 2, t1
    releases robot 0 (wages 2, 2).  Round 2: t0 would pay 3 > 2 and t1 6 > 3: both give
    up.  t2 alone: 5."""
    m = cfopt.Mission.from_arrays([[1], [1]], [[1], [2], [1]], [1, 1.5, 5])
    run = rachna_dt(m)
    assert run.trajectory.tolist() == [
        [1, 0, 0, 0],
        [2, 0, 1, 0],
        [2, 1, 1, 0],
        [3, 1, 0, 0],
        [3, 0, -1, -1],
        [4, 0, 2, 0],
    ]
    assert (run.iterations, run.rounds) == (4, 5)
    seq = rachna_dt(m, schedule="sequential")
    assert seq.assignment.task.tolist() == [-1, 2] and seq.rounds == 2
    assert run.assignment.utility(m) == cfopt.solve_exact(m).utility == 6
    assert seq.assignment.utility(m) == 5


def test_simultaneous_war_is_jumped_over_exactly():
    """u = 1e4 and 2e4 on one robot, eps = 1: the wage rises by one a round; task 0 bids in
    the odd rounds up to 9999, task 1 in the even ones; in round 10001 task 0 would pay
    10001 > 1e4.  The engine adds the repeating rounds in a few jumps."""
    m = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1e4, 2e4])
    run = rachna_dt(m, eps=1)
    assert (run.rounds, run.iterations) == (10001, 10000)
    assert run.trajectory[:2].tolist() == [[1, 0, 0, 0], [2, 0, 1, 0]]
    assert run.trajectory[-2:].tolist() == [[9999, 0, 0, 0], [10000, 0, 1, 0]]
    assert run.assignment.task.tolist() == [1]
    ref = literal_simultaneous(m, Fraction(1))
    run = rachna_dt(m, eps=1, medium="unicast")  # the literal auction counts point to point
    assert (run.rounds, run.messages, run.bytes, run.work) == (
        ref["rounds"],
        ref["messages"],
        ref["bytes"],
        ref["work"],
    )


def test_schedule_must_be_known():
    m = cfopt.Mission.from_arrays([[1]], [[1]], [1])
    with pytest.raises(cfopt.MissionError, match="schedule: must be one of simultaneous"):
        rachna_dt(m, schedule="parallel")


# ------------------------------------------------ an independent literal auction


def literal_simultaneous(mission: cfopt.Mission, eps: Fraction | None = None) -> dict:
    """The simultaneous auction in plain Python: brute-force bundles, every round run, every
    unstaffed task searching each round (no give-up bookkeeping), the documented counts."""
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    n, m, S = mission.n_robots, mission.n_tasks, mission.n_services
    eps = Fraction(1, max(n, 1)) if eps is None else Fraction(eps)
    budget = [math.floor(Fraction(float(x)) / eps) for x in mission.utilities]
    need = [[(s, reqs[j][s]) for s in range(S) if reqs[j][s]] for j in range(m)]
    k = [sum(r for _, r in need[j]) for j in range(m)]
    reach = [sum(1 for i in range(n) if any(caps[i][s] for s, _ in need[j])) for j in range(m)]
    needing = [sum(1 for j in range(m) if reqs[j][s]) for s in range(S)]
    wage = [0] * n
    task, service = [-1] * n, [-1] * n
    staffed = [False] * m
    rounds = iterations = messages = nbytes = work = 0
    ambiguous = False
    while True:
        rounds += 1
        price = [w + 1 for w in wage]
        held = [1 if task[i] >= 0 else 0 for i in range(n)]
        bids = []
        for j in range(m):
            if staffed[j]:
                continue
            work += reach[j] * k[j]
            key, b, amb = best_bundle(caps, need[j], list(range(n)), price, held)
            if b is None or key[0] > budget[j]:
                continue
            ambiguous |= amb
            bids.append((j, b))
        if not bids:
            break
        iterations += 1
        taken: set[int] = set()
        winners = []
        for j, b in bids:  # in task order: a bid wins if no earlier winner has its robots
            messages += 2 * len(need[j])
            nbytes += 2 * 8 * len(need[j]) + 12 * k[j]
            robots = {i for i, _ in b}
            if not robots & taken:
                taken |= robots
                winners.append((j, b))
        losers = {task[i] for i in taken} - {-1}
        for j, b in winners:
            for i, s in b:
                task[i], service[i] = j, s
                wage[i] += 1
            staffed[j] = True
        changed = set(taken)
        for loser in losers:
            staffed[loser] = False
            rel = [i for i in range(n) if task[i] == loser]
            if rel:
                performed = {service[i] for i in rel}
                messages += len(performed)
                nbytes += 8 * len(performed) + 12 * len(rel)
            for i in rel:
                task[i], service[i] = -1, -1
                changed.add(i)
        for s in range(S):
            c = sum(1 for i in changed if caps[i][s])
            if c:
                messages += needing[s]
                nbytes += needing[s] * (8 + 12 * c)
    return dict(
        task=task,
        rounds=rounds,
        iterations=iterations,
        messages=messages,
        bytes=nbytes,
        work=work,
        wages=wage,
        ambiguous=ambiguous,
    )


def _wages(run, n: int) -> list[int]:
    """Wages in units of eps, from the trajectory: one unit per purchase of the robot."""
    bought = run.trajectory[run.trajectory[:, 2] >= 0, 1] if len(run.trajectory) else []
    return np.bincount(np.asarray(bought, dtype=np.int64), minlength=n).tolist()


@st.composite
def single_service_missions(draw):
    """Small missions where each robot has exactly one service (its role is forced, so the
    release messages do not depend on which slot a robot fills)."""
    mission = draw(small_missions(max_robots=5, max_tasks=4))
    S = mission.n_services
    caps = np.zeros((mission.n_robots, S), dtype=bool)
    for i in range(mission.n_robots):
        caps[i, draw(st.integers(0, S - 1))] = True
    return cfopt.Mission.from_arrays(caps, mission.requirements, mission.utilities)


@st.composite
def war_missions(draw):
    """Small missions with budgets up to 400 units: long bidding wars."""
    mission = draw(small_missions(max_robots=5, max_tasks=4))
    utilities = [draw(st.integers(0, 400)) for _ in range(mission.n_tasks)]
    return cfopt.Mission.from_arrays(mission.capabilities, mission.requirements, utilities)


@pytest.mark.parametrize("eps", [None, Fraction(1, 2), Fraction(1)])
@given(mission=small_missions(max_robots=5, max_tasks=4))
def test_simultaneous_matches_the_literal_auction(eps, mission):
    ref = literal_simultaneous(mission, eps)
    assume(not ref["ambiguous"])
    run = rachna_dt(mission, eps=eps)
    assert run.assignment.task.tolist() == ref["task"]
    assert (run.rounds, run.iterations, run.work) == (ref["rounds"], ref["iterations"], ref["work"])
    assert _wages(run, mission.n_robots) == ref["wages"]
    independent_utility(mission, run.assignment.task, run.assignment.service)


@given(mission=single_service_missions(), eps=st.sampled_from([None, Fraction(1)]))
def test_simultaneous_messages_match_the_literal_auction(mission, eps):
    ref = literal_simultaneous(mission, eps)
    assume(not ref["ambiguous"])
    run = rachna_dt(mission, eps=eps, medium="unicast")  # the literal auction's counts
    assert (run.messages, run.bytes) == (ref["messages"], ref["bytes"])


@given(mission=war_missions(), eps=st.sampled_from([Fraction(1, 2), Fraction(1), Fraction(3)]))
def test_simultaneous_jump_changes_nothing(mission, eps):
    jumped = rachna._core(mission, eps, 10**9, jump=True, schedule="simultaneous")
    literal = rachna._core(mission, eps, 10**9, jump=False, schedule="simultaneous")
    assert jumped.moves.array().tolist() == literal.moves.array().tolist()
    for name in ("task", "service"):
        assert getattr(jumped, name).tolist() == getattr(literal, name).tolist()
    for name in ("iterations", "rounds", "messages", "bytes", "work"):
        assert getattr(jumped, name) == getattr(literal, name), name


@given(mission=war_missions(), eps=st.sampled_from([Fraction(1, 2), Fraction(1), Fraction(3)]))
def test_sequential_jump_changes_nothing(mission, eps):
    jumped = rachna._core(mission, eps, 10**9, jump=True, schedule="sequential")
    literal = rachna._core(mission, eps, 10**9, jump=False, schedule="sequential")
    assert jumped.moves.array().tolist() == literal.moves.array().tolist()
    for name in ("iterations", "rounds", "messages", "bytes", "work"):
        assert getattr(jumped, name) == getattr(literal, name), name


@pytest.mark.parametrize("schedule", SCHEDULES)
@given(mission=war_missions(), limit=st.integers(1, 400))
def test_raises_exactly_when_more_than_max_rounds_are_needed(schedule, mission, limit):
    needed = rachna_dt(mission, eps=1, schedule=schedule, max_rounds=10**9).rounds
    if needed > limit:
        with pytest.raises(cfopt.MissionError, match=f"max_rounds={limit} rounds"):
            rachna_dt(mission, eps=1, schedule=schedule, max_rounds=limit)
    else:
        assert rachna_dt(mission, eps=1, schedule=schedule, max_rounds=limit).rounds == needed


# ------------------------------------------------ both readings, any mission


@pytest.mark.parametrize("schedule", SCHEDULES)
@settings(max_examples=60)
@given(mission=small_missions())
def test_valid_deterministic_and_bounded_by_the_optimum(schedule, mission):
    run = rachna_dt(mission, schedule=schedule)
    utility = independent_utility(mission, run.assignment.task, run.assignment.service)
    assert utility == run.assignment.utility(mission)
    assert utility <= cfopt.solve_exact(mission).utility + 1e-9
    again = rachna_dt(mission, schedule=schedule, seed=7)  # the seed is only recorded
    assert again.replace_seconds(0) == dataclasses.replace(run.replace_seconds(0), seed=7)


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize(("S", "K"), [(5, 1), (5, 5), (10, 1), (10, 5)])
def test_seed_missions_are_valid_and_deterministic(schedule, S, K):
    m = cfopt.GridCell(100, 10, S, K).mission(0)
    run = rachna_dt(m, schedule=schedule)
    run.assignment.validate(m)
    assert run.assignment.utility(m) <= cfopt.solve_exact(m).utility + 1e-9
    assert rachna_dt(m, schedule=schedule).replace_seconds(0) == run.replace_seconds(0)
    assert run.iterations == run.rounds - 1


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("eps", [None, 0.5, 2.0])
@given(mission=small_missions())
def test_round_bound(schedule, eps, mission):
    """Derived bound.  Every purchase raises a wage by one unit of eps, and a robot is
    bought at wage + 1 <= floor(u_j / eps) units, so no wage exceeds floor(u_max / eps): at
    most n floor(u_max / eps) purchases, every bidding round has one, plus the quiet last
    round."""
    n = mission.n_robots
    e = Fraction(1, n) if eps is None else Fraction(eps)
    cap = math.floor(max(Fraction(float(x)) for x in mission.utilities) / e)
    run = rachna_dt(mission, eps=eps, schedule=schedule)
    assert run.rounds <= n * cap + 1
    assert run.rounds == run.iterations + 1
