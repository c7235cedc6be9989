"""Mission: the file format's round trip, its validation, and fuzzing of the loader."""

from __future__ import annotations

import contextlib
import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cfopt import MISSION_FORMAT, Mission, MissionError

# ------------------------------------------------------------------ valid mission dicts
names = st.text(min_size=1, max_size=6)
json_scalars = (
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats(allow_nan=False, allow_infinity=False)
    | names
)
json_values = st.recursive(
    json_scalars,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(names, inner, max_size=3),
    max_leaves=8,
)
utilities = st.integers(0, 2**53) | st.floats(min_value=0, max_value=1e300)
counts = st.integers(1, 1000) | st.integers(1, 1000).map(float)


@st.composite
def mission_dicts(draw: st.DrawFn) -> dict:
    """Valid ``cfopt.mission/1`` objects, in any order the format allows."""
    services = draw(st.lists(names, min_size=1, max_size=5, unique=True))
    robot_ids = draw(st.lists(names, max_size=8, unique=True))
    task_ids = draw(st.lists(names, max_size=6, unique=True))
    robots = [
        {
            "id": rid,
            "services": draw(
                st.permutations(services).map(lambda p: p[: draw(st.integers(0, len(services)))])
            ),
        }
        for rid in robot_ids
    ]
    tasks = []
    for tid in task_ids:
        needed = draw(st.lists(st.sampled_from(services), min_size=1, unique=True))
        tasks.append(
            {
                "id": tid,
                "utility": draw(utilities),
                "requires": {name: draw(counts) for name in needed},
            }
        )
    data: dict = {"services": services, "robots": robots, "tasks": tasks}
    if draw(st.booleans()):
        data["format"] = MISSION_FORMAT
    if draw(st.booleans()):
        data["name"] = draw(st.text(max_size=10))
    if draw(st.booleans()):
        data["metadata"] = draw(st.dictionaries(names, json_values, max_size=3))
    return data


def canonical(data: dict) -> dict:
    """What to_dict documents: format present, robot services in declaration order."""
    order = {name: k for k, name in enumerate(data["services"])}
    out = {**data, "format": MISSION_FORMAT}
    out["robots"] = [
        {"id": r["id"], "services": sorted(r["services"], key=order.__getitem__)}
        for r in data["robots"]
    ]
    return out


@given(mission_dicts())
def test_dict_round_trip_is_identical_up_to_canonical_order(data: dict) -> None:
    mission = Mission.from_dict(data)
    out = mission.to_dict()
    assert out == canonical(data)
    assert Mission.from_dict(out) == mission
    assert Mission.from_dict(out).to_dict() == out  # canonical input comes back unchanged


@given(mission_dicts())
def test_json_text_round_trip_is_byte_stable(data: dict) -> None:
    mission = Mission.from_dict(data)
    text = mission.to_json()
    again = Mission.from_dict(json.loads(text))
    assert again == mission
    assert again.to_json() == text


def test_whole_number_forms_are_normalised() -> None:
    data = {
        "services": ["a", "b"],
        "robots": [{"id": "r", "services": ["b", "a"]}],
        "tasks": [{"id": "t", "utility": 12.0, "requires": {"b": 2.0, "a": 1}}],
    }
    out = Mission.from_dict(data).to_dict()
    assert out["robots"][0]["services"] == ["a", "b"]
    assert out["tasks"][0] == {"id": "t", "utility": 12, "requires": {"a": 1, "b": 2}}
    assert type(out["tasks"][0]["utility"]) is int
    assert type(out["tasks"][0]["requires"]["b"]) is int


def test_mission_is_frozen_and_its_arrays_read_only() -> None:
    m = Mission.from_arrays([[1, 0]], [[1, 0]], [3.0], metadata={"k": [1]})
    with pytest.raises(AttributeError):
        m.name = "x"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        m.requirements[0, 0] = 5
    with pytest.raises(TypeError):
        m.metadata["k"] = 2  # type: ignore[index]


def test_missions_pickle_for_worker_processes() -> None:
    m = Mission.from_arrays([[1, 0]], [[1, 0]], [3.0], metadata={"k": [1], "g": {"seed": 2}})
    again = pickle.loads(pickle.dumps(m))
    assert again == m
    assert not again.requirements.flags.writeable
    with pytest.raises(TypeError):
        again.metadata["k"] = 2  # type: ignore[index]


def test_empty_robots_and_tasks_are_allowed() -> None:
    m = Mission.from_dict({"services": ["a"], "robots": [], "tasks": []})
    assert (m.n_robots, m.n_tasks, m.n_services) == (0, 0, 1)
    assert m.capabilities.shape == (0, 1) and m.requirements.shape == (0, 1)
    assert m.total_utility == 0
    assert Mission.from_dict(m.to_dict()) == m


