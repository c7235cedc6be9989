"""The public agent API: what a distributed algorithm implements, and what it may read.

A distributed algorithm is a :class:`Protocol`: it builds one *agent* per robot and reads
the end of a run.  A *transport* -- the discrete-event simulator
(:func:`heuristics.simulate`) or real MPI processes (:func:`heuristics.mpi_run`) --
decides when each agent runs and what reaches it; it knows time, delivery and encoded
sizes, never which algorithm it carries.  Any protocol runs on every transport, unchanged:

>>> import cfopt, heuristics
>>> m = cfopt.generate_mission(robots=12, percent_tasks=25, service_types=3,
...                            services_per_robot=2, seed=4)
>>> from heuristics.agents.grape_s import GrapeSProtocol
>>> run = heuristics.simulate(m, GrapeSProtocol(), "ring latency=uniform:1ms:5ms", seed=0)
>>> run.algorithm, run.network.beliefs_agree
('grape-s', True)

Time
----
Integer nanoseconds of simulated time (of real time since the run's common start, in a
free-running MPI run).  Every robot has a clock (``period=`` of the network spec, 10 ms by
default, with offsets and jitter unless ``sync=true``).

Agents
------
An agent is one robot's state machine; it reads only its own state, its
:class:`AgentContext` and the messages that reached it.  There are two kinds
(:class:`Agent` gives every attribute a default):

*Clocked* agents (``clocked = True``) run at every tick of their robot's clock:
``tick(now, received, inbox) -> (belief or None, sends)``.  ``received`` is the newest
*belief* that has reached the robot strictly before ``now`` (``None``: none has) and
``inbox`` the direct messages that arrived since the last tick, oldest first; the belief
returned is broadcast to the robot's neighbours (``None``: nothing this tick).  An agent
ends by setting ``stopped = True``: it is not ticked again, broadcasts nothing and hears
nothing.

*Message-driven* agents (``clocked = False``) run when something happens to them:
``start(now)`` at their robot's first tick (the only tick they get), ``receive(now,
message)`` the moment a direct message reaches their robot, and ``wake(now)`` when the
time they put in ``wake_at`` comes (``None``: no timer; a timer moved or cleared before it
fires does not fire).  Each returns its sends.

``sends`` is a list of ``(robot, message)``: a direct message to the agent of robot
``robot`` (its own robot included: two agents on one robot talk without a transmission),
routed hop by hop along a shortest path, every hop with its own latency and loss.

Beliefs and keys
----------------
A broadcast belief is any object with a ``key``: a tuple of three ints ``(r, time, id)``
compared lexicographically (``r >= 0``, ``0 <= time < 2**43`` ns, ``-1 <= id < 2**20 -
1``), and a clocked agent's ``belief`` attribute is the one it holds (its key never goes
down).  The transport implements the *distributed mutex* for the agents: of the
broadcasts that have reached a robot it hands over only the one with the highest key, and
it may drop a broadcast whose key is not above the receiver's own when it is sent (it
cannot win there).  Beliefs are therefore compared by key alone: two beliefs with one key
must be the same belief.  The transport also watches the keys: a run's ``beliefs_agree``
and the time every robot last changed its belief come from them.

Messages on the wire
--------------------
Everything sent is encoded: :meth:`Protocol.encode` gives a belief's bytes,
:meth:`Protocol.encode_message` a direct message's (by default ``message.encode()``).
The medium counts those bytes.  The MPI transport sends exactly them and rebuilds what
was sent with :meth:`Protocol.decode` and :meth:`Protocol.decode_message`, so these must
be exact inverses (up to what the agents never read).

Determinism
-----------
Agents draw nothing random unless a protocol gives them a generator of their own
(seeded from its options): the transport's draws (placement, clocks, latencies, losses)
come from the run's seed, so the same mission, network spec, seed and protocol make the
same run, byte for byte.

The end of a run
----------------
A run ends when nothing is left to happen -- every clocked agent has stopped, no message
is in flight and no timer is set -- or at its time limit (it is then *cut*).  Each robot
performs what its agent's ``performed_slot()`` says (``task * S + service``, ``-1``:
none).  The transport sums the agents' ``work`` (counted computation) into
``run.work``, their ``proposals`` into the network report's, and takes the most
``ticks`` any agent made as ``run.rounds``; :meth:`Protocol.report` then gives what each
agent tells the observer (picklable: over MPI it travels to rank 0) and
:meth:`Protocol.outcome` reads the run's :class:`RunEnd` into a :class:`ProtocolOutcome`.

Mission events
--------------
A simulated run may be given a timeline of mission events
(:mod:`heuristics.transport.events`: robots fail or join, tasks arrive or are withdrawn,
utilities change).  The transport tells an agent what *its robot* can know, through
:meth:`Agent.on_event` with one of: :class:`RobotFailed` (its failure detector presumes a
neighbour failed), :class:`RobotRecovered` (a presumed-failed neighbour was heard again),
:class:`RobotJoined` (its own robot has just joined, or it first heard a robot
that joined), :class:`MissionChanged` (the
mission as it now stands, announced to every robot), :class:`NewsArrived` (a belief
newer than its own reached it while it was stopped).  ``on_event`` returns ``True`` to
run again: a stopped clocked agent is then ticked again from its robot's next tick.  The
default ignores every event and returns ``False``, so a protocol written without events
runs unchanged (its robots simply do not react).

MPI
---
For :func:`heuristics.mpi_run` a protocol object is pickled to the ranks: it (and
whatever it holds) must be picklable, and its class must live in a module the ranks can
import (not ``__main__``; the ranks get the launching process's working directory first
on ``sys.path``).  Each rank builds the agents of its own robots only, with its own
:meth:`Protocol.prepare`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission

__all__ = [
    "NO_BELIEF",
    "Agent",
    "AgentContext",
    "Key",
    "MissionChanged",
    "NewsArrived",
    "NoBelief",
    "Protocol",
    "ProtocolOutcome",
    "RobotFailed",
    "RobotJoined",
    "RobotRecovered",
    "RunContext",
    "RunEnd",
    "Sends",
]

#: A broadcast belief's key ``(r, time, id)``: the distributed mutex keeps the highest.
Key = tuple[int, int, int]
#: Direct messages an agent sends: ``(robot, message)`` pairs.
Sends = list[tuple[int, Any]]


@dataclass(frozen=True)
class RunContext:
    """What every agent of a run may read: the mission and the network's shape (frozen).

    Attributes
    ----------
    mission : cfopt.Mission
        Common knowledge: every robot knows the mission.
    reward : str
        The reward weighting the run was asked for (``"paper"`` by default); a protocol
        that has its own refuses others in :meth:`Protocol.prepare`.
    quiet_limit : int
        ``K * d_G``: the ticks without a change after which the shipped agents stop.
    diameter : int
        ``d_G``, the network's diameter (in hops).
    period_ns : int
        The clock period, in nanoseconds.
    hops : callable
        ``hops(a, b)``: the length of a shortest route from robot ``a`` to robot ``b``.
    neighbours : callable
        ``neighbours(i)``: robot ``i``'s neighbours, a sorted int64 array.
    """

    mission: Mission
    reward: str
    quiet_limit: int
    diameter: int
    period_ns: int
    hops: Callable[[int, int], int] = field(repr=False)
    neighbours: Callable[[int], npt.NDArray[np.int64]] = field(repr=False)

    @property
    def n(self) -> int:
        """The number of robots."""
        return self.mission.n_robots

    def for_robot(self, robot: int, shared: Any = None) -> AgentContext:
        """Robot ``robot``'s :class:`AgentContext`, with what :meth:`Protocol.prepare`
        returned as ``shared``."""
        return AgentContext(
            self.mission,
            self.reward,
            self.quiet_limit,
            self.diameter,
            self.period_ns,
            self.hops,
            self.neighbours,
            robot=robot,
            shared=shared,
        )


@dataclass(frozen=True)
class AgentContext(RunContext):
    """What one robot's agent may read when it is built (frozen): the run's
    :class:`RunContext`, the robot, and what the protocol prepared for the run.

    Attributes
    ----------
    robot : int
        The robot this agent runs on.
    shared : object
        :meth:`Protocol.prepare`'s value (built once per process and shared by the
        agents built there: only what every robot knows, and caches).
    """

    robot: int = -1
    shared: Any = field(default=None, repr=False)


@dataclass(frozen=True)
class NoBelief:
    """What a clocked agent holds before it has a belief: the key every belief starts
    from, ``(0, 0, -1)``."""

    key: Key = (0, 0, -1)


#: The :class:`NoBelief`.
NO_BELIEF = NoBelief()


@dataclass(frozen=True)
class RobotFailed:
    """This robot's failure detector presumes neighbour ``robot`` failed."""

    robot: int


