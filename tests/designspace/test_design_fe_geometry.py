"""Design maps over the geometry with the compliant disc (``disc_body = "fe"``): every
candidate geometry gets its own FE body (built in the map's workers, through the cache),
so every candidate's numbers are those of ``cyclomesh run`` of that candidate (coarse
FE meshes, in a cache folder of each test)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

try:  # the fe extra; gmsh's wheel also needs X11/OpenGL client libraries (see .ci/run)
    import gmsh  # noqa: F401
    import skfem  # noqa: F401
except (ImportError, OSError) as exc:  # pragma: no cover
    pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)

import xarray as xr
from typer.testing import CliRunner

import cyclomesh.fe.influence as fe
from cyclomesh.cli import app
from cyclomesh.studyfile.schema import load_study

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
COARSE = dict(points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0)
ARCMIN = np.pi / (180 * 60)


@pytest.fixture
def coarse(monkeypatch):
    """The FE model's defaults made coarse (what ``disc_body = "fe"`` builds with)."""
    for key, value in COARSE.items():
        monkeypatch.setitem(fe.MESH_DEFAULTS, key, value)


def _table2(tmp_path: Path) -> str:
    """The base of examples/table2.toml with the compliant disc, the half-plane law and
    three crank angles (0°, 3°, 6°)."""
    text = (EXAMPLES / "table2.toml").read_text()
    base = text[: text.index("[figures]")].replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1)
    base = base.replace('contact_law = "paper"', 'contact_law = "half_plane"')
    return base.replace("crank_stop_deg = 360.0", "crank_stop_deg = 9.0").replace(
        "crank_step_deg = 0.1", "crank_step_deg = 3.0"
    )


def test_geometry_map_with_the_fe_disc_equals_run_of_each_candidate(tmp_path, coarse, cluster):
    """A map over the pin-circle radius a (80 and 82 mm) of the Table 1 pair with
    disc_body = "fe": each candidate's peak stress and TE equal `cyclomesh run` of that
    candidate (its own FE body) to 1e-12; the map is the same to the bit in one process,
    on two local worker processes and on a Dask cluster, each building the two bodies
    in a cache folder of its own (the workers build them with the parent's coarse
    settings); the notice before the map says 2 bodies to build, then all cached; the
    runs reuse the bodies. Without its own body (the base geometry's table for both, as
    the map did before it refused) the 80 mm candidate's stress is another number."""
    from cyclomesh.core.pair import Modification
    from cyclomesh.designspace.candidate import candidate_metrics

    base = _table2(tmp_path)
    study = tmp_path / "geometry.toml"
    study.write_text(
        base + '[design_space]\nobjective = "max_contact_stress"\n'
        "pin_circle_radius_mm = { start = 80.0, stop = 82.0, points = 2 }\n"
    )
    runner = CliRunner()
    maps, outputs = {}, {}
    engines = {
        "serial": [],
        "workers": ["--workers", "2"],
        "dask": ["--scheduler", cluster[0].scheduler_address],
    }
    for name, more in engines.items():
        out = tmp_path / name
        args = ["design", str(study), "--out", str(out), "--figures", "none"]
        result = runner.invoke(app, [*args, "--cache-dir", str(tmp_path / f"cache-{name}"), *more])
        assert result.exit_code == 0, result.output
        maps[name], outputs[name] = xr.load_dataset(out / "design.nc"), result.output
        assert "2 of 2 FE disc bodies to build" in " ".join(result.output.split())
        assert len(list((tmp_path / f"cache-{name}").glob("influence-*.npz"))) == 2
    cache = tmp_path / "cache-serial"
    args = ["design", str(study), "--out", str(tmp_path / "again"), "--figures", "none"]
    again = runner.invoke(app, [*args, "--cache-dir", str(cache)])
    assert "2 FE disc bodies of 2 geometries, all cached" in " ".join(again.output.split())
    ds = maps["serial"]
    assert ds.attrs["disc_body"] == "fe" and ds.attrs["feasible_candidates"] == 2
    for name in ("workers", "dask"):
        for var in ("max_contact_stress_mpa", "te_pp_arcsec", "play_arcmin"):
            np.testing.assert_array_equal(maps[name][var].values, ds[var].values)
    for a in (80.0, 82.0):
        one = tmp_path / f"a{a:g}.toml"
        one.write_text(base.replace("pin_circle_radius_mm = 82.0", f"pin_circle_radius_mm = {a}"))
        out = tmp_path / f"run{a:g}"
        args = ["run", str(one), "--out", str(out), "--figures", "none"]
        result = runner.invoke(app, [*args, "--cache-dir", str(cache)])
        assert result.exit_code == 0, result.output
        run = json.loads((out / "summary.json").read_text())["cases"][0]
        cell = ds.sel(pin_circle_radius_mm=a)
        for var in ("max_contact_stress_mpa", "te_pp_arcsec"):
            assert float(cell[var]) == pytest.approx(run[var], rel=1e-12, abs=0), var
    assert len(list(cache.glob("influence-*.npz"))) == 2  # the runs built none
    # the base geometry's table for the 80 mm candidate (what the map once did)
    inputs = load_study(tmp_path / "a80.toml").base.to_core()
    own = load_study(study).base.to_core()
    base_body = fe.influence(own.design, own.modification, None, cache, **COARSE)
    wrong = candidate_metrics(
        inputs.design,
        Modification(pin_radius=8e-6),
        None,
        250.0,
        np.deg2rad([0.0, 3.0, 6.0]),
        disc_body=base_body,
    )["max_contact_stress"]
    right = float(ds.sel(pin_circle_radius_mm=80.0)["max_contact_stress_mpa"])
    assert abs(float(wrong) * 1e-6 - right) > 1e-3 * right


