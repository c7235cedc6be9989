"""The seed's claims as executable properties, with verdicts and shrunk counterexamples.

Every entry of :data:`CLAIMS` quotes a statement of the seed paper
(Diehl and Adams, "GRAPE-S: Near Real-Time Coalition Formation for Multiple
Service Collectives"), names the missions it ranges over, and checks it:
:meth:`Claim.check` returns a :class:`Verdict` -- ``holds`` (no counterexample among the
missions checked), ``fails`` (with a :class:`Counterexample`: a mission and the partition
the algorithm produced on it) or ``inconclusive``.

How a claim about single runs is checked
----------------------------------------
1. *Seeded missions of the seed's grid*: ``n_missions`` missions of the cells of
   :func:`cfopt.paper_grid` with 100 robots (the seed's smallest collective) and the
   compositions the claim is about, in the same order on every machine.
2. *A hypothesis search* (``hypothesis.find``), ``SEARCH_FACTOR * n_missions`` drawn
   missions from the claim's family -- small structural missions
   (:mod:`proofs.strategies`), or the seed's generator with a drawn size and seed -- with
   ``hypothesis.target`` steering towards a larger *gap* (how badly the property fails:
   violations, missing utility, surplus iterations).  A failure is **shrunk** by
   hypothesis to a minimal mission of the family.
The smallest counterexample found is reported.  Every counterexample replays from the
command line: ``cfopt run ALGORITHM mission.json`` reproduces the assignment (index
order, the runs' default) and ``cfopt check mission.json assignment.json`` shows the
violation (see :func:`write_counterexamples`).

How a complexity claim is checked
---------------------------------
Counted work / messages on a size ladder (:mod:`proofs.scaling`), fitted in log-log space,
against the exponent the seed's O(...) bound gives with the other sizes held as the ladder
holds them.  The bound is an upper bound: the claim *holds* when the fitted interval lies
at or below ``exponent + EXPONENT_TOLERANCE``, *fails* when it lies above, and is
*inconclusive* otherwise.

The checks use ``proofs``' own stability checkers and call the algorithms through the
public registry (``heuristics.get_algorithm``); :meth:`Claim.with_algorithm` substitutes
another implementation (to audit a variant of a heuristic against the same claims).

Dependencies: the search needs hypothesis, a runtime dependency of cfopt (``cfopt audit``
runs it); ``import proofs`` and ``import proofs.claims`` do not import it, a check does.

Examples
--------
>>> from proofs.claims import CLAIMS
>>> list(CLAIMS)[:6]
['L1', 'T1', 'G1', 'G2', 'G3', 'G4']
>>> v = CLAIMS["X2"].check(2, seed=0)
>>> v.verdict.value, v.counterexample is None
('holds', True)
"""

from __future__ import annotations

import enum
import math
import random
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from cfopt import Assignment, GridCell, Mission, MissionError, generate_mission, paper_grid
from cfopt.checks import require_int
from proofs.scaling import (
    Fit,
    fit_rungs,
    ladder,
    ladder_mission,
)
from proofs.stability import is_pairwise_stable, nash_violations, pairwise_violations

__all__ = [
    "CLAIMS",
    "EXPONENT_TOLERANCE",
    "SEARCH_FACTOR",
    "Claim",
    "Counterexample",
    "Verdict",
    "VerdictKind",
    "audit_claims",
    "format_verdict_table",
    "small_scope",
    "write_counterexamples",
]

#: Drawn missions of the hypothesis search per seeded grid mission.
SEARCH_FACTOR = 4
#: How far above the seed's exponent a fitted exponent may lie and still count as holding.
EXPONENT_TOLERANCE = 0.25
#: Collective sizes of the complexity ladders (``m`` in proportion, 10 % tasks, 10:5).
LADDER_SIZES = (25, 50, 100, 200, 400)
#: Collective sizes of the seed-family sweep of the property claims (smallest first).
SWEEP_ROBOTS = tuple(range(3, 13))
_SDA_LADDER_SIZES = (25, 50, 100, 200)  # SDA's counted work is ~n^3: 400 takes seconds


# ----------------------------------------------------------------------- results
class VerdictKind(enum.Enum):
    """What the check of a claim concluded."""

    HOLDS = "holds"
    FAILS = "fails"
    INCONCLUSIVE = "inconclusive"


@dataclass(frozen=True, eq=False)
class Counterexample:
    """A mission on which a claim fails, and the partition the algorithm produced there.

    ``algorithm`` is the registry name whose run gave ``assignment`` (``""`` when none
    did); ``detail`` says in words what is violated, e.g. the deviation a robot wants.
    A distributed run's counterexample also has its ``network`` spec and simulator
    ``seed`` (``cfopt run ALGORITHM MISSION --network SPEC --seed SEED`` replays it).
    """

    mission: Mission
    assignment: Assignment
    algorithm: str
    detail: str
    network: str | None = None
    seed: int | None = None

    @property
    def size(self) -> tuple[int, int, int]:
        """``(robots, tasks, services)``."""
        m = self.mission
        return (m.n_robots, m.n_tasks, m.n_services)

    def to_dict(self) -> dict[str, Any]:
        """``{"mission", "assignment", "algorithm", "detail"}``, the first two in the
        ``cfopt.mission/1`` and ``cfopt.assignment/1`` formats."""
        return {
            "mission": self.mission.to_dict(),
            "assignment": self.assignment.to_dict(self.mission),
            "algorithm": self.algorithm,
            "detail": self.detail,
            "network": self.network,
            "seed": self.seed,
        }


