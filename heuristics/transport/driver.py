"""The delivery driver every transport shares: beliefs in flight, a robot's tick, direct
messages routed hop by hop, timers, and the :class:`heuristics.Run` at the end.

A transport -- the simulator (:mod:`heuristics.transport.simulator`) or an MPI rank
(:mod:`heuristics.transport.mpi`) -- owns time and the medium; everything it does alike
is here, once, so that a simulated run and a real one treat an agent the same way.  It
runs any :class:`heuristics.agents.Protocol` and knows none by name.

Beliefs in flight
-----------------
A clocked agent's broadcast is kept as a row of the in-flight table (:class:`InFlight`):
per receiver an arrival time, or never (lost, not a neighbour, or not newer than what the
receiver already holds when it was sent, so that it cannot change anything there).  At a
tick the robot is handed the *newest* belief that has arrived strictly before the tick --
the one the distributed mutex would keep of them all (the others cannot matter, beliefs
being compared by key alone).  A key ``(r, time, id)`` is packed into two int64,
``r`` and ``time * 2**20 + id + 1``.

Direct messages
---------------
A message travels hop by hop along a shortest path, every hop a transmission of its
encoded size with its own latency and loss; relays forward at once (the network layer
does not wait for a tick).  At its destination it goes to a clocked agent's inbox (seen at
the robot's first tick strictly after it arrived) or straight to a message-driven agent's
``receive``.  Two agents on one robot talk without a transmission.

Counters
--------
``transmissions``, ``receptions``, ``losses``, ``bytes`` (the medium), ``ticks`` (clock
ticks processed, and messages handed to message-driven agents); the agents' own
``ticks``, ``proposals`` and ``work`` are read at the end.

The end
-------
Each robot performs the slot its agent says; the run's assignment is exactly that, so a
run whose robots disagree is scored by what they actually do.  :func:`assemble_run`
builds the :class:`heuristics.Run` from every robot's :class:`AgentEnd` (gathered from
every process of a run) and the protocol's outcome.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError
from cfopt.checks import require_int, require_number, shown
from cfopt.errors import MissionTypeError
from heuristics._run import Run
from heuristics.agents.protocol import Agent, Key, Protocol, RunContext, RunEnd, Sends
from heuristics.network import Clocks, Links, Network, NetworkSpec

__all__ = [
    "COUNTERS",
    "DEFAULT_TIME_LIMIT",
    "HOP",
    "MAX_TIME_LIMIT",
    "MAX_TIME_NS",
    "NEVER",
    "QUIET_FACTOR",
    "TICK",
    "WAKE",
    "AgentEnd",
    "Driver",
    "EventRouting",
    "InFlight",
    "NetworkReport",
    "assemble_run",
    "network_spec",
    "pack_key",
    "quiet_factor_for",
    "require_protocol",
    "run_limits",
    "seed_entropy",
    "world_streams",
]

#: Simulated seconds after which a run that has not ended is cut (the seed's one hour).
DEFAULT_TIME_LIMIT = 3600.0
#: ``K`` of the termination rule: a robot stops after ``K * d_G`` ticks without a change.
QUIET_FACTOR = 2
_ID_BITS = 20  # a key (r, time, id) packs time and id into one int64: time * 2**20 + id + 1
#: The latest time (ns) a key can carry, and so the longest time limit.
MAX_TIME_NS = (2**63 - 1) >> _ID_BITS
#: The longest ``time_limit`` a run takes, in seconds (8796: event times are packed into
#: 64-bit keys).
MAX_TIME_LIMIT = MAX_TIME_NS // 10**9
#: An arrival that never comes.
NEVER = np.iinfo(np.int64).max
#: The kinds of events: a robot's clock tick, a direct message's hop, a timer.
TICK, HOP, WAKE = 0, 1, 2
#: The medium's counters, every transport's.
COUNTERS = ("transmissions", "receptions", "losses", "bytes", "ticks")


@dataclass(frozen=True)
class NetworkReport:
    """What the network did during a distributed run (frozen).

    Attributes
    ----------
    spec : str
        The network spec (canonical one-line form).
    topology : str
    diameter : int
        ``d_G``.
    latency, loss, medium : str
    simulated_seconds : float
        Simulated time when the last robot stopped (the time limit when cut).
    convergence_seconds : float or None
        Simulated time from which every robot held the same final belief (``None``: never).
    transmissions, receptions, losses, bytes : int
        Sends on the medium, messages received, receptions lost, bytes transmitted.
    ticks : int
        Clock ticks processed (the simulator's main events).
    proposals : int
        Belief updates robots made, those the mutex later discarded included.
    converged : bool
        All robots ended on one belief that is final for the algorithm.
    beliefs_agree : bool
        All robots ended on one belief.
    cut : bool
        The simulated time limit ended the run.
    transport : heuristics.mpi.TransportReport or None
        ``None`` for a simulated run.  A run of real processes (``backend="mpi"``) fills
        it with what the processes measured (wall time, messages and bytes on the wire);
        its time fields above are then measured wall-clock seconds, not simulated ones.
    channel : heuristics.transport.channel.ChannelReport or None
        The radio channel's figures when the network has one (``bitrate=``); ``None``
        otherwise (and then absent from :meth:`to_dict`).
    dynamics : heuristics.transport.events.DynamicReport or None
        A run with mission events: what followed each, utility over time against the
        optimum; ``None`` otherwise (and then absent from :meth:`to_dict`).
    """

    spec: str
    topology: str
    diameter: int
    latency: str
    loss: str
    medium: str
    simulated_seconds: float
    convergence_seconds: float | None
    transmissions: int
    receptions: int
    losses: int
    bytes: int
    ticks: int
    proposals: int
    converged: bool
    beliefs_agree: bool
    cut: bool
    transport: Any = None
    channel: Any = None
    dynamics: Any = None

    @classmethod
    def on(cls, spec: NetworkSpec, diameter: int, **measured: Any) -> NetworkReport:
        """The report of a run on ``spec``'s network (of diameter ``diameter``): the
        network's description from the spec, the ``measured`` fields as given."""
        return cls(
            spec=spec.to_text(),
            topology=spec.topology,
            diameter=int(diameter),
            latency=spec.latency.to_text(),
            loss=spec.loss.to_text(),
            medium=spec.medium,
            **measured,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (the ``network`` object of ``cfopt run --json``); a run of
        real processes adds ``transport``."""
        out = asdict(self)
        out["d_G"] = out.pop("diameter")
        for key in ("transport", "channel", "dynamics"):
            if out[key] is None:
                del out[key]
        return out


def network_spec(network: Any) -> NetworkSpec:
    """``network`` as a :class:`~heuristics.network.NetworkSpec`: a spec as it is, text (a
    one-line spec or a network file's path) parsed.  Errors name ``network``; their
    command-line wording is the parser's (``--network: token ...``)."""
    if isinstance(network, NetworkSpec):
        return network
    if not isinstance(network, str):
        raise MissionTypeError(
            f"network: must be a network spec (text or a NetworkSpec), got {shown(network)}"
        )
    try:
        return NetworkSpec.parse(network)
    except MissionError as exc:
        raise MissionError(f"network: {exc}", cli=exc.cli_message) from None


def quiet_factor_for(spec: NetworkSpec, n_robots: int, quiet_factor: Any = None) -> Any:
    """The quiet factor of a run of ``n_robots`` robots on ``spec``: ``quiet_factor`` when
    given, else the halting rule of the spec's profile (:mod:`heuristics.profiles`), else
    :data:`QUIET_FACTOR`.

    >>> quiet_factor_for(NetworkSpec.parse("seed"), 100), quiet_factor_for(NetworkSpec(), 100)
    (334, 2)
    """
    if quiet_factor is not None:
        return quiet_factor
    profiled = spec.quiet_factor(n_robots)
    return QUIET_FACTOR if profiled is None else profiled


def run_limits(time_limit: Any, quiet_factor: Any) -> tuple[int, int]:
    """The checked ``time_limit`` (in nanoseconds) and ``quiet_factor`` of a distributed run.

    >>> run_limits(1.5, 2)
    (1500000000, 2)
    """
    scaled = 1e9 * require_number("time_limit", time_limit, above=0, what="a number of seconds")
    if scaled > MAX_TIME_NS + 1 or round(scaled) > MAX_TIME_NS:  # no round() of inf
        problem = f"at most {MAX_TIME_LIMIT} simulated seconds, got {time_limit!r}"
        raise MissionError(f"time_limit: {problem}", cli=f"--time-limit: {problem}")
    # never 0 ns: a limit > 0 s, as the ranks of an MPI run are given it back in seconds
    return max(round(scaled), 1), require_int("quiet_factor", quiet_factor, minimum=1)


class InFlight:
    """Belief broadcasts in flight: rows of per-receiver arrival times (module docstring).

    A row is retired once every reception has arrived; its belief is then folded into a
    per-receiver *carry* (the newest retired belief that reached that receiver).
    """

    def __init__(self, n: int, capacity: int = 64) -> None:
        self.n = n
        self.arrival = np.full((capacity, n), NEVER, dtype=np.int64)
        self.r = np.zeros(capacity, dtype=np.int64)
        self.tid = np.zeros(capacity, dtype=np.int64)
        self.beliefs: list[Any] = [None] * capacity
        self.alive = np.zeros(capacity, dtype=bool)
        self.free = list(range(capacity - 1, -1, -1))
        self.rows: npt.NDArray[np.intp] = np.zeros(0, dtype=np.intp)
        self.dirty = False
        self.retire_at: list[tuple[int, int]] = []
        self.carry_r = np.full(n, -1, dtype=np.int64)
        self.carry_tid = np.full(n, -1, dtype=np.int64)
        self.carry: list[Any] = [None] * n

    def _grow(self) -> None:
        old = self.alive.size
        self.arrival = np.vstack([self.arrival, np.full((old, self.n), NEVER, dtype=np.int64)])
        self.r = np.concatenate([self.r, np.zeros(old, dtype=np.int64)])
        self.tid = np.concatenate([self.tid, np.zeros(old, dtype=np.int64)])
        self.alive = np.concatenate([self.alive, np.zeros(old, dtype=bool)])
        self.beliefs += [None] * old
        self.free = list(range(2 * old - 1, old - 1, -1))

    def add(
        self,
        belief: Any,
        receivers: npt.NDArray[np.int64],
        arrivals: npt.NDArray[np.int64],
    ) -> None:
        if not self.free:
            self._grow()
        row = self.free.pop()
        self.arrival[row, receivers] = arrivals
        self.r[row], self.tid[row] = pack_key(belief.key)
        self.beliefs[row] = belief
        self.alive[row] = True
        self.dirty = True
        heapq.heappush(self.retire_at, (int(arrivals.max()), row))

    def retire(self, now: int) -> None:
        """Fold every row whose receptions have all arrived before ``now`` into the carry."""
        while self.retire_at and self.retire_at[0][0] < now:
            _, row = heapq.heappop(self.retire_at)
            arrived = self.arrival[row]
            receivers = np.flatnonzero(arrived != NEVER)
            r, tid = self.r[row], self.tid[row]
            newer = (r > self.carry_r[receivers]) | (
                (r == self.carry_r[receivers]) & (tid > self.carry_tid[receivers])
            )
            belief = self.beliefs[row]
            for j in receivers[newer].tolist():
                self.carry[j] = belief
            self.carry_r[receivers[newer]] = r
            self.carry_tid[receivers[newer]] = tid
            self.arrival[row] = NEVER
            self.beliefs[row] = None
            self.alive[row] = False
            self.free.append(row)
            self.dirty = True

    def newest(self, receiver: int, now: int) -> Any:
        """The newest belief that reached ``receiver`` strictly before ``now``."""
        if self.dirty:
            self.rows = np.flatnonzero(self.alive)
            self.dirty = False
        best = self.carry[receiver]
        best_r, best_tid = self.carry_r[receiver], self.carry_tid[receiver]
        rows = self.rows
        if rows.size:
            hit = rows[self.arrival[rows, receiver] < now]
            if hit.size:
                rs = self.r[hit]
                top = rs.max()
                tids = np.where(rs == top, self.tid[hit], -1)
                k = int(tids.argmax())
                if top > best_r or (top == best_r and tids[k] > best_tid):
                    best = self.beliefs[int(hit[k])]
        return best


def require_protocol(protocol: Any) -> Protocol:
    """``protocol`` if it is a :class:`heuristics.agents.Protocol`; otherwise
    :class:`cfopt.errors.MissionTypeError` naming ``protocol``."""
    if not isinstance(protocol, Protocol):
        raise MissionTypeError(
            f"protocol: must be a heuristics.agents.Protocol, got {shown(protocol)}"
        )
    return protocol


def pack_key(key: Key) -> tuple[int, int]:
    """A belief key ``(r, time, id)`` as two ints comparing as the key does.

    >>> pack_key((3, 7, 1)) > pack_key((3, 7, 0)) > pack_key((3, 6, 999)) > pack_key((2, 9, 9))
    True
    """
    r, t, robot = key
    return r, (t << _ID_BITS) + robot + 1


def seed_entropy(seed: Any) -> Any:
    """SeedSequence entropy from a run's seed (a Generator gives a fresh draw of its own)."""
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(2**63))
    return seed


def world_streams(entropy: Any) -> list[np.random.SeedSequence]:
    """The topology's, the clocks', the latencies' and the losses' streams of a run."""
    return np.random.SeedSequence(entropy).spawn(4)


@dataclass(frozen=True)
class AgentEnd:
    """One robot at the end of a run, as its process saw it (picklable).

    Attributes
    ----------
    slot : int
        What it performs (``task * S + service``, -1: nothing).
    ticks, proposals, work : int
        Its agent's counts.
    key : tuple of int or None
        Its final belief's key (``None``: a message-driven agent).
    changed_ns : int
        When its belief last changed (0: never).
    report : object
        :meth:`heuristics.agents.Protocol.report` of its agent.
    """

    slot: int
    ticks: int
    proposals: int
    work: int
    key: Key | None
    changed_ns: int
    report: Any


class Driver:
    """One process's share of a run: the agents it hosts and what reaches them.

    Parameters
    ----------
    protocol : heuristics.agents.Protocol
    mission : cfopt.Mission
    spec : NetworkSpec
    network : Network
    clocks : Clocks
    links : Links
    robots : iterable of int
        The robots whose agents this process runs (every robot in the simulator).
    limit : int
        The time limit, ns.
    quiet_factor : int
    reward : str

    Notes
    -----
    A transport provides ``_broadcast(i, belief, now)`` (the medium), ``_send(source,
    dest, message, now)`` (how a direct message leaves) and ``_timer(i, t)`` (a
    message-driven agent's timer, due at ``t``).
    """

    def __init__(
        self,
        protocol: Protocol,
        mission: Mission,
        spec: NetworkSpec,
        network: Network,
        clocks: Clocks,
        links: Links,
        robots: Iterable[int],
        limit: int,
        quiet_factor: int,
        reward: str,
    ) -> None:
        self.protocol, self.mission, self.spec = protocol, mission, spec
        self.network, self.clocks, self.links = network, clocks, links
        self.limit, self.quiet_factor, self.reward = limit, quiet_factor, reward
        n = self.n = mission.n_robots
        self.context = RunContext(
            mission,
            reward,
            quiet_factor * max(network.diameter, 1),
            network.diameter,
            clocks.period_ns,
            hops=network.hops,
            neighbours=network.neighbours,
        )
        self.shared = protocol.prepare(self.context)
        self.robots = list(robots)
        self.agents: dict[int, Agent] = {
            i: protocol.make_agent(self.context.for_robot(i, self.shared)) for i in self.robots
        }
        self.inflight = InFlight(n)
        self.key_r = np.zeros(n, dtype=np.int64)
        self.key_tid = np.zeros(n, dtype=np.int64)
        for i, agent in self.agents.items():
            if agent.clocked:
                self.key_r[i], self.key_tid[i] = pack_key(agent.belief.key)
        self.stopped = np.zeros(n, dtype=bool)
        self.changed_ns = dict.fromkeys(self.robots, 0)
        self.inbox: dict[int, list[tuple[int, Any]]] = {i: [] for i in self.robots}
        self.waking: dict[int, int | None] = dict.fromkeys(self.robots)
        self.unicast = spec.medium == "unicast"
        self.transmissions = self.receptions = self.losses = self.bytes = self.ticks = 0
        self.cut = False
        self.end = 0

    # ------------------------------------------------------------------ a tick
    def _tick(self, i: int, now: int) -> bool:
        """Robot ``i``'s clock tick at ``now``; ``False`` when it has no more ticks (a
        message-driven agent's clock only starts it; a clocked agent may stop)."""
        self.ticks += 1
        agent = self.agents[i]
        if not agent.clocked:
            self._act(i, agent.start(now), now)
            return False
        self.inflight.retire(now)
        received = self.inflight.newest(i, now)
        inbox = self._take(i, now)
        before = agent.belief.key
        belief, sends = agent.tick(now, received, inbox)
        after = agent.belief.key
        if after != before:
            self._observe(i, after, now)
        if belief is not None:
            self._broadcast(i, belief, now)
        for dest, message in sends:
            self._send(i, dest, message, now)
        if agent.stopped:
            self.stopped[i] = True
            return False
        return True

    def _take(self, i: int, now: int) -> list[Any]:
        """The direct messages robot ``i`` has received strictly before ``now``."""
        box = self.inbox[i]
        if not box:
            return []
        ready = [message for arrival, message in box if arrival < now]
        if ready:
            self.inbox[i] = [(a, m) for a, m in box if a >= now]
        return ready

    def _observe(self, i: int, key: Key, now: int) -> None:
        self.key_r[i], self.key_tid[i] = pack_key(key)
        self.changed_ns[i] = now

    def _can_change(self, belief: Any, receivers: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        """Which ``receivers`` ``belief`` can still change: running, holding an older key."""
        r, tid = pack_key(belief.key)
        kr, kt = self.key_r[receivers], self.key_tid[receivers]
        return ~self.stopped[receivers] & ((r > kr) | ((r == kr) & (tid > kt)))

    # ------------------------------------------------------- message-driven agents
    def _act(self, i: int, sends: Sends, now: int) -> None:
        """After robot ``i``'s agent ran at ``now``: its sends, then its timer (a timer
        moved before it fires does not fire)."""
        for dest, message in sends:
            self._send(i, dest, message, now)
        wake = self.agents[i].wake_at
        if wake is not None and wake != self.waking[i]:
            self.waking[i] = wake
            self._timer(i, max(wake, now))

    def _deliver(self, dest: int, message: Any, now: int) -> None:
        """A direct message reached robot ``dest`` at ``now``."""
        agent = self.agents[dest]
        if agent.clocked:
            self.inbox[dest].append((now, message))
        else:
            self.ticks += 1
            self._act(dest, agent.receive(now, message), now)

    # ------------------------------------------------------------ the transport's
    def _broadcast(self, i: int, belief: Any, now: int) -> None:
        raise NotImplementedError

    def _send(self, source: int, dest: int, message: Any, now: int) -> None:
        raise NotImplementedError

    def _timer(self, i: int, t: int) -> None:
        raise NotImplementedError

    # ------------------------------------------------------------------ the end
    def ends(self) -> dict[int, AgentEnd]:
        """Every hosted robot's :class:`AgentEnd`."""
        out = {}
        for i in self.robots:
            agent = self.agents[i]
            out[i] = AgentEnd(
                slot=int(agent.performed_slot()),
                ticks=int(agent.ticks),
                proposals=int(agent.proposals),
                work=int(agent.work),
                key=agent.belief.key if agent.clocked else None,
                changed_ns=int(self.changed_ns[i]),
                report=self.protocol.report(agent),
            )
        return out


class EventRouting(Driver):
    """A :class:`Driver` whose time is a sequence of events: clock ticks, the hops of
    direct messages and timers (the simulator's kernel, and an MPI run in lock-step).

    A transport provides ``_push(t, kind, payload)`` (an event at ``t``: ``TICK`` robot,
    ``HOP`` ``(dest, message, size, at)``, ``WAKE`` robot) and runs the events it pushed in
    order, handing each to ``handlers[kind](payload, t)`` unless it is :meth:`_stale`.
    ``faults`` (``None``, or the simulator's) may add delays and losses to a hop.
    """

    faults: Any = None

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.tick_index = dict.fromkeys(self.robots, 0)
        #: What runs an event, by its kind.
        self.handlers = (self._on_tick, self._on_hop, self._on_wake)

    def _push(self, t: int, kind: int, payload: Any) -> None:
        raise NotImplementedError

    def _on_tick(self, i: int, t: int) -> None:
        if self._tick(i, t):
            k = self.tick_index[i] = self.tick_index[i] + 1
            self._push(self.clocks.tick_time(i, k), TICK, i)

    def _on_hop(self, hop: tuple[int, Any, int, int], t: int) -> None:
        dest, message, size, at = hop
        if at != dest:
            self._forward(dest, message, size, at, t)
        else:
            self._deliver(dest, message, t)

    def _on_wake(self, i: int, t: int) -> None:
        self.waking[i] = None
        self._act(i, self.agents[i].wake(t), t)

    def _stale(self, kind: int, payload: Any, t: int) -> bool:
        """A timer the agent has since moved or cleared: not an event."""
        return kind == WAKE and self.waking[payload] != t

    def _timer(self, i: int, t: int) -> None:
        self._push(t, WAKE, i)

    def _send(self, source: int, dest: int, message: Any, now: int) -> None:
        size = len(self.protocol.encode_message(message))
        if dest == source:  # two agents on one robot: no transmission
            self._push(now, HOP, (dest, message, 0, dest))
            return
        self._forward(dest, message, size, source, now)

    def _forward(self, dest: int, message: Any, size: int, at: int, now: int) -> None:
        # a complete network (no adjacency kept) delivers directly: next_hop would say so
        nxt = dest if self.network.indptr is None else self.network.next_hop(at, dest)
        if self.faults is None:
            delay, lost = self.links.transmit_one(at, nxt)
        else:
            delay, lost = self._transmit_one(at, nxt, now)
        self.transmissions += 1
        self.bytes += size
        if lost:
            self.losses += 1
            return
        self.receptions += 1
        self._push(now + delay, HOP, (dest, message, size, nxt))

    def _transmit_one(self, sender: int, receiver: int, now: int) -> tuple[int, bool]:
        """One hop's delay and loss, with ``faults``."""
        raise NotImplementedError


def assemble_run(
    driver: Driver,
    ends: Mapping[int, AgentEnd],
    counts: Mapping[str, int],
    *,
    cut: bool,
    end_ns: int,
    seconds: float,
    seed: int | None,
    engine: tuple[tuple[str, Any], ...],
    transport: Any = None,
    channel: Any = None,
    dynamics: Any = None,
) -> Run:
    """The :class:`heuristics.Run` of a run: every robot's :class:`AgentEnd`, the summed
    counters (:data:`COUNTERS`), the protocol's outcome (read in ``driver``'s process).

    ``engine`` ends ``run.options`` (``(("engine", "simulated"),)``...); ``transport`` is
    the network report's (``None`` for a simulated run).
    """
    context = driver.context
    n = context.n
    robots = [ends[i] for i in range(n)]
    slots = np.array([e.slot for e in robots], dtype=np.int64)
    end = RunEnd(
        context=context,
        shared=driver.shared,
        reports=tuple(e.report for e in robots),
        keys=tuple(e.key for e in robots),
        changed_ns=tuple(e.changed_ns for e in robots),
        slots=slots,
        cut=cut,
        end_ns=end_ns,
    )
    outcome = driver.protocol.outcome(end)
    spec = driver.spec
    report = NetworkReport.on(
        spec,
        context.diameter,
        simulated_seconds=end_ns / 1e9,
        convergence_seconds=(
            None if outcome.convergence_ns is None else outcome.convergence_ns / 1e9
        ),
        transmissions=counts["transmissions"],
        receptions=counts["receptions"],
        losses=counts["losses"],
        bytes=counts["bytes"],
        ticks=counts["ticks"],
        proposals=sum(e.proposals for e in robots),
        converged=bool(outcome.converged),
        beliefs_agree=bool(outcome.beliefs_agree),
        cut=cut,
        transport=transport,
        channel=channel,
        dynamics=dynamics,
    )
    S = max(context.mission.n_services, 1)
    return Run(
        algorithm=driver.protocol.label,
        assignment=Assignment(
            task=np.where(slots >= 0, slots // S, -1), service=np.where(slots >= 0, slots % S, -1)
        ),
        iterations=outcome.iterations,
        rounds=max((e.ticks for e in robots), default=0),
        messages=counts["transmissions"],
        bytes=counts["bytes"],
        work=sum(e.work for e in robots),
        seconds=seconds,
        seed=seed,
        exchanges=outcome.exchanges,
        pairwise_step_ran=outcome.pairwise_step_ran,
        trajectory=np.array(outcome.trajectory, dtype=np.int64).reshape(-1, 4),
        options=(
            ("network", spec.to_text()),
            ("quiet_factor", driver.quiet_factor),
            *outcome.options,
            *engine,
        ),
        network=report,
    )
