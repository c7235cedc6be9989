"""GRAPE-S-Select against the exact optimum, and its wall time against GRAPE-S.

Run: ``python benchmarks/bench_select.py [--missions 3] [--repeats 5] [--quick] [--compare]``.
Prints medians (and minima) of:

* percent of the ILP optimum on over-subscribed missions of the seed's family -- loads
  1.25, 1.5 and 2; 100, 500 and 1000 robots; compositions 5:1, 5:5, 10:1, 10:5; 10 and
  50 % tasks; ``--missions`` seeded missions per cell (targets: median >= 99 %, minimum
  >= 95 %); ``--compare`` adds GRAPE-S and SDA on the same missions;
* percent of the optimum on achievable missions (load 1, 100 and 500 robots, 1 % tasks
  too at 500) next to GRAPE-S's (target: not worse);
* wall time of whole calls at 1000 robots, every composition, 1/10/50 % tasks and loads
  1-2, against GRAPE-S on the same mission (target: within 2x).

``--quick`` keeps 100 and 500 robots and one mission per cell.
"""

from __future__ import annotations

import argparse
import statistics
import time

from cfopt import GridCell, solve_exact
from heuristics import grape_s, sda
from heuristics.grape_s_select import grape_s_select

COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
OVERSUBSCRIBED = (1.25, 1.5, 2.0)


def median_seconds(function, mission, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function(mission)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def percent(mission, assignment, optimum: float) -> float:
    return 100.0 if optimum <= 0 else 100.0 * assignment.utility(mission) / optimum


def quality(sizes, loads, percents, missions, algorithms) -> dict:
    """{(load, n, name): [percent of the optimum, ...]} over the grid."""
    table: dict = {}
    for load in loads:
        for n in sizes:
            for S, k in COMPOSITIONS:
                for p in percents(n):
                    cell = GridCell(n, p, S, k, load=load)
                    for i in range(missions):
                        m = cell.mission(i)
                        optimum = solve_exact(m, time_limit=120).utility
                        for name, function in algorithms:
                            pct = percent(m, function(m).assignment, optimum)
                            table.setdefault((load, n, name), []).append(pct)
    return table


def print_quality(title: str, table: dict, names) -> None:
    print(title)
    header = f"{'load':>5}{'robots':>8}{'missions':>10}"
    for name in names:
        header += f"{name + ' med':>20}{'min':>8}"
    print(header)
    keys = sorted({(load, n) for load, n, _ in table})
    for load, n in keys:
        row = f"{load:>5g}{n:>8}{len(table[load, n, names[0]]):>10}"
        for name in names:
            values = table[load, n, name]
            row += f"{statistics.median(values):>20.2f}{min(values):>8.2f}"
        print(row)
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--missions", type=int, default=3, help="seeded missions per cell")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per mission")
    parser.add_argument("--quick", action="store_true", help="100 and 500 robots, 1 mission")
    parser.add_argument("--compare", action="store_true", help="also GRAPE-S and SDA")
    args = parser.parse_args()
    missions = 1 if args.quick else args.missions
    sizes = (100, 500) if args.quick else (100, 500, 1000)

    algorithms = [("select", grape_s_select)]
    if args.compare:
        algorithms += [("grape-s", grape_s), ("sda", sda)]
    names = [name for name, _ in algorithms]
    started = time.perf_counter()
    table = quality(sizes, OVERSUBSCRIBED, lambda n: (10, 50), missions, algorithms)
    print_quality(
        f"percent of the ILP optimum, over-subscribed missions ({missions} per cell, "
        f"8 cells per row; {time.perf_counter() - started:.0f} s)",
        table,
        names,
    )

    table = quality(
        (100, 500),
        (1.0,),
        lambda n: (1, 10, 50) if n >= 500 else (10, 50),
        max(missions, 3),
        [("select", grape_s_select), ("grape-s", grape_s)],
    )
    print_quality(
        "percent of the ILP optimum, achievable missions (load 1)", table, ["select", "grape-s"]
    )
    for n in (100, 500):
        ours, theirs = table[1.0, n, "select"], table[1.0, n, "grape-s"]
        worse = sum(a < b for a, b in zip(ours, theirs, strict=True))
        better = sum(a > b for a, b in zip(ours, theirs, strict=True))
        mine, gs = statistics.mean(ours), statistics.mean(theirs)
        print(
            f"  n = {n}: mean {mine:.3f} % vs GRAPE-S {gs:.3f} %; below GRAPE-S on {worse}, "
            f"above on {better} of {len(ours)} missions"
        )
    print()

    print(f"wall time at 1000 robots, median of {args.repeats} whole calls (mission index 0)")
    print(f"{'cell':<30}{'grape-s s':>11}{'select s':>10}{'ratio':>7}{'rounds':>8}")
    worst = 0.0
    ratios = []
    for load in (1.0, *OVERSUBSCRIBED):
        for S, k in COMPOSITIONS:
            for p in (1, 10, 50):
                cell = GridCell(1000, p, S, k, load=load)
                m = cell.mission(0)
                tg = median_seconds(grape_s, m, args.repeats)
                ts = median_seconds(grape_s_select, m, args.repeats)
                rounds = grape_s_select(m).rounds
                ratios.append(ts / tg)
                worst = max(worst, ts / tg)
                print(f"{cell.label:<30}{tg:>11.4f}{ts:>10.4f}{ts / tg:>7.2f}{rounds:>8}")
    print(
        f"median ratio {statistics.median(ratios):.2f}, worst {worst:.2f} "
        f"(target: within 2x of GRAPE-S)"
    )


if __name__ == "__main__":
    main()
