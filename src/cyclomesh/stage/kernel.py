"""The stage equilibrium's two innermost laws compiled (numba), beside the NumPy reference.

With ``CYCLOMESH_KERNEL=numba`` (the one switch of :mod:`cyclomesh.core.kernel`) every
evaluation of the stage's potential in Newton's method
(:func:`cyclomesh.stage.equilibrium._evaluate`) takes

* the pins' law (:func:`pin_law`): the approach of every pin from the disc's motion,
  δ = l·(θ − φbl) + n·u − (C'λ), the force by inverting δ = F·(α − γ ln F) (Eq. 20 of
  [1], the algorithm of :func:`cyclomesh.core.hertz.force_from_approach`: two
  fixed-point steps, then Newton in y = ln F to a residual of 2e-15·δ, each pin on its
  own), its stiffness 1/(α − γ(1 + ln F)) and energy ½F²(α − γ/2 − γ ln F), in one pass
  over the pins without temporaries, the law evaluated on the closed pins only;
* the crank bearing's roller set (:func:`roller_law`, Harris & Kotzalas [2], Ch. 7):
  δ_j = s·cos ψ_j − P_d/2, Q_j = K_n·δ_j^(10/9), its force Σ Q_j cos ψ_j, stiffness
  Σ (10/9)K_n δ_j^(1/9) cos² ψ_j and energy Σ K_n δ_j^(19/9)/(19/9), one power a loaded
  roller (δ^(10/9) = δ·δ^(1/9), δ^(19/9) = δ·δ^(10/9)).

Both are the reference's arithmetic element by element except for the last bits of the
C library's exp, log and pow against NumPy's SIMD functions, the powers formed from one
root, and the roller sums taken in order (NumPy's are pairwise): the stage's results
agree with the NumPy path to round-off (``tests/stage/test_kernel_stage.py``). A pin
whose law cannot be inverted is handed to the reference, which raises its own error.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] T. A. Harris, M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., CRC Press 2007, Ch. 7.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.jit import njit
from cyclomesh.core.kernel import kernel_name

__all__ = ["MAX_NEWTON", "ROUND_OFF", "compiled", "pin_law", "roller_law"]

FloatArray = NDArray[np.float64]

MAX_NEWTON = 50
"""Newton steps of one force inversion (as :func:`cyclomesh.core.hertz.force_from_approach`)."""
ROUND_OFF = 2e-15
"""Relative residual of a converged force inversion (as force_from_approach)."""


def compiled() -> bool:
    """True when ``CYCLOMESH_KERNEL=numba`` selects the compiled laws (read at each call)."""
    return kernel_name() == "numba"


@cache
def _kernels() -> tuple[Any, Any]:
    jit = njit()
    return jit(_pin_rows), jit(_roller_rows)


def pin_law(
    bl: FloatArray,
    arm: FloatArray,
    nx: FloatArray,
    ny: FloatArray,
    alpha: FloatArray,
    gamma: FloatArray,
    dmax: FloatArray,
    theta: FloatArray,
    ux: FloatArray | None,
    uy: FloatArray | None,
    shift: FloatArray | None,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]] | None:
    """Force [N], stiffness [N/m], energy [J] of every pin (A, D, P) and ``bad`` (A,): an
    approach at or beyond ``dmax`` [m]; None if a closed pin's law cannot be inverted (the
    caller then takes the reference). Pins with φbl = inf have no law (δ = −1).

    ``bl`` [rad], ``arm`` [m], ``nx``, ``ny``, ``alpha``, ``gamma`` [m/N], ``dmax`` [m]:
    (A, D, P); ``theta`` [rad], ``ux``, ``uy`` [m]: (A, D), ``ux`` None: no translation;
    ``shift`` [m]: (A, D, P) or None.
    """
    A, D, P = bl.shape
    force = np.zeros((A, D, P))
    stiff = np.zeros((A, D, P))
    energy = np.zeros((A, D, P))
    bad = np.zeros(A, np.bool_)
    move = ux is not None
    zero = np.zeros((A, D))
    ok = _kernels()[0](
        *(np.ascontiguousarray(v) for v in (bl, arm, nx, ny, alpha, gamma, dmax, theta)),
        np.ascontiguousarray(ux if move else zero),
        np.ascontiguousarray(uy if move else zero),
        move,
        np.ascontiguousarray(shift if shift is not None else bl[..., :0]),
        shift is not None,
        force,
        stiff,
        energy,
        bad,
    )
    return (force, stiff, energy, bad) if ok else None


def _pin_rows(
    bl,
    arm,
    nx,
    ny,
    alpha,
    gamma,
    dmax,
    theta,
    ux,
    uy,
    move,
    shift,
    shifted,
    force,
    stiff,
    energy,
    bad,
):  # pragma: no cover (compiled)
    """:func:`pin_law` written for numba (plain loops, scalars); False on a failed inversion."""
    A, D, P = bl.shape
    for i in range(A):
        for d in range(D):
            for j in range(P):
                b = bl[i, d, j]
                if not np.isfinite(b):
                    continue  # no law: δ = −1, open
                delta = arm[i, d, j] * (theta[i, d] - b)
                if move:
                    delta = delta + nx[i, d, j] * ux[i, d] + ny[i, d, j] * uy[i, d]
                if shifted:
                    delta = delta - shift[i, d, j]
                if delta <= 0.0:
                    continue
                if delta >= dmax[i, d, j]:
                    bad[i] = True
                    continue
                a, g = alpha[i, d, j], gamma[i, d, j]
                if g == 0.0:
                    f = delta / a
                else:
                    if np.log(delta / g) - a / g >= -1.0:
                        return False  # past the stiffest point: the reference raises
                    y = np.log(delta / a)
                    y = np.log(delta / (a - g * y))
                    y = np.log(delta / (a - g * y))
                    done = False
                    for _ in range(MAX_NEWTON):
                        e = np.exp(y)
                        resid = e * (a - g * y) - delta
                        if abs(resid) <= ROUND_OFF * delta:
                            done = True
                            break
                        y = y - resid / (e * (a - g - g * y))
                    if not done:
                        e = np.exp(y)
                        resid = e * (a - g * y) - delta
                        resolution = 4.0 * 2.220446049250313e-16 * abs(y) * abs(e * (a - g - g * y))
                        if not (abs(resid) <= ROUND_OFF * delta or abs(resid) <= resolution):
                            return False
                    f = e  # e^y of the last y (the reference's exp(y) again)
                if f > 0.0:
                    logf = np.log(f)
                    force[i, d, j] = f
                    stiff[i, d, j] = 1.0 / (a - g * (1.0 + logf))
                    energy[i, d, j] = 0.5 * f * f * (a - 0.5 * g - g * logf)
    return True


def roller_law(
    cosines: FloatArray, half_clearance: float, constant: float, s: FloatArray, stiffness: bool
) -> tuple[FloatArray, FloatArray | None, FloatArray]:
    """Force [N], stiffness [N/m] (None if not ``stiffness``) and energy [J] of a roller set
    at the displacements ``s`` [m] (any shape): ``cosines`` cos ψ_j (Z,), ``half_clearance``
    P_d/2 [m], ``constant`` K_n [N/m^(10/9)]."""
    flat = np.ascontiguousarray(s, dtype=float).reshape(-1)
    force, stiff, energy = (np.empty(flat.shape) for _ in range(3))
    _kernels()[1](
        np.ascontiguousarray(cosines), half_clearance, constant, flat, force, stiff, energy
    )
    shape = np.shape(s)
    return (
        force.reshape(shape),
        stiff.reshape(shape) if stiffness else None,
        energy.reshape(shape),
    )


def _roller_rows(cosines, half, constant, s, force, stiff, energy):  # pragma: no cover
    """:func:`roller_law` written for numba."""
    p = 10.0 / 9.0
    for i in range(s.size):
        fsum = 0.0
        ksum = 0.0
        usum = 0.0
        for j in range(cosines.size):
            c = cosines[j]
            delta = s[i] * c - half
            if delta > 0.0:
                root = delta ** (1.0 / 9.0)
                q = delta * root  # δ^(10/9)
                fsum += constant * q * c
                ksum += p * constant * root * c * c
                usum += constant * (delta * q)
        force[i] = fsum
        stiff[i] = ksum
        energy[i] = usum / (p + 1.0)


# --- the start of the bearing phase (stiff-limit split, bearing deflection) ---------------


@cache
def _start_kernels() -> tuple[Any, Any]:
    jit = njit()
    global _roller_point, _solve3, _split_rows, _deflection_rows, _disc_sum_rows, _turn_rows
    _roller_point = jit(_roller_point)
    _solve3 = jit(_solve3)
    _split_rows = jit(_split_rows)  # compiled in place: _start_rows calls them
    _deflection_rows = jit(_deflection_rows)
    _disc_sum_rows = jit(_disc_sum_rows)
    _turn_rows = jit(_turn_rows)
    return (
        _split_rows,
        _deflection_rows,
        _disc_sum_rows,
        _turn_rows,
        jit(_single_rows),
        jit(_mesh_work_rows),
        jit(_flank_rows),
        jit(_dmax_rows),
        jit(_start_rows),
    )


def bearing_start(
    block: FloatArray,
    force: FloatArray,
    stiffness: FloatArray,
    x: FloatArray,
    holes: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    L: float,
    rs,
    exponent: float,
    split_iterations: int,
) -> FloatArray | None:
    """The bearing phase's start of :func:`cyclomesh.stage.equilibrium.solve_direction`
    (its ``bearing_start``, rigid discs, no friction, no series spring) in one compiled
    pass: from the rigid solution ``x`` (k, 1 + 3D), its pins' forces [N] and
    stiffnesses [N/m] (k, D, P), the stiff limit's split of each disc's load
    (:func:`split`), the bearings' deflections under it (:func:`deflection`, roller set
    ``rs``), each disc's mean translation and turn and the carrier's rotation, as the
    NumPy start forms them: the same operations in the same order (NumPy's sums of these
    few terms along the last axis are in order, from the first; numba's hypot is the C
    library's, as NumPy's), so the same bits. ``block`` the problem's pins (7, k, D, P),
    ``holes`` (hx, hy (k, N), ex, ey (k, D, N)) [m], ``L`` r_c [m]. None where the split
    does not converge (the caller takes the NumPy start, which raises)."""
    out = np.array(x, dtype=float)
    ok = _start_kernels()[8](
        block,
        np.ascontiguousarray(force, dtype=float),
        np.ascontiguousarray(stiffness, dtype=float),
        *(np.ascontiguousarray(v, dtype=float) for v in holes),
        float(L),
        float(exponent),
        int(split_iterations),
        np.cos(rs.angles),
        0.5 * rs.clearance,
        float(rs.constant),
        out,
    )
    return out if ok else None


def _start_rows(
    pin, force, k_pin, hx, hy, ex, ey, L, p, split_iterations, cosines, half, constant, x,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`bearing_start` written for numba (``x`` the rigid solution, overwritten)."""
    A, D, P = force.shape
    N = hx.shape[1]
    share = np.empty((A, D))
    rfx = np.empty((A, D))
    rfy = np.empty((A, D))
    weight = np.empty((A, D))
    _disc_sum_rows(force, pin[1], pin[2], pin[3], k_pin, share, rfx, rfy, weight)
    moment = -share
    bfx = np.zeros((A, D, N))
    bfy = np.zeros((A, D, N))
    if not _split_rows(hx, hy, rfx, rfy, moment, L, p, split_iterations, bfx, bfy):
        return False
    B = np.empty((A, D, N))
    for i in range(A):
        for d in range(D):
            for k in range(N):
                B[i, d, k] = math.hypot(bfx[i, d, k], bfy[i, d, k])
    s = np.empty(A * D * N)
    _deflection_rows(cosines, half, constant, p, B.reshape(-1), 100, D * N, s)
    dx = np.empty((A, D, N))
    dy = np.empty((A, D, N))
    omega = np.empty((A, D))
    ux = np.empty((A, D))
    uy = np.empty((A, D))
    scale = N * L * L
    for i in range(A):
        for d in range(D):
            for k in range(N):
                b = B[i, d, k]
                sk = s[(i * D + d) * N + k]
                dx[i, d, k] = (bfx[i, d, k] / b * sk if b > 0 else 0.0) - ex[i, d, k]
                dy[i, d, k] = (bfy[i, d, k] / b * sk if b > 0 else 0.0) - ey[i, d, k]
            om = dx[i, d, 0] * -hy[i, 0] + dy[i, d, 0] * hx[i, 0]
            sx = dx[i, d, 0]
            sy = dy[i, d, 0]
            for k in range(1, N):
                om += dx[i, d, k] * -hy[i, k] + dy[i, d, k] * hx[i, k]
                sx += dx[i, d, k]
                sy += dy[i, d, k]
            omega[i, d] = om / scale
            ux[i, d] = sx / N
            uy[i, d] = sy / N
    turn = np.empty((A, D))
    _turn_rows(k_pin, pin[1], pin[2], pin[3], ux, uy, weight, turn)
    for i in range(A):
        c = (x[i, 1] + turn[i, 0]) - omega[i, 0]
        for d in range(1, D):
            c += (x[i, 1 + 3 * d] + turn[i, d]) - omega[i, d]
        c = c / D
        x[i, 0] = c
        for d in range(D):
            x[i, 1 + 3 * d] = c + omega[i, d]
            x[i, 2 + 3 * d] = ux[i, d]
            x[i, 3 + 3 * d] = uy[i, d]
    return True


