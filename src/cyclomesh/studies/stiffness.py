"""Stiffness studies: the torsion curve of every case of a study file (``cyclomesh stiffness``).

For each case, the ``[stiffness]`` section (:class:`~cyclomesh.studyfile.schema.StiffnessSection`,
per case: cases may override it) gives ``rated_torque_nm`` (required), ``points``
(default 41) and ``series_stiffness_nm_per_arcmin`` (optional); the crank angles come
from ``[analysis]``. Stages (see ``docs/pipeline.md``):

1. :func:`check_stiffness`: every case has a ``[stiffness]`` section;
2. :func:`compute_stiffness`: the torsion curve of every case
   (:func:`cyclomesh.results.torsion.stiffness`) and its headline numbers
   (:data:`cyclomesh.results.metrics.STIFFNESS_METRICS`); nothing is written;
3. :func:`write_stiffness`: ``<case>/stiffness.nc`` and ``summary.json``;
4. :func:`stiffness_figures`, :func:`stiffness_sections`: figure jobs and report sections
   for :func:`cyclomesh.publish.pipeline.publish`.

The numbers are those of the cycloid-pin mesh alone; the whole-drive curve (with the
series stiffness) is reported beside it, never instead of it. See ``docs/drive.md``.
"""

from __future__ import annotations

import html
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cyclomesh.exceptions import CyclomeshError, StudyError
from cyclomesh.publish.pipeline import case_attrs, summary_document
from cyclomesh.results.metrics import STIFFNESS_METRICS
from cyclomesh.studies.execute import CommandSteps, StudyKind
from cyclomesh.studyfile.schema import CaseSpec, StiffnessSection, Study, folder_name

if TYPE_CHECKING:
    import xarray as xr

    from cyclomesh.figures.render import FigureJob
    from cyclomesh.publish.report import Section

__all__ = [
    "CAVEAT",
    "StiffnessResult",
    "check_stiffness",
    "compute_stiffness",
    "write_stiffness",
    "stiffness_figures",
    "stiffness_sections",
]

CAVEAT = (
    "These are the characteristics of the cycloid-pin mesh alone. A whole RV reducer is "
    "much softer: crank bearings, crankshafts and the first stage add compliance in series "
    "(RV catalogues quote about 113 N·m/arcmin for a reducer of the size of the Table 1 "
    "pair, RV-42N, rated 412 N·m, lost motion < 1 arcmin). Do not compare the mesh "
    "rigidity with a catalogue figure; [stiffness] series_stiffness_nm_per_arcmin adds "
    "the rest of the drive as a linear spring in series, reported beside the mesh."
)
DEFINITIONS = (
    "play = TE of the reverse-flank rest position − TE of the forward-flank rest position "
    "(zero load); lost motion = TE(−3 % T_r) − TE(+3 % T_r); torsional rigidity = mean "
    "over both directions of 0.5·T_r/|TE(±T_r) − TE(±0.5·T_r)|."
)


@dataclass
class StiffnessResult:
    """The torsion curves of a study, in memory."""

    study: Study
    curves: dict[str, xr.Dataset] = field(default_factory=dict)
    """Case name → Dataset of :func:`cyclomesh.results.torsion.stiffness`, with the case inputs."""
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → rated torque, discs and :data:`STIFFNESS_METRICS` (JSON numbers)."""
    checks: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Case name → requirement checks and design warnings (:mod:`cyclomesh.studies.checks`)."""
    seconds: float = 0.0
    warnings: dict[str, list[str]] = field(default_factory=dict)
    """Case name → warnings (:mod:`cyclomesh.studyfile.warnings`)."""

    def study_warnings(self) -> list[str]:
        """The warnings of the study, each once (prefixed by the case where not all)."""
        from cyclomesh.studyfile.warnings import merge_warnings

        return merge_warnings(self.warnings)


def _section(case: CaseSpec) -> StiffnessSection:
    if case.stiffness is None:
        raise StudyError(
            f"{case.label}: no [stiffness] section: give at least stiffness.rated_torque_nm "
            "(see examples/stiffness.toml)"
        )
    return case.stiffness


def check_stiffness(study: Study) -> None:
    """Raise a :class:`StudyError` naming the first case without a ``[stiffness]`` section."""
    for case in study.cases:
        _section(case)


