"""Friction through the study file: run, stiffness and cyclomesh efficiency end to end;
the one speed key."""

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile import load_study

PAIR = """
[design]
pins = 40
pin_circle_radius_mm = 82.0
pin_radius_mm = 3.5
groove_radius_mm = 3.505
eccentricity_mm = 1.5
width_mm = 12.0
[modification]
pin_radius_um = 8.0
[analysis]
crank_start_deg = 0.0
crank_stop_deg = 9.0
crank_step_deg = 3.0
"""
FRICTION = """
[friction]
mesh_coefficient = 0.08
groove_coefficient = 0.08
pins = "fixed"
bearing_coefficient = 0.0025
bearing_diameter_mm = 40.0
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text('title = "f"\n' + text)
    return path


def _invoke(*args: str) -> None:
    result = CliRunner().invoke(app, [*args, "--figures", "none", "--quiet"])
    assert result.exit_code == 0, result.output


def test_run_reports_efficiency_and_losses_with_units(tmp_path):
    path = _write(tmp_path, PAIR + FRICTION + "[load]\ninput_speed_rpm = 1000.0\n")
    _invoke("run", str(path), "--out", str(tmp_path / "out"))
    doc = json.loads((tmp_path / "out" / "summary.json").read_text())
    case = doc["cases"][0]
    assert 0.8 < case["efficiency"] < 1.0 and 0.8 < case["backdrive_efficiency"] < 1.0
    loss = case["power_loss_w"]
    assert loss["pin_tooth"] > 0 and loss["crank_bearings"] > 0 and loss["pin_groove"] == 0
    assert loss["output_mechanism"] is None
    total = sum(v for v in loss.values() if v is not None)
    assert case["input_power_w"] - case["output_power_w"] == pytest.approx(total, rel=1e-12)
    assert case["input_speed_rpm"] == 1000.0
    assert doc["units"]["power_loss_w"] == "W" and doc["units"]["efficiency"] == "1"
    import xarray as xr

    ds = xr.open_dataset(tmp_path / "out" / case["results"])
    for name in ("friction_force", "sliding_velocity_tooth", "power_loss_tooth"):
        assert ds[name].dims == ("crank_angle", "pin") and "units" in ds[name].attrs
    assert ds["instantaneous_efficiency"].dims == ("crank_angle",)


def test_stiffness_reports_the_loop(tmp_path):
    text = PAIR + FRICTION + "[stiffness]\nrated_torque_nm = 250.0\npoints = 5\n"
    _invoke("stiffness", str(_write(tmp_path, text)), "--out", str(tmp_path / "out"))
    case = json.loads((tmp_path / "out" / "summary.json").read_text())["cases"][0]
    assert case["hysteresis_arcmin_max"] > 0


def test_stiffness_takes_a_lubricant_at_rest_as_boundary_friction(tmp_path):
    """One file for run, efficiency and stiffness: at rest (no film) the lubricated
    coefficient is the boundary one, so the loop is that of the boundary coefficients
    alone, with a note naming the lubricant."""
    rolling = FRICTION.replace('"fixed"', '"rolling"')
    oil = "[friction.lubricant]\ngrade = 220\ntemperature_c = 60.0\n"
    text = PAIR + rolling + "[stiffness]\nrated_torque_nm = 250.0\npoints = 3\n"
    cases = []
    for name, extra in (("dry", ""), ("oil", oil)):
        (tmp_path / name).mkdir()
        path = _write(tmp_path / name, text + extra)
        _invoke("stiffness", str(path), "--out", str(tmp_path / name / "out"))
        doc = json.loads((tmp_path / name / "out" / "summary.json").read_text())
        cases.append(doc)
    dry, wet = (d["cases"][0] for d in cases)
    assert wet["hysteresis_arcmin_max"] == dry["hysteresis_arcmin_max"] > 0
    notes = json.dumps(cases[1]["warnings"]) + json.dumps(wet.get("warnings", []))
    assert "friction.lubricant" in notes and "boundary" in notes
    assert "friction.lubricant" not in json.dumps(cases[0]["warnings"]) + json.dumps(
        dry.get("warnings", [])
    )


def test_efficiency_map_end_to_end(tmp_path):
    text = (
        PAIR
        + FRICTION
        + """
[efficiency]
torque_nm = { start = 50.0, stop = 250.0, points = 3 }
input_speed_rpm = { start = 500.0, stop = 1500.0, points = 2 }
[requirements]
min_efficiency = 0.99
"""
    )
    out = tmp_path / "out"
    _invoke("efficiency", str(_write(tmp_path, text)), "--out", str(out))
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert 0.8 < case["rated_efficiency"] <= case["peak_efficiency"] < 1.0
    assert case["rated_torque_nm"] == 250.0 and case["rated_speed_rpm"] == 1500.0
    rows = {r["check"]: r for r in case["checks"]["rows"]}
    assert rows["min_efficiency"]["verdict"] == "fail"
    import xarray as xr

    ds = xr.open_dataset(out / case["results"])
    assert ds["efficiency"].dims == ("torque", "input_speed")
    assert ds["power_loss"].sizes["path"] == 3
    from cyclomesh.quantities import QUANTITIES  # every number a registry row, its unit

    units = json.loads((out / "summary.json").read_text())["units"]
    for key in case.keys() - {"name", "results", "checks"}:
        assert key in QUANTITIES and units[key] == QUANTITIES[key].unit, key
    for name in ds.data_vars:
        assert ds[name].attrs["units"] == QUANTITIES[name].unit, name


def test_efficiency_needs_friction_and_its_section(tmp_path):
    result = CliRunner().invoke(
        app, ["efficiency", str(_write(tmp_path, PAIR)), "--out", str(tmp_path / "o")]
    )
    assert result.exit_code == 2 and "[efficiency]" in result.output


def test_one_speed_key(tmp_path):
    stage = """
