"""Numbers a designer can trust (issue 14): a converged default law, stacks in every kind
of study, one rule for crank angles, a stated contacts threshold, a lost-motion
constraint and the mesh force of every map."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh import TABLE1, Modification, PinErrors
from cyclomesh.cli import app
from cyclomesh.core.ltca import CONTACT_LOAD_FRACTION, solve_ltca
from cyclomesh.designspace.sweep import Constraints, design_map
from cyclomesh.drive.solve import solve_drive
from cyclomesh.results.metrics import summary_metrics
from cyclomesh.studyfile.schema import load_study
from cyclomesh.units import RAD_PER_ARCMIN as ARCMIN

TPM = Modification(pin_radius=8e-6)
ARCSEC = np.pi / 648000


def headline(law: str, step_deg: float) -> np.ndarray:
    """Ratio ripple [%], TE p-p [arcsec], peak stress [MPa] over one mesh cycle (0-9°)."""
    phi = np.deg2rad(np.arange(0.0, 9.0, step_deg))
    r = solve_ltca(TABLE1, TPM, None, 250.0, phi, contact_law=law)
    m = summary_metrics(
        {
            "transmission_error": r.transmission_error / ARCSEC,
            "gear_ratio": r.gear_ratio,
            "contacts": r.contacts,
            "pin_load": r.pin_load,
            "groove_load": r.groove_load,
            "contact_stress": r.contact_stress * 1e-6,
            "groove_stress": r.groove_stress * 1e-6,
            "overlap": r.overlap / ARCSEC,
        },
        TABLE1.teeth,
    )
    return np.array(
        [m["gear_ratio_ripple_pct"], m["te_pp_arcsec"], m["max_contact_stress_mpa"]], float
    )


def test_default_law_is_converged_in_the_crank_step():
    """Halving the step from 0.01° to 0.005° moves ripple, TE p-p and peak stress < 1 %."""
    coarse = headline("half_plane", 0.01)
    fine = headline("half_plane", 0.005)
    assert np.all(np.abs(fine / coarse - 1.0) < 0.01), (coarse, fine)
    # ... where the paper's law is not: its ripple grows as the step shrinks
    paper_coarse, paper_fine = headline("paper", 0.01), headline("paper", 0.005)
    assert paper_fine[0] > 1.2 * paper_coarse[0]


def study_file(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


PAIR = """
title = "pair"
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[modification]
pin_radius_um = 8.0
[load]
torque_nm = 250.0
"""


def test_paper_law_warns_in_summary_cli_and_report(tmp_path):
    text = PAIR + '[analysis]\ncrank_stop_deg = 9.0\ncrank_step_deg = 1.0\ncontact_law = "{}"\n'
    runner = CliRunner()
    for law in ("paper", "half_plane"):
        out = tmp_path / law
        result = runner.invoke(
            app,
            [
                "run",
                str(study_file(tmp_path, text.format(law))),
                "--out",
                str(out),
                "--figures",
                "none",
            ],  # fmt: skip
        )
        assert result.exit_code == 0, result.output
        summary = json.loads((out / "summary.json").read_text())
        report = (out / "report.html").read_text()
        warned = "not converged in the crank step"
        if law == "paper":
            assert any(warned in w for w in summary["warnings"])
            assert any(warned in w for w in summary["cases"][0]["warnings"])
            assert "not" in result.output and "converged" in result.output
            assert warned in report
        else:
            assert summary["warnings"] == [] and warned not in report
            assert "warning" not in result.output


# --- contacts --------------------------------------------------------------------------


def test_contacts_count_pins_above_the_stated_threshold():
    """Unmodified pair: the pin at the tooth-space bottom (moment arm 0) touches with about
    1e-8 of the peak load and is not counted; every pin above 0.1 % of the peak is."""
    phi = np.deg2rad(np.arange(0.0, 9.0, 0.5))
    r = solve_ltca(TABLE1, Modification(), None, 250.0, phi)
    peak = r.pin_load.max(axis=-1, keepdims=True)
    touching = np.sum(r.pin_load > 0, axis=-1)
    above = np.sum(r.pin_load > CONTACT_LOAD_FRACTION * peak, axis=-1)
    np.testing.assert_array_equal(r.contacts, above)
    assert np.any(touching > r.contacts)  # a zero-arm pin carrying ~0 N is left out
    light = np.where(r.pin_load > 0, r.pin_load / peak, np.inf).min(axis=-1)
    assert np.all(light[touching > r.contacts] < 1e-6)
    # a stack counts per disc against the stack's peak pin load
    stack = solve_drive(TABLE1, TPM, None, 250.0, phi, discs=2)
    load = stack.pin_load[0]  # (A, N, n1)
    ref = load.max(axis=(-2, -1), keepdims=True)
    np.testing.assert_array_equal(stack.contacts[0], np.sum(load > 1e-3 * ref, axis=-1))


def test_contacts_attribute_states_the_threshold():
    from cyclomesh import analyse

    ds = analyse(TABLE1, TPM, crank_angles_deg=[0.0, 3.0])
    assert ds["contacts"].attrs["load_threshold_fraction"] == CONTACT_LOAD_FRACTION
    assert "0.1 %" in ds["contacts"].attrs["long_name"]


# --- disc stacks in design maps --------------------------------------------------------


def test_two_disc_map_at_t_equals_one_disc_map_at_half_t():
    """No pin errors, 40 pins: disc 2 (eccentric at φ + 180°) is disc 1 turned by 180°, so
    each carries T/2 and every per-disc metric equals the one-disc map's at T/2."""
    axes = {"pin_circle_radius_um": [-3.0, 0.0], "pin_radius_um": [6.0, 9.0]}
    angles = np.arange(0.0, 9.0, 1.5)
    kw = dict(crank_angles_deg=angles, base=TPM, lost_motion=True)
    one = design_map(TABLE1, axes, torque=125.0, **kw)
    two = design_map(TABLE1, axes, torque=250.0, discs=2, **kw)
    assert two.attrs["discs"] == 2 and one.attrs["discs"] == 1
    for name in ("max_contact_stress_mpa", "te_pp_arcsec", "min_contacts", "play_arcmin",
                 "min_play_arcmin", "max_mesh_force_n", "lost_motion_arcmin"):  # fmt: skip
        np.testing.assert_allclose(two[name].values, one[name].values, rtol=1e-9, err_msg=name)
    np.testing.assert_allclose(two["max_torque_share_nm"].values, 125.0, rtol=1e-9)
    np.testing.assert_allclose(two["min_torque_share_nm"].values, 125.0, rtol=1e-9)
    assert "max_torque_share_nm" not in one


