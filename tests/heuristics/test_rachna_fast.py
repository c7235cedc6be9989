"""RACHNA_dt's incremental price book (:mod:`heuristics._rachna_fast`) changes nothing: the
simultaneous engine with it equals the literal engine (``_core(..., fast=False)``) in
assignment, rounds, iterations, counts under both media, work and trajectory.  Nor does
the bound on the engine's log of bids (``rachna._LOG_CELLS``): a full log only moves the
checkpoint of the cycle detection."""

from __future__ import annotations

from collections.abc import Iterator
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cfopt
from heuristics import rachna
from heuristics._auction import BundleFinder
from heuristics._rachna_fast import Ledger
from proofs.strategies import missions

FIELDS = ("iterations", "rounds", "messages", "bytes", "work", "cast_messages", "cast_bytes")


def assert_same(fast: rachna._Outcome, literal: rachna._Outcome) -> None:
    assert np.array_equal(fast.moves.array(), literal.moves.array())
    assert fast.task.tolist() == literal.task.tolist()
    assert fast.service.tolist() == literal.service.tolist()
    for name in FIELDS:
        assert getattr(fast, name) == getattr(literal, name), name


def both(mission: cfopt.Mission, eps: Fraction, schedule: str = "simultaneous", jump=True):
    runs = []
    for fast in (True, False):
        try:
            runs.append(rachna._core(mission, eps, 10**6, jump=jump, schedule=schedule, fast=fast))
        except cfopt.MissionError as error:  # pragma: no cover - not reached at these sizes
            runs.append(str(error))
    return runs


@settings(max_examples=80, deadline=None)
@given(
    mission=missions(max_robots=12, max_tasks=6, max_services=4, max_utility=60),
    eps=st.sampled_from([None, Fraction(1, 3), Fraction(1), Fraction(5, 2)]),
    jump=st.booleans(),
)
def test_fast_equals_literal_on_hypothesis_missions(mission, eps, jump):
    e = Fraction(1, max(mission.n_robots, 1)) if eps is None else eps
    fast, literal = both(mission, e, jump=jump)
    assert_same(fast, literal)


@settings(max_examples=40, deadline=None)
@given(mission=missions(max_robots=20, max_tasks=8, max_services=3, achievable=False, load=2.0))
def test_fast_equals_literal_on_over_subscribed_missions(mission):
    e = Fraction(1, max(mission.n_robots, 1))
    fast, literal = both(mission, e)
    assert_same(fast, literal)


@pytest.mark.parametrize(("S", "K"), [(5, 1), (5, 5), (10, 1), (10, 5)])
@pytest.mark.parametrize("load", [1.0, 1.25, 2.0])
@pytest.mark.parametrize("eps", [None, Fraction(1, 8), Fraction(1, 2)])
def test_fast_equals_literal_on_generated_missions(S, K, load, eps):
    n = 40 if eps is None else 60
    mission = cfopt.generate_mission(n, 20, S, K, load=load, seed=S * 10 + K)
    e = Fraction(1, n) if eps is None else eps
    fast, literal = both(mission, e)
    assert_same(fast, literal)


@pytest.mark.parametrize(("S", "K"), [(5, 5), (10, 1)])
def test_fast_equals_literal_on_a_larger_mission(S, K):
    """A few hundred robots, a short auction (load 1): many tasks bid together."""
    mission = cfopt.generate_mission(300, 10, S, K, seed=3)
    fast, literal = both(mission, Fraction(1, 300))
    assert_same(fast, literal)


@pytest.mark.parametrize("schedule", rachna.SCHEDULES)
def test_public_run_is_unchanged(schedule):
    """``rachna_dt`` (fast by default) reports what the literal engine counts."""
    mission = cfopt.generate_mission(40, 20, 10, 5, load=1.25, seed=1)
    run = rachna.rachna_dt(mission, schedule=schedule, medium="unicast")
    literal = rachna._core(
        mission, Fraction(1, 40), rachna.MAX_ROUNDS, schedule=schedule, fast=False
    )
    assert run.trajectory.tolist() == literal.moves.array().tolist()
    assert (run.rounds, run.iterations, run.messages, run.bytes, run.work) == (
        literal.rounds,
        literal.iterations,
        literal.messages,
        literal.bytes,
        literal.work,
    )


