"""``cyclomesh fe`` end to end on a coarse mesh (optional ``fe`` extra)."""

from __future__ import annotations

import json

import numpy as np
import pytest

try:  # the fe extra; gmsh's wheel also needs X11/OpenGL client libraries (see .ci/run)
    import gmsh  # noqa: F401
    import skfem  # noqa: F401
except (ImportError, OSError) as exc:
    pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)

import xarray as xr  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from cyclomesh.cli import app  # noqa: E402

STUDY = """
title = "FE coarse"
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
[fe]
crank_angles_deg = [0.0]
elements_per_half_width = 2.0
far_size_mm = 5.0
"""


def test_fe_writes_the_comparison_with_units_and_report(tmp_path):
    study = tmp_path / "fe.toml"
    study.write_text(STUDY + "[requirements]\nmax_contact_stress_mpa = 1500.0\n", encoding="utf-8")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["fe", str(study), "--out", str(out), "--no-convergence"])
    assert result.exit_code == 0, result.output
    ds = xr.load_dataset(out / "FE_coarse" / "fe.nc")
    assert ds["pin_load_fe"].dims == ("crank_angle", "pin")
    for name, units in (
        ("pin_load_fe", "N"),
        ("pin_load_ltca", "N"),
        ("contact_stress_fe", "MPa"),
        ("contact_stress_ltca", "MPa"),
        ("rotation_fe", "arcsec"),
        ("rotation_ltca", "arcsec"),
    ):
        assert ds[name].attrs["units"] == units
        assert np.all(np.isfinite(ds[name].values))
    assert ds.crank_angle.attrs["units"] == "deg"
    assert set(np.unique(ds["contact_stress_fe_resolved"].values)) <= {0, 1}
    fe, ltca = ds["pin_load_fe"].values, ds["pin_load_ltca_paper"].values
    assert np.all(fe >= 0)
    # the same torque through the same pins: the FE and LTCA peaks agree to a few 10 %
    assert 0.8 < fe.max() / ltca.max() < 1.2
    # a positive torque turns the disc back: negative in the TE convention, in both models
    assert float(ds["rotation_fe"][0]) < float(ds["rotation_ltca"][0]) < 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cases"][0]["fe_max_pin_load_n"] == pytest.approx(fe.max())
    # the FE study checks the requirements it computes: the peak stress of the FE model
    rows = {r["check"]: r for r in summary["cases"][0]["checks"]["rows"]}
    stress = rows["max_contact_stress_mpa"]
    assert stress["value"] == summary["cases"][0]["fe_max_contact_stress_mpa"]
    assert "FE model" in stress["note"] and "verdict" in result.output
    assert (out / "report.html").read_text().count("FE against LTCA") >= 1
    assert (out / "figures" / "fe_FE_coarse.png").stat().st_size > 0


def test_fe_refuses_pin_errors_in_one_line(tmp_path):
    study = tmp_path / "fe.toml"
    study.write_text(STUDY + "[errors]\nradial_um = 2.0\n", encoding="utf-8")
    result = CliRunner().invoke(app, ["fe", str(study), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "no pin errors" in result.output
    assert "Traceback" not in result.output
