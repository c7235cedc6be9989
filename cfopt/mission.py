"""The mission: robots with services, tasks with service requirements and utilities.

A :class:`Mission` is the seed's services model (ST-MR-IA): robot ``i`` can perform
service ``s`` when ``capabilities[i, s]``; task ``j`` needs ``requirements[j, s]`` robots
performing ``s`` and earns ``utilities[j]`` only when all of its needs are met.
The file format is ``cfopt.mission/1`` (see :meth:`Mission.from_dict` and the README).
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt._jsonio import (
    Source,
    check_free_json,
    check_keys,
    check_output,
    check_text,
    expect_list,
    expect_object,
    layout_json,
    read_json,
    write_text,
)
from cfopt.checks import is_real, is_whole, shown
from cfopt.errors import MissionError, MissionTypeError, describe, is_unicode, key_path

__all__ = ["MAX_COUNT", "MISSION_FORMAT", "Mission", "MissionError"]

MISSION_FORMAT = "cfopt.mission/1"
#: The largest requirement count a task may state (counts are stored as int64 and
#: multiplied with each other in exact reward comparisons, so they are kept modest).
MAX_COUNT = 2**31 - 1

_TOP_REQUIRED = ("services", "robots", "tasks")
_TOP_OPTIONAL = ("format", "name", "metadata")


@dataclass(frozen=True, eq=False)
class Mission:
    """A coalition-formation mission under the services model (frozen).

    Parameters
    ----------
    services : sequence of str
        The service names, unique and non-empty; their order fixes the columns below.
    robot_ids, task_ids : sequence of str
        Unique non-empty ids (robots and tasks are separate namespaces).
    capabilities : array_like of bool, shape (n, S)
        ``capabilities[i, s]``: robot ``i`` can perform service ``s``.
    requirements : array_like of int, shape (m, S)
        ``requirements[j, s]``: robots task ``j`` needs for service ``s`` (0: not needed).
        Every task needs at least one service.
    utilities : array_like of float, shape (m,)
        Finite utilities >= 0.
    name : str, optional
    metadata : mapping, optional
        Free-form JSON data, kept as is.

    Notes
    -----
    The arrays are read-only copies.  Missions compare equal when every field does.
    Validation costs O(n S + m S).

    Examples
    --------
    >>> m = Mission.from_dict({
    ...     "services": ["survey", "lift"],
    ...     "robots": [{"id": "r0", "services": ["survey"]},
    ...                {"id": "r1", "services": ["survey", "lift"]}],
    ...     "tasks": [{"id": "t0", "utility": 12, "requires": {"survey": 1, "lift": 1}}]})
    >>> m.n_robots, m.n_tasks, m.n_services, m.total_utility
    (2, 1, 2, 12.0)
    >>> m.requirements
    array([[1, 1]])
    >>> Mission.from_dict(m.to_dict()) == m
    True
    """

    services: tuple[str, ...]
    robot_ids: tuple[str, ...]
    task_ids: tuple[str, ...]
    capabilities: npt.NDArray[np.bool_]
    requirements: npt.NDArray[np.int64]
    utilities: npt.NDArray[np.float64]
    name: str | None = None
    metadata: Mapping[str, Any] | None = field(default=None)

    def __post_init__(self) -> None:
        services = _id_tuple(self.services, "services", "service name")
        if not services:
            raise MissionError("services: must list at least one service")
        robot_ids = _id_tuple(self.robot_ids, "robots", "robot id", argument="robot_ids")
        task_ids = _id_tuple(self.task_ids, "tasks", "task id", argument="task_ids")
        n, m, s = len(robot_ids), len(task_ids), len(services)
        capabilities = _frozen_array(
            self.capabilities, np.bool_, (n, s), "capabilities", "robots x services"
        )
        requirements = _frozen_array(
            self.requirements, np.int64, (m, s), "requirements", "tasks x services"
        )
        utilities = _frozen_array(self.utilities, np.float64, (m,), "utilities", "tasks")
        _check_requirements(requirements, task_ids, services)
        _check_utilities(utilities, task_ids)
        if self.name is not None and (not isinstance(self.name, str) or not is_unicode(self.name)):
            kind = MissionError if isinstance(self.name, str) else MissionTypeError
            raise kind(f"name: must be a string of valid Unicode, got {describe(self.name)}")
        if self.metadata is not None and not isinstance(self.metadata, Mapping):
            raise MissionTypeError(f"metadata: must be an object, got {describe(self.metadata)}")
        if self.metadata is not None:
            check_free_json(self.metadata, "metadata")
        for attr, value in (
            ("services", services),
            ("robot_ids", robot_ids),
            ("task_ids", task_ids),
            ("capabilities", capabilities),
            ("requirements", requirements),
            ("utilities", utilities),
            ("metadata", None if self.metadata is None else _frozen_metadata(self.metadata)),
        ):
            object.__setattr__(self, attr, value)

    # ----------------------------------------------------------------- sizes and lookups
    @property
    def n_robots(self) -> int:
        """Number of robots ``n``."""
        return len(self.robot_ids)

    @property
    def n_tasks(self) -> int:
        """Number of tasks ``m``."""
        return len(self.task_ids)

    @property
    def n_services(self) -> int:
        """Number of service types ``S``."""
        return len(self.services)

    @cached_property
    def total_utility(self) -> float:
        """The sum of all task utilities (what a perfect assignment earns)."""
        return math.fsum(self.utilities.tolist())

    @cached_property
    def robot_index(self) -> Mapping[str, int]:
        """Robot id -> row index."""
        return {rid: i for i, rid in enumerate(self.robot_ids)}

    @cached_property
    def task_index(self) -> Mapping[str, int]:
        """Task id -> row index."""
        return {tid: j for j, tid in enumerate(self.task_ids)}

    @cached_property
    def service_index(self) -> Mapping[str, int]:
        """Service name -> column index."""
        return {name: s for s, name in enumerate(self.services)}

    # ---------------------------------------------------------------------- equality
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Mission):
            return NotImplemented
        return (
            self.services == other.services
            and self.robot_ids == other.robot_ids
            and self.task_ids == other.task_ids
            and np.array_equal(self.capabilities, other.capabilities)
            and np.array_equal(self.requirements, other.requirements)
            and np.array_equal(self.utilities, other.utilities)
            and self.name == other.name
            and self.metadata == other.metadata
        )

    __hash__ = None  # type: ignore[assignment]

    def __getstate__(self) -> dict[str, Any]:
        # mappingproxy does not pickle; missions travel to worker processes in sweeps
        state = {k: v for k, v in self.__dict__.items() if k in self.__dataclass_fields__}
        if state["metadata"] is not None:
            state["metadata"] = dict(state["metadata"])
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        for name in ("capabilities", "requirements", "utilities"):
            array = np.array(state[name], copy=True)
            array.setflags(write=False)
            state[name] = array
        if state["metadata"] is not None:
            state["metadata"] = _frozen_metadata(state["metadata"])
        self.__dict__.update(state)

    def __repr__(self) -> str:
        label = f" {self.name!r}" if self.name else ""
        return (
            f"<Mission{label}: {self.n_robots} robots, {self.n_tasks} tasks, "
            f"{self.n_services} services>"
        )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_arrays(
        cls,
        capabilities: npt.ArrayLike,
        requirements: npt.ArrayLike,
        utilities: npt.ArrayLike,
        *,
        services: Sequence[str] | None = None,
        robot_ids: Sequence[str] | None = None,
        task_ids: Sequence[str] | None = None,
        name: str | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> Mission:
        """Build a mission from arrays, naming robots ``r0..``, tasks ``t0..``, services ``s0..``.

        >>> Mission.from_arrays([[1, 0], [1, 1]], [[2, 0]], [5.0]).to_dict()["tasks"]
        [{'id': 't0', 'utility': 5, 'requires': {'s0': 2}}]
        """
        caps = _array(capabilities, "capabilities")
        reqs = _array(requirements, "requirements")
        if caps.ndim != 2 or reqs.ndim != 2:
            raise MissionError("capabilities and requirements must be 2-D arrays")
        n_services = caps.shape[1]
        return cls(
            services=services if services is not None else _names("s", n_services),
            robot_ids=robot_ids if robot_ids is not None else _names("r", caps.shape[0]),
            task_ids=task_ids if task_ids is not None else _names("t", reqs.shape[0]),
            capabilities=caps,
            requirements=reqs,
            utilities=_array(utilities, "utilities", float).reshape(-1),
            name=name,
            metadata=metadata,
        )

    @classmethod
    def from_dict(cls, data: Any) -> Mission:
        """Validate a ``cfopt.mission/1`` object (as parsed from JSON) and build the mission.

        The rules: ``format`` is optional and, when present, ``"cfopt.mission/1"``;
        ``services`` is a non-empty list of unique non-empty names; ``robots`` a list of
        objects with a unique non-empty ``id`` and a list ``services`` of declared,
        distinct names (may be empty); ``tasks`` a list of objects with a unique
        non-empty ``id`` (a namespace apart from the robots'), a finite ``utility`` >= 0
        (booleans are not numbers; all utilities together must add up to a finite
        float) and ``requires``, a non-empty map from declared services to whole numbers
        between 1 and 2**31 - 1 (``2.0`` is read as 2).  Ids and names are valid Unicode
        text.  ``name`` is an optional string and ``metadata`` an optional object of
        plain JSON data (finite numbers, at most 100 levels deep), kept as is.  Unknown
        keys are errors (they are almost always typos), except inside ``metadata``.

        Every rule is checked; the first broken one raises :class:`MissionError` naming
        the place, e.g. ``tasks[3].requires.lift: must be a whole number >= 1, got 2.5``.
        """
        return _parse_mission(data)

    @classmethod
    def from_json(cls, source: Source) -> Mission:
        """Load a mission file (a path or an open text stream).

        Errors start with the file's name: ``m.json: tasks[0].utility: ...``.
        """
        value, name = read_json(source)
        try:
            return _parse_mission(value)
        except MissionError as exc:
            raise exc.prefixed(name) from None

    # --------------------------------------------------------------------- writing
    def to_dict(self) -> dict[str, Any]:
        """The mission as a ``cfopt.mission/1`` object.

        The form is canonical: ``format`` is always written, each robot's services and
        each task's requirements are listed in the order of ``services``, whole-number
        utilities are written as integers.  ``from_dict(to_dict())`` gives back an equal
        mission, and a canonical object comes back unchanged.
        """
        out: dict[str, Any] = {"format": MISSION_FORMAT}
        if self.name is not None:
            out["name"] = self.name
        out["services"] = list(self.services)
        out["robots"] = [
            {"id": rid, "services": names}
            for rid, names in zip(self.robot_ids, self._robot_service_lists(), strict=True)
        ]
        names = self.services
        out["tasks"] = [
            {
                "id": tid,
                "utility": _json_number(u),
                "requires": {names[s]: int(row[s]) for s in np.flatnonzero(row)},
            }
            for tid, u, row in zip(
                self.task_ids, self.utilities.tolist(), self.requirements, strict=True
            )
        ]
        if self.metadata is not None:
            out["metadata"] = _deep_copy_json(self.metadata)
        return out

    def to_json(
        self, path: str | os.PathLike[str] | None = None, *, overwrite: bool = False
    ) -> str:
        """The mission as JSON text, one robot or task per line; written to ``path`` if given.

        The text is a pure function of the mission (same mission, same bytes).  An
        existing file is replaced only with ``overwrite=True``; ``/dev/null`` takes
        nothing, and a directory or a device is never written (``MissionError``).
        """
        check_output(path, overwrite)
        text = layout_json(self.to_dict())
        if path is not None:
            write_text(text, path, overwrite=overwrite)
        return text

    def _robot_service_lists(self) -> list[list[str]]:
        # Robots share few distinct service sets, so resolve names once per set.
        if self.n_robots == 0:
            return []
        kinds, which = np.unique(self.capabilities, axis=0, return_inverse=True)
        per_kind = [[self.services[s] for s in np.flatnonzero(kind)] for kind in kinds]
        return [list(per_kind[k]) for k in which.reshape(-1).tolist()]


# ---------------------------------------------------------------------- array checks
def _names(prefix: str, count: int) -> tuple[str, ...]:
    return tuple(f"{prefix}{i}" for i in range(count))


def _id_tuple(
    values: Sequence[str], place: str, what: str, *, argument: str | None = None
) -> tuple[str, ...]:
    if isinstance(values, str | bytes) or not isinstance(values, Iterable):
        raise MissionTypeError(
            f"{argument or place}: must be a sequence of strings ({what}s), got {shown(values)}"
        )
    out = tuple(values)
    seen: dict[str, int] = {}
    for index, value in enumerate(out):
        check_text(value, f"{place}[{index}]", f"a non-empty string ({what})")
        if value in seen:
            raise MissionError(
                f"{place}[{index}]: duplicate {what} {describe(value)} "
                f"(first at {place}[{seen[value]}])"
            )
        seen[value] = index
    return out


def _array(value: npt.ArrayLike, place: str, dtype: type | None = None) -> npt.NDArray[Any]:
    """``numpy.asarray(value)``, refusing what is not an array (ragged lists, text) by name."""
    try:
        return np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        what = "an array of numbers" if dtype is float else "an array"
        raise MissionError(f"{place}: must be {what}, got {shown(value)}") from None


def _frozen_array(
    value: npt.ArrayLike, dtype: type, shape: tuple[int, ...], place: str, axes: str
) -> npt.NDArray[Any]:
    raw = _array(value, place)
    if raw.size == 0:
        raw = raw.reshape(shape) if raw.size == math.prod(shape) else raw
    if raw.shape != shape:
        raise MissionError(f"{place}: expected shape {shape} ({axes}), got {raw.shape}")
    if dtype is np.int64:
        if raw.dtype.kind not in "iub":
            raise MissionError(f"{place}: must hold whole numbers, got dtype {raw.dtype}")
        if raw.dtype.kind == "u" and raw.size and raw.max() > MAX_COUNT:
            raise MissionError(f"{place}: counts must be at most {MAX_COUNT}")
    elif dtype is np.bool_ and raw.dtype.kind not in "bui":
        raise MissionError(f"{place}: must hold booleans, got dtype {raw.dtype}")
    elif (
        dtype is np.bool_ and raw.dtype.kind in "ui" and raw.size and not np.isin(raw, (0, 1)).all()
    ):
        raise MissionError(f"{place}: must hold only 0/1 or booleans")
    out = np.array(raw, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


def _check_requirements(
    requirements: npt.NDArray[np.int64], task_ids: tuple[str, ...], services: tuple[str, ...]
) -> None:
    bad = np.argwhere((requirements < 0) | (requirements > MAX_COUNT))
    if len(bad):
        j, s = bad[0]
        raise MissionError(
            f"{key_path(f'tasks[{j}].requires', services[s])}: must be a whole number "
            f"between 1 and {MAX_COUNT}, got {requirements[j, s]}"
        )
    empty = np.flatnonzero(~requirements.any(axis=1))
    if len(empty):
        raise MissionError(f"tasks[{empty[0]}].requires: must require at least one service")


def _check_utilities(utilities: npt.NDArray[np.float64], task_ids: tuple[str, ...]) -> None:
    bad = np.flatnonzero(~np.isfinite(utilities) | (utilities < 0))
    if len(bad):
        j = bad[0]
        raise MissionError(
            f"tasks[{j}].utility: must be a finite number >= 0, got {describe(utilities[j].item())}"
        )
    try:
        total = math.fsum(utilities.tolist())
    except OverflowError:
        total = math.inf
    if not math.isfinite(total):
        raise MissionError(
            "tasks: the utilities add up to more than the largest floating-point number "
            f"({sys.float_info.max:.6g}); scale them down"
        )


def _deep_copy_json(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _deep_copy_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_deep_copy_json(v) for v in value]
    return value


def _frozen_metadata(metadata: Mapping[str, Any]) -> Mapping[str, Any]:
    return MappingProxyType(_deep_copy_json(metadata))


def _json_number(value: float) -> int | float:
    """Whole numbers print as integers (``12`` not ``12.0``) when that is exact."""
    if value.is_integer() and abs(value) <= 2**53:
        return int(value)
    return value


# ---------------------------------------------------------------------- dict parsing
def _parse_mission(data: Any) -> Mission:
    top = expect_object(data, "")
    check_keys(top, "", _TOP_REQUIRED, _TOP_OPTIONAL)
    if "format" in top and top["format"] != MISSION_FORMAT:
        raise MissionError(f'format: must be "{MISSION_FORMAT}", got {describe(top["format"])}')
    name = top.get("name")
    if name is not None and not isinstance(name, str):
        raise MissionError(f"name: must be a string, got {describe(name)}")
    if "name" in top and name is None:
        raise MissionError("name: must be a string, got null")
    if name is not None and not is_unicode(name):
        raise MissionError(f"name: must be valid Unicode text, got {describe(name)}")
    services = _parse_services(top["services"])
    index = {s: k for k, s in enumerate(services)}
    robot_ids, capabilities = _parse_robots(top["robots"], index)
    task_ids, requirements, utilities = _parse_tasks(top["tasks"], index)
    metadata = None
    if "metadata" in top:
        metadata = expect_object(top["metadata"], "metadata")
    return Mission(
        services=services,
        robot_ids=robot_ids,
        task_ids=task_ids,
        capabilities=capabilities,
        requirements=requirements,
        utilities=utilities,
        name=name,
        metadata=metadata,
    )


def _parse_services(value: Any) -> tuple[str, ...]:
    items = expect_list(value, "services")
    if not items:
        raise MissionError("services: must list at least one service")
    for k, item in enumerate(items):
        check_text(item, f"services[{k}]")
    return _id_tuple(items, "services", "service name")


def _parse_id(obj: dict[str, Any], place: str) -> str:
    return check_text(obj["id"], f"{place}.id")


def _check_unique(value: str, place: str, seen: dict[str, str], what: str) -> None:
    if value in seen:
        raise MissionError(
            f"{place}.id: duplicate {what} id {describe(value)} (first at {seen[value]})"
        )
    seen[value] = place


def _unknown_service(place: str, name: Any, index: Mapping[str, int]) -> MissionError:
    declared = ", ".join(index)
    return MissionError(
        f"{place}: unknown service {describe(name)} (declared services: {declared})"
    )


def _parse_robots(value: Any, index: Mapping[str, int]) -> tuple[list[str], npt.NDArray[np.bool_]]:
    items = expect_list(value, "robots")
    capabilities = np.zeros((len(items), len(index)), dtype=bool)
    ids: list[str] = []
    seen: dict[str, str] = {}
    for i, item in enumerate(items):
        place = f"robots[{i}]"
        robot = expect_object(item, place)
        check_keys(robot, place, ("id", "services"))
        rid = _parse_id(robot, place)
        _check_unique(rid, place, seen, "robot")
        ids.append(rid)
        names = expect_list(robot["services"], f"{place}.services")
        row = capabilities[i]
        for k, name in enumerate(names):
            where = f"{place}.services[{k}]"
            column = index.get(name) if isinstance(name, str) else None
            if column is None:
                raise _unknown_service(where, name, index)
            if row[column]:
                raise MissionError(f"{where}: service {describe(name)} listed twice")
            row[column] = True
    return ids, capabilities


def _parse_count(value: Any, place: str) -> int:
    whole = is_whole(value) or (
        isinstance(value, float) and math.isfinite(value) and value.is_integer()
    )
    if not whole or value < 1:
        raise MissionError(f"{place}: must be a whole number >= 1, got {describe(value)}")
    if value > MAX_COUNT:
        raise MissionError(f"{place}: must be at most {MAX_COUNT}, got {describe(value)}")
    return int(value)


def _parse_utility(value: Any, place: str) -> float:
    number = is_real(value)
    converted = math.nan
    if number:
        try:
            converted = float(value)
        except OverflowError:
            converted = math.inf
    if not number or not math.isfinite(converted) or converted < 0:
        raise MissionError(f"{place}: must be a finite number >= 0, got {describe(value)}")
    return converted


def _parse_tasks(
    value: Any, index: Mapping[str, int]
) -> tuple[list[str], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    items = expect_list(value, "tasks")
    requirements = np.zeros((len(items), len(index)), dtype=np.int64)
    utilities = np.zeros(len(items), dtype=np.float64)
    ids: list[str] = []
    seen: dict[str, str] = {}
    for j, item in enumerate(items):
        place = f"tasks[{j}]"
        task = expect_object(item, place)
        check_keys(task, place, ("id", "utility", "requires"))
        tid = _parse_id(task, place)
        _check_unique(tid, place, seen, "task")
        ids.append(tid)
        utilities[j] = _parse_utility(task["utility"], f"{place}.utility")
        requires = expect_object(task["requires"], f"{place}.requires")
        if not requires:
            raise MissionError(f"{place}.requires: must require at least one service, got {{}}")
        for name, count in requires.items():
            where = key_path(f"{place}.requires", name)
            column = index.get(name)
            if column is None:
                raise _unknown_service(where, name, index)
            requirements[j, column] = _parse_count(count, where)
    return ids, requirements, utilities
