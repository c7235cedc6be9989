"""GRAPE-S-Select: the spec, move for move; validity, optimality gap, stability, counts."""

from __future__ import annotations

import importlib
import statistics
from fractions import Fraction

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import proofs.select_stability as sel
from cfopt import Assignment, GridCell, Mission, MissionError, generate_mission, solve_exact
from heuristics import grape_s
from heuristics.grape_s_select import fillable, grape_s_select, select_priorities
from proofs.strategies import missions

COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
OVERSUBSCRIBED = (1.25, 1.5, 2.0)
#: The floor this module asserts on the seeded 100-robot grid (the measured minimum there
#: is 67.8 %, on GridCell(100, 10, 10, 1, 2.0).mission(0), where SDA earns the same).
GRID_FLOOR = 65.0


# ------------------------------------------------------------- a literal reference
def _can_fill(mission: Mission, free: list[int], need: list[int], groups=()) -> bool:
    """A max-flow: free robots (one unit each) and groups (robots, at most ``cap`` used)."""
    graph = nx.DiGraph()
    caps = mission.capabilities
    for i in free:
        graph.add_edge("src", ("r", i), capacity=1)
    for g, (robots, cap) in enumerate(groups):
        graph.add_edge("src", ("g", g), capacity=cap)
        for i in robots:
            graph.add_edge(("g", g), ("r", i), capacity=1)
    for i in [*free, *(i for robots, _ in groups for i in robots)]:
        for s, r in enumerate(need):
            if r and caps[i, s]:
                graph.add_edge(("r", i), ("s", s), capacity=1)
    for s, r in enumerate(need):
        graph.add_edge(("s", s), "sink", capacity=r)
    if sum(need) == 0:
        return True
    if "src" not in graph:
        return False
    return nx.maximum_flow_value(graph, "src", "sink") == sum(need)


