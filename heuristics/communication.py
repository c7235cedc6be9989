"""Communication models: how the centralized engines count their messages and bytes.

A model is a *medium* and an *encoding* (:class:`CommModel`).

Medium
------
``"broadcast"`` (default, the seed's: "All communication was non-blocking to model a
robot using UDP broadcasts").  A robot's send of one message to all its neighbours is
**one transmission** of that message's size, received by every neighbour.  On the
fully connected network of the centralized engines a round in which every robot
broadcasts costs ``n`` transmissions (none when ``n < 2``: a robot without neighbours
sends nothing).

``"unicast"``: one message per receiver (point to point), so the same round costs
``n (n - 1)`` messages.  This was cfopt's only model before; :func:`heuristics.broadcast_cost`
still counts it.

Messages addressed to one agent (a chain request, an SDA bid or its answer) are *direct*:
one transmission per message under both media.  Only a message whose content is the same
for all its receivers (a belief, an auction announcement) is *broadcast-able*; each
engine's docstring says which of its kinds are which.

Encoding
--------
Of a *belief* ``(r, time, Pi)`` -- the partition every GRAPE-S robot sends each round --
of ``n`` robots on a mission of ``m`` tasks and ``S`` services:

``"full"`` (default): a :data:`HEADER_BYTES` = 16-byte header (int32 evolution number
``r``, int32 sender id, int64 time stamp), then one int32 slot per robot (``j S + s``, -1
unassigned): ``16 + 4 n`` bytes.

``"compact"``: the same header, then the slots bit-packed, :func:`slot_bits` ``= ceil(log2(m S
+ 1))`` bits per robot (a value in ``0 .. m S``: the slot index ``j S + s`` or ``m S`` for
unassigned), the bit string rounded up to whole bytes: ``16 + ceil(n b / 8)`` bytes.

A belief with further fields packed as bits (GRAPE-S-Select's two task bits per task) adds
them to the bit string: ``full`` ``16 + 4 n + ceil(extra / 8)``, ``compact`` ``16 + ceil((n
b + extra) / 8)``.  The encoding applies to beliefs only: direct messages and the auctions'
announcements (which carry no partition) keep their documented layouts under both.

Every count is an exact Python integer.

Examples
--------
>>> model = CommModel()                      # the default: broadcast, full
>>> model.belief_bytes(100, n_slots=50)      # 16 + 4 x 100
416
>>> model.rounds_cost(100, 101, 416)         # 101 rounds x 100 transmissions
(10100, 4201600)
>>> CommModel("unicast").rounds_cost(100, 101, 416)   # 101 x 100 x 99 messages
(999900, 415958400)
>>> CommModel(encoding="compact").belief_bytes(100, n_slots=50)  # 6 bits: 16 + 75
91
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cfopt import MissionError

__all__ = [
    "DEFAULT_MODEL",
    "ENCODINGS",
    "HEADER_BYTES",
    "MEDIA",
    "MODELS",
    "ROBOT_ENTRY_BYTES",
    "CommModel",
    "Table",
    "belief_rounds_table",
    "belief_size",
    "comm_model",
    "communication_table",
    "media_table",
    "slot_bits",
    "table_cost",
]

#: The media: one transmission per send, or one message per receiver.
MEDIA = ("broadcast", "unicast")
#: The belief encodings: int32 per robot, or bit-packed slots.
ENCODINGS = ("full", "compact")
#: Bytes of a belief's header: int32 evolution number ``r``, int32 sender, int64 time stamp.
HEADER_BYTES = 16
#: Bytes per robot of a ``full`` belief: one int32 slot index ``j * S + s`` (-1 void).
ROBOT_ENTRY_BYTES = 4

#: A run's communication table: ``(medium, encoding, messages, bytes)`` per model.
Table = tuple[tuple[str, str, int, int], ...]


@dataclass(frozen=True)
class CommModel:
    """A communication model: the medium and the belief encoding (frozen, validated).

    Parameters
    ----------
    medium : {"broadcast", "unicast"}, default "broadcast"
        ``"broadcast"``: a send to all neighbours is one transmission of its size;
        ``"unicast"``: one message per receiver.  Direct messages are one transmission
        per message under both.
    encoding : {"full", "compact"}, default "full"
        ``"full"``: a belief is ``16 + 4 n`` bytes; ``"compact"``: ``16 + ceil(n b / 8)``
        bytes with ``b = ceil(log2(m S + 1))`` (module notes).

    Raises
    ------
    cfopt.MissionError
        A value that is not one of the known ones (the message names it and them).

    Examples
    --------
    >>> CommModel("unicast", "compact").label
    'unicast/compact'
    >>> CommModel("udp")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: medium: must be one of broadcast, unicast, got 'udp'
    """

    medium: str = "broadcast"
    encoding: str = "full"

    def __post_init__(self) -> None:
        if not isinstance(self.medium, str) or self.medium not in MEDIA:
            raise MissionError(f"medium: must be one of {', '.join(MEDIA)}, got {self.medium!r}")
        if not isinstance(self.encoding, str) or self.encoding not in ENCODINGS:
            raise MissionError(
                f"encoding: must be one of {', '.join(ENCODINGS)}, got {self.encoding!r}"
            )

    @property
    def label(self) -> str:
        """``"medium/encoding"``."""
        return f"{self.medium}/{self.encoding}"

    @property
    def options(self) -> tuple[tuple[str, str], tuple[str, str]]:
        """``(("medium", ...), ("encoding", ...))``, as a run's ``options`` record them."""
        return (("medium", self.medium), ("encoding", self.encoding))

    def belief_bytes(self, n_robots: int, n_slots: int, extra_bits: int = 0) -> int:
        """Size of one belief of ``n_robots`` robots on ``n_slots = m S`` slots under this
        model's encoding (:func:`belief_size`)."""
        return belief_size(n_robots, n_slots, encoding=self.encoding, extra_bits=extra_bits)

    def rounds_cost(self, n_robots: int, rounds: int, size: int) -> tuple[int, int]:
        """Messages and bytes of ``rounds`` rounds in which each of ``n_robots`` fully
        connected robots sends one ``size``-byte message to all the others.

        Broadcast: ``rounds n`` transmissions (0 when ``n < 2``); unicast: ``rounds n (n -
        1)`` messages; each of ``size`` bytes.

        >>> CommModel().rounds_cost(3, 4, 28), CommModel("unicast").rounds_cost(3, 4, 28)
        ((12, 336), (24, 672))
        """
        per_round = n_robots if n_robots >= 2 else 0
        if self.medium == "unicast":
            per_round = n_robots * max(n_robots - 1, 0)
        messages = rounds * per_round
        return messages, messages * size

    def announce(self, receivers: int) -> int:
        """Messages of one sender's message with the same content for ``receivers``
        receivers: 1 under broadcast (0 without receivers), ``receivers`` under unicast.

        >>> CommModel().announce(5), CommModel().announce(0), CommModel("unicast").announce(5)
        (1, 0, 5)
        """
        if self.medium == "unicast":
            return receivers
        return 1 if receivers > 0 else 0


