"""The compliant disc in the RV stage (disc_body = "fe" with [stage]): the FE disc with its
crank-hole centres free, coupled with the crank bearings and the pins (coarse meshes)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.stage.fe_cases import COARSE, EXAMPLE, require_fe

require_fe()

import cyclomesh.stage.equilibrium as eq  # noqa: E402
import cyclomesh.stage.newton as nt  # noqa: E402
from cyclomesh.core.discbody import FREE_HELD, FreeDiscBody  # noqa: E402
from cyclomesh.fe.influence import free_influence  # noqa: E402
from cyclomesh.stage.solve import solve  # noqa: E402
from cyclomesh.studyfile.schema import load_study  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 15.0))


@pytest.fixture(scope="module")
def coarse(example, tmp_path_factory):
    """The example's coarse free disc (``example``: tests/stage/conftest.py) and the folder
    it is cached in."""
    folder = tmp_path_factory.mktemp("cache")
    ex = example
    return free_influence(ex.design, ex.modification, ex.crank_holes, folder, **COARSE), folder


def _solve(example, body, torque=412.0, phi=PHI):
    case = example.case().replace(torque=torque, crank_angles=phi)
    return solve(case, example.model().replace(disc_body=body))


def _fit(holes: np.ndarray, angles: np.ndarray, r_c: float) -> np.ndarray:
    """Least-squares rigid motion (tx, ty, ω·r_c) of hole-centre displacements (..., N, 2)
    given radially and tangentially."""
    r, t = holes[..., 0], holes[..., 1]
    c, s = np.cos(angles), np.sin(angles)
    return np.stack(
        [np.mean(r * c - t * s, -1), np.mean(r * s + t * c, -1), np.mean(t, -1)], axis=-1
    )


def test_free_disc_is_reciprocal_and_measured_from_the_holes_mean_motion(coarse, example):
    body, _ = coarse
    holes = example.crank_holes
    assert body.pins.info["reciprocity"] < 1e-10  # pin→hole against hole→pin, from the FE
    scale = np.max(np.abs(body.hole_pin))
    # no column moves the hole centres rigidly (the frame of their least-squares motion)
    fit = _fit(body.hole_pin, holes.angles, holes.circle_radius)
    assert np.max(np.abs(fit)) <= 1e-10 * scale
    hh = np.moveaxis(body.hole_hole.reshape(3, 2, 6), -1, 0)  # (load, hole, r/t)
    assert np.max(np.abs(_fit(hh, holes.angles, holes.circle_radius))) <= 1e-10 * scale
    # the cyclic period of the pin table: 39 teeth, 3 holes repeat every 13
    assert body.pins.period == 13
    # symmetric; with the held components out, positive definite on the hole centres, and
    # with the contact law's compliance at a light load (10 N) on the pins too (alone the
    # pins' block is not: the near field is the law's, issue 17)
    from cyclomesh.core.discbody import tooth_index

    k = tooth_index(40, 2 * np.pi / 40, 0.3)[1:12]
    u = np.linspace(-0.3, -2.5, 11)
    c = body.matrix(k, u)
    free = [11 + 2 * h + j for h in range(3) for j in range(2) if (h, j) not in FREE_HELD]
    assert np.allclose(c, c.T, rtol=0, atol=1e-12 * np.max(np.abs(c)))
    assert np.linalg.eigvalsh(c[np.ix_(free, free)]).min() > 0
    law = np.zeros(11 + len(free))
    law[:11] = 6e-9 - 5e-10 * (1.0 + np.log(10.0))  # α − γ(1 + ln F) of the example's pins
    both = c[np.ix_([*range(11), *free], [*range(11), *free])] + np.diag(law)
    assert np.linalg.eigvalsh(both).min() > 0


def test_a_stiff_disc_tends_to_the_rigid_stage(coarse, example):
    body, _ = coarse
    rigid = _solve(example, "rigid")
    gaps = []
    for eps in (1e-2, 1e-4):
        stiff = FreeDiscBody(
            replace(body.pins, table=eps * body.pins.table, diagonal=eps * body.pins.diagonal),
            eps * body.hole_pin,
            eps * body.hole_hole,
            body.count,
        )
        soft = _solve(example, stiff)
        gaps.append(np.max(np.abs(soft.twist - rigid.twist)) / np.max(rigid.twist))
        np.testing.assert_allclose(
            soft.bearing_load, rigid.bearing_load, rtol=0, atol=50 * eps * rigid.bearing_load.max()
        )
    # first order in the compliance: 100 times stiffer, 100 times closer (within 20 %)
    assert 0.8e-2 < gaps[1] / gaps[0] < 1.2e-2
    assert gaps[1] < 1e-5


def test_the_compliant_disc_balances_and_its_share_is_its_own_work(coarse, example):
    body, _ = coarse
    res = _solve(example, body, torque=[-412.0, 412.0])
    rigid = _solve(example, "rigid", torque=[-412.0, 412.0])
    # softer, and by the body's share: the shares add up to 1 in both directions
    assert np.all(res.twist[1] > rigid.twist[1])
    for q, torque in enumerate((-412.0, 412.0)):
        total = torque * res.twist[q]
        parts = sum(res.work[name][q] for name in res.work)
        np.testing.assert_allclose(parts, total, rtol=1e-9)
        assert np.all(res.work["disc_body"][q] > 0)
    # the body's work λᵀC'λ recomputed from the written loads: pins on the loaded flanks
    # (into the disc) and the crank bearings' reaction on the disc at the hole centres
    from cyclomesh.core.discbody import tooth_index
    from cyclomesh.drive.mesh import disc_angles

    design, holes = example.design, example.crank_holes
    tooth = tooth_index(design.pins, design.pitch, disc_angles(PHI, 2))
    tooth = tooth.reshape(2, PHI.size, design.pins)  # (D, A, n1), as the mesh core's
    from cyclomesh.drive.mesh import stacked_contact

    geo = stacked_contact(design, example.modification, example.errors, PHI, 2)
    worst = 0.0
    for a in range(0, PHI.size, 4):
        work = 0.0
        for d in range(2):
            f_pin = res.pin_load[1, a, d]
            on = f_pin > 0
            ang_h = holes.angles - PHI[a] / design.teeth
            B = res.bearing_load[1, a, d]
            rel = res.bearing_load_angle[1, a, d] - ang_h
            f_hole = np.stack([-B * np.cos(rel), -B * np.sin(rel)], -1).ravel()
            c = body.matrix(tooth[d, a][on], geo.profile_angle[a, d][on])
            f = np.concatenate([f_pin[on], f_hole])
            work += f @ c @ f
        worst = max(worst, abs(work - res.work["disc_body"][1, a]) / res.work["disc_body"][1, a])
    assert worst < 1e-6


def test_run_and_stiffness_with_the_compliant_disc_end_to_end(
    coarse, example, tmp_path, monkeypatch
):
    """``cyclomesh run`` and ``stiffness`` of examples/rv_stage.toml with disc_body = "fe"
    (its first case, coarse FE meshes from the module's cache): the compliance budget
    gets the disc body's share, the shares add up to 1, the stage is softer than with the
    rigid disc, and the stiffness study reports the stage below the mesh alone."""
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app

    _, folder = coarse
    for key, value in COARSE.items():  # the study's FE meshes are the coarse ones
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.read_text()
    base = text[: text.index("[[cases]]")]  # three crankshafts
    path = tmp_path / "rv_fe.toml"
    path.write_text(base.replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1))
    rigid_path = tmp_path / "rv.toml"
    rigid_path.write_text(base)
    runner = CliRunner()
    common = ["--crank-step-deg", "30", "--figures", "none", "--cache-dir", str(folder)]
    sheets = {}
    for name, study in (("fe", path), ("rigid", rigid_path)):
        out = tmp_path / f"run_{name}"
        result = runner.invoke(app, ["run", str(study), "--out", str(out), *common])
        assert result.exit_code == 0, result.output
        sheets[name] = json.loads((out / "summary.json").read_text())["cases"][0]
    fe_sheet, rigid_sheet = sheets["fe"], sheets["rigid"]
    share = fe_sheet["compliance_share"]
    assert share["disc_body"] > 0.005 and rigid_sheet["compliance_share"]["disc_body"] == 0
    assert sum(share.values()) == pytest.approx(1.0, abs=1e-9)
    assert (
        fe_sheet["stage_torsional_rigidity_nm_per_arcmin"]
        < rigid_sheet["stage_torsional_rigidity_nm_per_arcmin"]
    )
    out = tmp_path / "stiff"
    result = runner.invoke(app, ["stiffness", str(path), "--out", str(out), *common])
    assert result.exit_code == 0, result.output
    stiff = json.loads((out / "summary.json").read_text())["cases"][0]
    assert stiff["stage_torsional_rigidity_nm_per_arcmin_mean"] > 0
    assert (
        stiff["stage_torsional_rigidity_nm_per_arcmin_min"]
        < stiff["torsional_rigidity_nm_per_arcmin_min"]
    )


def test_tolerance_and_allocate_with_the_compliant_disc_end_to_end(
    coarse, example, tmp_path, monkeypatch
):
    """``cyclomesh tolerance`` of examples/rv_stage.toml with disc_body = "fe" (coarse FE
    meshes from the module's cache, the free body resolved once and shipped to two worker
    processes): every ring's stage is solved with the compliant disc, its worst_ring.toml
    reruns the ring to the bit with ``cyclomesh run``, and against the same rings with the
    rigid disc the stage is softer (lost motion not smaller) by a small amount;
    ``cyclomesh allocate`` runs on the same ring model."""
    import xarray as xr
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app

    _, folder = coarse
    for key, value in COARSE.items():  # the study's FE meshes are the coarse ones
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.read_text()
    base = text[: text.index("[[cases]]")] + (
        "[tolerance]\nseed = 3\nrings = 3\nallowable_contact_stress_mpa = 1850.0\n"
        "crank_step_deg = 30.0\n"
        'radial_um = { distribution = "uniform", half_range = 2.0 }\n'
        'hole_radial_um = { distribution = "uniform", half_range = 3.0 }\n'
        "\n[tolerance.allocation]\nfactor_max = 2.0\nfactor_steps = 2\nbisections = 1\n"
    )
    path = tmp_path / "tol_fe.toml"
    path.write_text(base.replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1))
    rigid_path = tmp_path / "tol.toml"
    rigid_path.write_text(base)
    runner = CliRunner()
    common = ["--figures", "none", "--cache-dir", str(folder)]
    rings = {}
    for name, study in (("fe", path), ("rigid", rigid_path)):
        out = tmp_path / f"tol_{name}"
        args = ["tolerance", str(study), "--out", str(out), "--workers", "2", *common]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        rings[name] = xr.load_dataset(out / "tolerance_rings.nc")
    fe_rings, rigid_rings = rings["fe"], rings["rigid"]
    lost = "stage_lost_motion_arcmin_max"
    assert np.all(np.isfinite(fe_rings[lost].values))
    # the same drawn errors; the mesh alone (the held disc) is not the stage's business
    for name in ("max_contact_stress_mpa", "stage_max_crank_bearing_load_n"):
        assert not np.array_equal(fe_rings[name].values, rigid_rings[name].values), name
    softer = fe_rings[lost].values / rigid_rings[lost].values
    assert np.all(softer >= 1.0) and np.all(softer < 1.05), softer
    load = fe_rings["stage_max_crank_bearing_load_n"].values
    ratio = load / rigid_rings["stage_max_crank_bearing_load_n"].values
    assert np.all(np.abs(ratio - 1.0) < 0.05), ratio
    # the worst ring's study file keeps disc_body = "fe" and reruns the ring to the bit
    summary = json.loads((tmp_path / "tol_fe" / "tolerance_summary.json").read_text())
    k = summary["worst_ring"]["ring"]
    worst = (tmp_path / "tol_fe" / "worst_ring.toml").read_text()
    assert 'disc_body = "fe"' in worst
    rerun = tmp_path / "rerun"
    args = ["run", str(tmp_path / "tol_fe" / "worst_ring.toml"), "--out", str(rerun), *common]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    case = json.loads((rerun / "summary.json").read_text())["cases"][0]
    for name in (lost, "stage_l10_h_min", "stage_max_crank_bearing_load_n"):
        assert case[name] == float(fe_rings[name].sel(ring=k)), name
    out = tmp_path / "alloc"
    args = ["allocate", str(path), "--out", str(out), "--rings", "2", *common]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    alloc = xr.load_dataset(out / "allocation_rings.nc")
    assert np.all(np.isfinite(alloc["stage_max_contact_stress_mpa"].values))
    # the criterion is the stage's stress: a ring not exceeding at f = 1 has f* > 1
    above = alloc["stage_max_contact_stress_mpa"].values > 1850.0
    assert np.all(alloc["critical_factor_upper"].values[above] <= 1.0)
    assert not np.any(np.isnan(alloc["critical_factor_upper"].values))


def test_design_map_with_the_compliant_disc_in_the_stage(coarse, example, tmp_path, monkeypatch):
    """``cyclomesh design`` of examples/rv_stage.toml with disc_body = "fe" over Δρ: every
    candidate's stage metrics are the stage's own torsion curve and life with the study's
    free disc body (the base geometry's, as tolerance rings use it), to 1e-12; the
    compliant stage is softer than the rigid one of the same map. (A map over the geometry
    builds each candidate's own bodies: tests/designspace/test_design_fe_geometry.py.)"""
    import xarray as xr
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app
    from cyclomesh.core.case import Case
    from cyclomesh.core.pair import Modification
    from cyclomesh.stage.solve import bearing_life, stage_torsion

    _, folder = coarse
    for key, value in COARSE.items():
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.read_text()
    base = text[: text.index("[[cases]]")].replace(
        "crank_step_deg = 1.0",
        "crank_start_deg = 0.0\ncrank_stop_deg = 30.0\ncrank_step_deg = 15.0",
    )
    space = (
        '[design_space]\nobjective = "stage_rigidity"\n'
        "pin_radius_um = { start = 2.0, stop = 4.0, points = 2 }\n"
    )
    runner = CliRunner()
    maps = {}
    for name, analysis in (("fe", '[analysis]\ndisc_body = "fe"'), ("rigid", "[analysis]")):
        study = tmp_path / f"{name}.toml"
        study.write_text(base.replace("[analysis]", analysis, 1) + space)
        out = tmp_path / name
        args = ["design", str(study), "--out", str(out), "--figures", "none"]
        result = runner.invoke(app, [*args, "--cache-dir", str(folder)])
        assert result.exit_code == 0, result.output
        maps[name] = xr.load_dataset(out / "design.nc")
    assert maps["fe"].attrs["stage_disc_body"] == "fe"
    rig = "stage_torsional_rigidity_nm_per_arcmin_min"
    assert np.all(maps["fe"][rig].values < maps["rigid"][rig].values)
    arcmin = np.pi / (180 * 60)
    inputs = load_study(tmp_path / "fe.toml").base.to_core()  # the map's base, not case 1
    body = free_influence(inputs.design, inputs.modification, inputs.crank_holes, folder, **COARSE)
    model = inputs.model().replace(disc_body=body)
    for dr in (2.0, 4.0):
        case = Case(
            inputs.design,
            Modification(pin_radius=dr * 1e-6),
            None,
            412.0,
            np.deg2rad(load_study(tmp_path / "fe.toml").base.analysis.crank_angles_deg()),
        )
        curve = stage_torsion(case, model, points=2)
        cell = maps["fe"].sel(pin_radius_um=dr)
        assert float(cell[rig]) == pytest.approx(
            np.min(curve.torsional_rigidity) * arcmin, rel=1e-12
        )
        assert float(cell["stage_lost_motion_arcmin_max"]) == pytest.approx(
            np.max(curve.lost_motion) / arcmin, rel=1e-12
        )
        at = int(np.flatnonzero(curve.stage.torque == 412.0)[0])
        hours = bearing_life(curve.stage, inputs.stage, inputs.design.pins)[2][at]
        assert float(cell["stage_l10_h_min"]) == pytest.approx(np.min(hours), rel=1e-12)


def test_a_refused_compliant_stage_keeps_the_earlier_result(coarse, tmp_path, monkeypatch):
    """Issue 23 with the compliant disc: ``cyclomesh run`` of the stage with disc_body =
    "fe" into a folder holding its complete result, refused after its first case was
    solved (a second case whose pins overlap the disc, Δρ = -8 µm): one error line, exit
    2, every file of the earlier result byte-identical and loadable."""
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app
    from cyclomesh.output.folder import LOCK, STAGING, load_results

    _, folder = coarse
    for key, value in COARSE.items():
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.read_text()
    base = text[: text.index("[[cases]]")].replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1)
    good, bad = tmp_path / "good.toml", tmp_path / "bad.toml"
    good.write_text(base)
    bad.write_text(
        base
        + '\n[[cases]]\nname = "a"\n\n[[cases]]\nname = "b"\nmodification.pin_radius_um = -8.0\n'
    )
    out = tmp_path / "out"
    common = ["--out", str(out), "-q", "--crank-step-deg", "60", "--figures", "none"]
    common += ["--cache-dir", str(folder)]

    def snapshot():
        return {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file() and p.name != LOCK}

    first = CliRunner().invoke(app, ["run", str(good), *common])
    assert first.exit_code == 0, first.output
    before = snapshot()
    refused = CliRunner().invoke(app, ["run", str(bad), *common])
    lines = [line for line in refused.output.splitlines() if line.strip()]
    assert refused.exit_code == 2 and len(lines) == 1, refused.output
    assert lines[0].startswith('error: case "b": pin 1 overlaps the disc'), lines[0]
    assert snapshot() == before and not (out / STAGING).exists()
    load_results(out)


@pytest.mark.parametrize("motion", [1.0, -1.0])
def test_friction_with_the_compliant_disc_closes_its_power_and_work(coarse, example, motion):
    """Friction with the compliant disc (the body's unknowns in ∂Q/∂x): P_in from the crank
    pins' forces = ±P_out + losses + the approach power, the parts' work (the disc body's
    and friction's included) adds to T·twist, and the equilibrium converges to the test
    of the frictionless stage; all coefficients 0 is the frictionless compliant stage."""
    from cyclomesh.core.friction import Friction

    body, _ = coarse
    speed = 2.0 * np.pi * 585.0 / 60.0
    case = example.case().replace(torque=[-412.0, 412.0], crank_angles=PHI)
    model = example.model().replace(disc_body=body)
    plain = solve(case, model)
    zero = solve(case, model.replace(friction=Friction(speed=speed)), motion=motion)
    np.testing.assert_array_equal(zero.pin_load, plain.pin_load)
    friction = Friction(mesh=0.05, groove=0.05, bearing=0.0025, bearing_diameter=18e-3,
                        speed=speed)  # fmt: skip
    res = solve(case, model.replace(friction=friction), motion=motion)
    f = res.friction
    loss = np.sum(f["power_loss_tooth"] + f["power_loss_groove"], (-2, -1)) + np.sum(
        f["power_loss_bearing"], (-2, -1)
    )
    p_out = 412.0 * speed / example.design.teeth
    np.testing.assert_allclose(
        f["input_power"], motion * p_out + loss + f["approach_power"], rtol=0, atol=1e-9 * p_out
    )
    assert np.all(res.work["disc_body"] > 0) and "friction" in res.work
    total = sum(res.work.values())
    np.testing.assert_allclose(total, res.torque[:, None] * res.twist, rtol=1e-9)
    assert np.max(res.residual) < 1e-9 * 412.0 / example.crank_holes.circle_radius
    # friction changes the loads by a few per cent at most at mu = 0.05, not their pattern
    scale = np.max(plain.pin_load)
    assert 0 < np.max(np.abs(res.pin_load - plain.pin_load)) < 0.1 * scale


def test_friction_with_the_compliant_disc_end_to_end(coarse, tmp_path, monkeypatch):
    """``cyclomesh run`` and ``stiffness`` of examples/rv_stage_friction.toml with
    disc_body = "fe" (coarse meshes): the stage's efficiency and loop with the compliant
    disc, a warning that the mesh alone on rigid bearings is frictionless, and the
    efficiency a little below the rigid disc's (more pins share the load and slide)."""
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app

    _, folder = coarse
    for key, value in COARSE.items():
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.with_name("rv_stage_friction.toml").read_text()
    path = tmp_path / "rvf_fe.toml"
    path.write_text(text.replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1))
    rigid = tmp_path / "rvf.toml"
    rigid.write_text(text)
    runner = CliRunner()
    common = ["--crank-step-deg", "30", "--figures", "none", "--cache-dir", str(folder)]
    eff = {}
    for name, study in (("fe", path), ("rigid", rigid)):
        out = tmp_path / f"run_{name}"
        result = runner.invoke(app, ["run", str(study), "--out", str(out), *common])
        assert result.exit_code == 0, result.output
        summary = json.loads((out / "summary.json").read_text())
        eff[name] = summary["cases"][0]["efficiency"]
        noted = any("mesh alone on rigid bearings" in w for w in summary.get("warnings", []))
        assert noted == (name == "fe")
    assert 0.9 < eff["fe"] < eff["rigid"] < 1.0
    out = tmp_path / "stiff"
    result = runner.invoke(app, ["stiffness", str(path), "--out", str(out), *common])
    assert result.exit_code == 0, result.output
    case = json.loads((out / "summary.json").read_text())["cases"][0]
    assert case["stage_hysteresis_arcmin_max"] > 0


def test_a_compliant_stage_ring_that_does_not_converge_is_unsolved(coarse, tmp_path, monkeypatch):
    """The compliant disc in a stage tolerance study: a ring whose stage solve does not
    converge (made so, tests/execution/_unsolvable.py) is flagged ``unsolved`` with the
    solver's message, its metrics NaN (attributed), and the other rings keep the bits of
    the study without the failure."""
    import sys

    import xarray as xr
    from typer.testing import CliRunner

    import cyclomesh.fe.influence as fe
    from cyclomesh.cli import app
    from cyclomesh.studies.tolerance import load_tolerance_study, ring_model

    sys.path.insert(0, str(Path(__file__).parents[1] / "execution"))
    from _unsolvable import STAGE_MESSAGE, fail_rings

    _, folder = coarse
    for key, value in COARSE.items():
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)
    text = EXAMPLE.read_text()
    path = tmp_path / "tol_fe.toml"
    path.write_text(
        text[: text.index("[[cases]]")].replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1)
        + "[tolerance]\nseed = 3\nrings = 3\nallowable_contact_stress_mpa = 1850.0\n"
        "crank_step_deg = 30.0\n"
        'radial_um = { distribution = "uniform", half_range = 2.0 }\n'
    )
    args = ["--workers", "1", "--figures", "none", "--cache-dir", str(folder), "-q"]
    runner = CliRunner()
    rings = {}
    for name in ("clean", "failing"):
        if name == "failing":
            study, spec = load_tolerance_study(path)
            fail_rings(monkeypatch, ring_model(study, spec), [1], stage=True)
        out = tmp_path / name
        result = runner.invoke(app, ["tolerance", str(path), "--out", str(out), *args])
        assert result.exit_code == 0, result.output
        rings[name] = xr.load_dataset(out / "tolerance_rings.nc")
    ds, clean = rings["failing"], rings["clean"]
    assert ds["unsolved"].values.tolist() == [0, 1, 0]
    assert str(ds["unsolved_reason"].values[1]) == STAGE_MESSAGE
    keep = [0, 2]
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f" and np.isnan(var.values).any():
            assert "nonfinite" in var.attrs, name
        if name not in ("unsolved", "unsolved_reason", "jammed"):
            assert np.isnan(var.values[1]) or var.dtype.kind != "f", name
            np.testing.assert_array_equal(var.values[keep], clean[name].values[keep], name)


