"""The study file schema: every section of a study file, validated by one set of models.

A study file holds a base description (``[design]``, ``[modification]``, ``[material]``,
``[load]``, ``[errors]``, ``[analysis]``), a list of ``[[cases]]``, ``[figures]`` and
the sections of the other kinds of study (``[tolerance]``, ...). All sections are strict
pydantic models (unknown keys refused, ``"12"`` is not an integer, ``true`` is not a
number) and every problem comes out through one formatter (:func:`one_line`) as one
line naming the dotted key. ``cyclomesh check`` therefore refuses a bad key in any
section before any work is done. To add the section of a new kind of study, see
``docs/pipeline.md``.

Each case is the base deep-merged with the case's own keys. Every key a user types
carries its unit (``_mm``, ``_um``, ``_urad``, ``_gpa``, ``_nm``, ``_deg``);
:meth:`CaseSpec.to_core` converts a case to the SI objects of the core
(:class:`~cyclomesh.core.pair.PairDesign`, :class:`~cyclomesh.core.pair.Modification`,
:class:`~cyclomesh.core.pair.PinErrors`).

Every problem (unknown key, wrong type, list of the wrong length, a design the core
refuses) is raised as one :class:`~cyclomesh.exceptions.StudyError` whose one-line
message names the dotted key, e.g. ``errors.radial_um: expected 40 values (one per
pin), got 39``. The file format is documented in ``docs/study-files.md``.

Defaults of the optional sections are those of the example of [1] (Table 1): steel
(206 GPa, 0.3), 250 N·m, crank angle 0–360° in steps of 0.1°, pin-groove deformation
on; an omitted ``[modification]`` or ``[errors]`` means none.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, "Design and Load Distribution Analysis of the
    Mismatched Cycloid-Pin Gear Pair in RV Speed Reducers", Machines 10 (2022) 672,
    doi:10.3390/machines10080672.
"""

from __future__ import annotations

import copy
import hashlib
import math
import re
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.core.pair import (
    POISSON_RATIO_RANGE,
    YOUNGS_MODULUS_RANGE,
    CrankHoles,
    Material,
    Modification,
    PairDesign,
    PinErrors,
    check_physical,
    pin_errors_si,
)
from cyclomesh.core.profile import check_profile
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.stage.bearing import RollerSet
from cyclomesh.stage.carrier import Carrier
from cyclomesh.stage.crankshaft import Crankshaft
from cyclomesh.stage.duty import DutyCycle
from cyclomesh.stage.solve import StageDesign
from cyclomesh.studyfile.limits import (
    MAX_ABS_CRANK_DEG,
    MAX_CANDIDATES,
    MAX_CRANK_ANGLES,
    MAX_DISCS,
    MAX_PINS,
    MAX_RINGS,
    MAX_SEED,
    MAX_STIFFNESS_POINTS,
    MAX_STUDY_FILE_BYTES,
    MIN_CRANK_STEP_DEG,
    count_crank_angles,
    read_regular_file,
)
from cyclomesh.studyfile.measurements import PIN_ERROR_COLUMNS, read_pin_errors_csv
from cyclomesh.studyfile.profile_csv import read_profile_csv
from cyclomesh.units import RAD_PER_ARCMIN

__all__ = [
    "DesignSection",
    "ModificationSection",
    "MaterialProperties",
    "MaterialSection",
    "LoadSection",
    "RandomErrorsSection",
    "ErrorsSection",
    "AnalysisSection",
    "StiffnessSection",
    "FeSection",
    "FiguresSection",
    "RequirementsSection",
    "Uniform",
    "Normal",
    "TruePosition",
    "AllocationSection",
    "ToleranceSection",
    "CaseSpec",
    "CaseInputs",
    "StudyFile",
    "Study",
    "load_study",
    "crank_angles_deg",
    "deep_merge",
    "pin_errors_si",
    "one_line",
    "parse_section",
]

MM = 1e-3
UM = 1e-6
URAD = 1e-6
GPA = 1e9
CASE_SECTIONS = (
    "design",
    "modification",
    "material",
    "load",
    "errors",
    "analysis",
    "stiffness",
    "stage",
)
"""Sections that a case may override."""


def tangential_urad(tangential_um: Any, pin_circle_radius_mm: float) -> NDArray:
    """Angular pin position error εψ,i [µrad] of a tangential one [µm]: t / a.

    µm over mm is 1e-3 rad, i.e. 1e3 µrad.
    """
    return np.asarray(tangential_um, dtype=float) / pin_circle_radius_mm * 1e3


class _Section(BaseModel):
    # strict: TOML is typed, so "40" is not an integer and 1 is not true.
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


