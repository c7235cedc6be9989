"""The seed paper's published figures, as data: what ``cfopt reproduce`` sets cfopt's beside.

Diehl and Adams, "GRAPE-S: Near Real-Time Coalition Formation for Multiple Service
Collectives".  Every figure its results sections (§5, the centralized evaluation, and §6,
the distributed one) state in their text, tables and captions is one :class:`Figure`:
where it stands (section, and the paper's own table number), which algorithm, which cells
of the grid it covers, what is measured, the statistic and how the paper states it
(``=``, ``<``, ``>``...), the value as printed, and the sentence it comes from, verbatim
(the LaTeX reduced by :func:`plain_text`).  The statistical results carry the test, the
groups, the paper's ``n`` and ``p`` as printed, whether the paper calls the result
significant, and the direction the paper gives (which group is lowest, whether values
increase with a factor).  Numbers are transcribed once, here; the report code only reads
these tables.

The paper's tables: Table 1 and Table 3 are its grids (centralized and distributed
independent variables), Table 2 GRAPE-S's centralized percent utilities (10:5), Table 4
GRAPE-S's distributed ones (10:5) and Table 5 SDA's distributed ones.  Its grids: 100,
500 and 1000 robots (distributed: 100 and 500); 1, 10 and 50 % tasks (1 % only above 100
robots); compositions 5:1, 5:5, 10:1 and 10:5; 25 missions per cell, i.e. 800 trials per
algorithm centralized (Pair-GRAPE-S: 10:5 only, 200) and 500 distributed (Pair-GRAPE-S:
125).

Three more tables complete the transcription: :data:`OMITTED`, the numbers of §5 and §6
that are no figure (grid parameters, hardware, axis ticks, hypothesis labels, complexity
classes...), each with its reason; and :data:`DISAGREEMENTS`, the places where the paper
contradicts itself, both places quoted, with the arithmetic.

Examples
--------
>>> len(FIGURES) > 200
True
>>> [f.value for f in figures(table="Table 2", percent_tasks=(10.0,), statistic="min")]
[89.68, 98.47, 100.0]
>>> figures(measure="percent_utility", statistic="second lowest")[0].printed
'96.07%'
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = [
    "CENTRALIZED_ALGORITHMS",
    "COMMUNICATION_ALGORITHM",
    "COMMUNICATION_CURVE",
    "DISAGREEMENTS",
    "DISTRIBUTED_ALGORITHMS",
    "FIGURES",
    "GRAPE_S_ALGORITHMS",
    "OMITTED",
    "PAIRWISE_ALGORITHM",
    "Disagreement",
    "Figure",
    "Omitted",
    "figures",
    "plain_text",
]

#: The algorithms of the seed's centralized evaluation and of its distributed one
#: (registry names; RACHNA_dt had no distributed agents).
CENTRALIZED_ALGORITHMS = ("grape-s", "pair-grape-s", "sda", "rachna-dt")
DISTRIBUTED_ALGORITHMS = ("grape-s", "pair-grape-s", "sda")
#: Its GRAPE-S variants, whose iterations it counts (about ``n`` a run, §5.1.1 and §6.1).
GRAPE_S_ALGORITHMS = ("grape-s", "pair-grape-s")
#: Its algorithm with the pairwise step: run on the 10:5 composition only, and the runs
#: that needed the step counted (§5.1 and §6.1).
PAIRWISE_ALGORITHM = "pair-grape-s"
#: Its algorithm whose communication §5.1.2 gives per collective size.
COMMUNICATION_ALGORITHM = "grape-s"
#: How the paper states a figure: equal, below, at most, above, at least, about.
RELATIONS = ("=", "<", "<=", ">", ">=", "~")


@dataclass(frozen=True)
class Figure:
    """One published figure of the seed paper (frozen).

    Attributes
    ----------
    evaluation : {"centralized", "distributed"}
    section : str
        Where it stands, e.g. ``"§5.1.3"``.
    table : str
        ``"text"``, or the paper's table: ``"Table 2"``, ``"Table 4"``, ``"Table 5"``,
        or a table's caption (``"Table 2 caption"``).
    algorithm : str
        Registry name (``"grape-s"``...), or ``"all"``.
    measure : str
        ``"percent_utility"``, ``"runtime_s"`` (seconds), ``"communication_mb"``
        (megabytes), ``"trials"`` (a sample size), ``"solved_trials"``,
        ``"pairwise_step_ran"``, ``"optimal_trials"``, ``"cut_trials"`` (stopped by the
        time limit), ``"iterations"`` (the share of runs with exactly ``n``).
    statistic : str
        Of the trials in the cells: ``"median"``, ``"min"``, ``"max"``, ``"second
        lowest"``, ``"second highest"``, ``"every trial"`` (each trial has the value),
        ``"count"`` (trials with a value in :attr:`threshold`, or with the property of the
        measure), ``"largest cell median"``, ``"cell median range"`` (largest minus
        smallest median over the compositions), ``"median difference"`` and ``"median
        ratio"`` (of :attr:`groups`: two compositions or two algorithms), ``"spread
        ratio"`` (interquartile ranges of two algorithms), ``"share lower"`` (of the
        missions, in percent, on which the first of :attr:`groups` has the lower value),
        ``"growth exponent"`` (log-log slope over the sizes); of a test: ``"chi2"``,
        ``"H"``, ``"p"``.
    value : float
    relation : str
        One of :data:`RELATIONS`: ``"<"`` for the paper's "<500 MB"...
    robots, percent_tasks : tuple or None
        The cells it covers (``None``: every value).
    compositions : tuple of (service types, services per robot), or None
    excluding : tuple of (robots, percent tasks, service types, services per robot)
        Cells left out ("all other trials", "except with 500 robots").
    quote : str
        The paper's words, verbatim (see :func:`plain_text`), unique in §5-§6.
    printed : str
        The figure as printed (``"5 min 22 s"``).
    test : str
        ``"friedman"``, ``"conover"`` (its post-hoc pairs), ``"kruskal"``,
        ``"mann-whitney"`` (also Kruskal-Wallis' post-hoc pairs) or ``"wilcoxon"``.
    factor : str
        What a test's groups are: ``"algorithm"``, ``"robots"``, ``"percent_tasks"``,
        ``"service_types"`` or ``"services_per_robot"``.
    groups : tuple of str
        A test's groups (algorithms, or a factor's levels), or the two things a ratio,
        difference or share compares.
    pair : tuple of str
        The two groups of a post-hoc result.
    n : int or None
        The paper's ``n`` as printed.
    p : str
        The paper's p as printed (``"<0.01"``).
    significant : bool or None
        Whether the paper calls the result significant.
    lowest : str
        The group the paper says has the lowest values (``""``: it does not say).
    trend : str
        ``"increases"`` or ``"decreases"``: the values along the factor's levels, as the
        paper says.
    direction_quote : str
        Where the paper states the direction, verbatim, when not in :attr:`quote`.
    threshold : tuple of (float, float) or None
        The range of values a ``"count"`` counts, ``[low, high)``.
    curve : str
        Figures of one curve over the sizes (compared in shape and in level).
    note : str
        A reading of the paper's words that needs saying (a typo, a test's name).
    qualitative : bool
        A bound in words ("multiple gigabyte"): it holds on its side, not near its value.
    """

    evaluation: str
    section: str
    table: str
    algorithm: str
    measure: str
    statistic: str
    value: float
    relation: str = "="
    robots: tuple[int, ...] | None = None
    percent_tasks: tuple[float, ...] | None = None
    compositions: tuple[tuple[int, int], ...] | None = None
    excluding: tuple[tuple[int, float, int, int], ...] = ()
    quote: str = ""
    printed: str = ""
    test: str = ""
    factor: str = ""
    groups: tuple[str, ...] = ()
    pair: tuple[str, ...] = ()
    n: int | None = None
    p: str = ""
    significant: bool | None = None
    lowest: str = ""
    trend: str = ""
    direction_quote: str = ""
    threshold: tuple[float, float] | None = None
    curve: str = ""
    note: str = ""
    qualitative: bool = False

    def covers(self, robots: int, percent_tasks: float, service_types: int, k: int) -> bool:
        """Whether the cell (robots, percent tasks, service types, services per robot) is
        one of the figure's.

        >>> figures(table="Table 2")[0].covers(100, 10.0, 10, 5)
        True
        """
        return (
            (self.robots is None or robots in self.robots)
            and (self.percent_tasks is None or percent_tasks in self.percent_tasks)
            and (self.compositions is None or (service_types, k) in self.compositions)
            and (robots, percent_tasks, service_types, k) not in self.excluding
        )

    @property
    def sample_size(self) -> bool:
        """A count of trials run: the design, not a result (the report's header)."""
        return self.measure == "trials"


@dataclass(frozen=True)
class Omitted:
    """Numbers of §5-§6 that are no figure (frozen): where (verbatim, as
    :attr:`Figure.quote`), which numbers, and why."""

    quote: str
    numbers: tuple[float, ...]
    reason: str


@dataclass(frozen=True)
class Disagreement:
    """Two places where the paper contradicts itself (frozen).

    Attributes
    ----------
    figure : Figure
        The first place (one of :data:`FIGURES`).
    other_section, other_quote : str
        The second place, verbatim.
    why : str
        The arithmetic.
    """

    figure: Figure
    other_section: str
    other_quote: str
    why: str


# ------------------------------------------------------------------------ builders
_C, _D = "centralized", "distributed"
_ALL_COMPOSITIONS = ("5:1", "5:5", "10:1", "10:5")
_GRAPES_BASELINES = tuple(a for a in CENTRALIZED_ALGORITHMS if a != PAIRWISE_ALGORITHM)


def _tuple(value: object, kind: type) -> tuple | None:
    if value is None:
        return None
    values = value if isinstance(value, tuple) else (value,)
    return tuple(kind(v) for v in values)


def _compositions(value: str | tuple[str, ...] | None) -> tuple[tuple[int, int], ...] | None:
    if value is None:
        return None
    names = (value,) if isinstance(value, str) else value
    return tuple((int(s), int(k)) for s, k in (name.split(":") for name in names))


def _fig(
    evaluation: str,
    section: str,
    algorithm: str,
    measure: str,
    statistic: str,
    value: float,
    quote: str,
    printed: str,
    *,
    relation: str = "=",
    robots: int | tuple[int, ...] | None = None,
    percent: float | tuple[float, ...] | None = None,
    comp: str | tuple[str, ...] | None = None,
    excluding: tuple[tuple[int, float, str], ...] = (),
    table: str = "text",
    **extra: object,
) -> Figure:
    """One figure, cells written as the paper does (``comp="10:5"``)."""
    cells = tuple((n, float(p), *_compositions(c)[0]) for n, p, c in excluding)  # type: ignore[index]
    return Figure(
        evaluation, section, table, algorithm, measure, statistic, float(value), relation,
        _tuple(robots, int), _tuple(percent, float), _compositions(comp), cells, quote, printed,
        **extra,  # type: ignore[arg-type]
    )  # fmt: skip


def _test(
    evaluation: str,
    section: str,
    measure: str,
    test: str,
    quote: str,
    p: str,
    *,
    algorithm: str = "all",
    statistic: str = "p",
    value: float | None = None,
    significant: bool = True,
    **extra: object,
) -> Figure:
    """A statistical result: ``value`` is the statistic when printed, else the p bound."""
    if value is None:
        value = float(re.sub(r"[^\d.]", "", p)) if p else 0.05
    if statistic != "p":
        relation, printed = "=", f"{value:g}"
    elif p:
        relation, printed = (p[:1] if p[:1] in ("<", ">") else "="), f"p{p}"
    else:
        relation = "<" if significant else ">="
        printed = "significant" if significant else "not significant"
    return _fig(
        evaluation, section, algorithm, measure, statistic, value, quote, printed,
        relation=relation, test=test, p=p, significant=significant, **extra,  # type: ignore[arg-type]
    )  # fmt: skip


def _pairs(
    evaluation: str,
    section: str,
    measure: str,
    test: str,
    quote: str,
    pairs: Sequence[tuple[str, str, str, bool, str]],
    **extra: object,
) -> list[Figure]:
    """Post-hoc pairs ``(a, b, p, significant, lowest)`` of one sentence."""
    return [
        _test(evaluation, section, measure, test, quote, p, pair=(a, b), significant=sig,
              lowest=low, **extra)
        for a, b, p, sig, low in pairs
    ]  # fmt: skip


def _table(
    evaluation: str,
    table: str,
    section: str,
    algorithm: str,
    comp: str,
    rows: Sequence[tuple[float, int, float, float, float, str]],
) -> list[Figure]:
    """A utility table's rows ``(percent tasks, robots, median, min, max, row as printed)``."""
    out = []
    for p, n, median, low, high, row in rows:
        printed = row.split(" & ")[-1].strip()
        for statistic, value in (("median", median), ("min", low), ("max", high)):
            figure = _fig(evaluation, section, algorithm, "percent_utility", statistic, value,
                          row, printed, robots=n, percent=p, comp=comp, table=table)  # fmt: skip
            out.append(figure)
    return out


def _caption(evaluation: str, table: str, after: str) -> list[Figure]:
    """The captions of Tables 2 and 4: the 1 %-task rows (10:5) and the other compositions
    had 100 % utility.  ``after``: the words that follow, to make the quote unique."""
    quote = (
        "five services per robot. 1% tasks had 100% utility, as did all other collective "
        f"compositions {after}"
    )
    section = "§5.1.3" if evaluation == _C else "§6.1.3"
    out = []
    for percent, comp in ((1, "10:5"), (None, ("5:1", "5:5", "10:1"))):
        figure = _fig(evaluation, section, "grape-s", "percent_utility", "min", 100, quote,
                      "100%", percent=percent, comp=comp, table=f"{table} caption")  # fmt: skip
        out.append(figure)
    return out


#: The curve of GRAPE-S's centralized communication over the sizes (§5.1.2).
COMMUNICATION_CURVE = "GRAPE-S's centralized communication per collective size (5:1, 5:5, 10:1)"

# ---------------------------------------------------------------- §5: centralized
_CENTRALIZED_SAMPLE = [
    _fig(_C, "§5", "all", "trials", "count", 800,
         "for a total of 800 trials per algorithm", "800"),
    _fig(_C, "§5.1", "pair-grape-s", "trials", "count", 200,
         "Pair-GRAPE-S also produced solutions for all of its 200 ten service types/five "
         "services per robot trials", "200", comp="10:5"),
    _fig(_C, "§5.1", "all", "solved_trials", "count", 800,
         "GRAPE-S, SDA, and RACHNA_dt produced solutions for all 800 trials", "all 800",
         groups=_GRAPES_BASELINES),
    _fig(_C, "§5.1", "pair-grape-s", "solved_trials", "count", 200,
         "Pair-GRAPE-S also produced solutions for all of its 200 ten service types/five "
         "services per robot trials", "all of its 200", comp="10:5"),
    _fig(_C, "§5.1", "pair-grape-s", "pairwise_step_ran", "count", 111,
         "The pairwise stability step ran during 111 trials. For the other 89 trials",
         "111 (the other 89 without it)", comp="10:5"),
]  # fmt: skip

_CENTRALIZED_RUNTIME = [
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "median", 322,
         "The only exception was 1000 robot collectives with 50% tasks, ten service types, "
         "and five services per robot (median 5 min 22 s)", "5 min 22 s",
         robots=1000, percent=50, comp="10:5"),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "max", 735,
         "The the maximum runtime was 12 min 15 s", "12 min 15 s"),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "second highest", 438,
         "but all other trials required <=7 min 18 s", "<=7 min 18 s", relation="<="),
    _test(_C, "§5.1.1", "runtime_s", "kruskal",
          "GRAPE-S's runtimes did increase significantly with increased collective size "
          "(H (n=200) = 523.03, p < 0.01)", "<0.01", algorithm="grape-s", statistic="H",
          value=523.03, n=200, factor="robots", groups=("100", "500", "1000"),
          percent=(10, 50), trend="increases"),
    _test(_C, "§5.1.1", "runtime_s", "kruskal",
          "and percent tasks (H (n=200) = 271.95, p < 0.01)", "<0.01", algorithm="grape-s",
          statistic="H", value=271.95, n=200, factor="percent_tasks", groups=("1", "10", "50"),
          robots=(500, 1000), trend="increases"),
    *_pairs(_C, "§5.1.1", "runtime_s", "mann-whitney",
            "All post-hoc analyses were also significant (p<0.01); however, runtimes remained "
            "low.", [("100", "500", "<0.01", True, "100"), ("100", "1000", "<0.01", True, "100"),
                     ("500", "1000", "<0.01", True, "500")],
            algorithm="grape-s", factor="robots", percent=(10, 50)),
    *_pairs(_C, "§5.1.1", "runtime_s", "mann-whitney",
            "All post-hoc analyses were also significant (p<0.01); however, runtimes remained "
            "low.", [("1", "10", "<0.01", True, "1"), ("1", "50", "<0.01", True, "1"),
                     ("10", "50", "<0.01", True, "10")],
            algorithm="grape-s", factor="percent_tasks", robots=(500, 1000)),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "median difference", 10,
         "they differed from those with ten service types and one service per robot by <10 s",
         "<10 s", relation="<", comp=("5:1", "10:1"), groups=("5:1", "10:1")),
    _fig(_C, "§5.1.1", "grape-s", "iterations", "share", 1.0,
         "All other collective compositions required exactly n iterations", "exactly n",
         comp=("5:1", "5:5", "10:1")),
    _test(_C, "§5.1.1", "runtime_s", "mann-whitney",
          "GRAPE-S's runtimes differed significantly from one to five services per robot "
          "(p<0.01)", "<0.01", algorithm="grape-s", factor="services_per_robot",
          groups=("1", "5")),
    _test(_C, "§5.1.1", "runtime_s", "mann-whitney",
          "No significant difference was found between five and ten service types.", "",
          algorithm="grape-s", factor="service_types", groups=("5", "10"), significant=False),
    _fig(_C, "§5.1.1", "pair-grape-s", "runtime_s", "max", 497,
         "The only trial that exceeded 5 min occurred with 1000 robots and 50% tasks, which "
         "required 8 min 17 s", "8 min 17 s", robots=1000, percent=50, comp="10:5"),
    _fig(_C, "§5.1.1", "pair-grape-s", "runtime_s", "count", 1,
         "The only trial that exceeded 5 min occurred with 1000 robots and 50% tasks",
         "only trial that exceeded 5 min", comp="10:5", threshold=(300, float("inf"))),
    _test(_C, "§5.1.1", "runtime_s", "kruskal",
          "Pair-GRAPE-S's runtimes increased significantly with collective size (H (n=50) = "
          "132.46, p < 0.01)", "<0.01", algorithm="pair-grape-s", statistic="H", value=132.46,
          n=50, factor="robots", groups=("100", "500", "1000"), percent=(10, 50), comp="10:5",
          trend="increases"),
    _test(_C, "§5.1.1", "runtime_s", "kruskal",
          "and percent tasks (H (n=50) = 65.29, p < 0.01)", "<0.01", algorithm="pair-grape-s",
          statistic="H", value=65.29, n=50, factor="percent_tasks", groups=("1", "10", "50"),
          robots=(500, 1000), comp="10:5", trend="increases"),
    *_pairs(_C, "§5.1.1", "runtime_s", "mann-whitney",
            "and all post hoc analyses were significant (p<0.01). Overall, Pair-GRAPE-S's",
            [("100", "500", "<0.01", True, "100"), ("100", "1000", "<0.01", True, "100"),
             ("500", "1000", "<0.01", True, "500")],
            algorithm="pair-grape-s", factor="robots", percent=(10, 50), comp="10:5"),
    *_pairs(_C, "§5.1.1", "runtime_s", "mann-whitney",
            "and all post hoc analyses were significant (p<0.01). Overall, Pair-GRAPE-S's",
            [("1", "10", "<0.01", True, "1"), ("1", "50", "<0.01", True, "1"),
             ("10", "50", "<0.01", True, "10")],
            algorithm="pair-grape-s", factor="percent_tasks", robots=(500, 1000), comp="10:5"),
    # baseline comparison
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "max", 300,
         "RACHNA_dt, like GRAPE-S, completed all trials in <5 min with five service types and "
         "one service per robot", "<5 min", relation="<", comp="5:1"),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "max", 300,
         "RACHNA_dt, like GRAPE-S, completed all trials in <5 min with five service types and "
         "one service per robot", "<5 min", relation="<", comp="5:1"),
    _fig(_C, "§5.1.1", "sda", "runtime_s", "max", 480,
         "SDA's runtimes for these variable values were <8 min", "<8 min", relation="<",
         comp="5:1"),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "max", 300,
         "GRAPE-S's <5 min runtimes with 1000 robot collectives", "<5 min", relation="<",
         robots=1000, comp="5:5"),
    _fig(_C, "§5.1.1", "sda", "runtime_s", "min", 1200,
         "substantially better than SDA's 20-30 min runtimes", "20-30 min", relation=">=",
         robots=1000, comp="5:5"),
    _fig(_C, "§5.1.1", "sda", "runtime_s", "max", 1800,
         "substantially better than SDA's 20-30 min runtimes", "20-30 min", relation="<=",
         robots=1000, comp="5:5"),
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "max", 330,
         "RACHNA_dt's runtimes were <5.5 min with 1% tasks", "<5.5 min", relation="<",
         percent=1, comp="5:5"),
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "min", 2700,
         "but increased to 45-55 min with 10% tasks", "45-55 min", relation=">=", percent=10,
         comp="5:5"),
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "max", 3300,
         "but increased to 45-55 min with 10% tasks", "45-55 min", relation="<=", percent=10,
         comp="5:5"),
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "min", 7200,
         "and were >2 hours with 50% tasks", ">2 hours", relation=">", percent=50, comp="5:5"),
    _fig(_C, "§5.1.1", "rachna-dt", "runtime_s", "median", 300,
         "RACHNA_dt generally performed comparably, completing most trial in <5 min",
         "most trial in <5 min", relation="<", comp="10:5"),
    *(
        _fig(_C, "§5.1.1", name, "runtime_s", "median ratio", 2,
             "Pair-GRAPE-S and GRAPE-S with 1000 robots and 10%- 50% tasks were meaningfully "
             "faster (i.e., ~ 2x)", "~ 2x", relation="~", robots=1000, percent=(10, 50),
             comp="10:5", groups=("rachna-dt", name))
        for name in ("pair-grape-s", "grape-s")
    ),
    *(
        _fig(_C, "§5.1.1", name, "runtime_s", "max", 300,
             "Pair-GRAPE-S and GRAPE-S with 500 robots were also marginally faster than SDA, "
             "with <5 min runtimes", "<5 min", relation="<", robots=500, comp="10:5")
        for name in ("pair-grape-s", "grape-s")
    ),
    _fig(_C, "§5.1.1", "pair-grape-s", "runtime_s", "max", 492,
         "Pair-GRAPE-S's <= 8 min 12 s runtimes", "<= 8 min 12 s", relation="<=", robots=1000,
         comp="10:5"),
    _fig(_C, "§5.1.1", "grape-s", "runtime_s", "max", 735,
         "and GRAPE-S's <=12 min 15 s runtimes with 1000 robot collectives",
         "<=12 min 15 s", relation="<=", robots=1000, comp="10:5"),
    _fig(_C, "§5.1.1", "sda", "runtime_s", "min", 1200,
         "substantially faster than SDA's 20-30 min runtimes", "20-30 min", relation=">=",
         robots=1000, comp="10:5"),
    _fig(_C, "§5.1.1", "sda", "runtime_s", "max", 1800,
         "substantially faster than SDA's 20-30 min runtimes", "20-30 min", relation="<=",
         robots=1000, comp="10:5"),
    _test(_C, "§5.1.1", "runtime_s", "friedman",
          "The algorithms’ performance with ten services and five services per robot differed "
          "significantly (χ_r² (n=200) = 484.15, p<0.01)", "<0.01", statistic="chi2",
          value=484.15, n=200, factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5",
          lowest="pair-grape-s", direction_quote="Pair-GRAPE-S was the fastest with ten "
          "services and five services per robot, closely followed by GRAPE-S"),
    _test(_C, "§5.1.1", "runtime_s", "conover",
          "Post hoc analysis found significant differences between Pair-GRAPE-S and all other "
          "algorithms (GRAPE-S/Pair-GRAPE-S: p=0.03, all others: p<0.01), as well as GRAPE-S and "
          "all other algorithms (GRAPE-S/Pair-GRAPE-S: p=0.03, all others: p<0.01)", "=0.03",
          factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5",
          pair=("grape-s", "pair-grape-s")),
    *_pairs(_C, "§5.1.1", "runtime_s", "conover",
            "Post hoc analysis found significant differences between Pair-GRAPE-S and all other "
            "algorithms (GRAPE-S/Pair-GRAPE-S: p=0.03, all others: p<0.01)",
            [("pair-grape-s", "sda", "<0.01", True, "pair-grape-s"),
             ("pair-grape-s", "rachna-dt", "<0.01", True, "pair-grape-s")],
            factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5"),
    *_pairs(_C, "§5.1.1", "runtime_s", "conover",
            "as well as GRAPE-S and all other algorithms (GRAPE-S/Pair-GRAPE-S: p=0.03, all "
            "others: p<0.01)", [("grape-s", "sda", "<0.01", True, ""),
                                ("grape-s", "rachna-dt", "<0.01", True, "")],
            factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5"),
    _test(_C, "§5.1.1", "runtime_s", "conover",
          "No significant difference between SDA and RACHNA_dt was identified.", "",
          factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5", pair=("sda", "rachna-dt"),
          significant=False),
    _test(_C, "§5.1.1", "runtime_s", "friedman",
          "A significant difference was also identified across GRAPE-S, SDA, and RACHNA_dt "
          "(χ_r² (n=800) = 913.24, p<0.01)", "<0.01", statistic="chi2", value=913.24, n=800,
          factor="algorithm", groups=_GRAPES_BASELINES, lowest="grape-s",
          direction_quote="Overall, GRAPE-S's and Pair-GRAPE-S's runtimes were better than "
          "SDA's and RACHNA_dt's."),
    *_pairs(_C, "§5.1.1", "runtime_s", "conover",
            "Specifically, significant differences existed between pairs: GRAPE-S/SDA (p<0.01), "
            "GRAPE-S/RACHNA_dt (p=0.02), and SDA/RACHNA_dt (p<0.01).",
            [("grape-s", "sda", "<0.01", True, ""), ("grape-s", "rachna-dt", "=0.02", True, ""),
             ("sda", "rachna-dt", "<0.01", True, "")],
            factor="algorithm", groups=_GRAPES_BASELINES),
]  # fmt: skip

_CENTRALIZED_COMMUNICATION = [
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "every trial", 30,
         "The required communication was low with 100 robots (i.e., 30 MB)", "30 MB",
         robots=100, comp=("5:1", "5:5", "10:1"), curve=COMMUNICATION_CURVE),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "growth exponent", 3,
         "consistent with GRAPE-S's O(n^3) communication complexity", "O(n^3)", relation="~",
         comp=("5:1", "5:5", "10:1")),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "every trial", 750,
         "GRAPE-S required 750 MB with 500 robots", "750 MB", robots=500,
         comp=("5:1", "5:5", "10:1"), curve=COMMUNICATION_CURVE),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "every trial", 3000,
         "and 3,000 MB (i.e., 3 GB) with 1000 robots", "3,000 MB (i.e., 3 GB)", robots=1000,
         comp=("5:1", "5:5", "10:1"), curve=COMMUNICATION_CURVE),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "max", 10000,
         "resulting in much higher worst case communication (i.e., >10,000 MB, 10 GB)",
         ">10,000 MB, 10 GB", relation=">", comp="10:5"),
    _test(_C, "§5.1.2", "communication_mb", "kruskal",
          "Overall, GRAPE-S's communication increased significantly across the collective sizes "
          "(H (n=200) = 566.54, p<0.01)", "<0.01", algorithm="grape-s", statistic="H",
          value=566.54, n=200, factor="robots", groups=("100", "500", "1000"), percent=(10, 50),
          trend="increases"),
    *_pairs(_C, "§5.1.2", "communication_mb", "mann-whitney",
            "with significant post-hoc analysis results (p<0.01)",
            [("100", "500", "<0.01", True, "100"), ("100", "1000", "<0.01", True, "100"),
             ("500", "1000", "<0.01", True, "500")],
            algorithm="grape-s", factor="robots", percent=(10, 50)),
    _test(_C, "§5.1.2", "communication_mb", "mann-whitney",
          "Significant differences were also detected between results for five and ten service "
          "types (p=0.02)", "=0.02", algorithm="grape-s", factor="service_types",
          groups=("5", "10"), trend="increases", direction_quote="GRAPE-S with ten service "
          "types and five services per robot (Figure ) required at minimum the same "
          "communication as the other collective compositions"),
    _test(_C, "§5.1.2", "communication_mb", "mann-whitney",
          "and one and five services per robot (p=0.02)", "=0.02", algorithm="grape-s",
          factor="services_per_robot", groups=("1", "5"), trend="increases",
          direction_quote="GRAPE-S with ten service types and five services per robot (Figure "
          ") required at minimum the same communication as the other collective compositions"),
    _test(_C, "§5.1.2", "communication_mb", "kruskal",
          "No significant difference was identified with respect to the percent tasks.", "",
          algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"),
          robots=(500, 1000), significant=False),
    _test(_C, "§5.1.2", "communication_mb", "kruskal",
          "Pair-GRAPE-S's total communication increased significantly across the collective "
          "sizes (H (n=50) = 133.39, p<0.01)", "<0.01", algorithm="pair-grape-s",
          statistic="H", value=133.39, n=50, factor="robots", groups=("100", "500", "1000"),
          percent=(10, 50), comp="10:5", trend="increases"),
    *_pairs(_C, "§5.1.2", "communication_mb", "mann-whitney",
            "with significant post hoc analyses (p<0.01), and no significant difference was "
            "detected across the percent tasks",
            [("100", "500", "<0.01", True, "100"), ("100", "1000", "<0.01", True, "100"),
             ("500", "1000", "<0.01", True, "500")],
            algorithm="pair-grape-s", factor="robots", percent=(10, 50), comp="10:5"),
    _test(_C, "§5.1.2", "communication_mb", "kruskal",
          "with significant post hoc analyses (p<0.01), and no significant difference was "
          "detected across the percent tasks", "", algorithm="pair-grape-s",
          factor="percent_tasks", groups=("1", "10", "50"), robots=(500, 1000), comp="10:5",
          significant=False),
    _fig(_C, "§5.1.2", "pair-grape-s", "communication_mb", "spread ratio", 1,
         "Pair-GRAPE-S's communication was slightly more variable than GRAPE-S's for 1% tasks",
         "slightly more variable", relation=">", percent=1, comp="10:5",
         groups=("pair-grape-s", "grape-s")),
    _fig(_C, "§5.1.2", "pair-grape-s", "communication_mb", "spread ratio", 1,
         "and much less variable for 10%-50% tasks", "much less variable", relation="<",
         percent=(10, 50), comp="10:5", groups=("pair-grape-s", "grape-s")),
    _fig(_C, "§5.1.2", "pair-grape-s", "communication_mb", "median ratio", 1,
         "The decreased variability with 10%-50% tasks resulted in lower overall communication",
         "lower", relation="<", percent=(10, 50), comp="10:5", groups=("pair-grape-s", "grape-s")),
    # baseline comparison
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "median ratio", 1,
         "GRAPE-S required more communication than RACHNA_dt with five service types, one "
         "service per robot, and 1-10% tasks", "more", relation=">", percent=(1, 10), comp="5:1",
         groups=("grape-s", "rachna-dt")),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "median ratio", 1,
         "but less with 50% tasks (Figure )", "less", relation="<", percent=50, comp="5:1",
         groups=("grape-s", "rachna-dt")),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 100,
         "Overall, RACHNA_dt required little communication with 100 robots (i.e., <100 MB)",
         "<100 MB", relation="<", robots=100, comp="5:1"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 400,
         "or with 500 robots and 1%-10% tasks (i.e., <400 MB)", "<400 MB", relation="<",
         robots=500, percent=(1, 10), comp="5:1"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 1800,
         "However, RACHNA_dt required >1,800 MB (i.e., 1.8 GB) with 500 robots and 50% tasks.",
         ">1,800 MB (i.e., 1.8 GB)", relation=">", robots=500, percent=50, comp="5:1"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 200,
         "Additionally, RACHNA_dt required <200 MB with 1000 robots and 1% tasks", "<200 MB",
         relation="<", robots=1000, percent=1, comp="5:1"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 1200,
         "but >1,200 MB (i.e., 1.2 GB) with 10%-50% tasks.", ">1,200 MB (i.e., 1.2 GB)",
         relation=">", robots=1000, percent=(10, 50), comp="5:1"),
    _fig(_C, "§5.1.2", "sda", "communication_mb", "max", 500,
         "SDA required <500 MB communication for all trials, which is relatively low.",
         "<500 MB", relation="<", comp="5:1"),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "median ratio", 1,
         "GRAPE-S required more communication than RACHNA_dt for most trials with five "
         "services, five services per robot, and 1%-10% tasks", "more", relation=">",
         percent=(1, 10), comp="5:5", groups=("grape-s", "rachna-dt"),
         excluding=((500, 10, "5:5"),)),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 1200,
         "500 robots and 10% tasks were an exception, where RACHNA_dt required more "
         "communication than GRAPE-S (i.e., >1,200 MB, or 1.2 GB)", ">1,200 MB, or 1.2 GB",
         relation=">", robots=500, percent=10, comp="5:5"),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "median ratio", 1,
         "500 robots and 10% tasks were an exception, where RACHNA_dt required more "
         "communication than GRAPE-S (i.e., >1,200 MB, or 1.2 GB)", "more", relation="<",
         robots=500, percent=10, comp="5:5", groups=("grape-s", "rachna-dt")),
    _fig(_C, "§5.1.2", "grape-s", "communication_mb", "median ratio", 1,
         "RACHNA_dt also required more communication than GRAPE-S with 50% tasks.", "more",
         relation="<", percent=50, comp="5:5", groups=("grape-s", "rachna-dt")),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 500,
         "RACHNA_dt required <500 MB, except with 500 robots and 50% tasks", "<500 MB",
         relation="<", comp="5:5", excluding=((500, 50, "5:5"), (1000, 50, "5:5"))),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 6800,
         "(i.e., >6,800 MB, 6.8 GB)", ">6,800 MB, 6.8 GB", relation=">", robots=500,
         percent=50, comp="5:5"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 5200,
         "and 1000 robots with 50% tasks (i.e., >5,200 MB, 5.2 GB)", ">5,200 MB, 5.2 GB",
         relation=">", robots=1000, percent=50, comp="5:5"),
    _fig(_C, "§5.1.2", "sda", "communication_mb", "max", 550,
         "SDA required <550 MB for all trials.", "<550 MB", relation="<", comp="5:5"),
    *(
        _fig(_C, "§5.1.2", name, "communication_mb", "share lower", 100,
             "GRAPE-S and Pair-GRAPE-S required less communication than RACHNA_dt for all 50% "
             "task trials", "all 50% task trials", percent=50, comp="10:5",
             groups=(name, "rachna-dt"))
        for name in ("grape-s", "pair-grape-s")
    ),
    *(
        _fig(_C, "§5.1.2", name, "communication_mb", "share lower", share,
             "as well as some 10% task trials; however, RACHNA_dt required less communication "
             "for other 10% trials", printed, relation=relation, percent=10, comp="10:5",
             groups=(name, "rachna-dt"))
        for name in ("grape-s", "pair-grape-s")
        for share, relation, printed in ((0, ">", "some 10% task trials"),
                                         (100, "<", "other 10% trials"))
    ),
    *(
        _fig(_C, "§5.1.2", name, "communication_mb", "median ratio", 1,
             "Finally, Pair-GRAPE-S and GRAPE-S with 1% tasks required more communication than "
             "RACHNA_dt.", "more", relation=">", percent=1, comp="10:5",
             groups=(name, "rachna-dt"))
        for name in ("pair-grape-s", "grape-s")
    ),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 600,
         "RACHNA_dt's required communication was relatively low with 1% tasks (i.e., <600 MB)",
         "<600 MB", relation="<", percent=1, comp="10:5"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "min", 1000,
         "but was >1,000 MB (i.e., 1 GB) with 10%-50% tasks", ">1,000 MB (i.e., 1 GB)",
         relation=">", percent=(10, 50), comp="10:5"),
    _fig(_C, "§5.1.2", "rachna-dt", "communication_mb", "max", 27500,
         "RACHNA_dt required >27,500 MB (i.e., 27.5 GB) in the worst-case.",
         ">27,500 MB (i.e., 27.5 GB)", relation=">", comp="10:5"),
    _fig(_C, "§5.1.2", "sda", "communication_mb", "median", 500,
         "SDA required the least communication, <500 MB for most trials", "<500 MB for most",
         relation="<", comp="10:5"),
    _fig(_C, "§5.1.2", "sda", "communication_mb", "max", 650,
         "with a >650 MB worst-case communication requirement", ">650 MB", relation=">",
         comp="10:5"),
    _test(_C, "§5.1.2", "communication_mb", "friedman",
          "The algorithms' communication with ten services and five services per robot differed "
          "significantly (χ_r² (n=200) = 399.34, p<0.01)", "<0.01", statistic="chi2",
          value=399.34, n=200, factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5",
          lowest="sda", direction_quote="SDA required the least communication, <500 MB for "
          "most trials"),
    _test(_C, "§5.1.2", "communication_mb", "conover",
          "No significant difference between Pair-GRAPE-S and GRAPE-S was found", "",
          factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5",
          pair=("grape-s", "pair-grape-s"), significant=False),
    *_pairs(_C, "§5.1.2", "communication_mb", "conover",
            "but all other post hoc tests were significant (p<0.01).",
            [("grape-s", "sda", "<0.01", True, "sda"), ("grape-s", "rachna-dt", "<0.01", True, ""),
             ("pair-grape-s", "sda", "<0.01", True, "sda"),
             ("pair-grape-s", "rachna-dt", "<0.01", True, ""),
             ("sda", "rachna-dt", "<0.01", True, "sda")],
            factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5"),
    _test(_C, "§5.1.2", "communication_mb", "friedman",
          "The algorithms also differed significantly overall (χ_r² (n=800) = 1186.8, "
          "p<0.01).", "<0.01", statistic="chi2", value=1186.8, n=800, factor="algorithm",
          groups=_GRAPES_BASELINES, lowest="sda",
          direction_quote="SDA required the least communication overall (Figure )."),
    *_pairs(_C, "§5.1.2", "communication_mb", "conover",
            "Significant differences existed between SDA and GRAPE-S (p<0.01), and SDA and "
            "RACHNA_dt (p<0.01)", [("sda", "grape-s", "<0.01", True, "sda"),
                                   ("sda", "rachna-dt", "<0.01", True, "sda")],
            factor="algorithm", groups=_GRAPES_BASELINES),
    _test(_C, "§5.1.2", "communication_mb", "conover",
          "but no significant difference between GRAPE-S and RACHNA_dt was identified.", "",
          factor="algorithm", groups=_GRAPES_BASELINES, pair=("grape-s", "rachna-dt"),
          significant=False),
]  # fmt: skip