# The compliant disc's Newton (stage.equilibrium._body_newton): the potential's Newton
# (stage.newton.newton) with a ``failed`` array hands only the crank angles it cannot
# finish (the descent runs away along the body unknowns' saddle) to the residual Newton
# (_stationary); the others keep its arithmetic.

BOTH = [-412.0, 412.0]
NEWTON_FIELDS = ("twist", "bearing_load", "pin_load", "torque_share")


def _count_stationary(monkeypatch):
    """Crank angles handed to _stationary, counted."""
    handed = []
    stationary = eq._stationary

    def counted(p, evaluate, law, x, discs, phi):
        handed.append(x.shape[0])
        return stationary(p, evaluate, law, x, discs, phi)

    monkeypatch.setattr(eq, "_stationary", counted)
    return handed


def test_failed_newton_keeps_the_arithmetic_where_every_angle_converges(
    example, coarse, monkeypatch
):
    """Where Newton finishes every crank angle, the ``failed`` array changes no bit."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    body, _ = coarse
    handed = _count_stationary(monkeypatch)
    ref = _solve(example, body, BOTH)
    assert sum(handed) == 0
    plain = nt.newton

    def without(p, evaluate, law, x, discs, rigid, phi, failed=None):
        return plain(p, evaluate, law, x, discs, rigid, phi)

    monkeypatch.setattr(eq, "newton", without)
    got = _solve(example, body, BOTH)
    for name in NEWTON_FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), name)


def test_angles_handed_to_the_residual_newton_reach_the_same_root(example, coarse, monkeypatch):
    """Every crank angle given up (here: a stall declared after 0 steps) is solved by the
    residual Newton from its start, to the same root: 1e-13 of each field's largest value
    (that Newton goes on to round-off near the root, residual_newton(round_off=True);
    it stopped at 1e-12·T/r_c before, and this bound was 1e-12)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    body, _ = coarse
    ref = _solve(example, body, BOTH)
    handed = _count_stationary(monkeypatch)
    monkeypatch.setattr(nt, "_STALL_ITERATIONS", 0)
    got = _solve(example, body, BOTH)
    assert sum(handed) > 0
    for name in NEWTON_FIELDS:
        a, b = getattr(ref, name), getattr(got, name)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a)), name


