"""Generic claims about any algorithm, chosen by the stability its spec declares.

:func:`algorithm_claims` turns a :class:`heuristics.AlgorithmSpec` -- a shipped algorithm,
an installed package's or a plain function of yours -- into the claims ``cfopt audit
--algorithm NAME`` checks beside the seed's, built from :mod:`proofs.claimkit` alone:

``NAME.valid``
    Every run returns a valid assignment: checked here by :func:`validity_problems`
    (each robot it assigns performs a service it has, for a task requiring it; one slot
    per robot; as many robots as the mission), not by the algorithm or by cfopt.  A run
    that raises, or returns neither a :class:`heuristics.Run` nor a
    :class:`cfopt.Assignment`, fails this claim on that mission.
``NAME.stable`` (unless the spec declares ``stability="none"``)
    The partition is stable as declared: ``"seed"`` -- Nash stable under the seed's
    reward (:func:`proofs.nash_violations`); ``"capped"`` -- Nash stable with capped
    moves; ``"own"`` -- no violation by the spec's own ``checker`` (a ``"MODULE:ATTR"``
    checker is imported when the claim is checked; one that cannot be imported is a
    :class:`cfopt.MissionError` saying so, not a counterexample).
``NAME.95pct``
    At least :data:`MIN_PERCENT` % of the optimum on every achievable mission: a run
    below that share of the total utility is compared with the exact ILP's optimum
    (:func:`cfopt.solve_exact`; the missions are small enough for milliseconds).
``NAME.scaling``
    Wall time and, when the runs are counted and report work, counted work over the size
    ladder of :mod:`proofs.scaling` (n = 25..400, 10 % tasks, 10:5), fitted in log-log
    space against the ceiling :data:`MAX_EXPONENT` (``n^3``, GRAPE-S's stated work with
    ``m ~ n``): *holds* when the fit's 95 % interval lies at or below the ceiling plus
    :data:`proofs.claimkit.EXPONENT_TOLERANCE`, *fails* when it lies above, otherwise
    *inconclusive*.  Wall time is a measurement (the best of up to three timings per
    mission), noisy on a loaded machine: the note gives the fitted exponent with its
    interval, and counted work, where reported, is the repeatable measure.

Every run is ``run(mission, seed=0)`` (:data:`REPLAY_SEED`; the algorithm's other options
at their defaults), so each counterexample replays: ``cfopt run NAME mission.json --seed
0`` reproduces the assignment of a deterministic algorithm (the counterexample records
the seed), and ``cfopt check mission.json assignment.json`` shows it.  An invalid
assignment cannot be written as an assignment file: its counterexample holds the run's
assignment with the robots at fault unassigned, and its detail names them.

The property claims range over the families of :mod:`proofs.claimkit` (the seed's grid
cells at n = 100, a seed-family sweep at n = 3..12, a hypothesis search shrinking a
failure to a small mission and, for validity and stability, every mission of the small
scope): their scope is *a generalisation to the paper's family at any size*.

Examples
--------
>>> import cfopt, heuristics
>>> def nobody(mission, *, seed=None):  # assigns no robot: valid, 0 % of the optimum
...     return cfopt.Assignment.empty(mission)
>>> spec = heuristics.AlgorithmSpec(name="nobody", run=nobody, stability="capped")
>>> [c.id for c in algorithm_claims(spec)]
['nobody.valid', 'nobody.stable', 'nobody.95pct', 'nobody.scaling']
>>> verdict = algorithm_claims(spec)[2].check(1)  # 0 % of the optimum
>>> verdict.verdict.value, verdict.counterexample.seed, verdict.counterexample.size
('fails', 0, (1, 1, 1))
"""

from __future__ import annotations

import hashlib
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from cfopt import Assignment, ExactStatus, Mission, MissionError, solve_exact
from cfopt.checks import require_bool, require_number, require_text
from cfopt.errors import MissionTypeError
from proofs.claimkit import (
    ACHIEVABLE_FAMILY,
    ALL_COMPOSITIONS,
    ANY_FAMILY,
    EXPONENT_TOLERANCE,
    LADDER_SIZES,
    SMALL_SCOPE_FAMILY,
    CheckResult,
    Claim,
    ClaimCheck,
    Counterexample,
    Evaluation,
    Evaluator,
    Scope,
    VerdictKind,
    achievable,
    exponent_verdict,
    format_number,
    grid_cells,
    property_claim,
    small_scope,
    structural_missions,
    tally_summary,
    worst_verdict,
)
from proofs.scaling import Fit, fit_exponent, ladder_mission
from proofs.stability import nash_violations

