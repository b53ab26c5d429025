"""[requirements]: verdicts, margins, defaults from the materials, design warnings."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.core.pair import TABLE1, Modification, PairDesign
from cyclomesh.results.requirements import (
    check_requirements,
    design_warnings,
    peak_stress_warning,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_margins_verdicts_and_what_is_not_computed():
    summary = {
        "max_contact_stress_mpa": [1200.0, 1600.0],  # a torque list: the worst counts
        "min_contacts": [7, 5],
        "te_pp_arcsec": 3.0,
        "play_arcsec_max": 45.0,
        "lost_motion_arcmin_max": 0.5,
        "drive_lost_motion_arcmin_max": 1.2,  # the whole drive wins over the mesh alone
    }
    limits = {
        "max_contact_stress_mpa": 1500.0,
        "min_contacts": 6,
        "max_te_pp_arcsec": 4.0,
        "max_play_arcmin": 1.0,
        "max_lost_motion_arcmin": 1.0,
        "min_torsional_rigidity_nm_per_arcmin": 100.0,
    }
    rows, unchecked = check_requirements(limits, summary, {"min_contacts": "a note"})
    by = {r["check"]: r for r in rows}
    assert unchecked == ["min_torsional_rigidity_nm_per_arcmin"]
    assert by["max_contact_stress_mpa"]["value"] == 1600.0
    assert by["max_contact_stress_mpa"]["margin"] == -100.0
    assert by["max_contact_stress_mpa"]["verdict"] == "fail"
    assert by["min_contacts"]["value"] == 5 and by["min_contacts"]["verdict"] == "fail"
    assert by["min_contacts"]["note"] == "a note"
    assert by["max_te_pp_arcsec"]["margin"] == 1.0
    assert by["max_te_pp_arcsec"]["margin_pct"] == 25.0
    assert by["max_play_arcmin"]["value"] == 0.75 and by["max_play_arcmin"]["verdict"] == "pass"
    assert by["max_lost_motion_arcmin"]["value"] == 1.2
    assert "whole drive" in by["max_lost_motion_arcmin"]["note"]
    # on the limit passes
    rows, _ = check_requirements({"max_te_pp_arcsec": 3.0}, summary)
    assert rows[0]["verdict"] == "pass" and rows[0]["margin"] == 0.0


def test_design_warnings_k1_and_undercut_margin():
    rows = {r["check"]: r for r in design_warnings(TABLE1, Modification())}
    assert rows["k1"]["value"] == pytest.approx(1.5 * 40 / 82)
    assert rows["k1"]["verdict"] == "ok"  # 0.732
    assert rows["undercut_margin"]["verdict"] == "ok"
    # K1 = 0.83: warned; the undercut margin shrinks as the teeth get pointed
    short = PairDesign(40, 82e-3, 3.5e-3, 3.505e-3, 1.7e-3, 12e-3)
    rows2 = {r["check"]: r for r in design_warnings(short, Modification())}
    assert rows2["k1"]["verdict"] == "warning" and rows2["k1"]["margin"] < 0
    assert rows2["undercut_margin"]["value"] < rows["undercut_margin"]["value"]
    # a larger pin radius, close to undercut, warns on the margin
    fat = PairDesign(40, 82e-3, 6.35e-3, 6.4e-3, 1.5e-3, 12e-3)
    rows3 = {r["check"]: r for r in design_warnings(fat, Modification())}
    assert 0 < rows3["undercut_margin"]["value"] < 0.1
    assert rows3["undercut_margin"]["verdict"] == "warning"


def test_peak_stress_on_a_sharp_convex_part_warns():
    stress = np.array([[100.0, 900.0], [200.0, 300.0]])
    ds = xr.Dataset(
        {
            "contact_stress": (("crank_angle", "pin"), stress),
            "curvature_radius": (("crank_angle", "pin"), np.array([[9.0, 2.0], [-5.0, 8.0]])),
        },
        coords={"crank_angle": [0.0, 1.0], "pin": [1, 2]},
    )
    row = peak_stress_warning(ds, 3.5)
    assert row["verdict"] == "warning" and row["value"] == 2.0
    assert "pin 2 at crank angle 0" in row["note"]
    ds["curvature_radius"][0, 1] = -4.0  # concave at the peak: no warning
    assert peak_stress_warning(ds, 3.5)["verdict"] == "ok"


def test_example_run_and_stiffness_show_the_verdict(tmp_path):
    runner = CliRunner()
    study = str(EXAMPLES / "requirements.toml")
    out = tmp_path / "run"
    result = runner.invoke(
        app, ["run", study, "-o", str(out), "--crank-step-deg", "5", "--figures", "none"]
    )
    assert result.exit_code == 0, result.output
    assert "verdict" in result.output and "FAIL" in result.output
    assert max(len(line) for line in result.output.splitlines()) <= 80
    (case,) = json.loads((out / "summary.json").read_text())["cases"]
    rows = {r["check"]: r for r in case["checks"]["rows"]}
    stress = rows["max_contact_stress_mpa"]
    assert stress["limit"] == 1500.0 and "GCr15" in stress["note"]  # the material's allowable
    assert stress["value"] == case["max_contact_stress_mpa"]
    assert stress["verdict"] == ("pass" if stress["value"] <= 1500 else "fail")
    assert rows["max_groove_stress_mpa"]["limit"] == 600.0  # nodular-iron ring
    assert rows["max_play_arcmin"]["value"] == pytest.approx(case["play_arcsec_max"] / 60)
    assert {"k1", "undercut_margin", "peak_stress_curvature"} <= set(rows)
    assert "max_lost_motion_arcmin" in case["checks"]["not_checked"]
    report = (out / "report.html").read_text()
    assert '<table class="verdict">' in report and "σH tooth [MPa]" in report
    out2 = tmp_path / "stiff"
    result = runner.invoke(
        app,
        ["stiffness", study, "-o", str(out2), "--crank-step-deg", "10", "--figures", "none"],
    )
    assert result.exit_code == 0, result.output
    (case,) = json.loads((out2 / "summary.json").read_text())["cases"]
    rows = {r["check"]: r for r in case["checks"]["rows"]}
    lost = rows["max_lost_motion_arcmin"]
    assert lost["value"] == case["drive_lost_motion_arcmin_max"] and lost["limit"] == 1.0
    rigid = rows["min_torsional_rigidity_nm_per_arcmin"]
    assert rigid["value"] == case["drive_torsional_rigidity_nm_per_arcmin_min"]
    assert "drive lost motion [arcmin]" in result.output


def test_bad_requirement_key_is_one_line(tmp_path):
    text = (
        (EXAMPLES / "requirements.toml")
        .read_text()
        .replace("max_play_arcmin = 1.0", "max_play_arcsec = 60.0")
    )
    path = tmp_path / "bad.toml"
    path.write_text(text)
    result = CliRunner().invoke(app, ["check", str(path)])
    assert result.exit_code == 2
    assert "requirements.max_play_arcsec: unknown key" in result.output


def test_tolerance_study_checks_at_the_stated_percentile(tmp_path):
    from cyclomesh.studies.tolerance import compute_tolerance
    from cyclomesh.studyfile import load_study

    path = tmp_path / "tol.toml"
    path.write_text(
        (EXAMPLES / "tolerance.toml").read_text()
        + "\n[requirements]\nmax_te_pp_arcsec = 12.0\nmin_contacts = 4\n"
        + "tolerance_percentile = 90.0\n"
    )
    result = compute_tolerance(load_study(path), rings=12)
    checks = result.summary["checks"]
    rows = {r["check"]: r for r in checks["rows"]}
    te = result.rings["te_pp_arcsec"].values
    contacts = result.rings["min_contacts"].values
    assert rows["max_te_pp_arcsec"]["value"] == pytest.approx(np.percentile(te, 90))
    assert rows["min_contacts"]["value"] == pytest.approx(np.percentile(contacts, 10))
    assert "P90 of 12 rings" in checks["values"]
    assert "max_lost_motion_arcmin" not in checks["not_checked"]  # not required


def test_stage_results_are_checked_before_the_mesh_alone():
    summary = {
        "lost_motion_arcmin_max": 0.4,  # the mesh alone
        "stage_lost_motion_arcmin_max": 0.9,  # the RV stage: mesh + crank bearings
        "stage_torsional_rigidity_nm_per_arcmin_min": 150.0,
        "torsional_rigidity_nm_per_arcmin_min": 2000.0,
        "stage_l10_h_min": 4000.0,
    }
    limits = {
        "max_lost_motion_arcmin": 1.0,
        "min_torsional_rigidity_nm_per_arcmin": 200.0,
        "min_bearing_life_h": 6000.0,
    }
    rows = {r["check"]: r for r in check_requirements(limits, summary)[0]}
    assert rows["max_lost_motion_arcmin"]["value"] == 0.9
    assert "stage: mesh + crank bearings" in rows["max_lost_motion_arcmin"]["note"]
    assert "reducer" in rows["min_torsional_rigidity_nm_per_arcmin"]["note"]
    assert rows["min_torsional_rigidity_nm_per_arcmin"]["verdict"] == "fail"
    assert rows["min_bearing_life_h"]["margin"] == -2000.0


def test_a_stage_row_names_the_parts_the_stage_modelled():
    """Issue 23: the rigidity row says what was checked. A stage with crankshafts and
    carrier must not say they are left out; the mesh alone names crank bearings and
    crankshafts as left out."""
    from types import SimpleNamespace

    from cyclomesh.results.requirements import stage_parts

    summary = {
        "stage_torsional_rigidity_nm_per_arcmin_min": 150.0,
        "torsional_rigidity_nm_per_arcmin_min": 2000.0,
    }
    limits = {"min_torsional_rigidity_nm_per_arcmin": 200.0}
    full = SimpleNamespace(bearing=object(), crankshaft=object(), carrier=object())
    parts = stage_parts(full, "fe")
    assert parts == ("crank bearings", "crankshafts", "carrier", "compliant disc")
    note = check_requirements(limits, summary, stage=parts)[0][0]["note"]
    assert "stage: mesh + crank bearings + crankshafts + carrier + compliant disc" in note
    assert "(main bearings, housing, first stage not included)" in note
    rigid = SimpleNamespace(bearing=None, crankshaft=None, carrier=None)
    note = check_requirements(limits, summary, stage=stage_parts(rigid))[0][0]["note"]
    assert note.startswith("stage: mesh;")
    assert "crank bearings, crankshafts, carrier not included" in note
    mesh = check_requirements(limits, {"torsional_rigidity_nm_per_arcmin_min": 2000.0})
    note = mesh[0][0]["note"]
    assert note.startswith("mesh alone") and "crank bearings, crankshafts not included" in note
