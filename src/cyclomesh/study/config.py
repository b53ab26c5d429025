"""Study files: a TOML description of one or more analysis cases.

A study file holds a base description (``[design]``, ``[modification]``, ``[material]``,
``[load]``, ``[errors]``, ``[analysis]``) and a list of ``[[cases]]``; each case is the
base deep-merged with the case's own keys. Every key a user types carries its unit
(``_mm``, ``_um``, ``_urad``, ``_gpa``, ``_nm``, ``_deg``); :meth:`CaseSpec.to_core`
converts a case to the SI objects of the core (:class:`~cyclomesh.design.PairDesign`,
:class:`~cyclomesh.design.Modification`, :class:`~cyclomesh.design.PinErrors`).

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
    model_validator,
)

from cyclomesh.design import Material, Modification, PairDesign, PinErrors
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.profile import check_profile
from cyclomesh.study.measurements import PIN_ERROR_COLUMNS, read_pin_errors_csv

__all__ = [
    "DesignSection",
    "ModificationSection",
    "MaterialProperties",
    "MaterialSection",
    "LoadSection",
    "RandomErrorsSection",
    "ErrorsSection",
    "AnalysisSection",
    "FiguresSection",
    "CaseSpec",
    "CaseInputs",
    "Study",
    "load_study",
    "crank_angles_deg",
    "deep_merge",
    "pin_errors_si",
]

MM = 1e-3
UM = 1e-6
URAD = 1e-6
GPA = 1e9
CASE_SECTIONS = ("design", "modification", "material", "load", "errors", "analysis")
"""Sections that a case may override."""


def pin_errors_si(
    radial_um: Any, angular_urad: Any, pin_radius_um: Any, eccentricity_um: Any
) -> PinErrors:
    """Core errors (SI) from the study units µm, µrad, µm, µm (leading axes = rings).

    The one conversion of study-file errors, shared with the tolerance studies so that a
    ring written out as a study file reads back to bit-for-bit the same errors.
    """
    return PinErrors(
        radial=np.asarray(radial_um, float) * UM,
        angular=np.asarray(angular_urad, float) * URAD,
        pin_radius=np.asarray(pin_radius_um, float) * UM,
        eccentricity=np.asarray(eccentricity_um, float) * UM,
    )


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


class DesignSection(_Section):
    """``[design]``: the nominal gear pair (Table 1 of [1]); every key is required."""

    pins: int = Field(ge=3, description="number of ring pins n1; the disc has n1 - 1 teeth")
    pin_circle_radius_mm: float = Field(gt=0, description="pin-centre circle radius a [mm]")
    pin_radius_mm: float = Field(gt=0, description="pin radius ρp [mm]")
    groove_radius_mm: float = Field(gt=0, description="pin-groove radius ρg [mm]")
    eccentricity_mm: float = Field(gt=0, description="eccentricity e [mm]")
    width_mm: float = Field(gt=0, description="disc face width B [mm]")


class ModificationSection(_Section):
    """``[modification]``: tooth profile modification (Eq. 3 of [1]); default none."""

    pin_circle_radius_um: float = Field(0.0, description="Δa [µm], negative opens clearance")
    pin_radius_um: float = Field(0.0, description="Δρ [µm], positive opens clearance")
    rotation_urad: float = Field(0.0, description="rotation-angle modification δ [µrad]")


class MaterialProperties(_Section):
    """Elastic constants; a key left out falls back to ``[material]``, then to steel."""

    youngs_modulus_gpa: float | None = Field(None, gt=0, description="E [GPa]")
    poisson_ratio: float | None = Field(None, gt=-1.0, lt=0.5, description="ν [-]")


class MaterialSection(MaterialProperties):
    """``[material]`` for all parts, refined by ``[material.pin|disc|ring]``."""

    pin: MaterialProperties = MaterialProperties()
    disc: MaterialProperties = MaterialProperties()
    ring: MaterialProperties = MaterialProperties()

    def resolve(self, part: Literal["pin", "disc", "ring"]) -> Material:
        """Core :class:`Material` of one part (E in Pa); steel of Table 1 of [1] by default."""
        own: MaterialProperties = getattr(self, part)
        modulus = own.youngs_modulus_gpa or self.youngs_modulus_gpa or 206.0
        ratio = own.poisson_ratio if own.poisson_ratio is not None else self.poisson_ratio
        return Material(youngs_modulus=modulus * GPA, poisson_ratio=0.3 if ratio is None else ratio)


class LoadSection(_Section):
    """``[load]``."""

    torque_nm: float = Field(250.0, gt=0, description="torque on the disc T [N·m]")


class RandomErrorsSection(_Section):
    """``[errors.random]``: one independent uniform draw per pin within ± the half-range.

    The draws use ``numpy.random.default_rng(seed)`` in the fixed order radial,
    angular, pin radius (``n1`` values each), so changing one half-range leaves the
    others' draws unchanged.
    """

    seed: int = Field(ge=0, description="seed of numpy.random.default_rng")
    radial_um: float = Field(0.0, ge=0, description="half-range of εa,i [µm]")
    angular_urad: float = Field(0.0, ge=0, description="half-range of εψ,i [µrad]")
    pin_radius_um: float = Field(0.0, ge=0, description="half-range of ερ,i [µm]")

    def draw(self, pins: int) -> dict[str, NDArray]:
        """Per-pin errors in study units (µm, µrad, µm), shape ``(pins,)`` each."""
        rng = np.random.default_rng(self.seed)
        return {
            name: rng.uniform(-half, half, pins)
            for name, half in (
                ("radial_um", self.radial_um),
                ("angular_urad", self.angular_urad),
                ("pin_radius_um", self.pin_radius_um),
            )
        }


class ErrorsSection(_Section):
    """``[errors]``: pin-ring errors (Eq. 5 of [1]); default none.

    The per-pin errors are the sum of the values given here (a number for every pin or
    a list of n1 numbers), the rows of ``file`` and the draws of ``[errors.random]``.
    """

    eccentricity_um: float = Field(0.0, description="eccentricity error εe [µm]")
    radial_um: PerPin = Field(0.0, description="radial position error εa,i [µm]")
    angular_urad: PerPin = Field(0.0, description="angular position error εψ,i [µrad]")
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


class AnalysisSection(_Section):
    """``[analysis]``: crank angles and the pin-groove deformation switch."""

    crank_start_deg: float = Field(0.0, description="first crank angle [deg]")
    crank_stop_deg: float = Field(360.0, description="crank angle where to stop, excluded [deg]")
    crank_step_deg: float = Field(0.1, gt=0, description="crank angle step [deg]")
    groove_deformation: bool = Field(True, description="the improved model of [1] (Eq. 19)")
    contact_law: Literal["paper", "half_plane"] = Field(
        "paper",
        description=(
            "tooth term of the contact law: Eq. 20 of [1] as published, or the approach of a "
            "half-plane to the disc centre (Johnson eq. 5.41), finite at inflection points"
        ),
    )

    @model_validator(mode="after")
    def _at_least_two_angles(self) -> AnalysisSection:
        if len(self.crank_angles_deg()) < 2:
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
    stress_pin: int = Field(
        20, ge=1, description="pin whose contact stress is drawn over the profile"
    )
    stress_over: Literal["profile_angle", "contact_radius"] = Field(
        "profile_angle", description="abscissa of the contact stress over the tooth profile"
    )
    formats: list[Literal["png", "svg", "pdf"]] = Field(["png", "svg"], min_length=1)
    dpi: int = Field(150, ge=50, le=600, description="resolution of PNG figures [dots/inch]")


@dataclass(frozen=True)
class CaseInputs:
    """The core objects of one case, in SI units, ready for :func:`cyclomesh.analyse`."""

    design: PairDesign
    modification: Modification
    errors: PinErrors
    torque: float
    """Torque on the disc [N·m]."""
    crank_angles: NDArray
    """Crank angles φin [rad]."""
    groove_deformation: bool
    contact_law: str = "paper"

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`cyclomesh.analyse`."""
        return {
            "design": self.design,
            "modification": self.modification,
            "errors": self.errors,
            "torque": self.torque,
            "crank_angles": self.crank_angles,
            "groove_deformation": self.groove_deformation,
            "contact_law": self.contact_law,
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
        if self.errors.file is not None:
            try:
                measured = read_pin_errors_csv(self._base_dir / self.errors.file, pins)
            except StudyError as exc:
                raise StudyError(f"{self.label}: {exc}") from None
            for name in PIN_ERROR_COLUMNS:
                total[name] += measured[name]
        if self.errors.random is not None:
            drawn = self.errors.random.draw(pins)
            for name in PIN_ERROR_COLUMNS:
                total[name] += drawn[name]
        return total

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
                groove_radius=d.groove_radius_mm * MM,
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
            )
            errors = pin_errors_si(
                per_pin["radial_um"],
                per_pin["angular_urad"],
                per_pin["pin_radius_um"],
                self.errors.eccentricity_um,
            )
            errors.ring_shape(design.pins)
            check_profile(design, modification)
        except DesignError as exc:
            raise StudyError(f"{self.label}: {exc}") from None
        return CaseInputs(
            design=design,
            modification=modification,
            errors=errors,
            torque=self.load.torque_nm,
            crank_angles=np.deg2rad(self.analysis.crank_angles_deg()),
            groove_deformation=self.analysis.groove_deformation,
            contact_law=self.analysis.contact_law,
        )


