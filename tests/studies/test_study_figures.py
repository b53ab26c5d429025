"""Figures, report and result files: structure, not pixels."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import QuadMesh
from matplotlib.container import BarContainer

from cyclomesh import TABLE1, Modification, PinErrors, analyse, figures
from cyclomesh.figures.render import decimate
from cyclomesh.output.writers import csv_column, write_pin_csv
from cyclomesh.publish.report import Section, figure_html, render_report, table_html
from cyclomesh.results.profile import profile_curves
from cyclomesh.studies.run import summary_record

ANGLES = np.deg2rad(np.arange(0.0, 360.0, 10.0))
TPM = Modification(pin_radius=8e-6)


@pytest.fixture(scope="module")
def cases() -> dict[str, xr.Dataset]:
    return {
        "TPM": analyse(TABLE1, TPM, crank_angles=ANGLES),
        "no TPM": analyse(TABLE1, None, crank_angles=ANGLES, groove_deformation=False),
    }


def labels(ax) -> tuple[str, str]:
    return ax.get_xlabel(), ax.get_ylabel()


def test_profile_shows_the_modification_in_micrometres():
    curves = profile_curves(TABLE1, {"Δρ = 8 µm": TPM, "Δa = -5 µm": Modification(-5e-6)})
    fig = figures.plot_profile(curves)
    tooth, modification = fig.axes
    assert labels(tooth) == ("x [mm]", "y [mm]")
    assert labels(modification)[1] == "modification, normal to profile [µm]"
    assert len(tooth.lines) == 3  # standard + two modified
    equidistant, shifted, zero = modification.lines
    assert zero.get_ydata()[0] == 0.0
    # an equidistant modification Δρ removes Δρ everywhere along the normal (Eq. 3)
    np.testing.assert_allclose(equidistant.get_ydata(), 8.0, atol=0.02)
    # a negative shift Δa removes material at the tooth-space bottom, |Δa| there
    phi = shifted.get_xdata()
    assert shifted.get_ydata()[np.argmin(np.abs(phi))] == pytest.approx(5.0, abs=0.02)


def test_pin_errors_are_bars_per_case():
    rng = np.random.default_rng(1)
    errors = {
        "a": PinErrors(radial=rng.uniform(-4e-6, 4e-6, 40)),
        "b": PinErrors(angular=rng.uniform(-5e-5, 5e-5, 40)),
    }
    fig = figures.plot_pin_errors(errors, 40)
    assert len(fig.axes) == 3
    for ax in fig.axes:
        bars = [c for c in ax.containers if isinstance(c, BarContainer)]
        assert len(bars) == 2 and all(len(b) == 40 for b in bars)
    assert fig.axes[0].get_ylabel() == "radial position error εa [µm]"
    heights = [bar.get_height() for bar in fig.axes[0].containers[0]]
    np.testing.assert_allclose(heights, errors["a"].radial * 1e6)
    assert fig.axes[-1].get_xlabel() == "pin"


def test_loads_one_row_per_crank_angle(cases):
    fig = figures.plot_loads(cases, [0, 60, 125])
    assert len(fig.axes) == 6
    for ax in fig.axes:
        assert len(ax.lines) == 2
    assert fig.axes[0].get_ylabel() == "pin load Fc [N]"
    assert fig.axes[1].get_ylabel() == "groove load Fp [N]"
    assert "120°" in fig.axes[4].get_title()  # nearest computed angle to 125°
    np.testing.assert_allclose(
        fig.axes[0].lines[0].get_ydata(), cases["TPM"]["pin_load"].isel(crank_angle=0)
    )


def test_profile_stress_only_where_loaded(cases):
    fig = figures.plot_profile_stress(cases, pin=20)
    (ax,) = fig.axes
    assert labels(ax)[1] == "contact stress σH [MPa]" and "[deg]" in labels(ax)[0]
    assert len(ax.lines) == 2
    loaded = int((cases["TPM"]["pin_load"].sel(pin=20) > 0).sum())
    assert np.count_nonzero(np.isfinite(ax.lines[0].get_ydata())) == loaded
    fig = figures.plot_profile_stress(cases, pin=20, x="contact_radius")
    assert fig.axes[0].get_xlabel() == "radius of the contact point on the disc [mm]"
    with pytest.raises(ValueError, match="x must be"):
        figures.plot_profile_stress(cases, x="roll")


def test_stress_maps_teeth_and_grooves(cases):
    fig = figures.plot_stress_maps(cases)
    colorbar_axes = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    maps = [ax for ax in fig.axes if ax not in colorbar_axes]
    assert len(maps) == 4
    assert all(len(ax.images) == 1 for ax in maps)  # equally spaced angles: an image
    image = maps[0].images[0].get_array()  # first case, teeth: pins × angles, unloaded blank
    stress = cases["TPM"]["contact_stress"].transpose("pin", "crank_angle").values
    np.testing.assert_array_equal(image.filled(0.0), np.where(stress > 0, stress, 0.0))
    assert np.array_equal(image.mask, stress <= 0)
    uneven = {k: ds.isel(crank_angle=[0, 1, 3, 7]) for k, ds in cases.items()}
    fig = figures.plot_stress_maps(uneven)
    maps = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert all(any(isinstance(c, QuadMesh) for c in ax.collections) for ax in maps)
    colorbars = {ax.get_ylabel() for ax in colorbar_axes}
    assert colorbars == {"tooth contact stress [MPa]", "groove stress [MPa]"}
    assert all(labels(ax)[1] == "pin" for ax in maps)


def test_transmission_error_gear_ratio_contacts_backlash(cases):
    te = figures.plot_transmission_error(cases)
    assert [len(ax.lines) for ax in te.axes] == [2, 2]
    assert te.axes[0].get_ylabel() == "TE minus its mean [arcsec]"
    assert te.axes[1].get_ylabel() == "loaded transmission error [arcsec]"
    mesh_cycle = te.axes[0].lines[0].get_xdata()
    assert mesh_cycle.max() <= 360.0 / 40 + 1e-9
    # the left axes shows the ripple: TE minus the mean of the case, which the legend gives
    first = next(iter(cases.values()))["transmission_error"]
    ripple = te.axes[0].lines[0].get_ydata()
    mean = float(first.mean())
    np.testing.assert_allclose(ripple, first.values[: len(ripple)] - mean, atol=1e-12)
    assert f"{mean:.4g}" in te.axes[1].get_legend().get_texts()[0].get_text()
    # a case drawn exactly over another still shows: different width and dashes
    a, b = te.axes[1].lines[:2]
    assert a.get_linewidth() > b.get_linewidth() and a.get_linestyle() != b.get_linestyle()
    ratio = figures.plot_gear_ratio(cases)
    assert len(ratio.axes[0].lines) == 3  # two cases + ideal n2
    assert ratio.axes[0].lines[-1].get_ydata()[0] == 39
    assert labels(ratio.axes[0]) == ("crank angle [deg]", "instantaneous gear ratio [-]")
    contacts = figures.plot_contacts(cases)
    assert labels(contacts.axes[0]) == ("crank angle [deg]", "pins in contact [-]")
    assert len(contacts.axes[0].lines) == 2
    backlash = figures.plot_backlash(cases, [0, 90])
    assert len(backlash.axes) == 2 and backlash.axes[0].get_ylabel() == "backlash [arcsec]"
    values = backlash.axes[0].lines[0].get_ydata()
    assert np.all(np.isfinite(values) | np.isnan(values))
    # the axes show the backlash that matters (3 × the largest play, at least 60″) and
    # mark the pins above it on the top edge
    play = max(float(ds["play"].max()) for ds in cases.values())
    top = backlash.axes[0].get_ylim()[1]
    assert top == pytest.approx(max(60.0, 3 * play))
    marks = backlash.axes[0].lines[1].get_ydata()
    assert np.all(marks == top) and len(marks) == np.sum(values > top)


def test_a_single_dataset_is_accepted(cases):
    fig = figures.plot_contacts(cases["TPM"])
    assert len(fig.axes[0].lines) == 1


def test_report_embeds_figures_and_escapes_text(cases):
    fig = figures.plot_contacts(cases)
    page = render_report(
        "A <study>",
        [
            Section("Summary", table_html(["case", "x [N]"], [["<a>", 1.23456], ["b", None]])),
            Section("Figures", "", [(fig, "contacts"), (b"\x89PNG fake", "bytes")]),
            Section("SVG", "", [(fig, "as svg")]),
        ],
        {"SHA-256 of the study file": "abc123"},
    )
    assert "<h1>A &lt;study&gt;</h1>" in page and '<td class="t">&lt;a&gt;</td>' in page
    assert "<td>1.235</td>" in page
    assert page.count("data:image/png;base64,") == 3
    assert "abc123" in page and "cyclomesh version: <code>" in page
    svg = figure_html(fig, "svg", embed="svg")
    assert svg.startswith("<figure><svg") and "<?xml" not in svg


def test_result_files_helpers(tmp_path, cases):
    assert csv_column("pin_load", "N") == "pin_load_n"
    assert csv_column("profile_angle", "deg") == "profile_angle_deg"
    assert csv_column("gear_ratio", "1") == "gear_ratio"
    assert csv_column("contact_stress", "MPa") == "contact_stress_mpa"
    path = write_pin_csv(cases["TPM"], tmp_path / "r.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:3] == ["crank_angle_deg", "pin", "pin_load_n"]
    record = summary_record(
        xr.Dataset({"te_pp_arcsec": math.inf, "min_contacts": np.int64(3), "any_overlap": False})
    )
    assert record == {"te_pp_arcsec": None, "min_contacts": 3, "any_overlap": False}
    json.dumps(record, allow_nan=False)


def test_decimation_keeps_every_spike_and_the_envelope():
    x = np.arange(100_000, dtype=float)
    y = np.sin(x / 5000.0)
    spikes = [777, 50_001, 99_998]
    y[spikes] = [5.0, -7.0, 9.0]  # one-sample spikes, like the gear-ratio spikes
    dx, dy = decimate(x, y, bins=500)
    assert dx.size <= 4 * 500 and np.all(np.diff(dx) > 0)
    for k in spikes:
        assert k in dx and dy[np.searchsorted(dx, k)] == y[k]
    assert dy.max() == y.max() and dy.min() == y.min()
    assert dx[0] == 0 and dx[-1] == x[-1]
    # per bin of the original, the decimated line spans the same range
    edges = np.linspace(0, x.size, 501).astype(int)
    for a, b in zip(edges[:-1:37], edges[1::37], strict=True):
        inside = (dx >= a) & (dx < b)
        assert dy[inside].max() == y[a:b].max() and dy[inside].min() == y[a:b].min()
    short_x, short_y = decimate(x[:100], y[:100], bins=500)
    assert short_x.size == 100  # short lines are left alone


def test_netcdf_writer_reads_back_as_xarray_writes_it(tmp_path, cases):
    from cyclomesh.output.writers import write_netcdf

    ds = cases["TPM"].assign(flag=("pin", np.arange(40) % 2 == 0))
    ds.attrs["switch"] = True
    write_netcdf(ds, tmp_path / "ours.nc")
    reference = ds.assign(flag=ds["flag"].astype(np.int8))
    reference.attrs["switch"] = np.int8(1)
    reference.to_netcdf(tmp_path / "xarray.nc")
    with (
        xr.open_dataset(tmp_path / "ours.nc") as ours,
        xr.open_dataset(tmp_path / "xarray.nc") as ref,
    ):
        xr.testing.assert_identical(ours.load(), ref.load())
        assert np.isinf(ours["backlash"].values).any()  # infinities kept in NetCDF


def test_renderer_saves_every_format_the_same_in_a_pool_or_not(tmp_path, cases):
    from cyclomesh.figures.render import FigureJob, render_figures

    jobs = [
        FigureJob("contacts", figures.plot_contacts, (cases,), caption="c", section="A"),
        FigureJob("ratio", figures.plot_gear_ratio, (cases,), caption="r", section="B"),
        FigureJob("te", figures.plot_transmission_error, (cases,), caption="t", section="B"),
    ]
    serial = render_figures(jobs, tmp_path / "one", ("png", "svg", "pdf"), 60, workers=1)
    pooled = render_figures(jobs, tmp_path / "two", ("png",), 60, workers=2)
    assert [f.name for f in pooled] == [f.name for f in serial] == ["contacts", "ratio", "te"]
    for one, two in zip(serial, pooled, strict=True):
        assert one.png == two.png and one.png[:8] == b"\x89PNG\r\n\x1a\n"
        assert [p.suffix for p in one.files] == [".png", ".svg", ".pdf"]
        assert (tmp_path / "two" / f"{two.name}.png").read_bytes() == two.png
    with pytest.raises(ValueError, match="unknown figure format 'gif'"):
        render_figures(jobs, tmp_path, ("gif",))


def test_pool_draws_submitted_figures_once_and_writes_only_when_collected(tmp_path, cases):
    from cyclomesh.figures.render import FigureJob, FigurePool, render_figures

    jobs = [
        FigureJob("contacts", figures.plot_contacts, (cases,), caption="c", section="A"),
        FigureJob("ratio", figures.plot_gear_ratio, (cases,), caption="r", section="B"),
    ]
    serial = render_figures(jobs, tmp_path / "one", ("png", "svg"), 60, workers=1)
    folder = tmp_path / "two"
    with FigurePool(2) as pool:
        pool.submit(jobs[:1], ("png", "svg"), 60)  # e.g. before the solve
        pool.submit(jobs, ("png", "svg"), 60)  # the first one is not drawn twice
        assert not folder.exists()  # workers draw; files come when collected
        pooled = render_figures(jobs, folder, ("png", "svg"), 60, pool=pool)
    assert [f.name for f in pooled] == ["contacts", "ratio"]
    for one, two in zip(serial, pooled, strict=True):
        assert one.png == two.png
        assert [p.name for p in two.files] == [f"{two.name}.png", f"{two.name}.svg"]
        assert (folder / f"{two.name}.svg").read_bytes().startswith(b"<?xml")


def test_figure_formats_option():
    from cyclomesh.exceptions import StudyError
    from cyclomesh.publish.pipeline import parse_figure_formats

    assert parse_figure_formats("png,svg") == ("png", "svg")
    assert parse_figure_formats(" PDF , png,pdf") == ("pdf", "png")
    assert parse_figure_formats("none") == ()
    with pytest.raises(StudyError, match="--figures: unknown format 'jpg'"):
        parse_figure_formats("png,jpg")
