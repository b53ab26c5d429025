"""The stage's whole Newton iteration of one crank angle compiled (numba), beside the
NumPy reference :func:`cyclomesh.stage.newton.newton`.

With ``CYCLOMESH_KERNEL=numba`` (the one switch of :mod:`cyclomesh.core.kernel`) the
rigid discs' stage (no compliant disc, no friction, a bearing law without a series
spring) solves each crank angle to its end in one compiled pass (:func:`newton` for the
bearing phase, :func:`rigid_newton` for the rigid phase): the potential, gradient and
Hessian of :func:`cyclomesh.stage.equilibrium._evaluate` with the laws of
:mod:`cyclomesh.stage.kernel` (the pins' Eq. 20 of [1], the crank bearing's roller set of
[2]), the same step, stretched step, step cap, line search and convergence test. The
crank angles it cannot finish go back to the reference, which raises its own error.
The crank angles are solved in order, each after the first started from the line through
the solutions of the two before (the bearing phase from the parabola through the three
before once it has three; from the one before where a pin is past its law there;
:func:`run`: the whole revolution, where the reference's warm start,
:func:`cyclomesh.stage.equilibrium._warm`, restarts every
:data:`~cyclomesh.stage.newton.WARM_RUN` crank angles for its vectorised passes), the
pins' inversion memo kept; the root is the same at round-off. Savings the reference's
arithmetic does not see: an accepted line-search trial is evaluated with its gradient
and Hessian, which the next step then uses (the reference evaluates that point again
and gets the same numbers: each pin's inversion starts from its memo at the same
approach); the round-off of the unknowns (16ε·|H|·|x|) is formed only for a residual
above the tolerance, the only place it decides; the Newton step eliminates the crank
pins' deflections crankshaft by crankshaft before the pivoted elimination of the rest
(:func:`_solve_blocks`; Chebyshev's second solve from the first's LU factors,
:func:`_lu_again`); a pin's inversion starts from its last root by the inverse's
third-order Taylor series, takes Halley's steps and ends without a last exponential
after a small one (:data:`TINY_STEP`); a crank angle's own start is asked of the
caller only where the iteration needs it (:func:`newton` ``start``); the problem's arrays
are passed packed (:func:`pin_block`: a compiled call pays two atomic reference counts
per array; the pins' and rollers' laws are written out in the evaluations for that).
Steps of higher order and a last step left unevaluated (the root the same to
round-off, reached in fewer evaluations): the rigid phase's step is Halley's
(:data:`HALLEY`), the bearing phase's Chebyshev's (:data:`CHEBYSHEV`, the potential's third
derivative along the Newton step by :func:`_curvature`), and where Newton's quadratic
convergence predicts a residual far below the floor after the step from a crank angle's
iterate, that step is taken and the crank angle ends without evaluating its end
(:data:`LAST_PREDICTED`), its state moved there to first order (:func:`_last_state`),
unless a pin or a roller changes its state of the law on the way.
Split from :mod:`cyclomesh.stage.kernel` (the laws) as a pure move.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.jit import njit
from cyclomesh.stage.kernel import MAX_NEWTON, ROUND_OFF

__all__ = ["newton", "rigid_newton", "run", "pin_block", "PIN_BLOCK"]

FloatArray = NDArray[np.float64]

TINY_STEP = 1e-6
"""A pin's inversion (:func:`_pin_force`) ends with a Halley step in y = ln F no larger
than this: the error after it is C·h³ (Halley's cubic convergence, C = (1 − q)²/4 −
(1 − 2q)/6 with q = γ/(α − γ − γy), at most 24 where |q| ≤ 10, which that exit also
asks: below the law's stiffest point), ≤ 2.4·10⁻¹⁷ in y, a relative error of F below its
round-off, so that step's evaluation is not needed, and F = e^y·e^h with e^h = 1 + h +
h²/2 + h³/6 to round-off (the next term h⁴/24 ≤ 5·10⁻²⁶). Before: Newton's step, 10⁻⁹,
from a second-order start (i43s: the third-order start and Halley's step, ~15 % less
time an inversion, most from one exponential where there were two or three)."""
LAST_FALL = 1e-3
"""The last step (:data:`LAST_PREDICTED`): the residual |g| must have fallen to this
fraction of the one before or less (Newton's quadratic convergence), as the compliant
disc's ``newton._LAST_STEP``."""
LAST_PREDICTED = 1e-2
"""The last step of either phase: taken without evaluating its end where the residual
that Newton's quadratic convergence predicts there, |g|³/|g₋₁|² (after a Chebyshev step
C·|g|², C = |T[s, s]/2|/|g₋₁|² from its quadratic term), is at most this fraction of the
round-off floor (ROUND_OFF_FORCE·|T|/r_c); the largest residual |g| must also have fallen
to :data:`LAST_FALL` of the one before, the step before and this one unstretched and
uncapped. Traced on the benchmark's stage (360 crank angles, Newton's steps): a warm
start's residual of 3–70 N falls to 10⁻⁴–10⁻² N, then 10⁻¹³–10⁻⁹ N, each within a few
per cent of that prediction. The state at the end is the evaluation's before moved to
first order (:func:`_last_state`, :func:`rigid_newton`), a relative error of (dδ/δ)²
with dδ ~ 10⁻¹³ m; the gradient reported there (the residual) the linear model's."""
CHEBYSHEV = 0.5
"""The bearing phase's step (:func:`newton`) is Chebyshev's, Newton's s plus t = −H⁻¹·T[s,
s]/2 (T the potential's third derivative: the pins' stiffening and the crank bearings'
curvature, :func:`_curvature`), where |t| ≤ this·|s| (largest components) and the step is
neither a bearing's stretched step nor the last step, and the problem has no crankshaft
blocks (:func:`_solve_blocks`: with them, 20 unknowns, its copy, second solve and T cost
as much as the evaluations it saves on a tolerance ring); else Newton's. Cubic convergence
(Newton's residual after the first step ×0.005 in the median): the benchmark's stage
2.80 → 2.38 evaluations a crank angle with the last step (3.64 with neither)."""
HALLEY = 0.5
"""The rigid phase's step (:func:`rigid_newton`, one unknown c) is Halley's, Newton's
−g/h divided by 1 − q with q = g·h'/(2h²) (h' = Σ v³·γk³/F, the pins' stiffening, k = dF/dδ
= 1/(α − γ(1 + ln F)) of Eq. 20), where |q| is at most this; else Newton's. Cubic
convergence: a warm start's residual of 3–70 N falls to 10⁻⁸–10⁻⁴ N in one step (Newton's
to 10⁻⁴–10⁻²), from which the last step ends: the benchmark's stage 2.68 → 2.01
evaluations a crank angle with the last step (3.46 with neither)."""
PIN_BLOCK = ("bl", "arm", "nx", "ny", "alpha", "gamma", "dmax")
"""The per-pin arrays of a problem in the order of :func:`pin_block`."""


def run(angles: int) -> int:
    """The compiled iteration's warm-start run over ``angles`` crank angles solved in order:
    all of them (only the first from its own start), where the NumPy reference restarts
    every :data:`~cyclomesh.stage.newton.WARM_RUN` (its runs are vectorised passes,
    :func:`cyclomesh.stage.equilibrium._warm`). The root does not depend on the start
    (the iteration runs to round-off); from the line through the two solutions before,
    a crank angle of the stage tolerance study's ring needs 4.1 Newton steps at the rated
    torque and 5.2–5.5 at ∓3 % (runs of four: 4.9 and 7.0–7.6 evaluations).

    The bearing phase (:func:`newton`) starts a crank angle from the parabola through the
    solutions of the three before (3·x₋₁ − 3·x₋₂ + x₋₃) where it has them: the
    benchmark's stage from a residual of ~10 N to ~1 N, so that its third Newton step is
    the last where it was the fourth (evaluations a crank angle 4.00 → 3.64; the elastic
    stage at 412 N·m 4.10 → 3.75, at 12.36 N·m 4.79 → 4.78; a cubic through four: 3.74).
    The root is the same to round-off (the stage's outputs moved by up to 2.3e-14 of each
    one's largest against the line's). The rigid phase (:func:`rigid_newton`) keeps the
    line: a parabola needed more evaluations there (docs/stage.md)."""
    return max(int(angles), 1)


def newton(
    p,
    law,
    x: FloatArray,
    discs: int,
    jacobian: FloatArray,
    settings: tuple,
    state: dict | None = None,
    start=None,
    keep: dict | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """:func:`cyclomesh.stage.newton.newton` of the rigid discs' stage (``rigid=False``, no
    compliant disc, a bearing law without a series spring), every crank angle on its own
    in one compiled pass: the potential, gradient and Hessian of
    :func:`cyclomesh.stage.equilibrium._evaluate` (pins, crank bearings, crankshafts,
    end plate) assembled per crank angle on the nonzero columns of ``jacobian`` (∂d/∂x of
    the holes, :func:`~cyclomesh.stage.equilibrium.bearing_jacobian`), the same step, the
    same stretched step of a bearing at zero load, step cap, line search and convergence
    test. ``settings``: the reference's (FORCE_TOLERANCE, _MAX_ITERATIONS, _MAX_HALVINGS,
    _STEP_CAP, *_LINEAR, ROUND_OFF_FORCE), passed in by the caller (this module is
    imported by the bearing law, which cyclomesh.stage.newton imports). ``x`` (A, m) is
    overwritten by the solution; returns the crank angles the kernel could not finish
    (the caller solves them with the reference, which raises its own error where it fails
    too) and those whose own start it was given. ``start``: None, every row of ``x`` is
    a start; else a function of crank-angle indices giving their starts (k, m), asked
    for only where the iteration needs a crank angle's own start (the first, one after
    a failure, and where neither warm start can be evaluated), which it then leaves in
    ``x`` (the rigid solution, split and deflections of the others are never formed;
    the iteration stops at such a crank angle and goes on from it, its pins' memo
    kept). ``state``: a dict that receives the state at the solution of the crank angles
    it finished, as equilibrium._evaluate's: ``pin_force`` [N] (A, D, P), ``bearing_fx``,
    ``bearing_fy`` [N] and ``deflection`` [m] (A, D, N), and ``gradient`` (A, m), the
    scaled gradient of its convergence test (the evaluation at the solution the caller
    need not repeat). ``keep``: a dict of the caller's in which the arrays that depend on
    the problem but not on its torque (the bearings' columns and the block structure,
    the packed hole arrays and constants) are kept from one call to the next; it must be
    the caller's for this ``jacobian`` and this problem's holes, law and supports (the
    cache of :func:`cyclomesh.stage.equilibrium.solve_direction`); None: formed here.
    """
    force, iterations, halvings, cap, low, high, round_off, run = settings
    A, m = x.shape
    sup = p.supports
    N = p.hx.shape[-1]
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = sup is not None and sup.carrier is not None
    G = np.ascontiguousarray(jacobian)
    if keep is None or "kernel_columns" not in keep:
        cols, core, blocks, hole, const = _arrays(p, law, G, discs, nw, m)
        if keep is not None:
            keep["kernel_columns"] = (cols, core, blocks, hole, const)
    else:
        cols, core, blocks, hole, const = keep["kernel_columns"]
    failed = np.zeros(A, np.bool_)
    D, P = p.bl.shape[1], p.bl.shape[2]
    pf, bf, gout = np.zeros((A, D, P)), np.zeros((A, D, N, 6)), np.zeros((A, m))
    block = pin_block(p)
    started = np.full(A, start is None)
    memo = np.zeros((3, D, P))  # each pin's last inversion (δ, y, F), call to call
    first = 0
    while first < A:
        first = _kernels_newton()(
            first, started, memo, x, block, hole, G, cols, core, blocks, const, nw,
            float(sup.carrier) if carrier else 0.0, carrier, 0.5 * law.rs.clearance,
            law.rs.constant, float(p.torque), float(p.scale), force * abs(p.torque) / p.scale,
            round_off * abs(p.torque) / p.scale, iterations, halvings, cap, low, high, run,
            failed, pf, bf, gout,
        )  # fmt: skip
        if first < A:  # the own start of crank angle ``first`` asked for
            x[first] = start(np.array([first]))[0]
            started[first] = True
    if state is not None:
        state.update(
            pin_force=pf,
            bearing_fx=bf[..., 0],
            bearing_fy=bf[..., 1],
            deflection=bf[..., 2],
            gradient=gout,
        )
    return failed, started


def _arrays(p, law, G: FloatArray, discs: int, nw: int, m: int):
    """The torque-free arguments of :func:`_newton_rows`: each crank bearing's columns
    (D, N, 1 + c: their count, then the nonzero columns of ``G`` at any crank angle), the
    unknowns of :func:`_solve_blocks` (:func:`_structure`), the holes (4, A, D, N: hx, hy,
    the same for every disc, ex, ey) and the constants (the rollers' cosines, the discs'
    fractions of the end plate's turn, the crankshafts' stiffness (D, D) flat)."""
    sup = p.supports
    A, N = p.hx.shape
    # (D, N, m): the structure, any crank angle (the crank angles reduced first, along
    # the contiguous leading axis: the same booleans as np.any over axes (0, 3))
    nonzero, cols = _kernels_columns()(G)
    core, blocks = _structure(nonzero, discs, N, nw, m)
    hole = np.empty((4, A, discs, N))
    hole[0], hole[1], hole[2], hole[3] = p.hx[:, None, :], p.hy[:, None, :], p.ex, p.ey
    const = np.concatenate(
        [
            np.cos(law.rs.angles),
            np.zeros(discs) if sup is None else np.asarray(sup.fraction, dtype=float),
            np.zeros(discs * discs) if nw == 0 else np.asarray(sup.stiffness).ravel(),
        ]
    )
    return cols, core, blocks, hole, const


@cache
def _kernels_columns() -> Any:
    return njit()(_column_rows)


def _column_rows(G):  # pragma: no cover (compiled)
    """The columns of :func:`_arrays` in one pass: ``nonzero`` (D, N, m), True where
    ∂d/∂x (``G`` (A, D, N, 2, m)) of hole (d, k) has a nonzero (or NaN) entry in column j
    at any crank angle (np.any's booleans), and ``cols`` (D, N, 1 + c): each hole's count
    of them, then their indices in increasing order (c the largest count, at least 1)."""
    A, D, N, two, m = G.shape
    nonzero = np.zeros((D, N, m), np.bool_)
    for i in range(A):
        for d in range(D):
            for k in range(N):
                for r in range(two):
                    for j in range(m):
                        if G[i, d, k, r, j] != 0.0:
                            nonzero[d, k, j] = True
    width = 1
    for d in range(D):
        for k in range(N):
            width = max(width, int(np.sum(nonzero[d, k])))
    cols = np.zeros((D, N, width + 1), np.int64)  # the count first
    for d in range(D):
        for k in range(N):
            c = 0
            for j in range(m):
                if nonzero[d, k, j]:
                    c += 1
                    cols[d, k, c] = j
            cols[d, k, 0] = c
    return nonzero, cols


def pin_block(p) -> FloatArray:
    """The problem's seven per-pin arrays (``PIN_BLOCK``: bl, arm, nx, ny, alpha, gamma,
    dmax, each (A, D, P)) as one C-contiguous (7, A, D, P) array, the compiled iteration's
    argument: ``p.pins``, the block they are views of
    (:func:`cyclomesh.stage.equilibrium._problem` forms them so), else a stacked copy. One
    array where there were seven: a compiled call pays two atomic reference counts per
    array argument, and the evaluation is called once or more per Newton step."""
    block = p.pins
    if block is not None and block.flags.c_contiguous:
        start = block.__array_interface__["data"][0]
        if all(
            v.base is block
            and v.shape == block.shape[1:]
            and v.strides == block.strides[1:]
            and v.__array_interface__["data"][0] == start + q * block.strides[0]
            for q, v in enumerate(getattr(p, name) for name in PIN_BLOCK)
        ):
            return block
    return np.stack([np.asarray(getattr(p, name), dtype=float) for name in PIN_BLOCK])


def _structure(nonzero, discs: int, N: int, nw: int, m: int):
    """The unknowns of :func:`_solve_blocks`: ``core`` (c, the discs' θ and u, the end
    plate's β) and ``blocks`` (N, 2D), crankshaft k's pin deflections (x, y at every disc),
    when each crank bearing's columns (``nonzero`` (D, N, m)) are the core's and its own
    pin's only; else no blocks (every unknown in the core: one pivoted elimination)."""
    base = 1 + 3 * discs
    blocks = np.zeros((N, 2 * discs), np.int64)
    for k in range(N):
        for d in range(discs):
            blocks[k, 2 * d] = base + 2 * (d * N + k)
            blocks[k, 2 * d + 1] = base + 2 * (d * N + k) + 1
    wide = np.zeros(m, bool)
    wide[base : base + nw] = True
    core = np.flatnonzero(~wide)
    if nw == 0 or any(
        set(np.flatnonzero(nonzero[d, k] & wide)) - set(blocks[k, 2 * d : 2 * d + 2])
        for d in range(discs)
        for k in range(N)
    ):
        return np.arange(m), np.zeros((0, 2 * discs), np.int64)
    return core, blocks


@cache
def _kernels_newton() -> Any:
    jit = njit()
    global _evaluate_one, _pin_force, _solve_in_place, _solve_blocks, _rollers, _pin_law
    global _hole_offset, _last_state, _rollers_curved, _curvature, _solve_lu, _lu_again
    _pin_force = jit(_pin_force)
    _pin_law = njit(inline=True)(_pin_law)
    _rollers_curved = njit(inline=True)(_rollers_curved)
    _rollers = jit(_rollers)
    _solve_in_place = jit(_solve_in_place)
    _solve_blocks = jit(_solve_blocks)
    _solve_lu = jit(_solve_lu)
    _lu_again = jit(_lu_again)
    _evaluate_one = jit(_evaluate_one)
    _hole_offset = jit(_hole_offset)
    _curvature = jit(_curvature)
    _last_state = jit(_last_state)
    return jit(_newton_rows)


def _pin_force(delta, a, g, checked, d0, y0, f0):  # pragma: no cover (compiled)
    """F of δ = F(α − γ ln F) as :func:`_pin_rows` (γ = 0: δ/α): Halley's iteration in
    y = ln F to a residual of 2e-15·δ (or a last step of :data:`TINY_STEP`), started, when
    this pin's last inversion (δ0, y0, F0) was at an approach within a factor of 2, from
    that solution moved along the inverse's Taylor series to third order (the previous
    step or trial is near: one exponential and one step, where the tangent alone needs
    three), else as the reference (two fixed-point steps from ln(δ/α)). Returns (F, ln
    F), F = −1 if it cannot; the caller keeps (δ, ln F, F) as the pin's last inversion
    where γ ≠ 0 and F > 0 (scalars in and out: an array argument costs a compiled call
    two atomic reference counts). ``checked``: δ lies below the stiffest point (δ <
    dmax), so its test is left out."""
    if g == 0.0:
        return delta / a, 0.0
    if not checked and np.log(delta / g) - a / g >= -1.0:
        return -1.0, 0.0
    if d0 > 0.0 and 0.5 * d0 <= delta <= 2.0 * d0:
        # y(δ) to third order about the last root: δ(y) = e^y (α − γy), δ' = e^y s,
        # δ'' = e^y (s − γ), δ''' = e^y (s − 2γ) with s = α − γ − γy: the inverse series
        # y ≈ y0 + h − c2·h² + (2c2² − c3)·h³, h = Δδ/δ', c2 = δ''/(2δ'), c3 = δ'''/(6δ')
        r = 1.0 / (a - g - g * y0)
        h = (delta - d0) * r / f0
        c2 = 0.5 - 0.5 * g * r
        c3 = (1.0 - 2.0 * g * r) * (1.0 / 6.0)
        y = y0 + h * (1.0 - h * (c2 - h * (2.0 * c2 * c2 - c3)))
    else:
        y = np.log(delta / a)
        y = np.log(delta / (a - g * y))
        y = np.log(delta / (a - g * y))
    for _ in range(MAX_NEWTON):
        e = np.exp(y)
        slope = a - g - g * y
        resid = e * (a - g * y) - delta
        if abs(resid) <= ROUND_OFF * delta:
            return e, y
        # Halley's step −(r/r')/(1 − r·r''/(2r'²)), r' = e^y·s, r'' = e^y·(s − γ)
        step = -resid * slope / (e * slope * slope - 0.5 * resid * (slope - g))
        if abs(step) <= TINY_STEP and abs(g) <= 10.0 * abs(slope):
            # the root: e^(y + h) to round-off without exp (TINY_STEP)
            return e * (1.0 + step * (1.0 + step * (0.5 + step * (1.0 / 6.0)))), y + step
        y = y + step
    e = np.exp(y)
    resid = e * (a - g * y) - delta
    if abs(resid) <= 4.0 * 2.220446049250313e-16 * abs(y) * abs(e * (a - g - g * y)):
        return e, y
    return -1.0, 0.0


def _solve_in_place(H, g, step):  # pragma: no cover (compiled)
    """step = −H⁻¹g by Gaussian elimination with partial pivoting (LAPACK's dgesv without
    its blocking; H is overwritten); False if a pivot is 0."""
    m = g.size
    for r in range(m):
        step[r] = -g[r]
    for k in range(m):
        piv = k
        big = abs(H[k, k])
        for r in range(k + 1, m):
            if abs(H[r, k]) > big:
                big = abs(H[r, k])
                piv = r
        if big == 0.0:
            return False
        if piv != k:
            for c in range(m):
                H[k, c], H[piv, c] = H[piv, c], H[k, c]
            step[k], step[piv] = step[piv], step[k]
        inv = 1.0 / H[k, k]
        for r in range(k + 1, m):
            f = H[r, k] * inv
            if f != 0.0:
                for c in range(k + 1, m):
                    H[r, c] -= f * H[k, c]
                step[r] -= f * step[k]
    for k in range(m - 1, -1, -1):
        acc = step[k]
        for c in range(k + 1, m):
            acc -= H[k, c] * step[c]
        step[k] = acc / H[k, k]
    return True


def _solve_lu(H, g, step, perm):  # pragma: no cover (compiled)
    """:func:`_solve_in_place` (the same operations in the same order) that also keeps
    its factors: the multipliers in H's lower triangle and the pivot rows in ``perm``
    (m,), for :func:`_lu_again` (LAPACK's dgetrf layout)."""
    m = g.size
    for r in range(m):
        step[r] = -g[r]
    for k in range(m):
        piv = k
        big = abs(H[k, k])
        for r in range(k + 1, m):
            if abs(H[r, k]) > big:
                big = abs(H[r, k])
                piv = r
        if big == 0.0:
            return False
        perm[k] = piv
        if piv != k:
            for c in range(m):
                H[k, c], H[piv, c] = H[piv, c], H[k, c]
            step[k], step[piv] = step[piv], step[k]
        inv = 1.0 / H[k, k]
        for r in range(k + 1, m):
            f = H[r, k] * inv
            H[r, k] = f
            if f != 0.0:
                for c in range(k + 1, m):
                    H[r, c] -= f * H[k, c]
                step[r] -= f * step[k]
    for k in range(m - 1, -1, -1):
        acc = step[k]
        for c in range(k + 1, m):
            acc -= H[k, c] * step[c]
        step[k] = acc / H[k, k]
    return True


def _lu_again(H, perm, b, out):  # pragma: no cover (compiled)
    """out = −A⁻¹b from :func:`_solve_lu`'s factors of A (H, ``perm``): bit for bit
    :func:`_solve_in_place` on a copy of A (the same pivots, multipliers and operations
    on the right-hand side in the same order), without its elimination."""
    m = b.size
    for r in range(m):
        out[r] = -b[r]
    for k in range(m):
        piv = perm[k]
        if piv != k:
            out[k], out[piv] = out[piv], out[k]
        for r in range(k + 1, m):
            f = H[r, k]
            if f != 0.0:
                out[r] -= f * out[k]
    for k in range(m - 1, -1, -1):
        acc = out[k]
        for c in range(k + 1, m):
            acc -= H[k, c] * out[c]
        out[k] = acc / H[k, k]


def _solve_blocks(H, g, step, core, blocks, S, Z, rhs, sc):  # pragma: no cover (compiled)
    """step = −H⁻¹g with the crank pins' deflections (the unknowns of ``blocks``, (N, 2D):
    crankshaft k's pins at every disc, x and y) eliminated first: H restricted to one
    crankshaft's deflections is its beam stiffness plus its crank bearings' (positive
    definite, coupled to the others' deflections only through the unknowns of ``core``:
    c, the discs' θ, u and the end plate's β), so block elimination leaves the Schur
    complement S (nc, nc) of the core, solved by :func:`_solve_in_place` (pivoted: a
    floating disc's direction is there), and each crankshaft's deflections from it.
    ``Z`` (2D, nc + 1), ``rhs``, ``sc`` (nc,): work arrays. H is overwritten; False if a
    pivot is 0."""
    nc = core.size
    nb = blocks.shape[1]
    for a in range(nc):
        ra = core[a]
        for b in range(nc):
            S[a, b] = H[ra, core[b]]
        rhs[a] = g[ra]
    for k in range(blocks.shape[0]):
        # Z = B⁻¹ [H_wc | g_w] by Gaussian elimination on the block B = H_ww (in place
        # in H's rows of the block: its columns are not needed after)
        for q in range(nb):
            rq = blocks[k, q]
            for a in range(nc):
                Z[q, a] = H[rq, core[a]]
            Z[q, nc] = g[rq]
        for q in range(nb):
            rq = blocks[k, q]
            piv = H[rq, blocks[k, q]]
            if piv == 0.0:
                return False
            inv = 1.0 / piv
            for q2 in range(q + 1, nb):
                r2 = blocks[k, q2]
                f = H[r2, blocks[k, q]] * inv
                if f != 0.0:
                    for q3 in range(q + 1, nb):
                        H[r2, blocks[k, q3]] -= f * H[rq, blocks[k, q3]]
                    for a in range(nc + 1):
                        Z[q2, a] -= f * Z[q, a]
        for q in range(nb - 1, -1, -1):
            rq = blocks[k, q]
            for q3 in range(q + 1, nb):
                h = H[rq, blocks[k, q3]]
                for a in range(nc + 1):
                    Z[q, a] -= h * Z[q3, a]
            inv = 1.0 / H[rq, rq]
            for a in range(nc + 1):
                Z[q, a] *= inv
        # S −= H_cw Z, rhs −= H_cw z; Z kept in H's block rows for the back substitution
        for a in range(nc):
            ra = core[a]
            for q in range(nb):
                h = H[ra, blocks[k, q]]
                if h != 0.0:
                    for b in range(nc):
                        S[a, b] -= h * Z[q, b]
                    rhs[a] -= h * Z[q, nc]
        for q in range(nb):
            rq = blocks[k, q]
            for a in range(nc):
                H[rq, core[a]] = Z[q, a]
            step[rq] = -Z[q, nc]
    if not _solve_in_place(S, rhs, sc):
        return False
    for a in range(nc):
        step[core[a]] = sc[a]
    for k in range(blocks.shape[0]):
        for q in range(nb):
            rq = blocks[k, q]
            acc = step[rq]
            for a in range(nc):
                acc -= H[rq, core[a]] * sc[a]
            step[rq] = acc
    return True


def _pin_law(delta, pin, i, d, j, memo):  # pragma: no cover (compiled)
    """One closing pin's law at its approach δ > 0 [m] (crank angle ``i``, disc ``d``, pin
    ``j`` of the block ``pin`` (7, A, D, P): α, γ in rows 4 and 5, the reach dmax in row
    6): (code, F [N], ln F, α, γ) with code 1 where δ is at or past dmax (F not formed), 2
    where the law cannot be inverted (F < 0), else 0; F by :func:`_pin_force` from the
    pin's last inversion in ``memo`` (3, D, P), which it updates, and ln F where F > 0
    (γ = 0: formed here). The one place the compiled evaluations (:func:`_evaluate_one`,
    :func:`_rigid_one`, :mod:`cyclomesh.stage.kernel_compliant`) take a pin's law."""
    if delta >= pin[6, i, d, j]:
        return 1, 0.0, 0.0, 0.0, 0.0
    a, gm = pin[4, i, d, j], pin[5, i, d, j]
    f, logf = _pin_force(
        delta, a, gm, np.isfinite(pin[6, i, d, j]), memo[0, d, j], memo[1, d, j], memo[2, d, j]
    )
    if f > 0.0 and gm != 0.0:
        memo[0, d, j], memo[1, d, j], memo[2, d, j] = delta, logf, f
    if f < 0.0:
        return 2, f, logf, a, gm
    if f > 0.0 and gm == 0.0:
        logf = np.log(f)
    return 0, f, logf, a, gm


def _rollers(s, const, R, half, kn):  # pragma: no cover (compiled)
    """One crank bearing's rollers at the deflection s [m] of its hole against its crank pin
    (the roller law of :mod:`cyclomesh.stage.bearing`, Q = kn·δ^p with p = 10/9 on each of
    the R rollers, δ_j = s·cos ψ_j − e/2, ``const[:R]`` the cosines, ``half`` = e/2):
    the bearing's load B = Σ Q_j·cos ψ_j [N], its stiffness dB/ds = Σ p·kn·δ_j^(1/9)·cos²ψ_j
    [N/m] and Σ kn·δ_j^(p+1) (the energy times p + 1 [J]). Shared by the rigid discs'
    compiled evaluation (:func:`_evaluate_one`) and the compliant disc's
    (:mod:`cyclomesh.stage.kernel_compliant`), the same operations in the same order."""
    B, kb, ub, _ = _rollers_curved(s, const, R, half, kn)  # (d²B/ds² unused: dropped)
    return B, kb, ub


def _rollers_curved(s, const, R, half, kn):  # pragma: no cover (compiled)
    """:func:`_rollers`' B, dB/ds and Σ kn·δ_j^(p+1), and d²B/ds² = Σ p·(p − 1)·kn·
    δ_j^(p−2)·cos³ψ_j [N/m²] (the bearing phase's third derivative, :func:`_curvature`);
    :func:`_rollers` is this without the last."""
    p = 10.0 / 9.0
    B = 0.0
    kb = 0.0
    ub = 0.0
    b2 = 0.0
    for j in range(R):
        cj = const[j]
        dj = s * cj - half
        if dj > 0.0:
            root = dj ** (1.0 / 9.0)
            q = dj * root
            B += kn * q * cj
            kb += p * kn * root * cj * cj
            ub += kn * (dj * q)
            b2 += (p - 1.0) * p * kn * root / dj * cj * cj * cj
    return B, kb, ub, b2


def _curvature(
    i, xi, step, pin, hole, G, cols, const, nw, carrier, L, pf, bf, kp, out
):  # pragma: no cover (compiled)
    """T[step, step] into ``out`` (m,): the potential's third derivative twice along
    ``step`` (scaled, as g and H) at the evaluation at ``xi`` (its state ``pf[i]``,
    ``kp``, ``bf[i]``): the pins' stiffening dk/dδ = γ·k³/F (Eq. 20), κ·(v·step)²·v on
    each loaded pin's v = (l/L, nx, ny), and the crank bearings' d²F[Δ, Δ] along Δ =
    G·step of their force F = φ(s)·d, φ = B/s: (φ''·a² + φ'·(|Δ|² − a²)/s)·d + 2φ'·a·Δ
    with a = ĉ·Δ, φ' = (dB/ds − φ)/s, φ'' = (d²B/ds² − 2φ')/s, carried back by Gᵀ (the
    crankshafts and the end plate are linear). Returns max |T|/2, Newton's residual after
    ``step`` to leading order."""
    m = xi.size
    D, P = pin.shape[2], pin.shape[3]
    N = hole.shape[3]
    R = const.size - D - D * D
    for r in range(m):
        out[r] = 0.0
    for d in range(D):
        r0 = 1 + 3 * d
        s0, s1, s2 = step[r0], step[r0 + 1], step[r0 + 2]
        for j in range(P):
            kappa = kp[1, d, j]
            if pf[i, d, j] > 0.0 and kappa != 0.0:
                v0, v1, v2 = pin[1, i, d, j] / L, pin[2, i, d, j], pin[3, i, d, j]
                w = v0 * s0 + v1 * s1 + v2 * s2
                c = kappa * w * w
                out[r0] += c * v0
                out[r0 + 1] += c * v1
                out[r0 + 2] += c * v2
        for k in range(N):
            s = bf[i, d, k, 2]
            B = bf[i, d, k, 3]
            if not (s > 0.0 and B > 0.0):
                continue
            dx, dy = _hole_offset(i, xi, d, k, hole, const, R, nw, carrier)
            ex, ey = 0.0, 0.0
            for u in range(1, cols[d, k, 0] + 1):
                r = cols[d, k, u]
                ex += G[i, d, k, 0, r] * step[r]
                ey += G[i, d, k, 1, r] * step[r]
            phi = B / s
            phi1 = (bf[i, d, k, 4] - phi) / s
            phi2 = (bf[i, d, k, 5] - 2.0 * phi1) / s
            a = (dx * ex + dy * ey) / s
            c = phi2 * a * a + phi1 * (ex * ex + ey * ey - a * a) / s
            fx = c * dx + 2.0 * phi1 * a * ex
            fy = c * dy + 2.0 * phi1 * a * ey
            for u in range(1, cols[d, k, 0] + 1):
                r = cols[d, k, u]
                out[r] += G[i, d, k, 0, r] * fx + G[i, d, k, 1, r] * fy
    big = 0.0
    for r in range(m):
        big = max(big, abs(out[r]))
    return 0.5 * big


def _evaluate_one(
    i, x, pin, hole, G, cols, const, nw, kcarrier, carrier, half, kn, torque, L, want, g, H, memo,
    pf, bf, kp,
):  # fmt: skip  # pragma: no cover (compiled)
    """Potential of crank angle ``i`` at x (m,), with ``want`` its gradient g and Hessian
    H (scaled: rotations × L) as equilibrium._evaluate, and then the state: the pins'
    forces ``pf[i]`` (D, P) and stiffnesses dF/dδ ``kp`` (D, P, where F > 0) and the
    bearings' force on the crank pins, deflection, load and stiffness ``bf[i]`` (D, N, 5:
    fx, fy, s, B, dB/ds); returns (energy, status): status 0 usable, 1 an approach at or
    past dmax (bad), 2 a pin law that cannot be inverted."""
    m = x.size
    D, P = pin.shape[2], pin.shape[3]
    N = hole.shape[3]
    R = const.size - D - D * D  # the rollers' cosines, then frac (D), kshaft (D, D)
    if want:
        for r in range(m):
            g[r] = 0.0
            for s in range(m):
                H[r, s] = 0.0
        for d in range(D):
            for j in range(P):
                pf[i, d, j] = 0.0
    status = 0
    pins = 0.0
    for d in range(D):
        th, ux, uy = x[1 + 3 * d], x[2 + 3 * d], x[3 + 3 * d]
        # the disc's pin sums in registers (g and H are zero here: the same sums)
        g0 = g1 = g2 = 0.0
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        for j in range(P):
            b = pin[0, i, d, j]
            if not np.isfinite(b):
                continue
            delta = pin[1, i, d, j] * (th - b) + pin[2, i, d, j] * ux + pin[3, i, d, j] * uy
            if delta <= 0.0:
                continue
            # _pin_law written out: an array passed to even an inlined function costs
            # two atomic reference counts (two arrays a pin: perf, NRT_incref/decref
            # 15 → 8 % of the compiled iteration's samples with the rollers' below)
            reach = pin[6, i, d, j]
            if delta >= reach:
                status = 1
                continue
            a, gm = pin[4, i, d, j], pin[5, i, d, j]
            f, logf = _pin_force(
                delta, a, gm, np.isfinite(reach), memo[0, d, j], memo[1, d, j], memo[2, d, j]
            )
            if f > 0.0 and gm != 0.0:
                memo[0, d, j], memo[1, d, j], memo[2, d, j] = delta, logf, f
            if f < 0.0:
                return 0.0, 2
            if f > 0.0:
                if gm == 0.0:
                    logf = np.log(f)
                pins += 0.5 * f * f * (a - 0.5 * gm - gm * logf)
                if want:
                    pf[i, d, j] = f
                    k = 1.0 / (a - gm * (1.0 + logf))
                    kp[0, d, j] = k
                    kp[1, d, j] = gm * k * k * k / f  # dk/dδ (Eq. 20)
                    v0, v1, v2 = pin[1, i, d, j] / L, pin[2, i, d, j], pin[3, i, d, j]
                    g0 += f * v0
                    g1 += f * v1
                    g2 += f * v2
                    h00 += k * v0 * v0
                    h01 += k * v0 * v1
                    h02 += k * v0 * v2
                    h11 += k * v1 * v1
                    h12 += k * v1 * v2
                    h22 += k * v2 * v2
        if want:
            r0 = 1 + 3 * d
            g[r0], g[r0 + 1], g[r0 + 2] = g0, g1, g2
            H[r0, r0], H[r0, r0 + 1], H[r0, r0 + 2] = h00, h01, h02
            H[r0 + 1, r0], H[r0 + 1, r0 + 1], H[r0 + 1, r0 + 2] = h01, h11, h12
            H[r0 + 2, r0], H[r0 + 2, r0 + 1], H[r0 + 2, r0 + 2] = h02, h12, h22
    if want:
        g[0] -= torque / L
    energy = pins - torque * x[0]
    base = 1 + 3 * D
    beta = x[base + nw] if carrier else 0.0
    p = 10.0 / 9.0
    bearings = 0.0
    for d in range(D):
        rot = (x[1 + 3 * d] - x[0]) - const[R + d] * beta
        for k in range(N):
            wx = x[base + 2 * (d * N + k)] if nw else 0.0
            wy = x[base + 2 * (d * N + k) + 1] if nw else 0.0
            dx = x[2 + 3 * d] + rot * (-hole[1, i, d, k]) + hole[2, i, d, k] - wx
            dy = x[3 + 3 * d] + rot * hole[0, i, d, k] + hole[3, i, d, k] - wy
            s = np.hypot(dx, dy)
            # _rollers_curved written out (no array passed: see the pins)
            B = kb = ub = b2 = 0.0
            for q in range(R):
                cq = const[q]
                dq = s * cq - half
                if dq > 0.0:
                    root = dq ** (1.0 / 9.0)
                    qq = dq * root
                    B += kn * qq * cq
                    kb += p * kn * root * cq * cq
                    ub += kn * (dq * qq)
                    b2 += (p - 1.0) * p * kn * root / dq * cq * cq * cq
            bearings += ub / (p + 1.0)
            if not want:
                continue
            if s > 0.0:
                cx, cy, secant = dx / s, dy / s, B / s
            else:
                cx, cy, secant = 1.0, 0.0, kb
            fx, fy = B * cx, B * cy
            bf[i, d, k, 0], bf[i, d, k, 1], bf[i, d, k, 2] = fx, fy, s
            bf[i, d, k, 3], bf[i, d, k, 4], bf[i, d, k, 5] = B, kb, b2
            kxx = kb * cx * cx + secant * cy * cy
            kyy = kb * cy * cy + secant * cx * cx
            kxy = (kb - secant) * cx * cy
            for u in range(1, cols[d, k, 0] + 1):
                r = cols[d, k, u]
                g0, g1 = G[i, d, k, 0, r], G[i, d, k, 1, r]
                g[r] += fx * g0 + fy * g1
                ka = kxx * g0 + kxy * g1
                kc = kxy * g0 + kyy * g1
                for v in range(1, cols[d, k, 0] + 1):
                    c2 = cols[d, k, v]
                    H[r, c2] += ka * G[i, d, k, 0, c2] + kc * G[i, d, k, 1, c2]
    energy = energy + bearings
    if nw:
        shafts = 0.0
        for d in range(D):
            for k in range(N):
                for c in range(2):
                    kw = 0.0
                    for e in range(D):
                        kw += const[R + D + d * D + e] * x[base + 2 * (e * N + k) + c]
                    shafts += x[base + 2 * (d * N + k) + c] * kw
                    if want:
                        r = base + 2 * (d * N + k) + c
                        g[r] += kw
                        for e in range(D):
                            H[r, base + 2 * (e * N + k) + c] += const[R + D + d * D + e]
        energy = energy + 0.5 * shafts
    if carrier:
        energy = energy + 0.5 * kcarrier * beta * beta
        if want:
            g[base + nw] += kcarrier * beta / L
            H[base + nw, base + nw] += kcarrier / (L * L)
    return energy, status


def _hole_offset(i, x, d, k, hole, const, R, nw, carrier):  # pragma: no cover (compiled)
    """(dx, dy) [m]: the offset of disc ``d``'s crank hole ``k`` from its crank pin at x,
    as :func:`_evaluate_one` forms it."""
    D, N = hole.shape[2], hole.shape[3]
    base = 1 + 3 * D
    beta = x[base + nw] if carrier else 0.0
    rot = (x[1 + 3 * d] - x[0]) - const[R + d] * beta
    wx = x[base + 2 * (d * N + k)] if nw else 0.0
    wy = x[base + 2 * (d * N + k) + 1] if nw else 0.0
    dx = x[2 + 3 * d] + rot * (-hole[1, i, d, k]) + hole[2, i, d, k] - wx
    dy = x[3 + 3 * d] + rot * hole[0, i, d, k] + hole[3, i, d, k] - wy
    return dx, dy


def _last_state(
    i, xi, trial, pin, hole, const, nw, carrier, half, pf, bf, kp
):  # pragma: no cover (compiled)
    """The bearing phase's last step (:data:`LAST_PREDICTED`): where every pin of crank
    angle ``i`` is in the same state of its law at ``trial`` as at ``xi`` (open or
    closing below its reach dmax) and every roller of every crank bearing too (loaded or
    not; the hole off its crank pin), the state of the evaluation at ``xi`` (``pf[i]``,
    ``kp``, ``bf[i]``) moved to ``trial`` to first order (the pins' forces by dF = k·dδ,
    the bearings' loads by dB = (dB/ds)·ds along the deflection at ``trial``) and True;
    else False and nothing changed."""
    D, P = pin.shape[2], pin.shape[3]
    N = hole.shape[3]
    R = const.size - D - D * D
    for d in range(D):
        r0 = 1 + 3 * d
        for j in range(P):
            b = pin[0, i, d, j]
            if not np.isfinite(b):
                continue
            l, nx, ny = pin[1, i, d, j], pin[2, i, d, j], pin[3, i, d, j]
            d0 = l * (xi[r0] - b) + nx * xi[r0 + 1] + ny * xi[r0 + 2]
            d1 = l * (trial[r0] - b) + nx * trial[r0 + 1] + ny * trial[r0 + 2]
            if (d0 > 0.0) != (d1 > 0.0):
                return False
            if d1 > 0.0:
                reach = pin[6, i, d, j]
                if not d1 < reach or (not np.isfinite(reach) and pin[5, i, d, j] != 0.0):
                    return False
        for k in range(N):
            dx, dy = _hole_offset(i, trial, d, k, hole, const, R, nw, carrier)
            s0, s1 = bf[i, d, k, 2], np.hypot(dx, dy)
            if not (s0 > 0.0 and s1 > 0.0):
                return False
            for j in range(R):
                if (s0 * const[j] - half > 0.0) != (s1 * const[j] - half > 0.0):
                    return False
    for d in range(D):
        r0 = 1 + 3 * d
        for j in range(P):
            f = pf[i, d, j]
            if f > 0.0:
                l, nx, ny = pin[1, i, d, j], pin[2, i, d, j], pin[3, i, d, j]
                dd = (
                    l * (trial[r0] - xi[r0])
                    + nx * (trial[r0 + 1] - xi[r0 + 1])
                    + ny * (trial[r0 + 2] - xi[r0 + 2])
                )
                pf[i, d, j] = f + kp[0, d, j] * dd
        for k in range(N):
            dx, dy = _hole_offset(i, trial, d, k, hole, const, R, nw, carrier)
            s1 = np.hypot(dx, dy)
            B = bf[i, d, k, 3] + bf[i, d, k, 4] * (s1 - bf[i, d, k, 2])
            bf[i, d, k, 0], bf[i, d, k, 1], bf[i, d, k, 2] = B * (dx / s1), B * (dy / s1), s1
    return True


def _newton_rows(
    first, started, memo, x, pin, hole, G, cols, core, blocks, const, nw, kcarrier, carrier,
    half, kn, torque, L, tol, floor, iterations, halvings, cap, low, high, run, failed,
    pf, bf, gout,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`newton` written for numba: each crank angle's iteration of
    cyclomesh.stage.newton.newton (rigid=False) to the end, on its own, from crank angle
    ``first`` on; returns the first crank angle whose own start it needs and has not
    (``started``), A when all are done. ``memo`` (3, D, P): each pin's last inversion
    (δ, y, F), kept from call to call."""
    A, m = x.shape
    D = pin.shape[2]
    eps = 2.220446049250313e-16
    p = 10.0 / 9.0
    rot = np.zeros(m, np.bool_)
    rot[0] = True
    for d in range(D):
        rot[1 + 3 * d] = True
    if carrier:
        rot[m - 1] = True
    g = np.zeros(m)
    H = np.zeros((m, m))
    gt = np.zeros(m)
    Ht = np.zeros((m, m))
    Hc = np.zeros((m, m))  # H before a last step's solve (its gradient at the end)
    kp = np.zeros((2, D, pin.shape[3]))  # the pins' k and dk/dδ of the last evaluation
    perm = np.zeros(m, np.int64)  # the pivots of H's factors (_solve_lu)
    third = np.zeros(m)  # T[step, step]
    quad = -1.0  # Newton's constant r₊/r² of the step before, where it was Chebyshev's
    # Chebyshev's step without the crankshafts' blocks only: with them (20 unknowns) its
    # copy, second solve and T cost as much as the evaluations they save (CHEBYSHEV)
    dense = blocks.shape[0] == 0
    trial = np.zeros(m)
    step = np.zeros(m)
    nc = core.size
    S = np.zeros((nc, nc))
    Z = np.zeros((blocks.shape[1], nc + 1))
    rhs = np.zeros(nc)
    sc = np.zeros(nc)
    for i in range(first, A):
        xi = x[i].copy()
        # g, H, energy and status hold the evaluation at xi (a trial's, or the warm
        # start's, with its gradient and Hessian): the next iteration need not repeat it
        have = False
        energy, status = 0.0, 0
        if i % run != 0 and not failed[i - 1]:
            # warm start (the run): from the parabola through the solutions of the three
            # crank angles before, else the line through two, else from the one before,
            # the first of them where no pin is at or past its law's end (the pins' memo
            # kept: their inversions are near)
            line = i % run >= 2 and not failed[i - 2]
            para = line and i % run >= 3 and not failed[i - 3]
            first_try = 0 if para else (1 if line else 2)
            for attempt in range(first_try, 3):  # 0 parabola, 1 line, 2 the one before
                for r in range(m):
                    if attempt == 0:
                        trial[r] = 3.0 * x[i - 1, r] - 3.0 * x[i - 2, r] + x[i - 3, r]
                    elif attempt == 1:
                        trial[r] = 2.0 * x[i - 1, r] - x[i - 2, r]
                    else:
                        trial[r] = x[i - 1, r]
                e1, s1 = _evaluate_one(
                    i,
                    trial,
                    pin,
                    hole,
                    G,
                    cols,
                    const,
                    nw,
                    kcarrier,
                    carrier,
                    half,
                    kn,
                    torque,
                    L,
                    True,
                    g,
                    H,
                    memo,
                    pf,
                    bf,
                    kp,
                )
                if s1 == 0:
                    break
            if s1 == 0:
                for r in range(m):
                    xi[r] = trial[r]
                energy, status, have = e1, s1, True
        else:
            memo[0] = 0.0
        if not have and not started[i]:
            return i  # its own start is needed
        previous = np.inf
        extended = False
        linear = False
        ok_angle = False
        stay = False  # the last step found no digits near the root (the iterate stays)
        for _ in range(iterations):
            if not have:
                energy, status = _evaluate_one(
                    i,
                    xi,
                    pin,
                    hole,
                    G,
                    cols,
                    const,
                    nw,
                    kcarrier,
                    carrier,
                    half,
                    kn,
                    torque,
                    L,
                    True,
                    g,
                    H,
                    memo,
                    pf,
                    bf,
                    kp,
                )
            have = False
            if status == 2:
                break
            done = True
            res = 0.0
            for r in range(m):
                res = max(res, abs(g[r]))
                if done and not (abs(g[r]) <= tol):  # the round-off of the unknowns?
                    noise = 0.0
                    for s in range(m):
                        xs = abs(xi[s]) * L if rot[s] else abs(xi[s])
                        noise += abs(H[r, s]) * xs
                    noise *= 16.0 * eps
                    if not (abs(g[r]) <= max(tol, noise)):
                        done = False
            # near the root (done): on to round-off, as the reference
            near = done
            done = done and (res <= floor or res >= previous or stay)
            stay = False
            ratio = res > low * previous and res < high * previous
            stretch = (not extended) and ratio and linear
            linear = ratio and not extended
            before = previous
            previous = res
            if done:
                ok_angle = True
                for r in range(m):
                    gout[i, r] = g[r]
                break
            # the last step (:data:`LAST_PREDICTED`)? Newton's, unstretched, after an
            # unstretched one, from a residual that fell quadratically
            # (after a Chebyshev step, Newton's constant from its quadratic term)
            predicted = quad * res * res if quad >= 0.0 else res * res * res / before / before
            quad = -1.0
            last = (
                not stretch
                and not extended
                and before < np.inf
                and res <= LAST_FALL * before
                and predicted <= LAST_PREDICTED * floor
            )
            if last:
                for r in range(m):
                    for c in range(m):
                        Hc[r, c] = H[r, c]
            diag = 0.0
            for r in range(m):
                diag = max(diag, abs(H[r, r]))
            diag = max(diag, 1e-300)
            for r in range(m):
                H[r, r] += 1e-14 * diag
            cheb = dense and not last and not stretch
            if blocks.shape[0]:
                solved = _solve_blocks(H, g, step, core, blocks, S, Z, rhs, sc)
            else:  # its factors kept for Chebyshev's second solve
                solved = _solve_lu(H, g, step, perm)
            if not solved:
                break  # singular: the reference's LinAlgError, or its own way out
            if cheb:  # Chebyshev's step (CHEBYSHEV): step − H⁻¹·T[step, step]/2
                newton_res = _curvature(
                    i, xi, step, pin, hole, G, cols, const, nw, carrier, L, pf, bf, kp, third
                )
                for r in range(m):
                    third[r] *= 0.5
                _lu_again(H, perm, third, gt)  # (dense: no blocks) H's factors kept
                big, size = 0.0, 0.0
                for r in range(m):
                    big = max(big, abs(gt[r]))
                    size = max(size, abs(step[r]))
                if solved and big <= CHEBYSHEV * size:
                    for r in range(m):
                        step[r] += gt[r]
                    quad = newton_res / (res * res) if res > 0.0 else -1.0
            slope = 0.0
            for r in range(m):
                slope += g[r] * step[r]
            if not slope < 0.0:
                last = False
                quad = -1.0
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
                quad = -1.0
            elif last:
                # Newton's step to a residual predicted far below the floor, taken
                # without its evaluation where no pin and no roller changes its state on
                # the way: the state moved there to first order, the gradient there the
                # quadratic model's, g + H·step
                for r in range(m):
                    trial[r] = xi[r] + (step[r] / L if rot[r] else step[r])
                if _last_state(i, xi, trial, pin, hole, const, nw, carrier, half, pf, bf, kp):
                    for r in range(m):
                        acc = g[r]
                        for c in range(m):
                            acc += Hc[r, c] * step[c]
                        gout[i, r] = acc
                        xi[r] = trial[r]
                    ok_angle = True
                    break
            extended = stretch
            tiny = -slope <= 1e-13 * max(abs(energy), 1e-300)
            work = torque * xi[0]  # the reference's _magnitude: flat, judged by |g|
            flat = (not tiny) and -slope <= 1e-13 * (abs(energy + work) + abs(work))
            norm = 0.0
            if flat:
                for r in range(m):
                    norm += g[r] * g[r]
                norm = np.sqrt(norm)
            moved = False
            st = 0
            for _h in range(halvings):
                for r in range(m):
                    trial[r] = xi[r] + (step[r] * t / L if rot[r] else step[r] * t)
                e_t, st = _evaluate_one(
                    i,
                    trial,
                    pin,
                    hole,
                    G,
                    cols,
                    const,
                    nw,
                    kcarrier,
                    carrier,
                    half,
                    kn,
                    torque,
                    L,
                    True,
                    gt,
                    Ht,
                    memo,
                    pf,
                    bf,
                    kp,
                )
                if st == 2:
                    break
                ok = e_t <= energy + 1e-4 * t * slope or tiny
                if flat:
                    norm_t = 0.0
                    for r in range(m):
                        norm_t += gt[r] * gt[r]
                    ok = np.sqrt(norm_t) <= (1.0 - 1e-4 * t) * norm
                if st == 0 and ok:
                    for r in range(m):
                        xi[r] = trial[r]
                    g, gt = gt, g  # the trial's gradient and Hessian: the next iteration's
                    H, Ht = Ht, H
                    energy, status, have = e_t, st, True
                    moved = True
                    if t != 1.0:  # a shortened step: no Newton's constant from it
                        quad = -1.0
                    break
                extended = False
                t = 1.0 if t > 1.0 else 0.5 * t
            if not moved:
                if not (near and flat and st != 2):
                    break
                stay = True  # no digits left near the root: x stays, as the reference's
        if ok_angle:
            x[i] = xi
        else:
            failed[i] = True
    return A


def rigid_newton(
    p, x: FloatArray, discs: int, settings: tuple, state: dict | None = None
) -> NDArray[np.bool_]:
    """:func:`cyclomesh.stage.newton.newton` of the rigid stage (``rigid=True``: θ_d = c,
    u = 0, the one unknown c), every crank angle on its own in one compiled pass, the
    reference's step, line search and convergence test. ``x`` (A, 1 + 3D) is overwritten
    by the solution; returns the crank angles the kernel could not finish. ``settings``
    as :func:`newton`'s; ``state`` receives ``pin_force`` [N] and ``pin_stiffness``
    [N/m] (A, D, P) at the solution of the crank angles it finished."""
    force, iterations, halvings, cap = settings[:4]
    round_off, run = settings[6], settings[7]
    failed = np.zeros(x.shape[0], np.bool_)
    pf, pk = np.zeros(p.bl.shape), np.zeros(p.bl.shape)
    _kernels_newton()  # compiles _pin_force
    _kernels_rigid()(
        x,
        pin_block(p),
        float(p.torque),
        float(p.scale),
        force * abs(p.torque) / p.scale,
        round_off * abs(p.torque) / p.scale,
        iterations,
        halvings,
        cap,
        run,
        failed,
        pf,
        pk,
    )
    if state is not None:
        state.update(pin_force=pf, pin_stiffness=pk)
    return failed


@cache
def _kernels_rigid() -> Any:
    jit = njit()
    global _rigid_one, _rigid_same
    _rigid_one = jit(_rigid_one)
    _rigid_same = jit(_rigid_same)
    return jit(_rigid_rows)


def _rigid_one(i, x, pin, torque, L, memo, store, pf, pk, opens):  # pragma: no cover
    """(energy, ∂/∂(cL), ∂²/∂(cL)², ∂³/∂(cL)³, status) of the rigid stage at crank angle
    ``i``; status as :func:`_evaluate_one`. With ``store`` the pins' forces and stiffnesses in
    ``pf[i]``, ``pk[i]`` (D, P). ``opens`` (D,): the largest finite backlash of each
    disc's opposite flanks (pins P/2 … P − 1, arm −l' ≤ 0), −inf without one: at a
    rotation θ ≥ it every one of them has δ = −l'·(θ − φbl) ≤ 0 (open), so they are
    not scanned (the same sums)."""
    D, P = pin.shape[2], pin.shape[3]
    pins = 0.0
    g = 0.0
    h = 0.0
    h3 = 0.0
    status = 0
    if store:
        for d in range(D):
            for j in range(P):
                pf[i, d, j] = 0.0
                pk[i, d, j] = 0.0
    for d in range(D):
        th = x[1 + 3 * d]
        for j in range(P if th < opens[d] else P // 2):
            b = pin[0, i, d, j]
            if not np.isfinite(b):
                continue
            delta = pin[1, i, d, j] * (th - b)
            if delta <= 0.0:
                continue
            reach = pin[6, i, d, j]  # _pin_law written out, as in _evaluate_one
            if delta >= reach:
                status = 1
                continue
            a, gm = pin[4, i, d, j], pin[5, i, d, j]
            f, logf = _pin_force(
                delta, a, gm, np.isfinite(reach), memo[0, d, j], memo[1, d, j], memo[2, d, j]
            )
            if f > 0.0 and gm != 0.0:
                memo[0, d, j], memo[1, d, j], memo[2, d, j] = delta, logf, f
            if f < 0.0:
                return 0.0, 0.0, 0.0, 0.0, 2
            if f > 0.0:
                if gm == 0.0:
                    logf = np.log(f)
                pins += 0.5 * f * f * (a - 0.5 * gm - gm * logf)
                v = pin[1, i, d, j] / L
                k = 1.0 / (a - gm * (1.0 + logf))  # dF/dδ (Eq. 20)
                g += f * v
                h += v * v * k
                if gm != 0.0:  # dk/dδ = γ·k³/F
                    h3 += v * v * v * (gm * k * k * k / f)
                if store:
                    pf[i, d, j] = f
                    pk[i, d, j] = k
    return pins - torque * x[0], g - torque / L, h, h3, status


def _rigid_same(i, xi, trial, pin, opens):  # pragma: no cover (compiled)
    """Whether every pin of crank angle ``i`` is in the same state of its law at the rigid
    stage's ``trial`` as at ``xi`` (open or closing; a closing one below its reach dmax,
    γ = 0 where dmax is not finite), so that the pins' sums are smooth between them."""
    D, P = pin.shape[2], pin.shape[3]
    for d in range(D):
        t0, t1 = xi[1 + 3 * d], trial[1 + 3 * d]
        for j in range(P):
            b = pin[0, i, d, j]
            if not np.isfinite(b):
                continue
            l = pin[1, i, d, j]
            d0 = l * (t0 - b)
            d1 = l * (t1 - b)
            if (d0 > 0.0) != (d1 > 0.0):
                return False
            if d1 > 0.0:
                reach = pin[6, i, d, j]
                if not d1 < reach or (not np.isfinite(reach) and pin[5, i, d, j] != 0.0):
                    return False
    return True


def _rigid_rows(
    x, pin, torque, L, tol, floor, iterations, halvings, cap, run, failed,
    pf, pk,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`rigid_newton` written for numba."""
    A, m = x.shape
    D = pin.shape[2]
    eps = 2.220446049250313e-16
    trial = np.zeros(m)
    memo = np.zeros((3, D, pin.shape[3]))  # each pin's last inversion (δ, y, F)
    opens = np.empty(D)  # the largest finite backlash of each disc's opposite flanks
    half = pin.shape[3] // 2
    for i in range(A):
        for d in range(D):
            top = -np.inf
            for j in range(half, pin.shape[3]):
                b = pin[0, i, d, j]
                if np.isfinite(b) and b > top:
                    top = b
            opens[d] = top
        xi = x[i].copy()
        have = False  # energy, g, h, status (and pf, pk) hold the evaluation at xi
        energy, g, h, h3, status = 0.0, 0.0, 0.0, 0.0, 0
        warm = i % run != 0 and not failed[i - 1]
        if warm:  # warm start, as _newton_rows
            line = i % run >= 2 and not failed[i - 2]
            for r in range(m):
                trial[r] = 2.0 * x[i - 1, r] - x[i - 2, r] if line else x[i - 1, r]
            e1, g1, h1, c1, s1 = _rigid_one(i, trial, pin, torque, L, memo, True, pf, pk, opens)
            if line and s1 != 0:
                for r in range(m):
                    trial[r] = x[i - 1, r]
                e1, g1, h1, c1, s1 = _rigid_one(i, trial, pin, torque, L, memo, True, pf, pk, opens)
            if s1 == 0:
                for r in range(m):
                    xi[r] = trial[r]
                energy, g, h, h3, status, have = e1, g1, h1, c1, s1, True
        else:
            memo[0] = 0.0
        ok_angle = False
        stay = False  # the last step found no digits near the root (the iterate stays)
        previous = np.inf
        for _ in range(iterations):
            if not have:
                energy, g, h, h3, status = _rigid_one(
                    i, xi, pin, torque, L, memo, True, pf, pk, opens
                )
            have = False
            if status == 2:
                break
            xs = abs(xi[0]) * L
            for d in range(D):
                xs += abs(xi[1 + 3 * d]) * L
            near = abs(g) <= max(tol, 16.0 * eps * abs(h) * xs)
            if near and (abs(g) <= floor or abs(g) >= previous or stay):
                ok_angle = True  # near the root, then on to round-off, as the reference
                break
            stay = False
            before = previous
            previous = abs(g)
            diag = max(abs(h), 1e-300)
            h = h + 1e-14 * diag
            step = -g / h
            q = 0.5 * g * h3 / (h * h)  # Halley's correction (HALLEY)
            if abs(q) <= HALLEY:
                step = step / (1.0 - q)
            slope = g * step
            if not slope < 0.0:
                step = -g / diag
                slope = g * step
            t = 1.0
            reach = abs(step)
            if reach * t > cap:
                t = cap / (reach if reach > 0 else 1.0)
            elif (
                warm  # (a cold crank angle's state is a start the caller may ask for alone)
                and slope < 0.0
                and before < np.inf
                and abs(g) <= LAST_FALL * before
                and abs(g) ** 3 <= LAST_PREDICTED * floor * before * before
            ):
                # the last step (:data:`LAST_PREDICTED`): Newton's, to a residual predicted
                # far below the floor, taken without its evaluation where no pin opens,
                # closes or passes its reach on the way; the pins' forces and stiffnesses
                # moved to first order (the state is a start's: the bearing phase's)
                move = step / L
                for r in range(m):
                    trial[r] = xi[r]
                trial[0] = xi[0] + move
                for d in range(D):
                    trial[1 + 3 * d] = xi[1 + 3 * d] + move
                if _rigid_same(i, xi, trial, pin, opens):
                    for d in range(D):
                        for j in range(pin.shape[3]):
                            f = pf[i, d, j]
                            if f > 0.0:  # dF = k·dδ, dk = γ·k³/F·dδ (δ = F(α − γ ln F))
                                k = pk[i, d, j]
                                dd = pin[1, i, d, j] * move
                                pf[i, d, j] = f + k * dd
                                pk[i, d, j] = k + pin[5, i, d, j] * k * k * k / f * dd
                    for r in range(m):
                        xi[r] = trial[r]
                    ok_angle = True
                    break
            tiny = -slope <= 1e-13 * max(abs(energy), 1e-300)
            work = torque * xi[0]  # the reference's _magnitude: flat, judged by |g|
            flat = (not tiny) and -slope <= 1e-13 * (abs(energy + work) + abs(work))
            moved = False
            st = 0
            for _h in range(halvings):
                move = step * t / L
                for r in range(m):
                    trial[r] = xi[r]
                trial[0] = xi[0] + move
                for d in range(D):
                    trial[1 + 3 * d] = xi[1 + 3 * d] + move
                e_t, g_t, h_t, c_t, st = _rigid_one(
                    i, trial, pin, torque, L, memo, True, pf, pk, opens
                )
                if st == 2:
                    break
                ok = e_t <= energy + 1e-4 * t * slope or tiny
                if flat:
                    ok = abs(g_t) <= (1.0 - 1e-4 * t) * abs(g)
                if st == 0 and ok:
                    for r in range(m):
                        xi[r] = trial[r]
                    energy, g, h, h3, status, have = e_t, g_t, h_t, c_t, st, True  # the next's
                    moved = True
                    break
                t = 1.0 if t > 1.0 else 0.5 * t
            if not moved:
                if not (near and flat and st != 2):
                    break
                stay = True  # no digits left near the root: x stays, as the reference's
        if ok_angle:
            x[i] = xi
        else:
            failed[i] = True