def test_robot_and_task_ids_are_separate_namespaces() -> None:
    m = Mission.from_dict(
        {
            "services": ["a"],
            "robots": [{"id": "x", "services": ["a"]}],
            "tasks": [{"id": "x", "utility": 1, "requires": {"a": 1}}],
        }
    )
    assert m.robot_ids == m.task_ids == ("x",)


# ----------------------------------------------------------------- malformed missions
def base() -> dict:
    return {
        "format": MISSION_FORMAT,
        "services": ["survey", "lift"],
        "robots": [{"id": "r0", "services": ["survey"]}, {"id": "r1", "services": ["lift"]}],
        "tasks": [
            {"id": "t0", "utility": 12, "requires": {"survey": 1}},
            {"id": "t1", "utility": 7.5, "requires": {"lift": 1}},
        ],
    }


def edited(change) -> dict:
    data = base()
    change(data)
    return data


def set_count(value):
    return lambda d: d["tasks"][1]["requires"].__setitem__("lift", value)


def set_utility(value):
    return lambda d: d["tasks"][0].__setitem__("utility", value)


BASE_TEXT = json.dumps(base())

MALFORMED = [
    # (content: dict = a mission object, str = raw file text, message fragment)
    pytest.param(
        edited(lambda d: d["robots"][1].update(id="r0")),
        'robots[1].id: duplicate robot id "r0" (first at robots[0])',
        id="dup-robot-id",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][1].update(id="t0")),
        'tasks[1].id: duplicate task id "t0"',
        id="dup-task-id",
    ),
    pytest.param(
        edited(lambda d: d["services"].append("lift")),
        'services[2]: duplicate service name "lift"',
        id="dup-service-name",
    ),
    pytest.param(
        edited(lambda d: d["robots"][0]["services"].append("swim")),
        'robots[0].services[1]: unknown service "swim"',
        id="robot-unknown-service",
    ),
    pytest.param(
        edited(lambda d: d["robots"][0]["services"].append("survey")),
        'robots[0].services[1]: service "survey" listed twice',
        id="robot-repeated-service",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][0]["requires"].update(swim=1)),
        'tasks[0].requires.swim: unknown service "swim"',
        id="task-unknown-service",
    ),
    pytest.param(
        BASE_TEXT.replace('{"lift": 1}', '{"lift": 1, "lift": 2}'),
        "tasks[1].requires.lift: key given more than once",
        id="task-repeated-service",
    ),
    pytest.param(
        edited(set_count(0)),
        "tasks[1].requires.lift: must be a whole number >= 1, got 0",
        id="count-0",
    ),
    pytest.param(
        edited(set_count(-1)),
        "tasks[1].requires.lift: must be a whole number >= 1, got -1",
        id="count-negative",
    ),
    pytest.param(
        edited(set_count(2.5)),
        "tasks[1].requires.lift: must be a whole number >= 1, got 2.5",
        id="count-2.5",
    ),
    pytest.param(
        edited(set_count(True)),
        "tasks[1].requires.lift: must be a whole number >= 1, got true",
        id="count-true",
    ),
    pytest.param(
        edited(set_count("2")),
        'tasks[1].requires.lift: must be a whole number >= 1, got "2"',
        id="count-string",
    ),
    pytest.param(
        edited(set_count(2**40)), "tasks[1].requires.lift: must be at most", id="count-huge"
    ),
    pytest.param(
        edited(lambda d: d["tasks"][0].update(requires={})),
        "tasks[0].requires: must require at least one service",
        id="requires-empty",
    ),
    pytest.param(
        BASE_TEXT.replace('"utility": 12', '"utility": NaN'),
        "tasks[0].utility: must be a finite number >= 0, got NaN",
        id="utility-nan",
    ),
    pytest.param(
        BASE_TEXT.replace('"utility": 12', '"utility": Infinity'),
        "tasks[0].utility: must be a finite number >= 0, got Infinity",
        id="utility-inf",
    ),
    pytest.param(
        BASE_TEXT.replace('"utility": 12', '"utility": 1e400'),
        "tasks[0].utility: must be a finite number >= 0",
        id="utility-overflow",
    ),
    pytest.param(
        edited(set_utility(-3)),
        "tasks[0].utility: must be a finite number >= 0, got -3",
        id="utility-negative",
    ),
    pytest.param(
        edited(set_utility(False)),
        "tasks[0].utility: must be a finite number >= 0, got false",
        id="utility-bool",
    ),
    pytest.param(
        edited(set_utility("12")),
        'tasks[0].utility: must be a finite number >= 0, got "12"',
        id="utility-string",
    ),
    pytest.param(
        edited(lambda d: d.pop("services")),
        'top level: missing key "services"',
        id="missing-services",
    ),
    pytest.param(
        edited(lambda d: d.pop("robots")), 'top level: missing key "robots"', id="missing-robots"
    ),
    pytest.param(
        edited(lambda d: d["tasks"][0].pop("utility")),
        'tasks[0]: missing key "utility"',
        id="missing-task-utility",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][1].pop("requires")),
        'tasks[1]: missing key "requires"',
        id="missing-task-requires",
    ),
    pytest.param(
        edited(lambda d: d["robots"][1].pop("id")),
        'robots[1]: missing key "id"',
        id="missing-robot-id",
    ),
    pytest.param(
        edited(lambda d: d.update(servces=[])), "servces: unknown key", id="unknown-top-key"
    ),
    pytest.param(
        edited(lambda d: d["robots"][0].update(speed=3)),
        "robots[0].speed: unknown key",
        id="unknown-robot-key",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][1].update(utilty=3)),
        "tasks[1].utilty: unknown key",
        id="unknown-task-key",
    ),
    pytest.param(
        edited(lambda d: d.update(services="survey")),
        'services: must be a list, got "survey"',
        id="services-not-list",
    ),
    pytest.param(
        edited(lambda d: d.update(robots={"r0": ["survey"]})),
        "robots: must be a list",
        id="robots-not-list",
    ),
    pytest.param(
        edited(lambda d: d.update(tasks=None)),
        "tasks: must be a list, got null",
        id="tasks-not-list",
    ),
    pytest.param(
        edited(lambda d: d["robots"].__setitem__(0, "r0")),
        'robots[0]: must be an object, got "r0"',
        id="robot-not-object",
    ),
    pytest.param(
        edited(lambda d: d["tasks"].__setitem__(1, [])),
        "tasks[1]: must be an object",
        id="task-not-object",
    ),
    pytest.param(
        edited(lambda d: d["robots"][0].update(services="survey")),
        'robots[0].services: must be a list, got "survey"',
        id="robot-services-not-list",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][0].update(requires=["survey"])),
        "tasks[0].requires: must be an object",
        id="requires-not-object",
    ),
    pytest.param(
        edited(lambda d: d["robots"][0].update(id=7)),
        "robots[0].id: must be a non-empty string, got 7",
        id="robot-id-not-string",
    ),
    pytest.param(
        edited(lambda d: d["tasks"][0].update(id="")),
        'tasks[0].id: must be a non-empty string, got ""',
        id="task-id-empty",
    ),
    pytest.param(
        edited(lambda d: d["services"].__setitem__(0, 3)),
        "services[0]: must be a non-empty string, got 3",
        id="service-name-not-string",
    ),
    pytest.param(
        edited(lambda d: d.update(services=[])),
        "services: must list at least one service",
        id="services-empty",
    ),
    pytest.param(
        edited(lambda d: d.update(format="cfopt.mission/2")),
        'format: must be "cfopt.mission/1", got "cfopt.mission/2"',
        id="wrong-format",
    ),
    pytest.param(
        edited(lambda d: d.update(name=5)), "name: must be a string, got 5", id="name-number"
    ),
    pytest.param(
        edited(lambda d: d.update(metadata=[1])),
        "metadata: must be an object, got [1]",
        id="metadata-not-object",
    ),
    pytest.param("[1, 2]", "top level: must be an object, got [1, 2]", id="top-level-list"),
    pytest.param('{"services": ["a"], ', "not valid JSON: Expecting", id="not-json"),
    pytest.param("", "empty file", id="empty-file"),
    pytest.param("  \n", "empty file", id="blank-file"),
    pytest.param(b"\xff\xfe{}", "not UTF-8 text", id="not-utf8"),
    pytest.param("[" * 100_000, "not valid JSON", id="nested-too-deep"),
]


