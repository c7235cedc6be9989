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

import atexit
import contextlib
import dataclasses
import enum
import inspect
import io
import math
import numbers
import os
import re
import shutil
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
import proofs.claims
import proofs.strategies
from cfopt import Assignment, GridCell, Mission, checks

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
    heuristics.AlgorithmSpec: heuristics.get_algorithm("sda"),
    heuristics.Option: heuristics.get_algorithm("sda").options[0],
}
#: Where the files the calls read and write are (the calls run in it); removed at exit.
FOLDER = Path(tempfile.mkdtemp(prefix="cfopt-api-types-"))
atexit.register(shutil.rmtree, FOLDER, True)
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
REQUIRED_BY_CALLABLE["Option.check"] = {"value": 1.0}  # sda's eps
# a spec registered already: registering it again changes nothing
REQUIRED_BY_CALLABLE["register_algorithm"] = {"algorithm": heuristics.get_algorithm("grape-s")}
REQUIRED_BY_CALLABLE["generate_with_witness"] = REQUIRED_BY_CALLABLE["generate_mission"]
# a claim registered already: registering the same object again changes nothing
REQUIRED_BY_CALLABLE["register_claim"] = {"claim": proofs.claims.CLAIMS["G1"]}
#: Parameters whose errors name another word: the thing the argument is.
ALIASES = {
    "get_algorithm.name": "algorithm",
    "run_algorithm.name": "algorithm",
    "require_mission.value": "mission",
    "Option.check.value": "eps",  # a value is named by its option (sda's eps here)
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


def _valid(target_id: str, function: Callable[..., Any]) -> dict[str, Any]:
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
        if inspect.isclass(obj) and issubclass(obj, BaseException | enum.Enum):
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
            out.append(Target(name, function, hints, _valid(name, function)))
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
    if kind is Callable:
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
    """Whether ``message`` names ``word`` (as a word: ``tasks[0].utility`` names ``utility``)."""
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


# ------------------------------------------------------------ the campaign's findings
def _cell_missions_none() -> Any:
    return CELL.missions(count=None)  # refused by the call, before any mission is drawn


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        pytest.param(lambda: Assignment.empty([]), TypeError, "mission: ", id="empty-list"),
        pytest.param(lambda: Assignment.empty(-1), ValueError, "mission: ", id="empty-negative"),
        pytest.param(
            lambda: Assignment.from_dict([], ASSIGNMENT.to_dict(MISSION)),
            TypeError,
            r"mission: must be a cfopt\.Mission, got list",
            id="from_dict",
        ),
        pytest.param(lambda: ASSIGNMENT.validate([]), TypeError, "mission: ", id="validate"),
        pytest.param(lambda: ASSIGNMENT.utility([]), TypeError, "mission: ", id="utility"),
        pytest.param(
            lambda: ASSIGNMENT.completed_tasks([]), TypeError, "mission: ", id="completed_tasks"
        ),
        pytest.param(
            lambda: ASSIGNMENT.percent_utility([]), TypeError, "mission: ", id="percent_utility"
        ),
        pytest.param(lambda: ASSIGNMENT.to_dict([]), TypeError, "mission: ", id="to_dict"),
        pytest.param(
            lambda: Mission.from_json(None), TypeError, "source: must be a file path", id="json"
        ),
        pytest.param(
            lambda: heuristics.broadcast_cost(10, "abc"), TypeError, "rounds: ", id="cost-str"
        ),
        pytest.param(lambda: heuristics.belief_bytes(-1), ValueError, "n_robots: ", id="bytes-neg"),
        pytest.param(
            lambda: heuristics.belief_bytes(math.nan), TypeError, "n_robots: ", id="bytes-nan"
        ),
        pytest.param(lambda: CELL.mission(index=[]), TypeError, "index: ", id="cell-index"),
        pytest.param(_cell_missions_none, TypeError, "count: ", id="cell-missions-eager"),
        pytest.param(
            lambda: heuristics.grape_s(MISSION, capped=[]),
            TypeError,
            r"capped: must be a bool \(True or False\), got \[\]",
            id="capped",
        ),
        pytest.param(
            lambda: heuristics.grape_s_select(MISSION, exchange="no"),
            TypeError,
            "exchange: ",
            id="exchange",
        ),
        pytest.param(lambda: MISSION.to_json(overwrite=1), TypeError, "overwrite: ", id="ow"),
        pytest.param(
            lambda: ASSIGNMENT.to_json(MISSION, overwrite="yes"),
            TypeError,
            "overwrite: ",
            id="ow-assignment",
        ),
        pytest.param(
            lambda: proofs.nash_violations(MISSION, ASSIGNMENT, capped=1),
            TypeError,
            "capped: ",
            id="checker-capped",
        ),
        pytest.param(
            lambda: proofs.pairwise_violations(MISSION, ASSIGNMENT, individual=None),
            TypeError,
            "individual: ",
            id="checker-individual",
        ),
        pytest.param(lambda: heuristics.grape_s(MISSION, seed=True), TypeError, "seed: ", id="t"),
        pytest.param(lambda: heuristics.sda(MISSION, seed=[1, 2]), TypeError, "seed: ", id="l"),
        pytest.param(
            lambda: cfopt.generate_mission(6, 50, 2, 1, seed=True), TypeError, "seed: ", id="gen"
        ),
        pytest.param(
            lambda: heuristics.rachna_dt(MISSION, seed=-1), ValueError, "seed: ", id="negative"
        ),
        pytest.param(
            lambda: heuristics.mpi_run(MISSION, "grape-s", seed=np.random.default_rng(0)),
            TypeError,
            "seed: must be None or a whole number >= 0",
            id="mpi-generator",
        ),
        pytest.param(
            lambda: heuristics.mpi_run(MISSION, "grape-s", quiet_factor=0),
            ValueError,
            "quiet_factor: ",
            id="mpi-quiet-factor",
        ),
        pytest.param(
            lambda: heuristics.mpi_run(MISSION, "grape-s", reward="fair"),
            ValueError,
            "reward: ",
            id="mpi-reward",
        ),
        pytest.param(
            lambda: heuristics.simulate(MISSION, "grape-s", "complete", time_limit=1e300),
            ValueError,
            "time_limit: at most",
            id="simulate-time-limit",
        ),
        pytest.param(
            lambda: heuristics.simulate(MISSION, "grape-s", None),
            TypeError,
            "network: ",
            id="simulate-network",
        ),
        pytest.param(
            lambda: heuristics.simulate(MISSION, "grape-s", "ring loss=1.5"),
            ValueError,
            r"network: loss=1\.5: ",
            id="simulate-spec",
        ),
        pytest.param(
            lambda: heuristics.simulate(MISSION, "grape-s", "complete", faults=True),
            TypeError,
            "faults: ",
            id="simulate-faults",
        ),
        pytest.param(
            lambda: heuristics.simulate(MISSION, "sda", "complete", options="eps"),
            TypeError,
            "options: ",
            id="simulate-options",
        ),
        pytest.param(
            lambda: cfopt.solve_exact(MISSION, time_limit=1e300),
            ValueError,
            "time_limit: ",
            id="solve-time-limit",
        ),
        pytest.param(lambda: heuristics.get_algorithm([]), TypeError, "algorithm: ", id="name"),
        pytest.param(
            lambda: Mission.from_arrays([[1]], [[1]], [1.0], services="s"),
            TypeError,
            "services: must be a sequence of strings",
            id="services-text",
        ),
        pytest.param(lambda: MISSION.to_json(b"m.json"), TypeError, "path: ", id="path-bytes"),
        pytest.param(lambda: Mission.from_json("m\0.json"), ValueError, "NUL", id="path-nul"),
        pytest.param(
            lambda: dataclasses.replace(RUN, algorithm=None), TypeError, "algorithm: ", id="run"
        ),
        pytest.param(
            lambda: RUN.replace_seconds(math.nan), ValueError, "seconds: ", id="run-seconds"
        ),
        pytest.param(lambda: proofs.Move(-1, None, None), ValueError, "robot: ", id="move"),
        pytest.param(lambda: proofs.Move(0, (0, "s"), None), TypeError, "source: ", id="move-slot"),
        pytest.param(
            lambda: proofs.PairwiseViolation(robots=(0, 1), moves=(MOVE,)),
            ValueError,
            "moves: one move per robot",
            id="pairwise-violation",
        ),
        pytest.param(
            lambda: dataclasses.replace(RESULT, status="optimal"), TypeError, "status: ", id="res"
        ),
        pytest.param(
            lambda: proofs.strategies.assignments(MISSION, unassigned=1),
            TypeError,
            "unassigned: ",
            id="strategy-flag",
        ),
    ],
)
def test_campaign_findings(call: Callable[[], Any], error: type, match: str) -> None:
    with mock.patch.dict(os.environ, NO_LAUNCHER), pytest.raises(error, match=match) as caught:
        call()
    assert isinstance(caught.value, cfopt.MissionError)  # the command line's one handler


