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

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyclomesh.core.kernel import kernel_name

__all__ = ["compiled", "pin_law", "roller_law"]

FloatArray = NDArray[np.float64]

_MAX_NEWTON = 50
"""Newton steps of one force inversion (as :func:`cyclomesh.core.hertz.force_from_approach`)."""
_ROUND_OFF = 2e-15
"""Relative residual of a converged force inversion (as force_from_approach)."""


def compiled() -> bool:
    """True when ``CYCLOMESH_KERNEL=numba`` selects the compiled laws (read at each call)."""
    return kernel_name() == "numba"


@cache
def _kernels() -> tuple[Any, Any]:
    import numba

    jit = numba.njit(cache=True, nogil=True, error_model="numpy")
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
                    for _ in range(_MAX_NEWTON):
                        e = np.exp(y)
                        resid = e * (a - g * y) - delta
                        if abs(resid) <= _ROUND_OFF * delta:
                            done = True
                            break
                        y = y - resid / (e * (a - g - g * y))
                    if not done:
                        e = np.exp(y)
                        resid = e * (a - g * y) - delta
                        resolution = 4.0 * 2.220446049250313e-16 * abs(y) * abs(e * (a - g - g * y))
                        if not (abs(resid) <= _ROUND_OFF * delta or abs(resid) <= resolution):
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


# --- the whole Newton iteration of one crank angle ------------------------------------


def newton(
    p, law, x: FloatArray, discs: int, jacobian: FloatArray, settings: tuple
) -> NDArray[np.bool_]:
    """:func:`cyclomesh.stage.newton.newton` of the rigid discs' stage (``rigid=False``, no
    compliant disc, a bearing law without a series spring), every crank angle on its own
    in one compiled pass: the potential, gradient and Hessian of
    :func:`cyclomesh.stage.equilibrium._evaluate` (pins, crank bearings, crankshafts,
    end plate) assembled per crank angle on the nonzero columns of ``jacobian`` (∂d/∂x of
    the holes, :func:`~cyclomesh.stage.equilibrium.bearing_jacobian`), the same step, the
    same stretched step of a bearing at zero load, step cap, line search and convergence
    test. ``settings``: the reference's (FORCE_TOLERANCE, _MAX_ITERATIONS, _MAX_HALVINGS,
    _STEP_CAP, *_LINEAR), passed in by the caller (this module is imported by the bearing
    law, which cyclomesh.stage.newton imports). ``x`` (A, m) is overwritten by the
    solution; returns the crank angles the kernel could not finish (the caller solves
    them with the reference, which raises its own error where it fails too).
    """
    force, iterations, halvings, cap, low, high = settings
    A, m = x.shape
    sup = p.supports
    N = p.hx.shape[-1]
    nw = 2 * discs * N if sup is not None and sup.stiffness is not None else 0
    carrier = sup is not None and sup.carrier is not None
    G = np.ascontiguousarray(jacobian)
    nonzero = np.any(G != 0.0, axis=(0, 3))  # (D, N, m): the structure, any crank angle
    count = nonzero.sum(-1)
    cols = np.zeros((*count.shape, max(int(count.max()), 1)), np.int64)
    for d in range(discs):
        for k in range(N):
            cols[d, k, : count[d, k]] = np.flatnonzero(nonzero[d, k])
    failed = np.zeros(A, np.bool_)
    _kernels_newton()(
        x,
        *(np.ascontiguousarray(v) for v in (p.bl, p.arm, p.nx, p.ny, p.alpha, p.gamma, p.dmax)),
        *(np.ascontiguousarray(v) for v in (p.ex, p.ey, p.hx, p.hy)),
        G,
        cols,
        count,
        np.zeros((discs, discs)) if nw == 0 else np.ascontiguousarray(sup.stiffness),
        nw,
        np.zeros(discs) if sup is None else np.ascontiguousarray(sup.fraction, dtype=float),
        float(sup.carrier) if carrier else 0.0,
        carrier,
        np.cos(law.rs.angles),
        0.5 * law.rs.clearance,
        law.rs.constant,
        float(p.torque),
        float(p.scale),
        force * abs(p.torque) / p.scale,
        iterations,
        halvings,
        cap,
        low,
        high,
        failed,
    )
    return failed


