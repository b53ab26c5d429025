"""Design objects of a cycloid-pin gear pair: geometry, materials, modification, errors.

All quantities are SI (metres, radians, pascals). The symbols follow Table 1 of [1];
see ``docs/glossary.md`` for the full nomenclature.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, "Design and Load Distribution Analysis of the
    Mismatched Cycloid-Pin Gear Pair in RV Speed Reducers", Machines 10 (2022) 672,
    doi:10.3390/machines10080672.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.exceptions import DesignError

if TYPE_CHECKING:
    from cyclomesh.core.deviation import ProfileDeviation

__all__ = [
    "Material",
    "STEEL",
    "PairDesign",
    "CrankHoles",
    "Modification",
    "PinErrors",
    "TABLE1",
    "check_physical",
    "YOUNGS_MODULUS_RANGE",
    "POISSON_RATIO_RANGE",
    "check_bore",
]


YOUNGS_MODULUS_RANGE = (0.1e9, 1200e9)
"""Young's moduli accepted [Pa]: from soft polymers to diamond."""

POISSON_RATIO_RANGE = (0.0, 0.5)
"""Poisson's ratios accepted [-]: [0, 0.5) (auxetic materials make no gears)."""

MIN_SHORT_AMPLITUDE = 0.05
"""Smallest K1 = e·n1/a accepted (cycloid drives use about 0.5 to 0.9)."""

ECCENTRICITY_ERROR_FRACTION = 0.5
"""|εe| must stay below this fraction of e: the disc centre stays off the crank axis."""

ANGLE_PITCH_FRACTION = 0.1
"""|δ| and |εψ,i| must stay below this fraction of the tooth pitch 2π/n2: they are
small corrections and errors, not a re-indexing of the teeth."""


@dataclass(frozen=True)
class Material:
    """Isotropic elastic material.

    Parameters
    ----------
    youngs_modulus : float
        Young's modulus E [Pa].
    poisson_ratio : float
        Poisson's ratio ν [-], in (-1, 0.5).
    """

    youngs_modulus: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        lo, hi = YOUNGS_MODULUS_RANGE
        if not (math.isfinite(self.youngs_modulus) and lo <= self.youngs_modulus <= hi):
            raise DesignError(
                f"youngs_modulus_gpa = {self.youngs_modulus / 1e9:.6g}: expected "
                f"{lo / 1e9:g} to {hi / 1e9:g} GPa (polymers to diamond)"
            )
        lo, hi = POISSON_RATIO_RANGE
        if not (lo <= self.poisson_ratio < hi):
            raise DesignError(
                f"poisson_ratio = {self.poisson_ratio:.6g}: expected {lo:g} to below {hi:g} "
                "(engineering materials)"
            )

    @property
    def compliance(self) -> float:
        """(1 − ν²)/E [1/Pa], the plane-strain compliance of Eqs. 20–23 in [1]."""
        return (1.0 - self.poisson_ratio**2) / self.youngs_modulus


STEEL = Material(youngs_modulus=206e9, poisson_ratio=0.3)
"""Steel of Table 1 in [1]: E = 206 GPa, ν = 0.3."""


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise DesignError(f"{name} must be a positive finite number, got {value!r}")