def at_rest(friction: Any) -> Any:
    """The friction of the torsion test: at rest there is no entrainment, so no film (film
    parameter λ = 0) and a lubricated coefficient is its boundary value
    (:func:`cyclomesh.core.friction.boundary_share` = 1 below λ = 1): the lubricant is
    dropped and the boundary coefficients of ``[friction]`` apply."""
    if friction is None or friction.lubricant is None:
        return friction
    import dataclasses

    return dataclasses.replace(friction, lubricant=None)


def _lubricant_note(friction: Any) -> str | None:
    if friction is None or friction.lubricant is None:
        return None
    return (
        "friction.lubricant: the torsion test is at rest (no oil film), so the boundary "
        "coefficients mesh_coefficient and groove_coefficient apply; the lubricant acts in "
        "cyclomesh run, efficiency and tolerance"
    )


def compute_stiffness(
    study: Study, *, backend: Any = None, progress: Callable[[int], None] | None = None
) -> StiffnessResult:
    """Compute the torsion curve of every case (nothing is written).

    ``progress(1)`` is called after each case; ``backend`` is not used (one signature
    for every kind). One case is one vectorised core call per
    torque (0.4 s for 42 torques × 360 crank angles × 40 pins), so the cases run here.
    """
    from cyclomesh.output.writers import jsonable
    from cyclomesh.results.torsion import stiffness, summarize_stiffness
    from cyclomesh.studies.checks import case_checks, case_warnings
    from cyclomesh.studyfile.usage import check_keys

    check_stiffness(study)
    check_keys(study.raw, "stiffness")
    from cyclomesh.studies.preflight import refuse_friction_with_stage

    refuse_friction_with_stage(study)
    start = time.perf_counter()
    result = StiffnessResult(study=study)
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        section = _section(case)
        try:
            ds = stiffness(
                inputs.design,
                inputs.modification,
                inputs.errors,
                section.rated_torque_nm,
                section.points,
                groove_deformation=inputs.groove_deformation,
                crank_angles_deg=case.analysis.crank_angles_deg(),
                discs=inputs.discs,
                series_stiffness_nm_per_arcmin=section.series_stiffness_nm_per_arcmin,
                contact_law=inputs.contact_law,
                disc_body=inputs.disc_body,
                crank_holes=inputs.crank_holes,
                friction=at_rest(inputs.mesh_friction),
            )
        except CyclomeshError as exc:  # name the case
            raise type(exc)(f"{case.label}: {exc}") from None
        ds.attrs.update(case_attrs(study, case))
        stage_summary: dict[str, Any] = {}
        if inputs.stage is not None:  # the RV stage in one solve, beside the mesh alone
            from cyclomesh.results.stage import stage_torsion_variables

            data, stage_summary = stage_torsion_variables(
                inputs, section.rated_torque_nm, section.points, inputs.crank_angles
            )
            ds = ds.assign(data)
        summary = summarize_stiffness(ds)
        if section.measured_file is not None:  # read back beside the model, never applied
            ds, measured = _measured(case, section, ds, summary, stage_summary)
            stage_summary = {**stage_summary, **measured}
        result.curves[case.name] = ds
        record: dict[str, Any] = {"rated_torque_nm": section.rated_torque_nm}
        record["discs"] = inputs.discs
        record.update(
            {
                name: jsonable(summary[name].values[()])
                for name in STIFFNESS_METRICS
                if name in summary
            }
        )
        record.update(stage_summary)
        result.summaries[case.name] = record
        result.warnings[case.name] = case_warnings(
            case, inputs, ds, _lubricant_note(inputs.friction)
        )
        result.checks[case.name] = case_checks(study, case, inputs, record, ds[["play"]])
        if progress:
            progress(1)
    result.seconds = time.perf_counter() - start
    return result