def test_a_stack_map_with_pin_errors_reports_the_split():
    rng = np.random.default_rng(3)
    errors = PinErrors(radial=rng.uniform(-3e-6, 3e-6, 40), angular=rng.uniform(-3e-5, 3e-5, 40))
    ds = design_map(
        TABLE1, {"pin_radius_um": [8.0]}, errors=errors, torque=250.0, discs=2,
        crank_angles_deg=np.arange(0.0, 360.0, 10.0),
    )  # fmt: skip
    assert float(ds["max_torque_share_nm"][0]) > 130.0
    assert float(ds["min_torque_share_nm"][0]) < 120.0
    res = solve_drive(TABLE1, TPM, errors, 250.0, np.deg2rad(np.arange(0.0, 360.0, 10.0)),
                      discs=2)  # fmt: skip
    assert float(ds["max_mesh_force_n"][0]) == pytest.approx(res.mesh_force.max(), rel=1e-12)
    assert float(ds["max_contact_stress_mpa"][0]) == pytest.approx(
        res.contact_stress.max() * 1e-6, rel=1e-12
    )


def test_lost_motion_constraint():
    axes = {"pin_radius_um": [2.0, 6.0, 10.0]}
    free = design_map(TABLE1, axes, crank_angles_deg=[0.0, 3.0, 6.0], lost_motion=True)
    lost = free["lost_motion_arcmin"].values
    limit = float(np.median(lost))
    ds = design_map(
        TABLE1, axes, crank_angles_deg=[0.0, 3.0, 6.0],
        constraints=Constraints(max_lost_motion=limit * ARCMIN),
    )  # fmt: skip
    assert "lost_motion_arcmin" in ds  # computed because it is constrained
    np.testing.assert_array_equal(ds["feasible"].values == 1, lost <= limit)
    assert set(ds["reason"].values[lost > limit]) == {"max_lost_motion violated"}
    assert ds.attrs["max_lost_motion_arcmin"] == pytest.approx(limit)
    assert "max_mesh_force_n" in ds and np.all(ds["max_mesh_force_n"].values > 0)


