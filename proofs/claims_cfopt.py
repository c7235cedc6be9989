"""cfopt's own claims about its own algorithms (C1, C2, O1-O3), in the audit's format.

These are not the seed paper's statements: they are what cfopt claims of the algorithms
it adds, checked with :mod:`proofs.claimkit`'s machinery the way the seed's claims are
(:mod:`proofs.claims_seed`: seeded grid missions, the seed-family sweep, a hypothesis
search with shrinking and, when that finds nothing, an exhaustive search).

Pair-GRAPE-S with chain exchanges (``pair-grape-s-chain``, :func:`chain_claims`)

``C1``
    The chain variant completes every task on every achievable mission (its docstring
    proves it with the augmenting-path theorem); checked as the seed's P1 is, plus the
    small-scope search restricted to the achievable missions of
    :func:`proofs.claimkit.small_scope`.
``C2``
    Its partition is Nash stable under capped moves (the property the seed's Lemma 1
    asserts of Pair-GRAPE-S).

GRAPE-S-Select (``grape-s-select``, :func:`select_claims`)

``O1``
    The run ends Nash stable under its own (completion) reward, checked by the
    independent :mod:`proofs.select_stability` on grid missions of every load, a
    hypothesis search with shrinking, the seed-family sweep at load 1 and, when the
    search finds nothing, a sweep of small over-subscribed missions of the seed's family.
``O2``
    On over-subscribed missions (loads 1.25-2) every run earns at least 95 % of the exact
    (ILP) optimum: a per-mission floor.  It fails on missions with few tasks, through the
    reward's price of stability and greedy selection (the Limits of
    :mod:`heuristics.grape_s_select`); the sweep and the search find a 5-robot one.
``O3``
    On the seed's over-subscribed grid (100 robots) the median run earns at least 99 % of
    the optimum at every load: the typical case.  A statistical claim: per load the
    median with its confidence interval and sample size; holds, fails, or inconclusive at
    this budget (8 missions per load leave the interval too wide at load 2), never a
    counterexample.

The claims run the algorithms through the public registry (``heuristics.get_algorithm``);
:meth:`proofs.claimkit.Claim.with_algorithm` substitutes another implementation.
``import proofs.claims_cfopt`` imports neither heuristics nor hypothesis.

Examples
--------
>>> [c.id for c in cfopt_claims()]
['C1', 'C2', 'O1', 'O2', 'O3']
>>> chain_claims()[0].algorithms
('pair-grape-s-chain',)
>>> v = {c.id: c for c in select_claims()}["O3"].check(8, seed=0)
>>> v.verdict.value, v.instances_checked, v.scope.value, v.counterexample
('inconclusive', 24, "at the paper's sizes", None)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from cfopt import GridCell, Mission, generate_mission
from proofs.claimkit import (
    ACHIEVABLE_FAMILY,
    ALL_COMPOSITIONS,
    CheckResult,
    Claim,
    Counterexample,
    Evaluation,
    PropertyCheck,
    Scope,
    achievable,
    achievable_small_scope,
    capped_nash_claim,
    grid_cells,
    interval_verdict,
    median_estimate,
    property_claim,
    structural_missions,
    tally_summary,
    verdict_words,
    worst_verdict,
)
from proofs.claimkit import format_number as fmt
from proofs.select_stability import select_violations

__all__ = [
    "CHAIN_ALGORITHM",
    "FLOOR",
    "MEDIAN_TARGET",
    "OVERSUBSCRIBED",
    "SELECT_ALGORITHM",
    "cfopt_claims",
    "chain_claims",
    "select_claims",
]

#: The registry names of the algorithms the claims are about.
CHAIN_ALGORITHM = "pair-grape-s-chain"
SELECT_ALGORITHM = "grape-s-select"
#: Orders (with seed 0) every C1 mission is run in.
_ORDERS = ("index", "random")
#: O2's per-mission floor and O3's median target, in percent of the ILP optimum.
FLOOR = 95.0
MEDIAN_TARGET = 99.0
#: The over-subscription levels the select claims range over.
OVERSUBSCRIBED = (1.25, 1.5, 2.0)
#: Seconds the exact solver may take per mission (the claims' missions take far less).
_TIME_LIMIT = 60.0


def cfopt_claims() -> list[Claim]:
    """cfopt's claims, in the audit's order: :func:`chain_claims`, :func:`select_claims`."""
    return chain_claims() + select_claims()


# ------------------------------------------------------- pair-grape-s-chain
def _chains(run: Any) -> int:
    """The longest chain (partners) among the run's exchanges, from its trajectory."""
    traj = run.trajectory
    second = traj[traj[:, 0] > run.iterations - run.exchanges]
    if second.size == 0:
        return 0
    _, rows = np.unique(second[:, 0], return_counts=True)
    return int(rows.max()) - 1


