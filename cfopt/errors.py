"""The one exception type for bad input, and helpers that format its messages."""

from __future__ import annotations

import json
import re
from typing import Any

__all__ = ["MissionError", "describe", "key_path"]

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*\Z")
_MAX_SHOWN = 60


class MissionError(ValueError):
    """Bad input: a mission, an assignment or a file that breaks the formats' rules.

    The message names the place, e.g. ``tasks[3].requires.lift: must be a whole
    number >= 1, got 2.5``; when the input came from a file it starts with the file
    name.  The command line prints exactly this message after ``error:``.
    """


def describe(value: Any) -> str:
    """Show a user's value as it looks in JSON, shortened when long.

    >>> describe(True), describe("2"), describe(2.5), describe(float("nan"))
    ('true', '"2"', '2.5', 'NaN')
    """
    try:
        text = json.dumps(value, ensure_ascii=False, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(value)
    if len(text) > _MAX_SHOWN:
        text = text[: _MAX_SHOWN - 3] + "..."
    return text


def key_path(parent: str, key: str) -> str:
    """Append a mapping key to a place, quoting keys that are not plain words.

    >>> key_path("tasks[3].requires", "lift"), key_path("tasks[0].requires", "a b")
    ('tasks[3].requires.lift', 'tasks[0].requires["a b"]')
    """
    if _IDENTIFIER.match(key):
        return f"{parent}.{key}" if parent else key
    return f"{parent}[{json.dumps(key, ensure_ascii=False)}]"