def split(
    hx: FloatArray,
    hy: FloatArray,
    L: float,
    mesh_fx: FloatArray,
    mesh_fy: FloatArray,
    moment: FloatArray,
    exponent: float,
    iterations: int,
) -> tuple[FloatArray, FloatArray] | None:
    """:func:`cyclomesh.stage.supports.stiff_limit_split` compiled: the forces on the crank
    pins [N] (A, D, N) each, or None if a (crank angle, disc) does not converge within
    ``iterations`` Newton steps (the caller then raises). The reference's arithmetic
    element by element (its start, step and test for each (crank angle, disc) on its own,
    as its active set does) except the 3 × 3 solve by Gaussian elimination with partial
    pivoting (LAPACK's dgesv unblocked) and the powers, s^p formed as s·s^(p−1) from the
    C library's pow (one power a bearing and step, as the roller law's); and each disc
    starts from its solution at the crank angle before where there is one (the loads turn
    little from one angle to the next: fewer steps to the same test), from the reference's
    start where that does not pass the test within :data:`_WARM_STEPS` steps."""
    A, D = mesh_fx.shape
    fx, fy = np.zeros((A, D, hx.shape[-1])), np.zeros((A, D, hx.shape[-1]))
    ok = _start_kernels()[0](
        *(np.ascontiguousarray(v, dtype=float) for v in (hx, hy, mesh_fx, mesh_fy, moment)),
        float(L),
        float(exponent),
        int(iterations),
        fx,
        fy,
    )
    return (fx, fy) if ok else None


