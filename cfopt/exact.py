"""The exact optimum: the ST-MR-IA-with-services ILP, solved by HiGHS.

Two formulations of the same integer program:

``"aggregated"`` (the default)
    Binary ``y[j]`` per task and a continuous flow ``f[k, s]`` from each *capability
    type* ``k`` (a distinct service set, ``cnt[k]`` robots) to each service ``s`` it
    has: maximise ``sum_j u[j] y[j]`` subject to ``sum_s f[k, s] <= cnt[k]`` and
    ``sum_k f[k, s] >= sum_j req[j, s] y[j]``.  For integral ``y`` the flow part is a
    transportation polytope with integral data, so an integral flow with the same
    ``y`` exists; it is recovered by an integral max-flow (networkx) and the slots are
    handed to concrete robots.  HiGHS is given this model *grouped*
    (:mod:`cfopt._exact_groups`): services that the same robots have merged into one,
    and tasks with equal requirements and utility merged into one integer variable
    ``z[g]`` in ``0..multiplicity[g]`` (the number of them done), as arrays through
    highspy.  The ungrouped model is also written in cvxpy
    (:func:`_aggregated_problem`), the readable statement the tests cross-check the
    grouped one against.
``"assignment"`` (the cross-check)
    Binary ``x[i, j, s]`` per robot ``i`` having ``s`` and slot ``(j, s)``, binary
    ``y[j]``: at most one slot per robot, ``sum_i x[i, j, s] >= req[j, s] y[j]``.
    Written in cvxpy.

Both are built from a handful of sparse matrix constraints (never a Python loop over
the variables) and handed to HiGHS in separate stages, so that a time limit covers the
whole call (see :func:`solve_exact`).
"""

from __future__ import annotations

import atexit
import contextlib
import enum
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import networkx as nx
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from networkx.algorithms.flow import edmonds_karp

from cfopt._exact_groups import (
    ServiceClasses,
    TaskGroups,
    Types,
    capability_types,
    service_classes,
    split_class_flow,
    task_groups,
)
from cfopt._limits import MAX_TIME_LIMIT  # the longest time limit solve_exact takes
from cfopt.assignment import UNASSIGNED, Assignment
from cfopt.checks import require_assignment, require_choice, require_mission, require_number
from cfopt.errors import MissionTypeError
from cfopt.mission import Mission

if TYPE_CHECKING:  # cvxpy takes a second or two to import: only solve_exact pays for it
    import cvxpy as cp

__all__ = [
    "FORMULATIONS",
    "MAX_TIME_LIMIT",
    "TIME_LIMIT_SLACK",
    "ExactResult",
    "ExactStatus",
    "solve_exact",
]

#: The formulations :func:`solve_exact` accepts.
FORMULATIONS = ("aggregated", "assignment")

#: :func:`solve_exact` returns within ``time_limit`` plus this many seconds (see its
#: Notes for the exceptions: a loaded machine, models of a million variables or more).
TIME_LIMIT_SLACK = 0.25

#: ``gap`` divides by ``max(bound, _TINY)``.
_TINY = 1e-12
#: The reported utility must equal the ILP objective to this relative precision.
_OBJECTIVE_RTOL = 1e-9
#: LP flows above this count as used; LP flows are rounded down after adding it.
_SUPPORT_TOL = 1e-6
#: HiGHS's ``primal_solution_status`` value meaning "a feasible solution is held".
_HIGHS_SOLUTION_FEASIBLE = 2
#: HiGHS sees the utilities times a power of two that puts the largest in
#: ``[2**(_TOP_EXPONENT - 1), 2**_TOP_EXPONENT)``: about a million, where its absolute
#: tolerances (about 1e-6) are about 1e-12 of the largest utility.
_TOP_EXPONENT = 20
#: Seconds past the deadline the caller waits for the solving thread to hand over.
_GRACE = 0.05
#: Seconds kept back from HiGHS's time limit for the hand-over to HiGHS (cvxpy's, for
#: the assignment model; HiGHS's clock does not see it), HiGHS's own overrun of its
#: limit (it checks its clock only now and then) and reading back and recovering the
#: assignment: a base plus a share per model variable (measured: about 2 s for a
#: million variables).
_RESERVE_BASE = 0.02
_RESERVE_PER_VARIABLE = 2e-6

Formulation = Literal["aggregated", "assignment"]


class ExactStatus(enum.Enum):
    """What :func:`solve_exact` proved."""

    #: HiGHS proved the returned assignment optimal (within ``mip_gap``, 0 by default).
    OPTIMAL = "optimal"
    #: The time limit stopped the solve: the assignment is the best incumbent HiGHS
    #: found (the empty assignment when none was found, or when the time ran out before
    #: HiGHS could run or hand its incumbent over) and ``bound`` the proven upper bound.
    TIME_LIMIT = "time_limit"
    #: HiGHS failed or reported something impossible for this model (infeasible,
    #: unbounded, an unknown status): the empty assignment and the trivial bound.
    ERROR = "error"


#: The one table from cvxpy's status strings (``cvxpy.settings``; HiGHS's ``kOptimal``
#: -> ``optimal``, ``kTimeLimit`` and the other limits -> ``user_limit``, ...) to ours.
#: The model is always feasible (all ``y = 0``) and bounded, so every other status is
#: an error; :func:`_map_status` falls back to ``ERROR`` for statuses missing here.
_STATUS_TABLE: Mapping[str, ExactStatus] = {
    "optimal": ExactStatus.OPTIMAL,
    "user_limit": ExactStatus.TIME_LIMIT,  # the only limit we set is time_limit
    "optimal_inaccurate": ExactStatus.ERROR,
    "infeasible": ExactStatus.ERROR,
    "infeasible_inaccurate": ExactStatus.ERROR,
    "unbounded": ExactStatus.ERROR,
    "unbounded_inaccurate": ExactStatus.ERROR,
    "infeasible_or_unbounded": ExactStatus.ERROR,
    "solver_error": ExactStatus.ERROR,
    "unknown": ExactStatus.ERROR,
}


def _map_status(status: str | None) -> ExactStatus:
    return _STATUS_TABLE.get(status, ExactStatus.ERROR) if status else ExactStatus.ERROR


class _InternalError(RuntimeError):
    """A broken invariant of the solver (a bug, never bad input)."""


