"""Wall-clock benchmark of GRAPE-S and Pair-GRAPE-S.

Run: ``python benchmarks/bench_grape_s.py [--repeats 5] [--big-repeats 3] [--quick]
[--no-100k] [--eager] [--profile]``.
Prints medians of ``--repeats`` whole calls (mission generation excluded):

* GRAPE-S and Pair-GRAPE-S at 1000 robots, every composition and percent-task level of
  the seed's grid (target: < 1 s each; the seed's C++ simulator: median 5 min 22 s at
  1000 robots, 50 %, 10:5);
* GRAPE-S and Pair-GRAPE-S on ``cfopt.generate_mission(n, 10, 10, 5, seed=0)`` at
  n = 10,000 and n = 100,000, index and random order (targets at 100,000: < 60 s in
  index order, GRAPE-S < 20 s in random order; ``--big-repeats`` calls, ``--no-100k``
  skips them; ``--eager`` also times GRAPE-S drawing a whole permutation per round in
  random order, :func:`heuristics.grape_s.grape_s_eager`, the engine before the lazy
  order);
* fast vs reference engine at 200 robots, 10:5, 50 % (target: >= 100x).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time

from cfopt import GridCell, generate_mission
from heuristics import grape_s, pair_grape_s
from heuristics._reference import grape_s_reference
from heuristics.grape_s import grape_s_eager


def median_seconds(function, mission, repeats: int, **kwargs) -> tuple[float, object]:
    times, run = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        run = function(mission, **kwargs)
        times.append(time.perf_counter() - started)
    return statistics.median(times), run


#: (robots, order) -> GRAPE-S target, seconds.
GRAPE_S_TARGETS = {(100_000, "index"): 60.0, (100_000, "random"): 20.0}


def scale(args: argparse.Namespace) -> None:
    """Medians at 10,000 and 100,000 robots, index and random order."""
    cases = [(10_000, "index", args.repeats), (10_000, "random", args.repeats)]
    if not args.no_100k:
        cases += [(100_000, "index", args.big_repeats), (100_000, "random", args.big_repeats)]
    print(
        f"{'robots':>8}{'order':>8}{'grape-s':>10}{'target':>8}{'iters':>8}"
        f"{'pair-grape-s':>14}{'iters':>8}{'eager':>9}"
    )
    for n, order, repeats in cases:
        m = generate_mission(n, 10, 10, 5, seed=0)
        if args.profile and n == 10_000:
            profiler = cProfile.Profile()
            profiler.enable()
            grape_s(m, order=order, seed=0)
            profiler.disable()
            pstats.Stats(profiler).sort_stats("tottime").print_stats(12)
        tg, g = median_seconds(grape_s, m, repeats, order=order, seed=0)
        tp, p = median_seconds(pair_grape_s, m, repeats, order=order, seed=0)
        target = GRAPE_S_TARGETS.get((n, order))
        shown = f"< {target:g}" if target else ""
        eager = ""
        if args.eager and order == "random":
            eager = f"{median_seconds(grape_s_eager, m, repeats, order=order, seed=0)[0]:.3f}"
        print(
            f"{n:>8}{order:>8}{tg:>10.3f}{shown:>8}{g.iterations:>8}"
            f"{tp:>14.3f}{p.iterations:>8}{eager:>9}",
            flush=True,
        )
    print("generate_mission(n, 10, 10, 5, seed=0); seconds\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--big-repeats", type=int, default=3, help="calls at 100,000 robots")
    parser.add_argument("--quick", action="store_true", help="skip 10,000 and 100,000 robots")
    parser.add_argument("--no-100k", action="store_true", help="skip 100,000 robots")
    parser.add_argument("--eager", action="store_true", help="also time the eager random order")
    parser.add_argument("--profile", action="store_true", help="cProfile the 10,000-robot runs")
    args = parser.parse_args()
    r = args.repeats

    print(f"median of {r} whole calls, seconds; mission index 0 of each cell\n")
    print(
        f"{'cell':<28}{'grape-s':>10}{'iters':>7}{'util%':>8}"
        f"{'pair-grape-s':>14}{'iters':>7}{'exch':>6}{'util%':>8}"
    )
    worst = 0.0
    for percent in (1, 10, 50):
        for s, k in ((5, 1), (5, 5), (10, 1), (10, 5)):
            cell = GridCell(1000, percent, s, k)
            m = cell.mission(0)
            tg, g = median_seconds(grape_s, m, r)
            tp, p = median_seconds(pair_grape_s, m, r)
            worst = max(worst, tg, tp)
            print(
                f"{cell.label:<28}{tg:>10.3f}{g.iterations:>7}"
                f"{g.assignment.percent_utility(m):>8.2f}{tp:>14.3f}{p.iterations:>7}"
                f"{p.exchanges:>6}{p.assignment.percent_utility(m):>8.2f}"
            )
    print(f"worst 1000-robot median: {worst:.3f} s (target < 1 s)\n")

    if not args.quick:
        scale(args)

    m = GridCell(200, 50, 10, 5).mission(0)
    tf, f = median_seconds(grape_s, m, r)
    tr, ref = median_seconds(grape_s_reference, m, max(1, min(r, 3)))
    assert ref.trajectory.tolist() == f.trajectory.tolist()
    print(
        f"n=200 p=50% 10:5: fast {tf * 1000:.2f} ms, reference {tr:.2f} s "
        f"(median of {max(1, min(r, 3))}), speed-up {tr / tf:.0f}x (target >= 100x)"
    )


if __name__ == "__main__":
    main()
