"""The result store: the trials and claim verdicts of sweeps, in one SQLite file.

A :class:`Trial` is one algorithm on one mission, scored against the mission's exact
optimum.  :class:`ResultStore` keeps trials keyed by ``(cell, mission seed, algorithm,
algorithm version, code version)``, committed one at a time, and the audit's claim verdicts keyed by
``(claim, budget, seed, code version)``, so an interrupted sweep or audit resumes with
nothing lost and nothing computed twice.  :func:`store_lock` lets one sweep at a time
write to a store: a second sweep on the same store is refused with a message naming the
process that holds it.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sqlite3
import stat
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from cfopt._jsonio import check_folder, shown_path, stat_path
from cfopt.checks import is_whole
from cfopt.errors import MissionError, describe

__all__ = ["EXACT", "ResultStore", "StoreBusy", "Trial", "check_store_path", "store_lock"]

#: The algorithm name of the exact solve's trials.
EXACT = "exact"
_SCHEMA_VERSION = "5"
#: Older schemas this cfopt reads (and, when it writes, upgrades in place).
_READABLE_SCHEMAS = ("2", "3", "4", "5")
_SQLITE_MAGIC = b"SQLite format 3\x00"


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
        ``"exact"``, a registry name (``"grape-s"``...) or the ``MODULE:ATTR`` reference
        the sweep was given.
    code_version : str
        :func:`code_version` of the code that computed the trial.
    algorithm_version : str
        The algorithm's :attr:`heuristics.AlgorithmSpec.version` (``""`` for ``exact``,
        whose code the code version covers); part of the key, so a new version of an
        algorithm is computed again.  Trials stored before schema 5 read as ``"1"``
        (every algorithm's version then).
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
        Whether the algorithm's pairwise step was needed, as its run reports it (the
        Pair-GRAPE-S variants; ``False`` for the algorithms without one); ``None`` for
        ``exact`` and for runs that report no counts.  Before cfopt stored it for every
        algorithm, only Pair-GRAPE-S's was kept.
    algorithm_seed : int or None
        The seed the heuristic ran with (the mission seed).
    finished : float
        Unix time when the trial finished.
    network : str or None
        The network spec of a distributed trial (its cell's); ``None`` for centralized.
    sim_seconds, convergence_seconds : float or None
        A distributed trial's simulated seconds until its robots stopped (the time limit
        when cut) and until they all held one final belief (``None``: never).
    transmissions, receptions, losses : int or None
        A distributed trial's messages on the medium.
    converged, beliefs_agree, cut : bool or None
        A distributed trial's ending (see :class:`heuristics.simulate.NetworkReport`).
    communication : tuple of (str, str, int, int), or None
        A centralized run's messages and bytes under every communication model,
        ``(medium, encoding, messages, bytes)`` per row (:attr:`heuristics.Run.communication`,
        :mod:`heuristics.communication`); ``messages`` and ``bytes`` above are the row of
        the algorithm's default model (broadcast, full).  ``None`` for ``exact``, for
        distributed trials, for algorithms that do not count by model and for trials
        stored before schema 4.  Stored as JSON text (a list of 4-element lists).
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
    network: str | None = None
    sim_seconds: float | None = None
    convergence_seconds: float | None = None
    transmissions: int | None = None
    receptions: int | None = None
    losses: int | None = None
    converged: bool | None = None
    beliefs_agree: bool | None = None
    cut: bool | None = None
    communication: tuple[tuple[str, str, int, int], ...] | None = None
    algorithm_version: str = ""

    @property
    def optimum_proven(self) -> bool:
        """Whether the optimum this trial is scored against was proven optimal."""
        return self.optimum_status == "optimal"

    @property
    def composition(self) -> str:
        """``"S:k"``."""
        return f"{self.service_types}:{self.services_per_robot}"

    @property
    def key(self) -> tuple[str, int, str, str, str]:
        """The store's primary key ``(cell, mission_seed, algorithm, algorithm_version,
        code_version)``."""
        return (
            self.cell,
            self.mission_seed,
            self.algorithm,
            self.algorithm_version,
            self.code_version,
        )

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
    "converged",
    "beliefs_agree",
    "cut",
}
_INT_FIELDS = {
    "robots", "service_types", "services_per_robot", "mission_index", "base_seed",
    "mission_seed", "tasks", "iterations", "rounds", "messages", "bytes", "work",
    "algorithm_seed", "transmissions", "receptions", "losses",
}  # fmt: skip
_TRIAL_FIELDS = tuple(f.name for f in fields(Trial))
_TEXT_FIELDS = {
    "cell", "algorithm", "code_version", "optimum_status", "network", "algorithm_version",
}  # fmt: skip
_OPTIONAL_FIELDS = {
    "percent_optimum", "iterations", "rounds", "messages", "bytes", "work",
    "pairwise_step_ran", "algorithm_seed", "network", "sim_seconds", "convergence_seconds",
    "transmissions", "receptions", "losses", "converged", "beliefs_agree", "cut",
    "communication",
}  # fmt: skip
#: Columns added by schema 3 (distributed trials); a schema-2 store gains them, empty.
_SCHEMA_3_COLUMNS = (
    "network", "sim_seconds", "convergence_seconds", "transmissions", "receptions", "losses",
    "converged", "beliefs_agree", "cut",
)  # fmt: skip
#: Columns added by schema 4 (the per-trial communication table, JSON text); an older
#: store gains them, empty.
_SCHEMA_4_COLUMNS = ("communication",)
#: Columns added by schema 5 (the algorithm's version, in the primary key): an older
#: store is rebuilt with it, ``"1"`` for its heuristics' trials and ``""`` for exact ones.
_SCHEMA_5_COLUMNS = ("algorithm_version",)
#: The columns each older schema lacks.
_LATER_COLUMNS = {
    "2": set(_SCHEMA_3_COLUMNS) | set(_SCHEMA_4_COLUMNS) | set(_SCHEMA_5_COLUMNS),
    "3": set(_SCHEMA_4_COLUMNS) | set(_SCHEMA_5_COLUMNS),
    "4": set(_SCHEMA_5_COLUMNS),
}
#: How a store without the column reads a trial's algorithm version.
_OLD_ALGORITHM_VERSION = f"CASE WHEN algorithm = '{EXACT}' THEN '' ELSE '1' END"


def _communication_json(table: Any) -> str | None:
    """A trial's communication table as the JSON text stored (``None`` stays ``None``)."""
    if table is None:
        return None
    return json.dumps([[str(md), str(en), int(ms), int(by)] for md, en, ms, by in table])