def literal_select(mission: Mission, *, seed=None, order="index", exchange=True):
    """The module notes of :mod:`heuristics.grape_s_select`, transcribed naively.

    Every round every robot enumerates every slot and every move is scored on the
    partition after it, counts recomputed from scratch; feasibility is a networkx
    max-flow.  Returns (trajectory, iterations, rounds).
    """
    n, S = mission.capabilities.shape
    reqs = mission.requirements.tolist()
    m = len(reqs)
    caps = mission.capabilities.tolist()
    util = [Fraction(u) for u in mission.utilities.tolist()]
    pi = sel.select_priorities(mission)  # independent of heuristics
    supply = [sum(row[s] for row in caps) for s in range(S)]
    demand = [sum(row[s] for row in reqs) for s in range(S)]
    sigma = [Fraction(demand[s], max(supply[s], 1)) for s in range(S)]
    viable = [util[j] > 0 and all(reqs[j][s] <= supply[s] for s in range(S)) for j in range(m)]
    closed = [not v for v in viable]
    used = [not v for v in viable]
    pos: list[tuple[int, int] | None] = [None] * n
    rng = np.random.default_rng(seed)

    def counts(p):
        c = [[0] * S for _ in range(m)]
        for q in p:
            if q is not None:
                c[q[0]][q[1]] += 1
        return c

    def complete(j, c):
        return all(c[j][s] >= reqs[j][s] for s in range(S))

    def reward(i, p, c):
        if p[i] is None:
            return -1
        j, s = p[i]
        if not viable[j] or not (complete(j, c) or not closed[j]):
            return -1
        return m + pi[j] if c[j][s] <= reqs[j][s] else pi[j]

    traj, iterations, rounds = [], 0, 0
    if n == 0:
        return traj, 0, 1

    def members(j):
        return [i for i in range(n) if pos[i] is not None and pos[i][0] == j]

    def release(j):
        for i in members(j):
            pos[i] = None
            traj.append((iterations, i, -1, -1))

    while True:
        rounds += 1
        sequence = rng.permutation(n).tolist() if order == "random" else list(range(n))
        c = counts(pos)
        cur = [reward(i, pos, c) for i in range(n)]
        proposal = None
        for i in sequence:
            best = None
            for k in range(m):
                for t in range(S):
                    if not caps[i][t] or not reqs[k][t] or pos[i] == (k, t):
                        continue
                    after = list(pos)
                    after[i] = (k, t)
                    r = reward(i, after, counts(after))
                    if r <= cur[i]:
                        continue
                    others = sum(1 for o in range(n) if o != i and caps[o][t] and cur[o] < r)
                    key = (-r, others - max(reqs[k][t] - c[k][t], 0), -sigma[t], t)
                    if best is None or key < best[0]:
                        best = (key, k, t)
            if best is not None:
                proposal = (i, best[1], best[2])  # the last robot in the order wins
        if proposal is not None:
            i, k, t = proposal
            pos[i] = (k, t)
            iterations += 1
            traj.append((iterations, i, k, t))
            continue
        # 1. close
        busy = [j for j in range(m) if not closed[j] and members(j) and not complete(j, c)]
        if busy:
            j = min(busy, key=lambda j: pi[j])
            iterations += 1
            release(j)
            closed[j] = True
            continue
        free = [i for i in range(n) if pos[i] is None]
        spares = [
            ([i for i in range(n) if pos[i] == (j, s)], c[j][s] - reqs[j][s], j)
            for j in range(m)
            for s in range(S)
            if reqs[j][s] and c[j][s] > reqs[j][s]
        ]
        cands = [j for j in range(m) if closed[j] and not used[j] and sum(reqs[j]) > 1]
        # 2. reopen
        done = False
        for j in sorted(cands, key=lambda j: -pi[j]):
            if _can_fill(mission, free, reqs[j], [(r, e) for r, e, _ in spares]):
                closed[j], used[j], done = False, True, True
                break
        if done:
            continue
        # 3. exchange
        if exchange:
            donors = sorted(
                (j for j in range(m) if members(j) and complete(j, c) and sum(reqs[j]) > 1),
                key=lambda j: (util[j], pi[j]),
            )

            def fits(k, given, free=free, spares=spares):
                pool = free + [i for d in given for i in members(d)]
                groups = [(r, e) for r, e, j in spares if j not in given]
                return _can_fill(mission, pool, reqs[k], groups)

            chosen = None
            for k in sorted(cands, key=lambda j: (-util[j], -pi[j])):
                for d in donors:
                    if util[d] < util[k] and fits(k, [d]):
                        chosen = (k, [d])
                        break
                if chosen is None:
                    total = Fraction(0)
                    for p, d in enumerate(donors):
                        total += util[d]
                        if total >= util[k]:
                            break
                        if fits(k, donors[: p + 1]):
                            chosen = (k, donors[: p + 1])
                            break
                if chosen is not None:
                    break
            if chosen is not None:
                k, given = chosen
                iterations += 1
                for d in given:
                    release(d)
                    closed[d] = True
                closed[k], used[k] = False, True
                continue
        return traj, iterations, rounds


# ------------------------------------------------------------------- semantics
def test_a_task_that_cannot_be_completed_is_closed_and_its_robot_released() -> None:
    m = Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
    run = grape_s_select(m)
    # r2, r1 fill t0; r0 starts t1, which is closed; r0 is released, then over-fills t0
    assert run.trajectory.tolist() == [
        [1, 2, 0, 0],
        [2, 1, 0, 0],
        [3, 0, 1, 0],
        [4, 0, -1, -1],
        [5, 0, 0, 0],
    ]
    assert run.assignment.task.tolist() == [0, 0, 0]
    assert (run.iterations, run.rounds) == (5, 6)


def test_reopen_gives_a_second_chance_after_a_closing_frees_robots() -> None:
    # r2 {a, b} starts the valuable X (a + b: only r2 can do either, so X cannot be done);
    # r0, r1 {c} start Y (b + 2 c).  Y is closed first (lower priority), then X; r2 is
    # free, Y is reopened and completed.
    m = Mission.from_arrays([[0, 0, 1], [0, 0, 1], [1, 1, 0]], [[1, 1, 0], [0, 1, 2]], [100, 10])
    run = grape_s_select(m)
    released = [row[1] for row in run.trajectory.tolist() if row[2] == -1]
    assert released == [0, 1, 2]  # Y's robots, then X's
    assert run.assignment.completed_tasks(m).tolist() == [1]
    assert run.assignment.utility(m) == solve_exact(m).utility == 10
    assert run.rounds == run.iterations + 2  # the reopening and the last, quiet round


