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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.contact import contact_tangent
from cyclomesh.exceptions import DesignError
from cyclomesh.units import IN_PER_M, LBF_PER_IN_PER_N_PER_M, UIN_PER_M

__all__ = [
    "Friction",
    "Lubricant",
    "PINS",
    "ISO_VG",
    "walther_viscosity",
    "benedict_kelley",
    "tangential_velocity",
    "normal_moment",
    "effective_coefficient",
    "torque_arm",
    "input_torque",
    "pin_resultant",
    "contact_losses",
    "bearing_moment",
]

FloatArray = NDArray[np.float64]

PINS = ("rolling", "fixed")

ISO_VG: dict[int, tuple[float, float]] = {
    32: (32.0, 5.4),
    46: (46.0, 6.8),
    68: (68.0, 8.8),
    100: (100.0, 11.2),
    150: (150.0, 14.7),
    220: (220.0, 19.0),
    320: (320.0, 24.1),
    460: (460.0, 30.6),
    680: (680.0, 39.2),
}
"""ISO 3448 viscosity grade → (ν at 40 °C, ν at 100 °C) [cSt]: the grade's midpoint at
40 °C, and at 100 °C the value of a mineral gear oil of viscosity index about 95–100
(manufacturers' data sheets of ISO VG gear oils); give ``viscosity_100c_cst`` to use
another oil."""


@dataclass(frozen=True)
class Lubricant:
    """A lubricant for the Benedict–Kelley coefficient, SI except the viscosities.

    Parameters
    ----------
    viscosity_40 : float
        Kinematic viscosity at 40 °C [cSt = mm²/s] (the ISO VG grade).
    viscosity_100 : float
        Kinematic viscosity at 100 °C [cSt].
    temperature : float
        Oil (bulk) temperature [°C].
    roughness : float
        Mean arithmetic roughness Ra of the two surfaces [m].
    """

    viscosity_40: float
    viscosity_100: float
    temperature: float = 40.0
    roughness: float = 0.4e-6

    def __post_init__(self) -> None:
        if not (0 < self.viscosity_100 < self.viscosity_40):
            raise DesignError(
                "friction.lubricant: the viscosity at 100 °C must be positive and below "
                "the one at 40 °C"
            )
        if not (-30.0 <= self.temperature <= 150.0):
            raise DesignError("friction.lubricant.temperature_c must lie in [−30, 150] °C")
        if not (0 <= self.roughness * UIN_PER_M < 40.0):
            raise DesignError(
                "friction.lubricant.roughness_um must be ≥ 0 and below 1 µm "
                "(the range of Benedict–Kelley's roughness factor)"
            )

    @property
    def viscosity(self) -> float:
        """Kinematic viscosity at the oil temperature [cSt] (ASTM D341, [5])."""
        return float(walther_viscosity(self.viscosity_40, self.viscosity_100, self.temperature))


def walther_viscosity(nu40: float, nu100: float, temperature_c: ArrayLike) -> FloatArray:
    """Kinematic viscosity [cSt] at ``temperature_c`` [°C] from its values at 40 and
    100 °C: log10 log10(ν + 0.7) = A − B·log10 T, T in K (ASTM D341, Walther [5])."""
    t40, t100 = math.log10(313.15), math.log10(373.15)
    z40 = math.log10(math.log10(nu40 + 0.7))
    z100 = math.log10(math.log10(nu100 + 0.7))
    slope = (z40 - z100) / (t100 - t40)
    t = np.log10(np.asarray(temperature_c, float) + 273.15)
    z = z40 - slope * (t - t40)
    return 10.0 ** (10.0**z) - 0.7


def benedict_kelley(
    load_per_width: ArrayLike,
    sliding: ArrayLike,
    entrainment: ArrayLike,
    viscosity_cst: float,
    roughness: float,
) -> FloatArray:
    """Benedict–Kelley friction coefficient [4] (unbounded; see :func:`effective_coefficient`).

    Parameters
    ----------
    load_per_width : array_like
        Normal load per unit face width [N/m], > 0.
    sliding, entrainment : array_like
        Sliding speed |u1 − u2| and sum speed u1 + u2 [m/s], > 0.
    viscosity_cst : float
        Kinematic viscosity at the oil temperature [cSt].
    roughness : float
        Mean Ra of the two surfaces [m].

    Returns
    -------
    ndarray
        μ = 0.0127·C_R·log10[3.17e8·w/(ν0·V_s·V_e²)] (US units inside, as published).
    """
    w = np.asarray(load_per_width, float) * LBF_PER_IN_PER_N_PER_M
    vs = np.asarray(sliding, float) * IN_PER_M
    ve = np.asarray(entrainment, float) * IN_PER_M
    c_r = 50.0 / (50.0 - roughness * UIN_PER_M)
    with np.errstate(divide="ignore"):
        return 0.0127 * c_r * np.log10(3.17e8 * w / (viscosity_cst * vs * ve * ve))


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

    Returns
    -------
    mu : ndarray
        μ_eff: the tangential force on the disc is μ_eff·F (module doc).
    groove : ndarray of bool
        True where the pin rolls on the tooth and slides in its groove.
    """
    cos_beta = np.asarray(cos_beta, float)
    mesh = np.full(cos_beta.shape, float(friction.mesh))
    groove = friction.groove * cos_beta
    if friction.lubricant is not None and force is not None:
        lub = friction.lubricant
        speed = np.abs(np.asarray(velocity, float)) * friction.speed
        f = np.asarray(force, float)
        loaded = (f > 0) & (speed > 0)
        w = np.where(loaded, f, 1.0) / width
        v = np.where(loaded, speed, 1.0)
        mu_tooth = benedict_kelley(w, v, v, lub.viscosity, lub.roughness)
        mu_groove = benedict_kelley(w * cos_beta, v, v, lub.viscosity, lub.roughness)
        mesh = np.where(loaded, np.clip(mu_tooth, 0.0, mesh), mesh)
        groove = np.where(loaded, np.clip(mu_groove, 0.0, friction.groove) * cos_beta, groove)
    if friction.pins == "fixed":
        return mesh, np.zeros(mesh.shape, bool)
    slides_in_groove = groove < mesh
    return np.where(slides_in_groove, groove, mesh), slides_in_groove


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