def _communication_table(text: Any) -> tuple[tuple[str, str, int, int], ...] | None:
    """The stored JSON text back as a table; ``None`` when it is not one."""
    try:
        rows = json.loads(text)
    except (TypeError, ValueError):
        return None
    if not isinstance(rows, list):
        return None
    table = []
    for row in rows:
        if not (
            isinstance(row, list)
            and len(row) == 4
            and all(isinstance(v, str) for v in row[:2])
            and all(is_whole(v) and v >= 0 for v in row[2:])
        ):
            return None
        table.append((row[0], row[1], row[2], row[3]))
    return tuple(table)


def _kind(name: str) -> str:
    if name == "communication":
        return "communication table (JSON)"
    if name in _TEXT_FIELDS:
        return "text"
    if name in _BOOL_FIELDS:
        return "bool"
    return "whole number" if name in _INT_FIELDS else "number"


def _fits(value: Any, kind: str) -> bool:
    if kind == "communication table (JSON)":
        return isinstance(value, str) and _communication_table(value) is not None
    if kind == "text":
        return isinstance(value, str)
    if kind == "bool":
        return value in (0, 1) and isinstance(value, int)
    if kind == "whole number":
        return isinstance(value, int)
    return isinstance(value, int | float) and not math.isnan(value)


def _trial_from_row(row: tuple[Any, ...], where: str) -> Trial:
    """A stored row as a :class:`Trial`, every column checked (a store may be edited)."""
    values = dict(zip(_TRIAL_FIELDS, row, strict=True))
    for name, value in values.items():
        if value is None and name in _OPTIONAL_FIELDS:
            continue
        kind = _kind(name)
        if value is None or not _fits(value, kind):
            raise MissionError(
                f"{where} ({values.get('algorithm')!s} on {values.get('cell')!s}): column "
                f"{name} holds {describe(value)}, expected a {kind}; the store was edited "
                "or written by another program"
            )
        if kind == "bool":
            values[name] = bool(value)
        elif name == "communication":
            values[name] = _communication_table(value)
    return Trial(**values)


# -------------------------------------------------------------------------- store
_COLUMN_TYPES = {
    "cell": "TEXT NOT NULL",
    "mission_seed": "INTEGER NOT NULL",
    "algorithm": "TEXT NOT NULL",
    "code_version": "TEXT NOT NULL",
    "algorithm_version": "TEXT NOT NULL DEFAULT ''",
}
_PRIMARY_KEY = "(cell, mission_seed, algorithm, algorithm_version, code_version)"


