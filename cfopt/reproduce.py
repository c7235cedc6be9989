"""``cfopt reproduce``: the seed paper's evaluation, run again, every figure beside cfopt's.

The seed (Diehl and Adams, GRAPE-S) evaluated its four algorithms on a centralized grid
(100, 500 and 1000 robots; 1, 10 and 50 % tasks; compositions 5:1, 5:5, 10:1, 10:5; 25
missions per cell) and its three distributed ones on a distributed grid (100 and 500
robots on a network).  :func:`run_reproduce` runs both grids with those algorithms into a
result store (resumable), then :func:`compare_figures` sets every published figure of
:data:`cfopt.paper.FIGURES` beside cfopt's value of the same statistic over the same
cells, with a verdict:

* ``agree`` -- the same value within the tolerance of its kind (below), the same side
  of a stated bound, or the same statistical conclusion;
* ``differs`` -- with a one-line reason;
* ``not comparable`` -- wall-clock times of cfopt's engines against the seed's C++ on
  its hardware (the counted work, machine-independent, is given beside them);
* ``no trials`` -- the store holds none of the figure's cells.

Tolerances.  The paper's missions are other random draws of the same family, so values
agree statistically, not exactly: a median agrees within 1 percentage point, a minimum or
maximum of percent utility within 5 points (or both exactly 100); a count of trials with
some property (the pairwise step ran, optimal) agrees when Fisher's exact test does not
reject equal proportions at 5 %; a communication volume agrees within a factor of 2; a
test statistic agrees when both reach the same conclusion at 5 % (the paper's p-value is
recomputed from its statistic and the degrees of freedom).

Examples
--------
>>> sweeps = reproduction_sweeps(missions=2)
>>> [(len(s.cells), s.missions, s.algorithms) for s in sweeps]  # doctest: +NORMALIZE_WHITESPACE
[(32, 2, ('exact', 'grape-s', 'pair-grape-s', 'sda', 'rachna-dt')),
 (20, 2, ('exact', 'grape-s', 'pair-grape-s', 'sda'))]
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import math
import os
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cfopt._jsonio import make_directory, output_target
from cfopt._progress import Progress
from cfopt.errors import MissionError, plural
from cfopt.paper import (
    CENTRALIZED_ALGORITHMS,
    COMMUNICATION_ALGORITHM,
    DISTRIBUTED_ALGORITHMS,
    FIGURES,
    GRAPE_S_ALGORITHMS,
    PAIRWISE_ALGORITHM,
    Figure,
)
from cfopt.store import EXACT, Trial, check_store_path

__all__ = [
    "AGREE",
    "DIFFERS",
    "NOT_COMPARABLE",
    "NO_TRIALS",
    "Comparison",
    "ReproduceResult",
    "compare_figures",
    "reproduction_sweeps",
    "run_reproduce",
    "write_reproduction",
]

AGREE, DIFFERS, NOT_COMPARABLE, NO_TRIALS = "agree", "differs", "not comparable", "no trials"
#: Missions per cell in the seed (and the default here).
PAPER_MISSIONS = 25
#: The seed's viability targets: above 95 % utility, under 5 minutes.
VIABLE_PERCENT, VIABLE_SECONDS = 95.0, 300.0
MEDIAN_TOLERANCE, EXTREME_TOLERANCE, VOLUME_FACTOR = 1.0, 5.0, 2.0
ALPHA = 0.05
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
    written, the sweeps' outcomes and the trials' code version."""

    directory: Path
    comparisons: tuple[Comparison, ...]
    files: tuple[Path, ...]
    outcomes: tuple[Any, ...]
    code_version: str

    def counts(self) -> dict[str, int]:
        """How many comparisons have each verdict."""
        out: dict[str, int] = defaultdict(int)
        for c in self.comparisons:
            out[c.verdict] += 1
        return dict(out)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``cfopt reproduce --json``)."""
        return {
            "directory": os.fspath(self.directory),
            "code_version": self.code_version,
            "verdicts": self.counts(),
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
        directory, tuple(comparisons), (*files, *report.files), tuple(outcomes), version
    )


# ------------------------------------------------------------------ the comparison
@dataclass(frozen=True)
class Comparison:
    """One published figure beside cfopt's (frozen).

    Attributes
    ----------
    figure : cfopt.paper.Figure
    value : float or None
        cfopt's value of the same statistic over the same cells (``None``: no trials).
    trials : int
        cfopt's trials behind it.
    verdict : str
        :data:`AGREE`, :data:`DIFFERS`, :data:`NOT_COMPARABLE` or :data:`NO_TRIALS`.
    reason : str
        One line: why, and what else there is to see (the counted work, other models).
    """

    figure: Figure
    value: float | None
    trials: int
    verdict: str
    reason: str

    def to_dict(self) -> dict[str, Any]:
        f = self.figure
        return {
            "evaluation": f.evaluation,
            "section": f.section,
            "table": f.table,
            "algorithm": f.algorithm,
            "cells": _scope(f),
            "measure": f.measure,
            "statistic": f.statistic,
            "paper": f.value,
            "cfopt": self.value,
            "trials": self.trials,
            "verdict": self.verdict,
            "reason": self.reason,
        }


def _scope(f: Figure) -> str:
    parts = []
    if f.robots is not None:
        parts.append(f"n={f.robots}")
    if f.percent_tasks is not None:
        parts.append(f"{f.percent_tasks:g}% tasks")
    if f.service_types is not None:
        parts.append(f"{f.service_types}:{f.services_per_robot}")
    return ", ".join(parts) or "all cells"


def _in_scope(t: Trial, f: Figure) -> bool:
    return (
        t.load == 1
        and (t.network is None) == (f.evaluation == "centralized")
        and all(
            want is None or got == want
            for want, got in (
                (f.robots, t.robots),
                (f.percent_tasks, t.percent_tasks),
                (f.service_types, t.service_types),
                (f.services_per_robot, t.services_per_robot),
            )
        )
    )


def _scoped(trials: Sequence[Trial], f: Figure, algorithm: str | None = None) -> list[Trial]:
    name = algorithm or f.algorithm
    return [t for t in trials if _in_scope(t, f) and (name == "all" or t.algorithm == name)]


def _statistic(values: Sequence[float], statistic: str) -> float:
    if statistic == "min":
        return float(min(values))
    if statistic in ("max", "upper bound"):
        return float(max(values))
    return float(np.median(values))  # median, value, lower bound


def _paper_cells(f: Figure) -> int:
    """Cells of the seed's grid a figure covers (its trials: 25 per cell)."""
    from cfopt.experiments import distributed_grid
    from cfopt.generate import paper_grid

    grid = paper_grid() if f.evaluation == "centralized" else distributed_grid()
    return sum(
        all(
            want is None or got == want
            for want, got in (
                (f.robots, c.robots),
                (f.percent_tasks, c.percent_tasks),
                (f.service_types, c.service_types),
                (f.services_per_robot, c.services_per_robot),
            )
        )
        for c in grid
    )


