"""Figures of the RV stage (docs/stage.md): crank bearing loads over the crank angle.

Each function takes the run's Datasets (case name → Dataset with the stage variables of
:func:`cyclomesh.results.stage.stage_dataset`) and returns a matplotlib Figure.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import xarray as xr

from cyclomesh.figures.render import new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_crank_bearing_loads", "plot_stage_torsion_curve"]

Results = xr.Dataset | Mapping[str, xr.Dataset]


def plot_crank_bearing_loads(results: Results) -> Figure:
    """Load of every crank bearing [N] over the crank angle, one panel per case.

    Colour: the crankshaft; line style: the disc. With several torques, the last.
    """
    if isinstance(results, xr.Dataset):
        results = {str(results.attrs.get("case_name", "")): results}
    cases = {name: ds for name, ds in results.items() if "crank_bearing_load" in ds}
    if not cases:
        raise ValueError("no results with crank bearing loads to plot")
    height = 1.0 + 2.2 * len(cases)
    fig = new_figure(7.0, height)
    fig.subplots_adjust(left=0.9 / 7.0, right=1 - 0.15 / 7.0, bottom=0.5 / height,
                        top=1 - 0.3 / height, hspace=0.25)  # fmt: skip
    axes = fig.subplots(len(cases), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, ds) in zip(axes, cases.items(), strict=True):
        load = ds["crank_bearing_load"]
        if "torque" in load.dims:
            load = load.isel(torque=-1)
        discs = load["disc"].values if "disc" in load.dims else [None]
        for k, disc in enumerate(discs):
            per_disc = load if disc is None else load.sel(disc=disc)
            for crank in per_disc["crank"].values:
                values = per_disc.sel(crank=crank)
                label = f"crank {crank}" + ("" if disc is None else f", disc {disc}")
                ax.plot(
                    values["crank_angle"].values,
                    values.values,
                    ("-", "--", ":", "-.")[k % 4],
                    color=f"C{int(crank) - 1}",
                    label=label,
                )
        ax.set_ylabel("bearing load [N]")
        ax.set_title(name, fontsize="small")
        ax.legend(fontsize="x-small", ncol=3)
    axes[-1].set_xlabel("crank angle [deg]")
    return fig


def plot_stage_torsion_curve(results: Results) -> Figure:
    """Torsion curve of the RV stage beside the mesh alone, one panel per case.

    Rotation [arcmin] (mean over the crank angles, TE sign) against torque [% of rated]:
    the mesh (rigid bearings) and the stage (mesh, crank bearings, springs in one solve),
    with their lost motion (±3 %) and mean rigidity (secant 50–100 %) in the legend.
    """
    if isinstance(results, xr.Dataset):
        results = {str(results.attrs.get("case_name", "")): results}
    cases = {name: ds for name, ds in results.items() if "stage_rotation" in ds}
    if not cases:
        raise ValueError("no results with a stage torsion curve to plot")
    width = 4.2 * len(cases) + 0.8
    fig = new_figure(width, 4.0)
    fig.subplots_adjust(left=0.8 / width, right=1 - 0.2 / width, bottom=0.13, top=0.9,
                        wspace=0.3)  # fmt: skip
    axes = fig.subplots(1, len(cases), squeeze=False)[0]
    for ax, (name, ds) in zip(axes, cases.items(), strict=True):
        rated = float(ds.attrs.get("rated_torque_nm", abs(ds["torque"]).max()))
        percent = 100.0 * ds["torque"].values / rated
        for var, lost, rigid, label, colour in (
            ("rotation", "lost_motion", "torsional_rigidity", "mesh alone", "C0"),
            ("stage_rotation", "stage_lost_motion", "stage_torsional_rigidity", "stage", "C3"),
        ):
            mean = ds[var].mean("crank_angle").values / 60.0  # arcsec → arcmin
            text = f"{label}: LM {float(ds[lost].mean()):.3g}′, {float(ds[rigid].mean()):.4g} N·m/′"
            ax.plot(percent, mean, "-", color=colour, label=text)
        ax.axhline(0.0, color="0.7", lw=0.6)
        ax.axvline(0.0, color="0.7", lw=0.6)
        ax.set_xlabel("torque [% of rated]")
        ax.set_title(name, fontsize="small")
        ax.legend(fontsize="x-small")
    axes[0].set_ylabel("rotation [arcmin]")
    return fig