if TYPE_CHECKING:
    from heuristics import AlgorithmSpec

__all__ = [
    "MAX_EXPONENT",
    "MIN_PERCENT",
    "REPLAY_SEED",
    "WallTimeScaling",
    "algorithm_claims",
    "claim_prefix",
    "validity_problems",
]

#: The share of the optimum (percent) the ``NAME.95pct`` claim asks for by default.
MIN_PERCENT = 95.0
#: The default ceiling of the scaling claim's exponents in ``n`` (GRAPE-S's stated work).
MAX_EXPONENT = 3.0
#: The seed every run of a generic claim gets (``cfopt run NAME MISSION --seed 0``).
REPLAY_SEED = 0
#: Problems a validity failure lists before "and N more".
_SHOWN = 3
#: Timings per ladder mission (the best is kept) while they take less than this in all.
_TIMINGS, _TIMING_BUDGET = 3, 0.5
_ID_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
_PREFIX_MAX = 48


# ------------------------------------------------------------------- one run
def validity_problems(mission: Mission, assignment: Assignment) -> list[str]:
    """What makes ``assignment`` invalid for ``mission``, in words (empty: valid).

    Recomputed here from the mission's arrays: the assignment has one entry per robot,
    and every robot it assigns has a task and a service in range, has that service, and
    the task requires it.  (One slot per robot holds by construction of an
    :class:`cfopt.Assignment`.)

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 0], [0, 1]], [[1, 1]], [1.0])
    >>> validity_problems(m, cfopt.Assignment(task=[0, 0], service=[0, 1]))
    []
    >>> validity_problems(m, cfopt.Assignment(task=[0, 0], service=[1, 1]))
    ["robot 'r0' performs 's1', which it does not have"]
    """
    n, tasks, services = mission.n_robots, mission.n_tasks, mission.n_services
    if assignment.task.size != n:
        return [f"it assigns {assignment.task.size} robots, the mission has {n}"]
    problems = []
    for i in np.flatnonzero(assignment.task >= 0).tolist():
        j, s = int(assignment.task[i]), int(assignment.service[i])
        robot = mission.robot_ids[i]
        if j >= tasks or s >= services:
            problems.append(f"robot {robot!r} has task {j} / service {s} (out of range)")
        elif not mission.capabilities[i, s]:
            problems.append(
                f"robot {robot!r} performs {mission.services[s]!r}, which it does not have"
            )
        elif mission.requirements[j, s] <= 0:
            problems.append(
                f"robot {robot!r} performs {mission.services[s]!r} for task "
                f"{mission.task_ids[j]!r}, which does not require it"
            )
    return problems


@dataclass(frozen=True)
class _Outcome:
    """One run of the claim's algorithm: its result, problems and wall time."""

    result: Any
    assignment: Assignment | None  # the valid assignment, None when there is none
    problems: tuple[str, ...]
    shown: Assignment  # what a counterexample holds
    seconds: float

    def failure(self, claim: Claim, mission: Mission, what: str) -> Evaluation:
        """The evaluation of a run without a valid assignment: ``what`` cannot be checked."""
        name = claim.algorithms[0]
        detail = f"{_problem_text(name, self.problems)}; so {what} cannot hold"
        return Evaluation(_example(claim, mission, self.shown, detail), math.inf, ("invalid",))


def _run(claim: Claim, mission: Mission) -> _Outcome:
    name = claim.algorithms[0]
    started = time.perf_counter()
    try:
        result = claim.run(name, mission, seed=REPLAY_SEED)
    except Exception as exc:
        raised = f"raised {type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        return _Outcome(None, None, (raised,), Assignment.empty(mission), math.nan)
    seconds = time.perf_counter() - started
    assignment = result if isinstance(result, Assignment) else getattr(result, "assignment", None)
    if not isinstance(assignment, Assignment):
        problem = f"returned {type(result).__name__}, not a heuristics.Run or a cfopt.Assignment"
        return _Outcome(result, None, (problem,), Assignment.empty(mission), seconds)
    problems = tuple(validity_problems(mission, assignment))
    if not problems:
        return _Outcome(result, assignment, (), assignment, seconds)
    return _Outcome(result, None, problems, _valid_part(mission, assignment), seconds)