def write_case(tmp_path, content) -> str:
    path = tmp_path / "mission.json"
    if isinstance(content, dict):
        path.write_text(json.dumps(content), encoding="utf-8")
    elif isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return str(path)


@pytest.mark.parametrize(("content", "fragment"), MALFORMED)
def test_malformed_mission_files_name_the_place(tmp_path, content, fragment) -> None:
    path = write_case(tmp_path, content)
    with pytest.raises(MissionError) as info:
        Mission.from_json(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert fragment in message
    assert "\n" not in message
    if isinstance(content, dict):
        with pytest.raises(MissionError, match=None) as direct:
            Mission.from_dict(content)
        assert fragment in str(direct.value)


@pytest.mark.parametrize(
    ("make_path", "fragment"),
    [
        pytest.param(lambda tmp: tmp, "is a directory", id="directory"),
        pytest.param(lambda tmp: tmp / "absent.json", "no such file", id="missing-file"),
    ],
)
def test_unreadable_paths(tmp_path, make_path, fragment) -> None:
    path = make_path(tmp_path)
    with pytest.raises(MissionError, match=fragment) as info:
        Mission.from_json(path)
    assert str(info.value).startswith(str(path))


def test_table_covers_at_least_25_distinct_cases() -> None:
    assert len({p.id for p in MALFORMED}) == len(MALFORMED) >= 25


# ------------------------------------------------------------------- array construction
@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        pytest.param(
            {"requirements": [[0, 0]]},
            "tasks[0].requires: must require at least one",
            id="no-requirement",
        ),
        pytest.param(
            {"requirements": [[-1, 1]]},
            "tasks[0].requires.s0: must be a whole number",
            id="negative-requirement",
        ),
        pytest.param(
            {"requirements": [[1.5, 1]]},
            "requirements: must hold whole numbers",
            id="float-requirement",
        ),
        pytest.param(
            {"utilities": [math.nan]}, "tasks[0].utility: must be a finite number", id="nan-utility"
        ),
        pytest.param({"utilities": [1.0, 2.0]}, "utilities: expected shape (1,)", id="shape"),
        pytest.param({"capabilities": [[2, 0]]}, "capabilities: must hold only 0/1", id="caps-2"),
        pytest.param(
            {"robot_ids": ["a", "a"], "capabilities": [[1, 0], [1, 0]]},
            'robots[1]: duplicate robot id "a"',
            id="dup-ids",
        ),
    ],
)
def test_from_arrays_validates(kwargs, fragment) -> None:
    args = {"capabilities": [[1, 0]], "requirements": [[1, 0]], "utilities": [1.0], **kwargs}
    with pytest.raises(MissionError) as info:
        Mission.from_arrays(
            args.pop("capabilities"), args.pop("requirements"), args.pop("utilities"), **args
        )
    assert fragment in str(info.value)


