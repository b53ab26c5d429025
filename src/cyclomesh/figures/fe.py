"""Figure of an FE check: pin loads and contact stresses, FE against both LTCA laws.

Takes the Dataset of one case of :func:`cyclomesh.studies.fe.compute_fe` and returns a
:class:`matplotlib.figure.Figure` on the Agg canvas (no pyplot state, no files).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cyclomesh.figures.render import new_figure

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = ["plot_fe_comparison"]

_LAWS = (("paper", "-", "LTCA Eq. 20"), ("half_plane", "--", "LTCA half-plane"))


def plot_fe_comparison(ds: xr.Dataset) -> Figure:
    """Pin load [N] and pin-tooth contact stress [MPa] against pin number, one colour per
    crank angle: FE as dots, the LTCA with Eq. 20 (solid) and the half-plane law (dashed).
    Only pins that either model loads are shown."""
    fig = new_figure(8.0, 6.0)
    top, bottom = fig.subplots(2, 1, sharex=True)
    loaded = (ds["pin_load_fe"] > 0).any("crank_angle")
    for law, _, _ in _LAWS:
        loaded = loaded | (ds[f"pin_load_ltca_{law}"] > 0).any("crank_angle")
    sub = ds.sel(pin=ds.pin[loaded.values]) if bool(loaded.any()) else ds
    pins = sub.pin.values
    for k, phi in enumerate(sub.crank_angle.values):
        color = f"C{k % 10}"
        at = sub.sel(crank_angle=phi)
        for ax, var in ((top, "pin_load"), (bottom, "contact_stress")):
            ax.plot(pins, at[f"{var}_fe"].values, "o", color=color, ms=4, label=f"FE {phi:g}°")
            for law, style, name in _LAWS:
                ax.plot(
                    pins,
                    at[f"{var}_ltca_{law}"].values,
                    style,
                    color=color,
                    lw=1.0,
                    label=f"{name} {phi:g}°",
                )
    top.set_ylabel("pin load [N]")
    bottom.set_ylabel("contact stress, pin-tooth [MPa]")
    bottom.set_xlabel("pin")
    top.legend(fontsize="x-small", ncol=3)
    for ax in (top, bottom):
        ax.grid(True, lw=0.3)
    title = ds.attrs.get("case_name", "")
    top.set_title(f"{title}: FE against LTCA" if title else "FE against LTCA")
    fig.subplots_adjust(left=0.11, right=0.98, top=0.94, bottom=0.09, hspace=0.08)
    return fig