def _split_rows(hx, hy, mfx, mfy, moment, L, p, iterations, fx, fy):  # pragma: no cover
    """:func:`split` written for numba."""
    A, D = mfx.shape
    N = hx.shape[1]
    jx = np.zeros(N)
    jy = np.zeros(N)
    dx = np.zeros(N)
    dy = np.zeros(N)
    B = np.zeros(N)
    kb = np.zeros(N)
    cx = np.zeros(N)
    cy = np.zeros(N)
    sec = np.zeros(N)
    vx = np.zeros((3, N))
    vy = np.zeros((3, N))
    H = np.zeros((3, 3))
    g = np.zeros(3)
    y = np.zeros(3)
    step = np.zeros(3)
    previous = np.zeros((D, 3))  # each disc's solution at the crank angle before
    warm = np.zeros(D, np.bool_)
    for i in range(A):
        for k in range(N):
            jx[k] = -hy[i, k]
            jy[k] = hx[i, k]
            vx[0, k] = jx[k] / L
            vy[0, k] = jy[k] / L
            vx[1, k], vy[1, k] = 1.0, 0.0
            vx[2, k], vy[2, k] = 0.0, 1.0
        for d in range(D):
            t0, t1, t2 = moment[i, d] / L, mfx[i, d], mfy[i, d]
            if t0 == 0.0 and t1 == 0.0 and t2 == 0.0:
                warm[d] = False
                continue  # carries nothing: B = 0 exactly
            scale = max(max(abs(t0), max(abs(t1), abs(t2))), 1e-300)
            done = False
            for attempt in range(2):
                if attempt == 0:  # from the crank angle before, in a few steps
                    if not warm[d]:
                        continue
                    for r in range(3):
                        y[r] = previous[d, r]
                    cap = _WARM_STEPS
                else:
                    # the linear (least-norm) split, its magnitude through the power law
                    a0 = 0.0
                    a1 = 0.0
                    a2 = 0.0
                    for k in range(N):
                        lin_x = mfx[i, d] / N + moment[i, d] * jx[k] / (N * L * L)
                        lin_y = mfy[i, d] / N + moment[i, d] * jy[k] / (N * L * L)
                        mag = np.hypot(lin_x, lin_y)
                        s0 = mag ** (1.0 / p)
                        dx0 = lin_x / mag * s0 if mag > 0 else 0.0
                        dy0 = lin_y / mag * s0 if mag > 0 else 0.0
                        a0 += dx0 * jx[k] + dy0 * jy[k]
                        a1 += dx0
                        a2 += dy0
                    y[0], y[1], y[2] = a0 / (N * L), a1 / N, a2 / N
                    cap = iterations
                for _ in range(cap):
                    for k in range(N):
                        dx[k] = y[1] + y[0] * jx[k] / L
                        dy[k] = y[2] + y[0] * jy[k] / L
                        s = np.hypot(dx[k], dy[k])
                        root = s ** (p - 1.0)  # one power: s^p = s·s^(p−1)
                        B[k] = s * root
                        kb[k] = p * root
                        if s > 0:
                            cx[k], cy[k], sec[k] = dx[k] / s, dy[k] / s, B[k] / s
                        else:
                            cx[k], cy[k], sec[k] = 1.0, 0.0, 0.0
                        fx[i, d, k] = B[k] * cx[k]
                        fy[i, d, k] = B[k] * cy[k]
                    small = True
                    for r in range(3):
                        acc = 0.0
                        for k in range(N):
                            acc += B[k] * cx[k] * vx[r, k] + B[k] * cy[k] * vy[r, k]
                        g[r] = acc - (t0 if r == 0 else (t1 if r == 1 else t2))
                        if not (abs(g[r]) <= 1e-13 * scale):
                            small = False
                    if small:
                        done = True
                        break
                    for r in range(3):
                        for c in range(3):
                            acc = 0.0
                            for k in range(N):
                                kxx = kb[k] * cx[k] * cx[k] + sec[k] * cy[k] * cy[k]
                                kyy = kb[k] * cy[k] * cy[k] + sec[k] * cx[k] * cx[k]
                                kxy = (kb[k] - sec[k]) * cx[k] * cy[k]
                                acc += (kxx * vx[r, k] + kxy * vy[r, k]) * vx[c, k] + (
                                    kxy * vx[r, k] + kyy * vy[r, k]
                                ) * vy[c, k]
                            H[r, c] = acc
                    if not _solve3(H, g, step):
                        break
                    for r in range(3):
                        y[r] = y[r] - step[r]
                if done:
                    break
            if not done:
                return False
            for r in range(3):
                previous[d, r] = y[r]
            warm[d] = True
    return True