def _percent(trials: Sequence[Trial], f: Figure) -> Comparison:
    values = [t.percent_optimum for t in trials if t.percent_optimum is not None]
    if not values:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    value = _statistic(values, f.statistic)
    if f.statistic == "median":
        agree, tolerance = abs(value - f.value) <= MEDIAN_TOLERANCE, MEDIAN_TOLERANCE
    else:
        both_optimal = round(value, 2) == 100 and f.value == 100
        agree = both_optimal or (
            round(value, 2) < 100 and f.value < 100 and abs(value - f.value) <= EXTREME_TOLERANCE
        )
        tolerance = EXTREME_TOLERANCE
    if agree and round(value, 2) == 100 and f.value == 100:
        reason = "both optimal"
    elif agree:
        reason = f"within {tolerance:g} percentage points"
    elif f.statistic != "median" and round(value, 2) == 100:
        reason = f"no cfopt trial below the optimum among {len(values)} (the paper's: 25 per cell)"
    elif f.statistic == "median":
        reason = f"{value - f.value:+.2f} points over {len(values)} trials"
    else:
        reason = (
            f"{value - f.value:+.2f} points; the extremes of {len(values)} random missions "
            "vary from draw to draw"
        )
    return Comparison(f, value, len(values), AGREE if agree else DIFFERS, reason)


