"""The algorithms as message-driven agents, one module each.

An agent is one robot's state machine.  It reads only its own state and the messages it
received, and the transport -- the discrete-event simulator of :mod:`heuristics.simulate`
or, for real processes, MPI -- decides when it runs and what reaches it.  Both transports
share these agents, so a simulated run and a real one execute the same code.
"""

from heuristics.agents.belief import Belief, Problem, decode_belief, encode_belief
from heuristics.agents.grape_s import GrapeSAgent, PairGrapeSAgent
from heuristics.agents.grape_s_select import GrapeSSelectAgent

__all__ = [
    "Belief",
    "GrapeSAgent",
    "GrapeSSelectAgent",
    "PairGrapeSAgent",
    "Problem",
    "decode_belief",
    "encode_belief",
]
