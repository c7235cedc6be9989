"""Pair-GRAPE-S with chain exchanges: capped GRAPE-S, then augmenting-path exchanges.

Pair-GRAPE-S's pairwise step lets an unassigned robot replace one assigned robot that can
itself fill a short slot.  When the only robots able to fill the short slot sit where no
unassigned robot can stand in, that one-hop exchange stops short.  This variant replaces it
by *chain* exchanges -- augmenting paths of bipartite matching -- and so completes every
task of every achievable mission.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import shortest_path

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_seed
from heuristics._run import NO_DEADLINE, Deadline, Run, check_order, moves_run
from heuristics.communication import belief_rounds_table, comm_model, table_cost
from heuristics.grape_s import _core
from heuristics.reward import RewardModel, reward_model

__all__ = ["ACCEPT_BYTES", "pair_grape_s_chain", "request_bytes"]

#: Bytes of the acceptance a chain sends back hop by hop: int32 type, source, accepted.
ACCEPT_BYTES = 12


def request_bytes(partners: int) -> int:
    """Size of a chain request: int32 type and source, then an int32 (robot, slot) per partner.

    ``8 + 8 k`` bytes for a chain of ``k`` partners: 16 bytes for a one-hop exchange, the
    size of Pair-GRAPE-S's request.

    >>> request_bytes(1), request_bytes(3)
    (16, 32)
    """
    return 8 + 8 * partners


def pair_grape_s_chain(
    mission: Mission,
    *,
    seed: SeedLike = None,
    order: str = "index",
    reward: str = "paper",
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
) -> Run:
    """Run Pair-GRAPE-S with chain exchanges on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    seed : None, int or numpy.random.Generator
        Feeds ``numpy.random.default_rng``; ``order="random"`` draws the GRAPE-S round
        orders and then one permutation per pass of the chain step from it, exactly as
        :func:`heuristics.pair_grape_s` does.
    order : {"index", "random"}
        Robot order of both phases (see :func:`heuristics.grape_s`).
    reward : {"paper", "utility"}
        Reward weighting (:mod:`heuristics.reward`).
    medium : {"broadcast", "unicast"}, default "broadcast"
    encoding : {"full", "compact"}, default "full"
        The communication model of ``messages`` and ``bytes`` (message model below,
        :mod:`heuristics.communication`).

    time_limit : float, optional
        Wall-clock seconds after which no further round (GRAPE-S round or pass of the
        second phase) starts; the run then returns the partition reached, ``status``
        ``TIME_LIMIT``.

    Returns
    -------
    Run
        ``algorithm="pair-grape-s-chain"``; ``exchanges`` counts chain exchanges and
        ``pairwise_step_ran`` says whether the chain step was needed.  A chain exchange of
        ``k`` partners is ``k + 1`` rows of ``trajectory`` with one iteration: the
        unassigned source first, then the partners along the chain.  ``options`` records
        ``medium`` and ``encoding``, ``communication`` the counts under every model.

    Notes
    -----
    **Phase 1** is Pair-GRAPE-S's: capped GRAPE-S (``heuristics.grape_s._core`` with
    ``capped=True``, same random stream), so no slot ever holds more than ``req[j, s]``
    robots.

    **Phase 2, the chain step**, runs while some slot is *short* (``c < req``) and some
    robot is unassigned, in passes as Pair-GRAPE-S's pairwise step: a pass goes through
    the robots unassigned at its start in the pass order (index order, or one fresh seeded
    permutation of all robots per pass for ``order="random"``; the *scan position* of a
    robot is its place in that order).  For the current robot ``o`` it looks for a chain

        ``o -> a_1 -> a_2 -> ... -> a_k -> (j, s)``

    of distinct assigned robots where each robot can perform the service of the next
    one's slot (``o`` takes ``a_1``'s slot, ``a_1`` takes ``a_2``'s ...) and ``a_k`` can
    perform a short slot ``(j, s)`` other than its own (``k = 0``: ``o`` joins a short
    slot itself).  The chain is applied atomically as one exchange -- one iteration,
    every robot on it moves one step, ``k + 1`` trajectory rows -- and the pass goes on
    with the next robot.  A pass without an exchange ends the step.

    Path choice (deterministic).  The *shortest* chain from ``o`` (fewest partners);
    among shortest chains the one whose partners have the lexicographically smallest scan
    positions (``a_1`` first, then ``a_2``...); ``a_k``'s short slot is the one with the
    lowest ``(key(j, s, c + 1), j, s)`` of the reward, as in Pair-GRAPE-S.

    Search.  Chains are shortest paths in the directed graph on robot nodes, one node
    per service and a sink ``T``, searched *backwards* from ``T``: ``T -> a`` for every
    robot ``a`` that can perform a short slot other than its own, ``a -> s`` for every
    assigned robot ``a`` performing service ``s`` and ``s -> b`` for every robot ``b``
    that can perform ``s`` ("``b`` can take the slot of any robot performing ``s``").
    One :func:`scipy.sparse.csgraph.shortest_path` call (``method="D"``,
    ``unweighted=True``, ``indices=T``) gives every robot's chain length
    ``D(b) = (dist(T, b) - 1) / 2`` (``inf``: no chain); the chain from ``o`` is then
    read off greedily, ``a_{i+1}`` being the assigned robot of lowest scan position
    whose slot ``a_i`` can take and with ``D = D(a_i) - 1``.  The distances are
    recomputed after every exchange only (a skipped robot changes nothing).  Unassigned
    robots have no arc into a service node, so they are never inside a chain;
    ``D`` falls by one along a chain, so its robots are distinct.

    **Optimality on achievable missions** (every task complete whenever a complete
    assignment exists).  Replace every slot ``(j, s)`` by ``req[j, s]`` *copies* and join
    robot ``i`` to every copy of every slot whose service it has: a bipartite graph
    ``G``.  An assignment that completes every task and never over-fills a slot is a
    matching of ``G`` covering every copy; a complete assignment (possibly over-full) can
    be trimmed to one, so a mission is achievable exactly when ``G`` has a copy-covering
    matching -- by Hall's theorem, when every set ``X`` of copies has at least ``|X|``
    robots able to serve some copy in ``X``; equivalently (transportation /
    max-flow-min-cut) when, for every set ``Q`` of services, the robots having a service in
    ``Q`` number at least the total requirement of ``Q``.  Throughout phase 2 the
    partition is a matching ``M`` of ``G``: capped GRAPE-S never over-fills a slot, and a
    chain exchange keeps every slot on it at its count except the short slot ``(j, s)``,
    which gains one robot, so slots are never over-full; each robot sits in one slot copy.
    A chain is an ``M``-augmenting path of ``G`` (``o``, a copy of ``a_1``'s slot,
    ``a_1``, a copy of ``a_2``'s slot, ..., ``a_k``, a free copy of ``(j, s)``), and every
    augmenting path gives a chain: an augmenting path joins a free robot to a free copy;
    if its last robot's free copy belongs to that robot's own slot, the robot before it
    can take that copy directly, which shortens the path, so some augmenting path ends
    in a slot other than its last robot's own.  By Berge's augmenting-path theorem ``M``
    is maximum exactly when no augmenting path exists.  A pass without an exchange found
    no chain from any unassigned robot on an unchanged partition, so the final ``M`` is
    maximum; on an achievable mission a maximum matching covers every copy: every slot is
    full and every task complete.  Each exchange adds one edge to ``M`` (one robot
    assigned, none unassigned), so there are at most ``u`` exchanges, ``u`` the robots
    unassigned after phase 1, and at most ``u + 1`` passes.  On any mission the step
    ends with the most slot copies filled that any capped partition fills, and no slot
    loses a robot, so the utility never falls below phase 1's.  It does *not* follow
    that the result is Nash stable: as in Pair-GRAPE-S, a robot moved into a slot can
    lower the reward of the robots already there below that of a slot still short
    (``proofs.claims_chain``, claim C2).

    Relation to Pair-GRAPE-S.  A one-hop chain (``k = 1``) is exactly the exchange
    Pair-GRAPE-S makes for ``o``: its partner is the first assigned robot in scan order
    whose slot ``o`` can take and that can perform a short slot other than its own
    (``D = 0``), and it moves to the same slot.  Where Pair-GRAPE-S finds no partner for
    ``o``, the shortest chain has ``k = 0`` or ``k >= 2`` or does not exist; ``k = 0``
    (``o`` can join a short slot itself) never happens under the paper reward, because
    capped GRAPE-S leaves no unassigned robot next to a short slot it can perform and
    short slots only disappear in phase 2 (it can happen with ``reward="utility"`` and a
    task of utility 0, whose reward equals being unassigned).  So up to the first
    exchange with ``k != 1`` both runs make the same exchanges in the same order from the
    same random stream, and a run whose exchanges all have ``k = 1`` has Pair-GRAPE-S's
    assignment, trajectory, iterations, exchanges and rounds; its ``messages`` exceed
    Pair-GRAPE-S's by two per exchange (Pair-GRAPE-S counts broadcast rounds only).
    Pair-GRAPE-S reaching the optimum does not imply this when robots are spare: on
    ``cfopt.generate_mission(6, 10, 10, 5, load=0.6, seed=86)`` it skips r0 (which needs
    a 2-partner chain) and completes the task with the next robot's one-hop exchange,
    while this variant serves r0 with the chain; both end at 100 %.  On load-1 missions
    (every robot needed) no such case is known -- none among the seed family's
    n = 3..15 -- but none is ruled out either.

    **Message model** (a distributed version on a fully connected network, as in
    :mod:`heuristics.agents`, where every robot knows the mission and reads the partition
    from its belief).  Phase 1: GRAPE-S's broadcast rounds.  The chain search is local:
    the source computes the chain on its own belief, with no messages (its cost is in
    ``work``).  An exchange with ``k >= 1`` partners sends the *request* hop by hop along
    the chain, ``o -> a_1 -> ... -> a_k`` (``k`` messages of :func:`request_bytes`
    ``(k) = 8 + 8 k`` bytes: type, source, and each partner with the slot it holds, which
    it checks), ``a_k`` applies the exchange to its belief and broadcasts it (one
    broadcast round), and an *acceptance* travels back ``a_k -> ... -> a_1 -> o``
    (``k`` messages of :data:`ACCEPT_BYTES` = 12 bytes); with ``k = 0`` ``o`` moves and
    broadcasts itself.  A pass without an exchange costs one quiet broadcast round, as in
    Pair-GRAPE-S.  So ``rounds`` = phase-1 rounds + exchanges (+ 1 quiet pass).  A belief
    round costs what it costs in :func:`heuristics.grape_s` under the chosen model
    (``n`` broadcasts, or ``n (n - 1)`` unicasts, of one belief of
    :func:`heuristics.communication.belief_size` bytes); requests and acceptances are
    direct messages, one transmission each under both media, and keep their layout under
    both encodings.  So ``messages = rounds n + 2 sum k`` (broadcast) or ``rounds n (n -
    1) + 2 sum k`` (unicast), and ``bytes`` = the belief rounds' bytes ``+ sum (k (8 + 8
    k) + 12 k)``.

    ``work`` is GRAPE-S's slot examinations plus, in phase 2, per search one unit per arc
    of the search graph (building it and the search each touch an arc once), per chain
    step one unit per assigned robot examined as the next partner, and one unit per short
    slot the last partner (or a joining ``o``) evaluates.

    Complexity.  Phase 1 is capped GRAPE-S (see :func:`heuristics.grape_s`).  Phase 2
    runs at most ``u + 1`` passes (O(n) each for the permutation and the unassigned
    robots) and one search per pass plus one per exchange, at most ``2 u + 1``
    (``u <= n``); a search is O((n + n K + S) log n) on a graph of ``n + S + 1`` nodes
    and at most ``n (K + 2)`` arcs (``K <= S`` services per robot), a chain of ``k``
    partners is read off in O(k n) numpy work and its end slot chosen among O(m S)
    keys.  Phase 2 costs O(u (n S log n + k_max n + m S)) with ``k_max <= min(n, m S)``,
    i.e. O(n^2 (S log n + m)) in the worst case; communication adds
    O(u k_max) direct messages to Pair-GRAPE-S's O(rounds n) broadcasts (O(rounds n^2)
    unicasts).

    Examples
    --------
    >>> import cfopt
    >>> from heuristics.pair_grape_s import pair_grape_s
    >>> # r0 does A, r1 A and B, r2 B and C; one task needs A, B and C once each.
    >>> # Capped GRAPE-S: r2 takes B, r1 takes A, r0 is left out with C short.  Nobody
    >>> # r0 can replace (r1) can do C: Pair-GRAPE-S stops; the chain r0 -> r1 -> r2 -> C
    >>> # completes the task.
    >>> m = cfopt.Mission.from_arrays([[1, 0, 0], [1, 1, 0], [0, 1, 1]], [[1, 1, 1]], [10])
    >>> pair_grape_s(m).assignment.percent_utility(m)
    0.0
    >>> run = pair_grape_s_chain(m)
    >>> run.assignment.percent_utility(m), run.assignment.service.tolist()
    (100.0, [0, 1, 2])
    >>> run.exchanges, run.iterations, run.trajectory.tolist()[2:]
    (1, 3, [[3, 0, 0, 0], [3, 1, 0, 1], [3, 2, 0, 2]])
    >>> # 4 rounds (2 moves, GRAPE-S's quiet round, the exchange) of 3 broadcast beliefs
    >>> # of 16 + 4 x 3 bytes, plus 2 requests of 8 + 8 x 2 bytes and 2 acceptances of 12
    >>> run.rounds, run.messages, run.bytes
    (4, 16, 408)
    >>> run.communication_cost("unicast", "full")   # 4 x 3 x 2 beliefs + the 4 direct
    (28, 744)
    """
    started = time.perf_counter()
    deadline = Deadline(time_limit, started=started)
    require_mission(mission)
    rng = np.random.default_rng(require_seed("seed", seed))
    check_order(order)
    model = reward_model(mission, reward)
    comm = comm_model(medium, encoding)
    caps, reqs = mission.capabilities, mission.requirements
    first = _core(caps, reqs, model, order, True, rng, deadline=deadline)
    second = _chain_step(
        caps, reqs, model, order, rng, first.task, first.service, first.iterations, deadline
    )
    rounds = first.rounds + second.rounds
    table = belief_rounds_table(
        mission.n_robots,
        mission.n_tasks * mission.n_services,
        rounds,
        direct=(second.unicasts, second.unicast_bytes),
    )
    messages, nbytes = table_cost(table, comm)
    return moves_run(
        "pair-grape-s-chain",
        second.task,
        second.service,
        first.moves + second.moves,
        started=started,
        seed=seed,
        iterations=first.iterations + second.exchanges,
        rounds=rounds,
        messages=messages,
        bytes=nbytes,
        work=first.work + second.work,
        exchanges=second.exchanges,
        pairwise_step_ran=second.ran,
        options=(("order", order), ("capped", True), ("reward", reward), *comm.options),
        communication=table,
        status=deadline.status,
    )


@dataclass
class _ChainOutcome:
    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    ran: bool = False
    exchanges: int = 0
    rounds: int = 0
    unicasts: int = 0
    unicast_bytes: int = 0
    work: int = 0
    moves: list[tuple[int, int, int, int]] = field(default_factory=list)


def _chain_step(
    caps: npt.NDArray[np.bool_],
    reqs: npt.NDArray[np.int64],
    model: RewardModel,
    order: str,
    rng: np.random.Generator,
    task_in: npt.NDArray[np.int64],
    service_in: npt.NDArray[np.int64],
    base_iteration: int,
    deadline: Deadline = NO_DEADLINE,
) -> _ChainOutcome:
    """The chain passes; see :func:`pair_grape_s_chain` Notes."""
    n, n_services = caps.shape
    m = reqs.shape[0]
    task, service = task_in.copy(), service_in.copy()
    out = _ChainOutcome(task, service)
    assigned = task >= 0
    counts = np.zeros((m, n_services), dtype=np.int64)
    np.add.at(counts, (task[assigned], service[assigned]), 1)
    if (counts > reqs).any():  # capped GRAPE-S never over-fills: the proof relies on it
        raise AssertionError("phase 1 left an over-full slot")
    short = counts < reqs  # requirement 0 is never short
    key: Any = model.key

    def needed() -> bool:
        return bool(short.any()) and bool((task < 0).any())

    def chain_lengths() -> npt.NDArray[np.float64]:
        lengths, work = chain_distances(caps, short, task, service)
        out.work += work
        return lengths

    if not needed() or deadline.reached():
        return out
    out.ran = True
    while needed() and not deadline.reached():
        scan = rng.permutation(n) if order == "random" else np.arange(n)
        position = np.empty(n, dtype=np.int64)
        position[scan] = np.arange(n)
        made = 0
        lengths = chain_lengths()
        for o in scan[task[scan] < 0].tolist():
            if not short.any():
                break
            d = lengths[o]
            if not np.isfinite(d):
                continue
            chain, work = trace_chain(o, lengths, caps, task, service, position)
            out.work += work
            found, work = end_slot(chain[-1], caps, short, counts, task, service, key)
            out.work += work
            assert found is not None  # D(last) = 0 guarantees a short slot other than its own
            j_new, s_new = found
            slots = [(int(task[b]), int(service[b])) for b in chain[1:]] + [(j_new, s_new)]
            iteration = base_iteration + out.exchanges + 1
            for robot, (j, s) in zip(chain, slots, strict=True):
                task[robot], service[robot] = j, s
                out.moves.append((iteration, robot, j, s))
            counts[j_new, s_new] += 1
            short[j_new, s_new] = counts[j_new, s_new] < reqs[j_new, s_new]
            partners = len(chain) - 1
            out.exchanges += 1
            out.rounds += 1
            out.unicasts += 2 * partners
            out.unicast_bytes += partners * (request_bytes(partners) + ACCEPT_BYTES)
            made += 1
            if short.any():
                lengths = chain_lengths()
        if made == 0:
            out.rounds += 1  # the quiet pass: one broadcast round, nobody changed
            break
    return out


def chain_distances(
    caps: npt.NDArray[np.bool_],
    short: npt.NDArray[np.bool_],
    task: npt.NDArray[np.int64],
    service: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.float64], int]:
    """``D(b)`` for every robot -- the partners on its shortest chain (``inf``: none) --
    and the arcs searched (the ``work``).

    One backwards shortest-path search from the sink over robots and services (see
    :func:`pair_grape_s_chain`): ``T -> a`` when ``a`` can serve a short slot other than
    its own, ``a -> s`` for an assigned robot ``a`` on service ``s``, ``s -> b`` when ``b``
    has ``s``.  O(n S) with scipy's unweighted Dijkstra.
    """
    n, n_services = caps.shape
    sink = n + n_services
    cap_robot, cap_service = np.nonzero(caps)
    on = task >= 0
    own_short = np.zeros(n, dtype=np.int64)
    own_short[on] = short[task[on], service[on]]
    terminal = np.flatnonzero(caps.astype(np.int64) @ short.sum(axis=0) - own_short > 0)
    holders = np.flatnonzero(on)
    rows = np.concatenate([np.full(terminal.size, sink), holders, n + cap_service])
    cols = np.concatenate([terminal, n + service[holders], cap_robot])
    graph = sp.csr_matrix(
        (np.ones(rows.size, dtype=np.float64), (rows, cols)), shape=(sink + 1, sink + 1)
    )
    dist = shortest_path(graph, method="D", directed=True, unweighted=True, indices=sink)
    return (dist[:n] - 1.0) / 2.0, int(rows.size)


def trace_chain(
    o: int,
    lengths: npt.NDArray[np.float64],
    caps: npt.NDArray[np.bool_],
    task: npt.NDArray[np.int64],
    service: npt.NDArray[np.int64],
    position: npt.NDArray[np.int64],
) -> tuple[list[int], int]:
    """The chain ``[o, a_1, ..., a_k]`` from ``o`` (``lengths[o] = k`` finite): each next
    robot is, of the assigned robots whose slot the current one can take and whose
    distance is one less, the first in ``position`` order.  Returns it and the work."""
    chain, work = [o], 0
    for step in range(int(lengths[o]), 0, -1):
        cur = chain[-1]
        on = task >= 0
        fits = on & caps[cur][np.where(on, service, 0)] & (lengths == step - 1)
        work += int(on.sum())
        nxt = np.flatnonzero(fits)
        chain.append(int(nxt[np.argmin(position[nxt])]))
    return chain, work


def end_slot(
    last: int,
    caps: npt.NDArray[np.bool_],
    short: npt.NDArray[np.bool_],
    counts: npt.NDArray[np.int64],
    task: npt.NDArray[np.int64],
    service: npt.NDArray[np.int64],
    key: Any,
) -> tuple[tuple[int, int] | None, int]:
    """The short slot (not its own) the chain's last robot moves to: the lowest
    ``(key(j, s, c + 1), j, s)``; ``None`` when there is none.  Returns it and the work."""
    own = (int(task[last]), int(service[last])) if task[last] >= 0 else None
    best, work = None, 0
    for s in np.flatnonzero(caps[last]).tolist():
        for j in np.flatnonzero(short[:, s]).tolist():
            if (j, s) == own:
                continue
            work += 1
            candidate = (key(j, s, int(counts[j, s]) + 1), j, s)
            if best is None or candidate < best:
                best = candidate
    return (None if best is None else (best[1], best[2])), work