def _bound_holds(value: float, f: Figure) -> bool:
    return value < f.value if f.statistic == "upper bound" else value >= f.value


def _runtime(trials: Sequence[Trial], f: Figure) -> Comparison:
    distributed = f.evaluation == "distributed"
    values = [
        v
        for t in trials
        if (v := (t.sim_seconds if distributed else t.seconds)) is not None and math.isfinite(v)
    ]
    if not values:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    value = _statistic(values, f.statistic)
    work = [t.work for t in trials if t.work is not None]
    work_text = f"median counted work {_si(float(np.median(work)))}" if work else ""
    if distributed:
        if f.statistic in ("upper bound", "lower bound"):
            agree = _bound_holds(value, f)
        else:
            agree = 0.5 <= value / f.value <= 2 if f.value else value == 0
        reason = (
            f"simulated seconds on the seed's network ({f.statistic} over {len(values)} "
            "trials) against the seed's wall time on its cluster"
        )
        return Comparison(f, value, len(values), AGREE if agree else DIFFERS, reason)
    side = ""
    if f.statistic in ("upper bound", "lower bound"):
        side = "; on the bound's side" if _bound_holds(value, f) else "; not on the bound's side"
    reason = f"wall time of cfopt's engine on this machine vs the seed's C++{side}; {work_text}"
    return Comparison(f, value, len(values), NOT_COMPARABLE, reason.rstrip("; "))


def _megabytes(t: Trial, model: tuple[str, str] | None = None) -> float | None:
    """A trial's communication in MB: as stored (the algorithm's default model, or the
    bytes a distributed run transmitted) or under another ``(medium, encoding)``."""
    if model is not None:
        table = _communication(t)
        return None if model not in table else table[model] / _MB
    return None if t.bytes is None else t.bytes / _MB


def _communication(t: Trial) -> dict[tuple[str, str], float]:
    rows = getattr(t, "communication", None) or ()
    return {(medium, encoding): float(nbytes) for medium, encoding, _, nbytes in rows}


def _volume(trials: Sequence[Trial], f: Figure) -> Comparison:
    values = [v for t in trials if (v := _megabytes(t)) is not None]
    if not values:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    value = _statistic(values, f.statistic)
    others = []
    for model in (("unicast", "full"), ("broadcast", "compact")):
        alt = [v for t in trials if (v := _megabytes(t, model)) is not None]
        if alt:
            others.append(f"{'/'.join(model)} {_si(_statistic(alt, f.statistic))} MB")
    if f.statistic in ("upper bound", "lower bound"):
        agree = _bound_holds(value, f)
        reason = "on the bound's side" if agree else "not on the bound's side"
    else:
        ratio = value / f.value if f.value else math.inf
        agree = 1 / VOLUME_FACTOR <= ratio <= VOLUME_FACTOR
        reason = f"cfopt/paper = {ratio:.3g}"
    model = (
        "transmitted on the simulated medium"
        if f.evaluation == "distributed"
        else ("the default model (broadcast, full beliefs)")
    )
    reason += f"; {model}" + (f"; {', '.join(others)}" if others else "")
    return Comparison(f, value, len(values), AGREE if agree else DIFFERS, reason)


def _proportion(f: Figure, hits: int, total: int, paper_total: int, what: str) -> Comparison:
    from scipy.stats import fisher_exact

    if total == 0:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    paper_hits = int(f.value)
    _, p = fisher_exact([[paper_hits, paper_total - paper_hits], [hits, total - hits]])
    agree = p >= ALPHA
    reason = (
        f"{what} in {hits} of {total} (paper: {paper_hits} of {paper_total}); Fisher's exact "
        f"p = {p:.3g}"
    )
    return Comparison(f, float(hits), total, AGREE if agree else DIFFERS, reason)


