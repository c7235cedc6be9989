"""The simulator's network model: the spec, the graphs, the clocks and the link physics."""

from __future__ import annotations

import itertools
import json
import time

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cfopt import Mission, MissionError
from heuristics.network import (
    MAX_DURATION_NS,
    Clocks,
    Latency,
    Links,
    Loss,
    Network,
    NetworkSpec,
    format_duration,
    parse_duration,
)


def robots(n: int) -> Mission:
    return Mission.from_arrays(np.ones((n, 1), dtype=bool), [[1]], [1.0])


def build(text: str, n: int, seed: int = 0) -> Network:
    return NetworkSpec.parse(text).build(robots(n), np.random.default_rng(seed))


# ------------------------------------------------------------------ spec round trips
probabilities = st.floats(0, 1)
durations = st.one_of(
    st.integers(0, MAX_DURATION_NS),
    st.integers(0, 10**6).map(lambda v: v * 10**6),  # whole ms, formatted as ms or s
)


@st.composite
def latencies(draw) -> Latency:
    kind = draw(st.sampled_from(["constant", "uniform", "exponential", "lognormal"]))
    if kind == "uniform":
        low, high = sorted((draw(durations), draw(durations)))
        return Latency(kind, (low, high))
    if kind == "lognormal":
        return Latency(kind, (draw(durations.filter(bool)),), draw(st.floats(0, 5)))
    return Latency(kind, (draw(durations),))


losses = st.one_of(
    st.builds(lambda p: Loss("bernoulli", (p,)), st.floats(0, 1, exclude_max=True)),
    st.builds(
        lambda a, b, c: Loss("ge", (a, b, c)),
        probabilities,
        st.floats(0, 1, exclude_min=True),
        probabilities,
    ),
)


@st.composite
def specs(draw) -> NetworkSpec:
    topology = draw(st.sampled_from(["complete", "ring", "grid", "geometric", "er", "smallworld"]))
    params: dict = {}
    if topology == "geometric":
        params["radius"] = draw(st.floats(0, 2, exclude_min=True))
    if topology == "er":
        params["p"] = draw(st.floats(0, 1, exclude_min=True))
    if topology == "smallworld":
        params["k"] = 2 * draw(st.integers(1, 50))
        params["p"] = draw(probabilities)
    return NetworkSpec(
        topology=topology,
        **params,
        latency=draw(latencies()),
        loss=draw(losses),
        medium=draw(st.sampled_from(["broadcast", "unicast"])),
        period_ns=draw(st.integers(1, MAX_DURATION_NS)),
        jitter=draw(st.floats(0, 1, exclude_max=True)),
        sync=draw(st.booleans()),
    )


@settings(max_examples=80)
@given(spec=specs())
def test_text_and_json_forms_round_trip(spec: NetworkSpec) -> None:
    text = spec.to_text()
    assert "\n" not in text
    assert NetworkSpec.parse(text) == spec
    assert NetworkSpec.parse(text).to_text() == text
    assert NetworkSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec


@settings(max_examples=50)
@given(ns=st.integers(0, MAX_DURATION_NS))
def test_durations_round_trip(ns: int) -> None:
    assert parse_duration(format_duration(ns)) == ns


def test_defaults_and_spelled_out_values() -> None:
    spec = NetworkSpec.parse("  complete  ")
    assert spec == NetworkSpec()
    assert spec.to_text() == "complete"
    assert (spec.latency, spec.loss, spec.medium) == (
        Latency("constant", (0,)),
        Loss(),
        "broadcast",
    )
    assert (spec.period_ns, spec.jitter, spec.sync) == (10_000_000, 0.1, False)
    spelled = NetworkSpec.parse(
        "smallworld p=0.25 k=6 latency=lognormal:0.5ms:0.25 loss=ge:0.01:0.5:1 "
        "medium=unicast period=0.02s jitter=0 sync=true"
    )
    assert (spelled.k, spelled.p) == (6, 0.25)
    assert spelled.latency == Latency("lognormal", (500_000,), 0.25)
    assert spelled.loss.probabilities == (0.01, 0.5, 1.0)
    assert spelled.to_text() == (
        "smallworld k=6 p=0.25 latency=lognormal:500us:0.25 loss=ge:0.01:0.5:1.0 "
        "medium=unicast period=20ms jitter=0.0 sync=true"
    )
    assert parse_duration("1.5us") == 1500
    assert parse_duration("2s") == 2 * 10**9