_OPTIMAL_ELSEWHERE = (
    "GRAPE-S produced optimal solutions with five services and one service per robot, five "
    "services and five services per robot, and ten services and one service per robot"
)
_CENTRALIZED_UTILITY = [
    *(
        _fig(_C, "§5.1.3", "grape-s", "percent_utility", "min", 100, _OPTIMAL_ELSEWHERE,
             "optimal", comp=comp)
        for comp in ("5:1", "5:5", "10:1")
    ),
    *_table(_C, "Table 2", "§5.1.3", "grape-s", "10:5", [
        (10, 100, 100.0, 89.68, 100.0, "10 & 100 & 100.0 (89.68, 100.0)"),
        (10, 500, 100.0, 98.47, 100.0, "& 500 & 100.0 (98.47, 100.0)"),
        (10, 1000, 100.0, 100.0, 100.0, "& 1000 & 100.0 (100.0, 100.0)"),
        (50, 100, 100.0, 96.59, 100.0, "50& 100 & 100.0 (96.59, 100.0)"),
        (50, 500, 100.0, 99.66, 100.0, "& 500 & 100.0 (99.66, 100.0)"),
        (50, 1000, 100.0, 99.69, 100.0, "& 1000 & 100.0 (99.69, 100.0)"),
    ]),
    *_caption(_C, "Table 2", "Percent Tasks"),
    _fig(_C, "§5.1.3", "grape-s", "percent_utility", "min", 89.68,
         "GRAPE-S's lowest utility trial (i.e., 89.68%), which occurred for 100 robot "
         "collectives with ten services, five service per robot, and 10% tasks",
         "89.68%, at 100 robots and 10% tasks"),
    _fig(_C, "§5.1.3", "grape-s", "percent_utility", "second lowest", 96.07,
         "The next lowest percent utility with this independent variable combination was "
         "96.07%.", "96.07%", robots=100, percent=10, comp="10:5"),
    _fig(_C, "§5.1.3", "grape-s", "percent_utility", "min", 95,
         "The percent utilities for all other independent variable combinations were above the "
         ">95% target threshold.", ">95%", relation=">", excluding=((100, 10, "10:5"),)),
    _test(_C, "§5.1.3", "percent_utility", "kruskal",
          "GRAPE-S's percent utilities differed significantly across the percent tasks (H "
          "(n=200) = 7.19, p=0.03)", "=0.03", algorithm="grape-s", statistic="H", value=7.19,
          n=200, factor="percent_tasks", groups=("1", "10", "50"), robots=(500, 1000)),
    _test(_C, "§5.1.3", "percent_utility", "mann-whitney",
          "with significant differences existed between 1% and 50% tasks (p=0.01)", "=0.01",
          algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"),
          robots=(500, 1000), pair=("1", "50")),
    *_pairs(_C, "§5.1.3", "percent_utility", "mann-whitney",
            "No other significant differences between percent tasks were detected.",
            [("1", "10", "", False, ""), ("10", "50", "", False, "")],
            algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"),
            robots=(500, 1000)),
    _test(_C, "§5.1.3", "percent_utility", "mann-whitney",
          "However, significant differences were found between five and ten services (p<0.01)",
          "<0.01", algorithm="grape-s", factor="service_types", groups=("5", "10"),
          trend="decreases", direction_quote="GRAPE-S's percent utilities with ten services "
          "and five services per robot were slightly lower"),
    _test(_C, "§5.1.3", "percent_utility", "mann-whitney",
          "and between one and ten services per robot (p<0.01)", "<0.01", algorithm="grape-s",
          factor="services_per_robot", groups=("1", "5"), trend="decreases",
          direction_quote="GRAPE-S's percent utilities with ten services and five services per "
          "robot were slightly lower", note="the paper prints 'one and ten services per robot'; "
          "its robots have one or five"),
    _fig(_C, "§5.1.3", "pair-grape-s", "percent_utility", "min", 100,
         "Pair-GRAPE-S produced optimal solutions for all problems.", "optimal", comp="10:5"),
    # baseline comparison
    _fig(_C, "§5.1.3", "rachna-dt", "percent_utility", "min", 100,
         "RACHNA_dt, and Pair-GRAPE-S when applicable had the highest percent utilities, "
         "producing optimal solutions for all trials.", "optimal"),
    _fig(_C, "§5.1.3", "pair-grape-s", "percent_utility", "min", 100,
         "RACHNA_dt, and Pair-GRAPE-S when applicable had the highest percent utilities, "
         "producing optimal solutions for all trials.", "optimal", comp="10:5"),
    *(
        _fig(_C, "§5.1.3", "sda", "percent_utility", statistic, value,
             "SDA's percent utilities for 100 robot collectives with ten service types, five "
             "services per robot, and 50% tasks were slightly lower (i.e., 99.99% median, min. "
             "= 99.87%, max. = 100.0%)", printed, robots=100, percent=50, comp="10:5")
        for statistic, value, printed in (("median", 99.99, "99.99%"), ("min", 99.87, "99.87%"),
                                          ("max", 100.0, "100.0%"))
    ),
    _test(_C, "§5.1.3", "percent_utility", "friedman",
          "the algorithms' utilities differed significantly for collectives with ten service "
          "types and five services per robot (χ_r² (n=200) = 39.00, p<0.01)", "<0.01",
          statistic="chi2", value=39.00, n=200, factor="algorithm", groups=CENTRALIZED_ALGORITHMS,
          comp="10:5", lowest="grape-s", direction_quote="Specifically, GRAPE-S's utilities "
          "were significantly worse than the other algorithms (p<0.01)"),
    *_pairs(_C, "§5.1.3", "percent_utility", "conover",
            "Specifically, GRAPE-S's utilities were significantly worse than the other "
            "algorithms (p<0.01)", [("grape-s", other, "<0.01", True, "grape-s")
                                    for other in ("pair-grape-s", "sda", "rachna-dt")],
            factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5"),
    *_pairs(_C, "§5.1.3", "percent_utility", "conover",
            "although largely near-optimal. No other significant differences were detected.",
            [("pair-grape-s", "sda", "", False, ""), ("pair-grape-s", "rachna-dt", "", False, ""),
             ("sda", "rachna-dt", "", False, "")],
            factor="algorithm", groups=CENTRALIZED_ALGORITHMS, comp="10:5"),
    _test(_C, "§5.1.3", "percent_utility", "friedman",
          "The algorithms' percent utilities also differed significantly overall (χ_r² "
          "(n=800) = 17.63, p<0.01).", "<0.01", statistic="chi2", value=17.63, n=800,
          factor="algorithm", groups=_GRAPES_BASELINES, lowest="grape-s",
          direction_quote="GRAPE-S's utilities were significantly worse than SDA's (p<0.01), "
          "as well as RACHNA_dt's (p<0.01)"),
    *_pairs(_C, "§5.1.3", "percent_utility", "conover",
            "GRAPE-S's utilities were significantly worse than SDA's (p<0.01), as well as "
            "RACHNA_dt's (p<0.01)", [("grape-s", "sda", "<0.01", True, "grape-s"),
                                     ("grape-s", "rachna-dt", "<0.01", True, "grape-s")],
            factor="algorithm", groups=_GRAPES_BASELINES),
    _test(_C, "§5.1.3", "percent_utility", "conover",
          "but no significant differences were identified between SDA and RACHNA_dt.", "",
          factor="algorithm", groups=_GRAPES_BASELINES, pair=("sda", "rachna-dt"),
          significant=False),
]  # fmt: skip

_CENTRALIZED_DISCUSSION = [
    _fig(_C, "§5.2", "pair-grape-s", "runtime_s", "largest cell median", 300,
         "being the only algorithm with <5 min median runtimes for all collective sizes, "
         "compositions, and percent tasks", "<5 min median", relation="<", comp="10:5"),
    _fig(_C, "§5.2", "grape-s", "communication_mb", "min", 2000,
         "their multiple gigabyte communication requirements with 1000 robots",
         "multiple gigabyte", relation=">=", robots=1000, qualitative=True),
    _fig(_C, "§5.2", "grape-s", "percent_utility", "min", 95,
         "being the only algorithm to produce a solution below the >95% threshold", ">95%",
         relation="<"),
    *(
        _fig(_C, "§5.2", name, "percent_utility", "min", 95,
             "being the only algorithm to produce a solution below the >95% threshold", ">95%",
             relation=">", comp="10:5" if name == "pair-grape-s" else None)
        for name in ("pair-grape-s", "sda", "rachna-dt")
    ),
]  # fmt: skip

# ---------------------------------------------------------------- §6: distributed
_DISTRIBUTED_SAMPLE = [
    _fig(_D, "§6", "all", "trials", "count", 500,
         "This reduction decreases the number of trials to 500 per algorithm.", "500"),
    _fig(_D, "§6.1", "pair-grape-s", "trials", "count", 125,
         "Pair-GRAPE-S produced solutions for all 125 trials with this collective composition",
         "125", comp="10:5"),
    _fig(_D, "§6.1", "all", "solved_trials", "count", 500,
         "GRAPE-S and SDA produced solutions for all 500 trials.", "all 500",
         groups=("grape-s", "sda")),
    _fig(_D, "§6.1", "pair-grape-s", "solved_trials", "count", 125,
         "Pair-GRAPE-S produced solutions for all 125 trials with this collective composition",
         "all 125", comp="10:5"),
    _fig(_D, "§6.1", "pair-grape-s", "pairwise_step_ran", "count", 80,
         "and the required pairwise stability step in 80 trials", "80", comp="10:5"),
]  # fmt: skip

_DISTRIBUTED_RUNTIME = [
    _fig(_D, "§6.1.1", "grape-s", "runtime_s", "max", 300,
         "GRAPE-S's runtimes were well within the 5 min target for all 500 trials",
         "within the 5 min target for all 500", relation="<"),
    _fig(_D, "§6.1.1", "grape-s", "runtime_s", "count", 1,
         "Only one trial had a >4 min runtime", "one trial had a >4 min",
         threshold=(240, float("inf"))),
    _fig(_D, "§6.1.1", "grape-s", "runtime_s", "max", 262,
         "(i.e., 4 min 22 s with ten service, five services per robot, 500 robots, and 50% "
         "tasks)", "4 min 22 s, at 500 robots and 50% tasks"),
    _fig(_D, "§6.1.1", "grape-s", "runtime_s", "count", 3,
         "Additionally, only three trials had 3-4 min runtimes", "three trials had 3-4 min",
         threshold=(180, 240)),
    _fig(_D, "§6.1.1", "grape-s", "runtime_s", "count", 496,
         "with the other 496 trials completing in <3 min.", "496 trials completing in <3 min",
         threshold=(0, 180), note="1 + 3 + 496 = the paper's 500 trials: '<3 min' is said of "
         "496 of them, not of all 500"),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "they did increase significantly with the collective size (p<0.01)", "<0.01",
          algorithm="grape-s", factor="robots", groups=("100", "500"), percent=(10, 50),
          trend="increases"),
    _test(_D, "§6.1.1", "runtime_s", "mann-whitney",
          "as well as the number of service types (p<0.01)", "<0.01", algorithm="grape-s",
          factor="service_types", groups=("5", "10"), trend="increases"),
    _test(_D, "§6.1.1", "runtime_s", "mann-whitney",
          "however, no other significant differences were detected. [Five service types", "",
          algorithm="grape-s", factor="services_per_robot", groups=("1", "5"),
          significant=False),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "however, no other significant differences were detected. [Five service types", "",
          algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"), robots=500,
          significant=False),
    _fig(_D, "§6.1.1", "pair-grape-s", "runtime_s", "max", 213,
         "The longest runtime was only 3 min 33 s, which occurred with 500 robots, 1% tasks, "
         "five service types, and one service per robot.",
         "3 min 33 s, at 500 robots and 1% tasks"),
    _fig(_D, "§6.1.1", "pair-grape-s", "runtime_s", "second highest", 180,
         "All other trials completed in <3 min. Like GRAPE-S", "<3 min", relation="<"),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "Like GRAPE-S, Pair-GRAPE-S's runtimes did increase significantly with the collective "
          "size (p<0.01)", "<0.01", algorithm="pair-grape-s", factor="robots",
          groups=("100", "500"), percent=(10, 50), comp="10:5", trend="increases"),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "and no difference was found across the percent tasks. SDA's runtimes", "",
          algorithm="pair-grape-s", factor="percent_tasks", groups=("1", "10", "50"), robots=500,
          comp="10:5", significant=False),
    *(
        _fig(_D, "§6.1.1", "sda", "runtime_s", "median ratio", 1,
             "SDA's runtimes with 500 robots and 1% tasks were slightly faster than GRAP-E-S's "
             "and Pair-GRAPE-S's.", "slightly faster", relation="<", robots=500, percent=1,
             groups=("sda", name))
        for name in ("grape-s", "pair-grape-s")
    ),
    _fig(_D, "§6.1.1", "sda", "runtime_s", "max", 300,
         "SDA's runtimes with 100 robots and 10% tasks were not meaningfully longer, with all "
         "trials completing in <5 min", "<5 min", relation="<", robots=100, percent=10),
    _fig(_D, "§6.1.1", "sda", "runtime_s", "min", 2100,
         "100 robot collectives with 50% tasks required 35-57 min", "35-57 min", relation=">=",
         robots=100, percent=50),
    _fig(_D, "§6.1.1", "sda", "runtime_s", "max", 3420,
         "100 robot collectives with 50% tasks required 35-57 min", "35-57 min", relation="<=",
         robots=100, percent=50),
    _fig(_D, "§6.1.1", "sda", "runtime_s", "min", 1500,
         "while 500 robots with 10% tasks required >=25 min", ">=25 min", relation=">=",
         robots=500, percent=10),
    _fig(_D, "§6.1.1", "sda", "cut_trials", "count", 0,
         "while 500 robots with 10% tasks required >=25 min and sometimes exceeded the one hour "
         "limit", "sometimes", relation=">", robots=500, percent=10),
    _fig(_D, "§6.1.1", "sda", "completed_trials", "count", 0,
         "No trial with 500 robots and 50% tasks completed within the time limit.", "no trial",
         robots=500, percent=50),
    _fig(_D, "§6.1.1", "sda", "runtime_s", "cell median range", 300,
         "The median runtimes with 500 robots and 10% tasks differed by <5 min for collectives "
         "with five service types with one service per robot, five service types with five "
         "services per robot, and ten services with five services per robot.", "<5 min",
         relation="<", robots=500, percent=10, comp=("5:1", "5:5", "10:5")),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "Overall, SDA's runtimes increased significantly with the collective size (p<0.01)",
          "<0.01", algorithm="sda", factor="robots", groups=("100", "500"), percent=(10, 50),
          trend="increases"),
    _test(_D, "§6.1.1", "runtime_s", "mann-whitney",
          "and differed significantly with the number of services per robot (p=0.04)", "=0.04",
          algorithm="sda", factor="services_per_robot", groups=("1", "5")),
    _test(_D, "§6.1.1", "runtime_s", "kruskal",
          "SDA's runtimes also increased significantly with the percent tasks (H (n=25) = "
          "99.87, p<0.01)", "<0.01", algorithm="sda", statistic="H", value=99.87, n=25,
          factor="percent_tasks", groups=("1", "10", "50"), robots=500, trend="increases"),
    *_pairs(_D, "§6.1.1", "runtime_s", "mann-whitney",
            "Specifically, significant differences were found between 1% tasks and 10% tasks "
            "(p<0.01), as well as 1% and 50% tasks (p<0.01).",
            [("1", "10", "<0.01", True, "1"), ("1", "50", "<0.01", True, "1")],
            algorithm="sda", factor="percent_tasks", groups=("1", "10", "50"), robots=500),
    _test(_D, "§6.1.1", "runtime_s", "mann-whitney",
          "No significant difference between 10% and 50% tasks existed.", "", algorithm="sda",
          factor="percent_tasks", groups=("1", "10", "50"), robots=500, pair=("10", "50"),
          significant=False),
    _test(_D, "§6.1.1", "runtime_s", "wilcoxon",
          "GRAPE-S's and SDA's runtimes differed significantly (p<0.01), considering all "
          "collective compositions.", "<0.01", factor="algorithm", groups=("grape-s", "sda")),
    _test(_D, "§6.1.1", "runtime_s", "friedman",
          "The difference between GRAPE-S, Pair-GRAPE-S, and SDA with ten services and five "
          "services per robot was not mathematically significant", "", factor="algorithm",
          groups=DISTRIBUTED_ALGORITHMS, comp="10:5", significant=False),
]  # fmt: skip