@dataclass(frozen=True)
class Verdict:
    """The outcome of :meth:`Claim.check` (an entry of ``cfopt audit --json``'s ``claims``)."""

    claim_id: str
    statement: str
    verdict: VerdictKind
    instances_checked: int
    counterexample: Counterexample | None
    seconds: float
    note: str = ""

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Verdict:
        """The verdict :meth:`to_dict` described (the counterexample rebuilt and validated)."""
        ce = data.get("counterexample")
        counterexample = None
        if ce is not None:
            mission = Mission.from_dict(ce["mission"])
            counterexample = Counterexample(
                mission=mission,
                assignment=Assignment.from_dict(mission, ce["assignment"]),
                algorithm=ce["algorithm"],
                detail=ce["detail"],
                network=ce.get("network"),
                seed=ce.get("seed"),
            )
        return cls(
            claim_id=data["id"],
            statement=data["statement"],
            verdict=VerdictKind(data["verdict"]),
            instances_checked=int(data["instances_checked"]),
            counterexample=counterexample,
            seconds=float(data["seconds"]),
            note=data.get("note", ""),
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready; ``verdict`` is ``"holds"``, ``"fails"`` or ``"inconclusive"``."""
        return {
            "id": self.claim_id,
            "statement": self.statement,
            "verdict": self.verdict.value,
            "instances_checked": self.instances_checked,
            "counterexample": None
            if self.counterexample is None
            else self.counterexample.to_dict(),
            "note": self.note,
            "seconds": self.seconds,
        }


# ------------------------------------------------------------------------ claims
Runner = Callable[..., Any]


@dataclass(frozen=True)
class _Outcome:
    """One mission's evaluation: the failure (if any), a gap >= 0 for ``target`` (larger
    means the property fails worse or is closer to failing), and labels tallied in the note.
    """

    failure: Counterexample | None
    gap: float = 0.0
    tallies: tuple[str, ...] = ()


@dataclass(frozen=True)
class Claim:
    """One claim of the seed, executable.

    Attributes
    ----------
    id : str
        ``L1``, ``T1``, ``G1``... (the keys of :data:`CLAIMS`).
    statement : str
        The claim, quoting the seed with its section.
    family : str
        The missions the claim ranges over and how they are drawn.
    algorithms : tuple of str
        Registry names of the algorithms the check runs.
    overrides : tuple of (str, callable)
        Replacement implementations (see :meth:`with_algorithm`).
    """

    id: str
    statement: str
    family: str
    algorithms: tuple[str, ...]
    _method: Any = field(repr=False, compare=False)
    overrides: tuple[tuple[str, Runner], ...] = field(default=(), compare=False)

    def check(self, n_missions: int, seed: int = 0) -> Verdict:
        """Check the claim on ``n_missions`` seeded grid missions plus a hypothesis search.

        Parameters
        ----------
        n_missions : int
            Budget: seeded grid missions (the search draws ``SEARCH_FACTOR`` times as many);
            for a complexity claim, missions per ladder rung are ``ceil(n_missions / 5)``
            (2..5).
        seed : int, default 0
            Base seed of the grid missions and of the search (same seed, same verdict).

        Returns
        -------
        Verdict
        """
        n_missions = require_int("n_missions", n_missions, minimum=1)
        seed = require_int("seed", seed, minimum=0)
        started = time.perf_counter()
        kind, count, example, note = self._method.check(self, n_missions, seed)
        return Verdict(
            claim_id=self.id,
            statement=self.statement,
            verdict=kind,
            instances_checked=count,
            counterexample=example,
            seconds=time.perf_counter() - started,
            note=note,
        )

    def with_algorithm(self, name: str, function: Runner) -> Claim:
        """A copy of this claim that runs ``function`` wherever it would run ``name``.

        ``function(mission, *, seed, order, **options)`` must return an object with the
        fields of :class:`heuristics.Run` the claim reads (``assignment``, ``iterations``,
        ``work``...).  Use it to check a variant -- or a deliberately broken version -- of a
        heuristic against the seed's claims.
        """
        if name not in self.algorithms:
            raise ValueError(
                f"name: claim {self.id} runs {', '.join(self.algorithms)}, not {name!r}"
            )
        if not callable(function):
            raise TypeError(f"function: must be callable, got {type(function).__name__}")
        kept = tuple((n, f) for n, f in self.overrides if n != name)
        return replace(self, overrides=(*kept, (name, function)))

    def run(self, name: str, mission: Mission, **options: Any) -> Any:
        """Run algorithm ``name`` (or its override) on ``mission`` with ``options``."""
        for key, function in self.overrides:
            if key == name:
                return function(mission, **options)
        from heuristics import get_algorithm  # the public registry, never internals

        return get_algorithm(name)(mission, **options)


# --------------------------------------------------------------- run properties
def _percent(mission: Mission, assignment: Assignment) -> float:
    return assignment.percent_utility(mission)


def _fmt(x: float) -> str:
    return f"{x:.4g}"


class _PropertyMethod:
    """Grid missions plus a hypothesis search for missions where ``evaluate`` fails."""

    def __init__(
        self,
        evaluate: Callable[[Claim, Mission], _Outcome],
        cells: Sequence[GridCell],
        strategy: Callable[[], Any],
        summary: Callable[[Counter[str], int], str] | None = None,
        scope: Callable[[], Iterable[Mission]] | None = None,
        sweep: Sequence[tuple[int, int]] = (),
    ) -> None:
        self.scope = scope
        self.sweep = tuple(sweep)
        self.evaluate = evaluate
        self.cells = tuple(cells)
        self.strategy = strategy
        self.summary = summary

    def _safe(self, claim: Claim, mission: Mission) -> _Outcome:
        try:
            return self.evaluate(claim, mission)
        except Exception as exc:  # a crash is a failure of the claim, with its mission
            return _Outcome(
                Counterexample(
                    mission,
                    Assignment.empty(mission),
                    claim.algorithms[0],
                    f"{claim.algorithms[0]} raised {type(exc).__name__}: {exc}",
                ),
                gap=math.inf,
            )

    def grid(self, n_missions: int, seed: int) -> Iterator[Mission]:
        for i in range(n_missions):
            cell = self.cells[i % len(self.cells)]
            yield cell.mission(i // len(self.cells), base_seed=seed)

    def family_sweep(self, n_missions: int, seed: int) -> Iterator[Mission]:
        """The seed's generator at small sizes, smallest first: for n = 3..12 robots, each
        of the claim's compositions, 10 and 50 % tasks, ``n_missions`` seeds each.

        Failures of the hedonic dynamics are rare at n = 100 but common among small
        missions of the same family (e.g. 3.6 % of 10:5 missions with 3..15 robots leave
        Pair-GRAPE-S short of the optimum), which a random search may miss.
        """
        for n in SWEEP_ROBOTS:
            for S, k in self.sweep:
                for p in (10, 50):
                    for i in range(n_missions):
                        yield generate_mission(n, p, S, k, seed=seed * 100_000 + i)

    def check(self, claim: Claim, n_missions: int, seed: int):
        tallies: Counter[str] = Counter()
        found: list[Counterexample] = []
        checked = 0
        for mission in self.grid(n_missions, seed):
            out = self._safe(claim, mission)
            checked += 1
            tallies.update(out.tallies)
            if out.failure is not None:
                tallies["failed (grid)"] += 1
                if not found:
                    found.append(out.failure)
        swept = 0
        for mission in self.family_sweep(n_missions, seed):
            out = self._safe(claim, mission)
            swept += 1
            tallies.update(out.tallies)
            if out.failure is not None:  # smallest first: stop at the first failure
                found.append(out.failure)
                break
        checked += swept
        searched, shrunk = self._search(claim, n_missions * SEARCH_FACTOR, seed, tallies)
        checked += searched
        notes = []
        if self.sweep:
            stop = " (stopped at the first failure)" if swept and found else ""
            notes.append(f"seed-family sweep n = 3..12: {swept} missions{stop}")
        if self.scope is not None and shrunk is None:
            scoped = 0
            for mission in self.scope():
                out = self._safe(claim, mission)
                scoped += 1
                if out.failure is not None:
                    shrunk = out.failure  # smallest first: minimal in the scope
                    break
            checked += scoped
            notes.append(f"small-scope search: {scoped} missions")
        if shrunk is not None:
            found.append(shrunk)
        if found:
            example = min(found, key=lambda c: (c.size, c.mission.requirements.sum()))
            if shrunk is None:
                notes.append(
                    "counterexample: a grid or sweep mission (the hypothesis search found "
                    "none to shrink)"
                )
            kind = VerdictKind.FAILS
        else:
            example, kind = None, VerdictKind.HOLDS
        if self.summary is not None:
            notes.append(self.summary(tallies, checked))
        notes.append(
            f"{n_missions} grid missions ({len(self.cells)} cells, n=100) + {searched} searched"
        )
        return kind, checked, example, "; ".join(n for n in notes if n)

    def _search(
        self, claim: Claim, max_examples: int, seed: int, tallies: Counter[str]
    ) -> tuple[int, Counterexample | None]:
        """``hypothesis.find`` the minimal failing mission; returns (missions drawn, it)."""
        from hypothesis import HealthCheck, Phase, find, settings, target
        from hypothesis.errors import NoSuchExample, Unsatisfiable

        state = {"drawn": 0, "failed": False}

        def fails(mission: Mission) -> bool:
            out = self._safe(claim, mission)
            if not state["failed"]:  # count the search, not the shrinking
                state["drawn"] += 1
                tallies.update(out.tallies)
            target(float(min(out.gap, 1e9)), label="gap")
            if out.failure is not None:
                state["failed"] = True
                return True
            return False

        config = settings(
            max_examples=max_examples,
            database=None,
            deadline=None,
            derandomize=False,
            suppress_health_check=list(HealthCheck),
            phases=(Phase.generate, Phase.target, Phase.shrink),
            print_blob=False,
            report_multiple_bugs=False,
        )
        try:
            mission = find(self.strategy(), fails, settings=config, random=random.Random(seed))
        except (NoSuchExample, Unsatisfiable):
            return state["drawn"], None
        out = self._safe(claim, mission)
        return state["drawn"], out.failure


# ----------------------------------------------------------------- strategies
def _structural(*, achievable: bool | None, load: float | None = None) -> Callable[[], Any]:
    """Small missions of :mod:`proofs.strategies` (up to 8 robots, 4 tasks, 4 services)."""

    def make() -> Any:
        from proofs import strategies

        if achievable:
            return strategies.achievable_missions(
                max_robots=8, max_tasks=4, max_services=4, load=load
            )
        return strategies.missions(max_robots=8, max_tasks=4, max_services=4)

    return make


def _generated(
    compositions: Sequence[tuple[int, int]],
    *,
    min_robots: int = 2,
    max_robots: int = 60,
    percents: Sequence[float] = (10, 50),
) -> Callable[[], Any]:
    """Missions of the seed's generator: drawn composition, size, percent tasks and seed.

    Shrinks towards fewer robots, the first composition and percentage, and seed 0; the
    mission records its generator arguments, so ``cfopt generate`` rebuilds it.
    """

    def make() -> Any:
        from hypothesis import strategies as st

        @st.composite
        def generated(draw: Any) -> Mission:
            S, k = draw(st.sampled_from(list(compositions)))
            n = draw(st.integers(min_robots, max_robots))
            p = draw(st.sampled_from(list(percents)))
            seed = draw(st.integers(0, 2**32 - 1))
            return generate_mission(n, p, S, k, seed=seed)

        return generated()

    return make


def small_scope(
    max_robots: int = 3, max_services: int = 3, max_tasks: int = 3, max_requirement: int = 2
) -> Iterator[Mission]:
    """Every small mission of a bounded scope, smallest first (a small-scope search).

    Robots are non-empty capability sets, tasks need one service each (``1..max_requirement``
    robots), utilities 1; robots and tasks are enumerated as multisets (sorted), sizes
    ascending (robots, then services, then tasks).  Rare failures of the hedonic dynamics
    live in such tiny missions, where random search needs ~10^4 draws to meet them.
    The default scope has about 5,000 missions (3 robots, 3 services, 3 tasks at most).

    >>> sum(1 for _ in small_scope(2, 2, 2))
    136
    """
    import itertools

    import numpy as np

    for n in range(1, max_robots + 1):
        for S in range(1, max_services + 1):
            subsets = [c for c in itertools.product((0, 1), repeat=S) if any(c)]
            needs = [(sv, r) for sv in range(S) for r in range(1, max_requirement + 1)]
            for T in range(1, max_tasks + 1):
                for caps in itertools.combinations_with_replacement(subsets, n):
                    for tasks in itertools.combinations_with_replacement(needs, T):
                        reqs = np.zeros((T, S), dtype=np.int64)
                        for j, (sv, r) in enumerate(tasks):
                            reqs[j, sv] = r
                        yield Mission.from_arrays(np.array(caps, dtype=bool), reqs, np.ones(T))


def _cells(compositions: Iterable[tuple[int, int]], robots: int = 100) -> list[GridCell]:
    wanted = set(compositions)
    return [
        c
        for c in paper_grid()
        if c.robots == robots and (c.service_types, c.services_per_robot) in wanted
    ]


_ALL = ((5, 1), (5, 5), (10, 1), (10, 5))
_EASY = ((5, 1), (5, 5), (10, 1))
_HARD = ((10, 5),)


def _tally_summary(*labels: str) -> Callable[[Counter[str], int], str]:
    def summary(tallies: Counter[str], checked: int) -> str:
        return ", ".join(f"{label}: {tallies[label]} of {checked}" for label in labels)

    return summary


# ---------------------------------------------------------- the properties
def _lemma1(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("pair-grape-s", m, seed=0, order="index")
    a = run.assignment
    capped = nash_violations(m, a, capped=True)
    uncapped = nash_violations(m, a)
    tallies = ("uncapped not Nash stable",) if uncapped else ()
    if not capped:
        return _Outcome(None, 0.0, tallies)
    detail = (
        f"Pair-GRAPE-S's partition is not Nash stable (capped moves): "
        f"{capped[0].describe(m)}" + (f" and {len(capped) - 1} more" if len(capped) > 1 else "")
    )
    return _Outcome(
        Counterexample(m, a, "pair-grape-s", detail),
        float(len(capped)),
        (*tallies, "capped not Nash stable"),
    )


def _theorem1(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("pair-grape-s", m, seed=0, order="index")
    a = run.assignment
    pareto = not is_pairwise_stable(m, a, mode="pareto", capped=True)
    tallies = ("not pareto pairwise stable",) if pareto else ()
    if not pareto or is_pairwise_stable(m, a, mode="strict", capped=True):
        return _Outcome(None, 0.0, tallies)  # strict violations are pareto violations
    strict = pairwise_violations(m, a, mode="strict", capped=True)
    v = strict[0]
    detail = (
        f"Pair-GRAPE-S's partition is not pairwise stable (strict, capped moves): "
        f"{v.kind} deviation {v.describe(m)}"
    )
    return _Outcome(Counterexample(m, a, "pair-grape-s", detail), float(len(strict)), tallies)


def _g1(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("grape-s", m, seed=0, order="index")
    found = nash_violations(m, run.assignment)
    if not found:
        return _Outcome(None)
    detail = f"GRAPE-S's partition is not Nash stable: {found[0].describe(m)}"
    return _Outcome(Counterexample(m, run.assignment, "grape-s", detail), float(len(found)))


def _optimal(name: str, label: str) -> Callable[[Claim, Mission], _Outcome]:
    def evaluate(claim: Claim, m: Mission) -> _Outcome:
        run = claim.run(name, m, seed=0, order="index")
        pct = _percent(m, run.assignment)
        if pct >= 100.0:
            return _Outcome(None)
        done = run.assignment.completed_tasks(m).size
        detail = (
            f"{label} earns {_fmt(run.assignment.utility(m))} of {_fmt(m.total_utility)} "
            f"({pct:.2f} %, {done} of {m.n_tasks} tasks) on an achievable mission"
        )
        return _Outcome(Counterexample(m, run.assignment, name, detail), 100.0 - pct)

    return evaluate


def _g3(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("grape-s", m, seed=0, order="index")
    if run.iterations == m.n_robots:
        return _Outcome(None)
    detail = f"GRAPE-S needs {run.iterations} iterations, n = {m.n_robots}"
    return _Outcome(
        Counterexample(m, run.assignment, "grape-s", detail),
        float(abs(run.iterations - m.n_robots)),
        ("more than n" if run.iterations > m.n_robots else "fewer than n",),
    )


def _g4(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("grape-s", m, seed=0, order="index")
    pct = _percent(m, run.assignment)
    tallies = ("below 100 %",) if pct < 100 else ()
    if pct >= 95.0:
        return _Outcome(None, 100.0 - pct, tallies)
    detail = f"GRAPE-S earns {pct:.2f} % < 95 % on an achievable 10:5 mission"
    return _Outcome(Counterexample(m, run.assignment, "grape-s", detail), 100.0 - pct, tallies)


def _x2(claim: Claim, m: Mission) -> _Outcome:
    run = claim.run("pair-grape-s", m, seed=0, order="index")
    tallies = ("pairwise step ran",) if run.pairwise_step_ran else ()
    if run.exchanges <= m.n_robots:
        return _Outcome(None, run.exchanges / max(m.n_robots, 1), tallies)
    detail = f"the pairwise step made {run.exchanges} exchanges > n = {m.n_robots}"
    return _Outcome(Counterexample(m, run.assignment, "pair-grape-s", detail), 2.0, tallies)


def _h4(claim: Claim, m: Mission) -> _Outcome:
    pair = claim.run("pair-grape-s", m, seed=0, order="index")
    grape = claim.run("grape-s", m, seed=0, order="index")
    up, ug = pair.assignment.utility(m), grape.assignment.utility(m)
    tally = "higher" if up > ug else "equal" if up == ug else "lower"
    if up >= ug:
        return _Outcome(None, 0.0, (tally,))
    detail = f"Pair-GRAPE-S earns {_fmt(up)} < GRAPE-S's {_fmt(ug)} of {_fmt(m.total_utility)}"
    return _Outcome(Counterexample(m, pair.assignment, "pair-grape-s", detail), ug - up, (tally,))


def _s1(claim: Claim, m: Mission) -> _Outcome:
    pair = claim.run("pair-grape-s", m, seed=0, order="index")
    if not pair.pairwise_step_ran:
        return _Outcome(None)
    first = claim.run("grape-s", m, seed=0, order="index", capped=True)
    if _percent(m, first.assignment) < 100.0:
        return _Outcome(None, 0.0, ("pairwise step ran",))
    detail = "the pairwise step ran although Pair-GRAPE-S's GRAPE-S phase was already optimal"
    return _Outcome(
        Counterexample(m, pair.assignment, "pair-grape-s", detail), 1.0, ("pairwise step ran",)
    )


def _i1(claim: Claim, m: Mission) -> _Outcome:
    pair = claim.run("pair-grape-s", m, seed=0, order="index")
    grape = claim.run("grape-s", m, seed=0, order="index")
    if pair.assignment == grape.assignment and pair.iterations == grape.iterations:
        return _Outcome(None)
    moved = int((pair.assignment.task != grape.assignment.task).sum()) + int(
        (pair.assignment.service != grape.assignment.service).sum()
    )
    detail = (
        f"Pair-GRAPE-S differs from GRAPE-S: {pair.iterations} vs {grape.iterations} "
        f"iterations, utility {_fmt(pair.assignment.utility(m))} vs "
        f"{_fmt(grape.assignment.utility(m))}"
    )
    return _Outcome(
        Counterexample(m, pair.assignment, "pair-grape-s", detail),
        float(moved + abs(pair.iterations - grape.iterations)),
    )


# ------------------------------------------------------------- scaling claims
@dataclass(frozen=True)
class _Part:
    algorithm: str
    measure: str
    exponent: float
    why: str
    #: Keyword options of the runs, e.g. the communication model a messages part is about.
    options: tuple[tuple[str, Any], ...] = ()

    @property
    def label(self) -> str:
        """The algorithm, with its pinned options: ``grape-s [medium=unicast]``."""
        if not self.options:
            return self.algorithm
        return f"{self.algorithm} [{', '.join(f'{k}={v}' for k, v in self.options)}]"


#: A messages part is about point-to-point messages: one per receiver (the toolkit's
#: counts before the broadcast default, the model the seed's O(...) bounds are read in).
_UNICAST = (("medium", "unicast"),)


class _ScalingMethod:
    """Fitted exponents in ``n`` (10 % tasks, 10:5) against the seed's, per part."""

    def __init__(
        self, parts: Sequence[_Part], extra: Callable[[Claim, int], list[str]] | None = None
    ):
        self.parts = tuple(parts)
        self.extra = extra

    def check(self, claim: Claim, n_missions: int, seed: int):
        per_rung = min(5, max(2, math.ceil(n_missions / 5)))
        seeds = list(range(seed, seed + per_rung))
        notes, kinds, checked = [], [], 0
        cache: dict[tuple[str, tuple[tuple[str, Any], ...]], list[Any]] = {}
        failing: tuple[_Part, Fit] | None = None
        for part in self.parts:
            sizes = _SDA_LADDER_SIZES if part.algorithm == "sda" else LADDER_SIZES
            key = (part.algorithm, part.options)
            if key not in cache:
                cache[key] = ladder(
                    _bound_runner(claim, part.algorithm, dict(part.options)), sizes, seeds=seeds
                )
                checked += len(cache[key])
            fit = fit_rungs(cache[key], part.measure, "n")
            kind = _exponent_verdict(fit, part.exponent)
            kinds.append(kind)
            if kind is VerdictKind.FAILS and failing is None:
                failing = (part, fit)
            notes.append(
                f"{part.label} {part.measure} ~ n^{fit} vs seed n^{part.exponent:g} "
                f"({part.why}): {kind.value}"
            )
        if self.extra is not None:
            notes += self.extra(claim, seed)
        if VerdictKind.FAILS in kinds:
            kind = VerdictKind.FAILS
        elif VerdictKind.INCONCLUSIVE in kinds:
            kind = VerdictKind.INCONCLUSIVE
        else:
            kind = VerdictKind.HOLDS
        example = None
        if failing is not None:
            part, fit = failing
            sizes = _SDA_LADDER_SIZES if part.algorithm == "sda" else LADDER_SIZES
            mission = ladder_mission(sizes[-1], seeds[0])
            run = claim.run(part.algorithm, mission, seed=seeds[0], **dict(part.options))
            example = Counterexample(
                mission,
                run.assignment,
                part.algorithm,
                f"largest ladder mission: {part.measure} = {getattr(run, part.measure)}; "
                f"fitted exponent {fit} exceeds the seed's {part.exponent:g} + "
                f"{EXPONENT_TOLERANCE}",
            )
        notes.append(f"ladder n = {', '.join(map(str, LADDER_SIZES))}, {per_rung} seeds each")
        return kind, checked, example, "; ".join(notes)