def test_geometry_map_with_the_fe_disc_in_the_stage(tmp_path, coarse):
    """examples/rv_stage.toml with disc_body = "fe" over the eccentricity (1.25, 1.3 mm):
    each candidate's stage rigidity, lost motion and L10 are the stage's torsion curve
    and life with that geometry's own free FE body, and its peak stress the mesh's with
    its own held body, to 1e-12; the 2 geometries built 4 bodies (held and free)."""
    from cyclomesh.core.case import Case
    from cyclomesh.stage.solve import bearing_life, stage_torsion

    text = (EXAMPLES / "rv_stage.toml").read_text()
    base = text[: text.index("[[cases]]")].replace(
        "crank_step_deg = 1.0",
        "crank_start_deg = 0.0\ncrank_stop_deg = 30.0\ncrank_step_deg = 15.0",
    )
    base = base.replace("[analysis]", '[analysis]\ndisc_body = "fe"', 1)
    study = tmp_path / "stage.toml"
    study.write_text(
        base + '[design_space]\nobjective = "stage_rigidity"\n'
        "eccentricity_mm = { start = 1.25, stop = 1.3, points = 2 }\n"
    )
    cache = tmp_path / "cache"
    out = tmp_path / "map"
    args = ["design", str(study), "--out", str(out), "--figures", "none"]
    result = CliRunner().invoke(app, [*args, "--cache-dir", str(cache)])
    assert result.exit_code == 0, result.output
    assert "4 of 4 FE disc bodies to build (2 geometries, held and free" in " ".join(
        result.output.split()
    )
    assert len(list(cache.glob("influence-*.npz"))) == 4
    ds = xr.load_dataset(out / "design.nc")
    assert ds.attrs["stage_disc_body"] == "fe" and ds.attrs["feasible_candidates"] == 2
    rig = "stage_torsional_rigidity_nm_per_arcmin_min"
    values = ds[rig].values
    assert values[0] != values[1]
    angles = np.deg2rad(load_study(study).base.analysis.crank_angles_deg())
    for e in (1.25, 1.3):
        one = tmp_path / f"e{e:g}.toml"
        one.write_text(base.replace("eccentricity_mm = 1.3", f"eccentricity_mm = {e}", 1))
        inputs = load_study(one).base.to_core()
        assert inputs.design.eccentricity == pytest.approx(e * 1e-3, rel=1e-15)
        free = fe.free_influence(
            inputs.design, inputs.modification, inputs.crank_holes, cache, **COARSE
        )
        held = fe.influence(inputs.design, inputs.modification, inputs.crank_holes, cache, **COARSE)
        case = Case(inputs.design, inputs.modification, None, float(inputs.torque), angles)
        curve = stage_torsion(case, inputs.model().replace(disc_body=free), points=2)
        cell = ds.sel(eccentricity_mm=e)
        assert float(cell[rig]) == pytest.approx(
            np.min(curve.torsional_rigidity) * ARCMIN, rel=1e-12
        )
        assert float(cell["stage_lost_motion_arcmin_max"]) == pytest.approx(
            np.max(curve.lost_motion) / ARCMIN, rel=1e-12
        )
        at = int(np.flatnonzero(curve.stage.torque == inputs.torque)[0])
        hours = bearing_life(curve.stage, inputs.stage, inputs.design.pins)[2][at]
        assert float(cell["stage_l10_h_min"]) == pytest.approx(np.min(hours), rel=1e-12)
        from cyclomesh.drive.solve import solve_drive

        mesh = solve_drive(
            inputs.design,
            inputs.modification,
            None,
            [float(inputs.torque)],
            angles,
            inputs.groove_deformation,
            inputs.discs,
            contact_law=inputs.contact_law,
            disc_body=held,
        )
        stress = mesh.contact_stress[0].max() * 1e-6
        assert float(cell["max_contact_stress_mpa"]) == pytest.approx(stress, rel=1e-12)
    assert len(list(cache.glob("influence-*.npz"))) == 4  # the checks built none
