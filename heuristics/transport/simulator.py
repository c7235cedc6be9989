"""The simulator: a protocol's agents on a modelled network, event by event.

:func:`simulate` runs any :class:`heuristics.agents.Protocol`'s agents on a network
(:mod:`heuristics.network`: topology, per-message latency and loss, the medium, clocks)
in a deterministic discrete-event simulation, and returns the same frozen
:class:`heuristics.Run` as the centralized engines, with a
:class:`~heuristics.transport.driver.NetworkReport`.  What it does to an agent -- beliefs
in flight, ticks, direct messages, timers, the end -- is the shared driver's
(:mod:`heuristics.transport.driver`); this module is time and the medium.

The kernel
----------
A heap of ``(time, seq, kind, payload)`` events with an ``itertools.count`` tie-breaker:
clock ticks (one per robot per period), the hops of direct messages and the agents'
timers.  Time is integer nanoseconds.  Same mission, network spec, protocol and seed:
the same run, byte for byte (every random draw comes from generators spawned from the
seed, in event order).  On the seed's largest distributed cell (500 robots, 50 % tasks,
10:5, the seed's network) the heap took 6.20 s and simpy's environment driving the same
ticks 6.33 s (``python benchmarks/bench_distributed.py --kernels``): the kernel is a small
share of a run, whose time goes into the robots' ticks.  The heap is kept: as fast, and
no dependency.

The medium
----------
A message is processed by a clocked receiver at its first clock tick strictly after it
arrived (with lock-step clocks and no latency, a tick's messages are thus seen at the
next tick, after every robot has ticked).  A broadcast reaches every neighbour with
independent latency and loss draws; ``medium=broadcast`` counts it as one transmission
of its encoded size, ``medium=unicast`` as one per neighbour.  A run that has not ended by
its simulated time limit is *cut* and reported as such, with the agents as they stand.
"""

from __future__ import annotations

import heapq
import itertools
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_seed, shown
from cfopt.errors import MissionTypeError
from heuristics._run import Run, seed_label
from heuristics.agents.protocol import Protocol
from heuristics.network import Clocks, Links, NetworkSpec
from heuristics.transport.driver import (
    COUNTERS,
    DEFAULT_TIME_LIMIT,
    TICK,
    EventRouting,
    assemble_run,
    network_spec,
    quiet_factor_for,
    require_protocol,
    run_limits,
    seed_entropy,
    world_streams,
)

__all__ = ["Faults", "Simulator", "simulate"]

#: ``faults(sender, receivers, now) -> (extra_delay_ns, drop)`` (see :func:`simulate`).
Faults = Callable[
    [int, npt.NDArray[np.int64], int], tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]
]


def simulate(
    mission: Mission,
    protocol: Protocol,
    network: str | NetworkSpec,
    *,
    seed: SeedLike = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int | None = None,
    reward: str = "paper",
    faults: Faults | None = None,
    events: Any = None,
) -> Run:
    """Run ``protocol``'s agents on ``network`` (see the module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    protocol : heuristics.agents.Protocol
        Any protocol (:func:`heuristics.simulate` also takes an algorithm's name).
    network : str or NetworkSpec
        A one-line spec (``"complete latency=uniform:1ms:10ms loss=0.01"``) or a parsed one.
    seed : None, int or numpy.random.Generator
        Everything random (placement, clocks, latencies, losses) flows from it.
    time_limit : float, default 3600
        Simulated seconds after which the run is cut, at most
        :data:`~heuristics.transport.driver.MAX_TIME_LIMIT` (8796).
    quiet_factor : int, optional
        ``K``: the context's ``quiet_limit`` is ``K * d_G`` ticks.  Default: the halting
        rule of the network's profile (``seed``: :mod:`heuristics.profiles`), else
        :data:`~heuristics.transport.driver.QUIET_FACTOR` (2).
    reward : str, default "paper"
        The reward weighting handed to the protocol (:class:`heuristics.agents.RunContext`).
    faults : callable, optional
        For experiments: ``faults(sender, receivers, now)`` is called for every
        transmission, after the network's own draws, with the receivers as an int64 array
        and the send time in nanoseconds; it returns ``(extra_delay_ns, drop)`` arrays of
        the same length, added to the drawn delays and or-ed into the losses.
    events : Timeline, dict or path, optional
        Mission events during the run (a ``cfopt.events/1`` timeline:
        :mod:`heuristics.transport.events`); ``run.network.dynamics`` then reports them.

    Returns
    -------
    Run
        ``run.network`` is the network report; ``messages`` and ``bytes`` are the
        transmissions and their bytes, ``rounds`` the most ticks any agent made, ``work``
        the agents' counted work; ``iterations``, ``trajectory``, ``converged`` and
        ``beliefs_agree`` are the protocol's outcome.

    Notes
    -----
    Cost: one heap operation and O(rows in flight) numpy work per tick, plus one
    vectorised draw per broadcast, plus the agents' own work.

    Examples
    --------
    Robots that do nothing, and stop at once:

    >>> import cfopt
    >>> from heuristics.agents import Agent, Protocol
    >>> class Idle(Agent):
    ...     def tick(self, now, received, inbox):
    ...         self.ticks += 1
    ...         self.stopped = True
    ...         return None, []          # nothing to broadcast, nothing to send
    >>> class Nothing(Protocol):
    ...     def make_agent(self, context):
    ...         return Idle()
    >>> m = cfopt.generate_mission(robots=12, percent_tasks=25, service_types=3,
    ...                            services_per_robot=2, seed=4)
    >>> run = simulate(m, Nothing(), "ring latency=uniform:1ms:5ms", seed=0)
    >>> run.algorithm, run.rounds, run.messages, run.network.converged
    ('Nothing', 1, 0, True)
    >>> run.assignment.task.tolist() == [-1] * 12
    True
    """
    started = time.perf_counter()
    require_mission(mission)
    require_protocol(protocol)
    spec = network_spec(network)
    require_seed("seed", seed)
    quiet_factor = quiet_factor_for(spec, mission.n_robots, quiet_factor)
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    if faults is not None and not callable(faults):
        raise MissionTypeError(f"faults: must be callable or None, got {shown(faults)}")
    kind = Simulator
    if spec.bitrate is not None:
        from heuristics.transport import channel

        kind = channel.RadioSimulator
    timeline = None
    if events is not None:
        from heuristics.transport import events as dynamics

        timeline = dynamics.Timeline.read(events, mission)
        kind = dynamics.dynamic_class(kind)
    sim = kind(mission, protocol, spec, seed, limit, quiet_factor, reward, faults)
    if timeline is not None:
        sim.setup(timeline)
    sim.run()
    return sim.result(time.perf_counter() - started, seed_label(seed))


