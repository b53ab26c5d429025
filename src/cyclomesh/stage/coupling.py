"""The compliant disc's coupling compiled (numba), beside the NumPy reference.

With ``CYCLOMESH_KERNEL=numba`` (the one switch of :mod:`cyclomesh.core.kernel`)
:func:`cyclomesh.stage.equilibrium.body_coupling` forms the compliant disc's
:class:`~cyclomesh.stage.assembly.Body` of one direction here, crank angle by crank
angle and disc by disc, in three passes without the reference's (A, D, P + 2N, P + 2N)
temporaries:

1. :func:`_candidates`: the candidate pins of each crank angle and disc (a loaded flank
   with a positive moment arm and an unloaded backlash below the reach), in pin order,
   then the others in pin order (the reference's stable ``argsort``), and their count;
2. :func:`_own_rows`: each candidate's Catmull–Rom cell and weights on the profile
   angles (``DiscBody._cells``) and its own coefficient C_ii (``DiscBody.diagonal``
   interpolated, the four products summed as NumPy's ``einsum`` sums them here:
   (q₀ + q₂) + (q₁ + q₃));
3. :func:`_fill`: the free disc's influence coefficients C' of the candidates and the 2N
   hole components (:meth:`~cyclomesh.core.discbody.FreeDiscBody.matrix`: each pin
   pair's 4×4 window of the reciprocal table ``DiscBody._padded`` and its weights, the
   load's nodes first; the pin–hole terms interpolated along u; the hole–hole block
   symmetrised), and from them, with c0 the mean of |C_ii| (NumPy's mean, between passes
   2 and 3), the pins' and holes' displacements per unit body unknown (the P rows of
   the candidates' and padding's pins, ``Body.w``, with the pin each moves, and
   ``hole_w``, the holes turned to the fixed frame), the energy matrix E = C'/c0² on the
   free components and the start z = c0·λ from the rigid disc's loads.

Each number is the reference's arithmetic, operation for operation (the window's sums
in the reference's order), so the Body is the same, bit for bit, on this machine
(``tests/stage/test_coupling.py``; the one sum whose order is NumPy's SIMD choice is the
own coefficient's). The arrays are C-contiguous, where the reference's ``hole_w`` and
``energy`` come out of its fancy indexing with the crank angles and discs innermost in
memory: NumPy's products that read them (``np.matmul`` in the assembly) then take BLAS's
sums instead of their own loop, and the compiled Hessian reads them without a copy, so
the stage's results on this path move at round-off (≤ 1.2·10⁻¹⁴ of a field's largest
value on tests/stage/test_stage_fe.py's cases; the reference's memory order, tried, is
bit for bit and ~4 % slower a ring). The reference's memo of the coefficients (a lighter
torque's taken from the rated torque's) is not needed here: forming them costs less than
finding them.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core import kernel_discbody
from cyclomesh.core.discbody import FREE_HELD, FreeDiscBody
from cyclomesh.core.jit import njit

__all__ = ["coupling", "positions"]

FloatArray = NDArray[np.float64]


@cache
def _kernels() -> tuple[Any, Any, Any, Any]:
    jit = njit()
    global _cell  # the Catmull–Rom cell of core.kernel_discbody's passes (one formula)
    _cell = kernel_discbody.compiled().cell
    return jit(_candidates), jit(_own_rows), jit(_fill), jit(_position_rows)


def positions(
    here: NDArray[np.int64], there: NDArray[np.int64]
) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
    """:func:`cyclomesh.stage.equilibrium._positions` compiled: where each candidate pin
    of ``here`` (..., P) stands among those of ``there`` (..., P') (pin indices, −1 for
    padding): (found, its first position; 0 where not found), the same integers."""
    here = np.ascontiguousarray(here, dtype=np.int64)
    there = np.ascontiguousarray(np.broadcast_to(there, (*here.shape[:-1], there.shape[-1])))
    found = np.empty(here.shape, np.bool_)
    where = np.empty(here.shape, np.int64)
    P, Q = here.shape[-1], there.shape[-1]
    _kernels()[3](
        here.reshape(-1, P), there.reshape(-1, Q), found.reshape(-1, P), where.reshape(-1, P)
    )
    return found, where


def _position_rows(here, there, found, where):  # pragma: no cover (compiled)
    """:func:`positions` of (B, P) and (B, P') rows."""
    B, P = here.shape
    Q = there.shape[1]
    for b in range(B):
        for p in range(P):
            pin = here[b, p]
            found[b, p] = False
            where[b, p] = 0
            if pin < 0:
                continue
            for q in range(Q):
                if there[b, q] == pin:
                    found[b, p] = True
                    where[b, p] = q
                    break


def coupling(
    tooth: NDArray[np.int64],
    angle: FloatArray,
    bl: FloatArray,
    arm: FloatArray,
    reach: FloatArray,
    body: FreeDiscBody,
    hx: FloatArray,
    hy: FloatArray,
    scale: float,
    pin_force: FloatArray,
    bearing_fx: FloatArray,
    bearing_fy: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.int64], NDArray[np.int64], FloatArray]:
    """The compliant disc's coupling of one direction (the arrays of
    :func:`cyclomesh.stage.equilibrium.body_coupling`, the same numbers).

    ``tooth`` (A, D, n1) the tooth of every loaded-flank pin, ``angle`` (A, D, n1) its
    profile angle [rad], ``bl`` [rad] and ``arm`` [m] (A, D, n1) its unloaded backlash
    and moment arm, ``reach`` (A,) [rad] the largest backlash of a candidate; ``hx``,
    ``hy`` (A, N) [m] the hole centres in the fixed frame, ``scale`` r_c [m];
    ``pin_force`` (A, D, ≥ n1) [N], ``bearing_fx``, ``bearing_fy`` (A, D, N) [N] the
    start's loads (the disc's pins, the crank bearings on the crank pins).

    Returns the pins' rows ``w`` (A, D, P, Λ) (:attr:`Body.w
    <cyclomesh.stage.assembly.Body>`), ``hole_w`` (A, D, N, 2, Λ), ``energy``
    (A, D, Λ, Λ), ``pins`` (A, D, P) (−1 for padding), ``flank`` (A, D, P) the pin of each
    row of ``w`` (the candidates, then the padding's: the next pins in order) and the start
    z (A, D·Λ).
    """
    cand_pass, own_pass, fill_pass, _ = _kernels()
    A, D, n1 = bl.shape
    N = body.count
    order = np.empty((A, D, n1), np.int64)
    count = np.empty((A, D), np.int64)
    cand_pass(
        np.ascontiguousarray(bl),
        np.ascontiguousarray(arm),
        np.ascontiguousarray(reach, dtype=float),
        order,
        count,
    )
    P = max(int(np.max(count)), 1)
    ok = np.arange(P) < count[..., None]
    pins = np.where(ok, order[..., :P], -1)
    table = body.pins
    u = table.profile_angles
    grid = np.array([u[0], u[-1], u[1] - u[0], float(u.size)])
    cell = np.zeros((A, D, P), np.int64)
    weights = np.zeros((A, D, P, 4))
    own = np.zeros((A, D, P))
    k = np.ascontiguousarray(tooth, dtype=np.int64)
    own_pass(k, np.ascontiguousarray(angle, dtype=float), order, count, table.diagonal, grid,
             cell, weights, own)  # fmt: skip
    c0 = float(np.mean(np.abs(own[ok])))  # the reference's mean, the same order
    held = [2 * h + c for h, c in FREE_HELD]
    free_holes = np.array([j for j in range(2 * N) if j not in held], np.int64)
    lam = P + free_holes.size
    hh = body.hole_hole.reshape(2 * N, 2 * N)
    hh = 0.5 * (hh + hh.T)
    pin_w = np.empty((A, D, P, lam))  # every row written
    hole_w = np.empty((A, D, N, 2, lam))
    energy = np.empty((A, D, lam, lam))
    z = np.empty((A, D, lam))
    fill_pass(
        k, order, count, cell, weights, own, table._padded.reshape(-1), table.teeth,
        table.period, u.size, np.ascontiguousarray(body.hole_pin), np.ascontiguousarray(hh),
        free_holes, c0, np.ascontiguousarray(hx), np.ascontiguousarray(hy), scale,
        np.ascontiguousarray(pin_force), np.ascontiguousarray(bearing_fx),
        np.ascontiguousarray(bearing_fy), pin_w, hole_w, energy, z,
    )  # fmt: skip
    flank = np.ascontiguousarray(order[..., :P])
    return pin_w, hole_w, energy, pins, flank, z.reshape(A, -1)


