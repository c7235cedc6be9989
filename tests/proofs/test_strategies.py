"""proofs.strategies: bounds, the achievable / over-subscribed guarantees, eager checks."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

import cfopt
import proofs
from proofs import strategies as S


@given(S.missions(min_robots=2, max_robots=6, max_tasks=3, max_services=2, max_requirement=2))
def test_missions_respect_bounds(m):
    assert 2 <= m.n_robots <= 6 and 0 <= m.n_tasks <= 3 and 1 <= m.n_services <= 2
    assert (m.requirements <= 2).all() and (m.requirements.sum(axis=1) >= 1).all()
    assert ((m.utilities >= 1) & (m.utilities <= 50)).all()


@given(S.achievable_missions(max_robots=8, density=0.5))
def test_achievable_missions_have_room_for_every_task(m):
    assert m.n_tasks >= 1 and m.requirements.sum() <= m.n_robots


@given(S.achievable_missions(max_robots=8, load=1.0))
def test_full_load_uses_every_robot(m):
    assert m.requirements.sum() == m.n_robots


@given(S.missions(achievable=False, max_robots=8, load=1.5))
def test_oversubscribed_missions_cannot_be_completed(m):
    assert m.requirements.sum() >= 1.5 * m.n_robots and m.requirements.sum() > m.n_robots


@given(S.missions(density=1.0, max_robots=5))
def test_full_density(m):
    assert m.capabilities.all()


@given(st.data())
def test_assignments_are_valid(data):
    m = data.draw(S.missions())
    a = data.draw(S.assignments(m, unassigned=False))
    a.validate(m)
    can = (m.capabilities[:, None, :] & (m.requirements[None, :, :] > 0)).any(axis=(1, 2))
    assert ((a.task >= 0) == can).all()  # nobody left out who could work


@given(st.data())
def test_near_stable_without_perturbation_is_stable(data):
    m = data.draw(S.missions())
    capped = data.draw(st.booleans())
    a = data.draw(S.near_stable_assignments(m, capped=capped, perturb=False))
    assert proofs.is_nash_stable(m, a, capped=capped)
    b = data.draw(S.near_stable_assignments(m, capped=capped))
    assert int((a.task != b.task).sum()) <= m.n_robots  # valid and drawn


_M = cfopt.Mission.from_arrays([[1]], [[1]], [1.0])


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        pytest.param(lambda: S.missions(max_robots=-1), ValueError, "max_robots", id="neg"),
        pytest.param(
            lambda: S.missions(min_tasks=4, max_tasks=2), ValueError, "larger", id="lo>hi"
        ),
        pytest.param(lambda: S.missions(max_robots=True), ValueError, "max_robots", id="bool"),
        pytest.param(lambda: S.missions(density=0), ValueError, "density", id="density0"),
        pytest.param(lambda: S.missions(density=1.5), ValueError, "density", id="density>1"),
        pytest.param(lambda: S.missions(load=0.5), ValueError, "only meaningful", id="load"),
        pytest.param(
            lambda: S.missions(achievable=False, load=0.9), ValueError, "> 1", id="load<=1"
        ),
        pytest.param(
            lambda: S.missions(achievable=True, load=1.2), ValueError, "load", id="load>1"
        ),
        pytest.param(
            lambda: S.missions(achievable=True, min_tasks=5, max_robots=3),
            ValueError,
            "max_robots >= max",
            id="too-few-robots",
        ),
        pytest.param(
            lambda: S.missions(achievable=False, max_tasks=0), ValueError, "max_tasks", id="no-task"
        ),
        pytest.param(lambda: S.missions(achievable=1), ValueError, "achievable", id="achievable"),
        pytest.param(lambda: S.assignments("m"), TypeError, "cfopt.Mission", id="assign-type"),
        pytest.param(lambda: S.assignments(_M, unassigned=1), ValueError, "bool", id="flag"),
        pytest.param(
            lambda: S.near_stable_assignments(_M, capped="yes"), ValueError, "capped", id="capped"
        ),
    ],
)
def test_arguments_are_checked_eagerly(make, error, match):
    with pytest.raises(error, match=match):
        make()  # raised by the call itself, before anything is drawn
