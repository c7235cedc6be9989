"""cfopt's own claims about Pair-GRAPE-S with chain exchanges (``pair-grape-s-chain``).

These are not the seed paper's statements: they are what cfopt claims of the variant it
adds, :func:`heuristics.pair_grape_s_chain.pair_grape_s_chain`, checked the way
:mod:`proofs.claims` checks the seed's (seeded grid missions, the seed-family sweep, a
hypothesis search with shrinking and, when that finds nothing, an exhaustive small-scope
search; see that module for the method and :class:`proofs.claims.Verdict` for the result).

``C1``
    The chain variant completes every task on every achievable mission (its docstring
    proves it with the augmenting-path theorem); checked as the seed's P1 is, plus the
    small-scope search restricted to the achievable missions of :func:`small_scope`.
``C2``
    Its partition is Nash stable under capped moves (the property the seed's Lemma 1
    asserts of Pair-GRAPE-S).

The claims run the algorithm through the public registry (``heuristics.get_algorithm``),
like every claim; ``import proofs.claims_chain`` imports neither heuristics nor hypothesis.

Examples
--------
>>> [c.id for c in chain_claims()]
['C1', 'C2']
>>> chain_claims()[0].algorithms
('pair-grape-s-chain',)

``chain_claims()[0].check(25, seed=0)`` returns C1's :class:`proofs.claims.Verdict`.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from cfopt import Mission
from proofs.claims import (
    _ACHIEVABLE_FAMILY,
    _ALL,
    _ANY_FAMILY,
    _SCOPED,
    Claim,
    Counterexample,
    _cells,
    _fmt,
    _Outcome,
    _percent,
    _property,
    _structural,
    _tally_summary,
    small_scope,
)
from proofs.stability import nash_violations

__all__ = ["ALGORITHM", "achievable", "chain_claims"]

#: The registry name of the algorithm the claims are about.
ALGORITHM = "pair-grape-s-chain"
#: Above this many needed services :func:`achievable` asks the exact ILP instead of
#: enumerating Hall's condition over service subsets.
_HALL_MAX_SERVICES = 16
#: Orders (with seed 0) every C1 mission is run in.
_ORDERS = ("index", "random")


def achievable(mission: Mission) -> bool:
    """Whether some assignment completes every task (Hall's condition, or the exact ILP).

    Robots against slot copies (``req[j, s]`` copies of slot ``(j, s)``): a copy of
    service ``s`` is adjacent to exactly the robots having ``s``, so Hall's condition
    for the copies reads, for every set ``Q`` of services, "the robots having some
    service of ``Q`` number at least the total requirement of ``Q``".  It is enumerated
    over the ``2^q`` subsets of the ``q`` services some task needs (O(2^q n q) numpy
    work); with more than 16 needed services :func:`cfopt.solve_exact` decides instead.
    Independent of the algorithm under audit.

    >>> import cfopt
    >>> achievable(cfopt.Mission.from_arrays([[1, 0], [1, 1]], [[1, 1]], [1]))
    True
    >>> achievable(cfopt.Mission.from_arrays([[1, 0], [1, 0]], [[1, 1]], [1]))
    False
    """
    need = mission.requirements.sum(axis=0)
    needed = np.flatnonzero(need)
    if needed.size > _HALL_MAX_SERVICES:
        from cfopt import ExactStatus, solve_exact

        res = solve_exact(mission)
        return res.status is ExactStatus.OPTIMAL and res.utility >= mission.total_utility
    subsets = np.array(list(itertools.product((0, 1), repeat=needed.size)), dtype=np.int64)
    caps = mission.capabilities[:, needed].astype(np.int64)
    robots = ((caps @ subsets.T) > 0).sum(axis=0)
    return bool((robots >= subsets @ need[needed]).all())


def _chains(run: Any) -> int:
    """The longest chain (partners) among the run's exchanges, from its trajectory."""
    traj = run.trajectory
    second = traj[traj[:, 0] > run.iterations - run.exchanges]
    if second.size == 0:
        return 0
    _, rows = np.unique(second[:, 0], return_counts=True)
    return int(rows.max()) - 1


def _c1(claim: Claim, m: Mission) -> _Outcome:
    tallies: list[str] = []
    for order in _ORDERS:
        run = claim.run(ALGORITHM, m, seed=0, order=order)
        pct = _percent(m, run.assignment)
        if pct >= 100.0:
            if _chains(run) >= 2:
                tallies.append(f"chain of 2+ partners ({order})")
            continue
        if not achievable(m):
            return _Outcome(None, 0.0, ("not achievable (skipped)",))
        done = run.assignment.completed_tasks(m).size
        detail = (
            f"Pair-GRAPE-S with chain exchanges ({order} order, seed 0) earns "
            f"{_fmt(run.assignment.utility(m))} of {_fmt(m.total_utility)} ({pct:.2f} %, "
            f"{done} of {m.n_tasks} tasks) on an achievable mission"
        )
        return _Outcome(Counterexample(m, run.assignment, ALGORITHM, detail), 100.0 - pct)
    return _Outcome(None, 0.0, tuple(tallies))


def _c2(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run(ALGORITHM, m, seed=0, order="index")
    a = run.assignment
    capped = nash_violations(m, a, capped=True)
    tallies = ("uncapped not Nash stable",) if nash_violations(m, a) else ()
    if not capped:
        return _Outcome(None, 0.0, tallies)
    detail = (
        f"the chain variant's partition is not Nash stable (capped moves): "
        f"{capped[0].describe(m)}" + (f" and {len(capped) - 1} more" if len(capped) > 1 else "")
    )
    return _Outcome(
        Counterexample(m, a, ALGORITHM, detail),
        float(len(capped)),
        (*tallies, "capped not Nash stable"),
    )


def _achievable_scope() -> Any:
    """The missions of :func:`small_scope` that have a complete assignment, smallest first."""
    return (m for m in small_scope() if achievable(m))


def chain_claims() -> list[Claim]:
    """The claims C1 and C2 about ``pair-grape-s-chain``, in the audit's order.

    Each :meth:`Claim.check` with budget 25 takes well under a minute (C1's small-scope
    search of the 1,630 achievable missions of :func:`small_scope` takes a few seconds;
    C2 runs the whole scope, 10,550 missions, when its search finds nothing).
    """
    c1 = _property(
        "C1",
        "cfopt's claim about its own algorithm Pair-GRAPE-S with chain exchanges "
        "(pair-grape-s-chain): it reaches the optimum -- every task complete -- on every "
        "achievable mission (proved in heuristics.pair_grape_s_chain by the augmenting-path "
        "theorem; checked as P1 is)",
        _ACHIEVABLE_FAMILY
        + " (load 1); both orders (index and random, seed 0); when the search finds nothing, "
        "every achievable mission of the small scope (small_scope(): up to 3 robots, "
        "3 services, 3 one-service tasks; achievable by Hall's condition) is checked, "
        "smallest first",
        (ALGORITHM,),
        _c1,
        _cells(_ALL),
        _structural(achievable=True, load=1.0),
        _tally_summary(
            "chain of 2+ partners (index)",
            "chain of 2+ partners (random)",
            "not achievable (skipped)",
        ),
        _achievable_scope,
        sweep=_ALL,
    )
    c2 = _property(
        "C2",
        "cfopt's claim about its own algorithm Pair-GRAPE-S with chain exchanges "
        "(pair-grape-s-chain): its partition is Nash stable under capped moves",
        _ANY_FAMILY + _SCOPED + "; uncapped Nash stability reported in the note",
        (ALGORITHM,),
        _c2,
        _cells(_ALL),
        _structural(achievable=None),
        _tally_summary("capped not Nash stable", "uncapped not Nash stable"),
        small_scope,
        sweep=_ALL,
    )
    return [c1, c2]
