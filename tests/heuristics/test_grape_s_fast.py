"""The grouped GRAPE-S core against the O(n)-per-round literal core, move for move."""

from __future__ import annotations

import functools
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from cfopt import Mission
from heuristics import pair_grape_s
from heuristics.grape_s import _core
from heuristics.reward import reward_model
from proofs.strategies import missions

pair_module = sys.modules["heuristics.pair_grape_s"]

CASES = [
    pytest.param(order, capped, reward, id=f"{order}-{'capped' if capped else 'free'}-{reward}")
    for order in ("index", "random")
    for capped in (False, True)
    for reward in ("paper", "utility")
]
BIG = 2**31 - 1


def assert_same_core(mission: Mission, order: str, capped: bool, reward: str, seed: int) -> None:
    """Both cores: the same outcome and the same draws left in the generator (random
    order: the grouped core drawing the literal one's permutations; the lazy order's law
    is tested in test_grape_s_lazy_order.py)."""
    model = reward_model(mission, reward)
    caps, reqs = mission.capabilities, mission.requirements
    rng_fast, rng_literal = np.random.default_rng(seed), np.random.default_rng(seed)
    fast = _core(caps, reqs, model, order, capped, rng_fast, eager=True)
    literal = _core(caps, reqs, model, order, capped, rng_literal, literal=True)
    assert fast.moves == literal.moves
    assert fast.task.tolist() == literal.task.tolist()
    assert fast.service.tolist() == literal.service.tolist()
    assert (fast.iterations, fast.rounds, fast.work) == (
        literal.iterations,
        literal.rounds,
        literal.work,
    )
    assert rng_fast.bit_generator.state == rng_literal.bit_generator.state


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
@settings(max_examples=25, deadline=None)
@given(
    mission=missions(min_robots=0, max_robots=40, max_tasks=8, max_services=4, max_requirement=4),
    seed=st.integers(0, 2**32 - 1),
)
def test_cores_agree_on_hypothesis_missions(order, capped, reward, mission, seed) -> None:
    assert_same_core(mission, order, capped, reward, seed)


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
@settings(max_examples=10, deadline=None)
@given(
    mission=missions(max_robots=12, max_tasks=4, max_services=2, max_utility=3),
    seed=st.integers(0, 2**32 - 1),
)
def test_cores_agree_when_weights_and_keys_tie(order, capped, reward, mission, seed) -> None:
    # few utilities and small requirements: many equal keys and equal weights
    assert_same_core(mission, order, capped, reward, seed)


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
@pytest.mark.parametrize(
    ("robots", "percent", "types", "per_robot", "index"),
    [(300, 10, 10, 5, 0), (400, 50, 5, 1, 1), (250, 1, 10, 1, 2), (500, 10, 5, 5, 3)],
)
def test_cores_agree_on_generated_missions(
    order, capped, reward, robots, percent, types, per_robot, index
) -> None:
    mission = cfopt.generate_mission(robots, percent, types, per_robot, seed=index)
    assert_same_core(mission, order, capped, reward, seed=index)


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
def test_cores_agree_on_many_robots_piling_onto_one_slot(order, capped, reward) -> None:
    # uncapped, one slot holds every robot: one bucket per count, the grouping's worst case
    mission = Mission.from_arrays(np.ones((150, 2), bool), [[BIG, 0], [0, 3]], [1.0, 1.0])
    assert_same_core(mission, order, capped, reward, seed=7)


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
def test_cores_agree_where_weights_sit_inside_the_float_filter(order, capped, reward) -> None:
    # w_0 and w_1 differ by one ulp: every cross-task comparison goes to the exact key
    mission = Mission.from_arrays(
        np.ones((60, 1), bool), [[BIG], [BIG - 1], [2]], [1.0, 1.0000000000000002, 5.0]
    )
    assert_same_core(mission, order, capped, reward, seed=11)


@pytest.mark.parametrize(("order", "capped", "reward"), CASES)
def test_cores_agree_on_degenerate_missions(order, capped, reward) -> None:
    no_robots = Mission.from_arrays(np.zeros((0, 2), bool), [[1, 0]], [4])
    nobody_capable = Mission.from_arrays([[0, 1], [0, 1]], [[1, 0]], [4])
    zero_utility = Mission.from_arrays(np.ones((5, 1), bool), [[2], [1]], [0.0, 3.0])
    for mission in (no_robots, nobody_capable, zero_utility):
        assert_same_core(mission, order, capped, reward, seed=1)


@pytest.mark.parametrize("order", ["index", "random"])
@pytest.mark.parametrize("reward", ["paper", "utility"])
def test_pair_grape_s_runs_the_same_with_either_core(order, reward, monkeypatch) -> None:
    mission = cfopt.generate_mission(300, 10, 10, 5, seed=4)
    monkeypatch.setattr(pair_module, "_core", functools.partial(_core, eager=True))
    fast = pair_grape_s(mission, seed=9, order=order, reward=reward)
    monkeypatch.setattr(pair_module, "_core", functools.partial(_core, literal=True))
    literal = pair_grape_s(mission, seed=9, order=order, reward=reward)
    assert fast.trajectory.tolist() == literal.trajectory.tolist()
    assert fast.assignment == literal.assignment
    counted = ("iterations", "rounds", "messages", "bytes", "work", "exchanges")
    assert [getattr(fast, c) for c in counted] == [getattr(literal, c) for c in counted]