@dataclass(frozen=True, eq=False)
class ExactResult:
    """The outcome of :func:`solve_exact` (frozen).

    Attributes
    ----------
    status : ExactStatus
        ``OPTIMAL`` only when HiGHS proved it; ``TIME_LIMIT``; ``ERROR``.
    utility : float
        ``assignment.utility(mission)``, recomputed from the assignment.
    bound : float
        A proven upper bound on the optimum (``>= utility``).
    gap : float
        ``(bound - utility) / max(bound, 1e-12)``.
    total_utility : float
        The mission's total utility (every task done).
    assignment : Assignment
        The best assignment found; always valid for the mission.
    seconds : float
        Wall-clock time of the whole call (presolve, model build, compilation, solve,
        recovery).
    formulation : str
        ``"aggregated"`` or ``"assignment"``.
    """

    status: ExactStatus
    utility: float
    bound: float
    gap: float
    total_utility: float
    assignment: Assignment
    seconds: float
    formulation: str

    def __post_init__(self) -> None:
        if not isinstance(self.status, ExactStatus):
            raise MissionTypeError(
                f"status: must be a cfopt.ExactStatus, got {type(self.status).__name__}"
            )
        for name in ("utility", "bound", "gap", "total_utility", "seconds"):
            require_number(name, getattr(self, name), finite=False)
        require_assignment(self.assignment)
        require_choice("formulation", self.formulation, FORMULATIONS)

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """The ``cfopt solve --json`` object for this result."""
        require_mission(mission)
        return {
            "status": self.status.value,
            "utility": self.utility,
            "bound": self.bound,
            "gap": self.gap,
            "total_utility": self.total_utility,
            "seconds": self.seconds,
            "formulation": self.formulation,
            "assignment": self.assignment.to_dict(mission)["assignment"],
        }


def solve_exact(
    mission: Mission,
    *,
    time_limit: float | None = None,
    formulation: Formulation = "aggregated",
    mip_gap: float = 0.0,
) -> ExactResult:
    """The optimal assignment of a mission, by integer programming (HiGHS).

    Parameters
    ----------
    mission : Mission
    time_limit : float, optional
        Seconds (at most :data:`MAX_TIME_LIMIT`) the whole call may take: presolve,
        grouping, model building (and cvxpy's compilation for the assignment model), HiGHS
        and recovery.  The call returns
        within ``time_limit + TIME_LIMIT_SLACK`` (0.25 s; see the Notes for when it can
        take longer), apart from the first call in a process, which imports highspy
        (about 0.1 s; cvxpy, about a second, for the assignment model) before its clock
        starts.  When the time runs out the result has status ``time_limit``, the best
        incumbent (possibly the empty assignment) and HiGHS's proven dual bound (the
        total of the tasks presolve kept when HiGHS had none or never ran).  Default: no
        limit.
    formulation : {"aggregated", "assignment"}, default "aggregated"
        The grouped capability-type model (small: at most ``m' + |K| S'`` variables, one
        per task group and per type-service pair) or the per-robot model (``n'`` times
        the number of slots variables), see the module docstring.
    mip_gap : float, default 0.0
        HiGHS's relative MIP gap (``mip_rel_gap``); its absolute gap
        (``mip_abs_gap``) is always set to 0.  HiGHS's defaults (1e-4, 1e-6) are not
        zero; with the default 0 here ``optimal`` means proven optimal.  With
        ``mip_gap > 0``, ``optimal`` means proven within that relative gap, and
        ``gap`` says how close the proof came.

    Returns
    -------
    ExactResult
        Its ``utility`` is ``assignment.utility(mission)`` recomputed from scratch; it
        is checked against the ILP objective (to 1e-9 of the larger of the objective and
        the largest kept utility) and a mismatch raises ``RuntimeError`` (a bug, not a
        result).

    Raises
    ------
    MissionError
        For a bad ``time_limit``, ``formulation`` or ``mip_gap``.

    Notes
    -----
    *Presolve.*  Before any model is built, tasks that cannot or need not be done are
    dropped: tasks with utility 0, tasks that need a service no robot has (or more
    robots for a service than have it, or more robots in all than there are), and then
    robots that have none of the services the remaining tasks require, and services
    no remaining task requires.  Dropped tasks earn nothing in every assignment worth
    having, so the optimum is unchanged.  A mission left empty (no robots or no tasks)
    is solved without calling HiGHS: the empty assignment, proven optimal.

    *Grouping.*  The aggregated model merges services that exactly the same robots
    have, and tasks with equal (merged) requirements and equal utility, into one
    integer variable per group (see the module docstring); these are reformulations,
    not relaxations: every assignment's utility is a feasible objective value of the
    grouped model and back, so its optimum and its bound are the ungrouped model's.
    A group doing ``z`` of its tasks does its lowest-indexed ``z``.  On the seed's
    family at 100,000 robots and 50,000 tasks this leaves 7,000 to 18,000 task
    columns (one per distinct requirement vector and utility in 1..50), or a few
    hundred when every robot has every service; HiGHS would otherwise spend most of
    its time finding these duplicates itself.

    *Time limit.*  With a ``time_limit`` the model is built (and compiled by cvxpy for
    the assignment model), solved and recovered in a worker thread while the caller
    waits until 0.05 s past the deadline.  The worker checks the deadline between
    stages, and HiGHS gets only the time that is left, less a reserve (0.02 s plus 2 s
    per million variables) for the hand-over to HiGHS, HiGHS's own overrun and the
    recovery.  When the deadline passes before HiGHS can start, or before the worker
    hands its result over, the result is an honest ``time_limit``: the empty assignment
    and the total of the kept tasks as the bound.  HiGHS checks its clock only now and
    then (its presolve of the per-robot model with a million variables overran a 5 s
    limit by a minute, which is why that model is solved without presolve, which also
    solves it faster; its presolve of the grouped model of a 100,000-robot mission,
    a few seconds, is not interrupted either: a shorter limit there gives the empty
    ``time_limit`` result), and it cannot be stopped from outside: an abandoned run
    goes on in the background until its next clock check.  HiGHS runs one at a time per process
    (a later call waits for it within its own time limit), and the interpreter's exit
    waits for a run in progress.  ``TIME_LIMIT_SLACK`` (0.25 s) covers the wait past the
    deadline and the final checks on an ordinary machine.  It can be exceeded on a
    heavily loaded machine, and with models of a million variables or more (the
    per-robot model of a large mission): some steps of cvxpy's compilation and of its
    hand-over to HiGHS hold Python's global interpreter lock for up to about 0.7 s at
    that size, and the caller cannot return before such a step ends (its own worker's,
    or one of a run an earlier call abandoned).

    *Scaling.*  HiGHS treats costs from 1e20 up as infinite and uses absolute
    tolerances of about 1e-6, so it is given the utilities times ``2**k``, the power of
    two that puts the largest kept utility in ``[2**19, 2**20)`` (exact in floating
    point: only the exponents change, except that utilities below about 1e-314 of
    the largest lose digits or underflow to zero).  The objective, the bound and the
    agreement checks are scaled back.  HiGHS then tells apart assignments whose
    utilities differ by more than about 1e-12 of the largest kept utility (2e-12 at
    most): smaller improvements (for instance a task worth 1e-300 beside one worth 1)
    are below what it can prove, and ``optimal`` means optimal to that precision.
    When the utilities are integers (as generated missions' are), HiGHS exploits the
    integral objective and the optimum is exact.

    *Honesty.*  ``optimal`` is reported only when HiGHS reports ``kOptimal``.  The
    bound is HiGHS's ``mip_dual_bound`` (clamped to ``[utility, total of the kept
    tasks]``; the latter when HiGHS has no bound yet).

    *Recovery.*  The aggregated model's integral ``z`` (rounded to the nearest
    integer: HiGHS holds it to within 1e-6) chooses the tasks; they are turned into
    robots by an integral max-flow source -> type -> service class -> sink (sink
    capacities: the chosen tasks' demands, warm-started from HiGHS's flow), each
    class's flow is split among its services by the north-west corner rule, then
    each type's robots (in index order) take their services' slots and each
    service's robots fill the chosen tasks' slots in task order.  The
    assignment model's robots in slots of tasks it did not choose, and robots beyond a
    slot's requirement (the lowest indices are kept), are unassigned.

    Complexity: grouping and building the aggregated model is O(n S + m S log m) with
    numpy; HiGHS's branch and bound is exponential in the worst case (the problem is
    NP-hard), fast in practice on the seed's family; recovery is one max-flow on ``|K| +
    S'`` nodes plus O(n S + m S).  The assignment model has O(n m S) variables, and
    cvxpy's compilation costs about a microsecond per variable.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays(
    ...     [[1, 0], [1, 1], [0, 1]],  # r0 surveys, r1 surveys and lifts, r2 lifts
    ...     [[2, 0], [1, 1], [0, 1]],  # t0: 2 survey; t1: survey + lift; t2: lift
    ...     [5.0, 4.0, 3.0])
    >>> res = cfopt.solve_exact(m)
    >>> res.status.value, res.utility, res.bound, res.gap
    ('optimal', 8.0, 8.0, 0.0)
    >>> res.assignment.to_dict(m)["assignment"]  # doctest: +NORMALIZE_WHITESPACE
    [{'robot': 'r0', 'task': 't0', 'service': 's0'},
     {'robot': 'r1', 'task': 't0', 'service': 's0'},
     {'robot': 'r2', 'task': 't2', 'service': 's1'}]
    >>> cfopt.solve_exact(m, formulation="assignment").utility
    8.0
    >>> huge = cfopt.Mission.from_arrays([[1]], [[1], [1]], [1e308, 5e307])  # one robot
    >>> cfopt.solve_exact(huge).utility
    1e+308
    """
    start = time.perf_counter()
    require_mission(mission)
    time_limit, formulation, mip_gap = _check_options(time_limit, formulation, mip_gap)
    # One-time imports (cvxpy: about a second; highspy: about 0.1 s), not the solve's time.
    if formulation == "assignment":
        import cvxpy  # noqa: F401
    else:
        import highspy  # noqa: F401
    start = time.perf_counter()
    clock = _Clock(None if time_limit is None else start + time_limit)
    reduced = _presolve(mission)
    if reduced.n_tasks == 0 or reduced.n_robots == 0:
        outcome = _Outcome(ExactStatus.OPTIMAL, None, 0.0, 0.0)
    else:
        core = _aggregated_core if formulation == "aggregated" else _assignment_core
        outcome = _run(core, reduced, clock, mip_gap)
    assignment = _lift(mission, reduced, outcome.task, outcome.service)
    utility = assignment.utility(mission)
    if not _agrees(utility, outcome.objective):
        raise _InternalError(
            f"solve_exact({formulation}): the recovered assignment earns {utility!r}, "
            f"the ILP objective is {outcome.objective!r}"
        )
    bound = _final_bound(outcome, utility, math.fsum(reduced.utilities.tolist()), mip_gap)
    return ExactResult(
        status=outcome.status,
        utility=utility,
        bound=bound,
        gap=(bound - utility) / max(bound, _TINY),
        total_utility=mission.total_utility,
        assignment=assignment,
        seconds=time.perf_counter() - start,
        formulation=formulation,
    )


