"""Distributed runs as real processes: the robots' agents over MPI (mpi4py).

The simulator (:mod:`heuristics.simulate`) runs the agents of :mod:`heuristics.agents` on
a modelled network, reproducibly on one machine.  This module runs the *same agent
objects* as MPI processes that exchange real messages, as the seed's own evaluation did,
so that wall-clock time and bytes on a real network can be measured and the simulator's
model held against them.  Only the transport differs; the algorithms are not written
again.

* :func:`mpi_run` (``cfopt run ALG MISSION --backend mpi --ranks K``) launches ``mpiexec
  -n K python -m cfopt.mpi ...`` and returns the run gathered on rank 0 (the waiting,
  killing and error lines: :mod:`heuristics.mpi_job`);
* :func:`run_ranks` is what every rank executes (``mpiexec -n K python -m cfopt.mpi ALG
  MISSION ...`` on a cluster whose launcher is given); collective over ``comm``.

It needs the ``mpi`` extra: ``pip install "cfopt[mpi]"`` (mpi4py, and MPICH's wheel,
which brings ``mpiexec``).

Placement
---------
Rank ``r`` of ``K`` hosts the robots ``r n // K .. (r + 1) n // K - 1`` (contiguous blocks;
one robot per rank when ``K = n``; ``1 <= K <= n``).  Each rank builds the whole mission,
the topology and the clocks from the run's seed -- the same as the simulator's for the
same seed -- and the agents of its own robots only.

Messages on the wire
--------------------
A robot's broadcast is one MPI message to each *other rank* hosting a neighbour of it
(the robots of its own rank hear it without MPI); its bytes are exactly the belief
encoder's (``16 + 4 n``; ``24 + 4 n`` for Pair-GRAPE-S), its tag ``2 * sender``.  A direct
message (request, answer) is one MPI message to the rank of its destination robot, bytes
exactly its encoder's, tag ``2 * destination + 1``.  Sends are non-blocking (``Isend``:
the seed's UDP-like model); ranks probe for messages (``Iprobe``) between ticks.  The
transport counts the messages and bytes it hands to MPI (``wire_messages``,
``wire_bytes``) and, on the receiving side, the encoder's size of every message it decoded
(``received_bytes``): with no message left in flight the two byte counts are equal.

Injected physics
----------------
The spec's topology decides who hears a broadcast; its latency and loss are injected on
top of the real network's.  The receiving rank draws, for each of its robots hearing a
broadcast, a delay and a loss (per directed link, as the simulator's
:class:`heuristics.network.Links`) and hands the belief to the robot at its first tick
after receipt plus delay.  A direct message's route is drawn at its sender, hop by hop
along a shortest path (a lost hop drops it), and the sender holds it for the route's delay
before sending it.  ``run.messages`` and ``run.bytes`` count the robots' transmissions as
the simulator does (a broadcast is one transmission under ``medium=broadcast``; a direct
message one per hop); each rank draws from its own generators, spawned from the seed.

Clocks
------
Asynchronous (the default): robot ``i``'s tick ``k`` is due at ``t0 +
Clocks.tick_time(i, k)`` of real monotonic time, ``t0`` taken on every rank right after
a barrier.  A rank ticks its due robots in due order and sleeps otherwise; a rank that
falls behind ticks late, and a robot's ticks that passed meanwhile are coalesced into one
(``missed_ticks`` counts them), as a periodic timer's overruns are: an overloaded robot
ticks less often, never twice without looking at the wire in between.  Beliefs are stamped with the
real nanoseconds since ``t0``.

``sync=true``: lock-step rounds.  Round ``k`` ticks every robot at the logical time ``k *
period`` (paced to real time), then the ranks exchange the round's messages (an
``alltoall`` of counts, then exactly those messages), so a message sent in round ``k``
with a delay below the period is seen in round ``k + 1``, the simulator's rule.  With the
same seed, a fixed latency and no loss, a lock-step MPI run makes the simulator's run, move
for move.

Termination
-----------
Every robot stops by its agent's own rule (``K d_G`` quiet ticks).  A rank whose robots
have all stopped and whose held messages are sent enters a non-blocking barrier and keeps
receiving until every rank has; the ranks then exchange how many messages each sent to
each and receive the rest, so nothing is left in flight.  A run that reaches its time
limit (real seconds; logical ones with ``sync=true``) is cut.

Outcome
-------
Gathered on rank 0, in the same frozen :class:`heuristics.Run` as the simulator's: each
robot performs the slot of its own final belief (split brains included); ``converged`` and
``beliefs_agree`` as the simulator's; the trajectory is the newest final belief's history,
rebuilt from the updates every rank recorded (each with the key of the belief it was made
on).  ``run.network.transport`` is the :class:`TransportReport`.
"""

