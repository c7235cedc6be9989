"""Resource blow-ups: the network diameter, large edge lists, refusals, time limits.

Targets:

* the exact diameter of ``er`` networks: G(5000, 0.002) under 3 s and G(20000, 0.0005)
  under 15 s (the extrema bounding it replaced: 1884 and about 16,500 searches); drawn
  graphs with peripheral fringes (geometric, smallworld) under 1 s;
* a text edge list read and built into a network at under 20 bytes of peak memory per
  byte of file (the figure the size check assumes; it was about 60);
* refusals before any work: a 1 TiB edge list and a GRAPE-S mission whose member table
  needs hundreds of GiB, each refused in under 1 s;
* ``rachna-dt --time-limit 2`` on 500 robots and 300 over-subscribed identical tasks
  (over 240 s without a limit) back within 3 s with status ``time_limit``.

Run: ``python benchmarks/bench_resources.py [--repeat 3] [--edges 1300000]``.  Memory
is measured in a fresh subprocess (ru_maxrss, less the interpreter's own).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.sparse import csr_array

import heuristics
import heuristics._graphs as graphs
from cfopt import Mission, MissionError, generate_mission
from heuristics.network import NetworkSpec

_EDGES_CHILD = """
import resource, sys, time
import numpy as np
from cfopt import Mission
from heuristics.network import NetworkSpec
mission = Mission.from_json(sys.argv[2])
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
NetworkSpec.parse("file=" + sys.argv[1]).build(mission, np.random.default_rng(0))
seconds = time.perf_counter() - start
print(seconds, (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) * 1024)
"""


def _median(repeat: int, work: Callable[[], object]) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = work()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def _counted(function: Callable[..., int], graph: object) -> tuple[int, int]:
    """The diameter and the number of breadth-first searches it took."""
    calls = [0]
    search = graphs.bfs_distances

    def counting(*args: object) -> object:
        calls[0] += 1
        return search(*args)  # type: ignore[arg-type]

    graphs.bfs_distances = counting  # type: ignore[assignment]
    try:
        return function(graph), calls[0]
    finally:
        graphs.bfs_distances = search


def diameter_rows(repeat: int) -> list[tuple[str, str, str]]:
    cases = [
        ("er p=0.002", 5000, "< 3 s", True),
        ("er p=0.0005", 20000, "< 15 s", False),
        ("geometric radius=0.04", 10000, "< 1 s", True),
        ("smallworld k=10 p=0.3", 3000, "< 1 s", True),
    ]
    rows = []
    for text, n, target, with_reference in cases:
        mission = Mission.from_arrays(np.ones((n, 1), bool), [[1]], [1.0])
        net = NetworkSpec.parse(text).build(mission, np.random.default_rng(0))
        graph = csr_array(
            (np.ones(len(net.indices), dtype=np.int8), net.indices, net.indptr), shape=(n, n)
        )
        seconds, (d, searches) = _median(repeat, lambda g=graph: _counted(graphs.diameter, g))
        rows.append((f"diameter {text} n={n}", f"{seconds:.2f} s", target))
        note = f"d_G {d}, {searches} searches"
        if with_reference:
            old, (d_old, old_searches) = _median(
                1, lambda g=graph: _counted(graphs.reference_diameter, g)
            )
            assert d_old == d
            note += f"; reference {old:.2f} s, {old_searches} searches"
        rows.append(("", note, ""))
    return rows


def edge_list_rows(edges: int, folder: Path) -> list[tuple[str, str, str]]:
    n = 100_000
    rng = np.random.default_rng(0)
    first, second = rng.integers(0, n, edges), rng.integers(0, n, edges)
    keep = first != second
    path = folder / "edges.txt"
    path.write_text(
        "".join(f"r{a} r{b}\n" for a, b in zip(first[keep], second[keep], strict=True)),
        encoding="utf-8",
    )
    mission_path = folder / "mission.json"
    generate_mission(n, 1, 3, 1, seed=0).to_json(mission_path)
    out = subprocess.run(
        [sys.executable, "-c", _EDGES_CHILD, str(path), str(mission_path)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    size = path.stat().st_size
    per_byte = float(out[1]) / size
    return [
        (f"edge list {size / 2**20:.0f} MB read+build", f"{float(out[0]):.1f} s", "-"),
        ("  peak memory per file byte", f"{per_byte:.1f} B", "< 20 B"),
    ]


def refusal_rows(folder: Path) -> list[tuple[str, str, str]]:
    huge = folder / "huge.txt"
    with open(huge, "wb") as handle:
        handle.truncate(2**40)
    wide = generate_mission(200, 25, 40_000, 1, seed=0)
    rows = []
    for case, work in (
        ("refuse a 1 TiB edge list", lambda: NetworkSpec.parse(f"file={huge}")),
        ("refuse GRAPE-S, 50 x 40000 services", lambda: heuristics.grape_s(wide)),
    ):
        start = time.perf_counter()
        try:
            work()
        except MissionError:
            pass
        else:
            raise AssertionError(f"{case}: not refused")
        rows.append((case, f"{time.perf_counter() - start:.3f} s", "< 1 s"))
    return rows


def time_limit_rows() -> list[tuple[str, str, str]]:
    mission = generate_mission(500, 60, 1, 1, load=3, seed=0)
    start = time.perf_counter()
    run = heuristics.rachna_dt(mission, time_limit=2.0)
    seconds = time.perf_counter() - start
    return [
        (
            f"rachna-dt 500x{mission.n_tasks} --time-limit 2",
            f"{seconds:.2f} s",
            f"< 3 s ({run.status.value})",
        )
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--edges", type=int, default=1_300_000)
    args = parser.parse_args()
    rows = diameter_rows(args.repeat)
    with tempfile.TemporaryDirectory() as name:
        rows += edge_list_rows(args.edges, Path(name))
        rows += refusal_rows(Path(name))
    rows += time_limit_rows()
    print(f"median of {args.repeat} where repeated")
    print(f"{'case':<42}{'median':>14}  target")
    for case, value, target in rows:
        print(f"{case:<42}{value:>14}  {target}")


if __name__ == "__main__":
    main()
