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
