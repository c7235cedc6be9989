"""Every heuristic on valid but extreme missions: finishes fast, in little memory, exactly.

A valid mission may state requirements up to ``2**31 - 1`` and any finite utilities >= 0
whose sum is finite.  The table below runs every algorithm on each kind of extreme
mission; the expected utilities are worked out by hand in the comments of ``MISSIONS``.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import cfopt
import heuristics
from heuristics import _auction, rachna
from heuristics._reference import grape_s_reference
from heuristics.grape_s import grape_s_eager
from tests.heuristics.test_auctions_common import literal_rachna, small_missions

BIG = 2**31 - 1  # the largest requirement a mission may state
RAISES = "raises"


def _ones(n: int, s: int = 1) -> np.ndarray:
    return np.ones((n, s), dtype=bool)


#: kind -> (capabilities, requirements, utilities, expected utility per algorithm).
#: ``"*"`` is every algorithm not named; ``RAISES``: cfopt.MissionError naming eps;
#: ``None``: a valid assignment, utility not stated.
MISSIONS = {
    # Two robots, two one-robot tasks: every algorithm staffs both.
    "utility-1e25": (_ones(2), [[1], [1]], [1e25, 1e25], {"*": 2 * 1e25}),
    "utility-near-max": (_ones(2), [[1], [1]], [1e308, 5e307], {"*": 1e308 + 5e307}),
    # RACHNA_dt's budget is floor(u / eps) = 0 units: it cannot pay the 1-unit price.
    "utility-subnormal": (
        _ones(2),
        [[1], [1]],
        [5e-324, 5e-324],
        {"*": 1e-323, "rachna-dt": 0.0, "rachna-dt-eps-1": 0.0},
    ),
    # Task 0 can never be staffed (BIG > 4 robots) and is pruned by the auctions; task 1
    # gets 2 robots.  Under the paper reward GRAPE-S robots prefer t0's key c / BIG < 1/2
    # and all four pile onto it (0); under the utility reward w_0 = 5 / BIG is so small
    # that t1 (w_1 = 3/2) wins even at 4 robots (3); capped, two fill t1 first (3).
    "requirement-max": (
        _ones(4),
        [[BIG], [2]],
        [5, 3],
        {"*": 3.0, "grape-s": 0.0, "pair-grape-s": 0.0},
    ),
    # Task 0 needs BIG robots of s1; task 1 needs one robot of each service: robots 0
    # (s0) and 2 (s1), or 1 on either side.  Paper reward: as above, 0.
    "requirement-max-2-services": (
        [[1, 0], [1, 1], [0, 1]],
        [[1, BIG], [1, 1]],
        [5, 3],
        {"*": 3.0, "grape-s": 0.0, "pair-grape-s": 0.0},
    ),
    # 1000 robots; t0 and t1 need BIG and BIG - 1 (never staffable), t2 needs 2.  Paper
    # reward: keys c / BIG stay far below t2's 1/2, so every robot joins t0 or t1 (0).
    # Utility reward: w_2 = 5/2 beats w_0 ~ w_1 ~ 4.7e-10 until t2 holds ~ 44 robots (5);
    # the weights of t0 and t1 differ by a relative 4.7e-10, inside the float filter, so
    # every round has undecided robots: decided once per (target, slot), not per robot.
    "near-equal-weights": (
        _ones(1000),
        [[BIG], [BIG - 1], [2]],
        [1, 1, 5],
        {"*": 5.0, "grape-s": 0.0, "pair-grape-s": 0.0},
    ),
    # 3 robots: BIG > 3 and 4 > 3, nothing can ever be staffed.
    "nothing-staffable": (_ones(3, 2), [[BIG, 1], [4, 0]], [1e308, 1], {"*": 0.0}),
    # One robot, two tasks.  GRAPE-S: the robot joins t0 (paper: equal keys, the lower
    # task; utility: the larger weight); SDA: t0 can afford it first.  RACHNA_dt: a
    # bidding war of about 5e307 / eps rounds; the state repeats after round 2 with the
    # wage 2 units higher, so the engine knows the length and refuses at once.
    "one-robot-war": (
        _ones(1),
        [[1], [1]],
        [1e308, 5e307],
        {"*": 1e308, "rachna-dt": RAISES, "rachna-dt-eps-1": RAISES},
    ),
    # The same war with budgets 10^4 and 2 * 10^4 units (eps = 1 = 1/n): in round r, t0
    # pays 2r - 1 and t1 2r, until t0 gives up in round 5001: t1 wins (RACHNA_dt jumps
    # over the 5000 repeating rounds).  SDA's descending wages reach t1's 2e4 first; the
    # paper reward is indifferent (t0), the utility reward prefers t1.
    "war-1e4": (
        _ones(1),
        [[1], [1]],
        [1e4, 2e4],
        {"*": 2e4, "grape-s": 1e4, "pair-grape-s": 1e4},
    ),
    # Over-subscribed: t0 needs 1 s0 + 2 s1 (all three robots), t1 2 s0 + 1 s1, t2 1 s0.
    # SDA: the wages fall together from 6e300 + eps; t2 can pay one robot at 3e300 long
    # before t0 (three near 2e300) or t1 (three near 1.33e300), and then two robots are
    # left for tasks needing three: 3e300.  RACHNA_dt: a war whose wages drift apart (robot
    # 0, with s1 only, is bought less often), so no period repeats; from round 16 the
    # engine proves that no task can give up for ~1e295 rounds and refuses.  GRAPE-S and
    # Pair-GRAPE-S: only checked for validity (``None``).
    "tangled-war": (
        [[0, 1], [1, 1], [1, 1]],
        [[1, 2], [2, 1], [1, 0]],
        [6e300, 4e300, 3e300],
        {
            "*": None,
            "sda": 3e300,
            "sda-uniform": 3e300,
            "sda-eps-subnormal": 3e300,
            "rachna-dt": RAISES,
            "rachna-dt-eps-1": RAISES,
        },
    ),
}

ALGORITHMS = {
    "grape-s": lambda m: heuristics.grape_s(m),
    "grape-s-utility": lambda m: heuristics.grape_s(m, reward="utility"),
    "grape-s-capped-random": lambda m: heuristics.grape_s(m, capped=True, order="random", seed=1),
    "pair-grape-s": lambda m: heuristics.pair_grape_s(m),
    "pair-grape-s-utility": lambda m: heuristics.pair_grape_s(m, reward="utility"),
    "sda": lambda m: heuristics.sda(m),
    "sda-uniform": lambda m: heuristics.sda(m, schedule="uniform"),
    "sda-eps-subnormal": lambda m: heuristics.sda(m, eps=5e-324),
    "rachna-dt": lambda m: heuristics.rachna_dt(m),
    "rachna-dt-eps-1": lambda m: heuristics.rachna_dt(m, eps=1),
}

#: grape-s-capped-random is expected to earn what pair-grape-s does (both capped; on these
#: missions neither the order nor the pairwise step changes the utility).
_SAME_AS = {"grape-s-capped-random": "pair-grape-s"}


def _expected(kind: str, algorithm: str):
    table = MISSIONS[kind][3]
    name = _SAME_AS.get(algorithm, algorithm)
    return table.get(name, table["*"])


CASES = [
    pytest.param(kind, algorithm, _expected(kind, algorithm), id=f"{kind}-{algorithm}")
    for kind in MISSIONS
    for algorithm in ALGORITHMS
]


def _mission(kind: str) -> cfopt.Mission:
    caps, reqs, utils, _ = MISSIONS[kind]
    return cfopt.Mission.from_arrays(caps, reqs, utils)


@pytest.mark.parametrize(("kind", "algorithm", "expected"), CASES)
def test_extreme_mission(kind, algorithm, expected) -> None:
    mission = _mission(kind)
    run_it = ALGORITHMS[algorithm]
    tracemalloc.start()
    started = time.perf_counter()
    try:
        if expected == RAISES:
            with pytest.raises(cfopt.MissionError, match=r"^eps: RACHNA_dt needs more than"):
                run_it(mission)
        else:
            run = run_it(mission)
    finally:
        seconds = time.perf_counter() - started
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert seconds < 10, f"{seconds:.1f} s"
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MiB"
    if expected == RAISES:
        return
    run.assignment.validate(mission)
    if expected is not None:
        assert run.assignment.utility(mission) == expected
    assert run.iterations <= run.rounds


@pytest.mark.parametrize("kind", [k for k in MISSIONS if len(MISSIONS[k][0]) <= 10])
@pytest.mark.parametrize("reward", ["paper", "utility"])
def test_grape_s_engines_agree_on_extreme_missions(kind, reward) -> None:
    mission = _mission(kind)
    for order in ("index", "random"):
        for capped in (False, True):
            fast = grape_s_eager(mission, seed=3, order=order, capped=capped, reward=reward)
            ref = grape_s_reference(mission, seed=3, order=order, capped=capped, reward=reward)
            assert fast.trajectory.tolist() == ref.trajectory.tolist()
            counted = ("iterations", "rounds", "messages", "bytes", "work")
            assert [getattr(fast, c) for c in counted] == [getattr(ref, c) for c in counted]


def test_sequential_rachna_jump_matches_the_literal_auction_on_a_long_war() -> None:
    # literal_rachna is the sequential reading (the simultaneous one: test_rachna.py)
    mission = _mission("war-1e4")
    run = heuristics.rachna_dt(mission, eps=1, schedule="sequential")
    ref = literal_rachna(mission, Fraction(1))
    assert run.assignment.task.tolist() == ref["task"] == [1]
    assert (run.rounds, run.iterations) == (ref["rounds"], ref["iterations"]) == (5001, 5000)
    assert run.trajectory[-2:].tolist() == [[5000, 0, 0, 0], [5000, 0, 1, 0]]


def test_rachna_error_names_an_eps_that_works() -> None:
    mission = _mission("one-robot-war")
    with pytest.raises(cfopt.MissionError) as info:
        heuristics.rachna_dt(mission)
    message = str(info.value)
    assert "\n" not in message
    assert "use eps >= 1.01e+303" in message
    run = heuristics.rachna_dt(mission, eps=1.01e303)  # ~ 25,000 rounds, jumped over
    assert run.rounds <= rachna.MAX_ROUNDS
    assert run.assignment.task.tolist() == [0]


def test_pruned_tasks_allocate_nothing() -> None:
    caps = _ones(5, 2)
    reqs = np.array([[BIG, 0], [0, BIG], [3, 3], [2, 1]], dtype=np.int64)
    finder = _auction.BundleFinder(caps, reqs)
    assert finder.possible.tolist() == [False, False, False, True]  # 3 + 3 > 5 robots
    assert finder.k == [BIG, BIG, 6, 3]
    assert finder.cheapest(0, finder.robots_with, np.zeros(5, dtype=np.int64)) is None
    b = finder.cheapest(3, finder.robots_with, np.zeros(5, dtype=np.int64))
    assert b is not None and b.robots.size == 3


# ------------------------------------------------------- exactness at any scale


_SCALES = [pytest.param(2**900, id="2^900"), pytest.param(Fraction(1, 2**900), id="2^-900")]


def _scaled(mission: cfopt.Mission, scale) -> cfopt.Mission:
    utilities = [float(Fraction(u) * scale) for u in mission.utilities.tolist()]
    return cfopt.Mission.from_arrays(mission.capabilities, mission.requirements, utilities)


@pytest.mark.parametrize("scale", _SCALES)
@pytest.mark.parametrize("schedule", ["max-wage", "uniform"])
@given(mission=small_missions(max_robots=5))
def test_sda_is_scale_invariant(scale, schedule, mission) -> None:
    """Utilities and eps times a power of two give the same auction (wages scale with
    them), so the huge-number path agrees with the one the literal auction checks."""
    small = heuristics.sda(mission, eps=Fraction(3, 4), schedule=schedule)
    large = heuristics.sda(_scaled(mission, scale), eps=Fraction(3, 4) * scale, schedule=schedule)
    assert large.trajectory.tolist() == small.trajectory.tolist()
    counted = ("iterations", "rounds", "messages", "bytes", "work")
    assert [getattr(large, c) for c in counted] == [getattr(small, c) for c in counted]


@pytest.mark.parametrize("scale", _SCALES)
@given(mission=small_missions(max_robots=5))
def test_rachna_is_scale_invariant(scale, mission) -> None:
    small = heuristics.rachna_dt(mission, eps=Fraction(1, 2))
    large = heuristics.rachna_dt(_scaled(mission, scale), eps=Fraction(1, 2) * scale)
    assert large.trajectory.tolist() == small.trajectory.tolist()
    counted = ("iterations", "rounds", "messages", "bytes", "work")
    assert [getattr(large, c) for c in counted] == [getattr(small, c) for c in counted]


# ------------------------------------------------------- RACHNA_dt's jump and limit


@st.composite
def war_missions(draw):
    """Small missions with budgets up to 400 units: long bidding wars."""
    mission = draw(small_missions(max_robots=5, max_tasks=4))
    utilities = [draw(st.integers(0, 400)) for _ in range(mission.n_tasks)]
    return cfopt.Mission.from_arrays(mission.capabilities, mission.requirements, utilities)


@given(mission=war_missions(), eps=st.sampled_from([Fraction(1, 2), Fraction(1), Fraction(3)]))
def test_rachna_jump_changes_nothing(mission, eps) -> None:
    jumped = rachna._core(mission, eps, 10**9, jump=True)
    literal = rachna._core(mission, eps, 10**9, jump=False)
    assert jumped.moves.array().tolist() == literal.moves.array().tolist()
    for name in ("task", "service"):
        assert getattr(jumped, name).tolist() == getattr(literal, name).tolist()
    for name in ("iterations", "rounds", "messages", "bytes", "work"):
        assert getattr(jumped, name) == getattr(literal, name), name


@given(mission=war_missions(), limit=st.integers(1, 400))
def test_rachna_raises_exactly_when_it_needs_more_than_max_rounds(mission, limit) -> None:
    needed = heuristics.rachna_dt(mission, eps=1, max_rounds=10**9).rounds
    if needed > limit:
        with pytest.raises(cfopt.MissionError, match=f"max_rounds={limit} rounds"):
            heuristics.rachna_dt(mission, eps=1, max_rounds=limit)
    else:
        assert heuristics.rachna_dt(mission, eps=1, max_rounds=limit).rounds == needed


@given(mission=small_missions(max_robots=6, max_tasks=4), data=st.data())
def test_joint_staffing_check_matches_brute_force(mission, data) -> None:
    finder = _auction.BundleFinder(mission.capabilities, mission.requirements)
    demand = np.array(
        [data.draw(st.integers(0, 3)) for _ in range(mission.n_services)], dtype=np.int64
    )
    # brute force: give every robot one service (or none) in every possible way
    options = [[-1, *np.flatnonzero(row).tolist()] for row in mission.capabilities]
    feasible = False
    for choice in np.array(np.meshgrid(*options)).reshape(len(options), -1).T.tolist():
        got = np.bincount([s for s in choice if s >= 0], minlength=mission.n_services)
        if (got >= demand).all():
            feasible = True
            break
    assert rachna._staffable(finder, demand) == feasible


@pytest.mark.parametrize("bad", [0, -3, True, 2.5, "10"])
def test_max_rounds_must_be_a_positive_whole_number(bad) -> None:
    m = cfopt.Mission.from_arrays([[1]], [[1]], [1])
    with pytest.raises(cfopt.MissionError, match="max_rounds: must be a whole number >= 1"):
        heuristics.rachna_dt(m, max_rounds=bad)


# ------------------------------------------------------- GRAPE-S's utility reward


@pytest.mark.parametrize(
    "utilities",
    [
        pytest.param([1, 1, 5], id="requirements-near-max"),
        pytest.param([1.0, 1.0000000000000002, 5], id="utilities-one-ulp-apart"),
    ],
)
@pytest.mark.parametrize("order", ["index", "random"])
def test_grape_s_near_equal_weights_match_the_reference(utilities, order) -> None:
    """Weights within the float filter: the fast engine's per-pair exact decisions make
    the reference's moves."""
    mission = cfopt.Mission.from_arrays(_ones(12), [[BIG], [BIG - 1], [2]], utilities)
    for capped in (False, True):
        fast = grape_s_eager(mission, seed=5, order=order, capped=capped, reward="utility")
        ref = grape_s_reference(mission, seed=5, order=order, capped=capped, reward="utility")
        assert fast.trajectory.tolist() == ref.trajectory.tolist()
        assert fast.assignment.utility(mission) == 5.0