from __future__ import annotations

import dataclasses
import heapq
import itertools
import os
import shlex
import shutil
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError, require_mission
from cfopt.checks import require_choice, require_int, require_seed
from heuristics._run import Run, seed_label
from heuristics.agents.belief import Belief, Problem, decode_belief
from heuristics.agents.grape_s import decode_message
from heuristics.mpi_job import job_folder, run_job
from heuristics.network import Clocks, Links, NetworkSpec
from heuristics.reward import REWARDS
from heuristics.simulate import (
    DEFAULT_TIME_LIMIT,
    QUIET_FACTOR,
    NetworkReport,
    _entropy,
    _InFlight,
    _packed,
    _protocol,
    _Ticking,
    network_spec,
    run_limits,
)

__all__ = ["INSTALL", "MPI_ALGORITHMS", "TransportReport", "mpi_run", "run_ranks"]

#: The algorithms whose agents run over MPI (their messages have decoders).
MPI_ALGORITHMS = ("grape-s", "pair-grape-s", "pair-grape-s-chain")
#: What to install for ``backend="mpi"``.
INSTALL = 'pip install "cfopt[mpi]"'
#: Environment variable naming the launcher command (default: ``mpiexec`` next to Python,
#: then on ``PATH``), e.g. ``"mpiexec --oversubscribe"`` for Open MPI.
LAUNCHER_ENV = "CFOPT_MPIEXEC"
_BELIEF, _DIRECT = 0, 1  # tag = 2 * robot + kind
_SLEEP_NS = 200_000  # the longest nap between two looks at the wire


@dataclass(frozen=True)
class TransportReport:
    """What the MPI processes measured (frozen; ``run.network.transport``).

    Attributes
    ----------
    backend : str
        ``"mpi"``.
    ranks : int
    robots_per_rank : tuple of int
    library : str
        The MPI library's version line.
    wall_seconds : float
        From the start barrier until every rank was done and drained (rank 0's clock).
    launch_seconds : float or None
        The launcher's whole call (``mpiexec`` start-up, mission reading, gathering);
        ``None`` when the ranks were started by hand.
    wire_messages, wire_bytes : int
        MPI messages and payload bytes the ranks sent.
    received_messages, received_bytes : int
        MPI messages the ranks received, and the encoder's size of each decoded message.
    missed_ticks : int
        Clock ticks a robot did not get because its rank was busy past them (coalesced,
        as a periodic timer's overruns are; 0 when every rank kept up).
    """

    backend: str
    ranks: int
    robots_per_rank: tuple[int, ...]
    library: str
    wall_seconds: float
    launch_seconds: float | None
    wire_messages: int
    wire_bytes: int
    received_messages: int
    received_bytes: int
    missed_ticks: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        out = dataclasses.asdict(self)
        out["robots_per_rank"] = list(self.robots_per_rank)
        return out


# --------------------------------------------------------------------------- launcher
def check_backend(algorithm: str, n_robots: int, ranks: Any) -> int:
    """Refuse, before anything is launched, what an MPI run cannot do; returns ``ranks``.

    Raises :class:`cfopt.MissionError` naming the option (``algorithm``, ``ranks``).
    """
    if algorithm not in MPI_ALGORITHMS:
        raise MissionError(
            f"algorithm: {algorithm!r} has no MPI agents (available: {', '.join(MPI_ALGORITHMS)})"
        )
    ranks = require_int("ranks", ranks, minimum=1)
    if ranks > max(n_robots, 1):
        raise MissionError(
            f"ranks: at most one rank per robot ({n_robots} robots), got {int(ranks)}"
        )
    return int(ranks)


