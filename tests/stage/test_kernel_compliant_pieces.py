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


# --- the Schur complement's L·Δ·Lᵀ (task i43c) ---


def _close_to(ref, got, rtol):
    assert np.max(np.abs(got - ref)) <= rtol * np.max(np.abs(ref))


def _upper_read(S):
    """S with its strict lower triangle spoiled: _ldl reads the upper one only."""
    spoiled = S.copy()
    spoiled[np.tril_indices(S.shape[0], -1)] = np.nan
    return spoiled


def _symmetric(rng, n, kind):
    A = rng.standard_normal((n, n))
    if kind == "spd":
        return A @ A.T + n * np.eye(n)
    # indefinite: eigenvalues of both signs, the pivots far from 0 (no growth)
    A = 0.5 * (A + A.T)
    return A + np.diag(np.where(np.arange(n) % 3 == 1, -1.0, 1.0) * (2.0 * n + 3.0))


@pytest.mark.parametrize("kind", ["spd", "indefinite"])
@pytest.mark.parametrize("n", [1, 2, 7, 20, 33])
def test_the_schur_ldl_is_lapacks(kind, n):
    """_ldl on symmetric S (its upper triangle only read): numpy.linalg.solve's −S⁻¹·rhs
    to 1e-12, its factors kept (piv[0] = −1) and _ldl_solve with them another right-hand
    side's; indefinite S too (the pivots' signs mixed)."""
    kc._kernels()
    rng = np.random.default_rng(100 + n)
    S = _symmetric(rng, n, kind)
    if kind == "indefinite" and n > 2:
        assert np.min(np.linalg.eigvalsh(S)) < 0.0 < np.max(np.linalg.eigvalsh(S))
    b = rng.standard_normal(n)
    W, got, piv, ds = _upper_read(S), np.zeros(n), np.zeros(n, np.int64), np.zeros(n)
    assert kc._ldl(W, b, got, piv, ds)
    assert piv[0] == -1
    np.testing.assert_array_equal(np.triu(W), np.triu(S))  # (the upper triangle kept)
    _close_to(np.linalg.solve(S, -b), got, 1e-12)
    if kind == "spd":  # (Δ: the squares of Cholesky's diagonal)
        np.testing.assert_allclose(1.0 / ds, np.diag(np.linalg.cholesky(S)) ** 2, rtol=1e-10)
    b2 = rng.standard_normal(n)
    again = np.zeros(n)
    kc._ldl_solve(W, b, again, ds)
    np.testing.assert_array_equal(again, got)  # (the same operations as at the factoring)
    kc._ldl_solve(W, b2, again, ds)
    _close_to(np.linalg.solve(S, -b2), again, 1e-12)


@pytest.mark.parametrize("case", ["zero pivot", "growth", "singular"])
def test_the_schur_ldl_falls_back_to_the_lu(case):
    """A first pivot 0 (S indefinite: [[0, 1], [1, 0]]-like) or an L beyond _GROWTH (a
    tiny pivot): S mirrored from its upper triangle and _lu's (row swaps kept, piv[0] ≥
    0), numpy.linalg.solve's to 1e-10, _lu_solve with them another right-hand side's; S
    singular: False."""
    kc._kernels()
    rng = np.random.default_rng(21)
    n = 9
    S = _symmetric(rng, n, "indefinite")
    if case == "zero pivot":
        S[0, 0] = 0.0
    elif case == "growth":
        S[2, 2] = 1e-6 * abs(S[2, 5])
        S[2, 2] += S[:2, 2] @ np.linalg.solve(S[:2, :2], S[:2, 2])  # (Δ_2 tiny)
    else:
        S[:, 4] = 0.0
        S[4, :] = 0.0
    b = rng.standard_normal(n)
    W, got, piv, ds = _upper_read(S), np.zeros(n), np.zeros(n, np.int64), np.zeros(n)
    ok = kc._ldl(W, b, got, piv, ds)
    if case == "singular":
        assert not ok
        return
    assert ok and piv[0] >= 0
    _close_to(np.linalg.solve(S, -b), got, 1e-10)
    b2 = rng.standard_normal(n)
    again = np.zeros(n)
    kc._lu_solve(W, b2, again, piv)
    _close_to(np.linalg.solve(S, -b2), again, 1e-10)