_WARM_STEPS = 12
"""Newton steps of :func:`_split_rows` from the crank angle before, after which it starts
again from the linear split (its own start, with all its steps)."""


def _solve3(H, g, out):  # pragma: no cover (compiled)
    """out = H⁻¹g (3 × 3) by Gaussian elimination with partial pivoting; False if a pivot
    is 0 (H is overwritten)."""
    n = g.size
    for r in range(n):
        out[r] = g[r]
    for k in range(n):
        piv = k
        big = abs(H[k, k])
        for r in range(k + 1, n):
            if abs(H[r, k]) > big:
                big = abs(H[r, k])
                piv = r
        if big == 0.0:
            return False
        if piv != k:
            for c in range(n):
                H[k, c], H[piv, c] = H[piv, c], H[k, c]
            out[k], out[piv] = out[piv], out[k]
        for r in range(k + 1, n):
            f = H[r, k] / H[k, k]
            for c in range(k + 1, n):
                H[r, c] -= f * H[k, c]
            out[r] -= f * out[k]
    for k in range(n - 1, -1, -1):
        acc = out[k]
        for c in range(k + 1, n):
            acc -= H[k, c] * out[c]
        out[k] = acc / H[k, k]
    return True


def deflection(
    cosines: FloatArray,
    half_clearance: float,
    constant: float,
    exponent: float,
    force: FloatArray,
    iterations: int,
) -> FloatArray:
    """:func:`cyclomesh.stage.supports.bearing_deflection`'s roller set compiled: the
    displacement s [m] at which the roller set (:func:`roller_law`) carries ``force`` [N]
    ≥ 0 (any shape), by the reference's Newton iteration from its start, each element
    stepped until its own residual passes the reference's test (|B(s) − F| ≤ 1e-12·F) and
    then once more from the values at hand (no evaluation: Newton's step from there lands
    at round-off), or ``iterations`` steps, after which the reference too returns where it
    is. The reference steps every element until all have passed (its whole-array test),
    so that most elements end at round-off: the same s to round-off. With a leading axis
    of crank angles (``force`` of two or more axes) an element whose crank angle before
    carries load starts from that angle's solution instead (Newton's method on the
    convex, increasing B(s) converges from any point where a roller is loaded: past the
    root in one step, then monotonically down onto it; the neighbouring angle's is close,
    so that two or three steps reach the test instead of four or five)."""
    flat = np.ascontiguousarray(force, dtype=float).reshape(-1)
    s = np.empty(flat.shape)
    _start_kernels()[1](
        np.ascontiguousarray(cosines),
        float(half_clearance),
        float(constant),
        float(exponent),
        flat,
        int(iterations),
        flat.size // np.shape(force)[0] if np.ndim(force) > 1 and flat.size else 0,
        s,
    )
    return s.reshape(np.shape(force))