@cache
def _kernels_newton() -> Any:
    import numba

    jit = numba.njit(cache=True, nogil=True, error_model="numpy")
    global _evaluate_one, _pin_force, _solve_in_place
    _pin_force = jit(_pin_force)
    _solve_in_place = jit(_solve_in_place)
    _evaluate_one = jit(_evaluate_one)
    return jit(_newton_rows)


def _pin_force(delta, a, g, checked, memo, d, j):  # pragma: no cover (compiled)
    """F of δ = F(α − γ ln F) as :func:`_pin_rows` (γ = 0: δ/α): Newton in y = ln F to a
    residual of 2e-15·δ, started, when this pin's last inversion ``memo[:, d, j]`` (δ, y,
    F) was at an approach within a factor of 2, from that solution moved along its
    tangent (the previous step or trial is near), else as the reference (two fixed-point
    steps from ln(δ/α)). Returns (F, ln F), F = −1 if it cannot; ``checked``: δ lies below
    the stiffest point (δ < dmax), so its test is left out."""
    if g == 0.0:
        return delta / a, 0.0
    if not checked and np.log(delta / g) - a / g >= -1.0:
        return -1.0, 0.0
    d0 = memo[0, d, j]
    if d0 > 0.0 and 0.5 * d0 <= delta <= 2.0 * d0:
        y0, f0 = memo[1, d, j], memo[2, d, j]
        y = y0 - (d0 - delta) / (f0 * (a - g - g * y0))
    else:
        y = np.log(delta / a)
        y = np.log(delta / (a - g * y))
        y = np.log(delta / (a - g * y))
    for _ in range(_MAX_NEWTON):
        e = np.exp(y)
        resid = e * (a - g * y) - delta
        if abs(resid) <= _ROUND_OFF * delta:
            memo[0, d, j], memo[1, d, j], memo[2, d, j] = delta, y, e
            return e, y
        y = y - resid / (e * (a - g - g * y))
    e = np.exp(y)
    resid = e * (a - g * y) - delta
    if abs(resid) <= 4.0 * 2.220446049250313e-16 * abs(y) * abs(e * (a - g - g * y)):
        memo[0, d, j], memo[1, d, j], memo[2, d, j] = delta, y, e
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


