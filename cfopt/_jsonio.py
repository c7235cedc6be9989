"""Reading and writing the JSON files of the formats, with errors that name the file."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import IO, Any

from cfopt.errors import MissionError, describe, key_path

__all__ = [
    "DuplicateKeysObject",
    "Source",
    "check_keys",
    "expect_list",
    "expect_object",
    "layout_json",
    "read_json",
    "source_name",
    "write_text",
]

Source = str | os.PathLike[str] | IO[str]


class DuplicateKeysObject(dict):
    """A JSON object that named some key more than once (JSON allows it; we do not)."""

    duplicates: tuple[str, ...] = ()


def _object_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result = dict(pairs)
    if len(result) == len(pairs):
        return result
    seen: set[str] = set()
    repeated = [key for key, _ in pairs if key in seen or seen.add(key)]
    flagged = DuplicateKeysObject(result)
    flagged.duplicates = tuple(dict.fromkeys(repeated))
    return flagged


def source_name(source: Source) -> str:
    """The name a message uses for a path or an open file."""
    if isinstance(source, str | os.PathLike):
        return os.fspath(source)
    if source is sys.stdin:
        return "<stdin>"
    return str(getattr(source, "name", "<stream>"))


def _read_text(source: Source, name: str) -> str:
    if not isinstance(source, str | os.PathLike):
        try:
            return source.read()
        except UnicodeDecodeError as exc:
            raise MissionError(f"{name}: not UTF-8 text ({exc.reason})") from None
    path = Path(source)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissionError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise MissionError(f"{name}: is a directory, not a JSON file") from None
    except PermissionError:
        raise MissionError(f"{name}: permission denied") from None
    except UnicodeDecodeError as exc:
        raise MissionError(f"{name}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise MissionError(f"{name}: cannot read ({exc.strerror or exc})") from None


def read_json(source: Source) -> tuple[Any, str]:
    """Parse a JSON file or stream; returns the value and the source's name.

    Objects that repeat a key come back as :class:`DuplicateKeysObject` so that the
    validator can name the place.  ``NaN`` and ``Infinity`` literals are parsed (the
    validator then says where they are not allowed).
    """
    name = source_name(source)
    text = _read_text(source, name)
    if not text.strip():
        raise MissionError(f"{name}: empty file, expected a JSON object")
    try:
        value = json.loads(text, object_pairs_hook=_object_pairs)
    except json.JSONDecodeError as exc:
        raise MissionError(
            f"{name}: not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})"
        ) from None
    except RecursionError:
        raise MissionError(f"{name}: not valid JSON: nested too deeply") from None
    return value, name


def write_text(text: str, path: str | os.PathLike[str], *, overwrite: bool) -> None:
    """Write UTF-8 text to ``path``; an existing file is replaced only when asked."""
    target = Path(path)
    if target.is_dir():
        raise MissionError(f"{os.fspath(path)}: is a directory")
    mode = "w" if overwrite else "x"
    try:
        with target.open(mode, encoding="utf-8") as handle:
            handle.write(text)
    except FileExistsError:
        raise MissionError(
            f"{os.fspath(path)}: already exists (pass overwrite=True / --force to replace it)"
        ) from None
    except FileNotFoundError:
        raise MissionError(f"{os.fspath(path)}: its folder does not exist") from None
    except PermissionError:
        raise MissionError(f"{os.fspath(path)}: permission denied") from None


def expect_object(value: Any, place: str) -> dict[str, Any]:
    """``value`` must be a JSON object without repeated keys."""
    if not isinstance(value, dict):
        where = place or "top level"
        raise MissionError(f"{where}: must be an object, got {describe(value)}")
    duplicates = getattr(value, "duplicates", ())
    if duplicates:
        raise MissionError(f"{key_path(place, duplicates[0])}: key given more than once")
    return value


def expect_list(value: Any, place: str) -> list[Any]:
    """``value`` must be a JSON array."""
    if not isinstance(value, list):
        raise MissionError(f"{place or 'top level'}: must be a list, got {describe(value)}")
    return value


def check_keys(
    obj: dict[str, Any], place: str, required: Iterable[str], optional: Iterable[str] = ()
) -> None:
    """Unknown keys are errors (they are almost always typos); required keys must be there."""
    required = tuple(required)
    allowed = (*required, *optional)
    for key in obj:
        if key not in allowed:
            expected = ", ".join(allowed)
            raise MissionError(f"{key_path(place, str(key))}: unknown key (expected {expected})")
    for key in required:
        if key not in obj:
            where = place or "top level"
            raise MissionError(f'{where}: missing key "{key}"')


def layout_json(obj: dict[str, Any]) -> str:
    """JSON with one list item per line: readable, diffable, and still compact."""
    dumps = json.dumps
    lines = ["{"]
    keys = list(obj)
    for position, key in enumerate(keys):
        value = obj[key]
        comma = "," if position < len(keys) - 1 else ""
        if key in ("robots", "tasks", "assignment") and value:
            lines.append(f"  {dumps(key)}: [")
            items = [f"    {dumps(item, ensure_ascii=False)}" for item in value]
            lines.append(",\n".join(items))
            lines.append(f"  ]{comma}")
        else:
            lines.append(f"  {dumps(key)}: {dumps(value, ensure_ascii=False)}{comma}")
    lines.append("}")
    return "\n".join(lines) + "\n"
