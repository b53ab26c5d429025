"""Hertzian line contact of pin, tooth and groove (Eqs. 19–24 of [1]).

The pin is squeezed between the tooth (force Fc along the line of action) and its
groove (Fp = Fc·cos β). The approach of two cylinders of length B under a force F is
(Eqs. 20, 21)

    δ = 2F/(πB) · [ c1·(ln(4r1/b) − ½) + c2·(ln(4r2/b) − ½) ],   b = sqrt(4Fρ*/(πBE*))

with c = (1 − ν²)/E. Since ln(4r/b) = ln(4r/κ) − ½·ln F with κ = sqrt(4ρ*/(πBE*)), every
pair, and their sum along the line of action (Eq. 19, δ = δc + δp·cos β), takes the form

    δ(F) = F·(α − γ·ln F)        [F in N, δ in m]

which :func:`compliance_coefficients` returns and :func:`force_from_approach` inverts
exactly through the Lambert W function.

Contact laws
------------
``contact_law="paper"`` is Eq. 20 as published: the disc's term is the
approach of the centre of curvature of the tooth, c·(ln(4|ρc|/b) − ½). At the
inflection points of a modified profile |ρc| → ∞, so that term, and the tooth's
compliance, diverge although the tooth there is nearly flat.

``contact_law="half_plane"`` refers the disc's approach to a point at a finite depth d
inside the disc, as for a 2-D half-plane under Hertzian pressure (Johnson [2], eq. 5.41):

    δdisc = 2F/(πB) · c·(ln(2d/b) − ν/(2(1 − ν)))

with d the distance from the contact point to the disc centre (where the disc carries
its torque). The pin's and the groove's terms stay those of Eqs. 20, 21 (their radii are
physical). The law has the same form δ = F·(α − γ·ln F) with the same γ, so the exact
inverse below carries over; it is finite and smooth through the inflection points
(ρ*pc → ρp there). It is the default: under Eq. 20 a pin crossing an inflection point
loses its load for a crank angle, so the ratio ripple and the TE peak-to-peak grow
without bound as the crank step shrinks. See ``docs/contact-law.md``.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] K. L. Johnson, Contact Mechanics, Cambridge University Press, 1985, §5.6.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import ConvergenceError

__all__ = [
    "effective_modulus",
    "pin_tooth_radius",
    "pin_groove_radius",
    "half_width",
    "approach",
    "compliance_coefficients",
    "force_from_approach",
    "force_from_approach_w",
    "half_plane_coefficients",
    "max_pressure",
    "CONTACT_LAWS",
]

CONTACT_LAWS = ("paper", "half_plane")
"""Names of the contact laws :func:`compliance_coefficients` accepts."""

FloatArray = NDArray[np.float64]


def effective_modulus(compliance_1: float, compliance_2: float) -> float:
    """Effective modulus E* = 1/(c1 + c2), c = (1 − ν²)/E (Eqs. 22, 23 of [1]) [Pa]."""
    return 1.0 / (compliance_1 + compliance_2)


def pin_tooth_radius(pin_radius: ArrayLike, profile_radius: ArrayLike) -> FloatArray:
    """Equivalent radius ρ*pc = ρp·ρc/(ρp + ρc) of pin and tooth (Eq. 22 of [1]) [m].

    ``profile_radius`` is the signed ρc of Eq. 4: a concave flank (ρc < 0, |ρc| > ρp)
    gives a conforming contact with a large ρ*. At an inflection point of the profile
    (ρc = ±inf) the limit ρ* = ρp is returned.
    """
    rp, rc = np.asarray(pin_radius, float), np.asarray(profile_radius, float)
    with np.errstate(invalid="ignore"):
        rho = rp * rc / (rp + rc)
    return np.where(np.isinf(rc), rp, rho)


def pin_groove_radius(pin_radius: ArrayLike, groove_radius: float) -> FloatArray:
    """Equivalent radius ρ*pg = ρp·ρg/(ρg − ρp) of pin and concave groove (Eq. 23 of [1]) [m]."""
    rp = np.asarray(pin_radius, float)
    return rp * groove_radius / (groove_radius - rp)


def half_width(force: ArrayLike, radius: ArrayLike, modulus: float, width: float) -> FloatArray:
    """Contact half-width b = sqrt(4Fρ*/(πBE*)) (Eqs. 20, 21 of [1]) [m].

    Parameters
    ----------
    force : array_like
        Normal force F [N].
    radius : array_like
        Equivalent radius ρ* [m].
    modulus : float
        Effective modulus E* [Pa].
    width : float
        Contact length B [m].
    """
    return np.sqrt(4.0 * np.asarray(force, float) * radius / (np.pi * width * modulus))


def approach(
    force: ArrayLike,
    radius_1: ArrayLike,
    radius_2: ArrayLike,
    compliance_1: float,
    compliance_2: float,
    equivalent_radius: ArrayLike,
    width: float,
) -> FloatArray:
    """Approach δ of two cylinders in line contact (Eqs. 20, 21 of [1]) [m].

    Parameters
    ----------
    force : array_like
        Normal force F [N].
    radius_1, radius_2 : array_like
        Radii of the two bodies, |ρ| in the logarithms [m].
    compliance_1, compliance_2 : float
        (1 − ν²)/E of each body [1/Pa].
    equivalent_radius : array_like
        ρ* of the pair [m].
    width : float
        Contact length B [m].
    """
    force = np.asarray(force, float)
    modulus = effective_modulus(compliance_1, compliance_2)
    b = half_width(force, equivalent_radius, modulus, width)
    return (
        2.0
        * force
        / (np.pi * width)
        * (
            compliance_1 * (np.log(4.0 * np.abs(radius_1) / b) - 0.5)
            + compliance_2 * (np.log(4.0 * np.abs(radius_2) / b) - 0.5)
        )
    )


def _pair_coefficients(r1, r2, c1, c2, rho_star, width):
    """(α, γ) of one pair: δ = F(α − γ ln F)."""
    kappa = np.sqrt(4.0 * rho_star / (np.pi * width * effective_modulus(c1, c2)))
    alpha = (
        2.0
        / (np.pi * width)
        * (
            c1 * (np.log(4.0 * np.abs(r1) / kappa) - 0.5)
            + c2 * (np.log(4.0 * np.abs(r2) / kappa) - 0.5)
        )
    )
    gamma = (c1 + c2) / (np.pi * width)
    return alpha, gamma


def half_plane_coefficients(
    depth: ArrayLike,
    pin_radius: ArrayLike,
    rho_star: ArrayLike,
    disc_compliance: float,
    disc_poisson: float,
    pin_compliance: float,
    width: float,
) -> tuple[FloatArray, FloatArray]:
    """(α, γ) of the pin–tooth pair with the disc as a half-plane to depth d [m/N].

    δ = 2F/(πB)·[c_d·(ln(2d/b) − ν_d/(2(1 − ν_d))) + c_p·(ln(4ρp/b) − ½)], the disc's
    term from Johnson's approach of a point at depth d (eq. 5.41 of [2]), the pin's from
    Eq. 20 of [1]; b = κ·sqrt(F) with κ = sqrt(4ρ*/(πBE*)) (Eq. 22).

    Parameters
    ----------
    depth : array_like
        Reference depth d in the disc [m], > 0.
    pin_radius : array_like
        ρp [m].
    rho_star : array_like
        ρ*pc of the pair (Eq. 22) [m].
    disc_compliance, pin_compliance : float
        (1 − ν²)/E of disc and pin [1/Pa].
    disc_poisson : float
        ν of the disc [-].
    width : float
        Face width B [m].
    """
    c1, c2 = disc_compliance, pin_compliance
    kappa = np.sqrt(4.0 * np.asarray(rho_star, float) / (np.pi * width * effective_modulus(c1, c2)))
    alpha = (
        2.0
        / (np.pi * width)
        * (
            c1
            * (
                np.log(2.0 * np.asarray(depth, float) / kappa)
                - 0.5 * disc_poisson / (1.0 - disc_poisson)
            )
            + c2 * (np.log(4.0 * np.asarray(pin_radius, float) / kappa) - 0.5)
        )
    )
    gamma = (c1 + c2) / (np.pi * width)
    return alpha, np.broadcast_to(gamma, np.shape(alpha))


def compliance_coefficients(
    pin_radius: ArrayLike,
    profile_radius: ArrayLike,
    groove_radius: float,
    cos_beta: ArrayLike,
    width: float,
    pin_compliance: float,
    disc_compliance: float,
    ring_compliance: float,
    groove_deformation: bool = True,
    contact_law: str = "paper",
    reference_depth: ArrayLike | None = None,
    disc_poisson: float | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Coefficients (α, γ) of the total approach δ = F·(α − γ·ln F) along the line of action.

    Combines Eqs. 19–23 of [1]: δtotal = δc(Fc) + cos β·δp(Fc·cos β). With
    ``groove_deformation=False`` (the "current model") only δc remains.

    Parameters
    ----------
    pin_radius : array_like
        Pin radius ρp [m].
    profile_radius : array_like
        Signed profile curvature radius ρc at the contact [m] (Eq. 4).
    groove_radius : float
        Groove radius ρg [m].
    cos_beta : array_like
        Cosine of the angle between the line of action and the pin's radial line.
    width : float
        Face width B [m].
    pin_compliance, disc_compliance, ring_compliance : float
        (1 − ν²)/E of pin, disc and ring [1/Pa].
    groove_deformation : bool
        Include the pin–groove deformation (the "improved model").
    contact_law : {"paper", "half_plane"}
        The disc's term: Eq. 20 of [1] as published (the default of this low-level
        function, which needs no contact geometry), or the approach of a half-plane to
        ``reference_depth`` (Johnson [2], eq. 5.41; see the module docstring), the default
        of every solver and study.
    reference_depth : array_like, optional
        Depth d of the reference point in the disc [m]; required by ``"half_plane"``.
    disc_poisson : float, optional
        Poisson's ratio of the disc; required by ``"half_plane"``.

    Returns
    -------
    alpha : ndarray
        [m/N]; the approach of 1 N.
    gamma : ndarray
        [m/N], the coefficient of ln F (F in newtons).
    """
    rp = np.asarray(pin_radius, float)
    rc = np.asarray(profile_radius, float)
    if contact_law == "paper":
        alpha, gamma = _pair_coefficients(
            rc, rp, disc_compliance, pin_compliance, pin_tooth_radius(rp, rc), width
        )
    elif contact_law == "half_plane":
        if reference_depth is None or disc_poisson is None:
            raise ValueError("contact_law 'half_plane' needs reference_depth and disc_poisson")
        with np.errstate(divide="ignore"):  # ρc = ±inf exactly at an inflection: ρ* = ρp
            rho_star = rp / (1.0 + rp / rc)
        alpha, gamma = half_plane_coefficients(
            reference_depth,
            rp,
            rho_star,
            disc_compliance,
            disc_poisson,
            pin_compliance,
            width,
        )
    else:
        raise ValueError(f"contact_law must be one of {CONTACT_LAWS}, got {contact_law!r}")
    if groove_deformation:
        cb = np.asarray(cos_beta, float)
        a_p, g_p = _pair_coefficients(
            groove_radius,
            rp,
            ring_compliance,
            pin_compliance,
            pin_groove_radius(rp, groove_radius),
            width,
        )
        # δp·cos β with Fp = Fc cos β:  cos²β·Fc·(α_p − γ_p·ln cos β − γ_p·ln Fc)
        c2 = cb * cb
        with np.errstate(divide="ignore"):
            log_cb = np.where(cb > 0, np.log(np.where(cb > 0, cb, 1.0)), 0.0)
        alpha = alpha + c2 * (a_p - g_p * log_cb)
        gamma = gamma + c2 * g_p
    return np.broadcast_arrays(np.asarray(alpha, float), np.asarray(gamma, float))