def launcher() -> list[str]:
    """The ``mpiexec`` command: ``$CFOPT_MPIEXEC`` (split like a shell), else the
    ``mpiexec`` beside the running Python (where the ``mpi`` extra's MPICH wheel puts
    it), else the one on ``PATH``.  Raises :class:`cfopt.MissionError` (with the install
    command) when there is none, or when mpi4py is missing."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        raise MissionError(
            f"backend: mpi4py is not installed; install the mpi extra: {INSTALL}"
        ) from None
    given = os.environ.get(LAUNCHER_ENV)
    if given:
        try:
            command = shlex.split(given)
        except ValueError as exc:  # an unclosed quote, a lone backslash
            raise MissionError(
                f"backend: {LAUNCHER_ENV}={given!r} is not a command line ({exc})"
            ) from None
        if command and shutil.which(command[0]):
            return command
        raise MissionError(f"backend: {LAUNCHER_ENV}={given!r} is not a command that exists")
    beside = Path(sys.executable).parent / "mpiexec"
    if beside.is_file() and os.access(beside, os.X_OK):
        return [str(beside)]
    found = shutil.which("mpiexec")
    if found:
        return [found]
    raise MissionError(
        "backend: no MPI launcher (mpiexec) beside Python or on PATH; install the mpi "
        f"extra: {INSTALL} (MPICH's wheel brings mpiexec), or set {LAUNCHER_ENV}"
    )


def mpi_run(
    mission: Mission,
    algorithm: str,
    network: str | NetworkSpec = "complete",
    *,
    ranks: int = 2,
    seed: int | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int = QUIET_FACTOR,
    reward: str = "paper",
) -> Run:
    """Run ``algorithm``'s agents as ``ranks`` MPI processes (module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    algorithm : {"grape-s", "pair-grape-s", "pair-grape-s-chain"}
    network : str or NetworkSpec, default "complete"
        Topology, injected latency and loss, clocks (as :func:`heuristics.simulate`).
    ranks : int, default 2
        MPI processes, ``1 <= ranks <= n``.
    seed : None or int
        Topology, clocks and the injected draws flow from it (``None``: fresh).
    time_limit : float, default 3600
        Seconds (real; logical with ``sync=true``) after which the run is cut, at most
        :data:`heuristics.simulate.MAX_TIME_LIMIT` (8796).
    quiet_factor, reward
        As :func:`heuristics.simulate`.

    Returns
    -------
    Run
        As the simulator's, with ``options`` ``engine="mpi"`` and ``ranks``, and
        ``run.network.transport`` the :class:`TransportReport`.

    Raises
    ------
    cfopt.MissionError
        A bad argument or network (checked before anything is launched), or no mpi4py /
        no launcher (naming ``pip install "cfopt[mpi]"``).
    heuristics.mpi_job.MPIJobError
        The MPI job failed (a :class:`cfopt.MissionError` and a :class:`RuntimeError`):
        one line naming the launcher or the rank and how (a rank's own error line as it
        is), e.g. a rank killed or stopped, or the job still running ``time_limit +``
        :data:`heuristics.mpi_job.GRACE` seconds after its ranks started (it is killed).
    RuntimeError
        A rank crashed with a traceback (the end of the job's output is in the message).

    Notes
    -----
    The launcher runs in a session of its own and dies with this process; its ranks die
    with it too, and whatever is left of the job when it ends is killed
    (:mod:`heuristics.mpi_job`).  The job's folder (``cfopt-mpi-PID-*`` in the temporary
    directory) goes with the run; if this process is killed by SIGKILL, the next MPI run
    removes it.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.generate_mission(20, 20, 4, 2, seed=1)
    >>> run = mpi_run(m, "grape-s", "complete period=1ms sync=true", ranks=2, seed=0)
    >>> run.network.transport.ranks, run.network.converged, run.assignment.percent_utility(m)
    (2, True, 100.0)
    >>> run.network.transport.wire_bytes == run.network.transport.received_bytes
    True
    """
    started = time.perf_counter()
    require_mission(mission)
    spec = network_spec(network)
    ranks = check_backend(algorithm, mission.n_robots, ranks)
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    seed = require_seed("seed", seed, generator=False)
    require_choice("reward", reward, REWARDS)
    command = launcher()
    fresh = None if seed is not None else int(np.random.SeedSequence().entropy)
    world = seed if fresh is None else np.random.default_rng(fresh)  # what rank 0 gets
    # the ranks' own network: a bad one is the simulator's error line, before any launch
    spec.build(mission, np.random.default_rng(_world_streams(_entropy(world))[0]))
    with job_folder() as folder:
        mission_file = folder / "mission.json"
        mission_file.write_text(mission.to_json(), encoding="utf-8")
        result_file = folder / "run.pickle"
        program = [sys.executable, "-m", "cfopt.mpi", algorithm, str(mission_file)]
        program += ["--network", spec.to_text(), "--result-file", str(result_file)]
        program += ["--time-limit", repr(limit / 1e9), "--quiet-factor", str(quiet_factor)]
        program += ["--reward", reward]
        program += ["--seed", str(seed)] if fresh is None else ["--entropy", str(fresh)]
        run = run_job(
            command,
            ranks,
            program,
            folder=folder,
            result=result_file,
            time_limit=limit / 1e9,
            kind=Run,
        )
    transport = dataclasses.replace(
        run.network.transport, launch_seconds=time.perf_counter() - started
    )
    report = dataclasses.replace(run.network, transport=transport)
    return dataclasses.replace(run, network=report)


def _world_streams(entropy: Any) -> list[np.random.SeedSequence]:
    """The topology's, the clocks', the latencies' and the losses' streams of a run."""
    return np.random.SeedSequence(entropy).spawn(4)


# ------------------------------------------------------------------------------ ranks
def run_ranks(
    mission: Mission,
    algorithm: str,
    network: str | NetworkSpec = "complete",
    *,
    seed: int | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int = QUIET_FACTOR,
    reward: str = "paper",
    comm: Any = None,
) -> Run | None:
    """One rank's share of an MPI run (collective over ``comm``, default
    ``MPI.COMM_WORLD``); returns the :class:`heuristics.Run` on rank 0 and ``None`` on
    the others.  Arguments as :func:`mpi_run`; the ranks are ``comm``'s."""
    from mpi4py import MPI

    started = time.perf_counter()
    comm = MPI.COMM_WORLD if comm is None else comm
    require_mission(mission)
    spec = network_spec(network)
    check_backend(algorithm, mission.n_robots, comm.Get_size())
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    entropy = comm.bcast(
        np.random.SeedSequence(_entropy(seed)).entropy if comm.Get_rank() == 0 else None
    )
    rank = _Rank(comm, mission, algorithm, spec, entropy, limit, quiet_factor, reward)
    rank.run()
    return rank.gather(seed_label(seed), started)


