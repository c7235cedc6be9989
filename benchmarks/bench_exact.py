"""Wall-clock benchmark of the exact solver: a table of medians against the targets.

Scale targets (whole call: presolve, grouping, model build, HiGHS,
recovery and the utility re-evaluated from scratch):

- 100,000 robots, 50,000 tasks (50 %), every composition (5:1, 5:5, 10:1, 10:5), load
  1.0 and 1.25, ``generate_mission(100_000, 50, S, k, load=load, seed=0)``: under 10 s
  each, peak memory under 4 GB;
- 1000 robots, 50 % tasks, 10:5, load 1.25 (seed 0): under 0.2 s.

With ``--earlier``, the earlier targets as well (median over a cell's first ``repeat``
missions, ``GridCell.mission(0..)``):

- 1000 robots, 10 % and 50 % tasks, 10:5, load 1.0 and 1.25: under 0.5 s each;
- 10,000 robots, 50 % tasks, 10:5, load 1.25: under 5 s, peak memory under 1 GB;
- 500 robots, 10 % tasks, 10:5, load 1.25, mission 0: the aggregated formulation at
  least 500x faster than the assignment formulation, with the same optimum;
- ``time_limit=1`` on 2,000 robots, 10 % tasks, 10:5, assignment formulation: every
  call back within the limit plus ``cfopt.exact.TIME_LIMIT_SLACK``.

Run: ``python benchmarks/bench_exact.py [--repeat 3] [--earlier] [--only 100000]``.
Each case runs in a fresh subprocess (so ``peak MB`` is that process's own ru_maxrss,
interpreter, imports and the mission included) which first solves a tiny mission to
warm up imports; the scale cases solve the same seed-0 mission ``repeat`` times.  This
is a script, not a test: timings depend on the machine and on what else runs on it.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

_CHILD = """
import json, resource, sys, time
import cfopt
from cfopt.generate import GridCell

robots, percent, services, per_robot, load, formulation, repeat, same, limit = json.loads(
    sys.argv[1]
)
cfopt.solve_exact(cfopt.generate_mission(20, 10, 5, 2, seed=0), formulation=formulation)
cell = GridCell(robots, percent, services, per_robot, load)
rows = []
for index in range(repeat):
    if same == "seed0":
        mission = cfopt.generate_mission(robots, percent, services, per_robot, load=load, seed=0)
    else:
        mission = cell.mission(0 if same else index)
    start = time.perf_counter()
    result = cfopt.solve_exact(mission, formulation=formulation, time_limit=limit)
    seconds = time.perf_counter() - start
    rows.append([seconds, result.status.value, result.utility, result.bound, mission.n_tasks])
peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"rows": rows, "peak_mb": peak_mb}))
"""


def run_case(
    robots: int,
    percent: int,
    load: float,
    formulation: str,
    repeat: int,
    same: bool | str,
    time_limit: float | None = None,
    composition: tuple[int, int] = (10, 5),
) -> dict:
    """Run one case in a fresh interpreter; ``{"rows": [...], "peak_mb": ...}``.

    ``same``: ``"seed0"`` solves ``generate_mission(..., seed=0)`` every time, ``True``
    the cell's mission 0 every time, ``False`` the cell's missions 0..repeat-1.
    """
    services, per_robot = composition
    spec = json.dumps(
        [robots, percent, services, per_robot, load, formulation, repeat, same, time_limit]
    )
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, spec], check=True, capture_output=True, text=True
    )
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--earlier", action="store_true", help="the earlier targets as well")
    parser.add_argument(
        "--only", type=int, default=None, help="only the scale cases with this many robots"
    )
    args = parser.parse_args()
    repeat = args.repeat

    header = (
        f"{'case':<46} {'form.':<8} {'median s':>9} {'max s':>8} {'peak MB':>8} "
        f"{'target':>11} {'status':<9} {'utility':>12}"
    )
    print(header)
    print("-" * len(header), flush=True)

    def line(label: str, form: str, data: dict, target: str) -> float:
        times = [row[0] for row in data["rows"]]
        statuses = sorted({row[1] for row in data["rows"]})
        median = statistics.median(times)
        print(
            f"{label:<46} {form:<8} {median:>9.3f} {max(times):>8.3f} "
            f"{data['peak_mb']:>8.0f} {target:>11} {','.join(statuses):<9} "
            f"{data['rows'][0][2]:>12.10g}",
            flush=True,
        )
        return median

    verdicts = []
    compositions = ((5, 1), (5, 5), (10, 1), (10, 5))
    scale = [(100_000, c, load) for c in compositions for load in (1.0, 1.25)]
    scale.append((1000, (10, 5), 1.25))
    for robots, composition, load in scale:
        if args.only is not None and robots != args.only:
            continue
        data = run_case(robots, 50, load, "aggregated", repeat, "seed0", None, composition)
        m = data["rows"][0][4]
        label = f"n={robots} p=50% {composition[0]}:{composition[1]} load={load:g} (m={m})"
        limit, target = (10.0, "< 10 s,4GB") if robots == 100_000 else (0.2, "< 0.2 s")
        median = line(label, "aggreg.", data, target)
        verdicts.append((label, median < limit and data["peak_mb"] < 4096))

    if args.earlier:
        verdicts += earlier_targets(repeat, line)
    print()
    for label, ok in verdicts:
        print(f"{'met   ' if ok else 'MISSED'} {label}")


def earlier_targets(repeat: int, line) -> list[tuple[str, bool]]:
    """The earlier cases (see the module docstring); their verdicts."""
    verdicts = []
    for percent in (10, 50):
        for load in (1.0, 1.25):
            data = run_case(1000, percent, load, "aggregated", repeat, same=False)
            label = f"n=1000 p={percent}% 10:5 load={load:g} (m={data['rows'][0][4]})"
            median = line(label, "aggreg.", data, "< 0.5 s")
            verdicts.append((label, median < 0.5))

    data = run_case(10_000, 50, 1.25, "aggregated", repeat, same=False)
    label = f"n=10000 p=50% 10:5 load=1.25 (m={data['rows'][0][4]})"
    median = line(label, "aggreg.", data, "< 5 s,1GB")
    verdicts.append((label, median < 5 and data["peak_mb"] < 1024))

    label = "n=500 p=10% 10:5 load=1.25, mission 0"
    fast = run_case(500, 10, 1.25, "aggregated", repeat, same=True)
    slow = run_case(500, 10, 1.25, "assignment", repeat, same=True)
    fast_median = line(label, "aggreg.", fast, "")
    slow_median = line(label, "assign.", slow, "")
    ratio = slow_median / fast_median
    same_optimum = fast["rows"][0][2] == slow["rows"][0][2]
    print(
        f"speed-up aggregated vs assignment: {ratio:.0f}x (target >= 500x); "
        f"same optimum: {same_optimum} ({fast['rows'][0][2]:g} vs {slow['rows'][0][2]:g})"
    )
    verdicts.append(("speed-up >= 500x, same optimum", ratio >= 500 and same_optimum))

    from cfopt.exact import TIME_LIMIT_SLACK

    limit = 1.0
    data = run_case(2000, 10, 1.0, "assignment", repeat, same=False, time_limit=limit)
    label = f"n=2000 p=10% 10:5 load=1, limit {limit:g} s (m={data['rows'][0][4]})"
    line(label, "assign.", data, f"<= {limit + TIME_LIMIT_SLACK:g} s")
    longest = max(row[0] for row in data["rows"])
    verdicts.append((f"{label}: every call", longest <= limit + TIME_LIMIT_SLACK))
    return verdicts


if __name__ == "__main__":
    main()
