"""The distributed runs: every robot an agent, over a simulated network, event by event.

:func:`simulate` runs an algorithm's agents (:mod:`heuristics.agents`) on a network
(:mod:`heuristics.network`: topology, per-message latency and loss, the medium, clocks)
in a deterministic discrete-event simulation, and returns the same frozen
:class:`heuristics.Run` as the centralized engines, with a :class:`NetworkReport`.

The kernel
----------
A heap of ``(time, seq, kind, payload)`` events with an ``itertools.count`` tie-breaker:
clock ticks (one per robot per period) and the hops of direct messages.  Time is integer
nanoseconds.  Same mission, network spec and seed: the same run, byte for byte (every
random draw comes from generators spawned from the seed, in event order).  On the seed's
largest distributed cell (GRAPE-S, 500 robots, 50 % tasks, 10:5, the seed's network) the
heap took 6.20 s and simpy's environment driving the same ticks 6.33 s
(``python benchmarks/bench_distributed.py --kernels``): the kernel is a small share of a
run, whose time goes into the robots' ticks.  The heap is kept: as fast, and no
dependency.

Messages
--------
A message is processed by its receiver at the receiver's first clock tick strictly after
it arrived (with lock-step clocks and no latency, a tick's messages are thus seen at the
next tick, after every robot has selected).  Belief broadcasts are kept as rows of an
in-flight table -- per receiver an arrival time, or never (lost, not a neighbour, or not
newer than what the receiver already holds when it was sent, so that it cannot change
anything there) -- and at a tick the robot is handed the *newest* belief that has
arrived: the one the distributed mutex would keep of them all (the others cannot matter,
beliefs being compared by key alone).  A broadcast reaches every neighbour with
independent latency and loss draws; ``medium=broadcast`` counts it as one transmission
of its encoded size, ``medium=unicast`` as one per neighbour.  Direct messages (requests,
answers, bids) travel hop by hop along a shortest path, every hop a transmission with its
own latency and loss; relays forward at once (the network layer does not wait for a tick).

Outcome
-------
Each robot performs the slot *its own* final belief gives it; the run's assignment is
exactly that, so a run whose robots disagree is scored by what they actually do.  The
observer (which no agent can see) records when all robots first held one belief that is
final for the algorithm (Nash stable for GRAPE-S, nothing left for the pairwise step of
Pair-GRAPE-S, no move and no phase step left for GRAPE-S-Select) and stayed there; a run
that has not ended by its simulated time limit is *cut* and reported as such, with the
robots' beliefs as they stand.
"""

from __future__ import annotations

import heapq
import itertools
import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError, require_mission
from cfopt.checks import (
    SeedLike,
    require_int,
    require_number,
    require_seed,
    require_text,
    shown,
)
from cfopt.errors import MissionTypeError
from heuristics._run import Run, seed_label
from heuristics.agents.belief import Belief, Problem, encode_belief
from heuristics.agents.grape_s import (
    GrapeSAgent,
    PairGrapeSAgent,
    PairGrapeSChainAgent,
    chain_plan,
    pairwise_plan,
)
from heuristics.agents.grape_s_select import (
    GrapeSSelectAgent,
    SelectBelief,
    SelectModel,
    encode_select_belief,
)
from heuristics.network import Clocks, Links, Network, NetworkSpec

__all__ = [
    "DEFAULT_TIME_LIMIT",
    "MAX_TIME_LIMIT",
    "QUIET_FACTOR",
    "NetworkReport",
    "network_spec",
    "run_limits",
    "simulate",
]