def _column_type(name: str) -> str:
    if name in _COLUMN_TYPES:
        return _COLUMN_TYPES[name]
    if name in _INT_FIELDS or name in _BOOL_FIELDS:
        return "INTEGER"
    return "TEXT" if name in _TEXT_FIELDS or name == "communication" else "REAL"


def _schema(table: str = "trials") -> str:
    columns = []
    for name in _TRIAL_FIELDS:
        columns.append(f"  {name} {_column_type(name)}")
    columns.append(f"  PRIMARY KEY {_PRIMARY_KEY}")
    return f"CREATE TABLE IF NOT EXISTS {table} (\n" + ",\n".join(columns) + "\n)"


_CLAIMS_SCHEMA = (
    "CREATE TABLE IF NOT EXISTS claims (claim_id TEXT NOT NULL, budget INTEGER NOT NULL,"
    " seed INTEGER NOT NULL, code_version TEXT NOT NULL, verdict TEXT NOT NULL,"
    " finished REAL, PRIMARY KEY (claim_id, budget, seed, code_version))"
)


class ResultStore:
    """The trials of sweeps and the claim verdicts of audits, in one SQLite file.

    Parameters
    ----------
    path : str or path-like
        An existing store, or (with ``create``) a new one; its folder must exist.  An
        existing file that is not an SQLite database, or a database without cfopt's
        tables and not empty, is refused (:class:`cfopt.MissionError`): it is never
        modified.
    create : bool, default True
        Create the file and the tables when missing.  ``False`` opens an existing store
        for reading without changing it (what reports do).

    Notes
    -----
    WAL mode, one committed transaction per trial.  The primary key is ``(cell,
    mission_seed, algorithm, algorithm_version, code_version)`` and trials are inserted
    with ``INSERT OR IGNORE``: adding a trial twice keeps the first.  Every row read back is checked
    column by column, so an edited store gives a clean error naming the row.  Several
    processes may read at once; one sweep at a time writes (:func:`store_lock`), from
    its parent process only.  Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, path: str | os.PathLike[str], *, create: bool = True) -> None:
        self.path = Path(path)
        self._name = name = os.fspath(path)
        info = check_store_path(path, create=create)
        if info is not None and info.st_size > 0:
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
            self._open(create)
        except sqlite3.DatabaseError as exc:
            self._db.close()
            raise MissionError(f"{name}: not a usable result store ({exc})") from None
        except BaseException:
            self._db.close()
            raise

    def _open(self, create: bool) -> None:
        db, name = self._db, self._name
        db.execute("PRAGMA busy_timeout = 60000")
        tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if tables and "trials" not in tables:
            raise MissionError(
                f"{name}: an SQLite database of something else (tables: "
                f"{', '.join(sorted(tables))}); it was left untouched"
            )
        if not tables and not create:
            raise MissionError(f"{name}: an empty file, not a result store yet")
        if create:
            db.execute("PRAGMA journal_mode = WAL")
            db.execute("PRAGMA synchronous = FULL")
            with self._transaction():
                db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)")
                db.execute(_schema())
                db.execute(_CLAIMS_SCHEMA)
                db.execute(
                    "CREATE TABLE IF NOT EXISTS sweeps (id INTEGER PRIMARY KEY AUTOINCREMENT,"
                    " started REAL, code_version TEXT, spec TEXT)"
                )
                db.execute(
                    "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (_SCHEMA_VERSION,)
                )
        row = db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        version = row[0] if row else None
        if version not in _READABLE_SCHEMAS:
            raise MissionError(
                f"{name}: result store schema {version}, this cfopt reads "
                f"{', '.join(_READABLE_SCHEMAS)}"
            )
        if version != _SCHEMA_VERSION and create:
            self._upgrade()
        columns = {r[1] for r in db.execute("PRAGMA table_info(trials)")}
        self._columns = columns
        later = _LATER_COLUMNS.get(version, set())
        missing = [f for f in _TRIAL_FIELDS if f not in columns and f not in later]
        if missing:
            raise MissionError(
                f"{name}: its trials table lacks the column(s) {', '.join(missing)}; the "
                "store was edited or written by another program"
            )
        self._has_claims = create or "claims" in tables
        self._has_sweeps = create or "sweeps" in tables

    def _upgrade(self) -> None:
        """Schema 2 -> 3 -> 4 -> 5, in one transaction: the distributed trials' columns
        (3) and the communication table's (4), empty for the stored trials; then (5) the
        table is rebuilt with the algorithm's version in its primary key, ``"1"`` for the
        stored heuristics' trials and ``""`` for the exact solves."""
        db = self._db
        with self._transaction():
            present = {r[1] for r in db.execute("PRAGMA table_info(trials)")}
            for column in (*_SCHEMA_3_COLUMNS, *_SCHEMA_4_COLUMNS):
                if column not in present:
                    kind = _column_type(column)
                    db.execute(f"ALTER TABLE trials ADD COLUMN {column} {kind}")
            if "algorithm_version" not in present:
                db.execute("DROP TABLE IF EXISTS trials_upgrade")
                db.execute(_schema("trials_upgrade"))
                kept = [f for f in _TRIAL_FIELDS if f != "algorithm_version"]
                db.execute(
                    f"INSERT INTO trials_upgrade ({', '.join(kept)}, algorithm_version) "
                    f"SELECT {', '.join(kept)}, {_OLD_ALGORITHM_VERSION} FROM trials"
                )
                db.execute("DROP TABLE trials")
                db.execute("ALTER TABLE trials_upgrade RENAME TO trials")
            db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (_SCHEMA_VERSION,))

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
        values[_TRIAL_FIELDS.index("communication")] = _communication_json(trial.communication)
        placeholders = ", ".join("?" * len(values))
        with self._transaction():
            cursor = self._db.execute(
                f"INSERT OR IGNORE INTO trials ({', '.join(_TRIAL_FIELDS)}) "
                f"VALUES ({placeholders})",
                values,
            )
        return cursor.rowcount == 1

    def record_sweep(self, sweep: Any, version: str, described: str | None = None) -> None:
        """Remember that ``sweep`` (anything with ``to_dict()``) was started with ``version``;
        ``described`` is the code's description for people (version and git commit)."""
        spec = dict(sweep.to_dict())
        if described is not None:
            spec["cfopt"] = described
        with self._transaction():
            self._db.execute(
                "INSERT INTO sweeps (started, code_version, spec) VALUES (?, ?, ?)",
                (time.time(), version, json.dumps(spec)),
            )

    def add_claim(
        self, claim_id: str, budget: int, seed: int, version: str, verdict: dict[str, Any]
    ) -> None:
        """Store one claim's verdict (the JSON object of ``Verdict.to_dict()``)."""
        with self._transaction():
            self._db.execute(
                "INSERT OR REPLACE INTO claims VALUES (?, ?, ?, ?, ?, ?)",
                (claim_id, budget, seed, version, json.dumps(verdict), time.time()),
            )

    # ----------------------------------------------------------------- reads
    def done(self, version: str) -> set[tuple[str, int, str, str]]:
        """``(cell, mission_seed, algorithm, algorithm_version)`` of the trials stored for
        code version ``version``."""
        rows = self._db.execute(
            "SELECT cell, mission_seed, algorithm, algorithm_version FROM trials"
            " WHERE code_version = ?",
            (version,),
        )
        return {(c, int(s), a, str(v)) for c, s, a, v in rows}

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
        return [str(r[0]) for r in rows]

    def trials(self, version: str | None = None) -> list[Trial]:
        """Stored trials (of ``version``, or all), in a stable order, each row checked."""
        selected = [f if f in self._columns else f"{_missing(f)} AS {f}" for f in _TRIAL_FIELDS]
        query = f"SELECT rowid, {', '.join(selected)} FROM trials"
        args: tuple[Any, ...] = ()
        if version is not None:
            query += " WHERE code_version = ?"
            args = (version,)
        query += (
            " ORDER BY robots, percent_tasks, service_types, services_per_robot, load,"
            " base_seed, mission_index, algorithm, algorithm_version, code_version"
        )
        return [
            _trial_from_row(row[1:], f"{self._name}: trials row {row[0]}")
            for row in self._db.execute(query, args)
        ]

    def claims(self, budget: int, seed: int, version: str) -> dict[str, dict[str, Any]]:
        """Stored claim verdicts for this budget, seed and code version: id -> JSON object."""
        if not self._has_claims:
            return {}
        rows = self._db.execute(
            "SELECT claim_id, verdict FROM claims"
            " WHERE budget = ? AND seed = ? AND code_version = ?",
            (budget, seed, version),
        )
        out = {}
        for claim_id, text in rows:
            with contextlib.suppress(ValueError, TypeError):
                out[str(claim_id)] = json.loads(text)
        return out

    def version_description(self, version: str) -> str | None:
        """How the sweeps that computed ``version`` described their code (package version
        and git commit, see :func:`cfopt.experiments.describe_version`), if they did."""
        for sweep in reversed(self.sweeps()):
            described = sweep["spec"].get("cfopt") if isinstance(sweep["spec"], dict) else None
            if sweep["code_version"] == version and isinstance(described, str):
                return described
        return None

    def count(self) -> int:
        """Number of stored trials (all code versions)."""
        return int(self._db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])

    def sweeps(self) -> list[dict[str, Any]]:
        """The sweeps started on this store: ``started``, ``code_version``, ``spec``."""
        if not self._has_sweeps:
            return []
        rows = self._db.execute("SELECT started, code_version, spec FROM sweeps ORDER BY id")
        out = []
        for started, version, spec in rows:
            with contextlib.suppress(ValueError, TypeError):
                out.append({"started": started, "code_version": version, "spec": json.loads(spec)})
        return out