def test_exchange_gives_up_a_cheaper_task_for_a_better_one() -> None:
    # Homogeneous robots, capacity 10: t0 (worth 2 per robot) fills first, t1 (8 robots,
    # 1.5 per robot) cannot fit; exchanging t0 (u 4) for t1 (u 12) pays.
    m = Mission.from_arrays(np.ones((10, 1), bool), [[2], [10]], [4, 12])
    with_exchange, without = grape_s_select(m), grape_s_select(m, exchange=False)
    assert with_exchange.assignment.utility(m) == 12.0
    assert without.assignment.utility(m) == 4.0
    assert with_exchange.options == (
        ("order", "index"),
        ("exchange", True),
        ("medium", "broadcast"),
        ("encoding", "full"),
    )


def test_the_knapsack_family_bounds_the_minimum_near_one_half() -> None:
    # The counterexample family of the report: 2h identical robots; X needs h + 1 (u = h
    # + 2), Y1 and Y2 need h each (u = h).  X is worth more per robot and more than either
    # Y, so no exchange pays; the optimum (Y1 + Y2) earns 2h: ratio (h + 2) / 2h -> 1/2.
    for h in (3, 10, 50):
        m = Mission.from_arrays(np.ones((2 * h, 1), bool), [[h + 1], [h], [h]], [h + 2, h, h])
        run = grape_s_select(m)
        assert run.assignment.utility(m) == h + 2
        assert solve_exact(m).utility == 2 * h
        assert sel.is_select_stable(m, run.assignment)


def test_the_price_of_stability_family() -> None:
    # n identical robots; t0 needs one (u 2), t1 needs all n (u 1.9 n).  A robot of a
    # complete t1 would move to complete t0 (worth more per robot): the optimum is not
    # stable under the completion reward, and the run earns 2 (as SDA does).
    for n in (4, 10, 50):
        m = Mission.from_arrays(np.ones((n, 1), bool), [[1], [n]], [2, 1.9 * n])
        optimum = solve_exact(m)
        assert not sel.is_select_stable(m, optimum.assignment)
        assert grape_s_select(m).assignment.utility(m) == 2
    smallest = generate_mission(5, 50, 5, 5, load=1.25, seed=1)  # O2's counterexample
    run = grape_s_select(smallest)
    assert (run.assignment.utility(smallest), solve_exact(smallest).utility) == (42, 52)


