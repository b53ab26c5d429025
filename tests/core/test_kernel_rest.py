"""The compiled rest positions (numba) give the NumPy reference's bits (issue 27)."""

import numpy as np
import pytest

from cyclomesh import TABLE1, Modification
from cyclomesh.core import kernel
from cyclomesh.core.ltca import CONDITIONED_ARM, rest_position
from cyclomesh.core.pair import PinErrors
from cyclomesh.drive.mesh import rest_positions, stacked_contact

pytest.importorskip("numba")


def test_the_compiled_rest_positions_are_the_references_bit_for_bit():
    """Random rotations with ±inf, NaN and unconditioned arms (the fallback to the
    unconditioned minimum): the same minimum, NaN propagating, as rest_position's."""
    from cyclomesh.core.kernel_contact import rest_arrays

    rng = np.random.default_rng(0)
    for trial in range(200):
        shape = tuple(int(v) for v in rng.integers(1, (4, 6, 50)))
        rot, rev = rng.normal(size=shape), rng.normal(size=shape)
        arm = rng.uniform(-1e-4, 3e-4, shape)
        for arr in (rot, rev):
            arr[rng.random(shape) < 0.1] = np.inf
            arr[rng.random(shape) < 0.1] = -np.inf
            if trial % 5 == 0:
                arr[rng.random(shape) < 0.05] = np.nan
        if trial % 7 == 0:
            arm[:] = 0.0  # no conditioned pin: the unconditioned minimum
        rest, reverse = rest_arrays(rot, rev, arm, CONDITIONED_ARM)
        np.testing.assert_array_equal(rest, rest_position(rot, arm), strict=True)
        np.testing.assert_array_equal(reverse, -rest_position(-rev, arm), strict=True)
        alone, none = rest_arrays(rot, None, arm, CONDITIONED_ARM)
        assert none is None
        np.testing.assert_array_equal(alone, rest, strict=True)


def test_rest_position_takes_the_compiled_pass_with_the_same_bits(monkeypatch):
    """ltca's rest_position on the numba kernel: the reference's bits, broadcast and
    one-dimensional inputs included."""
    rng = np.random.default_rng(1)
    rot = rng.normal(size=(3, 7, 40))
    rot[rng.random(rot.shape) < 0.2] = np.inf
    arm = rng.uniform(-1e-4, 3e-4, (7, 40))
    for args in ((rot, np.broadcast_to(arm, rot.shape)), (rot[0, 0], arm[0])):
        out = {}
        for name in kernel.KERNELS:
            monkeypatch.setenv(kernel.ENV_VAR, name)
            out[name] = rest_position(*args)
        np.testing.assert_array_equal(out["numba"], out["numpy"], strict=True)


def test_a_stacks_rest_positions_agree_on_both_kernels(monkeypatch):
    rng = np.random.default_rng(4)
    errors = PinErrors(radial=rng.uniform(-4e-6, 4e-6, (2, 40)))
    phi = np.deg2rad(np.arange(0.0, 360.0, 7.0))
    geo = stacked_contact(TABLE1, Modification(pin_radius=8e-6), errors, phi, 2)
    out = {}
    for name in kernel.KERNELS:
        monkeypatch.setenv(kernel.ENV_VAR, name)
        out[name] = rest_positions(geo, TABLE1.pins, 2)
    for ref, got in zip(out["numpy"], out["numba"], strict=True):
        assert ref.shape == (2, phi.size)
        np.testing.assert_array_equal(got, ref, strict=True)


def test_the_compiled_overlap_and_contacts_are_the_references_bits(monkeypatch):
    """fields.contact_fields' overlap and contact count of one disc on the numba kernel
    (one compiled pass): the reference's bits, with ±inf reverse rotations and a NaN."""
    from cyclomesh.core.fields import CONTACT_LOAD_FRACTION, count_contacts, overlap
    from cyclomesh.core.kernel_contact import overlap_contacts

    rng = np.random.default_rng(2)
    reverse = rng.normal(size=(2, 9, 40))
    reverse[rng.random(reverse.shape) < 0.2] = -np.inf
    force = np.where(rng.random(reverse.shape) < 0.7, 0.0, rng.uniform(0, 1e3, reverse.shape))
    force[0, 3, :] = 1e-4 * rng.random(40)  # near the threshold of its own row
    force[1, 2, 5] = np.nan
    rotation = rng.normal(size=(2, 9, 1))
    got = overlap_contacts(reverse, rotation, force, CONTACT_LOAD_FRACTION)
    np.testing.assert_array_equal(got[0], overlap(reverse, rotation), strict=True)
    np.testing.assert_array_equal(got[1], count_contacts(force), strict=True)
    assert got[1][1, 2] == 0 and got[1][0, 3] > 0
