"""The exact solver: both ILP formulations against a brute force written here.

Nothing in this file calls cfopt's own evaluation (``Assignment.utility``, ``counts``,
``validate``) to judge a result: :func:`independent_utility` recomputes validity and
utility with plain Python, and :func:`brute_force_optimum` enumerates task subsets and
decides each by its own max-flow from robots to service demands.
"""

from __future__ import annotations

import itertools
import json
import math
import threading
import time

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from cfopt import ExactResult, ExactStatus, Mission, MissionError, solve_exact
from cfopt import exact as exact_module

FORMULATIONS = ("aggregated", "assignment")


# ------------------------------------------------------------------ independent oracles
def independent_utility(mission: Mission, assignment: cfopt.Assignment) -> float:
    """Check ``assignment`` against ``mission`` and return its utility, in plain Python."""
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    utils = mission.utilities.tolist()
    tasks = [int(j) for j in assignment.task.tolist()]
    services = [int(s) for s in assignment.service.tolist()]
    assert len(tasks) == len(services) == len(caps), "one entry per robot"
    filled: dict[tuple[int, int], int] = {}
    for i, (j, s) in enumerate(zip(tasks, services, strict=True)):
        if j == -1 and s == -1:
            continue
        assert 0 <= j < len(reqs) and 0 <= s < len(mission.services), (i, j, s)
        assert caps[i][s], f"robot {i} cannot perform service {s}"
        assert reqs[j][s] > 0, f"robot {i}: task {j} does not need service {s}"
        filled[j, s] = filled.get((j, s), 0) + 1
    done = [
        j
        for j, row in enumerate(reqs)
        if all(filled.get((j, s), 0) >= need for s, need in enumerate(row) if need > 0)
    ]
    return math.fsum(utils[j] for j in done)


def _subset_feasible(caps: list[list[bool]], demand: list[int]) -> bool:
    """Can distinct robots cover ``demand[s]`` robots per service?  (max-flow)"""
    total = sum(demand)
    if total == 0:
        return True
    if total > len(caps):
        return False
    graph = nx.DiGraph()
    for i, row in enumerate(caps):
        graph.add_edge("src", ("r", i), capacity=1)
        for s, has in enumerate(row):
            if has and demand[s]:
                graph.add_edge(("r", i), ("s", s), capacity=1)
    for s, need in enumerate(demand):
        if need:
            graph.add_edge(("s", s), "dst", capacity=need)
    if "src" not in graph or "dst" not in graph:
        return False
    return nx.maximum_flow_value(graph, "src", "dst") == total


def brute_force_optimum(mission: Mission) -> float:
    """The best utility over all task subsets whose demands robots can cover."""
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    utils = mission.utilities.tolist()
    best = 0.0
    for size in range(1, len(reqs) + 1):
        for subset in itertools.combinations(range(len(reqs)), size):
            value = math.fsum(utils[j] for j in subset)
            if value <= best:
                continue
            demand = [sum(reqs[j][s] for j in subset) for s in range(len(mission.services))]
            if _subset_feasible(caps, demand):
                best = value
    return best


def assert_honest(mission: Mission, result: ExactResult, mip_gap: float = 0.0) -> None:
    """What every result must satisfy, whatever its status."""
    assert isinstance(result.status, ExactStatus)
    utility = independent_utility(mission, result.assignment)
    assert result.utility == pytest.approx(utility, rel=1e-12, abs=0)
    assert result.total_utility == pytest.approx(math.fsum(mission.utilities.tolist()))
    assert result.bound >= result.utility
    assert result.bound <= result.total_utility * (1 + 1e-12)
    expected_gap = (result.bound - result.utility) / max(result.bound, 1e-12)
    assert result.gap == pytest.approx(expected_gap, abs=1e-12)
    assert result.seconds >= 0
    if result.status is ExactStatus.OPTIMAL:  # proven: within the gap asked for
        assert result.gap <= mip_gap + 1e-9


# ------------------------------------------------------------------------ strategies
_UTILITY = st.one_of(
    st.just(0.0),
    st.integers(1, 50).map(float),
    st.floats(0.001, 100.0, allow_nan=False, allow_infinity=False),
)


