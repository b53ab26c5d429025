"""The overview of a run study: the one figure ``cyclomesh run`` draws by default.

Four panels a gear designer reads first, every case in each: the load on every pin at
one crank angle (Eq. 18 of Li et al. 2022), the loaded transmission error (Eq. 25),
the peak tooth contact stress over the pins (Eq. 24) and the number of pins in
contact, the last three over the crank angle. ``--figures all`` draws the full set of
:mod:`cyclomesh.figures.run` (one figure per quantity, groove loads and stresses,
gear ratio, backlash, mesh force, profile, pin errors).

The plot takes plain NumPy arrays (:class:`OverviewCase`), not Datasets: a worker
that draws only this figure imports matplotlib, never xarray.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from cyclomesh.figures.render import decimate, fixed_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["OverviewCase", "plot_overview"]


class OverviewCase(NamedTuple):
    """What the overview draws of one case (one torque, one disc).

    Attributes
    ----------
    crank_angle : ndarray
        Crank angles φin [deg].
    pin : ndarray
        Pin numbers (1 … n1).
    pin_load_at : float
        The crank angle of ``pin_load`` [deg] (the computed one nearest to the asked).
    pin_load : ndarray
        Load Fc on every pin at ``pin_load_at`` [N].
    transmission_error : ndarray
        Loaded transmission error per crank angle [arcsec].
    max_contact_stress : ndarray
        Peak tooth contact stress over the pins per crank angle [MPa].
    contacts : ndarray
        Pins in contact per crank angle.
    """

    crank_angle: np.ndarray
    pin: np.ndarray
    pin_load_at: float
    pin_load: np.ndarray
    transmission_error: np.ndarray
    max_contact_stress: np.ndarray
    contacts: np.ndarray


_DASHES = ("-", "--", "-.", ":")
_TITLE = {"fontsize": "medium", "y": 1.0}
"""Titles at the top of their axes, where matplotlib puts them (no tick labels above):
given, matplotlib does not measure every tick label to place them, a quarter of the
figure's drawing time."""


def plot_overview(cases: Mapping[str, OverviewCase]) -> Figure:
    """Overview of a run study, 2 × 2 panels, one line per case in each (later cases
    thinner and dashed differently, so that equal curves still show each other)."""
    count = len(cases)
    labels = [name for name in cases if name]
    longest = max((len(label) for label in labels), default=0)
    right = 0.3 if count < 2 and not longest else 0.95 + 0.075 * longest
    fig = fixed_figure(
        11.0, 6.4, left=0.8, right=right, bottom=0.55, top=0.4, wspace=0.28, hspace=0.42
    )
    (loads, te), (stress, contacts) = fig.subplots(2, 2)
    at = sorted({f"{case.pin_load_at:g}" for case in cases.values()})
    for i, (name, case) in enumerate(cases.items()):
        style = {"color": f"C{i}", "label": name or None}
        if count > 1:
            style |= {"ls": _DASHES[i % len(_DASHES)], "lw": max(2.4 - 0.5 * i, 1.0)}
        loads.plot(case.pin, case.pin_load, marker=".", **style)
        te.plot(*decimate(case.crank_angle, case.transmission_error), **style)
        stress.plot(*decimate(case.crank_angle, case.max_contact_stress), **style)
        shift = 0.0 if count == 1 else 0.25 * (i / (count - 1) - 0.5)
        contacts.plot(
            case.crank_angle,
            case.contacts + shift,
            linestyle="none",
            marker="os^Dv"[i % 5],
            markersize=2.5,
            color=f"C{i}",
        )
    loads.set_title(f"load on every pin, crank angle {', '.join(at)}°", **_TITLE)
    loads.set_xlabel("pin")
    loads.set_ylabel("pin load Fc [N]")
    te.set_title("loaded transmission error", **_TITLE)
    te.set_ylabel("TE [arcsec]")
    te.ticklabel_format(axis="y", useOffset=False, style="plain")
    stress.set_title("peak tooth contact stress over the pins", **_TITLE)
    stress.set_ylabel("contact stress [MPa]")
    stress.ticklabel_format(axis="y", useOffset=False, style="plain")
    contacts.set_title("pins in contact", **_TITLE)
    contacts.set_ylabel("pins in contact [-]")
    contacts.yaxis.get_major_locator().set_params(integer=True)
    for ax in (te, stress, contacts):
        ax.set_xlabel("crank angle [deg]")
    for ax in (loads, te, stress, contacts):
        ax.grid(True, linewidth=0.4, alpha=0.5)
    if labels:
        te.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig
