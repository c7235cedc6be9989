"""GRAPE-S-Select: hedonic coalition formation that selects the tasks it can complete.

GRAPE-S spreads the robots over every task in proportion to the requirements, so on an
over-subscribed mission (the tasks need more robots than there are) almost every task ends
a few robots short and earns nothing.  GRAPE-S-Select keeps GRAPE-S's dynamics -- robots on
a shared partition, one strictly improving move per round, the distributed mutex -- and
changes what a robot wants: a *needed* place in the most valuable task it can help to
complete, and the collective gives up the tasks that cannot be completed.

Priorities
----------
Let ``N_s`` be the number of robots able to perform service ``s`` and ``D_s = sum_j req[j,
s]`` the demand for it.  Service ``s`` has the *price* ``p_s = max(1, D_s / N_s)`` (an
over-subscribed service costs more than one robot per unit; ``N_s = 0``: ``max(1, D_s)``)
and the *scarcity* ``sigma_s = D_s / max(N_s, 1)``.  Task ``j`` is worth ``w_j = u_j /
sum_s req[j, s] p_s`` -- at load <= 1 every price is 1 and ``w_j`` is the utility per
required robot.  The *priority* ``pi_j`` is the task's position when the tasks are sorted
by ``(w_j, -j)`` in increasing order (``m - 1``: the most valuable task; equal worths
favour the lower index).  A task is *viable* when ``u_j > 0`` and ``req[j, s] <= N_s`` for
every ``s``.  All of this is exact: worths are compared as rationals (floats only pre-sort
them; every near tie is decided by integer cross-multiplication).

State (the shared belief)
-------------------------
The partition ``Pi`` (a slot ``(j, s)`` or unassigned, per robot) and, per task, two bits:
*closed* (the collective has given it up) and *reopened* (its one reopening is used).
Every viable task starts open; the others start closed and reopened.  A robot needs the
mission (every robot's services, the requirements and utilities: priorities and
tie-breaks follow from them) and this belief: ``16 + 4 n`` bytes of GRAPE-S's belief
plus ``ceil(m / 4)`` bytes of task bits.

Reward
------
A task is *alive* when it is complete (every slot holds at least ``req`` robots) or open.
A robot that is one of ``c`` robots in slot ``(j, s)`` of a viable, alive task earns
``(1, pi_j)`` -- *needed* -- when ``c <= req[j, s]``, and ``(0, pi_j)`` -- *surplus* -- when
the slot is over-full; otherwise (unassigned, or the task is closed and incomplete) it
earns ``bot``, below everything.  Rewards compare lexicographically; they are coded as
the integers ``m + pi_j``, ``pi_j`` and ``-1``, so every comparison is exact.  A *move* of
robot ``i`` is to any slot ``(k, t)`` other than its own, ``t`` one of its services; it
earns the reward of ``(k, t)`` recomputed after the move: joining a closed task pays only
if the move completes it.  So a robot prefers any needed place to any surplus one, a
more valuable task to a less valuable one, and a robot with nothing better over-fills a
slot of the most valuable task it can -- which makes every robot of that slot surplus
and sends one that is needed elsewhere there (GRAPE-S's way of finding chains).

Rounds
------
Each round every robot computes, on the shared belief, its best move: the highest
reward; ties (several of its services in the same task) go to the smallest *slack*
``a_t - missing[k, t]`` -- ``a_t`` the number of other robots with service ``t`` whose
reward is below the move's, ``missing`` the robots the slot lacks -- so the robot takes
the place fewest others could take; then to the larger ``sigma_t``; then to the lower
``t``.  It proposes the move if it is strictly better than staying.  As in GRAPE-S the
mutex keeps the proposal of the *last* robot in the order (index order, or a fresh seeded
permutation each round): one move per round.  In a round without a proposal the first
*phase step* that applies is made (every robot can compute every robot's wish on the
shared belief, so every robot knows the round is quiet and computes the same step):

1. **close**: the open, non-empty, incomplete task of lowest priority is closed and all
   its robots are released (unassigned);
2. **reopen**: else, the closed, viable, not yet reopened task needing two robots or more
   of highest priority that the *free* robots can complete is reopened;
3. **exchange** (``exchange=True``): else, the closed, viable, not yet reopened task ``k``
   needing two robots or more of highest utility (then priority) for which complete
   tasks of smaller utility can make room: the complete task ``d`` (needing two robots or
   more) of least utility (then priority) with ``u_d < u_k`` whose robots, with the free
   ones, can complete ``k``; failing one, the shortest prefix of those tasks in
   increasing utility order whose total utility stays below ``u_k`` and that can.  They
   are closed (their robots released) and ``k`` is reopened.

The *free* robots are the unassigned ones plus, for every over-full slot holding ``c >
req`` robots, any ``c - req`` of its robots; "can complete" is an exact matching check
(Hall's condition over the task's services with these group limits).  A closed task
needing one robot is never given up (one robot completes it alone, so it stays joinable):
it is no candidate and no donor.  A round in which no step applies ends the run.

Termination
-----------
Between phase steps the moves terminate: closed tasks needing two robots or more are
empty and no single move completes them, and every other slot pays a reward that depends
on its own count only and does not increase with it -- a singleton congestion game.  Its
Rosenthal potential (with the rewards mapped to reals in order) grows by the mover's gain
with every move, and there are finitely many partitions.  Phase steps are finite: a task
leaves the closed set only by its one reopening, so at most ``2 m`` tasks enter it and at
most ``m`` leave it.

What the run guarantees
-----------------------
When the run ends no open task is non-empty and incomplete, and closed tasks are empty or
complete (needing one robot): every assigned robot works for a complete task.  Then the
partition is **Nash stable under the completion reward**, which depends on the partition
alone: a robot in a slot of a complete task of positive utility earns ``(1, pi_j)`` or
``(0, pi_j)`` as above, every other robot ``bot``; a move (to any slot) earns the same
recomputed after the move.  Every robot earns the same under both rewards and no move
earns more under the completion reward than under the run's, so a partition without an
improving move for the run has none for the completion reward.  The independent checker
:mod:`proofs.select_stability` verifies this on any partition.

Limits
------
Two kinds of missions keep a run well below the optimum; SDA and RACHNA_dt end the same
way on both.

* *The reward's price of stability.*  A robot earns its task's priority, so it leaves a
  complete task to complete a task worth more per robot that lacks one robot: a partition
  in which such a task stays empty is not stable.  With ``n`` identical robots, one task
  needing one robot (``u = 2``) and one needing ``n`` (``u = 1.9 n``), every stable
  partition earns 2 of the optimum ``1.9 n``.  The smallest over-subscribed mission of the
  seed's family where this bites (the claim O2's counterexample) has 5 robots:
  ``generate_mission(5, 50, 5, 5, load=1.25, seed=1)``, where the best stable partition
  earns 42 of 52 (80.8 %).
* *Greedy selection.*  Closing gives tasks up from the least valuable, exchanging trades
  one task for cheaper ones; no step trades several tasks for several.  With ``2 h``
  identical robots, ``X`` needing ``h + 1`` (``u = h + 2``) and ``Y1``, ``Y2`` needing
  ``h`` each (``u = h``), the run keeps ``X``: ``(h + 2) / 2 h`` of the optimum, towards
  one half.  On the seed's family such knapsack effects matter with few tasks (100
  robots, 10 % tasks) and fade with size (``benchmarks/bench_select.py``).

Examples
--------
>>> import cfopt
>>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
>>> run = grape_s_select(m)       # 3 robots, two tasks of 2: only one can be done
>>> run.assignment.task.tolist(), run.assignment.percent_utility(m)
([0, 0, 0], 71.42857142857143)
"""