def _c1(claim: Claim, m: Mission) -> Evaluation:
    tallies: list[str] = []
    for order in _ORDERS:
        run = claim.run(CHAIN_ALGORITHM, m, seed=0, order=order)
        pct = run.assignment.percent_utility(m)
        if pct >= 100.0:
            if _chains(run) >= 2:
                tallies.append(f"chain of 2+ partners ({order})")
            continue
        if not achievable(m):
            return Evaluation(None, 0.0, ("not achievable (skipped)",))
        done = run.assignment.completed_tasks(m).size
        detail = (
            f"Pair-GRAPE-S with chain exchanges ({order} order, seed 0) earns "
            f"{fmt(run.assignment.utility(m))} of {fmt(m.total_utility)} ({pct:.2f} %, "
            f"{done} of {m.n_tasks} tasks) on an achievable mission"
        )
        return Evaluation(Counterexample(m, run.assignment, CHAIN_ALGORITHM, detail), 100.0 - pct)
    return Evaluation(None, 0.0, tuple(tallies))


def chain_claims() -> list[Claim]:
    """The claims C1 and C2 about ``pair-grape-s-chain``, in the audit's order.

    Each :meth:`Claim.check` with budget 25 takes well under a minute (C1's small-scope
    search of the 1,630 achievable missions of :func:`small_scope` takes a few seconds;
    C2 runs the whole scope, 10,550 missions, when its search finds nothing).
    """
    c1 = property_claim(
        "C1",
        "cfopt's claim about its own algorithm Pair-GRAPE-S with chain exchanges "
        "(pair-grape-s-chain): it reaches the optimum -- every task complete -- on every "
        "achievable mission (proved in heuristics.pair_grape_s_chain by the augmenting-path "
        "theorem; checked as P1 is)",
        ACHIEVABLE_FAMILY
        + " (load 1); both orders (index and random, seed 0); when the search finds nothing, "
        "every achievable mission of the small scope (small_scope(): up to 3 robots, "
        "3 services, 3 one-service tasks; achievable by Hall's condition) is checked, "
        "smallest first",
        (CHAIN_ALGORITHM,),
        _c1,
        scope=Scope.GENERALISATION,
        cells=grid_cells(ALL_COMPOSITIONS),
        strategy=structural_missions(achievable=True, load=1.0),
        summary=tally_summary(
            "chain of 2+ partners (index)",
            "chain of 2+ partners (random)",
            "not achievable (skipped)",
        ),
        exhaustive=achievable_small_scope,
        sweep=ALL_COMPOSITIONS,
    )
    c2 = capped_nash_claim(
        "C2",
        "cfopt's claim about its own algorithm Pair-GRAPE-S with chain exchanges "
        "(pair-grape-s-chain): its partition is Nash stable under capped moves",
        CHAIN_ALGORITHM,
        subject="the chain variant's partition",
        note="; uncapped Nash stability reported in the note",
    )
    return [c1, c2]


# ----------------------------------------------------------- grape-s-select
def _run(claim: Claim, mission: Mission) -> Any:
    """The run the claims judge: index order, seed 0, through the registry when possible."""
    from heuristics import ALGORITHMS  # the public registry, never internals

    overridden = any(key == SELECT_ALGORITHM for key, _ in claim.overrides)
    if SELECT_ALGORITHM in ALGORITHMS or overridden:
        return claim.run(SELECT_ALGORITHM, mission, seed=0, order="index")
    from heuristics.grape_s_select import grape_s_select  # not registered (yet)

    return grape_s_select(mission, seed=0, order="index")


def _select_cells(loads: Sequence[float], robots: int = 100) -> list[GridCell]:
    return [
        GridCell(robots, p, S, k, load=load)
        for load in loads
        for S, k in ALL_COMPOSITIONS
        for p in (10, 50)
    ]


def _percent_of_optimum(mission: Mission, utility: float) -> tuple[float, float]:
    """(percent of the ILP optimum, the optimum); 100 % when nothing can be earned."""
    from cfopt import solve_exact

    optimum = solve_exact(mission, time_limit=_TIME_LIMIT).utility
    if optimum <= 0:
        return 100.0, optimum
    return 100.0 * utility / optimum, optimum