@st.composite
def small_missions(
    draw: st.DrawFn,
    *,
    max_robots: int = 12,
    max_tasks: int = 7,
    max_services: int = 4,
    min_load: float = 0.5,
    max_load: float = 2.5,
    utilities: st.SearchStrategy[float] = _UTILITY,
) -> Mission:
    """Missions small enough to enumerate: robots may have no service, tasks may be
    worth 0, and the total requirement is about ``load * n`` (at least one per task)."""
    if not (max_robots >= 0 and max_tasks >= 0 and max_services >= 1 and min_load <= max_load):
        raise ValueError("small_missions: bad bounds")
    n_services = draw(st.integers(1, max_services))
    n_robots = draw(st.integers(0, max_robots))
    n_tasks = draw(st.integers(0, max_tasks))
    caps = np.array(
        draw(
            st.lists(
                st.lists(st.booleans(), min_size=n_services, max_size=n_services),
                min_size=n_robots,
                max_size=n_robots,
            )
        ),
        dtype=bool,
    ).reshape(n_robots, n_services)
    reqs = np.zeros((n_tasks, n_services), dtype=np.int64)
    if n_tasks:
        load = draw(st.floats(min_load, max_load))
        total = max(n_tasks, round(load * max(n_robots, 1)))
        for j in range(n_tasks):  # every task needs at least one service
            reqs[j, draw(st.integers(0, n_services - 1))] += 1
        extra = draw(
            st.lists(
                st.tuples(st.integers(0, n_tasks - 1), st.integers(0, n_services - 1)),
                min_size=total - n_tasks,
                max_size=total - n_tasks,
            )
        )
        for j, s in extra:
            reqs[j, s] += 1
    utils = draw(st.lists(utilities, min_size=n_tasks, max_size=n_tasks))
    return Mission.from_arrays(caps, reqs, np.array(utils, dtype=float).reshape(n_tasks))


# ----------------------------------------------------------------- brute-force agreement
@given(mission=small_missions())
def test_both_formulations_reach_the_brute_force_optimum(mission: Mission) -> None:
    expected = brute_force_optimum(mission)
    for formulation in FORMULATIONS:
        result = solve_exact(mission, formulation=formulation)
        assert_honest(mission, result)
        assert result.status is ExactStatus.OPTIMAL, formulation
        assert result.formulation == formulation
        assert result.utility == pytest.approx(expected, rel=1e-9, abs=1e-12), formulation
        assert result.bound == pytest.approx(expected, rel=1e-9, abs=1e-12), formulation


_WIDE = st.integers(-3, 6).flatmap(
    lambda e: st.floats(0.5, 9.5).map(lambda mantissa: mantissa * 10.0**e)
)


@settings(max_examples=40)
@given(mission=small_missions(max_robots=10, max_tasks=7, utilities=_WIDE))
def test_utilities_from_1e_3_to_1e6_solve_to_the_true_optimum(mission: Mission) -> None:
    # Any other task subset differs by at least 5e-4 out of at most ~7e7: far beyond
    # 1e-12 relative, so this catches a solver that stops at HiGHS's default gaps.
    expected = brute_force_optimum(mission)
    for formulation in FORMULATIONS:
        result = solve_exact(mission, formulation=formulation)
        assert_honest(mission, result)
        assert result.status is ExactStatus.OPTIMAL
        assert result.utility == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_the_smallest_utility_decides_against_a_million() -> None:
    # r0..r2 do the 1e6 task; r3 can do one of two tasks worth 1e-3 and 2e-3.
    mission = Mission.from_arrays(
        [[1, 0], [1, 0], [1, 0], [0, 1]],
        [[3, 0], [0, 1], [0, 1]],
        [1e6, 1e-3, 2e-3],
    )
    for formulation in FORMULATIONS:
        result = solve_exact(mission, formulation=formulation)
        assert result.status is ExactStatus.OPTIMAL
        assert result.utility == math.fsum([1e6, 2e-3])
        assert independent_utility(mission, result.assignment) == result.utility
        assert result.assignment.task.tolist() == [0, 0, 0, 2]


