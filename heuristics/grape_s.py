"""GRAPE-S: the seed's hedonic-game coalition formation, as its centralized simulator ran it.

The fast engine.  :mod:`heuristics._reference` is the literal transcription of the seed's
Algorithm 1 that it must agree with, move for move.
"""

from __future__ import annotations

import heapq
import time
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_bool, require_seed
from heuristics._grape_s_fast import BAND as _BAND
from heuristics._grape_s_fast import EXACT_FLOAT_LIMIT as _EXACT_FLOAT_LIMIT
from heuristics._grape_s_fast import Outcome as _Outcome
from heuristics._grape_s_fast import core_fast
from heuristics._run import NO_DEADLINE, Deadline, Run, check_order, moves_run
from heuristics.communication import belief_rounds_table, comm_model, table_cost
from heuristics.reward import VOID, RewardModel, reward_model

__all__ = ["grape_s"]


def grape_s(
    mission: Mission,
    *,
    seed: SeedLike = None,
    order: str = "index",
    capped: bool = False,
    reward: str = "paper",
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
) -> Run:
    """Run GRAPE-S (centralized, synchronous, fully connected) on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    seed : None, int or numpy.random.Generator
        Feeds ``numpy.random.default_rng``; only ``order="random"`` draws from it.
    order : {"index", "random"}
        The order in which robots select each round: robot index order (the seed's
        sequential simulator) or a fresh, uniformly random, seeded order every round
        (drawn lazily, see Notes; :func:`grape_s_eager` draws a whole permutation).
    capped : bool, default False
        Forbid joining a slot that already has ``req[j, s]`` robots (Pair-GRAPE-S's first
        phase).
    reward : {"paper", "utility"}
        The reward weighting, see :mod:`heuristics.reward`.
    medium : {"broadcast", "unicast"}, default "broadcast"
        How ``messages`` and ``bytes`` count a belief sent to all neighbours: one
        transmission (the seed's UDP broadcasts) or one message per receiver
        (:mod:`heuristics.communication`).
    encoding : {"full", "compact"}, default "full"
        The belief's encoding: ``16 + 4 n`` bytes, or the slots bit-packed.
    time_limit : float, optional
        Wall-clock seconds after which no further round starts (checked before each
        round); the run then returns the partition reached, ``status`` ``TIME_LIMIT``.

    Returns
    -------
    Run
        ``algorithm="grape-s"``; ``trajectory`` lists the applied moves; ``options``
        records ``medium`` and ``encoding``; ``communication`` holds the counts under
        every model; ``status`` says whether the time limit cut it.

    Notes
    -----
    Semantics.  All robots start on the void task.  A round: every
    robot, in order, computes its best move on the shared partition -- the slot ``(j, s)``
    of one of its services, other than its own, minimising ``(key, j, s)`` where ``key``
    is the exact reward key of joining (for the paper reward ``(c[j, s] + 1) / req[j,
    s]``, smaller is better; ties go to the lowest task, then service index) -- and
    proposes it if it is strictly better than staying (an unassigned robot earns 0).  Each
    proposal carries evolution number ``r + 1`` and its position in the order as time
    stamp; the distributed mutex keeps the highest ``(r, time, id)``, so exactly one move
    survives a round: that of the *last* robot in the order that wants to move.  It is
    applied and ``r`` grows by one.  A round without a proposal ends the run (the
    partition is Nash stable, capped or not).

    Counting.  ``iterations`` = rounds with a move; ``rounds`` = iterations + 1 (the quiet
    last round).  Every robot broadcasts ``(r, time, Pi)`` to its ``n - 1`` neighbours
    every round: ``messages = rounds n`` transmissions under ``medium="broadcast"``,
    ``rounds n (n - 1)`` messages under ``"unicast"`` (none when ``n = 1``); each is one
    belief, ``16 + 4 n`` bytes with ``encoding="full"`` (int32 ``r``, int32 id, int64 time
    stamp, one int32 slot per robot), ``16 + ceil(n ceil(log2(m S + 1)) / 8)`` with
    ``"compact"`` (:func:`heuristics.communication.belief_size`).  ``work`` counts *slot
    examinations* as the algorithm performs them: every round every robot examines every
    slot of every service it has -- its own slot gives its current reward, each other slot
    a candidate reward (full slots included when capped: examined, then rejected), so a
    round costs ``P = sum_i sum_{s of i} slots(s)`` and ``work = rounds * P``, the seed's
    O(n^2 S m) computation.

    The engine does not do that work.  A robot's wish to move depends only on its current
    key and on ``A(T)``, the best joining key over the services of its *capability type*
    ``T`` (its own slot can be left in: joining it again is always worse than staying),
    and its target is the slot that attains ``A(T)``.  Per service a heap of
    ``(key, task)`` entries with lazy deletion gives the best slot; a round ranks the
    ``S`` service bests exactly, takes ``A(T)`` for every type with one numpy reduction,
    compares every robot's current key with ``A`` of its type by integer
    cross-multiplication, and takes the last wanting robot in the order.  A round costs
    O(n + K S + S log S + log m) with ``K`` capability types, numpy-vectorised in ``n``.
    Heap and ranking keys lead with the correctly rounded float ``(c + 1) / req``, which
    is monotone in the exact key, and fall back to the exact key when two floats are
    equal (with counts and requirements below 2**26 equal floats imply equal fractions).
    For ``reward="utility"`` robots and targets of tasks with equal weight are compared
    exactly with integers, others by a float filter of width 1e-9 whose undecided cases
    go to the exact comparison of :class:`heuristics.reward.UtilityKey`, once per distinct
    pair (target slot, own slot) -- the robots of a slot and type share it, so weights
    that differ by a hair (requirements near ``2**31``, utilities one ulp apart) cost a
    few exact comparisons per round, not one per robot.  That is ``_core_literal``, kept
    as the cross-check.

    The default core (:mod:`heuristics._grape_s_fast`) removes the O(n) per round: robots
    with the same service and the same slot key want the same, so it keeps, per service
    and distinct exact key, the highest robot index (lazy heaps, O(S log n) per move) and
    finds the mover by comparing the ``S`` service bests with the ``B`` distinct keys:
    O(S B) per round in index order (``B``: a few dozen for the paper reward).  Same
    moves and counts as ``_core_literal``.  In random order it draws the round's order
    lazily, from its end, up to its last wanting robot (about ``n / w`` uniform draws with
    ``w`` wanting robots) instead of a whole permutation: the same law of the run (each
    round's mover is uniform over the robots that want to move, independently of the
    earlier rounds' draws), other draws from ``seed`` than ``_core_literal``'s
    ``rng.permutation(n)`` per round.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    >>> run = grape_s(m)
    >>> # 4 rounds x 3 broadcasts of 16 + 4 x 3 bytes
    >>> run.assignment.task.tolist(), run.iterations, run.rounds, run.messages, run.bytes
    ([1, 0, 0], 3, 4, 12, 336)
    >>> run.trajectory.tolist()      # (iteration, robot, task, service): robot 2 first
    [[1, 2, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0]]
    >>> run.communication_cost("unicast", "full")     # 4 x 3 x 2 messages of 28 bytes
    (24, 672)
    """
    options = {"seed": seed, "order": order, "capped": capped, "reward": reward}
    return _run(mission, medium=medium, encoding=encoding, time_limit=time_limit, **options)