def _missing(column: str) -> str:
    """What an older store without ``column`` reads in its place."""
    return _OLD_ALGORITHM_VERSION if column == "algorithm_version" else "NULL"


# --------------------------------------------------------------------------- lock
class StoreBusy(MissionError):
    """Another process is writing to the store (see :func:`store_lock`)."""


def _lock_path(store: Path) -> Path:
    return store.with_name(store.name + _LOCK_SUFFIX)


_LOCK_SUFFIX = ".lock"
#: The longest suffix of a file kept beside a store (SQLite's rollback journal).
_SIDECAR_SUFFIX = "-journal"


def check_store_path(path: str | os.PathLike[str], *, create: bool = True) -> os.stat_result | None:
    """What a store path must be, checked before anything is created beside it.

    An existing regular file (its ``os.stat`` is returned), or with ``create`` nothing
    yet in an existing folder (``None``).  A directory, a device or a FIFO is refused
    (:class:`cfopt.MissionError`), and so is a name too long to leave room for the files
    kept beside the store (SQLite's ``-journal``, ``-wal`` and ``-shm``, cfopt's
    ``.lock``).
    """
    name = os.fspath(path)
    info = stat_path(path)
    if info is None:
        if not create:
            raise MissionError(f"{name}: no such result store")
        check_folder(path)
    elif stat.S_ISDIR(info.st_mode):
        raise MissionError(f"{name}: is a directory, not a result store")
    elif not stat.S_ISREG(info.st_mode):
        raise MissionError(f"{name}: not a regular file, not a result store")
    _check_sidecar_names(Path(path))
    return info


