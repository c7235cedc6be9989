"""Pair-GRAPE-S with chain exchanges: optimal on achievable missions, valid, deterministic."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

import proofs
from cfopt import GridCell, Mission, MissionError, generate_mission, solve_exact
from heuristics import belief_bytes, broadcast_cost, grape_s, pair_grape_s
from heuristics.communication import CommModel
from heuristics.pair_grape_s_chain import ACCEPT_BYTES, pair_grape_s_chain, request_bytes
from proofs.claimkit import achievable
from proofs.strategies import achievable_missions, missions

# r0 does A, r1 A and B, r2 B and C; one task needs A, B, C.  Capped GRAPE-S leaves r0
# out with C short; the one robot r0 can replace (r1) cannot do C: a 2-partner chain.
CHAIN_MISSION = Mission.from_arrays([[1, 0, 0], [1, 1, 0], [0, 1, 1]], [[1, 1, 1]], [10])
# The smallest capped Nash violation (claim C2, shared with Pair-GRAPE-S's Lemma 1).
LEMMA1_MISSION = Mission.from_arrays(
    [[1, 0, 0], [1, 1, 0], [0, 1, 1]], [[1, 0, 0], [0, 2, 0], [0, 0, 2]], [1, 1, 1]
)
COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))


def phase2_chains(run) -> list[int]:
    """Partners per chain exchange, in order (rows per phase-2 iteration minus one)."""
    traj = run.trajectory
    second = traj[traj[:, 0] > run.iterations - run.exchanges]
    return [rows - 1 for rows in Counter(second[:, 0].tolist()).values()]


def max_filled_copies(mission: Mission) -> int:
    """Maximum matching of robots to slot copies (scipy's Hopcroft-Karp), independently."""
    reqs = mission.requirements
    copies = np.repeat(np.tile(np.arange(mission.n_services), mission.n_tasks), reqs.ravel())
    if copies.size == 0 or mission.n_robots == 0:
        return 0
    graph = csr_matrix(mission.capabilities[:, copies].astype(np.int8))
    match = maximum_bipartite_matching(graph, perm_type="column")
    return int((match >= 0).sum())


def test_chain_completes_what_pair_grape_s_cannot() -> None:
    m = CHAIN_MISSION
    assert pair_grape_s(m).assignment.percent_utility(m) == 0.0
    run = pair_grape_s_chain(m)
    assert run.algorithm == "pair-grape-s-chain"
    assert run.assignment.percent_utility(m) == 100.0
    assert run.pairwise_step_ran and run.exchanges == 1 and run.iterations == 3
    # one iteration, every robot on the chain moves one step: r0 -> r1's A, r1 -> r2's B,
    # r2 -> the short C
    assert run.trajectory.tolist()[2:] == [[3, 0, 0, 0], [3, 1, 0, 1], [3, 2, 0, 2]]
    assert phase2_chains(run) == [2]
    assert run.rounds == 2 + 1 + 1
    direct = (2 * 2, 2 * (request_bytes(2) + ACCEPT_BYTES))
    messages, nbytes = CommModel().rounds_cost(3, run.rounds, belief_bytes(3))  # broadcast
    assert (run.messages, run.bytes) == (messages + direct[0], nbytes + direct[1])
    messages, nbytes = broadcast_cost(3, run.rounds)  # point to point
    assert run.communication_cost("unicast") == (messages + direct[0], nbytes + direct[1])


def test_direct_join_under_utility_reward() -> None:
    # A task of utility 0 rewards like being unassigned: GRAPE-S never joins it, Pair-
    # GRAPE-S has no partner, the chain step lets r0 join directly (0 partners, 1 row).
    m = Mission.from_arrays([[1]], [[1]], [0])
    run = pair_grape_s_chain(m, reward="utility")
    assert run.assignment.task.tolist() == [0]
    assert run.trajectory.tolist() == [[1, 0, 0, 0]] and phase2_chains(run) == [0]
    assert run.messages == 0 and run.rounds == 2  # n = 1: broadcasts reach nobody
    assert pair_grape_s(m, reward="utility").assignment.task.tolist() == [-1]
    # under the paper reward GRAPE-S itself joins it: no step
    assert not pair_grape_s_chain(m).pairwise_step_ran


@settings(max_examples=25, deadline=None)
@given(mission=achievable_missions(max_robots=8, max_tasks=4, max_services=4))
def test_never_below_the_exact_optimum_on_achievable_missions(mission) -> None:
    exact = solve_exact(mission)
    assert exact.utility == pytest.approx(mission.total_utility)  # achievable: optimum 100 %
    assert achievable(mission)
    for order in ("index", "random"):
        run = pair_grape_s_chain(mission, seed=1, order=order)
        assert run.assignment.utility(mission) >= exact.utility - 1e-9
        assert run.assignment.percent_utility(mission) == 100.0
        assert run.assignment.completed_tasks(mission).size == mission.n_tasks


@settings(max_examples=20, deadline=None)
@given(mission=missions(max_robots=6, max_tasks=3, max_services=3))
def test_hall_check_agrees_with_the_exact_optimum(mission) -> None:
    # the claims' achievability test (claim C1 skips missions it rejects)
    exact = solve_exact(mission)
    assert achievable(mission) == (exact.utility >= mission.total_utility - 1e-9)


@pytest.mark.parametrize(("services", "per_robot"), COMPOSITIONS)
@pytest.mark.parametrize("percent", [10, 50])
def test_seeded_grid_missions_are_optimal(services, per_robot, percent) -> None:
    cell = GridCell(100, percent, services, per_robot)
    for index in range(3):
        m = cell.mission(index)
        for order in ("index", "random"):
            run = pair_grape_s_chain(m, seed=index, order=order)
            assert run.assignment.percent_utility(m) == 100.0


def test_the_p1_counterexample_family_is_optimal() -> None:
    # claim P1's family: small achievable 10:5 missions of the seed's generator; about 4 %
    # leave Pair-GRAPE-S short (the first: 4 robots, 1 task, seed 3 -- P1's counterexample)
    short = []
    for n in range(3, 13):
        for percent in (10, 50):
            for seed in range(40):
                m = generate_mission(n, percent, 10, 5, seed=seed)
                if pair_grape_s(m).assignment.percent_utility(m) < 100.0:
                    short.append(m)
    assert len(short) >= 20
    p1 = generate_mission(4, 10, 10, 5, seed=3)
    assert short[0] == p1 and pair_grape_s(p1).assignment.percent_utility(p1) == 0.0
    for m in short:
        for order in ("index", "random"):
            run = pair_grape_s_chain(m, seed=0, order=order)
            assert run.assignment.percent_utility(m) == 100.0


@given(
    mission=st.one_of(
        missions(min_robots=0, max_robots=12, max_tasks=5, max_services=4),
        missions(max_robots=12, max_tasks=5, max_services=4, achievable=False),
    ),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
    reward=st.sampled_from(["paper", "utility"]),
)
def test_valid_maximum_and_accounted_on_any_mission(mission, order, seed, reward) -> None:
    run = pair_grape_s_chain(mission, seed=seed, order=order, reward=reward)
    first = grape_s(mission, seed=seed, order=order, capped=True, reward=reward)
    a = run.assignment
    a.validate(mission)
    counts = a.counts(mission)
    assert (counts <= mission.requirements).all()  # never over-full
    # as many slot copies filled as any capped partition can fill (Berge): no chain left
    assert int(counts.sum()) == max_filled_copies(mission)
    # no slot lost a robot: utility and completed tasks never fall below phase 1's
    assert (counts >= first.assignment.counts(mission)).all()
    assert a.utility(mission) >= first.assignment.utility(mission)
    unassigned_before = int((first.assignment.task < 0).sum())
    assert run.exchanges <= unassigned_before
    assert run.iterations == first.iterations + run.exchanges
    assert run.trajectory[: len(first.trajectory)].tolist() == first.trajectory.tolist()
    # replaying the trajectory gives the assignment; rows of an exchange share an iteration
    task = np.full(mission.n_robots, -1)
    service = np.full(mission.n_robots, -1)
    for _, robot, j, s in run.trajectory.tolist():
        task[robot], service[robot] = j, s
    assert task.tolist() == a.task.tolist() and service.tolist() == a.service.tolist()
    chains = phase2_chains(run)
    assert len(chains) == run.exchanges
    n = mission.n_robots
    messages, nbytes = CommModel().rounds_cost(n, run.rounds, belief_bytes(n))
    assert run.messages == messages + 2 * sum(chains)
    assert run.bytes == nbytes + sum(k * (request_bytes(k) + ACCEPT_BYTES) for k in chains)
    # a step that ends with a short slot and an unassigned robot ended by a quiet pass
    still = bool((a.task < 0).any()) and bool((counts < mission.requirements).any())
    assert run.rounds == first.rounds + run.exchanges + int(still)
    assert run.pairwise_step_ran == bool(
        unassigned_before and (first.assignment.counts(mission) < mission.requirements).any()
    )


def chain_equals_pair_until_first_chain(mission, seed, order) -> bool:
    """Check the documented relation; returns whether every exchange was one-hop."""
    pair = pair_grape_s(mission, seed=seed, order=order)
    run = pair_grape_s_chain(mission, seed=seed, order=order)
    chains = phase2_chains(run)
    if all(k == 1 for k in chains):
        assert run.assignment == pair.assignment
        assert run.trajectory.tolist() == pair.trajectory.tolist()
        assert (run.iterations, run.exchanges, run.rounds) == (
            pair.iterations,
            pair.exchanges,
            pair.rounds,
        )
        assert run.pairwise_step_ran == pair.pairwise_step_ran
        assert run.messages == pair.messages + 2 * run.exchanges
        return True
    # identical up to the first exchange with k != 1
    base = run.iterations - run.exchanges
    first_other = base + 1 + next(i for i, k in enumerate(chains) if k != 1)
    mine = run.trajectory[run.trajectory[:, 0] < first_other].tolist()
    assert pair.trajectory[: len(mine)].tolist() == mine
    return False


@given(
    mission=st.one_of(
        achievable_missions(max_robots=12, max_tasks=5, max_services=5),
        missions(max_robots=12, max_tasks=5, max_services=5),
    ),
    order=st.sampled_from(["index", "random"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_equal_to_pair_grape_s_while_one_hop_suffices(mission, order, seed) -> None:
    chain_equals_pair_until_first_chain(mission, seed, order)


def test_equal_to_pair_grape_s_on_the_seed_family() -> None:
    one_hop = longer = 0
    for n in (4, 6, 8, 10, 12, 100):
        for percent in (10, 50):
            for seed in range(30 if n < 100 else 3):
                m = generate_mission(n, percent, 10, 5, seed=seed)
                for order in ("index", "random"):
                    if chain_equals_pair_until_first_chain(m, seed, order):
                        one_hop += 1
                        continue
                    longer += 1
                    # observed (not proved) on load-1 missions: a chain was needed only
                    # where Pair-GRAPE-S stops short
                    pair = pair_grape_s(m, seed=seed, order=order)
                    assert pair.assignment.percent_utility(m) < 100.0
    assert one_hop > 0 and longer > 0  # both branches of the relation are exercised


def test_pair_grape_s_optimal_yet_different_with_spare_robots() -> None:
    # the documented case: Pair-GRAPE-S skips r0 and completes the task with r1's one-hop
    # exchange; the chain variant serves r0 first with a 2-partner chain
    m = generate_mission(6, 10, 10, 5, load=0.6, seed=86)
    pair, run = pair_grape_s(m), pair_grape_s_chain(m)
    assert pair.assignment.percent_utility(m) == run.assignment.percent_utility(m) == 100.0
    assert pair.trajectory.tolist()[3:] == [[4, 1, 0, 2], [4, 5, 0, 6]]
    assert run.trajectory.tolist()[3:] == [[4, 0, 0, 3], [4, 2, 0, 2], [4, 5, 0, 6]]
    assert phase2_chains(run) == [2]


@pytest.mark.parametrize("order", ["index", "random"])
def test_same_mission_same_seed_same_run(order) -> None:
    for m in (GridCell(100, 10, 10, 5).mission(2), generate_mission(12, 50, 10, 5, seed=174)):
        a = pair_grape_s_chain(m, seed=3, order=order)
        b = pair_grape_s_chain(m, seed=3, order=order)
        assert a.replace_seconds(0.0) == b.replace_seconds(0.0)
        assert a.to_dict(m)["algorithm"] == "pair-grape-s-chain"
        assert a.seed == 3 and dict(a.options) == {
            "order": order,
            "capped": True,
            "reward": "paper",
            "medium": "broadcast",
            "encoding": "full",
        }


def test_not_nash_stable_like_pair_grape_s() -> None:
    # claim C2's counterexample: the one-hop exchange is Pair-GRAPE-S's, so is the flaw
    run = pair_grape_s_chain(LEMMA1_MISSION)
    assert run.assignment == pair_grape_s(LEMMA1_MISSION).assignment
    found = [
        v.describe(LEMMA1_MISSION)
        for v in proofs.nash_violations(LEMMA1_MISSION, run.assignment, capped=True)
    ]
    assert found == ["r2: t1/s1 -> t2/s2"]


def test_bad_arguments() -> None:
    with pytest.raises(MissionError, match="order"):
        pair_grape_s_chain(CHAIN_MISSION, order="sorted")
    with pytest.raises(MissionError, match="reward"):
        pair_grape_s_chain(CHAIN_MISSION, reward="nope")
    with pytest.raises(MissionError, match="mission"):
        pair_grape_s_chain("mission.json")  # type: ignore[arg-type]
