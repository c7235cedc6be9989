"""Text edge lists (two robot ids per line) read in chunks with bounded memory.

A chunk of plain ASCII lines (ids of printable characters, spaces, tabs and ``\\n``
only, no ``#``) is split and checked by numpy and C-level string calls; any other chunk
goes line by line (``str.splitlines`` numbering, Unicode whitespace, comments), which is
also what names the first mistake of a chunk, so both give the same edges, lines and
messages.  Each distinct id is kept once; the edges are held as an index table into
the distinct ids, so that mapping them to a mission's robots costs one look-up per id.

>>> import io
>>> table = read_edges(io.BytesIO(b"a b\\nb c  # last\\n"), "edges.txt")
>>> table.names, table.index.tolist(), table.lines.tolist(), table.pairs()
(['a', 'b', 'c'], [[0, 1], [1, 2]], [1, 2], (('a', 'b'), ('b', 'c')))
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np
import numpy.typing as npt

from cfopt._jsonio import open_regular_file
from cfopt._limits import format_bytes, require_memory
from cfopt.errors import MissionError, describe, plural

__all__ = ["CHUNK_BYTES", "EDGE_LIST_MEMORY_PER_BYTE", "EdgeTable", "read_edge_list", "read_edges"]

#: Memory a text edge list takes, per byte of the file, from reading it to a built
#: network (measured: a peak of about 15 bytes per byte, ids such as ``r12345``, 1.3
#: million edges); a file whose size times this exceeds the machine's memory is refused
#: before it is read.
EDGE_LIST_MEMORY_PER_BYTE = 20
#: About this many bytes of lines are read and parsed at a time.
CHUNK_BYTES = 4 << 20

_TAB, _NEWLINE, _SPACE = 9, 10, 32
_PLAIN = np.zeros(256, dtype=bool)
_PLAIN[0x21:0x7F] = True
_PLAIN[ord("#")] = False
_PLAIN[[_TAB, _NEWLINE, _SPACE]] = True
_BLANK = np.zeros(256, dtype=bool)
_BLANK[[_TAB, _NEWLINE, _SPACE]] = True


@dataclass(frozen=True, eq=False)
class EdgeTable:
    """The edges of a list: ``index[k] = (a, b)`` links ``names[a]`` and ``names[b]``
    (distinct ids, in order of appearance); ``lines[k]`` is edge k's line."""

    names: list[str]
    index: npt.NDArray[np.int64]
    lines: npt.NDArray[np.int64]

    def pairs(self) -> tuple[tuple[str, str], ...]:
        """The edges as id pairs, each distinct id one shared string."""
        names = np.array(self.names, dtype=object)
        first, second = names[self.index[:, 0]].tolist(), names[self.index[:, 1]].tolist()
        return tuple(zip(first, second, strict=True))


def read_edge_list(path: str) -> EdgeTable:
    """Read the edge list at ``path``; errors start with the path or ``line N``.

    The file's size is checked against the machine's memory first
    (:data:`EDGE_LIST_MEMORY_PER_BYTE`), so that a list too large is refused unread; a
    FIFO or a device is refused unopened.  O(size).
    """
    handle, size = open_regular_file(path, path, stdin_hint=False, expected="an edge list")
    with handle:
        require_memory(
            size * EDGE_LIST_MEMORY_PER_BYTE, f"{path}: an edge list of {format_bytes(size)}"
        )
        try:
            return read_edges(handle, path)
        except OSError as exc:
            raise MissionError(f"{path}: cannot read ({exc.strerror or exc})") from None


def read_edges(handle: BinaryIO, name: str) -> EdgeTable:
    """The edges of an open binary stream (see the module notes); ``name`` starts the
    message of a byte that is not UTF-8."""
    reader = _Reader(name)
    for lines in _chunks(handle):
        chunk = b"".join(lines)
        if not reader.plain(chunk, len(lines)):
            reader.line_by_line(lines)
        reader.offset += len(chunk)
    return reader.table()


def _chunks(handle: BinaryIO) -> Iterator[list[bytes]]:
    while lines := handle.readlines(CHUNK_BYTES):
        yield lines


class _Reader:
    def __init__(self, name: str) -> None:
        self.name = name
        self.codes: dict[str, int] = {}
        self.names: list[str] = []
        self.index: list[npt.NDArray[np.int64]] = []
        self.lines: list[npt.NDArray[np.int64]] = []
        self.number = 0  # lines read so far, numbered as str.splitlines numbers them
        self.offset = 0  # bytes read so far

    def code(self, rid: str) -> int:
        found = self.codes.get(rid)
        if found is None:
            found = self.codes[rid] = len(self.names)
            self.names.append(rid)
        return found

    def plain(self, chunk: bytes, count: int) -> bool:
        """Take a chunk of plain ASCII lines whole; ``False`` (nothing taken) when it is
        not plain or not two distinct ids on every non-blank line."""
        octets = np.frombuffer(chunk, dtype=np.uint8)
        if not _PLAIN[octets].all():
            return False
        blank = _BLANK[octets]
        starts = np.flatnonzero(~blank & np.concatenate(([True], blank[:-1])))
        line_of = np.cumsum(octets == _NEWLINE)[starts]
        per_line = np.bincount(line_of, minlength=count)
        if not ((per_line == 0) | (per_line == 2)).all():
            return False
        words = np.array(chunk.split(), dtype=bytes)
        distinct, inverse = np.unique(words, return_inverse=True)
        codes = np.array([self.code(w.decode("ascii")) for w in distinct.tolist()], np.int64)
        pairs = codes[inverse.reshape(-1)].reshape(-1, 2)
        if (pairs[:, 0] == pairs[:, 1]).any():
            return False
        self.index.append(pairs)
        self.lines.append(np.flatnonzero(per_line == 2) + self.number + 1)
        self.number += count
        return True

    def line_by_line(self, lines: list[bytes]) -> None:
        """The general reading: UTF-8 checked per line, ``str.splitlines`` numbering,
        Unicode whitespace, ``#`` comments; the first mistake is an error."""
        pairs: list[tuple[int, int]] = []
        numbers: list[int] = []
        offset = self.offset
        for raw in lines:
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                where = offset + exc.start
                raise MissionError(
                    f"{self.name}: not UTF-8 text ({exc.reason} at byte {where})"
                ) from None
            offset += len(raw)
            for line in text.splitlines():
                self.number += 1
                words = (line.split("#", 1)[0] if "#" in line else line).split()
                if words:
                    pairs.append(self._pair(words))
                    numbers.append(self.number)
        self.index.append(np.array(pairs, dtype=np.int64).reshape(-1, 2))
        self.lines.append(np.array(numbers, dtype=np.int64))

    def _pair(self, words: list[str]) -> tuple[int, int]:
        if len(words) != 2:
            raise MissionError(
                f"line {self.number}: expected two robot ids, got {plural(len(words), 'word')}"
            )
        first, second = words
        if first == second:
            raise MissionError(f"line {self.number}: links robot {describe(first)} to itself")
        return self.code(first), self.code(second)

    def table(self) -> EdgeTable:
        index = np.concatenate([*self.index, np.empty((0, 2), dtype=np.int64)])
        lines = np.concatenate([*self.lines, np.empty(0, dtype=np.int64)])
        for array in (index, lines):
            array.setflags(write=False)
        return EdgeTable(self.names, index, lines)
