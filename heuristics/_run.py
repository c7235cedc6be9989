"""The frozen result every heuristic returns, and the historical (unicast) message count.

The communication models themselves (broadcast or unicast medium, full or compact belief
encoding) are in :mod:`heuristics.communication`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from enum import Enum
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Assignment, Mission, MissionError
from cfopt.checks import (
    is_whole,
    require_assignment,
    require_bool,
    require_int,
    require_number,
    require_seed,
    require_text,
    shown,
)
from cfopt.errors import MissionTypeError
from heuristics.communication import (
    HEADER_BYTES,
    ROBOT_ENTRY_BYTES,
    CommModel,
    Table,
    table_cost,
)

__all__ = [
    "HEADER_BYTES",
    "NO_DEADLINE",
    "ORDERS",
    "ROBOT_ENTRY_BYTES",
    "Deadline",
    "Run",
    "RunStatus",
    "belief_bytes",
    "broadcast_cost",
    "check_order",
    "seed_label",
]

#: Robot orders the GRAPE-S engines accept.
ORDERS = ("index", "random")


def belief_bytes(n_robots: int) -> int:
    """Size of one ``(r, time, Pi)`` message in the ``full`` encoding: ``16 + 4 n`` bytes
    (:func:`heuristics.communication.belief_size` gives every encoding).

    >>> belief_bytes(100)
    416
    """
    return HEADER_BYTES + ROBOT_ENTRY_BYTES * require_int("n_robots", n_robots, minimum=0)


def broadcast_cost(n_robots: int, rounds: int) -> tuple[int, int]:
    """Messages and bytes of ``rounds`` fully connected belief rounds, counted point to
    point (the ``unicast`` medium, ``full`` encoding of :mod:`heuristics.communication`).

    Every robot sends its belief to each of its ``n - 1`` neighbours every round
    (the seed's fully connected GRAPE-S round), so a round costs ``n (n - 1)`` messages of
    :func:`belief_bytes` bytes each.  Exact Python integers.  The engines' default is
    now the ``broadcast`` medium (``n`` transmissions a round):
    ``CommModel().rounds_cost(n, rounds, belief_bytes(n))``.

    >>> broadcast_cost(100, 101)
    (999900, 415958400)
    """
    size = belief_bytes(n_robots)
    rounds = require_int("rounds", rounds, minimum=0)
    return CommModel("unicast", "full").rounds_cost(int(n_robots), rounds, size)


def check_order(order: str) -> str:
    """Validate an ``order`` argument."""
    if order not in ORDERS:
        raise MissionError(f"order: must be one of {', '.join(ORDERS)}, got {order!r}")
    return order


def seed_label(seed: Any) -> int | None:
    """The seed as recorded in a :class:`Run`: an int, or ``None`` (fresh or a Generator)."""
    if is_whole(seed):
        return int(seed)
    return None


def _trajectory(value: Any) -> npt.NDArray[np.int64]:
    """The trajectory as a read-only ``(k, 4)`` int64 copy."""
    try:
        traj = np.array(value, dtype=np.int64, copy=True).reshape(-1, 4)
    except (TypeError, ValueError, OverflowError):
        raise MissionError(
            f"trajectory: must be rows of 4 whole numbers (iteration, robot, task, service), "
            f"got {shown(value)}"
        ) from None
    traj.setflags(write=False)
    return traj


def _rows(name: str, value: Any, width: int) -> tuple[tuple[Any, ...], ...]:
    """``value`` (a tuple or list of rows of ``width`` items, each led by a name) as a
    tuple of tuples."""
    if not isinstance(value, tuple | list) or not all(
        isinstance(row, tuple | list) and len(row) == width and isinstance(row[0], str)
        for row in value
    ):
        raise MissionTypeError(
            f"{name}: must be a tuple of {width}-tuples led by a name, got {shown(value)}"
        )
    return tuple(map(tuple, value))


class RunStatus(Enum):
    """How a run ended: ``COMPLETE`` (the algorithm's own end) or ``TIME_LIMIT`` (cut
    at its ``time_limit``, with the partition reached so far)."""

    COMPLETE = "complete"
    TIME_LIMIT = "time_limit"


class Deadline:
    """A centralized engine's time limit: ``seconds`` of wall-clock time from
    ``started`` (a ``time.perf_counter()`` reading), or none.

    :meth:`reached` reads the clock (about 0.1 microsecond) only when there is a limit,
    so the engines call it once per round; once reached it stays reached.

    >>> Deadline(None).reached(), Deadline(1e-9, started=0.0).reached()
    (False, True)
    >>> Deadline(0)
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: time_limit: must be a number of seconds > 0 or None, got 0
    """

    def __init__(self, seconds: float | None, *, started: float | None = None) -> None:
        if seconds is not None:
            seconds = require_number(
                "time_limit", seconds, above=0, what="a number of seconds", or_none=True
            )
        self.seconds = None if seconds is None else float(seconds)
        begin = time.perf_counter() if started is None else started
        self._end = math.inf if seconds is None else begin + float(seconds)
        self._reached = False

    def reached(self) -> bool:
        """Whether the time limit has passed (always ``False`` without a limit)."""
        if self._end == math.inf:
            return False
        if not self._reached:
            self._reached = time.perf_counter() >= self._end
        return self._reached

    @property
    def status(self) -> RunStatus:
        """``TIME_LIMIT`` once :meth:`reached` said so, else ``COMPLETE``."""
        return RunStatus.TIME_LIMIT if self._reached else RunStatus.COMPLETE


#: The deadline of a run without a time limit.
NO_DEADLINE = Deadline(None)


def _status(value: Any) -> RunStatus:
    """A :class:`RunStatus`, or its value (``"complete"``, ``"time_limit"``)."""
    if isinstance(value, RunStatus):
        return value
    if isinstance(value, str):
        values = [status.value for status in RunStatus]
        if value in values:
            return RunStatus(value)
        raise MissionError(f"status: must be one of {', '.join(values)}, got {shown(value)}")
    raise MissionTypeError(f"status: must be a heuristics.RunStatus, got {shown(value)}")


def _empty_trajectory() -> npt.NDArray[np.int64]:
    out = np.zeros((0, 4), dtype=np.int64)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Run:
    """One heuristic run: the assignment and what it cost (frozen).

    Attributes
    ----------
    algorithm : str
        Registry name, e.g. ``"grape-s"``.
    assignment : cfopt.Assignment
        The final partition.
    iterations : int
        Rounds in which the partition changed (GRAPE-S moves plus pairwise exchanges).
    rounds : int
        Communication rounds, quiet rounds included.
    messages, bytes : int
        Messages and their total size under the run's communication model
        (:mod:`heuristics.communication`; ``options`` records ``medium`` and ``encoding``
        for the engines that take them, default broadcast/full: one transmission per
        broadcast), as the algorithm's docstring documents.
    work : int
        Counted computation in the algorithm's documented unit (for GRAPE-S: slot
        examinations, see :func:`heuristics.grape_s`).
    seconds : float
        Wall-clock time of the whole call.
    seed : int or None
        The integer seed given, ``None`` when none (or a Generator) was.
    exchanges : int
        Pairwise exchanges (Pair-GRAPE-S; 0 for the others).
    pairwise_step_ran : bool
        Whether Pair-GRAPE-S's pairwise step was needed (a short slot and an unassigned
        robot after its GRAPE-S phase).
    trajectory : ndarray of int64, shape (k, 4)
        The applied moves in order, one row ``(iteration, robot, task, service)`` per robot
        that changed slot (``task = service = -1``: became unassigned).  A pairwise exchange
        is two rows with the same iteration.
    options : tuple of (str, object)
        The options the run used (``order``, ``capped``, ``reward``...).
    network : heuristics.simulate.NetworkReport or None
        For a distributed run: the network's figures (time to termination and to
        convergence, transmissions, receptions, losses, bytes, whether the run converged,
        whether the robots' beliefs agree, whether it was cut); ``None`` for the
        centralized engines.
    communication : tuple of (str, str, int, int)
        The centralized engines' ``(medium, encoding, messages, bytes)`` under every model
        of :data:`heuristics.communication.MODELS` (broadcast/full, broadcast/compact,
        unicast/full, unicast/compact), so that models compare without running again;
        ``messages`` and ``bytes`` are the row of the run's own model.  Empty for the
        runs that do not count by model (distributed runs, which count real payloads).
    status : RunStatus
        ``COMPLETE``, or ``TIME_LIMIT`` when the engine was cut at its ``time_limit``:
        then the assignment is the partition reached so far and the counts are those of
        the rounds run.
    counted : bool, default True
        Whether ``iterations``, ``rounds``, ``messages``, ``bytes``, ``work``,
        ``exchanges`` and ``pairwise_step_ran`` are the algorithm's own counts.  ``False``
        for an algorithm that returned only an assignment (:class:`heuristics.AlgorithmSpec`
        wraps it with its wall-clock time): those fields are then 0 here and *not
        reported* -- ``None`` in :meth:`to_dict` and in stored trials.

    Notes
    -----
    Two runs compare equal when every field does, ``seconds`` included; compare
    ``run.replace_seconds(0.0)`` to ignore timing.
    """

    algorithm: str
    assignment: Assignment
    iterations: int
    rounds: int
    messages: int
    bytes: int
    work: int
    seconds: float
    seed: int | None
    exchanges: int = 0
    pairwise_step_ran: bool = False
    trajectory: npt.NDArray[np.int64] = field(default_factory=_empty_trajectory)
    options: tuple[tuple[str, Any], ...] = ()
    network: Any = None
    communication: Table = ()
    status: RunStatus = RunStatus.COMPLETE
    counted: bool = True

    def __post_init__(self) -> None:
        require_text("algorithm", self.algorithm)
        require_assignment(self.assignment)
        for name in ("iterations", "rounds", "messages", "bytes", "work", "exchanges"):
            require_int(name, getattr(self, name), minimum=0)
        require_number("seconds", self.seconds, minimum=0, what="a number of seconds")
        require_seed("seed", self.seed, generator=False)
        require_bool("pairwise_step_ran", self.pairwise_step_ran)
        require_bool("counted", self.counted)
        object.__setattr__(self, "trajectory", _trajectory(self.trajectory))
        object.__setattr__(self, "options", _rows("options", self.options, 2))
        object.__setattr__(self, "communication", _rows("communication", self.communication, 4))
        object.__setattr__(self, "status", _status(self.status))

    def communication_cost(
        self, medium: str = "broadcast", encoding: str = "full"
    ) -> tuple[int, int]:
        """``(messages, bytes)`` of this run under another model, from :attr:`communication`
        (:class:`cfopt.MissionError` when the run has no such table)."""
        return table_cost(self.communication, CommModel(medium, encoding))

    def replace_seconds(self, seconds: float) -> Run:
        """A copy with another ``seconds`` (to compare runs without their timing)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values["seconds"] = seconds
        return Run(**values)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Run):
            return NotImplemented
        for f in fields(self):
            mine, theirs = getattr(self, f.name), getattr(other, f.name)
            if isinstance(mine, np.ndarray):
                if not np.array_equal(mine, theirs):
                    return False
            elif mine != theirs:
                return False
        return True

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"<Run {self.algorithm}: {self.assignment.n_assigned} of "
            f"{self.assignment.task.size} assigned, {self.iterations} iterations, "
            f"{self.rounds} rounds, {self.seconds:.3g} s>"
        )

    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """The ``run`` JSON object that ``cfopt run --json`` prints, without the stability
        verdicts: the keys below (``status``: ``"complete"`` or ``"time_limit"``), plus
        ``network`` for a distributed run and ``communication`` (one object per model)
        when the run counted by model.  A run that did not count (``counted`` false)
        has ``None`` (not reported) for ``iterations``, ``rounds``, ``messages``,
        ``bytes``, ``work``, ``exchanges`` and ``pairwise_step_ran``.

        ``nash_stable`` and ``pairwise_stable`` are added by the caller from ``proofs``.
        """
        a = self.assignment

        def count(value: Any) -> Any:
            return value if self.counted else None

        return {
            "algorithm": self.algorithm,
            "status": self.status.value,
            "seed": self.seed,
            "utility": a.utility(mission),
            "total_utility": mission.total_utility,
            "percent_utility": a.percent_utility(mission),
            "iterations": count(self.iterations),
            "rounds": count(self.rounds),
            "messages": count(self.messages),
            "bytes": count(self.bytes),
            "work": count(self.work),
            "seconds": self.seconds,
            "exchanges": count(self.exchanges),
            "pairwise_step_ran": count(self.pairwise_step_ran),
            "options": dict(self.options),
            **({} if self.network is None else {"network": self.network.to_dict()}),
            **(
                {}
                if not self.communication
                else {
                    "communication": [
                        {"medium": md, "encoding": en, "messages": ms, "bytes": by}
                        for md, en, ms, by in self.communication
                    ]
                }
            ),
            "assignment": a.to_dict(mission)["assignment"],
        }


def moves_run(
    algorithm: str,
    task: npt.NDArray[np.int64],
    service: npt.NDArray[np.int64],
    moves: list[tuple[int, int, int, int]],
    *,
    started: float,
    seed: Any,
    **figures: Any,
) -> Run:
    """The :class:`Run` of an engine that moved robots on a shared partition: the final
    ``task``/``service`` arrays, the applied ``moves`` as trajectory rows, the wall-clock
    time since ``started`` (a ``time.perf_counter()`` reading), the seed's label and the
    remaining fields (``iterations``, ``rounds``, ``messages``...) as given."""
    return Run(
        algorithm=algorithm,
        assignment=Assignment(task=task, service=service),
        seconds=time.perf_counter() - started,
        seed=seed_label(seed),
        trajectory=np.array(moves, dtype=np.int64).reshape(-1, 4),
        **figures,
    )