@dataclass(frozen=True)
class RobotRecovered:
    """A neighbour this robot presumed failed has been heard again."""

    robot: int


@dataclass(frozen=True)
class RobotJoined:
    """Robot ``robot`` has joined the mission: told to the robot itself when it joins,
    and to each neighbour when it first hears it."""

    robot: int


@dataclass(frozen=True)
class NewsArrived:
    """A belief newer than this stopped robot's own (of key ``key``) is on its way to it."""

    key: Key


@dataclass(frozen=True)
class MissionChanged:
    """The mission as it now stands, announced to every robot at a task event.

    Attributes
    ----------
    mission : cfopt.Mission
        The mission with the utilities as they now are (every task of the run, those
        absent included).
    active : ndarray of bool
        Which tasks are present (arrived and not withdrawn).
    withdrawn : tuple of int
        The tasks this event withdrew.
    cache : dict
        Shared by every robot's copy of the event: what a protocol builds once from it.
    """

    mission: Mission
    active: npt.NDArray[np.bool_] = field(repr=False)
    withdrawn: tuple[int, ...] = ()
    cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)


class Agent:
    """A robot's agent, with the defaults of every attribute the transports read (see
    the module docstring for the contract).

    Attributes
    ----------
    clocked : bool
        ``True``: :meth:`tick` at every clock tick; ``False``: :meth:`start`,
        :meth:`receive` and :meth:`wake`.
    belief : object
        A clocked agent's current belief (with a ``key``; :data:`NO_BELIEF` until it
        has one).
    stopped : bool
        Set by a clocked agent to end.
    wake_at : int or None
        A message-driven agent's next timer (ns).
    ticks, proposals, work : int
        Clock ticks (or rounds) it made, belief updates it proposed, counted work.
    """

    clocked: bool = True
    belief: Any = NO_BELIEF
    stopped: bool = False
    wake_at: int | None = None
    ticks: int = 0
    proposals: int = 0
    work: int = 0

    def tick(self, now: int, received: Any, inbox: list[Any]) -> tuple[Any, Sends]:
        """A clock tick of a clocked agent: the belief to broadcast (or ``None``) and the
        direct messages to send."""
        raise NotImplementedError(f"{type(self).__name__} is clocked but has no tick()")

    def start(self, now: int) -> Sends:
        """A message-driven agent's first tick."""
        return []

    def receive(self, now: int, message: Any) -> Sends:
        """A direct message reached a message-driven agent's robot."""
        return []

    def wake(self, now: int) -> Sends:
        """A message-driven agent's timer (``wake_at``) came."""
        return []

    def performed_slot(self) -> int:
        """The slot ``task * S + service`` the robot performs at the end (``-1``: none)."""
        return -1

    def on_event(self, now: int, event: Any) -> bool:
        """A mission event reached this robot (module docstring, *Mission events*);
        ``True``: run again.  The default ignores it."""
        return False