# The compliant disc's speed (task i35b): warm runs along the revolution (eq._body_warm),
# the first trial's evaluation kept for the next Newton step (nt._REUSE_TRIAL), the
# residual Newton on to round-off, and with numba the Hessian's products compiled
# (stage.kernel_body). Each reaches the reference's root at round-off (measured on these
# cases: 4.0e-15 of a field's largest value at most).

LIGHT = [-12.36, 12.36]


def _close(a, b, rtol, name):
    assert np.max(np.abs(a - b)) <= rtol * np.max(np.abs(a)), (name, np.max(np.abs(a - b)))


@pytest.mark.parametrize("torque", [BOTH, LIGHT])
def test_warm_runs_reach_the_own_starts_root(example, coarse, monkeypatch, torque):
    """Each crank angle from its own start (runs of 1) and in warm runs: the same root,
    1e-13 of each field's largest value (the iteration runs to round-off)."""
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    body, _ = coarse
    warm = _solve(example, body, torque)
    monkeypatch.setattr(eq, "BODY_RUN", 1)
    cold = _solve(example, body, torque)
    for name in NEWTON_FIELDS:
        assert getattr(cold, name).shape == getattr(warm, name).shape
        _close(getattr(cold, name), getattr(warm, name), 1e-13, name)


def test_a_warm_start_carries_each_pins_unknown_by_its_pin():
    """_body_carried: the stage's unknowns and the holes' from the crank angle before, a
    pin's from the same pin there, its own start's where that pin was no candidate."""
    lam = 5  # 3 pin unknowns, 2 hole components a disc; one disc, no supports
    pins = np.array([[[4, 5, 6]], [[5, 6, -1]], [[6, 7, 8]]])  # (A, D, P)
    body = eq._Body.of_dense(
        pin_w=np.zeros((3, 1, 10, lam)),
        hole_w=np.zeros((3, 1, 3, 2, lam)),
        energy=np.zeros((3, 1, lam, lam)),
        pins=pins,
    )
    p = type("P", (), {"body": body})()
    x = np.arange(3 * 9, dtype=float).reshape(3, 9)  # m = 4 + 5
    got = eq._body_carried(p, x, np.array([1, 2]), 1)
    z = got[:, 4:]
    np.testing.assert_array_equal(got[:, :4], x[[0, 1], :4])
    np.testing.assert_array_equal(z[0], [x[0, 5], x[0, 6], x[1, 6], x[0, 7], x[0, 8]])
    np.testing.assert_array_equal(z[1], [x[1, 5], x[2, 5], x[2, 6], x[1, 7], x[1, 8]])


