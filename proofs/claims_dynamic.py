"""cfopt's claims about recovery after a robot fails (F1-F3), on cfopt's simulator.

Each mission is run distributed (:func:`heuristics.simulate`, public API) on the seed's
network (:data:`cfopt.generate.SEED_NETWORK`: complete, latencies uniform in 1-10 ms, 1 %
loss, 10 ms clocks), and at 2 s -- after the robots of these missions have formed their
partition -- the first robot the run assigned fails (fail-stop).  The failure detector is
the simulator's (:mod:`heuristics.transport.events`): heartbeats every ``P`` = 100 ms, a
neighbour presumed failed after ``D`` = 300 ms of silence.  The partition the surviving
robots then hold is judged by ``proofs``' own Nash checker on the sub-mission of the
surviving robots.  A counterexample carries the network, the simulator seed and the
timeline, so ``cfopt run ALGORITHM mission.json --network SPEC --seed 0 --events FILE``
replays it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cfopt import Assignment, Mission
from cfopt.generate import SEED_NETWORK
from proofs.claimkit import (
    ALL_COMPOSITIONS,
    Claim,
    Counterexample,
    Evaluation,
    Scope,
    generated_missions,
    property_claim,
    tally_summary,
)
from proofs.stability import is_nash_stable

__all__ = ["FAIL_AT", "dynamic_claims", "recovery_bound_seconds", "survivors_stable"]

#: When the robot fails (simulated seconds), and the simulator's seed.
FAIL_AT = "2s"
SIM_SEED = 0
#: The detector of the claims (the simulator's defaults), in seconds.
DETECTOR_S, HEARTBEAT_S = 0.3, 0.1
#: The seed network's clock period, jitter and largest latency, in seconds.
_PERIOD_S, _JITTER, _LATENCY_S = 0.01, 0.1, 0.01


def survivors_stable(mission: Mission, outcome: Any) -> bool:
    """Whether the partition an event's window ended on
    (:class:`heuristics.transport.events.EventOutcome`) is Nash stable on the sub-mission
    of the robots and tasks present then (:func:`proofs.stability.is_nash_stable`)."""
    robots = np.array(outcome.robots, dtype=np.int64)
    tasks = np.array(outcome.tasks, dtype=np.int64)
    if robots.size == 0 or tasks.size == 0:
        return True
    sub = Mission.from_arrays(
        mission.capabilities[robots],
        mission.requirements[tasks],
        mission.utilities[tasks],
        services=mission.services,
    )
    S = max(mission.n_services, 1)
    slots = np.array(outcome.partition, dtype=np.int64)[robots]
    where = np.full(mission.n_tasks, -1, dtype=np.int64)
    where[tasks] = np.arange(tasks.size)
    task = np.where(slots >= 0, where[np.maximum(slots, 0) // S], -1)
    placed = task >= 0
    assignment = Assignment(task=task, service=np.where(placed, slots % S, -1))
    return bool(is_nash_stable(sub, assignment))


def recovery_bound_seconds(diameter: int) -> float:
    """F2's bound on the time from a failure to the survivors' last belief change:
    detection (``D + P``), then ``2 d_G + 3`` clock periods each stretched by the jitter
    and the largest latency (the freeing update's flood, and the moves it sets off)."""
    step = _PERIOD_S * (1 + _JITTER) + _LATENCY_S
    return DETECTOR_S + HEARTBEAT_S + (2 * max(diameter, 1) + 3) * step


def _failure(m: Mission, algorithm: str) -> tuple[Any, Any, dict[str, Any]] | None:
    """The run with its first assigned robot failing at :data:`FAIL_AT`, its event's
    outcome and the timeline (``None``: no robot was assigned)."""
    from heuristics import simulate  # the public API, never internals

    before = simulate(m, algorithm, SEED_NETWORK, seed=SIM_SEED)
    placed = [i for i, t in enumerate(before.assignment.task.tolist()) if t >= 0]
    if not placed:
        return None
    events = {"events": [{"at": FAIL_AT, "kind": "fail", "robot": m.robot_ids[placed[0]]}]}
    run = simulate(m, algorithm, SEED_NETWORK, seed=SIM_SEED, events=events)
    return run, run.network.dynamics.events[0], events


def _replay(algorithm: str, events: dict[str, Any]) -> str:
    return (
        f"replay: cfopt run {algorithm} MISSION --network '{SEED_NETWORK}' --seed {SIM_SEED} "
        f"--events FILE with FILE = {events}"
    )


def _stable_after(algorithm: str) -> Any:
    def evaluate(claim: Claim, m: Mission) -> Evaluation:
        found = _failure(m, algorithm)
        if found is None:
            return Evaluation(None, 0.0, ("nobody assigned",))
        run, after, events = found
        if after.reconverge_seconds is not None and survivors_stable(m, after):
            return Evaluation(None, 0.0, ("stable again",))
        state = "beliefs disagree" if after.reconverge_seconds is None else "not Nash stable"
        detail = (
            f"after robot {after.target} fails at {FAIL_AT}, the survivors' partition is "
            f"{state} (utility {after.utility_after:g} of optimum {after.optimum:g}); "
            f"{_replay(algorithm, events)}"
        )
        ce = Counterexample(m, run.assignment, algorithm, detail, SEED_NETWORK, SIM_SEED)
        return Evaluation(ce, 1.0, ("not stable",))

    return evaluate


def f2(claim: Claim, m: Mission) -> Evaluation:
    """GRAPE-S's survivors settle within :func:`recovery_bound_seconds` of the failure."""
    found = _failure(m, "grape-s")
    if found is None:
        return Evaluation(None, 0.0, ("nobody assigned",))
    run, after, events = found
    bound = recovery_bound_seconds(run.network.diameter)
    took = after.reconverge_seconds
    if took is not None and took <= bound:
        return Evaluation(None, took / bound, ("within the bound",))
    detail = (
        f"after robot {after.target} fails at {FAIL_AT} the survivors "
        + ("never agree" if took is None else f"settle after {took:.3f} s")
        + f" > D + P + (2 d_G + 3)(1.1 period + max latency) = {bound:.3f} s; "
        + _replay("grape-s", events)
    )
    ce = Counterexample(m, run.assignment, "grape-s", detail, SEED_NETWORK, SIM_SEED)
    return Evaluation(ce, 1.0 + (took or bound) / bound, ("beyond the bound",))


def dynamic_claims() -> list[Claim]:
    """The claims F1-F3, in the audit's order."""
    family = (
        "generated missions of 5..30 robots on the seed's network (complete, latencies "
        "uniform 1-10 ms, 1 % loss), the first assigned robot failing at 2 s; detector "
        "D = 300 ms, heartbeats every 100 ms"
    )
    strategy = generated_missions(ALL_COMPOSITIONS, min_robots=5, max_robots=30)
    stable = tally_summary("stable again", "not stable", "nobody assigned")
    return [
        property_claim(
            "F1",
            "cfopt's claim: after a robot fails, distributed GRAPE-S's surviving robots "
            "return to one belief whose partition is Nash stable for them",
            family,
            ("grape-s",),
            _stable_after("grape-s"),
            scope=Scope.SIMULATOR,
            network=SEED_NETWORK,
            strategy=strategy,
            summary=stable,
        ),
        property_claim(
            "F2",
            "cfopt's claim: GRAPE-S's survivors settle within D + P + (2 d_G + 3) clock "
            "periods (each stretched by the jitter and the largest latency) of a failure",
            family,
            ("grape-s",),
            f2,
            scope=Scope.SIMULATOR,
            network=SEED_NETWORK,
            strategy=strategy,
            summary=tally_summary("within the bound", "beyond the bound", "nobody assigned"),
        ),
        property_claim(
            "F3",
            "cfopt's claim: after a robot fails, distributed Pair-GRAPE-S's surviving robots "
            "return to one belief whose partition is Nash stable for them",
            family,
            ("pair-grape-s",),
            _stable_after("pair-grape-s"),
            scope=Scope.SIMULATOR,
            network=SEED_NETWORK,
            strategy=strategy,
            summary=stable,
        ),
    ]
