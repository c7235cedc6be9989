"""Pair-GRAPE-S: capped GRAPE-S followed by the seed's pairwise exchange step."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_seed
from heuristics._run import NO_DEADLINE, Deadline, Run, check_order, moves_run
from heuristics.communication import belief_rounds_table, comm_model, table_cost
from heuristics.grape_s import _core
from heuristics.reward import RewardModel, reward_model

__all__ = ["pair_grape_s"]


def pair_grape_s(
    mission: Mission,
    *,
    seed: SeedLike = None,
    order: str = "index",
    reward: str = "paper",
    medium: str = "broadcast",
    encoding: str = "full",
    time_limit: float | None = None,
) -> Run:
    """Run Pair-GRAPE-S (the seed's Algorithm 2) on ``mission``.

    Parameters
    ----------
    mission : cfopt.Mission
    seed : None, int or numpy.random.Generator
        Feeds ``numpy.random.default_rng``; ``order="random"`` draws the GRAPE-S round
        orders and then one permutation per pass of the pairwise step from it.
    order : {"index", "random"}
        Robot order of both phases (see :func:`heuristics.grape_s`).
    reward : {"paper", "utility"}
        Reward weighting (:mod:`heuristics.reward`); the seed's Lemma 1 and Theorem 1
        are stated for ``"paper"``.
    medium : {"broadcast", "unicast"}, default "broadcast"
    encoding : {"full", "compact"}, default "full"
        The communication model of ``messages`` and ``bytes``, as in
        :func:`heuristics.grape_s` (:mod:`heuristics.communication`).

    time_limit : float, optional
        Wall-clock seconds after which no further round (GRAPE-S round or pass of the
        second phase) starts; the run then returns the partition reached, ``status``
        ``TIME_LIMIT``.

    Returns
    -------
    Run
        ``algorithm="pair-grape-s"``; ``exchanges`` and ``pairwise_step_ran`` filled in;
        a pairwise exchange appears in ``trajectory`` as two rows with one iteration;
        ``options`` records ``medium`` and ``encoding``, ``communication`` the counts
        under every model.

    Notes
    -----
    Phase 1 is :func:`heuristics.grape_s` with ``capped=True`` (a robot may not join a
    slot that already has ``req[j, s]`` robots: the seed's implementation note).

    Phase 2, the pairwise step (Algorithm 2 after its GRAPE-S phase), runs while some
    slot is *short* (``c < req``) and some robot is unassigned.  A *pass* goes through the robots
    unassigned at its start, in the pass order (robot index order, or a fresh seeded
    permutation of all robots per pass for ``order="random"``).  Unassigned ``a_o``
    examines the assigned robots in the same order and takes the first ``a_i`` such that
    ``a_o`` can perform ``a_i``'s service and ``a_i`` can perform some short slot other
    than its own.  Then ``a_o`` takes ``a_i``'s slot and ``a_i`` moves to its
    highest-reward short slot (minimal ``(key(j, s, c + 1), j, s)``).  Each exchange is one
    iteration and one broadcast round (§3's message model).  A pass that makes no exchange
    ends the step and costs one (quiet) broadcast round; a step that ends because no slot
    is short or no robot is unassigned any more needs no extra round.  The seed's loop
    condition alone ("a task is short and a robot is unassigned") would never end when
    no exchange is possible, e.g. when no unassigned robot shares a service with any
    assigned robot that could fill a short slot: hence the quiet-pass rule.

    The exchange is one hop: ``a_o`` replaces a robot that can itself fill a short slot.
    When the only robot that can fill a short slot sits where ``a_o`` cannot stand in, a
    longer chain would be needed and the step stops short.  ``cfopt audit`` (claim P1)
    finds such achievable missions of the seed's family with as few as 4 robots and one
    task, where Pair-GRAPE-S earns nothing: so the seed's "optimal solutions for all
    problems" does not hold in general.

    Counting.  ``rounds`` = phase-1 rounds + exchanges (+ 1 quiet pass); ``messages``
    and ``bytes`` are those of ``rounds`` belief rounds exactly as in
    :func:`heuristics.grape_s` (``rounds n`` broadcasts or ``rounds n (n - 1)`` unicasts
    of one belief each); the exchange's request and answer are not counted (the seed's
    §3 model counts the broadcast rounds only).

    ``work`` is GRAPE-S's slot examinations plus, in the pairwise step, one unit per
    assigned robot examined as a partner and one per short slot ``a_i`` evaluates.
    Phase 2 costs O(n S) numpy work per unassigned robot per pass.

    Examples
    --------
    >>> import cfopt
    >>> # r0 can do s0 only, r1 both; t0 needs s0, t1 needs s1.  Capped GRAPE-S puts r1
    >>> # on t0 (index order: r1 moves first, to the lowest (key, task)), leaving r0 out.
    >>> m = cfopt.Mission.from_arrays([[1, 0], [1, 1]], [[1, 0], [0, 1]], [1, 1])
    >>> run = pair_grape_s(m)
    >>> run.assignment.task.tolist(), run.assignment.service.tolist()
    ([0, 1], [0, 1])
    >>> run.pairwise_step_ran, run.exchanges, run.iterations, run.trajectory.tolist()
    (True, 1, 2, [[1, 1, 0, 0], [2, 0, 0, 0], [2, 1, 1, 1]])
    >>> # 3 rounds (a move, the quiet round, the exchange) x 2 broadcasts of 16 + 4 x 2
    >>> run.rounds, run.messages, run.bytes
    (3, 6, 144)
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
    second = _pairwise_step(
        caps, reqs, model, order, rng, first.task, first.service, first.iterations, deadline
    )
    rounds = first.rounds + second.rounds
    table = belief_rounds_table(mission.n_robots, mission.n_tasks * mission.n_services, rounds)
    messages, nbytes = table_cost(table, comm)
    return moves_run(
        "pair-grape-s",
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
class _PairOutcome:
    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]
    ran: bool = False
    exchanges: int = 0
    rounds: int = 0
    work: int = 0
    moves: list[tuple[int, int, int, int]] = field(default_factory=list)


def _pairwise_step(
    caps: npt.NDArray[np.bool_],
    reqs: npt.NDArray[np.int64],
    model: RewardModel,
    order: str,
    rng: np.random.Generator,
    task_in: npt.NDArray[np.int64],
    service_in: npt.NDArray[np.int64],
    base_iteration: int,
    deadline: Deadline = NO_DEADLINE,
) -> _PairOutcome:
    """The exchange passes; see :func:`pair_grape_s` Notes."""
    n, n_services = caps.shape
    m = reqs.shape[0]
    task, service = task_in.copy(), service_in.copy()
    out = _PairOutcome(task, service)
    assigned_mask = task >= 0
    counts = np.zeros((m, n_services), dtype=np.int64)
    np.add.at(counts, (task[assigned_mask], service[assigned_mask]), 1)
    short = counts < reqs  # requirement 0 is never short
    caps_int = caps.astype(np.int64)
    key: Any = model.key

    def needed() -> bool:
        return bool(short.any()) and bool((task < 0).any())

    if not needed() or deadline.reached():
        return out
    out.ran = True
    while needed() and not deadline.reached():
        scan = rng.permutation(n) if order == "random" else np.arange(n)
        made = 0
        for o in scan[task[scan] < 0].tolist():
            if not short.any():
                break
            partners = scan[task[scan] >= 0]
            sv, tk = service[partners], task[partners]
            options = caps_int[partners] @ short.sum(axis=0) - short[tk, sv]
            hits = np.flatnonzero(caps[o, sv] & (options > 0))
            if hits.size == 0:
                out.work += int(partners.size)
                continue
            out.work += int(hits[0]) + 1
            a = int(partners[hits[0]])
            j_a, s_a = int(task[a]), int(service[a])
            best = None
            for s in np.flatnonzero(caps[a]).tolist():
                for j in np.flatnonzero(short[:, s]).tolist():
                    if (j, s) == (j_a, s_a):
                        continue
                    out.work += 1
                    candidate = (key(j, s, int(counts[j, s]) + 1), j, s)
                    if best is None or candidate < best:
                        best = candidate
            assert best is not None  # options > 0 guarantees a short slot
            _, j, s = best
            task[o], service[o] = j_a, s_a
            task[a], service[a] = j, s
            counts[j, s] += 1
            short[j, s] = counts[j, s] < reqs[j, s]
            out.exchanges += 1
            out.rounds += 1
            made += 1
            iteration = base_iteration + out.exchanges
            out.moves.append((iteration, o, j_a, s_a))
            out.moves.append((iteration, a, j, s))
        if made == 0:
            out.rounds += 1  # the quiet pass: one broadcast round, nobody changed
            break
    return out