DESIGN_STUDY = (
    PAIR
    + """
[analysis]
crank_stop_deg = 9.0
crank_step_deg = 1.5
[design_space]
pin_radius_um = {{ start = 6.0, stop = 10.0, points = 3 }}
allowable_contact_stress_mpa = {allowable}
max_lost_motion_arcmin = 5.0
"""
)


def test_design_cli_analyses_the_stack(tmp_path):
    runner = CliRunner()
    outs = {}
    for discs, torque in ((1, 125.0), (2, 250.0)):
        text = (
            DESIGN_STUDY.format(allowable=900.0)
            .replace("torque_nm = 250.0", f"torque_nm = {torque}")
            .replace("width_mm = 12.0", f"width_mm = 12.0\ndiscs = {discs}")
        )
        out = tmp_path / f"d{discs}"
        result = runner.invoke(
            app,
            [
                "design",
                str(study_file(tmp_path, text, f"d{discs}.toml")),
                "--out",
                str(out),
                "--figures",
                "none",
                "--quiet",
            ],  # fmt: skip
        )
        assert result.exit_code == 0, result.output
        outs[discs] = json.loads((out / "summary.json").read_text())
    assert outs[2]["discs"] == 2 and outs[2]["torque_nm"] == 250.0
    assert outs[2]["feasible_candidates"] == outs[1]["feasible_candidates"]
    assert outs[2]["optimum"]["parameters"] == outs[1]["optimum"]["parameters"]
    for name, value in outs[1]["optimum"]["metrics"].items():
        assert outs[2]["optimum"]["metrics"][name] == pytest.approx(value, rel=1e-9), name
    assert "lost_motion_arcmin" in outs[2]["optimum"]["metrics"]
    assert outs[2]["constraints"]["max_lost_motion_arcmin"] == 5.0


# --- disc stacks in tolerance and allocation studies ------------------------------------

TOLERANCE_STUDY = (
    PAIR
    + """
[design]
discs = 2
[tolerance]
seed = 5
rings = 6
allowable_contact_stress_mpa = 1500.0
crank_step_deg = 10.0
radial_um = {{ distribution = "uniform", half_range = {radial} }}
angular_urad = {{ distribution = "uniform", half_range = {angular} }}
[tolerance.allocation]
factor_max = 1.5
factor_steps = 3
bisections = 2
"""
)


def two_disc_study(tmp_path: Path, radial: float, angular: float) -> Path:
    text = (
        TOLERANCE_STUDY.format(radial=radial, angular=angular)
        .replace("[design]\ndiscs = 2\n", "")
        .replace("width_mm = 12.0", "width_mm = 12.0\ndiscs = 2")
    )
    return study_file(tmp_path, text, f"tol_{radial}.toml")


def test_two_disc_tolerance_study_reports_the_torque_split(tmp_path):
    from cyclomesh.studies.tolerance import compute_tolerance

    result = compute_tolerance(load_study(two_disc_study(tmp_path, 4.0, 50.0)))
    rings = result.rings
    assert result.summary["discs"] == 2
    low, high = rings["min_torque_share_nm"].values, rings["max_torque_share_nm"].values
    assert np.all(low < 125.0 - 1.0) and np.all(high > 125.0 + 1.0)  # not T/2
    assert np.all(low + high < 250.0 + 1e-6 + (high - low))  # shares of one total
    for name in ("min_torque_share_nm", "max_torque_share_nm", "max_mesh_force_n"):
        assert name in result.summary["metrics"]
        assert rings[name].attrs["units"] in ("N·m", "N")
    # the ring as a study file reruns (cyclomesh run) to the same numbers
    from cyclomesh.studies.run import compute_run
    from cyclomesh.studies.tolerance import worst_ring, worst_ring_study

    k = worst_ring(rings)
    text = worst_ring_study(result.model, result.study.base.model_dump(), k, "worst")
    run = compute_run(load_study(study_file(tmp_path, text, "worst.toml")))
    record = next(iter(run.summaries.values()))
    for name in ("max_contact_stress_mpa", "min_torque_share_nm", "max_torque_share_nm",
                 "max_mesh_force_n"):  # fmt: skip
        assert record[name] == float(rings[name].sel(ring=k)), name


