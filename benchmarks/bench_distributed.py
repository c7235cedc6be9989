"""Wall-clock benchmark of the distributed simulator (issue targets in parentheses).

Run: ``python benchmarks/bench_distributed.py [--repeats 3] [--quick] [--kernels]
[--algorithm NAME ...]``.
Prints medians of ``--repeats`` runs, each in a fresh process (so that its peak resident
memory is its own), on the seed's network unless stated:

* GRAPE-S, 100 and 500 robots, 50 % tasks, 10:5, complete, latency uniform 1-10 ms, 1 %
  loss, broadcast: the seed's largest distributed cell (< 2 s and < 60 s);
* GRAPE-S, 1000 robots, 10 % tasks, 10:5, random geometric topology (< 120 s, < 2 GB);
* SDA, the seed's 500-robot, 10 %-task distributed cell (< 5 min);
* GRAPE-S-Select, 100 and 500 robots, 50 % tasks, 10:5, over-subscribed (load 1.25);
* with ``--kernels``: the same 500-robot GRAPE-S run driven by simpy's event loop instead
  of the heap (needs ``pip install simpy``), to compare the two kernels.

Columns: wall seconds, simulated seconds, clock ticks and message events per wall second,
utility, converged, megabytes transmitted, peak RSS.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

SEED_NETWORK = "complete latency=uniform:1ms:10ms loss=0.01"
#: (algorithm, robots, percent tasks, (service types, services per robot), load, network,
#: target)
CASES = [
    ("grape-s", 100, 50, (10, 5), 1.0, SEED_NETWORK, "< 2 s"),
    ("grape-s", 500, 50, (10, 5), 1.0, SEED_NETWORK, "< 60 s"),
    ("grape-s", 1000, 10, (10, 5), 1.0, "geometric radius=0.08 " + SEED_NETWORK[9:], "< 120 s"),
    ("pair-grape-s", 500, 50, (10, 5), 1.0, SEED_NETWORK, "-"),
    ("sda", 100, 10, (10, 5), 1.0, SEED_NETWORK, "-"),
    ("sda", 500, 10, (10, 5), 1.0, SEED_NETWORK, "< 5 min"),
    ("sda", 500, 10, (5, 1), 1.0, SEED_NETWORK, "< 5 min"),
    ("grape-s-select", 100, 50, (10, 5), 1.25, SEED_NETWORK, "-"),
    ("grape-s-select", 500, 50, (10, 5), 1.25, SEED_NETWORK, "-"),
]

_CHILD = """
import json, resource, sys, time
import cfopt
from heuristics.simulate import simulate
algorithm, n, p, s, k, load, network, kernel = json.loads(sys.argv[1])
m = cfopt.GridCell(n, p, s, k, load).mission(0)
if kernel == "simpy":
    sys.path.insert(0, "benchmarks")
    from bench_distributed import simpy_simulate as run_it
else:
    run_it = simulate
started = time.perf_counter()
run = run_it(m, algorithm, network, seed=0)
wall = time.perf_counter() - started
r = run.network
print(json.dumps({
    "wall": wall, "sim": r.simulated_seconds, "ticks": r.ticks,
    "utility": run.assignment.percent_utility(m), "converged": r.converged,
    "cut": r.cut, "mb": r.bytes / 1e6, "transmissions": r.transmissions,
    "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
}))
"""


def simpy_simulate(mission, algorithm, network, *, seed):
    """The simulator with simpy's environment as its event loop (for the comparison)."""
    import importlib

    import simpy

    from heuristics.simulate import simulate

    sim = importlib.import_module("heuristics.transport.simulator")

    def run(self) -> None:
        env = simpy.Environment()

        def robot(i: int):
            while True:
                t = self.clocks.tick_time(i, self.tick_index[i])
                if t > self.limit:
                    self.cut = True
                    return
                yield env.timeout(t - env.now)
                before = self.tick_index[i]
                self.now = int(env.now)
                self._on_tick(i, int(env.now))
                self.heap.clear()  # _on_tick schedules the next tick on the heap: simpy does
                if self.stopped[i] or self.tick_index[i] == before:
                    return

        for i in range(self.n):
            env.process(robot(i))
        env.run()
        self.end = self.limit if self.cut else self.now

    original = sim.Simulator.run
    sim.Simulator.run = run
    try:
        return simulate(mission, algorithm, network, seed=seed)
    finally:
        sim.Simulator.run = original


def measure(case, kernel: str, repeats: int) -> dict:
    algorithm, n, p, (s, k), load, network, _ = case
    args = json.dumps([algorithm, n, p, s, k, load, network, kernel])
    runs = []
    for _ in range(repeats):
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, args], capture_output=True, text=True, check=True
        )
        runs.append(json.loads(out.stdout))
    best = {key: statistics.median(r[key] for r in runs) for key in ("wall", "rss", "mb")}
    return {**runs[0], **best}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="only the 100- and 500-robot GRAPE-S")
    parser.add_argument("--kernels", action="store_true", help="also time the simpy kernel")
    parser.add_argument(
        "--algorithm",
        action="append",
        metavar="NAME",
        help="only the cases of this algorithm (repeatable)",
    )
    args = parser.parse_args()
    cases = CASES[:2] if args.quick else CASES
    if args.algorithm:
        cases = [case for case in cases if case[0] in args.algorithm]
    print(f"median of {args.repeats} runs, each in a fresh process; mission 0 of each cell\n")
    header = (
        f"{'case':<52}{'target':>9}{'wall s':>9}{'sim s':>8}{'ticks/s':>10}"
        f"{'util%':>8}{'conv':>6}{'MB':>10}{'RSS MB':>8}"
    )
    print(header)
    for case in cases:
        algorithm, n, p, (s, k), load, network, target = case
        r = measure(case, "heap", args.repeats)
        over = f" load={load:g}" if load != 1 else ""
        label = f"{algorithm} n={n} p={p}% {s}:{k}{over} {network.split()[0]}"
        print(
            f"{label:<52}{target:>9}{r['wall']:>9.2f}{r['sim']:>8.2f}"
            f"{r['ticks'] / r['wall']:>10.0f}{r['utility']:>8.2f}"
            f"{'yes' if r['converged'] else 'no':>6}"
            f"{r['mb']:>10.1f}{r['rss']:>8.0f}"
        )
    if args.kernels:
        print("\nkernels on GRAPE-S n=500 p=50% 10:5 (the seed's network)")
        for kernel in ("heap", "simpy"):
            r = measure(CASES[1], kernel, args.repeats)
            print(f"  {kernel:<6} {r['wall']:>8.2f} s  {r['ticks'] / r['wall']:>9.0f} ticks/s")


if __name__ == "__main__":
    main()
