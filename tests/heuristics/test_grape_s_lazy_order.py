"""GRAPE-S's lazy random order against the eager one (a whole permutation per round).

The grouped engine draws each round's order lazily (uniform draws from the order's end
up to its last wanting robot); the literal engine and :func:`heuristics.grape_s.grape_s_eager`
draw ``rng.permutation(n)``.  Where the run does not depend on the draws they are equal;
elsewhere the law of the run is the same, checked by chi-square tests over many seeds
(fixed seeds: the tests are deterministic).
"""

from __future__ import annotations

import collections
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import cfopt
from cfopt import Mission
from heuristics import grape_s, pair_grape_s
from heuristics.grape_s import grape_s_eager
from heuristics.registry import get_algorithm
from heuristics.reward import reward_model
from proofs.strategies import missions

grape_module = sys.modules["heuristics.grape_s"]
SEEDS = range(2000)
#: p-value below which the laws are declared different (fixed seeds: no flakiness).
ALPHA = 1e-3


def _core_run(mission: Mission, seed: int, *, literal: bool, capped: bool = False) -> tuple:
    """The movers ``(robot, task, service)`` of one random-order run of a core."""
    model = reward_model(mission, "paper")
    rng = np.random.default_rng(seed)
    caps, reqs = mission.capabilities, mission.requirements
    out = grape_module._core(caps, reqs, model, "random", capped, rng, literal=literal)
    return tuple(move[1:] for move in out.moves)


def _law(mission: Mission, *, literal: bool, capped: bool = False) -> collections.Counter:
    return collections.Counter(_core_run(mission, s, literal=literal, capped=capped) for s in SEEDS)


def _homogeneity(first: collections.Counter, second: collections.Counter) -> float:
    """The chi-square p-value that two samples come from one law (rare outcomes pooled)."""
    outcomes = sorted(set(first) | set(second))
    table = np.array([[first[o] for o in outcomes], [second[o] for o in outcomes]])
    common = table.sum(axis=0) >= 10
    pooled = table[:, ~common].sum(axis=1, keepdims=True)
    table = np.hstack([table[:, common], pooled]) if pooled.any() else table[:, common]
    return float(stats.chi2_contingency(table).pvalue)


# --------------------------------------------------------------- equal where forced
def _same(first, second) -> None:
    assert first.trajectory.tolist() == second.trajectory.tolist()
    assert first.assignment == second.assignment
    counted = ("iterations", "rounds", "messages", "bytes", "work", "status")
    assert [getattr(first, c) for c in counted] == [getattr(second, c) for c in counted]


@settings(max_examples=40, deadline=None)
@given(
    mission=missions(min_robots=0, max_robots=30, max_tasks=6, max_services=4),
    seed=st.integers(0, 2**32 - 1),
    capped=st.booleans(),
)
def test_index_order_is_the_same_run_as_the_eager_engine(mission, seed, capped) -> None:
    _same(
        grape_s(mission, seed=seed, capped=capped), grape_s_eager(mission, seed=seed, capped=capped)
    )


@settings(max_examples=40, deadline=None)
@given(
    capable=st.lists(st.booleans(), min_size=3, max_size=3),
    idle=st.integers(0, 20),
    reqs=st.lists(
        st.lists(st.integers(0, 3), min_size=3, max_size=3).filter(any), min_size=1, max_size=4
    ),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_order_with_one_robot_able_to_move_is_the_eager_run(
    capable, idle, reqs, seed
) -> None:
    # one robot has services, ``idle`` others have none: whatever the draws, every
    # round's mover is that robot, so lazy and eager orders make the same run
    caps = np.zeros((idle + 1, 3), bool)
    caps[idle // 2] = capable
    mission = Mission.from_arrays(caps, reqs, [1.0] * len(reqs))
    _same(
        grape_s(mission, seed=seed, order="random"),
        grape_s_eager(mission, seed=seed, order="random"),
    )


def test_random_order_without_a_wanting_robot_draws_nothing() -> None:
    mission = Mission.from_arrays([[0, 1], [0, 1]], [[1, 0]], [4])
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    model = reward_model(mission, "paper")
    out = grape_module._core(
        mission.capabilities, mission.requirements, model, "random", False, rng
    )
    assert (out.iterations, out.rounds) == (0, 1)
    assert rng.bit_generator.state == before


# ---------------------------------------------------------------------- same law
def test_first_mover_is_uniform_over_the_robots_that_want_to_move() -> None:
    # robots 0, 3, 6, ... have no service: the first round's mover is uniform on the rest
    caps = np.ones((12, 1), bool)
    caps[::3] = False
    mission = Mission.from_arrays(caps, [[20]], [1.0])
    first = collections.Counter(_core_run(mission, s, literal=False)[0][0] for s in SEEDS)
    able = np.flatnonzero(caps[:, 0]).tolist()
    assert set(first) == set(able)
    observed = [first[i] for i in able]
    assert stats.chisquare(observed).pvalue > ALPHA


@pytest.mark.parametrize(
    ("caps", "reqs", "capped"),
    [
        pytest.param(np.ones((4, 1), bool), [[2], [1]], False, id="4-robots-2-tasks"),
        pytest.param([[1, 0], [1, 1], [0, 1], [1, 1], [1, 0]], [[1, 1], [2, 0]], False, id="mixed"),
        pytest.param(np.ones((5, 2), bool), [[2, 1], [1, 0]], True, id="capped"),
    ],
)
def test_runs_have_the_eager_engines_law(caps, reqs, capped) -> None:
    # the whole run (every mover, in order) over 2000 seeds: one law for both orders
    mission = Mission.from_arrays(caps, reqs, [1.0] * len(reqs))
    lazy, eager = (
        _law(mission, literal=False, capped=capped),
        _law(mission, literal=True, capped=capped),
    )
    assert len(lazy) > 10  # many different runs: the test has something to compare
    assert _homogeneity(lazy, eager) > ALPHA


def test_the_law_test_tells_a_biased_order_apart() -> None:
    # the same test rejects an order that is not uniform: index order on even seeds
    mission = Mission.from_arrays(np.ones((4, 1), bool), [[2], [1]], [1.0, 1.0])
    model = reward_model(mission, "paper")
    biased: collections.Counter = collections.Counter()
    for s in SEEDS:
        order = "index" if s % 2 == 0 else "random"
        rng = np.random.default_rng(s)
        out = grape_module._core(
            mission.capabilities, mission.requirements, model, order, False, rng
        )
        biased[tuple(move[1:] for move in out.moves)] += 1
    assert _homogeneity(biased, _law(mission, literal=True)) < 1e-9


# -------------------------------------------------------------------- versioning
def test_lazy_order_engines_have_a_new_version() -> None:
    # other draws than version 1's: stored trials of version 1 must not be reused
    for name in ("grape-s", "pair-grape-s", "pair-grape-s-chain"):
        assert get_algorithm(name).version == "2"
    mission = cfopt.GridCell(60, 10, 10, 5).mission(1)
    runs = {tuple(pair_grape_s(mission, seed=s, order="random").trajectory[:, 1]) for s in range(4)}
    assert len(runs) > 1  # the lazy order still depends on the seed