def _measured(case: Any, section: Any, ds: Any, summary: Any, stage_summary: dict):
    """The measured loop of ``[stiffness] measured_file`` against the stage (or the mesh)."""
    from cyclomesh.results.datasheet import measured_loop_variables
    from cyclomesh.studyfile.loops import read_loop_csv

    torque, twist = read_loop_csv(case._base_dir / section.measured_file)
    if "stage_torsional_rigidity_nm_per_arcmin_mean" in stage_summary:
        rigidity = stage_summary["stage_torsional_rigidity_nm_per_arcmin_mean"]
        lost = stage_summary["stage_lost_motion_arcmin_mean"]
    else:
        rigidity = float(summary["torsional_rigidity_nm_per_arcmin_mean"].values[()])
        lost = float(summary["lost_motion_arcmin_mean"].values[()])
    try:
        data, measured = measured_loop_variables(
            torque, twist, section.rated_torque_nm, rigidity, lost
        )
    except CyclomeshError as exc:
        raise StudyError(f"stiffness.measured_file: {section.measured_file}: {exc}") from None
    return ds.assign(data), measured


def write_stiffness(result: StiffnessResult, out: Path) -> list[Path]:
    """Write ``<case>/stiffness.nc`` of every case and ``summary.json`` into ``out``."""
    from cyclomesh.output.writers import write_case_netcdf, write_json

    study = result.study
    written, records = write_case_netcdf(
        study,
        out,
        result.curves,
        "stiffness.nc",
        lambda case: {
            **result.summaries[case.name],
            "checks": result.checks[case.name],
            "warnings": result.warnings.get(case.name, []),
        },
    )
    from cyclomesh.results.stage import STAGE_STIFFNESS_METRICS

    document = summary_document(
        study,
        {name: m.unit for name, m in (STIFFNESS_METRICS | STAGE_STIFFNESS_METRICS).items()},
        records,
        scope="cycloid-pin mesh only; drive_* numbers add the series stiffness",
        warnings=result.study_warnings(),
    )
    written.append(write_json(out / "summary.json", document))
    return written


_HEADINGS = {
    "torsion_curve": "Torsion curve",
    "torsional_rigidity": "Torsional rigidity",
    "play": "Play and lost motion",
    "torque_share": "Torque split between the discs",
    "stage_torsion_curve": "Torsion curve of the RV stage",
    "measured_loop": "Measured loop",
}


def _curves(result: StiffnessResult, names: tuple[str, ...]) -> dict[str, xr.Dataset]:
    """Only the variables a figure needs (jobs may be pickled to a worker)."""
    return {
        case: ds[[n for n in names if n in ds]].assign_attrs(ds.attrs)
        for case, ds in result.curves.items()
    }


def stiffness_figures(result: StiffnessResult) -> list[FigureJob]:
    """The figures of a stiffness study as jobs for :func:`cyclomesh.publish.pipeline.publish`."""
    from cyclomesh.figures import drive as plots
    from cyclomesh.figures.render import FigureJob

    def job(name: str, plot: Callable[..., Any], *args: Any, caption: str) -> FigureJob:
        return FigureJob(name, plot, args, caption=caption, section=_HEADINGS[name])

    jobs = [
        job(
            "torsion_curve",
            plots.plot_torsion_curve,
            _curves(
                result,
                (
                    "rotation",
                    "drive_rotation",
                    "lost_motion",
                    "drive_lost_motion",
                    "torsional_rigidity",
                    "drive_torsional_rigidity",
                ),
            ),
            caption="Torsion curve: rotation of the disc (stack) from its theoretical position "
            "against torque in % of rated; band: range over the crank angles, line: mean; "
            "arrow: lost motion between -3 % and +3 %; dotted: rigidity secants 50-100 %. "
            "Right: the whole drive with the series stiffness, if given.",
        ),
        job(
            "torsional_rigidity",
            plots.plot_rigidity,
            _curves(result, ("torsional_rigidity", "drive_torsional_rigidity")),
            caption="Torsional rigidity over the crank angle (secant between 50 % and 100 % "
            "of rated, mean of both directions).",
        ),
        job(
            "play",
            plots.plot_play,
            _curves(result, ("play", "lost_motion", "drive_lost_motion")),
            caption="Play at zero load and lost motion (±3 % of rated) over the crank angle.",
        ),
    ]
    names = (
        "rotation",
        "stage_rotation",
        "lost_motion",
        "stage_lost_motion",
        "torsional_rigidity",
        "stage_torsional_rigidity",
        "stage_rotation_ascending",
        "stage_rotation_descending",
        "stage_hysteresis",
    )
    staged = {k: v for k, v in _curves(result, names).items() if "stage_rotation" in v}
    if staged:
        from cyclomesh.figures import stage as stage_plots

        jobs.append(
            job(
                "stage_torsion_curve",
                stage_plots.plot_stage_torsion_curve,
                staged,
                caption="Torsion curve of the RV stage (mesh, crank bearings and springs in "
                "one solve) beside the mesh alone: rotation of the output, mean over the "
                "crank angles, against torque in % of rated (docs/stage.md); with "
                "[friction], the loop's mid curve, and its width (rising − falling branch) "
                "on the right axis.",
            )
        )
    loops = {
        k: v
        for k, v in _curves(
            result, ("measured_torque", "measured_twist", "rotation", "stage_rotation")
        ).items()
        if "measured_twist" in v
    }
    if loops:
        from cyclomesh.figures import stage as stage_plots

        jobs.append(
            job(
                "measured_loop",
                stage_plots.plot_measured_loop,
                loops,
                caption="Measured hysteresis loop ([stiffness] measured_file) over the model's "
                "torsion curve (mean over the crank angles); the reconciling series "
                "compliance is reported in the summary, never applied (docs/stage.md).",
            )
        )
    stacks = {k: v for k, v in _curves(result, ("torque_share",)).items() if "torque_share" in v}
    if stacks:
        jobs.append(
            job(
                "torque_share",
                plots.plot_torque_share,
                stacks,
                caption="Split of the rated torque between the discs of a stack over the "
                "revolution.",
            )
        )
    return jobs