def grape_s_eager(mission: Mission, **options: Any) -> Run:
    """:func:`grape_s` drawing a whole ``rng.permutation(n)`` every round in random order.

    The literal engine's draws, the reference the lazy order of :func:`grape_s` is tested
    against: the same law, other draws (index order: the same run).  Same parameters and
    result as :func:`grape_s`.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    >>> grape_s_eager(m).trajectory.tolist() == grape_s(m).trajectory.tolist()
    True
    """
    return _run(mission, eager=True, **options)


def _run(
    mission: Mission,
    *,
    seed: SeedLike = None,
    order: str = "index",
    capped: bool = False,
    reward: str = "paper",
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
    eager: bool = False,
) -> Run:
    """:func:`grape_s`'s body; ``eager``: the literal engine's permutation per round."""
    started = time.perf_counter()
    deadline = Deadline(time_limit, started=started)
    require_mission(mission)
    rng = np.random.default_rng(require_seed("seed", seed))
    check_order(order)
    capped = require_bool("capped", capped)
    model = reward_model(mission, reward)
    comm = comm_model(medium, encoding)
    out = _core(
        mission.capabilities,
        mission.requirements,
        model,
        order,
        capped,
        rng,
        eager=eager,
        deadline=deadline,
    )
    n_slots = mission.n_tasks * mission.n_services
    table = belief_rounds_table(mission.n_robots, n_slots, out.rounds)
    messages, nbytes = table_cost(table, comm)
    return moves_run(
        "grape-s",
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
        options=(("order", order), ("capped", capped), ("reward", reward), *comm.options),
        communication=table,
        status=deadline.status,
    )


