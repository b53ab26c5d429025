"""Drive characteristics through the API: Datasets of analyse and stiffness, figures."""

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PinErrors, analyse, summarize
from cyclomesh.figures.drive import (
    plot_mesh_force,
    plot_play,
    plot_rigidity,
    plot_torque_share,
    plot_torsion_curve,
)
from cyclomesh.results.torsion import stiffness, summarize_stiffness

TPM = Modification(pin_radius=8e-6)
CRANK = np.arange(0.0, 360.0, 4.0)


def test_analyse_single_torque_keeps_its_layout_and_adds_play_and_mesh_force():
    ds = analyse(TABLE1, TPM, crank_angles_deg=CRANK)
    assert ds["pin_load"].dims == ("crank_angle", "pin")
    assert ds["transmission_error"].dims == ("crank_angle",)
    assert ds["contacts"].dims == ("crank_angle",)
    assert ds["play"].attrs["units"] == "arcsec" and ds["play"].dims == ("crank_angle",)
    assert ds["mesh_force"].attrs["units"] == "N"
    assert "torque_share" not in ds and ds.attrs["torque_nm"] == 250.0
    # the mesh force is at least the torque over the largest arm, at most the load sum
    assert np.all(ds["mesh_force"] > 250.0 / (TABLE1.eccentricity * TABLE1.pins))
    assert np.all(ds["mesh_force"] <= ds["pin_load"].sum("pin") + 1e-9)
    summary = summarize(ds)
    assert float(summary["play_arcsec_mean"]) > 0


def test_analyse_torque_list_and_stack_dimensions():
    ds = analyse(TABLE1, TPM, torque=[-250.0, 100.0, 250.0], crank_angles_deg=CRANK, discs=2)
    assert ds["pin_load"].dims == ("torque", "crank_angle", "disc", "pin")
    assert ds["torque_share"].dims == ("torque", "crank_angle", "disc")
    assert ds["transmission_error"].dims == ("torque", "crank_angle")
    assert ds["play"].dims == ("crank_angle",)
    assert ds["torque"].attrs["units"] == "N·m" and list(ds["disc"].values) == [1, 2]
    te = ds["transmission_error"]
    assert np.all(te.sel(torque=-250.0) > 0) and np.all(te.sel(torque=250.0) < 0)
    total = ds["torque_share"].sum("disc").transpose("torque", "crank_angle")
    np.testing.assert_allclose(total, np.broadcast_to(ds["torque"].values[:, None], total.shape))
    summary = summarize(ds)
    assert summary["max_pin_load_n"].dims == ("torque",)


def test_analyse_refuses_zero_torque():
    with pytest.raises(DesignError, match="torque 0"):
        analyse(TABLE1, TPM, torque=0.0, crank_angles_deg=CRANK)


def test_stiffness_dataset_and_summary():
    errors = PinErrors(radial=np.random.default_rng(2).uniform(-3e-6, 3e-6, 40))
    ds = stiffness(
        TABLE1,
        TPM,
        errors,
        250.0,
        points=9,
        crank_angles_deg=CRANK,
        series_stiffness_nm_per_arcmin=113.0,
    )
    assert ds["rotation"].dims == ("torque", "crank_angle")
    assert ds["rotation"].attrs["units"] == "arcsec"
    assert ds["lost_motion"].attrs["units"] == "arcmin"
    assert ds["torsional_rigidity"].attrs["units"] == "N·m/arcmin"
    assert 0.0 not in ds["torque"].values
    assert np.all(ds["rotation"].sel(torque=250.0) < 0)
    summary = summarize_stiffness(ds)
    for key in (
        "play_arcmin_mean",
        "play_arcmin_max",
        "lost_motion_arcmin_mean",
        "lost_motion_arcmin_max",
        "torsional_rigidity_nm_per_arcmin_mean",
        "torsional_rigidity_nm_per_arcmin_min",
        "drive_lost_motion_arcmin_mean",
        "drive_torsional_rigidity_nm_per_arcmin_min",
    ):
        assert np.isfinite(float(summary[key])), key
    # the mesh is far stiffer than the rest of the drive: the whole drive is softer
    # than either part and close to the series spring
    drive = float(summary["drive_torsional_rigidity_nm_per_arcmin_mean"])
    mesh = float(summary["torsional_rigidity_nm_per_arcmin_mean"])
    assert 1 / drive == pytest.approx(1 / mesh + 1 / 113.0, rel=0.02)
    # the play in arcmin agrees with analyse's play in arcsec
    play = analyse(TABLE1, TPM, errors, crank_angles_deg=CRANK)["play"]
    np.testing.assert_allclose(ds["play"] * 60.0, play, rtol=1e-12)


def test_stiffness_refuses_bad_series_stiffness():
    with pytest.raises(DesignError, match="series_stiffness"):
        stiffness(
            TABLE1, TPM, None, 250.0, crank_angles_deg=CRANK, series_stiffness_nm_per_arcmin=-1.0
        )


def test_figures_have_their_axes_and_curves():
    ds = stiffness(
        TABLE1,
        TPM,
        None,
        250.0,
        points=5,
        crank_angles_deg=CRANK,
        discs=2,
        series_stiffness_nm_per_arcmin=113.0,
    )
    fig = plot_torsion_curve({"A": ds, "B": ds})
    assert len(fig.axes) == 2  # mesh and whole drive
    assert fig.axes[0].get_xlabel() == "torque [% of rated]"
    assert len(plot_rigidity(ds).axes) == 2
    assert len(plot_play(ds).axes[0].lines) == 3  # play, lost motion, whole-drive lost motion
    # the same case twice: the second is drawn thinner, so the first still shows around it
    lines = plot_play({"A": ds, "B": ds}).axes[0].lines
    assert lines[0].get_linewidth() > lines[3].get_linewidth()
    np.testing.assert_array_equal(lines[0].get_ydata(), lines[3].get_ydata())
    assert len(plot_torque_share(ds).axes[0].lines) == 3  # two discs and the equal split
    run = analyse(TABLE1, TPM, torque=[-250.0, 250.0], crank_angles_deg=CRANK, discs=2)
    assert len(plot_mesh_force(run).axes[0].lines) == 2
    with pytest.raises(ValueError, match="torque_share"):
        plot_torque_share(analyse(TABLE1, TPM, crank_angles_deg=CRANK))
