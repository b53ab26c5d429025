"""The sections of a case in a study file: ``[design]`` (``[design.disc]``),
``[modification]``, ``[material]``, ``[load]``, ``[errors]``, ``[analysis]``,
``[figures]`` and ``[requirements]``: strict pydantic models (:class:`StrictSection`),
every key with its unit (``docs/study-files.md``). The sections of the drive around the
mesh (``[friction]``, ``[stiffness]``, ``[stage]``) are
:mod:`cyclomesh.studyfile.drive_sections`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)

from cyclomesh.core.pair import (
    POISSON_RATIO_RANGE,
    YOUNGS_MODULUS_RANGE,
    CrankHoles,
    Material,
)
from cyclomesh.studyfile.limits import (
    MAX_ABS_CRANK_DEG,
    MAX_CRANK_ANGLES,
    MAX_DISCS,
    MAX_PINS,
    MAX_SEED,
    MIN_CRANK_STEP_DEG,
    count_crank_angles,
)
from cyclomesh.studyfile.messages import show
from cyclomesh.units import M_PER_MM, PA_PER_GPA

__all__ = [
    "tangential_urad",
    "StrictSection",
    "CrankDeg",
    "DiscSection",
    "DesignSection",
    "ModificationSection",
    "MaterialProperties",
    "MaterialSection",
    "LoadSection",
    "RandomErrorsSection",
    "ErrorsSection",
    "crank_angles_deg",
    "AnalysisSection",
    "FiguresSection",
    "RequirementsSection",
    "CASE_SECTIONS",
    "GROOVE_CLEARANCE_MM",
    "FE_BORE_FRACTION",
]

CASE_SECTIONS = (
    "design",
    "modification",
    "material",
    "load",
    "errors",
    "analysis",
    "stiffness",
    "stage",
    "friction",
)
"""Sections that a case may override."""


def tangential_urad(tangential_um: Any, pin_circle_radius_mm: float) -> NDArray:
    """Angular pin position error εψ,i [µrad] of a tangential one [µm]: t / a.

    µm over mm is 1e-3 rad, i.e. 1e3 µrad.
    """
    return np.asarray(tangential_um, dtype=float) / pin_circle_radius_mm * 1e3


class StrictSection(BaseModel):
    # strict: TOML is typed, so "40" is not an integer and 1 is not true.
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


def _per_pin(value: Any) -> float | list[float]:
    """A number for every pin, or a list with one number per pin (checked in to_core)."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        raise ValueError(f"expected a number or a list of numbers (one per pin), got {show(value)}")
    items = value if isinstance(value, list) else [value]
    for i, item in enumerate(items):
        if isinstance(item, bool) or not isinstance(item, int | float):
            raise ValueError(f"item {i + 1} is {show(item)}: expected a number")
        if not math.isfinite(item):
            raise ValueError(f"item {i + 1} is {item}: expected a finite number")
    return [float(v) for v in value] if isinstance(value, list) else float(value)


PerPin = Annotated[float | list[float], BeforeValidator(_per_pin)]


class DiscSection(StrictSection):
    """``[design.disc]``: the disc's crank holes (supports of the disc, seats of the cranks).

    One set of keys for the compliant disc (held at the hole centres) and the RV stage
    (one crankshaft and crank bearing per hole). ``crank_holes = 0`` (the default): no
    holes, the disc is held at its bore.
    """

    crank_holes: int = Field(
        0, ge=0, le=12, description="number of crank holes = crankshafts N (0: none)"
    )
    crank_hole_circle_radius_mm: float | None = Field(
        None, gt=0, description="radius of the circle through the hole centres r_c [mm]"
    )
    crank_hole_radius_mm: float | None = Field(
        None, gt=0, description="radius of each crank hole [mm]"
    )
    bore_radius_mm: float | None = Field(
        None, gt=0, description="radius of the disc's central bore [mm] (drawn by export)"
    )

    @model_validator(mode="after")
    def _complete(self) -> DiscSection:
        given = [
            self.crank_hole_circle_radius_mm is not None,
            self.crank_hole_radius_mm is not None,
        ]
        if self.crank_holes == 1:
            raise ValueError("crank_holes: expected 0 (no holes) or 2 to 12 holes, got 1")
        if self.crank_holes and not all(given):
            raise ValueError(
                "crank_holes > 0 needs crank_hole_circle_radius_mm and crank_hole_radius_mm"
            )
        if not self.crank_holes and any(given):
            raise ValueError("crank hole sizes given but crank_holes = 0: set crank_holes")
        return self

    def to_core(self) -> CrankHoles | None:
        """The :class:`~cyclomesh.core.pair.CrankHoles` in SI units, or None."""
        if not self.crank_holes:
            return None
        return CrankHoles(
            count=self.crank_holes,
            circle_radius=self.crank_hole_circle_radius_mm * M_PER_MM,
            radius=self.crank_hole_radius_mm * M_PER_MM,
        )