_DISTRIBUTED_COMMUNICATION = [
    _fig(_D, "§6.1.2", "grape-s", "communication_mb", "max", 100,
         "GRAPE-S's communication requirement was reasonable for 100 robot collectives (i.e., "
         "<100 MB in total)", "<100 MB", relation="<", robots=100),
    _fig(_D, "§6.1.2", "grape-s", "communication_mb", "max", 50000,
         "GRAPE-S required as much as 50-120 GB of communication for for 500 robot collectives",
         "50-120 GB", relation=">=", robots=500),
    _fig(_D, "§6.1.2", "grape-s", "communication_mb", "max", 120000,
         "GRAPE-S required as much as 50-120 GB of communication for for 500 robot collectives",
         "50-120 GB", relation="<=", robots=500),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "The communication increase with collective size was significant (p<0.01)", "<0.01",
          algorithm="grape-s", factor="robots", groups=("100", "500"), percent=(10, 50),
          trend="increases"),
    _test(_D, "§6.1.2", "communication_mb", "mann-whitney",
          "as was the increase with the number of services per agent (p<0.01)", "<0.01",
          algorithm="grape-s", factor="services_per_robot", groups=("1", "5"),
          trend="increases"),
    _test(_D, "§6.1.2", "communication_mb", "mann-whitney",
          "No other significant differences existed. Pair-GRAPE-S was equivalent", "",
          algorithm="grape-s", factor="service_types", groups=("5", "10"), significant=False),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "No other significant differences existed. Pair-GRAPE-S was equivalent", "",
          algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"), robots=500,
          significant=False),
    _fig(_D, "§6.1.2", "pair-grape-s", "communication_mb", "max", 110,
         "(i.e., <= 110 MB for 100 robot collectives, 45-110 GB with 500 robots)", "<= 110 MB",
         relation="<=", robots=100, comp="10:5"),
    _fig(_D, "§6.1.2", "pair-grape-s", "communication_mb", "min", 45000,
         "(i.e., <= 110 MB for 100 robot collectives, 45-110 GB with 500 robots)", "45-110 GB",
         relation=">=", robots=500, comp="10:5"),
    _fig(_D, "§6.1.2", "pair-grape-s", "communication_mb", "max", 110000,
         "(i.e., <= 110 MB for 100 robot collectives, 45-110 GB with 500 robots)", "45-110 GB",
         relation="<=", robots=500, comp="10:5"),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "The increase with the collective size was significant (p<0.01), but no difference "
          "across the percent tasks was found.", "<0.01", algorithm="pair-grape-s",
          factor="robots", groups=("100", "500"), percent=(10, 50), comp="10:5",
          trend="increases"),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "The increase with the collective size was significant (p<0.01), but no difference "
          "across the percent tasks was found.", "", algorithm="pair-grape-s",
          factor="percent_tasks", groups=("1", "10", "50"), robots=500, comp="10:5",
          significant=False),
    _fig(_D, "§6.1.2", "sda", "communication_mb", "max", 500,
         "All SDA trials required <500 MB.", "<500 MB", relation="<"),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "Nevertheless, the communication increased significantly from 100 to 500 robots "
          "(p<0.1)", "<0.1", algorithm="sda", factor="robots", groups=("100", "500"),
          percent=(10, 50), trend="increases",
          note="the paper calls p<0.1 significant; cfopt tests at 5 %"),
    _test(_D, "§6.1.2", "communication_mb", "kruskal",
          "as well as with the percent tasks (H (n=25) = 231.92, p<0.01)", "<0.01",
          algorithm="sda", statistic="H", value=231.92, n=25, factor="percent_tasks",
          groups=("1", "10", "50"), robots=500, trend="increases"),
    *_pairs(_D, "§6.1.2", "communication_mb", "mann-whitney",
            "All post hoc analyses were significant. Overall,",
            [("1", "10", "", True, "1"), ("1", "50", "", True, "1"), ("10", "50", "", True, "10")],
            algorithm="sda", factor="percent_tasks", groups=("1", "10", "50"), robots=500),
    _test(_D, "§6.1.2", "communication_mb", "wilcoxon",
          "Overall, SDA's communication was significantly lower than SDA's (p<0.01).", "<0.01",
          factor="algorithm", groups=("grape-s", "sda"), lowest="sda",
          note="the paper prints 'lower than SDA's'; the Wilcoxon test of §6.1 compares GRAPE-S "
          "and SDA"),
    _test(_D, "§6.1.2", "communication_mb", "friedman",
          "The algorithms' communication also differed significantly for collectives with ten "
          "service type and five services per robots (H (n=25) = 116.42, p<0.01).", "<0.01",
          statistic="chi2", value=116.42, n=25, factor="algorithm", groups=DISTRIBUTED_ALGORITHMS,
          comp="10:5", lowest="sda", direction_quote="Specifically, SDA's communication was "
          "significantly lower than GRAPE-S's (p<0.01) and Pair-GRAPE-S's (p<0.01).",
          note="the paper prints H; §6.1 says this comparison used Friedman tests"),
    *_pairs(_D, "§6.1.2", "communication_mb", "conover",
            "Specifically, SDA's communication was significantly lower than GRAPE-S's (p<0.01) "
            "and Pair-GRAPE-S's (p<0.01).", [("sda", "grape-s", "<0.01", True, "sda"),
                                             ("sda", "pair-grape-s", "<0.01", True, "sda")],
            factor="algorithm", groups=DISTRIBUTED_ALGORITHMS, comp="10:5"),
    _test(_D, "§6.1.2", "communication_mb", "conover",
          "No significant difference between GRAPE-S and Pair-GRAPE-S was identified.", "",
          factor="algorithm", groups=DISTRIBUTED_ALGORITHMS, comp="10:5",
          pair=("grape-s", "pair-grape-s"), significant=False),
]  # fmt: skip