[design.disc]
crank_holes = 3
crank_hole_circle_radius_mm = 45.0
crank_hole_radius_mm = 10.0
[stage.crank_bearing]
rollers = 10
roller_diameter_mm = 4.0
roller_length_mm = 9.0
"""
    study = load_study(_write(tmp_path, PAIR + stage + "[load]\ninput_speed_rpm = 780.0\n"))
    assert study.inputs[0].stage.output_speed == pytest.approx(20.0)  # 780/39
    study = load_study(_write(tmp_path, PAIR + stage))
    assert study.inputs[0].stage.output_speed == 15.0  # the default, unchanged
    bad = PAIR + stage + "output_speed_rpm = 30.0\n[load]\ninput_speed_rpm = 780.0\n"
    bad = bad.replace(
        "[stage.crank_bearing]", "[stage]\noutput_speed_rpm = 30.0\n[stage.crank_bearing]"
    )
    bad = bad.replace("roller_length_mm = 9.0\noutput_speed_rpm = 30.0", "roller_length_mm = 9.0")
    with pytest.raises(StudyError, match="disagrees with load.input_speed_rpm"):
        load_study(_write(tmp_path, bad))


def test_friction_section_refusals(tmp_path):
    with pytest.raises(StudyError, match="bearing_diameter_mm"):
        load_study(_write(tmp_path, PAIR + "[friction]\nbearing_coefficient = 0.01\n"))
    lub = "[friction]\nmesh_coefficient = 0.1\ngroove_coefficient = 0.1\n[friction.lubricant]\n"
    with pytest.raises(StudyError, match="grade"):
        load_study(_write(tmp_path, PAIR + lub + "grade = 221\n"))
    with pytest.raises(StudyError, match="one of them"):
        load_study(_write(tmp_path, PAIR + lub + "temperature_c = 50.0\n"))
    with pytest.raises(StudyError, match="caps"):
        load_study(_write(tmp_path, PAIR + "[friction]\n[friction.lubricant]\ngrade = 220\n"))


@pytest.mark.parametrize(
    ("nu40", "nu100"),
    [(0.1, 0.05), (100.0, 200.0), (100.0, 100.0), (10.0, 1.0)],  # fmt: skip
)
def test_an_oil_outside_walthers_equation_is_refused_in_one_line(tmp_path, nu40, nu100):
    """Below 0.3 cSt log log(ν + 0.7) does not exist (a math domain error before); an oil
    that thickens as it warms makes no sense: both refused by the schema, exit 2."""
    oil = f"viscosity_40c_cst = {nu40}\nviscosity_100c_cst = {nu100}\n"
    lub = "[friction]\nmesh_coefficient = 0.1\ngroove_coefficient = 0.1\n[friction.lubricant]\n"
    path = _write(tmp_path, PAIR + lub + oil + "[load]\ninput_speed_rpm = 1000.0\n")
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "o"), "--quiet"])
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and "viscosity_100c_cst" in line and "Traceback" not in line
    assert not (tmp_path / "o" / "summary.json").exists()


def test_walther_refuses_an_oil_below_its_range():
    from cyclomesh.core.friction import Lubricant
    from cyclomesh.exceptions import DesignError

    with pytest.raises(DesignError, match="viscosity_100c_cst"):
        Lubricant(viscosity_40=0.1, viscosity_100=0.05)


ALLOCATION = """
[load]
torque_nm = 250.0
input_speed_rpm = 1000.0
[tolerance]
seed = 1
rings = 3
allowable_contact_stress_mpa = 1400.0
radial_um = { distribution = "uniform", half_range = 3.0 }
[tolerance.allocation]
factor_max = 1.5
factor_steps = 2
bisections = 1
"""


def test_allocate_takes_friction_in_the_equilibrium(tmp_path):
    """cyclomesh allocate with [friction]: the contact stress of its criterion comes from
    the solve with friction (the tangential forces change the torque balance, so the
    nominal stress moves), and the rings' efficiency at the stated tolerances is reported;
    frictionless, no efficiency is reported."""
    from cyclomesh.studies.allocate import compute_allocation

    records = {}
    for name, extra in (("dry", ""), ("friction", FRICTION)):
        (tmp_path / name).mkdir()
        study = load_study(_write(tmp_path / name, PAIR + ALLOCATION + extra))
        records[name] = compute_allocation(study).record
    dry, wet = records["dry"], records["friction"]
    assert "efficiency" not in dry["at_stated_tolerances"]
    eff = wet["at_stated_tolerances"]["efficiency"]
    assert 0.8 < eff["min"] <= eff["max"] < 1.0 and eff["unit"] == "1"
    assert wet["nominal_contact_stress_mpa"] != dry["nominal_contact_stress_mpa"]
    assert wet["nominal_contact_stress_mpa"] == pytest.approx(
        dry["nominal_contact_stress_mpa"], rel=0.05
    )


def test_allocate_with_friction_from_the_cli(tmp_path):
    path = _write(tmp_path, PAIR + ALLOCATION + FRICTION)
    _invoke("allocate", str(path), "--out", str(tmp_path / "out"))
    doc = json.loads((tmp_path / "out" / "allocation.json").read_text())
    assert "efficiency" in doc["at_stated_tolerances"]


def test_tolerance_figures_draw_the_efficiency_with_friction():
    """The rings' efficiency (a metric of the table with [friction]) has its histogram
    and ECDF too; without it the figures are those of before."""
    import numpy as np
    import xarray as xr

    from cyclomesh.figures.tolerance import plot_metric_histograms, reduce_rings

    rng = np.random.default_rng(1)
    stress = xr.DataArray(1500 + 100 * rng.standard_normal(50), dims="ring")
    dry = xr.Dataset({"max_contact_stress_mpa": stress})
    wet = dry.assign(efficiency=xr.DataArray(0.88 + 0.002 * rng.standard_normal(50), dims="ring"))
    assert "efficiency" not in reduce_rings(dry, 2000.0).histograms
    dist = reduce_rings(wet, 2000.0)
    counts, edges, _ = dist.histograms["efficiency"]
    assert counts.sum() == 50 and 0.85 < edges[0] < edges[-1] < 0.9
    assert "efficiency" in dist.ecdfs
    fig = plot_metric_histograms(dist, 2000.0)
    assert any("efficiency" in ax.get_xlabel() for ax in fig.axes)


TOLERANCE = """
[load]
torque_nm = 250.0
input_speed_rpm = 1000.0
[tolerance]
seed = 3
rings = 4
allowable_contact_stress_mpa = 2000.0
radial_um = { distribution = "uniform", half_range = 3.0 }
"""


def _tolerance(tmp_path: Path, text: str) -> dict:
    path = _write(tmp_path, text)
    _invoke("tolerance", str(path), "--out", str(tmp_path / "out"))
    return json.loads((tmp_path / "out" / "tolerance_summary.json").read_text())


def test_tolerance_backdrive_efficiency_only_when_required(tmp_path):
    """[requirements] min_backdrive_efficiency asks for a back-driven solve of every ring:
    its statistics and its check appear; without it, no second solve (no metric)."""
    import xarray as xr

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    plain = _tolerance(tmp_path / "a", PAIR + TOLERANCE + FRICTION)
    assert "efficiency" in plain["metrics"] and "backdrive_efficiency" not in plain["metrics"]
    req = "[requirements]\nmin_backdrive_efficiency = 0.5\n"
    asked = _tolerance(tmp_path / "b", PAIR + TOLERANCE + FRICTION + req)
    back = asked["metrics"]["backdrive_efficiency"]
    assert 0.5 < back["min"] <= back["max"] < 1.0
    # the forward metrics do not move with the second solve
    assert asked["metrics"]["efficiency"] == plain["metrics"]["efficiency"]
    rows = [r for r in asked["checks"]["rows"] if r["check"] == "min_backdrive_efficiency"]
    assert rows and rows[0]["verdict"] == "pass"
    rings = xr.open_dataset(tmp_path / "b" / "out" / "tolerance_rings.nc")
    assert rings["backdrive_efficiency"].attrs["units"] == "1"


def test_ring_backdrive_efficiency_is_the_runs(tmp_path):
    """A ring's back-driving efficiency is that of cyclomesh run on the same ring (its
    worst_ring.toml): the ring formula and the run's record agree."""
    import xarray as xr

    req = "[requirements]\nmin_backdrive_efficiency = 0.5\n"
    _tolerance(tmp_path, PAIR + TOLERANCE + FRICTION + req)
    rings = xr.open_dataset(tmp_path / "out" / "tolerance_rings.nc")
    worst = int(rings["ring"].values[int(np.argmax(rings["max_contact_stress_mpa"].values))])
    _invoke("run", str(tmp_path / "out" / "worst_ring.toml"), "--out", str(tmp_path / "run"))
    case = json.loads((tmp_path / "run" / "summary.json").read_text())["cases"][0]
    ring = rings.sel(ring=worst)
    assert float(ring["backdrive_efficiency"]) == pytest.approx(
        case["backdrive_efficiency"], rel=1e-9
    )
    assert float(ring["efficiency"]) == pytest.approx(case["efficiency"], rel=1e-9)