def _final_bound(outcome: _Outcome, utility: float, ceiling: float, mip_gap: float) -> float:
    """HiGHS's bound clamped to ``[utility, ceiling]`` (``ceiling`` when it has none)."""
    bound = outcome.bound if math.isfinite(outcome.bound) else ceiling
    bound = max(utility, min(bound, ceiling))
    if outcome.status is ExactStatus.OPTIMAL and mip_gap == 0.0 and _agrees(bound, utility):
        return utility
    return bound


# ------------------------------------------------------------------------- input
def _check_options(
    time_limit: Any, formulation: Any, mip_gap: Any
) -> tuple[float | None, str, float]:
    if time_limit is not None:
        time_limit = require_number(
            "time_limit",
            time_limit,
            above=0,
            maximum=MAX_TIME_LIMIT,
            what="a number of seconds",
            or_none=True,
        )
    formulation = require_choice("formulation", formulation, FORMULATIONS)
    mip_gap = require_number("mip_gap", mip_gap, minimum=0, below=1, what="a number")
    return time_limit, formulation, mip_gap


# ----------------------------------------------------------------------- presolve
@dataclass(frozen=True, eq=False)
class _Reduced:
    """The mission after presolve: kept rows/columns and the arrays restricted to them."""

    tasks: npt.NDArray[np.intp]  # kept task indices, ascending
    robots: npt.NDArray[np.intp]  # kept robot indices, ascending
    services: npt.NDArray[np.intp]  # kept service columns, ascending
    requirements: npt.NDArray[np.int64]  # (m', S')
    utilities: npt.NDArray[np.float64]  # (m',)
    capabilities: npt.NDArray[np.bool_]  # (n', S')

    @property
    def n_tasks(self) -> int:
        return len(self.tasks)

    @property
    def n_robots(self) -> int:
        return len(self.robots)


def _presolve(mission: Mission) -> _Reduced:
    caps, reqs, utils = mission.capabilities, mission.requirements, mission.utilities
    tasks = np.flatnonzero(utils > 0)
    robots = np.arange(mission.n_robots)
    while True:  # dropping robots can make more tasks impossible; a few rounds at most
        have = caps[robots].sum(axis=0)
        sub = reqs[tasks]
        doable = (sub <= have).all(axis=1) & (sub.sum(axis=1) <= len(robots))
        tasks = tasks[doable]
        services = np.flatnonzero(reqs[tasks].any(axis=0))
        useful = robots[caps[np.ix_(robots, services)].any(axis=1)]
        if len(useful) == len(robots) and doable.all():
            break
        robots = useful
    return _Reduced(
        tasks=tasks,
        robots=robots,
        services=services,
        requirements=reqs[np.ix_(tasks, services)],
        utilities=utils[tasks],
        capabilities=caps[np.ix_(robots, services)],
    )


def _lift(
    mission: Mission,
    reduced: _Reduced,
    task: npt.NDArray[np.int64] | None,
    service: npt.NDArray[np.int64] | None,
) -> Assignment:
    """Map a reduced assignment (indices into the reduced arrays) back to the mission."""
    full_task = np.full(mission.n_robots, UNASSIGNED, dtype=np.int64)
    full_service = np.full(mission.n_robots, UNASSIGNED, dtype=np.int64)
    if task is not None and service is not None:
        on = task >= 0
        full_task[reduced.robots[on]] = reduced.tasks[task[on]]
        full_service[reduced.robots[on]] = reduced.services[service[on]]
    return Assignment(task=full_task, service=full_service)


