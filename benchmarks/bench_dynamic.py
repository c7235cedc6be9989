"""Wall-clock benchmark of mission events and the radio channel (issue targets in
parentheses).

Run: ``python benchmarks/bench_dynamic.py [--repeats 3] [--baseline /path/to/checkout]``.
Every run is a fresh process; medians of ``--repeats`` are printed beside the targets:

* GRAPE-S, 500 robots, 50 % tasks, 10:5 (the seed's largest cell), the seed's network with
  a shared 10 Mbit/s channel and one failure at 1 s (< 60 s wall);
* GRAPE-S, 100 and 500 robots, the same cell on the seed's network without a channel or
  events, in this tree and, with ``--baseline``, in another checkout (e.g. main before
  the change): this tree within 5 % of the baseline.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

SEED_NETWORK = "complete latency=uniform:1ms:10ms loss=0.01"
HERE = Path(__file__).resolve().parent.parent

_CHILD = """
import json, sys, time
import cfopt, heuristics
n, network, events = json.loads(sys.argv[1])
m = cfopt.GridCell(n, 50, 10, 5, 1.0).mission(0)
kwargs = {} if events is None else {"events": events}
started = time.perf_counter()
run = heuristics.simulate(m, "grape-s", network, seed=0, **kwargs)
wall = time.perf_counter() - started
r = run.network
print(json.dumps({"wall": wall, "sim": r.simulated_seconds, "converged": r.converged,
                  "utility": run.assignment.percent_utility(m)}))
"""


def _once(tree: Path, n: int, network: str, events: object) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps([n, network, events])],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        cwd=tree,
    )
    return json.loads(out.stdout)


def _median(tree: Path, n: int, network: str, events: object, repeats: int) -> dict[str, float]:
    runs = [_once(tree, n, network, events) for _ in range(repeats)]
    best = sorted(runs, key=lambda r: r["wall"])[len(runs) // 2]
    return dict(best, wall=statistics.median(r["wall"] for r in runs))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--baseline", type=Path, default=None, help="another checkout")
    parser.add_argument("--skip-channel", action="store_true")
    args = parser.parse_args()
    fail = {"events": [{"at": "1s", "kind": "fail", "robot": "r7"}]}
    print(f"{'case':<58} {'wall s':>8} {'sim s':>8} {'util %':>7}  target")
    if not args.skip_channel:
        network = SEED_NETWORK + " bitrate=10Mbit/s"
        r = _median(HERE, 500, network, fail, args.repeats)
        print(
            f"{'500 robots, shared 10 Mbit/s, one failure at 1 s':<58} {r['wall']:>8.2f} "
            f"{r['sim']:>8.3f} {r['utility']:>7.2f}  < 60 s"
        )
    for n in (100, 500):
        mine = _median(HERE, n, SEED_NETWORK, None, args.repeats)
        line = f"{n} robots, no channel, no events (this tree)"
        print(f"{line:<58} {mine['wall']:>8.2f} {mine['sim']:>8.3f} {mine['utility']:>7.2f}")
        if args.baseline is not None:
            base = _median(args.baseline, n, SEED_NETWORK, None, args.repeats)
            ratio = mine["wall"] / base["wall"]
            line = f"{n} robots, no channel, no events (baseline)"
            print(
                f"{line:<58} {base['wall']:>8.2f} {base['sim']:>8.3f} {base['utility']:>7.2f}"
                f"  this tree / baseline = {ratio:.3f} (<= 1.05)"
            )


if __name__ == "__main__":
    main()
