"""Complexity scaling: size ladders of counted cost and log-log exponent fits.

Counting, not timing: every heuristic's :class:`heuristics.Run`
reports ``work`` (its documented unit of computation), ``rounds``, ``messages`` and
``bytes``.  These are deterministic for a mission, so a ladder of missions from the seed's
family (:func:`cfopt.generate_mission`) at growing sizes, fitted by least squares in
log-log space, measures the exponent of each count in ``n`` (tasks and service types held
in proportion), in ``m`` (``n`` and ``S`` fixed) or in ``S`` (``n`` and ``m`` fixed, each
robot having a fixed share of the services).  :data:`SEED_EXPONENTS` lists the exponents
the seed states (§3.1, §3.2, §4) for the same variables, so the fitted and the claimed
exponents can be set side by side (:func:`scaling_table`, :func:`format_scaling_table`).

The algorithms are called through the registry (``heuristics.get_algorithm``) or a
callable given by the caller; nothing of ``heuristics``' internals is used.

Examples
--------
>>> from proofs.scaling import ladder, fit_exponent
>>> rungs = ladder("grape-s", [20, 40, 80], percent_tasks=10, service_types=5,
...                services_per_robot=1, seeds=[0])
>>> [r.robots for r in rungs], [r.iterations for r in rungs]
([20, 40, 80], [20, 40, 80])
>>> fit = fit_exponent([r.robots for r in rungs], [r.messages for r in rungs])
>>> round(fit.slope, 2)          # (n + 1) rounds of n broadcasts: n (n + 1)
1.97
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cfopt import Mission, MissionError, generate_mission
from cfopt.checks import is_whole

__all__ = [
    "MEASURES",
    "SEED_EXPONENTS",
    "VARIABLES",
    "Fit",
    "Rung",
    "ScalingRow",
    "SeedExponent",
    "fit_exponent",
    "fit_rungs",
    "format_scaling_table",
    "ladder",
    "ladder_mission",
    "scaling_table",
    "seed_exponent",
    "service_ladder",
    "task_ladder",
]

#: The counted quantities a :class:`Rung` holds and a fit can be made of.
MEASURES = ("work", "rounds", "messages", "bytes")
#: The ladder variables: collective size (tasks in proportion), tasks, service types.
VARIABLES = ("n", "m", "S")

Runner = Callable[..., Any]


# ------------------------------------------------------------------------- rungs
@dataclass(frozen=True)
class Rung:
    """One run on one mission of a ladder: the mission's size and the run's counts.

    ``work`` is in the algorithm's documented unit (GRAPE-S: slot examinations; the
    auctions: cost-matrix entries of bundle selections).
    """

    algorithm: str
    robots: int
    tasks: int
    services: int
    services_per_robot: int
    percent_tasks: float
    seed: int
    work: int
    rounds: int
    iterations: int
    messages: int
    bytes: int
    percent_utility: float

    def value(self, measure: str) -> int:
        """The count named ``measure`` (one of :data:`MEASURES`)."""
        if measure not in MEASURES:
            raise ValueError(f"measure: must be one of {', '.join(MEASURES)}, got {measure!r}")
        return int(getattr(self, measure))

    def size(self, variable: str) -> int:
        """The size named ``variable``: ``"n"`` robots, ``"m"`` tasks, ``"S"`` services."""
        if variable not in VARIABLES:
            raise ValueError(f"variable: must be one of {', '.join(VARIABLES)}, got {variable!r}")
        return {"n": self.robots, "m": self.tasks, "S": self.services}[variable]


def _resolve(algorithm: str | Runner) -> tuple[str, Runner]:
    if callable(algorithm):
        return getattr(algorithm, "__name__", "custom"), algorithm
    from heuristics import get_algorithm  # the public registry

    return algorithm, get_algorithm(algorithm)


def _rung(
    name: str,
    runner: Runner,
    mission: Mission,
    *,
    percent_tasks: float,
    services_per_robot: int,
    seed: int,
) -> Rung:
    run = runner(mission, seed=seed)
    return Rung(
        algorithm=name,
        robots=mission.n_robots,
        tasks=mission.n_tasks,
        services=mission.n_services,
        services_per_robot=services_per_robot,
        percent_tasks=percent_tasks,
        seed=seed,
        work=int(run.work),
        rounds=int(run.rounds),
        iterations=int(run.iterations),
        messages=int(run.messages),
        bytes=int(run.bytes),
        percent_utility=run.assignment.percent_utility(mission),
    )


def _check_seeds(seeds: Iterable[int]) -> list[int]:
    out = list(seeds)
    if not out or not all(is_whole(s) for s in out):
        raise MissionError(f"seeds: must be a non-empty list of whole numbers, got {out!r}")
    return [int(s) for s in out]


def ladder_mission(
    robots: int,
    seed: int,
    *,
    percent_tasks: float = 10,
    service_types: int = 10,
    services_per_robot: int = 5,
    load: float = 1.0,
) -> Mission:
    """The mission :func:`ladder` runs at size ``robots`` for ``seed`` (seed ``1000 seed + n``).

    >>> ladder_mission(30, 0).n_robots
    30
    """
    return generate_mission(
        robots,
        percent_tasks,
        service_types,
        services_per_robot,
        load=load,
        seed=1000 * seed + robots,
    )


def ladder(
    algorithm: str | Runner,
    sizes: Sequence[int],
    *,
    percent_tasks: float = 10,
    service_types: int = 10,
    services_per_robot: int = 5,
    seeds: Iterable[int] = (0, 1, 2),
    load: float = 1.0,
) -> list[Rung]:
    """Run ``algorithm`` on missions of growing collective size ``n``.

    Parameters
    ----------
    algorithm : str or callable
        A registry name (``"grape-s"``, ``"pair-grape-s"``, ``"sda"``, ``"rachna-dt"``)
        or a function ``f(mission, *, seed)`` returning a run with ``work``, ``rounds``,
        ``messages``, ``bytes``, ``iterations`` and ``assignment``.
    sizes : sequence of int
        Collective sizes ``n``.  The tasks stay in proportion, ``m = round(n p / 100)``,
        and the composition ``S:k`` is fixed.
    percent_tasks, service_types, services_per_robot, load
        The seed's family parameters (:func:`cfopt.generate_mission`).
    seeds : iterable of int
        One mission (and one run, with that seed) per seed and size; the mission seed is
        ``1000 * seed + n`` so every rung draws fresh missions.

    Returns
    -------
    list of Rung
        Size-major, seed-minor.

    Notes
    -----
    Cost: one run per (size, seed); the counts are exact integers, deterministic for the
    arguments.
    """
    name, runner = _resolve(algorithm)
    seeds = _check_seeds(seeds)
    return [
        _rung(
            name,
            runner,
            ladder_mission(
                n,
                s,
                percent_tasks=percent_tasks,
                service_types=service_types,
                services_per_robot=services_per_robot,
                load=load,
            ),
            percent_tasks=percent_tasks,
            services_per_robot=services_per_robot,
            seed=s,
        )
        for n in sizes
        for s in seeds
    ]


def task_ladder(
    algorithm: str | Runner,
    percents: Sequence[float],
    *,
    robots: int = 200,
    service_types: int = 5,
    services_per_robot: int = 5,
    seeds: Iterable[int] = (0, 1, 2),
    load: float = 1.0,
) -> list[Rung]:
    """Run ``algorithm`` with ``n`` and ``S`` fixed and the number of tasks growing.

    ``percents`` are the seed's *percent tasks*: ``m = round(n p / 100)``.  The mean
    coalition size ``n / m`` falls as ``m`` grows.  The default composition 5:5
    (homogeneous) keeps every task's slots available to every robot.
    """
    name, runner = _resolve(algorithm)
    seeds = _check_seeds(seeds)
    return [
        _rung(
            name,
            runner,
            generate_mission(
                robots, p, service_types, services_per_robot, load=load, seed=1000 * s + 7
            ),
            percent_tasks=p,
            services_per_robot=services_per_robot,
            seed=s,
        )
        for p in percents
        for s in seeds
    ]


def service_ladder(
    algorithm: str | Runner,
    service_types: Sequence[int],
    *,
    robots: int = 200,
    percent_tasks: float = 5,
    share: float = 0.5,
    seeds: Iterable[int] = (0, 1, 2),
    load: float = 1.0,
) -> list[Rung]:
    """Run ``algorithm`` with ``n`` and ``m`` fixed and the number of service types growing.

    Each robot has ``k = max(1, round(share * S))`` services, a fixed share of the types
    (with ``k`` fixed instead, a robot's options would not grow with ``S``).  The default
    coalitions (5 % tasks: 20 robots each) are large enough that tasks need most types.
    """
    name, runner = _resolve(algorithm)
    seeds = _check_seeds(seeds)
    if not 0 < share <= 1:
        raise MissionError(f"share: must be in (0, 1], got {share!r}")
    out = []
    for S in service_types:
        k = max(1, min(S, math.floor(share * S + 0.5)))
        for s in seeds:
            mission = generate_mission(robots, percent_tasks, S, k, load=load, seed=1000 * s + S)
            out.append(
                _rung(
                    name,
                    runner,
                    mission,
                    percent_tasks=percent_tasks,
                    services_per_robot=k,
                    seed=s,
                )
            )
    return out


# -------------------------------------------------------------------------- fits
@dataclass(frozen=True)
class Fit:
    """A least-squares line ``log y = slope log x + intercept`` and its slope's interval.

    ``ci_low``/``ci_high`` bound the slope at ``confidence`` (Student t with ``points - 2``
    degrees of freedom on the regression's standard error); ``r2`` is the coefficient of
    determination.
    """

    slope: float
    intercept: float
    ci_low: float
    ci_high: float
    r2: float
    points: int
    confidence: float = 0.95

    def __str__(self) -> str:
        return f"{self.slope:.2f} [{self.ci_low:.2f}, {self.ci_high:.2f}]"


def fit_exponent(xs: Sequence[float], ys: Sequence[float], *, confidence: float = 0.95) -> Fit:
    """Fit ``y ~ C x^slope`` by least squares on ``(log x, log y)``.

    Parameters
    ----------
    xs, ys : sequences of positive numbers, same length
        Sizes and counts; at least three points and two distinct sizes.
    confidence : float, default 0.95
        Level of the slope's confidence interval.

    Returns
    -------
    Fit

    Notes
    -----
    ``scipy.stats.linregress`` gives the slope and its standard error; the interval is
    ``slope +- t_{(1 + confidence) / 2, points - 2} * stderr``.  O(points).

    Examples
    --------
    >>> fit = fit_exponent([10, 20, 40, 80], [3 * x**2 for x in [10, 20, 40, 80]])
    >>> round(fit.slope, 6), round(fit.r2, 6), round(fit.ci_low, 6), round(fit.ci_high, 6)
    (2.0, 1.0, 2.0, 2.0)
    """
    from scipy import stats

    x = np.asarray(xs, dtype=float)
    y = np.asarray(ys, dtype=float)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(
            f"xs and ys: must be two flat sequences of one length, got {x.shape} and {y.shape}"
        )
    if x.size < 3 or np.unique(x).size < 2:
        raise ValueError("xs: need at least three points and two distinct sizes to fit")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y)) and (x > 0).all() and (y > 0).all()):
        raise ValueError("xs and ys: every value must be finite and > 0 to take logarithms")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: must be in (0, 1), got {confidence!r}")
    lx, ly = np.log(x), np.log(y)
    if np.ptp(ly) == 0:  # constant counts: slope exactly 0
        return Fit(0.0, float(ly[0]), 0.0, 0.0, 1.0, int(x.size), confidence)
    res = stats.linregress(lx, ly)
    half = float(stats.t.ppf((1 + confidence) / 2, x.size - 2)) * float(res.stderr)
    slope = float(res.slope)
    return Fit(
        slope=slope,
        intercept=float(res.intercept),
        ci_low=slope - half,
        ci_high=slope + half,
        r2=float(res.rvalue) ** 2,
        points=int(x.size),
        confidence=confidence,
    )


# ---------------------------------------------------------- the seed's exponents
@dataclass(frozen=True)
class SeedExponent:
    """An exponent the seed states for ``measure`` of ``algorithm`` in ``variable``.

    ``exponent`` is read off the seed's O(...) bound with the other sizes held as the
    ladder holds them (``n`` ladders keep ``m`` proportional to ``n``; ``u_max = 50``,
    ``eps`` and ``d_G = 1`` are constants); ``bound`` quotes the seed and ``where`` gives
    the section.  Bounds are upper bounds: a fitted exponent below is consistent with
    them.
    """

    algorithm: str
    measure: str
    variable: str
    exponent: float
    bound: str
    where: str


def _seed_exponents() -> tuple[SeedExponent, ...]:
    rows = []
    grape = "O(n^2 |S| m d_G)"
    for algo, where in (("grape-s", "§3.2 (Eq. 4.2)"), ("pair-grape-s", "§4.1")):
        rows += [
            SeedExponent(algo, "work", "n", 3, grape, where),
            SeedExponent(algo, "work", "m", 1, grape, where),
            SeedExponent(algo, "work", "S", 1, grape, where),
            SeedExponent(algo, "messages", "n", 3, "O(n^3 d_G)", where),
        ]
    rows += [
        SeedExponent("sda", "work", "n", 5, "O(m n^4 u_max / eps_d)", "§3.1"),
        SeedExponent("sda", "work", "m", 1, "O(m n^4 u_max / eps_d)", "§3.1"),
        SeedExponent("sda", "messages", "n", 1, "O((m + n) |S| u_max / eps_d)", "§3.1"),
        SeedExponent("sda", "messages", "S", 1, "O((m + n) |S| u_max / eps_d)", "§3.1"),
        SeedExponent("rachna-dt", "work", "n", 4, "O(m n^3 log n u_max)", "§3.1"),
        SeedExponent("rachna-dt", "work", "m", 1, "O(m n^3 log n u_max)", "§3.1"),
        SeedExponent("rachna-dt", "messages", "n", 4, "O(n^3 m |S| u_max)", "§3.1"),
        SeedExponent("rachna-dt", "messages", "m", 1, "O(n^3 m |S| u_max)", "§3.1"),
        SeedExponent("rachna-dt", "messages", "S", 1, "O(n^3 m |S| u_max)", "§3.1"),
    ]
    return tuple(rows)


#: What the seed states, per (algorithm, measure, variable).
SEED_EXPONENTS: tuple[SeedExponent, ...] = _seed_exponents()


def seed_exponent(algorithm: str, measure: str, variable: str) -> SeedExponent | None:
    """The seed's exponent for this combination, or ``None`` when the seed states none.

    >>> seed_exponent("grape-s", "work", "n").exponent
    3
    >>> seed_exponent("grape-s", "bytes", "n") is None
    True
    """
    for row in SEED_EXPONENTS:
        if (row.algorithm, row.measure, row.variable) == (algorithm, measure, variable):
            return row
    return None


# ------------------------------------------------------------------------ tables
@dataclass(frozen=True)
class ScalingRow:
    """A fitted exponent of ``measure`` in ``variable`` and the seed's, if any."""

    algorithm: str
    measure: str
    variable: str
    fit: Fit
    seed: SeedExponent | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the fit's numbers and the seed's exponent and bound."""
        return {
            "algorithm": self.algorithm,
            "measure": self.measure,
            "variable": self.variable,
            "slope": self.fit.slope,
            "ci_low": self.fit.ci_low,
            "ci_high": self.fit.ci_high,
            "r2": self.fit.r2,
            "points": self.fit.points,
            "seed_exponent": None if self.seed is None else self.seed.exponent,
            "seed_bound": None if self.seed is None else self.seed.bound,
        }


def fit_rungs(rungs: Sequence[Rung], measure: str, variable: str) -> Fit:
    """Fit ``measure`` against ``variable`` over ``rungs`` (every rung one point).

    Rungs whose count is 0 (e.g. no messages) are left out: a zero has no logarithm.
    """
    points = [(r.size(variable), r.value(measure)) for r in rungs if r.value(measure) > 0]
    return fit_exponent([p[0] for p in points], [p[1] for p in points])


_N_SIZES = (25, 50, 100, 200, 400)
_SDA_SIZES = (25, 50, 100, 200)


def scaling_table(
    algorithms: Iterable[str] = ("grape-s", "pair-grape-s", "sda", "rachna-dt"),
    *,
    seeds: Iterable[int] = (0, 1, 2),
    measures: Iterable[str] = MEASURES,
) -> list[ScalingRow]:
    """Fitted exponents of every measure in ``n``, ``m`` and ``S`` for each algorithm.

    Ladders: ``n`` in 25..400 (SDA: ..200) at 10 % tasks and 10:5; ``m`` at n = 200,
    5:5, percent tasks 2.5..40 (``m`` = 5..80); ``S`` at n = 200, 5 % tasks, S = 2..16
    with half the types per robot.  A few seconds per algorithm.
    """
    seeds = _check_seeds(seeds)
    measures = list(measures)
    rows = []
    for algo in algorithms:
        ladders = {
            "n": ladder(algo, _SDA_SIZES if algo == "sda" else _N_SIZES, seeds=seeds),
            "m": task_ladder(algo, (2.5, 5, 10, 20, 40), seeds=seeds),
            "S": service_ladder(algo, (2, 4, 8, 16), seeds=seeds),
        }
        for variable, rungs in ladders.items():
            for measure in measures:
                fit = fit_rungs(rungs, measure, variable)
                rows.append(
                    ScalingRow(algo, measure, variable, fit, seed_exponent(algo, measure, variable))
                )
    return rows


def format_scaling_table(rows: Sequence[ScalingRow]) -> str:
    """A plain-text table: algorithm, measure, variable, fitted exponent [CI], seed's.

    >>> f = fit_exponent([1, 2, 4], [1, 4, 16])
    >>> print(format_scaling_table([ScalingRow("grape-s", "work", "n", f, None)]))
    algorithm  measure  in  fitted [95% CI]     r2     seed
    grape-s    work     n   2.00 [2.00, 2.00]   1.000  -
    """
    header = ("algorithm", "measure", "in", "fitted [95% CI]", "r2", "seed")
    body = [
        (
            r.algorithm,
            r.measure,
            r.variable,
            str(r.fit),
            f"{r.fit.r2:.3f}",
            "-" if r.seed is None else f"{r.seed.exponent:g}  {r.seed.bound} ({r.seed.where})",
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]
    lines = [
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in [header, *body]
    ]
    return "\n".join(lines)
