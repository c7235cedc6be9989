"""Real processes: a protocol's agents as MPI ranks (mpi4py) that exchange real messages.

The simulator (:mod:`heuristics.transport.simulator`) runs agents on a modelled network,
reproducibly on one machine.  This module runs the *same agent objects* -- any
:class:`heuristics.agents.Protocol`'s -- as MPI processes, as the seed's own evaluation
did, so that wall-clock time and bytes on a real network can be measured and the
simulator's model held against them.  Only the transport differs: what happens to an
agent is the shared driver's (:mod:`heuristics.transport.driver`).
:func:`run_ranks` is what every rank executes (collective over ``comm``); the launcher
is :func:`heuristics.mpi_run`.

Placement
---------
Rank ``r`` of ``K`` hosts the robots ``r n // K .. (r + 1) n // K - 1`` (contiguous blocks;
one robot per rank when ``K = n``; ``1 <= K <= n``).  Each rank builds the whole mission,
the topology and the clocks from the run's seed -- the same as the simulator's for the
same seed -- prepares the protocol (:meth:`~heuristics.agents.Protocol.prepare`) and
builds the agents of its own robots only.

Messages on the wire
--------------------
A robot's broadcast is one MPI message to each *other rank* hosting a neighbour of it
(the robots of its own rank hear it without MPI); its bytes are exactly the protocol's
belief encoder's, its tag ``2 * sender``.  A direct message is one MPI message to the
rank of its destination robot, bytes exactly its encoder's, tag ``2 * destination + 1``.
Sends are non-blocking (``Isend``: the seed's UDP-like model).  The transport counts the
messages and bytes it hands to MPI (``wire_messages``, ``wire_bytes``) and, on the
receiving side, the encoder's size of every message it decoded (``received_bytes``):
with no message left in flight the two byte counts are equal.

Injected physics
----------------
The spec's topology decides who hears a broadcast; its latency and loss are injected on
top of the real network's.  The receiving rank draws, for each of its robots hearing a
broadcast, a delay and a loss (per directed link, as the simulator's
:class:`heuristics.network.Links`) and hands the belief to the robot at its first tick
after receipt plus delay.  A direct message's route is drawn by the rank that sends it,
hop by hop along a shortest path (a lost hop drops it).  ``run.messages`` and
``run.bytes`` count the robots' transmissions as the simulator does; each rank draws from
its own generators, spawned from the seed.

Clocks
------
Free-running (the default): robot ``i``'s tick ``k`` is due at ``t0 +
Clocks.tick_time(i, k)`` of real monotonic time, ``t0`` taken on every rank right after
a barrier.  A rank ticks its due robots in due order, fires its agents' due timers,
probes for messages (``Iprobe``) between them and sleeps otherwise; a message-driven
agent gets a direct message the moment it is received.  A rank that falls behind ticks
late, and a robot's ticks that passed meanwhile are coalesced into one (``missed_ticks``
counts them), as a periodic timer's overruns are.  A direct message is held by its sender
for its route's delay, then sent.  Times are the real nanoseconds since ``t0``.

``sync=true``: lock-step, in the simulator's logical time.  The ranks step together
through the times at which anything happens anywhere (ticks, message arrivals, timers:
the smallest next time over all ranks, an ``allgather``), paced to real time; at each time
they run the events due then, wave by wave (a message sent with no delay is a new wave
of the same time), each rank its own in the simulator's order, and exchange the wave's
messages (an ``alltoall`` of what was sent, then exactly those messages).  Relays of a
direct message are run by the rank that sent it.  The events of a time are numbered
exactly as the simulator's heap orders them (every event is keyed by the event that made
it), so with the same seed, a fixed latency and no loss a lock-step MPI run is the
simulator's run, move for move, whatever the protocol.

Termination
-----------
Lock-step: when no event is left anywhere.  Free-running: a rank is *passive* when it
has nothing left to do of its own accord (its clocked robots have stopped, its
message-driven ones have started, it holds no message and no timer is set); passive ranks
take part in waves of a non-blocking ``allreduce`` of the MPI messages sent and received,
and the run has ended when two consecutive waves found every rank passive with the same
counts, sent equal to received (Mattern's counting method: nothing in flight, nobody
active).  A run that reaches its time limit (real seconds; logical ones with
``sync=true``) is cut.  Either way the ranks then drain the wire (a barrier, the counts
each sent to each, the rest received) so nothing is left in flight.

Outcome
-------
Gathered on rank 0, in the same frozen :class:`heuristics.Run` as the simulator's: every
rank sends its robots' ends (slot, counts, final key, the protocol's report) and its
counters; rank 0 reads the protocol's outcome from them.  ``run.network.transport`` is
the :class:`TransportReport`.
"""

