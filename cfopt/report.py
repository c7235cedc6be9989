"""Optimal-gap reports: the seed's tables, statistics and box plots, from a result store.

From the trials of a sweep (:mod:`cfopt.experiments`) this module builds what the seed
paper's evaluation shows (its §5: Table 2 and Figures 1-2; §6: Tables 4-5):

* tables of ``median (min, max)`` per grid cell and algorithm for percent of optimum,
  percent of total utility, runtime and communication (:func:`cell_table`);
* the seed's non-parametric tests (:func:`statistics`): Kruskal-Wallis with pairwise
  Mann-Whitney-Wilcoxon post-hoc tests across collective sizes and percent tasks,
  Mann-Whitney-Wilcoxon between service-type and services-per-robot levels, and Friedman
  across the algorithms with Conover's post-hoc test -- computed by ``scipy.stats`` and
  ``scikit_posthocs``, never by hand;
* box plots per composition (matplotlib, PNG, :func:`box_plots`);
* the claims verdict table of :mod:`proofs.claims` when given.

:func:`write_report` writes them as one Markdown report, CSV files and a self-contained
HTML page (figures embedded as base64), and never replaces an existing file unless
``force=True``.  matplotlib, scipy.stats and scikit_posthocs are imported only by the
functions that need them.

Examples
--------
>>> from cfopt.report import format_range
>>> format_range([100.0, 96.5, 100.0])
'100 (96.5, 100)'
"""

from __future__ import annotations

import base64
import contextlib
import csv
import html
import math
import os
import re
import shutil
import tempfile
import textwrap
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from stat import S_ISDIR
from typing import Any

import numpy as np

from cfopt._jsonio import make_directory, output_target, stat_path
from cfopt.errors import MissionError, plural
from cfopt.stats import (
    ALPHA,
    Outcome,
    StatResult,
    complete_blocks,
    friedman,
    kruskal,
    mann_whitney,
)
from cfopt.store import EXACT, ResultStore, Trial

__all__ = [
    "METRICS",
    "Metric",
    "Report",
    "TestResult",
    "box_plots",
    "cell_table",
    "format_median_max",
    "format_range",
    "gap_report",
    "load_trials",
    "megabytes",
    "report_from_store",
    "statistics",
    "summary_rows",
    "summary_text",
    "write_report",
]


# ------------------------------------------------------------------------ metrics
@dataclass(frozen=True)
class Metric:
    """A measured quantity of a trial: name, label, unit, how to read it."""

    name: str
    label: str
    unit: str
    value: Callable[[Trial], float | None]
    heuristics_only: bool = True
    log_scale: bool = False


def megabytes(t: Trial, model: tuple[str, str] | None = None) -> float | None:
    """A trial's communication in MB (10^6 bytes): as stored -- the algorithm's default
    model, or the bytes a distributed run transmitted -- or under another ``(medium,
    encoding)`` model of :attr:`Trial.communication` (``None`` when not recorded)."""
    if model is None:
        return None if t.bytes is None else t.bytes / 1e6
    for medium, encoding, _, nbytes in t.communication or ():
        if (medium, encoding) == model:
            return float(nbytes) / 1e6
    return None


def _work(t: Trial) -> float | None:
    return None if t.work is None else float(t.work)


#: The metrics of the tables and plots, in report order.  ``work`` is each algorithm's
#: documented unit of computation (GRAPE-S: slot examinations), the same on every machine.
METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("percent_optimum", "Percent of optimum", "%", lambda t: t.percent_optimum),
        Metric("percent_total", "Percent of total utility", "%", lambda t: t.percent_total),
        Metric("seconds", "Runtime", "s", lambda t: t.seconds, False, True),
        Metric("work", "Counted work (machine-independent runtime)", "units", _work, True, True),
        Metric("megabytes", "Total communication", "MB", megabytes, True, True),
        Metric("sim_seconds", "Simulated runtime", "s", lambda t: t.sim_seconds, True, True),
    )
}
#: Metrics only distributed trials have (tables and plots only when there are some).
DISTRIBUTED_METRICS = ("sim_seconds",)


def _metrics(distributed: bool) -> list[str]:
    return [m for m in METRICS if distributed or m not in DISTRIBUTED_METRICS]


def network_tags(trials: Sequence[Trial]) -> dict[str, str]:
    """Network spec -> its short tag in tables: ``distributed``, or ``net 1``, ``net 2``...
    when the trials ran on several networks."""
    networks = sorted({t.network for t in trials if t.network is not None})
    if len(networks) == 1:
        return {networks[0]: "distributed"}
    return {spec: f"net {k}" for k, spec in enumerate(networks, 1)}


def label_variants(trials: Sequence[Trial]) -> list[Trial]:
    """Distributed trials under their own algorithm names, so that every table keeps them
    apart from the centralized runs of the same algorithm: ``grape-s (distributed)``, or
    ``grape-s (net 2)`` when the trials ran on several networks (see
    :func:`network_tags`).  The exact solve is the same on every cell and keeps its name."""
    tags = network_tags(trials)
    out = []
    for t in trials:
        if t.network is None or t.algorithm == EXACT or " (" in t.algorithm:
            out.append(t)
        else:
            out.append(replace(t, algorithm=f"{t.algorithm} ({tags[t.network]})"))
    return out


def _values(trials: Iterable[Trial], metric: Metric) -> list[float]:
    out = []
    for t in trials:
        v = metric.value(t)
        if v is not None and math.isfinite(v):
            out.append(float(v))
    return out


def _fmt(x: float) -> str:
    if x == 0:
        return "0"
    if abs(x) >= 1e4:
        return f"{x:,.0f}"
    if abs(x) >= 100:
        return f"{x:.4g}"
    return f"{x:.3g}"


def format_range(values: Sequence[float]) -> str:
    """``"median (min, max)"`` like the seed's Tables 2, 4 and 5; ``"-"`` for no values.

    >>> format_range([0.12, 0.5, 3.0]), format_range([])
    ('0.5 (0.12, 3)', '-')
    """
    if len(values) == 0:
        return "-"
    a = np.asarray(values, dtype=float)
    return f"{_fmt(float(np.median(a)))} ({_fmt(float(a.min()))}, {_fmt(float(a.max()))})"


def _algorithms(trials: Sequence[Trial]) -> list[str]:
    names = sorted({t.algorithm for t in trials} - {EXACT})
    return ([EXACT] if any(t.algorithm == EXACT for t in trials) else []) + names


def _cell_key(t: Trial) -> tuple[float, int, int, float, int]:
    return (t.load, t.service_types, t.services_per_robot, t.percent_tasks, t.robots)


def _load_label(load: float) -> str:
    if load == 1:
        return "achievable (load 1)"
    return f"over-subscribed (load {load:g})" if load > 1 else f"spare robots (load {load:g})"


# ------------------------------------------------------------------------- loading
def load_trials(
    store: str | os.PathLike[str], version: str | None = None
) -> tuple[list[Trial], str]:
    """The trials of one code version of a store (default: the most recent one).

    Of an algorithm stored under several versions (:attr:`Trial.algorithm_version`: a
    sweep after the algorithm's version changed), only the trials of the version stored
    most recently are read, as only the newest code version is by default.  Raises
    :class:`cfopt.MissionError` for a missing or empty store.
    """
    with ResultStore(store, create=False) as db:
        versions = db.code_versions()
        if not versions:
            raise MissionError(f"{os.fspath(store)}: the result store holds no trials yet")
        if version is None:
            version = versions[0]
        elif version not in versions:
            raise MissionError(
                f"{os.fspath(store)}: no trials of code version {version!r} "
                f"(stored: {', '.join(versions)})"
            )
        return newest_versions(db.trials(version)), version


def newest_versions(trials: Sequence[Trial]) -> list[Trial]:
    """``trials`` without those of an algorithm's older versions: per algorithm, only
    the :attr:`Trial.algorithm_version` of its most recently finished trial is kept."""
    newest: dict[str, tuple[float, str]] = {}
    for t in trials:
        seen = newest.get(t.algorithm)
        if seen is None or t.finished > seen[0]:
            newest[t.algorithm] = (t.finished, t.algorithm_version)
    return [t for t in trials if t.algorithm_version == newest[t.algorithm][1]]


