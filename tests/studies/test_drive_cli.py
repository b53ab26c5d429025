"""End-to-end: ``cyclomesh stiffness`` on the example, and ``cyclomesh run`` on a stack."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.results.metrics import STIFFNESS_METRICS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

DESIGN = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
discs = 2
[modification]
pin_radius_um = 8.0
[analysis]
crank_step_deg = 10.0
"""


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


@pytest.fixture(scope="module")
def stiffness_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("stiffness") / "out"
    result = invoke(
        "stiffness", str(EXAMPLES / "stiffness.toml"), "--out", str(out), "--crank-step-deg", "10"
    )
    assert result.exit_code == 0, result.output
    assert "the mesh alone" in result.output
    return out


def test_stiffness_writes_curves_summary_and_report(stiffness_out):
    summary = json.loads((stiffness_out / "summary.json").read_text())
    names = [case["name"] for case in summary["cases"]]
    assert names == ["one disc", "two discs", "two discs, pin errors"]
    for case in summary["cases"]:
        for key in list(STIFFNESS_METRICS)[:6]:
            assert isinstance(case[key], float) and case[key] > 0, key
        assert case["drive_torsional_rigidity_nm_per_arcmin_mean"] < 113.0
        assert case["lost_motion_arcmin_mean"] >= case["play_arcmin_mean"]
        ds = xr.open_dataset(stiffness_out / case["results"])
        assert ds["rotation"].dims == ("torque", "crank_angle")
        assert ds.sizes["crank_angle"] == 36 and ds.sizes["torque"] == 42
        assert ds.attrs["case_name"] == case["name"]
        np.testing.assert_allclose(
            float(ds["torsional_rigidity"].mean()),
            case["torsional_rigidity_nm_per_arcmin_mean"],
            rtol=1e-12,
        )
        if case["discs"] == 2:
            share = ds["torque_share"].sel(torque=250.0)
            np.testing.assert_allclose(share.sum("disc"), 250.0, rtol=1e-10)
        ds.close()
    page = (stiffness_out / "report.html").read_text()
    assert "cycloid-pin mesh alone" in page
    assert page.count("data:image/png;base64,") == 4  # curve, rigidity, play, split
    for name in ("torsion_curve", "torsional_rigidity", "play", "torque_share"):
        assert (stiffness_out / "figures" / f"{name}.png").stat().st_size > 1000


def test_stiffness_without_section_is_refused_and_writes_nothing(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(DESIGN, encoding="utf-8")
    out = tmp_path / "out"
    result = invoke("stiffness", str(study), "--out", str(out))
    assert result.exit_code == 2
    assert "no [stiffness] section" in result.output
    assert not out.exists()


def test_run_with_torque_list_and_stack(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(DESIGN + "[load]\ntorque_nm = [-250.0, 250.0]\n", encoding="utf-8")
    out = tmp_path / "out"
    result = invoke("run", str(study), "--out", str(out), "--figures", "all")
    assert result.exit_code == 0, result.output
    record = json.loads((out / "summary.json").read_text())["cases"][0]
    assert record["torque_nm"] == [-250.0, 250.0]
    assert len(record["te_mean_arcsec"]) == 2
    assert record["te_mean_arcsec"][0] > 0 > record["te_mean_arcsec"][1]
    ds = xr.open_dataset(out / "s" / "results.nc")
    assert ds["pin_load"].dims == ("torque", "crank_angle", "disc", "pin")
    assert "torque_share" in ds and "play" in ds
    ds.close()
    assert (out / "figures" / "torque_share.png").exists()
    # angles.csv: one row per torque and crank angle, per-disc values in their own columns
    lines = (out / "s" / "angles.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:2] == ["torque_nm", "crank_angle_deg"] and len(lines) == 1 + 2 * 36
    for column in (
        "play_arcsec",
        "mesh_force_n_disc1",
        "mesh_force_n_disc2",
        "torque_share_nm_disc2",
    ):
        assert column in header, column