def _exact_log_sign(q: Fraction, d: Fraction) -> int:
    from decimal import Decimal, localcontext

    # ln q - d can be as small as (q - 1)^2 / 2 (2**-2201 at q = 1 + 2**-1100) beside ln
    # terms up to about 760: twice the decimal zeros of q - 1, plus a margin, keep the
    # absolute error far below it
    diff = abs(q - 1)
    zeros = max(0, diff.denominator.bit_length() - diff.numerator.bit_length()) * 0.302
    with localcontext() as ctx:
        ctx.prec = int(80 + 2 * zeros)
        value = (
            Decimal(q.numerator).ln()
            - Decimal(q.denominator).ln()
            - Decimal(d.numerator) / Decimal(d.denominator)
        )
    return 1 if value > 0 else -1


_RATIOS = st.one_of(
    st.fractions(min_value=Fraction(1, 10**6), max_value=10**6, max_denominator=10**12),
    st.builds(
        lambda a, b: Fraction(a) / Fraction(b),
        st.floats(5e-324, 1e308, allow_nan=False, allow_infinity=False),
        st.floats(5e-324, 1e308, allow_nan=False, allow_infinity=False),
    ),
    st.builds(lambda k: 1 + Fraction(1, 2**k), st.integers(1, 1100)),
)


@given(q=_RATIOS, data=st.data())
def test_float_log_sign_never_contradicts_the_exact_sign(q, data) -> None:
    from heuristics.reward import _float_log_sign, _log_sign

    if q == 1:
        return
    if abs(q - 1) < Fraction(1, 2):  # a d as close to ln q as floats get
        near = Fraction(math.log1p(float(q - 1)))
    else:
        near = Fraction(math.log(q.numerator) - math.log(q.denominator))
    d = data.draw(
        st.sampled_from([near, near * (1 + Fraction(1, 2**50)), Fraction(0), Fraction(1, 3)])
    )
    exact = _exact_log_sign(q, d)
    assert _float_log_sign(q, d) in (0, exact)
    assert _log_sign(q, d) == exact