def random_books(
    mission: cfopt.Mission, steps: int, seed: int, most_changed: int, most_rise: int
) -> Iterator[tuple[BundleFinder, Ledger, rachna._Book]]:
    """The finder, the ledger and the literal book after each of ``steps`` random changes
    of wages (rises below ``most_rise``) and flags (below ``most_changed`` robots)."""
    rng = np.random.default_rng(seed)
    n = mission.n_robots
    finder = BundleFinder(mission.capabilities, mission.requirements)
    market = rachna._Market(finder)
    wage = np.zeros(n, dtype=np.int64)
    held = np.zeros(n, dtype=np.int64)
    ledger = Ledger(market, wage, held, rachna._services)
    for _ in range(steps):
        changed = np.unique(rng.integers(0, n, size=rng.integers(1, most_changed)))
        wage[changed] += rng.integers(0, most_rise, size=changed.size)
        held[changed] = rng.integers(0, 2, size=changed.size)
        ledger.update(changed)
        yield finder, ledger, market.book(wage, held)


def test_ledger_answers_as_the_literal_book_after_updates():
    """Random wage and flag changes: every task's answer equals the literal book's."""
    mission = cfopt.generate_mission(50, 20, 5, 5, load=1.25, seed=2)
    for _, ledger, book in random_books(mission, 60, seed=5, most_changed=6, most_rise=2):
        for j in range(mission.n_tasks):
            got, want = ledger.best(j), book.best(j)
            assert (got is None) == (want is None)
            if got is not None:
                assert got[0].tolist() == want[0].tolist()
                assert got[1].tolist() == want[1].tolist()
                assert got[2] == want[2]


def test_ledger_falls_back_past_the_key_limit():
    """Wages past the int64 keys' limit: the literal book answers, as before."""
    mission = cfopt.generate_mission(10, 20, 5, 5, seed=0)
    finder = BundleFinder(mission.capabilities, mission.requirements)
    market = rachna._Market(finder)
    wage = np.zeros(10, dtype=np.int64)
    held = np.zeros(10, dtype=np.int64)
    ledger = Ledger(market, wage, held, rachna._services)
    assert ledger.book() is ledger
    wage[3] = market.limit + 1
    ledger.update(np.array([3]))
    assert ledger.book() is not ledger
    assert not ledger.kept


def war() -> cfopt.Mission:
    """Two tasks on one robot, budgets 1e4 and 2e4 units at eps = 1: a 2-round cycle."""
    return cfopt.Mission.from_arrays([[1]], [[1], [1]], [1e4, 2e4])


@pytest.mark.parametrize("cells", [8, 2])
def test_a_full_bid_log_only_moves_the_checkpoint(cells):
    """A log cap above one period of the war still jumps it; below, every round is run;
    both give the uncapped run, and the log never holds more than one round past the cap."""
    reference = rachna._core(war(), Fraction(1), 10**5)
    held, leaps = [], []
    add, leap = rachna._BidLog.add, rachna._leap

    def logging_add(log, tasks):
        add(log, tasks)
        held.append(log.cells)

    def counting_leap(*args):
        leaps.append(leap(*args))
        return leaps[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rachna, "_LOG_CELLS", cells)
        patch.setattr(rachna._BidLog, "add", logging_add)
        patch.setattr(rachna, "_leap", counting_leap)
        capped = rachna._core(war(), Fraction(1), 10**5)
    assert_same(capped, reference)
    assert max(held) <= cells + 2  # one round of the war: one bid, one round
    assert any(leaps) == (cells == 8)


@settings(max_examples=40, deadline=None)
@given(
    mission=missions(max_robots=6, max_tasks=4, max_services=3, max_utility=60),
    cells=st.sampled_from([4, 16, 64]),
)
def test_a_small_bid_log_changes_nothing(mission, cells):
    """Wars with the log capped at a few bids equal the run without jumps."""
    e = Fraction(1, 3)
    literal = rachna._core(mission, e, 10**6, jump=False)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rachna, "_LOG_CELLS", cells)
        capped = rachna._core(mission, e, 10**6)
    assert_same(capped, literal)


def test_bid_log_gives_back_its_rounds():
    """The log returns each round's bidding tasks and counts the words a log of whole
    words it holds (one a bid, one a round)."""
    log = rachna._BidLog()
    log.add([3, 0])
    log.add([1])
    assert list(log.rounds()) == [[3, 0], [1]]
    assert log.cells == 3 + 2


def test_more_services_than_int64_bits():
    """70 services: the capability codes pass int64, so the ledger hands its slot
    fillings to the literal one; the engines still agree."""
    mission = cfopt.generate_mission(40, 20, 70, 40, load=1.25, seed=4)
    calls = []
    services = rachna._services

    def counting(*args):
        calls.append(args[1])
        return services(*args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rachna, "_services", counting)
        fast = rachna._core(mission, Fraction(1, 40), 10**6)
    assert_same(fast, rachna._core(mission, Fraction(1, 40), 10**6, fast=False))
    assert calls
