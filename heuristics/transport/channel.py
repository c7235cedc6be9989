"""A radio channel of finite capacity for the simulator (the ``bitrate=`` network tokens).

Without ``bitrate`` the simulator's medium has no capacity: any number of transmissions
fit at once.  With ``bitrate=RATE`` every transmission occupies the air, and the run is
simulated by :class:`RadioSimulator` under this MAC model:

Frames
    A broadcast belief is one frame of its encoded size (``encoding=full|compact``;
    ``medium=unicast``: one frame of ``degree x size``, the copies back to back); a hop
    of a direct message is one frame of the message's size.  A frame occupies the air
    for ``ceil(bytes x 8 / bitrate)`` ns.

A FIFO per sender
    Each robot sends its frames one at a time, in the order it made them.  A frame
    made while ``queue`` frames already wait (the one on the air not counted) is
    dropped at the sender: an *overflow* (tail drop).

Carrier sensing
    ``channel=shared``: a robot senses the channel busy while it or any robot in range
    of it (a neighbour) is on the air; the head of its queue goes on the air as soon as
    the channel is idle as it senses it.  Sensing is instantaneous (no propagation
    delay), so two robots in range of each other never overlap; several robots that find
    the channel idle at one instant are served in the order they started to wait (an
    ideal backoff).  ``channel=per-link``: every link has a channel of its own and only
    the sender's own FIFO serialises its frames (no sensing, no collisions).

Collisions
    ``channel=shared``: a reception is lost when two frames audible at the receiver
    overlap in time -- both frames, at that receiver (hidden terminals: senders out of
    range of each other with a common neighbour).  A collision is a loss; the network's
    own latency and loss then apply to what survives, the latency counted from the
    frame's end.

The report (:class:`ChannelReport`, ``run.network.channel``) gives the frames sent, their
airtime, the channel's utilisation (the fraction of the run during which a robot senses
the channel busy: the mean over robots and the busiest robot), the queueing delay (from a
frame's making to its start on the air: mean and maximum), the overflows and the
collisions.  ``bytes`` and ``transmissions`` count what went on the air.
"""

from __future__ import annotations

from collections import deque
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from heuristics.network import NetworkSpec, format_bitrate
from heuristics.transport.driver import HOP
from heuristics.transport.simulator import Simulator

__all__ = ["DONE", "ChannelReport", "Frame", "RadioSimulator", "airtime_ns"]

#: The channel's event: a frame ends.
DONE = 4