from __future__ import annotations

import dataclasses
import heapq
import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, MissionError, require_mission
from cfopt.checks import require_int
from heuristics._run import Run, seed_label
from heuristics.agents.protocol import Protocol
from heuristics.network import Clocks, Links, NetworkSpec
from heuristics.transport.driver import (
    COUNTERS,
    DEFAULT_TIME_LIMIT,
    HOP,
    NEVER,
    TICK,
    AgentEnd,
    Driver,
    EventRouting,
    assemble_run,
    network_spec,
    quiet_factor_for,
    require_protocol,
    run_limits,
    seed_entropy,
    world_streams,
)

__all__ = ["TransportReport", "check_ranks", "refuse_channel", "robots_of", "run_ranks"]

_BELIEF, _DIRECT = 0, 1  # tag = 2 * robot + kind
_SLEEP_NS = 200_000  # the longest nap between two looks at the wire
#: The counters every rank sends to rank 0, summed there.
_RANK_COUNTERS = (
    *COUNTERS,
    "missed_ticks",
    "wire_messages",
    "wire_bytes",
    "received_messages",
    "received_bytes",
)


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


def refuse_channel(spec: NetworkSpec) -> None:
    """Refuse a spec with a radio channel (``bitrate=``): a run of real processes has the
    real network's capacity, the channel model is the simulator's."""
    if spec.bitrate is not None:
        raise MissionError(
            "network: bitrate: a radio channel of finite capacity is the simulator's model; "
            "an MPI run has the real network's",
            cli="--network: bitrate: a radio channel is simulated only (not with --backend mpi)",
        )


def check_ranks(n_robots: int, ranks: Any) -> int:
    """``ranks`` if ``1 <= ranks <= n`` (at most one rank per robot); otherwise
    :class:`cfopt.MissionError` naming ``ranks``."""
    ranks = require_int("ranks", ranks, minimum=1)
    if ranks > max(n_robots, 1):
        raise MissionError(
            f"ranks: at most one rank per robot ({n_robots} robots), got {int(ranks)}"
        )
    return int(ranks)


def run_ranks(
    mission: Mission,
    protocol: Protocol,
    network: str | NetworkSpec = "complete",
    *,
    seed: Any = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int | None = None,
    reward: str = "paper",
    comm: Any = None,
) -> Run | None:
    """One rank's share of an MPI run of ``protocol`` (collective over ``comm``, default
    ``MPI.COMM_WORLD``); returns the :class:`heuristics.Run` on rank 0 and ``None`` on
    the others.  Arguments as :func:`heuristics.mpi_run`'s; the ranks are ``comm``'s."""
    from mpi4py import MPI

    started = time.perf_counter()
    comm = MPI.COMM_WORLD if comm is None else comm
    require_mission(mission)
    require_protocol(protocol)
    spec = network_spec(network)
    refuse_channel(spec)
    check_ranks(mission.n_robots, comm.Get_size())
    quiet_factor = quiet_factor_for(spec, mission.n_robots, quiet_factor)
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    entropy = comm.bcast(
        np.random.SeedSequence(seed_entropy(seed)).entropy if comm.Get_rank() == 0 else None
    )
    kind = _LockStep if spec.sync else _FreeRunning
    rank = kind(comm, mission, protocol, spec, entropy, limit, quiet_factor, reward)
    rank.run()
    return rank.gather(seed_label(seed), started)