def _trials_count(trials: Sequence[Trial], f: Figure) -> Comparison:
    names = (
        (CENTRALIZED_ALGORITHMS if f.evaluation == "centralized" else DISTRIBUTED_ALGORITHMS)
        if f.algorithm == "all"
        else (f.algorithm,)
    )
    scoped = {a: _scoped(trials, f, a) for a in names}
    value = float(min(len(v) for v in scoped.values()))
    if not value:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    agree = value == f.value
    cells = max(len({t.cell for t in v}) for v in scoped.values())
    reason = f"{value / cells:g} missions in each of {plural(cells, 'cell')} (the paper: 25 in "
    reason += f"each of {_paper_cells(f)})"
    return Comparison(f, value, int(value), AGREE if agree else DIFFERS, reason)


def _iterations(trials: Sequence[Trial], f: Figure) -> Comparison:
    runs = [t for t in trials if (t.service_types, t.services_per_robot) != (10, 5)]
    if not runs:
        return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
    exact = sum(1 for t in runs if t.iterations == t.robots)
    value = exact / len(runs)
    agree = value == f.value
    reason = f"{exact} of {len(runs)} runs (compositions 5:1, 5:5, 10:1) took exactly n iterations"
    return Comparison(f, value, len(runs), AGREE if agree else DIFFERS, reason)


#: The metric each test figure is about.
_TEST_METRICS: dict[str, Callable[[Trial], float | None]] = {
    "runtime": lambda t: t.seconds,
    "communication": lambda t: _megabytes(t),
    "utility": lambda t: t.percent_optimum,
}


@dataclass(frozen=True)
class _TestOutcome:
    statistic: float | None
    p_value: float | None
    n: int
    mean_ranks: tuple[tuple[str, float], ...]
    note: str = ""


def _friedman(trials: Sequence[Trial], algorithms: Sequence[str], metric) -> _TestOutcome:
    from scipy import stats

    blocks: dict[tuple[str, int], dict[str, float]] = defaultdict(dict)
    for t in trials:
        v = metric(t)
        if t.algorithm in algorithms and v is not None and math.isfinite(v):
            blocks[(t.cell, t.mission_seed)][t.algorithm] = float(v)
    rows = np.array(
        [[b[a] for a in algorithms] for b in blocks.values() if len(b) == len(algorithms)]
    )
    if len(rows) < 2:
        return _TestOutcome(None, None, len(rows), (), "fewer than 2 complete blocks")
    ranks = np.apply_along_axis(stats.rankdata, 1, rows).mean(axis=0)
    mean_ranks = tuple(zip(algorithms, (float(r) for r in ranks), strict=True))
    if (rows == rows[:, :1]).all():
        return _TestOutcome(None, None, len(rows), mean_ranks, "ties in every block")
    chi2, p = stats.friedmanchisquare(*rows.T)
    return _TestOutcome(float(chi2), float(p), len(rows), mean_ranks)


def _kruskal(trials: Sequence[Trial], factor: str, metric) -> _TestOutcome:
    from scipy import stats

    from cfopt.report import _factor_subset

    _, chosen = _factor_subset(trials, factor)
    groups: dict[float, list[float]] = defaultdict(list)
    for t in chosen:
        v = metric(t)
        if v is not None and math.isfinite(v):
            groups[getattr(t, factor)].append(float(v))
    labels = sorted(groups)
    if len(labels) < 2:
        return _TestOutcome(None, None, sum(map(len, groups.values())), (), "one level only")
    pooled = stats.rankdata(np.concatenate([groups[g] for g in labels]))
    mean_ranks, start = [], 0
    for g in labels:
        size = len(groups[g])
        mean_ranks.append((f"{g:g}", float(pooled[start : start + size].mean())))
        start += size
    n = len(pooled)
    if len(set(pooled)) == 1:
        return _TestOutcome(None, None, n, tuple(mean_ranks), "no variation")
    h, p = stats.kruskal(*(groups[g] for g in labels))
    return _TestOutcome(float(h), float(p), n, tuple(mean_ranks))


