"""Reading and writing the JSON files of the formats, with errors that name the file."""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import IO, Any, BinaryIO

from cfopt._limits import format_bytes, require_memory
from cfopt.checks import require_bool
from cfopt.errors import MissionError, MissionTypeError, describe, is_unicode, key_path

__all__ = [
    "MAX_DEPTH",
    "MAX_DIGITS",
    "DuplicateKeysObject",
    "Source",
    "check_folder",
    "check_free_json",
    "check_keys",
    "check_output",
    "check_source",
    "check_text",
    "expect_list",
    "expect_object",
    "is_null_device",
    "layout_json",
    "make_directory",
    "open_regular_file",
    "output_target",
    "read_json",
    "read_text_file",
    "shown_path",
    "source_name",
    "stat_path",
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


def check_source(source: Any) -> Source:
    """``source`` if it is a file path (``str`` or ``os.PathLike``) or a text stream (an
    object with ``read()``); :class:`~cfopt.errors.MissionTypeError` naming it otherwise."""
    if _is_path(source) or (not isinstance(source, bytes) and hasattr(source, "read")):
        return source
    raise MissionTypeError(
        f"source: must be a file path or a text stream, got {type(source).__name__}"
    )


def check_output(path: Any, overwrite: Any) -> None:
    """Check the ``path`` (None, or a file path) and ``overwrite`` arguments of a writer."""
    if path is not None and not _is_path(path):
        raise MissionTypeError(
            f"path: must be a file path (str or os.PathLike) or None, got {type(path).__name__}"
        )
    if path is not None and "\0" in os.fspath(path):
        raise MissionError(f"{os.fspath(path)}: not a file name (it holds a NUL character)")
    require_bool("overwrite", overwrite)


def _is_path(value: Any) -> bool:
    return isinstance(value, str) or (
        isinstance(value, os.PathLike) and isinstance(os.fspath(value), str)
    )


def source_name(source: Source) -> str:
    """The name a message uses for a path or an open file."""
    if isinstance(source, str | os.PathLike):
        return os.fspath(source)
    if source is sys.stdin:
        return "<stdin>"
    return str(getattr(source, "name", "<stream>"))


#: Memory a parsed JSON document takes, per byte of its text (Python objects, a
#: conservative figure for the formats' lists of small objects).
_PARSE_MEMORY_PER_BYTE = 12
#: Longest run of digits a JSON integer may have (CPython's int-to-string limit).
MAX_DIGITS = 4300
_FILE_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def _file_kind(mode: int) -> str:
    for test, kind in _FILE_KINDS:
        if test(mode):
            return kind
    return "not a regular file"


def read_text_file(path: str | os.PathLike[str]) -> str:
    """The UTF-8 text of a regular file (a FIFO or a device is refused, unread)."""
    return _read_path(path, os.fspath(path))


def open_regular_file(
    path: str | os.PathLike[str],
    name: str,
    *,
    stdin_hint: bool = True,
    expected: str = "a JSON file",
) -> tuple[BinaryIO, int]:
    """Open a regular file for binary reading: ``(handle, size in bytes)``.

    Anything else (a FIFO would block forever, a device never ends) is refused unread
    with a :class:`MissionError` starting with ``name``; ``stdin_hint`` says whether the
    message may suggest ``'-'`` (for the inputs that read stdin from ``-``); ``expected``
    names what a directory was given for.
    """
    try:
        # O_NONBLOCK: opening a FIFO that has no writer must not hang before the check
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise MissionError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise MissionError(f"{name}: is a directory, not {expected}") from None
    except PermissionError:
        raise MissionError(f"{name}: permission denied") from None
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise _lookup_error(name, exc) from None
        raise MissionError(f"{name}: cannot read ({exc.strerror or exc})") from None
    except ValueError:  # a NUL character
        raise MissionError(f"{name}: not a file name (it holds a NUL character)") from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        if stat.S_ISDIR(info.st_mode):
            raise MissionError(f"{name}: is a directory, not {expected}")
        hint = "give a file, or '-' to read stdin" if stdin_hint else "give a regular file"
        raise MissionError(f"{name}: is {_file_kind(info.st_mode)}, not a regular file; {hint}")
    return os.fdopen(fd, "rb"), info.st_size


def _read_path(path: str | os.PathLike[str], name: str, *, stdin_hint: bool = True) -> str:
    """Read a regular file; anything else (a FIFO would block forever) is refused unread."""
    handle, size = open_regular_file(path, name, stdin_hint=stdin_hint)
    with handle:
        require_memory(size * _PARSE_MEMORY_PER_BYTE, f"{name}: {format_bytes(size)} of JSON")
        try:
            data = handle.read()
        except OSError as exc:
            raise MissionError(f"{name}: cannot read ({exc.strerror or exc})") from None
    return _decode(data, name)


def _decode(data: bytes, name: str) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MissionError(f"{name}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _read_text(source: Source, name: str, *, stdin_hint: bool = True) -> str:
    if isinstance(source, str | os.PathLike):
        return _read_path(source, name, stdin_hint=stdin_hint)
    try:
        return source.read()
    except UnicodeDecodeError as exc:
        raise MissionError(f"{name}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise MissionError(f"{name}: cannot read ({exc.strerror or exc})") from None


class _LongNumber(Exception):
    def __init__(self, text: str) -> None:
        self.text = text


def _parse_int(text: str) -> int:
    if len(text) - text.startswith("-") > MAX_DIGITS:
        raise _LongNumber(text)
    return int(text)


def _line_column(text: str, position: int) -> tuple[int, int]:
    line = text.count("\n", 0, position) + 1
    return line, position - (text.rfind("\n", 0, position) + 1) + 1


def read_json(source: Source, *, stdin_hint: bool = True) -> tuple[Any, str]:
    """Parse a JSON file or stream; returns the value and the source's name.

    Objects that repeat a key come back as :class:`DuplicateKeysObject` so that the
    validator can name the place.  ``NaN`` and ``Infinity`` literals are parsed (the
    validator then says where they are not allowed).  Paths must name regular files (a
    FIFO or a device is refused before reading, so nothing blocks), files too large to
    parse in this machine's memory are refused with the memory they would need, and
    integers of more than 4300 digits are refused with their line and column.
    ``stdin_hint``: whether the refusal of a FIFO or a device may suggest ``'-'``.
    """
    name = source_name(check_source(source))
    text = _read_text(source, name, stdin_hint=stdin_hint)
    if not text.strip():
        raise MissionError(f"{name}: empty file, expected a JSON object")
    try:
        value = json.loads(text, object_pairs_hook=_object_pairs, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise MissionError(
            f"{name}: not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})"
        ) from None
    except RecursionError:
        raise MissionError(f"{name}: not valid JSON: nested too deeply") from None
    except _LongNumber as exc:
        line, column = _line_column(text, max(text.find(exc.text), 0))
        digits = len(exc.text) - exc.text.startswith("-")
        raise MissionError(
            f"{name}: line {line}, column {column}: a number of {digits} digits is out of "
            f"the range cfopt reads (at most {MAX_DIGITS} digits)"
        ) from None
    return value, name


#: Paths longer than this are shown cut in the middle in messages.
_SHOWN_LENGTH = 100


def shown_path(path: str | os.PathLike[str]) -> str:
    """A path as a message shows it: one of more than 100 characters is cut in the middle.

    >>> shown_path("results/m.json"), shown_path("x" * 300)[38:]
    ('results/m.json', 'xx...xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx (300 characters)')
    """
    name = os.fspath(path)
    if len(name) <= _SHOWN_LENGTH:
        return name
    return f"{name[:40]}...{name[-40:]} ({len(name)} characters)"


def _lookup_error(name: str, exc: OSError) -> MissionError:
    if exc.errno == errno.ENAMETOOLONG:
        return MissionError(f"{shown_path(name)}: name too long for the file system")
    if isinstance(exc, PermissionError):
        return MissionError(f"{name}: permission denied")
    return MissionError(f"{name}: cannot look it up ({exc.strerror or exc})")


def stat_path(
    path: str | os.PathLike[str], *, follow_symlinks: bool = True, name: str | None = None
) -> os.stat_result | None:
    """What is at ``path``: its ``os.stat`` (``os.lstat`` without ``follow_symlinks``), or
    ``None`` when nothing is there (or a folder on the way is a file).

    A path that cannot even be looked up (a name too long for the file system, a folder
    that may not be searched, a loop of symbolic links) is a :class:`MissionError`
    naming ``name`` (default: the path).
    """
    try:
        return os.stat(path, follow_symlinks=follow_symlinks)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise _lookup_error(os.fspath(path) if name is None else name, exc) from None


def check_folder(path: str | os.PathLike[str]) -> Path:
    """The rule for every output: the folder an output goes into must exist already.

    cfopt creates the file or the report directory it is asked to write, never a
    missing folder above it (a typo in a path should not scatter folders).
    """
    target = Path(path)
    parent = target.parent
    info = stat_path(parent, name=os.fspath(path))
    if info is None or not stat.S_ISDIR(info.st_mode):
        what = "does not exist" if info is None else "is not a directory"
        raise MissionError(f"{os.fspath(path)}: the folder {os.fspath(parent)!r} {what}")
    return target


def _exists_message(path: str | os.PathLike[str]) -> MissionError:
    where = os.fspath(path)
    return MissionError(
        f"{where}: already exists (pass overwrite=True to replace it)",
        cli=f"{where}: already exists (pass --force to replace it)",
    )


#: Kinds of existing paths a file output never goes into, even when replacing is allowed.
_NEVER_WRITTEN = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISSOCK, "a socket"),
)


def _is_null_device(info: os.stat_result) -> bool:
    null = stat_path(os.devnull)
    return null is not None and os.path.samestat(info, null)


def is_null_device(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is the null device (``/dev/null`` or a symbolic link to it): the
    output every command accepts, to compute and print and keep nothing.

    >>> is_null_device(os.devnull), is_null_device("results.json")
    (True, False)
    """
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return False
    return _is_null_device(info)


def output_target(
    path: str | os.PathLike[str], *, overwrite: bool, directory: bool = False
) -> Path | None:
    """The rule for every output path: where to write ``path``, decided before writing.

    Returns the path to write, or ``None`` for the null device (``/dev/null`` or a
    symbolic link to it), which is always accepted and needs nothing written.  A path
    that names nothing yet is accepted when its folder exists.  For a file output
    (``directory=False``) an existing path is refused (:class:`MissionError`) unless
    ``overwrite``; a directory, a block or character device other than the null device
    and a socket are refused even then (a mission is never written into a disk).  With
    ``overwrite`` a FIFO is written as it is, and a symbolic link to a file has the file
    it points to replaced (the link stays).  For a report directory (``directory=True``)
    an existing directory is accepted (its files are checked by the report) and any
    other existing path is refused.  Symbolic links are judged by what they point to;
    names too long for the file system are refused with one line.
    """
    where = os.fspath(path)
    target = Path(path)
    entry = stat_path(target, follow_symlinks=False)
    if entry is None:
        check_folder(path)
        return target
    linked = stat.S_ISLNK(entry.st_mode)
    info = stat_path(target) if linked else entry
    if directory:
        if info is None or not stat.S_ISDIR(info.st_mode):
            raise MissionError(f"{where}: exists and is not a directory")
        return target
    if info is not None and _is_null_device(info):
        return None
    for test, kind in _NEVER_WRITTEN:
        if info is not None and test(info.st_mode):
            raise MissionError(
                f"{where}: is {kind}, not a file cfopt may write (give a file name, "
                "or /dev/null to discard the output)"
            )
    if not overwrite:
        raise _exists_message(path)
    if linked and info is not None and stat.S_ISREG(info.st_mode):
        return Path(os.path.realpath(target))
    return target


def make_directory(path: str | os.PathLike[str]) -> bool:
    """Create the directory ``path`` (its folder must exist); ``True`` if it was created,
    ``False`` if it was there already.  A failure is a :class:`MissionError` naming it."""
    where = os.fspath(path)
    try:
        os.mkdir(path)
    except FileExistsError:
        info = stat_path(path)
        if info is None or not stat.S_ISDIR(info.st_mode):
            raise MissionError(f"{where}: exists and is not a directory") from None
        return False
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise _lookup_error(where, exc) from None
        raise MissionError(
            f"{where}: cannot create the directory ({exc.strerror or exc})"
        ) from None
    return True


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_text(text: str, path: str | os.PathLike[str], *, overwrite: bool) -> None:
    """Write UTF-8 text to ``path`` atomically; an existing file is replaced only when asked.

    Where it may go is :func:`output_target`'s rule: the null device is accepted and
    nothing is written to it; a FIFO (with ``overwrite``) is written directly.  Otherwise
    the text goes to a temporary file in the same folder (a short name of its own, so
    that every valid file name works), is flushed to disk, and is then renamed into
    place, so ``path`` holds either its old content or the whole new one, never a part
    (a full disk or a crash leaves the old file as it was).  Without ``overwrite`` the
    file is linked into place, which fails if it appeared meanwhile.
    """
    data = text.encode("utf-8")
    where = os.fspath(path)
    target = output_target(path, overwrite=overwrite)
    if target is None:
        return
    existing = stat_path(target)
    if existing is not None and stat.S_ISFIFO(existing.st_mode):
        _write_directly(data, target, where)
        return
    mode = (existing.st_mode & 0o7777) if existing is not None else 0o666 & ~_umask()
    try:
        fd, temporary = tempfile.mkstemp(dir=target.parent, prefix=".cfopt-", suffix=".part")
    except PermissionError:
        raise MissionError(f"{where}: permission denied") from None
    except OSError as exc:
        raise MissionError(f"{where}: cannot write ({exc.strerror or exc})") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(temporary, mode)
        _move_into_place(temporary, target, overwrite)
    except FileExistsError:
        _remove(temporary)
        raise _exists_message(path) from None
    except OSError as exc:
        _remove(temporary)
        kept = "the existing file is unchanged" if existing is not None else "nothing was written"
        raise MissionError(f"{where}: cannot write ({exc.strerror or exc}); {kept}") from None
    except BaseException:
        _remove(temporary)
        raise
    _sync_folder(target.parent)


def _write_directly(data: bytes, target: Path, where: str) -> None:
    try:
        with target.open("wb") as handle:
            handle.write(data)
    except OSError as exc:
        raise MissionError(f"{where}: cannot write ({exc.strerror or exc})") from None


def _move_into_place(temporary: str, target: Path, overwrite: bool) -> None:
    if overwrite:
        os.replace(temporary, target)
        return
    try:
        os.link(temporary, target)  # atomic, and fails if the target appeared meanwhile
    except FileExistsError:
        raise
    except OSError:  # a file system without hard links
        if target.exists():
            raise FileExistsError(target) from None
        os.replace(temporary, target)
        return
    _remove(temporary)


def _remove(path: str | os.PathLike[str]) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)


def _sync_folder(folder: Path) -> None:
    """Make a rename durable (best effort: not every system can open a folder)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


#: How deeply free-form JSON (a mission's ``metadata``) may nest.
MAX_DEPTH = 100


def check_text(value: Any, place: str, what: str = "a non-empty string") -> str:
    """``value`` must be a non-empty string of valid Unicode (no lone surrogates)."""
    if not isinstance(value, str) or not value:
        raise MissionError(f"{place}: must be {what}, got {describe(value)}")
    if not is_unicode(value):
        raise MissionError(
            f"{place}: must be valid Unicode text, got {describe(value)} (a lone surrogate)"
        )
    return value


def check_free_json(value: Any, place: str) -> None:
    """Free-form data must be plain JSON that cfopt can write back unchanged.

    Objects with string keys, lists, valid Unicode strings, finite numbers (integers of
    at most 4300 digits), booleans and null, nested at most :data:`MAX_DEPTH` levels.
    Checked without recursion, so any depth gives a clean error.
    """
    stack: list[tuple[Any, str, int]] = [(value, place, 0)]
    while stack:
        item, where, depth = stack.pop()
        if depth > MAX_DEPTH:
            shown = where if len(where) <= 60 else where[:57] + "..."
            raise MissionError(f"{shown}: nested more than {MAX_DEPTH} levels deep")
        if isinstance(item, str):
            if not is_unicode(item):
                raise MissionError(f"{where}: must be valid Unicode text, got {describe(item)}")
        elif isinstance(item, bool) or item is None:
            continue
        elif isinstance(item, int):
            if item.bit_length() > _MAX_INT_BITS:
                raise MissionError(f"{where}: {describe(item)} is out of the range cfopt writes")
        elif isinstance(item, float):
            if not math.isfinite(item):
                raise MissionError(f"{where}: must be a finite number, got {describe(item)}")
        elif isinstance(item, Mapping):
            for key, inner in item.items():
                if not isinstance(key, str) or not is_unicode(key):
                    raise MissionError(
                        f"{where}: keys must be valid Unicode strings, got {describe(key)}"
                    )
                stack.append((inner, key_path(where, key), depth + 1))
        elif isinstance(item, list | tuple):
            stack.extend((inner, f"{where}[{k}]", depth + 1) for k, inner in enumerate(item))
        else:
            raise MissionError(f"{where}: must be JSON data, got a {type(item).__name__}")


_MAX_INT_BITS = int(MAX_DIGITS / 0.30103) - 4


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
