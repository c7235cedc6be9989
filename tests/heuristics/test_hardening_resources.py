"""Resource blow-ups, centralized time limits and the network spec's small print.

Each fault that once escaped is a row here: the exact diameter against its reference,
edge lists and missions too large for the machine refused up front with the memory they
would need, every centralized engine's ``time_limit`` (and ``cfopt run --time-limit``),
and the spec's stdin, path and digit rules.  Cases about the command line run it as a
real process (``python -m cfopt``): exit 0 or 2, one ``error:`` line, no traceback.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_array

import heuristics
from cfopt import Mission, MissionError, generate_mission
from heuristics._graphs import bfs_distances, diameter, reference_diameter
from heuristics.network import NetworkSpec
from tests.cfopt.test_hardening import assert_one_error_line, cfopt

ENGINES = heuristics.algorithm_names()


# ---------------------------------------------------------------------- diameter
def _adjacency(n: int, edges: list[tuple[int, int]]) -> csr_array:
    pairs = np.array(edges, dtype=np.int64).reshape(-1, 2)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1]])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0]])
    graph = csr_array((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n, n))
    graph.sum_duplicates()
    return graph


@st.composite
def connected_graphs(draw: st.DrawFn) -> tuple[int, list[tuple[int, int]]]:
    """A random tree (each robot linked to an earlier one) plus random extra links."""
    n = draw(st.integers(2, 60))
    parents = [draw(st.integers(0, i - 1)) for i in range(1, n)]
    edges = [(parent, i) for i, parent in enumerate(parents, start=1)]
    extra = draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=3 * n))
    return n, edges + [(a, b) for a, b in extra if a != b]


@settings(max_examples=150, deadline=None)
@given(connected_graphs())
def test_diameter_equals_the_reference_and_networkx(graph: tuple[int, list]) -> None:
    n, edges = graph
    adjacency = _adjacency(n, edges)
    expected = nx.diameter(nx.Graph(edges))
    assert diameter(adjacency) == reference_diameter(adjacency) == expected


@pytest.mark.parametrize(
    "text",
    ["er p=0.05", "er p=0.3", "geometric radius=0.25", "smallworld k=4 p=0.1",
     "smallworld k=6 p=0.5", "ring", "grid"],
)  # fmt: skip
@pytest.mark.parametrize("n", [3, 17, 120, 400])
def test_every_topology_keeps_its_diameter(text: str, n: int) -> None:
    mission = Mission.from_arrays(np.ones((n, 1), bool), [[1]], [1.0])
    try:
        net = NetworkSpec.parse(text).build(mission, np.random.default_rng(n))
    except MissionError:
        pytest.skip("no connected draw at this size")
    if net.is_complete:
        return
    adjacency = _adjacency(n, net.edges.tolist())
    assert net.diameter == diameter(adjacency) == reference_diameter(adjacency)


def test_breadth_first_distances_match_networkx() -> None:
    graph = nx.connected_watts_strogatz_graph(300, 4, 0.2, seed=3)
    adjacency = _adjacency(300, list(graph.edges()))
    lengths = nx.single_source_shortest_path_length(graph, 7)
    assert bfs_distances(adjacency, 7).tolist() == [lengths[v] for v in range(300)]


def test_a_single_robot_and_a_path() -> None:
    assert diameter(csr_array((1, 1), dtype=np.int8)) == 0
    path = _adjacency(50, [(i, i + 1) for i in range(49)])
    assert diameter(path) == reference_diameter(path) == 49


# --------------------------------------------------------------------- edge lists
@pytest.fixture
def mission6(tmp_path: Path) -> Path:
    path = tmp_path / "m6.json"
    generate_mission(6, 50, 2, 1, seed=0).to_json(path)
    return path


def _sparse_file(path: Path, size: int) -> Path:
    with open(path, "wb") as handle:
        handle.truncate(size)  # a hole: nothing is written, the size is what is checked
    return path


@pytest.mark.parametrize("name", ["edges.txt", "net.json"])
def test_an_edge_list_too_large_is_refused_unread(tmp_path: Path, mission6: Path, name: str):
    huge = _sparse_file(tmp_path / name, 2**40)
    spec = f"file={huge}"
    result = cfopt("run", "grape-s", str(mission6), "--network", spec)
    assert_one_error_line(result, "would need about")
    assert spec in result.stderr and "this machine has" in result.stderr


def test_a_network_json_too_large_is_refused_unread(tmp_path: Path, mission6: Path) -> None:
    huge = _sparse_file(tmp_path / "huge.json", 2**40)
    result = cfopt("run", "grape-s", str(mission6), "--network", str(huge))
    assert_one_error_line(result, "would need about")


def test_a_disconnected_edge_list_is_one_error(tmp_path: Path, mission6: Path) -> None:
    edges = tmp_path / "edges.txt"
    edges.write_text("r0 r1\nr1 r2\n# r3 is alone\nr4 r5\n", encoding="utf-8")
    result = cfopt("run", "grape-s", str(mission6), "--network", f"file={edges}")
    assert_one_error_line(result, "disconnected")


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        pytest.param(b"r0 r1\r\nr1 r2 r3\n", "line 2: expected two robot ids", id="crlf"),
        pytest.param(b"r0 r1\x0cr1\nr2 r3\n", "line 2: expected two robot ids", id="form-feed"),
        pytest.param(b"r0 r1\nr1 r1\n", "line 2: links robot \"r1\" to itself", id="loop"),
        pytest.param(b"r0 r1\nr1 \xff\n", "not UTF-8 text (invalid start byte at byte 9)",
                     id="utf8"),
    ],
)  # fmt: skip
def test_edge_list_lines_are_numbered_as_before(tmp_path: Path, content: bytes, fragment: str):
    edges = tmp_path / "edges.txt"
    edges.write_bytes(content)
    with pytest.raises(MissionError, match=re.escape(fragment)):
        NetworkSpec.parse(f"file={edges}")


def test_an_edge_list_keeps_one_copy_of_each_id(tmp_path: Path) -> None:
    edges = tmp_path / "edges.txt"
    edges.write_text("".join(f"a{i % 5} b{i % 7}\n" for i in range(200)), encoding="utf-8")
    spec = NetworkSpec.parse(f"file={edges}")
    assert len({id(rid) for pair in spec.edges for rid in pair}) == 12
    assert spec.edge_lines is not None and list(spec.edge_lines) == list(range(1, 201))


# ------------------------------------------------------------ dense engine tables
@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s", "pair-grape-s-chain"])
def test_a_wide_mission_is_refused_with_the_memory_it_needs(tmp_path: Path, algorithm: str):
    wide = tmp_path / "wide.json"
    generate_mission(200, 25, 40_000, 1, seed=0).to_json(wide)
    result = cfopt("run", algorithm, str(wide), "--json")
    assert_one_error_line(result, "would need about")
    assert "40000 services" in result.stderr and result.stdout == ""


# ------------------------------------------------------------------- time limits
@pytest.fixture(scope="module")
def crowded() -> Mission:
    return generate_mission(60, 50, 2, 1, load=3, seed=4)


@pytest.mark.parametrize("algorithm", ENGINES)
def test_a_time_limit_reached_returns_the_partition_so_far(crowded: Mission, algorithm: str):
    run = heuristics.run_algorithm(algorithm, crowded, time_limit=1e-9)
    assert run.status is heuristics.RunStatus.TIME_LIMIT
    assert run.to_dict(crowded)["status"] == "time_limit"
    full = heuristics.run_algorithm(algorithm, crowded)
    assert run.iterations < full.iterations
    run.assignment.to_dict(crowded)  # a valid partition of the mission's robots


@pytest.mark.parametrize("algorithm", ENGINES)
@pytest.mark.parametrize("order", ["index", "random"])
def test_a_time_limit_not_reached_changes_nothing(crowded: Mission, algorithm: str, order):
    if order == "random" and algorithm in ("sda", "rachna-dt"):
        order = "index"
    plain = heuristics.run_algorithm(algorithm, crowded, seed=5, order=order)
    limited = heuristics.run_algorithm(algorithm, crowded, seed=5, order=order, time_limit=1e6)
    assert plain.status is limited.status is heuristics.RunStatus.COMPLETE
    assert plain.replace_seconds(0.0) == limited.replace_seconds(0.0)
    assert plain.to_dict(crowded)["status"] == "complete"


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, True, "1"])
def test_a_bad_time_limit_is_refused(crowded: Mission, bad: object) -> None:
    with pytest.raises(MissionError, match="time_limit: must be a number of seconds > 0"):
        heuristics.grape_s(crowded, time_limit=bad)  # type: ignore[arg-type]


def test_cfopt_run_time_limit_for_a_centralized_run(tmp_path: Path) -> None:
    mission = tmp_path / "m.json"
    generate_mission(60, 50, 2, 1, load=3, seed=4).to_json(mission)
    result = cfopt("run", "rachna-dt", str(mission), "--time-limit", "1e-9", "--json")
    assert result.returncode == 0 and result.stderr == ""
    assert json.loads(result.stdout)["status"] == "time_limit"
    summary = cfopt("run", "sda", str(mission), "--time-limit", "1e-9")
    assert summary.returncode == 0 and "stopped at the time limit" in summary.stdout
    complete = cfopt("run", "grape-s", str(mission), "--time-limit", "1000", "--json")
    assert json.loads(complete.stdout)["status"] == "complete"
    assert_one_error_line(
        cfopt("run", "grape-s", str(mission), "--time-limit", "0"), "--time-limit"
    )


# -------------------------------------------------------------------- spec nits
@pytest.mark.parametrize("spec", ["-", "file=-"])
def test_stdin_is_refused_as_a_network(mission6: Path, spec: str) -> None:
    assert_one_error_line(
        cfopt("run", "grape-s", str(mission6), "--network", spec), "not read from stdin"
    )


@pytest.mark.parametrize("as_edges", [False, True])
def test_a_fifo_network_names_no_stdin_hint(tmp_path: Path, mission6: Path, as_edges: bool):
    fifo = tmp_path / "net.json"
    os.mkfifo(fifo)
    spec = f"file={fifo}" if as_edges else str(fifo)
    result = cfopt("run", "grape-s", str(mission6), "--network", spec)
    assert_one_error_line(result, "give a regular file")
    assert "'-'" not in result.stderr


def test_paths_with_spaces_are_files(tmp_path: Path, mission6: Path) -> None:
    folder = tmp_path / "my networks"
    folder.mkdir()
    ring = [[f"r{i}", f"r{(i + 1) % 6}"] for i in range(6)]
    network = folder / "ring net.json"
    network.write_text(json.dumps({"topology": "file", "edges": ring}), encoding="utf-8")
    named = folder / "named ring"  # no .json: an existing path is a network file
    named.write_text(json.dumps({"topology": "ring"}), encoding="utf-8")
    edges = folder / "the edges.txt"
    edges.write_text("".join(f"{a} {b}\n" for a, b in ring), encoding="utf-8")
    for spec in (str(network), str(named), f"file={edges} latency=constant:1ms"):
        result = cfopt("run", "grape-s", str(mission6), "--network", spec, "--seed", "1", "--json")
        assert result.returncode == 0, result.stderr
        assert json.loads(result.stdout)["network"]["d_G"] == 3
    spec = NetworkSpec.parse(f"file={edges} loss=0.1")
    assert NetworkSpec.parse(spec.to_text()) == spec and spec.path == str(edges)


@pytest.mark.parametrize(
    "token",
    ["latency=constant:\u0661ms", "latency=uniform:1ms:\uff15ms", "loss=\u0660.\u0661",
     "loss=ge:0.1:0.\u0663:0.5", "period=\u0967ms", "jitter=0.\u0662",
     "latency=lognormal:5ms:0.\u0665"],
)  # fmt: skip
def test_numbers_take_ascii_digits_only(token: str) -> None:
    with pytest.raises(MissionError) as caught:
        NetworkSpec.parse(f"ring {token}")
    assert caught.value.cli_message.startswith(f"--network: token {token!r}: ")


@pytest.mark.parametrize("params", ["k=\u0664 p=0.1", "k=4 p=0.\u0661"])
def test_topology_parameters_take_ascii_digits_only(params: str, mission6: Path) -> None:
    result = cfopt("run", "grape-s", str(mission6), "--network", f"smallworld {params}")
    assert_one_error_line(result, "--network: token")
