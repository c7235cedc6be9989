"""The grouped, highspy-direct aggregated model against the ungrouped cvxpy one.

``solve_exact``'s aggregated path groups robots into capability types, services into
classes (equal capability columns) and tasks into (requirements, utility) groups, and
hands the arrays to HiGHS through highspy.  The ungrouped model, one binary per task,
written in cvxpy (``exact._aggregated_core_cvxpy``, the solver before the grouping),
is the reference: both must reach the same utility, and every result must pass the
independent checks of ``test_exact`` (plain-Python validity and utility, brute force).
The groupings themselves are checked against their definitions.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from cfopt import ExactStatus, Mission, solve_exact
from cfopt import _exact_groups as groups
from cfopt import exact as exact_module
from proofs import strategies
from tests.cfopt.test_exact import (
    assert_honest,
    brute_force_optimum,
    independent_utility,
    small_missions,
)


def reference(mission: Mission, mip_gap: float = 0.0) -> tuple[ExactStatus, float, float]:
    """Status, utility and bound of the ungrouped cvxpy model (the solver before this
    change), through the same presolve, runner and lift as ``solve_exact``."""
    reduced = exact_module._presolve(mission)
    if reduced.n_tasks == 0 or reduced.n_robots == 0:
        return ExactStatus.OPTIMAL, 0.0, 0.0
    outcome = exact_module._run(
        exact_module._aggregated_core_cvxpy, reduced, exact_module._Clock(None), mip_gap
    )
    assignment = exact_module._lift(mission, reduced, outcome.task, outcome.service)
    return outcome.status, independent_utility(mission, assignment), outcome.bound


def assert_same_as_reference(mission: Mission) -> cfopt.ExactResult:
    result = solve_exact(mission)
    assert_honest(mission, result)
    status, utility, bound = reference(mission)
    assert result.status is status is ExactStatus.OPTIMAL
    if float(np.max(mission.utilities, initial=0.0)).is_integer():
        assert result.utility == utility  # integral utilities: identical optima
    else:
        assert result.utility == pytest.approx(utility, rel=1e-12, abs=0)
    assert result.bound == pytest.approx(bound if math.isfinite(bound) else utility, rel=1e-12)
    return result


# ----------------------------------------------------------- the two models agree
@settings(max_examples=15)
@given(
    mission=strategies.missions(
        min_robots=0, max_robots=30, max_tasks=25, max_requirement=2, max_utility=3
    )
)
def test_grouped_model_matches_the_ungrouped_one_on_missions_with_duplicates(
    mission: Mission,
) -> None:
    # utilities in 1..3 and requirements up to 2: many tasks share a group
    assert_same_as_reference(mission)


@settings(max_examples=25)
@given(mission=strategies.missions(max_robots=20, max_tasks=8, density=0.5))
def test_grouped_model_matches_the_ungrouped_one_on_free_missions(mission: Mission) -> None:
    assert_same_as_reference(mission)


@settings(max_examples=25)
@given(mission=strategies.achievable_missions(max_robots=25, max_tasks=12))
def test_achievable_missions_are_completed(mission: Mission) -> None:
    result = assert_same_as_reference(mission)
    assert result.utility == mission.total_utility


@settings(max_examples=30)
@given(mission=small_missions(max_robots=10, max_tasks=6))
def test_grouped_model_reaches_the_brute_force_optimum(mission: Mission) -> None:
    # float utilities too (0.001..100, and 0): equal utilities group, others do not
    expected = brute_force_optimum(mission)
    result = assert_same_as_reference(mission)
    assert result.utility == pytest.approx(expected, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize(
    ("robots", "percent", "services", "per_robot", "load", "seed"),
    [
        (1000, 50, 5, 1, 1.0, 0),
        (1000, 50, 5, 1, 1.25, 1),
        (1000, 50, 5, 5, 1.25, 2),
        (1000, 50, 10, 1, 1.25, 3),
        (1000, 50, 10, 5, 1.0, 4),
        (1000, 50, 10, 5, 1.25, 5),
        (500, 10, 10, 5, 1.25, 6),
        (300, 50, 10, 3, 1.5, 7),
    ],
)
def test_grouped_model_matches_the_ungrouped_one_on_seeded_missions(
    robots: int, percent: int, services: int, per_robot: int, load: float, seed: int
) -> None:
    mission = cfopt.generate_mission(robots, percent, services, per_robot, load=load, seed=seed)
    result = assert_same_as_reference(mission)
    if load <= 1.0:  # achievable by construction
        assert result.utility == mission.total_utility


@pytest.mark.parametrize("exponent", [-1074, -1000, -30, 0, 40, 1000])
def test_power_of_two_utilities_group_and_scale_exactly(exponent: int) -> None:
    # Ten identical tasks in pairs of equal utility: five groups of two; the optimum
    # (four robots: the two best pairs of one-robot tasks) scales with the utilities.
    utilities = np.ldexp(np.repeat([1.0, 2.0, 3.0, 0.5, 1.5], 2), exponent)
    mission = Mission.from_arrays(np.ones((4, 1), bool), np.ones((10, 1), int), utilities)
    result = solve_exact(mission)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    expected = math.ldexp(2 * 3.0 + 2 * 2.0, exponent)
    assert (result.utility, result.bound) == (expected, expected)
    # the lowest-indexed tasks of each group chosen: t4, t5 (3.0), t2, t3 (2.0)
    assert sorted(result.assignment.task.tolist()) == [2, 3, 4, 5]


def test_the_lowest_indexed_tasks_of_a_group_are_done() -> None:
    # Six identical tasks, robots for three: tasks 0, 1, 2.
    mission = Mission.from_arrays(np.ones((6, 2), bool), [[1, 1]] * 6, [7.0] * 6)
    result = solve_exact(mission)
    assert result.status is ExactStatus.OPTIMAL
    assert result.utility == 21.0
    assert sorted(set(result.assignment.task.tolist())) == [0, 1, 2]


def test_grouped_model_is_small_where_the_mission_repeats_itself() -> None:
    # Every robot has every service: one class; 200 tasks over 3 requirement totals
    # and 4 utilities: at most 12 task columns.
    rng = np.random.default_rng(0)
    reqs = np.zeros((200, 5), dtype=np.int64)
    reqs[np.arange(200), rng.integers(0, 5, 200)] = rng.integers(1, 4, 200)
    mission = Mission.from_arrays(np.ones((150, 5), bool), reqs, rng.integers(1, 5, 200))
    reduced = exact_module._presolve(mission)
    grouped = exact_module._group(reduced)
    assert grouped.classes.n_classes == 1
    assert grouped.n_groups <= 12
    assert exact_module._grouped_model(grouped, 0).n_columns == grouped.n_groups + 1
    assert_same_as_reference(mission)


# --------------------------------------------------------------- time and honesty
def test_a_passed_deadline_stops_the_grouped_model_before_highs() -> None:
    reduced = exact_module._presolve(cfopt.generate_mission(50, 50, 5, 2, seed=0))
    clock = exact_module._Clock(time.perf_counter() - 1.0)
    with pytest.raises(exact_module._OutOfTime):
        exact_module._aggregated_core(reduced, clock, 0.0)
    outcome = exact_module._run(exact_module._aggregated_core, reduced, clock, 0.0)
    assert outcome is exact_module._OUT_OF_TIME


def test_time_limit_on_the_grouped_model_is_honest_and_on_time() -> None:
    # 1000 robots with one of ten services each, 1.5x over-subscribed: a 10-dimensional
    # knapsack HiGHS does not prove within 0.2 s on this machine (or does: both honest).
    mission = cfopt.generate_mission(2000, 50, 10, 1, load=1.5, seed=1)
    solve_exact(cfopt.generate_mission(10, 10, 3, 1, seed=0))  # imports done
    start = time.perf_counter()
    result = solve_exact(mission, time_limit=0.2)
    wall = time.perf_counter() - start
    assert wall <= 0.2 + exact_module.TIME_LIMIT_SLACK
    assert_honest(mission, result)
    full = solve_exact(mission)
    assert full.status is ExactStatus.OPTIMAL
    assert result.utility <= full.utility <= result.bound * (1 + 1e-12)
    for thread in __import__("threading").enumerate():
        if thread.name == "cfopt-solve-exact":
            thread.join(timeout=60)


def test_highs_model_statuses_map_like_cvxpy_with_an_error_fallback() -> None:
    import highspy

    table = exact_module._HIGHS_STATUS_TABLE
    for status in highspy.HighsModelStatus.__members__.values():
        expected = {"kOptimal": ExactStatus.OPTIMAL, "kTimeLimit": ExactStatus.TIME_LIMIT}
        got = table.get(status.name, ExactStatus.ERROR)
        if status.name in expected:
            assert got is expected[status.name]
        elif status.name in {"kInfeasible", "kUnbounded", "kModelError", "kSolveError"}:
            assert got is ExactStatus.ERROR
    assert table.get("a status HiGHS adds next year", ExactStatus.ERROR) is ExactStatus.ERROR


# ----------------------------------------------------------------- the groupings
@settings(max_examples=40)
@given(
    n=st.integers(0, 40),
    width=st.sampled_from([1, 3, 8, 9, 64, 65, 130]),
    distinct=st.integers(1, 6),
    seed=st.integers(0, 2**16),
)
def test_unique_boolean_rows_is_np_unique_by_rows(
    n: int, width: int, distinct: int, seed: int
) -> None:
    rng = np.random.default_rng(seed)  # a few distinct rows, repeated in any order
    rows = (rng.random((distinct, width)) < 0.5)[rng.integers(0, distinct, n)]
    first, inverse = groups.unique_boolean_rows(rows)
    if len(rows) == 0:
        assert len(first) == len(inverse) == 0
        return
    distinct, expected_inverse = np.unique(rows, axis=0, return_inverse=True)
    assert np.array_equal(rows[first], distinct)
    assert np.array_equal(inverse, expected_inverse.reshape(-1))
    for label, index in enumerate(first.tolist()):  # the first occurrence
        assert np.flatnonzero(inverse == label)[0] == index


@settings(max_examples=40)
@given(m=st.integers(1, 30), seed=st.integers(0, 2**16))
def test_task_groups_are_equal_requirements_and_utility(m: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    reqs = rng.integers(0, 3, (m, 3))
    utils = rng.choice([1.0, 2.0, 0.5, 1e-300], m)
    grouping = groups.task_groups(reqs, utils)
    for i in range(m):
        for j in range(m):
            same = bool((reqs[i] == reqs[j]).all() and utils[i] == utils[j])
            assert bool(grouping.of_task[i] == grouping.of_task[j]) is same
    for g, first in enumerate(grouping.first.tolist()):
        members = np.flatnonzero(grouping.of_task == g)
        assert first == members[0]
        assert grouping.multiplicity[g] == len(members)
        assert grouping.rank[members].tolist() == list(range(len(members)))
    done = np.minimum(grouping.multiplicity, 1)
    chosen = grouping.chosen(done)
    assert np.array_equal(np.flatnonzero(chosen), np.sort(grouping.first))


@given(
    kinds=st.integers(1, 12).flatmap(
        lambda k: st.lists(
            st.lists(st.booleans(), min_size=6, max_size=6), min_size=k, max_size=k
        ).map(lambda data: np.array(data, dtype=bool))
    ),
    seed=st.integers(0, 2**16),
)
def test_service_classes_and_the_north_west_split(kinds: np.ndarray, seed: int) -> None:
    kinds = np.unique(kinds, axis=0)
    rng = np.random.default_rng(seed)
    types = groups.Types(
        kinds=kinds,
        which=np.arange(len(kinds)),
        counts=rng.integers(1, 6, len(kinds)),
        pair_kind=np.nonzero(kinds)[0],
        pair_service=np.nonzero(kinds)[1],
    )
    classes = groups.service_classes(kinds)
    for s in range(6):
        for t in range(6):
            same = bool((kinds[:, s] == kinds[:, t]).all())
            assert bool(classes.of_service[s] == classes.of_service[t]) is same
    assert classes.representative.tolist() == sorted(
        int(np.flatnonzero(classes.of_service == c)[0]) for c in range(classes.n_classes)
    )
    reqs = rng.integers(0, 4, (5, 6))
    merged = classes.merge(reqs)
    for c in range(classes.n_classes):
        members = classes.of_service == c
        assert np.array_equal(merged[:, c], reqs[:, members].sum(axis=1))
    # A random type -> class flow; a per-service demand that sums to it per class.
    pair_kind, pair_class = np.nonzero(kinds[:, classes.representative])
    class_flow = rng.integers(0, 4, len(pair_kind))
    demand = np.zeros(6, dtype=np.int64)
    for c in range(classes.n_classes):
        members = np.flatnonzero(classes.of_service == c)
        total = int(class_flow[pair_class == c].sum())
        cuts = np.sort(rng.integers(0, total + 1, len(members) - 1))
        demand[members] = np.diff(np.concatenate(([0], cuts, [total])))
    flow = groups.split_class_flow(types, classes, pair_kind, pair_class, class_flow, demand)
    assert flow.dtype.kind == "i" and (flow >= 0).all()
    assert np.bincount(types.pair_service, flow, 6).tolist() == demand.tolist()
    for k in range(len(kinds)):
        assert flow[types.pair_kind == k].sum() == class_flow[pair_kind == k].sum()
    with pytest.raises(ValueError, match="not its services' demand"):
        groups.split_class_flow(types, classes, pair_kind, pair_class, class_flow, demand + 1)
