"""The compliant disc's Hessian compiled (numba), beside the NumPy reference.

With ``CYCLOMESH_KERNEL=numba`` (the one switch of :mod:`cyclomesh.core.kernel`) the
assembly of the compliant disc's stage (:func:`cyclomesh.stage.assembly.evaluate` with
:class:`~cyclomesh.stage.assembly.Body`) forms the two products of its Hessian that the
NumPy reference forms as dense batched matrix products, one crank angle at a time, on
their nonzero terms only:

* the body at the pins (:func:`body_pin_hessian`, the reference's
  :func:`~cyclomesh.stage.assembly._body_pins`): ∂²Π/∂z² = Wᵀ·diag(k)·W + E and
  ∂²Π/∂(θ·r_c, u)∂z = −Aᵀ·diag(k)·W of each disc, the sums over the closed pins only
  (an open pin's stiffness is 0: its terms are exact zeros);
* the crank bearings (:func:`bearing_hessian`, :func:`~cyclomesh.stage.assembly.
  _evaluate_supported`'s Gᵀ·K·G over the holes' (x, y)), each hole's 2×2 stiffness on
  the columns of ∂d/∂x that are not 0 (the disc's, its crankshaft's, the end plate's
  and its body unknowns), and the crankshafts' K ⊗ I(2N).

The products are the reference's element by element, the closed pins' rank-one terms
summed in order, the holes' terms added to H hole by hole (the reference's BLAS sums in
its own order and adds the total): the Hessian agrees to round-off, and Newton's iteration runs
to the root at round-off on both paths (``tests/stage/test_stage_fe.py``).
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.jit import njit

__all__ = ["body_pin_hessian", "bearing_hessian", "hessian_noise"]

FloatArray = NDArray[np.float64]


@cache
def _kernels() -> tuple[Any, Any, Any]:
    jit = njit()
    return jit(_body_pin_rows), jit(_bearing_rows), jit(_noise_rows)


def hessian_noise(H: FloatArray, xs: FloatArray) -> FloatArray:
    """16·eps·|H|·|x| (n, m) of :func:`cyclomesh.stage.newton.newton`'s convergence test
    (the round-off of the residual at the unknowns' own round-off) without forming |H|:
    each row's sum in order (the reference's BLAS product sums in its own order)."""
    out = np.empty(xs.shape)
    _kernels()[2](np.ascontiguousarray(H), np.ascontiguousarray(xs), out)
    return out


def _noise_rows(H, xs, out):  # pragma: no cover (compiled)
    n, m, _ = H.shape
    scale = 16.0 * np.finfo(np.float64).eps
    for i in range(n):
        for r in range(m):
            acc = 0.0
            for c in range(m):
                acc += abs(H[i, r, c]) * xs[i, c]
            out[i, r] = scale * acc


def body_pin_hessian(
    H: FloatArray,
    k: FloatArray,
    w: FloatArray,
    cols: FloatArray,
    energy: FloatArray,
    z0: int,
) -> None:
    """Adds the compliant disc's terms at the pins to the Hessian ``H`` (n, m, m) in place.

    ``k`` (n, D, P): the pins' stiffness [N/m]; ``w`` (n, D, P, Λ): ∂(C'λ)/∂z at every pin
    (:attr:`Body.pin_w`); ``cols`` (n, D, a, P): ∂δ/∂(θ·r_c, u) of every pin; ``energy``
    (n, D, Λ, Λ): E; ``z0``: the first body unknown. Per disc d (its Λ unknowns from
    z0 + d·Λ, its a unknowns from 1 + 3d): H_zz += Wᵀ·diag(k)·W + E, H_uz += −A·diag(k)·W
    and its transpose (the reference: :func:`~cyclomesh.stage.assembly._body_pins`).
    """
    _kernels()[0](
        H,
        np.ascontiguousarray(k),
        np.ascontiguousarray(w),
        np.ascontiguousarray(cols),
        np.ascontiguousarray(energy),
        z0,
    )


def _body_pin_rows(H, k, w, cols, energy, z0):  # pragma: no cover (compiled)
    n, D, P, lam = w.shape
    a = cols.shape[2]
    kw = np.empty(lam)
    zz = np.empty((lam, lam))  # Wᵀ·diag(k)·W of one disc, summed over the closed pins
    za = np.empty((a, lam))  # A·diag(k)·W
    for i in range(n):
        for d in range(D):
            zz[:, :] = 0.0
            za[:, :] = 0.0
            for p in range(P):  # rank-one terms of the closed pins, in order
                kp = k[i, d, p]
                if kp == 0.0:
                    continue
                for s in range(lam):
                    kw[s] = kp * w[i, d, p, s]
                for r in range(lam):
                    wr = w[i, d, p, r]
                    for s in range(lam):
                        zz[r, s] += wr * kw[s]
                for r in range(a):
                    cr = cols[i, d, r, p]
                    for s in range(lam):
                        za[r, s] += cr * kw[s]
            zi = z0 + d * lam
            for r in range(lam):
                for s in range(lam):
                    H[i, zi + r, zi + s] += zz[r, s] + energy[i, d, r, s]
            base = 1 + 3 * d
            for r in range(a):
                for s in range(lam):
                    H[i, base + r, zi + s] -= za[r, s]
                    H[i, zi + s, base + r] -= za[r, s]


def bearing_hessian(
    H: FloatArray,
    G: FloatArray,
    kxx: FloatArray,
    kyy: FloatArray,
    kxy: FloatArray,
    stiffness: FloatArray | None,
    base: int,
) -> None:
    """Adds the crank bearings' Gᵀ·K·G (and the crankshafts' K ⊗ I(2N) at ``base``, with
    ``stiffness`` (D, D) [N/m]) to the Hessian ``H`` (n, m, m) in place.

    ``G`` (n, D, N, 2, m): ∂d/∂x of every hole (:func:`~cyclomesh.stage.assembly.
    bearing_jacobian`); ``kxx``, ``kyy``, ``kxy`` (n, D, N): each bearing's 2×2 stiffness
    [N/m] (the reference: :func:`~cyclomesh.stage.assembly._evaluate_supported`).
    """
    shafts = np.zeros((0, 0)) if stiffness is None else np.ascontiguousarray(stiffness, float)
    _kernels()[1](
        H,
        np.ascontiguousarray(G),
        np.ascontiguousarray(kxx),
        np.ascontiguousarray(kyy),
        np.ascontiguousarray(kxy),
        shafts,
        base,
    )


def _bearing_rows(H, G, kxx, kyy, kxy, shafts, base):  # pragma: no cover (compiled)
    n, D, N, _, m = G.shape
    nz = np.empty(m, np.int64)
    kg = np.empty((2, m))
    size = 2 * N
    for i in range(n):
        for d in range(D):
            for h in range(N):
                c = 0
                for j in range(m):
                    if G[i, d, h, 0, j] != 0.0 or G[i, d, h, 1, j] != 0.0:
                        nz[c] = j
                        c += 1
                a, b, e = kxx[i, d, h], kyy[i, d, h], kxy[i, d, h]
                for q in range(c):
                    j = nz[q]
                    gx, gy = G[i, d, h, 0, j], G[i, d, h, 1, j]
                    kg[0, j] = a * gx + e * gy
                    kg[1, j] = e * gx + b * gy
                for q in range(c):
                    r = nz[q]
                    gx, gy = G[i, d, h, 0, r], G[i, d, h, 1, r]
                    for t in range(c):
                        s = nz[t]
                        H[i, r, s] += gx * kg[0, s] + gy * kg[1, s]
        for d in range(shafts.shape[0]):
            for e in range(shafts.shape[1]):
                for r in range(size):
                    H[i, base + d * size + r, base + e * size + r] += shafts[d, e]