def _code_description(store: str, version: str) -> str:
    """``cfopt 0.1.0 (git 6adb985); trials keyed by code version 0.1.0+<digest>``."""
    described = None
    if store and Path(store).is_file():
        with contextlib.suppress(MissionError), ResultStore(store, create=False) as db:
            described = db.version_description(version)
    keyed = f"trials keyed by code version {version or '(unknown)'} (a digest of the sources)"
    return f"cfopt {described}; {keyed}" if described else keyed


# -------------------------------------------------------------------------- tables
def summary_rows(trials: Sequence[Trial]) -> list[dict[str, Any]]:
    """One row per (load, algorithm): the audit's summary table.

    Keys: ``load``, ``algorithm``, ``trials``, ``percent_optimum`` / ``percent_total`` /
    ``seconds`` / ``megabytes`` (each ``{"median", "min", "max"}`` or ``None``),
    ``optimal`` (trials that reached the optimum), ``nash_stable``, ``pairwise_stable``
    (trials judged stable), ``unproven_optima`` (trials scored against an optimum the
    solver did not prove).
    """
    groups: dict[tuple[float, str], list[Trial]] = defaultdict(list)
    for t in trials:
        groups[(t.load, t.algorithm)].append(t)
    order = {a: i for i, a in enumerate(_algorithms(trials))}
    rows = []
    for (load, algorithm), group in sorted(
        groups.items(), key=lambda kv: (kv[0][0], order[kv[0][1]])
    ):
        row: dict[str, Any] = {"load": load, "algorithm": algorithm, "trials": len(group)}
        for metric in METRICS.values():
            vals = _values(group, metric)
            row[metric.name] = (
                {"median": float(np.median(vals)), "min": min(vals), "max": max(vals)}
                if vals
                else None
            )
        row["optimal"] = sum(
            1 for t in group if t.percent_optimum is not None and t.percent_optimum >= 100 - 1e-9
        )
        row["nash_stable"] = sum(t.nash_stable for t in group)
        row["pairwise_stable"] = sum(t.pairwise_stable for t in group)
        row["pareto_stable"] = sum(t.pareto_stable for t in group)
        row["unproven_optima"] = sum(not t.optimum_proven for t in group)
        rows.append(row)
    return rows


def pooling_warning(trials: Sequence[Trial]) -> str | None:
    """A warning line when the algorithms of ``trials`` (one load) ran on different
    numbers of trials -- e.g. trials of two sweeps pooled -- else ``None``.

    >>> from cfopt.store import Trial
    >>> pooling_warning([])
    """
    counts: dict[str, int] = defaultdict(int)
    for t in trials:
        counts[t.algorithm] += 1
    if len(set(counts.values())) < 2:
        return None
    listed = ", ".join(f"{a}: {counts[a]}" for a in _algorithms(trials))
    return (
        f"warning: the algorithms ran on different numbers of trials ({listed}); their rows "
        "are not over the same missions (trials of several sweeps pooled?)"
    )


def _summary_table(trials: Sequence[Trial]) -> tuple[list[str], list[list[str]]]:
    header = [
        "missions",
        "algorithm",
        "trials",
        "% of optimum: median (min, max)",
        "optimal",
        "Nash stable",
        "pairwise stable",
        "pareto stable",
        "% of total: median (min, max)",
        "seconds: median (max)",
        "work: median (max)",
        "communication (MB): median (max)",
    ]

    def rng(d: dict[str, float] | None, with_min: bool = True) -> str:
        if d is None:
            return "-"
        if with_min:
            return f"{_fmt(d['median'])} ({_fmt(d['min'])}, {_fmt(d['max'])})"
        return f"{_fmt(d['median'])} ({_fmt(d['max'])})"

    body = []
    for r in summary_rows(trials):
        n = r["trials"]
        star = "†" if r["unproven_optima"] else ""
        body.append(
            [
                _load_label(r["load"]),
                r["algorithm"],
                str(n),
                rng(r["percent_optimum"]) + star,
                f"{r['optimal']}/{n}",
                f"{r['nash_stable']}/{n}",
                f"{r['pairwise_stable']}/{n}",
                f"{r['pareto_stable']}/{n}",
                rng(r["percent_total"]),
                rng(r["seconds"], False),
                rng(r["work"], False),
                rng(r["megabytes"], False),
            ]
        )
    return header, body


def cell_table(trials: Sequence[Trial], metric: str | Metric) -> tuple[list[str], list[list[str]]]:
    """The seed's Table 2 for every algorithm: ``median (min, max)`` per cell.

    Rows are cells (load, composition, percent tasks, collective size), columns the
    algorithms.  In the percent-of-optimum table a ``†`` marks a cell whose optimum was
    not proven for some mission (the ILP hit its time limit).

    >>> from cfopt.report import cell_table
    >>> header, rows = cell_table([], "seconds")
    >>> header[:4]
    ['load', 'S:k', '% tasks', 'robots']
    """
    m = METRICS[metric] if isinstance(metric, str) else metric
    algorithms = [a for a in _algorithms(trials) if not (m.heuristics_only and a == EXACT)]
    cells: dict[tuple[float, int, int, float, int], dict[str, list[Trial]]] = defaultdict(
        lambda: defaultdict(list)
    )
    for t in trials:
        cells[_cell_key(t)][t.algorithm].append(t)
    header = ["load", "S:k", "% tasks", "robots", *algorithms]
    rows = []
    for key in sorted(cells):
        load, s, k, p, n = key
        row = [f"{load:g}", f"{s}:{k}", f"{p:g}", str(n)]
        counts = {len(g) for a, g in cells[key].items() if a in algorithms and g}
        for a in algorithms:
            group = cells[key].get(a, [])
            text = format_range(_values(group, m))
            if len(counts) > 1 and group:
                text += f" (n={len(group)})"
            if m.name == "percent_optimum" and any(not t.optimum_proven for t in group):
                text += " †"
            row.append(text)
        rows.append(row)
    return header, rows


# ---------------------------------------------------------------------- statistics
@dataclass(frozen=True)
class TestResult:
    """One statistical test (frozen).

    Attributes
    ----------
    test : str
        ``"Kruskal-Wallis"``, ``"Mann-Whitney-Wilcoxon"`` or ``"Friedman"``.
    subject : str
        The algorithm whose results are compared across a factor, or ``"algorithms"``.
    metric : str
        A key of :data:`METRICS`.
    factor : str
        What the groups are: ``"robots"``, ``"percent_tasks"``, ``"service_types"``,
        ``"services_per_robot"`` or ``"algorithm"``.
    subset : str
        Which trials (e.g. ``"load 1, percent tasks 10, 50"``).
    groups : tuple of str
        Group labels, in order.
    n : int
        Observations (Friedman: blocks, i.e. missions).
    statistic, p_value : float or None
        ``H``, ``U`` or chi-square; ``None`` when the test could not be run (``note``).
    posthoc : tuple of (str, str, float)
        Pairwise p-values: Mann-Whitney-Wilcoxon after Kruskal-Wallis, Conover after
        Friedman (unadjusted, as in the seed).
    note : str
    mean_ranks : tuple of (str, float)
        Each group's mean rank (Kruskal-Wallis and Mann-Whitney: over the pooled values;
        Friedman: within each block): the direction of an effect -- a lower rank is a
        smaller value.
    """

    __test__ = False  # not a pytest test class

    test: str
    subject: str
    metric: str
    factor: str
    subset: str
    groups: tuple[str, ...]
    n: int
    statistic: float | None
    p_value: float | None
    posthoc: tuple[tuple[str, str, float], ...] = field(default=())
    note: str = ""
    mean_ranks: tuple[tuple[str, float], ...] = field(default=())

    @property
    def direction(self) -> str:
        """The groups by mean rank, lowest first (e.g. ``"sda < grape-s < rachna-dt"``)."""
        ordered = sorted(self.mean_ranks, key=lambda r: r[1])
        return " < ".join(f"{g} ({r:.3g})" for g, r in ordered)

    @property
    def significant(self) -> bool:
        """``p < 0.05``."""
        return self.p_value is not None and self.p_value < ALPHA


def _format_p(p: float | None) -> str:
    if p is None or not math.isfinite(p):
        return "-"
    return "<0.001" if p < 0.001 else f"{p:.3f}"


def _labelled(
    result: StatResult, subject: str, metric: str, factor: str, subset: str
) -> TestResult:
    """A :class:`cfopt.stats.StatResult` with the report's labels."""
    return TestResult(
        result.test, subject, metric, factor, subset, result.groups, result.n, result.statistic,
        result.p_value, tuple((r.a, r.b, r.p_value) for r in result.posthoc),
        result.note,
        tuple(zip(result.groups, result.mean_ranks, strict=False)),
    )  # fmt: skip


def _friedman(
    metric: Metric, subset: str, trials: Sequence[Trial], algorithms: Sequence[str]
) -> TestResult | None:
    """Friedman across ``algorithms`` with the missions as blocks (``None``: not enough
    data -- fewer than 3 algorithms or 2 complete missions)."""
    observations = [((t.cell, t.mission_seed), t.algorithm, metric.value(t)) for t in trials]
    result = friedman(complete_blocks(observations, algorithms))
    if result.outcome is Outcome.NOT_ENOUGH_DATA:
        return None
    return _labelled(result, "algorithms", metric.name, "algorithm", subset)


_FACTORS = (
    ("robots", "collective size", lambda t: t.robots),
    ("percent_tasks", "percent tasks", lambda t: t.percent_tasks),
    ("service_types", "service types", lambda t: t.service_types),
    ("services_per_robot", "services per robot", lambda t: t.services_per_robot),
)
_TESTED_METRICS = ("percent_optimum", "seconds", "megabytes")


def statistics(trials: Sequence[Trial]) -> list[TestResult]:
    """The seed's tests on the trials, per load level.

    For every heuristic and metric (percent of optimum, runtime, communication):
    across collective sizes (only the percent-task levels every size has, as the seed
    left out 1 % at 100 robots) and across percent tasks (only the sizes that have every
    level) a Kruskal-Wallis test with pairwise Mann-Whitney-Wilcoxon post-hoc tests;
    between the levels of service types and of services per robot a Mann-Whitney-Wilcoxon
    test (Kruskal-Wallis when there are more than two levels).  Then, per composition and
    over all, a Friedman test across the heuristics with the missions as blocks, and
    Conover's post-hoc test (``scikit_posthocs.posthoc_conover_friedman``).  A factor
    with one level, or fewer than three heuristics for Friedman, gives no test; groups
    whose values are all equal give a result with ``statistic=None`` and a note.
    """
    results: list[TestResult] = []
    heuristics = [a for a in _algorithms(trials) if a != EXACT]
    for load in sorted({t.load for t in trials}):
        at_load = [t for t in trials if t.load == load]
        for algorithm in heuristics:
            mine = [t for t in at_load if t.algorithm == algorithm]
            for metric_name in _TESTED_METRICS:
                metric = METRICS[metric_name]
                for factor, _label, get in _FACTORS:
                    subset, chosen = _factor_subset(mine, factor)
                    subset = f"load {load:g}" + subset
                    labelled: dict[str, list[float]] = defaultdict(list)
                    for t in sorted(chosen, key=get):
                        v = metric.value(t)
                        if v is not None and math.isfinite(v):
                            labelled[f"{get(t):g}"].append(float(v))
                    if len(labelled) < 2:
                        continue
                    test = mann_whitney if len(labelled) == 2 else kruskal
                    results.append(
                        _labelled(test(labelled), algorithm, metric_name, factor, subset)
                    )
        for metric_name in _TESTED_METRICS:
            metric = METRICS[metric_name]
            compositions = sorted({(t.service_types, t.services_per_robot) for t in at_load})
            for s, k in compositions:
                sub = [t for t in at_load if (t.service_types, t.services_per_robot) == (s, k)]
                r = _friedman(metric, f"load {load:g}, composition {s}:{k}", sub, heuristics)
                if r is not None:
                    results.append(r)
            if len(compositions) > 1:
                r = _friedman(metric, f"load {load:g}, all compositions", at_load, heuristics)
                if r is not None:
                    results.append(r)
    return results


def _factor_subset(trials: Sequence[Trial], factor: str) -> tuple[str, list[Trial]]:
    """The seed's restriction: compare sizes on the percent levels every size has, and
    percent levels on the sizes that have every level."""
    if factor not in ("robots", "percent_tasks"):
        return "", list(trials)
    other = "percent_tasks" if factor == "robots" else "robots"
    levels: dict[Any, set[Any]] = defaultdict(set)
    for t in trials:
        levels[getattr(t, other)].add(getattr(t, factor))
    every = set().union(*levels.values()) if levels else set()
    keep = sorted(o for o, seen in levels.items() if seen == every)
    chosen = [t for t in trials if getattr(t, other) in keep]
    if len(keep) == len(levels):
        return "", chosen
    name = "percent tasks" if other == "percent_tasks" else "robots"
    return f", {name} {', '.join(f'{v:g}' for v in keep)}", chosen


def _statistics_table(results: Sequence[TestResult]) -> tuple[list[str], list[list[str]]]:
    header = [
        "test", "subject", "metric", "groups", "subset", "n", "statistic", "p",
        "mean ranks (lowest first)", "post-hoc",
    ]  # fmt: skip
    rows = []
    for r in results:
        stat = "-" if r.statistic is None else f"{r.statistic:.4g}"
        post = "; ".join(f"{a}/{b}: {_format_p(p)}" for a, b, p in r.posthoc)
        rows.append(
            [
                r.test,
                r.subject,
                r.metric,
                f"{r.factor}: {', '.join(r.groups)}",
                r.subset,
                str(r.n),
                stat,
                _format_p(r.p_value) + (" *" if r.significant else ""),
                r.direction or "-",
                post or r.note,
            ]
        )
    return header, rows


# -------------------------------------------------------------------------- figures
#: Colour-blind-safe colours, in the order they are given to algorithms: Okabe-Ito's
#: eight without its black, then Paul Tol's muted scheme.  The exact solve is grey.
PALETTE = (
    "#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442",
    "#332288", "#88CCEE", "#44AA99", "#117733", "#999933", "#DDCC77", "#CC6677",
    "#882255", "#AA4499",
)  # fmt: skip
EXACT_COLOUR = "#7f7f7f"
#: Hatches of the algorithms beyond the palette's length (one per round of colours).
_HATCHES = ("", "xx", "..", "oo", "++", "**")
#: Hatches of the distributed variants of an algorithm (one per network tag).
_VARIANT_HATCHES = ("////", "\\\\", "||||", "----")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "h", "*", "p")


@dataclass(frozen=True)
class SeriesStyle:
    """How one algorithm is drawn in every figure: face colour, edge colour, hatch and
    marker (frozen).  Two series never share ``(colour, hatch)``."""

    colour: str
    edge: str
    hatch: str
    marker: str


def _lighter(colour: str, amount: float = 0.5) -> str:
    """``colour`` (``#rrggbb``) mixed with white: the shade of a distributed variant."""
    rgb = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    return "#" + "".join(f"{round(c + (255 - c) * amount):02x}" for c in rgb)


def _base_name(name: str) -> tuple[str, str]:
    """``"grape-s (net 2)"`` -> ``("grape-s", "net 2")``; ``"sda"`` -> ``("sda", "")``."""
    base, sep, tag = name.partition(" (")
    return (base, tag.rstrip(")")) if sep else (name, "")