def _valid_part(mission: Mission, assignment: Assignment) -> Assignment:
    """``assignment`` with every robot that makes it invalid unassigned."""
    if assignment.task.size != mission.n_robots:
        return Assignment.empty(mission)
    task, service = assignment.task.copy(), assignment.service.copy()
    assigned = task >= 0
    j = np.where(assigned, task, 0)
    s = np.where(assigned, service, 0)
    inside = (j < mission.n_tasks) & (s < mission.n_services)
    j, s = np.where(inside, j, 0), np.where(inside, s, 0)
    rows = np.arange(mission.n_robots)
    fine = inside & mission.capabilities[rows, s] & (mission.requirements[j, s] > 0)
    task[assigned & ~fine] = service[assigned & ~fine] = -1
    return Assignment(task=task, service=service)


def _problem_text(name: str, problems: Sequence[str]) -> str:
    if problems[0].startswith(("raised", "returned")):
        return f"{name} {problems[0]} (seed {REPLAY_SEED})"
    more = f" and {len(problems) - _SHOWN} more" if len(problems) > _SHOWN else ""
    return (
        f"{name} returned an invalid assignment (seed {REPLAY_SEED}): "
        f"{'; '.join(problems[:_SHOWN])}{more}; the counterexample's assignment leaves "
        "those robots unassigned"
    )


def _example(claim: Claim, mission: Mission, assignment: Assignment, detail: str) -> Counterexample:
    name = claim.algorithms[0]
    replay = f"replay: cfopt run {name} MISSION --seed {REPLAY_SEED}"
    return Counterexample(mission, assignment, name, f"{detail}; {replay}", seed=REPLAY_SEED)


# --------------------------------------------------------------- properties
def _valid(claim: Claim, mission: Mission) -> Evaluation:
    out = _run(claim, mission)
    if not out.problems:
        return Evaluation(None)
    detail = _problem_text(claim.algorithms[0], out.problems)
    tally = "raised" if out.problems[0].startswith("raised") else "invalid"
    return Evaluation(
        _example(claim, mission, out.shown, detail), float(len(out.problems)), (tally,)
    )


#: A stability check: ``check(mission, assignment) -> list`` of violations.
_Checker = Callable[[Mission, Assignment], Sequence[Any]]


def _stable(promise: str, checker: Callable[[], _Checker]) -> Evaluator:
    def evaluate(claim: Claim, mission: Mission) -> Evaluation:
        out = _run(claim, mission)
        if out.assignment is None:
            return out.failure(claim, mission, promise)
        found = list(checker()(mission, out.assignment))
        if not found:
            return Evaluation(None)
        first = found[0]
        shown = first.describe(mission) if callable(getattr(first, "describe", None)) else first
        more = f" and {len(found) - 1} more" if len(found) > 1 else ""
        detail = f"{claim.algorithms[0]}'s partition is not {promise}: {shown}{more}"
        return Evaluation(
            _example(claim, mission, out.assignment, detail), float(len(found)), ("unstable",)
        )

    return evaluate


def _share(min_percent: float) -> Evaluator:
    def evaluate(claim: Claim, mission: Mission) -> Evaluation:
        if not achievable(mission):
            return Evaluation(None, 0.0, ("not achievable (skipped)",))
        out = _run(claim, mission)
        if out.assignment is None:
            return out.failure(claim, mission, f"{min_percent:g} % of the optimum")
        got, total = out.assignment.utility(mission), mission.total_utility
        if total <= 0 or 100.0 * got >= min_percent * total:  # the optimum is <= total
            return Evaluation(None, 1.0 - got / total if total > 0 else 0.0)
        best = solve_exact(mission)
        if best.status is not ExactStatus.OPTIMAL:
            return Evaluation(None, 0.0, ("optimum not proven (skipped)",))
        percent = 100.0 if best.utility <= 0 else 100.0 * got / best.utility
        if percent >= min_percent:
            return Evaluation(None, 1.0 - percent / 100.0)
        detail = (
            f"{claim.algorithms[0]} earns {format_number(got)} of the optimum "
            f"{format_number(best.utility)} ({percent:.2f} % < {min_percent:g} %; the "
            "optimum: cfopt solve MISSION)"
        )
        return Evaluation(
            _example(claim, mission, out.assignment, detail), 100.0 - percent, ("below",)
        )

    return evaluate


