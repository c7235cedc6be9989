"""Distributed runs, simulated: every robot an agent, over a modelled network.

:func:`simulate` runs an algorithm's agents -- named (``"grape-s"``, ``"sda"``, ...: a
registered algorithm with a protocol, or ``MODULE:ATTR``) or any
:class:`heuristics.agents.Protocol` object --
in the discrete-event simulator of :mod:`heuristics.transport.simulator`, and returns
the same frozen :class:`heuristics.Run` as the centralized engines, with a
:class:`NetworkReport`.  The simulator knows no algorithm; the name is resolved here
(:func:`heuristics.distributed.protocol_for`, from the algorithm's registry entry).

Outcome
-------
Each robot performs the slot *its own* agent gives it (for the belief protocols: its own
final belief); the run's assignment is exactly that, so a run whose robots disagree is
scored by what they actually do.  The protocol reads the end: for GRAPE-S and its
variants the robots *converged* when they all ended on one belief that is final for the
algorithm (Nash stable for GRAPE-S, nothing left for the pairwise step of Pair-GRAPE-S,
no move and no phase step left for GRAPE-S-Select), at the time the last of them adopted
it; SDA's is in :mod:`heuristics.agents.sda`.  A run that has not ended by its simulated
time limit is *cut* and reported as such, with the robots' beliefs as they stand.

Mission events
--------------
With ``events=`` (a timeline: :mod:`heuristics.transport.events`) robots fail or join
and tasks arrive, are withdrawn or change utility during the run.

What the shipped protocols do
-----------------------------
GRAPE-S and Pair-GRAPE-S (:meth:`heuristics.agents.GrapeSAgent.on_event`): a detected
failure frees the failed robot's slot in the detecting robot's belief (an update, made
again whenever a newer belief shows that robot assigned); a withdrawn task's robots are
freed and the selection rule follows the present tasks and current utilities; every
event, news included, sets the robot running again, its quiet count reset (Pair-GRAPE-S
back in its GRAPE-S phase), so robots move again where the change makes a slot better.
GRAPE-S-Select, SDA and any protocol keeping the default ignore events: their robots do
not react (SDA does not re-open an auction).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cfopt import Mission, require_mission
from cfopt.checks import SeedLike, require_choice
from heuristics._run import Run
from heuristics.agents.protocol import Protocol
from heuristics.distributed import protocol_for
from heuristics.network import NetworkSpec
from heuristics.reward import REWARDS
from heuristics.transport import simulator
from heuristics.transport.driver import (
    DEFAULT_TIME_LIMIT,
    MAX_TIME_LIMIT,
    QUIET_FACTOR,
    NetworkReport,
    network_spec,
    quiet_factor_for,
    run_limits,
)
from heuristics.transport.simulator import Faults

__all__ = [
    "DEFAULT_TIME_LIMIT",
    "MAX_TIME_LIMIT",
    "QUIET_FACTOR",
    "NetworkReport",
    "network_spec",
    "quiet_factor_for",
    "run_limits",
    "simulate",
]


def simulate(
    mission: Mission,
    algorithm: str | Protocol,
    network: str | NetworkSpec,
    *,
    seed: SeedLike = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int | None = None,
    reward: str = "paper",
    faults: Faults | None = None,
    options: Mapping[str, Any] | None = None,
    events: Any = None,
) -> Run:
    """Run ``algorithm``'s agents on ``network`` (see the module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    algorithm : str or heuristics.agents.Protocol
        A registered name whose :class:`heuristics.AlgorithmSpec` has a protocol
        (``"grape-s"``, ``"pair-grape-s"``, ``"pair-grape-s-chain"``, ``"sda"``,
        ``"grape-s-select"``; RACHNA_dt has none, the seed did not run it distributed
        either), a ``MODULE:ATTR`` reference to one, or any protocol object.
    network : str or NetworkSpec
        A one-line spec (``"complete latency=uniform:1ms:10ms loss=0.01"``) or a parsed one.
    seed : None, int or numpy.random.Generator
        Everything random (placement, clocks, latencies, losses) flows from it.
    time_limit : float, default 3600
        Simulated seconds after which the run is cut, at most :data:`MAX_TIME_LIMIT`
        (8796).
    quiet_factor : int, optional
        ``K``: robots stop after ``K * d_G`` ticks without a change.  Default: the
        halting rule of the network's profile (``seed``: :mod:`heuristics.profiles`),
        else :data:`QUIET_FACTOR` (2).
    reward : {"paper", "utility"}
        GRAPE-S's reward weighting; ``"grape-s-select"`` has its own reward and takes only
        the default.
    faults : callable, optional
        For experiments: ``faults(sender, receivers, now)`` is called for every
        transmission, after the network's own draws, with the receivers as an int64 array
        and the send time in nanoseconds; it returns ``(extra_delay_ns, drop)`` arrays of
        the same length, added to the drawn delays and or-ed into the losses.
    options : mapping, optional
        With a name, the agents' own options: for ``"sda"`` ``eps`` (the wage decrement,
        default 1) and ``resend_tries`` (0, the plain protocol: see
        :mod:`heuristics.agents.sda`); for ``"grape-s-select"`` ``exchange`` (default
        ``True``: the exchange phase step).  A protocol object has its own.
    events : Timeline, dict or path, optional
        Mission events during the run: robots fail or join, tasks arrive or are
        withdrawn, utilities change (a ``cfopt.events/1`` timeline, with its failure
        detector: :mod:`heuristics.transport.events`); ``run.network.dynamics`` reports
        what followed each event and the utility over time against the optimum.

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
    require_mission(mission)
    protocol = protocol_for(algorithm, options)  # refused before anything is built
    spec = network_spec(network)
    require_choice("reward", reward, REWARDS)
    return simulator.simulate(
        mission,
        protocol,
        spec,
        seed=seed,
        time_limit=time_limit,
        quiet_factor=quiet_factor,
        reward=reward,
        faults=faults,
        events=events,
    )