def robots_of(ranks: int, n: int) -> Sequence[range]:
    """The robots each of ``ranks`` ranks hosts (module docstring, Placement).

    >>> [list(r) for r in robots_of(3, 7)]
    [[0, 1], [2, 3], [4, 5, 6]]
    """
    bounds = [r * n // ranks for r in range(ranks + 1)]
    return [range(a, b) for a, b in itertools.pairwise(bounds)]


class _Rank(Driver):
    """One MPI process: its robots' agents and the wire (module docstring)."""

    def __init__(
        self,
        comm: Any,
        mission: Mission,
        protocol: Protocol,
        spec: NetworkSpec,
        entropy: Any,
        limit: int,
        quiet_factor: int,
        reward: str,
    ) -> None:
        from mpi4py import MPI

        self.MPI, self.comm = MPI, comm
        self.rank, self.size = comm.Get_rank(), comm.Get_size()
        n = mission.n_robots
        if 2 * n + 1 > int(comm.Get_attr(MPI.TAG_UB)):
            raise MissionError(f"ranks: this MPI's tags cannot name {n} robots")
        # topology and clocks: the simulator's, the same on every rank; the injected
        # latencies and losses: this rank's own generators
        topology, clock, latency, loss = world_streams(entropy)
        network = spec.build(mission, np.random.default_rng(topology))
        clocks = Clocks(spec, n, np.random.default_rng(clock))
        losses = loss.spawn(2 * self.size)
        self.tally = np.random.default_rng(losses[self.size + self.rank])
        links = Links(
            network,
            np.random.default_rng(latency.spawn(self.size)[self.rank]),
            np.random.default_rng(losses[self.rank]),
        )
        blocks = robots_of(self.size, n)
        self.robots_per_rank = tuple(len(block) for block in blocks)
        self.owner = np.repeat(np.arange(self.size), self.robots_per_rank).astype(np.int64)
        local = blocks[self.rank]
        super().__init__(
            protocol, mission, spec, network, clocks, links, local, limit, quiet_factor, reward
        )
        self.fanout: dict[int, tuple[list[int], npt.NDArray[np.int64]]] = {}
        self.hearers: dict[int, npt.NDArray[np.int64]] = {}
        self.known: dict[Any, Any] = {}  # decoded beliefs by key
        self.requests: list[Any] = []
        self.sent_to = [0] * self.size
        self.received_from = [0] * self.size
        self.status = MPI.Status()
        self.missed_ticks = self.wire_messages = self.wire_bytes = 0
        self.received_messages = self.received_bytes = 0
        self.halted = False  # the run is over here: what still arrives is only counted
        self.t0 = 0
        self.wall = 0.0

    def run(self) -> None:
        """Run this rank's robots to the end, then drain the wire."""
        self.comm.Barrier()
        self.t0 = time.monotonic_ns()
        self._run()
        self.halted = True
        self._drain()
        self.wall = (time.monotonic_ns() - self.t0) / 1e9

    def _run(self) -> None:
        raise NotImplementedError

    def _now(self) -> int:
        return time.monotonic_ns() - self.t0

    def _nap(self, until: int) -> None:
        wait = min(until - self._now(), _SLEEP_NS)
        if wait > 0:
            time.sleep(wait / 1e9)

    # ------------------------------------------------------------------ sending
    def _broadcast(self, i: int, belief: Any, now: int) -> None:
        ranks, local = self._fanout(i)
        if not ranks and local.size == 0:
            return
        payload = self.protocol.encode(belief)
        sends = self.network.degree(i) if self.unicast else 1
        self.transmissions += sends
        self.bytes += sends * len(payload)
        for rank in ranks:
            self._isend(payload, rank, 2 * i + _BELIEF, (_BELIEF, i))
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

    def _isend(self, payload: bytes, rank: int, tag: int, meta: tuple[Any, ...]) -> None:
        """Send ``payload`` to ``rank`` (``meta``: what the receiver needs beside it, in
        lock-step)."""
        request = self.comm.Isend([payload, self.MPI.BYTE], dest=rank, tag=tag)
        self.requests.append((request, payload))
        self.sent_to[rank] += 1
        self.wire_messages += 1
        self.wire_bytes += len(payload)
        if len(self.requests) >= 1024:
            self.requests = [(r, p) for r, p in self.requests if not r.Test()]

    # ---------------------------------------------------------------- receiving
    def _recv(self, source: int) -> tuple[int, bytes]:
        """The next message from ``source`` (blocking): its tag and bytes."""
        status = self.status
        self.comm.Probe(source=source, tag=self.MPI.ANY_TAG, status=status)
        buffer = bytearray(status.Get_count(self.MPI.BYTE))
        tag = status.Get_tag()
        self.comm.Recv([buffer, self.MPI.BYTE], source=source, tag=tag)
        self.received_from[source] += 1
        self.received_messages += 1
        return tag, bytes(buffer)

    def _belief(self, payload: bytes) -> Any:
        """The belief a broadcast carries: one object per key on a rank (so that what
        agents cache on it is computed once)."""
        belief = self.protocol.decode(payload, self.context)
        self.received_bytes += len(self.protocol.encode(belief))
        return self.known.setdefault(belief.key, belief)

    def _message(self, payload: bytes) -> Any:
        message = self.protocol.decode_message(payload, self.context)
        self.received_bytes += len(self.protocol.encode_message(message))
        return message

    def _heard(self, sender: int, payload: bytes, sent: int) -> None:
        """A broadcast of ``sender``'s came in, sent at ``sent``."""
        belief = self._belief(payload)
        hearers = self._hearers(sender)
        if hearers.size:
            self._hear(sender, belief, hearers, sent)

    def _hearers(self, sender: int) -> npt.NDArray[np.int64]:
        found = self.hearers.get(sender)
        if found is None:
            receivers = self.network.neighbours(sender)
            found = self.hearers[sender] = receivers[self.owner[receivers] == self.rank]
        return found

    def _hear(self, sender: int, belief: Any, receivers: npt.NDArray[np.int64], sent: int) -> None:
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

    def _poll(self, now: int) -> None:
        """Receive every message that has come in (free-running, and while draining)."""
        MPI = self.MPI
        while self.comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=self.status):
            self._receive(self.status.Get_source(), now)

    def _receive(self, source: int, now: int) -> None:
        """Receive the next message from ``source`` and hand it over as arrived at
        ``now``; once halted, only count it."""
        tag, payload = self._recv(source)
        robot, kind = divmod(tag, 2)
        if kind == _BELIEF:
            self._heard(robot, payload, now)
            return
        message = self._message(payload)
        if not self.halted:
            self.end = max(self.end, now)
            self._deliver(robot, message, now)

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
        share = {
            "ends": self.ends(),
            "counts": {name: getattr(self, name) for name in _RANK_COUNTERS},
            "end": self.end,
            "cut": self.cut,
        }
        shares = self.comm.gather(share, root=0)
        if self.rank != 0:
            return None
        ends: dict[int, AgentEnd] = {}
        for s in shares:
            ends.update(s["ends"])
        counts = {name: sum(s["counts"][name] for s in shares) for name in _RANK_COUNTERS}
        cut = any(s["cut"] for s in shares)
        return assemble_run(
            self,
            ends,
            counts,
            cut=cut,
            end_ns=self.limit if cut else max(s["end"] for s in shares),
            seconds=time.perf_counter() - started,
            seed=seed,
            engine=(("engine", "mpi"), ("ranks", self.size)),
            transport=self._transport(counts),
        )

    def _transport(self, counts: dict[str, int]) -> TransportReport:
        return TransportReport(
            backend="mpi",
            ranks=self.size,
            robots_per_rank=self.robots_per_rank,
            library=" ".join(self.MPI.Get_library_version().split()[:3]),
            wall_seconds=self.wall,
            launch_seconds=None,
            wire_messages=counts["wire_messages"],
            wire_bytes=counts["wire_bytes"],
            received_messages=counts["received_messages"],
            received_bytes=counts["received_bytes"],
            missed_ticks=counts["missed_ticks"],
        )