def _per_pin(value: Any) -> float | list[float]:
    """A number for every pin, or a list with one number per pin (checked in to_core)."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        raise ValueError(
            f"expected a number or a list of numbers (one per pin), got {_show(value)}"
        )
    items = value if isinstance(value, list) else [value]
    for i, item in enumerate(items):
        if isinstance(item, bool) or not isinstance(item, int | float):
            raise ValueError(f"item {i + 1} is {_show(item)}: expected a number")
        if not math.isfinite(item):
            raise ValueError(f"item {i + 1} is {item}: expected a finite number")
    return [float(v) for v in value] if isinstance(value, list) else float(value)


PerPin = Annotated[float | list[float], BeforeValidator(_per_pin)]


class DiscSection(_Section):
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
            circle_radius=self.crank_hole_circle_radius_mm * MM,
            radius=self.crank_hole_radius_mm * MM,
        )


GROOVE_CLEARANCE_MM = 0.005
"""Default ρg − ρp [mm]: 3.505 − 3.5 mm of Table 1 of [1]."""


class DesignSection(_Section):
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


class ModificationSection(_Section):
    """``[modification]``: tooth profile modification (Eq. 3 of [1]); default none."""

    pin_circle_radius_um: float = Field(0.0, description="Δa [µm], negative opens clearance")
    pin_radius_um: float = Field(0.0, description="Δρ [µm], positive opens clearance")
    rotation_urad: float = Field(0.0, description="rotation-angle modification δ [µrad]")
    profile_file: str | None = Field(
        None, description="CSV of a tabulated normal profile deviation (docs/modification.md)"
    )


class MaterialProperties(_Section):
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
            "youngs_modulus_gpa": grade.youngs_modulus / GPA,
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
            youngs_modulus=(206.0 if modulus is None else modulus) * GPA,
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
        raise ValueError(f"expected a number or a list of numbers, got {_show(value)}")
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
            raise ValueError(f"item {i + 1} is {_show(item)}: expected {what}")
        raise ValueError(f"expected {what}, got {_show(item)}")
    if len(set(items)) != len(items):
        raise ValueError("the torques must differ from each other")
    return [float(v) for v in value] if isinstance(value, list) else float(value)


class LoadSection(_Section):
    """``[load]``."""

    torque_nm: Annotated[float | list[float], BeforeValidator(_torques)] = Field(
        250.0,
        description="torque on the disc (stack) T [N·m], or a list; negative loads the "
        "reverse flanks; 0 is refused",
    )


class StiffnessSection(_Section):
    """``[stiffness]``: the torsion curve of ``cyclomesh stiffness`` (see docs/drive.md)."""

    rated_torque_nm: float = Field(gt=0, description="rated torque T_r of the stack [N·m]")
    points: int = Field(
        41,
        ge=2,
        le=MAX_STIFFNESS_POINTS,
        description="evenly spaced torques from -T_r to +T_r (0 left out)",
    )
    series_stiffness_nm_per_arcmin: float | None = Field(
        None,
        gt=0,
        description="torsional stiffness of the rest of the drive, in series [N·m/arcmin]",
    )
    measured_file: str | None = Field(
        None,
        description="measured hysteresis loop (CSV torque_nm, twist_arcmin), read back by "
        "the catalogue definitions beside the model (docs/stage.md)",
    )


def _per_crank(value: Any) -> float | list[float] | list[list[float]]:
    """One number, one per crank, or one list per disc of one per crank [µm]."""
    rows = value if isinstance(value, list) else [value]
    for row in rows:
        for item in row if isinstance(row, list) else [row]:
            if isinstance(item, bool) or not isinstance(item, int | float):
                raise ValueError(f"expected numbers [µm], got {_show(item)}")
            if not math.isfinite(item):
                raise ValueError(f"expected finite numbers [µm], got {item}")
    return value


PerCrank = Annotated[Any, BeforeValidator(_per_crank)]


class CrankBearingSection(_Section):
    """``[stage.crank_bearing]``: the needle roller set of every crank hole."""

    rollers: int = Field(ge=3, description="number of rollers Z")
    roller_diameter_mm: float = Field(gt=0, description="roller diameter D_we [mm]")
    roller_length_mm: float = Field(gt=0, description="effective roller length L_we [mm]")
    radial_clearance_um: float = Field(
        0.0, ge=0, description="radial internal clearance P_d (ISO 5753-1, total free travel) [µm]"
    )
    dynamic_load_rating_kn: float | None = Field(
        None, gt=0, description="catalogue C_r [kN]; default: ISO 281 from the geometry"
    )
    rating_factor: float = Field(1.1, gt=0, description="b_m of ISO 281 (1.1 machined raceways)")


class CrankshaftSection(_Section):
    """``[stage.crankshaft]``: every crankshaft as a beam on two support bearings."""

    support_span_mm: float = Field(
        gt=0, description="distance between the crankshaft's two support bearings [mm]"
    )
    disc_pitch_mm: float = Field(
        gt=0, description="axial distance between neighbouring discs' mid-planes [mm]"
    )
    support_bearing_stiffness_n_per_um: float | None = Field(
        None, gt=0, description="radial stiffness of each support bearing [N/µm] (omitted: rigid)"
    )


class CarrierSection(_Section):
    """``[stage.carrier]``: the pillars joining the output flange and the end plate."""

    pillars: int = Field(ge=2, description="number of pillars")
    pillar_diameter_mm: float = Field(gt=0, description="pillar diameter [mm]")
    pillar_length_mm: float = Field(gt=0, description="free length between the flanges [mm]")
    pillar_circle_radius_mm: float = Field(gt=0, description="radius of the pillars' circle [mm]")


class DutyCycleSection(_Section):
    """``[stage.duty_cycle]``: a load spectrum of the output, one value per step."""

    torque_nm: list[float] = Field(min_length=1, description="output torque of each step")
    output_speed_rpm: list[float] = Field(min_length=1, description="output speed of each step")
    time_share: list[float] = Field(
        min_length=1, description="share of the time of each step (normalised)"
    )


class StageSection(_Section):
    """``[stage]``: the RV stage around the mesh: crank bearings, springs, hole errors.

    The crankshafts are the crank holes of ``[design.disc]`` (``crank_holes``,
    ``crank_hole_circle_radius_mm``, ``crank_hole_radius_mm``): one set of keys.
    """

    output_speed_rpm: float = Field(15.0, gt=0, description="output speed for L10h [rpm]")
    rated_torque_nm: float | None = Field(
        None, gt=0, description="rated torque of the data sheet [N·m] (default: the load)"
    )
    crank_bearing: CrankBearingSection | None = None
    crankshaft: CrankshaftSection | None = None
    carrier: CarrierSection | None = None
    duty_cycle: DutyCycleSection | None = None
    crankshaft_stiffness_n_per_um: float | None = Field(
        None, gt=0, description="radial stiffness of a crank pin, in series with its bearing"
    )
    carrier_stiffness_nm_per_arcmin: float | None = Field(
        None, gt=0, description="torsional stiffness of the carrier, in series [N·m/arcmin]"
    )
    hole_error_radial_um: PerCrank = Field(0.0, description="crank hole position error, radial")
    hole_error_tangential_um: PerCrank = Field(
        0.0, description="crank hole position error, tangential (counter-clockwise)"
    )

    @model_validator(mode="before")
    @classmethod
    def _one_set_of_keys(cls, raw: Any) -> Any:
        if isinstance(raw, dict):
            for key, use in (
                ("crankshafts", "crank_holes"),
                ("crank_circle_radius_mm", "crank_hole_circle_radius_mm"),
            ):
                if key in raw:
                    raise ValueError(
                        f"{key}: the crankshafts are the crank holes; give [design.disc] {use}"
                    )
        return raw

    def to_core(self, holes: CrankHoles | None, discs: int) -> StageDesign:
        """The :class:`~cyclomesh.stage.solve.StageDesign` in SI units."""
        if holes is None:
            raise DesignError(
                "stage: needs the crankshafts: set [design.disc] crank_holes (2 or 3), "
                "crank_hole_circle_radius_mm and crank_hole_radius_mm"
            )
        bearing = None
        b = self.crank_bearing
        if b is not None:
            bearing = RollerSet(
                rollers=b.rollers,
                diameter=b.roller_diameter_mm * MM,
                length=b.roller_length_mm * MM,
                clearance=b.radial_clearance_um * UM,
                pitch_diameter=2.0 * holes.radius - b.roller_diameter_mm * MM,
                dynamic_load_rating=(
                    None if b.dynamic_load_rating_kn is None else b.dynamic_load_rating_kn * 1e3
                ),
                rating_factor=b.rating_factor,
            )
        crankshaft = carrier = None
        if self.crankshaft is not None:
            if b is None:
                raise DesignError(
                    "stage.crankshaft: needs [stage.crank_bearing] (the crank pin's diameter "
                    "is the crank hole's less two rollers)"
                )
            crankshaft = Crankshaft(
                support_span=self.crankshaft.support_span_mm * MM,
                disc_pitch=self.crankshaft.disc_pitch_mm * MM,
                pin_diameter=2.0 * holes.radius - 2.0 * b.roller_diameter_mm * MM,
                support_stiffness=(
                    None
                    if self.crankshaft.support_bearing_stiffness_n_per_um is None
                    else self.crankshaft.support_bearing_stiffness_n_per_um / UM
                ),
            )
            crankshaft.positions(discs)  # the stack fits between the supports
        if self.carrier is not None:
            c = self.carrier
            carrier = Carrier(
                pillars=c.pillars,
                pillar_diameter=c.pillar_diameter_mm * MM,
                pillar_length=c.pillar_length_mm * MM,
                pillar_circle_radius=c.pillar_circle_radius_mm * MM,
            )
        duty = None
        if self.duty_cycle is not None:
            duty = DutyCycle(
                tuple(self.duty_cycle.torque_nm),
                tuple(self.duty_cycle.output_speed_rpm),
                tuple(self.duty_cycle.time_share),
            )
        stage = StageDesign(
            holes=holes,
            bearing=bearing,
            crankshaft=crankshaft,
            carrier=carrier,
            duty_cycle=duty,
            crankshaft_stiffness=(
                None
                if self.crankshaft_stiffness_n_per_um is None
                else self.crankshaft_stiffness_n_per_um / UM
            ),
            carrier_stiffness=(
                None
                if self.carrier_stiffness_nm_per_arcmin is None
                else self.carrier_stiffness_nm_per_arcmin / RAD_PER_ARCMIN
            ),
            hole_error_radial=np.asarray(self.hole_error_radial_um, float) * UM,
            hole_error_tangential=np.asarray(self.hole_error_tangential_um, float) * UM,
            output_speed=self.output_speed_rpm,
        )
        stage.hole_errors(discs)  # the shapes, checked here
        return stage


def refuse_stage(study: Study, command: str) -> None:
    """One-line :class:`StudyError` if a case has ``[stage]``, which ``command`` does not
    take yet (the RV stage runs in ``cyclomesh run`` and ``cyclomesh stiffness``)."""
    for case in study.cases:
        if case.stage is not None:
            raise StudyError(
                f"{case.label}: [stage] is not taken by cyclomesh {command} yet; use "
                "cyclomesh run or cyclomesh stiffness for the RV stage, or remove [stage] "
                "(docs/stage.md)"
            )


class RandomErrorsSection(_Section):
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


class ErrorsSection(_Section):
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


class AnalysisSection(_Section):
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


class FiguresSection(_Section):
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


# --- [tolerance]: Monte Carlo tolerance studies (docs/tolerance.md) ----------------------


class Uniform(_Section):
    """Uniform error on [−half_range, +half_range], in the unit of the enclosing key."""

    distribution: Literal["uniform"]
    half_range: float = Field(ge=0.0, description="half range [unit of the key]")

    def scale(self) -> float:
        """Half range [unit of the key]."""
        return self.half_range


class Normal(_Section):
    """Normal error with mean 0 and standard deviation sigma, in the unit of the key."""

    distribution: Literal["normal"]
    sigma: float = Field(ge=0.0, description="standard deviation [unit of the key]")

    def scale(self) -> float:
        """Standard deviation [unit of the key]."""
        return self.sigma


class TruePosition(_Section):
    """True-position zone: the pin centre is uniform (in area) over a disc of this diameter.

    Gives both the radial error εa,i and the angular error εψ,i = tangential / a.
    """

    distribution: Literal["true_position"]
    zone_diameter_um: float = Field(ge=0.0, description="diameter of the zone [µm]")


ErrorDistribution = Annotated[Uniform | Normal, Field(discriminator="distribution")]


class AllocationSection(_Section):
    """``[tolerance.allocation]``: settings of ``cyclomesh allocate``.

    The search steps the scale factor on the stated tolerances over ``factor_steps``
    equal steps of (0, factor_max], then bisects ``bisections`` times per ring
    (resolution factor_max / factor_steps / 2**bisections).
    """

    target_probability: float = Field(
        0.01, gt=0.0, lt=1.0, description="largest acceptable P(peak stress > allowable)"
    )
    confidence: float = Field(0.95, gt=0.0, lt=1.0, description="level of the stated bounds")
    factor_max: float = Field(4.0, gt=0.0, description="largest scale factor searched [-]")
    factor_steps: int = Field(8, ge=1, le=1000, description="coarse search steps")
    bisections: int = Field(6, ge=0, le=40, description="bisections per ring")


class ToleranceSection(_Section):
    """``[tolerance]``: distributions of the pin-ring errors of a Monte Carlo study.

    A kind of error left out has no error. Every pin draws independently; the
    eccentricity error is one value per ring. The sampled errors add to the base's
    ``[errors]``.
    """

    seed: int = Field(ge=0, le=MAX_SEED, description="ring k's errors depend only on (seed, k)")
    rings: int = Field(
        1000, ge=1, le=MAX_RINGS, description="how many rings to draw (--rings overrides)"
    )
    allowable_contact_stress_mpa: float = Field(
        gt=0.0, description="allowable peak tooth contact stress [MPa]"
    )
    crank_start_deg: CrankDeg | None = Field(
        None, description="first crank angle [deg] (default: [analysis]'s)"
    )
    crank_stop_deg: CrankDeg | None = Field(
        None, description="crank angle where to stop, excluded [deg] (default: [analysis]'s)"
    )
    crank_step_deg: float | None = Field(
        None,
        ge=MIN_CRANK_STEP_DEG,
        le=MAX_ABS_CRANK_DEG,
        description="crank angle step [deg] (default: [analysis]'s)",
    )
    radial_um: ErrorDistribution | None = None
    angular_urad: ErrorDistribution | None = None
    tangential_um: ErrorDistribution | None = Field(
        None, description="tangential position error a·εψ,i [µm] (instead of angular_urad)"
    )
    pin_radius_um: ErrorDistribution | None = None
    eccentricity_um: ErrorDistribution | None = None
    position: TruePosition | None = None
    allocation: AllocationSection = AllocationSection()

    @model_validator(mode="after")
    def _consistent(self) -> ToleranceSection:
        if self.position is not None and (
            self.radial_um is not None
            or self.angular_urad is not None
            or self.tangential_um is not None
        ):
            raise ValueError(
                "position (true_position) replaces radial_um, angular_urad and tangential_um; "
                "give one or the other"
            )
        if self.angular_urad is not None and self.tangential_um is not None:
            raise ValueError("give angular_urad or tangential_um, not both")
        return self

    def crank_range(self, analysis: AnalysisSection | None = None) -> tuple[float, float, float]:
        """(start, stop, step) [deg] of the rings' crank angles: the keys of
        ``[tolerance]``, each falling back to ``analysis``'s (the one rule of tolerance,
        allocation and robust design studies)."""
        analysis = analysis or AnalysisSection()
        start, stop, step = (
            float(mine if mine is not None else getattr(analysis, key))
            for key, mine in (
                ("crank_start_deg", self.crank_start_deg),
                ("crank_stop_deg", self.crank_stop_deg),
                ("crank_step_deg", self.crank_step_deg),
            )
        )
        if stop <= start:
            raise StudyError(
                f"tolerance.crank_stop_deg: the crank angles stop at {stop:g}°, not after "
                f"their start {start:g}° (tolerance keys override [analysis]'s)"
            )
        count = count_crank_angles(start, stop, step)
        if count > MAX_CRANK_ANGLES:
            raise StudyError(
                f"tolerance.crank_step_deg: {count:.3g} crank angles, more than "
                f"{MAX_CRANK_ANGLES}; use a larger step"
            )
        if count < 2:
            raise StudyError(
                "tolerance.crank_step_deg: fewer than 2 crank angles; use a smaller step"
            )
        return start, stop, step

    def crank_angles_deg(self, analysis: AnalysisSection | None = None) -> NDArray:
        """Crank angles start, start + step, ... below stop [deg] (:meth:`crank_range`)."""
        return crank_angles_deg(*self.crank_range(analysis))


# --- [design_space]: design maps (docs/design-map.md) ------------------------------------


class RangeSection(_Section):
    """``{ start = , stop = , points = }``: ``numpy.linspace(start, stop, points)``."""

    start: float = Field(description="first value [unit of the key]")
    stop: float = Field(description="last value, included [unit of the key]")
    points: int = Field(ge=1, le=1001, description="number of values")

    @model_validator(mode="after")
    def _distinct(self) -> RangeSection:
        if self.points > 1 and self.start == self.stop:
            raise ValueError(
                f"start = stop = {self.start:g} with points = {self.points}: the values "
                "repeat; give a stop other than the start, or points = 1"
            )
        return self

    def values(self) -> NDArray:
        """The grid values [unit of the key]."""
        return np.linspace(self.start, self.stop, self.points)


class FeSection(_Section):
    """``[fe]``: the whole-disc finite-element model of ``cyclomesh fe`` (docs/contact-law.md).

    Validated here with every other section (``cyclomesh check``); the FE model itself
    needs the optional ``fe`` extra (scikit-fem, gmsh).
    """

    bore_radius_mm: float = Field(30.0, gt=0, description="bore tied to the rigid centre [mm]")
    crank_angles_deg: list[CrankDeg] = Field(
        [0.0, 3.0, 6.0], min_length=1, max_length=24, description="crank angles solved [deg]"
    )
    elements_per_half_width: float = Field(
        8.0, ge=2, le=40, description="contact mesh size: the Hertz half-width b over this"
    )
    far_size_mm: float = Field(1.5, ge=0.2, le=5, description="mesh size away from contacts [mm]")


class DesignSpaceSection(_Section):
    """``[design_space]``: swept modification parameters, constraints, objective, rings."""

    pin_circle_radius_um: RangeSection | None = Field(None, description="Δa range [µm]")
    pin_radius_um: RangeSection | None = Field(None, description="Δρ range [µm]")
    rotation_urad: RangeSection | None = Field(None, description="rotation δ range [µrad]")
    pin_circle_radius_mm: RangeSection | None = Field(None, description="a range [mm]")
    pin_radius_mm: RangeSection | None = Field(None, description="ρp range [mm]")
    eccentricity_mm: RangeSection | None = Field(None, description="e range [mm]")
    width_mm: RangeSection | None = Field(None, description="face width B range [mm]")
    max_play_arcmin: float | None = Field(None, description="largest allowed play [arcmin]")
    min_play_arcmin: float | None = Field(None, description="smallest allowed play [arcmin]")
    allowable_contact_stress_mpa: float | None = Field(
        None, gt=0, description="allowed max. contact stress [MPa]"
    )
    max_te_pp_arcsec: float | None = Field(
        None, gt=0, description="allowed peak-to-peak TE [arcsec]"
    )
    min_contacts: int | None = Field(None, ge=0, description="fewest loaded pins allowed")
    max_lost_motion_arcmin: float | None = Field(
        None, gt=0, description="largest allowed lost motion [arcmin] (computes it)"
    )
    objective: Literal["max_contact_stress", "te_pp", "lost_motion", "play"] = Field(
        "max_contact_stress", description="metric minimised"
    )
    rings: int = Field(
        0, ge=0, le=MAX_RINGS, description="rings drawn from [tolerance] (0: nominal map)"
    )
    lost_motion: bool | None = Field(
        None,
        description="compute the lost motion (default: if it is the objective or constrained)",
    )

    @model_validator(mode="after")
    def _something_swept(self) -> DesignSpaceSection:
        ranges = [getattr(self, k) for k in ("pin_circle_radius_um", "pin_radius_um")]
        ranges.append(self.rotation_urad)
        size = math.prod(r.points for r in ranges if r is not None)
        if size > MAX_CANDIDATES:
            raise ValueError(
                f"the design space has {size} candidates (the product of the points), "
                f"more than {MAX_CANDIDATES}: use fewer points"
            )
        if self.lost_motion is False and (
            self.max_lost_motion_arcmin is not None or self.objective == "lost_motion"
        ):
            raise ValueError(
                "lost_motion = false, but max_lost_motion_arcmin or objective = "
                '"lost_motion" needs it: leave lost_motion out'
            )
        if not self.axes():
            raise ValueError(
                "sweep at least one of " + ", ".join(self.SWEEPABLE) + " as "
                "{ start = , stop = , points = }"
            )
        return self

    SWEEPABLE: typing.ClassVar[tuple[str, ...]] = (
        "pin_circle_radius_um",
        "pin_radius_um",
        "rotation_urad",
        "pin_circle_radius_mm",
        "pin_radius_mm",
        "eccentricity_mm",
        "width_mm",
    )

    def axes(self) -> dict[str, NDArray]:
        """Swept parameters (study units), in the order Δa, Δρ, δ, a, ρp, e, B."""
        return {
            k: getattr(self, k).values() for k in self.SWEEPABLE if getattr(self, k) is not None
        }

    def constraints_dict(self) -> dict[str, Any]:
        """The constraints that are set, in study units."""
        keys = (
            "max_play_arcmin",
            "min_play_arcmin",
            "allowable_contact_stress_mpa",
            "max_te_pp_arcsec",
            "min_contacts",
            "max_lost_motion_arcmin",
        )
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}


class RequirementsSection(_Section):
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


@dataclass(frozen=True)
class CaseInputs:
    """The core objects of one case, in SI units, ready for :func:`cyclomesh.analyse`."""

    design: PairDesign
    modification: Modification
    errors: PinErrors
    torque: float | NDArray
    """Torque on the disc (stack) [N·m], one value or an array."""
    crank_angles: NDArray
    """Crank angles φin [rad]."""
    groove_deformation: bool
    errors_um: dict[str, NDArray]
    """Per-pin errors in study units (``radial_um``, ``angular_urad``, ``pin_radius_um``),
    read once (lists + file + random draws)."""
    discs: int = 1
    """Number of discs on the pin ring."""
    contact_law: str = "half_plane"
    crank_holes: CrankHoles | None = None
    """The disc's crank holes (``[design.disc]``), or None: held at the bore."""
    disc_body: str = "rigid"
    """``[analysis] disc_body``: "rigid" or "fe" (held at the crank holes if any)."""
    stage: StageDesign | None = None
    """The RV stage (``[stage]``: crank bearings on the crank holes), or None: mesh alone."""

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`cyclomesh.analyse`."""
        return {
            "design": self.design,
            "modification": self.modification,
            "errors": self.errors,
            "torque": self.torque,
            "crank_angles": self.crank_angles,
            "groove_deformation": self.groove_deformation,
            "discs": self.discs,
            "contact_law": self.contact_law,
            **(
                {"disc_body": self.disc_body, "crank_holes": self.crank_holes}
                if self.disc_body != "rigid"
                else {}
            ),
        }


class CaseSpec(_Section):
    """One case of a study: the base of the file deep-merged with the case's keys."""

    name: str = Field(min_length=1, description="name of the case in tables, figures, folders")
    description: str = ""
    design: DesignSection
    modification: ModificationSection = ModificationSection()
    material: MaterialSection = MaterialSection()
    load: LoadSection = LoadSection()
    errors: ErrorsSection = ErrorsSection()
    analysis: AnalysisSection = AnalysisSection()
    stiffness: StiffnessSection | None = None
    stage: StageSection | None = None

    _base_dir: Path = PrivateAttr(default_factory=Path)

    @property
    def label(self) -> str:
        """How messages name the case."""
        return f'case "{self.name}"'

    def pin_errors(self) -> dict[str, NDArray]:
        """Per-pin errors in study units, shape ``(n1,)`` each: lists + file + random.

        Returns ``{"radial_um": [µm], "angular_urad": [µrad], "pin_radius_um": [µm]}``.

        Raises
        ------
        StudyError
            A list of the wrong length, or a bad ``errors.file``.
        """
        pins = self.design.pins
        total: dict[str, NDArray] = {}
        for name in PIN_ERROR_COLUMNS:
            value = getattr(self.errors, name)
            if isinstance(value, list) and len(value) != pins:
                raise StudyError(
                    f"{self.label}: errors.{name}: expected {pins} values (one per pin), "
                    f"got {len(value)}"
                )
            total[name] = np.broadcast_to(np.asarray(value, dtype=float), (pins,)).copy()
        tangential = self.errors.tangential_um
        if isinstance(tangential, list) and len(tangential) != pins:
            raise StudyError(
                f"{self.label}: errors.tangential_um: expected {pins} values (one per pin), "
                f"got {len(tangential)}"
            )
        total["angular_urad"] += tangential_urad(
            np.broadcast_to(np.asarray(tangential, dtype=float), (pins,)),
            self.design.pin_circle_radius_mm,
        )
        if self.errors.file is not None:
            try:
                measured = read_pin_errors_csv(self._base_dir / self.errors.file, pins)
            except StudyError as exc:
                raise StudyError(f"{self.label}: {exc}") from None
            for name in PIN_ERROR_COLUMNS:
                total[name] += measured[name]
        if self.errors.random is not None:
            drawn = self.errors.random.draw(pins, self.design.pin_circle_radius_mm)
            for name in PIN_ERROR_COLUMNS:
                total[name] += drawn[name]
        return total

    def profile_deviation(self) -> ProfileDeviation | None:
        """The table of ``modification.profile_file`` (SI), or None.

        Raises
        ------
        StudyError
            A bad file or table, naming the case, the file and the line.
        """
        if self.modification.profile_file is None:
            return None
        try:
            return read_profile_csv(
                self._base_dir / self.modification.profile_file, self.design.pins - 1
            )
        except StudyError as exc:
            raise StudyError(f"{self.label}: {exc}") from None

    def to_core(self) -> CaseInputs:
        """Convert to the core's SI objects, checked by the core.

        Raises
        ------
        StudyError
            One line naming the case and what is wrong, including the core's
            :class:`DesignError` (undercut profile, interfering pins, K1 ≥ 1, ...).
        """
        d, m = self.design, self.modification
        per_pin = self.pin_errors()
        try:
            design = PairDesign(
                pins=d.pins,
                pin_circle_radius=d.pin_circle_radius_mm * MM,
                pin_radius=d.pin_radius_mm * MM,
                groove_radius=(
                    d.groove_radius_mm
                    if d.groove_radius_mm is not None
                    else d.pin_radius_mm + GROOVE_CLEARANCE_MM
                )
                * MM,
                eccentricity=d.eccentricity_mm * MM,
                width=d.width_mm * MM,
                pin_material=self.material.resolve("pin"),
                disc_material=self.material.resolve("disc"),
                ring_material=self.material.resolve("ring"),
            )
            modification = Modification(
                pin_circle_radius=m.pin_circle_radius_um * UM,
                pin_radius=m.pin_radius_um * UM,
                rotation=m.rotation_urad * URAD,
                profile=self.profile_deviation(),
            )
            errors = pin_errors_si(
                per_pin["radial_um"],
                per_pin["angular_urad"],
                per_pin["pin_radius_um"],
                self.errors.eccentricity_um,
            )
            errors.ring_shape(design.pins)
            check_physical(design, modification, errors)
            try:
                with np.errstate(over="ignore", invalid="ignore"):  # huge tables: inf, refused
                    check_profile(design, modification)
            except DesignError as exc:
                if m.profile_file is None:
                    raise
                what = str(exc).removeprefix("profile deviation: ")
                raise DesignError(f"modification.profile_file {m.profile_file}: {what}") from None
            crank_holes = d.disc.to_core()
            if crank_holes is not None:
                crank_holes.check_fits(design)
            stage = None if self.stage is None else self.stage.to_core(crank_holes, d.discs)
            if stage is not None:
                stage.check_fits(design, d.discs)
        except DesignError as exc:
            raise StudyError(f"{self.label}: {exc}") from None
        if stage is not None and self.analysis.disc_body != "rigid":
            raise StudyError(
                f'{self.label}: [analysis] disc_body = "fe" is not coupled with the [stage] '
                'crank bearings yet: set disc_body = "rigid" or remove [stage]'
            )
        return CaseInputs(
            design=design,
            modification=modification,
            errors=errors,
            torque=(
                np.asarray(self.load.torque_nm, float)
                if isinstance(self.load.torque_nm, list)
                else self.load.torque_nm
            ),
            crank_angles=np.deg2rad(self.analysis.crank_angles_deg()),
            groove_deformation=self.analysis.groove_deformation,
            errors_um=per_pin,
            discs=d.discs,
            contact_law=self.analysis.contact_law,
            crank_holes=crank_holes,
            disc_body=self.analysis.disc_body,
            stage=stage,
        )


