"""Figures of the drive characteristics: torsion curve, rigidity, play, torque split, mesh force.

Every function takes results (a Dataset of :func:`cyclomesh.results.torsion.stiffness` or
:func:`cyclomesh.analyse`, or a mapping ``{case name: Dataset}``) and returns a
:class:`matplotlib.figure.Figure` on the Agg canvas, without pyplot's global state and
without writing files. Datasets with a ``ring`` dimension must be reduced to one ring
first. The definitions of play, lost motion and torsional rigidity are in
``docs/drive.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from cyclomesh.figures.render import fixed_figure, new_figure, steady_axis
from cyclomesh.figures.run import case_legend, case_results, case_width, legend_room

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "plot_torsion_curve",
    "plot_rigidity",
    "plot_play",
    "plot_torque_share",
    "plot_mesh_force",
]

Results = xr.Dataset | Mapping[str, xr.Dataset]


def plot_torsion_curve(results: Results) -> Figure:
    """Catalogue-style torsion curve: rotation [arcmin] against torque [% of rated].

    The band spans the crank angles (min to max), the line is their mean. Marked on it:
    the lost motion (the rotation between −3 % and +3 % of the rated torque, an arrow at
    the origin) and the rigidity secants between 50 % and 100 % on each side (dotted).
    With a series stiffness, the whole-drive curve gets its own axes beside the mesh's.
    """
    cases = case_results(results, "rotation")
    kinds = [("rotation", "cycloid-pin mesh")]
    if any("drive_rotation" in ds for ds in cases.values()):
        kinds.append(("drive_rotation", "whole drive (mesh + series stiffness)"))
    fig = new_figure(6.0 * len(kinds), 4.6, layout="constrained")
    axes = fig.subplots(1, len(kinds), squeeze=False)[0]
    for ax, (var, title) in zip(axes, kinds, strict=True):
        for i, (name, ds) in enumerate(cases.items()):
            if var not in ds:
                continue
            colour = f"C{i}"
            rated = float(ds.attrs["rated_torque_nm"])
            pct = ds["torque"].values / rated * 100.0
            rot = ds[var].values / 60.0  # arcsec → arcmin
            mean = rot.mean(-1)
            ax.fill_between(pct, rot.min(-1), rot.max(-1), color=colour, alpha=0.25, lw=0)
            ax.plot(pct, mean, color=colour, label=name or None, lw=case_width(i, len(cases)))
            at = {round(p, 9): k for k, p in enumerate(pct)}
            lo, hi = mean[at[-3.0]], mean[at[3.0]]
            ax.plot([-3.0, 3.0], [lo, hi], "o", color=colour, ms=4)
            ax.annotate(
                "", xy=(0.0, hi), xytext=(0.0, lo), arrowprops={"arrowstyle": "<->", "color": "k"}
            )
            lost = var.replace("rotation", "lost_motion")
            rigidity = var.replace("rotation", "torsional_rigidity")
            for sign in (-1.0, 1.0):
                k50, k100 = at[sign * 50.0], at[sign * 100.0]
                ax.plot([pct[k50], pct[k100]], [mean[k50], mean[k100]], ":", color="k", lw=2)
            ax.text(
                0.98,
                0.98 - 0.06 * i,
                f"{name + ': ' if name else ''}lost motion {float(ds[lost].mean()):.3g}′, "
                f"rigidity {float(ds[rigidity].mean()):.4g} N·m/′",
                transform=ax.transAxes,
                ha="right",
                va="top",
                color=colour,
                fontsize="small",
            )
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.axvline(0.0, color="0.6", lw=0.6)
        ax.set_xlabel("torque [% of rated]")
        ax.set_ylabel("rotation from theoretical [arcmin]")
        ax.set_title(title, fontsize="medium")
        if any(cases):
            ax.legend(fontsize="small", loc="lower left")
    return fig


def plot_rigidity(results: Results) -> Figure:
    """Torsional rigidity [N·m/arcmin] over the crank angle; whole drive on its own axes."""
    cases = case_results(results, "torsional_rigidity")
    drive = any("drive_torsional_rigidity" in ds for ds in cases.values())
    fig = new_figure(8.5, 5.6 if drive else 3.6, layout="constrained")
    axes = fig.subplots(2 if drive else 1, 1, sharex=True, squeeze=False)[:, 0]
    for i, (name, ds) in enumerate(cases.items()):
        crank = ds["crank_angle"].values
        lw = case_width(i, len(cases))
        axes[0].plot(crank, ds["torsional_rigidity"].values, label=name or "mesh", lw=lw)
        if drive and "drive_torsional_rigidity" in ds:
            axes[1].plot(crank, ds["drive_torsional_rigidity"].values, label=name or "drive", lw=lw)
    axes[0].set_ylabel("mesh rigidity [N·m/arcmin]")
    if drive:
        axes[1].set_ylabel("whole-drive rigidity\n[N·m/arcmin]")
    axes[-1].set_xlabel("crank angle [deg]")
    axes[0].set_title("Torsional rigidity (secant 50–100 % of rated, mean of both directions)")
    case_legend(axes[0], cases, outside=True)
    return fig


def plot_play(results: Results) -> Figure:
    """Play and lost motion [arcmin] over the crank angle."""
    cases = case_results(results, "play")
    fig = new_figure(9.0, 3.8, layout="constrained")
    ax = fig.add_subplot()
    for i, (name, ds) in enumerate(cases.items()):
        crank = ds["crank_angle"].values
        play = ds["play"]
        scale = 1.0 / 60.0 if play.attrs.get("units") == "arcsec" else 1.0
        prefix = f"{name}: " if name else ""
        lw = case_width(i, len(cases))
        ax.plot(crank, play.values * scale, color=f"C{i}", label=f"{prefix}play", lw=lw)
        if "lost_motion" in ds:
            ax.plot(
                crank,
                ds["lost_motion"].values,
                "--",
                color=f"C{i}",
                label=f"{prefix}lost motion (±3 %)",
                lw=lw,
            )
        if "drive_lost_motion" in ds:
            ax.plot(
                crank,
                ds["drive_lost_motion"].values,
                ":",
                color=f"C{i}",
                label=f"{prefix}whole-drive lost motion",
                lw=lw,
            )
    ax.set_xlabel("crank angle [deg]")
    ax.set_ylabel("play, lost motion [arcmin]")
    ax.set_title("Play (zero load) and lost motion")
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def plot_torque_share(results: Results, torque_nm: float | None = None) -> Figure:
    """Torque carried by each disc of a stack over the crank angle [N·m].

    For results with a ``torque`` dimension, ``torque_nm`` picks the torque (default the
    largest positive one).
    """
    cases = case_results(results, "torque_share")
    labels = [f"{name}: disc 0" for name in cases]
    fig = fixed_figure(
        7.0 + legend_room(labels), 3.6, left=0.9, right=legend_room(labels), bottom=0.5, top=0.5
    )
    ax = fig.add_subplot()
    shares = []
    for i, (name, ds) in enumerate(cases.items()):
        share = ds["torque_share"]
        if "torque" in share.dims:
            pick = float(ds["torque"].max()) if torque_nm is None else torque_nm
            share = share.sel(torque=pick, method="nearest")
        total = float(share.sum("disc").mean())
        shares.append(share.values)
        prefix = f"{name}: " if name else ""
        for k, disc in enumerate(share["disc"].values):
            ax.plot(
                share["crank_angle"].values,
                share.sel(disc=disc).values,
                color=f"C{i}",
                ls=("-", "--", ":", "-.")[k % 4],
                label=f"{prefix}disc {disc}",
            )
        ax.axhline(total / share.sizes["disc"], color="0.6", lw=0.6)
    ax.set_xlabel("crank angle [deg]")
    ax.set_ylabel("torque share [N·m]")
    # an even split (identical discs, no errors) is constant to round-off: drawn flat
    steady_axis(ax, np.concatenate([v.ravel() for v in shares]), rtol=0.02)
    ax.set_title("Split of the torque between the discs (grey: equal split)", fontsize="medium")
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def plot_mesh_force(results: Results) -> Figure:
    """Mesh force (the crank bearing load) [N] and its direction [deg] over the crank angle."""
    cases = case_results(results, "mesh_force")
    room = legend_room([f"{name} disc 0" for name in cases])
    fig = fixed_figure(7.0 + room, 5.0, left=0.9, right=room, bottom=0.5, top=0.3, hspace=0.08)
    top, bottom = fig.subplots(2, 1, sharex=True)
    for i, (name, ds) in enumerate(cases.items()):
        force, angle = ds["mesh_force"], ds["mesh_force_angle"]
        if "torque" in force.dims:
            force = force.isel(torque=-1)
            angle = angle.isel(torque=-1)
        discs = force["disc"].values if "disc" in force.dims else [None]
        for k, disc in enumerate(discs):
            f = force if disc is None else force.sel(disc=disc)
            a = angle if disc is None else angle.sel(disc=disc)
            label = " ".join(x for x in (name, "" if disc is None else f"disc {disc}") if x)
            style = ("-", "--", ":", "-.")[k % 4]
            lw = case_width(i, len(cases))
            top.plot(f["crank_angle"].values, f.values, style, color=f"C{i}", label=label, lw=lw)
            bottom.plot(a["crank_angle"].values, a.values, style, color=f"C{i}", lw=lw)
    top.set_ylabel("mesh force [N]")
    bottom.set_ylabel("direction [deg from x]")
    bottom.set_xlabel("crank angle [deg]")
    top.set_title("Resultant of the pin forces on the disc (crank bearing load)")
    # a ripple of a few newtons on 4 kN is shown within at least ±2.5 % of the force
    steady_axis(top, np.concatenate([line.get_ydata() for line in top.lines]), rtol=0.05)
    if any(line.get_label() and not line.get_label().startswith("_") for line in top.lines):
        top.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig
