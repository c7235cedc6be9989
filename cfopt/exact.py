"""The exact optimum: the ST-MR-IA-with-services ILP in cvxpy, solved by HiGHS.

Two formulations of the same integer program (``algorithms.md`` §1):

``"aggregated"`` (the default)
    Binary ``y[j]`` per task and a continuous flow ``f[k, s]`` from each *capability
    type* ``k`` (a distinct service set, ``cnt[k]`` robots) to each service ``s`` it
    has: maximise ``sum_j u[j] y[j]`` subject to ``sum_s f[k, s] <= cnt[k]`` and
    ``sum_k f[k, s] >= sum_j req[j, s] y[j]``.  For integral ``y`` the flow part is a
    transportation polytope with integral data, so an integral flow with the same
    ``y`` exists; it is recovered by an integral max-flow (networkx) and the slots are
    handed to concrete robots.
``"assignment"`` (the cross-check)
    Binary ``x[i, j, s]`` per robot ``i`` having ``s`` and slot ``(j, s)``, binary
    ``y[j]``: at most one slot per robot, ``sum_i x[i, j, s] >= req[j, s] y[j]``.

Both are built from a handful of sparse matrix constraints (never a Python loop over
the variables) and solved with ``solver=cvxpy.HIGHS``.
"""

from __future__ import annotations

import enum
import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import networkx as nx
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from networkx.algorithms.flow import edmonds_karp

from cfopt.assignment import UNASSIGNED, Assignment
from cfopt.errors import MissionError, describe
from cfopt.mission import Mission, require_mission

if TYPE_CHECKING:  # cvxpy takes a second or two to import: only solve_exact pays for it
    import cvxpy as cp

__all__ = ["FORMULATIONS", "ExactResult", "ExactStatus", "solve_exact"]

#: The formulations :func:`solve_exact` accepts.
FORMULATIONS = ("aggregated", "assignment")

#: ``gap`` divides by ``max(bound, _TINY)`` (interface.md §3).
_TINY = 1e-12
#: The reported utility must equal the ILP objective to this relative precision.
_OBJECTIVE_RTOL = 1e-9
#: LP flows above this count as used; LP flows are rounded down after adding it.
_SUPPORT_TOL = 1e-6
#: HiGHS's ``primal_solution_status`` value meaning "a feasible solution is held".
_HIGHS_SOLUTION_FEASIBLE = 2

Formulation = Literal["aggregated", "assignment"]


class ExactStatus(enum.Enum):
    """What :func:`solve_exact` proved."""

    #: HiGHS proved the returned assignment optimal (within ``mip_gap``, 0 by default).
    OPTIMAL = "optimal"
    #: The time limit stopped HiGHS: the assignment is the best incumbent found (the
    #: empty assignment when none was found) and ``bound`` the proven upper bound.
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
        Wall-clock time of the whole call (model build, solve, recovery).
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

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """The ``cfopt solve --json`` object (interface.md §3) for this result."""
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
    """The optimal assignment of a mission, by integer programming (HiGHS via cvxpy).

    Parameters
    ----------
    mission : Mission
    time_limit : float, optional
        Seconds HiGHS may spend (model building and recovery come on top).  When it
        runs out the result has status ``time_limit``, the best incumbent (possibly
        the empty assignment) and HiGHS's proven dual bound.  Default: no limit.
    formulation : {"aggregated", "assignment"}, default "aggregated"
        The capability-type model (small: ``m' + |K| S'`` variables) or the per-robot
        model (``n'`` times the number of slots variables), see the module docstring.
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
        is checked against the ILP objective (to 1e-9 relative) and a mismatch raises
        ``RuntimeError`` (a bug, not a result).

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

    *Honesty.*  ``optimal`` is reported only when HiGHS reports ``kOptimal``.  The
    bound is HiGHS's ``mip_dual_bound`` (clamped to ``[utility, total of the kept
    tasks]``; the latter when HiGHS has no bound yet).  HiGHS prunes with its
    ``mip_feasibility_tolerance`` (1e-6), so improvements smaller than about 1e-6 in
    absolute utility are below what it can prove.

    *Recovery.*  The aggregated model's integral ``y`` is turned into robots by an
    integral max-flow source -> type -> service -> sink (sink capacities: the chosen
    tasks' demands), then each type's robots (in index order) take their services'
    slots and each service's robots fill the chosen tasks' slots in task order.  The
    assignment model's robots in slots of tasks it did not choose, and robots beyond a
    slot's requirement (the lowest indices are kept), are unassigned.

    Complexity: building the aggregated model is O(n S + m S) with numpy; HiGHS's
    branch and bound is exponential in the worst case (the problem is NP-hard), fast
    in practice on the seed's family; recovery is one max-flow on ``|K| + S'`` nodes
    plus O(n + m S).  The assignment model has O(n m S) variables.

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
    """
    import cvxpy  # noqa: F401  (a one-time import of about a second: not the solve's time)

    start = time.perf_counter()
    require_mission(mission)
    time_limit, formulation, mip_gap = _check_options(time_limit, formulation, mip_gap)
    reduced = _presolve(mission)
    if reduced.n_tasks == 0 or reduced.n_robots == 0:
        outcome = _Outcome(ExactStatus.OPTIMAL, None, 0.0, 0.0)
    else:
        build = _aggregated_core if formulation == "aggregated" else _assignment_core
        outcome = build(reduced, time_limit=time_limit, mip_gap=mip_gap)
    assignment = _lift(mission, reduced, outcome.task, outcome.service)
    utility = assignment.utility(mission)
    if not _agrees(utility, outcome.objective):
        raise _InternalError(
            f"solve_exact({formulation}): the recovered assignment earns {utility!r}, "
            f"the ILP objective is {outcome.objective!r}"
        )
    ceiling = math.fsum(reduced.utilities.tolist())
    bound = outcome.bound if math.isfinite(outcome.bound) else ceiling
    bound = max(utility, min(bound, ceiling))
    if outcome.status is ExactStatus.OPTIMAL and mip_gap == 0.0:
        bound = utility if _agrees(bound, utility, 1e-9) else bound
    gap = (bound - utility) / max(bound, _TINY)
    return ExactResult(
        status=outcome.status,
        utility=utility,
        bound=bound,
        gap=gap,
        total_utility=mission.total_utility,
        assignment=assignment,
        seconds=time.perf_counter() - start,
        formulation=formulation,
    )


