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
the numba kernel the same algorithm, case by case in one compiled pass: the start at
the single-pin bound, the candidate pins, Newton's method on M(Δφc) = Σ l·F(l·(Δφc −
φbl)⁺) − T (Eqs. 15–18 of [1]) with each pin's force inverted from its approach
(δ = F(α − γ ln F), Eqs. 19–23, Newton in y = ln F as
:func:`cyclomesh.core.hertz.force_from_approach`), without temporaries, skipping the
unloaded pins (about three in four), reusing ln F = y in the slope and updating F = e^y
after a small Newton step by a polynomial instead of a new exponential, and starting
each pin's inversion from the nearer of its last one and its own at the same Newton
step of the crank angle before (``angle_axis``: that angle's steps are nearly the same
ones, so its forces are nearer than the step before while the steps are large; within
one ring only, so a ring's bits do not depend on the rings solved with it). The results
agree with the reference to round-off (tested to 1e-13 relative on both contact laws,
stacks, the compliant disc and the stage, ``tests/core/test_kernel.py``). Any case the
kernel cannot finish (no usable pin, a torque too large, a force past the stiffest
point of the law, no convergence, a jammed pin) is handed to the reference, which
raises its own one-line error, so the errors are those of the NumPy path.

The switch: the environment variable ``CYCLOMESH_KERNEL`` = ``numpy`` (the default) or
``numba`` (needs the ``fast`` extra, ``pip install 'cyclomesh[fast]'``), read at each
call, so worker processes follow the command's environment. Friction (a torque arm
apart from the compatibility arm) always takes the NumPy load sharing; a tabulated
profile deviation the NumPy contact. The default stays NumPy: importing numba and
loading the compiled passes costs a process about a second, more than a short run
takes (README, "The compiled kernel").

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
_WARM_STEPS = 12
"""Newton steps on Δφc whose force inversions start from the case before's (the
neighbouring crank angle of the same ring) at the same step."""


