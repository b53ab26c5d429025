"""End-to-end: ``[stage]`` in ``cyclomesh run`` and ``cyclomesh stiffness`` (the RV stage)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


@pytest.fixture(scope="module")
def run_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rv") / "out"
    result = invoke(
        "run", str(EXAMPLE), "--out", str(out), "--crank-step-deg", "10", "--figures", "none"
    )
    assert result.exit_code == 0, result.output
    return out


def test_run_writes_bearing_loads_life_and_data_sheet(run_out):
    summary = json.loads((run_out / "summary.json").read_text())
    cases = {case["name"]: case for case in summary["cases"]}
    assert list(cases) == ["three crankshafts", "two crankshafts"]
    for case in cases.values():
        assert case["stage_rated_torque_nm"] == 412.0
        assert (
            case["stage_torsional_rigidity_nm_per_arcmin"]
            < case["mesh_torsional_rigidity_nm_per_arcmin"]
        )
        assert case["stage_lost_motion_arcmin"] > case["mesh_lost_motion_arcmin"]
        ds = xr.open_dataset(run_out / case["results"])
        load = ds["crank_bearing_load"]
        assert load.dims == ("crank_angle", "disc", "crank") and load.attrs["units"] == "N"
        assert ds.sizes["crank"] == (3 if case["name"] == "three crankshafts" else 2)
        assert ds["crank_bearing_l10"].attrs["units"] == "h"
        assert ds["disc_translation_x"].attrs["units"] == "um"
        # the run's torque is the rated torque: the sheet's weakest bearing is in the file
        assert case["stage_l10_h_min"] == pytest.approx(float(ds["crank_bearing_l10"].min()))
        assert np.all(np.isfinite(load.values))
    # three crankshafts share the load better than two
    assert (
        cases["three crankshafts"]["stage_l10_h_min"] > cases["two crankshafts"]["stage_l10_h_min"]
    )
    report = (run_out / "report.html").read_text()
    assert "Data sheet (RV stage)" in report


def test_stiffness_reports_the_stage_beside_the_mesh(tmp_path):
    out = tmp_path / "stiff"
    result = invoke(
        "stiffness", str(EXAMPLE), "--out", str(out), "--crank-step-deg", "30", "--figures", "none"
    )
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert (
        case["stage_torsional_rigidity_nm_per_arcmin_mean"]
        < case["torsional_rigidity_nm_per_arcmin_mean"]
    )
    assert case["stage_lost_motion_arcmin_mean"] > case["lost_motion_arcmin_mean"]
    ds = xr.open_dataset(out / case["results"])
    assert ds["stage_rotation"].dims == ("torque", "crank_angle")
    assert ds["crank_bearing_load"].dims == ("torque", "crank_angle", "stage_disc", "crank")
    from cyclomesh.figures.stage import plot_stage_torsion_curve

    fig = plot_stage_torsion_curve({"three": ds})
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) == 4  # mesh, stage, two axes lines


@pytest.mark.parametrize(
    "extra, message",
    [
        ("[stage]\ncrankshafts = 3\n", "give [design.disc] crank_holes"),
        ("[stage]\ncrank_circle_radius_mm = 36.0\n", "crank_hole_circle_radius_mm"),
    ],
)
def test_one_set_of_keys_for_the_crankshafts(tmp_path, extra, message):
    text = EXAMPLE.read_text().replace("[stage]\n", extra, 1)
    study = tmp_path / "s.toml"
    study.write_text(text)
    result = invoke("run", str(study), "--out", str(tmp_path / "o"))
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output


def test_stage_needs_the_crank_holes(tmp_path):
    text = EXAMPLE.read_text()
    start = text.index("[design.disc]")
    text = text[:start] + text[text.index("[modification]") :]
    text = text.replace("design.disc.crank_holes = 2\n", "")
    study = tmp_path / "s.toml"
    study.write_text(text)
    result = invoke("run", str(study), "--out", str(tmp_path / "o"))
    assert result.exit_code == 2
    assert "set [design.disc] crank_holes" in result.output


def test_one_disc_stage_and_its_figure(tmp_path):
    from cyclomesh.figures.stage import plot_crank_bearing_loads

    text = EXAMPLE.read_text().replace("discs = 2 ", "discs = 1 ")
    study = tmp_path / "s.toml"
    study.write_text(text[: text.index("[[cases]]")])
    out = tmp_path / "o"
    result = invoke(
        "run", str(study), "--out", str(out), "--crank-step-deg", "30", "--figures", "all"
    )
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    ds = xr.open_dataset(out / case["results"])
    assert ds["crank_bearing_load"].dims == ("crank_angle", "crank")
    assert "disc" not in ds.dims
    assert (out / "figures" / "crank_bearing_loads.png").exists()
    fig = plot_crank_bearing_loads({"one disc": ds})
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) == 3


STAGE_MAP = """
[design_space]
pin_radius_um = { start = 2.0, stop = 6.0, points = 3 }
max_stage_lost_motion_arcmin = 1.3
objective = "stage_rigidity"
"""


def _stage_map_study(tmp_path: Path, space: str) -> Path:
    text = EXAMPLE.read_text()
    text = text[: text.index("[[cases]]")]
    text = text.replace("crank_step_deg = 1.0", "crank_start_deg = 0.0\ncrank_stop_deg = 6.0\n"
                        "crank_step_deg = 3.0")  # fmt: skip
    study = tmp_path / "map.toml"
    study.write_text(text + space)
    return study


def test_design_map_with_the_stage_metrics(tmp_path):
    from cyclomesh.core.case import Case, Model
    from cyclomesh.core.pair import Modification
    from cyclomesh.stage.solve import bearing_life, stage_torsion
    from cyclomesh.studyfile.schema import load_study

    study = _stage_map_study(tmp_path, STAGE_MAP)
    out = tmp_path / "out"
    result = invoke("design", str(study), "--out", str(out), "--figures", "none")
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "design.nc")
    rig = ds["stage_torsional_rigidity_nm_per_arcmin_min"]
    assert rig.attrs["units"] == "N·m/arcmin"
    assert ds["stage_l10_h_min"].attrs["units"] == "h"
    assert ds["stage_lost_motion_arcmin_max"].attrs["units"] == "arcmin"
    # the optimum is the stiffest feasible candidate (a maximised objective)
    feasible = ds["feasible"].values.astype(bool)
    assert feasible.any()
    best = float(ds.attrs["optimum_pin_radius_um"])
    assert float(rig.sel(pin_radius_um=best)) == np.max(rig.values[feasible])
    lost = ds["stage_lost_motion_arcmin_max"].values
    assert np.array_equal(feasible, lost <= 1.3)
    # each metric is the stage's own torsion curve and life, recomputed for a candidate
    base = load_study(study).base
    inputs = base.to_core()
    dr = 4.0
    curve = stage_torsion(
        Case(
            inputs.design,
            Modification(pin_radius=dr * 1e-6),
            None,
            412.0,
            np.deg2rad(base.analysis.crank_angles_deg()),
        ),
        Model("half_plane", True, "rigid", 2, inputs.stage),
        points=2,
    )
    arcmin = np.pi / (180 * 60)
    cell = ds.sel(pin_radius_um=dr)
    assert float(cell["stage_torsional_rigidity_nm_per_arcmin_min"]) == pytest.approx(
        np.min(curve.torsional_rigidity) * arcmin, rel=1e-12
    )
    assert float(cell["stage_lost_motion_arcmin_max"]) == pytest.approx(
        np.max(curve.lost_motion) / arcmin, rel=1e-12
    )
    at = int(np.flatnonzero(curve.stage.torque == 412.0)[0])
    hours = bearing_life(curve.stage, inputs.stage, 40)[2][at]
    assert float(cell["stage_l10_h_min"]) == pytest.approx(np.min(hours), rel=1e-12)
    # more play (a larger Δρ) costs lost motion
    assert np.all(np.diff(lost) > 0)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["constraints"] == {"max_stage_lost_motion_arcmin": 1.3}
    assert "[stage.crank_bearing]" in (out / "best.toml").read_text()


def test_design_map_stage_limits_and_refusals(tmp_path):
    space = STAGE_MAP.replace("max_stage_lost_motion_arcmin = 1.3", "min_stage_l10_h = 1e9")
    out = tmp_path / "out"
    result = invoke(
        "design", str(_stage_map_study(tmp_path, space)), "--out", str(out), "--figures", "none"
    )
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "design.nc")
    assert not ds["feasible"].values.any()
    assert set(ds["reason"].values.tolist()) == {"min_stage_l10 violated"}
    # a stage objective without [stage]: one line, exit 2
    text = (Path(__file__).resolve().parents[1] / "studies" / "test_design_cli.py").read_text()
    plain = text[text.index('title = "small'): text.index('objective = "max')]  # fmt: skip
    study = tmp_path / "plain.toml"
    study.write_text(plain + 'objective = "stage_l10"\n')
    result = invoke("design", str(study), "--out", str(tmp_path / "o2"))
    assert result.exit_code == 2, result.output
    assert "needs the RV stage: add [stage]" in result.output


@pytest.mark.parametrize(
    "errors, warned",
    [
        ("hole_error_radial_um = [0.0, 4.0, 0.0]\n", True),  # > 2.5 µm left after the pose
        ("hole_error_radial_um = [0.0, 1.0, 0.0]\n", False),  # within the free travel
        ("hole_error_tangential_um = 8.0\n", False),  # only turns the disc
    ],
)
def test_hole_errors_beyond_the_clearance_are_warned(tmp_path, errors, warned):
    text = EXAMPLE.read_text()
    text = text[: text.index("[[cases]]")].replace(
        "rated_torque_nm = 412.0\n", "rated_torque_nm = 412.0\n" + errors, 1
    )
    text = text.replace("crank_step_deg = 1.0", "crank_step_deg = 30.0")
    study = tmp_path / "s.toml"
    study.write_text(text)
    out = tmp_path / "o"
    result = invoke("run", str(study), "--out", str(out), "--figures", "none")
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    text = " ".join(summary["warnings"])
    assert ("preloaded at zero torque" in text) is warned
    assert ("preloaded at zero torque" in " ".join(result.output.split())) is warned
    if warned:  # the base's hole errors in a tolerance study too
        study.write_text(study.read_text() + STAGE_TOLERANCE.replace("rings = 4", "rings = 1"))
        out = tmp_path / "t"
        result = invoke("tolerance", str(study), "--out", str(out), "--figures", "none")
        assert result.exit_code == 0, result.output
        summary = json.loads((out / "tolerance_summary.json").read_text())
        assert "preloaded at zero torque" in " ".join(summary["warnings"])


STAGE_TOLERANCE = """
[tolerance]
seed = 3
rings = 4
allowable_contact_stress_mpa = 1850.0
crank_step_deg = 10.0
radial_um = { distribution = "uniform", half_range = 2.0 }
angular_urad = { distribution = "uniform", half_range = 20.0 }
hole_radial_um = { distribution = "uniform", half_range = 3.0 }
hole_tangential_um = { distribution = "normal", sigma = 2.0 }