def _bound_runner(claim: Claim, name: str, options: Mapping[str, Any] | None = None) -> Runner:
    def runner(mission: Mission, *, seed: int) -> Any:
        return claim.run(name, mission, seed=seed, order="index", **(options or {}))

    runner.__name__ = name
    return runner


def _exponent_verdict(fit: Fit, exponent: float) -> VerdictKind:
    limit = exponent + EXPONENT_TOLERANCE
    if fit.ci_high <= limit:
        return VerdictKind.HOLDS
    if fit.ci_low > limit:
        return VerdictKind.FAILS
    return VerdictKind.INCONCLUSIVE


def _x1_extra(claim: Claim, seed: int) -> list[str]:
    """GRAPE-S's work in m (n, S fixed) and in S (n, m fixed), each against exponent 1."""
    from proofs.scaling import service_ladder, task_ladder

    runner = _bound_runner(claim, "grape-s")
    seeds = [seed, seed + 1]
    out = []
    for variable, rungs in (
        ("m", task_ladder(runner, (2.5, 5, 10, 20, 40), seeds=seeds)),
        ("S", service_ladder(runner, (2, 4, 8, 16), seeds=seeds)),
    ):
        fit = fit_rungs(rungs, "work", variable)
        out.append(
            f"grape-s work ~ {variable}^{fit} vs seed {variable}^1: "
            f"{_exponent_verdict(fit, 1).value}"
        )
    return out


