"""Wall-clock benchmark of the auction baselines SDA and RACHNA_dt (median of 3).

    python benchmarks/bench_auctions.py [--repeat 3] [--profile]

Targets: 1000 robots, 10% tasks, 10:5 -- SDA < 30 s, RACHNA_dt < 60 s;
500 robots, 10% tasks, 5:5 -- both < 5 s.  The seed reports 20-30 min (SDA) and > 2 h
(RACHNA_dt) at 1000 robots with five services per robot, in C++.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time

import cfopt
from heuristics.rachna import rachna_dt
from heuristics.sda import sda

CASES = [
    # (robots, percent tasks, service types, services per robot, {algorithm: target s})
    (1000, 10, 10, 5, {"sda": 30.0, "rachna-dt": 60.0}),
    (500, 10, 5, 5, {"sda": 5.0, "rachna-dt": 5.0}),
]
ALGORITHMS = {"sda": sda, "rachna-dt": rachna_dt}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true", help="cProfile one run of each")
    args = parser.parse_args()
    header = (
        f"{'case':<22} {'algorithm':<10} {'median s':>9} {'target s':>9} {'%util':>7} "
        f"{'rounds':>7} {'iters':>6} {'messages':>10} {'bytes':>12}"
    )
    print(header)
    print("-" * len(header))
    for n, p, S, K, targets in CASES:
        case = f"{n} robots {p}% {S}:{K}"
        for name, target in targets.items():
            f = ALGORITHMS[name]
            times, run = [], None
            for i in range(args.repeat):
                m = cfopt.generate_mission(n, p, S, K, seed=i)
                t0 = time.perf_counter()
                run = f(m)
                times.append(time.perf_counter() - t0)
                pct = run.assignment.percent_utility(m)
            med = statistics.median(times)
            print(
                f"{case:<22} {name:<10} {med:>9.3f} {target:>9.1f} {pct:>7.2f} "
                f"{run.rounds:>7} {run.iterations:>6} {run.messages:>10} {run.bytes:>12}"
            )
            if args.profile:
                m = cfopt.generate_mission(n, p, S, K, seed=0)
                prof = cProfile.Profile()
                prof.runcall(f, m)
                pstats.Stats(prof).sort_stats("cumulative").print_stats(12)


if __name__ == "__main__":
    main()