#: Simulated seconds after which a run that has not ended is cut (the seed's one hour).
DEFAULT_TIME_LIMIT = 3600.0
#: ``K`` of the termination rule: a robot stops after ``K * d_G`` ticks without a change.
QUIET_FACTOR = 2
#: Distributed algorithms the simulator runs.
DISTRIBUTED = ("grape-s", "pair-grape-s", "sda", "pair-grape-s-chain", "grape-s-select")
_ID_BITS = 20  # a key (r, time, id) packs time and id into one int64: time * 2**20 + id + 1
_MAX_TIME_NS = (2**63 - 1) >> _ID_BITS
#: The longest ``time_limit`` a run takes, in seconds (8796: event times are packed into
#: 64-bit keys).
MAX_TIME_LIMIT = _MAX_TIME_NS // 10**9
_NEVER = np.iinfo(np.int64).max
_TICK, _HOP, _WAKE = 0, 1, 2

Faults = Callable[
    [int, npt.NDArray[np.int64], int], tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]
]


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
        if out["transport"] is None:
            del out["transport"]
        return out


def simulate(
    mission: Mission,
    algorithm: str,
    network: str | NetworkSpec,
    *,
    seed: SeedLike = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int = QUIET_FACTOR,
    reward: str = "paper",
    faults: Faults | None = None,
    options: Mapping[str, Any] | None = None,
) -> Run:
    """Run ``algorithm``'s agents on ``network`` (see the module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    algorithm : {"grape-s", "pair-grape-s", "pair-grape-s-chain", "sda", "grape-s-select"}
        The algorithms with agents (:data:`DISTRIBUTED`); RACHNA_dt has none (the seed did
        not run it distributed either).
    network : str or NetworkSpec
        A one-line spec (``"complete latency=uniform:1ms:10ms loss=0.01"``) or a parsed one.
    seed : None, int or numpy.random.Generator
        Everything random (placement, clocks, latencies, losses) flows from it.
    time_limit : float, default 3600
        Simulated seconds after which the run is cut, at most :data:`MAX_TIME_LIMIT`
        (8796).
    quiet_factor : int, default 2
        ``K``: robots stop after ``K * d_G`` ticks without a change.
    reward : {"paper", "utility"}
        GRAPE-S's reward weighting; ``"grape-s-select"`` has its own reward and takes only
        the default.
    faults : callable, optional
        For experiments: ``faults(sender, receivers, now)`` is called for every
        transmission, after the network's own draws, with the receivers as an int64 array
        and the send time in nanoseconds; it returns ``(extra_delay_ns, drop)`` arrays of
        the same length, added to the drawn delays and or-ed into the losses.
    options : mapping, optional
        The algorithm's own options: for ``"sda"`` ``eps`` (the wage decrement, default 1)
        and ``resend_tries`` (0, the plain protocol: see :mod:`heuristics.agents.sda`); for
        ``"grape-s-select"`` ``exchange`` (default ``True``: the exchange phase step).

    Returns
    -------
    Run
        ``run.network`` is the :class:`NetworkReport`; ``messages`` and ``bytes`` are the
        transmissions and their bytes, ``rounds`` the most ticks any robot made,
        ``iterations`` the updates in the history of the newest final belief (whose
        moves are the ``trajectory``), ``work`` the slot examinations of every tick.

    Notes
    -----
    Cost: one heap operation and O(rows in flight) numpy work per tick, plus one
    vectorised draw per broadcast; beliefs are computed on once each (their slot bests are
    cached), so a run costs about O(ticks (n + rows)) with small constants.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.generate_mission(robots=12, percent_tasks=25, service_types=3,
    ...                            services_per_robot=2, seed=4)
    >>> run = simulate(m, "grape-s", "complete sync=true", seed=0)
    >>> run.network.converged, run.network.beliefs_agree, run.assignment.percent_utility(m)
    (True, True, 100.0)
    """
    started = time.perf_counter()
    require_mission(mission)
    _protocol(algorithm, options)  # an unknown algorithm is refused before anything is built
    spec = network_spec(network)
    require_seed("seed", seed)
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    if faults is not None and not callable(faults):
        raise MissionTypeError(f"faults: must be callable or None, got {shown(faults)}")
    sim = _Simulation(mission, algorithm, spec, seed, limit, quiet_factor, reward, faults, options)
    sim.run()
    return sim.result(time.perf_counter() - started, seed_label(seed))


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


