"""The algorithms as agents, one module each, and the public agent API.

An agent is one robot's state machine.  It reads only its own state and the messages it
received, and a transport -- the discrete-event simulator or, for real processes, MPI
(:mod:`heuristics.transport`) -- decides when it runs and what reaches it.  Both
transports share these agents, so a simulated run and a real one execute the same code.

:mod:`heuristics.agents.protocol` is the API a distributed algorithm is written against
(:class:`Protocol`, :class:`Agent`, the contexts they read, what they report); every
shipped protocol lives beside its agents (:mod:`heuristics.agents.grape_s`,
:mod:`heuristics.agents.grape_s_select`, :mod:`heuristics.agents.sda`).
"""

from heuristics.agents.belief import Belief, Problem, decode_belief, encode_belief
from heuristics.agents.grape_s import GrapeSAgent, PairGrapeSAgent
from heuristics.agents.grape_s_select import GrapeSSelectAgent
from heuristics.agents.protocol import (
    NO_BELIEF,
    Agent,
    AgentContext,
    Key,
    NoBelief,
    Protocol,
    ProtocolOutcome,
    RunContext,
    RunEnd,
    Sends,
)

__all__ = [
    "NO_BELIEF",
    "Agent",
    "AgentContext",
    "Belief",
    "GrapeSAgent",
    "GrapeSSelectAgent",
    "Key",
    "NoBelief",
    "PairGrapeSAgent",
    "Problem",
    "Protocol",
    "ProtocolOutcome",
    "RunContext",
    "RunEnd",
    "Sends",
    "decode_belief",
    "encode_belief",
]
