"""Load sharing among the pins: compatibility and equilibrium (Eqs. 15–18 of [1]).

Under the torque T the disc turns by Δφc beyond its rest position. Pin i, with unloaded
backlash φbl,i and moment arm l_i, deforms by δi = l_i·(Δφc − φbl,i) when Δφc > φbl,i
(Eqs. 15, 17) and carries Fi = F(δi) from the nonlinear Hertzian law of
:mod:`cyclomesh.core.hertz`. Equilibrium (Eqs. 16, 18) is the scalar equation

    M(Δφc) = Σ l_i·F_i(l_i·(Δφc − φbl,i)⁺) − T = 0.

M is increasing and convex in Δφc (each F is convex in δ, (·)⁺ is convex), so Newton's
method started right of the root decreases monotonically onto it. The start is the
rotation at which any single pin alone would carry T, which bounds the root from above.
The iteration runs to the root at round-off (the paper stops at 1 %): once the torque
residual is below 1e-12·T, Newton's steps go on while they still reduce it, and stop at
a residual of a few units in the last place of T (:data:`ROUND_OFF_TORQUE`) or at the
first step that does not reduce it (the residual's round-off floor, the sum of the pin
moments). From 1e-12·T one step (quadratic convergence) reaches that floor, so the
result no longer depends on the path Newton took: any start gives the same root to
round-off.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.hertz import force_from_approach
from cyclomesh.exceptions import ConvergenceError

__all__ = ["share_load", "Balance", "column_sum", "TORQUE_TOLERANCE", "ROUND_OFF_TORQUE"]

FloatArray = NDArray[np.float64]

TORQUE_TOLERANCE = 1e-12
"""Relative torque residual |Σ F·l − T|/T below which Newton's steps are near the root:
from there they go on to round-off (:data:`ROUND_OFF_TORQUE`, or a step that no longer
reduces the residual)."""
ROUND_OFF_TORQUE = 4.0 * float(np.finfo(float).eps)
"""Relative torque residual |Σ F·l − T|/T at which the root is reached (four units in
the last place of T, about 8.9e-16); a residual within :data:`TORQUE_TOLERANCE`·T that a
Newton step does not reduce ends the iteration as well (the round-off of the sum)."""
_MAX_ITERATIONS = 100


def column_sum(values: FloatArray) -> FloatArray:
    """Sum over the last axis, column after column.

    The candidate pins are padded to the widest case of the batch; numpy's pairwise
    ``sum`` would group the additions by that width, so a ring's result would depend on
    which rings it was solved with. Adding the columns in pin order (padding adds exact
    zeros at the end) gives the same bits for a ring however it is batched.
    """
    total = np.zeros(values.shape[:-1])
    for column in np.moveaxis(values, -1, 0):
        total += column
    return total


class Balance(Protocol):
    """A torque balance whose pin moments depend on the pin loads (a load-dependent
    friction coefficient, a bearing moment from the pin resultant): ``data`` holds per-pin
    arrays (broadcast against the backlash), handed back compacted to the candidate pins
    of the cases still iterating; the call returns the pins' moment Σ F·l'(F) less any
    load-dependent torque the pins also carry, per case, and its derivative with respect
    to Δφ from ``dforce`` = dF/dΔφ (both shape (k,), summed with :func:`column_sum`)."""

    data: Mapping[str, ArrayLike]

    def __call__(
        self, force: FloatArray, dforce: FloatArray, data: Mapping[str, FloatArray]
    ) -> tuple[FloatArray, FloatArray]: ...


def share_load(
    backlash: ArrayLike,
    moment_arm: ArrayLike,
    alpha: ArrayLike,
    gamma: ArrayLike,
    torque: ArrayLike,
    torque_arm: ArrayLike | None = None,
    start: ArrayLike | None = None,
    balance: Balance | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Solve the statically indeterminate load sharing (Eqs. 15–18 of [1]).

    Parameters
    ----------
    backlash : array_like
        φbl,i ≥ 0, shape (..., n_pins) [rad]; +inf for a pin that cannot touch.
    moment_arm : array_like
        l_i ≥ 0 [m], same shape.
    alpha, gamma : array_like
        Compliance coefficients of δ = F(α − γ ln F) [m/N], same shape
        (:func:`cyclomesh.core.hertz.compliance_coefficients`; γ = 0 for a linear spring).
    torque : float or array_like
        T > 0 [N·m], one value or one per case (shape (...)).
    torque_arm : array_like, optional
        Moment arm of each pin's load in the torque balance [m], Σ F_i·l'_i = T, when it
        differs from the compatibility arm ``moment_arm`` (friction at the contacts,
        :func:`cyclomesh.core.friction.torque_arm`); None: l' = l (Eq. 18 of [1]), the
        paper's problem. A pin with l' ≤ 0 (friction-locked) still takes its load from
        compatibility but bounds nothing.
    start : array_like, optional
        Newton's start Δφc, shape (...) [rad] (a nearby solution); None: the single-pin
        bound below. From the left of the root the first tangent step of the convex M
        lands right of it, from where it descends as usual.
    balance : Balance, optional
        A load-dependent torque balance (:class:`Balance`; friction with a lubricated
        coefficient or a crank bearing, :class:`cyclomesh.core.friction.FrictionBalance`),
        solved in the same Newton loop: M(Δφ) = balance(F(Δφ)) − T. ``torque_arm`` then
        only sets the start and the candidate pins (give the smallest arm the pin can
        have).

    Returns
    -------
    rotation : ndarray
        Δφc, shape (...) [rad].
    force : ndarray
        Fc,i, shape (..., n_pins) [N].

    Raises
    ------
    ConvergenceError
        If no pin can carry the torque or Newton's method stalls; its ``case_index``
        attribute is the flat index of the failing case along the leading axes.

    Notes
    -----
    One Newton loop on M(Δφ) = Σ l'_i·F_i(l_i·(Δφ − φbl,i)⁺) − T, dM/dΔφ = Σ l_i·l'_i·dF/dδ.
    It starts at the smallest rotation at which one pin (l' > 0) alone carries T, which
    bounds the root from above when every l' ≥ 0 (always without friction), and only the
    pins whose backlash lies below that start are kept as candidates. With friction the
    few friction-locked pins (l' ≤ 0, near a tip or a tooth-space bottom, where l < μ·m)
    subtract loads that are small because their l is, and can move the root right of the
    start: a case whose root passes the backlash of a pin left out is solved again with
    every usable pin. With l' = l the loop is the paper's, bit for bit (l·l' = l·l = l²).
    The loop runs to the root at round-off (the module's note), not only to 1e-12·T.
    """
    bl = np.asarray(backlash, float)
    arm = np.asarray(moment_arm, float)
    t_arm = arm if torque_arm is None else np.asarray(torque_arm, float)
    bl, arm, t_arm, alpha, gamma = np.broadcast_arrays(
        bl, arm, t_arm, np.asarray(alpha, float), np.asarray(gamma, float)
    )
    lead = bl.shape[:-1]
    n_pins = bl.shape[-1]
    bl, arm, t_arm, alpha, gamma = (v.reshape(-1, n_pins) for v in (bl, arm, t_arm, alpha, gamma))
    torque = np.broadcast_to(np.asarray(torque, float), lead).reshape(-1)
    if not np.all(torque > 0):
        err = ConvergenceError("the torque on the pins is not positive: friction too large")
        err.case_index = int(np.argmin(torque > 0))
        raise err

    usable = np.isfinite(bl) & (arm > 0)
    if not np.all(np.any(usable, axis=-1)):
        bad = int(np.argmin(np.any(usable, axis=-1)))
        err = ConvergenceError(
            "no pin can touch the loaded flanks: the pin errors (errors.radial_um, "
            "errors.pin_radius_um, errors.eccentricity_um) open more clearance than the "
            "teeth can close; lower them (or modification.pin_radius_um)"
        )
        err.case_index = bad
        raise err
    drives = usable & (t_arm > 0)
    if not np.all(np.any(drives, axis=-1)):
        err = ConvergenceError(
            "no pin can carry the torque against its friction: check the coefficients"
        )
        err.case_index = int(np.argmin(np.any(drives, axis=-1)))
        raise err
    # rotation at which pin i alone carries T: an upper bound of the root (pins whose
    # single-pin force lies past the stiffest point of the contact law bound nothing)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        single_force = np.where(drives, torque[:, None] / np.where(drives, t_arm, 1.0), 0.0)
        log_single = np.log(np.where(drives, single_force, 1.0))
        valid = drives & ((gamma == 0) | (log_single < alpha / gamma - 1.0))
        single_delta = single_force * (alpha - gamma * log_single)
        alone = np.where(valid, bl + single_delta / np.where(valid, arm, 1.0), np.inf)
    x = np.min(alone, axis=-1)
    if not np.all(np.isfinite(x)):
        bad = int(np.argmax(~np.isfinite(x)))
        err = ConvergenceError(_too_large(single_force[bad], alpha[bad], gamma[bad], drives[bad]))
        err.case_index = bad
        raise err

    # keep only the pins that can engage below that bound
    candidate = usable & (bl < x[:, None])
    if start is not None:
        x = np.broadcast_to(np.asarray(start, float), lead).reshape(-1).copy()
    data = {}
    if balance is not None:
        data = {
            key: np.broadcast_to(np.asarray(value, float), (*lead, n_pins)).reshape(-1, n_pins)
            for key, value in balance.data.items()
        }
    problem = (bl, arm, t_arm, alpha, gamma, torque)
    x, force = _newton(x, candidate, *problem, balance, data)
    late = np.flatnonzero(np.any(usable & ~candidate & (bl < x[:, None]), axis=-1))
    if late.size:  # friction-locked pins moved the root past a pin left out: all pins
        x[late], force[late] = _newton(
            x[late],
            usable[late],
            *(v[late] for v in problem),
            balance,
            {key: value[late] for key, value in data.items()},
        )
    return x.reshape(lead), force.reshape(*lead, n_pins)


