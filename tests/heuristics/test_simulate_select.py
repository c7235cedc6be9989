"""GRAPE-S-Select as agents: lock-step equivalence with the centralized engine, the
belief's message, determinism, lossy multi-hop runs (valid, terminating, stable when
converged) and the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import proofs.select_stability as sel
from cfopt import GridCell, Mission, MissionError, generate_mission
from cfopt.cli import main
from cfopt.generate import SEED_NETWORK
from heuristics.agents import GrapeSSelectAgent
from heuristics.agents.belief import Problem
from heuristics.agents.grape_s_select import (
    SelectModel,
    decode_select_belief,
    encode_select_belief,
)
from heuristics.grape_s_select import grape_s_select
from heuristics.registry import get_algorithm
from heuristics.simulate import simulate
from proofs.strategies import missions

LOCKSTEP = "complete sync=true"  # as tests/heuristics/test_simulate.py
ALGORITHM = "grape-s-select"


def assert_same_run(mission: Mission, *, exchange: bool = True) -> None:
    central = grape_s_select(mission, order="index", exchange=exchange)
    options = None if exchange else {"exchange": False}
    run = simulate(mission, ALGORITHM, LOCKSTEP, seed=0, options=options)
    assert run.assignment == central.assignment
    assert run.trajectory.tolist() == central.trajectory.tolist()
    assert run.iterations == central.iterations
    report = run.network
    assert report.converged and report.beliefs_agree and not report.cut
    assert report.losses == 0
    n, m = mission.n_robots, mission.n_tasks
    assert run.bytes == run.messages * (16 + 4 * n + (m + 3) // 4)  # one broadcast each


# ------------------------------------------------------------ lock-step equivalence
@pytest.mark.parametrize("load", [1.0, 1.25, 1.5, 2.0])
def test_lockstep_runs_end_on_the_centralized_assignment(load: float) -> None:
    for robots, percent, services, per_robot in [(12, 50, 3, 2), (20, 10, 5, 2), (30, 50, 10, 5)]:
        for seed in range(3):
            assert_same_run(generate_mission(robots, percent, services, per_robot, load, seed))


def test_lockstep_phase_steps_and_the_exchange_option() -> None:
    """A mission whose centralized run closes tasks, reopens one and exchanges (the
    ablation without the exchange step ends elsewhere): the agents make the same steps."""
    m = generate_mission(30, 50, 10, 5, load=2.0, seed=0)
    with_exchange = grape_s_select(m)
    without = grape_s_select(m, exchange=False)
    assert with_exchange.assignment != without.assignment
    assert with_exchange.rounds > with_exchange.iterations + 1  # a reopening (no move)
    assert (with_exchange.trajectory[:, 2] == -1).any()  # released robots
    assert_same_run(m)
    assert_same_run(m, exchange=False)


@settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(mission=missions(max_robots=9, max_tasks=4, max_services=3))
def test_lockstep_on_drawn_missions(mission: Mission) -> None:
    assert_same_run(mission)


@settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(mission=missions(min_robots=2, max_robots=9, max_tasks=4, max_services=3, achievable=False))
def test_lockstep_on_drawn_oversubscribed_missions(mission: Mission) -> None:
    assert_same_run(mission)


# ----------------------------------------------------------------- belief, agents
@pytest.mark.parametrize("m", [1, 3, 4, 5, 9])
def test_the_message_carries_the_task_bits(m: int) -> None:
    rng = np.random.default_rng(m)
    mission = Mission.from_arrays([[1]] * 3, [[1]] * m, [1.0] * m)
    b = SelectModel(mission).initial()
    b = b.updated(((0, 0), (2, 0)), 5, 2, closed=rng.random(m) < 0.5, used=rng.random(m) < 0.5)
    data = encode_select_belief(b)
    assert len(data) == 16 + 4 * 3 + -(-m // 4)
    back = decode_select_belief(data, 3, m)
    assert back.key == b.key and back.slots.tolist() == b.slots.tolist()
    assert back.closed.tolist() == b.closed.tolist() and back.used.tolist() == b.used.tolist()


def test_concurrent_phase_steps_resolve_by_the_mutex() -> None:
    """Two robots holding one quiet belief make the same close step at different times:
    the beliefs have the same content, and the mutex keeps the higher key."""
    m = Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
    model = SelectModel(m)
    problem = Problem(m)
    start = model.initial()
    b = start.updated(((2, 0),), 1, 2).updated(((1, 0),), 2, 1).updated(((0, 1),), 3, 0)
    assert not model.any_move(b) and not model.final(b)  # t1 can't be completed: close it
    agents = [GrapeSSelectAgent(i, problem, model, quiet_limit=2) for i in range(3)]
    first, _ = agents[0].tick(10, b, [])
    second, _ = agents[1].tick(20, b, [])
    assert first.slots.tolist() == second.slots.tolist() == [-1, 0, 0]
    assert first.closed.tolist() == second.closed.tolist() == [False, True]
    assert first.r == second.r == b.r + 1 and second.key > first.key
    assert agents[0].steps == agents[1].steps == 1
    after, _ = agents[0].tick(30, second, [])  # the mutex keeps robot 1's step; robot 0
    assert after.r == second.r + 1 and after.slots.tolist() == [0, 0, 0]  # then over-fills t0
    assert model.final(after) and not agents[0].stopped
    for now in (40, 50):
        agents[0].tick(now, None, [])
    assert agents[0].stopped  # quiet for quiet_limit ticks with nothing left


def test_bad_options() -> None:
    m = Mission.from_arrays([[1], [1]], [[1]], [1.0])
    assert get_algorithm(ALGORITHM).distributed
    with pytest.raises(MissionError, match="take exchange"):
        simulate(m, ALGORITHM, LOCKSTEP, options={"eps": 1})
    with pytest.raises(MissionError, match="True or False"):
        simulate(m, ALGORITHM, LOCKSTEP, options={"exchange": 1})
    with pytest.raises(MissionError, match="its own reward"):
        simulate(m, ALGORITHM, LOCKSTEP, reward="utility")


# ------------------------------------------------------------ lossy networks
NETWORKS = st.sampled_from(
    [
        SEED_NETWORK,
        "complete latency=exponential:4ms loss=0.1",
        "ring latency=uniform:1ms:5ms loss=0.02",
        "grid latency=constant:3ms loss=0.05 medium=unicast",
        "smallworld k=4 p=0.3 latency=uniform:0ms:12ms loss=ge:0.05:0.5:0.8",
    ]
)


def check_lossy_run(mission: Mission, run) -> None:
    report = run.network
    assert not report.cut  # the robots stopped by themselves
    run.assignment.validate(mission)
    if report.converged:
        assert report.beliefs_agree
        assert sel.is_select_stable(mission, run.assignment)


@settings(max_examples=20, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(mission=missions(min_robots=5, max_robots=10, max_tasks=4, max_services=3),
       spec=NETWORKS, seed=st.integers(0, 2**32))  # fmt: skip
def test_lossy_runs_end_valid_and_stable_when_converged(mission, spec, seed) -> None:
    check_lossy_run(mission, simulate(mission, ALGORITHM, spec, seed=seed))


@pytest.mark.parametrize(
    "spec",
    [SEED_NETWORK, "ring latency=uniform:1ms:10ms loss=0.05", "grid latency=constant:3ms loss=0.1"],
)
def test_lossy_runs_on_oversubscribed_missions(spec: str) -> None:
    converged = 0
    for load, seed in [(1.25, 0), (1.5, 1), (2.0, 2)]:
        m = GridCell(30, 50, 10, 5, load).mission(seed)
        run = simulate(m, ALGORITHM, spec, seed=seed)
        check_lossy_run(m, run)
        assert run.network.losses > 0 and run.network.proposals >= run.iterations
        again = simulate(m, ALGORITHM, spec, seed=seed)
        assert again.replace_seconds(0.0) == run.replace_seconds(0.0)  # same seed, same run
        converged += run.network.converged
    assert converged >= 1


# ------------------------------------------------------------------- command line
def test_cli_runs_grape_s_select_on_a_network(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``cfopt run grape-s-select --network SPEC``, in this process and in a fresh one
    (the same seed gives the same run in both)."""
    m = GridCell(20, 10, 5, 2, 1.5).mission(0)
    path = tmp_path / "m.json"
    m.to_json(path)
    spec = "ring latency=uniform:1ms:10ms loss=0.02"
    args = ["run", ALGORITHM, str(path), "--network", spec, "--seed", "3"]
    assert main(args) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("grape-s-select: utility")
    assert out[3].startswith("network: ring (d_G 10), latency uniform:1ms:10ms, loss 0.02")
    fresh = subprocess.run(
        [sys.executable, "-m", "cfopt", *args, "--json"], capture_output=True, text=True
    )
    assert fresh.returncode == 0, fresh.stderr
    data = json.loads(fresh.stdout)
    run = simulate(m, ALGORITHM, spec, seed=3)
    expected = run.to_dict(m)
    for key in ("algorithm", "iterations", "rounds", "messages", "bytes", "work", "assignment"):
        assert data[key] == expected[key], key
    assert data["network"] == json.loads(json.dumps(expected["network"]))
    assert data["options"]["exchange"] is True and data["options"]["engine"] == "simulated"