def airtime_ns(size: int, bitrate: int) -> int:
    """The nanoseconds a frame of ``size`` bytes occupies a channel of ``bitrate`` bit/s.

    >>> airtime_ns(2016, 10_000_000), airtime_ns(1, 3)   # 1.6128 ms; ceil(8e9 / 3)
    (1612800, 2666666667)
    """
    return -(-size * 8 * 10**9 // bitrate)


@dataclass(frozen=True)
class ChannelReport:
    """What the radio channel did during a run (frozen; ``run.network.channel``).

    Attributes
    ----------
    model : str
        ``shared`` or ``per-link``.
    bitrate : str
        The channel's capacity (``"2Mbit/s"``).
    queue : int
        Each sender's queue bound (frames waiting).
    frames : int
        Frames that went on the air.
    airtime_seconds : float
        Their total airtime.
    utilisation, peak_utilisation : float
        The fraction of the run during which a robot senses the channel busy (its own
        frames and, when shared, its neighbours'): the mean over robots, and the largest.
    queueing_mean_seconds, queueing_max_seconds : float
        Delay from a frame's making to its start on the air.
    overflows : int
        Frames dropped at a full queue.
    collisions : int
        Receptions lost to overlapping frames (counted among the network's losses).
    """

    model: str
    bitrate: str
    queue: int
    frames: int
    airtime_seconds: float
    utilisation: float
    peak_utilisation: float
    queueing_mean_seconds: float
    queueing_max_seconds: float
    overflows: int
    collisions: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return asdict(self)


class Frame:
    """One frame waiting for or on the air: who sends it, its size and airtime, when it
    was made, its receivers, and what it carries (a belief, or a direct message's hop
    ``(dest, message, size, next)``)."""

    __slots__ = ("airtime", "belief", "collided", "hop", "made", "receivers", "sender", "size")

    def __init__(
        self,
        sender: int,
        size: int,
        airtime: int,
        made: int,
        receivers: npt.NDArray[np.int64],
        belief: Any = None,
        hop: tuple[int, Any, int, int] | None = None,
    ) -> None:
        self.sender, self.size, self.airtime, self.made = sender, size, airtime, made
        self.receivers, self.belief, self.hop = receivers, belief, hop
        self.collided: set[int] = set()


class RadioSimulator(Simulator):
    """The simulator with a channel of finite capacity (module docstring); chosen by
    :func:`heuristics.transport.simulator.simulate` when the spec has a ``bitrate``."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        spec: NetworkSpec = self.spec
        n = self.n
        self.bitrate = int(spec.bitrate or 0)
        self.shared_channel = spec.channel == "shared"
        self.queue_bound = spec.queue
        self.queues: dict[int, deque[Frame]] = {}
        self.on_air: dict[int, Frame] = {}  # sender -> its frame on the air
        self.waiting = np.zeros(n, dtype=bool)  # its queue's head waits for the channel
        self.wait_order = np.zeros(n, dtype=np.int64)  # when it started to (a counter)
        self.waits = 0
        self.busy_until = np.zeros(n, dtype=np.int64)  # the channel as each robot senses it
        self.heard_until = np.zeros(n, dtype=np.int64)  # the latest audible frame's end
        self.heard_sender = np.full(n, -1, dtype=np.int64)  # and its sender
        #: Collisions need robots out of range of each other: none on a complete network.
        self.hidden = self.shared_channel and not self.network.is_complete
        self.sensed_busy = np.zeros(n, dtype=np.int64)  # busy time each robot sensed
        self.frames = self.overflows = self.collisions = 0
        self.airtime = self.queued_total = self.queued_max = 0
        self.handlers = (*self.handlers[:3], None, self._on_done, *self.handlers[5:])

    # ------------------------------------------------------------------ making frames
    def _broadcast(self, i: int, belief: Any, now: int) -> None:
        receivers = self.network.neighbours(i)
        if receivers.size == 0:
            return
        sends = receivers.size if self.unicast else 1
        size = sends * self._belief_size(belief)
        self._enqueue(Frame(i, size, airtime_ns(size, self.bitrate), now, receivers, belief))

    def _forward(self, dest: int, message: Any, size: int, at: int, now: int) -> None:
        nxt = dest if self.network.indptr is None else self.network.next_hop(at, dest)
        receivers = np.array([nxt], dtype=np.int64)
        hop = (dest, message, size, nxt)
        self._enqueue(Frame(at, size, airtime_ns(size, self.bitrate), now, receivers, hop=hop))

    def _enqueue(self, frame: Frame) -> None:
        box = self.queues.setdefault(frame.sender, deque())
        if len(box) >= self.queue_bound:
            self.overflows += 1
            return
        box.append(frame)
        i = frame.sender
        if i not in self.on_air and not self.waiting[i]:
            self._wait(i)
            if self.busy_until[i] <= frame.made:  # sensed idle: on the air at once
                self._go(i, frame.made)

    # ------------------------------------------------------------------ the air
    def _wait(self, i: int) -> None:
        self.waiting[i] = True
        self.wait_order[i] = self.waits
        self.waits += 1

    def _go(self, i: int, t: int) -> None:
        self.waiting[i] = False
        self._start(self.queues[i].popleft(), t)

    def _release(self, t: int) -> None:
        """After a frame ended at ``t``: the waiting senders that now sense the channel
        idle go on the air, in the order they started to wait (each one's start may
        make the channel busy for the next).  Frames end only here, so no waiting sender
        is ever left sensing an idle channel."""
        ready = np.flatnonzero(self.waiting & (self.busy_until <= t))
        if ready.size > 1:
            ready = ready[np.argsort(self.wait_order[ready], kind="stable")]
        for i in ready.tolist():
            if self.busy_until[i] <= t:
                self._go(i, t)

    def _start(self, frame: Frame, t: int) -> None:
        i, end = frame.sender, t + frame.airtime
        self.on_air[i] = frame
        sends = frame.receivers.size if self.unicast and frame.belief is not None else 1
        self.transmissions += sends
        self.bytes += frame.size
        self.frames += 1
        self.airtime += frame.airtime
        delay = t - frame.made
        self.queued_total += delay
        self.queued_max = max(self.queued_max, delay)
        audience = self.network.neighbours(i) if self.shared_channel else frame.receivers[:0]
        self._sense(np.append(audience, i), t, end)
        if self.hidden:
            self._collide(frame, audience, t, end)
        self._push(end, DONE, frame)

    def _sense(self, robots: npt.NDArray[np.int64], t: int, end: int) -> None:
        """``robots`` sense the channel busy over ``[t, end)`` (frames start in time order,
        so adding what lies past each robot's busy end counts the union exactly)."""
        until = self.busy_until[robots]
        self.sensed_busy[robots] += end - np.maximum(until, t).clip(max=end)
        self.busy_until[robots] = np.maximum(until, end)

    def _collide(self, frame: Frame, audience: npt.NDArray[np.int64], t: int, end: int) -> None:
        """Mark the receptions ``frame`` collides with: at every robot in range that
        already hears a frame, both are lost there (of the frames audible there, the one
        ending last is the one to mark: any other still on the air overlaps it, and was
        marked when the later of the two started)."""
        heard = self.heard_until[audience]
        clash = heard > t
        if clash.any():
            for r, sender in zip(
                audience[clash].tolist(), self.heard_sender[audience[clash]].tolist(), strict=True
            ):
                frame.collided.add(r)
                self.on_air[sender].collided.add(r)  # still on the air: it ends after t
        later = audience[heard < end]
        self.heard_until[later] = end
        self.heard_sender[later] = frame.sender

    def _on_done(self, frame: Frame, t: int) -> None:
        i = frame.sender
        del self.on_air[i]
        if frame.hop is None:
            self._deliver_belief(frame, t)
        else:
            self._deliver_hop(frame, t)
        if self.queues[i]:
            self._wait(i)
        self._release(t)

    def _deliver_belief(self, frame: Frame, t: int) -> None:
        receivers = frame.receivers
        delays, lost = self._transmit(frame.sender, receivers, t)
        if frame.collided:
            hit = np.isin(receivers, np.fromiter(frame.collided, dtype=np.int64))
            self.collisions += int((hit & ~lost).sum())
            lost = lost | hit
        dropped = int(lost.sum())
        self.losses += dropped
        self.receptions += receivers.size - dropped
        useful = ~lost & self._can_change(frame.belief, receivers)
        if useful.any():
            self.inflight.add(frame.belief, receivers[useful], t + delays[useful])

    def _deliver_hop(self, frame: Frame, t: int) -> None:
        dest, message, size, nxt = frame.hop  # type: ignore[misc]
        delay, lost = self._transmit_one(frame.sender, nxt, t)  # faults applied too
        if nxt in frame.collided and not lost:
            self.collisions += 1
            lost = True
        if lost:
            self.losses += 1
            return
        self.receptions += 1
        self._push(t + delay, HOP, (dest, message, size, nxt))

    # ------------------------------------------------------------------ the result
    def channel_report(self) -> ChannelReport:  # type: ignore[override]
        """The run's :class:`ChannelReport` (after :meth:`run`)."""
        span = max(self.end, 1)
        past = np.maximum(self.busy_until - self.end, 0)  # on the air past a cut run's end
        busy = (self.sensed_busy - past) / span
        return ChannelReport(
            model=self.spec.channel,
            bitrate=format_bitrate(self.bitrate),
            queue=self.queue_bound,
            frames=self.frames,
            airtime_seconds=self.airtime / 1e9,
            utilisation=float(busy.mean()) if self.n else 0.0,
            peak_utilisation=float(busy.max()) if self.n else 0.0,
            queueing_mean_seconds=self.queued_total / max(self.frames, 1) / 1e9,
            queueing_max_seconds=self.queued_max / 1e9,
            overflows=self.overflows,
            collisions=self.collisions,
        )