# ------------------------------------------------------------------ solving helpers
@dataclass(frozen=True)
class _Outcome:
    status: ExactStatus
    task: npt.NDArray[np.int64] | None  # reduced robot -> reduced task (or -1)
    objective: float  # the ILP objective of the returned point (sum of chosen utilities)
    bound: float  # proven upper bound (may be inf: unknown)
    service: npt.NDArray[np.int64] | None = None


#: The time ran out before HiGHS ran or handed an incumbent over: nothing done, no bound.
_OUT_OF_TIME = _Outcome(ExactStatus.TIME_LIMIT, None, 0.0, math.inf)
#: HiGHS failed: nothing done, no bound.
_FAILED = _Outcome(ExactStatus.ERROR, None, 0.0, math.inf)

_Core = Callable[["_Reduced", "_Clock", float], _Outcome]


class _OutOfTime(Exception):
    """The deadline passed before the next stage could start."""


@dataclass(frozen=True)
class _Clock:
    """The call's deadline, a :func:`time.perf_counter` reading (``None``: no limit)."""

    deadline: float | None

    def remaining(self) -> float:
        """Seconds left (``inf`` without a limit; negative once it has passed)."""
        return math.inf if self.deadline is None else self.deadline - time.perf_counter()

    def check(self) -> None:
        """Raise :class:`_OutOfTime` when the deadline has passed."""
        if self.remaining() <= 0.0:
            raise _OutOfTime


def _run(core: _Core, reduced: _Reduced, clock: _Clock, mip_gap: float) -> _Outcome:
    """``core``'s outcome, or :data:`_OUT_OF_TIME` when it is late.

    Without a deadline ``core`` runs here.  With one it runs in a daemon worker thread
    and the caller stops waiting at ``_GRACE`` seconds past the deadline; a late
    worker is abandoned and its result dropped (it stops at its next clock check; the
    interpreter's exit waits only for a HiGHS run in progress, see
    :func:`_close_highs`).  An exception in the worker is re-raised here.
    """
    if clock.deadline is None:
        return _staged(core, reduced, clock, mip_gap)
    box: list[_Outcome | Exception] = []
    worker = threading.Thread(
        target=_work,
        args=(box, core, reduced, clock, mip_gap),
        name="cfopt-solve-exact",
        daemon=True,
    )
    worker.start()
    worker.join(max(clock.remaining() + _GRACE, 0.0))
    if not box:
        return _OUT_OF_TIME
    if isinstance(box[0], Exception):
        raise box[0]
    return box[0]


def _work(
    box: list[_Outcome | Exception],
    core: _Core,
    reduced: _Reduced,
    clock: _Clock,
    mip_gap: float,
) -> None:
    """The worker thread's body: ``core``'s outcome, or its exception, into ``box``."""
    try:
        box.append(_staged(core, reduced, clock, mip_gap))
    except Exception as exc:  # handed to the caller, which re-raises it
        box.append(exc)


def _staged(core: _Core, reduced: _Reduced, clock: _Clock, mip_gap: float) -> _Outcome:
    """``core``'s outcome, or :data:`_OUT_OF_TIME` when a stage finds the deadline past."""
    try:
        clock.check()
        return core(reduced, clock, mip_gap)
    except _OutOfTime:
        return _OUT_OF_TIME


#: HiGHS runs one at a time per process: an abandoned run (see :func:`_run`) must not
#: share the machine, or HiGHS's per-thread scheduler, with the next call's run.
_HIGHS_LOCK = threading.Lock()
#: Set at interpreter exit: no HiGHS run may start after it.
_CLOSED = threading.Event()


def _forget_parent_highs() -> None:
    """Free the HiGHS lock in a forked child.

    The parent's threads, and any HiGHS run in one of them, do not exist in the child,
    so a lock held by one of them at the fork would never be released.
    """
    global _HIGHS_LOCK
    _HIGHS_LOCK = threading.Lock()


os.register_at_fork(after_in_child=_forget_parent_highs)


@atexit.register
def _close_highs() -> None:
    """At interpreter exit, wait for a HiGHS run in progress and let no other start.

    An abandoned worker is a daemon thread, which the interpreter does not wait for;
    one still inside HiGHS's native code must not outlive it (HiGHS's own time limit,
    already past, stops it at its next clock check).
    """
    with _HIGHS_LOCK:
        _CLOSED.set()


#: Held while fd 1 points at ``/dev/null`` for HiGHS's banner (see :func:`_quiet_highs`).
_BANNER_LOCK = threading.Lock()
_banner_printed = False


def _quiet_highs() -> None:
    """Let HiGHS print its banner, once per process, where no one reads it.

    HiGHS writes a copyright banner on standard output from the first ``Highs()``
    built in a process (highspy 1.16 does so in the constructor, before any option can
    be set, and highspy offers no quiet constructor), which would corrupt ``--json``.
    So the first solver of a process, whoever builds it (cfopt's own highspy model or
    cvxpy's HiGHS interface), is preceded by a throw-away ``Highs()`` built with file
    descriptor 1 pointing at ``/dev/null``.  Python's and C's buffers are flushed on
    both sides of the swap, and the lock keeps two threads from swapping at once.
    """
    global _banner_printed
    if _banner_printed:
        return
    with _BANNER_LOCK:
        if _banner_printed:
            return
        import highspy

        with _stdout_to_devnull():
            highspy.Highs()
        _banner_printed = True


@contextlib.contextmanager
def _stdout_to_devnull() -> Iterator[None]:
    """File descriptor 1 points at ``/dev/null`` inside the block (a no-op without one)."""
    import ctypes
    import sys

    with contextlib.suppress(ValueError, OSError):  # a closed or detached sys.stdout
        sys.stdout.flush()
    try:
        saved = os.dup(1)
    except OSError:  # no descriptor 1: nothing to protect
        yield
        return
    libc = ctypes.CDLL(None)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        try:
            yield
        finally:
            libc.fflush(None)  # what C's stdio buffered goes to /dev/null, not the user
            os.dup2(saved, 1)
    finally:
        os.close(devnull)
        os.close(saved)


def _forget_parent_banner_lock() -> None:
    global _BANNER_LOCK
    _BANNER_LOCK = threading.Lock()


os.register_at_fork(after_in_child=_forget_parent_banner_lock)


@contextlib.contextmanager
def _highs_turn(clock: _Clock, reserve: float) -> Iterator[float | None]:
    """Hold :data:`_HIGHS_LOCK`; yields HiGHS's time limit (``None``: no limit).

    Raises :class:`_OutOfTime` when the lock or a positive time limit (the time left
    less ``reserve``) cannot be had before the deadline.
    """
    if clock.deadline is None:
        with _HIGHS_LOCK:
            yield None
        return
    if not _HIGHS_LOCK.acquire(timeout=max(clock.remaining() - reserve, 0.0)):
        raise _OutOfTime
    try:
        seconds = clock.remaining() - reserve
        if seconds <= 0.0 or _CLOSED.is_set():
            raise _OutOfTime
        yield seconds
    finally:
        _HIGHS_LOCK.release()