_DISTRIBUTED_UTILITY = [
    _fig(_D, "§6.1.3", "grape-s", "optimal_trials", "count", 495,
         "GRAPE-S's produced optimal 100% utility solutions for 495 of 500 trials.",
         "100% ... 495 of 500"),
    _fig(_D, "§6.1.3", "grape-s", "percent_utility", "min", 100,
         "The five subpotimal trials all incorporated collectives with ten service types and "
         "five services per robot", "optimal", comp=("5:1", "5:5", "10:1")),
    _fig(_D, "§6.1.3", "grape-s", "percent_utility", "min", 96.7,
         "The lowest solution utility, 96.7%, was the only utility <98%", "96.7%"),
    _fig(_D, "§6.1.3", "grape-s", "percent_utility", "second lowest", 98,
         "The lowest solution utility, 96.7%, was the only utility <98%", "<98%",
         relation=">="),
    _test(_D, "§6.1.3", "percent_utility", "mann-whitney",
          "GRAPE-S's utilities decreased significantly with increased service types (p<0.01)",
          "<0.01", algorithm="grape-s", factor="service_types", groups=("5", "10"),
          trend="decreases"),
    _test(_D, "§6.1.3", "percent_utility", "mann-whitney",
          "and services per agent (p<0.01). GRAPE-S's utilities", "<0.01", algorithm="grape-s",
          factor="services_per_robot", groups=("1", "5"), trend="decreases"),
    _test(_D, "§6.1.3", "percent_utility", "kruskal",
          "GRAPE-S's utilities also differed significantly across the percent tasks (H (n=25) = "
          "364.20, p<0.01)", "<0.01", algorithm="grape-s", statistic="H", value=364.20, n=25,
          factor="percent_tasks", groups=("1", "10", "50"), robots=500),
    *_pairs(_D, "§6.1.3", "percent_utility", "mann-whitney",
            "with significant post hoc analyses (p<0.01). No significant differences were "
            "detected between 100 and 500 robots.",
            [("1", "10", "<0.01", True, ""), ("1", "50", "<0.01", True, ""),
             ("10", "50", "<0.01", True, "")],
            algorithm="grape-s", factor="percent_tasks", groups=("1", "10", "50"), robots=500),
    _test(_D, "§6.1.3", "percent_utility", "kruskal",
          "No significant differences were detected between 100 and 500 robots.", "",
          algorithm="grape-s", factor="robots", groups=("100", "500"), percent=(10, 50),
          significant=False),
    _fig(_D, "§6.1.3", "pair-grape-s", "percent_utility", "min", 100,
         "Unlike GRAPE-S, Pair-GRAPE-S produced optimal solutions for all trials.", "optimal"),
    *_table(_D, "Table 4", "§6.1.3", "grape-s", "10:5", [
        (10, 100, 100.0, 100.0, 100.0, "10 & 100 & 100.0 (100, 100.0)"),
        (10, 500, 100.0, 96.7, 100.0, "& 500 & 100.0 (96.7, 100.0)"),
        (50, 100, 100.0, 98.8, 100.0, "50& 100 & 100.0 (98.8, 100.0)"),
        (50, 500, 100.0, 99.3, 100.0, "& 500 & 100.0 (99.3, 100.0)"),
    ]),
    *_caption(_D, "Table 4", "Percent &"),
    _fig(_D, "§6.1.3", "sda", "percent_utility", "median", 5,
         "SDA's utilities with 500 robots and 50% tasks were generally even lower (i.e., <5%)",
         "<5%", relation="<", robots=500, percent=50),
    _test(_D, "§6.1.3", "percent_utility", "kruskal",
          "SDA's percent utilities decreased significantly with the collective size (p<0.01)",
          "<0.01", algorithm="sda", factor="robots", groups=("100", "500"), percent=(10, 50),
          trend="decreases"),
    _test(_D, "§6.1.3", "percent_utility", "mann-whitney",
          "and differed significantly with the number of services per robot (p<0.01). The "
          "utilities", "<0.01", algorithm="sda", factor="services_per_robot", groups=("1", "5")),
    _test(_D, "§6.1.3", "percent_utility", "kruskal",
          "The utilities also decreased significantly with the percent tasks (H (n=25) = 16.12, "
          "p<0.01).", "<0.01", algorithm="sda", statistic="H", value=16.12, n=25,
          factor="percent_tasks", groups=("1", "10", "50"), robots=500, trend="decreases"),
    *_pairs(_D, "§6.1.3", "percent_utility", "mann-whitney",
            "Specifically, there were significant differences between 1% and 10% tasks "
            "(p<0.01), as well as 1% and 50% tasks (p<0.01).",
            [("1", "10", "<0.01", True, "10"), ("1", "50", "<0.01", True, "50")],
            algorithm="sda", factor="percent_tasks", groups=("1", "10", "50"), robots=500),
    _test(_D, "§6.1.3", "percent_utility", "mann-whitney",
          "No other significant differences were detected. SDA's percent utilities.", "",
          algorithm="sda", factor="percent_tasks", groups=("1", "10", "50"), robots=500,
          pair=("10", "50"), significant=False),
    *(
        fig
        for comp, rows in (
            ("5:1", [(1, 500, 100, 73.7, 100, "5 & 1 & 1 & 500 & 100 (73.7, 100)"),
                     (10, 100, 100, 86.4, 100, "&&10 & 100 & 100 (86.4, 100)"),
                     (10, 500, 100, 58.5, 100, "& & & 500 & 100 (58.5, 100)"),
                     (50, 100, 100, 97.1, 100, "& & 50 & 100 & 100 (97.1, 100)"),
                     (50, 500, 3.9, 1.6, 8.2, "& & & 500 & 3.9 (1.6, 8.2)")]),
            ("5:5", [(1, 500, 100, 100, 100, "5 & 5 & 1 & 500 & 100 (100, 100)"),
                     (10, 100, 100, 94.1, 100, "&&10 & 100 & 100 (94.1, 100)"),
                     (10, 500, 100, 6.8, 100, "& & & 500 & 100 (6.8, 100)"),
                     (50, 100, 100, 93.5, 100, "& & 50 & 100 & 100 (93.5, 100)"),
                     (50, 500, 3.8, 0.8, 6.4, "& & & 500 & 3.8 (0.8, 6.4)")]),
            ("10:1", [(1, 500, 100, 100, 100, "10 & 1 & 1 & 500 & 100 (100, 100)"),
                      (10, 100, 100, 90.2, 100, "&&10 & 100 & 100 (90.2, 100)"),
                      (10, 500, 99.8, 14.2, 100, "& & & 500 & 99.8 (14.2, 100)"),
                      (50, 100, 100, 100, 100, "& & 50 & 100 & 100 (100, 100)"),
                      (50, 500, 3.2, 1.5, 6.4, "& & & 500 & 3.2 (1.5, 6.4)")]),
            ("10:5", [(1, 500, 100, 64.2, 100, "10 & 5 & 1 & 500 & 100 (64.2, 100)"),
                      (10, 100, 100, 63.4, 100, "&&10 & 100 & 100 (63.4, 100)"),
                      (10, 500, 100, 3.0, 100, "& & & 500 & 100 (3.0, 100)"),
                      (50, 100, 99.8, 96.5, 100, "& & 50 & 100 & 99.8 (96.5, 100)"),
                      (50, 500, 4.5, 2.4, 27.4, "& & & 500 & 4.5 (2.4, 27.4)")]),
        )
        for fig in _table(_D, "Table 5", "§6.1.3", "sda", comp, rows)
    ),
    _test(_D, "§6.1.3", "percent_utility", "wilcoxon",
          "Overall, SDA's utilities were significantly lower than GRAPE-S's (p<0.01).", "<0.01",
          factor="algorithm", groups=("grape-s", "sda"), lowest="sda"),
    _test(_D, "§6.1.3", "percent_utility", "friedman",
          "No significant difference existed when only collectives ten service types and five "
          "services per robot were considered.", "", factor="algorithm",
          groups=DISTRIBUTED_ALGORITHMS, comp="10:5", significant=False),
]  # fmt: skip

