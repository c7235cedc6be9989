"""Pair-GRAPE-S: the pairwise step, the seed's Lemma 1 and Theorem 1, determinism."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import proofs
from cfopt import GridCell, Mission
from heuristics import grape_s, pair_grape_s
from proofs.strategies import missions

# Lemma 1 / Theorem 1 counterexample (found by random search on 10-robot missions,
# shrunk by hand).  r0 does p, r1 does p and s, r2 does s and s'; t0 needs 1 p, t1 needs
# 2 s, t2 needs 2 s'.  Capped GRAPE-S (index order): r2 joins t1/s (1/2; t2/s' ties at
# 1/2, lower task wins), r1 joins t0/p, r0 cannot join anything.  The pairwise step: r0
# takes r1's t0/p, r1 fills the short t1/s.  Now t1/s holds 2 of 2, r2's reward falls to
# exp(0) and joining t2/s' gives exp(1/2): r2 wants to move.  The proof of Lemma 1 notes
# that coalitions only shrink in reward, but forgets that this lowers the reward of the
# robots *inside* the coalition a_i joins.
LEMMA1_MISSION = Mission.from_arrays(
    [[1, 0, 0], [1, 1, 0], [0, 1, 1]], [[1, 0, 0], [0, 2, 0], [0, 0, 2]], [1, 1, 1]
)
# Uncapped: capping leaves a robot out that the paper's (uncapped) reward would place.
UNCAPPED_MISSION = Mission.from_arrays([[1], [1]], [[1]], [6])


def test_pairwise_step_exchange_is_recorded() -> None:
    m = Mission.from_arrays([[1, 0], [1, 1]], [[1, 0], [0, 1]], [1, 1])
    run = pair_grape_s(m)
    assert run.pairwise_step_ran and run.exchanges == 1
    assert run.trajectory.tolist() == [[1, 1, 0, 0], [2, 0, 0, 0], [2, 1, 1, 1]]
    assert run.iterations == 2
    assert run.rounds == 2 + 1  # GRAPE-S: 1 move + quiet round; then 1 exchange round
    assert run.messages == run.rounds * 2 * 1
    assert run.assignment.percent_utility(m) == 100.0


def test_quiet_pass_ends_the_step_and_costs_one_round() -> None:
    # t0/s1 is short, r1 is unassigned but nobody can do s1: the seed's loop condition
    # stays true forever; the quiet pass stops it.
    m = Mission.from_arrays([[1, 0], [1, 0]], [[1, 1]], [1])
    run = pair_grape_s(m)
    grape = grape_s(m, capped=True)
    assert run.pairwise_step_ran and run.exchanges == 0
    assert run.rounds == grape.rounds + 1
    assert run.assignment == grape.assignment


def test_step_not_needed_when_nothing_is_short() -> None:
    m = GridCell(100, 10, 5, 1).mission(0)
    run = pair_grape_s(m)
    assert not run.pairwise_step_ran and run.exchanges == 0
    assert run.replace_seconds(0).trajectory.tolist() == grape_s(m, capped=True).trajectory.tolist()


@given(
    mission=missions(min_robots=0, max_robots=30, max_tasks=6, max_services=4),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_pairwise_step_only_adds_utility_and_at_most_n_exchanges(mission, order, seed) -> None:
    run = pair_grape_s(mission, seed=seed, order=order)
    first = grape_s(mission, seed=seed, order=order, capped=True)
    run.assignment.validate(mission)
    assert (run.assignment.counts(mission) <= mission.requirements).all()  # capped
    assert run.exchanges <= int((first.assignment.task < 0).sum()) <= mission.n_robots  # X2
    assert run.assignment.utility(mission) >= first.assignment.utility(mission)
    assert run.iterations == first.iterations + run.exchanges
    # Lemma 1 fails (see the xfails), but only where its proof slips: every capped Nash
    # violation is by a robot sitting in a slot that an exchanged a_i joined.
    joined = {(j, s) for _, _, j, s in run.trajectory[len(first.trajectory) :][1::2].tolist()}
    for violation in proofs.nash_violations(mission, run.assignment, capped=True):
        assert violation.source in joined, violation.describe(mission)


def test_lemma1_counterexample_has_this_violation() -> None:
    run = pair_grape_s(LEMMA1_MISSION)
    assert run.exchanges == 1
    assert run.assignment.task.tolist() == [0, 1, 1]
    found = [
        v.describe(LEMMA1_MISSION)
        for v in proofs.nash_violations(LEMMA1_MISSION, run.assignment, capped=True)
    ]
    assert found == ["r2: t1/s1 -> t2/s2"]


@pytest.mark.xfail(strict=True, reason="Lemma 1 fails: LEMMA1_MISSION, see the comment above")
def test_lemma1_pair_grape_s_is_nash_stable() -> None:
    run = pair_grape_s(LEMMA1_MISSION)
    assert proofs.is_nash_stable(LEMMA1_MISSION, run.assignment, capped=True)


@pytest.mark.xfail(strict=True, reason="Theorem 1 fails on the Lemma 1 counterexample")
def test_theorem1_pair_grape_s_is_pairwise_stable() -> None:
    run = pair_grape_s(LEMMA1_MISSION)
    assert proofs.is_pairwise_stable(LEMMA1_MISSION, run.assignment, mode="strict", capped=True)


@pytest.mark.xfail(strict=True, reason="uncapped, a capped result leaves robots that would join")
def test_lemma1_uncapped_pair_grape_s_is_nash_stable() -> None:
    run = pair_grape_s(UNCAPPED_MISSION)
    assert proofs.is_nash_stable(UNCAPPED_MISSION, run.assignment)


SEED_CELLS = [
    pytest.param(s, k, p, id=f"{s}:{k}-{p}%")
    for s, k in ((5, 1), (5, 5), (10, 1), (10, 5))
    for p in (10, 50)
]


@pytest.mark.parametrize(("service_types", "per_robot", "percent"), SEED_CELLS)
def test_seed_missions_observed_optimal_and_stable(service_types, per_robot, percent) -> None:
    # Observed on 5 missions per cell, both orders: optimal, Nash stable (capped and
    # uncapped) and pairwise stable (strict and pareto): the counterexamples are rare.
    cell = GridCell(100, percent, service_types, per_robot)
    for index in range(5):
        m = cell.mission(index)
        for order in ("index", "random"):
            run = pair_grape_s(m, seed=index, order=order)
            assert run.assignment.percent_utility(m) == 100.0
            assert proofs.is_nash_stable(m, run.assignment)
            assert proofs.is_nash_stable(m, run.assignment, capped=True)
            assert proofs.is_pairwise_stable(m, run.assignment, mode="strict")
            assert proofs.is_pairwise_stable(m, run.assignment, mode="pareto")


def test_pairwise_step_runs_often_on_10_5() -> None:
    # The seed's Pair-GRAPE-S needed its pairwise step on 10:5 only; observed here.
    ran = {
        (p, i): pair_grape_s(GridCell(100, p, 10, 5).mission(i)).pairwise_step_ran
        for p in (10, 50)
        for i in range(5)
    }
    assert sum(ran.values()) == 8


@pytest.mark.parametrize("order", ["index", "random"])
def test_same_mission_same_seed_same_run(order) -> None:
    m = GridCell(100, 10, 10, 5).mission(2)
    a, b = pair_grape_s(m, seed=3, order=order), pair_grape_s(m, seed=3, order=order)
    assert a.replace_seconds(0.0) == b.replace_seconds(0.0)
    assert a.to_dict(m)["algorithm"] == "pair-grape-s"
    assert np.array_equal(a.trajectory, b.trajectory)
