"""SDA and RACHNA_dt: validity, optimality gap, literal references, the seed's missions.

The validator and the literal auctions here share no code with ``heuristics``: bundles are
found by brute-force enumeration, wages are ``Fraction`` objects, every round is run.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import cfopt
import heuristics
from heuristics.rachna import rachna_dt
from heuristics.sda import sda

# --------------------------------------------------------------------------- validator


def independent_utility(mission: cfopt.Mission, task, service) -> float:
    """Check an assignment with plain Python and return its utility (raises AssertionError)."""
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    n, m, S = mission.n_robots, mission.n_tasks, mission.n_services
    task, service = list(map(int, task)), list(map(int, service))
    assert len(task) == n and len(service) == n
    counts = [[0] * S for _ in range(m)]
    for i in range(n):
        if task[i] == -1:
            assert service[i] == -1, f"robot {i}: unassigned with a service"
            continue
        j, s = task[i], service[i]
        assert 0 <= j < m and 0 <= s < S, f"robot {i}: out of range"
        assert caps[i][s], f"robot {i} lacks service {s}"
        assert reqs[j][s] > 0, f"robot {i}: task {j} does not need service {s}"
        counts[j][s] += 1
    total = 0.0
    for j in range(m):
        if all(counts[j][s] >= reqs[j][s] for s in range(S)):
            total += float(mission.utilities[j])
    return total


# ---------------------------------------------------------------------------- missions


@st.composite
def small_missions(draw, *, max_robots: int = 6, max_tasks: int = 3, max_services: int = 3):
    n = draw(st.integers(1, max_robots))
    S = draw(st.integers(1, max_services))
    m = draw(st.integers(1, max_tasks))
    caps = [[draw(st.booleans()) for _ in range(S)] for _ in range(n)]
    reqs = []
    for _ in range(m):
        row = [draw(st.integers(0, 2)) for _ in range(S)]
        if not any(row):
            row[draw(st.integers(0, S - 1))] = 1
        reqs.append(row)
    utils = [draw(st.integers(0, 20)) / 2 for _ in range(m)]
    return cfopt.Mission.from_arrays(caps, reqs, utils)


# ------------------------------------------------------------ brute-force bundles


def all_bundles(caps, need, available):
    """Every complete bundle as a list of (robot, service) pairs."""
    slots = [s for s, r in need for _ in range(r)]
    out = []

    def rec(t, used, acc):
        if t == len(slots):
            out.append(list(acc))
            return
        s = slots[t]
        # robots of the same service in increasing order, so each set is produced once
        start = acc[-1][0] + 1 if t and slots[t - 1] == s else 0
        for i in available:
            if i >= start and i not in used and caps[i][s]:
                used.add(i)
                acc.append((i, s))
                rec(t + 1, used, acc)
                acc.pop()
                used.discard(i)

    rec(0, set(), [])
    return out


def best_bundle(caps, need, available, price, flag=None):
    """(key, bundle, ambiguous): the bundle minimising (sum price, sum flag, sum index);
    ambiguous when two different robot sets attain it."""
    best_key, best, sets = None, None, set()
    for b in all_bundles(caps, need, available):
        robots = [i for i, _ in b]
        key = (
            sum(price[i] for i in robots),
            sum(flag[i] for i in robots) if flag else 0,
            sum(robots),
        )
        if best_key is None or key < best_key:
            best_key, best, sets = key, b, {frozenset(robots)}
        elif key == best_key:
            sets.add(frozenset(robots))
    return best_key, best, len(sets) > 1


def literal_sda(mission, eps=Fraction(1), schedule="max-wage"):
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    n, m, S = mission.n_robots, mission.n_tasks, mission.n_services
    u = [Fraction(float(x)) for x in mission.utilities]
    need = [[(s, reqs[j][s]) for s in range(S) if reqs[j][s]] for j in range(m)]
    k = [sum(r for _, r in need[j]) for j in range(m)]
    w0 = max(u) + eps
    wage = {i: w0 for i in range(n)}
    unsold, staffed = set(range(n)), set()
    task, service = [-1] * n, [-1] * n
    rounds = iterations = messages = nbytes = work = 0
    cast = cast_bytes = 0  # the broadcast medium: one transmission per announcement
    ambiguous = False

    def rows(j):
        return sum(1 for i in unsold if any(caps[i][s] for s, _ in need[j]))

    while unsold and len(staffed) < m:
        rounds += 1
        open_tasks = [j for j in range(m) if j not in staffed]
        A = [sum(1 for j in open_tasks if reqs[j][s]) for s in range(S)]
        # (1) decrement
        if schedule == "max-wage":
            positive = [i for i in sorted(unsold) if wage[i] > 0]
            if positive:
                i = max(positive, key=lambda r: (wage[r], -r))
                wage[i] = max(Fraction(0), wage[i] - eps)
                notes = sum(A[s] for s in range(S) if caps[i][s])
                messages += notes
                nbytes += 20 * notes
                casts = sum(1 for s in range(S) if caps[i][s] and A[s])
                cast += casts
                cast_bytes += 20 * casts
        else:
            if any(wage[i] > 0 for i in unsold):
                for i in unsold:
                    wage[i] = max(Fraction(0), wage[i] - eps)
                for s in range(S):
                    size = sum(1 for i in unsold if caps[i][s])
                    if size:
                        messages += A[s]
                        nbytes += A[s] * (8 + 12 * size)
                        if A[s]:
                            cast += 1
                            cast_bytes += 8 + 12 * size
        # (2) bids
        bids = {}
        for j in open_tasks:
            work += rows(j) * k[j]
            key, b, amb = best_bundle(caps, need[j], sorted(unsold), wage)
            ambiguous |= amb
            if b is not None and key[0] <= u[j]:
                bids[j] = (key[0], b)
                messages += len(need[j])
                nbytes += 8 * len(need[j]) + 12 * k[j]
                cast += len(need[j])  # bids are direct
                cast_bytes += 8 * len(need[j]) + 12 * k[j]
        # (3) awards
        sold_now = set()
        if bids:
            iterations += 1
        while bids:
            j = min(bids, key=lambda t: (bids[t][0] - u[t], t))
            _, b = bids.pop(j)
            messages += len(need[j])
            nbytes += 8 * len(need[j])
            cast += len(need[j])  # answers are direct
            cast_bytes += 8 * len(need[j])
            if any(i in sold_now for i, _ in b):
                work += rows(j) * k[j]
                key, nb, amb = best_bundle(caps, need[j], sorted(unsold), wage)
                ambiguous |= amb
                if nb is not None and key[0] <= u[j]:
                    bids[j] = (key[0], nb)
                    messages += len(need[j])
                    nbytes += 8 * len(need[j]) + 12 * k[j]
                    cast += len(need[j])
                    cast_bytes += 8 * len(need[j]) + 12 * k[j]
                continue
            staffed.add(j)
            for i, s in b:
                task[i], service[i] = j, s
                unsold.discard(i)
                sold_now.add(i)
        if sold_now:
            for s in range(S):
                c = sum(1 for i in sold_now if caps[i][s])
                if c:
                    a_s = sum(1 for j in range(m) if j not in staffed and reqs[j][s])
                    messages += a_s
                    nbytes += a_s * (8 + 12 * c)
                    if a_s:
                        cast += 1
                        cast_bytes += 8 + 12 * c
        if all(wage[i] == 0 for i in unsold):
            break
    return dict(
        task=task,
        service=service,
        rounds=rounds,
        iterations=iterations,
        messages=messages,
        bytes=nbytes,
        cast=cast,
        cast_bytes=cast_bytes,
        work=work,
        ambiguous=ambiguous,
    )


def literal_rachna(mission, eps=None):
    caps = mission.capabilities.tolist()
    reqs = mission.requirements.tolist()
    n, m, S = mission.n_robots, mission.n_tasks, mission.n_services
    eps = Fraction(1, n) if eps is None else eps
    budget = [math.floor(Fraction(float(x)) / eps) for x in mission.utilities]
    need = [[(s, reqs[j][s]) for s in range(S) if reqs[j][s]] for j in range(m)]
    wage = [0] * n
    task, service = [-1] * n, [-1] * n
    staffed = [False] * m
    rounds = iterations = 0
    ambiguous = False
    while True:
        rounds += 1
        acted = False
        for j in range(m):
            if staffed[j]:
                continue
            price = [w + 1 for w in wage]
            held = [1 if task[i] >= 0 else 0 for i in range(n)]
            key, b, amb = best_bundle(caps, need[j], list(range(n)), price, held)
            ambiguous |= amb
            if b is None or key[0] > budget[j]:
                continue
            if not acted:
                acted, iterations = True, iterations + 1
            robots = {i for i, _ in b}
            for loser in {task[i] for i in robots} - {-1}:
                staffed[loser] = False
                for i in range(n):
                    if task[i] == loser and i not in robots:
                        task[i], service[i] = -1, -1
            for i, s in b:
                task[i], service[i] = j, s
                wage[i] += 1
            staffed[j] = True
        if not acted:
            break
    return dict(
        task=task,
        service=service,
        rounds=rounds,
        iterations=iterations,
        ambiguous=ambiguous,
        wages=wage,
    )


# ------------------------------------------------------------------------------ tests

AUCTIONS = [
    pytest.param(lambda m: sda(m), id="sda-max-wage"),
    pytest.param(lambda m: sda(m, schedule="uniform"), id="sda-uniform"),
    pytest.param(lambda m: sda(m, eps=0.75), id="sda-eps-0.75"),
    pytest.param(lambda m: rachna_dt(m), id="rachna-dt"),
    pytest.param(lambda m: rachna_dt(m, eps=1), id="rachna-eps-1"),
]


@pytest.mark.parametrize("algorithm", AUCTIONS)
@given(mission=small_missions())
def test_valid_and_at_most_the_optimum(algorithm, mission):
    run = algorithm(mission)
    utility = independent_utility(mission, run.assignment.task, run.assignment.service)
    assert utility == run.assignment.utility(mission)
    optimum = cfopt.solve_exact(mission)
    assert optimum.status.value == "optimal"
    assert utility <= optimum.utility + 1e-9
    assert run.iterations <= run.rounds


@pytest.mark.parametrize("schedule", ["max-wage", "uniform"])
@pytest.mark.parametrize("eps", [Fraction(1), Fraction(3, 4), Fraction(5, 2)])
@given(mission=small_missions(max_robots=5))
def test_sda_matches_literal_auction(schedule, eps, mission):
    ref = literal_sda(mission, eps, schedule)
    assume(not ref["ambiguous"])
    run = sda(mission, eps=eps, schedule=schedule)
    assert run.assignment.task.tolist() == ref["task"]
    independent_utility(mission, run.assignment.task, run.assignment.service)
    for name in ("rounds", "iterations", "work"):
        assert getattr(run, name) == ref[name], name
    assert (run.messages, run.bytes) == (ref["cast"], ref["cast_bytes"])  # broadcast
    assert run.communication_cost("unicast") == (ref["messages"], ref["bytes"])
    assert sda(mission, eps=eps, schedule=schedule, medium="unicast").messages == ref["messages"]


@pytest.mark.parametrize("eps", [None, Fraction(1, 2), Fraction(1)])
@given(mission=small_missions(max_robots=5))
def test_sequential_rachna_matches_literal_auction(eps, mission):
    # literal_rachna is the sequential reading; the simultaneous one is in test_rachna.py
    ref = literal_rachna(mission, eps)
    assume(not ref["ambiguous"])
    run = rachna_dt(mission, eps=eps, schedule="sequential")
    assert run.assignment.task.tolist() == ref["task"]
    assert (run.rounds, run.iterations) == (ref["rounds"], ref["iterations"])


def test_deterministic_and_registered():
    m = cfopt.generate_mission(60, 10, 10, 5, seed=3)
    for name, f in (("sda", sda), ("rachna-dt", rachna_dt)):
        assert heuristics.ALGORITHMS[name].run is f
        assert heuristics.run_algorithm(name, m, seed=7, order="index").replace_seconds(0) == (
            f(m, seed=7).replace_seconds(0)
        )
        run = f(m, seed=7)
        assert run.seed == 7 and run.algorithm == name
        assert run.to_dict(m)["options"]["eps"]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        pytest.param(lambda m: sda(m, eps=0), "eps: must be a finite number > 0", id="sda-eps-0"),
        pytest.param(lambda m: sda(m, eps=-1.0), "eps: must be", id="sda-eps-neg"),
        pytest.param(lambda m: sda(m, eps=float("nan")), "eps: must be", id="sda-eps-nan"),
        pytest.param(lambda m: sda(m, eps=True), "eps: must be", id="sda-eps-bool"),
        pytest.param(lambda m: sda(m, eps="1"), "eps: must be", id="sda-eps-str"),
        pytest.param(lambda m: sda(m, schedule="fast"), "schedule: must be one of", id="sched"),
        pytest.param(lambda m: sda(m, order="random"), "order: the auctions", id="sda-order"),
        pytest.param(lambda m: rachna_dt(m, eps=float("inf")), "eps: must", id="rachna-inf"),
        pytest.param(lambda m: rachna_dt(m, order="random"), "order:", id="rachna-order"),
        pytest.param(lambda m: sda("mission"), "mission: must be a cfopt.Mission", id="sda-m"),
        pytest.param(lambda m: rachna_dt(None), "mission: must be", id="rachna-m"),
    ],
)
def test_invalid_arguments(call, match):
    m = cfopt.Mission.from_arrays([[1]], [[1]], [1])
    with pytest.raises(cfopt.MissionError, match=match):
        call(m)


def test_empty_missions():
    for caps, reqs, utils in (
        ([[1]], np.zeros((0, 1), dtype=int), []),
        (np.zeros((0, 1), dtype=bool), [[1]], [3]),
    ):
        m = cfopt.Mission.from_arrays(caps, reqs, utils)
        for run in (sda(m), rachna_dt(m)):
            assert run.assignment.n_assigned == 0
            assert independent_utility(m, run.assignment.task, run.assignment.service) == 0


# ------------------------------------------------------------- the seed's missions

COMPOSITIONS = [(5, 1), (5, 5), (10, 1), (10, 5)]
#: Observed (utility, total) where SDA is below 100 % (every other mission: exactly 100 %).
SDA_BELOW_100 = {(10, 5, 10, 1): (297.0, 301.0), (10, 5, 50, 3): (1534.0, 1540.0)}


def test_seed_achievable_missions():
    """100 robots, all four compositions, 10 and 50 percent tasks, missions 0..4.

    Observed: RACHNA_dt 100 % on all 40 (the seed: "optimal for all trials"); SDA 100 % on
    38 and 98.67 % / 99.61 % on two 10:5 missions (the seed: "near-optimal")."""
    sda_values = {}
    for S, K in COMPOSITIONS:
        for p in (10, 50):
            cell = cfopt.GridCell(100, p, S, K)
            for i in range(5):
                m = cell.mission(i)
                total = m.total_utility
                r = rachna_dt(m)
                assert independent_utility(m, r.assignment.task, r.assignment.service) == total
                s = sda(m)
                got = independent_utility(m, s.assignment.task, s.assignment.service)
                sda_values[(S, K, p, i)] = (got, total)
    below = {key: v for key, v in sda_values.items() if v[0] < v[1]}
    assert below == SDA_BELOW_100