def algorithm_styles(names: Iterable[str] = ()) -> dict[str, SeriesStyle]:
    """The style of every algorithm, the same in every figure of every report.

    Each base algorithm gets a colour of :data:`PALETTE` (and a marker) by its place in
    the registry (:data:`heuristics.registry.ALGORITHMS`, in registration order: cfopt's
    algorithms first, a user's after), names not registered after those, sorted; past
    the palette's length the colours repeat with a hatch.  A distributed variant
    (``"grape-s (distributed)"``, ``"grape-s (net 2)"``) is a lighter shade of its
    algorithm's colour with a hatch of its own.  Returns the registered algorithms, the
    exact solve and every name in ``names``.

    >>> styles = algorithm_styles(["grape-s (distributed)"])
    >>> styles["grape-s"].colour, styles["grape-s (distributed)"].hatch
    ('#0072B2', '////')
    """
    from heuristics.registry import ALGORITHMS

    names = list(names)
    registered = [a for a in ALGORITHMS if a != EXACT]
    bases = registered + sorted({_base_name(n)[0] for n in names} - {EXACT, *registered})
    styles = {EXACT: SeriesStyle(EXACT_COLOUR, EXACT_COLOUR, "", "o")}
    for i, base in enumerate(bases):
        colour = PALETTE[i % len(PALETTE)]
        hatch = _HATCHES[(i // len(PALETTE)) % len(_HATCHES)]
        styles[base] = SeriesStyle(colour, colour, hatch, _MARKERS[i % len(_MARKERS)])
    tags: dict[str, list[str]] = defaultdict(list)
    for name in sorted(set(names)):
        base, tag = _base_name(name)
        if tag and name not in styles:
            tags[base].append(name)
    for base, variants in tags.items():
        own = styles.get(base, styles[EXACT])
        for k, name in enumerate(variants):
            hatch = own.hatch + _VARIANT_HATCHES[k % len(_VARIANT_HATCHES)]
            styles[name] = SeriesStyle(_lighter(own.colour), own.edge, hatch, own.marker)
    return styles


def _figure_name(metric: str, load: float) -> str:
    return f"fig_{metric}_load{load:g}".replace(".", "_") + ".png"


_FIGURE_METRICS = ("percent_optimum", "seconds", "work", "megabytes", "sim_seconds")


def _figures(loads: Iterable[tuple[float, bool]]) -> list[tuple[str, float, str]]:
    """``(metric, load, file)`` for each load, given whether it has distributed trials."""
    return [
        (name, load, _figure_name(name, load))
        for load, distributed in sorted(set(loads))
        for name in _FIGURE_METRICS
        if distributed or name not in DISTRIBUTED_METRICS
    ]


def _figure_names(trials: Sequence[Trial]) -> list[tuple[str, float, str]]:
    loads = {t.load for t in trials}
    return _figures(
        (load, any(t.network is not None for t in trials if t.load == load)) for load in loads
    )


def figure_names_for(cells: Iterable[Any]) -> list[str]:
    """The figure files a report of these grid cells' trials will have."""
    cells = list(cells)
    loads = {c.load for c in cells}
    flagged = (
        (load, any(c.network is not None for c in cells if c.load == load)) for load in loads
    )
    return [HEADLINE_FIGURE, *(f for _, _, f in _figures(flagged))]


def report_names_for(cells: Iterable[Any], claims: bool = False) -> list[str]:
    """Every file a report of these grid cells' trials will have (for the audit's check)."""
    cells = list(cells)
    distributed = any(c.network is not None for c in cells)
    names = _report_files(distributed) + figure_names_for(cells)
    return [*names, "claims.csv"] if claims else names


def _percent_axis(ax: Any, values: Sequence[float]) -> None:
    """A percentage axis that never shows an impossible value.

    Percentages of the optimum or of the total lie in [0, 100] (above 100 only when an
    optimum was not proven, and then the data say so): the axis stops at the data's
    maximum or 100, whichever is larger, and at 0 below; no tick lies outside.
    """
    from matplotlib.ticker import MaxNLocator

    lo, hi = min(values), max(values)
    top = max(hi, 100.0)
    pad = 0.06 * max(top - lo, 10.0)
    bottom = max(0.0, lo - pad)
    ticks = [t for t in MaxNLocator(nbins=6).tick_values(bottom, top) if bottom <= t <= top]
    ax.set_ylim(bottom, top + 0.02 * (top - bottom))
    ax.set_yticks(ticks)


#: The report's headline figure: percent of optimum by algorithm and load.
HEADLINE_FIGURE = "fig_headline_percent_optimum.png"


def box_plots(trials: Sequence[Trial], directory: str | os.PathLike[str]) -> list[Path]:
    """Write every figure of :func:`figures` as a PNG into ``directory`` (which must
    exist), replacing files of the same name; returns the paths.  Legends are kept whole
    (``bbox_inches="tight"``)."""
    import matplotlib.pyplot as plt

    directory = Path(directory)
    written = []
    for filename, fig in figures(trials):
        path = directory / filename
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written


def figures(trials: Sequence[Trial]) -> Iterator[tuple[str, Any]]:
    """Every figure of the report, as ``(file name, matplotlib Figure)``, drawn (Agg)
    and not saved.

    First the headline (:data:`HEADLINE_FIGURE`: percent of optimum per algorithm and
    load, all cells pooled), then box plots like the seed's Figures 1-4, one per metric
    and load: one panel per composition (``S:k``), the x axis grouping the cells by
    collective size and percent tasks, every algorithm with its box in each group.
    Runtime and communication use a log scale.  Every algorithm has the style
    :func:`algorithm_styles` gives it, and a labelled legend entry.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = algorithm_styles(t.algorithm for t in trials)
    yield HEADLINE_FIGURE, _headline(plt, trials, styles)
    for metric_name, load, filename in _figure_names(trials):
        yield filename, _metric_figure(plt, trials, METRICS[metric_name], load, styles)


def _headline(plt: Any, trials: Sequence[Trial], styles: dict[str, SeriesStyle]) -> Any:
    """Percent of optimum by algorithm (boxes) and load (groups)."""
    metric = METRICS["percent_optimum"]
    algorithms = [a for a in _algorithms(trials) if a != EXACT]
    loads = sorted({t.load for t in trials})
    fig, ax = plt.subplots(
        figsize=(max(6.4, 1.6 * len(loads) + 0.35 * len(algorithms)), 4.2), layout="constrained"
    )
    width = 0.8 / max(len(algorithms), 1)
    values: list[float] = []
    for a_pos, algorithm in enumerate(algorithms):
        groups = []
        for x_pos, load in enumerate(loads):
            vals = _values(
                (t for t in trials if t.algorithm == algorithm and t.load == load), metric
            )
            values += vals
            groups.append((vals, x_pos + (a_pos - (len(algorithms) - 1) / 2) * width))
        _draw_boxes(ax, groups, styles[algorithm], width)
    if values:
        _percent_axis(ax, values)
    ax.set_xticks(range(len(loads)))
    ax.set_xticklabels([_load_label(load) for load in loads], fontsize=9)
    ax.set_xlim(-0.6, len(loads) - 0.4)
    ax.set_ylabel(f"{metric.label} ({metric.unit})", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    ax.set_title("Percent of optimum by algorithm and load (all cells)", fontsize=11)
    _legend(fig, plt, algorithms, styles)
    return fig


def _metric_figure(
    plt: Any, trials: Sequence[Trial], metric: Metric, load: float, styles: dict[str, SeriesStyle]
) -> Any:
    """One metric at one load: a panel per composition."""
    at_load = [t for t in trials if t.load == load]
    algorithms = [a for a in _algorithms(at_load) if not (metric.heuristics_only and a == EXACT)]
    comps = sorted({(t.service_types, t.services_per_robot) for t in at_load})
    ncols = 2 if len(comps) > 1 else 1
    nrows = math.ceil(len(comps) / ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(6.4 * ncols, 3.4 * nrows + 1.0), squeeze=False,
        layout="constrained",
    )  # fmt: skip
    for ax in axes.ravel()[len(comps) :]:
        ax.set_visible(False)
    width = 0.8 / max(len(algorithms), 1)
    for panel, ((s, k), ax) in enumerate(zip(comps, axes.ravel(), strict=False)):
        mine = [t for t in at_load if (t.service_types, t.services_per_robot) == (s, k)]
        xs = sorted({(t.percent_tasks, t.robots) for t in mine})
        panel_values: list[float] = []
        for a_pos, algorithm in enumerate(algorithms):
            groups = []
            for x_pos, (p, n) in enumerate(xs):
                chosen = (
                    t
                    for t in mine
                    if t.algorithm == algorithm and (t.percent_tasks, t.robots) == (p, n)
                )
                vals = _values(chosen, metric)
                if metric.log_scale:
                    vals = [max(v, 1e-6) for v in vals]
                panel_values += vals
                groups.append((vals, x_pos + (a_pos - (len(algorithms) - 1) / 2) * width))
            _draw_boxes(ax, groups, styles[algorithm], width)
        if metric.unit == "%" and panel_values:
            _percent_axis(ax, panel_values)
        ax.set_xticks(range(len(xs)))
        ax.set_xticklabels([f"n={n}\n{p:g}% tasks" for p, n in xs], fontsize=8)
        ax.set_xlim(-0.6, len(xs) - 0.4)
        if metric.log_scale:
            ax.set_yscale("log")
        ax.set_ylabel(f"{metric.label} ({metric.unit})", fontsize=9)
        ax.set_title(
            f"({chr(ord('a') + panel)}) {s} service types, {k} "
            f"service{'s' if k != 1 else ''} per robot",
            fontsize=10,
        )
        ax.grid(axis="y", alpha=0.3)
        ax.tick_params(axis="y", labelsize=8)
        for x_pos in range(1, len(xs)):
            ax.axvline(x_pos - 0.5, color="#dddddd", linewidth=0.8)
    _legend(fig, plt, algorithms, styles)
    fig.suptitle(
        f"{metric.label} by collective size and percent tasks, {_load_label(load)}", fontsize=11
    )
    return fig


def _draw_boxes(
    ax: Any, groups: Sequence[tuple[list[float], float]], style: SeriesStyle, width: float
) -> None:
    """One algorithm's boxes at the given x positions (groups without values are skipped)."""
    from matplotlib.colors import to_rgba

    data = [vals for vals, _ in groups if vals]
    if not data:
        return
    positions = [x for vals, x in groups if vals]
    ax.boxplot(
        data,
        positions=positions,
        widths=width * 0.85,
        patch_artist=True,
        manage_ticks=False,
        boxprops={"facecolor": to_rgba(style.colour, 0.8), "edgecolor": style.edge,
                  "hatch": style.hatch},
        medianprops={"color": style.edge, "linewidth": 1.8},
        whiskerprops={"color": style.edge},
        capprops={"color": style.edge},
        flierprops={"marker": style.marker, "markersize": 3.5, "markeredgecolor": style.edge,
                    "markerfacecolor": style.colour},
    )  # fmt: skip
    # the median as the algorithm's marker: a box of one value (or none) stays readable
    ax.scatter(
        positions, [float(np.median(v)) for v in data], marker=style.marker, s=22, zorder=3,
        facecolors=style.colour, edgecolors="#000000", linewidths=0.6,
    )  # fmt: skip


def _legend(fig: Any, plt: Any, algorithms: Sequence[str], styles: dict[str, SeriesStyle]) -> None:
    """A legend entry per algorithm, below the axes, in rows of at most four."""
    from matplotlib.colors import to_rgba

    handles = [
        plt.Rectangle(
            (0, 0), 1, 1, facecolor=to_rgba(styles[a].colour, 0.8), edgecolor=styles[a].edge,
            hatch=styles[a].hatch, label=a,
        )
        for a in algorithms
    ]  # fmt: skip
    fig.legend(
        handles=handles, labels=list(algorithms), loc="outside lower center",
        ncol=min(len(algorithms), 4), frameon=False, fontsize=8,
    )  # fmt: skip


# ------------------------------------------------------------------ the report itself
@dataclass(frozen=True)
class Report:
    """What :func:`write_report` wrote (frozen)."""

    directory: Path
    files: tuple[Path, ...]
    summary: str
    gap_report: dict[str, Any]

    @property
    def markdown(self) -> Path:
        """The Markdown report."""
        return self.directory / "report.md"

    @property
    def html(self) -> Path:
        """The self-contained HTML page."""
        return self.directory / "report.html"


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A plain-text table with aligned columns (what the CLI prints).

    >>> print(format_table(["a", "bb"], [["1", "2"]]))
    a  bb
    -  --
    1  2
    """
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(header, widths, strict=True)).rstrip()]
    lines.append("  ".join("-" * w for w in widths))
    for r in rows:
        lines.append("  ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip())
    return "\n".join(lines)


def summary_text(trials: Sequence[Trial]) -> str:
    """The summary as plain text under 100 columns (``cfopt audit`` and ``cfopt report``).

    One table per load: per algorithm the percent of optimum (median, min, max), how many
    trials reached the optimum, the median seconds and megabytes, and how many final
    partitions are Nash / strictly pairwise / pareto pairwise stable.  The report files
    have more (percent of total, maxima, statistics).
    """
    rows = summary_rows(trials)
    missions_at = defaultdict(set)
    for t in trials:
        missions_at[t.load].add((t.cell, t.mission_seed))
    header = ["algorithm", "% of optimum", "optimal", "seconds", "MB"]
    header.append("Nash/strict/pareto")
    legend = (
        "Cells: median (min, max) over the trials; seconds and MB (communication): median; "
        "Nash/strict/pareto: "
        "trials whose final partition is Nash / strictly pairwise / pareto pairwise stable."
    )
    parts = [textwrap.fill(legend, width=100)]
    for load in sorted(missions_at):
        body = []
        for r in (r for r in rows if r["load"] == load):
            n = r["trials"]
            star = "†" if r["unproven_optima"] else ""
            body.append(
                [
                    r["algorithm"],
                    _range_text(r["percent_optimum"]) + star,
                    f"{r['optimal']}/{n}",
                    _median_text(r["seconds"]),
                    _median_text(r["megabytes"]),
                    f"{r['nash_stable']}/{r['pairwise_stable']}/{r['pareto_stable']} of {n}",
                ]
            )
        heading = f"{_load_label(load)}: {plural(len(missions_at[load]), 'mission')}"
        warning = pooling_warning([t for t in trials if t.load == load])
        table = format_table(header, body)
        parts.append(
            heading + "\n" + table + ("" if warning is None else "\n" + textwrap.fill(warning, 100))
        )
    tags = network_tags(trials)
    if tags:
        listed = "; ".join(f"{tag}: {spec}" for spec, tag in tags.items())
        parts.append(textwrap.fill(f"Distributed runs on the simulated network ({listed}).", 100))
    if any(not t.optimum_proven for t in trials):
        parts.append(
            "† some optima were not proven (ILP time limit): percentages are of the best found"
        )
    return "\n\n".join(parts)


def _range_text(d: dict[str, float] | None) -> str:
    return "-" if d is None else f"{_fmt(d['median'])} ({_fmt(d['min'])}, {_fmt(d['max'])})"


def _median_text(d: dict[str, float] | None) -> str:
    return "-" if d is None else _fmt(d["median"])


def _md_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    def esc(s: str) -> str:
        return str(s).replace("|", "\\|")

    lines = ["| " + " | ".join(esc(h) for h in header) + " |"]
    lines.append("|" + "|".join("---" for _ in header) + "|")
    lines += ["| " + " | ".join(esc(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def _html_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A table in a wrapper that scrolls sideways only if it cannot fit; a verdict cell
    is coloured by its verdict."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)

    def cell(c: str) -> str:
        css = f' class="{c}"' if c in _VERDICT_CLASSES else ""
        return f"<td{css}>{_inline(c)}</td>"

    body = "".join("<tr>" + "".join(cell(str(c)) for c in r) + "</tr>" for r in rows)
    table = f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    return f'<div class="wrap">{table}</div>'


def _write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[Any]], mode: str) -> None:
    with path.open(mode, encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)


_VERDICT_ORDER = {"fails": 0, "inconclusive": 1, "holds": 2}


def plain_markup(text: str) -> str:
    """A claim's text with its Sphinx roles as plain code and its whitespace folded.

    >>> plain_markup("as :func:`heuristics.sda` and ``n^3``\\n says")
    'as `heuristics.sda` and `n^3` says'
    """
    text = re.sub(r":[\w.:-]+:`~?([^`]+)`", r"`\1`", str(text))
    return " ".join(text.replace("``", "`").split())


def claim_sources(claim_ids: Iterable[str]) -> dict[str, str]:
    """Whose claim each id is: ``"seed paper"``, ``"cfopt"``, or ``"yours"`` (a claim
    of an installed package says its module: ``"yours (mypkg.claims)"``)."""
    from proofs.claims import claim_origin
    from proofs.claims_cfopt import cfopt_claims
    from proofs.claims_distributed import distributed_claims
    from proofs.claims_dynamic import dynamic_claims
    from proofs.claims_seed import seed_claims

    seed = {c.id for c in (*seed_claims(), *distributed_claims())}
    own = {c.id for c in (*cfopt_claims(), *dynamic_claims())}
    out = {}
    for claim_id in claim_ids:
        if claim_id in seed:
            out[claim_id] = "seed paper"
        elif claim_id in own:
            out[claim_id] = "cfopt"
        else:
            origin = claim_origin(claim_id)
            out[claim_id] = f"yours ({origin})" if origin else "yours"
    return out


def replay_commands(verdict: Any, files: Sequence[str]) -> list[str]:
    """The commands that replay a counterexample from its files (paths as given)."""
    mission = next((f for f in files if f.endswith(".mission.json")), None)
    assignment = next((f for f in files if f.endswith(".assignment.json")), None)
    ce = verdict.counterexample
    if ce is None or mission is None or assignment is None:
        return []
    lines = [f"cfopt check {mission} {assignment}"]
    if ce.algorithm:
        network = next((f for f in files if f.endswith(".network.json")), None)
        run = f"cfopt run {ce.algorithm} {mission}"
        if network is not None:
            run += f" --network {network}" + ("" if ce.seed is None else f" --seed {ce.seed}")
        lines.append(run)
    return lines


def _claim_files(claim_id: str, claim_files: Sequence[str]) -> list[str]:
    kinds = ("mission.json", "assignment.json", "network.json")
    return [f for f in claim_files if Path(f).name in {f"{claim_id}.{k}" for k in kinds}]


def _claims_table(
    claims: Sequence[Any], claim_files: Sequence[str] = (), *, links: bool = False
) -> tuple[list[str], list[list[str]]]:
    """The claims, failures first: id, whose, verdict, scope, the counterexample's
    violation, its files with the replay commands, statement and note.  ``links``: the
    files as Markdown links and the commands as code (the report), else plain (CSV)."""
    header = [
        "id", "verdict", "scope", "source", "missions", "counterexample", "violation",
        "replay", "seconds", "statement", "note",
    ]  # fmt: skip
    sources = claim_sources(v.claim_id for v in claims)
    rows = []
    for v in sorted(claims, key=lambda v: _VERDICT_ORDER.get(v.verdict.value, 1)):
        ce = v.counterexample
        files = _claim_files(v.claim_id, claim_files)
        commands = replay_commands(v, files)
        if links:
            shown = [f"[{Path(f).name}]({Path(f).as_posix()})" for f in files]
            replay = " ".join(shown + [f"`{c}`" for c in commands])
        else:
            replay = "; ".join(commands)
        rows.append(
            [
                v.claim_id,
                v.verdict.value,
                v.scope_text,
                sources[v.claim_id],
                str(v.instances_checked),
                "-" if ce is None else "{} robots, {} tasks, {} services".format(*ce.size),
                "-" if ce is None else plain_markup(ce.detail) or "-",
                replay or "-",
                f"{v.seconds:.1f}",
                plain_markup(v.statement),
                plain_markup(v.note),
            ]
        )
    return header, rows


def _claims_blocks(claims: Sequence[Any], claim_files: Sequence[str]) -> list[tuple[str, Any]]:
    """The report's first section: the verdicts, failures first."""
    header, rows = _claims_table(claims, claim_files, links=True)
    keep = [h for h in header if h not in ("missions", "counterexample", "seconds")]
    index = [header.index(h) for h in keep]
    table = (keep, [[r[i] for i in index] for r in rows])
    counts = defaultdict(int)
    for v in claims:
        counts[v.verdict.value] += 1
    sources = claim_sources(v.claim_id for v in claims)
    whose = defaultdict(list)
    for claim_id, source in sources.items():
        whose[source.split(" (")[0]].append(claim_id)
    said = "; ".join(
        f"{', '.join(ids)} {'are' if len(ids) > 1 else 'is'} "
        + {"seed paper": "the seed paper's", "cfopt": "cfopt's own", "yours": "yours"}[src]
        for src, ids in whose.items()
    )
    tally = ", ".join(f"{counts[k]} {k}" for k in _VERDICT_ORDER if counts[k])
    return [
        ("h2", "Claims: verdicts"),
        ("p", f"{plural(len(claims), 'claim')} checked: {tally}. Whose: {said}."),
        ("table", table),
        (
            "p",
            "Violation: what the counterexample violates, in words. Replay: the "
            "counterexample's files (beside this report) and the commands that show it.",
        ),
    ]


def gap_report(trials: Sequence[Trial], version: str = "") -> dict[str, Any]:
    """The ``gap_report`` object of ``cfopt audit --json``.

    Keys: ``code_version``, ``trials``, ``missions``, ``algorithms``, ``unproven_optima``,
    ``summary`` (:func:`summary_rows`), ``cells`` (per cell and algorithm: trials and
    ``{"median", "min", "max"}`` of every metric), ``statistics`` (every
    :class:`TestResult` as a dict).
    """
    cells: dict[tuple[Any, ...], list[Trial]] = defaultdict(list)
    for t in trials:
        cells[(*_cell_key(t), t.algorithm)].append(t)
    order = {a: i for i, a in enumerate(_algorithms(trials))}
    cell_rows = []
    for key in sorted(cells, key=lambda k: (*k[:5], order[k[5]])):
        group = cells[key]
        first = group[0]
        row: dict[str, Any] = {
            "cell": first.cell,
            "robots": first.robots,
            "percent_tasks": first.percent_tasks,
            "composition": first.composition,
            "load": first.load,
            "algorithm": first.algorithm,
            "trials": len(group),
            "unproven_optima": sum(not t.optimum_proven for t in group),
        }
        for metric in METRICS.values():
            vals = _values(group, metric)
            row[metric.name] = (
                {"median": float(np.median(vals)), "min": min(vals), "max": max(vals)}
                if vals
                else None
            )
        cell_rows.append(row)
    stats_rows = []
    for r in statistics(trials):
        d = {k: getattr(r, k) for k in r.__dataclass_fields__}
        d["groups"] = list(r.groups)
        d["posthoc"] = [{"a": a, "b": b, "p": p} for a, b, p in r.posthoc]
        stats_rows.append(d)
    return {
        "code_version": version,
        "trials": len(trials),
        "missions": len({(t.cell, t.mission_seed) for t in trials}),
        "algorithms": _algorithms(trials),
        "unproven_optima": len({(t.cell, t.mission_seed) for t in trials if not t.optimum_proven}),
        "summary": summary_rows(trials),
        "cells": cell_rows,
        "statistics": stats_rows,
    }


def _report_files(distributed: bool) -> list[str]:
    names = ["report.md", "report.html", "trials.csv", "summary.csv", "statistics.csv"]
    names += [f"table_{m}.csv" for m in _metrics(distributed)]
    return [*names, "distributed.csv"] if distributed else names


def planned_files(trials: Sequence[Trial], claims: Sequence[Any] | None = None) -> list[str]:
    """Names :func:`write_report` writes into its directory for these trials."""
    distributed = any(t.network is not None for t in trials)
    names = [*_report_files(distributed), HEADLINE_FIGURE]
    names += [f for _, _, f in _figure_names(trials)]
    if claims is not None:
        names.append("claims.csv")
    return names


def check_free(directory: str | os.PathLike[str], names: Iterable[str]) -> None:
    """Raise :class:`cfopt.MissionError` if any of ``names`` exists in ``directory``."""
    directory = Path(directory)
    info = stat_path(directory)
    if info is None:
        return
    if not S_ISDIR(info.st_mode):
        raise MissionError(f"{os.fspath(directory)}: exists and is not a directory")
    taken = [n for n in names if stat_path(directory / n, follow_symlinks=False) is not None]
    if taken:
        shown = ", ".join(taken[:3]) + (f" and {len(taken) - 3} more" if len(taken) > 3 else "")
        where = os.fspath(directory)
        raise MissionError(
            f"{where}: already holds a report ({shown}); pass force=True to replace those "
            "files, or choose another directory",
            cli=f"{where}: already holds a report ({shown}); pass --force to replace those "
            "files, or choose another directory",
        )


def write_report(
    trials: Sequence[Trial],
    directory: str | os.PathLike[str],
    *,
    version: str = "",
    claims: Sequence[Any] | None = None,
    claim_files: Sequence[Path] = (),
    source: str = "",
    force: bool = False,
    title: str = "cfopt optimal-gap report",
) -> Report:
    """Write the report: ``report.md``, ``report.html``, CSV tables and PNG box plots.

    Parameters
    ----------
    trials : sequence of Trial
        Typically ``load_trials(store)[0]``.
    directory : path
        Created when missing (its parent folder must exist).  If it already holds any
        file this report would write, nothing is written and :class:`cfopt.MissionError`
        is raised, unless ``force`` (then exactly those files are replaced; other files
        are left alone).  Every file is first written in a temporary folder inside
        ``directory`` and moved into place only when all of them are complete, so a
        failure (a full disk, an interruption) leaves the directory as it was.
    version : str
        The trials' code version (shown in the report).
    claims : sequence of proofs.claimkit.Verdict, optional
        Adds the claims verdict table (and ``claims.csv``).
    claim_files : sequence of Path
        Counterexample files already written (listed in the report).
    source : str
        Where the trials came from (the store's path), shown in the report.
    force : bool, default False
    title : str

    Returns
    -------
    Report
        ``summary`` is the plain-text summary table; ``gap_report`` the JSON-ready data.
    """
    if not trials:
        raise MissionError("no trials to report")
    trials = label_variants(trials)
    directory = Path(directory)
    names = planned_files(trials, claims)
    output_target(directory, overwrite=force, directory=True)
    if not force:
        check_free(directory, names)
    created = make_directory(directory)
    with _staging(directory, created) as stage:
        _write_files(
            trials, stage, version=version, claims=claims, source=source, title=title,
            claim_files=[os.path.relpath(p, directory) for p in claim_files],
        )  # fmt: skip
        _publish(stage, directory, names, force)
    return Report(
        directory=directory,
        files=tuple(directory / n for n in names),
        summary=summary_text(trials),
        gap_report=gap_report(trials, version),
    )


@contextlib.contextmanager
def _staging(directory: Path, created: bool) -> Iterator[Path]:
    """A temporary folder inside ``directory``, removed at the end; on failure also
    ``directory`` itself when this report created it."""
    done = False
    try:
        stage = Path(tempfile.mkdtemp(prefix=".cfopt-report-", dir=directory))
    except OSError as exc:
        raise MissionError(
            f"{os.fspath(directory)}: cannot write ({exc.strerror or exc})"
        ) from None
    try:
        yield stage
        done = True
    except OSError as exc:
        raise MissionError(
            f"{os.fspath(directory)}: cannot write the report ({exc.strerror or exc}); "
            "nothing in it was changed"
        ) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if created and not done:
            with contextlib.suppress(OSError):
                directory.rmdir()  # only if empty


def _publish(stage: Path, directory: Path, names: Sequence[str], force: bool) -> None:
    """Move the finished files into place (renames in one folder: they cannot run out of
    space); without ``force`` a file that appeared meanwhile is not replaced."""
    for name in names:
        if force:
            os.replace(stage / name, directory / name)
            continue
        try:
            os.link(stage / name, directory / name)
        except FileExistsError:
            raise MissionError(
                f"{os.fspath(directory / name)}: appeared while the report was written; "
                "it was left as it is"
            ) from None


def _write_files(
    trials: Sequence[Trial],
    directory: Path,
    *,
    version: str,
    claims: Sequence[Any] | None,
    claim_files: Sequence[str],
    source: str,
    title: str,
) -> None:
    """Every file of the report, into ``directory`` (a fresh staging folder)."""
    mode = "x"

    # CSV files.
    fields = list(trials[0].to_dict())
    _write_csv(
        directory / "trials.csv", fields, ([t.to_dict()[f] for f in fields] for t in trials), mode
    )
    summary_header, summary_body = _summary_table(trials)
    _write_csv(directory / "summary.csv", summary_header, summary_body, mode)
    results = statistics(trials)
    stats_header, stats_body = _statistics_table(results)
    _write_csv(directory / "statistics.csv", stats_header, stats_body, mode)
    distributed = any(t.network is not None for t in trials)
    tables = {name: cell_table(trials, name) for name in _metrics(distributed)}
    for name, (header, rows) in tables.items():
        _write_csv(directory / f"table_{name}.csv", header, rows, mode)
    if claims is not None:
        _write_csv(directory / "claims.csv", *_claims_table(claims, claim_files), mode)
    if distributed:
        _write_csv(directory / "distributed.csv", *distributed_table(trials), mode)
    box_plots(trials, directory)

    # The document, as blocks rendered twice (Markdown and HTML).
    missions = len({(t.cell, t.mission_seed) for t in trials})
    unproven = len({(t.cell, t.mission_seed) for t in trials if not t.optimum_proven})
    blocks: list[tuple[str, Any]] = [("h1", title)]
    facts = [
        f"{len(trials)} trials on {missions} missions in {len({t.cell for t in trials})} grid "
        f"cells; algorithms: {', '.join(_algorithms(trials))}.",
        f"Code: {_code_description(source, version)}"
        + (f"; trials from `{source}`." if source else "."),
        f"Generated {time.strftime('%Y-%m-%d %H:%M:%S %Z')}.",
        "Every mission is solved exactly (`exact`, HiGHS); each heuristic is scored against "
        "that optimum. "
        + (
            f"{unproven} optima were not proven (ILP time limit), marked †: their percentages "
            "are of the best assignment found."
            if unproven
            else "Every optimum was proven."
        ),
    ]
    blocks.append(("p", " ".join(facts)))
    if claims is not None:
        blocks += _claims_blocks(claims, claim_files)
    caption = "Percent of optimum by algorithm and load"
    blocks += [("h2", caption), ("img", (directory / HEADLINE_FIGURE, caption))]
    blocks += _summary_blocks(trials)
    if distributed:
        blocks += _distributed_blocks(trials)
    if claims is not None:
        blocks += _profile_blocks(claims)
    figure_of = {(m, load): directory / f for m, load, f in _figure_names(trials)}
    for name in tables:
        metric = METRICS[name]
        blocks += [("h2", f"{metric.label} ({metric.unit}): median (min, max)")]
        blocks.append(("table", tables[name]))
        for (m, load), path in figure_of.items():
            if m == name:
                blocks.append(("img", (path, f"{metric.label}, {_load_label(load)}")))
    blocks += [
        ("h2", "Statistics"),
        (
            "p",
            "As in the seed: Kruskal-Wallis (H) with pairwise Mann-Whitney-Wilcoxon post-hoc "
            "tests across collective sizes and percent tasks, Mann-Whitney-Wilcoxon (U) "
            "between service-type and services-per-robot levels, each per heuristic; Friedman "
            "(chi-square) across the heuristics with missions as blocks and Conover's post-hoc "
            "test. scipy.stats and scikit-posthocs; p-values unadjusted; * marks p < 0.05. Mean "
            "ranks give the direction: a lower rank is a smaller value (faster, less "
            "communication, lower utility).",
        ),
        ("table", (stats_header, stats_body)),
    ]
    markdown, page = _render(blocks, directory, title)
    for name, text in (("report.md", markdown), ("report.html", page)):
        with (directory / name).open(mode, encoding="utf-8") as handle:
            handle.write(text)


def distributed_table(trials: Sequence[Trial]) -> tuple[list[str], list[list[str]]]:
    """The distributed runs in the layout of the seed's Tables 4 and 5: per algorithm and
    cell (service types, services per robot, percent tasks, collective size) the percent
    of optimum as median (min, max), with how the runs ended, their simulated runtime and
    their communication."""
    header = [
        "algorithm", "service types", "per robot", "% tasks", "robots", "load",
        "% of optimum: median (min, max)", "optimal", "converged", "beliefs agree", "cut",
        "simulated s: median (max)", "communication (MB): median (max)",
    ]  # fmt: skip
    groups: dict[tuple[Any, ...], list[Trial]] = defaultdict(list)
    for t in trials:
        if t.network is not None and t.algorithm != EXACT:
            key = (t.algorithm, t.load, t.service_types, t.services_per_robot)
            groups[(*key, t.percent_tasks, t.robots)].append(t)
    rows = []
    for (algorithm, load, s, k, p, n), group in sorted(groups.items()):
        size = len(group)
        optimal = sum(1 for t in group if (t.percent_optimum or 0) >= 100 - 1e-9)
        rows.append(
            [
                algorithm, str(s), str(k), f"{p:g}", str(n), f"{load:g}",
                format_range(_values(group, METRICS["percent_optimum"])),
                f"{optimal}/{size}",
                f"{sum(bool(t.converged) for t in group)}/{size}",
                f"{sum(bool(t.beliefs_agree) for t in group)}/{size}",
                f"{sum(bool(t.cut) for t in group)}/{size}",
                format_median_max(_values(group, METRICS["sim_seconds"])),
                format_median_max(_values(group, METRICS["megabytes"])),
            ]
        )  # fmt: skip
    return header, rows


def format_median_max(values: Sequence[float]) -> str:
    """``median (max)`` of the values, ``"-"`` without any.

    >>> format_median_max([1.0, 2.0, 10.0])
    '2 (10)'
    """
    return "-" if not values else f"{_fmt(float(np.median(values)))} ({_fmt(max(values))})"


def _summary_blocks(trials: Sequence[Trial]) -> list[tuple[str, Any]]:
    """The summary: a table per load, each with its pooling warning."""
    blocks: list[tuple[str, Any]] = [("h2", "Summary")]
    for load in sorted({t.load for t in trials}):
        at_load = [t for t in trials if t.load == load]
        header, rows = _summary_table(at_load)
        missions = len({(t.cell, t.mission_seed) for t in at_load})
        blocks += [("h3", f"{_load_label(load)}: {plural(missions, 'mission')}")]
        warning = pooling_warning(at_load)
        if warning is not None:
            blocks.append(("warning", warning))
        blocks.append(("table", (header[1:], [r[1:] for r in rows])))
    blocks.append(
        (
            "p",
            "Trials: n per algorithm. Optimal: trials that reached the optimum. Stability: "
            "Nash, strict pairwise and pareto pairwise stability of the final partition by the "
            "independent checkers of `proofs` (under the seed's reward strict pairwise "
            "stability coincides with Nash stability; pareto is the informative pairwise "
            "notion); an exact optimum need not be stable. Communication (MB, 10^6 bytes): "
            "total communication under each algorithm's documented message model.",
        )
    )
    return blocks


def _profile_blocks(claims: Sequence[Any]) -> list[tuple[str, Any]]:
    """The derivation of every network profile the claims ran under (``seed``)."""
    from heuristics.profiles import SEED_PROFILE, seed_profile_derivation

    if not any(getattr(v, "network", None) == SEED_PROFILE for v in claims):
        return []
    lines = seed_profile_derivation()
    return [("h2", "The seed-calibrated network profile"), *(("p", line) for line in lines)]


def _distributed_blocks(trials: Sequence[Trial]) -> list[tuple[str, Any]]:
    tags = network_tags(trials)
    if len(tags) == 1:
        listed = f"`{next(iter(tags))}`"
    else:
        listed = "; ".join(f"{tag}: `{spec}`" for spec, tag in tags.items())
    return [
        ("h2", "Distributed runs"),
        (
            "p",
            "Every robot ran the algorithm as its own agent in cfopt's discrete-event "
            f"simulator, on the network(s) {listed} (topology, per-message latency and loss, "
            "clocks); each robot performs the slot its own final belief gives it, and the run "
            "is scored by that. Converged: all robots ended on one final belief; beliefs "
            "agree: on one belief; cut: stopped by the simulated time limit. Simulated s: "
            "simulated time until the robots stopped; MB: bytes transmitted on the medium. "
            "The seed's distributed results (its Tables 4 and 5) use this layout.",
        ),
        ("table", distributed_table(trials)),
    ]


_CSS = (
    "body{font-family:system-ui,sans-serif;margin:1.5em auto;max-width:110em;padding:0 1em;"
    "color:#222}.wrap{overflow-x:auto;max-width:100%}"
    "table{border-collapse:collapse;margin:1em 0;font-size:.8em;width:100%}"
    "th,td{border:1px solid #ccc;padding:.2em .4em;text-align:left;vertical-align:top;"
    # long paths and commands break anywhere, but no column narrower than a short word
    # (an id, a verdict), so a narrow window never spells one letter per line
    "overflow-wrap:anywhere;min-width:5.5em}th{background:#f3f3f3}"
    "img{max-width:100%;border:1px solid #eee}code{background:#f6f6f6;overflow-wrap:anywhere}"
    ".warning{color:#8a4b00;font-weight:bold}.fails{background:#fde2e2;font-weight:bold}"
    ".inconclusive{background:#fff4d6}.holds{background:#e3f4e6}"
)
_LINK = re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)")
_VERDICT_CLASSES = frozenset(_VERDICT_ORDER)


def _render(blocks: Sequence[tuple[str, Any]], directory: Path, title: str) -> tuple[str, str]:
    md: list[str] = []
    page: list[str] = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
    ]
    for kind, content in blocks:
        if kind in ("h1", "h2", "h3"):
            md.append(f"{'#' * int(kind[1])} {content}\n")
            page.append(f"<{kind}>{html.escape(content)}</{kind}>")
        elif kind in ("p", "warning"):
            md.append(f"**{content}**\n" if kind == "warning" else f"{content}\n")
            css = ' class="warning"' if kind == "warning" else ""
            page.append(f"<p{css}>{_inline(content)}</p>")
        elif kind == "table":
            md.append(_md_table(*content) + "\n")
            page.append(_html_table(*content))
        elif kind == "img":
            path, caption = content
            md.append(f"![{caption}]({path.relative_to(directory).as_posix()})\n")
            data = base64.b64encode(path.read_bytes()).decode("ascii")
            page.append(
                f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{html.escape(caption)}</figcaption></figure>"
            )
    page.append("</body></html>")
    return "\n".join(md), "\n".join(page) + "\n"


def _inline(text: str) -> str:
    """Markdown's inline code and links as HTML (the rest escaped)."""
    escaped = _LINK.sub(r'<a href="\2">\1</a>', html.escape(str(text), quote=True))
    return _inline_code(escaped)


def _inline_code(text: str) -> str:
    parts = text.split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


def report_from_store(
    store: str | os.PathLike[str],
    directory: str | os.PathLike[str],
    *,
    version: str | None = None,
    force: bool = False,
    claims: Sequence[Any] | None = None,
    claim_files: Sequence[Path] = (),
) -> Report:
    """:func:`load_trials` then :func:`write_report` (what ``cfopt report`` does)."""
    trials, version = load_trials(store, version)
    return write_report(
        trials,
        directory,
        version=version,
        claims=claims,
        claim_files=claim_files,
        source=os.fspath(store),
        force=force,
    )