# --------------------------------------------------------------------- registry
def _property(
    id: str,
    statement: str,
    family: str,
    algorithms: tuple[str, ...],
    evaluate: Callable[[Claim, Mission], _Outcome],
    cells: Sequence[GridCell],
    strategy: Callable[[], Any],
    summary: Callable[[Counter[str], int], str] | None = None,
    scope: Callable[[], Iterable[Mission]] | None = None,
    sweep: Sequence[tuple[int, int]] = (),
) -> Claim:
    if sweep:
        family += (
            "; plus a seed-family sweep: the seed's generator at n = 3..12, compositions "
            + ", ".join(f"{S}:{k}" for S, k in sweep)
            + ", 10 and 50 % tasks, smallest first"
        )
    return Claim(
        id,
        statement,
        family,
        algorithms,
        _PropertyMethod(evaluate, cells, strategy, summary, scope, sweep),
    )


def _scaling(id: str, statement: str, parts: Sequence[_Part], extra: Any = None) -> Claim:
    algorithms = tuple(dict.fromkeys(p.algorithm for p in parts))
    family = (
        "size ladder n = 25..400 (SDA: ..200), 10 % tasks (m proportional to n), 10:5, "
        "load 1; u_max = 50, d_G = 1 (fully connected)"
    )
    return Claim(id, statement, family, algorithms, _ScalingMethod(parts, extra))


