"""RACHNA_dt on hand-built missions with known answers, and its derived round bound."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given

import cfopt
from heuristics.rachna import rachna_dt
from tests.heuristics.test_auctions_common import independent_utility, small_missions


def test_outbidding_reassigns_a_robot():
    """Robot 0 has A and B, robot 1 only A; task 0 needs A, task 1 needs B.  Task 0 takes
    robot 0 (index tie-break); task 1 can only use robot 0 and outbids task 0 (wage 1 -> 2
    units); task 0 re-forms with robot 1 next round."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [5, 5])
    run = rachna_dt(m)
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [1, 0, 1, 1], [2, 1, 0, 0]]
    assert run.assignment.task.tolist() == [1, 0]
    assert run.assignment.service.tolist() == [1, 0]
    assert (run.iterations, run.rounds) == (2, 3)


def test_outbidding_releases_the_losers_other_robots():
    """Task 0 needs 2 x A and takes robots 0 and 1; task 1 needs B, only robot 0 has it: it
    takes robot 0, task 0 releases robot 1 and re-forms next round with robots 1 and 2."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0], [1, 0]], [[2, 0], [0, 1]], [5, 5])
    run = rachna_dt(m)
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
    run = rachna_dt(m, eps=0.25)
    assert run.trajectory.tolist() == [[1, 0, 0, 0], [1, 0, 1, 0], [2, 0, 0, 0], [2, 0, 1, 0]]
    assert (run.iterations, run.rounds) == (2, 3)
    assert run.assignment.task.tolist() == [1]


def test_dynamic_threshold_staffs_large_coalitions():
    """Three robots for a task worth 2: with eps = 1 the bundle costs 3 > 2 (the fixed-eps
    RACHNA restriction of the seed); with eps = 1/n = 1/3 it costs 1 <= 2."""
    m = cfopt.Mission.from_arrays([[1], [1], [1]], [[3]], [2])
    assert rachna_dt(m, eps=1).assignment.n_assigned == 0
    run = rachna_dt(m)
    assert run.assignment.task.tolist() == [0, 0, 0]
    assert dict(run.options)["eps"] == "1/3"


@pytest.mark.parametrize("eps", [None, 0.5, 2.0])
@given(mission=small_missions())
def test_round_bound(eps, mission):
    """Derived bound.  Every acquisition raises at least one wage by one unit of eps, and a
    robot is bought at wage + 1 <= floor(u_j / eps) units, so no wage exceeds
    floor(u_max / eps): at most n floor(u_max / eps) acquisitions, every bidding round has
    one, plus the quiet last round."""
    n = mission.n_robots
    e = Fraction(1, n) if eps is None else Fraction(eps)
    cap = math.floor(max(Fraction(float(x)) for x in mission.utilities) / e)
    run = rachna_dt(mission, eps=eps)
    assert run.rounds <= n * cap + 1
    assert run.rounds == run.iterations + 1
