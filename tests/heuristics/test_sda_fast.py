"""SDA's prefix-rank engine (heuristics._sda_fast) against the previous engine and brute force.

The engine :func:`heuristics.sda.sda` runs must give exactly what the previous engine
(``heuristics.sda._core_literal``, a binary search of matchings per task) gives: the same
assignment, trajectory, rounds, iterations, work and messages/bytes under both media.  Its
two ingredients are checked on their own: the greedy basis (brute force over all bundles)
and the closed-form counts of the skipped rounds (one round at a time).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from heuristics import _sda_fast, sda
from heuristics._sda_fast import Outcome, greedy_basis
from heuristics.sda import _core, _core_literal
from proofs.strategies import missions
from tests.heuristics.test_auctions_common import all_bundles

SCHEDULES = ("max-wage", "uniform")
EPS = (Fraction(1), Fraction(3, 4), Fraction(5, 2), Fraction(1, 3))


def _counts(out: Outcome) -> tuple:
    """Everything an outcome reports (the Run's communication table derives from it)."""
    return (
        out.task.tolist(),
        out.service.tolist(),
        out.iterations,
        out.rounds,
        out.messages,
        out.bytes,
        out.cast_messages,
        out.cast_bytes,
        out.work,
        out.moves,
    )


def _assert_same(mission: cfopt.Mission, eps: Fraction, schedule: str) -> None:
    fast = _core(mission, eps, schedule)
    literal = _core_literal(mission, eps, schedule)
    assert _counts(fast) == _counts(literal)


def test_sda_runs_the_prefix_rank_engine() -> None:
    assert _core is _sda_fast.core


# ------------------------------------------------------------ engine = previous engine


@settings(max_examples=200, deadline=None)
@given(
    mission=st.one_of(
        missions(max_robots=12, max_tasks=6, max_services=4),
        missions(max_robots=12, max_tasks=6, achievable=True),
        missions(max_robots=12, max_tasks=6, achievable=False),
        missions(max_robots=12, max_tasks=4, max_services=4, max_utility=3),
    ),
    schedule=st.sampled_from(SCHEDULES),
    eps=st.sampled_from(EPS),
)
def test_equal_to_previous_engine_on_hypothesis_missions(mission, schedule, eps) -> None:
    _assert_same(mission, eps, schedule)


@pytest.mark.parametrize(("S", "K"), [(5, 1), (5, 5), (10, 1), (10, 5)])
@pytest.mark.parametrize("load", [1, 1.25, 2])
def test_equal_to_previous_engine_on_generated_missions(S, K, load) -> None:
    """A few hundred robots, every composition and load, both schedules, several eps."""
    for schedule, eps, n, seed in (
        ("max-wage", Fraction(1), 300, 0),
        ("max-wage", Fraction(3, 4), 200, 1),
        ("max-wage", Fraction(1, 3), 120, 2),
        ("uniform", Fraction(1), 300, 0),
        ("uniform", Fraction(5, 2), 300, 1),
        ("uniform", Fraction(1, 3), 200, 2),
    ):
        mission = cfopt.generate_mission(n, 10, S, K, load=load, seed=seed)
        _assert_same(mission, eps, schedule)


def test_equal_with_float_eps_and_media() -> None:
    """Through the public function: a float eps (taken exactly), both media."""
    mission = cfopt.generate_mission(150, 20, 10, 5, load=1.25, seed=4)
    for schedule in SCHEDULES:
        run = sda(mission, eps=0.1, schedule=schedule, medium="unicast")
        literal = _core_literal(mission, Fraction(0.1), schedule)
        assert (run.messages, run.bytes) == (literal.messages, literal.bytes)
        assert run.communication_cost("broadcast") == (literal.cast_messages, literal.cast_bytes)
        assert run.trajectory.tolist() == [list(move) for move in literal.moves]
        assert (run.rounds, run.iterations, run.work) == (
            literal.rounds,
            literal.iterations,
            literal.work,
        )


# ------------------------------------------------------------------ the greedy basis


@st.composite
def _tasks(draw):
    """Robots (capability rows over the task's L needed services) and requirements."""
    L = draw(st.integers(1, 4))
    n = draw(st.integers(1, 8))
    rows = [draw(st.lists(st.booleans(), min_size=L, max_size=L)) for _ in range(n)]
    cap = draw(st.lists(st.integers(1, 3), min_size=L, max_size=L))
    return np.array(rows, dtype=bool).reshape(n, L), cap


def _brute_bundles(rows, cap):
    caps = rows.tolist()
    need = list(enumerate(cap))
    return [sorted(i for i, _ in b) for b in all_bundles(caps, need, range(len(caps)))]


@settings(max_examples=200, deadline=None)
@given(task=_tasks())
def test_greedy_basis_is_the_least_index_bundle(task) -> None:
    """The kept robots are the complete bundle of least index sum (none: fewer kept)."""
    rows, cap = task
    k = sum(cap)
    robots = [i for i in range(rows.shape[0]) if rows[i].any()]
    codes = _sda_fast._codes(rows[robots])
    kept = greedy_basis(robots, codes, cap, k)
    bundles = _brute_bundles(rows, cap)
    if not bundles:
        assert len(kept) < k
        return
    assert kept == min(bundles, key=lambda b: (sum(b), b))


@settings(max_examples=200, deadline=None)
@given(task=_tasks())
def test_prefix_rank_gives_the_least_number_of_high_wage_robots(task) -> None:
    """With the first r robots at the low wage, the cheapest complete bundle has
    ``k - #(basis robots < r)`` high-wage robots, for every r."""
    rows, cap = task
    k = sum(cap)
    robots = [i for i in range(rows.shape[0]) if rows[i].any()]
    kept = greedy_basis(robots, _sda_fast._codes(rows[robots]), cap, k)
    bundles = _brute_bundles(rows, cap)
    for r in range(rows.shape[0] + 1):
        if bundles:
            least = min(sum(1 for i in b if i >= r) for b in bundles)
            assert least == k - sum(1 for i in kept if i < r)


def test_greedy_basis_moves_robots_between_services() -> None:
    """Robot 0 has both services and takes s0's slot; robot 1 (s0 only) fits only if robot 0
    moves to s1: the augmenting chain.  Robot 2 (s0) then finds no room: blocked."""
    codes = [0b11, 0b01, 0b01, 0b10]
    assert greedy_basis([0, 1, 2, 3], codes, [1, 1], 2) == [0, 1]
    assert greedy_basis([0, 1, 2, 3], [0b01, 0b01, 0b01, 0b10], [1, 1], 2) == [0, 3]
    assert greedy_basis([0, 1], [0b01, 0b01], [1, 1], 2) == [0]


def test_codes_beyond_62_services() -> None:
    rows = np.zeros((2, 70), dtype=bool)
    rows[0, [0, 69]] = True
    rows[1, 64] = True
    assert _sda_fast._codes(rows) == [1 | 1 << 69, 1 << 64]


# ------------------------------------------------------- counts of the skipped rounds


def _by_hand(auction, t_from: int, t_to: int) -> tuple[int, int, int, int]:
    """The literal count of rounds ``t_from..t_to`` without an award, round by round:
    (unicast messages, bytes, broadcasts, broadcast bytes).

    ``max-wage``: round ``t`` is decrement ``x = total + t - R`` (none once every wage is
    0, ``x > q D``), of the robot at position ``(x - 1) mod q`` (the fewest decrements,
    lowest index); it is told to every unstaffed task needing one of its services, once
    per service agent under broadcast; 20 bytes each.  ``uniform``: while ``t <= D``,
    every service agent with ``c > 0`` unsold robots tells each of the ``A_s`` unstaffed
    tasks needing it (``8 + 12 c`` bytes), one broadcast when ``A_s > 0``.
    """
    A, q = auction.A, auction.alive.size
    msgs = nbytes = casts = cast_bytes = 0
    for t in range(t_from, t_to + 1):
        if auction.uniform:
            if t > auction.D:
                continue
            for s in range(A.size):
                c = int(auction.caps64[auction.alive, s].sum())
                if c:
                    msgs += int(A[s])
                    nbytes += int(A[s]) * (8 + 12 * c)
                    casts += int(A[s] > 0)
                    cast_bytes += (8 + 12 * c) * int(A[s] > 0)
            continue
        x = auction.total + t - auction.R
        if x > q * auction.D:
            continue
        mine = auction.caps64[int(auction.alive[(x - 1) % q])]
        msgs += int(mine @ A)
        casts += int(mine @ (A > 0))
        nbytes, cast_bytes = 20 * msgs, 20 * casts
    return msgs, nbytes, casts, cast_bytes


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("schedule", SCHEDULES)
def test_skipped_rounds_counted_as_the_literal_auction(seed, schedule) -> None:
    """``quiet`` over a span of rounds without an award (after two award rounds, so some
    robots and tasks are gone) equals the round-by-round count, and the literal work:
    every unstaffed task matches (unsold robots with one of its services) x k_j entries."""
    mission = cfopt.generate_mission(30, 20, 5, 2, load=1.25, seed=seed)
    auction = _sda_fast._Auction(mission, Fraction(1, 2), schedule)
    for _ in range(2):
        best, bidders = auction.next_award()
        if best is None:
            break
        auction.quiet(auction.R + 1, best)
        auction.settle(*auction.award_round(best, bidders))
    if not auction.alive.size:
        return
    # a span running past the end of the wages (q D decrements, D rounds)
    span = (auction.R + 1, auction.R + auction.alive.size * (auction.D + 1) - auction.total + 2)
    auction.out = whole = Outcome(auction.out.task, auction.out.service)
    auction.quiet(*span)
    counted = (whole.messages, whole.bytes, whole.cast_messages, whole.cast_bytes)
    assert counted == _by_hand(auction, *span)
    unsold = auction.caps[auction.alive]
    work = sum(
        int(unsold[:, auction.finder.need[j]].any(axis=1).sum()) * auction.k[j]
        for j in range(auction.m)
        if not auction.staffed[j]
    )
    assert whole.work == (span[1] - span[0] + 1) * work


def test_pruned_tasks_never_get_a_basis() -> None:
    """A task needing more robots than exist is pruned: it is never searched."""
    mission = cfopt.Mission.from_arrays([[1], [1]], [[3], [1]], [5, 2])
    auction = _sda_fast._Auction(mission, Fraction(1), "max-wage")
    out = auction.run()
    assert out.task.tolist() == [1, -1]
    assert 0 not in auction.bases.cache
    assert _counts(out) == _counts(_core_literal(mission, Fraction(1), "max-wage"))
