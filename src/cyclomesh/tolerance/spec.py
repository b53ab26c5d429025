"""The ``[tolerance]`` section of a study file: distributions of the pin-ring errors.

The study loader hands the raw ``[tolerance]`` table over as a dict;
:func:`parse_tolerance` validates it (pydantic v2, unknown keys refused) and raises
:class:`~cyclomesh.exceptions.StudyError` with a one-line message naming the dotted
key. The shape of the section (see ``examples/tolerance.toml``)::

    [tolerance]
    seed = 20220810                       # ring k's errors depend only on (seed, k)
    rings = 1000                          # how many rings to draw
    allowable_contact_stress_mpa = 1500   # for the exceedance probability
    crank_start_deg = 0.0                 # crank angles start:stop:step [deg],
    crank_stop_deg = 360.0                #   stop excluded
    crank_step_deg = 1.0
    radial_um = { distribution = "uniform", half_range = 4.0 }    # εa,i [µm]
    angular_urad = { distribution = "uniform", half_range = 50.0 }  # εψ,i [µrad]
    pin_radius_um = { distribution = "normal", sigma = 1.0 }      # ερ,i [µm]
    eccentricity_um = { distribution = "uniform", half_range = 2.0 }  # εe [µm], one per ring
    # or, instead of radial_um and angular_urad, a true-position zone of the pin centre:
    # position = { distribution = "true_position", zone_diameter_um = 8.0 }

    [tolerance.allocation]                # for ``cyclomesh allocate``
    target_probability = 0.01
    confidence = 0.95
    factor_max = 4.0
    factor_steps = 8
    bisections = 6

The half range, sigma and zone diameter are in the unit named by the key they sit
under (µm for ``radial_um``, µrad for ``angular_urad``). A kind that is left out has
no error. Every pin draws independently; the eccentricity error is one value per ring.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from cyclomesh.exceptions import StudyError
from cyclomesh.study.config import crank_angles_deg

__all__ = [
    "Uniform",
    "Normal",
    "TruePosition",
    "AllocationSpec",
    "ToleranceSpec",
    "parse_tolerance",
]

_STRICT = ConfigDict(extra="forbid", frozen=True)
_TAGS = ("uniform", "normal", "true_position")


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number")
    return value


class Uniform(BaseModel):
    """Uniform error on [−half_range, +half_range], in the unit of the enclosing key."""

    model_config = _STRICT
    distribution: Literal["uniform"]
    half_range: Annotated[float, Field(ge=0.0)]

    _check = field_validator("half_range")(_finite)

    def scale(self) -> float:
        """Half range [unit of the key]."""
        return self.half_range


class Normal(BaseModel):
    """Normal error with mean 0 and standard deviation sigma, in the unit of the key."""

    model_config = _STRICT
    distribution: Literal["normal"]
    sigma: Annotated[float, Field(ge=0.0)]

    _check = field_validator("sigma")(_finite)

    def scale(self) -> float:
        """Standard deviation [unit of the key]."""
        return self.sigma


class TruePosition(BaseModel):
    """True-position zone: the pin centre is uniform (in area) over a disc of this diameter.

    Gives both the radial error εa,i and the angular error εψ,i = tangential / a.
    """

    model_config = _STRICT
    distribution: Literal["true_position"]
    zone_diameter_um: Annotated[float, Field(ge=0.0)]

    _check = field_validator("zone_diameter_um")(_finite)


ErrorDistribution = Annotated[Uniform | Normal, Field(discriminator="distribution")]


class AllocationSpec(BaseModel):
    """Settings of ``cyclomesh allocate`` (tolerance scale-factor allocation).

    Parameters
    ----------
    target_probability : float
        Largest acceptable probability that the peak tooth contact stress exceeds
        the allowable [-].
    confidence : float
        Confidence level of the stated bounds [-].
    factor_max : float
        Largest scale factor on the stated tolerances that is searched [-].
    factor_steps : int
        Number of equal steps of the coarse search on (0, factor_max].
    bisections : int
        Bisection steps per ring after the coarse search (resolution
        factor_max / factor_steps / 2**bisections).
    """

    model_config = _STRICT
    target_probability: Annotated[float, Field(gt=0.0, lt=1.0)] = 0.01
    confidence: Annotated[float, Field(gt=0.0, lt=1.0)] = 0.95
    factor_max: Annotated[float, Field(gt=0.0)] = 4.0
    factor_steps: Annotated[int, Field(ge=1, le=1000)] = 8
    bisections: Annotated[int, Field(ge=0, le=40)] = 6

    _check = field_validator("factor_max")(_finite)


class ToleranceSpec(BaseModel):
    """The validated ``[tolerance]`` section (see the module docstring for the TOML)."""

    model_config = _STRICT
    seed: Annotated[int, Field(ge=0)]
    rings: Annotated[int, Field(ge=1)] = 1000
    allowable_contact_stress_mpa: Annotated[float, Field(gt=0.0)]
    crank_start_deg: float = 0.0
    crank_stop_deg: float = 360.0
    crank_step_deg: Annotated[float, Field(gt=0.0)] = 1.0
    radial_um: ErrorDistribution | None = None
    angular_urad: ErrorDistribution | None = None
    pin_radius_um: ErrorDistribution | None = None
    eccentricity_um: ErrorDistribution | None = None
    position: TruePosition | None = None
    allocation: AllocationSpec = AllocationSpec()

    _check = field_validator(
        "allowable_contact_stress_mpa", "crank_start_deg", "crank_stop_deg", "crank_step_deg"
    )(_finite)

    @model_validator(mode="after")
    def _consistent(self) -> ToleranceSpec:
        if self.position is not None and (
            self.radial_um is not None or self.angular_urad is not None
        ):
            raise ValueError(
                "position (true_position) replaces radial_um and angular_urad; "
                "give one or the other"
            )
        if self.crank_stop_deg <= self.crank_start_deg:
            raise ValueError("crank_stop_deg must be larger than crank_start_deg")
        count = (self.crank_stop_deg - self.crank_start_deg) / self.crank_step_deg
        if count > 1e6:
            raise ValueError("more than a million crank angles; use a larger crank_step_deg")
        if len(self.crank_angles_deg()) < 2:
            raise ValueError("fewer than 2 crank angles; use a smaller crank_step_deg")
        return self

    def crank_angles_deg(self) -> NDArray[np.float64]:
        """Crank angles start, start + step, ... below stop [deg] (as ``[analysis]``)."""
        return crank_angles_deg(self.crank_start_deg, self.crank_stop_deg, self.crank_step_deg)


def _dotted(prefix: str, loc: tuple[Any, ...]) -> str:
    parts = [prefix] + [str(p) for p in loc if p not in _TAGS]
    return ".".join(parts)


def _message(err: dict[str, Any]) -> str:
    kind = err.get("type", "")
    if kind == "union_tag_invalid":
        ctx = err.get("ctx", {})
        hint = " (a true-position zone goes under tolerance.position)"
        return (
            f"unknown distribution {ctx.get('tag')!r}; expected one of {ctx.get('expected_tags')}"
            + (hint if ctx.get("tag") == "true_position" else "")
        )
    if kind == "union_tag_not_found":
        return "missing distribution (uniform or normal)"
    if kind == "extra_forbidden":
        return "unknown key"
    if kind == "missing":
        return "missing (required)"
    msg = str(err.get("msg", "invalid value"))
    return msg.removeprefix("Value error, ")


def parse_tolerance(raw: Any, prefix: str = "tolerance") -> ToleranceSpec:
    """Validate the raw ``[tolerance]`` table of a study file.

    Parameters
    ----------
    raw : dict
        The table as read by ``tomllib``.
    prefix : str
        Dotted name of the table, used in messages.

    Raises
    ------
    StudyError
        One line naming the first offending dotted key, e.g.
        ``tolerance.radial_um.half_range: Input should be greater than or equal to 0``.
    """
    if raw is None:
        raise StudyError(f"the study file has no [{prefix}] section")
    if not isinstance(raw, dict):
        raise StudyError(f"{prefix} must be a table")
    try:
        return ToleranceSpec.model_validate(raw)
    except ValidationError as exc:
        errors = exc.errors()
        # an unknown (misspelt) key explains the missing one that usually comes with it
        err = min(errors, key=lambda e: e.get("type") != "extra_forbidden")
        loc = tuple(err.get("loc", ()))
        if err.get("type") == "union_tag_invalid":
            loc = (*loc, "distribution")
        where = _dotted(prefix, loc)
        extra = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        raise StudyError(f"{where}: {_message(err)}{extra}") from None