[tolerance.allocation]
factor_max = 2.0
factor_steps = 2
bisections = 1
"""


def _stage_tolerance_study(tmp_path: Path, extra: str = STAGE_TOLERANCE) -> Path:
    text = EXAMPLE.read_text()
    study = tmp_path / "tol.toml"
    study.write_text(text[: text.index("[[cases]]")] + extra)
    return study


def test_tolerance_with_the_stage_draws_hole_errors_and_reports_the_bearings(tmp_path):
    study = _stage_tolerance_study(tmp_path)
    out = tmp_path / "out"
    result = invoke("tolerance", str(study), "--out", str(out), "--figures", "none")
    assert result.exit_code == 0, result.output
    assert "stage: weakest ring" in " ".join(result.output.split())
    ds = xr.open_dataset(out / "tolerance_rings.nc")
    units = {
        "stage_l10_h_min": "h",
        "stage_lost_motion_arcmin_max": "arcmin",
        "stage_max_crank_bearing_load_n": "N",
        "stage_max_contact_stress_mpa": "MPa",
    }
    for name, unit in units.items():
        assert ds[name].attrs["units"] == unit
        assert np.all(np.isfinite(ds[name].values)) and np.all(ds[name].values > 0)
    summary = json.loads((out / "tolerance_summary.json").read_text())
    loads = summary["metrics"]["stage_max_crank_bearing_load_n"]
    assert [p["percent"] for p in loads["percentiles"]][:3] == [5.0, 50.0, 95.0]
    weakest = summary["stage_worst_ring"]
    life = ds["stage_l10_h_min"].values
    assert weakest["stage_l10_h_min"] == np.min(life)
    assert weakest["ring"] == int(ds["ring"].values[np.argmin(life)])
    # the worst ring's study file reruns the ring: its hole errors and pin errors
    # are written bit for bit, so cyclomesh run gives the same stage numbers
    k = summary["worst_ring"]["ring"]
    rerun = tmp_path / "rerun"
    result = invoke("run", str(out / "worst_ring.toml"), "--out", str(rerun), "--figures", "none")
    assert result.exit_code == 0, result.output
    case = json.loads((rerun / "summary.json").read_text())["cases"][0]
    for name in units:
        assert case[name] == float(ds[name].sel(ring=k)), name
    # hole errors move the stage's numbers (not the mesh's on rigid bearings)
    plain = _stage_tolerance_study(
        tmp_path, "".join(
            line + "\n" for line in STAGE_TOLERANCE.splitlines() if not line.startswith("hole_")
        )
    )  # fmt: skip
    out2 = tmp_path / "plain"
    assert invoke("tolerance", str(plain), "--out", str(out2), "--figures", "none").exit_code == 0
    ds2 = xr.open_dataset(out2 / "tolerance_rings.nc")
    np.testing.assert_array_equal(
        ds2["max_contact_stress_mpa"].values, ds["max_contact_stress_mpa"].values
    )
    assert not np.array_equal(ds2["stage_l10_h_min"].values, life)


def test_allocation_with_the_stage_scales_the_hole_errors_too(tmp_path):
    out = tmp_path / "out"
    result = invoke(
        "allocate", str(_stage_tolerance_study(tmp_path)), "--out", str(out), "--figures", "none"
    )
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "allocation_rings.nc")
    assert "stage_max_contact_stress_mpa" in ds and "stage_l10_h_min" in ds
    # the criterion is the stage's stress: a ring not exceeding at f = 1 has f* > 1
    above = ds["stage_max_contact_stress_mpa"].values > 1850.0
    assert np.all(ds["critical_factor_upper"].values[above] <= 1.0)
    assert np.all(ds["critical_factor_lower"].values[~above] >= 1.0)


def test_hole_tolerances_need_the_stage(tmp_path):
    text = EXAMPLE.read_text()
    start = text.index("[stage]")
    study = tmp_path / "s.toml"
    body = text[:start].replace("[design.disc]", "[design.disc_unused]")
    body = body[: body.index("[design.disc_unused]")] + body[body.index("[modification]") :]
    study.write_text(body + STAGE_TOLERANCE)
    result = invoke("tolerance", str(study), "--out", str(tmp_path / "o"))
    assert result.exit_code == 2, result.output
    assert "crank hole errors need the RV stage" in " ".join(result.output.split())


def test_stage_rings_do_not_depend_on_their_chunk(tmp_path):
    """Ring k's stage metrics depend on (seed, k) alone: each ring's stage is solved on
    its own, so chunks of 1 and of 3 rings give the same bits."""
    from cyclomesh.studies.tolerance import compute_tolerance
    from cyclomesh.studyfile.schema import load_study

    study = load_study(
        _stage_tolerance_study(
            tmp_path, STAGE_TOLERANCE.replace("crank_step_deg = 10.0", "crank_step_deg = 30.0")
        )
    )
    one = compute_tolerance(study, rings=4, chunk_rings=1).rings
    three = compute_tolerance(study, rings=4, chunk_rings=3).rings
    for name in one.data_vars:
        np.testing.assert_array_equal(one[name].values, three[name].values, strict=True)
    assert "stage_l10_h_min" in one


def test_tolerance_with_the_stage_checks_its_requirements_on_the_percentiles(tmp_path):
    extra = STAGE_TOLERANCE.replace("crank_step_deg = 10.0", "crank_step_deg = 30.0")
    extra += "\n[requirements]\nmin_bearing_life_h = 6000.0\nmax_lost_motion_arcmin = 1.0\n"
    out = tmp_path / "out"
    study = _stage_tolerance_study(tmp_path, extra)
    result = invoke("tolerance", str(study), "--out", str(out), "--figures", "none")
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "tolerance_summary.json").read_text())
    ds = xr.open_dataset(out / "tolerance_rings.nc")
    rows = {row["check"]: row for row in summary["checks"]["rows"]}
    # a lower limit on P5 of the rings, an upper one on P95 (requirements.tolerance_percentile)
    assert rows["min_bearing_life_h"]["value"] == pytest.approx(
        np.percentile(ds["stage_l10_h_min"].values, 5.0), rel=1e-12
    )
    assert rows["max_lost_motion_arcmin"]["value"] == pytest.approx(
        np.percentile(ds["stage_lost_motion_arcmin_max"].values, 95.0), rel=1e-12
    )


FRICTION_EXAMPLE = EXAMPLE.with_name("rv_stage_friction.toml")


def test_run_and_stiffness_with_friction_in_the_stage(tmp_path):
    """``examples/rv_stage_friction.toml`` end to end: the run reports the stage's
    efficiency and loss split (the crank bearings included) and the stiffness study the
    stage's friction loop, whose branches straddle the mid curve."""
    out = tmp_path / "run"
    result = invoke("run", str(FRICTION_EXAMPLE), "--out", str(out), "--crank-step-deg", "20",
                    "--figures", "none")  # fmt: skip
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert 0.8 < case["backdrive_efficiency"] < 1.0 and 0.8 < case["efficiency"] < 1.0
    loss = case["power_loss_w"]
    assert loss["crank_bearings"] > 0 and loss["pin_groove"] > 0
    assert case["input_power_w"] == pytest.approx(
        case["output_power_w"] + loss["pin_tooth"] + loss["pin_groove"] + loss["crank_bearings"]
    )
    ds = xr.open_dataset(out / case["results"])
    # the power from the crank pins' forces closes on the losses (the approach power's
    # mean over the angles aside, a few per mille here at 20° steps)
    moment = float(ds["moment_input_power"].mean())
    assert moment == pytest.approx(case["input_power_w"], rel=2e-2)
    assert ds["power_loss_bearing"].attrs["units"] == "W"
    out = tmp_path / "stiff"
    result = invoke("stiffness", str(FRICTION_EXAMPLE), "--out", str(out), "--crank-step-deg",
                    "20", "--figures", "none")  # fmt: skip
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert case["stage_hysteresis_arcmin_max"] > case["stage_hysteresis_arcmin_mean"] > 0
    ds = xr.open_dataset(out / case["results"])
    up, down = ds["stage_rotation_ascending"], ds["stage_rotation_descending"]
    assert float((up - down).min()) >= 0.0  # rising: friction helps hold the output
    mid = 0.5 * (up + down)
    np.testing.assert_allclose(mid.values, ds["stage_rotation"].values, rtol=1e-12)