def _test_scope(f: Figure) -> tuple[str, Sequence[str], str | None, str]:
    """(kind, algorithms, factor, metric) of a test figure, e.g. ``friedman_chi2_runtime``
    -> Friedman over the paper's algorithm set for that scope."""
    parts = f.measure.split("_")
    if parts[0] == "friedman":
        ten_five = (f.service_types, f.services_per_robot) == (10, 5)
        algorithms = tuple(a for a in CENTRALIZED_ALGORITHMS if ten_five or a != PAIRWISE_ALGORITHM)
        return "friedman", algorithms, None, parts[2]
    factor = "percent_tasks" if f.measure.endswith("percent_tasks") else "robots"
    return "kruskal", (f.algorithm,), factor, parts[2]


def run_test(trials: Sequence[Trial], f: Figure) -> tuple[_TestOutcome, float, int]:
    """cfopt's test for a test figure, the paper's p-value (recomputed from its statistic)
    and the degrees of freedom."""
    from scipy.stats import chi2

    kind, algorithms, factor, metric_name = _test_scope(f)
    metric = _TEST_METRICS[metric_name]
    scoped = [t for t in trials if _in_scope(t, f) and t.algorithm in algorithms]
    if kind == "friedman":
        outcome = _friedman(scoped, algorithms, metric)
        dof = len(algorithms) - 1
    else:
        outcome = _kruskal(scoped, factor or "robots", metric)
        dof = max(len(outcome.mean_ranks) - 1, 1) if outcome.mean_ranks else 2
    return outcome, float(chi2.sf(f.value, dof)), dof


def _direction(outcome: _TestOutcome, kind: str) -> str:
    if not outcome.mean_ranks:
        return ""
    ordered = sorted(outcome.mean_ranks, key=lambda r: r[1])
    if kind == "friedman":
        return "lowest first: " + ", ".join(f"{a} {r:.2f}" for a, r in ordered)
    ranks = [r for _, r in outcome.mean_ranks]
    trend = (
        "increases with the level"
        if all(a < b for a, b in itertools.pairwise(ranks))
        else "decreases with the level"
        if all(a > b for a, b in itertools.pairwise(ranks))
        else "not monotone"
    )
    return f"{trend} (mean ranks {', '.join(f'{g} {r:.1f}' for g, r in outcome.mean_ranks)})"


def _test(trials: Sequence[Trial], f: Figure) -> Comparison:
    outcome, paper_p, _ = run_test(trials, f)
    kind = _test_scope(f)[0]
    if outcome.p_value is None:
        if outcome.n == 0:
            return Comparison(f, None, 0, NO_TRIALS, "no trials of these cells")
        significant = False
        text = f"no test ({outcome.note})"
    else:
        significant = outcome.p_value < ALPHA
        text = f"p = {outcome.p_value:.3g}"
    same = significant == (paper_p < ALPHA)
    conclusion = "same conclusion as the paper" if same else "not the paper's conclusion"
    reason = (
        f"{conclusion}: n = {outcome.n}, {text} (paper p = {paper_p:.2g}); "
        f"{_direction(outcome, kind)}"
    )
    return Comparison(f, outcome.statistic, outcome.n, AGREE if same else DIFFERS, reason)


def _compare(trials: Sequence[Trial], f: Figure) -> Comparison:
    scoped = _scoped(trials, f)
    if f.measure == "percent_utility":
        return _percent(scoped, f)
    if f.measure == "runtime_s":
        return _runtime(scoped, f)
    if f.measure == "communication_mb":
        return _volume(scoped, f)
    if f.measure == "trials":
        return _trials_count(trials, f)
    if f.measure == "iterations":
        return _iterations(scoped, f)
    if f.measure == "pairwise_step_ran":
        ran = sum(1 for t in scoped if t.pairwise_step_ran)
        return _proportion(f, ran, len(scoped), PAPER_MISSIONS * _paper_cells(f), "it ran")
    if f.measure == "optimal_trials":
        hits = sum(1 for t in scoped if (t.percent_optimum or 0) >= 100 - 1e-9)
        return _proportion(
            f, hits, len(scoped), PAPER_MISSIONS * _paper_cells(f), "optimal solutions"
        )
    if f.measure.startswith(("friedman", "kruskal")):
        return _test(trials, f)
    raise ValueError(f"no comparison for the measure {f.measure!r}")


