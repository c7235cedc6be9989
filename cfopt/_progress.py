"""Progress on stderr: bars on a terminal, lines in a log, nothing when quiet.

A long command (a sweep, an audit) reports its stages through one :class:`Progress`:

- on a terminal, each stage is a tqdm bar (several stages running at once get a bar
  each, one per line); a stage that resumes stored work says so in its description
  (``claims, 6 reused``), and a terminal that reports no size (0 columns or 0 lines, as
  some consoles of containers and CI do) gets bars 80 columns wide;
- when stderr is not a terminal (a log file, a pipe, CI), each stage prints one line
  when it starts, a heartbeat line every 30 s while it runs (units done of the total,
  time elapsed, rate), and one line when it ends; no carriage returns;
- with ``quiet``, nothing at all.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import IO, Any

__all__ = [
    "FALLBACK_COLUMNS",
    "FALLBACK_LINES",
    "HEARTBEAT_SECONDS",
    "Progress",
    "Stage",
    "format_duration",
    "terminal_shape",
]

#: Seconds between two heartbeat lines of a running stage when stderr is not a terminal.
HEARTBEAT_SECONDS = 30.0
#: The terminal size bars use when the terminal reports none (0 columns or lines).
FALLBACK_COLUMNS, FALLBACK_LINES = 80, 24

Clock = Callable[[], float]


def terminal_shape(stream: Any) -> tuple[int, int]:
    """``(columns, lines)`` a bar may use on ``stream``, as tqdm's ``dynamic_ncols`` wants.

    The terminal's size less one column and one line (tqdm's margin); a terminal that
    reports 0 columns or 0 lines, or none at all, gets :data:`FALLBACK_COLUMNS` and
    :data:`FALLBACK_LINES` instead (tqdm would draw nothing).

    >>> import io
    >>> terminal_shape(io.StringIO())
    (79, 23)
    """
    try:
        size = os.get_terminal_size(stream.fileno())
        columns, lines = size.columns, size.lines
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both
        columns, lines = 0, 0
    return (
        (columns if columns > 0 else FALLBACK_COLUMNS) - 1,
        (lines if lines > 0 else FALLBACK_LINES) - 1,
    )


def format_duration(seconds: float) -> str:
    """Elapsed time for people.

    >>> format_duration(4.25), format_duration(65), format_duration(3725)
    ('4.2 s', '1 min 05 s', '1 h 02 min')
    """
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, rest = divmod(int(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {rest:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def _rate(done: int, seconds: float, unit: str) -> str:
    """``"2.50 trials/s"``, or ``"40.0 s/trial"`` when slower than one a second."""
    if done == 0 or seconds <= 0:
        return f"no {unit} finished yet"
    per_second = done / seconds
    if per_second >= 1:
        return f"{per_second:.2f} {unit}s/s"
    return f"{seconds / done:.1f} s/{unit}"


class Stage:
    """One stage: ``update`` per finished unit, ``close`` at the end (prints its summary).

    Opened by :meth:`Progress.stage`.
    """

    def __init__(
        self, progress: Progress, name: str, total: int, unit: str, reused: int = 0
    ) -> None:
        self.progress, self.name, self.total, self.unit = progress, name, total, unit
        self.reused = reused
        self.done = 0
        self.started = progress.clock()
        self.last_line = self.started
        self._postfix: dict[str, Any] = {}
        self._bar: Any = None
        self._closed = False
        self._beating = threading.Lock()
        if progress.mode == "bar":
            self._bar = self._make_bar()

    def _make_bar(self) -> Any:
        from tqdm import tqdm

        stream = self.progress.stream
        columns, lines = terminal_shape(stream)
        bar = tqdm(
            total=self.total,
            desc=self.name if not self.reused else f"{self.name}, {self.reused} reused",
            unit=self.unit,
            file=stream,
            ncols=columns,
            nrows=lines,
            smoothing=0.05,
            position=self.progress.next_position(),
            leave=True,
        )
        bar.dynamic_ncols = terminal_shape  # follow resizes, with the same fallback
        return bar

    def update(self, count: int = 1) -> None:
        """``count`` more units are finished (in lines mode a heartbeat may be due)."""
        self.done += count
        if self._bar is not None:
            self._bar.update(count)
        else:
            self.beat()

    def set_postfix(self, **values: Any) -> None:
        """Extra figures shown beside a bar (``failed=2``); heartbeat lines show them too."""
        self._postfix = values
        if self._bar is not None:
            self._bar.set_postfix(**values)

    def heartbeat_text(self, now: float) -> str:
        """``"trials: 120/1424 trials, 5 min 00 s elapsed, 0.40 trials/s"``."""
        took = now - self.started
        text = (
            f"{self.name}: {self.done}/{self.total} {self.unit}s, "
            f"{format_duration(took)} elapsed, {_rate(self.done, took, self.unit)}"
        )
        if self.reused:
            text += f", {self.reused} reused"
        extra = ", ".join(f"{k} {v}" for k, v in self._postfix.items())
        return f"{text}, {extra}" if extra else text

    def beat(self) -> bool:
        """In lines mode, print a heartbeat line if one is due (the last line is at least
        :attr:`Progress.heartbeat` seconds old); whether one was printed."""
        if self.progress.mode != "lines" or self._closed or self.progress.heartbeat <= 0:
            return False
        with self._beating:  # the ticker thread and update() may both ask
            now = self.progress.clock()
            if now - self.last_line < self.progress.heartbeat:
                return False
            self.last_line = now
        self.progress.line(self.heartbeat_text(now))
        return True

    def close(self, summary: str | None = None) -> None:
        """End the stage; in lines mode print ``name: summary (elapsed)``."""
        if self._closed:
            return
        self._closed = True
        self.progress.closed(self)
        if self._bar is not None:
            self._bar.close()
        elif self.progress.mode == "lines":
            took = self.progress.clock() - self.started
            text = summary or f"{self.done} of {self.total} {self.unit}s done"
            self.progress.line(f"{self.name}: {text} ({format_duration(took)})")


class Progress:
    """Where a command reports its stages (see the module docstring).

    Parameters
    ----------
    mode : {"bar", "lines", "off"}
    stream : text stream, default sys.stderr
    clock : callable, default time.monotonic
        Seconds, for the elapsed times and the heartbeats (a test gives a fake one).
    heartbeat : float, default 30
        Seconds between two heartbeat lines of a running stage in lines mode (0: none).
    tick : float or None, default 1
        How often a background thread looks for due heartbeats in lines mode, so that a
        stage whose units take minutes still shows signs of life; ``None``: no thread,
        heartbeats only when a unit finishes (or :meth:`Stage.beat` is called).
    """

    def __init__(
        self,
        mode: str = "lines",
        stream: IO[str] | None = None,
        *,
        clock: Clock = time.monotonic,
        heartbeat: float = HEARTBEAT_SECONDS,
        tick: float | None = 1.0,
    ) -> None:
        import sys

        if mode not in ("bar", "lines", "off"):
            raise ValueError(f"mode: must be bar, lines or off, got {mode!r}")
        self.mode = mode
        self.stream = stream if stream is not None else sys.stderr
        self.clock, self.heartbeat, self.tick = clock, heartbeat, tick
        self._positions = 0
        self._open: list[Stage] = []
        self._lock = threading.Lock()
        self._ticker: threading.Thread | None = None
        self._stop = threading.Event()

    @classmethod
    def auto(cls, quiet: bool = False, stream: IO[str] | None = None) -> Progress:
        """Bars on a terminal, lines elsewhere, nothing when ``quiet``."""
        import sys

        stream = stream if stream is not None else sys.stderr
        if quiet:
            return cls("off", stream)
        isatty = getattr(stream, "isatty", None)
        return cls("bar" if isatty is not None and isatty() else "lines", stream)

    @classmethod
    def coerce(cls, value: bool | Progress) -> Progress:
        """``True`` -> :meth:`auto`, ``False`` -> off, a :class:`Progress` as is."""
        if isinstance(value, Progress):
            return value
        return cls.auto(quiet=not value)

    def next_position(self) -> int:
        """The screen line of the next bar (0, 1, ...)."""
        position = self._positions
        self._positions += 1
        return position

    def line(self, text: str) -> None:
        """One line of news (not in ``off`` mode)."""
        if self.mode == "off":
            return
        with self._lock:
            if self.mode == "bar":
                from tqdm import tqdm

                tqdm.write(text, file=self.stream)
            else:
                self.stream.write(text + "\n")
                self.stream.flush()

    def stage(
        self, name: str, total: int, unit: str, start: str | None = None, *, reused: int = 0
    ) -> Stage:
        """Open a stage of ``total`` units; in lines mode print ``name: start`` first.

        ``reused``: units of the same stage a former run finished and this one reuses
        (not in ``total``); a bar says so in its description, heartbeat lines too.
        """
        if self.mode == "lines" and start:
            self.line(f"{name}: {start}")
        stage = Stage(self, name, total, unit, reused)
        if self.mode == "lines":
            with self._lock:
                self._open.append(stage)
            self._start_ticker()
        return stage

    def closed(self, stage: Stage) -> None:
        """``stage`` has ended: no more heartbeats for it (the thread stops with the last)."""
        with self._lock:
            if stage in self._open:
                self._open.remove(stage)
            last = not self._open
        if last:
            self._stop.set()

    def _start_ticker(self) -> None:
        if self.tick is None or self.heartbeat <= 0:
            return
        if self._ticker is not None and self._ticker.is_alive() and not self._stop.is_set():
            return
        self._stop = threading.Event()
        self._ticker = threading.Thread(
            target=self._beat_while_open, args=(self._stop,), name="cfopt-heartbeat", daemon=True
        )
        self._ticker.start()

    def _beat_while_open(self, stop: threading.Event) -> None:
        while not stop.wait(self.tick):
            with self._lock:
                stages = list(self._open)
            for stage in stages:
                stage.beat()
