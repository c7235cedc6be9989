"""Progress on stderr: bars on a terminal, one line per stage in a log, nothing when quiet.

A long command (a sweep, an audit) reports its stages through one :class:`Progress`:

- on a terminal, each stage is a tqdm bar (several stages running at once get a bar
  each, one per line);
- when stderr is not a terminal (a log file, a pipe, CI), each stage prints one line
  when it starts and one when it ends, and no carriage returns;
- with ``quiet``, nothing at all.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any

__all__ = ["Progress", "Stage"]


class Stage:
    """One stage: ``update`` per finished unit, ``close`` at the end (prints its summary)."""

    def __init__(self, progress: Progress, name: str, total: int, unit: str) -> None:
        self.progress, self.name, self.total, self.unit = progress, name, total, unit
        self.done = 0
        self.started = time.perf_counter()
        self._bar: Any = None
        self._closed = False
        if progress.mode == "bar":
            from tqdm import tqdm

            self._bar = tqdm(
                total=total,
                desc=name,
                unit=unit,
                file=progress.stream,
                dynamic_ncols=True,
                smoothing=0.05,
                position=progress.next_position(),
                leave=True,
            )

    def update(self, count: int = 1) -> None:
        """``count`` more units are finished."""
        self.done += count
        if self._bar is not None:
            self._bar.update(count)

    def set_postfix(self, **values: Any) -> None:
        """Extra figures shown beside a bar (``failed=2``); lines mode shows them at the end."""
        self._postfix = values
        if self._bar is not None:
            self._bar.set_postfix(**values)

    def close(self, summary: str | None = None) -> None:
        """End the stage; in lines mode print ``name: summary (N s)``."""
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.close()
        elif self.progress.mode == "lines":
            took = time.perf_counter() - self.started
            text = summary or f"{self.done} of {self.total} {self.unit}s done"
            self.progress.line(f"{self.name}: {text} ({took:.1f} s)")


class Progress:
    """Where a command reports its stages (see the module docstring).

    Parameters
    ----------
    mode : {"bar", "lines", "off"}
    stream : text stream, default sys.stderr
    """

    def __init__(self, mode: str = "lines", stream: IO[str] | None = None) -> None:
        if mode not in ("bar", "lines", "off"):
            raise ValueError(f"mode: must be bar, lines or off, got {mode!r}")
        self.mode = mode
        self.stream = stream if stream is not None else sys.stderr
        self._positions = 0

    @classmethod
    def auto(cls, quiet: bool = False, stream: IO[str] | None = None) -> Progress:
        """Bars on a terminal, lines elsewhere, nothing when ``quiet``."""
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
        position = self._positions
        self._positions += 1
        return position

    def line(self, text: str) -> None:
        """One line of news (not in ``off`` mode)."""
        if self.mode == "off":
            return
        if self.mode == "bar":
            from tqdm import tqdm

            tqdm.write(text, file=self.stream)
        else:
            self.stream.write(text + "\n")
            self.stream.flush()

    def stage(self, name: str, total: int, unit: str, start: str | None = None) -> Stage:
        """Open a stage of ``total`` units; in lines mode print ``name: start`` first."""
        if self.mode == "lines" and start:
            self.line(f"{name}: {start}")
        return Stage(self, name, total, unit)
