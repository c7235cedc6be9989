"""RACHNA_dt's bidding wars: the simultaneous engine's bulk settling of losing bids
(:func:`heuristics.rachna._settle`) gives what the round-by-round reference gives.

The reference is ``_core(..., jump=False, fast=False)``: every round run, every bidding
task searched on the literal price book.  The engine under test is the default one (the
incremental ledger, losing bids settled without a search, jumps over repeating wars).
Equal means the same trajectory rows, holders, services, rounds, iterations, work and
counts under both media."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from heuristics import _rachna_fast, rachna
from heuristics._rachna_fast import LastBundles, Ledger
from proofs.strategies import missions
from tests.heuristics.test_rachna_fast import assert_same, random_books


def engine_and_reference(mission: cfopt.Mission, eps: Fraction) -> None:
    got = rachna._core(mission, eps, 10**6)
    want = rachna._core(mission, eps, 10**6, jump=False, fast=False)
    assert_same(got, want)


@settings(max_examples=60, deadline=None)
@given(
    mission=missions(max_robots=16, max_tasks=10, max_services=3, achievable=False, load=1.5),
    eps=st.sampled_from([None, Fraction(1, 4), Fraction(2)]),
)
def test_over_subscribed_hypothesis_missions_match_the_reference(mission, eps):
    e = Fraction(1, max(mission.n_robots, 1)) if eps is None else eps
    engine_and_reference(mission, e)


@pytest.mark.parametrize(("S", "K"), [(5, 1), (5, 5), (10, 1), (10, 5)])
@pytest.mark.parametrize("percent", [10, 50])
@pytest.mark.parametrize("load", [1.25, 1.5, 2.0])
def test_the_audits_over_subscribed_cells_at_small_sizes(S, K, percent, load):
    """The audit's over-subscribed cells (every composition, 10 and 50 % tasks, loads
    1.25, 1.5 and 2), at 30 robots instead of 100, eps = 1/n."""
    mission = cfopt.generate_mission(30, percent, S, K, load=load, seed=S + K + percent)
    engine_and_reference(mission, Fraction(1, 30))


def crowd(tasks: int, robots: int, utilities: list[float]) -> cfopt.Mission:
    """``tasks`` tasks each needing one robot of the one service, ``robots`` robots."""
    return cfopt.Mission.from_arrays(
        [[1]] * robots,
        [[1]] * tasks,
        utilities[:tasks] + [utilities[-1]] * (tasks - len(utilities)),
    )


@pytest.mark.parametrize(
    "mission",
    [
        crowd(6, 3, [5, 9, 2, 7, 7, 4]),  # six bidders on three robots
        crowd(12, 4, [3, 8, 8, 8, 1, 6, 6, 6, 2, 9, 9, 4]),  # equal budgets: ties by index
        cfopt.Mission.from_arrays(  # overlapping needs: bundles of two over one shared robot
            [[1, 1], [1, 0], [0, 1], [1, 1]],
            [[1, 1], [2, 0], [0, 2], [1, 0], [0, 1]],
            [9, 7, 6, 3, 8],
        ),
        cfopt.Mission.from_arrays(  # one robot everyone wants, others only some
            [[1, 1, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
            [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1], [1, 0, 1]],
            [4, 5, 6, 9, 8, 7],
        ),
    ],
)
@pytest.mark.parametrize("eps", [Fraction(1, 2), Fraction(1, 10)])
def test_hand_made_bidding_wars_match_the_reference(mission, eps):
    engine_and_reference(mission, eps)


def test_losing_bids_are_settled_without_searches():
    """On a crowded war most bids lose to an earlier winner of their round: the engine
    searches far fewer bundles than there are bids, and still equals the reference."""
    mission = crowd(12, 4, [3, 8, 8, 8, 1, 6, 6, 6, 2, 9, 9, 4])
    searches, bids = [], []
    best, settle = Ledger.best, rachna._settle

    def counting_best(self, j):
        searches.append(j)
        return best(self, j)

    def counting_settle(*args):
        result = settle(*args)
        bids.extend(result[0])
        return result

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Ledger, "best", counting_best)
        patch.setattr(rachna, "_settle", counting_settle)
        got = rachna._core(mission, Fraction(1, 10), 10**6, jump=False)
    assert_same(got, rachna._core(mission, Fraction(1, 10), 10**6, jump=False, fast=False))
    assert len(searches) < len(bids) / 2


def test_wages_past_the_exact_matching_settle_every_bid_by_search():
    """When the wages pass what the matching orders exactly, the shortcut stops (here
    forced after 3 units) and every bid is searched again; the run still equals the
    reference."""
    mission = crowd(6, 3, [5, 9, 2, 7, 7, 4])
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(_rachna_fast, "_exact_limit", lambda finder: 3)
        got = rachna._core(mission, Fraction(1, 4), 10**6)
    assert_same(got, rachna._core(mission, Fraction(1, 4), 10**6, jump=False, fast=False))


def test_a_blocked_task_s_cheapest_bundle_holds_a_taken_robot():
    """The lemma the shortcut rests on, on random wages, flags and taken robots: when
    :meth:`Ledger.blocked` says so, task ``j``'s cheapest bundle on the literal book holds
    a taken robot; and it says so for every task whose ``r_s`` least robots having ``s``
    hold one (those robots are all in the bundle)."""
    rng = np.random.default_rng(11)
    mission = cfopt.generate_mission(60, 30, 10, 5, load=1.5, seed=3)
    verdicts = []
    for finder, ledger, book in random_books(mission, 40, seed=7, most_changed=12, most_rise=3):
        tasks = np.flatnonzero(finder.possible)
        taken = rng.random(60) < 0.08
        blocked = ledger.blocked(tasks, taken)
        order = np.asarray(ledger.sorted, dtype=np.int64) % ledger.k_f  # robots by key
        for j, says in zip(tasks.tolist(), blocked.tolist(), strict=True):
            bundle = book.best(j)[0]
            firsts = [
                order[finder.caps[order, s]][:r]
                for s, r in zip(finder.need[j].tolist(), finder.counts[j], strict=True)
            ]
            assert set(np.concatenate(firsts).tolist()) <= set(bundle.tolist())
            assert says == any(taken[first].any() for first in firsts)
            assert not says or taken[bundle].any()
            verdicts.append(says)
    assert any(verdicts) and not all(verdicts)


def test_last_bundles_price_each_task_on_the_current_wages():
    last = LastBundles([2, 1, 3], 5, [7, 1, 2**70])
    wage = np.array([1, 2, 3, 0, 4], dtype=np.int64)
    last.keep(0, np.array([1, 2]))  # 2 + 3 + 2 = 7 <= 7
    last.keep(2, np.array([0, 3, 4]))  # 1 + 0 + 4 + 3 = 8, budget capped at 2^62
    tasks = np.arange(3)
    assert last.affordable(tasks, wage).tolist() == [True, False, True]  # task 1: none kept
    wage[2] += 1
    assert last.affordable(tasks, wage).tolist() == [False, False, True]
    assert LastBundles.fits([3] * 10) and not LastBundles.fits([2**13] * 2**12)


@pytest.mark.parametrize(("S", "K", "load"), [(10, 5, 1.5), (5, 1, 2.0), (10, 1, 1.25)])
def test_the_proof_reads_the_same_prices_from_the_ledger(S, K, load):
    """At every checkpoint the lower bound on the rounds left, with the least prices read
    from the ledger, equals the bound with the literal finder's searches."""
    mission = cfopt.generate_mission(40, 50, S, K, load=load, seed=9)
    rounds_left, bounds = rachna._rounds_left, []

    def both(limit, holdings, price=None):
        bound = rounds_left(limit, holdings, price)
        assert bound == rounds_left(limit, holdings)
        bounds.append((price is not None, bound))
        return bound

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rachna, "_rounds_left", both)
        got = rachna._core(mission, Fraction(1, 40), 10**6)
    assert_same(got, rachna._core(mission, Fraction(1, 40), 10**6, jump=False, fast=False))
    assert any(with_price and bound is not None for with_price, bound in bounds)
