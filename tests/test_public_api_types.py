"""Every public callable, called with a wrong argument, says which argument is wrong.

The callables are enumerated from ``__all__`` of ``cfopt``, ``heuristics``, ``proofs`` and
``proofs.strategies``: every function, every class's constructor and every public method
(bound to a real instance).  Each is called with real, valid arguments (real missions,
real assignments) except one, which gets a value drawn from :data:`WRONG`.  The only
exceptions allowed are :class:`TypeError` and :class:`ValueError` (``cfopt.MissionError``
is one) whose message names that argument; ``AttributeError``, ``KeyError``,
``IndexError``, ``OverflowError``, ``ZeroDivisionError``... are failures.  A value that
does not fit the parameter's annotation (a list for ``capped: bool``, ``True`` for a
seed) must be refused; one that fits may be accepted.

Left out: enums (``ExactStatus``, standard library behaviour) and exception classes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import inspect
import io
import math
import numbers
import os
import re
import tempfile
import types
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
import heuristics
import proofs
import proofs.strategies
from cfopt import Assignment, GridCell, Mission

# ------------------------------------------------------------------ real arguments
MISSION = Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 1], [0, 1]], [5.0, 3.0])
ASSIGNMENT = Assignment(task=[0, 0, 1], service=[0, 1, 1])
CELL = GridCell(robots=6, percent_tasks=50, service_types=2, services_per_robot=1)
MOVE = proofs.Move(robot=0, source=(0, 0), target=None)
RESULT = cfopt.solve_exact(MISSION)
RUN = heuristics.grape_s(MISSION)
#: One real instance of every public class, for its methods and its constructor's fields.
INSTANCES: dict[type, Any] = {
    Assignment: ASSIGNMENT,
    Mission: MISSION,
    GridCell: CELL,
    cfopt.ExactResult: RESULT,
    heuristics.Run: RUN,
    proofs.Move: MOVE,
    proofs.NashViolation: proofs.NashViolation(robot=0, source=(0, 0), target=None),
    proofs.PairwiseViolation: proofs.PairwiseViolation(robots=(0,), moves=(MOVE,)),
}
FOLDER = Path(tempfile.mkdtemp(prefix="cfopt-api-types-"))
MISSION_FILE = FOLDER / "mission.json"
MISSION_FILE.write_text(MISSION.to_json(), encoding="utf-8")
ASSIGNMENT_FILE = FOLDER / "assignment.json"
ASSIGNMENT_FILE.write_text(ASSIGNMENT.to_json(MISSION), encoding="utf-8")
#: A launcher that does not exist: an ``mpi_run`` that passed its argument checks stops at
#: the launcher (``backend: ...``) instead of starting MPI processes.
NO_LAUNCHER = {"CFOPT_MPIEXEC": str(FOLDER / "no-such-mpiexec")}

#: Valid values of the required parameters, by name, then by callable where names clash.
REQUIRED: dict[str, Any] = {
    "mission": MISSION,
    "assignment": ASSIGNMENT,
    "index": 0,
    "n_robots": 4,
    "rounds": 2,
    "seconds": 1.0,
    "algorithm": "grape-s",
    "network": "complete sync=true",
    "name": "grape-s",
    "capabilities": MISSION.capabilities,
    "requirements": MISSION.requirements,
    "utilities": MISSION.utilities,
}
REQUIRED_BY_CALLABLE: dict[str, dict[str, Any]] = {
    "Mission.from_dict": {"data": MISSION.to_dict()},
    "Mission.from_json": {"source": str(MISSION_FILE)},
    "Assignment.from_dict": {"data": ASSIGNMENT.to_dict(MISSION)},
    "Assignment.from_json": {"source": str(ASSIGNMENT_FILE)},
    "generate_mission": {
        "robots": 6,
        "percent_tasks": 50,
        "service_types": 2,
        "services_per_robot": 1,
    },
}
REQUIRED_BY_CALLABLE["require_mission"] = {"value": MISSION}
REQUIRED_BY_CALLABLE["generate_with_witness"] = REQUIRED_BY_CALLABLE["generate_mission"]
#: Parameters whose errors name another word: the thing the argument is.
ALIASES = {
    "get_algorithm.name": "algorithm",
    "run_algorithm.name": "algorithm",
    "require_mission.value": "mission",
    # a mission's arrays and ids are checked at the places of its file format
    "Mission.robot_ids": "robots",
    "Mission.task_ids": "tasks",
    "Mission.from_arrays.robot_ids": "robots",
    "Mission.from_arrays.task_ids": "tasks",
    "Mission.utilities": "utility",
    "Mission.from_arrays.utilities": "utility",
}
#: Parameters holding a JSON document: its errors name the place in the document.
DOCUMENTS = {"data"}


@dataclasses.dataclass(frozen=True)
class Target:
    """One public callable and how to call it with valid arguments."""

    id: str
    call: Callable[..., Any]
    hints: dict[str, Any]
    valid: dict[str, Any]

    def __str__(self) -> str:
        return self.id


def _hints(function: Callable[..., Any]) -> dict[str, Any]:
    namespace = {**vars(cfopt), **vars(heuristics)}
    return typing.get_type_hints(function, localns=namespace)


def _valid(target_id: str, function: Callable[..., Any], owner: type | None) -> dict[str, Any]:
    valid: dict[str, Any] = {}
    fields = inspect.isclass(function) and dataclasses.is_dataclass(function)
    for p in inspect.signature(function).parameters.values():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if fields:
            valid[p.name] = getattr(INSTANCES[function], p.name)
        elif p.name in REQUIRED_BY_CALLABLE.get(target_id, {}):
            valid[p.name] = REQUIRED_BY_CALLABLE[target_id][p.name]
        elif p.default is not p.empty:
            valid[p.name] = p.default
        else:
            assert p.name in REQUIRED, f"{target_id}: give a valid value for {p.name!r}"
            valid[p.name] = REQUIRED[p.name]
    return valid


def _members(owner: type) -> Iterator[tuple[str, Callable[..., Any]]]:
    instance = INSTANCES[owner]
    for name, raw in vars(owner).items():
        if name.startswith("_") or isinstance(raw, property | staticmethod):
            continue
        if isinstance(raw, classmethod):
            yield name, getattr(owner, name)
        elif inspect.isfunction(raw):
            yield name, getattr(instance, name)


def _public(module: types.ModuleType) -> Iterator[tuple[str, Callable[..., Any]]]:
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.ismodule(obj) or not callable(obj):
            continue
        if inspect.isclass(obj) and issubclass(obj, BaseException | __import__("enum").Enum):
            continue
        yield name, obj
        if inspect.isclass(obj):
            for member, method in _members(obj):
                yield f"{name}.{member}", method


def targets() -> list[Target]:
    out = []
    for module in (cfopt, heuristics, proofs, proofs.strategies):
        for name, function in _public(module):
            hints = _hints(function.__init__ if inspect.isclass(function) else function)
            owner = function if inspect.isclass(function) else None
            out.append(Target(name, function, hints, _valid(name, function, owner)))
    return out


TARGETS = targets()
CASES = [(t, name) for t in TARGETS for name in t.valid]


# ---------------------------------------------------------------- what fits a hint
def fits(value: Any, hint: Any) -> bool:
    """Whether ``value`` is of the type the annotation ``hint`` states (loosely: the
    container, not its items; anything array-like for an array)."""
    if hint is Any or hint == npt.ArrayLike:
        return True
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(fits(value, arg) for arg in typing.get_args(hint))
    if origin is typing.Literal:
        return isinstance(value, str) and value in typing.get_args(hint)
    if origin is np.ndarray:
        return True
    if origin is not None:
        return _fits_class(value, origin)
    if hint is type(None):
        return value is None
    return _fits_class(value, hint)


def _fits_class(value: Any, kind: Any) -> bool:
    if kind is bool:
        return isinstance(value, bool | np.bool_)
    if kind is int:
        return isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if kind is float:
        return isinstance(value, numbers.Real) and not isinstance(value, bool)
    if kind is tuple:
        return isinstance(value, tuple | list)
    if kind is typing.IO:
        return hasattr(value, "read")
    if kind is Callable or kind is __import__("collections.abc").abc.Callable:
        return callable(value)
    return isinstance(value, kind)


# ------------------------------------------------------------------- wrong values
WRONG = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=-1),
    st.integers(0, 3),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.5, -0.0, 1e300]),
    st.text(max_size=4),
    st.from_type(bytes),
    st.from_type(complex),
    st.lists(st.integers(-2, 2), max_size=2),
    st.dictionaries(st.text(max_size=2), st.integers(), max_size=1),
    st.builds(object),
    st.just(MISSION),
    st.just(ASSIGNMENT),
    st.builds(io.StringIO, st.text(max_size=4)),
)


def names(message: str, word: str) -> bool:
    return re.search(rf"(?<![\w]){re.escape(word)}\b", message) is not None


def _named(target: Target, name: str, value: Any, exc: BaseException) -> bool:
    message = str(exc)
    if names(message, name) or names(message, ALIASES.get(f"{target.id}.{name}", name)):
        return True
    if name in DOCUMENTS and isinstance(exc, cfopt.MissionError):
        return True
    # a file's errors start with its name (a path, or a stream's name)
    if not isinstance(exc, cfopt.MissionError) or not fits("x", target.hints.get(name)):
        return False
    if isinstance(value, str | os.PathLike):
        return message.startswith(f"{os.fspath(value)}:")
    return hasattr(value, "read") and message.startswith(f"{getattr(value, 'name', '<stream>')}:")


def _accepted(target: Target, exc: BaseException) -> bool:
    """An ``mpi_run`` that got as far as its (missing) launcher accepted its arguments."""
    return target.id == "mpi_run" and str(exc).startswith("backend:")


def call_with(target: Target, name: str, value: Any) -> None:
    """Call ``target`` with ``name=value``: it must refuse ``value`` naming ``name``, or
    (if ``value`` fits the annotation) may accept it."""
    arguments = {**target.valid, name: value}
    with contextlib.chdir(FOLDER), mock.patch.dict(os.environ, NO_LAUNCHER):
        try:
            target.call(**arguments)
        except (TypeError, ValueError) as exc:
            if _accepted(target, exc):
                return
            assert _named(target, name, value, exc), (
                f"{target}({name}={value!r}) raised {type(exc).__name__} not naming {name!r}: {exc}"
            )
            return
    assert fits(value, target.hints.get(name, Any)), f"{target}({name}={value!r}) was accepted"


EXAMPLES = max(4, settings.default.max_examples // 6)


def test_every_public_callable_is_covered():
    ids = {t.id for t in TARGETS}
    assert {"grape_s", "Assignment.empty", "GridCell.mission", "nash_violations"} <= ids
    assert "Run.to_dict" in ids and "missions" in ids and len(CASES) > 100


@pytest.mark.parametrize(("target", "name"), CASES, ids=[f"{t}-{n}" for t, n in CASES])
@settings(max_examples=EXAMPLES)
@given(value=WRONG)
def test_wrong_argument_is_named(target: Target, name: str, value: Any) -> None:
    call_with(target, name, value)


@pytest.mark.parametrize("target", TARGETS, ids=str)
def test_valid_arguments_are_accepted(target: Target) -> None:
    with contextlib.chdir(FOLDER), mock.patch.dict(os.environ, NO_LAUNCHER):
        try:
            target.call(**target.valid)
        except cfopt.MissionError as exc:
            assert _accepted(target, exc), exc