class _LockStep(EventRouting, _Rank):
    """``sync=true``: the simulator's events, run by the ranks in step (module docstring).

    Every event carries the key the simulator's heap would order it by: ``(time, wave,
    ordinal, i)`` of the event that made it (its ``i``-th push), ``ordinal`` its maker's
    place among every event of its time and wave on all ranks; the first ticks are keyed
    by robot.
    """

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.heap: list[tuple[int, tuple[int, ...], int, Any]] = []
        self.outgoing: list[list[tuple[Any, ...]]] = [[] for _ in range(self.size)]
        self.maker: tuple[int, int, int] = (-1, 0, 0)
        self.pushed = 0

    def _run(self) -> None:
        heap = self.heap
        for i in self.robots:
            heapq.heappush(heap, (self.clocks.tick_time(i, 0), (-1, 0, 0, i), TICK, i))
        last, wave = -1, 0
        while True:
            batch = self._next_batch()
            here = batch[0][0] if batch else NEVER
            live = any(not self._stale(kind, payload, t) for t, _, kind, payload in batch)
            everyone = self.comm.allgather((here, [event[1] for event in batch], live))
            now = min(t for t, _, _ in everyone)
            if now == NEVER:
                return
            if here != now:  # not this rank's turn yet
                for event in batch:
                    heapq.heappush(heap, event)
                batch = []
            if now > self.limit:  # cut, unless every event then is a stale timer
                if any(alive for t, _, alive in everyone if t == now):
                    self.cut = True
                    return
                continue
            wave = wave + 1 if now == last else 0
            last = now
            ordinal = {
                key: k
                for k, key in enumerate(
                    sorted(key for t, keys, _ in everyone if t == now for key in keys)
                )
            }
            while self._now() < now:  # paced to real time
                self._nap(now)
            for t, key, kind, payload in batch:
                if self._stale(kind, payload, t):
                    continue
                self.end = t
                self.maker, self.pushed = (t, wave, ordinal[key]), 0
                self.handlers[kind](payload, t)
            self._exchange(now)

    def _next_batch(self) -> list[tuple[int, tuple[int, ...], int, Any]]:
        """Every event of this rank at its earliest time, in key order."""
        heap = self.heap
        if not heap:
            return []
        t = heap[0][0]
        batch = []
        while heap and heap[0][0] == t:
            batch.append(heapq.heappop(heap))
        return batch

    def _push(self, t: int, kind: int, payload: Any) -> None:
        key = (*self.maker, self.pushed)
        self.pushed += 1
        if kind == HOP and payload[3] == payload[0]:  # arriving: at its robot's rank
            dest, message, size, _ = payload
            owner = int(self.owner[dest])
            if owner != self.rank:
                data = self.protocol.encode_message(message)
                self._isend(data, owner, 2 * dest + _DIRECT, (_DIRECT, dest, t, key, size))
                return
        heapq.heappush(self.heap, (t, key, kind, payload))

    def _isend(self, payload: bytes, rank: int, tag: int, meta: tuple[Any, ...]) -> None:
        super()._isend(payload, rank, tag, meta)
        self.outgoing[rank].append(meta)

    def _exchange(self, now: int) -> None:
        """The wave's messages, to the ranks they are for: what was sent (an
        ``alltoall``), then exactly those messages, in the order they were sent."""
        incoming = self.comm.alltoall(self.outgoing)
        self.outgoing = [[] for _ in range(self.size)]
        for source, metas in enumerate(incoming):
            for meta in metas:
                _, payload = self._recv(source)
                if meta[0] == _BELIEF:
                    self._heard(meta[1], payload, now)
                else:
                    _, dest, t, key, size = meta
                    message = self._message(payload)
                    heapq.heappush(self.heap, (t, key, HOP, (dest, message, size, dest)))


