"""The indexed pairwise check equals the original class-against-class loop, exactly.

``proofs.stability._pairwise_violations_reference`` (and ``_is_pairwise_stable_reference``)
keep the O(C^2) loop; the public functions decide the same relation by look-ups.  Both
must return the same list (same violations, same order, same moves).  Each indexed case
is also checked on its own against a literal per-pair evaluation, so that one case
cannot hide a wrong answer behind another's lower partner.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given

import cfopt
import proofs
from proofs import stability
from proofs._dynamics import best_response

from .cases import missions_with_assignments

COMBOS = [(mode, capped) for capped in (False, True) for mode in proofs.MODES]


def _random_assignment(mission: cfopt.Mission, rng: np.random.Generator) -> cfopt.Assignment:
    """Each robot on a uniformly drawn slot it can perform, or unassigned (1 in 5)."""
    slots = np.argwhere(mission.requirements > 0)
    task = np.full(mission.n_robots, -1)
    service = np.full(mission.n_robots, -1)
    for i in range(mission.n_robots):
        mine = slots[mission.capabilities[i, slots[:, 1]]]
        if len(mine) and rng.random() >= 0.2:
            task[i], service[i] = mine[rng.integers(len(mine))]
    return cfopt.Assignment(task=task, service=service)


def _seeded_case(seed: int) -> tuple[cfopt.Mission, cfopt.Assignment]:
    """A generated mission (few services, crowded slots) and a best-response partition
    with a seed-dependent share of its robots re-placed at random."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(8, 90))
    services = int(rng.integers(1, 5))
    per_robot = int(rng.integers(1, services + 1))
    load = float(rng.choice([0.8, 1.0, 1.25, 2.0]))
    percent = float(rng.choice([5, 10, 20]))
    mission = cfopt.generate_mission(n, percent, services, per_robot, load=load, seed=seed)
    stable = best_response(mission, capped=bool(seed % 2), order=rng.permutation(n))
    noise = _random_assignment(mission, rng)
    pick = rng.random(n) < float(rng.choice([0.0, 0.03, 0.2, 1.0]))
    return mission, cfopt.Assignment(
        task=np.where(pick, noise.task, stable.task),
        service=np.where(pick, noise.service, stable.service),
    )


def _assert_same(mission: cfopt.Mission, assignment: cfopt.Assignment) -> None:
    for mode, capped in COMBOS:
        kw = {"mode": mode, "capped": capped}
        for individual in (True, False):
            fast = proofs.pairwise_violations(mission, assignment, individual=individual, **kw)
            ref = stability._pairwise_violations_reference(
                mission, assignment, individual=individual, **kw
            )
            assert fast == ref
        assert proofs.is_pairwise_stable(
            mission, assignment, **kw
        ) == stability._is_pairwise_stable_reference(mission, assignment, **kw)


def _cases():
    return missions_with_assignments(max_robots=14, max_tasks=5, max_services=3)


@given(_cases())
def test_fast_equals_reference_on_hypothesis_missions(case):
    _assert_same(*case)


@pytest.mark.parametrize("seed", range(24))
def test_fast_equals_reference_on_generated_missions(seed):
    _assert_same(*_seeded_case(seed))


def _pairs(joint: stability._FastJoint) -> tuple[np.ndarray, np.ndarray]:
    A, B = np.meshgrid(np.arange(joint.C), np.arange(joint.C), indexing="ij")
    return A.reshape(-1), B.reshape(-1)


def _lowest_other(joint: stability._FastJoint, holds: np.ndarray) -> np.ndarray:
    """Per class A: the lowest first robot of a class B != A with ``holds[A, B]``."""
    holds = holds.reshape(joint.C, joint.C).copy()
    np.fill_diagonal(holds, False)
    return np.where(holds, joint.first[None, :], joint.big).min(axis=1)


CASES = [
    ("_independent", "_pair_independent"),
    ("_same_new_slot", "_pair_same_new_slot"),
    ("_a_takes", "_pair_a_takes"),
    ("_b_takes", "_pair_b_takes"),
]


@pytest.mark.parametrize("seed", range(16))
def test_each_indexed_case_equals_its_literal_predicate(seed):
    mission, assignment = _seeded_case(seed)
    for mode, capped in COMBOS:
        joint = stability._FastJoint(stability._State(mission, assignment, capped), mode)
        if joint.C == 0:
            continue
        A, B = _pairs(joint)
        # the literal per-pair predicate is _compatible, entry by entry
        literal = np.stack([joint._compatible(k) for k in range(joint.C)])
        ok = joint._pair_ok(A, B).reshape(joint.C, joint.C)
        alone = joint.second < 0
        ok[np.arange(joint.C)[alone], np.arange(joint.C)[alone]] = False
        np.testing.assert_array_equal(ok, literal)
        for indexed, literal_case in CASES:
            expected = _lowest_other(joint, getattr(joint, literal_case)(A, B))
            np.testing.assert_array_equal(getattr(joint, indexed)(), expected, err_msg=indexed)


def test_a_crowded_target_slot_is_decided_slot_by_slot():
    # Every robot can do only s0; the two best slots hold robots, so classes sit on T and
    # the exclusions p_A / p_B bite.  The answer must equal the reference's.
    caps = np.ones((7, 1), dtype=bool)
    reqs = np.array([[2], [3], [1], [4]])
    m = cfopt.Mission.from_arrays(caps, reqs, np.ones(4))
    a = cfopt.Assignment(task=[0, 0, 1, 1, 2, 3, -1], service=[0, 0, 0, 0, 0, 0, -1])
    _assert_same(m, a)
    assert proofs.pairwise_violations(m, a, mode="pareto", individual=False)


def test_empty_and_tiny_missions():
    no_tasks = cfopt.Mission.from_arrays(np.ones((3, 2), bool), np.zeros((0, 2), int), [])
    _assert_same(no_tasks, cfopt.Assignment.empty(no_tasks))
    one = cfopt.Mission.from_arrays(np.ones((1, 1), bool), [[1]], [1.0])
    _assert_same(one, cfopt.Assignment.empty(one))
    state = stability._State(one, cfopt.Assignment.empty(one), False)
    assert stability._FastJoint(state, "pareto").any() is False


def test_load_ranks_are_exact_and_dense():
    big = cfopt.mission.MAX_COUNT
    vn = np.array([1, 2, 1, 1, 3, 1], dtype=np.int64)
    vd = np.array([2, 4, big, big - 1, 0, 3], dtype=np.int64)  # 1/2 = 2/4; 1/big < 1/(big-1)
    assert stability._load_ranks(vn, vd).tolist() == [3, 3, 0, 1, 4, 2]


def test_distinct_rows_number_rows_lexicographically():
    rows = np.array([[3, -1], [0, 5], [3, -1], [0, 2], [-7, 9]])
    ids, at = stability._distinct_rows(rows)
    assert ids.tolist() == [3, 2, 3, 1, 0]
    assert rows[at].tolist() == [[-7, 9], [0, 2], [0, 5], [3, -1]]
    empty_ids, empty_at = stability._distinct_rows(np.zeros((0, 3), dtype=np.int64))
    assert empty_ids.size == empty_at.size == 0
