"""The compiled bearing phase's columns (cyclomesh.stage.kernel_newton._column_rows):
the nonzero columns of every crank bearing's ∂d/∂x and their counts, as the NumPy scan
they replace formed them."""

import numpy as np
import pytest

from cyclomesh.stage import kernel_newton as kn

pytest.importorskip("numba")


def _reference(G):
    A_, D_, N_, two, m_ = G.shape
    nonzero = np.any(G.reshape(A_, -1) != 0.0, axis=0).reshape(D_, N_, two, m_).any(axis=2)
    count = nonzero.sum(-1)
    cols = np.zeros((*count.shape, max(int(count.max()), 1) + 1), np.int64)
    for d in range(D_):
        for k in range(N_):
            cols[d, k, 0] = count[d, k]
            cols[d, k, 1 : 1 + count[d, k]] = np.flatnonzero(nonzero[d, k])
    return nonzero, cols


@pytest.mark.parametrize("case", ["sparse", "nan", "empty", "one_angle"])
def test_the_columns_are_the_numpy_scans(case):
    rng = np.random.default_rng(3)
    A, D, N, m = (1 if case == "one_angle" else 12), 2, 3, 13
    G = np.zeros((A, D, N, 2, m))
    if case != "empty":
        mask = rng.random(G.shape) < 0.08
        G[mask] = rng.normal(size=int(mask.sum()))
        G[-1, 1, 2, 1, m - 1] = -0.0  # a signed zero is no entry
        if case == "nan":
            G[0, 0, 1, 0, 4] = np.nan
    nonzero, cols = kn._kernels_columns()(G)
    ref_nonzero, ref_cols = _reference(G)
    assert np.array_equal(nonzero, ref_nonzero)
    assert cols.dtype == ref_cols.dtype and np.array_equal(cols, ref_cols)