@dataclass(frozen=True)
class _Run:
    """What HiGHS reported, objective in the scaled units it saw, bound in utility."""

    status: ExactStatus
    has_incumbent: bool
    scaled_objective: float  # the incumbent's objective times 2**shift (0 without one)
    bound: float  # proven upper bound on the utility (inf: unknown)


_HIGHS_FAILED = _Run(ExactStatus.ERROR, False, 0.0, math.inf)


def _highs(
    problem: cp.Problem, *, clock: _Clock, mip_gap: float, shift: int, presolve: bool = True
) -> _Run:
    """Compile ``problem`` with cvxpy, solve it with HiGHS in the time left, read it back.

    The model minimises ``-utility * 2**shift`` so that HiGHS's own sense is ours,
    negated and scaled: its ``mip_dual_bound`` (a lower bound on the minimum) is minus
    our upper bound, scaled.  cvxpy's ``get_problem_data``, ``solve_via_data`` and
    ``invert`` + ``unpack`` are the stages of ``Problem.solve``; calling them one by
    one lets the clock be checked between them (and skips ``unpack_results``'s
    "may be inaccurate" warning on a time limit, which our status already says).
    ``presolve=False`` turns HiGHS's presolve off.
    """
    import cvxpy as cp

    _quiet_highs()
    # cvxpy's SciPy backend compiles these sparse-matrix models faster than its default.
    data, chain, inverse = problem.get_problem_data(
        cp.HIGHS, ignore_dpp=True, canon_backend="SCIPY"
    )
    clock.check()
    size = sum(variable.size for variable in problem.variables())
    options: dict[str, Any] = {"mip_rel_gap": mip_gap, "mip_abs_gap": 0.0}
    if not presolve:
        options["presolve"] = "off"
    with _highs_turn(clock, _RESERVE_BASE + _RESERVE_PER_VARIABLE * size) as seconds:
        if seconds is not None:
            options["time_limit"] = seconds
        try:
            raw = chain.solve_via_data(problem, data, False, False, options)
        except cp.SolverError:
            return _HIGHS_FAILED
    return _read_back(problem, chain.invert(raw, inverse), raw, shift)


def _read_back(problem: cp.Problem, solution: Any, raw: Any, shift: int) -> _Run:
    """HiGHS's status, incumbent and unscaled bound, read back.

    ``solution`` is cvxpy's inverted solution (its point goes into ``problem``'s
    variables), ``raw`` HiGHS's results as cvxpy's ``solve_via_data`` returns them.
    """
    status = _map_status(solution.status)
    info = raw.get("info") if isinstance(raw, dict) else None
    if status is ExactStatus.ERROR or info is None:
        return _HIGHS_FAILED
    problem.unpack(solution)
    has_incumbent = int(info.primal_solution_status) == _HIGHS_SOLUTION_FEASIBLE
    if status is ExactStatus.OPTIMAL and not has_incumbent:
        return _HIGHS_FAILED  # "optimal" without a point
    scaled = -float(info.objective_function_value) if has_incumbent else 0.0
    dual = float(info.mip_dual_bound)
    bound = _unscale(-dual, shift) if math.isfinite(dual) else math.inf
    return _Run(status, has_incumbent, scaled, bound)


def _shift(utilities: npt.NDArray[np.float64]) -> int:
    """The ``k`` for which ``utilities * 2**k`` has its largest in ``[2**19, 2**20)``."""
    return _TOP_EXPONENT - math.frexp(float(utilities.max()))[1]


def _scaled(utilities: npt.NDArray[np.float64], shift: int) -> npt.NDArray[np.float64]:
    """``utilities * 2**shift``, exactly (only tiny values can underflow)."""
    return np.ldexp(utilities, shift)


def _unscale(value: float, shift: int) -> float:
    """``value / 2**shift``; +-inf where that overflows."""
    try:
        return math.ldexp(value, -shift)
    except OverflowError:
        return math.copysign(math.inf, value)


def _chosen(y: cp.Variable, has_incumbent: bool, n_tasks: int) -> npt.NDArray[np.bool_]:
    if not has_incumbent or y.value is None:
        return np.zeros(n_tasks, dtype=bool)
    return np.asarray(y.value).reshape(-1) > 0.5


def _agrees(a: float, b: float, rtol: float = _OBJECTIVE_RTOL, scale: float = 0.0) -> bool:
    """``a == b`` to ``rtol`` of the larger of ``|a|``, ``|b|`` and ``scale``."""
    return a == b or abs(a - b) <= rtol * max(abs(a), abs(b), scale)


def _checked_objective(
    reduced: _Reduced, chosen: npt.NDArray[np.bool_], run: _Run, shift: int
) -> float:
    """The ILP objective at the rounded point, checked against HiGHS's own value.

    The check is in HiGHS's scaled units, to 1e-9 of the larger of the objective and
    the largest utility (``2**20`` scaled): below that HiGHS cannot tell anyway.
    """
    if not run.has_incumbent:
        return 0.0
    utilities = reduced.utilities[chosen]
    expected = math.fsum(_scaled(utilities, shift).tolist())
    if not _agrees(expected, run.scaled_objective, scale=2.0**_TOP_EXPONENT):
        raise _InternalError(
            f"HiGHS reports objective {run.scaled_objective!r} (scaled by 2**{shift}) "
            f"but its integral point earns {expected!r}"
        )
    return math.fsum(utilities.tolist())


# --------------------------------------------------------------- aggregated model
#: HiGHS's model statuses (``HighsModelStatus`` names) to ours, as cvxpy's HiGHS
#: interface maps them (``kOptimal`` -> optimal, the limits -> a time limit, the only
#: limit we set); every other status, and a status missing here, is an error.
_HIGHS_STATUS_TABLE: Mapping[str, ExactStatus] = {
    "kOptimal": ExactStatus.OPTIMAL,
    "kTimeLimit": ExactStatus.TIME_LIMIT,
    "kIterationLimit": ExactStatus.TIME_LIMIT,
    "kSolutionLimit": ExactStatus.TIME_LIMIT,
    "kObjectiveBound": ExactStatus.TIME_LIMIT,
    "kObjectiveTarget": ExactStatus.TIME_LIMIT,
}


def _types(capabilities: npt.NDArray[np.bool_]) -> Types:
    """The capability types (distinct rows of ``capabilities``) and their pairs."""
    return capability_types(capabilities)


@dataclass(frozen=True, eq=False)
class _Grouped:
    """The aggregated model's data after the exact groupings of :mod:`cfopt._exact_groups`.

    Columns of the model: one integer ``z[g]`` per task group (tasks done,
    ``0..multiplicity[g]``), then one continuous ``f[q]`` per (type, service class)
    pair ``q``.
    """

    types: Types
    classes: ServiceClasses
    groups: TaskGroups
    requirements: npt.NDArray[np.int64]  # (G, C): each group's requirements per class
    utilities: npt.NDArray[np.float64]  # (G,)
    pair_kind: npt.NDArray[np.intp]  # (Q,): the (type, class) pairs, sorted
    pair_class: npt.NDArray[np.intp]

    @property
    def n_groups(self) -> int:
        return len(self.utilities)