_ANY_FAMILY = (
    "any mission: the seed's grid cells with n = 100 (all compositions) and hypothesis-drawn "
    "missions of up to 8 robots, 4 tasks, 4 services (any capabilities, any requirements)"
)
_SCOPED = (
    "; when the search finds nothing, every mission of the small scope (small_scope(): up "
    "to 3 robots, 3 services, 3 one-service tasks) is checked, smallest first"
)
_ACHIEVABLE_FAMILY = (
    "achievable missions (requirements sum to n, a complete assignment exists): the seed's "
    "grid cells with n = 100 and hypothesis-drawn achievable missions of up to 8 robots, "
    "4 tasks, 4 services"
)


def _build() -> dict[str, Claim]:
    claims = [
        _property(
            "L1",
            'Lemma 1 (§4.1): "Algorithm 2 produces a Nash stable solution, given the reward '
            'function specified by Eq. 4.2 and u_js = |S_s|."',
            _ANY_FAMILY + _SCOPED + "; Nash stability with capped moves (Pair-GRAPE-S's move set), "
            "uncapped reported in the note",
            ("pair-grape-s",),
            _lemma1,
            _cells(_ALL),
            _structural(achievable=None),
            _tally_summary("capped not Nash stable", "uncapped not Nash stable"),
            small_scope,
            sweep=_ALL,
        ),
        _property(
            "T1",
            'Theorem 1 (§4.1): "Algorithm 2 produces a pairwise stable solution, given the '
            'reward function specified by Eq. 4.2 and u_js = |S_s|."',
            _ANY_FAMILY + _SCOPED + "; strict pairwise stability (both deviators strictly better), "
            "capped moves; the pareto notion reported in the note",
            ("pair-grape-s",),
            _theorem1,
            _cells(_ALL),
            _structural(achievable=None),
            _tally_summary("not pareto pairwise stable"),
            small_scope,
            sweep=_ALL,
        ),
        _property(
            "G1",
            'GRAPE-S (§4, Algorithm 1): "The algorithm finishes when Nash stability is reached."',
            _ANY_FAMILY + "; uncapped moves",
            ("grape-s",),
            _g1,
            _cells(_ALL),
            _structural(achievable=None),
            sweep=_ALL,
        ),
        _property(
            "G2",
            '§5.1.3: "GRAPE-S produced optimal solutions with five services and one service '
            "per robot, five services and five services per robot, and ten services and one "
            'service per robot."',
            "achievable missions of the seed's generator (load 1) with compositions 5:1, 5:5, "
            "10:1: grid cells n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("grape-s",),
            _optimal("grape-s", "GRAPE-S"),
            _cells(_EASY),
            _generated(_EASY),
            sweep=_EASY,
        ),
        _property(
            "G3",
            '§5.1.1: "All other collective compositions [than 10:5] required exactly n '
            'iterations, where n is the collective size."',
            "achievable missions of the seed's generator (load 1), 5:1, 5:5, 10:1: grid cells "
            "n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("grape-s",),
            _g3,
            _cells(_EASY),
            _generated(_EASY),
            _tally_summary("more than n", "fewer than n"),
            sweep=_EASY,
        ),
        _property(
            "G4",
            "Abstract and §5.1.3: GRAPE-S produces near optimal solutions (> 95 % utility) on "
            "10:5 collectives (the seed itself reports a minimum of 89.68 %, n = 100, 10 % "
            "tasks)",
            "achievable 10:5 missions of the seed's generator (load 1) of the seed's sizes: "
            "grid cells n = 100, and generated missions of 100..150 robots, 10 or 50 % tasks",
            ("grape-s",),
            _g4,
            _cells(_HARD),
            _generated(_HARD, min_robots=100, max_robots=150),
            _tally_summary("below 100 %"),
        ),
        _property(
            "P1",
            '§5.1.3: "Pair-GRAPE-S produced optimal solutions for all problems"; §1: '
            '"producing optimal solutions for all of the coalition formation problems '
            'considered"',
            _ACHIEVABLE_FAMILY + " (load 1, the seed's missions)",
            ("pair-grape-s",),
            _optimal("pair-grape-s", "Pair-GRAPE-S"),
            _cells(_ALL),
            _structural(achievable=True, load=1.0),
            sweep=_ALL,
        ),
        _property(
            "R1",
            '§5.1.3: "RACHNA_dt, and Pair-GRAPE-S when applicable had the highest percent '
            'utilities, producing optimal solutions for all trials"; §3.1: "produces '
            'empirically optimal solutions"',
            _ACHIEVABLE_FAMILY + " (load 1, the seed's missions); RACHNA_dt as "
            ":func:`heuristics.rachna_dt` runs it by default: simultaneous bidding, the "
            "faithful reading",
            ("rachna-dt",),
            _optimal("rachna-dt", "RACHNA_dt"),
            _cells(_ALL),
            _structural(achievable=True, load=1.0),
            sweep=_ALL,
        ),
        _scaling(
            "X1",
            '§4: GRAPE-S uses "O(n^2 |S| m d_G) computation" (counted work: slot '
            "examinations; exponent 3 in n with m proportional to n, 1 in m, 1 in S)",
            [_Part("grape-s", "work", 3, "n^2 m, m ~ n")],
            _x1_extra,
        ),
        _property(
            "X2",
            '§4.1: "Algorithm 2 requires at most O(n) reassignments" (checked: the pairwise '
            "step makes at most n exchanges)",
            _ANY_FAMILY,
            ("pair-grape-s",),
            _x2,
            _cells(_ALL),
            _structural(achievable=None),
            _tally_summary("pairwise step ran"),
            sweep=_ALL,
        ),
        _scaling(
            "X3",
            '§4: GRAPE-S uses "O(n^3 d_G) communication" (messages, counted point to point: '
            "medium=unicast, one message per receiver; d_G = 1)",
            [_Part("grape-s", "messages", 3, "n^3", _UNICAST)],
        ),
        _scaling(
            "X4",
            "§4.1: \"Pair-GRAPE-S's overall computational and communication complexities are "
            'identical to GRAPE-S" (O(n^2 |S| m d_G) work, O(n^3 d_G) messages counted point '
            "to point: medium=unicast; the work does not depend on the medium)",
            [
                _Part("pair-grape-s", "work", 3, "n^2 m, m ~ n", _UNICAST),
                _Part("pair-grape-s", "messages", 3, "n^3", _UNICAST),
            ],
        ),
        _scaling(
            "X5",
            "§3.1: \"SDA's computational complexity is O(m n^4 u_max / eps_d)\" (the toolkit's "
            "reading of SDA, :func:`heuristics.sda`; work: bundle cost-matrix entries)",
            [_Part("sda", "work", 5, "m n^4, m ~ n")],
        ),
        _scaling(
            "X6",
            '§3.1: SDA\'s "communication complexity is O((m + n) |S| u_max / eps_d)" (the '
            "toolkit's reading and point-to-point message model of SDA, :func:`heuristics.sda` "
            "with medium=unicast)",
            [_Part("sda", "messages", 1, "m + n, m ~ n", _UNICAST)],
        ),
        _scaling(
            "X7",
            '§3.1: "RACHNA_dt\'s computational ... complexities are O(m n^3 log n (u_max))" '
            "(the toolkit's faithful reading, simultaneous bidding, the default of "
            ":func:`heuristics.rachna_dt`; the log n factor inside the tolerance)",
            [_Part("rachna-dt", "work", 4, "m n^3 log n, m ~ n")],
        ),
        _scaling(
            "X8",
            '§3.1: RACHNA_dt\'s communication complexity is "O(n^3 m |S| (u_max))" (the '
            "toolkit's faithful reading, simultaneous bidding, the default of "
            ":func:`heuristics.rachna_dt`, and its message model counted point to point: "
            "medium=unicast)",
            [_Part("rachna-dt", "messages", 4, "n^3 m, m ~ n", _UNICAST)],
        ),
        _property(
            "H4",
            "§5.2 (H4): \"The hypothesis (H_4) that Pair-GRAPE-S's utilities are higher than "
            "GRAPE-S's was supported\" (checked per mission: never lower)",
            "achievable 10:5 missions of the seed's generator (load 1): grid cells n = 100, and "
            "generated missions of 2..60 robots, 10 or 50 % tasks",
            ("pair-grape-s", "grape-s"),
            _h4,
            _cells(_HARD),
            _generated(_HARD),
            _tally_summary("higher", "equal", "lower"),
            sweep=_HARD,
        ),
        _property(
            "S1",
            '§5.1: "Pair-GRAPE-S uses its extra pairwise stability step only when a '
            'suboptimal solution is initially produced"',
            _ACHIEVABLE_FAMILY + " (load 1); 'initially produced' = Pair-GRAPE-S's own "
            "(capped) GRAPE-S phase",
            ("pair-grape-s", "grape-s"),
            _s1,
            _cells(_ALL),
            _structural(achievable=True, load=1.0),
            _tally_summary("pairwise step ran"),
            sweep=_ALL,
        ),
        _property(
            "I1",
            '§5: "Pair-GRAPE-S is identical to GRAPE-S for the other three collective '
            "compositions, where the collectives are homogeneous or possesses only single "
            'service robots" (checked: same partition, same iterations)',
            "achievable missions of the seed's generator (load 1), 5:1, 5:5, 10:1: grid cells "
            "n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("pair-grape-s", "grape-s"),
            _i1,
            _cells(_EASY),
            _generated(_EASY),
            sweep=_EASY,
        ),
    ]
    from proofs.claims_chain import chain_claims
    from proofs.claims_select import select_claims
    from proofs.distributed import distributed_claims

    claims += distributed_claims()
    claims += chain_claims()
    claims += select_claims()
    return {c.id: c for c in claims}


