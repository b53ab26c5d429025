"""``[stage]`` with ``[friction]`` in the ring studies and design maps: the RV stage's
efficiency per ring (``cyclomesh tolerance``, ``allocate``) and per candidate
(``cyclomesh design``), the same as ``cyclomesh run`` reports for one case."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from cyclomesh.cli import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage_friction.toml"

TOLERANCE = """
[tolerance]
seed = 3
rings = {rings}
allowable_contact_stress_mpa = 1850.0
crank_step_deg = 30.0
"""
SPREAD = """radial_um = { distribution = "uniform", half_range = 2.0 }
angular_urad = { distribution = "uniform", half_range = 20.0 }
hole_radial_um = { distribution = "uniform", half_range = 3.0 }
"""


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


def _study(tmp_path: Path, extra: str, name: str = "study.toml", text: str | None = None) -> Path:
    path = tmp_path / name
    path.write_text((EXAMPLE.read_text() if text is None else text) + extra)
    return path


def test_a_ring_without_spread_is_the_run_of_the_nominal_case(tmp_path):
    """Rings with no error drawn are the study's case: their stage efficiencies, forward
    and back-driving, are those ``cyclomesh run`` reports for it (the same solves, read
    through the same conversion), to 1e-12."""
    extra = TOLERANCE.format(rings=2) + "\n[requirements]\nmin_backdrive_efficiency = 0.5\n"
    study = _study(tmp_path, extra)
    out, run = tmp_path / "tol", tmp_path / "run"
    result = invoke("tolerance", study, "--out", out, "--figures", "none", "-q")
    assert result.exit_code == 0, result.output
    result = invoke("run", study, "--out", run, "--figures", "none", "-q", "--crank-step-deg", 30)
    assert result.exit_code == 0, result.output
    case = json.loads((run / "summary.json").read_text())["cases"][0]
    ds = xr.open_dataset(out / "tolerance_rings.nc")
    for name, key in (
        ("stage_efficiency", "efficiency"),
        ("stage_backdrive_efficiency", "backdrive_efficiency"),
    ):
        assert ds[name].attrs["units"] == "1"
        np.testing.assert_allclose(ds[name].values, case[key], rtol=1e-12, atol=0)
    # the mesh on rigid bearings keeps its own efficiency beside the stage's
    assert np.all(ds["efficiency"].values != ds["stage_efficiency"].values)


def test_the_stage_efficiency_over_rings_and_its_requirements(tmp_path):
    """Drawn errors move the stage's efficiency a little; its P5/P50/P95 are reported like
    the other stage metrics, the requirements check the stage's (P5 for a lower limit),
    and two workers give the serial rings bit for bit."""
    extra = TOLERANCE.format(rings=4) + SPREAD
    extra += "\n[requirements]\nmin_efficiency = 0.5\n"
    study = _study(tmp_path, extra)
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        result = invoke(
            "tolerance", study, "--out", out, "--figures", "none", "-q", "--workers", workers
        )
        assert result.exit_code == 0, result.output
        runs[workers] = out
    one = xr.open_dataset(runs[1] / "tolerance_rings.nc")
    two = xr.open_dataset(runs[2] / "tolerance_rings.nc")
    for name in one.data_vars:
        np.testing.assert_array_equal(one[name].values, two[name].values, strict=True)
    eff = one["stage_efficiency"].values
    assert np.all((0.5 < eff) & (eff < 1.0)) and np.ptp(eff) > 0
    assert "stage_backdrive_efficiency" not in one  # only when a requirement asks for it
    summary = json.loads((runs[1] / "tolerance_summary.json").read_text())
    stats = summary["metrics"]["stage_efficiency"]
    assert [p["percent"] for p in stats["percentiles"]][:3] == [5.0, 50.0, 95.0]
    assert summary["stage_worst_ring"]["stage_efficiency"] in eff
    row = {r["check"]: r for r in summary["checks"]["rows"]}["min_efficiency"]
    assert row["value"] == pytest.approx(np.percentile(eff, 5.0), rel=1e-12)
    # the worst ring's study file carries its pin and hole errors and the friction: its
    # case's stage, solved as cyclomesh run solves it, has the ring's efficiency
    from cyclomesh.results.stage import solve_case
    from cyclomesh.stage.efficiency import as_drive
    from cyclomesh.studyfile.schema import load_study
    from cyclomesh.tolerance.tasks import ring_efficiency

    inputs = load_study(runs[1] / "worst_ring.toml").base.to_core()
    speed = inputs.friction.speed
    direct = ring_efficiency(as_drive(solve_case(inputs), 1.0, speed), 39, speed)
    k = summary["worst_ring"]["ring"]
    assert float(one["stage_efficiency"].sel(ring=k)) == pytest.approx(float(direct), rel=1e-12)


def test_zero_sliding_friction_gives_efficiency_one_and_no_loss():
    """Rolling pins whose groove has no friction (μ_eff = min(μ_tooth, μ_groove) = 0) and
    no bearing friction: the stage solved with friction loses exactly nothing, both
    efficiencies are exactly 1, and its loads are the frictionless stage's."""
    import dataclasses

    from cyclomesh.results.stage import stage_model
    from cyclomesh.stage.efficiency import as_drive, stage_efficiency
    from cyclomesh.stage.solve import solve
    from cyclomesh.studyfile.schema import load_study

    inputs = load_study(EXAMPLE).base.to_core()
    case = inputs.case().replace(torque=[412.0], crank_angles=np.deg2rad([0.0, 7.0, 50.0]))
    model = stage_model(inputs)
    friction = dataclasses.replace(model.friction, groove=0.0, bearing=0.0)
    assert not friction.frictionless and friction.pins == "rolling"
    slipping = model.replace(friction=friction)
    assert stage_efficiency(case, slipping, backdrive=True) == {
        "stage_efficiency": 1.0,
        "stage_backdrive_efficiency": 1.0,
    }
    solved = solve(case, slipping)
    drive = as_drive(solved, 1.0, friction.speed)
    for name in ("power_loss_tooth", "power_loss_groove", "power_loss_bearing"):
        assert np.all(drive.friction[name] == 0.0)
    plain = solve(case, model.replace(friction=None))
    np.testing.assert_allclose(solved.bearing_load, plain.bearing_load, rtol=1e-9)
    np.testing.assert_allclose(solved.pin_load, plain.pin_load, rtol=1e-9, atol=1e-9)