@dataclass(frozen=True)
class ProtocolOutcome:
    """What a protocol says about a finished run (frozen; :meth:`Protocol.outcome`).

    Attributes
    ----------
    iterations : int
        The run's ``iterations`` (for the shipped belief protocols: the updates in the
        history of the newest belief).
    trajectory : sequence of (iteration, robot, task, service)
        The moves behind the result, oldest first (``task = service = -1``: released).
    converged : bool
        The robots ended on what is final for the algorithm.
    beliefs_agree : bool
        The robots ended on one belief (or one state).
    convergence_ns : int or None
        When the robots reached what they ended on (``None``: they did not converge).
    exchanges : int
        Exchange updates (updates that moved two or more robots at once).
    pairwise_step_ran : bool
        A pairwise step had work to do.
    options : tuple of (str, object)
        The protocol's options, recorded in ``run.options``.
    """

    iterations: int
    trajectory: Sequence[tuple[int, int, int, int]]
    converged: bool
    beliefs_agree: bool
    convergence_ns: int | None
    exchanges: int = 0
    pairwise_step_ran: bool = False
    options: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class RunEnd:
    """What the observer has at the end of a run: every robot's agent's report and what
    the transport watched (frozen).  Rank 0 builds it in an MPI run.

    Attributes
    ----------
    context : RunContext
    shared : object
        :meth:`Protocol.prepare`'s value in the observer's process.
    reports : tuple
        :meth:`Protocol.report` of every robot's agent, robot 0 first.
    keys : tuple
        Every robot's final belief key (``None`` for a message-driven agent).
    changed_ns : tuple of int
        When each robot's belief key last changed (0: never).
    slots : ndarray of int64
        The slot every robot performs.
    cut : bool
        The time limit ended the run.
    end_ns : int
        When the run ended.
    """

    context: RunContext
    shared: Any
    reports: tuple[Any, ...]
    keys: tuple[Key | None, ...]
    changed_ns: tuple[int, ...]
    slots: npt.NDArray[np.int64] = field(repr=False)
    cut: bool
    end_ns: int

    @property
    def beliefs_agree(self) -> bool:
        """Every clocked robot ended on one belief key."""
        return len({key for key in self.keys if key is not None}) <= 1

    @property
    def newest_key(self) -> Key | None:
        """The highest final key (``None``: no clocked robot)."""
        return max((key for key in self.keys if key is not None), default=None)

    @property
    def settled_ns(self) -> int:
        """When the last robot last changed its belief (0: none ever did)."""
        return max(self.changed_ns, default=0)