def stiffness_sections(result: StiffnessResult) -> list[Section]:
    """Report sections of a stiffness study: study and scope, summary (figures follow)."""
    from cyclomesh.publish.report import Section, table_html

    study = result.study
    intro = f"<p>{html.escape(study.description)}</p>" if study.description else ""
    intro += f"<p><strong>{html.escape(CAVEAT)}</strong></p>"
    intro += f"<p>{html.escape(DEFINITIONS)} Definitions: docs/drive.md.</p>"
    rows = []
    for case, inputs in zip(study.cases, study.inputs, strict=True):
        section = _section(case)
        curve = result.curves[case.name]
        rows.append(
            (
                case.name,
                case.description,
                section.rated_torque_nm,
                inputs.discs,
                curve.sizes["torque"],
                curve.sizes["crank_angle"],
                section.series_stiffness_nm_per_arcmin,
                f"{folder_name(case.name)}/stiffness.nc",
            )
        )
    intro += table_html(
        [
            "case",
            "description",
            "rated torque [N·m]",
            "discs",
            "torques",
            "crank angles",
            "series stiffness [N·m/arcmin]",
            "results",
        ],
        rows,
    )
    intro += (
        f"<details><summary>study file {html.escape(study.path.name)}</summary>"
        f"<pre>{html.escape(study.text)}</pre></details>"
    )
    from cyclomesh.publish.report import metrics_table
    from cyclomesh.results.stage import STAGE_STIFFNESS_METRICS
    from cyclomesh.studies.checks import checks_section

    summary = metrics_table(result.summaries, STIFFNESS_METRICS | STAGE_STIFFNESS_METRICS)
    from cyclomesh.publish.report import warning_sections

    return warning_sections(result.study_warnings()) + [
        Section("Study", intro),
        checks_section(result.checks),
        Section("Summary", summary),
    ]


def _preflight(study: Study) -> None:
    from cyclomesh.studies.preflight import refuse_friction_with_stage

    refuse_friction_with_stage(study)
    check_stiffness(study)


def _show(result: StiffnessResult, out: Path, options: Any) -> None:
    from cyclomesh.publish.console import print_stiffness, print_warnings

    print_warnings(result.study_warnings())
    print_stiffness(result.summaries, out, result.checks)


STIFFNESS = StudyKind(
    command="stiffness",
    title="torsion curve",
    compute=lambda study, **kw: compute_stiffness(study, **kw),
    write=lambda result, out, options: write_stiffness(result, out),
    figures=lambda result, early: stiffness_figures(result),
    sections=lambda result: stiffness_sections(result),
    preflight=_preflight,
    steps=CommandSteps(progress=lambda study, o: (len(study.cases), "cases"), show=_show),
)
"""``cyclomesh stiffness`` (:func:`cyclomesh.studies.execute.execute`)."""
