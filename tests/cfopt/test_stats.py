"""cfopt.stats: each test against scipy / scikit-posthocs, its direction, its power, and
the one edge rule (not enough data, no variation: values, never exceptions or None)."""

from __future__ import annotations

import numpy as np
import pytest
import scikit_posthocs
from scipy import stats as scipy_stats

from cfopt.stats import (
    ALPHA,
    Outcome,
    complete_blocks,
    friedman,
    kruskal,
    mann_whitney,
    wilcoxon,
)

RNG = np.random.default_rng(11)
A, B, C = (RNG.normal(mu, 1.0, size=9).round(3) for mu in (0.0, 1.5, 3.0))


def test_friedman_and_conover_match_the_libraries() -> None:
    r = friedman({"a": A, "b": B, "c": C})
    chi2, p = scipy_stats.friedmanchisquare(A, B, C)
    assert (r.statistic, r.p_value) == (pytest.approx(chi2), pytest.approx(p))
    conover = scikit_posthocs.posthoc_conover_friedman(np.column_stack([A, B, C])).to_numpy()
    assert r.pair("c", "a").p_value == pytest.approx(conover[0, 2])
    assert (r.sizes, r.n, r.lowest, r.highest, r.outcome) == ((9,) * 3, 9, "a", "c", Outcome.TESTED)
    assert r.smallest_p == pytest.approx(scipy_stats.chi2.sf(9 * 2, 2))


def test_kruskal_with_mann_whitney_pairs() -> None:
    r = kruskal({"100": A, "500": B, "1000": C})
    h, p = scipy_stats.kruskal(A, B, C)
    assert (r.statistic, r.p_value) == (pytest.approx(h), pytest.approx(p))
    _, pair = scipy_stats.mannwhitneyu(A, C, alternative="two-sided")
    assert r.pair("100", "1000").p_value == pytest.approx(pair)
    assert r.trend == "increases" and r.medians[0] == pytest.approx(np.median(A))
    flipped = kruskal({"1": C, "10": B, "50": A})
    assert flipped.trend == "decreases" and flipped.lowest == "50"


def test_two_sample_tests() -> None:
    u, p = scipy_stats.mannwhitneyu(A, B, alternative="two-sided")
    r = mann_whitney({"5": A, "10": B})
    assert (r.statistic, r.p_value, r.highest) == (pytest.approx(u), pytest.approx(p), "10")
    w, p = scipy_stats.wilcoxon(A, B)
    r = wilcoxon({"grape-s": A, "sda": B})
    assert (r.statistic, r.p_value, r.lowest) == (pytest.approx(w), pytest.approx(p), "grape-s")


@pytest.mark.parametrize(
    ("result", "why"),
    [
        pytest.param(friedman({"a": A, "b": B}), "2 groups, Friedman needs 3", id="friedman-2"),
        pytest.param(friedman({"a": [1], "b": [2], "c": [3]}), "1 blocks", id="friedman-1-block"),
        pytest.param(kruskal({"a": A, "b": B}), "Kruskal-Wallis needs 3", id="kruskal-2"),
        pytest.param(kruskal({"a": A, "b": B, "c": []}), "an empty group", id="kruskal-empty"),
        pytest.param(mann_whitney({"a": A}), "1 groups", id="mann-whitney-1"),
        pytest.param(mann_whitney({"a": A, "b": []}), "an empty group", id="mann-whitney-empty"),
        pytest.param(wilcoxon({"a": [], "b": []}), "no pairs", id="wilcoxon-empty"),
    ],
)
def test_not_enough_data_is_an_outcome(result, why: str) -> None:
    assert result.outcome is Outcome.NOT_ENOUGH_DATA and why in result.note
    assert result.p_value is None and not result.significant and not result.has_power
    assert result.lowest is None and result.to_dict()["outcome"] == "not enough data"


def test_no_variation_is_an_outcome_with_its_ranks() -> None:
    for result in (
        friedman({"a": [1, 2], "b": [1, 2], "c": [1, 2]}),
        kruskal({"a": [5, 5], "b": [5], "c": [5, 5]}),
        mann_whitney({"a": [5, 5], "b": [5]}),
        wilcoxon({"a": [1, 2], "b": [1, 2]}),
    ):
        assert result.outcome is Outcome.NO_VARIATION and "no variation" in result.note
        assert result.statistic is None and result.lowest is None and result.mean_ranks


def test_power_small_samples_cannot_reject() -> None:
    # 2 / C(6, 3) = 0.1 and 2 / 2^5 = 0.0625: no data could give p < 0.05
    assert mann_whitney({"a": [1, 2, 3], "b": [4, 5, 6]}).smallest_p == pytest.approx(0.1)
    assert not wilcoxon({"a": [1, 2, 3, 4, 5], "b": [2, 3, 4, 5, 6]}).has_power
    assert wilcoxon({"a": range(6), "b": range(1, 7)}).smallest_p < ALPHA
    assert kruskal({"a": [1, 2, 3], "b": [4, 5, 6], "c": [7, 8, 9]}).smallest_p < ALPHA


def test_malformed_groups_raise() -> None:
    with pytest.raises(ValueError, match="one value per group and block"):
        friedman({"a": [1, 2], "b": [1], "c": [1, 2]})
    with pytest.raises(ValueError, match="needs pairs"):
        wilcoxon({"a": [1, 2], "b": [1]})
    with pytest.raises(ValueError, match=r"groups\['b'\]: must be finite numbers"):
        kruskal({"a": [1], "b": [float("nan")], "c": [2]})


def test_complete_blocks_keeps_blocks_with_every_group() -> None:
    observations = [(1, "a", 1.0), (1, "b", 2.0), (2, "a", 3.0), (3, "a", 4.0), (3, "b", None),
                    (4, "b", 5.0), (4, "a", float("inf")), (5, "x", 1.0)]  # fmt: skip
    assert complete_blocks(observations, ["a", "b"]) == {"a": [1.0], "b": [2.0]}