def test_run_with_a_lubricant_in_the_stage(tmp_path):
    """The friction example with a lubricant and a higher boundary cap at 1500 rpm: the run
    writes the film parameter (units 1, > 0 where a pin carries load) and its summary
    keys, the lubricated coefficient stays below the cap, and the power balance holds;
    the stiffness study takes the boundary coefficients (at rest) and says so."""
    text = FRICTION_EXAMPLE.read_text(encoding="utf-8")
    text = text.replace("mesh_coefficient = 0.05", "mesh_coefficient = 0.12")
    text = text.replace("groove_coefficient = 0.05", "groove_coefficient = 0.12")
    text = text.replace(
        "[stage]\n",
        "[friction.lubricant]\ngrade = 150\ntemperature_c = 70.0\nroughness_um = 0.1\n"
        "composite_roughness_um = 0.15\n\n[stage]\n",
        1,
    )
    text = text.replace("input_speed_rpm = 585.0", "input_speed_rpm = 1500.0")
    text = text.replace("output_speed_rpm = 15.0", "# output_speed_rpm = 15.0")  # the load's
    study = tmp_path / "lubricated.toml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "run"
    result = invoke("run", str(study), "--out", str(out), "--crank-step-deg", "20",
                    "--figures", "none")  # fmt: skip
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert 0 < case["film_parameter_min"] <= case["film_parameter_mean"]
    loss = case["power_loss_w"]
    assert case["input_power_w"] == pytest.approx(
        case["output_power_w"] + loss["pin_tooth"] + loss["pin_groove"] + loss["crank_bearings"]
    )
    ds = xr.open_dataset(out / case["results"])
    on = ds["pin_load"] > 0
    assert ds["film_parameter"].attrs["units"] == "1"
    assert float(ds["film_parameter"].where(on).min()) > 0
    assert float(ds["friction_coefficient"].where(on).max()) < 0.12
    out = tmp_path / "stiff"
    result = invoke("stiffness", str(study), "--out", str(out), "--crank-step-deg", "30",
                    "--figures", "none")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "at rest" in " ".join(result.output.split())


