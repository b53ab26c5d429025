"""Statistics over rings and the allocation of the scale factor (no core needed)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from cyclomesh.tolerance.allocation import allocate_factor, minimum_rings
from cyclomesh.tolerance.statistics import (
    clopper_pearson,
    describe,
    exceedance_probability,
    lower_quantile_bound_rank,
    order_statistic_ranks,
    percentile_with_interval,
)


def brute_percentile(values, q):
    """Hyndman & Fan type 7 by hand: h = (n − 1)·q, linear between neighbours."""
    x = sorted(values)
    h = (len(x) - 1) * q / 100
    lo = int(np.floor(h))
    hi = min(lo + 1, len(x) - 1)
    return x[lo] + (h - lo) * (x[hi] - x[lo])


@pytest.mark.parametrize("n", [1, 2, 7, 100, 1001])
def test_percentiles_match_a_brute_force_computation(n):
    values = np.random.default_rng(n).gamma(2.0, 100.0, n)
    for p in percentile_with_interval(values, (5, 50, 95, 99)):
        assert p.estimate == pytest.approx(brute_percentile(values, p.percent), rel=1e-12)


def test_percentile_interval_brackets_the_estimate_and_uses_order_statistics():
    values = np.random.default_rng(3).normal(size=1000)
    x = np.sort(values)
    for p in percentile_with_interval(values):
        assert p.lower <= p.estimate <= p.upper
        assert p.lower in x and p.upper in x
    # too few rings for a two-sided interval on the 99th percentile: upper bound missing
    p99 = percentile_with_interval(values[:50], (99,))[0]
    assert np.isnan(p99.upper) and np.isfinite(p99.lower)


def test_order_statistic_interval_has_its_coverage():
    """Distribution-free: coverage ≥ 95 % for any continuous distribution."""
    rng = np.random.default_rng(5)
    n, q, reps = 200, 0.95, 4000
    lo, hi = order_statistic_ranks(n, q, 0.95)
    true = stats.expon.ppf(q)
    x = np.sort(rng.exponential(size=(reps, n)), axis=1)
    covered = np.mean((x[:, lo - 1] <= true) & (true <= x[:, hi - 1]))
    assert covered >= 0.95 - 3 * np.sqrt(0.95 * 0.05 / reps)
    exact = stats.binom.cdf(hi - 1, n, q) - stats.binom.cdf(lo - 1, n, q)
    assert exact >= 0.95


def test_exceedance_probability_is_clopper_pearson():
    p = exceedance_probability(3, 200, 0.95)
    assert p.estimate == 3 / 200
    assert p.lower == pytest.approx(stats.beta.ppf(0.025, 3, 198), rel=1e-9)
    assert p.upper == pytest.approx(stats.beta.ppf(0.975, 4, 197), rel=1e-9)
    zero = exceedance_probability(0, 299, 0.95)
    assert zero.lower == 0.0 and zero.upper == pytest.approx(1 - 0.025 ** (1 / 299), rel=1e-9)
    lo, hi = clopper_pearson([3, 0, 200], 200, 0.95)
    assert lo[0] == pytest.approx(p.lower) and hi[0] == pytest.approx(p.upper)
    assert lo[1] == 0.0 and hi[2] == 1.0


def test_describe_gives_mean_std_and_percentiles():
    values = np.arange(1.0, 101.0)
    d = describe(values)
    assert d["mean"] == 50.5 and d["std"] == pytest.approx(np.std(values, ddof=1))
    assert [p["percent"] for p in d["percentiles"]] == [5.0, 50.0, 95.0, 99.0]


def test_lower_quantile_bound_rank():
    assert lower_quantile_bound_rank(298, 0.01, 0.95) == 0
    assert lower_quantile_bound_rank(299, 0.01, 0.95) == 1
    assert minimum_rings(0.01, 0.95) == 299
    r = lower_quantile_bound_rank(1000, 0.01, 0.95)
    assert stats.binom.sf(r - 1, 1000, 0.01) >= 0.95 > stats.binom.sf(r, 1000, 0.01)


def test_allocation_recovers_a_known_quantile():
    """Critical factors exponential with mean 1: the 5 % quantile is −ln 0.95."""
    rng = np.random.default_rng(9)
    crit = rng.exponential(size=20000)
    a = allocate_factor(crit, crit, 0.05, 0.95, factor_max=10.0)
    assert a.factor == pytest.approx(-np.log(0.95), rel=0.05)
    assert a.confident_factor <= a.factor
    assert np.all(np.diff(a.curve_probability) >= 0)  # non-decreasing in the factor
    assert np.all(a.curve_lower <= a.curve_probability + 1e-15)
    assert np.all(a.curve_probability <= a.curve_upper + 1e-15)


def test_allocation_is_monotone_in_the_target():
    crit = np.random.default_rng(2).lognormal(size=3000)
    factors = [allocate_factor(crit, crit, t).factor for t in (0.001, 0.01, 0.05, 0.2)]
    assert factors == sorted(factors)


def test_allocation_without_enough_rings_states_it():
    crit = np.linspace(0.5, 2.0, 100)
    a = allocate_factor(crit, crit, 0.01, 0.95, factor_max=4.0)
    assert np.isnan(a.confident_factor)
    assert "at least 299 rings" in a.statement()


def test_allocation_censored_when_no_ring_exceeds():
    lower = np.full(50, 2.0)
    upper = np.full(50, np.inf)
    a = allocate_factor(lower, upper, 0.01, 0.95, factor_max=2.0)
    assert a.factor == 2.0 and a.factor_censored
    assert "or more" in a.statement()


def _ranks_over_the_whole_range(n, p, confidence):
    """The ranks of order_statistic_ranks from the binomial CDF at every rank 0 .. n + 1."""
    r = np.arange(0, n + 2)
    cdf = np.where(r - 1 < 0, 0.0, stats.binom.cdf(r - 1, n, p))
    alpha = 1.0 - confidence
    low = np.nonzero(cdf <= alpha / 2)[0]
    high = np.nonzero(cdf >= 1.0 - alpha / 2)[0]
    return (int(r[low[-1]]) if low.size else 0, int(r[high[0]]) if high.size else n + 1)


@pytest.mark.parametrize("n", [1, 5, 50, 299, 1000, 20000, 250000])
@pytest.mark.parametrize("confidence", [0.5, 0.95, 0.9999])
def test_order_statistic_ranks_searched_in_a_window_are_those_of_the_whole_range(n, confidence):
    for p in (0.0, 0.001, 0.05, 0.5, 0.95, 0.99, 1.0):
        assert order_statistic_ranks(n, p, confidence) == _ranks_over_the_whole_range(
            n, p, confidence
        )


def test_percentiles_of_a_partial_sort_are_those_of_a_full_sort():
    """One partition at the needed ranks and one percentile call give the numbers of a
    full sort and one call per percentile, bit for bit (ties and NaN included)."""
    rng = np.random.default_rng(11)
    for n in (3, 40, 1001):
        for x in (rng.normal(size=n), np.round(rng.gamma(2.0, 3.0, n))):
            s = np.sort(x)
            for p in percentile_with_interval(x, (1, 5, 50, 95, 99)):
                lo, hi = order_statistic_ranks(n, p.percent / 100.0)
                assert p.estimate == np.percentile(s, p.percent)
                assert p.lower == s[lo - 1] if lo >= 1 else np.isnan(p.lower)
                assert p.upper == s[hi - 1] if hi <= n else np.isnan(p.upper)
    x = rng.normal(size=50)
    x[7] = np.nan
    assert all(np.isnan(p.estimate) for p in percentile_with_interval(x))