def _newton(
    x: FloatArray,
    candidate: NDArray,
    bl: FloatArray,
    arm: FloatArray,
    t_arm: FloatArray,
    alpha: FloatArray,
    gamma: FloatArray,
    torque: FloatArray,
    balance: Balance | None = None,
    data: Mapping[str, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Newton's method of :func:`share_load` on the candidate pins of each case, from
    ``x`` (shape (k,)); the arrays are (k, n_pins) and ``torque`` (k,), ``data`` the
    balance's per-pin arrays. Returns the rotation and the forces of every pin (0 off
    the candidates)."""
    x = x.copy()
    width = int(np.max(np.sum(candidate, axis=-1)))
    order = np.argsort(~candidate, axis=-1, kind="stable")[:, :width]
    take = np.take_along_axis
    c_bl, c_arm = take(bl, order, -1), take(arm, order, -1)
    c_tarm = c_arm if t_arm is arm else take(t_arm, order, -1)
    c_alpha, c_gamma = take(alpha, order, -1), take(gamma, order, -1)
    c_ok = take(candidate, order, -1)
    c_bl = np.where(c_ok, c_bl, np.inf)
    c_data = {key: take(value, order, -1) for key, value in (data or {}).items()}

    tol = TORQUE_TOLERANCE * torque
    floor = ROUND_OFF_TORQUE * torque
    last = np.full(x.shape, np.inf)  # |residual| of each case's step before
    active = np.ones(x.shape, bool)
    force = np.zeros_like(c_bl)
    for _ in range(_MAX_ITERATIONS):
        xa = x[active]
        ca, ta = c_arm[active], c_tarm[active]
        delta = np.maximum(xa[:, None] - c_bl[active], 0.0) * ca
        f = force_from_approach(delta, c_alpha[active], c_gamma[active])
        force[active] = f
        # dM/dΔφ = Σ l·l'·dF/dδ, dδ/dF = α − γ − γ·ln F on the loaded pins
        engaged = f > 0
        with np.errstate(divide="ignore"):
            log_f = np.log(np.where(engaged, f, 1.0))
        dddf = c_alpha[active] - c_gamma[active] * (1.0 + log_f)
        if balance is None:
            resid = column_sum(f * ta) - torque[active]
            slope = column_sum(np.where(engaged, ca * ta / dddf, 0.0))
        else:
            every = active.all()  # no copies while every case iterates
            moment, slope = balance(
                f,
                np.where(engaged, ca / dddf, 0.0),
                c_data if every else {key: value[active] for key, value in c_data.items()},
            )
            resid = moment - torque[active]
        # at the root: a residual at round-off, or one near the root that the step
        # before did not reduce (the floor of the sum's round-off)
        size = np.abs(resid)
        done = (size <= floor[active]) | ((size <= tol[active]) & (size >= last[active]))
        step = np.where(done, 0.0, resid / np.where(slope > 0, slope, np.inf))
        idx = np.flatnonzero(active)
        last[idx] = size
        x[idx] = xa - step
        active[idx[done]] = False
        if not np.any(active):
            break
    else:
        err = ConvergenceError(
            f"load sharing did not converge: torque residual above "
            f"{TORQUE_TOLERANCE:.0e}·T or still falling after {_MAX_ITERATIONS} Newton steps"
        )
        err.case_index = int(np.flatnonzero(active)[0])
        raise err
    full = np.zeros_like(bl)
    np.put_along_axis(full, order, np.where(c_ok, force, 0.0), -1)
    return x, full


def _too_large(force: FloatArray, alpha: FloatArray, gamma: FloatArray, usable: NDArray) -> str:
    """The message for a torque that no pin could carry alone: by which factor the face
    width or the moduli must grow (or, where the law's largest force is not exceeded, that
    B·E is beyond what a double can evaluate). The largest force of the law, exp(α/γ − 1), is
    proportional to B·E (α/γ = ln(B/C) + const. in Eqs. 20–23 of [1]; C the compliance)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        limit = np.where(gamma > 0, np.exp(alpha / np.where(gamma > 0, gamma, 1.0) - 1.0), np.inf)
        ratio = np.where(usable, force / limit, np.inf)
    factor = float(np.min(ratio))
    if not (np.isfinite(factor) and factor >= 1.0):
        # within the law's largest force, yet no pin carries it: α and γ (∝ 1/(B·E)) under-
        # or overflow, e.g. a face width of 1e300 mm; raising B or E would only go further
        return (
            "the line-contact law (Eq. 20) cannot be evaluated in double precision for "
            "this face width and Young's modulus (its compliance coefficients under- or "
            "overflow); give design.width_mm and the youngs_modulus_gpa of [material] at "
            "a real size (mm, GPa)"
        )
    need = f" by a factor above {factor:.3g}" if factor > 1 else ""
    return (
        "torque too large for the contact: no pin could carry it alone within the "
        "line-contact law (Eq. 20); lower the torque, or raise design.width_mm or the "
        f"youngs_modulus_gpa of [material]{need}"
    )