def run_limits(time_limit: Any, quiet_factor: Any) -> tuple[int, int]:
    """The checked ``time_limit`` (in nanoseconds) and ``quiet_factor`` of a distributed run.

    >>> run_limits(1.5, 2)
    (1500000000, 2)
    """
    scaled = 1e9 * require_number("time_limit", time_limit, above=0, what="a number of seconds")
    if scaled > _MAX_TIME_NS + 1 or round(scaled) > _MAX_TIME_NS:  # no round() of inf
        problem = f"at most {MAX_TIME_LIMIT} simulated seconds, got {time_limit!r}"
        raise MissionError(f"time_limit: {problem}", cli=f"--time-limit: {problem}")
    # never 0 ns: a limit > 0 s, as the ranks of an MPI run are given it back in seconds
    return max(round(scaled), 1), require_int("quiet_factor", quiet_factor, minimum=1)


def _packed(key: tuple[int, int, int]) -> tuple[int, int]:
    r, t, robot = key
    return r, (t << _ID_BITS) + robot + 1


class _InFlight:
    """Belief broadcasts in flight: rows of per-receiver arrival times (module docstring).

    A row is retired once every reception has arrived; its belief is then folded into a
    per-receiver *carry* (the newest retired belief that reached that receiver).
    """

    def __init__(self, n: int, capacity: int = 64) -> None:
        self.n = n
        self.arrival = np.full((capacity, n), _NEVER, dtype=np.int64)
        self.r = np.zeros(capacity, dtype=np.int64)
        self.tid = np.zeros(capacity, dtype=np.int64)
        self.beliefs: list[Belief | None] = [None] * capacity
        self.alive = np.zeros(capacity, dtype=bool)
        self.free = list(range(capacity - 1, -1, -1))
        self.rows: npt.NDArray[np.intp] = np.zeros(0, dtype=np.intp)
        self.dirty = False
        self.retire_at: list[tuple[int, int]] = []
        self.carry_r = np.full(n, -1, dtype=np.int64)
        self.carry_tid = np.full(n, -1, dtype=np.int64)
        self.carry: list[Belief | None] = [None] * n

    def _grow(self) -> None:
        old = self.alive.size
        self.arrival = np.vstack([self.arrival, np.full((old, self.n), _NEVER, dtype=np.int64)])
        self.r = np.concatenate([self.r, np.zeros(old, dtype=np.int64)])
        self.tid = np.concatenate([self.tid, np.zeros(old, dtype=np.int64)])
        self.alive = np.concatenate([self.alive, np.zeros(old, dtype=bool)])
        self.beliefs += [None] * old
        self.free = list(range(2 * old - 1, old - 1, -1))

    def add(
        self,
        belief: Belief,
        receivers: npt.NDArray[np.int64],
        arrivals: npt.NDArray[np.int64],
    ) -> None:
        if not self.free:
            self._grow()
        row = self.free.pop()
        self.arrival[row, receivers] = arrivals
        self.r[row], self.tid[row] = _packed(belief.key)
        self.beliefs[row] = belief
        self.alive[row] = True
        self.dirty = True
        heapq.heappush(self.retire_at, (int(arrivals.max()), row))

    def retire(self, now: int) -> None:
        """Fold every row whose receptions have all arrived before ``now`` into the carry."""
        while self.retire_at and self.retire_at[0][0] < now:
            _, row = heapq.heappop(self.retire_at)
            arrived = self.arrival[row]
            receivers = np.flatnonzero(arrived != _NEVER)
            r, tid = self.r[row], self.tid[row]
            newer = (r > self.carry_r[receivers]) | (
                (r == self.carry_r[receivers]) & (tid > self.carry_tid[receivers])
            )
            belief = self.beliefs[row]
            for j in receivers[newer].tolist():
                self.carry[j] = belief
            self.carry_r[receivers[newer]] = r
            self.carry_tid[receivers[newer]] = tid
            self.arrival[row] = _NEVER
            self.beliefs[row] = None
            self.alive[row] = False
            self.free.append(row)
            self.dirty = True

    def newest(self, receiver: int, now: int) -> Belief | None:
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