GROOVE_CLEARANCE_MM = 0.005
"""Default ρg − ρp [mm]: 3.505 − 3.5 mm of Table 1 of [1]."""


class DesignSection(StrictSection):
    """``[design]``: the nominal gear pair (Table 1 of [1]); every key but
    ``groove_radius_mm`` (default ρp + :data:`GROOVE_CLEARANCE_MM`) is required."""

    pins: int = Field(
        ge=3, le=MAX_PINS, description="number of ring pins n1; the disc has n1 - 1 teeth"
    )
    pin_circle_radius_mm: float = Field(gt=0, description="pin-centre circle radius a [mm]")
    pin_radius_mm: float = Field(gt=0, description="pin radius ρp [mm]")
    groove_radius_mm: float | None = Field(
        None,
        gt=0,
        description="pin-groove radius ρg [mm]; default ρp + 0.005 mm (the clearance of "
        "Table 1 of [1])",
    )
    eccentricity_mm: float = Field(gt=0, description="eccentricity e [mm]")
    width_mm: float = Field(gt=0, description="disc face width B [mm]")
    discs: int = Field(
        1,
        ge=1,
        le=MAX_DISCS,
        description="identical discs on the pin ring, disc k's eccentric at φ + (k - 1)·360°/N",
    )
    disc: DiscSection = DiscSection()


class ModificationSection(StrictSection):
    """``[modification]``: tooth profile modification (Eq. 3 of [1]); default none."""

    pin_circle_radius_um: float = Field(0.0, description="Δa [µm], negative opens clearance")
    pin_radius_um: float = Field(0.0, description="Δρ [µm], positive opens clearance")
    rotation_urad: float = Field(0.0, description="rotation-angle modification δ [µrad]")
    profile_file: str | None = Field(
        None, description="CSV of a tabulated normal profile deviation (docs/modification.md)"
    )


class MaterialProperties(StrictSection):
    """Material of a part: a named grade (:data:`cyclomesh.core.materials.MATERIALS`) and/or
    explicit values; a key left out falls back to the name, then to ``[material]``, then
    to steel (Table 1 of [1])."""

    name: str | None = Field(
        None, description='named material, e.g. "GCr15" (docs/study-files.md lists them)'
    )
    youngs_modulus_gpa: float | None = Field(
        None,
        ge=YOUNGS_MODULUS_RANGE[0] / 1e9,
        le=YOUNGS_MODULUS_RANGE[1] / 1e9,
        description="E [GPa]",
    )
    poisson_ratio: float | None = Field(
        None, ge=POISSON_RATIO_RANGE[0], lt=POISSON_RATIO_RANGE[1], description="ν [-]"
    )
    allowable_contact_stress_mpa: float | None = Field(
        None, gt=0, description="allowable contact stress σH,lim [MPa]"
    )

    @field_validator("name")
    @classmethod
    def _known_name(cls, name: str | None) -> str | None:
        if name is not None:
            from cyclomesh.core.materials import material_grade

            try:
                material_grade(name)
            except KeyError as exc:
                raise ValueError(exc.args[0]) from None
        return name

    def value(self, key: str) -> float | None:
        """The explicit value of ``key`` (study units), else the named grade's, else None."""
        own = getattr(self, key)
        if own is not None or self.name is None:
            return own
        from cyclomesh.core.materials import material_grade

        grade = material_grade(self.name)
        return {
            "youngs_modulus_gpa": grade.youngs_modulus / PA_PER_GPA,
            "poisson_ratio": grade.poisson_ratio,
            "allowable_contact_stress_mpa": grade.allowable_contact_stress / 1e6,
        }[key]