@dataclass(frozen=True)
class PairDesign:
    """Nominal geometry and materials of a cycloid-pin gear pair (Table 1 of [1]).

    Parameters
    ----------
    pins : int
        Number of ring pins n1 [-]; the disc has n2 = n1 − 1 teeth.
    pin_circle_radius : float
        Pin-centre circle radius a [m].
    pin_radius : float
        Pin radius ρp [m].
    groove_radius : float
        Radius ρg of the pin's semicircular seat in the ring [m]; must exceed ρp.
    eccentricity : float
        Crank eccentricity e [m].
    width : float
        Face width B of the disc [m].
    pin_material, disc_material, ring_material : Material
        Elastic constants of pins, disc and ring (default: steel of Table 1).

    Raises
    ------
    DesignError
        For non-positive sizes, K1 = e·n1/a ≥ 1 (looped locus), pins that overlap
        each other, or a groove not larger than the pin.
    """

    pins: int
    pin_circle_radius: float
    pin_radius: float
    groove_radius: float
    eccentricity: float
    width: float
    pin_material: Material = STEEL
    disc_material: Material = STEEL
    ring_material: Material = STEEL

    def __post_init__(self) -> None:
        if not isinstance(self.pins, int | np.integer) or self.pins < 3:
            raise DesignError(f"pins must be an integer of at least 3, got {self.pins!r}")
        for name in ("pin_circle_radius", "pin_radius", "groove_radius", "eccentricity", "width"):
            _positive(name, getattr(self, name))
        k1, n1 = self.short_amplitude_coefficient, int(self.pins)
        a_mm, e_mm = self.pin_circle_radius * 1e3, self.eccentricity * 1e3
        keys = (
            f"design.eccentricity_mm = {e_mm:.6g}, design.pins = {n1} and "
            f"design.pin_circle_radius_mm = {a_mm:.6g} give K1 = e·n1/a = {k1:.4g}"
        )
        if k1 >= 1.0:
            raise DesignError(
                f"{keys}; it must be below 1 (the pin-centre locus would loop): raise "
                f"design.pin_circle_radius_mm above {e_mm * n1:.6g}, or lower "
                f"design.eccentricity_mm below {a_mm / n1:.6g} or design.pins below "
                f"{self.pin_circle_radius / self.eccentricity:.6g}"
            )
        if k1 < MIN_SHORT_AMPLITUDE:
            raise DesignError(
                f"{keys}; it must be at least {MIN_SHORT_AMPLITUDE:g} (a cycloid disc, not a "
                f"circle): lower design.pin_circle_radius_mm to at most "
                f"{e_mm * n1 / MIN_SHORT_AMPLITUDE:.6g}, or raise design.eccentricity_mm to at "
                f"least {MIN_SHORT_AMPLITUDE * a_mm / n1:.6g}"
            )
        half_pitch_chord = self.pin_circle_radius * math.sin(math.pi / self.pins)
        if self.pin_radius >= half_pitch_chord:
            raise DesignError(
                f"design.pin_radius_mm = {self.pin_radius * 1e3:.6g}: neighbouring pins "
                f"interfere; it must be below a·sin(π/n1) = {half_pitch_chord * 1e3:.6g} mm "
                "(or raise design.pin_circle_radius_mm, or lower design.pins)"
            )
        if self.groove_radius <= self.pin_radius:
            raise DesignError(
                f"design.groove_radius_mm = {self.groove_radius * 1e3:.6g} must exceed "
                f"design.pin_radius_mm = {self.pin_radius * 1e3:.6g} (the groove seats the pin)"
            )
        if self.groove_radius >= half_pitch_chord:
            raise DesignError(
                f"design.groove_radius_mm = {self.groove_radius * 1e3:.6g}: neighbouring pin "
                f"grooves overlap in the ring; it must be below a·sin(π/n1) = "
                f"{half_pitch_chord * 1e3:.6g} mm (the groove seats the pin with a small "
                "clearance)"
            )
        if self.eccentricity >= self.pin_circle_radius:
            raise DesignError("eccentricity must be smaller than pin_circle_radius")

    @property
    def teeth(self) -> int:
        """Number of disc teeth n2 = n1 − 1 [-]."""
        return int(self.pins) - 1

    @property
    def pitch(self) -> float:
        """Angular pin pitch ψ = 2π/n1 [rad]."""
        return 2.0 * math.pi / self.pins

    @property
    def short_amplitude_coefficient(self) -> float:
        """K1 = e·n1/a [-]."""
        return self.eccentricity * self.pins / self.pin_circle_radius