class _StudyFile(_Section):
    """Top level of a study file, before the cases are merged."""

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
    tolerance: dict[str, Any] | None = None
    fe: dict[str, Any] | None = None  # validated by cyclomesh.fe.study (optional extra)


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
    tolerance : dict or None
        The raw ``[tolerance]`` table, validated by :mod:`cyclomesh.tolerance`.
    """

    title: str
    description: str
    path: Path
    text: str
    sha256: str
    base: CaseSpec
    cases: list[CaseSpec]
    figures: FiguresSection
    tolerance: dict[str, Any] | None
    raw: dict[str, Any]

    def to_core(self) -> list[CaseInputs]:
        """Core inputs of every case (checks them all; see :meth:`CaseSpec.to_core`)."""
        inputs = [case.to_core() for case in self.cases]
        min_pins = min(case.design.pins for case in self.cases)
        if self.figures.stress_pin > min_pins:
            raise StudyError(
                f"figures.stress_pin: expected a pin number from 1 to {min_pins}, "
                f"got {self.figures.stress_pin}"
            )
        return inputs


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
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise StudyError(f"study file not found: {path}") from None
    except OSError as exc:
        raise StudyError(f"cannot read study file {path}: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
        raw = tomllib.loads(text)
    except UnicodeDecodeError:
        raise StudyError(f"{path.name}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{path.name}: invalid TOML: {exc}") from None
    overrides = dict(overrides or {})
    top = deep_merge(raw, {k: v for k, v in overrides.items() if k in CASE_SECTIONS})
    try:
        study_file = _StudyFile.model_validate(top)
    except ValidationError as exc:
        raise StudyError(_one_line(exc, _StudyFile)) from None

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
    study = Study(
        title=title,
        description=study_file.description,
        path=path,
        text=text,
        sha256=hashlib.sha256(data).hexdigest(),
        base=base,
        cases=cases,
        figures=study_file.figures,
        tolerance=study_file.tolerance,
        raw=raw,
    )
    study.to_core()
    return study


def _validate_case(raw: dict[str, Any], label: str, base_dir: Path) -> CaseSpec:
    try:
        case = CaseSpec.model_validate(raw)
    except ValidationError as exc:
        message = _one_line(exc, CaseSpec)
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


def _dotted(loc: tuple[int | str, ...]) -> str:
    text = ""
    for part in loc:
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


def _one_line(exc: ValidationError, model: type[BaseModel]) -> str:
    """The first error of ``exc`` as ``dotted.key: what is expected, got what``."""
    errors = exc.errors(include_url=False)
    first = errors[0]
    loc = tuple(first["loc"])
    kind, value, ctx = first["type"], first.get("input"), first.get("ctx", {})
    if kind == "missing":
        what = "required key missing"
    elif kind == "extra_forbidden":
        parent = _model_at(model, loc[:-1])
        allowed = ", ".join(parent.model_fields) if parent else ""
        what = "unknown key" + (f" (expected one of: {allowed})" if allowed else "")
    elif kind in _EXPECTED:
        what = f"expected {_EXPECTED[kind]}, got {_show(value)}"
    elif kind in _BOUNDS:
        bound = next(iter(ctx.values()))
        what = f"expected a number {_BOUNDS[kind]} {bound:g}, got {_show(value)}"
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
    key = _dotted(loc)
    more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return f"{key}: {what}" + (more if len(errors) > 1 else "") if key else what
