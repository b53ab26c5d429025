"""The one registry of the kinds of study: what each command takes from a study file.

Every command that runs a study file (``run``, ``export``, ``stiffness``, ``efficiency``,
``tolerance``, ``allocate``, ``design``, ``fe``) is one :class:`KindSpec` of
:data:`KINDS`, which holds as data:

* its **section** of the study file (``[tolerance]``, ``[design_space]``, ...: the name
  of its model in :mod:`cyclomesh.studyfile.kind_sections`), a field of
  :class:`~cyclomesh.studyfile.schema.StudyFile` built from this registry;
* its **key usage**: the keys it uses, refuses (with the one-line reason and fix) and
  owns, read by :mod:`cyclomesh.studyfile.usage` (``USED``, ``REFUSED``,
  ``OWN_SECTIONS``, ``NEEDS``);
* its **work estimate** (pin-steps solved and held), read by :func:`check_study_work`;
* its **command line**: the help text, the options (names of :mod:`cyclomesh.cli.options`)
  and the argument; :mod:`cyclomesh.cli` builds one command per entry;
* where its behaviour lives: ``home``, the ``StudyKind`` (compute, write, figures,
  report, pre-flight and the command's steps; :mod:`cyclomesh.studies.execute`),
  imported only when the command runs, so ``cyclomesh --help`` stays fast.

A new kind of study is its module in ``studies/`` and one entry here (with its section
model in ``kind_sections.py``); see ``docs/pipeline.md``, "Recipe: add a kind of study".
This module imports nothing heavy (no pydantic, no NumPy), so the command line reads it
at start.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from cyclomesh.studyfile.limits import check_work, count_crank_angles

__all__ = ["Work", "KindSpec", "KINDS", "kind_spec", "check_study_work"]


@dataclass(frozen=True)
class Work:
    """The work of a study for :func:`~cyclomesh.studyfile.limits.check_work`: the
    product that gives it, pin-steps solved and held [-], the keys to change."""

    what: str
    solved: float
    stored: float
    fix: str


@dataclass(frozen=True)
class KindSpec:
    """One kind of study in the registry (module doc).

    Attributes
    ----------
    command : str
        The ``cyclomesh`` command.
    home : str
        ``"module:NAME"`` of its :class:`~cyclomesh.studies.execute.StudyKind`.
    help : str
        The command's help text (first line: the summary of ``cyclomesh --help``).
    options : tuple of str
        The command's options after ``STUDY.toml`` and ``--out``, in order (names of
        ``cyclomesh.cli.options.OPTIONS``).
    argument : str
        ``"study"``, or the section the file must have (``"tolerance"``,
        ``"design_space"``), which the argument's help names.
    section : tuple of (str, str) or None
        ``(field of StudyFile, model in kind_sections)`` of its own section.
    written_for : callable or None
        ``written_for(study) -> bool``: whether ``cyclomesh check`` checks the file for
        this kind (None: only when asked with ``--kind``).
    own, used : tuple of str
        Keys (or whole tables) it owns (another kind leaves them) and uses; ``used``
        None: the kind takes every key and refuses none (``export``).
    refused : mapping
        Key -> the one-line reason and fix.
    needs : mapping
        Key -> (the key it needs, the refusal without it).
    work : callable or None
        ``work(study, rings) -> Work or None`` (None: no work limit, or no section).
    in_check : bool
        ``cyclomesh check`` applies its work limit.
    overview : bool
        Its default figures are one overview drawn from NumPy arrays (``run``): the
        command forks the process that draws it as it starts, before the study is loaded
        (:class:`cyclomesh.figures.worker.FigureProcess`).
    """

    command: str
    home: str
    help: str
    options: tuple[str, ...]
    argument: str = "study"
    section: tuple[str, str] | None = None
    written_for: Callable[[Any], bool] | None = None
    own: tuple[str, ...] = ()
    used: tuple[str, ...] | None = None
    refused: Mapping[str, str] = field(default_factory=dict)
    needs: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    work: Callable[[Any, int | None], Work | None] | None = None
    in_check: bool = False
    overview: bool = False


# --- the keys: groups several kinds use, and the common refusals --------------------------

ALLOWABLES = tuple(
    f"material.{part}allowable_contact_stress_mpa" for part in ("", "pin.", "disc.", "ring.")
)
"""The allowable contact stresses: the default limits of [requirements]. The kinds that
check requirements use them; an allocation (its own allowable in [tolerance]) leaves them."""

_PAIR = (
    "design.pins",
    "design.pin_circle_radius_mm",
    "design.pin_radius_mm",
    "design.groove_radius_mm",
    "design.eccentricity_mm",
    "design.width_mm",
    "modification",
    "material",
)
_OUTPUT = ("title", "description", "figures.enabled", "figures.formats", "figures.dpi")
_LTCA = (*_PAIR, *_OUTPUT, "design.discs", "load.torque_nm", "errors", "analysis")
RUN_FIGURES = ("figures.crank_angles_deg", "figures.stress_pin", "figures.stress_over")
_RINGS = (
    "tolerance.seed",
    "tolerance.crank_start_deg",
    "tolerance.crank_stop_deg",
    "tolerance.crank_step_deg",
    "tolerance.radial_um",
    "tolerance.angular_urad",
    "tolerance.pin_radius_um",
    "tolerance.eccentricity_um",
    "tolerance.position",
    "tolerance.tangential_um",
)
_CHECKED = ("requirements", *ALLOWABLES)
"""What the kinds that check requirements use besides their own keys."""

_HOLES = (
    "design.disc: the crank holes are the crankshafts of the RV stage, which this kind of "
    "study does not take; remove [design.disc] (cyclomesh run and stiffness take [stage])"
)


def _stage(kind: str) -> str:
    return (
        f"stage: [stage] is not taken by cyclomesh {kind} yet; use cyclomesh run or "
        "cyclomesh stiffness for the RV stage, or remove [stage] (docs/stage.md)"
    )


def _friction(kind: str) -> str:
    return (
        f"friction: [friction] is not taken by cyclomesh {kind} yet; use cyclomesh run, "
        "stiffness, tolerance, allocate or design for friction and efficiency (each also "
        "with [stage]), or remove [friction] (docs/efficiency.md)"
    )


_NEEDS_STAGE = {
    "design.disc": (
        "stage",
        "design.disc: the crank holes are the crankshafts of the RV stage: add [stage] "
        "or remove [design.disc] (docs/stage.md)",
    )
}
_BASE_ONLY = (
    "cases: this kind of study analyses the base description only; remove [[cases]] "
    "(cyclomesh run runs them)"
)
_NO_RUN_FIGURES = "this kind of study draws no load or stress figures; remove the key"
_NO_FIGURES = {key: _NO_RUN_FIGURES for key in RUN_FIGURES}

# --- the work estimates -------------------------------------------------------------------


def _torques(inputs: object) -> int:
    import numpy as np

    return int(np.size(getattr(inputs, "torque", 1)))


def _case_work(study: Any, stiffness: bool) -> Work:
    cases = list(zip(study.cases, study.inputs, strict=True))
    per_case = [
        len(inputs.crank_angles) * case.design.pins * case.design.discs * _torques(inputs)
        for case, inputs in cases
    ]
    what = f"{len(cases)} case(s) x crank angles x pins x discs x torques"
    fix = "analysis.crank_step_deg (or --crank-step-deg)"
    if stiffness:
        points = [case.stiffness.points if case.stiffness else 1 for case, _ in cases]
        per_case = [n * p for n, p in zip(per_case, points, strict=True)]
        what = f"{len(cases)} case(s) x stiffness.points x crank angles x pins x discs"
        fix += " or stiffness.points"
    return Work(what, float(sum(per_case)), float(sum(per_case)), fix)


def _ring_work(study: Any, rings: int | None, allocate: bool) -> Work | None:
    spec = study.file.tolerance
    if spec is None:
        return None
    n = spec.rings if rings is None else rings
    base = study.base
    angles = count_crank_angles(*spec.crank_range(base.analysis))
    ring = angles * base.design.pins * base.design.discs
    steps = 1 if not allocate else spec.allocation.factor_steps
    steps += 0 if not allocate else spec.allocation.bisections
    what = f"{n} rings x {angles:.0f} crank angles x {base.design.pins} pins"
    if steps > 1:
        what += f" x {steps} scale factors"
    fix = "tolerance.rings (or --rings) or tolerance.crank_step_deg"
    return Work(what, float(n) * ring * steps, ring, fix)


def _design_work(study: Any, rings: int | None) -> Work | None:
    space = study.file.design_space
    if space is None:
        return None
    candidates = math.prod(len(v) for v in space.axes().values())
    case, inputs = study.cases[0], study.inputs[0]
    per = len(inputs.crank_angles) * case.design.pins * case.design.discs * _torques(inputs)
    k = max(1, space.rings)
    what = (
        f"{candidates} candidates x {k} ring(s) x {len(inputs.crank_angles)} crank angles "
        f"x {case.design.pins} pins"
    )
    fix = "the design_space points, design_space.rings or analysis.crank_step_deg"
    return Work(what, float(candidates) * k * per, float(k) * per, fix)


# --- the registry ---------------------------------------------------------------------------

_RING_OPTIONS = (
    "rings",
    "scheduler",
    "quiet",
    "workers",
    "chunk_rings",
    "figures",
    "cache_dir",
    "no_work_limit",
)

KINDS: tuple[KindSpec, ...] = (
    KindSpec(
        command="run",
        home="cyclomesh.studies.run:RUN",
        help="Run every case of a study; write results, figures, summary.json and report.html.",
        overview=True,
        options=(
            "quiet",
            "crank_step_deg",
            "figures",
            "csv",
            "cache_dir",
            "no_work_limit",
        ),
        written_for=lambda study: True,
        own=(
            "load.torque_nm",
            "load.input_speed_rpm",
            "stage.rated_torque_nm",
            "stage.duty_cycle",
            "requirements",
            *ALLOWABLES,
        ),
        used=(  # [stage] with [friction]: Coulomb coefficients (stage/friction.py)
            *_LTCA,
            *RUN_FIGURES,
            "cases",
            "stage",
            "design.disc",
            "friction",
            "load.input_speed_rpm",
            *_CHECKED,
        ),
        needs=_NEEDS_STAGE,
        work=lambda study, rings: _case_work(study, False),
        in_check=True,
    ),
    KindSpec(
        command="stiffness",
        home="cyclomesh.studies.stiffness:STIFFNESS",
        help="""Torsion curve of every case ([stiffness] section): play, lost motion, rigidity.

    Writes <case>/stiffness.nc, summary.json, the figures and report.html. Without
    [stage] the numbers are those of the cycloid-pin mesh alone (docs/drive.md); with
    [stage], the requirements check those of the RV stage (mesh, crank bearings and,
    when given, crankshafts and carrier; docs/stage.md), the mesh's are shown beside
    them; with [stage] and [friction] (Coulomb coefficients) the stage's curve is a
    friction loop. The whole reducer is softer than both.
    """,
        options=("quiet", "crank_step_deg", "figures", "cache_dir", "no_work_limit"),
        section=("stiffness", "StiffnessSection"),
        written_for=lambda study: any(case.stiffness is not None for case in study.cases),
        own=("stiffness",),
        used=(
            *_PAIR,
            *_OUTPUT,
            "design.discs",
            "errors",
            "analysis",
            "cases",
            "stiffness",
            "stage",
            "design.disc",
            "friction",
            *_CHECKED,
        ),
        refused={**_NO_FIGURES},
        needs=_NEEDS_STAGE,
        work=lambda study, rings: _case_work(study, True),
    ),
    KindSpec(
        command="tolerance",
        home="cyclomesh.studies.tolerance:TOLERANCE",
        help="Monte Carlo tolerance study: per-ring metrics, statistics, worst ring, report.",
        options=_RING_OPTIONS,
        argument="tolerance",
        section=("tolerance", "ToleranceSection"),
        written_for=lambda study: study.tolerance is not None,
        own=("tolerance", "requirements.tolerance_percentile"),
        used=(
            *_LTCA,
            *_RINGS,
            "stage",
            "design.disc",
            "tolerance.hole_radial_um",
            "tolerance.hole_tangential_um",
            "tolerance.rings",
            "tolerance.allowable_contact_stress_mpa",
            "tolerance.allocation.confidence",
            "friction",
            "load.input_speed_rpm",
            *_CHECKED,
            "requirements.tolerance_percentile",
        ),
        refused={"cases": _BASE_ONLY, **_NO_FIGURES},
        needs=_NEEDS_STAGE,
        work=lambda study, rings: _ring_work(study, rings, False),
        in_check=True,
    ),
    KindSpec(
        command="allocate",
        home="cyclomesh.studies.allocate:ALLOCATE",
        help="Largest scale factor on the tolerances that meets the target exceedance probability.",
        options=("target_probability", *_RING_OPTIONS),
        argument="tolerance",
        written_for=lambda study: study.tolerance is not None,
        own=("tolerance",),
        used=(*_LTCA, "tolerance", "stage", "design.disc", "friction", "load.input_speed_rpm"),
        refused={"cases": _BASE_ONLY, **_NO_FIGURES},
        needs=_NEEDS_STAGE,
        work=lambda study, rings: _ring_work(study, rings, True),
    ),
    KindSpec(
        command="design",
        home="cyclomesh.studies.designmap:DESIGN",
        help="""Design map: sweep the modification, map the metrics, mark the optimum.

    A nominal map runs in this process unless --workers or --scheduler is given; a
    robust map (design_space.rings > 0) runs on all local cores by default.
    """,
        options=(
            "scheduler",
            "quiet",
            "workers",
            "figures",
            "cache_dir",
            "no_work_limit",
        ),
        argument="design_space",
        section=("design_space", "DesignSpaceSection"),
        written_for=lambda study: study.file.design_space is not None,
        own=("design_space",),
        used=(*_LTCA, *_RINGS, "design_space", "friction", "stage", "design.disc", *_CHECKED),
        refused={"cases": _BASE_ONLY, **_NO_FIGURES},
        needs=_NEEDS_STAGE,
        work=_design_work,
        in_check=True,
    ),
    KindSpec(
        command="fe",
        home="cyclomesh.studies.fe:FE",
        help="""Whole-disc finite-element model beside the LTCA, per case (needs the fe extra).

    Writes <case>/fe.nc, <case>/convergence.csv, summary.json, the figures and
    report.html (docs/contact-law.md). The LTCA runs under the study's [analysis]
    settings (contact_law, disc_body).
    """,
        options=("crank_angles", "convergence", "quiet", "figures", "cache_dir"),
        section=("fe", "FeSection"),
        written_for=lambda study: study.file.fe is not None,
        own=("fe",),
        used=(
            *_PAIR,
            *_OUTPUT,
            "load.torque_nm",
            "analysis.contact_law",
            "analysis.disc_body",
            "cases",
            "fe",
            *_CHECKED,
        ),
        refused={
            "design.disc": _HOLES,
            "stage": _stage("fe"),
            "friction": _friction("fe"),
            "design.discs": "the FE model solves one disc; remove [design] discs",
            "errors": "the FE model takes no pin errors yet; remove [errors] (cyclomesh run "
            "handles them)",
            "analysis.crank_start_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
            "analysis.crank_stop_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
            "analysis.crank_step_deg": "cyclomesh fe solves at fe.crank_angles_deg; remove it",
            "analysis.groove_deformation": "the FE model always has the pin-groove contact "
            "(the improved model); remove it",
            **_NO_FIGURES,
        },
    ),
    KindSpec(
        command="export",
        home="cyclomesh.studies.export:EXPORT",
        help="""Export the whole modified disc profile (every tooth) and the pins: DXF, SVG, CSV.

    Writes <case>/profile.dxf (polyline and splines, mm), profile.svg, profile.csv (points
    with outward unit normals) and export.json. Datum: disc centre, tooth space 1 on +x.
    """,
        options=("format", "chord_tolerance_um", "quiet"),
        own=("design.disc.bore_radius_mm",),
    ),
    KindSpec(
        command="efficiency",
        home="cyclomesh.studies.efficiency:EFFICIENCY",
        help="""Efficiency map of every case ([efficiency] and [friction]): forward and back-driving
    efficiency over torque × input speed, the loss breakdown at the rated point.""",
        options=("quiet", "crank_step_deg", "figures"),
        section=("efficiency", "EfficiencySection"),
        written_for=lambda study: study.file.efficiency is not None,
        own=("efficiency",),
        used=(
            *_PAIR,
            *_OUTPUT,
            "design.discs",
            "errors",
            "analysis",
            "cases",
            "friction",
            "efficiency",
            *_CHECKED,
        ),
        refused={
            "design.disc": _HOLES,
            "stage": _stage("efficiency"),
            "analysis.disc_body": "the efficiency map solves the rigid disc (friction is not "
            "coupled with the FE disc body yet); remove disc_body",
            **_NO_FIGURES,
        },
    ),
)
"""Every kind of study, in the order of the commands of ``cyclomesh --help`` (and of
``cyclomesh check``)."""

_BY_COMMAND = {spec.command: spec for spec in KINDS}


def kind_spec(command: str) -> KindSpec:
    """The registry entry of ``command`` (KeyError if there is none)."""
    return _BY_COMMAND[command]


def check_study_work(
    study: object,
    command: str,
    *,
    rings: int | None = None,
    allow: bool = False,
) -> None:
    """:func:`~cyclomesh.studyfile.limits.check_work` of a loaded study for ``command``
    (a kind of :data:`KINDS` with a work estimate, or ``check``: those of the kinds
    ``in_check``); ``rings`` is ``--rings``.

    Raises
    ------
    StudyError
        The work is above a limit (its product and the keys to change in the message).
    """
    specs = [s for s in KINDS if s.in_check] if command == "check" else [kind_spec(command)]
    for spec in specs:
        work = None if spec.work is None else spec.work(study, rings)
        if work is not None:
            check_work(work.what, work.solved, work.stored, work.fix, allow)
