"""Start-up time of the command line: ``cfopt --help`` and ``cfopt validate MISSION``.

Run: ``python benchmarks/bench_startup.py [--repeats 15] [--imports]``.

Each command runs ``--repeats`` times in a fresh process (the interpreter's own start
included); the table shows the median wall-clock and CPU seconds beside the target (wall
clock < 0.25 s), and those of ``python -c pass`` for scale.  The
console script ``cfopt`` beside this interpreter is timed when it exists, else
``python -m cfopt``.  ``--imports`` also prints the slowest imports of each command
(``python -X importtime``, cumulative microseconds).  The machine's load (``os.getloadavg``)
is printed first: on a loaded machine every figure grows.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET = 0.25  # seconds


def command_prefix() -> list[str]:
    """The ``cfopt`` console script of this interpreter's environment, or ``-m cfopt``."""
    script = Path(sys.executable).with_name("cfopt")
    if script.exists():
        return [str(script)]
    found = shutil.which("cfopt")
    return [found] if found else [sys.executable, "-m", "cfopt"]


def median_seconds(command: list[str], repeats: int) -> tuple[float, float]:
    """Median wall-clock and CPU (user + system) seconds of ``repeats`` runs of ``command``
    (each must pass)."""
    walls, cpus = [], []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        walls.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def slowest_imports(arguments: list[str], top: int = 8) -> list[tuple[int, str]]:
    """The ``top`` imports of ``python -m cfopt ARGUMENTS`` by cumulative microseconds."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "cfopt", *arguments],
        check=True,
        capture_output=True,
        text=True,
    )
    rows = []
    for line in done.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cumulative, name = line.split("|")
            if cumulative.strip().isdigit():
                rows.append((int(cumulative), name.strip()))
    return sorted(rows, reverse=True)[:top]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--imports", action="store_true", help="show the slowest imports")
    args = parser.parse_args()

    import cfopt

    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    prefix = command_prefix()
    print(f"load average {load}; {Path(prefix[0]).name} ...; median of {args.repeats} runs\n")
    with tempfile.TemporaryDirectory() as folder:
        mission = Path(folder) / "mission.json"
        mission.write_text(cfopt.generate_mission(100, 10, 5, 2, seed=1).to_json())
        cases = [
            ("cfopt --help", ["--help"]),
            ("cfopt validate MISSION", ["validate", str(mission)]),
        ]
        wall, cpu = median_seconds([sys.executable, "-c", "pass"], args.repeats)
        print(f"{'command':<26}{'wall s':>9}{'cpu s':>8}{'target s':>10}{'verdict':>9}")
        print(f"{'python -c pass':<26}{wall:>9.3f}{cpu:>8.3f}")
        for label, arguments in cases:
            wall, cpu = median_seconds([*prefix, *arguments], args.repeats)
            verdict = "met" if wall < TARGET else "MISSED"
            print(f"{label:<26}{wall:>9.3f}{cpu:>8.3f}{TARGET:>10.2f}{verdict:>9}")
        if args.imports:
            for label, arguments in cases:
                print(f"\nslowest imports of {label} (cumulative us):")
                for micros, name in slowest_imports(arguments):
                    print(f"  {micros:>9} {name}")


if __name__ == "__main__":
    main()