def force_from_approach(approach: ArrayLike, alpha: ArrayLike, gamma: ArrayLike) -> FloatArray:
    """Invert δ = F·(α − γ·ln F) for the force F [N] on its stiffening branch.

    The exact inverse is F = exp(α/γ + W₋₁(−(δ/γ)·e^(−α/γ))), W₋₁ the lower branch of
    the Lambert W function (the branch on which dδ/dF > 0); :func:`force_from_approach_w`
    evaluates it with SciPy. This hot-path version reaches the same root by Newton's
    method in y = ln F, started from two fixed-point steps y = ln(δ/(α − γ·y)), and stops
    at a residual of 2e-15·δ (round-off), each element on its own (so that its result
    does not depend on the other elements of the array), 10 times faster than the
    complex-valued ``scipy.special.lambertw``. γ = 0 gives the linear spring F = δ/α.

    Parameters
    ----------
    approach : array_like
        δ ≥ 0 [m].
    alpha, gamma : array_like
        Coefficients from :func:`compliance_coefficients` [m/N].

    Raises
    ------
    ConvergenceError
        If δ exceeds the largest approach the line-contact formula can describe, or the
        iteration fails.
    """
    delta = np.asarray(approach, float)
    alpha = np.asarray(alpha, float)
    gamma = np.asarray(gamma, float)
    delta, alpha, gamma = np.broadcast_arrays(delta, alpha, gamma)
    out = np.zeros(delta.shape)
    pos = delta > 0
    lin = pos & (gamma == 0)
    out[lin] = delta[lin] / alpha[lin]
    nl = pos & (gamma != 0)
    if not np.any(nl):
        return out
    d, a, g = delta[nl], alpha[nl], gamma[nl]
    _check_branch(d, a, g)
    y = np.log(d / a)
    y = np.log(d / (a - g * y))
    y = np.log(d / (a - g * y))
    # Each element stops at its own residual: a batch-wide stop would give an element
    # extra Newton steps when another element of the batch converges later, so its last
    # bit would depend on what it was solved with (docs/pipeline.md, reproducibility).
    for _ in range(_MAX_NEWTON):
        f = np.exp(y)
        resid = f * (a - g * y) - d
        active = ~(np.abs(resid) <= _ROUND_OFF * d)
        if not np.any(active):
            break
        y = np.where(active, y - resid / (f * (a - g - g * y)), y)
    else:
        # at round-off: a residual no step of y can reduce, below what one unit in the
        # last place of y changes it (|y| ≈ 35 for an approach of 1e-23 m, where 2e-15·δ
        # is below the resolution of y); only these elements, after the loop, so the
        # bits of every element that meets 2e-15·δ are unchanged
        f = np.exp(y)
        resid = f * (a - g * y) - d
        resolution = 4.0 * np.finfo(float).eps * np.abs(y) * np.abs(f * (a - g - g * y))
        if not np.all((np.abs(resid) <= _ROUND_OFF * d) | (np.abs(resid) <= resolution)):
            raise ConvergenceError("inversion of the contact law (Eq. 20) did not converge")
    out[nl] = np.exp(y)
    return out