@dataclass(frozen=True)
class Outcome:
    """What a protocol reports about a finished run (see :class:`Protocol`)."""

    iterations: int
    trajectory: list[tuple[int, int, int, int]]
    converged: bool
    beliefs_agree: bool
    convergence_ns: int | None
    exchanges: int = 0
    pairwise_step_ran: bool = False
    options: tuple[tuple[str, Any], ...] = ()
    # counted work of message-driven agents and of phase steps (ticks are counted per tick)
    work: int = 0


class Protocol:
    """An algorithm as the simulator runs it: its agents and the reading of their end.

    The kernel drives two kinds of agents.  *Clocked* agents (``agent.clocked``) run at
    every tick of their robot's clock: ``tick(now, newest_belief, inbox) -> (belief or
    None, sends)``, the belief being broadcast; they set ``stopped`` to end.  *Message
    driven* agents run when a message reaches their robot, ``receive(now, message) ->
    sends``, at ``start(now) -> sends`` (their robot's first tick) and at ``wake(now) ->
    sends`` when the time they put in ``wake_at`` comes.  ``sends`` are ``(robot,
    message)`` pairs, a message having ``encode() -> bytes``.  Every agent has
    ``performed_slot()`` (what its robot does at the end), ``ticks`` and ``proposals``.
    """

    name = ""
    pairwise = False

    def make_agents(self, sim: _Simulation) -> list[Any]:
        """Every robot's agent, robot 0 first."""
        return [self.make_agent(sim, i) for i in range(sim.n)]

    def make_agent(self, sim: Any, robot: int) -> Any:
        """Robot ``robot``'s agent (``sim`` gives ``problem``, ``quiet_limit`` and
        ``network``): the MPI transport builds only the robots of its rank."""
        raise NotImplementedError

    def encode(self, belief: Belief, agent: Any) -> bytes:
        """The message by which a clocked agent broadcasts ``belief`` (the medium counts
        its bytes)."""
        return encode_belief(belief, pairwise=agent.pairwise)

    def outcome(self, sim: _Simulation) -> Outcome:
        raise NotImplementedError