def test_edge_list_files_round_trip(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "edges.txt").write_text("# a triangle\nr0 r1\n\nr1   r2  # trailing\nr2 r0\n")
    (tmp_path / "edges.json").write_text('[["r0", "r1"], ["r1", "r2"], ["r2", "r0"]]')
    text = NetworkSpec.parse("file=edges.txt latency=constant:1ms")
    assert text.edges == (("r0", "r1"), ("r1", "r2"), ("r2", "r0"))
    assert text.to_text() == "file=edges.txt latency=constant:1ms"
    assert NetworkSpec.parse(text.to_text()) == text
    from_json = NetworkSpec.parse("file=edges.json latency=constant:1ms")
    assert from_json == text and from_json.path == "edges.json"
    assert NetworkSpec.from_dict(text.to_dict()) == text
    net = text.build(robots(3), np.random.default_rng(0))
    assert net.edges.tolist() == [[0, 1], [0, 2], [1, 2]]
    assert net.diameter == 1


def test_network_json_file_and_replay(tmp_path, monkeypatch) -> None:
    """A geometric run's network written by ``to_json`` rebuilds the same graph."""
    monkeypatch.chdir(tmp_path)
    mission = robots(60)
    net = build("geometric radius=0.35 latency=uniform:1ms:3ms loss=0.05 jitter=0.2", 60, 3)
    (tmp_path / "net.json").write_text(net.to_json(mission))
    replayed_spec = NetworkSpec.parse("net.json")
    assert replayed_spec.topology == "file"
    assert (replayed_spec.latency, replayed_spec.loss) == (net.spec.latency, net.spec.loss)
    assert replayed_spec.jitter == 0.2
    replayed = replayed_spec.build(mission, np.random.default_rng(99))
    assert np.array_equal(replayed.edges, net.edges)
    assert replayed.diameter == net.diameter
    assert replayed_spec.path == "net.json"
    text = replayed_spec.to_text()
    assert text == "file=net.json latency=uniform:1ms:3ms loss=0.05 jitter=0.2"
    assert NetworkSpec.parse(text) == replayed_spec  # file=net.json reads its edges
    with pytest.raises(MissionError, match="no one-line spec"):
        NetworkSpec.from_dict(replayed_spec.to_dict()).to_text()
    (tmp_path / "ring.json").write_text(json.dumps(NetworkSpec.parse("ring").to_dict()))
    with pytest.raises(MissionError, match=r"^file=ring\.json: a network JSON file of topology"):
        NetworkSpec.parse("file=ring.json")
    # deterministic topologies are written by name
    assert build("grid", 7).to_dict(robots(7))["topology"] == "grid"
    assert "edges" not in NetworkSpec().build(robots(4), np.random.default_rng(0)).to_dict(
        robots(4)
    )