from __future__ import annotations

import heapq
import math
import time
from collections import defaultdict
from dataclasses import dataclass
from fractions import Fraction
from functools import cmp_to_key

import numpy as np
import numpy.typing as npt

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_bool, require_seed
from heuristics._grape_s_fast import Outcome as _Outcome
from heuristics._run import NO_DEADLINE, Deadline, Run, check_order, moves_run
from heuristics.communication import belief_rounds_table, comm_model, table_cost

__all__ = ["fillable", "grape_s_select", "select_priorities"]

#: Exact matching checks enumerate the subsets of up to this many services; beyond, a
#: max-flow (networkx).
_HALL_BITS = 14
#: Relative width of the float pre-sort's near-tie runs (decided exactly).
_TIE_BAND = 1e-9


def grape_s_select(
    mission: Mission,
    *,
    seed: SeedLike = None,
    order: str = "index",
    exchange: bool = True,
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
) -> Run:
    """Run GRAPE-S-Select (centralized, synchronous, fully connected) on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    seed : None, int or numpy.random.Generator
        Feeds ``numpy.random.default_rng``; only ``order="random"`` draws from it.
    order : {"index", "random"}
        The order in which robots select each round (see :func:`heuristics.grape_s`); the
        mutex keeps the move of the last robot in it that wants to move.
    exchange : bool, default True
        Enable the exchange step (phase 3 of the module notes); ``False`` keeps only the
        close and reopen steps (an ablation).
    medium : {"broadcast", "unicast"}, default "broadcast"
    encoding : {"full", "compact"}, default "full"
        The communication model of ``messages`` and ``bytes`` (Counting below,
        :mod:`heuristics.communication`); recorded in ``options``, and ``communication``
        holds the counts under every model.

    time_limit : float, optional
        Wall-clock seconds after which no further round starts; the run then returns
        the partition reached, ``status`` ``TIME_LIMIT``.

    Returns
    -------
    Run
        ``algorithm="grape-s-select"``.  ``trajectory`` lists the moves and, for close and
        exchange steps, every released robot as ``(iteration, robot, -1, -1)``.

    Notes
    -----
    The module notes define the reward, the tie-breaks, the phase steps, why the run ends
    and why it ends Nash stable under the completion reward (which
    :mod:`proofs.select_stability` checks independently).

    Counting.  ``rounds`` = moves + phase steps + 1 (the last, quiet round);
    ``iterations`` = rounds in which the partition changed (moves, close and exchange
    steps; a reopening changes only the task bits).  Every robot broadcasts its belief to
    its ``n - 1`` neighbours every round: ``messages = rounds n`` transmissions
    (``medium="broadcast"``) or ``rounds n (n - 1)`` messages (``"unicast"``), each ``16 +
    4 n + ceil(m / 4)`` bytes (``encoding="full"``) or ``16 + ceil((n ceil(log2(m S + 1))
    + 2 m) / 8)`` (``"compact"``: slots and task bits packed together).  ``work``
    is in GRAPE-S's unit, slot examinations: every round every robot examines every slot of
    every service it has (``P`` per round, ``rounds * P``); phase steps add what they
    examine -- ``m`` task states per step, one unit per (candidate, donor, service)
    comparison of the necessary conditions, and ``2**b`` per exact matching check of a
    task needing ``b`` services (times the over-full slots it draws on, plus one).

    Complexity.  A round costs O(n + K S) numpy work (``K`` capability types) plus
    O(S log(m S)) heap work and O(req) bookkeeping for the move; a close O(m + req S log(m
    S)); a reopen or exchange search O(c d S) vectorised comparisons for ``c`` candidates
    and ``d`` donors plus O(G b 2**b) per exact check (``G`` over-full slots).  On the
    seed's family the rounds are ``n`` to about ``2 n`` (``4 n`` where closing big tasks
    releases many robots: 1 % tasks, 10:1, load 2) and a whole run at 1000 robots takes
    0.5-1.7 times as long as GRAPE-S (``benchmarks/bench_select.py``).

    Examples
    --------
    Three robots, two tasks needing two each.  The robots fill the more valuable ``t0``
    (robot 2 first: the mutex keeps the last robot in index order); robot 0 starts
    ``t1``, which cannot be completed and is closed, releasing it; with nothing needed
    left it over-fills ``t0`` (a surplus place beats none).

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
    >>> run = grape_s_select(m)
    >>> run.trajectory.tolist()       # (iteration, robot, task, service); -1: released
    [[1, 2, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0], [4, 0, -1, -1], [5, 0, 0, 0]]
    >>> run.iterations, run.rounds, run.messages, run.bytes   # 6 x 3 of 16 + 12 + 1 bytes
    (5, 6, 18, 522)

    On an over-subscribed mission of the seed's family (load 1.5: the tasks need 150
    robots, there are 100):

    >>> m = cfopt.generate_mission(100, 10, 10, 5, load=1.5, seed=1)
    >>> run = grape_s_select(m)
    >>> round(run.assignment.percent_utility(m), 2)
    79.23
    >>> import proofs.select_stability as sel
    >>> sel.is_select_stable(m, run.assignment)
    True
    """
    started = time.perf_counter()
    deadline = Deadline(time_limit, started=started)
    require_mission(mission)
    rng = np.random.default_rng(require_seed("seed", seed))
    check_order(order)
    exchange = require_bool("exchange", exchange)
    comm = comm_model(medium, encoding)
    out = _Engine(mission, order, exchange, rng).run(deadline)
    n, m = mission.n_robots, mission.n_tasks
    table = belief_rounds_table(n, m * mission.n_services, out.rounds, extra_bits=2 * m)
    messages, nbytes = table_cost(table, comm)
    return moves_run(
        "grape-s-select",
        out.task,
        out.service,
        out.moves,
        started=started,
        seed=seed,
        iterations=out.iterations,
        rounds=out.rounds,
        messages=messages,
        bytes=nbytes,
        work=out.work,
        options=(("order", order), ("exchange", exchange), *comm.options),
        communication=table,
        status=deadline.status,
    )


