"""The one exception type for bad input, and helpers that format its messages."""

from __future__ import annotations

import json
import re
from typing import Any

__all__ = [
    "ExecutorFailed",
    "MissionError",
    "MissionTypeError",
    "SweepInterrupted",
    "WorkerDied",
    "byte_count",
    "describe",
    "key_path",
    "parameter_error",
    "plural",
]

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*\Z")
_MAX_SHOWN = 60


class MissionError(ValueError):
    """Bad input: a mission, an assignment or a file that breaks the formats' rules.

    The message names the place, e.g. ``tasks[3].requires.lift: must be a whole
    number >= 1, got 2.5``; when the input came from a file it starts with the file
    name.  The command line prints exactly this message after ``error:``, or
    :attr:`cli_message` when the error has a wording of its own for the command line
    (a parameter named by its flag, ``--services-per-robot`` rather than
    ``services_per_robot``).

    >>> err = MissionError("load: must be > 0", cli="--load: must be > 0")
    >>> str(err), err.cli_message, str(err.prefixed("grid.toml"))
    ('load: must be > 0', '--load: must be > 0', 'grid.toml: load: must be > 0')
    """

    def __init__(self, message: str, *, cli: str | None = None) -> None:
        super().__init__(message)
        self.cli_message = cli if cli is not None else message

    def prefixed(self, prefix: str) -> MissionError:
        """The same error with ``prefix: `` in front of both wordings (e.g. a file name)."""
        return MissionError(f"{prefix}: {self}", cli=f"{prefix}: {self.cli_message}")


class MissionTypeError(MissionError, TypeError):
    """A :class:`MissionError` about an argument of the wrong type; also a :class:`TypeError`.

    ``except TypeError`` catches it as Python code expects, and ``except MissionError``
    (the command line's one error handler) as every other bad input.

    >>> issubclass(MissionTypeError, TypeError), issubclass(MissionTypeError, ValueError)
    (True, True)
    """


def parameter_error(name: str, problem: str) -> MissionError:
    """An error about the keyword argument ``name``, worded for Python and for the CLI.

    >>> parameter_error("services_per_robot", "must be >= 1, got 0").cli_message
    '--services-per-robot: must be >= 1, got 0'
    """
    return MissionError(f"{name}: {problem}", cli=f"--{name.replace('_', '-')}: {problem}")


def plural(count: int, word: str, many: str | None = None) -> str:
    """``"1 task"``, ``"4 tasks"``: a count with its noun in the right number.

    >>> plural(1, "violation"), plural(4, "robot"), plural(2, "bus", "buses")
    ('1 violation', '4 robots', '2 buses')
    """
    return f"{count} {word if count == 1 else (many or word + 's')}"


_DECIMAL_UNITS = ("kB", "MB", "GB", "TB", "PB", "EB", "ZB", "YB")


def byte_count(count: int) -> str:
    """A count of bytes for people: decimal units (1 kB = 1000 bytes), then the exact count.

    Counts below 1000 are only the count.  The command line prints every byte count
    this way (``--json`` keeps the exact integer).

    >>> byte_count(1), byte_count(999), byte_count(25264), byte_count(503502480000)
    ('1 byte', '999 bytes', '25.3 kB (25,264 bytes)', '503.5 GB (503,502,480,000 bytes)')
    """
    if count < 1000:
        return plural(count, "byte")
    value, power = float(count) / 1000, 0
    while value >= 999.95 and power < len(_DECIMAL_UNITS) - 1:
        value, power = value / 1000, power + 1
    return f"{value:.1f} {_DECIMAL_UNITS[power]} ({count:,} bytes)"


def describe(value: Any) -> str:
    """Show a user's value as it looks in JSON, shortened when long.

    Values that JSON cannot show (nested too deeply, integers of thousands of digits)
    are described instead of shown, and text that is not valid Unicode (a lone
    surrogate such as ``"\\ud800"``) is shown with escapes, so the message itself can
    always be printed.

    >>> describe(True), describe("2"), describe(2.5), describe(float("nan"))
    ('true', '"2"', '2.5', 'NaN')
    >>> describe("\\ud800"), describe(10**5000)
    ('"\\\\ud800"', 'a whole number of about 5001 digits')
    """
    try:
        text = json.dumps(value, ensure_ascii=False, allow_nan=True)
    except (TypeError, ValueError, RecursionError):
        text = _summary(value)
    if not is_unicode(text):
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    if len(text) > _MAX_SHOWN:
        text = text[: _MAX_SHOWN - 3] + "..."
    return text


def is_unicode(text: str) -> bool:
    """Whether ``text`` is valid Unicode (encodable as UTF-8: no lone surrogates)."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _summary(value: Any) -> str:
    if isinstance(value, int) and not isinstance(value, bool):
        digits = int(value.bit_length() * 0.30103) + 1  # str() refuses > 4300 digits
        return f"a whole number of about {digits} digits" if digits > 20 else repr(value)
    if isinstance(value, list):
        return f"a list of {plural(len(value), 'item')} nested too deeply to show"
    if isinstance(value, dict):
        return f"an object of {plural(len(value), 'key')} nested too deeply to show"
    return f"a {type(value).__name__}"


def key_path(parent: str, key: str) -> str:
    """Append a mapping key to a place, quoting keys that are not plain words.

    >>> key_path("tasks[3].requires", "lift"), key_path("tasks[0].requires", "a b")
    ('tasks[3].requires.lift', 'tasks[0].requires["a b"]')
    """
    if _IDENTIFIER.match(key):
        return f"{parent}.{key}" if parent else key
    return f"{parent}[{describe(key)}]"


class WorkerDied(RuntimeError):
    """A trial that never finished because the worker process running it died, each time
    it ran (set on its future by a cluster executor such as :mod:`cfopt.cluster`).

    The sweep records it as a failure with this message rather than a traceback (the
    trial did not raise); it is not stored and the next run tries it again.  Also
    importable as ``cfopt.experiments.WorkerDied``.
    """


class ExecutorFailed(MissionError):
    """The executor can run no more trials (a cluster's scheduler is gone).

    Set on a trial's future by the executor, it stops the sweep:
    :func:`cfopt.experiments.run_sweep` raises it again, its message completed with the
    trials kept in the store.  Also importable as ``cfopt.experiments.ExecutorFailed``.
    """


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by SIGINT or SIGTERM; what it stored is kept (also importable as
    ``cfopt.experiments.SweepInterrupted``).

    ``completed`` trials were computed and committed by this sweep before it stopped;
    the next run of the same sweep resumes after them.
    """

    def __init__(
        self, store: str, completed: int, remaining: int, signal_name: str, extra: str = ""
    ) -> None:
        super().__init__(f"{signal_name}: {store}")
        self.store, self.completed, self.remaining = store, completed, remaining
        self.signal_name = signal_name
        #: What else was kept, in words (the audit: "5 claim verdicts").
        self.extra = extra
