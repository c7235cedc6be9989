"""The stability checkers: hand-built missions with known answers, and argument checks."""

from __future__ import annotations

import numpy as np
import pytest

import cfopt
import proofs
from cfopt import Assignment, Mission
from proofs import Move, NashViolation, PairwiseViolation


def _mission(caps, reqs):
    return Mission.from_arrays(np.asarray(caps), np.asarray(reqs), np.ones(len(reqs)))


def _nash(m, a, **kw):
    return [(m.robot_ids[v.robot], v.source, v.target) for v in proofs.nash_violations(m, a, **kw)]


def _joint(m, a, **kw):
    return [
        tuple((m.robot_ids[mv.robot], mv.source, mv.target) for mv in v.moves)
        for v in proofs.pairwise_violations(m, a, individual=False, **kw)
    ]


ALL = [
    pytest.param(dict(capped=c, mode=mo), id=f"{mo}-{'capped' if c else 'uncapped'}")
    for c in (False, True)
    for mo in proofs.MODES
]


# ------------------------------------------------------------------ known answers
@pytest.mark.parametrize("kw", ALL)
def test_complete_partition_is_stable(kw):
    # every slot exactly full: any move overfills a slot (load (r+1)/r > 1)
    m = _mission([[1, 0], [1, 1], [0, 1], [1, 1]], [[2, 0], [0, 1], [0, 1]])
    a = Assignment(task=[0, 0, 1, 2], service=[0, 0, 1, 1])
    assert proofs.nash_violations(m, a, capped=kw["capped"]) == []
    assert proofs.pairwise_violations(m, a, **kw) == []
    assert proofs.is_nash_stable(m, a, capped=kw["capped"])
    assert proofs.is_pairwise_stable(m, a, **kw)


def test_exactly_one_nash_deviation():
    # r0 fills t0; r1 is unassigned; t1 is empty.  r0's move to t1 is a tie (1/1 = 1/1).
    m = _mission([[1], [1]], [[1], [1]])
    a = Assignment(task=[0, -1], service=[0, -1])
    assert proofs.nash_violations(m, a) == [NashViolation(robot=1, source=None, target=(1, 0))]
    assert proofs.nash_violations(m, a, capped=True) == [
        NashViolation(robot=1, source=None, target=(1, 0))
    ]
    (v,) = proofs.pairwise_violations(m, a)
    assert v == PairwiseViolation(robots=(1,), moves=(Move(1, None, (1, 0)),)) or (
        v.robots == (1,) and v.moves[0].target == (1, 0)
    )
    assert v.kind == "individual"
    assert v.to_dict(m) == {
        "robots": ["r1"],
        "moves": [{"robot": "r1", "from": None, "to": {"task": "t1", "service": "s0"}}],
        "kind": "individual",
    }


def test_best_move_tie_breaks_to_first_slot():
    # r0 (unassigned) sees four empty slots of load 1/1 and 2/2 ... all equal: first wins
    m = _mission([[1, 1], [1, 1]], [[0, 1], [2, 1], [1, 0]])
    a = Assignment(task=[-1, 1], service=[-1, 0])
    # loads if r0 joins: t0/s1 1/1, t1/s0 2/2, t1/s1 1/1, t2/s0 1/1 -> all 1: first is t0/s1
    assert _nash(m, a) == [("r0", None, (0, 1))]
    # r1 at t1/s0 has load 1/2; nothing beats it
    assert proofs.nash_violations(m, Assignment(task=[0, 1], service=[1, 0])) == []


def test_nash_picks_lowest_load_not_first_slot():
    m = _mission([[1], [1], [1]], [[1], [4]])
    a = Assignment(task=[0, 0, -1], service=[0, 0, -1])
    # r0, r1 crowd t0 (load 2); t1 gives 1/4; r2 unassigned also goes to t1
    assert _nash(m, a) == [("r0", (0, 0), (1, 0)), ("r1", (0, 0), (1, 0)), ("r2", None, (1, 0))]


