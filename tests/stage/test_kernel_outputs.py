"""The stage's outputs after the compiled iteration in one pass
(cyclomesh.stage.kernel_outputs, CYCLOMESH_KERNEL=numba): bit for bit what
cyclomesh.core.fields.contact_fields and cyclomesh.stage.kernel.disc_sums give on the
same forces, whatever subset is asked; and a whole stage's outputs to round-off of the
NumPy reference."""

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
from cyclomesh.core import kernel
from cyclomesh.core.fields import CONTACT_LOAD_FRACTION, contact_fields
from cyclomesh.stage import solve_stage
from cyclomesh.stage.kernel import disc_sums
from cyclomesh.stage.kernel_newton import newton as kernel_newton
from cyclomesh.stage.kernel_outputs import stage_fields

pytest.importorskip("numba")

from tests.stage.test_newton import LIGHT, MOD, RV40, _hard_stage  # noqa: E402

PHI = np.radians(np.arange(0.0, 360.0, 6.0))
LOADED = ("groove_load", "contact_stress", "groove_stress", "contacts")


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


def _captured(monkeypatch, seed):
    """The forces, problem and mesh of a solve_direction of the hard stage (numba)."""
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    seen = []
    real = eq.stage_fields

    def keep(force, block, geo, design, fraction, wanted):
        seen.append((force.copy(), block, geo, design))
        return real(force, block, geo, design, fraction, wanted)

    monkeypatch.setattr(eq, "stage_fields", keep)
    errors, stage = _hard_stage(seed)
    solve_stage(RV40, stage, MOD, errors, [412.0, -LIGHT, LIGHT], PHI, discs=2)
    assert len(seen) == 3
    return seen


@pytest.mark.parametrize("seed", [0, 1])
def test_the_one_pass_is_contact_fields_and_disc_sums_bit_for_bit(monkeypatch, seed):
    for force, block, geo, design in _captured(monkeypatch, seed):
        n1 = force.shape[-1] // 2
        ref = contact_fields(LOADED, design, geo, force[..., :n1], stack_axes=2)
        share, fx, fy, _ = disc_sums(force, block[1], block[2], block[3], force)
        ref.update(torque_share=share, mesh_fx=fx, mesh_fy=fy)
        got = stage_fields(force, block, geo, design, CONTACT_LOAD_FRACTION, set(ref))
        assert set(got) == set(ref)
        for name in ref:
            assert _same(got[name], ref[name]), name
            assert np.array_equal(np.signbit(got[name]), np.signbit(ref[name])), name
        # each the same whatever else is asked
        for name in ref:
            alone = stage_fields(force, block, geo, design, CONTACT_LOAD_FRACTION, {name})
            assert set(alone) == {name} and _same(alone[name], ref[name]), name


def test_a_nan_load_counts_no_contact_and_an_idle_disc_none(monkeypatch):
    force, block, geo, design = _captured(monkeypatch, 0)[0]
    force = force.copy()
    force[3, 0, 5] = np.nan  # a crank angle with a NaN load: no pin counted there
    force[7, 1, :] = 0.0  # a disc that carries nothing
    n1 = force.shape[-1] // 2
    ref = contact_fields(LOADED, design, geo, force[..., :n1], stack_axes=2)
    got = stage_fields(force, block, geo, design, CONTACT_LOAD_FRACTION, set(LOADED))
    for name in LOADED:
        assert _same(got[name], ref[name]), name
    assert np.all(got["contacts"][3] == 0) and got["contacts"][7, 1] == 0
    assert np.all(got["contact_stress"][7, 1] == 0.0)


def test_the_stage_outputs_agree_with_the_reference(monkeypatch):
    """Every output the pass forms, the NumPy path against numba: to round-off."""
    errors, stage = _hard_stage(1)
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = solve_stage(RV40, stage, MOD, errors, [412.0, -LIGHT], PHI, discs=2)
    ref, got = out["numpy"], out["numba"]
    for name in ("groove_load", "contact_stress", "groove_stress", "torque_share", "mesh_force"):
        a, b = getattr(ref, name), getattr(got, name)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a)), name
    assert np.array_equal(ref.contacts, got.contacts)


def _starts(monkeypatch, compiled_start, torques, stage, errors):
    """The bearing phase's starts the compiled iteration asked for (crank angle, start)."""
    monkeypatch.setenv(kernel.ENV_VAR, "numba")
    if not compiled_start:
        monkeypatch.setattr(eq, "compiled_start", lambda *args, **kwargs: None)
    seen = []
    real = kernel_newton  # the module's own (a second call does not wrap the first's)

    def recording(p, law, x, discs, jacobian, settings, found, start, keep):
        def asked(idx):
            got = start(idx)
            seen.append((idx.copy(), got.copy()))
            return got

        return real(p, law, x, discs, jacobian, settings, found, asked, keep)

    monkeypatch.setattr(eq, "kernel_newton", recording)
    out = solve_stage(RV40, stage, MOD, errors, torques, PHI, discs=2)
    return seen, out


@pytest.mark.parametrize("seed", [0, 1])
def test_the_compiled_bearing_start_is_the_numpy_start_bit_for_bit(monkeypatch, seed):
    """stage.kernel.bearing_start (the start of a crank angle the compiled iteration asks
    for, in one pass) against solve_direction's NumPy start: the same starts, bit for
    bit, so the same solution (crankshafts and carrier from geometry, pin and crank hole
    errors, the rated torque and ∓3 % of it: discs that float)."""
    errors, stage = _hard_stage(seed)
    torques = [412.0, -LIGHT, LIGHT]
    got, a = _starts(monkeypatch, True, torques, stage, errors)
    ref, b = _starts(monkeypatch, False, torques, stage, errors)
    assert len(got) == len(ref) >= 3
    for (i, x), (j, y) in zip(got, ref, strict=True):
        assert np.array_equal(i, j) and np.array_equal(x, y)
    for name in ("twist", "bearing_load", "pin_load", "disc_rotation"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