def compare_figures(
    trials: Sequence[Trial], figures: Iterable[Figure] = FIGURES
) -> list[Comparison]:
    """Every figure beside cfopt's value over the same cells (achievable missions, load 1:
    the seed's; centralized figures from centralized trials, distributed ones from
    distributed trials), in the figures' order."""
    trials = [t for t in trials if t.algorithm != EXACT]
    return [_compare(trials, f) for f in figures]


# -------------------------------------------------------------------- the document
def _si(x: float) -> str:
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    if abs(x) >= 1e5:
        return f"{x:.3g}"
    return f"{x:.2f}" if abs(x) < 100 else f"{x:,.0f}"


def _two(x: float | None) -> str:
    return "-" if x is None else _si(x)


def comparison_table(comparisons: Sequence[Comparison]) -> tuple[list[str], list[list[str]]]:
    """paper | cfopt | verdict, one row per figure."""
    header = [
        "evaluation", "where", "algorithm", "cells", "measure", "statistic", "paper",
        "cfopt", "trials", "verdict", "reason",
    ]  # fmt: skip
    rows = []
    for c in comparisons:
        f = c.figure
        where = f.section + ("" if f.table == "text" else f", {f.table}")
        rows.append(
            [
                f.evaluation, where, f.algorithm, _scope(f), f.measure, f.statistic,
                _si(f.value), _two(c.value), str(c.trials), c.verdict, c.reason,
            ]
        )  # fmt: skip
    return header, rows


def paper_layout_table(
    comparisons: Sequence[Comparison], table: str
) -> tuple[list[str], list[list[str]]]:
    """One of the paper's utility tables (2, 3 or 4) in its layout -- per composition,
    percent tasks and collective size: median, min, max -- each as ``paper / cfopt``,
    two decimals, with the verdicts."""
    header = ["composition", "% tasks", "robots", "median", "min", "max", "agree"]
    groups: dict[tuple[Any, ...], dict[str, Comparison]] = defaultdict(dict)
    for c in comparisons:
        f = c.figure
        if f.table == table:
            key = (f.service_types, f.services_per_robot, f.percent_tasks, f.robots)
            groups[key][f.statistic] = c
    rows = []
    for (s, k, p, n), stats in groups.items():
        cells = []
        for name in ("median", "min", "max"):
            c = stats[name]
            cells.append(f"{c.figure.value:.2f} / {'-' if c.value is None else f'{c.value:.2f}'}")
        verdicts = {c.verdict for c in stats.values()}
        agree = (
            "yes"
            if verdicts == {AGREE}
            else "no trials"
            if verdicts == {NO_TRIALS}
            else ", ".join(
                name for name in ("median", "min", "max") if stats[name].verdict != AGREE
            )
            + " differ"
        )
        rows.append([f"{s}:{k}", f"{p:g}", str(n), *cells, agree])
    return header, rows


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
        (f.evaluation, f.service_types, f.services_per_robot): f
        for f in FIGURES
        if f.measure == "pairwise_step_ran"
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
            total = PAPER_MISSIONS * _paper_cells(f)
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
                evaluation, algorithm, str(n), str(len(group)), _median_max(seconds),
                _median_max(work), _median_max(sim), f"{good}/{len(group)}",
                f"{fast}/{len(group)}",
            ]
        )  # fmt: skip
    return header, rows


def _median_max(values: Sequence[float]) -> str:
    if not values:
        return "-"
    return f"{_si(float(np.median(values)))} ({_si(float(max(values)))})"


