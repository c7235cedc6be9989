"""GRAPE-S: semantics, counts, stability, the seed's claims, determinism, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import proofs
from cfopt import Assignment, GridCell, Mission, MissionError
from heuristics import Run, grape_s
from heuristics.reward import reward_model
from proofs.strategies import missions


def small_mission() -> Mission:
    return Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])


# ------------------------------------------------------------------------ semantics
def test_the_last_robot_in_the_order_that_wants_to_move_moves() -> None:
    run = grape_s(small_mission())
    # round 1: everyone wants t0 (1/2 < 1/1); robot 2 is last -> it moves.
    # round 2: robot 2 at 1/2 stays; robot 1 joins t0 (2/2 ties 1/1, lower task wins).
    # round 3: t0 is at 1, joining t1 gives 1/1, not strictly better; robot 0 joins t1.
    assert run.trajectory.tolist() == [[1, 2, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0]]
    assert run.assignment == Assignment(task=[1, 0, 0], service=[0, 0, 0])
    assert (run.iterations, run.rounds) == (3, 4)


def test_switching_service_within_a_task_is_a_move() -> None:
    # t0 needs 2 x s0 and 1 x s1; r2 can do both.  r2 and r1 fill s0 (r2 prefers 1/2 to
    # 1/1), r0 over-fills it (anything beats the void task), then r2 at 3/2 switches to s1.
    m = Mission.from_arrays([[1, 0], [1, 0], [1, 1]], [[2, 1]], [3])
    run = grape_s(m)
    assert run.trajectory.tolist() == [[1, 2, 0, 0], [2, 1, 0, 0], [3, 0, 0, 0], [4, 2, 0, 1]]
    assert run.assignment.utility(m) == 3.0
    assert proofs.is_nash_stable(m, run.assignment)


def test_counts_follow_the_documented_model() -> None:
    m = GridCell(50, 10, 10, 5).mission(0)
    run = grape_s(m)
    n = m.n_robots
    assert run.rounds == run.iterations + 1
    assert run.messages == run.rounds * n  # one broadcast per robot and round
    assert run.bytes == run.messages * (16 + 4 * n)
    unicast = run.rounds * n * (n - 1)
    assert run.communication_cost("unicast") == (unicast, unicast * (16 + 4 * n))
    slots_per_service = (m.requirements > 0).sum(axis=0)
    per_round = int((m.capabilities.astype(np.int64) @ slots_per_service).sum())
    assert run.work == run.rounds * per_round
    assert len(run.trajectory) == run.iterations


def test_no_robots_and_no_capable_robots() -> None:
    empty = Mission.from_arrays(np.zeros((0, 2), bool), [[1, 0]], [4])
    run = grape_s(empty)
    assert (run.iterations, run.rounds, run.messages, run.work) == (0, 1, 0, 0)
    idle = Mission.from_arrays([[0, 1], [0, 1]], [[1, 0]], [4])
    run = grape_s(idle)
    assert run.iterations == 0 and run.assignment.n_assigned == 0


def test_capped_never_overfills_a_slot() -> None:
    m = Mission.from_arrays(np.ones((6, 1), bool), [[1], [2]], [1, 1])
    capped, free = grape_s(m, capped=True), grape_s(m)
    assert capped.assignment.counts(m).tolist() == [[1], [2]]
    assert capped.assignment.n_assigned == 3
    assert free.assignment.n_assigned == 6  # uncapped: the spare robots join anyway


def test_rewards_compare_exactly_even_where_floats_tie() -> None:
    paper = reward_model(Mission.from_arrays([[1]], [[3], [6]], [1, 1]), "paper")
    assert paper.key(0, 0, 1) == paper.key(1, 0, 2)  # 1/3 == 2/6: an exact tie
    big = 2**31 - 1
    m = Mission.from_arrays([[1]], [[big], [big - 1]], [1, 1])
    model = reward_model(m, "paper")
    a, b = model.key(0, 0, big - 1), model.key(1, 0, big - 2)
    assert float(a) == float(b)  # indistinguishable as floats ...
    assert b < a  # ... but (big-2)/(big-1) < (big-1)/big exactly


def test_utility_reward_ties_only_when_weight_and_load_match() -> None:
    m = Mission.from_arrays([[1, 1]], [[1, 1], [2, 0], [1, 0]], [4, 4, 2])
    model = reward_model(m, "utility")  # w = 4/2, 4/2, 2/1: all equal to 2
    assert model.key(0, 0, 1) == model.key(1, 0, 2) == model.key(2, 0, 1)
    assert model.key(0, 0, 1) < model.key(0, 1, 2)
    with pytest.raises(MissionError, match="reward: must be one of paper, utility"):
        reward_model(m, "flat")


# ------------------------------------------------------------------------ stability
@given(
    mission=missions(min_robots=0, max_robots=40, max_tasks=6, max_services=4),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_grape_s_results_are_nash_stable(mission, order, seed) -> None:
    run = grape_s(mission, seed=seed, order=order)
    assert proofs.nash_violations(mission, run.assignment) == []
    capped = grape_s(mission, seed=seed, order=order, capped=True)
    assert proofs.nash_violations(mission, capped.assignment, capped=True) == []


@given(
    n_per_task=st.lists(st.integers(1, 6), min_size=1, max_size=6),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_single_service_grape_is_optimal_on_achievable_missions(n_per_task, order, seed) -> None:
    # Original GRAPE (Jang et al. 2018) = GRAPE-S with one service.  With sum(req) = n
    # every Nash stable partition has c = req everywhere (a short task would lure a robot
    # from an over-full one), so GRAPE must be optimal; it also never revises: n moves.
    n = sum(n_per_task)
    m = Mission.from_arrays(np.ones((n, 1), bool), [[k] for k in n_per_task], [1] * len(n_per_task))
    run = grape_s(m, seed=seed, order=order)
    assert run.assignment.counts(m)[:, 0].tolist() == n_per_task
    assert run.assignment.percent_utility(m) == 100.0
    assert run.iterations == n
    assert proofs.is_nash_stable(m, run.assignment)
    assert proofs.is_pairwise_stable(m, run.assignment)


# ----------------------------------------------------------------- the seed's claims
SEED_CELLS = [
    pytest.param(s, k, p, id=f"{s}:{k}-{p}%")
    for s, k in ((5, 1), (5, 5), (10, 1))
    for p in (10, 50)
]


@pytest.mark.parametrize(("service_types", "per_robot", "percent"), SEED_CELLS)
def test_seed_claims_optimal_in_exactly_n_iterations(service_types, per_robot, percent) -> None:
    # The seed: GRAPE-S is optimal on achievable 5:1, 5:5, 10:1 missions and needs exactly
    # n iterations.  Observed here on 5 missions per cell, both orders: it holds.
    cell = GridCell(100, percent, service_types, per_robot)
    for index in range(5):
        m = cell.mission(index)
        for order in ("index", "random"):
            run = grape_s(m, seed=index, order=order)
            assert run.assignment.percent_utility(m) == 100.0
            assert run.iterations == m.n_robots
            assert run.rounds == m.n_robots + 1


def test_observed_10_5_cells_are_optimal_but_need_more_than_n_iterations() -> None:
    # Not claimed optimal by the seed (it saw a 89.68 % worst case); recorded as observed
    # on the same 5 missions per level, index order: all optimal, iterations > n mostly.
    observed = {}
    for percent in (10, 50):
        cell = GridCell(100, percent, 10, 5)
        runs = [grape_s(cell.mission(i)) for i in range(5)]
        observed[percent] = [
            (r.assignment.percent_utility(cell.mission(i)), r.iterations)
            for i, r in enumerate(runs)
        ]
    assert observed == {
        10: [(100.0, 107), (100.0, 108), (100.0, 106), (100.0, 101), (100.0, 102)],
        50: [(100.0, 101), (100.0, 101), (100.0, 103), (100.0, 103), (100.0, 101)],
    }


# ---------------------------------------------------------------------- determinism
@pytest.mark.parametrize("order", ["index", "random"])
def test_same_mission_same_seed_same_run(order) -> None:
    m = GridCell(100, 10, 10, 5).mission(1)
    first, second = grape_s(m, seed=42, order=order), grape_s(m, seed=42, order=order)
    assert first.replace_seconds(0.0) == second.replace_seconds(0.0)
    gen = grape_s(m, seed=np.random.default_rng(42), order=order)
    assert gen.trajectory.tolist() == first.trajectory.tolist() and gen.seed is None


def test_random_order_depends_on_the_seed() -> None:
    m = GridCell(100, 10, 10, 5).mission(1)
    trajectories = {tuple(grape_s(m, seed=s, order="random").trajectory[:, 1]) for s in range(4)}
    assert len(trajectories) > 1


def test_run_is_frozen_and_serialises() -> None:
    m = small_mission()
    run = grape_s(m, seed=7)
    with pytest.raises(AttributeError):
        run.iterations = 0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        run.trajectory[0, 0] = 5
    d = run.to_dict(m)
    for key in (
        "algorithm",
        "seed",
        "utility",
        "total_utility",
        "percent_utility",
        "iterations",
        "messages",
        "bytes",
        "seconds",
        "assignment",
    ):
        assert key in d
    assert d["algorithm"] == "grape-s" and d["seed"] == 7
    assert d["utility"] == 10.0 and math.isclose(d["percent_utility"], 100.0)
    assert d["assignment"][0] == {"robot": "r0", "task": "t1", "service": "s0"}
    assert isinstance(run, Run) and run == run.replace_seconds(run.seconds)


# ----------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        pytest.param({"order": "reverse"}, "order: must be one of index, random", id="order"),
        pytest.param({"reward": "flat"}, "reward: must be one of paper, utility", id="reward"),
    ],
)
def test_bad_options_raise_mission_error(kwargs, match) -> None:
    with pytest.raises(MissionError, match=match):
        grape_s(small_mission(), **kwargs)


def test_a_non_mission_is_rejected() -> None:
    with pytest.raises(MissionError, match=r"mission: must be a cfopt\.Mission"):
        grape_s({"robots": []})  # type: ignore[arg-type]