def test_run_checks_min_backdrive_efficiency(tmp_path):
    req = "[requirements]\nmin_backdrive_efficiency = 0.999\n"
    path = _write(tmp_path, PAIR + FRICTION + "[load]\ninput_speed_rpm = 1000.0\n" + req)
    result = CliRunner().invoke(
        app, ["run", str(path), "--out", str(tmp_path / "o"), "--figures", "none", "--quiet"]
    )
    case = json.loads((tmp_path / "o" / "summary.json").read_text())["cases"][0]
    rows = [r for r in case["checks"]["rows"] if r["check"] == "min_backdrive_efficiency"]
    assert rows[0]["value"] == case["backdrive_efficiency"] and rows[0]["verdict"] == "fail"
    assert rows[0]["margin"] == pytest.approx(case["backdrive_efficiency"] - 0.999)
    assert result.exit_code == 0, result.output  # a failed requirement is a verdict, no error


def test_run_with_zero_friction_says_it_is_frictionless(tmp_path):
    """All coefficients 0: the frictionless model, bit for bit the run without [friction],
    and a warning says why no efficiency is reported."""
    zero = "[friction]\nmesh_coefficient = 0.0\n"
    docs = []
    for name, extra in (("none", ""), ("zero", zero)):
        path = _write(tmp_path, PAIR + extra)
        _invoke("run", str(path), "--out", str(tmp_path / name))
        docs.append(json.loads((tmp_path / name / "summary.json").read_text()))
    plain, zeroed = docs
    assert "efficiency" not in zeroed["cases"][0]
    for key in ("te_pp_arcsec", "max_contact_stress_mpa", "max_pin_load_n"):
        assert zeroed["cases"][0][key] == plain["cases"][0][key]
    text = json.dumps(zeroed["warnings"]) + json.dumps(zeroed["cases"][0]["warnings"])
    assert "frictionless" in text and "frictionless" not in json.dumps(plain)


def test_run_report_shows_the_loss_table_readably(tmp_path):
    """The report's summary labels the friction numbers and writes the loss table as
    path: W, not as a Python dict."""
    path = _write(tmp_path, PAIR + FRICTION + "[load]\ninput_speed_rpm = 1000.0\n")
    _invoke("run", str(path), "--out", str(tmp_path / "out"))
    text = (tmp_path / "out" / "report.html").read_text()
    assert "{&#x27;" not in text and "{'" not in text
    assert "pin-tooth: " in text and "output-mechanism: not modelled" in text
    assert "P loss [W]" in text and "back-drive eff." in text