class Simulator(EventRouting):
    """One simulated run: every robot's agent, the network, the kernel and the counters."""

    def __init__(
        self,
        mission: Mission,
        protocol: Protocol,
        spec: NetworkSpec,
        seed: Any,
        limit: int,
        quiet_factor: int,
        reward: str,
        faults: Faults | None = None,
    ) -> None:
        topology, clock, latency, loss = (
            np.random.default_rng(s) for s in world_streams(seed_entropy(seed))
        )
        network = spec.build(mission, topology)
        n = mission.n_robots
        clocks = Clocks(spec, n, clock)
        links = Links(network, latency, loss)
        super().__init__(
            protocol, mission, spec, network, clocks, links, range(n), limit, quiet_factor, reward
        )
        self.faults = faults
        self.compact = spec.encoding == "compact"
        self.heap: list[tuple[int, int, int, Any]] = []
        self.seq = itertools.count()
        self.now = 0

    # ---------------------------------------------------------------- the kernel
    def run(self) -> None:
        heap, handlers = self.heap, self.handlers
        for i in range(self.n):
            heapq.heappush(heap, (self.clocks.tick_time(i, 0), next(self.seq), TICK, i))
        while heap:
            t, _, kind, payload = heapq.heappop(heap)
            if self._stale(kind, payload, t):
                continue
            if t > self.limit:
                self.cut = True
                self.now = self.limit
                break
            self.now = t
            handlers[kind](payload, t)
        self.end = self.limit if self.cut else self.now

    def _push(self, t: int, kind: int, payload: Any) -> None:
        heapq.heappush(self.heap, (t, next(self.seq), kind, payload))

    # ------------------------------------------------------------------ the medium
    def _broadcast(self, i: int, belief: Any, now: int) -> None:
        receivers = self.network.neighbours(i)
        if receivers.size == 0:
            return
        size = self._belief_size(belief)
        delays, lost = self._transmit(i, receivers, now)
        sends = receivers.size if self.unicast else 1
        self.transmissions += sends
        self.bytes += sends * size
        dropped = int(lost.sum())
        self.losses += dropped
        self.receptions += receivers.size - dropped
        useful = ~lost & self._can_change(belief, receivers)
        if useful.any():
            self.inflight.add(belief, receivers[useful], now + delays[useful])

    def _belief_size(self, belief: Any) -> int:
        """A belief's bytes on the air: its encoding, or its compact size
        (``encoding=compact``: :meth:`heuristics.agents.Protocol.encoded_size`)."""
        if self.compact:
            return self.protocol.encoded_size(belief, "compact", self.context)
        return len(self.protocol.encode(belief))

    def _transmit(
        self, sender: int, receivers: npt.NDArray[np.int64], now: int
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        delays, lost = self.links.transmit(sender, receivers)
        if self.faults is not None:
            extra, drop = self.faults(sender, receivers, now)
            delays = delays + np.asarray(extra, dtype=np.int64)
            lost = lost | np.asarray(drop, dtype=bool)
        return delays, lost

    def _transmit_one(self, sender: int, receiver: int, now: int) -> tuple[int, bool]:
        delays, lost = self._transmit(sender, np.array([receiver], dtype=np.int64), now)
        return int(delays[0]), bool(lost[0])

    # ------------------------------------------------------------------ the result
    def result(self, seconds: float, seed: int | None) -> Run:
        """The run's :class:`heuristics.Run` (after :meth:`run`)."""
        return assemble_run(
            self,
            self.ends(),
            {name: getattr(self, name) for name in COUNTERS},
            cut=self.cut,
            end_ns=self.end,
            seconds=seconds,
            seed=seed,
            engine=(("engine", "simulated"),),
            channel=self.channel_report(),
            dynamics=self.dynamic_report(),
        )

    def channel_report(self) -> Any:
        """The radio channel's report (``None``: the network has no channel)."""
        return None

    def dynamic_report(self) -> Any:
        """The mission events' report (``None``: a run without events)."""
        return None