class MaterialSection(MaterialProperties):
    """``[material]`` for all parts, refined by ``[material.pin|disc|ring]``."""

    pin: MaterialProperties = MaterialProperties()
    disc: MaterialProperties = MaterialProperties()
    ring: MaterialProperties = MaterialProperties()

    def _lookup(self, part: str, key: str) -> float | None:
        own = getattr(self, part).value(key)
        return own if own is not None else self.value(key)

    def resolve(self, part: Literal["pin", "disc", "ring"]) -> Material:
        """Core :class:`Material` of one part (E in Pa); steel of Table 1 of [1] by default."""
        modulus = self._lookup(part, "youngs_modulus_gpa")
        ratio = self._lookup(part, "poisson_ratio")
        return Material(
            youngs_modulus=(206.0 if modulus is None else modulus) * PA_PER_GPA,
            poisson_ratio=0.3 if ratio is None else ratio,
        )

    def allowable_mpa(self, part: Literal["pin", "disc", "ring"]) -> float | None:
        """Allowable contact stress of one part [MPa], or None if no name or value gives it."""
        return self._lookup(part, "allowable_contact_stress_mpa")

    def names(self) -> dict[str, str]:
        """Part → name of its material grade, for the parts that have one."""
        out = {}
        for part in ("pin", "disc", "ring"):
            name = getattr(self, part).name or self.name
            if name is not None:
                from cyclomesh.core.materials import material_grade

                out[part] = material_grade(name).name
        return out