class _Claims(Mapping[str, Claim]):
    """The claims by id, built on first use (the modules of the further claims import this
    one, so they are gathered only once everything is defined)."""

    def __init__(self) -> None:
        self._built: dict[str, Claim] | None = None

    def _claims(self) -> dict[str, Claim]:
        if self._built is None:
            self._built = _build()
        return self._built

    def __getitem__(self, key: str) -> Claim:
        return self._claims()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._claims())

    def __len__(self) -> int:
        return len(self._claims())

    def __repr__(self) -> str:
        return f"CLAIMS({', '.join(self)})"


#: The claims, in the audit's order: the seed's stability, optimality and complexity
#: claims (L1 ... X2), further statements of the seed (X3 ... I1), its distributed claims
#: (D1 ... X9), then cfopt's claims about its own algorithms (C1 ...).
CLAIMS: Mapping[str, Claim] = _Claims()


# --------------------------------------------------------------------- the audit
def audit_claims(
    *, budget: int = 25, seed: int = 0, ids: Iterable[str] | None = None
) -> list[Verdict]:
    """Check claims (all of :data:`CLAIMS`, or ``ids`` in the given order).

    Parameters
    ----------
    budget : int, default 25
        ``n_missions`` of each :meth:`Claim.check`.
    seed : int, default 0
    ids : iterable of str, optional
        Claim ids; an unknown id raises :class:`cfopt.MissionError` naming the known ones.

    Returns
    -------
    list of Verdict

    Notes
    -----
    Imports hypothesis (a runtime dependency) on first use.  With the default budget the
    whole audit takes about a minute (L1 and T1's small-scope searches: ~15 s each).
    """
    chosen = list(CLAIMS) if ids is None else list(ids)
    unknown = [i for i in chosen if i not in CLAIMS]
    if unknown:
        raise MissionError(f"unknown claim {unknown[0]!r} (known: {', '.join(CLAIMS)})")
    return [CLAIMS[i].check(budget, seed) for i in chosen]


