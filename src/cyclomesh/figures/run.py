"""Figures of a run study (loaded tooth contact analysis), after the figures of [1].

Every function takes results (one Dataset of :func:`cyclomesh.analyse`, or a mapping
``{case name: Dataset}`` to compare cases; :class:`~cyclomesh.results.profile.ProfileCurves`
for the profile) and returns a :class:`matplotlib.figure.Figure` drawn on the Agg
canvas, without touching pyplot's global state; nothing is computed here but the
drawing, and no file is written (:mod:`cyclomesh.figures.render` saves them). Lines
with more points than pixels are min/max decimated (:func:`~cyclomesh.figures.render.decimate`).
Tests check a figure's structure (axes, labels, lines), not its pixels. Datasets with
a ``ring`` dimension must be reduced to one ring first (``ds.isel(ring=0)``).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, "Design and Load Distribution Analysis of the
    Mismatched Cycloid-Pin Gear Pair in RV Speed Reducers", Machines 10 (2022) 672,
    doi:10.3390/machines10080672.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from cyclomesh.core.pair import PinErrors
from cyclomesh.figures.render import decimate, fixed_figure, new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cyclomesh.results.profile import ProfileCurves

__all__ = [
    "plot_profile",
    "plot_pin_errors",
    "plot_loads",
    "plot_profile_stress",
    "plot_stress_maps",
    "plot_transmission_error",
    "plot_gear_ratio",
    "plot_contacts",
    "plot_backlash",
]

Results = xr.Dataset | Mapping[str, xr.Dataset]


_MARGINS = {"left": 0.8, "right": 0.25, "bottom": 0.55, "top": 0.4, "wspace": 0.25, "hspace": 0.45}
"""Subplot margins [in] and spacing of the run figures (:func:`fixed_figure`)."""


def case_results(results: Results, needs: str | None = None) -> dict[str, xr.Dataset]:
    """``{case name: Dataset}`` of one ring each (also for the drive figures); with
    ``needs``, each must have that variable."""
    if isinstance(results, xr.Dataset):
        results = {str(results.attrs.get("case_name", "")): results}
    cases = dict(results)
    if not cases:
        raise ValueError("no results to plot")
    for name, ds in cases.items():
        if "ring" in ds.dims:
            raise ValueError(f"{name}: select one ring first (ds.isel(ring=0))")
        if needs is not None and needs not in ds:
            raise ValueError(f"{name}: the results have no {needs!r} variable")
    return cases


def case_legend(ax, cases: Mapping[str, object], outside: bool = False) -> None:
    if len(cases) > 1 or any(cases):
        where = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0)} if outside else {}
        ax.legend(fontsize="small", **where)


def legend_room(labels: Sequence[str]) -> float:
    """Right margin [in] that holds a small-font legend of ``labels`` beside the axes
    (where it hides no curve): a line sample and about 0.075 in per character."""
    longest = max((len(label) for label in labels), default=0)
    return 0.25 if not longest else 0.85 + 0.075 * longest


_DASHES = ("-", "--", "-.", ":")


def case_width(index: int, count: int) -> float:
    """Line width of case ``index`` of ``count``: each later case thinner, so that a case
    drawn exactly over an earlier one leaves the earlier one showing around it."""
    return max(2.8 - 0.6 * index, 1.0) if count > 1 else 1.5


def case_style(index: int, count: int, marker: str | None = None) -> dict[str, object]:
    """Line style of case ``index`` of ``count``: with several cases each later case is
    thinner and dashed differently, so a case drawn exactly over another still shows
    (the earlier, wider line shows around the later one)."""
    style: dict[str, object] = {} if marker is None else {"marker": marker}
    if count > 1:
        style["ls"] = _DASHES[index % len(_DASHES)]
        style["lw"] = case_width(index, count)
        if marker is not None:
            style["ms"] = max(7.0 - 1.2 * index, 3.0)
    return style


def _nearest_index(ds: xr.Dataset, angle_deg: float) -> int:
    """Index of the computed crank angle nearest to ``angle_deg`` (modulo 360)."""
    crank = ds["crank_angle"].values
    return int(np.argmin(np.abs((crank - angle_deg + 180.0) % 360.0 - 180.0)))


def _grid(ds: xr.Dataset, name: str, *dims: str) -> np.ndarray:
    """``ds[name]`` over ``dims`` as a NumPy array. The figures index and reduce NumPy
    arrays, not Datasets: xarray's indexing and reductions import ``dask.array`` in the
    figure worker whenever Dask is installed (see :mod:`cyclomesh.results.arrays`)."""
    return ds[name].transpose(*dims).values


def plot_profile(curves: ProfileCurves) -> Figure:
    """One tooth of the disc with its modification (Eqs. 1-3 of [1]).

    Left: one tooth space of the standard profile (dashed) and of each modified
    profile, with the pin seated at the bottom [mm]. Right: the modification, i.e. the
    normal distance from the standard to the modified profile [µm] (positive = material
    removed, clearance opened) over the generating angle φ1 within the tooth [deg]
    (0 = tooth-space bottom, ±180 = tips). The right axes has one line per case, then
    the zero line. The curves come from :func:`cyclomesh.results.profile.profile_curves`.
    """
    fig = fixed_figure(10.0, 4.2, **{**_MARGINS, "left": 0.7, "wspace": 0.3})
    ax_tooth, ax_mod = fig.subplots(1, 2, width_ratios=[1.0, 1.4])
    ax_tooth.plot(curves.standard_x_mm, curves.standard_y_mm, "k--", lw=1.0, label="standard")
    for name, (x, y, removed) in curves.modified.items():
        ax_tooth.plot(x, y, lw=1.2, label=name)
        ax_mod.plot(curves.phi1_deg, removed, label=name)
    from matplotlib.patches import Circle

    ax_tooth.add_patch(
        Circle((curves.seat_mm, 0.0), curves.pin_radius_mm, fill=False, color="0.5", lw=0.8)
    )
    ax_tooth.set_aspect("equal")
    ax_tooth.set_xlabel("x [mm]")
    ax_tooth.set_ylabel("y [mm]")
    ax_tooth.set_title("one tooth space, disc frame")
    ax_mod.axhline(0.0, color="k", ls="--", lw=1.0, label="standard")
    ax_mod.set_xlabel("generating angle φ1 within the tooth [deg] (0 = tooth-space bottom)")
    ax_mod.set_ylabel("modification, normal to profile [µm]")
    ax_mod.set_title("profile modification (positive = clearance)")
    ax_mod.set_xlim(-180.0, 180.0)
    ax_mod.legend(fontsize="small")  # one legend for both axes: it covers no label
    return fig


def plot_pin_errors(errors: PinErrors | Mapping[str, PinErrors], pins: int) -> Figure:
    """Pin errors per pin as bars (Eq. 5 of [1]): radial [µm], angular [µrad], radius [µm].

    One bar series (``BarContainer``) per case in each of the three axes.
    """
    if isinstance(errors, PinErrors):
        errors = {"": errors}
    fig = fixed_figure(10.0, 7.0, **{**_MARGINS, "left": 0.9, "hspace": 0.15})
    axes = fig.subplots(3, 1, sharex=True)
    numbers = np.arange(1, pins + 1)
    width = 0.8 / len(errors)
    fields = (
        ("radial", 1e6, "radial position error εa [µm]"),
        ("angular", 1e6, "angular position error εψ [µrad]"),
        ("pin_radius", 1e6, "pin radius error ερ [µm]"),
    )
    for k, (name, pin_errors) in enumerate(errors.items()):
        offset = (k - (len(errors) - 1) / 2) * width
        for ax, (field, scale, _) in zip(axes, fields, strict=True):
            values = np.broadcast_to(getattr(pin_errors, field), (pins,)) * scale
            ax.bar(numbers + offset, values, width=width, label=name or None)
    for ax, (_, _, label) in zip(axes, fields, strict=True):
        ax.set_ylabel(label, fontsize="small")
        ax.axhline(0.0, color="k", lw=0.6)
    axes[-1].set_xlabel("pin")
    if len(errors) > 1 or any(errors):
        axes[0].legend(fontsize="small")
    return fig


def plot_loads(results: Results, crank_angles_deg: Sequence[float] = (0, 60, 120, 180)) -> Figure:
    """Load on every pin and every groove at a few crank angles (Figs. of [1], Eq. 18).

    One row per crank angle (the computed angle nearest to each); left the pin-tooth load
    Fc [N], right the groove load Fp [N]; one line per case in each axes.
    """
    cases = case_results(results)
    # the legend beside the right column, where it hides no load (inside, "best" still
    # covered the loaded pins of a stack or a stage at the first angle)
    legend = len(cases) > 1 or any(cases)
    room = legend_room(list(cases)) if legend else _MARGINS["right"]
    fig = fixed_figure(
        10.0 + room - _MARGINS["right"],
        2.4 * len(crank_angles_deg) + 0.6,
        **{**_MARGINS, "hspace": 0.4, "right": room},
    )
    axes = np.atleast_2d(fig.subplots(len(crank_angles_deg), 2, sharex=True, squeeze=False))
    for row, angle in zip(axes, crank_angles_deg, strict=True):
        for i, (name, ds) in enumerate(cases.items()):
            k = _nearest_index(ds, angle)
            at = float(ds["crank_angle"].values[k])
            pins = ds["pin"].values
            style = case_style(i, len(cases), ".")
            for ax, load in zip(row, ("pin_load", "groove_load"), strict=True):
                ax.plot(pins, _grid(ds, load, "crank_angle", "pin")[k], label=name, **style)
        row[0].set_title(f"pin-tooth load, crank angle {at:g}°", fontsize="medium")
        row[1].set_title(f"pin-groove load, crank angle {at:g}°", fontsize="medium")
        row[0].set_ylabel("pin load Fc [N]")
        row[1].set_ylabel("groove load Fp [N]")
    for ax in axes[-1]:
        ax.set_xlabel("pin")
    case_legend(axes[0, 1], cases, outside=True)
    return fig


def plot_profile_stress(results: Results, pin: int = 20, x: str = "profile_angle") -> Figure:
    """Contact stress over the tooth profile for one pin through its mesh cycle (Eq. 24).

    Parameters
    ----------
    results : Dataset or mapping of Datasets
    pin : int
        Pin number (1 … n1).
    x : {"profile_angle", "contact_radius"}
        Abscissa: generating angle φ1 of the contact [deg] or its radius on the disc [mm].

    One line per case; angles where the pin carries no load are left out.
    """
    if x not in ("profile_angle", "contact_radius"):
        raise ValueError(f"x must be 'profile_angle' or 'contact_radius', got {x!r}")
    cases = case_results(results)
    room = legend_room(list(cases)) if len(cases) > 1 or any(cases) else _MARGINS["right"]
    fig = fixed_figure(7.5 + room - _MARGINS["right"], 4.5, **{**_MARGINS, "right": room})
    ax = fig.subplots()
    anywhere = False
    for i, (name, ds) in enumerate(cases.items()):
        j = int(np.flatnonzero(ds["pin"].values == pin)[0])
        loaded = _grid(ds, "pin_load", "crank_angle", "pin")[:, j] > 0
        anywhere |= bool(loaded.any())
        abscissa = np.where(loaded, _grid(ds, x, "crank_angle", "pin")[:, j], np.nan)
        stress = np.where(loaded, _grid(ds, "contact_stress", "crank_angle", "pin")[:, j], np.nan)
        order = np.argsort(np.where(loaded, abscissa, np.inf), kind="stable")
        ax.plot(abscissa[order], stress[order], label=name, **case_style(i, len(cases)))
    if x == "profile_angle":
        ax.set_xlabel("generating angle φ1 of the contact [deg] (0 = tooth-space bottom)")
    else:
        ax.set_xlabel("radius of the contact point on the disc [mm]")
    ax.set_ylabel("contact stress σH [MPa]")
    ax.set_title(f"pin {pin}: contact stress over the tooth profile")
    if not anywhere:  # an empty frame with a legend would look like a drawing fault
        ax.text(
            0.5,
            0.5,
            f"pin {pin} carries no load at any crank angle\n(choose another: [figures] stress_pin)",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
        ax.set_yticks([])
        ax.set_xticks([])
        return fig
    case_legend(ax, cases, outside=True)  # beside the axes: it hides no curve
    return fig


def plot_stress_maps(results: Results) -> Figure:
    """Contact stress of every pin over the crank angle, on the teeth and on the grooves.

    One row per case; left tooth contact stress, right groove stress [MPa], colour scale
    shared by a column; blank where a pin carries no load. Equally spaced crank angles
    are drawn as an image (one pixel per angle and pin), others as a mesh.
    """
    cases = case_results(results)
    height = 2.6 * len(cases) + 0.8
    fig = new_figure(11.0, height)
    grid = fig.add_gridspec(
        len(cases),
        5,
        width_ratios=[1.0, 0.03, 0.32, 1.0, 0.03],
        left=0.7 / 11.0,
        right=1 - 0.75 / 11.0,
        bottom=0.55 / height,
        top=1 - 0.4 / height,
        hspace=0.45,
        wspace=0.08,
    )
    axes = np.empty((len(cases), 2), dtype=object)
    for row in range(len(cases)):
        for column, slot in enumerate((0, 3)):
            share = axes[0, 0] if row or column else None
            axes[row, column] = fig.add_subplot(grid[row, slot], sharex=share, sharey=share)
    for column, (variable, label) in enumerate(
        (("contact_stress", "tooth contact stress [MPa]"), ("groove_stress", "groove stress [MPa]"))
    ):
        top = max(float(np.nanmax(ds[variable].values)) for ds in cases.values()) or 1.0
        for ax, (name, ds) in zip(axes[:, column], cases.items(), strict=True):
            values = np.ma.masked_less_equal(ds[variable].transpose("pin", "crank_angle").values, 0)
            crank, pins = ds["crank_angle"].values, ds["pin"].values
            step = np.diff(crank)
            if crank.size > 1 and np.allclose(step, step[0], rtol=1e-9, atol=0.0):
                half = step[0] / 2
                image = ax.imshow(
                    values,
                    extent=(crank[0] - half, crank[-1] + half, pins[0] - 0.5, pins[-1] + 0.5),
                    origin="lower",
                    aspect="auto",
                    interpolation="nearest",
                    vmin=0.0,
                    vmax=top,
                )
            else:
                image = ax.pcolormesh(
                    crank, pins, values, vmin=0.0, vmax=top, shading="nearest", rasterized=True
                )
            ax.set_ylabel("pin")
            ax.set_title(f"{name}: {label.split(' [')[0]}" if name else label, fontsize="medium")
        cax = fig.add_subplot(grid[:, 1 + 3 * column], label="<colorbar>")
        fig.colorbar(image, cax=cax, label=label)
    for ax in axes[-1]:
        ax.set_xlabel("crank angle [deg]")
    for ax in axes[:-1].ravel():
        ax.tick_params(labelbottom=False)
    return fig


def plot_transmission_error(results: Results) -> Figure:
    """Loaded transmission error (Eq. 25 of [1]): its ripple and its course over the run.

    Left: the ripple, TE minus its mean, over the first mesh cycle (360°/n1 of crank
    angle), where the mean of a case (in the legend) would hide it; right: TE over all
    computed angles. One line per case; TE [arcsec], negative = the disc lags.
    """
    cases = case_results(results)
    labels = [f"{name} (mean -00.0000″)" for name in cases]
    fig = fixed_figure(
        11.0, 4.0, **{**_MARGINS, "left": 0.9, "wspace": 0.3, "right": legend_room(labels)}
    )
    ax_mesh, ax_all = fig.subplots(1, 2, width_ratios=[1.0, 2.0])
    for i, (name, ds) in enumerate(cases.items()):
        crank = ds["crank_angle"].values
        te = ds["transmission_error"].values
        period = 360.0 / int(ds.attrs.get("pins") or ds.sizes["pin"])
        cycle = crank <= crank[0] + period + 1e-9
        mean = float(np.mean(te))
        style = case_style(i, len(cases))
        ax_mesh.plot(*decimate(crank[cycle], te[cycle] - mean), **style)
        label = f"{name} (mean {mean:.4g}″)" if name else f"mean {mean:.4g}″"
        ax_all.plot(*decimate(crank, te), label=label, **style)
    ax_mesh.set_title("ripple over one mesh cycle (360°/n1)", fontsize="medium")
    ax_all.set_title("all computed crank angles", fontsize="medium")
    ax_mesh.set_ylabel("TE minus its mean [arcsec]")
    ax_all.set_ylabel("loaded transmission error [arcsec]")
    for ax in (ax_mesh, ax_all):
        ax.set_xlabel("crank angle [deg]")
    ax_all.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def plot_gear_ratio(results: Results) -> Figure:
    """Instantaneous gear ratio over the crank angle (Eq. 26 of [1]); dotted line at n2.

    One line per case plus the ideal ratio n2.
    """
    cases = case_results(results)
    fig = fixed_figure(9.0, 4.0, **{**_MARGINS, "right": legend_room([*cases, "ideal n2 = 00"])})
    ax = fig.subplots()
    for i, (name, ds) in enumerate(cases.items()):
        ax.plot(
            *decimate(ds["crank_angle"].values, ds["gear_ratio"].values),
            label=name,
            **case_style(i, len(cases)),
        )
    first = next(iter(cases.values()))
    teeth = int(first.attrs.get("teeth") or first.sizes["pin"] - 1)
    ax.axhline(teeth, color="k", ls=":", lw=1.0, label=f"ideal n2 = {teeth}")
    step = first.attrs.get("gear_ratio_step_deg")
    ax.set_title(
        "instantaneous gear ratio" + (f" (taken over {step:g}° of crank angle)" if step else ""),
        fontsize="medium",
    )
    ax.set_xlabel("crank angle [deg]")
    ax.set_ylabel("instantaneous gear ratio [-]")
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def plot_contacts(results: Results) -> Figure:
    """Number of pins in contact over the crank angle: one marker per computed angle and
    case (a count that alternates between two values from one angle to the next reads
    as two rows of dots, not as a solid block of vertical lines); cases side by side
    are offset by a fraction of a pin so that equal counts do not hide each other."""
    cases = case_results(results)
    fig = fixed_figure(9.0, 3.6, **{**_MARGINS, "right": legend_room(list(cases))})
    ax = fig.subplots()
    markers = ("o", "s", "^", "D", "v", "P")
    count = len(cases)
    for i, (name, ds) in enumerate(cases.items()):
        shift = 0.0 if count == 1 else 0.25 * (i / (count - 1) - 0.5)
        ax.plot(
            ds["crank_angle"].values,
            ds["contacts"].values + shift,
            linestyle="none",
            marker=markers[i % len(markers)],
            markersize=2.5,
            label=name,
            color=f"C{i}",
        )
    ax.set_xlabel("crank angle [deg]")
    ax.set_ylabel("pins in contact [-]")
    ax.yaxis.get_major_locator().set_params(integer=True)
    case_legend(ax, cases, outside=True)
    return fig


BACKLASH_SCALE_MIN = 60.0
"""Smallest top of the backlash axes [arcsec]."""


def plot_backlash(results: Results, crank_angles_deg: Sequence[float] = (0.0,)) -> Figure:
    """Unloaded backlash of every pin (Eq. 11 of [1]) at a few crank angles [arcsec].

    One axes per crank angle (the computed angle nearest to each), one line per case;
    pins the loaded flank cannot reach (infinite backlash) are left out. The pins far
    from the mesh have backlashes of thousands of arcseconds; the axes show the ones
    that matter, up to three times the largest play of the cases (at least
    :data:`BACKLASH_SCALE_MIN`), and mark the pins above it with a triangle on the top
    edge.
    """
    cases = case_results(results)
    plays = [float(np.nanmax(ds["play"].values)) for ds in cases.values() if "play" in ds]
    top = max([BACKLASH_SCALE_MIN, *(3.0 * p for p in plays if np.isfinite(p))])
    fig = fixed_figure(
        9.0, 2.4 * len(crank_angles_deg) + 0.6, **{**_MARGINS, "right": legend_room(list(cases))}
    )
    axes = fig.subplots(len(crank_angles_deg), 1, sharex=True, squeeze=False)[:, 0]
    for ax, angle in zip(axes, crank_angles_deg, strict=True):
        above = 0
        for i, (name, ds) in enumerate(cases.items()):
            k = _nearest_index(ds, angle)
            at = float(ds["crank_angle"].values[k])
            pins = ds["pin"].values
            one = _grid(ds, "backlash", "crank_angle", "pin")[k]
            values = np.where(np.isfinite(one), one, np.nan)
            line = ax.plot(pins, values, label=name, **case_style(i, len(cases), "."))[0]
            high = values > top
            above = max(above, int(np.sum(high)))
            ax.plot(
                pins[high],
                np.full(int(np.sum(high)), top),
                "^",
                color=line.get_color(),
                ms=5,
                clip_on=False,
            )
        ax.set_ylim(-0.03 * top, top)
        note = f"; {above} pins above {top:.0f}″ (▲)" if above else ""
        ax.set_title(f"crank angle {at:g}°{note}", fontsize="medium")
        ax.set_ylabel("backlash [arcsec]")
    axes[-1].set_xlabel("pin")
    case_legend(axes[0], cases, outside=True)
    return fig
