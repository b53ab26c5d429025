"""stage.kernel_body (the compliant disc's Hessian products compiled) against the NumPy
reference's products (stage.assembly._body_pins, _evaluate_supported), on random arrays
with open pins (stiffness 0), zero columns of ∂d/∂x and with and without crankshafts."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from cyclomesh.stage.assembly import _shaft_entries  # noqa: E402
from cyclomesh.stage.kernel_body import (  # noqa: E402
    bearing_hessian,
    body_pin_hessian,
    hessian_noise,
)


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("closed", [0.0, 0.3, 1.0])
def test_body_pin_hessian_is_the_references(closed):
    rng = np.random.default_rng(1)
    n, D, P, lam, a = 5, 2, 9, 7, 3
    m = 1 + 3 * D + D * lam
    z0 = m - D * lam
    k = rng.uniform(1e7, 1e9, (n, D, P)) * (rng.uniform(size=(n, D, P)) < closed)
    w = rng.standard_normal((n, D, P, lam))
    cols = rng.standard_normal((n, D, a, P))
    energy = rng.standard_normal((n, D, lam, lam)) * 1e8
    H0 = rng.standard_normal((n, m, m))
    ref = H0.copy()
    for d in range(D):  # stage.assembly._body_pins's products
        zi = slice(z0 + d * lam, z0 + (d + 1) * lam)
        kw = k[:, d, :, None] * w[:, d]
        ref[:, zi, zi] += np.matmul(np.swapaxes(w[:, d], 1, 2), kw) + energy[:, d]
        v = -np.matmul(cols[:, d], kw)
        ref[:, 1 + 3 * d : 1 + 3 * d + a, zi] += v
        ref[:, zi, 1 + 3 * d : 1 + 3 * d + a] += np.swapaxes(v, 1, 2)
    got = H0.copy()
    body_pin_hessian(got, k, w, cols, energy, z0)
    assert _rel(got, ref) <= 1e-14
    if closed == 0.0:  # no closed pin: E alone
        np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("shafts", [False, True])
def test_bearing_hessian_is_the_references(shafts):
    rng = np.random.default_rng(2)
    n, D, N, m = 4, 2, 3, 40
    G = rng.standard_normal((n, D, N, 2, m))
    G[..., 5:9] = 0.0  # columns of other discs' unknowns
    G[0, :, :, 0, 11] = 0.0  # one row's own zero
    kxx, kyy = rng.uniform(1e7, 1e9, (2, n, D, N))
    kxy = rng.uniform(-1e8, 1e8, (n, D, N))
    kxx[1, 0, 2] = kyy[1, 0, 2] = kxy[1, 0, 2] = 0.0  # a bearing at zero load
    stiffness = rng.uniform(1e7, 1e8, (D, D)) if shafts else None
    base = 7
    H0 = rng.standard_normal((n, m, m))
    kmat = np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)
    rows = G.reshape(n, -1, m)
    ref = H0 + np.matmul(np.swapaxes(rows, -1, -2), np.matmul(kmat, G).reshape(n, -1, m))
    if shafts:
        r, c, v = _shaft_entries(stiffness, base, 2 * N)
        ref[:, r, c] += v
    got = H0.copy()
    bearing_hessian(got, G, kxx, kyy, kxy, stiffness, base)
    assert _rel(got, ref) <= 1e-14


def test_hessian_noise_is_the_references():
    rng = np.random.default_rng(3)
    H = rng.standard_normal((6, 30, 30)) * np.logspace(-3, 9, 30)
    xs = np.abs(rng.standard_normal((6, 30)))
    xs[2] = 0.0
    ref = 16.0 * np.finfo(float).eps * np.matmul(np.abs(H), xs[..., None])[..., 0]
    got = hessian_noise(H, xs)
    np.testing.assert_array_equal(got[2], 0.0)
    assert np.max(np.abs(got - ref) / np.where(ref > 0, ref, 1.0)) <= 1e-14
