"""SDA on hand-built missions with known answers, and its derived round bounds."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given

import cfopt
from heuristics.sda import sda
from tests.heuristics.test_auctions_common import independent_utility, small_missions


def test_greedy_order_by_utility_per_robot_is_suboptimal():
    """Task 0 needs 1 robot (u = 6, 6 per robot), task 1 needs both robots (u = 10, 5 per
    robot).  Wages start at 11 and fall; task 0 can afford a robot at wage 6, task 1 needs
    both at 5, so task 0 buys first and task 1 can never be staffed: 6, the optimum is 10."""
    m = cfopt.Mission.from_arrays([[1], [1]], [[1], [2]], [6, 10])
    assert cfopt.solve_exact(m).utility == 10
    for schedule in ("max-wage", "uniform"):
        run = sda(m, schedule=schedule)
        assert run.assignment.task.tolist() == [0, -1]
        assert run.assignment.service.tolist() == [0, -1]
        assert independent_utility(m, run.assignment.task, run.assignment.service) == 6
    # max-wage: robot 0 reaches wage 6 after 5 decrements = round 9 (robots alternate);
    # then robot 1 (4 decrements) runs down alone to 0: 7 more rounds.
    run = sda(m)
    assert (run.rounds, run.iterations) == (16, 1)
    assert run.trajectory.tolist() == [[1, 0, 0, 0]]
    # uniform: wage 6 at round 5, and the auction runs until wage 0 at round D = 11.
    assert sda(m, schedule="uniform").rounds == 11


def test_award_order_by_surplus_and_recomputed_bid():
    """Robot 0 has services A and B, robot 1 only A; task 0 needs A (u = 5), task 1 needs B
    (u = 5.5), task 2 needs C, which nobody has (u = 20, so wages start at 21).  Uniform
    wages reach 5 at round 16, where both tasks first afford a robot and both bid robot 0
    (task 0 by the index tie-break).  Task 1 has the larger surplus (0.5 > 0) and wins it;
    task 0's bid is recomputed in the same round to robot 1 (cost 5 <= 5) and also wins."""
    m = cfopt.Mission.from_arrays(
        [[1, 1, 0], [1, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [5, 5.5, 20]
    )
    run = sda(m, schedule="uniform")
    assert run.assignment.task.tolist() == [1, 0]
    assert run.assignment.service.tolist() == [1, 0]
    assert (run.rounds, run.iterations) == (16, 1)
    assert run.trajectory.tolist() == [[1, 0, 1, 1], [1, 1, 0, 0]]
    assert independent_utility(m, run.assignment.task, run.assignment.service) == 10.5
    assert cfopt.solve_exact(m).utility == 10.5


def test_equal_surplus_goes_to_the_lower_task_index():
    """As above with u = 6 for both tasks: equal surplus, task 0 takes robot 0 and task 1
    (which only robot 0 can serve) is never staffed: 6 of an optimal 12."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0]], [[1, 0], [0, 1]], [6, 6])
    run = sda(m, schedule="uniform")
    assert run.assignment.task.tolist() == [0, -1]
    assert cfopt.solve_exact(m).utility == 12


def test_matching_assigns_services():
    """The bundle needs A and B; only the matching puts robot 1 (A only) on A."""
    m = cfopt.Mission.from_arrays([[1, 1], [1, 0], [0, 0]], [[1, 1]], [3])
    run = sda(m)
    assert run.assignment.task.tolist() == [0, 0, -1]
    assert run.assignment.service.tolist() == [1, 0, -1]


def test_exact_wages_with_fractional_eps():
    """eps = 0.1 is not a binary fraction: wages stay exact (0.1 is its float value), and a
    task with u = 3 and one robot is bought exactly when the wage drops to <= 3."""
    m = cfopt.Mission.from_arrays([[1]], [[1]], [3])
    run = sda(m, eps=0.1, schedule="uniform")
    eps = Fraction(0.1)
    w0 = 3 + eps
    first = next(t for t in range(1, 100) if w0 - t * eps <= 3)
    assert run.rounds == first and run.assignment.task.tolist() == [0]


def _decrements_to_zero(mission, eps):
    u_max = max(Fraction(float(x)) for x in mission.utilities)
    return math.ceil((u_max + Fraction(eps)) / Fraction(eps))


@pytest.mark.parametrize("eps", [1.0, 0.5, 3.0])
@given(mission=small_missions())
def test_round_bounds(eps, mission):
    """Derived bounds.  A wage starts at u_max + eps and reaches 0 after
    D = ceil((u_max + eps) / eps) decrements; the auction ends at the latest in the round
    all unsold wages are 0.  max-wage decrements one robot per round while some wage is
    positive and never a robot at 0, so it runs at most n D rounds; uniform decrements all
    every round: at most D.  Every bidding round awards at least one task: iterations <= m."""
    D = _decrements_to_zero(mission, eps)
    n, m = mission.n_robots, mission.n_tasks
    run = sda(mission, eps=eps)
    assert 1 <= run.rounds <= n * D
    assert run.iterations <= min(m, run.rounds)
    run = sda(mission, eps=eps, schedule="uniform")
    assert 1 <= run.rounds <= D
    assert run.iterations <= min(m, run.rounds)