class _Rank(_Ticking):
    """One MPI process: its robots' agents, their clocks and the wire (module docstring)."""

    def __init__(
        self,
        comm: Any,
        mission: Mission,
        algorithm: str,
        spec: NetworkSpec,
        entropy: Any,
        limit: int,
        quiet_factor: int,
        reward: str,
    ) -> None:
        from mpi4py import MPI

        self.MPI, self.comm = MPI, comm
        self.rank, self.size = comm.Get_rank(), comm.Get_size()
        self.mission, self.algorithm, self.spec, self.limit = mission, algorithm, spec, limit
        self.reward, self.quiet_factor = reward, quiet_factor
        n = self.n = mission.n_robots
        if 2 * n + 1 > int(comm.Get_attr(MPI.TAG_UB)):
            raise MissionError(f"ranks: this MPI's tags cannot name {n} robots")
        self._draw_the_world(entropy)
        self.problem = Problem(mission, reward)
        self.quiet_limit = quiet_factor * max(self.network.diameter, 1)
        self.protocol = _protocol(algorithm)
        self._place_the_robots()
        self.agents = {i: self.protocol.make_agent(self, i) for i in self.local}
        self.inflight = _InFlight(n)
        self.key_r = np.zeros(n, dtype=np.int64)
        self.key_tid = np.zeros(n, dtype=np.int64)
        self.stopped = np.zeros(n, dtype=bool)
        self.inbox: dict[int, list[tuple[int, Any]]] = {i: [] for i in self.local}
        self.changed_at = dict.fromkeys(self.local, 0)
        self.held: list[tuple[int, int, int, Any, bytes]] = []  # direct messages due
        self.seq = itertools.count()
        self.fanout: dict[int, tuple[list[int], npt.NDArray[np.int64]]] = {}
        self.hearers: dict[int, npt.NDArray[np.int64]] = {}
        self.known: dict[tuple[int, int, int], Belief] = {}  # decoded beliefs by key
        self.node_key: dict[int, tuple[Any, tuple[int, int, int]]] = {}
        self.updates: dict[tuple[int, int, int], tuple[Any, Any]] = {}
        self.requests: list[Any] = []
        self.sent_to = [0] * self.size
        self.received_from = [0] * self.size
        self.round_sent = [0] * self.size
        self.status = MPI.Status()
        self.unicast = spec.medium == "unicast"
        self.transmissions = self.receptions = self.losses = self.bytes = 0
        self.ticks = self.work = self.missed_ticks = 0
        self.wire_messages = self.wire_bytes = 0
        self.received_messages = self.received_bytes = 0
        self.cut = False
        self.end = 0
        self.t0 = 0
        self.wall = 0.0

    def _draw_the_world(self, entropy: Any) -> None:
        """Topology and clocks: the simulator's, the same on every rank; the injected
        latencies and losses: this rank's own generators."""
        topology, clock, latency, loss = _world_streams(entropy)
        self.network = self.spec.build(self.mission, np.random.default_rng(topology))
        self.clocks = Clocks(self.spec, self.n, np.random.default_rng(clock))
        own_latency = latency.spawn(self.size)[self.rank]
        losses = loss.spawn(2 * self.size)
        self.tally = np.random.default_rng(losses[self.size + self.rank])
        self.links = Links(
            self.network,
            np.random.default_rng(own_latency),
            np.random.default_rng(losses[self.rank]),
        )

    def _place_the_robots(self) -> None:
        """Contiguous blocks: rank ``r`` hosts robots ``r n // K .. (r + 1) n // K - 1``."""
        bounds = [r * self.n // self.size for r in range(self.size + 1)]
        self.robots_per_rank = tuple(int(b - a) for a, b in itertools.pairwise(bounds))
        self.owner = np.repeat(np.arange(self.size), np.diff(bounds)).astype(np.int64)
        self.local = list(range(bounds[self.rank], bounds[self.rank + 1]))

    # ---------------------------------------------------------------- the clocks
    def run(self) -> None:
        self.comm.Barrier()
        self.t0 = time.monotonic_ns()
        if self.spec.sync:
            self._lock_step()
        else:
            self._free_running()
        self._drain()
        self.wall = (time.monotonic_ns() - self.t0) / 1e9

    def _now(self) -> int:
        return time.monotonic_ns() - self.t0

    def _free_running(self) -> None:
        due = [(self.clocks.tick_time(i, 0), i, 0) for i in self.local]
        heapq.heapify(due)
        while due or self.held:
            now = self._now()
            if now > self.limit:
                self.cut = True
                break
            self._poll(now)
            self._release(now)
            if due and due[0][0] <= now:
                _, i, k = heapq.heappop(due)
                if self._tick(i, now):
                    k = self._next_tick(i, k, self._now())
                    heapq.heappush(due, (self.clocks.tick_time(i, k), i, k))
                continue
            self._nap(
                min(due[0][0] if due else self.limit, self.held[0][0] if self.held else self.limit)
            )

    def _next_tick(self, i: int, k: int, now: int) -> int:
        """Robot ``i``'s next tick after tick ``k`` processed at ``now``: ``k + 1``, or,
        when its rank fell behind, the first tick still to come (missed ticks are
        coalesced, as a periodic timer's overruns are; ``missed_ticks`` counts them)."""
        nxt = k + 1
        period = self.spec.period_ns
        if self.clocks.tick_time(i, nxt) <= now:
            nxt = max(nxt, (now - int(self.clocks.offsets_ns[i])) // period)
            while self.clocks.tick_time(i, nxt) <= now:
                nxt += 1
            self.missed_ticks += nxt - k - 1
        return nxt

    def _nap(self, until: int) -> None:
        wait = min(until - self._now(), _SLEEP_NS)
        if wait > 0:
            time.sleep(wait / 1e9)

    def _lock_step(self) -> None:
        period = self.spec.period_ns
        active = list(self.local)
        for k in itertools.count():
            now = k * period
            if now > self.limit:
                self.cut = True
                break
            while self._now() < now:
                self._nap(now)
            active = [i for i in active if self._tick(i, now)]
            self._release((k + 1) * period - 1)
            busy = bool(active) or bool(self.held)
            counts = self.comm.alltoall([(sent, busy) for sent in self.round_sent])
            self.round_sent = [0] * self.size
            for source, (count, _) in enumerate(counts):
                for _ in range(count):
                    self._receive(source, now)
            if not any(other for _, other in counts):
                break

    # ------------------------------------------------------------------ a tick
    def _tick(self, i: int, now: int) -> bool:
        """Robot ``i``'s tick at ``now``; ``False`` when it stopped."""
        self.ticks += 1
        self.end = max(self.end, now)
        belief, before, sends = self._agent_tick(i, now)
        if belief.key != before:
            self._record(i, belief, now)
            self.key_r[i], self.key_tid[i] = _packed(belief.key)
            self.changed_at[i] = now
        self._broadcast(i, belief, now)
        for dest, message in sends:
            self._send(i, dest, message, now)
        if self.agents[i].stopped:
            self.stopped[i] = True
            return False
        return True

    def _record(self, i: int, belief: Belief, now: int) -> None:
        """Remember the updates robot ``i`` made this tick, each with the key of the
        belief it was made on (the trajectory is rebuilt from these on rank 0)."""
        fresh = []
        node = belief.trail
        while node is not None and id(node) not in self.node_key:
            fresh.append(node)
            node = node[2]
        parent = None if node is None else self.node_key[id(node)][1]
        for made in reversed(fresh):
            key = (made[0], now, i)
            self.node_key[id(made)] = (made, key)
            self.updates[key] = (made[1], parent)
            parent = key

    # ------------------------------------------------------------------ sending
    def _broadcast(self, i: int, belief: Belief, now: int) -> None:
        ranks, local = self._fanout(i)
        if not ranks and local.size == 0:
            return
        payload = self.protocol.encode(belief, self.agents[i])
        sends = self.network.degree(i) if self.unicast else 1
        self.transmissions += sends
        self.bytes += sends * len(payload)
        for rank in ranks:
            self._isend(payload, rank, 2 * i + _BELIEF)
        if local.size:
            self._hear(i, belief, local, now)

    def _fanout(self, i: int) -> tuple[list[int], npt.NDArray[np.int64]]:
        """The other ranks hosting a neighbour of robot ``i``, and its neighbours here."""
        found = self.fanout.get(i)
        if found is None:
            receivers = self.network.neighbours(i)
            owners = self.owner[receivers]
            ranks = [r for r in np.unique(owners).tolist() if r != self.rank]
            found = self.fanout[i] = (ranks, receivers[owners == self.rank])
        return found

    def _send(self, source: int, dest: int, message: Any, now: int) -> None:
        """A direct message: its route drawn hop by hop now, held for the route's delay."""
        payload = message.encode()
        at, due = source, now
        while at != dest:
            nxt = dest if self.network.indptr is None else self.network.next_hop(at, dest)
            delay, lost = self.links.transmit_one(at, nxt)
            self.transmissions += 1
            self.bytes += len(payload)
            if lost:
                self.losses += 1
                return
            self.receptions += 1
            due += delay
            at = nxt
        heapq.heappush(self.held, (due, next(self.seq), dest, message, payload))

    def _release(self, until: int) -> None:
        """Send (or deliver here) the held direct messages due by ``until``."""
        while self.held and self.held[0][0] <= until:
            due, _, dest, message, payload = heapq.heappop(self.held)
            owner = int(self.owner[dest])
            if owner == self.rank:
                self.inbox[dest].append((due, message))
            else:
                self._isend(payload, owner, 2 * dest + _DIRECT)

    def _isend(self, payload: bytes, rank: int, tag: int) -> None:
        request = self.comm.Isend([payload, self.MPI.BYTE], dest=rank, tag=tag)
        self.requests.append((request, payload))
        self.sent_to[rank] += 1
        self.round_sent[rank] += 1
        self.wire_messages += 1
        self.wire_bytes += len(payload)
        if len(self.requests) >= 1024:
            self.requests = [(r, p) for r, p in self.requests if not r.Test()]

    # ---------------------------------------------------------------- receiving
    def _poll(self, now: int) -> None:
        """Receive every message that has come in."""
        MPI = self.MPI
        while self.comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=self.status):
            self._receive(self.status.Get_source(), now)

    def _receive(self, source: int, arrival: int) -> None:
        """Receive the next message from ``source`` (blocking) and hand it over, as
        arrived at ``arrival`` (the receipt, or the round it was sent in)."""
        status = self.status
        self.comm.Probe(source=source, tag=self.MPI.ANY_TAG, status=status)
        buffer = bytearray(status.Get_count(self.MPI.BYTE))
        tag = status.Get_tag()
        self.comm.Recv([buffer, self.MPI.BYTE], source=source, tag=tag)
        self.received_from[source] += 1
        self.received_messages += 1
        robot, kind = divmod(tag, 2)
        if kind == _BELIEF:
            belief = self._belief(bytes(buffer))
            self.received_bytes += len(self.protocol.encode(belief, self))
            hearers = self._hearers(robot)
            if hearers.size:
                self._hear(robot, belief, hearers, arrival)
            return
        message = decode_message(bytes(buffer))
        self.received_bytes += len(message.encode())
        self.inbox[robot].append((arrival, message))

    @property
    def pairwise(self) -> bool:
        """Whether beliefs carry the pairwise step's pass state (for the encoder)."""
        return self.protocol.pairwise

    def _belief(self, payload: bytes) -> Belief:
        """The belief a broadcast carries: one object per key on a rank (so its cached
        selections are computed once), its trail a stub standing for its key."""
        belief = decode_belief(payload, self.n, pairwise=self.protocol.pairwise)
        known = self.known.get(belief.key)
        if known is not None:
            return known
        stub = (belief.r, (), None)
        belief.trail = stub
        self.node_key[id(stub)] = (stub, belief.key)
        self.known[belief.key] = belief
        return belief

    def _hearers(self, sender: int) -> npt.NDArray[np.int64]:
        found = self.hearers.get(sender)
        if found is None:
            receivers = self.network.neighbours(sender)
            found = self.hearers[sender] = receivers[self.owner[receivers] == self.rank]
        return found

    def _hear(
        self, sender: int, belief: Belief, receivers: npt.NDArray[np.int64], sent: int
    ) -> None:
        """``receivers`` (robots of this rank) hear ``sender``'s broadcast sent at
        ``sent``: an injected delay and loss each, kept when it can change anything (the
        simulator's rule).

        Most broadcasts repeat a belief their receivers already hold; under Bernoulli
        loss only the receptions that can matter get their own draws, and the losses of
        the others are counted with one binomial draw (the same law, far fewer draws).
        Gilbert-Elliott loss has a state per link, so every reception draws.
        """
        useful = self._can_change(belief, receivers)
        if self.spec.loss.kind == "ge":
            delays, lost = self.links.transmit(sender, receivers)
            dropped = int(lost.sum())
            kept = useful & ~lost
            hearing, delays = receivers[kept], delays[kept]
        else:
            targets = receivers[useful]
            delays, lost = self.links.transmit(sender, targets)
            dropped = int(lost.sum()) + self._unseen_losses(receivers.size - targets.size)
            hearing, delays = targets[~lost], delays[~lost]
        self.losses += dropped
        self.receptions += receivers.size - dropped
        if hearing.size:
            self.inflight.add(belief, hearing, sent + delays)

    def _unseen_losses(self, count: int) -> int:
        """How many of ``count`` Bernoulli receptions that cannot matter were lost."""
        p = self.spec.loss.probabilities[0]
        return int(self.tally.binomial(count, p)) if count and p > 0 else 0

    def _drain(self) -> None:
        """Wait for every rank, then receive whatever is still on its way here."""
        barrier = self.comm.Ibarrier()
        while not barrier.Test():
            self._poll(self._now())
            time.sleep(_SLEEP_NS / 1e9)
        expected = self.comm.alltoall(self.sent_to)
        now = self._now()
        for source, count in enumerate(expected):
            while self.received_from[source] < count:
                self._receive(source, now)
        self.MPI.Request.Waitall([request for request, _ in self.requests])
        self.requests = []

    # ------------------------------------------------------------------ the result
    def gather(self, seed: int | None, started: float) -> Run | None:
        """Every rank's robots and counts to rank 0, which builds the run."""
        finals = {agent.belief.key: agent.belief for agent in self.agents.values()}
        share = {
            "slots": {i: a.performed_slot() for i, a in self.agents.items()},
            "keys": {i: a.belief.key for i, a in self.agents.items()},
            "ticks": [a.ticks for a in self.agents.values()],
            "proposals": sum(a.proposals for a in self.agents.values()),
            "step_needed": any(getattr(a, "step_needed", False) for a in self.agents.values()),
            "changed_at": self.changed_at,
            "updates": self.updates,
            "finals": {key: self.protocol.encode(b, self) for key, b in finals.items()},
            "counts": {name: getattr(self, name) for name in _COUNTERS},
            "end": self.end,
            "cut": self.cut,
        }
        shares = self.comm.gather(share, root=0)
        if self.rank != 0:
            return None
        return self._assemble(shares, seed, time.perf_counter() - started)

    def _assemble(self, shares: Sequence[dict[str, Any]], seed: int | None, seconds: float) -> Run:
        """Rank 0: the run from every rank's share (module docstring, Outcome)."""
        merged = _Merged(shares, self.n)
        S = max(self.mission.n_services, 1)
        newest_key = max(merged.keys.values(), default=(0, 0, -1))
        newest = (
            decode_belief(merged.payloads[newest_key], self.n, pairwise=self.protocol.pairwise)
            if merged.keys
            else Belief.initial(self.n)
        )
        agree = len(set(merged.keys.values())) <= 1
        converged = agree and self.protocol.final(self, newest)
        history = _history(merged.updates, newest_key)
        moves = [(r, robot, slot) for r, changes in history for robot, slot in reversed(changes)]
        moves.reverse()
        trajectory = [
            (it, robot, slot // S if slot >= 0 else -1, slot % S if slot >= 0 else -1)
            for it, robot, slot in moves
        ]
        slots = merged.slots
        return Run(
            algorithm=self.algorithm,
            assignment=Assignment(
                task=np.where(slots >= 0, slots // S, -1),
                service=np.where(slots >= 0, slots % S, -1),
            ),
            iterations=newest_key[0],
            rounds=max((t for s in shares for t in s["ticks"]), default=0),
            messages=merged.counts["transmissions"],
            bytes=merged.counts["bytes"],
            work=merged.counts["work"],
            seconds=seconds,
            seed=seed,
            exchanges=sum(1 for _, changes in history if len(changes) >= 2),
            pairwise_step_ran=any(s["step_needed"] for s in shares),
            trajectory=np.array(trajectory, dtype=np.int64).reshape(-1, 4),
            options=(
                ("network", self.spec.to_text()),
                ("quiet_factor", self.quiet_factor),
                ("capped", self.protocol.pairwise),
                ("reward", self.reward),
                ("engine", "mpi"),
                ("ranks", self.size),
            ),
            network=self._report(merged, shares, converged=bool(converged), agree=agree),
        )

    def _report(
        self, merged: _Merged, shares: Sequence[dict[str, Any]], *, converged: bool, agree: bool
    ) -> NetworkReport:
        from mpi4py import MPI

        counts = merged.counts
        transport = TransportReport(
            backend="mpi",
            ranks=self.size,
            robots_per_rank=self.robots_per_rank,
            library=" ".join(MPI.Get_library_version().split()[:3]),
            wall_seconds=self.wall,
            launch_seconds=None,
            wire_messages=counts["wire_messages"],
            wire_bytes=counts["wire_bytes"],
            received_messages=counts["received_messages"],
            received_bytes=counts["received_bytes"],
            missed_ticks=counts["missed_ticks"],
        )
        cut = any(s["cut"] for s in shares)
        end = self.limit if cut else max(s["end"] for s in shares)
        converged_at = max(merged.changed_at.values(), default=0) / 1e9
        return NetworkReport.on(
            self.spec,
            self.network.diameter,
            simulated_seconds=end / 1e9,
            convergence_seconds=converged_at if converged else None,
            transmissions=counts["transmissions"],
            receptions=counts["receptions"],
            losses=counts["losses"],
            bytes=counts["bytes"],
            ticks=counts["ticks"],
            proposals=sum(s["proposals"] for s in shares),
            converged=converged,
            beliefs_agree=agree,
            cut=cut,
            transport=transport,
        )


#: The counters every rank sends to rank 0, summed there.
_COUNTERS = (
    "transmissions",
    "receptions",
    "losses",
    "bytes",
    "ticks",
    "work",
    "missed_ticks",
    "wire_messages",
    "wire_bytes",
    "received_messages",
    "received_bytes",
)


class _Merged:
    """Every rank's share put together: robots' slots and final keys, the updates, the
    final beliefs' payloads, the times of the robots' last changes and summed counters."""

    def __init__(self, shares: Sequence[dict[str, Any]], n: int) -> None:
        self.slots = np.full(n, -1, dtype=np.int64)
        self.keys: dict[int, tuple[int, int, int]] = {}
        self.updates: dict[Any, Any] = {}
        self.payloads: dict[Any, bytes] = {}
        self.changed_at: dict[int, int] = {}
        for share in shares:
            for i, slot in share["slots"].items():
                self.slots[i] = slot
            self.keys.update(share["keys"])
            self.updates.update(share["updates"])
            self.payloads.update(share["finals"])
            self.changed_at.update(share["changed_at"])
        self.counts = {name: sum(share["counts"][name] for share in shares) for name in _COUNTERS}


def _history(updates: dict[Any, Any], key: Any) -> list[tuple[int, Any]]:
    """``(r, changes)`` of every update behind the belief ``key``, newest first."""
    out = []
    while key in updates:
        changes, parent = updates[key]
        out.append((key[0], changes))
        key = parent
    return out
