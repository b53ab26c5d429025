"""The compiled pin-step (numba) beside the NumPy reference, and the switch.

With ``CYCLOMESH_KERNEL=numba`` every step of the pin-step runs compiled, each the
reference's algorithm in one pass over rings, crank angles and pins without
temporaries: the unloaded contact (:func:`cyclomesh.core.contact.unloaded_contact`,
undeviated profiles), the compliance (:func:`cyclomesh.core.ltca.pin_compliance`) and the
stresses (:func:`cyclomesh.core.fields.contact_stresses`) through
:mod:`cyclomesh.core.kernel_contact`, and the load sharing here. The contact rotations
come out bit for bit (NumPy takes their arccos and arctangents between two compiled
passes, as its SIMD functions differ from the C library's in the last bit, and one bit
of a rotation moves the pin loads by about 1e-11); the rest agrees to round-off.

:func:`share_load` is the one load-sharing entry of the solvers (the one-disc chain
:func:`cyclomesh.core.ltca.ltca`, the stacks of :mod:`cyclomesh.drive.mesh`, the start of
the compliant disc :func:`cyclomesh.core.discbody.share_load_coupled`): with the NumPy
kernel it is :func:`cyclomesh.core.loadsharing.share_load` itself (the reference), with
the numba kernel the same equations, case by case in one compiled pass: Newton's
method on M(Δφc) = Σ l·F(l·(Δφc − φbl)⁺) − T (Eqs. 15–18 of [1]) to the root at
round-off with the reference's test (so that the start does not matter), with each
pin's force inverted from its approach (δ = F(α − γ ln F), Eqs. 19–23, Newton in
y = ln F as :func:`cyclomesh.core.hertz.force_from_approach`), without temporaries,
skipping the unloaded pins (about three in four), reusing ln F = y in the slope and
updating F = e^y after a small Newton step by a polynomial instead of a new
exponential. Each angle after a ring's first (``angle_axis``) starts at the roots of
the angles before, extrapolated, with Halley's steps (2.1–2.3 evaluations of M per
angle on Table 1 at 0.1° instead of 7–8) over the pins within its reach (about 12 of
40), and each pin's inversion from the pin's last one, moved along its tangent (within
one ring only, so a ring's bits do not depend on the rings solved with it). Where the
roots before are too far apart to extrapolate (a tolerance study's 10° step) and at a
ring's first angle, the start is the root of the pins taken as linear springs at
their secant compliance (3 evaluations of M instead of 4 at 10°, 3–4 instead of 7–8
at a first angle); the reference's start (the single-pin bound, its candidate pins,
Newton's steps) is the fallback. The results agree with the reference to round-off
(tested to 1e-13 relative on both contact laws, stacks, the compliant disc and the
stage, ``tests/core/test_kernel.py``). Any case the
kernel cannot finish (no usable pin, a torque too large, a force past the stiffest
point of the law, no convergence, a jammed pin) is handed to the reference, which
raises its own one-line error, so the errors are those of the NumPy path.

The switch: the environment variable ``CYCLOMESH_KERNEL`` = ``numpy`` (the default) or
``numba`` (needs the ``fast`` extra, ``pip install 'cyclomesh[fast]'``), read at each
call, so worker processes follow the command's environment. Friction (a torque arm
apart from the compatibility arm) always takes the NumPy load sharing; a tabulated
profile deviation the NumPy contact. The default stays NumPy: importing numba and
loading the compiled passes costs a process about a second, more than a short run
takes (docs/speed.md, "The compiled kernel").

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import os
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core import loadsharing
from cyclomesh.core.jit import njit
from cyclomesh.core.loadsharing import ROUND_OFF_TORQUE, TORQUE_TOLERANCE
from cyclomesh.exceptions import CyclomeshError

__all__ = ["KERNELS", "ENV_VAR", "kernel_name", "share_load"]

FloatArray = NDArray[np.float64]

ENV_VAR = "CYCLOMESH_KERNEL"
"""Environment variable that selects the kernel."""
KERNELS = ("numpy", "numba")
"""Kernel names: the NumPy reference (default) and the compiled numba kernel."""


def kernel_name() -> str:
    """The selected kernel, from ``CYCLOMESH_KERNEL`` (``numpy`` when unset).

    Raises
    ------
    CyclomeshError
        (a ``ValueError``) One line naming the variable and its values, for any other
        value, or ``numba`` without numba installed (the fix: the ``fast`` extra); the
        CLI shows it as a refusal (exit 2), not as an internal error.
    """
    name = os.environ.get(ENV_VAR, "numpy").strip().lower() or "numpy"
    if name not in KERNELS:
        raise CyclomeshError(
            f"{ENV_VAR}={name!r}: expected one of {', '.join(KERNELS)}; unset it for numpy"
        )
    if name == "numba" and _compiled() is None:
        raise CyclomeshError(
            f"{ENV_VAR}=numba needs numba: pip install 'cyclomesh[fast]' (or unset {ENV_VAR})"
        )
    return name


def share_load(
    backlash: ArrayLike,
    moment_arm: ArrayLike,
    alpha: ArrayLike,
    gamma: ArrayLike,
    torque: float,
    angle_axis: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """:func:`cyclomesh.core.loadsharing.share_load` (frictionless) on the selected kernel.

    Parameters and returns as there: φbl [rad], l [m], α, γ [m/N] of shape
    (..., n_pins), T [N·m]; Δφc (...) [rad] and the pin loads (..., n_pins) [N].
    ``angle_axis``: the last leading axis is one ring's crank angles in order, whose
    neighbours the numba kernel starts its force inversions from (the cases of one
    ring, never across rings, so a ring's bits do not depend on its batch); False:
    every case on its own. The NumPy kernel ignores it.
    """
    if kernel_name() == "numpy":
        return loadsharing.share_load(backlash, moment_arm, alpha, gamma, torque)
    bl, arm, a, g = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (backlash, moment_arm, alpha, gamma))
    )
    lead, n_pins = bl.shape[:-1], bl.shape[-1]
    flat = [np.ascontiguousarray(v).reshape(-1, n_pins) for v in (bl, arm, a, g)]
    rotation = np.empty(flat[0].shape[0])
    force = np.zeros(flat[0].shape)
    block = lead[-1] if angle_axis and lead else 1
    failed = _compiled()(*flat, float(torque), max(block, 1), rotation, force)
    if failed:  # the reference raises its one-line error (or solves the case)
        return loadsharing.share_load(backlash, moment_arm, alpha, gamma, torque)
    return rotation.reshape(lead), force.reshape(*lead, n_pins)


_MAX_ITERATIONS = 100
"""Newton steps on Δφc before a case is handed to the reference (as loadsharing's)."""
_MAX_NEWTON = 50
"""Newton steps of one force inversion (as :func:`cyclomesh.core.hertz.force_from_approach`)."""
_ROUND_OFF = 2e-15
"""Relative residual of a converged force inversion (as force_from_approach)."""
_LOOSE = 1e-10
"""Relative residual of the force inversions while the torque residual is above
:data:`_LOOSE_UNTIL`·T: Newton's steps there are far from the root, and an error of
1e-10 in their forces is squared away by the steps that follow."""
_LOOSE_UNTIL = 1e-3
_WARM_LOOSE = 1e-7
"""Relative residual of the force inversions of a warm start's first evaluation of M
(:func:`_secant_start`'s start is about 5e-4·T off the root: an error of 1e-7 in its
forces moves Halley's step by about that much, which the next step, at round-off
forces, takes away: three evaluations a case as with forces at round-off, with fewer
Newton steps in the first); the evaluations after it are at round-off."""
_WARM_REDO = 1e-9
"""A warm start's first evaluation with a torque residual below this (relative to T) is
taken again at round-off forces instead of stepping on its loose ones."""


@cache
def _compiled() -> Any:
    """The compiled kernel, or None without numba (imported on first use only)."""
    try:
        jit = njit()
    except ImportError:
        return None
    global _invert_cold, _newton_y, _exp_step  # compiled in place: the kernel calls them
    global _warm_start, _bounded_start, _solve_case, _secant_start, _secant_root, _usable
    _usable = jit(_usable)
    _exp_step = jit(_exp_step)
    _secant_root = jit(_secant_root)
    _secant_start = jit(_secant_start)
    _newton_y = jit(_newton_y)
    _invert_cold = jit(_invert_cold)
    _warm_start = jit(_warm_start)
    _bounded_start = jit(_bounded_start)
    _solve_case = jit(_solve_case)
    return jit(_share_load_rows)


def _invert_cold(d, a, g, tol):  # pragma: no cover (compiled)
    """y = ln F of δ = F(α − γ ln F) as :func:`cyclomesh.core.hertz.force_from_approach`:
    two fixed-point steps from ln(δ/α), then Newton to a residual of ``tol``·δ; returns
    (y, F, converged)."""
    y = np.log(d / a)
    y = np.log(d / (a - g * y))
    y = np.log(d / (a - g * y))
    return _newton_y(d, a, g, y, np.exp(y), _MAX_NEWTON, tol)


def _newton_y(d, a, g, y, f, steps, tol):  # pragma: no cover (compiled)
    """Newton's method in y = ln F on δ = e^y(α − γ y) from ``y`` (``f`` = e^y) to a
    residual of ``tol``·δ; at 2e-15 (round-off), one more step where the residual is
    above :data:`_EXACT`·δ (two units in the last place), which brings F to round-off (a
    residual below that leaves F within about two units in its last place of the root,
    about 2e-15 of the largest pin load from the reference's: within the kernel's 1e-13,
    and 10 % of the load sharing's time spared). A step below √tol (√(tol/100) at round-off) ends it
    unchecked: Newton's error after a step s is about (δ''/2δ')·s² ≈ s²/2 (δ'' ≈ δ' on
    the stiffening branch), so the residual is below tol·δ without another pass (at
    round-off, 100 times below). After a step s, e^y is
    updated as F·e^(−s) (:func:`_exp_step`, a polynomial for small steps): F then
    differs from e^y by a few units in its last place, which moves the converged force
    by a fraction of that (the residual is taken with F itself: F(α − γ y) = δ holds
    to round-off, and y enters only through γ y, γ/(α − γ(1 + y)) ≈ 1/15 of F's
    weight). Returns (y, F, converged)."""
    exact = tol <= _ROUND_OFF
    for _ in range(steps):
        resid = f * (a - g * y) - d
        if abs(resid) <= tol * d:
            if exact and abs(resid) > _EXACT * d:
                step = resid / (f * (a - g - g * y))
                y = y - step
                f = _exp_step(f, -step, y)
            return y, f, True
        step = resid / (f * (a - g - g * y))
        y = y - step
        f = _exp_step(f, -step, y)
        if step * step <= (0.01 * tol if exact else tol):
            return y, f, True
    return y, 0.0, False


_EXACT = 4.4e-16
"""Relative residual of a force inversion at round-off below which :func:`_newton_y`
takes no further step (two units in the last place of δ)."""
_SMALL_STEP = 1e-3
"""Largest |s| for which e^s is taken as its Taylor polynomial to s⁵ (remainder s⁶/720
≤ 1.4e-21, below the round-off of the product)."""
_SIXTH, _TWENTY_FOURTH, _ONE_20TH = 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0
"""The polynomial's coefficients, multiplied (a quotient by 120 would be a division,
10–20 cycles, in the chain of every Newton step)."""


def _exp_step(f, s, y):  # pragma: no cover (compiled)
    """e^y from f = e^(y − s): f·(1 + s + s²/2 + … + s⁵/120) for |s| ≤ :data:`_SMALL_STEP`
    (a few units in the last place of F), else exp(y); the polynomial in Estrin's form
    (two independent halves in s², a shorter chain of dependent operations than
    Horner's)."""
    if abs(s) <= _SMALL_STEP:
        s2 = s * s
        return f * ((1.0 + s) + s2 * ((0.5 + s * _SIXTH) + s2 * (_TWENTY_FOURTH + s * _ONE_20TH)))
    return np.exp(y)


def _share_load_rows(bl, arm, alpha, gamma, torque, block, rotation, force):  # pragma: no cover
    """Load sharing of every case (row), written for numba (plain loops, scalars).

    The algorithm of :func:`cyclomesh.core.loadsharing.share_load`: Newton's method on
    Δφc, sums in pin order, run to the root at round-off with the reference's test
    (:data:`cyclomesh.core.loadsharing.ROUND_OFF_TORQUE`), so that its result does not
    depend on the start. The first case of a ring (``block``: cases per ring, consecutive
    crank angles; 1: every case on its own) starts as the reference, at the single-pin
    bound with its candidate pins (:func:`_bounded_start`); each case after it at the
    root of the crank angle before (:func:`_warm_start`), a few Newton steps from its own
    (from the left of the root the convex M's first tangent step lands right of it, from
    where Newton descends as usual). A warm start that cannot finish (no pin loaded
    there, a force past the stiffest point of the law, no convergence) is started again
    at the bound. Each pin's force inversion starts from the pin's last one (this case's
    Newton step before, or the case before's last), moved along its tangent
    (:func:`_solve_case`). Where the roots before are not smooth enough to extrapolate
    (their third difference above :data:`_SMOOTH` of the root, as at a 10° crank step)
    and at a ring's first case, the start is instead :func:`_secant_start`'s, from the
    case's own backlashes (Newton's first evaluation then with forces to 1e-7, the
    others at round-off); the bound is the fallback of both. Within one ring only: a
    ring's bits depend on its cases before it (at round-off), never on other rings.

    Fills ``rotation`` (n_cases) and ``force`` (n_cases, n_pins, zero on entry); returns
    the number of cases it could not finish (then the caller uses the reference).
    """
    n_cases, n_pins = bl.shape
    candidates = np.empty(n_pins, np.int64)
    last_y = np.empty(n_pins)  # ln F of each pin's last inversion
    last_f = np.empty(n_pins)  # F there [N]
    last_d = np.empty(n_pins)  # its approach [m]
    last_inv = np.zeros(n_pins)  # 1/(dδ/dy) there [1/m], 0: none yet
    order = np.empty(n_pins, np.int64)  # the secant start's candidates by backlash
    secant = np.empty(n_pins)  # their secant compliances α − γ·ŷ [m/N]
    failed = 0
    solved_before = False  # the case before, of the same ring, was solved here
    streak = 0
    for k in range(n_cases):
        if k % block == 0:  # a new ring: nothing to start from
            last_inv[:] = 0.0
            solved_before = False
            streak = 0
        warm = True  # first near the root, then (if that fails) from the bound
        smooth = False
        if not solved_before:
            streak = 0
        after = solved_before
        solved_before = False
        for _ in range(2):
            if warm:
                if after:  # the roots before, extrapolated, and the pins within reach
                    n_cand, x, reach = _warm_start(k, bl, arm, rotation, candidates, streak)
                    # the quadratic extrapolation's error at the case before (the roots'
                    # third difference): below _SMOOTH the extrapolation is the better start
                    smooth = streak >= 4 and abs(
                        (rotation[k - 1] - rotation[k - 4])
                        - 3.0 * (rotation[k - 2] - rotation[k - 3])
                    ) <= _SMOOTH * abs(x)
                else:  # a ring's first case: every usable pin
                    n_cand, x, reach = _usable(k, bl, arm, candidates), np.nan, np.inf
                if n_cand > 0 and not smooth:
                    x = _secant_start(
                        k, x, reach, candidates, n_cand, bl, arm, alpha, gamma, torque,
                        order, secant, last_y, last_f, last_d, last_inv
                    )  # fmt: skip
                if not x == x:  # no secant start: from the bound
                    warm = False
            if not warm:
                n_cand, x = _bounded_start(k, bl, arm, alpha, gamma, torque, candidates)
                reach = np.inf
            if n_cand == 0:
                break
            x, solved = _solve_case(
                k, x, candidates, n_cand, bl, arm, alpha, gamma, torque, warm, not smooth,
                last_y, last_f, last_d, last_inv, force
            )  # fmt: skip
            # a root beyond the warm start's reach may load a pin it left out
            solved = solved and x <= reach
            if solved:
                rotation[k] = x
                solved_before = True
                streak += 1
                break
            if not warm:
                break
            warm = False  # the warm start failed: again from the bound
            force[k, :] = 0.0
        if not solved_before:
            failed += 1
    return failed


def _warm_start(k, bl, arm, rotation, candidates, streak):  # pragma: no cover (compiled)
    """The start of case ``k`` from the ``streak`` (≥ 1) cases solved just before it in
    its ring: their roots extrapolated to it (constant, linear or quadratic in the case
    index, as for evenly spaced crank angles; a residual of about 1e-8·T at a 0.1° step
    on the Table 1 pair; any start reaches the same root), and as candidates the usable
    pins whose backlash lies below the reach x₀ + |x₀|/2 + 4|x₀ − x_(k−1)| (about 12 of
    40 pins on Table 1 at 0.1°, instead of every usable pin; the others cannot carry
    load at a root below the reach, which the caller checks, starting the case again
    from the bound if the root lies beyond it); returns (number of candidates, start
    Δφc [rad], reach [rad])."""
    if streak >= 3:
        x = 3.0 * (rotation[k - 1] - rotation[k - 2]) + rotation[k - 3]
    elif streak >= 2:
        x = 2.0 * rotation[k - 1] - rotation[k - 2]
    else:
        x = rotation[k - 1]
    reach = x + _REACH * abs(x) + 4.0 * abs(x - rotation[k - 1])
    n_cand = 0
    for i in range(bl.shape[1]):
        if bl[k, i] < reach and arm[k, i] > 0.0:  # (a NaN or infinite backlash: not)
            candidates[n_cand] = i
            n_cand += 1
    return n_cand, x, reach


_SMOOTH = 1e-2
"""Largest third difference of a ring's roots before a case, relative to the root, at
which the case starts from their extrapolation (:func:`_warm_start`; about 1e-8·T off
the root at a 0.1° crank step) rather than from :func:`_secant_start` (about 5e-4·T
off, whatever the step; the extrapolation about 1e-1·T off at 10°)."""
_REACH = 0.5
"""The warm start's reach beyond its start, relative to the start (:func:`_warm_start`)."""


def _secant_start(
    k, x, reach, candidates, n_cand, bl, arm, alpha, gamma, torque,
    order, secant, last_y, last_f, last_d, last_inv
):  # fmt: skip  # pragma: no cover (compiled)
    """A start of case ``k`` from its own backlashes: each candidate pin taken as the
    linear spring F = δ/(α − γ·ŷ) with the secant compliance of the law (Eqs. 19–23 of
    [1]) at ŷ = ln F, the torque balance (Eqs. 15–18) of those springs solved exactly
    (piecewise linear in Δφc, :func:`_secant_root`), first with one ŷ for every pin (a
    quarter of T on the longest moment arm), then with each loaded pin's own ŷ = ln F of
    the first solve (one fixed-point step of F = δ/(α − γ ln F)). On Table 1 with the
    pin errors of ``examples/tolerance.toml`` its torque residual is about 3e-4·T
    (median, 2e-3·T at most, at any crank angle: it depends on the case alone; the
    extrapolated roots of the cases before, ``x``, about 1e-1·T at a 10° step), so
    Newton's method takes a step or two fewer (3 evaluations of M a case instead of 4).
    Each pin loaded at the first solve gets that point of its law as its last inversion
    (``last_*``: δ = F(α − γ ln F) exactly there), from which :func:`_solve_case`
    starts its inversion along the tangent. Returns the start (``x`` where the springs
    would load a pin beyond ``reach``, outside the candidates, or the law's stiffest
    point is passed; any start reaches the same root)."""
    longest = 0.0  # ŷ: a quarter of T on the longest arm (the step below corrects it)
    for j in range(n_cand):
        longest = max(longest, arm[k, candidates[j]])
    mean_y = np.log(torque / (4.0 * longest))
    n = 0
    for j in range(n_cand):  # insertion sort of the candidates by backlash
        i = candidates[j]
        b = bl[k, i]
        m = n
        while m > 0 and bl[k, order[m - 1]] > b:
            order[m] = order[m - 1]
            m -= 1
        order[m] = i
        n += 1
    for j in range(n):
        i = order[j]
        c = alpha[k, i] - gamma[k, i] * mean_y
        if not c > 0.0:
            return x
        secant[i] = c
    first, active = _secant_root(k, order, n, bl, arm, secant, torque)
    if not first < reach:
        return x
    for j in range(active):  # each loaded pin's own ln F, the law's point there
        i = order[j]
        a, g = alpha[k, i], gamma[k, i]
        if g == 0.0:
            continue
        f = arm[k, i] * (first - bl[k, i]) / secant[i]
        if not f > 0.0:
            continue
        y = np.log(f)
        if g > 0.0 and not y < a / g - 1.0 - 1e-6:
            return x
        c = a - g * y
        secant[i] = c
        last_y[i] = y
        last_f[i] = f
        last_d[i] = f * c
        last_inv[i] = 1.0 / (f * (c - g))
    second, active = _secant_root(k, order, n, bl, arm, secant, torque)
    return second if second < reach else first


def _secant_root(k, order, n, bl, arm, secant, torque):  # pragma: no cover (compiled)
    """The root of Σ l²(Δφc − φbl)⁺/c = T over the pins ``order[:n]`` (ascending
    backlash, compliances ``secant``): the pins taken in order until the root of those
    loaded lies below the next one's backlash; returns (root [rad], pins loaded)."""
    slope = 0.0
    offset = 0.0
    x = np.inf
    for j in range(n):
        i = order[j]
        lk = arm[k, i]
        s = lk * lk / secant[i]
        slope += s
        offset += s * bl[k, i]
        x = (torque + offset) / slope
        if j + 1 == n or x <= bl[k, order[j + 1]]:
            return x, j + 1
    return x, n


def _usable(k, bl, arm, candidates):  # pragma: no cover (compiled)
    """The usable pins of case ``k`` (finite backlash, positive moment arm) as its
    candidates; returns their number."""
    n_cand = 0
    for i in range(bl.shape[1]):
        if np.isfinite(bl[k, i]) and arm[k, i] > 0.0:
            candidates[n_cand] = i
            n_cand += 1
    return n_cand


def _bounded_start(k, bl, arm, alpha, gamma, torque, candidates):  # pragma: no cover
    """The reference's start of case ``k``: the rotation at which one pin alone carries T
    (an upper bound of the root), and the pins whose backlash lies below it as the
    candidates; (0, nan) where there is none (the reference raises)."""
    n_pins = bl.shape[1]
    # the pin with the smallest backlash first, so that the bound prunes the others early
    first = -1
    smallest = np.inf
    for i in range(n_pins):
        b = bl[k, i]
        if np.isfinite(b) and arm[k, i] > 0.0 and (first < 0 or b < smallest):
            first = i
            smallest = b
    if first < 0:
        return 0, np.nan
    x = np.inf
    for jj in range(-1, n_pins):
        i = first if jj < 0 else jj
        if jj == first:
            continue
        b, lk = bl[k, i], arm[k, i]
        if not (np.isfinite(b) and lk > 0.0) or b >= x:
            continue  # δ > 0 on the valid branch: its rotation alone is above b ≥ x
        a, g = alpha[k, i], gamma[k, i]
        single = torque / lk
        log_single = np.log(single)
        if g == 0.0 or log_single < a / g - 1.0:
            alone = b + single * (a - g * log_single) / lk
            if alone < x:
                x = alone
    if not np.isfinite(x):
        return 0, np.nan
    n_cand = 0
    for i in range(n_pins):
        b = bl[k, i]
        if np.isfinite(b) and arm[k, i] > 0.0 and b < x:
            candidates[n_cand] = i
            n_cand += 1
    return n_cand, x


def _solve_case(
    k, x, candidates, n_cand, bl, arm, alpha, gamma, torque, warm, loose,
    last_y, last_f, last_d, last_inv, force
):  # fmt: skip  # pragma: no cover (compiled)
    """Newton's method on Δφc of case ``k`` from ``x`` over its candidate pins, to the
    reference's test; returns (Δφc, solved). An unloaded pin (Δφc ≤ φbl) is skipped.
    Each pin's force inversion starts from its last one (``last_*``, per pin, kept
    from case to case), moved along its tangent, y₀ = y + Δδ/(dδ/dy), which Newton's
    method in y finishes in a step or two (the convex δ(y) puts that start right of the
    root, from where Newton descends monotonically); while the torque residual is above
    1e-3·T the inversions stop at 1e-10·δ (the steps that follow square that error
    away), then the step is taken again with every force at round-off. ``warm``: a
    start off the bound (near the root: forces at round-off from the first step on,
    Halley's steps with the curvature of M), which gives up (False) where no pin is
    loaded (no slope)."""
    tol = TORQUE_TOLERANCE * torque
    floor = ROUND_OFF_TORQUE * torque
    last = np.inf  # |residual| of the step before (at round-off forces)
    # the inversions' tolerance: loose while the torque is far off (a warm start is near)
    inner = (_WARM_LOOSE if loose else _ROUND_OFF) if warm else _LOOSE
    for _ in range(_MAX_ITERATIONS):
        moment = 0.0
        slope = 0.0  # dM/dΔφc = Σ l²·dF/dδ
        bend = 0.0  # d²M/dΔφc² = Σ l³·d²F/dδ² (on the loaded pins; 0 at their kinks)
        for j in range(n_cand):
            i = candidates[j]
            gap = x - bl[k, i]
            if gap <= 0.0:  # unloaded pin: no force, no inversion
                force[k, i] = 0.0
                continue
            lk = arm[k, i]
            d = gap * lk
            if d <= 0.0:
                force[k, i] = 0.0
                continue
            a, g = alpha[k, i], gamma[k, i]
            if g == 0.0:
                f = d / a
                dddf = a
            else:
                peak = a / g - 1.0  # ln F at the stiffest point of the law
                converged = False
                if last_inv[i] > 0.0:  # from the pin's last inversion, along its tangent
                    dy = (d - last_d[i]) * last_inv[i]
                    y0 = last_y[i] + dy
                    if y0 < peak:
                        f0 = _exp_step(last_f[i], dy, y0)
                        y, f, converged = _newton_y(d, a, g, y0, f0, 8, inner)
                # the stiffening branch ends at the stiffest point δmax = γ·e^(α/γ − 1)
                # (ln F = α/γ − 1): a warm start that Newton carried past it (to the
                # other root) is started again cold; no root below it, or one within
                # 1e-6 of it in ln F (δ within 1e-12 of δmax), the reference decides
                # (it raises, or solves a pin that barely fits)
                if not (converged and (g < 0.0 or y < peak - 1e-6)):
                    y, f, converged = _invert_cold(d, a, g, inner)
                if not (converged and (g < 0.0 or y < peak - 1e-6)):
                    return x, False
                dddf = a - g * (1.0 + y)
                last_y[i] = y
                last_f[i] = f
                last_d[i] = d
                last_inv[i] = 1.0 / (f * dddf)
            force[k, i] = f
            moment += f * lk
            slope += lk * lk / dddf
            if warm and g != 0.0:  # d²F/dδ² = γ/(F·(dδ/dF)³)
                bend += lk * lk * lk * g / (f * dddf * dddf * dddf)
        resid = moment - torque
        if inner > _ROUND_OFF and abs(resid) <= (_WARM_REDO if warm else _LOOSE_UNTIL) * torque:
            inner = _ROUND_OFF  # near the root: this step again, forces to round-off
            continue
        inner = _ROUND_OFF if warm else inner  # a warm start's first step only is loose
        size = abs(resid)
        if size <= floor or (size <= tol and size >= last):  # the reference's test
            return x, True
        if not slope > 0.0:
            if warm:
                return x, False  # no pin loaded at the start: from the bound instead
            slope = np.inf  # as the reference: no step (it raises after its steps)
        last = size
        # from a warm start Halley's step (cubic: a start 1e-8·T off is at round-off
        # after one step), kept within 2/3 to 2 times Newton's; from the bound Newton's
        h = resid * bend / (2.0 * slope * slope)
        if warm and abs(h) < 0.5:
            x = x - resid / (slope * (1.0 - h))
        else:
            x = x - resid / slope
    return x, False
