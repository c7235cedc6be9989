"""Missions that change during a simulated run: a timeline of events, a failure detector,
and the run scored over time against the optimum of the mission as it stands.

The timeline (``events=`` of :func:`heuristics.simulate`, ``--events FILE`` of ``cfopt
run --network``) is a ``cfopt.events/1`` JSON object::

    {"format": "cfopt.events/1", "detector": "300ms", "heartbeat": "100ms",
     "events": [{"at": "2s", "kind": "fail", "robot": "r3"},
                {"at": "3s", "kind": "join", "robot": "r7"},
                {"at": "3s", "kind": "task-arrives", "task": "t2"},
                {"at": "4s", "kind": "task-withdrawn", "task": "t1"},
                {"at": "5s", "kind": "utility", "task": "t0", "utility": 8.5}]}

Robots and tasks are the mission's, by id: a robot that joins is absent until it does,
a task that arrives is absent until it does.  ``fail`` is fail-stop: the robot stops
ticking, sending, relaying and hearing (its queued frames are dropped).

The failure detector
--------------------
Not an oracle: every present robot sends a heartbeat beacon (8 bytes, counted in the
transmissions and bytes; the network's latency and loss apply, the radio channel is not
occupied) every ``heartbeat`` (default 100 ms, from its clock's offset), and a robot
*presumes a neighbour failed* when, at one of its own beats, it has heard nothing from
it for more than ``detector`` (``D``, default 300 ms).  A neighbour presumed failed and
heard again is presumed alive again.  What the robots are told goes through the agent
API (:meth:`heuristics.agents.Agent.on_event`): :class:`~heuristics.agents.protocol.RobotFailed`
and ``RobotRecovered`` from the detector, ``RobotJoined`` to a robot that joins,
``MissionChanged`` to every present robot at a task event (an operator's announcement,
not carried by the network), ``NewsArrived`` when a belief newer than a stopped robot's
own is sent to it.  A stopped agent whose ``on_event`` returns ``True`` ticks again from
its robot's next tick.

How a protocol reacts is its own: :mod:`heuristics.simulate` says what the shipped
protocols do.

Scoring over time
-----------------
At time 0 and at every event the mission as it now stands -- present robots, present
tasks, current utilities -- is solved exactly (:func:`cfopt.exact.solve_exact`, the ILP).
Every ``sample`` (default 10 clock periods) the utility of what the present robots would
perform (their own beliefs' slots) is recorded against that optimum.  Per event the
report (:class:`EventOutcome`) gives the time to re-converge (from the event to the last
belief change before the next event or the end; ``None`` when the robots' beliefs do not
agree then), the transmissions and bytes spent until then, and the partition the robots
then hold with the surviving robots and present tasks, so that the verification layer
judges its stability on that sub-mission (:func:`proofs.claims_dynamic.survivors_stable`,
``proofs``' Nash checker: what ``cfopt run`` prints and the claims check).
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt import Mission, MissionError
from cfopt._jsonio import check_keys, expect_list, expect_object, read_json
from heuristics.agents.protocol import (
    MissionChanged,
    NewsArrived,
    RobotFailed,
    RobotJoined,
    RobotRecovered,
)
from heuristics.network import parse_duration
from heuristics.transport.driver import HOP, TICK, WAKE, pack_key

__all__ = [
    "BEAT",
    "EVENTS_FORMAT",
    "EVENT_KINDS",
    "SAMPLE",
    "STAND",
    "DynamicReport",
    "EventOutcome",
    "MissionEvent",
    "Timeline",
    "dynamic_class",
]

EVENTS_FORMAT = "cfopt.events/1"
#: The kinds of mission events.
EVENT_KINDS = ("fail", "join", "task-arrives", "task-withdrawn", "utility")
#: The dynamics' kernel events: a mission event, a robot's heartbeat, a utility sample.
STAND, BEAT, SAMPLE = 5, 6, 7
#: A heartbeat beacon's bytes.
HEARTBEAT_BYTES = 8
_ROBOT_KINDS = ("fail", "join")


@dataclass(frozen=True)
class MissionEvent:
    """One event of a timeline: at ``at_ns``, ``kind`` on robot or task index ``target``
    (``utility``: the task's new utility)."""

    at_ns: int
    kind: str
    target: int
    utility: float | None = None


@dataclass(frozen=True)
class Timeline:
    """A run's mission events, in time order, and its failure detector (module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> m = Mission.from_arrays(np.ones((3, 1), bool), [[1], [2]], [1.0, 2.0])
    >>> t = Timeline.from_dict({"events": [{"at": "1s", "kind": "fail", "robot": "r2"}]}, m)
    >>> t.events, t.detector_ns, t.heartbeat_ns
    ((MissionEvent(at_ns=1000000000, kind='fail', target=2, utility=None),), 300000000, 100000000)
    """

    events: tuple[MissionEvent, ...]
    detector_ns: int = 300_000_000
    heartbeat_ns: int = 100_000_000
    sample_ns: int | None = None

    @classmethod
    def from_dict(cls, data: Any, mission: Mission) -> Timeline:
        """Validate a ``cfopt.events/1`` object against ``mission``; errors name the key."""
        top = expect_object(data, "")
        check_keys(top, "", ("events",), ("format", "detector", "heartbeat", "sample"))
        if "format" in top and top["format"] != EVENTS_FORMAT:
            raise MissionError(f'format: must be "{EVENTS_FORMAT}", got {top["format"]!r}')
        times = {key: _duration(top[key], key) for key in ("detector", "heartbeat", "sample")
                 if key in top}  # fmt: skip
        if times.get("heartbeat", 1) == 0 or times.get("sample", 1) == 0:
            raise MissionError("heartbeat, sample: must be > 0")
        items = expect_list(top["events"], "events")
        events = [_event(item, f"events[{k}]", mission) for k, item in enumerate(items)]
        events.sort(key=lambda e: e.at_ns)
        _check_order(events, mission)
        return cls(
            tuple(events),
            times.get("detector", 300_000_000),
            times.get("heartbeat", 100_000_000),
            times.get("sample"),
        )

    @classmethod
    def read(cls, source: Any, mission: Mission) -> Timeline:
        """A timeline from a JSON file's path (errors start with its name), a dict, or a
        :class:`Timeline` as it is."""
        if isinstance(source, Timeline):
            return source
        if isinstance(source, dict):
            return cls.from_dict(source, mission)
        if not isinstance(source, str | os.PathLike):
            raise MissionError(f"events: must be a timeline, a dict or a path, got {source!r}")
        data, name = read_json(source, stdin_hint=False)
        try:
            return cls.from_dict(data, mission)
        except MissionError as exc:
            raise exc.prefixed(name) from None

    def absent_robots(self, n: int) -> npt.NDArray[np.bool_]:
        """The robots absent at the start (those that join later)."""
        out = np.zeros(n, dtype=bool)
        out[[e.target for e in self.events if e.kind == "join"]] = True
        return out

    def absent_tasks(self, m: int) -> npt.NDArray[np.bool_]:
        """The tasks absent at the start (those that arrive later)."""
        out = np.zeros(m, dtype=bool)
        out[[e.target for e in self.events if e.kind == "task-arrives"]] = True
        return out


def _duration(value: Any, place: str) -> int:
    if not isinstance(value, str):
        raise MissionError(f'{place}: must be a duration with a unit, e.g. "300ms", got {value!r}')
    try:
        return parse_duration(value)
    except MissionError as exc:
        raise MissionError(f"{place}: {exc}") from None


def _event(item: Any, place: str, mission: Mission) -> MissionEvent:
    obj = expect_object(item, place)
    kind = obj.get("kind")
    if kind not in EVENT_KINDS:
        raise MissionError(f"{place}.kind: must be one of {', '.join(EVENT_KINDS)}, got {kind!r}")
    what = "robot" if kind in _ROBOT_KINDS else "task"
    extra = ("utility",) if kind == "utility" else ()
    check_keys(obj, place, ("at", "kind", what, *extra), ())
    ids = mission.robot_ids if what == "robot" else mission.task_ids
    if obj[what] not in ids:
        raise MissionError(f"{place}.{what}: no {what} {obj[what]!r} in the mission")
    utility = None
    if kind == "utility":
        utility = obj["utility"]
        if isinstance(utility, bool) or not isinstance(utility, int | float):
            raise MissionError(f"{place}.utility: must be a number, got {utility!r}")
        if not math.isfinite(utility) or utility <= 0:
            raise MissionError(f"{place}.utility: must be a finite number > 0, got {utility!r}")
        utility = float(utility)
    at = _duration(obj["at"], f"{place}.at")
    return MissionEvent(at, kind, ids.index(obj[what]), utility)


def _check_order(events: list[MissionEvent], mission: Mission) -> None:
    """Each robot joins at most once and fails at most once, after joining; each task
    arrives at most once, before it is withdrawn."""
    seen: dict[tuple[str, int], int] = {}
    for event in events:
        mark = (event.kind, event.target)
        if event.kind != "utility" and mark in seen:
            raise MissionError(f"events: {event.kind} of the same target twice ({event.target})")
        seen[mark] = event.at_ns
    for (kind, target), at in seen.items():
        before = {"fail": "join", "task-withdrawn": "task-arrives"}.get(kind)
        if before and (before, target) in seen and seen[(before, target)] > at:
            raise MissionError(f"events: {kind} of {target} comes before its {before}")


# ------------------------------------------------------------------------ reports
@dataclass(frozen=True)
class EventOutcome:
    """What followed one event (frozen; module docstring, *Scoring over time*).

    Attributes
    ----------
    at_seconds : float
    kind : str
    target : str
        The robot's or the task's id.
    optimum : float
        The ILP optimum of the mission as it stands after the event.
    utility_after : float
        The utility of what the present robots hold at the end of the event's window.
    reconverge_seconds : float or None
        From the event to the last belief change of its window (``None``: the beliefs do
        not agree at the window's end).
    transmissions, bytes : int
        Spent during the window (heartbeats included).
    partition : tuple of int
        Every robot's slot (``task * S + service``, -1: none or absent) at the window's end.
    robots, tasks : tuple of int
        The robots and tasks present then.
    """

    at_seconds: float
    kind: str
    target: str
    optimum: float
    utility_after: float
    reconverge_seconds: float | None
    transmissions: int
    bytes: int
    partition: tuple[int, ...]
    robots: tuple[int, ...]
    tasks: tuple[int, ...]


@dataclass(frozen=True)
class DynamicReport:
    """A run with mission events (frozen; ``run.network.dynamics``).

    Attributes
    ----------
    detector_seconds, heartbeat_seconds : float
    events : tuple of EventOutcome
    samples : tuple of (float, float, float)
        ``(time_s, utility, optimum)`` over simulated time (the optimum a step line).
    initial_optimum : float
    """

    detector_seconds: float
    heartbeat_seconds: float
    events: tuple[EventOutcome, ...]
    samples: tuple[tuple[float, float, float], ...]
    initial_optimum: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        out = asdict(self)
        out["samples"] = [list(s) for s in self.samples]
        return out


# ------------------------------------------------------------------ the dynamics
class _Stand:
    """The mission as it stands: present robots and tasks, current utilities."""

    def __init__(self, mission: Mission, timeline: Timeline) -> None:
        self.mission = mission
        self.present = ~timeline.absent_robots(mission.n_robots)
        self.failed = np.zeros(mission.n_robots, dtype=bool)
        self.active = ~timeline.absent_tasks(mission.n_tasks)
        self.utilities = mission.utilities.astype(np.float64).copy()

    def current(self) -> Mission:
        """The mission with the current utilities (every task)."""
        if np.array_equal(self.utilities, self.mission.utilities):
            return self.mission
        m = self.mission
        return Mission.from_arrays(
            m.capabilities,
            m.requirements,
            self.utilities,
            services=m.services,
            robot_ids=m.robot_ids,
            task_ids=m.task_ids,
        )

    def sub(self) -> tuple[Mission | None, npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """The sub-mission of present robots and tasks (``None``: nothing to do), with
        the robots' and tasks' indices in the whole mission."""
        robots, tasks = np.flatnonzero(self.present), np.flatnonzero(self.active)
        if robots.size == 0 or tasks.size == 0:
            return None, robots, tasks
        m = self.mission
        sub = Mission.from_arrays(
            m.capabilities[robots], m.requirements[tasks], self.utilities[tasks],
            services=m.services,
        )  # fmt: skip
        return sub, robots, tasks

    def optimum(self) -> float:
        from cfopt.exact import solve_exact

        sub, _, _ = self.sub()
        return 0.0 if sub is None else float(solve_exact(sub).utility)

    def utility(self, slots: npt.NDArray[np.int64]) -> float:
        """The utility of ``slots`` (every robot's; absent robots' ignored) now."""
        m = self.mission
        S = max(m.n_services, 1)
        placed = slots[self.present & (slots >= 0)]
        counts = np.bincount(placed, minlength=m.n_tasks * S).reshape(m.n_tasks, S)
        done = (counts >= m.requirements).all(axis=1) & self.active
        return math.fsum(self.utilities[done].tolist())


def dynamic_class(base: type) -> type:
    """``base`` (the simulator or the radio simulator) with mission events."""
    return type(f"Dynamic{base.__name__}", (Dynamics, base), {})


class Dynamics:
    """The simulator's mission events (a mixin before a simulator class; module
    docstring).  ``setup(timeline)`` after the simulator's own construction."""

    # what the simulator provides
    n: int
    mission: Mission
    agents: dict[int, Any]
    stopped: npt.NDArray[np.bool_]
    handlers: tuple[Any, ...]

    def setup(self, timeline: Timeline) -> None:
        """Install the timeline: absent robots, heartbeats, samples and the events."""
        self.timeline = timeline
        self.stand = _Stand(self.mission, timeline)
        n = self.n
        self.heard = np.full((n, n), -1, dtype=np.int64)  # [hearer, robot]: last heard
        self.suspected = np.zeros((n, n), dtype=bool)
        self.clocked = np.array([self.agents[i].clocked for i in range(n)], dtype=bool)
        self.joiners = timeline.absent_robots(n)  # heard for the first time: a join
        handlers = list(self.handlers) + [None] * (SAMPLE + 1 - len(self.handlers))
        handlers[TICK], handlers[HOP], handlers[WAKE] = (
            self._dyn_tick,
            self._dyn_hop,
            self._dyn_wake,
        )
        handlers[STAND], handlers[BEAT], handlers[SAMPLE] = (
            self._on_stand,
            self._on_beat,
            self._on_sample,
        )
        self.handlers = tuple(handlers)
        self.outcomes: list[EventOutcome] = []
        self.window: dict[str, Any] | None = None
        self.optimum = self.stand.optimum()
        self.initial_optimum = self.optimum
        self.samples: list[tuple[float, float, float]] = []
        self.sample_ns = timeline.sample_ns or 10 * self.clocks.period_ns  # type: ignore[attr-defined]
        self.last_change = 0
        last = timeline.events[-1].at_ns if timeline.events else 0
        self.horizon = last + 3 * (timeline.detector_ns + timeline.heartbeat_ns)

    def run(self) -> None:
        """The kernel, with absent robots' first ticks skipped, the initial announcement,
        the beats, the samples and the events pushed first."""
        if not self.stand.active.all():
            self._announce(0, ())
        for i in range(self.n):
            first = int(self.clocks.tick_time(i, 0))  # type: ignore[attr-defined]
            self._push(first, BEAT, i)  # type: ignore[attr-defined]
        for index, event in enumerate(self.timeline.events):
            self._push(event.at_ns, STAND, index)  # type: ignore[attr-defined]
        self._push(0, SAMPLE, None)  # type: ignore[attr-defined]
        super().run()  # type: ignore[misc]
        self._close_window(self.end)  # type: ignore[attr-defined]
        self._sample(self.end)  # type: ignore[attr-defined]

    def ends(self) -> dict[int, Any]:
        """Every robot's end; an absent robot (failed, or never joined) performs nothing."""
        out = super().ends()  # type: ignore[misc]
        for i in np.flatnonzero(~self.stand.present).tolist():
            out[i] = dataclasses.replace(out[i], slot=-1)
        return out

    # ------------------------------------------------------------ the kernel's
    def _alive(self, t: int) -> bool:
        """Whether the beats and samples go on: while a present clocked robot runs, and
        until ``3 (D + heartbeat)`` after the last event (so that a failure is detected);
        then they stop and the run can end."""
        running = self.stand.present & self.clocked & ~self.stopped
        return t < self.horizon or bool(running.any())

    def _dyn_tick(self, i: int, t: int) -> None:
        if self.stand.present[i]:
            self._on_tick(i, t)  # type: ignore[attr-defined]

    def _dyn_hop(self, hop: tuple[int, Any, int, int], t: int) -> None:
        if self.stand.present[hop[3]]:
            self._on_hop(hop, t)  # type: ignore[attr-defined]

    def _dyn_wake(self, i: int, t: int) -> None:
        if self.stand.present[i]:
            self._on_wake(i, t)  # type: ignore[attr-defined]

    def _observe(self, i: int, key: Any, now: int) -> None:
        super()._observe(i, key, now)  # type: ignore[misc]
        self.last_change = now

    def _can_change(self, belief: Any, receivers: npt.NDArray[np.int64]) -> Any:
        """Present receivers holding an older key; stopped ones are told the news."""
        r, tid = pack_key(belief.key)
        kr, kt = self.key_r[receivers], self.key_tid[receivers]  # type: ignore[attr-defined]
        newer = self.stand.present[receivers] & ((r > kr) | ((r == kr) & (tid > kt)))
        for j in receivers[newer & self.stopped[receivers]].tolist():
            self._tell(j, NewsArrived(belief.key), self.now)  # type: ignore[attr-defined]
        return newer & ~self.stopped[receivers]

    # ------------------------------------------------------------ telling agents
    def _tell(self, i: int, event: Any, now: int) -> None:
        agent = self.agents[i]
        before = agent.belief.key if agent.clocked else None
        again = agent.on_event(now, event)
        if agent.clocked and agent.belief.key != before:
            self._observe(i, agent.belief.key, now)
        if again and self.stopped[i] and agent.clocked and not agent.stopped:
            self.stopped[i] = False
            k, at = self.clocks.next_tick(i, now + 1)  # type: ignore[attr-defined]
            self.tick_index[i] = k  # type: ignore[attr-defined]
            self._push(at, TICK, i)  # type: ignore[attr-defined]

    def _announce(self, now: int, withdrawn: tuple[int, ...]) -> None:
        event = MissionChanged(self.stand.current(), self.stand.active.copy(), withdrawn)
        for i in np.flatnonzero(self.stand.present).tolist():
            self._tell(i, event, now)

    # ------------------------------------------------------------ the events
    def _on_stand(self, index: int, t: int) -> None:
        self._close_window(t)
        event = self.timeline.events[index]
        stand = self.stand
        if event.kind == "fail":
            self._fail(event.target)
        elif event.kind == "join":
            self._join(event.target, t)
        elif event.kind == "task-arrives":
            stand.active[event.target] = True
        elif event.kind == "task-withdrawn":
            stand.active[event.target] = False
        else:
            stand.utilities[event.target] = event.utility
        if event.kind not in _ROBOT_KINDS:
            withdrawn = (event.target,) if event.kind == "task-withdrawn" else ()
            self._announce(t, withdrawn)
        self.optimum = stand.optimum()
        self._sample(t)
        self.window = {
            "event": event,
            "start": t,
            "optimum": self.optimum,
            "transmissions": self.transmissions,  # type: ignore[attr-defined]
            "bytes": self.bytes,  # type: ignore[attr-defined]
        }
        self.last_change = t

    def _fail(self, robot: int) -> None:
        self.stand.present[robot] = False
        self.stand.failed[robot] = True
        self.stopped[robot] = True
        queues = getattr(self, "queues", None)
        if queues is not None and robot in queues:  # its frames never go on the air
            queues[robot].clear()
            self.waiting[robot] = False  # type: ignore[attr-defined]

    def _join(self, robot: int, t: int) -> None:
        self.stand.present[robot] = True
        self._tell(robot, RobotJoined(robot), t)
        k, at = self.clocks.next_tick(robot, t)  # type: ignore[attr-defined]
        self.tick_index[robot] = k  # type: ignore[attr-defined]
        self.stopped[robot] = False
        self._push(at, TICK, robot)  # type: ignore[attr-defined]
        self._push(at, BEAT, robot)  # type: ignore[attr-defined]

    def _close_window(self, t: int) -> None:
        window, self.window = self.window, None
        if window is None:
            return
        event = window["event"]
        slots = self._slots()
        keys = {a.belief.key for i, a in self.agents.items() if self.stand.present[i] and a.clocked}
        settled = self.last_change - window["start"]
        ids = self.mission.robot_ids if event.kind in _ROBOT_KINDS else self.mission.task_ids
        self.outcomes.append(
            EventOutcome(
                at_seconds=window["start"] / 1e9,
                kind=event.kind,
                target=ids[event.target],
                optimum=window["optimum"],
                utility_after=self.stand.utility(slots),
                reconverge_seconds=max(settled, 0) / 1e9 if len(keys) <= 1 else None,
                transmissions=self.transmissions - window["transmissions"],  # type: ignore[attr-defined]
                bytes=self.bytes - window["bytes"],  # type: ignore[attr-defined]
                partition=tuple(slots.tolist()),
                robots=tuple(np.flatnonzero(self.stand.present).tolist()),
                tasks=tuple(np.flatnonzero(self.stand.active).tolist()),
            )
        )

    # ------------------------------------------------------------ the detector
    def _on_beat(self, i: int, t: int) -> None:
        if not self.stand.present[i]:
            return
        receivers = self.network.neighbours(i)  # type: ignore[attr-defined]
        if receivers.size:
            delays, lost = self._transmit(i, receivers, t)  # type: ignore[attr-defined]
            self.transmissions += 1  # type: ignore[attr-defined]
            self.bytes += HEARTBEAT_BYTES  # type: ignore[attr-defined]
            self.losses += int(lost.sum())  # type: ignore[attr-defined]
            got = ~lost & self.stand.present[receivers]
            heard = receivers[got]
            self.receptions += heard.size  # type: ignore[attr-defined]
            if self.joiners[i]:
                for j in heard[self.heard[heard, i] < 0].tolist():
                    self._tell(j, RobotJoined(i), t)
            self.heard[heard, i] = np.maximum(self.heard[heard, i], t + delays[got])
        self._detect(i, receivers, t)
        if self._alive(t):
            self._push(t + self.timeline.heartbeat_ns, BEAT, i)  # type: ignore[attr-defined]

    def _detect(self, i: int, neighbours: npt.NDArray[np.int64], t: int) -> None:
        last = self.heard[i, neighbours]
        known = (last >= 0) & (last <= t)
        silent = known & (t - last > self.timeline.detector_ns)
        suspected = self.suspected[i, neighbours]
        for f in neighbours[silent & ~suspected].tolist():
            self.suspected[i, f] = True
            self._tell(i, RobotFailed(f), t)
        for f in neighbours[~silent & known & suspected].tolist():
            self.suspected[i, f] = False
            self._tell(i, RobotRecovered(f), t)

    # ------------------------------------------------------------ scoring
    def _slots(self) -> npt.NDArray[np.int64]:
        return np.array(
            [
                self.agents[i].performed_slot() if self.stand.present[i] else -1
                for i in range(self.n)
            ],
            dtype=np.int64,
        )

    def _sample(self, t: int) -> None:
        self.samples.append((t / 1e9, self.stand.utility(self._slots()), self.optimum))

    def _on_sample(self, _: Any, t: int) -> None:
        self._sample(t)
        if self._alive(t):
            self._push(t + self.sample_ns, SAMPLE, None)  # type: ignore[attr-defined]

    def dynamic_report(self) -> DynamicReport:
        """The run's :class:`DynamicReport` (after :meth:`run`)."""
        return DynamicReport(
            detector_seconds=self.timeline.detector_ns / 1e9,
            heartbeat_seconds=self.timeline.heartbeat_ns / 1e9,
            events=tuple(self.outcomes),
            samples=tuple(self.samples),
            initial_optimum=self.initial_optimum,
        )


def plot_utility(report: DynamicReport, path: str | os.PathLike[str], title: str = "") -> None:
    """Write a PNG of the utility the robots hold over simulated time, the optimum of the
    mission as it stands as a step line and the events as vertical marks (matplotlib,
    Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = [s[0] for s in report.samples]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(times, [s[1] for s in report.samples], label="utility held by the robots")
    ax.step(times, [s[2] for s in report.samples], where="post", label="optimum (ILP)")
    for event in report.events:
        ax.axvline(event.at_seconds, color="grey", linestyle=":", linewidth=1)
        ax.annotate(f"{event.kind} {event.target}", (event.at_seconds, 0), fontsize=7,
                    rotation=90, va="bottom")  # fmt: skip
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("utility")
    ax.set_title(title or "utility over time")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