def _check_sidecar_names(store: Path) -> None:
    try:
        longest = os.pathconf(store.parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        longest = 255
    room = longest - len(_SIDECAR_SUFFIX)
    if len(os.fsencode(store.name)) > room:
        raise MissionError(
            f"{shown_path(store)}: the name is too long for a result store (at most {room} "
            f"bytes here: SQLite keeps files named after it with '{_SIDECAR_SUFFIX}' added)"
        )


@contextlib.contextmanager
def store_lock(path: str | os.PathLike[str], purpose: str = "cfopt sweep") -> Iterator[None]:
    """Hold the store for one writer; a second one gets :class:`StoreBusy` at once.

    The lock is an advisory ``flock`` on ``<store>.lock`` beside the store (created,
    holding the holder's process id, and removed on release), taken only once the
    store's path passes :func:`check_store_path`.  The operating system
    drops it when the holder dies, even by SIGKILL, so a killed sweep never leaves the
    store locked.  Without ``fcntl`` (Windows) there is no lock.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on POSIX
        yield
        return
    check_store_path(path)
    store = Path(path)
    lock = _lock_path(store)
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
        except OSError as exc:
            raise MissionError(f"{lock}: cannot create the store's lock ({exc.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(fd, 200, 0).decode("utf-8", "replace").strip() or "another process"
            os.close(fd)
            raise StoreBusy(
                f"{os.fspath(path)}: in use by {holder}; wait for it to finish, "
                "or use another store"
            ) from None
        if _same_file(fd, lock):  # not a lock file its previous holder just removed
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{purpose} (process {os.getpid()})".encode(), 0)
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)
        os.close(fd)


def _same_file(fd: int, path: Path) -> bool:
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except OSError:
        return False
