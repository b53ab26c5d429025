"""The compliant disc's stage: each crank angle's Newton iteration compiled (numba), beside
the NumPy reference :func:`cyclomesh.stage.newton.newton` on a problem with a
:class:`~cyclomesh.stage.assembly.Body`.

With ``CYCLOMESH_KERNEL=numba`` the compliant disc's stage without friction (a bearing law
without a series spring) solves each crank angle to its end in one compiled pass, as
:mod:`cyclomesh.stage.kernel_newton` does for the rigid discs: the potential, gradient and
Hessian of :func:`cyclomesh.stage.assembly.evaluate` (:func:`_evaluate_one_py`: the pins with
the body's displacement δ −= (C'·λ)_i, the body's energy ½·zᵀEz, the crank bearings with
the hole centres moved by the body, the crankshafts and the end plate) on the crank
angle's own arrays, the same step, stretched step (``_LINEAR``; after one ratio, not two,
in the active set's iteration: ``_ONCE``, task i47a), step cap, line search
(Armijo, or the residual's norm where the potential has no digits left), convergence test,
the quadratic last step (``_LAST_STEP``) and the give-ups of :func:`newton`'s ``failed``
(``_STALL_ITERATIONS``, ``_STALL_HALVINGS``). The crank angles are solved in order, each
after the first started from the line through the solutions of the two before (where the
default active set's iteration chooses: the solution before where it predicted the crank
angle before better than the line, the parabola through three on a smooth stretch,
``_WARM``, task i46a; else the one before; else its own start), each pin's body unknown
carried by its pin (:attr:`~cyclomesh.stage.assembly.Body.pins`, as
:func:`~cyclomesh.stage.equilibrium._body_carried`). The crank angles it cannot finish
(the saddle of the body's unknowns, a law it cannot invert, a stall) are left to the NumPy
path from their own start (:func:`~cyclomesh.stage.equilibrium._body_newton`: the
reference's Newton, then the residual Newton), exactly as there. The iteration runs to
round-off, so the root is the reference's to round-off.

Not every step is Newton's (:data:`cyclomesh.stage.newton._CHORD`, task i40k): where the
last step cut the largest residual by ``_CHORD`` at least, the next one reuses the last
Newton step's factors (a chord, or modified Newton, step: :func:`_resolve_py`, a back
substitution), every trial evaluates its gradient only (its Hessian where the next step
is predicted Newton's: a linear tail, this step's rate poor), and a chord step that does
not cut the residual at its first trial is redone as Newton's from the same point (and
no chord step follows in that crank angle). The same test ends the iteration (with the
H in hand for the round-off of the unknowns), so the root is the same to round-off;
``_CHORD`` = 0: every step Newton's, bit for bit the iteration before.

The Newton step eliminates each disc's body unknowns first (:func:`_solve_ldl_py`: the
Hessian is block-arrow shaped, each disc's body block coupled only to itself and to c, the
disc's θ and u, its crankshafts' deflections and the end plate's β; each body block by
L·Δ·Lᵀ without pivoting, else by LU with partial pivoting, :func:`_solve_body_py`),
leaving the Schur complement S of those ~20 unknowns, symmetric, by L·Δ·Lᵀ too
(:func:`_ldl_py`; indefinite with a small pivot, ~1 in 9: its LU) (a zero pivot in a
body block: the whole Hessian by the rigid discs' elimination,
:func:`cyclomesh.stage.kernel_newton._solve_blocks`). The factors keep the reciprocal
pivots and Δ⁻¹·W, so a chord step divides nothing but in S's LU (task i43c). Where
every crank angle was finished, the state at the solution (the pins' forces and the
body's shift there, the bearings' forces and deflections, the gradient) is handed to the
caller, which need not evaluate the solution again (:func:`newton` ``state``).
Each warm crank angle is iterated on an active set of the body's unknowns (task i45e,
``_ACTIVE``, :func:`_newton_rows`' ``active``): the holes' and those of the pins loaded at
the crank angle before and their neighbours (:func:`_choose_py`), the others held at 0
and left out of every array (:func:`_reduce_py`: no padding but the discs' equal
sizes), the reduced root checked on K's layout (:func:`_grow_py`: every left-out pin
without load, so the root is K's; else those pins added, z = c0·F, and the iteration
goes on; a failure there: K's iteration from the same start). ~10 pin unknowns of ~21
at a stage tolerance ring's crank angles: the compiled Newton −22 %.
Measured (tasks i38b, i39b, i42c, i43c, docs/stage.md): an evaluation with its Hessian
~11 µs at the rated torque (~6 at ±3 %), a Newton step's solve ~8.3 µs (~6.3; 72
unknowns, two 26-unknown body blocks; ~20 by their L·Δ·Lᵀ), a chord step's ~1.5,
5.5 evaluations a crank angle at the rated torque and 5.8 at ±3 % (task i46a); a stage
tolerance ring's three solves ~0.095 CPU-s.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.jit import njit
from cyclomesh.stage import kernel_newton as _kn

__all__ = ["newton", "evaluate"]

FloatArray = NDArray[np.float64]


@cache
def _kernels() -> tuple[Any, Any]:
    jit = njit()
    _kn._kernels_newton()  # compiles kernel_newton's pieces (their module's globals)
    global _solve_in_place, _solve_blocks, _evaluate_one, _carry, _solve_body, _rows, _carried
    global _owned_rows
    global _solve_ldl, _rollers, _coupled, _pin_law, _back, _resolve, _lu, _lu_solve, _by_lu
    global _dots, _ldl, _ldl_solve
    global _fill, _choose, _grow, _reduce, _compact, _expand, _smooth, _bend, _still, _slot
    _slot = njit(inline=True)(_slot_py)
    _smooth = jit(_smooth_py)
    _bend = jit(_bend_py)
    _still = jit(_still_py)
    _fill = jit(_fill_py)
    _choose = jit(_choose_py)
    _grow = jit(_grow_py)
    _reduce = jit(_reduce_py)
    _compact = jit(_compact_py)
    _expand = jit(_expand_py)
    _pin_law = _kn._pin_law
    _rollers = _kn._rollers
    _solve_in_place = _kn._solve_in_place
    _solve_blocks = _kn._solve_blocks
    _evaluate_one = jit(_evaluate_one_py)
    _carry = jit(_carry_py)
    _rows = jit(_rows_py)
    _carried = jit(_carried_py)
    _owned_rows = jit(_owned_rows_py)
    _coupled = jit(_coupled_py)
    _dots = njit(inline=True)(_dots_py)
    _solve_body = jit(_solve_body_py)
    _lu = jit(_lu_py)
    _lu_solve = jit(_lu_solve_py)
    _ldl = jit(_ldl_py)
    _ldl_solve = jit(_ldl_solve_py)
    _back = jit(_back_py)
    _resolve = jit(_resolve_py)
    _by_lu = jit(_by_lu_py)
    _solve_ldl = jit(_solve_ldl_py)
    return jit(_evaluate_rows), jit(_newton_rows)


def _prepare(p, law, x: FloatArray, discs: int, jacobian: FloatArray):
    """The arrays of the compiled calls: the pins' block, the body's pin coefficients and
    energy, the bearings' columns of ``jacobian`` and the block structure, the holes, the
    constants (kernel_newton's)."""
    sup = p.supports
    m = x.shape[1]
    N = p.hx.shape[-1]
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = sup is not None and sup.carrier is not None
    G = np.ascontiguousarray(jacobian)
    cols, core, blocks, hole, const = _kn._arrays(p, law, G, discs, nw, m)
    b = p.body
    # the body's pin rows and the flank each moves (Body.w, Body.flank): _rows' map
    pin_w = (np.ascontiguousarray(b.w, dtype=float), np.ascontiguousarray(b.flank, np.int64))
    energy = np.ascontiguousarray(b.energy, dtype=float)
    pins = np.ascontiguousarray(b.pins, dtype=np.int64)
    block = _kn.pin_block(p)
    return G, cols, core, blocks, hole, const, nw, carrier, pin_w, energy, pins, block


def evaluate(p, law, x: FloatArray, discs: int, jacobian: FloatArray | None = None):
    """Potential (A,), scaled gradient (A, m) and Hessian (A, m, m) and status (A,: 0
    usable, 1 a pin at or past its law's reach, 2 a law it cannot invert) of the compliant
    disc's stage at ``x`` (A, m), every crank angle by :func:`_evaluate_one_py`
    (the reference: :func:`cyclomesh.stage.assembly.evaluate`, ``rigid=False``)."""
    from cyclomesh.stage.assembly import bearing_jacobian

    A, m = x.shape
    if jacobian is None:
        jacobian = p.jacobian if p.jacobian is not None else bearing_jacobian(p, discs, m)
    G, cols, _, _, hole, const, nw, carrier, pin_w, energy, _, block = _prepare(
        p, law, x, discs, jacobian
    )
    sup = p.supports
    e, g, H = np.zeros(A), np.zeros((A, m)), np.zeros((A, m, m))
    status = np.zeros(A, np.int64)
    _kernels()[0](
        np.ascontiguousarray(x, dtype=float), block, pin_w, energy, hole, G, cols, const, nw,
        float(sup.carrier) if carrier else 0.0, carrier, 0.5 * law.rs.clearance,
        law.rs.constant, float(p.torque), float(p.scale), e, g, H, status,
    )  # fmt: skip
    return e, g, H, status


def _evaluate_rows(
    x, pin, pin_w, energy, hole, G, cols, const, nw, kcarrier, carrier, half, kn, torque, L,
    e, g, H, status,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`evaluate` written for numba (each crank angle from a fresh inversion memo)."""
    A, m = x.shape
    D, P = pin.shape[2], pin.shape[3]
    memo = np.zeros((3, D, P))
    pf = np.zeros((2, A, D, P))
    bf = np.zeros((A, D, hole.shape[3], 3))
    wrow = np.zeros((D, P), np.int64)  # the row of pin_w of each flank, −1: none
    scratch = np.zeros((3, max(m, D * pin_w[0].shape[2], energy.shape[3], 9)))
    zz = np.zeros((D, energy.shape[3], energy.shape[3]))  # Σ k·w·wᵀ of each disc's pins
    for i in range(A):
        memo[0] = 0.0
        _rows(wrow, pin_w, i)
        e[i], status[i] = _evaluate_one(
            i, i, x[i], pin, pin_w, energy, hole, G, cols, const, nw, kcarrier, carrier, half,
            kn, torque, L, 2, g[i], H[i], memo, pf, bf, wrow, scratch, zz,
        )  # fmt: skip


def _evaluate_one_py(
    i, ib, x, pin, pin_w, energy, hole, G, cols, const, nw, kcarrier, carrier, half, kn, torque,
    L, want, g, H, memo, pf, bf, wrow, scratch, zz,
):  # fmt: skip  # pragma: no cover (compiled)
    """Potential of crank angle ``i`` at x (m,) and, with ``want`` ≥ 1, its scaled gradient
    g (and with ``want`` = 2 its Hessian H), as :func:`cyclomesh.stage.assembly.evaluate`
    (``rigid=False``) with the compliant disc: the pins' δ less the body's displacement at
    the pin Σ_s w[i, d, q, s]·z_ds of its row q (``pin_w`` = (Body.w, Body.flank), the
    row of each pin in ``wrow``, :func:`_rows_py`), the body's energy ½·zᵀEz per disc, the
    crank bearings' hole-against-pin vector with the hole centre's displacement by the
    body (the columns of ``G`` that are the body's,
    :func:`~cyclomesh.stage.assembly.bearing_jacobian`).
    With ``want`` = 3 the Hessian's upper triangle only (the lower one neither zeroed nor
    formed: what the compiled Newton's solve and test read, :func:`_coupled_py`).
    Returns (energy, status) as :func:`cyclomesh.stage.kernel_newton._evaluate_one`;
    with ``want`` ≥ 1 the state: ``pf[0, i]`` the pins' forces, ``pf[1, i]`` the body's
    displacement at them (0 where it moves none), ``bf[i]`` the bearings' (fx, fy, s).
    ``scratch`` (3, ≥ max(m, D·Q, Λ, 9)), Q the rows of Body.w a disc: work (the pins'
    body shifts by :func:`_dots_py`, E·z, the bearings' Jacobian rows and stiffnesses);
    ``zz`` (D, Λ, Λ): work (the pins' and bearings' terms of each body block)."""
    m = x.size
    D, P = pin.shape[2], pin.shape[3]
    lam = energy.shape[3]
    z0 = m - D * lam
    N = hole.shape[3]
    R = const.size - D - D * D
    hess = want >= 2
    if want:
        for r in range(m):
            g[r] = 0.0
        for d in range(D):
            for j in range(P):
                pf[0, i, d, j] = 0.0
                pf[1, i, d, j] = 0.0
    if hess:  # (want 3: the upper triangle only is formed; the whole H zeroed as one
        # flat run, cheaper than the triangle's rows)
        Hf = H.reshape(m * m)
        for r in range(m * m):
            Hf[r] = 0.0
        zz[:, :, :] = 0.0
    status = 0
    pins = 0.0
    W = pin_w[0]
    Q = W.shape[2]
    for d in range(D):  # the body's displacement at each row of pin_w: scratch[0, d·Q + q]
        zd = z0 + d * lam
        _dots(W[ib, d], x, zd, scratch[0], d * Q)
    for d in range(D):
        th, ux, uy = x[1 + 3 * d], x[2 + 3 * d], x[3 + 3 * d]
        zd = z0 + d * lam
        r0 = 1 + 3 * d
        for j in range(P):
            b = pin[0, i, d, j]
            if not np.isfinite(b):
                continue
            wq = wrow[d, j]  # the pin's row of the body's, −1: none (a row of 0 adds 0)
            shift = scratch[0, d * Q + wq] if wq >= 0 else 0.0
            delta = pin[1, i, d, j] * (th - b) + pin[2, i, d, j] * ux + pin[3, i, d, j] * uy
            delta = delta - shift
            if want:
                pf[1, i, d, j] = shift
            if delta <= 0.0:
                continue
            code, f, logf, a, gm = _pin_law(delta, pin, i, d, j, memo)
            if code == 1:
                status = 1
                continue
            if code == 2:
                return 0.0, 2
            if f > 0.0:
                pins += 0.5 * f * f * (a - 0.5 * gm - gm * logf)
                if want:
                    pf[0, i, d, j] = f
                    k = 1.0 / (a - gm * (1.0 + logf))
                    v0, v1, v2 = pin[1, i, d, j] / L, pin[2, i, d, j], pin[3, i, d, j]
                    g[r0] += f * v0
                    g[r0 + 1] += f * v1
                    g[r0 + 2] += f * v2
                    w = pin_w[0][ib, d, max(wq, 0)]
                    if not hess:
                        for s in range(lam if wq >= 0 else 0):
                            g[zd + s] -= f * w[s]
                        continue
                    H[r0, r0] += k * v0 * v0
                    H[r0, r0 + 1] += k * v0 * v1
                    H[r0, r0 + 2] += k * v0 * v2
                    H[r0 + 1, r0 + 1] += k * v1 * v1
                    H[r0 + 1, r0 + 2] += k * v1 * v2
                    H[r0 + 2, r0 + 2] += k * v2 * v2
                    # the body: ∂δ/∂z = −w, so g_z −= F·w, H_zz += k·w·wᵀ, H_az −= k·a·wᵀ
                    for s in range(lam if wq >= 0 else 0):
                        ws = w[s]
                        if ws == 0.0:
                            continue
                        g[zd + s] -= f * ws
                        kw = k * ws
                        H[r0, zd + s] -= v0 * kw
                        H[r0 + 1, zd + s] -= v1 * kw
                        H[r0 + 2, zd + s] -= v2 * kw
                        row = zz[d, s]  # (whole rows: the inner loop vectorises)
                        for q in range(lam):
                            row[q] += kw * w[q]
    # the body's energy ½·zᵀEz per disc, its gradient E·z and Hessian E
    body = 0.0
    for d in range(D):
        zd = z0 + d * lam
        _dots(energy[ib, d], x, zd, scratch[1], 0)  # E·z (each row summed in order)
        for s in range(lam):
            ez = scratch[1, s]
            body += x[zd + s] * ez
            if want:
                g[zd + s] += ez
            # (its Hessian E: added with zz at the end, the body block's one pass)
    if want:
        g[0] -= torque / L
    energy_total = pins - torque * x[0] + 0.5 * body
    base = 1 + 3 * D
    beta = x[base + nw] if carrier else 0.0
    p = 10.0 / 9.0
    bearings = 0.0
    for d in range(D):
        rot = (x[1 + 3 * d] - x[0]) - const[R + d] * beta
        zd = z0 + d * lam
        for k in range(N):
            wx = x[base + 2 * (d * N + k)] if nw else 0.0
            wy = x[base + 2 * (d * N + k) + 1] if nw else 0.0
            dx = x[2 + 3 * d] + rot * (-hole[1, i, d, k]) + hole[2, i, d, k] - wx
            dy = x[3 + 3 * d] + rot * hole[0, i, d, k] + hole[3, i, d, k] - wy
            hx = 0.0
            hy = 0.0
            for s in range(lam):
                hx += G[ib, d, k, 0, zd + s] * x[zd + s]
                hy += G[ib, d, k, 1, zd + s] * x[zd + s]
            dx = dx + hx
            dy = dy + hy
            s_ = np.hypot(dx, dy)
            B, kb, ub = _rollers(s_, const, R, half, kn)
            bearings += ub / (p + 1.0)
            if not want:
                continue
            if s_ > 0.0:
                cx, cy, secant = dx / s_, dy / s_, B / s_
            else:
                cx, cy, secant = 1.0, 0.0, kb
            fx, fy = B * cx, B * cy
            bf[i, d, k, 0], bf[i, d, k, 1], bf[i, d, k, 2] = fx, fy, s_
            kxx = kb * cx * cx + secant * cy * cy
            kyy = kb * cy * cy + secant * cx * cx
            kxy = (kb - secant) * cx * cy
            nk = cols[d, k, 0]
            for u in range(nk):  # this hole's nonzero columns of ∂d/∂x
                r = cols[d, k, 1 + u]
                g0, g1 = G[ib, d, k, 0, r], G[ib, d, k, 1, r]
                scratch[0, u], scratch[1, u] = g0, g1
                g[r] += fx * g0 + fy * g1
            if not hess:
                continue
            for u in range(nk):  # Gᵀ·K·G, each pair once (H is symmetric)
                r = cols[d, k, 1 + u]
                if r >= zd:  # the body's own columns: into zz, whole rows
                    break
                g0, g1 = scratch[0, u], scratch[1, u]
                ka = kxx * g0 + kxy * g1
                kc = kxy * g0 + kyy * g1
                H[r, r] += ka * g0 + kc * g1
                body = nk
                for v in range(u + 1, nk):  # (the columns in increasing order: r < c2)
                    c2 = cols[d, k, 1 + v]
                    if c2 >= zd:
                        body = v
                        break
                    H[r, c2] += ka * scratch[0, v] + kc * scratch[1, v]
                if body == nk:
                    continue
                for q in range(lam):  # the body's columns as one run (a zero column adds 0)
                    H[r, zd + q] += ka * G[ib, d, k, 0, zd + q] + kc * G[ib, d, k, 1, zd + q]
                for v in range(body, nk):  # (none: a hole moves its own disc's body only)
                    c2 = cols[d, k, 1 + v]
                    if c2 >= zd + lam:
                        H[r, c2] += ka * scratch[0, v] + kc * scratch[1, v]
            if N == 3:  # (the three holes' body terms in one pass below)
                scratch[2, 3 * k], scratch[2, 3 * k + 1], scratch[2, 3 * k + 2] = kxx, kxy, kyy
                continue
            hx_, hy_ = G[ib, d, k, 0, zd : zd + lam], G[ib, d, k, 1, zd : zd + lam]
            for q in range(lam):
                ka = kxx * hx_[q] + kxy * hy_[q]
                kc = kxy * hx_[q] + kyy * hy_[q]
                row = zz[d, q]
                for v in range(lam):
                    row[v] += ka * hx_[v] + kc * hy_[v]
        if hess and N == 3:  # the holes' Gᵀ·K·G on the body's columns, each entry's three
            # terms added in the holes' order (the bits of one hole at a time)
            h0, y0 = G[ib, d, 0, 0, zd : zd + lam], G[ib, d, 0, 1, zd : zd + lam]
            h1, y1 = G[ib, d, 1, 0, zd : zd + lam], G[ib, d, 1, 1, zd : zd + lam]
            h2, y2 = G[ib, d, 2, 0, zd : zd + lam], G[ib, d, 2, 1, zd : zd + lam]
            xx0, xy0, yy0 = scratch[2, 0], scratch[2, 1], scratch[2, 2]
            xx1, xy1, yy1 = scratch[2, 3], scratch[2, 4], scratch[2, 5]
            xx2, xy2, yy2 = scratch[2, 6], scratch[2, 7], scratch[2, 8]
            for q in range(lam):
                a0, c0 = xx0 * h0[q] + xy0 * y0[q], xy0 * h0[q] + yy0 * y0[q]
                a1, c1 = xx1 * h1[q] + xy1 * y1[q], xy1 * h1[q] + yy1 * y1[q]
                a2, c2 = xx2 * h2[q] + xy2 * y2[q], xy2 * h2[q] + yy2 * y2[q]
                row = zz[d, q]
                for v in range(lam):
                    row[v] = (
                        row[v]
                        + (a0 * h0[v] + c0 * y0[v])
                        + (a1 * h1[v] + c1 * y1[v])
                        + (a2 * h2[v] + c2 * y2[v])
                    )
    energy_total = energy_total + bearings
    if nw:
        shafts = 0.0
        for d in range(D):
            for k in range(N):
                for c in range(2):
                    kw = 0.0
                    for e in range(D):
                        kw += const[R + D + d * D + e] * x[base + 2 * (e * N + k) + c]
                    shafts += x[base + 2 * (d * N + k) + c] * kw
                    r = base + 2 * (d * N + k) + c
                    if want:
                        g[r] += kw
                    if hess:
                        for e in range(d, D):  # (the upper triangle)
                            H[r, base + 2 * (e * N + k) + c] += const[R + D + d * D + e]
        energy_total = energy_total + 0.5 * shafts
    if carrier:
        energy_total = energy_total + 0.5 * kcarrier * beta * beta
        if want:
            g[base + nw] += kcarrier * beta / L
        if hess:
            H[base + nw, base + nw] += kcarrier / (L * L)
    if hess:  # every term above was added to the upper triangle: mirrored (want 2)
        for d in range(D):  # (the body's Σ k·w·wᵀ and its bearings' terms)
            zd = z0 + d * lam
            for s in range(lam):  # (0 + E) + zz: the bits of E added to the zeroed H first
                for q in range(s, lam):
                    H[zd + s, zd + q] = (0.0 + energy[ib, d, s, q]) + zz[d, s, q]
        if want == 2:
            for r in range(m):
                for c in range(r + 1, m):
                    H[c, r] = H[r, c]
    return energy_total, status


def _dots_py(M, x, z, out, o):  # pragma: no cover (compiled)
    """out[o + q] = Σ_s M[q, s]·x[z + s] for each row q of M (n, lam), each sum from 0 in
    s's order (the bits of the plain loop), four rows at a time: four independent chains
    of additions where one row's chain waits on each addition."""
    n, lam = M.shape
    q = 0
    while q + 4 <= n:
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        for s in range(lam):
            xs = x[z + s]
            a0 += M[q, s] * xs
            a1 += M[q + 1, s] * xs
            a2 += M[q + 2, s] * xs
            a3 += M[q + 3, s] * xs
        out[o + q] = a0
        out[o + q + 1] = a1
        out[o + q + 2] = a2
        out[o + q + 3] = a3
        q += 4
    while q < n:
        a0 = 0.0
        for s in range(lam):
            a0 += M[q, s] * x[z + s]
        out[o + q] = a0
        q += 1


def _coupled_py(H, g, nr, D, lam, S, rhs, cl, Y):  # pragma: no cover (compiled)
    """The start of both body-block eliminations (:func:`_solve_body_py`,
    :func:`_solve_ldl_py`): S = H_RR and rhs = g_R (R the nr unknowns before the body's),
    and per disc d the columns of R that its body block Z_d couples to (``cl[d]``: their
    count, then their indices, from H's nonzeros) with Y_d = [H_ZR | g_Z] on them. Only
    H's and g's entries are read, of its upper triangle (H symmetric: a lower one need not
    be formed); a disc's later elimination does not touch another's."""
    for a in range(nr):
        for b in range(a, nr):  # (H's rows contiguous, S's columns written across)
            h = H[a, b]
            S[a, b] = h
            S[b, a] = h
        rhs[a] = g[a]
    for d in range(D):
        z = nr + d * lam
        nc = 0
        for a in range(nr):
            for q in range(lam):
                if H[a, z + q] != 0.0:
                    cl[d, 1 + nc] = a
                    nc += 1
                    break
        cl[d, 0] = nc
        for b in range(nc):  # (H's rows read contiguous)
            a = cl[d, 1 + b]
            for q in range(lam):
                Y[d, q, b] = H[a, z + q]
        for q in range(lam):
            Y[d, q, nc] = g[z + q]


def _solve_body_py(H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T):  # pragma: no cover
    """step = −H⁻¹g with each disc's body unknowns eliminated first: the unknowns are the
    rest R (the first ``nr``: c, the discs' θ and u, the crankshafts' deflections, the end
    plate's β) and the discs' body unknowns Z_d (``lam`` each, from ``nr``), and Z_d couples
    only to R and to itself (the pins of disc d, its energy E, its crank bearings'
    hole-against-pin vectors: :func:`~cyclomesh.stage.assembly.bearing_jacobian`), so H is
    block-arrow shaped. Per disc: the columns of R that Z_d couples to (``cl``: c, θ_d,
    u_d, its crankshafts' deflections, β), H_ZZ's LU with partial pivoting inside the
    block, Y = H_ZZ⁻¹[H_ZR | g_Z] on those columns, S −= H_RZ·Y; then S (the Schur
    complement of R) by :func:`~cyclomesh.stage.kernel_newton._solve_in_place`, and
    Z_d = y_d − Y_d·s_R. ``S`` (nr, nr), ``Y`` (D, lam, nr + 1), ``rhs``, ``sc`` (nr,),
    ``cl`` (D, nr + 1, count first), ``T`` (nr + 1, nr + 1): work arrays. H is
    overwritten (its Z blocks by their LU); False where a pivot is 0 (the caller then
    evaluates H again and solves it whole)."""
    _coupled(H, g, nr, D, lam, S, rhs, cl, Y)
    for d in range(D):
        z = nr + d * lam
        nc = cl[d, 0]
        # LU of the block in H's rows z … z + lam − 1 (columns z …), rows pivoted
        for k in range(lam):
            piv = k
            big = abs(H[z + k, z + k])
            for r in range(k + 1, lam):
                v = abs(H[z + r, z + k])
                if v > big:
                    big = v
                    piv = r
            if big == 0.0:
                return False
            if piv != k:
                for c in range(lam):
                    H[z + k, z + c], H[z + piv, z + c] = H[z + piv, z + c], H[z + k, z + c]
                for c in range(nc + 1):
                    Y[d, k, c], Y[d, piv, c] = Y[d, piv, c], Y[d, k, c]
            inv = 1.0 / H[z + k, z + k]
            for r in range(k + 1, lam):
                f = H[z + r, z + k] * inv
                if f != 0.0:
                    for c in range(k + 1, lam):
                        H[z + r, z + c] -= f * H[z + k, z + c]
                    for c in range(nc + 1):
                        Y[d, r, c] -= f * Y[d, k, c]
        for k in range(lam - 1, -1, -1):
            for q in range(k + 1, lam):
                h = H[z + k, z + q]
                if h != 0.0:
                    for c in range(nc + 1):
                        Y[d, k, c] -= h * Y[d, q, c]
            inv = 1.0 / H[z + k, z + k]
            for c in range(nc + 1):
                Y[d, k, c] *= inv
        # S −= H_RZ·Y, rhs −= H_RZ·y (H_RZ's nonzero rows are H_ZR's nonzero columns)
        for u in range(nc):  # (summed in T's contiguous rows, then scattered)
            a = cl[d, 1 + u]
            for b in range(nc + 1):
                T[u, b] = 0.0
            for q in range(lam):
                h = H[a, z + q]
                if h != 0.0:
                    for b in range(nc + 1):
                        T[u, b] += h * Y[d, q, b]
            for b in range(nc):
                S[a, cl[d, 1 + b]] -= T[u, b]
            rhs[a] -= T[u, nc]
    if not _solve_in_place(S, rhs, sc):
        return False
    for a in range(nr):
        step[a] = sc[a]
    for d in range(D):
        z = nr + d * lam
        nc = cl[d, 0]
        for q in range(lam):
            acc = -Y[d, q, nc]
            for b in range(nc):
                acc -= Y[d, q, b] * sc[cl[d, 1 + b]]
            step[z + q] = acc
    return True


_GROWTH = 1e3  # the largest |L_rk| of the LDLᵀ without pivoting; beyond: the LU's


def _solve_ldl_py(
    H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T, dg, Lb, piv, v, Wd, ds
):  # fmt: skip  # pragma: no cover (compiled)
    """step = −H⁻¹g as :func:`_solve_body_py` (each disc's body unknowns Z_d eliminated
    first, the block-arrow Hessian), each body block H_ZZ = L·Δ·Lᵀ (symmetric, L unit lower
    triangular, Δ diagonal; H_ZZ is symmetric but not definite: the body's energy E is
    not), without pivoting: W = L⁻¹[H_ZR | g_Z] on the columns of R that Z_d couples to
    (``cl``), S −= W_Rᵀ·Δ⁻¹·W_R (its upper triangle only: S is symmetric), rhs −=
    W_Rᵀ·Δ⁻¹·w_g; then S by :func:`_ldl_py` (S = L·Δ·Lᵀ, else its LU) and Z_d =
    −L⁻ᵀΔ⁻¹(w_g + W_R·s_R). About half the arithmetic of the LU's (no back substitution
    of Y, half the factorisation). Where a pivot is 0 or an entry of L beyond ``_GROWTH``
    (the elimination without pivoting not stable), the LU's :func:`_solve_body_py` instead
    (its False: a pivot 0 there too). Only H's upper triangle is read, and H is not written
    but by the LU's fallback (:func:`_by_lu_py`); ``dg`` (D, lam): the reciprocal pivots
    1/Δ, ``Lb`` (D, lam, lam): L, ``Wd`` (D, lam, nr): Δ⁻¹·W_R, ``ds`` (nr,): S's
    reciprocal pivots, ``piv`` (nr,) int, ``v`` (D, lam): work. Each division once, at
    the factorisation (task i43c: ~1,300 divisions a step before, ~600 a chord step).
    Returns 0 where no step was formed, 1 where it was by the L·Δ·Lᵀ, whose factors stay
    for :func:`_resolve_py` (another gradient, the same H: Lb, dg, the coupled columns
    ``cl``, W_R in Y's first columns and Δ⁻¹·W_R in Wd, S's factors with ``ds`` or its LU
    with its row swaps ``piv``), 2 where by the LU's (nothing kept)."""
    _coupled(H, g, nr, D, lam, S, rhs, cl, Y)
    for d in range(D):
        z = nr + d * lam
        nc = cl[d, 0]
        # L·Δ·Lᵀ by rows: Lb[r, j] (j < r) holds L_rj·Δ_j while row r is formed, then L_rj
        for r in range(lam):
            lr = Lb[d, r]
            for k in range(r):
                lk = Lb[d, k]
                acc = H[z + k, z + r]  # (the upper triangle: H_rk = H_kr)
                for j in range(k):
                    acc -= lr[j] * lk[j]  # (L_rj·Δ_j)·L_kj
                lr[k] = acc  # L_rk·Δ_k
            dr = H[z + r, z + r]
            for k in range(r):
                t = lr[k]
                f = t * dg[d, k]
                lr[k] = f
                dr -= f * t
                if abs(f) > _GROWTH:
                    return _by_lu(H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T)
            if dr == 0.0:
                return _by_lu(H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T)
            rd = 1.0 / dr
            dg[d, r] = rd
            # the forward substitution's row r: W_r = Y_r − Σ_k<r L_rk·W_k, then Δ⁻¹·W_r
            for k in range(r):
                f = lr[k]
                if f != 0.0:
                    for c in range(nc + 1):
                        Y[d, r, c] -= f * Y[d, k, c]
            for c in range(nc):
                Wd[d, r, c] = Y[d, r, c] * rd
        # S −= W_Rᵀ·Δ⁻¹·W_R, rhs −= W_Rᵀ·Δ⁻¹·w_g: T's contiguous rows (each entry summed
        # over q in order, as _resolve_py's), then scattered
        for u in range(nc):
            a = cl[d, 1 + u]
            for b in range(nc + 1):
                T[u, b] = 0.0
            for q in range(lam):
                w = Wd[d, q, u]
                if w != 0.0:
                    for b in range(nc + 1):
                        T[u, b] += w * Y[d, q, b]
            for b in range(nc):
                S[a, cl[d, 1 + b]] -= T[u, b]
            rhs[a] -= T[u, nc]
    if not _ldl(S, rhs, sc, piv, ds):
        return 0
    _back(step, nr, D, lam, Y, sc, cl, dg, Lb, v)
    return 1


def _by_lu_py(H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T):  # pragma: no cover (compiled)
    """:func:`_solve_ldl_py`'s fallback: the body blocks' lower triangles mirrored from
    their upper ones (which is all :func:`_solve_ldl_py` reads), then :func:`_solve_body_py`;
    2 where it solved, else 0."""
    for d in range(D):
        z = nr + d * lam
        for r in range(lam):
            for c in range(r):
                H[z + r, z + c] = H[z + c, z + r]
    return 2 if _solve_body(H, g, step, nr, D, lam, S, Y, rhs, sc, cl, T) else 0


def _back_py(step, nr, D, lam, Y, sc, cl, dg, Lb, v):  # pragma: no cover (compiled)
    """The end of :func:`_solve_ldl_py` and :func:`_resolve_py`: step_R = s_R (``sc``) and
    each disc's Z_d = −L⁻ᵀΔ⁻¹(w_g + W_R·s_R) (w_g in Y's column ``cl[d, 0]``, ``dg`` the
    reciprocal pivots 1/Δ); ``v``: work (D, lam)."""
    for a in range(nr):
        step[a] = sc[a]
    for d in range(D):
        z = nr + d * lam
        nc = cl[d, 0]
        for q in range(lam):  # Δ⁻¹(w_g + W_R·s_R)
            acc = Y[d, q, nc]
            for b in range(nc):
                acc += Y[d, q, b] * sc[cl[d, 1 + b]]
            v[d, q] = acc * dg[d, q]
        for k in range(lam - 1, -1, -1):  # Lᵀ·v = that, by L's rows
            lk = Lb[d, k]
            vk = v[d, k]
            step[z + k] = -vk
            for j in range(k):
                v[d, j] -= lk[j] * vk


def _resolve_py(
    g, step, nr, D, lam, S, Y, rhs, sc, cl, dg, Lb, piv, v, Wd, ds
):  # fmt: skip  # pragma: no cover (compiled)
    """step = −H⁻¹g for another gradient ``g`` with the factors :func:`_solve_ldl_py` kept
    of H (its return 1): the same operations on g as there (w_g = L⁻¹g_Z into Y's column
    ``cl[d, 0]``, rhs = g_R − (Δ⁻¹·W_R)ᵀ·w_g with Δ⁻¹·W_R from ``Wd``, S's solve by its
    factors (:func:`_ldl_solve_py`, or its LU's where ``piv[0]`` ≥ 0), :func:`_back_py`), so
    with the gradient it factored the same step bit for bit. A chord (modified Newton)
    step: triangular solves and products, no division (but S's LU's, where it has one)."""
    for a in range(nr):
        rhs[a] = g[a]
    for d in range(D):
        z = nr + d * lam
        nc = cl[d, 0]
        for r in range(lam):
            lr = Lb[d, r]
            acc = g[z + r]
            for k in range(r):
                f = lr[k]
                if f != 0.0:
                    acc -= f * Y[d, k, nc]
            Y[d, r, nc] = acc
        for u in range(nc):  # (sc: work here, each sum over q in order as T's)
            sc[u] = 0.0
        for q in range(lam):
            y = Y[d, q, nc]
            for u in range(nc):
                sc[u] += Wd[d, q, u] * y
        for u in range(nc):
            rhs[cl[d, 1 + u]] -= sc[u]
    if piv[0] < 0:
        _ldl_solve(S, rhs, sc, ds)
    else:
        _lu_solve(S, rhs, sc, piv)
    _back(step, nr, D, lam, Y, sc, cl, dg, Lb, v)


def _ldl_py(S, rhs, sc, piv, ds):  # pragma: no cover (compiled)
    """sc = −S⁻¹·rhs for a symmetric S (its upper triangle read, not written) by
    S = L·Δ·Lᵀ without pivoting, by rows as the body blocks' (:func:`_solve_ldl_py`; ~n³/6
    multiply-adds, half the LU's; 20 unknowns: ~0.5 µs against the LU's ~1.2): L unit
    lower triangular into S's strict lower triangle, the reciprocal pivots 1/Δ into
    ``ds``, ``piv[0]`` = −1 (the mark :func:`_resolve_py` reads). Where a pivot is 0 or an
    entry of L beyond ``_GROWTH`` (the elimination without pivoting not stable: S
    indefinite, a small pivot; ~1 in 9 of a stage ring's), S's lower triangle mirrored
    from its upper one and :func:`_lu_py` instead (its row swaps in ``piv``, ≥ 0). False
    where that finds a pivot 0 (S singular)."""
    m = rhs.size
    ok = True
    for r in range(m):
        lr = S[r]
        for k in range(r):
            lk = S[k]
            acc = S[k, r]  # (the upper triangle: S_rk = S_kr)
            for j in range(k):
                acc -= lr[j] * lk[j]  # (L_rj·Δ_j)·L_kj
            lr[k] = acc  # L_rk·Δ_k
        dr = S[r, r]
        for k in range(r):
            t = lr[k]
            f = t * ds[k]
            lr[k] = f
            dr -= f * t
            if abs(f) > _GROWTH:
                ok = False
        if not ok or dr == 0.0:
            ok = False
            break
        ds[r] = 1.0 / dr
    if not ok:
        for r in range(m):
            for c in range(r):
                S[r, c] = S[c, r]
        return _lu(S, rhs, sc, piv)
    if m:
        piv[0] = -1
    _ldl_solve(S, rhs, sc, ds)
    return True


def _ldl_solve_py(S, rhs, sc, ds):  # pragma: no cover (compiled)
    """sc = −S⁻¹·rhs with the factors :func:`_ldl_py` left (L in S's strict lower
    triangle, 1/Δ in ``ds``): L·y = −rhs by L's rows, Δ⁻¹·y, Lᵀ·sc = that by L's rows."""
    m = rhs.size
    for r in range(m):
        lr = S[r]
        acc = -rhs[r]
        for k in range(r):
            acc -= lr[k] * sc[k]
        sc[r] = acc
    for r in range(m):
        sc[r] *= ds[r]
    for k in range(m - 1, -1, -1):
        lk = S[k]
        xk = sc[k]
        for j in range(k):
            sc[j] -= lk[j] * xk


def _lu_py(S, rhs, sc, piv):  # pragma: no cover (compiled)
    """sc = −S⁻¹·rhs by Gaussian elimination with partial pivoting, the operations of
    :func:`~cyclomesh.stage.kernel_newton._solve_in_place` (so the same bits), S
    overwritten by its LU (the multipliers below the diagonal, rows swapped as LAPACK's)
    and the row swaps in ``piv`` for :func:`_lu_solve_py`; False if a pivot is 0."""
    m = rhs.size
    for r in range(m):
        sc[r] = -rhs[r]
    for k in range(m):
        p = k
        big = abs(S[k, k])
        for r in range(k + 1, m):
            if abs(S[r, k]) > big:
                big = abs(S[r, k])
                p = r
        if big == 0.0:
            return False
        piv[k] = p
        if p != k:
            for c in range(m):
                S[k, c], S[p, c] = S[p, c], S[k, c]
            sc[k], sc[p] = sc[p], sc[k]
        inv = 1.0 / S[k, k]
        pk = S[k, k + 1 :]  # (1-D views of the rows: the update loop vectorises)
        n = m - k - 1
        for r in range(k + 1, m):
            f = S[r, k] * inv
            S[r, k] = f
            if f != 0.0:
                row = S[r, k + 1 :]
                for c in range(n):
                    row[c] -= f * pk[c]
                sc[r] -= f * sc[k]
    for k in range(m - 1, -1, -1):
        acc = sc[k]
        for c in range(k + 1, m):
            acc -= S[k, c] * sc[c]
        sc[k] = acc / S[k, k]
    return True


def _lu_solve_py(S, rhs, sc, piv):  # pragma: no cover (compiled)
    """sc = −S⁻¹·rhs with the LU and row swaps :func:`_lu_py` left (LAPACK's getrs order:
    every swap, then L and U; each entry the same operations in the same order as there)."""
    m = rhs.size
    for r in range(m):
        sc[r] = -rhs[r]
    for k in range(m):  # the row swaps first: L's rows were swapped with the later ones
        p = piv[k]
        if p != k:
            sc[k], sc[p] = sc[p], sc[k]
    for k in range(m):
        for r in range(k + 1, m):
            f = S[r, k]
            if f != 0.0:
                sc[r] -= f * sc[k]
    for k in range(m - 1, -1, -1):
        acc = sc[k]
        for c in range(k + 1, m):
            acc -= S[k, c] * sc[c]
        sc[k] = acc / S[k, k]


def _rows_py(wrow, pin_w, i):  # pragma: no cover (compiled)
    """``wrow`` (D, P): the row of ``pin_w`` = (w, flank) (Body.w, Body.flank) of each
    flank at crank angle ``i`` whose body coefficients are not all 0, −1 for the others
    (the body moves no other pin)."""
    w, flank = pin_w
    D, Q, lam = w.shape[1], w.shape[2], w.shape[3]
    wrow[:, :] = -1
    for d in range(D):
        for q in range(Q):
            j = flank[i, d, q]
            if j < 0:
                continue
            for s in range(lam):
                if w[i, d, q, s] != 0.0:
                    wrow[d, j] = q
                    break


def _slot_py(pins, row, d, pin):  # pragma: no cover (compiled)
    """Where ``pin`` stands among disc d's candidates at crank angle ``row`` (``pins``
    (A, D, P), −1 for padding): its position, −1 where it is none (or ``pin`` < 0)."""
    if pin < 0:
        return -1
    for q in range(pins.shape[2]):
        if pins[row, d, q] == pin:
            return q
    return -1


_slot = _slot_py  # compiled in place (inlined) by _kernels


def _carry_py(out, x, own, pins, i, back, z0, lam):  # pragma: no cover (compiled)
    """``out`` = the solution at crank angle i − back with each pin unknown carried by its
    pin, ``own``'s where that pin was no candidate there (equilibrium._body_carried)."""
    m = out.size
    D, P = pins.shape[1], pins.shape[2]
    for r in range(m):
        out[r] = x[i - back, r]
    for d in range(D):
        zd = z0 + d * lam
        for q in range(P):
            found = _slot(pins, i - back, d, pins[i, d, q])
            if found >= 0:
                out[zd + q] = x[i - back, zd + found]
            else:
                out[zd + q] = own[zd + q]


_WARM = True  # the warm start chosen by the crank angles before (task i46a)
"""The warm start of a crank angle of the default active set's reduced iteration
(``_ACTIVE`` 1), chosen by the crank angles before: the solution before (each pin unknown
carried by its pin) where at the crank angle before it was nearer the solution than the
line through the two before it (:func:`_still_py`: at a light torque the disc moves in
its bearings' play and the solution jumps between crank angles, where a line overshoots);
else the parabola through the three solutions before where those three were one smooth
stretch (:func:`_smooth_py`: the same loaded pins and crank bearings, none at the edge of
its clearance; :func:`_bend_py`); else the line through two, as before. On the 8-ring
stage tolerance study's 24 solves (numba, main's kernel replayed): at 412 N·m
evaluations 5.67 → 5.48 a crank angle, Hessians 2.01 → 2.00, factorisations 1.60 →
1.60; at ±12.36 N·m 6.61 → 5.82, 3.28 → 2.81, 3.09 → 2.66. Where a contact's load is set on
or off the solution has a kink and the parabola does worse than the line (without the
check more Hessians than the line). K's iteration and ``_ACTIVE`` 2 keep the line: a
crank bearing entering contact at a light torque carries a load the iteration resolves
only to ~10⁻¹¹ N (its δ^(10/9) law's linear convergence), and there the parabola's start
moved it by 1.3–2.1·10⁻¹³ of the largest roller load. False: the line everywhere, bit
for bit the kernel before."""
_EDGE = 1e-6
"""A contact's load at the edge of its clearance (:func:`_smooth_py`): at most this
fraction of the largest load of its kind (pins, crank bearings) at the crank angle
before."""


def _smooth_py(pf, bf, i):  # pragma: no cover (compiled)
    """Whether crank angles i − 3, i − 2 and i − 1 were one smooth run: each pin (``pf[0]``,
    the pins' forces at each solution) and each crank bearing (``bf``'s forces) without
    load at all three or loaded at all three beyond ``_EDGE`` of the largest load of its
    kind (a contact at the edge of its clearance: a kink of the solution near, and its load
    the round-off's to ~1e-13 of the largest, task i46a)."""
    D, P, N = pf.shape[2], pf.shape[3], bf.shape[2]
    big = 0.0
    bigb = 0.0
    for d in range(D):
        for j in range(P):
            big = max(big, pf[0, i - 1, d, j])
        for k in range(N):
            bigb = max(bigb, bf[i - 1, d, k, 0] ** 2 + bf[i - 1, d, k, 1] ** 2)
    edge = _EDGE * big
    edgeb = _EDGE * _EDGE * bigb
    for d in range(D):
        for j in range(P):
            a = pf[0, i - 1, d, j] > 0.0
            for b in range(1, 4):
                f = pf[0, i - b, d, j]
                if a != (f > 0.0) or (a and f <= edge):
                    return False
        for k in range(N):
            a = bf[i - 1, d, k, 0] != 0.0 or bf[i - 1, d, k, 1] != 0.0
            for b in range(1, 4):
                f = bf[i - b, d, k, 0] ** 2 + bf[i - b, d, k, 1] ** 2
                if a != (f > 0.0) or (a and f <= edgeb):
                    return False
    return True


def _still_py(x, i, z0, rot, L):  # pragma: no cover (compiled)
    """Whether the solution at crank angle i − 2 was nearer that at i − 1 than the line
    through i − 3 and i − 2 (the largest difference of the unknowns before the body's,
    rotations times the reference length ``L``): the warm start at i from i − 1 alone."""
    el = 0.0
    ec = 0.0
    for r in range(z0):
        w = L if rot[r] else 1.0
        el = max(el, abs(2.0 * x[i - 2, r] - x[i - 3, r] - x[i - 1, r]) * w)
        ec = max(ec, abs(x[i - 2, r] - x[i - 1, r]) * w)
    return ec < el


def _bend_py(out, x, prev, pins, i, z0, lam):  # pragma: no cover (compiled)
    """``out`` = the parabola through the solutions at crank angles i − 3, i − 2, i − 1,
    evaluated at i (3·x₋₁ − 3·x₋₂ + x₋₃), each pin unknown carried by its pin; where that
    pin was no candidate at i − 3 the line through i − 2, i − 1, at i − 2 ``prev``'s (the
    solution at i − 1 carried: :func:`_carry_py`'s start)."""
    m = out.size
    D, P = pins.shape[1], pins.shape[2]
    for r in range(m):  # (the holes' unknowns, after the pins' of each disc, too)
        out[r] = 3.0 * (x[i - 1, r] - x[i - 2, r]) + x[i - 3, r]
    for d in range(D):
        zd = z0 + d * lam
        for q in range(P):
            f2 = _slot(pins, i - 2, d, pins[i, d, q])
            f3 = _slot(pins, i - 3, d, pins[i, d, q])
            v1 = prev[zd + q]
            if f2 >= 0 and f3 >= 0:
                out[zd + q] = 3.0 * (v1 - x[i - 2, zd + f2]) + x[i - 3, zd + f3]
            elif f2 >= 0:
                out[zd + q] = 2.0 * v1 - x[i - 2, zd + f2]
            else:
                out[zd + q] = v1


def newton(
    p,
    law,
    x: FloatArray,
    discs: int,
    jacobian: FloatArray,
    settings: tuple,
    stats: dict | None = None,
    state: dict | None = None,
    start=None,
    ahead: bool = True,
) -> NDArray[np.bool_]:
    """The compliant disc's :func:`cyclomesh.stage.newton.newton` (with ``failed``), every
    crank angle to its end in one compiled pass, in order, warm from the ones before
    (module docstring). ``x`` (A, m): every crank angle's own start, overwritten by the
    solution where the kernel finished it (its own start left where it did not);
    ``settings``: the reference's (FORCE_TOLERANCE, _MAX_ITERATIONS, _MAX_HALVINGS,
    _STEP_CAP, *_LINEAR, ROUND_OFF_FORCE, _STALL_HALVINGS, _STALL_ITERATIONS,
    _QUADRATIC, _LAST_STEP, _CHORD, run). Returns the crank angles it could not finish.
    ``stats``: a dict that receives ``counts`` (A, 5): each crank angle's evaluations, its
    steps (Newton's and chord steps), how it ended (0 converged, 1 the last step, 2 an
    inversion failed, 3 the saddle's stall, 4 a singular step, 5 the line search's
    give-up, 6 the steps' limit), its evaluations with the Hessian and its
    factorisations (each step not a chord step). ``state``: a dict that receives, where
    every crank angle was finished, the state at the solution as
    :func:`cyclomesh.stage.assembly.evaluate`'s (``pin_force``, ``pin_shift`` (A, D, P),
    ``bearing_fx``, ``bearing_fy``, ``deflection`` (A, D, N)) and ``gradient`` (A, m), the
    scaled gradient there (the evaluation the caller need not repeat). ``start``: None,
    every row of ``x`` is a crank angle's own start; else ``x``'s rows are ignored and
    ``start(idx)`` gives the own starts (len(idx), m) of the crank angles ``idx``, formed
    only where the iteration reads them (:func:`_owned`): those it reads whatever the
    iteration does (the first of each run, and where ``_carry`` takes a pin unknown of a
    pin that was no candidate at the crank angle before: in one call, with ``ahead``),
    then, one call each, the crank angles whose warm starts it cannot evaluate or whose
    warm iteration fails (the cold retry): the kernel stops there and goes on from where
    it stopped, its memo kept. Each start is the caller's row, so the solution's bits
    are those from every start formed (tests/stage/test_own_starts.py)."""
    (force, iterations, halvings, cap, low, high, round_off, stall_h, stall_it, quad, last,
     reuse, run) = settings  # fmt: skip
    A, m = x.shape
    G, cols, core, blocks, hole, const, nw, carrier, pin_w, energy, pins, block = _prepare(
        p, law, x, discs, jacobian
    )
    sup = p.supports
    failed = np.zeros(A, np.bool_)
    counts = np.zeros((A, 5), np.int64)  # evaluations, steps, how it ended, Hessians, LDLᵀs
    astats = np.zeros((A, 3), np.int64)  # the active set's pin unknowns, grows, left for K
    D, P, N = p.bl.shape[1], p.bl.shape[2], p.hx.shape[-1]
    pf, bf, gout = np.zeros((2, A, D, P)), np.zeros((A, D, N, 3)), np.zeros((A, m))
    whole = np.ones(1, np.bool_)  # the state at every solution formed
    if start is None:
        own = x.copy()
        have = np.ones(A, np.bool_)
        need = have
    else:
        own = np.zeros_like(x)
        have = np.zeros(A, np.bool_)
        need = _owned(pins, int(run))
        if ahead:
            idx = np.flatnonzero(need)
            if idx.size:
                own[idx] = start(idx)
                have[idx] = True
    memo = np.zeros((3, D, P))  # each pin's last inversion (δ, y, F), call to call
    resume = np.zeros(2, np.int64)  # where the kernel stopped, its chord guess (call to call)
    first = 0
    while first < A:
        first = _kernels()[1](
            first, have, need, memo, resume, x, own, block, pin_w, energy, pins, hole, G, cols,
            core, blocks, const, nw, float(sup.carrier) if carrier else 0.0, carrier,
            0.5 * law.rs.clearance, law.rs.constant, float(p.torque), float(p.scale),
            force * abs(p.torque) / p.scale, round_off * abs(p.torque) / p.scale,
            iterations, halvings, cap, low, high, stall_h, stall_it, quad, bool(last),
            float(reuse), int(run), failed, counts, pf, bf, gout, whole, int(_ACTIVE), astats,
            bool(_WARM), bool(_ONCE),
        )  # fmt: skip
        if first < A:  # the own start of crank angle ``first`` asked for
            own[first] = start(np.array([first]))[0]
            have[first] = True
    if stats is not None:
        stats["counts"] = counts
        stats["active"] = astats
    if state is not None and whole[0] and not np.any(failed):
        state.update(
            pin_force=pf[0],
            pin_shift=pf[1],
            bearing_fx=bf[..., 0],
            bearing_fy=bf[..., 1],
            deflection=bf[..., 2],
            gradient=gout,
        )
    return failed


def _owned(pins: NDArray[np.int64], run: int) -> NDArray[np.bool_]:
    """The crank angles (A,) whose own start :func:`_newton_rows` reads whatever its
    iteration does: the first of each run of ``run`` and those with a candidate pin
    (``pins`` (A, D, P), −1 padding) that was no candidate at the crank angle before
    (``_carry`` takes its unknown from the own start; padding's is 0 in any start)."""
    need = np.zeros(pins.shape[0], np.bool_)
    _kernels()  # (compiles _owned_rows)
    _owned_rows(pins, run, need)
    return need


def _owned_rows_py(pins, run, need):  # pragma: no cover (compiled)
    """:func:`_owned` written for numba."""
    A = pins.shape[0]
    none = np.zeros(A, np.bool_)
    for i in range(A):
        need[i] = i % run == 0 or _carried(none, pins, i)


def _carried_py(have, pins, i):  # pragma: no cover (compiled)
    """Whether ``_carry`` at crank angle i from i − 1 reads an own start it does not
    ``have`` (a candidate pin that was none at i − 1)."""
    if have[i]:
        return False
    D, P = pins.shape[1], pins.shape[2]
    for d in range(D):
        for q in range(P):
            if pins[i, d, q] >= 0 and _slot(pins, i - 1, d, pins[i, d, q]) < 0:
                return True
    return False


def _newton_rows(
    begin, has, need, memo, resume, x, own, pin, pin_w, energy, pins, hole, G, cols, core,
    blocks, const, nw, kcarrier, carrier, half, kn, torque, L, tol, floor, iterations,
    halvings, cap, low, high, stall_h, stall_it, quad, last_on, reuse, run, failed, counts,
    pf, bf, gout, whole, active, astats, chosen, once,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`newton` written for numba: cyclomesh.stage.newton.newton's iteration with
    ``failed`` (rigid=False, the compliant disc), crank angle by crank angle, from crank
    angle ``begin`` on; returns the first crank angle whose own start it reads and ``has``
    not (A when all are done), with ``memo`` (3, D, P) (each pin's last inversion) and
    ``resume`` (2,) as they are there: where it stopped (0 the crank angle's top, 1 after
    its warm starts failed, 2 its cold retry) and its chord guess (``first``), which the
    call that goes on from there reads. ``need`` (A,): the crank angles whose own start
    the warm start's ``_carry`` reads (:func:`_owned`). ``active`` 1: each warm crank
    angle iterated on an active set of the body's pin unknowns (:func:`_choose_py`; 2: an
    empty one, every pin added by the check; 0: all of them), ``astats`` (A, 3): its body
    unknowns a disc at the start (the holes' too; 0: all), the times the set grew, 1
    where it was left for all. ``chosen``: the warm start chosen by the crank angles
    before (:data:`_WARM`), else the line through two. ``once``: the active set's
    iteration stretches a step after one residual ratio in ``_LINEAR`` (:data:`_ONCE`),
    else after two as K's."""
    A, mf = x.shape
    m = mf
    D, P = pin.shape[2], pin.shape[3]
    lam = energy.shape[3]
    z0 = m - D * lam
    eps = 2.220446049250313e-16
    p = 10.0 / 9.0
    base = 1 + 3 * D
    rot = np.zeros(m, np.bool_)
    rot[0] = True
    for d in range(D):
        rot[1 + 3 * d] = True
    if carrier:
        rot[base + nw] = True
    gB, gtB, trialB = np.zeros(mf), np.zeros(mf), np.zeros(mf)
    stepB, xiB = np.zeros(mf), np.zeros(mf)
    HB, HtB = np.zeros(mf * mf), np.zeros(mf * mf)
    g, gt, trial, step, xi = gB[:mf], gtB[:mf], trialB[:mf], stepB[:mf], xiB[:mf]
    H, Ht = HB[: mf * mf].reshape((mf, mf)), HtB[: mf * mf].reshape((mf, mf))
    prev = np.zeros(mf)  # the warm starts, the solution, its gradient: K's layout
    trialF = np.zeros(mf)
    xF = np.zeros(mf)
    gF = np.zeros(mf)
    HF = np.zeros((mf, mf))
    # the active set (task i45e): the reduced problem's arrays at index 0, its map
    Q = pin_w[0].shape[2]
    N = hole.shape[3]
    ebuf = np.zeros(D * lam * lam)
    wbuf = np.zeros(D * Q * lam)
    fa = np.zeros((1, D, Q), np.int64)
    Ga = np.zeros((1, D, N, 2, mf))
    ca = np.zeros((D, N, 1 + mf), np.int64)
    act = np.zeros((D, lam), np.bool_)
    amap = np.zeros((D, lam), np.int64)
    ident = np.zeros((D, lam), np.int64)
    for d in range(D):
        for q in range(lam):
            ident[d, q] = q
    loaded = np.zeros((D, P), np.bool_)
    nc = core.size
    S = np.zeros((nc, nc))
    Z = np.zeros((blocks.shape[1], nc + 1))
    rhs = np.zeros(nc)
    sc = np.zeros(nc)
    nr = z0
    Sb = np.zeros((nr, nr))
    Yb = np.zeros((D, lam, nr + 1))
    rb = np.zeros(nr)
    sb = np.zeros(nr)
    cl = np.zeros((D, nr + 1), np.int64)
    Tb = np.zeros((nr + 1, nr + 1))
    dg = np.zeros((D, lam))
    Lb = np.zeros((D, lam, lam))
    pv = np.zeros(nr, np.int64)
    vb = np.zeros((D, lam))
    Wd = np.zeros((D, lam, nr))  # Δ⁻¹·W_R of the kept factors
    ds = np.zeros(nr)  # S's reciprocal pivots
    wrow = np.zeros((D, P), np.int64)  # the row of pin_w of each flank, −1: none
    scratch = np.zeros((3, max(m, D * pin_w[0].shape[2], lam, 9)))
    zz = np.zeros((D, energy.shape[3], energy.shape[3]))  # Σ k·w·wᵀ of each disc's pins
    want_t = 3  # a trial's evaluation: 3 with its Hessian (the next step Newton's), else 1
    diag = 1.0
    first = resume[1] != 0  # the last angle's first step too slow for a chord step after it
    for i in range(begin, A):
        # a warm start that ends on the saddle (or fails otherwise) is tried once more
        # from the crank angle's own start before the NumPy path is asked
        cold = False
        again = 0  # the call goes on at crank angle ``begin`` from where the last stopped
        if i == begin:
            again = resume[0]
            resume[0] = 0
            cold = again == 2
        red = active == 2 or (
            active == 1 and i % run != 0 and not failed[i - 1] and not (i == begin and again)
        )
        la = lam
        if red:
            la = _choose(act, amap, loaded, pf, pins, i, lam, active == 2)
            red = la < lam
        grows = 0
        restart = False
        astats[i, 0] = la if red else 0  # (its checks, not in ``counts``: 1 + its grows)
        while True:
            if red:
                en, wa = _reduce(
                    i, amap, la, energy, pin_w[0], pin_w[1], G, cols, z0, ebuf, wbuf, fa,
                    Ga, ca,
                )  # fmt: skip
                pw = (wa, fa)
                Gu, cu, ib, mp = Ga, ca, 0, amap
            else:
                la = lam
                en, pw, Gu, cu, ib, mp = energy, pin_w, G, cols, i, ident
            m = z0 + D * la
            _rows(wrow, pw, ib)
            g, gt, trial, step, xi = gB[:m], gtB[:m], trialB[:m], stepB[:m], xiB[:m]
            H, Ht = HB[: m * m].reshape((m, m)), HtB[: m * m].reshape((m, m))
            _compact(xi, own[i], z0, D, lam, la, mp)
            have = False
            energy_i, status = 0.0, 0
            warm = i % run != 0 and not failed[i - 1] and not cold
            ask = not warm and not has[i]  # (from its top, or its cold retry: 2)
            if restart:  # a grown set's, or K's after it: from the reduced root (xF)
                _compact(xi, xF, z0, D, lam, la, mp)
                memo[0] = 0.0
                restart = False
            elif ask or (warm and again == 0 and need[i] and not has[i]):
                resume[0] = 2 if cold else 0
                resume[1] = 1 if first else 0
                return i
            elif warm and again == 0:
                # warm start: the line through the two solutions before (the default
                # active set's: the one before where it predicted the crank angle before
                # better, the parabola through three on a smooth stretch, task i46a), else
                # the one before, each pin unknown carried by its pin (equilibrium._body_warm)
                line = i % run >= 2 and not failed[i - 2]
                choose = chosen and red and active == 1  # (task i46a)
                still = (
                    choose and line and i % run >= 3 and not failed[i - 3]
                    and _still(x, i, z0, rot, L)
                )  # fmt: skip
                bend = choose and line and not still and i % run >= 3 and not failed[i - 3]
                bend = bend and _smooth(pf, bf, i)
                _carry(prev, x, own[i], pins, i, 1, z0, lam)
                s1 = 1
                e1 = 0.0
                for attempt in range(0 if line and not still else 1, 2):
                    if attempt == 0 and bend:
                        _bend(trialF, x, prev, pins, i, z0, lam)
                        _compact(trial, trialF, z0, D, lam, la, mp)
                    elif attempt == 0:
                        _carry(trialF, x, prev, pins, i, 2, z0, lam)
                        for r in range(mf):
                            trialF[r] = 2.0 * prev[r] - trialF[r]
                        _compact(trial, trialF, z0, D, lam, la, mp)
                    else:
                        _compact(trial, prev, z0, D, lam, la, mp)
                    e1, s1 = _evaluate_one(
                        i, ib, trial, pin, pw, en, hole, Gu, cu, const, nw, kcarrier, carrier,
                        half, kn, torque, L, 3, g, H, memo, pf, bf, wrow, scratch, zz,
                    )  # fmt: skip
                    counts[i, 0] += 1
                    counts[i, 3] += 1
                    if s1 == 0:
                        break
                if s1 == 0:
                    for r in range(m):
                        xi[r] = trial[r]
                    energy_i, status, have = e1, s1, True
                elif not has[i]:  # neither warm start evaluated: from its own, asked for
                    resume[0] = 1
                    resume[1] = 1 if first else 0
                    return i
            elif warm:  # (again 1: the warm starts failed before the call, from the own)
                again = 0
            else:
                memo[0] = 0.0
            previous = np.inf
            extended = False
            linear = False
            best = np.inf
            since = 0
            ok_angle = False
            stay = False
            how = 6
            fresh = have  # H is the Hessian at xi (the warm start's evaluation)
            kept = False  # the factors of a Hessian kept (_solve_ldl's 1): chord steps
            barred = False  # a chord step failed: Newton's steps to the end of the angle
            moves = 0
            for _ in range(iterations):
                if not have:
                    energy_i, status = _evaluate_one(
                        i, ib, xi, pin, pw, en, hole, Gu, cu, const, nw, kcarrier, carrier,
                        half, kn, torque, L, 3, g, H, memo, pf, bf, wrow, scratch, zz,
                    )  # fmt: skip
                    counts[i, 0] += 1
                    counts[i, 3] += 1
                    fresh = True
                have = False
                if status == 2:
                    how = 2
                    break
                near = True
                res = 0.0
                for r in range(m):
                    res = max(res, abs(g[r]))
                    if near and not (abs(g[r]) <= tol):  # the round-off of the unknowns?
                        noise = 0.0
                        for s in range(m):  # (H's upper triangle: H_rs = H_sr)
                            xs = abs(xi[s]) * L if rot[s] else abs(xi[s])
                            noise += abs(H[r, s] if s >= r else H[s, r]) * xs
                        noise *= 16.0 * eps
                        if not (abs(g[r]) <= max(tol, noise)):
                            near = False
                if near and (res <= floor or res >= previous or stay):
                    ok_angle = True
                    how = 0
                    break
                stay = False
                # a chord step (the kept factors of an earlier Hessian) where the last step
                # cut the residual by ``reuse`` at least; else Newton's (a linear tail, a
                # nearly singular H: a chord step there can run far, the round-off)
                chord = (not fresh) and kept and res <= reuse * previous and not barred
                if moves == 1:  # the first step's rate: the next angle's guess
                    first = res > reuse * previous
                if not fresh and not chord:
                    energy_i, status = _evaluate_one(
                        i, ib, xi, pin, pw, en, hole, Gu, cu, const, nw, kcarrier, carrier,
                        half, kn, torque, L, 3, g, H, memo, pf, bf, wrow, scratch, zz,
                    )  # fmt: skip
                    counts[i, 0] += 1
                    counts[i, 3] += 1
                    fresh = True
                    if status == 2:
                        how = 2
                        break
                # the last step untried where the next residual is predicted at the
                # round-off: Newton's quadratically, a chord step's at its linear rate
                take_last = (
                    last_on
                    and near
                    and not linear
                    and (
                        (fresh and res <= quad * previous and res**3 <= floor * previous**2)
                        or (chord and res * res <= floor * previous)
                    )
                )
                saved = (previous, extended, linear, best, since)  # (a chord step's retry)
                # the trial's Hessian where the next step is predicted Newton's: every step,
                # else a linear tail (this step's rate poor), the first step as the last angle's
                if reuse <= 0.0:
                    want_t = 3
                elif chord or near:
                    want_t = 1
                elif previous == np.inf:
                    want_t = 3 if first else 1
                else:
                    want_t = 3 if res > reuse * previous else 1
                if res < best:
                    best = res
                    since = 0
                else:
                    since += 1
                if not near and since >= stall_it:
                    how = 3
                    break  # the saddle: given up to the caller
                ratio = res > low * previous and res < high * previous
                # the stretched step (×p) after two ratios in the window, after one in
                # the active set's iteration (task i47a, _ONCE: a roller's linear tail)
                stretch = (not extended) and ratio and (linear or (once and red))
                linear = ratio and not extended
                previous = res
                if chord:
                    _resolve(g, step, nr, D, la, Sb, Yb, rb, sb, cl, dg, Lb, pv, vb, Wd, ds)
                    solved = True
                else:
                    diag = 0.0
                    for r in range(m):
                        diag = max(diag, abs(H[r, r]))
                    diag = max(diag, 1e-300)
                    for r in range(m):
                        H[r, r] += 1e-14 * diag
                    code = _solve_ldl(
                        H, g, step, nr, D, la, Sb, Yb, rb, sb, cl, Tb, dg, Lb, pv, vb, Wd, ds
                    )  # fmt: skip
                    counts[i, 4] += 1
                    kept = code == 1 and reuse > 0.0
                    solved = code != 0
                    if code != 1:  # H overwritten by an LU: the trial's Hessian for the test
                        want_t = 3
                    if not solved:  # a body block's pivot 0: the whole H, evaluated again
                        _evaluate_one(
                            i, ib, xi, pin, pw, en, hole, Gu, cu, const, nw, kcarrier,
                            carrier, half, kn, torque, L, 2, g, H, memo, pf, bf, wrow,
                            scratch, zz,
                        )  # fmt: skip
                        for r in range(m):
                            H[r, r] += 1e-14 * diag
                        if red:  # (the reduced H: K's retry does it)
                            solved = False
                        elif blocks.shape[0]:
                            solved = _solve_blocks(H, g, step, core, blocks, S, Z, rhs, sc)
                        else:
                            solved = _solve_in_place(H, g, step)
                if not solved:
                    how = 4
                    break
                counts[i, 1] += 1
                slope = 0.0
                for r in range(m):
                    slope += g[r] * step[r]
                flip = not slope < 0.0
                if flip and chord:  # not a descent: the Hessian here instead
                    previous, extended, linear, best, since = saved
                    kept = False
                    barred = True
                    continue
                if flip:
                    slope = 0.0
                    for r in range(m):
                        step[r] = -g[r] / diag
                        slope += g[r] * step[r]
                t = p if stretch else 1.0
                reach = 0.0
                for r in range(m):
                    reach = max(reach, abs(step[r]))
                if reach * t > cap:
                    t = cap / (reach if reach > 0 else 1.0)
                extended = stretch
                if take_last and not flip and t == 1.0:  # the last step, without a trial
                    for r in range(m):
                        xi[r] = xi[r] + (step[r] / L if rot[r] else step[r])
                    ok_angle = True
                    how = 1
                    break
                tiny = -slope <= 1e-13 * max(abs(energy_i), 1e-300)
                work = torque * xi[0]
                flat = (not tiny) and -slope <= 1e-13 * (abs(energy_i + work) + abs(work))
                norm = 0.0
                if flat:
                    for r in range(m):
                        norm += g[r] * g[r]
                    norm = np.sqrt(norm)
                moved = False
                st = 0
                gave_up = False
                for _h in range(halvings):
                    for r in range(m):
                        trial[r] = xi[r] + (step[r] * t / L if rot[r] else step[r] * t)
                    # the trial's gradient, and its Hessian where the next step is predicted
                    # to be Newton's (every step; a linear tail: this step's rate poor)
                    e_t, st = _evaluate_one(
                        i, ib, trial, pin, pw, en, hole, Gu, cu, const, nw, kcarrier, carrier,
                        half, kn, torque, L, want_t, gt, Ht, memo, pf, bf, wrow, scratch, zz,
                    )  # fmt: skip
                    counts[i, 0] += 1
                    if want_t == 3:
                        counts[i, 3] += 1
                    if st == 2:
                        break
                    ok = e_t <= energy_i + 1e-4 * t * slope or tiny
                    if flat:
                        norm_t = 0.0
                        for r in range(m):
                            norm_t += gt[r] * gt[r]
                        ok = np.sqrt(norm_t) <= (1.0 - 1e-4 * t) * norm
                    if st == 0 and ok and chord:  # a chord step: the residual falls too
                        res_t = 0.0
                        for r in range(m):
                            res_t = max(res_t, abs(gt[r]))
                        ok = res_t < res
                    if st == 0 and ok:
                        for r in range(m):
                            xi[r] = trial[r]
                        g, gt = gt, g
                        if want_t == 3:
                            H, Ht = Ht, H
                        energy_i, status, have = e_t, st, True
                        fresh = want_t == 3
                        if fresh:
                            kept = False
                        moves += 1
                        moved = True
                        break
                    if chord:  # (one trial: else Newton's step from here)
                        break
                    if _h + 1 >= stall_h and not near:
                        gave_up = True
                        break
                    extended = False
                    t = 1.0 if t > 1.0 else 0.5 * t
                if not moved and chord:  # the chord step failed: Newton's from here
                    previous, extended, linear, best, since = saved
                    kept = False
                    barred = True
                    continue  # (xi evaluated again: the state there)
                if not moved:
                    if gave_up or not (near and flat and st != 2):
                        how = 5 if st != 2 else 2
                        break
                    stay = True
            if not ok_angle and red:  # the reduced iteration failed: K's from its start
                red = False
                astats[i, 2] = 1
                continue
            if ok_angle and red:  # the check: every pin left out carries no load
                _expand(xF, xi, z0, D, lam, la, mp)
                _rows(wrow, pin_w, i)
                _, st = _evaluate_one(
                    i, i, xF, pin, pin_w, energy, hole, G, cols, const, nw, kcarrier, carrier,
                    half, kn, torque, L, 1, gF, HF, memo, pf, bf, wrow, scratch, zz,
                )  # fmt: skip
                grown = _grow(act, amap, pf, pins, xF, i, z0, lam)
                if grown:  # those pins' unknowns added (z = c0·F), from the root reached
                    grows += 1
                    astats[i, 1] += 1
                    restart = True
                    ok_angle = False
                    if grows > _GROWS:
                        red = False
                        astats[i, 2] = 1
                    else:
                        la = grown
                    continue
                if st == 2:
                    whole[0] = False
                break
            if ok_angle or cold or not warm:
                break
            cold = True
        counts[i, 2] = how
        if ok_angle and red:  # (the state at xF formed by the check)
            for r in range(mf):
                x[i, r] = xF[r]
                gout[i, r] = gF[r]
        elif ok_angle:
            if how == 1:  # the last step was taken untried: the state there
                _, st = _evaluate_one(
                    i, ib, xi, pin, pw, en, hole, Gu, cu, const, nw, kcarrier, carrier,
                    half, kn, torque, L, 1, g, H, memo, pf, bf, wrow, scratch, zz,
                )  # fmt: skip
                if st == 2:
                    whole[0] = False
            for r in range(m):
                x[i, r] = xi[r]
                gout[i, r] = g[r]
        else:
            failed[i] = True
            for r in range(mf):
                x[i, r] = own[i, r]
    resume[1] = 1 if first else 0
    return A


_ONCE = True
"""The active set's iteration (``_ACTIVE`` 1 or 2; K's keeps two) stretches its step by
p = 10/9 after ONE residual ratio in ``_LINEAR`` (task i47a), not two: a linear tail is a
crank bearing's roller law F ∝ δ^p near δ = 0 (a bearing leaving contact at the root),
where Newton's step takes δ to δ·(1 − 1/p) = δ/10 (the residual by 10^(−10/9) = 0.077)
and the step ×p lands δ = 0 at once. At ±12.36 N·m a stage tolerance ring's crank angles
−10 % Hessians and factorisations (2.80 → 2.52, 2.67 → 2.39), −6 % evaluations; 412 N·m
+1 %. The root is the same to round-off (the same test ends it,
tests/stage/test_linear_tail_fe.py). False: after two, the iteration before."""
_GROWS = 3  # the times a crank angle's active set may grow; then all the pins'
_ACTIVE = 1  # newton's active set (_newton_rows' ``active``): 1 on, 0 off, 2 from empty


def _fill_py(act, amap, lam):  # pragma: no cover (compiled)
    """The active set's size Λ_a (the most of any disc's; a disc with fewer takes its
    first left-out unknowns too: the kernel's discs share Λ_a) and ``amap`` (D, Λ_a): the
    unknowns of each disc in their order."""
    D = act.shape[0]
    la = 0
    for d in range(D):
        n = 0
        for q in range(lam):
            if act[d, q]:
                n += 1
        la = max(la, n)
    for d in range(D):
        n = 0
        for q in range(lam):
            if act[d, q]:
                n += 1
        for q in range(lam):
            if n >= la:
                break
            if not act[d, q]:
                act[d, q] = True
                n += 1
        n = 0
        for q in range(lam):
            if act[d, q]:
                amap[d, n] = q
                n += 1
    return la


def _choose_py(act, amap, loaded, pf, pins, i, lam, empty):  # pragma: no cover
    """Crank angle i's active set ``act`` (D, Λ): the hole unknowns (after the pins'), and
    each pin unknown whose pin (``pins``, Body.pins: its flank; −1, padding: none) or a
    neighbour of it (the next pin each side, of the same flank's n1) carried load at crank
    angle i − 1 (``pf[0, i − 1]``); ``empty``: the hole unknowns only. Returns Λ_a
    (:func:`_fill_py`)."""
    D, P = loaded.shape
    Q = pins.shape[2]
    for d in range(D):
        for j in range(P):
            loaded[d, j] = (not empty) and i > 0 and pf[0, i - 1, d, j] > 0.0
    n1 = P // 2
    for d in range(D):
        for q in range(lam):
            if q >= Q:
                act[d, q] = True
                continue
            j = pins[i, d, q]
            if j < 0:
                act[d, q] = False
                continue
            a = loaded[d, j]
            if not a and n1 > 0 and P == 2 * n1:
                h = (j // n1) * n1
                r = j - h
                a = loaded[d, h + (r + 1) % n1] or loaded[d, h + (r + n1 - 1) % n1]
            act[d, q] = a
    return _fill(act, amap, lam)


def _grow_py(act, amap, pf, pins, xF, i, z0, lam):  # pragma: no cover (compiled)
    """The check of a reduced root (``pf[0, i]``: the pins' forces at ``xF``, K's layout):
    each left-out pin unknown whose pin carries load F is added, its z set to c0·F (c0
    = z/F of the most loaded pin in the set: at the root z = c0·λ, λ the load). Returns the
    new Λ_a (:func:`_fill_py`), 0 where none carries load (the reduced root is K's)."""
    D = act.shape[0]
    Q = pins.shape[2]
    big = 0.0
    c0 = 0.0
    for d in range(D):
        for q in range(Q):
            j = pins[i, d, q]
            if act[d, q] and j >= 0 and pf[0, i, d, j] > big:
                big = pf[0, i, d, j]
                c0 = xF[z0 + d * lam + q] / big
    added = 0
    for d in range(D):
        for q in range(Q):
            j = pins[i, d, q]
            if not act[d, q] and j >= 0 and pf[0, i, d, j] > 0.0:
                act[d, q] = True
                xF[z0 + d * lam + q] = c0 * pf[0, i, d, j]
                added += 1
    if added == 0:
        return 0
    return _fill(act, amap, lam)


def _reduce_py(i, amap, la, energy, w, flank, G, cols, z0, ebuf, wbuf, fa, Ga, ca):
    """Crank angle i's arrays on the active set (``amap`` (D, Λ_a)) at index 0, the body
    unknowns of disc d from z0 + d·Λ_a: E's rows and columns, Body.w's columns (every
    row: each pin still moved by the set's unknowns), the bearing Jacobian's columns
    (``Ga``) and each hole's columns (``ca``). Returns (E_a, w_a), views of ``ebuf``,
    ``wbuf``."""  # pragma: no cover (compiled)
    D, lam = energy.shape[1], energy.shape[3]
    Q = w.shape[2]
    N = G.shape[2]
    en = ebuf[: D * la * la].reshape((1, D, la, la))
    wa = wbuf[: D * Q * la].reshape((1, D, Q, la))
    for d in range(D):
        for a in range(la):
            qa = amap[d, a]
            for b in range(la):
                en[0, d, a, b] = energy[i, d, qa, amap[d, b]]
        for q in range(Q):
            fa[0, d, q] = flank[i, d, q]
            for b in range(la):
                wa[0, d, q, b] = w[i, d, q, amap[d, b]]
    m = z0 + D * la
    for d in range(D):
        for k in range(N):
            for c in range(2):
                for r in range(z0):
                    Ga[0, d, k, c, r] = G[i, d, k, c, r]
                for r in range(z0, m):
                    Ga[0, d, k, c, r] = 0.0
                for b in range(la):
                    Ga[0, d, k, c, z0 + d * la + b] = G[i, d, k, c, z0 + d * lam + amap[d, b]]
            n = 0
            for u in range(cols[d, k, 0]):
                r = cols[d, k, 1 + u]
                if r < z0:
                    ca[d, k, 1 + n] = r
                    n += 1
            for b in range(la):
                ca[d, k, 1 + n] = z0 + d * la + b
                n += 1
            ca[d, k, 0] = n
    return en, wa


def _compact_py(out, full, z0, D, lam, la, amap):  # pragma: no cover (compiled)
    """``out`` (z0 + D·Λ_a) = ``full`` (K's layout) on the active set ``amap``."""
    for r in range(z0):
        out[r] = full[r]
    for d in range(D):
        for b in range(la):
            out[z0 + d * la + b] = full[z0 + d * lam + amap[d, b]]


def _expand_py(out, red, z0, D, lam, la, amap):  # pragma: no cover (compiled)
    """``out`` (K's layout) = ``red`` on the active set, 0 on the unknowns left out."""
    for r in range(z0):
        out[r] = red[r]
    for r in range(z0, out.size):
        out[r] = 0.0
    for d in range(D):
        for b in range(la):
            out[z0 + d * lam + amap[d, b]] = red[z0 + d * la + b]
