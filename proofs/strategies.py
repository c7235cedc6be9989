"""Hypothesis strategies for missions and assignments (needs the ``test`` extra).

Every strategy takes keyword-only, typed, bounded arguments, checks them when it is
called (not when it is drawn from), and shrinks towards small missions: fewer robots,
tasks and services, requirements of 1, robots that can do nothing, unassigned robots.

>>> from hypothesis import given, settings
>>> import proofs
>>> @settings(max_examples=5, database=None)
... @given(achievable_missions(max_robots=6))
... def test(m):
...     assert m.requirements.sum() <= m.n_robots
>>> test()
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import strategies as st

from cfopt import Assignment, Mission
from cfopt.checks import require_bool, require_int, require_mission, require_number
from proofs._dynamics import best_response

__all__ = ["achievable_missions", "assignments", "missions", "near_stable_assignments"]

_MAX_ROBOTS = 200
_MAX_TASKS = 100
_MAX_SERVICES = 20


def _bounded(name: str, value: Any, low: int, high: int) -> int:
    return require_int(name, value, minimum=low, maximum=high)


def _range(name: str, low: Any, high: Any, floor: int, ceiling: int) -> tuple[int, int]:
    low = _bounded(f"min_{name}", low, floor, ceiling)
    high = _bounded(f"max_{name}", high, floor, ceiling)
    if low > high:
        raise ValueError(f"min_{name}: {low} is larger than max_{name}: {high}")
    return low, high


def _fraction(name: str, value: Any, *, low_open: bool, high: float) -> float | None:
    if value is None:
        return None
    low = {"above": 0} if low_open else {"minimum": 0}
    return require_number(name, value, **low, maximum=high, or_none=True)


def missions(
    *,
    min_robots: int = 1,
    max_robots: int = 10,
    min_tasks: int = 1,
    max_tasks: int = 5,
    min_services: int = 1,
    max_services: int = 4,
    max_requirement: int = 3,
    max_utility: int = 50,
    density: float | None = None,
    achievable: bool | None = None,
    load: float | None = None,
) -> st.SearchStrategy[Mission]:
    """Missions under the services model.

    Parameters
    ----------
    min_robots, max_robots : int
        Collective size (0..200; default 1..10).
    min_tasks, max_tasks : int
        Number of tasks (0..100; default 1..5).
    min_services, max_services : int
        Number of service types (1..20; default 1..4).
    max_requirement : int, default 3
        Largest requirement per slot when requirements are drawn freely (1..50).
    max_utility : int, default 50
        Utilities are whole numbers in 1..max_utility (1..10**6).
    density : float, optional
        Probability that a robot has a service, in (0, 1]; default: any capability matrix.
    achievable : bool, optional
        ``True``: a complete assignment exists by construction (as in the seed's family:
        robots are grouped, each picks one of its services, the groups' counts are the
        requirements; needs ``max_robots >= max(min_tasks, 1)``).  ``False``: the tasks
        together need more robots than there are, so no assignment completes them all
        (requirements may then exceed ``max_requirement``).  ``None`` (default): free.
    load : float, optional
        With ``achievable=True``: the share of robots the construction uses, in (0, 1]
        (default drawn).  With ``achievable=False``: total requirement at least
        ``ceil(load * n)``, ``load > 1`` (default: n + 1).  Not allowed otherwise.

    Examples
    --------
    >>> from hypothesis import given, settings
    >>> @settings(max_examples=10, database=None)
    ... @given(missions(achievable=False, max_robots=5))
    ... def test(m):
    ...     assert m.requirements.sum() > m.n_robots
    >>> test()
    """
    lo_n, hi_n = _range("robots", min_robots, max_robots, 0, _MAX_ROBOTS)
    lo_m, hi_m = _range("tasks", min_tasks, max_tasks, 0, _MAX_TASKS)
    lo_s, hi_s = _range("services", min_services, max_services, 1, _MAX_SERVICES)
    max_requirement = _bounded("max_requirement", max_requirement, 1, 50)
    max_utility = _bounded("max_utility", max_utility, 1, 10**6)
    density = _fraction("density", density, low_open=True, high=1.0)
    if achievable is not None:
        require_bool("achievable", achievable)
    if load is not None:
        if achievable is None:
            raise ValueError("load: only meaningful with achievable=True or achievable=False")
        load = _fraction("load", load, low_open=True, high=1.0 if achievable else 1e6)
        if achievable is False and load is not None and load <= 1:
            raise ValueError(f"load: must be > 1 with achievable=False, got {load!r}")
    if achievable is False and hi_m < 1:
        raise ValueError("achievable=False needs max_tasks >= 1 (no task is always achievable)")
    if achievable and hi_n < max(lo_m, 1):
        raise ValueError(
            f"achievable=True needs max_robots >= max(min_tasks, 1) (every task needs a robot), "
            f"got max_robots={hi_n}, min_tasks={lo_m}"
        )
    return _missions(
        lo_n, hi_n, lo_m, hi_m, lo_s, hi_s, max_requirement, max_utility, density, achievable, load
    )


@st.composite
def _missions(
    draw: st.DrawFn,
    lo_n: int,
    hi_n: int,
    lo_m: int,
    hi_m: int,
    lo_s: int,
    hi_s: int,
    max_req: int,
    max_utility: int,
    density: float | None,
    achievable: bool | None,
    load: float | None,
) -> Mission:
    S = draw(st.integers(lo_s, hi_s))
    if achievable:
        n = draw(st.integers(max(lo_n, lo_m, 1), hi_n))
        m = draw(st.integers(max(lo_m, 1), min(hi_m, n)))
    else:
        n = draw(st.integers(lo_n, hi_n))
        m = draw(st.integers(max(lo_m, 1) if achievable is False else lo_m, hi_m))
    caps = np.array(
        [[_capable(draw, density) for _ in range(S)] for _ in range(n)], dtype=bool
    ).reshape(n, S)
    reqs = np.zeros((m, S), dtype=np.int64)
    if achievable:
        used = m if load is None else max(m, min(n, math.ceil(load * n)))
        builders = draw(st.integers(used, n)) if load is None else used
        for i in range(builders):
            # robot i builds task (i for the first m, then any), with one of its services
            j = i if i < m else draw(st.integers(0, m - 1))
            mine = np.flatnonzero(caps[i]).tolist()
            if mine:
                s = draw(st.sampled_from(mine))
            else:
                s = draw(st.integers(0, S - 1))
                caps[i, s] = True
            reqs[j, s] += 1
    else:
        for j in range(m):
            for s in range(S):
                reqs[j, s] = draw(st.integers(0, max_req))
            if not reqs[j].any():
                reqs[j, draw(st.integers(0, S - 1))] = 1
        if achievable is False:
            need = n + 1 if load is None else max(n + 1, math.ceil(load * n))
            while reqs.sum() < need:
                j, s = draw(st.integers(0, m - 1)), draw(st.integers(0, S - 1))
                if reqs[j, s] == 0:
                    s = int(np.flatnonzero(reqs[j])[0])
                reqs[j, s] += need - int(reqs.sum())
    utilities = [draw(st.integers(1, max_utility)) for _ in range(m)]
    return Mission.from_arrays(caps, reqs, np.asarray(utilities, dtype=float).reshape(m))


def _capable(draw: st.DrawFn, density: float | None) -> bool:
    if density is None:
        return draw(st.booleans())
    if density >= 1.0:
        return True
    # shrinks towards 999, i.e. "not capable", like booleans() shrinks to False
    return draw(st.integers(0, 999).map(lambda x: 999 - x)) < round(density * 1000)


def achievable_missions(
    *,
    min_robots: int = 1,
    max_robots: int = 10,
    min_tasks: int = 1,
    max_tasks: int = 5,
    min_services: int = 1,
    max_services: int = 4,
    max_utility: int = 50,
    density: float | None = None,
    load: float | None = None,
) -> st.SearchStrategy[Mission]:
    """Missions with a complete assignment by construction: ``missions(achievable=True)``.

    >>> from hypothesis import given, settings
    >>> import cfopt
    >>> @settings(max_examples=5, database=None)
    ... @given(achievable_missions(load=1.0))
    ... def test(m):
    ...     assert m.requirements.sum() == m.n_robots
    >>> test()
    """
    return missions(
        min_robots=min_robots,
        max_robots=max_robots,
        min_tasks=min_tasks,
        max_tasks=max_tasks,
        min_services=min_services,
        max_services=max_services,
        max_utility=max_utility,
        density=density,
        achievable=True,
        load=load,
    )


def _options(mission: Mission, i: int) -> list[tuple[int, int]]:
    """Robot i's slots in task-then-service order."""
    reqs = mission.requirements
    return [
        (j, s)
        for j in range(mission.n_tasks)
        for s in range(mission.n_services)
        if reqs[j, s] > 0 and mission.capabilities[i, s]
    ]


