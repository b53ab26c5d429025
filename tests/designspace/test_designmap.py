"""Design map over the modification space (issue 9)."""

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PinErrors
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.designspace.sweep import (
    Constraints,
    DesignTask,
    candidate_metrics,
    design_map,
    evaluate_grid,
)
from cyclomesh.drive.solve import play, solve_drive
from cyclomesh.execution.backends import ProcessBackend, SerialBackend
from cyclomesh.figures.designmap import map_metrics, plot_design_map, plot_design_maps
from cyclomesh.units import RAD_PER_ARCMIN as ARCMIN

ANGLES = np.arange(0.0, 9.0, 0.5)
PHI = np.deg2rad(ANGLES)


def rings(k, seed=4):
    rng = np.random.default_rng(seed)
    return PinErrors(
        radial=rng.normal(0, 1.5e-6, (k, TABLE1.pins)),
        angular=rng.normal(0, 1.5e-5, (k, TABLE1.pins)),
    )


def small_map(**kw):
    return design_map(
        TABLE1,
        {"pin_circle_radius_um": [-6.0, -3.0, 0.0, 2.0], "pin_radius_um": [-1.0, 4.0, 8.0]},
        torque=250.0,
        crank_angles_deg=ANGLES,
        **kw,
    )


def test_map_labels_every_metric_with_units_and_keeps_failed_candidates():
    ds = small_map(constraints=Constraints(max_play=1.0 * ARCMIN))
    assert ds["max_contact_stress_mpa"].dims == ("pin_circle_radius_um", "pin_radius_um")
    for name in map_metrics(ds):
        assert ds[name].attrs["units"]
    assert ds["pin_radius_um"].attrs["units"] == "um"
    # Δa = +2 µm, Δρ = −1 µm: the pins interfere with the disc; reported, not dropped
    bad = ds.sel(pin_circle_radius_um=2.0, pin_radius_um=-1.0)
    assert int(bad["feasible"]) == 0 and "overlaps" in str(bad["reason"].values)
    assert np.isnan(float(bad["max_contact_stress_mpa"]))
    ok = ds["reason"].values == ""
    assert np.all(np.isfinite(ds["max_contact_stress_mpa"].values[ok]))
    # every candidate with a metric NaN has a reason
    assert np.all(ds["reason"].values[np.isnan(ds["te_pp_arcsec"].values)] != "")
    assert ds.attrs["candidates"] == 12


def test_map_values_are_those_of_a_single_analysis():
    ds = small_map()
    mod = Modification(-3e-6, 8e-6)
    res = solve_ltca(TABLE1, mod, None, 250.0, PHI)
    cell = ds.sel(pin_circle_radius_um=-3.0, pin_radius_um=8.0)
    assert float(cell["max_contact_stress_mpa"]) == res.contact_stress.max() / 1e6
    te = res.transmission_error
    assert float(cell["te_pp_arcsec"]) == pytest.approx((te.max() - te.min()) / (np.pi / 648000))
    assert float(cell["min_contacts"]) == res.contacts.min()
    gap = play(TABLE1, mod, None, PHI)
    assert float(cell["play_arcmin"]) == pytest.approx(gap.max() / ARCMIN, rel=1e-12)


def test_optimum_is_the_best_feasible_candidate():
    limits = Constraints(max_play=1.0 * ARCMIN, min_play=0.2 * ARCMIN)
    ds = small_map(constraints=limits, objective="max_contact_stress")
    feasible = ds["feasible"].values.astype(bool)
    assert ds.attrs["feasible_candidates"] == feasible.sum() > 0
    best = ds.sel(
        pin_circle_radius_um=ds.attrs["optimum_pin_circle_radius_um"],
        pin_radius_um=ds.attrs["optimum_pin_radius_um"],
    )
    assert int(best["feasible"]) == 1
    assert (
        float(best["max_contact_stress_mpa"]) == ds["max_contact_stress_mpa"].values[feasible].min()
    )
    play_ = ds["play_arcmin"].values
    assert np.all(play_[feasible] <= 1.0) and np.all(ds["min_play_arcmin"].values[feasible] >= 0.2)
    violated = ds["reason"].values == "max_play violated"
    assert np.all(play_[violated] > 1.0)