def _evaluate_one(
    i,
    x,
    bl,
    arm,
    nx,
    ny,
    alpha,
    gamma,
    dmax,
    ex,
    ey,
    hx,
    hy,
    G,
    cols,
    count,
    kshaft,
    nw,
    frac,
    kcarrier,
    carrier,
    cosines,
    half,
    kn,
    torque,
    L,
    want,
    g,
    H,
    memo,
):  # pragma: no cover (compiled)
    """Potential of crank angle ``i`` at x (m,), with ``want`` its gradient g and Hessian
    H (scaled: rotations × L) as equilibrium._evaluate; returns (energy, status): status
    0 usable, 1 an approach at or past dmax (bad), 2 a pin law that cannot be inverted."""
    m = x.size
    D, P = bl.shape[1], bl.shape[2]
    N = hx.shape[1]
    if want:
        for r in range(m):
            g[r] = 0.0
            for s in range(m):
                H[r, s] = 0.0
    status = 0
    pins = 0.0
    for d in range(D):
        th, ux, uy = x[1 + 3 * d], x[2 + 3 * d], x[3 + 3 * d]
        for j in range(P):
            b = bl[i, d, j]
            if not np.isfinite(b):
                continue
            delta = arm[i, d, j] * (th - b) + nx[i, d, j] * ux + ny[i, d, j] * uy
            if delta <= 0.0:
                continue
            if delta >= dmax[i, d, j]:
                status = 1
                continue
            a, gm = alpha[i, d, j], gamma[i, d, j]
            f, logf = _pin_force(delta, a, gm, np.isfinite(dmax[i, d, j]), memo, d, j)
            if f < 0.0:
                return 0.0, 2
            if f > 0.0:
                if gm == 0.0:
                    logf = np.log(f)
                pins += 0.5 * f * f * (a - 0.5 * gm - gm * logf)
                if want:
                    k = 1.0 / (a - gm * (1.0 + logf))
                    v0, v1, v2 = arm[i, d, j] / L, nx[i, d, j], ny[i, d, j]
                    r0 = 1 + 3 * d
                    g[r0] += f * v0
                    g[r0 + 1] += f * v1
                    g[r0 + 2] += f * v2
                    H[r0, r0] += k * v0 * v0
                    H[r0, r0 + 1] += k * v0 * v1
                    H[r0, r0 + 2] += k * v0 * v2
                    H[r0 + 1, r0 + 1] += k * v1 * v1
                    H[r0 + 1, r0 + 2] += k * v1 * v2
                    H[r0 + 2, r0 + 2] += k * v2 * v2
    if want:
        for d in range(D):
            r0 = 1 + 3 * d
            H[r0 + 1, r0] = H[r0, r0 + 1]
            H[r0 + 2, r0] = H[r0, r0 + 2]
            H[r0 + 2, r0 + 1] = H[r0 + 1, r0 + 2]
        g[0] -= torque / L
    energy = pins - torque * x[0]
    base = 1 + 3 * D
    beta = x[base + nw] if carrier else 0.0
    p = 10.0 / 9.0
    bearings = 0.0
    for d in range(D):
        rot = (x[1 + 3 * d] - x[0]) - frac[d] * beta
        for k in range(N):
            wx = x[base + 2 * (d * N + k)] if nw else 0.0
            wy = x[base + 2 * (d * N + k) + 1] if nw else 0.0
            dx = x[2 + 3 * d] + rot * (-hy[i, k]) + ex[i, d, k] - wx
            dy = x[3 + 3 * d] + rot * hx[i, k] + ey[i, d, k] - wy
            s = np.hypot(dx, dy)
            B = 0.0
            kb = 0.0
            ub = 0.0
            for j in range(cosines.size):
                cj = cosines[j]
                dj = s * cj - half
                if dj > 0.0:
                    root = dj ** (1.0 / 9.0)
                    q = dj * root
                    B += kn * q * cj
                    kb += p * kn * root * cj * cj
                    ub += kn * (dj * q)
            bearings += ub / (p + 1.0)
            if not want:
                continue
            if s > 0.0:
                cx, cy, secant = dx / s, dy / s, B / s
            else:
                cx, cy, secant = 1.0, 0.0, kb
            fx, fy = B * cx, B * cy
            kxx = kb * cx * cx + secant * cy * cy
            kyy = kb * cy * cy + secant * cx * cx
            kxy = (kb - secant) * cx * cy
            for u in range(count[d, k]):
                r = cols[d, k, u]
                g0, g1 = G[i, d, k, 0, r], G[i, d, k, 1, r]
                g[r] += fx * g0 + fy * g1
                ka = kxx * g0 + kxy * g1
                kc = kxy * g0 + kyy * g1
                for v in range(count[d, k]):
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
                        kw += kshaft[d, e] * x[base + 2 * (e * N + k) + c]
                    shafts += x[base + 2 * (d * N + k) + c] * kw
                    if want:
                        r = base + 2 * (d * N + k) + c
                        g[r] += kw
                        for e in range(D):
                            H[r, base + 2 * (e * N + k) + c] += kshaft[d, e]
        energy = energy + 0.5 * shafts
    if carrier:
        energy = energy + 0.5 * kcarrier * beta * beta
        if want:
            g[base + nw] += kcarrier * beta / L
            H[base + nw, base + nw] += kcarrier / (L * L)
    return energy, status