def test_run_with_stage_reports_the_stages_mesh(tmp_path):
    """Issue 23: with [stage], the σH verdict, the summary (TE p-p, pin loads), angles.csv
    and the figures are those of the stage solve, not of the mesh on rigid bearings
    (whose TE is kept as rigid_bearing_transmission_error)."""
    text = EXAMPLE.read_text(encoding="utf-8").replace(
        "[stage]\n", "[requirements]\nmax_contact_stress_mpa = 1500.0\n\n[stage]\n", 1
    )
    study = tmp_path / "stage.toml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    result = invoke("run", str(study), "--out", str(out), "--crank-step-deg", "10")
    assert result.exit_code == 0, result.output
    assert (out / "figures" / "overview.png").is_file()
    summary = json.loads((out / "summary.json").read_text())
    for case in summary["cases"]:
        ds = xr.open_dataset(out / case["results"])
        stage_te = ds["stage_transmission_error"].values
        rigid_te = ds["rigid_bearing_transmission_error"].values
        assert np.ptp(stage_te) != pytest.approx(np.ptp(rigid_te), rel=0.05)
        assert case["te_pp_arcsec"] == pytest.approx(np.ptp(stage_te), rel=1e-12)
        assert case["max_pin_load_n"] == pytest.approx(float(ds["stage_pin_load"].max()))
        assert case["max_contact_stress_mpa"] == pytest.approx(
            float(ds["stage_contact_stress"].max())
            if "stage_contact_stress" in ds
            else float(ds["contact_stress"].max())
        )
        np.testing.assert_allclose(ds["transmission_error"].values, stage_te, rtol=1e-12)
        np.testing.assert_allclose(ds["pin_load"].values, ds["stage_pin_load"].values)
        angles = np.genfromtxt(
            out / Path(case["results"]).parent / "angles.csv",
            delimiter=",",
            names=True,
            comments="#",
        )
        np.testing.assert_allclose(angles["transmission_error_arcsec"], stage_te, rtol=1e-9)
        rows = {row["check"]: row for row in case["checks"]["rows"]}
        assert rows["max_contact_stress_mpa"]["value"] == case["max_contact_stress_mpa"]