# ------------------------------------------------------------------ priorities
def _integer_utilities(mission: Mission) -> list[int]:
    """The utilities times a common power of two: exact integers, same order and ratios."""
    ratios = [float(u).as_integer_ratio() for u in mission.utilities.tolist()]
    scale = max((d for _, d in ratios), default=1)  # denominators are powers of two
    return [num * (scale // den) for num, den in ratios]


def _supply_demand(mission: Mission) -> tuple[list[int], list[int]]:
    supply = mission.capabilities.sum(axis=0).astype(np.int64).tolist()
    demand = mission.requirements.sum(axis=0).astype(np.int64).tolist()
    return supply, demand


def select_priorities(mission: Mission) -> npt.NDArray[np.int64]:
    """Per task its priority ``pi_j`` (0 = least valuable, ``m - 1`` = most); see the module.

    Tasks are ranked by ``(w_j, -j)`` with ``w_j = u_j / sum_s req[j, s] max(1, D_s /
    N_s)``, exactly.  O(m S + m log m): floats pre-sort, runs of near ties are re-sorted
    by integer cross-multiplication (costs times the lcm of the ``N_s``, utilities times a
    power of two).

    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1]], [[2], [1], [1]], [10, 4, 4])
    >>> select_priorities(m).tolist()   # price 4/2 = 2: w = 10/4, 4/2, 4/2
    [2, 1, 0]
    """
    reqs = mission.requirements
    m = reqs.shape[0]
    supply, demand = _supply_demand(mission)
    # price p_s = P_s / Q_s; cost_j * L = sum_s req[j, s] P_s (L / Q_s) is an integer C_j
    Q = [max(s, 1) for s in supply]
    P = [max(d, q) for d, q in zip(demand, Q, strict=True)]
    L = math.lcm(*Q) if Q else 1
    weight = [p * (L // q) for p, q in zip(P, Q, strict=True)]
    price_f = np.array([p / q for p, q in zip(P, Q, strict=True)], dtype=np.float64)
    cost_f = reqs.astype(np.float64) @ price_f
    worth_f = (mission.utilities / np.maximum(cost_f, 1.0)).tolist()
    order = sorted(range(m), key=lambda j: (worth_f[j], -j))
    utility = _integer_utilities(mission)  # w_j is proportional to utility[j] / C_j

    def exact(a: int, b: int) -> int:  # (w_a, -a) against (w_b, -b), by integers
        cost_a = sum(r * w for r, w in zip(reqs[a].tolist(), weight, strict=True))
        cost_b = sum(r * w for r, w in zip(reqs[b].tolist(), weight, strict=True))
        diff = utility[a] * cost_b - utility[b] * cost_a
        return (diff > 0) - (diff < 0) or b - a

    ranked: list[int] = []
    start = 0
    for pos in range(1, m + 1):
        if pos < m:
            x, y = worth_f[order[pos - 1]], worth_f[order[pos]]
            top = max(abs(x), abs(y))
            if y - x <= max(_TIE_BAND * top, 4 * math.ulp(top)):  # ulp: subnormal worths
                continue  # a near tie: the run continues
        group = order[start:pos]
        if len(group) > 1:
            group.sort(key=cmp_to_key(exact))
        ranked.extend(group)
        start = pos
    rank = np.empty(m, dtype=np.int64)
    rank[ranked] = np.arange(m)
    return rank


# ------------------------------------------------------------ feasibility check
def fillable(
    counts: npt.ArrayLike,
    kinds: npt.ArrayLike,
    need: npt.ArrayLike,
    work: list[int] | None = None,
    groups: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
) -> bool:
    """Whether free robots (and groups of robots with a limit) can fill ``need``.

    Parameters
    ----------
    counts : array_like of int, shape (K,)
        Free robots per capability type.
    kinds : array_like of bool, shape (K, S)
        The capability types.
    need : array_like of int, shape (S,)
        Robots needed per service; each robot fills at most one unit of a service it has.
    work : list of one int, optional
        Gets the subsets checked (or the flow's edge scans) added to ``work[0]``.
    groups : (array_like (G, K), array_like (G,)), optional
        Group ``g`` has ``types[g, t]`` robots of type ``t`` of which at most ``cap[g]`` may
        be used (the spare robots of an over-full slot).

    Returns
    -------
    bool

    Notes
    -----
    Exact.  Hall's condition over the subsets ``U`` of the needed services: ``need(U) <=
    free robots having a service in U + sum_g min(cap_g, robots of g having one)`` (the
    max-flow min-cut theorem of the network source -> group -> robot -> service ->
    sink), O((G + 1) b 2**b) numpy for ``b <= 14`` needed services; beyond, a max-flow.

    >>> fillable([1, 1], [[1, 1], [1, 0]], [1, 1])   # {s0, s1} and {s0} cover s0 + s1
    True
    >>> fillable([2], [[1, 0]], [1, 1])              # nobody can do s1
    False
    >>> fillable([1, 1, 1], [[1, 0, 1], [1, 0, 1], [0, 1, 0]], [2, 1, 1])  # Hall: s0+s2 > 2
    False
    >>> fillable([0, 0], [[1, 0], [0, 1]], [1, 1], groups=([[1, 1]], [1]))  # one of two
    False
    """
    counts_a = np.asarray(counts, dtype=np.int64).reshape(-1)
    kinds_a = np.asarray(kinds, dtype=bool).reshape(counts_a.size, -1)
    need_a = np.asarray(need, dtype=np.int64).reshape(-1)
    if groups is None:
        g_types = np.zeros((0, counts_a.size), dtype=np.int64)
        g_cap = np.zeros(0, dtype=np.int64)
    else:
        g_types = np.asarray(groups[0], dtype=np.int64).reshape(-1, counts_a.size)
        g_cap = np.asarray(groups[1], dtype=np.int64).reshape(-1)
    total = int(need_a.sum())
    if total == 0:
        return True
    g_size = g_types.sum(axis=1)
    if int(counts_a.sum()) + int(np.minimum(g_size, g_cap).sum()) < total:
        return False
    svc = np.flatnonzero(need_a)
    sub = kinds_a[:, svc].astype(np.int64)
    have = counts_a @ sub + np.minimum(g_types @ sub, g_cap[:, None]).sum(axis=0)
    if bool((have < need_a[svc]).any()):
        return False
    b = int(svc.size)
    if b == 1:
        return True
    if b <= _HALL_BITS:
        if work is not None:
            work[0] += (g_cap.size + 1) << b
        return _hall(counts_a, sub, need_a[svc], g_types, g_cap)
    return _flow(counts_a, sub.astype(bool), need_a[svc], g_types, g_cap, work)


def _touching(counts: npt.NDArray[np.int64], proj: npt.NDArray[np.int64], b: int):
    """Per row of ``counts`` (G, K) and every service set U: robots having a service in U."""
    size = 1 << b
    inside = np.zeros((counts.shape[0], size), dtype=np.int64)  # services within X
    np.add.at(inside.T, proj, counts.T)
    for i in range(b):
        step = 1 << i
        view = inside.reshape(counts.shape[0], -1, 2, step)
        view[:, :, 1, :] += view[:, :, 0, :]
    return counts.sum(axis=1)[:, None] - inside[:, ::-1]


def _hall(counts, sub, need, g_types, g_cap) -> bool:
    b = need.size
    proj = sub @ (np.int64(1) << np.arange(b, dtype=np.int64))
    avail = _touching(counts[None, :], proj, b)[0]
    if g_cap.size:
        avail = avail + np.minimum(_touching(g_types, proj, b), g_cap[:, None]).sum(axis=0)
    wanted = np.zeros(1 << b, dtype=np.int64)  # wanted[U] = need(U)
    wanted[np.int64(1) << np.arange(b, dtype=np.int64)] = need
    for i in range(b):
        view = wanted.reshape(-1, 2, 1 << i)
        view[:, 1, :] += view[:, 0, :]
    return bool((wanted <= avail).all())


def _flow(counts, sub, need, g_types, g_cap, work) -> bool:
    """The same question as a max-flow (networkx), for tasks needing many services."""
    import networkx as nx

    graph = nx.DiGraph()
    K, b = sub.shape
    for t in range(K):
        if counts[t]:
            graph.add_edge("src", ("free", t), capacity=int(counts[t]))
            for s in np.flatnonzero(sub[t]).tolist():
                graph.add_edge(("free", t), ("svc", s), capacity=int(counts[t]))
    for g in range(g_cap.size):
        graph.add_edge("src", ("group", g), capacity=int(g_cap[g]))
        for t in np.flatnonzero(g_types[g]).tolist():
            graph.add_edge(("group", g), ("gt", g, t), capacity=int(g_types[g, t]))
            for s in np.flatnonzero(sub[t]).tolist():
                graph.add_edge(("gt", g, t), ("svc", s), capacity=int(g_types[g, t]))
    for s in range(b):
        graph.add_edge(("svc", s), "sink", capacity=int(need[s]))
    if work is not None:
        work[0] += graph.number_of_edges()
    return nx.maximum_flow_value(graph, "src", "sink") == int(need.sum())


# ------------------------------------------------------------------- the engine
@dataclass
class _Pool:
    """The free robots at a phase step: unassigned ones, and over-full slots as groups."""

    types: npt.NDArray[np.int64]  # (K,) unassigned robots per type
    cap: npt.NDArray[np.int64]  # (S,) per service: unassigned + group limits
    size: int  # unassigned robots + group spares
    g_types: npt.NDArray[np.int64]  # (G, K)
    g_cap: npt.NDArray[np.int64]  # (G,) spares c - req
    g_task: npt.NDArray[np.int64]  # (G,) the task of each group
    g_svc_cap: npt.NDArray[np.int64]  # (G, S) min(spares, members having s)


class _Engine:
    """The rounds and phase steps of :func:`grape_s_select` (see the module notes).

    Per service two max-heaps of ``(-pi_k, k)`` entries with lazy deletion -- slots that
    are short (a needed place) and slots that are full or over-full (a surplus place) --
    give the best place a robot can join; per capability type the best service follows
    with one numpy reduction, and a robot wants to move exactly when its reward is below
    its type's best.  (Its own slot never is that best: joining it again pays at most
    what the robot has; its task's other slots pay more only when it is surplus and they
    are short, a real move.)
    """

    def __init__(self, mission: Mission, order: str, exchange: bool, rng: np.random.Generator):
        caps, reqs = mission.capabilities, mission.requirements
        n, S = caps.shape
        m = reqs.shape[0]
        self.n, self.m, self.S = n, m, S
        self.reqs = reqs
        self.order, self.exchange, self.rng = order, exchange, rng
        self.rank = select_priorities(mission)
        self.rank_l = self.rank.tolist()
        self.task_of_rank = np.argsort(self.rank).tolist()
        self.util = _integer_utilities(mission)
        supply, demand = _supply_demand(mission)
        sigma = [Fraction(d, max(s, 1)) for s, d in zip(supply, demand, strict=True)]
        by_sigma = sorted(range(S), key=lambda s: (sigma[s], -s))
        self.sigma_rank = [0] * S
        for r, s in enumerate(by_sigma):
            self.sigma_rank[s] = r
        enough = (reqs <= np.array(supply, dtype=np.int64)).all(axis=1).tolist()
        self.viable = [self.util[j] > 0 and enough[j] for j in range(m)]
        self.req = reqs.ravel().tolist()
        self.REQ = reqs.sum(axis=1).astype(np.int64)
        self.REQ_l = self.REQ.tolist()
        self.svc_of_task = [np.flatnonzero(reqs[j]).tolist() for j in range(m)]
        if n:
            self.kinds, rtype = np.unique(caps, axis=0, return_inverse=True)
            self.rtype = rtype.reshape(-1).astype(np.int64)
        else:
            self.kinds = np.zeros((0, S), dtype=bool)
            self.rtype = np.zeros(0, dtype=np.int64)
        self.K = self.kinds.shape[0]
        self.kinds_i = self.kinds.astype(np.int64)
        self.svc_of_type = [np.flatnonzero(row).tolist() for row in self.kinds]
        slots_per_service = (reqs > 0).sum(axis=0).astype(np.int64)
        self.per_round = int(caps.astype(np.int64).sum(axis=0) @ slots_per_service)
        self.absent = np.where(self.kinds, 0, -(2 * m + 2))  # a service the type lacks: never best
        self._reset([not v for v in self.viable], [not v for v in self.viable])

    def _reset(self, closed: list[bool], used: list[bool]) -> None:
        """The mutable state: every robot unassigned, these task bits."""
        n, m, S = self.n, self.m, self.S
        self.cnt = [0] * (m * S)
        self.short = list(self.REQ_l)  # robots missing per task
        self.nmem = [0] * m
        self.busy = [False] * m  # open, non-empty, incomplete: the close step's candidates
        self.closed = list(closed)
        self.used = list(used)
        self.members: defaultdict[int, set[int]] = defaultdict(set)  # per slot
        self.overfull: set[int] = set()
        self.rtask = [-1] * n  # Python lists: the hot path writes single entries
        self.rserv = [-1] * n
        self.cur = np.full(n, -1, dtype=np.int64)
        self.need_heap: list[list[tuple[int, int]]] = [[] for _ in range(S)]
        self.spare_heap: list[list[tuple[int, int]]] = [[] for _ in range(S)]
        self.in_need = [False] * (m * S)
        self.in_spare = [False] * (m * S)
        self.top = np.full(S, -1, dtype=np.int64)
        self.top_l = [-1] * S
        for j in range(m):
            self._push(j)
        for s in range(S):
            self._refresh(s)
        self.out = _Outcome(np.zeros(0, np.int64), np.zeros(0, np.int64))
        self.phase_work = [0]

    def load(
        self,
        task: npt.ArrayLike,
        service: npt.ArrayLike,
        closed: npt.ArrayLike,
        used: npt.ArrayLike,
    ) -> None:
        """Put the engine in the state of a partition with these task bits, as a run that
        reached it would hold it (the distributed agents' belief,
        :mod:`heuristics.agents.grape_s_select`); ``out`` and the phase work start empty.

        The phase steps depend on this state alone (not on how it was reached), so
        :meth:`phase_step` then makes the step a run would make there.  O(n log(m S)).
        """
        self._reset(np.asarray(closed, dtype=bool).tolist(), np.asarray(used, dtype=bool).tolist())
        task_l = np.asarray(task, dtype=np.int64).tolist()
        service_l = np.asarray(service, dtype=np.int64).tolist()
        for i, (k, s) in enumerate(zip(task_l, service_l, strict=True)):
            if k >= 0:
                self._place(i, k, s)

    # -- slots
    def _joinable(self, k: int) -> bool:
        return self.viable[k] and (not self.closed[k] or self.REQ_l[k] == 1)

    def _push(self, k: int) -> None:
        for s in self.svc_of_task[k]:
            self._push_slot(k, s)

    def _push_slot(self, k: int, s: int) -> None:
        """Make sure the heap of the slot's current kind (short or not) holds it."""
        if not self._joinable(k):
            return
        sl = k * self.S + s
        if self.cnt[sl] < self.req[sl]:
            if not self.in_need[sl]:
                heapq.heappush(self.need_heap[s], (-self.rank_l[k], k))
                self.in_need[sl] = True
        elif not self.in_spare[sl]:
            heapq.heappush(self.spare_heap[s], (-self.rank_l[k], k))
            self.in_spare[sl] = True

    def _refresh(self, s: int) -> None:
        S, cnt, req = self.S, self.cnt, self.req
        heap = self.need_heap[s]
        while heap:
            k = heap[0][1]
            sl = k * S + s
            if cnt[sl] < req[sl] and self._joinable(k):
                self.top[s] = self.top_l[s] = self.m + self.rank_l[k]
                return
            heapq.heappop(heap)
            self.in_need[sl] = False
        heap = self.spare_heap[s]
        while heap:
            k = heap[0][1]
            sl = k * S + s
            if cnt[sl] >= req[sl] and self._joinable(k):
                self.top[s] = self.top_l[s] = self.rank_l[k]
                return
            heapq.heappop(heap)
            self.in_spare[sl] = False
        self.top[s] = self.top_l[s] = -1

    # -- moves
    def _place(self, i: int, k: int, s: int) -> None:
        S, cnt, req = self.S, self.cnt, self.req
        old = self.rtask[i]
        if old >= 0:
            s0 = self.rserv[i]
            sl0 = old * S + s0
            if cnt[sl0] <= req[sl0]:
                self.short[old] += 1
            cnt[sl0] -= 1
            self.nmem[old] -= 1
            self.members[sl0].discard(i)
            if cnt[sl0] == req[sl0]:  # no longer over-full: its robots are needed again
                self.overfull.discard(sl0)
                key = self.m + self.rank_l[old]
                for r in self.members[sl0]:
                    self.cur[r] = key
        sl = k * S + s
        if cnt[sl] < req[sl]:
            self.short[k] -= 1
        cnt[sl] += 1
        self.nmem[k] += 1
        self.members[sl].add(i)
        self.rtask[i], self.rserv[i] = k, s
        if cnt[sl] == req[sl] + 1:  # over-full now: all its robots are surplus
            self.overfull.add(sl)
            key = self.rank_l[k]
            for r in self.members[sl]:
                self.cur[r] = key
        self.cur[i] = self.m + self.rank_l[k] if cnt[sl] <= req[sl] else self.rank_l[k]
        closed, nmem, short, busy = self.closed, self.nmem, self.short, self.busy
        busy[k] = not closed[k] and short[k] > 0  # k has a robot now
        self._push_slot(k, s)
        if old >= 0:
            busy[old] = not closed[old] and nmem[old] > 0 and short[old] > 0
            self._push_slot(old, s0)
            if s0 != s:
                self._refresh(s0)
        self._refresh(s)

    def _update_busy(self, j: int) -> None:
        self.busy[j] = not self.closed[j] and self.nmem[j] > 0 and self.short[j] > 0

    def _release(self, j: int, iteration: int) -> None:
        S = self.S
        released = []
        for s in self.svc_of_task[j]:
            sl = j * S + s
            released.extend(self.members[sl])
            self.members[sl].clear()
            self.cnt[sl] = 0
            self.overfull.discard(sl)
        for i in sorted(released):
            self.rtask[i] = self.rserv[i] = -1
            self.cur[i] = -1
            self.out.moves.append((iteration, i, -1, -1))
        self.short[j] = self.REQ_l[j]
        self.nmem[j] = 0
        self.busy[j] = False

    def _set_closed(self, j: int, value: bool) -> None:
        self.closed[j] = value
        self._update_busy(j)
        self._push(j)
        for s in self.svc_of_task[j]:
            self._refresh(s)

    def _choose_service(self, i: int, T: int, key: int, k: int) -> int:
        options = [s for s in self.svc_of_type[T] if self.top_l[s] == key]
        return self.service_choice(options, self.cur, i, key, k, self.cnt)

    def wants(
        self, top: npt.NDArray[np.int64], cur: npt.NDArray[np.int64]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        """Per capability type the best reward to join (``top``: per service), and per
        robot whether it is strictly better than its reward ``cur``.  Pure."""
        best = (top + self.absent).max(axis=1)
        return best, cur < best[self.rtype]

    def task_of_key(self, key: int) -> int:
        """The task whose needed (``m + pi``) or surplus (``pi``) reward ``key`` is."""
        return self.task_of_rank[key - self.m if key >= self.m else key]

    def service_choice(
        self,
        options: list[int],
        cur: npt.NDArray[np.int64],
        i: int,
        key: int,
        k: int,
        cnt: list[int] | npt.NDArray[np.int64],
    ) -> int:
        """The service robot ``i`` takes in task ``k`` among ``options`` (its services
        whose best place, reward ``key``, is in ``k``): the smallest slack, then the larger
        scarcity, then the lower index (module notes).  Pure: the robots' rewards ``cur``
        and the slot counts ``cnt`` are arguments."""
        if len(options) == 1:
            return options[0]
        lower = cur < key
        lower[i] = False
        per = np.bincount(self.rtype[lower], minlength=self.K) @ self.kinds_i
        S, req = self.S, self.req
        return min(
            options,
            key=lambda s: (
                int(per[s]) - max(req[k * S + s] - cnt[k * S + s], 0),
                -self.sigma_rank[s],
                s,
            ),
        )

    # -- the run
    def run(self, deadline: Deadline = NO_DEADLINE) -> _Outcome:
        """The rounds until none moves and no phase step applies, or ``deadline``."""
        out = self.out
        n, m = self.n, self.m
        if n == 0:
            out.rounds = 1
            out.task = out.service = np.zeros(0, dtype=np.int64)
            return out
        rtype, cur, top = self.rtype, self.cur, self.top
        random_order = self.order == "random"
        place, choose, task_of_rank, moves, wants = (
            self._place,
            self._choose_service,
            self.task_of_rank,
            out.moves,
            self.wants,
        )
        while not deadline.reached():
            out.rounds += 1
            best, want = wants(top, cur)
            if random_order:
                perm = self.rng.permutation(n)
                ordered = want[perm]
                last = n - 1 - int(ordered[::-1].argmax())
                mover = int(perm[last]) if ordered[last] else -1
            else:
                last = n - 1 - int(want[::-1].argmax())
                mover = last if want[last] else -1
            if mover >= 0:
                T = int(rtype[mover])
                key = int(best[T])
                k = task_of_rank[key - m if key >= m else key]
                s = choose(mover, T, key, k)
                out.iterations += 1
                place(mover, k, s)
                moves.append((out.iterations, mover, k, s))
                continue
            if self.phase_step():
                continue
            break
        out.work = out.rounds * self.per_round + self.phase_work[0]
        out.task = np.array(self.rtask, dtype=np.int64)
        out.service = np.array(self.rserv, dtype=np.int64)
        return out

    # -- phase steps
    def phase_step(self) -> bool:
        """Make the first phase step that applies (close, reopen, exchange if enabled) on
        the current state; ``False``: none applies (the run ends)."""
        return self._close() or self._reopen() or (self.exchange and self._exchange())

    def _close(self) -> bool:
        self.phase_work[0] += self.m
        cand = np.array(self.busy, dtype=bool)
        if not cand.any():
            return False
        j = int(np.where(cand, self.rank, self.m).argmin())
        self.out.iterations += 1
        self._release(j, self.out.iterations)
        self._set_closed(j, True)
        return True

    def _candidates(self) -> list[int]:
        return [
            j for j in range(self.m) if self.closed[j] and not self.used[j] and self.REQ_l[j] > 1
        ]

    def _pool(self) -> _Pool:
        K, S = self.K, self.S
        types = np.bincount(self.rtype[self.cur < 0], minlength=K)
        slots = sorted(self.overfull)
        G = len(slots)
        g_types = np.zeros((G, K), dtype=np.int64)
        for g, sl in enumerate(slots):
            robots = np.fromiter(self.members[sl], dtype=np.int64)
            g_types[g] = np.bincount(self.rtype[robots], minlength=K)
        g_cap = np.array([self.cnt[sl] - self.req[sl] for sl in slots], dtype=np.int64)
        g_task = np.array([sl // S for sl in slots], dtype=np.int64)
        g_svc_cap = np.minimum(g_types @ self.kinds_i, g_cap[:, None])
        return _Pool(
            types=types,
            cap=types @ self.kinds_i + g_svc_cap.sum(axis=0),
            size=int(types.sum() + g_cap.sum()),
            g_types=g_types,
            g_cap=g_cap,
            g_task=g_task,
            g_svc_cap=g_svc_cap,
        )

    def _reopen(self) -> bool:
        cands = self._candidates()
        if not cands:
            return False
        pool = self._pool()
        need = self.reqs[cands]
        ok = (need <= pool.cap).all(axis=1) & (self.REQ[cands] <= pool.size)
        self.phase_work[0] += len(cands) * self.S
        groups = (pool.g_types, pool.g_cap)
        for j in sorted(np.array(cands)[ok].tolist(), key=lambda j: -self.rank_l[j]):
            if fillable(pool.types, self.kinds, self.reqs[j], self.phase_work, groups):
                self.used[j] = True
                self._set_closed(j, False)
                return True
        return False

    def _exchange(self) -> bool:
        cands = self._candidates()
        if not cands:
            return False
        util, rank_l = self.util, self.rank_l
        donors = [
            j
            for j in range(self.m)
            if self.nmem[j] > 0 and self.short[j] == 0 and self.REQ_l[j] > 1
        ]
        if not donors:
            return False
        donors.sort(key=lambda d: (util[d], rank_l[d]))
        d_arr = np.array(donors, dtype=np.int64)
        pool = self._pool()
        # per donor: all its robots (types, per-service capabilities, count), and the
        # spares of its own over-full slots (already in the pool, not to count twice)
        rtask = np.array(self.rtask, dtype=np.int64)
        assigned = np.flatnonzero(rtask >= 0)
        tcount = np.zeros((self.m, self.K), dtype=np.int64)
        np.add.at(tcount, (rtask[assigned], self.rtype[assigned]), 1)
        dtypes = tcount[d_arr]
        dcap = dtypes @ self.kinds_i
        dsize = dtypes.sum(axis=1)
        own_cap = np.zeros((self.m, self.S), dtype=np.int64)
        own_spare = np.zeros(self.m, dtype=np.int64)
        np.add.at(own_cap, pool.g_task, pool.g_svc_cap)
        np.add.at(own_spare, pool.g_task, pool.g_cap)
        d_cap = pool.cap + dcap - own_cap[d_arr]  # (D, S) free capabilities with donor d
        d_size = pool.size + dsize - own_spare[d_arr]
        big = max(util[d] for d in donors) * (len(donors) + 1) >= 2**62
        du = np.array([util[d] for d in donors], dtype=object if big else np.int64)
        cum_u = np.cumsum(du)
        cum_cap = pool.cap + np.cumsum(dcap - own_cap[d_arr], axis=0)
        cum_size = pool.size + np.cumsum(dsize - own_spare[d_arr])
        cum_types = np.cumsum(dtypes, axis=0)
        ordered = sorted(cands, key=lambda k: (-util[k], -rank_l[k]))
        self.phase_work[0] += len(ordered) * len(donors) * self.S
        for k in ordered:
            need = self.reqs[k]
            total = int(self.REQ[k])
            uk = util[k]
            cheaper = np.asarray(du < uk, dtype=bool)
            single = cheaper & (d_cap >= need).all(axis=1) & (d_size >= total)
            for p in np.flatnonzero(single).tolist():
                if self._fits(pool, dtypes[p], donors[p : p + 1], need):
                    self._make_room(k, donors[p : p + 1])
                    return True
            prefix = int(np.count_nonzero(np.asarray(cum_u < uk, dtype=bool)))
            ok = (cum_cap[:prefix] >= need).all(axis=1) & (cum_size[:prefix] >= total)
            for p in np.flatnonzero(ok).tolist():
                if self._fits(pool, cum_types[p], donors[: p + 1], need):
                    self._make_room(k, donors[: p + 1])
                    return True
        return False

    def _fits(self, pool: _Pool, extra: npt.NDArray[np.int64], given: list[int], need) -> bool:
        keep = ~np.isin(pool.g_task, given)
        groups = (pool.g_types[keep], pool.g_cap[keep])
        return fillable(pool.types + extra, self.kinds, need, self.phase_work, groups)

    def _make_room(self, k: int, donors: list[int]) -> None:
        self.out.iterations += 1
        for d in donors:
            self._release(d, self.out.iterations)
            self._set_closed(d, True)
        self.used[k] = True
        self._set_closed(k, False)