# ------------------------------------------------------------------------- input
def _check_options(
    time_limit: Any, formulation: Any, mip_gap: Any
) -> tuple[float | None, str, float]:
    if time_limit is not None:
        if (
            isinstance(time_limit, bool)
            or not isinstance(time_limit, int | float)
            or not math.isfinite(time_limit)
            or time_limit <= 0
        ):
            raise MissionError(
                f"time_limit: must be a finite number of seconds > 0 or None, "
                f"got {describe(time_limit)}"
            )
        time_limit = float(time_limit)
    if formulation not in FORMULATIONS:
        raise MissionError(
            f"formulation: must be one of {', '.join(FORMULATIONS)}, got {describe(formulation)}"
        )
    if (
        isinstance(mip_gap, bool)
        or not isinstance(mip_gap, int | float)
        or not (0.0 <= mip_gap < 1.0)
    ):
        raise MissionError(f"mip_gap: must be a number in [0, 1), got {describe(mip_gap)}")
    return time_limit, str(formulation), float(mip_gap)


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


def _highs(
    problem: cp.Problem, *, time_limit: float | None, mip_gap: float
) -> tuple[ExactStatus, bool, float, float]:
    """Solve with HiGHS; returns (status, has incumbent, objective, proven upper bound).

    The model minimises ``-utility`` so that HiGHS's own sense is ours, negated: its
    ``mip_dual_bound`` (a lower bound on the minimum) is minus our upper bound.
    """
    import cvxpy as cp

    options: dict[str, Any] = {"mip_rel_gap": mip_gap, "mip_abs_gap": 0.0}
    if time_limit is not None:
        options["time_limit"] = time_limit
    try:
        with warnings.catch_warnings():
            # cvxpy warns "Solution may be inaccurate" on a time limit; the status says so.
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.HIGHS, ignore_dpp=True, warm_start=False, **options)
    except cp.SolverError:
        return ExactStatus.ERROR, False, 0.0, math.inf
    status = _map_status(problem.status)
    info = problem.solver_stats.extra_stats if problem.solver_stats else None
    if status is ExactStatus.ERROR or info is None:
        return ExactStatus.ERROR, False, 0.0, math.inf
    has_incumbent = int(info.primal_solution_status) == _HIGHS_SOLUTION_FEASIBLE
    objective = -float(info.objective_function_value) if has_incumbent else 0.0
    dual = float(info.mip_dual_bound)
    bound = -dual if math.isfinite(dual) else math.inf
    if status is ExactStatus.OPTIMAL and not has_incumbent:
        return ExactStatus.ERROR, False, 0.0, math.inf  # "optimal" without a point
    return status, has_incumbent, objective, bound


def _chosen(y: cp.Variable, has_incumbent: bool, n_tasks: int) -> npt.NDArray[np.bool_]:
    if not has_incumbent or y.value is None:
        return np.zeros(n_tasks, dtype=bool)
    return np.asarray(y.value).reshape(-1) > 0.5


def _agrees(a: float, b: float, rtol: float = _OBJECTIVE_RTOL) -> bool:
    return a == b or abs(a - b) <= rtol * max(abs(a), abs(b))


def _checked_objective(reduced: _Reduced, chosen: npt.NDArray[np.bool_], solver: float) -> float:
    """The ILP objective at the rounded point, checked against HiGHS's own value."""
    objective = math.fsum(reduced.utilities[chosen].tolist())
    if not _agrees(objective, solver):
        raise _InternalError(
            f"HiGHS reports objective {solver!r} but its integral point earns {objective!r}"
        )
    return objective