_MAX_NEWTON = 50
_ROUND_OFF = 2e-15


def _check_branch(d: FloatArray, a: FloatArray, g: FloatArray) -> None:
    """Refuse δ beyond δmax = γ·exp(α/γ − 1), the stiffest point of δ(F)."""
    if np.any(np.log(d / g) - a / g >= -1.0):
        raise ConvergenceError(
            "contact approach beyond the validity of the line-contact formula "
            "(force past the stiffest point of Eq. 20): torque too large for the design; "
            "lower the torque, or raise design.width_mm or the youngs_modulus_gpa of [material]"
        )


def force_from_approach_w(approach: ArrayLike, alpha: ArrayLike, gamma: ArrayLike) -> FloatArray:
    """Closed-form inverse of δ = F·(α − γ·ln F) through Lambert W₋₁ [N] (γ > 0, δ > 0).

    F = exp(α/γ + W₋₁(−(δ/γ)·e^(−α/γ))); the reference for :func:`force_from_approach`.
    """
    from scipy.special import lambertw  # the reference only: kept off the solver's imports

    d, a, g = np.broadcast_arrays(*(np.asarray(x, float) for x in (approach, alpha, gamma)))
    _check_branch(d, a, g)
    log_mz = np.log(d / g) - a / g  # log of −z, kept in logs against underflow
    return np.exp(a / g + lambertw(-np.exp(log_mz), k=-1).real)


def max_pressure(force: ArrayLike, radius: ArrayLike, modulus: float, width: float) -> FloatArray:
    """Maximum Hertzian contact pressure σ = 2F/(πbB) = sqrt(F·E*/(πBρ*)) (Eq. 24 of [1]) [Pa]."""
    return np.sqrt(np.asarray(force, float) * modulus / (np.pi * width * np.asarray(radius, float)))
