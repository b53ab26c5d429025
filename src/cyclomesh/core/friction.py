"""Friction at the pin contacts: kinematics, coefficients, forces and power losses.

The paper's model drops friction (assumption 3 of [1]). This module puts it back as
Coulomb (or lubricated) tangential forces at every pin contact, in the equilibrium of the
disc, so that load sharing, TE, the input torque and the power losses all follow from one
solve (:func:`cyclomesh.core.loadsharing.share_load` with the friction moment arms of
:func:`torque_arm`).

Kinematics of a contact
-----------------------
Crank angle φ, input (crank) speed ω. The disc centre O2 = e·(cos φ, sin φ) moves at
v_O2 = ω·e·ẑ×û(φ); the disc turns at ω_d = −ω/n2 (its theoretical motion; the TE rate is
of the order of 1e-4 of it and left out). At the contact point P of pin i (on the common
normal n, the disc's outward flank normal, P = C_i − r_p·n) the disc's material point moves
at v_d = v_O2 + ω_d·ẑ×(P − O2). With the tangent t = ẑ×n and r = P − O2:

    v_d·t = ω·[e·û(φ)·n − m/n2],        m = r·n = √(|r|² − l²) > 0,

(ẑ×û)·(ẑ×n) = û·n and (ẑ×r)·(ẑ×n) = r·n; l = |r×n| is the moment arm of Eq. 17 of [1],
and r·n > 0 because the disc profile is star-shaped about O2. For a conjugate profile
v_d·n = 0 and v_d·t is the whole relative velocity of disc and (fixed) pin.

Pins
----
``"fixed"``: the pin does not turn; the disc slides on it at v_d·t (pin–tooth sliding).
``"rolling"``: the pin turns in its groove under two tangential forces, at the tooth (T_t)
and at the groove (T_g, normal load F_p = F·cos β, Eq. 19 of [1]); its moment balance
(both at radius r_p) gives |T_t| = |T_g|. The interface with the smaller capacity slides
and the other rolls (sticks): μ_eff = min(μ_mesh, μ_groove·cos β) of F; the pin surface
moves with the disc when the groove slides (sliding at the groove at |v_d·t|, none at the
tooth), and stands still when the tooth slides. Either way the tangential force on the
disc is −μ_eff·F·sgn(v_d·t)·t and the loss μ_eff·F·|v_d·t| (Sensinger [2], §2; Malhotra &
Parameswaran [3] for the rolling pin).

Torque balance
--------------
The force of pin i on the disc is −F_i·n_i + T_i·t_i with T_i = −μ_eff,i·F_i·s_i,
s_i = sgn(v_d·t). About O2 the normal force has the moment −F_i·l_i (clockwise: the pins
turn the disc against the load T, which acts counter-clockwise, Σ F·l = T in
:mod:`cyclomesh.core.loadsharing`) and the tangential one T_i·m_i (r×t = r·n = m). The
disc's balance Σ(−F_i·l_i + T_i·m_i) + T = 0 becomes

    Σ F_i·(l_i + μ_eff,i·s_i·m_i) = T,

a load-sharing problem with the compatibility of Eq. 15 (δ_i = l_i·(Δφ − φbl,i)) and the
friction moment arm l_i + μ_eff·s_i·m_i in the balance: :func:`torque_arm`. In forward
drive s = −1 at every loaded pin (the sliding comes mostly from the disc's spin, −m/n2):
friction resists the disc's turn, the pins carry more.

Input torque and power
----------------------
The output acts on the disc as a couple, so the crank carries the resultant R of the pin
forces at O2 and T_in = −(O2 × R)·ẑ (:func:`input_torque`). The virtual power of the
theoretical motion gives, exactly,

    T_in·ω = T·ω/n2 + Σ μ_eff·F·|v_d·t| + Σ F·(v_d·n),

the last term the power of the normal approach of a non-conjugate (modified) profile,
the rate of the elastic energy and of the rest rotation, whose mean over a revolution
nearly vanishes. The efficiency is taken from the losses, η = P_out/(P_out + P_loss):
exactly 1 without friction. The crank bearing (:func:`bearing_moment`) adds its moment to
the disc's balance and to T_in (:mod:`cyclomesh.drive.friction`).

Lubricated coefficient
----------------------
Benedict & Kelley [4] (mixed/EHL sliding of gear teeth, Hertzian line contacts):

    μ = 0.0127·C_R·log10[3.17e8·w / (ν0·V_s·V_e²)],   C_R = 50/(50 − S),

w the load per unit width [lbf/in], V_s the sliding and V_e the sum (entraining) velocity
[in/s], ν0 the kinematic viscosity at the oil temperature [cSt], S the mean roughness
[µin]. It falls with speed and rises with load. Out of its range (little sliding, light
load, slow speed) it exceeds boundary friction; the interface's Coulomb coefficient is
then taken as the boundary value: μ = min(μ_BK, μ_boundary), and μ ≥ 0.

The regime follows from the film parameter λ = h_c/σ (:func:`film_parameters`): the
central film thickness of Dowson & Toyoda [7] from the Hertz geometry of the contact, σ
the composite roughness. Boundary friction below λ = 1, Benedict–Kelley's (capped) above
3 [8], and between them a smooth step of this model (:func:`boundary_share`). The
coefficient is a function of the pin load; :class:`FrictionBalance` puts it, with the
crank bearing's moment, into the Newton loop of the load sharing. The oil, Benedict and
Kelley's coefficient and the film parameter are in :mod:`cyclomesh.core.lubrication`
(their names stay importable here).

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
[2] J. W. Sensinger, "Efficiency of high-sensitivity gear trains, such as cycloid drives",
    J. Mech. Des. 135 (2013) 071006; "Unified approach to cycloid drive profile, stress,
    and efficiency optimization", J. Mech. Des. 132 (2010) 024503.
[3] S. K. Malhotra, M. A. Parameswaran, "Analysis of a cycloid speed reducer", Mech.
    Mach. Theory 18 (1983) 491–499.
[4] C. Benedict, B. W. Kelley, "Instantaneous coefficients of gear tooth friction",
    ASLE Trans. 4 (1961) 59–70 (as used in AGMA 925 and ISO/TR 14179-2 style models).
[5] ASTM D341: viscosity–temperature relation of petroleum oils (Walther's equation).
[6] SKF, Rolling bearings catalogue (2018), "Friction: estimating the frictional moment",
    M = 0.5·μ·P·d, μ ≈ 0.0025 for needle roller bearings.
[7] D. Dowson, S. Toyoda, "A central film thickness formula for elastohydrodynamic line
    contacts", Proc. 5th Leeds-Lyon Symposium on Tribology (1979) 60–65: H_c =
    3.06·G^0.56·U^0.69·W^−0.1 (the Dowson–Higginson line-contact analysis).
[8] B. J. Hamrock, S. R. Schmid, B. O. Jacobson, Fundamentals of Fluid Film Lubrication,
    2nd ed., Marcel Dekker (2004): film parameter λ = h/σ, σ = √(σ1² + σ2²); boundary
    λ < 1, mixed 1 ≤ λ ≤ 3, full film λ > 3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.contact import contact_tangent
from cyclomesh.core.loadsharing import column_sum
from cyclomesh.core.lubrication import (
    ISO_VG,
    MIN_VISCOSITY_CST,
    MIXED_RANGE,
    Film,
    Lubricant,
    benedict_kelley,
    boundary_share,
    central_film_thickness,
    film_parameters,
    walther_viscosity,
)
from cyclomesh.exceptions import DesignError
from cyclomesh.units import IN_PER_M, LBF_PER_IN_PER_N_PER_M, UIN_PER_M

__all__ = [
    "Friction",
    "Lubricant",
    "PINS",
    "ISO_VG",
    "walther_viscosity",
    "MIN_VISCOSITY_CST",
    "benedict_kelley",
    "tangential_velocity",
    "normal_moment",
    "effective_coefficient",
    "coefficients",
    "lubrication_constants",
    "loaded_film_parameter",
    "FrictionBalance",
    "Film",
    "central_film_thickness",
    "film_parameters",
    "boundary_share",
    "MIXED_RANGE",
    "torque_arm",
    "input_torque",
    "pin_resultant",
    "contact_losses",
    "bearing_moment",
    "closed_form_efficiency",
]

FloatArray = NDArray[np.float64]

PINS = ("rolling", "fixed")


@dataclass(frozen=True)
class Friction:
    """Friction of the drive: Coulomb coefficients per interface, or a lubricant.

    Parameters
    ----------
    mesh, groove : float
        Coulomb coefficients of the pin–tooth and pin–groove interfaces [-] (with a
        lubricant: the boundary values that cap Benedict–Kelley's).
    bearing : float
        Friction coefficient of the crank bearing (the disc's bearing on the eccentric),
        SKF's constant-coefficient model [6]: moment M = μ_b·|R|·d/2 with R the bearing
        load (the resultant of the pin forces on the disc) and d the bore diameter.
    bearing_diameter : float
        d [m], > 0 when ``bearing`` > 0.
    pins : {"rolling", "fixed"}
        Pins free to turn in their grooves, or fixed.
    lubricant : Lubricant, optional
        Lubricated (Benedict–Kelley) coefficients at the pin contacts.
    speed : float
        Input (crank) speed ω [rad/s], > 0.
    """

    mesh: float = 0.0
    groove: float = 0.0
    bearing: float = 0.0
    pins: str = "rolling"
    lubricant: Lubricant | None = None
    speed: float = 2.0 * math.pi * 1500.0 / 60.0
    bearing_diameter: float = 0.0

    def __post_init__(self) -> None:
        if self.bearing > 0 and not (
            math.isfinite(self.bearing_diameter) and self.bearing_diameter > 0
        ):
            raise DesignError(
                "friction.bearing_diameter_mm: a crank bearing coefficient needs the bore "
                "diameter of the crank bearing"
            )
        for name in ("mesh", "groove", "bearing"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and 0 <= value < 1):
                raise DesignError(f"friction.{name}_coefficient must lie in [0, 1), got {value!r}")
        if self.pins not in PINS:
            raise DesignError(f'friction.pins must be "rolling" or "fixed", got {self.pins!r}')
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise DesignError("load.input_speed_rpm must be a positive number")

    @property
    def frictionless(self) -> bool:
        """No friction anywhere (the paper's assumption 3)."""
        return self.mesh == 0 and self.groove == 0 and self.bearing == 0


def normal_moment(contact_radius: ArrayLike, moment_arm: ArrayLike) -> FloatArray:
    """m = r·n = √(|r|² − l²) [m]: moment arm of the tangential force about O2 (module doc)."""
    r = np.asarray(contact_radius, float)
    arm = np.asarray(moment_arm, float)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.maximum(r * r - arm * arm, 0.0))


def tangential_velocity(
    eccentricity: ArrayLike,
    crank_angle: ArrayLike,
    normal_x: ArrayLike,
    normal_y: ArrayLike,
    contact_radius: ArrayLike,
    moment_arm: ArrayLike,
    teeth: int,
) -> FloatArray:
    """Velocity of the disc's material point along t = ẑ×n at the contact, per unit input
    speed [m/rad]: e·û(φ)·n − m/n2 (module doc; [2], [3]).

    Arrays broadcast; ``crank_angle`` [rad] is the disc's own eccentric angle, normals in
    the fixed frame.
    """
    phi = np.asarray(crank_angle, float)
    e = np.asarray(eccentricity, float)
    m = normal_moment(contact_radius, moment_arm)
    return e * (np.cos(phi) * normal_x + np.sin(phi) * normal_y) - m / teeth


def effective_coefficient(
    friction: Friction,
    cos_beta: ArrayLike,
    force: ArrayLike | None = None,
    velocity: ArrayLike | None = None,
    width: float | None = None,
    film: Film | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Coefficients of the pin contacts: the one that acts on the disc, and whether the
    groove is the interface that slides.

    Parameters
    ----------
    friction : Friction
    cos_beta : array_like
        cos β of every contact (groove load F·cos β, Eq. 19 of [1]).
    force, velocity, width
        Pin load [N], tangential velocity of the disc per unit input speed [m/rad] and face
        width [m], for the lubricated coefficient (Benedict–Kelley [4] at the sliding
        interface, |v| = sliding = entrainment speed there, capped by the boundary value).
    film : Film, optional
        With a lubricant: the film parameter's mixed regime (:func:`coefficients`).

    Returns
    -------
    mu : ndarray
        μ_eff: the tangential force on the disc is μ_eff·F (module doc).
    groove : ndarray of bool
        True where the pin rolls on the tooth and slides in its groove.
    """
    speed = None if velocity is None else np.abs(np.asarray(velocity, float)) * friction.speed
    mu, groove, _ = coefficients(friction, cos_beta, force, speed, width, film)
    return mu, groove


_BK_ELASTICITY = 0.0127 / math.log(10.0)
"""F·dμ/dF of Benedict–Kelley's coefficient per unit C_R: μ ∝ log10 of the load [4]."""


def lubrication_constants(
    friction: Friction,
    cos_beta: ArrayLike,
    speed: ArrayLike,
    width: float,
    film: Film | None = None,
) -> dict[str, FloatArray]:
    """The load-independent parts of the lubricated coefficient of every pin, at a load of
    1 N: Benedict–Kelley's μ is 0.0127·C_R·log10 of the load, so μ_BK(F) = μ_BK(1 N) +
    0.0127·C_R·log10 F, and the film parameter λ(F) = λ(1 N)·F^−0.1 (Dowson–Toyoda, w^−0.1).
    Keys ``moving`` (1 where the contact slides), ``mu0_tooth``, ``mu0_groove`` and with a
    film ``lam0_tooth``, ``lam0_groove``: per-pin arrays for :func:`coefficients` (the
    Newton loop of the load sharing evaluates only F's logarithm per step)."""
    lub = friction.lubricant
    cos_beta = np.asarray(cos_beta, float)
    speed = np.asarray(speed, float)
    moving = speed > 0
    shape = np.broadcast_shapes(moving.shape, cos_beta.shape)
    log_v = np.log(np.where(moving, speed, 1.0))
    log_cb = np.log(cos_beta)
    # Benedict–Kelley [4] at F = 1 N, its logarithms taken apart (V_s = V_e = v):
    # μ = k·[ln(3.17e8·w_us/ν0) − 3·ln v_us], k = 0.0127·C_R/ln 10, w_us = cos β/B [lbf/in]
    k = _BK_ELASTICITY * 50.0 / (50.0 - lub.roughness * UIN_PER_M)
    base = math.log(3.17e8 * LBF_PER_IN_PER_N_PER_M / (width * lub.viscosity))
    mu0_tooth = k * (base - 3.0 * (log_v + math.log(IN_PER_M)))
    out = {
        "moving": np.broadcast_to(moving, shape),
        "mu0_tooth": np.broadcast_to(mu0_tooth, shape),
        "mu0_groove": mu0_tooth + k * log_cb,
    }
    if film is not None:
        # Dowson–Toyoda [7] at F = 1 N (w = 1/B), u = v/2, over σ: the powers as exponentials,
        # h_c = 3.06·α^0.56·E'^−0.03·η0^0.69·w^−0.1·u^0.69·R^0.41
        log_u = log_v - math.log(2.0)

        def lam0(radius: ArrayLike, modulus: float, log_w: ArrayLike) -> FloatArray:
            const = math.log(
                3.06
                * lub.pressure_viscosity**0.56
                * modulus**-0.03
                * lub.dynamic_viscosity**0.69
                / lub.sigma
            )
            log_r = np.log(np.abs(np.asarray(radius, float)))
            return np.where(moving, np.exp(const - 0.1 * log_w + 0.69 * log_u + 0.41 * log_r), 0.0)

        log_w = -math.log(width)
        out["lam0_tooth"] = lam0(film.tooth_radius, film.tooth_modulus, log_w)
        out["lam0_groove"] = lam0(film.groove_radius, film.groove_modulus, log_w + log_cb)
    return {key: np.asarray(np.broadcast_to(value, shape), float) for key, value in out.items()}


def coefficients(
    friction: Friction,
    cos_beta: ArrayLike,
    force: ArrayLike | None = None,
    speed: ArrayLike | None = None,
    width: float | None = None,
    film: Film | None = None,
    constants: dict | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`effective_coefficient` from the sliding speed |v·t|·ω [m/s], with the
    coefficient's elasticity F·dμ_eff/dF [-] (0 for a Coulomb or a capped coefficient;
    Benedict–Kelley's μ is 0.0127·C_R·log10 of the load, so F·dμ/dF = 0.0127·C_R/ln 10,
    times cos β at the groove), which the Newton step of the load sharing needs
    (:class:`FrictionBalance`).

    With ``film`` the film parameter λ of each interface (:func:`film_parameters`) sets
    the regime: μ = w(λ)·μ_boundary + (1 − w(λ))·μ_BK (:func:`boundary_share`), boundary
    friction below λ = 1, Benedict–Kelley's (capped) above 3; λ ∝ w^−0.1, so
    F·dλ/dF = −0.1·λ. ``constants``: those of :func:`lubrication_constants` (then
    ``speed``, ``width`` and ``film`` are not read)."""
    cos_beta = np.asarray(cos_beta, float)
    cap_t, cap_g = float(friction.mesh), float(friction.groove)
    mesh = np.full(cos_beta.shape, cap_t)
    groove = cap_g * cos_beta
    el_mesh = el_groove = np.zeros(cos_beta.shape)
    if friction.lubricant is not None and force is not None:
        lub = friction.lubricant
        if constants is None:
            constants = lubrication_constants(friction, cos_beta, speed, width, film)
        f = np.asarray(force, float)
        loaded = (f > 0) & (constants["moving"] > 0)
        log_f = np.log(np.where(loaded, f, 1.0))
        slope = _BK_ELASTICITY * 50.0 / (50.0 - lub.roughness * UIN_PER_M)
        scale = np.exp(-0.1 * log_f) if "lam0_tooth" in constants else None
        bk_tooth, el_mesh = _mixed(constants, "tooth", scale, log_f, cap_t, slope)
        mesh = np.where(loaded, bk_tooth, mesh)
        if friction.pins != "fixed":  # a fixed pin never slides in a groove
            bk_groove, el_groove = _mixed(constants, "groove", scale, log_f, cap_g, slope)
            el_groove = el_groove * cos_beta
            groove = np.where(loaded, bk_groove * cos_beta, groove)
    if friction.pins == "fixed":
        return mesh, np.zeros(mesh.shape, bool), el_mesh
    slides_in_groove = groove < mesh
    return (
        np.where(slides_in_groove, groove, mesh),
        slides_in_groove,
        np.where(slides_in_groove, el_groove, el_mesh),
    )


def loaded_film_parameter(constants: dict, force: ArrayLike, groove: ArrayLike) -> FloatArray:
    """The film parameter λ [-] of every pin's sliding interface (the groove where
    ``groove``, else the tooth) at the loads ``force`` [N]: λ(F) = λ(1 N)·F^−0.1
    (Dowson–Toyoda, w^−0.1; ``constants`` of :func:`lubrication_constants` with a film),
    0 where a pin carries no load."""
    f = np.asarray(force, float)
    on = f > 0
    scale = np.where(on, f, 1.0) ** -0.1
    lam0 = np.where(groove, constants["lam0_groove"], constants["lam0_tooth"])
    return np.where(on, lam0 * scale, 0.0)


def _mixed(
    constants: dict,
    interface: str,
    scale: FloatArray | None,
    log_f: FloatArray,
    cap: float,
    slope: float,
) -> tuple[FloatArray, FloatArray]:
    """The lubricated coefficient of one interface and its elasticity F·dμ/dF
    (:func:`coefficients`): Benedict–Kelley's capped at the boundary value, blended with it
    by the film parameter's boundary share. Where every contact of the array is boundary
    (λ ≤ 1) or full film (λ ≥ 3) the formulas reduce exactly to the cap or to
    Benedict–Kelley's, and the rest is not evaluated (the Newton loop's hot path)."""
    lam = None if scale is None else constants[f"lam0_{interface}"] * scale
    lo, hi = MIXED_RANGE
    if lam is not None and lam.size and lam.max() <= lo:
        return np.full(log_f.shape, cap), np.zeros(log_f.shape)
    mu = constants[f"mu0_{interface}"] + slope * log_f
    bk = np.minimum(np.maximum(mu, 0.0), cap)
    el = np.where((mu > 0.0) & (mu < cap), slope, 0.0)
    if lam is not None and not (lam.size and lam.min() >= hi):
        w, dw = boundary_share(lam)
        el = (1.0 - w) * el - 0.1 * (cap - bk) * dw * lam
        bk = bk + w * (cap - bk)
    return bk, el


@dataclass(frozen=True)
class FrictionBalance:
    """The torque balance of a disc stack with load-dependent friction, for
    :func:`cyclomesh.core.loadsharing.share_load` (its ``balance``): the lubricated
    coefficient μ(F) at the pins and the crank bearing's moment M_b(|R|), R the resultant
    of the pin forces on each disc, both functions of the pin loads and so of Δφ alone.

        M(Δφ) = Σ F_i·(l_i + μ_i(F_i)·s_i·m_i) − s_b·Σ_k M_b(|R_k|),

    dM/dΔφ = Σ dF_i·(l_i + s_i·m_i·(μ_i + F_i·dμ_i/dF)) − s_b·Σ_k dM_b,k, one Newton loop
    with the compatibility (no fixed point on μ or M_b). Per-pin ``data``: ``arm`` l,
    ``normal_moment`` m, ``sign`` s, ``cos_beta`` and the constants of
    :func:`lubrication_constants` (lubricated), else ``mu``; with a
    bearing ``normal_x``, ``normal_y`` and ``disc`` (index of the pin's disc).

    Parameters
    ----------
    friction : Friction
    data : dict
        The per-pin arrays above, broadcast against the backlash.
    width : float
        Face width [m] (lubricated coefficient).
    discs : int
        Number of discs in a row of the load sharing.
    bearing_sense : float
        s_b: +1 when the bearing's moment adds to the torque on the pins (module doc).
    film : Film, optional
        The film parameter's mixed regime of the lubricated coefficient.
    """

    friction: Friction
    data: dict
    width: float = 0.0
    discs: int = 1
    bearing_sense: float = 1.0
    film: Film | None = None

    def coefficient(self, force: FloatArray, data: dict) -> tuple[FloatArray, FloatArray]:
        """μ_eff and F·dμ_eff/dF at the pins (:func:`coefficients`)."""
        if "mu" in data:
            return data["mu"], np.zeros(force.shape)
        # only the loaded pins: an unloaded one's μ multiplies a zero force (and dF = 0)
        on = force > 0
        keys = ("cos_beta", "moving", "mu0_tooth", "lam0_tooth")
        if self.friction.pins != "fixed":
            keys = (*keys, "mu0_groove", "lam0_groove")
        sub = {key: data[key][on] for key in keys if key in data}
        mu_on, _, el_on = coefficients(self.friction, sub["cos_beta"], force[on], constants=sub)
        mu = np.zeros(force.shape)
        elasticity = np.zeros(force.shape)
        mu[on] = mu_on
        elasticity[on] = el_on
        return mu, elasticity

    def __call__(
        self, force: FloatArray, dforce: FloatArray, data: dict
    ) -> tuple[FloatArray, FloatArray]:
        mu, elasticity = self.coefficient(force, data)
        sm = data["sign"] * data["normal_moment"]
        moment = column_sum(force * (data["arm"] + mu * sm))
        slope = column_sum(dforce * (data["arm"] + sm * (mu + elasticity)))
        if self.friction.bearing > 0:
            tx, ty = contact_tangent(data["normal_x"], data["normal_y"])
            tangential = -data["sign"] * mu * force  # on the disc, along t
            dtangential = -data["sign"] * (mu + elasticity) * dforce
            gx = -force * data["normal_x"] + tangential * tx
            gy = -force * data["normal_y"] + tangential * ty
            dgx = -dforce * data["normal_x"] + dtangential * tx
            dgy = -dforce * data["normal_y"] + dtangential * ty
            scale = 0.5 * self.friction.bearing * self.friction.bearing_diameter
            for k in range(self.discs):
                on = data["disc"] == k
                rx = column_sum(np.where(on, gx, 0.0))
                ry = column_sum(np.where(on, gy, 0.0))
                load = np.hypot(rx, ry)
                drx = column_sum(np.where(on, dgx, 0.0))
                dry = column_sum(np.where(on, dgy, 0.0))
                dload = (rx * drx + ry * dry) / np.where(load > 0, load, 1.0)
                moment = moment - self.bearing_sense * scale * load
                slope = slope - self.bearing_sense * scale * dload
        return moment, slope


def torque_arm(
    moment_arm: ArrayLike, normal_moment_arm: ArrayLike, mu: ArrayLike, sign: ArrayLike
) -> FloatArray:
    """Moment arm of a pin's load in the torque balance with friction [m]:
    l + μ_eff·s·m, s = sgn(v_d·t) of the motion (module doc)."""
    return np.asarray(moment_arm, float) + np.asarray(mu, float) * sign * normal_moment_arm


def pin_resultant(
    force: ArrayLike, tangential: ArrayLike, normal_x: ArrayLike, normal_y: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Resultant R = Σ(−F·n + T·t) of the pin forces on a disc [N], summed over the last
    axis (the pins): normal load F along the outward flank normal n
    (:func:`cyclomesh.core.contact.contact_normal`), tangential force T along
    t = ẑ×n (:func:`cyclomesh.core.contact.contact_tangent`)."""
    f = np.asarray(force, float)
    tf = np.asarray(tangential, float)
    tx, ty = contact_tangent(normal_x, normal_y)
    return np.sum(-f * normal_x + tf * tx, axis=-1), np.sum(-f * normal_y + tf * ty, axis=-1)


def input_torque(
    force: ArrayLike,
    tangential: ArrayLike,
    normal_x: ArrayLike,
    normal_y: ArrayLike,
    eccentricity: ArrayLike,
    crank_angle: ArrayLike,
) -> FloatArray:
    """Torque on the crank [N·m] that holds the disc's pin forces (moment about the crank
    axis of their resultant at O2): T_in = −O2 × R, R = Σ(−F·n + T·t) per disc.

    ``force`` and ``tangential`` (the tangential force T on the disc, along t = ẑ×n) are
    (..., n1) per disc; ``eccentricity`` and ``crank_angle`` broadcast against (...).
    """
    rx, ry = pin_resultant(force, tangential, normal_x, normal_y)
    e = np.asarray(eccentricity, float)
    phi = np.asarray(crank_angle, float)
    return -e * (np.cos(phi) * ry - np.sin(phi) * rx)


def bearing_moment(friction: Friction, load: ArrayLike) -> FloatArray:
    """Friction moment of the crank bearing [N·m]: 0.5·μ_b·|R|·d (SKF [6])."""
    return 0.5 * friction.bearing * friction.bearing_diameter * np.asarray(load, float)


def contact_losses(
    mu: ArrayLike, force: ArrayLike, velocity: ArrayLike, speed: float
) -> FloatArray:
    """Power lost at each pin contact [W]: μ_eff·F·|v_d·t|·ω."""
    return np.asarray(mu, float) * force * np.abs(velocity) * speed


def closed_form_efficiency(
    pins: int,
    pin_circle_radius: float,
    pin_radius: float,
    eccentricity: float,
    mu: float,
    equilibrium: bool = False,
    backdrive: bool = False,
) -> float:
    """Efficiency of a cycloid stage with fixed pins in closed form, on the assumptions of
    Malhotra & Parameswaran [3]: rigid members, the unmodified profile with no clearance,
    half the pins loaded with F_i ∝ l_i (their load distribution,
    F_i = 4T/(z_c·K1·r_p)·sin θ_i/S_i, S_i = √(1 + K1² − 2·K1·cos θ_i), K1 = n1·e/r_p < 1),
    Coulomb sliding μ at every pin, the pins' number large enough for the sums over the
    pins to be integrals over θ ∈ (0, π).

    The disc turns about the pitch point I (n1·e from the ring's centre) at ω/n2, so pin
    i slides at (ω/n2)·|PI|, |PI| = r_p·S − r_rp, and its force's arm about the disc's
    centre is l = n2·e·sin θ/S. With ∫ sin²θ/S² dθ = π/2 and ∫ sin θ·(r_p − r_rp/S) dθ =
    2·(r_p − r_rp) over (0, π), the loss over the output power is

        x = Σ μ·F·|PI| / Σ F·l = 4·μ·(r_p − r_rp)/(π·n2·e),   η = 1/(1 + x)

    (``equilibrium=False``: the losses on the frictionless loads, as in [3]). This
    continuum form of the per-pin sums of [3] is derived here, not quoted: the text of
    the paper's own efficiency equation was not at hand.

    ``equilibrium=True``: friction in the torque balance, as cyclomesh solves it. The loss
    splits into the crank's share p (the friction force into the crank bearing) and the
    disc spin's share q (its moment about the disc centre, arm m = |PI| − n2·e·(K1 −
    cos θ)/S): p = −2·μ·J(K1)/π, q = x − p, J(K) = −1/K + (1 − K²)/(2K²)·ln((1 + K)/(1 − K))
    (J < 0), and η_f = (1 − q)/(1 + p), η_b = (1 − p)/(1 + q) (``backdrive``).

    Parameters
    ----------
    pins : int
        n1 (the disc has n2 = n1 − 1 teeth).
    pin_circle_radius, pin_radius, eccentricity : float
        r_p, r_rp, e [m].
    mu : float
        Coulomb coefficient at the pins [-].
    equilibrium, backdrive : bool

    Returns
    -------
    float
        The efficiency [-].
    """
    teeth = pins - 1
    k1 = pins * eccentricity / pin_circle_radius
    if not 0.0 < k1 < 1.0:
        raise DesignError("closed form: K1 = n1·e/r_p must lie in (0, 1)")
    x = 4.0 * mu * (pin_circle_radius - pin_radius) / (math.pi * teeth * eccentricity)
    if not equilibrium:
        if backdrive:
            raise DesignError("closed form: back-driving needs friction in the equilibrium")
        return 1.0 / (1.0 + x)
    j = -1.0 / k1 + (1.0 - k1 * k1) / (2.0 * k1 * k1) * math.log((1.0 + k1) / (1.0 - k1))
    p = -2.0 * mu * j / math.pi
    q = x - p
    return (1.0 - p) / (1.0 + q) if backdrive else (1.0 - q) / (1.0 + p)