# ---------------------------------------------------------------------------- fuzzing
fuzz_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(
            st.sampled_from(
                [
                    "format",
                    "name",
                    "services",
                    "robots",
                    "tasks",
                    "metadata",
                    "id",
                    "utility",
                    "requires",
                    "a",
                    "b",
                ]
            )
            | st.text(max_size=3),
            inner,
            max_size=5,
        )
    ),
    max_leaves=20,
)


@given(fuzz_values)
def test_arbitrary_json_values_load_or_raise_mission_error(value) -> None:
    try:
        mission = Mission.from_dict(value)
    except MissionError as exc:
        assert str(exc) and "\n" not in str(exc)
    else:
        assert isinstance(mission, Mission)


@given(mission_dicts(), st.data())
def test_mutated_valid_missions_load_or_raise_mission_error(data: dict, draw) -> None:
    """Replace one value deep inside a valid mission by arbitrary JSON."""
    target: object = data
    path: list = []
    while isinstance(target, dict | list) and target and draw.draw(st.booleans()):
        key = draw.draw(
            st.sampled_from(list(target) if isinstance(target, dict) else range(len(target)))
        )
        path.append(key)
        target = target[key]
    if not path:
        return
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = draw.draw(fuzz_values)
    with contextlib.suppress(MissionError):
        Mission.from_dict(data)


@given(st.text(max_size=200) | st.binary(max_size=200))
def test_arbitrary_file_text_loads_or_raises_mission_error(tmp_path_factory, content) -> None:
    path = write_case(tmp_path_factory.mktemp("fuzz"), content)
    try:
        Mission.from_json(path)
    except MissionError as exc:
        assert str(exc).startswith(path)


def test_requirements_and_capabilities_have_the_documented_layout() -> None:
    m = Mission.from_dict(base())
    assert m.services == ("survey", "lift")
    np.testing.assert_array_equal(m.capabilities, [[True, False], [False, True]])
    np.testing.assert_array_equal(m.requirements, [[1, 0], [0, 1]])
    np.testing.assert_array_equal(m.utilities, [12.0, 7.5])
    assert m.requirements.dtype == np.int64 and m.utilities.dtype == np.float64
    assert m.robot_index["r1"] == 1 and m.service_index["lift"] == 1