@dataclass(frozen=True)
class CrankHoles:
    """The crank holes of the disc: where it is held, and where the crankshafts run.

    One set of holes serves both the compliant disc (the disc body is held at the hole
    centres) and the RV stage (each hole carries one crankshaft's crank bearing). Hole k
    (k = 0 … N − 1) is centred at radius ``circle_radius`` and polar angle 2πk/N in the
    disc's own frame (the frame in which Eq. 1 of [1] writes the profile).

    Parameters
    ----------
    count : int
        Number N of crank holes (crankshafts) [-], 2 or more.
    circle_radius : float
        Radius of the circle through the hole centres, r_c [m].
    radius : float
        Radius of each hole (the outer raceway of its crank bearing) [m].

    Raises
    ------
    DesignError
        For N < 2, non-positive sizes, or holes that overlap each other or the disc
        centre. :meth:`check_fits` also checks them against the tooth root.
    """

    count: int
    circle_radius: float
    radius: float

    def __post_init__(self) -> None:
        if not isinstance(self.count, int | np.integer) or not 2 <= self.count <= 12:
            raise DesignError(
                f"design.disc.crank_holes: expected 2 to 12 holes, got {self.count!r}"
            )
        _positive("design.disc.crank_hole_circle_radius", self.circle_radius)
        _positive("design.disc.crank_hole_radius", self.radius)
        if self.radius >= self.circle_radius:
            raise DesignError(
                f"design.disc.crank_hole_radius_mm {self.radius * 1e3:.4g} must be below "
                f"crank_hole_circle_radius_mm {self.circle_radius * 1e3:.4g} "
                "(the holes would cut the disc centre)"
            )
        half_chord = self.circle_radius * math.sin(math.pi / self.count)
        if self.radius >= half_chord:
            raise DesignError(
                f"design.disc.crank_hole_radius_mm {self.radius * 1e3:.4g}: neighbouring "
                f"crank holes overlap; it must be below r_c·sin(π/N) = {half_chord * 1e3:.4g}"
            )

    @property
    def angles(self) -> NDArray[np.float64]:
        """Polar angles 2πk/N of the hole centres in the disc frame [rad], shape (N,)."""
        return 2.0 * np.pi * np.arange(self.count) / self.count

    @property
    def centres(self) -> NDArray[np.float64]:
        """Hole centres (x, y) in the disc frame [m], shape (N, 2)."""
        a = self.angles
        return self.circle_radius * np.stack([np.cos(a), np.sin(a)], axis=-1)

    def check_fits(self, design: PairDesign, margin: float = 0.0) -> None:
        """Raise :class:`DesignError` unless the holes stay inside the tooth root.

        The root radius of the unmodified disc is a − e − ρp [m]; the holes' outer edge
        r_c + r must stay at least ``margin`` [m] below it.
        """
        root = design.pin_circle_radius - design.eccentricity - design.pin_radius
        if self.circle_radius + self.radius + margin >= root:
            raise DesignError(
                "design.disc: the crank holes reach the tooth root: crank_hole_circle_radius"
                f"_mm + crank_hole_radius_mm = {(self.circle_radius + self.radius) * 1e3:.4g}"
                f" must be below a − e − ρp = {root * 1e3:.4g} mm"
            )


def check_bore(design: PairDesign, holes: CrankHoles | None, bore_radius: float) -> None:
    """Raise :class:`DesignError` unless the disc's central bore (radius [m]) stays clear
    of the crank holes (r_b < r_c − r) and inside the tooth root a − e − ρp."""
    root = design.pin_circle_radius - design.eccentricity - design.pin_radius
    if holes is not None and bore_radius >= holes.circle_radius - holes.radius:
        raise DesignError(
            f"design.disc.bore_radius_mm = {bore_radius * 1e3:.6g}: the bore cuts the crank "
            "holes; it must be below crank_hole_circle_radius_mm − crank_hole_radius_mm = "
            f"{(holes.circle_radius - holes.radius) * 1e3:.6g}"
        )
    if bore_radius >= root:
        raise DesignError(
            f"design.disc.bore_radius_mm = {bore_radius * 1e3:.6g}: the bore reaches the "
            f"tooth root; it must be below a − e − ρp = {root * 1e3:.6g} mm"
        )


TABLE1 = PairDesign(
    pins=40,
    pin_circle_radius=82e-3,
    pin_radius=3.5e-3,
    groove_radius=3.505e-3,
    eccentricity=1.5e-3,
    width=12e-3,
)
"""The example design of Table 1 in [1] (n1 = 40, a = 82 mm, ρp = 3.5 mm, ...)."""