# ---------------------------------------------------------------- strategies
def _small_missions() -> Any:
    """Structural missions of up to 8 robots, 4 tasks, 4 services: any, or over-subscribed."""
    from hypothesis import strategies as st

    from proofs import strategies

    return st.one_of(
        strategies.missions(max_robots=8, max_tasks=4, max_services=4),
        strategies.missions(max_robots=8, max_tasks=4, max_services=4, achievable=False),
    )


def _oversubscribed(min_robots: int = 5, max_robots: int = 60) -> Callable[[], Any]:
    """The seed's generator at loads 1.25-2: drawn composition, size, percent, load, seed.

    Shrinks towards fewer robots, 5:1, 10 % tasks, load 1.25 and seed 0; a mission records
    its generator arguments, so ``cfopt generate ... --load L`` rebuilds it.
    """

    def make() -> Any:
        from hypothesis import strategies as st

        @st.composite
        def generated(draw: Any) -> Mission:
            S, k = draw(st.sampled_from(list(ALL_COMPOSITIONS)))
            n = draw(st.integers(min_robots, max_robots))
            p = draw(st.sampled_from([10, 50]))
            load = draw(st.sampled_from(list(OVERSUBSCRIBED)))
            seed = draw(st.integers(0, 2**32 - 1))
            return generate_mission(n, p, S, k, load=load, seed=seed)

        return generated()

    return make


def _oversubscribed_sweep(seeds: int = 3, base_seed: int = 0) -> Iterator[Mission]:
    """Small over-subscribed missions of the seed's family, smallest first: n = 3..12,
    every composition, 10 and 50 % tasks, loads 1.25-2, ``seeds`` seeds each."""
    for n in range(3, 13):
        for S, k in ALL_COMPOSITIONS:
            for p in (10, 50):
                for load in OVERSUBSCRIBED:
                    for i in range(seeds):
                        yield generate_mission(n, p, S, k, load=load, seed=base_seed * 100_000 + i)


class _OversubscribedSweep(PropertyCheck):
    """A property check whose seed-family sweep is over-subscribed (loads 1.25-2, three
    seeds per size, composition, percentage and load; smallest first)."""

    def family_sweep(self, n_missions: int, seed: int) -> Iterator[Mission]:
        return _oversubscribed_sweep(min(n_missions, 3), seed)


# ------------------------------------------------------------------ properties
def _o1(claim: Claim, m: Mission) -> Evaluation:
    run = _run(claim, m)
    a = run.assignment
    found = select_violations(m, a)
    done = set(a.completed_tasks(m).tolist())
    idle = sum(1 for t in a.task.tolist() if t >= 0 and t not in done)
    tallies = ("robot in an incomplete task",) if idle else ()
    if not found:
        return Evaluation(None, 0.0, tallies)
    v = found[0]
    detail = (
        f"GRAPE-S-Select's partition is not Nash stable under its completion reward: "
        f"{v.describe(m)} (reward {v.before} -> {v.after})"
        + (f" and {len(found) - 1} more" if len(found) > 1 else "")
    )
    return Evaluation(Counterexample(m, a, SELECT_ALGORITHM, detail), float(len(found)), tallies)


def _o2(claim: Claim, m: Mission) -> Evaluation:
    run = _run(claim, m)
    got = run.assignment.utility(m)
    pct, optimum = _percent_of_optimum(m, got)
    tallies = ("optimal",) if pct >= 100.0 - 1e-9 else ("below 99 %",) if pct < 99.0 else ()
    if pct >= FLOOR:
        return Evaluation(None, max(0.0, 100.0 - pct), tallies)
    done = run.assignment.completed_tasks(m).size
    detail = (
        f"GRAPE-S-Select earns {got:.4g} of the optimum {optimum:.4g} ({pct:.2f} % < "
        f"{FLOOR:g} %, {done} of {m.n_tasks} tasks) on an over-subscribed mission"
    )
    return Evaluation(
        Counterexample(m, run.assignment, SELECT_ALGORITHM, detail), 100.0 - pct, tallies
    )