def _torques(value: Any) -> float | list[float]:
    """One torque or a non-empty list of distinct torques [N·m], none of them 0."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        raise ValueError(f"expected a number or a list of numbers, got {show(value)}")
    items = value if isinstance(value, list) else [value]
    if not items:
        raise ValueError("expected at least one torque")
    for i, item in enumerate(items):
        if isinstance(item, bool) or not isinstance(item, int | float):
            what = "a number"
        elif not math.isfinite(item):
            what = "a finite number"
        elif item == 0:
            what = (
                "a torque other than 0 (with no load the disc can sit anywhere in the play; "
                "give a positive (forward) or negative (reverse) torque)"
            )
        else:
            continue
        if isinstance(value, list):
            raise ValueError(f"item {i + 1} is {show(item)}: expected {what}")
        raise ValueError(f"expected {what}, got {show(item)}")
    if len(set(items)) != len(items):
        raise ValueError("the torques must differ from each other")
    return [float(v) for v in value] if isinstance(value, list) else float(value)


class LoadSection(StrictSection):
    """``[load]``."""

    torque_nm: Annotated[float | list[float], BeforeValidator(_torques)] = Field(
        250.0,
        description="torque on the disc (stack) T [N·m], or a list; negative loads the "
        "reverse flanks; 0 is refused",
    )
    input_speed_rpm: float | None = Field(
        None,
        gt=0,
        le=1e5,
        description="input (crank) speed [rpm]: friction powers, lubricated coefficients, the "
        "stage's output speed (= input/n2); default 15·n2 (15 rpm at the output)",
    )

    def speed_rpm(self, teeth: int) -> float:
        """The input speed [rpm]: the key, else 15 rpm at the output (15·n2)."""
        return self.input_speed_rpm if self.input_speed_rpm is not None else 15.0 * teeth


class RandomErrorsSection(StrictSection):
    """``[errors.random]``: one independent uniform draw per pin within ± the half-range.

    The draws use ``numpy.random.default_rng(seed)`` in the fixed order radial,
    angular, pin radius (``n1`` values each), so changing one half-range leaves the
    others' draws unchanged.
    """

    seed: int = Field(ge=0, le=MAX_SEED, description="seed of numpy.random.default_rng")
    radial_um: float = Field(0.0, ge=0, description="half-range of εa,i [µm]")
    angular_urad: float = Field(0.0, ge=0, description="half-range of εψ,i [µrad]")
    pin_radius_um: float = Field(0.0, ge=0, description="half-range of ερ,i [µm]")
    tangential_um: float = Field(
        0.0, ge=0, description="half-range of the tangential position error a·εψ,i [µm]"
    )

    @model_validator(mode="after")
    def _one_angular(self) -> RandomErrorsSection:
        if self.tangential_um and self.angular_urad:
            raise ValueError("give angular_urad or tangential_um, not both")
        return self

    def draw(self, pins: int, pin_circle_radius_mm: float | None = None) -> dict[str, NDArray]:
        """Per-pin errors in study units (µm, µrad, µm), shape ``(pins,)`` each.

        A tangential half-range is drawn after the three others (their draws do not
        change) and turned into the angular error εψ,i = tangential / a [µrad]."""
        rng = np.random.default_rng(self.seed)
        out = {
            name: rng.uniform(-half, half, pins)
            for name, half in (
                ("radial_um", self.radial_um),
                ("angular_urad", self.angular_urad),
                ("pin_radius_um", self.pin_radius_um),
            )
        }
        if self.tangential_um:
            tangential = rng.uniform(-self.tangential_um, self.tangential_um, pins)
            out["angular_urad"] = out["angular_urad"] + tangential_urad(
                tangential, pin_circle_radius_mm
            )
        return out


class ErrorsSection(StrictSection):
    """``[errors]``: pin-ring errors (Eq. 5 of [1]); default none.

    The per-pin errors are the sum of the values given here (a number for every pin or
    a list of n1 numbers), the rows of ``file`` and the draws of ``[errors.random]``.
    """

    eccentricity_um: float = Field(0.0, description="eccentricity error εe [µm]")
    radial_um: PerPin = Field(0.0, description="radial position error εa,i [µm]")
    angular_urad: PerPin = Field(0.0, description="angular position error εψ,i [µrad]")
    tangential_um: PerPin = Field(
        0.0, description="tangential position error a·εψ,i [µm], added to angular_urad"
    )
    pin_radius_um: PerPin = Field(0.0, description="pin radius error ερ,i [µm]")
    file: str | None = Field(None, description="CSV of measured pins, relative to the study")
    random: RandomErrorsSection | None = None


def crank_angles_deg(start_deg: float, stop_deg: float, step_deg: float) -> NDArray:
    """``numpy.arange(start, stop, step)`` [deg] without its floating-point surprises.

    The stop is excluded even when ``(stop - start)/step`` is a whole number up to
    round-off, so 0 to 360 in steps of 0.1 gives exactly 3600 angles.
    """
    count = max(math.ceil((stop_deg - start_deg) / step_deg - 1e-9), 0)
    return start_deg + step_deg * np.arange(count)


FE_BORE_FRACTION = 0.8
"""Largest bore radius of the FE disc as a fraction of the root radius a − e − ρp."""

CrankDeg = Annotated[
    float,
    Field(ge=-MAX_ABS_CRANK_DEG, le=MAX_ABS_CRANK_DEG, description="crank angle [deg]"),
]


class AnalysisSection(StrictSection):
    """``[analysis]``: crank angles and the pin-groove deformation switch."""

    crank_start_deg: CrankDeg = Field(0.0, description="first crank angle [deg]")
    crank_stop_deg: CrankDeg = Field(360.0, description="crank angle where to stop, excluded [deg]")
    crank_step_deg: float = Field(
        0.1, ge=MIN_CRANK_STEP_DEG, le=MAX_ABS_CRANK_DEG, description="crank angle step [deg]"
    )
    groove_deformation: bool = Field(True, description="the improved model of [1] (Eq. 19)")
    contact_law: Literal["paper", "half_plane"] = Field(
        "half_plane",
        description=(
            "tooth term of the contact law: the approach of a half-plane to the disc centre "
            "(Johnson eq. 5.41, default: finite at inflection points, converged in the crank "
            'step), or Eq. 20 of [1] as published ("paper", to reproduce the paper)'
        ),
    )
    disc_body: Literal["rigid", "fe"] = Field(
        "rigid",
        description=(
            "the disc body: rigid apart from the contact law (as in [1]), or compliant with "
            "influence coefficients condensed from the FE model (needs the fe extra and "
            'contact_law = "half_plane"; computed once per design and cached)'
        ),
    )

    @model_validator(mode="after")
    def _fe_body_needs_half_plane(self) -> AnalysisSection:
        if self.disc_body == "fe" and self.contact_law != "half_plane":
            raise ValueError(
                'disc_body = "fe" leaves the near field to the half-plane law: set '
                'contact_law = "half_plane"'
            )
        return self

    @model_validator(mode="after")
    def _at_least_two_angles(self) -> AnalysisSection:
        count = count_crank_angles(self.crank_start_deg, self.crank_stop_deg, self.crank_step_deg)
        if count > MAX_CRANK_ANGLES:
            raise ValueError(
                f"crank_start_deg, crank_stop_deg and crank_step_deg give {count:.3g} crank "
                f"angles, more than {MAX_CRANK_ANGLES}: use a larger crank_step_deg"
            )
        if count < 2:
            raise ValueError(
                f"crank_start_deg = {self.crank_start_deg:g}, crank_stop_deg = "
                f"{self.crank_stop_deg:g} and crank_step_deg = {self.crank_step_deg:g} "
                "give fewer than 2 crank angles"
            )
        return self

    def crank_angles_deg(self) -> NDArray:
        """The crank angles φin [deg], stop excluded."""
        return crank_angles_deg(self.crank_start_deg, self.crank_stop_deg, self.crank_step_deg)


class FiguresSection(StrictSection):
    """``[figures]``: which figures to draw and where to look."""

    enabled: bool = Field(True, description="draw the figures and put them in the report")
    crank_angles_deg: list[float] = Field(
        [0.0, 60.0, 120.0, 180.0],
        min_length=1,
        max_length=12,
        description="crank angles of the load and backlash figures (nearest computed angle)",
    )
    stress_pin: int | None = Field(
        None,
        ge=1,
        description="pin whose contact stress is drawn over the profile (default: pin n1/2)",
    )
    stress_over: Literal["profile_angle", "contact_radius"] = Field(
        "profile_angle", description="abscissa of the contact stress over the tooth profile"
    )
    formats: list[Literal["png", "svg", "pdf"]] = Field(
        ["png"], min_length=1, description="file formats of the figures (--figures overrides)"
    )
    dpi: int = Field(150, ge=50, le=600, description="resolution of PNG figures [dots/inch]")


class RequirementsSection(StrictSection):
    """``[requirements]``: limits every kind of study checks where it computes the quantity.

    ``max_contact_stress_mpa`` defaults to the allowable contact stress of the pin and
    disc materials (the smaller of those ``[material]`` gives; a named material gives
    one), ``max_groove_stress_mpa`` to that of pin and ring. See ``docs/requirements.md``.
    """

    max_contact_stress_mpa: float | None = Field(
        None, gt=0, description="peak pin-tooth contact stress [MPa] (default: allowable)"
    )
    max_groove_stress_mpa: float | None = Field(
        None, gt=0, description="peak pin-groove contact stress [MPa] (default: allowable)"
    )
    max_te_pp_arcsec: float | None = Field(None, gt=0, description="TE peak-to-peak [arcsec]")
    min_contacts: int | None = Field(None, ge=1, description="fewest pins in contact")
    max_gear_ratio_ripple_pct: float | None = Field(
        None, gt=0, description="gear-ratio ripple [% of n2]"
    )
    max_play_arcmin: float | None = Field(None, ge=0, description="largest play [arcmin]")
    max_lost_motion_arcmin: float | None = Field(
        None, gt=0, description="largest lost motion [arcmin] (cyclomesh stiffness)"
    )
    min_torsional_rigidity_nm_per_arcmin: float | None = Field(
        None, gt=0, description="smallest torsional rigidity [N·m/arcmin] (cyclomesh stiffness)"
    )
    max_mesh_force_n: float | None = Field(None, gt=0, description="largest mesh force [N]")
    min_efficiency: float | None = Field(
        None, gt=0, le=1, description="smallest forward efficiency [-] (with [friction])"
    )
    min_backdrive_efficiency: float | None = Field(
        None,
        ge=0,
        le=1,
        description="smallest back-driving efficiency [-] (with [friction]; in a tolerance "
        "study it adds a back-driving solve per ring)",
    )
    min_bearing_life_h: float | None = Field(
        None, gt=0, description="L10h of the weakest crank bearing [h] (RV stage, [stage])"
    )
    tolerance_percentile: float = Field(
        95.0,
        gt=0,
        lt=100,
        description="percentile of the rings a tolerance study checks the limits at [%]",
    )

    def limits(self, material: MaterialSection) -> tuple[dict[str, float], dict[str, str]]:
        """The limits of one case (study units) and a note for each defaulted one."""
        limits = {
            k: v
            for k, v in self.model_dump().items()
            if v is not None and k != "tolerance_percentile"
        }
        notes = {}
        for key, parts in (
            ("max_contact_stress_mpa", ("pin", "disc")),
            ("max_groove_stress_mpa", ("pin", "ring")),
        ):
            if key in limits:
                continue
            allowables = [(material.allowable_mpa(p), p) for p in parts]
            known = [(v, p) for v, p in allowables if v is not None]
            if known:  # the smaller of the parts that have one
                value, part = min(known)
                limits[key] = value
                name = material.names().get(part)
                notes[key] = f"allowable of the {part} material" + (f" ({name})" if name else "")
        return limits, notes