def test_two_disc_tolerance_without_errors_shares_half_each(tmp_path):
    from cyclomesh.studies.tolerance import compute_tolerance

    result = compute_tolerance(load_study(two_disc_study(tmp_path, 0.0, 0.0)))
    np.testing.assert_allclose(result.rings["min_torque_share_nm"].values, 125.0, rtol=1e-9)
    np.testing.assert_allclose(result.rings["max_torque_share_nm"].values, 125.0, rtol=1e-9)


def test_two_disc_allocation_runs_on_the_stack(tmp_path):
    from cyclomesh.studies.allocate import compute_allocation
    from cyclomesh.studies.rings import ring_model

    study = load_study(two_disc_study(tmp_path, 4.0, 50.0))
    assert ring_model(study, study.tolerance).discs == 2
    result = compute_allocation(study)
    assert result.record["discs"] == 2
    assert 0.0 <= result.allocation.factor <= 1.5
    # the split and the mesh force at the stated tolerances, per ring and as statistics
    stats = result.record["at_stated_tolerances"]
    assert stats["min_torque_share_nm"]["max"] < 125.0 < stats["max_torque_share_nm"]["min"]
    assert stats["max_mesh_force_n"]["unit"] == "N"
    from cyclomesh.studies.tolerance import compute_tolerance

    same = compute_tolerance(study).rings  # the same rings, drawn once each
    for name in ("max_torque_share_nm", "max_mesh_force_n", "max_contact_stress_mpa"):
        np.testing.assert_array_equal(result.rings[name].values, same[name].values)


# --- one rule for crank angles ----------------------------------------------------------


def test_tolerance_crank_angles_fall_back_to_analysis(tmp_path):
    from cyclomesh.studies.tolerance import compute_tolerance, ring_model

    base = (
        PAIR
        + """
[analysis]
crank_step_deg = 10.0
[tolerance]
seed = 1
rings = 2
allowable_contact_stress_mpa = 2000.0
radial_um = { distribution = "uniform", half_range = 2.0 }
"""
    )
    study = load_study(study_file(tmp_path, base))
    model = ring_model(study, study.tolerance)
    np.testing.assert_array_equal(model.crank_angles_deg, np.arange(0.0, 360.0, 10.0))
    assert compute_tolerance(study).summary["warnings"] == []
    # a [tolerance] key overrides [analysis]'s; the others still fall back
    over = load_study(study_file(tmp_path, base + "crank_stop_deg = 90.0\n", "o.toml"))
    model = ring_model(over, over.tolerance)
    np.testing.assert_array_equal(model.crank_angles_deg, np.arange(0.0, 90.0, 10.0))
    warnings = compute_tolerance(over).summary["warnings"]
    assert any("cover 90°" in w for w in warnings)
    # a robust design map takes the same angles as the tolerance study
    from cyclomesh.studies.designmap import compute_design

    text = (
        base
        + "crank_stop_deg = 90.0\n"
        + """
[design_space]
pin_radius_um = { start = 8.0, stop = 8.0, points = 1 }
rings = 2
"""
    )
    result = compute_design(load_study(study_file(tmp_path, text, "d.toml")))
    assert result.map.attrs["crank_angles"] == 9
    assert any("cover 90°" in w for w in result.summary["warnings"])


def test_crank_range_errors_name_the_key(tmp_path):
    from cyclomesh.exceptions import StudyError
    from cyclomesh.studies.tolerance import ring_model

    text = (
        PAIR
        + """
[analysis]
crank_stop_deg = 30.0
[tolerance]
seed = 1
allowable_contact_stress_mpa = 2000.0
crank_start_deg = 40.0
"""
    )
    study = load_study(study_file(tmp_path, text))
    with pytest.raises(StudyError, match="tolerance.crank_stop_deg"):
        ring_model(study, study.tolerance)


def test_run_with_pin_errors_over_a_mesh_cycle_warns(tmp_path):
    from cyclomesh.studies.run import compute_run

    text = PAIR + "[analysis]\ncrank_stop_deg = 9.0\ncrank_step_deg = 3.0\n"
    nominal = compute_run(load_study(study_file(tmp_path, text)))
    assert nominal.study_warnings() == []  # a perfect ring: a mesh cycle is enough
    errors = text + "[errors]\nradial_um = 1.0\n"
    run = compute_run(load_study(study_file(tmp_path, errors, "e.toml")))
    assert any("cover 9°" in w for w in run.study_warnings())
