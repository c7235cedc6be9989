"""Optimal-gap sweeps: grid cells x missions x algorithms, into a store that loses nothing.

A *sweep* (:class:`Sweep`) names grid cells (:class:`cfopt.GridCell`), a number of
missions per cell and the heuristics to run.  Every mission is solved exactly
(:func:`cfopt.solve_exact`, the ``"exact"`` trial) and every heuristic runs on it; each
*trial* (:class:`Trial`) records the mission's parameters and seed, the algorithm's
utility, the optimum it is scored against (with the solver's status: an optimum that is
not proven is marked), percent of optimum and of total, iterations, messages, bytes,
counted work, seconds, and the Nash and pairwise verdicts of :mod:`proofs`.

The result store (:class:`ResultStore`) is one SQLite file in WAL mode.  A trial is
keyed by ``(cell, mission seed, algorithm, algorithm version, code version)`` (``PRIMARY
KEY``, ``INSERT OR IGNORE``) and committed as soon as it finishes: the code version
covers cfopt's own sources, the algorithm's version (:attr:`heuristics.AlgorithmSpec.version`)
what cfopt cannot see, a user's algorithm.  Trials are computed in workers and
written by the parent only, so a sweep killed at any moment and run again completes with
no trial lost or duplicated, and re-running a finished sweep does nothing.

Trials run through any :class:`concurrent.futures.Executor`: a
:class:`~concurrent.futures.ProcessPoolExecutor` by default (``workers``), the calling
process for ``workers=1``, or one you pass -- ``dask.distributed.Client(...).get_executor()``
works unchanged, and :func:`cfopt.cluster.dask_executor` (``cfopt sweep --scheduler``)
adds a clear account of workers that died and of a lost scheduler.

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
import contextlib
import hashlib
import itertools
import math
import os
import subprocess
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from cfopt import __version__
from cfopt._jsonio import read_json, read_text_file, stat_path
from cfopt._limits import MAX_TIME_LIMIT, require_memory
from cfopt._progress import Progress
from cfopt._workers import default_workers, make_executor, stop_executor
from cfopt.checks import require_int, require_number
from cfopt.errors import (  # the executor failures: defined beside the errors, light to import
    ExecutorFailed,
    MissionError,
    SweepInterrupted,
    WorkerDied,
    describe,
    parameter_error,
    plural,
)
from cfopt.generate import SEED_NETWORK, GridCell, paper_distributed_grid, paper_grid
from cfopt.store import EXACT, ResultStore, Trial, store_lock

__all__ = [
    "EXACT",
    "GRIDS",
    "ExecutorFailed",
    "ResultStore",
    "Sweep",
    "SweepInterrupted",
    "SweepOutcome",
    "Trial",
    "WorkerDied",
    "audit_grid",
    "code_version",
    "describe_version",
    "distributed_agents",
    "distributed_grid",
    "grid_from_file",
    "make_executor",
    "named_grid",
    "product_grid",
    "quick_grid",
    "replay_command",
    "resolve_grid",
    "run_sweep",
    "run_trial",
]

#: Default time limit (seconds) of a sweep's exact solves (the whole solve_exact call).
DEFAULT_TIME_LIMIT = 60.0
_COMPOSITIONS = ((5, 1), (5, 5), (10, 1), (10, 5))
_PERCENTS = (1.0, 10.0, 50.0)


#: The over-subscribed loads of the audit's grids.
OVER_LOADS = (1.25, 1.5, 2.0)
#: Memory a sweep holds per trial before running it (its queue entry and key).
_BYTES_PER_TRIAL = 400


# --------------------------------------------------------------------------- grids
def distributed_grid(load: float = 1.0) -> tuple[GridCell, ...]:
    """The seed's distributed evaluation: its 20 cells of 100 and 500 robots, run as agents
    on :data:`cfopt.generate.SEED_NETWORK` (complete, 1-10 ms latency, 1 % loss).

    >>> cells = distributed_grid()
    >>> len(cells), cells[0].network
    (20, 'complete latency=uniform:1ms:10ms loss=0.01')
    """
    return tuple(paper_distributed_grid(load, network=SEED_NETWORK))


def audit_grid() -> tuple[GridCell, ...]:
    """The grid of ``cfopt audit``: the seed's distributed grid, centralized and
    distributed, plus over-subscription.

    The seed's 20 cells with 100 and 500 robots (every composition and percent-task
    level, achievable missions), the 100-robot cells again at loads 1.25, 1.5 and 2
    (over-subscribed: not every task can be done, only the ILP knows the optimum), and the
    100-robot achievable cells on the seed's network (distributed runs of the algorithms
    that have agents).

    >>> cells = audit_grid()
    >>> len(cells), sorted({c.load for c in cells}), sum(c.network is not None for c in cells)
    (52, [1.0, 1.25, 1.5, 2.0], 8)
    """
    over = [c for load in OVER_LOADS for c in paper_distributed_grid(load=load) if c.robots == 100]
    distributed = [c for c in distributed_grid() if c.robots == 100]
    return (*paper_distributed_grid(), *over, *distributed)


def quick_grid() -> tuple[GridCell, ...]:
    """The grid of ``cfopt audit --quick``: the seed's 100-robot cells, achievable, and
    their 10 %-task cells at load 1.25 (RACHNA_dt takes seconds per over-subscribed
    mission at 50 % tasks, so those are left to the full audit).

    >>> cells = quick_grid()
    >>> len(cells), sorted({c.load for c in cells}), {c.robots for c in cells}
    (22, [1.0, 1.25, 1.5, 2.0], {100})

    The over-subscribed cells are at loads 1.25, 1.5 and 2; plus two distributed cells
    (100 robots, 10 % tasks, 5:1 and 10:5, on the seed's network).
    """
    achievable = [c for c in paper_grid() if c.robots == 100]
    over = [
        c
        for load in OVER_LOADS
        for c in paper_grid(load=load)
        if c.robots == 100 and c.percent_tasks == 10
    ]
    distributed = [
        c
        for c in distributed_grid()
        if c.robots == 100 and c.percent_tasks == 10 and c.composition in ("5:1", "10:5")
    ]
    return (*achievable, *over, *distributed)


#: Named grids: name -> (cells factory taking a load or None, default missions per cell,
#: whether ``load`` may be changed).
GRIDS: dict[str, tuple[Callable[[], Sequence[GridCell]], int, bool]] = {
    "paper": (paper_grid, 25, True),
    "paper-distributed": (distributed_grid, 25, True),
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
    networks: Sequence[str | None] = (None,),
) -> tuple[GridCell, ...]:
    """Every combination of the given values (robots outermost, network innermost).

    ``networks`` are network specs (``None``: centralized); each is checked and put in
    canonical form.

    >>> [c.label for c in product_grid([20], [10], [(5, 2)], [1.0, 1.25])]
    ['n=20 p=10% 5:2 load=1', 'n=20 p=10% 5:2 load=1.25']
    >>> product_grid([20], [10], [(5, 2)], networks=["ring  loss=0.1"])[0].network
    'ring loss=0.1'
    """
    return tuple(
        _canonical(GridCell(n, p, s, k, load, network))
        for n in robots
        for p in percent_tasks
        for s, k in compositions
        for load in loads
        for network in networks
    )


def parse_composition(text: str) -> tuple[int, int]:
    """``"10:5"`` -> ``(10, 5)``: service types, services per robot (1 <= k <= S).

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
    if not 1 <= k <= s:
        raise MissionError(
            f"composition {text}: the services per robot ({k}) must be between 1 and the "
            f"service types ({s})"
        )
    return s, k


_FILE_KEYS = (
    "robots", "percent_tasks", "compositions", "load", "loads", "network", "missions", "cells",
)  # fmt: skip
_CELL_KEYS = ("robots", "percent_tasks", "service_types", "services_per_robot", "load", "network")


def grid_from_file(path: str | os.PathLike[str]) -> tuple[tuple[GridCell, ...], int | None]:
    """Read a grid from a small TOML (``.toml``) or JSON file.

    The file gives a product of values, explicit cells, or both::

        robots = [20, 30]                # the product (robots is required for it);
        percent_tasks = [10, 50]         # missing keys take the seed's values:
        compositions = ["5:1", "10:5"]   # 1, 10, 50 percent; 5:1, 5:5, 10:1, 10:5;
        load = [1.0, 1.25]               # load 1 ("loads" is accepted too)
        missions = 3                     # optional: missions per cell

        [[cells]]                        # explicit cells, after the product's
        robots = 40
        percent_tasks = 10
        service_types = 5
        services_per_robot = 2
        load = 1.25                      # optional, default 1

    The keys are the ``cfopt sweep`` flags' names with ``_`` for ``-``.  Returns the
    cells and ``missions`` (``None`` when the file does not say).  Unknown keys and bad
    values are :class:`cfopt.MissionError` naming the file and the place.
    """
    name = os.fspath(path)
    suffix = name.lower().rsplit(".", 1)[-1]
    if suffix not in ("toml", "json"):
        raise MissionError(f"{name}: a grid file must end in .toml or .json")
    if suffix == "json":
        data, _ = read_json(path)
    else:
        import tomllib

        try:
            data = tomllib.loads(read_text_file(path))
        except ValueError as exc:  # tomllib.TOMLDecodeError, or an integer too long
            raise MissionError(f"{name}: not valid TOML: {exc}") from None
    try:
        return _grid_from_data(data)
    except MissionError as exc:
        raise exc.prefixed(name) from None


def resolve_grid(
    grid: str, loads: Sequence[float] | None = None
) -> tuple[tuple[GridCell, ...], int | None]:
    """The cells of ``grid`` (a name of :data:`GRIDS` or a grid file) and its missions.

    >>> cells, missions = resolve_grid("quick")
    >>> len(cells), missions
    (22, 2)
    """
    if grid in GRIDS:
        return named_grid(grid, loads), GRIDS[grid][1]
    if not grid.lower().endswith((".toml", ".json")) and stat_path(grid) is None:
        raise MissionError(
            f"grid: unknown grid {grid!r}: give one of {', '.join(GRIDS)}, "
            "or a .toml/.json grid file",
            cli=f"--grid: unknown grid {grid!r}: give one of {', '.join(GRIDS)}, "
            "or a .toml/.json grid file",
        )
    if loads:
        raise parameter_error("load", "a grid file sets its own loads")
    return grid_from_file(grid)


def _networks(value: Any) -> list[str | None]:
    """A grid file's ``network``: absent (centralized), one spec, or a list of specs."""
    if value is None:
        return [None]
    items = value if isinstance(value, list) else [value]
    if not items or not all(isinstance(v, str) and v.strip() for v in items):
        raise MissionError(
            f"network: must be a network spec or a list of them, got {describe(value)}"
        )
    return list(items)


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

    if "load" in data and "loads" in data:
        raise MissionError('loads: give "load" or "loads" (the same key), not both')
    cells: list[GridCell] = []
    product_keys = ("robots", "percent_tasks", "compositions", "load", "loads", "network")
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
                    values("loads" if "loads" in data else "load", [1.0]),
                    _networks(data.get("network")),
                )
            )
        except MissionError as exc:  # the file's keys, not the command line's flags
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
            cells.append(_canonical(GridCell(**entry)))
        except MissionError as exc:
            raise MissionError(f"cells[{i}].{exc}") from None
    if not cells:
        raise MissionError("no cells: give robots = [...] (a product) or [[cells]] entries")
    missions = data.get("missions")
    if missions is not None:
        require_int("missions", missions, minimum=1)
    return tuple(dict.fromkeys(cells)), missions


