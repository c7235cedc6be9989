"""``cfopt reproduce``: the seed paper's evaluation, run again, every figure beside cfopt's.

The seed (Diehl and Adams, GRAPE-S) evaluated its four algorithms on a centralized grid
(100, 500 and 1000 robots; 1, 10 and 50 % tasks; compositions 5:1, 5:5, 10:1, 10:5; 25
missions per cell, §5) and its three distributed ones on a distributed grid (100 and 500
robots on a network, §6).  :func:`run_reproduce` runs both grids with those algorithms
into a result store (resumable), then :func:`compare_figures` sets every published figure
of :data:`cfopt.paper.FIGURES` beside cfopt's value of the same statistic over the same
cells.  Each comparison states the statistic on each side, the tolerance and one verdict:

* ``agree`` -- within the tolerance of its kind (below);
* ``differ`` -- with a one-line reason;
* ``not comparable`` -- seconds: cfopt's wall time on this machine against the seed's C++
  on its workstation (§5), or cfopt's *simulated* seconds against the seed's wall time on
  its cluster (§6), and the runtime order of different algorithms (which depends on how
  each is implemented); the counted work and cfopt's value are given beside them.  The
  change of one algorithm's centralized runtime with a factor (a test's significance and
  direction) is compared;
* ``no trials`` -- the store holds none of the figure's cells;
* ``inconclusive`` (shown ``inconclusive: n = 3``) -- the sample cannot decide: a test
  that could not reach p < 0.05 at cfopt's group sizes whatever the data, a median of
  fewer than 6 trials (no 95 % interval) or whose 95 % interval reaches the tolerance, an
  extreme over fewer trials than the paper's that is less extreme than the paper's (a
  maximum over 3 missions is expected below one over 25);
* ``the paper disagrees with itself`` -- two places of the paper that cannot both hold
  (:data:`cfopt.paper.DISAGREEMENTS`), both quoted.

Tolerances.  The paper's missions are other random draws of the same family, so values
agree statistically, not exactly: a median of percent utility within 1 percentage point,
any other percent utility within 5 points, a utility bound (">95 %") on its side; a
communication volume within a factor of 2, a volume bound ("<500 MB") on its side *and*
within a factor 2 of it (the bound stands for volumes of its size); a bound is compared
with the statistic that bounds it (a worst case with the maximum, "for all trials" with
the maximum or the minimum, "for most trials" with the median); a count of trials with a
property (the pairwise step ran, optimal) when Fisher's exact test does not reject equal
proportions at 5 %; a ratio, a share or an order on its side; a curve in shape (its
log-log slope within 0.25, or inside cfopt's 95 % interval) and in level (the ratio at
each size, within a factor 2) as separate lines; a statistical test when significance at
5 % *and* the direction the paper gives (which group is lowest, whether values grow with
the factor) both agree.  The sample size is the report's header, not a figure to agree
with.

Examples
--------
>>> sweeps = reproduction_sweeps(missions=2)
>>> [(len(s.cells), s.missions, s.algorithms) for s in sweeps]  # doctest: +NORMALIZE_WHITESPACE
[(32, 2, ('exact', 'grape-s', 'pair-grape-s', 'sda', 'rachna-dt')),
 (20, 2, ('exact', 'grape-s', 'pair-grape-s', 'sda'))]
>>> verdict_tally({"agree": 1, "differ": 86, "inconclusive": 2})
'1 agrees, 86 differ, 2 are inconclusive'
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import functools
import math
import os
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from cfopt._jsonio import make_directory, output_target
from cfopt._progress import Progress
from cfopt.errors import MissionError, plural
from cfopt.paper import (
    CENTRALIZED_ALGORITHMS,
    COMMUNICATION_ALGORITHM,
    COMMUNICATION_CURVE,
    DISAGREEMENTS,
    DISTRIBUTED_ALGORITHMS,
    FIGURES,
    GRAPE_S_ALGORITHMS,
    PAIRWISE_ALGORITHM,
    Disagreement,
    Figure,
)
from cfopt.report import format_median_max, megabytes
from cfopt.stats import (
    ALPHA,
    Outcome,
    StatResult,
    complete_blocks,
    friedman,
    kruskal,
    mann_whitney,
    wilcoxon,
)
from cfopt.store import EXACT, Trial, check_store_path

__all__ = [
    "AGREE",
    "DIFFER",
    "INCONCLUSIVE",
    "NOT_COMPARABLE",
    "NO_TRIALS",
    "PAPER_DISAGREES",
    "Comparison",
    "ReproduceResult",
    "Verdict",
    "compare_figures",
    "paper_test",
    "reproduction_sweeps",
    "run_reproduce",
    "verdict_tally",
    "write_reproduction",
]


class Verdict(StrEnum):
    """A comparison's verdict (its value is the word the report prints)."""

    AGREE = "agree"
    DIFFER = "differ"
    NOT_COMPARABLE = "not comparable"
    NO_TRIALS = "no trials"
    INCONCLUSIVE = "inconclusive"
    PAPER_DISAGREES = "the paper disagrees with itself"


AGREE, DIFFER, NOT_COMPARABLE = Verdict.AGREE, Verdict.DIFFER, Verdict.NOT_COMPARABLE
NO_TRIALS, INCONCLUSIVE, PAPER_DISAGREES = (
    Verdict.NO_TRIALS,
    Verdict.INCONCLUSIVE,
    Verdict.PAPER_DISAGREES,
)
#: Missions per cell in the seed (and the default here).
PAPER_MISSIONS = 25
#: The seed's viability targets: above 95 % utility, under 5 minutes.
VIABLE_PERCENT, VIABLE_SECONDS = 95.0, 300.0
#: Tolerances (module docstring): percentage points, a factor, a log-log slope.
MEDIAN_POINTS, OTHER_POINTS, VOLUME_FACTOR, SLOPE_TOLERANCE = 1.0, 5.0, 2.0, 0.25
#: A ratio "more" or "less" than 1 must clear it by this factor (1.02 is "the same").
RATIO_MARGIN = 1.05
#: The fewest values with a distribution-free 95 % interval for their median.
MEDIAN_INTERVAL_MIN = 6
#: Files of the reproduction (the optimal-gap report's files come beside them).
REPRODUCTION_FILES = (
    "reproduction.md",
    "reproduction.html",
    "reproduction.csv",
    "reproduction_tests.csv",
    "communication_models.png",
)
REPRODUCE_STORE = "trials.sqlite"
_MB = 1e6


# --------------------------------------------------------------------------- the runs
def reproduction_sweeps(
    missions: int = PAPER_MISSIONS, base_seed: int = 0, distributed: bool = True
) -> list[Any]:
    """The seed's centralized grid with its four algorithms and, with ``distributed``,
    its distributed grid (:func:`cfopt.experiments.distributed_grid`) with its three, as
    :class:`cfopt.experiments.Sweep` objects of ``missions`` missions per cell."""
    from cfopt.experiments import Sweep, distributed_grid
    from cfopt.generate import paper_grid

    sweeps = [Sweep(tuple(paper_grid()), missions, CENTRALIZED_ALGORITHMS, base_seed)]
    if distributed:
        sweeps.append(Sweep(distributed_grid(), missions, DISTRIBUTED_ALGORITHMS, base_seed))
    return sweeps