FIGURES: tuple[Figure, ...] = (
    *_CENTRALIZED_SAMPLE,
    *_CENTRALIZED_RUNTIME,
    *_CENTRALIZED_COMMUNICATION,
    *_CENTRALIZED_UTILITY,
    *_CENTRALIZED_DISCUSSION,
    *_DISTRIBUTED_SAMPLE,
    *_DISTRIBUTED_RUNTIME,
    *_DISTRIBUTED_COMMUNICATION,
    *_DISTRIBUTED_UTILITY,
)


# ------------------------------------------------------------ not figures, with reasons
_GRID = "a parameter of the seed's grid (its Tables 1 and 3), the same in cfopt.paper_grid"
_TARGET = "the viability target, a definition (cfopt's runtime table counts the runs under it)"
_AXES = "a plot's axis ticks, not a result"
_HYPOTHESIS = "a hypothesis label (H_1 to H_4)"
_COMPLEXITY = "a complexity class the paper gives no measured figure for"
_METHOD = "the subsets of the paper's tests, kept as the cells of each test figure"
_QUALITATIVE = "a qualitative statement with no figure to set beside cfopt's"

OMITTED: tuple[Omitted, ...] = (
    Omitted("(i.e., >95% utility) in near real-time (i.e., <5 min)", (95, 5), _TARGET),
    Omitted("Collectives with 100, 500, and 1000 robots were considered", (100, 500, 1000), _GRID),
    Omitted("(i.e., 1%, 10%, and 50% the collective size)", (1, 10, 50), _GRID),
    Omitted("(i.e., 100, 10, and 2 for 1%, 10%, and 50% tasks, respectively)",
            (100, 10, 2, 1, 50), "the family's mean coalition size n/m, by construction "
            "(cfopt.generate_mission)"),
    Omitted("map to 1% tasks", (1,), _GRID),
    Omitted("map to 10% tasks", (10,), _GRID),
    Omitted("map to 50%. 1% tasks (i.e., coalition size 100) was used only for collectives "
            "with >100 robots", (50, 1, 100), _GRID),
    Omitted("Collective Size & 100, 500, 1000 Percent Tasks & 1, 10, 50 Service Types: Per "
            "Robot & 5:1 , 5:5, 10:1, 10:5", (100, 500, 1000, 1, 10, 50, 5), _GRID + " (Table 1)"),
    Omitted("each task was assigned a random utility in the range [1, 50]", (1, 50),
            "the family's task utilities, the same in cfopt.generate_mission"),
    Omitted("HP Z640 Workstation (Intel Xeon processor, 62 GB RAM)", (640, 62),
            "the seed's hardware"),
    Omitted("shorter runtimes (H_1) and less communication (H_2) without substantially lower "
            "percent utilities (H_3)", (1, 2, 3), _HYPOTHESIS),
    Omitted("five services per robot (H_4)", (4,), _HYPOTHESIS),
    Omitted("The collective size analysis considered only 10%-50% tasks, and the percent task "
            "analysis considered only 500-1000 robots, as 100 robots with 1% tasks were not "
            "evaluated.", (10, 50, 500, 1000, 100, 1), _METHOD),
    Omitted("GRAPE-S's runtimes were well within the 5 min target", (5,), _TARGET),
    Omitted("consistent with GRAPE-S's O(n^2|S| m) computational complexity", (2,),
            _COMPLEXITY + " (no runtime per size is printed)"),
    Omitted("Pair-GRAPE-S's runtimes were also well within the 5 min target", (5,), _TARGET),
    Omitted("Figures and have 1 min increments, while and have 5 min increments", (1, 5), _AXES),
    Omitted("differences between the algorithms with 100 robots were negligible", (100,),
            _QUALITATIVE),
    Omitted("exceeding the 5 min threshold", (5,), _TARGET),
    Omitted("were reasonably near the 5 min target with 500 robots", (5, 500), _QUALITATIVE),
    Omitted("substantially exceeding the 5 min target", (5,), _TARGET),
    Omitted("Subfigures and have 100 MB increments. Subfigures and have 200 MB and 500 MB "
            "increments", (100, 200, 500), _AXES),
    Omitted("All algorithms with 100 robots required little communication, but had high "
            "communication requirements for certain 1000 robot trials.", (100, 1000),
            _QUALITATIVE),
    Omitted("Pair-GRAPE-S best met the near real-time target (H_1)", (1,), _HYPOTHESIS),
    Omitted("hypothesized (H_2)", (2,), _HYPOTHESIS),
    Omitted("Pair-GRAPE-S only had low communication requirements for 100 robots.", (100,),
            _QUALITATIVE),
    Omitted("comparable to the baselines (H_3)", (3,), _HYPOTHESIS),
    Omitted("The hypothesis (H_4)", (4,), _HYPOTHESIS),
    Omitted("Collective Size & 100, 500 Percent Tasks & 1, 10, 50 Service Types: Per Robot & "
            "5:1 , 5:5, 10:1, 10:5", (100, 500, 1, 10, 50, 5), _GRID + " (Table 3)"),
    Omitted("The collective sizes are reduced from 100, 500, and 1000 to only 100 and 500, due "
            "to the HPCC's inability to support 1000 robot collectives.", (100, 500, 1000),
            _GRID),
    Omitted("Mann-Whitney-Wilcoxon tests compared the numbers of service types and the services "
            "per robot (n=250)", (250,), "the paper's n of its distributed Mann-Whitney tests "
            "(each test figure carries cfopt's own n)"),
    Omitted("the collective size analysis considered only 10%-50% tasks, and the percent task "
            "analysis considered only 500 robot collectives, as 100 robots with 1% tasks was "
            "not evaluated.", (10, 50, 500, 100, 1), _METHOD),
    Omitted("This analysis considered all 500 independent variable combinations.", (500,),
            "the paper's n of its Wilcoxon tests (each test figure carries cfopt's own n)"),
    Omitted("This trend is consistent with SDA's O(mn^4u_max/epsilon_dec) computational "
            "complexity.", (4,), _COMPLEXITY),
    Omitted("SDA's results were largely consistent across the different collective compositions "
            "with the exception of the 500 robot, 10% task trials.", (500, 10), _QUALITATIVE),
    Omitted("It is also worth noting that 500 robot collectives with 50% tasks may exhibit "
            "similar trends", (500, 50), "a conjecture, not a result"),
    Omitted("however, it was substantially different for 100 robot collectives with 50% tasks, "
            "as well as 500 robot collectives with 10%-50% tasks.", (100, 50, 500, 10),
            _QUALITATIVE + " ('substantially different', of simulated seconds)"),
    Omitted("SDA's percent utilities were optimal or near-optimal for the majority of of the "
            "100 robot trials, as well as trials incorporating 500 robot collectives and 1%-10% "
            "tasks", (100, 500, 1, 10), "restates Table 5's medians (figures of Table 5)"),
    Omitted("The low worst-case utilities with 500 robots and 10% tasks may be attributed to "
            "the fact that some trials reached the time limit", (500, 10),
            "an explanation, not a result"),
    Omitted("SDA's percent utilities. Percent utilities <95% are noted in red", (95,),
            "the colour rule of Table 5"),
    Omitted("as expected (H_1)", (1,), _HYPOTHESIS),
    Omitted("both consistently met the 5 min runtime target", (5,), _TARGET),
    Omitted("was not supported (H_2)", (2,), _HYPOTHESIS),
    Omitted("comparable to SDA's (H_3)", (3,), _HYPOTHESIS),
    Omitted("preferable to GRAPE-S's (H_4)", (4,), _HYPOTHESIS),
)  # fmt: skip


