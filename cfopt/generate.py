"""The seed's instance family: random missions that are achievable by construction.

The seed paper (its §5, "Centralized Evaluation") draws collectives of ``n`` robots with
``S`` service types and ``k`` services per robot, ``m`` tasks (1, 10 or 50 percent of
``n``), utilities uniform in 1..50, and missions that "required exactly the number of
robots in the collective".  :func:`generate_mission` builds that family (and over- and
under-subscribed variants); :func:`paper_grid` lists the seed's 32 cells.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt._limits import require_memory
from cfopt.assignment import Assignment
from cfopt.checks import SeedLike, require_int, require_number, require_seed
from cfopt.errors import describe, parameter_error, plural
from cfopt.mission import MAX_COUNT, Mission

__all__ = [
    "PAPER_MISSIONS_PER_CELL",
    "SEED_NETWORK",
    "GridCell",
    "generate_mission",
    "generate_with_witness",
    "paper_distributed_grid",
    "paper_grid",
    "task_count",
]

PAPER_MISSIONS_PER_CELL = 25
_UTILITY_RANGE = (1, 50)


def task_count(robots: int, percent_tasks: float) -> int:
    """``m = max(1, round(n p / 100))``, rounding halves up.

    >>> task_count(100, 1), task_count(1000, 50), task_count(30, 5)
    (1, 500, 2)
    """
    return max(1, math.floor(robots * percent_tasks / 100 + 0.5))


def generate_mission(
    robots: int,
    percent_tasks: float,
    service_types: int,
    services_per_robot: int,
    load: float = 1.0,
    seed: SeedLike = None,
) -> Mission:
    """A random mission from the seed's family.

    Parameters
    ----------
    robots : int
        Collective size ``n >= 1``.
    percent_tasks : float
        Tasks as a percentage of ``n`` (0 < p <= 100); ``m = max(1, round(n p / 100))``.
    service_types : int
        Number of service types ``S >= 1``.
    services_per_robot : int
        Distinct services each robot gets, ``1 <= k <= S``, drawn uniformly.
    load : float, default 1.0
        Total requirement over ``n``.  ``1.0`` is the seed's *achievable mission*: the
        tasks need exactly ``n`` robots and a complete assignment exists.  ``load > 1``
        over-subscribes (total requirement ``round(load n)``: not every task can be
        done); ``load < 1`` leaves ``n - round(load n)`` robots spare (still achievable).
    seed : None, int or numpy.random.Generator
        Every random choice flows from ``numpy.random.default_rng(seed)``.  With
        ``None`` a fresh integer seed is drawn and recorded in the metadata, so every
        mission can be regenerated.

    Returns
    -------
    Mission
        Robots ``r0..``, tasks ``t0..``, services ``s0..``; the parameters are kept in
        ``metadata["generator"]``.

    Notes
    -----
    Construction: each robot draws ``k`` services; ``min(n, round(load n))`` robots
    chosen at random are cut into ``m`` non-empty groups of random sizes (random cut
    points), each of those robots picks one of its services uniformly, and a group's
    service counts become its task's requirements.  For ``load > 1`` the missing
    ``round(load n) - n`` units are added one at a time to a uniformly drawn task, on a
    service that task already requires (drawn uniformly).  Utilities are integers
    drawn uniformly from 1..50.  O(n S + m S) time.

    Same arguments and an integer seed give the same mission, byte for byte, on every
    machine (numpy's PCG64 stream).

    Examples
    --------
    >>> m = generate_mission(robots=100, percent_tasks=10, service_types=10,
    ...                      services_per_robot=5, seed=0)
    >>> m.n_robots, m.n_tasks, int(m.requirements.sum()), int(m.capabilities.sum(axis=1).max())
    (100, 10, 100, 5)
    """
    mission, _ = generate_with_witness(
        robots, percent_tasks, service_types, services_per_robot, load=load, seed=seed
    )
    return mission


def generate_with_witness(
    robots: int,
    percent_tasks: float,
    service_types: int,
    services_per_robot: int,
    load: float = 1.0,
    seed: SeedLike = None,
) -> tuple[Mission, Assignment]:
    """:func:`generate_mission` plus the construction's own assignment.

    The witness puts every robot of the construction in the slot it was built for.  At
    ``load <= 1`` it completes every task (a proof that the mission is achievable); at
    ``load > 1`` it is valid but leaves the over-subscribed tasks short.

    >>> m, w = generate_with_witness(50, 10, 5, 2, seed=3)
    >>> w.percent_utility(m)
    100.0
    """
    n, p, s, k, load = _check_parameters(
        robots, percent_tasks, service_types, services_per_robot, load
    )
    m = task_count(n, p)
    total = math.floor(load * n + 0.5)
    require_seed("seed", seed)
    if seed is None:  # draw a fresh seed, but record it so the mission can be replayed
        seed = int(np.random.default_rng().integers(2**32))
    rng = np.random.default_rng(seed)
    ranked = np.argsort(rng.random((n, s)), axis=1, kind="stable")[:, :k]
    capabilities = np.zeros((n, s), dtype=bool)
    np.put_along_axis(capabilities, ranked, True, axis=1)
    utilities = rng.integers(_UTILITY_RANGE[0], _UTILITY_RANGE[1] + 1, size=m).astype(float)

    builders = rng.permutation(n)[: min(n, total)]
    group = _random_groups(rng, len(builders), m)
    picked = ranked[builders, rng.integers(0, k, size=len(builders))]
    requirements = np.zeros((m, s), dtype=np.int64)
    np.add.at(requirements, (group, picked), 1)
    if total > n:
        _oversubscribe(rng, requirements, total - n)

    task = np.full(n, -1, dtype=np.int64)
    service = np.full(n, -1, dtype=np.int64)
    task[builders], service[builders] = group, picked
    mission = Mission.from_arrays(
        capabilities,
        requirements,
        utilities,
        name=f"seed family n={n} p={p:g} S:k={s}:{k} load={load:g} seed={_seed_label(seed)}",
        metadata={"generator": _generator_record(n, p, s, k, load, seed)},
    )
    return mission, Assignment(task=task, service=service)


def _random_groups(rng: np.random.Generator, size: int, groups: int) -> npt.NDArray[np.int64]:
    """Group labels 0..groups-1 for ``size`` consecutive items, every group non-empty."""
    cuts = np.zeros(size, dtype=np.int64)
    if groups > 1:
        cuts[np.sort(rng.choice(size - 1, groups - 1, replace=False)) + 1] = 1
    return np.cumsum(cuts)


def _oversubscribe(
    rng: np.random.Generator, requirements: npt.NDArray[np.int64], extra: int
) -> None:
    per_task = np.bincount(
        rng.integers(0, requirements.shape[0], size=extra), minlength=requirements.shape[0]
    )
    for j in np.flatnonzero(per_task):
        needed = np.flatnonzero(requirements[j])
        np.add.at(requirements[j], rng.choice(needed, size=per_task[j]), 1)


def _whole(value: Any, name: str, low: int, high: int | None = None) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)  # a grid file's 100.0 (or 1e22, refused below) is a whole number
    return require_int(name, value, minimum=low, maximum=high, flag=True)


#: Bytes the generator and the mission it returns take per robot and service type, per
#: robot, per task and service type, and per unit of over-subscription (a measured
#: upper bound: random keys, their argsort, the capability matrix, the JSON text).
_BYTES_PER_ROBOT_SERVICE, _BYTES_PER_ROBOT = 24, 600
_BYTES_PER_TASK_SERVICE, _BYTES_PER_EXTRA_UNIT = 40, 16


def _check_size(n: int, m: int, s: int, total: int) -> None:
    """Refuse, before drawing anything, a mission that cannot fit in memory."""
    needed = (
        _BYTES_PER_ROBOT_SERVICE * n * s + _BYTES_PER_ROBOT * n + _BYTES_PER_TASK_SERVICE * m * s
    )
    what = f"{_count_text(n)} robots, {_count_text(m)} tasks and {_count_text(s)} service types"
    larger = "service_types" if s > n else "robots"  # the parameter to blame
    require_memory(needed, f"{larger}: {what}", cli=f"--{larger.replace('_', '-')}: {what}")
    if total > MAX_COUNT:
        raise parameter_error(
            "load",
            f"asks for {_count_text(total)} robots' worth of requirements in all; at most "
            f"{MAX_COUNT} (2**31 - 1)",
        )
    extra = max(total - n, 0)
    what = f"{_count_text(extra)} units of over-subscription"
    require_memory(_BYTES_PER_EXTRA_UNIT * extra, f"load: {what}", cli=f"--load: {what}")


def _count_text(count: int) -> str:
    return str(count) if count < 10**15 else f"{float(count):.3g}"


def _check_parameters(
    robots: Any, percent_tasks: Any, service_types: Any, services_per_robot: Any, load: Any
) -> tuple[int, float, int, int, float]:
    n = _whole(robots, "robots", 1)
    s = _whole(service_types, "service_types", 1)
    k = _whole(services_per_robot, "services_per_robot", 1, s)
    for name, value in (("percent_tasks", percent_tasks), ("load", load)):
        require_number(name, value, above=0, flag=True)
    if percent_tasks > 100:
        raise parameter_error(
            "percent_tasks", f"must be at most 100, got {describe(percent_tasks)}"
        )
    m = task_count(n, float(percent_tasks))
    total = math.floor(float(load) * n + 0.5)
    if total < m:
        raise parameter_error(
            "load",
            f"{load:g} asks for {plural(total, 'robot')} in all, "
            f"but each of the {m} tasks needs at least one",
        )
    _check_size(n, m, s, total)
    return n, float(percent_tasks), s, k, float(load)


def _seed_label(seed: SeedLike) -> str:
    return str(seed) if isinstance(seed, numbers.Integral) else "rng"


def _generator_record(n: int, p: float, s: int, k: int, load: float, seed: SeedLike) -> dict:
    return {
        "family": "cfopt.generate_mission",
        "robots": n,
        "percent_tasks": p,
        "service_types": s,
        "services_per_robot": k,
        "load": load,
        "seed": int(seed) if isinstance(seed, numbers.Integral) else None,
    }


# --------------------------------------------------------------------------- grids
@dataclass(frozen=True)
class GridCell:
    """One combination of the seed's independent variables.

    ``network`` (a network spec, see ``cfopt run --help``) makes it a distributed cell:
    its heuristics run as agents on that simulated network.  The missions do not depend
    on it: a distributed cell has the same missions as its centralized twin.

    Examples
    --------
    >>> cell = GridCell(robots=100, percent_tasks=10, service_types=10, services_per_robot=5)
    >>> cell.label, cell.composition
    ('n=100 p=10% 10:5 load=1', '10:5')
    >>> cell.mission(0) == cell.mission(0), cell.mission(0) == cell.mission(1)
    (True, False)
    """

    robots: int
    percent_tasks: float
    service_types: int
    services_per_robot: int
    load: float = 1.0
    network: str | None = None

    def __post_init__(self) -> None:
        _check_parameters(
            self.robots, self.percent_tasks, self.service_types, self.services_per_robot, self.load
        )
        if self.network is not None and (not isinstance(self.network, str) or not self.network):
            raise parameter_error(
                "network", f"must be a network spec (text) or None, got {describe(self.network)}"
            )

    @property
    def composition(self) -> str:
        """``"S:k"``: service types to services per robot."""
        return f"{self.service_types}:{self.services_per_robot}"

    @property
    def label(self) -> str:
        """A short human-readable name (with ``net=SPEC`` for a distributed cell)."""
        label = f"n={self.robots} p={self.percent_tasks:g}% {self.composition} load={self.load:g}"
        return label if self.network is None else f"{label} net={self.network}"

    def mission_seed(self, index: int, base_seed: int = 0) -> int:
        """The integer seed of this cell's ``index``-th mission (``cfopt generate --seed``);
        ``index`` and ``base_seed`` are whole numbers >= 0."""
        index = require_int("index", index, minimum=0)
        key = [
            require_int("base_seed", base_seed, minimum=0),
            self.robots,
            round(self.percent_tasks * 1000),
            self.service_types,
            self.services_per_robot,
            round(self.load * 1000),
            index,
        ]
        return int(np.random.SeedSequence(key).generate_state(1, dtype=np.uint32)[0])

    def mission(self, index: int, base_seed: int = 0) -> Mission:
        """This cell's ``index``-th mission, the same on every machine."""
        return generate_mission(
            self.robots,
            self.percent_tasks,
            self.service_types,
            self.services_per_robot,
            load=self.load,
            seed=self.mission_seed(index, base_seed),
        )

    def missions(
        self, count: int = PAPER_MISSIONS_PER_CELL, base_seed: int = 0
    ) -> Iterator[Mission]:
        """The first ``count`` missions of this cell (generated one at a time)."""
        count = require_int("count", count, minimum=0)
        base_seed = require_int("base_seed", base_seed, minimum=0)
        return (self.mission(index, base_seed) for index in range(count))


_COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
_PERCENTS = (1, 10, 50)


#: The network of the seed's distributed evaluation, as cfopt models it.  The seed ran every
#: robot as an MPI process on a cluster, "fully-connected", with non-blocking (UDP-like)
#: messages that were "not instantaneous"; it gives no latency or loss figures.  cfopt's
#: reading: a complete topology, latencies uniform in 1-10 ms, 1 % independent loss, one
#: broadcast transmission per send, 10 ms clocks.
SEED_NETWORK = "complete latency=uniform:1ms:10ms loss=0.01"


def _grid(sizes: tuple[int, ...], load: float, network: str | None = None) -> list[GridCell]:
    return [
        GridCell(n, p, s, k, load, network)
        for n in sizes
        for p in _PERCENTS
        if p != 1 or n > 100  # the seed used 1% only when it gives more than one task
        for s, k in _COMPOSITIONS
    ]


def paper_grid(load: float = 1.0) -> list[GridCell]:
    """The seed's centralized grid: 32 cells (25 missions each in the seed: 800 trials).

    >>> len(paper_grid()), paper_grid()[0].label
    (32, 'n=100 p=10% 5:1 load=1')
    """
    return _grid((100, 500, 1000), load)


def paper_distributed_grid(load: float = 1.0, network: str | None = None) -> list[GridCell]:
    """The seed's distributed grid (collectives of 100 and 500 robots): 20 cells.

    ``network`` makes the cells distributed (:data:`SEED_NETWORK` for the seed's own runs);
    without it they are the same missions for the centralized engines.

    >>> len(paper_distributed_grid()), paper_distributed_grid(network=SEED_NETWORK)[0].label
    (20, 'n=100 p=10% 5:1 load=1 net=complete latency=uniform:1ms:10ms loss=0.01')
    """
    return _grid((100, 500), load, network)