# --------------------------------------------------------------- aggregated model
def _aggregated_core(reduced: _Reduced, *, time_limit: float | None, mip_gap: float) -> _Outcome:
    import cvxpy as cp

    reqs, utils = reduced.requirements, reduced.utilities
    m, n_services = reqs.shape
    kinds, which = np.unique(reduced.capabilities, axis=0, return_inverse=True)
    which = which.reshape(-1)
    counts = np.bincount(which, minlength=len(kinds))
    pair_kind, pair_service = np.nonzero(kinds)  # one flow variable per (type, service)
    n_pairs = len(pair_kind)
    ones = np.ones(n_pairs)
    columns = np.arange(n_pairs)
    by_kind = sp.csr_array((ones, (pair_kind, columns)), shape=(len(kinds), n_pairs))
    by_service = sp.csr_array((ones, (pair_service, columns)), shape=(n_services, n_pairs))
    need = sp.csr_array(reqs.T.astype(float))  # service x task requirements

    y = cp.Variable(m, boolean=True)
    f = cp.Variable(n_pairs, nonneg=True)
    problem = cp.Problem(
        cp.Minimize(-(utils @ y)),
        [by_kind @ f <= counts.astype(float), by_service @ f >= need @ y],
    )
    status, has_incumbent, solver_objective, bound = _highs(
        problem, time_limit=time_limit, mip_gap=mip_gap
    )
    if status is ExactStatus.ERROR:
        return _Outcome(status, None, 0.0, bound)
    chosen = _chosen(y, has_incumbent, m)
    objective = _checked_objective(reduced, chosen, solver_objective) if has_incumbent else 0.0
    demand = reqs[chosen].sum(axis=0)
    lp_flow = np.asarray(f.value).reshape(-1) if has_incumbent and f.value is not None else None
    pair_flow = _integral_flow(counts, demand, pair_kind, pair_service, lp_flow)
    task, service = _hand_out(reqs, chosen, which, counts, pair_kind, pair_service, pair_flow)
    return _Outcome(status, task, objective, bound, service)


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
def _assignment_core(reduced: _Reduced, *, time_limit: float | None, mip_gap: float) -> _Outcome:
    import cvxpy as cp

    reqs, utils, caps = reduced.requirements, reduced.utilities, reduced.capabilities
    m, n_services = reqs.shape
    n = caps.shape[0]
    slot_task, slot_service = np.nonzero(reqs)  # slot l = (task, service), row-major
    n_slots = len(slot_task)
    robot_parts, slot_parts = [], []
    for s in range(n_services):  # S' iterations, each vectorised over robots x slots
        robots_s = np.flatnonzero(caps[:, s])
        slots_s = np.flatnonzero(slot_service == s)
        robot_parts.append(np.repeat(robots_s, len(slots_s)))
        slot_parts.append(np.tile(slots_s, len(robots_s)))
    pair_robot = np.concatenate(robot_parts)
    pair_slot = np.concatenate(slot_parts)
    n_pairs = len(pair_robot)
    ones = np.ones(n_pairs)
    columns = np.arange(n_pairs)
    by_robot = sp.csr_array((ones, (pair_robot, columns)), shape=(n, n_pairs))
    by_slot = sp.csr_array((ones, (pair_slot, columns)), shape=(n_slots, n_pairs))
    slot_need = sp.csr_array(
        (reqs[slot_task, slot_service].astype(float), (np.arange(n_slots), slot_task)),
        shape=(n_slots, m),
    )

    y = cp.Variable(m, boolean=True)
    x = cp.Variable(n_pairs, boolean=True)
    problem = cp.Problem(
        cp.Minimize(-(utils @ y)),
        [by_robot @ x <= 1.0, by_slot @ x >= slot_need @ y],
    )
    status, has_incumbent, solver_objective, bound = _highs(
        problem, time_limit=time_limit, mip_gap=mip_gap
    )
    if status is ExactStatus.ERROR:
        return _Outcome(status, None, 0.0, bound)
    chosen = _chosen(y, has_incumbent, m)
    objective = _checked_objective(reduced, chosen, solver_objective) if has_incumbent else 0.0
    task = np.full(n, UNASSIGNED, dtype=np.int64)
    service = np.full(n, UNASSIGNED, dtype=np.int64)
    if has_incumbent and x.value is not None:
        picked = np.flatnonzero(np.asarray(x.value).reshape(-1) > 0.5)
        # Keep only robots in slots of chosen tasks: the others earn nothing in the ILP.
        picked = picked[chosen[slot_task[pair_slot[picked]]]]
        # ... and only the first req[j, s] robots (by index) of each slot: no surplus.
        picked = picked[np.lexsort((pair_robot[picked], pair_slot[picked]))]
        slots = pair_slot[picked]
        first = np.searchsorted(slots, slots)  # picked is sorted by slot
        rank = np.arange(len(picked)) - first
        picked = picked[rank < reqs[slot_task[slots], slot_service[slots]]]
        robots = pair_robot[picked]
        if len(np.unique(robots)) != len(robots):
            raise _InternalError("HiGHS's point gives some robot two slots")
        task[robots] = slot_task[pair_slot[picked]]
        service[robots] = slot_service[pair_slot[picked]]
    return _Outcome(status, task, objective, bound, service)
