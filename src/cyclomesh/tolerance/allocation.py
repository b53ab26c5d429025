"""Tolerance allocation: the largest scale factor on the stated tolerances that keeps the
probability of exceeding the allowable contact stress at or below a target.

Common random numbers: every ring keeps its underlying draws and all its errors are
scaled by the factor f together, so each ring has a critical factor f*k (the smallest
f at which its peak tooth contact stress exceeds the allowable, first passage, see
:class:`cyclomesh.tolerance.tasks.AllocationTask`) and the exceedance probability is
the distribution function of f*:

    P(f) = P(f* ≤ f),  estimated by  P̂(f) = #{k : lk < f} / n

with lk ≤ f*k the lower end of ring k's bracket (conservative by at most the bracket
width). P̂ is a non-decreasing step function of f: smooth in f, no sampling noise from
one factor to the next.

- Point estimate of the allowed factor: the largest f with P̂(f) ≤ target, i.e. the
  order statistic l(m+1) with m = ⌊target·n⌋.
- Confident factor: the order statistic l(r) with the largest r such that
  P(Bin(n, target) ≥ r) ≥ confidence. It is a one-sided lower confidence bound on the
  target-quantile of f*: with that confidence, P(f_conf) ≤ target. It needs at least
  ⌈ln(1 − confidence)/ln(1 − target)⌉ rings (299 for 1 % at 95 %).
- The curve carries pointwise Clopper–Pearson intervals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.tolerance.statistics import (
    clopper_pearson,
    exceedance_probability,
    lower_quantile_bound_rank,
)

__all__ = ["Allocation", "allocate_factor", "minimum_rings"]


def minimum_rings(target: float, confidence: float) -> int:
    """Fewest rings for which a confident factor exists: ⌈ln(1 − c)/ln(1 − p)⌉."""
    return math.ceil(math.log1p(-confidence) / math.log1p(-target) - 1e-12)


@dataclass(frozen=True)
class Allocation:
    """Result of :func:`allocate_factor` (factors are dimensionless multipliers)."""

    rings: int
    target_probability: float
    confidence: float
    factor_max: float
    factor: float
    """Largest f with P̂(f) ≤ target (point estimate) [-]."""
    factor_censored: bool
    """True if no ring exceeded up to ``factor``: the true value may be larger."""
    confident_factor: float
    """Lower confidence bound on the allowed factor [-]; NaN with too few rings."""
    confident_rank: int
    probability_at_stated: float
    """P̂(1), at the stated tolerances [-]."""
    probability_at_stated_interval: tuple[float, float]
    curve_factor: NDArray[np.float64] = field(repr=False)
    curve_probability: NDArray[np.float64] = field(repr=False)
    curve_lower: NDArray[np.float64] = field(repr=False)
    curve_upper: NDArray[np.float64] = field(repr=False)

    def statement(self) -> str:
        """One paragraph for people: the allocated factor and its confidence."""
        pct = f"{self.target_probability:.3g}"
        text = (
            f"Scale factor on the stated tolerances: {self.factor:.3f}"
            f"{' or more' if self.factor_censored else ''} keeps the estimated probability "
            f"of exceeding the allowable contact stress at or below {pct} "
            f"({self.rings} rings). "
        )
        if math.isfinite(self.confident_factor):
            text += (
                f"With {self.confidence:.0%} confidence the probability is at most {pct} for "
                f"factors up to {self.confident_factor:.3f} (order statistic "
                f"{self.confident_rank} of {self.rings})."
            )
        else:
            text += (
                f"A {self.confidence:.0%} confidence bound needs at least "
                f"{minimum_rings(self.target_probability, self.confidence)} rings."
            )
        lo, hi = self.probability_at_stated_interval
        text += (
            f" At the stated tolerances (factor 1) the probability is "
            f"{self.probability_at_stated:.3g} [{lo:.3g}, {hi:.3g}]."
        )
        return text

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready record, with the curve."""
        return {
            "rings": self.rings,
            "target_probability": self.target_probability,
            "confidence": self.confidence,
            "factor_max": self.factor_max,
            "factor": self.factor,
            "factor_censored": self.factor_censored,
            "confident_factor": self.confident_factor,
            "confident_rank": self.confident_rank,
            "minimum_rings_for_confidence": minimum_rings(self.target_probability, self.confidence),
            "probability_at_stated": self.probability_at_stated,
            "probability_at_stated_interval": list(self.probability_at_stated_interval),
            "statement": self.statement(),
            "method": (
                "common random numbers; per-ring critical factor by first passage over a "
                "grid of factors and bisection; P(f) = ECDF of the lower bracket ends; "
                "confident factor = one-sided order-statistic lower bound on the "
                "target-quantile; curve intervals Clopper-Pearson"
            ),
            "curve": {
                "factor": self.curve_factor.tolist(),
                "probability": self.curve_probability.tolist(),
                "lower": self.curve_lower.tolist(),
                "upper": self.curve_upper.tolist(),
            },
        }


def allocate_factor(
    critical_lower: ArrayLike,
    critical_upper: ArrayLike,
    target_probability: float,
    confidence: float = 0.95,
    factor_max: float | None = None,
    curve_points: int = 401,
) -> Allocation:
    """Allowed scale factor from per-ring critical-factor brackets (lower < f* ≤ upper).

    Parameters
    ----------
    critical_lower, critical_upper : array_like
        Bracket of each ring's critical factor [-] (upper = inf: never exceeded up to
        ``factor_max``, lower = ``factor_max`` then).
    target_probability : float
        Acceptable exceedance probability [-].
    confidence : float
        Level of the one-sided bound and of the curve intervals [-].
    factor_max : float, optional
        Largest factor searched [-] (default: the largest finite bracket end).
    curve_points : int
        Points of the P(f) curve on [0, factor_max].
    """
    lower = np.sort(np.asarray(critical_lower, dtype=float).reshape(-1))
    upper = np.asarray(critical_upper, dtype=float).reshape(-1)
    n = lower.size
    if n == 0:
        raise ValueError("no rings")
    if factor_max is None:
        finite = np.concatenate([lower, upper[np.isfinite(upper)]])
        factor_max = float(finite.max()) if finite.size else 1.0
    m = math.floor(target_probability * n + 1e-12)
    if m >= n:
        factor, censored = factor_max, True
    else:
        factor = float(lower[m])
        censored = factor >= factor_max
    r = lower_quantile_bound_rank(n, target_probability, confidence)
    confident = float(lower[r - 1]) if r >= 1 else float("nan")
    grid = np.linspace(0.0, factor_max, curve_points)
    counts = np.searchsorted(lower, grid, side="left")  # #{l_k < f}
    lo, hi = clopper_pearson(counts, n, confidence)
    at_one = exceedance_probability(int(np.searchsorted(lower, 1.0, side="left")), n, confidence)
    return Allocation(
        rings=n,
        target_probability=target_probability,
        confidence=confidence,
        factor_max=float(factor_max),
        factor=factor,
        factor_censored=bool(censored),
        confident_factor=confident,
        confident_rank=r,
        probability_at_stated=at_one.estimate,
        probability_at_stated_interval=(at_one.lower, at_one.upper),
        curve_factor=grid,
        curve_probability=counts / n,
        curve_lower=lo,
        curve_upper=hi,
    )