# ------------------------------------------------------------------------ reading
_REPLACEMENTS = (
    (r"\%", "%"), ("$", ""), ("\\\\", " "), (r"\leq", "<="), (r"\geq", ">="), (r"\approx", "~"),
    (r"\lvert ", "|"), (r"\lvert", "|"), (r"\rvert", "|"), (r"\chi_r^2", "χ_r²"),
    (r"\epsilon", "epsilon"),
)  # fmt: skip


def plain_text(latex: str) -> str:
    """The paper's LaTeX as the plain text its quotes here are taken from.

    Comments, labels, references, citations, figure files and table layout are dropped;
    ``\\%`` is ``%``, math is unwrapped (``$\\leq$`` is ``<=``, ``$\\geq$`` ``>=``,
    ``$\\approx$`` ``~``, ``RACHNA$_{dt}$`` ``RACHNA_dt``), other commands keep only their
    text, and white space is one space.

    >>> plain_text(r"RACHNA$_{dt}$ required $>27,500$ MB \\cite{x} (\\textit{i.e.}, 27.5 GB)")
    'RACHNA_dt required >27,500 MB (i.e., 27.5 GB)'
    """
    text = "\n".join(re.sub(r"(?<!\\)%.*", "", line) for line in latex.splitlines())
    text = re.sub(r"\\(?:label|ref|cite|cline)\{[^}]*\}", "", text)
    text = re.sub(r"\\includegraphics(?:\[[^\]]*\])?\{[^}]*\}", "", text)
    text = re.sub(r"\\begin\{(?:tabular|NiceTabular)\}\{[^}]*\}", "", text)
    text = re.sub(r"\\(?:begin|end)\{[^}]*\}(?:\[[^\]]*\])?", "", text)
    text = re.sub(r"\\(?:multirow\{[^}]*\}\{[^}]*\}|textcolor\{[^}]*\})", "", text)
    for latex_, plain in _REPLACEMENTS:
        text = text.replace(latex_, plain)
    text = re.sub(r"_\{([^}]*)\}", r"_\1", text)
    text = re.sub(r"\\[A-Za-z]+\*?", "", text)
    return re.sub(r"\s+", " ", text.replace("{", "").replace("}", "")).strip()