def test_rotation_axis_adds_twice_delta_to_the_play():
    ds = design_map(
        TABLE1,
        {"rotation_urad": [0.0, 10.0, 20.0]},
        base=Modification(pin_radius=5e-6),
        crank_angles_deg=ANGLES,
        objective="play",
    )
    step = np.diff(ds["play_arcmin"].values) * ARCMIN
    np.testing.assert_allclose(step, 20e-6, rtol=0, atol=1e-14)
    assert ds.attrs["optimum_rotation_urad"] == 0.0


def test_robust_metric_is_the_percentile_over_common_rings():
    errors = rings(12)
    ds = design_map(
        TABLE1,
        {"pin_radius_um": [6.0, 9.0]},
        errors=errors,
        crank_angles_deg=ANGLES,
        lost_motion=True,
    )
    assert ds.attrs["robust"] == 1 and ds.attrs["rings"] == 12
    per_ring = candidate_metrics(
        TABLE1, Modification(pin_radius=9e-6), errors, 250.0, PHI, lost_motion=True
    )
    cell = ds.sel(pin_radius_um=9.0)
    assert float(cell["max_contact_stress_mpa"]) == pytest.approx(
        np.percentile(per_ring["max_contact_stress"], 95, method="higher") * 1e-6, rel=1e-14
    )
    assert float(cell["min_contacts"]) == np.percentile(per_ring["min_contacts"], 5, method="lower")
    assert float(cell["min_play_arcmin"]) == pytest.approx(
        np.percentile(per_ring["min_play"], 5, method="lower") / ARCMIN, rel=1e-14
    )
    # conservative order statistics: at least 95 % of rings do as well
    assert (
        np.mean(per_ring["max_contact_stress"] <= float(cell["max_contact_stress_mpa"]) * 1e6)
        >= 0.95
    )
    # lost motion includes the play and the elastic deflection at ±3 % of the torque
    assert np.all(per_ring["lost_motion"] > per_ring["max_play"])


def test_reverse_te_at_vanishing_load_is_the_reverse_rest_position():
    """The mirrored solve agrees with the unloaded-flank geometry of the forward solver."""
    errors = rings(1, seed=8)
    mod = Modification(-2e-6, 6e-6, 5e-6)
    reverse = solve_drive(TABLE1, mod, errors, -1e-6, PHI).transmission_error[..., 0, :]
    forward = solve_ltca(TABLE1, mod, errors, 1e-6, PHI).transmission_error
    np.testing.assert_allclose(reverse - forward, play(TABLE1, mod, errors, PHI), atol=1e-10)


def test_robust_map_is_bit_for_bit_the_same_on_local_processes():
    task = DesignTask(
        design=TABLE1,
        base=Modification(),
        axes=(("pin_circle_radius", (-4e-6, -1e-6)), ("pin_radius", (-1e-6, 5e-6, 8e-6))),
        errors=rings(6),
        torque=250.0,
        crank_angles=tuple(PHI[::3]),
    )
    serial = evaluate_grid(task, SerialBackend(), chunk=1)
    pool = ProcessBackend(2)
    try:
        parallel = evaluate_grid(task, pool, chunk=2)
    finally:
        pool.close()
    whole = evaluate_grid(task)
    for name, value in serial.items():
        np.testing.assert_array_equal(parallel[name], value)
        np.testing.assert_array_equal(whole[name], value)


def test_bad_design_space_is_refused():
    with pytest.raises(DesignError, match="groove_radius_mm"):
        design_map(TABLE1, {"groove_radius_mm": [4.0]})
    with pytest.raises(DesignError, match="objective"):
        design_map(TABLE1, {"pin_radius_um": [8.0]}, objective="cost")


