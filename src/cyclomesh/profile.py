"""Tooth profile of the cycloid disc and its modification (Eqs. 1–4 of [1]).

The profile is the inner offset, by the generating pin radius ρ' = ρp + Δρ, of the
locus of a point at radius a' = a + Δa (the pin-centre locus, an epitrochoid) traced in
the disc frame S2:

    P(t) = a'·(cos t, sin t) − e·(cos n1·t, sin n1·t),     t = φ1/n2

with φ1 the generating angle of Eq. 1. One tooth is φ1 ∈ [0, 2π): φ1 = 0 is the bottom
of a tooth space (|P| = a' − e), φ1 = ±π a tooth tip (|P| = a' + e).

The outward unit normal (from the disc towards the pins) is ``n = (P'_y, −P'_x)/|P'|``.
A pin whose centre lies at signed distance s along n from the locus touches the profile
when s = r_pin − ρ' (Eq. 10 restated as an offset condition).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.design import Modification, PairDesign
from cyclomesh.exceptions import DesignError

__all__ = [
    "generating_radii",
    "locus",
    "modified_profile",
    "curvature_radius",
    "check_profile",
]

FloatArray = NDArray[np.float64]


def generating_radii(design: PairDesign, modification: Modification) -> tuple[float, float]:
    """Modified generating radii (a', ρ') = (a + Δa, ρp + Δρ) of Eq. 3 in [1] [m]."""
    return (
        design.pin_circle_radius + modification.pin_circle_radius,
        design.pin_radius + modification.pin_radius,
    )


def locus(
    t: ArrayLike, a: float, e: float, n1: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Pin-centre locus P(t) and its first two derivatives (Eq. 1 of [1], without the offset).

    Parameters
    ----------
    t : array_like
        Locus parameter t = φ1/n2 [rad].
    a : float
        Generating pin-circle radius a' [m].
    e : float
        Eccentricity [m].
    n1 : int
        Number of pins.

    Returns
    -------
    x, y, dx, dy, ddx, ddy : ndarray
        P, dP/dt, d²P/dt² [m].
    """
    t = np.asarray(t, dtype=float)
    c, s = np.cos(t), np.sin(t)
    cn, sn = np.cos(n1 * t), np.sin(n1 * t)
    x = a * c - e * cn
    y = a * s - e * sn
    dx = -a * s + e * n1 * sn
    dy = a * c - e * n1 * cn
    ddx = -a * c + e * n1 * n1 * cn
    ddy = -a * s + e * n1 * n1 * sn
    return x, y, dx, dy, ddx, ddy


def modified_profile(
    design: PairDesign, modification: Modification | None, phi1: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Points of the modified disc profile in the disc frame (Eqs. 1 and 3 of [1]).

    Parameters
    ----------
    design : PairDesign
    modification : Modification or None
        Δa and Δρ enter the generating radii; a rotation modification δ turns the
        flank φ1 mod 2π ∈ (−π, 0) (the flank loaded by cyclomesh's torque convention)
        by −δ and the other flank by +δ about the disc centre.
    phi1 : array_like
        Generating angle φ1 [rad]; one tooth spans 2π, the whole disc 2π·n2.

    Returns
    -------
    x, y : ndarray
        Profile coordinates [m].
    """
    modification = modification or Modification()
    a, rho = generating_radii(design, modification)
    phi1 = np.asarray(phi1, dtype=float)
    x, y, dx, dy, _, _ = locus(phi1 / design.teeth, a, design.eccentricity, design.pins)
    speed = np.hypot(dx, dy)
    px = x - rho * dy / speed
    py = y + rho * dx / speed
    if modification.rotation:
        phase = np.angle(np.exp(1j * phi1))
        turn = np.where(phase < 0.0, -modification.rotation, modification.rotation)
        c, s = np.cos(turn), np.sin(turn)
        px, py = c * px - s * py, s * px + c * py
    return px, py


def curvature_radius(
    theta_c: ArrayLike, design: PairDesign, modification: Modification | None = None
) -> FloatArray:
    """Signed curvature radius ρc of the modified profile, Eq. 4 of [1] [m].

    ρc = [e²n1² + a'² − 2e·n1·a'·cos(n2θc)]^(3/2)
         / [e²n1³ + a'² − e·n1·(1 + n1)·a'·cos(n2θc)] − ρ'

    Positive where the profile is convex (flanks), negative where it is concave
    (tooth-space bottom on most designs).

    Parameters
    ----------
    theta_c : array_like
        θc = φ1/n2, the locus parameter t [rad].
    design, modification
        Give a' = a + Δa, ρ' = ρp + Δρ, e, n1, n2.
    """
    modification = modification or Modification()
    a, rho = generating_radii(design, modification)
    e, n1, n2 = design.eccentricity, design.pins, design.teeth
    cos_u = np.cos(n2 * np.asarray(theta_c, dtype=float))
    num = (e * e * n1 * n1 + a * a - 2.0 * e * n1 * a * cos_u) ** 1.5
    den = e * e * n1**3 + a * a - e * n1 * (1 + n1) * a * cos_u
    return num / den - rho


def check_profile(design: PairDesign, modification: Modification | None = None) -> None:
    """Raise :class:`DesignError` if the modified profile is undercut or cannot seat a pin.

    The locus curvature radius R = ρc + ρ' (Eq. 4 of [1]) is sampled densely over one
    tooth. The inner offset by ρ' loops (undercut) where the locus is convex with
    0 < R < ρ'. In a concave region the pin must fit inside the profile: |ρc| > ρp.
    """
    modification = modification or Modification()
    a, rho = generating_radii(design, modification)
    if rho <= 0:
        raise DesignError("modification.pin_radius: ρp + Δρ must stay positive")
    if a <= design.eccentricity * design.pins:
        raise DesignError(
            "modification.pin_circle_radius: a + Δa must exceed e·n1 (K1 < 1) for a valid profile"
        )
    theta = np.linspace(0.0, 2.0 * np.pi / design.teeth, 4001)
    rho_c = curvature_radius(theta, design, modification)
    locus_radius = rho_c + rho
    convex = locus_radius > 0
    if np.any(convex & (locus_radius <= rho)):
        r_min = float(np.min(locus_radius[convex]))
        raise DesignError(
            f"undercut profile: generating pin radius ρp+Δρ = {rho * 1e3:.4g} mm exceeds the "
            f"smallest convex curvature radius of the pin-centre locus ({r_min * 1e3:.4g} mm); "
            "reduce pin_radius or eccentricity, or enlarge pin_circle_radius"
        )
    concave = ~convex
    if np.any(concave & (-rho_c <= design.pin_radius)):
        raise DesignError(
            "the pin does not fit the concave tooth-space bottom (|ρc| ≤ ρp): "
            "reduce modification.pin_radius's negative amount or the pin radius"
        )