def assignments(mission: Mission, *, unassigned: bool = True) -> st.SearchStrategy[Assignment]:
    """Valid assignments for ``mission``: each robot on any slot it can perform.

    Parameters
    ----------
    mission : cfopt.Mission
    unassigned : bool, default True
        Allow robots to be unassigned (robots that can do nothing always are).

    Notes
    -----
    Slots may be over-full or short: this is every valid partition.  Shrinks towards
    unassigned robots (or the first slot in task-then-service order).

    Examples
    --------
    >>> from hypothesis import given, settings
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1, 0], [1, 1]], [[2, 1]], [3.0])
    >>> @settings(max_examples=10, database=None)
    ... @given(assignments(m))
    ... def test(a):
    ...     a.validate(m)
    >>> test()
    """
    mission = require_mission(mission)
    return _assignments(mission, require_bool("unassigned", unassigned))


@st.composite
def _assignments(draw: st.DrawFn, mission: Mission, unassigned: bool) -> Assignment:
    task = np.full(mission.n_robots, -1, dtype=np.int64)
    service = np.full(mission.n_robots, -1, dtype=np.int64)
    for i in range(mission.n_robots):
        opts: list[tuple[int, int] | None] = list(_options(mission, i))
        if unassigned or not opts:
            opts.insert(0, None)
        pick = draw(st.sampled_from(opts))
        if pick is not None:
            task[i], service[i] = pick
    return Assignment(task=task, service=service)


