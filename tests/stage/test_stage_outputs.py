"""What a stage solve is asked for (cyclomesh.stage.solve.solve ``outputs``) and what a
tolerance ring reads of it: every output asked for is the full solve's, bit for bit, on
both kernels (the work split, the groove and disc fields, the disc positions left out);
a tolerance ring's stage metrics are those of the same ring solved in full, as
``cyclomesh run`` solves it."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cyclomesh.core import kernel
from cyclomesh.core.case import Case, Model
from cyclomesh.drive.torsion import LOST_MOTION_FRACTION
from cyclomesh.stage.solve import OUTPUTS, bearing_life, solve
from cyclomesh.tolerance.sampling import RingErrors
from cyclomesh.tolerance.tasks import STAGE_OUTPUTS
from tests.stage.rv40 import RV40
from tests.stage.test_newton import LIGHT, MOD, _hard_stage

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"
PHI = np.radians(np.arange(0.0, 360.0, 6.0))
TORQUES = np.array([412.0, -LIGHT, LIGHT])


def _kernels():
    names = ["numpy"]
    try:
        import numba  # noqa: F401

        names.append("numba")
    except ImportError:  # pragma: no cover
        pass
    return names


def _same(a, b, name):
    assert a.shape == b.shape, name
    np.testing.assert_array_equal(a, b, err_msg=name, strict=True)


@pytest.mark.parametrize("name", _kernels())
@pytest.mark.parametrize("seed", [0, 3])
def test_each_output_asked_for_is_the_full_solves(monkeypatch, name, seed):
    """Both rings have a disc that carries nothing at ±3 % at some crank angles (seed 0:
    27 and 17 of 60, seed 3: 3; its loads reported as 0, its position canonical in the
    full solve and left as solved here)."""
    monkeypatch.setenv(kernel.ENV_VAR, name)
    errors, stage = _hard_stage(seed)
    case, model = Case(RV40, MOD, errors, TORQUES, PHI), Model(discs=2, stage=stage)
    full = solve(case, model)
    for asked in (STAGE_OUTPUTS, ("pin_load", "work"), ("bearing_load_angle", "twist")):
        part = solve(case, model, positions=False, outputs=asked)
        for field in OUTPUTS:
            got = getattr(part, field)
            if field not in asked:
                assert got is None, field
            elif field == "work":
                assert got.keys() == full.work.keys()
                for key in got:
                    _same(got[key], full.work[key], key)
            else:
                _same(got, getattr(full, field), field)


@pytest.mark.parametrize("name", _kernels())
def test_outputs_at_some_torques_only(monkeypatch, name):
    """``only_at``: the contact stress at the rated torque alone (a tolerance ring's), the
    full solve's there bit for bit and NaN at ∓3 %; the other outputs at every torque."""
    monkeypatch.setenv(kernel.ENV_VAR, name)
    errors, stage = _hard_stage(0)
    case, model = Case(RV40, MOD, errors, TORQUES, PHI), Model(discs=2, stage=stage)
    full = solve(case, model, outputs=STAGE_OUTPUTS)
    part = solve(case, model, outputs=STAGE_OUTPUTS, only_at={"contact_stress": [0]})
    _same(part.contact_stress[0], full.contact_stress[0], "contact_stress")
    assert np.all(np.isnan(part.contact_stress[1:]))
    _same(part.transmission_error, full.transmission_error, "transmission_error")
    _same(part.bearing_load, full.bearing_load, "bearing_load")
    with pytest.raises(ValueError, match="not asked for"):
        solve(case, model, outputs=STAGE_OUTPUTS, only_at={"pin_load": [0]})


def test_unknown_outputs_are_refused():
    errors, stage = _hard_stage(0)
    with pytest.raises(ValueError, match="unknown outputs"):
        solve(Case(RV40, MOD, errors, 412.0, PHI), Model(discs=2, stage=stage), outputs=["te"])


TOLERANCE = """
[tolerance]
seed = 3
allowable_contact_stress_mpa = 2500.0
crank_step_deg = 6.0
radial_um = { distribution = "uniform", half_range = 2.0 }
angular_urad = { distribution = "uniform", half_range = 20.0 }
hole_radial_um = { distribution = "uniform", half_range = 3.0 }
hole_tangential_um = { distribution = "normal", sigma = 2.0 }
"""


@pytest.mark.parametrize("name", _kernels())
def test_a_tolerance_rings_stage_metrics_are_the_full_solves(monkeypatch, tmp_path, name):
    """RingModel.metrics of a block of rings of examples/rv_stage.toml (the stage solves
    ask for what they read; the meshes formed once per ring and shared with the mesh
    alone) against the full solve of each ring at the torque and ∓3 % of it, as cyclomesh
    run solves a ring's study file: the same bits."""
    from cyclomesh.core.pair import pin_errors_si
    from cyclomesh.studies.rings import load_tolerance_study, ring_model
    from cyclomesh.units import M_PER_UM, RAD_PER_ARCMIN

    monkeypatch.setenv(kernel.ENV_VAR, name)
    text = EXAMPLE.read_text()
    path = tmp_path / "tol.toml"
    path.write_text(text[: text.index("[[cases]]")] + TOLERANCE)
    model = ring_model(*load_tolerance_study(path))
    rings = 3
    drawn = model.draw(np.arange(rings))
    assert isinstance(drawn, RingErrors)
    got = model.metrics(drawn)
    total = model.total_errors_um(drawn)
    phi = np.deg2rad(model.crank_angles_deg)
    light = LOST_MOTION_FRACTION * model.torque_nm
    for i in range(rings):
        stage = dataclasses.replace(
            model.stage,
            hole_error_radial=total["hole_radial_um"][i] * M_PER_UM,
            hole_error_tangential=total["hole_tangential_um"][i] * M_PER_UM,
        )
        errors = pin_errors_si(
            *(total[k][i] for k in ("radial_um", "angular_urad", "pin_radius_um")),
            total["eccentricity_um"][i],
        )
        full = solve(
            Case(model.design, model.modification, errors, [model.torque_nm, -light, light], phi),
            Model(model.contact_law, model.groove_deformation, "rigid", model.discs, stage),
        )
        te = full.transmission_error
        want = {
            "stage_lost_motion_arcmin_max": np.max(te[1] - te[2]) / RAD_PER_ARCMIN,
            "stage_max_crank_bearing_load_n": np.max(full.bearing_load[0]),
            "stage_max_contact_stress_mpa": np.max(full.contact_stress[0]) * 1e-6,
            "stage_l10_h_min": np.min(bearing_life(full, stage, model.design.pins)[2][0]),
        }
        for key, value in want.items():
            assert got[key][i] == value, (key, i)