def test_allocate_takes_the_stage_with_friction(tmp_path):
    """The allocation's criterion stays the stage's contact stress; the stage's
    efficiency at the stated tolerances is reported beside it."""
    extra = TOLERANCE.format(rings=3) + SPREAD
    extra += "\n[tolerance.allocation]\nfactor_max = 2.0\nfactor_steps = 2\nbisections = 1\n"
    out = tmp_path / "out"
    result = invoke("allocate", _study(tmp_path, extra), "--out", out, "--figures", "none", "-q")
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "allocation_rings.nc")
    eff = ds["stage_efficiency"].values
    assert ds["stage_efficiency"].attrs["units"] == "1"
    assert np.all((0.5 < eff) & (eff < 1.0))
    above = ds["stage_max_contact_stress_mpa"].values > 1850.0
    assert np.all(ds["critical_factor_upper"].values[above] <= 1.0)
    assert np.all(ds["critical_factor_lower"].values[~above] >= 1.0)


def test_all_zero_coefficients_are_the_frictionless_stage(tmp_path):
    """A [friction] whose coefficients are all 0 is the paper's frictionless model, as in
    ``cyclomesh run``: no stage efficiency is reported, the stage's metrics are those of
    the study without [friction]."""
    text = EXAMPLE.read_text()
    zero = text.replace("= 0.05 ", "= 0.0 ").replace("= 0.0025 ", "= 0.0 ")
    assert zero.count("= 0.0 ") == 3
    extra = TOLERANCE.format(rings=1) + SPREAD
    outs = []
    for name, body in (("zero.toml", zero), ("none.toml", text[: text.index("[friction]")])):
        out = tmp_path / f"out_{name}"
        study = _study(tmp_path, extra, name, body)
        result = invoke("tolerance", study, "--out", out, "--figures", "none", "-q")
        assert result.exit_code == 0, result.output
        outs.append(xr.open_dataset(out / "tolerance_rings.nc"))
    assert "stage_efficiency" not in outs[0]
    for name in outs[1].data_vars:
        np.testing.assert_array_equal(outs[0][name].values, outs[1][name].values)