def _candidates(bl, arm, reach, order, count):  # pragma: no cover (compiled)
    """The candidates of every crank angle and disc (``bl``, ``arm`` (A, D, n1)): φbl
    finite, l > 0, φbl < ``reach`` (A,); their pin indices first into ``order``
    (A, D, n1), in pin order, then the others in pin order; their number into ``count``."""
    A, D, n1 = bl.shape
    for a in range(A):
        r = reach[a]
        for d in range(D):
            c = 0
            for i in range(n1):
                b = bl[a, d, i]
                if np.isfinite(b) and arm[a, d, i] > 0.0 and b < r:
                    order[a, d, c] = i
                    c += 1
            count[a, d] = c
            o = c
            for i in range(n1):
                b = bl[a, d, i]
                if not (np.isfinite(b) and arm[a, d, i] > 0.0 and b < r):
                    order[a, d, o] = i
                    o += 1


def _own_rows(tooth, angle, order, count, diagonal, grid, cell, weights, own):  # pragma: no cover
    """Each candidate's Catmull–Rom cell and weights (``DiscBody._cells``) into ``cell``,
    ``weights`` (A, D, P[, 4]) and its own coefficient C_ii [m/N] into ``own``
    (``DiscBody.diagonal`` of its tooth mod the period, the products summed as NumPy's
    einsum: (q₀ + q₂) + (q₁ + q₃)); padding stays 0."""
    A, D, _ = angle.shape
    u0, u_last, h, m = grid[0], grid[1], grid[2], int(grid[3])
    period = diagonal.shape[0]
    for a in range(A):
        for d in range(D):
            for p in range(count[a, d]):
                i = order[a, d, p]
                c, w0, w1, w2, w3 = _cell(angle[a, d, i], u0, u_last, h, m)
                cell[a, d, p] = c
                weights[a, d, p, 0] = w0
                weights[a, d, p, 1] = w1
                weights[a, d, p, 2] = w2
                weights[a, d, p, 3] = w3
                row = tooth[a, d, i] % period
                q0 = diagonal[row, max(c - 1, 0)] * w0
                q1 = diagonal[row, c] * w1
                q2 = diagonal[row, c + 1] * w2
                q3 = diagonal[row, min(c + 2, m - 1)] * w3
                own[a, d, p] = (q0 + q2) + (q1 + q3)