def _newton_rows(
    x,
    bl,
    arm,
    nx,
    ny,
    alpha,
    gamma,
    dmax,
    ex,
    ey,
    hx,
    hy,
    G,
    cols,
    count,
    kshaft,
    nw,
    frac,
    kcarrier,
    carrier,
    cosines,
    half,
    kn,
    torque,
    L,
    tol,
    iterations,
    halvings,
    cap,
    low,
    high,
    failed,
):  # pragma: no cover (compiled)
    """:func:`newton` written for numba: each crank angle's iteration of
    cyclomesh.stage.newton.newton (rigid=False) to the end, on its own."""
    A, m = x.shape
    D = bl.shape[1]
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
    trial = np.zeros(m)
    step = np.zeros(m)
    memo = np.zeros((3, D, bl.shape[2]))  # each pin's last inversion (δ, y, F)
    for i in range(A):
        memo[0] = 0.0
        xi = x[i].copy()
        previous = np.inf
        extended = False
        linear = False
        ok_angle = False
        for _ in range(iterations):
            energy, status = _evaluate_one(
                i,
                xi,
                bl,
                arm,
                nx,
                ny,
                alpha,
                gamma,
                dmax,
                ex,
                ey,
                hx,
                hy,
                G,
                cols,
                count,
                kshaft,
                nw,
                frac,
                kcarrier,
                carrier,
                cosines,
                half,
                kn,
                torque,
                L,
                True,
                g,
                H,
                memo,
            )
            if status == 2:
                break
            done = True
            res = 0.0
            for r in range(m):
                noise = 0.0
                for s in range(m):
                    xs = abs(xi[s]) * L if rot[s] else abs(xi[s])
                    noise += abs(H[r, s]) * xs
                noise *= 16.0 * eps
                if not (abs(g[r]) <= max(tol, noise)):
                    done = False
                res = max(res, abs(g[r]))
            ratio = res > low * previous and res < high * previous
            stretch = (not extended) and ratio and linear
            linear = ratio and not extended
            previous = res
            if done:
                ok_angle = True
                break
            diag = 0.0
            for r in range(m):
                diag = max(diag, abs(H[r, r]))
            diag = max(diag, 1e-300)
            for r in range(m):
                H[r, r] += 1e-14 * diag
            if not _solve_in_place(H, g, step):
                break  # singular: the reference's LinAlgError, or its own way out
            slope = 0.0
            for r in range(m):
                slope += g[r] * step[r]
            if not slope < 0.0:
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
            tiny = -slope <= 1e-13 * max(abs(energy), 1e-300)
            moved = False
            for _h in range(halvings):
                for r in range(m):
                    trial[r] = xi[r] + (step[r] * t / L if rot[r] else step[r] * t)
                e_t, st = _evaluate_one(
                    i,
                    trial,
                    bl,
                    arm,
                    nx,
                    ny,
                    alpha,
                    gamma,
                    dmax,
                    ex,
                    ey,
                    hx,
                    hy,
                    G,
                    cols,
                    count,
                    kshaft,
                    nw,
                    frac,
                    kcarrier,
                    carrier,
                    cosines,
                    half,
                    kn,
                    torque,
                    L,
                    False,
                    gt,
                    Ht,
                    memo,
                )
                if st == 2:
                    break
                if st == 0 and (e_t <= energy + 1e-4 * t * slope or tiny):
                    for r in range(m):
                        xi[r] = trial[r]
                    moved = True
                    break
                extended = False
                t = 1.0 if t > 1.0 else 0.5 * t
            if not moved:
                break
        if ok_angle:
            x[i] = xi
        else:
            failed[i] = True


def rigid_newton(p, x: FloatArray, discs: int, settings: tuple) -> NDArray[np.bool_]:
    """:func:`cyclomesh.stage.newton.newton` of the rigid stage (``rigid=True``: θ_d = c,
    u = 0, the one unknown c), every crank angle on its own in one compiled pass, the
    reference's step, line search and convergence test. ``x`` (A, 1 + 3D) is overwritten
    by the solution; returns the crank angles the kernel could not finish. ``settings``
    as :func:`newton`'s."""
    force, iterations, halvings, cap = settings[:4]
    failed = np.zeros(x.shape[0], np.bool_)
    _kernels_newton()  # compiles _pin_force
    _kernels_rigid()(
        x,
        *(np.ascontiguousarray(v) for v in (p.bl, p.arm, p.alpha, p.gamma, p.dmax)),
        float(p.torque),
        float(p.scale),
        force * abs(p.torque) / p.scale,
        iterations,
        halvings,
        cap,
        failed,
    )
    return failed