# ------------------------------------------------------------------- code version
#: Modules left out of :func:`code_version` (they do not shape a trial's values).
_NOT_TRIAL_SOURCES = {
    "cfopt": (
        "cli.py", "report.py", "audit.py", "reproduce.py", "paper.py", "stats.py",
        "_progress.py", "__main__.py", "cluster.py",
    )
}  # fmt: skip


def code_version(scope: str = "trials") -> str:
    """``"<cfopt version>+<hash>"``: a digest of the sources that shape a result.

    With ``scope="trials"`` the hash covers ``cfopt`` (all modules but the CLI, the
    cluster executor, the report and its statistics, the orchestration of the audit and of
    the reproduction, and the paper's figures), ``heuristics`` and ``proofs/stability.py``:
    any change there is a new code version, and a sweep re-runs its trials rather than
    mixing results of different code.
    ``scope="claims"`` covers all of ``proofs`` as well (the claims' checks), and keys the
    audit's stored claim verdicts.

    >>> code_version().startswith(__version__ + "+")
    True
    """
    import heuristics
    import proofs

    if scope not in ("trials", "claims"):
        raise parameter_error("scope", f"must be trials or claims, got {scope!r}")
    digest = hashlib.sha256()
    for package in (sys.modules["cfopt"], heuristics, proofs):
        root = Path(package.__file__).parent  # type: ignore[arg-type]
        name = package.__name__
        if name == "proofs" and scope == "trials":
            files = [root / "stability.py"]
        else:
            excluded = _NOT_TRIAL_SOURCES.get(name, ())
            files = sorted(p for p in root.rglob("*.py") if p.name not in excluded)
        for path in files:
            digest.update(f"{name}/{path.relative_to(root).as_posix()}\0".encode())
            digest.update(path.read_bytes())
            digest.update(b"\0")
    return f"{__version__}+{digest.hexdigest()[:12]}"