# ---------------------------------------------------------------------- bad specs
DISCONNECTED_EDGES = "r0 r1\nr2 r3\n"
BAD_SPECS = [
    pytest.param("", {}, "^empty network spec", id="empty"),
    pytest.param("star", {}, "^star: unknown topology 'star'", id="unknown-topology"),
    pytest.param("ring speed=3", {}, "^speed=3: unknown key 'speed'", id="unknown-key"),
    pytest.param("ring loss=0.1 loss=0.2", {}, "^loss=0.2: key 'loss' given twice", id="dup-key"),
    pytest.param(
        "ring period=1ms period=1ms", {}, "^period=1ms: key 'period' given", id="dup-key2"
    ),
    pytest.param("ring jitter", {}, "^jitter: expected key=value", id="no-value"),
    pytest.param(
        "ring latency=constant:-2ms",
        {},
        r"^latency=constant:-2ms: durations must be >= 0",
        id="negative-latency",
    ),
    pytest.param(
        "ring latency=uniform:5ms:1ms",
        {},
        "the low bound 5ms is above the high bound 1ms",
        id="uniform-a-above-b",
    ),
    pytest.param(
        "ring latency=lognormal:5ms:-0.5",
        {},
        "SIGMA must be a finite number >= 0",
        id="negative-sigma",
    ),
    pytest.param("ring latency=constant:5", {}, "is not a duration", id="duration-without-unit"),
    pytest.param("ring latency=gauss:5ms", {}, "unknown latency model 'gauss'", id="latency-model"),
    pytest.param(
        "ring loss=1.5", {}, r"^loss=1.5: the loss probability must be in \[0, 1\)", id="loss>1"
    ),
    pytest.param("ring loss=1", {}, r"must be in \[0, 1\), got 1.0", id="loss=1"),
    pytest.param("ring loss=-0.1", {}, r"must be in \[0, 1\)", id="loss<0"),
    pytest.param("ring loss=ge:0.1:0.5", {}, "expected ge:P_GOOD_TO_BAD", id="ge-arity"),
    pytest.param("ring loss=ge:1.2:0.5:0.5", {}, "P_GOOD_TO_BAD must be in", id="ge-gb"),
    pytest.param("ring loss=ge:0.1:0:0.5", {}, "P_BAD_TO_GOOD must be > 0", id="ge-bg"),
    pytest.param("ring loss=ge:0.1:0.5:2", {}, "LOSS_IN_BAD must be in", id="ge-loss"),
    pytest.param("ring loss=gx:0.1:0.5:2", {}, "unknown loss model 'gx'", id="loss-model"),
    pytest.param("geometric", {}, "^geometric: needs radius=R", id="missing-radius"),
    pytest.param("smallworld k=4", {}, "^smallworld: needs k=K p=P", id="missing-p"),
    pytest.param(
        "ring radius=0.3", {}, "^radius=0.3: radius applies only to geometric", id="radius"
    ),
    pytest.param("geometric radius=-1", {}, "radius must be a finite number > 0", id="radius<0"),
    pytest.param("er p=1.5", {}, r"p must be in \(0, 1\]", id="er-p"),
    pytest.param("smallworld k=3 p=0.1", {}, "k must be an even whole number", id="odd-k"),
    pytest.param("smallworld k=40 p=0.1", {}, "^k=40: smallworld needs k below", id="k>=n"),
    pytest.param("loss=0.1 ring", {}, "must start with a topology", id="key-first"),
    pytest.param("ring jitter=1", {}, r"^jitter=1: the jitter .* must be in \[0, 1\)", id="jitter"),
    pytest.param("ring period=0ms", {}, "^period=0ms: the clock period must be > 0", id="period0"),
    pytest.param("ring sync=yes", {}, "must be true or false", id="sync"),
    pytest.param("ring medium=radio", {}, "must be broadcast or unicast", id="medium"),
    pytest.param(
        "geometric radius=0.01",
        {},
        r"^radius=0.01: .* disconnected \(\d+ components\); use a "
        "larger radius",
        id="disconnected-geometric",
    ),
    pytest.param("er p=0.001", {}, r"^p=0.001: 100 draws .* use a larger p", id="disconnected-er"),
    pytest.param(
        "file=edges.txt",
        {"edges.txt": "r0 r1\nr1 r99\n"},
        r'^file=edges.txt: line 2: unknown robot id "r99"',
        id="file-unknown-robot",
    ),
    pytest.param(
        "file=edges.json",
        {"edges.json": '[["r0", "r1"], ["r1", "nobody"]]'},
        r'^file=edges.json: \[1\]\[1\]: unknown robot id "nobody"',
        id="json-unknown-robot",
    ),
    pytest.param(
        "file=edges.txt",
        {"edges.txt": DISCONNECTED_EDGES},
        r"^file=edges.txt: the file network over 20 robots is disconnected \(18 components; "
        r"r2, r3, r4 and 15 more cannot reach r0\); add edges",
        id="file-disconnected",
    ),
    pytest.param(
        "file=edges.txt",
        {"edges.txt": "r0 r1 r2\n"},
        "^file=edges.txt: line 1: expected two",
        id="file-three-ids",
    ),
    pytest.param(
        "file=edges.txt", {"edges.txt": "r0 r0\n"}, 'links robot "r0" to itself', id="self-loop"
    ),
    pytest.param("file=missing.txt", {}, "^file=missing.txt: no such file", id="file-missing"),
    pytest.param(
        "net.json",
        {"net.json": '{"topology": "ring", "speed": 1}'},
        "^net.json: speed: unknown key",
        id="network-json-unknown-key",
    ),
    pytest.param(
        "net.json",
        {"net.json": '{"topology": "ring", "loss": 0.1, "loss": 0.2}'},
        "^net.json: loss: key given more than once",
        id="network-json-dup-key",
    ),
    pytest.param(
        "net.json",
        {"net.json": '{"topology": "ring", "period": 10}'},
        "^net.json: period: must be a duration with a unit",
        id="network-json-period",
    ),
    pytest.param(
        "net.json",
        {"net.json": '{"topology": "file", "edges": [["r0", "r1"], ["r1", "x"]]}'},
        r'^net.json: edges\[1\]\[1\]: unknown robot id "x"',
        id="network-json-unknown-robot",
    ),
    pytest.param("absent.json", {}, "^absent.json: no such file", id="network-json-missing"),
]


