"""SDA's work count per capability type equals the literal robots-times-tasks count."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import cfopt
from heuristics.sda import _Touched


def _naive(caps_rows: np.ndarray, needmask: np.ndarray) -> np.ndarray:
    """The count as SDA wrote it before: one row per robot, one column per task."""
    return ((caps_rows.astype(np.int64) @ needmask.astype(np.int64).T) > 0).sum(axis=0)


@st.composite
def _rows_and_needs(draw, max_services: int = 8):
    services = draw(st.integers(1, max_services))
    robots = draw(st.integers(0, 12))
    tasks = draw(st.integers(1, 6))
    caps = draw(hnp.arrays(bool, (robots, services)))
    needs = draw(hnp.arrays(bool, (tasks, services)))
    return caps, needs


@given(_rows_and_needs())
def test_per_type_count_equals_naive(case):
    caps, needs = case
    got = _Touched(needs)(caps)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, _naive(caps, needs))


@pytest.mark.parametrize("services", [62, 63, 70])
def test_wide_service_sets_use_the_product(services):
    # past 62 services the bit codes would not fit an int64: the U x m product decides
    rng = np.random.default_rng(services)
    caps = rng.random((9, services)) < 0.1
    caps[3] = caps[0]  # a repeated type
    needs = rng.random((5, services)) < 0.1
    np.testing.assert_array_equal(_Touched(needs)(caps), _naive(caps, needs))


def test_generated_mission_bundles():
    m = cfopt.generate_mission(400, 10, 10, 5, seed=3)
    needs = m.requirements > 0
    touched = _Touched(needs)
    rng = np.random.default_rng(0)
    for k in (1, 7, 40, 400):
        robots = np.sort(rng.choice(m.n_robots, k, replace=False))
        caps = m.capabilities[robots]
        np.testing.assert_array_equal(touched(caps), _naive(caps, needs))