def paper_tests_table(
    trials: Sequence[Trial], comparisons: Sequence[Comparison]
) -> tuple[list[str], list[list[str]]]:
    """The paper's statistical tests, re-run with its algorithm sets and factor subsets:
    statistic and p beside the paper's, mean ranks and the direction, the verdict."""
    header = [
        "where", "test", "subject", "scope", "paper", "paper p", "cfopt", "cfopt p", "n",
        "direction (mean ranks)", "conclusion",
    ]  # fmt: skip
    rows = []
    for c in comparisons:
        f = c.figure
        if not f.measure.startswith(("friedman", "kruskal")):
            continue
        outcome, paper_p, _ = run_test(trials, f)
        kind, algorithms, factor, metric = _test_scope(f)
        subject = ", ".join(algorithms) if kind == "friedman" else f"{f.algorithm} by {factor}"
        rows.append(
            [
                f.section, f"{'Friedman' if kind == 'friedman' else 'Kruskal-Wallis'} ({metric})",
                subject, _scope(f), f"{f.value:g}", f"{paper_p:.2g}",
                _two(outcome.statistic),
                "-" if outcome.p_value is None else f"{outcome.p_value:.3g}",
                str(outcome.n), _direction(outcome, kind) or outcome.note,
                "same as the paper" if c.verdict == AGREE else "not the paper's",
            ]
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
    published = {
        f.robots: f.value
        for f in FIGURES
        if f.measure == "communication_mb"
        and f.algorithm == COMMUNICATION_ALGORITHM
        and f.robots
        and f.evaluation == "centralized"
        and f.statistic == "value"
    }
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
            values = [v for t in chosen if t.robots == n and (v := _megabytes(t, model))]
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
    return float(np.polyfit(np.log(sizes), np.log(values), 1)[0])


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
        tests = paper_tests_table(trials, comparisons)
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


def _document(
    trials: Sequence[Trial],
    comparisons: Sequence[Comparison],
    models: dict[str, Any],
    tests: tuple[list[str], list[list[str]]],
    missions: int,
    version: str,
    stage: Path,
) -> list[tuple[str, Any]]:
    counts: dict[str, int] = defaultdict(int)
    for c in comparisons:
        counts[c.verdict] += 1
    tally = ", ".join(f"{plural(v, 'figure')} {k}" for k, v in sorted(counts.items()))
    blocks: list[tuple[str, Any]] = [
        ("h1", "cfopt reproduce: the seed paper's figures beside cfopt's"),
        (
            "p",
            "The seed: Diehl and Adams, GRAPE-S and Pair-GRAPE-S (§5: centralized evaluation, "
            "§6: distributed). cfopt ran the seed's grids with the seed's algorithms, "
            f"{plural(missions, 'mission')} per cell (the seed: 25), code {version or '-'}, "
            f"{time.strftime('%Y-%m-%d %H:%M:%S %Z')}. {tally}. Percent utility is of the "
            "exact (ILP) optimum, which on these achievable missions is the total utility. "
            "Tolerances: medians within 1 point, extremes within 5 points (or both 100), "
            "counts by Fisher's exact test, volumes within a factor 2, tests by their "
            "conclusion at 5 %. Wall times of cfopt's Python engines are not comparable "
            "with the seed's C++; counted work and simulated time are given instead.",
        ),
        ("h2", "Every figure: paper | cfopt | verdict"),
        ("table", comparison_table(comparisons)),
    ]
    for table, what in (
        ("Table 2", "GRAPE-S percent utility, centralized, 10:5 (paper / cfopt)"),
        ("Table 3", "GRAPE-S percent utility, distributed, 10:5 (paper / cfopt)"),
        ("Table 4", "SDA percent utility, distributed (paper / cfopt)"),
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
        ("h2", "Statistical tests with the paper's algorithm sets"),
        (
            "p",
            "Friedman over GRAPE-S, Pair-GRAPE-S, SDA and RACHNA_dt on 10:5 missions and over "
            "GRAPE-S, SDA and RACHNA_dt on all compositions (missions as blocks; a lower mean "
            "rank is a smaller value: faster, less communication, lower utility); "
            "Kruskal-Wallis for GRAPE-S across sizes (10 and 50 % tasks) and percent tasks "
            "(500 and 1000 robots). The paper's p is recomputed from its statistic.",
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
