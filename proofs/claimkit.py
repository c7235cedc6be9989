"""The claims kit: state a claim about any algorithm, check it, get a verdict.

A :class:`Claim` is a statement, the missions it ranges over (its *family*, in words, and
its :class:`Scope`) and a check.  :meth:`Claim.check` returns a :class:`Verdict` --
``holds`` (no counterexample among the missions checked; never a proof), ``fails`` (with
a :class:`Counterexample`: a mission and the partition the algorithm produced on it) or
``inconclusive``.  The seed paper's claims (:mod:`proofs.claims_seed`,
:mod:`proofs.claims_distributed`) and cfopt's own (:mod:`proofs.claims_cfopt`) are built
from this module's public names only; a claim of yours is built the same way and
registered with :func:`proofs.register_claim`, an entry point of group ``cfopt.claims``,
or named as ``MODULE:ATTR`` on the command line (``cfopt audit --claims MODULE:ATTR``).

Two kinds of claim come ready-made:

Property claims (:func:`property_claim`)
    A claim about single runs: ``evaluate(claim, mission)`` returns an :class:`Evaluation`
    (the failure, if the mission breaks the property; a *gap* >= 0 saying how badly it
    fails or how close it comes; labels tallied in the verdict's note).  The check
    (:class:`PropertyCheck`) runs it on

    1. ``n_missions`` *seeded missions of the seed's grid* (``cells``, e.g.
       :func:`grid_cells`), in the same order on every machine;
    2. a *seed-family sweep* (``sweep``): the seed's generator at n = 3..12 robots for
       the given compositions, smallest first, up to the first failure;
    3. a *hypothesis search* (``hypothesis.find``) of ``SEARCH_FACTOR * n_missions``
       missions drawn from ``strategy`` (:func:`structural_missions`,
       :func:`generated_missions`, or any strategy factory of yours), with
       ``hypothesis.target`` steering towards a larger gap; a failure is **shrunk** to a
       minimal mission of the family;
    4. when the search finds nothing, every mission of ``exhaustive`` (e.g.
       :func:`small_scope`), smallest first.

    The smallest counterexample found is reported.

Scaling claims (:func:`scaling_claim`)
    Counted work or messages of algorithms on a size ladder (:mod:`proofs.scaling`),
    fitted in log-log space against a stated exponent (an upper bound): the claim
    *holds* when the fitted interval lies at or below ``exponent + EXPONENT_TOLERANCE``,
    *fails* when it lies above, and is *inconclusive* otherwise.

Statistical claims
    A claim about a statistic (a median, an aggregate hypothesis) is checked on a sample:
    :func:`median_estimate` gives the median with its distribution-free confidence
    interval and the sample size, :func:`interval_verdict` turns it into *holds* (the
    interval inside the bound), *fails* (wholly outside) or *inconclusive at this
    budget*; :func:`paired_comparison` tallies paired values and tests them (Wilcoxon
    signed-rank, one-sided both ways).  Such a verdict never has a counterexample; a
    decision needs the whole interval on one side, so a small budget (``--quick``) says
    *inconclusive* where a larger one decides, rather than the opposite verdict.

Any other check is an object with a ``check(claim, n_missions, seed)`` method returning
``(VerdictKind, missions checked, Counterexample or None, note)`` (:class:`ClaimCheck`),
given to :class:`Claim` directly.  A distributed claim names its network
(:attr:`Claim.network`); :attr:`Verdict.scope_text` says the scope with it.

Algorithms are run through :meth:`Claim.run`: the public registry
(``heuristics.get_algorithm``) unless :meth:`Claim.with_algorithm` substituted another
implementation; an ``evaluate`` may also call any function of yours directly.

Dependencies: the search needs hypothesis (a runtime dependency of cfopt); importing this
module does not import it, a check does.

Examples
--------
A claim of your own: "my greedy assigner earns at least 90 % of the optimum on achievable
missions", about a plain function (no registration needed to check it):

>>> import numpy as np
>>> import cfopt
>>> from proofs import claimkit as ck
>>> def my_greedy(mission):
...     # each robot in index order takes the first still-short slot it can serve
...     short = mission.requirements.copy()
...     task = np.full(mission.n_robots, -1)
...     service = np.full(mission.n_robots, -1)
...     for robot in range(mission.n_robots):
...         open_slots = np.argwhere((short > 0) & mission.capabilities[robot])
...         if len(open_slots):
...             task[robot], service[robot] = open_slots[0]
...             short[task[robot], service[robot]] -= 1
...     return cfopt.Assignment(task=task, service=service)
>>> def at_least_90(claim, mission):
...     assignment = my_greedy(mission)
...     got, best = assignment.utility(mission), cfopt.solve_exact(mission).utility
...     if got >= 0.9 * best:
...         return ck.Evaluation(None, gap=max(0.0, 1 - got / best) if best else 0.0)
...     detail = f"my-greedy earns {got:g} of the optimum {best:g}"
...     return ck.Evaluation(
...         ck.Counterexample(mission, assignment, "my-greedy", detail), gap=1 - got / best
...     )
>>> claim = ck.property_claim(
...     "MY1",
...     "my-greedy earns at least 90 % of the optimum on achievable missions",
...     ck.ACHIEVABLE_FAMILY,
...     ("my-greedy",),
...     at_least_90,
...     scope=ck.Scope.GENERALISATION,
...     strategy=ck.structural_missions(achievable=True),
... )
>>> verdict = claim.check(2, seed=0)
>>> verdict.verdict.value, verdict.scope is ck.Scope.GENERALISATION
('fails', True)
>>> ce = verdict.counterexample  # shrunk by hypothesis: a small mission
>>> ce.size[0] <= 8, my_greedy(ce.mission) == ce.assignment
(True, True)

Put ``claim`` in a module ``my_claims.py`` and ``cfopt audit --claims my_claims:claim
--claims-only`` checks it, writing the counterexample's mission and assignment files.
"""