def _fill(
    tooth, order, count, cell, weights, own, padded, n2, period, m, hole_pin, hh, free_holes,
    c0, hx, hy, scale, pin_force, bearing_fx, bearing_fy, pin_w, hole_w, energy, z
):  # fmt: skip  # pragma: no cover (compiled)
    """The Body's arrays of every crank angle and disc (:func:`coupling`): C' of the
    candidates and hole components into a scratch matrix, then ``pin_w`` (A, D, P, Λ)
    (the rows of the candidates' and padding's unknowns), ``hole_w``, ``energy``, ``z``."""
    A, D, P = cell.shape
    N = hh.shape[0] // 2
    F = free_holes.size
    S = P + 2 * N
    lam = P + F
    side = m + 2
    block = side * side
    # C' with its rows and columns in the unknowns' order: the pins, the free hole
    # components, then the held ones (pos: where each hole component stands), so that
    # every row of the outputs is a contiguous run of it
    cmat = np.zeros((S, S))
    pos = np.empty(2 * N, np.int64)
    held = lam
    for j in range(2 * N):
        pos[j] = -1
    for j in range(F):
        pos[free_holes[j]] = P + j
    for j in range(2 * N):
        if pos[j] < 0:
            pos[j] = held
            held += 1
    c0sq = c0 * c0
    km = np.empty(P, np.int64)  # a candidate's tooth mod n2
    # unsigned: no negative-index test per read (as core.kernel_discbody's)
    base = np.empty(P, np.uint64)  # a candidate's load windows' start in the padded table
    cl = np.empty(P, np.uint64)  # its cell
    wts = np.empty((P, 4))
    uside, ublock = np.uint64(side), np.uint64(block)
    one, two, three = np.uint64(1), np.uint64(2), np.uint64(3)
    for a in range(A):
        erx = np.empty(N)
        ery = np.empty(N)
        for hole in range(N):
            erx[hole] = hx[a, hole] / scale
            ery[hole] = hy[a, hole] / scale
        for d in range(D):
            nc = count[a, d]
            # C': the pins (padding rows and columns 0, c0 on their diagonal) …
            for i in range(S):
                for j in range(S):
                    cmat[i, j] = 0.0
            for j in range(P):
                cmat[j, j] = own[a, d, j] if j < nc else c0
            for p in range(nc):
                k = tooth[a, d, order[a, d, p]]
                c = cell[a, d, p]
                km[p] = k % n2
                base[p] = np.uint64(((k % period) * n2) * block + c * side)
                cl[p] = np.uint64(c)
                for q in range(4):
                    wts[p, q] = weights[a, d, p, q]
            for jl in range(nc):  # the load j
                wj0, wj1, wj2, wj3 = wts[jl, 0], wts[jl, 1], wts[jl, 2], wts[jl, 3]
                kj, bj = km[jl], base[jl]
                for il in range(jl):  # the response i < j
                    offset = km[il] - kj
                    if offset < 0:
                        offset += n2
                    s0 = np.uint64(offset) * ublock + bj + cl[il]
                    s1 = s0 + uside
                    s2 = s1 + uside
                    s3 = s2 + uside
                    h0 = padded[s0] * wj0 + padded[s1] * wj1 + padded[s2] * wj2 + padded[s3] * wj3
                    h1 = (
                        padded[s0 + one] * wj0
                        + padded[s1 + one] * wj1
                        + padded[s2 + one] * wj2
                        + padded[s3 + one] * wj3
                    )
                    h2 = (
                        padded[s0 + two] * wj0
                        + padded[s1 + two] * wj1
                        + padded[s2 + two] * wj2
                        + padded[s3 + two] * wj3
                    )
                    h3 = (
                        padded[s0 + three] * wj0
                        + padded[s1 + three] * wj1
                        + padded[s2 + three] * wj2
                        + padded[s3 + three] * wj3
                    )
                    pair = ((h0 * wts[il, 0] + h1 * wts[il, 1]) + h2 * wts[il, 2]) + h3 * wts[il, 3]
                    cmat[il, jl] = pair
                    cmat[jl, il] = pair
            # … the pins and the holes (the hole_pin table along u) …
            for p in range(nc):
                kp = tooth[a, d, order[a, d, p]] % n2
                c = cell[a, d, p]
                n0, n1_, n2_, n3 = max(c - 1, 0), c, c + 1, min(c + 2, m - 1)
                w0, w1 = weights[a, d, p, 0], weights[a, d, p, 1]
                w2, w3 = weights[a, d, p, 2], weights[a, d, p, 3]
                for hole in range(N):
                    for comp in range(2):
                        v = (
                            hole_pin[kp, n0, hole, comp] * w0
                            + hole_pin[kp, n1_, hole, comp] * w1
                            + hole_pin[kp, n2_, hole, comp] * w2
                            + hole_pin[kp, n3, hole, comp] * w3
                        )
                        cmat[p, pos[2 * hole + comp]] = v
                        cmat[pos[2 * hole + comp], p] = v
            # … and the holes
            for i in range(2 * N):
                for j in range(2 * N):
                    cmat[pos[i], pos[j]] = hh[i, j]
            # the pins' displacements per unit z (C'/c0 on the free columns), by unknown
            for p in range(P):
                for col in range(lam):
                    pin_w[a, d, p, col] = cmat[p, col] / c0
            # the holes', turned from the disc's radial/tangential to the fixed frame
            for hole in range(N):
                ex, ey = erx[hole], ery[hole]
                r0, r1 = pos[2 * hole], pos[2 * hole + 1]
                for col in range(lam):
                    radial = cmat[r0, col] / c0
                    tangential = cmat[r1, col] / c0
                    hole_w[a, d, hole, 0, col] = radial * ex - tangential * ey
                    hole_w[a, d, hole, 1, col] = radial * ey + tangential * ex
            for r in range(lam):
                for col in range(lam):
                    energy[a, d, r, col] = cmat[r, col] / c0sq
            # the start: λ the loads on the disc (the pins', the bearings' on the disc)
            for p in range(P):
                load = pin_force[a, d, order[a, d, p]] if p < nc else 0.0
                z[a, d, p] = c0 * load
            for j in range(F):
                comp = free_holes[j]
                hole = comp // 2
                fx, fy = -bearing_fx[a, d, hole], -bearing_fy[a, d, hole]
                if comp % 2 == 0:
                    value = fx * erx[hole] + fy * ery[hole]
                else:
                    value = -fx * ery[hole] + fy * erx[hole]
                z[a, d, P + j] = c0 * value
