"""Who does what: an assignment of robots to (task, service) slots, and what it earns."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cfopt._jsonio import (
    Source,
    check_keys,
    check_output,
    expect_list,
    expect_object,
    layout_json,
    read_json,
    write_text,
)
from cfopt.checks import is_whole, require_int, require_mission, shown
from cfopt.errors import MissionError, MissionTypeError, describe
from cfopt.mission import Mission

__all__ = ["ASSIGNMENT_FORMAT", "UNASSIGNED", "Assignment"]

ASSIGNMENT_FORMAT = "cfopt.assignment/1"
#: The marker for "no task" (the seed's void task) in :attr:`Assignment.task`.
UNASSIGNED = -1


@dataclass(frozen=True, eq=False)
class Assignment:
    """Per robot a (task, service) slot, or unassigned (frozen).

    Parameters
    ----------
    task, service : array_like of int, shape (n,)
        ``task[i]`` is the row of robot ``i``'s task and ``service[i]`` the column of the
        service it performs there, both ``-1`` (:data:`UNASSIGNED`) for a robot on the
        void task.

    Notes
    -----
    An assignment does not hold its mission; methods that need one take it and check
    that the assignment fits it (one slot per robot by construction, only services the
    robot has, only services the task requires).  Counting is O(n + m S) with numpy.

    Examples
    --------
    >>> from cfopt import Mission
    >>> m = Mission.from_arrays([[1, 0], [0, 1], [1, 1]], [[1, 1], [2, 0]], [10, 4])
    >>> a = Assignment(task=[0, 0, -1], service=[0, 1, -1])
    >>> a.utility(m), a.completed_tasks(m).tolist(), a.percent_utility(m)
    (10.0, [0], 71.42857142857143)
    >>> a.to_dict(m)["assignment"][1]
    {'robot': 'r1', 'task': 't0', 'service': 's1'}
    """

    task: npt.NDArray[np.int64]
    service: npt.NDArray[np.int64]

    def __post_init__(self) -> None:
        task = _index_array(self.task, "task")
        service = _index_array(self.service, "service")
        if task.shape != service.shape:
            raise MissionError(
                "assignment: task and service arrays differ in length "
                f"({task.size} vs {service.size})"
            )
        half = np.flatnonzero((task < 0) != (service < 0))
        if len(half):
            raise MissionError(
                f"assignment: robot {half[0]} has a task without a service "
                "or a service without a task"
            )
        object.__setattr__(self, "task", task)
        object.__setattr__(self, "service", service)

    # ------------------------------------------------------------------ construction
    @classmethod
    def empty(cls, mission: Mission | int) -> Assignment:
        """Every robot unassigned (the seed's initial partition) of ``mission``, or of that
        many robots."""
        if isinstance(mission, Mission):
            n = mission.n_robots
        elif is_whole(mission):
            n = require_int("mission", mission, minimum=0)
        else:
            raise MissionTypeError(
                f"mission: must be a cfopt.Mission or a number of robots, got {shown(mission)}"
            )
        blank = np.full(n, UNASSIGNED, dtype=np.int64)
        return cls(task=blank, service=blank)

    @classmethod
    def from_dict(cls, mission: Mission, data: Any) -> Assignment:
        """Validate a ``cfopt.assignment/1`` object against ``mission`` and build it.

        A robot that is not listed is unassigned.  A robot listed twice, an unknown
        robot, task or service, a service the robot does not have or one the task does
        not require raise :class:`MissionError` naming the entry.
        """
        return _parse_assignment(require_mission(mission), data)

    @classmethod
    def from_json(cls, mission: Mission, source: Source) -> Assignment:
        """Load an assignment file (path or text stream) for ``mission``."""
        require_mission(mission)
        value, name = read_json(source)
        try:
            return _parse_assignment(mission, value)
        except MissionError as exc:
            raise exc.prefixed(name) from None

    # --------------------------------------------------------------------- checking
    def validate(self, mission: Mission) -> None:
        """Raise :class:`MissionError` unless this assignment is valid for ``mission``."""
        require_mission(mission)
        n, m, s = mission.n_robots, mission.n_tasks, mission.n_services
        if self.task.size != n:
            raise MissionError(f"assignment: has {self.task.size} robots, the mission has {n}")
        assigned = np.flatnonzero(self.task >= 0)
        tasks, services = self.task[assigned], self.service[assigned]
        out_of_range = assigned[(tasks >= m) | (services >= s)]
        if len(out_of_range):
            i = out_of_range[0]
            raise MissionError(
                f"assignment: robot {mission.robot_ids[i]!r} has task {self.task[i]} / "
                f"service {self.service[i]}, the mission has {m} tasks and {s} services"
            )
        lacking = assigned[~mission.capabilities[assigned, services]]
        if len(lacking):
            i = lacking[0]
            raise MissionError(
                f"assignment: robot {mission.robot_ids[i]!r} cannot perform service "
                f"{mission.services[self.service[i]]!r}"
            )
        unneeded = assigned[mission.requirements[tasks, services] == 0]
        if len(unneeded):
            i = unneeded[0]
            raise MissionError(
                f"assignment: robot {mission.robot_ids[i]!r} performs "
                f"{mission.services[self.service[i]]!r} for task "
                f"{mission.task_ids[self.task[i]]!r}, which does not require it"
            )

    # ------------------------------------------------------------------- evaluating
    @property
    def n_assigned(self) -> int:
        """How many robots are on a real task."""
        return int(np.count_nonzero(self.task >= 0))

    def counts(self, mission: Mission) -> npt.NDArray[np.int64]:
        """Robots per slot: ``counts[j, s]`` robots perform ``s`` for task ``j`` (m x S)."""
        self.validate(mission)
        m, s = mission.n_tasks, mission.n_services
        assigned = self.task >= 0
        flat = self.task[assigned] * s + self.service[assigned]
        return np.bincount(flat, minlength=m * s).reshape(m, s)

    def completed_tasks(self, mission: Mission) -> npt.NDArray[np.intp]:
        """Indices (ascending) of the tasks whose every requirement is met."""
        met = self.counts(mission) >= mission.requirements
        return np.flatnonzero(met.all(axis=1))

    def utility(self, mission: Mission) -> float:
        """The utility earned: the sum of the completed tasks' utilities."""
        completed = self.completed_tasks(mission)
        return math.fsum(mission.utilities[completed].tolist())

    def percent_utility(self, mission: Mission) -> float:
        """Utility as a percentage of the mission's total (100 when there is nothing to earn)."""
        utility = self.utility(mission)
        total = mission.total_utility
        return 100.0 if total == 0 else 100.0 * (utility / total)  # no overflow

    # ---------------------------------------------------------------------- writing
    def to_dict(self, mission: Mission) -> dict[str, Any]:
        """The ``cfopt.assignment/1`` object, assigned robots in mission order."""
        self.validate(mission)
        rids, tids, names = mission.robot_ids, mission.task_ids, mission.services
        rows = [
            {"robot": rids[i], "task": tids[j], "service": names[s]}
            for i, j, s in zip(
                np.flatnonzero(self.task >= 0).tolist(),
                self.task[self.task >= 0].tolist(),
                self.service[self.task >= 0].tolist(),
                strict=True,
            )
        ]
        return {"format": ASSIGNMENT_FORMAT, "assignment": rows}

    def to_json(
        self,
        mission: Mission,
        path: str | os.PathLike[str] | None = None,
        *,
        overwrite: bool = False,
    ) -> str:
        """The assignment as JSON text (one entry per line); written to ``path`` if given
        (as :meth:`Mission.to_json` writes)."""
        check_output(path, overwrite)
        text = layout_json(self.to_dict(mission))
        if path is not None:
            write_text(text, path, overwrite=overwrite)
        return text

    # --------------------------------------------------------------------- equality
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Assignment):
            return NotImplemented
        return np.array_equal(self.task, other.task) and np.array_equal(self.service, other.service)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"<Assignment: {self.n_assigned} of {self.task.size} robots assigned>"


