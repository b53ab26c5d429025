"""A cylindrical (needle) roller set with radial clearance: load distribution, stiffness, life.

The crank bearing of an RV stage is a set of Z needle rollers running directly on the crank
pin and in the disc's crank hole. Under a relative displacement s of the two raceways
(hole centre from pin centre, a vector of magnitude s) roller j, at the angle ψ_j from the
displacement, is compressed by (Harris & Kotzalas [1], Ch. 7, load distribution)

    δ_j = s·cos ψ_j − P_d/2,          Q_j = K_n·δ_j^(10/9) for δ_j > 0, else 0,

with P_d the radial internal clearance (the free radial travel of one raceway against the
other, ISO 5753-1; Harris's "diametral clearance"). K_n is the load–deflection constant of
a roller between two raceways from Palmgren's line-contact formula for steel [1, Ch. 6]

    δ [mm] = 3.84·10⁻⁵ · Q^0.9 [N] / l^0.8 [mm]          (one raceway contact),

two contacts in series per roller. The rollers are taken symmetric about the displacement,
one on its line (ψ_j = 2πj/Z; Harris's convention), so the set is isotropic: its force is
F(s) = Σ_j Q_j cos ψ_j along the displacement. The integral limit (Z → ∞) of this sum is
Sjövall's load distribution integral J_r(ε) (Harris [1], Table 7.1), F = Z·Q_max·J_r(ε);
with no clearance Q_max = 4.08·F/Z (Stribeck–Palmgren, line contact).

Life (ISO 281:2007 [2]): the basic dynamic load rating of the roller set,

    C_r = b_m · f_c · (i·L_we·cos α)^(7/9) · Z^(3/4) · D_we^(29/27)     [N, mm],

f_c from the ISO 281 table of radial roller bearings (linear interpolation in
D_we·cos α/D_pw), the equivalent load over a revolution for a varying load
P = (mean of F^p)^(1/p), and L10 = (C_r/P)^p million revolutions with p = 10/3.

All functions take SI units (m, N) unless a name says otherwise.

References
----------
[1] T. A. Harris, M. N. Kotzalas, *Rolling Bearing Analysis*, 5th ed. (Essential Concepts of
    Bearing Technology), CRC Press 2007: Ch. 6 (Palmgren's line-contact deflection), Ch. 7
    (distribution of internal loading, Table 7.1 J_r(ε) for line contact).
[2] ISO 281:2007, Rolling bearings — Dynamic load ratings and rating life, 7.1.1 (C_r of
    radial roller bearings, table of f_c, b_m), 7.2 (P_r), 6 (L10 = (C/P)^p, p = 10/3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import ConvergenceError, DesignError
from cyclomesh.stage.kernel import compiled, roller_law

__all__ = [
    "RollerSet",
    "TaperedRollerBearing",
    "LOAD_EXPONENT",
    "LIFE_EXPONENT",
    "PALMGREN_LINE_CONTACT",
    "roller_constant",
    "roller_loads",
    "radial_force",
    "radial_stiffness",
    "radial_energy",
    "radial_law",
    "deflection_for_force",
    "fc_table",
    "dynamic_load_rating",
    "equivalent_load",
    "rating_life",
    "life_hours",
]

FloatArray = NDArray[np.float64]

LOAD_EXPONENT = 10.0 / 9.0
"""Exponent of Q = K·δ^(10/9), line contact (Harris & Kotzalas, Ch. 7)."""
LIFE_EXPONENT = 10.0 / 3.0
"""Life exponent p of roller bearings (ISO 281:2007, 6)."""
PALMGREN_LINE_CONTACT = 3.84e-5
"""Palmgren: δ [mm] = 3.84e-5·Q^0.9/l^0.8 per steel line contact (Q in N, l in mm)."""

# ISO 281:2007, f_c of radial roller bearings against D_we·cos α / D_pw (linear interpolation)
# (the table's first 30 rows, 0.01 to 0.30, the range of crank bearings; each agrees within
# its rounding (0.05) with the closed form of ISO/TR 1281-1 with λ·ν = 0.83, tested)
_FC_RATIO = np.round(np.arange(1, 31) * 0.01, 2)
_FC = np.array(
    [
        52.1, 60.8, 66.5, 70.7, 74.1, 76.9, 79.2, 81.2, 82.8, 84.2,
        85.4, 86.4, 87.1, 87.7, 88.2, 88.5, 88.7, 88.8, 88.8, 88.7,
        88.5, 88.2, 87.9, 87.5, 87.0, 86.4, 85.8, 85.2, 84.5, 83.8,
    ]
)  # fmt: skip


def fc_table() -> tuple[FloatArray, FloatArray]:
    """ISO 281:2007 table of f_c for radial roller bearings: (D_we·cos α/D_pw, f_c)."""
    return _FC_RATIO.copy(), _FC.copy()


@dataclass(frozen=True)
class RollerSet:
    """A radial set of cylindrical or needle rollers between two raceways, SI units.

    Parameters
    ----------
    rollers : int
        Number of rollers Z.
    diameter : float
        Roller diameter D_we [m].
    length : float
        Effective (contact) length of a roller L_we [m].
    clearance : float
        Radial internal clearance P_d [m] ≥ 0: the free radial travel of one raceway
        against the other (ISO 5753-1), from one extreme to the opposite one.
    pitch_diameter : float
        D_pw [m]: diameter of the circle through the roller centres (crank hole diameter
        minus D_we).
    dynamic_load_rating : float, optional
        C_r [N] from a catalogue; overrides the ISO 281 value from the geometry.
    rating_factor : float
        b_m of ISO 281 (1.1 for needle and cylindrical roller bearings with machined
        raceways; 1.0 for drawn cups).
    """

    rollers: int
    diameter: float
    length: float
    clearance: float
    pitch_diameter: float
    dynamic_load_rating: float | None = None
    rating_factor: float = 1.1

    def __post_init__(self) -> None:
        if isinstance(self.rollers, bool) or not isinstance(self.rollers, int | np.integer):
            raise DesignError(
                f"stage.crank_bearing.rollers must be a whole number, got {self.rollers!r}"
            )
        if self.rollers < 3:
            raise DesignError(
                f"stage.crank_bearing.rollers: at least 3 rollers, got {self.rollers}"
            )
        for name, value in (
            ("roller_diameter", self.diameter),
            ("roller_length", self.length),
            ("pitch_diameter", self.pitch_diameter),
        ):
            if not (math.isfinite(value) and value > 0):
                raise DesignError(f"stage.crank_bearing.{name} must be positive, got {value!r}")
        if not (math.isfinite(self.clearance) and self.clearance >= 0):
            raise DesignError(
                f"stage.crank_bearing.radial_clearance must be ≥ 0, got {self.clearance!r}"
            )
        if self.pitch_diameter <= self.diameter:
            raise DesignError(
                "stage.crank_bearing: the roller diameter must be below the pitch diameter "
                f"({self.diameter * 1e3:.4g} mm ≥ {self.pitch_diameter * 1e3:.4g} mm)"
            )
        if math.pi * self.pitch_diameter < self.rollers * self.diameter * (1 - 1e-12):
            raise DesignError(
                f"stage.crank_bearing: {self.rollers} rollers of {self.diameter * 1e3:.4g} mm "
                f"do not fit on the pitch circle of {self.pitch_diameter * 1e3:.4g} mm "
                f"(at most {int(math.pi * self.pitch_diameter / self.diameter)})"
            )
        if self.dynamic_load_rating is not None and not (
            math.isfinite(self.dynamic_load_rating) and self.dynamic_load_rating > 0
        ):
            raise DesignError("stage.crank_bearing.dynamic_load_rating_kn must be positive")

    @property
    def constant(self) -> float:
        """K_n of Q = K_n·δ^(10/9) for one roller between both raceways [N/m^(10/9)]."""
        return roller_constant(self.length)

    @property
    def angles(self) -> FloatArray:
        """Roller angles ψ_j = 2πj/Z from the displacement [rad], (Z,)."""
        return 2.0 * np.pi * np.arange(self.rollers) / self.rollers

    def rating(self) -> float:
        """C_r [N]: the catalogue value if given, else ISO 281 from the geometry."""
        if self.dynamic_load_rating is not None:
            return float(self.dynamic_load_rating)
        return dynamic_load_rating(
            self.rollers, self.diameter, self.length, self.pitch_diameter, self.rating_factor
        )


def roller_constant(length: float) -> float:
    """K_n [N/m^(10/9)] of one roller between two steel raceways (Harris & Kotzalas, Ch. 6–7).

    Palmgren per contact: δ = 3.84e-5·Q^0.9/l^0.8 (mm, N); two equal contacts in series
    give δ = 2·3.84e-5·Q^0.9/l^0.8, i.e. Q = K_n·δ^(10/9) with δ in m.
    """
    length_mm = length * 1e3
    return (1e3 * length_mm**0.8 / (2.0 * PALMGREN_LINE_CONTACT)) ** LOAD_EXPONENT


@dataclass(frozen=True)
class TaperedRollerBearing:
    """One of a crankshaft's two support bearings: a tapered roller bearing of a pair
    preloaded against each other (back to back, as in RV reducers), SI units.

    Model (Harris & Kotzalas [1], Ch. 6 and 7, with the line-contact law of
    :func:`roller_constant`): the axial preload F_a0 loads every roller alike,

        Q_0 = F_a0/(Z·sin α),          δ_0 = (Q_0/K_n)^(9/10),

    δ_0 the roller's normal approach of both raceways. A small radial displacement δ_r
    of the cone against the cup compresses roller j (at ψ_j = 2πj/Z from the
    displacement) by δ_r·cos α·cos ψ_j along its contact normal; the rollers' axial
    components cancel to first order (Σ cos ψ_j = 0), so the preload holds the shaft
    axially and the radial tangent stiffness of the bearing is

        k_r = K'·cos²α·Σ_j cos²ψ_j = (Z/2)·(10/9)·(Q_0/δ_0)·cos²α          [N/m]

    (Σ cos²ψ_j = Z/2 for Z ≥ 3). Assumptions, stated where the key is documented
    (docs/stage.md): one contact angle α for cone and cup (their mean), the rib contact
    and the rollers' tilt neglected (the crankshaft is a beam simply supported on radial
    springs: no moment stiffness), and the stiffness is the tangent at the preload, which
    holds while the radial load stays below :meth:`linear_limit`.

    Parameters
    ----------
    rollers : int
        Number of rollers Z (≥ 3).
    length : float
        Effective contact length of a roller l_we [m].
    contact_angle : float
        Contact angle α of the raceways against the radial plane [rad], in (0, π/2).
    preload : float
        Axial preload F_a0 of the pair [N] (each bearing carries it).
    """

    rollers: int
    length: float
    contact_angle: float
    preload: float

    def __post_init__(self) -> None:
        where = "stage.crankshaft.support_bearing"
        if isinstance(self.rollers, bool) or not isinstance(self.rollers, int | np.integer):
            raise DesignError(f"{where}.rollers must be a whole number, got {self.rollers!r}")
        if self.rollers < 3:
            raise DesignError(f"{where}.rollers: at least 3 rollers, got {self.rollers}")
        for name, value in (("roller_length_mm", self.length), ("preload_n", self.preload)):
            if not (math.isfinite(value) and value > 0):
                raise DesignError(f"{where}.{name} must be positive, got {value!r}")
        if not (math.isfinite(self.contact_angle) and 0.0 < self.contact_angle < 0.5 * math.pi):
            raise DesignError(
                f"{where}.contact_angle_deg must lie strictly between 0 and 90 degrees, got "
                f"{math.degrees(self.contact_angle)!r}"
            )

    def roller_load(self) -> float:
        """Q_0 = F_a0/(Z·sin α) [N]: each roller's load under the preload alone."""
        return self.preload / (self.rollers * math.sin(self.contact_angle))

    def approach(self) -> float:
        """δ_0 = (Q_0/K_n)^(9/10) [m]: each roller's normal approach under the preload."""
        return (self.roller_load() / roller_constant(self.length)) ** (1.0 / LOAD_EXPONENT)

    def radial_stiffness(self) -> float:
        """k_r = (Z/2)·(10/9)·(Q_0/δ_0)·cos²α [N/m]: the radial tangent stiffness at the
        preload (Harris & Kotzalas [1], Ch. 7; see the class)."""
        normal = LOAD_EXPONENT * self.roller_load() / self.approach()
        return 0.5 * self.rollers * normal * math.cos(self.contact_angle) ** 2

    def linear_limit(self) -> float:
        """Radial load [N] at which the tangent model unloads the roller opposite the load
        (δ_r·cos α = δ_0): above it the spring is outside its range (a warning says so)."""
        return self.radial_stiffness() * self.approach() / math.cos(self.contact_angle)