def test_design_map_figures_show_feasible_region_and_optimum():
    ds = small_map(constraints=Constraints(max_play=1.0 * ARCMIN))
    fig = plot_design_map(ds, "max_contact_stress_mpa", marks={"paper": {"pin_radius_um": 8.0}})
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[:2] == ["optimum", "paper"]
    # the hatched (infeasible) region has its legend entry; failed candidates too if any
    feasible = ds["feasible"].values.astype(bool)
    assert ("infeasible (constraint)" in labels) == bool((~feasible).any())
    # the solved candidates are marked (the contours join them only); blank is explained
    # where failed candidates leave a gap
    assert "solved candidate" in labels
    failed = ~np.isfinite(ds["max_contact_stress_mpa"].values)
    assert ("blank: not interpolated" in labels) == bool(failed.any())
    assert "Δρ" in ax.get_xlabel() and "Δa" in ax.get_ylabel()
    assert ax.get_xlabel().endswith("[µm]") and "um]" not in ax.get_ylabel()
    assert ax.get_title() == ds["max_contact_stress_mpa"].attrs["long_name"]
    star = next(line for line in ax.lines if line.get_label() == "optimum")
    assert not star.get_clip_on()  # drawn whole on the edge of the range
    fig = plot_design_maps(ds)
    assert len([a for a in fig.axes if a.get_visible() and a.get_title()]) == len(map_metrics(ds))
    with pytest.raises(ValueError, match="not in the map"):
        plot_design_map(ds, "lost_motion_arcmin")


def test_geometry_sweep_checks_every_candidate_and_keeps_full_reasons():
    base = Modification(pin_radius=8e-6)
    ds = design_map(
        TABLE1,
        {"eccentricity_mm": [1.5, 2.0], "pin_radius_mm": [3.5, 6.5], "width_mm": [12.0, 16.0]},
        base=base,
        torque=250.0,
        crank_angles_deg=ANGLES,
    )
    assert ds["eccentricity_mm"].attrs["units"] == "mm"
    # the base geometry in the grid reproduces the analysis of the base design exactly
    res = solve_ltca(TABLE1, base, None, 250.0, PHI)
    same = ds.sel(eccentricity_mm=1.5, pin_radius_mm=3.5, width_mm=12.0)
    assert float(same["max_contact_stress_mpa"]) == pytest.approx(
        res.contact_stress.max() * 1e-6, rel=1e-12
    )
    # a wider disc carries the same torque at a lower stress
    wide = ds.sel(eccentricity_mm=1.5, pin_radius_mm=3.5, width_mm=16.0)
    assert float(wide["max_contact_stress_mpa"]) < float(same["max_contact_stress_mpa"])
    # e = 2 mm (K1 = 0.976) undercuts the profile; ρp = 6.5 mm makes neighbouring pins
    # overlap: infeasible, with the core's whole message as the reason
    undercut = str(ds["reason"].sel(eccentricity_mm=2.0, pin_radius_mm=3.5, width_mm=12.0).values)
    assert undercut.startswith("undercut profile") and undercut.endswith("pin_circle_radius_mm")
    assert len(undercut) > 160  # was cut at 160 characters
    overlap = str(ds["reason"].sel(eccentricity_mm=1.5, pin_radius_mm=6.5, width_mm=12.0).values)
    assert "neighbouring pins interfere" in overlap
    assert int(ds["feasible"].sum()) == 2  # e = 1.5, ρp = 3.5, both widths
    assert ds.attrs["optimum_width_mm"] == 16.0


def test_swept_pin_radius_keeps_the_groove_clearance():
    task = DesignTask(
        TABLE1,
        Modification(),
        (("design.pin_radius", (4.0e-3,)), ("pin_radius", (5e-6,))),
        None,
        250.0,
        (0.0,),
    )
    design, modification = task.candidate(0)
    assert design.pin_radius == 4.0e-3 and modification.pin_radius == 5e-6
    assert design.groove_radius - design.pin_radius == pytest.approx(5e-6, abs=1e-15)
    assert task.modification(0) == modification


def test_robust_geometry_map_uses_the_same_rings_for_every_width():
    from dataclasses import replace

    errors = rings(8)
    ds = design_map(
        TABLE1,
        {"width_mm": [10.0, 14.0]},
        base=Modification(pin_radius=8e-6),
        errors=errors,
        crank_angles_deg=ANGLES,
    )
    assert ds.attrs["robust"] == 1 and ds.attrs["rings"] == 8
    wide = replace(TABLE1, width=14e-3)
    per_ring = candidate_metrics(wide, Modification(pin_radius=8e-6), errors, 250.0, PHI)
    assert float(ds["max_contact_stress_mpa"].sel(width_mm=14.0)) == pytest.approx(
        np.percentile(per_ring["max_contact_stress"], 95, method="higher") * 1e-6, rel=1e-14
    )