# ------------------------------------------------------------------ scaling
@dataclass(frozen=True)
class _Point:
    mission: Mission
    outcome: _Outcome
    seconds: float
    work: int | None


class WallTimeScaling:
    """A :class:`proofs.claimkit.ClaimCheck`: wall time (and counted work, when every run
    reports it) of the claim's first algorithm over the size ladder, fitted against
    ``max_exponent``.

    A check with budget ``n`` runs ``min(5, max(2, ceil(n / 5)))`` missions per rung
    (:func:`proofs.scaling.ladder_mission`), each with seed :data:`REPLAY_SEED`, timed up
    to three times (the best timing is kept).  A run that raises or returns an invalid
    assignment fails the claim with its mission; a failing fit's counterexample is the
    largest ladder mission.
    """

    def __init__(self, max_exponent: float, sizes: Sequence[int] = LADDER_SIZES) -> None:
        self.max_exponent = float(max_exponent)
        self.sizes = tuple(sizes)

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        """The ladder, its fits and their verdicts (see the class)."""
        per_rung = min(5, max(2, math.ceil(n_missions / 5)))
        points = []
        for n in self.sizes:
            for s in range(seed, seed + per_rung):
                point = self._point(claim, ladder_mission(n, s))
                if point.outcome.assignment is None:
                    ce = point.outcome.failure(claim, point.mission, "its scaling").failure
                    return VerdictKind.FAILS, len(points) + 1, ce, "a ladder run failed"
                points.append(point)
        kinds, notes = [], []
        fits = self._fits(points)
        for label, fit in fits:
            kind = exponent_verdict(fit, self.max_exponent)
            kinds.append(kind)
            notes.append(f"{label} ~ n^{fit} vs the ceiling n^{self.max_exponent:g}: {kind.value}")
        if all(p.work is None for p in points):
            notes.append("work not reported (its runs are not counted)")
        notes.append(
            "wall time is a measurement, noisy on a loaded machine (best of up to "
            f"{_TIMINGS} timings per mission; the interval is the fit's 95 %)"
        )
        sizes = ", ".join(map(str, self.sizes))
        notes.append(f"ladder n = {sizes} (10 % tasks, 10:5), {per_rung} seeds each")
        kind = worst_verdict(kinds) if kinds else VerdictKind.INCONCLUSIVE
        example = None
        if kind is VerdictKind.FAILS:
            example = self._largest(claim, points[-1], fits)
        return kind, len(points), example, "; ".join(notes)

    @staticmethod
    def _point(claim: Claim, mission: Mission) -> _Point:
        out = _run(claim, mission)
        if out.assignment is None:
            return _Point(mission, out, math.nan, None)
        timings = [out.seconds]
        while len(timings) < _TIMINGS and sum(timings) < _TIMING_BUDGET:
            timings.append(_run(claim, mission).seconds)
        counted = getattr(out.result, "counted", False) is True
        work = getattr(out.result, "work", None) if counted else None
        return _Point(mission, out, min(timings), None if work is None else int(work))

    @staticmethod
    def _fits(points: Sequence[_Point]) -> list[tuple[str, Fit]]:
        fits = []
        measures: list[tuple[str, Callable[[_Point], float | None]]] = [
            ("wall time", lambda p: p.seconds),
            ("work", lambda p: p.work),
        ]
        for label, value in measures:
            pairs = [(p.mission.n_robots, value(p)) for p in points]
            if any(v is None for _, v in pairs):
                continue  # work: not every run reports it
            usable = [(n, v) for n, v in pairs if v is not None and v > 0]
            if len(usable) >= 3 and len({n for n, _ in usable}) >= 2:
                fits.append((label, fit_exponent([n for n, _ in usable], [v for _, v in usable])))
        return fits

    def _largest(
        self, claim: Claim, point: _Point, fits: Sequence[tuple[str, Fit]]
    ) -> Counterexample:
        limit = self.max_exponent + EXPONENT_TOLERANCE
        over = [f"{label} ~ n^{fit}" for label, fit in fits if fit.ci_low > limit]
        work = "" if point.work is None else f", work {point.work}"
        detail = (
            f"largest ladder mission (n = {point.mission.n_robots}): wall time "
            f"{point.seconds:.3g} s{work}; fitted {', '.join(over)} exceeds the ceiling "
            f"{self.max_exponent:g} + {EXPONENT_TOLERANCE}"
        )
        assert point.outcome.assignment is not None  # ladder points are valid runs
        return _example(claim, point.mission, point.outcome.assignment, detail)


