"""The sections of the kinds of study beside a run: ``[tolerance]`` (Monte Carlo
tolerance studies and allocation, ``docs/tolerance.md``) and ``[design_space]`` / ``[fe]``
(design maps, ``docs/design-map.md``; the FE check, ``docs/contact-law.md``).
"""

from __future__ import annotations

import math
import typing
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    Field,
    model_validator,
)

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.limits import (
    MAX_ABS_CRANK_DEG,
    MAX_CANDIDATES,
    MAX_CRANK_ANGLES,
    MAX_RINGS,
    MAX_SEED,
    MIN_CRANK_STEP_DEG,
    count_crank_angles,
)
from cyclomesh.studyfile.sections import AnalysisSection, CrankDeg, StrictSection, crank_angles_deg

__all__ = [
    "Uniform",
    "Normal",
    "TruePosition",
    "AllocationSection",
    "ToleranceSection",
    "RangeSection",
    "FeSection",
    "EfficiencySection",
    "DesignSpaceSection",
]

# --- [tolerance]: Monte Carlo tolerance studies (docs/tolerance.md) ----------------------


class Uniform(StrictSection):
    """Uniform error on [−half_range, +half_range], in the unit of the enclosing key."""

    distribution: Literal["uniform"]
    half_range: float = Field(ge=0.0, description="half range [unit of the key]")

    def scale(self) -> float:
        """Half range [unit of the key]."""
        return self.half_range


class Normal(StrictSection):
    """Normal error with mean 0 and standard deviation sigma, in the unit of the key."""

    distribution: Literal["normal"]
    sigma: float = Field(ge=0.0, description="standard deviation [unit of the key]")

    def scale(self) -> float:
        """Standard deviation [unit of the key]."""
        return self.sigma


class TruePosition(StrictSection):
    """True-position zone: the pin centre is uniform (in area) over a disc of this diameter.

    Gives both the radial error εa,i and the angular error εψ,i = tangential / a.
    """

    distribution: Literal["true_position"]
    zone_diameter_um: float = Field(ge=0.0, description="diameter of the zone [µm]")


ErrorDistribution = Annotated[Uniform | Normal, Field(discriminator="distribution")]


class AllocationSection(StrictSection):
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


class ToleranceSection(StrictSection):
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
    hole_radial_um: ErrorDistribution | None = Field(
        None, description="crank hole position error, radial [µm], per disc and crank ([stage])"
    )
    hole_tangential_um: ErrorDistribution | None = Field(
        None, description="crank hole position error, tangential [µm], per disc and crank"
    )
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


class RangeSection(StrictSection):
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


class EfficiencySection(StrictSection):
    """``[efficiency]``: the efficiency map of ``cyclomesh efficiency`` (docs/efficiency.md)."""

    torque_nm: RangeSection = Field(description="output torques [N·m], > 0")
    input_speed_rpm: RangeSection = Field(description="input (crank) speeds [rpm], > 0")
    rated_torque_nm: float | None = Field(
        None, gt=0, description="rated torque of the loss breakdown [N·m] (default: largest)"
    )
    rated_speed_rpm: float | None = Field(
        None, gt=0, description="rated input speed of the loss breakdown [rpm] (default: largest)"
    )

    @model_validator(mode="after")
    def _positive(self) -> EfficiencySection:
        for name in ("torque_nm", "input_speed_rpm"):
            grid = getattr(self, name)
            if min(grid.start, grid.stop) <= 0:
                raise ValueError(f"{name}: start and stop must be positive")
            if grid.points > 1 and grid.start == grid.stop:
                raise ValueError(f"{name}: start and stop must differ for several points")
        return self

    def rated(self) -> tuple[float, float]:
        """The rated point (torque [N·m], input speed [rpm])."""
        torques, speeds = self.torque_nm.values(), self.input_speed_rpm.values()
        return (
            self.rated_torque_nm if self.rated_torque_nm is not None else float(torques.max()),
            self.rated_speed_rpm if self.rated_speed_rpm is not None else float(speeds.max()),
        )


class FeSection(StrictSection):
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


class DesignSpaceSection(StrictSection):
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
    min_efficiency: float | None = Field(
        None, gt=0, le=1, description="smallest forward efficiency allowed (needs [friction])"
    )
    min_stage_l10_h: float | None = Field(
        None, gt=0, description="shortest L10h of the weakest crank bearing allowed [h] ([stage])"
    )
    min_stage_rigidity_nm_per_arcmin: float | None = Field(
        None, gt=0, description="smallest stage torsional rigidity allowed [N·m/arcmin] ([stage])"
    )
    max_stage_lost_motion_arcmin: float | None = Field(
        None, gt=0, description="largest stage lost motion allowed [arcmin] ([stage])"
    )
    min_stage_efficiency: float | None = Field(
        None,
        gt=0,
        le=1,
        description="smallest forward efficiency of the stage allowed ([stage] and [friction])",
    )
    objective: Literal[
        "max_contact_stress",
        "te_pp",
        "lost_motion",
        "play",
        "efficiency",
        "stage_l10",
        "stage_rigidity",
        "stage_lost_motion",
        "stage_efficiency",
    ] = Field(
        "max_contact_stress",
        description="metric minimised (efficiency, stage_l10, stage_rigidity, "
        "stage_efficiency: maximised)",
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
            "min_efficiency",
            "min_stage_l10_h",
            "min_stage_rigidity_nm_per_arcmin",
            "max_stage_lost_motion_arcmin",
            "min_stage_efficiency",
        )
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}