# ------------------------------------------------------------------- the checks
@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        pytest.param(
            lambda: checks.require_int("k", 2.0), TypeError, "k: must be a whole number, got 2.0"
        ),
        pytest.param(
            lambda: checks.require_int("k", 7, minimum=1, maximum=5),
            ValueError,
            "k: must be a whole number between 1 and 5, got 7",
        ),
        pytest.param(
            lambda: checks.require_number("x", "1", above=0),
            TypeError,
            'x: must be a finite number > 0, got "1"',
        ),
        pytest.param(
            lambda: checks.require_number("x", 1, minimum=0, below=1),
            ValueError,
            "x: must be a finite number in [0, 1), got 1",
        ),
        pytest.param(
            lambda: checks.require_number("x", 10**400, maximum=5),
            ValueError,
            "x: must be a finite number <= 5, got 1000",
        ),
        pytest.param(
            lambda: checks.require_seed("seed", 1.5),
            TypeError,
            "seed: must be None, a whole number >= 0 or a numpy.random.Generator, got 1.5",
        ),
        pytest.param(
            lambda: checks.require_choice("order", "up", ("index", "random")),
            ValueError,
            'order: must be one of index, random, got "up"',
        ),
        pytest.param(
            lambda: checks.require_text("name", ""), ValueError, "name: must be a non-empty string"
        ),
        pytest.param(
            lambda: checks.require_assignment(MISSION),
            TypeError,
            "assignment: must be a cfopt.Assignment, got Mission",
        ),
    ],
    ids=[
        "int-float",
        "int-range",
        "number-text",
        "number-interval",
        "number-huge",
        "seed-float",
        "choice",
        "text-empty",
        "assignment",
    ],
)
def test_checks_messages(call: Callable[[], Any], error: type, message: str) -> None:
    with pytest.raises(error) as caught:
        call()
    assert str(caught.value).startswith(message)
    wrong_type = isinstance(caught.value, TypeError)
    assert wrong_type == (error is TypeError) and isinstance(caught.value, cfopt.MissionError)


def test_checks_accept_numpy_and_refuse_bools():
    assert checks.require_int("k", np.int64(3)) == 3 and checks.require_seed("s", np.uint8(4)) == 4
    assert checks.require_bool("b", np.bool_(True)) is True
    assert checks.require_number("x", np.float32(0.5), above=0) == 0.5
    for check in (checks.require_int, checks.require_number, checks.require_seed):
        with pytest.raises(TypeError, match="got true"):
            check("v", True)
    with pytest.raises(TypeError) as caught:
        checks.require_int("services_per_robot", None, flag=True)
    assert caught.value.cli_message.startswith("--services-per-robot: must be a whole number")


def test_seed_like_is_defined_once():
    """Every ``seed: SeedLike`` annotation names the one alias of :mod:`cfopt.checks`."""
    root = Path(cfopt.__file__).parent.parent
    defining = [
        str(path.relative_to(root))
        for package in ("cfopt", "heuristics", "proofs")
        for path in sorted((root / package).rglob("*.py"))
        if re.search(r"^SeedLike\b.*=", path.read_text(encoding="utf-8"), flags=re.M)
    ]
    assert defining == ["cfopt/checks.py"]