# ------------------------------------------------------------------- claims
class _CheckerFirst:
    """A check that resolves the spec's own stability checker before the inner check, so
    a checker that cannot be imported is an error, not a counterexample."""

    def __init__(self, inner: ClaimCheck, resolve: Callable[[], Any]) -> None:
        self.inner, self.resolve = inner, resolve

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        self.resolve()
        return self.inner.check(claim, n_missions, seed)


def claim_prefix(name: str) -> str:
    """The id prefix of an algorithm's generic claims: ``name`` with every run of
    characters a claim id cannot hold replaced by ``-`` (a long name is cut and given a
    digest).

    >>> claim_prefix("mymod:greedy"), claim_prefix("grape-s")
    ('mymod-greedy', 'grape-s')
    """
    prefix = _ID_UNSAFE.sub("-", name).strip("-._") or "algorithm"
    if len(prefix) > _PREFIX_MAX:
        digest = hashlib.sha256(name.encode()).hexdigest()[:8]
        prefix = f"{prefix[: _PREFIX_MAX - 9]}-{digest}"
    return prefix


def _checker(spec: AlgorithmSpec) -> tuple[str, Callable[[], _Checker]] | None:
    """The declared promise in words and how to get its checker; ``None`` for none."""
    kind = spec.stability.value  # type: ignore[union-attr]
    if kind == "seed":
        return "Nash stable under the seed's reward", lambda: nash_violations
    if kind == "capped":
        return "Nash stable with capped moves", lambda: _capped
    if kind == "own":
        where = spec.checker if isinstance(spec.checker, str) else "its own checker"
        return f"stable by {where}", lambda: _own_checker(spec)
    return None


def _capped(mission: Mission, assignment: Assignment) -> list[Any]:
    return nash_violations(mission, assignment, capped=True)


def _own_checker(spec: AlgorithmSpec) -> _Checker:
    try:
        checker = spec.stability_checker()
    except MissionError as exc:
        raise MissionError(f"{spec.name}: its stability checker: {exc}") from None
    if not callable(checker):
        raise MissionError(
            f"{spec.name}: its stability checker {spec.checker!r} is not callable, got "
            f"{type(checker).__name__}"
        )
    return checker


@dataclass(frozen=True)
class _Subject:
    """The algorithm the claims are about: its spec, the name commands run it by."""

    spec: AlgorithmSpec
    run_as: str
    exhaustive: bool

    @property
    def prefix(self) -> str:
        return claim_prefix(self.spec.name)

    def any_mission_claim(
        self, kind: str, statement: str, evaluate: Evaluator, *labels: str
    ) -> Claim:
        return property_claim(
            f"{self.prefix}.{kind}",
            statement,
            ANY_FAMILY + (SMALL_SCOPE_FAMILY if self.exhaustive else ""),
            (self.run_as,),
            evaluate,
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=None),
            summary=tally_summary(*labels),
            exhaustive=small_scope if self.exhaustive else None,
            sweep=ALL_COMPOSITIONS,
        )


