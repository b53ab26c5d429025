"""The sections of the drive around the mesh in a study file: ``[friction]``
(``[friction.lubricant]``), ``[stiffness]`` and ``[stage]`` (``[stage.crank_bearing]``,
``[stage.crankshaft]``, ``[stage.carrier]``, ``[stage.duty_cycle]``): strict pydantic
models (:class:`~cyclomesh.studyfile.sections.StrictSection`), every key with its unit
(``docs/study-files.md``). The sections of the mesh itself are
:mod:`cyclomesh.studyfile.sections`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from cyclomesh.core.friction import ISO_VG, MIN_VISCOSITY_CST, Friction, Lubricant
from cyclomesh.core.pair import CrankHoles
from cyclomesh.exceptions import DesignError
from cyclomesh.studyfile.limits import MAX_STIFFNESS_POINTS
from cyclomesh.studyfile.messages import show
from cyclomesh.studyfile.sections import StrictSection
from cyclomesh.units import M_PER_MM, M_PER_UM, RAD_PER_ARCMIN

if TYPE_CHECKING:
    from cyclomesh.stage.duty import DutyCycle
    from cyclomesh.stage.solve import StageDesign

__all__ = [
    "LubricantSection",
    "FrictionSection",
    "StiffnessSection",
    "CrankBearingSection",
    "SupportBearingSection",
    "CrankshaftSection",
    "CarrierSection",
    "DutyCycleSection",
    "StageSection",
]


class LubricantSection(StrictSection):
    """``[friction.lubricant]``: the oil of the lubricated coefficient (Benedict–Kelley in
    the mixed regime of the film parameter λ, docs/efficiency.md)."""

    grade: int | None = Field(
        None, description=f"ISO VG viscosity grade, one of {', '.join(map(str, ISO_VG))}"
    )
    viscosity_40c_cst: float | None = Field(
        None, gt=0, le=1e5, description="kinematic viscosity at 40 °C [cSt] (instead of grade)"
    )
    viscosity_100c_cst: float | None = Field(
        None, gt=0, le=1e4, description="kinematic viscosity at 100 °C [cSt]"
    )
    temperature_c: float = Field(40.0, ge=-30, le=150, description="oil temperature [°C]")
    roughness_um: float = Field(0.4, ge=0, lt=1, description="mean roughness Ra [µm]")
    composite_roughness_um: float | None = Field(
        None,
        gt=0,
        lt=10,
        description="composite roughness √(σ1² + σ2²) of the film parameter [µm] "
        "(default √2·roughness_um)",
    )
    pressure_viscosity_per_gpa: float = Field(
        20.0, gt=0, lt=100, description="pressure-viscosity coefficient α [1/GPa]"
    )
    density_kg_m3: float = Field(880.0, ge=500, le=2000, description="oil density [kg/m³]")

    @model_validator(mode="after")
    def _one_viscosity(self) -> LubricantSection:
        if (self.grade is None) == (self.viscosity_40c_cst is None):
            raise ValueError("give grade (ISO VG) or viscosity_40c_cst, one of them")
        if self.grade is not None and self.grade not in ISO_VG:
            raise ValueError(
                f"grade: expected an ISO VG grade ({', '.join(map(str, ISO_VG))}), got {self.grade}"
            )
        if self.viscosity_40c_cst is not None and self.viscosity_100c_cst is None:
            raise ValueError("viscosity_40c_cst needs viscosity_100c_cst")
        at_40 = self.viscosity_40c_cst or ISO_VG.get(self.grade or 0, (math.inf,))[0]
        if self.viscosity_100c_cst is not None and not (
            MIN_VISCOSITY_CST <= self.viscosity_100c_cst < at_40
        ):
            raise ValueError(
                f"viscosity_100c_cst: expected at least {MIN_VISCOSITY_CST:g} cSt (Walther's "
                "equation, ASTM D341) and below viscosity_40c_cst (oil thins as it warms), "
                f"got {self.viscosity_100c_cst:g}"
            )
        return self

    def to_core(self) -> Lubricant:
        """The :class:`~cyclomesh.core.friction.Lubricant` (SI roughness)."""
        nu40, nu100 = ISO_VG[self.grade] if self.grade is not None else (None, None)
        return Lubricant(
            viscosity_40=self.viscosity_40c_cst or nu40,
            viscosity_100=self.viscosity_100c_cst or nu100,
            temperature=self.temperature_c,
            roughness=self.roughness_um * M_PER_UM,
            composite_roughness=None
            if self.composite_roughness_um is None
            else self.composite_roughness_um * M_PER_UM,
            pressure_viscosity=self.pressure_viscosity_per_gpa * 1e-9,
            density=self.density_kg_m3,
        )


class FrictionSection(StrictSection):
    """``[friction]``: friction at the pin contacts, in the equilibrium (docs/efficiency.md)."""

    mesh_coefficient: float = Field(
        0.0, ge=0, lt=1, description="Coulomb coefficient pin-tooth (boundary value)"
    )
    groove_coefficient: float = Field(
        0.0, ge=0, lt=1, description="Coulomb coefficient pin-groove (boundary value)"
    )
    bearing_coefficient: float = Field(
        0.0, ge=0, lt=1, description="crank bearing friction coefficient μ (SKF: M = μ·P·d/2)"
    )
    bearing_diameter_mm: float | None = Field(
        None, gt=0, le=1e4, description="bore diameter d of the crank bearing [mm]"
    )
    pins: Literal["rolling", "fixed"] = Field(
        "rolling", description="pins free to turn in their grooves, or fixed"
    )
    lubricant: LubricantSection | None = None

    @model_validator(mode="after")
    def _caps(self) -> FrictionSection:
        if self.bearing_coefficient > 0 and self.bearing_diameter_mm is None:
            raise ValueError(
                "bearing_coefficient needs bearing_diameter_mm (the crank bearing's bore)"
            )
        if self.lubricant is not None and (
            self.mesh_coefficient == 0 or (self.pins == "rolling" and self.groove_coefficient == 0)
        ):
            raise ValueError(
                "lubricant: give mesh_coefficient (and groove_coefficient for rolling pins) > 0: "
                "the boundary friction that caps the lubricated coefficient"
            )
        return self

    def to_core(self, speed_rpm: float) -> Friction:
        """The :class:`~cyclomesh.core.friction.Friction` at ``speed_rpm`` (input speed)."""
        return Friction(
            mesh=self.mesh_coefficient,
            groove=self.groove_coefficient,
            bearing=self.bearing_coefficient,
            pins=self.pins,
            lubricant=None if self.lubricant is None else self.lubricant.to_core(),
            speed=speed_rpm * 2.0 * math.pi / 60.0,
            bearing_diameter=(self.bearing_diameter_mm or 0.0) * M_PER_MM,
        )


class StiffnessSection(StrictSection):
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
                raise ValueError(f"expected numbers [µm], got {show(item)}")
            if not math.isfinite(item):
                raise ValueError(f"expected finite numbers [µm], got {item}")
    return value


PerCrank = Annotated[Any, BeforeValidator(_per_crank)]


class CrankBearingSection(StrictSection):
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


class SupportBearingSection(StrictSection):
    """``[stage.crankshaft.support_bearing]``: each of a crankshaft's two support bearings,
    a tapered roller bearing preloaded against the other (its radial stiffness from the
    geometry, :class:`cyclomesh.stage.bearing.TaperedRollerBearing`)."""

    rollers: int = Field(ge=3, description="number of rollers Z")
    roller_length_mm: float = Field(gt=0, description="effective contact length l_we [mm]")
    contact_angle_deg: float = Field(
        gt=0, lt=90, description="contact angle α of the raceways (mean of cone and cup) [deg]"
    )
    preload_n: float = Field(gt=0, description="axial preload of the pair [N]")


class CrankshaftSection(StrictSection):
    """``[stage.crankshaft]``: every crankshaft as a beam on two support bearings."""

    support_span_mm: float = Field(
        gt=0, description="distance between the crankshaft's two support bearings [mm]"
    )
    disc_pitch_mm: float = Field(
        gt=0, description="axial distance between neighbouring discs' mid-planes [mm]"
    )
    support_bearing_stiffness_n_per_um: float | None = Field(
        None,
        gt=0,
        description="radial stiffness of each support bearing [N/µm] (omitted: rigid, or "
        "from [stage.crankshaft.support_bearing])",
    )
    support_bearing: SupportBearingSection | None = Field(
        None, description="the support bearings' geometry, instead of their stiffness"
    )

    @model_validator(mode="after")
    def _stiffness_or_geometry(self) -> CrankshaftSection:
        if self.support_bearing is not None and self.support_bearing_stiffness_n_per_um is not None:
            raise ValueError(
                "give support_bearing_stiffness_n_per_um or [stage.crankshaft.support_bearing], "
                "not both"
            )
        return self


class CarrierSection(StrictSection):
    """``[stage.carrier]``: the pillars joining the output flange and the end plate."""

    pillars: int = Field(ge=2, description="number of pillars")
    pillar_diameter_mm: float = Field(gt=0, description="pillar diameter [mm]")
    pillar_length_mm: float = Field(gt=0, description="free length between the flanges [mm]")
    pillar_circle_radius_mm: float = Field(gt=0, description="radius of the pillars' circle [mm]")


class DutyCycleSection(StrictSection):
    """``[stage.duty_cycle]``: a load spectrum of the output, one value per step, given
    either as the three lists or as ``file``, a CSV with the columns ``torque_nm``,
    ``output_speed_rpm`` and ``time_share`` (one row per step, relative to the study)."""

    torque_nm: list[float] | None = Field(
        None, min_length=1, description="output torque of each step [N·m]"
    )
    output_speed_rpm: list[float] | None = Field(
        None, min_length=1, description="output speed of each step [rpm]"
    )
    time_share: list[float] | None = Field(
        None, min_length=1, description="share of the time of each step (normalised)"
    )
    file: str | None = Field(
        None,
        description="CSV of the steps (columns torque_nm, output_speed_rpm, time_share), "
        "instead of the three lists",
    )

    @model_validator(mode="after")
    def _lists_or_file(self) -> DutyCycleSection:
        lists = [self.torque_nm, self.output_speed_rpm, self.time_share]
        if self.file is not None:
            if any(v is not None for v in lists):
                raise ValueError(
                    "give the steps either as file or as torque_nm, output_speed_rpm and "
                    "time_share, not both"
                )
        elif any(v is None for v in lists):
            raise ValueError(
                "needs torque_nm, output_speed_rpm and time_share (one value per step each), "
                "or file (a CSV with those columns)"
            )
        return self

    def to_core(self, base_dir: Path) -> DutyCycle:
        """The :class:`~cyclomesh.stage.duty.DutyCycle` (torque [N·m], speed [rpm], share);
        ``file`` is read relative to ``base_dir``."""
        from cyclomesh.stage.duty import DutyCycle  # the stage only where a study has one

        if self.file is None:
            return DutyCycle(
                tuple(self.torque_nm or ()),
                tuple(self.output_speed_rpm or ()),
                tuple(self.time_share or ()),
            )
        from cyclomesh.studyfile.loops import read_duty_csv

        key = "stage.duty_cycle.file"
        torque, speed, share = read_duty_csv(base_dir / self.file, key)
        try:
            return DutyCycle(torque, speed, share)
        except DesignError as exc:
            what = str(exc).removeprefix("stage.duty_cycle.")
            raise DesignError(f"{key}: {self.file}: {what}") from None


class StageSection(StrictSection):
    """``[stage]``: the RV stage around the mesh: crank bearings, springs, hole errors.

    The crankshafts are the crank holes of ``[design.disc]`` (``crank_holes``,
    ``crank_hole_circle_radius_mm``, ``crank_hole_radius_mm``): one set of keys.
    """

    output_speed_rpm: float | None = Field(
        None,
        gt=0,
        description="output speed for L10h [rpm]; default load.input_speed_rpm/n2 (15 rpm); "
        "refused when it disagrees with load.input_speed_rpm",
    )
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

    def to_core(
        self,
        holes: CrankHoles | None,
        discs: int,
        output_speed: float = 15.0,
        base_dir: Path | None = None,
    ) -> StageDesign:
        """The :class:`~cyclomesh.stage.solve.StageDesign` in SI units; ``output_speed``
        [rpm] from ``load.input_speed_rpm`` where ``output_speed_rpm`` is not given;
        ``base_dir``: the study's folder (a duty cycle's ``file`` is relative to it)."""
        from cyclomesh.stage.bearing import (
            RollerSet,
            TaperedRollerBearing,
        )  # the stage only where a study has one
        from cyclomesh.stage.carrier import Carrier
        from cyclomesh.stage.crankshaft import Crankshaft
        from cyclomesh.stage.solve import StageDesign

        if holes is None:
            raise DesignError(
                "stage: needs the crankshafts: set [design.disc] crank_holes (2 or 3), "
                "crank_hole_circle_radius_mm and crank_hole_radius_mm"
            )
        bearing = None
        b = self.crank_bearing
        if b is not None:
            if b.roller_diameter_mm * M_PER_MM >= holes.radius:  # the crank pin: 2R - 2d > 0
                raise DesignError(
                    f"stage.crank_bearing.roller_diameter_mm = {b.roller_diameter_mm:g}: two "
                    "rollers and the crank pin between them must fit across the crank hole "
                    f"(design.disc.crank_hole_radius_mm = {holes.radius / M_PER_MM:g}); it "
                    f"must be below {holes.radius / M_PER_MM:g} mm"
                )
            bearing = RollerSet(
                rollers=b.rollers,
                diameter=b.roller_diameter_mm * M_PER_MM,
                length=b.roller_length_mm * M_PER_MM,
                clearance=b.radial_clearance_um * M_PER_UM,
                pitch_diameter=2.0 * holes.radius - b.roller_diameter_mm * M_PER_MM,
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
                support_span=self.crankshaft.support_span_mm * M_PER_MM,
                disc_pitch=self.crankshaft.disc_pitch_mm * M_PER_MM,
                pin_diameter=2.0 * holes.radius - 2.0 * b.roller_diameter_mm * M_PER_MM,
                support_stiffness=(
                    None
                    if self.crankshaft.support_bearing_stiffness_n_per_um is None
                    else self.crankshaft.support_bearing_stiffness_n_per_um / M_PER_UM
                ),
                support_bearing=(
                    None
                    if (sb := self.crankshaft.support_bearing) is None
                    else TaperedRollerBearing(
                        rollers=sb.rollers,
                        length=sb.roller_length_mm * M_PER_MM,
                        contact_angle=math.radians(sb.contact_angle_deg),
                        preload=sb.preload_n,
                    )
                ),
            )
            crankshaft.positions(discs)  # the stack fits between the supports
        if self.carrier is not None:
            c = self.carrier
            carrier = Carrier(
                pillars=c.pillars,
                pillar_diameter=c.pillar_diameter_mm * M_PER_MM,
                pillar_length=c.pillar_length_mm * M_PER_MM,
                pillar_circle_radius=c.pillar_circle_radius_mm * M_PER_MM,
            )
        duty = None
        if self.duty_cycle is not None:
            duty = self.duty_cycle.to_core(Path() if base_dir is None else base_dir)
        stage = StageDesign(
            holes=holes,
            bearing=bearing,
            crankshaft=crankshaft,
            carrier=carrier,
            duty_cycle=duty,
            crankshaft_stiffness=(
                None
                if self.crankshaft_stiffness_n_per_um is None
                else self.crankshaft_stiffness_n_per_um / M_PER_UM
            ),
            carrier_stiffness=(
                None
                if self.carrier_stiffness_nm_per_arcmin is None
                else self.carrier_stiffness_nm_per_arcmin / RAD_PER_ARCMIN
            ),
            hole_error_radial=np.asarray(self.hole_error_radial_um, float) * M_PER_UM,
            hole_error_tangential=np.asarray(self.hole_error_tangential_um, float) * M_PER_UM,
            output_speed=(
                self.output_speed_rpm if self.output_speed_rpm is not None else output_speed
            ),
        )
        stage.hole_errors(discs)  # the shapes, checked here
        return stage
