"""Figures of tolerance studies.

Plot functions take results (the per-ring Dataset of
:func:`cyclomesh.studies.tolerance.compute_tolerance`, or an
:class:`~cyclomesh.tolerance.allocation.Allocation`) and return a matplotlib
:class:`~matplotlib.figure.Figure` on the Agg canvas, without pyplot's global state;
they write no file (:mod:`cyclomesh.figures.render` does).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from cyclomesh.figures.render import fixed_figure, plain_log_axis
from cyclomesh.results.metrics import (
    DRIVE_METRICS,
    METRICS,
    STAGE_RING_METRICS,
    STRESS_METRIC,
    metric_label,
)

if TYPE_CHECKING:
    from cyclomesh.tolerance.allocation import Allocation

__all__ = [
    "RingDistributions",
    "reduce_rings",
    "plot_metric_histograms",
    "plot_metric_ecdfs",
    "plot_stress_exceedance",
    "plot_allocation",
]


_MARGINS = {"left": 0.75, "right": 0.2, "bottom": 0.6, "top": 0.5, "wspace": 0.35, "hspace": 0.55}
"""Subplot margins [in] and spacing of the tolerance figures (:func:`fixed_figure`)."""


ECDF_POINTS = 2000
"""Points of an empirical distribution function drawn (evenly spaced in probability)."""

EXCEEDANCE_LEVELS = 400
"""Stress levels of the exceedance curve."""


@dataclass(frozen=True)
class RingDistributions:
    """What the tolerance figures draw, reduced from the per-ring metrics: its size does
    not depend on the number of rings (the figures of 10^6 rings need no more memory
    than those of 100; the workers receive this, not the rings).

    Attributes
    ----------
    rings : int
    histograms : dict of (counts, edges, integer)
        Per metric: bin counts, bin edges [unit of the metric], integer-valued.
    ecdfs : dict of (values, fractions)
        Per metric: at most :data:`ECDF_POINTS` order statistics and their fractions
        i/n of rings ≤ the value (the first and the last always included).
    levels, exceedance_counts : ndarray
        Stress levels [MPa] and the number of rings above each (for the exceedance).
    exceeding : int
        Rings above the allowable contact stress.
    jammed : int
        Rings that jam the disc or that a solver did not converge on (NaN metrics: not in
        the histograms, above every level).
    """

    rings: int
    histograms: dict[str, tuple[np.ndarray, np.ndarray, bool]]
    ecdfs: dict[str, tuple[np.ndarray, np.ndarray]]
    levels: np.ndarray
    exceedance_counts: np.ndarray
    exceeding: int
    jammed: int = 0


def reduce_rings(
    ds: xr.Dataset | RingDistributions, allowable_contact_stress_mpa: float | None = None
) -> RingDistributions:
    """The histograms, ECDF points and exceedance counts of every per-ring metric."""
    if isinstance(ds, RingDistributions):
        return ds
    n = int(ds.sizes["ring"])
    histograms, ecdfs = {}, {}
    take = np.unique(np.linspace(0, n - 1, min(n, ECDF_POINTS)).round().astype(np.int64))
    for name in _metrics(ds):
        values = np.sort(np.asarray(ds[name].values, dtype=float))
        finite = values[np.isfinite(values)]
        # counts stay integers when jammed rings (NaN) made them floats
        integer = bool(np.issubdtype(ds[name].dtype, np.integer)) or (
            name.startswith("contacts") and bool(np.all(finite == np.rint(finite)))
        )
        if integer and finite.size:
            bins: Any = np.arange(finite.min() - 0.5, finite.max() + 1.5)
        else:
            bins = min(50, max(5, int(np.sqrt(max(finite.size, 1)))))
        counts, edges = np.histogram(finite, bins=bins)
        histograms[name] = (counts, edges, integer)
        ecdfs[name] = (values[take], (take + 1) / n)
    # a ring that jams the disc or was not solved (NaN metrics) exceeds every stress level
    stress = np.asarray(ds[STRESS_METRIC].values, dtype=float)
    stress = np.sort(np.where(np.isnan(stress), np.inf, stress))
    finite = stress[np.isfinite(stress)]
    lo, hi = (finite[0], finite[-1]) if finite.size else (0.0, 0.0)
    allowable = hi if allowable_contact_stress_mpa is None else allowable_contact_stress_mpa
    span = max(hi - lo, 1.0)
    levels = np.linspace(
        min(lo, allowable) - 0.05 * span,
        max(hi, allowable) + 0.05 * span,
        EXCEEDANCE_LEVELS,
    )
    counts = n - np.searchsorted(stress, levels, side="right")  # #{σ > level}
    exceeding = int(np.count_nonzero(stress > allowable))
    jammed = int(n - finite.size)
    return RingDistributions(n, histograms, ecdfs, levels, counts, exceeding, jammed)


def _metrics(ds: xr.Dataset) -> list[str]:
    # the mesh force, a stack's torque split, the RV stage's metrics and the efficiency
    names = (*METRICS, *DRIVE_METRICS, *STAGE_RING_METRICS, "efficiency", "backdrive_efficiency")
    return [name for name in names if name in ds and name not in ("any_overlap", "jammed")]


def _label(name: str) -> str:
    return metric_label(name)


def plot_metric_histograms(
    ds: xr.Dataset | RingDistributions, allowable_contact_stress_mpa: float | None = None
):
    """Histogram of every per-ring metric (one panel each), from the rings or from their
    :func:`reduce_rings`."""
    dist = reduce_rings(ds, allowable_contact_stress_mpa)
    names = list(dist.histograms)
    cols = 4
    rows = -(-len(names) // cols)
    fig = fixed_figure(3.2 * cols, 2.5 * rows, **_MARGINS)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        counts, edges, _ = dist.histograms[name]
        ax.stairs(counts, edges, fill=True, color="tab:blue", alpha=0.8)
        if name == STRESS_METRIC and allowable_contact_stress_mpa is not None:
            ax.axvline(allowable_contact_stress_mpa, color="tab:red", label="allowable")
            ax.legend(fontsize="small")
        ax.set_xlabel(_label(name), fontsize="small")
        ax.set_ylabel("rings")
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    if dist.jammed:
        fig.suptitle(
            f"Per-ring metrics over the {dist.rings - dist.jammed} of {dist.rings} rings that "
            f"were solved (the others jam the disc or did not converge)"
        )
    else:
        fig.suptitle(f"Per-ring metrics over {dist.rings} rings")
    return fig


def plot_metric_ecdfs(
    ds: xr.Dataset | RingDistributions, allowable_contact_stress_mpa: float | None = None
):
    """Empirical distribution function of every per-ring metric (one panel each), at
    most :data:`ECDF_POINTS` order statistics each."""
    dist = reduce_rings(ds, allowable_contact_stress_mpa)
    names = list(dist.ecdfs)
    cols = 4
    rows = -(-len(names) // cols)
    fig = fixed_figure(3.2 * cols, 2.5 * rows, **_MARGINS)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    n = dist.rings
    for ax, name in zip(axes, names, strict=False):
        values, fractions = dist.ecdfs[name]
        ax.step(values, fractions, where="post", color="tab:blue")
        if name == STRESS_METRIC and allowable_contact_stress_mpa is not None:
            ax.axvline(allowable_contact_stress_mpa, color="tab:red", label="allowable")
            ax.legend(fontsize="small")
        ax.set_xlabel(_label(name), fontsize="small")
        ax.set_ylabel("fraction of rings ≤ x")
        ax.set_ylim(0, 1)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    fig.suptitle(f"Empirical distribution functions over {n} rings")
    return fig


def plot_stress_exceedance(
    ds: xr.Dataset | RingDistributions,
    allowable_contact_stress_mpa: float,
    confidence: float = 0.95,
):
    """Probability that the peak tooth contact stress exceeds a level, vs. the level.

    The band is the pointwise Clopper–Pearson interval; log scale, probabilities below
    half a ring (0.5/n, including 0) drawn at that floor.
    """
    from cyclomesh.tolerance.statistics import clopper_pearson

    dist = reduce_rings(ds, allowable_contact_stress_mpa)
    n, levels, counts = dist.rings, dist.levels, dist.exceedance_counts
    lo, hi = clopper_pearson(counts, n, confidence)
    floor = 0.5 / n
    lo, hi = np.maximum(lo, floor), np.maximum(hi, floor)
    fig = fixed_figure(6.4, 4.2, **_MARGINS)
    ax = fig.add_subplot()
    ax.fill_between(
        levels,
        lo,
        hi,
        step="post",
        color="tab:blue",
        alpha=0.2,
        label=f"{confidence:.0%} Clopper–Pearson",
    )
    ax.step(levels, np.maximum(counts / n, floor), where="post", color="tab:blue", label="estimate")
    ax.axvline(allowable_contact_stress_mpa, color="tab:red", label="allowable")
    p = dist.exceeding / n
    ax.set_title(f"P(σH > {allowable_contact_stress_mpa:g} MPa) = {p:.3g}  ({n} rings)")
    ax.set_xlabel("peak tooth contact stress level [MPa]")
    ax.set_ylabel("exceedance probability [-] (log)")
    ax.set_yscale("log")
    plain_log_axis(ax.yaxis)
    ax.set_ylim(floor * 0.8, 1.05)
    ax.legend()
    return fig


def plot_allocation(allocation: Allocation):
    """Exceedance probability vs. scale factor on the stated tolerances (log scale).

    Probabilities below half a ring (0.5/n, including 0) are drawn at that floor.
    """
    a = allocation
    floor = 0.5 / a.rings
    fig = fixed_figure(6.4, 4.2, **_MARGINS)
    ax = fig.add_subplot()
    ax.fill_between(
        a.curve_factor,
        np.maximum(a.curve_lower, floor),
        np.maximum(a.curve_upper, floor),
        step="post",
        alpha=0.2,
        color="tab:blue",
        label=f"{a.confidence:.0%} Clopper–Pearson",
    )
    ax.step(
        a.curve_factor,
        np.maximum(a.curve_probability, floor),
        where="post",
        color="tab:blue",
        label="estimate (common random numbers)",
    )
    ax.axhline(a.target_probability, color="tab:red", linestyle="--", label="target")
    ax.axvline(a.factor, color="tab:green", label=f"allowed factor {a.factor:.3f}")
    if np.isfinite(a.confident_factor):
        ax.axvline(
            a.confident_factor,
            color="tab:green",
            linestyle=":",
            label=f"{a.confidence:.0%} lower bound {a.confident_factor:.3f}",
        )
    ax.axvline(1.0, color="0.5", linewidth=0.8, label="stated tolerances")
    ax.set_yscale("log")
    plain_log_axis(ax.yaxis)
    ax.set_xlabel("scale factor on the stated tolerances [-]")
    ax.set_ylabel("P(peak tooth contact stress > allowable) [-]")
    ax.set_title(f"{a.rings} rings; below {floor:.2g} means no ring", fontsize="small")
    ax.set_xlim(0, a.factor_max)
    ax.set_ylim(floor * 0.8, 1.05)
    ax.legend(fontsize="small", loc="lower right")
    return fig