def write_counterexamples(
    verdicts: Iterable[Verdict], directory: str | Path, *, overwrite: bool = False
) -> list[Path]:
    """Write ``<id>.mission.json`` and ``<id>.assignment.json`` for every failed claim, and
    ``<id>.network.json`` when the counterexample is a distributed run.

    Replay with ``cfopt check DIR/<id>.mission.json DIR/<id>.assignment.json`` and
    ``cfopt run ALGORITHM DIR/<id>.mission.json`` (the algorithm is the counterexample's;
    a distributed one with ``--network DIR/<id>.network.json --seed SEED``).  Existing files
    are not overwritten unless ``overwrite=True`` (:class:`cfopt.MissionError` names the
    first one; nothing is written then); each file is written atomically.  ``directory``
    is created if missing (its parent must exist).  Returns the paths written.
    """
    from cfopt._jsonio import check_folder, make_directory, stat_path, write_text

    directory = Path(directory)
    plan: list[tuple[Path, str]] = []
    for v in verdicts:
        ce = v.counterexample
        if ce is None:
            continue
        plan.append((directory / f"{v.claim_id}.mission.json", ce.mission.to_json()))
        plan.append(
            (directory / f"{v.claim_id}.assignment.json", ce.assignment.to_json(ce.mission))
        )
        if ce.network is not None:
            from heuristics.network import NetworkSpec

            spec = NetworkSpec.parse(ce.network)
            plan.append((directory / f"{v.claim_id}.network.json", spec.to_json()))
    if not overwrite:
        for path, _ in plan:
            if stat_path(path, follow_symlinks=False) is not None:
                raise MissionError(
                    f"{path}: exists (use overwrite=True to replace it)",
                    cli=f"{path}: exists (pass --force to replace it)",
                )
    if plan:
        check_folder(directory)
        make_directory(directory)
    for path, text in plan:
        write_text(text, path, overwrite=overwrite)
    return [path for path, _ in plan]


def format_verdict_table(verdicts: Sequence[Verdict], *, width: int = 60) -> str:
    """A plain-text table: id, statement (cut to ``width``), verdict, missions, size.

    The counterexample size is ``robots/tasks/services``, ``-`` when there is none.
    """
    header = ("id", "statement", "verdict", "missions", "counterexample")
    body = []
    for v in verdicts:
        text = " ".join(v.statement.split())
        if len(text) > width:
            text = text[: width - 3] + "..."
        size = "-" if v.counterexample is None else "/".join(map(str, v.counterexample.size))
        body.append((v.claim_id, text, v.verdict.value, str(v.instances_checked), size))
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in [header, *body]
    )