def _index_array(value: npt.ArrayLike, place: str) -> npt.NDArray[np.int64]:
    raw = np.asarray(value)
    if raw.size == 0:
        raw = raw.reshape(0)
    if raw.ndim != 1:
        raise MissionError(f"assignment.{place}: must be 1-D, got shape {raw.shape}")
    if raw.dtype.kind not in "iu":
        raise MissionError(f"assignment.{place}: must hold whole numbers, got dtype {raw.dtype}")
    out = raw.astype(np.int64, copy=True)
    if out.size and out.min() < UNASSIGNED:
        raise MissionError(f"assignment.{place}: indices must be >= -1")
    out.setflags(write=False)
    return out


def _parse_assignment(mission: Mission, data: Any) -> Assignment:
    top = expect_object(data, "")
    check_keys(top, "", ("assignment",), ("format",))
    if "format" in top and top["format"] != ASSIGNMENT_FORMAT:
        raise MissionError(f'format: must be "{ASSIGNMENT_FORMAT}", got {describe(top["format"])}')
    entries = expect_list(top["assignment"], "assignment")
    task = np.full(mission.n_robots, UNASSIGNED, dtype=np.int64)
    service = np.full(mission.n_robots, UNASSIGNED, dtype=np.int64)
    first_seen: dict[int, int] = {}
    for k, item in enumerate(entries):
        place = f"assignment[{k}]"
        entry = expect_object(item, place)
        check_keys(entry, place, ("robot", "task", "service"))
        i = _lookup(entry["robot"], mission.robot_index, f"{place}.robot", "robot")
        j = _lookup(entry["task"], mission.task_index, f"{place}.task", "task")
        s = _lookup(entry["service"], mission.service_index, f"{place}.service", "service")
        if i in first_seen:
            raise MissionError(
                f"{place}.robot: robot {describe(entry['robot'])} is listed twice "
                f"(first at assignment[{first_seen[i]}])"
            )
        first_seen[i] = k
        if not mission.capabilities[i, s]:
            raise MissionError(
                f"{place}.service: robot {describe(entry['robot'])} cannot perform "
                f"{describe(entry['service'])}"
            )
        if not mission.requirements[j, s]:
            raise MissionError(
                f"{place}.service: task {describe(entry['task'])} does not require "
                f"{describe(entry['service'])}"
            )
        task[i], service[i] = j, s
    return Assignment(task=task, service=service)


def _lookup(value: Any, index: Any, place: str, what: str) -> int:
    found = index.get(value) if isinstance(value, str) else None
    if found is None:
        raise MissionError(f"{place}: unknown {what} {describe(value)}")
    return int(found)
