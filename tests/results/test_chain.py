"""One chain (cyclomesh.results.chain.run) from a Case and a Model: the same numbers as the
public API it stands behind (analyse, stiffness, solve_ltca, solve_drive, solve_stage)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from cyclomesh import TABLE1, Modification, PinErrors, analyse, stiffness
from cyclomesh.core.case import Case, Model
from cyclomesh.core.ltca import ltca, solve_ltca
from cyclomesh.exceptions import DesignError
from cyclomesh.results.chain import run
from cyclomesh.stage.bearing import RollerSet
from cyclomesh.stage.solve import StageDesign, solve_stage
from tests.stage.rv40 import HOLES

TPM = Modification(pin_radius=8e-6)
PHI_DEG = np.arange(0.0, 9.0, 1.5)
CASE = Case(TABLE1, TPM, None, 250.0, np.deg2rad(PHI_DEG))


def test_loads_are_those_of_analyse_for_a_stack_and_a_torque_list():
    case = CASE.replace(torque=[-250.0, 250.0])
    got = run(case, Model(discs=2)).to_dataset()
    want = analyse(TABLE1, TPM, torque=[-250.0, 250.0], crank_angles=case.crank_angles, discs=2)
    xr.testing.assert_identical(got, want)


def test_summary_is_that_of_summarize():
    from cyclomesh import summarize

    want = summarize(analyse(TABLE1, TPM, torque=250.0, crank_angles=CASE.crank_angles))
    got = run(CASE, Model()).summary()
    assert set(got) == set(want.data_vars)
    for name, value in got.items():
        assert value == want[name].values[()], name


def test_torsion_is_that_of_stiffness():
    got = run(CASE, Model(contact_law="paper"), "torsion", points=5).to_dataset()
    want = stiffness(TABLE1, TPM, None, 250.0, 5, CASE.crank_angles, contact_law="paper")
    xr.testing.assert_identical(got, want)
    summary = run(CASE, Model(), "torsion", points=5).summary()
    assert summary["lost_motion_arcmin_max"] > 0


def test_solve_ltca_is_the_chain_of_a_case_and_a_model():
    errors = PinErrors(radial=np.linspace(-3e-6, 3e-6, TABLE1.pins))
    a = solve_ltca(TABLE1, TPM, errors, 250.0, CASE.crank_angles, False, "paper")
    b = ltca(CASE.replace(errors=errors), Model("paper", groove_deformation=False))
    for name in a.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    with pytest.raises(DesignError, match="one disc"):
        ltca(CASE, Model(discs=2))


def test_the_stage_goes_through_the_same_chain_and_reports_the_groove_stress():
    stage = StageDesign(
        HOLES,
        RollerSet(14, 4e-3, 9e-3, 5e-6, 22e-3),
    )
    case = CASE.replace(torque=[-250.0, 250.0])
    result = run(case, Model(discs=2, stage=stage))
    want = solve_stage(TABLE1, stage, TPM, None, [-250.0, 250.0], case.crank_angles, discs=2)
    for name in want.__dataclass_fields__:
        got, ref = getattr(result.solution, name), getattr(want, name)
        if isinstance(ref, dict):  # the work of every part (Stage.work)
            assert got.keys() == ref.keys(), name
            for part in ref:
                np.testing.assert_array_equal(got[part], ref[part], err_msg=f"{name} {part}")
        else:
            np.testing.assert_array_equal(got, ref, err_msg=name)
    assert np.all(want.groove_stress > 0) or np.any(want.pin_load == 0)
    np.testing.assert_array_equal(want.groove_stress > 0, want.pin_load > 0)
    ds = result.to_dataset()
    assert ds["stage_groove_stress"].attrs["units"] == "MPa"
    with pytest.raises(DesignError, match="what must be one of"):
        run(case, Model(), what="efficiency")


def test_the_stage_takes_the_disc_body_through_the_model_and_names_what_is_missing():
    """Nothing in the chain stops a DiscBody on its way to the stage: Model carries it,
    check() accepts it (half-plane law, teeth match), and the stage refuses it in one
    line: the stage's compliant disc is the FreeDiscBody (hole centres free), not the
    DiscBody held at its holes."""
    from cyclomesh.core.discbody import DiscBody

    body = DiscBody(np.linspace(-np.pi, 0.0, 5), np.zeros((1, TABLE1.teeth, 5, 5)), TABLE1.teeth)
    stage = StageDesign(HOLES)
    with pytest.raises(DesignError, match=r"^stage: the compliant disc needs the crank-hole"):
        run(CASE, Model(disc_body=body, discs=2, stage=stage))
    # the same body and model without the stage: the mesh takes it (zero compliance: the
    # rigid disc's loads)
    coupled = run(CASE, Model(disc_body=body)).solution
    rigid = run(CASE, Model()).solution
    np.testing.assert_allclose(coupled.pin_load, rigid.pin_load, rtol=1e-9, atol=1e-9)
