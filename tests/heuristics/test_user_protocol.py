"""A protocol written only against the public agent API -- the README's, read from the
README so the two cannot drift -- runs in the simulator and over MPI, with neither
transport changed; and what the API promises around it."""

from __future__ import annotations

import ast
import importlib
import pickle
import re
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import cfopt
import heuristics
from cfopt import Mission, MissionError
from heuristics.agents import Agent, Protocol
from heuristics.distributed import protocol_for

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), re.S | re.M)
(PROTOCOL_BLOCK,) = [block for block in BLOCKS if "(Protocol):" in block]
LOCKSTEP = "complete period=1ms sync=true"
NETWORKS = [
    LOCKSTEP,
    "complete latency=uniform:1ms:10ms loss=0.01",
    "ring latency=uniform:1ms:5ms loss=0.05",
    "geometric radius=0.5 latency=exponential:3ms medium=unicast",
]


def definitions(block: str) -> str:
    """The block's imports, classes and functions: the module a user would save."""
    kinds = (ast.Import, ast.ImportFrom, ast.ClassDef, ast.FunctionDef)
    tree = ast.parse(block)
    return "\n\n".join(
        ast.get_source_segment(block, node) or "" for node in tree.body if isinstance(node, kinds)
    )


@pytest.fixture
def greedy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """The README's protocol saved as ``greedy.py`` in the working directory."""
    (tmp_path / "greedy.py").write_text(definitions(PROTOCOL_BLOCK), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("greedy", None)
    return importlib.import_module("greedy")


def mission_of(robots: int = 20, seed: int = 1) -> Mission:
    return cfopt.generate_mission(robots, 20, 4, 2, seed=seed)


def test_the_readme_block_is_about_fifty_lines_of_public_api() -> None:
    code = definitions(PROTOCOL_BLOCK)
    assert 40 <= len([line for line in code.splitlines() if line.strip()]) <= 60
    imported = {
        node.module for node in ast.walk(ast.parse(code)) if isinstance(node, ast.ImportFrom)
    }
    assert imported == {"heuristics.agents"}  # the public API, nothing private


@pytest.mark.parametrize("network", NETWORKS)
def test_the_users_protocol_runs_in_the_simulator(greedy: ModuleType, network: str) -> None:
    m = mission_of(30)
    run = heuristics.simulate(m, greedy.GreedyProtocol(), network, seed=0)
    run.assignment.validate(m)  # only slots the robots can serve
    assert run.algorithm == "greedy" and run.assignment.percent_utility(m) > 50
    if "loss" not in network:  # a lost last update may leave a robot behind
        assert run.network.beliefs_agree and run.network.converged
    assert run.bytes == run.network.bytes > 0 and run.iterations > 0
    assert dict(run.options)["engine"] == "simulated"
    again = heuristics.simulate(m, greedy.GreedyProtocol(), network, seed=0)
    assert again.replace_seconds(0.0) == run.replace_seconds(0.0)  # byte for byte


def test_the_users_protocol_over_mpi_is_the_simulators_run(greedy: ModuleType) -> None:
    pytest.importorskip("mpi4py")
    m = mission_of(20)
    sim = heuristics.simulate(m, greedy.GreedyProtocol(), LOCKSTEP, seed=0)
    run = heuristics.mpi_run(m, greedy.GreedyProtocol(), LOCKSTEP, ranks=2, seed=0)
    assert run.algorithm == "greedy"
    assert np.array_equal(run.assignment.task, sim.assignment.task)
    assert np.array_equal(run.assignment.service, sim.assignment.service)
    assert (run.iterations, run.rounds, run.messages, run.bytes) == (
        sim.iterations,
        sim.rounds,
        sim.messages,
        sim.bytes,
    )
    assert run.network.converged and run.network.ticks == sim.network.ticks
    transport = run.network.transport
    assert transport.wire_messages == transport.received_messages > 0
    assert transport.wire_bytes == transport.received_bytes


# ------------------------------------------------------------------- the API around it
class Idle(Agent):
    """Does nothing and stops at its first tick."""

    def tick(self, now: int, received: object, inbox: list) -> tuple[None, list]:
        self.ticks += 1
        self.stopped = True
        return None, []


class Nothing(Protocol):
    def make_agent(self, context):  # type: ignore[no-untyped-def]
        return Idle()


def test_a_protocol_that_does_nothing() -> None:
    m = mission_of(8)
    run = heuristics.simulate(m, Nothing(), "ring", seed=0)
    assert run.algorithm == "Nothing"  # a protocol without a name: its class's
    assert (run.rounds, run.messages, run.iterations, run.work) == (1, 0, 0, 0)
    assert run.network.converged and run.network.convergence_seconds == 0.0
    assert run.assignment.task.tolist() == [-1] * 8


def test_protocols_of_main_cannot_go_to_the_ranks() -> None:
    pytest.importorskip("mpi4py")
    Lost = type("Lost", (Nothing,), {"__module__": "__main__"})
    with pytest.raises(MissionError, match="defined in __main__"):
        heuristics.mpi_run(mission_of(8), Lost(), LOCKSTEP, ranks=2, seed=0)
    local = Nothing()
    local.hook = lambda: None  # type: ignore[attr-defined]  # a lambda does not pickle
    with pytest.raises(MissionError, match="must be picklable"):
        heuristics.mpi_run(mission_of(8), local, LOCKSTEP, ranks=2, seed=0)


@pytest.mark.parametrize(
    ("algorithm", "options", "error", "match"),
    [
        pytest.param("rachna-dt", None, MissionError, "has no distributed agents", id="no-agents"),
        pytest.param(3, None, TypeError, "algorithm: must be an algorithm's name", id="type"),
        pytest.param("sda", {"exchange": True}, MissionError, "take eps, resend", id="option"),
        pytest.param("grape-s", {"eps": 1}, MissionError, "take none", id="none"),
        pytest.param(Nothing(), {"eps": 1}, MissionError, "only with an algorithm", id="object"),
        pytest.param("sda", ["eps"], TypeError, "options: must be a mapping", id="mapping"),
    ],
)
def test_bad_algorithms_and_options(
    algorithm: object, options: object, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        protocol_for(algorithm, options)  # type: ignore[arg-type]
    with pytest.raises(error, match=match):
        heuristics.simulate(mission_of(8), algorithm, "complete", options=options)  # type: ignore[arg-type]


def test_every_name_stands_for_a_protocol_that_runs() -> None:
    m = mission_of(12)
    names = [n for n in heuristics.algorithm_names() if heuristics.get_algorithm(n).distributed]
    assert len(names) == 5
    for name in names:
        protocol = protocol_for(name)
        assert isinstance(protocol, Protocol) and protocol.name == name
        by_object = heuristics.simulate(m, protocol, LOCKSTEP, seed=2)
        by_name = heuristics.simulate(m, name, LOCKSTEP, seed=2)
        assert by_object.replace_seconds(0.0) == by_name.replace_seconds(0.0)


def test_ranks_load_the_pickled_protocol_from_the_launchers_directory(tmp_path: Path) -> None:
    """What a rank does with ``--protocol-file`` and ``--sys-path``."""
    from heuristics.mpi import load_protocol

    home = tmp_path / "home"
    home.mkdir()
    (home / "far_away.py").write_text(definitions(PROTOCOL_BLOCK), encoding="utf-8")
    sys.path.insert(0, str(home))
    try:
        shipped = tmp_path / "protocol.pickle"
        shipped.write_bytes(pickle.dumps(importlib.import_module("far_away").GreedyProtocol()))
    finally:
        sys.path.remove(str(home))
        sys.modules.pop("far_away", None)
    with pytest.raises(MissionError, match="cannot load the protocol"):
        load_protocol(shipped)  # the module is nowhere on the path
    try:
        assert load_protocol(shipped, str(home)).name == "greedy"
    finally:
        sys.path.remove(str(home))
        sys.modules.pop("far_away", None)
    (tmp_path / "other.pickle").write_bytes(pickle.dumps([1, 2]))
    with pytest.raises(MissionError, match=r"holds no heuristics\.agents\.Protocol"):
        load_protocol(tmp_path / "other.pickle")
