"""The compliant disc's coupled load sharing compiled (numba), beside the NumPy reference
(issue 27).

With ``CYCLOMESH_KERNEL=numba`` (:func:`cyclomesh.core.kernel.kernel_name`) the Newton
iteration of :func:`cyclomesh.core.discbody.share_load_coupled` on a set of candidate
pins (its ``_solve_set``) runs case by case (crank angles × rings) in one compiled pass:
the reciprocal coefficients of the candidate pins
(:meth:`cyclomesh.core.discbody.DiscBody.reciprocal_matrix`: each pair's 4×4 window of
the symmetrised, edge-padded table and its Catmull–Rom weights, the own coefficients on
the diagonal, 0 between the discs of a stack), Newton's step on the same equations (the
symmetric system (D⁻¹ + C)_EE·ΔF_E − l_E·Δx = r_w,E, l_Eᵀ·ΔF_E = −r_t on the engaged
pins E, two right-hand sides, solved by Cholesky's factorisation, symmetric positive
definite as it is, or by Gaussian elimination with partial pivoting where a pivot is
not positive), the same backtracking line search on the same scaled residual, and the
reference's end: the tolerances (1e-12 of the torque and of the largest approach), then
on to the root at round-off (four units in the last place, or a step that no longer
reduces the residual), with each force the exact inverse of the contact law as
:func:`cyclomesh.core.hertz.force_from_approach` (two fixed-point steps and Newton's
method in ln F to 2e-15·δ).

Both run to the root, so the kernel need not follow the reference's path: a ring's first
crank angle starts as the reference does (the rigid disc's solution, w = 0, on the pins
below the single-pin bound, and those the start can reach as a later one's), each later
one from the roots before it, extrapolated (Δφc cubically, every pin load cubically on a
smooth run of four loaded angles, else linearly: :func:`_order`; a loaded pin's state is
its load with δ = F(α − γ ln F) and w = l·(Δφc − φbl) − δ, no inversion), on the pins
that start can reach (φbl below Δφc, with margins, plus the reach of the table's most
negative coefficient: the check after the solve then finds nothing to add). Near the
root a Newton step with the engaged pins of the last factorisation reuses its factor (a
chord step), and the last such step from within the tolerances updates the loads
linearly (F + ΔF, exact to (1e-12)²) instead of inverting the law again. The results
agree with the reference's to a few units in the last place (tested to 1e-14 of the
largest load, and to 1e-13 of each field's scale through the solvers,
``tests/core/test_kernel_discbody.py``), not bit for bit: the sums run in pin order and
the logarithms and exponentials are the C library's, not NumPy's SIMD ones.

A case the pass cannot finish (no candidate pin, a force past the stiffest point of the
law, a singular Newton system, no convergence) is given the rigid disc's start and
solved again, and if that fails too the caller takes the reference for the whole set,
which raises its own one-line error (or solves it), so the errors are those of the
NumPy path.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np

from cyclomesh.core.jit import njit

__all__ = ["compiled"]

_MAX_NEWTON = 50
"""Newton steps of one force inversion (as :func:`cyclomesh.core.hertz.force_from_approach`)."""
_ROUND_OFF = 2e-15
"""Relative residual of a converged force inversion (as force_from_approach)."""
_EPS = float(np.finfo(float).eps)
_EXACT = 4.4e-16
"""Relative residual of a force inversion below which :func:`_force` takes no last step
(two units in the last place of δ: F within about two of its own of the root, as
:mod:`cyclomesh.core.kernel`'s)."""
_HALVINGS = 30
"""Step halvings of the line search (as the reference's)."""
_SMALLEST_STEP = 1e-6
"""The line search accepts any step once it is this short (as the reference)."""
_CHORD = 1e-8
"""Scaled residual below which a Newton step with the engaged pins of the last
factorisation reuses its factor (a chord step)."""
_REACH = 0.05
"""Margin of a warm start's candidates: the pins whose backlash is below its Δφc by
this fraction of it more (plus four times its change from the case before) and the
table's most negative response to the loads before, raised by the same fraction."""


@cache
def compiled() -> Any:
    """The compiled passes as a namespace (``cell``: :func:`_cell`, ``candidates``:
    :func:`_candidates`, ``solve_sets``: :func:`_solve_sets`, ``suspects``:
    :func:`_suspects`, ``teeth``: :func:`_teeth`), or None
    without numba (imported on first use)."""
    try:
        jit = njit()
    except ImportError:
        return None
    # compiled in place: the passes call them
    global _cell, _bound_row, _own_row, _own, _exp_step, _force, _evaluate, _residuals
    global _solve2, _cholesky2, _extrapolate, _cholesky_solve, _factor_solve, _give_up
    global _order
    _cell = jit(_cell)
    _bound_row = jit(_bound_row)
    _own = jit(_own)
    _own_row = jit(_own_row)
    _exp_step = jit(_exp_step)
    _force = jit(_force)
    _evaluate = jit(_evaluate)
    _residuals = jit(_residuals)
    _solve2 = jit(_solve2)
    _cholesky2 = jit(_cholesky2)
    _cholesky_solve = jit(_cholesky_solve)
    _factor_solve = jit(_factor_solve)
    _extrapolate = jit(_extrapolate)
    _give_up = jit(_give_up)
    _order = jit(_order)

    class Passes:
        cell = _cell  # (the Catmull–Rom cell, also the stage's coupling's: stage.coupling)
        candidates = jit(_candidates)
        solve_sets = jit(_solve_sets)
        suspects = jit(_suspects)
        teeth = jit(_teeth)

    return Passes


def _candidates(
    bl, arm, alpha, gamma, tooth, angle, diagonal, grid, torque, block, own, candidate
):  # fmt: skip  # pragma: no cover (compiled)
    """The start of :func:`cyclomesh.core.discbody.share_load_coupled` for every case
    (row), written for numba, at each ring's first case (every ``block``-th row; ``block``
    1: every row): each pin's own coefficient C_ii
    (:meth:`~cyclomesh.core.discbody.DiscBody.self_compliance`, ``diagonal`` (p, m) its
    table) into ``own`` (B, n) and the pins below the single-pin bound into
    ``candidate`` (B, n) (:func:`_bound_row`). The other rows are left to
    :func:`_solve_sets` (``own`` NaN, no candidate), which takes the pins its start can
    reach and their own coefficients."""
    n_cases, n = bl.shape
    for k in range(n_cases):
        if k % block == 0:
            _own_row(k, tooth, angle, diagonal, grid, own)
            _bound_row(k, bl, arm, alpha, gamma, own, torque, candidate)
        else:
            for i in range(n):
                candidate[k, i] = False
                own[k, i] = np.nan


def _own_row(k, tooth, angle, diagonal, grid, own):  # pragma: no cover (compiled)
    """The own coefficients C_ii of every pin of case ``k`` into ``own[k]`` [m/N]
    (:meth:`~cyclomesh.core.discbody.DiscBody.self_compliance`)."""
    u0, u_last, h, m = grid[0], grid[1], grid[2], int(grid[3])
    for i in range(own.shape[1]):
        c, w0, w1, w2, w3 = _cell(angle[k, i], u0, u_last, h, m)
        own[k, i] = _own(diagonal, tooth[k, i] % diagonal.shape[0], c, m, w0, w1, w2, w3)


def _own(diagonal, row, c, m, w0, w1, w2, w3):  # pragma: no cover (compiled)
    """C_ii of a contact in Catmull–Rom cell ``c`` (weights w0 … w3) of the diagonal
    table's ``row`` (the tooth mod the period) [m/N]."""
    return (
        diagonal[row, max(c - 1, 0)] * w0
        + diagonal[row, c] * w1
        + diagonal[row, c + 1] * w2
        + diagonal[row, min(c + 2, m - 1)] * w3
    )


def _bound_row(k, bl, arm, alpha, gamma, own, torque, candidate):  # pragma: no cover
    """The pins of case ``k`` below the single-pin bound with the body's own compliance
    into ``candidate[k]`` (as the reference's ``_candidates``, whose logarithms are
    NumPy's: a pin within a unit in the last place of the bound may fall the other way,
    and the check after the solve adds any pin that could touch)."""
    n = bl.shape[1]
    bound = np.inf
    # the pin with the smallest backlash first, then only the pins below the bound so
    # far (a counted pin's rotation alone is above its backlash)
    first = -1
    for i in range(n):
        b = bl[k, i]
        if np.isfinite(b) and arm[k, i] > 0.0 and (first < 0 or b < bl[k, first]):
            first = i
    for jj in range(-1, n):
        i = first if jj < 0 else jj
        if i < 0 or (jj >= 0 and jj == first):
            continue
        b, lk = bl[k, i], arm[k, i]
        if not (np.isfinite(b) and lk > 0.0) or b >= bound:
            continue
        a, g = alpha[k, i], gamma[k, i]
        single = torque / lk
        log_single = math.log(single)
        if not (g == 0.0 or log_single < a / g - 1.0):
            continue
        alone = b + (single * (a - g * log_single) + own[k, i] * single) / lk
        if alone > b and alone < bound:
            bound = alone
    for i in range(n):
        b = bl[k, i]
        candidate[k, i] = np.isfinite(b) and arm[k, i] > 0.0 and b < bound


def _cell(ang, u0, u_last, h, m):  # pragma: no cover (compiled)
    """The Catmull–Rom cell c of profile angle ``ang`` [rad] (NaN: u₀) on the grid
    (u₀, u_last, h, m) and its four weights, as ``DiscBody._cells``: the one formula of
    the own coefficients (:func:`_candidates`) and the reciprocal windows
    (:func:`_solve_sets`)."""
    if np.isnan(ang):
        ang = u0
    s = (min(max(ang, u0), u_last) - u0) / h
    c = min(max(int(np.floor(s)), 0), m - 2)
    t = s - c
    t2, t3 = t * t, t * t * t
    return (
        c,
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    )


def _force(d, a, g, y_last, d_last, f_last):  # pragma: no cover (compiled)
    """F of δ = F(α − γ ln F) as :func:`cyclomesh.core.hertz.force_from_approach`, δ ≥ 0
    [m], to the same residual (2e-15·δ); returns (F [N], ln F, ok), ok False where the
    reference raises (past the stiffest point of the law, or no convergence).

    Newton's method in y = ln F starts from the
    pin's last inversion (``y_last`` at δ = ``d_last``, F = ``f_last``; d_last ≤ 0: none)
    moved along its second-order expansion, y₀ = y + u − ½(δ''/δ')u², u = Δδ/(dδ/dy) (a
    step or two of Newton's method near the root);
    without one, or if that start does not converge in 8 steps, from the reference's
    start (two fixed-point steps from ln(δ/α)), after the reference's test of the
    stiffest point of the law, ln(δ/γ) − α/γ ≥ −1. The root is the reference's to
    round-off. A root from the last inversion is accepted at ln F below α/γ − 1 − 1e-6
    only, where δ is below the stiffest point by 5e-13 of it (δ''/δ = −1 there), well
    clear of the test's round-off: the reference would not raise there either.
    """
    if not d > 0.0:
        return 0.0, 0.0, True
    if g == 0.0:
        return d / a, 0.0, True
    if d_last > 0.0:
        inv = 1.0 / (f_last * (a - g - g * y_last))  # 1/(dδ/dy)
        u = (d - d_last) * inv
        # second order: y = y_last + u − ½·(δ''/δ')·u², δ''/δ' = 1 − γ·F/(dδ/dy)
        dy = u - 0.5 * (1.0 - g * f_last * inv) * u * u
        y = y_last + dy
        peak = a / g - 1.0 - 1e-6 if g > 0.0 else np.inf  # ln F short of the stiffest point
        if y < peak:
            f = _exp_step(f_last, dy, y)
            for _ in range(8):
                resid = f * (a - g * y) - d
                if abs(resid) <= _ROUND_OFF * d:
                    if abs(resid) > _EXACT * d:  # one more step: the root at round-off
                        step = resid / (f * (a - g - g * y))
                        y = y - step
                        f = _exp_step(f, -step, y)
                    if y < peak:
                        return f, y, True
                    break
                step = resid / (f * (a - g - g * y))
                y = y - step
                f = _exp_step(f, -step, y)
                if step * step <= 0.01 * _ROUND_OFF:  # the next residual ≈ step²/2
                    if y < peak:
                        return f, y, True
                    break
    if math.log(d / g) - a / g >= -1.0:  # past the stiffest point: the reference raises
        return 0.0, 0.0, False
    y = math.log(d / a)
    y = math.log(d / (a - g * y))
    y = math.log(d / (a - g * y))
    for _ in range(_MAX_NEWTON):
        f = math.exp(y)
        resid = f * (a - g * y) - d
        if abs(resid) <= _ROUND_OFF * d:
            return f, y, True
        y = y - resid / (f * (a - g - g * y))
    f = math.exp(y)
    resid = f * (a - g * y) - d
    resolution = 4.0 * _EPS * abs(y) * abs(f * (a - g - g * y))
    if abs(resid) <= _ROUND_OFF * d or abs(resid) <= resolution:
        return f, y, True
    return 0.0, 0.0, False


_SMALL_STEP = 1e-3
"""Largest |s| for which e^s is taken as its Taylor polynomial to s⁵ (remainder s⁶/720 ≤
1.4e-21, below the round-off of the product), as :mod:`cyclomesh.core.kernel`'s."""
_SIXTH, _TWENTY_FOURTH, _ONE_20TH = 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0


def _exp_step(f, s, y):  # pragma: no cover (compiled)
    """e^y from f = e^(y − s): f·(1 + s + … + s⁵/120) for |s| ≤ :data:`_SMALL_STEP` (a few
    units in the last place of F), else exp(y); :mod:`cyclomesh.core.kernel`'s update."""
    if abs(s) <= _SMALL_STEP:
        s2 = s * s
        return f * ((1.0 + s) + s2 * ((0.5 + s * _SIXTH) + s2 * (_TWENTY_FOURTH + s * _ONE_20TH)))
    return math.exp(y)


def _evaluate(
    nc, x, w, c_bl, c_arm, c_alpha, c_gamma, cmat, torque, last, delta, f, y, r_w, loaded
):  # fmt: skip  # pragma: no cover (compiled)
    """The residuals of the coupled system at (Δφc, w) on the ``nc`` candidates, as the
    reference's ``evaluate``: fills δ, F, ln F and r_w = w − C·F, each force inverted
    from the state ``last`` (δ, F, ln F of the last accepted step); returns (r_t = Σ l·F
    − T, the scaled residual of the line search, ok) (:func:`_residuals`)."""
    d_last, f_last, y_last = last
    for i in range(nc):
        di = c_arm[i] * (x - c_bl[i]) - w[i]
        delta[i] = di if di > 0.0 else 0.0
        fi, yi, ok = _force(delta[i], c_alpha[i], c_gamma[i], y_last[i], d_last[i], f_last[i])
        if not ok:
            return 0.0, 0.0, False
        f[i] = fi
        y[i] = yi
    r_t, merit = _residuals(nc, w, c_arm, cmat, torque, delta, f, r_w, loaded)
    return r_t, merit, True


def _residuals(nc, w, c_arm, cmat, torque, delta, f, r_w, loaded):  # pragma: no cover
    """r_w = w − C·F (into ``r_w``) and (r_t = Σ l·F − T, the line search's scaled
    residual) at the approaches ``delta`` and forces ``f`` of the ``nc`` candidates;
    C·F summed over the loaded pins only (``loaded``: scratch), in pin order."""
    n_loaded = 0
    for i in range(nc):
        if f[i] != 0.0:
            loaded[n_loaded] = i
            n_loaded += 1
    # C·F into r_w, a loaded pin's row (C = Cᵀ) at a time: each pin's sum in pin order,
    # the pins' sums side by side (independent, not one chain of dependent sums)
    for i in range(nc):
        r_w[i] = 0.0
    for q in range(n_loaded):
        j = loaded[q]
        fj = f[j]
        row = cmat[j]
        for i in range(nc):
            r_w[i] += row[i] * fj
    moment = 0.0
    largest = 0.0
    worst = 0.0
    for i in range(nc):
        r_w[i] = w[i] - r_w[i]
        moment += f[i] * c_arm[i]
        largest = max(largest, delta[i])
        worst = max(worst, abs(r_w[i]))
    r_t = moment - torque
    return r_t, worst / max(largest, 1e-300) + abs(r_t) / torque


def _solve2(ne, system, rhs):  # pragma: no cover (compiled)
    """Solve system[:ne, :ne]·X = rhs[:ne, :2] in place (Gaussian elimination with
    partial pivoting, as LAPACK's getrf/getrs); X in ``rhs``. False if a pivot is 0."""
    for c in range(ne):
        p = c
        big = abs(system[c, c])
        for r in range(c + 1, ne):
            v = abs(system[r, c])
            if v > big:
                big = v
                p = r
        if big == 0.0 or not np.isfinite(big):
            return False
        if p != c:
            for j in range(ne):
                system[c, j], system[p, j] = system[p, j], system[c, j]
            rhs[c, 0], rhs[p, 0] = rhs[p, 0], rhs[c, 0]
            rhs[c, 1], rhs[p, 1] = rhs[p, 1], rhs[c, 1]
        inv = 1.0 / system[c, c]
        for r in range(c + 1, ne):
            m = system[r, c] * inv
            if m != 0.0:
                for j in range(c + 1, ne):
                    system[r, j] -= m * system[c, j]
                rhs[r, 0] -= m * rhs[c, 0]
                rhs[r, 1] -= m * rhs[c, 1]
    for c in range(ne - 1, -1, -1):
        s0, s1 = rhs[c, 0], rhs[c, 1]
        for j in range(c + 1, ne):
            s0 -= system[c, j] * rhs[j, 0]
            s1 -= system[c, j] * rhs[j, 1]
        rhs[c, 0] = s0 / system[c, c]
        rhs[c, 1] = s1 / system[c, c]
    return True


def _cholesky2(ne, system, rhs):  # pragma: no cover (compiled)
    """Solve system[:ne, :ne]·X = rhs[:ne, :2] in place by Cholesky's factorisation
    (system = Uᵀ·U; the upper triangle is read and overwritten by U, its diagonal by
    1/U_jj; the lower one is not read); X in ``rhs``. Row by row, each row's update of
    the rows below it a set of independent products along contiguous rows (no chains of
    dependent sums). False if a pivot is not positive (the system is not positive
    definite: the caller then takes :func:`_solve2`)."""
    one = np.uint64(1)  # unsigned indices: no negative-index test per access
    une = np.uint64(ne)
    for j in range(une):
        d = system[j, j]
        if not (d > 0.0 and np.isfinite(d)):
            return False
        inv = 1.0 / math.sqrt(d)
        system[j, j] = inv
        row = system[j]
        for i in range(j + one, une):
            row[i] *= inv
        for k in range(j + one, une):  # the trailing upper triangle, row k
            uk = row[k]
            below = system[k]
            for i in range(k, une):
                below[i] -= row[i] * uk
    for j in range(une):  # Uᵀ·Z = rhs, row by row of U
        z0 = rhs[j, 0] * system[j, j]
        z1 = rhs[j, 1] * system[j, j]
        rhs[j, 0], rhs[j, 1] = z0, z1
        for i in range(j + one, une):
            rhs[i, 0] -= system[j, i] * z0
            rhs[i, 1] -= system[j, i] * z1
    for back in range(une):  # U·X = Z, from the last row
        i = une - one - back
        s0, s1 = rhs[i, 0], rhs[i, 1]
        for p in range(i + one, une):
            s0 -= system[i, p] * rhs[p, 0]
            s1 -= system[i, p] * rhs[p, 1]
        rhs[i, 0] = s0 * system[i, i]
        rhs[i, 1] = s1 * system[i, i]
    return True


def _factor_solve(ne, eng, cmat, c_alpha, c_gamma, y, r_w, c_arm, system, rhs):  # pragma: no cover
    """The Newton system (D⁻¹ + C)_EE of the ``ne`` engaged pins ``eng`` (dδ/dF = α −
    γ(1 + ln F) on the diagonal) and its right-hand sides r_w and l into ``system`` and
    ``rhs``, solved in place by Cholesky's factorisation (:func:`_cholesky2`: True, the
    factor kept in ``system``); False if it is not positive definite, the whole
    system and right-hand sides then in place again for :func:`_solve2`."""
    une = np.uint64(ne)  # unsigned indices: no negative-index test per access
    for e in range(une):
        a = eng[e]
        for q in range(e):
            system[q, e] = cmat[a, eng[q]]
        system[e, e] = cmat[a, a] + (c_alpha[a] - c_gamma[a] * (1.0 + y[a]))
        rhs[e, 0] = r_w[a]
        rhs[e, 1] = c_arm[a]
    if _cholesky2(ne, system, rhs):
        return True
    for e in range(une):
        a = eng[e]
        for q in range(une):
            system[e, q] = cmat[a, eng[q]]
        system[e, e] += c_alpha[a] - c_gamma[a] * (1.0 + y[a])
        rhs[e, 0] = r_w[a]
        rhs[e, 1] = c_arm[a]
    return False


def _cholesky_solve(ne, system, rhs):  # pragma: no cover (compiled)
    """Solve with the factor :func:`_cholesky2` left in ``system`` for rhs[:ne, 0] alone,
    in place (rhs[:, 1] untouched)."""
    one = np.uint64(1)
    une = np.uint64(ne)
    for j in range(une):
        z = rhs[j, 0] * system[j, j]
        rhs[j, 0] = z
        for i in range(j + one, une):
            rhs[i, 0] -= system[j, i] * z
    for back in range(une):
        i = une - one - back
        s0 = rhs[i, 0]
        for p in range(i + one, une):
            s0 -= system[i, p] * rhs[p, 0]
        rhs[i, 0] = s0 * system[i, i]


def _give_up(
    k, warm, tooth, angle, diagonal, grid, own, bl, arm, alpha, gamma, torque, candidate, status,
    root, suspect
):  # fmt: skip  # pragma: no cover (compiled)
    """Case ``k`` given up by :func:`_solve_sets` (no candidate, or its start or Newton
    failed): status 1, or 2 on a warm start with the case's own coefficients and its
    candidates by the single-pin bound written for the rigid disc's start that the caller
    gives it; its root NaN; flagged for the check after the solve."""
    if warm:
        _own_row(k, tooth, angle, diagonal, grid, own)
        _bound_row(k, bl, arm, alpha, gamma, own, torque, candidate)
    status[k] = 2 if warm else 1
    root[k] = np.nan
    suspect[k] = True


def _order(f1, f2, f3, f4, streak):  # pragma: no cover (compiled)
    """How many of a pin's loads before a case its warm start extrapolates
    (:func:`_extrapolate`'s ``streak``) from the last four, f1 the last [N]: cubically
    (4) where the pin was loaded at all four and the loads' third difference is within
    their second (a smooth run), else linearly (at most 2). The cubic's error grows with
    the third difference, which a pin entering contact (its load is 0, then a power of
    the approach) or a coefficient's Catmull–Rom node (C¹: its second derivative jumps)
    makes large; at 1° steps (a tolerance study's) every fourth pin-case or so.
    Either start goes on to the same root: only the number of Newton steps differs."""
    if streak >= 4 and f4 > 0.0 and f3 > 0.0 and f2 > 0.0:
        if abs(f1 - 3.0 * (f2 - f3) - f4) <= abs(f1 - 2.0 * f2 + f3):
            return 4
    return min(streak, 2)


def _extrapolate(v1, v2, v3, v4, streak):  # pragma: no cover (compiled)
    """The value at the next of evenly spaced crank angles from the ``streak`` (≥ 1)
    values just before it (v1 the last): constant, linear, quadratic or cubic in the
    angle."""
    if streak >= 4:
        return 4.0 * (v1 + v3) - 6.0 * v2 - v4
    if streak >= 3:
        return 3.0 * (v1 - v2) + v3
    if streak >= 2:
        return 2.0 * v1 - v2
    return v1


def _solve_sets(
    candidate, bl, arm, alpha, gamma, tooth, angle, own, x0, f0, padded, diagonal, grid, n2,
    period, per_disc, torque, tol_torque, tol_compat, round_off, max_iterations, lowest, block,
    rotation, force, status, suspect
):  # fmt: skip  # pragma: no cover (compiled)
    """The reference's ``_solve_set`` of every case (row), written for numba: the same
    equations to the same root at round-off, from a start of its own where it can.

    ``candidate`` (B, n) bool, ``bl``, ``arm``, ``alpha``, ``gamma``, ``angle``, ``own``
    (B, n) float, ``tooth`` (B, n) int, ``x0`` (B,) and ``f0`` (B, n) the rigid disc's
    Δφc [rad] and loads [N] (the start; NaN in ``x0``: not given); ``padded``: the
    reciprocal table edge-padded (``DiscBody._padded``, flat; a pair's Catmull–Rom
    window is four rows of four in it);
    ``diagonal`` (p, m) the own coefficients' table and ``grid`` (u₀, u_last, h, m) of
    the profile angles; ``lowest`` [m/N] minus the table's most negative coefficient (0
    if none); ``block``: cases per ring (consecutive crank angles; 1: every case on its
    own).

    A case with ``x0`` starts from the rigid disc's solution with w = 0 on the given
    candidates and the pins that start can reach (added to ``candidate``, as a warm
    start's below with the rigid ΣF and Δφc). A case without it after others of its ring
    starts from their roots, extrapolated (:func:`_extrapolate`, :func:`_order`: Δφc and
    each pin's load; a loaded pin's w from its load, an unloaded one's C·F of the loads;
    after a case given up, the last one solved as it is), on the pins that start can
    reach (written into ``candidate``; their own coefficients into ``own``). Newton's
    steps (a backtracking line search on the scaled residual) run to the tolerances,
    then on to round-off (``round_off``) or to a step that does not reduce the residual,
    with the last Cholesky factor where the engaged pins are the same and the residual
    below :data:`_CHORD`, the last of them from within the tolerances a linear update of
    the loads (F + ΔF). Fills ``rotation`` (B,), ``force`` (B, n) (zero on entry),
    ``suspect`` (B,) bool (:func:`_suspects`' flag of each case solved, from the same
    sum and test while its row is at hand; True where not solved) and ``status`` (B,): 0
    solved, 1 not finished (the caller then takes the reference), 2 needs ``x0`` (its
    candidates and own coefficients then the single-pin bound's, :func:`_candidates`);
    returns the number of cases not solved.
    """
    n_cases, n = bl.shape
    u0, u_last, h, m = grid[0], grid[1], grid[2], int(grid[3])
    side = m + 2  # the padded table's rows
    idx = np.empty(n, np.int64)
    cell = np.empty(n, np.int64)
    wts = np.empty((n, 4))
    base = np.empty(n, np.uint64)  # unsigned: no negative-index test per read (the
    ucell = np.empty(n, np.uint64)  # window's four reads of a row then one vector load)
    one = np.uint64(1)
    by_period = np.empty(n2, np.int64)  # t mod period of each tooth t < n2
    for t in range(n2):
        by_period[t] = t % period
    disc_of = np.empty(n, np.int64)  # the disc of each pin (of a stack)
    for i in range(n):
        disc_of[i] = i // per_disc
    uside = np.uint64(side)
    block_size = np.uint64(side * side)
    km = np.empty(n, np.int64)
    c_disc = np.empty(n, np.int64)  # the disc of each candidate (of a stack)
    cmat = np.zeros((n, n))
    c_bl, c_arm = np.empty(n), np.empty(n)
    c_alpha, c_gamma = np.empty(n), np.empty(n)
    w, delta, f, y, r_w = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    wn, dn, fn, yn, rwn = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    step_f, step_w = np.zeros(n), np.zeros(n)
    eng = np.empty(n, np.uint64)  # unsigned: no negative-index test where they index
    loaded = np.empty(n, np.uint64)
    system = np.empty((n, n))
    root = np.empty(n_cases)  # Δφc of each case solved, to extrapolate
    streak = 0
    rhs = np.empty((n, 2))
    failed = 0
    last = -1  # the last case of the ring solved
    last_total = 0.0  # its Σ F [N]
    for k in range(n_cases):
        if k % block == 0:
            streak = 0
            last = -1
        x = x0[k]
        warm = not np.isfinite(x)
        if warm and last < 0:  # no start: the caller gives the rigid disc's
            if k % block != 0:  # (a ring's first: _candidates took them)
                _own_row(k, tooth, angle, diagonal, grid, own)
                _bound_row(k, bl, arm, alpha, gamma, own, torque, candidate)
            status[k] = 2
            failed += 1
            suspect[k] = True
            continue
        if warm:  # Δφc of the roots before extrapolated; the candidates: the pins it
            # can reach, φbl < Δφc + c·ΣF/l with c the table's most negative coefficient
            # (as the check after the solve), with a margin for the extrapolation
            # (after a case not solved, the last one solved: its values as they are)
            if streak > 0:
                x = _extrapolate(root[k - 1], root[k - 2], root[k - 3], root[k - 4], streak)
            else:
                x = root[last]
            total = last_total  # Σ F of the last case solved, in pin order
            pad = _REACH * abs(x) + 4.0 * abs(x - root[last])
            push = (1.0 + _REACH) * lowest * total
            reach = x + pad
            for i in range(n):
                b, lk = bl[k, i], arm[k, i]  # φbl < reach + push/l, l > 0, no quotient
                candidate[k, i] = np.isfinite(b) and lk > 0.0 and (b - reach) * lk < push
        else:  # the rigid disc's start: the single-pin bound's candidates (_candidates) and
            # the pins the table's most negative coefficient lets the start reach, as a warm
            # start's (the root's Δφc is above the rigid one: the check after the solve
            # then rarely has a case to look at, nor the reference's coefficients to form)
            total = 0.0
            for i in range(n):
                total += f0[k, i]
            push = (1.0 + _REACH) * lowest * total
            reach = x + _REACH * abs(x)
            for i in range(n):
                b, lk = bl[k, i], arm[k, i]
                if not candidate[k, i] and np.isfinite(b) and lk > 0.0:
                    candidate[k, i] = (b - reach) * lk < push
        nc = 0
        for i in range(n):
            if candidate[k, i]:
                idx[nc] = i
                nc += 1
        if nc == 0:
            _give_up(k, warm, tooth, angle, diagonal, grid, own, bl, arm, alpha, gamma, torque,
                     candidate, status, root, suspect)  # fmt: skip
            streak = 0
            failed += 1
            continue
        # the candidates' Catmull–Rom cells and weights (DiscBody._cells)
        for a in range(nc):
            i = idx[a]
            c_bl[a], c_arm[a] = bl[k, i], arm[k, i]
            c_alpha[a], c_gamma[a] = alpha[k, i], gamma[k, i]
            c, wts[a, 0], wts[a, 1], wts[a, 2], wts[a, 3] = _cell(angle[k, i], u0, u_last, h, m)
            cell[a] = c
            t = tooth[k, i]
            if 0 <= t < n2:  # tooth_index's range: the remainders tabulated
                row, km[a] = by_period[t], t
            else:
                row, km[a] = t % period, t % n2
            if warm:  # the own coefficients of the candidates chosen here
                own[k, i] = _own(
                    diagonal, row, c, m, wts[a, 0], wts[a, 1], wts[a, 2], wts[a, 3]
                )  # fmt: skip
            base[a] = np.uint64((row * n2 * side + c) * side)
            ucell[a] = np.uint64(c)
            c_disc[a] = disc_of[i]
        # the reciprocal matrix (DiscBody.reciprocal_matrix): pairs i < j from their
        # windows, the own coefficients on the diagonal, 0 between discs
        for b in range(nc):  # the load
            cmat[b, b] = own[k, idx[b]]
            wb0, wb1, wb2, wb3 = wts[b, 0], wts[b, 1], wts[b, 2], wts[b, 3]
            disc = c_disc[b]
            for a in range(b):  # the response
                if c_disc[a] != disc:
                    cmat[a, b] = 0.0
                    cmat[b, a] = 0.0
                    continue
                offset = km[a] - km[b]
                if offset < 0:
                    offset += n2
                # the pair's window: rows cell_b … cell_b + 3 (the load's nodes) and
                # columns cell_a … cell_a + 3 (the response's) of its block
                s0 = np.uint64(offset) * block_size + base[b] + ucell[a]
                s1 = s0 + uside
                s2 = s1 + uside
                s3 = s2 + uside
                # the load's nodes first, as the reference: the sum over them in order
                h0 = ((padded[s0] * wb0 + padded[s1] * wb1) + padded[s2] * wb2) + padded[s3] * wb3
                s0, s1, s2, s3 = s0 + one, s1 + one, s2 + one, s3 + one
                h1 = ((padded[s0] * wb0 + padded[s1] * wb1) + padded[s2] * wb2) + padded[s3] * wb3
                s0, s1, s2, s3 = s0 + one, s1 + one, s2 + one, s3 + one
                h2 = ((padded[s0] * wb0 + padded[s1] * wb1) + padded[s2] * wb2) + padded[s3] * wb3
                s0, s1, s2, s3 = s0 + one, s1 + one, s2 + one, s3 + one
                h3 = ((padded[s0] * wb0 + padded[s1] * wb1) + padded[s2] * wb2) + padded[s3] * wb3
                pair = ((h0 * wts[a, 0] + h1 * wts[a, 1]) + h2 * wts[a, 2]) + h3 * wts[a, 3]
                cmat[a, b] = pair
                cmat[b, a] = pair
        # the start: the rigid disc's solution and w = 0 (a ring's first case), or the
        # pin loads of the roots before extrapolated and w = C·F of them
        ok = True
        if not warm:  # the forces are the rigid disc's loads (inverted there to
            # round-off; a pin they leave unloaded at δ > 0 is inverted here)
            for a in range(nc):
                da = c_arm[a] * (x - c_bl[a])
                delta[a] = da if da > 0.0 else 0.0
                fa = f0[k, idx[a]]
                if delta[a] > 0.0 and fa > 0.0:
                    f[a], y[a] = fa, math.log(fa)
                else:
                    f[a], y[a], good = _force(delta[a], c_alpha[a], c_gamma[a], 0.0, 0.0, 0.0)
                    ok = ok and good
                w[a] = 0.0
        else:
            for a in range(nc):
                i = idx[a]
                if streak > 0:
                    f1, f2, f3 = force[k - 1, i], force[k - 2, i], force[k - 3, i]
                    f4 = force[k - 4, i]
                    fa = _extrapolate(f1, f2, f3, f4, _order(f1, f2, f3, f4, streak))
                else:
                    fa = force[last, i]
                step_f[a] = fa if fa > 0.0 else 0.0
            # a loaded pin's state is its extrapolated load, δ = F(α − γ ln F) of it and w
            # = l·(Δφc − φbl) − δ (no inversion); an unloaded one's w = C·F of the loads,
            # its load the law's inverse of δ = l·(Δφc − φbl) − w (0 where δ ≤ 0)
            for a in range(nc):
                fa = step_f[a]
                gap = c_arm[a] * (x - c_bl[a])
                if fa > 0.0:
                    ya = math.log(fa)
                    ga = c_gamma[a]
                    if ga > 0.0 and ya >= c_alpha[a] / ga - 1.0:  # past the stiffest point
                        ok = False
                    da = fa * (c_alpha[a] - ga * ya)
                    f[a], y[a], delta[a], w[a] = fa, ya, da, gap - da
                else:
                    wa = 0.0
                    row = cmat[a]  # C = Cᵀ: the row of the response
                    for b in range(nc):
                        wa += row[b] * step_f[b]
                    w[a] = wa
                    da = gap - wa
                    delta[a] = da if da > 0.0 else 0.0
                    f[a], y[a], good = _force(delta[a], c_alpha[a], c_gamma[a], 0.0, 0.0, 0.0)
                    ok = ok and good
        # a start that failed (not ok) ends the Newton loop at once and is given up below
        r_t, current = _residuals(nc, w, c_arm, cmat, torque, delta, f, r_w, loaded)
        solved = False
        previous = np.inf  # the scaled residual before the last step
        factored = False  # system holds the Cholesky factor of n_factored engaged pins
        n_factored = 0
        for _ in range(max_iterations):
            if not ok:
                break
            scale = 0.0
            worst = 0.0
            for a in range(nc):
                gap = x - c_bl[a]
                scale = max(scale, c_arm[a] * (gap if gap > 0.0 else 0.0))
                worst = max(worst, abs(r_w[a]))
            # near the root (the tolerances), then on to the root at round-off: a residual
            # of a few units in the last place, or the first step that does not reduce it
            near = abs(r_t) <= tol_torque * torque and worst <= tol_compat * scale
            if near and (
                (abs(r_t) <= round_off * torque and worst <= round_off * scale)
                or current >= previous
            ):
                solved = True
                break
            previous = current
            # the Newton step on the engaged pins: (D⁻¹ + C)_EE, right-hand sides r_w, l
            ne = 0
            same = factored
            for a in range(nc):
                if f[a] > 0.0:
                    same = same and ne < n_factored and int(eng[ne]) == a
                    eng[ne] = a
                    ne += 1
            chord = near and same and ne == n_factored
            if same and ne == n_factored and current <= _CHORD:
                # close to the root, the engaged pins as at the last factorisation: its
                # factor again (a chord step: the Jacobian has moved by about the last
                # step, so from 1e-12 to round-off in one), only r_w to solve for (the
                # solution for l is the factorisation's, in rhs)
                for e in range(ne):
                    rhs[e, 0] = r_w[eng[e]]
                _cholesky_solve(ne, system, rhs)
            else:
                factored = _factor_solve(
                    ne, eng, cmat, c_alpha, c_gamma, y, r_w, c_arm, system, rhs
                )
                n_factored = ne
                if not factored and not _solve2(ne, system, rhs):
                    ok = False
                    break
            den = 0.0
            top = 0.0
            for e in range(ne):
                den += c_arm[eng[e]] * rhs[e, 1]
                top += c_arm[eng[e]] * rhs[e, 0]
            if not (np.isfinite(den) and den != 0.0):
                ok = False
                break
            step_x = -(r_t + top) / den
            for a in range(nc):
                step_f[a] = 0.0
            for e in range(ne):
                step_f[eng[e]] = rhs[e, 0] + rhs[e, 1] * step_x
            if chord:  # the last step: F + ΔF is the law's inverse at the new approach to
                # second order (ΔF = D·Δδ, Δδ within 1e-12 of δ: to 1e-24), no evaluation
                x = x + step_x
                for e in range(ne):
                    a = eng[e]
                    fa = f[a] + step_f[a]
                    f[a] = fa if fa > 0.0 else 0.0
                solved = True
                break
            # C·ΔF over the engaged pins (ΔF = 0 elsewhere), as C·F in _residuals
            for a in range(nc):
                step_w[a] = 0.0
            for e in range(ne):
                dfe = step_f[eng[e]]
                row = cmat[eng[e]]
                for a in range(nc):
                    step_w[a] += row[a] * dfe
            for a in range(nc):
                step_w[a] -= r_w[a]
            # backtracking on the scaled residual (near the root: the full step)
            lam = 1.0
            for _ in range(_HALVINGS):
                xn = x + lam * step_x
                for a in range(nc):
                    wn[a] = w[a] + lam * step_w[a]
                rtn, new, ok = _evaluate(
                    nc, xn, wn, c_bl, c_arm, c_alpha, c_gamma, cmat, torque,
                    (delta, f, y), dn, fn, yn, rwn, loaded
                )  # fmt: skip
                if not ok or near:
                    break
                if not (new > current and lam > _SMALLEST_STEP):
                    break
                lam = 0.5 * lam
            if not ok:
                break
            x = xn
            r_t = rtn
            current = new
            for a in range(nc):
                w[a], delta[a], f[a], y[a], r_w[a] = wn[a], dn[a], fn[a], yn[a], rwn[a]
        if not solved:  # or its start failed: the caller gives the rigid disc's start
            # (or takes the reference)
            _give_up(k, warm, tooth, angle, diagonal, grid, own, bl, arm, alpha, gamma, torque,
                     candidate, status, root, suspect)  # fmt: skip
            streak = 0
            failed += 1
            continue
        status[k] = 0
        streak += 1
        last = k
        rotation[k] = x
        root[k] = x
        # Σ F in pin order (the other pins' loads are 0: the sum of the whole row)
        last_total = 0.0
        for a in range(nc):
            i = idx[a]
            force[k, i] = f[a]
            last_total += f[a]
        # _suspects' test of this case (the same ΣF, in pin order, and the same margin)
        # (branch-free over the pins: φbl = +inf or NaN fails the comparison itself)
        load = lowest * last_total
        flag = False
        for i in range(n):
            b, lk = bl[k, i], arm[k, i]
            near = (b - x) * lk < load + 1e-12 * (abs(x) * lk + load)
            flag |= (not candidate[k, i]) & (lk > 0.0) & (b > -np.inf) & near
        suspect[k] = flag
    return failed


def _suspects(candidate, bl, arm, rotation, force, lowest, out):  # pragma: no cover (compiled)
    """The cases (rows) in which the check after the solve of
    :func:`cyclomesh.core.discbody.share_load_coupled` may find a pin outside the
    candidates that could touch (φbl < Δφc + c·ΣF/l, c [m/N] the table's most negative
    coefficient ``lowest``), into ``out`` (B,) bool: the test with a margin of 1e-12 of
    its terms, a superset of the cases the check's own NumPy test flags (its sum of the
    loads is pairwise, this one in pin order), so that the check need look at these
    cases only."""
    n_cases, n = bl.shape
    for k in range(n_cases):
        total = 0.0
        for i in range(n):
            total += force[k, i]
        flag = False
        r = rotation[k]
        load = lowest * total  # the test times l > 0: (φbl − Δφc)·l < c·ΣF, no quotient
        for i in range(n):
            b, lk = bl[k, i], arm[k, i]
            if candidate[k, i] or not (np.isfinite(b) and lk > 0.0):
                continue
            if (b - r) * lk < load + 1e-12 * (abs(r) * lk + load):
                flag = True
                break
        out[k] = flag


def _teeth(phi, step, n2, out):  # pragma: no cover (compiled)
    """:func:`cyclomesh.core.discbody.tooth_index` into ``out`` (crank angles, pins) int:
    rint((step·i + φ)/2π) mod n2, ``step`` = n2·ψ [rad] (the same operations in the same
    order as the NumPy function, so the same integers)."""
    two_pi = 2.0 * np.pi
    inv = 1.0 / n2
    for k in range(phi.size):
        for i in range(out.shape[1]):
            t = np.rint((step * float(i) + phi[k]) / two_pi)
            r = t - np.floor(t * inv) * n2  # t mod n2 (t integer-valued, |t| ≪ 2⁵³) …
            r = r - n2 if r >= n2 else (r + n2 if r < 0.0 else r)  # … whatever 1/n2 rounds to
            out[k, i] = int(r)
