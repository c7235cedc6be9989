"""Loading and validating a large mission file, and scoring an assignment on it.

Target: a 100,000-robot, 50,000-task mission file loads and validates in under
5 s with peak memory under 1 GB; ``Assignment.utility`` on it takes under 50 ms.

Run: ``python benchmarks/bench_io.py [--repeat 5]``.  Each load runs in a fresh
subprocess so that its peak resident memory (ru_maxrss) is its own.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cfopt import generate_with_witness

_CHILD = """
import resource, sys, time
from cfopt import Mission
start = time.perf_counter()
mission = Mission.from_json(sys.argv[1])
seconds = time.perf_counter() - start
peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(seconds, peak_mb, mission.n_robots, mission.n_tasks)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--robots", type=int, default=100_000)
    args = parser.parse_args()

    mission, witness = generate_with_witness(args.robots, 50, 10, 5, seed=0)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mission.json"
        start = time.perf_counter()
        mission.to_json(path)
        write_s = time.perf_counter() - start
        size_mb = path.stat().st_size / 2**20
        loads, peaks = [], []
        for _ in range(args.repeat):
            out = subprocess.run(
                [sys.executable, "-c", _CHILD, str(path)],
                check=True,
                capture_output=True,
                text=True,
            ).stdout.split()
            loads.append(float(out[0]))
            peaks.append(float(out[1]))
    utility_s = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        witness.utility(mission)
        utility_s.append(time.perf_counter() - start)

    n, m = mission.n_robots, mission.n_tasks
    rows = [
        ("to_json (write)", f"{write_s:.3f} s", "-"),
        ("from_json (load+validate)", f"{statistics.median(loads):.3f} s", "< 5 s"),
        ("from_json peak RSS", f"{statistics.median(peaks):.0f} MB", "< 1024 MB"),
        ("Assignment.utility", f"{1000 * statistics.median(utility_s):.1f} ms", "< 50 ms"),
    ]
    print(
        f"mission: {n} robots, {m} tasks, 10 services, file {size_mb:.1f} MB; "
        f"median of {args.repeat}"
    )
    print(f"{'case':<28}{'median':>12}  target")
    for case, value, target in rows:
        print(f"{case:<28}{value:>12}  {target}")


if __name__ == "__main__":
    main()