def figures(**where: object) -> list[Figure]:
    """The figures whose fields equal the given values, in table order.

    >>> [f.statistic for f in figures(table="Table 4", robots=(500,), percent_tasks=(10.0,))]
    ['median', 'min', 'max']
    """
    fields = Figure.__dataclass_fields__
    unknown = [k for k in where if k not in fields]
    if unknown:
        raise TypeError(f"figures(): no field {unknown[0]!r}")
    return [f for f in FIGURES if all(getattr(f, k) == v for k, v in where.items())]


def _one(**where: object) -> Figure:
    (figure,) = figures(**where)
    return figure


#: The paper against itself: each pair of places, quoted, with the arithmetic.
DISAGREEMENTS: tuple[Disagreement, ...] = (
    Disagreement(
        _one(algorithm="pair-grape-s", measure="runtime_s", statistic="max", value=497.0),
        "§5.1.1",
        "Pair-GRAPE-S's <= 8 min 12 s runtimes",
        "Pair-GRAPE-S's one trial above 5 min took 8 min 17 s (497 s), above its stated "
        "maximum of 8 min 12 s (492 s) for the same 1000-robot 10:5 collectives",
    ),
    Disagreement(
        _one(measure="communication_mb", statistic="growth exponent"),
        "§5.1.2",
        "The required communication was low with 100 robots (i.e., 30 MB) ... GRAPE-S required "
        "750 MB with 500 robots, and 3,000 MB (i.e., 3 GB) with 1000 robots",
        "30, 750 and 3,000 MB at 100, 500 and 1000 robots grow as n^2: log(750/30)/log(5) = "
        "2.00 and log(3000/750)/log(2) = 2.00; O(n^3) would give 3,750 and 30,000 MB",
    ),
    Disagreement(
        _one(evaluation=_D, algorithm="grape-s", measure="percent_utility", test="kruskal",
             factor="percent_tasks"),
        "§6.1",
        "the percent task analysis considered only 500 robot collectives",
        "a Kruskal-Wallis H is at most N - 1, and the 500-robot collectives are 3 percent "
        "levels x 4 compositions x 25 = 300 trials, so H <= 299 < 364.20; moreover at most 4 "
        "of these 300 utilities are below 100 % (5 suboptimal trials of 500, one or more of "
        "them at 100 robots: Table 4), which bounds H at 8.1",
    ),
)  # fmt: skip