def near_stable_assignments(
    mission: Mission, *, capped: bool = False, perturb: bool = True
) -> st.SearchStrategy[Assignment]:
    """A Nash-stable partition of ``mission``, then (optionally) one robot perturbed.

    The stable partition comes from sequential best-response dynamics (the checkers'
    reward, robots visited in a drawn order, from a drawn valid start); the perturbation
    moves one drawn robot to another drawn position (a slot it can perform, or
    unassigned).  Such partitions sit next to stable ones, where pairwise and capped
    violations are found far more often than among arbitrary partitions.

    Parameters
    ----------
    mission : cfopt.Mission
    capped : bool, default False
        Stabilise under capped moves (as Pair-GRAPE-S's first phase does).
    perturb : bool, default True
        Perturb one robot; ``False`` returns the stable partition itself.

    Examples
    --------
    >>> from hypothesis import given, settings
    >>> import cfopt, proofs
    >>> m = cfopt.generate_mission(12, 25, 3, 2, seed=1)
    >>> @settings(max_examples=10, database=None)
    ... @given(near_stable_assignments(m, perturb=False))
    ... def test(a):
    ...     assert proofs.is_nash_stable(m, a)
    >>> test()
    """
    mission = require_mission(mission)
    capped, perturb = require_bool("capped", capped), require_bool("perturb", perturb)
    return _near_stable(mission, capped, perturb)


@st.composite
def _near_stable(draw: st.DrawFn, mission: Mission, capped: bool, perturb: bool) -> Assignment:
    start = draw(_assignments(mission, True))
    order = draw(st.permutations(range(mission.n_robots)))
    stable = best_response(mission, start, capped=capped, order=order)
    if not perturb or mission.n_robots == 0:
        return stable
    i = draw(st.integers(0, mission.n_robots - 1))
    here = None if stable.task[i] < 0 else (int(stable.task[i]), int(stable.service[i]))
    opts = [q for q in [None, *_options(mission, i)] if q != here]
    if not opts:
        return stable
    pick = draw(st.sampled_from(opts))
    task, service = stable.task.copy(), stable.service.copy()
    task[i], service[i] = pick if pick is not None else (-1, -1)
    return Assignment(task=task, service=service)