def _roller_point(cosines, half, constant, s):  # pragma: no cover (compiled)
    """Force [N] and stiffness [N/m] of the roller set at one displacement ``s``, the
    arithmetic of :func:`_roller_rows` (one power a loaded roller)."""
    p = 10.0 / 9.0
    fsum = 0.0
    ksum = 0.0
    for j in range(cosines.size):
        c = cosines[j]
        delta = s * c - half
        if delta > 0.0:
            root = delta ** (1.0 / 9.0)
            fsum += constant * (delta * root) * c
            ksum += p * constant * root * c * c
    return fsum, ksum


def _deflection_rows(cosines, half, constant, p, force, iterations, row, s):  # pragma: no cover
    """:func:`deflection` written for numba: each element on its own, started from the
    element ``row`` before it where that one carries load (``row`` 0: none); False if one
    has not passed the test after ``iterations`` steps."""
    converged = True
    for i in range(force.size):
        f = force[i]
        if row > 0 and i >= row and f > 0.0 and force[i - row] > 0.0 and s[i - row] > half:
            x = s[i - row]
        else:
            x = half + (max(f, 0.0) / constant) ** (1.0 / p)
        done = False
        for _ in range(iterations):
            value, stiff = _roller_point(cosines, half, constant, x)
            if abs(value - f) <= 1e-12 * max(f, 1e-300):
                done = True
                if f > 0 and stiff > 0:  # one more step from the values at hand: round-off
                    x = x - (value - f) / stiff
                break
            if f > 0:
                k = stiff if stiff > 0 else np.inf
                x = x - (value - f) / k
            else:
                x = half
        s[i] = x
        converged = converged and done
    return converged


