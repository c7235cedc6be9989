"""SDA's agents in the distributed simulator: lock-step equivalence with the centralized
auction, determinism, lost messages (a robot sold twice, a task short), cut runs, the
message encodings."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cfopt import GridCell, Mission
from heuristics import sda
from heuristics.agents.sda import (
    RESEND_TRIES,
    Ack,
    Announce,
    Award,
    Bid,
    Digest,
    NoBid,
    Resend,
    Withdraw,
    decode_message,
)
from heuristics.simulate import simulate
from proofs.strategies import missions

LOCKSTEP = "complete sync=true"
LOSSY = "complete latency=uniform:1ms:10ms loss=0.05"


RESENDS = {"resend_tries": RESEND_TRIES}


def assert_same_auction(mission: Mission, tries: int = 0) -> None:
    central = sda(mission)
    run = simulate(mission, "sda", LOCKSTEP, seed=0, options={"resend_tries": tries})
    run.assignment.validate(mission)
    assert run.assignment == central.assignment
    assert run.trajectory.tolist() == central.trajectory.tolist()
    assert (run.rounds, run.iterations) == (central.rounds, central.iterations)
    report = run.network
    assert report.converged and report.beliefs_agree and not report.cut
    assert report.losses == 0 and report.convergence_seconds == 0.0


# ------------------------------------------------------------ lock-step equivalence
@settings(max_examples=100, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(
    mission=missions(max_robots=8, max_tasks=4, max_services=3),
    tries=st.sampled_from([0, RESEND_TRIES]),
)
def test_lockstep_runs_make_the_centralized_awards(mission: Mission, tries: int) -> None:
    assert_same_auction(mission, tries)


@pytest.mark.parametrize(
    ("cell", "index"),
    [
        (GridCell(20, 50, 10, 5), 0),
        (GridCell(30, 10, 5, 1), 0),
        (GridCell(20, 50, 5, 1), 0),
        (GridCell(20, 50, 5, 1), 1),
    ],
    ids=lambda x: x.label if isinstance(x, GridCell) else str(x),
)
def test_lockstep_on_the_seed_family(cell: GridCell, index: int) -> None:
    assert_same_auction(cell.mission(index), tries=RESEND_TRIES * index)


# --------------------------------------------------------------------- determinism
def test_same_seed_same_run() -> None:
    m = GridCell(20, 50, 5, 1).mission(0)
    runs = [simulate(m, "sda", LOSSY, seed=3).to_dict(m) for _ in range(2)]
    for out in runs:
        out.pop("seconds")
    assert runs[0] == runs[1]
    assert runs[0]["network"]["losses"] > 0
    other = simulate(m, "sda", LOSSY, seed=4).network
    assert other.transmissions != runs[0]["network"]["transmissions"]


# ---------------------------------------------------------- lost and late messages
def _dropping(sender: int, receiver: int, seen: list[int]):
    """Drop every transmission from robot ``sender`` to robot ``receiver`` (and count them
    in ``seen``); nothing else."""

    def faults(who, receivers, now):
        hit = (receivers == receiver) & (who == sender)
        seen.append(int(hit.sum()))
        return np.zeros(receivers.size, dtype=np.int64), hit

    return faults


def one_task_short_of_robot_3() -> Mission:
    # service agent 0 on robot 0, service agent 1 on robot 1, task agent 0 on robot 2;
    # the auction sells robot 3 (service 0) to task 0 in round 4 -- so every transmission
    # from robot 0 to robot 3 is an award
    m = Mission.from_arrays([[0, 1], [0, 1], [0, 1], [1, 0]], [[1, 0]], [1.0])
    assert sda(m).assignment.task.tolist() == [-1, -1, -1, 0]
    return m


def test_a_lost_award_leaves_its_task_short() -> None:
    """The award to robot 3 is lost: the replicas agree, but robot 3 never learns its
    slot and task 0 stays short."""
    m = one_task_short_of_robot_3()
    seen: list[int] = []
    run = simulate(m, "sda", LOCKSTEP, seed=0, faults=_dropping(0, 3, seen))
    run.assignment.validate(m)
    assert sum(seen) == 1 == run.network.losses
    assert run.assignment.task.tolist() == [-1, -1, -1, -1]
    assert run.assignment.utility(m) == 0.0
    assert run.network.beliefs_agree and not run.network.converged
    assert run.trajectory.size == 0 and run.iterations == 0


def test_with_resends_a_lost_award_is_sent_again() -> None:
    m = one_task_short_of_robot_3()
    seen: list[int] = []
    drop_first = _dropping(0, 3, seen)

    def faults(who, receivers, now):
        delay, drop = drop_first(who, receivers, now)
        return delay, drop & (sum(seen) == 1)

    run = simulate(m, "sda", LOCKSTEP, seed=0, faults=faults, options=RESENDS)
    run.assignment.validate(m)
    assert sum(seen) == 2 and run.network.losses == 1  # the award, then its resend
    assert run.assignment == sda(m).assignment
    assert run.network.converged
    assert run.network.convergence_seconds == pytest.approx(0.03)  # T_resend: 3 periods


def test_with_resends_an_award_lost_every_time_leaves_its_task_short() -> None:
    m = one_task_short_of_robot_3()
    seen: list[int] = []
    run = simulate(m, "sda", LOCKSTEP, seed=0, faults=_dropping(0, 3, seen), options=RESENDS)
    run.assignment.validate(m)
    assert sum(seen) == 1 + RESEND_TRIES
    assert run.assignment.utility(m) == 0.0
    assert run.network.beliefs_agree and not run.network.converged


def test_with_resends_lossy_runs_keep_the_replicas_in_step() -> None:
    m = GridCell(20, 50, 5, 1).mission(0)
    run = simulate(m, "sda", LOSSY, seed=3, options=RESENDS)
    run.assignment.validate(m)
    report = run.network
    assert report.losses > 0 and report.converged and report.beliefs_agree
    assert run.assignment.utility(m) == sda(m).assignment.utility(m)


def test_a_lost_digest_sells_a_robot_twice() -> None:
    """Robot 4 alone can serve tasks 0 (service 0) and 1 (service 1); both bid for it in
    round 5 with equal surplus.  Service agent 1 (robot 1) never hears service agent 0's
    digests (robot 0 -> robot 1 is cut), so it misses task 0's bid and sells robot 4 to
    task 1, while service agent 0 sells it to task 0.  Robot 4 gets both awards and
    performs the first, task 0's; task 1 stays short."""
    caps = [[0, 0], [0, 0], [0, 0], [0, 0], [1, 1]]
    m = Mission.from_arrays(caps, [[1, 0], [0, 1]], [2.0, 2.0])
    assert sda(m).assignment.task.tolist() == [-1, -1, -1, -1, 0]
    run = simulate(m, "sda", LOCKSTEP, seed=0, faults=_dropping(0, 1, []))
    run.assignment.validate(m)
    assert run.trajectory.tolist() == [[1, 4, 0, 0], [1, 4, 1, 1]]  # sold twice, round 5
    assert run.assignment.task.tolist() == [-1, -1, -1, -1, 0]
    assert run.assignment.utility(m) == 2.0
    report = run.network
    assert not report.beliefs_agree and not report.converged and not report.cut
    assert report.convergence_seconds is None


