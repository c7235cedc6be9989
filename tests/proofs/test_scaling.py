"""Complexity scaling: fitted exponents of counted work against the seed's (deterministic)."""

from __future__ import annotations

import math

import pytest

from proofs.scaling import (
    SEED_EXPONENTS,
    fit_exponent,
    fit_rungs,
    format_scaling_table,
    ladder,
    scaling_table,
    seed_exponent,
    service_ladder,
    task_ladder,
)

SEEDS = (0, 1, 2)
N_SIZES = (25, 50, 100, 200, 400)
# A fitted exponent may exceed the seed's upper-bound exponent by this much.
TOL = 0.25


def _n_fit(algorithm: str, measure: str = "work", sizes=N_SIZES):
    return fit_rungs(ladder(algorithm, sizes, seeds=SEEDS), measure, "n")


# Fitted exponent of counted work in n (m = 10 % of n, 10:5), measured, with a window of
# +-0.15 around the measurement, and the seed's exponent as the upper bound (+ TOL).
WORK_IN_N = [
    pytest.param("grape-s", 2.92, N_SIZES, id="grape-s"),
    pytest.param("pair-grape-s", 2.93, N_SIZES, id="pair-grape-s"),
    pytest.param("sda", 3.18, (25, 50, 100, 200), id="sda"),
    pytest.param("rachna-dt", 2.77, N_SIZES, id="rachna-dt"),  # simultaneous bidding
]


@pytest.mark.parametrize(("algorithm", "measured", "sizes"), WORK_IN_N)
def test_work_exponent_in_n(algorithm, measured, sizes) -> None:
    fit = _n_fit(algorithm, sizes=sizes)
    claimed = seed_exponent(algorithm, "work", "n").exponent
    assert fit.slope <= claimed + TOL  # the seed's O(...) bound holds
    assert abs(fit.slope - measured) < 0.15, fit
    assert fit.r2 > 0.98


def test_grape_s_is_n_squared_m_exactly_in_shape() -> None:
    # GRAPE-S: (n + 1) rounds on 5:1 missions, each examining every slot of each robot's
    # service: the exponent is the seed's 3 (m ~ n), within 0.1.
    fit = fit_rungs(
        ladder("grape-s", N_SIZES, service_types=5, services_per_robot=1, seeds=SEEDS), "work", "n"
    )
    assert abs(fit.slope - 3) < 0.1, fit
    rounds = fit_rungs(
        ladder("grape-s", N_SIZES, service_types=5, services_per_robot=1, seeds=SEEDS),
        "rounds",
        "n",
    )
    assert abs(rounds.slope - 1) < 0.02


def _unicast(algorithm: str):
    """The registry's ``algorithm`` counting point to point (``medium="unicast"``)."""
    from heuristics import get_algorithm

    function = get_algorithm(algorithm)

    def run(mission, *, seed):
        return function(mission, seed=seed, medium="unicast")

    return run


@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s"])
def test_grape_messages_are_cubic_and_bytes_quartic(algorithm) -> None:
    rungs = ladder(_unicast(algorithm), N_SIZES, seeds=SEEDS)
    assert abs(fit_rungs(rungs, "messages", "n").slope - 3) < 0.05  # the seed's O(n^3)
    # every message carries the partition (16 + 4 n bytes): bytes grow one power faster
    assert abs(fit_rungs(rungs, "bytes", "n").slope - 4) < 0.1
    # the default medium, broadcast: one transmission per robot and round, n fewer
    rungs = ladder(algorithm, N_SIZES, seeds=SEEDS)
    assert abs(fit_rungs(rungs, "messages", "n").slope - 2) < 0.05
    assert abs(fit_rungs(rungs, "bytes", "n").slope - 3) < 0.1


def test_sda_messages_exceed_the_seeds_linear_bound() -> None:
    sizes = (25, 50, 100, 200)
    fit = fit_rungs(ladder(_unicast("sda"), sizes, seeds=SEEDS), "messages", "n")
    assert fit.ci_low > 1 + TOL  # X6 fails under the toolkit's point-to-point model
    assert abs(fit.slope - 2.1) < 0.2
    # broadcast announcements (the default) grow more slowly
    assert _n_fit("sda", "messages", sizes=sizes).slope < fit.slope - 0.5


# Dependence on m alone (n = 200, 5:5) and on S alone (n = 200, 5 % tasks, k = S / 2).
WORK_IN_M = [
    pytest.param("grape-s", 0.67, id="grape-s"),
    pytest.param("pair-grape-s", 0.67, id="pair-grape-s"),
    pytest.param("sda", -0.07, id="sda"),
    pytest.param("rachna-dt", 0.95, id="rachna-dt"),  # every unstaffed task searches each round
]


@pytest.mark.parametrize(("algorithm", "measured"), WORK_IN_M)
def test_work_exponent_in_m(algorithm, measured) -> None:
    fit = fit_rungs(task_ladder(algorithm, (2.5, 5, 10, 20, 40), seeds=SEEDS), "work", "m")
    assert fit.slope <= seed_exponent(algorithm, "work", "m").exponent + TOL
    assert abs(fit.slope - measured) < 0.15, fit


WORK_IN_S = [
    pytest.param("grape-s", 0.81, id="grape-s"),
    pytest.param("pair-grape-s", 0.81, id="pair-grape-s"),
    pytest.param("sda", 0.04, id="sda"),
    pytest.param("rachna-dt", 0.0, id="rachna-dt"),
]


@pytest.mark.parametrize(("algorithm", "measured"), WORK_IN_S)
def test_work_exponent_in_s(algorithm, measured) -> None:
    fit = fit_rungs(service_ladder(algorithm, (2, 4, 8, 16), seeds=SEEDS), "work", "S")
    assert fit.slope <= 1 + TOL  # the seed's |S| factor (GRAPE-S); auctions state none
    assert abs(fit.slope - measured) < 0.15, fit


def test_ladders_are_deterministic() -> None:
    assert ladder("grape-s", (20, 40), seeds=[3]) == ladder("grape-s", (20, 40), seeds=[3])


def test_fit_exponent_interval_and_errors() -> None:
    xs = [10, 20, 40, 80, 160]
    ys = [x**1.5 * (1.1 if i % 2 else 0.9) for i, x in enumerate(xs)]
    fit = fit_exponent(xs, ys)
    assert fit.ci_low < 1.5 < fit.ci_high and 0 < fit.r2 < 1
    assert math.isclose(fit_exponent(xs, [7] * 5).slope, 0.0)
    with pytest.raises(ValueError, match="at least three"):
        fit_exponent([1, 2], [1, 2])
    with pytest.raises(ValueError, match="> 0"):
        fit_exponent([1, 2, 3], [1, 0, 3])


def test_scaling_table_lists_the_seeds_exponents() -> None:
    rows = scaling_table(["rachna-dt"], seeds=[0], measures=["work"])
    assert [(r.variable, r.seed is not None) for r in rows] == [
        ("n", True),
        ("m", True),
        ("S", False),
    ]
    text = format_scaling_table(rows)
    assert "O(m n^3 log n u_max)" in text
    assert {r.algorithm for r in SEED_EXPONENTS} == {"grape-s", "pair-grape-s", "sda", "rachna-dt"}