def disc_sums(
    force: FloatArray, arm: FloatArray, nx: FloatArray, ny: FloatArray, stiffness: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The rigid solution's sums over the pins of every (crank angle, disc) in one pass, as
    :func:`cyclomesh.stage.equilibrium.solve_direction`'s start forms them with NumPy:
    the torque share Σ F·l [N·m], the mesh force −Σ F·n [N] (x, y) and the rotational
    stiffness Σ k·l² [N·m] (:func:`cyclomesh.core.fields.contact_fields`' and the start's
    arithmetic element by element, the sums taken in order where NumPy's are pairwise).
    ``force`` [N], ``arm`` [m], ``nx``, ``ny``, ``stiffness`` [N/m]: (A, D, P); each
    result (A, D)."""
    A, D = force.shape[:2]
    out = [np.empty((A, D)) for _ in range(4)]
    _start_kernels()[2](
        *(np.ascontiguousarray(v, dtype=float) for v in (force, arm, nx, ny, stiffness)), *out
    )
    return out[0], out[1], out[2], out[3]


def _disc_sum_rows(force, arm, nx, ny, k, share, fx, fy, weight):  # pragma: no cover
    """:func:`disc_sums` written for numba."""
    A, D, P = force.shape
    for i in range(A):
        for d in range(D):
            a = 0.0
            bx = 0.0
            by = 0.0
            w = 0.0
            for j in range(P):
                f = force[i, d, j]
                lj = arm[i, d, j]
                a += f * lj
                bx += f * nx[i, d, j]
                by += f * ny[i, d, j]
                w += k[i, d, j] * lj * lj
            share[i, d] = a
            fx[i, d] = -bx
            fy[i, d] = -by
            weight[i, d] = w


def disc_turn(
    stiffness: FloatArray,
    arm: FloatArray,
    nx: FloatArray,
    ny: FloatArray,
    ux: FloatArray,
    uy: FloatArray,
    weight: FloatArray,
) -> FloatArray:
    """The start's turn of every disc [rad] (A, D): −Σ k·l·(n·u) / Σ k·l² (0 where the
    weight is not positive), the least-squares rotation that keeps the pins' approach of
    the rigid solution despite the translation u [m] (A, D), in one pass (the NumPy
    start's arithmetic element by element, the sum in order)."""
    turn = np.empty(weight.shape)
    _start_kernels()[3](
        *(np.ascontiguousarray(v, dtype=float) for v in (stiffness, arm, nx, ny, ux, uy)),
        np.ascontiguousarray(weight, dtype=float),
        turn,
    )
    return turn


def _turn_rows(k, arm, nx, ny, ux, uy, weight, turn):  # pragma: no cover (compiled)
    """:func:`disc_turn` written for numba."""
    A, D, P = k.shape
    for i in range(A):
        for d in range(D):
            t = 0.0
            for j in range(P):
                t += k[i, d, j] * arm[i, d, j] * (nx[i, d, j] * ux[i, d] + ny[i, d, j] * uy[i, d])
            w = weight[i, d]
            turn[i, d] = -t / (w if w > 0 else np.inf)


def single_rotation(
    bl: FloatArray, arm: FloatArray, alpha: FloatArray, gamma: FloatArray, torque: float, pins: int
) -> FloatArray:
    """The rigid start of :func:`cyclomesh.stage.equilibrium.solve_direction` in one pass:
    the smallest rotation [rad] (A,) at which one pin alone (of the first ``pins`` of
    every disc, the loaded flanks, with a law and a positive arm) carries ``torque``
    [N·m] on the stiffening branch of its law, φbl + F·(α − γ ln F)/l with F = T/l (inf
    where none can). The NumPy start's arithmetic element by element, the logarithm the
    C library's; a pin whose φbl is not below the smallest so far is passed over (on the
    stiffening branch α − γ ln F > γ ≥ 0, so its value exceeds its φbl): the same
    minimum."""
    out = np.empty(bl.shape[0])
    _start_kernels()[4](bl, arm, alpha, gamma, float(torque), int(pins), out)
    return out


def _single_rows(bl, arm, alpha, gamma, torque, pins, out):  # pragma: no cover (compiled)
    """:func:`single_rotation` written for numba."""
    A, D = bl.shape[:2]
    for i in range(A):
        best = np.inf
        for d in range(D):
            for j in range(pins):
                b = bl[i, d, j]
                lj = arm[i, d, j]
                if not (np.isfinite(b) and lj > 0) or b >= best:
                    continue  # (b ≥ best: v = b + F·(α − γ ln F)/l > b cannot be smaller)
                f1 = torque / lj
                log1 = np.log(f1)
                a, g = alpha[i, d, j], gamma[i, d, j]
                if not (g == 0 or log1 < a / g - 1.0):
                    continue
                v = b + f1 * (a - g * log1) / lj
                if v < best:
                    best = v
        out[i] = best


def mesh_work(block: FloatArray, force: FloatArray, x: FloatArray, discs: int) -> FloatArray:
    """The mesh's work on its own deformation [J] (A,) of
    :func:`cyclomesh.stage.equilibrium._work` in one pass: Σ F·(δ_lin − δ_lin(0)) over the
    pins with a law (φbl finite), δ_lin = l·(θ − φbl) + n·u and δ_lin(0) = −l·φbl, each
    term the NumPy reference's arithmetic element by element, the sum over every disc's
    pins taken in order (NumPy's is pairwise: the same to round-off). ``block`` the
    problem's pins (:func:`cyclomesh.stage.kernel_newton.pin_block`, (7, A, D, P)),
    ``force`` [N] (A, D, P), ``x`` the unknowns (A, ≥ 1 + 3D): c, then θ, ux, uy per disc."""
    out = np.empty(force.shape[0])
    _start_kernels()[5](
        block, np.ascontiguousarray(force, dtype=float), np.ascontiguousarray(x, dtype=float),
        int(discs), out,
    )  # fmt: skip
    return out


def _mesh_work_rows(pin, force, x, discs, out):  # pragma: no cover (compiled)
    """:func:`mesh_work` written for numba."""
    A, D, P = force.shape
    for i in range(A):
        acc = 0.0
        for d in range(D):
            th, ux, uy = x[i, 1 + 3 * d], x[i, 2 + 3 * d], x[i, 3 + 3 * d]
            for j in range(P):
                b = pin[0, i, d, j]
                if not np.isfinite(b):
                    continue
                arm = pin[1, i, d, j]
                lin = arm * (th - b) + pin[2, i, d, j] * ux + pin[3, i, d, j] * uy
                acc += force[i, d, j] * (lin - (-arm) * b)
        out[i] = acc


def flank_block(block: FloatArray, this: tuple, that: tuple, reverse: FloatArray, rest) -> None:
    """The pins' arrays of :func:`cyclomesh.stage.equilibrium._problem` but ``dmax`` in one
    pass, into ``block`` (7, A, D, 2·n1) in the order of
    :data:`cyclomesh.stage.kernel_newton.PIN_BLOCK`: pins 0 … n1 − 1 the loaded flanks
    (``this``: backlash [rad], moment arm [m], normal x, y, α, γ [m/N] of the mesh, each
    (A, D, n1)), pins n1 … 2n1 − 1 the opposite flanks from the mirror problem (``that``:
    its moment arm, normal x, y, α, γ, (A, D, n1) each, crank angles reversed, disc d ←
    disc (−d) mod D, pin i ← pin (n1 − i) mod n1), their backlash the mesh's opposite-flank
    rotation ``reverse`` (A, D, n1) less the rest ``rest`` (A,); an opposite flank without
    a usable law (a backlash, arm, α or γ not finite, or an arm < 0) gets φbl = inf, arm
    −0, α = 1, γ = 0 and a zero normal; the others the arm −l' and the normal's y
    negated. The reference's copies, negations and selects element by element: the same
    bits. ``dmax`` (block[6]) gets α/γ − 1, the argument of the exponential of
    :func:`dmax_finish`."""
    _start_kernels()[6](block, *this, *that, reverse, np.asarray(rest, dtype=float))


def dmax_finish(block: FloatArray, reach: float) -> None:
    """``dmax`` of :func:`cyclomesh.stage.equilibrium._pin_problem` in ``block``
    (:func:`flank_block`'s) from α/γ − 1 there: NumPy's exponential in place (its bits,
    which the C library's need not have), then in one pass γ·exp(α/γ − 1)·``reach``
    [m] where γ > 0 and γ·exp(α/γ − 1) is finite, else inf: the reference's products in
    its order, the same bits."""
    dmax = block[6]
    with np.errstate(over="ignore", invalid="ignore"):
        np.exp(dmax, out=dmax)
    _start_kernels()[7](block, float(reach))


def _dmax_rows(block, reach):  # pragma: no cover (compiled)
    """:func:`dmax_finish`'s pass, written for numba."""
    _, A, D, P = block.shape
    for i in range(A):
        for d in range(D):
            for j in range(P):
                g = block[5, i, d, j]
                v = g * block[6, i, d, j]
                block[6, i, d, j] = v * reach if (g > 0 and np.isfinite(v)) else np.inf


def _flank_rows(
    block, bl_f, arm_f, nx_f, ny_f, alpha_f, gamma_f, arm_m, nx_m, ny_m, alpha_m, gamma_m,
    reverse, rest,
):  # fmt: skip  # pragma: no cover (compiled)
    """:func:`flank_block` written for numba."""
    A, D, n1 = arm_f.shape
    for i in range(A):
        im = A - 1 - i
        r = rest[i]
        for d in range(D):
            dm = (D - d) % D
            for j in range(n1):
                block[0, i, d, j] = bl_f[i, d, j]
                block[1, i, d, j] = arm_f[i, d, j]
                block[2, i, d, j] = nx_f[i, d, j]
                block[3, i, d, j] = ny_f[i, d, j]
                block[4, i, d, j] = alpha_f[i, d, j]
                block[5, i, d, j] = gamma_f[i, d, j]
            for j in range(n1):
                jm = (n1 - j) % n1
                o = n1 + j
                b = reverse[i, d, j] - r
                arm = arm_m[im, dm, jm]
                a = alpha_m[im, dm, jm]
                g = gamma_m[im, dm, jm]
                usable = (
                    np.isfinite(b)
                    and np.isfinite(arm)
                    and arm >= 0
                    and np.isfinite(a)
                    and np.isfinite(g)
                )
                if usable:
                    block[0, i, d, o] = b
                    block[1, i, d, o] = -arm
                    block[2, i, d, o] = nx_m[im, dm, jm]
                    block[3, i, d, o] = -ny_m[im, dm, jm]
                    block[4, i, d, o] = a
                    block[5, i, d, o] = g
                else:
                    block[0, i, d, o] = np.inf
                    block[1, i, d, o] = -0.0
                    block[2, i, d, o] = 0.0
                    block[3, i, d, o] = 0.0
                    block[4, i, d, o] = 1.0
                    block[5, i, d, o] = 0.0
            for j in range(2 * n1):  # the exponential's argument of dmax_finish
                block[6, i, d, j] = block[4, i, d, j] / block[5, i, d, j] - 1.0
