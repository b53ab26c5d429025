"""The one registry of result quantities (cyclomesh.quantities): every Dataset variable and
every summary key a study writes is a row, with the row's unit; one spelling per unit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh import TABLE1, Modification, PinErrors, analyse, stiffness, summarize
from cyclomesh.cli import app
from cyclomesh.quantities import QUANTITIES, REDUCTIONS, label, quantity

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
UNITS = {
    "1", "N", "MPa", "kN", "arcsec", "arcmin", "deg", "mm", "um", "N/um", "h", "rpm", "%",
    "N·m", "N·m/arcmin", "arcmin/kN·m", "urad", "", "W", "m/s",
}  # fmt: skip
"""The spellings of units in every output (one per unit: ``N·m``, never ``N m``)."""
NOT_QUANTITIES = {"name", "results", "checks", "warnings", "disc", "torque_nm", "crank_angle"}
"""Keys of a case in summary.json that are not numbers of a quantity (labels, file names,
the checks table, a case's torque and disc when a list is unrolled)."""
OTHER_UNIT = {("stiffness", "play")}
"""Known exception: the torsion curve's ``play`` is in arcmin, the run's in arcsec (the
registry row); kept so that the files of earlier versions read the same."""


def test_every_row_is_well_formed():
    for name, q in QUANTITIES.items():
        assert q.name == name
        assert q.unit in UNITS, f"{name}: unit {q.unit!r} is not one of the spellings"
        assert q.parity in (1, -1)
        assert q.long_name and q.label
        if q.reduce is not None:
            source, how = q.reduce
            assert source in QUANTITIES and how in REDUCTIONS, name
            assert QUANTITIES[source].dims, f"{name} reduces {source}, which has no dims"
    assert label("max_contact_stress_mpa").endswith("[MPa]")
    with pytest.raises(KeyError, match="QUANTITIES"):
        quantity("contacts_min")  # the old twin of min_contacts


def assert_rows(ds, kind: str) -> None:
    for name in ds.data_vars:
        assert name in QUANTITIES, f"{kind}: variable {name!r} is not a registry row"
        unit = ds[name].attrs.get("units", "")
        if (kind, name) not in OTHER_UNIT:
            assert unit == QUANTITIES[name].unit, f"{kind}: {name} in {unit!r}"


def test_every_variable_of_a_run_and_its_summary_is_a_row():
    errors = PinErrors(radial=np.linspace(-2e-6, 2e-6, 2 * TABLE1.pins).reshape(2, -1))
    ds = analyse(
        TABLE1,
        Modification(pin_radius=8e-6),
        errors,
        torque=[-250.0, 250.0],
        crank_angles_deg=np.arange(0.0, 18.0, 3.0),
        discs=2,
    )
    assert_rows(ds, "run")
    assert_rows(summarize(ds), "summary")


def test_every_variable_of_a_torsion_curve_is_a_row():
    ds = stiffness(
        TABLE1,
        Modification(pin_radius=8e-6),
        rated_torque=250.0,
        points=5,
        crank_angles_deg=[0.0, 4.5],
        discs=2,
        series_stiffness_nm_per_arcmin=100.0,
    )
    assert_rows(ds, "stiffness")


def test_every_variable_of_a_design_map_is_a_row():
    from cyclomesh import design_map

    ds = design_map(TABLE1, {"pin_radius_um": [0.0, 4.0]}, crank_angles_deg=[0.0, 4.5])
    assert_rows(ds, "design")


@pytest.fixture(scope="module")
def rv_stage(tmp_path_factory) -> Path:
    """The RV-40E example (two discs on three cranks, bearings) at a coarse crank step."""
    out = tmp_path_factory.mktemp("rv") / "out"
    result = CliRunner().invoke(
        app,
        ["run", str(EXAMPLES / "rv_stage.toml"), "--out", str(out), "--figures", "none"]
        + ["--crank-step-deg", "20"],
    )
    assert result.exit_code == 0, result.output
    return out


def test_every_summary_key_and_variable_of_a_stage_run_is_a_row(rv_stage):
    import xarray as xr

    summary = json.loads((rv_stage / "summary.json").read_text())
    for name, unit in summary["units"].items():
        assert name in QUANTITIES and QUANTITIES[name].unit == unit, (name, unit)
    for case in summary["cases"]:
        for key, value in case.items():
            if key in NOT_QUANTITIES:
                continue
            assert key in QUANTITIES, f"summary.json key {key!r} is not a registry row"
            if isinstance(value, dict):  # one quantity by part (compliance_share)
                assert all(isinstance(v, int | float) for v in value.values()), key
            else:
                assert isinstance(value, int | float | list | None), key
        with xr.open_dataset(rv_stage / case["results"]) as ds:
            assert_rows(ds.load(), "run")


def test_every_friction_variable_summary_key_and_loop_variable_is_a_row(tmp_path):
    """With [friction]: the run's friction variables and summary keys (power_loss_w a
    table path -> W), the torsion loop's variables (docs/efficiency.md)."""
    import xarray as xr

    out = tmp_path / "out"
    result = CliRunner().invoke(
        app,
        ["run", str(EXAMPLES / "efficiency.toml"), "--out", str(out), "--figures", "none"]
        + ["--crank-step-deg", "3"],
    )
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    for name, unit in summary["units"].items():
        assert name in QUANTITIES and QUANTITIES[name].unit == unit, (name, unit)
    for case in summary["cases"]:
        assert "efficiency" in case and "power_loss_w" in case
        for key, value in case.items():
            if key in NOT_QUANTITIES:
                continue
            assert key in QUANTITIES, f"summary.json key {key!r} is not a registry row"
            if key == "power_loss_w":
                assert all(isinstance(v, float | None) for v in value.values()), value
            else:
                assert isinstance(value, int | float | list | None), key
        with xr.open_dataset(out / case["results"]) as ds:
            assert "power_loss" in ds
            assert_rows(ds.load(), "run")
    from cyclomesh.core.friction import Friction

    ds = stiffness(
        TABLE1,
        Modification(pin_radius=8e-6),
        rated_torque=250.0,
        points=5,
        crank_angles_deg=[0.0, 4.5],
        friction=Friction(mesh=0.05, groove=0.05),
    )
    assert "hysteresis" in ds
    assert_rows(ds, "stiffness")
