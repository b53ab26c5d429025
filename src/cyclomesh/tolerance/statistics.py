"""Statistics over Monte Carlo rings: percentiles with intervals, exceedance probability.

Methods (stated in every output that uses them):

- Percentiles: point estimate by linear interpolation between order statistics
  (``numpy.percentile`` default, Hyndman & Fan type 7).
- Percentile confidence interval: distribution-free order-statistic interval
  [x(l), x(u)] with l, u from the binomial distribution of the number of rings below
  the true quantile, B ~ Bin(n, p): l is the largest rank with P(B ≤ l − 1) ≤ α/2 and
  u the smallest with P(B ≤ u − 1) ≥ 1 − α/2, so that P(x(l) ≤ ξp ≤ x(u)) ≥ 1 − α
  (Hahn & Meeker, Statistical Intervals, 1991, §5.2). A bound that needs a rank
  outside 1..n is not available (NaN): too few rings for that percentile.
- Exceedance probability: k/n with the exact Clopper–Pearson interval
  (the beta quantiles of ``scipy.stats.binomtest(...).proportion_ci(method="exact")``,
  taken from ``scipy.special`` directly: ``scipy.stats`` takes longer to import than a
  small study takes to run).
- One-sided lower confidence bound on a p-quantile (used by the allocation): the
  order statistic x(r) with the largest r such that P(B ≥ r) ≥ confidence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

__all__ = [
    "PERCENTILES",
    "Percentile",
    "Proportion",
    "percentile_with_interval",
    "order_statistic_ranks",
    "clopper_pearson",
    "exceedance_probability",
    "lower_quantile_bound_rank",
    "describe",
]

PERCENTILES: tuple[float, ...] = (5.0, 50.0, 95.0, 99.0)


@dataclass(frozen=True)
class Percentile:
    """A percentile estimate with its distribution-free confidence interval."""

    percent: float
    estimate: float
    lower: float
    upper: float


@dataclass(frozen=True)
class Proportion:
    """A binomial proportion k/n with its Clopper–Pearson interval."""

    count: int
    total: int
    estimate: float
    lower: float
    upper: float
    confidence: float


def binomial_cdf(k: ArrayLike, n: int, p: float) -> NDArray[np.float64]:
    """P(B ≤ k) of B ~ Bin(n, p), for integer k (0 below 0, 1 from n on)."""
    k = np.asarray(k)
    inside = special.bdtr(np.clip(k, 0, n), n, p)
    return np.where(k < 0, 0.0, np.where(k >= n, 1.0, inside))


def order_statistic_ranks(n: int, p: float, confidence: float = 0.95) -> tuple[int, int]:
    """1-based ranks (l, u) of the order-statistic interval for the p-quantile.

    A rank of 0 (lower) or n + 1 (upper) means the bound is not available.

    The binomial distribution function is evaluated on the ranks within
    :data:`RANK_WINDOW_SD` standard deviations of n·p only (:func:`_rank_window`), where
    it crosses α/2 and 1 − α/2; outside it, it is within about 1e-30 of 0 or 1, so the
    ranks are those of the whole range 0 .. n + 1, which is taken instead whenever the
    window's ends do not bracket both crossings. Cached: a study asks for the same
    (n, p, confidence) once per metric.
    """
    return _order_statistic_ranks(int(n), float(p), float(confidence))


RANK_WINDOW_SD = 12.0
"""Half-width of the window of ranks around n·p that :func:`order_statistic_ranks` searches,
in standard deviations sqrt(n·p·(1 − p)) of the binomial distribution [-]."""


@cache
def _order_statistic_ranks(n: int, p: float, confidence: float) -> tuple[int, int]:
    alpha = 1.0 - confidence
    first, stop = _rank_window(n, p)
    r = np.arange(first, stop)
    cdf = binomial_cdf(r - 1, n, p)  # P(B ≤ r − 1)
    brackets = (first == 0 or cdf[0] <= alpha / 2) and (stop == n + 2 or cdf[-1] >= 1.0 - alpha / 2)
    if not brackets:  # the crossings outside the window: the whole range
        r = np.arange(0, n + 2)
        cdf = binomial_cdf(r - 1, n, p)
    lower_ok = np.nonzero(cdf <= alpha / 2)[0]
    lower = int(r[lower_ok[-1]]) if lower_ok.size else 0
    upper_ok = np.nonzero(cdf >= 1.0 - alpha / 2)[0]
    upper = int(r[upper_ok[0]]) if upper_ok.size else n + 1
    return max(lower, 0), min(upper, n + 1)


def _rank_window(n: int, p: float) -> tuple[int, int]:
    """Ranks first .. stop − 1 within :data:`RANK_WINDOW_SD` standard deviations (and 2
    ranks) of n·p, clipped to 0 .. n + 1."""
    half = RANK_WINDOW_SD * math.sqrt(n * p * (1.0 - p)) + 2.0
    first = max(0, math.floor(n * p - half))
    stop = min(n + 2, math.ceil(n * p + half) + 1)
    return first, stop


def percentile_with_interval(
    values: ArrayLike, percents: Sequence[float] = PERCENTILES, confidence: float = 0.95
) -> list[Percentile]:
    """Percentiles of ``values`` with order-statistic confidence intervals.

    Parameters
    ----------
    values : array_like
        One value per ring, any unit (NaN not allowed).
    percents : sequence of float
        Percentiles in [0, 100].
    confidence : float
        Two-sided confidence level of the intervals [-].

    The order statistics the intervals need are found by one partial sort
    (``numpy.partition`` at those ranks: the same values as a full sort's), and the
    estimates by one ``numpy.percentile`` call for all ``percents`` (elementwise the
    same interpolation as one call per percentile).
    """
    x = np.asarray(values, dtype=float).reshape(-1)
    n = x.size
    if not n:
        return [Percentile(float(q), *(float("nan"),) * 3) for q in percents]
    ranks = [order_statistic_ranks(n, q / 100.0, confidence) for q in percents]
    kth = sorted({k - 1 for pair in ranks for k in pair if 1 <= k <= n})
    part = np.partition(x, kth) if kth else x
    estimates = np.percentile(x, list(percents)) if len(percents) else []
    out = []
    for q, est, (lo_rank, hi_rank) in zip(percents, estimates, ranks, strict=True):
        lo = float(part[lo_rank - 1]) if 1 <= lo_rank <= n else float("nan")
        hi = float(part[hi_rank - 1]) if 1 <= hi_rank <= n else float("nan")
        out.append(Percentile(float(q), float(est), lo, hi))
    return out


def clopper_pearson(
    count: ArrayLike, total: int, confidence: float = 0.95
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact two-sided Clopper–Pearson interval of count/total, vectorised over count."""
    k = np.asarray(count, dtype=float)
    alpha = 1.0 - confidence
    with np.errstate(invalid="ignore"):
        lower = np.where(k > 0, special.betaincinv(k, total - k + 1, alpha / 2), 0.0)
        upper = np.where(k < total, special.betaincinv(k + 1, total - k, 1 - alpha / 2), 1.0)
    return lower, upper


def exceedance_probability(count: int, total: int, confidence: float = 0.95) -> Proportion:
    """Probability estimate count/total with its exact Clopper–Pearson interval."""
    if total <= 0:
        return Proportion(count, total, float("nan"), 0.0, 1.0, confidence)
    k, n = int(count), int(total)
    low, high = clopper_pearson(k, n, confidence)
    return Proportion(k, n, count / total, float(low), float(high), confidence)


def lower_quantile_bound_rank(n: int, p: float, confidence: float = 0.95) -> int:
    """Largest 1-based rank r with P(Bin(n, p) ≥ r) ≥ confidence (0 if none).

    With that r, x(r) is a lower confidence bound on the p-quantile: with the stated
    confidence, the fraction of the population below x(r) is at most p.
    """
    r = np.arange(1, n + 1)
    ok = np.nonzero(special.bdtrc(r - 1, n, p) >= confidence)[0]  # P(B ≥ r), 1 ≤ r ≤ n
    return int(r[ok[-1]]) if ok.size else 0


def describe(
    values: ArrayLike, percents: Sequence[float] = PERCENTILES, confidence: float = 0.95
) -> dict[str, float | list[dict[str, float]]]:
    """Mean, sample standard deviation (ddof 1), min, max and percentiles with intervals."""
    x: NDArray[np.float64] = np.asarray(values, dtype=float).reshape(-1)
    n = x.size
    return {
        "count": n,
        "mean": float(np.mean(x)) if n else float("nan"),
        "std": float(np.std(x, ddof=1)) if n > 1 else float("nan"),
        "min": float(np.min(x)) if n else float("nan"),
        "max": float(np.max(x)) if n else float("nan"),
        "percentiles": [
            {"percent": p.percent, "estimate": p.estimate, "lower": p.lower, "upper": p.upper}
            for p in percentile_with_interval(x, percents, confidence)
        ],
    }
