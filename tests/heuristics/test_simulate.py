"""The distributed simulator: lock-step equivalence with the centralized engines,
determinism, lost and late messages, stability of converged runs, cut runs."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import proofs
from cfopt import GridCell, Mission, MissionError
from heuristics import grape_s, pair_grape_s, pair_grape_s_chain
from heuristics.simulate import simulate
from proofs.strategies import missions

LOCKSTEP = "complete sync=true"
CENTRAL = {
    "grape-s": grape_s,
    "pair-grape-s": pair_grape_s,
    "pair-grape-s-chain": pair_grape_s_chain,
}


def assert_same_moves(mission: Mission, algorithm: str) -> None:
    central = CENTRAL[algorithm](mission)
    run = simulate(mission, algorithm, LOCKSTEP, seed=0)
    assert run.trajectory.tolist() == central.trajectory.tolist()
    assert run.iterations == central.iterations
    assert run.assignment == central.assignment
    assert run.exchanges == central.exchanges
    report = run.network
    assert report.converged and report.beliefs_agree and not report.cut
    assert report.losses == 0 and report.receptions >= report.transmissions


# ------------------------------------------------------------ lock-step equivalence
@settings(max_examples=80, suppress_health_check=[HealthCheck.too_slow])
@given(mission=missions(max_robots=9, max_tasks=4, max_services=3))
@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s"])
def test_lockstep_runs_make_the_centralized_moves(algorithm: str, mission: Mission) -> None:
    assert_same_moves(mission, algorithm)


@settings(max_examples=30, suppress_health_check=[HealthCheck.too_slow])
@given(mission=missions(max_robots=12, max_tasks=4, max_services=4, achievable=True))
@pytest.mark.parametrize("algorithm", ["pair-grape-s", "pair-grape-s-chain"])
def test_lockstep_exchanges_on_achievable_missions(algorithm: str, mission: Mission) -> None:
    assert_same_moves(mission, algorithm)


def test_lockstep_chain_exchanges_on_the_seed_family() -> None:
    """Small 10:5 missions of the seed's generator, where Pair-GRAPE-S's one-hop exchange
    falls short and chains of several robots are needed (claim P1's family)."""
    chains = 0
    for seed in range(40):
        mission = GridCell(8, 10, 10, 5).mission(seed)
        assert_same_moves(mission, "pair-grape-s-chain")
        run = simulate(mission, "pair-grape-s-chain", LOCKSTEP, seed=0)
        assert run.assignment.percent_utility(mission) == 100.0
        chains += (
            any(np.bincount(run.trajectory[:, 0])[it] > 2 for it in np.unique(run.trajectory[:, 0]))
            if len(run.trajectory)
            else 0
        )
    assert chains > 0  # some runs needed a chain of more than one partner


@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s"])
@pytest.mark.parametrize(
    "cell",
    [GridCell(40, 10, 10, 5), GridCell(40, 50, 10, 5), GridCell(30, 10, 5, 1)],
    ids=lambda c: c.label,
)
def test_lockstep_on_the_seed_family(algorithm: str, cell: GridCell) -> None:
    for index in range(3):
        assert_same_moves(cell.mission(index), algorithm)


# --------------------------------------------------------------------- determinism
_RUN = """
import json, sys
import cfopt
from heuristics.simulate import simulate
m = cfopt.GridCell(40, 10, 10, 5).mission(1)
run = simulate(m, sys.argv[1], sys.argv[2], seed=7)
out = run.to_dict(m)
out.pop("seconds")
print(json.dumps(out, sort_keys=True))
"""


@pytest.mark.parametrize(
    "spec",
    [
        "complete latency=uniform:1ms:10ms loss=0.05",
        "geometric radius=0.4 latency=lognormal:3ms:0.5 loss=ge:0.1:0.3:0.5 medium=unicast",
    ],
)
def test_same_seed_same_run_in_two_processes(spec: str) -> None:
    outputs = [
        subprocess.run(
            [sys.executable, "-c", _RUN, "pair-grape-s", spec],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for _ in range(2)
    ]
    assert outputs[0] == outputs[1]
    assert json.loads(outputs[0])["network"]["transmissions"] > 0


def test_different_seeds_give_different_runs() -> None:
    m = GridCell(40, 10, 10, 5).mission(1)
    spec = "complete latency=uniform:1ms:10ms loss=0.05"
    a, b = (simulate(m, "grape-s", spec, seed=s).network for s in (1, 2))
    assert (a.transmissions, a.losses, a.simulated_seconds) != (
        b.transmissions,
        b.losses,
        b.simulated_seconds,
    )


# ---------------------------------------------------------- lost and late messages
def two_robots() -> Mission:
    # two robots, one task needing one robot: in lock-step both propose at tick 0, the
    # mutex keeps robot 1's proposal, robot 0 adopts it at tick 1 and then over-fills t0
    return Mission.from_arrays([[1], [1]], [[1]], [1.0])


def test_two_robots_without_faults() -> None:
    run = simulate(two_robots(), "grape-s", LOCKSTEP, seed=0)
    assert run.trajectory.tolist() == [[1, 1, 0, 0], [2, 0, 0, 0]]
    assert run.network.convergence_seconds == pytest.approx(0.02)  # tick 2 (10 ms period)


def _faulty(sender: int, at: int, extra_ns: int, drop: bool):
    """Delay (or drop) robot ``sender``'s transmissions at time ``at``; nothing else."""

    def faults(who, receivers, now):
        hit = who == sender and now == at
        extra = np.full(receivers.size, extra_ns if hit else 0, dtype=np.int64)
        return extra, np.full(receivers.size, hit and drop)

    return faults


def _split_after_a_missed_tick(run) -> None:
    # robot 0 learns of robot 1's proposal one tick late and joins t0 again at tick 2;
    # robot 1 has seen no change for two ticks (K d_G = 2) and stops at tick 2, before
    # robot 0's new belief reaches it: the beliefs end apart, each robot performs t0
    assert run.trajectory.tolist() == [[1, 1, 0, 0], [2, 0, 0, 0]]
    assert not run.network.beliefs_agree and not run.network.converged
    assert run.assignment.task.tolist() == [0, 0]


def test_a_lost_broadcast_is_never_processed() -> None:
    """Robot 1's tick-0 broadcast to robot 0 is lost: at tick 1 robot 0 keeps its own
    proposal (both believe they alone serve t0) and adopts robot 1's belief only from
    robot 1's tick-1 broadcast, at tick 2."""
    run = simulate(two_robots(), "grape-s", LOCKSTEP, seed=0, faults=_faulty(1, 0, 0, True))
    assert run.network.losses == 1
    _split_after_a_missed_tick(run)


def test_a_message_is_processed_at_the_first_tick_strictly_after_its_arrival() -> None:
    early = simulate(
        two_robots(), "grape-s", LOCKSTEP, seed=0, faults=_faulty(1, 0, 5 * 10**6, False)
    )
    assert early.trajectory.tolist() == [[1, 1, 0, 0], [2, 0, 0, 0]]
    assert early.network.converged  # 5 ms late: still before tick 1, nothing changes
    on_the_tick = simulate(
        two_robots(), "grape-s", LOCKSTEP, seed=0, faults=_faulty(1, 0, 10**7, False)
    )
    assert on_the_tick.network.losses == 0
    _split_after_a_missed_tick(on_the_tick)  # arriving at tick 1 exactly: seen at tick 2


def test_a_split_brain_run_earns_what_its_robots_do() -> None:
    """Every message is lost: each robot believes it alone serves t0, both perform t0 and
    t1 stays empty -- the run earns 1 of 2, and its beliefs do not agree."""
    m = Mission.from_arrays([[1], [1]], [[1], [1]], [1.0, 1.0])

    def silence(sender, receivers, now):
        return np.zeros(receivers.size, dtype=np.int64), np.ones(receivers.size, dtype=bool)

    run = simulate(m, "grape-s", LOCKSTEP, seed=0, faults=silence)
    assert not run.network.beliefs_agree and not run.network.converged
    assert run.assignment.task.tolist() == [0, 0]
    assert run.assignment.utility(m) == 1.0
    assert run.network.receptions == 0 and run.network.losses == run.network.transmissions


# -------------------------------------------------------------------- stability
NETWORKS = st.sampled_from(
    [
        "complete latency=uniform:1ms:10ms loss=0.01",
        "complete latency=exponential:4ms loss=0.1",
        "ring latency=uniform:1ms:5ms loss=0.02",
        "grid latency=constant:3ms medium=unicast",
        "smallworld k=4 p=0.3 latency=uniform:0ms:12ms loss=ge:0.05:0.5:0.8",
    ]
)


@settings(max_examples=40, suppress_health_check=[HealthCheck.too_slow])
@given(mission=missions(min_robots=5, max_robots=10, max_tasks=4, max_services=3),
       spec=NETWORKS, seed=st.integers(0, 2**32))  # fmt: skip
def test_every_converged_grape_s_run_is_nash_stable(mission, spec, seed) -> None:
    run = simulate(mission, "grape-s", spec, seed=seed)
    run.assignment.validate(mission)
    if run.network.converged:
        assert run.network.beliefs_agree
        assert proofs.is_nash_stable(mission, run.assignment)
    if run.network.beliefs_agree:  # everyone performs the common belief's slots
        assert run.rounds >= 1


def test_a_run_cut_by_its_time_limit() -> None:
    m = GridCell(40, 10, 10, 5).mission(0)
    run = simulate(m, "grape-s", "ring latency=uniform:1ms:10ms", seed=0, time_limit=0.05)
    report = run.network
    assert report.cut and report.simulated_seconds == pytest.approx(0.05)
    assert not report.converged
    run.assignment.validate(m)  # the robots' own beliefs as they stood
    assert run.assignment.n_assigned > 0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        pytest.param({"algorithm": "rachna-dt"}, "no distributed agents", id="algorithm"),
        pytest.param({"time_limit": 0}, "time_limit", id="time-limit"),
        pytest.param({"time_limit": 1e6}, "at most", id="time-limit-too-long"),
        pytest.param({"quiet_factor": 0}, "quiet_factor", id="quiet-factor"),
        pytest.param({"network": "torus"}, "torus", id="topology"),
    ],
)
def test_bad_arguments(kwargs: dict, match: str) -> None:
    call = {"algorithm": "grape-s", "network": LOCKSTEP, **kwargs}
    with pytest.raises(MissionError, match=match):
        simulate(two_robots(), call.pop("algorithm"), call.pop("network"), **call)