@cache
def _kernels_rigid() -> Any:
    import numba

    jit = numba.njit(cache=True, nogil=True, error_model="numpy")
    global _rigid_one
    _rigid_one = jit(_rigid_one)
    return jit(_rigid_rows)


def _rigid_one(i, x, bl, arm, alpha, gamma, dmax, torque, L, memo):  # pragma: no cover (compiled)
    """(energy, ∂/∂(cL), ∂²/∂(cL)², status) of the rigid stage at crank angle ``i``; status
    as :func:`_evaluate_one`."""
    D, P = bl.shape[1], bl.shape[2]
    pins = 0.0
    g = 0.0
    h = 0.0
    status = 0
    for d in range(D):
        th = x[1 + 3 * d]
        for j in range(P):
            b = bl[i, d, j]
            if not np.isfinite(b):
                continue
            delta = arm[i, d, j] * (th - b)
            if delta <= 0.0:
                continue
            if delta >= dmax[i, d, j]:
                status = 1
                continue
            a, gm = alpha[i, d, j], gamma[i, d, j]
            f, logf = _pin_force(delta, a, gm, np.isfinite(dmax[i, d, j]), memo, d, j)
            if f < 0.0:
                return 0.0, 0.0, 0.0, 2
            if f > 0.0:
                if gm == 0.0:
                    logf = np.log(f)
                pins += 0.5 * f * f * (a - 0.5 * gm - gm * logf)
                v = arm[i, d, j] / L
                g += f * v
                h += v * v / (a - gm * (1.0 + logf))
    return pins - torque * x[0], g - torque / L, h, status


def _rigid_rows(
    x, bl, arm, alpha, gamma, dmax, torque, L, tol, iterations, halvings, cap, failed
):  # pragma: no cover (compiled)
    """:func:`rigid_newton` written for numba."""
    A, m = x.shape
    D = bl.shape[1]
    eps = 2.220446049250313e-16
    trial = np.zeros(m)
    memo = np.zeros((3, D, bl.shape[2]))  # each pin's last inversion (δ, y, F)
    for i in range(A):
        memo[0] = 0.0
        xi = x[i].copy()
        ok_angle = False
        for _ in range(iterations):
            energy, g, h, status = _rigid_one(i, xi, bl, arm, alpha, gamma, dmax, torque, L, memo)
            if status == 2:
                break
            xs = abs(xi[0]) * L
            for d in range(D):
                xs += abs(xi[1 + 3 * d]) * L
            if abs(g) <= max(tol, 16.0 * eps * abs(h) * xs):
                ok_angle = True
                break
            diag = max(abs(h), 1e-300)
            h = h + 1e-14 * diag
            step = -g / h
            slope = g * step
            if not slope < 0.0:
                step = -g / diag
                slope = g * step
            t = 1.0
            reach = abs(step)
            if reach * t > cap:
                t = cap / (reach if reach > 0 else 1.0)
            tiny = -slope <= 1e-13 * max(abs(energy), 1e-300)
            moved = False
            for _h in range(halvings):
                move = step * t / L
                for r in range(m):
                    trial[r] = xi[r]
                trial[0] = xi[0] + move
                for d in range(D):
                    trial[1 + 3 * d] = xi[1 + 3 * d] + move
                e_t, _g, _h2, st = _rigid_one(
                    i, trial, bl, arm, alpha, gamma, dmax, torque, L, memo
                )
                if st == 2:
                    break
                if st == 0 and (e_t <= energy + 1e-4 * t * slope or tiny):
                    for r in range(m):
                        xi[r] = trial[r]
                    moved = True
                    break
                t = 1.0 if t > 1.0 else 0.5 * t
            if not moved:
                break
        if ok_angle:
            x[i] = xi
        else:
            failed[i] = True