def _compressions(rs: RollerSet, s: ArrayLike) -> FloatArray:
    """δ_j = s·cos ψ_j − P_d/2 ≥ 0 [m], shape (..., Z)."""
    s = np.asarray(s, float)[..., None]
    return np.maximum(s * np.cos(rs.angles) - 0.5 * rs.clearance, 0.0)


def roller_loads(rs: RollerSet, s: ArrayLike) -> FloatArray:
    """Load Q_j on every roller [N], shape (..., Z), for the raceway displacement s [m] ≥ 0."""
    return rs.constant * _compressions(rs, s) ** LOAD_EXPONENT


def radial_force(rs: RollerSet, s: ArrayLike) -> FloatArray:
    """F(s) = Σ Q_j cos ψ_j [N]: the force of the set along the displacement s [m]."""
    return np.sum(roller_loads(rs, s) * np.cos(rs.angles), axis=-1)


def radial_stiffness(rs: RollerSet, s: ArrayLike) -> FloatArray:
    """dF/ds = Σ (10/9)·K_n·δ_j^(1/9)·cos² ψ_j [N/m]."""
    d = _compressions(rs, s)
    c = np.cos(rs.angles)
    return np.sum(LOAD_EXPONENT * rs.constant * d ** (LOAD_EXPONENT - 1.0) * c * c, axis=-1)