def _without(text: str, *sections: str) -> str:
    """The study text without the given [sections] (header to the next header)."""
    for section in sections:
        i = text.index("\n" + section) + 1
        text = text[:i] + text[text.index("\n[", i + 1) + 1 :]
    return text


@pytest.mark.parametrize(
    "errors", ["radial_um = 3.0", "radial_um = 2.0\nangular_urad = 50.0"], ids=["3um", "2um50urad"]
)
@pytest.mark.parametrize("bearings", ["clearance", "rigid"])
def test_the_stage_solves_a_real_ring(tmp_path, errors, bearings):
    """Issue 23: the RV example with realistic pin errors ([errors.random] seed = 1,
    ±3 µm radial; ±2 µm with ±50 µrad) failed with "internal error (LinAlgError:
    Singular matrix)", with rigid bearings and with clearance. At 2° (the unloaded disc
    of seed 1 near 138° included) run and stiffness give finite stage numbers, and the
    errors move them off the perfect ring's."""
    text = EXAMPLE.read_text(encoding="utf-8")
    text = text[: text.index('\n[[cases]]\nname = "two crankshafts"')] + "\n"
    if bearings == "rigid":
        text = _without(
            text,
            "[stage.crankshaft]",
            "[stage.carrier]",
            "[stage.duty_cycle]",
            "[stage.crank_bearing]",
        )
    text = text.replace("[stage]\n", f"[errors.random]\nseed = 1\n{errors}\n\n[stage]\n", 1)
    study = tmp_path / "ring.toml"
    study.write_text(text, encoding="utf-8")
    values = {}
    for command in ("run", "stiffness"):
        out = tmp_path / command
        result = invoke(
            command, str(study), "--out", str(out), "--crank-step-deg", "2", "--figures", "none"
        )
        assert result.exit_code == 0, result.output
        (case,) = json.loads((out / "summary.json").read_text())["cases"]
        for key in ("stage_lost_motion_arcmin_max", "stage_torsional_rigidity_nm_per_arcmin_min"):
            assert np.isfinite(case[key]) and case[key] > 0
            values.setdefault(key, []).append(case[key])
        if command == "run":
            ds = xr.open_dataset(out / case["results"])
            assert np.all(np.isfinite(ds["stage_pin_load"].values))
            assert np.ptp(ds["stage_transmission_error"].values) > 0
            assert np.any(ds["pin_radial_error"].values != 0)
            if bearings == "clearance":
                assert np.all(np.isfinite(ds["crank_bearing_load"].values))
    for key, (run, stiffness) in values.items():  # one definition in both commands
        assert run == pytest.approx(stiffness, rel=1e-9), key