class _FreeRunning(_Rank):
    """Real-time clocks (module docstring)."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.held: list[tuple[int, int, int, Any, bytes]] = []  # direct messages due
        self.seq = itertools.count()
        self.timers: list[tuple[int, int]] = []  # (due, robot)

    def _run(self) -> None:
        due = [(self.clocks.tick_time(i, 0), i, 0) for i in self.robots]
        heapq.heapify(due)
        waves = _Waves(self.comm)
        while True:
            now = self._now()
            if now > self.limit:
                self.cut = self.halted = True
            self._poll(now)
            acted = False
            if not self.cut:
                self._release(now)
                acted = self._step(due, now)
            passive = self.cut or not (due or self.held or self._next_timer() < NEVER)
            verdict = waves.step(passive, self.cut, self.wire_messages, self.received_messages)
            if verdict is not None:
                self.cut = self.cut or verdict == "cut"
                return
            if not acted:
                self._nap(
                    min(
                        due[0][0] if due else self.limit,
                        self.held[0][0] if self.held else self.limit,
                        self._next_timer(),
                        self.limit,
                    )
                )

    def _step(self, due: list[tuple[int, int, int]], now: int) -> bool:
        """The earliest tick or timer due by ``now``, if any."""
        tick = due[0][0] if due else NEVER
        timer = self._next_timer()
        if min(tick, timer) > now:
            return False
        self.end = max(self.end, now)
        if tick <= timer:
            _, i, k = heapq.heappop(due)
            if self._tick(i, now):
                k = self._next_tick(i, k, self._now())
                heapq.heappush(due, (self.clocks.tick_time(i, k), i, k))
        else:
            _, i = heapq.heappop(self.timers)
            self.waking[i] = None
            self._act(i, self.agents[i].wake(now), now)
        return True

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

    def _timer(self, i: int, t: int) -> None:
        heapq.heappush(self.timers, (t, i))

    def _next_timer(self) -> int:
        """When the next live timer is due (``NEVER``: none); moved ones are dropped."""
        timers = self.timers
        while timers and self.waking[timers[0][1]] != timers[0][0]:
            heapq.heappop(timers)
        return timers[0][0] if timers else NEVER

    def _send(self, source: int, dest: int, message: Any, now: int) -> None:
        """A direct message: its route drawn hop by hop now, held for the route's delay."""
        payload = self.protocol.encode_message(message)
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
                self._deliver(dest, message, due)
            else:
                self._isend(payload, owner, 2 * dest + _DIRECT, (_DIRECT,))


class _Waves:
    """Termination detection by counting (module docstring): passive ranks take part in
    successive non-blocking sums of ``(cut, sent, received)``."""

    def __init__(self, comm: Any) -> None:
        self.comm = comm
        self.request: Any = None
        self.mine = np.zeros(3, dtype=np.int64)
        self.total = np.zeros(3, dtype=np.int64)
        self.last: tuple[int, int] | None = None

    def step(self, passive: bool, cut: bool, sent: int, received: int) -> str | None:
        """``"done"`` or ``"cut"`` once the ranks know the run is over, else ``None``."""
        if self.request is None:
            if passive:
                self.mine[:] = (int(cut), sent, received)
                self.request = self.comm.Iallreduce(self.mine, self.total)
            return None
        if not self.request.Test():
            return None
        self.request = None
        cuts, sent_all, received_all = (int(x) for x in self.total)
        if cuts:
            return "cut"
        counts = (sent_all, received_all)
        if sent_all == received_all and counts == self.last:
            return "done"
        self.last = counts if sent_all == received_all else None
        return None