MAP = """
[design_space]
pin_radius_um = { start = 2.0, stop = 6.0, points = 3 }
min_stage_efficiency = 0.944
objective = "stage_efficiency"
"""


def _map_text() -> str:
    return EXAMPLE.read_text().replace(
        "crank_step_deg = 2.0", "crank_start_deg = 0.0\ncrank_stop_deg = 6.0\ncrank_step_deg = 3.0"
    )


def test_design_map_with_the_stage_efficiency(tmp_path):
    """``stage_efficiency`` as the objective (maximised) and ``min_stage_efficiency`` as a
    constraint; a candidate's value is the stage solved with friction for its
    modification."""
    from cyclomesh.core.pair import Modification
    from cyclomesh.results.stage import stage_model
    from cyclomesh.stage.efficiency import stage_efficiency
    from cyclomesh.studyfile.schema import load_study

    study = _study(tmp_path, MAP, text=_map_text())
    out = tmp_path / "out"
    result = invoke("design", study, "--out", out, "--figures", "none", "-q")
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out / "design.nc")
    eff = ds["stage_efficiency"]
    assert eff.attrs["units"] == "1" and np.all(np.isfinite(eff.values))
    feasible = ds["feasible"].values.astype(bool)
    np.testing.assert_array_equal(feasible, eff.values >= 0.944)
    assert feasible.any() and not feasible.all()
    best = float(ds.attrs["optimum_pin_radius_um"])
    assert float(eff.sel(pin_radius_um=best)) == np.max(eff.values[feasible])
    assert "efficiency" in ds  # the mesh's on rigid bearings, beside the stage's
    inputs = load_study(study).base.to_core()
    case = inputs.case().replace(
        modification=Modification(pin_radius=4.0e-6), torque=[412.0], errors=None
    )
    direct = stage_efficiency(case, stage_model(inputs))["stage_efficiency"]
    assert float(eff.sel(pin_radius_um=4.0)) == pytest.approx(direct, rel=1e-12)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["constraints"] == {"min_stage_efficiency": 0.944}


def test_the_stage_efficiency_needs_friction(tmp_path):
    text = _map_text()
    study = _study(tmp_path, MAP, text=text[: text.index("[friction]")])
    result = invoke("design", study, "--out", tmp_path / "o")
    assert result.exit_code == 2, result.output
    assert "needs friction: add [friction]" in " ".join(result.output.split())


def test_a_robust_map_takes_each_rings_stage_efficiency(tmp_path):
    """Over K rings a candidate's stage efficiency is the 5th percentile (order statistic)
    of the rings' own, each ring's stage solved with its pin errors."""
    import dataclasses

    from cyclomesh.core.pair import PinErrors
    from cyclomesh.results.stage import stage_model
    from cyclomesh.stage.efficiency import stage_efficiency
    from cyclomesh.studies.rings import ring_model
    from cyclomesh.studyfile.schema import load_study

    space = MAP.replace("min_stage_efficiency = 0.944\n", "rings = 2\n")
    space = space.replace("points = 3", "points = 1")
    space += TOLERANCE.format(rings=2).replace("crank_step_deg = 30.0", "")
    space += 'radial_um = { distribution = "uniform", half_range = 2.0 }\n'
    study = _study(tmp_path, space, text=_map_text())
    out = tmp_path / "out"
    result = invoke("design", study, "--out", out, "--figures", "none", "-q", "--workers", 1)
    assert result.exit_code == 0, result.output
    value = float(xr.open_dataset(out / "design.nc")["stage_efficiency"].values[0])
    loaded = load_study(study)
    inputs = loaded.base.to_core()
    model = ring_model(loaded, loaded.tolerance)
    errors = model.pin_errors(model.draw(np.arange(2)))
    modification = dataclasses.replace(inputs.modification, pin_radius=2.0e-6)
    case = inputs.case().replace(modification=modification, torque=[412.0])
    rings = [
        stage_efficiency(
            case.replace(
                errors=PinErrors(
                    errors.radial[k], errors.angular[k], errors.pin_radius[k],
                    errors.eccentricity[k],
                )
            ),
            stage_model(inputs),
        )["stage_efficiency"]
        for k in range(2)
    ]  # fmt: skip
    assert np.ptp(rings) > 0
    assert value == pytest.approx(min(rings), rel=1e-12)


@pytest.mark.parametrize("kind", ["tolerance", "design"])
def test_a_bearing_coefficient_needs_the_crank_bearings(tmp_path, kind):
    """Refused in one line before any ring or candidate (a ring's DesignError would count
    as a jammed ring)."""
    text = _map_text()
    for section in ("[stage.crank_bearing]", "[stage.crankshaft]", "[stage.carrier]"):
        start = text.index(section)
        text = text[:start] + text[text.index("\n[", start + 1) + 1 :]
    extra = TOLERANCE.format(rings=1).replace("30.0", "3.0") if kind == "tolerance" else MAP
    result = invoke(kind, _study(tmp_path, extra, text=text), "--out", tmp_path / "o")
    assert result.exit_code == 2, result.output
    assert "needs [stage.crank_bearing]" in " ".join(result.output.split())


def test_the_worst_ring_of_a_study_with_hole_errors_runs_with_its_data_sheet(tmp_path):
    """A stage tolerance study with friction, pin errors and crank-hole errors of ±3 µm
    (beyond the bearings' 2.5 µm free travel): its worst ring's ``cyclomesh run`` writes
    the data sheet (it failed in the loop at −0.1 % of T_r: "no decrease of the residual").
    Its backlash (the loop's width at zero torque) is the frictionless run's plus a
    positive friction width far below the play, its lost motion within 0.1 % of it."""
    study = _study(tmp_path, TOLERANCE.format(rings=4) + SPREAD)
    out = tmp_path / "tol"
    result = invoke("tolerance", study, "--out", out, "--figures", "none", "-q")
    assert result.exit_code == 0, result.output
    ring = (out / "worst_ring.toml").read_text()
    assert "[friction]" in ring and "hole_error_radial_um" in ring
    sheets = []
    for name, text in (("ring", ring), ("plain", ring.replace("[friction]", "[ignored]"))):
        path = tmp_path / f"{name}.toml"
        if name == "plain":  # the same ring without friction
            head, _, tail = text.partition("[ignored]")
            text = head + tail[tail.index("\n[") + 1 :]
        path.write_text(text)
        result = invoke("run", path, "--out", tmp_path / name, "--figures", "none", "-q")
        assert result.exit_code == 0, result.output
        sheets.append(json.loads((tmp_path / name / "summary.json").read_text())["cases"][0])
    fric, plain = sheets
    assert "efficiency" in fric and "efficiency" not in plain
    width = fric["stage_backlash_arcmin"] - plain["stage_backlash_arcmin"]
    assert 0 < width < 0.01 * plain["stage_backlash_arcmin"]
    assert fric["stage_lost_motion_arcmin"] == pytest.approx(plain["stage_lost_motion_arcmin"],
                                                             rel=1e-3)  # fmt: skip
