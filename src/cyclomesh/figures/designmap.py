"""Figures of a design map (:func:`cyclomesh.designspace.sweep.design_map`, ``cyclomesh design``).

Every function takes the map's Dataset and returns a :class:`matplotlib.figure.Figure`
on the Agg canvas without touching pyplot's global state. Infeasible candidates are
hatched (the feasible region is left clear), the optimum is marked with a star, and
optional reference designs (e.g. the paper's Δρ = 8 µm) with labelled crosses.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from cyclomesh.designspace.sweep import METRICS
from cyclomesh.figures.render import new_figure

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = ["map_metrics", "plot_design_map", "plot_design_maps"]

Marks = Mapping[str, Mapping[str, float]]


def map_metrics(ds: xr.Dataset) -> list[str]:
    """The metric variables of a design map, in the order of :data:`METRICS`."""
    return [var for var, *_ in METRICS.values() if var in ds]


_UNITS = {"um": "µm", "urad": "µrad", "1": ""}
"""How file units are shown on axes (the files keep the ASCII names)."""


def _label(ds: xr.Dataset, name: str) -> str:
    var = ds[name]
    units = var.attrs.get("units", "")
    units = _UNITS.get(units, units)
    return var.attrs.get("long_name", name) + (f" [{units}]" if units else "")


def _optimum(ds: xr.Dataset) -> dict[str, float] | None:
    dims = list(ds["feasible"].dims)
    if not all(f"optimum_{d}" in ds.attrs for d in dims):
        return None
    return {d: float(ds.attrs[f"optimum_{d}"]) for d in dims}


def _plane(ds: xr.Dataset, dims: Sequence[str]) -> xr.Dataset:
    """Reduce a map to (at most) its first two swept parameters, at the optimum."""
    best = _optimum(ds)
    extra = {}
    for d in list(ds["feasible"].dims)[len(dims) :]:
        extra[d] = best[d] if best else float(ds[d][0])
    return ds.sel(extra) if extra else ds


def _draw(ax, ds: xr.Dataset, metric: str, marks: Marks | None) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    legend: list = []
    dims = list(ds["feasible"].dims)[:2]
    plane = _plane(ds, dims)
    best = _optimum(ds)
    feasible = plane["feasible"].values.astype(bool)
    values = plane[metric]
    if len(dims) == 1:
        x = plane[dims[0]].values
        ax.plot(x, values.values, "-o", ms=3, color="C0")
        for xi, ok in zip(x, feasible, strict=True):
            if not ok:
                ax.axvspan(xi - 0.5 * _step(x), xi + 0.5 * _step(x), color="0.85", lw=0)
        ax.set_xlabel(_label(plane, dims[0]))
        ax.set_ylabel(_label(plane, metric))
        if best:
            ax.plot(
                [best[dims[0]]],
                [float(plane[metric].sel({dims[0]: best[dims[0]]}))],
                "*",
                ms=14,
                color="C3",
                label="optimum",
                clip_on=False,  # on the edge of the range it is drawn whole
                zorder=5,
            )
    else:
        x, y = plane[dims[1]].values, plane[dims[0]].values
        z = values.transpose(dims[0], dims[1]).values
        finite = np.isfinite(z)
        if finite.sum() >= 2 and np.nanmax(z) > np.nanmin(z):
            cs = ax.contourf(x, y, np.where(finite, z, np.nan), levels=12, cmap="viridis")
            ax.figure.colorbar(cs, ax=ax, label=_label(plane, metric))
        else:
            ax.pcolormesh(x, y, np.where(finite, z, np.nan), shading="nearest", cmap="viridis")
        failed = ~finite
        if failed.any():  # no solution there (refused or not converged): grey, not blank
            from matplotlib.colors import ListedColormap

            ax.pcolormesh(
                x,
                y,
                np.where(failed, 1.0, np.nan),
                shading="nearest",
                cmap=ListedColormap(["0.55"]),
                vmin=0.0,
                vmax=1.0,
            )
            legend.append(Patch(facecolor="0.55", label="failed: no solution"))
            # the contours join solved candidates only: the half step between a solved
            # and a failed one is left blank, and said so
            legend.append(
                Patch(facecolor="white", edgecolor="0.6", label="blank: not interpolated")
            )
        xs, ys = np.meshgrid(x, y)
        ax.plot(xs[finite], ys[finite], ".", ms=2.5, color="0.25", zorder=3)
        legend.append(Line2D([], [], ls="", marker=".", color="0.25", label="solved candidate"))
        bad = (~feasible.reshape(z.shape) & finite).astype(float)
        if bad.any() and not bad.all():
            ax.contourf(x, y, bad, levels=[0.5, 1.5], colors="none", hatches=["///"])
            ax.contour(x, y, bad, levels=[0.5], colors="k", linewidths=0.8)
        elif bad.all():
            ax.contourf(x, y, bad, levels=[0.5, 1.5], colors="none", hatches=["///"])
        if bad.any():
            legend.append(
                Patch(facecolor="none", edgecolor="k", hatch="///", label="infeasible (constraint)")
            )
        # half a step of room around the candidates: the optimum on an edge is seen whole
        dx, dy = 0.5 * _step(x), 0.5 * _step(y)
        ax.set_xlim(x.min() - dx, x.max() + dx)
        ax.set_ylim(y.min() - dy, y.max() + dy)
        if best:
            ax.plot(
                best[dims[1]],
                best[dims[0]],
                "*",
                ms=14,
                color="C3",
                mec="w",
                label="optimum",
                clip_on=False,  # on the edge of the range it is drawn whole
                zorder=5,
            )
        ax.set_xlabel(_label(plane, dims[1]))
        ax.set_ylabel(_label(plane, dims[0]))
    for name, where in (marks or {}).items():
        if len(dims) == 1:
            xv = where.get(dims[0])
            if xv is not None:
                ax.axvline(xv, color="C1", ls="--", label=name)
        else:
            xv, yv = where.get(dims[1], 0.0), where.get(dims[0], 0.0)
            ax.plot(xv, yv, "X", ms=10, color="C1", mec="k", label=name)
    ax.set_title(ds[metric].attrs.get("long_name", metric), fontsize="medium")
    handles = ax.get_legend_handles_labels()[0] + legend
    if handles:  # below the map, where it hides no candidate
        ax.legend(
            handles=handles,
            fontsize="small",
            loc="upper center",
            bbox_to_anchor=(0.5, -0.16),
            ncol=2,
        )


def _step(x: np.ndarray) -> float:
    return float(np.min(np.diff(x))) if x.size > 1 else 1.0


def plot_design_map(ds: xr.Dataset, metric: str, marks: Marks | None = None) -> Figure:
    """One metric over the design space: contours (2-D) or a line (1-D).

    Infeasible candidates are hatched, the feasible region clear; the optimum is a star.
    A third swept parameter is held at its optimum value.

    Parameters
    ----------
    ds : xarray.Dataset
        A design map.
    metric : str
        A metric variable, e.g. ``max_contact_stress_mpa``.
    marks : mapping, optional
        Reference designs to mark, ``{label: {parameter: value}}`` in study units.
    """
    if metric not in ds:
        raise ValueError(f"{metric!r} is not in the map (one of {', '.join(map_metrics(ds))})")
    fig = new_figure(6.0, 4.6, layout="constrained")
    _draw(fig.subplots(), ds, metric, marks)
    return fig


def plot_design_maps(ds: xr.Dataset, marks: Marks | None = None) -> Figure:
    """Every metric of a design map, one panel each (see :func:`plot_design_map`)."""
    metrics = map_metrics(ds)
    cols = 2 if len(metrics) > 1 else 1
    rows = -(-len(metrics) // cols)
    fig = new_figure(6.0 * cols, 4.4 * rows, layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax, metric in zip(axes, metrics, strict=False):
        _draw(ax, ds, metric, marks)
    for ax in axes[len(metrics) :]:
        ax.set_visible(False)
    return fig
