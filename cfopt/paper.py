"""The seed paper's published figures, as data: what ``cfopt reproduce`` sets cfopt's beside.

Diehl and Adams, "GRAPE-S: Near Real-Time Coalition Formation for Multiple Service
Collectives".  Every figure the paper states in its text or tables is one :class:`Figure`:
where it stands (section and table), which algorithm, which cells of the grid it covers
(``None``: every value of that variable), what is measured, the statistic, the value
as printed and its unit, and the sentence it comes from.  Numbers are transcribed once,
here; the report code only reads this table.

The paper's grids (its Tables 1 and 3): centralized -- 100, 500 and 1000 robots; 1, 10
and 50 % tasks (1 % only above 100 robots); compositions 5:1, 5:5, 10:1 and 10:5; 25
missions per cell (800 trials per algorithm; Pair-GRAPE-S only 10:5, 200 trials);
distributed -- 100 and 500 robots, the same otherwise (500 trials per algorithm).

Examples
--------
>>> len(FIGURES) > 40
True
>>> [f.value for f in figures(table="Table 2", percent_tasks=10.0, statistic="min")]
[89.68, 98.47, 100.0]
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "CENTRALIZED_ALGORITHMS",
    "COMMUNICATION_ALGORITHM",
    "DISTRIBUTED_ALGORITHMS",
    "FIGURES",
    "GRAPE_S_ALGORITHMS",
    "PAIRWISE_ALGORITHM",
    "Figure",
    "figures",
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


@dataclass(frozen=True)
class Figure:
    """One published figure of the seed paper.

    Attributes
    ----------
    evaluation : {"centralized", "distributed"}
    section : str
        Where it stands, e.g. ``"§5.1.3"``.
    table : str
        ``"Table 2"`` (centralized GRAPE-S utilities), ``"Table 3"`` (distributed GRAPE-S
        utilities), ``"Table 4"`` (distributed SDA utilities), or ``"text"``.
    algorithm : str
        Registry name (``"grape-s"``...), or ``"all"``.
    measure : str
        ``"percent_utility"``, ``"runtime_s"``, ``"communication_mb"``, ``"trials"``,
        ``"iterations"``, ``"pairwise_step_ran"``, or a statistic of a test
        (``"friedman_chi2"``, ``"kruskal_h"``).
    statistic : str
        ``"median"``, ``"min"``, ``"max"``, ``"upper bound"`` (the paper says "<"),
        ``"lower bound"`` (">"), ``"count"``, ``"value"``.
    value : float
    robots, percent_tasks, service_types, services_per_robot : int, float or None
        The cells it covers (``None``: all of them).
    quote : str
        The paper's words, shortened.
    """

    evaluation: str
    section: str
    table: str
    algorithm: str
    measure: str
    statistic: str
    value: float
    robots: int | None = None
    percent_tasks: float | None = None
    service_types: int | None = None
    services_per_robot: int | None = None
    quote: str = ""


def _table(
    evaluation: str,
    table: str,
    section: str,
    algorithm: str,
    s: int,
    k: int,
    rows: list[tuple[float, int, float, float, float]],
    quote: str,
) -> list[Figure]:
    out = []
    for p, n, median, low, high in rows:
        for statistic, value in (("median", median), ("min", low), ("max", high)):
            cells = {"robots": n, "percent_tasks": p, "service_types": s, "services_per_robot": k}
            out.append(
                Figure(
                    evaluation,
                    section,
                    table,
                    algorithm,
                    "percent_utility",
                    statistic,
                    value,
                    quote=quote,
                    **cells,
                )
            )
    return out


_C, _D = "centralized", "distributed"

FIGURES: tuple[Figure, ...] = (
    # ---------------------------------------------------------------- centralized: trials
    Figure(_C, "§5.1", "text", "all", "trials", "count", 800, quote="800 trials per algorithm"),
    Figure(_C, "§5.1", "text", "pair-grape-s", "trials", "count", 200, None, None, 10, 5,
           "all of its 200 ten service types/five services per robot trials"),
    Figure(_C, "§5.1", "text", "pair-grape-s", "pairwise_step_ran", "count", 111, None, None,
           10, 5, "The pairwise stability step ran during 111 trials"),
    # iterations
    Figure(_C, "§5.1.1", "text", "grape-s", "iterations", "value", 1.0, quote=(
        "All other collective compositions [than 10:5] required exactly n iterations "
        "(value: iterations / n)")),
    # runtime (seconds)
    Figure(_C, "§5.1.1", "text", "grape-s", "runtime_s", "median", 322, 1000, 50, 10, 5,
           "1000 robot collectives with 50% tasks, ten service types, five services per robot "
           "(median 5 min 22 s)"),
    Figure(_C, "§5.1.1", "text", "grape-s", "runtime_s", "max", 735, quote=(
        "The maximum runtime was 12 min 15 s")),
    Figure(_C, "§5.1.1", "text", "pair-grape-s", "runtime_s", "max", 497, 1000, 50, 10, 5,
           "The only trial that exceeded 5 min ... required 8 min 17 s"),
    Figure(_C, "§5.1.1", "text", "sda", "runtime_s", "upper bound", 480, None, None, 5, 1,
           "SDA's runtimes for these variable values were <8 min"),
    Figure(_C, "§5.1.1", "text", "sda", "runtime_s", "lower bound", 1200, 1000, None, 5, 5,
           "SDA's 20-30 min runtimes [1000 robots, 5:5]"),
    Figure(_C, "§5.1.1", "text", "rachna-dt", "runtime_s", "upper bound", 330, None, 1, 5, 5,
           "RACHNA_dt's runtimes were <5.5 min with 1% tasks"),
    Figure(_C, "§5.1.1", "text", "rachna-dt", "runtime_s", "lower bound", 2700, None, 10, 5, 5,
           "increased to 45-55 min with 10% tasks"),
    Figure(_C, "§5.1.1", "text", "rachna-dt", "runtime_s", "lower bound", 7200, None, 50, 5, 5,
           "and were >2 hours with 50% tasks"),
    # communication (MB)
    *(
        Figure(_C, "§5.1.2", "text", "grape-s", "communication_mb", "value", mb, n, None, s, k,
               f"GRAPE-S required {mb:g} MB with {n} robots [5:1, 5:5, 10:1]")
        for n, mb in ((100, 30), (500, 750), (1000, 3000))
        for s, k in ((5, 1), (5, 5), (10, 1))
    ),
    Figure(_C, "§5.1.2", "text", "grape-s", "communication_mb", "lower bound", 10000, None, None,
           10, 5, "much higher worst case communication (i.e., >10,000 MB, 10 GB)"),
    Figure(_C, "§5.1.2", "text", "sda", "communication_mb", "upper bound", 500, None, None, 5, 1,
           "SDA required <500 MB communication for all trials"),
    Figure(_C, "§5.1.2", "text", "sda", "communication_mb", "upper bound", 550, None, None, 5, 5,
           "SDA required <550 MB for all trials"),
    Figure(_C, "§5.1.2", "text", "sda", "communication_mb", "lower bound", 650, None, None, 10, 5,
           "with a >650 MB worst-case communication requirement"),
    Figure(_C, "§5.1.2", "text", "rachna-dt", "communication_mb", "lower bound", 27500, None,
           None, 10, 5, "RACHNA_dt required >27,500 MB (i.e., 27.5 GB) in the worst-case"),
    Figure(_C, "§5.1.2", "text", "rachna-dt", "communication_mb", "lower bound", 6800, 500, 50,
           5, 5, "(i.e., >6,800 MB, 6.8 GB) [500 robots, 50% tasks, 5:5]"),
    # utility: Table 2 and text
    *_table(_C, "Table 2", "§5.1.3", "grape-s", 10, 5, [
        (10, 100, 100.0, 89.68, 100.0),
        (10, 500, 100.0, 98.47, 100.0),
        (10, 1000, 100.0, 100.0, 100.0),
        (50, 100, 100.0, 96.59, 100.0),
        (50, 500, 100.0, 99.66, 100.0),
        (50, 1000, 100.0, 99.69, 100.0),
    ], "GRAPE-S's percent utility statistics with ten service types and five services per robot"),
    Figure(_C, "§5.1.3", "text", "grape-s", "percent_utility", "min", 100.0, None, None, 5, 1,
           "GRAPE-S produced optimal solutions with five services and one service per robot"),
    Figure(_C, "§5.1.3", "text", "grape-s", "percent_utility", "min", 100.0, None, None, 5, 5,
           "[optimal] five services and five services per robot"),
    Figure(_C, "§5.1.3", "text", "grape-s", "percent_utility", "min", 100.0, None, None, 10, 1,
           "[optimal] ten services and one service per robot"),
    Figure(_C, "§5.1.3", "text", "pair-grape-s", "percent_utility", "min", 100.0, None, None,
           10, 5, "Pair-GRAPE-S produced optimal solutions for all problems"),
    Figure(_C, "§5.1.3", "text", "rachna-dt", "percent_utility", "min", 100.0, quote=(
        "RACHNA_dt ... producing optimal solutions for all trials")),
    Figure(_C, "§5.1.3", "text", "sda", "percent_utility", "median", 99.99, 100, 50, 10, 5,
           "99.99% median, min. = 99.87%, max. = 100.0%"),
    Figure(_C, "§5.1.3", "text", "sda", "percent_utility", "min", 99.87, 100, 50, 10, 5,
           "99.99% median, min. = 99.87%, max. = 100.0%"),
    # statistics
    Figure(_C, "§5.1.1", "text", "all", "friedman_chi2_runtime", "value", 484.15, None, None,
           10, 5, "chi_r^2 (n=200) = 484.15 [GRAPE-S, Pair-GRAPE-S, SDA, RACHNA_dt]"),
    Figure(_C, "§5.1.1", "text", "all", "friedman_chi2_runtime", "value", 913.24, quote=(
        "chi_r^2 (n=800) = 913.24 [GRAPE-S, SDA, RACHNA_dt, all compositions]")),
    Figure(_C, "§5.1.2", "text", "all", "friedman_chi2_communication", "value", 399.34, None,
           None, 10, 5, "chi_r^2 (n=200) = 399.34"),
    Figure(_C, "§5.1.2", "text", "all", "friedman_chi2_communication", "value", 1186.8,
           quote="chi_r^2 (n=800) = 1186.8"),
    Figure(_C, "§5.1.3", "text", "all", "friedman_chi2_utility", "value", 39.00, None, None,
           10, 5, "chi_r^2 (n=200) = 39.00"),
    Figure(_C, "§5.1.3", "text", "all", "friedman_chi2_utility", "value", 17.63,
           quote="chi_r^2 (n=800) = 17.63"),
    Figure(_C, "§5.1.1", "text", "grape-s", "kruskal_h_runtime_robots", "value", 523.03,
           quote="H (n=200) = 523.03 [collective size]"),
    Figure(_C, "§5.1.1", "text", "grape-s", "kruskal_h_runtime_percent_tasks", "value", 271.95,
           quote="H (n=200) = 271.95 [percent tasks]"),
    Figure(_C, "§5.1.2", "text", "grape-s", "kruskal_h_communication_robots", "value", 566.54,
           quote="H (n=200) = 566.54 [collective size]"),
    Figure(_C, "§5.1.3", "text", "grape-s", "kruskal_h_utility_percent_tasks", "value", 7.19,
           quote="H (n=200) = 7.19, p=0.03 [percent tasks]"),
    # ---------------------------------------------------------------- distributed
    Figure(_D, "§6", "text", "all", "trials", "count", 500, quote="500 trials per algorithm"),
    Figure(_D, "§6.1", "text", "pair-grape-s", "pairwise_step_ran", "count", 80, None, None, 10,
           5, "the required pairwise stability step in 80 trials [of 125]"),
    Figure(_D, "§6.1.1", "text", "grape-s", "runtime_s", "max", 262, 500, 50, 10, 5,
           "4 min 22 s with ten service, five services per robot, 500 robots, and 50% tasks"),
    Figure(_D, "§6.1.1", "text", "grape-s", "runtime_s", "upper bound", 180, quote=(
        "the other 496 trials completing in <3 min")),
    Figure(_D, "§6.1.1", "text", "pair-grape-s", "runtime_s", "max", 213, quote=(
        "The longest runtime was only 3 min 33 s")),
    Figure(_D, "§6.1.1", "text", "sda", "runtime_s", "lower bound", 2100, 100, 50, quote=(
        "100 robot collectives with 50% tasks required 35-57 min")),
    Figure(_D, "§6.1.1", "text", "sda", "runtime_s", "lower bound", 1500, 500, 10, quote=(
        "500 robots with 10% tasks required >=25 min and sometimes exceeded the one hour "
        "limit")),
    Figure(_D, "§6.1.2", "text", "grape-s", "communication_mb", "upper bound", 100, 100,
           quote="reasonable for 100 robot collectives (i.e., <100 MB in total)"),
    Figure(_D, "§6.1.2", "text", "grape-s", "communication_mb", "lower bound", 50000, 500,
           quote="as much as 50-120 GB of communication for 500 robot collectives"),
    Figure(_D, "§6.1.2", "text", "grape-s", "communication_mb", "max", 120000, 500,
           quote="as much as 50-120 GB of communication for 500 robot collectives"),
    Figure(_D, "§6.1.2", "text", "sda", "communication_mb", "upper bound", 500,
           quote="All SDA trials required <500 MB"),
    Figure(_D, "§6.1.3", "text", "grape-s", "optimal_trials", "count", 495, quote=(
        "GRAPE-S's produced optimal 100% utility solutions for 495 of 500 trials")),
    Figure(_D, "§6.1.3", "text", "pair-grape-s", "percent_utility", "min", 100.0, quote=(
        "Pair-GRAPE-S produced optimal solutions for all trials")),
    *_table(_D, "Table 3", "§6.1.3", "grape-s", 10, 5, [
        (10, 100, 100.0, 100.0, 100.0),
        (10, 500, 100.0, 96.7, 100.0),
        (50, 100, 100.0, 98.8, 100.0),
        (50, 500, 100.0, 99.3, 100.0),
    ], "GRAPE-S's percent utility statistics with ten service types and five services per robot"),
    *_table(_D, "Table 4", "§6.1.3", "sda", 5, 1, [
        (1, 500, 100, 73.7, 100), (10, 100, 100, 86.4, 100), (10, 500, 100, 58.5, 100),
        (50, 100, 100, 97.1, 100), (50, 500, 3.9, 1.6, 8.2),
    ], "SDA's percent utilities"),
    *_table(_D, "Table 4", "§6.1.3", "sda", 5, 5, [
        (1, 500, 100, 100, 100), (10, 100, 100, 94.1, 100), (10, 500, 100, 6.8, 100),
        (50, 100, 100, 93.5, 100), (50, 500, 3.8, 0.8, 6.4),
    ], "SDA's percent utilities"),
    *_table(_D, "Table 4", "§6.1.3", "sda", 10, 1, [
        (1, 500, 100, 100, 100), (10, 100, 100, 90.2, 100), (10, 500, 99.8, 14.2, 100),
        (50, 100, 100, 100, 100), (50, 500, 3.2, 1.5, 6.4),
    ], "SDA's percent utilities"),
    *_table(_D, "Table 4", "§6.1.3", "sda", 10, 5, [
        (1, 500, 100, 64.2, 100), (10, 100, 100, 63.4, 100), (10, 500, 100, 3.0, 100),
        (50, 100, 99.8, 96.5, 100), (50, 500, 4.5, 2.4, 27.4),
    ], "SDA's percent utilities"),
)  # fmt: skip


def figures(**where: object) -> list[Figure]:
    """The figures whose fields equal the given values, in table order.

    >>> [f.statistic for f in figures(table="Table 3", robots=500, percent_tasks=10.0)]
    ['median', 'min', 'max']
    """
    fields = Figure.__dataclass_fields__
    unknown = [k for k in where if k not in fields]
    if unknown:
        raise TypeError(f"figures(): no field {unknown[0]!r}")
    return [f for f in FIGURES if all(getattr(f, k) == v for k, v in where.items())]