class StudyFile(_Section):
    """Top level of a study file, before the cases are merged.

    The section of every kind of study is a field here (``tolerance``; add yours next
    to it, see ``docs/pipeline.md``) and is read as ``study.file.<section>``.
    """

    title: str | None = None
    description: str = ""
    design: DesignSection
    modification: ModificationSection = ModificationSection()
    material: MaterialSection = MaterialSection()
    load: LoadSection = LoadSection()
    errors: ErrorsSection = ErrorsSection()
    analysis: AnalysisSection = AnalysisSection()
    figures: FiguresSection = FiguresSection()
    cases: list[dict[str, Any]] = []
    # --- sections of the kinds of study (one line each; None when absent)
    tolerance: ToleranceSection | None = None
    stiffness: StiffnessSection | None = None  # also per case: cases may override it
    stage: StageSection | None = None  # the RV stage (crank bearings); per case too
    design_space: DesignSpaceSection | None = None
    fe: FeSection | None = None  # cyclomesh fe (the FE model needs the fe extra)
    requirements: RequirementsSection = RequirementsSection()  # checked by every kind


@dataclass(frozen=True)
class Study:
    """A validated study file.

    Attributes
    ----------
    title : str
        From ``title``, else the file name without suffix.
    path : Path
        The study file.
    text : str
        Its content, as read.
    sha256 : str
        SHA-256 of its bytes (hex).
    base : CaseSpec
        The base description (named ``"base"``), before any case's keys.
    cases : list of CaseSpec
        The cases; a file without ``[[cases]]`` has one case, the base, named after the
        title.
    figures : FiguresSection
    file : StudyFile
        Every validated top-level section (``study.file.tolerance``, ...).
    inputs : list of CaseInputs
        The core inputs of every case, built (and checked by the core) once on loading.
    """

    title: str
    description: str
    path: Path
    text: str
    sha256: str
    base: CaseSpec
    cases: list[CaseSpec]
    figures: FiguresSection
    file: StudyFile
    raw: dict[str, Any]
    inputs: list[CaseInputs]

    @property
    def tolerance(self) -> ToleranceSection | None:
        """The validated ``[tolerance]`` section, if any."""
        return self.file.tolerance


