"""Scale: the pairwise-stability checker and RACHNA_dt up to 100,000 robots.

Targets: ``proofs.pairwise_violations`` on a 100,000-robot partition in
under 30 s per mode with a peak RSS under 4 GB; ``heuristics.rachna_dt`` on
``cfopt.generate_mission(100000, 10, 10, 5, seed=0)`` (load 1) in under 30 s with a peak
RSS under 2 GB.

Missions are ``cfopt.generate_mission(n, 10, 10, 5, seed=SEED)``.  The checked partition
is GRAPE-S's up to 10,000 robots; GRAPE-S takes minutes at 100,000, so there the
partition is GRAPE-S-Select's (also Nash stable; ``--partition`` forces one producer).
Every case runs in its own subprocess, which times the call ``--repeats`` times (the
median is shown) and reports its peak RSS (``resource.getrusage``, the whole process:
interpreter, mission, partition and the call).  A case past ``--timeout`` seconds is
stopped and shown as such, with the peak RSS reached so far.

    python benchmarks/bench_scale.py [--sizes 1000 10000 100000] [--repeats 3]
        [--reference] [--rachna-sizes 100000] [--timeout 600]

``--reference`` also times the original O(C^2) checker (sizes up to
``--reference-max``, default 10,000), for before/after figures.
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
import tempfile
import time
from pathlib import Path

import numpy as np

MB = 1024.0  # ru_maxrss is in KiB on Linux
CHECK_SECONDS, CHECK_MB = 30.0, 4096.0
RACHNA_SECONDS, RACHNA_MB = 30.0, 2048.0


def mission(n: int, seed: int):
    import cfopt

    return cfopt.generate_mission(n, 10, 10, 5, seed=seed)


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / MB


# ------------------------------------------------------------------- the child side
def run_case(args: argparse.Namespace) -> None:
    """Run one case in this process and print one JSON line."""
    started = time.perf_counter()
    times: list[float] = []

    def stop(signum, frame):
        report = {"status": "timeout", "seconds": time.perf_counter() - started}
        print(json.dumps(report | {"runs": len(times), "peak_mb": peak_mb()}), flush=True)
        os._exit(0)

    signal.signal(signal.SIGALRM, stop)
    signal.alarm(args.timeout)
    m = mission(args.n, args.seed)
    base = peak_mb()
    extra: dict[str, object] = {}
    if args.case == "check":
        import cfopt
        import proofs
        from proofs import stability

        data = np.load(args.partition_file)
        a = cfopt.Assignment(task=data["task"], service=data["service"])
        check = (
            proofs.pairwise_violations
            if args.impl == "fast"
            else stability._pairwise_violations_reference
        )
        for _ in range(args.repeats):
            start = time.perf_counter()
            found = check(m, a, mode=args.mode)
            times.append(time.perf_counter() - start)
        extra = {"violations": len(found), "joint": sum(v.kind == "joint" for v in found)}
    else:
        import heuristics

        for _ in range(args.repeats):
            start = time.perf_counter()
            run = heuristics.rachna_dt(m)
            times.append(time.perf_counter() - start)
        extra = {"utility": round(run.assignment.percent_utility(m), 2), "rounds": run.rounds}
    signal.alarm(0)
    result = {"status": "ok", "seconds": statistics.median(times), "runs": len(times)}
    print(json.dumps(result | extra | {"base_mb": base, "peak_mb": peak_mb()}), flush=True)


# ------------------------------------------------------------------ the parent side
def make_partition(n: int, seed: int, producer: str, folder: str) -> tuple[str, str, float]:
    """Run the producer once, save its partition; returns (file, producer, seconds)."""
    import heuristics
    import proofs

    if producer == "auto":
        producer = "grape_s" if n <= 10_000 else "grape_s_select"
    m = mission(n, seed)
    start = time.perf_counter()
    a = getattr(heuristics, producer)(m).assignment
    seconds = time.perf_counter() - start
    if not proofs.is_nash_stable(m, a):
        producer += " (not Nash stable)"
    path = str(Path(folder) / f"partition_{n}.npz")
    np.savez(path, task=a.task, service=a.service)
    return path, producer, seconds


def spawn(args: argparse.Namespace, *case: str) -> dict:
    """Run one case in a fresh interpreter; its JSON line (or the failure)."""
    command = [sys.executable, __file__, "--timeout", str(args.timeout)]
    command += ["--repeats", str(args.repeats), "--seed", str(args.seed), *case]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        return {"status": f"failed ({done.returncode}): {done.stderr.strip()[-200:]}"}
    return json.loads(lines[-1])


def verdict(result: dict, seconds: float, mb: float) -> str:
    if result["status"] != "ok":
        return "TARGET MISSED"
    met = result["seconds"] < seconds and result["peak_mb"] < mb
    return "met" if met else "TARGET MISSED"


def row(name: str, n: int, detail: str, result: dict, target: tuple[float, float]) -> str:
    if result["status"] not in ("ok", "timeout"):
        return f"{name:<26} {n:>7} {detail:<34} {result['status']}"
    if result["status"] == "ok":
        secs = f"{result['seconds']:.2f}"
    else:
        secs = f">{result['seconds']:.0f} (stopped)"
    found = result.get("violations", result.get("utility", ""))
    return (
        f"{name:<26} {n:>7} {detail:<34} {secs:>14} {result['runs']:>4} "
        f"{result['peak_mb']:>8.0f} {found!s:>10}  {verdict(result, *target)}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[1000, 10_000, 100_000])
    parser.add_argument("--rachna-sizes", type=int, nargs="*", default=[100_000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=int, default=600, help="seconds per case")
    parser.add_argument(
        "--partition", default="auto", choices=["auto", "grape_s", "grape_s_select"]
    )
    parser.add_argument("--reference", action="store_true")
    parser.add_argument("--reference-max", type=int, default=10_000)
    # the child side (internal)
    parser.add_argument("--case", choices=["check", "rachna"], help=argparse.SUPPRESS)
    parser.add_argument("--n", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--mode", help=argparse.SUPPRESS)
    parser.add_argument("--impl", default="fast", help=argparse.SUPPRESS)
    parser.add_argument("--partition-file", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        run_case(args)
        return
    lines = []
    with tempfile.TemporaryDirectory() as folder:
        for n in args.sizes:
            path, producer, made = make_partition(n, args.seed, args.partition, folder)
            impls = ["fast"] + (["reference"] if args.reference and n <= args.reference_max else [])
            for impl in impls:
                for mode in ("strict", "pareto"):
                    case = ["--case", "check", "--n", str(n), "--mode", mode, "--impl", impl]
                    result = spawn(args, *case, "--partition-file", path)
                    detail = f"{mode}, {producer} ({made:.0f} s)"
                    name = "pairwise_violations" + ("" if impl == "fast" else " (ref)")
                    lines.append(row(name, n, detail, result, (CHECK_SECONDS, CHECK_MB)))
    for n in args.rachna_sizes:
        result = spawn(args, "--case", "rachna", "--n", str(n))
        target = (RACHNA_SECONDS, RACHNA_MB)
        lines.append(row("rachna_dt", n, "simultaneous, load 1", result, target))
    print(f"missions: cfopt.generate_mission(n, 10, 10, 5, seed={args.seed})")
    print(
        f"median of {args.repeats} runs per case, one subprocess per case; peak RSS of that "
        f"process; targets: checker < {CHECK_SECONDS:.0f} s and < {CHECK_MB / 1024:.0f} GB, "
        f"RACHNA_dt < {RACHNA_SECONDS:.0f} s and < {RACHNA_MB / 1024:.0f} GB"
    )
    head = (
        f"{'case':<26} {'robots':>7} {'mode / partition or setting':<34} {'median s':>14} "
        f"{'runs':>4} {'peak MB':>8} {'found':>10}  target"
    )
    print(head)
    print("-" * len(head))
    print("\n".join(lines))
    print("found: violations listed (checker) or % utility (RACHNA_dt)")


if __name__ == "__main__":
    main()
