"""Figures of the RV stage (docs/stage.md): crank bearing loads over the crank angle.

Each function takes the run's Datasets (case name → Dataset with the stage variables of
:func:`cyclomesh.results.stage.stage_dataset`) and returns a matplotlib Figure.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import xarray as xr

from cyclomesh.figures.render import new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "plot_crank_bearing_loads",
    "plot_stage_torsion_curve",
    "plot_compliance_budget",
    "plot_measured_loop",
]

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


def _case_panels(results: Results, var: str, none: str) -> tuple[Figure, Any, dict]:
    """A figure of one panel per case that has ``var`` (side by side, 4.2 in each):
    the figure, its axes and the cases; ``ValueError(none)`` if no case has it."""
    if isinstance(results, xr.Dataset):
        results = {str(results.attrs.get("case_name", "")): results}
    cases = {name: ds for name, ds in results.items() if var in ds}
    if not cases:
        raise ValueError(none)
    width = 4.2 * len(cases) + 0.8
    fig = new_figure(width, 4.0)
    fig.subplots_adjust(left=0.8 / width, right=1 - 0.2 / width, bottom=0.13, top=0.9,
                        wspace=0.3)  # fmt: skip
    axes = fig.subplots(1, len(cases), squeeze=False)[0]
    return fig, axes, cases


def plot_stage_torsion_curve(results: Results) -> Figure:
    """Torsion curve of the RV stage beside the mesh alone, one panel per case.

    Rotation [arcmin] (mean over the crank angles, TE sign) against torque [% of rated]:
    the mesh (rigid bearings) and the stage (mesh, crank bearings, springs in one solve),
    with their lost motion (±3 %) and mean rigidity (secant 50–100 %) in the legend. With
    friction the stage's curve is the loop's mid curve, and the loop's width (rising −
    falling branch, mean over the crank angles) is drawn on a second axis.
    """
    fig, axes, cases = _case_panels(
        results, "stage_rotation", "no results with a stage torsion curve to plot"
    )
    if any("stage_rotation_ascending" in ds for ds in cases.values()):  # room for 2nd axis
        width = fig.get_size_inches()[0]
        fig.subplots_adjust(right=1 - 0.9 / width, wspace=0.55)
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
        if "stage_rotation_ascending" in ds:  # friction: the loop's width on a second axis
            width = (ds["stage_rotation_ascending"] - ds["stage_rotation_descending"]).mean(
                "crank_angle"
            )
            twin = ax.twinx()
            widest = float(ds["stage_hysteresis"].max())
            twin.plot(percent, width.values, ":", color="C1",
                      label=f"stage loop width (max {widest:.3g}′)")  # fmt: skip
            twin.set_ylabel("loop width, rising − falling [arcsec]", fontsize="small")
            twin.legend(fontsize="x-small", loc="lower right")
        ax.axhline(0.0, color="0.7", lw=0.6)
        ax.axvline(0.0, color="0.7", lw=0.6)
        ax.set_xlabel("torque [% of rated]")
        ax.set_title(name, fontsize="small")
        ax.legend(fontsize="x-small")
    axes[0].set_ylabel("rotation [arcmin]")
    return fig


def plot_compliance_budget(shares: Mapping[str, Mapping[str, float]]) -> Figure:
    """The compliance budget of the RV stage at rated torque: one bar per part and case.

    ``shares``: case → part → share of the output twist (``compliance_share`` of the
    summary, :func:`cyclomesh.results.datasheet.compliance_share`), in per cent.
    """
    cases = {name: s for name, s in shares.items() if s}
    if not cases:
        raise ValueError("no compliance budget to plot")
    parts = list(dict.fromkeys(p for s in cases.values() for p in s))
    width = max(5.0, 1.0 + 0.9 * len(parts) * max(1, len(cases)) ** 0.5)
    fig = new_figure(width, 3.6)
    fig.subplots_adjust(left=0.8 / width, right=1 - 0.2 / width, bottom=0.18, top=0.95)
    ax = fig.add_subplot()
    step = 0.8 / len(cases)
    for i, (name, share) in enumerate(cases.items()):
        x = [j - 0.4 + step * (i + 0.5) for j in range(len(parts))]
        values = [100.0 * share.get(p, 0.0) for p in parts]
        ax.bar(x, values, width=step * 0.9, color=f"C{i}", label=name)
    ax.set_xticks(range(len(parts)))
    ax.set_xticklabels([p.replace("_", " ") for p in parts], rotation=20, fontsize="small")
    ax.set_ylabel("share of output twist [%]")
    ax.legend(fontsize="x-small")
    return fig


def plot_measured_loop(results: Results) -> Figure:
    """The measured hysteresis loop drawn over the model's torsion curve, one panel per case.

    Needs ``measured_torque`` [N m] and ``measured_twist`` [arcmin] (dim ``sample``) and the
    model's ``stage_rotation`` (or ``rotation``) [arcsec, TE sign] against ``torque``.
    """
    fig, axes, cases = _case_panels(results, "measured_twist", "no measured loop to plot")
    for ax, (name, ds) in zip(axes, cases.items(), strict=True):
        ax.plot(ds["measured_twist"].values, ds["measured_torque"].values, "-", color="0.4",
                lw=0.8, label="measured")  # fmt: skip
        var = "stage_rotation" if "stage_rotation" in ds else "rotation"
        model = -ds[var].mean("crank_angle").values / 60.0  # TE sign, arcsec → twist, arcmin
        ax.plot(model, ds["torque"].values, "o-", color="C3", ms=2.5,
                label="model (stage)" if var == "stage_rotation" else "model (mesh)")  # fmt: skip
        ax.axhline(0.0, color="0.7", lw=0.6)
        ax.axvline(0.0, color="0.7", lw=0.6)
        ax.set_xlabel("twist of the output [arcmin]")
        ax.set_title(name, fontsize="small")
        ax.legend(fontsize="x-small")
    axes[0].set_ylabel("torque [N·m]")
    return fig