def algorithm_claims(
    spec: AlgorithmSpec,
    *,
    reference: str | None = None,
    min_percent: float = MIN_PERCENT,
    max_exponent: float = MAX_EXPONENT,
    exhaustive: bool = True,
) -> list[Claim]:
    """The generic claims of ``spec``'s algorithm, in order: valid, stable (as declared;
    none for ``stability="none"``), ``min_percent`` % of the optimum, scaling.

    Parameters
    ----------
    spec : heuristics.AlgorithmSpec
        The algorithm (``heuristics.get_algorithm(NAME)``); its ``run`` is called
        directly, with ``seed=0``, so the claims see exactly what it returns.
    reference : str, optional
        The name commands run it by, when that is not the spec's name: the
        ``MODULE:ATTR`` of a spec that is not registered.  The counterexamples name it
        (``cfopt run REFERENCE MISSION --seed 0`` replays them).  Default: ``spec.name``.
    min_percent : float, default 95
        The share of the optimum (0 < ``min_percent`` <= 100) the third claim asks for;
        its id is ``<prefix>.<min_percent>pct``.
    max_exponent : float, default 3
        The ceiling of the scaling claim's exponents in ``n`` (> 0).
    exhaustive : bool, default True
        Whether the validity and stability claims, when their search finds nothing, run
        the algorithm on every mission of :func:`proofs.claimkit.small_scope` (about
        10,000 tiny missions: seconds for a fast algorithm, where rare failures live).

    Returns
    -------
    list of proofs.claimkit.Claim
        Ids ``<prefix>.valid``, ``<prefix>.stable``, ``<prefix>.95pct``,
        ``<prefix>.scaling`` (:func:`claim_prefix` of the spec's name), each running the
        spec's function wherever it runs ``reference`` (``Claim.with_algorithm``
        substitutes another).
    """
    from heuristics import AlgorithmSpec

    if not isinstance(spec, AlgorithmSpec):
        raise MissionTypeError(
            f"spec: must be a heuristics.AlgorithmSpec, got {type(spec).__name__}"
        )
    run_as = spec.name if reference is None else require_text("reference", reference)
    min_percent = require_number("min_percent", min_percent, above=0, maximum=100)
    max_exponent = require_number("max_exponent", max_exponent, above=0)
    subject = _Subject(spec, run_as, require_bool("exhaustive", exhaustive))
    claims = [_valid_claim(subject)]
    stable = _stable_claim(subject)
    if stable is not None:
        claims.append(stable)
    claims.append(_share_claim(subject, min_percent))
    claims.append(_scaling_claim(subject, max_exponent))
    return [c.with_algorithm(run_as, _direct(spec)) for c in claims]


def _valid_claim(subject: _Subject) -> Claim:
    return subject.any_mission_claim(
        "valid",
        f"{subject.spec.name} returns a valid assignment on every mission (each robot it "
        "assigns performs a service it has, for a task requiring it, in one slot; checked "
        "by proofs, not by the algorithm)",
        _valid,
        "raised",
        "invalid",
    )


def _stable_claim(subject: _Subject) -> Claim | None:
    spec = subject.spec
    declared = _checker(spec)
    if declared is None:
        return None
    promise, checker = declared
    kind = spec.stability.value  # type: ignore[union-attr]
    claim = subject.any_mission_claim(
        "stable",
        f"{spec.name}'s partition is {promise} on every mission, as its spec declares "
        f"(stability {kind!r})",
        _stable(promise, checker),
        "unstable",
    )
    if kind == "own":
        claim = replace(claim, method=_CheckerFirst(claim.method, checker))
    return claim


def _share_claim(subject: _Subject, min_percent: float) -> Claim:
    return property_claim(
        f"{subject.prefix}.{min_percent:g}pct",
        f"{subject.spec.name} earns at least {min_percent:g} % of the optimum (the exact "
        "ILP) on every achievable mission",
        ACHIEVABLE_FAMILY + "; the grid's and the sweep's missions without a complete "
        "assignment are skipped; the optimum is cfopt.solve_exact's, solved when a run "
        f"earns less than {min_percent:g} % of the total utility",
        (subject.run_as,),
        _share(min_percent),
        scope=Scope.GENERALISATION,
        cells=grid_cells(ALL_COMPOSITIONS),
        strategy=structural_missions(achievable=True),
        summary=tally_summary("below", "not achievable (skipped)", "invalid"),
        sweep=ALL_COMPOSITIONS,
    )


def _scaling_claim(subject: _Subject, max_exponent: float) -> Claim:
    return Claim(
        f"{subject.prefix}.scaling",
        f"{subject.spec.name}'s wall time, and its counted work where its runs report it, "
        f"grow at most as n^{max_exponent:g} (a stated ceiling) over a size ladder",
        "size ladder n = 25..400, 10 % tasks (m proportional to n), 10:5, load 1 "
        "(proofs.scaling.ladder_mission); wall time measured, work counted",
        (subject.run_as,),
        WallTimeScaling(max_exponent),
        Scope.GENERALISATION,
    )


def _direct(spec: AlgorithmSpec) -> Callable[..., Any]:
    """``spec``'s own function, called as the claims call it (what it returns, unwrapped)."""

    def run(mission: Mission, **options: Any) -> Any:
        return spec.run(mission, **options)

    run.__name__ = spec.name
    return run
