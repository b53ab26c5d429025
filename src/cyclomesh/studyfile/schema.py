"""The study file schema: every section of a study file, validated by one set of models.

A study file holds a base description (``[design]``, ``[modification]``, ``[material]``,
``[load]``, ``[errors]``, ``[analysis]``), a list of ``[[cases]]``, ``[figures]`` and
the sections of the other kinds of study (``[tolerance]``, ...). All sections are strict
pydantic models (unknown keys refused, ``"12"`` is not an integer, ``true`` is not a
number) and every problem comes out through one formatter (:func:`one_line`) as one
line naming the dotted key. ``cyclomesh check`` therefore refuses a bad key in any
section before any work is done. To add the section of a new kind of study, see
``docs/pipeline.md``.

The sections live by concern: those of a case in :mod:`cyclomesh.studyfile.sections`
and :mod:`cyclomesh.studyfile.drive_sections`,
those of the other kinds of study in :mod:`cyclomesh.studyfile.kind_sections`, the
one-line formatter in :mod:`cyclomesh.studyfile.messages`; this module assembles them
(:class:`CaseSpec`, :class:`StudyFile`), loads a file (:func:`load_study`) and re-exports
every section model, so ``from cyclomesh.studyfile.schema import ToleranceSection`` works.

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
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    Field,
    PrivateAttr,
    ValidationError,
    create_model,
)

from cyclomesh.core.case import Case, Model
from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.core.friction import Friction
from cyclomesh.core.pair import (
    CrankHoles,
    Modification,
    PairDesign,
    PinErrors,
    check_bore,
    check_physical,
    pin_errors_si,
)
from cyclomesh.core.profile import check_profile
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.studyfile import drive_sections, kind_sections
from cyclomesh.studyfile.drive_sections import (
    FrictionSection,
    LubricantSection,
    StageSection,
    StiffnessSection,
)
from cyclomesh.studyfile.kind_sections import (
    AllocationSection,
    DesignSpaceSection,
    EfficiencySection,
    FeSection,
    Normal,
    ToleranceSection,
    TruePosition,
    Uniform,
)
from cyclomesh.studyfile.kinds import KINDS
from cyclomesh.studyfile.limits import (
    MAX_STUDY_FILE_BYTES,
    read_regular_file,
)
from cyclomesh.studyfile.measurements import (
    PIN_ERROR_COLUMNS,
    name_measured_row,
    read_pin_errors_csv,
)
from cyclomesh.studyfile.messages import one_line, parse_section
from cyclomesh.studyfile.profile_csv import read_profile_csv
from cyclomesh.studyfile.sections import (
    CASE_SECTIONS,
    FE_BORE_FRACTION,
    GROOVE_CLEARANCE_MM,
    AnalysisSection,
    DesignSection,
    ErrorsSection,
    FiguresSection,
    LoadSection,
    MaterialProperties,
    MaterialSection,
    ModificationSection,
    RandomErrorsSection,
    RequirementsSection,
    StrictSection,
    crank_angles_deg,
    tangential_urad,
)
from cyclomesh.units import M_PER_MM, M_PER_UM, RAD_PER_URAD

if TYPE_CHECKING:
    from cyclomesh.stage.solve import StageDesign

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
    "DesignSpaceSection",
    "FrictionSection",
    "LubricantSection",
    "EfficiencySection",
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
    "StrictSection",
    "refuse_stage",
    "folder_name",
]


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
    friction: Friction | None = None
    """``[friction]`` at the input speed, or None: frictionless (the paper's model)."""

    def case(self) -> Case:
        """The case: design, modification, errors, torque, crank angles (SI)."""
        return Case(self.design, self.modification, self.errors, self.torque, self.crank_angles)

    def model(self) -> Model:
        """The model: contact law, groove deformation, disc body, discs, stage, friction."""
        return Model(
            self.contact_law,
            self.groove_deformation,
            self.disc_body,
            self.discs,
            self.stage,
            self.friction,
        )

    @property
    def mesh_friction(self) -> Friction | None:
        """The friction of the mesh alone (on rigid bearings): ``friction``, except with the
        compliant disc beside ``[stage]``, whose friction is solved in the stage's
        equilibrium only (:mod:`cyclomesh.stage.friction`): then None, frictionless."""
        if self.stage is not None and self.disc_body != "rigid":
            return None
        return self.friction

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`cyclomesh.analyse` (the mesh alone: friction
        :attr:`mesh_friction`)."""
        friction = self.mesh_friction
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
            **({"friction": friction} if friction is not None else {}),
        }


class CaseSpec(StrictSection):
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
    friction: FrictionSection | None = None

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
                pin_circle_radius=d.pin_circle_radius_mm * M_PER_MM,
                pin_radius=d.pin_radius_mm * M_PER_MM,
                groove_radius=(
                    d.groove_radius_mm
                    if d.groove_radius_mm is not None
                    else d.pin_radius_mm + GROOVE_CLEARANCE_MM
                )
                * M_PER_MM,
                eccentricity=d.eccentricity_mm * M_PER_MM,
                width=d.width_mm * M_PER_MM,
                pin_material=self.material.resolve("pin"),
                disc_material=self.material.resolve("disc"),
                ring_material=self.material.resolve("ring"),
            )
            modification = Modification(
                pin_circle_radius=m.pin_circle_radius_um * M_PER_UM,
                pin_radius=m.pin_radius_um * M_PER_UM,
                rotation=m.rotation_urad * RAD_PER_URAD,
                profile=self.profile_deviation(),
            )
            errors = pin_errors_si(
                per_pin["radial_um"],
                per_pin["angular_urad"],
                per_pin["pin_radius_um"],
                self.errors.eccentricity_um,
            )
            errors.ring_shape(design.pins)
            try:
                check_physical(design, modification, errors)
            except DesignError as exc:  # a bound on a measured pin: name the file's row
                if self.errors.file is None:
                    raise
                path = self._base_dir / self.errors.file
                raise DesignError(name_measured_row(exc, path, d.pins)) from None
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
            if d.disc.bore_radius_mm is not None:
                check_bore(design, crank_holes, d.disc.bore_radius_mm * M_PER_MM)
            speed = self.load.speed_rpm(d.pins - 1)
            stage = None
            if self.stage is not None:
                given = self.stage.output_speed_rpm
                if (
                    given is not None
                    and self.load.input_speed_rpm is not None
                    and abs(given * (d.pins - 1) - speed) > 1e-9 * speed
                ):
                    raise DesignError(
                        f"stage.output_speed_rpm = {given:g} disagrees with load.input_speed_rpm "
                        f"= {speed:g} (output = input/n2 = {speed / (d.pins - 1):.6g} rpm): "
                        "give load.input_speed_rpm alone"
                    )
                stage = self.stage.to_core(
                    crank_holes, d.discs, speed / (d.pins - 1), self._base_dir
                )
                stage.check_fits(design, d.discs)
            friction = None
            if self.friction is not None:
                friction = self.friction.to_core(speed)
                friction = None if friction.frictionless else friction
        except DesignError as exc:
            raise StudyError(f"{self.label}: {exc}") from None
        if stage is not None and self.analysis.disc_body != "rigid" and stage.bearing is None:
            raise StudyError(
                f'{self.label}: [analysis] disc_body = "fe" with [stage] needs the crank '
                "bearings ([stage.crank_bearing]; rigid bearings hold the hole centres): add "
                'them or set disc_body = "rigid"'
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
            friction=friction,
        )


class _StudyFileBase(StrictSection):
    """The sections of a study file that no kind of study owns."""

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
    stage: StageSection | None = None  # the RV stage (crank bearings); per case too
    friction: FrictionSection | None = None  # friction at the pins; per case too


def _kind_sections() -> dict[str, Any]:
    """The section of every kind of study in the registry
    (:data:`cyclomesh.studyfile.kinds.KINDS`, ``section``), None when absent, then
    ``[requirements]`` (checked by every kind)."""
    fields: dict[str, Any] = {}
    for spec in KINDS:
        if spec.section is not None:
            name, model = spec.section
            section = getattr(kind_sections, model, None) or getattr(drive_sections, model)
            fields[name] = (section | None, None)
    fields["requirements"] = (RequirementsSection, RequirementsSection())
    return fields


StudyFile = create_model(
    "StudyFile",
    __base__=_StudyFileBase,
    __module__=__name__,
    __doc__="""Top level of a study file, before the cases are merged.

    The section of every kind of study is a field here, built from the registry of the
    kinds (:data:`cyclomesh.studyfile.kinds.KINDS`: ``tolerance``, ``design_space``,
    ...; see ``docs/pipeline.md``), and is read as ``study.file.<section>``.
    """,
    **_kind_sections(),
)


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
