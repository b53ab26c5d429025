"""The compiled contact fields of a stack (numba) give the NumPy reference's bits (issue 27):
``overlap``, ``contacts``, ``torque_share`` and ``mesh_force_x``/``_y`` of
:func:`cyclomesh.core.fields.contact_fields` in one pass, NumPy's sums in NumPy's order."""

from types import SimpleNamespace

import numpy as np
import pytest

from cyclomesh.core import kernel
from cyclomesh.core.fields import contact_fields

pytest.importorskip("numba")

WHAT = ("overlap", "contacts", "torque_share", "mesh_force")


def _both(monkeypatch, *args, **kwargs):
    out = {}
    for name in ("numpy", "numba"):
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = contact_fields(*args, **kwargs)
    return out["numpy"], out["numba"]


def _case(rng, shape, stack_axes):
    force = np.where(rng.random(shape) < 0.7, 0.0, rng.uniform(0, 1e3, shape))
    force *= np.exp(rng.normal(0, 8, shape))  # magnitudes far apart: the order of the sums
    reverse = rng.normal(size=shape)
    reverse[rng.random(shape) < 0.2] = -np.inf
    geo = SimpleNamespace(reverse_rotation=reverse, moment_arm=rng.normal(0, 1e-2, shape))
    normal = (rng.normal(size=shape), rng.normal(size=shape))
    rows = (*shape[:-stack_axes], *(1,) * stack_axes)
    return geo, force, normal, rng.normal(size=rows)


@pytest.mark.parametrize("pins", [1, 5, 7, 8, 9, 13, 16, 40, 41, 127, 128, 129])
@pytest.mark.parametrize("stack_axes", [1, 2])
def test_the_compiled_stack_fields_are_the_references_bits(monkeypatch, pins, stack_axes):
    """Random stacks (1–3 discs), loads over 16 decades with zeros, a NaN in one row;
    129 pins (beyond NumPy's one block of pairwise summation) fall back to NumPy."""
    rng = np.random.default_rng(pins + 1000 * stack_axes)
    for discs in (1, 2, 3) if stack_axes == 2 else (1,):
        shape = (3, 5, discs, pins) if stack_axes == 2 else (3, 5, pins)
        geo, force, normal, rotation = _case(rng, shape, stack_axes)
        force.reshape(-1, pins)[4, pins // 2] = np.nan
        ref, got = _both(
            monkeypatch,
            WHAT,
            None,
            geo,
            force,
            rotation=rotation,
            normal=normal,
            stack_axes=stack_axes,
        )
        assert (
            sorted(got)
            == sorted(ref)
            == sorted(["overlap", "contacts", "torque_share", "mesh_force_x", "mesh_force_y"])
        )
        for name in ref:
            np.testing.assert_array_equal(got[name], ref[name], strict=True, err_msg=name)
            assert np.array_equal(np.signbit(got[name]), np.signbit(ref[name])), name


def test_the_compiled_stack_fields_take_what_is_asked(monkeypatch):
    """Each field alone, a separate moment arm, and arrays of other shapes (the stage's
    opposite flanks, a rotation per pin): the reference's fields, the same bits."""
    rng = np.random.default_rng(7)
    shape = (2, 6, 2, 40)
    geo, force, normal, rotation = _case(rng, shape, 2)
    for what in (("overlap",), ("contacts",), ("torque_share",), ("mesh_force",), WHAT):
        ref, got = _both(
            monkeypatch, what, None, geo, force, rotation=rotation, normal=normal, stack_axes=2
        )
        assert sorted(got) == sorted(ref)
        for name in ref:
            np.testing.assert_array_equal(got[name], ref[name], strict=True)
    arm = rng.normal(size=shape)
    ref, got = _both(monkeypatch, ("torque_share",), None, geo, force, moment_arm=arm, stack_axes=2)
    np.testing.assert_array_equal(got["torque_share"], ref["torque_share"], strict=True)
    per_pin = rng.normal(size=shape)  # not one rotation per row: NumPy's broadcast
    ref, got = _both(monkeypatch, ("overlap",), None, geo, force, rotation=per_pin, stack_axes=2)
    np.testing.assert_array_equal(got["overlap"], ref["overlap"], strict=True)
    wide = (rng.normal(size=(2, 6, 2, 41)),) * 2  # normals and arms given apart from geo
    ref, got = _both(
        monkeypatch, ("mesh_force",), None, geo, np.pad(force, [(0, 0)] * 3 + [(0, 1)]),
        normal=wide, moment_arm=wide[0], stack_axes=2,
    )  # fmt: skip
    np.testing.assert_array_equal(got["mesh_force_x"], ref["mesh_force_x"], strict=True)


def test_no_contacts_at_all(monkeypatch):
    """Empty stacks and rows of zero loads: the reference's empty arrays and zeros."""
    rng = np.random.default_rng(3)
    for shape in ((0, 4, 2, 40), (2, 3, 2, 40)):
        geo, force, normal, rotation = _case(rng, shape, 2)
        force[:] = 0.0
        ref, got = _both(
            monkeypatch, WHAT, None, geo, force, rotation=rotation, normal=normal, stack_axes=2
        )
        for name in ref:
            np.testing.assert_array_equal(got[name], ref[name], strict=True)