def test_counts_follow_the_documented_model() -> None:
    m = GridCell(60, 10, 10, 5, load=1.5).mission(0)
    run = grape_s_select(m)
    n, tasks = m.n_robots, m.n_tasks
    moves = int((run.trajectory[:, 2] >= 0).sum())
    assert run.iterations == len(set(run.trajectory[:, 0].tolist()))
    assert run.rounds > run.iterations >= moves
    assert run.messages == run.rounds * n  # one broadcast per robot and round
    assert run.bytes == run.messages * (16 + 4 * n + (tasks + 3) // 4)
    unicast = run.rounds * n * (n - 1)
    assert run.communication_cost("unicast") == (unicast, unicast * (16 + 4 * n + (tasks + 3) // 4))
    slots_per_service = (m.requirements > 0).sum(axis=0)
    per_round = int((m.capabilities.astype(np.int64) @ slots_per_service).sum())
    assert run.work >= run.rounds * per_round


def test_no_robots_no_tasks_no_capable_robots() -> None:
    empty = Mission.from_arrays(np.zeros((0, 2), bool), [[1, 0]], [4])
    run = grape_s_select(empty)
    assert (run.iterations, run.rounds, run.messages, run.work) == (0, 1, 0, 0)
    idle = Mission.from_arrays([[0, 1], [0, 1]], [[1, 0]], [4])
    run = grape_s_select(idle)
    assert run.iterations == 0 and run.assignment.n_assigned == 0
    no_tasks = Mission.from_arrays([[1], [1]], np.zeros((0, 1), np.int64), [])
    assert grape_s_select(no_tasks).assignment.n_assigned == 0


def test_zero_utility_and_unfillable_tasks_are_never_joined() -> None:
    m = Mission.from_arrays([[1, 0], [1, 0]], [[1, 0], [0, 1], [3, 0]], [0, 5, 9])
    run = grape_s_select(m)
    assert run.assignment.n_assigned == 0  # t0 is worthless, t1 needs s1, t2 three robots
    assert sel.is_select_stable(m, run.assignment)


def test_extreme_utilities_compare_exactly() -> None:
    # utilities 1e300 and 1e-300 (the exchange search's big-integer path), and weights a
    # float cannot tell apart (ties decided exactly, lower index first)
    m = Mission.from_arrays(np.ones((4, 1), bool), [[2], [3], [1]], [1e-300, 1e300, 1e300])
    run = grape_s_select(m)
    assert sel.is_select_stable(m, run.assignment)
    assert run.assignment.utility(m) == solve_exact(m).utility
    u = 2.0**53
    tie = Mission.from_arrays(np.ones((2, 1), bool), [[1], [1]], [u + 2, u + 2])
    assert select_priorities(tie).tolist() == [1, 0]
    near = Mission.from_arrays(np.ones((2, 1), bool), [[1], [1]], [u, u + 2])
    assert select_priorities(near).tolist() == [0, 1]
    tiny = 5e-324  # subnormal utilities: floats keep no relative precision
    sub = Mission.from_arrays(np.ones((3, 1), bool), [[3], [1], [2]], [3 * tiny, tiny, 2 * tiny])
    assert select_priorities(sub).tolist() == sel.select_priorities(sub) == [2, 1, 0]


# ---------------------------------------------------- the engine is the spec
@settings(max_examples=80, suppress_health_check=[HealthCheck.too_slow])
@given(
    mission=missions(max_robots=7, max_tasks=4, max_services=3),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
    exchange=st.booleans(),
)
def test_engine_makes_the_literal_specs_moves(mission, order, seed, exchange) -> None:
    run = grape_s_select(mission, seed=seed, order=order, exchange=exchange)
    traj, iterations, rounds = literal_select(mission, seed=seed, order=order, exchange=exchange)
    assert run.trajectory.tolist() == [list(row) for row in traj]
    assert (run.iterations, run.rounds) == (iterations, rounds)


@pytest.mark.parametrize("load", [1.0, *OVERSUBSCRIBED])
def test_engine_makes_the_literal_specs_moves_on_the_seed_family(load) -> None:
    for index, (S, k) in enumerate(COMPOSITIONS):
        for p in (10, 50):
            m = generate_mission(12, p, S, k, load=load, seed=index)
            run = grape_s_select(m)
            traj, iterations, rounds = literal_select(m)
            assert run.trajectory.tolist() == [list(row) for row in traj]
            assert (run.iterations, run.rounds) == (iterations, rounds)


@settings(max_examples=60)
@given(mission=missions(max_robots=8, max_tasks=5, max_services=4))
def test_priorities_agree_with_the_independent_checker(mission) -> None:
    assert select_priorities(mission).tolist() == sel.select_priorities(mission)


@settings(max_examples=200)
@given(
    counts=st.lists(st.integers(0, 3), min_size=1, max_size=5),
    data=st.data(),
)
def test_fillable_matches_a_brute_force_matching(counts, data) -> None:
    S = data.draw(st.integers(1, 4))
    kinds = data.draw(
        st.lists(
            st.lists(st.booleans(), min_size=S, max_size=S),
            min_size=len(counts),
            max_size=len(counts),
        )
    )
    need = data.draw(st.lists(st.integers(0, 3), min_size=S, max_size=S))
    robots = [t for t, c in enumerate(counts) for _ in range(c)]
    mission = Mission.from_arrays(
        np.array([kinds[t] for t in robots], bool).reshape(-1, S), [[1] * S], [1]
    )
    expected = _can_fill(mission, list(range(len(robots))), need)
    assert fillable(counts, kinds, need) == expected


def test_fillable_uses_a_flow_beyond_the_hall_limit(monkeypatch) -> None:
    module = importlib.import_module("heuristics.grape_s_select")

    monkeypatch.setattr(module, "_HALL_BITS", 1)
    rng = np.random.default_rng(3)
    for _ in range(200):
        K, S = int(rng.integers(1, 5)), int(rng.integers(2, 5))
        kinds = rng.random((K, S)) < 0.5
        counts = rng.integers(0, 3, K)
        need = rng.integers(0, 3, S)
        robots = [t for t, c in enumerate(counts.tolist()) for _ in range(c)]
        mission = Mission.from_arrays(kinds[robots].reshape(-1, S), [[1] * S], [1])
        work = [0]
        got = fillable(counts, kinds, need, work)
        assert got == _can_fill(mission, list(range(len(robots))), need.tolist())


# ------------------------------------------------ against the exact optimum
@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(
    mission=st.one_of(
        missions(max_robots=10, max_tasks=5, max_services=4),
        missions(max_robots=10, max_tasks=5, max_services=4, achievable=False),
        missions(max_robots=10, max_tasks=5, max_services=4, achievable=False, load=2.0),
    ),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_small_missions_valid_at_most_optimal_and_stable(mission, order, seed) -> None:
    run = grape_s_select(mission, seed=seed, order=order)
    a = run.assignment
    a.validate(mission)
    assert a.utility(mission) <= solve_exact(mission).utility + 1e-9
    assert sel.select_violations(mission, a) == []
    # every assigned robot works for a completed task
    done = set(a.completed_tasks(mission).tolist())
    assert all(t in done for t in a.task.tolist() if t >= 0)


def _grid(loads, indices=range(2)):
    for load in loads:
        for S, k in COMPOSITIONS:
            for p in (10, 50):
                for i in indices:
                    yield load, GridCell(100, p, S, k, load=load).mission(i)


def test_seeded_grid_missions_near_the_optimum() -> None:
    percents: dict[float, list[float]] = {}
    for load, m in _grid(OVERSUBSCRIBED):
        run = grape_s_select(m)
        run.assignment.validate(m)
        optimum = solve_exact(m).utility
        got = run.assignment.utility(m)
        assert got <= optimum + 1e-9
        assert sel.is_select_stable(m, run.assignment)
        percents.setdefault(load, []).append(100.0 * got / optimum)
    for load, values in percents.items():
        assert min(values) >= GRID_FLOOR, (load, min(values))
        assert statistics.median(values) >= 99.0, (load, statistics.median(values))


def test_not_worse_than_grape_s_on_achievable_missions() -> None:
    # Per mission GRAPE-S is sometimes a task ahead on 10:5 (a robot placed for one task
    # is needed by another: a chain no single strictly improving move makes), but never by
    # much, and GRAPE-S's own worst case is far lower.
    ours, theirs = [], []
    for _, m in _grid([1.0], range(3)):
        ours.append(grape_s_select(m).assignment.percent_utility(m))
        theirs.append(grape_s(m).assignment.percent_utility(m))
    assert statistics.median(ours) >= statistics.median(theirs)
    assert min(ours) >= min(theirs)
    assert statistics.mean(ours) >= statistics.mean(theirs) - 0.05


# -------------------------------------------------------------- determinism
@pytest.mark.parametrize("order", ["index", "random"])
def test_same_seed_same_run(order) -> None:
    m = GridCell(100, 10, 10, 5, load=1.5).mission(1)
    first = grape_s_select(m, seed=42, order=order)
    second = grape_s_select(m, seed=42, order=order)
    assert first.replace_seconds(0.0) == second.replace_seconds(0.0)
    gen = grape_s_select(m, seed=np.random.default_rng(42), order=order)
    assert gen.trajectory.tolist() == first.trajectory.tolist() and gen.seed is None


def test_random_order_depends_on_the_seed() -> None:
    m = GridCell(100, 10, 10, 5, load=1.25).mission(1)
    runs = {tuple(grape_s_select(m, seed=s, order="random").trajectory[:, 1]) for s in range(4)}
    assert len(runs) > 1


def test_run_serialises() -> None:
    m = Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
    d = grape_s_select(m, seed=7).to_dict(m)
    assert d["algorithm"] == "grape-s-select" and d["seed"] == 7
    assert d["options"] == {
        "order": "index",
        "exchange": True,
        "medium": "broadcast",
        "encoding": "full",
    }
    assert Assignment.from_dict(m, {"assignment": d["assignment"]}).task.tolist() == [0, 0, 0]


# ---------------------------------------------------------------- bad input
def test_bad_order_and_non_missions_are_rejected() -> None:
    m = Mission.from_arrays([[1]], [[1]], [1])
    with pytest.raises(MissionError, match="order: must be one of index, random"):
        grape_s_select(m, order="reverse")
    with pytest.raises(MissionError, match=r"mission: must be a cfopt\.Mission"):
        grape_s_select({"robots": []})  # type: ignore[arg-type]