def _knapsack_optimum(weights: list[int], values: list[float], capacity: int) -> float:
    """0/1 knapsack by dynamic programming over the capacity (exact, independent)."""
    best = [0.0] * (capacity + 1)
    for weight, value in zip(weights, values, strict=True):
        for c in range(capacity, weight - 1, -1):
            best[c] = max(best[c], best[c - weight] + value)
    return best[capacity]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_million_does_not_hide_a_suboptimal_remainder(seed: int) -> None:
    # One service, identical robots: the mission is a 0/1 knapsack (robots = capacity).
    # A task worth 1e6 dwarfs 40 tasks worth 1e-3..1e2; HiGHS's default gaps
    # (rel 1e-4, abs 1e-6) accept a remainder tens of units short on these seeds.
    rng = np.random.default_rng(seed)
    weights = rng.integers(5, 40, 40)
    values = np.round(weights * (1 + rng.random(40) / 10) * 10 ** rng.uniform(-3, 0, 40) * 100, 3)
    weights = np.concatenate(([1], weights))
    values = np.concatenate(([1e6], values + 1e-3))
    robots = int(weights.sum() // 2)
    mission = Mission.from_arrays(np.ones((robots, 1), bool), weights.reshape(-1, 1), values)
    expected = _knapsack_optimum(weights.tolist(), values.tolist(), robots)
    result = solve_exact(mission)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert result.utility == pytest.approx(expected, rel=1e-14)


# ---------------------------------------------------------------- formulations agree
@pytest.mark.parametrize(
    ("robots", "percent", "services", "per_robot", "load", "seed"),
    [
        (30, 10, 5, 2, 1.0, 0),
        (40, 20, 5, 1, 1.5, 1),
        (45, 10, 10, 5, 1.25, 2),
        (50, 10, 5, 5, 2.0, 3),
        (60, 10, 10, 5, 1.25, 4),
        (60, 5, 10, 1, 0.75, 5),
    ],
)
def test_formulations_agree_on_seeded_missions(
    robots: int, percent: int, services: int, per_robot: int, load: float, seed: int
) -> None:
    mission = cfopt.generate_mission(robots, percent, services, per_robot, load=load, seed=seed)
    results = [solve_exact(mission, formulation=f) for f in FORMULATIONS]
    for result in results:
        assert_honest(mission, result)
        assert result.status is ExactStatus.OPTIMAL
    assert results[0].utility == pytest.approx(results[1].utility, rel=1e-12)
    if load <= 1.0:  # achievable by construction
        assert results[0].utility == pytest.approx(mission.total_utility)


def test_the_solver_is_deterministic() -> None:
    mission = cfopt.generate_mission(200, 10, 10, 5, load=1.25, seed=7)
    first, second = solve_exact(mission), solve_exact(mission)
    assert first.assignment == second.assignment
    assert first.utility == second.utility


# --------------------------------------------------------------------------- presolve
def test_presolved_tasks_and_robots_are_handled() -> None:
    mission = Mission.from_arrays(
        # r0 nothing; r1 s0; r2 s0+s1; r3 s2 only (no task needs s2 after presolve)
        [[0, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0], [0, 0, 1, 0]],
        [
            [1, 0, 0, 1],  # needs s3, which no robot has
            [1, 1, 0, 0],  # doable: 5
            [2, 0, 0, 0],  # doable, worth 0
            [0, 0, 2, 0],  # needs two s2 robots, only r3 has s2
            [3, 0, 0, 0],  # needs three s0 robots, two have s0
        ],
        [100.0, 5.0, 0.0, 50.0, 70.0],
    )
    for formulation in FORMULATIONS:
        result = solve_exact(mission, formulation=formulation)
        assert result.status is ExactStatus.OPTIMAL
        assert result.utility == 5.0 == brute_force_optimum(mission)
        assert result.bound == 5.0
        assert result.assignment.task.tolist() == [-1, 1, 1, -1]


@pytest.mark.parametrize(
    "mission",
    [
        pytest.param(Mission.from_arrays(np.zeros((0, 2), bool), [[1, 0]], [3.0]), id="no-robots"),
        pytest.param(Mission.from_arrays([[1, 0]], np.zeros((0, 2), int), []), id="no-tasks"),
        pytest.param(Mission.from_arrays([[0, 0]], [[1, 1]], [4.0]), id="nothing-doable"),
        pytest.param(Mission.from_arrays([[1], [1]], [[1]], [0.0]), id="worthless"),
    ],
)
@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_empty_missions_are_proven_optimal_with_nothing_done(
    mission: Mission, formulation: str
) -> None:
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert (result.utility, result.bound, result.gap) == (0.0, 0.0, 0.0)
    assert result.assignment.n_assigned == 0


# ------------------------------------------------------------------------- time limits
def _hard_mission(seed: int = 0) -> Mission:
    """A 10-service multidimensional knapsack with correlated utilities (hard to prove).

    Every robot has one service, so capability types are services; each service has
    robots for half of the tasks' total need of it.
    """
    rng = np.random.default_rng(seed)
    reqs = rng.integers(1, 30, size=(150, 10))
    utils = reqs.sum(axis=1) + rng.random(150) * 5
    per_service = reqs.sum(axis=0) // 2
    caps = np.repeat(np.eye(10, dtype=bool), per_service, axis=0)
    return Mission.from_arrays(caps, reqs, utils)


def _cut_with_an_incumbent(mission: Mission) -> tuple[ExactResult, float]:
    """A solve the time limit cut after HiGHS found an incumbent, and its limit.

    The state is waited for, not a time: on a loaded machine 0.3 s may pass before HiGHS
    has one, so the limit doubles until it has (the mission is far from proven even in
    30 s: every one of these solves is cut).
    """
    limit = 0.3
    while True:
        result = solve_exact(mission, time_limit=limit)
        assert_honest(mission, result)
        assert result.status is ExactStatus.TIME_LIMIT  # deliberately hard: never proven
        assert result.gap > 0
        if result.utility > 0 or limit > 20:
            return result, limit
        limit *= 2


def test_time_limit_reports_incumbent_and_a_proven_bound() -> None:
    mission = _hard_mission()
    short, limit = _cut_with_an_incumbent(mission)
    assert short.utility > 0  # HiGHS finds incumbents quickly here (on a loaded machine too)
    # The bound is a real upper bound: a longer run never beats it.
    longer = solve_exact(mission, time_limit=5 * limit)
    assert_honest(mission, longer)
    assert longer.utility <= short.bound * (1 + 1e-9)
    assert short.utility <= longer.bound * (1 + 1e-9)


def test_time_limit_without_an_incumbent_returns_the_empty_assignment() -> None:
    mission = cfopt.generate_mission(300, 10, 10, 5, load=1.5, seed=11)
    result = solve_exact(mission, time_limit=1e-3, formulation="assignment")
    assert_honest(mission, result)
    assert result.status is not ExactStatus.OPTIMAL or result.gap == pytest.approx(0.0, abs=1e-9)


def test_time_limit_generous_enough_is_still_optimal() -> None:
    mission = cfopt.generate_mission(100, 10, 10, 5, load=1.25, seed=3)
    result = solve_exact(mission, time_limit=60)
    assert result.status is ExactStatus.OPTIMAL
    assert result.utility == solve_exact(mission).utility


@pytest.fixture
def cvxpy_imported() -> None:
    """solve_exact's first call imports cvxpy (about a second) before its clock starts."""
    pytest.importorskip("cvxpy")


@pytest.mark.usefixtures("cvxpy_imported")
@pytest.mark.parametrize("limit", [0.05, 0.3], ids=["in-the-build", "in-the-compilation"])
def test_time_limit_bounds_the_whole_call_including_the_model_build(limit: float) -> None:
    # About 450,000 (robot, slot) variables: building and compiling the per-robot
    # model takes longer than the limit by itself (it used to be uncounted: > 1 s).
    # HiGHS would then need a reserve of about 1 s: it never starts.
    mission = cfopt.generate_mission(1000, 50, 10, 5, seed=0)  # every task doable
    walls = []
    for _ in range(3):  # a busy CI machine can stall one call; the bound must hold for one
        start = time.perf_counter()
        result = solve_exact(mission, time_limit=limit, formulation="assignment")
        walls.append(wall := time.perf_counter() - start)
        assert result.seconds <= wall
        _wait_for_abandoned_workers()
        if wall <= limit + exact_module.TIME_LIMIT_SLACK:
            break
    assert min(walls) <= limit + exact_module.TIME_LIMIT_SLACK, walls
    assert_honest(mission, result)
    # Out of time before HiGHS could run: nothing done, the doable tasks' total as bound.
    assert result.status is ExactStatus.TIME_LIMIT
    assert (result.utility, result.assignment.n_assigned) == (0.0, 0)
    assert result.bound == result.total_utility
    _wait_for_abandoned_workers()  # it stops at its next clock check: not the next test's


def _wait_for_abandoned_workers() -> None:
    for thread in threading.enumerate():
        if thread.name == "cfopt-solve-exact":
            thread.join(timeout=60)
            assert not thread.is_alive()


def test_a_late_worker_is_abandoned_and_its_exceptions_are_re_raised() -> None:
    reduced = exact_module._presolve(cfopt.generate_mission(10, 10, 3, 1, seed=0))
    release = threading.Event()

    def stuck(*_: object) -> exact_module._Outcome:  # like HiGHS past its own limit
        release.wait(10)
        return exact_module._FAILED

    def broken(*_: object) -> exact_module._Outcome:
        raise ValueError("a bug in the worker")

    start = time.perf_counter()
    clock = exact_module._Clock(start + 0.1)
    try:
        outcome = exact_module._run(stuck, reduced, clock, 0.0)
        wall = time.perf_counter() - start
    finally:
        release.set()
    assert wall <= 0.1 + exact_module.TIME_LIMIT_SLACK
    assert outcome is exact_module._OUT_OF_TIME
    _wait_for_abandoned_workers()
    with pytest.raises(ValueError, match="a bug in the worker"):
        exact_module._run(broken, reduced, exact_module._Clock(time.perf_counter() + 10), 0.0)


@pytest.mark.usefixtures("cvxpy_imported")
def test_a_busy_highs_is_waited_for_only_within_the_time_limit() -> None:
    mission = cfopt.generate_mission(30, 10, 5, 2, seed=0)  # every task doable
    with exact_module._HIGHS_LOCK:  # as while an abandoned HiGHS run finishes
        start = time.perf_counter()
        result = solve_exact(mission, time_limit=0.2)
        wall = time.perf_counter() - start
    assert wall <= 0.2 + exact_module.TIME_LIMIT_SLACK
    assert_honest(mission, result)
    assert result.status is ExactStatus.TIME_LIMIT
    assert (result.utility, result.bound) == (0.0, result.total_utility)
    assert solve_exact(mission, time_limit=10).status is ExactStatus.OPTIMAL


def test_a_forked_child_does_not_inherit_a_held_highs_lock(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(exact_module, "_HIGHS_LOCK", threading.Lock())
    exact_module._HIGHS_LOCK.acquire()  # held by a parent's thread at the fork
    exact_module._forget_parent_highs()  # what os.register_at_fork runs in the child
    assert exact_module._HIGHS_LOCK.acquire(blocking=False)
    exact_module._HIGHS_LOCK.release()


def test_mip_gap_is_passed_to_highs_and_reported_honestly() -> None:
    mission = _hard_mission(1)
    result = solve_exact(mission, mip_gap=0.05, time_limit=5)
    assert_honest(mission, result, mip_gap=0.05)
    assert result.status is ExactStatus.OPTIMAL  # a 5% gap is quick to prove here
    assert 0 < result.gap <= 0.05  # HiGHS stopped early, and the result says so


# ----------------------------------------------------------- huge and tiny utilities
@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_utilities_near_the_float_maximum_solve_exactly(formulation: str) -> None:
    # Two robots: t0 and t1 need one each, t2 needs both; {t0, t1} beats {t2}.  HiGHS
    # takes costs from 1e20 up for infinite: unscaled, this crashed.
    mission = Mission.from_arrays([[1], [1]], [[1], [1], [2]], [1e308, 5e307, 2e307])
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert result.utility == math.fsum([1e308, 5e307]) == brute_force_optimum(mission)
    assert (result.bound, result.gap) == (result.utility, 0.0)
    assert result.assignment.task.tolist() == [0, 1]


@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("utilities", [[1e308, 5e307], [5e307, 1e308]])
def test_one_robot_picks_the_larger_huge_utility(formulation: str, utilities: list) -> None:
    mission = Mission.from_arrays([[1]], [[1], [1]], utilities)
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert (result.utility, result.bound) == (1e308, 1e308)
    assert result.assignment.task.tolist() == [utilities.index(1e308)]


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_utilities_of_1e25_solve_the_knapsack_exactly(formulation: str) -> None:
    # Three robots: t0 needs two, t1 and t2 one each, t3 two.  {t0, t1} = 1.6e25 beats
    # {t0, t2}, {t3, t1} and {t1, t2}.
    mission = Mission.from_arrays([[1], [1], [1]], [[2], [1], [1], [2]], [1e25, 6e24, 5e24, 9e24])
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert result.utility == math.fsum([1e25, 6e24]) == brute_force_optimum(mission)
    assert (result.bound, result.gap) == (result.utility, 0.0)


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_tiny_utilities_alone_are_not_lost(formulation: str) -> None:
    # One robot, tasks worth 1e-300 and 3e-300: below every HiGHS tolerance unscaled
    # (it used to report "optimal" with nothing done).
    mission = Mission.from_arrays([[1]], [[1], [1]], [1e-300, 3e-300])
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert (result.utility, result.bound, result.gap) == (3e-300, 3e-300, 0.0)
    assert result.assignment.task.tolist() == [1]


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_tiny_utilities_beside_one_pass_the_checks(formulation: str) -> None:
    # Two robots, one slot each for tasks worth 1, 1e-300 and 3e-300: the optimum,
    # 1 + 3e-300, is 1.0 in floating point; HiGHS cannot tell the tiny ones apart.
    mission = Mission.from_arrays([[1], [1]], [[1], [1], [1]], [1.0, 1e-300, 3e-300])
    result = solve_exact(mission, formulation=formulation)
    assert_honest(mission, result)
    assert result.status is ExactStatus.OPTIMAL
    assert (result.utility, result.bound, result.gap) == (1.0, 1.0, 0.0)
    assert result.assignment.task[0] == 0 or result.assignment.task[1] == 0


@settings(max_examples=30)
@given(mission=small_missions(max_robots=10, max_tasks=6), exponent=st.integers(-1060, 1000))
def test_scaling_all_utilities_by_a_power_of_two_scales_the_optimum(
    mission: Mission, exponent: int
) -> None:
    # From subnormal to near-overflow utilities (the sum stays below 2**1010): the
    # optimum found is the brute force's, to the precision of the unscaled test.
    scaled = Mission.from_arrays(
        mission.capabilities, mission.requirements, np.ldexp(mission.utilities, exponent)
    )
    expected = brute_force_optimum(scaled)
    for formulation in FORMULATIONS:
        result = solve_exact(scaled, formulation=formulation)
        assert_honest(scaled, result)
        assert result.status is ExactStatus.OPTIMAL
        assert result.utility == pytest.approx(expected, rel=1e-9, abs=0), formulation
        assert result.bound == pytest.approx(expected, rel=1e-9, abs=0), formulation


@pytest.mark.parametrize(
    "top", [5e-324, 1e-300, 0.75, 1.0, 50.0, 1e6, 1e25, 1.7976931348623157e308]
)
def test_highs_sees_the_largest_utility_between_2_19_and_2_20_exactly(top: float) -> None:
    utilities = np.array([top, top / 3, 5e-324])
    shift = exact_module._shift(utilities)
    scaled = exact_module._scaled(utilities, shift)
    assert 2.0**19 <= scaled.max() < 2.0**20
    assert exact_module._unscale(float(scaled[0]), shift) == top  # only exponents change
    assert exact_module._unscale(1e300, -100) == math.inf  # overflow is inf, not an error


# ------------------------------------------------------------------ status and shapes
def test_status_table_maps_every_cvxpy_status_with_an_error_fallback() -> None:
    import cvxpy.settings as s

    assert exact_module._map_status(s.OPTIMAL) is ExactStatus.OPTIMAL
    assert exact_module._map_status(s.USER_LIMIT) is ExactStatus.TIME_LIMIT
    for status in (s.INFEASIBLE, s.UNBOUNDED, s.SOLVER_ERROR, s.OPTIMAL_INACCURATE, s.UNKNOWN):
        assert exact_module._map_status(status) is ExactStatus.ERROR
    assert exact_module._map_status("a status cvxpy adds next year") is ExactStatus.ERROR
    assert exact_module._map_status(None) is ExactStatus.ERROR
    assert [e.value for e in ExactStatus] == ["optimal", "time_limit", "error"]


def test_result_is_frozen_and_serialises_to_the_interface_keys() -> None:
    mission = cfopt.generate_mission(20, 10, 5, 2, seed=1)
    result = solve_exact(mission)
    with pytest.raises(AttributeError):
        result.utility = 0.0  # type: ignore[misc]
    data = json.loads(json.dumps(result.to_dict(mission)))
    assert {"status", "utility", "bound", "gap", "total_utility", "seconds", "assignment"} <= set(
        data
    )
    assert data["status"] == "optimal"
    rebuilt = cfopt.Assignment.from_dict(mission, {"assignment": data["assignment"]})
    assert independent_utility(mission, rebuilt) == data["utility"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        pytest.param({"time_limit": 0}, "time_limit: must be", id="time-limit-zero"),
        pytest.param({"time_limit": -1.0}, "time_limit: must be", id="time-limit-negative"),
        pytest.param({"time_limit": math.nan}, "time_limit: must be", id="time-limit-nan"),
        pytest.param({"time_limit": math.inf}, "time_limit: must be", id="time-limit-inf"),
        pytest.param({"time_limit": True}, "time_limit: must be", id="time-limit-bool"),
        pytest.param({"time_limit": "1"}, "time_limit: must be", id="time-limit-str"),
        pytest.param({"formulation": "dense"}, "formulation: must be one of", id="formulation"),
        pytest.param({"mip_gap": -0.1}, r"mip_gap: must be a number in \[0, 1\)", id="gap-neg"),
        pytest.param({"mip_gap": 1.0}, r"mip_gap: must be a number in \[0, 1\)", id="gap-one"),
        pytest.param({"mip_gap": math.nan}, r"mip_gap: must be", id="gap-nan"),
    ],
)
def test_bad_arguments_raise_mission_error(kwargs: dict, match: str) -> None:
    mission = cfopt.generate_mission(10, 10, 3, 1, seed=0)
    with pytest.raises(MissionError, match=match):
        solve_exact(mission, **kwargs)


def test_not_a_mission_raises_mission_error() -> None:
    with pytest.raises(MissionError, match=r"mission: must be a cfopt\.Mission"):
        solve_exact({"robots": []})  # type: ignore[arg-type]


# ----------------------------------------------------------- flow recovery, both paths
@pytest.mark.parametrize("start", ["none", "fractional", "infeasible"])
def test_integral_flow_meets_demand_from_any_start(start: str) -> None:
    rng = np.random.default_rng(5)
    kinds = np.unique(rng.random((40, 6)) < 0.5, axis=0)
    kinds = kinds[kinds.any(axis=1)]
    counts = rng.integers(1, 6, size=len(kinds))
    pair_kind, pair_service = np.nonzero(kinds)
    # A demand that a fractional flow meets: spread each type evenly over its services.
    even = counts[pair_kind] / kinds.sum(axis=1)[pair_kind]
    demand = np.floor(np.bincount(pair_service, even, kinds.shape[1])).astype(np.int64)
    lp_flow = {"none": None, "fractional": even, "infeasible": even * 3}[start]
    flow = exact_module._integral_flow(counts, demand, pair_kind, pair_service, lp_flow)
    assert flow.dtype.kind == "i" and (flow >= 0).all()
    per_kind = [int(flow[pair_kind == k].sum()) for k in range(len(kinds))]
    per_service = [int(flow[pair_service == s].sum()) for s in range(kinds.shape[1])]
    assert all(used <= int(c) for used, c in zip(per_kind, counts.tolist(), strict=True))
    assert per_service == demand.tolist()