class Protocol:
    """A distributed algorithm: its agents, their codecs, and the reading of a run's end
    (module docstring).

    Subclasses implement :meth:`make_agent` and, when their agents broadcast beliefs,
    :meth:`encode` and :meth:`decode`; when they send direct messages over MPI,
    :meth:`decode_message`.  The rest has defaults.

    Attributes
    ----------
    name : str
        The run's ``algorithm`` (default: the class's name).
    """

    name: str = ""

    def prepare(self, context: RunContext) -> Any:
        """What the agents of a run share (built once per process before them; the
        default: nothing).  Raise :class:`cfopt.MissionError` here to refuse a run."""
        return None

    def make_agent(self, context: AgentContext) -> Agent:
        """Robot ``context.robot``'s agent (a transport builds only the robots it hosts)."""
        raise NotImplementedError(f"{type(self).__name__} must implement make_agent()")

    def encode(self, belief: Any) -> bytes:
        """The bytes by which a robot broadcasts ``belief``."""
        raise NotImplementedError(f"{type(self).__name__} broadcasts but has no encode()")

    def decode(self, data: bytes, context: RunContext) -> Any:
        """The belief :meth:`encode` made ``data`` from."""
        raise NotImplementedError(f"{type(self).__name__} has no decode() (needed over MPI)")

    def encoded_size(self, belief: Any, encoding: str, context: RunContext) -> int:
        """The bytes of ``belief`` on the air under ``encoding`` (the network token
        ``encoding=full|compact``).  The default: :meth:`encode`'s length for both (a
        protocol without a compact form sends its full one)."""
        return len(self.encode(belief))

    def encode_message(self, message: Any) -> bytes:
        """The bytes of a direct message (default: ``message.encode()``)."""
        return message.encode()

    def decode_message(self, data: bytes, context: RunContext) -> Any:
        """The direct message :meth:`encode_message` made ``data`` from."""
        raise NotImplementedError(
            f"{type(self).__name__} has no decode_message() (needed over MPI)"
        )

    def report(self, agent: Any) -> Any:
        """What ``agent`` tells the observer at the end (picklable; default ``None``)."""
        return None

    def outcome(self, end: RunEnd) -> ProtocolOutcome:
        """The run's outcome.  The default reads only the keys: the beliefs agree when
        every robot ended on one key, and then the run converged unless it was cut (when
        the last robot last changed); ``iterations`` is the newest key's ``r``."""
        agree = end.beliefs_agree
        converged = agree and not end.cut
        newest = end.newest_key
        return ProtocolOutcome(
            iterations=0 if newest is None else int(newest[0]),
            trajectory=(),
            converged=converged,
            beliefs_agree=agree,
            convergence_ns=end.settled_ns if converged else None,
        )

    @property
    def label(self) -> str:
        """:attr:`name`, or the class's name when it has none."""
        return self.name or type(self).__name__