def test_a_lost_answer_only_delays_a_bid() -> None:
    """Task 0's round-1 bid is lost (robot 1 -> robot 0 at time 0): its home closes round
    1 after ``T_digest`` without it, every replica stays in step, and the task wins the
    same robot in round 2 -- the centralized sale, a round late."""
    m = Mission.from_arrays([[1], [1], [1], [1]], [[1]], [4.0])
    central = sda(m)

    def faults(who, receivers, now):
        hit = (who == 1) & (receivers == 0) & (now == 0)
        return np.zeros(receivers.size, dtype=np.int64), hit

    run = simulate(m, "sda", LOCKSTEP, seed=0, faults=faults)
    run.assignment.validate(m)
    assert run.network.losses == 1
    assert run.network.converged and run.network.beliefs_agree
    assert run.assignment == central.assignment
    assert run.trajectory.tolist() == central.trajectory.tolist() == [[1, 0, 0, 0]]
    assert (central.rounds, run.rounds) == (1, 2)


NETWORKS = st.sampled_from(
    [
        "complete latency=uniform:1ms:10ms loss=0.05",
        "complete latency=exponential:4ms loss=0.1",
        "ring latency=uniform:1ms:5ms loss=0.02",
        "grid latency=constant:3ms medium=unicast",
        "smallworld k=4 p=0.3 latency=uniform:0ms:12ms loss=ge:0.05:0.5:0.8",
    ]
)


@settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(mission=missions(min_robots=5, max_robots=8, max_tasks=4, max_services=3),
       spec=NETWORKS, seed=st.integers(0, 2**32),
       tries=st.sampled_from([0, RESEND_TRIES]))  # fmt: skip
def test_every_run_is_valid_and_a_converged_one_is_consistent(mission, spec, seed, tries):
    run = simulate(mission, "sda", spec, seed=seed, options={"resend_tries": tries})
    run.assignment.validate(mission)
    report = run.network
    assert not report.cut
    robots = run.trajectory[:, 1].tolist()
    if report.converged:
        assert report.beliefs_agree
        assert len(robots) == len(set(robots))  # nobody sold twice
        assert sorted(robots) == np.flatnonzero(run.assignment.task >= 0).tolist()
        assert report.convergence_seconds is not None


def test_a_run_cut_by_its_time_limit() -> None:
    m = GridCell(30, 10, 5, 1).mission(0)
    run = simulate(m, "sda", "ring latency=uniform:1ms:10ms", seed=0, time_limit=0.5)
    report = run.network
    assert report.cut and report.simulated_seconds == pytest.approx(0.5)
    assert not report.converged and report.convergence_seconds is None
    run.assignment.validate(m)
    assert 0 < run.rounds < sda(m).rounds


# ------------------------------------------------------------------------ encodings
@pytest.mark.parametrize(
    ("message", "size"),
    [
        (Announce(3, 1, 2, 7), 29),
        (Announce(3, 1, 2, 7, ((4, 0), (5, 2)), final=True), 45),
        (Bid(9, 2, np.array([4, 1, 6]), np.array([0, 3, 3])), 41),
        (NoBid(9, 2), 13),
        (Withdraw(9, 2), 13),
        (Digest(9, 1, ((2, np.array([4]), np.array([0])), (5, np.arange(2), np.ones(2, int)))), 57),
        (Award(9, 4, 6, 2, 3), 25),
        (Resend(9, 1, 0), 17),
        (Ack(9, 6, 3), 17),
    ],
    ids=lambda x: type(x).__name__ if not isinstance(x, int) else str(x),
)  # fmt: skip
def test_messages_encode_to_their_documented_sizes_and_back(message, size: int) -> None:
    data = message.encode()
    assert len(data) == size
    back = decode_message(data)
    assert type(back) is type(message)
    assert back.encode() == data
