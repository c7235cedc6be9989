"""The bandwidth each distributed algorithm needs: the seed's "given sufficient
communication resources", made a figure.

Run: ``python benchmarks/bench_bandwidth.py [--robots 100 500] [--algorithm NAME ...]
[--encoding full compact] [--missions 1] [--steps 8] [--low 10kbit/s] [--high 1000Mbit/s]``.

For each algorithm with agents, number of robots and belief encoding, the smallest bit
rate of a shared radio channel (``bitrate=``, :mod:`heuristics.transport.channel`) at
which the seed's grid cell (50 % tasks, 10:5, on the seed's network: complete, latencies
uniform 1-10 ms, 1 % loss) still *succeeds* -- every one of ``--missions`` missions
converges within 5 simulated minutes at >= 95 % utility -- found by bisection on the
logarithm of the rate between ``--low`` and ``--high`` (``--steps`` halvings; success is
taken to be monotone in the rate, which the printed trail lets one check).  Prints one
row per case: the threshold (the smallest rate tried that succeeded), the largest that
failed, and the channel's utilisation and queueing at the threshold.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import cfopt
import heuristics
from heuristics.network import format_bitrate, parse_bitrate

SEED_NETWORK = "complete latency=uniform:1ms:10ms loss=0.01"
AGENTS = ("grape-s", "pair-grape-s", "pair-grape-s-chain", "sda", "grape-s-select")
LIMIT_S = 300.0  # five simulated minutes
GOAL = 95.0


def attempt(algorithm: str, missions: list[cfopt.Mission], rate: int, encoding: str) -> Any:
    """``(success, the last run)`` of every mission at ``rate`` bit/s."""
    network = f"{SEED_NETWORK} bitrate={format_bitrate(rate)} encoding={encoding}"
    run = None
    for m in missions:
        run = heuristics.simulate(m, algorithm, network, seed=0, time_limit=LIMIT_S)
        ok = run.network.converged and run.assignment.percent_utility(m) >= GOAL
        if not ok:
            return False, run
    return True, run


def threshold(
    algorithm: str, missions: list[cfopt.Mission], encoding: str, low: int, high: int, steps: int
) -> tuple[int | None, int | None, Any, list[str]]:
    """Bisection on log(rate): ``(smallest success, largest failure, run at the smallest
    success, trail)``."""
    trail: list[str] = []
    ok, run = attempt(algorithm, missions, high, encoding)
    trail.append(f"{format_bitrate(high)}:{'ok' if ok else 'fail'}")
    if not ok:
        return None, high, run, trail
    best, best_run, worst = high, run, None
    lo, hi = math.log(low), math.log(high)
    for _ in range(steps):
        mid = (lo + hi) / 2
        rate = max(1, round(math.exp(mid) / 1000) * 1000)  # whole kbit/s
        ok, run = attempt(algorithm, missions, rate, encoding)
        trail.append(f"{format_bitrate(rate)}:{'ok' if ok else 'fail'}")
        if ok:
            best, best_run, hi = rate, run, mid
        else:
            worst, lo = rate, mid
    return best, worst, best_run, trail


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[100, 500])
    parser.add_argument("--algorithm", nargs="+", default=list(AGENTS))
    parser.add_argument("--encoding", nargs="+", default=["full", "compact"])
    parser.add_argument("--missions", type=int, default=1)
    parser.add_argument("--steps", type=int, default=8)
    parser.add_argument("--low", default="10kbit/s")
    parser.add_argument("--high", default="1000Mbit/s")
    args = parser.parse_args()
    low, high = parse_bitrate(args.low), parse_bitrate(args.high)
    print(
        f"{'algorithm':<20} {'n':>4} {'encoding':<8} {'needs':>12} {'fails at':>12} "
        f"{'util':>6} {'queue ms':>9} {'wall s':>7}  trail"
    )
    for n in args.robots:
        cell = cfopt.GridCell(n, 50, 10, 5, 1.0)
        missions = [cell.mission(k) for k in range(args.missions)]
        for algorithm in args.algorithm:
            for encoding in args.encoding:
                started = time.perf_counter()
                best, worst, run, trail = threshold(
                    algorithm, missions, encoding, low, high, args.steps
                )
                wall = time.perf_counter() - started
                ch = run.network.channel
                needs = "-" if best is None else format_bitrate(best)
                fails = "-" if worst is None else format_bitrate(worst)
                print(
                    f"{algorithm:<20} {n:>4} {encoding:<8} {needs:>12} {fails:>12} "
                    f"{ch.utilisation:>6.1%} {ch.queueing_mean_seconds * 1e3:>9.3f} "
                    f"{wall:>7.1f}  {' '.join(trail)}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
