"""Figures of tolerance studies.

Plot functions take results (the per-ring Dataset of
:func:`cyclomesh.studies.tolerance.compute_tolerance`, or an
:class:`~cyclomesh.tolerance.allocation.Allocation`) and return a matplotlib
:class:`~matplotlib.figure.Figure` on the Agg canvas, without pyplot's global state;
they write no file (:mod:`cyclomesh.figures.render` does).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from cyclomesh.figures.render import new_figure
from cyclomesh.results.metrics import DRIVE_METRICS, METRICS, STRESS_METRIC, metric_label

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cyclomesh.tolerance.allocation import Allocation

__all__ = [
    "plot_metric_histograms",
    "plot_metric_ecdfs",
    "plot_stress_exceedance",
    "plot_allocation",
]


def _figure(width: float, height: float, hspace: float = 0.55) -> Figure:
    fig = new_figure(width, height)
    fig.subplots_adjust(
        left=0.75 / width,
        right=1 - 0.2 / width,
        bottom=0.6 / height,
        top=1 - 0.5 / height,
        wspace=0.35,
        hspace=hspace,
    )
    return fig


def _metrics(ds: xr.Dataset) -> list[str]:
    names = (*METRICS, *DRIVE_METRICS)  # the mesh force and a stack's torque split too
    return [name for name in names if name in ds and name != "overlap"]


def _label(name: str) -> str:
    return metric_label(name)


def plot_metric_histograms(ds: xr.Dataset, allowable_contact_stress_mpa: float | None = None):
    """Histogram of every per-ring metric (one panel each)."""
    names = _metrics(ds)
    cols = 4
    rows = -(-len(names) // cols)
    fig = _figure(3.2 * cols, 2.5 * rows)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        values = np.asarray(ds[name].values, dtype=float)
        integer = np.issubdtype(ds[name].dtype, np.integer)
        if integer:
            bins = np.arange(values.min() - 0.5, values.max() + 1.5)
        else:
            bins = min(50, max(5, int(np.sqrt(values.size))))
        ax.hist(values, bins=bins, color="tab:blue", alpha=0.8)
        if name == STRESS_METRIC and allowable_contact_stress_mpa is not None:
            ax.axvline(allowable_contact_stress_mpa, color="tab:red", label="allowable")
            ax.legend(fontsize="small")
        ax.set_xlabel(_label(name), fontsize="small")
        ax.set_ylabel("rings")
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    fig.suptitle(f"Per-ring metrics over {ds.sizes['ring']} rings")
    return fig


def plot_metric_ecdfs(ds: xr.Dataset, allowable_contact_stress_mpa: float | None = None):
    """Empirical distribution function of every per-ring metric (one panel each)."""
    names = _metrics(ds)
    cols = 4
    rows = -(-len(names) // cols)
    fig = _figure(3.2 * cols, 2.5 * rows)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    n = ds.sizes["ring"]
    for ax, name in zip(axes, names, strict=False):
        values = np.sort(np.asarray(ds[name].values, dtype=float))
        ax.step(values, np.arange(1, n + 1) / n, where="post", color="tab:blue")
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
    ds: xr.Dataset, allowable_contact_stress_mpa: float, confidence: float = 0.95
):
    """Probability that the peak tooth contact stress exceeds a level, vs. the level.

    The band is the pointwise Clopper–Pearson interval; log scale, probabilities below
    half a ring (0.5/n, including 0) drawn at that floor.
    """
    from cyclomesh.tolerance.statistics import clopper_pearson

    stress = np.sort(np.asarray(ds[STRESS_METRIC].values, dtype=float))
    n = stress.size
    span = max(stress[-1] - stress[0], 1.0)
    levels = np.linspace(
        min(stress[0], allowable_contact_stress_mpa) - 0.05 * span,
        max(stress[-1], allowable_contact_stress_mpa) + 0.05 * span,
        400,
    )
    counts = n - np.searchsorted(stress, levels, side="right")  # #{σ > level}
    lo, hi = clopper_pearson(counts, n, confidence)
    floor = 0.5 / n
    lo, hi = np.maximum(lo, floor), np.maximum(hi, floor)
    fig = _figure(6.4, 4.2)
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
    p = float(np.count_nonzero(stress > allowable_contact_stress_mpa)) / n
    ax.set_title(f"P(σH > {allowable_contact_stress_mpa:g} MPa) = {p:.3g}  ({n} rings)")
    ax.set_xlabel("peak tooth contact stress level [MPa]")
    ax.set_ylabel("exceedance probability [-] (log)")
    ax.set_yscale("log")
    ax.set_ylim(floor * 0.8, 1.05)
    ax.legend()
    return fig


def plot_allocation(allocation: Allocation):
    """Exceedance probability vs. scale factor on the stated tolerances (log scale).

    Probabilities below half a ring (0.5/n, including 0) are drawn at that floor.
    """
    a = allocation
    floor = 0.5 / a.rings
    fig = _figure(6.4, 4.2)
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
    ax.set_xlabel("scale factor on the stated tolerances [-]")
    ax.set_ylabel("P(peak tooth contact stress > allowable) [-]")
    ax.set_title(f"{a.rings} rings; below {floor:.2g} means no ring", fontsize="small")
    ax.set_xlim(0, a.factor_max)
    ax.set_ylim(floor * 0.8, 1.05)
    ax.legend(fontsize="small", loc="lower right")
    return fig