def _core(
    caps: npt.NDArray[np.bool_],
    reqs: npt.NDArray[np.int64],
    model: RewardModel,
    order: str,
    capped: bool,
    rng: np.random.Generator,
    *,
    literal: bool = False,
    eager: bool = False,
    deadline: Deadline = NO_DEADLINE,
) -> _Outcome:
    """The GRAPE-S rounds: the grouped engine, or ``_core_literal`` when ``literal``.

    In index order both make the same moves and return the same outcome.  In random order
    the literal engine draws ``rng.permutation(n)`` every round; the grouped engine draws
    the order lazily (the same law: each round's mover is uniform over the wanting
    robots, other draws), or, with ``eager``, the literal engine's permutations, and then
    makes the same moves with the same draws.  :mod:`heuristics._grape_s_fast` describes
    the grouped engine.  Both check ``deadline`` before each round.
    """
    if literal:
        return _core_literal(caps, reqs, model, order, capped, rng, deadline)
    return core_fast(caps, reqs, model, order, capped, rng, deadline, eager=eager)


def _core_literal(
    caps: npt.NDArray[np.bool_],
    reqs: npt.NDArray[np.int64],
    model: RewardModel,
    order: str,
    capped: bool,
    rng: np.random.Generator,
    deadline: Deadline = NO_DEADLINE,
) -> _Outcome:
    """The GRAPE-S rounds with O(n) numpy work per round (the engine before grouping).

    See :func:`grape_s` Notes for the method.
    """
    n, S = caps.shape
    m = reqs.shape[0]
    MS = m * S
    void_slot = MS  # a sentinel slot: count 1, requirement 0 -> key 1/0 = "infinite"
    req_list = reqs.ravel().tolist()
    cnt = np.zeros(MS + 1, dtype=np.int64)
    cnt[void_slot] = 1
    cnt_list = [0] * MS  # the same counts as Python ints (heap validity checks)

    tasks_of = [np.flatnonzero(reqs[:, s]).tolist() for s in range(S)]
    slots_per_service = np.array([len(t) for t in tasks_of], dtype=np.int64)
    per_round_work = int(caps.astype(np.int64).sum(axis=0) @ slots_per_service)
    out = _Outcome(np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64))
    if n == 0:
        out.rounds = 1
        return out
    kinds, rtype = np.unique(caps, axis=0, return_inverse=True)
    rtype = rtype.reshape(-1)
    K = kinds.shape[0]

    key = model.key
    paper = model.weights is None

    # Heap entries (hint, key, task, count).  The float hint (c + 1) / req is correctly
    # rounded, hence monotone in the exact key: unequal hints order exactly and equal
    # ones fall through to the exact key.  With counts and requirements below 2**26 two
    # different fractions p/q, p'/q' differ by a relative 1/(p q') > 2**-52, more than
    # two roundings can close, so equal hints mean equal keys and the key is not needed.
    small = paper and max(n + 1, max(req_list, default=1)) < _EXACT_FLOAT_LIMIT

    def entry(j: int, s: int, c: int) -> tuple[Any, ...]:
        if small:
            return ((c + 1) / req_list[j * S + s], 0, j, c)
        return ((c + 1) / req_list[j * S + s] if paper else 0.0, key(j, s, c + 1), j, c)

    heaps: list[list[tuple[Any, ...]]] = []
    for s in range(S):
        heap = [entry(j, s, 0) for j in tasks_of[s]]
        heap = [e for e in heap if e[1] is not VOID]
        heapq.heapify(heap)
        heaps.append(heap)
    best_key: list[Any] = [None] * S
    best_task = np.full(S, -1, dtype=np.int64)
    best_num = np.ones(S, dtype=np.int64)  # count + 1 of the best slot
    best_den = np.zeros(S, dtype=np.int64)  # its requirement

    def refresh(s: int) -> None:
        heap = heaps[s]
        while heap and cnt_list[heap[0][2] * S + s] != heap[0][3]:
            heapq.heappop(heap)
        if heap:
            h, k, j, c = heap[0]
            best_key[s], best_task[s] = (h, k), j
            best_num[s], best_den[s] = c + 1, req_list[j * S + s]
        else:
            best_key[s], best_task[s], best_num[s], best_den[s] = None, -1, 1, 0

    def push(j: int, s: int) -> None:
        c = cnt_list[j * S + s]
        if capped and c >= req_list[j * S + s]:
            return
        e = entry(j, s, c)
        if e[1] is not VOID:
            heapq.heappush(heaps[s], e)

    for s in range(S):
        refresh(s)

    robot_slot = np.full(n, void_slot, dtype=np.int64)
    robot_req = np.zeros(n, dtype=np.int64)  # requirement of the robot's slot (0: void)
    general = model.weights is not None
    if general:
        weight_class, log_weight = _weight_classes(model)
        robot_class = np.full(n, -1, dtype=np.int64)
        robot_logw = np.full(n, -np.inf)
    type_rows = np.arange(K)
    no_service = np.int64(S)
    random_order = order == "random"
    moves = out.moves
    while True:
        if deadline.reached():
            out.cut = True
            break
        out.rounds += 1
        perm = rng.permutation(n) if random_order else None
        # A(T): the best service of each capability type, by exact ranking of the S bests.
        live = [s for s in range(S) if best_task[s] >= 0]
        live.sort(key=lambda s: (*best_key[s], best_task[s], s))
        rank = np.full(S, no_service, dtype=np.int64)
        rank[live] = np.arange(len(live))
        masked = np.where(kinds, rank, no_service)
        a_svc = masked.argmin(axis=1)
        a_ok = masked[type_rows, a_svc] < no_service
        a_num = np.where(a_ok, best_num[a_svc], 1)[rtype]
        a_den = np.where(a_ok, best_den[a_svc], 0)[rtype]
        cur = cnt[robot_slot]
        # join A(T) beats staying  <=>  a_num / a_den < cur / robot_req  (exact)
        want = a_num * robot_req < cur * a_den
        if general:
            want = _general_want(
                want,
                a_ok,
                a_svc,
                rtype,
                best_task,
                best_num,
                best_den,
                weight_class,
                log_weight,
                robot_class,
                robot_logw,
                cur,
                robot_req,
                robot_slot,
                model,
                S,
            )
        if random_order:
            ordered = want[perm]
            last = n - 1 - int(ordered[::-1].argmax())
            mover = int(perm[last]) if ordered[last] else -1
        else:
            last = n - 1 - int(want[::-1].argmax())
            mover = last if want[last] else -1
        if mover < 0:
            break
        out.iterations += 1
        s1 = int(a_svc[rtype[mover]])
        j1 = int(best_task[s1])
        old = int(robot_slot[mover])
        new = j1 * S + s1
        cnt[new] += 1
        cnt_list[new] += 1
        robot_slot[mover] = new
        robot_req[mover] = req_list[new]
        out.task[mover], out.service[mover] = j1, s1
        if general:
            robot_class[mover] = weight_class[j1]
            robot_logw[mover] = log_weight[j1]
        moves.append((out.iterations, mover, j1, s1))
        push(j1, s1)
        if old != void_slot:
            cnt[old] -= 1
            cnt_list[old] -= 1
            j0, s0 = divmod(old, S)
            push(j0, s0)
            if s0 != s1:
                refresh(s0)
        refresh(s1)
    out.work = out.rounds * per_round_work
    return out


