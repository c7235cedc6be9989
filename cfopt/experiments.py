"""Optimal-gap sweeps: grid cells x missions x algorithms, into a store that loses nothing.

A *sweep* (:class:`Sweep`) names grid cells (:class:`cfopt.GridCell`), a number of
missions per cell and the heuristics to run.  Every mission is solved exactly
(:func:`cfopt.solve_exact`, the ``"exact"`` trial) and every heuristic runs on it; each
*trial* (:class:`Trial`) records the mission's parameters and seed, the algorithm's
utility, the optimum it is scored against (with the solver's status: an optimum that is
not proven is marked), percent of optimum and of total, iterations, messages, bytes,
counted work, seconds, and the Nash and pairwise verdicts of :mod:`proofs`.

The result store (:class:`ResultStore`) is one SQLite file in WAL mode.  A trial is
keyed by ``(cell, mission seed, algorithm, code version)`` (``PRIMARY KEY``, ``INSERT OR
IGNORE``) and committed as soon as it finishes.  Trials are computed in workers and
written by the parent only, so a sweep killed at any moment and run again completes with
no trial lost or duplicated, and re-running a finished sweep does nothing.

Trials run through any :class:`concurrent.futures.Executor`: a
:class:`~concurrent.futures.ProcessPoolExecutor` by default (``workers``), the calling
process for ``workers=1``, or one you pass -- ``dask.distributed.Client(...).get_executor()``
works unchanged.

Examples
--------
>>> import tempfile, os
>>> from cfopt import GridCell
>>> from cfopt.experiments import Sweep, ResultStore, run_sweep
>>> sweep = Sweep(cells=(GridCell(20, 10, 5, 2),), missions=2, algorithms=("grape-s",))
>>> with tempfile.TemporaryDirectory() as tmp:
...     store = os.path.join(tmp, "trials.sqlite")
...     first = run_sweep(sweep, store, workers=1, progress=False)
...     again = run_sweep(sweep, store, workers=1, progress=False)
...     with ResultStore(store) as db:
...         rows = db.trials()
>>> first.completed, again.completed, again.skipped, len(rows)
(4, 0, 4, 4)
>>> sorted({(t.algorithm, t.optimum_status) for t in rows})
[('exact', 'optimal'), ('grape-s', 'optimal')]
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import itertools
import json
import math
import os
import sqlite3
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from cfopt import __version__
from cfopt.errors import MissionError, describe
from cfopt.generate import GridCell, paper_distributed_grid, paper_grid

__all__ = [
    "EXACT",
    "GRIDS",
    "ResultStore",
    "Sweep",
    "SweepOutcome",
    "Trial",
    "audit_grid",
    "code_version",
    "grid_from_file",
    "named_grid",
    "product_grid",
    "quick_grid",
    "run_sweep",
    "run_trial",
]

#: The algorithm name of the exact solve in the store.
EXACT = "exact"
#: Default HiGHS time limit (seconds) of a sweep's exact solves.
DEFAULT_TIME_LIMIT = 60.0
_COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
_PERCENTS = (1.0, 10.0, 50.0)
_SCHEMA_VERSION = "2"
_SQLITE_MAGIC = b"SQLite format 3\x00"


# --------------------------------------------------------------------------- grids
def audit_grid() -> tuple[GridCell, ...]:
    """The grid of ``cfopt audit``: the seed's distributed grid plus over-subscription.

    The seed's 20 cells with 100 and 500 robots (every composition and percent-task
    level, achievable missions), and the 100-robot cells again at load 1.25
    (over-subscribed: not every task can be done, only the ILP knows the optimum).

    >>> cells = audit_grid()
    >>> len(cells), sorted({c.load for c in cells})
    (28, [1.0, 1.25])
    """
    over = [c for c in paper_distributed_grid(load=1.25) if c.robots == 100]
    return (*paper_distributed_grid(), *over)


def quick_grid() -> tuple[GridCell, ...]:
    """The grid of ``cfopt audit --quick``: the seed's 100-robot cells, achievable, and
    their 10 %-task cells at load 1.25 (RACHNA_dt takes seconds per over-subscribed
    mission at 50 % tasks, so those are left to the full audit).

    >>> cells = quick_grid()
    >>> len(cells), sorted({c.load for c in cells}), {c.robots for c in cells}
    (12, [1.0, 1.25], {100})
    """
    achievable = [c for c in paper_grid() if c.robots == 100]
    over = [c for c in paper_grid(load=1.25) if c.robots == 100 and c.percent_tasks == 10]
    return (*achievable, *over)


#: Named grids: name -> (cells factory taking a load or None, default missions per cell,
#: whether ``load`` may be changed).
GRIDS: dict[str, tuple[Callable[[], Sequence[GridCell]], int, bool]] = {
    "paper": (paper_grid, 25, True),
    "paper-distributed": (paper_distributed_grid, 25, True),
    "audit": (audit_grid, 4, False),
    "quick": (quick_grid, 2, False),
}


def named_grid(name: str, loads: Sequence[float] | None = None) -> tuple[GridCell, ...]:
    """The cells of a named grid (:data:`GRIDS`), optionally at other loads.

    Parameters
    ----------
    name : {"paper", "paper-distributed", "audit", "quick"}
    loads : sequence of float, optional
        For ``paper`` and ``paper-distributed``: the grid once per load (default: the
        seed's achievable missions, load 1).  ``audit`` and ``quick`` have fixed loads.

    >>> len(named_grid("paper")), len(named_grid("paper", loads=[1.0, 1.25]))
    (32, 64)
    """
    if name not in GRIDS:
        raise MissionError(f"grid: unknown grid {name!r} (known: {', '.join(GRIDS)}, or a file)")
    factory, _, loadable = GRIDS[name]
    if loads is None:
        return tuple(factory())
    if not loadable:
        raise MissionError(f"grid {name!r}: has fixed loads; --load applies to other grids")
    return tuple(c for load in loads for c in factory(load=float(load)))  # type: ignore[call-arg]


def product_grid(
    robots: Sequence[int],
    percent_tasks: Sequence[float] = _PERCENTS,
    compositions: Sequence[tuple[int, int]] = _COMPOSITIONS,
    loads: Sequence[float] = (1.0,),
) -> tuple[GridCell, ...]:
    """Every combination of the given values (robots outermost, load innermost).

    >>> [c.label for c in product_grid([20], [10], [(5, 2)], [1.0, 1.25])]
    ['n=20 p=10% 5:2 load=1', 'n=20 p=10% 5:2 load=1.25']
    """
    return tuple(
        GridCell(n, p, s, k, load)
        for n in robots
        for p in percent_tasks
        for s, k in compositions
        for load in loads
    )


def parse_composition(text: str) -> tuple[int, int]:
    """``"10:5"`` -> ``(10, 5)``.

    >>> parse_composition("10:5")
    (10, 5)
    """
    parts = str(text).split(":")
    try:
        s, k = (int(p) for p in parts)
    except ValueError:
        raise MissionError(
            f"composition: must be SERVICE_TYPES:SERVICES_PER_ROBOT like 10:5, got {text!r}"
        ) from None
    return s, k


_FILE_KEYS = ("robots", "percent_tasks", "compositions", "loads", "missions", "cells")
_CELL_KEYS = ("robots", "percent_tasks", "service_types", "services_per_robot", "load")


def grid_from_file(path: str | os.PathLike[str]) -> tuple[tuple[GridCell, ...], int | None]:
    """Read a grid from a small TOML (``.toml``) or JSON file.

    The file gives a product of values, explicit cells, or both::

        robots = [20, 30]                # the product (robots is required for it);
        percent_tasks = [10, 50]         # missing keys take the seed's values:
        compositions = ["5:1", "10:5"]   # 1, 10, 50 percent; 5:1, 5:5, 10:1, 10:5;
        loads = [1.0, 1.25]              # load 1
        missions = 3                     # optional: missions per cell

        [[cells]]                        # explicit cells, after the product's
        robots = 40
        percent_tasks = 10
        service_types = 5
        services_per_robot = 2
        load = 1.25                      # optional, default 1

    Returns the cells and ``missions`` (``None`` when the file does not say).  Unknown
    keys and bad values are :class:`cfopt.MissionError` naming the file and the place.
    """
    name = os.fspath(path)
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise MissionError(f"{name}: no such file") from None
    except OSError as exc:
        raise MissionError(f"{name}: cannot read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
        if name.lower().endswith(".toml"):
            import tomllib

            data = tomllib.loads(text)
        elif name.lower().endswith(".json"):
            data = json.loads(text)
        else:
            raise MissionError(f"{name}: a grid file must end in .toml or .json")
    except UnicodeDecodeError:
        raise MissionError(f"{name}: not UTF-8 text") from None
    except ValueError as exc:  # tomllib.TOMLDecodeError and JSONDecodeError
        if isinstance(exc, MissionError):
            raise
        raise MissionError(f"{name}: not valid {name.rsplit('.', 1)[-1].upper()}: {exc}") from None
    try:
        return _grid_from_data(data)
    except MissionError as exc:
        raise MissionError(f"{name}: {exc}") from None


def _grid_from_data(data: Any) -> tuple[tuple[GridCell, ...], int | None]:
    if not isinstance(data, dict):
        raise MissionError(f"top level: must be an object/table, got {describe(data)}")
    for key in data:
        if key not in _FILE_KEYS:
            raise MissionError(f"{key}: unknown key (expected {', '.join(_FILE_KEYS)})")

    def values(key: str, default: Sequence[Any]) -> list[Any]:
        value = data.get(key, default)
        if not isinstance(value, list) or not value:
            raise MissionError(f"{key}: must be a non-empty list, got {describe(value)}")
        return value

    cells: list[GridCell] = []
    product_keys = ("robots", "percent_tasks", "compositions", "loads")
    if any(k in data for k in product_keys):
        if "robots" not in data:
            raise MissionError('robots: required for a product grid (missing key "robots")')
        comps = []
        for i, text in enumerate(values("compositions", ["5:1", "5:5", "10:1", "10:5"])):
            try:
                comps.append(parse_composition(text))
            except MissionError as exc:
                raise MissionError(f"compositions[{i}]: {exc}") from None
        try:
            cells.extend(
                product_grid(
                    values("robots", []),
                    values("percent_tasks", list(_PERCENTS)),
                    comps,
                    values("loads", [1.0]),
                )
            )
        except MissionError as exc:
            raise MissionError(f"product: {exc}") from None
    for i, entry in enumerate(data.get("cells", [])):
        if not isinstance(entry, dict):
            raise MissionError(f"cells[{i}]: must be an object/table, got {describe(entry)}")
        for key in entry:
            if key not in _CELL_KEYS:
                raise MissionError(
                    f"cells[{i}].{key}: unknown key (expected {', '.join(_CELL_KEYS)})"
                )
        missing = [k for k in _CELL_KEYS[:4] if k not in entry]
        if missing:
            raise MissionError(f'cells[{i}]: missing key "{missing[0]}"')
        try:
            cells.append(GridCell(**entry))
        except MissionError as exc:
            raise MissionError(f"cells[{i}].{exc}") from None
    if not cells:
        raise MissionError("no cells: give robots = [...] (a product) or [[cells]] entries")
    missions = data.get("missions")
    if missions is not None and (
        isinstance(missions, bool) or not isinstance(missions, int) or missions < 1
    ):
        raise MissionError(f"missions: must be a whole number >= 1, got {describe(missions)}")
    return tuple(dict.fromkeys(cells)), missions


# ------------------------------------------------------------------- code version
#: Modules left out of :func:`code_version` (they do not shape a trial's values).
_NOT_TRIAL_SOURCES = {"cfopt": ("cli.py", "report.py", "__main__.py"), "heuristics": ()}


def code_version() -> str:
    """``"<cfopt version>+<hash>"``: a digest of the sources that shape a trial.

    The hash covers ``cfopt`` (all modules but the CLI and the report), ``heuristics``
    and ``proofs/stability.py``.  Any change there is a new code version, and a sweep
    re-runs its trials rather than mixing results of different code.

    >>> code_version().startswith(__version__ + "+")
    True
    """
    import heuristics
    import proofs

    digest = hashlib.sha256()
    for package in (sys.modules["cfopt"], heuristics, proofs):
        root = Path(package.__file__).parent  # type: ignore[arg-type]
        name = package.__name__
        if name == "proofs":
            files = [root / "stability.py"]
        else:
            excluded = _NOT_TRIAL_SOURCES[name]
            files = sorted(p for p in root.rglob("*.py") if p.name not in excluded)
        for path in files:
            digest.update(f"{name}/{path.relative_to(root).as_posix()}\0".encode())
            digest.update(path.read_bytes())
            digest.update(b"\0")
    return f"{__version__}+{digest.hexdigest()[:12]}"


# ------------------------------------------------------------------------- trials
@dataclass(frozen=True)
class Trial:
    """One algorithm on one mission, scored against the mission's optimum (frozen).

    Attributes
    ----------
    cell : str
        :attr:`cfopt.GridCell.label`, e.g. ``"n=100 p=10% 10:5 load=1"``.
    robots, percent_tasks, service_types, services_per_robot, load
        The cell's parameters.
    mission_index, base_seed, mission_seed : int
        The mission is ``cell.mission(mission_index, base_seed)``, i.e.
        ``cfopt generate ... --seed mission_seed``.
    tasks : int
        Tasks in the mission.
    total_utility : float
        Sum of the task utilities.
    algorithm : str
        ``"exact"`` or a registry name (``"grape-s"``...).
    code_version : str
        :func:`code_version` of the code that computed the trial.
    utility : float
        Utility of the algorithm's assignment, recomputed from scratch.
    optimum, optimum_bound : float
        The exact solve's utility and proven upper bound on the same mission.
    optimum_status : str
        ``"optimal"`` (proven), ``"time_limit"`` (``optimum`` is only the best found;
        the truth lies in ``[optimum, optimum_bound]``) or ``"error"``.
    percent_optimum : float or None
        ``100 utility / optimum`` (100 when both are 0); can exceed 100 when the optimum
        is not proven; ``None`` when the solver failed.
    percent_total : float
        ``100 utility / total_utility``.
    iterations, rounds, messages, bytes, work : int or None
        The heuristic's counts (:class:`heuristics.Run`); ``None`` for ``exact``.
    seconds : float
        Wall-clock time of the algorithm call (the solve for ``exact``).
    nash_stable, nash_stable_capped, pairwise_stable, pairwise_stable_capped : bool
        :mod:`proofs` verdicts on the assignment (pairwise: ``mode="strict"``, which under
        the paper's reward coincides with Nash stability).
    pareto_stable : bool
        Pairwise stability with ``mode="pareto"`` (one deviator strictly better, neither
        worse): the informative pairwise notion.
    pairwise_step_ran : bool or None
        Pair-GRAPE-S only: whether its pairwise step was needed.
    algorithm_seed : int or None
        The seed the heuristic ran with (the mission seed).
    finished : float
        Unix time when the trial finished.
    """

    cell: str
    robots: int
    percent_tasks: float
    service_types: int
    services_per_robot: int
    load: float
    mission_index: int
    base_seed: int
    mission_seed: int
    tasks: int
    total_utility: float
    algorithm: str
    code_version: str
    utility: float
    optimum: float
    optimum_bound: float
    optimum_status: str
    percent_optimum: float | None
    percent_total: float
    iterations: int | None
    rounds: int | None
    messages: int | None
    bytes: int | None
    work: int | None
    seconds: float
    nash_stable: bool
    nash_stable_capped: bool
    pairwise_stable: bool
    pairwise_stable_capped: bool
    pareto_stable: bool
    pairwise_step_ran: bool | None
    algorithm_seed: int | None
    finished: float

    @property
    def optimum_proven(self) -> bool:
        """Whether the optimum this trial is scored against was proven optimal."""
        return self.optimum_status == "optimal"

    @property
    def composition(self) -> str:
        """``"S:k"``."""
        return f"{self.service_types}:{self.services_per_robot}"

    @property
    def key(self) -> tuple[str, int, str, str]:
        """The store's primary key ``(cell, mission_seed, algorithm, code_version)``."""
        return (self.cell, self.mission_seed, self.algorithm, self.code_version)

    def to_dict(self) -> dict[str, Any]:
        """All fields, JSON-ready."""
        return asdict(self)


_BOOL_FIELDS = {
    "nash_stable",
    "nash_stable_capped",
    "pairwise_stable",
    "pairwise_stable_capped",
    "pareto_stable",
    "pairwise_step_ran",
}
_INT_FIELDS = {
    "robots", "service_types", "services_per_robot", "mission_index", "base_seed",
    "mission_seed", "tasks", "iterations", "rounds", "messages", "bytes", "work",
    "algorithm_seed",
}  # fmt: skip
_TRIAL_FIELDS = tuple(f.name for f in fields(Trial))


@dataclass(frozen=True)
class _Optimum:
    status: str
    utility: float
    bound: float


def _percent(part: float, whole: float) -> float:
    if whole == 0:
        return 100.0 if part == 0 else math.inf
    return 100.0 * part / whole


def run_trial(
    cell: GridCell,
    mission_index: int,
    algorithm: str,
    *,
    base_seed: int = 0,
    optimum: tuple[str, float, float] | None = None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
    version: str | None = None,
) -> Trial:
    """Compute one trial (in whatever process calls it; the store is not touched).

    Parameters
    ----------
    cell : GridCell
    mission_index : int
        The mission is ``cell.mission(mission_index, base_seed)``.
    algorithm : str
        ``"exact"`` or a name in :data:`heuristics.ALGORITHMS`.
    base_seed : int, default 0
    optimum : (status, utility, bound), optional
        The exact solve of the same mission, from the store; solved here when not given.
    time_limit : float or None
        For the exact solve.
    version : str, optional
        Recorded as :attr:`Trial.code_version` (default: :func:`code_version`).

    Examples
    --------
    >>> from cfopt import GridCell
    >>> t = run_trial(GridCell(20, 10, 5, 2), 0, "grape-s")
    >>> t.algorithm, t.percent_optimum, t.optimum_status, t.iterations >= 0
    ('grape-s', 100.0, 'optimal', True)
    """
    import proofs
    from cfopt.exact import solve_exact

    mission_seed = cell.mission_seed(mission_index, base_seed)
    mission = cell.mission(mission_index, base_seed)
    counts: dict[str, Any] = dict.fromkeys(
        ("iterations", "rounds", "messages", "bytes", "work", "pairwise_step_ran", "algorithm_seed")
    )
    if algorithm == EXACT or optimum is None:
        result = solve_exact(mission, time_limit=time_limit)
        best = _Optimum(result.status.value, result.utility, result.bound)
    else:
        best = _Optimum(*optimum)
    if algorithm == EXACT:
        assignment, seconds = result.assignment, result.seconds
    else:
        from heuristics.registry import get_algorithm

        run = get_algorithm(algorithm)(mission, seed=mission_seed)
        assignment, seconds = run.assignment, run.seconds
        counts.update(
            iterations=run.iterations,
            rounds=run.rounds,
            messages=run.messages,
            bytes=run.bytes,
            work=run.work,
            pairwise_step_ran=run.pairwise_step_ran if algorithm == "pair-grape-s" else None,
            algorithm_seed=mission_seed,
        )
    utility = assignment.utility(mission)
    return Trial(
        cell=cell.label,
        robots=cell.robots,
        percent_tasks=cell.percent_tasks,
        service_types=cell.service_types,
        services_per_robot=cell.services_per_robot,
        load=cell.load,
        mission_index=mission_index,
        base_seed=base_seed,
        mission_seed=mission_seed,
        tasks=mission.n_tasks,
        total_utility=mission.total_utility,
        algorithm=algorithm,
        code_version=version or code_version(),
        utility=utility,
        optimum=best.utility,
        optimum_bound=best.bound,
        optimum_status=best.status,
        percent_optimum=None if best.status == "error" else _percent(utility, best.utility),
        percent_total=_percent(utility, mission.total_utility),
        seconds=seconds,
        nash_stable=proofs.is_nash_stable(mission, assignment),
        nash_stable_capped=proofs.is_nash_stable(mission, assignment, capped=True),
        pairwise_stable=proofs.is_pairwise_stable(mission, assignment),
        pairwise_stable_capped=proofs.is_pairwise_stable(mission, assignment, capped=True),
        pareto_stable=proofs.is_pairwise_stable(mission, assignment, mode="pareto"),
        finished=time.time(),
        **counts,
    )


# -------------------------------------------------------------------------- store
_COLUMN_TYPES = {
    "cell": "TEXT NOT NULL",
    "mission_seed": "INTEGER NOT NULL",
    "algorithm": "TEXT NOT NULL",
    "code_version": "TEXT NOT NULL",
}


def _schema() -> str:
    columns = []
    for name in _TRIAL_FIELDS:
        if name in _COLUMN_TYPES:
            kind = _COLUMN_TYPES[name]
        elif name in _INT_FIELDS or name in _BOOL_FIELDS:
            kind = "INTEGER"
        elif name in ("optimum_status",):
            kind = "TEXT"
        else:
            kind = "REAL"
        columns.append(f"  {name} {kind}")
    columns.append("  PRIMARY KEY (cell, mission_seed, algorithm, code_version)")
    return "CREATE TABLE IF NOT EXISTS trials (\n" + ",\n".join(columns) + "\n)"


class ResultStore:
    """The trials of sweeps, in one SQLite file (WAL mode, one commit per trial).

    Parameters
    ----------
    path : str or path-like
        Created when missing.  An existing file that is not an SQLite database, or a
        database without cfopt's tables and not empty, is refused
        (:class:`cfopt.MissionError`): it is never modified.

    Notes
    -----
    The primary key is ``(cell, mission_seed, algorithm, code_version)`` and trials are
    inserted with ``INSERT OR IGNORE``: adding a trial twice keeps the first.  Several
    processes may read at once; a sweep writes from its parent process only.
    Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        name = os.fspath(path)
        if self.path.is_dir():
            raise MissionError(f"{name}: is a directory, not a result store")
        if self.path.exists() and self.path.stat().st_size > 0:
            with self.path.open("rb") as handle:
                if handle.read(len(_SQLITE_MAGIC)) != _SQLITE_MAGIC:
                    raise MissionError(
                        f"{name}: not a cfopt result store (not an SQLite file); "
                        "it was left untouched"
                    )
        try:
            self._db = sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
        except sqlite3.Error as exc:
            raise MissionError(f"{name}: cannot open the result store ({exc})") from None
        try:
            self._db.execute("PRAGMA busy_timeout = 60000")
            tables = {
                row[0]
                for row in self._db.execute("SELECT name FROM sqlite_master WHERE type='table'")
            }
            if tables and "trials" not in tables:
                raise MissionError(
                    f"{name}: an SQLite database of something else (tables: "
                    f"{', '.join(sorted(tables))}); it was left untouched"
                )
            self._db.execute("PRAGMA journal_mode = WAL")
            self._db.execute("PRAGMA synchronous = FULL")
            with self._transaction():
                self._db.execute(
                    "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)"
                )
                self._db.execute(_schema())
                self._db.execute(
                    "CREATE TABLE IF NOT EXISTS sweeps (id INTEGER PRIMARY KEY AUTOINCREMENT,"
                    " started REAL, code_version TEXT, spec TEXT)"
                )
                self._db.execute(
                    "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (_SCHEMA_VERSION,)
                )
            (version,) = self._db.execute(
                "SELECT value FROM meta WHERE key = 'schema_version'"
            ).fetchone()
        except sqlite3.DatabaseError as exc:
            self._db.close()
            raise MissionError(f"{name}: not a usable result store ({exc})") from None
        except BaseException:
            self._db.close()
            raise
        if version != _SCHEMA_VERSION:
            self._db.close()
            raise MissionError(
                f"{name}: result store schema {version}, this cfopt reads {_SCHEMA_VERSION}"
            )

    # -------------------------------------------------------------- plumbing
    def _transaction(self) -> Any:
        db = self._db

        class _Tx:
            def __enter__(self) -> None:
                db.execute("BEGIN IMMEDIATE")

            def __exit__(self, kind: Any, *rest: Any) -> None:
                db.execute("COMMIT" if kind is None else "ROLLBACK")

        return _Tx()

    def close(self) -> None:
        """Close the database (committed trials are on disk already)."""
        self._db.close()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # ---------------------------------------------------------------- writes
    def add(self, trial: Trial) -> bool:
        """Insert and commit one trial; ``False`` when its key was already stored."""
        values = [getattr(trial, name) for name in _TRIAL_FIELDS]
        values = [int(v) if isinstance(v, bool) else v for v in values]
        placeholders = ", ".join("?" * len(values))
        with self._transaction():
            cursor = self._db.execute(
                f"INSERT OR IGNORE INTO trials ({', '.join(_TRIAL_FIELDS)}) "
                f"VALUES ({placeholders})",
                values,
            )
        return cursor.rowcount == 1

    def record_sweep(self, sweep: Sweep, version: str) -> None:
        """Remember that ``sweep`` was started with ``version`` (provenance for reports)."""
        with self._transaction():
            self._db.execute(
                "INSERT INTO sweeps (started, code_version, spec) VALUES (?, ?, ?)",
                (time.time(), version, json.dumps(sweep.to_dict())),
            )

    # ----------------------------------------------------------------- reads
    def done(self, version: str) -> set[tuple[str, int, str]]:
        """``(cell, mission_seed, algorithm)`` of the trials stored for ``version``."""
        rows = self._db.execute(
            "SELECT cell, mission_seed, algorithm FROM trials WHERE code_version = ?",
            (version,),
        )
        return {(c, int(s), a) for c, s, a in rows}

    def optima(self, version: str) -> dict[tuple[str, int], tuple[str, float, float]]:
        """``(cell, mission_seed) -> (status, utility, bound)`` of the stored exact solves."""
        rows = self._db.execute(
            "SELECT cell, mission_seed, optimum_status, optimum, optimum_bound FROM trials "
            "WHERE code_version = ? AND algorithm = ?",
            (version, EXACT),
        )
        return {(c, int(s)): (st, float(u), float(b)) for c, s, st, u, b in rows}

    def code_versions(self) -> list[str]:
        """Stored code versions, the one with the most recent trial first."""
        rows = self._db.execute(
            "SELECT code_version FROM trials GROUP BY code_version ORDER BY MAX(finished) DESC"
        )
        return [r[0] for r in rows]

    def trials(self, version: str | None = None) -> list[Trial]:
        """Stored trials (of ``version``, or all), in a stable order."""
        query = f"SELECT {', '.join(_TRIAL_FIELDS)} FROM trials"
        args: tuple[Any, ...] = ()
        if version is not None:
            query += " WHERE code_version = ?"
            args = (version,)
        query += (
            " ORDER BY robots, percent_tasks, service_types, services_per_robot, load,"
            " base_seed, mission_index, algorithm, code_version"
        )
        out = []
        for row in self._db.execute(query, args):
            values = dict(zip(_TRIAL_FIELDS, row, strict=True))
            for name in _BOOL_FIELDS:
                if values[name] is not None:
                    values[name] = bool(values[name])
            out.append(Trial(**values))
        return out

    def count(self) -> int:
        """Number of stored trials (all code versions)."""
        return int(self._db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])

    def sweeps(self) -> list[dict[str, Any]]:
        """The sweeps started on this store: ``started``, ``code_version``, ``spec``."""
        rows = self._db.execute("SELECT started, code_version, spec FROM sweeps ORDER BY id")
        return [{"started": s, "code_version": v, "spec": json.loads(p)} for s, v, p in rows]


# -------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class Sweep:
    """What to run: cells x missions x algorithms (frozen).

    Parameters
    ----------
    cells : sequence of GridCell
    missions : int, default 5
        Missions per cell: indices ``0 .. missions-1`` of :meth:`GridCell.mission`.
    algorithms : sequence of str, optional
        Heuristics (registry names); default: every registered one.  The exact solve
        (``"exact"``) always runs: it is the optimum every trial is scored against.
    base_seed : int, default 0
    time_limit : float or None, default 60
        Seconds per exact solve (HiGHS); an optimum not proven by then is marked
        ``time_limit`` in the trials.
    """

    cells: tuple[GridCell, ...]
    missions: int = 5
    algorithms: tuple[str, ...] | None = None
    base_seed: int = 0
    time_limit: float | None = DEFAULT_TIME_LIMIT

    def __post_init__(self) -> None:
        cells = tuple(self.cells)
        if not cells or not all(isinstance(c, GridCell) for c in cells):
            raise MissionError("cells: must be a non-empty sequence of cfopt.GridCell")
        object.__setattr__(self, "cells", tuple(dict.fromkeys(cells)))
        for name, low in (("missions", 1), ("base_seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise MissionError(f"{name}: must be a whole number >= {low}, got {value!r}")
        from heuristics.registry import algorithm_names, get_algorithm

        names = algorithm_names() if self.algorithms is None else list(self.algorithms)
        for name in names:
            if name != EXACT:
                get_algorithm(name)  # raises MissionError listing the known names
        object.__setattr__(
            self, "algorithms", (EXACT, *dict.fromkeys(n for n in names if n != EXACT))
        )
        t = self.time_limit
        if t is not None and (
            isinstance(t, bool) or not isinstance(t, int | float) or not t > 0 or t == math.inf
        ):
            raise MissionError(f"time_limit: must be a number of seconds > 0 or None, got {t!r}")

    @property
    def heuristics(self) -> tuple[str, ...]:
        """The algorithms other than ``exact``."""
        return tuple(a for a in self.algorithms or () if a != EXACT)

    @property
    def size(self) -> int:
        """Number of trials: cells x missions x algorithms (exact included)."""
        return len(self.cells) * self.missions * len(self.algorithms or ())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (stored with each sweep for provenance)."""
        return {
            "cells": [asdict(c) for c in self.cells],
            "missions": self.missions,
            "algorithms": list(self.algorithms or ()),
            "base_seed": self.base_seed,
            "time_limit": self.time_limit,
        }


@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did (frozen).

    ``completed`` trials were computed and stored now, ``skipped`` were in the store
    already; ``failures`` lists ``(cell, mission_seed, algorithm, traceback)`` of trials
    that raised (a bug; they are not stored, so the next run retries them).
    """

    store: str
    code_version: str
    total: int
    completed: int
    skipped: int
    failures: tuple[tuple[str, int, str, str], ...] = field(default=())
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """Whether every trial of the sweep is in the store."""
        return not self.failures and self.completed + self.skipped == self.total


class _InlineExecutor(cf.Executor):
    """Runs each call at submission, in the calling process (``workers=1``)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:
            if not isinstance(exc, Exception):
                raise
            future.set_exception(exc)
        return future


def _default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def make_executor(workers: int | None) -> cf.Executor:
    """A process pool of ``workers`` processes (default: the usable CPUs); in-process for 1."""
    n = _default_workers() if workers is None else workers
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise MissionError(f"workers: must be a whole number >= 1, got {workers!r}")
    return _InlineExecutor() if n == 1 else cf.ProcessPoolExecutor(max_workers=n)


def _format_failure(exc: BaseException) -> str:
    return "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)).rstrip()


def run_sweep(
    sweep: Sweep,
    store: str | os.PathLike[str],
    *,
    executor: cf.Executor | None = None,
    workers: int | None = None,
    progress: bool = True,
    version: str | None = None,
    max_pending: int | None = None,
    extra_jobs: Iterable[tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]] = (),
    on_extra: Callable[[int, cf.Future], None] | None = None,
) -> SweepOutcome:
    """Run every trial of ``sweep`` that ``store`` does not hold yet; store each at once.

    Parameters
    ----------
    sweep : Sweep
    store : path
        The SQLite result store (:class:`ResultStore`), created when missing.
    executor : concurrent.futures.Executor, optional
        Where trials run, e.g. ``dask.distributed.Client(...).get_executor()``.  It is
        not shut down.  Default: :func:`make_executor` with ``workers``, shut down at the
        end.
    workers : int, optional
        Processes of the default executor (default: usable CPUs; 1 runs in this process).
    progress : bool, default True
        A tqdm progress bar on stderr.
    version : str, optional
        Code version of the trials (default: :func:`code_version`).
    max_pending : int, optional
        Trials submitted but not finished at any time (default: 4 per worker, 64 for a
        given executor).
    extra_jobs, on_extra
        Further calls ``(fn, args, kwargs)`` to run on the same executor alongside the
        trials (the audit's claims checks); ``on_extra(index, future)`` receives each
        finished one.

    Returns
    -------
    SweepOutcome

    Notes
    -----
    Each mission's exact solve runs first; when it is stored, the mission's heuristic
    trials are submitted with its optimum (an exact trial already in the store is
    reused).  Workers compute trials and return them; only this process writes, one
    committed ``INSERT OR IGNORE`` per trial.  A trial that raises is reported in
    :attr:`SweepOutcome.failures` (with its traceback) and not stored; the sweep goes on.
    On ``KeyboardInterrupt`` pending trials are cancelled and the stored ones kept.
    """
    started = time.perf_counter()
    version = version or code_version()
    own = executor is None
    pool = make_executor(workers) if own else executor
    if max_pending is None:
        max_pending = 4 * (workers or _default_workers()) if own else 64
    failures: list[tuple[str, int, str, str]] = []
    completed = skipped = 0
    try:
        with ResultStore(store) as db:
            db.record_sweep(sweep, version)
            done = db.done(version)
            optima = db.optima(version)
            todo_missions: deque[tuple[GridCell, int]] = deque()
            to_run = 0
            for cell, index in itertools.product(sweep.cells, range(sweep.missions)):
                seed = cell.mission_seed(index, sweep.base_seed)
                missing = [a for a in sweep.algorithms or () if (cell.label, seed, a) not in done]
                skipped += len(sweep.algorithms or ()) - len(missing)
                if missing:
                    todo_missions.append((cell, index))
                    to_run += len(missing)
            bar = _progress_bar(to_run, progress)
            ready: deque[tuple[GridCell, int, str, tuple[str, float, float] | None]] = deque()
            pending: dict[cf.Future, Any] = {}
            extras = list(extra_jobs)
            for number, (fn, args, kwargs) in enumerate(extras):
                pending[pool.submit(fn, *args, **kwargs)] = ("extra", number)

            def submit(cell: GridCell, index: int, algorithm: str, best: Any) -> None:
                future = pool.submit(
                    run_trial,
                    cell,
                    index,
                    algorithm,
                    base_seed=sweep.base_seed,
                    optimum=best,
                    time_limit=sweep.time_limit,
                    version=version,
                )
                pending[future] = ("trial", cell, index, algorithm)

            def queue_heuristics(cell: GridCell, index: int, best: Any) -> None:
                seed = cell.mission_seed(index, sweep.base_seed)
                for algorithm in sweep.heuristics:
                    if (cell.label, seed, algorithm) not in done:
                        ready.append((cell, index, algorithm, best))

            while True:
                while len(pending) < max_pending and (ready or todo_missions):
                    if ready:
                        submit(*ready.popleft())
                        continue
                    cell, index = todo_missions.popleft()
                    seed = cell.mission_seed(index, sweep.base_seed)
                    if (cell.label, seed, EXACT) in done:
                        queue_heuristics(cell, index, optima[(cell.label, seed)])
                    else:
                        submit(cell, index, EXACT, None)
                if not pending:
                    break
                finished, _ = cf.wait(list(pending), return_when=cf.FIRST_COMPLETED)
                for future in finished:
                    what = pending.pop(future)
                    if what[0] == "extra":
                        if on_extra is not None:
                            on_extra(what[1], future)
                        continue
                    _, cell, index, algorithm = what
                    seed = cell.mission_seed(index, sweep.base_seed)
                    exc = future.exception()
                    if exc is not None:
                        failures.append((cell.label, seed, algorithm, _format_failure(exc)))
                        bar.update(1)
                        if algorithm == EXACT:  # no optimum: the mission's heuristics wait
                            for name in sweep.heuristics:
                                if (cell.label, seed, name) not in done:
                                    failures.append(
                                        (cell.label, seed, name, "not run: the exact solve failed")
                                    )
                                    bar.update(1)
                        continue
                    trial: Trial = future.result()
                    db.add(trial)
                    done.add((cell.label, seed, algorithm))
                    completed += 1
                    bar.update(1)
                    if failures:
                        bar.set_postfix(failed=len(failures))
                    if algorithm == EXACT:
                        queue_heuristics(
                            cell,
                            index,
                            (trial.optimum_status, trial.optimum, trial.optimum_bound),
                        )
            bar.close()
    except BaseException:
        if own:
            pool.shutdown(wait=False, cancel_futures=True)
        raise
    if own:
        pool.shutdown(wait=True)
    return SweepOutcome(
        store=os.fspath(store),
        code_version=version,
        total=sweep.size,
        completed=completed,
        skipped=skipped,
        failures=tuple(failures),
        seconds=time.perf_counter() - started,
    )


class _NoBar:
    def update(self, n: int = 1) -> None:
        pass

    def set_postfix(self, **kwargs: Any) -> None:
        pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, enabled: bool) -> Any:
    if not enabled:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, unit="trial", file=sys.stderr, dynamic_ncols=True, smoothing=0.05)