def _tie_exchange():
    """Nash stable (uncapped) but not pareto pairwise stable.

    t0 {s0: 1} holds r0 and r1 (load 2); t1 {s0: 1} holds r2 (load 1); t2 {s1: 2} holds r3
    (load 1/2).  r2 can move to t2 at an unchanged load (2/2); then r0 (or r1) takes t1:
    load 2 -> 1, strictly better, r2 no worse.
    """
    m = _mission([[1, 0], [1, 0], [1, 1], [0, 1]], [[1, 0], [1, 0], [0, 2]])
    a = Assignment(task=[0, 0, 1, 2], service=[0, 0, 0, 1])
    return m, a


def test_nash_stable_but_not_pareto_pairwise_stable():
    m, a = _tie_exchange()
    assert proofs.is_nash_stable(m, a)
    assert proofs.is_pairwise_stable(m, a, mode="strict")
    assert proofs.pairwise_violations(m, a, mode="strict") == []
    assert not proofs.is_pairwise_stable(m, a, mode="pareto")
    assert _joint(m, a, mode="pareto") == [
        (("r0", (0, 0), (1, 0)), ("r2", (1, 0), (2, 1))),
        (("r1", (0, 0), (1, 0)), ("r2", (1, 0), (2, 1))),
        (("r2", (1, 0), (2, 1)), ("r0", (0, 0), (1, 0))),
    ]
    # capped: t1 and t2 keep within their requirements, so the same deviations stand
    assert _joint(m, a, mode="pareto", capped=True) == _joint(m, a, mode="pareto")
    (first, *_) = proofs.pairwise_violations(m, a, mode="pareto")
    assert first.to_dict(m) == {
        "robots": ["r0", "r2"],
        "moves": [
            {"robot": "r0", "from": {"task": "t0", "service": "s0"},
             "to": {"task": "t1", "service": "s0"}},
            {"robot": "r2", "from": {"task": "t1", "service": "s0"},
             "to": {"task": "t2", "service": "s1"}},
        ],
        "kind": "joint",
    }  # fmt: skip
    after = first.apply(a)
    assert after.task.tolist() == [1, 0, 2, 2]


def test_strict_joint_deviation_needs_an_individual_one():
    # Strict pairwise stability coincides with Nash stability here; a strict joint
    # deviation therefore appears only beside Nash violations.  Two unassigned robots,
    # one slot t0 {s0: 2}: joining together gives both load 2/2 < inf.
    m = _mission([[1], [1]], [[2]])
    a = Assignment.empty(m)
    assert _nash(m, a) == [("r0", None, (0, 0)), ("r1", None, (0, 0))]
    for kw in ({}, {"capped": True}):
        assert _joint(m, a, **kw) == [
            (("r0", None, (0, 0)), ("r1", None, (0, 0))),
            (("r1", None, (0, 0)), ("r0", None, (0, 0))),
        ]
    # with a requirement of 1, capped forbids both joining; uncapped allows load 2/1
    m1 = _mission([[1], [1]], [[1]])
    assert _joint(m1, Assignment.empty(m1), capped=True) == []
    assert len(_joint(m1, Assignment.empty(m1))) == 2


def test_capped_and_uncapped_differ():
    # the Pair-GRAPE-S situation: t0 {s0: 1} full with r1, r0 unassigned can only do s0,
    # t1 {s1: 2} has r2 and room for one more.
    m = _mission([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 2]])
    a = Assignment(task=[-1, 0, 1], service=[-1, 0, 1])
    assert _nash(m, a) == [("r0", None, (0, 0))]  # uncapped: r0 crowds t0 (load 2 < inf)
    assert _nash(m, a, capped=True) == []
    assert _joint(m, a, mode="strict", capped=True) == []
    assert _joint(m, a, mode="pareto", capped=True) == [
        (("r0", None, (0, 0)), ("r1", (0, 0), (1, 1))),
        (("r1", (0, 0), (1, 1)), ("r0", None, (0, 0))),
    ]
    # a full t1 removes the exchange in capped mode (r1 could only overfill it)
    m2 = _mission([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 1]])
    assert _joint(m2, a, mode="pareto", capped=True) == []
    assert proofs.is_pairwise_stable(m2, a, mode="pareto", capped=True)


def test_swap_is_never_a_violation():
    # r0 on t0 {s0: 1}, r1 and r2 on t1 {s1: 2}: all loads 1; r0 and r1 could swap
    m = _mission([[1, 1], [1, 1], [0, 1]], [[1, 0], [0, 2]])
    a = Assignment(task=[0, 1, 1], service=[0, 1, 1])
    for mode in proofs.MODES:
        assert proofs.pairwise_violations(m, a, mode=mode) == []
        assert proofs.pairwise_violations(m, a, mode=mode, capped=True) == []