@dataclass(frozen=True)
class Modification:
    """Tooth profile modification (TPM), Eq. 3 of [1].

    Parameters
    ----------
    pin_circle_radius : float
        Δa, change of the generating pin-circle radius [m] ("shift" modification;
        negative opens clearance).
    pin_radius : float
        Δρ, change of the generating pin radius [m] ("equidistant" modification;
        positive opens clearance).
    rotation : float
        δ, rotation-angle modification [rad] (Lin, Shih, Lee, Mech. Mach. Theory 2014):
        the loaded flanks are turned back by δ, which opens a uniform angular clearance.
        Positive opens clearance.
    profile : ProfileDeviation, optional
        Tabulated normal deviation d(φ1) of the profile (measured or designed), added to
        Δa, Δρ and δ (see :mod:`cyclomesh.core.deviation`).
    """

    pin_circle_radius: float = 0.0
    pin_radius: float = 0.0
    rotation: float = 0.0
    profile: ProfileDeviation | None = None

    def __post_init__(self) -> None:
        for name in ("pin_circle_radius", "pin_radius", "rotation"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise DesignError(f"modification {name} must be finite, got {value!r}")
        if self.profile is not None:
            from cyclomesh.core.deviation import ProfileDeviation  # SciPy only when used

            if not isinstance(self.profile, ProfileDeviation):
                raise DesignError("modification profile must be a ProfileDeviation or None")

    def mirrored(self) -> Modification:
        """The modification of the disc mirrored about its x-axis (reverse flank forward)."""
        if self.profile is None:
            return self
        return Modification(
            self.pin_circle_radius, self.pin_radius, self.rotation, self.profile.mirrored()
        )


def _as_errors(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise DesignError(f"errors.{name} must be finite numbers")
    return arr


@dataclass(frozen=True)
class PinErrors:
    """Manufacturing and assembly errors of the pin ring (Eq. 5 of [1]).

    Each per-pin field broadcasts to shape ``(..., n1)``: a scalar applies to every pin,
    and leading axes stand for several rings solved at once. ``eccentricity`` broadcasts
    to the leading shape ``(...)``.

    Parameters
    ----------
    radial : array_like
        εa,i, radial position error of pin i [m], positive outwards.
    angular : array_like
        εψ,i, angular position error of pin i [rad], positive counter-clockwise.
    pin_radius : array_like
        ερ,i, pin radius error [m].
    eccentricity : array_like
        εe, eccentricity error [m].
    """

    radial: ArrayLike = 0.0
    angular: ArrayLike = 0.0
    pin_radius: ArrayLike = 0.0
    eccentricity: ArrayLike = 0.0

    def __post_init__(self) -> None:
        for name in ("radial", "angular", "pin_radius", "eccentricity"):
            object.__setattr__(self, name, _as_errors(name, getattr(self, name)))

    def ring_shape(self, pins: int) -> tuple[int, ...]:
        """Leading (ring) shape of these errors for a ring of ``pins`` pins."""
        shapes = []
        for name in ("radial", "angular", "pin_radius"):
            arr = getattr(self, name)
            if arr.ndim and arr.shape[-1] not in (1, pins):
                raise DesignError(
                    f"errors.{name} has {arr.shape[-1]} values per ring; "
                    f"expected {pins} (one per pin)"
                )
            shapes.append(arr.shape[:-1] if arr.ndim else ())
        shapes.append(np.shape(self.eccentricity))
        try:
            return tuple(np.broadcast_shapes(*shapes))
        except ValueError as exc:
            raise DesignError(f"error arrays have incompatible ring shapes {shapes}") from exc


def check_physical(design: PairDesign, modification: Modification, errors: PinErrors) -> None:
    """Refuse modifications and errors outside the physics of the model.

    - |εe| < e/2 (so e + εe > e/2 > 0) and K1 = (e + εe)·n1/a < 1 [m];
    - |δ| and |εψ,i| below a tenth of the tooth pitch 2π/n2 [rad];
    - |εa,i|, |Δa| and |Δρ| below the pin radius ρp [m].

    Raises
    ------
    DesignError
        Naming the key and the bound (in study units: µm, µrad).
    """
    e = design.eccentricity
    ecc = np.asarray(errors.eccentricity, float)
    bound = ECCENTRICITY_ERROR_FRACTION * e
    if ecc.size and np.max(np.abs(ecc)) >= bound:
        worst = float(ecc.flat[int(np.argmax(np.abs(ecc)))])
        raise DesignError(
            f"errors.eccentricity_um = {worst * 1e6:.6g}: the eccentricity error must stay "
            f"within ±e/2 = ±{bound * 1e6:.6g} µm (e + εe must stay well above 0)"
        )
    if ecc.size and (e + np.max(ecc)) * design.pins / design.pin_circle_radius >= 1.0:
        k1 = (e + float(np.max(ecc))) * design.pins / design.pin_circle_radius
        raise DesignError(
            f"errors.eccentricity_um: K1 = (e + εe)·n1/a = {k1:.4f} must be below 1 "
            "(reduce the eccentricity error)"
        )
    for key, value in (
        ("pin_circle_radius_um", modification.pin_circle_radius),
        ("pin_radius_um", modification.pin_radius),
    ):
        if not abs(value) < design.pin_radius:
            raise DesignError(
                f"modification.{key} = {value * 1e6:.6g}: it must stay below the pin radius, "
                f"{design.pin_radius * 1e6:.6g} µm in size (a modification is a small change)"
            )
    limit = ANGLE_PITCH_FRACTION * 2.0 * math.pi / design.teeth
    if not abs(modification.rotation) < limit:
        raise DesignError(
            f"modification.rotation_urad = {modification.rotation * 1e6:.6g}: |δ| must stay "
            f"below a tenth of the tooth pitch 2π/n2, {limit * 1e6:.6g} µrad"
        )
    angular = np.asarray(errors.angular, float)
    if angular.size and not np.max(np.abs(angular)) < limit:
        raise _pin_error(
            "angular_urad",
            angular,
            f"|εψ| up to {np.max(np.abs(angular)) * 1e6:.6g} µrad; it must stay below a tenth "
            f"of the pin pitch, {limit * 1e6:.6g} µrad",
        )
    radius = np.asarray(errors.pin_radius, float)
    # (relative margin: ερ = −ρp written in µm converts to a hair below ρp in metres)
    if radius.size and not np.max(np.abs(radius)) < design.pin_radius * (1.0 - 1e-9):
        worst = float(radius.flat[int(np.argmax(np.abs(radius)))])
        raise _pin_error(
            "pin_radius_um",
            radius,
            f"ερ = {worst * 1e6:.6g} µm; |ερ| must stay below the pin radius, "
            f"{design.pin_radius * 1e6:.6g} µm (a pin of radius ρp + ερ ≤ 0 does not exist)",
        )
    radial = np.asarray(errors.radial, float)
    if radial.size and not np.max(np.abs(radial)) < design.pin_radius:
        raise _pin_error(
            "radial_um",
            radial,
            f"|εa| up to {np.max(np.abs(radial)) * 1e6:.6g} µm; it must stay below the pin "
            f"radius, {design.pin_radius * 1e6:.6g} µm",
        )


def _pin_error(column: str, values: NDArray, why: str) -> DesignError:
    """``errors.<column>: <why>``, with the column and the pin (1 … n1) of the largest
    |value| as attributes ``column`` and ``pin``, so that a study can name the row of a
    measured-pins file that holds it."""
    values = np.asarray(values)
    index = np.unravel_index(int(np.argmax(np.abs(values))), values.shape)
    err = DesignError(f"errors.{column}: {why}")
    err.column = column  # type: ignore[attr-defined]
    err.pin = int(index[-1]) + 1 if values.ndim else None  # type: ignore[attr-defined]
    err.why = why  # type: ignore[attr-defined]
    return err


def pin_errors_si(
    radial_um: Any, angular_urad: Any, pin_radius_um: Any, eccentricity_um: Any
) -> PinErrors:
    """Core errors (SI) from µm, µrad, µm, µm, the units of study files (leading axes =
    rings).

    The one conversion of study-file errors, shared with the tolerance studies so that a
    ring written out as a study file reads back to bit-for-bit the same errors.
    """
    return PinErrors(
        radial=np.asarray(radial_um, float) * 1e-6,
        angular=np.asarray(angular_urad, float) * 1e-6,
        pin_radius=np.asarray(pin_radius_um, float) * 1e-6,
        eccentricity=np.asarray(eccentricity_um, float) * 1e-6,
    )
