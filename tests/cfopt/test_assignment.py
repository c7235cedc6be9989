"""Assignment: validation, utility from counts, and the JSON round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cfopt import ASSIGNMENT_FORMAT, Assignment, Mission, MissionError


@st.composite
def missions_with_assignments(draw: st.DrawFn) -> tuple[Mission, Assignment]:
    n = draw(st.integers(0, 8))
    m = draw(st.integers(0, 5))
    s = draw(st.integers(1, 4))
    caps = np.array(
        draw(st.lists(st.lists(st.booleans(), min_size=s, max_size=s), min_size=n, max_size=n)),
        dtype=bool,
    ).reshape(n, s)
    reqs = np.array(
        draw(st.lists(st.lists(st.integers(0, 3), min_size=s, max_size=s), min_size=m, max_size=m)),
        dtype=np.int64,
    ).reshape(m, s)
    reqs[np.arange(m), draw(st.lists(st.integers(0, s - 1), min_size=m, max_size=m))] += 1
    utils = draw(st.lists(st.floats(0, 100), min_size=m, max_size=m))
    mission = Mission.from_arrays(caps, reqs, utils)
    task = np.full(n, -1)
    service = np.full(n, -1)
    for i in range(n):
        options = [(j, k) for j in range(m) for k in range(s) if reqs[j, k] and caps[i, k]]
        if options and draw(st.booleans()):
            task[i], service[i] = draw(st.sampled_from(options))
    return mission, Assignment(task=task, service=service)


def naive_utility(mission: Mission, assignment: Assignment) -> float:
    """Recount with plain Python, independently of Assignment.counts."""
    total = 0.0
    for j in range(mission.n_tasks):
        done = True
        for s in range(mission.n_services):
            have = sum(
                1
                for i in range(mission.n_robots)
                if assignment.task[i] == j and assignment.service[i] == s
            )
            done = done and have >= mission.requirements[j, s]
        total += mission.utilities[j] if done else 0.0
    return total


@given(missions_with_assignments())
def test_assignment_dict_round_trip_is_identical(pair) -> None:
    mission, assignment = pair
    data = assignment.to_dict(mission)
    assert data["format"] == ASSIGNMENT_FORMAT
    listed = [mission.robot_index[e["robot"]] for e in data["assignment"]]
    assert listed == sorted(listed)  # robots in mission order
    again = Assignment.from_dict(mission, data)
    assert again == assignment
    assert again.to_dict(mission) == data
    assert Assignment.from_dict(mission, json.loads(assignment.to_json(mission))) == assignment


@given(missions_with_assignments())
def test_utility_matches_a_plain_recount(pair) -> None:
    mission, assignment = pair
    assert assignment.utility(mission) == pytest.approx(naive_utility(mission, assignment))
    completed = assignment.completed_tasks(mission)
    assert assignment.utility(mission) == pytest.approx(float(mission.utilities[completed].sum()))


def small_mission() -> Mission:
    return Mission.from_dict(
        {
            "services": ["survey", "lift"],
            "robots": [
                {"id": "r0", "services": ["survey"]},
                {"id": "r1", "services": ["survey", "lift"]},
                {"id": "r2", "services": []},
            ],
            "tasks": [
                {"id": "t0", "utility": 12, "requires": {"survey": 1, "lift": 1}},
                {"id": "t1", "utility": 7.5, "requires": {"survey": 1}},
            ],
        }
    )


def test_partial_coalition_earns_nothing() -> None:
    m = small_mission()
    a = Assignment.from_dict(
        m, {"assignment": [{"robot": "r0", "task": "t0", "service": "survey"}]}
    )
    assert a.utility(m) == 0.0 and a.completed_tasks(m).size == 0
    b = Assignment.from_dict(
        m,
        {
            "assignment": [
                {"robot": "r0", "task": "t0", "service": "survey"},
                {"robot": "r1", "task": "t0", "service": "lift"},
            ]
        },
    )
    assert b.utility(m) == 12.0 and b.completed_tasks(m).tolist() == [0]
    assert b.percent_utility(m) == pytest.approx(100 * 12 / 19.5)
    np.testing.assert_array_equal(b.counts(m), [[1, 1], [0, 0]])


def test_empty_assignment_earns_nothing_and_lists_nobody() -> None:
    m = small_mission()
    a = Assignment.empty(m)
    assert a.utility(m) == 0.0 and a.n_assigned == 0
    assert a.to_dict(m) == {"format": ASSIGNMENT_FORMAT, "assignment": []}


ENTRY = {"robot": "r1", "task": "t0", "service": "lift"}

BAD_ASSIGNMENTS = [
    pytest.param(
        {"assignment": [ENTRY, ENTRY]},
        'assignment[1].robot: robot "r1" is listed twice (first at assignment[0])',
        id="robot-twice",
    ),
    pytest.param(
        {"assignment": [{**ENTRY, "robot": "r9"}]},
        'assignment[0].robot: unknown robot "r9"',
        id="unknown-robot",
    ),
    pytest.param(
        {"assignment": [{**ENTRY, "task": "t9"}]},
        'assignment[0].task: unknown task "t9"',
        id="unknown-task",
    ),
    pytest.param(
        {"assignment": [{**ENTRY, "service": "swim"}]},
        'assignment[0].service: unknown service "swim"',
        id="unknown-service",
    ),
    pytest.param(
        {"assignment": [{"robot": "r0", "task": "t0", "service": "lift"}]},
        'assignment[0].service: robot "r0" cannot perform "lift"',
        id="robot-lacks-service",
    ),
    pytest.param(
        {"assignment": [{"robot": "r1", "task": "t1", "service": "lift"}]},
        'assignment[0].service: task "t1" does not require "lift"',
        id="task-does-not-need",
    ),
    pytest.param(
        {"assignment": [{"robot": "r1", "task": "t0"}]},
        'assignment[0]: missing key "service"',
        id="missing-key",
    ),
    pytest.param(
        {"assignment": [{**ENTRY, "role": "x"}]},
        "assignment[0].role: unknown key",
        id="unknown-key",
    ),
    pytest.param({"assignment": {}}, "assignment: must be a list", id="not-a-list"),
    pytest.param(
        {"format": "cfopt.mission/1", "assignment": []},
        'format: must be "cfopt.assignment/1"',
        id="wrong-format",
    ),
    pytest.param({}, 'top level: missing key "assignment"', id="missing-assignment"),
    pytest.param([], "top level: must be an object", id="top-level-list"),
]


@pytest.mark.parametrize(("data", "fragment"), BAD_ASSIGNMENTS)
def test_bad_assignments_name_the_entry(data, fragment) -> None:
    with pytest.raises(MissionError) as info:
        Assignment.from_dict(small_mission(), data)
    assert fragment in str(info.value)


@pytest.mark.parametrize(
    ("task", "service", "fragment"),
    [
        pytest.param(
            [0, -1, -1], [1, -1, -1], "robot 'r0' cannot perform service 'lift'", id="lacks"
        ),
        pytest.param([-1, 1, -1], [-1, 1, -1], "does not require it", id="not-required"),
        pytest.param([-1, 5, -1], [-1, 0, -1], "the mission has 2 tasks", id="out-of-range"),
        pytest.param([-1, -1], [-1, -1], "has 2 robots, the mission has 3", id="length"),
    ],
)
def test_array_assignments_are_validated_against_the_mission(task, service, fragment) -> None:
    with pytest.raises(MissionError, match=None) as info:
        Assignment(task=task, service=service).utility(small_mission())
    assert fragment in str(info.value)


@pytest.mark.parametrize(
    ("task", "service", "fragment"),
    [
        pytest.param([0, -1], [-1, -1], "task without a service", id="half-assigned"),
        pytest.param([0, 0], [0], "differ in length", id="lengths"),
        pytest.param([-2], [-2], "indices must be >= -1", id="below-minus-one"),
        pytest.param([0.5], [0], "must hold whole numbers", id="float"),
    ],
)
def test_malformed_arrays_raise(task, service, fragment) -> None:
    with pytest.raises(MissionError, match=fragment):
        Assignment(task=task, service=service)


def test_assignment_file_errors_name_the_file(tmp_path) -> None:
    path = tmp_path / "a.json"
    path.write_text(json.dumps({"assignment": [ENTRY, ENTRY]}))
    with pytest.raises(MissionError, match=rf"^{path}: assignment\[1\]\.robot"):
        Assignment.from_json(small_mission(), path)


def test_to_json_refuses_to_overwrite(tmp_path) -> None:
    m = small_mission()
    path = tmp_path / "a.json"
    path.write_text("keep me")
    with pytest.raises(MissionError, match="already exists"):
        Assignment.empty(m).to_json(m, path)
    assert path.read_text() == "keep me"
    Assignment.empty(m).to_json(m, path, overwrite=True)
    assert Assignment.from_json(m, path) == Assignment.empty(m)
