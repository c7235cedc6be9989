"""Scale: RACHNA_dt on over-subscribed missions (load 1.25) and the 100,000-robot mission.

Targets (:data:`TARGETS`, printed beside each median): ``cfopt.generate_mission(1000, 50,
10, 5, load=1.25)`` under 30 s and ``cfopt.generate_mission(10000, 10, 10, 5, load=1.25)``
under 60 s (the default, simultaneous schedule, one core);
``cfopt.generate_mission(100000, 10, 10, 5, seed=0)`` (load 1) under 30 s with a peak RSS
under 2 GB.  A run needing more than ``--max-rounds`` rounds (default
``heuristics.rachna.MAX_ROUNDS``, the default of ``rachna_dt``) is refused, and the
refusal is its result.

Every case runs in its own subprocess, which times ``rachna_dt`` ``--repeats`` times (the
median is shown) and reports its peak RSS (``resource.getrusage``: the whole process).  A
case past ``--timeout`` seconds is stopped and shown with the rounds it had reached.
``--literal`` runs the simultaneous schedule on the literal price book
(``_core(..., fast=False)``) for before/after figures.

    python benchmarks/bench_rachna_scale.py [--schedules simultaneous sequential]
        [--repeats 3] [--timeout 300] [--literal] [--cases 0 1 2 3 4] [--max-rounds N]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import statistics
import subprocess
import sys
import time
from fractions import Fraction

#: (robots, percent tasks, service types, services per robot, load), all with seed 0.
CASES = (
    (1000, 50, 10, 5, 1.25),
    (1000, 50, 5, 1, 1.25),
    (1000, 10, 10, 5, 1.25),
    (10000, 10, 10, 5, 1.25),
    (100000, 10, 10, 5, 1.0),
)
#: Seconds each case should stay under (simultaneous schedule), ``None``: no target.
TARGETS = (30.0, None, None, 60.0, 30.0)


def peak_mb() -> float:
    """Peak RSS of this process in MiB (``ru_maxrss`` is in KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_case(args: argparse.Namespace) -> None:
    """Run one case in this process and print one JSON line."""
    import cfopt
    from heuristics import rachna

    reached = {"rounds": 0}
    direct = rachna._Outcome.direct

    def counting(self, messages, nbytes):  # every bidding round sends bids: a progress mark
        reached["rounds"] = self.rounds
        direct(self, messages, nbytes)

    rachna._Outcome.direct = counting
    started = time.perf_counter()
    times: list[float] = []

    def stop(signum, frame):
        report = {"status": "timeout", "seconds": time.perf_counter() - started}
        print(json.dumps(report | {"rounds": reached["rounds"], "peak_mb": peak_mb()}))
        sys.stdout.flush()
        os._exit(0)

    signal.signal(signal.SIGALRM, stop)
    signal.alarm(args.timeout)
    n, percent, services, per_robot, load = CASES[args.case]
    mission = cfopt.generate_mission(n, percent, services, per_robot, load=load, seed=0)
    max_rounds = rachna.MAX_ROUNDS if args.max_rounds is None else args.max_rounds
    result: dict[str, object] = {}
    for _ in range(args.repeats):
        t = time.perf_counter()
        try:
            if args.literal:
                out = rachna._core(
                    mission, Fraction(1, n), max_rounds, schedule=args.schedule, fast=False
                )
                result = {"rounds": out.rounds, "rows": out.moves.count}
            else:
                run = rachna.rachna_dt(mission, schedule=args.schedule, max_rounds=max_rounds)
                result = {"rounds": run.rounds, "rows": len(run.trajectory)}
        except cfopt.MissionError as error:
            result = {"error": str(error)[:60]}
        times.append(time.perf_counter() - t)
    report = {"status": "ok", "seconds": statistics.median(times), "peak_mb": peak_mb()}
    print(json.dumps(report | result), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--schedules", nargs="+", default=["simultaneous", "sequential"])
    parser.add_argument("--cases", nargs="+", type=int, default=list(range(len(CASES))))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--timeout", type=int, default=300)
    parser.add_argument("--literal", action="store_true")
    parser.add_argument("--max-rounds", type=int, default=None)
    parser.add_argument("--case", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--schedule", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case is not None:
        run_case(args)
        return
    header = f"{'case':<32} {'schedule':<13} {'target s':>9} {'median s':>9} {'peak MB':>8}"
    print(header + "  result")
    for case in args.cases:
        for schedule in args.schedules:
            command = [sys.executable, __file__, "--case", str(case), "--schedule", schedule]
            command += ["--repeats", str(args.repeats), "--timeout", str(args.timeout)]
            command += ["--literal"] if args.literal else []
            if args.max_rounds is not None:
                command += ["--max-rounds", str(args.max_rounds)]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            lines = done.stdout.strip().splitlines()
            report = json.loads(lines[-1]) if lines else {"status": done.stderr[-200:]}
            label = "generate_mission({}, {}, {}, {}, load={})".format(*CASES[case])
            seconds = report.get("seconds", float("nan"))
            mb = report.get("peak_mb", float("nan"))
            rest = {k: v for k, v in report.items() if k not in ("seconds", "peak_mb")}
            target = TARGETS[case] if schedule == "simultaneous" else None
            goal = "-" if target is None else f"< {target:g}"
            print(
                f"{label:<32} {schedule:<13} {goal:>9} {seconds:>9.2f} {mb:>8.0f}  {rest}",
                flush=True,
            )


if __name__ == "__main__":
    main()
