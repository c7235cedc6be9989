"""GRAPE-S, literally: the executable specification of the fast engine.

A direct transcription of the seed's Algorithm 1 for a fully connected network with
synchronous rounds (every robot acts once per round).  Every robot ``a_i`` keeps its own belief
``(r^i, time^i, id^i, Pi^i)``; in each round every robot, in order, selects on *its own*
belief (lines 4-9), changes only its own belief, then all robots broadcast to all
neighbours (line 10) and run the distributed mutex on the messages received (lines
11-18), keeping the belief with the highest ``(r, time, id)``.  A round in which no robot
changed its belief is the end (the partition is Nash stable).  Messages are built as
bytes (:func:`encode_belief`, in the run's encoding) and counted as sent on the run's
medium (:mod:`heuristics.communication`): one transmission per robot and round when
broadcast (with at least one neighbour), one message per neighbour when unicast.

Nothing here is optimised: it is O(n (n + P)) Python operations per round, with ``P`` the
slots a robot examines.  :func:`heuristics.grape_s` must produce the same trajectory.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from cfopt import Assignment, Mission
from heuristics._run import Run, check_order, seed_label
from heuristics.communication import comm_model, slot_bits
from heuristics.reward import VOID, reward_model

__all__ = ["encode_belief", "grape_s_reference"]


@dataclass(frozen=True)
class _Belief:
    r: int  # evolution number: partition updates seen
    time: int  # time stamp of the latest update
    robot: int  # id of the robot that made it (the mutex's last tie-breaker)
    partition: tuple[int, ...]  # per robot its slot j * S + s, -1 = void task


def encode_belief(belief: _Belief, encoding: str = "full", n_slots: int = 0) -> bytes:
    """A belief as sent: int32 r, int32 id, int64 time, then the slots: ``full``, one
    int32 per robot (-1 void); ``compact``, each robot's slot (``n_slots`` for void) in
    ``ceil(log2(n_slots + 1))`` bits, most significant first, zero-padded to whole bytes.

    >>> len(encode_belief(_Belief(3, 17, 2, (-1, 4, 0))))
    28
    >>> encode_belief(_Belief(3, 17, 2, (-1, 4, 0)), "compact", 6)[16:].hex()  # 110 100 000
    'd000'
    """
    header = np.array([belief.r, belief.robot], dtype="<i4").tobytes()
    header += np.array([belief.time], dtype="<i8").tobytes()
    if encoding == "full":
        return header + np.array(belief.partition, dtype="<i4").tobytes()
    values = np.array([n_slots if p < 0 else p for p in belief.partition], dtype=np.int64)
    shifts = np.arange(slot_bits(n_slots) - 1, -1, -1, dtype=np.int64)
    bits = ((values[:, None] >> shifts[None, :]) & 1).astype(np.uint8).ravel()
    return header + np.packbits(bits).tobytes()


def grape_s_reference(
    mission: Mission,
    *,
    seed: int | np.random.Generator | None = None,
    order: str = "index",
    capped: bool = False,
    reward: str = "paper",
    medium: str = "broadcast",
    encoding: str = "full",
) -> Run:
    """GRAPE-S by per-robot beliefs and the distributed mutex (slow; the specification).

    Same parameters, semantics and result as :func:`heuristics.grape_s`.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    >>> run = grape_s_reference(m)
    >>> run.assignment.task.tolist(), run.iterations, run.rounds
    ([1, 0, 0], 3, 4)
    """
    started = time.perf_counter()
    check_order(order)
    comm = comm_model(medium, encoding)
    model = reward_model(mission, reward)
    rng = np.random.default_rng(seed)
    n, S = mission.n_robots, mission.n_services
    n_slots = mission.n_tasks * S
    reqs = mission.requirements.tolist()
    services_of = [np.flatnonzero(row).tolist() for row in mission.capabilities]
    tasks_of = [np.flatnonzero(mission.requirements[:, s]).tolist() for s in range(S)]

    # Initialization (lines 1-2): every robot on the void task, r = 0.
    beliefs = [_Belief(0, 0, -1, (-1,) * n) for _ in range(n)]
    rounds = iterations = work = messages = nbytes = 0
    moves: list[tuple[int, int, int, int]] = []
    while True:
        rounds += 1
        before = beliefs[0].partition if n else ()
        sequence = rng.permutation(n).tolist() if order == "random" else range(n)
        changed = False
        for position, i in enumerate(sequence):
            belief = beliefs[i]
            counts = [[0] * S for _ in reqs]
            for slot in belief.partition:
                if slot >= 0:
                    counts[slot // S][slot % S] += 1
            own = belief.partition[i]
            current = VOID
            if own >= 0:
                current = model.key(own // S, own % S, counts[own // S][own % S])
                work += 1
            best = None  # lines 4: argmax over coalitions and services, ties: lowest (j, s)
            for s in services_of[i]:
                for j in tasks_of[s]:
                    if j * S + s == own:
                        continue
                    work += 1
                    c = counts[j][s]
                    if capped and c >= reqs[j][s]:
                        continue
                    candidate = (model.key(j, s, c + 1), j, s)
                    if best is None or candidate < best:
                        best = candidate
            if best is not None and best[0] < current:  # line 5: strictly better
                _, j, s = best
                partition = list(belief.partition)
                partition[i] = j * S + s
                beliefs[i] = _Belief(
                    belief.r + 1, (rounds - 1) * n + position + 1, i, tuple(partition)
                )  # lines 6-8
                changed = True
        # Line 10: broadcast to every neighbour (fully connected), receive theirs.
        sent = list(beliefs)
        for i in range(n):
            size = len(encode_belief(sent[i], comm.encoding, n_slots))
            sends = n - 1 if comm.medium == "unicast" else min(n - 1, 1)
            messages += sends
            nbytes += size * sends
        # Lines 11-18: the distributed mutex over the received messages.
        for i in range(n):
            mine = beliefs[i]
            for k in [i, *range(n)]:
                other = sent[k]
                if (other.r, other.time, other.robot) > (mine.r, mine.time, mine.robot):
                    mine = replace(other)
            beliefs[i] = mine
        if n and any(b != beliefs[0] for b in beliefs):  # pragma: no cover - fully connected
            raise AssertionError("beliefs disagree after the mutex")
        if not changed:
            break
        iterations += 1
        after = beliefs[0].partition if n else ()
        diff = [i for i in range(n) if after[i] != before[i]]
        for i in diff:
            moves.append((iterations, i, after[i] // S, after[i] % S))

    final = np.array(beliefs[0].partition if n else [], dtype=np.int64)
    task = np.where(final >= 0, final // max(S, 1), -1)
    service = np.where(final >= 0, final % max(S, 1), -1)
    return Run(
        algorithm="grape-s",
        assignment=Assignment(task=task, service=service),
        iterations=iterations,
        rounds=rounds,
        messages=messages,
        bytes=nbytes,
        work=work,
        seconds=time.perf_counter() - started,
        seed=seed_label(seed),
        trajectory=np.array(moves, dtype=np.int64).reshape(-1, 4),
        options=(
            ("order", order),
            ("capped", bool(capped)),
            ("reward", reward),
            *comm.options,
            ("engine", "reference"),
        ),
    )