#: The default model: the seed's UDP broadcasts with cfopt's full belief encoding.
DEFAULT_MODEL = CommModel()
#: Every model, in the order of a run's communication table.
MODELS: tuple[CommModel, ...] = tuple(CommModel(md, en) for md in MEDIA for en in ENCODINGS)


def comm_model(medium: Any = "broadcast", encoding: Any = "full") -> CommModel:
    """The validated :class:`CommModel` of these keyword values (what the engines call)."""
    return CommModel(medium, encoding)


def slot_bits(n_slots: int) -> int:
    """Bits of one robot's slot in a compact belief: ``ceil(log2(n_slots + 1))``, the
    values ``0 .. n_slots - 1`` being the slots and ``n_slots`` "unassigned".

    >>> slot_bits(0), slot_bits(1), slot_bits(3), slot_bits(4), slot_bits(50)
    (0, 1, 2, 3, 6)
    """
    if n_slots < 0:
        raise MissionError(f"n_slots: must be >= 0, got {n_slots!r}")
    return int(n_slots).bit_length()  # = ceil(log2(n_slots + 1)) exactly, for n_slots >= 0


def belief_size(
    n_robots: int, n_slots: int | None = None, *, encoding: str = "full", extra_bits: int = 0
) -> int:
    """Bytes of one belief of ``n_robots`` robots (module notes).

    Parameters
    ----------
    n_robots : int
    n_slots : int, optional
        ``m S``, the number of (task, service) slots; needed for ``"compact"``.
    encoding : {"full", "compact"}
    extra_bits : int, default 0
        Further bit-packed fields of the belief (GRAPE-S-Select: ``2 m`` task bits).

    Returns
    -------
    int
        ``full``: ``16 + 4 n + ceil(extra_bits / 8)``; ``compact``: ``16 + ceil((n
        slot_bits(n_slots) + extra_bits) / 8)``.

    Examples
    --------
    >>> belief_size(3), belief_size(3, 2, encoding="compact")   # 16 + 12; 16 + ceil(6 / 8)
    (28, 17)
    >>> belief_size(1000, 500, encoding="compact")                # 9 bits: 16 + 1125
    1141
    """
    if encoding not in ENCODINGS:
        raise MissionError(f"encoding: must be one of {', '.join(ENCODINGS)}, got {encoding!r}")
    if encoding == "full":
        return HEADER_BYTES + ROBOT_ENTRY_BYTES * n_robots + -(-extra_bits // 8)
    if n_slots is None:
        raise MissionError("n_slots: a compact belief's size needs the number of slots m S")
    return HEADER_BYTES + -(-(n_robots * slot_bits(n_slots) + extra_bits) // 8)


def communication_table(cost: Callable[[CommModel], tuple[int, int]]) -> Table:
    """``(medium, encoding, messages, bytes)`` of every model of :data:`MODELS`, from a
    function giving one model's ``(messages, bytes)``.

    >>> communication_table(lambda c: c.rounds_cost(3, 4, c.belief_bytes(3, 2)))[:2]
    (('broadcast', 'full', 12, 336), ('broadcast', 'compact', 12, 204))
    """
    return tuple((c.medium, c.encoding, *map(int, cost(c))) for c in MODELS)  # type: ignore[misc]


def media_table(unicast: tuple[int, int], broadcast: tuple[int, int]) -> Table:
    """The communication table of a run that sends no beliefs (the auctions): ``(messages,
    bytes)`` counted point to point for the unicast rows, and with each announcement as
    one transmission for the broadcast rows; the encoding changes nothing.

    >>> media_table((41, 820), (24, 480))[::2]
    (('broadcast', 'full', 24, 480), ('unicast', 'full', 41, 820))
    """
    return communication_table(lambda c: unicast if c.medium == "unicast" else broadcast)


def belief_rounds_table(
    n_robots: int,
    n_slots: int,
    rounds: int,
    *,
    extra_bits: int = 0,
    direct: tuple[int, int] = (0, 0),
) -> Table:
    """The communication table of a GRAPE-S-like run: ``rounds`` rounds in which every
    robot sends its belief to all the others (:meth:`CommModel.rounds_cost` of
    :meth:`CommModel.belief_bytes`), plus ``direct = (messages, bytes)`` of direct
    messages, the same under every model.

    >>> for row in belief_rounds_table(3, 2, 4, direct=(2, 56)):
    ...     print(row)
    ('broadcast', 'full', 14, 392)
    ('broadcast', 'compact', 14, 260)
    ('unicast', 'full', 26, 728)
    ('unicast', 'compact', 26, 464)
    """

    def cost(c: CommModel) -> tuple[int, int]:
        size = c.belief_bytes(n_robots, n_slots, extra_bits)
        messages, nbytes = c.rounds_cost(n_robots, rounds, size)
        return messages + direct[0], nbytes + direct[1]

    return communication_table(cost)


def table_cost(table: Table, model: CommModel) -> tuple[int, int]:
    """``(messages, bytes)`` of ``model`` in a communication table."""
    for medium, encoding, messages, nbytes in table:
        if (medium, encoding) == (model.medium, model.encoding):
            return messages, nbytes
    raise MissionError(f"the run's communication table has no {model.label} row")
