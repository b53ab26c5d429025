"""What the figures print and where (issue 23): plain tick labels, no offset axis for
round-off, a count that alternates drawn as dots, legends beside the curves."""

from __future__ import annotations

import matplotlib
import numpy as np
import xarray as xr

from cyclomesh.figures.drive import plot_torque_share
from cyclomesh.figures.run import plot_contacts, plot_loads, plot_profile_stress
from cyclomesh.figures.tolerance import plot_stress_exceedance


def _drawn(plot, *args):
    """The figure drawn as the renderer draws it (text.parse_math off)."""
    with matplotlib.rc_context({"text.parse_math": False}):
        fig = plot(*args)
        fig.canvas.draw()
    return fig


def test_log_axis_ticks_are_plain_text():
    stress = np.linspace(1700.0, 2100.0, 200)
    ds = xr.Dataset({"max_contact_stress_mpa": ("ring", stress)}, coords={"ring": np.arange(200)})
    fig = _drawn(plot_stress_exceedance, ds, 2000.0)
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert labels and not any("$" in text or "mathdefault" in text for text in labels)
    assert "0.1" in labels
    # the y label lies inside the figure
    box = ax.yaxis.label.get_window_extent()
    assert box.x0 >= 0


def test_contacts_alternating_between_two_counts_are_dots_not_a_block():
    crank = np.arange(360.0)
    contacts = np.where(np.arange(360) % 2 == 0, 10, 11)
    ds = xr.Dataset({"contacts": ("crank_angle", contacts)}, coords={"crank_angle": crank})
    fig = _drawn(plot_contacts, {"case A": ds, "case B": ds})
    ax = fig.axes[0]
    for line in ax.lines:
        assert line.get_linestyle() == "None" and line.get_marker() not in (None, "None", "")
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1  # beside the axes, over no dot


def test_an_even_torque_split_is_drawn_flat_without_an_offset():
    crank = np.arange(0.0, 360.0, 1.0)
    round_off = 3e-9 * np.sin(np.radians(crank * 7))
    share = np.stack([206.0 + round_off, 206.0 - round_off], axis=-1)
    ds = xr.Dataset(
        {"torque_share": (("crank_angle", "disc"), share)},
        coords={"crank_angle": crank, "disc": [1, 2]},
    )
    fig = _drawn(plot_torque_share, {"two discs": ds})
    ax = fig.axes[0]
    assert ax.yaxis.get_offset_text().get_text() == ""
    low, high = ax.get_ylim()
    assert high - low >= 0.01 * 206.0  # round-off is not a swing
    title = ax.title.get_window_extent()
    assert title.y1 <= fig.bbox.y1 and title.x0 >= 0 and title.x1 <= fig.bbox.x1


def _loads(pins: int = 40, angles: int = 8) -> xr.Dataset:
    """Pin loads with a loaded arc at the first pins (where a legend "best" placed goes)."""
    crank = np.linspace(0.0, 360.0, angles, endpoint=False)
    load = np.zeros((angles, pins))
    load[:, :12] = 600.0 * np.sin(np.linspace(0.1, np.pi, 12))
    ds = xr.Dataset(
        {
            "pin_load": (("crank_angle", "pin"), load),
            "groove_load": (("crank_angle", "pin"), 0.6 * load),
            "contact_stress": (("crank_angle", "pin"), 2.0 * load),
            "profile_angle": (
                ("crank_angle", "pin"),
                np.tile(-np.arange(pins, dtype=float), (angles, 1)),
            ),
        },
        coords={"crank_angle": crank, "pin": np.arange(1, pins + 1)},
    )
    return ds


def test_the_pin_load_legend_is_beside_the_axes():
    """Issue 23 (looked at again): the legend of the pin loads sat inside the first axes,
    over the loaded pins of the RV stage's discs."""
    ds = _loads()
    fig = _drawn(plot_loads, {"three crankshafts, disc 1": ds, "two crankshafts, disc 2": ds})
    legend = fig.axes[1].get_legend()
    assert fig.axes[0].get_legend() is None and legend is not None
    box = legend.get_window_extent()
    for ax in fig.axes:
        assert box.x0 >= ax.get_window_extent().x1  # beside every axes, over no curve
    assert box.x1 <= fig.bbox.x1  # and inside the figure


def test_the_profile_stress_of_an_unloaded_pin_says_so():
    """A pin the pin errors lift off at every angle drew an empty frame with a legend
    (examples/requirements.toml, pin 20): it now says why it is empty."""
    ds = _loads()
    fig = _drawn(plot_profile_stress, {"case": ds}, 20)
    ax = fig.axes[0]
    assert ax.get_legend() is None and "pin 20 carries no load" in ax.texts[0].get_text()
    fig = _drawn(plot_profile_stress, {"a": ds, "b": ds}, 5)
    legend = fig.axes[0].get_legend().get_window_extent()
    assert legend.x0 >= fig.axes[0].get_window_extent().x1


def test_the_default_stress_pin_is_a_loaded_one():
    """Without [figures] stress_pin the figure takes pin n/2, unless no case loads it:
    then the pin of the highest contact stress."""
    from cyclomesh.studies.run_figures import stress_pin as _stress_pin

    ds = _loads()
    assert _stress_pin({"case": ds}, 20) == 6  # the peak of the loaded arc (pins 1-12)
    assert _stress_pin({"case": ds}, 5) == 5  # loaded: kept