def test_the_first_trials_evaluation_kept_changes_no_bit(example, coarse, monkeypatch):
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    monkeypatch.setattr(nt, "_LAST_STEP", False)  # (it takes the reuse's path alone)
    body, _ = coarse
    ref = _solve(example, body, BOTH)
    monkeypatch.setattr(nt, "_REUSE_TRIAL", False)
    got = _solve(example, body, BOTH)
    for name in NEWTON_FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), name)


@pytest.mark.parametrize("torque", [BOTH, LIGHT])
def test_the_compiled_hessian_reaches_the_references_root(example, coarse, monkeypatch, torque):
    """CYCLOMESH_KERNEL=numba (stage.kernel_body and the compiled laws) against NumPy: 1e-13
    of each field's largest value."""
    pytest.importorskip("numba")
    body, _ = coarse
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    ref = _solve(example, body, torque)
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    got = _solve(example, body, torque)
    for name in NEWTON_FIELDS:
        _close(getattr(ref, name), getattr(got, name), 1e-13, name)


# Task i36b: a crank angle whose residual fell quadratically to one from which the next is
# predicted at the round-off takes that Newton step without a line search and ends
# (nt._LAST_STEP): the evaluation there and the round-off polish after it are saved.


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("torque", [BOTH, LIGHT])
def test_the_last_step_reaches_the_polished_root(example, coarse, monkeypatch, torque, kernel):
    """With and without the last step taken untried: the same root, 1e-13 of each
    field's largest value (measured on these cases: 5.3e-15 at most, the contact stress;
    main's two kernels differ by 6.5e-15 there), and fewer evaluations of the Hessian."""
    if kernel == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", kernel)
    body, _ = coarse
    rows = []
    evaluate = eq._evaluate

    def counted(sub, law, xa, discs, rigid, hessian=True, gradient=True):
        if hessian and gradient and sub.body is not None:
            rows[-1] += xa.shape[0]
        return evaluate(sub, law, xa, discs, rigid, hessian=hessian, gradient=gradient)

    monkeypatch.setattr(eq, "_evaluate", counted)
    compiled = eq.kernel_compliant  # (numba: the compiled Newton's evaluations, counted)

    def kernel_counted(p, law, x, discs, jacobian, settings, stats=None, state=None, start=None):
        found: dict = {}
        failed = compiled(p, law, x, discs, jacobian, settings, found, state, start)
        rows[-1] += int(found["counts"][:, 0].sum())
        return failed

    monkeypatch.setattr(eq, "kernel_compliant", kernel_counted)
    rows.append(0)
    fast = _solve(example, body, torque)
    monkeypatch.setattr(nt, "_LAST_STEP", False)
    rows.append(0)
    ref = _solve(example, body, torque)
    for name in NEWTON_FIELDS:
        _close(getattr(ref, name), getattr(fast, name), 1e-13, name)
    assert rows[0] < rows[1]
