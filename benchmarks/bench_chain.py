"""Wall-clock benchmark of Pair-GRAPE-S with chain exchanges against Pair-GRAPE-S.

Run: ``python benchmarks/bench_chain.py [--repeats 9] [--missions 25] [--quick]``.
Prints tables of medians (mission generation excluded from every timing):

* Pair-GRAPE-S and the chain variant at 1000 robots on every cell of the seed's grid
  (1, 10, 50 % tasks; 5:1, 5:5, 10:1, 10:5): median of ``--repeats`` whole calls
  (the two algorithms' calls interleaved) on mission 0 of each cell, and the ratio
  (target: chain within 2x of Pair-GRAPE-S);
* the chain variant on the seed's whole centralized grid (:func:`cfopt.paper_grid`,
  ``--missions`` per cell, 25 by default: 800 missions): optimal missions per cell
  (target: all, 100 %), median seconds per mission, and the wall time of the sweep;
  Pair-GRAPE-S's optimal count on the same missions for comparison;
* a stress test outside the seed's family, where phase 2 needs many long chains:
  *staircase* missions of 1000 robots (:func:`staircase`), both orders.

``--quick`` runs 2 repeats and 3 missions per cell.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from cfopt import GridCell, Mission, paper_grid
from heuristics.pair_grape_s import pair_grape_s
from heuristics.pair_grape_s_chain import pair_grape_s_chain

COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))


def paired_medians(mission, repeats: int) -> tuple[float, object, float, object]:
    """Median seconds of Pair-GRAPE-S and of the chain variant, calls interleaved (so that
    load on the machine falls on both alike), with the last run of each."""
    pair_times, chain_times, pair, chain = [], [], None, None
    for _ in range(repeats):
        started = time.perf_counter()
        pair = pair_grape_s(mission)
        middle = time.perf_counter()
        chain = pair_grape_s_chain(mission)
        pair_times.append(middle - started)
        chain_times.append(time.perf_counter() - middle)
    return statistics.median(pair_times), pair, statistics.median(chain_times), chain


def timing_table(repeats: int) -> None:
    print(f"1000 robots, mission 0 of each cell: median of {repeats} whole calls, seconds\n")
    print(
        f"{'cell':<26}{'pair-grape-s':>13}{'exch':>6}{'util%':>8}"
        f"{'chain':>9}{'exch':>6}{'util%':>8}{'ratio':>8}"
    )
    worst = 0.0
    for percent in (1, 10, 50):
        for s, k in COMPOSITIONS:
            m = GridCell(1000, percent, s, k).mission(0)
            tp, p, tc, c = paired_medians(m, repeats)
            worst = max(worst, tc / tp)
            print(
                f"{GridCell(1000, percent, s, k).label:<26}{tp:>13.3f}{p.exchanges:>6}"
                f"{p.assignment.percent_utility(m):>8.2f}{tc:>9.3f}{c.exchanges:>6}"
                f"{c.assignment.percent_utility(m):>8.2f}{tc / tp:>8.2f}"
            )
    print(f"worst ratio chain / pair-grape-s: {worst:.2f} (target <= 2)\n")


def grid_table(missions: int) -> None:
    cells = paper_grid()
    total = missions * len(cells)
    print(f"the seed's grid: {len(cells)} cells x {missions} missions = {total} missions\n")
    print(
        f"{'cell':<26}{'optimal':>9}{'min%':>8}{'median s':>10}"
        f"{'pair optimal':>14}{'pair min%':>11}"
    )
    chain_seconds = generate_seconds = 0.0
    optimal = pair_optimal = 0
    started = time.perf_counter()
    for cell in cells:
        times, pcts, ppcts = [], [], []
        for i in range(missions):
            t0 = time.perf_counter()
            m = cell.mission(i)
            t1 = time.perf_counter()
            run = pair_grape_s_chain(m)
            t2 = time.perf_counter()
            generate_seconds += t1 - t0
            chain_seconds += t2 - t1
            times.append(t2 - t1)
            pcts.append(run.assignment.percent_utility(m))
            ppcts.append(pair_grape_s(m).assignment.percent_utility(m))
        done = sum(p >= 100.0 for p in pcts)
        pdone = sum(p >= 100.0 for p in ppcts)
        optimal += done
        pair_optimal += pdone
        print(
            f"{cell.label:<26}{done:>5}/{missions:<3}{min(pcts):>8.2f}"
            f"{statistics.median(times):>10.4f}{pdone:>10}/{missions:<3}{min(ppcts):>11.2f}"
        )
    wall = time.perf_counter() - started
    print(
        f"\nchain variant optimal on {optimal} of {total} missions "
        f"({100.0 * optimal / total:.2f} %, target 100 %); Pair-GRAPE-S on {pair_optimal}"
    )
    print(
        f"chain runs {chain_seconds:.1f} s in total, mission generation {generate_seconds:.1f} s, "
        f"whole table (Pair-GRAPE-S runs included) {wall:.1f} s"
    )


def staircase(steps: int, blocks: int) -> Mission:
    """``blocks`` tasks, each needing services ``0..steps-1`` once; per task a block of
    robots ``{0}, {0, 1}, {1, 2}, ..., {steps-2, steps-1}``.  Capped GRAPE-S tends to shift
    the blocks one service down, leaving robot ``{0}`` out and the last service short:
    only a chain through the whole block fills it."""
    caps = np.zeros((steps * blocks, steps), dtype=bool)
    for b in range(blocks):
        caps[b * steps, 0] = True
        for i in range(1, steps):
            caps[b * steps + i, i - 1 : i + 1] = True
    return Mission.from_arrays(caps, np.ones((blocks, steps), dtype=np.int64), np.ones(blocks))


def longest_chain(run) -> int:
    traj = run.trajectory
    second = traj[traj[:, 0] > run.iterations - run.exchanges]
    return int(np.unique(second[:, 0], return_counts=True)[1].max()) - 1 if second.size else 0


def stress_table(repeats: int) -> None:
    print(f"\nstaircase missions, 1000 robots: median of {repeats} whole calls, seconds\n")
    print(
        f"{'mission':<26}{'pair-grape-s':>13}{'exch':>6}{'util%':>8}"
        f"{'chain':>9}{'exch':>6}{'longest':>9}{'util%':>8}{'ratio':>8}"
    )
    for steps in (10, 20, 50):
        m = staircase(steps, 1000 // steps)
        for order in ("index", "random"):
            pair_times, chain_times = [], []
            for _ in range(repeats):
                t0 = time.perf_counter()
                p = pair_grape_s(m, seed=0, order=order)
                t1 = time.perf_counter()
                c = pair_grape_s_chain(m, seed=0, order=order)
                pair_times.append(t1 - t0)
                chain_times.append(time.perf_counter() - t1)
            tp, tc = statistics.median(pair_times), statistics.median(chain_times)
            print(
                f"{f'steps={steps} {order}':<26}{tp:>13.3f}{p.exchanges:>6}"
                f"{p.assignment.percent_utility(m):>8.2f}{tc:>9.3f}{c.exchanges:>6}"
                f"{longest_chain(c):>9}{c.assignment.percent_utility(m):>8.2f}{tc / tp:>8.2f}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--missions", type=int, default=25)
    parser.add_argument("--quick", action="store_true", help="2 repeats, 3 missions per cell")
    args = parser.parse_args()
    repeats, missions = (2, 3) if args.quick else (args.repeats, args.missions)
    timing_table(repeats)
    grid_table(missions)
    stress_table(repeats)


if __name__ == "__main__":
    main()
