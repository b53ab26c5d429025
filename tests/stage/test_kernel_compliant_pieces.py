"""Pieces of stage.kernel_compliant's compiled evaluation and step (task i42c) against
their plain forms, bit for bit: _dots (the pins' body shifts and E·z, four rows' sums at
a time) and _lu's row updates (kernel_newton._solve_in_place's operations)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from cyclomesh.stage import kernel_compliant as kc  # noqa: E402
from cyclomesh.stage import kernel_newton as kn  # noqa: E402


def _plain_dots(M, x, z):
    """Each row's sum from 0 in order (the loop _dots replaced)."""
    out = np.zeros(M.shape[0])
    for q in range(M.shape[0]):
        acc = 0.0
        for s in range(M.shape[1]):
            acc += M[q, s] * x[z + s]
        out[q] = acc
    return out


@pytest.mark.parametrize("rows", [0, 1, 3, 4, 5, 8, 23, 26])
def test_dots_are_the_rows_sums_in_order(rows):
    """_dots: every row's sum the plain loop's bits, whatever the rows' count modulo 4,
    written at its offset and nowhere else."""
    kc._kernels()
    rng = np.random.default_rng(rows)
    lam, z = 26, 7
    M = rng.standard_normal((rows, lam)) * 10.0 ** rng.integers(-8, 8, (rows, lam))
    x = rng.standard_normal(z + lam + 3)
    out = np.full(rows + 9, np.nan)
    kc._dots(M, x, z, out, 5)
    np.testing.assert_array_equal(out[5 : 5 + rows], _plain_dots(M, x, z))
    assert np.all(np.isnan(out[:5])) and np.all(np.isnan(out[5 + rows :]))


def test_dots_on_a_disc_row_view():
    """_dots on a (Q, lam) view of a 4-D array (Body.w[i, d], Body.energy[i, d])."""
    kc._kernels()
    rng = np.random.default_rng(3)
    W = rng.standard_normal((3, 2, 23, 26))
    x = rng.standard_normal(72)
    out = np.zeros(2 * 23)
    for d in range(2):
        kc._dots(W[1, d], x, 20 + 26 * d, out, 23 * d)
        np.testing.assert_array_equal(
            out[23 * d : 23 * (d + 1)], _plain_dots(W[1, d], x, 20 + 26 * d)
        )


@pytest.mark.parametrize("n", [1, 2, 7, 20, 33])
def test_the_lu_by_row_views_is_solve_in_place(n):
    """_lu (its row updates through 1-D views) against kernel_newton._solve_in_place bit
    for bit, sparse rows (multipliers 0: skipped) and a row swap at every step."""
    kc._kernels()
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    A[rng.random((n, n)) < 0.4] = 0.0
    A += np.diag(np.where(np.arange(n) % 2, 0.0, 1e-3))  # (some small pivots: swaps)
    b = rng.standard_normal(n)
    ref = np.zeros(n)
    ok_ref = kn._solve_in_place(A.copy(), b, ref)
    got, piv = np.zeros(n), np.zeros(n, np.int64)
    ok = kc._lu(A.copy(), b, got, piv)
    assert ok == ok_ref
    if ok:
        np.testing.assert_array_equal(got, ref)