def test_the_stage_words_and_units_in_terminal_and_report(tmp_path):
    """Issue 23, units and words: Rich markup kept "[stage]" ("the RV stage of  (mesh +
    crank bearings)" had lost it); stiffness says "the mesh alone" only of the mesh rows,
    not above the stage's; play in arcmin in the terminal, the verdict and the report's
    summary (arcsec there before); the undercut margin without a per cent of its
    rule-of-thumb threshold."""
    outputs = {}
    for command in ("run", "stiffness"):
        out = tmp_path / command
        result = invoke(
            command, str(EXAMPLE), "--out", str(out), "--crank-step-deg", "30", "--figures", "none"
        )
        assert result.exit_code == 0, result.output
        outputs[command] = (" ".join(result.output.split()), out)
    run_text, run_out = outputs["run"]
    assert "with [stage]: loads, stresses, TE and contacts are those of the RV stage" in run_text
    assert "max play [arcmin]" in run_text and "play [arcsec]" not in run_text
    stiff_text, _ = outputs["stiffness"]
    assert "stage rows: the RV stage of [stage] (mesh, crank bearings" in stiff_text
    assert "the mesh alone: crank bearings" not in stiff_text
    report = (run_out / "report.html").read_text(encoding="utf-8")
    assert "play [arcmin]" in report and "play [arcsec]" not in report
    summary = json.loads((run_out / "summary.json").read_text())
    for case in summary["cases"]:
        rows = {row["check"]: row for row in case["checks"]["rows"]}
        assert rows["undercut_margin"]["margin_pct"] is None
        assert "%" not in run_text.split("undercut margin", 1)[1].split("│")[3]


def test_a_stage_tolerance_study_says_how_to_get_the_compiled_solve(tmp_path, monkeypatch):
    """On the NumPy path the banner of a [stage] tolerance study names the fast extra and
    the switch; with the switch set, or without [stage], it says nothing of it."""
    from cyclomesh.core.kernel import ENV_VAR
    from cyclomesh.studies.tolerance import _banner, load_tolerance_study

    stage, _ = load_tolerance_study(_stage_tolerance_study(tmp_path))
    plain, _ = load_tolerance_study(Path(__file__).parents[2] / "examples" / "tolerance.toml")
    options = {"rings": 4}
    monkeypatch.setenv(ENV_VAR, "numpy")
    assert f"{ENV_VAR}=numba" in _banner(stage, options, 2)
    assert "cyclomesh[fast]" in _banner(stage, options, 2)
    assert ENV_VAR not in _banner(plain, options, 2)
    monkeypatch.setenv(ENV_VAR, "numba")
    assert ENV_VAR not in _banner(stage, options, 2)