def _git(root: Path, *args: str) -> str:
    run = subprocess.run(
        ["git", "-C", os.fspath(root), *args],
        capture_output=True,
        text=True,
        timeout=10,
        check=True,
    )
    return run.stdout.strip()


def describe_version() -> str:
    """The package version, plus the git commit when cfopt runs from a git checkout.

    ``"0.1.0 (git 6adb985)"``, ``"0.1.0 (git 6adb985, with uncommitted changes)"``, or
    just ``"0.1.0"`` for an installed copy.  For people; trials are keyed by
    :func:`code_version`.
    """
    root = Path(sys.modules["cfopt"].__file__).resolve().parent.parent  # type: ignore[arg-type]
    if not (root / ".git").exists():
        return __version__
    try:
        commit = _git(root, "rev-parse", "--short", "HEAD")
        dirty = _git(root, "status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return __version__
    return f"{__version__} (git {commit}{', with uncommitted changes' if dirty else ''})"


@dataclass(frozen=True)
class _Optimum:
    status: str
    utility: float
    bound: float


def _percent(part: float, whole: float) -> float:
    if whole == 0:
        return 100.0 if part == 0 else math.inf
    return 100.0 * part / whole


def _run_heuristic(cell: GridCell, spec: Any, algorithm: str, mission: Any, seed: int) -> Any:
    if cell.network is None:
        return spec(mission, seed=seed)
    from heuristics.simulate import simulate

    agents, options = distributed_agents(algorithm)
    return simulate(mission, agents, cell.network, seed=seed, options=options)


def distributed_agents(
    algorithm: str, options: Mapping[str, Any] | None = None
) -> tuple[Any, dict[str, Any] | None]:
    """What a transport (:func:`heuristics.simulate`, :func:`heuristics.mpi_run`) is
    handed to run ``algorithm``'s agents with ``options``: a registered algorithm's name
    and the options (the transport builds its protocol), or for a ``MODULE:ATTR``
    reference its protocol built here (:meth:`heuristics.AlgorithmSpec.make_protocol`)
    and ``None``.

    >>> distributed_agents("sda", {"eps": 0.5})
    ('sda', {'eps': 0.5})
    """
    from heuristics.registry import ALGORITHMS, get_algorithm

    spec = get_algorithm(algorithm)
    if ALGORITHMS.get(algorithm) is spec:
        return algorithm, dict(options or {})
    return spec.make_protocol(**dict(options or {})), None


def _number_text(value: float) -> str:
    """A grid value as ``cfopt generate`` takes it back exactly: ``10``, ``1.25``."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def replay_command(
    cell: GridCell, mission_index: int, algorithm: str, *, base_seed: int = 0
) -> str:
    """The shell commands that replay one trial: generate its mission, run its algorithm.

    >>> replay_command(GridCell(20, 10, 5, 2), 0, "grape-s")  # doctest: +ELLIPSIS
    'cfopt generate --robots 20 --percent-tasks 10 ... -o mission.json && cfopt run grape-s ...'
    """
    import shlex

    seed = cell.mission_seed(mission_index, base_seed)
    generate = (
        f"cfopt generate --robots {cell.robots} --percent-tasks "
        f"{_number_text(cell.percent_tasks)} --service-types {cell.service_types} "
        f"--services-per-robot {cell.services_per_robot} --load {_number_text(cell.load)} "
        f"--seed {seed} -o mission.json"
    )
    run = f"cfopt run {shlex.quote(algorithm)} mission.json --seed {seed}"
    if cell.network is not None:
        run += f" --network {shlex.quote(cell.network)}"
    return f"{generate} && {run}"


def _network_fields(report: Any) -> dict[str, Any]:
    if report is None:
        return {}
    return {
        "sim_seconds": report.simulated_seconds,
        "convergence_seconds": report.convergence_seconds,
        "transmissions": report.transmissions,
        "receptions": report.receptions,
        "losses": report.losses,
        "converged": report.converged,
        "beliefs_agree": report.beliefs_agree,
        "cut": report.cut,
    }


def run_trial(
    cell: GridCell,
    mission_index: int,
    algorithm: str,
    *,
    base_seed: int = 0,
    optimum: tuple[str, float, float] | None = None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
    version: str | None = None,
    directory: str | None = None,
) -> Trial:
    """Compute one trial (in whatever process calls it; the store is not touched).

    Parameters
    ----------
    cell : GridCell
    mission_index : int
        The mission is ``cell.mission(mission_index, base_seed)``.
    algorithm : str
        ``"exact"``, a name in :data:`heuristics.ALGORITHMS` or a ``MODULE:ATTR``
        reference (:func:`heuristics.get_algorithm`).
    base_seed : int, default 0
    optimum : (status, utility, bound), optional
        The exact solve of the same mission, from the store; solved here when not given.
    time_limit : float or None
        For the exact solve.
    version : str, optional
        Recorded as :attr:`Trial.code_version` (default: :func:`code_version`).
    directory : str, optional
        Where the module of a ``MODULE:ATTR`` algorithm is imported from (default: the
        current directory): what a worker in another folder needs.

    Raises
    ------
    heuristics.AlgorithmFailed
        When an algorithm that is not cfopt's own raised (or returned no valid result).

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
    spec = None
    if algorithm != EXACT:
        from heuristics.registry import get_algorithm

        spec = get_algorithm(algorithm, directory=directory)  # a bad name fails before solving
    if algorithm == EXACT or optimum is None:
        result = solve_exact(mission, time_limit=time_limit)
        best = _Optimum(result.status.value, result.utility, result.bound)
    else:
        best = _Optimum(*optimum)
    if spec is None:
        assignment, seconds = result.assignment, result.seconds
    else:
        run = _run_heuristic(cell, spec, algorithm, mission, mission_seed)
        assignment, seconds = run.assignment, run.seconds
        counts.update(_network_fields(run.network), algorithm_seed=mission_seed)
        if run.counted:
            counts.update(
                iterations=run.iterations,
                rounds=run.rounds,
                messages=run.messages,
                bytes=run.bytes,
                work=run.work,
                pairwise_step_ran=(
                    run.pairwise_step_ran if "pairwise_step_ran" in spec.measures else None
                ),
                communication=run.communication or None,
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
        algorithm_version="" if spec is None else spec.version,
        network=cell.network,
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


def _canonical(cell: GridCell) -> GridCell:
    """The cell with its network spec in canonical form (validated: bad input raises)."""
    if cell.network is None:
        return cell
    from heuristics.network import NetworkSpec

    text = NetworkSpec.parse(cell.network).to_text()
    return cell if text == cell.network else replace(cell, network=text)


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
        Heuristics: registry names or ``MODULE:ATTR`` references
        (:func:`heuristics.get_algorithm`; resolved here, and again by each worker);
        default: every registered one.  The exact solve (``"exact"``) always runs: it is
        the optimum every trial is scored against.  A distributed cell (one with a
        ``network``) runs only the algorithms that have a distributed protocol
        (:attr:`heuristics.AlgorithmSpec.protocol`).
    base_seed : int, default 0
    time_limit : float or None, default 60
        Seconds per exact solve (HiGHS), at most ``1e9`` (``None``: no limit); an optimum
        not proven by then is marked ``time_limit`` in the trials.
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
        object.__setattr__(self, "cells", tuple(dict.fromkeys(_canonical(c) for c in cells)))
        for name, low in (("missions", 1), ("base_seed", 0)):
            require_int(name, getattr(self, name), minimum=low, flag=True)
        from heuristics.registry import algorithm_names, get_algorithm

        names = algorithm_names() if self.algorithms is None else list(self.algorithms)
        for name in names:
            if name != EXACT:
                get_algorithm(name)  # raises MissionError: unknown name, bad reference
        object.__setattr__(
            self, "algorithms", (EXACT, *dict.fromkeys(n for n in names if n != EXACT))
        )
        if self.time_limit is not None:
            require_number(
                "time_limit",
                self.time_limit,
                above=0,
                maximum=MAX_TIME_LIMIT,
                what="a number of seconds",
                or_none=True,
                flag=True,
            )
        trials = f"{self.size} trials"
        require_memory(
            _BYTES_PER_TRIAL * self.size, f"missions: {trials}", cli=f"--missions: {trials}"
        )

    @property
    def heuristics(self) -> tuple[str, ...]:
        """The algorithms other than ``exact``."""
        return tuple(a for a in self.algorithms or () if a != EXACT)

    def algorithms_for(self, cell: GridCell) -> tuple[str, ...]:
        """The algorithms run on ``cell`` (``exact`` first): on a distributed cell those
        with a distributed protocol."""
        if cell.network is None:
            return tuple(self.algorithms or ())
        from heuristics.registry import get_algorithm

        return tuple(a for a in self.algorithms or () if a == EXACT or get_algorithm(a).distributed)

    def algorithm_version(self, algorithm: str) -> str:
        """The version a trial of ``algorithm`` is stored under (its spec's; ``""`` for
        ``exact``)."""
        if algorithm == EXACT:
            return ""
        from heuristics.registry import get_algorithm

        return get_algorithm(algorithm).version

    def heuristics_for(self, cell: GridCell) -> tuple[str, ...]:
        """The algorithms other than ``exact`` run on ``cell``."""
        return tuple(a for a in self.algorithms_for(cell) if a != EXACT)

    @property
    def size(self) -> int:
        """Number of trials: cells x missions x their algorithms (exact included)."""
        return self.missions * sum(len(self.algorithms_for(c)) for c in self.cells)

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
    already; ``failures`` lists ``(cell, mission_seed, algorithm, record)`` of trials
    that did not finish (they are not stored, so the next run retries them); the record
    is the traceback of a bug, ``WorkerDied: ...`` for a worker that died, or
    ``AlgorithmFailed: ...`` and a ``replay:`` line for an algorithm that is not cfopt's
    own and raised (:attr:`algorithm_failures`).
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

    @property
    def algorithm_failures(self) -> tuple[tuple[str, int, str, str], ...]:
        """The failures of users' algorithms that raised (not cfopt's bugs)."""
        return tuple(f for f in self.failures if f[3].startswith(ALGORITHM_FAILED))


#: How the record of a failed trial of a user's algorithm starts (:class:`SweepOutcome`).
ALGORITHM_FAILED = "AlgorithmFailed: "


def _format_failure(exc: BaseException, replay: str) -> str:
    """A failed trial's record: ``WorkerDied: ...``, ``AlgorithmFailed: ...`` and the
    replay line for a user's algorithm that raised (not cfopt's bug: no traceback), or
    the traceback."""
    from heuristics.registry import AlgorithmFailed

    if isinstance(exc, WorkerDied):
        return f"{type(exc).__name__}: {exc}"
    if isinstance(exc, AlgorithmFailed):
        return f"{type(exc).__name__}: {exc}\nreplay: {replay}"
    return "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)).rstrip()


ExtraJob = tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]


def run_sweep(
    sweep: Sweep,
    store: str | os.PathLike[str],
    *,
    executor: cf.Executor | None = None,
    workers: int | None = None,
    progress: bool | Progress = True,
    version: str | None = None,
    max_pending: int | None = None,
    extra_jobs: Iterable[ExtraJob] = (),
    on_extra: Callable[[int, cf.Future], None] | None = None,
    lock: bool = True,
) -> SweepOutcome:
    """Run every trial of ``sweep`` that ``store`` does not hold yet; store each at once.

    Parameters
    ----------
    sweep : Sweep
    store : path
        The SQLite result store (:class:`ResultStore`), created when missing (its folder
        must exist).
    executor : concurrent.futures.Executor, optional
        Where trials run, e.g. ``dask.distributed.Client(...).get_executor()``.  It is
        not shut down.  Default: :func:`make_executor` with ``workers`` (processes that
        die with this one), shut down at the end.
    workers : int, optional
        Processes of the default executor (default: usable CPUs; 1 runs in this process).
    progress : bool or Progress, default True
        ``True``: a bar on a terminal, one line per stage otherwise; ``False``: silent.
    version : str, optional
        Code version of the trials (default: :func:`code_version`).
    max_pending : int, optional
        Trials submitted but not finished at any time (default: 4 per worker; for a
        given executor 4 per thread of its ``parallelism`` attribute when it has one, as
        :class:`cfopt.cluster.DaskExecutor` does, and at least 64).
    extra_jobs, on_extra
        Further calls ``(fn, args, kwargs)`` to run on the same executor alongside the
        trials (the audit's claims checks); ``on_extra(index, future)`` receives each
        finished one, in this process.
    lock : bool, default True
        Hold the store for this sweep (:func:`cfopt.store.store_lock`): a second sweep
        on the same store is refused with :class:`cfopt.store.StoreBusy` naming this
        one.  ``False`` when the caller holds the lock already.

    Returns
    -------
    SweepOutcome

    Raises
    ------
    SweepInterrupted
        On SIGINT (Ctrl-C, ``KeyboardInterrupt``): pending trials are cancelled, the
        default executor's workers are stopped at once, the trials stored so far are
        kept, and the exception says how many.
    ExecutorFailed
        When the executor can run no more trials (a lost cluster scheduler): the
        sweep stops, the trials stored so far are kept, and the message says how many.

    Notes
    -----
    Each mission's exact solve runs first; when it is stored, the mission's heuristic
    trials are submitted with its optimum (an exact trial already in the store is
    reused).  Workers compute trials and return them; only this process writes, one
    committed ``INSERT OR IGNORE`` per trial.  A trial that raises is reported in
    :attr:`SweepOutcome.failures` (with its traceback) and not stored; the sweep goes on.
    """
    version = version or code_version()
    guard = store_lock(store) if lock else contextlib.nullcontext()
    with guard, ResultStore(store) as db:
        own = executor is None
        pool = make_executor(workers) if own else executor
        limit = max_pending or _default_pending(None if own else pool, workers)
        run = _SweepRun(sweep, db, pool, version, Progress.coerce(progress), limit)
        try:
            run.start(list(extra_jobs), on_extra)
            run.loop()
        except KeyboardInterrupt as exc:
            if own:
                stop_executor(pool)
            run.close_stage("interrupted")
            raise SweepInterrupted(
                os.fspath(store), run.committed(), run.remaining, _signal_name(exc)
            ) from None
        except ExecutorFailed as exc:
            if own:
                stop_executor(pool)
            run.close_stage("stopped")
            raise _kept(exc, run.committed(), os.fspath(store)) from None
        except BaseException:
            if own:
                stop_executor(pool)
            raise
        if own:
            pool.shutdown(wait=True)
        run.close_stage(run.summary())
    return SweepOutcome(
        store=os.fspath(store),
        code_version=version,
        total=sweep.size,
        completed=run.completed,
        skipped=run.skipped,
        failures=tuple(run.failures),
        seconds=time.perf_counter() - run.started,
    )


def _default_pending(executor: cf.Executor | None, workers: int | None) -> int:
    """Trials in flight: 4 per worker of the default pool, 4 per thread of a given
    executor that tells its ``parallelism`` (at least 64), else 64."""
    if executor is None:
        return 4 * (workers or default_workers())
    slots = getattr(executor, "parallelism", None)
    return max(64, 4 * slots) if isinstance(slots, int) else 64


def _kept(exc: ExecutorFailed, completed: int, store: str) -> ExecutorFailed:
    """``exc`` with what the stopped sweep kept, and for the command line how to resume."""
    verb = "is" if completed == 1 else "are"
    kept = f"{plural(completed, 'trial')} computed by this run {verb} kept in {store}"
    return ExecutorFailed(
        f"{exc}; {kept}", cli=f"{exc.cli_message}; {kept}; run the same command again to resume"
    )


def _signal_name(exc: BaseException) -> str:
    return getattr(exc, "signal_name", "SIGINT")


class _SweepRun:
    """The state of one :func:`run_sweep` call: what is queued, pending and done."""

    def __init__(
        self,
        sweep: Sweep,
        db: ResultStore,
        pool: cf.Executor,
        version: str,
        progress: Progress,
        max_pending: int,
    ) -> None:
        self.sweep, self.db, self.pool, self.version = sweep, db, pool, version
        self.progress, self.max_pending = progress, max_pending
        self.started = time.perf_counter()
        self.failures: list[tuple[str, int, str, str]] = []
        self.completed = self.skipped = self.to_run = 0
        self.stored_at_start = db.count()  # one writer at a time: the rows added are ours
        self.ready: deque[tuple[GridCell, int, str, tuple[str, float, float] | None]] = deque()
        self.todo: deque[tuple[GridCell, int]] = deque()
        self.pending: dict[cf.Future, Any] = {}
        self.on_extra: Callable[[int, cf.Future], None] | None = None
        self.stage: Any = None

    def committed(self) -> int:
        """Trials this run stored, read from the store: an interruption can fall between a
        commit and ``completed += 1``, and the message must count what is kept."""
        return self.db.count() - self.stored_at_start

    def close_stage(self, summary: str) -> None:
        if self.stage is not None:
            self.stage.close(summary)

    @property
    def remaining(self) -> int:
        return self.to_run - self.committed() - len(self.failures)

    def start(self, extras: list[ExtraJob], on_extra: Any) -> None:
        sweep, db = self.sweep, self.db
        db.record_sweep(sweep, self.version, describe_version())
        self.done = db.done(self.version)
        self.versions = {a: sweep.algorithm_version(a) for a in sweep.algorithms or ()}
        self.optima = db.optima(self.version)
        for cell, index in itertools.product(sweep.cells, range(sweep.missions)):
            seed = cell.mission_seed(index, sweep.base_seed)
            wanted = sweep.algorithms_for(cell)
            missing = [a for a in wanted if not self.stored(cell, seed, a)]
            self.skipped += len(wanted) - len(missing)
            if missing:
                self.todo.append((cell, index))
                self.to_run += len(missing)
        stored = f", {self.skipped} already stored" if self.skipped else ""
        self.stage = self.progress.stage(
            "trials", self.to_run, "trial", f"{self.to_run} to run{stored}", reused=self.skipped
        )
        self.on_extra = on_extra
        for number, (fn, args, kwargs) in enumerate(extras):
            self.pending[self.pool.submit(fn, *args, **kwargs)] = ("extra", number)

    def stored(self, cell: GridCell, seed: int, algorithm: str) -> bool:
        """Whether the store holds this trial for this code and algorithm version."""
        return (cell.label, seed, algorithm, self.versions[algorithm]) in self.done

    def summary(self) -> str:
        failed = f", {len(self.failures)} failed" if self.failures else ""
        return f"{self.completed} run, {self.skipped} already stored{failed}"

    def submit(self, cell: GridCell, index: int, algorithm: str, best: Any) -> None:
        from heuristics.registry import algorithm_directory

        sweep = self.sweep
        future = self.pool.submit(
            run_trial,
            cell,
            index,
            algorithm,
            base_seed=sweep.base_seed,
            optimum=best,
            time_limit=sweep.time_limit,
            version=self.version,
            directory=None if algorithm == EXACT else algorithm_directory(algorithm),
        )
        self.pending[future] = ("trial", cell, index, algorithm)

    def queue_heuristics(self, cell: GridCell, index: int, best: Any) -> None:
        seed = cell.mission_seed(index, self.sweep.base_seed)
        for algorithm in self.sweep.heuristics_for(cell):
            if not self.stored(cell, seed, algorithm):
                self.ready.append((cell, index, algorithm, best))

    def fill(self) -> None:
        while len(self.pending) < self.max_pending and (self.ready or self.todo):
            if self.ready:
                self.submit(*self.ready.popleft())
                continue
            cell, index = self.todo.popleft()
            seed = cell.mission_seed(index, self.sweep.base_seed)
            if self.stored(cell, seed, EXACT):
                self.queue_heuristics(cell, index, self.optima[(cell.label, seed)])
            else:
                self.submit(cell, index, EXACT, None)

    def loop(self) -> None:
        while True:
            self.fill()
            if not self.pending:
                return
            finished, _ = cf.wait(list(self.pending), return_when=cf.FIRST_COMPLETED)
            for future in finished:
                self.collect(future, self.pending.pop(future))

    def collect(self, future: cf.Future, what: Any) -> None:
        if what[0] == "extra":
            if self.on_extra is not None:
                self.on_extra(what[1], future)
            return
        _, cell, index, algorithm = what
        seed = cell.mission_seed(index, self.sweep.base_seed)
        exc = future.exception()
        if isinstance(exc, ExecutorFailed):
            raise exc
        if exc is not None:
            replay = replay_command(cell, index, algorithm, base_seed=self.sweep.base_seed)
            self.fail(cell.label, seed, algorithm, _format_failure(exc, replay))
            if algorithm == EXACT:  # no optimum: the mission's heuristics cannot be scored
                for name in self.sweep.heuristics_for(cell):
                    if not self.stored(cell, seed, name):
                        self.fail(cell.label, seed, name, "not run: the exact solve failed")
            return
        trial: Trial = future.result()
        self.db.add(trial)
        self.done.add((cell.label, seed, algorithm, self.versions[algorithm]))
        self.completed += 1
        self.stage.update(1)
        if algorithm == EXACT:
            self.queue_heuristics(
                cell, index, (trial.optimum_status, trial.optimum, trial.optimum_bound)
            )

    def fail(self, cell: str, seed: int, algorithm: str, trace: str) -> None:
        self.failures.append((cell, seed, algorithm, trace))
        self.stage.update(1)
        self.stage.set_postfix(failed=len(self.failures))