@cache
def _compiled() -> Any:
    """The compiled kernel, or None without numba (imported on first use only)."""
    try:
        import numba
    except ImportError:
        return None
    jit = numba.njit(cache=True, nogil=True, error_model="numpy")
    global _invert_cold, _newton_y, _exp_step  # compiled in place: the kernel calls them
    _exp_step = jit(_exp_step)
    _newton_y = jit(_newton_y)
    _invert_cold = jit(_invert_cold)
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
    residual of ``tol``·δ; at 2e-15 (round-off), one more step makes the root
    independent of the start. A step below √tol (√(tol/100) at round-off) ends it
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
            if exact and resid != 0.0:
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

    The algorithm of :func:`cyclomesh.core.loadsharing.share_load` (same start, same
    candidates, same Newton steps on Δφc, sums in pin order) with three savings that
    leave every converged value at round-off: a pin whose backlash is already above
    the bound cannot lower it (its single-pin rotation is larger), so its logarithm is
    not taken; an unloaded pin (Δφc ≤ φbl) is skipped; and each pin's force inversion
    starts from a nearby solution moved along the tangent, y₀ = y + Δδ/(dδ/dy), which
    Newton's method in y finishes in a step or two (the convex δ(y) puts that start
    right of the root, from where Newton descends monotonically): while the torque
    residual is large, the same pin at the same Newton step of the case before when
    that is the neighbouring crank angle of the same ring (``block``: cases per ring,
    consecutive angles; 1: none), as Δφc's Newton steps move little from one angle to
    the next, else the pin's own last inversion; while the torque residual is above
    1e-3·T the inversions stop at 1e-10·δ (the
    steps that follow square that error away), then the step is taken again with
    every force at round-off, so Δφc follows the reference's Newton steps and stops
    where it stops (the root at round-off, the reference's test).

    Fills ``rotation`` (n_cases) and ``force`` (n_cases, n_pins, zero on entry); returns
    the number of cases it could not finish (then the caller uses the reference). A
    case's bits depend on its ring's cases before it (through the starts, at round-off),
    never on other rings.
    """
    n_cases, n_pins = bl.shape
    tol = TORQUE_TOLERANCE * torque
    floor = ROUND_OFF_TORQUE * torque
    candidates = np.empty(n_pins, np.int64)
    peak = np.empty(n_pins)  # ln F at the stiffest point of the law, α/γ − 1
    last_y = np.empty(n_pins)  # ln F of the pin's last inversion
    last_f = np.empty(n_pins)  # F there [N]
    last_d = np.empty(n_pins)  # its approach [m]
    last_inv = np.empty(n_pins)  # 1/(dδ/dy) there [1/m], 0: none yet
    # each pin's inversion at each of the first Newton steps of the case before
    warm_case = np.full((_WARM_STEPS, n_pins), -1, np.int64)  # that case, -1: none
    warm_y = np.empty((_WARM_STEPS, n_pins))
    warm_f = np.empty((_WARM_STEPS, n_pins))
    warm_d = np.empty((_WARM_STEPS, n_pins))
    warm_inv = np.empty((_WARM_STEPS, n_pins))
    failed = 0
    for k in range(n_cases):
        # start: the rotation at which one pin alone carries T (an upper bound), the pin
        # with the smallest backlash first so that the bound prunes the others early
        first = -1
        smallest = np.inf
        for i in range(n_pins):
            b = bl[k, i]
            if np.isfinite(b) and arm[k, i] > 0.0 and (first < 0 or b < smallest):
                first = i
                smallest = b
        if first < 0:
            failed += 1
            continue
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
            failed += 1
            continue
        n_cand = 0
        for i in range(n_pins):
            b = bl[k, i]
            if np.isfinite(b) and arm[k, i] > 0.0 and b < x:
                candidates[n_cand] = i
                peak[n_cand] = np.nan  # computed when the pin first carries load
                last_inv[n_cand] = 0.0  # no inversion yet
                n_cand += 1
        ok = False
        bad = False
        last = np.inf  # |residual| of the step before (at round-off forces)
        inner = _LOOSE  # the inversions' tolerance: loose while the torque is far off
        before = k - 1 if k % block != 0 else -2  # the case before, of the same ring
        for it in range(_MAX_ITERATIONS):
            moment = 0.0
            slope = 0.0
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
                    if np.isnan(peak[j]):
                        peak[j] = a / g - 1.0
                    converged = False
                    # the start: of this pin's last inversion here and its inversion at
                    # the same Newton step of the case before, the nearer (the smaller
                    # tangent step), moved along its tangent
                    dy = np.inf
                    if last_inv[j] > 0.0:
                        dy = (d - last_d[j]) * last_inv[j]
                        y_s, f_s = last_y[j], last_f[j]
                    if it < _WARM_STEPS and warm_case[it, i] == before:
                        dw = (d - warm_d[it, i]) * warm_inv[it, i]
                        if abs(dw) < abs(dy):
                            dy, y_s, f_s = dw, warm_y[it, i], warm_f[it, i]
                    if dy < np.inf:
                        y0 = y_s + dy
                        if y0 < peak[j]:
                            f0 = _exp_step(f_s, dy, y0)
                            y, f, converged = _newton_y(d, a, g, y0, f0, 8, inner)
                    # the stiffening branch ends at the stiffest point δmax = γ·e^(α/γ − 1)
                    # (ln F = α/γ − 1): a warm start that Newton carried past it (to the
                    # other root) is started again cold; no root below it, or one within
                    # 1e-6 of it in ln F (δ within 1e-12 of δmax), the reference decides
                    # (it raises, or solves a pin that barely fits)
                    if not (converged and (g < 0.0 or y < peak[j] - 1e-6)):
                        y, f, converged = _invert_cold(d, a, g, inner)
                    if not (converged and (g < 0.0 or y < peak[j] - 1e-6)):
                        bad = True
                        break
                    dddf = a - g * (1.0 + y)
                    last_y[j] = y
                    last_f[j] = f
                    last_d[j] = d
                    last_inv[j] = 1.0 / (f * dddf)
                    if it < _WARM_STEPS:
                        warm_case[it, i] = k
                        warm_y[it, i] = y
                        warm_f[it, i] = f
                        warm_d[it, i] = d
                        warm_inv[it, i] = last_inv[j]
                force[k, i] = f
                moment += f * lk
                slope += lk * lk / dddf
            if bad:
                break
            resid = moment - torque
            if inner > _ROUND_OFF and abs(resid) <= _LOOSE_UNTIL * torque:
                inner = _ROUND_OFF  # near the root: this step again, forces to round-off
                continue
            size = abs(resid)
            if size <= floor or (size <= tol and size >= last):  # the reference's test
                ok = True
                break
            last = size
            x = x - (resid / slope if slope > 0.0 else 0.0)
        if not ok:
            failed += 1
            continue
        rotation[k] = x
    return failed
