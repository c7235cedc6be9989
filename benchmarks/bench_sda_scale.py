"""Scale: SDA at 1000 and 10,000 robots, both schedules, loads 1 and 1.25.

Targets: ``cfopt.generate_mission(10000, 10, 10, 5, seed=0)`` and the same with
``load=1.25`` in under 60 s per schedule, peak RSS under 4 GB (issue "Scale"); under 3 s,
with a growth exponent close to GRAPE-S's (about 1.1), issue 27.  The table shows the
median wall clock and CPU seconds beside the 3 s target, and the exponent of the median
CPU seconds between the smallest and the largest size (``log(t2 / t1) / log(n2 / n1)``).

Every case runs in its own subprocess, which times the call ``--repeats`` times (the
median is shown; the mission is built once, outside the timing) and reports its peak RSS
(``resource.getrusage``: the whole process, interpreter and mission included).  A case past
``--timeout`` seconds is stopped and shown as such.  ``--literal`` also times the previous
engine (``heuristics.sda._core_literal``) for before/after figures; at 10,000 robots under
``max-wage`` it does not finish in 300 s.

    python benchmarks/bench_sda_scale.py [--sizes 1000 10000] [--repeats 3] [--literal]
        [--timeout 300]
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import time
from fractions import Fraction

SECONDS, MB_LIMIT, TARGET = 60.0, 4096.0, 3.0
LOADS = (1.0, 1.25)
SCHEDULES = ("max-wage", "uniform")


def child(n: int, load: float, schedule: str, engine: str, repeats: int) -> None:
    """Time one case in this process and print one JSON line."""
    import cfopt
    from heuristics.sda import _core_literal, sda

    mission = cfopt.generate_mission(n, 10, 10, 5, load=load, seed=0)
    times, cpu = [], []
    for _ in range(repeats):
        started, cpu_started = time.perf_counter(), time.process_time()
        if engine == "literal":
            out = _core_literal(mission, Fraction(1), schedule)
            rounds, iterations = out.rounds, out.iterations
        else:
            run = sda(mission, schedule=schedule)
            rounds, iterations = run.rounds, run.iterations
        times.append(time.perf_counter() - started)
        cpu.append(time.process_time() - cpu_started)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    line = {"median": statistics.median(times), "cpu": statistics.median(cpu), "mb": peak}
    line |= {"rounds": rounds, "iters": iterations}
    print(json.dumps(line))


def measure(n: int, load: float, schedule: str, engine: str, args: argparse.Namespace) -> dict:
    """Run one case in a subprocess; ``{"timeout": True}`` when it is stopped."""
    command = [sys.executable, __file__, "--child", str(n), str(load), schedule, engine]
    command += ["--repeats", str(args.repeats)]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, check=True, timeout=args.timeout
        )
    except subprocess.TimeoutExpired:
        return {"timeout": True}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=300.0)
    parser.add_argument("--literal", action="store_true", help="also time the previous engine")
    parser.add_argument("--child", nargs=4, metavar=("N", "LOAD", "SCHEDULE", "ENGINE"))
    args = parser.parse_args()
    if args.child:
        n, load, schedule, engine = args.child
        child(int(n), float(load), schedule, engine, args.repeats)
        return
    engines = ("prefix-rank", "literal") if args.literal else ("prefix-rank",)
    header = (
        f"{'robots':>7} {'load':>5} {'schedule':<9} {'engine':<12} {'median s':>9} "
        f"{'cpu s':>7} {'target':>7} {'peak MB':>8} {'rounds':>8} {'iters':>6} {'verdict':>7}"
    )
    print(f"median of {args.repeats} runs, one subprocess per case, 10:5, 10% tasks, seed 0")
    print(header)
    print("-" * len(header))
    cpu: dict[tuple[float, str, str], dict[int, float]] = {}
    for n in args.sizes:
        for load in LOADS:
            for schedule in SCHEDULES:
                for engine in engines:
                    r = measure(n, load, schedule, engine, args)
                    head = f"{n:>7} {load:>5} {schedule:<9} {engine:<12}"
                    if r.get("timeout"):
                        print(f"{head} {'> ' + str(int(args.timeout)):>9}")
                        continue
                    cpu.setdefault((load, schedule, engine), {})[n] = r["cpu"]
                    big = n >= 10000
                    ok = r["median"] < TARGET and r["mb"] < MB_LIMIT
                    verdict = ("met" if ok else "MISSED") if big else ""
                    target = f"< {TARGET:g}" if big else ""
                    print(
                        f"{head} {r['median']:>9.2f} {r['cpu']:>7.2f} {target:>7} {r['mb']:>8.0f} "
                        f"{r['rounds']:>8} {r['iters']:>6} {verdict:>7}",
                        flush=True,
                    )
    for (load, schedule, engine), by_size in cpu.items():
        if len(by_size) >= 2:
            (n1, t1), (n2, t2) = min(by_size.items()), max(by_size.items())
            exponent = math.log(t2 / t1) / math.log(n2 / n1)
            print(f"growth {load} {schedule} {engine}: n^{exponent:.2f} ({n1} -> {n2} robots)")


if __name__ == "__main__":
    main()