class GrapeSProtocol(Protocol):
    """GRAPE-S's agents (:class:`heuristics.agents.GrapeSAgent`); final = Nash stable."""

    name = "grape-s"

    def make_agent(self, sim: Any, robot: int) -> Any:
        return GrapeSAgent(robot, sim.problem, sim.quiet_limit)

    def final(self, sim: _Simulation, belief: Belief) -> bool:
        return sim.problem.stable(belief, capped=False)

    def outcome(self, sim: _Simulation) -> Outcome:
        S = max(sim.mission.n_services, 1)
        beliefs = [agent.belief for agent in sim.agents]
        newest = max(beliefs, key=lambda b: b.key) if beliefs else Belief.initial(0)
        agree = len(sim.held) <= 1
        converged = agree and self.final(sim, newest)
        when = None
        if converged:
            agreed = sim.agreed
            when = agreed[1] if agreed is not None and agreed[0] == newest.key else 0
        trajectory = [
            (it, robot, slot // S if slot >= 0 else -1, slot % S if slot >= 0 else -1)
            for it, robot, slot in newest.moves()
        ]
        return Outcome(
            iterations=newest.r,
            trajectory=trajectory,
            converged=bool(converged),
            beliefs_agree=bool(agree),
            convergence_ns=when,
            exchanges=sum(1 for node in _trail_nodes(newest) if len(node[1]) >= 2),
            pairwise_step_ran=any(getattr(a, "step_needed", False) for a in sim.agents),
            options=(("capped", self.pairwise), ("reward", sim.reward)),
        )


class PairGrapeSProtocol(GrapeSProtocol):
    """Pair-GRAPE-S's agents; final = nothing left for the pairwise step."""

    name = "pair-grape-s"
    pairwise = True

    def make_agent(self, sim: Any, robot: int) -> Any:
        return PairGrapeSAgent(robot, sim.problem, sim.quiet_limit, sim.network.hops)

    def final(self, sim: _Simulation, belief: Belief) -> bool:
        return pairwise_plan(sim.problem, belief) is None


class PairGrapeSChainProtocol(PairGrapeSProtocol):
    """Pair-GRAPE-S with chain exchanges; final = no chain left for the step."""

    name = "pair-grape-s-chain"

    def make_agent(self, sim: Any, robot: int) -> Any:
        return PairGrapeSChainAgent(robot, sim.problem, sim.quiet_limit, sim.network.hops)

    def final(self, sim: _Simulation, belief: Belief) -> bool:
        return chain_plan(sim.problem, belief) is None


class GrapeSSelectProtocol(GrapeSProtocol):
    """GRAPE-S-Select's agents (:class:`heuristics.agents.GrapeSSelectAgent`); final = no
    robot has a move and no phase step applies.  Beliefs carry the task bits (``16 + 4 n +
    ceil(m / 4)`` bytes); the trajectory and ``iterations`` count, as the centralized
    engine does, the updates that changed the partition (moves, close and exchange steps,
    not reopenings)."""

    name = "grape-s-select"

    def __init__(self, exchange: bool = True) -> None:
        if not isinstance(exchange, bool | np.bool_):
            raise MissionError(f"options: exchange must be True or False, got {exchange!r}")
        self.exchange = bool(exchange)
        self.model: SelectModel | None = None

    def make_agents(self, sim: _Simulation) -> list[Any]:
        if sim.reward != "paper":
            raise MissionError(
                f"reward: grape-s-select has its own reward, got reward={sim.reward!r}"
            )
        model = self.model = SelectModel(sim.mission, exchange=self.exchange)
        return [GrapeSSelectAgent(i, sim.problem, model, sim.quiet_limit) for i in range(sim.n)]

    def final(self, sim: _Simulation, belief: Belief) -> bool:
        assert self.model is not None and isinstance(belief, SelectBelief)
        return self.model.final(belief)

    def encode(self, belief: Belief, agent: Any) -> bytes:
        assert isinstance(belief, SelectBelief)
        return encode_select_belief(belief)

    def outcome(self, sim: _Simulation) -> Outcome:
        assert self.model is not None
        S = max(sim.mission.n_services, 1)
        beliefs = [agent.belief for agent in sim.agents]
        newest = max(beliefs, key=lambda b: b.key) if beliefs else self.model.initial()
        agree = len(sim.held) <= 1
        converged = agree and self.final(sim, newest)
        when = None
        if converged:
            agreed = sim.agreed
            when = agreed[1] if agreed is not None and agreed[0] == newest.key else 0
        iterations = 0
        trajectory = []
        for _, changes, _ in reversed(_trail_nodes(newest)):  # oldest first
            if changes:
                iterations += 1
                trajectory += [
                    (iterations, robot, *((slot // S, slot % S) if slot >= 0 else (-1, -1)))
                    for robot, slot in changes
                ]
        return Outcome(
            iterations=iterations,
            trajectory=trajectory,
            converged=bool(converged),
            beliefs_agree=bool(agree),
            convergence_ns=when,
            options=(("exchange", self.exchange),),
            work=sum(agent.work for agent in sim.agents),
        )


def _protocol(algorithm: str, options: Mapping[str, Any] | None = None) -> Protocol:
    require_text("algorithm", algorithm)
    if options is not None and not isinstance(options, Mapping):
        raise MissionTypeError(
            f"options: must be a mapping of the agents' options or None, got {shown(options)}"
        )
    options = dict(options or {})
    if algorithm == "grape-s-select":
        unknown = [k for k in options if k != "exchange"]
        if unknown:
            raise MissionError(
                f"options: grape-s-select's agents take exchange, not {unknown[0]!r}"
            )
        return GrapeSSelectProtocol(**options)
    if algorithm == "sda":
        from heuristics.agents.sda import SdaProtocol

        known = ("eps", "resend_tries")
        unknown = [k for k in options if k not in known]
        if unknown:
            raise MissionError(f"options: sda's agents take {', '.join(known)}, not {unknown[0]!r}")
        return SdaProtocol(**options)
    plain = {
        "grape-s": GrapeSProtocol,
        "pair-grape-s": PairGrapeSProtocol,
        "pair-grape-s-chain": PairGrapeSChainProtocol,
    }
    if algorithm in plain:
        if options:
            raise MissionError(f"options: {algorithm}'s agents take none, got {sorted(options)}")
        return plain[algorithm]()
    raise MissionError(
        f"algorithm: {algorithm!r} has no distributed agents (available: {', '.join(DISTRIBUTED)})"
    )


class _Ticking:
    """What every transport does alike at a clocked agent's tick (the simulator's
    :class:`_Simulation` and the MPI transport's rank).  Uses ``agents``, ``inflight``,
    ``inbox``, ``problem``, ``work``, ``stopped``, ``key_r`` and ``key_tid``."""

    agents: Any
    inflight: _InFlight
    inbox: Any
    problem: Problem
    work: int
    stopped: npt.NDArray[np.bool_]
    key_r: npt.NDArray[np.int64]
    key_tid: npt.NDArray[np.int64]

    def _agent_tick(self, i: int, now: int) -> tuple[Belief, tuple[int, int, int], list[Any]]:
        """Robot ``i``'s agent ticks on the newest belief and the direct messages that
        arrived strictly before ``now``; returns its belief, its key before the tick and
        its direct sends."""
        self.inflight.retire(now)
        received = self.inflight.newest(i, now)
        inbox = self._take(i, now)
        agent = self.agents[i]
        before = agent.belief.key
        belief, sends = agent.tick(now, received, inbox)
        self.work += int(self.problem.examined[i])
        return belief, before, sends

    def _take(self, i: int, now: int) -> list[Any]:
        box = self.inbox[i]
        if not box:
            return []
        ready = [message for arrival, message in box if arrival < now]
        if ready:
            self.inbox[i] = [(a, m) for a, m in box if a >= now]
        return ready

    def _can_change(
        self, belief: Belief, receivers: npt.NDArray[np.int64]
    ) -> npt.NDArray[np.bool_]:
        """Which ``receivers`` ``belief`` can still change: running, holding an older key."""
        r, tid = _packed(belief.key)
        kr, kt = self.key_r[receivers], self.key_tid[receivers]
        return ~self.stopped[receivers] & ((r > kr) | ((r == kr) & (tid > kt)))


class _Simulation(_Ticking):
    """One distributed run: the agents, the network, the kernel and the counters."""

    def __init__(
        self,
        mission: Mission,
        algorithm: str,
        spec: NetworkSpec,
        seed: Any,
        limit: int,
        quiet_factor: int,
        reward: str,
        faults: Faults | None = None,
        options: Mapping[str, Any] | None = None,
    ) -> None:
        self.mission, self.algorithm, self.spec, self.limit = mission, algorithm, spec, limit
        self.faults = faults
        streams = np.random.SeedSequence(_entropy(seed)).spawn(4)
        topology_rng, clock_rng, latency_rng, loss_rng = (np.random.default_rng(s) for s in streams)
        self.network: Network = spec.build(mission, topology_rng)
        n = mission.n_robots
        self.n = n
        self.clocks = Clocks(spec, n, clock_rng)
        self.links = Links(self.network, latency_rng, loss_rng)
        self.problem = Problem(mission, reward)
        self.reward = reward
        self.quiet_limit = quiet_factor * max(self.network.diameter, 1)
        self.quiet_factor = quiet_factor
        self.protocol = _protocol(algorithm, options)
        self.agents: list[Any] = self.protocol.make_agents(self)
        self.inflight = _InFlight(n)
        self.key_r = np.zeros(n, dtype=np.int64)
        self.key_tid = np.zeros(n, dtype=np.int64)
        self.stopped = np.zeros(n, dtype=bool)
        self.inbox: list[list[tuple[int, Any]]] = [[] for _ in range(n)]
        self.heap: list[tuple[int, int, int, Any]] = []
        self.seq = itertools.count()
        self.tick_index = [0] * n
        self.held = Counter({Belief.initial(0).key: n})
        self.agreed: tuple[tuple[int, int, int], int] | None = None
        self.now = 0
        self.cut = False
        self.end = 0
        self.transmissions = self.receptions = self.losses = self.bytes = 0
        self.ticks = self.work = 0
        self.unicast = spec.medium == "unicast"
        self.waking: list[int | None] = [None] * n

    # ---------------------------------------------------------------- the kernel
    def run(self) -> None:
        heap = self.heap
        for i in range(self.n):
            heapq.heappush(heap, (self.clocks.tick_time(i, 0), next(self.seq), _TICK, i))
        while heap:
            t, _, kind, payload = heapq.heappop(heap)
            if kind == _WAKE and self.waking[payload] != t:
                continue  # a timer the agent has since moved or cleared: not an event
            if t > self.limit:
                self.cut = True
                self.now = self.limit
                break
            self.now = t
            if kind == _TICK:
                self._tick(payload, t)
            elif kind == _HOP:
                self._hop(payload, t)
            else:
                self.waking[payload] = None
                self._act(payload, self.agents[payload].wake(t), t)
        self.end = self.limit if self.cut else self.now

    def _tick(self, i: int, now: int) -> None:
        self.ticks += 1
        agent = self.agents[i]
        if not agent.clocked:  # a message-driven agent: its clock only starts it
            self._act(i, agent.start(now), now)
            return
        belief, before, sends = self._agent_tick(i, now)
        if belief.key != before:
            self._observe(i, before, belief.key, now)
        self._broadcast(i, belief, now, agent)
        for dest, message in sends:
            self._send(i, dest, message, now)
        if agent.stopped:
            self.stopped[i] = True
            return
        self.tick_index[i] += 1
        nxt = self.clocks.tick_time(i, self.tick_index[i])
        heapq.heappush(self.heap, (nxt, next(self.seq), _TICK, i))

    def _act(self, i: int, sends: list[tuple[int, Any]], now: int) -> None:
        """After a message-driven agent ran: its sends, and its next wake-up."""
        for dest, message in sends:
            self._send(i, dest, message, now)
        wake = self.agents[i].wake_at
        if wake is not None and wake != self.waking[i]:
            self.waking[i] = wake
            heapq.heappush(self.heap, (max(wake, now), next(self.seq), _WAKE, i))

    def _observe(self, i: int, before: tuple[int, int, int], after: tuple[int, int, int], now: int):
        held = self.held
        held[before] -= 1
        if not held[before]:
            del held[before]
        held[after] += 1
        self.key_r[i], self.key_tid[i] = _packed(after)
        if held[after] == self.n:
            self.agreed = (after, now)

    # ------------------------------------------------------------------ the medium
    def _broadcast(self, i: int, belief: Belief, now: int, agent: Any) -> None:
        receivers = self.network.neighbours(i)
        if receivers.size == 0:
            return
        size = len(self.protocol.encode(belief, agent))
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

    def _transmit(
        self, sender: int, receivers: npt.NDArray[np.int64], now: int
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        delays, lost = self.links.transmit(sender, receivers)
        if self.faults is not None:
            extra, drop = self.faults(sender, receivers, now)
            delays = delays + np.asarray(extra, dtype=np.int64)
            lost = lost | np.asarray(drop, dtype=bool)
        return delays, lost

    def _send(self, source: int, dest: int, message: Any, now: int) -> None:
        payload = message.encode()
        if dest == source:  # two agents on one robot: no transmission
            heapq.heappush(self.heap, (now, next(self.seq), _HOP, (dest, message, 0, dest)))
            return
        self._forward(dest, message, len(payload), source, now)

    def _forward(self, dest: int, message: Any, size: int, at: int, now: int) -> None:
        # a complete network (no adjacency kept) delivers directly: next_hop would say so
        nxt = dest if self.network.indptr is None else self.network.next_hop(at, dest)
        if self.faults is None:
            delay, lost = self.links.transmit_one(at, nxt)
        else:
            delays, losts = self._transmit(at, np.array([nxt], dtype=np.int64), now)
            delay, lost = int(delays[0]), bool(losts[0])
        self.transmissions += 1
        self.bytes += size
        if lost:
            self.losses += 1
            return
        self.receptions += 1
        arrival = now + delay
        heapq.heappush(self.heap, (arrival, next(self.seq), _HOP, (dest, message, size, nxt)))

    def _hop(self, payload: tuple[int, Any, int, int], now: int) -> None:
        dest, message, size, at = payload
        if at != dest:
            self._forward(dest, message, size, at, now)
        elif self.agents[dest].clocked:
            self.inbox[dest].append((now, message))
        else:
            self.ticks += 1
            self._act(dest, self.agents[dest].receive(now, message), now)

    # ------------------------------------------------------------------ the result
    def result(self, seconds: float, seed: int | None) -> Run:
        S = max(self.mission.n_services, 1)
        own = np.array([a.performed_slot() for a in self.agents], dtype=np.int64)
        task = np.where(own >= 0, own // S, -1)
        service = np.where(own >= 0, own % S, -1)
        outcome = self.protocol.outcome(self)
        spec = self.spec
        report = NetworkReport.on(
            spec,
            self.network.diameter,
            simulated_seconds=self.end / 1e9,
            convergence_seconds=(
                None if outcome.convergence_ns is None else outcome.convergence_ns / 1e9
            ),
            transmissions=self.transmissions,
            receptions=self.receptions,
            losses=self.losses,
            bytes=self.bytes,
            ticks=self.ticks,
            proposals=sum(a.proposals for a in self.agents),
            converged=outcome.converged,
            beliefs_agree=outcome.beliefs_agree,
            cut=self.cut,
        )
        return Run(
            algorithm=self.algorithm,
            assignment=Assignment(task=task, service=service),
            iterations=outcome.iterations,
            rounds=max((a.ticks for a in self.agents), default=0),
            messages=self.transmissions,
            bytes=self.bytes,
            work=self.work + outcome.work,
            seconds=seconds,
            seed=seed,
            exchanges=outcome.exchanges,
            pairwise_step_ran=outcome.pairwise_step_ran,
            trajectory=np.array(outcome.trajectory, dtype=np.int64).reshape(-1, 4),
            options=(
                ("network", spec.to_text()),
                ("quiet_factor", self.quiet_factor),
                *outcome.options,
                ("engine", "simulated"),
            ),
            network=report,
        )


def _trail_nodes(belief: Belief) -> list[Any]:
    nodes = []
    node = belief.trail
    while node is not None:
        nodes.append(node)
        node = node[2]
    return nodes


def _entropy(seed: Any) -> Any:
    """SeedSequence entropy from a run's seed (a Generator gives a fresh draw of its own)."""
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(2**63))
    return seed