@pytest.mark.parametrize(("text", "files", "match"), BAD_SPECS)
def test_bad_specs_are_mission_errors(text, files, match, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    for name, content in files.items():
        (tmp_path / name).write_text(content)
    with pytest.raises(MissionError, match=match) as info:
        NetworkSpec.parse(text).build(robots(20), np.random.default_rng(0))
    assert info.value.cli_message.startswith("--network: ")
    token = text.split()[-1] if text.split() else ""
    if str(info.value).startswith(token + ":") and "=" in token:
        assert info.value.cli_message.startswith(f"--network: token {token!r}: ")


def test_direct_construction_is_validated() -> None:
    with pytest.raises(MissionError, match=r"^jitter: "):
        NetworkSpec(jitter=1.0)
    with pytest.raises(MissionError, match=r"^radius: the geometric topology needs radius"):
        NetworkSpec(topology="geometric")
    with pytest.raises(MissionError, match=r"^latency: the low bound"):
        Latency("uniform", (5, 1))
    with pytest.raises(MissionError, match=r"^loss: "):
        Loss("bernoulli", (1.0,))
    with pytest.raises(MissionError, match=r"^edges: the file topology needs its edges"):
        NetworkSpec(topology="file")
    with pytest.raises(TypeError, match=r"numpy.random.Generator"):
        NetworkSpec().build(robots(3), 42)  # type: ignore[arg-type]


# --------------------------------------------------------------------- the graphs
TOPOLOGIES = [
    "complete",
    "ring",
    "grid",
    "geometric radius=0.6",
    "er p=0.3",
    "smallworld k=2 p=0.3",
    "smallworld k=4 p=0",
]


@pytest.mark.parametrize("text", TOPOLOGIES)
@pytest.mark.parametrize("n", [2, 3, 5, 8, 13, 24])
def test_diameter_hops_and_next_hop_agree_with_networkx(text: str, n: int) -> None:
    if text.startswith("smallworld") and int(text.split()[1][2:]) >= n:
        pytest.skip("k must be below n")
    networks = []
    for seed in range(40):  # small geometric graphs are often disconnected: take 3 that are not
        try:
            networks.append(build(text, n, seed))
        except MissionError as exc:
            assert "disconnected" in str(exc) and text.startswith("geometric")
        if len(networks) == 3:
            break
    assert len(networks) == 3
    for net in networks:
        graph = net.to_networkx()
        assert nx.is_connected(graph)
        assert net.diameter == nx.diameter(graph)
        assert net.n_edges == graph.number_of_edges()
        distances = dict(nx.all_pairs_shortest_path_length(graph))
        for i in range(n):
            assert net.neighbours(i).tolist() == sorted(graph.neighbors(i))
            assert net.degree(i) == graph.degree(i)
            for t in range(n):
                assert net.hops(i, t) == distances[i][t]
                path = net.path(i, t)
                assert len(path) - 1 == distances[i][t]
                assert all(graph.has_edge(a, b) for a, b in itertools.pairwise(path))
                if i != t:
                    nearer = [
                        u for u in graph.neighbors(i) if distances[u][t] == distances[i][t] - 1
                    ]
                    assert net.next_hop(i, t) == min(nearer)


def test_diameter_of_larger_sparse_graphs(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(5)
    tree = nx.random_labeled_tree(150, seed=5) if hasattr(nx, "random_labeled_tree") else None
    if tree is None:  # networkx < 3.4
        tree = nx.random_tree(150, seed=5)  # pragma: no cover
    lines = [f"r{u} r{v}" for u, v in tree.edges()]
    lines += [f"r{u} r{v}" for u, v in rng.integers(150, size=(10, 2)).tolist() if u != v]
    (tmp_path / "tree.txt").write_text("\n".join(lines))
    net = build("file=tree.txt", 150)
    assert net.diameter == nx.diameter(net.to_networkx())
    for text in ("geometric radius=0.15", "smallworld k=4 p=0.05", "er p=0.04", "grid", "ring"):
        net = build(text, 300, 1)
        assert net.diameter == nx.diameter(net.to_networkx(), usebounds=True), text


def test_geometric_edges_are_networkx_random_geometric_graph() -> None:
    net = build("geometric radius=0.2", 200, 4)
    positions = net.positions
    assert positions is not None and positions.shape == (200, 2)
    assert np.array_equal(positions, np.random.default_rng(4).random((200, 2)))
    pos = {i: tuple(p) for i, p in enumerate(positions.tolist())}
    expected = nx.random_geometric_graph(200, 0.2, pos=pos)
    assert sorted(map(sorted, expected.edges())) == net.edges.tolist()


def test_grid_is_row_major_with_ceil_sqrt_columns() -> None:
    net = build("grid", 7)  # 3 columns: rows 0 1 2 / 3 4 5 / 6
    assert net.edges.tolist() == [[0, 1], [0, 3], [1, 2], [1, 4], [2, 5], [3, 4], [3, 6], [4, 5]]
    assert net.diameter == 4
    assert build("ring", 2).edges.tolist() == [[0, 1]]


@pytest.mark.parametrize("text", [*TOPOLOGIES, "er p=0.01"])
@pytest.mark.parametrize("n", [0, 1])
def test_tiny_missions_have_no_neighbours(text: str, n: int) -> None:
    net = build(text, n)
    assert net.diameter == 0 and net.n_edges == 0
    if n:
        assert net.neighbours(0).tolist() == [] and net.degree(0) == 0
        assert net.next_hop(0, 0) == 0 and net.hops(0, 0) == 0


def test_complete_graph_at_1000_robots_is_implicit_and_fast() -> None:
    start = time.perf_counter()
    net = build("complete", 1000)
    diameter = net.diameter
    neighbours = net.neighbours(500)
    elapsed = time.perf_counter() - start
    assert elapsed < 0.5
    assert diameter == 1 and net.is_complete and net.indices is None
    assert neighbours.dtype == np.int64 and len(neighbours) == 999 and 500 not in neighbours
    assert np.array_equal(neighbours, np.delete(np.arange(1000), 500))
    assert net.neighbours(500) is neighbours  # cached
    assert net.n_edges == 499_500 and net.next_hop(3, 999) == 999 and net.hops(3, 999) == 1
    assert not neighbours.flags.writeable


def test_sparse_graphs_at_1000_robots_are_fast() -> None:
    for text in ("geometric radius=0.1", "smallworld k=4 p=0", "er p=0.01"):
        start = time.perf_counter()
        net = build(text, 1000)
        assert net.diameter >= 2
        net.next_hop(0, 999)
        assert time.perf_counter() - start < 1.0, text


# -------------------------------------------------------------------- determinism
def test_same_seeds_same_everything_whatever_else_happened() -> None:
    def run(seed: int, noise: bool) -> tuple:
        if noise:  # other draws in the process must not matter
            np.random.seed(123)  # noqa: NPY002
            np.random.random(1000)  # noqa: NPY002
            np.random.default_rng().random(77)
        mission = robots(80)
        seeds = np.random.SeedSequence(seed).spawn(4)
        gens = [np.random.default_rng(s) for s in seeds]
        spec = NetworkSpec.parse(
            "geometric radius=0.3 latency=lognormal:2ms:0.7 loss=ge:0.1:0.3:0.6 jitter=0.3"
        )
        net = spec.build(mission, gens[0])
        clocks = Clocks(spec, 80, gens[1])
        links = Links(net, gens[2], gens[3])
        ticks = clocks.tick_times(np.arange(80)[:, None], np.arange(300)[None, :])
        draws = [links.broadcast(i % 80) for i in range(200)]
        delays = np.concatenate([d for _, d, _ in draws])
        lost = np.concatenate([x for _, _, x in draws])
        return net.edges.tobytes(), ticks.tobytes(), delays.tobytes(), lost.tobytes()

    first = run(7, False)
    assert run(7, True) == first
    other = run(8, False)
    assert all(a != b for a, b in zip(first, other, strict=True))


@pytest.mark.parametrize("text", ["er p=0.1", "smallworld k=4 p=0.2", "geometric radius=0.3"])
def test_random_topologies_are_reproducible(text: str) -> None:
    one, two, three = (build(text, 50, seed) for seed in (1, 1, 2))
    assert np.array_equal(one.edges, two.edges)
    assert not np.array_equal(one.edges, three.edges)


def test_clock_ticks_do_not_depend_on_the_order_they_are_asked_in() -> None:
    spec = NetworkSpec.parse("ring period=1ms jitter=0.5")
    forward = Clocks(spec, 10, np.random.default_rng(3))
    backward = Clocks(spec, 10, np.random.default_rng(3))
    ks = np.arange(0, 2000, 7)
    expected = [forward.tick_time(i, int(k)) for i in range(10) for k in ks]
    got = [backward.tick_time(i, int(k)) for i in reversed(range(10)) for k in ks[::-1]]
    assert sorted(expected) == sorted(got)
    assert expected == [backward.tick_time(i, int(k)) for i in range(10) for k in ks]
    assert forward.tick_times(np.arange(10)[:, None], ks).ravel().tolist() == expected
    forgetful = Clocks(spec, 10, np.random.default_rng(3))
    forgetful.kept_blocks = 2  # blocks dropped and drawn again are the same
    assert [forgetful.tick_time(i, int(k)) for i in range(10) for k in ks] == expected


# ------------------------------------------------------------------------- clocks
def test_clock_ticks_follow_offset_period_and_jitter() -> None:
    spec = NetworkSpec.parse("complete period=10ms jitter=0.25")
    clocks = Clocks(spec, 50, np.random.default_rng(0))
    k = np.arange(1000)
    times = clocks.tick_times(np.arange(50)[:, None], k[None, :])
    offsets = clocks.offsets_ns[:, None]
    assert clocks.offsets_ns.min() >= 0 and clocks.offsets_ns.max() < 10_000_000
    jitter = times - offsets - k * 10_000_000
    assert jitter.min() >= 0 and jitter.max() < 2_500_000
    assert jitter.max() > 2_400_000  # uniform over the whole range
    assert np.all(np.diff(times, axis=1) > 0)
    for i, t in ((3, 0), (3, 12_345_678), (49, 999_999_999)):
        kk, at = clocks.next_tick(i, t)
        assert at >= t and at == clocks.tick_time(i, kk)
        assert kk == 0 or clocks.tick_time(i, kk - 1) < t


def test_sync_clocks_tick_together() -> None:
    clocks = Clocks(NetworkSpec.parse("ring period=5ms sync=true"), 4, np.random.default_rng(0))
    assert clocks.tick_times([0, 1, 2, 3], 9).tolist() == [45_000_000] * 4
    assert clocks.offsets_ns.tolist() == [0, 0, 0, 0]
    assert clocks.next_tick(2, 45_000_001) == (10, 50_000_000)


# -------------------------------------------------------------------------- links
def test_latency_models() -> None:
    rng = np.random.default_rng(0)
    assert Latency.parse("constant:3ms").sample(rng, 4).tolist() == [3_000_000] * 4
    uniform = Latency.parse("uniform:1us:5us").sample(rng, 20_000)
    assert uniform.dtype == np.int64 and uniform.min() == 1000 and uniform.max() == 5000
    exponential = Latency.parse("exponential:2ms").sample(rng, 50_000)
    assert abs(exponential.mean() / 2e6 - 1) < 0.03
    lognormal = Latency.parse("lognormal:4ms:0.5").sample(rng, 50_000)
    assert abs(np.median(lognormal) / 4e6 - 1) < 0.03
    assert abs(lognormal.mean() / Latency.parse("lognormal:4ms:0.5").mean_ns - 1) < 0.03


def test_transmit_draws_once_per_reception() -> None:
    net = build("complete latency=uniform:1ms:9ms loss=0.3", 600)
    links = Links(net, np.random.default_rng(1), np.random.default_rng(2))
    receivers = np.arange(1, 501)
    delays, lost = links.transmit(0, receivers)
    assert delays.shape == lost.shape == (500,)
    assert np.array_equal(
        delays, np.random.default_rng(1).integers(10**6, 9 * 10**6, 500, endpoint=True)
    )
    assert np.array_equal(lost, np.random.default_rng(2).random(500) < 0.3)
    assert (links.transmissions, links.receptions, links.losses) == (1, 500, int(lost.sum()))
    empty_delays, empty_lost = links.transmit(3, [])
    assert empty_delays.size == empty_lost.size == 0
    with pytest.raises(IndexError):
        links.transmit(0, [0, 1])


def test_lossless_links_lose_nothing() -> None:
    net = build("ring loss=ge:0:0.5:1", 5)
    links = Links(net, np.random.default_rng(1), np.random.default_rng(2))
    for _ in range(100):
        assert not links.transmit(0, [1, 4])[1].any()


def test_gilbert_elliott_long_run_loss_rate_is_stationary() -> None:
    good_to_bad, bad_to_good, loss_in_bad = 0.05, 0.2, 0.6
    spec = f"complete loss=ge:{good_to_bad}:{bad_to_good}:{loss_in_bad}"
    net = build(spec, 101)
    links = Links(net, np.random.default_rng(0), np.random.default_rng(1))
    receivers = np.arange(1, 101)
    lost = np.array([links.transmit(0, receivers)[1] for _ in range(3000)])
    expected = good_to_bad / (good_to_bad + bad_to_good) * loss_in_bad
    assert net.spec.loss.rate == pytest.approx(expected)
    assert abs(lost[500:].mean() - expected) < 0.01
    # losses come in bursts: a loss is followed by a loss more often than on average
    after_loss = lost[1:][lost[:-1]].mean()
    assert after_loss > expected + 0.2
    # every link starts good: nothing can be lost before its first move to bad
    fresh = Links(net, np.random.default_rng(0), np.random.default_rng(1))
    assert fresh.transmit(0, receivers)[1].mean() < 0.1


def test_bernoulli_loss_rate() -> None:
    net = build("ring loss=0.2", 10)
    links = Links(net, np.random.default_rng(0), np.random.default_rng(1))
    lost = np.concatenate([links.broadcast(i % 10)[2] for i in range(20_000)])
    assert abs(lost.mean() - 0.2) < 0.01


@pytest.mark.parametrize(
    "text",
    [
        "complete",
        "complete latency=uniform:1ms:10ms loss=0.3",
        "ring latency=exponential:5ms loss=0.5",
        "complete latency=lognormal:2ms:0.7",
        "complete latency=lognormal:1s:40",  # a heavy tail: delays clipped to the maximum
        "complete latency=uniform:1ms:10ms loss=ge:0.1:0.3:0.6",
    ],
)
def test_transmit_one_is_transmit_to_one_receiver(text: str) -> None:
    # The simulator's direct-message fast path: same values, same counts, and the
    # generators left in the same state, so every later draw agrees too.
    net = build(text, 12)

    def links() -> Links:
        return Links(net, np.random.default_rng(5), np.random.default_rng(6))

    fast, literal = links(), links()
    pairs = [(i % 12, int(net.neighbours(i % 12)[i % 2])) for i in range(400)]
    for sender, receiver in pairs:
        delays, lost = literal.transmit(sender, [receiver])
        assert fast.transmit_one(sender, receiver) == (int(delays[0]), bool(lost[0]))
    counts = ("transmissions", "receptions", "losses")
    assert [getattr(fast, c) for c in counts] == [getattr(literal, c) for c in counts]
    with pytest.raises(IndexError):
        fast.transmit_one(0, 0)
