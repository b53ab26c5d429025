"""Figures of an efficiency map (``cyclomesh efficiency``, docs/efficiency.md)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from cyclomesh.figures.render import new_figure

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = ["plot_efficiency_map", "plot_loss_breakdown"]

_PATH_LABELS = {
    "pin_tooth": "pin-tooth sliding",
    "pin_groove": "pin-groove sliding",
    "crank_bearings": "crank bearings",
}


def plot_efficiency_map(maps: Mapping[str, xr.Dataset]) -> Figure:
    """Forward efficiency [%] against output torque, one curve per input speed (the
    catalogue figure); one panel per case, back-driving dashed."""
    fig = new_figure(9.0, 3.6 * len(maps), layout="constrained")
    for k, (name, ds) in enumerate(maps.items()):
        ax = fig.add_subplot(len(maps), 1, k + 1)
        torque = ds["torque"].values
        for i, speed in enumerate(ds["input_speed"].values):
            eff = ds["efficiency"].isel(input_speed=i).values * 100.0
            back = ds["backdrive_efficiency"].isel(input_speed=i).values * 100.0
            ax.plot(torque, eff, "o-", color=f"C{i}", ms=3, label=f"{speed:g} rpm")
            ax.plot(torque, back, "--", color=f"C{i}", lw=1.0)
        ax.set_xlabel("output torque [N·m]")
        ax.set_ylabel("efficiency [%]")
        ax.set_title(f"{name}\nsolid: forward, dashed: back-driving", fontsize="medium")
        ax.grid(alpha=0.3)
        # outside the axes: inside, it hides the curves' ends at the largest torque
        ax.legend(title="input speed", fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1))
    return fig


def plot_loss_breakdown(records: Mapping[str, dict[str, Any]]) -> Figure:
    """Stacked power loss by path [W] at the rated point of every case."""
    fig = new_figure(7.0, 4.0, layout="constrained")
    ax = fig.add_subplot()
    names = list(records)
    bottom = np.zeros(len(names))
    for i, (path, label) in enumerate(_PATH_LABELS.items()):
        values = np.array([records[n]["rated_power_loss_w"].get(path) or 0.0 for n in names])
        ax.bar(names, values, bottom=bottom, color=f"C{i}", label=label)
        bottom += values
    for x, name in enumerate(names):
        r = records[name]
        ax.annotate(
            f"η = {100 * r['rated_efficiency']:.1f} %",
            (x, bottom[x]),
            xytext=(0, 3),  # points above the bar: the text does not sit on its edge
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize="small",
        )
    ax.set_ylabel("power loss [W]")
    ax.set_title("Loss breakdown at the rated point")
    ax.set_ylim(0, 1.15 * max(bottom.max(), 1e-12))
    # outside the axes (inside, it covers the top of the bar and the η label); a path
    # with no loss in any case (e.g. pin-tooth sliding of rolling pins) is named as such
    handles, labels = ax.get_legend_handles_labels()
    totals = {
        label: sum(records[n]["rated_power_loss_w"].get(path) or 0.0 for n in names)
        for path, label in _PATH_LABELS.items()
    }
    labels = [f"{lb} (0 W)" if totals[lb] == 0.0 else lb for lb in labels]
    ax.legend(handles, labels, fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1))
    return fig