def _group(reduced: _Reduced) -> _Grouped:
    """Group robots into types, services into classes and tasks into groups."""
    types = _types(reduced.capabilities)
    classes = service_classes(types.kinds)
    merged = classes.merge(reduced.requirements)
    groups = task_groups(merged, reduced.utilities)
    pair_kind, pair_class = np.nonzero(types.kinds[:, classes.representative])
    return _Grouped(
        types=types,
        classes=classes,
        groups=groups,
        requirements=merged[groups.first],
        utilities=reduced.utilities[groups.first],
        pair_kind=pair_kind.astype(np.intp),
        pair_class=pair_class.astype(np.intp),
    )


@dataclass(frozen=True, eq=False)
class _Model:
    """A MIP ``min cost @ x`` s.t. ``row_lower <= A x <= row_upper``, bounds, integrality."""

    cost: npt.NDArray[np.float64]
    col_lower: npt.NDArray[np.float64]
    col_upper: npt.NDArray[np.float64]
    integer: npt.NDArray[np.bool_]
    matrix: sp.csc_array
    row_lower: npt.NDArray[np.float64]
    row_upper: npt.NDArray[np.float64]

    @property
    def n_columns(self) -> int:
        return len(self.cost)


def _grouped_model(grouped: _Grouped, shift: int) -> _Model:
    """The grouped capability-type ILP as arrays for HiGHS.

    Minimise ``-sum_g (u[g] 2**shift) z[g]`` subject to, per type ``k``,
    ``sum_{q of k} f[q] <= cnt[k]`` and, per class ``c``,
    ``sum_{q into c} f[q] - sum_g R[g, c] z[g] >= 0``, with integer
    ``0 <= z[g] <= multiplicity[g]`` and ``f >= 0``.
    """
    n_groups, n_pairs = grouped.n_groups, len(grouped.pair_kind)
    n_kinds, n_classes = len(grouped.types.counts), grouped.classes.n_classes
    need = sp.coo_array(grouped.requirements.T.astype(float))  # class x group
    rows = np.concatenate((grouped.pair_kind, n_kinds + grouped.pair_class, n_kinds + need.row))
    cols = np.concatenate((n_groups + np.arange(n_pairs), n_groups + np.arange(n_pairs), need.col))
    values = np.concatenate((np.ones(2 * n_pairs), -need.data))
    matrix = sp.csc_array((values, (rows, cols)), shape=(n_kinds + n_classes, n_groups + n_pairs))
    return _Model(
        cost=np.concatenate((-_scaled(grouped.utilities, shift), np.zeros(n_pairs))),
        col_lower=np.zeros(n_groups + n_pairs),
        col_upper=np.concatenate(
            (grouped.groups.multiplicity.astype(float), np.full(n_pairs, math.inf))
        ),
        integer=np.arange(n_groups + n_pairs) < n_groups,
        matrix=matrix,
        row_lower=np.concatenate((np.full(n_kinds, -math.inf), np.zeros(n_classes))),
        row_upper=np.concatenate(
            (grouped.types.counts.astype(float), np.full(n_classes, math.inf))
        ),
    )


def _highs_direct(
    model: _Model, *, clock: _Clock, mip_gap: float, shift: int
) -> tuple[_Run, npt.NDArray[np.float64] | None]:
    """Solve ``model`` with highspy in the time left: HiGHS's report and its point.

    The same contract as :func:`_highs` (the model minimises ``-utility * 2**shift``;
    ``mip_dual_bound`` is minus our bound, scaled), without cvxpy: the arrays go to
    HiGHS as they are.  The point is ``None`` without an incumbent.
    """
    import highspy

    _quiet_highs()
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = model.n_columns, len(model.row_lower)
    lp.col_cost_ = model.cost
    lp.col_lower_, lp.col_upper_ = model.col_lower, model.col_upper
    lp.row_lower_, lp.row_upper_ = model.row_lower, model.row_upper
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = model.matrix.indptr
    lp.a_matrix_.index_ = model.matrix.indices
    lp.a_matrix_.value_ = model.matrix.data
    kinds = (highspy.HighsVarType.kContinuous, highspy.HighsVarType.kInteger)
    lp.integrality_ = [kinds[flag] for flag in model.integer.tolist()]
    if highs.passModel(lp) == highspy.HighsStatus.kError:
        return _HIGHS_FAILED, None
    for name, value in (("mip_rel_gap", mip_gap), ("mip_abs_gap", 0.0)):
        highs.setOptionValue(name, value)
    clock.check()
    reserve = _RESERVE_BASE + _RESERVE_PER_VARIABLE * model.n_columns
    with _highs_turn(clock, reserve) as seconds:
        if seconds is not None:
            highs.setOptionValue("time_limit", seconds)
        if highs.run() == highspy.HighsStatus.kError:
            return _HIGHS_FAILED, None
    status = _HIGHS_STATUS_TABLE.get(highs.getModelStatus().name, ExactStatus.ERROR)
    if status is ExactStatus.ERROR:
        return _HIGHS_FAILED, None
    info = highs.getInfo()
    has_incumbent = int(info.primal_solution_status) == _HIGHS_SOLUTION_FEASIBLE
    if status is ExactStatus.OPTIMAL and not has_incumbent:
        return _HIGHS_FAILED, None  # "optimal" without a point
    scaled = -float(info.objective_function_value) if has_incumbent else 0.0
    dual = float(info.mip_dual_bound)
    bound = _unscale(-dual, shift) if math.isfinite(dual) else math.inf
    point = np.asarray(highs.getSolution().col_value, dtype=float) if has_incumbent else None
    return _Run(status, has_incumbent, scaled, bound), point


def _aggregated_core(reduced: _Reduced, clock: _Clock, mip_gap: float) -> _Outcome:
    """Build, solve and recover the grouped capability-type model (highspy, no cvxpy)."""
    grouped = _group(reduced)
    shift = _shift(reduced.utilities)
    model = _grouped_model(grouped, shift)
    clock.check()
    run, point = _highs_direct(model, clock=clock, mip_gap=mip_gap, shift=shift)
    if run.status is ExactStatus.ERROR:
        return _FAILED
    n_groups = grouped.n_groups
    if point is None:
        done = np.zeros(n_groups, dtype=np.int64)
    else:  # integral within HiGHS's tolerance: the nearest integer, inside the bounds
        done = np.clip(np.rint(point[:n_groups]), 0, grouped.groups.multiplicity)
        done = done.astype(np.int64)
    chosen = grouped.groups.chosen(done)
    objective = _checked_objective(reduced, chosen, run, shift)
    reqs = reduced.requirements
    demand = reqs[chosen].sum(axis=0)
    class_flow = _integral_flow(
        grouped.types.counts,
        grouped.classes.merge(demand.reshape(1, -1))[0],
        grouped.pair_kind,
        grouped.pair_class,
        None if point is None else point[n_groups:],
    )
    try:
        pair_flow = split_class_flow(
            grouped.types,
            grouped.classes,
            grouped.pair_kind,
            grouped.pair_class,
            class_flow,
            demand,
        )
    except ValueError as exc:
        raise _InternalError(str(exc)) from exc
    types = grouped.types
    task, service = _hand_out(
        reqs, chosen, types.which, types.counts, types.pair_kind, types.pair_service, pair_flow
    )
    return _Outcome(run.status, task, objective, run.bound, service)


def _aggregated_problem(
    reduced: _Reduced, types: Types, shift: int
) -> tuple[cp.Problem, cp.Variable, cp.Variable]:
    """The capability-type model in cvxpy, one binary per task, nothing grouped but the
    robots: (problem, ``y`` per task, ``f`` per (type, service) pair).

    The readable statement of the ILP that :func:`_grouped_model` reformulates; the
    tests solve both and compare (see :func:`_aggregated_core_cvxpy`).
    """
    import cvxpy as cp

    m, n_services = reduced.requirements.shape
    n_pairs = len(types.pair_kind)
    ones, columns = np.ones(n_pairs), np.arange(n_pairs)
    by_kind = sp.csr_array((ones, (types.pair_kind, columns)), shape=(len(types.counts), n_pairs))
    by_service = sp.csr_array((ones, (types.pair_service, columns)), shape=(n_services, n_pairs))
    need = sp.csr_array(reduced.requirements.T.astype(float))  # service x task requirements
    y = cp.Variable(m, boolean=True)
    f = cp.Variable(n_pairs, nonneg=True)
    problem = cp.Problem(
        cp.Minimize(-(_scaled(reduced.utilities, shift) @ y)),
        [by_kind @ f <= types.counts.astype(float), by_service @ f >= need @ y],
    )
    return problem, y, f


def _aggregated_core_cvxpy(reduced: _Reduced, clock: _Clock, mip_gap: float) -> _Outcome:
    """The ungrouped capability-type model through cvxpy (the cross-check of
    :func:`_aggregated_core`; not reachable from :func:`solve_exact`)."""
    types = _types(reduced.capabilities)
    shift = _shift(reduced.utilities)
    problem, y, f = _aggregated_problem(reduced, types, shift)
    clock.check()
    run = _highs(problem, clock=clock, mip_gap=mip_gap, shift=shift)
    if run.status is ExactStatus.ERROR:
        return _FAILED
    chosen = _chosen(y, run.has_incumbent, reduced.n_tasks)
    objective = _checked_objective(reduced, chosen, run, shift)
    reqs = reduced.requirements
    lp_flow = np.asarray(f.value).reshape(-1) if run.has_incumbent and f.value is not None else None
    pair_flow = _integral_flow(
        types.counts, reqs[chosen].sum(axis=0), types.pair_kind, types.pair_service, lp_flow
    )
    task, service = _hand_out(
        reqs, chosen, types.which, types.counts, types.pair_kind, types.pair_service, pair_flow
    )
    return _Outcome(run.status, task, objective, run.bound, service)


def _integral_flow(
    counts: npt.NDArray[np.int64],
    demand: npt.NDArray[np.int64],
    pair_kind: npt.NDArray[np.intp],
    pair_service: npt.NDArray[np.intp],
    lp_flow: npt.NDArray[np.float64] | None,
) -> npt.NDArray[np.int64]:
    """An integral flow per (type, service) pair: at most ``counts[k]`` robots out of
    each type, exactly ``demand[s]`` into each service.

    Warm start: the LP's flow, rounded down, is a valid partial flow; an integral
    max-flow (networkx's Edmonds-Karp: few augmenting paths are left) on the residual
    network of the LP's support completes it.  A
    basic LP solution has at most ``|K| + S' - 1`` positive pairs, so this network is
    small, and the LP flow proves that it carries the whole demand.  Should that fail
    (solver tolerances), the max-flow is rerun from zero on every pair.
    """
    if int(demand.sum()) == 0:
        return np.zeros(len(pair_kind), dtype=np.int64)
    if lp_flow is not None:
        support = lp_flow > _SUPPORT_TOL
        initial = np.floor(np.where(support, lp_flow, 0.0) + _SUPPORT_TOL).astype(np.int64)
        flow = _augment(counts, demand, pair_kind, pair_service, support, initial)
        if flow is not None:
            return flow
    everything = np.ones(len(pair_kind), dtype=bool)
    flow = _augment(
        counts, demand, pair_kind, pair_service, everything, np.zeros(len(pair_kind), np.int64)
    )
    if flow is None:
        raise _InternalError(
            f"the ILP's chosen tasks need {int(demand.sum())} robots, "
            "which the capability types cannot supply"
        )
    return flow


def _augment(
    counts: npt.NDArray[np.int64],
    demand: npt.NDArray[np.int64],
    pair_kind: npt.NDArray[np.intp],
    pair_service: npt.NDArray[np.intp],
    usable: npt.NDArray[np.bool_],
    initial: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64] | None:
    """Complete the integral partial flow ``initial`` by a max-flow on its residual
    network over the ``usable`` pairs; ``None`` when the demand cannot be met."""
    n_kinds, n_services = len(counts), len(demand)
    flow = np.maximum(initial, 0)
    if (np.bincount(pair_kind, flow, n_kinds) > counts).any():
        flow = np.zeros_like(flow)  # not a valid start: start from nothing
    supplied = np.bincount(pair_service, flow, n_services).astype(np.int64)
    for s in np.flatnonzero(supplied > demand).tolist():  # trim over-supply
        excess = int(supplied[s] - demand[s])
        for p in np.flatnonzero((pair_service == s) & (flow > 0)).tolist():
            take = min(excess, int(flow[p]))
            flow[p] -= take
            excess -= take
            if excess == 0:
                break
    spare = counts - np.bincount(pair_kind, flow, n_kinds).astype(np.int64)
    short = demand - np.bincount(pair_service, flow, n_services).astype(np.int64)
    if short.sum() > 0:
        graph = nx.DiGraph()
        graph.add_edges_from(
            ("source", ("kind", k), {"capacity": int(spare[k])})
            for k in np.flatnonzero(spare > 0).tolist()
        )
        used = np.flatnonzero(usable)
        # forward: uncapacitated (no capacity attribute); backward: undo up to flow[p]
        graph.add_edges_from(
            (("kind", k), ("service", s))
            for k, s in zip(pair_kind[used].tolist(), pair_service[used].tolist(), strict=True)
        )
        held = np.flatnonzero(flow > 0)
        graph.add_edges_from(
            (("service", s), ("kind", k), {"capacity": c})
            for k, s, c in zip(
                pair_kind[held].tolist(),
                pair_service[held].tolist(),
                flow[held].tolist(),
                strict=True,
            )
        )
        graph.add_edges_from(
            (("service", s), "sink", {"capacity": int(short[s])})
            for s in np.flatnonzero(short > 0).tolist()
        )
        if not graph.has_node("source") or not graph.has_node("sink"):
            return None
        value, extra = nx.maximum_flow(graph, "source", "sink", flow_func=edmonds_karp)
        if value != int(short.sum()):
            return None
        flow = flow.copy()
        for p in np.flatnonzero(usable | (flow > 0)).tolist():
            kind, service = ("kind", int(pair_kind[p])), ("service", int(pair_service[p]))
            flow[p] += extra.get(kind, {}).get(service, 0) - extra.get(service, {}).get(kind, 0)
    ok = (
        (flow >= 0).all()
        and (np.bincount(pair_kind, flow, n_kinds) <= counts).all()
        and (np.bincount(pair_service, flow, n_services) == demand).all()
    )
    return flow if ok else None