def test_move_replay_and_json():
    m = _mission([[1, 1], [1, 0]], [[1, 1]])
    a = Assignment(task=[0, -1], service=[1, -1])
    mv = Move(robot=0, source=(0, 1), target=None)
    assert mv.apply(a) == Assignment.empty(m)
    assert mv.to_dict(m) == {"robot": "r0", "from": {"task": "t0", "service": "s1"}, "to": None}
    assert mv.describe(m) == "r0: t0/s1 -> -"
    with pytest.raises(cfopt.MissionError, match="robot 0 is at"):
        Move(robot=0, source=(0, 0), target=None).apply(a)
    with pytest.raises(cfopt.MissionError, match="not in the assignment"):
        Move(robot=5, source=None, target=None).apply(a)


def test_degenerate_missions():
    no_tasks = Mission.from_arrays(np.ones((3, 2), bool), np.zeros((0, 2), int), [])
    e = Assignment.empty(no_tasks)
    assert proofs.nash_violations(no_tasks, e) == []
    assert proofs.pairwise_violations(no_tasks, e, mode="pareto") == []
    no_robots = Mission.from_arrays(np.zeros((0, 1), bool), [[1]], [1.0])
    assert proofs.pairwise_violations(no_robots, Assignment.empty(no_robots)) == []
    helpless = _mission([[0], [0]], [[1]])
    assert proofs.is_pairwise_stable(helpless, Assignment.empty(helpless), mode="pareto")


def test_large_requirements_compare_exactly():
    # loads 2^30+1 / 2^31-1 and 1/2 differ by ~2^-31: floats of the quotients are close,
    # the integer comparison is exact
    big = cfopt.mission.MAX_COUNT
    m = Mission.from_arrays(np.ones((1, 2), bool), [[big, 0], [0, 2]], [1.0, 1.0])
    a = Assignment(task=[1], service=[1])  # load 1/2; t0 would give 1/big
    assert _nash(m, a) == [("r0", (1, 1), (0, 0))]


# ------------------------------------------------------------------ bad arguments
_M = _mission([[1], [1]], [[1]])


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        pytest.param(
            lambda: proofs.pairwise_violations(_M, Assignment.empty(_M), mode="weak"),
            ValueError,
            "mode: must be one of 'strict', 'pareto', got 'weak'",
            id="bad-mode",
        ),
        pytest.param(
            lambda: proofs.is_pairwise_stable(_M, Assignment.empty(_M), mode=None),
            ValueError,
            "mode: must be one of",
            id="bad-mode-is",
        ),
        pytest.param(
            lambda: proofs.nash_violations(_M, Assignment.empty(3)),
            cfopt.MissionError,
            "has 3 robots, the mission has 2",
            id="wrong-size",
        ),
        pytest.param(
            lambda: proofs.nash_violations(_M, Assignment(task=[0, 0], service=[1, 0])),
            cfopt.MissionError,
            "robot 'r0' has task 0 / service 1",
            id="unknown-service",
        ),
        pytest.param(
            lambda: proofs.pairwise_violations(
                _mission([[0], [1]], [[1]]), Assignment(task=[0, -1], service=[0, -1])
            ),
            cfopt.MissionError,
            "cannot perform service 's0'",
            id="incapable",
        ),
        pytest.param(
            lambda: proofs.is_nash_stable("mission.json", Assignment.empty(2)),
            TypeError,
            "mission: must be a cfopt.Mission",
            id="not-a-mission",
        ),
        pytest.param(
            lambda: proofs.is_nash_stable(_M, {"assignment": []}),
            TypeError,
            "assignment: must be a cfopt.Assignment",
            id="not-an-assignment",
        ),
    ],
)
def test_bad_arguments(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_import_proofs_does_not_need_hypothesis():
    import subprocess
    import sys

    code = (
        "import sys; sys.modules['hypothesis'] = None\n"
        "import proofs\n"
        "assert 'proofs.strategies' not in sys.modules\n"
        "try:\n    proofs.strategies\nexcept ImportError:\n    print('lazy')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "lazy"
