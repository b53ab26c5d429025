"""The lubricated friction coefficient of the pin contacts (the ``[friction.lubricant]``
part of :mod:`cyclomesh.core.friction`): the oil (:class:`Lubricant`, ISO VG grades,
Walther's viscosity-temperature relation), Benedict and Kelley's coefficient
(:func:`benedict_kelley`), and the film parameter λ = h_c/σ of every contact from the
Dowson–Toyoda central film thickness (:func:`central_film_thickness`,
:func:`film_parameters`), whose regimes (:data:`MIXED_RANGE`, :func:`boundary_share`)
blend the boundary and the lubricated coefficient. SI units except the viscosities [cSt].

References
----------
[4] C. Benedict, B. W. Kelley, "Instantaneous coefficients of gear tooth friction",
    ASLE Trans. 4 (1961) 59–70 (as used in AGMA 925 and ISO/TR 14179-2 style models).
[5] ASTM D341: viscosity–temperature relation of petroleum oils (Walther's equation).
[7] D. Dowson, S. Toyoda, "A central film thickness formula for elastohydrodynamic line
    contacts", Proc. 5th Leeds-Lyon Symposium on Tribology (1979) 60–65: H_c =
    3.06·G^0.56·U^0.69·W^−0.1 (the Dowson–Higginson line-contact analysis).
[8] B. J. Hamrock, S. R. Schmid, B. O. Jacobson, Fundamentals of Fluid Film Lubrication,
    2nd ed., Marcel Dekker (2004): film parameter λ = h/σ, σ = √(σ1² + σ2²); boundary
    λ < 1, mixed 1 ≤ λ ≤ 3, full film λ > 3.

(numbered as in :mod:`cyclomesh.core.friction`.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError
from cyclomesh.units import IN_PER_M, LBF_PER_IN_PER_N_PER_M, UIN_PER_M

__all__ = [
    "ISO_VG",
    "MIN_VISCOSITY_CST",
    "Lubricant",
    "walther_viscosity",
    "benedict_kelley",
    "central_film_thickness",
    "MIXED_RANGE",
    "boundary_share",
    "Film",
    "film_parameters",
]

FloatArray = NDArray[np.float64]


MIN_VISCOSITY_CST = 2.0
"""Smallest kinematic viscosity [cSt] of Walther's equation in the form of
:func:`walther_viscosity` (ASTM D341 [5]: log log(ν + 0.7) holds from 2 cSt up; below, the
standard adds terms, and below 0.3 cSt the double logarithm does not exist)."""

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
        Mean arithmetic roughness Ra of the two surfaces [m] (Benedict–Kelley's S).
    composite_roughness : float, optional
        Composite roughness σ = √(σ1² + σ2²) of the two surfaces [m], the film parameter's
        λ = h_c/σ; None: √2·``roughness`` (two surfaces of that roughness).
    pressure_viscosity : float
        Pressure–viscosity coefficient α [1/Pa] (Barus; 2e-8 for a mineral gear oil).
    density : float
        Oil density [kg/m³] (dynamic viscosity η0 = ρ·ν).
    """

    viscosity_40: float
    viscosity_100: float
    temperature: float = 40.0
    roughness: float = 0.4e-6
    composite_roughness: float | None = None
    pressure_viscosity: float = 2.0e-8
    density: float = 880.0

    def __post_init__(self) -> None:
        if not (MIN_VISCOSITY_CST <= self.viscosity_100 < self.viscosity_40):
            raise DesignError(
                f"friction.lubricant: viscosity_100c_cst must be at least {MIN_VISCOSITY_CST:g} "
                "cSt (Walther's equation, ASTM D341) and below viscosity_40c_cst"
            )
        if not (-30.0 <= self.temperature <= 150.0):
            raise DesignError("friction.lubricant.temperature_c must lie in [−30, 150] °C")
        if not (0 <= self.roughness * UIN_PER_M < 40.0):
            raise DesignError(
                "friction.lubricant.roughness_um must be ≥ 0 and below 1 µm "
                "(the range of Benedict–Kelley's roughness factor)"
            )
        if self.composite_roughness is not None and not (
            math.isfinite(self.composite_roughness) and 0 < self.composite_roughness < 1e-5
        ):
            raise DesignError("friction.lubricant.composite_roughness_um must lie in (0, 10) µm")
        if not (0 < self.pressure_viscosity < 1e-7):
            raise DesignError(
                "friction.lubricant.pressure_viscosity_per_gpa must lie in (0, 100) 1/GPa"
            )
        if not (500.0 <= self.density <= 2000.0):
            raise DesignError("friction.lubricant.density_kg_m3 must lie in [500, 2000] kg/m³")

    @property
    def viscosity(self) -> float:
        """Kinematic viscosity at the oil temperature [cSt] (ASTM D341, [5])."""
        return float(walther_viscosity(self.viscosity_40, self.viscosity_100, self.temperature))

    @property
    def sigma(self) -> float:
        """Composite roughness σ of the film parameter [m]."""
        if self.composite_roughness is not None:
            return self.composite_roughness
        return math.sqrt(2.0) * self.roughness

    @property
    def dynamic_viscosity(self) -> float:
        """η0 = ρ·ν at the oil temperature [Pa·s]."""
        return self.density * self.viscosity * 1e-6


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