def _hand_out(
    reqs: npt.NDArray[np.int64],
    chosen: npt.NDArray[np.bool_],
    which: npt.NDArray[np.intp],
    counts: npt.NDArray[np.int64],
    pair_kind: npt.NDArray[np.intp],
    pair_service: npt.NDArray[np.intp],
    pair_flow: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Concrete robots for an integral type -> service flow.

    Each type's robots, in index order, take their services in service order (as many
    as the flow says); then each service's robots, in index order, fill the chosen
    tasks' slots in task order.
    """
    n_robots, n_services = len(which), reqs.shape[1]
    task = np.full(n_robots, UNASSIGNED, dtype=np.int64)
    service = np.full(n_robots, UNASSIGNED, dtype=np.int64)
    order = np.argsort(which, kind="stable")  # robots grouped by type, index order inside
    starts = np.concatenate(([0], np.cumsum(counts)))
    # pairs are sorted by (kind, service) (np.nonzero order): offsets within each type
    within = np.cumsum(pair_flow) - pair_flow
    within -= within[np.searchsorted(pair_kind, pair_kind)]
    for p in np.flatnonzero(pair_flow).tolist():
        first = starts[pair_kind[p]] + within[p]
        service[order[first : first + pair_flow[p]]] = pair_service[p]
    chosen_tasks = np.flatnonzero(chosen)
    for s in range(n_services):
        performers = np.flatnonzero(service == s)
        slots = np.repeat(chosen_tasks, reqs[chosen_tasks, s])
        if len(performers) != len(slots):
            raise _InternalError(
                f"service {s}: {len(performers)} robots for {len(slots)} slots after max-flow"
            )
        task[performers] = slots
    return task, service


# --------------------------------------------------------------- assignment model
@dataclass(frozen=True, eq=False)
class _Pairs:
    """One ``x`` variable per (robot, slot) the robot can fill; slot = (task, service)."""

    robot: npt.NDArray[np.intp]  # pair -> reduced robot
    slot: npt.NDArray[np.intp]  # pair -> slot
    slot_task: npt.NDArray[np.intp]  # slot l = (task, service), row-major
    slot_service: npt.NDArray[np.intp]


def _pairs(reduced: _Reduced) -> _Pairs:
    """Every (robot, slot) pair where the robot has the slot's service."""
    caps = reduced.capabilities
    slot_task, slot_service = np.nonzero(reduced.requirements)
    robot_parts, slot_parts = [], []
    for s in range(caps.shape[1]):  # S' iterations, each vectorised over robots x slots
        robots_s = np.flatnonzero(caps[:, s])
        slots_s = np.flatnonzero(slot_service == s)
        robot_parts.append(np.repeat(robots_s, len(slots_s)))
        slot_parts.append(np.tile(slots_s, len(robots_s)))
    return _Pairs(np.concatenate(robot_parts), np.concatenate(slot_parts), slot_task, slot_service)


def _assignment_problem(
    reduced: _Reduced, pairs: _Pairs, shift: int
) -> tuple[cp.Problem, cp.Variable, cp.Variable]:
    """The per-robot model: (problem, ``y`` per task, ``x`` per pair)."""
    import cvxpy as cp

    reqs = reduced.requirements
    n_slots, n_pairs = len(pairs.slot_task), len(pairs.robot)
    ones, columns = np.ones(n_pairs), np.arange(n_pairs)
    by_robot = sp.csr_array((ones, (pairs.robot, columns)), shape=(reduced.n_robots, n_pairs))
    by_slot = sp.csr_array((ones, (pairs.slot, columns)), shape=(n_slots, n_pairs))
    slot_need = sp.csr_array(
        (
            reqs[pairs.slot_task, pairs.slot_service].astype(float),
            (np.arange(n_slots), pairs.slot_task),
        ),
        shape=(n_slots, reduced.n_tasks),
    )
    y = cp.Variable(reduced.n_tasks, boolean=True)
    x = cp.Variable(n_pairs, boolean=True)
    problem = cp.Problem(
        cp.Minimize(-(_scaled(reduced.utilities, shift) @ y)),
        [by_robot @ x <= 1.0, by_slot @ x >= slot_need @ y],
    )
    return problem, y, x


def _assignment_core(reduced: _Reduced, clock: _Clock, mip_gap: float) -> _Outcome:
    """Build, solve and recover the per-robot model, checking ``clock`` between."""
    pairs = _pairs(reduced)
    clock.check()
    shift = _shift(reduced.utilities)
    problem, y, x = _assignment_problem(reduced, pairs, shift)
    clock.check()
    # HiGHS's presolve finds nothing to remove in this model, costs most of the solve
    # time and checks the clock rarely (a minute past a 5 s limit with 10^6 variables).
    run = _highs(problem, clock=clock, mip_gap=mip_gap, shift=shift, presolve=False)
    if run.status is ExactStatus.ERROR:
        return _FAILED
    chosen = _chosen(y, run.has_incumbent, reduced.n_tasks)
    objective = _checked_objective(reduced, chosen, run, shift)
    x_value = np.asarray(x.value).reshape(-1) if run.has_incumbent and x.value is not None else None
    task, service = _seated(reduced, pairs, chosen, x_value)
    return _Outcome(run.status, task, objective, run.bound, service)


def _seated(
    reduced: _Reduced,
    pairs: _Pairs,
    chosen: npt.NDArray[np.bool_],
    x_value: npt.NDArray[np.float64] | None,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Each robot's (task, service) from HiGHS's ``x``, keeping only useful robots."""
    task = np.full(reduced.n_robots, UNASSIGNED, dtype=np.int64)
    service = np.full(reduced.n_robots, UNASSIGNED, dtype=np.int64)
    if x_value is None:
        return task, service
    picked = np.flatnonzero(x_value > 0.5)
    # Keep only robots in slots of chosen tasks: the others earn nothing in the ILP.
    picked = picked[chosen[pairs.slot_task[pairs.slot[picked]]]]
    # ... and only the first req[j, s] robots (by index) of each slot: no surplus.
    picked = picked[np.lexsort((pairs.robot[picked], pairs.slot[picked]))]
    slots = pairs.slot[picked]
    first = np.searchsorted(slots, slots)  # picked is sorted by slot
    rank = np.arange(len(picked)) - first
    need = reduced.requirements[pairs.slot_task[slots], pairs.slot_service[slots]]
    picked = picked[rank < need]
    robots = pairs.robot[picked]
    if len(np.unique(robots)) != len(robots):
        raise _InternalError("HiGHS's point gives some robot two slots")
    task[robots] = pairs.slot_task[pairs.slot[picked]]
    service[robots] = pairs.slot_service[pairs.slot[picked]]
    return task, service