class _MedianMethod:
    """O3: per load, the median percent of the optimum over the seeded grid missions, with
    its distribution-free confidence interval (:func:`proofs.claimkit.median_estimate`).

    Per load it checks ``max(n_missions, MIN_SAMPLE)`` missions (a 95 % interval of a
    median needs at least 6 values; the ILP solves these missions in milliseconds).  Per
    load the claim holds when the interval lies at or above :data:`MEDIAN_TARGET`, fails
    when it lies below, and is inconclusive at this budget otherwise; the loads' worst
    verdict is the claim's.  A median has no counterexample.
    """

    #: The least missions per load.
    MIN_SAMPLE = 8

    def __init__(self, cells: Sequence[GridCell]) -> None:
        self.cells = tuple(cells)

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        rows, kinds, checked = [], [], 0
        for load in OVERSUBSCRIBED:
            cells = [c for c in self.cells if c.load == load]
            percents = []
            for i in range(max(n_missions, self.MIN_SAMPLE)):
                cell = cells[i % len(cells)]
                m = cell.mission(i // len(cells), base_seed=seed)
                run = _run(claim, m)
                percents.append(_percent_of_optimum(m, run.assignment.utility(m))[0])
            estimate = median_estimate(percents)
            kind = interval_verdict(estimate, lower=MEDIAN_TARGET)
            kinds.append(kind)
            checked += len(percents)
            rows.append(
                f"load {load:g}: {estimate.describe('%')}, min {min(percents):.2f} %: "
                f"{verdict_words(kind)}"
            )
        note = f"target: median >= {MEDIAN_TARGET:g} % of the optimum; " + "; ".join(rows)
        return worst_verdict(kinds), checked, None, note


def select_claims() -> list[Claim]:
    """The claims O1-O3 about GRAPE-S-Select, in the audit's order.

    Budget 25 (``Claim.check(25)``, measured on 2 cores): O1 checks 25 grid missions, 100
    searched, the seed-family sweep (2000 missions) and the over-subscribed sweep (720) in
    about 3 s; O2 25 grid missions, the searched ones and the over-subscribed sweep up to
    its first failure, each against the ILP, plus the shrinking, in about 4 s; O3 75 grid
    missions against the ILP in about 7 s.
    """
    every_load = (1.0, *OVERSUBSCRIBED)
    return [
        property_claim(
            "O1",
            "cfopt's claim: GRAPE-S-Select ends Nash stable under its own reward (the "
            "completion reward of heuristics.grape_s_select: a robot earns its task's "
            "priority, needed or surplus, when the task is complete; checked by "
            "proofs.select_stability)",
            "the seed's grid cells with n = 100 at loads 1, 1.25, 1.5 and 2 (all compositions, "
            "10 and 50 % tasks) and hypothesis-drawn missions of up to 8 robots, 4 tasks, 4 "
            "services (any, and over-subscribed); when the search finds nothing, the seed's "
            "family at n = 3..12, loads 1.25-2 (720 missions), smallest first",
            (SELECT_ALGORITHM,),
            _o1,
            scope=Scope.GENERALISATION,
            cells=_select_cells(every_load),
            strategy=_small_missions,
            summary=tally_summary("robot in an incomplete task"),
            exhaustive=_oversubscribed_sweep,
            sweep=ALL_COMPOSITIONS,
        ),
        Claim(
            "O2",
            f"cfopt's claim: GRAPE-S-Select earns at least {FLOOR:g} % of the ILP optimum on every "
            "over-subscribed mission of the seed's family (loads 1.25, 1.5 and 2)",
            "over-subscribed missions of the seed's generator: grid cells n = 100 at loads "
            "1.25, 1.5, 2 (all compositions, 10 and 50 % tasks), generated missions of 5..60 "
            "robots at those loads, and a sweep of the family at n = 3..12 (every "
            "composition, 10 and 50 % tasks, the three loads, 3 seeds), smallest first",
            (SELECT_ALGORITHM,),
            _OversubscribedSweep(
                _o2,
                _select_cells(OVERSUBSCRIBED),
                _oversubscribed(),
                tally_summary("optimal", "below 99 %"),
                sweep=ALL_COMPOSITIONS,
            ),
            Scope.GENERALISATION,
        ),
        Claim(
            "O3",
            f"cfopt's claim: GRAPE-S-Select's median run earns at least {MEDIAN_TARGET:g} % "
            "of the ILP optimum on the seed's over-subscribed missions (n = 100), at every load",
            "per load 1.25, 1.5 and 2: n_missions seeded missions of the grid cells n = 100 "
            "(all compositions, 10 and 50 % tasks), each against the ILP optimum",
            (SELECT_ALGORITHM,),
            _MedianMethod(_select_cells(OVERSUBSCRIBED)),
            Scope.PAPER_SIZES,
        ),
    ]
