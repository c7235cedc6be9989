"""Wall-clock medians of the stability checkers on the seed's largest 10:5 cell.

Targets: on a 1000-robot, 500-task, 10:5 mission, ``nash_violations`` under
50 ms and ``pairwise_violations`` under 2 s.

    python benchmarks/bench_stability.py [--repeats 5] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import cfopt
import proofs
from proofs._dynamics import best_response

TARGETS = {"nash": 0.050, "pairwise strict": 2.0, "pairwise pareto": 2.0}


def random_assignment(mission: cfopt.Mission, rng: np.random.Generator) -> cfopt.Assignment:
    """Each robot on a uniformly drawn slot it can perform, or unassigned (1 in 5)."""
    task = np.full(mission.n_robots, -1)
    service = np.full(mission.n_robots, -1)
    slots = np.argwhere(mission.requirements > 0)
    for i in range(mission.n_robots):
        mine = slots[mission.capabilities[i, slots[:, 1]]]
        if len(mine) and rng.random() >= 0.2:
            task[i], service[i] = mine[rng.integers(len(mine))]
    return cfopt.Assignment(task=task, service=service)


def median_seconds(call, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    rows = []
    for seed in args.seeds:
        mission, witness = cfopt.generate_with_witness(1000, 50, 10, 5, seed=seed)
        rng = np.random.default_rng(seed)
        stable = best_response(mission, order=rng.permutation(mission.n_robots))
        capped = best_response(mission, capped=True, order=rng.permutation(mission.n_robots))
        cases = {
            "witness": (witness, False),
            "empty": (cfopt.Assignment.empty(mission), False),
            "random": (random_assignment(mission, rng), False),
            "best-response": (stable, False),
            "best-response capped": (capped, True),
        }
        for name, (a, cap) in cases.items():
            row = {"seed": seed, "assignment": name, "capped": cap}
            for label, check, kw in (
                ("nash", proofs.nash_violations, {}),
                ("pairwise strict", proofs.pairwise_violations, {"mode": "strict"}),
                ("pairwise pareto", proofs.pairwise_violations, {"mode": "pareto"}),
            ):
                row[label] = median_seconds(
                    lambda c=check, k=kw, a=a, cap=cap, m=mission: c(m, a, capped=cap, **k),
                    args.repeats,
                )
            row["#nash"] = len(proofs.nash_violations(mission, a, capped=cap))
            row["#pareto"] = len(proofs.pairwise_violations(mission, a, mode="pareto", capped=cap))
            row["util%"] = a.percent_utility(mission)
            rows.append(row)
    print("mission: cfopt.generate_mission(1000, 50, 10, 5, seed=X): 1000 robots, 500 tasks")
    print(f"medians of {args.repeats} runs; targets: nash < 50 ms, pairwise < 2000 ms")
    head = (
        f"{'seed':>4} {'assignment':<21} {'nash ms':>8} {'strict ms':>10} {'pareto ms':>10} "
        f"{'#nash':>6} {'#pareto':>8} {'util%':>7}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['seed']:>4} {r['assignment']:<21} {1000 * r['nash']:>8.1f} "
            f"{1000 * r['pairwise strict']:>10.1f} {1000 * r['pairwise pareto']:>10.1f} "
            f"{r['#nash']:>6} {r['#pareto']:>8} {r['util%']:>7.2f}"
        )
    worst = {k: max(r[k] for r in rows) for k in TARGETS}
    verdict = all(worst[k] < TARGETS[k] for k in TARGETS)
    print(
        "worst: "
        + ", ".join(f"{k} {1000 * v:.1f} ms" for k, v in worst.items())
        + f" -> {'all targets met' if verdict else 'TARGET MISSED'}"
    )


if __name__ == "__main__":
    main()