def radial_energy(rs: RollerSet, s: ArrayLike) -> FloatArray:
    """Strain energy of the set, ∫F ds = Σ K_n·δ_j^(19/9)/(19/9) [J]."""
    d = _compressions(rs, s)
    return np.sum(rs.constant * d ** (LOAD_EXPONENT + 1.0), axis=-1) / (LOAD_EXPONENT + 1.0)


def radial_law(
    rs: RollerSet, s: ArrayLike, stiffness: bool = True
) -> tuple[FloatArray, FloatArray | None, FloatArray]:
    """(:func:`radial_force`, :func:`radial_stiffness`, :func:`radial_energy`) at once.

    The compressions δ_j are formed once and the powers taken on the loaded rollers only
    (an unloaded roller adds an exact 0): every element, and so every sum, is the same
    arithmetic as the three functions'. The stiffness is None if not ``stiffness``. With
    ``CYCLOMESH_KERNEL=numba`` the compiled :func:`cyclomesh.stage.kernel.roller_law`
    (the same law to round-off).
    """
    if compiled():  # CYCLOMESH_KERNEL=numba: one pass, one power a loaded roller
        return roller_law(np.cos(rs.angles), 0.5 * rs.clearance, rs.constant, s, stiffness)
    d = _compressions(rs, s)
    c = np.cos(rs.angles)
    loaded = d > 0.0
    dl = d[loaded]

    def power(exponent: float) -> FloatArray:
        out = np.zeros_like(d)
        out[loaded] = dl**exponent
        return out

    force = np.sum(rs.constant * power(LOAD_EXPONENT) * c, axis=-1)
    stiff = None
    if stiffness:
        stiff = np.sum(LOAD_EXPONENT * rs.constant * power(LOAD_EXPONENT - 1.0) * c * c, axis=-1)
    energy = np.sum(rs.constant * power(LOAD_EXPONENT + 1.0), axis=-1) / (LOAD_EXPONENT + 1.0)
    return force, stiff, energy


