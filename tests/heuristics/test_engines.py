"""The fast GRAPE-S engine against the literal transcription of Algorithm 1."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cfopt import Mission
from heuristics import grape_s
from heuristics._reference import grape_s_reference
from heuristics.grape_s import grape_s_eager
from proofs.strategies import missions

ORDERS_AND_CAPS = [
    pytest.param(order, capped, id=f"{order}-{'capped' if capped else 'uncapped'}")
    for order in ("index", "random")
    for capped in (False, True)
]


def engine(order: str):
    """The fast engine; in random order drawing the reference's permutations (the lazy
    order has other draws, the same law: test_grape_s_lazy_order.py)."""
    return grape_s if order == "index" else grape_s_eager


def assert_same_run(fast, ref) -> None:
    assert fast.trajectory.tolist() == ref.trajectory.tolist()
    assert fast.assignment == ref.assignment
    counted = ("iterations", "rounds", "messages", "bytes", "work", "seed")
    assert {k: getattr(fast, k) for k in counted} == {k: getattr(ref, k) for k in counted}


@pytest.mark.parametrize(("order", "capped"), ORDERS_AND_CAPS)
@given(
    mission=missions(min_robots=0, max_robots=30, max_tasks=6, max_services=4, max_requirement=4),
    seed=st.integers(0, 2**32 - 1),
)
def test_fast_and_reference_engines_make_the_same_moves(order, capped, mission, seed) -> None:
    fast = engine(order)(mission, seed=seed, order=order, capped=capped)
    ref = grape_s_reference(mission, seed=seed, order=order, capped=capped)
    assert_same_run(fast, ref)


@pytest.mark.parametrize(("order", "capped"), ORDERS_AND_CAPS)
@settings(max_examples=15)
@given(
    mission=missions(max_robots=16, max_tasks=5, max_services=3, max_utility=6),
    seed=st.integers(0, 2**32 - 1),
)
def test_engines_agree_with_the_utility_weighted_reward(order, capped, mission, seed) -> None:
    fast = engine(order)(mission, seed=seed, order=order, capped=capped, reward="utility")
    ref = grape_s_reference(mission, seed=seed, order=order, capped=capped, reward="utility")
    assert_same_run(fast, ref)


def test_engines_agree_on_a_seed_family_mission() -> None:
    from cfopt import GridCell

    mission = GridCell(40, 10, 10, 5).mission(3)
    for order in ("index", "random"):
        assert_same_run(
            engine(order)(mission, seed=5, order=order),
            grape_s_reference(mission, seed=5, order=order),
        )


def test_reference_messages_are_materialised_with_the_documented_size() -> None:
    # The reference builds every message as bytes; the fast engine uses the formula.
    mission = Mission.from_arrays(np.ones((7, 2), bool), [[2, 1], [1, 3]], [1, 1])
    ref = grape_s_reference(mission)  # broadcast: one transmission per robot and round
    assert ref.messages == ref.rounds * 7
    assert ref.bytes == ref.messages * (16 + 4 * 7)
    ref = grape_s_reference(mission, medium="unicast")
    assert ref.messages == ref.rounds * 7 * 6
    assert ref.bytes == ref.messages * (16 + 4 * 7)