def central_film_thickness(
    load_per_width: ArrayLike,
    mean_speed: ArrayLike,
    radius: ArrayLike,
    viscosity: float,
    pressure_viscosity: float,
    modulus: ArrayLike,
) -> FloatArray:
    """Central film thickness of a lubricated line contact [m], Dowson & Toyoda [7]:

        h_c = 3.06·G^0.56·U^0.69·W^−0.1·R,
        U = η0·u/(E'·R),  G = α·E',  W = w/(E'·R),

    u the mean (entraining) speed (u1 + u2)/2, R the reduced radius of curvature, w the
    load per unit length, E' = 2/((1 − ν1²)/E1 + (1 − ν2²)/E2) (twice the E* of
    :func:`cyclomesh.core.hertz.effective_modulus`). Isothermal, fully flooded.

    Parameters
    ----------
    load_per_width : array_like
        w [N/m], > 0.
    mean_speed : array_like
        u [m/s], > 0.
    radius : array_like
        R [m], > 0.
    viscosity : float
        η0 at the oil temperature and ambient pressure [Pa·s].
    pressure_viscosity : float
        α [1/Pa].
    modulus : array_like
        E' [Pa].
    """
    e = np.asarray(modulus, float)
    r = np.asarray(radius, float)
    u = viscosity * np.asarray(mean_speed, float) / (e * r)
    w = np.asarray(load_per_width, float) / (e * r)
    return 3.06 * (pressure_viscosity * e) ** 0.56 * u**0.69 * w**-0.1 * r


MIXED_RANGE = (1.0, 3.0)
"""Film parameters λ bounding mixed lubrication: boundary below 1, full film above 3 (the
classical regimes, Hamrock [8], Ch. 1)."""


def boundary_share(film_parameter: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Weight of boundary friction in the mixed regime [-] and its derivative dw/dλ.

    1 below λ = 1, 0 above λ = 3, between them the smooth step 1 − (3t² − 2t³),
    t = (λ − 1)/2, continuous with its slope (the Newton step of the load sharing uses
    it). The smooth step is this model's interpolation between the regimes of [8], not a
    published fit: μ = w·μ_boundary + (1 − w)·μ_EHL (:func:`coefficients`).
    """
    lam = np.asarray(film_parameter, float)
    lo, hi = MIXED_RANGE
    t = np.minimum(np.maximum((lam - lo) * (1.0 / (hi - lo)), 0.0), 1.0)
    one_minus = 1.0 - t
    return 1.0 - t * t * (3.0 - 2.0 * t), (-6.0 / (hi - lo)) * t * one_minus


@dataclass(frozen=True)
class Film:
    """Geometry and elasticity of the pin contacts for the film thickness: reduced radii
    of pin–tooth and pin–groove (Eqs. 22, 23 of [1], :func:`cyclomesh.core.hertz.pin_tooth_radius`,
    :func:`~cyclomesh.core.hertz.pin_groove_radius`) [m], arrays broadcasting with the pins,
    and E' of each pair [Pa]; ``width`` the contact length B [m]."""

    tooth_radius: ArrayLike
    groove_radius: ArrayLike
    tooth_modulus: float
    groove_modulus: float
    width: float

    @classmethod
    def of_contacts(cls, design, pin_radius: ArrayLike, curvature_radius: ArrayLike) -> Film:
        """The film of a pair's pin contacts: ``design`` a
        :class:`~cyclomesh.core.pair.PairDesign` (groove radius, materials, width),
        ``pin_radius`` and the tooth's ``curvature_radius`` ρ of every contact [m]
        (Eqs. 22, 23 of [1]); E' = 2/((1 − ν1²)/E1 + (1 − ν2²)/E2) [Pa] of pin–disc and
        pin–ring."""
        from cyclomesh.core.hertz import pin_groove_radius, pin_tooth_radius

        def modulus(a, b) -> float:
            return 2.0 / (
                (1 - a.poisson_ratio**2) / a.youngs_modulus
                + (1 - b.poisson_ratio**2) / b.youngs_modulus
            )

        return cls(
            pin_tooth_radius(pin_radius, curvature_radius),
            pin_groove_radius(pin_radius, design.groove_radius),
            modulus(design.pin_material, design.disc_material),
            modulus(design.pin_material, design.ring_material),
            design.width,
        )


def film_parameters(
    lubricant: Lubricant,
    force: ArrayLike,
    speed: ArrayLike,
    cos_beta: ArrayLike,
    film: Film,
    tooth_radius: ArrayLike | None = None,
    groove_radius: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Film parameters λ = h_c/σ of the pin–tooth and the pin–groove contact [-]
    (:func:`central_film_thickness`, loads F and F·cos β per unit width, mean speed
    |v·t|·ω/2: one surface slides on the other standing still); 0 where the pin carries
    no load. ``tooth_radius``/``groove_radius`` override the film's (a subset of pins)."""
    f = np.asarray(force, float)
    v = np.asarray(speed, float)
    loaded = (f > 0) & (v > 0)
    w = np.where(loaded, f, 1.0) / film.width
    u = 0.5 * np.where(loaded, v, 1.0)
    rt = film.tooth_radius if tooth_radius is None else tooth_radius
    rg = film.groove_radius if groove_radius is None else groove_radius
    eta, alpha, sigma = lubricant.dynamic_viscosity, lubricant.pressure_viscosity, lubricant.sigma
    h_t = central_film_thickness(w, u, np.abs(rt), eta, alpha, film.tooth_modulus)
    h_g = central_film_thickness(w * cos_beta, u, np.abs(rg), eta, alpha, film.groove_modulus)
    return np.where(loaded, h_t / sigma, 0.0), np.where(loaded, h_g / sigma, 0.0)