def deflection_for_force(rs: RollerSet, force: ArrayLike) -> FloatArray:
    """The displacement s [m] at which the set carries ``force`` [N] ≥ 0 (inverse of F(s)).

    F is convex and increasing beyond P_d/2, so Newton's method started from the
    roller-on-line bound s = P_d/2 + (F/K_n)^(9/10) (an upper bound: that roller alone
    would carry F) decreases monotonically onto the root; it stops at round-off.
    """
    force = np.asarray(force, float)
    s = 0.5 * rs.clearance + (np.maximum(force, 0.0) / rs.constant) ** (1.0 / LOAD_EXPONENT)
    for _ in range(100):
        resid = radial_force(rs, s) - force
        if np.all(np.abs(resid) <= 1e-13 * np.maximum(force, 1e-300)):
            return s
        k = radial_stiffness(rs, s)
        s = np.where(force > 0, s - resid / np.where(k > 0, k, np.inf), 0.5 * rs.clearance)
    raise ConvergenceError("deflection_for_force: Newton's method did not reach round-off")


def dynamic_load_rating(
    rollers: int, diameter: float, length: float, pitch_diameter: float, rating_factor: float = 1.1
) -> float:
    """Basic dynamic radial load rating C_r of a roller set [N] (ISO 281:2007, 7.1.1).

    C_r = b_m·f_c·(i·L_we·cos α)^(7/9)·Z^(3/4)·D_we^(29/27) with N, mm; here i = 1 row,
    α = 0, f_c interpolated linearly in the ISO table at D_we/D_pw.

    Raises
    ------
    DesignError
        If D_we/D_pw lies outside the table (0.01 to 0.50).
    """
    ratio = diameter / pitch_diameter
    if not (_FC_RATIO[0] <= ratio <= _FC_RATIO[-1]):
        raise DesignError(
            f"stage.crank_bearing: D_we/D_pw = {ratio:.3g} lies outside the ISO 281 table "
            "range used here (0.01 to 0.30); give dynamic_load_rating_kn"
        )
    fc = float(np.interp(ratio, _FC_RATIO, _FC))
    return (
        rating_factor
        * fc
        * (length * 1e3) ** (7.0 / 9.0)
        * rollers**0.75
        * (diameter * 1e3) ** (29.0 / 27.0)
    )


def equivalent_load(load: ArrayLike, axis: int = -1) -> FloatArray:
    """Equivalent dynamic load over a revolution [N] (ISO 281:2007, variable load).

    P = (mean of F^p)^(1/p), p = 10/3, the mean taken over ``axis`` (uniformly spaced
    crank angles of whole revolutions or mesh cycles).
    """
    f = np.abs(np.asarray(load, float))
    return np.mean(f**LIFE_EXPONENT, axis=axis) ** (1.0 / LIFE_EXPONENT)


def rating_life(rating: ArrayLike, load: ArrayLike) -> FloatArray:
    """Basic rating life L10 = (C/P)^(10/3) [million revolutions] (ISO 281:2007, 6)."""
    with np.errstate(divide="ignore"):
        return (np.asarray(rating, float) / np.asarray(load, float)) ** LIFE_EXPONENT


def life_hours(life: ArrayLike, speed_rpm: float) -> FloatArray:
    """L10h = 10⁶·L10/(60·n) [h], for L10 in million revolutions at n [rev/min]."""
    return np.asarray(life, float) * 1e6 / (60.0 * speed_rpm)