from __future__ import annotations

import enum
import itertools
import math
import random
import re
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from cfopt import Assignment, GridCell, Mission, MissionError, generate_mission, paper_grid
from cfopt.checks import require_int
from proofs.scaling import Fit, fit_rungs, ladder, ladder_mission
from proofs.stability import nash_violations

__all__ = [
    "ACHIEVABLE_FAMILY",
    "ALL_COMPOSITIONS",
    "ALPHA",
    "ANY_FAMILY",
    "CONFIDENCE",
    "EASY_COMPOSITIONS",
    "EXPONENT_TOLERANCE",
    "HARD_COMPOSITIONS",
    "LADDER_SIZES",
    "SEARCH_FACTOR",
    "SMALL_SCOPE_FAMILY",
    "SWEEP_ROBOTS",
    "UNICAST",
    "CheckResult",
    "Claim",
    "ClaimCheck",
    "Counterexample",
    "Evaluation",
    "Evaluator",
    "MedianEstimate",
    "MissionStrategy",
    "PairedComparison",
    "PropertyCheck",
    "Runner",
    "ScalingCheck",
    "ScalingPart",
    "Scope",
    "Verdict",
    "VerdictKind",
    "achievable",
    "achievable_small_scope",
    "bound_runner",
    "budget_note",
    "capped_nash_claim",
    "capped_nash_stable",
    "exponent_verdict",
    "format_number",
    "generated_missions",
    "grid_cells",
    "interval_verdict",
    "median_estimate",
    "paired_comparison",
    "property_claim",
    "scaling_claim",
    "scope_text",
    "small_scope",
    "structural_missions",
    "tally_summary",
    "verdict_words",
    "worst_verdict",
]

#: Drawn missions of the hypothesis search per seeded grid mission.
SEARCH_FACTOR = 4
#: How far above the stated exponent a fitted exponent may lie and still count as holding.
EXPONENT_TOLERANCE = 0.25
#: Collective sizes of the complexity ladders (``m`` in proportion, 10 % tasks, 10:5).
LADDER_SIZES = (25, 50, 100, 200, 400)
#: Collective sizes of the seed-family sweep of the property claims (smallest first).
SWEEP_ROBOTS = tuple(range(3, 13))
#: The seed's collective compositions (service types : services per robot): all of them,
#: those where its algorithms are reported optimal, and the heterogeneous 10:5.
ALL_COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
EASY_COMPOSITIONS = ((5, 1), (5, 5), (10, 1))
HARD_COMPOSITIONS = ((10, 5),)
#: A claim id: a letter or digit, then letters, digits, ``.``, ``_`` or ``-`` (it names
#: the counterexample files ``<id>.mission.json``...).
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}\Z")
#: Above this many needed services :func:`achievable` asks the exact ILP instead of
#: enumerating Hall's condition over service subsets.
_HALL_MAX_SERVICES = 16

#: Family texts of the ready-made mission families, for a claim's ``family``.
ANY_FAMILY = (
    "any mission: the seed's grid cells with n = 100 (all compositions) and hypothesis-drawn "
    "missions of up to 8 robots, 4 tasks, 4 services (any capabilities, any requirements)"
)
SMALL_SCOPE_FAMILY = (
    "; when the search finds nothing, every mission of the small scope (small_scope(): up "
    "to 3 robots, 3 services, 3 one-service tasks) is checked, smallest first"
)
ACHIEVABLE_FAMILY = (
    "achievable missions (requirements sum to n, a complete assignment exists): the seed's "
    "grid cells with n = 100 and hypothesis-drawn achievable missions of up to 8 robots, "
    "4 tasks, 4 services"
)


# ----------------------------------------------------------------------- results
class VerdictKind(enum.Enum):
    """What the check of a claim concluded."""

    HOLDS = "holds"
    FAILS = "fails"
    INCONCLUSIVE = "inconclusive"


class Scope(enum.Enum):
    """What a claim's check ranges over (its value is the text a report shows).

    >>> Scope.PAPER_SIZES.value
    "at the paper's sizes"
    """

    #: The paper's own grid and sizes (its cells, 100 robots and up).
    PAPER_SIZES = "at the paper's sizes"
    #: The paper's mission family at any size, small missions included.
    GENERALISATION = "a generalisation to the paper's family at any size"
    #: Distributed runs on cfopt's simulator, under the network the claim states.
    SIMULATOR = "on cfopt's simulator under a stated network"


