"""``cyclomesh design``: end-to-end runs of a study's [design_space] (issue 9)."""

import json

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app

STUDY = """
title = "small design map"
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
[analysis]
crank_start_deg = 0.0
crank_stop_deg = 9.0
crank_step_deg = 1.0
[design_space]
pin_circle_radius_um = { start = -4.0, stop = 2.0, points = 4 }
pin_radius_um = { start = -1.0, stop = 9.0, points = 3 }
max_play_arcmin = 1.0
min_play_arcmin = 0.1
objective = "max_contact_stress"
"""

TOLERANCE = """
[tolerance]
seed = 7
allowable_contact_stress_mpa = 2000.0
radial_um = { distribution = "uniform", half_range = 2.0 }
angular_urad = { distribution = "uniform", half_range = 20.0 }
"""


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def write(tmp_path, text, name="study.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_design_writes_the_map_summary_figures_report_and_best(tmp_path):
    out = tmp_path / "out"
    result = invoke("design", write(tmp_path, STUDY), "--out", out)
    assert result.exit_code == 0, result.output
    assert "optimum:" in result.output
    ds = xr.open_dataset(out / "design.nc")
    assert ds["max_contact_stress_mpa"].dims == ("pin_circle_radius_um", "pin_radius_um")
    assert ds["play_arcmin"].attrs["units"] == "arcmin"
    # Δa = +2 µm with Δρ = −1 µm interferes: kept, infeasible, with the model's reason
    bad = ds.sel(pin_circle_radius_um=2.0, pin_radius_um=-1.0)
    assert int(bad["feasible"]) == 0 and "overlaps" in str(bad["reason"].values)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["candidates"] == 12 and summary["feasible_candidates"] == int(
        ds["feasible"].sum()
    )
    assert summary["failed_candidates"] >= 1
    for name in ("max_contact_stress_mpa", "te_pp_arcsec", "play_arcmin", "min_contacts"):
        assert (out / "figures" / f"design_{name}.png").stat().st_size > 1000
    report = (out / "report.html").read_text()
    assert "Design map" in report and "best.toml" in report

    # best.toml reruns to the same numbers
    rerun = invoke("run", out / "best.toml", "--out", tmp_path / "best")
    assert rerun.exit_code == 0, rerun.output
    ran = json.load(open(next((tmp_path / "best").rglob("summary.json"))))
    case = ran["cases"][0] if "cases" in ran else next(iter(ran.values()))
    optimum = summary["optimum"]["metrics"]
    assert case["max_contact_stress_mpa"] == pytest.approx(
        optimum["max_contact_stress_mpa"], rel=1e-12
    )
    assert case["te_pp_arcsec"] == pytest.approx(optimum["te_pp_arcsec"], rel=1e-9, abs=1e-9)
    assert case["min_contacts"] == optimum["min_contacts"]


def test_robust_design_is_the_same_on_one_and_two_processes(tmp_path):
    text = STUDY.replace('objective = "max_contact_stress"', 'objective = "play"\nrings = 4')
    text = text.replace("crank_step_deg = 1.0", "crank_step_deg = 3.0") + TOLERANCE
    path = write(tmp_path, text)
    one = invoke("design", path, "--out", tmp_path / "one", "--workers", 1, "-q")
    two = invoke("design", path, "--out", tmp_path / "two", "--workers", 2, "-q")
    assert one.exit_code == 0 and two.exit_code == 0, one.output + two.output
    a = xr.open_dataset(tmp_path / "one" / "design.nc")
    b = xr.open_dataset(tmp_path / "two" / "design.nc")
    assert a.attrs["robust"] == 1 and a.attrs["rings"] == 4
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values)
    best = (tmp_path / "one" / "best.toml").read_text()
    assert "[tolerance]" in best


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("points = 3", "points = 0"), "design_space.pin_radius_um.points"),
        (('objective = "max_contact_stress"', 'objective = "cost"'), "design_space.objective"),
        (("max_play_arcmin = 1.0", "max_play = 1.0"), "design_space.max_play"),
        ((", points = 3 }", " }"), "design_space.pin_radius_um.points"),
        (("max_play_arcmin = 1.0", "max_play_arcmin = true"), "design_space.max_play_arcmin"),
        (('objective = "max_contact_stress"', "rings = 5"), "needs a \\[tolerance\\] section"),
    ],
)
def test_bad_design_space_is_one_line_and_exit_2(tmp_path, change, message):
    path = write(tmp_path, STUDY.replace(*change))
    result = invoke("design", path, "--out", tmp_path / "out")
    assert result.exit_code == 2
    import re

    assert re.search(message, result.output), result.output
    assert result.output.count("\n") == 1


def test_study_without_design_space_is_refused(tmp_path):
    path = write(tmp_path, STUDY.split("[design_space]")[0])
    result = invoke("design", path, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "no [design_space] section" in result.output


def test_example_design_study_is_valid_and_marks_the_paper_tpm():
    from pathlib import Path

    from cyclomesh.studies.designmap import load_design_study

    study, space = load_design_study(Path(__file__).parents[2] / "examples" / "design.toml")
    axes = space.axes()
    assert list(axes) == ["pin_circle_radius_um", "pin_radius_um"]
    assert 8.0 in axes["pin_radius_um"] and 0.0 in axes["pin_circle_radius_um"]
    assert space.max_play_arcmin == 1.0
    assert study.base.modification.pin_radius_um == 8.0  # the paper's TPM, marked on the maps


def test_geometry_design_map_end_to_end(tmp_path):
    import tomllib

    study = STUDY.split("[design_space]")[0] + (
        "[design_space]\n"
        "pin_radius_mm = { start = 3.5, stop = 4.5, points = 3 }\n"
        "eccentricity_mm = { start = 1.5, stop = 2.0, points = 2 }\n"
        "max_play_arcmin = 2.0\n"
        "[requirements]\nmax_contact_stress_mpa = 900.0\n"
    )
    out = tmp_path / "out"
    result = invoke("design", write(tmp_path, study), "--out", out)
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "design.nc")
    assert set(ds["feasible"].dims) == {"pin_radius_mm", "eccentricity_mm"}
    reasons = ds["reason"].sel(eccentricity_mm=2.0).values
    assert all(
        r.startswith("undercut profile") and r.endswith("pin_circle_radius_mm")
        for r in reasons.ravel()
    )
    best = tomllib.loads((out / "best.toml").read_text())
    optimum = json.loads((out / "summary.json").read_text())["optimum"]["parameters"]
    assert best["design"]["pin_radius_mm"] == optimum["pin_radius_mm"]
    assert best["design"]["eccentricity_mm"] == optimum["eccentricity_mm"]
    assert best["design"]["groove_radius_mm"] == pytest.approx(optimum["pin_radius_mm"] + 0.005)
    assert "pin_radius_mm" not in best["modification"]
    summary = json.loads((out / "summary.json").read_text())
    rows = {r["check"]: r for r in summary["checks"]["rows"]}
    stress = summary["optimum"]["metrics"]["max_contact_stress_mpa"]
    assert rows["max_contact_stress_mpa"]["value"] == stress
    assert rows["max_contact_stress_mpa"]["verdict"] == ("pass" if stress <= 900 else "fail")
    e = optimum["eccentricity_mm"]
    assert rows["k1"]["value"] == pytest.approx(e * 40 / 82.0)  # the optimum's geometry
    assert "verdict" in result.output
    rerun = invoke("run", out / "best.toml", "--out", tmp_path / "best", "--figures", "none", "-q")
    assert rerun.exit_code == 0, rerun.output
