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

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.pair import Modification, PairDesign
from cyclomesh.exceptions import DesignError

__all__ = [
    "generating_radii",
    "locus",
    "modified_profile",
    "curvature_radius",
    "check_profile",
    "OffsetGeometry",
    "deviated_geometry",
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
    offset = rho
    if modification.profile is not None:
        space = np.round(phi1 / (2.0 * np.pi))
        offset = rho + modification.profile.evaluate(phi1 - 2.0 * np.pi * space, space)
    px = x - offset * dy / speed
    py = y + offset * dx / speed
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
    d_rho_um = modification.pin_radius * 1e6
    if rho <= 0:
        raise DesignError(
            f"modification.pin_radius_um = {d_rho_um:.6g}: ρp + Δρ must stay positive; raise "
            f"it above {-design.pin_radius * 1e6:.6g}"
        )
    if a <= design.eccentricity * design.pins:
        raise DesignError(
            f"modification.pin_circle_radius_um = {modification.pin_circle_radius * 1e6:.6g}: "
            "a + Δa must exceed e·n1 (K1 < 1) for a valid profile; raise it above "
            f"{(design.eccentricity * design.pins - design.pin_circle_radius) * 1e6:.6g}"
        )
    # The pins must reach the teeth at every crank angle. Midway between two pins the
    # nearest pin centre is |w| = sqrt(a² + e² − 2ae·cos(π/n1)) from the disc centre;
    # the tooth tips' pin-centre offset reaches a' + e − (ρ' − ρp) (contact.py, c = −1).
    e, a0, n1 = design.eccentricity, design.pin_circle_radius, design.pins
    nearest = math.sqrt(a0 * a0 + e * e - 2.0 * a0 * e * math.cos(math.pi / n1))
    reach = a + e - (rho - design.pin_radius)
    if nearest >= reach:
        most = (modification.pin_circle_radius + a0 + e - nearest) * 1e6
        raise DesignError(
            f"modification.pin_radius_um = {d_rho_um:.6g}: no pin reaches the disc's teeth "
            f"(a clearance deeper than the teeth, about 2e = {2e6 * e:.6g} µm); it must be "
            f"below {most:.6g} (Δρ − Δa less than a + e − sqrt(a² + e² − 2ae·cos(π/n1)))"
        )
    theta = np.linspace(0.0, 2.0 * np.pi / design.teeth, 4001)
    rho_c = curvature_radius(theta, design, modification)
    locus_radius = rho_c + rho
    convex = locus_radius > 0
    if np.any(convex & (locus_radius <= rho)):
        r_min = float(np.min(locus_radius[convex]))
        raise DesignError(
            f"undercut profile: the generating pin radius ρp + Δρ = {rho * 1e3:.6g} mm "
            "(design.pin_radius_mm + modification.pin_radius_um) exceeds the smallest convex "
            f"curvature radius of the pin-centre locus ({r_min * 1e3:.6g} mm): lower "
            "design.pin_radius_mm or modification.pin_radius_um below it, or lower "
            "design.eccentricity_mm, or raise design.pin_circle_radius_mm"
        )
    concave = ~convex
    if np.any(concave & (-rho_c <= design.pin_radius)):
        # |ρc| = ρ' − R > ρp  ⇔  Δρ > R on every concave point (R < 0 there)
        least = float(np.max(locus_radius[concave])) * 1e6
        raise DesignError(
            f"modification.pin_radius_um = {d_rho_um:.6g}: the pin does not fit the concave "
            f"tooth-space bottom (|ρc| ≤ ρp there); raise it above {least:.6g}"
        )
    if modification.profile is not None:
        _check_deviation(design, modification)


def _check_deviation(design: PairDesign, modification: Modification) -> None:
    """Refuse a tabulated deviation that makes the profile (or the pin's path) loop."""
    dev = modification.profile
    if dev.per_tooth and dev.teeth != design.teeth:
        raise DesignError(
            f"profile deviation: {dev.teeth} teeth tabulated; the disc has {design.teeth} "
            "(give every tooth 1..n2, or leave out the tooth column)"
        )
    u = np.linspace(-np.pi, np.pi, 4001)[None, :]
    space = np.arange(dev.teeth)[:, None]
    geo = deviated_geometry(u, design, modification, design.pin_radius, space)
    looped = geo.tangent_scale <= 0
    concave = (geo.curvature_radius < 0) & (-geo.curvature_radius <= design.pin_radius)
    for bad, what in (
        (looped, "makes the profile loop (undercut)"),
        (concave, "makes a concave part of the profile tighter than the pin (|ρc| ≤ ρp)"),
    ):
        if np.any(bad):
            j, k = np.unravel_index(np.argmax(bad), bad.shape)
            where = dev.row_near(int(j), float(u[0, k]))
            raise DesignError(
                f"profile deviation: {where}: the deviation near profile_angle_deg "
                f"{np.degrees(u[0, k]):.4g} {what}; smooth or reduce it"
            )


class OffsetGeometry(NamedTuple):
    """Disc profile with a varying normal deviation at tooth phase u, and the pin centre.

    Vectors are in the frame turned by the locus parameter t = (2πj + u)/n2 of the tooth
    space j (the frame in which the locus point is P = (a' − e·cos u, −e·sin u)); lengths
    [m]. See :func:`deviated_geometry`.
    """

    x: FloatArray  # profile point X, x component
    y: FloatArray
    nx: FloatArray  # outward unit normal N of the profile X
    ny: FloatArray
    qx: FloatArray  # pin centre Q = X + r·N
    qy: FloatArray
    dq_du_x: FloatArray  # dQ/du of the fixed-frame Q, expressed in the turned frame
    dq_du_y: FloatArray
    curvature_radius: FloatArray  # signed ρc of X (convex > 0)
    tangent_scale: FloatArray  # A = |P'| − (ρ' + d)·θ' [m/rad]; ≤ 0 where X loops


def deviated_geometry(
    u: ArrayLike,
    design: PairDesign,
    modification: Modification,
    pin_radius: ArrayLike,
    space: ArrayLike = 0,
) -> OffsetGeometry:
    """Profile X = P − (ρ' + d)·n with a tabulated deviation d(φ1), and its pin centre.

    Derivation (docs/modification.md): with T = P'/|P'|, n = T turned by −90°, and θ' the
    turning rate of the locus tangent (T' = −θ'·n, n' = θ'·T), all derivatives along t,

        X'  = A·T − d'·n,                         A = |P'| − (ρ' + d)·θ'
        X'' = (A' − d'θ')·T − (A·θ' + d'')·n
        ρc  = |X'|³ / (X' × X'') = (A² + d'²)^{3/2} / (θ'(A² + d'²) + A·d'' − A'·d')
        N   = (A·n + d'·T)/|X'|,     Q = X + r·N,     Q' = (1 + r/ρc)·X'

    With d constant this is Eq. 4 of [1] with ρ' → ρ' + d. |P'| = D and θ' = G/D², with
    D² = a'² + e²n1² − 2a'e·n1·cos u and G = e²n1³ + a'² − e·n1(1 + n1)a'·cos u (Eq. 4).

    Parameters
    ----------
    u : array_like
        Tooth phase φ1 within the tooth space, in [−π, π] [rad].
    design, modification
        a', ρ', e, n1, n2 and ``modification.profile`` (required).
    pin_radius : array_like
        Radius r of the pin [m] (Q is its centre).
    space : array_like of int
        Tooth-space index j (per-tooth tables).
    """
    a, rho = generating_radii(design, modification)
    e, n1, n2 = design.eccentricity, design.pins, design.teeth
    u = np.asarray(u, dtype=float)
    c, s_u = np.cos(u), np.sin(u)
    dev = modification.profile
    d = dev.evaluate(u, space, 0)
    dt = n2 * dev.evaluate(u, space, 1)  # derivatives along t = φ1/n2
    dtt = n2 * n2 * dev.evaluate(u, space, 2)
    big_d = np.sqrt(a * a + e * e * n1 * n1 - 2.0 * a * e * n1 * c)
    g = e * e * n1**3 + a * a - e * n1 * (1 + n1) * a * c
    theta = g / (big_d * big_d)
    d_big_d = a * e * n1 * n2 * s_u / big_d
    d_g = e * n1 * (1 + n1) * a * n2 * s_u
    d_theta = d_g / big_d**2 - 2.0 * g * d_big_d / big_d**3
    nx, ny = (a - e * n1 * c) / big_d, -e * n1 * s_u / big_d
    tx, ty = -ny, nx
    offset = rho + d
    amp = big_d - offset * theta
    d_amp = d_big_d - dt * theta - offset * d_theta
    length2 = amp * amp + dt * dt
    length = np.sqrt(length2)
    cross = theta * length2 + amp * dtt - d_amp * dt
    x, y = a - e * c - offset * nx, -e * s_u - offset * ny
    big_nx, big_ny = (amp * nx + dt * tx) / length, (amp * ny + dt * ty) / length
    r = np.asarray(pin_radius, dtype=float)
    stretch = (1.0 + r * cross / length**3) / n2  # (1 + r/ρc)/n2: dQ/du = stretch·X'
    return OffsetGeometry(
        x=x,
        y=y,
        nx=big_nx,
        ny=big_ny,
        qx=x + r * big_nx,
        qy=y + r * big_ny,
        dq_du_x=stretch * (amp * tx - dt * nx),
        dq_du_y=stretch * (amp * ty - dt * ny),
        curvature_radius=length**3 / cross,
        tangent_scale=amp,
    )