def scope_text(scope: Scope | None, network: str | None = None) -> str:
    """A claim's scope in words, naming its network when it has one.

    >>> scope_text(Scope.SIMULATOR, "seed")
    "on cfopt's simulator under network `seed`"
    >>> scope_text(Scope.GENERALISATION)
    "a generalisation to the paper's family at any size"
    """
    if network is None:
        return "-" if scope is None else scope.value
    simulator = f"on cfopt's simulator under network `{network}`"
    if scope is None or scope is Scope.SIMULATOR:
        return simulator
    return f"{scope.value}, {simulator}"


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
        """``{"mission", "assignment", "algorithm", "detail", "network", "seed"}``, the first
        two in the ``cfopt.mission/1`` and ``cfopt.assignment/1`` formats."""
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
    """The outcome of :meth:`Claim.check` (an entry of ``cfopt audit --json``'s ``claims``).

    ``scope`` is the checked claim's :class:`Scope` (``None`` for a verdict stored before
    claims had one) and ``network`` the network its distributed runs used (``None``: no
    simulator); :attr:`scope_text` says both in words.
    """

    claim_id: str
    statement: str
    verdict: VerdictKind
    instances_checked: int
    counterexample: Counterexample | None
    seconds: float
    note: str = ""
    scope: Scope | None = None
    network: str | None = None

    @property
    def scope_text(self) -> str:
        """The scope in words, with the network (``"-"`` for a verdict without a scope).

        >>> Verdict("D4", "s", VerdictKind.FAILS, 1, None, 0.0, scope=Scope.PAPER_SIZES,
        ...         network="seed").scope_text
        "at the paper's sizes, on cfopt's simulator under network `seed`"
        """
        return scope_text(self.scope, self.network)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Verdict:
        """The verdict :meth:`to_dict` described (the counterexample rebuilt and validated;
        ``scope`` ``None`` when the object has none)."""
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
        scope = data.get("scope")
        return cls(
            claim_id=data["id"],
            statement=data["statement"],
            verdict=VerdictKind(data["verdict"]),
            instances_checked=int(data["instances_checked"]),
            counterexample=counterexample,
            seconds=float(data["seconds"]),
            note=data.get("note", ""),
            scope=None if scope is None else Scope(scope),
            network=data.get("network"),
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready; ``verdict`` is ``"holds"``, ``"fails"`` or ``"inconclusive"``,
        ``scope`` the :class:`Scope`'s text (or ``None``), ``network`` the claim's network
        (or ``None``) and ``scope_text`` the two in words."""
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
            "scope": None if self.scope is None else self.scope.value,
            "network": self.network,
            "scope_text": self.scope_text,
        }


@dataclass(frozen=True)
class Evaluation:
    """One mission's evaluation by a property claim.

    Attributes
    ----------
    failure : Counterexample or None
        The counterexample when the mission breaks the property.
    gap : float, default 0.0
        >= 0, steers the search (``hypothesis.target``): larger means the property fails
        worse, or comes closer to failing.
    tallies : tuple of str
        Labels counted over the missions checked, for the verdict's note
        (:func:`tally_summary`).
    """

    failure: Counterexample | None
    gap: float = 0.0
    tallies: tuple[str, ...] = ()


# ------------------------------------------------------------------------ claims
#: An algorithm: ``function(mission, *, seed, order, **options)`` returning a run.
Runner = Callable[..., Any]
#: A check's finding: the verdict, missions checked, the counterexample and the note.
CheckResult = tuple[VerdictKind, int, Counterexample | None, str]


class ClaimCheck(Protocol):
    """How a claim is checked: any object with this method (e.g. :class:`PropertyCheck`)."""

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        """Check ``claim`` with budget ``n_missions`` and base ``seed``."""
        ...  # pragma: no cover


@dataclass(frozen=True)
class Claim:
    """One claim, executable.

    Attributes
    ----------
    id : str
        ``L1``, ``T1``, ``G1``... (a letter or digit, then letters, digits, ``.``, ``_``
        or ``-``; at most 64 characters): the key of :data:`proofs.claims.CLAIMS` and the
        name of its counterexample files.
    statement : str
        The claim, quoting its source (the seed's claims: with their section).
    family : str
        The missions the claim ranges over and how they are drawn.
    algorithms : tuple of str
        Names of the algorithms the check runs (registry names, or labels of functions an
        ``evaluate`` calls itself); the first names a crash's counterexample.
    method : ClaimCheck
        The check (:class:`PropertyCheck`, :class:`ScalingCheck` or your own).
    scope : Scope
        What the check ranges over.
    overrides : tuple of (str, callable)
        Replacement implementations (see :meth:`with_algorithm`).
    network : str, optional
        The network a distributed claim's runs use (a ``--network`` spec or profile name,
        e.g. ``seed``); the verdict table shows it with the scope.
    """

    id: str
    statement: str
    family: str
    algorithms: tuple[str, ...]
    method: ClaimCheck = field(repr=False, compare=False)
    scope: Scope
    overrides: tuple[tuple[str, Runner], ...] = field(default=(), compare=False)
    network: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not _ID.match(self.id):
            raise MissionError(
                f"Claim.id: must be a letter or digit, then letters, digits, '.', '_' or '-' "
                f"(at most 64 characters), got {self.id!r}"
            )
        for name in ("statement", "family"):
            if not isinstance(getattr(self, name), str):
                raise MissionError(f"Claim.{name}: must be text, got {getattr(self, name)!r}")
        if (
            not isinstance(self.algorithms, tuple)
            or not self.algorithms
            or not all(isinstance(a, str) and a for a in self.algorithms)
        ):
            raise MissionError(
                f"Claim.algorithms: must be a non-empty tuple of names, got {self.algorithms!r}"
            )
        if not callable(getattr(self.method, "check", None)):
            raise MissionError(
                f"Claim.method: must have a check(claim, n_missions, seed) method, got "
                f"{type(self.method).__name__}"
            )
        if not isinstance(self.scope, Scope):
            raise MissionError(f"Claim.scope: must be a proofs.claimkit.Scope, got {self.scope!r}")
        if self.network is not None and not (isinstance(self.network, str) and self.network):
            raise MissionError(f"Claim.network: must be text or None, got {self.network!r}")

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
        kind, count, example, note = self.method.check(self, n_missions, seed)
        return Verdict(
            claim_id=self.id,
            statement=self.statement,
            verdict=kind,
            instances_checked=count,
            counterexample=example,
            seconds=time.perf_counter() - started,
            note=note,
            scope=self.scope,
            network=self.network,
        )

    def with_algorithm(self, name: str, function: Runner) -> Claim:
        """A copy of this claim that runs ``function`` wherever it would run ``name``.

        ``function(mission, *, seed, order, **options)`` must return an object with the
        fields of :class:`heuristics.Run` the claim reads (``assignment``, ``iterations``,
        ``work``...).  Use it to check a variant -- or a deliberately broken version -- of a
        heuristic against the same claims.
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


def format_number(x: float) -> str:
    """``x`` with 4 significant digits, as verdict details show utilities.

    >>> format_number(2 / 3), format_number(1500.0)
    ('0.6667', '1500')
    """
    return f"{x:.4g}"


def worst_verdict(kinds: Iterable[VerdictKind]) -> VerdictKind:
    """``fails`` if any fails, else ``inconclusive`` if any is, else ``holds``.

    >>> worst_verdict([VerdictKind.HOLDS, VerdictKind.INCONCLUSIVE]).value
    'inconclusive'
    """
    kinds = list(kinds)
    if VerdictKind.FAILS in kinds:
        return VerdictKind.FAILS
    if VerdictKind.INCONCLUSIVE in kinds:
        return VerdictKind.INCONCLUSIVE
    return VerdictKind.HOLDS


# --------------------------------------------------------------- run properties
#: A property: ``evaluate(claim, mission)`` -> :class:`Evaluation`.
Evaluator = Callable[[Claim, Mission], Evaluation]
#: A strategy factory: called (once hypothesis is imported) to build the search's strategy.
MissionStrategy = Callable[[], Any]


class PropertyCheck:
    """Grid missions, a seed-family sweep, a hypothesis search and an exhaustive fallback
    for missions where ``evaluate`` fails (see the module's summary).

    Parameters
    ----------
    evaluate : callable
        ``evaluate(claim, mission) -> Evaluation``; an exception it raises is a failure of
        the claim on that mission (its counterexample names the exception).
    cells : sequence of cfopt.GridCell
        The seeded grid missions: ``n_missions`` of them, cycling through the cells.
    strategy : callable or None
        A hypothesis strategy factory (e.g. :func:`structural_missions`); ``None``: no
        search (a claim about the grid missions only, e.g. at the paper's sizes).
    summary : callable, optional
        ``summary(tallies, checked) -> str`` for the note (e.g. :func:`tally_summary`).
    exhaustive : callable, optional
        Missions checked one by one, smallest first, when the search finds nothing (e.g.
        :func:`small_scope`).
    sweep : sequence of (int, int)
        Compositions of the seed-family sweep (none: no sweep).

    Notes
    -----
    A subclass may override :meth:`family_sweep` (e.g. a sweep at other loads).
    """

    def __init__(
        self,
        evaluate: Evaluator,
        cells: Sequence[GridCell],
        strategy: MissionStrategy | None,
        summary: Callable[[Counter[str], int], str] | None = None,
        exhaustive: Callable[[], Iterable[Mission]] | None = None,
        sweep: Sequence[tuple[int, int]] = (),
    ) -> None:
        self.exhaustive = exhaustive
        self.sweep = tuple(sweep)
        self.evaluate = evaluate
        self.cells = tuple(cells)
        self.strategy = strategy
        self.summary = summary

    def _safe(self, claim: Claim, mission: Mission) -> Evaluation:
        try:
            return self.evaluate(claim, mission)
        except Exception as exc:  # a crash is a failure of the claim, with its mission
            return Evaluation(
                Counterexample(
                    mission,
                    Assignment.empty(mission),
                    claim.algorithms[0],
                    f"{claim.algorithms[0]} raised {type(exc).__name__}: {exc}",
                ),
                gap=math.inf,
            )

    def grid(self, n_missions: int, seed: int) -> Iterator[Mission]:
        """``n_missions`` seeded missions, cycling through the cells (none without cells)."""
        if not self.cells:
            return
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

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        """Grid, sweep, search, then the exhaustive fallback; the smallest failure found.

        The note is made from the same evaluations as the verdict: the tallies count every
        mission checked (the exhaustive ones and the shrunk counterexample included), and
        the counterexample's own labels are named with where it was found.
        """
        tallies: Counter[str] = Counter()
        found: list[tuple[Evaluation, str]] = []
        checked = grid_failed = 0
        for mission in self.grid(n_missions, seed):
            out = self._safe(claim, mission)
            checked += 1
            tallies.update(out.tallies)
            if out.failure is not None:
                grid_failed += 1
                if not found:
                    found.append((out, "a grid mission"))
        swept = 0
        for mission in self.family_sweep(n_missions, seed):
            out = self._safe(claim, mission)
            swept += 1
            tallies.update(out.tallies)
            if out.failure is not None:  # smallest first: stop at the first failure
                found.append((out, "the seed-family sweep"))
                break
        checked += swept
        searched, shrunk = self._search(claim, n_missions * SEARCH_FACTOR, seed, tallies)
        checked += searched
        notes = []
        if self.sweep:
            stop = " (stopped at the first failure)" if swept and found else ""
            notes.append(f"seed-family sweep n = 3..12: {swept} missions{stop}")
        if shrunk is not None:  # a mission of its own: checked and tallied too
            checked += 1
            tallies.update(shrunk.tallies)
            found.append((shrunk, "the hypothesis search (shrunk)"))
        elif self.exhaustive is not None:
            scoped, exhausted = self._exhaust(claim, self.exhaustive(), tallies)
            checked += scoped
            notes.append(f"small-scope search: {scoped} missions")
            if exhausted is not None:
                found.append((exhausted, "the small-scope search"))
        example = None
        if found:
            out, source = min(found, key=lambda f: _smallness(f[0].failure))
            example = out.failure
            notes.append(_counterexample_note(out, source))
        if self.summary is not None:
            notes.append(self.summary(tallies, checked))
        notes.append(self._grid_note(n_missions, searched, grid_failed))
        kind = VerdictKind.HOLDS if example is None else VerdictKind.FAILS
        return kind, checked, example, "; ".join(n for n in notes if n)

    def _grid_note(self, n_missions: int, searched: int, failed: int) -> str:
        search = f"{searched} searched" if self.strategy is not None else "no search"
        if not self.cells:
            return search
        robots = ", ".join(str(r) for r in sorted({c.robots for c in self.cells}))
        cells = f"{len(self.cells)} cells, n={robots}"
        return f"{n_missions} grid missions ({cells}) + {search}; failing grid missions: {failed}"

    def _exhaust(
        self, claim: Claim, missions: Iterable[Mission], tallies: Counter[str]
    ) -> tuple[int, Evaluation | None]:
        """The exhaustive fallback: (missions checked, the first failure, smallest first);
        the missions' labels are tallied."""
        scoped = 0
        for mission in missions:
            out = self._safe(claim, mission)
            scoped += 1
            tallies.update(out.tallies)
            if out.failure is not None:
                return scoped, out  # smallest first: minimal in the scope
        return scoped, None

    def _search(
        self, claim: Claim, max_examples: int, seed: int, tallies: Counter[str]
    ) -> tuple[int, Evaluation | None]:
        """``hypothesis.find`` the minimal failing mission; returns (missions drawn, its
        evaluation).  No strategy: no search."""
        if self.strategy is None:
            return 0, None
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
        return state["drawn"], out if out.failure is not None else None


def _smallness(example: Counterexample | None) -> tuple[Any, ...]:
    assert example is not None
    return (example.size, int(example.mission.requirements.sum()))


def _counterexample_note(out: Evaluation, source: str) -> str:
    """Where the counterexample was found and its own labels (the same evaluation)."""
    robots, tasks, services = out.failure.size  # type: ignore[union-attr]
    labels = ", ".join(dict.fromkeys(out.tallies))
    return f"counterexample ({robots} robots, {tasks} tasks, {services} services) from {source}" + (
        f": {labels}" if labels else ""
    )


def capped_nash_stable(algorithm: str, subject: str) -> Evaluator:
    """A ready-made property: ``algorithm``'s partition (index order, seed 0) is Nash
    stable under capped moves (:func:`proofs.nash_violations` with ``capped=True``).

    The gap is the number of violations; the tallies count ``"capped not Nash stable"``
    and ``"uncapped not Nash stable"``; a failure's detail reads ``"<subject> is not Nash
    stable (capped moves): <the first deviation>"``.
    """

    def evaluate(claim: Claim, m: Mission) -> Evaluation:
        a = claim.run(algorithm, m, seed=0, order="index").assignment
        capped = nash_violations(m, a, capped=True)
        tallies = ("uncapped not Nash stable",) if nash_violations(m, a) else ()
        if not capped:
            return Evaluation(None, 0.0, tallies)
        more = f" and {len(capped) - 1} more" if len(capped) > 1 else ""
        detail = f"{subject} is not Nash stable (capped moves): {capped[0].describe(m)}{more}"
        return Evaluation(
            Counterexample(m, a, algorithm, detail),
            float(len(capped)),
            (*tallies, "capped not Nash stable"),
        )

    return evaluate


def property_claim(
    id: str,
    statement: str,
    family: str,
    algorithms: tuple[str, ...],
    evaluate: Evaluator,
    *,
    scope: Scope,
    strategy: MissionStrategy | None,
    cells: Sequence[GridCell] = (),
    summary: Callable[[Counter[str], int], str] | None = None,
    exhaustive: Callable[[], Iterable[Mission]] | None = None,
    sweep: Sequence[tuple[int, int]] = (),
    network: str | None = None,
) -> Claim:
    """A claim about single runs, checked by a :class:`PropertyCheck`.

    Parameters
    ----------
    id, statement, family, algorithms
        As in :class:`Claim`; with a ``sweep`` the family text gains a sentence on it.
    evaluate : callable
        ``evaluate(claim, mission) -> Evaluation`` (run algorithms with
        ``claim.run(name, mission, ...)``, or call any function directly).
    scope : Scope
        What the check ranges over.
    strategy, cells, summary, exhaustive, sweep
        As in :class:`PropertyCheck`.
    network : str, optional
        The network of a distributed claim (:attr:`Claim.network`).

    Returns
    -------
    Claim
        A check with budget ``n`` evaluates ``n`` grid missions, the sweep (``n`` seeds
        per size, composition and percentage), ``SEARCH_FACTOR * n`` drawn missions plus
        the shrinking, and the exhaustive fallback when the search finds nothing.
    """
    if sweep:
        family += (
            "; plus a seed-family sweep: the seed's generator at n = 3..12, compositions "
            + ", ".join(f"{S}:{k}" for S, k in sweep)
            + ", 10 and 50 % tasks, smallest first"
        )
    check = PropertyCheck(evaluate, cells, strategy, summary, exhaustive, sweep)
    return Claim(id, statement, family, algorithms, check, scope, network=network)


def capped_nash_claim(
    id: str, statement: str, algorithm: str, *, subject: str, note: str = ""
) -> Claim:
    """A ready-made claim: ``algorithm`` ends Nash stable under capped moves on any mission.

    Checked (:func:`capped_nash_stable`) on the seed's grid cells with n = 100 (all
    compositions), the seed-family sweep, hypothesis-drawn missions of up to 8 robots, 4
    tasks, 4 services and, when the search finds nothing, the whole :func:`small_scope`;
    the family text is :data:`ANY_FAMILY` and :data:`SMALL_SCOPE_FAMILY`, then ``note``.
    """
    return property_claim(
        id,
        statement,
        ANY_FAMILY + SMALL_SCOPE_FAMILY + note,
        (algorithm,),
        capped_nash_stable(algorithm, subject),
        scope=Scope.GENERALISATION,
        cells=grid_cells(ALL_COMPOSITIONS),
        strategy=structural_missions(achievable=None),
        summary=tally_summary("capped not Nash stable", "uncapped not Nash stable"),
        exhaustive=small_scope,
        sweep=ALL_COMPOSITIONS,
    )


# ------------------------------------------------------------------- families
def structural_missions(*, achievable: bool | None, load: float | None = None) -> MissionStrategy:
    """Small missions of :mod:`proofs.strategies` (up to 8 robots, 4 tasks, 4 services):
    any mission, or (``achievable=True``) ones with a complete assignment at ``load``."""

    def make() -> Any:
        from proofs import strategies

        if achievable:
            return strategies.achievable_missions(
                max_robots=8, max_tasks=4, max_services=4, load=load
            )
        return strategies.missions(max_robots=8, max_tasks=4, max_services=4)

    return make


def generated_missions(
    compositions: Sequence[tuple[int, int]],
    *,
    min_robots: int = 2,
    max_robots: int = 60,
    percents: Sequence[float] = (10, 50),
) -> MissionStrategy:
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


def achievable(mission: Mission) -> bool:
    """Whether some assignment completes every task (Hall's condition, or the exact ILP).

    Robots against slot copies (``req[j, s]`` copies of slot ``(j, s)``): a copy of
    service ``s`` is adjacent to exactly the robots having ``s``, so Hall's condition
    for the copies reads, for every set ``Q`` of services, "the robots having some
    service of ``Q`` number at least the total requirement of ``Q``".  It is enumerated
    over the ``2^q`` subsets of the ``q`` services some task needs (O(2^q n q) numpy
    work); with more than 16 needed services :func:`cfopt.solve_exact` decides instead.
    Independent of any algorithm under audit.

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


def achievable_small_scope() -> Iterator[Mission]:
    """The missions of :func:`small_scope` that have a complete assignment, smallest first."""
    return (m for m in small_scope() if achievable(m))


def grid_cells(compositions: Iterable[tuple[int, int]], robots: int = 100) -> list[GridCell]:
    """The cells of the seed's grid (:func:`cfopt.paper_grid`) with ``robots`` robots and
    the given compositions, in the grid's order.

    >>> [c.label for c in grid_cells(HARD_COMPOSITIONS)]
    ['n=100 p=10% 10:5 load=1', 'n=100 p=50% 10:5 load=1']
    """
    wanted = set(compositions)
    return [
        c
        for c in paper_grid()
        if c.robots == robots and (c.service_types, c.services_per_robot) in wanted
    ]


def tally_summary(*labels: str) -> Callable[[Counter[str], int], str]:
    """A note summary: ``"label: count of checked"`` for each label, in order.

    >>> tally_summary("optimal")(Counter(optimal=3), 4)
    'optimal: 3 of 4'
    """

    def summary(tallies: Counter[str], checked: int) -> str:
        return ", ".join(f"{label}: {tallies[label]} of {checked}" for label in labels)

    return summary


# --------------------------------------------------------- statistical claims
#: Confidence of the intervals and significance level of the tests of statistical claims.
CONFIDENCE = 0.95
ALPHA = 0.05


def verdict_words(kind: VerdictKind) -> str:
    """A verdict in words: ``inconclusive`` reads "inconclusive at this budget".

    >>> verdict_words(VerdictKind.INCONCLUSIVE), verdict_words(VerdictKind.HOLDS)
    ('inconclusive at this budget', 'holds')
    """
    return "inconclusive at this budget" if kind is VerdictKind.INCONCLUSIVE else kind.value


def budget_note(kind: VerdictKind, note: str) -> str:
    """``note``, led by "inconclusive at this budget: " when ``kind`` is inconclusive."""
    return f"{verdict_words(kind)}: {note}" if kind is VerdictKind.INCONCLUSIVE else note


@dataclass(frozen=True)
class MedianEstimate:
    """A sample's median with its distribution-free confidence interval (frozen).

    Attributes
    ----------
    median : float
    low, high : float or None
        The interval ``[x(k), x(n-k+1)]`` of order statistics with the largest ``k``
        whose coverage is at least the confidence asked for (``None`` when even
        ``[min, max]`` falls short: at 95 %, fewer than 6 values).
    coverage : float
        The interval's exact coverage (binomial, for any continuous distribution);
        0 without an interval.
    n : int
        Sample size.
    """

    median: float
    low: float | None
    high: float | None
    coverage: float
    n: int

    def describe(self, unit: str = "", digits: int = 2) -> str:
        """``"median 100.00 % (95.7 % CI [99.20, 100.00] %, n = 25)"``; without an interval
        ``"median 97.08 % (n = 5: too few for a 95 % interval)"``.

        >>> median_estimate([99.0] + [100.0] * 7).describe("%")
        'median 100.00 % (99.2 % CI [99.00, 100.00] %, n = 8)'
        """
        unit = f" {unit}" if unit else ""
        median = f"median {self.median:.{digits}f}{unit}"
        if self.low is None or self.high is None:
            return f"{median} (n = {self.n}: too few for a {CONFIDENCE * 100:g} % interval)"
        ci = f"[{self.low:.{digits}f}, {self.high:.{digits}f}]{unit}"
        return f"{median} ({self.coverage * 100:.1f} % CI {ci}, n = {self.n})"


def median_estimate(values: Sequence[float], confidence: float = CONFIDENCE) -> MedianEstimate:
    """The median of ``values`` and its exact order-statistic confidence interval.

    >>> e = median_estimate([99.0, 99.5, 100, 100, 100, 100, 100, 100])
    >>> e.median, e.low, e.high, round(e.coverage, 3)
    (100.0, 99.0, 100.0, 0.992)
    >>> median_estimate([1.0, 2.0, 3.0]).low is None
    True
    """
    from scipy.stats import binom

    xs = sorted(float(v) for v in values)
    n = len(xs)
    if n == 0:
        raise MissionError("values: a median needs at least one value")
    best = None
    for k in range(1, n // 2 + 1):
        coverage = 1.0 - 2.0 * float(binom.cdf(k - 1, n, 0.5))
        if coverage < confidence:
            break
        best = (k, coverage)
    median = float(np.median(xs))
    if best is None:
        return MedianEstimate(median, None, None, 0.0, n)
    k, coverage = best
    return MedianEstimate(median, xs[k - 1], xs[n - k], coverage, n)


def interval_verdict(
    estimate: MedianEstimate, lower: float | None = None, upper: float | None = None
) -> VerdictKind:
    """``holds`` when the interval lies inside ``[lower, upper]``, ``fails`` when it lies
    wholly outside, ``inconclusive`` otherwise -- also without an interval (too few
    values: inconclusive at this budget).  A decision needs the whole interval on one
    side: a wider interval (a smaller sample) says ``inconclusive`` sooner than the
    opposite verdict.

    >>> interval_verdict(median_estimate([99.5] * 8), lower=99).value
    'holds'
    >>> interval_verdict(median_estimate([97.0] * 5), lower=99).value
    'inconclusive'
    """
    low, high = estimate.low, estimate.high
    if low is None or high is None:
        return VerdictKind.INCONCLUSIVE
    inside = (lower is None or low >= lower) and (upper is None or high <= upper)
    if inside:
        return VerdictKind.HOLDS
    outside = (lower is not None and high < lower) or (upper is not None and low > upper)
    return VerdictKind.FAILS if outside else VerdictKind.INCONCLUSIVE


@dataclass(frozen=True)
class PairedComparison:
    """Paired values ``a`` against ``b`` (frozen): the tally and the Wilcoxon signed-rank
    test of the nonzero differences, in both one-sided directions.

    Attributes
    ----------
    higher, equal, lower : int
        Pairs with ``a > b``, ``a == b``, ``a < b``.
    statistic : float
        The signed-rank statistic (the sum of the ranks of the positive differences);
        0 without nonzero differences.
    p_greater, p_less : float
        One-sided p-values for "``a`` tends to be higher" and "lower" (1 without nonzero
        differences).
    """

    higher: int
    equal: int
    lower: int
    statistic: float
    p_greater: float
    p_less: float

    @property
    def n(self) -> int:
        """The number of pairs."""
        return self.higher + self.equal + self.lower

    def verdict(self, alpha: float = ALPHA) -> VerdictKind:
        """``holds`` when ``a`` is significantly higher, ``fails`` when significantly
        lower, ``inconclusive`` otherwise (at this budget)."""
        if self.p_greater < alpha:
            return VerdictKind.HOLDS
        if self.p_less < alpha:
            return VerdictKind.FAILS
        return VerdictKind.INCONCLUSIVE

    def describe(self, a: str = "a", b: str = "b") -> str:
        """The tally, the statistic, both p-values and the direction, in words."""
        direction = (
            f"{a} higher"
            if self.p_greater < ALPHA
            else f"{a} lower"
            if self.p_less < ALPHA
            else "no significant direction"
        )
        return (
            f"{a} vs {b} on {self.n} paired missions: higher {self.higher}, equal "
            f"{self.equal}, lower {self.lower}; Wilcoxon signed-rank W+ = {self.statistic:g}, "
            f"p = {self.p_greater:.3g} ({a} higher), p = {self.p_less:.3g} ({a} lower): "
            f"{direction} (alpha {ALPHA:g})"
        )


def paired_comparison(a: Sequence[float], b: Sequence[float]) -> PairedComparison:
    """Tally ``a`` against ``b`` pair by pair and test the nonzero differences with the
    Wilcoxon signed-rank test (scipy), one-sided both ways.

    >>> c = paired_comparison([1, 2, 3, 4, 5, 6, 7], [0, 1, 2, 3, 4, 5, 7])
    >>> (c.higher, c.equal, c.lower), c.verdict().value
    ((6, 1, 0), 'holds')
    """
    from scipy.stats import wilcoxon

    if len(a) != len(b):
        raise MissionError(f"a, b: paired samples must have one length, got {len(a)}, {len(b)}")
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    nonzero = d[d != 0]
    higher, lower = int((d > 0).sum()), int((d < 0).sum())
    equal = len(d) - higher - lower
    if nonzero.size == 0:
        return PairedComparison(higher, equal, lower, 0.0, 1.0, 1.0)
    greater = wilcoxon(nonzero, alternative="greater")
    less = wilcoxon(nonzero, alternative="less")
    return PairedComparison(
        higher, equal, lower, float(greater.statistic), float(greater.pvalue), float(less.pvalue)
    )


# ------------------------------------------------------------- scaling claims
#: A messages part is about point-to-point messages: one per receiver (the toolkit's
#: counts before the broadcast default, the model the seed's O(...) bounds are read in).
UNICAST: tuple[tuple[str, Any], ...] = (("medium", "unicast"),)


@dataclass(frozen=True)
class ScalingPart:
    """One fitted exponent of a scaling claim.

    Attributes
    ----------
    algorithm : str
        The algorithm whose runs are counted.
    measure : str
        The counted quantity (``work``, ``rounds``, ``messages`` or ``bytes``).
    exponent : float
        The stated exponent in ``n`` (an upper bound).
    why : str
        How the stated bound gives the exponent (``"n^2 m, m ~ n"``).
    options : tuple of (str, value)
        Keyword options of the runs, e.g. the communication model (:data:`UNICAST`).
    sizes : tuple of int
        The ladder's collective sizes.
    """

    algorithm: str
    measure: str
    exponent: float
    why: str
    options: tuple[tuple[str, Any], ...] = ()
    sizes: tuple[int, ...] = LADDER_SIZES

    @property
    def label(self) -> str:
        """The algorithm, with its pinned options: ``grape-s [medium=unicast]``."""
        if not self.options:
            return self.algorithm
        return f"{self.algorithm} [{', '.join(f'{k}={v}' for k, v in self.options)}]"


def bound_runner(claim: Claim, name: str, options: Mapping[str, Any] | None = None) -> Runner:
    """``runner(mission, *, seed)``: ``claim.run(name, ...)`` in index order with
    ``options``, for the ladders of :mod:`proofs.scaling`."""

    def runner(mission: Mission, *, seed: int) -> Any:
        return claim.run(name, mission, seed=seed, order="index", **(options or {}))

    runner.__name__ = name
    return runner


def exponent_verdict(
    fit: Fit, exponent: float, tolerance: float = EXPONENT_TOLERANCE
) -> VerdictKind:
    """Holds when the fit's interval lies at or below ``exponent + tolerance``, fails when
    it lies above, inconclusive otherwise."""
    limit = exponent + tolerance
    if fit.ci_high <= limit:
        return VerdictKind.HOLDS
    if fit.ci_low > limit:
        return VerdictKind.FAILS
    return VerdictKind.INCONCLUSIVE


class ScalingCheck:
    """Fitted exponents in ``n`` (10 % tasks, 10:5) against the stated ones, per part.

    ``extra(claim, seed)`` may add note lines (e.g. fits in other variables).
    """

    def __init__(
        self,
        parts: Sequence[ScalingPart],
        extra: Callable[[Claim, int], list[str]] | None = None,
    ) -> None:
        self.parts = tuple(parts)
        self.extra = extra

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        """Every part's ladder, fitted; a failure's counterexample is its largest mission."""
        per_rung = min(5, max(2, math.ceil(n_missions / 5)))
        seeds = list(range(seed, seed + per_rung))
        notes, kinds, checked = [], [], 0
        cache: dict[tuple[Any, ...], list[Any]] = {}
        failing: tuple[ScalingPart, Fit] | None = None
        for part in self.parts:
            key = (part.algorithm, part.options, part.sizes)
            if key not in cache:
                runner = bound_runner(claim, part.algorithm, dict(part.options))
                cache[key] = ladder(runner, part.sizes, seeds=seeds)
                checked += len(cache[key])
            fit = fit_rungs(cache[key], part.measure, "n")
            kind = exponent_verdict(fit, part.exponent)
            kinds.append(kind)
            if kind is VerdictKind.FAILS and failing is None:
                failing = (part, fit)
            notes.append(
                f"{part.label} {part.measure} ~ n^{fit} vs seed n^{part.exponent:g} "
                f"({part.why}): {kind.value}"
            )
        if self.extra is not None:
            notes += self.extra(claim, seed)
        example = None if failing is None else _largest_rung(claim, *failing, seeds[0])
        notes.append(f"ladder n = {', '.join(map(str, LADDER_SIZES))}, {per_rung} seeds each")
        return worst_verdict(kinds), checked, example, "; ".join(notes)


def _largest_rung(claim: Claim, part: ScalingPart, fit: Fit, seed: int) -> Counterexample:
    """A failing part's counterexample: its run on the largest mission of the ladder."""
    mission = ladder_mission(part.sizes[-1], seed)
    run = claim.run(part.algorithm, mission, seed=seed, **dict(part.options))
    return Counterexample(
        mission,
        run.assignment,
        part.algorithm,
        f"largest ladder mission: {part.measure} = {getattr(run, part.measure)}; "
        f"fitted exponent {fit} exceeds the seed's {part.exponent:g} + {EXPONENT_TOLERANCE}",
    )


def scaling_claim(
    id: str,
    statement: str,
    family: str,
    parts: Sequence[ScalingPart],
    extra: Callable[[Claim, int], list[str]] | None = None,
    *,
    scope: Scope = Scope.GENERALISATION,
) -> Claim:
    """A complexity claim checked by a :class:`ScalingCheck`; its algorithms are the parts'.

    A check with budget ``n`` runs ``min(5, max(2, ceil(n / 5)))`` seeds per ladder rung.
    The default scope: a ladder ranges over the family at sizes other than the paper's.
    """
    algorithms = tuple(dict.fromkeys(p.algorithm for p in parts))
    return Claim(id, statement, family, algorithms, ScalingCheck(parts, extra), scope)