@dataclass(frozen=True)
class ReproduceResult:
    """What :func:`run_reproduce` did (frozen): the directory, the comparisons, the files
    written, the sweeps' outcomes, the trials' code version and the sample (the report's
    header: :func:`sample_sizes`)."""

    directory: Path
    comparisons: tuple[Comparison, ...]
    files: tuple[Path, ...]
    outcomes: tuple[Any, ...]
    code_version: str
    sample: tuple[str, ...] = ()

    def counts(self) -> dict[str, int]:
        """How many comparisons have each verdict."""
        out: dict[str, int] = defaultdict(int)
        for c in self.comparisons:
            out[c.verdict.value] += 1
        return dict(out)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``cfopt reproduce --json``)."""
        return {
            "directory": os.fspath(self.directory),
            "code_version": self.code_version,
            "verdicts": self.counts(),
            "sample": list(self.sample),
            "comparisons": [c.to_dict() for c in self.comparisons],
            "files": [os.fspath(p) for p in self.files],
            "trials_computed": sum(o.completed for o in self.outcomes),
            "trials_reused": sum(o.skipped for o in self.outcomes),
        }


def run_reproduce(
    directory: str | os.PathLike[str] = "cfopt-reproduce",
    *,
    missions: int = PAPER_MISSIONS,
    workers: int | None = None,
    executor: cf.Executor | None = None,
    store: str | os.PathLike[str] | None = None,
    distributed: bool = True,
    force: bool = False,
    progress: bool | Progress = True,
) -> ReproduceResult:
    """Run the seed's grids and write the side-by-side reproduction report.

    Parameters
    ----------
    directory : path, default "cfopt-reproduce"
        Created if missing (its parent must exist).  Receives ``reproduction.md``,
        ``reproduction.html``, ``reproduction.csv`` (every figure: paper | cfopt | verdict),
        ``reproduction_tests.csv``, ``communication_models.png`` and the optimal-gap
        report of the same trials (``report.md``...).  Existing files are never replaced
        without ``force``: the check comes before any computation.
    missions : int, default 25
        Missions per cell (the seed's 25; fewer for a quick look, e.g. 2).
    workers : int, optional
        Worker processes (default: the usable CPUs).
    executor : concurrent.futures.Executor, optional
        Where the trials run instead, e.g. a dask cluster's
        (:func:`cfopt.cluster.dask_executor`); the store stays in this process.
    store : path, optional
        The result store (default ``DIRECTORY/trials.sqlite``); trials already in it are
        reused, so an interrupted run resumes.
    distributed : bool, default True
        Also the seed's distributed evaluation (every robot an agent in cfopt's simulator).
    force : bool, default False
    progress : bool or Progress

    Raises
    ------
    cfopt.experiments.SweepInterrupted
        On SIGINT/SIGTERM: what is stored is kept.
    """
    from cfopt.experiments import code_version, run_sweep
    from cfopt.report import check_free, load_trials, planned_files, write_report
    from cfopt.store import store_lock

    directory = Path(directory)
    if missions < 1:
        raise MissionError(f"--missions: must be at least 1, got {missions}")
    output_target(directory, overwrite=force, directory=True)
    if not force:
        check_free(directory, REPRODUCTION_FILES)
    if store is not None:
        check_store_path(store)  # before the directory is created
    progress = Progress.coerce(progress)
    make_directory(directory)
    store = Path(store) if store is not None else directory / REPRODUCE_STORE
    sweeps = reproduction_sweeps(missions, distributed=distributed)
    version = code_version()  # one version for both grids, read once
    outcomes = []
    with store_lock(store, "cfopt reproduce"):
        for sweep in sweeps:
            outcomes.append(
                run_sweep(
                    sweep,
                    store,
                    executor=executor,
                    workers=workers,
                    progress=progress,
                    version=version,
                    lock=False,
                )
            )
    trials, version = load_trials(store, version)
    wanted = {
        (c.label, c.mission_seed(i)) for s in sweeps for c in s.cells for i in range(missions)
    }
    trials = [t for t in trials if (t.cell, t.mission_seed) in wanted]
    if not force:
        check_free(directory, planned_files(trials))
    progress.line(f"report: writing {os.fspath(directory)}")
    comparisons = compare_figures(trials)
    files = write_reproduction(
        trials, comparisons, directory, missions=missions, version=version, force=force
    )
    report = write_report(
        trials,
        directory,
        version=version,
        source=os.fspath(store),
        force=force,
        title="cfopt reproduce: the seed's grids, the optimal-gap report",
    )
    return ReproduceResult(
        directory,
        tuple(comparisons),
        (*files, *report.files),
        tuple(outcomes),
        version,
        tuple(sample_sizes(trials)),
    )


# ------------------------------------------------------------------ the comparison
@dataclass(frozen=True)
class Comparison:
    """One published figure beside cfopt's (frozen).

    Attributes
    ----------
    figure : cfopt.paper.Figure
    paper : str
        The paper's side in words: the statistic, how it is stated, the value.
    against : str
        What it is set beside: cfopt's statistic over its trials (``"cfopt: max 4.61 MB
        over 24 trials"``), or for ``the paper disagrees with itself`` the other place.
    value : float or None
        cfopt's value (``None``: no trials, or a disagreement).
    trials : int
        cfopt's trials (or missions, blocks) behind it: the ``n`` of ``inconclusive``.
    tolerance : str
    verdict : Verdict
    reason : str
        One line: why, with both numbers and their ratio or difference.
    kind : str
        ``"figure"``, ``"shape"`` (a curve's slope) or ``"disagreement"``.
    """

    figure: Figure
    paper: str
    against: str
    value: float | None
    trials: int
    tolerance: str
    verdict: Verdict
    reason: str
    kind: str = "figure"

    @property
    def verdict_text(self) -> str:
        """The verdict as printed: ``"inconclusive: n = 3"`` with its sample size."""
        if self.verdict is INCONCLUSIVE:
            return f"inconclusive: n = {self.trials}"
        return self.verdict.value

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``cfopt reproduce --json``)."""
        f = self.figure
        return {
            "evaluation": f.evaluation,
            "section": f.section,
            "table": f.table,
            "algorithm": f.algorithm,
            "cells": _scope(f),
            "measure": f.measure,
            "statistic": f.statistic,
            "relation": f.relation,
            "kind": self.kind,
            "quote": f.quote,
            "paper": f.value,
            "paper_says": self.paper,
            "cfopt": self.value if self.value is None or math.isfinite(self.value) else None,
            "against": self.against,
            "trials": self.trials,
            "tolerance": self.tolerance,
            "verdict": self.verdict.value,
            "verdict_text": self.verdict_text,
            "reason": self.reason,
        }


def verdict_tally(counts: Mapping[str, int]) -> str:
    """The verdict counts in words, in :class:`Verdict` order, each verb in the number
    of its count.

    >>> verdict_tally({"differ": 1, "not comparable": 2, "the paper disagrees with itself": 3})
    '1 differs, 2 are not comparable, 3 find the paper disagreeing with itself'
    """
    verbs = {
        AGREE: ("agrees", "agree"),
        DIFFER: ("differs", "differ"),
        NOT_COMPARABLE: ("is not comparable", "are not comparable"),
        NO_TRIALS: ("has no trials", "have no trials"),
        INCONCLUSIVE: ("is inconclusive", "are inconclusive"),
        PAPER_DISAGREES: (
            "finds the paper disagreeing with itself",
            "find the paper disagreeing with itself",
        ),
    }
    parts = []
    for verdict, (one, many) in verbs.items():
        count = counts.get(verdict.value, 0)
        if count:
            parts.append(f"{count} {one if count == 1 else many}")
    return ", ".join(parts) or "no comparisons"


def _cells_text(name: str, values: tuple[Any, ...] | None, unit: str) -> str:
    if values is None:
        return ""
    return f"{name}{','.join(f'{v:g}' for v in values)}{unit}"


def _scope(f: Figure) -> str:
    parts = [
        _cells_text("n=", f.robots, ""),
        _cells_text("", f.percent_tasks, "% tasks"),
        ", ".join(f"{s}:{k}" for s, k in f.compositions or ()),
        ", ".join(f"not n={n} {p:g}% {s}:{k}" for n, p, s, k in f.excluding),
    ]
    return "; ".join(p for p in parts if p) or "all cells"


def _in_scope(t: Trial, f: Figure) -> bool:
    return (
        t.load == 1
        and (t.network is None) == (f.evaluation == "centralized")
        and f.covers(t.robots, t.percent_tasks, t.service_types, t.services_per_robot)
    )


def _scoped(trials: Sequence[Trial], f: Figure, algorithm: str | None = None) -> list[Trial]:
    name = algorithm or f.algorithm
    return [t for t in trials if _in_scope(t, f) and (name == "all" or t.algorithm == name)]


def _metric(f: Figure) -> Callable[[Trial], float | None]:
    """The trial value a figure is about (distributed runtime: simulated seconds)."""
    if f.measure == "percent_utility":
        return lambda t: t.percent_optimum
    if f.measure == "communication_mb":
        return megabytes
    if f.evaluation == "distributed":
        return lambda t: t.sim_seconds
    return lambda t: t.seconds


def _values(trials: Iterable[Trial], metric: Callable[[Trial], float | None]) -> list[float]:
    return [float(v) for t in trials if (v := metric(t)) is not None and math.isfinite(v)]


def _paper_trials(f: Figure) -> int:
    """The paper's trials behind a figure: 25 in each cell of its grid it covers."""
    covered = sum(f.covers(*cell) for cell in _grid(f.evaluation))
    return PAPER_MISSIONS * covered


@functools.cache
def _grid(evaluation: str) -> tuple[tuple[int, float, int, int], ...]:
    from cfopt.experiments import distributed_grid
    from cfopt.generate import paper_grid

    grid = paper_grid() if evaluation == "centralized" else distributed_grid()
    return tuple((c.robots, c.percent_tasks, c.service_types, c.services_per_robot) for c in grid)


def _si(x: float) -> str:
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    if abs(x) >= 1e5:
        return f"{x:.3g}"
    return f"{x:.2f}" if abs(x) < 100 else f"{x:,.0f}"


def _two(x: float | None) -> str:
    return "-" if x is None else _si(x)


_UNITS = {"percent_utility": " %", "communication_mb": " MB", "runtime_s": " s"}


def _unit(f: Figure) -> str:
    """The unit of the figure's value (none for counts, ratios, shares, slopes)."""
    if f.statistic in _RELATIVE[:3] or f.statistic in ("count", "growth exponent"):
        return " %" if f.statistic == "share lower" else ""
    return _UNITS.get(f.measure, "")


def _paper_side(f: Figure) -> str:
    stated = "" if f.relation == "=" else f"{f.relation} "
    value = f"{f.value:g}" if f.statistic == "count" else _si(f.value)
    return f"{f.statistic} {stated}{value}{_unit(f)} ({f.printed})"


def _range_text(threshold: tuple[float, float] | None, clock: str) -> str:
    """A count's range in words: ``"at least 240 simulated seconds"``."""
    low, high = threshold or (-math.inf, math.inf)
    if math.isinf(high):
        return f"at least {low:g} {clock}"
    if low <= 0:
        return f"under {high:g} {clock}"
    return f"{low:g} to {high:g} {clock}"


def _no_trials(f: Figure) -> Comparison:
    paper = _paper_test_side(f) if f.test else _paper_side(f)
    return Comparison(f, paper, "cfopt: -", None, 0, "-", NO_TRIALS,
                      "the store holds no trials of these cells")  # fmt: skip


# -------------------------------------------------------------- values and bounds
def _statistic(values: Sequence[float], f: Figure) -> float | None:
    """cfopt's value of the figure's statistic (``None``: too few values)."""
    ordered = sorted(values)
    if f.statistic in ("median", "every trial"):
        return float(np.median(ordered))
    if f.statistic == "count":
        low, high = f.threshold or (-math.inf, math.inf)
        return float(sum(low <= v < high for v in ordered))
    position = {"min": 0, "second lowest": 1, "max": -1, "second highest": -2}[f.statistic]
    if len(ordered) < (position + 1 if position >= 0 else -position):
        return None
    return ordered[position]


def _region(f: Figure) -> tuple[float, float, str]:
    """The values of cfopt's statistic that agree with the figure, and the tolerance in
    words."""
    p = f.value
    if f.measure == "percent_utility" or f.qualitative:
        if f.relation in ("<", "<="):
            return -math.inf, p, "on the bound's side (a threshold)"
        if f.relation in (">", ">="):
            return p, math.inf, "on the bound's side (a threshold)"
        points = MEDIAN_POINTS if f.statistic in ("median", "every trial") else OTHER_POINTS
        if f.measure != "percent_utility":
            return p / VOLUME_FACTOR, p * VOLUME_FACTOR, f"within a factor {VOLUME_FACTOR:g}"
        unit = "percentage point" if points == 1 else "percentage points"
        return p - points, p + points, f"within {points:g} {unit}"
    factor = VOLUME_FACTOR
    if f.relation in ("<", "<="):
        return p / factor, p, f"on the bound's side and within a factor {factor:g} of it"
    if f.relation in (">", ">="):
        return p, p * factor, f"on the bound's side and within a factor {factor:g} of it"
    return p / factor, p * factor, f"within a factor {factor:g}"


def _inside(value: float, low: float, high: float, relation: str) -> bool:
    if relation == "<":
        return low <= value < high
    if relation == ">":
        return low < value <= high
    return low <= value <= high


def _median_interval(values: Sequence[float]) -> tuple[float, float] | None:
    """The distribution-free 95 % interval of the median (``None`` below 6 values)."""
    from scipy import stats

    if len(values) < MEDIAN_INTERVAL_MIN:
        return None
    ci = stats.quantile_test(values, q=float(np.median(values)), p=0.5).confidence_interval()
    return float(ci.low), float(ci.high)


def _small_sample(
    f: Figure, value: float, values: Sequence[float], low: float, high: float
) -> tuple[str, str]:
    """(why a miss is the sample's -- ``""``: it is a difference, a note for the difference)."""
    if f.statistic in ("median", "every trial"):
        interval = _median_interval(values)
        if interval is None:
            return f"a median of {len(values)} trials has no 95 % interval", ""
        if interval[0] <= high and interval[1] >= low:
            return f"its 95 % interval [{_si(interval[0])}, {_si(interval[1])}] reaches it", ""
        return "", f" (95 % interval [{_si(interval[0])}, {_si(interval[1])}])"
    paper_n = _paper_trials(f)
    lows = f.statistic in ("min", "second lowest")
    less_extreme = value > high if lows else value < low
    if not less_extreme or len(values) >= paper_n:
        return "", ""
    why = f"an extreme of {len(values)} trials is expected less extreme than one of {paper_n}"
    if f.measure == "percent_utility":
        return why, ""  # rare events: a few missions may miss the paper's one bad trial
    spread = max(values) / min(values) if min(values) > 0 else math.inf
    reach = value / spread if lows else value * spread
    if (reach <= high) if lows else (reach >= low):
        return f"{why}, and cfopt's own values spread by a factor {spread:.3g}", ""
    return "", f" ({why}, but not by more than cfopt's own spread, a factor {spread:.3g})"


def _compare_values(f: Figure, values: Sequence[float], what: str) -> Comparison:
    value = _statistic(values, f)
    cfopt_side = f"cfopt: {f.statistic} {_two(value)}{_unit(f)} over {what}"
    if value is None:
        return Comparison(f, _paper_side(f), cfopt_side, None, len(values), "-", INCONCLUSIVE,
                          f"{len(values)} trials have no {f.statistic}")  # fmt: skip
    low, high, tolerance = _region(f)
    gap = (
        f"{value - f.value:+.2f} points"
        if f.measure == "percent_utility"
        else f"cfopt/paper = {value / f.value:.3g}"
        if f.value
        else f"cfopt {_si(value)}"
    )
    why, note = _small_sample(f, value, values, low, high)
    if _inside(value, low, high, f.relation):
        verdict, reason = AGREE, f"{gap}: {tolerance}"
    elif why:
        verdict, reason = INCONCLUSIVE, f"{gap}, but {why}"
    else:
        verdict, reason = DIFFER, f"{gap}: not {tolerance}{note}"
    return Comparison(f, _paper_side(f), cfopt_side, value, len(values), tolerance, verdict,
                      reason)  # fmt: skip


def _value(trials: Sequence[Trial], f: Figure) -> Comparison:
    values = _values(_scoped(trials, f), _metric(f))
    if not values:
        return _no_trials(f)
    what = plural(len(values), "trial")
    if f.curve:
        what += " (the level at this size; the curve's shape is its own line)"
    if f.measure == "communication_mb" and f.evaluation == "centralized":
        what += ", broadcast/full beliefs"
    if f.measure == "runtime_s":
        return _not_comparable(f, _statistic(values, f), len(values), what, trials)
    return _compare_values(f, values, what)


def _not_comparable(
    f: Figure, value: float | None, n: int, what: str, trials: Sequence[Trial]
) -> Comparison:
    clock = "simulated seconds" if f.evaluation == "distributed" else "wall seconds"
    if f.evaluation == "distributed":
        why = (
            "cfopt's simulated seconds under its own clock against the seed's wall time on its "
            "cluster"
        )
    else:
        why = (
            "the wall time of cfopt's Python engines on this machine against the seed's C++ on "
            "its workstation"
        )
    if f.groups and f.statistic in ("median ratio", "share lower"):
        why += "; an order of two implementations' speeds"
    work = [t.work for t in _scoped(trials, f) if t.work is not None]
    if work:
        why += f"; median counted work {_si(float(np.median(work)))}"
    if f.statistic in _RELATIVE[:3]:
        cfopt_side = f"cfopt: {_two(value)} ({what} of the {clock})"
    elif f.statistic in _RELATIVE:
        cfopt_side = f"cfopt: {f.statistic} {_two(value)} {clock} ({what}, {plural(n, 'trial')})"
    elif f.statistic == "count":
        within = _range_text(f.threshold, clock)
        cfopt_side = f"cfopt: {int(value or 0)} of {plural(n, 'trial')} took {within}"
    else:
        cfopt_side = f"cfopt: {f.statistic} {_two(value)} {clock} over {what}"
    return Comparison(f, _paper_side(f), cfopt_side, value, n, "-", NOT_COMPARABLE, why)


# ------------------------------------------------------------ relative figures
def _by_algorithm(trials: Sequence[Trial], f: Figure, name: str) -> list[float]:
    return _values(_scoped(trials, f, name), _metric(f))


def _iqr(values: Sequence[float]) -> float:
    q1, q3 = np.percentile(values, [25, 75])
    return float(q3 - q1)


def _relative_value(trials: Sequence[Trial], f: Figure) -> tuple[float | None, int, str]:
    """cfopt's value of a relative statistic, its sample and what it is."""
    metric = _metric(f)
    if f.statistic in ("median ratio", "spread ratio"):
        a, b = (_by_algorithm(trials, f, g) for g in f.groups)
        if not a or not b:
            return None, 0, ""
        of = np.median if f.statistic == "median ratio" else _iqr
        top, bottom = float(of(a)), float(of(b))
        ratio = top / bottom if bottom else (1.0 if top == bottom else math.inf)
        return ratio, min(len(a), len(b)), f"{f.groups[0]} / {f.groups[1]}"
    if f.statistic == "share lower":
        observations = [((t.cell, t.mission_seed), t.algorithm, metric(t)) for t in
                        _scoped(trials, f, "all")]  # fmt: skip
        paired = complete_blocks(observations, f.groups)
        a, b = (paired[g] for g in f.groups)
        if not a:
            return None, 0, ""
        share = 100 * sum(x < y for x, y in zip(a, b, strict=True)) / len(a)
        return share, len(a), f"% of missions with {f.groups[0]} < {f.groups[1]}"
    medians = _cell_medians(_scoped(trials, f), f, metric)
    if not medians:
        return None, 0, ""
    n = len(_scoped(trials, f))
    if f.statistic == "largest cell median":
        return max(medians.values()), n, "largest median of a cell"
    if f.statistic == "cell median range":
        return max(medians.values()) - min(medians.values()), n, "medians of the compositions"
    first, second = (medians.get(tuple(map(int, g.split(":")))) for g in f.groups)
    if first is None or second is None:
        return None, 0, ""
    return abs(first - second), n, f"|median {f.groups[0]} - median {f.groups[1]}|"


def _cell_medians(
    trials: Sequence[Trial], f: Figure, metric: Callable[[Trial], float | None]
) -> dict[Any, float]:
    """Median per cell; per composition for the statistics over compositions."""
    by_composition = f.statistic in ("cell median range", "median difference")
    groups: dict[Any, list[float]] = defaultdict(list)
    for t in trials:
        v = metric(t)
        if v is not None and math.isfinite(v):
            key = (t.service_types, t.services_per_robot) if by_composition else t.cell
            groups[key].append(float(v))
    return {k: float(np.median(v)) for k, v in groups.items()}


def _holds(value: float, relation: str, bound: float) -> bool:
    return {
        "=": value == bound,
        "~": bound / VOLUME_FACTOR <= value <= bound * VOLUME_FACTOR,
        "<": value < bound,
        "<=": value <= bound,
        ">": value > bound,
        ">=": value >= bound,
    }[relation]


def _relative(trials: Sequence[Trial], f: Figure) -> Comparison:
    value, n, what = _relative_value(trials, f)
    if value is None:
        return _no_trials(f)
    if f.measure == "runtime_s":
        return _not_comparable(f, value, n, what, trials)
    side = f"cfopt: {value:.3g} ({what}, {plural(n, 'trial')} each)"
    tolerance = "on the paper's side" if f.relation != "=" else "the same"
    bound = f.value
    if f.statistic in ("median ratio", "spread ratio") and f.relation in ("<", ">"):
        bound = f.value * RATIO_MARGIN if f.relation == ">" else f.value / RATIO_MARGIN
        tolerance += f", by more than {100 * (RATIO_MARGIN - 1):.0f} %"
    if _holds(value, f.relation, bound):
        verdict, reason = AGREE, f"{value:.3g} {f.relation} {bound:.3g}"
    elif n < MEDIAN_INTERVAL_MIN:
        verdict, reason = INCONCLUSIVE, f"{value:.3g} from {plural(n, 'trial')} a side"
    else:
        verdict, reason = DIFFER, f"{value:.3g}, not {f.relation} {bound:.3g}"
    return Comparison(f, _paper_side(f), side, value, n, tolerance, verdict, reason)


# ------------------------------------------------------------------- counts
def _fisher(f: Figure, hits: int, total: int, what: str) -> Comparison:
    from scipy.stats import fisher_exact

    paper_total = _paper_trials(f)
    paper_hits = int(f.value)
    _, p = fisher_exact([[paper_hits, paper_total - paper_hits], [hits, total - hits]])
    smallest = min(
        fisher_exact([[paper_hits, paper_total - paper_hits], [h, total - h]])[1]
        for h in range(total + 1)
    )
    side = f"cfopt: {what} in {hits} of {total} ({100 * hits / total:.1f} %)"
    paper = f"count {paper_hits} of {paper_total} ({100 * paper_hits / paper_total:.1f} %)"
    reason = f"Fisher's exact p = {p:.3g}"
    if smallest >= ALPHA:
        verdict, reason = INCONCLUSIVE, reason + f"; no {total} trials could reject at 5 %"
    else:
        verdict = AGREE if p >= ALPHA else DIFFER
    return Comparison(f, paper, side, float(hits), total, "Fisher's exact test at 5 %", verdict,
                      reason)  # fmt: skip


def _count(trials: Sequence[Trial], f: Figure) -> Comparison:
    scoped = _scoped(trials, f)
    if not scoped and f.measure != "solved_trials":
        return _no_trials(f)
    if f.measure == "pairwise_step_ran":
        return _fisher(f, sum(bool(t.pairwise_step_ran) for t in scoped), len(scoped), "it ran")
    if f.measure == "optimal_trials":
        hits = sum(1 for t in scoped if (t.percent_optimum or 0) >= 100 - 1e-9)
        return _fisher(f, hits, len(scoped), "optimal")
    if f.measure in ("cut_trials", "completed_trials"):
        cut = sum(bool(t.cut) for t in scoped)
        value = cut if f.measure == "cut_trials" else len(scoped) - cut
        side = f"cfopt: {value} of {len(scoped)} {'cut' if f.measure == 'cut_trials' else 'done'}"
        why = "stopped by cfopt's simulated time limit, against the seed's one-hour wall limit"
        return Comparison(f, _paper_side(f), side, float(value), len(scoped), "-",
                          NOT_COMPARABLE, why)  # fmt: skip
    return _solved(trials, f)


def _solved(trials: Sequence[Trial], f: Figure) -> Comparison:
    names = f.groups or (f.algorithm,)
    missions = {(t.cell, t.mission_seed) for t in trials if _in_scope(t, f)}
    if not missions:
        return _no_trials(f)
    solved = {a: len({(t.cell, t.mission_seed) for t in _scoped(trials, f, a)}) for a in names}
    side = "cfopt: " + ", ".join(f"{a} {k} of {len(missions)}" for a, k in solved.items())
    every = all(k == len(missions) for k in solved.values())
    reason = "a solution on every mission" if every else "some missions have no solution"
    return Comparison(f, f"every trial solved ({f.printed})", side, float(min(solved.values())),
                      len(missions), "all", AGREE if every else DIFFER, reason)  # fmt: skip


def _iterations(trials: Sequence[Trial], f: Figure) -> Comparison:
    runs = [t for t in _scoped(trials, f) if t.iterations is not None]
    if not runs:
        return _no_trials(f)
    exact = sum(1 for t in runs if t.iterations == t.robots)
    side = f"cfopt: exactly n in {exact} of {len(runs)}"
    agree = exact == len(runs)
    return Comparison(f, "every run exactly n iterations", side, exact / len(runs), len(runs),
                      "all", AGREE if agree else DIFFER,
                      "every run" if agree else f"{len(runs) - exact} runs took more")  # fmt: skip


# ------------------------------------------------------------------- curves
def _fit(sizes: Sequence[float], values: Sequence[float]) -> tuple[float, float, float]:
    """Log-log slope and its 95 % interval (a point when the fit is exact)."""
    from scipy import stats

    fit = stats.linregress(np.log(sizes), np.log(values))
    if len(sizes) < 3 or not math.isfinite(fit.stderr):
        return float(fit.slope), float(fit.slope), float(fit.slope)
    t = float(stats.t.ppf(0.975, len(sizes) - 2))
    return float(fit.slope), float(fit.slope - t * fit.stderr), float(fit.slope + t * fit.stderr)


def _cfopt_slope(trials: Sequence[Trial], f: Figure) -> tuple[float, float, float, int] | None:
    metric = _metric(f)
    points = [(t.robots, v) for t in _scoped(trials, f) if (v := metric(t)) and v > 0]
    if len({n for n, _ in points}) < 2:
        return None
    slope, low, high = _fit([n for n, _ in points], [v for _, v in points])
    return slope, low, high, len(points)


def _slope_comparison(trials: Sequence[Trial], f: Figure, paper: str, kind: str) -> Comparison:
    fit = _cfopt_slope(trials, f)
    if fit is None:
        return dataclasses.replace(_no_trials(f), kind=kind)
    slope, low, high, n = fit
    side = f"cfopt: slope {slope:.2f}, 95 % interval [{low:.2f}, {high:.2f}], {n} trials"
    agree = abs(slope - f.value) <= SLOPE_TOLERANCE or low <= f.value <= high
    tolerance = f"within {SLOPE_TOLERANCE:g} or inside cfopt's 95 % interval"
    reason = f"slopes {slope:.2f} (cfopt) and {f.value:.2f} (paper): {slope - f.value:+.2f}"
    return Comparison(f, paper, side, slope, n, tolerance, AGREE if agree else DIFFER, reason,
                      kind)  # fmt: skip


def _shape(trials: Sequence[Trial], curve: Sequence[Figure]) -> Comparison:
    """A curve's shape: the slope of the paper's points against cfopt's fit."""
    sizes = [f.robots[0] for f in curve if f.robots]
    slope, _, _ = _fit(sizes, [f.value for f in curve])
    f = dataclasses.replace(
        curve[0], robots=tuple(sizes), statistic="growth exponent", value=round(slope, 2),
        relation="~", printed=", ".join(f.printed for f in curve), curve="",
    )  # fmt: skip
    paper = f"slope {slope:.2f} of {', '.join(f'{_si(c.value)}' for c in curve)} MB at n = "
    paper += ", ".join(map(str, sizes))
    return _slope_comparison(trials, f, paper, "shape")


# -------------------------------------------------------------------- tests
_TEST_NAMES = {
    "friedman": "Friedman", "conover": "Conover (after Friedman)", "kruskal": "Kruskal-Wallis",
    "mann-whitney": "Mann-Whitney-Wilcoxon", "wilcoxon": "Wilcoxon signed-rank",
}  # fmt: skip


def paper_test(trials: Sequence[Trial], f: Figure) -> StatResult:
    """cfopt's run of the test a figure reports: the paper's test on cfopt's trials of the
    same cells, algorithms and factor (a Kruskal-Wallis test of two levels is run as
    Mann-Whitney-Wilcoxon; Conover's pairs come with their Friedman test).

    Raises
    ------
    ValueError
        ``f`` is not a test figure.
    """
    if not f.test:
        raise ValueError(f"f: not a test figure ({f.measure} {f.statistic})")
    metric = _metric(f)
    scoped = [t for t in trials if _in_scope(t, f) and t.algorithm != EXACT]
    if f.factor == "algorithm":
        names = f.groups
        observations = [((t.cell, t.mission_seed), t.algorithm, metric(t)) for t in scoped]
        aligned = complete_blocks(observations, names)
        return wilcoxon(aligned) if f.test == "wilcoxon" else friedman(aligned)
    levels: dict[float, list[float]] = defaultdict(list)
    for t in scoped:
        v = metric(t)
        if t.algorithm == f.algorithm and v is not None and math.isfinite(v):
            levels[float(getattr(t, f.factor))].append(float(v))
    groups = {f"{level:g}": levels[level] for level in sorted(levels)}
    if f.pair:
        groups = {g: groups.get(g, []) for g in f.pair}
    return kruskal(groups) if len(groups) >= 3 else mann_whitney(groups)


def _paper_test_side(f: Figure) -> str:
    from scipy.stats import chi2

    name = _TEST_NAMES[f.test] + (f" {'/'.join(f.pair)}" if f.pair else "")
    statistic = f" {f.statistic} = {f.value:g}" if f.statistic != "p" else ""
    n = f" (n = {f.n})" if f.n else ""
    p = f", p {f.p}" if f.p else ""
    if f.statistic in ("chi2", "H"):
        dof = max(len(f.groups) - 1, 1)
        p += f" (from the statistic: {chi2.sf(f.value, dof):.2g})"
    verdict = "significant" if f.significant else "not significant"
    return f"{name}{statistic}{n}{p}: {verdict}{_paper_direction(f)}"


def _paper_direction(f: Figure) -> str:
    if f.lowest:
        return f"; lowest: {f.lowest}"
    if f.trend:
        return f"; {f.trend} with {f.factor.replace('_', ' ')}"
    return ""


def _cfopt_direction(result: StatResult, f: Figure) -> tuple[str, str]:
    """(lowest group, trend) of cfopt's result, for a post-hoc pair between the two."""
    if f.pair and result.test == "Friedman":
        ranks = dict(zip(result.groups, result.mean_ranks, strict=False))
        a, b = f.pair
        if a in ranks and b in ranks and ranks[a] != ranks[b]:
            return (a if ranks[a] < ranks[b] else b), ""
        return "", ""
    return result.lowest or "", result.trend


def _test_outcome(result: StatResult, f: Figure) -> tuple[bool, float | None]:
    """(significant, p) of cfopt's result, of the figure's pair for Conover."""
    if f.test == "conover":
        pair = result.pair(*f.pair)
        return (pair is not None and pair.significant), (pair.p_value if pair else None)
    return result.significant, result.p_value


def _p_text(p: float | None) -> str:
    """A p-value in two significant digits, three where two would print the 5 % level.

    >>> _p_text(0.0498), _p_text(0.0312), _p_text(None)
    ('0.0498', '0.031', '-')
    """
    if p is None:
        return "-"
    text = f"{p:.2g}"
    return f"{p:.3g}" if float(text) == ALPHA and p != ALPHA else text


def _cfopt_test_side(result: StatResult, f: Figure) -> str:
    significant, p = _test_outcome(result, f)
    if result.outcome is not Outcome.TESTED:
        return f"cfopt: {result.note} ({result.test}, n = {result.n})"
    statistic = f"{result.statistic:.4g}" if result.statistic is not None else "-"
    lowest, trend = _cfopt_direction(result, f)
    direction = f"; lowest: {lowest}" if lowest else ""
    if trend and f.factor != "algorithm":
        direction += f"; {trend}"
    test = f"{result.test} {statistic}"
    if f.test == "conover":  # the pair's p, after the Friedman test it follows
        overall = _p_text(result.p_value)
        test = f"Conover {'/'.join(f.pair)} (after Friedman {statistic}, p = {overall})"
    return (
        f"cfopt: {test}, p = {_p_text(p)} ({result.n} "
        f"{'blocks' if f.factor == 'algorithm' else 'trials'}): "
        f"{'significant' if significant else 'not significant'}{direction}; mean ranks "
        f"{result.direction()}"
    )


def _test_verdict(result: StatResult, f: Figure) -> tuple[Verdict, str]:
    significant, _ = _test_outcome(result, f)
    if result.outcome is Outcome.NOT_ENOUGH_DATA:
        return INCONCLUSIVE, result.note
    if not result.has_power:
        return INCONCLUSIVE, (
            f"the smallest p {result.n} values can give is {result.smallest_p:.2g}: no power"
        )
    if significant != f.significant:
        said = "significant" if f.significant else "not significant"
        found = "significant" if significant else "not significant"
        if result.outcome is Outcome.NO_VARIATION:
            found = result.note
        return DIFFER, f"the paper: {said}; cfopt: {found}"
    if not significant:
        return AGREE, "neither significant"
    lowest, trend = _cfopt_direction(result, f)
    if f.lowest and lowest != f.lowest:
        return (
            DIFFER,
            f"both significant, direction reversed: lowest {lowest or 'tied'}, "
            f"the paper {f.lowest}",
        )
    if f.trend and f.factor != "algorithm" and trend != f.trend:
        factor = f.factor.replace("_", " ")
        return DIFFER, f"both significant, but with {factor} cfopt: {trend}; the paper: {f.trend}"
    stated = (
        "and the same direction" if (f.lowest or f.trend) else "(the paper states no direction)"
    )
    return AGREE, f"both significant {stated}"


def _test(trials: Sequence[Trial], f: Figure) -> Comparison:
    result = paper_test(trials, f)
    if result.n == 0:
        return _no_trials(f)
    side = _cfopt_test_side(result, f)
    tolerance = "significance at 5 % and the paper's direction"
    _, p = _test_outcome(result, f)
    statistic = result.statistic if f.test != "conover" else p
    if f.measure == "runtime_s" and (f.evaluation == "distributed" or f.factor == "algorithm"):
        why = (
            "cfopt's simulated seconds against the seed's wall time"
            if f.evaluation == "distributed"
            else "which algorithm is fastest depends on how each is implemented (cfopt's Python "
            "engines against the seed's C++)"
        )
        return Comparison(f, _paper_test_side(f), side, statistic, result.n, "-",
                          NOT_COMPARABLE, why)  # fmt: skip
    verdict, reason = _test_verdict(result, f)
    return Comparison(f, _paper_test_side(f), side, statistic, result.n, tolerance, verdict,
                      reason)  # fmt: skip


# ----------------------------------------------------------------- dispatch
_RELATIVE = ("median ratio", "spread ratio", "share lower", "median difference",
             "cell median range", "largest cell median")  # fmt: skip
_COUNTS = ("solved_trials", "pairwise_step_ran", "optimal_trials", "cut_trials",
           "completed_trials")  # fmt: skip


def _compare(trials: Sequence[Trial], f: Figure) -> Comparison:
    """One figure beside cfopt's, with the figure's note (how the paper is read) after
    its reason."""
    c = _compare_kind(trials, f)
    if f.note and c.verdict is not NO_TRIALS:
        c = dataclasses.replace(c, reason=f"{c.reason} ({f.note})")
    return c


def _compare_kind(trials: Sequence[Trial], f: Figure) -> Comparison:
    if f.test:
        return _test(trials, f)
    if f.measure in _COUNTS:
        return _count(trials, f)
    if f.measure == "iterations":
        return _iterations(trials, f)
    if f.statistic == "growth exponent":
        paper = f"growth exponent ~ {f.value:g} ({f.printed})"
        return _slope_comparison(trials, f, paper, "figure")
    if f.statistic in _RELATIVE:
        return _relative(trials, f)
    return _value(trials, f)


def _disagreement(d: Disagreement) -> Comparison:
    f = d.figure
    return Comparison(
        f, f"“{f.quote}”", f"the paper, {d.other_section}: “{d.other_quote}”",
        None, 0, "-", PAPER_DISAGREES, d.why, "disagreement",
    )  # fmt: skip


def compare_figures(
    trials: Sequence[Trial], figures: Iterable[Figure] = FIGURES
) -> list[Comparison]:
    """Every figure beside cfopt's value over the same cells (achievable missions, load 1:
    the seed's; centralized figures from centralized trials, distributed ones from
    distributed trials), in the figures' order; a curve's shape after its last level, and
    a disagreement of the paper with itself after its figure.  The sample sizes
    (:attr:`cfopt.paper.Figure.sample_size`) are no comparison: they are the header of the
    report (:func:`sample_sizes`)."""
    trials = [t for t in trials if t.algorithm != EXACT]
    chosen = [f for f in figures if not f.sample_size]
    curves: dict[str, list[Figure]] = defaultdict(list)
    for f in chosen:
        if f.curve:
            curves[f.curve].append(f)
    out = []
    for f in chosen:
        out.append(_compare(trials, f))
        if f.curve and curves[f.curve][-1] is f:
            out.append(_shape(trials, curves[f.curve]))
        out.extend(_disagreement(d) for d in DISAGREEMENTS if d.figure == f)
    return out


def sample_sizes(trials: Sequence[Trial]) -> list[str]:
    """The header's sample: per evaluation, cfopt's missions per cell and trials per
    algorithm beside the paper's."""
    lines = []
    for evaluation, paper in (("centralized", "§5"), ("distributed", "§6")):
        mine = [t for t in trials if t.algorithm != EXACT and t.load == 1
                and (t.network is None) == (evaluation == "centralized")]  # fmt: skip
        if not mine:
            continue
        per_algorithm: dict[str, int] = defaultdict(int)
        per_cell: dict[tuple[str, str], int] = defaultdict(int)
        for t in mine:
            per_algorithm[t.algorithm] += 1
            per_cell[(t.algorithm, t.cell)] += 1
        missions = sorted(set(per_cell.values()))
        theirs = [f for f in FIGURES if f.sample_size and f.evaluation == evaluation]
        paper_text = "; ".join(
            f"{f.printed} {'per algorithm' if f.algorithm == 'all' else f'{f.algorithm} (10:5)'}"
            for f in theirs
        )
        lines.append(
            f"{evaluation} ({paper}): {'-'.join(map(str, missions))} "
            f"{'mission' if missions == [1] else 'missions'} per cell, "
            + ", ".join(f"{a} {plural(k, 'trial')}" for a, k in sorted(per_algorithm.items()))
            + f" (the paper: 25 missions per cell, {paper_text})"
        )
    return lines


# -------------------------------------------------------------------- the document
def comparison_table(comparisons: Sequence[Comparison]) -> tuple[list[str], list[list[str]]]:
    """One row per comparison: where, what, the paper's side, what it is set beside,
    the tolerance, the verdict and why."""
    header = [
        "evaluation", "where", "algorithm", "cells", "measure", "paper", "against",
        "tolerance", "verdict", "reason",
    ]  # fmt: skip
    rows = []
    for c in comparisons:
        f = c.figure
        where = f.section + ("" if f.table == "text" else f", {f.table}")
        rows.append(
            [
                f.evaluation, where, f.algorithm, _scope(f), f.measure, c.paper, c.against,
                c.tolerance, c.verdict_text, c.reason,
            ]
        )  # fmt: skip
    return header, rows


def paper_layout_table(
    comparisons: Sequence[Comparison], table: str
) -> tuple[list[str], list[list[str]]]:
    """One of the paper's utility tables (2, 4 or 5) in its layout -- per composition,
    percent tasks and collective size: median, min, max -- each as ``paper / cfopt``,
    two decimals, with the verdicts."""
    header = ["composition", "% tasks", "robots", "median", "min", "max", "verdicts"]
    groups: dict[tuple[Any, ...], dict[str, Comparison]] = defaultdict(dict)
    for c in comparisons:
        f = c.figure
        if f.table == table and c.kind == "figure":
            groups[(f.compositions, f.percent_tasks, f.robots)][f.statistic] = c
    rows = []
    for (compositions, percent, robots), stats in groups.items():
        cells = [
            f"{stats[name].figure.value:.2f} / {_decimals(stats[name].value)}"
            for name in ("median", "min", "max")
        ]
        verdicts = {c.verdict_text for c in stats.values()}
        summary = (
            next(iter(verdicts))
            if len(verdicts) == 1
            else "; ".join(
                f"{name} {stats[name].verdict_text}" for name in ("median", "min", "max")
            )
        )
        (s, k), (p,), (n,) = compositions[0], percent, robots
        rows.append([f"{s}:{k}", f"{p:g}", str(n), *cells, summary])
    return header, rows


def _decimals(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def iteration_table(trials: Sequence[Trial]) -> tuple[list[str], list[list[str]]]:
    """GRAPE-S and Pair-GRAPE-S iterations per evaluation, composition and size: runs,
    runs with exactly ``n`` iterations, median and maximum ``iterations / n``."""
    header = [
        "evaluation", "algorithm", "composition", "robots", "runs", "exactly n", "median it/n",
        "max it/n",
    ]  # fmt: skip
    groups: dict[tuple[Any, ...], list[Trial]] = defaultdict(list)
    for t in trials:
        if t.algorithm in GRAPE_S_ALGORITHMS and t.iterations is not None:
            evaluation = "centralized" if t.network is None else "distributed"
            key = (evaluation, t.algorithm, t.service_types, t.services_per_robot, t.robots)
            groups[key].append(t)
    rows = []
    for (evaluation, algorithm, s, k, n), group in sorted(groups.items()):
        ratios = [t.iterations / t.robots for t in group]
        exact = sum(1 for t in group if t.iterations == t.robots)
        rows.append(
            [
                evaluation, algorithm, f"{s}:{k}", str(n), str(len(group)), str(exact),
                f"{np.median(ratios):.2f}", f"{max(ratios):.2f}",
            ]
        )  # fmt: skip
    return header, rows


def pairwise_table(trials: Sequence[Trial]) -> tuple[list[str], list[list[str]]]:
    """In how many Pair-GRAPE-S runs the pairwise step ran, per evaluation and composition,
    beside the paper's count where it gives one."""
    header = ["evaluation", "composition", "step ran", "runs", "share", "paper"]
    paper = {
        (f.evaluation, *f.compositions[0]): f
        for f in FIGURES
        if f.measure == "pairwise_step_ran" and f.compositions
    }
    groups: dict[tuple[Any, ...], list[Trial]] = defaultdict(list)
    for t in trials:
        if t.algorithm == PAIRWISE_ALGORITHM and t.load == 1:
            evaluation = "centralized" if t.network is None else "distributed"
            groups[(evaluation, t.service_types, t.services_per_robot)].append(t)
    rows = []
    for key, group in sorted(groups.items()):
        ran = sum(1 for t in group if t.pairwise_step_ran)
        f = paper.get(key)
        published = "-"
        if f is not None:
            total = _paper_trials(f)
            published = f"{f.value:g} of {total} ({100 * f.value / total:.1f} %)"
        rows.append(
            [key[0], f"{key[1]}:{key[2]}", str(ran), str(len(group)),
             f"{100 * ran / len(group):.1f} %", published]
        )  # fmt: skip
    return header, rows


def runtime_table(trials: Sequence[Trial]) -> tuple[list[str], list[list[str]]]:
    """Per evaluation, algorithm and size: median wall seconds, median counted work
    (machine-independent), median simulated seconds (distributed), and the share of runs
    meeting the seed's viability targets (> 95 % utility, < 5 min; distributed: simulated
    minutes)."""
    header = [
        "evaluation", "algorithm", "robots", "runs", "wall s: median (max)",
        "work: median (max)", "simulated s: median (max)", "> 95 % utility", "< 5 min",
    ]  # fmt: skip
    groups: dict[tuple[Any, ...], list[Trial]] = defaultdict(list)
    for t in trials:
        if t.algorithm != EXACT and t.load == 1:
            evaluation = "centralized" if t.network is None else "distributed"
            groups[(evaluation, t.algorithm, t.robots)].append(t)
    rows = []
    for (evaluation, algorithm, n), group in sorted(groups.items()):
        seconds = [t.seconds for t in group]
        work = [float(t.work) for t in group if t.work is not None]
        sim = [t.sim_seconds for t in group if t.sim_seconds is not None]
        clock = sim if evaluation == "distributed" else seconds
        good = sum(1 for t in group if (t.percent_optimum or 0) > VIABLE_PERCENT)
        fast = sum(1 for x in clock if x < VIABLE_SECONDS)
        rows.append(
            [
                evaluation, algorithm, str(n), str(len(group)), format_median_max(seconds),
                format_median_max(work), format_median_max(sim), f"{good}/{len(group)}",
                f"{fast}/{len(group)}",
            ]
        )  # fmt: skip
    return header, rows


def paper_tests_table(comparisons: Sequence[Comparison]) -> tuple[list[str], list[list[str]]]:
    """The paper's statistical results, each re-run on cfopt's trials with the paper's
    test, groups and cells: the paper's statistic, p and direction, cfopt's, the verdict."""
    header = ["where", "measure", "subject", "cells", "the paper", "cfopt", "verdict", "why"]
    rows = []
    for c in comparisons:
        f = c.figure
        if not f.test or c.kind != "figure":
            continue
        subject = f.algorithm if f.factor != "algorithm" else ", ".join(f.groups)
        if f.factor != "algorithm":
            subject += f" by {f.factor.replace('_', ' ')}"
        rows.append(
            [f.section, f.measure, subject, _scope(f), c.paper, c.against.removeprefix("cfopt: "),
             c.verdict_text, c.reason]
        )  # fmt: skip
    return header, rows


#: The communication models every centralized run records.
MODELS = (("broadcast", "full"), ("broadcast", "compact"), ("unicast", "full"),
          ("unicast", "compact"))  # fmt: skip


def communication_models(trials: Sequence[Trial]) -> dict[str, Any]:
    """GRAPE-S's communication per collective size under each model beside the seed's
    (compositions 5:1, 5:5 and 10:1, where the seed gives one figure per size), the
    log-log slope of each model against the seed's, and the model whose slope is nearest.

    Returns ``{"sizes": [...], "paper": [...], "models": {name: {"mb": [...], "slope",
    "factor", "messages": [...], "per_message": [...]}}, "paper_slope", "best"}``;
    ``factor`` is the geometric mean of paper / cfopt over the sizes; ``messages`` the
    median messages (transmissions) of cfopt's runs and ``per_message`` the seed's bytes
    divided by them: the message size the seed's figures imply under that model's message
    count (a constant means the model's count has the seed's shape and only the message
    size differs).
    """
    published = {f.robots[0]: f.value for f in FIGURES if f.curve == COMMUNICATION_CURVE}
    sizes = sorted(published)
    chosen = [
        t for t in trials
        if t.algorithm == COMMUNICATION_ALGORITHM and t.network is None and t.load == 1
        and (t.service_types, t.services_per_robot) != (10, 5)
    ]  # fmt: skip
    paper = [published[n] for n in sizes]
    out: dict[str, Any] = {"sizes": sizes, "paper": paper, "models": {}}
    out["paper_slope"] = _slope(sizes, paper)
    for model in MODELS:
        mb = []
        for n in sizes:
            values = [v for t in chosen if t.robots == n and (v := megabytes(t, model))]
            mb.append(float(np.median(values)) if values else None)
        if any(v is None for v in mb):
            continue
        slope = _slope(sizes, mb)
        factor = math.exp(float(np.mean([math.log(p / c) for p, c in zip(paper, mb, strict=True)])))
        messages = [_median_messages(chosen, n, model) for n in sizes]
        per_message = [p * _MB / c if c else None for p, c in zip(paper, messages, strict=True)]
        out["models"]["/".join(model)] = {
            "mb": mb,
            "slope": slope,
            "factor": factor,
            "messages": messages,
            "per_message": per_message,
        }
    if out["models"]:
        out["best"] = min(
            out["models"], key=lambda k: abs(out["models"][k]["slope"] - out["paper_slope"])
        )
    return out


def _median_messages(trials: Sequence[Trial], robots: int, model: tuple[str, str]) -> float:
    """Median messages of the trials of ``robots`` robots under ``model`` (0 without rows)."""
    counts = [
        float(messages)
        for t in trials
        if t.robots == robots
        for medium, encoding, messages, _ in (t.communication or ())
        if (medium, encoding) == model
    ]
    return float(np.median(counts)) if counts else 0.0


def _slope(sizes: Sequence[float], values: Sequence[float]) -> float:
    return _fit(sizes, values)[0]


def _models_table(models: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    sizes = models["sizes"]
    header = ["model", *(f"n={n} MB" for n in sizes), "slope", "paper / cfopt",
              "paper bytes per cfopt message"]  # fmt: skip
    rows = [["paper (§5.1.2)", *(_si(v) for v in models["paper"]), f"{models['paper_slope']:.2f}",
             "-", "-"]]  # fmt: skip
    for name, m in models["models"].items():
        implied = ", ".join("-" if v is None else _si(v) for v in m["per_message"])
        rows.append(
            [name, *(_si(v) for v in m["mb"]), f"{m['slope']:.2f}", f"{m['factor']:.3g}", implied]
        )
    return header, rows


def _models_plot(models: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(models["sizes"], models["paper"], "ko-", label="the seed (§5.1.2)", linewidth=2)
    for name, m in models["models"].items():
        ax.plot(models["sizes"], m["mb"], "o--", label=f"cfopt {name}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("robots")
    ax.set_ylabel("GRAPE-S communication (MB)")
    ax.set_title("Communication models against the seed (5:1, 5:5, 10:1)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_reproduction(
    trials: Sequence[Trial],
    comparisons: Sequence[Comparison],
    directory: str | os.PathLike[str],
    *,
    missions: int,
    version: str = "",
    force: bool = False,
) -> list[Path]:
    """Write ``reproduction.md``/``.html``/``.csv``, ``reproduction_tests.csv`` and
    ``communication_models.png`` into ``directory`` (staged, then moved into place; an
    existing file is replaced only with ``force``)."""
    from cfopt.report import _publish, _render, _staging, _write_csv, check_free

    directory = Path(directory)
    if not force:
        check_free(directory, REPRODUCTION_FILES)
    created = make_directory(directory)
    trials = [t for t in trials if t.algorithm != EXACT]
    with _staging(directory, created) as stage:
        header, rows = comparison_table(comparisons)
        _write_csv(stage / "reproduction.csv", header, rows, "x")
        tests = paper_tests_table(comparisons)
        _write_csv(stage / "reproduction_tests.csv", *tests, "x")
        models = communication_models(trials)
        _models_plot(models, stage / "communication_models.png")
        blocks = _document(trials, comparisons, models, tests, missions, version, stage)
        title = "cfopt reproduce: the seed paper's figures beside cfopt's"
        markdown, page = _render(blocks, stage, title)
        for name, text in (("reproduction.md", markdown), ("reproduction.html", page)):
            (stage / name).write_text(text, encoding="utf-8")
        _publish(stage, directory, REPRODUCTION_FILES, force)
    return [directory / n for n in REPRODUCTION_FILES]


def _counts(comparisons: Sequence[Comparison]) -> dict[str, int]:
    counts: dict[str, int] = defaultdict(int)
    for c in comparisons:
        counts[c.verdict.value] += 1
    return dict(counts)


_RULES = (
    "Every row states the paper's statistic, cfopt's over the same cells, the tolerance and "
    "the verdict. Tolerances: a median of percent utility within 1 percentage point, other "
    "percent utilities within 5 points, a utility bound on its side; volumes within a factor "
    "2, a volume bound on its side and within a factor 2 of it; a bound against the "
    "statistic that bounds it (a worst case against cfopt's maximum); counts by Fisher's "
    "exact test at 5 %; a curve's shape (log-log slope within 0.25, or inside cfopt's 95 % "
    "interval) and its level at each size as separate lines; a test when both its "
    "significance at 5 % and the paper's direction agree. Seconds are not comparable: "
    "cfopt's Python engines on this machine against the seed's C++, cfopt's simulated "
    "seconds against the seed's wall time on its cluster, and which algorithm is fastest "
    "depends on each implementation; cfopt's value and its counted work are given beside "
    "them. 'inconclusive: n = 3' is a sample that cannot decide: a test that could not "
    "reach p < 0.05 with these groups, a median of fewer than 6 trials or whose 95 % "
    "interval reaches the tolerance, an extreme of fewer trials than the paper's that is "
    "less extreme than the paper's."
)


def _document(
    trials: Sequence[Trial],
    comparisons: Sequence[Comparison],
    models: dict[str, Any],
    tests: tuple[list[str], list[list[str]]],
    missions: int,
    version: str,
    stage: Path,
) -> list[tuple[str, Any]]:
    tally = verdict_tally(_counts(comparisons))
    sample = "; ".join(sample_sizes(trials)) or "no trials"
    blocks: list[tuple[str, Any]] = [
        ("h1", "cfopt reproduce: the seed paper's figures beside cfopt's"),
        (
            "p",
            "The seed: Diehl and Adams, GRAPE-S and Pair-GRAPE-S (§5: centralized evaluation, "
            "§6: distributed). cfopt ran the seed's grids with the seed's algorithms, "
            f"{plural(missions, 'mission')} per cell, code {version or '-'}, "
            f"{time.strftime('%Y-%m-%d %H:%M:%S %Z')}. Sample: {sample}.",
        ),
        ("p", f"{plural(len(comparisons), 'comparison')} with the paper: {tally}."),
        ("p", _RULES + " Percent utility is of the exact (ILP) optimum, which on these "
              "achievable missions is the total utility."),
    ]  # fmt: skip
    disagreements = [c for c in comparisons if c.kind == "disagreement"]
    if disagreements:
        rows = [[c.figure.section, c.paper, c.against, c.reason] for c in disagreements]
        blocks += [
            ("h2", "The paper disagrees with itself"),
            ("table", (["where", "the paper says", "and also says", "why both cannot hold"], rows)),
        ]
    blocks += [
        ("h2", "Every figure: the paper, cfopt, the tolerance, the verdict"),
        ("table", comparison_table(comparisons)),
    ]
    for table, what in (
        ("Table 2", "GRAPE-S percent utility, centralized, 10:5 (paper / cfopt)"),
        ("Table 4", "GRAPE-S percent utility, distributed, 10:5 (paper / cfopt)"),
        ("Table 5", "SDA percent utility, distributed (paper / cfopt)"),
    ):
        header, rows = paper_layout_table(comparisons, table)
        if rows:
            blocks += [("h2", f"The paper's {table}: {what}"), ("table", (header, rows))]
    blocks += [
        ("h2", "Iterations"),
        (
            "p",
            "The seed (§5.1.1): every composition but 10:5 took exactly n iterations (robot "
            "moves) in GRAPE-S; 10:5 frequently more.",
        ),
        ("table", iteration_table(trials)),
        ("h2", "The pairwise step of Pair-GRAPE-S"),
        ("table", pairwise_table(trials)),
        ("h2", "Runtime: wall time, counted work, simulated time; the viability targets"),
        (
            "p",
            "Counted work is each algorithm's documented unit of computation (GRAPE-S: slot "
            "examinations), the same on every machine. The seed's targets: above 95 % "
            "utility and below 5 minutes (distributed: simulated minutes).",
        ),
        ("table", runtime_table(trials)),
        ("h2", "The paper's statistical results, re-run on cfopt's trials"),
        (
            "p",
            "Each test with the paper's groups and cells: Friedman (missions as blocks) with "
            "Conover's pairs, Kruskal-Wallis with Mann-Whitney-Wilcoxon pairs (two levels: "
            "Mann-Whitney-Wilcoxon), Wilcoxon's signed-rank test of GRAPE-S and SDA. A lower "
            "mean rank is a smaller value: faster, less communication, lower utility. The "
            "paper's p is also recomputed from its statistic.",
        ),
        ("table", tests),
    ]
    if models["models"]:
        best = models["best"]
        m = models["models"][best]
        blocks += [
            ("h2", "Communication models"),
            (
                "p",
                "GRAPE-S's communication per size under each model (median over compositions "
                "5:1, 5:5 and 10:1) beside the seed's. The seed's figures grow with slope "
                f"{models['paper_slope']:.2f} in log-log; the nearest shape is {best} (slope "
                f"{m['slope']:.2f}), off by a factor {m['factor']:.3g} (paper / cfopt, "
                "geometric mean). The last column divides the seed's bytes by cfopt's "
                "messages under each model: where it is about constant over the sizes, that "
                "model's message count has the seed's shape and only the message size "
                "differs (cfopt's belief grows as 16 + 4 n bytes). No constant is tuned to "
                "the paper.",
            ),
            ("table", _models_table(models)),
            ("img", (stage / "communication_models.png", "Communication models")),
        ]
    return blocks