def _weight_classes(model: RewardModel) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Per task an integer class (equal exactly when the weights are) and ``ln w`` as float."""
    assert model.weights is not None
    distinct = sorted(set(model.weights))
    index = {w: k for k, w in enumerate(distinct)}
    classes = np.array([index[w] for w in model.weights], dtype=np.int64)
    scores = model.scores()
    assert scores is not None
    return classes, scores


def _general_want(
    want: npt.NDArray[np.bool_],
    a_ok: npt.NDArray[np.bool_],
    a_svc: npt.NDArray[np.int64],
    rtype: npt.NDArray[np.int64],
    best_task: npt.NDArray[np.int64],
    best_num: npt.NDArray[np.int64],
    best_den: npt.NDArray[np.int64],
    weight_class: npt.NDArray[np.int64],
    log_weight: npt.NDArray[np.float64],
    robot_class: npt.NDArray[np.int64],
    robot_logw: npt.NDArray[np.float64],
    cur: npt.NDArray[np.int64],
    robot_req: npt.NDArray[np.int64],
    robot_slot: npt.NDArray[np.int64],
    model: RewardModel,
    S: int,
) -> npt.NDArray[np.bool_]:
    """``want`` for utility-weighted rewards: exact within a weight class, filtered across.

    O(n) numpy work, plus one exact :class:`heuristics.reward.UtilityKey` comparison per
    distinct (target service, own slot) among the robots the float filter leaves undecided.
    """
    target = best_task[a_svc]
    a_class = np.where(a_ok, weight_class[np.maximum(target, 0)], -2)[rtype]
    with np.errstate(invalid="ignore", divide="ignore"):
        a_score = np.where(
            a_ok, log_weight[np.maximum(target, 0)] - best_num[a_svc] / best_den[a_svc], -np.inf
        )[rtype]
        cur_score = np.where(robot_req > 0, robot_logw - cur / np.maximum(robot_req, 1), -np.inf)
        same = a_class == robot_class
        by_float = a_score > cur_score + _BAND
        result = np.where(same, want, by_float)
        undecided = ~same & (np.abs(a_score - cur_score) <= _BAND)
    robots = np.flatnonzero(undecided)
    if robots.size:
        # one exact comparison per distinct (target service, own slot): the target slot
        # and count follow from the service, the own count from the slot
        span = int(robot_slot[robots].max()) + 1
        codes = a_svc[rtype[robots]] * span + robot_slot[robots]
        _, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
        decided = np.zeros(first.size, dtype=bool)
        for p, i in enumerate(robots[first].tolist()):
            s = int(a_svc[rtype[i]])
            join = model.key(int(best_task[s]), s, int(best_num[s]))
            j, s_own = divmod(int(robot_slot[i]), S)
            decided[p] = join < model.key(j, s_own, int(cur[i]))
        result[robots] = decided[inverse.reshape(-1)]
    return result