def deep_merge(base: Mapping[str, Any], override: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``override`` merged in: tables merge key by key, other values replace."""
    merged = copy.deepcopy(dict(base))
    for key, value in override.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def folder_name(name: str) -> str:
    """A file-system-safe folder name for a case name (letters, digits, ``._-``)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._-")


def _toml_error(text: str, exc: Exception) -> str:
    """``invalid TOML: ...``, naming the key (and its table) of a key or table given
    twice, which tomllib reports by line and column only."""
    message = str(exc)
    where = re.search(r"\(at line (\d+), column \d+\)", message)
    twice = any(
        what in message
        for what in ("Cannot overwrite a value", "Cannot declare", "Cannot mutate immutable")
    )
    if not (where and twice):
        return f"invalid TOML: {message}"
    number = int(where.group(1))
    lines = text.splitlines()
    line = lines[number - 1].strip() if number <= len(lines) else ""
    header = re.match(r"^\[\[?\s*([^\]]+?)\s*\]\]?", line)
    if header:
        return (
            f"table [{header.group(1)}] declared twice (line {number}): "
            "give each table once, with all its keys"
        )
    table = ""
    for previous in reversed(lines[: number - 1]):
        found = re.match(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?", previous)
        if found:
            table = f"[[{found.group(2)}]]" if found.group(1) == "[[" else found.group(2)
            break
    key = line.split("=", 1)[0].strip().strip('"')
    dotted = key if not table or table.startswith("[[") else f"{table}.{key}"
    within = f" of a {table} entry" if table.startswith("[[") else ""
    return (
        f"key {dotted}{within} given twice (line {number}, or set already by a table or "
        "a dotted key above): give each key once"
    )


def load_study(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Study:
    """Read, merge and validate a study file.

    Parameters
    ----------
    path : str or Path
        The TOML study file; relative file names inside it are relative to its folder.
    overrides : mapping, optional
        Keys merged into the base and into every case last (they win), e.g.
        ``{"analysis": {"crank_step_deg": 2.0}}``.

    Returns
    -------
    Study
        With every case validated and converted once to core objects (so that a
        design the core refuses is reported here, before anything runs).

    Raises
    ------
    StudyError
        One line naming the file or the dotted key and what is expected.
    """
    path = Path(path)
    data = read_regular_file(path, "study file", MAX_STUDY_FILE_BYTES)
    try:
        text = data.decode("utf-8")
        raw = tomllib.loads(text)
    except UnicodeDecodeError:
        raise StudyError(f"{path.name}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{path.name}: {_toml_error(text, exc)}") from None
    except RecursionError:
        raise StudyError(f"{path.name}: arrays or tables nested too deeply") from None
    overrides = dict(overrides or {})
    top = deep_merge(raw, {k: v for k, v in overrides.items() if k in CASE_SECTIONS})
    try:
        study_file = StudyFile.model_validate(top)
    except ValidationError as exc:
        raise StudyError(one_line(exc, StudyFile)) from None
    except RecursionError:
        raise StudyError(f"{path.name}: arrays or tables nested too deeply") from None

    base_raw = {key: top[key] for key in CASE_SECTIONS if key in top}
    base = _validate_case({"name": "base", **base_raw}, "base", path.parent)
    title = study_file.title if study_file.title is not None else path.stem
    cases: list[CaseSpec] = []
    for index, case_raw in enumerate(study_file.cases):
        name = case_raw.get("name")
        label = f'case "{name}"' if isinstance(name, str) and name else f"cases[{index}]"
        merged = deep_merge(deep_merge(base_raw, case_raw), overrides)
        cases.append(_validate_case(merged, label, path.parent))
    if not cases:
        cases = [_validate_case({"name": title or "case", **base_raw}, "base", path.parent)]
    seen: dict[str, str] = {}
    for case in cases:
        folder = folder_name(case.name).lower()
        if not folder:
            raise StudyError(f"{case.label}: name needs at least one letter or digit")
        if folder in seen:
            raise StudyError(
                f'{case.label}: name clashes with case "{seen[folder]}" '
                "(case names must differ in letters or digits)"
            )
        seen[folder] = case.name
    inputs = [case.to_core() for case in cases]
    if study_file.fe is not None:
        for case in cases:
            d = case.design
            root = d.pin_circle_radius_mm - d.eccentricity_mm - d.pin_radius_mm
            most = FE_BORE_FRACTION * root
            if study_file.fe.bore_radius_mm >= most:
                raise StudyError(
                    f"{case.label}: fe.bore_radius_mm = {study_file.fe.bore_radius_mm:g}: "
                    f"expected below {FE_BORE_FRACTION:g} of the root radius a - e - ρp, "
                    f"{most:.4g} mm (the disc must have a body between bore and teeth)"
                )
    min_pins = min(case.design.pins for case in cases)
    if study_file.figures.stress_pin is not None and study_file.figures.stress_pin > min_pins:
        raise StudyError(
            f"figures.stress_pin: expected a pin number from 1 to {min_pins}, "
            f"got {study_file.figures.stress_pin}"
        )
    return Study(
        title=title,
        description=study_file.description,
        path=path,
        text=text,
        sha256=hashlib.sha256(data).hexdigest(),
        base=base,
        cases=cases,
        figures=study_file.figures,
        file=study_file,
        raw=raw,
        inputs=inputs,
    )


def _validate_case(raw: dict[str, Any], label: str, base_dir: Path) -> CaseSpec:
    try:
        case = CaseSpec.model_validate(raw)
    except ValidationError as exc:
        message = one_line(exc, CaseSpec)
        raise StudyError(message if label == "base" else f"{label}: {message}") from None
    case._base_dir = base_dir
    return case


# --- one-line messages from pydantic's errors -------------------------------------------


def _show(value: Any) -> str:
    """A value as the user typed it in TOML, shortened."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = '"' + value.replace('"', '\\"') + '"'
    elif isinstance(value, dict):
        text = "a table"
    elif isinstance(value, list):
        text = f"a list of {len(value)} values"
    else:
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


_TAGS = ("uniform", "normal", "true_position")
"""Tags of discriminated unions, which pydantic puts in an error's location."""


def _dotted(loc: tuple[int | str, ...]) -> str:
    text = ""
    for part in loc:
        if part in _TAGS:
            continue
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _model_at(model: type[BaseModel], loc: tuple[int | str, ...]) -> type[BaseModel] | None:
    """The model class that validates the table at ``loc`` (None if not a model)."""
    current: Any = model
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return None
        field = current.model_fields.get(part)
        if field is None:
            return None
        current = field.annotation
        while typing.get_origin(current) in (typing.Union, types.UnionType):
            current = next(a for a in typing.get_args(current) if a is not type(None))
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


_EXPECTED = {
    "float_type": "a number",
    "float_parsing": "a number",
    "int_type": "an integer",
    "int_from_float": "an integer",
    "bool_type": "true or false",
    "string_type": "a string",
    "list_type": "a list",
    "dict_type": "a table",
    "model_type": "a table",
    "model_attributes_type": "a table",
}
_BOUNDS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def one_line(exc: ValidationError, model: type[BaseModel], prefix: str = "") -> str:
    """The first error of ``exc`` as ``dotted.key: what is expected, got what``.

    The one message formatter of every section. An unknown (misspelt) key is reported
    before the missing key that usually comes with it. ``prefix`` is the dotted name of
    the table ``model`` validated (empty for the whole file).
    """
    errors = exc.errors(include_url=False)
    first = min(errors, key=lambda e: e["type"] != "extra_forbidden")
    loc = tuple(first["loc"])
    kind, value, ctx = first["type"], first.get("input"), first.get("ctx", {})
    if kind == "union_tag_invalid":
        loc = (*loc, "distribution")
        hint = (
            " (a true-position zone goes under tolerance.position)"
            if ctx.get("tag") == "true_position"
            else ""
        )
        what = (
            f"unknown distribution {ctx.get('tag')!r}, expected one of {ctx.get('expected_tags')}"
        )
        what += hint
    elif kind == "union_tag_not_found":
        what = "missing distribution (uniform or normal)"
    elif kind == "missing":
        what = "required key missing"
    elif kind == "extra_forbidden":
        parent = _model_at(model, loc[:-1])
        allowed = ", ".join(parent.model_fields) if parent else ""
        what = "unknown key" + (f" (expected one of: {allowed})" if allowed else "")
    elif kind in _EXPECTED:
        what = f"expected {_EXPECTED[kind]}, got {_show(value)}"
    elif kind in _BOUNDS:
        bound = next(iter(ctx.values()))
        shown = f"{bound}" if isinstance(bound, int) else f"{bound:g}"
        what = f"expected a number {_BOUNDS[kind]} {shown}, got {_show(value)}"
    elif kind == "finite_number":
        what = f"expected a finite number, got {_show(value)}"
    elif kind == "literal_error":
        what = f"expected one of {ctx.get('expected')}, got {_show(value)}"
    elif kind in ("too_short", "too_long"):
        limit = ctx.get("min_length", ctx.get("max_length"))
        side = "at least" if kind == "too_short" else "at most"
        what = f"expected {side} {limit} values, got {ctx.get('actual_length')}"
    elif kind == "value_error":
        what = str(ctx.get("error", first["msg"]))
    else:
        what = first["msg"]
    key = _dotted(((prefix,) if prefix else ()) + loc)
    more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return f"{key}: {what}" + (more if len(errors) > 1 else "") if key else what


def parse_section(model: type[_Section], raw: Any, prefix: str) -> Any:
    """Validate one table of a study file on its own, e.g. ``parse_section(ToleranceSection,
    {...}, "tolerance")``; errors as :func:`one_line` with the dotted ``prefix``.

    Raises
    ------
    StudyError
        Not a table, or the first problem of the table.
    """
    if not isinstance(raw, dict):
        raise StudyError(f"{prefix}: expected a table, got {_show(raw)}")
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        raise StudyError(one_line(exc, model, prefix)) from None
