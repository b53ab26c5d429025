"""Both meshes of a stack (forward and mirror problem) from one compiled contact pass:
the same bits as each problem's own (drive.mesh._formed_pair, core.contact.
unloaded_contact_stack, kernel_contact's per-problem crank angles)."""

import dataclasses

import numpy as np
import pytest

from cyclomesh import TABLE1, DesignError, Modification, PinErrors
from cyclomesh.core.contact import UnloadedContact, unloaded_contact, unloaded_contact_stack
from cyclomesh.core.ltca import pin_compliance
from cyclomesh.drive.mesh import stack_meshes, stacked_contact
from cyclomesh.drive.mirror import mirror_problem
from tests.drive.test_drive import ring_errors

TPM = Modification(pin_radius=8e-6)
PHI = np.deg2rad(np.arange(0.0, 360.0, 5.0))


ERRORS = {
    "none": PinErrors(),
    "ring": ring_errors(3),
    "rings": ring_errors(5, (2,)),
}


def assert_contact_equal(got: UnloadedContact, want: UnloadedContact) -> None:
    for name in UnloadedContact.__dataclass_fields__:
        x, y = getattr(got, name), getattr(want, name)
        if y is None:
            assert x is None, name
            continue
        assert x.shape == y.shape, name
        assert np.array_equal(x, y, equal_nan=True), name


@pytest.mark.parametrize("errors", sorted(ERRORS))
@pytest.mark.parametrize("normals", [True, False])
def test_a_stack_of_problems_is_each_problem_alone_bit_for_bit(monkeypatch, errors, normals):
    """unloaded_contact_stack: problem p's arrays at [p], each unloaded_contact's of that
    problem bit for bit (its own pins and crank angles, rings too), C-contiguous."""
    pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    errs = ERRORS[errors]
    mod = Modification(pin_radius=8e-6, rotation=2e-5)
    _, errs_m = mirror_problem(mod, errs, TABLE1.pins)
    problems = [(errs, PHI), (errs_m, -PHI[::-1]), (errs, PHI + 0.1)]
    got = unloaded_contact_stack(TABLE1, mod, problems, normals=normals)
    assert got is not None
    for p, (e, phi) in enumerate(problems):
        want = unloaded_contact(TABLE1, mod, e, phi, normals=normals)
        part = UnloadedContact(
            **{
                name: None if getattr(got, name) is None else getattr(got, name)[p]
                for name in UnloadedContact.__dataclass_fields__
            }
        )
        assert_contact_equal(part, want)
        assert part.rotation.flags.c_contiguous


def test_a_stack_of_problems_is_refused_where_the_compiled_pass_does_not_apply(monkeypatch):
    """None (each problem then formed alone) on the NumPy kernel, with a profile
    deviation, with ring shapes or numbers of crank angles that differ, and where the
    compiled pass refuses a case (a jammed pin)."""
    pytest.importorskip("numba")
    from cyclomesh.core.deviation import ProfileDeviation

    monkeypatch.setenv("CYCLOMESH_KERNEL", "numpy")
    assert unloaded_contact_stack(TABLE1, TPM, [(None, PHI), (None, PHI)]) is None
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    angle = np.deg2rad(np.linspace(-180.0, 180.0, 73))
    profiled = Modification(pin_radius=8e-6, profile=ProfileDeviation(angle, 1e-6 + 0 * angle))
    assert unloaded_contact_stack(TABLE1, profiled, [(None, PHI), (None, PHI)]) is None
    assert unloaded_contact_stack(TABLE1, TPM, [(None, PHI), (ERRORS["rings"], PHI)]) is None
    assert unloaded_contact_stack(TABLE1, TPM, [(None, PHI), (None, PHI[1:])]) is None
    jammed = PinErrors(pin_radius=np.r_[20e-6, np.zeros(TABLE1.pins - 1)])
    assert unloaded_contact_stack(TABLE1, TPM, [(None, PHI), (jammed, PHI)]) is None


@pytest.mark.parametrize("errors", sorted(ERRORS))
@pytest.mark.parametrize("flags", [(True, True, True), (False, True, False), (True, False, True)])
def test_both_meshes_from_one_pass_are_each_mesh_alone(monkeypatch, errors, flags):
    """stack_meshes with numba forms the forward and the mirror problem's contact and
    compliance in one pass each: every array of both meshes is the one of the problem
    formed alone (stacked_contact and pin_compliance of its own), bit for bit, with and
    without normals, rests and force angles."""
    pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    normals, force_angle, rests = flags
    errs = ERRORS[errors]
    fwd, rev = stack_meshes(
        TABLE1, TPM, errs, PHI, 2, True, True, True, "half_plane", None, force_angle,
        normals=normals, reverse_rests=rests,
    )  # fmt: skip
    mod_m, errs_m = mirror_problem(TPM, errs, TABLE1.pins)
    for mesh, e, phi in ((fwd, errs, PHI), (rev, errs_m, -PHI[::-1])):
        geo = stacked_contact(TABLE1, TPM, e, phi, 2, normals)
        assert_contact_equal(mesh.geo, geo)
        alpha, gamma = pin_compliance(geo, TABLE1, True, "half_plane")
        flat = (*geo.rotation.shape[:-2], 2 * TABLE1.pins)
        assert np.array_equal(mesh.alpha, alpha.reshape(flat))
        assert np.array_equal(mesh.gamma, gamma.reshape(flat))
    # and the meshes as the NumPy-free reference of the same kernel forms them one by one
    alone = stack_meshes(
        TABLE1, TPM, errs, PHI, 2, True, True, False, "half_plane", None, force_angle,
        normals=normals,
    )[0]  # fmt: skip
    for field in dataclasses.fields(alone):
        x, y = getattr(fwd, field.name), getattr(alone, field.name)
        if isinstance(y, np.ndarray):
            assert np.array_equal(x, y, equal_nan=True), field.name


def test_a_jammed_pin_in_both_meshes_raises_as_before(monkeypatch):
    """A case the compiled pass refuses goes through each problem alone, which raises the
    reference's one-line error."""
    pytest.importorskip("numba")
    monkeypatch.setenv("CYCLOMESH_KERNEL", "numba")
    jammed = PinErrors(pin_radius=np.r_[20e-6, np.zeros(TABLE1.pins - 1)])
    with pytest.raises(DesignError, match="overlaps the disc"):
        stack_meshes(TABLE1, TPM, jammed, PHI, 2, True, True, True)
